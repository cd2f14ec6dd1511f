//! Unit tests of the uniform grid's build (`grid.rs`): completeness and tightness against
//! an independent clipping oracle on random soups, determinism across thread counts, cells
//! and padding worked out by hand, resolution choice, limits and statistics.

use super::*;
use crate::accel::tribox::tests::clip_overlap;
use crate::testing::{empty_scene, scene_of, soup, test_seed, with_threads, Rng};

fn fixed(res: [u32; 3]) -> GridConfig {
    GridConfig {
        res: GridRes::Fixed(res),
        ..GridConfig::default()
    }
}

fn tri_f64(s: &Scene, t: usize) -> [DVec3; 3] {
    s.triangle_vertices(t).map(|v| v.as_dvec3())
}

/// Structural invariants every consumer relies on.
fn check_structure(g: &Grid, n_tris: usize) {
    let n = cell_count(g.res) as usize;
    assert_eq!(g.cells.len(), n);
    let mut next = 0u32;
    for (i, c) in g.cells.iter().enumerate() {
        assert_eq!(c.offset, next, "cell {i}: ranges must tile tri_indices");
        next += c.count;
        let tris = &g.tri_indices[c.offset as usize..(c.offset + c.count) as usize];
        assert!(
            tris.windows(2).all(|w| w[0] < w[1]),
            "cell {i}: not strictly ascending: {tris:?}"
        );
        assert!(tris.iter().all(|&t| (t as usize) < n_tris));
    }
    assert_eq!(next as usize, g.tri_indices.len());
    assert_eq!(g.stats.references, g.tri_indices.len());
    assert_eq!(g.stats.cells, n);
    assert_eq!(g.stats.bytes, n * 8 + g.tri_indices.len() * 4);
    let empty = g.cells.iter().filter(|c| c.count == 0).count();
    assert_eq!(g.stats.empty_cells, empty);
    assert_eq!(
        g.cell_size,
        (g.max - g.min) / Vec3::new(g.res[0] as f32, g.res[1] as f32, g.res[2] as f32)
    );
}

