#!/usr/bin/env bash
# Build time of the irregular grid, two (or more) binaries interleaved round-robin so that a
# load change on the machine hits them alike: medians of RUNS of `accel.build_ms` and of
# the exit-box growth from `render SCENE --backend cpu --accel irregular --precision f32 --width 8 --height 8
# --stats` (an 8x8 render, so the build is most of the process), and of each build phase
# where the binary reports them (`accel.detail`'s "phases ms: ...").
# Usage: ci/compare-build.sh OLD_BINARY NEW_BINARY... (env: SCENE=scenes/bunny.toml, RUNS=5,
#        THREADS=2, FRAGTRACE_MODEL_PATH=../shared/models)
set -euo pipefail
[ $# -ge 1 ] || { echo "usage: $0 BINARY..." >&2; exit 2; }
HERE=$(cd "$(dirname "$0")" && pwd)
SCENE=${SCENE:-$HERE/../scenes/bunny.toml}
RUNS=${RUNS:-5}
THREADS=${THREADS:-2}
export FRAGTRACE_MODEL_PATH=${FRAGTRACE_MODEL_PATH:-$HERE/../../shared/models}
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
echo "== irregular build of $(basename "$SCENE"), $THREADS threads, $RUNS rounds; $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg), $(date -u +%FT%TZ)"
for ((i = 1; i <= RUNS; i++)); do
    for b in "$@"; do
        RAYON_NUM_THREADS=$THREADS "$b" render "$SCENE" --backend cpu --accel irregular --precision f32 \
            --width 8 --height 8 -q -o "$WORK/x.png" --stats "$WORK/s.json"
        python3 - "$WORK/s.json" "$b" <<'PY'
import json, re, sys
d = json.load(open(sys.argv[1]))
grow = re.search(r"\(([0-9.]+) ms growing", d["accel"]["detail"]).group(1)
# Builds that time their phases say "phases ms: a 1.0, b 2.0".
m = re.search(r"phases ms: ([^)]*)", d["accel"]["detail"])
ph = ",".join(p.strip().rsplit(" ", 1)[0].replace(" ", "_") + "=" + p.strip().rsplit(" ", 1)[1]
              for p in m.group(1).split(",")) if m else "-"
print(sys.argv[2], d["accel"]["build_ms"], grow, ph)
PY
    done
done | python3 -c '
import collections, statistics as st, sys
r = collections.defaultdict(list)
ph = collections.defaultdict(lambda: collections.defaultdict(list))
for line in sys.stdin:
    b, build, grow, phases = line.split()
    r[b].append((float(build), float(grow)))
    for kv in phases.split(",") if phases != "-" else []:
        k, v = kv.split("=")
        ph[b][k].append(float(v))
for b, v in r.items():
    print("%s: build median %.1f ms (runs %s), growing exit boxes median %.1f ms" % (
        b, st.median(x for x, _ in v), " ".join("%.0f" % x for x, _ in v), st.median(y for _, y in v)))
    if ph[b]:
        print("    phase medians (ms): " + ", ".join("%s %.1f" % (k, st.median(x)) for k, x in ph[b].items()))
'
