//! The irregular grid's build on every shipped scene: the structure it makes is pinned bit
//! for bit (a fingerprint of the voxel map, the cells with their exit boxes and the
//! references, taken from the build of commit e763231, before the build was sped up), and
//! one thread builds what two and four build. A change to the build that changes any cell,
//! exit box or list fails here; a deliberate change of the structure updates the table and
//! says why in its commit.

mod common;
use common::shipped_scenes;
use fragtrace::accel::{IrregularConfig, IrregularGrid};

/// FNV-1a over every field the traversal reads.
fn fingerprint(g: &IrregularGrid) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |w: u32| {
        for b in w.to_le_bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    for a in 0..3 {
        eat(g.top_res[a]);
        eat(g.shift[a]);
        eat(g.res[a]);
        eat(g.min[a].to_bits());
        eat(g.max[a].to_bits());
        eat(g.cell_size[a].to_bits());
    }
    for m in &g.levels {
        eat(m[0] as u32 | (m[1] as u32) << 1 | (m[2] as u32) << 2);
    }
    g.vmap.iter().for_each(|&e| eat(e));
    for c in &g.cells {
        for k in [c.lo, c.hi, c.exit_lo, c.exit_hi] {
            k.iter().for_each(|&v| eat(v));
        }
        eat(c.range.offset);
        eat(c.range.count);
    }
    g.tri_indices.iter().for_each(|&t| eat(t));
    h
}

/// Fingerprints of the default-configuration build, measured at e763231 (every exit-box
/// query descending from the top grid, every triangle tested in full against every child box)
/// and changed once since, deliberately, by the growth of the exit boxes of cells with
/// triangles over cells holding no other triangle (stop 64: the same cells and lists, larger
/// exit boxes).
const PINNED: &[(&str, u64)] = &[
    ("builtin", 0x74f99519113e4563),    // 22255 cells
    ("bunny", 0x6d5328f7892bf1fd),      // 138937 cells
    ("cornell", 0xcf8e64c46eb535a5),    // 20952 cells
    ("dragon", 0xf2fb2a52dd50ebf5),     // 244183 cells
    ("duck-table", 0xc27a5ffe6f64de83), // 31853 cells
    ("glass", 0x1fabdbd8cb34c8bc),      // 45292 cells
    ("ground", 0xb41ae10f1d1ce12f),     // 152855 cells
    ("lights", 0x75c85761af0b3642),     // 12301 cells
    ("sponza", 0x309a8783f9f39a7e),     // 451813 cells
    ("stadium", 0x7e66454c2a9543ba),    // 19015 cells
    ("teapot", 0x8c3232813ed63bac),     // 21751 cells
    ("turntable", 0x6d5328f7892bf1fd),  // 138937 cells
    ("whitted", 0x74f99519113e4563),    // 22255 cells
];

fn with_threads<T: Send>(n: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .unwrap()
        .install(f)
}

#[test]
fn build_is_pinned_and_independent_of_threads_on_every_shipped_scene() {
    let cfg = IrregularConfig::default();
    let mut missing = Vec::new();
    for (name, scene) in shipped_scenes() {
        let one = with_threads(1, || IrregularGrid::build(&scene, &cfg).unwrap());
        let f = fingerprint(&one);
        for n in [2, 4] {
            let many = with_threads(n, || IrregularGrid::build(&scene, &cfg).unwrap());
            assert_eq!(fingerprint(&many), f, "{name}: {n} threads against 1");
        }
        println!("(\"{name}\", {f:#018x}), // {} cells", one.cells.len());
        match PINNED.iter().find(|(n, _)| *n == name) {
            Some(&(_, want)) => assert_eq!(f, want, "{name}: structure changed"),
            None => missing.push(name),
        }
    }
    assert!(missing.is_empty(), "no pinned fingerprint for {missing:?}");
}
