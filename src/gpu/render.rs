//! The GPU backend's one entry: a render or a wave of rays goes to the wing its resolved
//! kernel names ([`KernelChoice`]), in one place (`wing`), with the one fallback there is (`auto`
//! chose compute and the driver cut its loops short: the fragment kernels finish the work).
//!
//! [`render`] and [`trace_rays_on`] take a [`GpuScene`], uploaded once and rendered from as
//! often as asked; [`render_gl`] and [`trace_rays`] build one for a single call.

#[cfg(not(target_arch = "wasm32"))]
use super::compute;
use super::context::GlContext;
use super::fragment;
use super::layout::LayoutTarget;
use super::options::{FragmentKernel, GpuOptions, KernelChoice};
use super::pause::Stepped;
use super::scene::GpuScene;
use super::shader::Query;
use super::wave::wave_size;
use crate::accel::AccelRef;
#[cfg(not(target_arch = "wasm32"))]
use crate::region::Region;
use crate::scene::Scene;
use crate::{Error, Result};

pub use super::request::{Advance, Flow, GpuOutput, ImageRequest, Observer, Snapshot, Work};
pub use super::wave::{GpuRay, GpuTrace};

/// What the kernel's wing leaves to do: the compute kernel's result, or the fragment
/// kernel that renders (the one resolved, or `auto`'s fallback).
enum Wing<T> {
    /// The compute kernel ran to the end.
    Done(T),
    /// A fragment kernel renders.
    Fragment(FragmentKernel),
}

/// The one switch from the kernel `gpu` resolves to in the context `info` describes
/// ([`GpuOptions::choose_kernel`]) to the wing that runs it: `compute` runs the compute
/// kernel, and where `auto` chose it and the driver cut its loops short, the fragment
/// kernel `auto` falls back to takes over, with a notice on stderr.
fn wing<T>(
    gpu: &GpuOptions,
    info: &super::info::GlInfo,
    compute: impl FnOnce() -> Result<T>,
) -> Result<Wing<T>> {
    match gpu.choose_kernel(info)? {
        KernelChoice::Fragment(k) => Ok(Wing::Fragment(k)),
        KernelChoice::Compute { fallback } => match compute() {
            Err(Error::Unfinished(why)) if fallback.is_some() => {
                let k = fallback.expect("checked");
                eprintln!(
                    "fragtrace: notice: the compute kernel did not finish ({why}); \
                     rendering with the {k} kernel"
                );
                Ok(Wing::Fragment(k))
            }
            r => r.map(Wing::Done),
        },
    }
}

/// Renders `req` from the scene on the GPU; `observer`, if any, is called between passes
/// and may cancel the render ([`Error::Cancelled`]).
pub fn render<'a>(
    gs: &'a GpuScene<'a>,
    req: &ImageRequest,
    observer: Option<&'a mut Observer<'a>>,
) -> Result<GpuOutput> {
    // Only the compute wing, absent from the wasm32 build, borrows it before the fragment one.
    #[cfg_attr(target_arch = "wasm32", allow(unused_mut))]
    let mut observer = observer;
    #[cfg(not(target_arch = "wasm32"))]
    let compute = || compute::render(gs, req, observer.as_deref_mut());
    #[cfg(target_arch = "wasm32")]
    let compute = || Err(no_compute());
    if let Some(k) = cold_start(gs, req)? {
        // A watched render (the viewer) shows one kernel's passes: its frame stays whole.
        let out = match observer {
            None => handover(gs, req, k)?,
            watched => fragment::render(gs, req, k, watched)?,
        };
        return after_cold_start(gs, out);
    }
    match wing(&req.gpu, &gs.ctx().info, compute)? {
        Wing::Done(out) => Ok(out),
        Wing::Fragment(k) => fragment::render(gs, req, k, observer),
    }
}

