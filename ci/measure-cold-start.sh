#!/usr/bin/env bash
# `--kernel auto`'s cold start (issue 52) on any GL, whole process to PNG: the equal-work
# view (one frame) and the turntable (FRAMES), each with both caches empty (a new
# MESA_SHADER_CACHE_DIR and FRAGTRACE_SHADER_CACHE_DIR: "cold") and then the run after it
# ("warm"), for OLD with auto and NEW with auto, with auto and FRAGTRACE_COMPILE_POLLS=1
# (the test hook that plays a driver compiling on its own threads: the first frame on the
# looped kernel) and with --kernel looped; rounds interleaved, medians. Every cold image and
# frame must equal its warm one byte for byte.
#
#   ci/measure-cold-start.sh OLD NEW     (env: FRAGTRACE_MODEL_PATH; ROUNDS=3, N=256 (image
#                                         side), FRAMES=0..23)
set -uo pipefail
[ $# -eq 2 ] || { sed -n '2,10p' "$0" >&2; exit 2; }
OLD=$(realpath "$1") NEW=$(realpath "$2")
cd "$(dirname "$0")/.."
ROUNDS=${ROUNDS:-3} N=${N:-256} FRAMES=${FRAMES:-0..23}
[ -n "${FRAGTRACE_MODEL_PATH:-}" ] || { echo "set FRAGTRACE_MODEL_PATH (the meshes)" >&2; exit 2; }
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
# `run LABEL BINARY [VAR=VALUE...] -- ARGS`: one render in the caches of $C.
run() {
    local label=$1 b=$2; shift 2
    local envs=(); while [ "$1" != -- ]; do envs+=("$1"); shift; done; shift
    local t0; t0=$(date +%s%N)
    env ${envs[@]+"${envs[@]}"} FRAGTRACE_SHADER_CACHE=on FRAGTRACE_SHADER_CACHE_DIR="$C/ours" \
        MESA_SHADER_CACHE_DIR="$C/mesa" "$b" render "$@" -q --stats "$C/s.json" 2>>"$W/stderr"
    local wall=$(( ($(date +%s%N) - t0) / 1000000 ))
    echo "$label :: wall_ms $wall $(python3 -c "
import json, sys; d = json.load(open(sys.argv[1]))
g = [d['gpu']] if 'gpu' in d else [f['render']['gpu'] for f in d['per_frame']]
print('compile_ms %.1f looped_frames %d' % (sum(x['compile_ms'] for x in g), sum(x['kernel'] != 'compute' for x in g)))" "$C/s.json" 2>/dev/null || echo failed)"
    rm -f "$C/s.json"
}
for ((r = 1; r <= ROUNDS; r++)); do
    for cfg in "OLD auto" "NEW auto" "NEW auto-polls1" "NEW looped"; do
        read -r v k <<< "$cfg"
        b=${!v} envs=() kernel=auto
        [ "$k" = auto-polls1 ] && envs=(FRAGTRACE_COMPILE_POLLS=1)
        [ "$k" = looped ] && kernel=looped
        C=$(mktemp -d -p "$W")
        one=(ci/peers/equal-work.toml --backend gl --kernel $kernel --width "$N" --height "$N")
        tt=(scenes/turntable.toml --backend gl --kernel $kernel --frames "$FRAMES" --width "$N" --height "$N")
        run "$cfg single ${N}² cold" "$b" ${envs[@]+"${envs[@]}"} -- "${one[@]}" -o "$C/a.png"
        run "$cfg single ${N}² warm" "$b" ${envs[@]+"${envs[@]}"} -- "${one[@]}" -o "$C/b.png"
        cmp -s "$C/a.png" "$C/b.png" || echo "$cfg: the cold and warm images differ" >&2
        rm -rf "$C/ours" "$C/mesa"
        run "$cfg turntable $FRAMES ${N}² cold" "$b" ${envs[@]+"${envs[@]}"} -- "${tt[@]}" -o "$C/c-####.png"
        run "$cfg turntable $FRAMES ${N}² warm" "$b" ${envs[@]+"${envs[@]}"} -- "${tt[@]}" -o "$C/w-####.png"
        for f in "$C"/c-*.png; do cmp -s "$f" "${f/c-/w-}" || echo "$cfg: $(basename "$f") cold and warm differ" >&2; done
        rm -rf "$C"
    done
done | python3 -u -c '
import collections, re, statistics as st, sys
v = collections.defaultdict(list)
for line in sys.stdin:
    print(line, end="", flush=True)
    if " :: " not in line:
        continue
    label, rest = line.rstrip().split(" :: ")
    for k, x in re.findall(r"(\w+) (-?[0-9.]+)", rest):
        v[(label, k)].append(float(x))
print("== medians over rounds")
for (label, k), x in v.items():
    print("%-44s %-14s %10.1f" % (label, k, st.median(x)))
'
echo "load $(cut -d' ' -f1-3 /proc/loadavg), $(nproc) cores"
[ -s "$W/stderr" ] && { echo "=== stderr (last lines)"; tail -5 "$W/stderr"; }
