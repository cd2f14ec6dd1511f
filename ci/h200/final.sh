#!/usr/bin/env bash
# Last H200 run of the session (one device call): the compute kernel's progress bands after
# the doubling rule, the irregular build on 16 cores before and after issue 27's build work,
# and the GL test binaries of this build. Carried: .gl, .devbin (fragtrace, fragtrace-e763 =
# the build before the build work, fragtrace-base = 6439039, the build before the fragment
# kernels' staging read-back, test binaries under .devbin/tests), .models.tar.xz.
set -uo pipefail
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/models && tar xJf .models.tar.xz -C /tmp/models
export FRAGTRACE_MODEL_PATH=/tmp/models
NEW=.devbin/fragtrace OLD=.devbin/fragtrace-e763 BASE=.devbin/fragtrace-base
one() { python3 - "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); g = d.get("gpu") or {}
print(f"   render_ms {d['render_ms']:.1f} gpu_ms_total {g.get('gpu_ms_total') or 0:.2f} phases " + ", ".join(f"{k} {v:.2f}" for k, v in sorted((g.get('phases_ms') or {}).items())) + f" passes {g.get('passes_total')}")
PY
}
$NEW render ci/peers/equal-work.toml --width 256 --height 256 -q -o /tmp/warm.png
echo "== compute kernel 4096², headless vs with its progress bar drawn (script), 2 runs each"
for run in 1 2; do
  $NEW render ci/peers/equal-work.toml --width 4096 --height 4096 -q -o /tmp/h.png --stats /tmp/h.json; echo "headless run $run"; one /tmp/h.json
  script -qc "$NEW render ci/peers/equal-work.toml --width 4096 --height 4096 -o /tmp/b.png --stats /tmp/b.json" /dev/null > /dev/null; echo "bar run $run"; one /tmp/b.json
done
echo "   bar vs headless: $($NEW compare /tmp/b.png /tmp/h.png 2>&1 | tail -1)"
echo "== irregular build, bunny, 16 and 2 threads, OLD (e763231) vs NEW, medians of 5"
THREADS=16 RUNS=5 bash ci/compare-build.sh $OLD $NEW 2>&1 | tail -6
THREADS=2 RUNS=5 bash ci/compare-build.sh $OLD $NEW 2>&1 | tail -6
echo "== icosphere scenes (ci/measure-build.sh), 16 threads: OLD then NEW"
bash ci/measure-build.sh $OLD irregular 16 2>&1 | tail -6
bash ci/measure-build.sh $NEW irregular 16 2>&1 | tail -6
echo "== fragment kernels, 4096² PNG: 8-bit read-back through the staging ring (NEW) vs glReadPixels into client memory (BASE), 2 runs each"
$BASE render ci/peers/equal-work.toml --kernel looped --width 256 --height 256 -q -o /tmp/warm.png
for run in 1 2; do
  for v in BASE NEW; do
    b=${!v}; $b render ci/peers/equal-work.toml --kernel looped --width 4096 --height 4096 -q -o /tmp/f-$v.png --stats /tmp/f-$v.json; echo "$v looped run $run"; one /tmp/f-$v.json
  done
done
echo "   BASE vs NEW: $($NEW compare /tmp/f-BASE.png /tmp/f-NEW.png 2>&1 | tail -1)"
for run in 1 2; do
  for v in BASE NEW; do
    b=${!v}; $b render ci/peers/equal-work.toml --kernel multipass --width 2048 --height 2048 -q -o /tmp/m-$v.png --stats /tmp/m-$v.json; echo "$v multipass 2048² run $run"; one /tmp/m-$v.json
  done
done
echo "   BASE vs NEW: $($NEW compare /tmp/m-BASE.png /tmp/m-NEW.png 2>&1 | tail -1)"
echo "== GL test binaries of this build on the H200"
export FRAGTRACE_ALLOW_SKIP=1
for t in .devbin/tests/*; do
  f=(); case $(basename $t) in fragtrace-*) f=(gpu::);; esac
  echo "-- $(basename $t)"; timeout 240 $t "${f[@]}" --test-threads 4 2>&1 | grep -E "^test result|FAILED|panicked|failures:" | head -8
done
