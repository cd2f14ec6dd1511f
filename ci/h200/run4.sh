#!/usr/bin/env bash
# H200, one device call (session of 2026-12-02, 15:08-18:08): the fragment kernels'
# read-back with the wait for their last passes timed apart (phase `drain`); the irregular
# build at 16 threads, 6439039 (BASE) against this build with the build-scaling branch
# merged (NEW); the integration test binary compute_kernel with the fragtrace binary where
# Cargo compiled its path in. Carried: .gl, .devbin (fragtrace, fragtrace-base, tests/),
# .models.tar.xz.
set -uo pipefail
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/models && tar xJf .models.tar.xz -C /tmp/models
export FRAGTRACE_MODEL_PATH=/tmp/models
NEW=.devbin/fragtrace BASE=.devbin/fragtrace-base
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
one() { python3 - "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); g = d.get("gpu") or {}
print(f"   render_ms {d['render_ms']:.1f} gpu_ms_total {g.get('gpu_ms_total') or 0:.2f} phases " + ", ".join(f"{k} {v:.2f}" for k, v in sorted((g.get('phases_ms') or {}).items())) + f" passes {g.get('passes_total')}")
PY
}
$NEW render ci/peers/equal-work.toml --kernel looped --width 256 --height 256 -q -o /tmp/warm.png
echo "== fragment kernels' read-back, the last passes' wait apart (drain), 2 runs each"
for run in 1 2; do
  $NEW render ci/peers/equal-work.toml --kernel looped --width 4096 --height 4096 -q -o /tmp/f.png --stats /tmp/f.json; echo "looped 4096² PNG run $run"; one /tmp/f.json
  $NEW render ci/peers/equal-work.toml --kernel looped --width 4096 --height 4096 -q -o /tmp/f.exr --stats /tmp/f.json; echo "looped 4096² EXR (RGBA32F read-back) run $run"; one /tmp/f.json
  $NEW render ci/peers/equal-work.toml --kernel multipass --width 2048 --height 2048 -q -o /tmp/m.png --stats /tmp/m.json; echo "multipass 2048² PNG run $run"; one /tmp/m.json
done
echo "== irregular build, BASE (6439039) vs NEW (serial phases made parallel), medians of 5"
THREADS=16 RUNS=5 bash ci/compare-build.sh $BASE $NEW 2>&1 | tail -4
THREADS=2 RUNS=5 bash ci/compare-build.sh $BASE $NEW 2>&1 | tail -4
echo "== icosphere scenes (ci/measure-build.sh), 16 threads: BASE then NEW"
bash ci/measure-build.sh $BASE irregular 16 2>&1 | tail -6
bash ci/measure-build.sh $NEW irregular 16 2>&1 | tail -6
echo "== phases of the 3.3M-triangle icosphere build, NEW, 16 threads"
mkdir -p /tmp/ico && python3 - /tmp/ico <<'PY'
import sys
s = ('background = [0.5, 0.6, 0.8]\nambient = [0.1, 0.1, 0.1]\n[camera]\neye = [0.0, 4.0, 12.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 60\n'
     '[[lights]]\nposition = [5.0, 10.0, 5.0]\nintensity = 0.9\n[materials.m]\nalbedo = [0.8, 0.3, 0.2]\n')
for i in range(10):
    x, z = (i % 4) * 2.2 - 3.3, (i // 4) * 2.2 - 3.3
    s += f'[[objects]]\nshape = "sphere"\nsubdivisions = 7\ntranslate = [{x}, 0.0, {z}]\nmaterial = "m"\n'
open(sys.argv[1] + "/s3m.toml", "w").write(s)
PY
for run in 1 2; do RAYON_NUM_THREADS=16 $NEW render /tmp/ico/s3m.toml --backend cpu --width 8 --height 8 -q -o /tmp/x.png --stats /tmp/ico.json; python3 -c "import json; d=json.load(open('/tmp/ico.json')); print(d['triangles'], d['accel']['build_ms'], d['accel']['detail'])"; done
echo "== compute_kernel tests, the binary where Cargo put it"
mkdir -p /work/main/target/release && ln -sf "$PWD/$NEW" /work/main/target/release/fragtrace
export FRAGTRACE_ALLOW_SKIP=1
for t in .devbin/tests/compute_kernel-*; do timeout 200 $t --test-threads 4 2>&1 | grep -E "^test |^test result|panicked" | head -12; done
