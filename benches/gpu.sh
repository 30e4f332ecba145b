#!/usr/bin/env bash
# benches/gpu.sh: issue 27's GPU benchmark as one short run, for a machine with a GPU (whose time is
# usually lent by the minute): the device and driver, the course scene at 1920x1080 (the goal is 1
# Gsample/s), every scene in scenes/ at 512x512, the mesh benchmark from 10^3 to 10^7 triangles, and
# Bitterli's three mesh scenes at 512x512 when ../shared/real-scenes is there. Each step is timed by
# vkpath itself (wall-clock samples/s of the median pass) and written to OUT as it finishes, so a run
# cut short still leaves the steps it finished.
#
#   benches/gpu.sh [VKPATH [OUT]]    VKPATH: the binary (default target/release/vkpath, built here
#                                    with `cargo build --release`); OUT: the results folder (default
#                                    benches/gpu-results, created)
#   VKPATH_GPU_BENCH_QUICK=1 benches/gpu.sh ...   the same steps at a few pixels (a check of the
#                                                 script on any machine, lavapipe included)
#
# The GPU is chosen as for a render (VKPATH_DEVICE picks another); the first lines of OUT/info.txt say
# which. Nothing here asserts a time: the figures go into docs/performance.md with the date, driver and
# command.
set -euo pipefail

vkpath=${1:-target/release/vkpath}
out=${2:-benches/gpu-results}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
real="$here/../shared/real-scenes"
mkdir -p "$out"

if [ "${VKPATH_GPU_BENCH_QUICK:-0}" = 1 ]; then
    hd=(--width 64 --height 36) sq=(--width 32 --height 32) spp=2 runs=1 sizes=(1000 10000)
else
    hd=(--width 1920 --height 1080) sq=(--width 512 --height 512) spp=64 runs=3
    sizes=(1000 100000 1000000 10000000)
fi

step() {
    local name=$1
    shift
    echo "benches/gpu.sh: $name: $*" >&2
    local start=$SECONDS
    "$@" > "$out/$name" 2> "$out/$name.stderr"
    echo "benches/gpu.sh: $name done in $((SECONDS - start)) s" >&2
}

step info.txt "$vkpath" info
date -u +"%Y-%m-%d %H:%M UTC" > "$out/date.txt"
git -C "$here" rev-parse --short HEAD > "$out/commit.txt" 2> /dev/null || true
step course-1080p.json "$vkpath" bench throughput "$here/scenes/course.toml" "${hd[@]}" \
    --spp "$spp" --runs "$runs" --json
step scenes-512.json "$vkpath" bench throughput "$here"/scenes/*.toml "${sq[@]}" --spp "$spp" \
    --runs "$runs" --json
step mesh.md "$vkpath" bench mesh "${sizes[@]}" "${sq[@]}" --spp "$spp" --runs "$runs" \
    --brute-force-up-to 0
if [ -d "$real" ]; then
    # Bitterli's exports as given, the integrator named (their files default to one vkpath does not
    # read); converted once, so that the timed passes read TOML.
    scenes=()
    for s in cornell-box veach-mis veach-bidir; do
        "$vkpath" convert "$real/bitterli-$s/scene.xml" -o "$out/bitterli-$s.toml" --xml-lenient \
            -D integrator=path 2> /dev/null && scenes+=("$out/bitterli-$s.toml")
    done
    step real-scenes-512.json "$vkpath" bench throughput "${scenes[@]}" "${sq[@]}" --spp "$spp" \
        --runs "$runs" --json
fi
echo "benches/gpu.sh: results in $out" >&2
