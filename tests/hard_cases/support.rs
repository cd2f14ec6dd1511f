//! What the hard cases share: one f32 test ray that every backend traces, tracing and
//! rendering on every backend and structure, scene builders, and the per-backend report
//! that prints every backend's line before a case fails.
//!
//! The acceleration structure is a dimension of the backend list: each of the four
//! backends (CPU f64, CPU f32, GL with the faithful multipass kernel, GL with the compute
//! kernel) runs once on the uniform grid and once on the irregular grid, and the CPU's two
//! once more on the BVH (`--accel bvh`, which the GPU does not walk), so a case's
//! `[_; NB]` results read in [`BACKENDS`] order and every per-backend loop covers the three
//! structures and both GL kernels (the fragment kernels share the multipass kernel's step
//! chunk pass by pass, tests/gpu_backend.rs; the compute kernel runs it in one dispatch:
//! `trace_rays` through `wave.comp`, renders through `render.comp`). The GL backends are
//! the grids' only ([`ACCELS`], [`is_gl`]): the BVH's two entries follow the grids' eight,
//! at the positions a third structure's CPU f64 and CPU f32 would take, so
//! [`precision_of`] and `bi % PER` read them as for the grids. The reference, [`F64`], is
//! the f64 CPU on the uniform grid: for the irregular and BVH backends it is an answer
//! from another structure.

use std::time::Instant;

use fragtrace::accel::{
    AccelKind, AccelRef, Bvh, Grid, GridConfig, GridRes, IrregularConfig, IrregularGrid,
};
use fragtrace::compare::compare;
use fragtrace::cpu::real::{Real, V3};
use fragtrace::cpu::simd::Isa;
use fragtrace::cpu::traverse::{CellWalk, GridWalker, Ray, Trace, Work};
use fragtrace::cpu::traverse_bvh::BvhWalker;
use fragtrace::cpu::traverse_packet::PacketIsa;
use fragtrace::cpu::walker::Walker;
use fragtrace::gpu::options::GpuOptions;
use fragtrace::gpu::options::Kernel;
use fragtrace::gpu::render::{trace_rays_on, GpuRay};
use fragtrace::gpu::scene::GpuScene;
use fragtrace::gpu::shader::{Query, RayState};
use fragtrace::gpu::GlContext;
use fragtrace::image_io::Image;
use fragtrace::options::{Backend, CpuPath, Precision, RenderOptions};
use fragtrace::render::{render_cpu, render_gl_with, Rendered};
use fragtrace::scene::{shapes, Camera, Light, Material, Scene, Triangle, NO_NORMAL};
use fragtrace::technique::Techniques;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// "No upper bound" for a ray, as every backend spells it (GLSL 1.20 has no infinity).
pub const BIG: f32 = 1.0e30;
/// The grids, which every backend walks (the GL batches index them), in [`BACKENDS`]
/// order; the BVH, CPU only, follows them ([`accel_of`]).
pub const ACCELS: [AccelKind; 2] = [AccelKind::Uniform, AccelKind::Irregular];
/// Every structure the CPU walks, in [`BACKENDS`] order: the grids, then the BVH.
pub const CPU_ACCELS: [AccelKind; 3] = [AccelKind::Uniform, AccelKind::Irregular, AccelKind::Bvh];
/// Backends per grid (CPU f64, CPU f32, GL multipass, GL compute).
pub const PER: usize = 4;
/// The grids' backends: backends per grid times grids (the first `NG` of [`BACKENDS`]).
pub const NG: usize = 8;
/// Every backend: the grids' [`NG`], then the BVH's CPU f64 and CPU f32.
pub const NB: usize = NG + 2;
/// Backend names, in the order results are reported: every `[_; NB]` below is in this
/// order, the uniform grid's four first, the BVH's two last (a `[_; PER]` of one grid is
/// in this order too).
pub const BACKENDS: [&str; NB] = [
    "CPU f64 uniform",
    "CPU f32 uniform",
    "GL uniform",
    "GL compute uniform",
    "CPU f64 irregular",
    "CPU f32 irregular",
    "GL irregular",
    "GL compute irregular",
    "CPU f64 bvh",
    "CPU f32 bvh",
];
/// Index of the f64 CPU on the uniform grid, the reference, in [`BACKENDS`].
pub const F64: usize = 0;

