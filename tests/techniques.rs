//! The robustness techniques switched off one at a time (src/technique.rs): the default
//! output is what tests/hard_cases.rs checks; here every non-default setting must still
//! render finite images (CPU f64, CPU f32, GL), and the hard cases each technique is
//! responsible for must get measurably worse without it, so the technique is shown to
//! matter. The numbers are printed (`-- --nocapture`) and tabulated in
//! docs/robustness.md, "Cost of each technique".
//!
//! - Möller–Trumbore instead of the watertight test: rays leak through the shared edge of
//!   case 1 and out of the closed mesh of case 3 (f32 CPU and GL).
//! - No t error bound: spawned rays that start on their triangle (no offset) or behind a
//!   too-small fixed epsilon re-hit it (case 5), and lit surfaces get shadow acne (case 16).
//! - Fixed epsilon offset instead of the error bound: spawned rays re-hit their own
//!   triangle at large scales in f32 (case 5), and shadows change at small scales
//!   (case 16).

mod common;
use common::Rng;
use common::{with_test_context, words};
use fragtrace::accel::{Grid, GridConfig};
use fragtrace::cpu::real::{Real, V3};
use fragtrace::cpu::shade::{offset_origin_with, reflect, surface};
use fragtrace::cpu::traverse::{CellWalk, GridWalker, Ray, Work};
use fragtrace::gpu::options::GpuOptions;
use fragtrace::gpu::options::Kernel;
use fragtrace::gpu::render::{trace_rays, GpuRay};
use fragtrace::gpu::shader::Query;
use fragtrace::gpu::GlContext;
use fragtrace::options::{Backend, CpuPath, Precision, RenderOptions};
use fragtrace::render::{render_cpu, render_gl_with};
use fragtrace::scene::{builtin_scene, shapes, Camera, Light, Material, Scene};
use fragtrace::technique::{IntersectMethod, OffsetMethod, TBound, Techniques, Terminator};
use glam::{DVec3, Vec3};
use rayon::prelude::*;

const BIG: f32 = 1.0e30;

fn camera() -> Camera {
    Camera {
        eye: Vec3::new(0.0, 0.0, 10.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
    }
}

/// One f32 ray, traced alike by every backend.
#[derive(Clone, Copy, Debug)]
struct TRay {
    o: Vec3,
    d: Vec3,
    t_max: f32,
}

impl TRay {
    fn towards(o: DVec3, target: DVec3) -> Self {
        let o = o.as_vec3();
        TRay {
            o,
            d: target.as_vec3() - o,
            t_max: BIG,
        }
    }
    fn cpu<T: Real>(&self) -> Ray<T> {
        Ray {
            o: V3::from_vec3(self.o),
            d: V3::from_vec3(self.d),
            t_min: T::ZERO,
            t_max: T::from_f32(self.t_max),
        }
    }
}

/// Closest hit triangle per ray on the CPU in precision `T` with `tech`.
fn cpu_closest<T: Real>(s: &Scene, g: &Grid, rays: &[TRay], tech: Techniques) -> Vec<Option<u32>> {
    let accel = GridWalker::<T>::with_techniques(s, g, tech);
    rays.par_iter()
        .map(|r| {
            accel
                .closest_hit(&r.cpu::<T>(), &mut Work::default())
                .map(|h| h.tri)
        })
        .collect()
}

/// Closest hit triangle per ray through the GL traversal kernel built for `tech`.
fn gl_closest(
    ctx: &GlContext,
    s: &Scene,
    g: &Grid,
    rays: &[TRay],
    tech: Techniques,
) -> Vec<Option<u32>> {
    let gpu: Vec<GpuRay> = rays
        .iter()
        .map(|r| GpuRay {
            o: r.o,
            d: r.d,
            t_max: r.t_max,
        })
        .collect();
    // The thesis's multipass kernel, as in tests/hard_cases.rs.
    let opts = GpuOptions {
        techniques: tech,
        kernel: Kernel::Multipass,
        ..GpuOptions::default()
    };
    trace_rays(ctx, s, g, &gpu, Query::Closest, opts)
        .unwrap()
        .into_iter()
        .map(|t| t.hit.map(|h| h.1))
        .collect()
}

fn misses(found: &[Option<u32>]) -> usize {
    found.iter().filter(|h| h.is_none()).count()
}

fn mt() -> Techniques {
    Techniques::default().with_intersect(IntersectMethod::MollerTrumbore)
}
fn no_t_bound() -> Techniques {
    Techniques::default().with_t_bound(TBound::Off)
}
fn epsilon() -> Techniques {
    Techniques::default().with_offset(OffsetMethod::Epsilon)
}

// ---------------------------------------------------------------------------------------

/// How a technique's image differs from the default's.
struct Differences {
    /// Pixels whose primary ray hits another triangle (or misses instead).
    primary: usize,
    /// Background pixels of the default image that changed.
    background: usize,
    /// Pixels brighter than the default by more than 1e-6 in some channel.
    brighter: usize,
    /// Pixels that changed by more than 1e-3 in some channel.
    above_1e3: usize,
    /// Pixels that changed by more than 1e-2 in some channel.
    above_1e2: usize,
    /// Largest change of a channel.
    max: f32,
}

fn differences(
    default: &fragtrace::render::Rendered,
    other: &fragtrace::render::Rendered,
) -> Differences {
    let mut d = Differences {
        primary: 0,
        background: 0,
        brighter: 0,
        above_1e3: 0,
        above_1e2: 0,
        max: 0.0,
    };
    let pixels = default.image.data.chunks(3).zip(other.image.data.chunks(3));
    for (k, (a, b)) in pixels.enumerate() {
        let (pa, pb) = (&default.aov.pixels[k], &other.aov.pixels[k]);
        d.primary += (pa.primid != pb.primid) as usize;
        let change = a
            .iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max);
        d.max = d.max.max(change);
        d.background += (pa.primid < 0.0 && change > 0.0) as usize;
        d.brighter += a.iter().zip(b).any(|(x, y)| *y > x + 1e-6) as usize;
        d.above_1e3 += (change > 1e-3) as usize;
        d.above_1e2 += (change > 1e-2) as usize;
    }
    d
}

