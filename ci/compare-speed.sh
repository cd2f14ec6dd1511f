#!/usr/bin/env bash
# Whole-process time of two fragtrace binaries on the same renders, interleaved run by run
# (so load on a shared machine falls on both alike), with medians and the NEW/OLD ratio:
# the check that a change is no slower.
#
#   ci/compare-speed.sh OLD_BINARY NEW_BINARY [RUNS]     (RUNS defaults to 3)
#
# NEW_ARGS adds flags to the new binary's renders only (as in ci/compare-binaries.sh).
# Meshes come from FRAGTRACE_MODEL_PATH (default ../shared/models).
set -uo pipefail
cd "$(dirname "$0")/.."
old=$1 new=$2 runs=${3:-3}
export FRAGTRACE_MODEL_PATH="${FRAGTRACE_MODEL_PATH:-$(cd .. && pwd)/shared/models}"
read -r -a new_extra <<< "${NEW_ARGS:-}"
out=$(mktemp -d)
configs=(
    "default-gl:--backend gl"
    "default-looped:--backend gl --kernel looped"
    "bunny-gl:scenes/bunny.toml --backend gl"
    "bunny-multipass-png:scenes/bunny.toml --backend gl --kernel multipass"
    "glass-gl:scenes/glass.toml --backend gl --width 320 --height 240"
)
med() { sort -n | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
printf '%-22s %10s %10s %7s\n' config old_ms new_ms new/old
for cfg in "${configs[@]}"; do
    tag=${cfg%%:*}; read -r -a flags <<< "${cfg#*:}"
    : > "$out/old" ; : > "$out/new"
    for _ in $(seq "$runs"); do
        for which in old new; do
            bin=$old extra=(); [ $which = new ] && bin=$new extra=("${new_extra[@]}")
            t0=$(date +%s%N)
            "$bin" render "${flags[@]}" "${extra[@]}" -q -o "$out/$tag-$which.png" 2>>"$out/err" \
                || echo "$tag $which failed" >&2
            echo $(( ($(date +%s%N) - t0) / 1000000 )) >> "$out/$which"
        done
    done
    o=$(med < "$out/old") n=$(med < "$out/new")
    printf '%-22s %10s %10s %7.2f   (old %s; new %s)\n' "$tag" "$o" "$n" "$(echo "$n / $o" | bc -l)" \
        "$(paste -sd' ' "$out/old")" "$(paste -sd' ' "$out/new")"
done
rm -rf "$out"
