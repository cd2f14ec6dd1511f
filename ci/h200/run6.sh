#!/usr/bin/env bash
# H200, one device call (issue 26, the kernel): the voxel map in hops of several levels
# (accel/irregular_wide.rs) and the lateral cell's crossings computed once
# (glsl120/traverse.glsl), against OLD = a03c542 (stop 35), with Mitsuba 3 cuda_ad_rgb on
# the same equal-work view in the same run. NEW runs with FRAGTRACE_VMAP_HOP_BITS=1 (the
# built map's levels one per hop: the lateral change alone), 6 and 9, and unset (its
# default). Carried: .gl, .devbin (fragtrace, fragtrace-old, stripped), .models.tar.xz,
# .peers (ci/h200/frames3.sh says how each is made). Log to stdout.
set -uo pipefail
. ci/h200/setup.sh
# config name -> binary and hop bits ("" = the binary's default)
cfgs=(old new1 new6 new9 new)
run_cfg() { local c=$1; shift
  case $c in
    old) "$OLD" "$@";;
    new) "$NEW" "$@";;
    new*) FRAGTRACE_VMAP_HOP_BITS=${c#new} "$NEW" "$@";;
  esac
}
echo "== warm the shader cache (a cold compile is 4 s on this driver)"
for c in "${cfgs[@]}"; do
  for s in ci/peers/equal-work.toml scenes/bunny.toml ""; do
    run_cfg $c render $s --width 128 --height 128 -q -o /tmp/warm.png 2>/dev/null
  done
done
echo "== equal-work steady-state frame 4096² (frames 2..10 of --frames 0..9), 3 rounds interleaved"
for round in 1 2 3; do
  for c in "${cfgs[@]}"; do
    run_cfg $c render ci/h200/equal-work-still.toml --frames 0..9 --width 4096 --height 4096 -q -o /tmp/still-$c-####.png --stats /tmp/steady.json 2>>/tmp/stderr.log
    echo "$c round $round"; summ /tmp/steady.json
  done
done
for c in new1 new6 new9 new; do echo "   old vs $c: $($NEW compare /tmp/still-old-0009.png /tmp/still-$c-0009.png 2>&1 | tail -1)"; done
echo "== equal-work steady-state frame 1024², 2 rounds"
for round in 1 2; do
  for c in old new; do
    run_cfg $c render ci/h200/equal-work-still.toml --frames 0..9 --width 1024 --height 1024 -q -o /tmp/s1k-$c-####.png --stats /tmp/steady.json 2>>/tmp/stderr.log
    echo "$c 1024² round $round"; summ /tmp/steady.json
  done
done
echo "== bunny.toml and the default scene, 4096², one render a process (GPU ms), 3 rounds"
for s in scenes/bunny.toml ""; do
  for round in 1 2 3; do
    for c in old new6 new9 new; do
      run_cfg $c render $s --width 4096 --height 4096 -q -o /tmp/sc-$c.png --stats /tmp/sc.json 2>>/tmp/stderr.log
      echo "${s:-default} $c round $round"; one /tmp/sc.json
    done
  done
  for c in new6 new9 new; do echo "   ${s:-default} old vs $c: $($NEW compare /tmp/sc-old.png /tmp/sc-$c.png 2>&1 | tail -1)"; done
done
echo "== whole process to PNG, equal-work 4096², 3 rounds"
for round in 1 2 3; do
  for c in old new; do
    t0=$(date +%s%N); run_cfg $c render ci/peers/equal-work.toml --width 4096 --height 4096 -q -o /tmp/wp-$c.png 2>>/tmp/stderr.log
    echo "$c round $round: $(( ($(date +%s%N) - t0) / 1000000 )) ms"
  done
done
echo "== every shipped scene, OLD vs NEW (default hops), 512x384: compute, looped, multipass"
compare_scenes compute looped multipass
echo "== Mitsuba 3.9.1 cuda_ad_rgb, same view"
mkdir -p /tmp/site && tar xJf .peers/mitsuba-cuda.tar.xz -C /tmp/site && export PYTHONPATH=/tmp/site
PYTHONUNBUFFERED=1 timeout 200 python3 ci/peers/mitsuba_equal_work.py /tmp/models/bunny/stanford-bunny.obj cuda_ad_rgb 1024,4096 5 2>&1 | tail -4
echo "== stderr (last lines)"; tail -5 /tmp/stderr.log
