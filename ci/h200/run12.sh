#!/usr/bin/env bash
# H200 host, stop 40 (issue 27): the BVH build with the top splits' boxes and bins found in
# parallel chunks (NEW = .devbin/fragtrace), icosphere builds of ci/measure-build.sh at 16
# and 2 threads for the BVH and, on the same host in the same run, the irregular grid; the
# equal-work bunny's builds at 16 threads. Carried: .gl, .devbin, .models.tar.xz.
set -uo pipefail
. ci/h200/setup.sh
nproc; uptime
for a in bvh irregular bvh; do echo "-- $a"; bash ci/measure-build.sh $NEW $a 16 2; done
echo "== equal-work bunny, 16 threads, 5 rounds: build ms"
for round in 1 2 3 4 5; do for a in irregular bvh; do
  RAYON_NUM_THREADS=16 $NEW render ci/peers/equal-work.toml --backend cpu --precision f32 --accel $a --width 64 --height 64 -q -o /tmp/e.png --stats /tmp/e.json
  python3 -c "import json; d=json.load(open('/tmp/e.json')); print('$a round $round: build', round(d['accel']['build_ms'],1), 'ms;', d['accel']['detail'][:60])"
done; done
