#!/usr/bin/env bash
# benches/peers/setup.sh: prepare this machine for the Mitsuba 3 side-by-side (benches/peers/compare.py).
#
#   benches/peers/setup.sh     creates benches/peers/.venv (git-ignored) with the pinned mitsuba, numpy,
#                              an EXR reader and vkpath's Python module (built from this checkout);
#                              installs Debian's libllvm19 when missing (Dr.Jit's LLVM back end crashes
#                              with the LLVM 15 that Mesa pulls in, so compare.py points DRJIT_LIBLLVM_PATH
#                              at LLVM 19 instead).
#
# Debian/Ubuntu only. Idempotent: what is already there is left alone; prints one line per step saying
# what it did. Run from anywhere.
set -euo pipefail

# The current release on PyPI (2026-12): comparisons are against each peer's current release. 3.9 renders
# the course's sphere-light box about twice as fast as the 3.6.4 pinned before on this machine.
MITSUBA_VERSION=3.9.1
NUMPY_SPEC='numpy>=1.24,<3'
# Reads and writes the EXR files vkpath writes; a self-contained wheel (no system OpenEXR needed).
OPENEXR_SPEC='OpenEXR>=3.3,<4'

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
venv="$here/.venv"

case "${1:-}" in
    -h | --help)
        sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'
        exit 0
        ;;
    "") ;;
    *)
        echo "setup.sh: unknown argument '$1'" >&2
        exit 2
        ;;
esac

if ! python3 -c 'import sys, tomllib, venv' 2>/dev/null; then
    echo "setup.sh: need python3 >= 3.11 with the venv module (compare.py reads scenes with tomllib)" >&2
    exit 1
fi

# --- libllvm19 -------------------------------------------------------------------------------------
# The same places compare.py looks (Debian's libllvm19 installs /usr/lib/<triplet>/libLLVM.so.19.1).
find_llvm19() {
    local f
    for f in /usr/lib/*/libLLVM.so.19* /usr/lib/*/libLLVM-19.so* /usr/lib/llvm-19/lib/libLLVM*.so*; do
        if [ -e "$f" ]; then
            echo "$f"
            return 0
        fi
    done
    return 1
}

if llvm=$(find_llvm19); then
    echo "setup.sh: libllvm19 already present ($llvm)"
else
    if ! command -v apt-get >/dev/null 2>&1; then
        echo "setup.sh: libllvm19 missing and no apt-get here: install LLVM 19's shared library by hand" >&2
        exit 1
    fi
    sudo=()
    if [ "$(id -u)" -ne 0 ]; then
        if command -v sudo >/dev/null 2>&1; then
            sudo=(sudo)
        else
            echo "setup.sh: need to install libllvm19 but not root and no sudo; run as root" >&2
            exit 1
        fi
    fi
    log=$(mktemp)
    trap 'rm -f "$log"' EXIT
    if ! { "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -q &&
        "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
            libllvm19; } >"$log" 2>&1; then
        cat "$log" >&2
        echo "setup.sh: installing libllvm19 failed (apt output above)" >&2
        exit 1
    fi
    llvm=$(find_llvm19) || {
        echo "setup.sh: installed libllvm19 but found no libLLVM 19 shared library" >&2
        exit 1
    }
    echo "setup.sh: installed libllvm19 ($llvm)"
fi

# --- the virtual environment ---------------------------------------------------------------------
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
    echo "setup.sh: created $venv"
else
    echo "setup.sh: venv $venv already present"
fi

want_ok() {
    "$venv/bin/python" - "$MITSUBA_VERSION" <<'PY'
import sys
from importlib.metadata import version, PackageNotFoundError
try:
    ok = version("mitsuba") == sys.argv[1]
    version("numpy"); version("OpenEXR")
except PackageNotFoundError:
    ok = False
sys.exit(0 if ok else 1)
PY
}

if want_ok; then
    echo "setup.sh: mitsuba==$MITSUBA_VERSION, numpy, OpenEXR already installed in the venv"
else
    "$venv/bin/python" -m pip install -q --disable-pip-version-check \
        "mitsuba==$MITSUBA_VERSION" "$NUMPY_SPEC" "$OPENEXR_SPEC"
    echo "setup.sh: pip installed mitsuba==$MITSUBA_VERSION, numpy, OpenEXR into the venv"
fi

# --- vkpath's Python module, from this checkout (compare.py renders through it) --------------------
# Built in release (maturin, a few minutes the first time); run setup.sh again after changing the code.
root=$(cd "$here/../.." && pwd)
"$venv/bin/python" -m pip install -q --disable-pip-version-check "$root"
echo "setup.sh: pip installed vkpath's Python module from $root into the venv"

# --- smoke test: the LLVM variant loads with LLVM 19 -------------------------------------------
if DRJIT_LIBLLVM_PATH="$llvm" "$venv/bin/python" -c \
    "import mitsuba as mi; mi.set_variant('llvm_ad_rgb'); print(mi.__version__)" >/dev/null 2>&1; then
    echo "setup.sh: mitsuba llvm_ad_rgb loads with DRJIT_LIBLLVM_PATH=$llvm"
else
    echo "setup.sh: mitsuba's llvm_ad_rgb variant failed to load with DRJIT_LIBLLVM_PATH=$llvm:" >&2
    DRJIT_LIBLLVM_PATH="$llvm" "$venv/bin/python" -c \
        "import mitsuba as mi; mi.set_variant('llvm_ad_rgb')" >&2 || true
    exit 1
fi
