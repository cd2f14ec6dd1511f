#!/usr/bin/env bash
# H200 host, stop 42 (issue 27): where the irregular build's time goes on 16 cores. The
# 3.3 M-triangle icosphere of ci/measure-build.sh and the equal-work bunny, built by NEW
# (the irregular build of 616ad69, unchanged since) at 16, 8, 4 and 2 threads, twice each;
# one line per build with every phase (`accel.detail`). Carried: .gl, .devbin, .models.tar.xz.
# The scenes come from `ci/measure-build.sh --write-scenes` (when it ran, this script wrote
# the same s3m.toml with its own copy of that generator).
set -uo pipefail
. ci/h200/setup.sh
nproc; uptime
dir=$(mktemp -d)
bash ci/measure-build.sh --write-scenes "$dir"
for scene in "$dir/s3m.toml" ci/peers/equal-work.toml; do
  for t in 16 8 4 2 16 8 4 2; do
    RAYON_NUM_THREADS=$t $NEW render "$scene" --backend cpu --accel irregular --width 8 --height 8 -q -o "$dir/x.png" --stats "$dir/s.json"
    python3 -c "import json,re; d=json.load(open('$dir/s.json')); print('$(basename $scene) threads $t', re.search(r'built in.*', d['accel']['detail']).group(0))"
  done
done
