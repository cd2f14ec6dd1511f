#!/usr/bin/env bash
# Frames at kernel speed on the H200 (issue 26), one device run: fragtrace before (OLD) and
# after (NEW) this change and Mitsuba 3 cuda_ad_rgb on the same equal-work view, whole
# process and steady state, then the 120-frame turntable. Run from the repository root on
# the device machine with the carried folders .gl (GL loader debs), .devbin (stripped
# binaries), .models.tar.xz (test meshes) and .peers (Mitsuba's slim tarball); writes logs
# to $OUT. Usage: ci/h200/frames.sh
set -uo pipefail
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/models && tar xJf .models.tar.xz -C /tmp/models
export FRAGTRACE_MODEL_PATH=/tmp/models
OLD=.devbin/fragtrace-old NEW=.devbin/fragtrace
out=${OUT:-/tmp/out}; mkdir -p "$out"
log() { echo "== $*"; }
ms() { local t0=$(date +%s%N); "$@" >/dev/null 2>>"$out/stderr.log"; local rc=$?; echo "$(( ($(date +%s%N) - t0) / 1000000 )) ms (rc $rc)"; }
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
$NEW info 2>&1 | head -5
for size in 1024 4096; do
  for bin in OLD NEW; do
    b=${!bin}
    for run in 1 2 3; do
      log "$bin equal-work ${size}x${size} PNG run $run: whole process $(ms $b render ci/peers/equal-work.toml --width $size --height $size -q -o /tmp/ew-$bin.png --stats $out/ew-$bin-$size-$run.json)"
    done
    python3 - "$out/ew-$bin-$size-3.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); g = d.get("gpu") or {}
print(f"   render_ms {d['render_ms']:.1f} gpu_ms {g.get('gpu_ms')} phases {g.get('phases_ms')} upload {g.get('upload_ms', 0):.1f} compile {g.get('compile_ms', 0):.1f}")
PY
  done
  python3 - /tmp/ew-OLD.png /tmp/ew-NEW.png <<'PY'
import sys, zlib, struct
def pixels(p):
    b = open(p, 'rb').read(); i = 8; idat = b''; w = h = 0
    while i < len(b):
        n = struct.unpack('>I', b[i:i+4])[0]; t = b[i+4:i+8]; d = b[i+8:i+8+n]
        if t == b'IHDR': w, h = struct.unpack('>II', d[:8])
        if t == b'IDAT': idat += d
        i += 12 + n
    raw = zlib.decompress(idat); stride = w * 3; out = bytearray(); prev = bytearray(stride)
    for y in range(h):
        f = raw[y*(stride+1)]; line = bytearray(raw[y*(stride+1)+1:(y+1)*(stride+1)])
        for x in range(stride):
            a = line[x-3] if x >= 3 else 0; up = prev[x]; c = prev[x-3] if x >= 3 else 0
            if f == 1: line[x] = (line[x] + a) & 255
            elif f == 2: line[x] = (line[x] + up) & 255
            elif f == 3: line[x] = (line[x] + (a + up) // 2) & 255
            elif f == 4:
                p = a + up - c; pa, pb, pc = abs(p-a), abs(p-up), abs(p-c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else up if pb <= pc else c)) & 255
        out += line; prev = line
    return bytes(out)
a, b = pixels(sys.argv[1]), pixels(sys.argv[2])
print("   OLD vs NEW PNG pixels:", "identical" if a == b else f"DIFFER in {sum(x != y for x, y in zip(a, b))} bytes")
PY
done
log "steady state: NEW --frames on the equal-work view (a still path), 4096 and 1024"
for size in 4096 1024; do
  log "$(ms $NEW render ci/h200/equal-work-still.toml --frames 0..9 --width $size --height $size -o /tmp/still_####.png --stats $out/steady-$size.json)"
  python3 - "$out/steady-$size.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
fr = d["per_frame"]
r = sorted(f["render"]["render_ms"] for f in fr[1:]); w = sorted(f["write_ms"] for f in fr[1:])
print(f"   set-up {d['setup_ms']:.0f} ms; first frame {fr[0]['render']['render_ms']:.1f} ms; frames 2..N render_ms median {r[len(r)//2]:.2f} (min {r[0]:.2f}); write median {w[len(w)//2]:.1f} ms; steady {d['steady_fps']:.1f} frames/s")
g = fr[-1]["render"]["gpu"]; print(f"   last frame gpu_ms {g['gpu_ms']} phases {g['phases_ms']}")
PY
done
log "turntable 120 frames 1024x1024 to PNG: whole process $(ms $NEW render scenes/turntable.toml --frames all --width 1024 --height 1024 -o /tmp/tt_####.png --stats $out/turntable.json)"
python3 -c "import json;d=json.load(open('$out/turntable.json'));print('   frames',d['frames'],'setup',round(d['setup_ms']),'ms frames',round(d['frames_ms']),'ms steady',round(d['steady_fps'],1),'fps')"
log "Mitsuba 3.9.1 cuda_ad_rgb, same view"
mkdir -p /tmp/site && tar xJf .peers/mitsuba-cuda.tar.xz -C /tmp/site && export PYTHONPATH=/tmp/site
PYTHONUNBUFFERED=1 python3 ci/peers/mitsuba_equal_work.py /tmp/models/bunny/stanford-bunny.obj cuda_ad_rgb 1024,4096 5 2>&1 | tail -4
cp /tmp/ew-NEW.png "$out/ew-4096-new.png" 2>/dev/null
tail -20 "$out/stderr.log"
