//! Cases of rays spawned at a hit, exactly as the renderer spawns them (`surface`,
//! `secondary`, `offset_origin`): no self-intersection from 1e-4 to 1e4 (5), two surfaces
//! 1e-3 apart (17), and shadow acne in a lit scene rendered at three scales (16). The CPU
//! spawns in each precision; GL traces the f32 CPU's spawned rays (its spawn pass is the
//! f32 arithmetic's twin, tests/glsl_twins.rs), so it tests the GPU's intersection kernel.

use crate::common::with_test_context;
use crate::common::Rng;
use crate::support::*;
use fragtrace::accel::AccelKind;
use fragtrace::accel::AccelRef;
use fragtrace::cpu::real::{Real, V3};
use fragtrace::cpu::shade::{offset_origin, secondary, surface, Secondary, SurfacePoint};
use fragtrace::cpu::traverse::{Ray, Trace, Work};
use fragtrace::gpu::shader::Query;
use fragtrace::options::Precision;
use fragtrace::render::{render_cpu, Rendered};
use fragtrace::scene::{Material, Scene};
use fragtrace::technique::{TBound, Techniques};
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
    accel: &dyn Trace<T>,
    r: &TRay,
) -> Option<(u32, SurfacePoint<T>, Secondary<T>)> {
    let mut ray = r.cpu::<T>();
    ray.d = ray.d.normalize();
    let hit = accel.closest_hit(&ray, &mut Work::default())?;
    let sp = surface(scene, &accel.tris()[hit.tri as usize], &hit, ray.d);
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

/// The triangle each spawned ray hits first, in its own precision, through any structure.
fn trace_spawned<T: Real>(
    s: &Scene,
    grid: AccelRef<'_>,
    spawned: &[Spawned<T>],
) -> Vec<Option<u32>> {
    let accel = cpu_tracer::<T>(s, grid, Techniques::default());
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
    grid: Accels,
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
        let grid = accels(&scene);
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
    /// at every primary hit, in precision `T`, primary rays traced through `accel`.
    fn spawn<T: Real>(&self, accel: AccelKind) -> Vec<Spawned<T>> {
        let accel = cpu_tracer::<T>(&self.scene, self.grid.get(accel), Techniques::default());
        let light = V3::<T>::from_vec3(self.scene.lights[0].position);
        let mut out = Vec::new();
        for r in &self.primary {
            let Some((tri, sp, sec)) = hit_and_secondary(&self.scene, &*accel, r) else {
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
    for (d, kind) in decades.iter().flat_map(|d| CPU_ACCELS.map(|k| (d, k))) {
        let accel = d.grid.get(kind);
        let s64 = d.spawn::<f64>(kind);
        let s32 = d.spawn::<f32>(kind);
        let h64 = per_kind(&s64, &trace_spawned(&d.scene, accel, &s64), own);
        let h32 = per_kind(&s32, &trace_spawned(&d.scene, accel, &s32), own);
        let first = first_of(kind);
        for (b, h, n) in [
            (BACKENDS[first], h64, s64.len()),
            (BACKENDS[first + 1], h32, s32.len()),
        ] {
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
        // The grids' GL backends (the BVH has none).
        let batch = for_gl(&s32);
        for bi in (first..first + PER).filter(|&bi| is_gl(bi)) {
            gl_batches.push((d, kind, bi, batch.clone()));
        }
    }
    with_test_context(|ctx| {
        for (d, kind, bi, batch) in &gl_batches {
            let rays: Vec<TRay> = batch.iter().map(|b| b.2).collect();
            let accel = d.grid.get(*kind);
            let k = kernel_of(*bi);
            let closest = gl_trace(ctx, &d.scene, accel, &rays, Query::Closest, k);
            let any = gl_trace(ctx, &d.scene, accel, &rays, Query::Any, k);
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
            let ok = n.iter().sum::<usize>() + n_any == 0;
            checks.line("case 05", BACKENDS[*bi], ok, line);
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
        let grid = accels(&s);
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
    fn transmit<T: Real>(s: &Scene, grid: AccelRef<'_>, rays: &[TRay]) -> Vec<Spawned<T>> {
        let accel = cpu_tracer::<T>(s, grid, Techniques::default());
        rays.iter()
            .filter_map(|r| hit_and_secondary(s, &*accel, r))
            .map(|(tri, sp, sec)| spawn(tri, 0, &sp, sec.refracted, T::BIG))
            .collect()
    }
    // Front quad: triangles 0 and 1.
    let wrong_side = |own: u32, got: Option<u32>| got.is_none_or(|t| (own < 2) == (t < 2));
    let mut checks = Checks::new();
    // Per scene and structure (the BVH too): (CPU f64 and f32 bad transmissions, f32
    // spawned rays).
    let mut cpu = Vec::new();
    for (_, s, grid, rays, _) in &prepared {
        cpu.push(CPU_ACCELS.map(|kind| {
            let grid = grid.get(kind);
            let sp64 = transmit::<f64>(s, grid, rays);
            let sp32 = transmit::<f32>(s, grid, rays);
            let bad64 = per_kind(&sp64, &trace_spawned(s, grid, &sp64), wrong_side)[0];
            let bad32 = per_kind(&sp32, &trace_spawned(s, grid, &sp32), wrong_side)[0];
            (bad64, bad32, for_gl(&sp32))
        }));
    }
    // (primary hits on every backend, GL hits of the f32 CPU's transmitted rays per GL
    // backend, empty for the CPU ones)
    let gl: Vec<(AllFound, AllFound)> = with_test_context(|ctx| {
        prepared
            .iter()
            .zip(&cpu)
            .map(|((_, s, grid, rays, _), per)| {
                let through = std::array::from_fn(|bi| {
                    if !is_gl(bi) {
                        return Vec::new();
                    }
                    let spawned: Vec<TRay> = per[bi / PER].2.iter().map(|x| x.2).collect();
                    let accel = grid.get(accel_of(bi));
                    gl_trace(ctx, s, accel, &spawned, Query::Closest, kernel_of(bi))
                });
                (closest_all(ctx, s, grid, rays), through)
            })
            .collect()
    });
    for (k, (offset, _, _, rays, want_front)) in prepared.iter().enumerate() {
        let (primary, gl_through) = &gl[k];
        let leaks = count(primary, |j, f| {
            f.tri().map(|t| t < 2) != Some(want_front[j])
        });
        for (bi, leak) in leaks.into_iter().enumerate() {
            let (bad64, bad32, sp) = &cpu[k][bi / PER];
            let bad = match bi % PER {
                0 => *bad64,
                1 => *bad32,
                _ => sp
                    .iter()
                    .zip(&gl_through[bi])
                    .filter(|((own, _, _), f)| wrong_side(*own, f.tri()))
                    .count(),
            };
            let line = format!(
                "offset {}: {} rays: {leak} hit the far surface or nothing; transmitted rays that missed the other surface: {bad}",
                offset.x,
                rays.len(),
            );
            checks.line("case 17", BACKENDS[bi], leak + bad == 0, line);
        }
    }
    checks.done();
}

/// Closest hits on every backend, in `BACKENDS` order.
type AllFound = [Vec<Found>; NB];

/// A solid of case 16's scene, for an analytic shadow test: an icosphere between its
/// inscribed and circumscribed balls, or the box itself.
enum Solid {
    Ball { c: DVec3, inner: f64, outer: f64 },
    Box { min: DVec3, max: DVec3 },
}

impl Solid {
    /// Whether the segment p-q meets the solid grown by `grow` (shrunk when negative); a
    /// ball grows from its circumscribed radius and shrinks from its inscribed one.
    fn meets(&self, p: DVec3, q: DVec3, grow: f64) -> bool {
        match *self {
            Solid::Ball { c, inner, outer } => {
                let r = if grow >= 0.0 { outer } else { inner } + grow;
                let d = q - p;
                let t = ((c - p).dot(d) / d.length_squared()).clamp(0.0, 1.0);
                (p + d * t - c).length() < r
            }
            Solid::Box { min, max } => {
                let (lo, hi) = (min - DVec3::splat(grow), max + DVec3::splat(grow));
                let (mut t0, mut t1) = (0.0f64, 1.0f64);
                for a in 0..3 {
                    let d = q[a] - p[a];
                    if d == 0.0 {
                        if p[a] < lo[a] || p[a] > hi[a] {
                            return false;
                        }
                        continue;
                    }
                    let (ta, tb) = ((lo[a] - p[a]) / d, (hi[a] - p[a]) / d);
                    t0 = t0.max(ta.min(tb));
                    t1 = t1.min(ta.max(tb));
                }
                t0 <= t1
            }
        }
    }
}

/// Case 16's scene at one scale, with its solids (triangle range, shape) and light.
struct AcneScene {
    k: f64,
    scene: Scene,
    solids: Vec<(std::ops::Range<u32>, Solid)>,
    light: DVec3,
}

/// Case 16's scene at scale `k` (geometry, camera and light scaled alike): a ground quad,
/// a box, a smooth and a flat icosphere(3), and a low light so that shadows are long and
/// shadow rays graze. Direct light only.
fn acne_scene(k: f64) -> AcneScene {
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
    let (size, centre) = (Vec3::new(1.5, 1.0, 1.0), DVec3::new(-2.0, 0.51, 0.0) * k);
    let bx = add_box(&mut s, size, m, k, centre);
    let half = size.as_dvec3() * 0.5 * k;
    // The icosphere(3)'s inscribed radius: its faces' least distance from the centre.
    let (p, _, t) = fragtrace::scene::shapes::sphere(3);
    let inradius = t
        .iter()
        .map(|t| {
            let v = t.map(|i| p[i as usize].as_dvec3());
            (v[1] - v[0]).cross(v[2] - v[0]).normalize().dot(v[0]).abs()
        })
        .fold(1.0, f64::min);
    let mut solids = vec![(
        bx,
        Solid::Box {
            min: centre - half,
            max: centre + half,
        },
    )];
    for (smooth, r, c) in [
        (true, 1.0, DVec3::new(1.5, 1.05, -1.0)),
        (false, 0.7, DVec3::new(0.3, 0.75, 2.0)),
    ] {
        let range = add_sphere(&mut s, 3, smooth, m, r * k, c * k);
        let (inner, outer) = (inradius * r * k, r * k);
        solids.push((
            range,
            Solid::Ball {
                c: c * k,
                inner,
                outer,
            },
        ));
    }
    let light_at = DVec3::new(9.0, 2.5, 3.0) * k;
    s.lights.push(light(light_at.as_vec3(), 1.0));
    s.max_depth = 0;
    AcneScene {
        k,
        scene: s,
        solids,
        light: light_at,
    }
}

/// Ambient-only level is 0.8 * 0.05 = 0.04; lit means clearly above it (a surface facing
/// the light at n.l > 0.2 shows at least 0.04 + 0.8 * 0.2 = 0.2).
fn is_lit(p: [f32; 3]) -> bool {
    p[0] > 0.06
}

/// One backend's render of case 16 against the analytic shadows: pixels whose primary hit
/// (the f64 reference's, when the backend hits the same triangle) faces the light
/// (geometric n.l > 0.2) and whose segment to the light passes at least 2% of the scene
/// unit outside every other solid's circumscribed volume must be lit; those whose segment
/// passes 2% inside another solid must be dark. The rest (segments grazing a solid,
/// surfaces facing away or near their terminator) are not judged.
struct Census {
    surely_lit: usize,
    /// Surely lit but dark: shadow acne.
    acne: usize,
    surely_shadowed: usize,
    /// Surely shadowed but lit: a light leak.
    leaks: usize,
    lit: usize,
}

impl Census {
    fn new(a: &AcneScene, r: &Rendered, reference: &Rendered) -> Self {
        let margin = 0.02 * a.k;
        let cam = &a.scene.camera;
        let eye = cam.eye.as_dvec3();
        let px: Vec<[f32; 3]> = pixels(&r.image).collect();
        let mut c = Census {
            surely_lit: 0,
            acne: 0,
            surely_shadowed: 0,
            leaks: 0,
            lit: px.iter().filter(|p| is_lit(**p)).count(),
        };
        for (k, (mine, want)) in r.aov.pixels.iter().zip(&reference.aov.pixels).enumerate() {
            if want.primid < 0.0 || mine.primid != want.primid {
                continue;
            }
            let tri = want.primid as u32;
            let d = cam.pixel_direction(W, H, k as u32 % W, k as u32 / W);
            let p = eye + d * want.depth as f64;
            let mut n = Vec3::from(want.normal).as_dvec3().normalize();
            if n.dot(d) > 0.0 {
                n = -n;
            }
            if n.dot((a.light - p).normalize()) <= 0.2 {
                continue;
            }
            let others = a.solids.iter().filter(|(range, _)| !range.contains(&tri));
            let (mut may, mut surely) = (false, false);
            for (_, solid) in others {
                may |= solid.meets(p, a.light, margin);
                surely |= solid.meets(p, a.light, -margin);
            }
            if !may {
                c.surely_lit += 1;
                c.acne += !is_lit(px[k]) as usize;
            } else if surely {
                c.surely_shadowed += 1;
                c.leaks += is_lit(px[k]) as usize;
            }
        }
        c
    }
}

/// Case 16 on one backend at one scale: the analytic census, and (except for the f64
/// reference itself) the lit-pixel count against the f64 render of the same scale. Returns
/// the report line and whether it passed.
fn acne_check(a: &AcneScene, r: &Rendered, reference: &Rendered, is_ref: bool) -> (String, bool) {
    assert!(r.image.all_finite(), "scale {}: NaN pixel", a.k);
    let c = Census::new(a, r, reference);
    let want = pixels(&reference.image).filter(|p| is_lit(*p)).count();
    let delta = c.lit as i64 - want as i64;
    let mut line = format!(
        "scale {:e}: {} lit; analytic: {} of {} surely lit pixels dark (acne), {} of {} surely shadowed lit",
        a.k, c.lit, c.acne, c.surely_lit, c.leaks, c.surely_shadowed
    );
    // Measured on llvmpipe: 0 acne among 762-766 surely lit pixels and 0 leaks among 45
    // surely shadowed ones, on every backend at every scale; the f32 CPU lights exactly as
    // many pixels as f64 (921), GL 2 more at 1e3 (the H200 log's lit counts agree); the
    // BVH in f64 and f32 lights the grids' 921 at every scale, with 0 acne and 0 leaks.
    // With `--t-bound off` (next test) 230-256 of the surely lit pixels are dark on every
    // backend at every scale, so both the census and the count vs f64 (-271 to -299) fail.
    let mut ok = c.acne == 0 && c.leaks == 0 && c.surely_lit > 400 && c.surely_shadowed > 30;
    if !is_ref {
        line.push_str(&format!(", vs CPU f64 {delta:+}"));
        ok &= delta.abs() as f64 <= (0.01 * want as f64).max(2.0);
    }
    (line, ok)
}

/// One lit scene (ground quad, box, flat and smooth spheres, low light so shadows are long
/// and shadow rays graze) rendered at scales 1, 1e-3 and 1e3 (geometry, camera and light
/// scaled alike). Shadow acne darkens lit pixels: at every scale, every pixel that the
/// analytic occluders (the box, the spheres' inscribed and circumscribed balls) say is lit
/// must be lit, every one they say is shadowed must be dark, on every backend; and the f32
/// CPU and GL light as many pixels as f64 at the same scale (within 1%).
#[test]
fn case_16_scaled_scene_no_shadow_acne() {
    let scenes: Vec<AcneScene> = [1.0, 1e-3, 1e3].map(acne_scene).into();
    let renders: Vec<[Rendered; NB]> =
        with_test_context(|ctx| scenes.iter().map(|a| render_all(ctx, &a.scene)).collect());
    let mut checks = Checks::new();
    for (a, r) in scenes.iter().zip(&renders) {
        for (bi, b) in BACKENDS.iter().enumerate() {
            let (line, ok) = acne_check(a, &r[bi], &r[F64], bi == F64);
            if !ok {
                dump(&format!("case16-{b}-{:e}", a.k), &r[bi].image);
            }
            checks.line("case 16", b, ok, line);
        }
    }
    checks.done();
}

/// Case 16's check can fail: with the pbrt t bound switched off (`--t-bound off`), shadow
/// rays re-hit the surface they leave, and the check (against the analytic occluders and
/// the default-technique f64 render of the same scale) fails on every backend at every
/// scale. Measured on llvmpipe: 230-256 of 762-766 surely lit pixels dark, 622-650 lit
/// pixels instead of 921 (-27% to -32%). The old check (each backend against its own
/// count at scale 1, within 1%) passed on CPU f64 (641 / 643 / 642 at 1, 1e-3, 1e3) and
/// failed on f32 (639 / 650 / 622) and GL (644 / 639 / 629) only by the acne's noise
/// between scales, not by its 27% loss. The BVH's CPU f64 and f32 renders fail it alike
/// (f64 the uniform grid's 641 / 643 / 642 lit, f32 639 / 650 / 622; 230-256 dark).
#[test]
fn case_16_check_fails_without_the_t_bound() {
    let off = Techniques::default().with_t_bound(TBound::Off);
    let scenes: Vec<AcneScene> = [1.0, 1e-3, 1e3].map(acne_scene).into();
    let renders: Vec<([Rendered; NB], Rendered)> = with_test_context(|ctx| {
        scenes
            .iter()
            .map(|a| {
                let reference = render_cpu(&a.scene, &opts(&a.scene, Precision::F64)).unwrap();
                (render_all_with(ctx, &a.scene, off), reference)
            })
            .collect()
    });
    let mut passed = Vec::new();
    for (a, (r, reference)) in scenes.iter().zip(&renders) {
        for (bi, b) in BACKENDS.iter().enumerate() {
            let (line, ok) = acne_check(a, &r[bi], reference, false);
            println!(
                "[case 16 t-bound off] {b}: {line}: check {}",
                if ok { "PASSES" } else { "fails" }
            );
            if ok {
                passed.push(format!("{b} scale {:e}", a.k));
            }
        }
    }
    assert!(
        passed.is_empty(),
        "case 16 cannot see the acne of --t-bound off: {passed:?}"
    );
}
