#!/usr/bin/env bash
# The distributed render against a real Slurm: starts a single-node cluster on this host
# (ci/slurm/cluster.sh: munged, slurmctld, slurmd from Debian's packages, no systemd),
# submits the job scripts of ci/slurm/ as a user would, waits for them (sbatch --wait),
# and checks that every merged image and every frame has exactly the bits of the
# single-process render: tiles of a still (GL and CPU), whole frames of an animation, and
# frames cut into tiles.
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
# 1. One image, 4 tasks, one tile each; the default backend (the GPU where EGL has one,
#    llvmpipe here), to PNG.
flags=(--width 320 --height 240 --spp 2)
"$bin" render "$repo/scenes/whitted.toml" "${flags[@]}" -q -o "$work/whitted-single.png" ||
    fail "the single-process render of whitted.toml failed"
"$repo/ci/slurm/submit-tiles.sh" --wait 4 "$repo/scenes/whitted.toml" \
    "$work/whitted.png" "${flags[@]}" || fail "the whitted.toml job (4 tiles) failed"
[ "$(ls "$work"/parts-whitted/*.exr | wc -l)" -eq 4 ] || fail "expected 4 parts of whitted"
same "$work/whitted.png" "$work/whitted-single.png"

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

echo "slurm test: passed in $(($(date +%s) - t0)) s of jobs"
