#!/usr/bin/env bash
# H200, one device call, after run6 (the voxel map in hops, built with the grid): the CPU
# backend on the H200's host against OLD = a03c542 (issue 27: render and build), the
# turntable, every configuration of ci/compare-binaries.sh OLD vs NEW, and the GL test
# binaries of this build. Carried: .gl, .devbin (fragtrace, fragtrace-old, stripped; test
# binaries under .devbin/tests), .models.tar.xz. Log to stdout.
set -uo pipefail
. ci/h200/setup.sh
echo "== CPU f32 (--cpu-path simd, the default), equal-work 1024², OLD vs NEW, 3 rounds interleaved"
for th in 2 16; do
  for round in 1 2 3; do
    for v in OLD NEW; do
      b=${!v}
      RAYON_NUM_THREADS=$th $b render ci/peers/equal-work.toml --backend cpu --precision f32 --width 1024 --height 1024 -q -o /tmp/c-$v.png --stats /tmp/c.json
      python3 -c "import json; d=json.load(open('/tmp/c.json')); print('$v $th threads round $round: build', round(d['accel']['build_ms'],1), 'ms, render', round(d['render_ms'],1), 'ms')"
    done
  done
  echo "   OLD vs NEW: $($NEW compare /tmp/c-OLD.png /tmp/c-NEW.png 2>&1 | tail -1)"
done
echo "== irregular build, bunny (ci/compare-build.sh), OLD vs NEW, 16 and 2 threads, medians of 5"
THREADS=16 RUNS=5 bash ci/compare-build.sh $OLD $NEW 2>&1 | tail -4
THREADS=2 RUNS=5 bash ci/compare-build.sh $OLD $NEW 2>&1 | tail -4
echo "== icosphere scenes (ci/measure-build.sh), 16 threads: OLD then NEW"
bash ci/measure-build.sh $OLD irregular 16 2>&1 | tail -6
bash ci/measure-build.sh $NEW irregular 16 2>&1 | tail -6
echo "== turntable, 120 x 1024² PNG, NEW, 2 runs (the first warms the shader cache)"
for run in 1 2; do
  t0=$(date +%s%N); $NEW render scenes/turntable.toml --frames all --width 1024 --height 1024 -q -o /tmp/tt_####.png
  echo "run $run: whole process $(( ($(date +%s%N) - t0) / 1000000 )) ms"
done
echo "== ci/compare-binaries.sh OLD NEW (every scene, backend, kernel, both structures, 64x48)"
bash ci/compare-binaries.sh $OLD $NEW 2>&1 | tail -5
echo "== GL test binaries of this build on the H200"
export FRAGTRACE_ALLOW_SKIP=1
mkdir -p /work/main/target/release && ln -sf "$PWD/$NEW" /work/main/target/release/fragtrace
for t in .devbin/tests/*; do
  f=(); case $(basename $t) in fragtrace-*) f=(gpu::);; esac
  echo "-- $(basename $t)"; timeout 200 $t "${f[@]}" --test-threads 4 2>&1 | grep -E "^test result|FAILED|panicked|failures:" | head -8
done
