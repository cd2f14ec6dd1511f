//! Tests of the vectorised walk (`simd_walk.rs`, `simd.rs`, `simd_step.rs`) against the
//! scalar f32 walk, its reference: on random soups, closed meshes and rays aimed at cell
//! corners, faces and shared edges, every query (`closest_hit`, `any_hit` and the streams
//! `closest_hits`, `any_hits`) with every kernel this CPU runs must give the scalar walk's
//! answer bit for bit: the same triangle, t and barycentrics, the same any-hit answer, and
//! the same cells and tests counted. The scalar walk itself is checked against brute force
//! in `traverse_irregular_tests.rs` and `traverse_tests.rs`.

use glam::{DVec3, Vec3};

use super::*;
use crate::accel::{Accel, AccelKind, GridConfig, GridRef, IrregularConfig};
use crate::technique::TBound;
use crate::testing::{random_rays, ray_of, rays_through, scene_of, soup, sphere, test_seed, Rng};

/// The kernels this CPU runs (the portable one always).
fn isas() -> Vec<Isa> {
    [Isa::Avx2, Isa::Sse2, Isa::Scalar]
        .into_iter()
        .filter(|i| i.available())
        .collect()
}

/// Bits of a hit, so that equality is bit for bit (t and barycentrics).
fn key(h: Option<Hit<f32>>) -> Option<(u32, u32, [u32; 3])> {
    h.map(|h| (h.tri, h.t.to_bits(), h.b.map(f32::to_bits)))
}

/// Every query of the vectorised walker against the scalar one on `rays`, per kernel and
/// t-bound setting. Returns how many rays hit.
fn check(s: &Scene, accel: &Accel, rays: &[(DVec3, DVec3, f64)], ctx: &str) -> usize {
    let mut hits = 0;
    for t_bound in [TBound::On, TBound::Off] {
        let tech = Techniques::default().with_t_bound(t_bound);
        let scalar = Walker::<f32>::new(s, accel.as_ref().grid().unwrap(), tech);
        let rs: Vec<Ray<f32>> = rays.iter().map(|&(o, d, t)| ray_of(o, d, t)).collect();
        let mut want = vec![None; rs.len()];
        let mut want_work = vec![Work::default(); rs.len()];
        let mut want_any = vec![false; rs.len()];
        let mut want_any_work = Work::default();
        for (i, r) in rs.iter().enumerate() {
            want[i] = scalar.closest_hit(r, &mut want_work[i]);
            want_any[i] = scalar.any_hit(r, &mut want_any_work);
        }
        hits = want.iter().filter(|h| h.is_some()).count();
        for isa in isas() {
            let w = SimdWalker::with_isa(s, accel.as_ref().grid().unwrap(), tech, isa);
            let who = format!("{ctx} {} {t_bound:?}", isa.name());
            let mut any_work = Work::default();
            for (i, r) in rs.iter().enumerate() {
                let mut work = Work::default();
                let got = w.closest_hit(r, &mut work);
                assert_eq!(
                    key(got),
                    key(want[i]),
                    "{who}: closest_hit, ray {i} {:?}",
                    rays[i]
                );
                assert_eq!(work, want_work[i], "{who}: closest_hit work, ray {i}");
                assert_eq!(
                    w.any_hit(r, &mut any_work),
                    want_any[i],
                    "{who}: any_hit, ray {i}"
                );
            }
            assert_eq!(any_work, want_any_work, "{who}: any_hit work");
            // The streams, over uneven batch sizes (lanes refill mid-stream).
            for chunk in [1, 7, 64, rs.len()] {
                for (c, part) in rs.chunks(chunk).enumerate() {
                    let base = c * chunk;
                    let mut got = vec![None; part.len()];
                    let mut work = vec![Work::default(); part.len()];
                    w.closest_hits(part, &mut got, &mut work);
                    let mut any = vec![true; part.len()];
                    let mut aw = Work::default();
                    w.any_hits(part, &mut any, &mut aw);
                    let mut want_aw = Work::default();
                    for (j, r) in part.iter().enumerate() {
                        let i = base + j;
                        assert_eq!(key(got[j]), key(want[i]), "{who}: closest_hits, ray {i}");
                        assert_eq!(work[j], want_work[i], "{who}: closest_hits work, ray {i}");
                        assert_eq!(any[j], want_any[i], "{who}: any_hits, ray {i}");
                        scalar.any_hit(r, &mut want_aw);
                    }
                    assert_eq!(aw, want_aw, "{who}: any_hits work, chunk {chunk}");
                }
            }
        }
    }
    hits
}

