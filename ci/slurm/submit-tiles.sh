#!/usr/bin/env bash
# Renders one image on a Slurm cluster: a job array of TASKS tiles, then the merge, which
# waits for the array (afterok). Prints the two job ids; with --wait, waits for the merge
# and exits with its status.
#
#   ci/slurm/submit-tiles.sh [--wait] [--gpu] TASKS SCENE.toml OUT.png|OUT.exr [render flags...]
#
# The parts go to OUT's folder, in parts-<stem>/. --gpu asks Slurm for one GPU per task.
# Extra sbatch options: SBATCH_* environment variables (SBATCH_PARTITION, SBATCH_ACCOUNT,
# SBATCH_TIMELIMIT, ...), which sbatch reads itself.
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
if [ $# -lt 3 ]; then
    echo "usage: $0 [--wait] [--gpu] TASKS SCENE.toml OUT.png|OUT.exr [render flags...]" >&2
    exit 2
fi
tasks=$1
scene=$2
out=$3
shift 3
stem=$(basename "${out%.*}")
parts="$(dirname "$out")/parts-$stem"
mkdir -p "$parts"
rm -f "$parts"/*.exr
array=$(sbatch --parsable "${gpu[@]}" --array="0-$((tasks - 1))" \
    "$here/tiles.sbatch" "$scene" "$parts" "$@")
array=${array%%;*}
merge=$(sbatch --parsable "${wait[@]}" --dependency="afterok:$array" --kill-on-invalid-dep=yes \
    "$here/merge.sbatch" "$out" "$parts")
echo "array job $array (tiles), merge job ${merge%%;*} -> $out"
