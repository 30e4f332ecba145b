#!/usr/bin/env bash
# ci/k8s-check.sh: the offline check of the Kubernetes render farm in deploy/k8s (no cluster needed).
#
#   1. Validates every manifest in deploy/k8s against the Kubernetes API's JSON schemas with
#      kubernetes-validate, in strict mode (an unknown field, such as a misspelled one, is an error),
#      for the newest Kubernetes version it ships. The schemas are files inside the Python package:
#      nothing is fetched.
#   2. Shows that this validation can fail: copies of render-job.yaml with a misspelled field
#      (completionMod) and a misspelled kind must be refused. kubernetes-validate only warns, and exits 0,
#      when it has no schema for a kind, so a line other than "INFO ... passed" counts as a failure here.
#   3. Shows that ci/k8s_local_run.py refuses a render Job whose completions disagree with its
#      --part env/N.
#   4. Runs the manifests locally with ci/k8s_local_run.py: every index of the render Job, a retried
#      index, the merge Job, and compares the merged image's pixels with a single render's, bit for bit.
#
# Needs: the venv ${VKPATH_CI_VENV:-target/ci-venv} with kubernetes-validate (ci/setup.sh installs it;
# by hand: python3 -m venv target/ci-venv && target/ci-venv/bin/pip install kubernetes-validate==1.37.0),
# and the vkpath binary ${VKPATH:-target/debug/vkpath} (cargo build / cargo test) with a Vulkan device
# (lavapipe will do). Takes seconds.
#
# Prints what it validated and ran, and ends with `k8s check: N passed, M failed`; exits 1 when anything
# failed, 2 when a prerequisite is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

venv=${VKPATH_CI_VENV:-target/ci-venv}
# The newest Kubernetes whose schemas kubernetes-validate 1.37.0 ships (it ships 1.25.0 to 1.37.0). The
# manifests need 1.29 or newer (deploy/k8s/render-job.yaml says why); Indexed Jobs are GA since 1.24.
k8s_version=1.37.0
validator=$venv/bin/kubernetes-validate
python=$venv/bin/python
export VKPATH=${VKPATH:-target/debug/vkpath}

if [ ! -x "$validator" ] || [ ! -x "$python" ]; then
    echo "ci/k8s-check.sh: no kubernetes-validate in $venv; create it with:" >&2
    echo "  python3 -m venv $venv && $venv/bin/pip install kubernetes-validate==1.37.0" >&2
    exit 2
fi

passed=0
failed=0
pass() {
    passed=$((passed + 1))
    echo "  ok: $*"
}
fail() {
    failed=$((failed + 1))
    echo "  FAIL: $*"
}

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
start=$SECONDS

# Validates one file; its output is kept in $tmp/out. Passes only when kubernetes-validate exits 0 and
# every line it printed says "INFO <file> passed for resource ...": it prints one such line per object,
# and only warns (exit 0) when it finds no schema for an object's kind or apiVersion.
validate() {
    local rc=0 lines ok
    "$validator" --strict --kubernetes-version "$k8s_version" "$1" >"$tmp/out" 2>&1 || rc=$?
    sed 's/^/    /' "$tmp/out"
    [ "$rc" = 0 ] || return 1
    lines=$(grep -c . "$tmp/out" || true)
    ok=$(grep -c '^INFO .* passed for resource ' "$tmp/out" || true)
    [ "$lines" -ge 1 ] && [ "$ok" = "$lines" ]
}

echo "==> k8s check: schemas (kubernetes-validate $("$validator" --version), Kubernetes $k8s_version, strict)"
# The schemas are read from the package (importlib resources); say where, and that this version is there.
if schema_dir=$("$python" - "$k8s_version" <<'EOF'
import sys
from pathlib import Path
import kubernetes_validate.utils as u
root = Path(u.__file__).parent / "kubernetes-json-schema"
d = root / f"v{sys.argv[1]}-local-strict"
print(d.relative_to(root.parent.parent) if d.is_dir() else "")
sys.exit(0 if d.is_dir() else 1)
EOF
); then
    pass "the strict schemas of Kubernetes $k8s_version are in the package (site-packages/$schema_dir)"
else
    fail "kubernetes-validate has no schemas for Kubernetes $k8s_version (a different version installed?)"
fi
manifests=(deploy/k8s/*.yaml)
for m in "${manifests[@]}"; do
    if validate "$m"; then
        pass "$m validates against Kubernetes $k8s_version"
    else
        fail "$m does not validate against Kubernetes $k8s_version (kubernetes-validate's output above)"
    fi
done

echo "==> k8s check: the validation refuses broken manifests"
# A misspelled field: only a strict validation notices (an unknown field is otherwise ignored, and the
# Job would silently run as NonIndexed). The misspelled kind: no schema at all.
sed 's/^  completionMode: Indexed$/  completionMod: Indexed/' deploy/k8s/render-job.yaml >"$tmp/misspelled-field.yaml"
sed 's/^kind: Job$/kind: Jbo/' deploy/k8s/render-job.yaml >"$tmp/misspelled-kind.yaml"
for case in "misspelled-field:completionMod:" "misspelled-kind:kind: Jbo"; do
    name=${case%%:*}
    mark=${case#*:}
    file=$tmp/$name.yaml
    if ! grep -q "^ *$mark" "$file"; then
        fail "$name: could not break render-job.yaml (the sed found nothing to change): update this check"
    elif validate "$file"; then
        fail "$name: a copy of render-job.yaml with '$mark' was accepted; the validation is not strict"
    else
        pass "$name: a copy of render-job.yaml with '$mark' is refused"
    fi
done

echo "==> k8s check: ci/k8s_local_run.py refuses completions that disagree with --part env/N"
sed 's/^  completions: 4 /  completions: 3 /' deploy/k8s/render-job.yaml >"$tmp/completions-3.yaml"
if ! grep -q '^  completions: 3 ' "$tmp/completions-3.yaml"; then
    fail "completions-3: could not change completions in render-job.yaml: update this check"
elif "$python" ci/k8s_local_run.py --check-only --render-job "$tmp/completions-3.yaml" >"$tmp/out" 2>&1; then
    sed 's/^/    /' "$tmp/out"
    fail "completions-3: a render Job with completions 3 and --part env/4 was accepted"
elif grep -q 'FAIL: completions (3)' "$tmp/out"; then
    grep 'FAIL' "$tmp/out" | sed 's/^/    /'
    pass "completions-3: completions 3 with --part env/4 is refused"
else
    sed 's/^/    /' "$tmp/out"
    fail "completions-3: refused, but not for the disagreeing N (output above)"
fi

echo "==> k8s check: the manifests run locally (vkpath: $VKPATH)"
if "$python" ci/k8s_local_run.py; then
    pass "the farm's parts merge into the single render's image (ci/k8s_local_run.py)"
else
    fail "ci/k8s_local_run.py (its output above)"
fi

echo "k8s check: $passed passed, $failed failed ($((SECONDS - start)) s)"
[ "$failed" = 0 ]
