//! `--kernel compute`: the host side of `glsl120/render.comp` (the whole ray tree of every
//! pixel and sample in one dispatch) and `glsl120/wave.comp` (a wave of given rays, for
//! [`trace_rays`](super::trace_rays)).
//!
//! No ray state crosses the host: the program computes the primary directions itself (the
//! camera's f64 formula, from a buffer of the frame and sample offsets), walks the tree
//! with a per-invocation stack and writes the summed radiance and the first sample's
//! primary-ray AOV texel to two images. Counts come back as one record per work group
//! (rays by kind, cells entered, triangle tests, rays cut off), summed here in u64.

use std::time::Instant;

use glow::HasContext;
use rayon::prelude::*;

use super::frame::{bind_texture, max_iterations};
use super::passes::set_scene_uniforms;
use super::readback::aov_pixel;
use super::{Flow, GpuOutput, ImageRequest, Observer, Snapshot, Work};
use crate::accel::AccelRef;
use crate::gpu::context::GlContext;
use crate::gpu::contract::compute::{camera_buffer, Counter, COUNTERS};
use crate::gpu::contract::Unit;
use crate::gpu::gl::{
    bind_image, compile_compute, Program, StorageBuffer, Texture, TimerQuery, Uniform,
};
use crate::gpu::info::GlInfo;
use crate::gpu::layout::{SceneTextures, STORAGE_BINDING_BASE};
use crate::gpu::options::{GpuOptions, SceneFetch, Storage};
use crate::gpu::shader::{assemble_compute, ComputePass, ComputeSpec, Features, Fetch, LOCAL_SIZE};
use crate::image_io::Image;
use crate::output::{Aov, AovPixel, GpuStats, RayCounts};
use crate::scene::{camera, Scene};
use crate::{Error, Result};

/// The scene uploaded and one compute program built for it.
struct Setup {
    program: Program,
    /// Scene textures, bound to their units for the dispatch (texelFetch).
    scene_tex: Vec<(Unit, Texture)>,
    /// The same texels as storage buffers, at their bindings (`Fetch::Storage`).
    scene_buf: Vec<(u32, StorageBuffer)>,
    /// How the program reads the scene.
    fetch: Fetch,

    stats: GpuStats,
}

impl Setup {
    fn new(
        ctx: &GlContext,
        scene: &Scene,
        accel: AccelRef<'_>,
        pass: ComputePass,
        spec: &ComputeSpec,
        opts: &GpuOptions,
    ) -> Result<Self> {
        let info = &ctx.info;
        if opts.storage != Storage::F32 {
            return Err(Error::Limit(format!(
                "--storage {} applies to the fragment kernels' ray textures; the compute \
                 kernel keeps its rays in registers",
                opts.storage
            )));
        }
        let features = if opts.no_specialize {
            Features::all()
        } else {
            Features::of(scene)
        };
        let mut stats = GpuStats {
            renderer: info.renderer.clone(),
            gl_version: info.gl_version.clone(),
            query_every: opts.query_every,
            features,
            kernel: "compute".into(),
            ..GpuStats::default()
        };
        let t_up = Instant::now();
        let max_size = info.max_texture_size.max(0) as u32;
        let layout = SceneTextures::pack_with(scene, accel, max_size, features.smooth_normals)?;
        // Storage buffers only where the context has blocks for every scene texture beside
        // the kernel's own: `auto` then falls back to texelFetch, an explicit request fails.
        let (blocks, needed) = (
            Limits::query(ctx.gl()).blocks,
            layout.storage_blocks() + STORAGE_BINDING_BASE,
        );
        let fetch = match spec.fetch {
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
        };
        stats.scene_fetch = fetch.name().into();
        let spec = &ComputeSpec { fetch, ..*spec };
        let (mut scene_tex, mut scene_buf) = (Vec::new(), Vec::new());
        for (k, (unit, t)) in layout.with_units().into_iter().enumerate() {
            match spec.fetch {
                Fetch::Storage => {
                    let bytes: Vec<u8> = t.data.iter().flat_map(|v| v.to_ne_bytes()).collect();
                    scene_buf.push((
                        STORAGE_BINDING_BASE + k as u32,
                        StorageBuffer::new(ctx, &bytes)?,
                    ));
                }
                Fetch::TexelFetch | Fetch::Texture2D => scene_tex.push((
                    unit,
                    Texture::new_f32(ctx, t.width, t.height, Some(&t.data))?,
                )),
            }
        }
        // SAFETY: the context is current.
        unsafe { ctx.gl().finish() };
        stats.upload_ms = t_up.elapsed().as_secs_f64() * 1e3;
        stats.upload_bytes = layout.bytes();

        let t_c = Instant::now();
        let a = assemble_compute(pass, spec, features, opts.techniques, &layout)?;
        let program = compile_compute(ctx, pass.name(), &a.source, &|n| a.origin(n))?;
        set_scene_uniforms(ctx.gl(), &program, accel, scene);
        stats.compile_ms = t_c.elapsed().as_secs_f64() * 1e3;
        Ok(Setup {
            program,
            scene_tex,
            scene_buf,
            fetch,
            stats,
        })
    }

