//! Unit tests of the shading model (`shade.rs`), each against an independent answer:
//! surface points, normals and error bounds of triangles worked out by hand, spawn offsets
//! checked against the f64 plane of the triangle they leave, checker squares counted by
//! hand, and reflection, Snell refraction and the Fresnel equations against their textbook
//! closed forms (sines and tangents of the two angles, which the renderer does not use).
//! Written after `cargo mutants` found the shading model covered only by the integration
//! tests (docs/testing.md).

use glam::Vec3;

use super::*;
use crate::cpu::intersect::{intersect_watertight, RayShear};
use crate::scene::{Checker, CheckerAxes, Triangle};
use crate::technique::{TBound, Techniques, Terminator};
use crate::testing::{gamma64, scene_of, test_seed, Rng};

fn v(x: f64, y: f64, z: f64) -> V3<f64> {
    V3::new(x, y, z)
}

fn assert_close(a: V3<f64>, b: V3<f64>, tol: f64, what: &str) {
    let e = (a - b).abs().max_elem();
    assert!(
        e <= tol,
        "{what}: {a:?} vs {b:?} (error {e:e}, bound {tol:e})"
    );
}

/// A flat surface point at `p` with unit geometric normal `ng`, hit from the side `d`
/// comes from, shading normal equal to the facing normal unless `ns` is given.
fn point(p: V3<f64>, ng: V3<f64>, d: V3<f64>, ns: Option<V3<f64>>) -> SurfacePoint<f64> {
    let entering = d.dot(ng) < 0.0;
    let nf = if entering { ng } else { -ng };
    SurfacePoint {
        p,
        p_err: V3::splat(0.0),
        ng,
        nf,
        ns: ns.unwrap_or(nf),
        entering,
        material: 0,
        gap: 0.0,
        reach: 0.0,
        flipped: false,
    }
}

fn deg(a: f64) -> f64 {
    a.to_radians()
}

#[test]
fn surface_of_a_flat_triangle_from_both_sides() {
    // (v1 - v0) x (v2 - v0) = (2,0,0) x (0,4,0) = (0,0,8): the winding normal is +z.
    let tri = [
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(2.0, 0.0, 1.0),
        Vec3::new(0.0, 4.0, 1.0),
    ];
    let mut scene = scene_of(&[tri]);
    scene.add_material(Material::default());
    scene.triangles[0].material = 1;
    let verts = tri.map(V3::<f64>::from_vec3);
    let hit = Hit {
        t: 3.0,
        tri: 0,
        b: [0.25, 0.5, 0.25],
    };
    let front = surface(&scene, &verts, &hit, v(0.0, 0.0, -1.0));
    // 0.25·(0,0,1) + 0.5·(2,0,1) + 0.25·(0,4,1), every product and sum exact.
    assert_eq!(front.p, v(1.0, 1.0, 1.0));
    // Σ|v_i b_i| = (0,0,.25) + (1,0,.5) + (0,1,.25) = (1,1,1), times γ(7).
    assert_eq!(front.p_err, V3::splat(gamma64(7.0)));
    assert_eq!(front.ng, v(0.0, 0.0, 1.0));
    assert_eq!(front.nf, v(0.0, 0.0, 1.0));
    assert_eq!(front.ns, v(0.0, 0.0, 1.0));
    assert!(front.entering);
    assert_eq!(front.material, 1);

    let back = surface(&scene, &verts, &hit, v(0.1, 0.2, 1.0));
    assert_eq!(
        back.ng,
        v(0.0, 0.0, 1.0),
        "ng follows the winding, not the ray"
    );
    assert_eq!(back.nf, v(0.0, 0.0, -1.0));
    assert_eq!(back.ns, v(0.0, 0.0, -1.0));
    assert!(!back.entering);
    // A ray in the plane (d·ng = 0) is not entering.
    assert!(!surface(&scene, &verts, &hit, v(1.0, 0.0, 0.0)).entering);
}

#[test]
fn surface_of_a_zero_area_triangle_is_finite() {
    // Collinear: the normal is the zero vector; the guard substitutes +y, never NaN.
    let tri = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
    let scene = scene_of(&[tri]);
    let verts = tri.map(V3::<f64>::from_vec3);
    let hit = Hit {
        t: 1.0,
        tri: 0,
        b: [0.5, 0.5, 0.0],
    };
    let sp = surface(&scene, &verts, &hit, v(0.0, -1.0, 0.0));
    assert_eq!(sp.ng, v(0.0, 1.0, 0.0));
    assert_eq!(sp.ns, v(0.0, 1.0, 0.0));
    assert!(sp.entering);
}

/// One triangle in z = 0 (winding normal +z) with the given vertex normals.
fn smooth_scene(normals: [Vec3; 3]) -> (Scene, [V3<f64>; 3]) {
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let mut scene = scene_of(&[tri]);
    scene.normals = normals.to_vec();
    scene.triangles[0] = Triangle {
        n: [0, 1, 2],
        ..scene.triangles[0]
    };
    (scene, tri.map(V3::from_vec3))
}

