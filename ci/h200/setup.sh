# Sourced by the H200 scripts from run6.sh on (`. ci/h200/setup.sh`): the GL loader packages
# of the device recipe (.gl), NVIDIA's EGL vendor file, the meshes (.models.tar.xz) under
# FRAGTRACE_MODEL_PATH, OLD/NEW binaries from .devbin, and two printers of `--stats` JSON:
# `one FILE` (a single render) and `summ FILE` (frames 2..N of `render --frames`), and
# `compare_scenes KERNEL...`: every shipped scene at 512x384, OLD vs NEW, one line each.
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/models && tar xJf .models.tar.xz -C /tmp/models
export FRAGTRACE_MODEL_PATH=/tmp/models
OLD=.devbin/fragtrace-old NEW=.devbin/fragtrace
one() { python3 - "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); g = d.get("gpu") or {}
print(f"   render_ms {d['render_ms']:.1f} gpu_ms_total {g.get('gpu_ms_total') or 0:.2f} phases " + ", ".join(f"{k} {v:.2f}" for k, v in sorted((g.get('phases_ms') or {}).items())))
PY
}
summ() { python3 - "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); fr = d["per_frame"]
def med(v): v = sorted(v); return v[len(v) // 2]
r = [f["render"]["render_ms"] for f in fr[1:]]
g = [f["render"]["gpu"]["gpu_ms_total"] for f in fr[1:]]
print(f"   frames 2..{len(fr)} render_ms median {med(r):.2f} (min {min(r):.2f}), GPU median {med(g):.2f} ms (min {min(g):.2f})")
PY
}
compare_scenes() {
  for s in scenes/*.toml; do case $s in *turntable*) continue;; esac
    for k in "$@"; do
      $OLD render "$s" --kernel $k --width 512 --height 384 -q -o /tmp/p-old.png 2>/dev/null
      $NEW render "$s" --kernel $k --width 512 --height 384 -q -o /tmp/p-new.png 2>/dev/null
      echo "$(basename $s) $k: $($NEW compare /tmp/p-old.png /tmp/p-new.png 2>&1 | tail -1)"
    done
  done
}
