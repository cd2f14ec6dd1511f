//! `fragtrace bench`: every configuration of the renderer on every scene, timed and judged
//! against the f64 CPU reference, written as a CSV table, a Markdown report and a
//! speed-versus-error plot.
//!
//! A *configuration* is a name plus `render` arguments (`gl-multipass = "--backend gl
//! --kernel multipass"`), parsed by the same parser as `fragtrace render`
//! ([`RenderArgs::try_parse_from_args`]). The shipped ones live in [`CONFIG_TABLE`], grouped
//! into the presets `default`, `quick` and `all`; a TOML file can name others.
//!
//! For each scene x configuration: one warm-up render, then `runs` timed renders (the rest
//! are skipped once one takes longer than `max_seconds`; a warm-up that alone takes longer
//! is kept as the only timed run). Time is the wall-clock time of the render call (grid
//! build, shader compilation, upload, passes, read-back), the median over the timed runs.
//! The error of the first timed run's image is measured against a CPU f64 render of the
//! same scene at the same size (rendered once per scene and cached in the output folder):
//! RMSE over linear RGB and mean FLIP ([`crate::compare`]).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use crate::cli::RenderArgs;
use crate::gpu::GlContext;
use crate::image_io::{self, Image};
use crate::output::RayCounts;
use crate::progress::Progress;
use crate::render::{self, Backend, RenderOptions};
use crate::scene::{self, Scene};
use crate::{Error, Result};

/// One shipped configuration: a name, its `render` arguments and the presets it is in
/// (`all` holds every row).
#[derive(Clone, Copy, Debug)]
pub struct ConfigRow {
    /// Name used in `--configs`, the tables and the plot.
    pub name: &'static str,
    /// `render` arguments, separated by white space.
    pub args: &'static str,
    /// Presets besides `all` that include this row.
    pub presets: &'static [&'static str],
}

const D: &[&str] = &["default"];
const DQ: &[&str] = &["default", "quick"];
const A: &[&str] = &[];

/// The shipped configurations and their presets.
pub const CONFIG_TABLE: &[ConfigRow] = &[
    ConfigRow {
        name: "cpu-f64",
        args: "--backend cpu --precision f64",
        presets: DQ,
    },
    ConfigRow {
        name: "cpu-f32",
        args: "--backend cpu --precision f32",
        presets: DQ,
    },
    ConfigRow {
        name: "gl-looped",
        args: "--backend gl --kernel looped",
        presets: DQ,
    },
    ConfigRow {
        name: "gl-unrolled:16",
        args: "--backend gl --kernel unrolled:16",
        presets: D,
    },
    ConfigRow {
        name: "gl-multipass",
        args: "--backend gl --kernel multipass",
        presets: D,
    },
    ConfigRow {
        name: "gl-looped-no-specialize",
        args: "--backend gl --kernel looped --no-specialize",
        presets: D,
    },
    ConfigRow {
        name: "gl-looped-f16",
        args: "--backend gl --kernel looped --storage f16",
        presets: DQ,
    },
    ConfigRow {
        name: "gl-multipass-early-z",
        args: "--backend gl --kernel multipass --mask early-z",
        presets: D,
    },
    ConfigRow {
        name: "gl-multipass-stencil",
        args: "--backend gl --kernel multipass --mask stencil",
        presets: D,
    },
    ConfigRow {
        name: "gl-unrolled:16-k64",
        args: "--backend gl --kernel unrolled:16 --query-every 64",
        presets: D,
    },
    ConfigRow {
        name: "gl-looped-k1",
        args: "--backend gl --kernel looped --query-every 1",
        presets: A,
    },
    ConfigRow {
        name: "gl-unrolled:4",
        args: "--backend gl --kernel unrolled:4",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-k32",
        args: "--backend gl --kernel looped --query-every 32",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-early-z",
        args: "--backend gl --kernel looped --mask early-z",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-stencil",
        args: "--backend gl --kernel looped --mask stencil",
        presets: A,
    },
    ConfigRow {
        name: "gl-multipass-k1",
        args: "--backend gl --kernel multipass --query-every 1",
        presets: A,
    },
    ConfigRow {
        name: "gl-multipass-k32",
        args: "--backend gl --kernel multipass --query-every 32",
        presets: A,
    },
    ConfigRow {
        name: "gl-multipass-f16",
        args: "--backend gl --kernel multipass --storage f16",
        presets: A,
    },
    ConfigRow {
        name: "gl-unrolled:16-f16",
        args: "--backend gl --kernel unrolled:16 --storage f16",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-moller-trumbore",
        args: "--backend gl --kernel looped --intersect moller-trumbore",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-no-t-bound",
        args: "--backend gl --kernel looped --t-bound off",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-epsilon",
        args: "--backend gl --kernel looped --offset epsilon",
        presets: A,
    },
    ConfigRow {
        name: "cpu-f32-moller-trumbore",
        args: "--backend cpu --precision f32 --intersect moller-trumbore",
        presets: A,
    },
    ConfigRow {
        name: "cpu-f32-epsilon",
        args: "--backend cpu --precision f32 --offset epsilon",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-density-1",
        args: "--backend gl --kernel looped --grid-density 1",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-density-4",
        args: "--backend gl --kernel looped --grid-density 4",
        presets: A,
    },
];

/// Preset names accepted by `--configs`.
pub const PRESETS: &[&str] = &["default", "quick", "all"];

/// A configuration to run: a name, its argument string and the parsed arguments.
#[derive(Clone, Debug)]
pub struct BenchConfig {
    /// Name shown in the tables and the plot.
    pub name: String,
    /// The `render` arguments as written.
    pub args: String,
    /// The parsed arguments (scene, size, output and quiet are set by the bench).
    pub render: RenderArgs,
}