#[test]
fn smooth_normals_interpolate_and_face_the_ray() {
    let (scene, verts) = smooth_scene([
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.6, 0.0, 0.8),
        Vec3::new(0.0, 0.6, 0.8),
    ]);
    let hit = Hit {
        t: 1.0,
        tri: 0,
        b: [0.5, 0.25, 0.25],
    };
    // 0.5·(0,0,1) + 0.25·(.6,0,.8) + 0.25·(0,.6,.8) = (.15, .15, .9), then normalised.
    let s = v(0.15, 0.15, 0.9) * (1.0 / (0.15f64 * 0.15 * 2.0 + 0.81).sqrt());
    let front = surface(&scene, &verts, &hit, v(0.0, 0.0, -1.0));
    assert_close(front.ns, s, 1e-7, "front shading normal");
    assert!((front.ns.length() - 1.0).abs() < 1e-15);
    assert_eq!(
        front.nf,
        v(0.0, 0.0, 1.0),
        "the geometric normal stays flat"
    );
    let back = surface(&scene, &verts, &hit, v(0.0, 0.0, 1.0));
    assert_close(
        back.ns,
        -s,
        1e-7,
        "back shading normal, flipped to face the ray",
    );

    // Vertex normals that cancel at the hit leave the facing geometric normal.
    let (scene, verts) = smooth_scene([Vec3::Z, -Vec3::Z, Vec3::Z]);
    let hit = Hit {
        t: 1.0,
        tri: 0,
        b: [0.5, 0.5, 0.0],
    };
    let sp = surface(&scene, &verts, &hit, v(0.0, 0.0, -1.0));
    assert_eq!(sp.ns, v(0.0, 0.0, 1.0));
}

#[test]
fn offset_moves_one_ulp_past_the_error_bound_on_the_side_of_w() {
    let tri = [
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(2.0, 0.0, 1.0),
        Vec3::new(0.0, 4.0, 1.0),
    ];
    let scene = scene_of(&[tri]);
    let verts = tri.map(V3::<f64>::from_vec3);
    let hit = Hit {
        t: 3.0,
        tri: 0,
        b: [0.25, 0.5, 0.25],
    };
    let sp = surface(&scene, &verts, &hit, v(0.0, 0.0, -1.0));
    // p = (1,1,1), p_err = γ(7)·(1,1,1), ng = +z: the bound along the normal is γ(7).
    let z0 = 1.0 + gamma64(7.0);
    let up = offset_origin(&sp, v(0.3, 0.0, 1.0));
    assert_eq!(up.x, 1.0, "no offset along x, so no nudge");
    assert_eq!(up.y, 1.0);
    // One more rounding step: |z|·2u (+1e-30) is just over one ulp of z in [1, 2).
    assert_eq!(up.z, z0 + f64::EPSILON);
    let down = offset_origin(&sp, v(0.3, 0.0, -1.0));
    assert_eq!((down.x, down.y), (1.0, 1.0));
    let z1 = 1.0 - gamma64(7.0);
    assert!(
        down.z < z1 && down.z >= z1 - 2.0 * f64::EPSILON,
        "{}",
        down.z
    );

    // A coordinate the offset lands on exactly zero still moves, by the 1e-30 floor.
    let at_zero = SurfacePoint {
        p: v(-0.5, 2.0, 3.0),
        p_err: v(0.5, 0.0, 0.0),
        ..point(v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(-1.0, 0.0, 0.0), None)
    };
    let o = offset_origin(&at_zero, v(1.0, 0.0, 0.0));
    assert_eq!(o, v(f64::from(1e-30f32), 2.0, 3.0));
    let o = offset_origin(&at_zero, v(-1.0, 0.0, 0.0));
    assert_eq!(
        o.x,
        -1.0 - f64::EPSILON,
        "-0.5 - 0.5, then one ulp of 1 away"
    );
}

#[test]
fn epsilon_offset_is_fixed_along_the_geometric_normal() {
    let sp = point(v(1.0, 2.0, 3.0), v(0.0, 0.0, 1.0), v(0.0, 0.0, -1.0), None);
    let eps = OFFSET_EPSILON;
    let up = offset_origin_with(&sp, v(0.0, 0.5, 1.0), OffsetMethod::Epsilon);
    assert_eq!(up, v(1.0, 2.0, 3.0 + eps));
    let down = offset_origin_with(&sp, v(0.0, 0.5, -1.0), OffsetMethod::Epsilon);
    assert_eq!(down, v(1.0, 2.0, 3.0 - eps));
    // The error-bound method on a point with no error only nudges.
    let eb = offset_origin_with(&sp, v(0.0, 0.5, 1.0), OffsetMethod::ErrorBound);
    assert_eq!(eb, v(1.0, 2.0, 3.0));
}

