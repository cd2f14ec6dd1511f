//! Cases of rays spawned at a hit, exactly as the renderer spawns them (`surface`,
//! `secondary`, `offset_origin`): no self-intersection from 1e-4 to 1e4 (5), two surfaces
//! 1e-3 apart (17), and shadow acne in a lit scene rendered at three scales (16). The CPU
//! spawns in each precision; GL traces the f32 CPU's spawned rays (its spawn pass is the
//! f32 arithmetic's twin, tests/glsl_twins.rs), so it tests the GPU's intersection kernel.

use crate::common::Rng;
use crate::support::*;
use fragtrace::accel::Grid;
use fragtrace::cpu::real::{Real, V3};
use fragtrace::cpu::shade::{offset_origin, secondary, surface, Secondary, SurfacePoint};
use fragtrace::cpu::traverse::{Accel, Ray, Work};
use fragtrace::gpu::shader::Query;
use fragtrace::gpu::with_test_context;
use fragtrace::image_io::Image;
use fragtrace::render::Rendered;
use fragtrace::scene::{Material, Scene};
use glam::{DVec3, Vec3};

/// A ray spawned at a hit: the triangle it leaves, its kind (an index into the case's
/// kinds), the ray in the CPU precision and rounded to f32 for GL.
struct Spawned<T: Real> {
    own: u32,
    kind: usize,
    ray: Ray<T>,
    f32ray: TRay,
}

/// The renderer's view of the closest hit of `r` (normalised first, as camera rays are):
/// the triangle, the surface point and the secondary directions of material 0.
fn hit_and_secondary<T: Real>(
    scene: &Scene,
    accel: &Accel<T>,
    r: &TRay,
) -> Option<(u32, SurfacePoint<T>, Secondary<T>)> {
    let mut ray = r.cpu::<T>();
    ray.d = ray.d.normalize();
    let hit = accel.closest_hit(&ray, &mut Work::default())?;
    let sp = surface(scene, &accel.tris[hit.tri as usize], &hit, ray.d);
    let sec = secondary(&scene.materials[0], &sp, ray.d);
    Some((hit.tri, sp, sec))
}

/// A ray leaving `sp` along `d` from `offset_origin`, as the renderer spawns it.
fn spawn<T: Real>(own: u32, kind: usize, sp: &SurfacePoint<T>, d: V3<T>, t_max: T) -> Spawned<T> {
    let o = offset_origin(sp, d);
    let ray = Ray {
        o,
        d,
        t_min: T::ZERO,
        t_max,
    };
    Spawned {
        own,
        kind,
        f32ray: TRay::from_cpu(&ray),
        ray,
    }
}

/// The triangle each spawned ray hits first, in its own precision.
fn trace_spawned<T: Real>(s: &Scene, grid: &Grid, spawned: &[Spawned<T>]) -> Vec<Option<u32>> {
    let accel = Accel::<T>::new(s, grid);
    spawned
        .iter()
        .map(|x| {
            accel
                .closest_hit(&x.ray, &mut Work::default())
                .map(|h| h.tri)
        })
        .collect()
}

/// Per kind, how many spawned rays `bad(own, hit)` holds for.
fn per_kind<T: Real>(
    spawned: &[Spawned<T>],
    hits: &[Option<u32>],
    bad: impl Fn(u32, Option<u32>) -> bool,
) -> [usize; 3] {
    let mut n = [0; 3];
    for (x, h) in spawned.iter().zip(hits) {
        n[x.kind] += bad(x.own, *h) as usize;
    }
    n
}

/// The f32 CPU's spawned rays as (own triangle, kind, ray) for GL.
fn for_gl(spawned: &[Spawned<f32>]) -> Vec<(u32, usize, TRay)> {
    spawned.iter().map(|x| (x.own, x.kind, x.f32ray)).collect()
}

/// One decade of case 5: 300 random glass triangles of size ~`scale`, a light, and 1500
/// rays aimed at interior points of random triangles.
struct Decade {
    scale: f64,
    scene: Scene,
    grid: Grid,
    primary: Vec<TRay>,
}