impl BenchConfig {
    /// Parses a configuration; a clear [`Error::Usage`] names it when its arguments are
    /// not valid `render` arguments or set what the bench decides (scene, size, outputs).
    pub fn parse(name: &str, args: &str) -> Result<Self> {
        let bad = |msg: String| Error::Usage(format!("configuration `{name}` (`{args}`): {msg}"));
        if name.trim().is_empty() || name.contains(',') {
            return Err(bad(
                "a configuration name must be non-empty and hold no comma".into(),
            ));
        }
        let words: Vec<&str> = args.split_whitespace().collect();
        for w in &words {
            let flag = w.split('=').next().unwrap_or(w);
            if ["-o", "--output", "--width", "--height", "--stats", "--aov"].contains(&flag)
                || (w.starts_with("-o") && !w.starts_with("--"))
            {
                return Err(bad(format!(
                    "`{flag}` is set by the bench, not by a configuration"
                )));
            }
        }
        let render = RenderArgs::try_parse_from_args(&words).map_err(|e| bad(e.to_string()))?;
        if let Some(s) = &render.scene {
            return Err(bad(format!(
                "unexpected argument `{}` (the scene is chosen with --scenes)",
                s.display()
            )));
        }
        // Value checks that the parser leaves to `cli::options` (ranges, grid density).
        crate::cli::options(&render, &scene::builtin_scene()).map_err(|e| bad(e.to_string()))?;
        Ok(BenchConfig {
            name: name.trim().to_string(),
            args: words.join(" "),
            render,
        })
    }
}

/// Resolves `--configs`: a preset name ([`PRESETS`]), a TOML file (`[configs] name =
/// "args"`, in file order), or comma-separated names from [`CONFIG_TABLE`].
pub fn resolve_configs(spec: &str) -> Result<Vec<BenchConfig>> {
    let spec = spec.trim();
    let path = Path::new(spec);
    let configs = if PRESETS.contains(&spec) {
        CONFIG_TABLE
            .iter()
            .filter(|r| spec == "all" || r.presets.contains(&spec))
            .map(|r| BenchConfig::parse(r.name, r.args))
            .collect::<Result<Vec<_>>>()?
    } else if spec.ends_with(".toml") || path.is_file() {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        parse_config_file(&text, &path.display().to_string())?
    } else {
        spec.split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(|name| match CONFIG_TABLE.iter().find(|r| r.name == name) {
                Some(r) => BenchConfig::parse(r.name, r.args),
                None => Err(Error::Usage(format!(
                    "unknown configuration `{name}`: --configs takes a preset ({}), a TOML file, or names from: {}",
                    PRESETS.join(", "),
                    CONFIG_TABLE.iter().map(|r| r.name).collect::<Vec<_>>().join(", ")
                ))),
            })
            .collect::<Result<Vec<_>>>()?
    };
    if configs.is_empty() {
        return Err(Error::Usage(format!(
            "--configs `{spec}` names no configuration"
        )));
    }
    let mut seen = std::collections::HashSet::new();
    for c in &configs {
        if !seen.insert(c.name.clone()) {
            return Err(Error::Usage(format!(
                "configuration `{}` is named twice",
                c.name
            )));
        }
    }
    Ok(configs)
}

/// Parses a configuration file: a TOML table `[configs]` of `name = "render args"`,
/// kept in file order. `origin` names the file in messages.
pub fn parse_config_file(text: &str, origin: &str) -> Result<Vec<BenchConfig>> {
    let doc: toml::Table =
        toml::from_str(text).map_err(|e| Error::Usage(format!("{origin}: {}", e.message())))?;
    let unknown: Vec<&String> = doc.keys().filter(|k| *k != "configs").collect();
    if !unknown.is_empty() {
        return Err(Error::Usage(format!(
            "{origin}: unknown table or key `{}` (expected only [configs])",
            unknown[0]
        )));
    }
    let Some(table) = doc.get("configs").and_then(|v| v.as_table()) else {
        return Err(Error::Usage(format!(
            "{origin}: no [configs] table (expected `[configs]` with lines `name = \"render args\"`)"
        )));
    };
    // toml::Table sorts its keys; recover the file order from the key positions.
    let mut named: Vec<(usize, &String, &toml::Value)> = table
        .iter()
        .map(|(k, v)| (key_position(text, k), k, v))
        .collect();
    named.sort_by_key(|(pos, k, _)| (*pos, (*k).clone()));
    named
        .into_iter()
        .map(|(_, name, value)| match value.as_str() {
            Some(args) => {
                BenchConfig::parse(name, args).map_err(|e| Error::Usage(format!("{origin}: {e}")))
            }
            None => Err(Error::Usage(format!(
                "{origin}: configs.{name}: expected a string of render arguments, found {}",
                value.type_str()
            ))),
        })
        .collect()
}

/// Where `key` is defined in `text` (bare or quoted), for ordering; `usize::MAX` if not found.
fn key_position(text: &str, key: &str) -> usize {
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        let t = line.trim_start();
        for cand in [key.to_string(), format!("\"{key}\""), format!("'{key}'")] {
            if let Some(rest) = t.strip_prefix(&cand) {
                if rest.trim_start().starts_with('=') {
                    return offset;
                }
            }
        }
        offset += line.len();
    }
    usize::MAX
}

/// Image size for `--size WxH`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Size {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl std::str::FromStr for Size {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let bad = || {
            format!(
                "size `{s}` is not WxH with both in 1..={}",
                render::MAX_IMAGE_SIDE
            )
        };
        let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
        let side = |v: &str| {
            v.trim()
                .parse::<u32>()
                .ok()
                .filter(|v| (1..=render::MAX_IMAGE_SIDE).contains(v))
        };
        match (side(w), side(h)) {
            (Some(width), Some(height)) => Ok(Size { width, height }),
            _ => Err(bad()),
        }
    }
}

impl std::fmt::Display for Size {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

/// The folder of the shipped scenes: `scenes/` in the working directory, else the one in
/// the source tree fragtrace was built from.
pub fn shipped_scenes_dir() -> PathBuf {
    let local = PathBuf::from("scenes");
    if local.is_dir() {
        local
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
    }
}

/// A scene to bench: its name and where it comes from (`None`: the built-in).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneSpec {
    /// Name in the tables (file stem).
    pub name: String,
    /// Scene file; `None` for the built-in `whitted`.
    pub path: Option<PathBuf>,
}

