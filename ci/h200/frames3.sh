#!/usr/bin/env bash
# Third H200 run for issue 26 (one device call): the output buffers kept per image shape,
# the compute kernel's progress bands, and the fragment kernels' 8-bit read-back, against
# the binary from before issue 26 (OLD, 5d36e05) and Mitsuba 3 cuda_ad_rgb on the same
# equal-work view, all in one run. Carried folders as in frames.sh (.gl, .devbin with
# fragtrace and fragtrace-old, .models.tar.xz, .peers). Logs to stdout; files to $OUT.
set -uo pipefail
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/models && tar xJf .models.tar.xz -C /tmp/models
export FRAGTRACE_MODEL_PATH=/tmp/models
OLD=.devbin/fragtrace-old NEW=.devbin/fragtrace out=${OUT:-/tmp/out}; mkdir -p "$out"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
ms() { local t0=$(date +%s%N); "$@" >/dev/null 2>>/tmp/stderr.log; echo "$(( ($(date +%s%N) - t0) / 1000000 )) ms (rc $?)"; }
one() { python3 - "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); g = d.get("gpu") or {}
print(f"   render_ms {d['render_ms']:.1f} gpu_ms_total {g.get('gpu_ms_total', 0):.2f} phases " + ", ".join(f"{k} {v:.2f}" for k, v in sorted((g.get('phases_ms') or {}).items())) + f" passes {g.get('passes_total')}")
PY
}
summ() { python3 - "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); fr = d["per_frame"]
def med(v): v = sorted(v); return v[len(v) // 2]
r = [f["render"]["render_ms"] for f in fr[1:]]; w = [f["write_ms"] for f in fr[1:]]
g = [f["render"]["gpu"]["gpu_ms_total"] for f in fr[1:]]
ph = {}
for f in fr[1:]:
    for k, v in f["render"]["gpu"]["phases_ms"].items(): ph.setdefault(k, []).append(v)
print(f"   {d['frames']} frames: set-up {d['setup_ms']:.0f} ms, first {fr[0]['render']['render_ms']:.1f} ms, frames 2..N render_ms median {med(r):.2f} (min {min(r):.2f}), GPU {med(g):.2f} ms, write {med(w):.1f} ms, {d['frames_ms']:.0f} ms in all; phases " + ", ".join(f"{k} {med(v):.2f}" for k, v in sorted(ph.items())))
PY
}
# Warm the driver's shader cache for both binaries (first compiles are 4 s on this driver).
for b in $OLD $NEW; do $b render ci/peers/equal-work.toml --width 256 --height 256 -q -o /tmp/warm.png 2>/dev/null; done
echo "== equal-work view, one render per process, PNG (3 runs each, interleaved)"
for size in 4096 1024; do
  for run in 1 2 3; do
    for bin in OLD NEW; do
      b=${!bin}
      echo "$bin ${size}² run $run: whole process $(ms $b render ci/peers/equal-work.toml --width $size --height $size -q -o /tmp/ew-$bin.png --stats /tmp/ew-$bin.json)"; one /tmp/ew-$bin.json
    done
  done
  echo "   OLD vs NEW: $($NEW compare /tmp/ew-OLD.png /tmp/ew-NEW.png 2>&1 | tail -1)"
done
echo "== steady state (NEW, --frames 0..9 of a still path), 2 runs each"
for size in 4096 1024; do
  for run in 1 2; do
    echo "steady ${size}² run $run: whole process $(ms $NEW render ci/h200/equal-work-still.toml --frames 0..9 --width $size --height $size -q -o /tmp/still_####.png --stats /tmp/steady.json)"; summ /tmp/steady.json
  done
done
for run in 1 2; do
  echo "turntable 120 x 1024² PNG run $run: whole process $(ms $NEW render scenes/turntable.toml --frames all --width 1024 --height 1024 -q -o /tmp/tt_####.png --stats /tmp/tt.json)"; summ /tmp/tt.json
done
cp /tmp/tt.json "$out/turntable.json"
echo "== the compute kernel with its progress bar drawn (a terminal through script): bands sized by time"
for run in 1 2; do
  t0=$(date +%s%N); script -qc "$NEW render ci/peers/equal-work.toml --width 4096 --height 4096 -o /tmp/ew-bar.png --stats /tmp/bar.json" /dev/null > /dev/null
  echo "bar 4096² run $run: whole process $(( ($(date +%s%N) - t0) / 1000000 )) ms"; one /tmp/bar.json
done
echo "   with bar vs without: $($NEW compare /tmp/ew-bar.png /tmp/ew-NEW.png 2>&1 | tail -1)"
echo "== fragment kernels, 4096² PNG: OLD read RGBA32F and converted on the host; NEW converts on the GPU"
for k in looped multipass; do
  for run in 1 2; do
    for bin in OLD NEW; do
      b=${!bin}
      echo "$bin $k run $run: whole process $(ms $b render ci/peers/equal-work.toml --kernel $k --width 4096 --height 4096 -q -o /tmp/fk-$bin.png --stats /tmp/fk-$bin.json)"; one /tmp/fk-$bin.json
    done
  done
  echo "   OLD vs NEW $k: $($NEW compare /tmp/fk-OLD.png /tmp/fk-NEW.png 2>&1 | tail -1)"
done
echo "== PNGs of every shipped scene, OLD vs NEW (NEW with --terminator exact, OLD's only mode), 512x384"
for s in scenes/*.toml; do
  case $s in *turntable*) continue;; esac
  for k in compute looped; do
    $OLD render "$s" --kernel $k --width 512 --height 384 -q -o /tmp/p-old.png 2>/dev/null
    $NEW render "$s" --kernel $k --terminator exact --width 512 --height 384 -q -o /tmp/p-new.png 2>/dev/null
    echo "$(basename $s) $k: $($NEW compare /tmp/p-old.png /tmp/p-new.png 2>&1 | tail -1)"
  done
done
echo "== Mitsuba 3.9.1 cuda_ad_rgb, same view"
mkdir -p /tmp/site && tar xJf .peers/mitsuba-cuda.tar.xz -C /tmp/site && export PYTHONPATH=/tmp/site
PYTHONUNBUFFERED=1 timeout 200 python3 ci/peers/mitsuba_equal_work.py /tmp/models/bunny/stanford-bunny.obj cuda_ad_rgb 1024,4096 5 2>&1 | tail -4
echo "== stderr (last lines)"; tail -5 /tmp/stderr.log
