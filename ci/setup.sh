#!/usr/bin/env bash
# ci/setup.sh: make sure this machine can run vkpath (and, with --test, its tests).
#
#   ci/setup.sh          a Vulkan loader (libvulkan.so.1) and at least one Vulkan driver (an ICD json);
#                        when either is missing, installs Mesa's drivers (lavapipe, the CPU implementation,
#                        is among them) and the loader: apt packages mesa-vulkan-drivers libvulkan1.
#                        And a current lavapipe: Mesa 24 or newer runs vkpath's kernel 1.4-3x faster than
#                        Mesa 22 (same image, bit for bit). On Debian 12, whose Mesa is 22.3, it installs
#                        mesa-vulkan-drivers from bookworm-backports (Mesa 25), adding that suite to apt's
#                        sources when missing; elsewhere (Ubuntu 24.04, Debian 13: Mesa 24, 25) the stock
#                        package is current. --keep-mesa leaves an installed Mesa as it is.
#   ci/setup.sh --test   also the Khronos validation layers (vulkan-validationlayers), which the tests enable,
#                        and an X server in memory for the preview window's test (xvfb, with xauth for
#                        xvfb-run) with the X client libraries winit loads at run time (libx11-6,
#                        libxcursor1, libxi6, libxkbcommon-x11-0); for the render-farm tests, Slurm and
#                        munge (slurmctld, slurmd, slurm-client, munge; no service is started: ci/slurm.sh
#                        starts a private cluster and stops it) and a Python venv in target/ci-venv with
#                        kubernetes-validate (the Kubernetes JSON schemas, offline) for ci/k8s-check.sh
#                        (python3's venv module, python3-venv on Debian, then also makes the Python
#                        module's venv in ci/python-test.sh); and the denoiser, as --denoise does.
#   ci/setup.sh --denoise
#                        also Intel Open Image Denoise (OIDN 2.5.1, Apache-2.0), which `vkpath render --denoise`
#                        loads at run time: Debian and Ubuntu do not package it, so its official Linux build
#                        is taken from the Python package index (the pyoidn 2.5.1.0 wheel, which carries
#                        libOpenImageDenoise.so.2 with its CPU, CUDA, HIP and SYCL devices), checked against
#                        the SHA-256 pinned here, and its lib/ copied to $VKPATH_OIDN_DIR/lib (default
#                        /usr/local/lib/vkpath-oidn), where vkpath looks (docs/denoising.md).
#                        Needs python3 (with venv, installed by apt when missing) to fetch the wheel.
#
# Debian/Ubuntu only. Idempotent: when everything is present it installs nothing and only says so.
# Prints one line saying what it did.
set -euo pipefail

want_validation=0
want_denoise=0
keep_mesa=0
for arg in "$@"; do
    case "$arg" in
        --test) want_validation=1 want_denoise=1 ;;
        --denoise) want_denoise=1 ;;
        --keep-mesa) keep_mesa=1 ;;
        -h | --help)
            sed -n '2,30p' "$0" | sed 's/^# \{0,1\}//'
            exit 0
            ;;
        *)
            echo "ci/setup.sh: unknown argument '$arg' (use --test, --denoise, --keep-mesa or nothing)" >&2
            exit 2
            ;;
    esac
done

have_loader() {
    # Not `grep -q`: under pipefail, grep quitting early could fail the pipeline with SIGPIPE.
    ldconfig -p 2>/dev/null | grep 'libvulkan\.so\.1\b' >/dev/null
}

have_icd() {
    local dir
    for dir in /usr/share/vulkan/icd.d /etc/vulkan/icd.d; do
        if compgen -G "$dir/*.json" >/dev/null; then
            return 0
        fi
    done
    return 1
}

have_validation() {
    [ -e /usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json ]
}

have_xvfb() {
    command -v Xvfb >/dev/null 2>&1 && command -v xvfb-run >/dev/null 2>&1
}

have_xauth() {
    command -v xauth >/dev/null 2>&1
}

