//! Cases of the grid traversal: axis-aligned rays with signed zeros (7), origins on cell
//! and grid faces and rays through cell edges and corners (8-9), triangles lying on cell
//! faces and axis-parallel triangles (10-11). Each compares every backend with an
//! independent answer: a cell count from the origin's index, or brute force over every
//! triangle.

use crate::common::with_test_context;
use crate::common::Rng;
use crate::support::*;
use fragtrace::gpu::shader::{Query, RayState};
use fragtrace::scene::Scene;
use glam::{DVec3, Vec3};

/// An 8x8x8 grid whose only triangles sit in the 8 corner cells; axis-aligned rays from
/// every cell centre away from the corner columns, with the two other direction components
/// +0 or -0 in all combinations. The cells visited must equal an independent count (for
/// +x from cell c: 8 - c; for -x: c + 1), no triangle test may run, the ray must end as a
/// miss, and identical rays differing only in the sign of a zero must agree. Rays whose
/// origin lies outside the slab of a zero component must miss the grid (0 cells).
/// The cell counts are the 3D-DDA's over a fixed resolution, so they are checked on the
/// uniform grid only; the BVH (CPU f64 and f32) traces the same rays with what does not
/// depend on cells: every ray misses, and the +0/-0 twins agree on the hit and the work
/// (nodes visited plus triangle tests: its slab test divides by the signed zeros).
#[test]
fn case_07_axis_aligned_dda_with_signed_zeros() {
    let (mut s, m) = plain_scene();
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
    let mut checks = Checks::new();
    let all = with_test_context(|ctx| closest_one(ctx, &s, &grid, &rays));
    for (bi, (b, res)) in BACKENDS.iter().zip(&all).enumerate() {
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
            if k >= n_inside && is_gl(bi) && f.state != Some(RayState::Invalid) {
                wrong += 1;
            }
        }
        let line = format!(
            "{} axis-aligned rays with ±0 components: {wrong} with wrong cell count, hit or state, {sign_disagree} where +0/-0 disagree",
            rays.len()
        );
        checks.line("case 07", b, wrong + sign_disagree == 0, line);
    }
    let bvh = fragtrace::accel::Bvh::build(&s).unwrap();
    for (b, res) in BACKENDS[NG..].iter().zip(closest_bvh(&s, &bvh, &rays)) {
        let hits = res.iter().filter(|f| f.hit.is_some()).count();
        let sign_disagree = (0..n_inside)
            .filter(|&k| k % 4 != 0 && res[k] != res[k - k % 4])
            .count();
        let line = format!(
            "{} axis-aligned rays with ±0 components: {hits} hits, {sign_disagree} where +0/-0 disagree (hit or nodes + tests)",
            rays.len()
        );
        checks.line("case 07", b, hits + sign_disagree == 0, line);
    }
    checks.done();
}

