#!/usr/bin/env bash
# The cost of cutting one image into 4 tiles, for docs/distributed.md:
#
# 1. Without a scheduler: the whole image in one process against its 4 tiles rendered one
#    after the other (4 processes, `--tile I/4`) plus the merge, each with every core, on
#    the CPU (f64) and on GL, RUNS times interleaved: median wall and CPU seconds.
# 2. Through Slurm (ci/slurm/cluster.sh, one node): one job of one task with every core
#    against the 4-task array (one core per task, as many at once as there are cores) plus
#    the merge job; the span from the first job's start to the last one's end, measured
#    inside the jobs (sbatch --wait polls, which would add its own seconds).
#
#   ci/slurm/measure-overhead.sh [path/to/fragtrace]   (RUNS=3 SCENE=scenes/bunny.toml SIZE=1024)
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
bin=$(realpath "${1:-$repo/target/release/fragtrace}")
runs=${RUNS:-3}
scene=$(realpath "${SCENE:-$repo/scenes/bunny.toml}")
size=${SIZE:-1024}
export FRAGTRACE_MODEL_PATH=${FRAGTRACE_MODEL_PATH:-$(cd "$repo/.." && pwd)/shared/models}
work=$(mktemp -d "${TMPDIR:-/tmp}/fragtrace-overhead.XXXXXX")
chmod 0755 "$work"
trap '"$repo/ci/slurm/cluster.sh" stop "$work/cluster" >/dev/null 2>&1 || true; rm -rf "$work"' EXIT
cd "$work"
common=(--width "$size" --height "$size" -q)

# Runs a command, appending "wall cpu" seconds to the file $1.
timed() {
    local out=$1
    shift
    /usr/bin/time -f "%e %U %S" -o "$work/t" "$@"
    awk '{ printf "%s %.2f\n", $1, $2 + $3 }' "$work/t" >>"$out"
}
median() { sort -n | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }

echo "machine: $(nproc) cores, $(uname -n); scene $(basename "$scene") ${size}x${size}; $runs runs"
for backend in cpu gl; do
    rm -f "single-$backend" "tiles-$backend"
    for _ in $(seq "$runs"); do
        timed "single-$backend" "$bin" render "$scene" --backend "$backend" "${common[@]}" -o single.png
        : >tiles-run
        for i in 0 1 2 3; do
            timed tiles-run "$bin" render "$scene" --backend "$backend" "${common[@]}" --tile "$i/4" -o "t$i.exr"
        done
        timed tiles-run "$bin" merge t0.exr t1.exr t2.exr t3.exr -q -o merged.png
        cmp merged.png single.png || { echo "merged image differs" >&2; exit 1; }
        awk '{ w += $1; c += $2 } END { printf "%.2f %.2f\n", w, c }' tiles-run >>"tiles-$backend"
    done
    sw=$(cut -d' ' -f1 "single-$backend" | median)
    sc=$(cut -d' ' -f2 "single-$backend" | median)
    tw=$(cut -d' ' -f1 "tiles-$backend" | median)
    tc=$(cut -d' ' -f2 "tiles-$backend" | median)
    echo "$backend: 1 process ${sw} s wall ${sc} s cpu; 4 tiles + merge in turn ${tw} s wall ${tc} s cpu; ratio wall $(awk "BEGIN { printf \"%.2f\", $tw / $sw }") cpu $(awk "BEGIN { printf \"%.2f\", $tc / $sc }")"
done

# Through Slurm: jobs stamp their start and end; the span is the last end minus the first start.
"$repo/ci/slurm/cluster.sh" start "$work/cluster" >/dev/null
export SLURM_CONF=$work/cluster/slurm.conf FRAGTRACE=$bin
cores=$(nproc)
cat >stamp.sh <<'EOF'
#!/usr/bin/env bash
# Runs the rest of the command line between two time stamps in $STAMPS.
set -euo pipefail
echo "start $(date +%s.%N)" >>"$STAMPS"
"$@"
echo "end $(date +%s.%N)" >>"$STAMPS"
EOF
chmod +x stamp.sh
span() { awk '$1 == "start" && (s == "" || $2 < s) { s = $2 } $1 == "end" && $2 > e { e = $2 } END { printf "%.2f", e - s }' "$1"; }
for backend in cpu gl; do
    rm -f "slurm-single-$backend" "slurm-tiles-$backend"
    for r in $(seq "$runs"); do
        export STAMPS=$work/stamps-single-$r
        : >"$STAMPS"
        sbatch --wait -Q -o /dev/null --cpus-per-task="$cores" \
            --wrap "LP_NUM_THREADS=$cores RAYON_NUM_THREADS=$cores $work/stamp.sh $bin render $scene --backend $backend ${common[*]} -o $work/s.png"
        span "$STAMPS" >>"slurm-single-$backend"
        echo >>"slurm-single-$backend"
        export STAMPS=$work/stamps-tiles-$r
        : >"$STAMPS"
        rm -rf parts && mkdir parts
        array=$(sbatch --parsable -o /dev/null --array=0-3 --cpus-per-task=1 \
            --wrap "LP_NUM_THREADS=1 RAYON_NUM_THREADS=1 $work/stamp.sh $bin render $scene --backend $backend ${common[*]} --task-index env -o $work/parts/part-{tile}.exr")
        sbatch --wait -Q -o /dev/null --dependency="afterok:${array%%;*}" \
            --wrap "$work/stamp.sh $bin merge $work/parts/part-0.exr $work/parts/part-1.exr $work/parts/part-2.exr $work/parts/part-3.exr -q -o $work/m.png"
        cmp m.png s.png || { echo "Slurm: merged image differs" >&2; exit 1; }
        span "$STAMPS" >>"slurm-tiles-$backend"
        echo >>"slurm-tiles-$backend"
    done
    a=$(median <"slurm-single-$backend")
    b=$(median <"slurm-tiles-$backend")
    echo "slurm $backend: 1 task x $cores cores ${a} s; 4-task array (1 core each) + merge ${b} s; ratio $(awk "BEGIN { printf \"%.2f\", $b / $a }")"
done