/// Resolves `--scenes`: comma-separated names of files in [`shipped_scenes_dir`] (`whitted`
/// is the built-in scene) or paths to scene files; `None` means every shipped scene.
pub fn resolve_scenes(spec: Option<&str>) -> Result<Vec<SceneSpec>> {
    let dir = shipped_scenes_dir();
    let names: Vec<String> = match spec {
        Some(s) => s
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(String::from)
            .collect(),
        None => {
            let mut v: Vec<String> = std::fs::read_dir(&dir)
                .map_err(|source| Error::Io {
                    path: dir.clone(),
                    source,
                })?
                .filter_map(|e| e.ok())
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|e| e == "toml"))
                .filter_map(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
                .collect();
            v.sort();
            v
        }
    };
    if names.is_empty() {
        return Err(Error::Usage("--scenes names no scene".into()));
    }
    let mut out: Vec<SceneSpec> = Vec::new();
    for n in names {
        let spec = if n == "whitted" || n == "builtin" {
            SceneSpec {
                name: "whitted".into(),
                path: None,
            }
        } else if n.ends_with(".toml") || n.contains('/') {
            let p = PathBuf::from(&n);
            SceneSpec {
                name: p
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or(n.clone()),
                path: Some(p),
            }
        } else {
            let p = dir.join(format!("{n}.toml"));
            if !p.is_file() {
                return Err(Error::Usage(format!(
                    "unknown scene `{n}`: no {} (give a name of a file in {} or a path to a scene file)",
                    p.display(),
                    dir.display()
                )));
            }
            SceneSpec {
                name: n.clone(),
                path: Some(p),
            }
        };
        if out.iter().any(|s| s.name == spec.name) {
            return Err(Error::Usage(format!(
                "scene `{}` is named twice",
                spec.name
            )));
        }
        out.push(spec);
    }
    Ok(out)
}

/// Everything `fragtrace bench` needs.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// Scenes, in order.
    pub scenes: Vec<SceneSpec>,
    /// Configurations, in order.
    pub configs: Vec<BenchConfig>,
    /// Timed runs per scene and configuration (after one warm-up).
    pub runs: u32,
    /// Image size of every render.
    pub size: Size,
    /// Once a run takes longer than this, the remaining runs are skipped.
    pub max_seconds: f64,
    /// Output folder (results.csv, report.md, speed_vs_error.png, cached references).
    pub out: PathBuf,
    /// No progress display and no summary lines.
    pub quiet: bool,
}

/// The measurements of one scene and configuration.
#[derive(Clone, Debug, Serialize)]
pub struct BenchRow {
    /// Scene name.
    pub scene: String,
    /// Configuration name.
    pub config: String,
    /// The configuration's `render` arguments.
    pub args: String,
    /// Backend that ran ("cpu" or "gl"; empty when the configuration failed).
    pub backend: String,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Timed runs done (fewer than asked when one run exceeded `max_seconds`).
    pub runs: u32,
    /// The warm-up alone exceeded `max_seconds` and is the only timed run.
    pub warmup_reused: bool,
    /// Wall time of each timed run, seconds.
    pub times_s: Vec<f64>,
    /// Median of `times_s`.
    pub time_s: f64,
    /// Median of the renderer's own `render_ms` (grid build excluded).
    pub render_ms: f64,
    /// Median GPU time over all passes (timer queries); `None` on the CPU or without timers.
    pub gpu_ms: Option<f64>,
    /// Passes drawn (GPU only).
    pub passes: Option<u64>,
    /// Rays by kind.
    pub rays: RayCounts,
    /// Million rays per second over the median wall time.
    pub mrays_per_s: f64,
    /// RMSE against the CPU f64 reference (linear RGB, unclamped).
    pub rmse: f64,
    /// Mean FLIP against the CPU f64 reference.
    pub flip_mean: f64,
    /// On the time-RMSE Pareto front of its scene.
    pub pareto_rmse: bool,
    /// On the time-FLIP Pareto front of its scene.
    pub pareto_flip: bool,
    /// Why the configuration failed on this scene; the figures are then NaN or zero.
    pub error: Option<String>,
}

impl BenchRow {
    fn failed(scene: &str, cfg: &BenchConfig, size: Size, msg: String) -> Self {
        BenchRow {
            scene: scene.into(),
            config: cfg.name.clone(),
            args: cfg.args.clone(),
            backend: String::new(),
            width: size.width,
            height: size.height,
            runs: 0,
            warmup_reused: false,
            times_s: vec![],
            time_s: f64::NAN,
            render_ms: f64::NAN,
            gpu_ms: None,
            passes: None,
            rays: RayCounts::default(),
            mrays_per_s: f64::NAN,
            rmse: f64::NAN,
            flip_mean: f64::NAN,
            pareto_rmse: false,
            pareto_flip: false,
            error: Some(msg),
        }
    }
}

/// What a bench produced.
#[derive(Clone, Debug)]
pub struct BenchReport {
    /// One row per scene and configuration, scenes in order, configurations in order.
    pub rows: Vec<BenchRow>,
    /// Triangle count per scene name.
    pub triangles: BTreeMap<String, usize>,
    /// GL_RENDERER of the context used, when a GL configuration ran.
    pub gl_device: Option<String>,
    /// The files written: results.csv, report.md, speed_vs_error.png.
    pub files: Vec<PathBuf>,
}

