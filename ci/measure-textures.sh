#!/usr/bin/env bash
# What image textures cost (issue 47's target): scenes/duck-table.toml rendered with its
# textures and as its untextured twin (`--textures off`: the same geometry and materials'
# colours, no texture coordinates or images), interleaved run by run, medians of RUNS.
# GPU: the compute kernel's time from the timer queries (`gpu.gpu_ms_total`) and the bytes
# uploaded (`gpu.upload_bytes`: the difference is the textures' memory); CPU: `render_ms`.
#
#   ci/measure-textures.sh [BINARY] [SIZE] [RUNS] [BACKENDS]
#       (target/release/fragtrace 1024 5 "gl cpu")
# Meshes come from FRAGTRACE_MODEL_PATH (default ../shared/models). Needs python3.
set -uo pipefail
cd "$(dirname "$0")/.."
bin=${1:-target/release/fragtrace} size=${2:-1024} runs=${3:-5}
read -r -a backends <<< "${4:-gl cpu}"
export FRAGTRACE_MODEL_PATH="${FRAGTRACE_MODEL_PATH:-$(cd .. && pwd)/shared/models}"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
for backend in "${backends[@]}"; do
    extra=(); [ "$backend" = gl ] && extra=(--kernel compute)
    for _ in $(seq "$runs"); do
        for tex in on off; do
            "$bin" render scenes/duck-table.toml --backend "$backend" "${extra[@]}" --textures "$tex" \
                --width "$size" --height "$size" -q -o "$out/$backend-$tex.png" --stats "$out/s.json" \
                2>>"$out/err" || { echo "$backend --textures $tex failed: $(tail -1 "$out/err")" >&2; continue; }
            python3 - "$out/s.json" >>"$out/$backend-$tex" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); g = d.get("gpu") or {}
print(g.get("gpu_ms_total") or d["render_ms"], g.get("upload_bytes", 0))
PY
        done
    done
    python3 - "$out/$backend-on" "$out/$backend-off" "$backend" "$size" <<'PY'
import statistics as st, sys
on, off = ([list(map(float, l.split())) for l in open(f)] for f in sys.argv[1:3])
m_on, m_off = st.median(r[0] for r in on), st.median(r[0] for r in off)
what = "compute kernel GPU ms" if sys.argv[3] == "gl" else "CPU render_ms"
print(f"duck-table {sys.argv[4]}² {what}: textured {m_on:.2f}, untextured {m_off:.2f}, "
      f"ratio {m_on / m_off:.3f} (runs: {' '.join('%.2f' % r[0] for r in on)} / "
      f"{' '.join('%.2f' % r[0] for r in off)})")
if sys.argv[3] == "gl":
    print(f"  uploaded: textured {on[0][1] / 2**20:.2f} MiB, untextured {off[0][1] / 2**20:.2f} MiB "
          f"(textures and uvs {(on[0][1] - off[0][1]) / 2**20:.2f} MiB)")
PY
done
