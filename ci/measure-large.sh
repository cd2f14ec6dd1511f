#!/usr/bin/env bash
# Issue 53 (part A): scenes past the GPU's old 2^24 cliff, measured as a user runs them.
# Writes spheres-N.toml (N icospheres at subdivisions = 7, 327,680 triangles each, on a
# floor quad: 36 -> 11.8 M triangles, 100 -> 32.8 M) and renders each at a small size on
# the CPU and, where a GL context is there, the compute and looped kernels, reporting the
# build time (-v), peak RSS and whole-process time (/usr/bin/time -v).
#
#   ci/measure-large.sh [OUT_DIR] [N...]     (defaults: target/large, 36 100)
#
# Env: FRAGTRACE (binary, default target/release/fragtrace), SIZE (image side, default 128),
# KERNELS (default "cpu compute looped"), GPU_ACCELS (the GPU's structures, default
# "irregular uniform"), MAIN (a second binary, e.g. /work/bin/fragtrace-main, whose CPU render
# is timed beside this one's). Runs one render at a time: the 100-sphere scene takes several
# GB, and the GPU kernels refuse it (more than 2^24 triangles).
set -euo pipefail
out=${1:-target/large}
shift || true
[ $# -gt 0 ] && counts=("$@") || counts=(36 100)
bin=${FRAGTRACE:-target/release/fragtrace}
size=${SIZE:-128}
kernels=${KERNELS:-cpu compute looped}
accels=${GPU_ACCELS:-irregular uniform}
main=${MAIN:-}
mkdir -p "$out"

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

run() { # name args... : one render with its time and memory
    local name=$1; shift
    local log="$out/$name.log"
    if /usr/bin/time -v "$bin" render "$@" -v >"$log" 2>&1; then status=ok; else status="exit $?"; fi
    local rss wall build
    rss=$(awk -F': ' '/Maximum resident set size/ {printf "%.2f GB", $2 / 1048576}' "$log")
    wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$log")
    build=$(grep -oiE '(build|built)[^,;]* [0-9.]+ ?m?s' "$log" | head -1 || true)
    printf '%-28s %-8s wall %-9s peak RSS %-9s %s\n' "$name" "$status" "$wall" "$rss" "$build"
    [ "$status" = ok ] || grep -m2 -iE 'error|limit' "$log" | sed 's/^/    /' || true
}

for n in "${counts[@]}"; do
    toml="$out/spheres-$n.toml"
    scene "$n" >"$toml"
    for k in $kernels; do
        case $k in
            cpu)
                run "spheres-$n-cpu" "$toml" --backend cpu --width "$size" --height "$size" -o "$out/spheres-$n-cpu.png"
                if [ -n "$main" ]; then
                    bin_was=$bin bin=$main
                    run "spheres-$n-cpu-main" "$toml" --backend cpu --width "$size" --height "$size" -o "$out/spheres-$n-cpu-main.png"
                    bin=$bin_was
                fi ;;
            *)
                for a in $accels; do
                    run "spheres-$n-$k-$a" "$toml" --backend gl --kernel "$k" --accel "$a" --width "$size" --height "$size" -o "$out/spheres-$n-$k-$a.png"
                    [ -f "$out/spheres-$n-$k-$a.png" ] && [ -f "$out/spheres-$n-cpu.png" ] &&
                        echo "    against the CPU: $("$bin" compare "$out/spheres-$n-$k-$a.png" "$out/spheres-$n-cpu.png")"
                done ;;
        esac
    done
done
