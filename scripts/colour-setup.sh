#!/usr/bin/env bash
# Make the Python environment of the spectral-EXR test (tests/spectral.rs): a virtual
# environment in target/colour-venv with colour-science (whose read_spectral_image_Fichet2021
# reads the spectral images of `stokes render --spectral`), the OpenImageIO it reads them with,
# and NumPy. Idempotent: a second run installs nothing. Prints the Python's path on its last line.
#
#   scripts/colour-setup.sh
#
# Needs python3 with the venv module (Debian: python3-venv; installed with apt-get when missing
# and run as root) and network access to PyPI. The test looks for STOKES_COLOUR_PYTHON, then
# target/colour-venv/bin/python; without one it skips, unless STOKES_REQUIRE_COLOUR=1 (CI).
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/colour-venv
py=$venv/bin/python

die() {
    printf 'colour-setup: error: %s\n' "$*" >&2
    exit 1
}

check() {
    "$py" -c 'import warnings; warnings.simplefilter("ignore"); import colour, OpenImageIO, numpy' \
        2>/dev/null
}

if [ -x "$py" ] && check; then
    echo "colour-setup: the environment is there"
    echo "$(pwd)/$py"
    exit 0
fi

# shellcheck source=lib/python-venv.sh
. scripts/lib/python-venv.sh
need_python_venv colour-setup
rm -rf "$venv"
mkdir -p target
python3 -m venv "$venv" || die "cannot make the virtual environment $venv"
"$venv/bin/pip" install -q colour-science==0.4.6 OpenImageIO numpy \
    || die "pip install of colour-science, OpenImageIO and numpy failed"
check || die "the environment was made but colour, OpenImageIO or numpy does not import"
echo "colour-setup: made $venv"
echo "$(pwd)/$py"
