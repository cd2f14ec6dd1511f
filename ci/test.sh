#!/usr/bin/env bash
# The README's test command, and CI's (.ci/run calls exactly this): on a Debian/Ubuntu
# machine with only Rust installed it sets up what the suite needs, then runs it.
#
# 1. System packages: says which are missing and why, then installs them with apt-get (as
#    root, or through sudo). Without root or sudo it stops with one line naming them.
# 2. The rustfmt and clippy components, through rustup when the toolchain lacks them.
# 3. The format and lint gates, a compile check of the fuzz targets, the web page's build
#    (ci/web-build.sh: the wasm32 target and the wasm-bindgen CLI when missing), and the whole test
#    suite under `xvfb-run -a` (the window tests of tests/view.rs need an X display; every
#    other test ignores it). On a machine that already has the packages, the suite alone
#    is `xvfb-run -a cargo test --release`.
#
# Each step prints how long it took, so a slow first run shows where its time went.
set -euo pipefail
cd "$(dirname "$0")/.."

say() { echo "ci/test.sh: $*"; }
t0=$SECONDS
step() { # step NAME COMMAND...: runs the command, then prints its wall time
    local name=$1 start=$SECONDS
    shift
    say "$name ..."
    "$@"
    say "$name: $((SECONDS - start)) s"
}

# --- 1. System packages -------------------------------------------------------------------
# Why each is needed (printed when it is missing).
declare -A why=(
    [gcc]="the C compiler and linker that rustc links with"
    [g++]="builds the FLIP image-metric library (the nv-flip crate) the tests compare with"
    [libegl1]="the EGL loader: headless OpenGL for the GPU backend"
    [libegl-mesa0]="Mesa's EGL driver (surfaceless platform; llvmpipe needs no GPU)"
    [libgl1-mesa-dri]="Mesa's GL drivers, llvmpipe among them"
    [glslang-tools]="glslangValidator: the tests validate every generated shader with it"
    [xvfb]="a virtual X server for the window tests (tests/view.rs)"
    [xauth]="needed by xvfb-run"
    [libxcursor1]="X11 client library fragtrace view loads at run time (winit's Xcursor)"
    [libxi6]="X11 client library fragtrace view loads at run time (winit's XInput2)"
    [libxkbcommon-x11-0]="keyboard library fragtrace view loads at run time (winit's xkbcommon)"
    [slurmd]="a single-node Slurm cluster that tests/slurm.rs starts itself (installed only: no service is configured or enabled)"
    [slurmctld]="the Slurm controller of that cluster"
    [slurm-client]="sbatch and squeue, which the distributed tests call"
    [munge]="Slurm's authentication daemon"
    [chromium]="the headless browser that tests/web.rs opens the web page in (WebGL 1 on SwiftShader)"
)
order=(gcc g++ libegl1 libegl-mesa0 libgl1-mesa-dri glslang-tools xvfb xauth
    libxcursor1 libxi6 libxkbcommon-x11-0
    slurmd slurmctld slurm-client munge chromium)
if command -v dpkg-query >/dev/null 2>&1; then
    need=()
    for pkg in "${order[@]}"; do
        status=$(dpkg-query -W -f='${db:Status-Status}' "$pkg" 2>/dev/null || true)
        [ "$status" = installed ] || need+=("$pkg")
    done
    if [ ${#need[@]} -gt 0 ]; then
        SUDO=()
        if [ "$(id -u)" -ne 0 ]; then
            if command -v sudo >/dev/null 2>&1; then
                SUDO=(sudo)
            else
                say "error: missing system packages: ${need[*]}; as root run: apt-get install -y ${need[*]}" >&2
                exit 1
            fi
        fi
        say "installing ${#need[@]} missing system package(s) with ${SUDO[*]:-}${SUDO[*]:+ }apt-get:"
        for pkg in "${need[@]}"; do
            say "  $pkg: ${why[$pkg]}"
        done
        export DEBIAN_FRONTEND=noninteractive
        start=$SECONDS
        "${SUDO[@]}" apt-get update -qq
        "${SUDO[@]}" apt-get install -y -qq "${need[@]}" >/dev/null
        say "installed ${need[*]} in $((SECONDS - start)) s"
    fi
else
    say "no dpkg here: not a Debian/Ubuntu system, so the system packages are not checked;" \
        "the suite needs a C/C++ compiler, an EGL runtime with a GL 2.1+ driver," \
        "glslangValidator and xvfb-run (tests that lack one fail naming it)"
fi

# --- 2. Toolchain components --------------------------------------------------------------
missing=()
cargo fmt --version >/dev/null 2>&1 || missing+=(rustfmt)
cargo clippy --version >/dev/null 2>&1 || missing+=(clippy)
if [ ${#missing[@]} -gt 0 ]; then
    if command -v rustup >/dev/null 2>&1; then
        say "adding the toolchain components ${missing[*]} (the format and lint gates)"
        rustup component add "${missing[@]}"
    else
        say "error: the Rust toolchain lacks ${missing[*]} and there is no rustup to add them;" \
            "install them with the toolchain (Debian: apt-get install -y rustfmt rust-clippy)" >&2
        exit 1
    fi
fi

# --- 3. Gates and suite -------------------------------------------------------------------
# Test meshes live outside the repository (never copied in): ../shared/models.
export FRAGTRACE_MODEL_PATH="${FRAGTRACE_MODEL_PATH:-$(cd .. && pwd)/shared/models}"

step "cargo fmt --check" cargo fmt --all -- --check
step "cargo clippy" cargo clippy --release --all-targets -- -D warnings
# The library's documentation: a link to a private or renamed item is an error.
step "cargo doc" env RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --lib
# The fuzz targets live in their own workspace, which `cargo test` never builds: check them
# so an API change cannot leave them uncompilable unnoticed (running them needs cargo-fuzz
# and nightly; docs/fuzzing.md).
step "cargo check (fuzz targets)" \
    cargo check --manifest-path fuzz/Cargo.toml --bins --target-dir target/fuzz-check
# The web page (docs/web.md): adds the wasm32 target and the pinned wasm-bindgen CLI when
# missing, and builds the page tests/web.rs opens in Chromium (timed apart from the suite).
step "web page (ci/web-build.sh)" ci/web-build.sh target/web-test
step "cargo fmt --check (web/)" cargo fmt --manifest-path web/Cargo.toml -- --check
step "xvfb-run -a cargo test --release" xvfb-run -a cargo test --release
say "all passed in $((SECONDS - t0)) s"
