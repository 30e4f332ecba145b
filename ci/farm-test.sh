#!/usr/bin/env bash
# ci/farm-test.sh: the render-farm test on a real one-node Slurm cluster (ci/slurm.sh).
#
# One frame of scenes/course.toml is rendered in 4 parts as a Slurm job array (deploy/slurm/submit.sh).
# Part 2 is cancelled (scancel) while it runs; the test checks that nothing was merged and that
# `vkpath merge` refuses the incomplete parts (exit 2, no image). The documented recipe then retries
# part 2 alone (`submit.sh ... --only 2`), which resumes from the part's checkpoint; the test checks that
# the merged EXR holds a single-process render's pixels bit for bit (`vkpath compare`), and that part 2's
# checkpoint equals an uninterrupted render of part 2 byte for byte.
#
#   ci/farm-test.sh      (as root; after `cargo build` or `cargo test`, which build target/debug/vkpath)
#
# Environment: VKPATH (the binary; default target/debug/vkpath), FARM_WIDTH, FARM_HEIGHT, FARM_SPP (the
# render: default 320x240 at 256 spp), FARM_KEEP=1 keeps the work directory. Needs the Debian packages
# slurmctld, slurmd, slurm-client and munge.
# Takes about 55 s on a 2-core machine with lavapipe while a compile runs beside it (the reference
# render alone 21 s; FARM_BUDGET, default 170 s, bounds every wait). Stops every daemon it started, also
# on failure or interruption, and then prints which checks passed.
set -euo pipefail

repo=$(cd "$(dirname "$0")/.." && pwd)
start_all=$SECONDS

# The render: each of the 4 parts takes a few seconds on lavapipe.
width=${FARM_WIDTH:-320}
height=${FARM_HEIGHT:-240}
spp=${FARM_SPP:-256}
parts=4
victim=2 # the part that is cancelled and retried
render=(--width "$width" --height "$height" --spp "$spp")
# The parts also save their checkpoint every 8 samples per pixel, so that the cancelled part leaves
# partial state for the retry to resume from.
part_flags=("${render[@]}" --checkpoint-every 8)
# Every wait, and every render outside Slurm, ends by this deadline: CI's limit for this test is 3 min.
deadline=$((start_all + ${FARM_BUDGET:-170}))

passed=0
failed=0

# The binary, as an absolute path: the jobs run in the work directory.
vkpath=${VKPATH:-$repo/target/debug/vkpath}
case $vkpath in
    /*) ;;
    */*) vkpath=$PWD/$vkpath ;;
    *) vkpath=$(command -v "$vkpath" || echo "$vkpath") ;;
esac
if [ ! -x "$vkpath" ]; then
    echo "farm test: no vkpath binary at $vkpath: build it first (cargo build, or cargo test), or set VKPATH" >&2
    exit 1
fi
if ! "$vkpath" render --help 2>/dev/null | grep -e '--part' >/dev/null; then
    echo "farm test: $vkpath has no 'render --part': rebuild it (cargo build)" >&2
    exit 1
fi
export VKPATH=$vkpath

# The work directory holds the cluster's state too, so that a developer's own cluster from
# `ci/slurm.sh up` (in /tmp/vkpath-slurm) is left alone. o+x: munged wants to reach its socket.
work=$(mktemp -d "${TMPDIR:-/tmp}/vkpath-farm.XXXXXX")
chmod 0755 "$work"
export VKPATH_SLURM_DIR=$work/slurm