/// Median of non-empty values (mean of the middle two for an even count); NaN when empty.
pub fn median(values: &[f64]) -> f64 {
    if values.is_empty() {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Pareto optimality for minimising both coordinates: `true` for each point that no other
/// point dominates (at most as large in both and smaller in one). Points with a non-finite
/// coordinate are never optimal and dominate nothing; equal points are all optimal.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<bool> {
    let finite = |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite();
    points
        .iter()
        .map(|p| {
            finite(p)
                && !points
                    .iter()
                    .any(|q| finite(q) && q.0 <= p.0 && q.1 <= p.1 && (q.0 < p.0 || q.1 < p.1))
        })
        .collect()
}

/// FNV-1a, to key cached references by scene text.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// A GL context made on first use and shared by every GL render of the bench.
struct GlCache(Option<std::result::Result<GlContext, String>>);

impl GlCache {
    fn get(&mut self) -> std::result::Result<&GlContext, String> {
        self.0
            .get_or_insert_with(|| GlContext::new().map_err(|e| e.to_string()))
            .as_ref()
            .map_err(Clone::clone)
    }
}

fn render_with(gl: &mut GlCache, scene: &Scene, opts: &RenderOptions) -> Result<render::Rendered> {
    match opts.backend {
        Backend::Cpu => render::render_cpu(scene, opts),
        Backend::Gl => {
            let ctx = gl.get().map_err(Error::GlUnavailable)?;
            render::render_gl_with(ctx, scene, opts)
        }
        Backend::Auto => match gl.get() {
            Ok(ctx) => render::render_gl_with(ctx, scene, opts),
            Err(_) => render::render_cpu(scene, opts),
        },
    }
}

/// The CPU f64 reference of `spec` at `size`: read from the cache in `dir` when there,
/// else rendered and cached (keyed by scene name, size and a hash of the scene text).
fn reference(spec: &SceneSpec, scene: &Scene, size: Size, dir: &Path) -> Result<Image> {
    let text = match &spec.path {
        None => scene::DEFAULT_SCENE_TOML.as_bytes().to_vec(),
        Some(p) => std::fs::read(p).map_err(|source| Error::Io {
            path: p.clone(),
            source,
        })?,
    };
    let key = fnv1a(&[&text[..], env!("CARGO_PKG_VERSION").as_bytes()].concat());
    let path = dir.join(format!("{}-{size}-{key:016x}.exr", spec.name));
    if path.is_file() {
        if let Ok(img) = image_io::read_image(&path) {
            if (img.width, img.height) == (size.width, size.height) {
                return Ok(img);
            }
        }
    }
    let mut opts = RenderOptions::for_scene(scene);
    opts.width = size.width;
    opts.height = size.height;
    let out = render::render_cpu(scene, &opts)?;
    std::fs::create_dir_all(dir).map_err(|source| Error::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    image_io::write_image(&path, &out.image)?;
    Ok(out.image)
}

/// Runs the bench and writes `results.csv`, `report.md` and `speed_vs_error.png` into
/// `opts.out`. Scenes are loaded (and configurations were parsed) before anything renders,
/// so bad input fails at once; a configuration that fails to render on a scene (no GL, a
/// missing feature) is recorded in its row and the bench goes on.
pub fn run_bench(opts: &BenchOptions) -> Result<BenchReport> {
    if opts.runs == 0 {
        return Err(Error::Usage("--runs must be at least 1".into()));
    }
    if opts.max_seconds.is_nan() || opts.max_seconds <= 0.0 {
        return Err(Error::Usage(format!(
            "--max-seconds {} must be positive",
            opts.max_seconds
        )));
    }
    if opts.configs.is_empty() || opts.scenes.is_empty() {
        return Err(Error::Usage("nothing to bench".into()));
    }
    let scenes: Vec<(SceneSpec, Scene)> = opts
        .scenes
        .iter()
        .map(|s| {
            let scene = match &s.path {
                None => scene::builtin_scene(),
                Some(p) => scene::load_scene(p)?,
            };
            Ok((s.clone(), scene))
        })
        .collect::<Result<_>>()?;
    std::fs::create_dir_all(&opts.out).map_err(|source| Error::Io {
        path: opts.out.clone(),
        source,
    })?;

    let per_config = opts.runs as u64 + 1;
    let total = scenes.len() as u64 * opts.configs.len() as u64 * per_config;
    let progress = Progress::bar_with_message(!opts.quiet, total, "renders");
    let say = |line: String| {
        if !opts.quiet {
            progress.println(line);
        }
    };
    let mut gl = GlCache(None);
    let mut rows = Vec::new();
    let mut triangles = BTreeMap::new();
    let refs_dir = opts.out.join("references");

    for (spec, scene) in &scenes {
        triangles.insert(spec.name.clone(), scene.triangles.len());
        progress.message(format!("{}: CPU f64 reference", spec.name));
        let reference = reference(spec, scene, opts.size, &refs_dir)?;
        let first_row = rows.len();
        for cfg in &opts.configs {
            let mut args = cfg.render.clone();
            args.width = Some(opts.size.width);
            args.height = Some(opts.size.height);
            args.quiet = true;
            args.verbose = false;
            let row = match crate::cli::options(&args, scene) {
                Err(e) => BenchRow::failed(&spec.name, cfg, opts.size, e.to_string()),
                Ok(ropts) => bench_one(
                    &mut gl, spec, scene, cfg, &ropts, opts, &reference, &progress,
                ),
            };
            match &row.error {
                None => say(format!(
                    "{} / {}: {} (median of {}), {} rays, {:.3} Mrays/s, RMSE {:.6}, FLIP {:.6}",
                    row.scene,
                    row.config,
                    fmt_secs(row.time_s),
                    row.runs,
                    row.rays.total,
                    row.mrays_per_s,
                    row.rmse,
                    row.flip_mean
                )),
                Some(e) => say(format!("{} / {}: failed: {e}", row.scene, row.config)),
            }
            rows.push(row);
        }
        mark_pareto(&mut rows[first_row..]);
    }
    progress.finish();

    let gl_device = match &gl.0 {
        Some(Ok(ctx)) => Some(ctx.info.renderer.clone()),
        _ => None,
    };
    let mut report = BenchReport {
        rows,
        triangles,
        gl_device,
        files: vec![],
    };
    let csv = opts.out.join("results.csv");
    write_text(&csv, &results_csv(&report.rows))?;
    let md = opts.out.join("report.md");
    write_text(&md, &report_markdown(&report, opts))?;
    let png = opts.out.join("speed_vs_error.png");
    plot_speed_vs_error(&png, &report.rows)?;
    report.files = vec![csv, md, png];
    if !opts.quiet {
        for f in &report.files {
            eprintln!("wrote {}", f.display());
        }
    }
    Ok(report)
}

#[allow(clippy::too_many_arguments)]
fn bench_one(
    gl: &mut GlCache,
    spec: &SceneSpec,
    scene: &Scene,
    cfg: &BenchConfig,
    ropts: &RenderOptions,
    opts: &BenchOptions,
    reference: &Image,
    progress: &Progress,
) -> BenchRow {
    let stage = |what: String| progress.message(format!("{} / {}: {what}", spec.name, cfg.name));
    let timed = |gl: &mut GlCache| -> Result<(f64, render::Rendered)> {
        let t0 = Instant::now();
        let out = render_with(gl, scene, ropts)?;
        let t = t0.elapsed().as_secs_f64();
        if !out.image.all_finite() {
            return Err(Error::Internal(
                "the render produced a NaN or Inf pixel".into(),
            ));
        }
        Ok((t, out))
    };
    stage("warm-up".into());
    let warm = timed(gl);
    progress.inc(1);
    let (warm_t, warm_out) = match warm {
        Ok(w) => w,
        Err(e) => {
            progress.inc(opts.runs as u64);
            return BenchRow::failed(&spec.name, cfg, opts.size, e.to_string());
        }
    };
    let mut runs: Vec<(f64, render::Rendered)> = Vec::new();
    let warmup_reused = warm_t > opts.max_seconds;
    if warmup_reused {
        progress.inc(opts.runs as u64);
        runs.push((warm_t, warm_out));
    } else {
        drop(warm_out);
        for i in 0..opts.runs {
            stage(format!("run {}/{}", i + 1, opts.runs));
            match timed(gl) {
                Ok((t, out)) => {
                    progress.inc(1);
                    // Only the first image is judged; keep the stats of the others.
                    let out = if runs.is_empty() {
                        out
                    } else {
                        render::Rendered {
                            image: Image::from_rgb(0, 0, vec![]),
                            ..out
                        }
                    };
                    runs.push((t, out));
                    if t > opts.max_seconds {
                        progress.inc((opts.runs - i - 1) as u64);
                        break;
                    }
                }
                Err(e) => {
                    progress.inc((opts.runs - i) as u64);
                    return BenchRow::failed(&spec.name, cfg, opts.size, e.to_string());
                }
            }
        }
    }
    stage("error against the reference".into());
    let cmp = match crate::compare::compare(&runs[0].1.image, reference, 0.01, false) {
        Ok(c) => c,
        Err(e) => return BenchRow::failed(&spec.name, cfg, opts.size, e.to_string()),
    };
    let times: Vec<f64> = runs.iter().map(|r| r.0).collect();
    let render_ms: Vec<f64> = runs.iter().map(|r| r.1.stats.render_ms).collect();
    let gpu_ms: Vec<f64> = runs
        .iter()
        .filter_map(|r| {
            let g = r.1.stats.gpu.as_ref()?;
            (!g.gpu_ms.is_empty()).then_some(g.gpu_ms_total)
        })
        .collect();
    let first = &runs[0].1.stats;
    let time_s = median(&times);
    BenchRow {
        scene: spec.name.clone(),
        config: cfg.name.clone(),
        args: cfg.args.clone(),
        backend: first.backend.clone(),
        width: first.width,
        height: first.height,
        runs: runs.len() as u32,
        warmup_reused,
        times_s: times,
        time_s,
        render_ms: median(&render_ms),
        gpu_ms: (!gpu_ms.is_empty()).then(|| median(&gpu_ms)),
        passes: first.gpu.as_ref().map(|g| g.passes_total),
        rays: first.rays,
        mrays_per_s: first.rays.total as f64 / time_s.max(1e-12) / 1e6,
        rmse: cmp.rmse,
        flip_mean: cmp.flip_mean,
        pareto_rmse: false,
        pareto_flip: false,
        error: None,
    }
}

/// Marks the Pareto fronts (time vs RMSE, time vs FLIP) within one scene's rows.
pub fn mark_pareto(rows: &mut [BenchRow]) {
    let rmse = pareto_front(&rows.iter().map(|r| (r.time_s, r.rmse)).collect::<Vec<_>>());
    let flip = pareto_front(
        &rows
            .iter()
            .map(|r| (r.time_s, r.flip_mean))
            .collect::<Vec<_>>(),
    );
    for ((r, a), b) in rows.iter_mut().zip(rmse).zip(flip) {
        r.pareto_rmse = a;
        r.pareto_flip = b;
    }
}

fn write_text(path: &Path, text: &str) -> Result<()> {
    image_io::write_atomic(path, |tmp| {
        std::fs::write(tmp, text.as_bytes()).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })
    })
}

