#!/usr/bin/env bash
# H200, one device call: the fragment kernels' 8-bit read-back with the srgb8 pass timed
# apart (phase `srgb8`) and the layout the driver prefers (GL_IMPLEMENTATION_COLOR_READ_*),
# BASE = 6439039 for the image. Ran twice (docs/bench/h200/run5/): 5a with glReadPixels
# straight into the mapped staging slot, 5b reading into a GPU buffer first and copying it
# into the slot (tried and not kept; the read-format query went with it: RGBA8 on NVIDIA).
set -uo pipefail
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/models && tar xJf .models.tar.xz -C /tmp/models
export FRAGTRACE_MODEL_PATH=/tmp/models
NEW=.devbin/fragtrace BASE=.devbin/fragtrace-base
one() { python3 - "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); g = d.get("gpu") or {}
print(f"   render_ms {d['render_ms']:.1f} gpu_ms_total {g.get('gpu_ms_total') or 0:.2f} read_format {g.get('read_format')} phases " + ", ".join(f"{k} {v:.2f}" for k, v in sorted((g.get('phases_ms') or {}).items())))
PY
}
$NEW render ci/peers/equal-work.toml --kernel looped --width 256 --height 256 -q -o /tmp/warm.png
$BASE render ci/peers/equal-work.toml --kernel looped --width 256 --height 256 -q -o /tmp/warm.png
for run in 1 2 3; do
  $NEW render ci/peers/equal-work.toml --kernel looped --width 4096 --height 4096 -q -o /tmp/f.png --stats /tmp/f.json; echo "NEW looped 4096² PNG run $run"; one /tmp/f.json
done
$BASE render ci/peers/equal-work.toml --kernel looped --width 4096 --height 4096 -q -o /tmp/b.png
echo "   BASE vs NEW: $($NEW compare /tmp/b.png /tmp/f.png 2>&1 | tail -1)"
for run in 1 2; do
  $NEW render ci/peers/equal-work.toml --kernel multipass --width 2048 --height 2048 -q -o /tmp/m.png --stats /tmp/m.json; echo "NEW multipass 2048² PNG run $run"; one /tmp/m.json
done
