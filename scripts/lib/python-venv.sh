# Sourced by the scripts that make a Python virtual environment (colour-setup.sh,
# python-test.sh): make sure python3 and its venv module are there, installing Debian's
# python3-venv with apt-get when it is missing and we are root. `die` and the message prefix
# come from the sourcing script.

# need_python_venv PREFIX: python3 with a working venv module, or exit through `die`.
need_python_venv() {
    local prefix=$1
    command -v python3 >/dev/null || die "python3 is not installed"
    if ! python3 -c 'import venv, ensurepip' 2>/dev/null; then
        [ "$(id -u)" -eq 0 ] || die "python3's venv module is missing (Debian: apt-get install python3-venv)"
        echo "$prefix: installing python3-venv"
        apt-get update -qq >/dev/null && apt-get install -y -qq python3-venv >/dev/null \
            || die "apt-get install python3-venv failed"
    fi
}