/// A CSV field, quoted when it holds a comma, a quote or a line break.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// A figure with `decimals` decimals; empty when not finite.
fn num(v: f64, decimals: usize) -> String {
    if v.is_finite() {
        format!("{v:.decimals$}")
    } else {
        String::new()
    }
}

/// An error figure in scientific notation (7 significant digits); empty when not finite.
fn err_num(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.6e}")
    } else {
        String::new()
    }
}

/// Header of `results.csv`.
pub const CSV_HEADER: &str = "scene,config,args,backend,width,height,runs,warmup_reused,time_s,\
times_s,render_ms,gpu_ms,passes,rays_primary,rays_shadow,rays_reflected,rays_refracted,\
rays_total,mrays_per_s,rmse,flip_mean,pareto_rmse,pareto_flip,error";

/// The rows as CSV ([`CSV_HEADER`] first; empty fields where a figure does not apply).
pub fn results_csv(rows: &[BenchRow]) -> String {
    let mut out = String::from(CSV_HEADER);
    out.push('\n');
    for r in rows {
        let ok = r.error.is_none();
        let times = r
            .times_s
            .iter()
            .map(|t| format!("{t:.6}"))
            .collect::<Vec<_>>()
            .join(" ");
        let rays = |v: u64| if ok { v.to_string() } else { String::new() };
        let fields = [
            csv_field(&r.scene),
            csv_field(&r.config),
            csv_field(&r.args),
            csv_field(&r.backend),
            r.width.to_string(),
            r.height.to_string(),
            r.runs.to_string(),
            r.warmup_reused.to_string(),
            num(r.time_s, 6),
            times,
            num(r.render_ms, 3),
            r.gpu_ms.map(|m| num(m, 3)).unwrap_or_default(),
            r.passes.map(|p| p.to_string()).unwrap_or_default(),
            rays(r.rays.primary),
            rays(r.rays.shadow),
            rays(r.rays.reflected),
            rays(r.rays.refracted),
            rays(r.rays.total),
            num(r.mrays_per_s, 6),
            err_num(r.rmse),
            err_num(r.flip_mean),
            r.pareto_rmse.to_string(),
            r.pareto_flip.to_string(),
            csv_field(r.error.as_deref().unwrap_or("")),
        ];
        out += &fields.join(",");
        out.push('\n');
    }
    out
}

