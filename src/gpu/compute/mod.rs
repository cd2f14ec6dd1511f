//! `--kernel compute`: the host side of `glsl120/render.comp` (the whole ray tree of every
//! pixel and sample in one dispatch) and `glsl120/wave.comp` (a wave of given rays, for
//! `trace_rays`).
//!
//! No ray state crosses the host: the program computes the primary directions itself (the
//! camera's f64 formula, from the host's tables of each column's and row's terms), walks the tree
//! with a per-invocation stack and writes the summed radiance and the first sample's
//! primary-ray AOV texel to two buffers. Counts come back as one record per work group
//! (rays by kind, cells entered, triangle tests, rays cut off), summed here in u64. Every
//! buffer, image and uniform is the contract's (`gpu::contract`).
//!
//! This wing stands on the GPU scene (`gpu::scene`) alone; it never imports the fragment
//! wing.

mod bands;

use std::rc::Rc;
use std::time::{Duration, Instant};

use rayon::prelude::*;

use self::bands::{BandPlan, Limits, Outputs, Shape, BAND_TIME};
use super::context::GlContext;
use super::contract::compute::{aov, camera_buffer, sum_words, Counter};
use super::contract::{uniform, Buffer, Image, StateTexels, STORAGE_BINDING_BASE};
use super::gl::{bind_image, dispatch, Program, ReadbackRing, StorageBuffer, Texture, TimerQuery};
use super::info::GlInfo;
use super::layout::LayoutTarget;
use super::options::{GpuOptions, SceneFetch, Storage};
use super::request::{aov_pixel, aov_pixel_id, Flow, GpuOutput, ImageRequest, Observer, Snapshot};
use super::scene::{ms_since, GpuScene};
use super::shader::{ComputePass, ComputeSpec, Fetch, Query, LOCAL_SIZE};
use super::wave::{check_finished, initial_state, traces_from, GpuRay, GpuTrace};
use crate::image_io::Image as RgbImage;
use crate::output::Work;
use crate::output::{Aov, AovPixel, GpuStats, RayCounts};
use crate::progress::Progress;
use crate::scene::camera;
use crate::technique::Techniques;
use crate::{Error, Result};

/// One compute program of the scene, with the scene's copy it reads bound for dispatch.
struct Setup<'g> {
    gs: &'g GpuScene<'g>,
    program: Rc<Program>,
    /// How the program reads the scene.
    fetch: Fetch,
    stats: GpuStats,
}

impl<'g> Setup<'g> {
    fn new(
        gs: &'g GpuScene<'g>,
        pass: ComputePass,
        spec: &ComputeSpec,
        opts: &GpuOptions,
        techniques: Techniques,
    ) -> Result<Self> {
        let ctx = gs.ctx();
        let info = &ctx.info;
        if opts.storage != Storage::F32 {
            return Err(Error::Limit(format!(
                "--storage {} applies to the fragment kernels' ray textures; the compute \
                 kernel keeps its rays in registers",
                opts.storage
            )));
        }
        let mut stats = GpuStats {
            renderer: info.renderer.clone(),
            gl_version: info.gl_version.clone(),
            query_every: opts.query_every,
            features: gs.features(),
            kernel: "compute".into(),
            ..GpuStats::default()
        };
        // Storage buffers only where the context has blocks for every scene texture beside
        // the kernel's own: `auto` then falls back to texelFetch, an explicit request fails.
        // Settled here, not in `Plan::resolve`: the blocks needed are the packed scene's
        // (`layout().storage_blocks()`), known only once `GpuScene` has packed it, which
        // comes after the plan so that a refused kernel costs no packing.
        let layout = gs.layout(LayoutTarget::Compute)?;
        stats.grid_layout = layout.grid_name().into();
        let (blocks, needed) = (
            Limits::query(ctx.gl()).blocks,
            layout.storage_blocks() + STORAGE_BINDING_BASE,
        );
        let fetch = settle_fetch(spec.fetch, blocks, needed, opts)?;
        stats.scene_fetch = fetch.name().into();
        gs.upload_compute(fetch)?;
        if gs.instanced() && pass != ComputePass::Render {
            return Err(Error::Internal(format!(
                "{} walks scenes stored flat; an instanced scene renders through render.comp",
                pass.name()
            )));
        }
        let program = gs.compute_program(pass, &ComputeSpec { fetch, ..*spec }, techniques)?;
        let costs = gs.take_costs();
        stats.upload_ms = costs.upload_ms;
        stats.upload_bytes = costs.upload_bytes;
        costs.charge_programs(&mut stats);
        Ok(Setup {
            gs,
            program,
            fetch,
            stats,
        })
    }