impl Decade {
    fn new(rng: &mut Rng, e: i32) -> Self {
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
        }
        scene
            .lights
            .push(light((offset + rng.dir() * 30.0 * s).as_vec3(), 1.0));
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
        Decade {
            scale: s,
            scene,
            grid,
            primary,
        }
    }

    /// The reflected (kind 0), refracted (1) and light (2, t_max = distance) rays spawned
    /// at every primary hit, in precision `T`.
    fn spawn<T: Real>(&self) -> Vec<Spawned<T>> {
        let accel = Accel::<T>::new(&self.scene, &self.grid);
        let light = V3::<T>::from_vec3(self.scene.lights[0].position);
        let mut out = Vec::new();
        for r in &self.primary {
            let Some((tri, sp, sec)) = hit_and_secondary(&self.scene, &accel, r) else {
                continue;
            };
            out.push(spawn(tri, 0, &sp, sec.reflected, T::BIG));
            if sec.kt.max_elem() > T::ZERO {
                out.push(spawn(tri, 1, &sp, sec.refracted, T::BIG));
            }
            let o = offset_origin(&sp, light - sp.p);
            let dl = light - o;
            let dist = dl.length();
            out.push(spawn(tri, 2, &sp, dl * (T::ONE / dist), dist));
        }
        out
    }
}

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
    let decades: Vec<Decade> = (-4..=4).map(|e| Decade::new(&mut rng, e)).collect();
    let own = |own: u32, hit: Option<u32>| hit == Some(own);
    let mut checks = Checks::new();
    let mut gl_batches = Vec::new();
    for d in &decades {
        let s64 = d.spawn::<f64>();
        let s32 = d.spawn::<f32>();
        let h64 = per_kind(&s64, &trace_spawned(&d.scene, &d.grid, &s64), own);
        let h32 = per_kind(&s32, &trace_spawned(&d.scene, &d.grid, &s32), own);
        for (b, h, n) in [(BACKENDS[0], h64, s64.len()), (BACKENDS[1], h32, s32.len())] {
            let line = format!(
                "scale {:.0e}: {n} spawned rays, self-hits reflected/refracted/light = {h:?}",
                d.scale
            );
            checks.line(
                "case 05",
                b,
                h.iter().sum::<usize>() == 0 && n >= 1500,
                line,
            );
        }
        gl_batches.push(for_gl(&s32));
    }
    with_test_context(|ctx| {
        for (d, batch) in decades.iter().zip(&gl_batches) {
            let rays: Vec<TRay> = batch.iter().map(|b| b.2).collect();
            let closest = gl_trace(ctx, &d.scene, &d.grid, &rays, Query::Closest);
            let any = gl_trace(ctx, &d.scene, &d.grid, &rays, Query::Any);
            let mut n = [0usize; 3];
            let mut n_any = 0;
            for (k, &(own, kind, _)) in batch.iter().enumerate() {
                n[kind] += (closest[k].tri() == Some(own)) as usize;
                n_any += (any[k].tri() == Some(own)) as usize;
            }
            let line = format!(
                "scale {:.0e}: {} spawned rays (from CPU f32), self-hits closest reflected/refracted/light = {n:?}, any-hit {n_any}",
                d.scale,
                rays.len()
            );
            checks.line("case 05", "GL", n.iter().sum::<usize>() + n_any == 0, line);
        }
    });
    checks.done();
}

/// Two 10x10 quads 1e-3 apart (1e-4 of the scene size), at the origin and translated by
/// (100, 100, 100). Rays from either side, down to 85 degrees from the normal, must hit the
/// near quad; rays transmitted through the near quad (spawned by `offset_origin`, f32 CPU
/// spawns for GL) must hit the far one: no leak and no overshoot of the gap.
#[test]
fn case_17_close_parallel_surfaces() {
    let mut rng = Rng::new("case 17", 0x9a9_u64);
    let gap = 1e-3;
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
    /// The transmitted continuation of each ray that hits.
    fn transmit<T: Real>(s: &Scene, grid: &Grid, rays: &[TRay]) -> Vec<Spawned<T>> {
        let accel = Accel::<T>::new(s, grid);
        rays.iter()
            .filter_map(|r| hit_and_secondary(s, &accel, r))
            .map(|(tri, sp, sec)| spawn(tri, 0, &sp, sec.refracted, T::BIG))
            .collect()
    }
    // Front quad: triangles 0 and 1.
    let wrong_side = |own: u32, got: Option<u32>| got.is_none_or(|t| (own < 2) == (t < 2));
    let mut checks = Checks::new();
    let mut cpu = Vec::new();
    for (_, s, grid, rays, _) in &prepared {
        let sp64 = transmit::<f64>(s, grid, rays);
        let sp32 = transmit::<f32>(s, grid, rays);
        let bad64 = per_kind(&sp64, &trace_spawned(s, grid, &sp64), wrong_side)[0];
        let bad32 = per_kind(&sp32, &trace_spawned(s, grid, &sp32), wrong_side)[0];
        cpu.push((bad64, bad32, for_gl(&sp32)));
    }
    // (primary hits on the three backends, GL hits of the f32 CPU's transmitted rays)
    let gl: Vec<([Vec<Found>; 3], Vec<Found>)> = with_test_context(|ctx| {
        prepared
            .iter()
            .zip(&cpu)
            .map(|((_, s, grid, rays, _), (_, _, sp))| {
                let spawned: Vec<TRay> = sp.iter().map(|x| x.2).collect();
                (
                    closest_all(ctx, s, grid, rays),
                    gl_trace(ctx, s, grid, &spawned, Query::Closest),
                )
            })
            .collect()
    });
    for (k, (offset, _, _, rays, want_front)) in prepared.iter().enumerate() {
        let (primary, gl_through) = &gl[k];
        let leaks = count(primary, |j, f| {
            f.tri().map(|t| t < 2) != Some(want_front[j])
        });
        let (bad64, bad32, sp) = &cpu[k];
        let bad_gl = sp
            .iter()
            .zip(gl_through)
            .filter(|((own, _, _), f)| wrong_side(*own, f.tri()))
            .count();
        for (bi, bad) in [*bad64, *bad32, bad_gl].into_iter().enumerate() {
            let line = format!(
                "offset {}: {} rays: {} hit the far surface or nothing; transmitted rays that missed the other surface: {bad}",
                offset.x,
                rays.len(),
                leaks[bi]
            );
            checks.line("case 17", BACKENDS[bi], leaks[bi] + bad == 0, line);
        }
    }
    checks.done();
}