    /// Dispatches the program over a `width` x `height` grid of invocations, timed when
    /// timers are on, and waits for its writes.
    fn dispatch(&mut self, ctx: &GlContext, width: u32, height: u32, timers: bool) -> Result<()> {
        let gl = ctx.gl();
        for (unit, tex) in &self.scene_tex {
            bind_texture(gl, *unit, tex);
        }
        for (binding, buf) in &self.scene_buf {
            buf.bind(gl, *binding);
        }
        let timer = (timers && ctx.info.timer_query)
            .then(|| TimerQuery::new(ctx))
            .transpose()?;
        if let Some(t) = &timer {
            t.begin(ctx);
        }
        // SAFETY: the context is current; the program, textures, images and buffers the
        // program reads are bound.
        unsafe {
            gl.use_program(Some(self.program.name()));
            gl.dispatch_compute(
                width.div_ceil(LOCAL_SIZE.0),
                height.div_ceil(LOCAL_SIZE.1),
                1,
            );
            gl.memory_barrier(glow::ALL_BARRIER_BITS);
        }
        if let Some(t) = timer {
            t.end(ctx);
            let ms = t.result_ns(ctx)? as f64 * 1e-6;
            self.stats.gpu_ms.insert("compute".into(), ms);
            self.stats.gpu_ms_total = ms;
        }
        crate::gpu::gl::check_gl_error(gl, "dispatching the compute kernel")?;
        *self.stats.passes.entry("compute".into()).or_default() += 1;
        self.stats.passes_total += 1;
        Ok(())
    }
}

/// Sums the per-work-group counter records.
fn sum_counters(records: &[u32]) -> [u64; COUNTERS] {
    let mut total = [0u64; COUNTERS];
    for rec in records.chunks_exact(COUNTERS) {
        for (t, &v) in total.iter_mut().zip(rec) {
            *t += v as u64;
        }
    }
    total
}

/// How the render kernel reads the scene: as asked, or under `auto` the faster of the two
/// where measured: storage buffers on the H200 (bunny.toml 4096x4096: 874 vs 604 M rays/s
/// with texelFetch), texelFetch on llvmpipe, whose storage loads run lane by lane with a
/// bounds check each (bunny.toml 160x120: 1.24 G instructions of shader code against
/// 1.47 G, callgrind). Other drivers get storage buffers unmeasured; `--scene-fetch` and
/// `fragtrace bench` are there to measure them.
fn scene_fetch(choice: SceneFetch, info: &GlInfo) -> Fetch {
    match choice {
        SceneFetch::TexelFetch => Fetch::TexelFetch,
        SceneFetch::StorageBuffer => Fetch::Storage,
        SceneFetch::Auto if info.renderer.starts_with("llvmpipe") => Fetch::TexelFetch,
        SceneFetch::Auto => Fetch::Storage,
    }
}

