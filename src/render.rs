//! Backend-independent rendering front door: [`prepare`] (options checked, the structure
//! they name built; what `render`, `view` and `bench` all call), dispatch to the CPU
//! reference renderer or the GPU backend, and the statistics of a render, built once for
//! every backend from the one backend output type. The options live in [`crate::options`]
//! (one layer down, so the CLI and the bench share them).

use std::borrow::Cow;
use std::time::Instant;

use serde::Serialize;

use crate::accel::{Accel, AccelRef, AccelSummary, GridRef};
use crate::cpu::simd::Isa;
use crate::cpu::simd_walk::SimdWalker;
use crate::cpu::traverse::Trace;
use crate::cpu::traverse_bvh::BvhWalker;
use crate::cpu::traverse_instances::InstanceWalker;
use crate::cpu::traverse_packet::PacketIsa;
use crate::cpu::CpuRenderer;
use crate::gpu::render::ImageRequest;
use crate::gpu::{self, GlContext, GpuScene};
use crate::image_io::Image;
use crate::output::{Aov, BackendOutput, GpuStats, RayCounts};
use crate::scene::{Camera, Scene};
use crate::Result;

use crate::options::{CpuPath, Precision, RenderOptions};
use crate::plan::Plan;

pub use crate::backend_choice::{auto_declines, context_for, SOFTWARE_DEVICE};

mod prepare;
use prepare::prepare_flat;
pub use prepare::{prepare, prepare_owned};

/// Statistics of one render (written by `--stats FILE.json`).
#[derive(Clone, Debug, Serialize)]
pub struct RenderStats {
    /// What ran, every `auto` resolved ([`Plan`]; written as its flags).
    pub plan: Plan,
    /// "cpu" or "gl" (the plan's backend).
    pub backend: String,
    /// CPU precision or GPU device name.
    pub device: String,
    /// "f32" or "f64" arithmetic (the plan's).
    pub precision: String,
    /// Scene source.
    pub scene: String,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// The pixels rendered, `[x0, y0, x1, y1]` (x1, y1 exclusive), when only a region of
    /// the image was (`--tile`, `--region`, `--task-index`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub region: Option<[u32; 4]>,
    /// Samples per pixel.
    pub spp: u32,
    /// Maximum depth used.
    pub max_depth: u32,
    /// Triangle count.
    pub triangles: usize,
    /// Cells per axis of the structure: the uniform grid's, or the irregular grid's finest
    /// (its virtual resolution, "finest" in the summary line); zeros for the BVH.
    pub grid: [u32; 3],
    /// The irregular grid's top cells per axis ("top" in the summary line); absent for
    /// the other structures.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grid_top: Option<[u32; 3]>,
    /// The acceleration structure: kind, size, memory, build time.
    pub accel: AccelSummary,
    /// Robustness techniques that differ from the default (`default` when none).
    pub techniques: String,
    /// Acceleration-structure build time.
    pub grid_build_ms: f64,
    /// Render time: tracing, shading and read-back, the same on every backend. It
    /// excludes the acceleration-structure build (`grid_build_ms`) and, on the GPU, the
    /// set-up a frame pays before tracing (`setup_ms`).
    pub render_ms: f64,
    /// What the frame paid before tracing: on the GPU the scene's packing and upload
    /// (`gpu.upload_ms`) and its programs' compile and link (`gpu.compile_ms`), charged to
    /// the first frame of a scene; 0 on the CPU. `setup_ms + render_ms` is the frame's
    /// wall time.
    pub setup_ms: f64,
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
    /// AOV or the backend's own sum: what the GPU reports of its traversal work, and the
    /// CPU alike for comparison (absent where neither was read back: a fragment kernel
    /// without `--aov`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub primary_steps_per_ray: Option<f64>,
    /// Million rays per second over `render_ms` (set-up excluded).
    pub mrays_per_s: f64,
    /// Backend-specific extras (GPU pass counts and timings).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gpu: Option<GpuStats>,
    /// Where a `render` command's whole process went (set by the command line, absent for
    /// library renders).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub process: Option<ProcessTimes>,
}

