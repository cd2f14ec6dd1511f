//! Running the bench: one GL context for every GL configuration, the cached CPU f64
//! reference of each scene, and the warm-up and timed renders of each scene and
//! configuration.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use super::report::{fmt_secs, mark_pareto, median, report_markdown, results_csv, write_text};
use super::{
    plot_speed_vs_error, BenchConfig, BenchOptions, BenchReport, BenchRow, SceneSpec, Size,
};
use crate::gpu::GlContext;
use crate::image_io::{self, Image};
use crate::options::{Backend, Precision, RenderOptions};
use crate::output::RayCounts;
use crate::progress::Progress;
use crate::render;
use crate::scene::{self, Scene};
use crate::{Error, Result};

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

/// FNV-1a, to key cached references by scene text.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// A GL context made on first use and shared by every GL render of the bench.
struct GlCache(std::cell::OnceCell<std::result::Result<GlContext, String>>);

impl GlCache {
    fn get(&self) -> std::result::Result<&GlContext, String> {
        self.0
            .get_or_init(|| GlContext::new().map_err(|e| e.to_string()))
            .as_ref()
            .map_err(Clone::clone)
    }
}

fn render_with(gl: &GlCache, scene: &Scene, opts: &RenderOptions) -> Result<render::Rendered> {
    match opts.backend {
        Backend::Cpu => render::render_cpu(scene, opts),
        Backend::Gl => {
            let ctx = gl.get().map_err(Error::GlUnavailable)?;
            render::render_gl_with(ctx, scene, opts)
        }
        Backend::Auto => match gl.get() {
            Ok(ctx) if render::auto_declines(&ctx.info).is_none() => {
                render::render_gl_with(ctx, scene, opts)
            }
            _ => render::render_cpu(scene, opts),
        },
    }
}

