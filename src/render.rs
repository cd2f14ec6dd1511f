//! Backend-independent rendering front door: options, statistics, AOVs, and dispatch to
//! the CPU reference renderer (and, where built, the GPU backend).

use std::time::Instant;

use serde::Serialize;

use crate::accel::{Grid, GridConfig};
use crate::cpu::CpuRenderer;
use crate::gpu::GlContext;
use crate::image_io::Image;
use crate::output::{Aov, GpuStats, RayCounts};
use crate::scene::Scene;
use crate::{Error, Result};

/// Which renderer runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// The GPU when a suitable GL context can be made, else the CPU with a notice.
    Auto,
    /// The CPU reference renderer.
    Cpu,
    /// The GLSL 1.20 multi-pass renderer; fails rather than falling back.
    Gl,
}

impl std::str::FromStr for Backend {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "auto" => Ok(Backend::Auto),
            "cpu" => Ok(Backend::Cpu),
            "gl" => Ok(Backend::Gl),
            _ => Err(format!("unknown backend `{s}` (expected auto, cpu or gl)")),
        }
    }
}

/// Arithmetic precision of the CPU renderer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// Single precision, as the GPU computes.
    F32,
    /// Double precision: the ground truth.
    F64,
}

impl std::str::FromStr for Precision {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "f32" => Ok(Precision::F32),
            "f64" => Ok(Precision::F64),
            _ => Err(format!("unknown precision `{s}` (expected f32 or f64)")),
        }
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
    /// Grid resolution and density.
    pub grid: GridConfig,
    /// Which renderer runs.
    pub backend: Backend,
    /// GPU backend options.
    pub gpu: crate::gpu::render::GpuOptions,
    /// Show a progress display on stderr (only drawn when stderr is a terminal).
    pub progress: bool,
    /// Robustness techniques, on every backend (the GL render uses these, not
    /// `gpu.techniques`).
    pub techniques: crate::technique::Techniques,
}