/// Index in [`BACKENDS`] of the first backend (CPU f64) of the structure `kind`.
pub fn first_of(kind: AccelKind) -> usize {
    CPU_ACCELS.iter().position(|&k| k == kind).unwrap() * PER
}

/// True for the GL backends of [`BACKENDS`] (the grids' only).
pub fn is_gl(bi: usize) -> bool {
    bi < NG && bi % PER >= 2
}

/// The GL kernel of backend `bi` of [`BACKENDS`] (only meaningful where [`is_gl`]).
pub fn kernel_of(bi: usize) -> Kernel {
    if bi % PER == 3 {
        Kernel::Compute
    } else {
        Kernel::Multipass
    }
}

/// The GL kernels of one structure's backends, in [`BACKENDS`] order.
pub const GL_KERNELS: [Kernel; 2] = [Kernel::Multipass, Kernel::Compute];

/// The structure of backend `bi` of [`BACKENDS`].
pub fn accel_of(bi: usize) -> AccelKind {
    if bi < NG {
        ACCELS[bi / PER]
    } else {
        AccelKind::Bvh
    }
}

/// The precision of backend `bi` of [`BACKENDS`] (GL computes in f32).
pub fn precision_of(bi: usize) -> Precision {
    if bi.is_multiple_of(PER) {
        Precision::F64
    } else {
        Precision::F32
    }
}
/// Image width of the render cases.
pub const W: u32 = 48;
/// Image height of the render cases.
pub const H: u32 = 36;

// ---------------------------------------------------------------------------------------
// The per-backend report
// ---------------------------------------------------------------------------------------

/// Collects a test's failures so that every backend prints its line before the test fails
/// (the figures of the backends that pass are what docs/robustness.md tabulates).
#[derive(Default)]
pub struct Checks(Vec<String>);

impl Checks {
    /// No failure yet.
    pub fn new() -> Self {
        Checks::default()
    }

    /// Prints `[case] who: line`; a failure unless `ok`.
    pub fn line(&mut self, case: &str, who: &str, ok: bool, line: impl AsRef<str>) {
        let text = format!("[{case}] {who}: {}", line.as_ref());
        println!("{text}");
        if !ok {
            self.0.push(text);
        }
    }

    /// Records a failure without a measurement line.
    pub fn fail(&mut self, msg: impl Into<String>) {
        self.0.push(msg.into());
    }

    /// Fails the test with every recorded failure.
    pub fn done(self) {
        assert!(self.0.is_empty(), "FAILED:\n{}", self.0.join("\n"));
    }
}

// ---------------------------------------------------------------------------------------
// Scene builders
// ---------------------------------------------------------------------------------------

/// A camera with +y up.
pub fn camera(eye: Vec3, look_at: Vec3, vfov_deg: f32) -> Camera {
    Camera {
        eye,
        look_at,
        up: Vec3::Y,
        vfov_deg,
    }
}

/// The ray cases' camera: at z = 10 looking at the origin.
pub fn default_camera() -> Camera {
    camera(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, 45.0)
}

/// The ray cases' scene: default camera and one default material (index returned).
pub fn plain_scene() -> (Scene, u32) {
    let mut s = Scene::empty(default_camera());
    let m = s.add_material(Material::default());
    (s, m)
}

/// A white point light.
pub fn light(position: Vec3, intensity: f32) -> Light {
    Light {
        position,
        color: Vec3::ONE,
        intensity,
    }
}

/// A diffuse material of colour `albedo`.
pub fn diffuse(albedo: Vec3) -> Material {
    Material {
        albedo,
        ..Material::default()
    }
}

/// Clear glass (no local shading, all light transmitted) of index `ior`.
pub fn glass(ior: f32, fresnel: bool) -> Material {
    Material {
        albedo: Vec3::ONE,
        ka: 0.0,
        kd: 0.0,
        kt: Vec3::ONE,
        ior,
        fresnel,
        ..Material::default()
    }
}

