#!/usr/bin/env bash
# ci/setup.sh: make sure this machine can run vkpath (and, with --test, its tests).
#
#   ci/setup.sh          a Vulkan loader (libvulkan.so.1) and at least one Vulkan driver (an ICD json);
#                        when either is missing, installs Mesa's drivers (lavapipe, the CPU implementation,
#                        is among them) and the loader: apt packages mesa-vulkan-drivers libvulkan1.
#   ci/setup.sh --test   also the Khronos validation layers (vulkan-validationlayers), which the tests enable,
#                        and an X server in memory for the preview window's test (xvfb, with xauth for
#                        xvfb-run) with the X client libraries winit loads at run time (libx11-6,
#                        libxcursor1, libxi6, libxkbcommon-x11-0).
#
# Debian/Ubuntu only. Idempotent: when everything is present it installs nothing and only says so.
# Prints one line saying what it did.
set -euo pipefail

want_validation=0
for arg in "$@"; do
    case "$arg" in
        --test) want_validation=1 ;;
        -h | --help)
            sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'
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
fi

if [ "${#packages[@]}" -eq 0 ]; then
    if [ "$want_validation" = 1 ]; then
        echo "ci/setup.sh: Vulkan loader, driver, validation layers and Xvfb already present; nothing to do"
    else
        echo "ci/setup.sh: Vulkan loader and driver already present; nothing to do"
    fi
    exit 0
fi

# A missing loader or driver: install both, so that the two come from the same release.
if ! have_loader || ! have_icd; then
    for p in libvulkan1 mesa-vulkan-drivers; do
        [[ " ${packages[*]} " == *" $p "* ]] || packages+=("$p")
    done
fi

if ! command -v apt-get >/dev/null 2>&1; then
    echo "ci/setup.sh: missing ${packages[*]} and no apt-get here: install a Vulkan loader and driver" \
        "(e.g. Mesa's lavapipe) with this system's package manager" >&2
    exit 1
fi

sudo=()
if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1; then
        sudo=(sudo)
    else
        echo "ci/setup.sh: need to install ${packages[*]} but not root and no sudo; run as root" >&2
        exit 1
    fi
fi

log=$(mktemp)
trap 'rm -f "$log"' EXIT
if ! { "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update -q &&
    "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
        "${packages[@]}"; } >"$log" 2>&1; then
    cat "$log" >&2
    echo "ci/setup.sh: installing ${packages[*]} failed (apt output above)" >&2
    exit 1
fi

if ! have_loader || ! have_icd ||
    { [ "$want_validation" = 1 ] && ! { have_validation && have_xvfb && have_xauth && have_x11_libs; }; }; then
    echo "ci/setup.sh: installed ${packages[*]} but Vulkan is still incomplete" \
        "(loader: $(have_loader && echo yes || echo no), driver: $(have_icd && echo yes || echo no))" >&2
    exit 1
fi
echo "ci/setup.sh: installed ${packages[*]}"
