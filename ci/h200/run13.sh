#!/usr/bin/env bash
# H200 host, stop 41 (issue 27): OLD = 9569f93 (the irregular grid the CPU's default), NEW =
# this stop (`--accel auto`: the BVH on the CPU; the irregular build's binning pass).
# Irregular builds of ci/measure-build.sh's icospheres at 16 and 2 threads, both binaries
# in one run; the equal-work bunny's irregular build, interleaved, 16 threads; the default
# CPU renders old against new (ci/compare-default.sh) at 16 threads; what `auto` picks.
# Carried: .gl, .devbin, .models.tar.xz.
set -uo pipefail
. ci/h200/setup.sh
nproc; uptime
for b in $OLD $NEW $OLD $NEW; do echo "-- irregular, $b"; bash ci/measure-build.sh $b irregular 16 2; done
echo "== equal-work bunny, irregular build, 16 threads"
SCENE=ci/peers/equal-work.toml THREADS=16 RUNS=7 bash ci/compare-build.sh $OLD $NEW
echo "== default CPU renders, 16 threads"
THREADS=16 RUNS=5 bash ci/compare-default.sh $OLD $NEW
echo "== what auto picks"
for flags in "" "--backend cpu" "--backend gl" "--backend cpu --grid-density 0.5"; do
  $NEW render ci/peers/equal-work.toml $flags --width 256 --height 256 -q -o /tmp/a.png --stats /tmp/a.json
  python3 -c "import json; d=json.load(open('/tmp/a.json')); print('flags [$flags]:', d['backend'], d['accel']['kind'])"
done