    /// Dispatches the program over a `width` x `height` grid of invocations, timed when
    /// timers are on, and waits for its writes.
    fn dispatch(&mut self, width: u32, height: u32, timers: bool) -> Result<()> {
        let ctx = self.gs.ctx();
        let gl = ctx.gl();
        self.gs.bind_compute(self.fetch)?;
        let timer = (timers && ctx.info.timer_query)
            .then(|| TimerQuery::new(ctx))
            .transpose()?;
        if let Some(t) = &timer {
            t.begin(ctx);
        }
        // The program's textures, images and buffers are bound.
        dispatch(
            gl,
            &self.program,
            [
                width.div_ceil(LOCAL_SIZE.0),
                height.div_ceil(LOCAL_SIZE.1),
                1,
            ],
        );
        if let Some(t) = timer {
            t.end(ctx);
            let ns = t.result_ns(ctx)?;
            self.stats.add_gpu_time("compute", ns);
        }
        super::gl::check_gl_error(gl, "dispatching the compute kernel")?;
        *self.stats.passes.entry("compute".into()).or_default() += 1;
        self.stats.passes_total += 1;
        Ok(())
    }
}

/// How the render kernel reads the scene: as asked, or under `auto` the faster of the two
/// where measured: storage buffers on the H200, texelFetch on llvmpipe, whose storage loads
/// run lane by lane with a bounds check each (docs/performance.md, "llvmpipe (here)"; the
/// H200 runs: `git show b97da3f:docs/performance.md`). Other
/// drivers get storage buffers unmeasured; `--scene-fetch` and `fragtrace bench` are there
/// to measure them.
fn scene_fetch(choice: SceneFetch, info: &GlInfo) -> Fetch {
    match choice {
        SceneFetch::TexelFetch => Fetch::TexelFetch,
        SceneFetch::StorageBuffer => Fetch::Storage,
        SceneFetch::Auto if info.renderer.starts_with("llvmpipe") => Fetch::TexelFetch,
        SceneFetch::Auto => Fetch::Storage,
    }
}

/// The fetch a program asking for `fetch` gets where the context has `blocks` storage
/// blocks and the scene needs `needed`: storage buffers only where every scene texture
/// has its block beside the kernel's own; else `auto` falls back to texelFetch and an
/// explicit `--scene-fetch storage-buffer` fails.
fn settle_fetch(fetch: Fetch, blocks: u32, needed: u32, opts: &GpuOptions) -> Result<Fetch> {
    Ok(match fetch {
        Fetch::Storage if blocks < needed => {
            if opts.scene_fetch == SceneFetch::StorageBuffer {
                return Err(Error::Limit(format!(
                    "--scene-fetch storage-buffer needs {needed} storage blocks in a \
                     compute shader; this context has {blocks}"
                )));
            }
            Fetch::TexelFetch
        }
        f => f,
    })
}

/// The render program's specialisation for `req` (the scene fetch as asked, settled by
/// [`settle_fetch`] when the program is set up).
fn render_spec(gs: &GpuScene, req: &ImageRequest) -> ComputeSpec {
    ComputeSpec {
        samples: camera::sample_offsets(req.spp).len() as u32,
        lights: gs.scene().lights.len() as u32,
        max_depth: req.max_depth,
        secondary: gs.has_secondary(),
        max_iterations: gs.max_iterations().min(i32::MAX as u64) as u32,
        fetch: scene_fetch(req.gpu.scene_fetch, &gs.ctx().info),
        aov: req.readback.aov,
        instanced: gs.instanced(),
    }
}

