//! Build tests of the two-level grid: structure, completeness of the binning, determinism
//! across thread counts, limits. Traversal tests are in `cpu/traverse_two_level_tests.rs`.

use super::*;
use crate::accel::tribox::tests::{test_seed, Rng};
use crate::accel::tribox::tri_box_overlap;
use crate::scene::{Camera, Material};

/// An empty scene with one material.
pub(crate) fn empty_scene() -> Scene {
    let mut s = Scene::empty(Camera {
        eye: Vec3::new(0.0, 0.0, 5.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
    });
    s.add_material(Material::default());
    s
}

/// A scene of the given triangles.
pub(crate) fn scene_of(tris: &[[Vec3; 3]]) -> Scene {
    let mut s = empty_scene();
    for t in tris {
        s.add_triangle(t[0], t[1], t[2], 0);
    }
    s
}

/// Random triangle soup in roughly `[-3, 3]^3`: mostly small triangles, some large, some
/// degenerate and some axis-aligned (as grid.rs's tests use).
pub(crate) fn soup(rng: &mut Rng, n: usize) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|i| {
            let a = rng.dvec3(-3.0, 3.0);
            let s = if i % 7 == 0 { 3.0 } else { 0.5 };
            let mut b = a + rng.dvec3(-s, s);
            let mut c = a + rng.dvec3(-s, s);
            match i % 11 {
                0 => c = b,
                1 => (b, c) = (a, a),
                2 => (b.z, c.z) = (a.z, a.z),
                3 => c = a + (b - a) * 0.25,
                _ => {}
            }
            [a.as_vec3(), b.as_vec3(), c.as_vec3()]
        })
        .collect()
}

pub(crate) fn with_threads<T: Send>(n: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .expect("thread pool")
        .install(f)
}