/// Every non-default setting renders finite images on CPU f64, CPU f32 and GL (the built-in
/// scene at 64x48), and differs from the default image only where its technique matters:
/// the primary hits, the background and the rays traced stay the same, and each image
/// changes in its technique's own way (bounds below, against what was measured).
#[test]
fn every_technique_renders_finite_images() {
    let scene = builtin_scene();
    let mut o = RenderOptions::for_scene(&scene);
    o.width = 64;
    o.height = 48;
    o.backend = Backend::Cpu;
    let pixels = (o.width * o.height) as f64;
    with_test_context(|ctx| {
        let mut render = |tech: Techniques, p: Option<Precision>| {
            o.techniques = tech;
            let r = match p {
                Some(p) => {
                    o.precision = p;
                    render_cpu(&scene, &o).unwrap()
                }
                None => {
                    o.precision = Precision::F32;
                    render_gl_with(ctx, &scene, &o).unwrap()
                }
            };
            assert!(r.image.all_finite(), "{} {p:?}", tech.tag());
            assert_eq!(r.stats.techniques, tech.tag());
            r
        };
        for p in [Some(Precision::F64), Some(Precision::F32), None] {
            let where_ = p.map_or("GL".to_string(), |p| format!("CPU {p:?}"));
            let base = render(Techniques::default(), p);
            for tech in Techniques::one_off() {
                let r = render(tech, p);
                let d = differences(&base, &r);
                let what = format!("{} {where_}", tech.tag());
                println!(
                    "[techniques] {what}: finite; {} pixels changed by > 1e-3, {} by > 1e-2, \
                     max {:.2e}; {} brighter",
                    d.above_1e3, d.above_1e2, d.max, d.brighter
                );
                // No technique moves a camera ray: the 64x48 camera rays pass nowhere near
                // a seam or within rounding of their origin. Measured 0 of each everywhere.
                assert_eq!((d.primary, d.background), (0, 0), "{what}");
                assert_eq!(r.stats.rays, base.stats.rays, "{what}");
                if tech == mt() {
                    // Only rounding changes (no spawned ray crosses a seam either): measured
                    // max 0 in f64, 2.3e-5 on the f32 CPU, 2.5e-5 on GL.
                    assert!(d.max <= 1e-4, "{what}: {}", d.max);
                } else if tech == no_t_bound() {
                    // Acne: lit surfaces shadow themselves, so pixels only get darker, and
                    // many do (measured 0 brighter; 84..111 of 3072, 2.7..3.6%, by > 1e-2;
                    // 18% before scenes were stored relative to the camera eye, whose
                    // smaller coordinates leave less rounding to shadow a surface).
                    assert_eq!(d.brighter, 0, "{what}");
                    let share = d.above_1e2 as f64 / pixels;
                    assert!((0.01..=0.10).contains(&share), "{what}: {share}");
                } else if tech.terminator != Techniques::default().terminator {
                    // Shadow rays from the triangles instead of the smooth surface: the
                    // built-in scene's tessellated spheres have vertex normals.
                    // The shadow rays skip their start (the light's direction is the
                    // same): none of them passes near an occluder (measured max 0).
                    assert!(d.above_1e3 == 0 && d.max <= 1e-3, "{what}: {}", d.max);
                } else {
                    // Spawned rays start 1e-4 along the normal instead of the error bound:
                    // small shifts of what they see (measured 7 pixels by > 1e-3, max 0.033).
                    assert!(d.above_1e3 <= 30 && d.max <= 0.05, "{what}");
                }
            }
        }
    });
}

