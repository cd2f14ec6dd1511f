#!/usr/bin/env bash
# H200 host, stop 43 (issue 27): the voxel map's per-run tables reserved up front (ROOM =
# FINAL with `Vec::with_capacity` from the run's references) against FINAL (003f31a) and the
# issue's start (START = e763231): the 3.3 M icosphere at 16 threads, seven interleaved
# rounds; bunny.toml at 2 and 16 threads (ci/compare-build.sh, 9 rounds). CPU only;
# carried: .devbin, .models.tar.xz.
set -uo pipefail
. ci/h200/setup-cpu.sh
for round in 1 2 3 4 5 6 7; do
  for b in start final room; do
    RAYON_NUM_THREADS=16 /usr/bin/time -f "%e s %R minfl" -o $dir/t.txt $B-$b render $dir/s3m.toml --backend cpu --accel irregular --width 8 --height 8 -q -o $dir/x.png --stats $dir/s.json
    python3 -c "import json,re; d=json.load(open('$dir/s.json')); m=re.search(r'built in .*', d['accel']['detail']); print('s3m 16 $b', m.group(0), open('$dir/t.txt').read().strip())"
  done
done
for t in 2 16; do SCENE=scenes/bunny.toml THREADS=$t RUNS=9 bash ci/compare-build.sh $B-start $B-final $B-room; done
uptime
