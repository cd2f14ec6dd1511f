#!/usr/bin/env bash
# Issue 53: scenes past the GPU's old 2^24 cliff, measured as a user runs them. Writes
# spheres-N.toml (N icospheres at subdivisions = 7, 327,680 triangles each, on a floor quad:
# 12 -> 3.9 M triangles, 36 -> 11.8 M, 100 -> 32.8 M) and renders each on the CPU (the
# reference) and on each GPU kernel and structure, one render at a time, printing per render:
# exit status, whole-process wall time and peak RSS (/usr/bin/time -v), the structure's
# build, the scene's packing and upload, the trace and the whole render (ms, from --stats),
# rays/s over the render and over the trace alone, and the image against the CPU's (RMSE,
# share of pixels off by more than 0.01; "identical" when equal). A refusal prints its one
# line. Results also go to OUT/results.tsv.
#
#   ci/measure-large.sh [--size PIXELS] [--kernels "cpu compute looped"]
#                       [--accels "uniform irregular"] [--out DIR] [--bin FRAGTRACE] [N...]
#
# Defaults: --size 128 (a square image), --kernels "cpu compute looped", --accels
# "uniform irregular", --out target/large, --bin target/release/fragtrace, N = 36 100. The
# CPU image is always rendered first (the reference), whether or not `cpu` is listed.
# Env: MAIN (a second binary whose CPU render is timed beside this one's). The H200 run:
#   ci/measure-large.sh --size 4096 --kernels "cpu compute looped" --out /tmp/large 36 100
# The 100-sphere scene's CPU build takes about 5 GB; check `free -g` first.
set -euo pipefail
out=target/large
bin=target/release/fragtrace
size=128
kernels="cpu compute looped"
accels="uniform irregular"
while [ $# -gt 0 ]; do
    case $1 in
        --size) size=$2; shift 2 ;;
        --kernels) kernels=$2; shift 2 ;;
        --accels) accels=$2; shift 2 ;;
        --out) out=$2; shift 2 ;;
        --bin) bin=$2; shift 2 ;;
        -h|--help) sed -n '2,22p' "$0"; exit 0 ;;
        --*) echo "unknown option $1 (see --help)" >&2; exit 2 ;;
        *) break ;;
    esac