/// Case 1 (the seam: two triangles sharing the diagonal, 4096 rays aimed at points of it
/// from both sides, plus the ray) and case 3 (rays from inside a closed
/// icosphere(5)). The watertight test never lets a ray through; Möller–Trumbore, deciding
/// each triangle on its own, does in f32 (CPU and GL).
#[test]
fn moller_trumbore_leaks_through_shared_edges() {
    let mut rng = Rng::new("case 01 mt", 0x5ea_u64);
    let mut seam = Scene::empty(camera());
    let m = seam.add_material(Material::default());
    let (a, b, c, d) = (
        Vec3::new(-5.0, -5.0, 0.0),
        Vec3::new(5.0, -5.0, 0.0),
        Vec3::new(5.0, 5.0, 0.0),
        Vec3::new(-5.0, 5.0, 0.0),
    );
    seam.add_triangle(a, b, c, m);
    seam.add_triangle(a, c, d, m);
    let seam_grid = Grid::build(&seam, &GridConfig::default()).unwrap();
    let mut rays = vec![TRay {
        o: Vec3::new(0.0, 0.0, 10.0),
        d: Vec3::new(0.304_584_47, 0.304_584_47, -0.902_472_5),
        t_max: BIG,
    }];
    for k in 0..4096 {
        let s = rng.range(-4.9, 4.9);
        let side = if k % 2 == 0 { 1.0 } else { -1.0 };
        let o = DVec3::new(
            rng.range(-20.0, 20.0),
            rng.range(-20.0, 20.0),
            side * rng.range(0.5, 20.0),
        );
        rays.push(TRay::towards(o, DVec3::new(s, s, 0.0)));
    }

    let mut rng = Rng::new("case 03 mt", 0x1c05_u64);
    let (p, _, tris) = shapes::sphere(5);
    let mut sph = Scene::empty(camera());
    let m = sph.add_material(Material::default());
    for t in &tris {
        sph.add_triangle(p[t[0] as usize], p[t[1] as usize], p[t[2] as usize], m);
    }
    let sph_grid = Grid::build(&sph, &GridConfig::default()).unwrap();
    let inside: Vec<TRay> = (0..20000)
        .map(|_| {
            let o = rng.dir() * 0.5 * rng.f();
            TRay::towards(o, o + rng.dir())
        })
        .collect();

    // (seam misses, sphere-inside misses) on GL, watertight then Moller-Trumbore.
    let (gl_wt, gl_mt) = with_test_context(|ctx| {
        let run = |tech| {
            (
                misses(&gl_closest(ctx, &seam, &seam_grid, &rays, tech)),
                misses(&gl_closest(ctx, &sph, &sph_grid, &inside, tech)),
            )
        };
        (run(Techniques::default()), run(mt()))
    });
    let n = (rays.len(), inside.len());
    let row = |name: &str, tech: Techniques| {
        let s64 = misses(&cpu_closest::<f64>(&seam, &seam_grid, &rays, tech));
        let s32 = misses(&cpu_closest::<f32>(&seam, &seam_grid, &rays, tech));
        let i64 = misses(&cpu_closest::<f64>(&sph, &sph_grid, &inside, tech));
        let i32 = misses(&cpu_closest::<f32>(&sph, &sph_grid, &inside, tech));
        println!(
            "[case 01/03] {name}: seam misses f64 {s64}/{} f32 {s32}/{}; sphere-inside misses f64 {i64}/{} f32 {i32}/{}",
            n.0, n.0, n.1, n.1
        );
        (s64, s32, i64, i32)
    };
    let wt = row("watertight", Techniques::default());
    let mtr = row("moller-trumbore", mt());
    println!(
        "[case 01/03] GL: watertight seam {} sphere {}; moller-trumbore seam {} sphere {}",
        gl_wt.0, gl_wt.1, gl_mt.0, gl_mt.1
    );
    assert_eq!(wt, (0, 0, 0, 0), "the watertight test leaked");
    assert_eq!(gl_wt, (0, 0), "the watertight GL test leaked");
    // Measured: 433 / 4097 seam rays leak on the f32 CPU, 484 on GL, none in f64 (its
    // rounding happens to stay inside the closed-interval tests here). Random rays from
    // inside the sphere rarely pass within rounding of an edge: 0 / 20000 leaks there in
    // every precision, so case 3 is recorded, not asserted, for Moller-Trumbore.
    assert!(
        mtr.1 > 100 && gl_mt.0 > 100,
        "Moller-Trumbore leaked through the f32 seam only {} times (CPU), {} (GL)",
        mtr.1,
        gl_mt.0
    );
}