/// Appends an indexed mesh, mapped by `p * scale + offset` (in f64, rounded once to f32);
/// `normals` (one per position) make it smooth-shaded. Returns its triangle index range.
pub fn add_mesh(
    s: &mut Scene,
    positions: &[Vec3],
    normals: Option<&[Vec3]>,
    tris: &[[u32; 3]],
    material: u32,
    scale: f64,
    offset: DVec3,
) -> std::ops::Range<u32> {
    let base = s.positions.len() as u32;
    let nbase = s.normals.len() as u32;
    s.positions.extend(
        positions
            .iter()
            .map(|p| (p.as_dvec3() * scale + offset).as_vec3()),
    );
    if let Some(n) = normals {
        s.normals.extend_from_slice(n);
    }
    let first = s.triangles.len() as u32;
    for t in tris {
        s.triangles.push(Triangle {
            v: t.map(|i| base + i),
            n: if normals.is_some() {
                t.map(|i| nbase + i)
            } else {
                [NO_NORMAL; 3]
            },
            material,
        });
    }
    first..s.triangles.len() as u32
}

/// The closed unit-radius icosphere with `n` subdivisions, centred at `offset`, scaled by
/// `scale`, smooth-shaded (its vertex normals) or flat.
pub fn add_sphere(
    s: &mut Scene,
    n: u32,
    smooth: bool,
    material: u32,
    scale: f64,
    offset: DVec3,
) -> std::ops::Range<u32> {
    let (p, nrm, t) = shapes::sphere(n);
    add_mesh(
        s,
        &p,
        smooth.then_some(&nrm[..]),
        &t,
        material,
        scale,
        offset,
    )
}

/// An axis-aligned box of full extents `size` centred at `centre` (scaled by `scale`).
pub fn add_box(
    s: &mut Scene,
    size: Vec3,
    material: u32,
    scale: f64,
    centre: DVec3,
) -> std::ops::Range<u32> {
    let (p, t) = shapes::cuboid(size);
    add_mesh(s, &p, None, &t, material, scale, centre)
}

/// A quad a, b, c, d as two triangles (a, b, c) and (a, c, d).
pub fn add_quad(s: &mut Scene, q: [Vec3; 4], material: u32) -> [u32; 2] {
    [
        s.add_triangle(q[0], q[1], q[2], material),
        s.add_triangle(q[0], q[2], q[3], material),
    ]
}

/// The horizontal quad y = `y` over [-half, half]² around `centre` (x, z), in f64 then
/// rounded to f32.
pub fn add_ground(s: &mut Scene, y: f64, half: f64, centre: DVec3, material: u32) -> [u32; 2] {
    let q = [(-1.0, -1.0), (-1.0, 1.0), (1.0, 1.0), (1.0, -1.0)]
        .map(|(x, z)| (DVec3::new(x * half, y, z * half) + centre).as_vec3());
    add_quad(s, q, material)
}

/// A quad wound so that its normal points away from `inside` (closed meshes for glass).
pub fn add_quad_outward(s: &mut Scene, q: [Vec3; 4], inside: Vec3, material: u32) {
    let n = (q[1] - q[0]).cross(q[2] - q[0]);
    let c = (q[0] + q[1] + q[2] + q[3]) / 4.0;
    if n.dot(c - inside) > 0.0 {
        add_quad(s, q, material);
    } else {
        add_quad(s, [q[0], q[3], q[2], q[1]], material);
    }
}

/// The three structures of one scene, built once and traced by every backend (the BVH by
/// the CPU's only).
pub struct Accels {
    /// The uniform grid.
    pub uniform: Grid,
    /// The irregular grid.
    pub irregular: IrregularGrid,
    /// The 4-wide BVH (it has no parameters).
    pub bvh: Bvh,
}