/// Seconds for people: "12.3 s", "456 ms".
fn fmt_secs(s: f64) -> String {
    if !s.is_finite() {
        "-".into()
    } else if s >= 100.0 {
        format!("{s:.0} s")
    } else if s >= 1.0 {
        format!("{s:.2} s")
    } else {
        format!("{:.1} ms", s * 1e3)
    }
}

/// An integer with thousands separators.
fn thousands(v: u64) -> String {
    let s = v.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

fn sci(v: f64) -> String {
    if !v.is_finite() {
        "-".into()
    } else if v == 0.0 {
        "0".into()
    } else {
        format!("{v:.2e}")
    }
}

/// `report.md`: how the figures were made, then one table per scene sorted by time, with
/// the Pareto-optimal rows marked, and the plot.
pub fn report_markdown(report: &BenchReport, opts: &BenchOptions) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# fragtrace bench\n");
    let _ = writeln!(
        s,
        "- fragtrace {}; {} px; one warm-up, then {} timed run(s) per configuration, median \
         wall time of the render call (grid build, shader compilation and upload included); \
         runs stop once one takes over {} s.",
        env!("CARGO_PKG_VERSION"),
        opts.size,
        opts.runs,
        opts.max_seconds
    );
    let _ = writeln!(
        s,
        "- GL device: {}; CPU: {} threads.",
        report.gl_device.as_deref().unwrap_or("none used"),
        rayon::current_num_threads()
    );
    let _ = writeln!(
        s,
        "- Error against a CPU f64 render of the same scene and size: RMSE over linear RGB; \
         FLIP = mean FLIP error of the images clamped to [0, 1] as 8-bit sRGB, {:.2} pixels \
         per degree.",
        crate::compare::FLIP_PIXELS_PER_DEGREE
    );
    let _ = writeln!(
        s,
        "- Pareto: **RMSE** / **FLIP** marks a configuration that no other is both at least \
         as fast as and at most as wrong as (in RMSE / in FLIP), and better in one.\n"
    );
    let mut scenes: Vec<&str> = Vec::new();
    for r in &report.rows {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
        }
    }
    for scene in scenes {
        let mut rows: Vec<&BenchRow> = report.rows.iter().filter(|r| r.scene == scene).collect();
        rows.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
        let tris = report.triangles.get(scene).copied().unwrap_or(0);
        let _ = writeln!(s, "## {scene} ({} triangles)\n", thousands(tris as u64));
        let _ = writeln!(
            s,
            "| config | arguments | time | runs | GPU time | passes | rays | Mrays/s | RMSE | FLIP | Pareto |"
        );
        let _ = writeln!(s, "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|");
        let mut failed = Vec::new();
        for r in rows {
            if let Some(e) = &r.error {
                failed.push((r, e));
                continue;
            }
            let pareto = [(r.pareto_rmse, "RMSE"), (r.pareto_flip, "FLIP")]
                .iter()
                .filter(|(on, _)| *on)
                .map(|(_, n)| format!("**{n}**"))
                .collect::<Vec<_>>()
                .join(" ");
            let runs = if r.warmup_reused {
                "1 (warm-up)".to_string()
            } else {
                r.runs.to_string()
            };
            let _ = writeln!(
                s,
                "| {} | `{}` | {} | {} | {} | {} | {} | {:.3} | {} | {} | {} |",
                r.config,
                r.args,
                fmt_secs(r.time_s),
                runs,
                r.gpu_ms.map(|m| fmt_secs(m / 1e3)).unwrap_or("-".into()),
                r.passes.map(thousands).unwrap_or("-".into()),
                thousands(r.rays.total),
                r.mrays_per_s,
                sci(r.rmse),
                sci(r.flip_mean),
                pareto
            );
        }
        for (r, e) in failed {
            let _ = writeln!(s, "\n- {} (`{}`) failed: {}", r.config, r.args, e);
        }
        s.push('\n');
    }
    let _ = writeln!(s, "![time against error](speed_vs_error.png)");
    s
}

static FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");

fn register_font() -> Result<()> {
    static ONCE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *ONCE.get_or_init(|| {
        plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, FONT)
            .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(Error::Internal(
            "the bundled font could not be loaded".into(),
        ))
    }
}

const PALETTE: &[(u8, u8, u8)] = &[
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
];