/// The phases of one `render` command, wall time in milliseconds, for the whole-process
/// figures (`time fragtrace render ...`): what the process spent before the scene, loading
/// it, in the render call (the GL context, the structure's build, upload, compile and the
/// render itself: `grid_build_ms + setup_ms + render_ms` and the context's start), and
/// writing the image. What `time` adds beyond `total_ms` is the program's start and exit.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct ProcessTimes {
    /// From the process's start ([`crate::clock::mark_start`]) to the scene's load.
    pub start_ms: f64,
    /// Loading the scene and its meshes (on a thread of its own where a GL context opens
    /// meanwhile: [`crate::overlap`]).
    pub load_ms: f64,
    /// The render call, whole, from the load's start (the load overlaps it).
    pub render_call_ms: f64,
    /// Encoding and writing the image (and the AOV file).
    pub write_ms: f64,
    /// From the process's start to the statistics' write.
    pub total_ms: f64,
    /// The process ends at once after the statistics' write, without the drivers' exit
    /// handlers: a driver still compiles one of its programs
    /// ([`crate::overlap::end_now`]).
    pub ends_at_once: bool,
}

/// A finished render.
pub struct Rendered {
    /// Linear RGB image (no data where `srgb8` holds the image instead).
    pub image: Image,
    /// The image as 8-bit sRGB, where the backend converted it (`Readback::srgb8`).
    pub srgb8: Option<Vec<u8>>,
    /// Non-finite pixels, where the backend counted them instead of returning the image.
    pub nonfinite: Option<u64>,
    /// Primary-ray AOVs.
    pub aov: Aov,
    /// Statistics.
    pub stats: RenderStats,
}

/// A scene made ready to render as the options ask: the options checked and the
/// acceleration structure `--accel` names built. The one way in for `render`, `view` and
/// `bench`, so all three render the same structure from the same flags.
pub struct Prepared<'s> {
    /// The scene: the one given, or, for a structure other than the BVH (and the compute
    /// kernel's uniform grids, which walk instances as placed), the one given with its
    /// instances stored flat ([`Scene::flattened`]).
    pub scene: Cow<'s, Scene>,
    /// Its acceleration structure.
    pub accel: Accel,
    /// What was built (kind, size, build time): what `--stats` and the summary report.
    pub summary: AccelSummary,
    /// The scene with its instances stored flat, prepared where the GPU's two levels were
    /// cut short by the driver ([`RenderOptions::instanced_fallback`]): built once, by the
    /// first frame that needs it, for it and the frames after.
    flat: std::cell::OnceCell<Box<Prepared<'static>>>,
}

