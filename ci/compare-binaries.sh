#!/usr/bin/env bash
# Renders every shipped scene on every backend, kernel and acceleration structure with two
# fragtrace binaries and compares the images pairwise: the check that a refactor changed no
# pixel.
#
#   ci/compare-binaries.sh OLD_BINARY NEW_BINARY [SIZE]     (SIZE defaults to 64x48)
#
# Meshes come from FRAGTRACE_MODEL_PATH (default ../shared/models). NEW_ARGS adds flags to
# the new binary's renders only (e.g. NEW_ARGS="--terminator exact" against a binary from
# before that option's default). Prints one line per image that differs and a total; exits
# 1 when any image differs or fails to render.
set -uo pipefail
cd "$(dirname "$0")/.."
old=$1 new=$2 size=${3:-64x48}
w=${size%x*} h=${size#*x}
export FRAGTRACE_MODEL_PATH="${FRAGTRACE_MODEL_PATH:-$(cd .. && pwd)/shared/models}"
out=$(mktemp -d)
configs=(
    "cpu64:--backend cpu --accel irregular --precision f64" "cpu32:--backend cpu --accel irregular --precision f32"
    "looped:--backend gl --kernel looped" "unrolled4:--backend gl --kernel unrolled:4"
    "multipass:--backend gl --kernel multipass"
    "multipass-earlyz:--backend gl --kernel multipass --mask early-z"
    "f16:--backend gl --storage f16"
    "compute:--backend gl --kernel compute"
)
accels=(irregular uniform)
read -r -a new_extra <<< "${NEW_ARGS:-}"
total=0 same=0 refused=0
for scene in builtin scenes/*.toml; do
    name=$(basename "$scene" .toml)
    arg=(); [ "$scene" = builtin ] || arg=("$scene")
    for accel in "${accels[@]}"; do
    for cfg in "${configs[@]}"; do
        tag=${cfg%%:*}-$accel; read -r -a flags <<< "${cfg#*:}"
        flags+=(--accel "$accel")
        total=$((total + 1))
        for which in old new; do
            bin=$old extra=(); [ $which = new ] && bin=$new extra=("${new_extra[@]}")
            "$bin" render "${arg[@]}" "${flags[@]}" "${extra[@]}" --width "$w" --height "$h" -q \
                -o "$out/$name-$tag-$which.exr" 2> "$out/$which.err" || echo failed >> "$out/$which.err"
        done
        if grep -q failed "$out/old.err" || grep -q failed "$out/new.err"; then
            # Both refusing with the same message (an explicit --kernel compute past
            # llvmpipe's loop limit, say) is the same behaviour.
            if cmp -s "$out/old.err" "$out/new.err"; then
                same=$((same + 1)); refused=$((refused + 1))
            else
                echo "$name $tag: old: $(head -c 300 "$out/old.err") new: $(head -c 300 "$out/new.err")"
            fi
            continue
        fi
        r=$("$new" compare "$out/$name-$tag-old.exr" "$out/$name-$tag-new.exr" 2>&1)
        if [[ $r == *"PSNR identical"* ]]; then same=$((same + 1)); else echo "$name $tag: $r"; fi
    done
    done
done
rm -rf "$out"
echo "identical: $same of $total ($refused of them refused alike by both binaries)"
[ "$same" -eq "$total" ]
