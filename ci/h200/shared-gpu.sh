#!/usr/bin/env bash
# Tiles sharing one GPU (issue 28's H200 figure): scenes/bunny.toml at 4096x4096 as one
# process, then as N = 2 and 4 tile processes started together on the same GPU, merged;
# wall times and whether the merged PNG equals the single render. Carried: .gl, .devbin,
# .models.tar.xz. Usage: ci/h200/shared-gpu.sh
set -uo pipefail
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
mkdir -p /tmp/models && tar xJf .models.tar.xz -C /tmp/models bunny
export FRAGTRACE_MODEL_PATH=/tmp/models
B=.devbin/fragtrace S=scenes/bunny.toml
now() { date +%s%N; }
$B render $S --width 1024 --height 1024 -q -o /tmp/warm.png   # shader cache, page cache
for run in 1 2; do
  t0=$(now); $B render $S --width 4096 --height 4096 -q -o /tmp/one.png
  echo "run $run: 1 process: $(( ($(now) - t0) / 1000000 )) ms"
  for n in 2 4; do
    rm -rf /tmp/p; mkdir -p /tmp/p; t0=$(now)
    for i in $(seq 0 $((n - 1))); do
      $B render $S --width 4096 --height 4096 -q --tile $i/$n -o /tmp/p/part-$i.exr &
    done
    wait; t1=$(now)
    $B merge /tmp/p/part-*.exr -o /tmp/m$n.png
    t2=$(now)
    same=$(cmp -s /tmp/one.png /tmp/m$n.png && echo "byte-identical" || $B compare /tmp/one.png /tmp/m$n.png 2>&1 | head -1)
    echo "run $run: $n tile processes on one GPU: $(( (t1 - t0) / 1000000 )) ms, merge $(( (t2 - t1) / 1000000 )) ms; merged PNG vs single: $same"
  done
done