/// Whether every compute program `req` needs (the render kernel, and the 8-bit conversion
/// for `readback.srgb8`) is ready to run without waiting for a compile: kept by the scene,
/// linked from the program-binary cache, or compiled by the driver on its own threads
/// since it was started. A program that is not is started now (where it was not yet), and
/// the caller renders with a fragment kernel meanwhile (`--kernel auto`'s cold start,
/// issue 52; `gpu::render`).
pub(crate) fn programs_ready(gs: &GpuScene, req: &ImageRequest) -> Result<bool> {
    let spec = render_spec(gs, req);
    let needed = gs.layout(LayoutTarget::Compute)?.storage_blocks() + STORAGE_BINDING_BASE;
    let blocks = Limits::query(gs.ctx().gl()).blocks;
    let spec = ComputeSpec {
        fetch: settle_fetch(spec.fetch, blocks, needed, &req.gpu)?,
        ..spec
    };
    let render = gs.compute_program_ready(ComputePass::Render, &spec, req.techniques)?;
    // Both are polled (and started) whatever the first answers: they compile side by side.
    let convert = !req.readback.srgb8
        || gs.compute_program_ready(ComputePass::Srgb8, &ComputeSpec::CONVERT, req.techniques)?;
    Ok(render && convert)
}

/// How long each band should take: [`BAND_TIME`] when `progress` is drawn (a test may ask
/// for timed bands without a terminal), else None (the largest bands).
fn band_time(progress: &Progress) -> Option<Duration> {
    #[cfg(test)]
    if let Some(t) = tests::BAND_TIME_HOOK.get() {
        return Some(t);
    }
    progress.is_shown().then_some(BAND_TIME)
}

