#!/usr/bin/env bash
# H200, one device call (session of 2026-12-02, 15:08-18:08): the fragment kernels'
# read-back with the wait for their last passes timed apart (phase `drain`); the irregular
# build at 16 threads, main (NEW) against the build-scaling branch (SCALE); the integration
# test binary compute_kernel with the fragtrace binary where Cargo compiled its path in.
# Carried: .gl, .devbin (fragtrace, fragtrace-scale, tests/), .models.tar.xz.
set -uo pipefail
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/models && tar xJf .models.tar.xz -C /tmp/models
export FRAGTRACE_MODEL_PATH=/tmp/models
NEW=.devbin/fragtrace SCALE=.devbin/fragtrace-scale
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
if [ -x "$SCALE" ]; then
  echo "== irregular build, NEW (main) vs SCALE (build-scaling branch), medians of 5"
  THREADS=16 RUNS=5 bash ci/compare-build.sh $NEW $SCALE 2>&1 | tail -3
  THREADS=2 RUNS=5 bash ci/compare-build.sh $NEW $SCALE 2>&1 | tail -3
  echo "== icosphere scenes (ci/measure-build.sh), 16 threads: NEW then SCALE, then SCALE at 1 thread"
  bash ci/measure-build.sh $NEW irregular 16 2>&1 | tail -6
  bash ci/measure-build.sh $SCALE irregular 16 2>&1 | tail -6
  bash ci/measure-build.sh $SCALE irregular 1 2>&1 | tail -6
  RAYON_NUM_THREADS=16 $SCALE render scenes/bunny.toml --backend cpu --width 8 --height 8 -q -o /tmp/x.png -v 2>&1 | grep -i "irregular" | head -3
fi
echo "== compute_kernel tests, the binary where Cargo put it"
mkdir -p /work/main/target/release && ln -sf "$PWD/$NEW" /work/main/target/release/fragtrace
export FRAGTRACE_ALLOW_SKIP=1
for t in .devbin/tests/compute_kernel-*; do timeout 200 $t --test-threads 4 2>&1 | grep -E "^test |^test result|panicked" | head -12; done