impl Accels {
    /// The structure `kind`, borrowed.
    pub fn get(&self, kind: AccelKind) -> AccelRef<'_> {
        match kind {
            AccelKind::Uniform => (&self.uniform).into(),
            AccelKind::Irregular => (&self.irregular).into(),
            AccelKind::Bvh => (&self.bvh).into(),
        }
    }

    /// The grids' resolutions (the irregular grid's top and virtual ones) and the BVH's
    /// nodes, for the report.
    pub fn describe(&self) -> String {
        format!(
            "uniform {:?}, irregular top {:?} virtual {:?}, bvh {} nodes",
            self.uniform.res,
            self.irregular.top_res,
            self.irregular.res,
            self.bvh.nodes.len()
        )
    }
}

/// The three structures, the grids with their default (automatic) parameters.
pub fn accels(scene: &Scene) -> Accels {
    Accels {
        uniform: auto_grid(scene),
        irregular: IrregularGrid::build(scene, &IrregularConfig::default()).unwrap(),
        bvh: Bvh::build(scene).unwrap(),
    }
}

/// A uniform grid of exactly `res` cells, an irregular grid with as many top cells per
/// triangle as that grid has cells (it has no fixed resolution; its top grid is as fine,
/// so the case's triangles are split over as many cells, with its own cell faces), and the
/// BVH (the same as [`accels`]'s: it has no parameters).
pub fn accels_fixed(scene: &Scene, res: [u32; 3]) -> Accels {
    let cells = res.iter().map(|&r| r as f32).product::<f32>();
    let cfg = IrregularConfig {
        top_density: cells / scene.triangles.len().max(1) as f32,
        ..IrregularConfig::default()
    };
    Accels {
        uniform: fixed_grid(scene, res),
        irregular: IrregularGrid::build(scene, &cfg).unwrap(),
        bvh: Bvh::build(scene).unwrap(),
    }
}

/// The uniform grid with the default (automatic) resolution.
pub fn auto_grid(scene: &Scene) -> Grid {
    Grid::build(scene, &GridConfig::default()).unwrap()
}

/// A uniform grid of exactly `res` cells.
pub fn fixed_grid(scene: &Scene, res: [u32; 3]) -> Grid {
    Grid::build(
        scene,
        &GridConfig {
            res: GridRes::Fixed(res),
            ..GridConfig::default()
        },
    )
    .unwrap()
}

// ---------------------------------------------------------------------------------------
// Single rays on every backend
// ---------------------------------------------------------------------------------------

/// One test ray in f32, the precision the GPU stores; the f64 backend converts it exactly.
#[derive(Clone, Copy, Debug)]
pub struct TRay {
    pub o: Vec3,
    pub d: Vec3,
    pub t_max: f32,
}

impl TRay {
    /// A ray without an upper bound.
    pub fn new(o: Vec3, d: Vec3) -> Self {
        TRay { o, d, t_max: BIG }
    }
    /// From `o` through `target` (both rounded to f32 first, direction computed in f32).
    pub fn towards(o: DVec3, target: DVec3) -> Self {
        let o = o.as_vec3();
        TRay::new(o, target.as_vec3() - o)
    }
    /// The ray of a CPU-spawned ray, rounded to f32 (what the GPU would store).
    pub fn from_cpu<T: Real>(r: &Ray<T>) -> Self {
        TRay {
            o: r.o.to_dvec3().as_vec3(),
            d: r.d.to_dvec3().as_vec3(),
            t_max: r.t_max.to_f64().min(BIG as f64) as f32,
        }
    }
    /// The same ray in the CPU's precision `T` (exact conversion).
    pub fn cpu<T: Real>(&self) -> Ray<T> {
        Ray {
            o: V3::from_vec3(self.o),
            d: V3::from_vec3(self.d),
            t_min: T::ZERO,
            t_max: T::from_f32(self.t_max),
        }
    }
    /// The same ray for `trace_rays`.
    pub fn gpu(&self) -> GpuRay {
        GpuRay {
            o: self.o,
            d: self.d,
            t_max: self.t_max,
        }
    }
    /// The point at parameter `t`, in f64.
    pub fn at(&self, t: f64) -> DVec3 {
        self.o.as_dvec3() + self.d.as_dvec3() * t
    }
}