/// The configurations to run: all of `opts.configs`, except with
/// [`BenchOptions::fit_to_machine`] on a software GL, where the multipass and unrolled GL
/// kernels (hundreds to thousands of passes per frame, each a full-screen draw on the
/// CPU) would take tens of minutes; returns them, the names left out and why.
fn fit_to_machine<'a>(
    opts: &'a BenchOptions,
    gl: &GlCache,
) -> (Vec<&'a BenchConfig>, Vec<String>, Option<String>) {
    let all: Vec<&BenchConfig> = opts.configs.iter().collect();
    let uses_gl = |c: &BenchConfig| c.render.choices.backend != Backend::Cpu;
    if !opts.fit_to_machine || !all.iter().any(|c| uses_gl(c)) {
        return (all, Vec::new(), None);
    }
    let renderer = match gl.get() {
        Ok(ctx) if ctx.info.is_software() => ctx.info.renderer.clone(),
        _ => return (all, Vec::new(), None),
    };
    let slow = |c: &BenchConfig| {
        uses_gl(c)
            && matches!(
                c.render.choices.kernel,
                crate::gpu::options::Kernel::Multipass | crate::gpu::options::Kernel::Unrolled(_)
            )
    };
    let (left, kept): (Vec<&BenchConfig>, Vec<&BenchConfig>) =
        all.into_iter().partition(|c| slow(c));
    if left.is_empty() {
        return (kept, Vec::new(), None);
    }
    let why = format!(
        "{renderer} renders GL on the CPU, where the multipass and unrolled kernels of the \
         default preset take tens of minutes; `--configs default` runs them too"
    );
    (
        kept,
        left.iter().map(|c| c.name.clone()).collect(),
        Some(why),
    )
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
    // The reference is f64 whatever the default precision is (f32, the fast path).
    opts.precision = Precision::F64;
    let out = render::render_cpu(scene, &opts)?;
    image_io::create_folder(dir, "reference")?;
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
            // Warned about once here; a configuration's `--textures` applies per run.
            let mut scene = scene;
            crate::options::TextureMode::On.apply(&mut scene)?;
            Ok((s.clone(), scene))
        })
        .collect::<Result<_>>()?;
    image_io::create_folder(&opts.out, "bench output")?;

    let gl = GlCache(std::cell::OnceCell::new());
    let (configs, left_out, left_out_why) = fit_to_machine(opts, &gl);
    if let Some(why) = &left_out_why {
        if !opts.quiet {
            eprintln!(
                "fragtrace: notice: bench: {why}; left out: {}",
                left_out.join(", ")
            );
        }
    }
    let per_config = opts.runs as u64 + 1;
    let total = scenes.len() as u64 * configs.len() as u64 * per_config;
    let progress = Progress::bar_with_message(!opts.quiet, total, "renders");
    let say = |line: String| {
        if !opts.quiet {
            progress.println(line);
        }
    };
    let mut rows = Vec::new();
    let mut triangles = BTreeMap::new();
    let refs_dir = opts.out.join("references");

    for (spec, scene) in &scenes {
        triangles.insert(spec.name.clone(), scene.triangles.len());
        progress.message(format!("{}: CPU f64 reference", spec.name));
        let reference = reference(spec, scene, opts.size, &refs_dir)?;
        let first_row = rows.len();
        for cfg in configs.iter().copied() {
            let mut args = cfg.render.choices.clone();
            args.width = Some(opts.size.width);
            args.height = Some(opts.size.height);
            let row = match args.to_options(scene, crate::choices::Door::Bench) {
                Err(e) => BenchRow::failed(&spec.name, cfg, opts.size, e.to_string()),
                Ok(ropts) => bench_one(&gl, spec, scene, cfg, &ropts, opts, &reference, &progress),
            };
            match &row.error {
                None => say(format!(
                    "{} / {}: {} (median of {}), {} rays, {}, RMSE {:.6}, FLIP {:.6}",
                    row.scene,
                    row.config,
                    fmt_secs(row.time_s),
                    row.runs,
                    row.rays.total,
                    crate::output::ray_rate(row.rays.total, row.time_s * 1e3),
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

    let gl_device = match gl.0.get() {
        Some(Ok(ctx)) => Some(ctx.info.renderer.clone()),
        _ => None,
    };
    let mut report = BenchReport {
        rows,
        triangles,
        gl_device,
        files: vec![],
        left_out,
        left_out_why,
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
    gl: &GlCache,
    spec: &SceneSpec,
    scene: &Scene,
    cfg: &BenchConfig,
    ropts: &RenderOptions,
    opts: &BenchOptions,
    reference: &Image,
    progress: &Progress,
) -> BenchRow {
    let stage = |what: String| progress.message(format!("{} / {}: {what}", spec.name, cfg.name));
    // `--steady`: one renderer for the warm-up (its first frame) and every run, its
    // structure (`--accel auto` resolved) that of the backend the context settles.
    let ctx = match (cfg.steady, ropts.backend) {
        (true, Backend::Gl) => gl.get().ok(),
        (true, Backend::Auto) => gl
            .get()
            .ok()
            .filter(|ctx| render::auto_declines(&ctx.info).is_none()),
        _ => None,
    };
    let ropts = &match ctx {
        Some(ctx) => ropts.on_context(scene, Some(&ctx.info)),
        None => ropts.on_backend(ropts.backend == Backend::Gl),
    };
    let prepared = match cfg
        .steady
        .then(|| render::prepare(scene, ropts))
        .transpose()
    {
        Ok(p) => p,
        Err(e) => return BenchRow::failed(&spec.name, cfg, opts.size, e.to_string()),
    };
    let mut renderer = match (&prepared, ctx) {
        (Some(p), Some(ctx)) => match p.gl_renderer(ctx, ropts) {
            Ok(r) => Some(r),
            Err(e) => return BenchRow::failed(&spec.name, cfg, opts.size, e.to_string()),
        },
        (Some(_), None) if ropts.backend == Backend::Gl => {
            return BenchRow::failed(&spec.name, cfg, opts.size, "no GL context".into())
        }
        (Some(p), None) => Some(p.cpu_renderer(ropts)),
        (None, _) => None,
    };
    let mut timed = |gl: &GlCache| -> Result<(f64, render::Rendered)> {
        let t0 = Instant::now();
        let out = match renderer.as_mut() {
            Some(r) => r.render(&scene.camera)?,
            None => render_with(gl, scene, ropts)?,
        };
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
        .filter_map(|r| r.1.stats.gpu.as_ref()?.gpu_ms_total)
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
