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
use super::readback::{aov_pixel, flip_rgba_to_rgb};
use super::{Flow, GpuOutput, ImageRequest, Observer, Snapshot, Work};
use crate::accel::AccelRef;
use crate::gpu::context::GlContext;
use crate::gpu::contract::compute::{camera_buffer, Counter, COUNTERS};
use crate::gpu::contract::Unit;
use crate::gpu::gl::{bind_image, compile_compute, Program, StorageBuffer, Texture, TimerQuery};
use crate::gpu::layout::SceneTextures;
use crate::gpu::options::{GpuOptions, Storage};
use crate::gpu::shader::{assemble_compute, ComputePass, ComputeSpec, Features, LOCAL_SIZE};
use crate::image_io::Image;
use crate::output::{Aov, AovPixel, GpuStats, RayCounts};
use crate::scene::{camera, Scene};
use crate::{Error, Result};

/// The scene uploaded and one compute program built for it.
struct Setup {
    program: Program,
    /// Scene textures, bound to their units for the dispatch.
    scene_tex: Vec<(Unit, Texture)>,
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
        let scene_tex = layout
            .with_units()
            .into_iter()
            .map(|(unit, t)| {
                Ok((
                    unit,
                    Texture::new_f32(ctx, t.width, t.height, Some(&t.data))?,
                ))
            })
            .collect::<Result<Vec<_>>>()?;
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
            stats,
        })
    }

    fn set_ivec2(&self, gl: &glow::Context, name: &str, v: (u32, u32)) {
        // SAFETY: the context is current; `use_program` makes the location's program current.
        unsafe {
            gl.use_program(Some(self.program.name()));
            let loc = gl.get_uniform_location(self.program.name(), name);
            gl.uniform_2_i32(loc.as_ref(), v.0 as i32, v.1 as i32);
        }
    }

    fn set_vec3(&self, gl: &glow::Context, name: &str, v: [f32; 3]) {
        // SAFETY: as in `set_ivec2`.
        unsafe {
            gl.use_program(Some(self.program.name()));
            let loc = gl.get_uniform_location(self.program.name(), name);
            gl.uniform_3_f32(loc.as_ref(), v[0], v[1], v[2]);
        }
    }

    fn set_float(&self, gl: &glow::Context, name: &str, v: f32) {
        // SAFETY: as in `set_ivec2`.
        unsafe {
            gl.use_program(Some(self.program.name()));
            let loc = gl.get_uniform_location(self.program.name(), name);
            gl.uniform_1_f32(loc.as_ref(), v);
        }
    }

    /// Dispatches the program over a `width` x `height` grid of invocations, timed when
    /// timers are on, and waits for its writes.
    fn dispatch(&mut self, ctx: &GlContext, width: u32, height: u32, timers: bool) -> Result<()> {
        let gl = ctx.gl();
        for (unit, tex) in &self.scene_tex {
            bind_texture(gl, *unit, tex);
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
    let offsets = camera::sample_offsets(req.spp);
    let secondary = scene.materials.iter().any(|m| m.reflects() || m.refracts());
    let spec = ComputeSpec {
        samples: offsets.len() as u32,
        lights: scene.lights.len() as u32,
        max_depth: req.max_depth,
        secondary,
        max_iterations: max_iterations(accel).min(i32::MAX as u64) as u32,
    };
    let opts = GpuOptions {
        techniques: req.techniques,
        ..req.gpu
    };
    let mut setup = Setup::new(ctx, scene, accel, ComputePass::Render, &spec, &opts)?;
    let t_trace = Instant::now();
    let gl = ctx.gl();
    setup.set_vec3(gl, "u_eye", scene.camera.eye.to_array());
    setup.set_float(gl, "u_sample_weight", 1.0 / offsets.len() as f32);
    setup.set_ivec2(gl, "u_size", (width, height));

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
    let groups = width.div_ceil(LOCAL_SIZE.0) as usize * height.div_ceil(LOCAL_SIZE.1) as usize;
    let cam_buf = StorageBuffer::new(ctx, &cam_bytes)?;
    let light_buf = StorageBuffer::new(ctx, &lights)?;
    let counter_buf = StorageBuffer::zeroed_u32(ctx, groups * COUNTERS)?;
    cam_buf.bind(gl, 0);
    light_buf.bind(gl, 1);
    counter_buf.bind(gl, 2);
    let radiance = Texture::new_f32(ctx, width, height, None)?;
    let aov_tex = Texture::new_f32(ctx, width, height, None)?;
    bind_image(gl, 0, &radiance);
    bind_image(gl, 1, &aov_tex);
    setup.dispatch(ctx, width, height, opts.timers)?;

    let total = sum_counters(&counter_buf.read_u32(gl)?);
    // Rays cut off, ray trees left incomplete, or samples never started: the program's
    // loops did not run to their end. Besides a traversal bug, a driver can cause it:
    // llvmpipe ends every loop of a shader invocation once 65535 iterations of them all have
    // run (pixels with many samples, deep trees or long walks), and an image from such a
    // run is silently missing rays.
    let primaries = u64::from(width) * u64::from(height) * u64::from(spec.samples);
    let cut = total[Counter::Unfinished.slot()];
    if cut > 0 || total[Counter::Primary.slot()] != primaries {
        return Err(Error::Internal(format!(
            "the compute kernel did not finish: {cut} rays or ray trees cut off (traversal \
             bound {} iterations), {} of {primaries} primary rays traced; the driver may \
             limit the loop iterations of one invocation (llvmpipe: 65535); --kernel looped \
             splits the work into passes",
            spec.max_iterations,
            total[Counter::Primary.slot()],
        )));
    }
    if let Some(observer) = observer {
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
    let data = radiance.read(gl)?;
    let aov_data = aov_tex.read(gl)?;
    let image = Image::from_rgb(width, height, flip_rgba_to_rgb(&data, width, height));
    let aov = aov_from_texels(scene, &aov_data, width, height);
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

/// The primary-ray AOVs from `render.comp`'s AOV image: per pixel (t_best, tri_best or
/// TRI_NONE, steps, state), GL rows from the bottom.
fn aov_from_texels(scene: &Scene, data: &[f32], w: u32, h: u32) -> Aov {
    let mut pixels = vec![AovPixel::miss(0.0); (w * h) as usize];
    pixels
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(j, out)| {
            let row = (h as usize - 1 - j) * w as usize;
            for (i, px) in out.iter_mut().enumerate() {
                let t = &data[(row + i) * 4..(row + i) * 4 + 4];
                let hit = t[1] >= 0.0;
                *px = aov_pixel(scene, hit.then_some((t[0], t[1])), t[2]);
            }
        });
    Aov::from_pixels(w, h, &pixels)
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
    };
    let mut setup = Setup::new(ctx, scene, accel, ComputePass::Wave(query), &spec, opts)?;
    let gl = ctx.gl();
    setup.set_ivec2(gl, "u_size", (w, h));
    for (k, tex) in state.iter().enumerate() {
        bind_image(gl, k as u32, tex);
    }
    setup.dispatch(ctx, w, h, false)
}
