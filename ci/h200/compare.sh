#!/usr/bin/env bash
# Two fragtrace binaries measured side by side, rounds interleaved (OLD, NEW, OLD, NEW, ...)
# so that a change in the machine's load falls on both alike; medians and NEW/OLD per
# measure, and whether their images agree. Written for the H200 device machine (the GPU and
# its 16-core host: docs/performance.md names the suite behind each figure), it runs on any
# machine with a GL (the `cpu` and `build` suites need none).
#
#   ci/h200/compare.sh OLD NEW SUITE...     (env: ROUNDS, default 5)
#
# OLD, NEW: paths of the binaries (on the device, .devbin/NAME; OLD may be - for `tiles`).
# SIZES (default "4096 1024"): the `gpu` suite's image sides, the first also the scenes' and
# `tiles`'; FRAMES (default all): the turntable's frames in `frames`.
# SUITE, one or more of:
#   gpu     the compute kernel: the equal-work view's steady-state frame (frames 2..10 of
#           `render --frames`, ci/h200/equal-work-still.toml) at 4096² and 1024², and the
#           full Whitted tree of scenes/bunny.toml and the built-in scene at 4096² (GPU ms)
#   cpu     the CPU backend, f32: the equal-work render at 1024² on 1, 2 and 16 threads with
#           the BVH and the irregular grid, and ci/compare-default.sh on 16 threads
#   build   the irregular grid's build: the 3.3 M-triangle icosphere on 16 threads, and
#           scenes/bunny.toml on 2 and 16 threads (ci/compare-build.sh, 11 rounds)
#   frames  the 120-frame turntable (scenes/turntable.toml, 1024², PNG), whole process
#   tiles   NEW alone: scenes/bunny.toml 4096² as one process and as 2 and 4 tile processes
#           sharing the GPU, then `fragtrace merge` (docs/distributed.md)
#   images  ci/compare-binaries.sh OLD NEW: every shipped scene x backend, kernel and
#           structure, OLD against NEW (exit 1 when any image differs)
#   kernels NEW alone: every shipped scene on both grids at SIZES[1]², `--kernel compute`
#           against `--kernel looped`, the EXR and the AOV file byte for byte (issue 52:
#           the cold start shows either kernel's frames as one image; exit 1 where any
#           differs; llvmpipe's loop limit refuses compute on two scenes there, not here)
#   cold    the cold start (issue 52), whole process to PNG: the equal-work view at 1024²
#           with no cache at all (the driver's off and ours empty, which that run fills:
#           every CI run on a GPU runner), then with our program-binary cache warm (the
#           driver's still off), with the
#           driver's cache warm (ours off); the turntable (FRAMES) cold and with our cache
#           warm; the equal-work view at SIZES[0]² warm, and the built-in scene at SIZES[0]²
#           with no cache (a large cold frame: `handover_row`, the row from which the compute
#           kernel took over from the fallback) (SIZES[1]: the others' side). A single
#           render's line ends with its `process` times (`--stats`: start, load, the render
#           call, the write, total ms), where the build writes them. An OLD without the cache ignores its
#           variables, so its `ours` rows are cold ones. `looped_frames`: the frames a fragment
#           kernel rendered (with `--kernel auto`: while the compute kernel compiled, issue
#           52's cold start); the cold and warm images and turntable frames of NEW must be the same
#           bytes whichever kernel rendered them (exit 1 otherwise)
set -uo pipefail
[ $# -ge 3 ] || { sed -n '2,39p' "$0" >&2; exit 2; }
# The binaries by absolute path: the suites run from the repository's root.
abs() { if [ "$1" = - ]; then echo -; else realpath "$1"; fi; }
OLD=$(abs "$1") NEW=$(abs "$2")
for b in "$OLD" "$NEW"; do
    [ "$b" = - ] || [ -x "$b" ] || { echo "not an executable: $b" >&2; exit 2; }
done
cd "$(dirname "$0")/../.."
shift 2
ROUNDS=${ROUNDS:-5}
read -r -a SIZES <<< "${SIZES:-4096 1024}"
. ci/h200/setup.sh
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT
status=0

# Reads "OLD|NEW LABEL :: KEY VALUE ..." lines on stdin and echoes them as they come, then
# prints per LABEL and KEY the median over rounds of NEW, of OLD and NEW/OLD.
medians() {
    python3 -u -c '
import collections, re, statistics as st, sys
v = collections.defaultdict(list)
for line in sys.stdin:
    print(line, end="", flush=True)
    w = line.split()
    if len(w) < 3 or w[0] not in ("OLD", "NEW"):
        continue
    label = " ".join(w[1:]).split(" :: ")[0]
    for k, x in re.findall(r"(\w+) (-?[0-9.]+)\b", line.split(" :: ")[-1]):
        v[(label, k, w[0])].append(float(x))
print("== medians over rounds (NEW/OLD)")
for (label, k, who) in sorted(v):
    if who != "NEW":
        continue
    n = st.median(v[(label, k, "NEW")])
    o = v.get((label, k, "OLD"))
    r = " (%.3f)" % (n / st.median(o)) if o and st.median(o) else ""
    print("%-48s %-14s OLD %10s  NEW %10.2f%s" % (label, k, "%.2f" % st.median(o) if o else "-", n, r))
'
}
# `json FILE EXPR`: EXPR over the --stats JSON `d` (statistics as `st`, `nz` for a figure the
# driver may not have: NaN, which the medians skip); the file is removed,
# so that a render that fails cannot be read as the one before it.
json() {
    python3 -c "import json, statistics as st, sys; d = json.load(open(sys.argv[1]))
nz = lambda x: float('nan') if x is None else x  # no timer queries (llvmpipe): not a figure
print($2)" "$1"
    local rc=$?
    rm -f "$1"
    return $rc
}

suite_gpu() {
    for b in "$OLD" "$NEW"; do "$b" render ci/peers/equal-work.toml --backend gl --width 256 --height 256 -q -o "$W/warm.png" 2>/dev/null; done
    for ((r = 1; r <= ROUNDS; r++)); do
        for v in OLD NEW; do
            b=${!v}
            for size in "${SIZES[@]}"; do
                "$b" render ci/h200/equal-work-still.toml --backend gl --frames 0..9 --width "$size" --height "$size" -q \
                    -o "$W/st-$v-$size-####.png" --stats "$W/st.json" 2>>"$W/stderr"
                echo "$v equal-work ${size}² steady frame :: $(json "$W/st.json" '"render_ms %.3f gpu_ms %.3f" % (st.median(f["render"]["render_ms"] for f in d["per_frame"][1:]), st.median(nz(f["render"]["gpu"]["gpu_ms_total"]) for f in d["per_frame"][1:]))' 2>/dev/null || echo failed)"
            done
            for s in scenes/bunny.toml ""; do
                n=$(basename "${s:-builtin}" .toml)
                # shellcheck disable=SC2086
                "$b" render $s --backend gl --width "${SIZES[0]}" --height "${SIZES[0]}" -q -o "$W/sc-$v-$n.png" \
                    --stats "$W/sc.json" 2>>"$W/stderr"
                echo "$v ${s:-built-in scene} ${SIZES[0]}² :: $(json "$W/sc.json" '"gpu_ms %.3f render_ms %.1f" % (nz(d["gpu"]["gpu_ms_total"]), d["render_ms"])' 2>/dev/null || echo failed)"
            done
        done
    done | medians
    for f in "${SIZES[@]/#/st-OLD-}" sc-OLD-bunny sc-OLD-builtin; do
        [[ $f == st-* ]] && f=$f-0009
        echo "image ${f#*-OLD-}: $("$NEW" compare "$W/$f.png" "$W/${f/OLD/NEW}.png" 2>&1 | tail -1)"
    done
}

suite_cpu() {
    for ((r = 1; r <= ROUNDS; r++)); do
        for t in 1 2 16; do
            for accel in bvh irregular; do
                for v in OLD NEW; do
                    RAYON_NUM_THREADS=$t "${!v}" render ci/peers/equal-work.toml --backend cpu --precision f32 \
                        --accel $accel --width 1024 --height 1024 -q -o "$W/c-$v-$accel.png" --stats "$W/c.json" 2>>"$W/stderr"
                    echo "$v equal-work 1024² $accel $t threads :: $(json "$W/c.json" '"build_ms %.1f render_ms %.1f" % (d["accel"]["build_ms"], d["render_ms"])' 2>/dev/null || echo failed)"
                done
            done
        done
    done | medians
    for accel in bvh irregular; do echo "image $accel: $("$NEW" compare "$W/c-OLD-$accel.png" "$W/c-NEW-$accel.png" 2>&1 | tail -1)"; done
    THREADS=16 RUNS=$ROUNDS bash ci/compare-default.sh "$OLD" "$NEW"
}

suite_build() {
    bash ci/measure-build.sh --write-scenes "$W"
    for ((r = 1; r <= ROUNDS; r++)); do
        for v in OLD NEW; do
            RAYON_NUM_THREADS=16 "${!v}" render "$W/s3m.toml" --backend cpu --accel irregular --width 8 --height 8 \
                -q -o "$W/x.png" --stats "$W/s.json" 2>>"$W/stderr"
            echo "$v icosphere 3.3 M irregular build 16 threads :: $(json "$W/s.json" '"build_ms %.1f" % d["accel"]["build_ms"]' 2>/dev/null || echo failed)"
        done
    done | medians
    for t in 2 16; do SCENE=scenes/bunny.toml THREADS=$t RUNS=11 bash ci/compare-build.sh "$OLD" "$NEW"; done
}

suite_frames() {
    for ((r = 1; r <= ROUNDS; r++)); do
        for v in OLD NEW; do
            t0=$(date +%s%N)
            "${!v}" render scenes/turntable.toml --frames "${FRAMES:-all}" --width 1024 --height 1024 -q -o "$W/tt-$v-####.png" \
                --stats "$W/tt.json" 2>>"$W/stderr"
            echo "$v turntable frames ${FRAMES:-all} at 1024² to PNG :: wall_ms $(( ($(date +%s%N) - t0) / 1000000 ))"
            [ $r = "$ROUNDS" ] && frames_line "$W/tt.json" >&2
        done
    done | medians
}

suite_tiles() {
    local S=scenes/bunny.toml n=${SIZES[0]}
    "$NEW" render $S --width 256 --height 256 -q -o "$W/warm.png"
    for ((r = 1; r <= ROUNDS; r++)); do
        t0=$(date +%s%N)
        "$NEW" render $S --width "$n" --height "$n" -q -o "$W/one.png"
        echo "NEW bunny ${n}² one process :: wall_ms $(( ($(date +%s%N) - t0) / 1000000 ))"
        for k in 2 4; do
            rm -rf "$W/p" && mkdir -p "$W/p"
            t0=$(date +%s%N)
            for ((i = 0; i < k; i++)); do
                "$NEW" render $S --width "$n" --height "$n" -q --tile $i/$k -o "$W/p/part-$i.exr" &
            done
            wait
            t1=$(date +%s%N)
            "$NEW" merge "$W"/p/part-*.exr -o "$W/m.png"
            echo "NEW bunny ${n}² $k tile processes :: wall_ms $(( (t1 - t0) / 1000000 )) merge_ms $(( ($(date +%s%N) - t1) / 1000000 ))"
            cmp -s "$W/one.png" "$W/m.png" || echo "merged PNG of $k tiles differs from the single render" >&2
        done
    done | medians
}

# `cold_run LABEL V CACHE... -- ARGS`: one render by binary V (OLD or NEW) with the caches
# named: `driver` (the driver's disk cache on, in $W/drv-V, else off; Mesa's is never off,
# as Mesa offers program binaries only with it on, but empty), `ours` (our cache on, in
# $W/ours-V, else off); wall time, compile time and the programs linked from our cache.
cold_run() {
    local label=$1 v=$2; shift 2
    local drv=0 ours=off
    while [ "$1" != -- ]; do case $1 in driver) drv=1 ;; ours) ours=on ;; esac; shift; done
    shift
    local t0; t0=$(date +%s%N)
    __GL_SHADER_DISK_CACHE=$drv __GL_SHADER_DISK_CACHE_PATH="$W/drv-$v" \
        MESA_SHADER_CACHE_DIR=$([ $drv = 1 ] && echo "$W/drv-$v" || mktemp -d -p "$W") \
        FRAGTRACE_SHADER_CACHE=$ours FRAGTRACE_SHADER_CACHE_DIR="$W/ours-$v" \
        "${!v}" render "$@" -q --stats "$W/cold.json" 2>>"$W/stderr"
    local wall=$(( ($(date +%s%N) - t0) / 1000000 ))
    echo "$v $label :: wall_ms $wall $(json "$W/cold.json" '"compile_ms %.1f cached %d looped_frames %d handover_row %s%s" % (
        d["gpu"]["compile_ms"] if "gpu" in d else sum(f["render"]["gpu"]["compile_ms"] for f in d["per_frame"]),
        (d["gpu"] if "gpu" in d else d["per_frame"][0]["render"]["gpu"]).get("programs_cached", 0),
        sum(g["kernel"] != "compute" for g in ([d["gpu"]] if "gpu" in d else [f["render"]["gpu"] for f in d["per_frame"]])),
        next((g["handover_row"] for g in ([d["gpu"]] if "gpu" in d else [f["render"]["gpu"] for f in d["per_frame"]]) if g.get("handover_row") is not None), "-"),
        "".join(" %s %.1f" % kv for kv in (d.get("process") or {}).items()))' 2>/dev/null || echo failed)"
}