/// An exact tie (a dot product of zero) keeps the positive side in all three of the
/// shading model's sign decisions, as glsl120/shade.glsl's `< 0.0` tests do (its
/// `surface` and `offset_origin`), so the two renderers agree on a direction lying in the
/// surface's plane and on a shading normal perpendicular to the face. `cargo mutants` found
/// these ties unpinned (`<` -> `<=` survived at each).
#[test]
fn zero_dot_ties_keep_the_positive_side_like_the_glsl_twin() {
    let sp = SurfacePoint {
        p_err: v(0.0, 0.0, 0.25),
        ..point(v(1.0, 2.0, 3.0), v(0.0, 0.0, 1.0), v(0.0, 0.0, -1.0), None)
    };
    let in_plane = v(1.0, 0.5, 0.0);
    assert_eq!(sp.ng.dot(in_plane), 0.0);
    let eps = offset_origin_with(&sp, in_plane, OffsetMethod::Epsilon);
    assert_eq!(eps, v(1.0, 2.0, 3.0 + OFFSET_EPSILON));
    let eb = offset_origin_with(&sp, in_plane, OffsetMethod::ErrorBound);
    assert_eq!((eb.x, eb.y), (1.0, 2.0));
    // 3 + 0.25, then the nudge of a few ulps: above the bound, never below the plane.
    assert!(eb.z > 3.25 && eb.z < 3.25 + 1e-14, "{}", eb.z);

    // Vertex normals along +x on a face in z = 0: the interpolated normal is perpendicular
    // to the face from either side, and is kept as interpolated, not flipped.
    let (scene, verts) = smooth_scene([Vec3::X, Vec3::X, Vec3::X]);
    let hit = Hit {
        t: 1.0,
        tri: 0,
        b: [0.5, 0.25, 0.25],
    };
    for d in [v(0.0, 0.0, -1.0), v(0.0, 0.0, 1.0)] {
        let sp = surface(&scene, &verts, &hit, d);
        assert_eq!(sp.ns.dot(sp.nf), 0.0);
        assert_eq!(sp.ns, v(1.0, 0.0, 0.0), "ray {d:?}");
    }
}

/// f32 spawn points on random triangles: the offset origin lies strictly on `w`'s side of
/// the triangle's plane (evaluated in f64 from the same f32 vertices), and a ray from it
/// along `w` never hits the triangle again with the default intersection (t_min = 0). The
/// offset alone does not promise that: the intersection's own rounding can still report a
/// hit at t ~ 1e-10 (seed 1, case 208, without the t bound), which is the t bound's job.
#[test]
fn offset_origins_leave_the_surface_in_f32() {
    let seed = test_seed("offset_origins_leave_the_surface", 0x000F_F5E7);
    let mut rng = Rng::new(seed);
    let mut checked = 0;
    for case in 0..4_000 {
        let scale = [1e-3, 1.0, 1e3, 1e5][case % 4];
        let a = rng.dvec3(-1.0, 1.0) * scale;
        let tri = [
            a.as_vec3(),
            (a + rng.dvec3(-1.0, 1.0) * scale).as_vec3(),
            (a + rng.dvec3(-1.0, 1.0) * scale).as_vec3(),
        ];
        let verts = tri.map(V3::<f32>::from_vec3);
        let vd = tri.map(|p| p.as_dvec3());
        let n64 = (vd[1] - vd[0]).cross(vd[2] - vd[0]);
        if n64.length() < 1e-6 * scale * scale {
            continue;
        }
        let (u, w1) = (rng.f64(), rng.f64());
        let (b1, b2) = if u + w1 > 1.0 {
            (1.0 - u, 1.0 - w1)
        } else {
            (u, w1)
        };
        let b = [(1.0 - b1 - b2) as f32, b1 as f32, b2 as f32];
        let d = V3::<f32>::from_dvec3(rng.dvec3(-1.0, 1.0).normalize());
        let hit = Hit { t: 1.0, tri: 0, b };
        let scene = scene_of(&[tri]);
        let sp = surface(&scene, &verts, &hit, d);
        for w in [reflect(d, sp.nf), d] {
            let o = offset_origin(&sp, w);
            let side = (o.to_dvec3() - vd[0]).dot(n64);
            let want = w.to_dvec3().dot(n64);
            if want.abs() < 1e-3 * n64.length() {
                continue; // w grazes the plane
            }
            checked += 1;
            assert!(
                side * want > 0.0,
                "case {case}: origin {o:?} on the wrong side (seed {seed})"
            );
            let again =
                intersect_watertight(o, &RayShear::new(w), &verts, 0.0, f32::MAX, TBound::On);
            assert!(
                again.is_none(),
                "case {case}: re-hit {again:?} (seed {seed})"
            );
        }
    }
    println!("{checked} spawned rays checked");
    assert!(checked > 7_000, "only {checked} spawned rays checked");
}

fn checker(axes: CheckerAxes, scale: f32, phase: [f32; 2]) -> Material {
    Material {
        albedo: Vec3::new(0.5, 0.5, 0.5),
        checker: Some(Checker {
            color_a: Vec3::new(1.0, 0.0, 0.0),
            color_b: Vec3::new(0.0, 0.0, 1.0),
            scale,
            axes,
            phase,
        }),
        ..Material::default()
    }
}