impl RenderOptions {
    /// The scene's own size and depth, one sample, f64, the auto grid, the CPU backend.
    pub fn for_scene(scene: &Scene) -> Self {
        RenderOptions {
            width: scene.width,
            height: scene.height,
            spp: 1,
            max_depth: scene.max_depth,
            precision: Precision::F64,
            grid: GridConfig::default(),
            backend: Backend::Cpu,
            gpu: crate::gpu::render::GpuOptions::default(),
            progress: false,
            techniques: crate::technique::Techniques::default(),
        }
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
        let bytes = self.width as u64 * self.height as u64 * HOST_BYTES_PER_PIXEL;
        if bytes > MAX_HOST_BYTES {
            return Err(Error::Limit(format!(
                "a {}x{} image needs about {:.1} GiB of host memory, more than the {} GiB limit",
                self.width,
                self.height,
                bytes as f64 / (1u64 << 30) as f64,
                MAX_HOST_BYTES >> 30
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
        Ok(())
    }
}

/// Statistics of one render (written by `--stats FILE.json`).
#[derive(Clone, Debug, Serialize)]
pub struct RenderStats {
    /// "cpu" or "gl".
    pub backend: String,
    /// CPU precision or GPU device name.
    pub device: String,
    /// "f32" or "f64" arithmetic.
    pub precision: String,
    /// Scene source.
    pub scene: String,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Maximum depth used.
    pub max_depth: u32,
    /// Triangle count.
    pub triangles: usize,
    /// Grid cells per axis.
    pub grid: [u32; 3],
    /// Grid statistics.
    pub grid_stats: crate::accel::GridStats,
    /// Robustness techniques that differ from the default (`default` when none).
    pub techniques: String,
    /// Grid build time.
    pub grid_build_ms: f64,
    /// Render time (excluding grid build).
    pub render_ms: f64,
    /// Rays by kind.
    pub rays: RayCounts,
    /// Grid cells visited by all rays (CPU only: the GPU counts per primary ray, see the
    /// `steps` AOV).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cells_visited: Option<u64>,
    /// Ray-triangle tests by all rays (CPU only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub triangle_tests: Option<u64>,
    /// Million rays per second over `render_ms`.
    pub mrays_per_s: f64,
    /// Backend-specific extras (GPU pass counts and timings).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gpu: Option<GpuStats>,
}

/// A finished render.
pub struct Rendered {
    /// Linear RGB image.
    pub image: Image,
    /// Primary-ray AOVs.
    pub aov: Aov,
    /// Statistics.
    pub stats: RenderStats,
}

/// Builds the grid and renders `scene` on the CPU.
pub fn render_cpu(scene: &Scene, opts: &RenderOptions) -> Result<Rendered> {
    opts.validate()?;
    let grid = Grid::build(scene, &opts.grid)?;
    let progress = crate::progress::Progress::bar(opts.progress, opts.height as u64, "rows");
    let t0 = Instant::now();
    let out = match opts.precision {
        Precision::F64 => CpuRenderer::<f64>::new(scene, &grid, opts.max_depth, opts.techniques)
            .render_with_progress(opts.width, opts.height, opts.spp, &progress),
        Precision::F32 => CpuRenderer::<f32>::new(scene, &grid, opts.max_depth, opts.techniques)
            .render_with_progress(opts.width, opts.height, opts.spp, &progress),
    };
    let render_ms = t0.elapsed().as_secs_f64() * 1e3;
    let precision = match opts.precision {
        Precision::F32 => "f32",
        Precision::F64 => "f64",
    };
    let stats = RenderStats {
        backend: "cpu".into(),
        device: format!("cpu ({} threads)", rayon::current_num_threads()),
        precision: precision.into(),
        scene: scene.source.clone(),
        width: opts.width,
        height: opts.height,
        spp: opts.spp,
        max_depth: opts.max_depth,
        triangles: scene.triangles.len(),
        grid: grid.res,
        grid_build_ms: grid.stats.build_ms,
        grid_stats: grid.stats.clone(),
        techniques: opts.techniques.tag(),
        render_ms,
        rays: out.rays,
        cells_visited: Some(out.cells),
        triangle_tests: Some(out.tests),
        mrays_per_s: out.rays.total as f64 / (render_ms * 1e3).max(1e-9),
        gpu: None,
    };
    Ok(Rendered {
        image: out.image,
        aov: out.aov,
        stats,
    })
}

/// Builds the grid and renders `scene` with the GLSL 1.20 multi-pass backend in `ctx`.
pub fn render_gl_with(ctx: &GlContext, scene: &Scene, opts: &RenderOptions) -> Result<Rendered> {
    opts.validate()?;
    // The image must fit the driver's textures and viewport before any work is done.
    ctx.info.check_image_size(opts.width, opts.height)?;
    let grid = Grid::build(scene, &opts.grid)?;
    let t0 = Instant::now();
    let req = crate::gpu::render::ImageRequest {
        width: opts.width,
        height: opts.height,
        spp: opts.spp,
        max_depth: opts.max_depth,
        techniques: opts.techniques,
        progress: opts.progress,
        gpu: opts.gpu,
    };
    let out = crate::gpu::render::render_gl(ctx, scene, &grid, &req)?;
    let render_ms = t0.elapsed().as_secs_f64() * 1e3;
    let stats = RenderStats {
        backend: "gl".into(),
        device: ctx.info.renderer.clone(),
        precision: "f32".into(),
        scene: scene.source.clone(),
        width: opts.width,
        height: opts.height,
        spp: opts.spp,
        max_depth: opts.max_depth,
        triangles: scene.triangles.len(),
        grid: grid.res,
        grid_build_ms: grid.stats.build_ms,
        grid_stats: grid.stats.clone(),
        techniques: opts.techniques.tag(),
        render_ms,
        rays: out.rays,
        cells_visited: None,
        triangle_tests: None,
        mrays_per_s: out.rays.total as f64 / (render_ms * 1e3).max(1e-9),
        gpu: Some(out.stats),
    };
    Ok(Rendered {
        image: out.image,
        aov: out.aov,
        stats,
    })
}

/// Renders with the backend chosen in `opts`. `Auto` uses the GPU when a suitable context
/// can be made and otherwise the CPU, saying why on stderr; `Gl` never falls back.
pub fn render(scene: &Scene, opts: &RenderOptions) -> Result<Rendered> {
    match opts.backend {
        Backend::Cpu => render_cpu(scene, opts),
        Backend::Gl => {
            let ctx = GlContext::new()?;
            render_gl_with(&ctx, scene, opts)
        }
        Backend::Auto => match GlContext::new() {
            Ok(ctx) => render_gl_with(&ctx, scene, opts),
            Err(e) => {
                eprintln!("fragtrace: notice: using the CPU backend: {e}");
                render_cpu(scene, opts)
            }
        },
    }
}
