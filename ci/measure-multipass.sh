#!/usr/bin/env bash
# The faithful multipass kernel against the looped one (issue 49): GPU time from the timer
# queries (`gpu_ms_total` of --stats), medians of RUNS renders interleaved run by run, the
# multipass/looped ratio per scene, and the pixels the advancing passes drew against a
# full-screen quad per pass (tiles cut to the active rays) and against the active rays
# alone (the floor of stream reduction). With OLD, that binary's renders are timed too.
#
#   ci/measure-multipass.sh [BINARY] [SIZE] [RUNS]     (target/release/fragtrace 256 3)
#   OLD=/path/to/old/fragtrace ci/measure-multipass.sh
#
# On llvmpipe run it in a strict GL 2.1 context:
#   MESA_GL_VERSION_OVERRIDE=2.1 MESA_GLSL_VERSION_OVERRIDE=120 ci/measure-multipass.sh
# On the H200 (issue 49's figures): ci/measure-multipass.sh target/release/fragtrace 1024 3
# Meshes come from FRAGTRACE_MODEL_PATH (default ../shared/models). Needs python3.
set -uo pipefail
cd "$(dirname "$0")/.."
new=${1:-target/release/fragtrace} size=${2:-256} runs=${3:-3}
export FRAGTRACE_MODEL_PATH="${FRAGTRACE_MODEL_PATH:-$(cd .. && pwd)/shared/models}"
bins=(new); [ -n "${OLD:-}" ] && bins=(old new)
out=$(mktemp -d)
med() { sort -n | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
printf '%-8s %-4s %12s %12s %7s %8s %8s\n' scene bin multipass_ms looped_ms ratio drawn% active%
for scene in bunny:scenes/bunny.toml builtin: ground:scenes/ground.toml; do
    tag=${scene%%:*} file=${scene#*:}
    for _ in $(seq "$runs"); do
        for which in "${bins[@]}"; do
            bin=$new; [ "$which" = old ] && bin=$OLD
            for kernel in multipass looped; do
                # shellcheck disable=SC2086
                "$bin" render $file --backend gl --kernel "$kernel" --width "$size" \
                    --height "$size" -q -o "$out/img.png" --stats "$out/s.json" 2>>"$out/err" \
                    || { echo "$tag $which $kernel failed: $(tail -1 "$out/err")" >&2; continue; }
                # GPU time, then the drawn and active pixels against a full-screen quad per
                # advancing pass (python3 rather than jq: the device machine has no jq).
                python3 - "$out/s.json" $((size * size)) "$out/$which-$kernel" "$out/$which-$kernel-px" <<'PY'
import json, re, sys
g = json.load(open(sys.argv[1])).get("gpu") or {}
px = int(sys.argv[2])
ms = g.get("gpu_ms_total")
open(sys.argv[3], "a").write(f"{'nan' if ms is None else ms}\n")
n = sum(v for k, v in (g.get("passes") or {}).items()
        if re.match(r"(traverse_step|intersect|looped|unrolled)", k)) or 1
open(sys.argv[4], "w").write(f"{100 * (g.get('advance_pixels') or 0) / (n * px)} "
                             f"{100 * (g.get('advance_active') or 0) / (n * px)}\n")
PY
            done
        done
    done
    for which in "${bins[@]}"; do
        m=$(med < "$out/$which-multipass") l=$(med < "$out/$which-looped")
        read -r drawn active < "$out/$which-multipass-px"
        printf '%-8s %-4s %12.1f %12.1f %7.2f %8.1f %8.1f   (multipass %s; looped %s)\n' \
            "$tag" "$which" "$m" "$l" "$(awk -v m="$m" -v l="$l" 'BEGIN { print m / l }')" "$drawn" "$active" \
            "$(paste -sd' ' "$out/$which-multipass")" "$(paste -sd' ' "$out/$which-looped")"
        rm -f "$out/$which-multipass" "$out/$which-looped"
    done
done
rm -rf "$out"
