#!/usr/bin/env bash
# benches/peers/setup_cycles.sh: prepare this machine for the glTF side-by-side with Blender's Cycles
# (benches/peers/gltf_check.py).
#
#   benches/peers/setup_cycles.sh   creates benches/peers/.venv-cycles (git-ignored) with the pinned bpy
#                                   (Blender as a Python module: Cycles and the glTF importer), numpy and
#                                   an EXR reader; installs the X11/GL client libraries bpy's shared
#                                   libraries link against when they are missing (Debian's libgl1,
#                                   libxrender1, libxi6, libxkbcommon0, libsm6, ...). No display is needed.
#
# Debian/Ubuntu only. Idempotent: what is already there is left alone; prints one line per step saying
# what it did. Run from anywhere.
set -euo pipefail

# The current release on PyPI (2026-12): bpy 5.0.1 = Blender 5.0.1, wheels for CPython 3.11 only
# (cp311, manylinux_2_28 x86_64: Debian 12's Python 3.11 and glibc 2.36 take it). Comparisons are against
# each peer's current release; Blender 5.0's glTF importer (io_import_scene_gltf2) ships inside the wheel.
BPY_VERSION=5.0.1
NUMPY_SPEC='numpy>=1.24,<3'
# Reads the EXR files vkpath writes; the same self-contained wheel as setup.sh (no system OpenEXR needed).
OPENEXR_SPEC='OpenEXR>=3.3,<4'
# The system libraries bpy 5.0.1's shared objects link against (the NEEDED entries of bpy/__init__.so and
# bpy/lib/*.so that the wheel does not bundle, `objdump -p`, mapped to Debian 12 packages with dpkg -S;
# each one missing is an ImportError naming its .so). Their own dependencies come with them.
APT_PACKAGES=(libgl1 libx11-6 libxext6 libxfixes3 libxi6 libxrender1 libxt6 libxkbcommon0 libsm6 libice6)

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
venv="$here/.venv-cycles"

case "${1:-}" in
    -h | --help)
        sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'
        exit 0
        ;;
    "") ;;
    *)
        echo "setup_cycles.sh: unknown argument '$1'" >&2
        exit 2
        ;;
esac

if ! python3 -c 'import sys, tomllib, venv; sys.exit(0 if sys.version_info[:2] == (3, 11) else 1)' 2>/dev/null; then
    echo "setup_cycles.sh: need python3 3.11 with the venv module (bpy $BPY_VERSION has wheels for CPython 3.11 only)" >&2
    exit 1
fi

# --- system libraries ------------------------------------------------------------------------------
missing=()
for p in "${APT_PACKAGES[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
        missing+=("$p")
    fi
done
if [ ${#missing[@]} -eq 0 ]; then
    echo "setup_cycles.sh: system libraries already present (${APT_PACKAGES[*]})"
else
    if ! command -v apt-get >/dev/null 2>&1; then
        echo "setup_cycles.sh: missing ${missing[*]} and no apt-get here: install them by hand" >&2
        exit 1
    fi
    sudo=()
    if [ "$(id -u)" -ne 0 ]; then
        if command -v sudo >/dev/null 2>&1; then
            sudo=(sudo)
        else
            echo "setup_cycles.sh: need to install ${missing[*]} but not root and no sudo; run as root" >&2
            exit 1
        fi
    fi
    log=$(mktemp)
    trap 'rm -f "$log"' EXIT
    if ! { "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -q &&
        "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
            "${missing[@]}"; } >"$log" 2>&1; then
        cat "$log" >&2
        echo "setup_cycles.sh: installing ${missing[*]} failed (apt output above)" >&2
        exit 1
    fi
    echo "setup_cycles.sh: installed ${missing[*]}"
fi

# --- the virtual environment ---------------------------------------------------------------------
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
    echo "setup_cycles.sh: created $venv"
else
    echo "setup_cycles.sh: venv $venv already present"
fi

want_ok() {
    "$venv/bin/python" - "$BPY_VERSION" <<'PY'
import sys
from importlib.metadata import version, PackageNotFoundError
try:
    ok = version("bpy") == sys.argv[1]
    version("numpy"); version("OpenEXR")
except PackageNotFoundError:
    ok = False
sys.exit(0 if ok else 1)
PY
}

if want_ok; then
    echo "setup_cycles.sh: bpy==$BPY_VERSION, numpy, OpenEXR already installed in the venv"
else
    # bpy's wheel is ~375 MB (about 1.2 GB unpacked).
    "$venv/bin/python" -m pip install -q --disable-pip-version-check \
        "bpy==$BPY_VERSION" "$NUMPY_SPEC" "$OPENEXR_SPEC"
    echo "setup_cycles.sh: pip installed bpy==$BPY_VERSION, numpy, OpenEXR into the venv"
fi

# --- smoke test: bpy imports, Cycles and the glTF importer are there --------------------------------
smoke='import bpy, addon_utils
addon_utils.enable("io_scene_gltf2", default_set=True)
assert hasattr(bpy.ops.import_scene, "gltf"), "no glTF importer"
bpy.context.scene.render.engine = "CYCLES"
print(bpy.app.version_string)'
if v=$("$venv/bin/python" -c "$smoke" 2>/dev/null | tail -n 1); then
    echo "setup_cycles.sh: bpy imports (Blender $v), Cycles and the glTF importer load"
else
    echo "setup_cycles.sh: bpy failed to import or lacks Cycles / the glTF importer:" >&2
    "$venv/bin/python" -c "$smoke" >&2 || true
    exit 1
fi
