//! Tests of the exit-box growth's occupancy tables (`accel/irregular_grow.rs`): the
//! summed-volume table against a brute-force count, the tight boxes built tree by tree in
//! parallel against the serial pass. The growth itself is checked by the build's tests
//! (`irregular_tests.rs`: no exit box holds a foreign triangle) and the fingerprints of
//! `tests/irregular_build.rs`.

use super::*;
use crate::accel::IrregularConfig;
use crate::testing::{scene_of, soup, test_seed, with_threads, Rng};

/// On random soups: `count` of random blocks of top cells equals the cells counted one by
/// one, and the parallel build of the tables equals the serial one, entry for entry.
#[test]
fn occupancy_tables_match_brute_force_and_serial_build() {
    let seed = test_seed("irregular occupancy", 0x1_77E6_0003);
    let mut rng = Rng::new(seed);
    for (round, density) in [0.125, 1.0, 0.05].into_iter().enumerate() {
        let s = scene_of(&soup(&mut rng, 400));
        let cfg = IrregularConfig {
            top_density: density,
            leaf_max: 2,
        };
        let g = IrregularGrid::build(&s, &cfg).unwrap();
        let ctx = format!("seed {seed} round {round}: {}", g.stats);
        let par = with_threads(4, || Occupancy::build(&g, true));
        let ser = Occupancy::build(&g, false);
        assert!(g.vmap.len() > g.stats.top_cells, "{ctx}: never split");
        assert_eq!(par.sum, ser.sum, "{ctx}");
        assert_eq!(par.full, ser.full, "{ctx}");
        assert_eq!(par.tight, ser.tight, "{ctx}");
        let r = g.top_res;
        let full = |t: [u32; 3]| {
            let e = g.vmap[g.top_index(t)];
            e & NODE != 0 || g.cells[e as usize].range.count > 0
        };
        for _ in 0..300 {
            let mut pick = |a: usize| {
                let x = (rng.f64() * (r[a] + 1) as f64) as u32 % (r[a] + 1);
                let y = (rng.f64() * (r[a] + 1) as f64) as u32 % (r[a] + 1);
                (x.min(y), x.max(y))
            };
            let (x, y, z) = (pick(0), pick(1), pick(2));
            let mut n = 0;
            for k in z.0..z.1 {
                for j in y.0..y.1 {
                    for i in x.0..x.1 {
                        n += full([i, j, k]) as u32;
                    }
                }
            }
            let (lo, hi) = ([x.0, y.0, z.0], [x.1, y.1, z.1]);
            assert_eq!(par.count(lo, hi), n, "{ctx}: {lo:?}..{hi:?}");
        }
    }
}
