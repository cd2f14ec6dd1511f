#!/usr/bin/env bash
# CI entry point: installs what a clean Debian machine lacks for headless EGL on Mesa
# (llvmpipe), for validating the shaders as GLSL 1.20 (glslang-tools), for building the
# FLIP library's C++ (g++, for the nv-flip crate) and for an X server to open windows in
# (xvfb, with xauth for xvfb-run) and for a single-node Slurm cluster that tests/slurm.rs
# starts itself (slurmd, slurmctld, slurm-client, munge: installed only, no service is
# configured or enabled), then runs the README's test command plus the format and lint
# gates.
set -euo pipefail
cd "$(dirname "$0")/.."

need=()
for pkg in libegl1 libegl-mesa0 libgl1-mesa-dri glslang-tools g++ xvfb xauth \
    slurmd slurmctld slurm-client munge; do
    dpkg -s "$pkg" >/dev/null 2>&1 || need+=("$pkg")
done
if [ ${#need[@]} -gt 0 ]; then
    echo "ci: installing ${need[*]}"
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO="sudo"
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq "${need[@]}"
fi

# Test meshes live outside the repository (never copied in): ../shared/models.
export FRAGTRACE_MODEL_PATH="${FRAGTRACE_MODEL_PATH:-$(cd .. && pwd)/shared/models}"

cargo fmt --all -- --check
cargo clippy --release --all-targets -- -D warnings
# The fuzz targets live in their own workspace, which `cargo test` never builds: check them
# so an API change cannot leave them uncompilable unnoticed (running them needs cargo-fuzz
# and nightly; docs/fuzzing.md).
cargo check --manifest-path fuzz/Cargo.toml --bins --target-dir target/fuzz-check
# The README's test command, under Xvfb so that `fragtrace view`'s window tests
# (tests/view.rs) have an X display; every other test ignores it:
xvfb-run -a cargo test --release
