//! The program-binary cache (`gpu::program_cache`) as separate processes meet it: the second
//! process links every program from the cache, a damaged entry is compiled again and
//! rewritten, the flag and the environment variable turn the cache off, and a context
//! without binary formats compiles as before; every image equals the uncached one byte for
//! byte.

mod common;

use std::path::{Path, PathBuf};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fragtrace-sc-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// One render of the built-in scene with `kernel` in `d`, the cache in `d/cache` and
/// Mesa's own cache in `d/mesa` (on, so that llvmpipe offers a binary format, but private
/// to the test), extra `env` and `args`: its PNG's bytes and (compiled, cached) programs.
fn render(d: &Path, kernel: &str, env: &[(&str, &str)], args: &[&str]) -> (Vec<u8>, (u64, u64)) {
    let out = common::bin()
        .current_dir(d)
        .env("FRAGTRACE_SHADER_CACHE_DIR", d.join("cache"))
        .env("MESA_SHADER_CACHE_DIR", d.join("mesa"))
        .env_remove("FRAGTRACE_SHADER_CACHE")
        .env_remove("MESA_SHADER_CACHE_DISABLE")
        .envs(env.iter().copied())
        .args(["--backend", "gl", "--kernel", kernel, "--width", "48"])
        .args(["--height", "36", "-o", "out.png", "--stats", "s.json", "-q"])
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{kernel} {env:?} {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("s.json")).unwrap()).unwrap();
    let n = |k: &str| {
        stats["gpu"][k]
            .as_u64()
            .unwrap_or_else(|| panic!("gpu.{k}"))
    };
    let png = std::fs::read(d.join("out.png")).unwrap();
    (png, (n("programs_compiled"), n("programs_cached")))
}

/// The cache's entries in `d`.
fn entries(d: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(d.join("cache").join("programs"))
        .map(|r| r.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    v.sort();
    v
}

/// On each wing (compute, and the thesis's multipass kernel with its many programs): the
/// first process compiles and stores every program, the second links all of them from the
/// cache; damaged entries (a flipped payload byte, which the checksum sees; a flipped
/// format, which only the driver's link status sees; a truncated file) are compiled and
/// rewritten, so the process after that hits again; `--shader-cache off` and
/// `FRAGTRACE_SHADER_CACHE=off` compile everything and read or write nothing. Every PNG
/// equals the first byte for byte.
#[test]
fn a_second_process_links_from_the_cache_and_damage_is_rebuilt() {
    for kernel in ["compute", "multipass"] {
        let d = tmpdir(kernel);
        let (first, (n, cached)) = render(&d, kernel, &[], &[]);
        assert!(
            n >= 2 && cached == 0,
            "{kernel}: first run {n} compiled, {cached} cached"
        );
        let stored = entries(&d);
        assert_eq!(stored.len() as u64, n, "{kernel}: one entry per program");

        let (png, counts) = render(&d, kernel, &[], &[]);
        assert_eq!(
            counts,
            (0, n),
            "{kernel}: the second process hits every program"
        );
        assert!(png == first, "{kernel}: the cached programs' image differs");

        // Damage three entries three ways; the others stay good.
        let header = 8 + 8 + 8 + 4 + 8 + 8;
        let mut bytes = std::fs::read(&stored[0]).unwrap();
        let mid = header + (bytes.len() - header) / 2;
        bytes[mid] ^= 0x40;
        std::fs::write(&stored[0], &bytes).unwrap();
        let mut bytes = std::fs::read(&stored[1]).unwrap();
        bytes[24] ^= 0x01; // the binary's format: the header cannot tell
        std::fs::write(&stored[1], &bytes).unwrap();
        let damaged = if stored.len() > 2 {
            let bytes = std::fs::read(&stored[2]).unwrap();
            std::fs::write(&stored[2], &bytes[..bytes.len() / 3]).unwrap();
            3
        } else {
            2
        };
        let (png, counts) = render(&d, kernel, &[], &[]);
        assert_eq!(
            counts,
            (damaged, n - damaged),
            "{kernel}: damaged entries rebuilt"
        );
        assert!(png == first, "{kernel}: the image after a rebuild differs");
        let (png, counts) = render(&d, kernel, &[], &[]);
        assert_eq!(counts, (0, n), "{kernel}: the rewritten entries hit");
        assert!(png == first, "{kernel}");

        // Off, by flag or environment: nothing read, nothing written.
        std::fs::remove_dir_all(d.join("cache")).unwrap();
        for (env, args) in [
            (&[][..], &["--shader-cache", "off"][..]),
            (&[("FRAGTRACE_SHADER_CACHE", "off")][..], &[][..]),
        ] {
            let (png, counts) = render(&d, kernel, env, args);
            assert_eq!(counts, (n, 0), "{kernel} {env:?} {args:?}");
            assert!(png == first, "{kernel} {env:?} {args:?}");
            assert!(
                entries(&d).is_empty(),
                "{kernel} {env:?} {args:?}: wrote entries"
            );
        }
        // The flag wins over the environment.
        let (_, counts) = render(
            &d,
            kernel,
            &[("FRAGTRACE_SHADER_CACHE", "off")],
            &["--shader-cache", "on"],
        );
        assert_eq!(counts, (n, 0), "{kernel}: on by flag, the cache was empty");
        assert_eq!(entries(&d).len() as u64, n, "{kernel}: on by flag stores");
        std::fs::remove_dir_all(&d).unwrap();
    }
}

/// A context without a binary format (Mesa offers none with its own disk cache off)
/// compiles every program every time, silently, and writes no entry.
#[test]
fn without_binary_formats_every_program_is_compiled() {
    let d = tmpdir("noformat");
    let off = [("MESA_SHADER_CACHE_DISABLE", "true")];
    let info = common::bin().envs(off).arg("info").output().unwrap();
    let info = String::from_utf8_lossy(&info.stdout);
    assert!(info.contains("Program binaries: 0 formats"), "{info}");
    let (first, (n, cached)) = render(&d, "compute", &off, &[]);
    assert!(n >= 2 && cached == 0);
    let (png, counts) = render(&d, "compute", &off, &[]);
    assert_eq!(counts, (n, 0));
    assert!(png == first);
    assert!(entries(&d).is_empty());
    assert!(
        !String::from_utf8_lossy(&std::fs::read(d.join("s.json")).unwrap()).is_empty(),
        "stats written"
    );
    std::fs::remove_dir_all(&d).unwrap();
}
