#!/usr/bin/env bash
# Renders an animation on a Slurm cluster: a job array of TASKS sharing the frames A..B.
# Whole frames go straight to OUT (a run of # for the frame number: frames/frame_####.png).
# With --tiles N among the render flags, each frame is cut into N parts (written to
# parts-<stem>/ beside OUT) and a merge job, waiting for the array (afterok), writes OUT
# frame by frame. Prints the job ids; with --wait, waits for the last job and exits with
# its status.
#
#   ci/slurm/submit-frames.sh [--wait] [--gpu] TASKS SCENE.toml A..B OUT [render flags...]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
wait=()
gpu=()
while [ $# -gt 0 ]; do
    case "$1" in
    --wait) wait=(--wait); shift ;;
    --gpu) gpu=(--gpus-per-task=1); shift ;;
    *) break ;;
    esac
done
if [ $# -lt 4 ]; then
    echo "usage: $0 [--wait] [--gpu] TASKS SCENE.toml A..B OUT [render flags...]" >&2
    exit 2
fi
tasks=$1
scene=$2
frames=$3
out=$4
shift 4
tiled=0
for a in "$@"; do [ "$a" = --tiles ] && tiled=1; done
mkdir -p "$(dirname "$out")"
if [ $tiled = 0 ]; then
    array=$(sbatch --parsable "${wait[@]}" "${gpu[@]}" --array="0-$((tasks - 1))" \
        "$here/frames.sbatch" "$scene" "$frames" "$out" "$@")
    echo "array job ${array%%;*} (frames) -> $out"
    exit 0
fi
stem=$(basename "${out%.*}")
stem=${stem//#/}
parts="$(dirname "$out")/parts-$stem"
mkdir -p "$parts"
rm -f "$parts"/*.exr
array=$(sbatch --parsable "${gpu[@]}" --array="0-$((tasks - 1))" \
    "$here/frames.sbatch" "$scene" "$frames" "$parts/f####-{tile}.exr" "$@")
array=${array%%;*}
merge=$(sbatch --parsable "${wait[@]}" --dependency="afterok:$array" --kill-on-invalid-dep=yes \
    "$here/merge.sbatch" "$out" "$parts")
echo "array job $array (frames x tiles), merge job ${merge%%;*} -> $out"