/// Structural invariants, and completeness: every triangle that overlaps a leaf's
/// unpadded box (f64, from the f32 frame) is listed in that leaf.
fn check(g: &TwoLevelGrid, s: &Scene, ctx: &str) {
    let n_top = g.res.iter().map(|&r| r as usize).product::<usize>();
    assert_eq!(g.top.len(), n_top, "{ctx}");
    let mut next_leaf = 0u32;
    let mut next_sub = 0usize;
    let mut next_ref = 0u32;
    for z in 0..g.res[2] {
        for y in 0..g.res[1] {
            for x in 0..g.res[0] {
                let c = [x, y, z];
                let Some(t) = g.subgrid(c) else {
                    assert_eq!(g.top[g.top_index(c)], EMPTY_TOP, "{ctx}");
                    continue;
                };
                assert_eq!(g.top[g.top_index(c)] as usize, next_sub, "{ctx}");
                next_sub += 1;
                assert_eq!(
                    t.leaf_base, next_leaf,
                    "{ctx}: sub-grids must tile the leaves"
                );
                assert!(
                    t.res.iter().all(|&r| (1..=MAX_SUB_AXIS).contains(&r)),
                    "{ctx}"
                );
                next_leaf += t.leaf_count() as u32;
                let (lo, sub) = (t.lo, t.sub);
                for lz in 0..t.res[2] {
                    for ly in 0..t.res[1] {
                        for lx in 0..t.res[0] {
                            let l = [lx, ly, lz];
                            let r = g.leaves[t.leaf_base as usize
                                + (lx + t.res[0] * (ly + t.res[1] * lz)) as usize];
                            assert_eq!(r.offset, next_ref, "{ctx}: leaves must tile the list");
                            next_ref += r.count;
                            let list = g.leaf_triangles(c, l);
                            assert!(list.windows(2).all(|w| w[0] < w[1]), "{ctx}: {list:?}");
                            // The leaf box within the top cell: what it must cover.
                            let (clo, chi) = g.top_bounds(c);
                            let a = lo.as_dvec3()
                                + DVec3::new(lx as f64, ly as f64, lz as f64) * sub.as_dvec3();
                            let (a, b) = (a.max(clo), (a + sub.as_dvec3()).min(chi));
                            if (0..3).any(|k| a[k] > b[k]) {
                                continue;
                            }
                            for tri in 0..s.triangles.len() {
                                let v = s.triangle_vertices(tri).map(|p| p.as_dvec3());
                                if tri_box_overlap(0.5 * (a + b), 0.5 * (b - a), v) {
                                    assert!(
                                        list.contains(&(tri as u32)),
                                        "{ctx}: triangle {tri} missing from top {c:?} leaf {l:?}"
                                    );
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    assert_eq!(next_leaf as usize, g.leaves.len(), "{ctx}");
    assert_eq!(next_sub, g.subgrids.len(), "{ctx}");
    assert_eq!(next_ref as usize, g.tri_indices.len(), "{ctx}");
    assert_eq!(g.stats.leaf_cells, g.leaves.len(), "{ctx}");
    assert_eq!(g.stats.references, g.tri_indices.len(), "{ctx}");
    assert_eq!(
        g.stats.bytes,
        g.top.len() * 4 + g.subgrids.len() * 40 + g.leaves.len() * 8 + g.tri_indices.len() * 4,
        "{ctx}"
    );
}

#[test]
fn random_soups_complete() {
    let seed = test_seed("two-level random soups", 0x2_1E7E_0001);
    let mut rng = Rng::new(seed);
    for (round, (l1, l2)) in [(0.5, 4.0), (0.05, 2.0), (2.0, 1.0), (0.01, 30.0)]
        .into_iter()
        .enumerate()
    {
        let s = scene_of(&soup(&mut rng, 150));
        let cfg = TwoLevelConfig {
            top_density: l1,
            leaf_density: l2,
            ..TwoLevelConfig::default()
        };
        let g = TwoLevelGrid::build(&s, &cfg).unwrap();
        check(&g, &s, &format!("seed {seed} round {round} {cfg:?}"));
    }
}

#[test]
fn deterministic_across_thread_counts() {
    let seed = test_seed("two-level determinism", 0x2_1E7E_0002);
    let mut rng = Rng::new(seed);
    // Enough triangles for several top-level chunks.
    let s = scene_of(&soup(&mut rng, 3 * CHUNK + 17));
    for cfg in [
        TwoLevelConfig::default(),
        TwoLevelConfig {
            top_density: 0.02,
            leaf_density: 3.0,
            ..TwoLevelConfig::default()
        },
    ] {
        let a = with_threads(1, || TwoLevelGrid::build(&s, &cfg).unwrap());
        let b = with_threads(3, || TwoLevelGrid::build(&s, &cfg).unwrap());
        assert_eq!((a.min, a.max, a.res), (b.min, b.max, b.res), "seed {seed}");
        assert_eq!(a.top, b.top, "seed {seed}");
        assert_eq!(a.subgrids, b.subgrids, "seed {seed}");
        assert_eq!(a.leaves, b.leaves, "seed {seed}");
        assert_eq!(a.tri_indices, b.tri_indices, "seed {seed}");
    }
}

#[test]
fn limits_and_bad_input() {
    let seed = test_seed("two-level limits", 0x2_1E7E_0003);
    let mut rng = Rng::new(seed);
    let s = scene_of(&soup(&mut rng, 200));
    let cfg = TwoLevelConfig::default();
    let g = TwoLevelGrid::build(&s, &cfg).unwrap();
    let (leaves, refs) = (g.leaves.len(), g.tri_indices.len());
    // Exactly at the limits builds; one below fails with a message naming the limit.
    assert!(build_with_limits(&s, &cfg, leaves, refs).is_ok());
    match build_with_limits(&s, &cfg, leaves - 1, refs) {
        Err(Error::Limit(m)) => assert!(m.contains("leaf cells"), "{m}"),
        other => panic!("expected a leaf limit error, got {other:?}"),
    }
    match build_with_limits(&s, &cfg, leaves, refs - 1) {
        Err(Error::Limit(m)) => assert!(m.contains("triangle references"), "{m}"),
        other => panic!("expected a reference limit error, got {other:?}"),
    }
    for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        let c = TwoLevelConfig {
            top_density: bad,
            ..cfg
        };
        assert!(matches!(TwoLevelGrid::build(&s, &c), Err(Error::Usage(_))));
        let c = TwoLevelConfig {
            leaf_density: bad,
            ..cfg
        };
        assert!(matches!(TwoLevelGrid::build(&s, &c), Err(Error::Usage(_))));
    }
    for bad in [[0, 1, 1], [1, MAX_FIXED_TOP_AXIS + 1, 1]] {
        let c = TwoLevelConfig {
            top_res: Some(bad),
            ..cfg
        };
        assert!(matches!(TwoLevelGrid::build(&s, &c), Err(Error::Usage(_))));
    }
    let c = TwoLevelConfig {
        top_res: Some([4096, 4096, 2]),
        ..cfg
    };
    match TwoLevelGrid::build(&s, &c) {
        Err(Error::Limit(m)) => assert!(m.contains("top cells"), "{m}"),
        other => panic!("expected a top cell limit error, got {other:?}"),
    }
    let c = TwoLevelConfig {
        top_res: Some([3, 1, 5]),
        ..cfg
    };
    let g = TwoLevelGrid::build(&s, &c).unwrap();
    assert_eq!(g.res, [3, 1, 5]);
    check(&g, &s, &format!("seed {seed} fixed top"));
    let e = TwoLevelGrid::build(&empty_scene(), &cfg).unwrap();
    assert_eq!((e.res, e.top.len(), e.leaves.len()), ([1, 1, 1], 1, 0));
}

#[test]
fn top_grid_is_the_uniform_grids_frame() {
    let seed = test_seed("two-level frame", 0x2_1E7E_0004);
    let mut rng = Rng::new(seed);
    let s = scene_of(&soup(&mut rng, 300));
    let cfg = TwoLevelConfig::default();
    let g = TwoLevelGrid::build(&s, &cfg).unwrap();
    let u = Grid::build(
        &s,
        &crate::accel::GridConfig {
            res: crate::accel::GridRes::Fixed(g.res),
            density: cfg.top_density,
        },
    )
    .unwrap();
    assert_eq!(
        (g.min, g.max, g.res, g.cell_size),
        (u.min, u.max, u.res, u.cell_size)
    );
    // Same top-level binning: a top cell is non-empty exactly when the uniform cell is.
    for (i, &t) in g.top.iter().enumerate() {
        assert_eq!(
            t == EMPTY_TOP,
            u.cells[i].count == 0,
            "seed {seed} top cell {i}"
        );
    }
}

#[test]
fn top_resolution_layers_flat_scenes() {
    // A mesh on a floor 100 times its size: the uniform rule gives one cell in height.
    let flat = Vec3::new(400.0, 0.4, 400.0);
    assert_eq!(Grid::auto_resolution(flat, 69_451, 0.25)[1], 1);
    let r = top_resolution(flat, 69_451, 0.25);
    assert_eq!(r[1], MIN_TOP_AXIS);
    assert_eq!([r[0], r[2]], [132, 132]);
    // Cubical scenes keep the uniform rule; tiny scenes get no more than a cubical count.
    let cube = Vec3::splat(1.0);
    assert_eq!(
        top_resolution(cube, 69_451, 0.25),
        Grid::auto_resolution(cube, 69_451, 0.25)
    );
    assert_eq!(top_resolution(flat, 8, 1.0), [3, 2, 3]);
    assert_eq!(top_resolution(flat, 0, 1.0), [1, 1, 1]);
}
