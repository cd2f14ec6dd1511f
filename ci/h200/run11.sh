#!/usr/bin/env bash
# H200 host, stop 40 (issue 27): the CPU's BVH (--accel bvh) against the irregular grid,
# one binary (NEW = .devbin/fragtrace), --cpu-path simd: the equal-work view at 1, 2 and 16
# threads, bunny.toml (the mirror floor of the POV-Ray comparison) whole process, the
# icosphere builds of ci/measure-build.sh at 16 and 2 threads, every shipped scene's CPU
# image on both structures, and a GL render of every shipped scene against OLD (the GPU
# code changed only in how it is handed a grid). Carried: .gl, .devbin (fragtrace = NEW,
# fragtrace-old = the previous build for the GL check), .models.tar.xz. Log to stdout.
set -uo pipefail
. ci/h200/setup.sh
nproc; uptime
echo "== equal-work 1024², CPU f32 simd, irregular vs bvh, 5 rounds interleaved"
for th in 1 2 16; do
  for round in 1 2 3 4 5; do
    for a in irregular bvh; do
      RAYON_NUM_THREADS=$th $NEW render ci/peers/equal-work.toml --backend cpu --precision f32 --accel $a --width 1024 --height 1024 -q -o /tmp/c-$a.png --stats /tmp/c.json
      python3 -c "import json; d=json.load(open('/tmp/c.json')); print('$a $th threads round $round: build', round(d['accel']['build_ms'],1), 'ms, render', round(d['render_ms'],1), 'ms, cells', d['cells_visited'], 'tests', d['triangle_tests'])"
    done
  done
  echo "   irregular vs bvh: $($NEW compare /tmp/c-irregular.png /tmp/c-bvh.png 2>&1 | tail -1)"
done
echo "== bunny.toml 1024² (mirror floor, depth 5), CPU f32, whole process, 3 rounds interleaved"
for th in 2 16; do
  for round in 1 2 3; do
    for a in irregular bvh; do
      s=$(date +%s.%N)
      RAYON_NUM_THREADS=$th $NEW render scenes/bunny.toml --backend cpu --precision f32 --accel $a --width 1024 --height 1024 -q -o /tmp/b-$a.png --stats /tmp/b.json
      e=$(date +%s.%N)
      python3 -c "import json; d=json.load(open('/tmp/b.json')); print('$a $th threads round $round: whole', round(($e-$s)*1000), 'ms, build', round(d['accel']['build_ms'],1), 'ms, render', round(d['render_ms'],1), 'ms')"
    done
  done
  echo "   irregular vs bvh: $($NEW compare /tmp/b-irregular.png /tmp/b-bvh.png 2>&1 | tail -1)"
done
echo "== icosphere builds (ci/measure-build.sh), 16 and 2 threads"
for a in irregular bvh; do echo "-- $a"; bash ci/measure-build.sh $NEW $a 16 2; done
echo "== every shipped scene, CPU f32 256x192: irregular vs bvh"
for s in scenes/*.toml; do case $s in *turntable*) continue;; esac
  $NEW render "$s" --backend cpu --precision f32 --accel irregular --width 256 --height 192 -q -o /tmp/p-irr.png 2>/dev/null
  $NEW render "$s" --backend cpu --precision f32 --accel bvh --width 256 --height 192 -q -o /tmp/p-bvh.png 2>/dev/null
  echo "$(basename $s): $($NEW compare /tmp/p-irr.png /tmp/p-bvh.png 2>&1 | tail -1)"
done
echo "== GL (compute kernel) OLD vs NEW, every shipped scene 512x384"
compare_scenes compute
echo "== --backend gl --accel bvh is refused; auto takes the CPU"
$NEW render scenes/bunny.toml --backend gl --accel bvh --width 64 --height 64 -o /tmp/r.png; echo "rc $?"
$NEW render scenes/bunny.toml --accel bvh --width 64 --height 64 -o /tmp/r.png --stats /tmp/r.json; echo "rc $?"; python3 -c "import json; print(json.load(open('/tmp/r.json'))['device'])"
