//! `fragtrace bench`: every configuration of the renderer on every scene, timed and judged
//! against the f64 CPU reference, written as a CSV table, a Markdown report and a
//! speed-versus-error plot.
//!
//! A *configuration* is a name plus `render` arguments (`gl-multipass = "--backend gl
//! --kernel multipass"`), parsed by the same parser as `fragtrace render`
//! ([`RenderArgs`](crate::choices::RenderArgs), from the choices module below the CLI and
//! the bench). The shipped ones live in [`CONFIG_TABLE`], grouped into the presets
//! `default`, `quick` and `all`; a TOML file can name others.
//!
//! For each scene x configuration: one warm-up render, then `runs` timed renders (the rest
//! are skipped once one takes longer than `max_seconds`; a warm-up that alone takes longer
//! is kept as the only timed run). Time is the wall-clock time of the render call (grid
//! build, shader compilation, upload, passes, read-back), the median over the timed runs.
//! The error of the first timed run's image is measured against a CPU f64 render of the
//! same scene at the same size (rendered once per scene and cached in the output folder):
//! RMSE over linear RGB and mean FLIP ([`crate::compare`]).
//!
//! One file per job: `config` (presets, configuration files, sizes, scene names: all
//! resolved before the first render), `runner` (the GL context, the cached references, the
//! timed renders), `report` (Pareto fronts, `results.csv`, `report.md`) and `plot`
//! (`speed_vs_error.png`). This module holds the types they share and re-exports their
//! public items.

mod config;
mod plot;
mod report;
mod runner;

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::Serialize;

use crate::output::RayCounts;

pub use config::{
    parse_config_file, resolve_configs, resolve_scenes, shipped_scenes_dir, BenchConfig, ConfigRow,
    SceneSpec, Size, CONFIG_TABLE, PRESETS,
};
pub use plot::plot_speed_vs_error;
pub use report::{mark_pareto, median, pareto_front, report_markdown, results_csv, CSV_HEADER};
pub use runner::run_bench;

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
    /// `configs` is the default preset, not asked for by name: on a software GL
    /// (llvmpipe, softpipe, swrast) the bench leaves out its multipass and unrolled GL
    /// configurations, which take tens of minutes there, and says so.
    pub fit_to_machine: bool,
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
    /// Configurations left out to fit the machine ([`BenchOptions::fit_to_machine`]), and
    /// why; empty when none was.
    pub left_out: Vec<String>,
    /// Why they were left out (one sentence), when any was.
    pub left_out_why: Option<String>,
}