impl<'s> Prepared<'s> {
    /// A renderer of this scene on the CPU.
    pub fn cpu_renderer(&self, opts: &RenderOptions) -> Renderer<'_> {
        let (scene, depth, tech) = (&*self.scene, opts.max_depth, opts.techniques);
        // The one switch from the CPU choices to an engine; the plan records the path that
        // runs (packets need the BVH and AVX2, the vector paths the watertight test and
        // x86-64; f64 is always scalar).
        let (precision, path) = (opts.precision, opts.cpu_path);
        let (engine, kernel, ran) = match (self.accel.as_ref(), precision, path) {
            (AccelRef::Bvh(b), Precision::F64, _) => {
                let walker = BvhWalker::new(scene, b, tech);
                let r = CpuRenderer::with_walker(scene, walker, depth, tech);
                let kernel = "scalar triangle tests".to_string();
                (Engine::Cpu64Bvh(r), kernel, CpuPath::Scalar)
            }
            (AccelRef::Bvh(b), Precision::F32, path) => {
                let (isa, packets) = match path {
                    CpuPath::Scalar => (Isa::Scalar, None),
                    CpuPath::Simd => (Isa::detect(), None),
                    CpuPath::Packet => (Isa::detect(), PacketIsa::detect()),
                };
                let walker = match packets {
                    Some(p) => BvhWalker::with_packets(scene, b, tech, isa, p),
                    None => BvhWalker::vectorised(scene, b, tech, isa),
                };
                let (kernel, ran) = match (walker.packets(), walker.isa()) {
                    (Some(p), isa) => (
                        format!(
                            "{} packets of {} rays, {} triangle tests",
                            p.name(),
                            p.lanes(),
                            isa.name()
                        ),
                        CpuPath::Packet,
                    ),
                    (None, Isa::Scalar) => ("scalar triangle tests".into(), CpuPath::Scalar),
                    (None, isa) => (format!("{} triangle tests", isa.name()), CpuPath::Simd),
                };
                let r = CpuRenderer::with_walker(scene, walker, depth, tech);
                (Engine::Cpu32Bvh(r), kernel, ran)
            }
            (AccelRef::Instanced(t), Precision::F64, _) => {
                let own = BvhWalker::new(scene, &t.own, tech);
                let walker =
                    InstanceWalker::new(scene, t, tech, own, |g, b| BvhWalker::new(g, b, tech));
                let r = CpuRenderer::with_walker(scene, walker, depth, tech);
                let kernel = "two-level BVH, scalar triangle tests".to_string();
                (Engine::Cpu64Inst(r), kernel, CpuPath::Scalar)
            }
            (AccelRef::Instanced(t), Precision::F32, path) => {
                let (isa, packets) = match path {
                    CpuPath::Scalar => (Isa::Scalar, None),
                    CpuPath::Simd => (Isa::detect(), None),
                    CpuPath::Packet => (Isa::detect(), PacketIsa::detect()),
                };
                let own = match packets {
                    Some(p) => BvhWalker::with_packets(scene, &t.own, tech, isa, p),
                    None => BvhWalker::vectorised(scene, &t.own, tech, isa),
                };
                let walker = InstanceWalker::new(scene, t, tech, own, |g, b| {
                    BvhWalker::vectorised(g, b, tech, isa)
                });
                let (own, isa) = (walker.own().packets(), walker.own().isa());
                let (kernel, ran) = match (own, isa) {
                    (Some(p), isa) => (
                        format!(
                            "two-level BVH, {} packets of {} rays over the scene's own triangles, {} triangle tests",
                            p.name(),
                            p.lanes(),
                            isa.name()
                        ),
                        CpuPath::Packet,
                    ),
                    (None, Isa::Scalar) => (
                        "two-level BVH, scalar triangle tests".into(),
                        CpuPath::Scalar,
                    ),
                    (None, isa) => (
                        format!("two-level BVH, {} triangle tests", isa.name()),
                        CpuPath::Simd,
                    ),
                };
                let r = CpuRenderer::with_walker(scene, walker, depth, tech);
                (Engine::Cpu32Inst(r), kernel, ran)
            }
            (AccelRef::GridInstanced(_), ..) => {
                unreachable!("prepare builds the instanced grids for --backend gl only")
            }
            (AccelRef::Uniform(g), precision, path) => {
                grid_engine(scene, g.into(), opts, precision, path)
            }
            (AccelRef::Irregular(g), precision, path) => {
                grid_engine(scene, g.into(), opts, precision, path)
            }
        };
        let plan = Plan::Cpu {
            accel: self.summary.kind,
            precision,
            path: ran,
        };
        Renderer {
            prepared: self,
            opts: opts.clone(),
            plan,
            engine,
            device: match rayon::current_num_threads() {
                1 => format!("cpu (1 thread, {kernel})"),
                n => format!("cpu ({n} threads, {kernel})"),
            },
            pending_ms: 0.0,
        }
    }

    /// A renderer of this scene on the GPU in `ctx`: the scene packed now, uploaded and its
    /// programs compiled by the first frame (and charged to it), kept for every frame.
    pub fn gl_renderer<'r>(
        &'r self,
        ctx: &'r GlContext,
        opts: &RenderOptions,
    ) -> Result<Renderer<'r>> {
        let px = opts.pixels();
        ctx.info.check_image_size(px.width(), px.height())?;
        // Resolved before anything is uploaded: a kernel the context lacks, or an option
        // that does not apply to it, is refused now.
        let plan = Plan::resolve(opts, self.summary.kind, Some(&ctx.info))?;
        let t0 = Instant::now();
        let gs = GpuScene::new(ctx, &self.scene, &self.accel, opts.gpu.no_specialize)?
            .with_program_cache(opts.gpu.shader_cache.open(&ctx.info));
        Ok(Renderer {
            prepared: self,
            opts: opts.clone(),
            plan,
            engine: Engine::Gl(Box::new(gs)),
            device: ctx.info.renderer.clone(),
            pending_ms: t0.elapsed().as_secs_f64() * 1e3,
        })
    }

    /// Renders once on the CPU.
    pub fn render_cpu(&self, opts: &RenderOptions) -> Result<Rendered> {
        self.cpu_renderer(opts).render(&self.scene.camera)
    }

    /// Renders once on the GPU in `ctx`: the scene uploaded and the programs compiled
    /// (`setup_ms`), and the image rendered (`render_ms`).
    pub fn render_gl(&self, ctx: &GlContext, opts: &RenderOptions) -> Result<Rendered> {
        self.gl_renderer(ctx, opts)?.render(&self.scene.camera)
    }

    /// The GPU request of `opts` from `camera`.
    pub fn request(&self, opts: &RenderOptions, camera: &Camera) -> ImageRequest {
        ImageRequest {
            camera: *camera,
            width: opts.width,
            height: opts.height,
            spp: opts.spp,
            max_depth: opts.max_depth,
            techniques: opts.techniques,
            progress: opts.progress,
            gpu: opts.gpu,
            readback: opts.readback,
            region: opts.region,
        }
    }

    /// A backend's output with its statistics: built here once for every backend.
    fn rendered(
        &self,
        opts: &RenderOptions,
        plan: Plan,
        out: BackendOutput,
        device: String,
        wall_ms: f64,
    ) -> Rendered {
        let summary = self.summary.clone();
        // The GPU's set-up, charged to the frame that paid it: what the CPU's figure has no
        // counterpart of (its conversion happens when the renderer is made, unclocked).
        let setup_ms = out
            .gpu
            .as_ref()
            .map_or(0.0, |g| (g.upload_ms + g.compile_ms).min(wall_ms));
        let render_ms = wall_ms - setup_ms;
        let stats = RenderStats {
            plan,
            backend: plan.backend().into(),
            device,
            precision: plan.precision().name().into(),
            scene: self.scene.source.clone(),
            width: opts.width,
            height: opts.height,
            region: opts.region.map(|r| [r.x0, r.y0, r.x1, r.y1]),
            spp: opts.spp,
            max_depth: opts.max_depth,
            triangles: self.scene.instanced_triangles() as usize,
            grid: summary.resolution,
            grid_top: summary.top_resolution,
            grid_build_ms: summary.build_ms,
            accel: summary,
            techniques: opts.techniques.tag(),
            render_ms,
            setup_ms,
            rays: out.rays,
            cells_visited: out.work.map(|w| w.cells),
            triangle_tests: out.work.map(|w| w.tests),
            primary_steps_per_ray: out.mean_primary_steps(),
            mrays_per_s: out.rays.total as f64 / (render_ms * 1e3).max(1e-9),
            gpu: out.gpu,
            process: None,
        };
        Rendered {
            image: out.image,
            srgb8: out.srgb8,
            nonfinite: out.nonfinite,
            aov: out.aov,
            stats,
        }
    }
}