/// Renders with the compute kernel (see the module documentation).
///
/// Per band of rows: the render dispatch, with `readback.srgb8` the conversion to 8-bit
/// sRGB on the GPU, then a GPU copy of the band's output into a persistently mapped
/// staging slot, fenced; the host takes a band's bytes while the next band is traced.
/// Counters are summed on the GPU and read once. AOV texels are written and read only
/// with `readback.aov`.
pub(crate) fn render(
    gs: &GpuScene,
    req: &ImageRequest,
    observer: Option<&mut Observer<'_>>,
) -> Result<GpuOutput> {
    // The pixels rendered (a region of the image, or all of it); the primary rays are
    // the whole image's (the camera buffer carries its size and the region's corner).
    let px = req.pixels();
    let (width, height) = (px.width(), px.height());
    let ctx = gs.ctx();
    ctx.info.check_image_size(width, height)?;
    let gl = ctx.gl();
    let limits = Limits::query(gl);
    let offsets = camera::sample_offsets(req.spp);
    let readback = req.readback;
    // Setup::new falls back to texelFetch where the context has too few storage blocks.
    let spec = render_spec(gs, req);
    let mut setup = Setup::new(gs, ComputePass::Render, &spec, &req.gpu, req.techniques)?;
    // The 8-bit conversion: its program (compiled once per scene) and the thresholds.
    let convert = if readback.srgb8 {
        let p = gs.compute_program(ComputePass::Srgb8, &ComputeSpec::CONVERT, req.techniques)?;
        gs.take_costs().charge_programs(&mut setup.stats);
        Some((p, gs.srgb_thresholds()?))
    } else {
        None
    };
    let t_trace = Instant::now();
    let program = &setup.program;
    program.set(gl, uniform::EYE, req.camera.eye)?;
    program.set(gl, uniform::SAMPLE_WEIGHT, 1.0 / offsets.len() as f32)?;
    if gs.textured() {
        // The primary rays' cone spread (the root of every pixel's tree).
        let spread = crate::scene::texture::pixel_spread(req.camera.vfov_deg, req.height);
        program.set(
            gl,
            uniform::ROOT_CONE,
            glam::Vec3::new(1.0, spread as f32, 0.0),
        )?;
    }
    program.set(
        gl,
        uniform::SIZE,
        glam::IVec2::new(width as i32, height as i32),
    )?;

    let cam = camera_buffer(
        &req.camera.frame(),
        (req.width, req.height),
        (px.x0, px.y0),
        (width, height),
        &offsets,
    );
    let cam_bytes: Vec<u8> = cam.iter().flat_map(|v| v.to_ne_bytes()).collect();
    let cam_buf = StorageBuffer::new(ctx, &cam_bytes)?;
    cam_buf.bind(gl, Buffer::Camera.binding());
    gs.light_buffer()?.bind(gl, Buffer::Lights.binding());

    // Bands of rows whose outputs fit one storage block (the AOV's 16 bytes per pixel are
    // the larger); with a progress bar drawn, bands sized to take about BAND_TIME each.
    let max_rows = limits.band_rows(width, height)?;
    let progress = Progress::bar(req.progress, u64::from(height), "rows");
    let plan = BandPlan::new(height, max_rows, band_time(&progress));
    let shape = Shape {
        band_px: width as usize * max_rows as usize,
        aov: readback.aov,
        srgb8: readback.srgb8,
    };
    let mut kept = gs.kept::<Outputs>();
    if kept.as_ref().is_none_or(|o| o.shape != shape) {
        // Free the old shape's buffers before allocating the new ones.
        *kept = None;
        *kept = Some(Outputs::new(ctx, shape)?);
    }
    let bufs = kept.as_mut().expect("made above");
    bufs.reset_counters(gl)?;
    bufs.counters.bind(gl, Buffer::Counters.binding());
    bufs.radiance.bind(gl, Buffer::Radiance.binding());
    if let Some(b) = &bufs.aov {
        b.bind(gl, Buffer::Aov.binding());
    }
    let pixels = width as usize * height as usize;
    // Pages an earlier frame touched (`pool`); the bands write every byte.
    let mut out = crate::pool::take(shape.out_bytes(pixels));
    let mut aov_data = if readback.aov {
        vec![0f32; pixels * 4]
    } else {
        Vec::new()
    };
    setup
        .stats
        .phases_ms
        .insert("setup".into(), ms_since(t_trace));
    // The band whose copy is in flight: (staging slot, first byte in `out`, length, rows).
    let mut in_flight: Option<(usize, usize, usize, u32)> = None;
    let take = |ring: &mut ReadbackRing,
                (slot, at, len, rows): (usize, usize, usize, u32),
                out: &mut [u8]| {
        ring.take(ctx, slot, |bytes| {
            out[at..at + len]
                .par_chunks_mut(1 << 18)
                .zip(bytes.par_chunks(1 << 18))
                .for_each(|(d, s)| d.copy_from_slice(s));
        })?;
        progress.inc(u64::from(rows));
        Ok::<_, Error>(())
    };
    // Bands from the top of the image, so each band's rows follow the last in the outputs.
    let t_bands = Instant::now();
    let (mut top, mut last) = (0, (0, Duration::ZERO));
    while top < height {
        let t_band = Instant::now();
        let n = plan.next(top, last, t_bands.elapsed());
        let gl_row0 = height - top - n;
        let band = n as usize * width as usize;
        let t = Instant::now();
        setup.program.set(
            gl,
            uniform::BAND,
            glam::IVec2::new(gl_row0 as i32, n as i32),
        )?;
        setup.dispatch(width, n, req.gpu.timers)?;
        let src = match (&convert, &bufs.srgb8) {
            (Some((p, thresholds)), Some(dst)) => {
                convert_srgb8(gl, p, thresholds, dst, band)?;
                *setup.stats.passes.entry("srgb8".into()).or_default() += 1;
                setup.stats.passes_total += 1;
                dst
            }
            _ => &bufs.radiance,
        };
        *setup.stats.phases_ms.entry("dispatch".into()).or_default() += ms_since(t);
        let t = Instant::now();
        let at = shape.out_bytes(top as usize * width as usize);
        let len = shape.out_bytes(band);
        match bufs.ring.as_mut() {
            Some(r) => {
                // A slot at a time (STAGING_SLOT_BYTES): the host takes one piece while
                // the GPU copies the next; the band's rows count once its last is queued.
                let mut done = 0;
                while done < len {
                    let piece = (len - done).min(r.slot_bytes());
                    let slot = r.copy(ctx, src, done, piece)?;
                    let rows = if done + piece == len { n } else { 0 };
                    if let Some(prev) = in_flight.replace((slot, at + done, piece, rows)) {
                        take(r, prev, &mut out)?;
                    }
                    done += piece;
                }
                // A band sized by time is measured to its end before the next is sized.
                if plan.timed() {
                    take(r, in_flight.take().expect("just queued"), &mut out)?;
                }
            }
            None => {
                read_bytes_staged(ctx, src, &mut out[at..at + len])?;
                progress.inc(u64::from(n));
            }
        }
        if let Some(b) = &bufs.aov {
            let at = top as usize * width as usize * 4;
            b.read_f32_staged(ctx, &mut aov_data[at..at + band * 4])?;
        }
        *setup.stats.phases_ms.entry("read_back".into()).or_default() += ms_since(t);
        top += n;
        last = (n, t_band.elapsed());
    }
    let t = Instant::now();
    if let (Some(r), Some(last)) = (bufs.ring.as_mut(), in_flight) {
        take(r, last, &mut out)?;
    }
    progress.finish();
    let words = bufs.counters.read_u32(gl)?;
    drop(kept);
    let total = sum_words(&words);
    *setup.stats.phases_ms.entry("read_back".into()).or_default() += ms_since(t);
    // Rays cut off, ray trees left incomplete, or samples never started: the program's
    // loops did not run to their end. Besides a traversal bug, a driver can cause it:
    // llvmpipe ends every loop of a shader invocation once 65535 iterations of them all have
    // run (pixels with many samples, deep trees or long walks), and an image from such a
    // run is silently missing rays.
    let primaries = u64::from(width) * u64::from(height) * u64::from(spec.samples);
    let cut = total[Counter::Unfinished.slot()];
    if cut > 0 || total[Counter::Primary.slot()] != primaries {
        return Err(Error::Unfinished(format!(
            "{cut} rays or ray trees cut off (traversal \
             bound {} iterations), {} of {primaries} primary rays traced; the driver may \
             limit the loop iterations of one invocation (llvmpipe: 65535); --kernel looped \
             splits the work into passes",
            spec.max_iterations,
            total[Counter::Primary.slot()],
        )));
    }
    let t = Instant::now();
    let (image, srgb8) = if readback.srgb8 {
        (RgbImage::size_only(width, height), Some(out))
    } else {
        let rgb: Vec<f32> = out
            .chunks_exact(4)
            .map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        crate::pool::give_back(out);
        (RgbImage::from_rgb(width, height, rgb), None)
    };
    let aov = if readback.aov {
        aov_from_texels(gs.given_scene(), gs.instanced(), &aov_data, width, height)
    } else {
        Aov::from_vec(0, 0, Vec::new())
    };
    setup.stats.phases_ms.insert("aov".into(), ms_since(t));
    if let Some(observer) = observer {
        // The observer draws from a texture (GL rows from the bottom, RGBA, linear).
        let mut rgba = vec![0f32; pixels * 4];
        for j in 0..height as usize {
            let gl_row = height as usize - 1 - j;
            for i in 0..width as usize {
                let k = j * width as usize + i;
                let px: [f32; 3] = match &srgb8 {
                    Some(b) => std::array::from_fn(|c| {
                        crate::image_io::srgb_to_linear(b[3 * k + c] as f32 / 255.0)
                    }),
                    None => std::array::from_fn(|c| image.data[3 * k + c]),
                };
                let at = (gl_row * width as usize + i) * 4;
                rgba[at..at + 3].copy_from_slice(&px);
            }
        }
        let radiance = Texture::new_f32(ctx, width, height, Some(&rgba))?;
        let snap = Snapshot {
            radiance: &radiance,
            state: &[],
            samples_done: spec.samples,
            samples: spec.samples,
            passes: setup.stats.passes_total,
            pass: "compute",
            aov: None,
            advance: None,
        };
        if observer(&snap) == Flow::Cancel {
            return Err(Error::Cancelled);
        }
    }
    setup.stats.trace_ms = ms_since(t_trace);
    let n = |c: Counter| total[c.slot()];
    Ok(GpuOutput {
        image,
        aov,
        rays: RayCounts::new(
            n(Counter::Primary),
            n(Counter::Shadow),
            n(Counter::Reflected),
            n(Counter::Refracted),
        ),
        work: Some(Work {
            cells: n(Counter::Cells),
            tests: n(Counter::Tests),
        }),
        gpu: Some(setup.stats),
        srgb8,
        primary_steps: Some(n(Counter::PrimarySteps)),
        nonfinite: Some(n(Counter::NonFinite)),
    })
}

