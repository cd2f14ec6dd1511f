//! Which backend renders: the GL context `--backend` asks for (`gl`, on `--gpu N`'s
//! device), or the CPU; for `auto`, whether a GL context can be made and is worth using
//! ([`auto_declines`]: a context that fails the checks, or a software rasterizer), said in
//! one notice line with the GPU settings the CPU leaves unused. The options are then
//! settled for the backend chosen and the scene ([`RenderOptions::on_context`]). What
//! `render` (whole, parts, `--frames`), `bench` and `info` ask; re-exported by
//! [`crate::render`].

use crate::gpu::{GlContext, GlInfo};
use crate::options::{Backend, RenderOptions};
use crate::scene::Scene;
use crate::Result;

/// Why `--backend auto` takes the CPU backend rather than the GL that `info` describes,
/// or None where it takes GL: a GL that fails the checks cannot render, and a software
/// rasterizer (llvmpipe, softpipe, swrast) runs the GL kernels on the CPU, where the CPU
/// backend is faster (1.5-2.5x on the shipped scenes, docs/performance.md). The one place
/// the choice is made: `render` (whole, parts, `--frames`), `bench` and `info` ask it.
pub fn auto_declines(info: &GlInfo) -> Option<String> {
    if let Err(why) = info.verdict() {
        return Some(why);
    }
    info.is_software().then(|| {
        format!(
            "{} is a software rasterizer (GL run on the CPU, slower than the CPU backend); \
             --backend gl renders with it anyway",
            info.renderer
        )
    })
}

/// Why `--backend auto` takes the CPU where the only EGL device is Mesa's software one
/// ([`crate::gpu::egl::software_only`]), in the words of [`auto_declines`].
pub const SOFTWARE_DEVICE: &str = "the only EGL device is Mesa's software rasterizer \
     (EGL_MESA_device_software: GL run on the CPU, slower than the CPU backend); \
     --backend gl renders with it anyway";

/// The GL context the backend choice of `opts` renders in: None for the CPU. `Auto` uses
/// the GPU when a suitable context can be made (on `--gpu N`'s device) and is not a
/// software rasterizer ([`auto_declines`]), and otherwise the CPU, saying why in one line
/// on stderr when `notices` (off with `-q`), with the GPU settings it leaves unused; `Gl` never falls back, and neither does a
/// bad `--gpu N`. Returned with the options for that backend and `scene`
/// ([`RenderOptions::on_context`]: `--accel auto` settled, and a scene with instances on
/// the GPU's two levels where the context runs them), which whoever prepares the render
/// then uses.
pub fn context_for(
    opts: &RenderOptions,
    scene: &Scene,
    notices: bool,
) -> Result<(Option<GlContext>, RenderOptions)> {
    let ctx = choose_context(opts, notices)?;
    let opts = opts.on_context(scene, ctx.as_ref().map(|c| &c.info));
    Ok((ctx, opts))
}

/// What the backend choice of `opts` comes to before any driver starts.
pub(crate) enum Start {
    /// The CPU: named, or `auto` where no context is worth opening (why, for the notice).
    Cpu(Option<String>),
    /// A context to open ([`open_context`]): `gl`, or `auto` on a device that is not Mesa's
    /// software one.
    Open,
}

/// [`Start`] of `opts`: the part of the choice that needs no driver.
pub(crate) fn start_of(opts: &RenderOptions) -> Start {
    match opts.backend {
        Backend::Cpu => Start::Cpu(None),
        Backend::Gl => Start::Open,
        Backend::Auto if !opts.accel_kind().on_gpu() => Start::Cpu(Some(format!(
            "--accel {} is walked on the CPU only",
            opts.accel_kind().name()
        ))),
        // Only Mesa's software device to open: the answer `auto_declines` would give for
        // its context, without starting a driver to hear it.
        Backend::Auto if crate::gpu::egl::software_only(opts.device) => {
            Start::Cpu(Some(SOFTWARE_DEVICE.to_string()))
        }
        Backend::Auto => Start::Open,
    }
}

/// [`context_for`]'s context alone.
fn choose_context(opts: &RenderOptions, notices: bool) -> Result<Option<GlContext>> {
    match start_of(opts) {
        Start::Cpu(why) => {
            if let Some(why) = why.filter(|_| notices) {
                cpu_notice(opts, &why);
            }
            Ok(None)
        }
        Start::Open => open_context(opts, notices),
    }
}

/// The context of a [`Start::Open`] choice: `gl`'s, which never falls back, or `auto`'s,
/// None (the CPU, with the notice) where the context fails to open or
/// [`auto_declines`] it. A bad `--gpu N` is the user's to fix, not a reason to fall back.
pub(crate) fn open_context(opts: &RenderOptions, notices: bool) -> Result<Option<GlContext>> {
    if opts.backend == Backend::Gl {
        return GlContext::on_device(opts.device).map(Some);
    }
    let why = match GlContext::on_device(opts.device) {
        Ok(ctx) => match auto_declines(&ctx.info) {
            None => return Ok(Some(ctx)),
            Some(why) => why,
        },
        Err(e @ crate::Error::Usage(_)) => return Err(e),
        Err(e) => e.to_string(),
    };
    if notices {
        cpu_notice(opts, &why);
    }
    Ok(None)
}

/// `auto`'s one line on taking the CPU.
fn cpu_notice(opts: &RenderOptions, why: &str) {
    eprintln!(
        "fragtrace: notice: using the CPU backend: {why}{}",
        unused_on_the_cpu(opts)
    );
}

/// The GPU settings `opts` name that `--backend auto` leaves unused by taking the CPU, as
/// the end of its notice (`; --kernel compute does not apply on the CPU`), or nothing:
/// under `auto` they are accepted (either backend may run), so the notice says where they
/// were overridden instead of a refusal.
fn unused_on_the_cpu(opts: &RenderOptions) -> String {
    use crate::gpu::options::{GpuOptions, Kernel, Mask, SceneFetch, Storage};
    let (g, d) = (&opts.gpu, GpuOptions::default());
    let mut named = Vec::new();
    if g.kernel != Kernel::Auto {
        named.push(format!("--kernel {}", g.kernel));
    }
    if g.mask != Mask::Auto {
        named.push(format!("--mask {}", g.mask));
    }
    if g.storage != Storage::F32 {
        named.push(format!("--storage {}", g.storage));
    }
    if g.scene_fetch != SceneFetch::Auto {
        named.push(format!("--scene-fetch {}", g.scene_fetch));
    }
    if g.query_every != d.query_every {
        named.push(format!("--query-every {}", g.query_every));
    }
    if g.no_specialize {
        named.push("--no-specialize".into());
    }
    match named.len() {
        0 => String::new(),
        1 => format!("; {} does not apply on the CPU", named[0]),
        _ => format!("; {} do not apply on the CPU", named.join(", ")),
    }
}
