#!/usr/bin/env bash
# Whole-process wall time of the default CPU renders, two binaries interleaved round-robin
# (so a load change hits both alike), medians of RUNS: the built-in scene as `fragtrace
# render` renders it on a machine without a GPU (`--backend cpu`: what auto takes where GL
# is a software rasterizer), `scenes/bunny.toml --backend cpu` and the equal-work view in
# f32 at 1024x1024, each with the binary's defaults (`--accel`, `--precision`, `--cpu-path`);
# then whether the two binaries' images are equal.
# Usage: ci/compare-default.sh OLD_BINARY NEW_BINARY (env: RUNS=5, THREADS=2,
#        FRAGTRACE_MODEL_PATH=../shared/models)
set -euo pipefail
[ $# -eq 2 ] || { echo "usage: $0 OLD_BINARY NEW_BINARY" >&2; exit 2; }
HERE=$(cd "$(dirname "$0")" && pwd)
RUNS=${RUNS:-5}
export RAYON_NUM_THREADS=${THREADS:-2}
export FRAGTRACE_MODEL_PATH=${FRAGTRACE_MODEL_PATH:-$HERE/../../shared/models}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
cases=(
    "builtin|--backend cpu"
    "bunny|$HERE/../scenes/bunny.toml --backend cpu"
    "equal-work-f32|$HERE/peers/equal-work.toml --backend cpu --precision f32 --width 1024 --height 1024"
)
echo "== default CPU renders, $RAYON_NUM_THREADS threads, $RUNS rounds; $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg), $(date -u +%FT%TZ)"
for ((i = 1; i <= RUNS; i++)); do
    for c in "${cases[@]}"; do
        name=${c%%|*} flags=${c#*|}
        for b in old new; do
            bin=$1; [ $b = new ] && bin=$2
            # shellcheck disable=SC2086
            s=$(date +%s.%N); "$bin" render $flags -q -o "$WORK/$name-$b.png" --stats "$WORK/$name-$b.json"; e=$(date +%s.%N)
            python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print('$name', '$b', $e - $s, d['accel']['kind'], d['accel']['build_ms'], d['render_ms'])" "$WORK/$name-$b.json"
        done
    done
done | python3 -c '
import collections, statistics as st, sys
r = collections.defaultdict(list)
for line in sys.stdin:
    name, b, wall, kind, build, render = line.split()
    r[(name, b)].append((float(wall), kind, float(build), float(render)))
for name in dict.fromkeys(n for n, _ in r):
    o, n = r[(name, "old")], r[(name, "new")]
    med = lambda v, k: st.median(x[k] for x in v)
    ratios = [a[0] / b[0] for a, b in zip(o, n)]
    print("%-15s old %-9s wall %.3f s (build %.1f ms, render %.1f ms) | new %-9s wall %.3f s (build %.1f ms, render %.1f ms) | old/new per round %s, median %.2f" % (
        name, o[0][1], med(o, 0), med(o, 2), med(o, 3), n[0][1], med(n, 0), med(n, 2), med(n, 3),
        " ".join("%.2f" % x for x in ratios), st.median(ratios)))
'
for c in "${cases[@]}"; do
    name=${c%%|*}
    if cmp -s "$WORK/$name-old.png" "$WORK/$name-new.png"; then echo "$name: images equal"; else echo "$name: IMAGES DIFFER"; fi
done