/// Converts the first `pixels` pixels of the radiance buffer bound at its binding to 8-bit
/// sRGB bytes in `dst` (`srgb8.comp` as `p`, with the `thresholds` buffer).
fn convert_srgb8(
    gl: &glow::Context,
    p: &Program,
    thresholds: &StorageBuffer,
    dst: &StorageBuffer,
    pixels: usize,
) -> Result<()> {
    thresholds.bind(gl, Buffer::SrgbThresholds.binding());
    dst.bind(gl, Buffer::Srgb8.binding());
    p.set(gl, uniform::PIXELS, pixels as i32)?;
    dispatch(
        gl,
        p,
        [((pixels * 3).div_ceil(4)).div_ceil(64) as u32, 1, 1],
    );
    Ok(())
}

/// Reads `out.len()` bytes of `src` through a staging copy (contexts without persistent
/// mapping).
fn read_bytes_staged(ctx: &GlContext, src: &StorageBuffer, out: &mut [u8]) -> Result<()> {
    let mut words = vec![0f32; out.len().div_ceil(4)];
    src.read_f32_staged(ctx, &mut words)?;
    for (d, w) in out.chunks_mut(4).zip(&words) {
        d.copy_from_slice(&w.to_ne_bytes()[..d.len()]);
    }
    Ok(())
}