/// What one backend found for one ray: (t, triangle) of the hit and the work done
/// (cells visited plus triangle tests, the `steps` AOV).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Found {
    pub hit: Option<(f64, u32)>,
    pub steps: f64,
    /// GL only: the final ray state (`Invalid` = missed the grid box).
    pub state: Option<RayState>,
}

impl Found {
    /// The triangle hit, if any.
    pub fn tri(&self) -> Option<u32> {
        self.hit.map(|h| h.1)
    }
}

/// The CPU's scalar walk of `accel` in precision `T` with `techniques`, whichever
/// structure it is: the grids' [`Walker`], the BVH's [`BvhWalker::new`].
pub fn cpu_tracer<'a, T: Real>(
    scene: &Scene,
    accel: impl Into<AccelRef<'a>>,
    techniques: Techniques,
) -> Box<dyn Trace<T> + 'a> {
    match accel.into() {
        AccelRef::Bvh(b) => Box::new(BvhWalker::<T>::new(scene, b, techniques)),
        grid => Box::new(Walker::<T>::new(scene, grid.grid().unwrap(), techniques)),
    }
}

/// Closest hits through `tracer`, with the work of each (nodes or cells visited plus
/// triangle tests).
fn closest_through<T: Real>(tracer: &dyn Trace<T>, rays: &[TRay]) -> Vec<Found> {
    rays.par_iter()
        .map(|r| {
            let mut w = Work::default();
            let h = tracer.closest_hit(&r.cpu::<T>(), &mut w);
            Found {
                hit: h.map(|h| (h.t.to_f64(), h.tri)),
                steps: (w.cells + w.tests) as f64,
                state: None,
            }
        })
        .collect()
}

/// Whether `T` is f32 (the precision of the BVH's vectorised walk).
fn is_f32<T: Real>() -> bool {
    std::any::TypeId::of::<T>() == std::any::TypeId::of::<f32>()
}

/// Closest hits on the CPU in precision `T`, through any of the three structures (the
/// scalar walks). On the BVH in f32 the vectorised walk ([`BvhWalker::vectorised`], the
/// renderer's default) must also return the same hits, bit for bit, and the same work.
pub fn cpu_closest<'a, T: Real>(
    scene: &Scene,
    accel: impl Into<AccelRef<'a>>,
    rays: &[TRay],
) -> Vec<Found> {
    let accel = accel.into();
    let found = closest_through(&*cpu_tracer::<T>(scene, accel, Techniques::default()), rays);
    if let (AccelRef::Bvh(b), true) = (accel, is_f32::<T>()) {
        let v = BvhWalker::vectorised(scene, b, Techniques::default(), Isa::detect());
        let simd = closest_through::<f32>(&v, rays);
        let differ = (0..rays.len()).filter(|&k| simd[k] != found[k]).count();
        assert!(
            differ == 0,
            "the BVH's vectorised f32 walk ({}) differs from the scalar one on {differ} of {} rays, e.g. ray {:?}",
            v.isa().name(),
            rays.len(),
            (0..rays.len())
                .find(|&k| simd[k] != found[k])
                .map(|k| (rays[k], found[k], simd[k]))
        );
        // The packet walk (the renderer's default): the same hits (its work is counted per
        // packet).
        for_each_packet_walk(scene, b, rays, |packets, p, batch| {
            let mut hits = vec![None; batch.len()];
            let mut work = vec![Work::default(); batch.len()];
            p.closest_hits(batch, &mut hits, &mut work);
            let differ: Vec<usize> = (0..rays.len())
                .filter(|&k| hits[k].map(|h| (h.t as f64, h.tri)) != found[k].hit)
                .collect();
            assert!(
                differ.is_empty(),
                "the BVH's {}-packet walk differs from the scalar one on {} of {} rays, e.g. ray {:?}",
                packets.name(),
                differ.len(),
                rays.len(),
                differ.first().map(|&k| (rays[k], found[k], hits[k]))
            );
        });
    }
    found
}

