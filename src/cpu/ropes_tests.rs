//! Tests of the ropes (`cpu/ropes.rs`) against the voxel map's lookup, the independent
//! answer: a rope is the cell the lookup finds anywhere in the layer past its face, and a
//! face without one has the grid's edge or more than one cell past it. The walks through
//! the ropes are compared with the scalar walk in `simd_walk_tests.rs` and
//! `tests/cpu_simd.rs`.

use super::*;
use crate::accel::IrregularConfig;
use crate::testing::{corner_clusters, scene_of, soup, test_seed, Rng};

#[test]
fn every_rope_is_the_lookups_answer_across_its_face() {
    let seed = test_seed("ropes", 0x0002_07E5_0001);
    let mut rng = Rng::new(seed);
    let (mut roped, mut several, mut edge) = (0u64, 0u64, 0u64);
    for (round, (density, sparse)) in [(0.125, false), (1.0, false), (1.0, true), (4.0, true)]
        .into_iter()
        .enumerate()
    {
        let tris = if sparse {
            corner_clusters(&mut rng, 120, 12, 0.04)
        } else {
            soup(&mut rng, 300)
        };
        let cfg = IrregularConfig {
            top_density: density,
            leaf_max: 2,
        };
        let g = IrregularGrid::build(&scene_of(&tris), &cfg).unwrap();
        let cells = build(&g);
        let ctx = format!("seed {seed} round {round}: {}", g.stats);
        assert_eq!(cells.len(), g.cells.len(), "{ctx}");
        for (id, (rc, c)) in cells.iter().zip(&g.cells).enumerate() {
            assert_eq!(
                (rc.exit_lo, rc.exit_hi, rc.range),
                (c.exit_lo, c.exit_hi, c.range),
                "{ctx}: cell {id}"
            );
            for a in 0..3 {
                for up in [false, true] {
                    let rope = rc.ropes[face(a, up)];
                    let layer = if up {
                        (c.exit_hi[a] < g.res[a]).then_some(c.exit_hi[a])
                    } else {
                        c.exit_lo[a].checked_sub(1)
                    };
                    let Some(layer) = layer else {
                        edge += 1;
                        assert_eq!(rope, NO_ROPE, "{ctx}: cell {id} face {a}/{up} at the edge");
                        continue;
                    };
                    // The layer's corners and random virtual cells in it.
                    let at = |f: [f64; 3]| {
                        let mut k = [0u32; 3];
                        for b in 0..3 {
                            let span = c.exit_hi[b] - c.exit_lo[b];
                            k[b] = if b == a {
                                layer
                            } else {
                                c.exit_lo[b] + ((f[b] * span as f64) as u32).min(span - 1)
                            };
                        }
                        k
                    };
                    let mut probes: Vec<[u32; 3]> = (0..4)
                        .map(|m| at([(m & 1) as f64, (m >> 1 & 1) as f64, 1.0]))
                        .chain((0..4).map(|m| at([(m & 1) as f64, 1.0, (m >> 1 & 1) as f64])))
                        .collect();
                    probes.extend((0..6).map(|_| at([rng.f64(), rng.f64(), rng.f64()])));
                    let found: Vec<u32> = probes.iter().map(|&k| g.lookup(k)).collect();
                    if rope != NO_ROPE {
                        roped += 1;
                        for (k, f) in probes.iter().zip(&found) {
                            assert_eq!(*f, rope, "{ctx}: cell {id} face {a}/{up} at {k:?}");
                        }
                    } else {
                        several += 1;
                        // Past the first cell's box on some lateral axis lies another cell.
                        let first = &g.cells[g.lookup(at([0.0; 3])) as usize];
                        let past = (0..3).filter(|&b| b != a).find_map(|b| {
                            (first.hi[b] < c.exit_hi[b]).then(|| {
                                let mut k = at([0.0; 3]);
                                k[b] = first.hi[b];
                                k
                            })
                        });
                        let past = past.unwrap_or_else(|| {
                            panic!("{ctx}: cell {id} face {a}/{up}: one cell covers it, no rope")
                        });
                        assert_ne!(
                            g.lookup(past),
                            g.lookup(at([0.0; 3])),
                            "{ctx}: cell {id} face {a}/{up}"
                        );
                    }
                }
            }
        }
    }
    eprintln!("ropes: {roped} faces with a rope, {several} with several cells, {edge} at the edge");
    assert!(
        roped > 1000 && several > 1000 && edge > 100,
        "{roped} {several} {edge}"
    );
}
