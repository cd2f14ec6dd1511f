#!/usr/bin/env bash
# Renders one image on a Slurm cluster: a job array of TASKS tiles, then the merge, which
# waits for the array (afterok). Prints the two job ids. With --wait, waits for the merge
# and exits 0 only when OUT was written by it; otherwise exit 1 naming the missing or
# broken parts (fragtrace render --check) and the command that re-runs a task. Either way
# it ends with the parts across the tasks (fragtrace merge --summary: parts done, missing
# by tile with the task that owed each, time per task).
#
#   ci/slurm/submit-tiles.sh [--wait] [--gpu] TASKS SCENE.toml OUT.png|OUT.exr [render flags...]
#
# The parts go to OUT's folder, in parts-<stem>/. --gpu asks Slurm for one GPU per task.
# The backend is pinned (--backend gl with --gpu, else cpu) unless the flags name one:
# `auto` could choose differently on different nodes, and merge refuses such parts.
# Extra sbatch options: SBATCH_* environment variables (SBATCH_PARTITION, SBATCH_ACCOUNT,
# SBATCH_TIMELIMIT, ...), which sbatch reads itself.
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
if [ $# -lt 3 ]; then
    echo "usage: $0 [--wait] [--gpu] TASKS SCENE.toml OUT.png|OUT.exr [render flags...]" >&2
    exit 2
fi
tasks=$1
scene=$2
out=$3
shift 3
case "$tasks" in
'' | *[!0-9]* | 0) echo "$0: TASKS must be a whole number >= 1, not '$tasks'" >&2; exit 2 ;;
esac
flags=("$@")
has_flag backend "${flags[@]}" || flags+=(--backend "$backend")
tiles=$(flag_value tiles "${flags[@]}")
stem=$(basename "${out%.*}")
parts="$(dirname "$out")/parts-$stem"
mkdir -p "$parts"
# A fresh set of parts, unless --resume keeps the whole ones.
has_flag resume "${flags[@]}" || rm -f "$parts"/*.exr
stamp=$(mktemp "$parts/.submitted.XXXXXX")
array=$(sbatch --parsable "${gpu[@]}" --array="0-$((tasks - 1))" \
    "$here/tiles.sbatch" "$scene" "$parts" --task-index "env:$tasks" "${flags[@]}")
array=${array%%;*}
waitflag=()
[ $wait = 1 ] && waitflag=(--wait)
rc=0
merge=$(sbatch --parsable "${waitflag[@]}" --dependency="afterok:$array" --kill-on-invalid-dep=yes \
    "$here/merge.sbatch" "$out" "$parts") || rc=$?
merge=${merge%%;*}
echo "array job $array (tiles), merge job $merge -> $out"
[ $wait = 1 ] || { rm -f "$stamp"; exit 0; }
# Slurm 22.05's sbatch --wait returns 0 for a merge job cancelled because a task failed
# (DependencyNeverSatisfied): the output itself is the verdict.
if [ $rc = 0 ] && [ -f "$out" ] && [ "$out" -nt "$stamp" ]; then
    rm -f "$stamp"
    parts_summary "$parts" || true
    exit 0
fi
rm -f "$stamp"
echo "submit-tiles.sh: $out was not written (merge job $merge: $(job_state "$merge"), sbatch exit $rc)" >&2
check=(--task-index 0/1)
[ -n "$tiles" ] || check+=(--tiles "$tasks")
"${FRAGTRACE:-fragtrace}" render "$scene" "${flags[@]}" "${check[@]}" \
    -o "$parts/part-{tile}.exr" --check >&2 || true
parts_summary "$parts" >&2 || true
echo "submit-tiles.sh: re-run task K with: sbatch --array=K $here/tiles.sbatch $scene $parts --task-index env:$tasks ${flags[*]}; then: sbatch $here/merge.sbatch $out $parts" >&2
exit 1
