#!/usr/bin/env bash
# Makes the README's strip of the multipass wave (assets/view-wave-*.png): `fragtrace view`
# itself renders the built-in scene with the multipass kernel in a window and writes its
# content after a given number of passes (--passes-per-frame 100 --frames N), and once the
# render is complete. Needs an X display: run under `xvfb-run -a`.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q
bin=target/release/fragtrace
common=(view --kernel multipass --width 160 --height 120 --spp 1)
for frames in 4 10 20 30 50; do
    "$bin" "${common[@]}" --passes-per-frame 100 --frames "$frames" \
        --screenshot "assets/view-wave-$(printf %04d $((frames * 100))).png" 2>/dev/null
done
"$bin" "${common[@]}" --screenshot assets/view-wave-done.png 2>/dev/null
ls -l assets/view-wave-*.png
