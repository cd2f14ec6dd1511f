#!/usr/bin/env bash
# Second H200 run for issue 26: the steady state with overlapped bands, the turntable's
# per-frame phases, and ci/compare-binaries.sh (old vs new on every shipped scene, kernel
# and structure). Same carried folders as frames.sh.
set -uo pipefail
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/models && tar xJf .models.tar.xz -C /tmp/models
export FRAGTRACE_MODEL_PATH=/tmp/models
NEW=.devbin/fragtrace out=${OUT:-/tmp/out}; mkdir -p "$out"
summ() { python3 - "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); fr = d["per_frame"]
def med(v): v = sorted(v); return v[len(v) // 2]
r = [f["render"]["render_ms"] for f in fr[1:]]; w = [f["write_ms"] for f in fr[1:]]
g = [f["render"]["gpu"]["gpu_ms_total"] for f in fr[1:]]
ph = {}
for f in fr[1:]:
    for k, v in f["render"]["gpu"]["phases_ms"].items(): ph.setdefault(k, []).append(v)
print(f"   {d['frames']} frames: set-up {d['setup_ms']:.0f} ms, first {fr[0]['render']['render_ms']:.1f} ms, frames 2..N render_ms median {med(r):.2f} (min {min(r):.2f}), GPU {med(g):.2f} ms, write {med(w):.1f} ms, {d['frames_ms']:.0f} ms in all, {d['steady_fps']:.1f} frames/s; phases " + ", ".join(f"{k} {med(v):.2f}" for k, v in sorted(ph.items())))
PY
}
for size in 4096 1024; do
  for run in 1 2; do
    t0=$(date +%s%N); $NEW render ci/h200/equal-work-still.toml --frames 0..9 --width $size --height $size -q -o /tmp/still_####.png --stats /tmp/steady.json
    echo "== steady ${size} run $run: whole process $(( ($(date +%s%N) - t0) / 1000000 )) ms"; summ /tmp/steady.json
  done
done
for run in 1 2; do
  t0=$(date +%s%N); $NEW render scenes/turntable.toml --frames all --width 1024 --height 1024 -q -o /tmp/tt_####.png --stats /tmp/tt.json
  echo "== turntable 120 x 1024x1024 PNG run $run: whole process $(( ($(date +%s%N) - t0) / 1000000 )) ms"; summ /tmp/tt.json
done
cp /tmp/tt.json "$out/turntable.json"
t0=$(date +%s%N); $NEW render scenes/turntable.toml --frames all --width 1024 --height 1024 -q -o /tmp/tt_####.exr --stats /tmp/tte.json
echo "== turntable 120 x 1024x1024 EXR: whole process $(( ($(date +%s%N) - t0) / 1000000 )) ms"; summ /tmp/tte.json
for s in 1 4 16; do
  t0=$(date +%s%N); $NEW render scenes/bunny.toml --width 1024 --height 1024 --spp $s -q -o /tmp/b.png --stats /tmp/b.json
  echo "== bunny.toml 1024 spp $s single render: $(( ($(date +%s%N) - t0) / 1000000 )) ms, $(python3 -c "import json;d=json.load(open('/tmp/b.json'));g=d['gpu'];print('render_ms',round(d['render_ms'],1),'gpu',round(g['gpu_ms_total'],2),'phases',{k:round(v,2) for k,v in g['phases_ms'].items()})")"
done
echo "== ci/compare-binaries.sh old new 64x48"
bash ci/compare-binaries.sh .devbin/fragtrace-old .devbin/fragtrace 2>&1 | tail -15