# winit opens these with dlopen, so a missing one only shows when the window opens.
x11_libs=(libX11.so.6:libx11-6 libXcursor.so.1:libxcursor1 libXi.so.6:libxi6
    libxkbcommon-x11.so.0:libxkbcommon-x11-0)

# The render-farm test's Slurm (ci/slurm.sh, ci/farm-test.sh): the daemons, the client and munge.
farm_commands=(slurmctld:slurmctld slurmd:slurmd sbatch:slurm-client munged:munge mungekey:munge)

have_farm() {
    local entry
    for entry in "${farm_commands[@]}"; do
        command -v "${entry%%:*}" >/dev/null 2>&1 || return 1
    done
}

# The Kubernetes check's validator (ci/k8s-check.sh), pinned: its schemas are part of the package.
venv=${VKPATH_CI_VENV:-$(cd "$(dirname "$0")/.." && pwd)/target/ci-venv}
k8s_validate=kubernetes-validate==1.37.0

have_k8s_venv() {
    [ -x "$venv/bin/kubernetes-validate" ] && [ -x "$venv/bin/python" ]
}

have_lib() {
    ldconfig -p 2>/dev/null | grep "${1//./\\.}\\b" >/dev/null
}

have_x11_libs() {
    local entry
    for entry in "${x11_libs[@]}"; do
        have_lib "${entry%%:*}" || return 1
    done
}

# Mesa's lavapipe: its major version as dpkg knows it (0 when not installed by dpkg), and whether this is
# Debian 12, whose stock Mesa 22.3 is older than the 24 vkpath wants and whose backports have Mesa 25.
mesa_major() {
    local v
    v=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null) || v=0
    v=${v#*:}
    v=${v%%.*}
    [[ "$v" =~ ^[0-9]+$ ]] || v=0
    echo "$v"
}

on_bookworm() {
    [ -r /etc/os-release ] && (. /etc/os-release && [ "${ID:-}" = debian ] && [ "${VERSION_CODENAME:-}" = bookworm ])
}

want_backports=0
if [ "$keep_mesa" = 0 ] && command -v dpkg-query >/dev/null 2>&1 && on_bookworm && [ "$(mesa_major)" -lt 24 ]; then
    want_backports=1
fi

packages=()
have_loader || packages+=(libvulkan1)
have_icd || [ "$want_backports" = 1 ] || packages+=(mesa-vulkan-drivers)
if [ "$want_validation" = 1 ] && ! have_validation; then
    packages+=(vulkan-validationlayers)
fi
if [ "$want_validation" = 1 ] && ! have_xvfb; then
    packages+=(xvfb)
fi
if [ "$want_validation" = 1 ] && ! have_xauth; then
    packages+=(xauth)
fi
if [ "$want_validation" = 1 ]; then
    for entry in "${x11_libs[@]}"; do
        have_lib "${entry%%:*}" || packages+=("${entry#*:}")
    done
    if ! have_farm; then
        for entry in "${farm_commands[@]}"; do
            [[ " ${packages[*]} " == *" ${entry#*:} "* ]] || packages+=("${entry#*:}")
        done
    fi
fi

# The venv for the Kubernetes check, made with this machine's python3 (or Debian's, with python3-venv,
# when that one cannot make venvs); pip fetches the pinned validator from PyPI.
make_k8s_venv() {
    local quiet=$1 py log
    log=$(mktemp)
    for py in python3 /usr/bin/python3; do
        if command -v "$py" >/dev/null 2>&1 && "$py" -m venv --clear "$venv" >"$log" 2>&1; then
            if "$venv/bin/pip" install --quiet --disable-pip-version-check "$k8s_validate" >"$log" 2>&1; then
                rm -f "$log"
                return 0
            fi
            break
        fi
    done
    [ "$quiet" = 1 ] || cat "$log" >&2
    rm -f "$log"
    [ "$quiet" = 1 ] || echo "ci/setup.sh: could not make the venv $venv with $k8s_validate (output above)" >&2
    return 1
}