/// Draws `speed_vs_error.png`: one row of panels per scene, time (log axis) against RMSE on
/// the left and FLIP on the right; one labelled point per configuration (same colour for a
/// configuration in every panel) and each panel's Pareto front as a line.
pub fn plot_speed_vs_error(path: &Path, rows: &[BenchRow]) -> Result<()> {
    use plotters::prelude::*;
    register_font()?;
    let mut scenes: Vec<&str> = Vec::new();
    let mut configs: Vec<&str> = Vec::new();
    for r in rows {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
        }
        if !configs.contains(&r.config.as_str()) {
            configs.push(&r.config);
        }
    }
    let (pw, ph) = (720u32, 460u32);
    let (w, h) = (2 * pw, ph * scenes.len().max(1) as u32);
    let mut buf = vec![0u8; (w * h * 3) as usize];
    let draw_err = |e: &dyn std::fmt::Display| Error::Internal(format!("plot: {e}"));
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw_err(&e))?;
        let panels = root.split_evenly((scenes.len().max(1), 2));
        for (si, scene) in scenes.iter().enumerate() {
            let ok: Vec<&BenchRow> = rows
                .iter()
                .filter(|r| r.scene == *scene && r.error.is_none() && r.time_s > 0.0)
                .collect();
            for (pi, metric) in ["RMSE", "FLIP"].iter().enumerate() {
                let area = &panels[si * 2 + pi];
                let value = |r: &BenchRow| if pi == 0 { r.rmse } else { r.flip_mean };
                let on_front = |r: &BenchRow| {
                    if pi == 0 {
                        r.pareto_rmse
                    } else {
                        r.pareto_flip
                    }
                };
                let (mut t0, mut t1) = ok.iter().fold((f64::INFINITY, 0.0f64), |(a, b), r| {
                    (a.min(r.time_s), b.max(r.time_s))
                });
                if !t0.is_finite() {
                    (t0, t1) = (0.1, 1.0);
                }
                let (t0, t1) = (t0 / 1.6, t1 * 1.6);
                // Errors on a log axis too (they span decades); an error of exactly 0
                // sits on the bottom line, labelled 0.
                let positive = ok
                    .iter()
                    .map(|r| value(r))
                    .filter(|v| *v > 0.0 && v.is_finite());
                let (lo, hi) =
                    positive.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
                let (floor, top) = if hi > 0.0 {
                    (lo / 4.0, hi * 2.0)
                } else {
                    (1e-6, 1e-3)
                };
                let y_of = move |v: f64| if v > 0.0 { v.max(floor) } else { floor };
                let mut y_ticks = vec![floor];
                y_ticks.extend(
                    log_ticks(floor, top)
                        .into_iter()
                        .filter(|v| *v > floor * 1.5),
                );
                let mut chart = ChartBuilder::on(area)
                    .caption(
                        format!("{scene}: {metric} against time"),
                        ("sans-serif", 20).into_font(),
                    )
                    .margin(12)
                    .x_label_area_size(40)
                    .y_label_area_size(70)
                    .build_cartesian_2d(
                        (t0..t1).log_scale().with_key_points(log_ticks(t0, t1)),
                        (floor..top).log_scale().with_key_points(y_ticks),
                    )
                    .map_err(|e| draw_err(&e))?;
                chart
                    .configure_mesh()
                    .x_desc("median wall time (s, log scale)")
                    .y_desc(format!("{metric} vs CPU f64 (log scale)"))
                    .x_label_formatter(&|v| fmt_tick(*v))
                    .y_label_formatter(&|v| {
                        if *v <= floor * 1.000_001 {
                            "0".into()
                        } else {
                            format!("{v:.0e}")
                        }
                    })
                    .label_style(("sans-serif", 13).into_font())
                    .axis_desc_style(("sans-serif", 14).into_font())
                    .draw()
                    .map_err(|e| draw_err(&e))?;
                let mut front: Vec<(f64, f64)> = ok
                    .iter()
                    .filter(|r| on_front(r))
                    .map(|r| (r.time_s, y_of(value(r))))
                    .collect();
                front.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.total_cmp(&a.1)));
                chart
                    .draw_series(LineSeries::new(
                        front,
                        ShapeStyle::from(&BLACK.mix(0.6)).stroke_width(2),
                    ))
                    .map_err(|e| draw_err(&e))?;
                // Labels: placed in pixel space, pushed down when they would overlap.
                let mut placed: Vec<(i32, i32, i32)> = Vec::new();
                for r in &ok {
                    let ci = configs.iter().position(|c| *c == r.config).unwrap_or(0);
                    let (cr, cg, cb) = PALETTE[ci % PALETTE.len()];
                    let colour = RGBColor(cr, cg, cb);
                    let p = (r.time_s, y_of(value(r)));
                    chart
                        .draw_series(std::iter::once(Circle::new(p, 5, colour.filled())))
                        .map_err(|e| draw_err(&e))?;
                    let (px, mut py) = chart.backend_coord(&p);
                    let lw = 7 * r.config.len() as i32;
                    let (mut lx, lh) = (px + 8, 15);
                    if lx + lw > area.get_base_pixel().0 + pw as i32 - 4 {
                        lx = px - 8 - lw;
                    }
                    py -= 7;
                    while placed
                        .iter()
                        .any(|&(x, y, pw_)| lx < x + pw_ && x < lx + lw && (py - y).abs() < lh)
                    {
                        py += lh;
                    }
                    placed.push((lx, py, lw));
                    root.draw(&Text::new(
                        r.config.clone(),
                        (lx, py),
                        ("sans-serif", 13).into_font().color(&colour),
                    ))
                    .map_err(|e| draw_err(&e))?;
                }
            }
        }
        root.present().map_err(|e| draw_err(&e))?;
    }
    image_io::write_atomic(path, |tmp| {
        image::save_buffer_with_format(
            tmp,
            &buf,
            w,
            h,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| Error::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    })
}

