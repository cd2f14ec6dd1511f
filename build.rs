//! Names the build: `FRAGTRACE_BUILD`, the crate version and the commit of the code it was
//! built from (`0.1.0+3f9c2d1e4b5a`), so parts of an image rendered by two different builds
//! are told apart by `merge` (docs/distributed.md). The commit is the last one that changed
//! the code (src/, glsl120/, Cargo.toml, Cargo.lock, this file), with `-dirty` when the
//! working tree's code differs from it, and `unknown` without git (a source tarball):
//! `0.1.0+unknown`. `$FRAGTRACE_BUILD_COMMIT` names the commit instead (a packager's build
//! outside the repository).
//!
//! It reruns only when the code changes, never on a commit alone: a commit of docs costs no
//! rebuild. So a binary built before its code was committed keeps saying `<parent>-dirty`,
//! which is still true of it, until the next change to the code rebuilds it.

use std::process::Command;

/// What makes the binary: the paths whose changes rerun this script and mark it dirty.
const CODE: [&str; 5] = ["src", "glsl120", "Cargo.toml", "Cargo.lock", "build.rs"];

fn main() {
    for p in CODE {
        println!("cargo:rerun-if-changed={p}");
    }
    println!("cargo:rerun-if-env-changed=FRAGTRACE_BUILD_COMMIT");
    let commit = match std::env::var("FRAGTRACE_BUILD_COMMIT") {
        Ok(c) if !c.trim().is_empty() => c.trim().to_string(),
        _ => from_git().unwrap_or_else(|| "unknown".into()),
    };
    println!(
        "cargo:rustc-env=FRAGTRACE_BUILD={}+{commit}",
        std::env::var("CARGO_PKG_VERSION").unwrap_or_default()
    );
}

/// The last commit that changed the code, short, and `-dirty` when the code differs from it;
/// None when git or the repository is missing.
fn from_git() -> Option<String> {
    let git = |args: &[&str]| -> Option<String> {
        let out = Command::new("git")
            .args(args)
            .current_dir(std::env::var_os("CARGO_MANIFEST_DIR")?)
            .output()
            .ok()?;
        out.status
            .success()
            .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
    };
    let mut log = vec!["log", "-1", "--format=%h", "--abbrev=12", "--"];
    log.extend(CODE);
    let commit = git(&log).filter(|c| !c.is_empty())?;
    let mut status = vec!["status", "--porcelain", "--"];
    status.extend(CODE);
    let dirty = !git(&status)?.is_empty();
    Some(if dirty { commit + "-dirty" } else { commit })
}
