//! Build tests of the irregular grid: structure (voxel map against the cells' own boxes),
//! completeness of the binning, exit boxes that hold no triangle, determinism across
//! thread counts, limits. Traversal tests are in `cpu/traverse_irregular_tests.rs`.

use super::*;
use crate::accel::tribox::tri_box_overlap;
use crate::testing::{empty_scene, scene_of, soup, test_seed, with_threads, Rng};

/// Structural invariants and completeness, checked by brute force:
/// - the cells' own boxes tile the virtual grid, and `lookup` of every virtual cell of a
///   sampled set returns the cell whose own box holds it;
/// - every triangle overlapping a cell's unpadded own box (f64) is listed in it, lists
///   ascending;
/// - no triangle overlaps any exit box beyond the cell's own triangles' reach: every
///   triangle overlapping a cell's unpadded exit box is listed in the cell.
pub(crate) fn check(g: &IrregularGrid, s: &Scene, rng: &mut Rng, ctx: &str) {
    let res = g.res;
    assert_eq!(res, [0, 1, 2].map(|a| g.top_res[a] << g.shift[a]), "{ctx}");
    let volume: u64 = g
        .cells
        .iter()
        .map(|c| (0..3).map(|a| (c.hi[a] - c.lo[a]) as u64).product::<u64>())
        .sum();
    assert_eq!(
        volume,
        res.iter().map(|&r| r as u64).product::<u64>(),
        "{ctx}: cells tile the grid"
    );
    for _ in 0..2000 {
        let k = [0, 1, 2].map(|a| (rng.f64() * res[a] as f64) as u32 % res[a]);
        let c = &g.cells[g.lookup(k) as usize];
        assert!(
            (0..3).all(|a| c.lo[a] <= k[a] && k[a] < c.hi[a]),
            "{ctx}: lookup {k:?} -> {c:?}"
        );
    }
    let tris: Vec<[glam::DVec3; 3]> = (0..s.triangles.len())
        .map(|t| s.triangle_vertices(t).map(|v| v.as_dvec3()))
        .collect();
    let mut refs = 0;
    for (id, c) in g.cells.iter().enumerate() {
        let list = g.cell_triangles(id as u32);
        refs += list.len();
        assert!(
            list.windows(2).all(|w| w[0] < w[1]),
            "{ctx}: cell {id} list not ascending"
        );
        assert!(
            (0..3).all(|a| c.exit_lo[a] <= c.lo[a]
                && c.hi[a] <= c.exit_hi[a]
                && c.exit_hi[a] <= res[a]),
            "{ctx}: cell {id} {c:?}"
        );
        let (lo, hi) = g.world_box(c.exit_lo, c.exit_hi);
        for (t, v) in tris.iter().enumerate() {
            if tri_box_overlap(0.5 * (lo + hi), 0.5 * (hi - lo), *v) {
                assert!(
                    list.binary_search(&(t as u32)).is_ok(),
                    "{ctx}: triangle {t} overlaps cell {id}'s exit box {c:?} but is not listed"
                );
            }
        }
    }
    assert_eq!(refs, g.tri_indices.len(), "{ctx}");
}

#[test]
fn random_soups_complete() {
    let seed = test_seed("irregular build", 0x1_77E6_0001);
    let mut rng = Rng::new(seed);
    for (round, (density, leaf)) in [(0.125, 4), (0.01, 2), (1.0, 8), (0.05, 1)]
        .into_iter()
        .enumerate()
    {
        let s = scene_of(&soup(&mut rng, 300));
        let cfg = IrregularConfig {
            top_density: density,
            leaf_max: leaf,
        };
        let g = IrregularGrid::build(&s, &cfg).unwrap();
        let ctx = format!("seed {seed} round {round} {cfg:?}: {}", g.stats);
        check(&g, &s, &mut rng, &ctx);
        assert!(
            g.stats.levels > 0 && g.vmap.len() > g.stats.top_cells,
            "{ctx}: never split"
        );
        assert!(g.stats.mean_growth > 1.0, "{ctx}: no exit box grew");
    }
}

