//! The hard-case robustness suite: 22 geometric and numeric corner cases, each run on every
//! backend — the CPU reference in f64 (ground truth), the CPU in f32 (the GPU's arithmetic)
//! and the GLSL 1.20 backend (llvmpipe here) — through single rays (`Accel::<T>` and
//! `gpu::render::trace_rays`) or small images (`render_cpu` / `render_gl_with`).
//!
//! Every test prints what it measured, one line per backend, prefixed `[case NN]`;
//! `docs/robustness.md` tabulates those numbers. Reproduce with
//! `cargo test --release --test hard_cases -- --nocapture`.
//!
//! Rays are built in f32 (the precision the GPU stores), so all three backends trace the
//! very same ray; the f64 backend converts them exactly. Seeded randomness prints its seed.
//! GL work is kept small (llvmpipe on two cores): images are 48x36, ray batches one
//! `trace_rays` call per scene and query.

mod common;
use common::Rng;
use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use fragtrace::accel::{Grid, GridConfig, GridRes};
use fragtrace::compare::compare;
use fragtrace::cpu::real::{Real, V3};
use fragtrace::cpu::shade::{offset_origin, secondary, surface};
use fragtrace::cpu::traverse::{Accel, Ray, Work};
use fragtrace::gpu::layout::SceneTextures;
use fragtrace::gpu::render::{trace_rays, GpuOptions, GpuRay};
use fragtrace::gpu::shader::{Kernel, Query, RayState};
use fragtrace::gpu::{with_test_context, GlContext};
use fragtrace::image_io::Image;
use fragtrace::render::{render_cpu, render_gl_with, Backend, Precision, RenderOptions, Rendered};
use fragtrace::scene::{shapes, Camera, Light, Material, Scene, Triangle, NO_NORMAL};
use fragtrace::Error;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// "No upper bound" for a ray, as every backend spells it (GLSL 1.20 has no infinity).
const BIG: f32 = 1.0e30;
/// Backend names, in the order results are reported.
const BACKENDS: [&str; 3] = ["CPU f64", "CPU f32", "GL"];
/// Image size of the render cases.
const W: u32 = 48;
const H: u32 = 36;

// ---------------------------------------------------------------------------------------
// Shared helpers
// ---------------------------------------------------------------------------------------

fn camera(eye: Vec3, look_at: Vec3, vfov_deg: f32) -> Camera {
    Camera {
        eye,
        look_at,
        up: Vec3::Y,
        vfov_deg,
    }
}

fn default_camera() -> Camera {
    camera(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, 45.0)
}

/// Appends an indexed mesh, mapped by `p * scale + offset` (in f64, rounded once to f32);
/// `normals` (one per position) make it smooth-shaded. Returns its triangle index range.
fn add_mesh(
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

/// A quad a, b, c, d as two triangles (a, b, c) and (a, c, d).
fn add_quad(s: &mut Scene, q: [Vec3; 4], material: u32) -> [u32; 2] {
    [
        s.add_triangle(q[0], q[1], q[2], material),
        s.add_triangle(q[0], q[2], q[3], material),
    ]
}

/// A quad wound so that its normal points away from `inside` (closed meshes for glass).
fn add_quad_outward(s: &mut Scene, q: [Vec3; 4], inside: Vec3, material: u32) {
    let n = (q[1] - q[0]).cross(q[2] - q[0]);
    let c = (q[0] + q[1] + q[2] + q[3]) / 4.0;
    if n.dot(c - inside) > 0.0 {
        add_quad(s, q, material);
    } else {
        add_quad(s, [q[0], q[3], q[2], q[1]], material);
    }
}

/// One test ray in f32, the precision the GPU stores; the f64 backend converts it exactly.
#[derive(Clone, Copy, Debug)]
struct TRay {
    o: Vec3,
    d: Vec3,
    t_max: f32,
}

impl TRay {
    fn new(o: Vec3, d: Vec3) -> Self {
        TRay { o, d, t_max: BIG }
    }
    /// From `o` through `target` (both rounded to f32 first, direction computed in f32).
    fn towards(o: DVec3, target: DVec3) -> Self {
        let o = o.as_vec3();
        TRay::new(o, target.as_vec3() - o)
    }
    fn cpu<T: Real>(&self) -> Ray<T> {
        Ray {
            o: V3::from_vec3(self.o),
            d: V3::from_vec3(self.d),
            t_min: T::ZERO,
            t_max: T::from_f32(self.t_max),
        }
    }
    fn gpu(&self) -> GpuRay {
        GpuRay {
            o: self.o,
            d: self.d,
            t_max: self.t_max,
        }
    }
    fn at(&self, t: f64) -> DVec3 {
        self.o.as_dvec3() + self.d.as_dvec3() * t
    }
}

/// What one backend found for one ray: (t, triangle) of the hit and the work done
/// (cells visited plus triangle tests, the `steps` AOV).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Found {
    hit: Option<(f64, u32)>,
    steps: f64,
    /// GL only: the final ray state (`Invalid` = missed the grid box).
    state: Option<RayState>,
}

impl Found {
    fn tri(&self) -> Option<u32> {
        self.hit.map(|h| h.1)
    }
}

/// Closest hits on the CPU in precision `T`.
fn cpu_closest<T: Real>(scene: &Scene, grid: &Grid, rays: &[TRay]) -> Vec<Found> {
    let accel = Accel::<T>::new(scene, grid);
    rays.par_iter()
        .map(|r| {
            let mut w = Work::default();
            let h = accel.closest_hit(&r.cpu::<T>(), &mut w);
            Found {
                hit: h.map(|h| (h.t.to_f64(), h.tri)),
                steps: (w.cells + w.tests) as f64,
                state: None,
            }
        })
        .collect()
}

/// Any-hit answers on the CPU in precision `T`.
fn cpu_any<T: Real>(scene: &Scene, grid: &Grid, rays: &[TRay]) -> Vec<bool> {
    let accel = Accel::<T>::new(scene, grid);
    rays.par_iter()
        .map(|r| accel.any_hit(&r.cpu::<T>(), &mut Work::default()))
        .collect()
}

