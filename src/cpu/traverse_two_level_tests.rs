//! Traversal tests of the two-level grid: equality with brute force (same triangle, same
//! t bit for bit) in f32 and f64 on random scenes, a dense mesh on a huge floor, rays
//! through top-cell corners, sub-grid faces and shared edges; and the (ignored)
//! measurement of triangle tests and cells per ray on the bunny.

use glam::{DVec3, Vec3};

use super::*;
use crate::accel::tribox::tests::{test_seed, Rng};
use crate::accel::two_level::tests::{scene_of, soup};
use crate::accel::two_level::{TwoLevelConfig, EMPTY_TOP};

/// Checks closest_hit and any_hit against brute force for every ray, in precision `T`.
/// Returns how many rays hit.
fn check_rays<T: Real>(
    s: &Scene,
    g: &TwoLevelGrid,
    rays: &[(DVec3, DVec3, f64)],
    ctx: &str,
) -> usize {
    let w = TwoLevelWalker::<T>::new(s, g, Techniques::default());
    let mut hits = 0;
    for (i, &(o, d, t_max)) in rays.iter().enumerate() {
        let ray = ray_of::<T>(o, d, t_max);
        let mut work = Work::default();
        let got = w.closest_hit(&ray, &mut work);
        let want = w.brute_force(&ray);
        let key = |h: Option<Hit<T>>| h.map(|h| (h.tri, h.t.to_f64().to_bits()));
        assert_eq!(
            key(got),
            key(want),
            "{ctx} {}: ray {i} o {o} d {d} t_max {t_max}",
            T::NAME
        );
        assert_eq!(
            w.any_hit(&ray, &mut work),
            want.is_some(),
            "{ctx} {}: any_hit, ray {i} o {o} d {d} t_max {t_max}",
            T::NAME
        );
        hits += want.is_some() as usize;
    }
    hits
}

/// Both precisions.
fn check_both(s: &Scene, g: &TwoLevelGrid, rays: &[(DVec3, DVec3, f64)], ctx: &str) -> usize {
    check_rays::<f64>(s, g, rays, ctx);
    check_rays::<f32>(s, g, rays, ctx)
}

/// The ray (o, d) over (0, t_max) in precision `T`, as the random ray lists give them.
pub(crate) fn ray_of<T: Real>(o: DVec3, d: DVec3, t_max: f64) -> Ray<T> {
    Ray {
        o: V3::from_dvec3(o),
        d: V3::from_dvec3(d),
        t_min: T::ZERO,
        t_max: T::from_f64(t_max),
    }
}

/// Random rays: from inside and outside the box `[-r, r]^3` towards random points in it,
/// some with zeroed direction components (axis-parallel) and some with a finite t_max.
pub(crate) fn random_rays(rng: &mut Rng, n: usize, r: f64) -> Vec<(DVec3, DVec3, f64)> {
    (0..n)
        .map(|i| {
            let o = rng.dvec3(-2.0 * r, 2.0 * r);
            let mut d = rng.dvec3(-r, r) - o;
            match i % 9 {
                0 => d.x = 0.0,
                1 => (d.y, d.z) = (0.0, 0.0),
                _ => {}
            }
            if d == DVec3::ZERO {
                d = DVec3::X;
            }
            let t_max = if i % 5 == 0 {
                rng.range(0.2, 1.0)
            } else {
                1.0e30
            };
            (o, d, t_max)
        })
        .collect()
}

#[test]
fn random_scenes_equal_brute_force() {
    let seed = test_seed("two-level traversal", 0x2_7A7E_0001);
    let mut rng = Rng::new(seed);
    for (round, (l1, l2)) in [(0.5, 4.0), (0.05, 2.0), (2.0, 1.0), (0.01, 30.0)]
        .into_iter()
        .enumerate()
    {
        let s = scene_of(&soup(&mut rng, 400));
        let cfg = TwoLevelConfig {
            top_density: l1,
            leaf_density: l2,
            ..TwoLevelConfig::default()
        };
        let g = TwoLevelGrid::build(&s, &cfg).unwrap();
        let rays = random_rays(&mut rng, 1500, 3.0);
        let hits = check_both(&s, &g, &rays, &format!("seed {seed} round {round} {cfg:?}"));
        assert!(hits > 100, "seed {seed} round {round}: only {hits} hits");
    }
}

