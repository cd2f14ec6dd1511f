//! Render options and the flags that set them: [`RenderArgs`] (the clap flags of `render`,
//! which bench configurations are parsed with too), [`RenderOptions`] (what one render
//! needs, whoever asks) and the conversion between them, with the limits every backend
//! checks before allocating.
//!
//! This module sits below both the command line and the bench (and above the backends,
//! whose options it carries), so neither of those imports the other.

use std::path::PathBuf;

use clap::{Args, Parser, ValueEnum};
use serde::Serialize;

use crate::accel::{AccelKind, GridConfig, GridRes, IrregularConfig};
use crate::region::{Region, TileSpec, Tiling};
use crate::scene::Scene;
use crate::technique::{IntersectMethod, OffsetMethod, TBound, Techniques, Terminator};
use crate::{Error, Result};

/// Which renderer runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Backend {
    /// The GPU when a suitable GL context can be made on a GPU, else the CPU with a notice
    /// saying why (a software rasterizer such as llvmpipe runs GL on the CPU, slower than
    /// the CPU backend; `--backend gl` uses it anyway); `fragtrace info` says which.
    Auto,
    /// The CPU reference renderer.
    Cpu,
    /// The GPU renderer over EGL, with the kernel of --kernel (auto: compute on GL 4.3,
    /// looped on GL 3.x, the GLSL 1.20 multipass on GL 2.1); fails rather than falling back.
    Gl,
}

/// Arithmetic precision of the CPU renderer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// Single precision, as the GPU computes.
    F32,
    /// Double precision: the ground truth.
    F64,
}

/// How the f32 CPU renderer tests triangles (`--cpu-path`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum CpuPath {
    /// Ray packets: batches of rays walk the BVH 16 (AVX-512) or 8 (AVX2) at a time,
    /// chosen at run time, each box and triangle test one vector operation for the whole
    /// packet; the same hits and images as scalar (the `steps` AOV counts the packet's
    /// work). The grids, and CPUs without AVX2, take `simd`.
    #[default]
    Packet,
    /// Vectorised one ray at a time: each cell's or leaf's triangles 8 (AVX2) or 4 (SSE2)
    /// at a time, chosen at run time; the same hits, images and counters as scalar.
    Simd,
    /// One triangle at a time: the twin of the GLSL code.
    Scalar,
}

impl CpuPath {
    /// The name `--cpu-path` takes.
    pub fn name(self) -> &'static str {
        match self {
            CpuPath::Packet => "packet",
            CpuPath::Simd => "simd",
            CpuPath::Scalar => "scalar",
        }
    }
}

/// The structure `--accel` asks for: one by name, or `auto`, the fastest for the backend
/// that renders (the irregular grid on the GPU, the BVH on the CPU).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum AccelChoice {
    /// The irregular grid on the GPU (the structure its kernels walk fastest), the BVH on
    /// the CPU (3-4x faster to walk there, and 6x faster to build, with the same images);
    /// the irregular grid on both when a grid density is given.
    #[default]
    Auto,
    /// The thesis's uniform grid.
    Uniform,
    /// The irregular grid.
    Irregular,
    /// The 4-wide BVH (CPU backend only).
    Bvh,
}

impl AccelChoice {
    /// The structure named, or None for `auto`.
    pub fn named(self) -> Option<AccelKind> {
        match self {
            AccelChoice::Auto => None,
            AccelChoice::Uniform => Some(AccelKind::Uniform),
            AccelChoice::Irregular => Some(AccelKind::Irregular),
            AccelChoice::Bvh => Some(AccelKind::Bvh),
        }
    }
}

impl From<AccelKind> for AccelChoice {
    fn from(k: AccelKind) -> Self {
        match k {
            AccelKind::Uniform => AccelChoice::Uniform,
            AccelKind::Irregular => AccelChoice::Irregular,
            AccelKind::Bvh => AccelChoice::Bvh,
        }
    }
}

/// What `--accel auto` builds for a render on the GPU (`gpu`) or on the CPU.
pub fn auto_accel(gpu: bool) -> AccelKind {
    if gpu {
        AccelKind::Irregular
    } else {
        AccelKind::Bvh
    }
}

