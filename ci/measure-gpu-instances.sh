#!/usr/bin/env bash
# Issue 53, instancing on the GPU: every kernel with --accel uniform walks an instanced
# scene as two levels (accel/grid_instances.rs, glsl120/instance_walk.glsl). Renders
# the 36-sphere scene of ci/measure-large.sh (icospheres at subdivisions = 7, 327,680
# triangles each, on a floor) written twice, as 36 objects (stored flat) and as one object
# with 36 instances, then N instances of the same sphere (default 3000: 983 million
# triangles placed), each on the GPU (the compute kernel unless --flags says otherwise),
# one render at a time; prints per render:
# exit status, whole-process wall time and peak RSS (/usr/bin/time -v), the path that ran
# (kernel/structure, 2-level or flat), the structure's build, the bytes uploaded, the
# upload, the render (ms, from --stats) and, for the instanced 36, the image against the
# flat one. --flags replaces the kernel and structure flags after `--backend gl`:
# `--flags ""` measures the default `render --backend gl` (kernel and structure left to
# auto, which takes an instanced scene to the two levels: on the compute kernel where the
# context runs it, else on the fastest fragment kernel; before those changes, flat on the
# irregular grid).
#
#   ci/measure-gpu-instances.sh [--size PIXELS] [--bin FRAGTRACE] [--out DIR]
#                               [--flags "FLAGS"] [N]
#
# Defaults: --size 64, --bin target/release/fragtrace, --out target/gpu-instances,
# --flags "--kernel compute --accel uniform", N 3000.
set -euo pipefail
out=target/gpu-instances
bin=target/release/fragtrace
size=64
flags="--kernel compute --accel uniform"
while [ $# -gt 0 ]; do
    case $1 in
        --size) size=$2; shift 2 ;;
        --bin) bin=$2; shift 2 ;;
        --out) out=$2; shift 2 ;;
        --flags) flags=$2; shift 2 ;;
        -h|--help) sed -n '2,20p' "$0"; exit 0 ;;
        --*) echo "unknown option $1 (see --help)" >&2; exit 2 ;;
        *) break ;;
    esac
done
many=${1:-3000}
mkdir -p "$out"

scene() { # N MODE(flat|instanced) -> spheres on a square lattice over a floor
    python3 - "$1" "$2" <<'PY'
import math, sys
n, mode = int(sys.argv[1]), sys.argv[2]
side = math.ceil(math.sqrt(n))
half = side - 1
print(f"""background = [0.2, 0.25, 0.3]
ambient = [0.1, 0.1, 0.1]
max_depth = 2
[camera]
eye = [0.0, {side * 1.1 + 1.0:.2f}, {side * 1.9 + 2.0:.2f}]
look_at = [0.0, 0.0, 0.0]
fov = 45
[[lights]]
position = [{side:.1f}, {side * 2.0:.1f}, {side:.1f}]
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
at = [(2.0 * (i % side) - half, 2.0 * (i // side) - half) for i in range(n)]
if mode == "flat":
    for x, z in at:
        print(f'[[objects]]\nshape = "sphere"\nsubdivisions = 7\nradius = 0.8\n'
              f'translate = [{x:.1f}, 0.8, {z:.1f}]\nmaterial = "ball"\n')
else:
    print('[[objects]]\nshape = "sphere"\nsubdivisions = 7\nradius = 0.8\nmaterial = "ball"\ninstances = [')
    for x, z in at:
        print(f'  {{ translate = [{x:.1f}, 0.8, {z:.1f}] }},')
    print(']')
PY
}

run() { # name scene ref : one compute render with its time, memory and stats
    local name=$1 toml=$2 ref=$3 log="$out/$1.log" stats="$out/$1.json" img="$out/$1.exr"
    rm -f "$stats"
    # shellcheck disable=SC2086 # the flags are words
    if /usr/bin/time -v "$bin" render "$toml" --backend gl $flags \
        --width "$size" --height "$size" -o "$img" --stats "$stats" -q >"$log" 2>&1; then
        status=ok
    else
        status="exit $?"
    fi
    local rss wall cmp=""
    rss=$(awk -F': ' '/Maximum resident set size/ {printf "%.2f", $2 / 1048576}' "$log")
    wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$log")
    if [ "$status" = ok ] && [ -n "$ref" ]; then
        cmp="vs flat: $("$bin" compare "$img" "$ref")"
    fi
    python3 - "$stats" "$name" "$status" "$wall" "$rss" "$cmp" <<'PY'
import json, sys
path, name, status, wall, rss, cmp = sys.argv[1:]
try:
    s = json.load(open(path)); g = s["gpu"]
    w = s["plan"].split()
    ran = f"{w[w.index('--kernel') + 1]}/{w[w.index('--accel') + 1]}"
    ran += "/2-level" if "instanced" in s["accel"] else "/flat"
    f = (f"{ran:24} build {s['grid_build_ms']:8.0f} ms  uploaded {g['upload_bytes'] / 1e6:9.2f} MB  "
         f"upload {g['upload_ms']:7.0f} ms  render {s['render_ms']:8.0f} ms")
except (OSError, ValueError, KeyError, TypeError):
    f = "(no stats)"
print(f"{name:16} {status:7} wall {wall:>8}  RSS {rss:>5} GB  {f}  {cmp}")
PY
    [ "$status" = ok ] || grep -m2 -iE 'error|limit' "$log" | sed 's/^/    /' || true
}

scene 36 flat >"$out/spheres-36-flat.toml"
scene 36 instanced >"$out/spheres-36-instanced.toml"
scene "$many" instanced >"$out/spheres-$many-instanced.toml"
run spheres-36-flat "$out/spheres-36-flat.toml" ""
run spheres-36-inst "$out/spheres-36-instanced.toml" "$out/spheres-36-flat.exr"
run "spheres-$many-inst" "$out/spheres-$many-instanced.toml" ""