suite_cold() {
    local n=${SIZES[1]:-1024} big=${SIZES[0]}
    local ew=(ci/peers/equal-work.toml --backend gl --width "$n" --height "$n")
    local tt=(scenes/turntable.toml --backend gl --frames "${FRAMES:-all}" --width "$n" --height "$n")
    for ((r = 1; r <= ROUNDS; r++)); do
        for v in OLD NEW; do
            rm -rf "$W/drv-$v" "$W/ours-$v"
            cold_run "equal-work ${n}² no cache" $v ours -- "${ew[@]}" -o "$W/cold-$v.png"
            cold_run "equal-work ${n}² our cache warm" $v ours -- "${ew[@]}" -o "$W/ours-$v.png"
            cold_run "equal-work ${big}² PNG our cache warm" $v ours -- ci/peers/equal-work.toml --backend gl \
                --width "$big" --height "$big" -o "$W/big-$v.png"
            # The looped kernel alone from cold: what auto's cold start should come to, unless
            # the process waits at its exit for the compute compile it started.
            rm -rf "$W/ours-$v"
            cold_run "equal-work ${n}² no cache --kernel looped" $v ours -- "${ew[@]}" --kernel looped -o "$W/x.png"
            rm -rf "$W/drv-$v"
            cold_run "(warming the driver's cache)" $v driver -- "${ew[@]}" -o "$W/x.png" >/dev/null
            cold_run "equal-work ${n}² driver cache warm" $v driver -- "${ew[@]}" -o "$W/drv-$v.png"
            # A large single frame from cold: the fallback renders bands until the compute
            # kernel is linked, which renders the rest (gpu::render::handover).
            rm -rf "$W/ours-$v"
            cold_run "built-in scene ${big}² PNG no cache" $v ours -- --backend gl --width "$big" --height "$big" -o "$W/bic-$v.png"
            rm -rf "$W/drv-$v" "$W/ours-$v"
            cold_run "turntable ${n}² PNG no cache" $v ours -- "${tt[@]}" -o "$W/ttc-$v-####.png"
            cold_run "turntable ${n}² PNG our cache warm" $v ours -- "${tt[@]}" -o "$W/tt-$v-####.png"
            # A single frame that ends before the compute compile leaves our cache cold
            # (src/gpu/render.rs, cold_start): warmed here by one `--kernel compute` run.
            rm -rf "$W/ours-$v"
            cold_run "(warming our cache with --kernel compute)" $v ours -- "${ew[@]}" --kernel compute -o "$W/x.png" >/dev/null
            cold_run "equal-work ${n}² our cache warmed by --kernel compute" $v ours -- "${ew[@]}" -o "$W/ourc-$v.png"
        done
    done | grep -v "^(warming" | medians
    for f in cold ours drv big bic; do
        echo "image $f: $("$NEW" compare "$W/$f-OLD.png" "$W/$f-NEW.png" 2>&1 | tail -1)"
    done
    cmp -s "$W/cold-NEW.png" "$W/ours-NEW.png" || { echo "NEW: the cached programs' image differs" >&2; status=1; }
    cmp -s "$W/cold-NEW.png" "$W/ourc-NEW.png" || { echo "NEW: the image after --kernel compute differs" >&2; status=1; }
    for f in "$W"/ttc-NEW-*.png; do
        cmp -s "$f" "${f/ttc-/tt-}" || { echo "NEW: turntable $(basename "$f") cold differs from warm" >&2; status=1; }
    done
}