#[test]
fn checker_squares_counted_by_hand() {
    let (a, b) = (v(1.0, 0.0, 0.0), v(0.0, 0.0, 1.0));
    let plain = Material::default();
    assert_eq!(albedo(&plain, v(0.3, 0.1, 0.2)), V3::splat(0.8f32 as f64));
    let m = checker(CheckerAxes::Xz, 1.0, [0.0, 0.0]);
    // floor(x) + floor(z): 0+0 even, 1+0 odd, -1+0 odd, -1-1 even; y is ignored.
    assert_eq!(albedo(&m, v(0.5, 9.0, 0.5)), a);
    assert_eq!(albedo(&m, v(1.5, 9.0, 0.5)), b);
    assert_eq!(albedo(&m, v(-0.5, 9.0, 0.5)), b);
    assert_eq!(albedo(&m, v(-0.5, 9.0, -0.5)), a);
    assert_eq!(albedo(&m, v(2.5, 0.0, 1.5)), b);
    // Squares of two units: (1.5, 0.5) is in square (0, 0), (2.5, 0.5) in (1, 0).
    let m = checker(CheckerAxes::Xz, 2.0, [0.0, 0.0]);
    assert_eq!(albedo(&m, v(1.5, 0.0, 0.5)), a);
    assert_eq!(albedo(&m, v(2.5, 0.0, 0.5)), b);
    assert_eq!(albedo(&m, v(2.5, 0.0, 2.5)), a);
    // The phase shifts the local coordinates: 0.75 + 0.5 crosses into square 1.
    let m = checker(CheckerAxes::Xz, 1.0, [0.5, 0.0]);
    assert_eq!(albedo(&m, v(0.75, 0.0, 0.5)), b);
    assert_eq!(albedo(&m, v(0.25, 0.0, 0.5)), a);
    let m = checker(CheckerAxes::Xz, 1.0, [0.0, 0.5]);
    assert_eq!(albedo(&m, v(0.25, 0.0, 0.75)), b);
    // The other planes read their own axes.
    let m = checker(CheckerAxes::Yz, 1.0, [0.0, 0.0]);
    assert_eq!(albedo(&m, v(7.5, 1.5, 0.5)), b);
    assert_eq!(albedo(&m, v(7.5, 1.5, 1.5)), a);
    let m = checker(CheckerAxes::Xy, 1.0, [0.0, 0.0]);
    assert_eq!(albedo(&m, v(0.5, 1.5, 7.5)), b);
    assert_eq!(albedo(&m, v(1.5, 1.5, 7.5)), a);
}

#[test]
fn reflection_closed_forms() {
    assert_eq!(
        reflect(v(0.6, -0.8, 0.0), v(0.0, 1.0, 0.0)),
        v(0.6, 0.8, 0.0)
    );
    assert_eq!(
        reflect(v(1.0, 2.0, -3.0), v(0.0, 0.0, 1.0)),
        v(1.0, 2.0, 3.0)
    );
    let mirror = Material {
        kr: Vec3::new(0.5, 0.25, 0.125),
        ..Material::default()
    };
    let d = v(0.6, 0.0, -0.8);
    let sp = point(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), d, None);
    let s = secondary(&mirror, &sp, d);
    assert_eq!(s.reflected, v(0.6, 0.0, 0.8));
    assert_eq!(s.kr, v(0.5, 0.25, 0.125));
    assert_eq!(s.kt, V3::splat(0.0));
    assert_eq!(s.refracted, V3::splat(0.0));
}

#[test]
fn mirror_ray_below_the_surface_reflects_about_the_true_normal() {
    // A shading normal tilted 60° towards the ray: reflecting about it sends the ray into
    // the surface, so the geometric normal is used.
    let d = v(0.8, 0.0, -0.6);
    let ns = v(deg(60.0).sin(), 0.0, deg(60.0).cos());
    let sp = point(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), d, Some(ns));
    assert!(reflect(d, ns).z < 0.0, "the case this test is about");
    let s = secondary(&Material::default(), &sp, d);
    assert_eq!(s.reflected, v(0.8, 0.0, 0.6));
    // A mild tilt keeps the shading normal's mirror direction.
    let ns = v(deg(10.0).sin(), 0.0, deg(10.0).cos());
    let sp = point(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), d, Some(ns));
    assert_eq!(
        secondary(&Material::default(), &sp, d).reflected,
        reflect(d, ns)
    );
}

fn glass(fresnel: bool) -> Material {
    Material {
        kr: Vec3::splat(0.25),
        kt: Vec3::splat(0.5),
        ior: 1.5,
        fresnel,
        ..Material::default()
    }
}

/// The direction Snell's law gives in the xz plane: angle `theta_t` from the normal
/// `(0, 0, zsign)` the ray travels along, towards +x.
fn snell_dir(theta_t: f64, zsign: f64) -> V3<f64> {
    v(theta_t.sin(), 0.0, zsign * theta_t.cos())
}

/// Fresnel reflectance of unpolarised light from the two angles (Born & Wolf's form;
/// undefined at normal incidence, which is checked against ((n1 - n2) / (n1 + n2))^2).
fn fresnel_angles(ti: f64, tt: f64) -> f64 {
    let rs = -(ti - tt).sin() / (ti + tt).sin();
    let rp = (ti - tt).tan() / (ti + tt).tan();
    (rs * rs + rp * rp) / 2.0
}