done
[ $# -gt 0 ] && counts=("$@") || counts=(36 100)
main=${MAIN:-}
export FRAGTRACE_MODEL_PATH="${FRAGTRACE_MODEL_PATH:-$(cd "$(dirname "$0")/../.." && pwd)/shared/models}"
mkdir -p "$out"
tsv="$out/results.tsv"
printf 'render\tstatus\twall\tpeak_rss_gb\tbuild_ms\tupload_ms\ttrace_ms\trender_ms\tmrays_s\ttrace_mrays_s\tvs_cpu\n' >"$tsv"

scene() { # N -> spheres on a square lattice over a floor
    local n=$1 side
    side=$(python3 -c "import math; print(math.ceil(math.sqrt($n)))")
    python3 - "$n" "$side" <<'PY'
import sys
n, side = int(sys.argv[1]), int(sys.argv[2])
half = side - 1
print(f"""# {n} icospheres at subdivisions = 7 (327,680 triangles each) on a floor: {n * 327680 + 2:,} triangles.
# Written by ci/measure-large.sh.
background = [0.2, 0.25, 0.3]
ambient = [0.1, 0.1, 0.1]
max_depth = 2

[camera]
eye = [0.0, {side * 1.1 + 1.0:.2f}, {side * 1.9 + 2.0:.2f}]
look_at = [0.0, 0.0, 0.0]
fov = 45

[image]
width = 256
height = 256

[[lights]]
position = [{side:.1f}, {side * 2.0:.1f}, {side:.1f}]
color = [1.0, 1.0, 1.0]
intensity = 1.0

[materials.floor]
albedo = [0.6, 0.6, 0.6]
kd = 0.8

[materials.ball]
albedo = [0.8, 0.3, 0.2]
kd = 0.7
ks = [0.3, 0.3, 0.3]
ns = 40

[[objects]]
shape = "quad"
size = [{side * 2.0 + 2.0:.1f}, {side * 2.0 + 2.0:.1f}]
material = "floor"
""")
for i in range(n):
    x, z = i % side, i // side
    print(f"""[[objects]]
shape = "sphere"
subdivisions = 7
radius = 0.8
translate = [{2.0 * x - half:.1f}, 0.8, {2.0 * z - half:.1f}]
material = "ball"
""")
PY
}

run() { # name image ref args... : one render with its time, memory, stats and image check
    local name=$1 img=$2 ref=$3; shift 3
    local log="$out/$name.log" stats="$out/$name.json"
    rm -f "$stats"
    if /usr/bin/time -v "$bin" render "$@" -o "$img" --stats "$stats" -v >"$log" 2>&1; then status=ok; else status="exit $?"; fi
    local rss wall figures cmp=""
    rss=$(awk -F': ' '/Maximum resident set size/ {printf "%.2f", $2 / 1048576}' "$log")
    wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$log")
    figures=$(python3 - "$stats" <<'PY'
import json, sys
try:
    s = json.load(open(sys.argv[1]))
except (OSError, ValueError):
    print("\t".join(["-"] * 6)); sys.exit()
g = s.get("gpu") or {}
rays = s["rays"]["total"]
trace = g.get("trace_ms") or s["render_ms"] - (g.get("upload_ms") or 0.0) - (g.get("compile_ms") or 0.0)
f = lambda v: "-" if v is None else f"{v:.0f}"
print("\t".join([f(s.get("grid_build_ms")), f(g.get("upload_ms")), f(trace), f(s["render_ms"]),
                 f"{s['mrays_per_s']:.3f}", f"{rays / trace / 1e3:.3f}" if trace else "-"]))
PY
)
    if [ "$status" = ok ] && [ -n "$ref" ] && [ "$img" != "$ref" ] && [ -f "$ref" ]; then
        cmp=$("$bin" compare "$img" "$ref" | awk '{ if ($4 == "identical") print "identical"; else print "RMSE " $2 ", " $(NF-2) " of pixels off" }')
    fi
    IFS=$'\t' read -r build upload trace render mrays tmrays <<<"$figures"
    printf '%-30s %-7s wall %-8s RSS %6s GB  build %7s ms  upload %7s ms  trace %8s ms  render %8s ms  %7s Mrays/s (trace %s)  %s\n' \
        "$name" "$status" "$wall" "$rss" "$build" "$upload" "$trace" "$render" "$mrays" "$tmrays" "${cmp:+vs CPU: $cmp}"
    printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$status" "$wall" "$rss" "$build" "$upload" "$trace" "$render" "$mrays" "$tmrays" "$cmp" >>"$tsv"
    [ "$status" = ok ] || grep -m2 -iE 'error|limit' "$log" | sed 's/^/    /' || true
}

for n in "${counts[@]}"; do
    toml="$out/spheres-$n.toml"
    scene "$n" >"$toml"
    dims=(--width "$size" --height "$size")
    ref="$out/spheres-$n-cpu.png"
    run "spheres-$n-cpu" "$ref" "" "$toml" --backend cpu "${dims[@]}"
    if [ -n "$main" ]; then
        bin_was=$bin bin=$main
        run "spheres-$n-cpu-main" "$out/spheres-$n-cpu-main.png" "$ref" "$toml" --backend cpu "${dims[@]}"
        bin=$bin_was
    fi
    for k in $kernels; do
        [ "$k" = cpu ] && continue
        for a in $accels; do
            run "spheres-$n-$k-$a" "$out/spheres-$n-$k-$a.png" "$ref" "$toml" --backend gl --kernel "$k" --accel "$a" "${dims[@]}"
        done
    done
done
