//! Intersection (t and barycentrics, every technique) and the DDA helpers, GLSL vs CPU.

use super::harness::*;
use crate::common::with_test_context;
use fragtrace::accel::{Grid, GridConfig};
use fragtrace::cpu::intersect::{intersect_with, RayShear};
use fragtrace::cpu::real::V3;
use fragtrace::scene::{Camera, Material, Scene};
use fragtrace::technique::{IntersectMethod, TBound, Techniques};
use glam::Vec3;

/// Barycentrics of the watertight test, GLSL vs CPU f32, in ulps. The same operations in
/// the same order: measured bit-exact (0 ulps) on llvmpipe over the 4 x 720 hits below; the
/// bound leaves room for a driver that contracts a*b+c into an fma. Adding 1e-7 to the
/// GLSL's b2 (under one f32::EPSILON) made 268 of the 720 default-technique hits fail.
const B_ULPS_WATERTIGHT: u32 = 4;

/// Barycentrics of Möller–Trumbore, GLSL vs CPU f32, as |difference| / f32::EPSILON (an
/// absolute bound: b0 = 1 - u - v cancels, so ulps of a small b0 say little). llvmpipe
/// compiles GLSL's `cross`/`dot` to other roundings (order, fusing), so they differ: measured
/// 9 x EPSILON at most; the bound is about 3.5 times that.
const B_EPS_MOLLER_TRUMBORE: f32 = 32.0;

/// Barycentrics of both tests on a driver that contracts into fmas ([`exact_driver`] false),
/// as |difference| / f32::EPSILON. Measured on the H200: 48.5 (watertight), 62.5
/// (Moller-Trumbore); about 2x.
const B_EPS_CONTRACTING: f32 = 128.0;

#[test]
fn intersect_glsl_equals_cpu_f32() {
    let seed = 0xfeed_beef_u64;
    println!("seed = {seed:#x}");
    let mut r = Rng(seed);
    let mut cases = Vec::new();
    for i in 0..2048 {
        let o = [r.f() * 3.0, r.f() * 3.0, r.f() * 3.0 + 4.0];
        let p = [
            [r.f(), r.f(), r.f()],
            [r.f(), r.f(), r.f()],
            [r.f(), r.f(), r.f()],
        ];
        let c = [
            (p[0][0] + p[1][0] + p[2][0]) / 3.0,
            (p[0][1] + p[1][1] + p[2][1]) / 3.0,
            (p[0][2] + p[1][2] + p[2][2]) / 3.0,
        ];
        let d = [
            c[0] - o[0] + r.f() * 0.3,
            c[1] - o[1] + r.f() * 0.3,
            c[2] - o[2] + r.f() * 0.3,
        ];
        // Every third case has a finite t_max, some below the hit.
        let t_max = if i % 3 == 0 { 1e30 } else { 2.0 + r.f() * 4.0 };
        cases.push(vec![
            [o[0], o[1], o[2], 0.0],
            [d[0], d[1], d[2], t_max],
            [p[0][0], p[0][1], p[0][2], 0.0],
            [p[1][0], p[1][1], p[1][2], 0.0],
            [p[2][0], p[2][1], p[2][2], 0.0],
        ]);
    }
    let body = "    mat3 P; vec3 S; shear_setup(in1.xyz, P, S);\n    result = intersect_tri(in0.xyz, in1.xyz, P, S, in2.xyz, in3.xyz, in4.xyz, in0.w, in1.w);";
    // Every intersection technique: the default (watertight with the t bound) and the
    // switchable alternatives (src/technique.rs).
    let d = Techniques::default();
    let settings = [
        d,
        d.with_t_bound(TBound::Off),
        d.with_intersect(IntersectMethod::MollerTrumbore),
        d.with_intersect(IntersectMethod::MollerTrumbore)
            .with_t_bound(TBound::Off),
    ];
    for tech in settings {
        let (got, exact) = with_test_context(|ctx| {
            (
                run_cases_grid(ctx, body, &cases, None, tech),
                exact_driver(ctx),
            )
        });
        let (mut hits, mut mismatches, mut max_b_ulps, mut max_b_abs) =
            (0, Vec::new(), 0u32, 0.0f32);
        for (i, (c, g)) in cases.iter().zip(&got).enumerate() {
            let v = |t: [f32; 4]| V3::<f32>::new(t[0], t[1], t[2]);
            let tri = [v(c[2]), v(c[3]), v(c[4])];
            let (o, dir) = (v(c[0]), v(c[1]));
            let want = intersect_with(o, dir, &RayShear::new(dir), &tri, c[0][3], c[1][3], &tech);
            // Every check is written so that a NaN fails it: `!(x <= bound)` is true for NaN.
            match want {
                Some(h) => {
                    hits += 1;
                    let t_ok = g[0] > 0.0 && (g[0] - h.t).abs() <= 1e-5 * h.t.abs().max(1.0);
                    let b_ulps = (0..3).map(|k| ulps(g[k + 1], h.b[k])).fold(0u32, u32::max);
                    // NaN-propagating max: f32::max would drop a NaN.
                    let b_abs = (0..3)
                        .map(|k| (g[k + 1] - h.b[k]).abs() / f32::EPSILON)
                        .fold(0.0f32, |a, x| if a >= x { a } else { x });
                    max_b_ulps = max_b_ulps.max(b_ulps);
                    max_b_abs = if max_b_abs >= b_abs { max_b_abs } else { b_abs };
                    let b_ok = match (exact, tech.intersect) {
                        (true, IntersectMethod::Watertight) => b_ulps <= B_ULPS_WATERTIGHT,
                        (true, IntersectMethod::MollerTrumbore) => b_abs <= B_EPS_MOLLER_TRUMBORE,
                        (false, _) => b_abs <= B_EPS_CONTRACTING,
                    };
                    if !t_ok || !b_ok {
                        mismatches.push(format!(
                            "case {i}: cpu t {} b {:?}, gpu {:?} ({b_ulps} ulps, {b_abs} eps)",
                            h.t, h.b, g
                        ));
                    }
                }
                None => {
                    // A miss is exactly t = -1.0 (GLSL's miss value); NaN or any other
                    // value is a mismatch.
                    if g[0] != -1.0 {
                        mismatches.push(format!("case {i}: cpu miss, gpu {:?}", g));
                    }
                }
            }
        }
        println!(
            "{}: {hits} hits, {} mismatches, barycentrics within {max_b_ulps} ulps, {max_b_abs} x f32::EPSILON",
            tech.tag(),
            mismatches.len()
        );
        assert!(hits > 500, "{}: {hits} hits", tech.tag());
        assert!(
            mismatches.len() <= 2,
            "{}: {} of {} cases differ:\n{}",
            tech.tag(),
            mismatches.len(),
            cases.len(),
            mismatches[..mismatches.len().min(20)].join("\n")
        );
    }
}

