#!/usr/bin/env bash
# Cost and value of each robustness technique (docs/robustness.md, "Cost of each
# technique"). Renders the built-in default scene at 512x512 with the default techniques
# and with each technique switched to its classic alternative, on the CPU in f64 and f32
# and on the GL backend (looped kernel, the default), RUNS times each, interleaved (round
# by round) so that load drifting on a shared machine hits every setting alike. Reports
# the median render time (`render_ms` of `--stats`, wall clock) and the median CPU time of
# the whole process (user + system from /usr/bin/time: llvmpipe renders on the CPU too; far
# less sensitive than wall time to other jobs sharing the cores), each with its ratio to
# the default technique on the same backend, and the RMSE and share of pixels differing by more than 0.01 (largest
# channel, linear EXR values) against the default-technique f64 image, from
# `fragtrace compare`. Not run in CI; run by hand:
#   ci/measure-techniques.sh [OUT_DIR]      (RUNS=3 by default)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
bin=target/release/fragtrace
out=${1:-target/measure-techniques}
runs=${RUNS:-3}
mkdir -p "$out"
size=(--width 512 --height 512)

settings=("default" "intersect-moller-trumbore" "t-bound-off" "offset-epsilon" "terminator-exact")
flags_of() {
  case "$1" in
    default) echo "" ;;
    intersect-moller-trumbore) echo "--intersect moller-trumbore" ;;
    t-bound-off) echo "--t-bound off" ;;
    offset-epsilon) echo "--offset epsilon" ;;
    terminator-exact) echo "--terminator exact" ;;
  esac
}
backends=("cpu-f64" "cpu-f32" "gl")
backend_flags() {
  case "$1" in
    cpu-f64) echo "--backend cpu --accel irregular --precision f64" ;;
    cpu-f32) echo "--backend cpu --accel irregular --precision f32" ;;
    gl) echo "--backend gl" ;;
  esac
}

echo "machine: $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg) at start" >&2
for r in $(seq 1 "$runs"); do
  for b in "${backends[@]}"; do
    for s in "${settings[@]}"; do
      # shellcheck disable=SC2046
      /usr/bin/time -f "%U %S" -o "$out/$b.$s.$r.time" \
        "$bin" render "${size[@]}" -q $(backend_flags "$b") $(flags_of "$s") \
        --stats "$out/$b.$s.$r.json" -o "$out/$b.$s.exr"
      echo "run $r $b $s: $(jq .render_ms "$out/$b.$s.$r.json") ms, cpu $(awk '{print $1 + $2}' "$out/$b.$s.$r.time") s" >&2
    done
  done
done
echo "machine: load average $(cut -d' ' -f1-3 /proc/loadavg) at end" >&2

median() { sort -g | awk '{a[NR]=$1} END {print (NR % 2) ? a[(NR+1)/2] : (a[NR/2] + a[NR/2+1]) / 2}'; }

cpu_s() { awk '{print $1 + $2}' "$1"; }
echo "| setting | backend | median render ms (of $runs) | ratio | median CPU s | ratio | RMSE vs default f64 | pixels > 0.01 vs default f64 |"
echo "|---|---|---|---|---|---|---|---|"
for b in "${backends[@]}"; do
  base=$(for r in $(seq 1 "$runs"); do jq .render_ms "$out/$b.default.$r.json"; done | median)
  cbase=$(for r in $(seq 1 "$runs"); do cpu_s "$out/$b.default.$r.time"; done | median)
  for s in "${settings[@]}"; do
    med=$(for r in $(seq 1 "$runs"); do jq .render_ms "$out/$b.$s.$r.json"; done | median)
    cmed=$(for r in $(seq 1 "$runs"); do cpu_s "$out/$b.$s.$r.time"; done | median)
    cratio=$(awk -v m="$cmed" -v b="$cbase" 'BEGIN {printf "%.3f", m / b}')
    cmp=$("$bin" compare "$out/$b.$s.exr" "$out/cpu-f64.default.exr")
    rmse=$(echo "$cmp" | awk '{print $2}')
    share=$(echo "$cmp" | sed -E 's/.*pixels > 0.01: ([0-9.]+%).*/\1/')
    ratio=$(awk -v m="$med" -v b="$base" 'BEGIN {printf "%.3f", m / b}')
    printf "| %s | %s | %.0f | %s | %.1f | %s | %s | %s |\n" "$s" "$b" "$med" "$ratio" "$cmed" "$cratio" "$rmse" "$share"
  done
done