/// Case 5's check, per technique: random triangles at scales 1e-4 .. 1e4 (one scene per
/// decade, clustered up to 20 sizes away from the origin); rays aimed at random interior
/// points; from each hit, the mirror ray, the straight-through (transmitted) ray and a
/// shadow ray to a light are spawned with the technique's offset and traced with its
/// intersection test. A self-hit is a spawned ray whose closest hit is its own triangle.
/// With `offset` false the spawned rays start at the computed hit point itself (no offset
/// at all), so only the t bound stands between them and their own triangle. Returns
/// self-hits and spawned rays per decade.
fn self_hits<T: Real>(tech: Techniques, offset: bool) -> Vec<(i32, usize, usize)> {
    let mut out = Vec::new();
    for e in -4..=4 {
        let scale = 10f64.powi(e);
        let mut rng = Rng(0x5e1f_u64 ^ (e + 10) as u64);
        let mut s = Scene::empty(camera());
        let m = s.add_material(Material::default());
        let centre = DVec3::new(rng.range(-20.0, 20.0), rng.range(-20.0, 20.0), 0.0) * scale;
        for _ in 0..300 {
            let c = centre
                + DVec3::new(
                    rng.range(-8.0, 8.0),
                    rng.range(-8.0, 8.0),
                    rng.range(-8.0, 8.0),
                ) * scale;
            let v = |rng: &mut Rng| (c + rng.dir() * scale).as_vec3();
            let (a, b, cc) = (v(&mut rng), v(&mut rng), v(&mut rng));
            s.add_triangle(a, b, cc, m);
        }
        let g = Grid::build(&s, &GridConfig::default()).unwrap();
        let accel = GridWalker::<T>::with_techniques(&s, &g, tech);
        let light = V3::<T>::from_dvec3(centre + DVec3::new(30.0, 40.0, 50.0) * scale);
        let (mut hits, mut spawned) = (0usize, 0usize);
        for i in 0..s.triangles.len() {
            let [p0, p1, p2] = s.triangle_vertices(i).map(|v| v.as_dvec3());
            let (u, v) = (rng.range(0.1, 0.45), rng.range(0.1, 0.45));
            let target = p0 + (p1 - p0) * u + (p2 - p0) * v;
            let o = target + rng.dir() * 40.0 * scale;
            let ray = TRay::towards(o, target).cpu::<T>();
            let Some(hit) = accel.closest_hit(&ray, &mut Work::default()) else {
                continue;
            };
            let sp = surface(&s, &accel.tris[hit.tri as usize], &hit, ray.d);
            let d = ray.d.normalize();
            let mut spawn = |dir: V3<T>, t_max: T| {
                let o = if offset {
                    offset_origin_with(&sp, dir, tech.offset)
                } else {
                    sp.p
                };
                let r = Ray {
                    o,
                    d: dir,
                    t_min: T::ZERO,
                    t_max,
                };
                spawned += 1;
                if accel.closest_hit(&r, &mut Work::default()).map(|h| h.tri) == Some(hit.tri) {
                    hits += 1;
                }
            };
            spawn(reflect(d, sp.nf), T::BIG);
            spawn(d, T::BIG);
            let to_l = light - sp.p;
            let dist = to_l.length();
            spawn(to_l * (T::ONE / dist), dist);
        }
        out.push((e, hits, spawned));
    }
    out
}

