#!/usr/bin/env bash
# H200 host, stop 44 (issue 27): this stop's build (S44B = bad44fa: node records for the
# growth's queries, comparisons for a node frame's cells, the holding ancestor by bits, the
# split levels worked out once, no store-forwarding stall in the one-cell check, array maps
# written out, 32-byte leaf cells in the runs; the same structure as e763231's) against stop 43's (FINAL = 003f31a) and the
# issue's start (START = e763231): the 3.3 M icosphere at 16 threads, nine interleaved
# rounds; bunny.toml at 2 and 16 threads (ci/compare-build.sh, 11 rounds). CPU only;
# carried: .devbin, .models.tar.xz.
set -uo pipefail
. ci/h200/setup-cpu.sh
for round in 1 2 3 4 5 6 7 8 9; do
  for b in start final s44b; do
    RAYON_NUM_THREADS=16 /usr/bin/time -f "%e s %R minfl" -o $dir/t.txt $B-$b render $dir/s3m.toml --backend cpu --accel irregular --width 8 --height 8 -q -o $dir/x.png --stats $dir/s.json
    python3 -c "import json,re; d=json.load(open('$dir/s.json')); m=re.search(r'built in .*', d['accel']['detail']); print('s3m 16 $b', m.group(0), open('$dir/t.txt').read().strip())"
  done
done
for t in 2 16; do SCENE=scenes/bunny.toml THREADS=$t RUNS=11 bash ci/compare-build.sh $B-start $B-final $B-s44b; done
uptime
