#!/usr/bin/env bash
# The Python package's tests, as a new user runs them: a fresh virtual environment
# (target/python-venv, made again on every run), `pip install ./python pytest matplotlib`
# (maturin builds the extension from the workspace with cargo; matplotlib for the test that runs
# the examples), then pytest on python/tests. The tests compare
# Python renders with the CLI's, so the CLI is built first (`cargo build --release`; nothing to
# do after `cargo test --release`). Prints the time of each step.
#
#   scripts/python-test.sh [PYTEST ARGS...]
#
# Needs python3 (3.9 or later) with the venv module (Debian: python3-venv; installed with
# apt-get when missing and run as root) and network access to PyPI.
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/python-venv

die() {
    printf 'python-test: error: %s\n' "$*" >&2
    exit 1
}

# shellcheck source=lib/python-venv.sh
. scripts/lib/python-venv.sh
need_python_venv python-test

step() {
    local what=$1
    shift
    local t0=$SECONDS
    "$@"
    echo "python-test: $what: $((SECONDS - t0)) s"
}

step "cargo build --release (the CLI the tests compare with)" cargo build --release --quiet
rm -rf "$venv"
step "fresh virtual environment" python3 -m venv "$venv"
# matplotlib for the test that runs the examples (only the examples use it)
step "pip install ./python pytest matplotlib" "$venv/bin/pip" install --quiet --disable-pip-version-check ./python pytest matplotlib
STOKES_REQUIRE_MATPLOTLIB=1 step "pytest python/tests" "$venv/bin/pytest" -q python/tests "$@"