/// With the fixed epsilon offset at large scales in f32, spawned rays hit their own
/// triangle; with the default techniques never. The t bound alone (spawned rays starting
/// on the surface, or behind the too-small epsilon) removes most self-hits.
#[test]
fn t_bound_and_offset_prevent_self_intersection() {
    let mut totals = Vec::new();
    for (name, tech, offset) in [
        ("default", Techniques::default(), true),
        ("t-bound-off", no_t_bound(), true),
        ("offset-epsilon", epsilon(), true),
        ("t-bound, no offset", Techniques::default(), false),
        ("t-bound-off, no offset", no_t_bound(), false),
        (
            "t-bound-off, offset-epsilon",
            epsilon().with_t_bound(TBound::Off),
            true,
        ),
    ] {
        let r64 = self_hits::<f64>(tech, offset);
        let r32 = self_hits::<f32>(tech, offset);
        let fmt = |r: &[(i32, usize, usize)]| {
            r.iter()
                .map(|(e, h, n)| format!("1e{e}: {h}/{n}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        println!("[case 05] {name} f64: {}", fmt(&r64));
        println!("[case 05] {name} f32: {}", fmt(&r32));
        totals.push((name, r64, r32));
    }
    let sum = |r: &[(i32, usize, usize)], from: i32| -> usize {
        r.iter().filter(|x| x.0 >= from).map(|x| x.1).sum()
    };
    let (_, d64, d32) = &totals[0];
    assert_eq!(sum(d64, -4) + sum(d32, -4), 0, "self-hits with the default");
    // Measured: without the t bound, the error-bound offset alone keeps these isolated
    // triangles free of self-hits (0 at every scale); its acne shows in case 16 below.
    let (_, b64, b32) = &totals[1];
    assert_eq!(
        sum(b64, -4) + sum(b32, -4),
        0,
        "self-hits with the offset alone"
    );
    // The fixed epsilon is below the f32 error of the hit point from 1e2 on: self-hits
    // there in f32 (23, 30, 65 of 900 at 1e2, 1e3, 1e4), none in f64.
    let (_, e64, e32) = &totals[2];
    for e in 2..=4 {
        let at = e32.iter().find(|x| x.0 == e).unwrap();
        assert!(at.1 > 0, "no f32 self-hit with the fixed epsilon at 1e{e}");
    }
    assert_eq!(sum(e64, -4), 0, "f64 self-hit with the fixed epsilon");
    // The t bound's own share. With no offset at all, spawned rays start on their triangle:
    // without the t bound about half of them re-hit it (measured 429..460 of 900 per
    // decade, f64 and f32); with it, 25..65 of 900 (what remains is the hit point's own
    // error off the plane, the offset's job, not the t bound's). Bounds: at least 40%
    // without, at most 10% with, in every decade and both precisions.
    let (_, n64, n32) = &totals[3];
    let (_, o64, o32) = &totals[4];
    for (with, without) in [(n64, o64), (n32, o32)] {
        for (w, wo) in with.iter().zip(without.iter()) {
            assert!(
                (w.1 as f64) <= 0.1 * w.2 as f64 && (wo.1 as f64) >= 0.4 * wo.2 as f64,
                "no offset at 1e{}: {} self-hits with the t bound, {} without (of {})",
                w.0,
                w.1,
                wo.1,
                wo.2
            );
        }
    }
    // Behind the too-small fixed epsilon in f32 the t bound catches most self-hits:
    // without it 160, 427, 450 of 900 at 1e2, 1e3, 1e4 (with it 23, 30, 65). Bound: at
    // least 3x as many without, at each of those scales.
    let (_, _, x32) = &totals[5];
    for e in 2..=4 {
        let (with, without) = (
            e32.iter().find(|x| x.0 == e).unwrap().1,
            x32.iter().find(|x| x.0 == e).unwrap().1,
        );
        assert!(
            without >= 3 * with.max(1),
            "fixed epsilon at 1e{e}: {with} self-hits with the t bound, {without} without"
        );
    }
}

/// Case 16's scene idea: a ground quad with boxes and a sphere, a low light, rendered at
/// scales 1e-3, 1 and 1e3; counts lit pixels (brighter than the ambient-only level).
fn lit_pixels(scale: f32, tech: Techniques, backend: Backend, ctx: Option<&GlContext>) -> usize {
    let mut s = Scene::empty(Camera {
        eye: Vec3::new(0.0, 3.0, 8.0) * scale,
        look_at: Vec3::new(0.0, 0.5, 0.0) * scale,
        up: Vec3::Y,
        vfov_deg: 40.0,
    });
    s.ambient = Vec3::splat(0.05);
    s.background = Vec3::ZERO;
    let m = s.add_material(Material::default());
    let q = |x: f32, z: f32| Vec3::new(x, 0.0, z) * scale;
    s.add_triangle(q(-6.0, -6.0), q(6.0, 6.0), q(6.0, -6.0), m);
    s.add_triangle(q(-6.0, -6.0), q(-6.0, 6.0), q(6.0, 6.0), m);
    let (p, _, tris) = shapes::sphere(3);
    for t in &tris {
        let v = |k: usize| (p[t[k] as usize] + Vec3::new(-1.0, 1.0, 0.0)) * scale;
        s.add_triangle(v(0), v(1), v(2), m);
    }
    let (bp, bt) = shapes::cuboid(Vec3::new(1.5, 1.0, 1.0));
    for t in &bt {
        let v = |k: usize| (bp[t[k] as usize] + Vec3::new(1.5, 0.5, 0.5)) * scale;
        s.add_triangle(v(0), v(1), v(2), m);
    }
    s.lights.push(Light {
        position: Vec3::new(-8.0, 2.5, 3.0) * scale,
        color: Vec3::ONE,
        intensity: 1.0,
    });
    let mut o = RenderOptions::for_scene(&s);
    o.width = 64;
    o.height = 48;
    o.backend = backend;
    o.precision = Precision::F32;
    o.techniques = tech;
    let img = match ctx {
        Some(ctx) => render_gl_with(ctx, &s, &o).unwrap().image,
        None => render_cpu(&s, &o).unwrap().image,
    };
    img.data
        .chunks(3)
        .filter(|c| c.iter().any(|&v| v > 0.08))
        .count()
}

/// Without the t error bound, lit surfaces shadow themselves (acne: fewer lit pixels) at
/// every scale; the fixed epsilon changes the lit area at the small scale, while the
/// default keeps the count within 1% of scale 1 (CPU f32 and GL).
#[test]
fn t_bound_and_offset_prevent_shadow_acne() {
    let scales = [1e-3f32, 1.0, 1e3];
    let run = |tech: Techniques, ctx: Option<&GlContext>| -> Vec<usize> {
        let b = if ctx.is_some() {
            Backend::Gl
        } else {
            Backend::Cpu
        };
        scales
            .iter()
            .map(|&s| lit_pixels(s, tech, b, ctx))
            .collect()
    };
    let settings = [
        ("default", Techniques::default()),
        ("t-bound-off", no_t_bound()),
        ("offset-epsilon", epsilon()),
    ];
    let cpu: Vec<Vec<usize>> = settings.iter().map(|(_, t)| run(*t, None)).collect();
    let gl: Vec<Vec<usize>> =
        with_test_context(|ctx| settings.iter().map(|(_, t)| run(*t, Some(ctx))).collect());
    for (k, (name, _)) in settings.iter().enumerate() {
        println!(
            "[case 16] {name}: lit pixels at 1e-3 / 1 / 1e3: CPU f32 {:?}, GL {:?}",
            cpu[k], gl[k]
        );
    }
    let within = |v: &[usize]| {
        v.iter()
            .all(|&x| (x as f64 - v[1] as f64).abs() <= 0.01 * v[1] as f64)
    };
    assert!(within(&cpu[0]) && within(&gl[0]), "default: acne");
    // Measured: without the t bound about 27% of the lit pixels turn dark at every scale
    // (1698 -> 1212..1256); require at least 10% at each.
    for k in 0..3 {
        for v in [&cpu, &gl] {
            assert!(
                (v[1][k] as f64) < 0.9 * v[0][k] as f64,
                "no acne without the t bound at scale {}",
                scales[k]
            );
        }
    }
    // Measured: the fixed epsilon darkens 6 lit pixels at 1e-3 (shadow rays start 1e-4,
    // a tenth of the scene's unit, away), none at 1 and 1e3 (the t bound hides its
    // self-hits there); the error bound keeps all of them.
    assert!(cpu[2][0] < cpu[0][0] && gl[2][0] < gl[0][0]);
    assert_eq!((cpu[2][1], gl[2][1]), (cpu[0][1], gl[0][1]));
}

/// The command-line flags reach the render options; omitted, they are the defaults.
#[test]
fn command_line_flags_select_techniques() {
    use fragtrace::choices::RenderArgs;
    let scene = builtin_scene();
    let o = RenderArgs::try_parse_from_args::<&str>(&[])
        .unwrap()
        .to_options(&scene)
        .unwrap();
    assert_eq!(o.techniques, Techniques::default());
    let args = RenderArgs::try_parse_from_args(&words(
        "--intersect moller-trumbore --t-bound off --offset epsilon",
    ))
    .unwrap();
    let o = args.to_options(&scene).unwrap();
    assert_eq!(
        o.techniques,
        Techniques {
            intersect: IntersectMethod::MollerTrumbore,
            t_bound: TBound::Off,
            offset: OffsetMethod::Epsilon,
            terminator: Terminator::Smooth,
        }
    );
    assert_eq!(
        o.techniques.tag(),
        "intersect-moller-trumbore+t-bound-off+offset-epsilon"
    );
}

/// Luminance (Rec. 709) of pixel `k`.
fn luminance(img: &fragtrace::image_io::Image, k: usize) -> f32 {
    let c = &img.data[3 * k..3 * k + 3];
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Isolated dark and bright pixels of a render: a pixel whose primary ray and all 8
/// neighbours' hit a surface, with luminance below half the darkest neighbour's (dark), or
/// above twice the brightest neighbour's (bright), where that neighbour is lit (luminance
/// at least `lit`). Returns (dark, bright) and the dark pixels' positions.
fn speckles(r: &fragtrace::render::Rendered, lit: f32) -> (usize, usize, Vec<(u32, u32)>) {
    let (w, h) = (r.image.width as usize, r.image.height as usize);
    let (mut dark, mut bright, mut at) = (0, 0, Vec::new());
    for j in 1..h - 1 {
        for i in 1..w - 1 {
            let k = j * w + i;
            let ring: Vec<usize> = [
                (-1, -1),
                (0, -1),
                (1, -1),
                (-1, 0),
                (1, 0),
                (-1, 1),
                (0, 1),
                (1, 1),
            ]
            .iter()
            .map(|&(di, dj)| ((j as i64 + dj) as usize) * w + (i as i64 + di) as usize)
            .collect();
            let z = r.aov.pixels[k].depth;
            if r.aov.pixels[k].primid < 0.0
                || ring.iter().any(|&n| {
                    r.aov.pixels[n].primid < 0.0 || (r.aov.pixels[n].depth - z).abs() > 0.02 * z
                })
            {
                continue;
            }
            let y = luminance(&r.image, k);
            let ys: Vec<f32> = ring.iter().map(|&n| luminance(&r.image, n)).collect();
            let (lo, hi) = ys
                .iter()
                .fold((f32::MAX, 0.0f32), |(a, b), &v| (a.min(v), b.max(v)));
            if lo >= lit && y < 0.5 * lo {
                dark += 1;
                at.push((i as u32, j as u32));
            }
            if y > 2.0 * hi && hi >= lit {
                bright += 1;
            }
        }
    }
    (dark, bright, at)
}

/// A shipped scene, meshes from the test model path.
fn shipped(name: &str) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{name}.toml"));
    fragtrace::scene::load_scene_with_search_path(&path, &common::model_path())
        .unwrap_or_else(|e| panic!("{e}"))
}

/// The shadow terminator (docs/robustness.md, "The shadow terminator"): dragon.toml at its
/// 640x480 default, rendered with shadow rays from the triangles (`--terminator exact`)
/// and from the smooth surface (`smooth`, the default), on the f64 and f32 CPU and on GL
/// (the default kernel and the thesis's multipass). Dark speckles (see [`speckles`]) on the
/// lit jade go, no bright one appears, and no pixel gets darker. teapot.toml has no
/// vertex normals, so the technique must leave it bit for bit (its few dark pixels are
/// real concave-crease shadows of the faceted mesh).
#[test]
fn smooth_terminator_removes_dark_speckles() {
    let dragon = shipped("dragon");
    let teapot = shipped("teapot");
    let exact = Techniques::default().with_terminator(Terminator::Exact);
    let smooth = Techniques::default().with_terminator(Terminator::Smooth);
    let render = |scene: &Scene, tech, where_: &str, ctx: Option<&GlContext>| {
        let mut o = RenderOptions::for_scene(scene);
        o.techniques = tech;
        o.backend = if ctx.is_some() {
            Backend::Gl
        } else {
            Backend::Cpu
        };
        o.precision = if where_ == "CPU f64" {
            Precision::F64
        } else {
            Precision::F32
        };
        if where_ == "GL looped" {
            o.gpu.kernel = Kernel::Looped;
        }
        match ctx {
            Some(ctx) => render_gl_with(ctx, scene, &o).unwrap(),
            None => render_cpu(scene, &o).unwrap(),
        }
    };
    let mut rows = Vec::new();
    let mut check = |where_: &str, ctx: Option<&GlContext>| {
        let (a, b) = (
            render(&dragon, exact, where_, ctx),
            render(&dragon, smooth, where_, ctx),
        );
        let (sa, sb) = (speckles(&a, 0.05), speckles(&b, 0.05));
        let d = differences(&a, &b);
        // Pixels the smooth origin darkens by more than 1e-2 in some channel.
        let darker = a
            .image
            .data
            .chunks(3)
            .zip(b.image.data.chunks(3))
            .filter(|(x, y)| x.iter().zip(y.iter()).any(|(p, q)| *q < p - 1e-2))
            .count();
        println!(
            "[terminator] dragon {where_}: dark speckles exact {} smooth {} (left at {:?}); \
             bright speckles {} / {}; {} pixels changed by > 1e-2: {} brighter, {darker} darker",
            sa.0, sb.0, sb.2, sa.1, sb.1, d.above_1e2, d.brighter,
        );
        rows.push((
            where_.to_string(),
            sa.0,
            sb.0,
            sa.1 + sb.1,
            d.primary,
            darker,
        ));
        let (t0, t1) = (
            render(&teapot, exact, where_, ctx),
            render(&teapot, smooth, where_, ctx),
        );
        assert!(
            t0.image.data == t1.image.data,
            "teapot {where_}: the terminator changed a mesh without vertex normals"
        );
    };
    check("CPU f64", None);
    check("CPU f32", None);
    with_test_context(|ctx| {
        check("GL", Some(ctx));
        check("GL looped", Some(ctx));
    });
    for (where_, before, after, bright, moved, darker) in rows {
        // Measured: 22 dark speckles with shadow rays from the triangles on every backend,
        // 3 with the smooth terminator (two where both lights lie below the triangle's own
        // plane, which no shadow ray changes; one on a grazing light). The smooth
        // terminator's shadow ray is the exact one less its start, so no pixel gets darker
        // (Hanika's parallel lifted ray darkened 47..72 by > 1e-2: shadow edges it moved).
        assert!(
            before >= 12,
            "{where_}: only {before} dark speckles without the technique"
        );
        assert!(
            after <= 4,
            "{where_}: {after} dark speckles left of {before}"
        );
        assert_eq!(bright, 0, "{where_}: bright speckles");
        assert_eq!(moved, 0, "{where_}: a camera ray moved");
        assert_eq!(darker, 0, "{where_}: {darker} pixels darker");
    }
}

/// The smooth terminator casts no false light (issue 50): a smooth-shaded triangle whose
/// vertex normals lift the smooth surface 0.41 above the point seen (Hanika's lift; the
/// triangle's longest edge is 2.24), a light 30° above its plane, and a wall 1.5 away whose
/// top lies half that lift above the segment from the point to the light. The segment is
/// blocked, so every pixel of the triangle is black (no ambient, no background); Hanika's
/// lifted ray passed over the wall and lit all of them. Without the wall every pixel is lit.
/// CPU f64 (each CPU path) and f32, each GL kernel.
#[test]
fn smooth_terminator_does_not_jump_an_occluder() {
    let (lift, top) = (
        0.406_686_4f64,
        1.5 * 30f64.to_radians().tan() + 0.406_686_4 / 2.0,
    );
    let n = |x: f64, z: f64| DVec3::new(0.3 * x, 1.0, 0.3 * z).normalize();
    let tri = [(-1.0, -1.0), (0.0, 1.0), (1.0, -1.0)];
    let mut obj = String::new();
    for (x, z) in tri {
        obj += &format!("v {x} 0 {z}\n");
    }
    for (x, z) in tri {
        let v = n(x, z);
        obj += &format!("vn {} {} {}\n", v.x, v.y, v.z);
    }
    obj += "f 1//1 2//2 3//3\n";
    let wall =
        format!("v 1.5 0.3 -1\nv 1.5 0.3 1\nv 1.5 {top} 1\nv 1.5 {top} -1\nf 4 5 6\nf 4 6 7\n");
    let lp = DVec3::new(0.0, 0.0, -0.2) + DVec3::new(30f64.to_radians().cos(), 0.5, 0.0) * 20.0;
    let toml = format!(
        "ambient = [0.0, 0.0, 0.0]\nbackground = [0.0, 0.0, 0.0]\nmax_depth = 0\n\
         [camera]\neye = [0.0, 3.0, 0.3]\nlook_at = [0.0, 0.0, -0.2]\nfov = 10\n\
         [[lights]]\nposition = [{}, {}, {}]\nintensity = 1.0\n\
         [materials.white]\nalbedo = [1.0, 1.0, 1.0]\n\
         [[objects]]\nmesh = \"jump.obj\"\nmaterial = \"white\"\n",
        lp.x, lp.y, lp.z
    );
    let scene = |with_wall: bool| {
        let mut files = fragtrace::scene::MeshTexts::new();
        let text = if with_wall {
            obj.clone() + &wall
        } else {
            obj.clone()
        };
        files.insert("jump.obj".to_string(), text);
        fragtrace::scene::load_scene_str_with_texts(&toml, "jump.toml", &files).unwrap()
    };
    let (walled, open) = (scene(true), scene(false));
    // The closed form: the wall blocks the segment from the centre to the light, and it
    // would not block one lifted by `lift` (its top is lift/2 above the segment there).
    let t = 1.5 / 30f64.to_radians().cos();
    assert!(t * 0.5 < top && top < t * 0.5 + lift);
    let render = |scene: &Scene, where_: &str, ctx: Option<&GlContext>| {
        let mut o = RenderOptions::for_scene(scene);
        o.width = 9;
        o.height = 9;
        o.backend = if ctx.is_some() {
            Backend::Gl
        } else {
            Backend::Cpu
        };
        o.precision = if where_.starts_with("CPU f64") {
            Precision::F64
        } else {
            Precision::F32
        };
        o.cpu_path = match where_ {
            "CPU f64 simd" => CpuPath::Simd,
            "CPU f64 scalar" => CpuPath::Scalar,
            _ => CpuPath::Packet,
        };
        o.gpu.kernel = match where_ {
            "GL compute" => Kernel::Compute,
            "GL looped" => Kernel::Looped,
            "GL unrolled" => Kernel::Unrolled(4),
            "GL multipass" => Kernel::Multipass,
            _ => o.gpu.kernel,
        };
        match ctx {
            Some(ctx) => render_gl_with(ctx, scene, &o).unwrap(),
            None => render_cpu(scene, &o).unwrap(),
        }
    };
    let check = |where_: &str, ctx: Option<&GlContext>| {
        let lit = |r: &fragtrace::render::Rendered| {
            r.image
                .data
                .chunks(3)
                .filter(|c| c.iter().any(|&v| v > 0.0))
                .count()
        };
        let (a, b) = (render(&walled, where_, ctx), render(&open, where_, ctx));
        assert_eq!(lit(&a), 0, "{where_}: pixels lit behind the wall");
        assert_eq!(lit(&b), 81, "{where_}: pixels unlit without the wall");
    };
    for where_ in ["CPU f64", "CPU f64 simd", "CPU f64 scalar", "CPU f32"] {
        check(where_, None);
    }
    with_test_context(|ctx| {
        for where_ in ["GL compute", "GL looped", "GL unrolled", "GL multipass"] {
            check(where_, Some(ctx));
        }
    });
}