# Intel Open Image Denoise's official Linux build, from the pyoidn wheel on PyPI (pinned by hash: pip
# refuses any other bytes), its lib/ unpacked into $oidn_dir.
oidn_dir=${VKPATH_OIDN_DIR:-/usr/local/lib/vkpath-oidn}
oidn_wheel="pyoidn==2.5.1.0 --hash=sha256:32ad13368f8de1ef63001942ad05b02a00cd732d1206d97f352d3a3f606d823e"

have_oidn() {
    [ -e "$oidn_dir/lib/libOpenImageDenoise.so.2" ] && [ -e "$oidn_dir/lib/libOpenImageDenoise_device_cpu.so.2.5.1" ]
}

install_oidn() {
    local tmp py log
    tmp=$(mktemp -d)
    log="$tmp/log"
    for py in python3 /usr/bin/python3; do
        command -v "$py" >/dev/null 2>&1 && "$py" -m venv "$tmp/venv" >"$log" 2>&1 && break
    done
    if [ ! -x "$tmp/venv/bin/pip" ]; then
        apt_install python3-venv
        /usr/bin/python3 -m venv "$tmp/venv" >"$log" 2>&1 || { cat "$log" >&2; rm -rf "$tmp"; exit 1; }
    fi
    echo "$oidn_wheel" >"$tmp/requirements.txt"
    if ! "$tmp/venv/bin/pip" download --quiet --disable-pip-version-check --no-deps --only-binary=:all: \
        --platform manylinux2014_x86_64 --require-hashes -r "$tmp/requirements.txt" -d "$tmp/wheel" \
        >"$log" 2>&1; then
        cat "$log" >&2
        rm -rf "$tmp"
        echo "ci/setup.sh: could not fetch Open Image Denoise ($oidn_wheel) from PyPI (pip's output above)" >&2
        exit 1
    fi
    # A wheel is a zip file: unpacked with Python's zipfile (no unzip tool needed).
    "$tmp/venv/bin/python" -c 'import sys, zipfile; zipfile.ZipFile(sys.argv[1]).extractall(sys.argv[2])' \
        "$tmp"/wheel/pyoidn-*.whl "$tmp/x"
    # lib/ as in OIDN's own archives: its libraries find each other through their RPATH, $ORIGIN/../lib.
    "${sudo[@]}" mkdir -p "$oidn_dir/lib"
    "${sudo[@]}" cp -a "$tmp"/x/pyoidn/oidn/lib/. "$oidn_dir/lib/"
    "${sudo[@]}" rm -rf "$oidn_dir/lib/cmake"
    "${sudo[@]}" cp "$tmp"/x/pyoidn-*.dist-info/licenses/LICENSE "$oidn_dir/LICENSE.pyoidn" 2>/dev/null || true
    echo "Intel Open Image Denoise 2.5.1 (Apache-2.0), from the PyPI wheel $oidn_wheel" |
        "${sudo[@]}" tee "$oidn_dir/SOURCE" >/dev/null
    rm -rf "$tmp"
    have_oidn || { echo "ci/setup.sh: installed Open Image Denoise but $oidn_dir lacks its libraries" >&2; exit 1; }
}

finish() {
    local did=$1
    if [ "$want_denoise" = 1 ] && ! have_oidn; then
        install_oidn
        did="$did; installed Open Image Denoise 2.5.1 in $oidn_dir"
    fi
    if [ "$want_validation" = 1 ] && ! have_k8s_venv; then
        # Debian's own python3 makes venvs only with python3-venv installed.
        if ! make_k8s_venv 1; then
            apt_install python3-venv
            make_k8s_venv 0 || exit 1
        fi
        did="$did; made the venv $venv ($k8s_validate)"
    fi
    echo "ci/setup.sh: $did"
    exit 0
}

sudo=()
if [ "$(id -u)" -ne 0 ] && command -v sudo >/dev/null 2>&1; then
    sudo=(sudo)
fi

