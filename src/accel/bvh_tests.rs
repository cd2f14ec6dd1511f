//! Tests of the BVH build (`bvh.rs`): the tree's structure checked node by node against
//! the triangles (every triangle in exactly one leaf, every box exact around what is below
//! it), the statistics recounted, the SAH's choice on scenes where the right split is
//! known, the degenerate piles the median split handles, and the build's independence of
//! the thread count. The walk is tested in `cpu/traverse_bvh_tests.rs`.

use glam::{Vec3, Vec3A};

use super::*;
use crate::testing::{
    corner_clusters, empty_scene, scene_of, soup, sphere, test_seed, with_threads, Rng,
};

/// What a check of the whole tree found: leaves seen, deepest leaf, triangles per leaf.
struct Walked {
    leaves: usize,
    depth: usize,
    seen: Vec<u32>,
}

/// Walks the tree from the root, checking every node: each inner slot's box is exactly
/// the union of its node's slot boxes, each leaf slot's box exactly the box of its
/// triangles, leaves hold 1 ..= LEAF_MAX triangles in ascending order, empty slots have
/// the empty box, and every node is reached once.
fn check_tree(bvh: &Bvh, scene: &Scene) -> Walked {
    let mut reached = vec![0u32; bvh.nodes.len()];
    let mut seen = vec![0u32; scene.triangles.len()];
    let mut out = Walked {
        leaves: 0,
        depth: 0,
        seen: Vec::new(),
    };
    // (node, depth of its children)
    let mut stack = vec![(0u32, 1usize)];
    while let Some((k, d)) = stack.pop() {
        reached[k as usize] += 1;
        let node = &bvh.nodes[k as usize];
        for i in 0..WIDTH {
            let slot_lo = Vec3A::new(node.lo[0][i], node.lo[1][i], node.lo[2][i]);
            let slot_hi = Vec3A::new(node.hi[0][i], node.hi[1][i], node.hi[2][i]);
            if node.is_empty_slot(i) {
                assert_eq!(slot_lo, Vec3A::INFINITY, "node {k} slot {i}");
                assert_eq!(slot_hi, Vec3A::NEG_INFINITY, "node {k} slot {i}");
                continue;
            }
            let (lo, hi) = if node.count[i] > 0 {
                let (off, n) = (node.child[i] as usize, node.count[i] as usize);
                assert!(n <= LEAF_MAX, "node {k} slot {i}: {n} triangles");
                let leaf = &bvh.tri_indices[off..off + n];
                assert!(
                    leaf.windows(2).all(|w| w[0] < w[1]),
                    "leaf {leaf:?} ascending"
                );
                let mut b = Aabb::EMPTY;
                for &t in leaf {
                    seen[t as usize] += 1;
                    let [a, bb, c] = scene.triangle_vertices(t as usize).map(Vec3A::from);
                    b.grow(a.min(bb).min(c), a.max(bb).max(c));
                }
                out.leaves += 1;
                out.depth = out.depth.max(d);
                (b.lo, b.hi)
            } else {
                let c = node.child[i];
                assert!(c > k && (c as usize) < bvh.nodes.len(), "node {k} -> {c}");
                let kid = &bvh.nodes[c as usize];
                let mut b = Aabb::EMPTY;
                for j in 0..WIDTH {
                    if !kid.is_empty_slot(j) {
                        b.grow(
                            Vec3A::new(kid.lo[0][j], kid.lo[1][j], kid.lo[2][j]),
                            Vec3A::new(kid.hi[0][j], kid.hi[1][j], kid.hi[2][j]),
                        );
                    }
                }
                stack.push((c, d + 1));
                (b.lo, b.hi)
            };
            // Exact: the minimum and maximum of the very coordinates below.
            assert_eq!((slot_lo, slot_hi), (lo, hi), "node {k} slot {i}");
        }
    }
    assert!(reached.iter().all(|&r| r == 1), "every node reached once");
    out.seen = seen;
    out
}

