#!/usr/bin/env bash
# The distributed render against a real Slurm: starts a single-node cluster on this host
# (ci/slurm/cluster.sh: munged, slurmctld, slurmd from Debian's packages, no systemd),
# submits the job scripts of ci/slurm/ as a user would, waits for them (sbatch --wait),
# and checks that every merged image and every frame has exactly the bits of the
# single-process render: tiles of a still, whole frames of an animation, and frames cut
# into tiles; then the faults (issue 48): a cancelled task, a killed task's partial file,
# the re-run of one index, a resumed frame range, a frame without parts.
# Stops the daemons it started, by pid, whatever happens. Exit 0 only when all of it
# worked; any failure — Slurm not installed or not starting, a task failing, a merge
# refusing, one differing byte — exits 1 saying what.
#
#   ci/slurm/test.sh [path/to/fragtrace]     (default: target/release/fragtrace)
#
# Run by tests/slurm.rs (so `cargo test` and CI run it); needs root and the packages
# slurmd slurmctld slurm-client munge (ci/test.sh installs them).
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
bin=$(realpath "${1:-$repo/target/release/fragtrace}")
[ -x "$bin" ] || { echo "slurm test: no fragtrace binary at $bin" >&2; exit 1; }

work=$(mktemp -d "${TMPDIR:-/tmp}/fragtrace-slurm.XXXXXX")
chmod 0755 "$work" # munged's socket lives below it
cluster=$work/cluster
cleanup() {
    "$repo/ci/slurm/cluster.sh" stop "$cluster" || true
    if [ "${KEEP_SLURM_TEST:-0}" = 1 ]; then
        echo "slurm test: files kept in $work"
    else
        rm -rf "$work"
    fi
}
trap cleanup EXIT

