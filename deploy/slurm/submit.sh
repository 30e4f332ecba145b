#!/usr/bin/env bash
# deploy/slurm/submit.sh: render one frame across a Slurm cluster, split into N parts.
#
#   deploy/slurm/submit.sh SCENE N PARTS_DIR OUT_IMAGE [OUT_IMAGE...] [--only I,J,...] [-- RENDER_FLAGS...]
#
# Submits two jobs and prints their ids on stdout, one `name=id` line each:
#   render_job=ID   a job array of N tasks (render-part.sbatch): task I renders part I of N of the
#                   render's samples into PARTS_DIR/part-I.ckpt
#   merge_job=ID    merge.sbatch, held until every task of the array succeeded (afterok), then
#                   `vkpath merge PARTS_DIR -o OUT_IMAGE...`
#
# RENDER_FLAGS go to every part's `vkpath render`, e.g. `-- --spp 4096 --checkpoint-every 5m`; they must
# be the same for every part (and for a retry), as they define the render. Extra sbatch options (a
# partition, a time limit, --gres=gpu:1) can be given through Slurm's SBATCH_* environment variables,
# e.g. SBATCH_PARTITION=gpu SBATCH_TIMELIMIT=2:00:00, which apply to both jobs.
#
# A part failed or was cancelled? Nothing was merged (the merge job's dependency cannot be met). Resubmit
# just that part, same arguments plus `--only I` (or `--only I,J` for several): the retry resumes from the
# part's last checkpoint, and a new merge job merges all of PARTS_DIR when it succeeds.
#
# Runs from, and leaves the jobs' logs (vkpath-part-JOB_TASK.out, vkpath-merge-JOB.out) in, the current
# directory; SCENE, PARTS_DIR and OUT_IMAGE are relative to it, and it must be on a file system all
# nodes share. $VKPATH, if set, names the vkpath binary for the jobs (sbatch exports the environment);
# else they run `vkpath` from the nodes' PATH.
#
# Exit status: 0 both jobs submitted; 2 bad arguments; 1 sbatch failed (the array is then cancelled,
# so that nothing is left half submitted).
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)

# The comment block at the top of this file, without the '# '.
help_text() {
    awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "$0"
}

usage() {
    echo "usage: $(help_text | sed -n '3p' | sed 's/^ *//')" >&2
    echo "(submit.sh --help says more)" >&2
}

bad() {
    echo "submit.sh: $*" >&2
    usage
    exit 2
}

positional=()
only=""
render_flags=()
while [ $# -gt 0 ]; do
    case $1 in
        -h | --help)
            help_text
            exit 0
            ;;
        --only)
            [ $# -ge 2 ] || bad "--only needs a list of part indices, e.g. --only 2 or --only 0,3"
            only=$2
            shift 2
            ;;
        --only=*)
            only=${1#--only=}
            shift
            ;;
        --)
            shift
            render_flags=("$@")
            break
            ;;
        -*)
            bad "unknown option '$1' (vkpath render flags go after --)"
            ;;
        *)
            positional+=("$1")
            shift
            ;;
    esac
done

[ "${#positional[@]}" -ge 4 ] || bad "expected SCENE N PARTS_DIR OUT_IMAGE, got ${#positional[@]} argument(s)"
scene=${positional[0]}
parts=${positional[1]}
parts_dir=${positional[2]}
outputs=("${positional[@]:3}")

if ! [[ $parts =~ ^[0-9]{1,6}$ ]] || [ "$((10#$parts))" -lt 1 ]; then
    bad "N (the number of parts) must be a positive integer, not '$parts'"
fi
parts=$((10#$parts))
[ -e "$scene" ] || bad "scene '$scene' does not exist (paths are relative to the current directory)"

# The array's indices: all parts, or (a retry) the ones listed, each checked to be a part of N.
if [ -z "$only" ]; then
    array="0-$((parts - 1))"
else
    [[ $only =~ ^[0-9]+(,[0-9]+)*$ ]] ||
        bad "--only takes part indices separated by commas, e.g. --only 2 or --only 0,3; not '$only'"
    IFS=, read -r -a indices <<<"$only"
    for i in "${indices[@]}"; do
        [ "$((10#$i))" -lt "$parts" ] || bad "--only: part $i does not exist: parts are numbered 0 to $((parts - 1))"
    done
    array=$only
fi

mkdir -p "$parts_dir"

# --parsable prints "JOBID" (or "JOBID;CLUSTER" on a multi-cluster setup).
render_job=$(sbatch --parsable --array="$array" "$here/render-part.sbatch" \
    "$scene" "$parts" "$parts_dir" "${render_flags[@]}") || {
    echo "submit.sh: sbatch of the render array failed" >&2
    exit 1
}
render_job=${render_job%%;*}

merge_job=$(sbatch --parsable --dependency="afterok:$render_job" "$here/merge.sbatch" \
    "$parts_dir" "${outputs[@]}") || {
    echo "submit.sh: sbatch of the merge job failed; cancelling the render array $render_job" >&2
    scancel "$render_job" || true
    exit 1
}
merge_job=${merge_job%%;*}

echo "submit.sh: parts [$array] of $parts: job array $render_job; merge into ${outputs[*]}: job $merge_job (runs when every part succeeded)" >&2
echo "render_job=$render_job"
echo "merge_job=$merge_job"
