#!/usr/bin/env bash
# H200 host, stop 44 (issue 27): this stop's build (S44A = 8b4d64d: node records for
# the growth's queries, comparisons for a node frame's cells, the holding ancestor by bits,
# the one-cell check without a store-forwarding stall; the same structure) against stop 43's
# (FINAL = 003f31a) and the start (START = e763231); ENV = S44A with the growth's
# schedule read from GR_R (rounds), GR_F (step factor), GR_H (halve after a failure), for the
# schedule study only. The 3.3 M icosphere at 16 threads, seven interleaved rounds; bunny.toml
# at 2 and 16 threads (ci/compare-build.sh, 9 rounds). CPU only; carried: .devbin,
# .models.tar.xz.
set -uo pipefail
. ci/h200/setup-cpu.sh
run() { # NAME BINARY [ENV...]
  local name=$1 bin=$2; shift 2
  env "$@" RAYON_NUM_THREADS=16 /usr/bin/time -f "%e s %R minfl" -o $dir/t.txt $bin render $dir/s3m.toml --backend cpu --accel irregular --width 8 --height 8 -q -o $dir/x.png --stats $dir/s.json
  python3 -c "import json,re; d=json.load(open('$dir/s.json')); m=re.search(r'built in .*', d['accel']['detail']); print('s3m 16 $name', m.group(0), open('$dir/t.txt').read().strip())"
}
for round in 1 2 3 4 5 6 7; do
  run start $B-start
  run final $B-final
  run s44a $B-s44a
  run env-r4h0 $B-env GR_R=4 GR_F=2 GR_H=0
  run env-r3f4 $B-env GR_R=3 GR_F=4 GR_H=1
done
for t in 2 16; do SCENE=scenes/bunny.toml THREADS=$t RUNS=9 bash ci/compare-build.sh $B-start $B-final $B-s44a; done
uptime
