//! Helpers shared by the integration tests (each test crate includes this module; not every
//! crate uses every helper).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;

use fragtrace::gpu::GlContext;
use fragtrace::scene::{builtin_scene, load_scene_with_search_path, Scene};

use glam::DVec3;

/// Runs `cmdline` in `dir` on a pseudo-terminal (util-linux `script`, so progress displays
/// that only draw on a terminal do), requires success and returns what the terminal showed.
pub fn on_terminal(dir: &Path, cmdline: &str) -> String {
    let out = Command::new("script")
        .current_dir(dir)
        .args(["-qec", cmdline, "/dev/null"])
        .output()
        .expect("util-linux `script`");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Tiny xorshift; the seed is printed so a failure reproduces.
pub struct Rng(pub u64);

impl Rng {
    pub fn new(case: &str, seed: u64) -> Self {
        println!("[{case}] seed = {seed:#x}");
        Rng(seed | 1)
    }
    /// Uniform in [0, 1).
    pub fn f(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f()
    }
    pub fn below(&mut self, n: usize) -> usize {
        ((self.f() * n as f64) as usize).min(n - 1)
    }
    /// Uniform direction on the unit sphere.
    pub fn dir(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let l = v.length();
            if l > 1e-3 && l <= 1.0 {
                return v / l;
            }
        }
    }
    /// Uniform point in the ball of radius `r`.
    pub fn in_ball(&mut self, r: f64) -> DVec3 {
        self.dir() * r * self.f().cbrt()
    }
    /// Barycentric weights bounded away from the edges by `margin`.
    pub fn bary(&mut self, margin: f64) -> [f64; 3] {
        loop {
            let (a, b) = (self.f(), self.f());
            let w = [a, b, 1.0 - a - b];
            if w.iter().all(|&x| x > margin) {
                return w;
            }
        }
    }
}

/// Runs `f` with a fresh headless GL context, one test at a time per test binary (llvmpipe
/// already uses every core, and GL state must not interleave).
///
/// # Panics
/// When no usable context can be created: tests that need a GPU fail loudly, never skip.
pub fn with_test_context<R>(f: impl FnOnce(&GlContext) -> R) -> R {
    static LOCK: Mutex<()> = Mutex::new(());
    let _guard = LOCK.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    let ctx = GlContext::new().unwrap_or_else(|e| panic!("{e}"));
    f(&ctx)
}

/// Where the tests look for meshes: FRAGTRACE_MODEL_PATH, else ../shared/models.
pub fn model_path() -> Vec<PathBuf> {
    match std::env::var_os("FRAGTRACE_MODEL_PATH") {
        Some(p) => std::env::split_paths(&p).collect(),
        None => vec![PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../shared/models"
        ))],
    }
}

/// The built-in scene and every file in scenes/.
pub fn shipped_scenes() -> Vec<(String, Scene)> {
    let mut v = vec![("builtin".to_string(), builtin_scene())];
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    for f in files {
        let name = f.file_stem().unwrap().to_string_lossy().into_owned();
        let scene =
            load_scene_with_search_path(&f, &model_path()).unwrap_or_else(|e| panic!("{e}"));
        v.push((name, scene));
    }
    v
}