/// Largest image side accepted (checked before allocating anything).
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// Host memory one render may need at most; checked before allocating anything.
pub const MAX_HOST_BYTES: u64 = 8 << 30;
/// Upper estimate of the host bytes a render needs per pixel: the radiance and AOV rows
/// and their assembled copies on the CPU, or the read-back textures on the GPU, plus the
/// encoded image.
pub const HOST_BYTES_PER_PIXEL: u64 = 128;
/// Largest sample count per pixel.
pub const MAX_SPP: u32 = 1024;
/// Largest recursion depth.
pub const MAX_DEPTH: u32 = 16;
/// Largest `--query-every`: traversal iterations between termination queries.
pub const MAX_QUERY_EVERY: u32 = 4096;

/// Everything that controls one render.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel (stratified, fixed seed).
    pub spp: u32,
    /// Maximum recursion depth (reflection/refraction bounces).
    pub max_depth: u32,
    /// CPU arithmetic precision.
    pub precision: Precision,
    /// Vectorised or scalar triangle tests on the CPU in f32 (f64 is always scalar).
    pub cpu_path: CpuPath,
    /// Which acceleration structure is built.
    pub accel: AccelKind,
    /// `accel` follows the backend that renders (`--accel auto`): once the backend is
    /// chosen, [`RenderOptions::on_backend`] sets it to [`auto_accel`]'s structure.
    pub accel_auto: bool,
    /// Uniform grid resolution and density.
    pub grid: GridConfig,
    /// Irregular grid parameters.
    pub irregular: IrregularConfig,
    /// Which renderer runs.
    pub backend: Backend,
    /// GPU backend options.
    pub gpu: crate::gpu::options::GpuOptions,
    /// Show a progress display on stderr (only drawn when stderr is a terminal).
    pub progress: bool,
    /// Robustness techniques, on every backend (the GL render uses these, not
    /// `gpu.techniques`).
    pub techniques: crate::technique::Techniques,
    /// What to read back (default: everything; the CLI asks for less).
    pub readback: crate::output::Readback,
    /// Render only these pixels of the `width` x `height` image (`--tile`, `--region`);
    /// each is bit-identical to the same pixel of the whole render. None: the whole image.
    pub region: Option<Region>,
    /// The EGL device the GL backend opens (`--gpu N`); None: the first display that works.
    pub device: Option<u32>,
}

impl RenderOptions {
    /// The scene's own size and depth, one sample, f64, the irregular grid (named, not
    /// `auto`), the CPU backend.
    pub fn for_scene(scene: &Scene) -> Self {
        RenderOptions {
            width: scene.width,
            height: scene.height,
            spp: 1,
            max_depth: scene.max_depth,
            precision: Precision::F64,
            cpu_path: CpuPath::default(),
            accel: AccelKind::default(),
            accel_auto: false,
            grid: GridConfig::default(),
            irregular: IrregularConfig::default(),
            backend: Backend::Cpu,
            gpu: crate::gpu::options::GpuOptions::default(),
            progress: false,
            techniques: crate::technique::Techniques::default(),
            readback: crate::output::Readback::default(),
            region: None,
            device: None,
        }
    }

    /// These options for a render on the GPU (`gpu`) or the CPU: with `accel_auto`, the
    /// structure [`auto_accel`] picks for that backend (and `accel_auto` cleared, so a
    /// second call changes nothing); otherwise unchanged.
    pub fn on_backend(&self, gpu: bool) -> RenderOptions {
        let mut o = self.clone();
        if o.accel_auto {
            o.accel = auto_accel(gpu);
            o.accel_auto = false;
        }
        o
    }

    /// The pixels rendered: the region, or the whole image.
    pub fn pixels(&self) -> Region {
        self.region
            .unwrap_or_else(|| Region::full(self.width, self.height))
    }