/// Closed UV sphere of `n` x `2n` quads (each two triangles) with bitwise-shared vertices.
pub(crate) fn sphere(center: Vec3, radius: f32, n: usize) -> Vec<[Vec3; 3]> {
    let p = |i: usize, j: usize| {
        let th = std::f32::consts::PI * i as f32 / n as f32;
        let ph = std::f32::consts::PI * (j % (2 * n)) as f32 / n as f32;
        if i == 0 || i == n {
            // The poles: one vertex, not 2n almost-equal ones.
            return center + Vec3::new(0.0, if i == 0 { radius } else { -radius }, 0.0);
        }
        center + radius * Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin())
    };
    let mut tris = Vec::new();
    for i in 0..n {
        for j in 0..2 * n {
            let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    tris
}

#[test]
fn mesh_in_a_stadium() {
    // A dense closed mesh on a floor 1000 times its size: the floor sets the top grid, the
    // mesh lands in a handful of top cells with big sub-grids.
    let seed = test_seed("two-level stadium", 0x2_7A7E_0002);
    let mut rng = Rng::new(seed);
    let mut tris = sphere(Vec3::new(0.3, 0.0, -0.2), 1.0, 40);
    let f = 1000.0;
    let y = -1.0;
    tris.push([
        Vec3::new(-f, y, -f),
        Vec3::new(f, y, -f),
        Vec3::new(f, y, f),
    ]);
    tris.push([
        Vec3::new(-f, y, -f),
        Vec3::new(f, y, f),
        Vec3::new(-f, y, f),
    ]);
    let s = scene_of(&tris);
    let g = TwoLevelGrid::build(&s, &TwoLevelConfig::default()).unwrap();
    println!("stadium: top {:?}, {}", g.res, g.stats);
    let mut rays = random_rays(&mut rng, 1500, 1.5);
    // And from far out on the floor, grazing it.
    for _ in 0..500 {
        let o = DVec3::new(
            rng.range(-f as f64, f as f64),
            rng.range(-1.0, 3.0),
            rng.range(-f as f64, f as f64),
        );
        let d = rng.dvec3(-1.0, 1.0) - o;
        rays.push((o, d, 1.0e30));
    }
    let hits = check_both(&s, &g, &rays, &format!("seed {seed} stadium"));
    assert!(hits > 500, "seed {seed}: only {hits} hits");
}

/// Rays from random origins through `target` (and axis-parallel ones where possible).
pub(crate) fn rays_through(rng: &mut Rng, target: DVec3, out: &mut Vec<(DVec3, DVec3, f64)>) {
    for _ in 0..3 {
        let o = target + rng.dvec3(-4.0, 4.0);
        out.push((o, target - o, 1.0e30));
    }
    let a = (rng.f64() * 3.0) as usize % 3;
    let mut o = target;
    o[a] -= 5.0;
    let mut d = DVec3::ZERO;
    d[a] = 1.0;
    out.push((o, d, 1.0e30));
}

#[test]
fn rays_through_corners_faces_and_shared_edges() {
    let seed = test_seed("two-level boundaries", 0x2_7A7E_0003);
    let mut rng = Rng::new(seed);
    // Two closed spheres and a soup, so there are shared edges in many top cells.
    let mut tris = sphere(Vec3::new(-1.0, 0.2, 0.1), 1.2, 24);
    tris.extend(sphere(Vec3::new(1.5, -0.5, 0.4), 0.7, 16));
    tris.extend(soup(&mut rng, 100));
    let s = scene_of(&tris);
    for cfg in [
        TwoLevelConfig::default(),
        TwoLevelConfig {
            top_density: 0.05,
            leaf_density: 6.0,
            ..TwoLevelConfig::default()
        },
    ] {
        let g = TwoLevelGrid::build(&s, &cfg).unwrap();
        let ctx = format!("seed {seed} {cfg:?} top {:?}", g.res);
        let mut rays = Vec::new();
        // Top-cell corners, in f32 as the traversal computes them.
        for _ in 0..300 {
            let c = [0, 1, 2].map(|a| (rng.f64() * (g.res[a] + 1) as f64) as u32);
            let p = Vec3::new(
                g.min.x + c[0] as f32 * g.cell_size.x,
                g.min.y + c[1] as f32 * g.cell_size.y,
                g.min.z + c[2] as f32 * g.cell_size.z,
            );
            rays_through(&mut rng, p.as_dvec3(), &mut rays);
        }
        // Points on sub-grid faces (and leaf corners) of non-empty top cells.
        let full: Vec<usize> = (0..g.top.len())
            .filter(|&i| g.top[i] != EMPTY_TOP)
            .collect();
        for _ in 0..600 {
            let i = full[(rng.f64() * full.len() as f64) as usize];
            let c = [
                i as u32 % g.res[0],
                (i as u32 / g.res[0]) % g.res[1],
                i as u32 / (g.res[0] * g.res[1]),
            ];
            let sg = g.subgrid(c).expect("non-empty");
            let (r, lo, sub) = (sg.res, sg.lo, sg.sub);
            let mut p = lo.as_dvec3() + rng.dvec3(0.0, 1.0) * g.cell_size.as_dvec3();
            for a in 0..3 {
                if a == 0 || rng.f64() < 0.3 {
                    let k = (rng.f64() * (r[a] + 1) as f64) as u32;
                    p[a] = (lo[a] + k as f32 * sub[a]) as f64;
                }
            }
            rays_through(&mut rng, p, &mut rays);
        }
        check_both(&s, &g, &rays, &format!("{ctx} corners/faces"));
        // Shared edges and vertices of the closed spheres: aimed at from outside, every
        // such ray must hit something, in both precisions.
        let mut edge_rays = Vec::new();
        for (i, t) in tris.iter().take(2 * 24 * 48 + 2 * 16 * 32).enumerate() {
            if rng.f64() < 0.2 {
                let center = if i < 2 * 24 * 48 {
                    DVec3::new(-1.0, 0.2, 0.1)
                } else {
                    DVec3::new(1.5, -0.5, 0.4)
                };
                // From outside, roughly along the outward normal, so the ray crosses the
                // surface at the edge or vertex instead of grazing it.
                let w = [t[0], (t[0] + t[1]) * 0.5, t[1]][(rng.f64() * 3.0) as usize % 3];
                let w = w.as_dvec3();
                let o = w + (w - center) * rng.range(1.0, 4.0) + rng.dvec3(-0.3, 0.3);
                edge_rays.push((o, w - o, 1.0e30));
            }
        }
        let n = edge_rays.len();
        let hits = check_both(&s, &g, &edge_rays, &format!("{ctx} shared edges"));
        assert_eq!(hits, n, "{ctx}: rays at shared edges must all hit");
    }
}

#[test]
fn plane_on_a_top_cell_face_is_watertight() {
    // A tessellated plane lying exactly on an interior top-cell boundary: build once to
    // learn the boundary, move the plane there (same bounds, same count, so the same top
    // grid), build again and shoot at its vertices and edge midpoints from both sides.
    let frame = |x: f32| {
        let mut tris = vec![
            [
                Vec3::ZERO,
                Vec3::new(0.01, 0.0, 0.0),
                Vec3::new(0.0, 0.01, 0.0),
            ],
            [
                Vec3::splat(4.0),
                Vec3::new(3.99, 4.0, 4.0),
                Vec3::new(4.0, 3.99, 4.0),
            ],
        ];
        let n = 12;
        let at = |i: usize, j: usize| {
            Vec3::new(
                x,
                0.5 + 3.0 * i as f32 / n as f32,
                0.5 + 3.0 * j as f32 / n as f32,
            )
        };
        for i in 0..n {
            for j in 0..n {
                tris.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                tris.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        tris
    };
    let seed = test_seed("two-level face plane", 0x2_7A7E_0004);
    let mut rng = Rng::new(seed);
    let cfg = TwoLevelConfig {
        top_density: 0.2,
        leaf_density: 4.0,
        ..TwoLevelConfig::default()
    };
    let g0 = TwoLevelGrid::build(&scene_of(&frame(2.0)), &cfg).unwrap();
    assert!(
        g0.res[0] >= 3,
        "top grid {:?} too coarse for the test",
        g0.res
    );
    let xb = g0.min.x + (g0.res[0] / 2) as f32 * g0.cell_size.x;
    let tris = frame(xb);
    let s = scene_of(&tris);
    let g = TwoLevelGrid::build(&s, &cfg).unwrap();
    assert_eq!((g.min, g.max, g.res), (g0.min, g0.max, g0.res));
    let mut rays = Vec::new();
    for t in &tris[2..] {
        for w in [t[0], (t[0] + t[1]) * 0.5, (t[0] + t[2]) * 0.5] {
            let w = w.as_dvec3();
            // Only points inside the plane's rim: a ray at the rim may pass just outside.
            if [w.y, w.z].iter().any(|&v| !(0.6..=3.4).contains(&v)) {
                continue;
            }
            for side in [-1.0, 1.0] {
                let o = w + DVec3::new(
                    side * rng.range(0.5, 3.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                );
                rays.push((o, w - o, 1.0e30));
            }
        }
    }
    let n = rays.len();
    let hits = check_both(&s, &g, &rays, &format!("seed {seed} plane at x = {xb}"));
    assert_eq!(
        hits, n,
        "seed {seed}: rays at the plane's edges must all hit"
    );
}

#[test]
fn work_counts_top_and_leaf_cells() {
    // One triangle, one ray along x through it: the walk visits top cells and the leaves
    // of the one non-empty top cell, and the counters add both.
    let s = scene_of(&[[
        Vec3::new(0.0, -1.0, -1.0),
        Vec3::new(0.0, 1.0, -1.0),
        Vec3::new(0.0, 0.0, 1.0),
    ]]);
    let g = TwoLevelGrid::build(&s, &TwoLevelConfig::default()).unwrap();
    let w = TwoLevelWalker::<f64>::new(&s, &g, Techniques::default());
    let ray = Ray {
        o: V3::new(-5.0, 0.0, 0.0),
        d: V3::new(1.0, 0.0, 0.0),
        t_min: 0.0,
        t_max: 1.0e30,
    };
    let mut work = Work::default();
    let h = w.closest_hit(&ray, &mut work).expect("hit");
    assert_eq!(h.tri, 0);
    let top_cells = g.res.iter().product::<u32>() as u64;
    let leaves = g.leaves.len() as u64;
    assert!(
        work.cells >= 2 && work.cells <= top_cells + leaves,
        "{work:?}"
    );
    assert_eq!(work.tests, 1, "{work:?}");
    let mut miss = Work::default();
    let away = Ray {
        d: V3::new(-1.0, 0.0, 0.0),
        ..ray
    };
    assert!(w.closest_hit(&away, &mut miss).is_none());
    assert_eq!(miss, Work::default(), "a ray missing the box does no work");
}

/// Primary rays of `s.camera` at w x h (one sample at each pixel centre, as the CPU
/// renderer's first sample).
pub(crate) fn primary_rays(s: &Scene, w: u32, h: u32) -> Vec<(DVec3, DVec3)> {
    let (ox, oy) = crate::scene::camera::sample_offsets(1)[0];
    let eye = s.camera.eye.as_dvec3();
    (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .map(|(i, j)| {
            (
                eye,
                s.camera.direction_at(w, h, i as f64 + ox, j as f64 + oy),
            )
        })
        .collect()
}

/// (tests per ray, cells per ray, hits) of the two-level walk in f32.
fn measure_two_level(s: &Scene, g: &TwoLevelGrid, rays: &[(DVec3, DVec3)]) -> (f64, f64, usize) {
    let w = TwoLevelWalker::<f32>::new(s, g, Techniques::default());
    let mut work = Work::default();
    let mut hits = 0;
    for &(o, d) in rays {
        let ray = Ray {
            o: V3::from_dvec3(o),
            d: V3::from_dvec3(d),
            t_min: 0.0,
            t_max: f32::BIG,
        };
        hits += w.closest_hit(&ray, &mut work).is_some() as usize;
    }
    let n = rays.len() as f64;
    (work.tests as f64 / n, work.cells as f64 / n, hits)
}

/// Triangle tests and cells per primary ray on the bunny, uniform vs two-level, and on the
/// bunny with a 100x larger floor. Prints a table; no timed asserts.
/// `FRAGTRACE_MODEL_PATH=/work/shared/models cargo test --release --lib
/// cpu::traverse_two_level::tests::measure_bunny -- --ignored --nocapture`
#[test]
#[ignore]
fn measure_bunny() {
    use std::path::{Path, PathBuf};
    let models = std::env::var("FRAGTRACE_MODEL_PATH").expect("FRAGTRACE_MODEL_PATH");
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/bunny.toml");
    let bunny = crate::scene::load_scene_with_search_path(&path, &[PathBuf::from(models)]).unwrap();
    let floor = bunny.triangles.last().unwrap().material;
    let mut big_floor = bunny.clone();
    let mut verts: Vec<u32> = big_floor
        .triangles
        .iter()
        .filter(|t| t.material == floor)
        .flat_map(|t| t.v)
        .collect();
    verts.sort_unstable();
    verts.dedup();
    for v in verts {
        let p = &mut big_floor.positions[v as usize];
        (p.x, p.z) = (p.x * 100.0, p.z * 100.0);
    }
    let mut alone = bunny.clone();
    alone.triangles.retain(|t| t.material != floor);
    let (w, h) = (256, 256);
    let rays = primary_rays(&bunny, w, h);
    println!("{w}x{h} primary rays, f32; tests and cells per ray");
    {
        let g = crate::accel::Grid::build(&bunny, &crate::accel::GridConfig::default()).unwrap();
        let a = super::super::traverse::GridWalker::<f32>::new(&bunny, &g);
        let mut work = Work::default();
        for &(o, d) in &rays {
            let ray = Ray {
                o: V3::from_dvec3(o),
                d: V3::from_dvec3(d),
                t_min: 0.0,
                t_max: f32::BIG,
            };
            a.closest_hit(&ray, &mut work);
        }
        let n = rays.len() as f64;
        println!(
            "bunny.toml uniform {:?}: tests {:.1} cells {:.1} | {:.1} B/tri, {:.0} ms",
            g.res,
            work.tests as f64 / n,
            work.cells as f64 / n,
            g.stats.bytes as f64 / bunny.triangles.len() as f64,
            g.stats.build_ms
        );
    }
    let pairs: &[(f32, f32)] = &[
        (0.0625, 2.0),
        (0.125, 4.0),
        (0.25, 2.0),
        (0.25, 4.0),
        (0.5, 2.0),
        (0.5, 4.0),
        (0.5, 8.0),
        (1.0, 4.0),
        (1.0, 8.0),
        (2.0, 4.0),
        (4.0, 4.0),
    ];
    // The flat floor scene gets one top cell in height, so the floor runs through the
    // bunny's top cells; fixed top grids with more layers show what splitting it off buys.
    for (name, s, top_res) in [
        ("bunny, 100x floor", &big_floor, [132, 16, 132]),
        ("bunny, 100x floor", &big_floor, [132, 32, 132]),
        ("bunny, 100x floor", &big_floor, [132, 64, 132]),
        ("bunny.toml", &bunny, [77, 16, 77]),
        ("bunny.toml", &bunny, [77, 32, 77]),
    ] {
        let cfg = TwoLevelConfig {
            top_res: Some(top_res),
            ..TwoLevelConfig::default()
        };
        let g = TwoLevelGrid::build(s, &cfg).unwrap();
        let (t, c, hits) = measure_two_level(s, &g, &rays);
        println!(
            "{name} two-level top {top_res:?} l2 {}: tests {t:.1} cells {c:.1} hits {hits} | \
             {:.1} B/tri, {:.0} ms, {} leaves",
            cfg.leaf_density, g.stats.bytes_per_triangle, g.stats.build_ms, g.stats.leaf_cells
        );
    }
    for (name, s) in [
        ("bunny.toml", &bunny),
        ("bunny alone", &alone),
        ("bunny, 100x floor", &big_floor),
    ] {
        for &(l1, l2) in pairs {
            let cfg = TwoLevelConfig {
                top_density: l1,
                leaf_density: l2,
                ..TwoLevelConfig::default()
            };
            let g = TwoLevelGrid::build(s, &cfg).unwrap();
            let (t, c, hits) = measure_two_level(s, &g, &rays);
            println!(
                "{name} two-level l1 {l1} l2 {l2} top {:?}: tests {t:.1} cells {c:.1} hits {hits} | \
                 {:.1} B/tri, {:.0} ms, {} leaves, max sub-grid {}",
                g.res,
                g.stats.bytes_per_triangle,
                g.stats.build_ms,
                g.stats.leaf_cells,
                g.stats.max_sub_cells
            );
        }
    }
}