#[test]
fn refraction_follows_snell_entering_and_leaving() {
    // Entering glass (n 1 -> 1.5) at 45° from above a +z surface.
    let ti = deg(45.0);
    let d = v(ti.sin(), 0.0, -ti.cos());
    let sp = point(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), d, None);
    let s = secondary(&glass(false), &sp, d);
    let tt = (ti.sin() / 1.5).asin();
    assert_close(s.refracted, snell_dir(tt, -1.0), 1e-15, "entering");
    assert_eq!(s.kr, V3::splat(0.25));
    assert_eq!(s.kt, V3::splat(0.5));

    // Leaving glass (1.5 -> 1) at 30°, from below the +z surface (the ray goes up).
    let ti = deg(30.0);
    let d = v(ti.sin(), 0.0, ti.cos());
    let sp = point(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), d, None);
    assert!(!sp.entering);
    let s = secondary(&glass(false), &sp, d);
    let tt = (1.5 * ti.sin()).asin();
    assert_close(s.refracted, snell_dir(tt, 1.0), 1e-15, "leaving");
    assert_eq!((s.kr, s.kt), (V3::splat(0.25), V3::splat(0.5)));

    // Leaving at 45°: past the critical angle asin(1/1.5) = 41.8°, all is reflected.
    let ti = deg(45.0);
    let d = v(ti.sin(), 0.0, ti.cos());
    let sp = point(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), d, None);
    let s = secondary(&glass(false), &sp, d);
    assert_eq!(s.kr, V3::splat(0.75), "kr + kt");
    assert_eq!(s.kt, V3::splat(0.0));
    let s = secondary(&glass(true), &sp, d);
    assert_eq!(s.kr, V3::splat(1.0));
    assert_eq!(s.kt, V3::splat(0.0));
    assert_close(
        s.reflected,
        v(ti.sin(), 0.0, -ti.cos()),
        1e-15,
        "TIR mirror",
    );
}

/// Snell's law about a shading normal tilted 10° from the face, entering and leaving: the
/// transmitted ray is sin θt τ − cos θt n_s for the tangent τ of the plane of incidence,
/// and Fresnel's reflectance is the textbook one at the angles measured from n_s. With the
/// shading normal equal to the face normal (the other refraction tests) a wrong formula
/// about n_s hides behind the fallback about n_g; `cargo mutants` found that.
#[test]
fn refraction_about_a_tilted_shading_normal_follows_snell() {
    let a = deg(10.0);
    // (ray going down into glass, n_s), (ray going up out of it, n_s): the face is z = 0.
    let cases = [
        (deg(50.0), 1.0 / 1.5, -1.0, "entering"),
        (deg(25.0), 1.5, 1.0, "leaving"),
    ];
    for (ti, eta, up, what) in cases {
        // n_s faces the ray (down for a rising ray); τ is its tangent in the xz plane.
        let ns = v(a.sin(), 0.0, -up * a.cos());
        let tau = v(a.cos(), 0.0, up * a.sin());
        let d = tau * ti.sin() - ns * ti.cos();
        let sp = point(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), d, Some(ns));
        assert_eq!(sp.entering, up < 0.0, "{what}");
        let tt = (eta * ti.sin()).asin();
        let expected = tau * tt.sin() - ns * tt.cos();
        assert!(expected.dot(sp.nf) < -0.5, "{what}: no fallback involved");
        let s = secondary(&glass(false), &sp, d);
        assert_close(s.refracted, expected, 1e-15, what);
        assert_eq!((s.kr, s.kt), (V3::splat(0.25), V3::splat(0.5)), "{what}");
        let s = secondary(&glass(true), &sp, d);
        assert_close(s.refracted, expected, 1e-15, what);
        let f = fresnel_angles(ti, tt);
        assert!((s.kr.x - f).abs() < 1e-15, "{what}: {} vs {f}", s.kr.x);
        assert!((s.kt.x - (1.0 - f)).abs() < 1e-15, "{what}");
    }
}