/// Runs `check` on the BVH's packet walk of each unit this CPU has (AVX-512, AVX2), with
/// `rays` as one f32 batch.
fn for_each_packet_walk(
    scene: &Scene,
    bvh: &fragtrace::accel::bvh::Bvh,
    rays: &[TRay],
    mut check: impl FnMut(PacketIsa, &BvhWalker<'_, f32>, &[Ray<f32>]),
) {
    let batch: Vec<_> = rays.iter().map(|r| r.cpu::<f32>()).collect();
    for packets in [PacketIsa::Avx512, PacketIsa::Avx2] {
        if packets.available() {
            let p =
                BvhWalker::with_packets(scene, bvh, Techniques::default(), Isa::detect(), packets);
            check(packets, &p, &batch);
        }
    }
}

/// Any-hit answers on the CPU in precision `T`, through any of the three structures (on
/// the BVH in f32 the vectorised walk must give the same answers).
pub fn cpu_any<'a, T: Real>(
    scene: &Scene,
    accel: impl Into<AccelRef<'a>>,
    rays: &[TRay],
) -> Vec<bool> {
    let accel = accel.into();
    let tracer = cpu_tracer::<T>(scene, accel, Techniques::default());
    let any: Vec<bool> = rays
        .par_iter()
        .map(|r| tracer.any_hit(&r.cpu::<T>(), &mut Work::default()))
        .collect();
    if let (AccelRef::Bvh(b), true) = (accel, is_f32::<T>()) {
        let v = BvhWalker::vectorised(scene, b, Techniques::default(), Isa::detect());
        let simd: Vec<bool> = rays
            .par_iter()
            .map(|r| v.any_hit(&r.cpu::<f32>(), &mut Work::default()))
            .collect();
        assert!(
            simd == any,
            "the BVH's vectorised f32 any-hit ({}) differs from the scalar one",
            v.isa().name()
        );
        for_each_packet_walk(scene, b, rays, |packets, p, batch| {
            let mut hit = vec![false; batch.len()];
            p.any_hits(batch, &mut hit, &mut Work::default());
            assert!(
                hit == any,
                "the BVH's {}-packet any-hit differs from the scalar one",
                packets.name()
            );
        });
    }
    any
}

/// Brute force over every triangle (no grid) in precision `T`: the traversal's reference.
pub fn brute<T: Real>(scene: &Scene, grid: &Grid, rays: &[TRay]) -> Vec<Option<(f64, u32)>> {
    let accel = GridWalker::<T>::new(scene, grid);
    rays.par_iter()
        .map(|r| {
            accel
                .brute_force(&r.cpu::<T>())
                .map(|h| (h.t.to_f64(), h.tri))
        })
        .collect()
}

/// Traces rays through the GL traversal and intersection passes of `kernel` (the compute
/// kernel: `wave.comp`). Asserts the basics every case needs: the trace terminates (an
/// error otherwise), every ray ends in a final state, and no hit parameter or step count
/// is NaN.
pub fn gl_trace<'a>(
    ctx: &GlContext,
    scene: &Scene,
    accel: impl Into<AccelRef<'a>>,
    rays: &[TRay],
    q: Query,
    kernel: Kernel,
) -> Vec<Found> {
    gl_trace_with(ctx, scene, accel, rays, q, kernel, false)
}

/// [`gl_trace`], with the irregular grid's faces skewed by an ulp where `skew` is set
/// ([`GpuScene::with_skewed_faces`]: how NVIDIA's fused multiply-add rounds them).
pub fn gl_trace_with<'a>(
    ctx: &GlContext,
    scene: &Scene,
    accel: impl Into<AccelRef<'a>>,
    rays: &[TRay],
    q: Query,
    kernel: Kernel,
    skew: bool,
) -> Vec<Found> {
    let accel: AccelRef<'a> = accel.into();
    let gpu: Vec<GpuRay> = rays.iter().map(TRay::gpu).collect();
    let t0 = Instant::now();
    let opts = GpuOptions {
        kernel,
        ..faithful()
    };
    let out = GpuScene::new(ctx, scene, accel, opts.no_specialize)
        .map(|gs| if skew { gs.with_skewed_faces() } else { gs })
        .and_then(|gs| trace_rays_on(&gs, &gpu, q, opts))
        .unwrap_or_else(|e| panic!("trace_rays ({kernel}) failed: {e}"));
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    if ms > 500.0 {
        println!(
            "    (GL {kernel} trace_rays of {} rays: {ms:.0} ms)",
            rays.len()
        );
    }
    out.iter()
        .enumerate()
        .map(|(k, g)| {
            assert!(
                matches!(
                    g.state,
                    RayState::Shading | RayState::Done | RayState::Invalid
                ),
                "ray {k} {:?} ended in state {:?}",
                rays[k],
                g.state
            );
            assert!(g.steps.is_finite(), "ray {k}: steps {}", g.steps);
            if let Some((t, _)) = g.hit {
                assert!(t.is_finite(), "ray {k}: hit t = {t}");
            }
            Found {
                hit: g.hit.map(|(t, i)| (t as f64, i)),
                steps: g.steps as f64,
                state: Some(g.state),
            }
        })
        .collect()
}

