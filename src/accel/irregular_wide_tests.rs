//! Tests of the voxel map in hops (`accel/irregular_wide.rs`) against the cells it must
//! find and the built map's descent, [`IrregularGrid::lookup`], at every hop width.

use super::*;
use crate::accel::irregular::IrrCell;
use crate::accel::IrregularConfig;
use crate::testing::{corner_clusters, scene_of, soup, test_seed, with_threads, Rng};

/// Random grids, dense (soups at several densities: few levels) and sparse (small clusters
/// in opposite corners of a large box: many levels): at every hop width every cell's
/// corners and a random virtual cell inside it map to that cell, 20,000 random virtual
/// cells map to the built map's cell, reads never exceed the built descent's and are fewer
/// somewhere once hops take several levels, and the map is the same on 1 and 4 threads.
#[test]
fn every_cell_maps_to_itself_at_every_hop_width() {
    let seed = test_seed("irregular wide map", 0x1_77E6_0005);
    let mut rng = Rng::new(seed);
    let mut deepest = 0;
    // Last, a soup squashed flat in x: levels of two splits, which hops of a few bits
    // group otherwise than levels of three. (Squashed in x and y too, a soup still gave
    // levels of three: the top grid takes the shape.)
    let flat = glam::Vec3::new(0.03, 1.0, 1.0);
    for (round, (density, kind)) in [(0.125, 0), (1.0, 0), (1.0, 1), (4.0, 1), (0.125, 2)]
        .into_iter()
        .enumerate()
    {
        let tris = match kind {
            0 => soup(&mut rng, 300),
            1 => corner_clusters(&mut rng, 150, 10, 0.02),
            _ => soup(&mut rng, 300)
                .into_iter()
                .map(|t| t.map(|v| v * flat))
                .collect(),
        };
        let g = IrregularGrid::build(
            &scene_of(&tris),
            &IrregularConfig {
                top_density: density,
                leaf_max: 2,
            },
        )
        .unwrap();
        let ctx = format!("seed {seed} round {round}: {}", g.stats);
        deepest = deepest.max(g.levels.len());
        if kind == 2 {
            // What the flat round is for: levels of two splits.
            let want = 2;
            assert!(
                g.levels
                    .iter()
                    .any(|m| m.iter().filter(|&&b| b).count() == want),
                "{ctx}: no level of {want} splits in {:?}",
                g.levels
            );
        }
        let narrow = WideMap::build(&g, 1);
        assert_eq!(narrow.hops.len(), g.levels.len(), "{ctx}");
        assert_eq!(narrow.vmap.len(), g.vmap.len(), "{ctx}: one level a hop");
        let inside = |c: &IrrCell, rng: &mut Rng| {
            [0, 1, 2].map(|a| {
                c.lo[a] + (rng.f64() * (c.hi[a] - c.lo[a]) as f64) as u32 % (c.hi[a] - c.lo[a])
            })
        };
        let random: Vec<[u32; 3]> = (0..20_000)
            .map(|_| [0, 1, 2].map(|a| (rng.f64() * g.res[a] as f64) as u32 % g.res[a]))
            .collect();
        let mut fewer = 0u64;
        for bits in 1..=MAX_HOP_BITS {
            // The hops group the levels in order, greedily, each of at most `bits` splits
            // unless one level alone has more.
            let level_bits = |l: usize| g.levels[l].iter().filter(|&&m| m).count() as u32;
            let sp = spans(&g, bits);
            let mut next = 0;
            for (i, &(first, end, n)) in sp.iter().enumerate() {
                assert!(
                    first == next && end > first,
                    "{ctx}: {bits} bits, spans {sp:?}"
                );
                let want = (first..end).fold([0; 3], |s, l| {
                    [0, 1, 2].map(|a| s[a] + u32::from(g.levels[l][a]))
                });
                assert_eq!(n, want, "{ctx}: {bits} bits, span {i} of {sp:?}");
                let sum: u32 = n.iter().sum();
                assert!(
                    sum <= bits || end == first + 1,
                    "{ctx}: {bits} bits, span {i} of {sp:?} too wide"
                );
                if let Some(&(f, _, _)) = sp.get(i + 1) {
                    assert!(
                        sum + level_bits(f) > bits,
                        "{ctx}: {bits} bits, span {i} of {sp:?} could take level {f}"
                    );
                }
                next = end;
            }
            assert_eq!(next, g.levels.len(), "{ctx}: {bits} bits, spans {sp:?}");
            let w = with_threads(1, || WideMap::build(&g, bits));
            assert_eq!(
                w.hops,
                sp.iter().map(|s| s.2).collect::<Vec<_>>(),
                "{ctx}: {bits} bits"
            );
            assert_eq!(
                with_threads(4, || WideMap::build(&g, bits)),
                w,
                "{ctx}: {bits} bits, 4 threads against 1"
            );
            assert_eq!(
                w.hops
                    .iter()
                    .fold([0; 3], |s, n| [0, 1, 2].map(|a| s[a] + n[a])),
                g.shift,
                "{ctx}: hops of {bits} bits"
            );
            for (id, c) in g.cells.iter().enumerate() {
                let hi = c.hi.map(|v| v - 1);
                for k in [c.lo, hi, inside(c, &mut rng)] {
                    assert_eq!(
                        g.lookup(k),
                        id as u32,
                        "{ctx}: built map, cell {id} at {k:?}"
                    );
                    assert_eq!(
                        w.lookup(k),
                        id as u32,
                        "{ctx}: {bits} bits, cell {id} at {k:?}"
                    );
                }
            }
            for &k in &random {
                assert_eq!(
                    w.lookup(k),
                    g.lookup(k),
                    "{ctx}: {bits} bits, virtual cell {k:?}"
                );
                let (r, r1) = (w.reads(k), narrow.reads(k));
                assert!(r <= r1, "{ctx}: {bits} bits, {k:?}: {r} reads > {r1}");
                fewer += u64::from(r < r1);
            }
        }
        if g.levels.len() >= 4 {
            assert!(fewer > 0, "{ctx}: no descent got shorter");
        }
    }
    assert!(
        deepest >= 6,
        "seed {seed}: the deepest grid has {deepest} levels"
    );
}

/// `within` takes the widest map within its budget (its sizes counted before building),
/// and falls back to one level a hop: on a deep grid, every budget at and around each
/// width's size.
#[test]
fn within_takes_the_widest_map_that_fits() {
    let seed = test_seed("irregular wide budget", 0x1_77E6_0006);
    let mut rng = Rng::new(seed);
    let g = IrregularGrid::build(
        &scene_of(&corner_clusters(&mut rng, 150, 10, 0.02)),
        &IrregularConfig {
            top_density: 1.0,
            leaf_max: 2,
        },
    )
    .unwrap();
    assert!(g.levels.len() >= 6, "seed {seed}: {}", g.stats);
    let sizes: Vec<usize> = (1..=MAX_HOP_BITS)
        .map(|b| WideMap::build(&g, b).vmap.len())
        .collect();
    assert_eq!(
        WideMap::within(&g, usize::MAX),
        WideMap::build(&g, MAX_HOP_BITS)
    );
    assert_eq!(WideMap::within(&g, 0), WideMap::build(&g, 1));
    for budget in sizes.iter().flat_map(|&n| [n - 1, n, n + 1]) {
        let want = (2..=MAX_HOP_BITS)
            .rev()
            .find(|&b| sizes[b as usize - 1] <= budget)
            .unwrap_or(1);
        assert_eq!(
            WideMap::within(&g, budget),
            WideMap::build(&g, want),
            "seed {seed}: budget {budget}, sizes {sizes:?}"
        );
    }
}