    /// Rejects sizes and counts out of range before any allocation.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if v == 0 || v > MAX_IMAGE_SIDE {
                return Err(Error::Usage(format!(
                    "--{name} {v} is outside 1..={MAX_IMAGE_SIDE}"
                )));
            }
        }
        if let Some(r) = &self.region {
            r.check_inside(self.width, self.height, "the region")?;
        }
        // Memory goes with the pixels rendered: a poster too large for one process
        // renders as tiles that each fit.
        let px = self.pixels();
        let bytes = px.area() * HOST_BYTES_PER_PIXEL;
        if bytes > MAX_HOST_BYTES {
            let part = if self.region.is_some() {
                format!(
                    " (a {}x{} part of {}x{})",
                    px.width(),
                    px.height(),
                    self.width,
                    self.height
                )
            } else {
                String::new()
            };
            return Err(Error::Limit(format!(
                "a {}x{} image{part} needs about {:.1} GiB of host memory, more than the {} GiB limit{}",
                px.width(),
                px.height(),
                bytes as f64 / (1u64 << 30) as f64,
                MAX_HOST_BYTES >> 30,
                if self.region.is_some() { "; cut it into more tiles" } else { "; render it in tiles (--tile I/N, docs/distributed.md)" }
            )));
        }
        if self.spp == 0 || self.spp > MAX_SPP {
            return Err(Error::Usage(format!(
                "--spp {} is outside 1..={MAX_SPP}",
                self.spp
            )));
        }
        if self.max_depth > MAX_DEPTH {
            return Err(Error::Usage(format!(
                "--max-depth {} is outside 0..={MAX_DEPTH}",
                self.max_depth
            )));
        }
        if self.backend == Backend::Gl && !self.accel.on_gpu() {
            return Err(Error::Usage(format!(
                "--accel {} is walked on the CPU backend only: add --backend cpu, or take \
                 --accel irregular for the GPU",
                self.accel.name()
            )));
        }
        Ok(())
    }
}

