#!/usr/bin/env bash
# ci/setup.sh: make sure this machine can run vkpath (and, with --test, its tests).
#
#   ci/setup.sh          a Vulkan loader (libvulkan.so.1) and at least one Vulkan driver (an ICD json);
#                        when either is missing, installs Mesa's drivers (lavapipe, the CPU implementation,
#                        is among them) and the loader: apt packages mesa-vulkan-drivers libvulkan1.
#   ci/setup.sh --test   also the Khronos validation layers (vulkan-validationlayers), which the tests enable,
#                        and an X server in memory for the preview window's test (xvfb, with xauth for
#                        xvfb-run) with the X client libraries winit loads at run time (libx11-6,
#                        libxcursor1, libxi6, libxkbcommon-x11-0); for the render-farm tests, Slurm and
#                        munge (slurmctld, slurmd, slurm-client, munge; no service is started: ci/slurm.sh
#                        starts a private cluster and stops it) and a Python venv in target/ci-venv with
#                        kubernetes-validate (the Kubernetes JSON schemas, offline) for ci/k8s-check.sh.
#
# Debian/Ubuntu only. Idempotent: when everything is present it installs nothing and only says so.
# Prints one line saying what it did.
set -euo pipefail

want_validation=0
for arg in "$@"; do
    case "$arg" in
        --test) want_validation=1 ;;
        -h | --help)
            sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//'
            exit 0
            ;;
        *)
            echo "ci/setup.sh: unknown argument '$arg' (use --test or nothing)" >&2
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

packages=()
have_loader || packages+=(libvulkan1)
have_icd || packages+=(mesa-vulkan-drivers)
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

finish() {
    local did=$1
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
apt_install() {
    local log policy=/usr/sbin/policy-rc.d made_policy=0
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
    if ! { "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -q &&
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
}

if [ "${#packages[@]}" -eq 0 ]; then
    if [ "$want_validation" = 1 ]; then
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

if ! have_loader || ! have_icd ||
    { [ "$want_validation" = 1 ] && ! { have_validation && have_xvfb && have_xauth && have_x11_libs && have_farm; }; }; then
    echo "ci/setup.sh: installed ${packages[*]} but Vulkan is still incomplete" \
        "(loader: $(have_loader && echo yes || echo no), driver: $(have_icd && echo yes || echo no))" >&2
    exit 1
fi
finish "installed ${packages[*]}"