/// `--kernel auto`'s cold start (issue 52): where `auto` chose the compute kernel and its
/// programs are neither kept nor in the program-binary cache, their compile is handed to
/// the driver (`compute::programs_ready`) and, while a driver with
/// `GL_KHR_parallel_shader_compile` works on it on threads of its own, the fallback
/// fragment kernel renders this frame band by band until the compute kernel is linked,
/// which renders the rest ([`handover`]); compute takes the frames after the compile. On
/// the H200 that is the sooner end either way (cold: the looped kernel's compile 0.37 s
/// against compute's 1.8-2.6 s; docs/performance.md); a driver that compiles within the
/// call (llvmpipe, or no extension) is done when asked, and runs compute as before. The images are the same bytes (tests/compute_kernel.rs), so only
/// `GpuStats::kernel` and `cold_start` tell.
#[cfg(not(target_arch = "wasm32"))]
fn cold_start(gs: &GpuScene, req: &ImageRequest) -> Result<Option<FragmentKernel>> {
    Ok(match req.gpu.choose_kernel(&gs.ctx().info)? {
        KernelChoice::Compute { fallback: Some(k) } if !compute::programs_ready(gs, req)? => {
            // The fallback reads the float layout. Where that does not fit (an irregular
            // grid past the texture size, which compute's dense layout holds) the frame
            // waits for compute instead of failing; the float layout packed here is the
            // one the fallback would pack first anyway.
            match gs.layout(LayoutTarget::Float) {
                Ok(_) => Some(k),
                Err(Error::Limit(_)) => None,
                Err(e) => return Err(e),
            }
        }
        _ => None,
    })
}

/// Pixels of the fallback's first band on a cold start: small enough that the compute
/// kernel, once linked, takes over within a fraction of a large frame, large enough that a
/// band's own set-up stays a small share (1024 rows of 64 pixels, 64 of 1024, 16 of 4096).
#[cfg(not(target_arch = "wasm32"))]
const FIRST_BAND_PIXELS: u64 = 1 << 16;

/// How long each later band should take: the compute kernel takes over at most about this
/// late after its compile finishes.
#[cfg(not(target_arch = "wasm32"))]
const BAND_TARGET: std::time::Duration = std::time::Duration::from_millis(60);

/// A cold start's frame: the fallback fragment kernel `k` renders full-width bands of rows
/// from the top while the driver compiles the compute programs, asking before each band
/// whether they are linked; once they are, the compute kernel renders the rest of the
/// frame in one go. The parts are the same bytes as a whole render by either kernel (a
/// region renders exactly its pixels of the whole image: `crate::region`; the two kernels
/// agree to the bit: `tests/compute_kernel.rs`), so the frame is too; only the stats say
/// where the compute kernel took over ([`crate::output::GpuStats::handover_row`]). A large
/// frame thus costs about the compile plus the compute kernel's time, never the fallback's
/// time for the whole frame (the built-in scene at 4096² on the H100: 10.4 s of looped
/// kernel against 64 ms of compute). Bands after the first are sized from the last one's
/// time to take [`BAND_TARGET`].
#[cfg(not(target_arch = "wasm32"))]
fn handover(gs: &GpuScene, req: &ImageRequest, k: FragmentKernel) -> Result<GpuOutput> {
    let all = req.pixels();
    let mut rows =
        (FIRST_BAND_PIXELS / all.width().max(1) as u64).clamp(1, all.height() as u64) as u32;
    let mut parts = Vec::new();
    let mut handover_row = None;
    let mut y = all.y0;
    while y < all.y1 {
        let rest = Region { y0: y, ..all };
        if !parts.is_empty() && compute::programs_ready(gs, req)? {
            let part = ImageRequest {
                region: Some(rest),
                ..*req
            };
            let compute = || compute::render(gs, &part, None);
            parts.push(match wing(&req.gpu, &gs.ctx().info, compute)? {
                Wing::Done(out) => out,
                Wing::Fragment(k) => fragment::render(gs, &part, k, None)?,
            });
            handover_row = Some(y);
            break;
        }
        let band = Region {
            y1: (y + rows).min(all.y1),
            ..rest
        };
        let t0 = std::time::Instant::now();
        let part = ImageRequest {
            region: Some(band),
            ..*req
        };
        parts.push(fragment::render(gs, &part, k, None)?);
        let took = t0.elapsed().as_secs_f64().max(1e-4);
        let scale = (BAND_TARGET.as_secs_f64() / took).clamp(0.25, 4.0);
        rows = ((rows as f64 * scale) as u32).max(1);
        y = band.y1;
    }
    let mut out = crate::output::BackendOutput::stack_rows(parts);
    if let Some(g) = out.gpu.as_mut() {
        g.handover_row = handover_row;
    }
    Ok(out)
}

/// The web build has no compute kernel, so no cold start and no hand-over.
#[cfg(target_arch = "wasm32")]
fn handover(gs: &GpuScene, req: &ImageRequest, k: FragmentKernel) -> Result<GpuOutput> {
    fragment::render(gs, req, k, None)
}

/// The web build has no compute kernel, so no cold start.
#[cfg(target_arch = "wasm32")]
fn cold_start(_: &GpuScene, _: &ImageRequest) -> Result<Option<FragmentKernel>> {
    Ok(None)
}