/// Arguments of `render`.
#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// Scene file (TOML); the built-in default scene when omitted.
    pub scene: Option<PathBuf>,
    /// Output image, by extension: .png or .ppm (sRGB 8-bit), .exr or .tif/.tiff (linear
    /// 32-bit float), .hdr (Radiance RGBE, linear).
    #[arg(short, long, default_value = "render.png")]
    pub output: PathBuf,
    /// Image width (default: the scene's).
    #[arg(long, allow_negative_numbers = true, value_parser = count_in(1, MAX_IMAGE_SIDE))]
    pub width: Option<u32>,
    /// Image height (default: the scene's).
    #[arg(long, allow_negative_numbers = true, value_parser = count_in(1, MAX_IMAGE_SIDE))]
    pub height: Option<u32>,
    /// Renderer: auto, cpu or gl.
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
    /// CPU arithmetic: f64 (ground truth) or f32 (mirrors the GPU).
    #[arg(long, value_enum, default_value_t = Precision::F64)]
    pub precision: Precision,
    /// CPU triangle tests with --precision f32: simd (8 or 4 at a time, AVX2 or SSE2 as the
    /// CPU has; same hits and images as scalar) or scalar (the GLSL's twin). f64 is always
    /// scalar.
    #[arg(long, value_enum, default_value_t = CpuPath::default())]
    pub cpu_path: CpuPath,
    /// Maximum reflection/refraction depth (default: the scene's, else 5).
    #[arg(long, allow_negative_numbers = true, value_parser = count_in(0, MAX_DEPTH))]
    pub max_depth: Option<u32>,
    /// Samples per pixel (stratified, fixed seed).
    #[arg(long, default_value_t = 1, allow_negative_numbers = true, value_parser = count_in(1, MAX_SPP))]
    pub spp: u32,
    /// Acceleration structure: auto (the default: the irregular grid on the GPU, the BVH
    /// on the CPU, each the fastest there, with the same images; the irregular grid on both
    /// when a grid density is given), irregular (adaptive cells with exit boxes grown over empty
    /// space, after Perard-Gayot et al. 2017), uniform (the thesis's grid over the scene
    /// box) or bvh (CPU backend only: a 4-wide BVH).
    #[arg(long, value_enum, default_value_t = AccelChoice::default())]
    pub accel: AccelChoice,
    /// Uniform grid resolution: auto or AxBxC (with --accel uniform).
    #[arg(long, default_value = "auto")]
    pub grid: GridRes,
    /// Cells per triangle of the auto uniform grid (lambda, default 8; with --accel
    /// uniform), or top cells per triangle of the irregular grid (default 0.125).
    #[arg(long, allow_negative_numbers = true)]
    pub grid_density: Option<f32>,
    /// GPU: traversal iterations between termination queries (K).
    #[arg(long, default_value_t = 8, allow_negative_numbers = true, value_parser = count_in(1, MAX_QUERY_EVERY))]
    pub query_every: u32,
    /// GPU: kernel: auto (the fastest the context runs: compute on GL 4.3, looped on GL 3.x,
    /// multipass on GL 2.x), compute (GLSL 4.30: the whole ray tree per pixel in one
    /// dispatch), looped (bounded loop per pass), multipass (the thesis: one step per pass,
    /// no loops) or unrolled:K (K steps per pass, straight-line code, no loops). All render
    /// the same image.
    #[arg(long, default_value = "auto")]
    pub kernel: crate::gpu::options::Kernel,
    /// GPU: compile every shading feature in instead of only what the scene needs.
    #[arg(long)]
    pub no_specialize: bool,
    /// GPU: keep finished rays out of traversal passes with the depth test (early-z) or the
    /// stencil test, refreshed at each termination query; none relies on the in-shader
    /// early-out alone; auto is early-z for the multipass kernel and none for the others.
    #[arg(long, default_value = "auto")]
    pub mask: crate::gpu::options::Mask,
    /// GPU: ray textures in 32- or 16-bit floats (f16: ray directions and the colour sum;
    /// origins and every index stay in 32-bit textures).
    #[arg(long, default_value = "f32")]
    pub storage: crate::gpu::options::Storage,
    /// GPU, compute kernel: how it reads the scene, through texelFetch or storage buffers;
    /// auto is the faster where measured (storage buffers on NVIDIA, texelFetch on
    /// llvmpipe), storage buffers elsewhere. Both render the same image.
    #[arg(long, value_enum, default_value_t = crate::gpu::options::SceneFetch::Auto)]
    pub scene_fetch: crate::gpu::options::SceneFetch,
    /// Ray-triangle test: watertight (Woop et al. 2013, the default) or moller-trumbore
    /// (1997; rays can slip through shared edges). For measuring the technique's cost.
    #[arg(long, value_enum, default_value_t = IntersectMethod::Watertight)]
    pub intersect: IntersectMethod,
    /// pbrt's t error bound on hits (on, the default) or off (spawned rays may re-hit
    /// their own surface). For measuring the technique's cost.
    #[arg(long, value_enum, default_value_t = TBound::On)]
    pub t_bound: TBound,
    /// Origin offset of spawned rays: error-bound (scale-independent, the default) or
    /// epsilon (a fixed 1e-4 along the normal). For measuring the technique's cost.
    #[arg(long, value_enum, default_value_t = OffsetMethod::ErrorBound)]
    pub offset: OffsetMethod,
    /// Shadow rays of smooth-shaded meshes: smooth (start on the surface the vertex normals
    /// describe, Hanika 2021; the default: no dark speckles near the terminator) or exact
    /// (start on the triangle). For measuring the technique's cost and value.
    #[arg(long, value_enum, default_value_t = Terminator::Smooth)]
    pub terminator: Terminator,
    /// Write primary-ray AOVs next to the image: any of depth,normal,primid,steps
    /// (`<stem>.aov.exr`, and a PNG preview of each, `<stem>.<aov>.png`: depth as grey,
    /// normals as colour, primid in false colour, steps as a heat map).
    #[arg(long)]
    pub aov: Option<String>,
    /// Write render statistics as JSON to this file.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Render part I of the image cut into N parts (a grid chosen for the image; I/CxR
    /// for C columns by R rows), 0-based from the top left, as an OpenEXR part for
    /// `fragtrace merge` (-o PART.exr). Each pixel is bit-identical to the whole render's.
    #[arg(long, conflicts_with_all = ["region", "task_index"])]
    pub tile: Option<TileSpec>,
    /// Render only the pixels x0..x1, y0..y1 (x1, y1 exclusive; origin top left) of the
    /// image: a part for `fragtrace merge` as .exr, a crop as .png.
    #[arg(long, value_name = "X0,Y0,X1,Y1", conflicts_with = "task_index")]
    pub region: Option<Region>,
    /// Take this task's share of the work from the scheduler: env (a Slurm job array,
    /// SLURM_ARRAY_TASK_ID), env:N (a Kubernetes Indexed Job of N completions,
    /// JOB_COMPLETION_INDEX) or I/N. The image is cut into --tiles parts (default: one per
    /// task); -o names each part with {tile} (docs/distributed.md).
    #[arg(long, value_name = "env|env:N|I/N")]
    pub task_index: Option<crate::farm::task::TaskSource>,
    /// With --task-index: the parts the image is cut into, N or CxR (default: as many as
    /// there are tasks).
    #[arg(long, value_name = "N|CxR", requires = "task_index")]
    pub tiles: Option<Tiling>,
    /// GPU: render on EGL device N (`fragtrace info` lists them; on a Slurm GPU node, the
    /// one the task was given: docs/distributed.md); default: the first display that
    /// works.
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = count_in(0, u32::MAX))]
    pub gpu: Option<u32>,
    /// Render the frames A..B (both included), or all, of the scene's camera path
    /// (the scene file's `[animation]` table), uploading the scene once; -o names each frame with
    /// a run of # (out/frame_####.png) or {frame}.
    #[arg(long, value_name = "A..B|all")]
    pub frames: Option<FrameRange>,
    /// Print nothing but errors (no progress display, no summary).
    #[arg(short, long)]
    pub quiet: bool,
    /// After the render, log each pass kind's count and GPU time (or the CPU's work).
    #[arg(short, long)]
    pub verbose: bool,
}

