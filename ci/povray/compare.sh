#!/usr/bin/env bash
# Issue 13: fragtrace CPU f32 vs POV-Ray 3.7 on scenes/bunny.toml's view, whole process each.
#
# Usage: compare.sh [WxH]            (default 1024x1024)
# Env:   RUNS=3                       timed runs per configuration (median reported)
#        NICE=                        prefix for every timed command (e.g. NICE=nice on a shared box)
#        FT=target/release/fragtrace  SCENE=scenes/bunny.toml (defaults, relative to the repo)
#        FRAGTRACE_MODEL_PATH=../shared/models  OUTDIR=/tmp (pov.png, ft.png, side-by-side)
#
# Both sides are timed with /usr/bin/time -f %e around the whole process: POV-Ray's parse of
# the generated .pov (the 69k-triangle mesh2) and its bounding build are included, as are
# fragtrace's OBJ load and grid build.  Both run 2 threads, 1 sample per pixel, no AA.
# Runs are interleaved round-robin (pov, irregular, uniform, bvh, pov, ...) so that a load change
# on the machine hits every configuration alike.  CPU seconds (user+sys, %U+%S) are reported
# next to the wall clock: on a shared machine they are the steadier of the two.
#
# Note: POV-Ray's `+A0.0` does NOT turn anti-aliasing off -- it turns it ON with threshold 0
# (every pixel supersampled, ~8.5 samples/pixel, ~15x slower); `+A0` is rejected outright.
# `-A` is the switch that turns it off, used below.
set -euo pipefail

SIZE=${1:-1024x1024}
W=${SIZE%x*}
H=${SIZE#*x}
[[ $W =~ ^[0-9]+$ && $H =~ ^[0-9]+$ ]] || { echo "usage: $0 [WxH]" >&2; exit 2; }
RUNS=${RUNS:-3}
NICE=${NICE:-}
HERE=$(cd "$(dirname "$0")" && pwd)
FT=${FT:-$HERE/../../target/release/fragtrace}
SCENE=${SCENE:-$HERE/../../scenes/bunny.toml}
export FRAGTRACE_MODEL_PATH=${FRAGTRACE_MODEL_PATH:-$HERE/../../../shared/models}
OUTDIR=${OUTDIR:-/tmp}
WORK=$(mktemp -d /tmp/ft-pov.XXXXXX)
trap 'rm -rf "$WORK"' EXIT

command -v povray >/dev/null || { echo "povray missing: apt-get install -y povray" >&2; exit 1; }
POV_VERSION=$(povray --version 2>&1 | grep -m1 '^POV-Ray' || true)
FT_REV=$(git -C "$(dirname "$FT")/../.." rev-parse --short HEAD 2>/dev/null || echo '?')

echo "== issue 13: bunny + mirror floor, ${W}x${H}, 2 threads, 1 spp, whole process"
echo "   $POV_VERSION; fragtrace $FT (repo HEAD $FT_REV, binary $(date -u -r "$FT" +%FT%TZ))"
echo "   host: $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg), $(date -u +%FT%TZ)"

# The .pov is generated once, outside the timing (it is the input file, like the TOML+OBJ).
python3 "$HERE/obj2pov.py" "$SCENE" "$WORK/scene.pov" --width "$W" --height "$H"

POV_CMD=(povray +W"$W" +H"$H" -D -A +WT2 File_Gamma=sRGB +FN +O"$OUTDIR/pov.png" "$WORK/scene.pov")
ft_cmd() { # $1 = accel
    echo env RAYON_NUM_THREADS=2 "$FT" render "$SCENE" --backend cpu --precision f32 \
        --accel "$1" --width "$W" --height "$H" -q -o "$OUTDIR/ft-$1.png"
}
echo "   povray:    ${POV_CMD[*]}"
echo "   fragtrace: $(ft_cmd '{irregular|uniform|bvh}')"

timed() { # label cmd... ; appends seconds to $WORK/label
    local label=$1; shift
    # povray.conf restricts file I/O to a few trees and "."; run from the work dir.
    if ! (cd "$WORK" && $NICE /usr/bin/time -f '%e %U %S' -o "$WORK/t" "$@" >"$WORK/$label.log" 2>&1); then
        echo "$label failed; log:" >&2; tail -20 "$WORK/$label.log" >&2; exit 1
    fi
    read -r wall usr sys <"$WORK/t"
    echo "$wall" >>"$WORK/$label"
    awk -v u="$usr" -v s="$sys" 'BEGIN {printf "%.2f\n", u + s}' >>"$WORK/$label.cpu"
}

for ((i = 1; i <= RUNS; i++)); do
    timed povray "${POV_CMD[@]}"
    for a in irregular uniform bvh; do
        # shellcheck disable=SC2046  # ft_cmd prints a word list without spaces inside words
        timed "ft-$a" $(ft_cmd "$a")
    done
    echo "   round $i: povray $(tail -1 "$WORK/povray") s, irregular $(tail -1 "$WORK/ft-irregular") s, uniform $(tail -1 "$WORK/ft-uniform") s, bvh $(tail -1 "$WORK/ft-bvh") s"
done

median() { sort -g "$1" | awk '{a[NR]=$1} END {print (NR%2 ? a[(NR+1)/2] : (a[NR/2]+a[NR/2+1])/2)}'; }
P=$(median "$WORK/povray")
PC=$(median "$WORK/povray.cpu")
# POV's own split of its time (last run): parse vs trace.
PARSE=$(tr '\r' '\n' <"$WORK/povray.log" | awk '/Parse Time:/ {gsub(/[()]/,""); print $(NF-1)}')
TRACE=$(tr '\r' '\n' <"$WORK/povray.log" | awk '/Trace Time:/ {gsub(/[()]/,""); print $(NF-1)}')
echo
printf '%-28s %8s %8s   %s\n' "configuration (medians)" "wall s" "cpu s" "fragtrace / povray (wall, cpu)"
printf '%-28s %8s %8s   %s\n' "povray 3.7 (-A, +WT2)" "$P" "$PC" "1.00 (last run: parse ${PARSE}s, trace ${TRACE}s)"
for a in irregular uniform bvh; do
    F=$(median "$WORK/ft-$a")
    FC=$(median "$WORK/ft-$a.cpu")
    printf '%-28s %8s %8s   %s\n' "fragtrace cpu f32 $a" "$F" "$FC" \
        "$(awk -v f="$F" -v p="$P" -v fc="$FC" -v pc="$PC" 'BEGIN {printf "%.2f, %.2f (%s)", f/p, fc/pc, (f<p ? "faster" : "slower")}')"
done

# Same view check: side by side, plus the mean absolute difference where ImageMagick is there.
cp "$OUTDIR/ft-irregular.png" "$OUTDIR/ft.png"
if command -v montage >/dev/null; then
    SBS="$OUTDIR/ft-vs-pov-${W}x${H}.png"
    montage -label 'fragtrace cpu f32' "$OUTDIR/ft.png" -label 'POV-Ray 3.7' "$OUTDIR/pov.png" \
        -tile 2x1 -geometry +4+4 "$SBS"
    MAE=$(compare -metric MAE "$OUTDIR/ft.png" "$OUTDIR/pov.png" null: 2>&1 | sed 's/.*(\(.*\))/\1/' || true)
    echo
    echo "images: $OUTDIR/ft.png, $OUTDIR/pov.png, side by side $SBS"
    echo "mean absolute difference (0..1 of full scale): $MAE"
fi