/// Case 16's scene at scale `k` (geometry, camera and light scaled alike): a ground quad,
/// a box, a smooth and a flat icosphere(3), and a low light so that shadows are long and
/// shadow rays graze. Direct light only.
fn acne_scene(k: f64) -> Scene {
    let sc = |v: DVec3| (v * k).as_vec3();
    let mut s = Scene::empty(camera(
        sc(DVec3::new(0.0, 5.0, 11.0)),
        sc(DVec3::new(0.0, 0.5, 0.0)),
        45.0,
    ));
    s.ambient = Vec3::splat(0.05);
    s.background = Vec3::ZERO;
    let m = s.add_material(diffuse(Vec3::splat(0.8)));
    add_ground(&mut s, 0.0, 8.0 * k, DVec3::ZERO, m);
    add_box(
        &mut s,
        Vec3::new(1.5, 1.0, 1.0),
        m,
        k,
        DVec3::new(-2.0, 0.51, 0.0) * k,
    );
    add_sphere(&mut s, 3, true, m, k, DVec3::new(1.5, 1.05, -1.0) * k);
    add_sphere(&mut s, 3, false, m, 0.7 * k, DVec3::new(0.3, 0.75, 2.0) * k);
    s.lights.push(light(sc(DVec3::new(9.0, 2.5, 3.0)), 1.0));
    s.max_depth = 0;
    s
}

/// One lit scene (ground quad, box, flat and smooth spheres, low light so shadows are long
/// and shadow rays graze) rendered at scales 1, 1e-3 and 1e3 (geometry, camera and light
/// scaled alike). Shadow acne would darken lit pixels; the lit-pixel count at each scale
/// must stay within 1% of the unscaled count, per backend.
#[test]
fn case_16_scaled_scene_no_shadow_acne() {
    let scales = [1.0, 1e-3, 1e3];
    let scenes: Vec<Scene> = scales.iter().map(|&k| acne_scene(k)).collect();
    let renders: Vec<[Rendered; 3]> =
        with_test_context(|ctx| scenes.iter().map(|s| render_all(ctx, s)).collect());
    // Ambient-only level is 0.8 * 0.05 = 0.04; lit means clearly above it.
    let lit = |img: &Image| pixels(img).filter(|p| p[0] > 0.06).count();
    let mut checks = Checks::new();
    for (bi, b) in BACKENDS.iter().enumerate() {
        let base = lit(&renders[0][bi].image);
        let mut line = format!("lit pixels at scale 1: {base}");
        let mut ok = true;
        for (si, &k) in scales.iter().enumerate().skip(1) {
            let r = &renders[si][bi];
            assert!(r.image.all_finite(), "{b} scale {k}: NaN pixel");
            let n = lit(&r.image);
            let delta = n as i64 - base as i64;
            line.push_str(&format!("; at {k:e}: {n} ({delta:+})"));
            if delta.abs() as f64 > (0.01 * base as f64).max(2.0) {
                dump(&format!("case16-{b}-{k:e}"), &r.image);
                ok = false;
            }
        }
        checks.line("case 16", b, ok, line);
        assert!(
            base > 400,
            "{b}: only {base} lit pixels, the scene is not lit"
        );
    }
    checks.done();
}
