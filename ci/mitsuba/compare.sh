#!/usr/bin/env bash
# fragtrace's CPU backend against Mitsuba 3 on the equal-work view (ci/peers/equal-work.toml,
# and ci/mitsuba/equal-work.py for Mitsuba: the bunny on a 4x4 diffuse floor, one point light,
# primary + one shadow ray per hit, 1 spp), side by side in one run.
#
# Usage: compare.sh [SIZE]             (default 1024: SIZE x SIZE pixels)
# Env:   RUNS=5 (timed rounds, medians reported; the configurations interleaved round-robin
#        so a load change on the machine hits all alike), THREADS=2,
#        FT=target/release/fragtrace, FRAGTRACE_MODEL_PATH=../shared/models,
#        DRJIT_LIBLLVM_PATH (default: Debian's libLLVM 19, `apt-get install libllvm19`)
# Needs: python3 -m pip install mitsuba==3.9.1 drjit==1.5.0
#
# Configurations: Mitsuba `scalar_rgb` (Embree, one ray at a time) and `llvm_ad_rgb` (Embree
# packets, vectorised integrator; skipped with a note when no LLVM 16+ is found); fragtrace's
# BVH in f32 by each CPU path: `packet` (the default: ray packets), `simd` (one ray at a
# time, vectorised triangle tests) and `scalar`.
# Reported per configuration: the structure's build (fragtrace accel build; Mitsuba
# mi.load_dict, which includes its OBJ load), the render (fragtrace render_ms; Mitsuba
# mi.render to the evaluated image after a warm-up render) and the whole process
# (/usr/bin/time, wall); then each fragtrace path's render over each Mitsuba variant's, per
# round, and the packet path's image against the scalar path's.
set -euo pipefail
SIZE=${1:-1024}
RUNS=${RUNS:-5}
THREADS=${THREADS:-2}
HERE=$(cd "$(dirname "$0")" && pwd)
FT=${FT:-$HERE/../../target/release/fragtrace}
export FRAGTRACE_MODEL_PATH=${FRAGTRACE_MODEL_PATH:-$HERE/../../../shared/models}
for lib in /usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 /usr/lib/x86_64-linux-gnu/libLLVM-19.so; do
    [ -n "${DRJIT_LIBLLVM_PATH:-}" ] || { [ -f "$lib" ] && export DRJIT_LIBLLVM_PATH=$lib; }
done
WORK=$(mktemp -d /tmp/ft-mi.XXXXXX)
trap 'rm -rf "$WORK"' EXIT
python3 -c 'import mitsuba' 2>/dev/null || { echo "mitsuba missing: python3 -m pip install mitsuba==3.9.1 drjit==1.5.0" >&2; exit 1; }
variants=(scalar_rgb)
if python3 "$HERE/equal-work.py" --size 16 --threads 1 --variant llvm_ad_rgb >/dev/null 2>&1; then
    variants+=(llvm_ad_rgb)
else
    echo "note: llvm_ad_rgb does not run here (LLVM 16+ missing: apt-get install libllvm19); skipped"
fi
paths=(packet simd scalar)

echo "== equal work, ${SIZE}x${SIZE}, $THREADS threads, 1 spp, primary + shadow rays, $RUNS rounds"
echo "   fragtrace $FT (repo HEAD $(git -C "$HERE" rev-parse --short HEAD 2>/dev/null || echo '?')); $(python3 -c 'import mitsuba, drjit; print("mitsuba", mitsuba.__version__, "drjit", drjit.__version__)')"
echo "   host: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), load average $(cut -d' ' -f1-3 /proc/loadavg), $(date -u +%FT%TZ)"

ft() { # path: a line "build render whole rays" in ft-<path>
    /usr/bin/time -f '%e' -o "$WORK/t" env RAYON_NUM_THREADS="$THREADS" "$FT" render "$HERE/../peers/equal-work.toml" \
        --backend cpu --precision f32 --cpu-path "$1" --accel bvh --width "$SIZE" --height "$SIZE" -q \
        -o "$WORK/ft-$1.exr" --stats "$WORK/s.json"
    python3 - "$WORK/s.json" "$(cat "$WORK/t")" >>"$WORK/ft-$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print(d["grid_build_ms"] / 1e3, d["render_ms"] / 1e3, sys.argv[2], d["rays"]["total"])
PY
}
mi() { # variant: a line "build render whole" in mi-<variant>
    /usr/bin/time -f '%e' -o "$WORK/t" python3 "$HERE/equal-work.py" --size "$SIZE" --threads "$THREADS" \
        --variant "$1" >"$WORK/mi.log"
    awk -v w="$(cat "$WORK/t")" '{print $2, $4, w}' "$WORK/mi.log" >>"$WORK/mi-$1"
}
for ((i = 1; i <= RUNS; i++)); do
    line="   round $i:"
    for v in "${variants[@]}"; do mi "$v"; line+=" $v $(tail -1 "$WORK/mi-$v" | cut -d' ' -f2);"; done
    for p in "${paths[@]}"; do ft "$p"; line+=" $p $(tail -1 "$WORK/ft-$p" | cut -d' ' -f2);"; done
    echo "$line (render s)"
done
med() { awk -v c="$2" '{print $c}' "$1" | sort -g | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
echo
printf '%-24s %9s %9s %9s\n' "medians (s)" build render whole
for c in "${variants[@]/#/mi-}" "${paths[@]/#/ft-}"; do
    printf '%-24s %9s %9s %9s\n' "$c" "$(med "$WORK/$c" 1)" "$(med "$WORK/$c" 2)" "$(med "$WORK/$c" 3)"
done
echo "rays per frame (fragtrace): $(awk '{print $4}' "$WORK/ft-packet" | head -1)"
echo "render over Mitsuba's, per round, then the median:"
for p in "${paths[@]}"; do
    for v in "${variants[@]}"; do
        r=$(paste <(awk '{print $2}' "$WORK/ft-$p") <(awk '{print $2}' "$WORK/mi-$v") | awk '{printf "%.2f ", $1/$2}')
        m=$(echo "$r" | tr ' ' '\n' | grep . | sort -g | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}')
        printf '   %-8s / %-12s %s(median %s)\n' "$p" "$v" "$r" "$m"
    done
done
# (Mitsuba's image is not compared: its point light falls off with distance squared and its
# film has its own response; the work per pixel is what is equal.)
echo "images: packet against scalar (must be identical):"
"$FT" compare "$WORK/ft-scalar.exr" "$WORK/ft-packet.exr"
