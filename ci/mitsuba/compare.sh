#!/usr/bin/env bash
# Issue 27: fragtrace's CPU backend against Mitsuba 3 `scalar_rgb` (Embree's BVH) on the
# equal-work view (ci/peers/equal-work.toml, and ci/mitsuba/equal-work.py for Mitsuba: the bunny on a 4x4 diffuse
# floor, one point light, primary + one shadow ray per hit, 1 spp).
#
# Usage: compare.sh [SIZE]             (default 1024: SIZE x SIZE pixels)
# Env:   RUNS=3 (timed rounds, medians reported; the configurations interleaved round-robin
#        so a load change on the machine hits all alike), THREADS=2,
#        FT=target/release/fragtrace, FRAGTRACE_MODEL_PATH=../shared/models
# Needs: python3 -m pip install mitsuba==3.9.1 drjit==1.5.0
#
# Configurations: fragtrace's irregular grid by the vectorised (simd) and scalar f32 paths,
# and its BVH (`--accel bvh`, vectorised), against Mitsuba.
# Reported per configuration: the structure's build (fragtrace grid_build_ms; Mitsuba
# mi.load_dict, which includes its OBJ load), the render (fragtrace render_ms; Mitsuba
# mi.render after a warm-up render) and the whole process (/usr/bin/time, wall).
set -euo pipefail
SIZE=${1:-1024}
RUNS=${RUNS:-3}
THREADS=${THREADS:-2}
HERE=$(cd "$(dirname "$0")" && pwd)
FT=${FT:-$HERE/../../target/release/fragtrace}
export FRAGTRACE_MODEL_PATH=${FRAGTRACE_MODEL_PATH:-$HERE/../../../shared/models}
WORK=$(mktemp -d /tmp/ft-mi.XXXXXX)
trap 'rm -rf "$WORK"' EXIT
python3 -c 'import mitsuba' 2>/dev/null || { echo "mitsuba missing: python3 -m pip install mitsuba==3.9.1 drjit==1.5.0" >&2; exit 1; }

echo "== issue 27: equal work, ${SIZE}x${SIZE}, $THREADS threads, 1 spp, primary + shadow rays"
echo "   fragtrace $FT (repo HEAD $(git -C "$HERE" rev-parse --short HEAD 2>/dev/null || echo '?')); $(python3 -c 'import mitsuba, drjit; print("mitsuba", mitsuba.__version__, "drjit", drjit.__version__)')"
echo "   host: $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg), $(date -u +%FT%TZ)"

ft() { # path [accel]: results in ft-<path> (irregular grid) or ft-<accel>
    local accel=${2:-irregular} label=$1
    [ "$accel" = irregular ] || label=$accel
    /usr/bin/time -f '%e' -o "$WORK/t" env RAYON_NUM_THREADS="$THREADS" "$FT" render "$HERE/../peers/equal-work.toml" \
        --backend cpu --precision f32 --cpu-path "$1" --accel "$accel" --width "$SIZE" --height "$SIZE" -q \
        -o "$WORK/ft-$label.png" --stats "$WORK/s.json"
    python3 - "$WORK/s.json" "$(cat "$WORK/t")" >>"$WORK/ft-$label" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print(d["grid_build_ms"] / 1e3, d["render_ms"] / 1e3, sys.argv[2], d["rays"]["total"])
PY
}
mi() {
    /usr/bin/time -f '%e' -o "$WORK/t" python3 "$HERE/equal-work.py" --size "$SIZE" --threads "$THREADS" >"$WORK/mi.log"
    awk -v w="$(cat "$WORK/t")" '{print $2, $4, w}' "$WORK/mi.log" >>"$WORK/mitsuba"
}
for ((i = 1; i <= RUNS; i++)); do
    mi; ft simd; ft scalar; ft simd bvh
    echo "   round $i: mitsuba $(tail -1 "$WORK/mitsuba"); simd $(tail -1 "$WORK/ft-simd"); scalar $(tail -1 "$WORK/ft-scalar"); bvh $(tail -1 "$WORK/ft-bvh") (build render whole [rays])"
done
med() { awk -v c="$2" '{print $c}' "$1" | sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
echo
printf '%-30s %9s %9s %9s\n' "medians (s)" build render whole
for c in mitsuba ft-simd ft-scalar ft-bvh; do
    printf '%-30s %9s %9s %9s\n' "$c" "$(med "$WORK/$c" 1)" "$(med "$WORK/$c" 2)" "$(med "$WORK/$c" 3)"
done
echo "rays per frame: $(awk '{print $4}' "$WORK/ft-simd" | head -1)"
echo "ratios to mitsuba, per round (build, render, whole):"
for ((i = 1; i <= RUNS; i++)); do
    for c in ft-simd ft-scalar ft-bvh; do
        paste <(sed -n "${i}p" "$WORK/$c") <(sed -n "${i}p" "$WORK/mitsuba") |
            awk -v c="$c" -v i="$i" '{printf "   round %d %-10s %.2f %.2f %.2f\n", i, c, $1/$5, $2/$6, $3/$7}'
    done
done
echo "BVH image against the irregular grid's (same view, f32):"
"$FT" compare "$WORK/ft-simd.png" "$WORK/ft-bvh.png"
