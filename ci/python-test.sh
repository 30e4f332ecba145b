#!/usr/bin/env bash
# ci/python-test.sh: the Python module (docs/python.md) as a user installs it, checked against the
# command line.
#
#   1. a fresh venv (python3 with venv: ci/setup.sh --test makes sure of it) with NumPy and
#      pytest from PyPI
#   2. `pip install .`, the README's command: maturin (fetched by pip into an isolated build environment)
#      builds the abi3 wheel from python/Cargo.toml and pip installs it; the build uses Cargo's dev
#      profile here (MATURIN_PEP517_ARGS), which shares the dependencies `cargo build` compiled
#   3. pytest python/tests, run from outside the checkout so that the module imported is the installed
#      wheel, against the debug binary (VKPATH_BIN, default target/debug/vkpath: ci/test.sh built it)
#
# Run from anywhere; the venv is made in a temporary folder and removed after.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"

# Ranges, not pins: the Python of the machine (3.9 and later) picks the release it can run.
NUMPY_SPEC='numpy>=1.21,<3'
PYTEST_SPEC='pytest>=7,<10'

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
made=0
for py in python3 /usr/bin/python3; do
    if command -v "$py" >/dev/null 2>&1 && "$py" -m venv "$work/venv" >"$work/log" 2>&1; then
        made=1
        break
    fi
done
if [ "$made" = 0 ]; then
    cat "$work/log" >&2
    echo "ci/python-test.sh: python3 cannot make a venv; run ci/setup.sh --test (it installs python3-venv)" >&2
    exit 1
fi
pip=("$work/venv/bin/pip" --disable-pip-version-check --quiet)
"${pip[@]}" install "$NUMPY_SPEC" "$PYTEST_SPEC"
start=$SECONDS
MATURIN_PEP517_ARGS=${MATURIN_PEP517_ARGS:---profile dev} "${pip[@]}" install "$root"
echo "ci/python-test.sh: built and installed the wheel in $((SECONDS - start)) s"
cd "$work"
VKPATH_BIN=${VKPATH_BIN:-$root/target/debug/vkpath} "$work/venv/bin/python" -m pytest -q -p no:cacheprovider \
    "$root/python/tests"