/// Closest hits on the four backends through one grid, in [`BACKENDS`] order.
pub fn closest_one<'a>(
    ctx: &GlContext,
    scene: &Scene,
    accel: impl Into<AccelRef<'a>>,
    rays: &[TRay],
) -> [Vec<Found>; PER] {
    let accel = accel.into();
    let [multipass, compute] = GL_KERNELS;
    [
        cpu_closest::<f64>(scene, accel, rays),
        cpu_closest::<f32>(scene, accel, rays),
        gl_trace(ctx, scene, accel, rays, Query::Closest, multipass),
        gl_trace(ctx, scene, accel, rays, Query::Closest, compute),
    ]
}

/// Closest hits on every backend and structure, in [`BACKENDS`] order.
pub fn closest_all(
    ctx: &GlContext,
    scene: &Scene,
    accels: &Accels,
    rays: &[TRay],
) -> [Vec<Found>; NB] {
    let [a, b, c, d] = closest_one(ctx, scene, &accels.uniform, rays);
    let [e, f, g, h] = closest_one(ctx, scene, &accels.irregular, rays);
    let [i, j] = closest_bvh(scene, &accels.bvh, rays);
    [a, b, c, d, e, f, g, h, i, j]
}

/// Closest hits on the BVH's two backends (CPU f64, CPU f32), in [`BACKENDS`] order.
pub fn closest_bvh(scene: &Scene, bvh: &Bvh, rays: &[TRay]) -> [Vec<Found>; 2] {
    [
        cpu_closest::<f64>(scene, bvh, rays),
        cpu_closest::<f32>(scene, bvh, rays),
    ]
}

/// Per backend, how many of `res`'s rays `bad` holds for (`bad` gets the ray's index).
pub fn count<const N: usize>(
    res: &[Vec<Found>; N],
    bad: impl Fn(usize, &Found) -> bool,
) -> [usize; N] {
    res.each_ref()
        .map(|r| r.iter().enumerate().filter(|(k, f)| bad(*k, f)).count())
}

// ---------------------------------------------------------------------------------------
// Images on every backend
// ---------------------------------------------------------------------------------------

/// GPU options with the thesis's faithful multipass kernel: the hard cases test it and the
/// compute kernel ([`kernel_of`]); the other fragment kernels run the multipass kernel's
/// step chunk pass by pass (tests/gpu_backend.rs checks they agree).
pub fn faithful() -> GpuOptions {
    GpuOptions {
        kernel: Kernel::Multipass,
        ..GpuOptions::default()
    }
}

/// Render options for a `W`x`H` image of `scene` on the uniform grid (the reference's
/// structure; [`opts_on`] for another).
pub fn opts(scene: &Scene, precision: Precision) -> RenderOptions {
    opts_on(scene, precision, AccelKind::Uniform)
}

/// Render options for a `W`x`H` image of `scene` on the structure `accel`.
pub fn opts_on(scene: &Scene, precision: Precision, accel: AccelKind) -> RenderOptions {
    let mut o = RenderOptions::for_scene(scene);
    o.gpu = faithful();
    o.width = W;
    o.height = H;
    o.precision = precision;
    o.accel = accel.into();
    o.backend = Backend::Cpu;
    o
}

