#!/usr/bin/env bash
# H200 host, stop 39 (issue 27): the CPU walk with ropes and the next cells prefetched
# (NEW) against bfab3b2 (OLD, stop 37's step8), both --cpu-path simd: the equal-work view at
# 2 and 16 threads and bunny.toml (the mirror floor of the POV-Ray comparison), rounds
# interleaved, images compared. No GPU work. Carried: .gl, .devbin (fragtrace = NEW,
# fragtrace-old = OLD), .models.tar.xz. Log to stdout.
set -uo pipefail
. ci/h200/setup.sh
nproc; uptime
echo "== CPU f32 (--cpu-path simd), equal-work 1024², OLD vs NEW, 5 rounds interleaved"
for th in 2 16; do
  for round in 1 2 3 4 5; do
    for v in OLD NEW; do
      b=${!v}
      RAYON_NUM_THREADS=$th $b render ci/peers/equal-work.toml --backend cpu --precision f32 --width 1024 --height 1024 -q -o /tmp/c-$v.png --stats /tmp/c.json
      python3 -c "import json; d=json.load(open('/tmp/c.json')); print('$v $th threads round $round: build', round(d['accel']['build_ms'],1), 'ms, render', round(d['render_ms'],1), 'ms, cells', d['cells_visited'], 'tests', d['triangle_tests'])"
    done
  done
  echo "   OLD vs NEW: $($NEW compare /tmp/c-OLD.png /tmp/c-NEW.png 2>&1 | tail -1)"
done
echo "== bunny.toml 1024² (mirror floor, depth 5), CPU, whole process, 3 rounds interleaved"
for th in 2 16; do
  for round in 1 2 3; do
    for v in OLD NEW; do
      b=${!v}
      s=$(date +%s.%N)
      RAYON_NUM_THREADS=$th $b render scenes/bunny.toml --backend cpu --width 1024 --height 1024 -q -o /tmp/b-$v.png --stats /tmp/b.json
      e=$(date +%s.%N)
      python3 -c "import json; d=json.load(open('/tmp/b.json')); print('$v $th threads round $round: whole', round(($e-$s)*1000), 'ms, build', round(d['accel']['build_ms'],1), 'ms, render', round(d['render_ms'],1), 'ms')"
    done
  done
  echo "   OLD vs NEW: $($NEW compare /tmp/b-OLD.png /tmp/b-NEW.png 2>&1 | tail -1)"
done
echo "== every shipped scene on the CPU (f32 simd), OLD vs NEW, 256x192"
for s in scenes/*.toml; do case $s in *turntable*) continue;; esac
  $OLD render "$s" --backend cpu --precision f32 --width 256 --height 192 -q -o /tmp/p-old.png 2>/dev/null
  $NEW render "$s" --backend cpu --precision f32 --width 256 --height 192 -q -o /tmp/p-new.png 2>/dev/null
  echo "$(basename $s): $($NEW compare /tmp/p-old.png /tmp/p-new.png 2>&1 | tail -1)"
done