/// The CPU engine over a grid in `precision` by `path` (the grids have no packet walk:
/// `packet` walks them as `simd`), what its triangle kernel is, and the path that runs.
fn grid_engine<'p>(
    scene: &'p Scene,
    grid: GridRef<'p>,
    opts: &RenderOptions,
    precision: Precision,
    path: CpuPath,
) -> (Engine<'p>, String, CpuPath) {
    let (depth, tech) = (opts.max_depth, opts.techniques);
    let tests = |isa: &str| format!("{isa} triangle tests");
    match (precision, path) {
        (Precision::F64, _) => (
            Engine::Cpu64(CpuRenderer::new(scene, grid, depth, tech)),
            tests("scalar"),
            CpuPath::Scalar,
        ),
        (Precision::F32, CpuPath::Scalar) => (
            Engine::Cpu32(CpuRenderer::new(scene, grid, depth, tech)),
            tests("scalar"),
            CpuPath::Scalar,
        ),
        (Precision::F32, CpuPath::Simd | CpuPath::Packet) => {
            let walker = SimdWalker::new(scene, grid, tech);
            let isa = walker.isa();
            let ran = if isa == Isa::Scalar {
                CpuPath::Scalar
            } else {
                CpuPath::Simd
            };
            let r = CpuRenderer::with_walker(scene, walker, depth, tech);
            (Engine::Cpu32Simd(r), tests(isa.name()), ran)
        }
    }
}

