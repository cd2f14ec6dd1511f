#!/usr/bin/env bash
# Builds the web page (docs/web.md) into a static folder any static server can host:
#   ci/web-build.sh [OUT]        (default OUT: target/web)
# then e.g. `python3 -m http.server -d target/web 8000` and open http://localhost:8000/.
# Installs what it needs when missing: the wasm32-unknown-unknown target (rustup) and the
# wasm-bindgen CLI of exactly the version web/Cargo.toml pins. When FRAGTRACE_MODEL_PATH
# names a folder, OUT/models links to it (a symlink, never a copy), so the shipped scenes
# with third-party meshes load from the served folder.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-target/web}
step() { echo "web-build: $*" >&2; }

if command -v rustup >/dev/null && ! rustup target list --installed | grep -qx wasm32-unknown-unknown; then
    step "adding the wasm32-unknown-unknown target"
    rustup target add wasm32-unknown-unknown
fi
WB=$(sed -n 's/^wasm-bindgen = "=\([0-9.]*\)"$/\1/p' web/Cargo.toml)
[ -n "$WB" ] || { echo "web-build: no pinned wasm-bindgen version in web/Cargo.toml" >&2; exit 1; }
if ! wasm-bindgen --version 2>/dev/null | grep -qx "wasm-bindgen $WB"; then
    step "installing wasm-bindgen-cli $WB (the version web/Cargo.toml pins)"
    # Not --locked: the CLI's lock file names a webpki-roots release the index lacks.
    cargo install wasm-bindgen-cli --version "=$WB"
fi
step "building web/ for wasm32-unknown-unknown"
(cd web && cargo build --release --target wasm32-unknown-unknown --target-dir ../target)
mkdir -p "$OUT"
wasm-bindgen --target web --no-typescript --out-dir "$OUT" \
    target/wasm32-unknown-unknown/release/fragtrace_web.wasm
cp web/index.html "$OUT/index.html"
first_model_dir=${FRAGTRACE_MODEL_PATH:-}
first_model_dir=${first_model_dir%%:*}
if [ -n "$first_model_dir" ] && [ -d "$first_model_dir" ]; then
    ln -sfn "$(cd "$first_model_dir" && pwd)" "$OUT/models"
fi
step "done: $OUT ($(du -sh "$OUT" --apparent-size | cut -f1))"