# apt-get install of "$@", with no service started by the packages' scripts (munge's would start a
# system munged that nothing stops): a policy-rc.d that refuses every start, for the install only, when
# the system has none of its own.
apt_updated=0
apt_install() {
    local log policy=/usr/sbin/policy-rc.d made_policy=0 update=(true)
    if ! command -v apt-get >/dev/null 2>&1; then
        echo "ci/setup.sh: missing $* and no apt-get here: install them (a Vulkan loader and driver" \
            "such as Mesa's lavapipe, and for the tests the packages above) with this system's package" \
            "manager" >&2
        exit 1
    fi
    if [ "$(id -u)" -ne 0 ] && [ "${#sudo[@]}" -eq 0 ]; then
        echo "ci/setup.sh: need to install $* but not root and no sudo; run as root" >&2
        exit 1
    fi
    if [ ! -e "$policy" ]; then
        printf '#!/bin/sh\nexit 101\n' | "${sudo[@]}" tee "$policy" >/dev/null
        "${sudo[@]}" chmod 0755 "$policy"
        made_policy=1
    fi
    log=$(mktemp)
    [ "$apt_updated" = 1 ] || update=("${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -q)
    if ! { "${update[@]}" &&
        "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
            "$@"; } >"$log" 2>&1; then
        [ "$made_policy" = 0 ] || "${sudo[@]}" rm -f "$policy"
        cat "$log" >&2
        rm -f "$log"
        echo "ci/setup.sh: installing $* failed (apt output above)" >&2
        exit 1
    fi
    [ "$made_policy" = 0 ] || "${sudo[@]}" rm -f "$policy"
    rm -f "$log"
    apt_updated=1
}

# Debian 12: Mesa 25's mesa-vulkan-drivers from bookworm-backports (with the libdrm it needs; nothing else
# is taken from backports), adding the suite to apt's sources when no source names it.
install_backports_mesa() {
    local list=/etc/apt/sources.list.d/vkpath-bookworm-backports.list
    if ! grep -rqs 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
        echo "deb http://deb.debian.org/debian bookworm-backports main" | "${sudo[@]}" tee "$list" >/dev/null
        apt_updated=0
    fi
    apt_install -t bookworm-backports mesa-vulkan-drivers
    if [ "$(mesa_major)" -lt 24 ]; then
        echo "ci/setup.sh: installed mesa-vulkan-drivers from bookworm-backports but Mesa is still" \
            "$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || echo missing)" >&2
        exit 1
    fi
}

check_complete() {
    if ! have_loader || ! have_icd ||
        { [ "$want_validation" = 1 ] && ! { have_validation && have_xvfb && have_xauth && have_x11_libs && have_farm; }; }; then
        echo "ci/setup.sh: installed $1 but Vulkan is still incomplete" \
            "(loader: $(have_loader && echo yes || echo no), driver: $(have_icd && echo yes || echo no))" >&2
        exit 1
    fi
}

mesa_note=""
if [ "$want_backports" = 1 ]; then
    [ "${#packages[@]}" -eq 0 ] || apt_install "${packages[@]}"
    install_backports_mesa
    mesa_note="Mesa $(dpkg-query -W -f='${Version}' mesa-vulkan-drivers) from bookworm-backports"
    [ "${#packages[@]}" -eq 0 ] || mesa_note="${packages[*]}; $mesa_note"
    packages=()
fi

if [ "${#packages[@]}" -eq 0 ]; then
    if [ -n "$mesa_note" ]; then
        check_complete "$mesa_note"
        finish "installed $mesa_note"
    elif [ "$want_validation" = 1 ]; then
        finish "Vulkan loader, driver, validation layers, Xvfb and Slurm already present; nothing to install"
    else
        finish "Vulkan loader and driver already present; nothing to do"
    fi
fi

# A missing loader or driver: install both, so that the two come from the same release.
if ! have_loader || ! have_icd; then
    for p in libvulkan1 mesa-vulkan-drivers; do
        [[ " ${packages[*]} " == *" $p "* ]] || packages+=("$p")
    done
fi

apt_install "${packages[@]}"
check_complete "${packages[*]}"
finish "installed ${packages[*]}"