/// The backend a [`Renderer`] keeps between frames.
enum Engine<'p> {
    Cpu64(CpuRenderer<'p, f64>),
    Cpu32(CpuRenderer<'p, f32>),
    /// The vectorised f32 path (`--cpu-path simd`).
    Cpu32Simd(CpuRenderer<'p, f32, SimdWalker<'p>>),
    /// The BVH's walk in f64.
    Cpu64Bvh(CpuRenderer<'p, f64, BvhWalker<'p, f64>>),
    /// The BVH's walk in f32 (scalar or vectorised, as `--cpu-path` says).
    Cpu32Bvh(CpuRenderer<'p, f32, BvhWalker<'p, f32>>),
    /// The two-level BVH's walk (a scene with instances) in f64.
    Cpu64Inst(CpuRenderer<'p, f64, InstanceWalker<'p, f64>>),
    /// The two-level BVH's walk in f32.
    Cpu32Inst(CpuRenderer<'p, f32, InstanceWalker<'p, f32>>),
    Gl(Box<GpuScene<'p>>),
}

/// A scene prepared once and rendered frame after frame from any camera: on the CPU its
/// geometry converted once, on the GPU uploaded and compiled once ([`GpuScene`]). What
/// `render`, `view`, `bench` and animations render through.
pub struct Renderer<'p> {
    prepared: &'p Prepared<'p>,
    opts: RenderOptions,
    /// What runs, resolved once when the renderer was made.
    plan: Plan,
    engine: Engine<'p>,
    device: String,
    /// Set-up time not yet charged to a frame (the GPU scene's packing).
    pending_ms: f64,
}

impl<'p> Renderer<'p> {
    /// Renders only `region` of the image from the next frame on (None: all of it), as
    /// `RenderOptions::region` does: a process that renders several parts builds once.
    pub fn set_region(&mut self, region: Option<crate::region::Region>) -> Result<()> {
        let opts = RenderOptions {
            region,
            ..self.opts.clone()
        };
        opts.validate()?;
        if let Engine::Gl(gs) = &self.engine {
            let px = opts.pixels();
            gs.ctx().info.check_image_size(px.width(), px.height())?;
        }
        self.opts = opts;
        Ok(())
    }

    /// Renders one frame from `camera`; `setup_ms` plus `render_ms` is what this frame
    /// spent, set-up the first frame paid for included (in `setup_ms`).
    pub fn render(&mut self, camera: &Camera) -> Result<Rendered> {
        let opts = &self.opts;
        let t0 = Instant::now();
        let out = match &mut self.engine {
            Engine::Cpu64(r) => {
                r.set_camera(*camera);
                cpu_frame(r, opts)
            }
            Engine::Cpu32(r) => {
                r.set_camera(*camera);
                cpu_frame(r, opts)
            }
            Engine::Cpu32Simd(r) => {
                r.set_camera(*camera);
                cpu_frame(r, opts)
            }
            Engine::Cpu64Bvh(r) => {
                r.set_camera(*camera);
                cpu_frame(r, opts)
            }
            Engine::Cpu32Bvh(r) => {
                r.set_camera(*camera);
                cpu_frame(r, opts)
            }
            Engine::Cpu64Inst(r) => {
                r.set_camera(*camera);
                cpu_frame(r, opts)
            }
            Engine::Cpu32Inst(r) => {
                r.set_camera(*camera);
                cpu_frame(r, opts)
            }
            Engine::Gl(gs) => {
                let req = self.prepared.request(opts, camera);
                match gpu::render::render(gs, &req, None) {
                    Err(crate::Error::Unfinished(why)) if opts.instanced_fallback.is_some() => {
                        // The attempt is this frame's time, as `auto`'s fallback's is.
                        self.pending_ms += t0.elapsed().as_secs_f64() * 1e3;
                        self.take_instances_flat(&why)?;
                        return self.render(camera);
                    }
                    r => r?,
                }
            }
        };
        let wall_ms = t0.elapsed().as_secs_f64() * 1e3 + std::mem::take(&mut self.pending_ms);
        Ok(self
            .prepared
            .rendered(opts, self.plan, out, self.device.clone(), wall_ms))
    }

    /// `auto`'s fallback for a scene with instances on the GPU's two levels where the
    /// driver cut the compute kernel's loops short (`why`): as for any scene, a fragment
    /// kernel ([`RenderOptions::instanced_fallback`]) renders it, on the same two levels
    /// and upload where it walks them (an untextured scene); else the scene is prepared
    /// flat first (its structure the one asked for: `auto`'s for a flat scene, or the
    /// uniform grid named), with the one warning line that says so. This frame and the
    /// next render it; the set-up is charged to this frame.
    fn take_instances_flat(&mut self, why: &str) -> Result<()> {
        let Engine::Gl(gs) = &self.engine else {
            unreachable!("only a GPU renderer meets the compute kernel's loop limit")
        };
        let ctx = gs.ctx();
        let (kernel, accel) = self.opts.instanced_fallback.expect("checked by the caller");
        if self.opts.two_level_blocks(true).is_empty() {
            let mut opts = RenderOptions {
                instanced_fallback: None,
                ..self.opts.clone()
            };
            opts.gpu.kernel = kernel.kernel();
            self.plan = Plan::resolve(&opts, self.prepared.summary.kind, Some(&ctx.info))?;
            self.opts = opts;
            // As `auto`'s fallback says it for any scene (`gpu::render::wing`).
            eprintln!(
                "fragtrace: notice: the compute kernel did not finish ({why}); rendering the \
                 instances' two levels with the {kernel} kernel"
            );
            return Ok(());
        }
        let mut opts = RenderOptions {
            accel,
            instanced_fallback: None,
            ..self.opts.clone()
        };
        opts.gpu.kernel = kernel.kernel();
        let opts = opts.on_backend(true);
        let t0 = Instant::now();
        let prepared: &'p Prepared<'p> = self.prepared;
        if prepared.flat.get().is_none() {
            let given = &*prepared.scene;
            let flat = prepare_flat(given, &opts, || {
                let cut = why.split(';').next().unwrap_or(why);
                format!(
                    "the compute kernel, which walks them stored once, was cut short by the \
                     driver's loop limit ({cut}); --backend cpu --accel bvh walks them stored \
                     once"
                )
            })?;
            // Flattened, the scene is owned: no copy is made.
            let flat = Prepared {
                scene: Cow::Owned(flat.scene.into_owned()),
                accel: flat.accel,
                summary: flat.summary,
                flat: Default::default(),
            };
            let _ = prepared.flat.set(Box::new(flat));
        }
        let flat: &'p Prepared<'p> = prepared.flat.get().expect("set above");
        let plan = Plan::resolve(&opts, flat.summary.kind, Some(&ctx.info))?;
        let gs = GpuScene::new(ctx, &flat.scene, &flat.accel, opts.gpu.no_specialize)?
            .with_program_cache(opts.gpu.shader_cache.open(&ctx.info));
        self.prepared = flat;
        self.opts = opts;
        self.plan = plan;
        self.engine = Engine::Gl(Box::new(gs));
        self.pending_ms += t0.elapsed().as_secs_f64() * 1e3;
        Ok(())
    }

    /// What this renderer runs.
    pub fn plan(&self) -> Plan {
        self.plan
    }

    /// The GPU scene, for a GPU renderer.
    pub fn gpu_scene(&self) -> Option<&GpuScene<'_>> {
        match &self.engine {
            Engine::Gl(gs) => Some(gs),
            Engine::Cpu64(_)
            | Engine::Cpu32(_)
            | Engine::Cpu32Simd(_)
            | Engine::Cpu64Bvh(_)
            | Engine::Cpu32Bvh(_)
            | Engine::Cpu64Inst(_)
            | Engine::Cpu32Inst(_) => None,
        }
    }
}

