//! Helpers shared by the integration tests (each test crate includes this module; not every
//! crate uses every helper).
#![allow(dead_code)]

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Mutex;

use fragtrace::gpu::GlContext;
use fragtrace::scene::{builtin_scene, load_scene_with_search_path, Scene};

use glam::DVec3;

/// The binary under test, writing its program-binary cache into this test process's
/// [`shader_cache_dir`], never into the user's (`~/.cache/fragtrace`): every test runs it
/// through here (tests/cli.rs checks that no test crate names the binary itself).
pub fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_fragtrace"));
    c.env("FRAGTRACE_SHADER_CACHE_DIR", shader_cache_dir());
    c
}

/// The binary's path, for a script that runs it itself: give that script's command
/// `FRAGTRACE_SHADER_CACHE_DIR` = [`shader_cache_dir`] too (its jobs inherit it).
pub fn exe() -> &'static str {
    env!("CARGO_BIN_EXE_fragtrace")
}

/// This test process's own shader-cache folder, in the temporary folder (fresh for each
/// test process, so no test depends on what another left).
pub fn shader_cache_dir() -> PathBuf {
    std::env::temp_dir().join(format!(
        "fragtrace-test-shader-cache-{}",
        std::process::id()
    ))
}

/// A fresh scratch folder named by the test crate, `name` and the process.
pub fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "fragtrace-{}-{name}-{}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A child's stdout and stderr, for failure messages.
pub fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// The variables of Slurm arrays and Kubernetes Indexed Jobs that `--task-index env` reads:
/// a test's child must not inherit them from a CI job that itself runs under a scheduler.
pub const TASK_VARS: [&str; 6] = [
    "SLURM_ARRAY_TASK_ID",
    "SLURM_ARRAY_TASK_MIN",
    "SLURM_ARRAY_TASK_MAX",
    "SLURM_ARRAY_TASK_STEP",
    "SLURM_ARRAY_TASK_COUNT",
    "JOB_COMPLETION_INDEX",
];

/// Runs the binary in `dir` with `args`, the test meshes, none of [`TASK_VARS`] and the
/// variables `env`.
pub fn run<S: AsRef<OsStr>>(dir: &Path, args: &[S], env: &[(&str, &str)]) -> Output {
    let mut c = bin();
    c.current_dir(dir).args(args);
    c.env(
        "FRAGTRACE_MODEL_PATH",
        std::env::join_paths(model_path()).unwrap(),
    );
    for var in TASK_VARS {
        c.env_remove(var);
    }
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().unwrap()
}

/// Command-line words of `line`, split at white space (no quoting: for arguments without
/// spaces), so a test's command reads as one line.
pub fn words(line: &str) -> Vec<&str> {
    line.split_whitespace().collect()
}

/// Requires success, naming what the child said otherwise.
pub fn ok(o: Output) -> Output {
    assert!(o.status.success(), "{}", text(&o));
    o
}

/// One line `fragtrace: error: ...` containing `want`, exit 2.
pub fn refused(o: &Output, want: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{}", text(o));
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    assert!(
        err.starts_with("fragtrace: error: ") && err.contains(want),
        "want `{want}` in: {err}"
    );
}

/// Runs the binary under test with `args` (one string, split by the shell) in `dir` on a
/// pseudo-terminal (util-linux `script`, so progress displays that only draw on a terminal
/// do), requires success and returns what the terminal showed.
pub fn on_terminal(dir: &Path, args: &str) -> String {
    let cmdline = format!("{} {args}", env!("CARGO_BIN_EXE_fragtrace"));
    let out = Command::new("script")
        .current_dir(dir)
        .env("FRAGTRACE_SHADER_CACHE_DIR", shader_cache_dir())
        .args(["-qec", &cmdline, "/dev/null"])
        .output()
        .expect("util-linux `script`");
    assert!(
        out.status.success(),
        "`{cmdline}` on a terminal: {}",
        text(&out)
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

/// A test that cannot run here for the reason `why`: false after a `SKIPPED` line where
/// `FRAGTRACE_ALLOW_SKIP=1` acknowledges the skip, else a panic naming `why` and `remedy`
/// (a skip is never silent; docs/testing.md).
pub fn acknowledged_skip(why: &str, remedy: &str) -> bool {
    if std::env::var("FRAGTRACE_ALLOW_SKIP").as_deref() == Ok("1") {
        eprintln!("SKIPPED (FRAGTRACE_ALLOW_SKIP=1): {why}");
        return false;
    }
    panic!("{why}: {remedy}, or set FRAGTRACE_ALLOW_SKIP=1 to acknowledge the skip");
}

/// Whether a test that forces a GL 2.1 context through Mesa's version overrides can run
/// here: true on Mesa, else [`acknowledged_skip`].
pub fn mesa_overrides_available() -> bool {
    let version = with_test_context(|ctx| ctx.info.gl_version.clone());
    version.contains("Mesa")
        || acknowledged_skip(
            &format!("this test forces GL 2.1 through Mesa's overrides; the driver is {version:?}"),
            "run it on Mesa",
        )
}

/// The instanced scene the GPU, view, band and overlap tests share: spheres (a rotated, non-uniformly scaled one, a mirrored one overlapping it, one
/// rotated by 90 degrees), boxes touching at shared faces and one placed twice at the same
/// spot, over a floor of the scene's own triangles; a mirror material so that reflected
/// rays meet instances too.
pub const INSTANCED_SCENE: &str = r#"
[camera]
eye = [0.0, 4.0, 10.0]
look_at = [0.0, 0.7, 0.0]
fov = 40
[[lights]]
position = [3.0, 8.0, 6.0]
[materials.floor]
checker = { a = [0.9, 0.9, 0.9], b = [0.2, 0.2, 0.2], scale = 1.0 }
[materials.red]
albedo = [0.9, 0.2, 0.2]
ks = [0.5, 0.5, 0.5]
ns = 50
kr = [0.3, 0.3, 0.3]
[materials.blue]
albedo = [0.2, 0.3, 0.9]
[[objects]]
shape = "quad"
size = 20
material = "floor"
[[objects]]
shape = "sphere"
subdivisions = 2
radius = 0.5
material = "red"
instances = [
  { translate = [-2.5, 0.5, 0] },
  { translate = [-0.5, 1, 0], scale = [1.5, 2, 0.7], rotate = [10, 40, 0] },
  { translate = [-0.2, 1.2, 0.3], scale = [-1, 1, 1] },
  { translate = [2, 0.6, 0.5], rotate = [0, 0, 90], scale = 1.2 },
]
[[objects]]
shape = "box"
size = [1, 1, 1]
material = "blue"
instances = [
  { translate = [-1, 0.5, 3] },
  { translate = [0, 0.5, 3] },
  { translate = [0, 0.5, 3] },
  { translate = [1, 0.5, 3], rotate = [0, 90, 0] },
]
"#;