fail() {
    echo "slurm test: FAILED: $*" >&2
    for log in "$work"/jobs/*.log; do
        [ -f "$log" ] && { echo "--- $log:" >&2; tail -n 20 "$log" >&2; }
    done
    exit 1
}

"$repo/ci/slurm/cluster.sh" start "$cluster" || fail "the Slurm cluster did not start (above)"
export SLURM_CONF=$cluster/slurm.conf
export FRAGTRACE=$bin
export FRAGTRACE_MODEL_PATH=${FRAGTRACE_MODEL_PATH:-$(cd "$repo/.." && pwd)/shared/models}
mkdir -p "$work/jobs"
cd "$work/jobs" # the jobs' logs (fragtrace-*.log) land here

# Compares a merged image with the single-process one, byte for byte.
same() {
    cmp "$1" "$2" >/dev/null || fail "$1 differs from the single-process render $2 ($(cmp "$1" "$2" 2>&1 | head -n 1))"
    echo "slurm test: $(basename "$1") is bit-identical to the single-process render"
}

t0=$(date +%s)
# 1. One image, 4 tasks, one tile each; the backend submit-tiles.sh pins without --gpu
#    (the CPU), to PNG; the script ends with the summary across the tasks.
flags=(--width 320 --height 240 --spp 2)
"$bin" render "$repo/scenes/whitted.toml" "${flags[@]}" --backend cpu -q -o "$work/whitted-single.png" ||
    fail "the single-process render of whitted.toml failed"
"$repo/ci/slurm/submit-tiles.sh" --wait 4 "$repo/scenes/whitted.toml" \
    "$work/whitted.png" "${flags[@]}" >"$work/whitted.out" || fail "the whitted.toml job (4 tiles) failed"
[ "$(ls "$work"/parts-whitted/*.exr | wc -l)" -eq 4 ] || fail "expected 4 parts of whitted"
same "$work/whitted.png" "$work/whitted-single.png"
# It ends with the summary across the tasks: every part, each task's time and node.
grep -q "^4 of 4 parts done$" "$work/whitted.out" && grep -q "^task 3 of 4: 1 of 1 part, .* on " "$work/whitted.out" &&
    grep -q " over 4 complete tasks$" "$work/whitted.out" ||
    fail "submit-tiles.sh printed no summary across the tasks: $(cat "$work/whitted.out")"

# 2. A mesh scene on the CPU in f32, cut into 2x4 tiles shared by 4 tasks (two each, in one
#    process), to EXR: the merged floats equal the single render's.
flags=(--width 192 --height 160 --backend cpu --precision f32)
"$bin" render "$repo/scenes/bunny.toml" "${flags[@]}" -q -o "$work/bunny-single.exr" ||
    fail "the single-process render of bunny.toml failed (FRAGTRACE_MODEL_PATH=$FRAGTRACE_MODEL_PATH)"
"$repo/ci/slurm/submit-tiles.sh" --wait 4 "$repo/scenes/bunny.toml" \
    "$work/bunny.exr" "${flags[@]}" --tiles 2x4 || fail "the bunny.toml job (2x4 tiles on 4 tasks) failed"
[ "$(ls "$work"/parts-bunny/*.exr | wc -l)" -eq 8 ] || fail "expected 8 parts of bunny"
# RMSE 0 over linear floats: every value equal (a NaN would fail it too).
"$bin" compare "$work/bunny.exr" "$work/bunny-single.exr" --max-rmse 0 >/dev/null ||
    fail "the merged bunny.exr differs from the single-process render: $("$bin" compare "$work/bunny.exr" "$work/bunny-single.exr" 2>&1 | head -n 3 | tr '\n' ' ')"
echo "slurm test: bunny.exr (8 tiles on 4 tasks) has the single-process render's floats"

# 3. An animation: 8 frames of turntable.toml's camera path shared by a 4-task array, whole
#    frames straight to PNG; each equals the single-process animation's frame byte for byte.
flags=(--width 96 --height 72)
mkdir -p "$work/single"
"$bin" render "$repo/scenes/turntable.toml" "${flags[@]}" --frames 0..7 -q \
    -o "$work/single/frame_####.png" ||
    fail "the single-process render of turntable.toml's frames 0..7 failed"
"$repo/ci/slurm/submit-frames.sh" --wait 4 "$repo/scenes/turntable.toml" 0..7 \
    "$work/frames/frame_####.png" "${flags[@]}" || fail "the turntable.toml job (8 frames on 4 tasks) failed"
for f in 0 1 2 3 4 5 6 7; do
    same "$work/frames/frame_000$f.png" "$work/single/frame_000$f.png"
done

# 4. Frames times tiles: frames 3..4 cut into 2 tiles each, 4 tasks, then the merge job
#    writes each frame; equal to the single-process frames.
"$repo/ci/slurm/submit-frames.sh" --wait 4 "$repo/scenes/turntable.toml" 3..4 \
    "$work/tiled/frame_####.png" "${flags[@]}" --tiles 2 ||
    fail "the turntable.toml job (2 frames x 2 tiles on 4 tasks) failed"
[ "$(ls "$work"/tiled/parts-frame_/*.exr | wc -l)" -eq 4 ] || fail "expected 4 parts of frames 3..4"
for f in 3 4; do
    same "$work/tiled/frame_000$f.png" "$work/single/frame_000$f.png"
done

# 5. Faults (issue 48). One task of 4 cancelled while it runs (the binary of task 2 waits
#    first, through a wrapper): submit-tiles.sh --wait exits 1 naming the missing part.
cat >"$work/slow-fragtrace" <<EOS
#!/usr/bin/env bash
if [ "\${SLURM_ARRAY_TASK_ID:-}" = "\${SLOW_TASK:-none}" ]; then touch "$work/slow-started"; sleep 120; fi
exec "$bin" "\$@"
EOS
chmod +x "$work/slow-fragtrace"
scene=$repo/scenes/whitted.toml
flags=(--width 320 --height 240 --spp 2 --backend cpu)
rm -f "$work/slow-started"
SLOW_TASK=2 FRAGTRACE=$work/slow-fragtrace "$repo/ci/slurm/submit-tiles.sh" --wait 4 "$scene" \
    "$work/cancelled.png" "${flags[@]}" >"$work/cancelled.out" 2>&1 &
submit=$!
for _ in $(seq 600); do [ -f "$work/slow-started" ] && break; sleep 0.1; done
[ -f "$work/slow-started" ] || fail "task 2 of the cancelled job never started"
array=$(squeue -h -o '%F' -n fragtrace-tiles | head -n 1)
scancel "${array}_2" || fail "scancel ${array}_2 failed"
rc=0
wait $submit || rc=$?
cat "$work/cancelled.out"
[ $rc = 1 ] || fail "submit-tiles.sh --wait exited $rc, not 1, with task 2 cancelled"
[ ! -f "$work/cancelled.png" ] || fail "an image was written with task 2 cancelled"
grep -q "part-2.exr: missing" "$work/cancelled.out" ||
    fail "submit-tiles.sh did not name the missing part-2.exr"
grep -q "^task 2 of 4: 0 of 1 part; missing tile 2 of 4$" "$work/cancelled.out" &&
    grep -q "^to re-run: task 2 (sbatch --array=2" "$work/cancelled.out" ||
    fail "submit-tiles.sh's summary did not name task 2 and its tile"
echo "slurm test: a cancelled task: submit-tiles.sh --wait exits 1 naming part-2.exr"
# The array's other tasks may still be running: let them end before the re-run.
for _ in $(seq 600); do [ -z "$(squeue -h -j "$array" 2>/dev/null)" ] && break; sleep 0.2; done

# 6. A task killed mid-write left its temporary file (made here with a pid that has ended);
#    the documented re-run of index 2 alone renders only tile 2 of 4 (the other parts are
#    untouched), removes the leftover, and the merge equals one process.
parts=$work/parts-cancelled
sh -c 'exit 0' &
dead=$!
wait $dead
head -c 4096 /dev/urandom >"$parts/.part-2.exr.$dead.partial.exr"
head -c 4096 /dev/urandom >"$parts/.part-1.exr.$dead.partial.exr"
before=$(stat -c %Y.%s "$parts/part-0.exr" "$parts/part-1.exr" "$parts/part-3.exr" | md5sum)
sbatch --wait -Q --array=2 "$repo/ci/slurm/tiles.sbatch" "$scene" "$parts" --task-index env:4 \
    "${flags[@]}" || fail "the re-run of task 2 failed"
[ "$(stat -c %Y.%s "$parts/part-0.exr" "$parts/part-1.exr" "$parts/part-3.exr" | md5sum)" = "$before" ] ||
    fail "the re-run of task 2 rewrote other parts"
[ ! -e "$parts/.part-2.exr.$dead.partial.exr" ] || fail "the re-run of task 2 left a dead task's partial file"
grep -q "task 2 of 4" fragtrace-tiles-*_2.log || fail "the re-run's log does not say task 2 of 4"
sbatch --wait -Q "$repo/ci/slurm/merge.sbatch" "$work/cancelled.png" "$parts" ||
    fail "the merge after the re-run failed"
[ -z "$(find "$parts" -name '*.partial.*')" ] || fail "partial files survived the merge: $(ls -a "$parts")"
same "$work/cancelled.png" "$work/whitted-single.png"

# 7. An interrupted frame range resumed: frames 0..7 with frame 5 missing and frame 6 cut
#    short; --resume skips the whole frames (their files untouched), renders 5 and 6, and
#    every frame equals one process.
flags=(--width 96 --height 72)
rm "$work/frames/frame_0005.png"
head -c 300 "$work/frames/frame_0006.png" >"$work/f6" && mv "$work/f6" "$work/frames/frame_0006.png"
kept=$(stat -c %Y.%s "$work/frames/frame_0000.png" "$work/frames/frame_0007.png" | md5sum)
"$repo/ci/slurm/submit-frames.sh" --wait 2 "$repo/scenes/turntable.toml" 0..7 \
    "$work/frames/frame_####.png" "${flags[@]}" --resume || fail "the resumed frame range failed"
[ "$(stat -c %Y.%s "$work/frames/frame_0000.png" "$work/frames/frame_0007.png" | md5sum)" = "$kept" ] ||
    fail "--resume rendered frames that existed whole"
for f in 0 1 2 3 4 5 6 7; do
    same "$work/frames/frame_000$f.png" "$work/single/frame_000$f.png"
done

# 8. Frames x tiles with every part of frame 4 missing: the merge refuses, naming frame 4,
#    and submit-frames.sh --wait exits 1 (not 0 with frames 3 and 5 written).
rc=0
"$repo/ci/slurm/submit-frames.sh" --wait 2 "$repo/scenes/turntable.toml" 3,5 \
    "$work/gap/frame_####.png" "${flags[@]}" --tiles=2 >"$work/gap.out" 2>&1 || rc=$?
[ $rc = 0 ] || { cat "$work/gap.out"; fail "frames 3,5 x 2 tiles (--tiles=2) failed"; }
same "$work/gap/frame_0005.png" "$work/single/frame_0005.png"
rm -rf "$work"/gap/frame_*.png "$work/gap/parts-frame_"
"$bin" render "$repo/scenes/turntable.toml" "${flags[@]}" --backend cpu --frames 3..5 --tiles 2 \
    --task-index 0/1 -q -o "$work/gap/parts-frame_/f####-{tile}.exr" || fail "frames 3..5 in one process failed"
rm "$work"/gap/parts-frame_/f0004-*.exr
rc=0
sbatch --wait -Q "$repo/ci/slurm/merge.sbatch" "$work/gap/frame_####.png" "$work/gap/parts-frame_" || rc=$?
grep -q "frame 4 has no parts" fragtrace-merge-*.log || fail "the merge did not name the missing frame 4"
[ ! -f "$work/gap/frame_0003.png" ] || fail "the merge wrote frame 3 with frame 4 missing"
echo "slurm test: a frame without parts: the merge refuses, naming frame 4"

echo "slurm test: passed in $(($(date +%s) - t0)) s of jobs"
