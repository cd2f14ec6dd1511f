#!/usr/bin/env bash
# H200, stop 37: NEW = bfab3b2 (the irregular walk's fix for faces an ulp off, 1027322: a
# face behind the previous exit is crossed at once, the first cell brackets the entry
# parameter; and the CPU's vector step with eight rays in AVX2 lanes) against OLD = 86be750
# (stop 36's final build): hard cases on NVIDIA (test binaries of 1027322), GPU-vs-CPU
# tests, the CPU on the host (issue 27), the equal-work view and the full Whitted scenes for
# GPU speed, and every shipped scene's image OLD vs NEW. Carried: .gl, .devbin (fragtrace = NEW, fragtrace-old =
# 86be750, tests/), .models.tar.xz. Log to stdout.
set -uo pipefail
. ci/h200/setup.sh
echo "== hard cases and GPU tests (NEW test binaries) on the H200"
export FRAGTRACE_ALLOW_SKIP=1
mkdir -p /work/main/target/debug /work/main/target/release
ln -sf "$PWD/$NEW" /work/main/target/debug/fragtrace; ln -sf "$PWD/$NEW" /work/main/target/release/fragtrace
for t in .devbin/tests/hard_cases-* .devbin/tests/gpu_backend-*; do
  echo "-- $(basename $t)"; timeout 200 $t --test-threads 8 2>&1 | grep -E "^test result|FAILED|panicked|failures:|differ from brute force" | grep -v " 0 differ" | head -20
done
t=$(ls .devbin/tests/hard_cases-*); timeout 100 $t case_08_09 --nocapture 2>&1 | grep -E "irregular.*(differ|steps)|test result"
echo "== CPU f32 (--cpu-path simd), equal-work 1024², OLD vs NEW, 3 rounds interleaved"
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
for b in $OLD $NEW; do for s in ci/peers/equal-work.toml scenes/bunny.toml ""; do $b render $s --width 128 --height 128 -q -o /tmp/warm.png 2>/dev/null; done; done
echo "== equal-work steady state (frames 2..10), 2 rounds"
for size in 4096 1024; do for round in 1 2; do for v in OLD NEW; do b=${!v}
  $b render ci/h200/equal-work-still.toml --frames 0..9 --width $size --height $size -q -o /tmp/st-$v-####.png --stats /tmp/st.json; echo "$v ${size}² round $round"; summ /tmp/st.json
done; done; echo "   OLD vs NEW ${size}²: $($NEW compare /tmp/st-OLD-0009.png /tmp/st-NEW-0009.png 2>&1 | tail -1)"; done
echo "== full Whitted scenes 4096², GPU ms, 2 rounds"
for s in scenes/bunny.toml ""; do for round in 1 2; do for v in OLD NEW; do b=${!v}
  $b render $s --width 4096 --height 4096 -q -o /tmp/sc-$v.png --stats /tmp/sc.json
  python3 -c "import json; d=json.load(open('/tmp/sc.json')); print('${s:-default} $v round $round: GPU', round(d['gpu']['gpu_ms_total'],2), 'ms, render_ms', round(d['render_ms'],1))"
done; done; echo "   OLD vs NEW: $($NEW compare /tmp/sc-OLD.png /tmp/sc-NEW.png 2>&1 | tail -1)"; done
echo "== every shipped scene, OLD vs NEW, 512x384: compute, multipass"
compare_scenes compute multipass
