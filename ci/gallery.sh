#!/usr/bin/env bash
# Renders the README gallery (docs/images/<scene>.png) from the shipped scenes on the CPU
# reference backend. Not run in CI; run by hand after a scene or shading change:
#   FRAGTRACE_MODEL_PATH=../shared/models ci/gallery.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
bin=target/release/fragtrace
mkdir -p docs/images
"$bin" render --backend cpu --spp 4 --width 320 --height 240 -q -o docs/images/gallery-whitted.png
for f in scenes/*.toml; do
  name=$(basename "$f" .toml)
  [ "$name" = whitted ] && continue
  "$bin" render "$f" --backend cpu --spp 4 --width 320 --height 240 -q -o "docs/images/gallery-$name.png"
  echo "docs/images/gallery-$name.png"
done