/// Brute force over all cells and triangles: every true overlap with the unpadded
/// cell is listed, and every listed pair is within a small tolerance of its cell.
fn check_complete_and_tight(g: &Grid, s: &Scene, ctx: &str) {
    for z in 0..g.res[2] {
        for y in 0..g.res[1] {
            for x in 0..g.res[0] {
                let (lo, hi) = g.cell_bounds(x, y, z);
                let (c, h) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
                let listed = g.cell_triangles(x, y, z);
                for t in 0..s.triangles.len() {
                    let tri = tri_f64(s, t);
                    let present = listed.binary_search(&(t as u32)).is_ok();
                    if tri_box_overlap(c, h, tri) {
                        assert!(
                            present,
                            "{ctx}: tri {t} overlaps cell ({x},{y},{z}) but is missing"
                        );
                    }
                    if present {
                        assert!(
                            clip_overlap(c, h * (1.0 + 1e-3), tri),
                            "{ctx}: tri {t} listed in cell ({x},{y},{z}) it is not near"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn random_soups_complete_and_tight() {
    let seed = test_seed("grid random soups", 0x6E1D_0001);
    let mut rng = Rng::new(seed);
    for (round, res) in [
        GridRes::Fixed([7, 5, 6]),
        GridRes::Fixed([1, 1, 1]),
        GridRes::Fixed([13, 1, 4]),
        GridRes::Auto,
    ]
    .into_iter()
    .enumerate()
    {
        let s = scene_of(&soup(&mut rng, 150));
        let g = Grid::build(&s, &GridConfig { res, density: 2.0 }).unwrap();
        let ctx = format!("seed {seed} round {round} res {:?}", g.res);
        check_structure(&g, s.triangles.len());
        check_complete_and_tight(&g, &s, &ctx);
        // Binning is by overlap, not bounding box: the big diagonal triangles must
        // leave some bounding-box cells out, or the test proves nothing about that.
        if g.res.iter().all(|&r| r > 3) {
            let bbox_refs: usize = (0..s.triangles.len())
                .map(|t| {
                    let v = tri_f64(&s, t);
                    let lo = v[0].min(v[1]).min(v[2]) - g.min.as_dvec3();
                    let hi = v[0].max(v[1]).max(v[2]) - g.min.as_dvec3();
                    let cs = g.cell_size.as_dvec3();
                    let n = ((hi / cs).floor() - (lo / cs).floor() + 1.0).max(DVec3::ONE);
                    (n.x * n.y * n.z) as usize
                })
                .sum();
            assert!(
                g.tri_indices.len() < bbox_refs,
                "{ctx}: {} refs, bounding boxes give {bbox_refs}",
                g.tri_indices.len()
            );
        }
    }
}

#[test]
fn deterministic_across_thread_counts() {
    let seed = test_seed("grid determinism", 0x6E1D_0002);
    let mut rng = Rng::new(seed);
    // Enough triangles for several work chunks.
    let s = scene_of(&soup(&mut rng, 3 * CHUNK + 17));
    for cfg in [GridConfig::default(), fixed([9, 17, 4])] {
        let a = with_threads(1, || Grid::build(&s, &cfg).unwrap());
        let b = with_threads(4, || Grid::build(&s, &cfg).unwrap());
        assert_eq!((a.min, a.max, a.res), (b.min, b.max, b.res), "seed {seed}");
        assert_eq!(a.cells, b.cells, "seed {seed}");
        assert_eq!(a.tri_indices, b.tri_indices, "seed {seed}");
        check_structure(&a, s.triangles.len());
    }
}

#[test]
fn vertices_strictly_inside_bounds() {
    let seed = test_seed("grid bounds", 0x6E1D_0003);
    let mut rng = Rng::new(seed);
    for offset in [0.0, 1e3, -1e5, 3e6] {
        let tris: Vec<[Vec3; 3]> = soup(&mut rng, 50)
            .into_iter()
            .map(|t| t.map(|v| v + Vec3::splat(offset)))
            .collect();
        let s = scene_of(&tris);
        let g = Grid::build(&s, &GridConfig::default()).unwrap();
        for p in &s.positions {
            assert!(
                p.cmpgt(g.min).all() && p.cmplt(g.max).all(),
                "seed {seed} offset {offset}: {p} not strictly inside {}..{}",
                g.min,
                g.max
            );
        }
        // And no vertex lies on the far face of the last cell as f32 computes it.
        let far =
            g.min + g.cell_size * Vec3::new(g.res[0] as f32, g.res[1] as f32, g.res[2] as f32);
        let (_, hi) = s.bounds().unwrap();
        assert!(hi.cmplt(far).all(), "offset {offset}: {hi} vs {far}");
        check_structure(&g, s.triangles.len());
    }
}

#[test]
fn padding_is_several_f32_ulps_far_from_the_origin() {
    // A unit triangle a million units out: the relative pad (1e-4 of the extent) is under
    // one f32 ulp there (0.0625), so only the ulp term keeps the boundary off the vertices
    // by more than the single ulp of the last-resort step.
    let o = Vec3::splat(1e6);
    let s = scene_of(&[[o, o + Vec3::X, o + Vec3::Y + Vec3::Z]]);
    let g = Grid::build(&s, &GridConfig::default()).unwrap();
    let (lo, hi) = s.bounds().unwrap();
    for i in 0..3 {
        let ulp = (hi[i].next_up() - hi[i]) as f64;
        let below = (lo[i] - g.min[i]) as f64;
        let above = (g.max[i] - hi[i]) as f64;
        assert!(
            below >= PAD_ULPS * ulp && above >= PAD_ULPS * ulp,
            "axis {i}: pads {below} and {above}, ulp {ulp}"
        );
    }
}

/// Two tiny triangles pinning the scene bounds to about [0, 4]^3, so triangles added
/// inside do not move the grid.
fn framed(extra: &[[Vec3; 3]]) -> Scene {
    let e = 0.01;
    let mut tris = vec![
        [Vec3::ZERO, Vec3::new(e, 0.0, 0.0), Vec3::new(0.0, e, 0.0)],
        [
            Vec3::splat(4.0),
            Vec3::new(4.0 - e, 4.0, 4.0),
            Vec3::new(4.0, 4.0 - e, 4.0),
        ],
    ];
    tris.extend_from_slice(extra);
    scene_of(&tris)
}

#[test]
fn cell_pad_is_a_fraction_of_the_cell_size() {
    // 16^3 cells over [0, 4]^3: cells 0.25 wide, so the binning pad is about
    // 1e-5 * 0.25 + 4 ulps of 4 = 4.4e-6. A triangle that far above a cell's top face is
    // still listed in the cell below (f32 traversal may round into it); one 1.5e-5 above
    // is not.
    let cfg = fixed([16, 16, 16]);
    let base = Grid::build(&framed(&[]), &cfg).unwrap();
    let (lo, hi) = base.cell_bounds(5, 7, 6);
    let flat_at = |y: f64| {
        let (x0, x1, z0, z1) = (lo.x + 0.05, hi.x - 0.05, lo.z + 0.05, hi.z - 0.05);
        [
            Vec3::new(x0 as f32, y as f32, z0 as f32),
            Vec3::new(x1 as f32, y as f32, z0 as f32),
            Vec3::new(x0 as f32, y as f32, z1 as f32),
        ]
    };
    let near = flat_at(hi.y + 2e-6);
    let far = flat_at(hi.y + 1.5e-5);
    assert!(near[0].y as f64 > hi.y && far[0].y as f64 > hi.y + 1e-5);
    let g = Grid::build(&framed(&[near, far]), &cfg).unwrap();
    assert_eq!((g.min, g.cell_size), (base.min, base.cell_size));
    assert!(g.cell_triangles(5, 8, 6).contains(&2) && g.cell_triangles(5, 8, 6).contains(&3));
    assert!(g.cell_triangles(5, 7, 6).contains(&2), "within the pad");
    assert!(!g.cell_triangles(5, 7, 6).contains(&3), "beyond the pad");
}

#[test]
fn more_than_one_chunk_binned_as_the_oracle_says() {
    // The build bins in chunks of CHUNK triangles; a soup of two chunks and a bit checks
    // that every chunk's triangles keep their own indices.
    let seed = test_seed("grid chunks", 0x6E1D_0005);
    let s = scene_of(&soup(&mut Rng::new(seed), 2 * CHUNK + 5));
    let g = Grid::build(&s, &fixed([4, 4, 4])).unwrap();
    check_structure(&g, s.triangles.len());
    check_complete_and_tight(&g, &s, &format!("seed {seed}"));
}

#[test]
fn triangle_in_interior_grid_plane_lands_on_both_sides() {
    let cfg = fixed([4, 4, 4]);
    let base = Grid::build(&framed(&[]), &cfg).unwrap();
    // The plane x = min + 2 * cs exactly as an f32 traversal computes it.
    let px = base.min.x + 2.0 * base.cell_size.x;
    let in_plane = [
        Vec3::new(px, 1.2, 1.3),
        Vec3::new(px, 2.7, 1.4),
        Vec3::new(px, 1.5, 2.6),
    ];
    let g = Grid::build(&framed(&[in_plane]), &cfg).unwrap();
    assert_eq!(
        (g.min, g.max, g.cell_size),
        (base.min, base.max, base.cell_size)
    );
    for (y, z) in [(1, 1), (2, 1), (1, 2)] {
        for x in [1, 2] {
            assert!(
                g.cell_triangles(x, y, z).contains(&2),
                "in-plane triangle missing from cell ({x},{y},{z})"
            );
        }
        // Exact, not bounding-box-plus-slop: the cells beyond stay clean.
        for x in [0, 3] {
            assert!(!g.cell_triangles(x, y, z).contains(&2));
        }
    }
}

#[test]
fn triangle_touching_a_face_lands_in_both_cells() {
    let cfg = fixed([4, 4, 4]);
    let base = Grid::build(&framed(&[]), &cfg).unwrap();
    let py = base.min.y + 3.0 * base.cell_size.y;
    // Apex touches the plane y = py from below, in the middle of cell (1, *, 2).
    let mid = |i: f32, k: usize| base.min[k] + (i + 0.5) * base.cell_size[k];
    let (x, z) = (mid(1.0, 0), mid(2.0, 2));
    let touching = [
        Vec3::new(x, py, z),
        Vec3::new(x - 0.2, py - 0.5, z),
        Vec3::new(x + 0.2, py - 0.5, z + 0.1),
    ];
    let g = Grid::build(&framed(&[touching]), &cfg).unwrap();
    assert!(g.cell_triangles(1, 2, 2).contains(&2));
    assert!(
        g.cell_triangles(1, 3, 2).contains(&2),
        "touching cell missing"
    );
    // Neighbours in x, z are not touched.
    assert!(!g.cell_triangles(0, 3, 2).contains(&2));
    assert!(!g.cell_triangles(1, 3, 1).contains(&2));
}

#[test]
fn auto_resolution_proportional_and_clamped() {
    // 4 x 2 x 1 with 4096 target cells: k = 8.
    assert_eq!(
        Grid::auto_resolution(Vec3::new(4.0, 2.0, 1.0), 1024, 4.0),
        [32, 16, 8]
    );
    assert_eq!(
        Grid::auto_resolution(Vec3::new(1.0, 2.0, 4.0), 512, 1.0),
        [4, 8, 16]
    );
    // Per-axis clamp.
    let r = Grid::auto_resolution(Vec3::new(1e4, 1.0, 1.0), 1 << 20, 8.0);
    assert_eq!(r[0], MAX_AUTO_AXIS);
    // Total clamp, with proportions kept.
    let r = Grid::auto_resolution(Vec3::new(2.0, 1.0, 1.0), 100_000_000, 8.0);
    assert!(cell_count(r) <= MAX_AUTO_CELLS, "{r:?}");
    assert!(cell_count(r) >= MAX_AUTO_CELLS / 2, "{r:?}");
    assert!((r[0] as f64 / r[1] as f64 - 2.0).abs() < 0.05, "{r:?}");
    // Exactly: the largest grid of these proportions, k = cbrt(2^24 / (2 * 1 * 1)) = 203.19
    // cells per unit, so 406 x 203 x 203 (16,730,854 cells).
    assert_eq!(r, [406, 203, 203]);
    let r = Grid::auto_resolution(Vec3::ONE, usize::MAX, f32::MAX);
    assert!(cell_count(r) <= MAX_AUTO_CELLS && r.iter().all(|&v| v <= MAX_AUTO_AXIS));
    // Flat and thin: the thin axes get one cell and do not inflate the others.
    assert_eq!(
        Grid::auto_resolution(Vec3::new(1.0, 1.0, 0.001), 2, 4.0),
        [3, 3, 1]
    );
    assert_eq!(
        Grid::auto_resolution(Vec3::new(10.0, 0.0, 0.0), 5, 2.0),
        [10, 1, 1]
    );
    // Degenerate inputs.
    assert_eq!(Grid::auto_resolution(Vec3::ONE, 0, 4.0), [1, 1, 1]);
    assert_eq!(Grid::auto_resolution(Vec3::ZERO, 10, 4.0), [1, 1, 1]);
    assert_eq!(Grid::auto_resolution(Vec3::ONE, 10, f32::NAN), [1, 1, 1]);
    assert_eq!(
        Grid::auto_resolution(Vec3::splat(f32::INFINITY), 10, 4.0),
        [1, 1, 1]
    );
}

#[test]
fn clamp_total_trims_to_cap() {
    for (res, cap) in [
        ([512, 512, 512], 1 << 24),
        ([7, 7, 7], 100),
        ([1000, 1, 1], 10),
    ] {
        let r = clamp_total(res, cap);
        assert!(
            cell_count(r) <= cap && r.iter().all(|&v| v >= 1),
            "{res:?} -> {r:?}"
        );
    }
    assert_eq!(clamp_total([4, 4, 4], 64), [4, 4, 4]);
    // Scaled alike by cbrt(cap / total), rounded down, and trimmed only past the cap:
    // cbrt(1000 / 10^6) = 0.1 gives exactly the cap, which stays; cbrt(0.1) = 0.464 gives
    // floor(139.2, 9.28, 2.32), 2,502 cells, where trimming the longest axis alone would
    // have given 30 x 20 x 5.
    assert_eq!(clamp_total([100, 100, 100], 1000), [10, 10, 10]);
    assert_eq!(clamp_total([300, 20, 5], 3000), [139, 9, 2]);
}

#[test]
fn flat_scene_single_quad() {
    let (a, b, c, d) = (
        Vec3::new(-1.0, -1.0, 2.0),
        Vec3::new(1.0, -1.0, 2.0),
        Vec3::new(1.0, 1.0, 2.0),
        Vec3::new(-1.0, 1.0, 2.0),
    );
    let s = scene_of(&[[a, b, c], [a, c, d]]);
    let g = Grid::build(&s, &GridConfig::default()).unwrap();
    assert_eq!(g.res[2], 1, "{:?}", g.res);
    let ext = g.max - g.min;
    assert!(ext.z >= 1e-3 * ext.max_element() * 0.99, "{ext}");
    assert!(g.min.z < 2.0 && g.max.z > 2.0);
    check_structure(&g, 2);
    check_complete_and_tight(&g, &s, "quad");
    // Every cell of the single layer is covered by the quad.
    assert_eq!(g.stats.empty_cells, 0, "{:?}", g.res);
}

#[test]
fn single_point_scene() {
    let p = Vec3::new(5.0, -3.0, 1e4);
    let s = scene_of(&[[p, p, p]]);
    let g = Grid::build(&s, &GridConfig::default()).unwrap();
    assert!(p.cmpgt(g.min).all() && p.cmplt(g.max).all());
    let ext = g.max - g.min;
    assert!(ext.min_element() >= 1.0 && ext.max_element() < 2.0, "{ext}");
    // Four target cells make a 2x2x2 grid whose centre is the point: it lies on all
    // three interior planes, so the padding must put it in all eight cells.
    assert_eq!(g.res, [2, 2, 2]);
    assert_eq!(g.tri_indices, vec![0; 8]);
    check_structure(&g, 1);
}

#[test]
fn empty_scene_gives_unit_grid() {
    for cfg in [GridConfig::default(), fixed([8, 8, 8])] {
        let g = Grid::build(&empty_scene(), &cfg).unwrap();
        assert_eq!(g.res, [1, 1, 1]);
        assert_eq!((g.min, g.max), (Vec3::splat(-1.0), Vec3::splat(1.0)));
        assert_eq!(g.cell_size, Vec3::splat(2.0));
        assert_eq!(g.cells, vec![CellRange::default()]);
        assert!(g.tri_indices.is_empty() && g.cell_triangles(0, 0, 0).is_empty());
        assert_eq!(g.stats.empty_fraction, 1.0);
        assert_eq!(g.stats.mean_per_nonempty, 0.0);
    }
}

#[test]
fn rejects_bad_input() {
    let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let cfg = GridConfig::default();
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let s = scene_of(&[t, [Vec3::ZERO, Vec3::new(1.0, bad, 0.0), Vec3::Z]]);
        match Grid::build(&s, &cfg) {
            Err(Error::Scene { field, .. }) => assert_eq!(field, "triangles[1]"),
            other => panic!("{bad}: expected a scene error, got {other:?}"),
        }
    }
    // Finite corners whose difference overflows f32 (the grid's cell size would be inf).
    let wide = scene_of(&[[
        Vec3::new(-3e38, 0.0, 0.0),
        Vec3::new(3e38, 0.0, 0.0),
        Vec3::Y,
    ]]);
    match Grid::build(&wide, &cfg) {
        Err(Error::Scene { field, .. }) => assert_eq!(field, "positions"),
        other => panic!("expected a scene error, got {:?}", other.map(|g| g.stats)),
    }
    let mut s = scene_of(&[t]);
    s.triangles[0].v[2] = 99;
    assert!(matches!(Grid::build(&s, &cfg), Err(Error::Scene { .. })));

    let s = scene_of(&[t]);
    for res in [[4097, 1, 1], [1, 1, 4097], [4096, 4096, 5]] {
        assert!(
            matches!(Grid::build(&s, &fixed(res)), Err(Error::Limit(_))),
            "{res:?}"
        );
    }
    // The largest accepted fixed grid (not built: 2^26 cells is 512 MiB).
    assert!(check_fixed([4096, 4096, 4]).is_ok());
    assert!(matches!(
        Grid::build(&s, &fixed([0, 1, 1])),
        Err(Error::Usage(_))
    ));
    for density in [0.0, -1.0, f32::NAN] {
        let cfg = GridConfig {
            res: GridRes::Auto,
            density,
        };
        assert!(
            matches!(Grid::build(&s, &cfg), Err(Error::Usage(_))),
            "{density}"
        );
    }
}

#[test]
fn reference_limit() {
    let seed = test_seed("grid reference limit", 0x6E1D_0004);
    let s = scene_of(&soup(&mut Rng::new(seed), 3 * CHUNK));
    let cfg = fixed([16, 16, 16]);
    let g = Grid::build(&s, &cfg).unwrap();
    let n = g.tri_indices.len();
    // Exactly at the limit is fine, one below it is not, whatever the thread count.
    assert_eq!(
        build_with_limit(&s, &cfg, n).unwrap().tri_indices,
        g.tri_indices
    );
    for threads in [1, 4] {
        match with_threads(threads, || build_with_limit(&s, &cfg, n - 1)) {
            Err(Error::Limit(m)) => assert!(m.contains("references"), "{m}"),
            other => panic!("expected a limit error, got {:?}", other.map(|g| g.stats)),
        }
        assert!(matches!(
            with_threads(threads, || build_with_limit(&s, &cfg, 10)),
            Err(Error::Limit(_))
        ));
    }
    // The running total reaching the limit exactly is not yet over it: with five
    // triangles of one reference each and a limit of four, the fifth must still be binned
    // (and fail the build), not skipped.
    let mid = |x: f32| {
        let c = Vec3::new(x, 1.5, 1.5);
        [c, c + Vec3::X * 0.1, c + Vec3::Y * 0.1]
    };
    let five = framed(&[mid(0.5), mid(1.5), mid(2.5)]);
    let g = Grid::build(&five, &fixed([4, 4, 4])).unwrap();
    assert_eq!(g.tri_indices.len(), 5);
    assert!(matches!(
        build_with_limit(&five, &fixed([4, 4, 4]), 4),
        Err(Error::Limit(_))
    ));
    // A single triangle filling many cells stops early instead of exhausting memory.
    let big = scene_of(&[[
        Vec3::ZERO,
        Vec3::new(100.0, 0.0, 0.0),
        Vec3::new(0.0, 100.0, 0.0),
    ]]);
    assert!(matches!(
        build_with_limit(&big, &fixed([4096, 4096, 1]), 1000),
        Err(Error::Limit(_))
    ));
}

#[test]
fn parse_grid_res() {
    assert_eq!("auto".parse::<GridRes>(), Ok(GridRes::Auto));
    assert_eq!(" AUTO ".parse::<GridRes>(), Ok(GridRes::Auto));
    assert_eq!(
        "32x16x8".parse::<GridRes>(),
        Ok(GridRes::Fixed([32, 16, 8]))
    );
    assert_eq!("1X1x1".parse::<GridRes>(), Ok(GridRes::Fixed([1, 1, 1])));
    for bad in [
        "",
        "0x1x1",
        "1x0x1",
        "1x2",
        "1x2x3x4",
        "axbxc",
        "-1x2x3",
        "+1x2x3",
        "1x2x",
        "1 x2x3",
        "1x2x99999999999",
        "autox",
    ] {
        let e = bad.parse::<GridRes>().expect_err(bad);
        assert!(e.contains("grid resolution"), "{bad}: {e}");
    }
    for r in [GridRes::Auto, GridRes::Fixed([3, 4, 5])] {
        assert_eq!(r.to_string().parse::<GridRes>(), Ok(r));
    }
}

#[test]
fn stats_and_display() {
    let s = framed(&[]);
    let outer = std::time::Instant::now();
    let g = Grid::build(&s, &fixed([2, 2, 2])).unwrap();
    let outer_ms = outer.elapsed().as_secs_f64() * 1e3;
    // The two corner triangles each touch one corner cell.
    assert_eq!(g.stats.references, 2);
    assert_eq!(g.stats.empty_cells, 6);
    assert_eq!(g.stats.empty_fraction, 0.75);
    assert_eq!(g.stats.mean_per_nonempty, 1.0);
    assert_eq!(g.stats.max_per_nonempty, 1);
    assert_eq!(g.stats.bytes, 8 * 8 + 2 * 4);
    // The build time is the build's own wall time in milliseconds: at most the time of the
    // call around it and more than a thousandth of it (measured 0.1276 ms inside, 0.1284 ms
    // around). Seconds or microseconds for milliseconds, or a clock started before the
    // build, fail.
    assert!(
        g.stats.build_ms > outer_ms * 1e-3 && g.stats.build_ms <= outer_ms,
        "build_ms {} outside ({outer_ms} / 1000, {outer_ms}]",
        g.stats.build_ms
    );
    let line = g.stats.to_string();
    assert!(
        !line.contains('\n') && line.contains("8 cells") && line.contains("75.0% empty"),
        "{line}"
    );
    assert!(
        line.ends_with(&format!("built in {:.1} ms", g.stats.build_ms)),
        "{line}"
    );
}
