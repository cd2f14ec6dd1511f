#!/usr/bin/env bash
# Build-time scaling of the acceleration structures: icosphere scenes of 10k to 3.3M
# triangles (written to a temporary folder), each rendered at 8x8 on the CPU so that the
# build dominates; prints accel.build_ms per scene and thread count.
# Usage: ci/measure-build.sh [FRAGTRACE_BINARY] [ACCEL] [THREADS...]
#        ci/measure-build.sh --write-scenes DIR   (only write the scenes, s010k.toml .. s3m.toml)
set -euo pipefail
write_scenes() {
python3 - "$1" <<'PY'
import math, sys
out = sys.argv[1]
for name, (sub, n) in {"s010k": (4, 2), "s100k": (5, 5), "s330k": (7, 1), "s1m": (7, 4), "s3m": (7, 10)}.items():
    s = ('background = [0.5, 0.6, 0.8]\nambient = [0.1, 0.1, 0.1]\n'
         '[camera]\neye = [0.0, 4.0, 12.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 60\n'
         '[[lights]]\nposition = [5.0, 10.0, 5.0]\nintensity = 0.9\n'
         '[materials.m]\nalbedo = [0.8, 0.3, 0.2]\n')
    k = math.ceil(math.sqrt(n))
    for i in range(n):
        x, z = (i % k) * 2.2 - (k - 1) * 1.1, (i // k) * 2.2 - (k - 1) * 1.1
        s += f'[[objects]]\nshape = "sphere"\nsubdivisions = {sub}\ntranslate = [{x}, 0.0, {z}]\nmaterial = "m"\n'
    open(f"{out}/{name}.toml", "w").write(s)
PY
}
if [ "${1:-}" = --write-scenes ]; then
    mkdir -p "$2"
    write_scenes "$2"
    exit 0
fi
bin=${1:-target/release/fragtrace}
accel=${2:-irregular}
shift $(( $# > 2 ? 2 : $# )) || true
threads=("$@")
[ ${#threads[@]} -gt 0 ] || threads=("$(nproc)" 2)
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
write_scenes "$dir"
printf '%-8s %10s %8s %12s\n' threads triangles build_ms triangles/s
for t in "${threads[@]}"; do
    for s in s010k s100k s330k s1m s3m; do
        RAYON_NUM_THREADS=$t "$bin" render "$dir/$s.toml" --backend cpu --accel "$accel" \
            --width 8 --height 8 -q -o "$dir/x.png" --stats "$dir/s.json"
        python3 -c "import json,sys; d=json.load(open('$dir/s.json')); b=d['accel']['build_ms']; print('%-8s %10d %8.0f %12.0f' % ('$t', d['triangles'], b, d['triangles']/b*1e3))"
    done
done