#[test]
fn dda_helpers_glsl_equal_cpu_including_signed_zero_directions() {
    use fragtrace::cpu::traverse::{GridWalker, Ray};
    let mut s = Scene::empty(Camera {
        eye: Vec3::Z,
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
    });
    let m = s.add_material(Material::default());
    s.add_triangle(
        Vec3::new(-2.0, -1.0, -3.0),
        Vec3::new(2.0, 1.5, -3.0),
        Vec3::new(0.0, 1.0, 3.0),
        m,
    );
    let grid = Grid::build(
        &s,
        &GridConfig {
            res: fragtrace::accel::GridRes::Fixed([5, 7, 3]),
            ..GridConfig::default()
        },
    )
    .unwrap();
    let accel = GridWalker::<f32>::new(&s, &grid);
    let seed = 0x0dda_u64;
    println!("seed = {seed:#x}");
    let mut r = Rng(seed | 1);
    let mut cases = Vec::new();
    for i in 0..1024 {
        let o = [r.f() * 4.0, r.f() * 3.0, r.f() * 5.0];
        let mut d = [r.f(), r.f(), r.f()];
        // Signed zeros on one or two axes for half the cases.
        if i % 2 == 0 {
            d[i / 2 % 3] = if i % 4 == 0 { 0.0 } else { -0.0 };
        }
        if i % 8 == 0 {
            d[(i / 2 + 1) % 3] = -0.0;
        }
        cases.push(vec![[o[0], o[1], o[2], 0.0], [d[0], d[1], d[2], 1e30]]);
    }
    let body = "    vec2 span = clip_grid(in0.xyz, in1.xyz, 0.0, in1.w);\n    vec3 c = start_cell(in0.xyz, in1.xyz, span.x);\n    vec3 tn = boundaries(in0.xyz, in1.xyz, c);\n    result = span.x > span.y ? vec4(-1.0) : vec4(cell_linear(c), min(min(tn.x, tn.y), tn.z), span.x, span.y);";
    let got = with_test_context(|ctx| {
        run_cases_grid(ctx, body, &cases, Some(&grid), Techniques::default())
    });
    let mut bad = Vec::new();
    for (i, (c, g)) in cases.iter().zip(&got).enumerate() {
        assert!(g.iter().all(|v| !v.is_nan()), "case {i}: NaN {g:?}");
        let ray = Ray {
            o: V3::new(c[0][0], c[0][1], c[0][2]),
            d: V3::new(c[1][0], c[1][1], c[1][2]),
            t_min: 0.0,
            t_max: 1e30,
        };
        let want = accel.clip(&ray);
        match want {
            None => {
                if g[0] != -1.0 {
                    bad.push(format!("case {i}: cpu misses the grid, gpu {g:?}"));
                }
            }
            Some((t0, t1)) => {
                let cell = accel.start_cell(&ray, t0);
                let idx = cell[0] + accel.res[0] * (cell[1] + accel.res[1] * cell[2]);
                let exit = (0..3)
                    .map(|a| accel.boundary(&ray, a, cell[a]))
                    .fold(f32::MAX, f32::min);
                let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * a.abs().max(1.0);
                if g[0] != idx as f32 || !close(g[1], exit) || !close(g[2], t0) || !close(g[3], t1)
                {
                    bad.push(format!(
                        "case {i}: cpu cell {idx} exit {exit} span ({t0}, {t1}); gpu {g:?}"
                    ));
                }
            }
        }
    }
    assert!(
        bad.len() <= 3,
        "{} of {} differ:\n{}",
        bad.len(),
        cases.len(),
        bad[..bad.len().min(20)].join("\n")
    );
}
