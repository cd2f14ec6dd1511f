# Device set-up, sourced by ci/h200/compare.sh (`. ci/h200/setup.sh`); harmless on a machine
# without the carried folders (then the system's GL, meshes and binaries are used as they are).
#
# What the device call carries (docs/performance.md, "How to run"), each an ignored path of
# the checkout named in `carry`:
#   .gl/             the GL loader packages of the device recipe (libegl1, libglvnd0, libgl1,
#                    libopengl0, libglx0, libgles2, libvulkan1 as .deb), unpacked into /
#   .devbin/         the fragtrace binaries to compare (e.g. fragtrace-old, fragtrace)
#   .models.tar.xz   the meshes (the folder FRAGTRACE_MODEL_PATH names here, tarred)
#   .peers/          optional: mitsuba-cuda.tar.xz (Mitsuba 3 and Dr.Jit wheels, unpacked)
#
# After it: FRAGTRACE_MODEL_PATH is set, NVIDIA's EGL vendor file is named, and `stats_line
# FILE` / `frames_line FILE` print a `--stats` JSON of one render / of `render --frames`.
# Only on the NVIDIA machine: elsewhere (a checkout that keeps .gl/ for the next call) the
# system's own GL stays, and NVIDIA's vendor file would leave EGL without a display.
if compgen -G ".gl/*.deb" >/dev/null && command -v nvidia-smi >/dev/null; then
    for f in .gl/*.deb; do dpkg -x "$f" /; done
    ldconfig
    export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
fi
if [ -f .models.tar.xz ]; then
    mkdir -p /tmp/models && tar xJf .models.tar.xz -C /tmp/models
    export FRAGTRACE_MODEL_PATH=/tmp/models
fi
export FRAGTRACE_MODEL_PATH=${FRAGTRACE_MODEL_PATH:-$(cd .. && pwd)/shared/models}
command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
echo "$(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg), $(date -u +%FT%TZ)"

# One render's figures: render_ms, GPU time and phases (GPU backend), the build.
stats_line() {
    python3 - "$1" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); g = d.get("gpu") or {}
ph = ", ".join(f"{k} {v:.2f}" for k, v in sorted((g.get("phases_ms") or {}).items()))
print(f"render_ms {d['render_ms']:.1f} build_ms {d['accel']['build_ms']:.1f} "
      f"gpu_ms {g.get('gpu_ms_total') or 0:.2f}" + (f" phases {ph}" if ph else ""))
PY
}

# `render --frames`: frames 2..N (upload and compile paid by frame 1), medians.
frames_line() {
    python3 - "$1" <<'PY'
import json, sys, statistics as st
d = json.load(open(sys.argv[1])); fr = d["per_frame"][1:]
r = [f["render"]["render_ms"] for f in fr]
g = [(f["render"].get("gpu") or {}).get("gpu_ms_total") or 0 for f in fr]
w = [f["write_ms"] for f in fr]
print(f"{d['frames']} frames: set-up {d['setup_ms']:.0f} ms, frames 2..N render_ms median "
      f"{st.median(r):.2f} (min {min(r):.2f}), GPU median {st.median(g):.2f} ms, write median "
      f"{st.median(w):.1f} ms, {d['frames_ms']:.0f} ms in all")
PY
}