/// Exactly at the critical angle (k = 1 − η²(1 − cos²θi) evaluates to 0, found by a search
/// over f64 cosines for η = 1.5) the ray still refracts, grazing along the surface, and
/// Fresnel's reflectance is exactly 1 there, so both sides of the boundary meet: one ulp
/// steeper the ray is transmitted, one ulp shallower it is totally reflected. This is the
/// `k < 0.0` of glsl120/shade.glsl too.
#[test]
fn critical_angle_exactly_grazes_and_meets_total_reflection() {
    let c = f64::from_bits(0x3FE7_D9F4_CF75_4635); // 0.7453559924999299
    assert_eq!(1.0 - 2.25 * (1.0 - c * c), 0.0);
    let leaving = |cos_i: f64| {
        let d = v((1.0 - cos_i * cos_i).sqrt(), 0.0, cos_i);
        let sp = point(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), d, None);
        assert!(!sp.entering);
        (sp, d)
    };
    let (sp, d) = leaving(c);
    let s = secondary(&glass(false), &sp, d);
    assert_close(s.refracted, v(1.0, 0.0, 0.0), 1e-16, "along the surface");
    assert_eq!((s.kr, s.kt), (V3::splat(0.25), V3::splat(0.5)));
    let s = secondary(&glass(true), &sp, d);
    assert_eq!((s.kr, s.kt), (V3::splat(1.0), V3::splat(0.0)));

    let (sp, d) = leaving(c.next_up());
    let s = secondary(&glass(false), &sp, d);
    assert_eq!(s.kt, V3::splat(0.5), "one ulp steeper: transmitted");
    let (sp, d) = leaving(c.next_down());
    let s = secondary(&glass(false), &sp, d);
    assert_eq!(
        (s.kr, s.kt),
        (V3::splat(0.75), V3::splat(0.0)),
        "one ulp shallower: totally reflected"
    );
}

/// When the shading normal sends the transmitted ray back to the side it came from,
/// `secondary` bends it about the facing normal n_f instead. As long as n_s · n_f ≥ 0 (which
/// `surface` ensures) that only happens past n_f's critical angle: with x = η cos θi about
/// n_s, y = η cos θg about n_f and c = η² − 1, the wrong side needs y ≤ x − √(x² − c) =
/// c / (x + √(x² − c)) ≤ √c, so k_g = 1 − η² + y² ≤ 0 and the ray leaves along the surface,
/// the projection of d on the face. Random directions and shading normals, against that
/// projection: the mutants of k_g's formula cannot change the result (docs/testing.md).
#[test]
fn wrong_side_fallback_grazes_along_the_surface() {
    let seed = test_seed("wrong_side_fallback_grazes", 0x0006_2A2E);
    let mut rng = Rng::new(seed);
    let (mut fallbacks, mut transmitted, mut worst) = (0, 0, [0.0f64; 2]);
    for case in 0..50_000 {
        let d = V3::<f64>::from_dvec3(rng.dvec3(-1.0, 1.0));
        let ns = V3::<f64>::from_dvec3(rng.dvec3(-1.0, 1.0));
        if d.length() < 0.1 || ns.length() < 0.1 {
            continue;
        }
        let d = d.normalize();
        let sp0 = point(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), d, None);
        let ns = ns.normalize();
        let ns = if ns.dot(sp0.nf) < 0.0 { -ns } else { ns };
        let sp = SurfacePoint { ns, ..sp0 };
        let s = secondary(&glass(false), &sp, d);
        if s.kt.x == 0.0 {
            continue; // totally reflected about n_s
        }
        transmitted += 1;
        // Snell about n_s, from the tangential part of d.
        let eta = if sp.entering { 1.0 / 1.5 } else { 1.5 };
        let tangential = d + ns * -d.dot(ns);
        let sin_t = eta * tangential.length();
        let snell = tangential * eta - ns * (1.0 - sin_t * sin_t).sqrt();
        let side = snell.dot(sp.nf);
        let (k, expected) = if side < -1e-9 {
            (0, snell.normalize())
        } else if side > 1e-9 {
            fallbacks += 1;
            (1, (d - sp.nf * d.dot(sp.nf)).normalize())
        } else {
            continue; // too close to the face to tell which branch runs
        };
        let err = (s.refracted - expected).abs().max_elem();
        worst[k] = worst[k].max(err);
        assert!(
            err < [1e-13, 2e-15][k],
            "case {case}: {:?}, expected {expected:?} ({}) for d {d:?}, n_s {ns:?} (seed {seed})",
            s.refracted,
            ["Snell about n_s", "along the face"][k]
        );
    }
    println!("{transmitted} transmitted, {fallbacks} through the fallback; worst error {worst:?}");
    // Measured (default seed): 31,608 transmitted, 685 through the fallback; worst errors
    // 7.8e-15 about n_s (where the ray leaves nearly along the face) and 3.3e-16 along it.
    // Seeds 1-4: 601-636 fallbacks, up to 2.4e-14 and 3.3e-16. The bounds sit 4x and 6x
    // above the largest, the count 2x below the smallest.
    assert!(fallbacks > 300, "only {fallbacks} fallbacks (seed {seed})");
}

