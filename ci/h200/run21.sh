#!/usr/bin/env bash
# H200 host, stop 43 (issue 27): this stop's build (HEAD = b5decc2: the binning's widened
# run and slab paths) against the start (START = e763231) and stop 42 (BASE =
# 1add14f), in one run. The 3.3 M icosphere of ci/measure-build.sh at 16 threads, five
# interleaved rounds, and once at 2 threads; bunny.toml and the equal-work bunny at 2 and 16
# threads (ci/compare-build.sh, 11 rounds). CPU only; carried: .devbin, .models.tar.xz.
set -uo pipefail
. ci/h200/setup-cpu.sh
ico() {
  RAYON_NUM_THREADS=$1 $B-$2 render $dir/s3m.toml --backend cpu --accel irregular --width 8 --height 8 -q -o $dir/x.png --stats $dir/s.json
  python3 -c "import json,re; d=json.load(open('$dir/s.json')); m=re.search(r'built in .*', d['accel']['detail']); print('s3m $1 $2', m.group(0))"
}
for round in 1 2 3 4 5; do for b in start base head; do ico 16 $b; done; done
for b in start base head; do ico 2 $b; done
for t in 2 16; do
  for s in scenes/bunny.toml ci/peers/equal-work.toml; do
    SCENE=$s THREADS=$t RUNS=11 bash ci/compare-build.sh $B-start $B-base $B-head
  done
done
uptime