cleanup() {
    local rc=$?
    "$repo/ci/slurm.sh" down >/dev/null 2>&1 || echo "farm test: ci/slurm.sh down failed" >&2
    if [ "$rc" -eq 0 ] && [ "${FARM_KEEP:-0}" != 1 ]; then
        rm -rf "$work"
    else
        echo "farm test: work directory kept: $work" >&2
    fi
    exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# What helps to understand a failure: the jobs, their logs, the daemons' logs.
diagnose() {
    echo "----- squeue -----" >&2
    squeue -t all >&2 2>&1 || true
    local f
    for f in "$work"/run/*.out; do
        [ -e "$f" ] || continue
        echo "----- $f -----" >&2
        tail -n 20 "$f" >&2
    done
    ls -la "$work/run/parts" >&2 2>/dev/null || true
    for f in "$VKPATH_SLURM_DIR/log/slurmctld.log" "$VKPATH_SLURM_DIR/log/slurmd.log"; do
        [ -e "$f" ] || continue
        echo "----- last lines of $f -----" >&2
        tail -n 40 "$f" >&2
    done
}

fail() {
    failed=$((failed + 1))
    echo "FAIL: $*" >&2
    diagnose
    echo "farm test: $passed passed, $failed failed" >&2
    exit 1
}

ok() {
    passed=$((passed + 1))
    echo "ok: $*"
}

# A job's state (PENDING, RUNNING, COMPLETED, CANCELLED, FAILED, ...) from the controller, which keeps
# finished jobs for MinJobAge (300 s in ci/slurm.sh); "GONE" if it forgot the job.
job_state() {
    local s
    s=$(scontrol show job "$1" 2>/dev/null | grep -o 'JobState=[A-Z_]*' | head -n 1) || true
    s=${s#JobState=}
    echo "${s:-GONE}"
}

# Seconds left before the deadline (at least 1).
time_left() {
    local left=$((deadline - SECONDS))
    echo $((left > 0 ? left : 1))
}

# Runs vkpath outside Slurm, killed at the deadline.
run_vkpath() {
    timeout "$(time_left)" "$vkpath" "$@"
}

# Waits until a job (or an array task, JOB_I) has finished, at most $2 seconds and not past the
# deadline; prints its last state.
wait_done() {
    local job=$1 limit=$2 t0=$SECONDS s
    while :; do
        s=$(job_state "$job")
        case $s in
            PENDING | RUNNING | CONFIGURING | COMPLETING | SUSPENDED | REQUEUED | RESIZING) ;;
            *)
                echo "$s"
                return 0
                ;;
        esac
        if [ $((SECONDS - t0)) -ge "$limit" ] || [ "$SECONDS" -ge "$deadline" ]; then
            echo "$s"
            return 1
        fi
        sleep 0.2
    done
}

# Every task of an array job gone from the queue, at most $2 seconds.
wait_array_done() {
    local job=$1 limit=$2 t0=$SECONDS
    while [ -n "$(squeue -h -j "$job" -o '%i' 2>/dev/null || true)" ]; do
        [ $((SECONDS - t0)) -lt "$limit" ] && [ "$SECONDS" -lt "$deadline" ] || return 1
        sleep 0.2
    done
}

# ----- a. the cluster -----
conf_line=$("$repo/ci/slurm.sh" up) || fail "ci/slurm.sh up failed"
export SLURM_CONF=${conf_line#export SLURM_CONF=}
ok "cluster up ($((SECONDS - start_all)) s)"

mkdir -p "$work/run"
cd "$work/run"
scene=$repo/scenes/course.toml

# ----- c. the reference: one process, the whole frame -----
t0=$SECONDS
run_vkpath render "$scene" "${render[@]}" -o single.exr --quiet || fail "the reference render failed"
t_single=$((SECONDS - t0))
ok "reference render ${width}x${height} at $spp spp in $t_single s"

# ----- d. the farm: 4 parts as a job array, and the merge job -----
t_farm0=$SECONDS
submitted=$("$repo/deploy/slurm/submit.sh" "$scene" "$parts" parts out.exr -- "${part_flags[@]}") ||
    fail "submit.sh failed"
array=$(sed -n 's/^render_job=\([0-9]*\)$/\1/p' <<<"$submitted")
merge1=$(sed -n 's/^merge_job=\([0-9]*\)$/\1/p' <<<"$submitted")
if [ -z "$array" ] || [ -z "$merge1" ]; then
    fail "submit.sh printed no render_job=/merge_job= lines: $submitted"
fi
ok "submitted array $array and merge job $merge1"

# ----- e. cancel part 2 while it runs and has saved a checkpoint -----
t0=$SECONDS
while :; do
    s=$(job_state "${array}_$victim")
    if [ "$s" = RUNNING ] && [ -e "parts/part-$victim.ckpt" ]; then
        break
    fi
    case $s in
        PENDING | RUNNING | CONFIGURING) ;;
        *) fail "part $victim ended ($s) before it could be cancelled: raise FARM_SPP so that a part lasts longer" ;;
    esac
    if [ $((SECONDS - t0)) -ge 90 ] || [ "$SECONDS" -ge "$deadline" ]; then
        fail "part $victim not running with a checkpoint after $((SECONDS - t0)) s (state $s)"
    fi
    sleep 0.2
done
scancel "${array}_$victim" || fail "scancel ${array}_$victim failed (did part $victim just end? raise FARM_SPP)"
ok "cancelled part $victim (${array}_$victim) while it ran, its checkpoint on disk"

wait_array_done "$array" 120 || fail "the array's tasks did not end within 120 s"
for ((i = 0; i < parts; i++)); do
    s=$(job_state "${array}_$i")
    if [ "$i" -eq "$victim" ]; then
        [ "$s" = CANCELLED ] || fail "part $i ended $s, expected CANCELLED (if COMPLETED: it ended before the scancel; raise FARM_SPP)"
    else
        [ "$s" = COMPLETED ] || fail "part $i ended $s, expected COMPLETED"
    fi
done
t_farm1=$((SECONDS - t_farm0))
ok "the other $((parts - 1)) parts completed, part $victim was cancelled ($t_farm1 s since submission)"

# The merge job's dependency can never be met: kill_invalid_depend cancels it.
s=$(wait_done "$merge1" 30) || fail "merge job $merge1 still $s 30 s after its array ended (kill_invalid_depend?)"
[ "$s" = CANCELLED ] || fail "merge job $merge1 ended $s, expected CANCELLED (its dependency failed)"
[ ! -e out.exr ] || fail "out.exr exists although a part was cancelled"
ok "merge job $merge1 cancelled, no image written"

set +e
run_vkpath merge parts -o x.exr 2>merge-refused.txt
rc=$?
set -e
[ "$rc" -eq 2 ] || fail "vkpath merge of the incomplete parts exited $rc, expected 2 ($(cat merge-refused.txt))"
[ ! -e x.exr ] || fail "vkpath merge refused the parts but wrote x.exr"
ok "vkpath merge refuses the incomplete parts (exit 2: $(head -c 160 merge-refused.txt | tr '\n' ' '))"

# ----- f. the retry: part 2 alone, resuming from its checkpoint, and a new merge -----
t_retry0=$SECONDS
submitted=$("$repo/deploy/slurm/submit.sh" "$scene" "$parts" parts out.exr --only "$victim" -- "${part_flags[@]}") ||
    fail "submit.sh --only $victim failed"
array2=$(sed -n 's/^render_job=\([0-9]*\)$/\1/p' <<<"$submitted")
merge2=$(sed -n 's/^merge_job=\([0-9]*\)$/\1/p' <<<"$submitted")
if [ -z "$array2" ] || [ -z "$merge2" ]; then
    fail "submit.sh --only printed no render_job=/merge_job= lines: $submitted"
fi
s=$(wait_done "$merge2" 120) || fail "merge job $merge2 not finished within 120 s (state $s)"
[ "$s" = COMPLETED ] || fail "merge job $merge2 ended $s, expected COMPLETED"
[ "$(job_state "${array2}_$victim")" = COMPLETED ] || fail "the retry of part $victim did not complete"
grep -e 'resuming' "vkpath-part-${array2}_$victim.out" >/dev/null ||
    fail "the retry of part $victim did not resume from its checkpoint"
[ -s out.exr ] || fail "merge job $merge2 completed but out.exr is missing"
t_retry=$((SECONDS - t_retry0))
t_farm=$((t_farm1 + t_retry))
ok "retry of part $victim resumed and completed, merge job $merge2 wrote out.exr ($t_retry s)"

# The pixels, not the files: the two carry different metadata (the single render records its seconds).
"$vkpath" compare out.exr single.exr || fail "the merged out.exr differs from the single render single.exr"
ok "merged EXR has the single render's pixels bit for bit (vkpath compare)"

# A fresh, uninterrupted render of part 2, outside Slurm: the same bits as the cancelled and resumed one.
run_vkpath render "$scene" --part "$victim/$parts" "${part_flags[@]}" --checkpoint fresh.ckpt --quiet ||
    fail "the uninterrupted render of part $victim failed"
cmp "parts/part-$victim.ckpt" fresh.ckpt ||
    fail "part $victim's checkpoint (cancelled, then resumed) differs from an uninterrupted render's"
ok "part $victim's resumed checkpoint equals an uninterrupted render's byte for byte"

rate=$(awk -v n="$parts" -v t="$t_farm" 'BEGIN { printf "%.2f", (t > 0 ? n / t : n) }')
echo "timings: single render $t_single s; through Slurm $parts parts in $t_farm s ($rate parts/s, the retry included, the cancelled work lost); total $((SECONDS - start_all)) s"
echo "farm test: $passed passed, $failed failed"