/// Traces rays through the GL traversal and intersection passes. Asserts the basics every
/// case needs: the trace terminates (an error otherwise), every ray ends in a final state,
/// and no hit parameter or step count is NaN.
fn gl_trace(ctx: &GlContext, scene: &Scene, grid: &Grid, rays: &[TRay], q: Query) -> Vec<Found> {
    let gpu: Vec<GpuRay> = rays.iter().map(TRay::gpu).collect();
    let t0 = Instant::now();
    let out = trace_rays(ctx, scene, grid, &gpu, q, faithful())
        .unwrap_or_else(|e| panic!("trace_rays failed: {e}"));
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    if ms > 500.0 {
        println!("    (GL trace_rays of {} rays: {ms:.0} ms)", rays.len());
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

/// Closest hits on all three backends, in [`BACKENDS`] order.
fn closest_all(ctx: &GlContext, scene: &Scene, grid: &Grid, rays: &[TRay]) -> [Vec<Found>; 3] {
    [
        cpu_closest::<f64>(scene, grid, rays),
        cpu_closest::<f32>(scene, grid, rays),
        gl_trace(ctx, scene, grid, rays, Query::Closest),
    ]
}

fn auto_grid(scene: &Scene) -> Grid {
    Grid::build(scene, &GridConfig::default()).unwrap()
}

fn fixed_grid(scene: &Scene, res: [u32; 3]) -> Grid {
    Grid::build(
        scene,
        &GridConfig {
            res: GridRes::Fixed(res),
            ..GridConfig::default()
        },
    )
    .unwrap()
}

/// GPU options with the thesis's faithful multipass kernel: the hard cases test it, and
/// the other kernels run the same step chunk (tests/gpu_backend.rs checks they agree).
fn faithful() -> GpuOptions {
    GpuOptions {
        kernel: Kernel::Multipass,
        ..GpuOptions::default()
    }
}

/// Render options for a `W`x`H` image of `scene`.
fn opts(scene: &Scene, precision: Precision) -> RenderOptions {
    let mut o = RenderOptions::for_scene(scene);
    o.gpu = faithful();
    o.width = W;
    o.height = H;
    o.precision = precision;
    o.backend = Backend::Cpu;
    o
}

/// Renders `scene` on all three backends, in [`BACKENDS`] order.
fn render_all(ctx: &GlContext, scene: &Scene) -> [Rendered; 3] {
    let t0 = Instant::now();
    let gl = render_gl_with(ctx, scene, &opts(scene, Precision::F32))
        .unwrap_or_else(|e| panic!("GL render failed: {e}"));
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    if ms > 1000.0 {
        println!("    (GL render: {ms:.0} ms)");
    }
    [
        render_cpu(scene, &opts(scene, Precision::F64)).unwrap(),
        render_cpu(scene, &opts(scene, Precision::F32)).unwrap(),
        gl,
    ]
}

/// Largest channel difference of two pixels.
fn px_diff(a: [f32; 3], b: [f32; 3]) -> f32 {
    (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max)
}

fn pixels(img: &Image) -> impl Iterator<Item = [f32; 3]> + '_ {
    img.data.chunks(3).map(|c| [c[0], c[1], c[2]])
}

/// Writes an image for inspection when a render case fails (best effort).
fn dump(name: &str, img: &Image) {
    let p = std::env::temp_dir().join(format!("fragtrace-hard-{name}.png"));
    if fragtrace::image_io::write_image(&p, img).is_ok() {
        println!("    wrote {}", p.display());
    }
}

/// The closed unit-radius icosphere with vertex normals.
fn sphere_mesh(n: u32) -> (Vec<Vec3>, Vec<Vec3>, Vec<[u32; 3]>) {
    shapes::sphere(n)
}

// ---------------------------------------------------------------------------------------
// Cases 1-2: seams, vertices, shared edges
// ---------------------------------------------------------------------------------------

/// Case 1: the classic seam ray, plus 4096 rays aimed at points of the shared diagonal
/// from both sides. Case 2: rays aimed exactly at every vertex and at points of every
/// shared edge of a closed icosphere and of a box, from inside and (front-facing) from
/// outside; the hit must lie at the aimed-at point.
#[test]
fn case_01_02_seams_vertices_and_edges() {
    let mut rng = Rng::new("case 01", 0x5ea_u64);
    // --- case 1
    let mut seam = Scene::empty(default_camera());
    let m = seam.add_material(Material::default());
    seam.add_triangle(
        Vec3::new(-5.0, -5.0, 0.0),
        Vec3::new(5.0, -5.0, 0.0),
        Vec3::new(5.0, 5.0, 0.0),
        m,
    );
    seam.add_triangle(
        Vec3::new(-5.0, -5.0, 0.0),
        Vec3::new(5.0, 5.0, 0.0),
        Vec3::new(-5.0, 5.0, 0.0),
        m,
    );
    let seam_grid = auto_grid(&seam);
    let mut seam_rays = vec![TRay::new(
        Vec3::new(0.0, 0.0, 10.0),
        Vec3::new(0.304_584_47, 0.304_584_47, -0.902_472_5),
    )];
    for k in 0..4096 {
        let s = rng.range(-4.9, 4.9);
        let side = if k % 2 == 0 { 1.0 } else { -1.0 };
        let o = DVec3::new(
            rng.range(-20.0, 20.0),
            rng.range(-20.0, 20.0),
            side * rng.range(0.5, 20.0),
        );
        seam_rays.push(TRay::towards(o, DVec3::new(s, s, 0.0)));
    }

    // --- case 2: icosphere (642 vertices, 1920 edges) and a box
    let mut rng = Rng::new("case 02", 0xed6e_u64);
    let (p, nrm, tris) = sphere_mesh(3);
    let mut sph = Scene::empty(default_camera());
    let m = sph.add_material(Material::default());
    add_mesh(&mut sph, &p, Some(&nrm), &tris, m, 1.0, DVec3::ZERO);
    let sph_grid = auto_grid(&sph);
    let mut edges: Vec<(u32, u32)> = tris
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    edges.sort_unstable();
    edges.dedup();
    assert_eq!(edges.len(), 1920);
    // (ray, aimed-at point)
    let mut sph_rays: Vec<(TRay, DVec3)> = Vec::new();
    let aim = |target: DVec3, rng: &mut Rng, out: &mut Vec<(TRay, DVec3)>| {
        // From inside, and from outside within 30 degrees of the outward radial direction
        // (front-facing, so the point is not on the silhouette).
        let o_in = rng.in_ball(0.6);
        out.push((TRay::towards(o_in, target), target));
        let n = target.normalize();
        let r = rng.dir();
        let tilt = (r - n * r.dot(n)).normalize_or_zero() * rng.range(0.0, 0.5);
        let o_out = target + (n + tilt).normalize() * rng.range(0.5, 5.0);
        out.push((TRay::towards(o_out, target), target));
    };
    for v in &p {
        aim(v.as_dvec3(), &mut rng, &mut sph_rays);
    }
    for &(a, b) in &edges {
        let (pa, pb) = (p[a as usize], p[b as usize]);
        // The f32 midpoint and a random point of the edge (within rounding of the edge).
        aim(((pa + pb) * 0.5).as_dvec3(), &mut rng, &mut sph_rays);
        let f = rng.f() as f32;
        aim((pa + (pb - pa) * f).as_dvec3(), &mut rng, &mut sph_rays);
    }

    let mut bx = Scene::empty(default_camera());
    let m = bx.add_material(Material::default());
    let (bp, bt) = shapes::cuboid(Vec3::new(2.0, 1.0, 3.0));
    add_mesh(
        &mut bx,
        &bp,
        None,
        &bt,
        m,
        1.0,
        DVec3::new(0.25, 0.5, -0.125),
    );
    let bx_grid = auto_grid(&bx);
    let c = DVec3::new(0.25, 0.5, -0.125);
    let h = DVec3::new(1.0, 0.5, 1.5);
    let mut bx_rays: Vec<(TRay, DVec3)> = Vec::new();
    // Points on the box: 8 corners, points on the 12 box edges, points on the 6 face
    // diagonals (the edges shared by a face's two triangles). "Outside" origins lie in the
    // open cone of the outward normals of every face through the point.
    let signs = [-1.0, 1.0];
    let mut box_points: Vec<(DVec3, DVec3)> = Vec::new(); // (point, sign of each axis or 0)
    for &sx in &signs {
        for &sy in &signs {
            for &sz in &signs {
                let s = DVec3::new(sx, sy, sz);
                box_points.push((c + s * h, s));
            }
        }
    }
    for axis in 0..3 {
        for &s1 in &signs {
            for &s2 in &signs {
                for f in [0.1, 0.5, 0.77] {
                    let mut s = DVec3::ZERO;
                    s[(axis + 1) % 3] = s1;
                    s[(axis + 2) % 3] = s2;
                    let mut q = c + s * h;
                    q[axis] = c[axis] + (2.0 * f - 1.0) * h[axis];
                    box_points.push((q, s));
                }
            }
        }
    }
    for t in bt.iter().step_by(2) {
        // Each face is (a, b, c) + (a, c, d): the diagonal is a-c.
        let (a, cc) = (
            bp[t[0] as usize].as_dvec3() + c,
            bp[t[2] as usize].as_dvec3() + c,
        );
        let n = ((bp[t[1] as usize] - bp[t[0] as usize])
            .cross(bp[t[2] as usize] - bp[t[0] as usize]))
        .as_dvec3()
        .normalize();
        for f in [0.25, 0.5, 0.625] {
            box_points.push((a + (cc - a) * f, n.round()));
        }
    }
    for &(q, s) in &box_points {
        for _ in 0..4 {
            let o_in = c + DVec3::new(
                rng.range(-0.9, 0.9),
                rng.range(-0.45, 0.45),
                rng.range(-1.4, 1.4),
            );
            bx_rays.push((TRay::towards(o_in, q), q));
            // Outward along every face normal at the point, a little sideways along the
            // others.
            let mut away = DVec3::ZERO;
            for a in 0..3 {
                away[a] = if s[a] != 0.0 {
                    s[a] * rng.range(0.2, 3.0)
                } else {
                    rng.range(-0.3, 0.3)
                };
            }
            bx_rays.push((TRay::towards(q + away, q), q));
        }
    }

    with_test_context(|ctx| {
        let res = closest_all(ctx, &seam, &seam_grid, &seam_rays);
        let mut fail = Vec::new();
        for (b, r) in BACKENDS.iter().zip(&res) {
            let misses = r.iter().filter(|f| f.hit.is_none()).count();
            println!(
                "[case 01] {b}: seam ray {}; diagonal rays: {misses} misses of {}",
                if r[0].hit.is_some() { "hits" } else { "MISSES" },
                r.len() - 1
            );
            if misses > 0 {
                fail.push(format!(
                    "case 01 {b}: {misses} rays leaked through the seam"
                ));
            }
        }
        for (name, scene, grid, rays) in [
            ("icosphere(3)", &sph, &sph_grid, &sph_rays),
            ("box", &bx, &bx_grid, &bx_rays),
        ] {
            let plain: Vec<TRay> = rays.iter().map(|r| r.0).collect();
            let res = closest_all(ctx, scene, grid, &plain);
            for (b, r) in BACKENDS.iter().zip(&res) {
                let mut misses = 0;
                let mut wrong_place = 0;
                let mut worst: f64 = 0.0;
                for (f, (ray, target)) in r.iter().zip(rays.iter()) {
                    match f.hit {
                        None => misses += 1,
                        Some((t, _)) => {
                            let e = (ray.at(t) - *target).length();
                            worst = worst.max(e);
                            if e > 1e-4 {
                                wrong_place += 1;
                            }
                        }
                    }
                }
                println!(
                    "[case 02] {b} {name}: {} rays at vertices/edges: {misses} misses, {wrong_place} hits away from the aimed point (max distance {worst:.2e})",
                    rays.len()
                );
                if misses + wrong_place > 0 {
                    fail.push(format!(
                        "case 02 {b} {name}: {misses} misses, {wrong_place} misplaced hits"
                    ));
                }
            }
        }
        assert!(fail.is_empty(), "{}", fail.join("\n"));
    });
}

// ---------------------------------------------------------------------------------------
// Cases 3-4: rays from inside a closed mesh
// ---------------------------------------------------------------------------------------

/// Rays from inside a closed icosphere (5 subdivisions, 20480 triangles), alone and over
/// a 16x16 ground quad, must all hit the sphere: the miss (or leak to the ground) rate must
/// stay at or below Embree's 0.002%. Case 4 repeats it with everything translated to about
/// 1e5, where the f32 spacing is 2^-7 = 0.0078 on a radius-1 sphere, and records the rates.
#[test]
fn case_03_04_rays_from_inside_closed_mesh() {
    const CPU_RAYS: usize = 100_000;
    const GL_RAYS: usize = 65_536;
    const EMBREE: f64 = 2e-5;
    let (p, nrm, tris) = sphere_mesh(5);
    let mut failures = Vec::new();
    let configs: [(&str, &str, bool, DVec3); 4] = [
        ("case 03", "sphere", false, DVec3::ZERO),
        ("case 03", "sphere+ground", true, DVec3::ZERO),
        (
            "case 04",
            "sphere at 1e5",
            false,
            DVec3::new(100_000.3, 99_999.7, 100_000.1),
        ),
        (
            "case 04",
            "sphere+ground at 1e5",
            true,
            DVec3::new(100_000.3, 99_999.7, 100_000.1),
        ),
    ];
    let mut prepared = Vec::new();
    for (k, &(case, name, ground, offset)) in configs.iter().enumerate() {
        let mut s = Scene::empty(default_camera());
        let m = s.add_material(Material::default());
        let range = add_mesh(&mut s, &p, Some(&nrm), &tris, m, 1.0, offset);
        if ground {
            let y = -1.2;
            let q = [(-8.0, -8.0), (-8.0, 8.0), (8.0, 8.0), (8.0, -8.0)]
                .map(|(x, z)| (DVec3::new(x, y, z) + offset).as_vec3());
            add_quad(&mut s, q, m);
        }
        let grid = auto_grid(&s);
        let mut rng = Rng::new(case, 0x1a5_1de + k as u64);
        let rays: Vec<TRay> = (0..CPU_RAYS)
            .map(|_| {
                let o = offset + rng.in_ball(0.9);
                TRay::new(o.as_vec3(), rng.dir().as_vec3())
            })
            .collect();
        prepared.push((case, name, s, grid, range, rays));
    }
    let leak = |f: &Found, range: &std::ops::Range<u32>| match f.hit {
        None => true,
        Some((t, tri)) => !range.contains(&tri) || !t.is_finite(),
    };
    // CPU first (outside the GL lock), then one GL context for the four batches.
    let mut cpu = Vec::new();
    for (_, _, s, grid, range, rays) in &prepared {
        let c64 = cpu_closest::<f64>(s, grid, rays);
        let c32 = cpu_closest::<f32>(s, grid, rays);
        cpu.push([
            c64.iter().filter(|f| leak(f, range)).count(),
            c32.iter().filter(|f| leak(f, range)).count(),
        ]);
    }
    let gl: Vec<usize> = with_test_context(|ctx| {
        prepared
            .iter()
            .map(|(_, _, s, grid, range, rays)| {
                let r = gl_trace(ctx, s, grid, &rays[..GL_RAYS], Query::Closest);
                r.iter().filter(|f| leak(f, range)).count()
            })
            .collect()
    });
    for (k, (case, name, _, grid, _, _)) in prepared.iter().enumerate() {
        let counts = [
            (cpu[k][0], CPU_RAYS),
            (cpu[k][1], CPU_RAYS),
            (gl[k], GL_RAYS),
        ];
        for (b, &(n, total)) in BACKENDS.iter().zip(&counts) {
            let rate = n as f64 / total as f64;
            println!(
                "[{case}] {b} {name} (grid {:?}): {n} of {total} rays missed or leaked = {:.4}%",
                grid.res,
                rate * 100.0
            );
            assert!(rate.is_finite());
            if *case == "case 03" && rate > EMBREE {
                failures.push(format!(
                    "{case} {b} {name}: miss rate {:.4}% > 0.002%",
                    rate * 100.0
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

// ---------------------------------------------------------------------------------------
// Case 5: no self-intersection of spawned rays
// ---------------------------------------------------------------------------------------

/// Random glass triangles at scales 1e-4 .. 1e4 (one scene per decade, the cluster offset
/// from the origin by up to 20 triangle sizes). Rays hit them; from each hit the reflected,
/// refracted and light rays are spawned with `offset_origin`, exactly as the renderer does,
/// and traced: none may hit its own triangle. On the CPU each precision spawns its own
/// rays; the GL check traces the f32 CPU's spawned rays with `trace_rays` (closest and any
/// hit), so it tests the GPU's intersection kernel against self-hits, not the GLSL spawn
/// pass (whose arithmetic is the twin of the f32 one).
#[test]
fn case_05_no_self_intersection() {
    let mut rng = Rng::new("case 05", 0x5e1f_u64);
    struct Prepared {
        scale: f64,
        scene: Scene,
        grid: Grid,
        primary: Vec<TRay>,
    }
    let mut scenes = Vec::new();
    for e in -4..=4 {
        let s = 10f64.powi(e);
        let mut scene = Scene::empty(default_camera());
        let m = scene.add_material(Material {
            kt: Vec3::ONE,
            kr: Vec3::splat(0.2),
            ior: 1.5,
            ..Material::default()
        });
        let offset = DVec3::new(
            rng.range(-20.0, 20.0),
            rng.range(-20.0, 20.0),
            rng.range(-20.0, 20.0),
        ) * s;
        let mut centroids = Vec::new();
        for _ in 0..300 {
            let c = offset
                + DVec3::new(
                    rng.range(-5.0, 5.0),
                    rng.range(-5.0, 5.0),
                    rng.range(-5.0, 5.0),
                ) * s;
            let v: Vec<Vec3> = (0..3)
                .map(|_| (c + rng.dir() * s * rng.range(0.2, 1.0)).as_vec3())
                .collect();
            scene.add_triangle(v[0], v[1], v[2], m);
            centroids.push(c);
        }
        scene.lights.push(Light {
            position: (offset + rng.dir() * 30.0 * s).as_vec3(),
            color: Vec3::ONE,
            intensity: 1.0,
        });
        let grid = auto_grid(&scene);
        let primary: Vec<TRay> = (0..1500)
            .map(|_| {
                let i = rng.below(300);
                let v = scene.triangle_vertices(i).map(|v| v.as_dvec3());
                let w = rng.bary(0.01);
                let target = v[0] * w[0] + v[1] * w[1] + v[2] * w[2];
                let o = offset + rng.dir() * 30.0 * s;
                TRay::towards(o, target)
            })
            .collect();
        scenes.push(Prepared {
            scale: s,
            scene,
            grid,
            primary,
        });
    }

    /// Spawned rays of one CPU precision: (own triangle, ray, kind), kind 0 reflected,
    /// 1 refracted, 2 towards the light (t_max = distance).
    fn spawn<T: Real>(p: &Prepared) -> Vec<(u32, TRay, Ray<T>, u8)> {
        let accel = Accel::<T>::new(&p.scene, &p.grid);
        let light = V3::<T>::from_vec3(p.scene.lights[0].position);
        let mut out = Vec::new();
        for r in &p.primary {
            let mut ray = r.cpu::<T>();
            ray.d = ray.d.normalize();
            let Some(hit) = accel.closest_hit(&ray, &mut Work::default()) else {
                continue;
            };
            let sp = surface(&p.scene, &accel.tris[hit.tri as usize], &hit, ray.d);
            let sec = secondary(&p.scene.materials[0], &sp, ray.d);
            let mut push = |d: V3<T>, t_max: T, kind: u8| {
                let o = offset_origin(&sp, d);
                let cpu = Ray {
                    o,
                    d,
                    t_min: T::ZERO,
                    t_max,
                };
                let f32ray = TRay {
                    o: o.to_dvec3().as_vec3(),
                    d: d.to_dvec3().as_vec3(),
                    t_max: t_max.to_f64().min(BIG as f64) as f32,
                };
                out.push((hit.tri, f32ray, cpu, kind));
            };
            push(sec.reflected, T::BIG, 0);
            if sec.kt.max_elem() > T::ZERO {
                push(sec.refracted, T::BIG, 1);
            }
            let to_l = light - sp.p;
            let o = offset_origin(&sp, to_l);
            let dl = light - o;
            let dist = dl.length();
            let cpu_l = dl * (T::ONE / dist);
            push(cpu_l, dist, 2);
        }
        out
    }
    fn self_hits<T: Real>(p: &Prepared, spawned: &[(u32, TRay, Ray<T>, u8)]) -> [usize; 3] {
        let accel = Accel::<T>::new(&p.scene, &p.grid);
        let mut n = [0usize; 3];
        for (own, _, ray, kind) in spawned {
            if let Some(h) = accel.closest_hit(ray, &mut Work::default()) {
                if h.tri == *own {
                    n[*kind as usize] += 1;
                }
            }
        }
        n
    }

    let mut failures = Vec::new();
    let mut gl_batches = Vec::new();
    for p in &scenes {
        let s64 = spawn::<f64>(p);
        let s32 = spawn::<f32>(p);
        let h64 = self_hits(p, &s64);
        let h32 = self_hits(p, &s32);
        for (b, h, n) in [("CPU f64", h64, s64.len()), ("CPU f32", h32, s32.len())] {
            println!(
                "[case 05] {b} scale {:.0e}: {n} spawned rays, self-hits reflected/refracted/light = {:?}",
                p.scale, h
            );
            if h.iter().sum::<usize>() > 0 {
                failures.push(format!("case 05 {b} scale {:e}: self-hits {h:?}", p.scale));
            }
            if n < 1500 {
                failures.push(format!(
                    "case 05 {b} scale {:e}: only {n} spawned rays",
                    p.scale
                ));
            }
        }
        gl_batches.push(
            s32.iter()
                .map(|(own, r, _, kind)| (*own, *r, *kind))
                .collect::<Vec<_>>(),
        );
    }
    with_test_context(|ctx| {
        for (p, batch) in scenes.iter().zip(&gl_batches) {
            let rays: Vec<TRay> = batch.iter().map(|b| b.1).collect();
            let closest = gl_trace(ctx, &p.scene, &p.grid, &rays, Query::Closest);
            let any = gl_trace(ctx, &p.scene, &p.grid, &rays, Query::Any);
            let mut n = [0usize; 3];
            let mut n_any = 0;
            for (k, (own, _, kind)) in batch.iter().enumerate() {
                if closest[k].tri() == Some(*own) {
                    n[*kind as usize] += 1;
                }
                if any[k].tri() == Some(*own) {
                    n_any += 1;
                }
            }
            println!(
                "[case 05] GL scale {:.0e}: {} spawned rays (from CPU f32), self-hits closest reflected/refracted/light = {n:?}, any-hit {n_any}",
                p.scale,
                rays.len()
            );
            if n.iter().sum::<usize>() + n_any > 0 {
                failures.push(format!(
                    "case 05 GL scale {:e}: self-hits {n:?}, any {n_any}",
                    p.scale
                ));
            }
        }
    });
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

// ---------------------------------------------------------------------------------------
// Case 6: the sliver
// ---------------------------------------------------------------------------------------

/// The sliver of the issue: three vertices sharing x and z (zero area in f32), and a ray
/// whose f32 edge functions are all rounding noise of one sign. Every backend must miss it,
/// closest-hit and any-hit. (Before the fix this case records, the f32 CPU and GL hit it at
/// t = 0.99586.)
#[test]
// The literals are the issue's, digit for digit; each rounds to the intended f32 value.
#[allow(clippy::excessive_precision, clippy::inconsistent_digit_grouping)]
fn case_06_sliver_triangle_is_missed() {
    let mut s = Scene::empty(default_camera());
    let m = s.add_material(Material::default());
    s.add_triangle(
        Vec3::new(-1113.45459, -79.049614, -56.2431908),
        Vec3::new(-1113.45459, -87.0922699, -56.2431908),
        Vec3::new(-1113.45459, -79.2090149, -56.2431908),
        m,
    );
    let grid = auto_grid(&s);
    let ray = TRay {
        o: Vec3::new(-1081.47925, 99.9999542, 87.7701111),
        d: Vec3::new(-32.1072998, -183.355865, -144.607635),
        t_max: 0.9999,
    };
    let c64 = cpu_closest::<f64>(&s, &grid, &[ray])[0];
    let c32 = cpu_closest::<f32>(&s, &grid, &[ray])[0];
    let a64 = cpu_any::<f64>(&s, &grid, &[ray])[0];
    let a32 = cpu_any::<f32>(&s, &grid, &[ray])[0];
    let (gc, ga) = with_test_context(|ctx| {
        (
            gl_trace(ctx, &s, &grid, &[ray], Query::Closest)[0],
            gl_trace(ctx, &s, &grid, &[ray], Query::Any)[0],
        )
    });
    let results = [(c64.hit, a64), (c32.hit, a32), (gc.hit, ga.hit.is_some())];
    for (b, (closest, any)) in BACKENDS.iter().zip(results) {
        println!("[case 06] {b}: closest {closest:?}, any {any}");
        assert!(
            closest.is_none() && !any,
            "case 06 {b}: the sliver was hit: {closest:?} any {any}"
        );
    }
}

// ---------------------------------------------------------------------------------------
// Case 7: axis-aligned rays with +0 and -0 direction components
// ---------------------------------------------------------------------------------------

/// An 8x8x8 grid whose only triangles sit in the 8 corner cells; axis-aligned rays from
/// every cell centre away from the corner columns, with the two other direction components
/// +0 or -0 in all combinations. The cells visited must equal an independent count (for
/// +x from cell c: 8 - c; for -x: c + 1), no triangle test may run, the ray must end as a
/// miss, and identical rays differing only in the sign of a zero must agree. Rays whose
/// origin lies outside the slab of a zero component must miss the grid (0 cells).
#[test]
fn case_07_axis_aligned_dda_with_signed_zeros() {
    let mut s = Scene::empty(default_camera());
    let m = s.add_material(Material::default());
    for &x in &[-4.0f32, 4.0] {
        for &y in &[-4.0f32, 4.0] {
            for &z in &[-4.0f32, 4.0] {
                let c = Vec3::new(x, y, z);
                let i = -c.signum() * 0.2;
                s.add_triangle(
                    c,
                    c + Vec3::new(i.x, 0.0, 0.0),
                    c + Vec3::new(0.0, i.y, i.z),
                    m,
                );
            }
        }
    }
    let grid = fixed_grid(&s, [8, 8, 8]);
    let (min, cs) = (grid.min.as_dvec3(), grid.cell_size.as_dvec3());
    let mut rays = Vec::new();
    let mut expected = Vec::new();
    for axis in 0..3 {
        let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
        for c in 0..8u32 {
            for c1 in 1..7u32 {
                for c2 in 1..7u32 {
                    let mut cell = [0u32; 3];
                    cell[axis] = c;
                    cell[a1] = c1;
                    cell[a2] = c2;
                    let o = min
                        + (DVec3::new(cell[0] as f64, cell[1] as f64, cell[2] as f64) + 0.5) * cs;
                    for sign in [1.0f32, -1.0] {
                        for z1 in [0.0f32, -0.0] {
                            for z2 in [0.0f32, -0.0] {
                                let mut d = Vec3::ZERO;
                                d[axis] = sign;
                                d[a1] = z1;
                                d[a2] = z2;
                                rays.push(TRay::new(o.as_vec3(), d));
                                // Independent count from the origin's cell index.
                                let oc = ((o[axis] - min[axis]) / cs[axis]).floor() as u32;
                                let cells = if sign > 0.0 { 8 - oc } else { oc + 1 };
                                expected.push(cells as f64);
                            }
                        }
                    }
                }
            }
        }
    }
    let n_inside = rays.len();
    // Outside the slab of a zero component: never enters the grid.
    for axis in 0..3 {
        for z in [0.0f32, -0.0] {
            let mut o = Vec3::splat(0.3);
            o[(axis + 1) % 3] = grid.max[(axis + 1) % 3] + 1.0;
            let mut d = Vec3::splat(z);
            d[axis] = 1.0;
            rays.push(TRay::new(o, d));
            expected.push(0.0);
        }
    }
    let mut fail = Vec::new();
    let cpu64 = cpu_closest::<f64>(&s, &grid, &rays);
    let cpu32 = cpu_closest::<f32>(&s, &grid, &rays);
    let gl = with_test_context(|ctx| gl_trace(ctx, &s, &grid, &rays, Query::Closest));
    for (b, res) in BACKENDS.iter().zip([&cpu64, &cpu32, &gl]) {
        let mut wrong = 0;
        let mut sign_disagree = 0;
        for (k, f) in res.iter().enumerate() {
            if f.steps != expected[k] || f.hit.is_some() {
                if wrong < 5 {
                    println!(
                        "    {b} ray {k} {:?}: steps {} (expected {}), hit {:?}, state {:?}",
                        rays[k], f.steps, expected[k], f.hit, f.state
                    );
                }
                wrong += 1;
            }
            if k < n_inside && k % 4 != 0 && *f != res[k - k % 4] {
                sign_disagree += 1;
            }
            if k >= n_inside && *b == "GL" && f.state != Some(RayState::Invalid) {
                wrong += 1;
            }
        }
        println!(
            "[case 07] {b}: {} axis-aligned rays with ±0 components: {wrong} with wrong cell count, hit or state, {sign_disagree} where +0/-0 disagree",
            rays.len()
        );
        if wrong + sign_disagree > 0 {
            fail.push(format!(
                "case 07 {b}: {wrong} wrong, {sign_disagree} sign disagreements"
            ));
        }
    }
    assert!(fail.is_empty(), "{}", fail.join("\n"));
}

// ---------------------------------------------------------------------------------------
// Cases 8-9: origins on cell faces, grid faces, outside; rays through cell edges/corners
// ---------------------------------------------------------------------------------------

/// A random soup of 400 triangles in a fixed, non-cubic 10x7x12 grid. Ray origins exactly
/// on interior cell faces (the f32 value `min + k * size` the DDA uses), exactly on the
/// grid's boundary faces, and outside the grid; and rays from exact cell corners and cell
/// edges along multiples of the cell diagonal, so the DDA meets tMax ties at every step.
/// On every backend the grid traversal must return exactly what a brute-force loop over
/// all triangles returns (same triangle; on the CPU also the same t), and rays perturbed
/// by 1e-5 cells must agree with their own brute force too.
#[test]
fn case_08_09_origins_on_faces_and_rays_through_cell_edges() {
    let mut rng = Rng::new("case 08/09", 0xfaced_u64);
    let mut s = Scene::empty(default_camera());
    let m = s.add_material(Material::default());
    for _ in 0..400 {
        let c = DVec3::new(
            rng.range(-5.0, 5.0),
            rng.range(-5.0, 5.0),
            rng.range(-5.0, 5.0),
        );
        let size = rng.f().powi(2) * 2.5 + 0.05;
        let v: Vec<Vec3> = (0..3).map(|_| (c + rng.dir() * size).as_vec3()).collect();
        s.add_triangle(v[0], v[1], v[2], m);
    }
    let grid = fixed_grid(&s, [10, 7, 12]);
    let (gmin, gmax, cs) = (grid.min, grid.max, grid.cell_size);
    // The face coordinate exactly as the f32 DDA computes it.
    let face = |axis: usize, k: u32| gmin[axis] + k as f32 * cs[axis];
    let rand_inside = |rng: &mut Rng| {
        Vec3::new(
            rng.range(gmin.x as f64, gmax.x as f64) as f32,
            rng.range(gmin.y as f64, gmax.y as f64) as f32,
            rng.range(gmin.z as f64, gmax.z as f64) as f32,
        )
    };
    let rand_dir = |rng: &mut Rng, k: usize| {
        let mut d = rng.dir().as_vec3();
        match k % 6 {
            0 => d[k / 6 % 3] = 0.0,
            1 => d[k / 6 % 3] = -0.0,
            2 => {
                // Aim at a triangle so that many rays hit.
                d = Vec3::ZERO;
            }
            _ => {}
        }
        d
    };
    let aim = |rng: &mut Rng, o: Vec3, d: Vec3| {
        if d == Vec3::ZERO {
            let v = s.triangle_vertices(rng.below(400));
            let t = (v[0] + v[1] + v[2]) / 3.0 - o;
            if t.length() > 1e-3 {
                t
            } else {
                Vec3::X
            }
        } else {
            d
        }
    };
    // (category, ray)
    let mut rays: Vec<(&str, TRay)> = Vec::new();
    for k in 0..3000 {
        // Interior cell face.
        let axis = k % 3;
        let mut o = rand_inside(&mut rng);
        o[axis] = face(axis, 1 + rng.below(grid.res[axis] as usize - 1) as u32);
        let d = rand_dir(&mut rng, k);
        rays.push(("8 cell face", TRay::new(o, aim(&mut rng, o, d))));
        // Grid boundary face (min or max), inward, outward or parallel.
        let mut o = rand_inside(&mut rng);
        o[axis] = if k % 2 == 0 { gmin[axis] } else { gmax[axis] };
        let d = rand_dir(&mut rng, k + 1);
        rays.push(("8 grid face", TRay::new(o, aim(&mut rng, o, d))));
        // Outside the grid.
        let o = loop {
            let o = Vec3::new(
                rng.range(-20.0, 20.0) as f32,
                rng.range(-20.0, 20.0) as f32,
                rng.range(-20.0, 20.0) as f32,
            );
            if o.cmplt(gmin).any() || o.cmpgt(gmax).any() {
                break o;
            }
        };
        let d = rand_dir(&mut rng, k + 2);
        rays.push(("8 outside", TRay::new(o, aim(&mut rng, o, d))));
        // Through cell corners: from an exact corner along (a, b, c) cell diagonals.
        let corner = Vec3::new(
            face(0, rng.below(11) as u32),
            face(1, rng.below(8) as u32),
            face(2, rng.below(13) as u32),
        );
        let mult = |rng: &mut Rng| {
            [-2.0f32, -1.0, 1.0, 2.0, 0.0][rng.below(if k % 4 == 0 { 5 } else { 4 })]
        };
        let d = Vec3::new(
            mult(&mut rng) * cs.x,
            mult(&mut rng) * cs.y,
            mult(&mut rng) * cs.z,
        );
        if d != Vec3::ZERO {
            rays.push(("9 corners", TRay::new(corner, d)));
        }
        // Through cell edges: two coordinates on faces, the third free.
        let mut o = corner;
        o[axis] = rand_inside(&mut rng)[axis];
        let mut d = Vec3::new(
            mult(&mut rng) * cs.x,
            mult(&mut rng) * cs.y,
            mult(&mut rng) * cs.z,
        );
        d[axis] = rng.range(-1.0, 1.0) as f32 * cs[axis];
        if d != Vec3::ZERO {
            rays.push(("9 edges", TRay::new(o, d)));
        }
    }
    // Perturbed twins of the corner and edge rays: origin moved by ~1e-5 cells.
    let n_base = rays.len();
    for k in 0..n_base {
        if rays[k].0.starts_with('9') {
            let r = rays[k].1;
            let jitter = (rng.dir().as_vec3() * cs) * 1e-5;
            rays.push(("9 perturbed", TRay::new(r.o + jitter, r.d)));
        }
    }
    let plain: Vec<TRay> = rays.iter().map(|r| r.1).collect();

    fn brute<T: Real>(scene: &Scene, grid: &Grid, rays: &[TRay]) -> Vec<Option<(f64, u32)>> {
        let accel = Accel::<T>::new(scene, grid);
        rays.par_iter()
            .map(|r| {
                accel
                    .brute_force(&r.cpu::<T>())
                    .map(|h| (h.t.to_f64(), h.tri))
            })
            .collect()
    }
    let b64 = brute::<f64>(&s, &grid, &plain);
    let b32 = brute::<f32>(&s, &grid, &plain);
    let g64 = cpu_closest::<f64>(&s, &grid, &plain);
    let g32 = cpu_closest::<f32>(&s, &grid, &plain);
    let gl = with_test_context(|ctx| gl_trace(ctx, &s, &grid, &plain, Query::Closest));

    let cats = [
        "8 cell face",
        "8 grid face",
        "8 outside",
        "9 corners",
        "9 edges",
        "9 perturbed",
    ];
    let mut fail = Vec::new();
    for (bi, b) in BACKENDS.iter().enumerate() {
        for cat in cats {
            let (mut n, mut hits, mut wrong) = (0, 0, 0);
            for (k, (c, _)) in rays.iter().enumerate() {
                if *c != cat {
                    continue;
                }
                n += 1;
                // The CPU must match its brute force bit for bit (t and triangle); GL's
                // arithmetic is the f32 CPU's twin, so its triangle must match that one.
                let (ok, got, want) = match bi {
                    0 => (g64[k].hit == b64[k], g64[k].hit, b64[k]),
                    1 => (g32[k].hit == b32[k], g32[k].hit, b32[k]),
                    _ => (gl[k].tri() == b32[k].map(|h| h.1), gl[k].hit, b32[k]),
                };
                hits += want.is_some() as usize;
                if !ok {
                    if wrong < 3 {
                        println!(
                            "    {b} {cat} ray {k} {:?}: got {got:?}, brute force {want:?}",
                            plain[k]
                        );
                    }
                    wrong += 1;
                }
            }
            println!(
                "[case 0{}] {b} {cat}: {n} rays, {hits} hits, {wrong} differ from brute force",
                &cat[..1]
            );
            if wrong > 0 {
                fail.push(format!(
                    "case 0{} {b} {cat}: {wrong} of {n} differ from brute force",
                    &cat[..1]
                ));
            }
            assert!(
                n > 1000 && hits > n / 10,
                "{cat}: too few rays or hits ({n}, {hits})"
            );
        }
    }
    // How often the perturbed twin sees the same triangle (the geometry near a cell corner
    // is the same, so nearly always).
    let mut same = 0;
    let mut twins = 0;
    let mut j = n_base;
    for k in 0..n_base {
        if rays[k].0.starts_with('9') {
            twins += 1;
            same += (b64[k].map(|h| h.1) == b64[j].map(|h| h.1)) as usize;
            j += 1;
        }
    }
    println!("[case 09] perturbed twins with the same brute-force triangle: {same} of {twins}");
    assert!(same as f64 > 0.99 * twins as f64);
    assert!(fail.is_empty(), "{}", fail.join("\n"));
}

// ---------------------------------------------------------------------------------------
// Cases 10-11: triangles on cell faces and axis-parallel triangles
// ---------------------------------------------------------------------------------------

/// In a fixed 6x6x6 grid: triangles lying exactly in the planes of cell faces x = X_2,
/// y = Y_3, z = Z_4 (the f32 values the DDA computes, so a hit's t equals the cell's exit
/// t), a small axis-parallel triangle strictly inside one cell, and a large one in a
/// mid-cell plane. The face triangles must be binned on both sides of their face; every
/// triangle in the cell holding its centroid; rays aimed at them (from both sides, also at
/// points on cell edges) must hit them on every backend whenever brute force in f64 does.
#[test]
fn case_10_11_triangles_on_cell_faces_and_axis_parallel() {
    let mut rng = Rng::new("case 10/11", 0xce11_u64);
    let mut s = Scene::empty(default_camera());
    let m = s.add_material(Material::default());
    // Bounds-defining corner triangles; the grid must not change when the targets are added.
    s.add_triangle(
        Vec3::splat(-3.0),
        Vec3::new(-2.9, -3.0, -3.0),
        Vec3::new(-3.0, -2.9, -3.0),
        m,
    );
    s.add_triangle(
        Vec3::splat(3.0),
        Vec3::new(2.9, 3.0, 3.0),
        Vec3::new(3.0, 2.9, 3.0),
        m,
    );
    let g0 = fixed_grid(&s, [6, 6, 6]);
    let face = |axis: usize, k: u32| g0.min[axis] + k as f32 * g0.cell_size[axis];
    let cs = g0.cell_size;
    // Point with coordinate `v` on `axis` and (a, b) on the two others, in axis order.
    let on = |axis: usize, v: f32, a: f32, b: f32| {
        let mut p = Vec3::ZERO;
        p[axis] = v;
        p[(axis + 1) % 3] = a;
        p[(axis + 2) % 3] = b;
        p
    };
    let mut targets: Vec<(&str, u32, usize)> = Vec::new(); // (kind, index, axis)
    for (axis, k) in [(0usize, 2u32), (1, 3), (2, 4)] {
        let v = face(axis, k);
        let i = s.add_triangle(
            on(axis, v, -2.5, -2.5),
            on(axis, v, 2.5, -2.0),
            on(axis, v, -1.0, 2.7),
            m,
        );
        targets.push(("10 on cell face", i, axis));
    }
    // Small triangle inside cell (3, 2, 1), parallel to the x faces.
    let lo = g0.min + Vec3::new(3.0, 2.0, 1.0) * cs;
    let x = lo.x + 0.37 * cs.x;
    let i = s.add_triangle(
        Vec3::new(x, lo.y + 0.2 * cs.y, lo.z + 0.2 * cs.z),
        Vec3::new(x, lo.y + 0.8 * cs.y, lo.z + 0.3 * cs.z),
        Vec3::new(x, lo.y + 0.4 * cs.y, lo.z + 0.8 * cs.z),
        m,
    );
    targets.push(("11 inside a cell", i, 0));
    // Large triangle in a mid-cell plane y = Y_1.5.
    let y = g0.min.y + 1.5 * cs.y;
    let i = s.add_triangle(
        Vec3::new(-2.6, y, -2.6),
        Vec3::new(2.6, y, -1.0),
        Vec3::new(0.5, y, 2.6),
        m,
    );
    targets.push(("11 mid-cell plane", i, 1));
    let grid = fixed_grid(&s, [6, 6, 6]);
    assert_eq!(
        (grid.min, grid.max, grid.cell_size),
        (g0.min, g0.max, g0.cell_size)
    );

    // Binning: every cell that a target's sample points fall into lists it, and the
    // face triangles are listed on both sides of their face.
    let cell_of = |p: Vec3| {
        let c = ((p - grid.min) / grid.cell_size).floor();
        [0, 1, 2].map(|a| (c[a].max(0.0) as u32).min(grid.res[a] - 1))
    };
    let mut binning_errors = 0;
    let mut binning_checks = 0;
    for &(kind, i, axis) in &targets {
        let v = s.triangle_vertices(i as usize);
        for _ in 0..200 {
            let w = rng.bary(0.0);
            let p = v[0] * w[0] as f32 + v[1] * w[1] as f32 + v[2] * w[2] as f32;
            let mut cells = vec![cell_of(p)];
            if kind.starts_with("10") {
                let mut below = cell_of(p);
                let k = ((p[axis] - grid.min[axis]) / grid.cell_size[axis]).round() as u32;
                below[axis] = k - 1;
                let mut above = below;
                above[axis] = k;
                cells = vec![below, above];
            }
            for c in cells {
                binning_checks += 1;
                if !grid.cell_triangles(c[0], c[1], c[2]).contains(&i) {
                    binning_errors += 1;
                }
            }
        }
    }
    println!("[case 10/11] binning: {binning_errors} of {binning_checks} (triangle, cell) checks missing");
    assert_eq!(
        binning_errors, 0,
        "face or axis-parallel triangles not binned"
    );

    // Rays: aimed at random interior points and at points on cell edges in the plane.
    let mut rays: Vec<(usize, TRay)> = Vec::new(); // (target slot, ray)
    for (slot, &(kind, i, axis)) in targets.iter().enumerate() {
        let v = s.triangle_vertices(i as usize).map(|v| v.as_dvec3());
        for k in 0..600 {
            let mut p = {
                let w = rng.bary(0.02);
                v[0] * w[0] + v[1] * w[1] + v[2] * w[2]
            };
            p[axis] = v[0][axis];
            if k % 3 == 0 && kind != "11 inside a cell" {
                // Snap one in-plane coordinate to a cell face: a point on a cell edge.
                let a = (axis + 1 + k % 2) % 3;
                let kk = ((p[a] - grid.min[a] as f64) / grid.cell_size[a] as f64).round() as u32;
                p[a] = face(a, kk.clamp(1, 5)) as f64;
            }
            let side = if k % 2 == 0 { 1.0 } else { -1.0 };
            let mut o = p + rng.dir() * rng.range(0.3, 2.5);
            o[axis] = p[axis] + side * rng.range(0.05, 2.5);
            let mut r = TRay::towards(o, p);
            // Make the plane coordinate of the target exact: the ray reaches it at t = 1
            // exactly in the axis direction.
            r.d[axis] = p[axis] as f32 - r.o[axis];
            rays.push((slot, r));
        }
    }
    let plain: Vec<TRay> = rays.iter().map(|r| r.1).collect();
    let accel64 = Accel::<f64>::new(&s, &grid);
    let first64: Vec<Option<u32>> = plain
        .iter()
        .map(|r| accel64.brute_force(&r.cpu::<f64>()).map(|h| h.tri))
        .collect();
    let res = with_test_context(|ctx| closest_all(ctx, &s, &grid, &plain));
    let mut fail = Vec::new();
    for (b, r) in BACKENDS.iter().zip(&res) {
        for (slot, &(kind, i, _)) in targets.iter().enumerate() {
            let (mut eligible, mut lost) = (0, 0);
            for (k, (sl, _)) in rays.iter().enumerate() {
                if *sl != slot || first64[k] != Some(i) {
                    continue;
                }
                eligible += 1;
                if r[k].tri() != Some(i) {
                    if lost < 3 {
                        println!("    {b} {kind} ray {k} {:?}: got {:?}", plain[k], r[k].hit);
                    }
                    lost += 1;
                }
            }
            println!(
                "[case {}] {b} {kind} (triangle {i}): {eligible} rays aimed, {lost} not found",
                &kind[..2]
            );
            assert!(eligible > 150, "{kind}: only {eligible} unobstructed rays");
            if lost > 0 {
                fail.push(format!(
                    "case {} {b} {kind}: {lost} of {eligible} lost",
                    &kind[..2]
                ));
            }
        }
    }
    assert!(fail.is_empty(), "{}", fail.join("\n"));
}

// ---------------------------------------------------------------------------------------
// Case 12: rays in a triangle's plane
// ---------------------------------------------------------------------------------------

/// Rays that lie exactly in a triangle's plane (dyadic coordinates, so the plane and the
/// ray are exact in f32): an axis-aligned plane z = 0.5 and a 45-degree plane x + y = 1.
/// The ray crosses the triangle's interior within the plane; every backend must report a
/// miss (the watertight test gives det = 0) and no NaN.
#[test]
fn case_12_rays_in_triangle_plane() {
    let mut rng = Rng::new("case 12", 0x91a_u64);
    let mut s = Scene::empty(default_camera());
    let m = s.add_material(Material::default());
    s.add_triangle(
        Vec3::new(-2.0, -2.0, 0.5),
        Vec3::new(2.0, -2.0, 0.5),
        Vec3::new(0.0, 2.0, 0.5),
        m,
    );
    s.add_triangle(
        Vec3::new(-1.0, 2.0, -1.0),
        Vec3::new(2.0, -1.0, -1.0),
        Vec3::new(0.5, 0.5, 2.0),
        m,
    );
    // Off-plane geometry far away so the grid has depth.
    s.add_triangle(
        Vec3::splat(-6.0),
        Vec3::new(-5.0, -6.0, -6.0),
        Vec3::new(-6.0, -5.0, -6.0),
        m,
    );
    s.add_triangle(
        Vec3::splat(6.0),
        Vec3::new(5.0, 6.0, 6.0),
        Vec3::new(6.0, 5.0, 6.0),
        m,
    );
    let grid = auto_grid(&s);
    // Dyadic values with few bits, so every difference is exact.
    let dy = |rng: &mut Rng, lo: f64, hi: f64| (rng.range(lo, hi) * 16.0).round() as f32 / 16.0;
    // (own triangle, ray in its plane, the same ray tilted off the plane)
    let mut rays: Vec<(u32, TRay, TRay)> = Vec::new();
    for k in 0..2000 {
        if k % 2 == 0 {
            // Plane z = 0.5, through an interior point, d.z = +0 or -0.
            let p = Vec3::new(dy(&mut rng, -0.5, 0.5), dy(&mut rng, -1.5, 0.5), 0.5);
            let mut d = Vec3::new(dy(&mut rng, -2.0, 2.0), dy(&mut rng, -2.0, 2.0), 0.0);
            if d.x == 0.0 && d.y == 0.0 {
                continue;
            }
            d.z = if k % 4 == 0 { 0.0 } else { -0.0 };
            let o = p - d * 4.0;
            let o_off = o + Vec3::new(0.0, 0.0, 0.25);
            rays.push((0, TRay::new(o, d), TRay::new(o_off, p - o_off)));
        } else {
            // Plane x + y = 1: points (a, 1 - a, z), directions (u, -u, w).
            let a = dy(&mut rng, 0.0, 1.0);
            let p = Vec3::new(a, 1.0 - a, dy(&mut rng, -0.5, 0.5));
            let u = dy(&mut rng, -2.0, 2.0);
            let w = match k % 5 {
                1 => 0.0,
                3 => -0.0,
                _ => dy(&mut rng, -2.0, 2.0),
            };
            if u == 0.0 && w == 0.0 {
                continue;
            }
            let d = Vec3::new(u, -u, w);
            let o = p - d * 4.0;
            let o_off = o + Vec3::new(0.25, 0.25, 0.0);
            rays.push((1, TRay::new(o, d), TRay::new(o_off, p - o_off)));
        }
    }
    let n = rays.len();
    let mut all: Vec<TRay> = rays.iter().map(|r| r.1).collect();
    all.extend(rays.iter().map(|r| r.2));
    let res = with_test_context(|ctx| closest_all(ctx, &s, &grid, &all));
    let mut fail = Vec::new();
    for (b, r) in BACKENDS.iter().zip(&res) {
        // A ray in one triangle's plane may legitimately cross the other triangle.
        let in_plane_hits = (0..n).filter(|&k| r[k].tri() == Some(rays[k].0)).count();
        let tilted_hits = (0..n).filter(|&k| r[n + k].hit.is_some()).count();
        let nan = r
            .iter()
            .filter(|f| !f.steps.is_finite() || f.hit.is_some_and(|h| !h.0.is_finite()))
            .count();
        println!(
            "[case 12] {b}: {n} rays lying in a triangle's plane: {in_plane_hits} hit that triangle (must be 0), {nan} NaN; the same rays tilted off the plane: {tilted_hits} hits"
        );
        if in_plane_hits + nan > 0 || tilted_hits < n * 9 / 10 {
            fail.push(format!(
                "case 12 {b}: {in_plane_hits} in-plane hits, {nan} NaN, {tilted_hits} tilted hits"
            ));
        }
    }
    assert!(fail.is_empty(), "{}", fail.join("\n"));
}

// ---------------------------------------------------------------------------------------
// Case 13: silhouettes of a smooth mesh
// ---------------------------------------------------------------------------------------

/// A smooth-shaded icosphere (4 subdivisions, vertex normals, diffuse + Phong) over a ground
/// quad, lit from the side so the terminator and the silhouette both cross the image.
/// Against the f64 image: a "speckle" is a pixel where both backends hit the same triangle
/// but the colour differs by more than 0.05; a silhouette flip is a pixel where one backend
/// hits the sphere and the other does not (a legitimate f32 rounding of the ray).
#[test]
fn case_13_silhouettes_of_smooth_mesh() {
    let mut s = Scene::empty(camera(
        Vec3::new(0.0, 1.2, 4.0),
        Vec3::new(0.0, 0.3, 0.0),
        40.0,
    ));
    s.background = Vec3::new(0.05, 0.05, 0.1);
    s.ambient = Vec3::splat(0.1);
    let mat = s.add_material(Material {
        albedo: Vec3::new(0.9, 0.6, 0.3),
        ks: Vec3::splat(0.4),
        ns: 40.0,
        ..Material::default()
    });
    let ground = s.add_material(Material {
        albedo: Vec3::splat(0.7),
        ..Material::default()
    });
    let (p, n, t) = sphere_mesh(4);
    add_mesh(
        &mut s,
        &p,
        Some(&n),
        &t,
        mat,
        1.0,
        DVec3::new(0.0, 0.5, 0.0),
    );
    add_quad(
        &mut s,
        [(-6.0, -6.0), (-6.0, 6.0), (6.0, 6.0), (6.0, -6.0)].map(|(x, z)| Vec3::new(x, -0.5, z)),
        ground,
    );
    s.lights.push(Light {
        position: Vec3::new(6.0, 2.0, -1.0),
        color: Vec3::ONE,
        intensity: 1.0,
    });
    s.max_depth = 1;
    let [r64, r32, gl] = with_test_context(|ctx| render_all(ctx, &s));
    let mut fail = Vec::new();
    for (b, r) in [("CPU f32", &r32), ("GL", &gl)] {
        assert!(r.image.all_finite(), "{b}: NaN or Inf pixel");
        let (mut speckles, mut flips, mut same_tri) = (0, 0, 0);
        let mut worst: f32 = 0.0;
        for (k, (a, want)) in pixels(&r.image).zip(pixels(&r64.image)).enumerate() {
            let (pa, pw) = (r.aov.pixels[k].primid, r64.aov.pixels[k].primid);
            if pa == pw {
                same_tri += 1;
                let d = px_diff(a, want);
                worst = worst.max(d);
                if d > 0.05 {
                    speckles += 1;
                }
            } else if (pa < 0.0) != (pw < 0.0) {
                flips += 1;
            }
        }
        let cmp = compare(&r.image, &r64.image, 0.05, true).unwrap();
        println!(
            "[case 13] {b} vs CPU f64: {speckles} speckles (same triangle, |diff| > 0.05) of {same_tri} pixels, max diff on same triangle {worst:.2e}, {flips} silhouette flips, RMSE {:.2e}",
            cmp.rmse
        );
        if speckles > 0 || flips > 8 || cmp.rmse > 0.02 {
            dump(&format!("case13-{}", b.replace(' ', "")), &r.image);
            fail.push(format!(
                "case 13 {b}: {speckles} speckles, {flips} flips, RMSE {}",
                cmp.rmse
            ));
        }
    }
    assert!(fail.is_empty(), "{}", fail.join("\n"));
}

// ---------------------------------------------------------------------------------------
// Case 14: degenerate triangles
// ---------------------------------------------------------------------------------------

/// Zero-area (collinear), duplicate-vertex, single-point and needle (long, collinear with
/// distinct vertices) triangles, mirror-coated, in front of a lit quad and box. They are
/// binned (so they are tested), never hit by single rays aimed at their vertices and
/// midpoints, and the image with them equals the image without them on every backend,
/// with every pixel finite.
#[test]
fn case_14_degenerate_triangles() {
    let mut rng = Rng::new("case 14", 0xde9e_u64);
    let build = |with_degenerate: bool| {
        let mut s = Scene::empty(camera(Vec3::new(0.0, 0.5, 6.0), Vec3::ZERO, 45.0));
        let wall = s.add_material(Material::default());
        let mirror = s.add_material(Material {
            kr: Vec3::splat(0.8),
            ..Material::default()
        });
        add_quad(
            &mut s,
            [(-5.0, -4.0), (5.0, -4.0), (5.0, 4.0), (-5.0, 4.0)]
                .map(|(x, y)| Vec3::new(x, y, -2.0)),
            wall,
        );
        let (bp, bt) = shapes::cuboid(Vec3::splat(1.0));
        add_mesh(
            &mut s,
            &bp,
            None,
            &bt,
            mirror,
            1.0,
            DVec3::new(1.2, -0.5, -0.5),
        );
        s.lights.push(Light {
            position: Vec3::new(2.0, 4.0, 5.0),
            color: Vec3::ONE,
            intensity: 1.0,
        });
        let first = s.triangles.len() as u32;
        if with_degenerate {
            // 2^-10: the needle's vertices are exactly collinear in f32 (and f64).
            let a = 1.0 / 1024.0f32;
            let v = Vec3::new;
            let degenerate = [
                // collinear (zero area)
                [v(-2.0, -1.0, 0.5), v(-1.0, 0.0, 0.5), v(0.0, 1.0, 0.5)],
                [v(-1.0, 1.0, 1.0), v(0.0, 1.0, 0.0), v(1.0, 1.0, -1.0)],
                // duplicate vertex
                [v(0.5, -1.0, 0.2), v(0.5, -1.0, 0.2), v(-0.5, 0.5, 0.7)],
                [v(-1.5, 0.3, 0.0), v(1.5, 0.3, 0.0), v(-1.5, 0.3, 0.0)],
                // a single point
                [v(0.25, 0.25, 1.0); 3],
                // needles: long, distinct vertices, exactly collinear in f32
                [
                    v(-3.0, -0.5, 0.1),
                    v(-1.0, -0.5 + a, 0.1),
                    v(1.0, -0.5 + 2.0 * a, 0.1),
                ],
                [v(0.0, -2.0, 1.5), v(0.0, 2.0, -0.5), v(0.0, 0.0, 0.5)],
            ];
            for t in degenerate {
                s.add_triangle(t[0], t[1], t[2], mirror);
            }
        }
        (s, first)
    };
    let (with, first) = build(true);
    let (without, _) = build(false);
    let n_deg = with.triangles.len() as u32 - first;
    let grid = auto_grid(&with);
    let binned = (first..first + n_deg)
        .filter(|i| grid.tri_indices.contains(i))
        .count();
    assert_eq!(binned as u32, n_deg, "degenerate triangles must be binned");
    // Single rays at their vertices, midpoints and along their lines.
    let mut rays = Vec::new();
    for i in first..first + n_deg {
        let v = with.triangle_vertices(i as usize).map(|v| v.as_dvec3());
        let mut targets = v.to_vec();
        targets.extend([
            (v[0] + v[1]) * 0.5,
            (v[1] + v[2]) * 0.5,
            (v[0] + v[2]) * 0.5,
        ]);
        for t in targets {
            for _ in 0..20 {
                rays.push(TRay::towards(t + rng.dir() * rng.range(0.5, 5.0), t));
            }
            // Along the triangle's own line.
            if (v[2] - v[0]).length() > 0.0 {
                rays.push(TRay::towards(t - (v[2] - v[0]) * 2.0, t));
            }
        }
    }
    let (res, renders_with, renders_without) = with_test_context(|ctx| {
        (
            closest_all(ctx, &with, &grid, &rays),
            render_all(ctx, &with),
            render_all(ctx, &without),
        )
    });
    let mut fail = Vec::new();
    for (bi, b) in BACKENDS.iter().enumerate() {
        let hits_deg = res[bi]
            .iter()
            .filter(|f| f.tri().is_some_and(|t| t >= first))
            .count();
        let (a, z) = (&renders_with[bi], &renders_without[bi]);
        let finite = a.image.all_finite();
        let max_diff = pixels(&a.image)
            .zip(pixels(&z.image))
            .map(|(p, q)| px_diff(p, q))
            .fold(0.0f32, f32::max);
        let primid_deg = a
            .aov
            .pixels
            .iter()
            .filter(|p| p.primid >= first as f32)
            .count();
        let normals_finite = a
            .aov
            .pixels
            .iter()
            .all(|p| p.normal.iter().all(|c| c.is_finite()));
        println!(
            "[case 14] {b}: {} rays at {n_deg} degenerate triangles: {hits_deg} hit one; image with vs without them: max diff {max_diff:.2e}, {primid_deg} pixels on a degenerate triangle, all finite: {}",
            rays.len(),
            finite && normals_finite
        );
        if hits_deg > 0 || max_diff > 1e-5 || primid_deg > 0 || !finite || !normals_finite {
            fail.push(format!(
                "case 14 {b}: {hits_deg} hits, max diff {max_diff}, finite {finite}"
            ));
        }
    }
    assert!(fail.is_empty(), "{}", fail.join("\n"));
}

// ---------------------------------------------------------------------------------------
// Case 15: coplanar duplicates
// ---------------------------------------------------------------------------------------

/// Copies of one triangle (same vertices, rotated order, reversed winding) and an
/// overlapping triangle, all in the exact plane z = x/4 + y/2 + 1/8, interleaved with
/// unrelated triangles. Every ray that hits the overlap region must report the lowest
/// index of the triangles containing the point (the documented tie rule), on every backend,
/// in the auto grid and in a fixed grid that splits the triangles over many cells.
#[test]
fn case_15_coplanar_duplicates_pick_lowest_index() {
    let mut rng = Rng::new("case 15", 0xc0_91a_u64);
    let z = |x: f32, y: f32| x * 0.25 + y * 0.5 + 0.125;
    let p = |x: f32, y: f32| Vec3::new(x, y, z(x, y));
    let (a, b, c) = (p(-3.0, -2.5), p(3.5, -1.0), p(-0.5, 3.0));
    let (d, e, f) = (p(-3.5, 0.5), p(2.0, -3.0), p(2.5, 2.5));
    let mut s = Scene::empty(default_camera());
    let m = s.add_material(Material::default());
    // Unrelated triangles beside the plane's region, out of every ray's way.
    let filler = |s: &mut Scene, rng: &mut Rng| {
        let c = DVec3::new(
            rng.range(8.0, 10.0),
            rng.range(-5.0, 5.0),
            rng.range(-5.0, 5.0),
        );
        let v: Vec<Vec3> = (0..3).map(|_| (c + rng.dir() * 0.3).as_vec3()).collect();
        s.add_triangle(v[0], v[1], v[2], m);
    };
    filler(&mut s, &mut rng);
    let t1 = s.add_triangle(a, b, c, m); // 1
    filler(&mut s, &mut rng);
    let u1 = s.add_triangle(d, e, f, m); // 3
    let t2 = s.add_triangle(b, c, a, m); // 4
    filler(&mut s, &mut rng);
    let t3 = s.add_triangle(a, c, b, m); // 6
    let u2 = s.add_triangle(f, e, d, m); // 7
    let t4 = s.add_triangle(a, b, c, m); // 8
    let family_t = [t1, t2, t3, t4];
    let family_u = [u1, u2];
    let inside = |q: DVec3, tri: [Vec3; 3]| {
        let t = tri.map(|v| v.as_dvec3());
        let e = |p0: DVec3, p1: DVec3| (p1.x - p0.x) * (q.y - p0.y) - (p1.y - p0.y) * (q.x - p0.x);
        let w = [e(t[0], t[1]), e(t[1], t[2]), e(t[2], t[0])];
        if w.iter().any(|x| x.abs() < 1e-3) {
            None
        } else {
            Some(w.iter().all(|&x| x > 0.0) || w.iter().all(|&x| x < 0.0))
        }
    };
    let mut rays = Vec::new();
    let mut expected = Vec::new();
    while rays.len() < 3000 {
        let q = DVec3::new(rng.range(-3.5, 3.5), rng.range(-3.0, 3.0), 0.0);
        let (Some(in_t), Some(in_u)) = (inside(q, [a, b, c]), inside(q, [d, e, f])) else {
            continue;
        };
        let want = match (in_t, in_u) {
            (true, true) => t1.min(u1),
            (true, false) => t1,
            (false, true) => u1,
            (false, false) => continue,
        };
        let target = DVec3::new(q.x, q.y, q.x * 0.25 + q.y * 0.5 + 0.125);
        let side = if rays.len() % 2 == 0 { 1.0 } else { -1.0 };
        let o = target
            + DVec3::new(
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
                side * rng.range(2.0, 8.0),
            );
        rays.push(TRay::towards(o, target));
        expected.push(want);
    }
    assert!(family_t.iter().chain(&family_u).all(|&i| i > 0));
    let grids = [
        ("auto grid", auto_grid(&s)),
        ("9x7x5 grid", fixed_grid(&s, [9, 7, 5])),
    ];
    let results: Vec<[Vec<Found>; 3]> = with_test_context(|ctx| {
        grids
            .iter()
            .map(|(_, g)| closest_all(ctx, &s, g, &rays))
            .collect()
    });
    let mut fail = Vec::new();
    for ((gname, _), res) in grids.iter().zip(&results) {
        for (b, r) in BACKENDS.iter().zip(res) {
            let mut wrong = 0;
            let mut picked = std::collections::BTreeMap::new();
            for (k, f) in r.iter().enumerate() {
                *picked.entry(f.tri().map_or(-1, |t| t as i64)).or_insert(0) += 1;
                if f.tri() != Some(expected[k]) {
                    wrong += 1;
                }
            }
            println!("[case 15] {b} {gname}: {} rays on the overlap: {wrong} not the lowest index; picked {picked:?}", rays.len());
            if wrong > 0 {
                fail.push(format!("case 15 {b} {gname}: {wrong} wrong"));
            }
        }
    }
    assert!(fail.is_empty(), "{}", fail.join("\n"));
}

// ---------------------------------------------------------------------------------------
// Case 16: scaled scenes
// ---------------------------------------------------------------------------------------

/// One lit scene (ground quad, box, flat and smooth spheres, low light so shadows are long
/// and shadow rays graze) rendered at scales 1, 1e-3 and 1e3 (geometry, camera and light
/// scaled alike). Shadow acne would darken lit pixels; the lit-pixel count at each scale
/// must stay within 1% of the unscaled count, per backend.
#[test]
fn case_16_scaled_scene_no_shadow_acne() {
    fn scene(k: f64) -> Scene {
        let sc = |v: DVec3| (v * k).as_vec3();
        let mut s = Scene::empty(camera(
            sc(DVec3::new(0.0, 5.0, 11.0)),
            sc(DVec3::new(0.0, 0.5, 0.0)),
            45.0,
        ));
        s.ambient = Vec3::splat(0.05);
        s.background = Vec3::ZERO;
        let m = s.add_material(Material {
            albedo: Vec3::splat(0.8),
            ..Material::default()
        });
        let q = [(-8.0, -8.0), (-8.0, 8.0), (8.0, 8.0), (8.0, -8.0)]
            .map(|(x, z)| sc(DVec3::new(x, 0.0, z)));
        add_quad(&mut s, q, m);
        let (bp, bt) = shapes::cuboid(Vec3::new(1.5, 1.0, 1.0));
        add_mesh(
            &mut s,
            &bp,
            None,
            &bt,
            m,
            k,
            DVec3::new(-2.0, 0.51, 0.0) * k,
        );
        let (p, n, t) = sphere_mesh(3);
        add_mesh(
            &mut s,
            &p,
            Some(&n),
            &t,
            m,
            k,
            DVec3::new(1.5, 1.05, -1.0) * k,
        );
        add_mesh(
            &mut s,
            &p,
            None,
            &t,
            m,
            0.7 * k,
            DVec3::new(0.3, 0.75, 2.0) * k,
        );
        s.lights.push(Light {
            position: sc(DVec3::new(9.0, 2.5, 3.0)),
            color: Vec3::ONE,
            intensity: 1.0,
        });
        s.max_depth = 0;
        s
    }
    let scales = [1.0, 1e-3, 1e3];
    let scenes: Vec<Scene> = scales.iter().map(|&k| scene(k)).collect();
    let renders: Vec<[Rendered; 3]> =
        with_test_context(|ctx| scenes.iter().map(|s| render_all(ctx, s)).collect());
    // Ambient-only level is 0.8 * 0.05 = 0.04; lit means clearly above it.
    let lit = |img: &Image| pixels(img).filter(|p| p[0] > 0.06).count();
    let mut fail = Vec::new();
    for (bi, b) in BACKENDS.iter().enumerate() {
        let base = lit(&renders[0][bi].image);
        let mut line = format!("[case 16] {b}: lit pixels at scale 1: {base}");
        for (si, &k) in scales.iter().enumerate().skip(1) {
            let r = &renders[si][bi];
            assert!(r.image.all_finite(), "{b} scale {k}: NaN pixel");
            let n = lit(&r.image);
            let delta = n as i64 - base as i64;
            line.push_str(&format!("; at {k:e}: {n} ({delta:+})"));
            if delta.abs() as f64 > (0.01 * base as f64).max(2.0) {
                dump(&format!("case16-{}-{k:e}", b.replace(' ', "")), &r.image);
                fail.push(format!("case 16 {b} scale {k:e}: {n} lit pixels vs {base}"));
            }
        }
        println!("{line}");
        assert!(
            base > 400,
            "{b}: only {base} lit pixels, the scene is not lit"
        );
    }
    assert!(fail.is_empty(), "{}", fail.join("\n"));
}

// ---------------------------------------------------------------------------------------
// Case 17: two close parallel surfaces
// ---------------------------------------------------------------------------------------

/// Two 10x10 quads 1e-3 apart (1e-4 of the scene size), at the origin and translated by
/// (100, 100, 100). Rays from either side, down to 85 degrees from the normal, must hit the
/// near quad; rays transmitted through the near quad (spawned by `offset_origin`, f32 CPU
/// spawns for GL) must hit the far one: no leak and no overshoot of the gap.
#[test]
fn case_17_close_parallel_surfaces() {
    let mut rng = Rng::new("case 17", 0x9a9_u64);
    let gap = 1e-3;
    let mut fail = Vec::new();
    let mut prepared = Vec::new();
    for offset in [DVec3::ZERO, DVec3::splat(100.0)] {
        let mut s = Scene::empty(default_camera());
        let m = s.add_material(Material {
            kt: Vec3::ONE,
            ior: 1.0,
            ..Material::default()
        });
        let quad = |z: f64| {
            [(-5.0, -5.0), (5.0, -5.0), (5.0, 5.0), (-5.0, 5.0)]
                .map(|(x, y)| (DVec3::new(x, y, z) + offset).as_vec3())
        };
        add_quad(&mut s, quad(0.0), m); // 0, 1: front (z = 0)
        add_quad(&mut s, quad(-gap), m); // 2, 3: back
        let grid = auto_grid(&s);
        let mut rays = Vec::new();
        let mut want_front = Vec::new();
        for k in 0..4000 {
            let front = k % 2 == 0;
            let target = offset
                + DVec3::new(
                    rng.range(-4.8, 4.8),
                    rng.range(-4.8, 4.8),
                    if front { 0.0 } else { -gap },
                );
            let theta = rng.range(0.0, 85f64.to_radians());
            let phi = rng.range(0.0, std::f64::consts::TAU);
            let dir = DVec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            let dist = rng.range(0.5, 20.0);
            let o = target + if front { dir } else { -dir } * dist;
            rays.push(TRay::towards(o, target));
            want_front.push(front);
        }
        prepared.push((offset, s, grid, rays, want_front));
    }
    /// Transmitted continuation of each ray that hit, spawned in precision T.
    fn transmit<T: Real>(s: &Scene, grid: &Grid, rays: &[TRay]) -> Vec<(u32, TRay, Ray<T>)> {
        let accel = Accel::<T>::new(s, grid);
        let mut out = Vec::new();
        for r in rays {
            let mut ray = r.cpu::<T>();
            ray.d = ray.d.normalize();
            if let Some(h) = accel.closest_hit(&ray, &mut Work::default()) {
                let sp = surface(s, &accel.tris[h.tri as usize], &h, ray.d);
                let sec = secondary(&s.materials[0], &sp, ray.d);
                let o = offset_origin(&sp, sec.refracted);
                let cpu = Ray {
                    o,
                    d: sec.refracted,
                    t_min: T::ZERO,
                    t_max: T::BIG,
                };
                out.push((
                    h.tri,
                    TRay::new(o.to_dvec3().as_vec3(), sec.refracted.to_dvec3().as_vec3()),
                    cpu,
                ));
            }
        }
        out
    }
    fn through<T: Real>(
        s: &Scene,
        grid: &Grid,
        spawned: &[(u32, TRay, Ray<T>)],
    ) -> Vec<Option<u32>> {
        let accel = Accel::<T>::new(s, grid);
        spawned
            .iter()
            .map(|(_, _, r)| accel.closest_hit(r, &mut Work::default()).map(|h| h.tri))
            .collect()
    }
    let other_side = |own: u32, got: Option<u32>| match got {
        Some(t) => (own < 2) != (t < 2),
        None => false,
    };
    let mut cpu_through = Vec::new();
    for (_, s, grid, rays, _) in &prepared {
        let sp64 = transmit::<f64>(s, grid, rays);
        let sp32 = transmit::<f32>(s, grid, rays);
        let h64 = through::<f64>(s, grid, &sp64);
        let h32 = through::<f32>(s, grid, &sp32);
        cpu_through.push((
            sp64.iter()
                .zip(&h64)
                .filter(|((own, _, _), g)| !other_side(*own, **g))
                .count(),
            sp32.iter()
                .zip(&h32)
                .filter(|((own, _, _), g)| !other_side(*own, **g))
                .count(),
            sp32.iter()
                .map(|(own, r, _)| (*own, *r))
                .collect::<Vec<_>>(),
        ));
    }
    let gl: Vec<(Vec<Found>, Vec<Found>)> = with_test_context(|ctx| {
        prepared
            .iter()
            .zip(&cpu_through)
            .map(|((_, s, grid, rays, _), (_, _, sp))| {
                let spawned: Vec<TRay> = sp.iter().map(|x| x.1).collect();
                (
                    gl_trace(ctx, s, grid, rays, Query::Closest),
                    gl_trace(ctx, s, grid, &spawned, Query::Closest),
                )
            })
            .collect()
    });
    for (k, (offset, s, grid, rays, want_front)) in prepared.iter().enumerate() {
        let primary = [
            cpu_closest::<f64>(s, grid, rays),
            cpu_closest::<f32>(s, grid, rays),
            gl[k].0.clone(),
        ];
        for (bi, b) in BACKENDS.iter().enumerate() {
            let leaks = primary[bi]
                .iter()
                .zip(want_front)
                .filter(|(f, front)| f.tri().map(|t| t < 2) != Some(**front))
                .count();
            let bad_through = match bi {
                0 => cpu_through[k].0,
                1 => cpu_through[k].1,
                _ => cpu_through[k]
                    .2
                    .iter()
                    .zip(&gl[k].1)
                    .filter(|((own, _), f)| !other_side(*own, f.tri()))
                    .count(),
            };
            println!(
                "[case 17] {b} offset {}: {} rays: {leaks} hit the far surface or nothing; transmitted rays that missed the other surface: {bad_through}",
                offset.x,
                rays.len()
            );
            if leaks + bad_through > 0 {
                fail.push(format!(
                    "case 17 {b} offset {}: {leaks} leaks, {bad_through} bad transmissions",
                    offset.x
                ));
            }
        }
    }
    assert!(fail.is_empty(), "{}", fail.join("\n"));
}

// ---------------------------------------------------------------------------------------
// Cases 18-19: total internal reflection, camera inside glass
// ---------------------------------------------------------------------------------------

/// A 45-degree glass prism (ior 1.5, kt = 1): camera rays enter its front face, meet the
/// hypotenuse at about 45 degrees (beyond the 41.8-degree critical angle), are totally
/// reflected towards +x, leave through the side face and see a red wall. Every pixel whose
/// primary ray enters the prism's front face away from its rim must be red (no NaN, never
/// black) on every backend; a Fresnel variant must be finite and never black there.
#[test]
fn case_18_total_internal_reflection() {
    fn scene(fresnel: bool) -> Scene {
        let mut s = Scene::empty(camera(Vec3::new(0.0, 0.0, 16.0), Vec3::ZERO, 14.0));
        s.background = Vec3::new(0.1, 0.3, 0.8);
        s.ambient = Vec3::splat(0.2);
        s.max_depth = 5;
        let glass = s.add_material(Material {
            albedo: Vec3::ONE,
            ka: 0.0,
            kd: 0.0,
            kt: Vec3::ONE,
            ior: 1.5,
            fresnel,
            ..Material::default()
        });
        let red = s.add_material(Material {
            albedo: Vec3::new(1.0, 0.1, 0.1),
            ..Material::default()
        });
        // Cross-section (x, z): (-1, 1), (1, 1), (1, -1); extruded over y in [-1.5, 1.5].
        let (y0, y1) = (-1.5, 1.5);
        let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        let inside = v(0.4, 0.0, 0.4);
        add_quad_outward(
            &mut s,
            [
                v(-1.0, y0, 1.0),
                v(1.0, y0, 1.0),
                v(1.0, y1, 1.0),
                v(-1.0, y1, 1.0),
            ],
            inside,
            glass,
        ); // front z = 1
        add_quad_outward(
            &mut s,
            [
                v(1.0, y0, 1.0),
                v(1.0, y0, -1.0),
                v(1.0, y1, -1.0),
                v(1.0, y1, 1.0),
            ],
            inside,
            glass,
        ); // side x = 1
        add_quad_outward(
            &mut s,
            [
                v(-1.0, y0, 1.0),
                v(1.0, y0, -1.0),
                v(1.0, y1, -1.0),
                v(-1.0, y1, 1.0),
            ],
            inside,
            glass,
        ); // hypotenuse
        for y in [y0, y1] {
            let (a, b, c) = (v(-1.0, y, 1.0), v(1.0, y, 1.0), v(1.0, y, -1.0));
            let n = (b - a).cross(c - a);
            if n.dot(Vec3::new(0.0, y, 0.0)) > 0.0 {
                s.add_triangle(a, b, c, glass);
            } else {
                s.add_triangle(a, c, b, glass);
            }
        }
        add_quad(
            &mut s,
            [
                v(5.0, -4.0, -4.0),
                v(5.0, 4.0, -4.0),
                v(5.0, 4.0, 4.0),
                v(5.0, -4.0, 4.0),
            ],
            red,
        );
        s.lights.push(Light {
            position: Vec3::new(2.5, 0.5, 1.0),
            color: Vec3::ONE,
            intensity: 0.8,
        });
        s
    }
    let plain = scene(false);
    let fres = scene(true);
    let (r_plain, r_fres) =
        with_test_context(|ctx| (render_all(ctx, &plain), render_all(ctx, &fres)));
    // Pixels whose f64 primary ray hits the front face (triangles 0, 1) away from the rim.
    let cam = &plain.camera;
    let eye = cam.eye.as_dvec3();
    let mut selected = Vec::new();
    for j in 0..H {
        for i in 0..W {
            let k = (j * W + i) as usize;
            let pid = r_plain[0].aov.pixels[k].primid;
            let d = cam.pixel_direction(W, H, i, j);
            let p = eye + d * ((1.0 - eye.z) / d.z);
            if (pid == 0.0 || pid == 1.0) && p.x > -0.8 && p.x < 0.8 && p.y.abs() < 1.0 {
                selected.push(k);
            }
        }
    }
    assert!(selected.len() > 150, "only {} prism pixels", selected.len());
    let mut fail = Vec::new();
    for (variant, renders) in [("kt=1", &r_plain), ("fresnel", &r_fres)] {
        for (b, r) in BACKENDS.iter().zip(renders.iter()) {
            let finite = r.image.all_finite();
            let px: Vec<[f32; 3]> = pixels(&r.image).collect();
            let black = selected
                .iter()
                .filter(|&&k| px[k].iter().cloned().fold(0.0, f32::max) < 0.02)
                .count();
            let red = selected
                .iter()
                .filter(|&&k| px[k][0] > 0.3 && px[k][0] > 3.0 * px[k][2])
                .count();
            let vs64 = compare(&r.image, &renders[0].image, 0.05, true).unwrap();
            println!(
                "[case 18] {b} {variant}: {} prism pixels: {black} black, {red} red (via TIR), all finite: {finite}, RMSE vs f64 {:.2e}",
                selected.len(),
                vs64.rmse
            );
            let red_needed = if variant == "kt=1" { selected.len() } else { 0 };
            if !finite || black > 0 || red < red_needed || vs64.rmse > 0.02 {
                dump(
                    &format!("case18-{variant}-{}", b.replace(' ', "")),
                    &r.image,
                );
                fail.push(format!(
                    "case 18 {b} {variant}: black {black}, red {red}, finite {finite}, RMSE {}",
                    vs64.rmse
                ));
            }
        }
    }
    assert!(fail.is_empty(), "{}", fail.join("\n"));
}

/// The camera sits at the centre of a smooth glass icosphere (ior 1.5, kt = 1) in a room
/// with a floor, a box and a light. Every primary ray must hit the sphere from inside;
/// since they meet it almost normally, the image must match the same scene without the
/// sphere (RMSE < 0.03, CPU f64), GL must match the f32 CPU, and every pixel be finite.
#[test]
fn case_19_camera_inside_refractive_mesh() {
    let build = |with_sphere: bool| {
        let mut s = Scene::empty(camera(Vec3::ZERO, Vec3::new(0.0, -0.3, -1.0), 60.0));
        s.background = Vec3::new(0.3, 0.4, 0.6);
        s.ambient = Vec3::splat(0.15);
        s.max_depth = 3;
        let floor = s.add_material(Material {
            albedo: Vec3::new(0.8, 0.8, 0.7),
            ..Material::default()
        });
        let boxm = s.add_material(Material {
            albedo: Vec3::new(0.2, 0.7, 0.3),
            ..Material::default()
        });
        let glass = s.add_material(Material {
            albedo: Vec3::ONE,
            ka: 0.0,
            kd: 0.0,
            kt: Vec3::ONE,
            ior: 1.5,
            ..Material::default()
        });
        add_quad(
            &mut s,
            [(-20.0, -20.0), (-20.0, 20.0), (20.0, 20.0), (20.0, -20.0)]
                .map(|(x, z)| Vec3::new(x, -3.0, z)),
            floor,
        );
        let (bp, bt) = shapes::cuboid(Vec3::new(3.0, 2.0, 2.0));
        add_mesh(
            &mut s,
            &bp,
            None,
            &bt,
            boxm,
            1.0,
            DVec3::new(-1.0, -2.0, -8.0),
        );
        s.lights.push(Light {
            position: Vec3::new(0.0, 10.0, -7.0),
            color: Vec3::ONE,
            intensity: 0.9,
        });
        let mut range = 0..0;
        if with_sphere {
            let (p, n, t) = sphere_mesh(4);
            range = add_mesh(&mut s, &p, Some(&n), &t, glass, 1.0, DVec3::ZERO);
        }
        (s, range)
    };
    let (inside, range) = build(true);
    let (open, _) = build(false);
    let (renders, open64) = with_test_context(|ctx| {
        (
            render_all(ctx, &inside),
            render_cpu(&open, &opts(&open, Precision::F64)).unwrap(),
        )
    });
    let mut fail = Vec::new();
    for (b, r) in BACKENDS.iter().zip(renders.iter()) {
        let finite = r.image.all_finite();
        let on_sphere = r
            .aov
            .pixels
            .iter()
            .filter(|p| p.primid >= range.start as f32 && p.primid < range.end as f32)
            .count();
        let vs_open = compare(&r.image, &open64.image, 0.05, true).unwrap();
        let vs32 = compare(&r.image, &renders[1].image, 0.05, true).unwrap();
        println!(
            "[case 19] {b}: {on_sphere} of {} primary rays hit the sphere from inside, finite: {finite}, RMSE vs the open scene {:.2e}, vs CPU f32 {:.2e}",
            W * H,
            vs_open.rmse,
            vs32.rmse
        );
        if !finite || on_sphere != (W * H) as usize || vs_open.rmse > 0.03 || vs32.rmse > 0.02 {
            dump(&format!("case19-{}", b.replace(' ', "")), &r.image);
            fail.push(format!(
                "case 19 {b}: finite {finite}, {on_sphere} on sphere, RMSE open {}, f32 {}",
                vs_open.rmse, vs32.rmse
            ));
        }
    }
    assert!(fail.is_empty(), "{}", fail.join("\n"));
}

// ---------------------------------------------------------------------------------------
// Case 20: NaN and Inf in input files
// ---------------------------------------------------------------------------------------

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fragtrace-hard-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Scene files and OBJ meshes with nan, inf and f32-overflowing numbers: the binary exits
/// with code 2, prints one `fragtrace: error:` line naming the file and the problem, and
/// writes no image.
#[test]
fn case_20_non_finite_input_is_a_clear_error() {
    let dir = tmpdir("case20");
    let base = "[camera]\neye = [0, 1, 5]\nlook_at = [0, 0, 0]\nfov = 40\n\n[[lights]]\nposition = [2, 4, 3]\n\n";
    let obj_ok = "v -1 0 -1\nv 1 0 -1\nv 0 0 1\nf 1 2 3\n";
    std::fs::write(dir.join("ok.obj"), obj_ok).unwrap();
    std::fs::write(
        dir.join("nan.obj"),
        "v -1 0 -1\nv 1 nan -1\nv 0 0 1\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("inf.obj"),
        "v -1 0 -1\nv 1 0 -1\nv 0 0 inf\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("big.obj"),
        "v -1 0 -1\nv 1e39 0 -1\nv 0 0 1\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("vn.obj"),
        "v -1 0 -1\nv 1 0 -1\nv 0 0 1\nvn 0 nan 0\nf 1//1 2//1 3//1\n",
    )
    .unwrap();
    let mesh = |f: &str| format!("{base}[[objects]]\nmesh = \"{f}\"\n");
    let cases: Vec<(&str, String, &str)> = vec![
        ("ok", mesh("ok.obj"), ""),
        (
            "scene-nan-ambient",
            format!("ambient = [0.1, nan, 0.1]\n{}", mesh("ok.obj")),
            "finite",
        ),
        (
            "scene-inf-eye",
            mesh("ok.obj").replace("eye = [0, 1, 5]", "eye = [0, inf, 5]"),
            "finite",
        ),
        (
            "scene-overflow-light",
            mesh("ok.obj").replace("position = [2, 4, 3]", "position = [2, 1e39, 3]"),
            "finite",
        ),
        (
            "scene-nan-translate",
            format!("{}translate = [0, nan, 0]\n", mesh("ok.obj")),
            "finite",
        ),
        ("obj-nan", mesh("nan.obj"), "non-finite"),
        ("obj-inf", mesh("inf.obj"), "non-finite"),
        ("obj-overflow", mesh("big.obj"), "non-finite"),
        ("obj-nan-normal", mesh("vn.obj"), "non-finite"),
    ];
    let mut fail = Vec::new();
    for (name, toml, needle) in &cases {
        let scene = dir.join(format!("{name}.toml"));
        std::fs::write(&scene, toml).unwrap();
        let out_png = dir.join(format!("{name}.png"));
        let out = Command::new(env!("CARGO_BIN_EXE_fragtrace"))
            .args(["render"])
            .arg(&scene)
            .args(["--backend", "cpu", "--width", "8", "--height", "6", "-o"])
            .arg(&out_png)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr).trim().to_string();
        let code = out.status.code();
        println!("[case 20] {name}: exit {code:?}: {stderr}");
        if *name == "ok" {
            if code != Some(0) || !out_png.exists() {
                fail.push(format!("{name}: the control scene failed: {stderr}"));
            }
            continue;
        }
        let file = if name.starts_with("obj") {
            toml.split('"').nth(1).unwrap().to_string()
        } else {
            format!("{name}.toml")
        };
        let one_line = stderr.lines().count() == 1 && stderr.starts_with("fragtrace: error:");
        if code != Some(2)
            || !one_line
            || !stderr.contains(needle)
            || !stderr.contains(&file)
            || out_png.exists()
        {
            fail.push(format!("{name}: exit {code:?}, stderr `{stderr}` (want code 2, one line naming {file} and `{needle}`, no image)"));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(fail.is_empty(), "{}", fail.join("\n"));
}

// ---------------------------------------------------------------------------------------
// Case 21: empty scene, one triangle, camera inside the grid
// ---------------------------------------------------------------------------------------

/// The empty scene renders the background exactly everywhere; a single ambient-lit
/// triangle renders exactly two colours with the coverage of the f64 image; a camera inside
/// a closed room (so inside the grid) renders finite, every primary ray hits, and GL agrees
/// with the f32 CPU.
#[test]
fn case_21_empty_single_triangle_camera_inside_grid() {
    let mut empty = Scene::empty(default_camera());
    empty.background = Vec3::new(0.1, 0.3, 0.8);
    empty.lights.push(Light {
        position: Vec3::new(1.0, 2.0, 3.0),
        color: Vec3::ONE,
        intensity: 1.0,
    });

    let mut single = Scene::empty(default_camera());
    single.background = Vec3::new(0.0, 0.0, 1.0);
    single.ambient = Vec3::new(0.5, 0.25, 0.125);
    let m = single.add_material(Material {
        albedo: Vec3::new(0.8, 0.6, 0.4),
        ka: 0.75,
        kd: 0.0,
        ..Material::default()
    });
    single.add_triangle(
        Vec3::new(-3.0, -2.0, 0.5),
        Vec3::new(3.5, -1.0, -0.5),
        Vec3::new(-0.5, 3.0, 0.0),
        m,
    );
    let tri_colour = [0.8 * 0.5 * 0.75, 0.6 * 0.25 * 0.75, 0.4 * 0.125 * 0.75];

    let mut room = Scene::empty(camera(
        Vec3::new(0.5, 0.2, 2.0),
        Vec3::new(-0.3, 0.0, -1.0),
        70.0,
    ));
    let wall = room.add_material(Material {
        albedo: Vec3::new(0.7, 0.6, 0.5),
        ..Material::default()
    });
    let mirror = room.add_material(Material {
        albedo: Vec3::splat(0.2),
        kr: Vec3::splat(0.6),
        ..Material::default()
    });
    let (bp, bt) = shapes::cuboid(Vec3::new(8.0, 5.0, 9.0));
    add_mesh(&mut room, &bp, None, &bt, wall, 1.0, DVec3::ZERO);
    let (p, n, t) = sphere_mesh(3);
    add_mesh(
        &mut room,
        &p,
        Some(&n),
        &t,
        mirror,
        1.0,
        DVec3::new(-1.0, -1.0, -2.0),
    );
    room.lights.push(Light {
        position: Vec3::new(1.0, 2.0, 1.0),
        color: Vec3::ONE,
        intensity: 1.0,
    });
    let grid = auto_grid(&room);
    assert!(
        room.camera.eye.cmpgt(grid.min).all() && room.camera.eye.cmplt(grid.max).all(),
        "the camera must be inside the grid"
    );

    let (re, rs, rr) = with_test_context(|ctx| {
        (
            render_all(ctx, &empty),
            render_all(ctx, &single),
            render_all(ctx, &room),
        )
    });
    let mut fail = Vec::new();
    for (bi, b) in BACKENDS.iter().enumerate() {
        // Empty.
        let bg = empty.background.to_array();
        let not_bg = pixels(&re[bi].image)
            .filter(|p| px_diff(*p, bg) > 1e-6)
            .count();
        // Single triangle.
        let sb = single.background.to_array();
        let (mut tri_px, mut odd) = (0, 0);
        for p in pixels(&rs[bi].image) {
            if (0..3).all(|c| (p[c] as f64 - tri_colour[c]).abs() < 1e-5) {
                tri_px += 1;
            } else if px_diff(p, sb) > 1e-6 {
                odd += 1;
            }
        }
        let cover_diff = rs[bi]
            .aov
            .pixels
            .iter()
            .zip(&rs[0].aov.pixels)
            .filter(|(a, z)| (a.primid < 0.0) != (z.primid < 0.0))
            .count();
        // Room.
        let finite =
            rr[bi].image.all_finite() && re[bi].image.all_finite() && rs[bi].image.all_finite();
        let room_miss = rr[bi].aov.pixels.iter().filter(|p| p.primid < 0.0).count();
        let agree = rr[bi]
            .aov
            .pixels
            .iter()
            .zip(&rr[1].aov.pixels)
            .filter(|(a, z)| a.primid == z.primid)
            .count();
        let vs32 = compare(&rr[bi].image, &rr[1].image, 0.05, true).unwrap();
        println!(
            "[case 21] {b}: empty: {not_bg} non-background pixels; single triangle: {tri_px} triangle pixels, {odd} other colours, {cover_diff} coverage differences vs f64; room: {room_miss} misses, primid agreement with CPU f32 {agree}/{}, RMSE vs CPU f32 {:.2e}; all finite: {finite}",
            W * H,
            vs32.rmse
        );
        if not_bg > 0
            || odd > 0
            || tri_px < 150
            || cover_diff > 2
            || !finite
            || room_miss > 0
            || (agree as f64) < 0.995 * (W * H) as f64
            || vs32.rmse > 0.02
        {
            fail.push(format!("case 21 {b}: see the line above"));
        }
    }
    assert!(fail.is_empty(), "{}", fail.join("\n"));
}

// ---------------------------------------------------------------------------------------
// Case 22: texture limits
// ---------------------------------------------------------------------------------------

/// A scene or grid beyond the GPU's texture limits is refused with `Error::Limit` naming
/// GL_MAX_TEXTURE_SIZE (exit code 2), for the triangle and the cell textures; a grid with
/// more cells than float indices can address (2^24) is refused by the GL render itself,
/// while the CPU renders it; the same scenes pack fine at the real limit.
#[test]
fn case_22_texture_limits_are_clear_errors() {
    let mut s = Scene::empty(default_camera());
    let m = s.add_material(Material::default());
    let (p, n, t) = sphere_mesh(4); // 5120 triangles: 15360 tri texels
    add_mesh(&mut s, &p, Some(&n), &t, m, 1.0, DVec3::ZERO);
    let grid = fixed_grid(&s, [64, 64, 64]); // 262144 cells
    let mut fail = Vec::new();
    for (max, what) in [(64u32, "tri"), (128, "cell")] {
        match SceneTextures::pack(&s, &grid, max) {
            Err(e @ Error::Limit(_)) => {
                let msg = e.to_string();
                println!("[case 22] all backends: pack with GL_MAX_TEXTURE_SIZE {max}: {msg}");
                if !msg.contains("GL_MAX_TEXTURE_SIZE")
                    || !msg.contains(&format!("`{what}`"))
                    || e.exit_code() != 2
                {
                    fail.push(format!("unclear message for max {max}: {msg}"));
                }
            }
            Err(e) => fail.push(format!("max {max}: wrong error kind: {e}")),
            Ok(_) => fail.push(format!(
                "max {max}: packed a {what} texture beyond the limit"
            )),
        }
    }
    // More cells than exact float indices: only the GL backend must refuse.
    let mut tiny = Scene::empty(default_camera());
    let m = tiny.add_material(Material::default());
    tiny.add_triangle(
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.1),
        m,
    );
    let mut o = opts(&tiny, Precision::F32);
    o.width = 8;
    o.height = 6;
    o.grid = GridConfig {
        res: GridRes::Fixed([257, 256, 256]),
        ..GridConfig::default()
    };
    let (gl_err, real_ok, ctx_max) = with_test_context(|ctx| {
        let gl_err = render_gl_with(ctx, &tiny, &o).err();
        let real = SceneTextures::pack(&s, &grid, ctx.info.max_texture_size as u32).is_ok();
        (gl_err, real, ctx.info.max_texture_size)
    });
    match &gl_err {
        Some(e @ Error::Limit(msg)) => {
            println!("[case 22] GL: {} cells: {e}", 257 * 256 * 256);
            if !msg.contains("2^24") || !msg.contains("`cell`") {
                fail.push(format!("unclear message: {e}"));
            }
        }
        other => fail.push(format!(
            "GL render of a 2^24+ cell grid: {:?}",
            other.as_ref().map(|e| e.to_string())
        )),
    }
    let cpu = render_cpu(&tiny, &o);
    println!(
        "[case 22] CPU f32: the same 2^24+ cell grid renders: {}; real GL_MAX_TEXTURE_SIZE {ctx_max} packs the 5120-triangle scene: {real_ok}",
        cpu.is_ok()
    );
    if cpu.is_err() || !real_ok {
        fail.push("the CPU or the real limit refused a valid scene".into());
    }
    assert!(fail.is_empty(), "{}", fail.join("\n"));
}