/// Renders `scene` with the compute kernel (see the module documentation).
pub(super) fn render_compute(
    ctx: &GlContext,
    scene: &Scene,
    accel: AccelRef<'_>,
    req: &ImageRequest,
    observer: Option<&mut Observer<'_>>,
) -> Result<GpuOutput> {
    let (width, height) = (req.width, req.height);
    ctx.info.check_image_size(width, height)?;
    let gl = ctx.gl();
    let limits = Limits::query(gl);
    let offsets = camera::sample_offsets(req.spp);
    let secondary = scene.materials.iter().any(|m| m.reflects() || m.refracts());
    let spec = ComputeSpec {
        samples: offsets.len() as u32,
        lights: scene.lights.len() as u32,
        max_depth: req.max_depth,
        secondary,
        max_iterations: max_iterations(accel).min(i32::MAX as u64) as u32,
        // Setup::new falls back to texelFetch where the context has too few storage blocks.
        fetch: scene_fetch(req.gpu.scene_fetch, &ctx.info),
    };
    let opts = GpuOptions {
        techniques: req.techniques,
        ..req.gpu
    };
    let mut setup = Setup::new(ctx, scene, accel, ComputePass::Render, &spec, &opts)?;
    let spec = ComputeSpec {
        fetch: setup.fetch,
        ..spec
    };
    let t_trace = Instant::now();
    let program = &setup.program;
    program.set(gl, "u_eye", Uniform::Vec3(scene.camera.eye.to_array()));
    program.set(
        gl,
        "u_sample_weight",
        Uniform::Float(1.0 / offsets.len() as f32),
    );
    program.set(gl, "u_size", Uniform::IVec2([width as i32, height as i32]));

    let cam = camera_buffer(&scene.camera.frame(), width, height, &offsets);
    let cam_bytes: Vec<u8> = cam.iter().flat_map(|v| v.to_ne_bytes()).collect();
    let lights: Vec<u8> = scene
        .lights
        .iter()
        .flat_map(|l| {
            let (p, r) = (l.position, l.radiance());
            [p.x, p.y, p.z, 0.0, r.x, r.y, r.z, 0.0]
        })
        .flat_map(f32::to_ne_bytes)
        .collect();
    let cam_buf = StorageBuffer::new(ctx, &cam_bytes)?;
    let light_buf = StorageBuffer::new(ctx, &lights)?;
    cam_buf.bind(gl, 0);
    light_buf.bind(gl, 1);

    // Bands of rows whose outputs fit one storage block (the AOV's 16 bytes per pixel are
    // the larger), aligned so every band starts a whole number of rows in.
    let rows = limits.band_rows(width, height)?;
    let band_groups = width.div_ceil(LOCAL_SIZE.0) as usize * rows.div_ceil(LOCAL_SIZE.1) as usize;
    let counter_buf = StorageBuffer::zeroed_u32(ctx, band_groups * COUNTERS)?;
    counter_buf.bind(gl, 2);
    let band_px = width as usize * rows as usize;
    let radiance_buf = StorageBuffer::uninit(ctx, band_px * 3 * 4)?;
    let aov_buf = StorageBuffer::uninit(ctx, band_px * 4 * 4)?;
    radiance_buf.bind(gl, 3);
    aov_buf.bind(gl, 4);
    let pixels = width as usize * height as usize;
    let mut rgb = vec![0f32; pixels * 3];
    let mut aov_data = vec![0f32; pixels * 4];
    setup
        .stats
        .phases_ms
        .insert("setup".into(), ms_since(t_trace));
    let mut total = [0u64; COUNTERS];
    // Bands from the top of the image, so each band's rows follow the last in the outputs.
    for top in (0..height).step_by(rows as usize) {
        let n = rows.min(height - top);
        let gl_row0 = height - top - n;
        setup
            .program
            .set(gl, "u_band", Uniform::IVec2([gl_row0 as i32, n as i32]));
        let t = Instant::now();
        setup.dispatch(ctx, width, n, opts.timers)?;
        // Only this band's groups: a shorter last band leaves the records beyond stale.
        let groups = width.div_ceil(LOCAL_SIZE.0) as usize * n.div_ceil(LOCAL_SIZE.1) as usize;
        let records = counter_buf.read_u32(gl)?;
        for (t, c) in total
            .iter_mut()
            .zip(sum_counters(&records[..groups * COUNTERS]))
        {
            *t += c;
        }
        *setup.stats.phases_ms.entry("dispatch".into()).or_default() += ms_since(t);
        let t = Instant::now();
        let (at, len) = (top as usize * width as usize, n as usize * width as usize);
        let rgb_band = &mut rgb[at * 3..(at + len) * 3];
        let aov_band = &mut aov_data[at * 4..(at + len) * 4];
        radiance_buf.read_f32_staged(ctx, rgb_band)?;
        aov_buf.read_f32_staged(ctx, aov_band)?;
        *setup.stats.phases_ms.entry("read_back".into()).or_default() += ms_since(t);
    }
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
    let image = Image::from_rgb(width, height, rgb);
    let aov = aov_from_texels(scene, &aov_data, width, height);
    setup.stats.phases_ms.insert("aov".into(), ms_since(t));
    if let Some(observer) = observer {
        // The observer draws from a texture (GL rows from the bottom, RGBA).
        let mut rgba = vec![0f32; pixels * 4];
        for (j, row) in image.data.chunks(width as usize * 3).enumerate() {
            let gl_row = height as usize - 1 - j;
            for (i, px) in row.chunks(3).enumerate() {
                let at = (gl_row * width as usize + i) * 4;
                rgba[at..at + 3].copy_from_slice(px);
            }
        }
        let radiance = Texture::new_f32(ctx, width, height, Some(&rgba))?;
        let snap = Snapshot {
            radiance: &radiance,
            state: &[],
            samples_done: spec.samples,
            samples: spec.samples,
            passes: setup.stats.passes_total,
        };
        if observer(&snap) == Flow::Cancel {
            return Err(Error::Cancelled);
        }
    }
    setup.stats.trace_ms = t_trace.elapsed().as_secs_f64() * 1e3;
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
        stats: setup.stats,
    })
}