/// Tick values of a log axis over `[lo, hi]`: 1-2-5 in each decade (1-1.5-2-3-5-7 when
/// that gives fewer than four).
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let ticks = |mantissas: &[f64]| {
        let (d0, d1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
        let mut v = Vec::new();
        for d in d0..=d1 {
            for m in mantissas {
                let t = m * 10f64.powi(d);
                if t >= lo && t <= hi {
                    v.push(t);
                }
            }
        }
        v
    };
    let coarse = ticks(&[1.0, 2.0, 5.0]);
    if coarse.len() >= 4 {
        coarse
    } else {
        ticks(&[1.0, 1.5, 2.0, 3.0, 5.0, 7.0])
    }
}

/// A tick label without float noise: 0.05, 1.5, 200.
fn fmt_tick(v: f64) -> String {
    if v >= 10.0 {
        format!("{v:.0}")
    } else {
        let decimals = (2.0 - v.log10().floor()).max(1.0) as usize;
        let s = format!("{v:.decimals$}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_on_known_points() {
        // (time, error)
        let pts = [
            (1.0, 0.5),           // fastest: optimal
            (2.0, 0.1),           // slower, better: optimal
            (3.0, 0.1),           // dominated by (2, 0.1)
            (2.5, 0.3),           // dominated by (2, 0.1)
            (10.0, 0.0),          // slowest, exact: optimal
            (10.0, 0.0),          // its twin: optimal too
            (f64::NAN, 0.0),      // failed: never optimal
            (0.5, f64::INFINITY), // failed: dominates nothing
            (1.0, 0.6),           // dominated by (1, 0.5) on error alone
        ];
        assert_eq!(
            pareto_front(&pts),
            vec![true, true, false, false, true, true, false, false, false]
        );
        assert!(pareto_front(&[]).is_empty());
        assert_eq!(pareto_front(&[(1.0, 1.0)]), vec![true]);
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&[]).is_nan());
    }

    #[test]
    fn every_shipped_configuration_parses_and_presets_resolve() {
        for r in CONFIG_TABLE {
            BenchConfig::parse(r.name, r.args).unwrap();
        }
        assert_eq!(resolve_configs("all").unwrap().len(), CONFIG_TABLE.len());
        let default: Vec<String> = resolve_configs("default")
            .unwrap()
            .into_iter()
            .map(|c| c.name)
            .collect();
        assert_eq!(default.len(), 10);
        assert_eq!(default[0], "cpu-f64");
        let quick = resolve_configs("quick").unwrap();
        assert!(quick.len() >= 3 && quick.iter().any(|c| c.name == "cpu-f64"));
        let two = resolve_configs("gl-looped, cpu-f32").unwrap();
        assert_eq!(
            (two[0].name.as_str(), two[1].name.as_str()),
            ("gl-looped", "cpu-f32")
        );
        assert_eq!(two[0].render.kernel, crate::gpu::shader::Kernel::Looped);
    }

    #[test]
    fn bad_configurations_are_refused_clearly() {
        let e = resolve_configs("gl-looped,nope").unwrap_err().to_string();
        assert!(
            e.contains("unknown configuration `nope`") && e.contains("gl-multipass"),
            "{e}"
        );
        for (args, want) in [
            ("--kernel warp", "unknown kernel"),
            ("--frobnicate", "--frobnicate"),
            ("--query-every 0", "--query-every"),
            ("--width 10", "set by the bench"),
            ("-o x.png", "set by the bench"),
            ("scenes/cornell.toml", "--scenes"),
        ] {
            let e = BenchConfig::parse("x", args).unwrap_err();
            assert_eq!(e.exit_code(), 2);
            let e = e.to_string();
            assert!(
                e.contains("configuration `x`") && e.contains(want),
                "{args}: {e}"
            );
        }
    }

    #[test]
    fn config_files_keep_their_order() {
        let text = "[configs]\nzeta = \"--backend cpu\"\n\"gl-k4\" = \"--backend gl --query-every 4\"\nalpha = \"--backend cpu --precision f32\"\n";
        let c = parse_config_file(text, "c.toml").unwrap();
        let names: Vec<&str> = c.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["zeta", "gl-k4", "alpha"]);
        assert_eq!(c[1].render.query_every, 4);
        for bad in [
            "[configs]\na = 3\n",
            "x = 1\n",
            "[configs]\na = \"--nope\"\n",
            "[configs\n",
        ] {
            let e = parse_config_file(bad, "c.toml").unwrap_err();
            assert_eq!(e.exit_code(), 2);
            assert!(e.to_string().starts_with("c.toml: "), "{e}");
        }
    }

    #[test]
    fn sizes_and_scenes() {
        assert_eq!(
            "32x24".parse::<Size>().unwrap(),
            Size {
                width: 32,
                height: 24
            }
        );
        for bad in ["32", "0x4", "axb", "32x99999"] {
            assert!(bad.parse::<Size>().is_err(), "{bad}");
        }
        let all = resolve_scenes(None).unwrap();
        assert!(all.iter().any(|s| s.name == "whitted" && s.path.is_none()));
        assert!(all.iter().any(|s| s.name == "cornell"));
        let two = resolve_scenes(Some("whitted,cornell")).unwrap();
        assert_eq!(two[0].path, None);
        assert!(two[1].path.as_ref().unwrap().ends_with("cornell.toml"));
        assert!(resolve_scenes(Some("nope")).is_err());
        assert!(resolve_scenes(Some("whitted,builtin")).is_err());
    }

    #[test]
    fn csv_quotes_what_needs_it() {
        assert_eq!(csv_field("a b"), "a b");
        assert_eq!(csv_field("a,\"b\""), "\"a,\"\"b\"\"\"");
        assert_eq!(thousands(1_993_148), "1,993,148");
        assert_eq!(thousands(12), "12");
        assert_eq!(
            log_ticks(0.01, 1.0),
            vec![0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0]
        );
        assert_eq!(log_ticks(1.0, 2.5), vec![1.0, 1.5, 2.0]);
        let labels: Vec<String> = [0.05, 0.15, 1.5, 2.0, 300.0]
            .iter()
            .map(|v| fmt_tick(*v))
            .collect();
        assert_eq!(labels, ["0.05", "0.15", "1.5", "2", "300"]);
    }
}