#[test]
fn fresnel_matches_the_textbook_equations() {
    // Normal incidence: ((n1 - n2) / (n1 + n2))^2 = 0.04 for glass, from either side.
    for (d, what) in [
        (v(0.0, 0.0, -1.0), "entering"),
        (v(0.0, 0.0, 1.0), "leaving"),
    ] {
        let sp = point(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), d, None);
        let s = secondary(&glass(true), &sp, d);
        assert_close(s.kr, V3::splat(0.04), 1e-15, what);
        assert_close(s.kt, V3::splat(0.96), 1e-15, what);
        assert_close(s.refracted, d, 1e-15, what);
    }
    for deg_i in [10.0, 30.0, 45.0, 60.0, 80.0, 89.0] {
        let ti = deg(deg_i);
        let d = v(ti.sin(), 0.0, -ti.cos());
        let sp = point(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), d, None);
        let s = secondary(&glass(true), &sp, d);
        let tt = (ti.sin() / 1.5).asin();
        let f = fresnel_angles(ti, tt);
        assert!((s.kr.x - f).abs() < 1e-14, "{deg_i}°: {} vs {f}", s.kr.x);
        assert!((s.kt.x - (1.0 - f)).abs() < 1e-14);
        // Leaving at the refracted angle, the same path backwards: the same reflectance.
        let back = v(tt.sin(), 0.0, tt.cos());
        let sp = point(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), back, None);
        let s = secondary(&glass(true), &sp, back);
        // Measured 6.0e-14 at 89°, where cos θt = sqrt(1 - 2.25 sin² θi) cancels.
        let e = (s.kr.x - f).abs();
        assert!(e < 2e-13, "{deg_i}° reversed: {} vs {f} ({e:e})", s.kr.x);
        assert_close(s.refracted, snell_dir(ti, 1.0), 5e-14, "reversed direction");
        // 1.2e-14
    }
}

#[test]
fn transmitted_ray_on_the_wrong_side_bends_about_the_true_normal() {
    // Leaving glass at 60° with a shading normal tilted 20° away: refracting about the
    // shading normal would send the ray back inside. About the true normal 60° is past the
    // critical angle, so the clamped bend leaves the ray along the surface, (1, 0, 0).
    let ti = deg(60.0);
    let d = v(ti.sin(), 0.0, ti.cos());
    let a = deg(-20.0);
    let ns = v(a.sin(), 0.0, -a.cos());
    let sp = point(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), d, Some(ns));
    let s = secondary(&glass(false), &sp, d);
    assert_close(s.refracted, v(1.0, 0.0, 0.0), 1e-15, "bent about ng");
    assert_eq!(s.kt, V3::splat(0.5), "transmission is kept");
}

#[test]
fn light_term_closed_forms() {
    let m = Material {
        kd: 0.5,
        ks: Vec3::splat(0.25),
        ns: 10.0,
        ..Material::default()
    };
    let albedo = v(1.0, 0.5, 0.25);
    let radiance = v(2.0, 4.0, 8.0);
    let d = v(0.0, 0.0, -1.0);
    let sp = point(v(0.0, 0.0, 0.0), v(0.0, 0.0, 1.0), d, None);
    let l = v(0.0, 0.6, 0.8);
    // Viewer on the mirror direction of the light: r·v = 1.
    let c = light_term(&m, albedo, &sp, l, v(0.0, -0.6, 0.8), radiance);
    let want = (albedo * (0.5 * 0.8) + V3::splat(0.25)).mul_elem(radiance);
    assert_close(c, want, 1e-15, "mirror viewer");
    // Viewer overhead: r = (0, -.6, .8), r·v = 0.8.
    let c = light_term(&m, albedo, &sp, l, v(0.0, 0.0, 1.0), radiance);
    let want = (albedo * 0.4 + V3::splat(0.25 * 0.8f64.powi(10))).mul_elem(radiance);
    assert_close(c, want, 1e-15, "overhead viewer");
    // Viewer past the light: r·v = -0.576 + 0.224 < 0 clamps to 0 (the even power would
    // not).
    let c = light_term(&m, albedo, &sp, l, v(0.0, 0.96, 0.28), radiance);
    assert_close(
        c,
        (albedo * 0.4).mul_elem(radiance),
        1e-15,
        "clamped highlight",
    );
    // No specular colour: diffuse only.
    let matte = Material {
        ks: Vec3::ZERO,
        ..m.clone()
    };
    let c = light_term(&matte, albedo, &sp, l, v(0.0, -0.6, 0.8), radiance);
    assert_close(c, (albedo * 0.4).mul_elem(radiance), 1e-15, "matte");
    // A light at or below the horizon adds nothing, highlight included.
    for l in [v(0.0, 1.0, 0.0), v(0.0, 0.6, -0.8)] {
        let c = light_term(&m, albedo, &sp, l, -l, radiance);
        assert_eq!(c, V3::splat(0.0), "light {l:?}");
    }
}

/// The octant triangle of the unit sphere with the sphere's normals at its vertices.
fn octant() -> (Scene, [V3<f64>; 3]) {
    let tri = [Vec3::X, Vec3::Y, Vec3::Z];
    let mut scene = scene_of(&[tri]);
    scene.normals = tri.to_vec();
    scene.triangles[0] = Triangle {
        n: [0, 1, 2],
        ..scene.triangles[0]
    };
    (scene, tri.map(V3::from_vec3))
}

