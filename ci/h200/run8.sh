#!/usr/bin/env bash
# H200, last device call of the session (issue 26): the final build (86be750: the map in
# hops built by the GPU layout only) against OLD = a03c542 on the equal-work view and the
# full Whitted scenes, every shipped scene's image, and the GL test binaries of 9712123
# (the GPU code of the final build but for the literal form of irr_lookup's strides), the
# CLI tests running the final binary. Carried as in run7.sh. Log to stdout. (Written with
# its set-up inline; since moved into setup.sh, which run6-run8 share.)
set -uo pipefail
. ci/h200/setup.sh
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
echo "== every shipped scene, OLD vs NEW, 512x384: compute, looped, multipass"
compare_scenes compute looped multipass
echo "== GL test binaries (9712123) on the H200"
export FRAGTRACE_ALLOW_SKIP=1
mkdir -p /work/main/target/debug /work/main/target/release
ln -sf "$PWD/$NEW" /work/main/target/debug/fragtrace; ln -sf "$PWD/$NEW" /work/main/target/release/fragtrace
for t in .devbin/tests/compute_kernel-* .devbin/tests/glsl_twins-* .devbin/tests/gpu_backend-* .devbin/tests/hard_cases-* .devbin/tests/fragtrace-*; do
  f=(); case $(basename $t) in fragtrace-*) f=(gpu::);; esac
  echo "-- $(basename $t)"; timeout 150 $t "${f[@]}" --test-threads 8 2>&1 | grep -E "^test result|FAILED|panicked|failures:" | head -8
done
