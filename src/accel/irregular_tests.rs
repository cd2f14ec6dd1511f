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
        // Every cell the exit box overlaps holds only the cell's own triangles (none for an
        // empty cell): what the growth asks of the voxel map, by the cells' boxes.
        for (k, o) in g.cells.iter().enumerate() {
            if (0..3).all(|a| o.lo[a] < c.exit_hi[a] && c.exit_lo[a] < o.hi[a]) {
                assert!(
                    g.cell_triangles(k as u32)
                        .iter()
                        .all(|t| list.binary_search(t).is_ok()),
                    "{ctx}: cell {id}'s exit box {c:?} overlaps cell {k} {o:?}, which holds \
                     other triangles"
                );
            }
        }
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
    // Nothing to bound: the box -1..1, one cell whose exit box is itself.
    assert_eq!((g.min, g.max), (Vec3::splat(-1.0), Vec3::splat(1.0)));
    let st = &g.stats;
    assert_eq!((st.empty_cells, st.mean_per_nonempty), (1, 0.0));
    assert_eq!((st.bytes_per_triangle, st.mean_growth), (0.0, 1.0));
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

/// The finest side worked by hand: 2^-20 of the longest side near the origin, four f32
/// ulps of the largest coordinate far from it.
#[test]
fn finest_side_is_the_larger_floor() {
    // Longest side 2 (y), largest coordinate 1: 2 * 2^-20 = 2^-19 beats 4 * 2^-23 = 2^-21.
    let f = finest_side(Vec3::new(-1.0, -1.0, 0.0), Vec3::new(0.5, 1.0, 0.25));
    assert_eq!(f, 2f64.powi(-19));
    // At 1e4 with sides of 1: four ulps of 10001 (4 * 10001 * 2^-23 = 0.0048) beat 2^-20.
    let f = finest_side(Vec3::splat(1.0e4), Vec3::splat(10001.0));
    assert_eq!(f, 4.0 * 10001.0 * 2f64.powi(-23));
}

/// The limits at their boundaries: as many as the tables index is allowed, one more is not,
/// whichever table overflows.
#[test]
fn limits_refuse_one_past_the_tables_reach() {
    assert!(check_top(MAX_ENTRIES).is_ok());
    assert!(matches!(check_top(MAX_ENTRIES + 1), Err(Error::Limit(_))));
    assert!(check_sizes(9, MAX_CELLS, MAX_ENTRIES, MAX_REFERENCES).is_ok());
    for (cells, vmap, refs) in [
        (MAX_CELLS + 1, 0, 0),
        (0, MAX_ENTRIES + 1, 0),
        (0, 0, MAX_REFERENCES + 1),
    ] {
        let e = check_sizes(9, cells, vmap, refs).unwrap_err();
        // One line naming the need, the limits and options that exist.
        let text = e.to_string();
        assert!(
            matches!(e, Error::Limit(_))
                && text.contains("of 9 triangles")
                && text.contains("--grid-density")
                && !text.contains("leaf size"),
            "{cells} {vmap} {refs}: {e}"
        );
    }
}

/// Every figure of the statistics recomputed from the tables it describes, and the build's
/// phases adding up to its time.
#[test]
fn stats_agree_with_the_tables() {
    let seed = test_seed("irregular stats", 0x1_77E6_0003);
    let mut rng = Rng::new(seed);
    let s = scene_of(&soup(&mut rng, 400));
    let g = IrregularGrid::build(&s, &IrregularConfig::default()).unwrap();
    let (st, ctx) = (&g.stats, format!("seed {seed}: {}", g.stats));
    let n = g.cells.len();
    let counts: Vec<u32> = g.cells.iter().map(|c| c.range.count).collect();
    let empty = counts.iter().filter(|&&k| k == 0).count();
    let refs = g.tri_indices.len();
    assert_eq!(
        st.top_cells,
        g.top_res.iter().product::<u32>() as usize,
        "{ctx}"
    );
    assert_eq!(st.vmap_entries, g.vmap.len(), "{ctx}");
    assert_eq!((st.levels, st.cells), (g.levels.len(), n), "{ctx}");
    assert_eq!((st.empty_cells, st.references), (empty, refs), "{ctx}");
    assert!(
        empty > 0 && empty < n,
        "{ctx}: a soup has empty and full cells"
    );
    assert_eq!(st.max_per_cell, *counts.iter().max().unwrap(), "{ctx}");
    let bytes = g.vmap.len() * 4 + n * 32 + refs * 4;
    assert_eq!(st.bytes, bytes, "{ctx}");
    assert_eq!(st.bytes_per_triangle, bytes as f64 / 400.0, "{ctx}");
    assert_eq!(
        st.mean_per_nonempty,
        refs as f64 / (n - empty) as f64,
        "{ctx}"
    );
    let vol =
        |lo: [u32; 3], hi: [u32; 3]| -> f64 { (0..3).map(|a| (hi[a] - lo[a]) as f64).product() };
    let log_sum: f64 = g
        .cells
        .iter()
        .map(|c| (vol(c.exit_lo, c.exit_hi) / vol(c.lo, c.hi)).ln())
        .sum();
    let growth = (log_sum / n as f64).exp();
    assert!(growth > 1.0, "{ctx}: cells grew");
    assert!(
        (st.mean_growth / growth - 1.0).abs() < 1e-12,
        "{ctx}: growth {growth}"
    );
    // Timings: every phase counted once, back to back, so they add up to the whole but for
    // the moments between its first two and last two clock reads (microseconds; allowed
    // half the build, so a test preempted there does not fail).
    let p = &st.phases;
    let phases = [
        p.setup_ms,
        p.convert_ms,
        p.top_bin_ms,
        p.sort_ms,
        p.voxel_map_ms,
        p.flatten_ms,
        p.occupancy_ms,
        p.grow_ms,
        p.finish_ms,
    ];
    let sum: f64 = phases.iter().sum();
    assert!(phases.iter().all(|&ms| ms >= 0.0), "{ctx}");
    assert!(sum <= st.build_ms + 1e-9, "{ctx}: phases {sum} ms");
    assert!(sum >= 0.5 * st.build_ms, "{ctx}: phases {sum} ms");
    // The growth's own clock starts just after the occupancy phase's and stops just before
    // the growth phase's, and spans the gap between the two phases' clock reads: equal to
    // their sum within microseconds.
    let expand = p.occupancy_ms + p.grow_ms;
    assert!(st.expand_ms <= expand + 0.01, "{ctx}");
    assert!(st.expand_ms >= 0.5 * expand, "{ctx}");
}

/// The split's surface-area share worked by hand, where the axes differ (a flat node split in
/// two axes only) and where they do not (every axis halved: a quarter, whatever the shape).
#[test]
fn surface_share_is_the_area_ratio() {
    // Node 2 x 1 x 2 (area terms 2 + 2 + 4), child 1 x 1 x 1 (1 + 1 + 1).
    assert_eq!(
        surface_share(DVec3::ONE, DVec3::new(2.0, 1.0, 2.0)),
        3.0 / 8.0
    );
    // Node 4 x 2 x 1 (8 + 2 + 4), child 2 x 2 x 1 (4 + 2 + 2).
    assert_eq!(
        surface_share(DVec3::new(2.0, 2.0, 1.0), DVec3::new(4.0, 2.0, 1.0)),
        8.0 / 14.0
    );
    let node = DVec3::new(3.0, 5.0, 7.0);
    assert_eq!(surface_share(0.5 * node, node), 0.25);
}