#[test]
fn deterministic_across_thread_counts() {
    let seed = test_seed("irregular determinism", 0x1_77E6_0002);
    let mut rng = Rng::new(seed);
    // Enough triangles in one node for the parallel split to run.
    let mut tris = soup(&mut rng, 300);
    for i in 0..6000 {
        let a = rng.dvec3(-0.5, 0.5).as_vec3();
        let e = 0.01 * (1 + i % 3) as f32;
        tris.push([
            a,
            a + glam::Vec3::new(e, 0.0, 0.0),
            a + glam::Vec3::new(0.0, e, e),
        ]);
    }
    let s = scene_of(&tris);
    let cfg = IrregularConfig::default();
    let one = with_threads(1, || IrregularGrid::build(&s, &cfg).unwrap());
    let four = with_threads(4, || IrregularGrid::build(&s, &cfg).unwrap());
    assert_eq!(one.vmap, four.vmap, "seed {seed}");
    assert_eq!(one.cells, four.cells, "seed {seed}");
    assert_eq!(one.tri_indices, four.tri_indices, "seed {seed}");
}

#[test]
fn empty_and_bad_input() {
    let g = IrregularGrid::build(&empty_scene(), &IrregularConfig::default()).unwrap();
    assert_eq!((g.cells.len(), g.tri_indices.len()), (1, 0));
    assert_eq!(g.lookup([0, 0, 0]), 0);
    let s = scene_of(&[[glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y]]);
    for cfg in [
        IrregularConfig {
            top_density: 0.0,
            leaf_max: 4,
        },
        IrregularConfig {
            top_density: f32::NAN,
            leaf_max: 4,
        },
        IrregularConfig {
            top_density: 1.0,
            leaf_max: 0,
        },
    ] {
        let e = IrregularGrid::build(&s, &cfg).unwrap_err();
        assert!(matches!(e, Error::Usage(_)), "{cfg:?}: {e}");
    }
    let mut bad = s.clone();
    bad.positions[0].x = f32::INFINITY;
    assert!(matches!(
        IrregularGrid::build(&bad, &IrregularConfig::default()),
        Err(Error::Scene { .. })
    ));
}

#[test]
fn schedule_makes_cells_cubic() {
    // A flat top cell (8 x 1 x 8) splits x and z three times before y joins.
    let (levels, shift) = schedule(DVec3::new(8.0, 1.0, 8.0), [4, 1, 4], 0.1);
    assert_eq!(
        &levels[..4],
        &[
            [true, false, true],
            [true, false, true],
            [true, false, true],
            [true, true, true]
        ]
    );
    assert_eq!(shift[0] - shift[1], 3);
}

/// The schedule worked by hand: which axes halve at each level, and where it stops (the
/// finest size reached, the level cap, the virtual-resolution cap).
#[test]
fn schedule_stops_where_it_should() {
    let (xz, xyz) = ([true, false, true], [true; 3]);
    // 8 x 1 x 8 halves x and z to 1 x 1 x 1 (three levels), then all three: 0.5, 0.25,
    // 0.125 and 0.0625, the first side not above 0.1.
    let (levels, shift) = schedule(DVec3::new(8.0, 1.0, 8.0), [4, 1, 4], 0.1);
    assert_eq!(levels, [xz, xz, xz, xyz, xyz, xyz, xyz]);
    assert_eq!(shift, [7, 4, 7]);
    // A side equal to the finest size is fine enough: stop at 0.125.
    let (levels, shift) = schedule(DVec3::new(8.0, 1.0, 8.0), [4, 1, 4], 0.125);
    assert_eq!(levels, [xz, xz, xz, xyz, xyz, xyz]);
    assert_eq!(shift, [6, 3, 6]);
    // No finest size: the level cap ends it.
    let (levels, shift) = schedule(DVec3::splat(1.0), [1, 1, 1], 0.0);
    assert_eq!(levels, vec![xyz; MAX_LEVELS]);
    assert_eq!(shift, [MAX_LEVELS as u32; 3]);
    // The virtual-resolution cap keeps virtual coordinates exact: 2^20 top cells along x
    // split twice (2^22 = MAX_VIRTUAL_AXIS); y and z once more, after which x is the longest
    // side and may not split, and no other axis is long enough to.
    assert_eq!(MAX_VIRTUAL_AXIS, 1 << 22);
    let (levels, shift) = schedule(DVec3::splat(1.0), [1 << 20, 1, 1], 0.0);
    assert_eq!(levels, [xyz, xyz, [false, true, true]]);
    assert_eq!(shift, [2, 3, 3]);
}