/// A frame range of `--frames`: `A..B` (both included), `A` alone, or `all` (the path's).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FrameRange {
    /// Every frame of the scene's path.
    All,
    /// Frames `A..=B`.
    Range(u32, u32),
}

impl std::str::FromStr for FrameRange {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let bad = || format!("`{s}` is not a frame range (expected A..B, A or all)");
        if s == "all" {
            return Ok(FrameRange::All);
        }
        let (a, b) = match s.split_once("..") {
            Some((a, b)) => (a, b.strip_prefix('=').unwrap_or(b)),
            None => (s, s),
        };
        let (a, b): (u32, u32) = (a.parse().map_err(|_| bad())?, b.parse().map_err(|_| bad())?);
        if a > b {
            return Err(format!("frame range {s} runs backwards"));
        }
        Ok(FrameRange::Range(a, b))
    }
}

impl FrameRange {
    /// The frames this range takes of `path`'s frames, checked against them.
    pub fn frames(
        &self,
        path: &std::ops::RangeInclusive<u32>,
    ) -> Result<std::ops::RangeInclusive<u32>> {
        match *self {
            FrameRange::All => Ok(path.clone()),
            FrameRange::Range(a, b) if path.contains(&a) && path.contains(&b) => Ok(a..=b),
            FrameRange::Range(a, b) => Err(Error::Usage(format!(
                "--frames {a}..{b} is outside the scene's camera path, frames {}..{}",
                path.start(),
                path.end()
            ))),
        }
    }
}

/// `render`'s arguments as a command of their own, for parsing lists of them.
#[derive(Parser)]
#[command(name = "render")]
struct RenderArgsParser {
    #[command(flatten)]
    inner: RenderArgs,
}

impl RenderArgs {
    /// Parses `render` arguments from a list (a bench configuration's, for one), returning
    /// [`Error::Usage`] with clap's one-line message instead of exiting.
    pub fn try_parse_from_args<S: AsRef<str>>(args: &[S]) -> Result<Self> {
        let all = std::iter::once("render").chain(args.iter().map(|a| a.as_ref()));
        RenderArgsParser::try_parse_from(all)
            .map(|p| p.inner)
            .map_err(|e| {
                // The first line and the accepted values; clap's tips are about typing a
                // command line, not a configuration string.
                let lines = clap_error_lines(&e)
                    .into_iter()
                    .enumerate()
                    .filter(|(i, l)| *i == 0 || l.starts_with("[possible values"))
                    .map(|(_, l)| l)
                    .collect();
                Error::Usage(join_clap_lines(lines))
            })
    }