/// Renders `scene` on every backend and structure, in [`BACKENDS`] order.
pub fn render_all(ctx: &GlContext, scene: &Scene) -> [Rendered; NB] {
    render_all_with(ctx, scene, Techniques::default())
}

/// [`render_all`] with the given robustness techniques (to show that a check fails when
/// the technique it guards is switched off).
pub fn render_all_with(ctx: &GlContext, scene: &Scene, techniques: Techniques) -> [Rendered; NB] {
    std::array::from_fn(|bi| {
        let mut o = RenderOptions {
            techniques,
            ..opts_on(scene, precision_of(bi), accel_of(bi))
        };
        if !is_gl(bi) {
            let r = render_cpu(scene, &o).unwrap();
            if o.precision == Precision::F32 {
                // The vectorised paths must take the scalar twin's decisions: the default
                // (ray packets on the BVH, which count their work per packet) the same
                // image and hits, the single-ray one the same work too.
                o.cpu_path = CpuPath::Scalar;
                let s = render_cpu(scene, &o).unwrap();
                o.cpu_path = CpuPath::Simd;
                let v = render_cpu(scene, &o).unwrap();
                assert_same_cpu_paths(&r, &s, false, &format!("{} (packet)", BACKENDS[bi]));
                assert_same_cpu_paths(&v, &s, true, &format!("{} (simd)", BACKENDS[bi]));
            }
            return r;
        }
        o.gpu.kernel = kernel_of(bi);
        let t0 = Instant::now();
        let gl = render_gl_with(ctx, scene, &o)
            .unwrap_or_else(|e| panic!("{} render: {e}", BACKENDS[bi]));
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        if ms > 1000.0 {
            println!("    ({} render: {ms:.0} ms)", BACKENDS[bi]);
        }
        gl
    })
}

/// RMSE of two images (linear values clamped to [0, 1]).
pub fn rmse(a: &Image, b: &Image) -> f64 {
    compare(a, b, 0.05, true).unwrap().rmse
}

/// Largest channel difference of two pixels.
pub fn px_diff(a: [f32; 3], b: [f32; 3]) -> f32 {
    (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max)
}

/// An image's pixels as RGB triples, row by row.
pub fn pixels(img: &Image) -> impl Iterator<Item = [f32; 3]> + '_ {
    img.data.chunks(3).map(|c| [c[0], c[1], c[2]])
}

/// Writes an image for inspection when a render case fails (best effort).
pub fn dump(name: &str, img: &Image) {
    let p = std::env::temp_dir().join(format!("fragtrace-hard-{}.png", name.replace(' ', "")));
    if fragtrace::image_io::write_image(&p, img).is_ok() {
        println!("    wrote {}", p.display());
    }
}

/// The f32 CPU's vectorised and scalar paths rendered the same image and AOVs, bit for bit
/// (`--cpu-path`, src/cpu/simd_walk.rs, src/cpu/traverse_packet.rs); with `work_too`, the
/// same `steps` AOV and work counters as well (the single-ray paths; packets count the
/// work their lanes did).
pub fn assert_same_cpu_paths(simd: &Rendered, scalar: &Rendered, work_too: bool, who: &str) {
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert!(
        bits(&simd.image.data) == bits(&scalar.image.data),
        "{who}: the vectorised and scalar paths' images differ"
    );
    let px = |r: &Rendered| {
        r.aov
            .pixels
            .iter()
            .map(|p| {
                (
                    p.depth.to_bits(),
                    p.primid.to_bits(),
                    p.normal.map(f32::to_bits),
                    if work_too { p.steps.to_bits() } else { 0 },
                )
            })
            .collect::<Vec<_>>()
    };
    assert!(
        px(simd) == px(scalar),
        "{who}: the vectorised and scalar paths' AOVs differ"
    );
    if !work_too {
        return;
    }
    assert_eq!(
        (simd.stats.cells_visited, simd.stats.triangle_tests),
        (scalar.stats.cells_visited, scalar.stats.triangle_tests),
        "{who}: the vectorised and scalar paths' work differs"
    );
}