/// A random soup of 400 triangles in a fixed, non-cubic 10x7x12 grid. Ray origins exactly
/// on interior cell faces (the f32 value `min + k * size` the DDA uses), exactly on the
/// grid's boundary faces, and outside the grid; and rays from exact cell corners and cell
/// edges along multiples of the cell diagonal, so the DDA meets tMax ties at every step.
/// On every backend the grid traversal must return exactly what a brute-force loop over
/// all triangles returns (same triangle; on the CPU also the same t), and rays perturbed
/// by 1e-5 cells must agree with their own brute force too. The irregular grid traces the
/// same rays (its top grid as fine as the uniform one, its cell faces its own).
/// Case 08/09's scene, structures and rays, each ray with its category.
fn case_08_09_rays() -> (Scene, Accels, Vec<(&'static str, TRay)>) {
    let mut rng = Rng::new("case 08/09", 0xfaced_u64);
    let (mut s, m) = plain_scene();
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
    let both = accels_fixed(&s, [10, 7, 12]);
    let grid = &both.uniform;
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
    let mut rays: Vec<(&'static str, TRay)> = Vec::new();
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
    (s, both, rays)
}

#[test]
fn case_08_09_origins_on_faces_and_rays_through_cell_edges() {
    let (s, both, rays) = case_08_09_rays();
    let grid = &both.uniform;
    let plain: Vec<TRay> = rays.iter().map(|r| r.1).collect();

    let b64 = brute::<f64>(&s, grid, &plain);
    let b32 = brute::<f32>(&s, grid, &plain);
    let res = with_test_context(|ctx| closest_all(ctx, &s, &both, &plain));

    let cats = [
        "8 cell face",
        "8 grid face",
        "8 outside",
        "9 corners",
        "9 edges",
        "9 perturbed",
    ];
    let mut checks = Checks::new();
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
                let got = res[bi][k].hit;
                let (ok, want) = match bi % PER {
                    0 => (got == b64[k], b64[k]),
                    1 => (got == b32[k], b32[k]),
                    _ => (res[bi][k].tri() == b32[k].map(|h| h.1), b32[k]),
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
            let line = format!("{cat}: {n} rays, {hits} hits, {wrong} differ from brute force");
            checks.line(&format!("case 0{}", &cat[..1]), b, wrong == 0, line);
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
    // The perturbed twins follow the rays they were made from, in order.
    let n_base = rays.iter().filter(|r| r.0 != "9 perturbed").count();
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
    checks.done();
}

/// Case 08/09's rays through the irregular grid on the GL kernels with every face crossing
/// moved by about an ulp ([`GpuScene::with_skewed_faces`]), as NVIDIA's fused
/// multiply-add rounds `min + k * size` otherwise than the CPU: the walk must still find
/// the f32 brute-force triangle for every ray. Before the walk left a cell at once through
/// a face found behind the previous exit (it treated the face as never crossed), 23, 17
/// and 19 rays from cell faces, corners and edges missed their triangle here, the same
/// counts as on the H200. The skew must show (some ray takes another number of steps),
/// or the test would pass without testing anything.
///
/// [`GpuScene::with_skewed_faces`]: fragtrace::gpu::scene::GpuScene::with_skewed_faces
#[test]
fn case_08_09_irregular_walk_with_faces_an_ulp_off() {
    let (s, both, rays) = case_08_09_rays();
    let plain: Vec<TRay> = rays.iter().map(|r| r.1).collect();
    let b32 = brute::<f32>(&s, &both.uniform, &plain);
    let mut checks = Checks::new();
    with_test_context(|ctx| {
        for kernel in GL_KERNELS {
            let trace = |skew| {
                gl_trace_with(
                    ctx,
                    &s,
                    &both.irregular,
                    &plain,
                    Query::Closest,
                    kernel,
                    skew,
                )
            };
            let (skewed, exact) = (trace(true), trace(false));
            let moved = (0..plain.len())
                .filter(|&k| skewed[k].steps != exact[k].steps)
                .count();
            let who = format!("GL {kernel} irregular, faces skewed");
            checks.line(
                "case 08",
                &who,
                moved > 0,
                format!(
                    "{moved} of {} rays take another number of steps",
                    plain.len()
                ),
            );
            let mut wrong = 0;
            for (k, (cat, r)) in rays.iter().enumerate() {
                if skewed[k].tri() != b32[k].map(|h| h.1) {
                    if wrong < 3 {
                        println!(
                            "    {who} {cat} ray {k} {r:?}: got {:?}, brute force {:?}",
                            skewed[k].hit, b32[k]
                        );
                    }
                    wrong += 1;
                }
            }
            checks.line(
                "case 08",
                &who,
                wrong == 0,
                format!("{} rays, {wrong} differ from brute force", plain.len()),
            );
        }
    });
    checks.done();
}

/// In a fixed 6x6x6 grid: triangles lying exactly in the planes of cell faces x = X_2,
/// y = Y_3, z = Z_4 (the f32 values the DDA computes, so a hit's t equals the cell's exit
/// t), a small axis-parallel triangle strictly inside one cell, and a large one in a
/// mid-cell plane. The face triangles must be binned on both sides of their face; every
/// triangle in the cell holding its centroid; rays aimed at them (from both sides, also at
/// points on cell edges) must hit them on every backend whenever brute force in f64 does,
/// through every structure (the binning checks are the uniform grid's).
#[test]
fn case_10_11_triangles_on_cell_faces_and_axis_parallel() {
    let mut rng = Rng::new("case 10/11", 0xce11_u64);
    let (mut s, m) = plain_scene();
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
    let first64: Vec<Option<u32>> = brute::<f64>(&s, &grid, &plain)
        .iter()
        .map(|h| h.map(|h| h.1))
        .collect();
    let both = accels_fixed(&s, [6, 6, 6]);
    let res = with_test_context(|ctx| closest_all(ctx, &s, &both, &plain));
    let mut checks = Checks::new();
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
            let line = format!("{kind} (triangle {i}): {eligible} rays aimed, {lost} not found");
            checks.line(&format!("case {}", &kind[..2]), b, lost == 0, line);
            assert!(eligible > 150, "{kind}: only {eligible} unobstructed rays");
        }
    }
    checks.done();
}