    /// Turns the flags into render options for `scene`, checking the ranges the parser
    /// leaves open (grid density, query interval, sizes and counts).
    pub fn to_options(&self, scene: &Scene) -> Result<RenderOptions> {
        let args = self;
        let mut opts = RenderOptions::for_scene(scene);
        opts.width = args.width.unwrap_or(scene.width);
        opts.height = args.height.unwrap_or(scene.height);
        opts.spp = args.spp;
        opts.max_depth = args.max_depth.unwrap_or(scene.max_depth);
        opts.precision = args.precision;
        opts.cpu_path = args.cpu_path;
        opts.backend = args.backend;
        // `auto` with a density asks for a grid: the irregular one, on either backend.
        // Otherwise it follows the backend; `--backend auto` is settled when the context
        // is made (`RenderOptions::on_backend`), until then the GPU's structure stands.
        (opts.accel, opts.accel_auto) = match (args.accel.named(), args.grid_density) {
            (Some(kind), _) => (kind, false),
            (None, Some(_)) => (AccelKind::Irregular, false),
            (None, None) => (auto_accel(args.backend != Backend::Cpu), true),
        };
        let mut grid = GridConfig {
            res: args.grid,
            ..GridConfig::default()
        };
        if let Some(d) = args.grid_density {
            if !(d.is_finite() && d > 0.0 && d <= 1024.0) {
                return Err(Error::Usage(format!(
                    "--grid-density {d} is outside (0, 1024]"
                )));
            }
            match opts.accel {
                AccelKind::Uniform => grid.density = d,
                AccelKind::Irregular => opts.irregular.top_density = d,
                AccelKind::Bvh => {
                    return Err(Error::Usage(
                        "--grid-density sets a grid's cells; the BVH has none".into(),
                    ))
                }
            }
        }
        if opts.accel != AccelKind::Uniform && args.grid != GridRes::Auto {
            return Err(Error::Usage(format!(
                "--grid {} sets the uniform grid; add --accel uniform",
                args.grid
            )));
        }
        opts.grid = grid;
        if args.query_every == 0 || args.query_every > MAX_QUERY_EVERY {
            return Err(Error::Usage(format!(
                "--query-every {} is outside 1..={MAX_QUERY_EVERY}",
                args.query_every
            )));
        }
        opts.gpu.query_every = args.query_every;
        opts.gpu.no_specialize = args.no_specialize;
        opts.gpu.kernel = args.kernel;
        opts.gpu.mask = args.mask;
        opts.gpu.storage = args.storage;
        opts.gpu.scene_fetch = args.scene_fetch;
        opts.device = args.gpu;
        opts.progress = !args.quiet;
        opts.techniques = Techniques {
            intersect: args.intersect,
            t_bound: args.t_bound,
            offset: args.offset,
            terminator: args.terminator,
        };
        opts.validate()?;
        Ok(opts)
    }
}

/// The parser of a count flag whose valid values are `lo..=hi`. Negative numbers reach it
/// (the flags allow them) so that `--width -5` says what is wrong with -5 instead of clap's
/// "unexpected argument" and its tip to write `-- -5`. It refuses negative numbers
/// and non-numbers, naming that range (so `--width -5` does not suggest that 0 would do);
/// the range itself is checked with the other options ([`RenderOptions::validate`]), whose
/// message names the flag and the same range.
pub fn count_in(
    lo: u32,
    hi: u32,
) -> impl Fn(&str) -> std::result::Result<u32, String> + Clone + Send + Sync + 'static {
    move |s: &str| {
        s.parse::<u32>()
            .map_err(|_| match s.trim().parse::<i128>() {
                Ok(v) if v < 0 => {
                    format!("{v} is negative; a whole number in {lo}..={hi} is expected")
                }
                _ => format!("`{s}` is not a whole number in {lo}..={hi}"),
            })
    }
}

/// A clap error as one line: clap's own first line without its `error:` prefix and any
/// further lines of explanation (possible values, a tip), not the usage block.
pub fn clap_error_line(e: &clap::Error) -> String {
    join_clap_lines(clap_error_lines(e))
}

