#!/usr/bin/env bash
# Cost of instancing against the number of instances: a floor and N instances of the
# 327,680-triangle icosphere (`subdivisions = 7`, stored once) in a square field, N = 10,
# 100, 1000, 3000 (3000: 983 million triangles once placed), rendered on the CPU with
# the two-level BVH. Prints per N: triangles placed, the structure's build time, the whole
# process's wall time and peak RSS (/usr/bin/time -v), the render time and rays/s.
# Renders one at a time; the scenes are written to a temporary folder.
# Usage: ci/measure-instances.sh [FRAGTRACE_BINARY] [WIDTHxHEIGHT] [N...]
#        ci/measure-instances.sh --write-scene N FILE   (only write the scene of N instances)
set -euo pipefail
write_scene() {
python3 - "$1" "$2" <<'PY'
import math, sys
n, out = int(sys.argv[1]), sys.argv[2]
k = math.ceil(math.sqrt(n))
half = (k - 1) * 1.25
s = ('background = [0.5, 0.6, 0.8]\nambient = [0.1, 0.1, 0.1]\n'
     f'[camera]\neye = [0.0, {0.45 * half + 4:.2f}, {half + 6:.2f}]\nlook_at = [0.0, 0.0, 0.0]\nfov = 60\n'
     f'[[lights]]\nposition = [{half:.2f}, {2 * half + 10:.2f}, {half:.2f}]\nintensity = 0.9\n'
     '[materials.m]\nalbedo = [0.8, 0.3, 0.2]\nks = [0.4, 0.4, 0.4]\nns = 40\n'
     '[materials.floor]\nalbedo = [0.6, 0.6, 0.6]\n')
s += f'[[objects]]\nshape = "quad"\nsize = {2.5 * k + 4:.2f}\ntranslate = [0, -1, 0]\nmaterial = "floor"\n'
s += '[[objects]]\nshape = "sphere"\nsubdivisions = 7\nmaterial = "m"\ninstances = [\n'
for i in range(n):
    x, z = (i % k) * 2.5 - half, (i // k) * 2.5 - half
    s += f'  {{ translate = [{x:.2f}, 0, {z:.2f}], rotate = [0, {i * 37 % 360}, 0] }},\n'
s += ']\n'
open(out, "w").write(s)
PY
}
if [ "${1:-}" = --write-scene ]; then
    write_scene "$2" "$3"
    exit 0
fi
bin=${1:-target/release/fragtrace}
size=${2:-320x240}
shift $(( $# > 2 ? 2 : $# )) || true
counts=("$@")
[ ${#counts[@]} -gt 0 ] || counts=(10 100 1000 3000)
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
printf '%-9s %14s %9s %9s %9s %9s %8s\n' instances triangles build_ms render_ms wall_s peak_MB Mrays/s
for n in "${counts[@]}"; do
    write_scene "$n" "$dir/s.toml"
    /usr/bin/time -v -o "$dir/time.txt" "$bin" render "$dir/s.toml" --backend cpu --accel bvh \
        --width "${size%x*}" --height "${size#*x}" -q -o "$dir/x$n.png" --stats "$dir/s.json"
    wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, p, ":"); s = 0; for (i = 1; i <= n; i++) s = s * 60 + p[i]; print s}' "$dir/time.txt")
    rss=$(awk -F': ' '/Maximum resident set size/ {print $2 / 1024}' "$dir/time.txt")
    python3 -c "import json; d=json.load(open('$dir/s.json')); print('%-9s %14d %9.0f %9.0f %9.2f %9.0f %8.2f' % ('$n', d['triangles'], d['accel']['build_ms'], d['render_ms'], $wall, $rss, d['mrays_per_s']))"
    [ -z "${KEEP_IMAGES:-}" ] || cp "$dir/x$n.png" "$KEEP_IMAGES/instances-$n.png"
done
