#!/usr/bin/env bash
# H200 host, stop 42 (issue 27): where the irregular build's time goes on 16 cores. The
# 3.3 M-triangle icosphere of ci/measure-build.sh and the equal-work bunny, built by NEW
# (the irregular build of 616ad69, unchanged since) at 16, 8, 4 and 2 threads, twice each;
# one line per build with every phase (`accel.detail`). Carried: .gl, .devbin, .models.tar.xz.
set -uo pipefail
. ci/h200/setup.sh
nproc; uptime
dir=$(mktemp -d)
python3 - "$dir" <<'PY'
import math, sys
out = sys.argv[1]
sub, n = 7, 10
s = ('background = [0.5, 0.6, 0.8]\nambient = [0.1, 0.1, 0.1]\n'
     '[camera]\neye = [0.0, 4.0, 12.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 60\n'
     '[[lights]]\nposition = [5.0, 10.0, 5.0]\nintensity = 0.9\n'
     '[materials.m]\nalbedo = [0.8, 0.3, 0.2]\n')
k = math.ceil(math.sqrt(n))
for i in range(n):
    x, z = (i % k) * 2.2 - (k - 1) * 1.1, (i // k) * 2.2 - (k - 1) * 1.1
    s += f'[[objects]]\nshape = "sphere"\nsubdivisions = {sub}\ntranslate = [{x}, 0.0, {z}]\nmaterial = "m"\n'
open(f"{out}/s3m.toml", "w").write(s)
PY
for scene in "$dir/s3m.toml" ci/peers/equal-work.toml; do
  for t in 16 8 4 2 16 8 4 2; do
    RAYON_NUM_THREADS=$t $NEW render "$scene" --backend cpu --accel irregular --width 8 --height 8 -q -o "$dir/x.png" --stats "$dir/s.json"
    python3 -c "import json,re; d=json.load(open('$dir/s.json')); print('$(basename $scene) threads $t', re.search(r'built in.*', d['accel']['detail']).group(0))"
  done
done
