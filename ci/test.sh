#!/usr/bin/env bash
# ci/test.sh: the project's whole check, as CI runs it (and as a developer should before pushing).
#
#   1. ci/setup.sh --test      a Vulkan loader, a driver (Mesa's lavapipe runs on the CPU) and the
#                              Khronos validation layers; installs them with apt-get when missing
#   2. cargo fmt --check       formatting
#   3. cargo clippy            lints, warnings are errors
#   4. cargo check --no-default-features --bins
#                              the headless binary still builds without the `preview` feature (the window)
#   5. cargo test              unit and integration tests (dev profile); the tests that use the GPU
#                              turn the validation layers on themselves, and any validation error fails them;
#                              tests/preview.rs opens the preview window under Xvfb (xvfb-run)
#   6. ci/farm-test.sh         the Slurm render farm: a private one-node cluster (ci/slurm.sh: munged,
#                              slurmctld, slurmd, stopped after), the deploy/slurm recipe with a cancelled
#                              and resubmitted part, the merge checked bit for bit against one render
#   7. ci/k8s-check.sh         the Kubernetes recipe (deploy/k8s) validated against the API's schemas
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
step clippy cargo clippy --all-targets -- -D warnings
step headless cargo check --no-default-features --bins
step test cargo test
step farm ./ci/farm-test.sh
step k8s ./ci/k8s-check.sh
echo "==> all checks passed in $SECONDS s"