fn both(s: &Scene) -> [Accel; 2] {
    [AccelKind::Uniform, AccelKind::Irregular]
        .map(|k| Accel::build(s, k, &GridConfig::default(), &IrregularConfig::default()).unwrap())
}

#[test]
fn random_soups_equal_the_scalar_walk() {
    let seed = test_seed("simd walk soups", 0x51D_0001);
    let mut rng = Rng::new(seed);
    for round in 0..3 {
        let s = scene_of(&soup(&mut rng, 300 + 200 * round));
        let rays = random_rays(&mut rng, 1200, 3.0);
        for a in both(&s) {
            let ctx = format!("seed {seed} round {round} {:?}", a.as_ref().kind());
            let hits = check(&s, &a, &rays, &ctx);
            // Measured (default seed): 400 to 520 hits of 1200.
            assert!(hits > 200, "{ctx}: only {hits} hits");
        }
    }
}

#[test]
fn closed_meshes_cell_faces_and_shared_edges_equal_the_scalar_walk() {
    let seed = test_seed("simd walk boundaries", 0x51D_0002);
    let mut rng = Rng::new(seed);
    let mut tris = sphere(Vec3::new(-1.0, 0.2, 0.1), 1.2, 24);
    tris.extend(sphere(Vec3::new(1.5, -0.5, 0.4), 0.7, 16));
    // A floor far larger than the meshes: long exit boxes, grazing rays.
    let f = 200.0;
    tris.push([
        Vec3::new(-f, -2.0, -f),
        Vec3::new(f, -2.0, -f),
        Vec3::new(f, -2.0, f),
    ]);
    tris.push([
        Vec3::new(-f, -2.0, -f),
        Vec3::new(f, -2.0, f),
        Vec3::new(-f, -2.0, f),
    ]);
    let s = scene_of(&tris);
    for a in both(&s) {
        let mut rays = Vec::new();
        // Vertices and edge midpoints (shared by two triangles), and points on the grid's
        // virtual cell boundaries.
        for t in tris.iter().step_by(5) {
            let w = ((t[0] + t[1]) * 0.5).as_dvec3();
            rays_through(&mut rng, w, &mut rays);
            rays_through(&mut rng, t[2].as_dvec3(), &mut rays);
        }
        let (min, cs, res) = match a.as_ref().grid().unwrap() {
            GridRef::Uniform(g) => (g.min, g.cell_size, g.res),
            GridRef::Irregular(g) => (g.min, g.cell_size, g.res),
        };
        for _ in 0..400 {
            let c = [0, 1, 2].map(|k| (rng.f64() * (res[k] + 1) as f64) as u32);
            let p = min + Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * cs;
            rays_through(&mut rng, p.as_dvec3(), &mut rays);
        }
        let ctx = format!("seed {seed} {:?}", a.as_ref().kind());
        let hits = check(&s, &a, &rays, &ctx);
        assert!(
            hits * 2 > rays.len(),
            "{ctx}: only {hits} of {} hit",
            rays.len()
        );
    }
}

#[test]
fn moller_trumbore_runs_the_scalar_step() {
    let s = scene_of(&[[Vec3::ZERO, Vec3::X, Vec3::Y]]);
    let a = Accel::build(
        &s,
        AccelKind::Irregular,
        &GridConfig::default(),
        &IrregularConfig::default(),
    )
    .unwrap();
    let tech =
        Techniques::default().with_intersect(crate::technique::IntersectMethod::MollerTrumbore);
    assert_eq!(
        SimdWalker::new(&s, a.as_ref().grid().unwrap(), tech).isa(),
        Isa::Scalar
    );
    let w = SimdWalker::new(&s, a.as_ref().grid().unwrap(), Techniques::default());
    assert_eq!(w.isa(), Isa::detect());
}