/// The primary-ray AOVs from `render.comp`'s AOV buffer: one `A0_TEXEL` per pixel, in
/// image order.
/// An instanced scene's texels carry the hit's id as its bits (exact to 2^32; a float
/// holds ids exactly only below 2^24) and a hit as the SHADING state.
fn aov_from_texels(
    scene: &crate::scene::Scene,
    instanced: bool,
    data: &[f32],
    w: u32,
    h: u32,
) -> Aov {
    let shading = super::contract::RayState::Shading.code();
    // Collected in parallel: at 4096x4096 a serial fill of the 400 MB of pixels alone took
    // longer than the dispatch.
    let pixels: Vec<AovPixel> = data
        .par_chunks_exact(4)
        .map(|t| {
            let (tri, t_best) = (t[aov::TRI.first], t[aov::T_BEST.first]);
            let steps = t[aov::STEPS.first];
            if instanced {
                let hit = (t[aov::STATE.first] - shading).abs() < 0.25;
                aov_pixel_id(scene, hit.then_some((t_best, tri.to_bits() as u64)), steps)
            } else {
                aov_pixel(scene, (tri >= 0.0).then_some((t_best, tri)), steps)
            }
        })
        .collect();
    Aov::from_vec(w, h, pixels)
}

/// Traces the wave of `rays` with `wave.comp` (the compute side of `trace_rays`): the wave's
/// ray state in four images, every ray in state INITIAL (or a finished non-ray), traced to
/// its end in one dispatch, as after the fragment kernels' termination loop.
pub(crate) fn trace_wave(
    gs: &GpuScene,
    rays: &[GpuRay],
    query: Query,
    (w, h): (u32, u32),
    opts: &GpuOptions,
) -> Result<Vec<GpuTrace>> {
    let ctx = gs.ctx();
    let s = initial_state(rays, (w * h) as usize);
    let textures = s
        .texels
        .iter()
        .map(|data| Texture::new_f32(ctx, w, h, Some(data)))
        .collect::<Result<Vec<_>>>()?;
    let spec = ComputeSpec {
        samples: 1,
        lights: 0,
        max_depth: 0,
        secondary: false,
        max_iterations: gs.max_iterations().min(i32::MAX as u64) as u32,
        fetch: Fetch::TexelFetch,
        aov: false,
        instanced: false,
    };
    let mut setup = Setup::new(gs, ComputePass::Wave(query), &spec, opts, opts.techniques)?;
    let gl = ctx.gl();
    setup
        .program
        .set(gl, uniform::SIZE, glam::IVec2::new(w as i32, h as i32))?;
    for (img, tex) in Image::ALL.into_iter().zip(&textures) {
        bind_image(gl, img.binding(), tex);
    }
    setup.dispatch(w, h, false)?;
    let read = |k: usize| textures[k].read(gl);
    let s = StateTexels {
        texels: [read(0)?, Vec::new(), Vec::new(), read(3)?],
    };
    let out = traces_from(&s, rays.len());
    check_finished(&out)?;
    Ok(out)
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod camera_tests;
