#!/usr/bin/env bash
# Install a headless-capable browser for the report test (tests/report_browser.rs) on Debian or
# Ubuntu: Debian's `chromium` package, unless a browser is already there. Idempotent: a second
# run installs nothing. Prints the browser's path on its last line.
#
#   scripts/browser-setup.sh
#
# Needs root, or sudo (it re-runs itself with sudo), and apt-get. Environment:
#   STOKES_BROWSER   a browser to use instead; when it names an executable, nothing is installed
#
# The test looks for STOKES_BROWSER, then `chromium`, `chromium-browser` and `google-chrome` on
# the PATH; without one it skips, unless STOKES_REQUIRE_BROWSER=1 (CI sets it).
set -euo pipefail

die() {
    printf 'browser-setup: error: %s\n' "$*" >&2
    exit 1
}

find_browser() {
    if [ -n "${STOKES_BROWSER:-}" ]; then
        command -v "$STOKES_BROWSER" && return 0
        die "STOKES_BROWSER='$STOKES_BROWSER' is not an executable"
    fi
    local b
    for b in chromium chromium-browser google-chrome; do
        command -v "$b" && return 0
    done
    return 1
}

if path=$(find_browser); then
    echo "browser-setup: a browser is installed"
    echo "$path"
    exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || die "installing chromium needs root or sudo"
    echo "browser-setup: not root: running 'sudo $0'"
    exec sudo --preserve-env=STOKES_BROWSER "$0" "$@"
fi

command -v apt-get >/dev/null || die "apt-get not found: install chromium with this system's package manager"
echo "browser-setup: installing chromium with apt-get"
apt-get update -q
DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends chromium

path=$(find_browser) || die "chromium was installed but is not on the PATH"
"$path" --version || die "'$path --version' failed"
echo "$path"