/// A frame the fragment fallback rendered on a cold start, marked so; the compute programs
/// that finished compiling meanwhile are kept and stored for the next frame or run.
#[cfg_attr(target_arch = "wasm32", allow(dead_code))]
fn after_cold_start(gs: &GpuScene, mut out: GpuOutput) -> Result<GpuOutput> {
    gs.settle_compiles()?;
    if let Some(g) = out.gpu.as_mut() {
        g.cold_start = true;
    }
    Ok(out)
}

/// [`render`] one stretch at a time: the render runs on each [`Stepped::resume`] until
/// `observer` answers [`Flow::Pause`] after a pass, and its result comes from the last
/// resume. The same walk and passes as [`render`] (which runs the pauses through); the
/// fragment kernels only: the compute kernel (native) runs in one go on the first resume.
///
/// `gs` is the scene or anything that holds it (an `Rc`: the page keeps the render beside
/// the scene it renders).
pub fn render_stepped<'a>(
    gs: impl std::ops::Deref<Target = GpuScene<'a>> + 'a,
    req: ImageRequest,
    mut observer: Box<Observer<'a>>,
) -> Stepped<'a, Result<GpuOutput>> {
    Stepped::new(async move {
        let gs: &GpuScene = &gs;
        #[cfg(not(target_arch = "wasm32"))]
        let compute = || compute::render(gs, &req, Some(&mut *observer));
        #[cfg(target_arch = "wasm32")]
        let compute = || Err(no_compute());
        if let Some(k) = cold_start(gs, &req)? {
            let out = fragment::walk(gs, req, k, Some(&mut *observer)).await?;
            return after_cold_start(gs, out);
        }
        let kernel = match wing(&req.gpu, &gs.ctx().info, compute)? {
            Wing::Done(out) => return Ok(out),
            Wing::Fragment(k) => k,
        };
        fragment::walk(gs, req, kernel, Some(&mut *observer)).await
    })
}

/// The compute wing is not in the wasm32 build: WebGL has no compute shaders, and
/// `GlInfo::compute` is false there, so only an explicit `compute` kernel gets here.
#[cfg(target_arch = "wasm32")]
fn no_compute() -> Error {
    Error::GlUnavailable("the compute kernel needs OpenGL 4.3; WebGL has no compute shaders".into())
}

/// Renders `scene` over `accel` on the GPU in `ctx`: [`render`] of a scene uploaded for
/// this one call.
pub fn render_gl<'a>(
    ctx: &GlContext,
    scene: &Scene,
    accel: impl Into<AccelRef<'a>>,
    req: &ImageRequest,
) -> Result<GpuOutput> {
    let accel: AccelRef<'a> = accel.into();
    let gs = GpuScene::new(ctx, scene, accel, req.gpu.no_specialize)?
        .with_program_cache(req.gpu.shader_cache.open(&ctx.info));
    render(&gs, req, None)
}

/// Traces arbitrary rays through the same traversal and intersection code a render uses:
/// how tests put single hand-made rays through the GPU kernels.
pub fn trace_rays_on(
    gs: &GpuScene,
    rays: &[GpuRay],
    query: Query,
    opts: GpuOptions,
) -> Result<Vec<GpuTrace>> {
    if rays.is_empty() {
        return Ok(Vec::new());
    }
    #[cfg(not(target_arch = "wasm32"))]
    let compute = || compute::trace_wave(gs, rays, query, wave_size(rays.len() as u32), &opts);
    #[cfg(target_arch = "wasm32")]
    let compute = || Err(no_compute());
    let kernel = match wing(&opts, &gs.ctx().info, compute)? {
        Wing::Done(traces) => return Ok(traces),
        Wing::Fragment(k) => k,
    };
    fragment::trace_wave(gs, rays, query, kernel, &opts)
}

/// [`trace_rays_on`] a scene uploaded for this one call.
pub fn trace_rays<'a>(
    ctx: &GlContext,
    scene: &Scene,
    accel: impl Into<AccelRef<'a>>,
    rays: &[GpuRay],
    query: Query,
    opts: GpuOptions,
) -> Result<Vec<GpuTrace>> {
    let accel: AccelRef<'a> = accel.into();
    let gs = GpuScene::new(ctx, scene, accel, opts.no_specialize)?
        .with_program_cache(opts.shader_cache.open(&ctx.info));
    trace_rays_on(&gs, rays, query, opts)
}
