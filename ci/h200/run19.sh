#!/usr/bin/env bash
# H200 host, stop 43 (issue 27): where the 3.3 M icosphere's build spends its time on 16
# threads now (phases per binary, 16/8/4 threads), and the bunny at 2 and 16 threads.
# START = e763231 (the start), BASE = 1add14f (stop 42), SLAB2 = BASE with the
# binning's slab and run paths widened, BLK = SLAB2 with the blocks' summed-volume table.
# KNOWN = SLAB2 with the per-thread cache of known empty exit boxes.
# CPU only; carried: .devbin, .models.tar.xz.
# The set-up is ci/h200/setup-cpu.sh's (when it ran, this script did the same steps itself,
# writing s3m.toml with its own copy of ci/measure-build.sh's generator).
set -uo pipefail
. ci/h200/setup-cpu.sh
lscpu | grep -E "Model name|Thread|Core|Socket|L2|L3"
for round in 1 2; do
  for t in 16 8 4; do
    for b in start base slab2 blk known; do
      RAYON_NUM_THREADS=$t $B-$b render $dir/s3m.toml --backend cpu --accel irregular --width 8 --height 8 -q -o $dir/x.png --stats $dir/s.json
      python3 -c "import json,re; d=json.load(open('$dir/s.json')); m=re.search(r'built in .*', d['accel']['detail']); print('s3m $t $b', m.group(0))"
    done
  done
done
for t in 2 16; do SCENE=scenes/bunny.toml THREADS=$t RUNS=9 bash ci/compare-build.sh $B-start $B-base $B-slab2 $B-blk $B-known; done
