//! Backend-independent rendering front door: dispatch to the CPU reference renderer or the
//! GPU backend, and the statistics of a render. The options live in [`crate::options`]
//! (one layer down, so the CLI and the bench share them).

use std::time::Instant;

use serde::Serialize;

use crate::accel::{Accel, AccelSummary};
use crate::cpu::CpuRenderer;
use crate::gpu::GlContext;
use crate::image_io::Image;
use crate::output::{Aov, GpuStats, RayCounts};
use crate::scene::Scene;
use crate::Result;

use crate::options::{Backend, Precision, RenderOptions};

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
    /// Cells per axis of the structure (the irregular grid's virtual resolution).
    pub grid: [u32; 3],
    /// The acceleration structure: kind, size, memory, build time.
    pub accel: AccelSummary,
    /// Robustness techniques that differ from the default (`default` when none).
    pub techniques: String,
    /// Acceleration-structure build time.
    pub grid_build_ms: f64,
    /// Render time (excluding grid build).
    pub render_ms: f64,
    /// Rays by kind.
    pub rays: RayCounts,
    /// Grid cells visited by all rays (CPU and the compute kernel: the fragment kernels count
    /// per primary ray, see the `steps` AOV).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cells_visited: Option<u64>,
    /// Ray-triangle tests by all rays (CPU and the compute kernel).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub triangle_tests: Option<u64>,
    /// Cells visited plus triangle tests per primary ray (first sample), from the `steps`
    /// AOV: what the GPU reports of its traversal work, and the CPU alike for comparison.
    pub primary_steps_per_ray: f64,
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

/// Builds the acceleration structure and renders `scene` on the CPU.
pub fn render_cpu(scene: &Scene, opts: &RenderOptions) -> Result<Rendered> {
    opts.validate()?;
    let accel = Accel::build(scene, opts.accel, &opts.grid, &opts.irregular)?;
    let summary = accel.as_ref().summary(scene.triangles.len());
    let progress = crate::progress::Progress::bar(opts.progress, opts.height as u64, "rows");
    let t0 = Instant::now();
    let out = match opts.precision {
        Precision::F64 => CpuRenderer::<f64>::new(scene, &accel, opts.max_depth, opts.techniques)
            .render_with_progress(opts.width, opts.height, opts.spp, &progress),
        Precision::F32 => CpuRenderer::<f32>::new(scene, &accel, opts.max_depth, opts.techniques)
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
        grid: summary.resolution,
        grid_build_ms: summary.build_ms,
        accel: summary,
        techniques: opts.techniques.tag(),
        render_ms,
        rays: out.rays,
        cells_visited: Some(out.cells),
        triangle_tests: Some(out.tests),
        primary_steps_per_ray: out.aov.mean_steps(),
        mrays_per_s: out.rays.total as f64 / (render_ms * 1e3).max(1e-9),
        gpu: None,
    };
    Ok(Rendered {
        image: out.image,
        aov: out.aov,
        stats,
    })
}

/// Builds the acceleration structure and renders `scene` with the GLSL 1.20 multi-pass backend in `ctx`.
pub fn render_gl_with(ctx: &GlContext, scene: &Scene, opts: &RenderOptions) -> Result<Rendered> {
    opts.validate()?;
    // The image must fit the driver's textures and viewport before any work is done.
    ctx.info.check_image_size(opts.width, opts.height)?;
    let accel = Accel::build(scene, opts.accel, &opts.grid, &opts.irregular)?;
    let summary = accel.as_ref().summary(scene.triangles.len());
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
    let out = crate::gpu::render::render_gl(ctx, scene, &accel, &req)?;
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
        grid: summary.resolution,
        grid_build_ms: summary.build_ms,
        accel: summary,
        techniques: opts.techniques.tag(),
        render_ms,
        rays: out.rays,
        cells_visited: out.work.map(|w| w.cells),
        triangle_tests: out.work.map(|w| w.tests),
        primary_steps_per_ray: out.aov.mean_steps(),
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
