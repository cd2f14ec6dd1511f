#!/usr/bin/env bash
# The driver's compile time of the compute kernel (issue 52's cold start): for each BIN,
# its compute kernel for the equal-work view and scenes/bunny.toml, and for the first BIN
# variants of it (NVIDIA pragmas) and the fragment kernel's programs beside it, each timed
# by the `compile_time` example (RUNS each, the driver's disk caches off).
#
#   ci/h200/compile-variants.sh COMPILE_TIME_BIN BIN...
set -uo pipefail
ct=$(realpath "$1"); shift
bins=(); for b in "$@"; do bins+=("$(realpath "$b")"); done
cd "$(dirname "$0")/../.."
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
export __GL_SHADER_DISK_CACHE=0 MESA_SHADER_CACHE_DISABLE=true
files=()
for i in "${!bins[@]}"; do
    "${bins[$i]}" dump-shaders ci/peers/equal-work.toml "$out/ew$i" --backend gl >/dev/null
    "${bins[$i]}" dump-shaders scenes/bunny.toml "$out/bunny$i" --backend gl >/dev/null
    files+=("$out/ew$i/compute.comp" "$out/bunny$i/compute.comp")
done
c=$out/ew0/compute.comp
sed '1a #pragma optionNV(unroll none)' "$c" > "$out/ew0/v_unroll_none.comp"
sed '1a #pragma optionNV(inline none)' "$c" > "$out/ew0/v_inline_none.comp"
sed '/#pragma optionNV(fastmath off)/d' "$c" > "$out/ew0/v_fastmath_on.comp"
"$ct" "${files[@]}" "$out"/ew0/v_*.comp "$out/ew0/compute_srgb8.comp" "$out/ew0/looped.frag" \
    "$out/ew0/looped_any.frag" "$out/ew0/raygen.frag" | sed "s|$out/||"