/// One CPU frame (of the region's pixels, or the whole image's) with a progress bar over
/// its rows.
fn cpu_frame<T: crate::cpu::real::Real, W: Trace<T>>(
    r: &CpuRenderer<'_, T, W>,
    opts: &RenderOptions,
) -> BackendOutput {
    let px = opts.pixels();
    let progress = crate::progress::Progress::bar(opts.progress, px.height() as u64, "rows");
    r.render_region(
        opts.width,
        opts.height,
        px,
        opts.spp,
        opts.readback,
        &progress,
    )
}

/// Builds the acceleration structure and renders `scene` on the CPU.
pub fn render_cpu(scene: &Scene, opts: &RenderOptions) -> Result<Rendered> {
    let opts = &opts.on_backend(false);
    prepare(scene, opts)?.render_cpu(opts)
}

/// Builds the acceleration structure and renders `scene` on the GPU in `ctx` (the kernel
/// `opts.gpu.kernel` resolves to).
pub fn render_gl_with(ctx: &GlContext, scene: &Scene, opts: &RenderOptions) -> Result<Rendered> {
    render_gl_built(ctx, scene, opts, None)
}

/// [`render_gl_with`], with the structure `built` where it was prepared before the context
/// was open ([`crate::overlap`]) with the options the context settles: used where they
/// build the same one (the same structure and configuration, the scene's own triangles
/// only), else built again here.
pub(crate) fn render_gl_built(
    ctx: &GlContext,
    scene: &Scene,
    opts: &RenderOptions,
    built: Option<(&Prepared<'_>, &RenderOptions)>,
) -> Result<Rendered> {
    let opts = &opts.on_context(scene, Some(&ctx.info));
    opts.validate()?;
    // The pixels rendered must fit the driver's textures and viewport before any work is
    // done (a tile of a poster larger than the limit does).
    let px = opts.pixels();
    ctx.info.check_image_size(px.width(), px.height())?;
    let same = |o: &RenderOptions| {
        !scene.has_instances()
            && o.backend == opts.backend
            && o.accel_kind() == opts.accel_kind()
            && o.grid == opts.grid
            && o.irregular == opts.irregular
    };
    match built.filter(|(_, o)| same(o)) {
        Some((p, _)) => p.render_gl(ctx, opts),
        None => prepare(scene, opts)?.render_gl(ctx, opts),
    }
}

/// Renders with the backend chosen in `opts` (see [`context_for`]; its notice is shown
/// with `opts.progress`, which `-q` turns off with the progress display).
pub fn render(scene: &Scene, opts: &RenderOptions) -> Result<Rendered> {
    let t = crate::clock::Instant::now();
    match context_for(opts, scene, opts.progress)? {
        (Some(ctx), opts) => {
            let context_ms = t.elapsed().as_secs_f64() * 1e3;
            let mut out = render_gl_with(&ctx, scene, &opts)?;
            if let Some(g) = out.stats.gpu.as_mut() {
                g.context_ms = context_ms;
            }
            Ok(out)
        }
        (None, opts) => render_cpu(scene, &opts),
    }
}
