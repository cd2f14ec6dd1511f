#!/usr/bin/env bash
# H200 host, stop 43 (issue 27): is the 16-thread icosphere build held back by the kernel's
# page faults on fresh memory? BASE (1add14f) and SLAB2 with glibc's defaults and with its
# mmap and trim thresholds raised (freed memory kept in the process), interleaved.
# CPU only; carried: .devbin.
# The set-up is ci/h200/setup-cpu.sh's (when it ran, this script did the same steps itself,
# writing s3m.toml with its own copy of ci/measure-build.sh's generator).
set -uo pipefail
. ci/h200/setup-cpu.sh
T='glibc.malloc.mmap_threshold=4294967295:glibc.malloc.trim_threshold=4294967295:glibc.malloc.top_pad=268435456'
for round in 1 2 3; do
  for b in base slab2; do
    for tun in "" "$T"; do
      GLIBC_TUNABLES=$tun RAYON_NUM_THREADS=16 /usr/bin/time -f "%e s %M KB maxrss %F majfl %R minfl" $B-$b render $dir/s3m.toml --backend cpu --accel irregular --width 8 --height 8 -q -o $dir/x.png --stats $dir/s.json 2> $dir/time.txt
      python3 -c "import json,re; d=json.load(open('$dir/s.json')); m=re.search(r'built in .*', d['accel']['detail']); print('s3m 16 $b tunables=${tun:+on}', m.group(0), open('$dir/time.txt').read().strip())"
    done
  done
done
