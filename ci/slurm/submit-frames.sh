#!/usr/bin/env bash
# Renders an animation on a Slurm cluster: a job array of TASKS sharing the frames FRAMES
# (A..B, A..B:S, A,B,C or all). Whole frames go straight to OUT (a run of # for the frame
# number: frames/frame_####.png). With --tiles N (or --tiles=N) among the render flags,
# each frame is cut into N parts (written to parts-<stem>/ beside OUT) and a merge job,
# waiting for the array (afterok), writes OUT frame by frame. Prints the job ids. With
# --wait, waits for the last job and exits 0 only when every frame of OUT exists whole
# (fragtrace render --check); otherwise exit 1 naming the missing files and the command
# that re-runs a task. The backend is pinned (gl with --gpu, else cpu) unless the flags
# name one. --resume among the flags skips the frames that exist whole. With --tiles it
# ends with the parts across the tasks (fragtrace merge --summary).
#
#   ci/slurm/submit-frames.sh [--wait] [--gpu] TASKS SCENE.toml FRAMES OUT [render flags...]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
. "$here/flags.sh"
wait=0
gpu=()
backend=cpu
while [ $# -gt 0 ]; do
    case "$1" in
    --wait) wait=1; shift ;;
    --gpu) gpu=(--gpus-per-task=1); backend=gl; shift ;;
    *) break ;;
    esac
done
if [ $# -lt 4 ]; then
    echo "usage: $0 [--wait] [--gpu] TASKS SCENE.toml FRAMES OUT [render flags...]" >&2
    exit 2
fi
tasks=$1
scene=$2
frames=$3
out=$4
shift 4
case "$tasks" in
'' | *[!0-9]* | 0) echo "$0: TASKS must be a whole number >= 1, not '$tasks'" >&2; exit 2 ;;
esac
flags=("$@")
has_flag backend "${flags[@]}" || flags+=(--backend "$backend")
waitflag=()
[ $wait = 1 ] && waitflag=(--wait)
mkdir -p "$(dirname "$out")"
rc=0
if has_flag tiles "${flags[@]}"; then
    stem=$(basename "${out%.*}")
    stem=${stem//#/}
    parts="$(dirname "$out")/parts-$stem"
    mkdir -p "$parts"
    has_flag resume "${flags[@]}" || rm -f "$parts"/*.exr
    array=$(sbatch --parsable "${gpu[@]}" --array="0-$((tasks - 1))" \
        "$here/frames.sbatch" "$scene" "$frames" "$parts/f####-{tile}.exr" \
        --task-index "env:$tasks" "${flags[@]}")
    array=${array%%;*}
    last=$(sbatch --parsable "${waitflag[@]}" --dependency="afterok:$array" --kill-on-invalid-dep=yes \
        "$here/merge.sbatch" "$out" "$parts") || rc=$?
    last=${last%%;*}
    echo "array job $array (frames x tiles), merge job $last -> $out"
else
    parts=""
    array=$(sbatch --parsable "${waitflag[@]}" "${gpu[@]}" --array="0-$((tasks - 1))" \
        "$here/frames.sbatch" "$scene" "$frames" "$out" --task-index "env:$tasks" "${flags[@]}") || rc=$?
    array=${array%%;*}
    last=$array
    echo "array job $array (frames) -> $out"
fi
[ $wait = 1 ] || exit 0
# Slurm 22.05's sbatch --wait returns 0 for a merge job cancelled because a task failed,
# and an array's status says nothing of the frames: the files themselves are the verdict.
without_flag tiles "${flags[@]}"
without_switch resume "${rest[@]}"
frags=${FRAGTRACE:-fragtrace}
if "$frags" render "$scene" --frames "$frames" "${rest[@]}" -o "$out" --check >/dev/null 2>&1 && [ $rc = 0 ]; then
    [ -z "$parts" ] || parts_summary "$parts" || true
    exit 0
fi
echo "submit-frames.sh: not every frame of $out was written (job $last: $(job_state "$last"), sbatch exit $rc):" >&2
"$frags" render "$scene" --frames "$frames" "${rest[@]}" -o "$out" --check >&2 || true
if [ -n "$parts" ]; then
    "$frags" render "$scene" --frames "$frames" "${flags[@]}" --task-index 0/1 \
        -o "$parts/f####-{tile}.exr" --check >&2 || true
    parts_summary "$parts" >&2 || true
    echo "submit-frames.sh: re-run task K with: sbatch --array=K $here/frames.sbatch $scene $frames $parts/f####-{tile}.exr --task-index env:$tasks ${flags[*]}; then: sbatch $here/merge.sbatch $out $parts" >&2
else
    echo "submit-frames.sh: re-run task K with: sbatch --array=K $here/frames.sbatch $scene $frames $out --task-index env:$tasks ${flags[*]} (or add --resume to render only what is missing)" >&2
fi
exit 1