/// The context's storage-buffer limits that shape a compute render.
struct Limits {
    /// GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS.
    blocks: u32,
    /// GL_MAX_SHADER_STORAGE_BLOCK_SIZE (capped at what GL's 32-bit sizes express).
    block_bytes: u64,
}

impl Limits {
    fn query(gl: &glow::Context) -> Self {
        #[cfg(test)]
        if let Some(block_bytes) = tests::BLOCK_BYTES.get() {
            return Limits {
                blocks: 0,
                block_bytes,
            };
        }
        // SAFETY: the context is current; plain state queries.
        unsafe {
            Limits {
                blocks: gl
                    .get_parameter_i32(glow::MAX_COMPUTE_SHADER_STORAGE_BLOCKS)
                    .max(0) as u32,
                block_bytes: (gl
                    .get_parameter_i64(glow::MAX_SHADER_STORAGE_BLOCK_SIZE)
                    .max(0) as u64)
                    .min(i32::MAX as u64),
            }
        }
    }

    /// Rows per band: as many as keep the AOV output (16 bytes per pixel) within one
    /// storage block, a multiple of 256 rows (so every band's byte offsets keep any
    /// alignment GL asks of a range) unless the whole image fits.
    fn band_rows(&self, width: u32, height: u32) -> Result<u32> {
        let per_row = width as u64 * 16;
        let fit = self.block_bytes / per_row;
        if fit >= height as u64 {
            return Ok(height);
        }
        let rows = fit / 256 * 256;
        if rows == 0 {
            return Err(Error::Limit(format!(
                "a {width}-pixel row needs 256 x {per_row} bytes of output per band; \
                 GL_MAX_SHADER_STORAGE_BLOCK_SIZE is {}",
                self.block_bytes
            )));
        }
        Ok(rows as u32)
    }
}

/// The primary-ray AOVs from `render.comp`'s AOV buffer: per pixel (t_best, tri_best or
/// TRI_NONE, steps, state), in image order.
fn aov_from_texels(scene: &Scene, data: &[f32], w: u32, h: u32) -> Aov {
    // Collected in parallel: at 4096x4096 a serial fill of the 400 MB of pixels alone took
    // longer than the dispatch.
    let pixels: Vec<AovPixel> = data
        .par_chunks_exact(4)
        .map(|t| {
            let hit = t[1] >= 0.0;
            aov_pixel(scene, hit.then_some((t[0], t[1])), t[2])
        })
        .collect();
    Aov::from_vec(w, h, pixels)
}

fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// Traces a wave of rays held in the four state textures `state` (s0..s3, `w` x `h`, every
/// ray in state INITIAL or finished) to their end with `wave.comp`; the textures then hold
/// the final states, as after the fragment kernels' termination loop.
pub(super) fn trace_wave(
    ctx: &GlContext,
    scene: &Scene,
    accel: AccelRef<'_>,
    state: &[Texture],
    (w, h): (u32, u32),
    query: crate::gpu::shader::Query,
    opts: &GpuOptions,
) -> Result<()> {
    let spec = ComputeSpec {
        samples: 1,
        lights: 0,
        max_depth: 0,
        secondary: false,
        max_iterations: max_iterations(accel).min(i32::MAX as u64) as u32,
        fetch: Fetch::TexelFetch,
    };
    let mut setup = Setup::new(ctx, scene, accel, ComputePass::Wave(query), &spec, opts)?;
    let gl = ctx.gl();
    setup
        .program
        .set(gl, "u_size", Uniform::IVec2([w as i32, h as i32]));
    for (k, tex) in state.iter().enumerate() {
        bind_image(gl, k as u32, tex);
    }
    setup.dispatch(ctx, w, h, false)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{Accel, AccelKind, GridConfig, IrregularConfig};
    use crate::gpu::context::with_test_context;
    use crate::gpu::options::Kernel;
    use crate::scene::builtin_scene;

    thread_local! {
        /// Test hook: a storage-block size (and no storage blocks for the scene) in place
        /// of the context's, to force bands and texelFetch.
        pub(super) static BLOCK_BYTES: std::cell::Cell<Option<u64>> = const { std::cell::Cell::new(None) };
    }

    #[test]
    fn band_rows_fit_the_block_and_keep_alignment() {
        let l = |block_bytes| Limits {
            blocks: 16,
            block_bytes,
        };
        assert_eq!(l(1 << 30).band_rows(640, 480).unwrap(), 480);
        // 600 rows of 300 pixels at 16 bytes: 256 rows fit in 1.5 MB, 2 x 256 do not.
        assert_eq!(l(300 * 16 * 300).band_rows(300, 600).unwrap(), 256);
        assert!(l(300 * 16 * 255).band_rows(300, 600).is_err());
    }

    /// `--scene-fetch` changes only the compute kernel, so asking for it with another kernel
    /// is a usage error naming both; with auto it is taken where auto runs compute.
    #[test]
    fn scene_fetch_needs_the_compute_kernel() {
        with_test_context(|ctx| {
            let with = |kernel| GpuOptions {
                kernel,
                scene_fetch: SceneFetch::TexelFetch,
                ..GpuOptions::default()
            };
            let e = with(Kernel::Looped).resolve_kernel(&ctx.info).unwrap_err();
            assert!(matches!(e, Error::Usage(_)), "{e:?}");
            assert!(
                e.to_string()
                    .contains("--scene-fetch texel-fetch applies to the compute kernel; this render runs looped"),
                "{e}"
            );
            // Auto runs compute where the context has it, else a fragment kernel: refused.
            let auto = with(Kernel::Auto).resolve_kernel(&ctx.info);
            assert_eq!(auto.ok(), ctx.info.compute.then_some(Kernel::Compute));
        });
    }

    /// Rendering in bands (with texelFetch, as a context with few storage blocks would)
    /// gives the same bits as one dispatch with storage buffers.
    #[test]
    fn bands_and_fetch_paths_render_the_same_bits() {
        with_test_context(|ctx| {
            if !ctx.info.compute {
                eprintln!("SKIPPED: no GL 4.3 compute in this context");
                return;
            }
            let scene = builtin_scene();
            let accel = Accel::build(
                &scene,
                AccelKind::Irregular,
                &GridConfig::default(),
                &IrregularConfig::default(),
            )
            .unwrap();
            let req = ImageRequest {
                width: 96,
                height: 600,
                spp: 1,
                max_depth: scene.max_depth,
                techniques: Default::default(),
                progress: false,
                gpu: GpuOptions {
                    kernel: Kernel::Compute,
                    ..GpuOptions::default()
                },
            };
            // Storage buffers asked for (llvmpipe's preferred fetch is texelFetch).
            let asked = |scene_fetch| ImageRequest {
                gpu: GpuOptions {
                    scene_fetch,
                    ..req.gpu
                },
                ..req
            };
            let render =
                |req: &ImageRequest| render_compute(ctx, &scene, accel.as_ref(), req, None);
            let whole = render(&asked(SceneFetch::StorageBuffer)).unwrap();
            assert_eq!(whole.stats.scene_fetch, "storage-buffer");
            BLOCK_BYTES.set(Some(96 * 16 * 256));
            let banded = render(&req);
            // Too few storage blocks: auto falls back, an explicit request says why not.
            let refused = render(&asked(SceneFetch::StorageBuffer));
            BLOCK_BYTES.set(None);
            let banded = banded.unwrap();
            assert_eq!(banded.stats.scene_fetch, "texel-fetch");
            let e = refused
                .err()
                .expect("storage buffers without storage blocks")
                .to_string();
            assert!(e.contains("storage blocks"), "{e}");
            assert_eq!(banded.stats.passes_total, 3, "600 rows in bands of 256");
            assert_eq!(whole.stats.passes_total, 1);
            assert_eq!(whole.image.data, banded.image.data);
            assert_eq!(whole.rays.total, banded.rays.total);
            assert_eq!(whole.work, banded.work);
            let ids = |o: &GpuOutput| o.aov.pixels.iter().map(|p| p.primid).collect::<Vec<_>>();
            assert_eq!(ids(&whole), ids(&banded));
        });
    }
}