/// Random soups, clustered scenes and a closed sphere: every triangle in exactly one leaf,
/// boxes exact, leaves small, the statistics as the tables say.
#[test]
fn tree_holds_every_triangle_once_in_exact_boxes() {
    let seed = test_seed("bvh structure", 0xB0B0_0001);
    let mut rng = Rng::new(seed);
    let scenes = [
        soup(&mut rng, 3000),
        corner_clusters(&mut rng, 2000, 5, 0.05),
        sphere(Vec3::new(0.3, -0.2, 0.1), 2.0, 24),
        soup(&mut rng, 7),
        soup(&mut rng, 1),
    ];
    for (si, tris) in scenes.iter().enumerate() {
        let s = scene_of(tris);
        let bvh = Bvh::build(&s).unwrap();
        let w = check_tree(&bvh, &s);
        assert!(
            w.seen.iter().all(|&c| c == 1),
            "seed {seed} scene {si}: a triangle in {} leaves",
            w.seen.iter().find(|&&c| c != 1).unwrap()
        );
        assert_eq!(bvh.tri_indices.len(), s.triangles.len());
        let st = &bvh.stats;
        assert_eq!(st.nodes, bvh.nodes.len(), "scene {si}");
        assert_eq!(st.leaves, w.leaves, "scene {si}");
        assert_eq!(st.depth, w.depth, "scene {si}");
        assert_eq!(st.references, s.triangles.len(), "scene {si}");
        assert_eq!(st.bytes, bvh.nodes.len() * 128 + s.triangles.len() * 4);
        assert!((st.mean_per_leaf - tris.len() as f64 / w.leaves as f64).abs() < 1e-12);
        // The scene box is the union of the triangles' boxes.
        let mut b = Aabb::EMPTY;
        for t in tris {
            let t = t.map(Vec3A::from);
            b.grow(t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
        }
        assert_eq!((bvh.min, bvh.max), (b.lo.into(), b.hi.into()), "scene {si}");
        println!("scene {si}: {} triangles, {st}", tris.len());
    }
}

/// The collapse fills nodes: on 3000 random triangles most nodes have four children; those
/// near the leaves, whose binary subtrees run out of inner nodes, fewer (measured: 77% of
/// the slots used, 864 nodes).
#[test]
fn nodes_are_four_wide() {
    let mut rng = Rng::new(test_seed("bvh width", 0xB0B0_0002));
    let s = scene_of(&soup(&mut rng, 3000));
    let bvh = Bvh::build(&s).unwrap();
    let used: usize = bvh
        .nodes
        .iter()
        .map(|n| (0..WIDTH).filter(|&i| !n.is_empty_slot(i)).count())
        .sum();
    let share = used as f64 / (bvh.nodes.len() * WIDTH) as f64;
    println!("{} nodes, {:.3} of the slots used", bvh.nodes.len(), share);
    assert!(share > 0.7, "{share}");
    // A binary tree over n leaves has n - 1 inner nodes; four-wide, about a third.
    let leaves = bvh.stats.leaves;
    assert!(
        bvh.nodes.len() * 2 < leaves,
        "{} nodes for {leaves} leaves",
        bvh.nodes.len()
    );
}

/// Two tight clusters far apart: the SAH's first split separates them, so no slot of the
/// root spans the gap (a median split on the wrong axis would).
#[test]
fn sah_separates_distant_clusters() {
    let mut rng = Rng::new(test_seed("bvh sah", 0xB0B0_0003));
    let mut tris = Vec::new();
    for (k, t) in soup(&mut rng, 400).into_iter().enumerate() {
        // Clusters of side about 1 (the soup's large triangles reach 1.2) at x = -50 and
        // x = +50, interleaved in load order.
        let at = Vec3::new(if k % 2 == 0 { -50.0 } else { 50.0 }, 0.0, 0.0);
        tris.push(t.map(|v| at + v * 0.1));
    }
    let s = scene_of(&tris);
    let bvh = Bvh::build(&s).unwrap();
    let root = &bvh.nodes[0];
    for i in 0..WIDTH {
        if !root.is_empty_slot(i) {
            let ext = root.hi[0][i] - root.lo[0][i];
            assert!(ext < 10.0, "root slot {i} spans {ext} in x: across the gap");
        }
    }
    // And the tree is no worse than the leaves' own area: each cluster costs about what a
    // tree over 200 small triangles costs, far below one leaf of 400 (cost 400).
    assert!(bvh.stats.sah_cost < 50.0, "{}", bvh.stats.sah_cost);
}

/// Piles of triangles with one centroid (no SAH split exists): the median split halves
/// them until leaves are small, the depth stays logarithmic, and every triangle is kept.
#[test]
fn piles_with_one_centroid_split_by_the_median() {
    let t = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    for n in [1, 2, 3, 8, 9, 100, 1000] {
        let s = scene_of(&vec![t; n]);
        let bvh = Bvh::build(&s).unwrap();
        let w = check_tree(&bvh, &s);
        assert!(w.seen.iter().all(|&c| c == 1), "{n} copies");
        // ceil(log2(n / 8)) binary levels below the root, fewer four-wide.
        let bound = 1 + (n as f64 / LEAF_MAX as f64).log2().ceil().max(0.0) as usize;
        assert!(w.depth <= bound, "{n} copies: depth {} > {bound}", w.depth);
    }
}

/// The empty scene: one node of empty slots, no leaves.
#[test]
fn empty_scene_has_an_empty_root() {
    let s = empty_scene();
    let bvh = Bvh::build(&s).unwrap();
    assert_eq!(bvh.nodes.len(), 1);
    assert!((0..WIDTH).all(|i| bvh.nodes[0].is_empty_slot(i)));
    assert_eq!(bvh.stats.leaves, 0);
    assert_eq!(bvh.stats.mean_per_leaf, 0.0);
}

/// The same tree whatever the thread count (the parallel halves write disjoint slices and
/// the collapse runs after them in one order).
#[test]
fn build_does_not_depend_on_threads() {
    let mut rng = Rng::new(test_seed("bvh threads", 0xB0B0_0004));
    // Above PAR_BIN triangles, so the top splits bin in parallel chunks and build their
    // halves in parallel.
    let s = scene_of(&soup(&mut rng, PAR_BIN + PAR_BIN / 2));
    let one = with_threads(1, || Bvh::build(&s).unwrap());
    let four = with_threads(4, || Bvh::build(&s).unwrap());
    assert_eq!(one.nodes, four.nodes);
    assert_eq!(one.tri_indices, four.tri_indices);
}