/// The terminator gap by hand on the sphere octant (vertex normals = vertices): p·v_k - 1
/// is p's height above vertex k's tangent plane. At the centroid each is -2/3, so the gap
/// is Σ (1/3)(2/3)·v_k·nf = 2/(3√3), Hanika's lift, between the flat face (|p| = 0.577)
/// and the sphere (1); seen from inside (the flipped side) the same distance. At
/// b = (0.9, 0.05, 0.05) the heights are -0.1, -0.95, -0.95 and the gap 0.185/√3. The
/// smooth terminator's shadow ray is the exact one less its first 2·gap / cos θ (θ from the
/// face normal), at most a third of the longest edge (√2/3).
#[test]
fn terminator_gap_of_the_sphere_octant() {
    let (scene, verts) = octant();
    let third = 1.0 / 3.0;
    let at = |b: [f64; 3], d: V3<f64>| {
        let hit = Hit { t: 1.0, tri: 0, b };
        surface(&scene, &verts, &hit, d.normalize())
    };
    let outside = at([third; 3], v(-1.0, -1.0, -1.0));
    assert_close(outside.p, v(third, third, third), 1e-15, "centroid");
    let gap = 2.0 / (3.0 * 3f64.sqrt());
    assert!((outside.gap - gap).abs() < 1e-15, "{}", outside.gap);
    let inside = at([third; 3], v(1.0, 1.0, 1.0));
    assert!((inside.gap - gap).abs() < 1e-15, "{}", inside.gap);
    let reach = 2f64.sqrt() / 3.0;
    assert!((outside.reach - reach).abs() < 1e-15, "{}", outside.reach);

    let exact_tech = Techniques::default().with_terminator(Terminator::Exact);
    let sp = at([0.9, 0.05, 0.05], v(-1.0, -1.0, -1.0));
    let gap = 0.185 / 3f64.sqrt();
    assert!((sp.gap - gap).abs() < 1e-15, "{}", sp.gap);
    let t = v(1.0, -1.0, 0.0).normalize();
    for (deg, skip) in [(0.0f64, 2.0 * gap), (60.0, 4.0 * gap), (80.0, reach)] {
        let (c, s) = (deg.to_radians().cos(), deg.to_radians().sin());
        let lp = sp.p + (sp.nf * c + t * s) * 10.0;
        let (o, l, dist) = shadow_ray(&sp, lp, Techniques::default()).unwrap();
        let (oe, le, de) = shadow_ray(&sp, lp, exact_tech).unwrap();
        assert_eq!(oe, offset_origin(&sp, lp - sp.p));
        assert_eq!(l, le, "{deg}°: the exact ray's direction");
        assert!((de - dist - skip).abs() < 1e-13, "{deg}°: {de} - {dist}");
        assert_close(o, oe + l * skip, 1e-14, "on the exact ray");
    }
    // No vertex normals: the exact ray, bit for bit.
    let flat = SurfacePoint {
        gap: 0.0,
        reach: 0.0,
        ..sp
    };
    let lp = v(3.0, 3.0, 3.0);
    assert_eq!(
        shadow_ray(&flat, lp, Techniques::default()),
        shadow_ray(&flat, lp, exact_tech)
    );
}

/// A vertex normal perpendicular to the face (as at Sponza's sharp edges) adds nothing:
/// only the gap's component along the facing normal counts; a point above the three
/// tangent planes (a concave fold, as at dragon.toml's pixel (292, 206)) gets the same gap
/// as one below them by as much.
#[test]
fn terminator_gap_is_along_the_face_normal_on_both_sides() {
    let (scene, verts) = smooth_scene([Vec3::Z, Vec3::Z, Vec3::new(-1.0, 0.0, 0.0)]);
    let hit = Hit {
        t: 1.0,
        tri: 0,
        b: [0.25, 0.25, 0.5],
    };
    let sp = surface(&scene, &verts, &hit, v(0.0, 0.0, -1.0));
    // h_2 = (p - (0,1,0))·(-1,0,0) = -0.25: Hanika's point moves 0.5·0.25 along -x; the
    // other two planes contain p. Nothing of it is along +z.
    assert_eq!(sp.gap, 0.0);
    assert_eq!(sp.reach, 0.0);
    // Concave: normals tilted towards the centre, so p lies above each tangent plane by
    // 0.75, 1.25 and 0.75 times s/|n|; convex (tilted away), below by as much.
    let s = 0.6f32;
    let (scene, verts) = smooth_scene([
        Vec3::new(s, s, 1.0).normalize(),
        Vec3::new(-s, s, 1.0).normalize(),
        Vec3::new(s, -s, 1.0).normalize(),
    ]);
    let concave = surface(&scene, &verts, &hit, v(0.0, 0.0, -1.0));
    let (scene, verts) = smooth_scene([
        Vec3::new(-s, -s, 1.0).normalize(),
        Vec3::new(s, -s, 1.0).normalize(),
        Vec3::new(-s, s, 1.0).normalize(),
    ]);
    let convex = surface(&scene, &verts, &hit, v(0.0, 0.0, -1.0));
    let n2 = 1.0 + 2.0 * (s as f64) * (s as f64);
    let want = (0.25 * 0.75 + 0.25 * 1.25 + 0.5 * 0.75) * s as f64 / n2;
    assert!((convex.gap - want).abs() < 1e-7, "{} vs {want}", convex.gap);
    assert!((concave.gap - convex.gap).abs() < 1e-7, "{}", concave.gap);
    assert!((convex.reach - 2f64.sqrt() / 3.0).abs() < 1e-15);
}