suite_kernels() {
    local n=${SIZES[1]:-1024} differ=0 total=0
    for scene in builtin scenes/*.toml; do
        local arg=(); [ "$scene" = builtin ] || arg=("$scene")
        for accel in irregular uniform; do
            for k in compute looped; do
                "$NEW" render "${arg[@]}" --backend gl --kernel $k --accel $accel --width "$n" --height "$n" \
                    --aov depth,normal,primid,steps -q -o "$W/k-$k.exr" 2>>"$W/stderr" || echo "$scene $accel $k: failed"
            done
            total=$((total + 1))
            if ! cmp -s "$W/k-compute.exr" "$W/k-looped.exr" || ! cmp -s "$W/k-compute.aov.exr" "$W/k-looped.aov.exr"; then
                differ=$((differ + 1))
                echo "$(basename "$scene" .toml) $accel: compute and looped differ: $("$NEW" compare "$W/k-compute.exr" "$W/k-looped.exr" 2>&1 | tail -1)"
            fi
            rm -f "$W"/k-*
        done
    done
    echo "kernels: $differ of $total scene x grid pairs differ between compute and looped"
    [ $differ = 0 ] || status=1
}

suite_images() { bash ci/compare-binaries.sh "$OLD" "$NEW" || status=1; }

for s in "$@"; do
    case $s in
        gpu | cpu | build | frames | tiles | images | kernels | cold) echo "=== $s ($(date -u +%T))"; "suite_$s" ;;
        *) echo "unknown suite: $s (gpu, cpu, build, frames, tiles, images, kernels, cold)" >&2; exit 2 ;;
    esac
done
[ -s "$W/stderr" ] && { echo "=== stderr (last lines)"; tail -5 "$W/stderr"; }
exit $status
