#!/usr/bin/env bash
# ci/test.sh: the project's whole check, as CI runs it (and as a developer should before pushing).
#
#   1. ci/setup.sh --test      a Vulkan loader, a driver (Mesa's lavapipe runs on the CPU) and the
#                              Khronos validation layers; installs them with apt-get when missing
#   2. cargo fmt --check       formatting
#      cargo build             the debug binary, which compiles the generic kernel in the background
#                              (Mesa's shader cache then has it for the tests: below)
#   3. cargo clippy            lints, warnings are errors (the Python module's crate too)
#   4. cargo check --no-default-features --bins
#                              the headless binary still builds without the `preview` feature (the window)
#   5. cargo test              unit and integration tests (dev profile); the tests that use the GPU
#                              turn the validation layers on themselves, and any validation error fails them;
#                              tests/preview.rs opens the preview window under Xvfb (xvfb-run)
#   6. ci/python-test.sh     the Python module: `pip install .` in a fresh venv (the wheel built by
#                              maturin), then its pytest suite against the command line, bit for bit
#   7. ci/farm-test.sh         the Slurm render farm: a private one-node cluster (ci/slurm.sh: munged,
#                              slurmctld, slurmd, stopped after), the deploy/slurm recipe with a cancelled
#                              and resubmitted part, the merge checked bit for bit against one render
#   8. ci/k8s-check.sh         the Kubernetes recipe (deploy/k8s) validated against the API's schemas
#                              offline, and its Jobs' commands run locally, checked bit for bit
#
# Exits non-zero at the first failing step.
set -euo pipefail
cd "$(dirname "$0")/.."

step() {
    local name=$1
    shift
    local start=$SECONDS
    echo "==> $name: $*"
    if ! "$@"; then
        echo "==> FAILED: $name ($((SECONDS - start)) s)" >&2
        exit 1
    fi
    echo "==> ok: $name ($((SECONDS - start)) s)"
}

step setup ./ci/setup.sh --test
step fmt cargo fmt --all -- --check

# The generic kernel (every feature, `--generic`) takes minutes to compile on lavapipe with a cold Mesa
# shader cache (docs/testing.md, "What the test suite's time is"), and the first tests that render with
# it compile it on both test threads at once. So it is compiled once, in the background, while the lints
# and the build run (one core of the two, where they leave it idle): the tests then find it in Mesa's
# disk cache. (A warm-up that fails changes nothing: the tests compile the kernel themselves.) The
# validation layers are on, as the tests have them. The render's kernel first, then one per --aov layer
# (the generic kernel fixes what it renders, as a specialised one does: tests/outputs.rs renders the
# three layers with it).
step build cargo build --bin vkpath
warm_dir=$(mktemp -d)
VKPATH_VALIDATION=1 target/debug/vkpath render scenes/course.toml --generic --width 8 --height 8 --spp 1 \
    --aov albedo,normal,depth --output "$warm_dir/warm.exr" >"$warm_dir/log" 2>&1 &
warm_pid=$!
trap 'kill "$warm_pid" 2>/dev/null || true; rm -rf "$warm_dir"' EXIT
warm_start=$SECONDS

step clippy cargo clippy --workspace --all-targets -- -D warnings
step headless cargo check --no-default-features --bins
step test cargo test
if wait "$warm_pid"; then
    echo "==> the generic kernel's warm-up (started $((SECONDS - warm_start)) s ago): $(tail -n 1 "$warm_dir/log")"
else
    echo "==> the generic kernel's warm-up failed (the tests compiled it themselves): $(tail -n 1 "$warm_dir/log")"
fi
step python ./ci/python-test.sh
step farm ./ci/farm-test.sh
step k8s ./ci/k8s-check.sh
echo "==> all checks passed in $SECONDS s"