/// The lines of a clap error before its usage block, trimmed, without the `error:` prefix;
/// the error kind when clap gave no text.
fn clap_error_lines(e: &clap::Error) -> Vec<String> {
    let rendered = e.render().to_string();
    let mut parts: Vec<String> = Vec::new();
    for line in rendered.lines().map(str::trim) {
        if line.starts_with("Usage:") || line.starts_with("For more information") {
            break;
        }
        if line.is_empty() {
            continue;
        }
        // clap suggests `-- -5` for a value that looks like a flag; after `--` it would be
        // read as the scene file, so the tip misleads.
        if line.starts_with("tip: to pass '") && line.contains("use '-- ") {
            continue;
        }
        parts.push(line.strip_prefix("error: ").unwrap_or(line).to_owned());
    }
    if parts.is_empty() {
        parts.push(format!("{}", e.kind()));
    }
    parts
}

/// Joins message lines with `: ` (one space after a line that already ends in a colon).
fn join_clap_lines(parts: Vec<String>) -> String {
    let mut out = String::new();
    for p in parts {
        if !out.is_empty() {
            out += if out.ends_with(':') { " " } else { ": " };
        }
        out += &p;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options(flags: &[&str]) -> Result<RenderOptions> {
        RenderArgs::try_parse_from_args(flags)?.to_options(&crate::scene::builtin_scene())
    }

    /// `--accel auto` (the default) is the BVH for `--backend cpu` and the irregular grid
    /// for `gl`; for `auto` the GPU's structure until the context settles the backend, when
    /// `on_backend` takes the CPU's; a density asks for the irregular grid on either; a
    /// named structure is never changed.
    #[test]
    fn accel_auto_follows_the_backend() {
        let kind = |flags: &[&str]| {
            let o = options(flags).unwrap();
            (o.accel, o.accel_auto)
        };
        use AccelKind::*;
        assert_eq!(kind(&["--backend", "cpu"]), (Bvh, true));
        assert_eq!(kind(&["--backend", "cpu", "--accel", "auto"]), (Bvh, true));
        assert_eq!(kind(&["--backend", "gl"]), (Irregular, true));
        assert_eq!(kind(&[]), (Irregular, true));
        for backend in ["cpu", "gl", "auto"] {
            let flags = ["--backend", backend, "--grid-density", "0.5"];
            assert_eq!(kind(&flags), (Irregular, false), "{backend}");
            let o = options(&flags).unwrap();
            assert_eq!(o.irregular.top_density, 0.5);
            for (name, k) in [("uniform", Uniform), ("irregular", Irregular)] {
                assert_eq!(kind(&["--backend", backend, "--accel", name]), (k, false));
            }
        }
        assert_eq!(kind(&["--backend", "cpu", "--accel", "bvh"]), (Bvh, false));

        let auto = options(&[]).unwrap();
        assert_eq!(auto.on_backend(false).accel, Bvh);
        assert_eq!(auto.on_backend(true).accel, Irregular);
        // Resolved once: a second call for the other backend changes nothing.
        assert_eq!(auto.on_backend(false).on_backend(true).accel, Bvh);
        let named = options(&["--accel", "uniform"]).unwrap();
        assert_eq!(named.on_backend(false).accel, Uniform);
        assert_eq!(named.on_backend(true).accel, Uniform);
        // The library's own defaults name the irregular grid.
        let lib = RenderOptions::for_scene(&crate::scene::builtin_scene());
        assert_eq!((lib.accel, lib.accel_auto), (Irregular, false));
        assert_eq!(lib.on_backend(false).accel, Irregular);
    }

    /// What `auto` cannot mean: the BVH's density, and `--grid` without the uniform grid.
    #[test]
    fn accel_auto_keeps_the_refusals() {
        for flags in [
            &["--backend", "cpu", "--accel", "bvh", "--grid-density", "2"][..],
            &["--backend", "cpu", "--grid", "4x4x4"][..],
            &["--backend", "gl", "--grid", "4x4x4"][..],
        ] {
            assert!(matches!(options(flags), Err(Error::Usage(_))), "{flags:?}");
        }
        assert!(options(&["--backend", "cpu", "--accel", "uniform", "--grid", "4x4x4"]).is_ok());
    }
}
