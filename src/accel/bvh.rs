//! A bounding volume hierarchy over the scene's triangles (`--accel bvh`): the structure
//! CPU ray tracers such as Embree use, here for the CPU backend only (the GPU walks the
//! grids; `RenderOptions::validate` refuses `--accel bvh` with `--backend gl`).
//!
//! Built top-down as a binary tree with binned surface-area-heuristic splits
//! ([`BINS`] bins on each axis, the cheapest of the three axes, Wald 2007), the two halves
//! of a node in parallel and the largest nodes' bins in parallel chunks, then collapsed
//! into a 4-wide tree ([`Node4`]): each node holds its four children's boxes side by side, one array per axis and side, so one
//! SSE operation tests the ray against all four slabs of an axis. The walk is
//! `cpu/traverse_bvh.rs`.
//!
//! The boxes are exact: the minimum and maximum of f32 vertex coordinates, so a triangle
//! lies inside every box above it; the walk pads only its own slab arithmetic.

use glam::{Vec3, Vec3A};
use std::time::Instant;

use crate::scene::Scene;
use crate::{Error, Result};

/// Children per node of the collapsed tree.
pub const WIDTH: usize = 4;
/// Most triangles in a leaf: the binary build splits any node with more (one 8-wide
/// triangle-kernel chunk holds them all).
pub const LEAF_MAX: usize = 8;
/// Bins per axis of the SAH split search.
pub const BINS: usize = 16;
/// Deepest binary node: there a node becomes a leaf whatever its size. A guard against
/// splits that peel off a few triangles at a time (triangles spaced geometrically can make
/// the SAH do so); piles with one centroid are halved by the median and stay shallow.
pub const MAX_DEPTH: usize = 60;
/// Nodes with fewer triangles build their two subtrees on this thread.
const PAR_MIN: usize = 4096;
/// Nodes with at least this many triangles find their box and bins in parallel, in chunks
/// of a quarter of this: the top splits, which otherwise run on one thread while the
/// others wait (the 3.3 M-triangle icosphere built only 2.8x faster on 16 threads than
/// on 2).
const PAR_BIN: usize = 1 << 16;
/// Cost of visiting a node relative to one triangle test, in the SAH. Four, not the
/// textbook one: the vectorised walk tests up to eight of a leaf's triangles in one
/// kernel call, so larger leaves cost little and save node visits. Measured on the
/// equal-work bunny (1024², f32): with 1, 6.0 nodes and 1.8 triangle tests per ray, 18,853
/// nodes, built in 129 ms (here, 1 thread, median of 7); with 4, 5.0 nodes and 5.7 tests,
/// 6,140 nodes, 94 ms; renders alike within this machine's noise.
const TRAVERSAL_COST: f32 = 4.0;

/// A node of the 4-wide tree.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct Node4 {
    /// `lo[a][i]`: lower bound on axis `a` of child `i`'s box (`+inf` for an empty slot).
    pub lo: [[f32; WIDTH]; 3],
    /// `hi[a][i]`: upper bound on axis `a` of child `i`'s box (`-inf` for an empty slot).
    pub hi: [[f32; WIDTH]; 3],
    /// Child `i`: its node's index when `count[i]` is 0, else the offset of its leaf's
    /// range in [`Bvh::tri_indices`].
    pub child: [u32; WIDTH],
    /// Child `i`: 0 for an inner node or an empty slot, else its leaf's triangle count.
    pub count: [u32; WIDTH],
}

impl Node4 {
    /// A node with four empty slots: boxes no ray meets (lower bound above upper).
    const EMPTY: Node4 = Node4 {
        lo: [[f32::INFINITY; WIDTH]; 3],
        hi: [[f32::NEG_INFINITY; WIDTH]; 3],
        child: [0; WIDTH],
        count: [0; WIDTH],
    };

    /// Whether slot `i` holds nothing.
    pub fn is_empty_slot(&self, i: usize) -> bool {
        self.count[i] == 0 && self.lo[0][i] > self.hi[0][i]
    }
}

/// Build figures for `--stats`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BvhStats {
    /// Wall-clock build time in milliseconds.
    pub build_ms: f64,
    /// Nodes of the 4-wide tree.
    pub nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Triangle references (each triangle once).
    pub references: usize,
    /// Deepest leaf below the root (the root's children are at depth 1).
    pub depth: usize,
    /// Mean triangles per leaf (0 when there is none).
    pub mean_per_leaf: f64,
    /// Memory: nodes * 128 + references * 4 bytes.
    pub bytes: usize,
    /// The SAH cost of the binary tree, relative to one triangle test per ray that meets
    /// the root box.
    pub sah_cost: f64,
}

impl std::fmt::Display for BvhStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} nodes, {} leaves ({:.2} triangles each), depth {}, SAH cost {:.1}, {:.1} MB, built in {:.1} ms",
            self.nodes,
            self.leaves,
            self.mean_per_leaf,
            self.depth,
            self.sah_cost,
            self.bytes as f64 / 1e6,
            self.build_ms
        )
    }
}

/// The 4-wide tree: node 0 is the root.
#[derive(Clone, Debug)]
pub struct Bvh {
    /// Nodes, depth first.
    pub nodes: Vec<Node4>,
    /// Triangle indices, leaf after leaf, ascending within each leaf.
    pub tri_indices: Vec<u32>,
    /// The scene's box (the root's children together).
    pub min: Vec3,
    /// See `min`.
    pub max: Vec3,
    /// Build figures.
    pub stats: BvhStats,
}

/// A triangle's box and centroid.
#[derive(Clone, Copy)]
struct Prim {
    lo: Vec3A,
    hi: Vec3A,
    c: Vec3A,
}

/// An axis-aligned box being grown.
#[derive(Clone, Copy, Debug)]
struct Aabb {
    lo: Vec3A,
    hi: Vec3A,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: Vec3A::splat(f32::INFINITY),
        hi: Vec3A::splat(f32::NEG_INFINITY),
    };

    fn grow(&mut self, lo: Vec3A, hi: Vec3A) {
        self.lo = self.lo.min(lo);
        self.hi = self.hi.max(hi);
    }

    fn join(self, o: Aabb) -> Aabb {
        Aabb {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    /// Half the surface area (the SAH needs only ratios); 0 for an empty box.
    fn half_area(&self) -> f32 {
        let e = (self.hi - self.lo).max(Vec3A::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

/// A node of the binary tree the build makes first.
enum Bin2 {
    Leaf { bounds: Aabb, start: u32, n: u32 },
    Inner { bounds: Aabb, kids: Box<[Bin2; 2]> },
}

impl Bin2 {
    fn bounds(&self) -> Aabb {
        match self {
            Bin2::Leaf { bounds, .. } | Bin2::Inner { bounds, .. } => *bounds,
        }
    }

    /// SAH cost of the subtree, in area-weighted units (divide by the root's area).
    fn sah(&self) -> f64 {
        match self {
            Bin2::Leaf { bounds, n, .. } => bounds.half_area() as f64 * *n as f64,
            Bin2::Inner { bounds, kids } => {
                bounds.half_area() as f64 * TRAVERSAL_COST as f64 + kids[0].sah() + kids[1].sah()
            }
        }
    }
}

impl Bvh {
    /// Builds the tree over `scene`'s triangles.
    pub fn build(scene: &Scene) -> Result<Bvh> {
        use rayon::prelude::*;
        let t0 = Instant::now();
        let n = scene.triangles.len();
        if n >= u32::MAX as usize {
            return Err(Error::Limit(format!(
                "{n} triangles: the BVH indexes them with 32 bits"
            )));
        }
        let prims: Vec<Prim> = (0..n)
            .into_par_iter()
            .map(|i| {
                let [a, b, c] = scene.triangle_vertices(i).map(Vec3A::from);
                let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
                Prim {
                    lo,
                    hi,
                    c: (lo + hi) * 0.5,
                }
            })
            .collect();
        Ok(Self::over(&prims, TRAVERSAL_COST, t0))
    }

    /// A tree over boxes `lo..hi` (the leaves' "triangles" are the boxes' indices): the
    /// top level of instancing (`accel/instances.rs`), whose leaves hold instances. A
    /// node visit costs `node_cost` box contents in the SAH: small for instances, each of
    /// which costs a walk of its own tree, so that leaves hold one or two.
    pub fn over_boxes(boxes: &[(Vec3, Vec3)], node_cost: f32) -> Result<Bvh> {
        let t0 = Instant::now();
        if boxes.len() >= u32::MAX as usize {
            return Err(Error::Limit(format!(
                "{} boxes: the BVH indexes them with 32 bits",
                boxes.len()
            )));
        }
        let prims: Vec<Prim> = boxes
            .iter()
            .map(|&(lo, hi)| {
                let (lo, hi) = (Vec3A::from(lo), Vec3A::from(hi));
                Prim {
                    lo,
                    hi,
                    c: (lo + hi) * 0.5,
                }
            })
            .collect();
        Ok(Self::over(&prims, node_cost, t0))
    }

    /// The tree over `prims`, `node_cost` the SAH's cost of a node visit; `t0` when the
    /// build began.
    fn over(prims: &[Prim], node_cost: f32, t0: Instant) -> Bvh {
        let n = prims.len();
        let mut refs: Vec<u32> = (0..n as u32).collect();
        let mut nodes = Vec::new();
        let mut bvh = Bvh {
            nodes: Vec::new(),
            tri_indices: Vec::new(),
            min: Vec3::ZERO,
            max: Vec3::ZERO,
            stats: BvhStats::default(),
        };
        if n == 0 {
            nodes.push(Node4::EMPTY);
        } else {
            let root = build2(prims, &mut refs, 0, 0, node_cost);
            let b = root.bounds();
            bvh.min = b.lo.into();
            bvh.max = b.hi.into();
            bvh.stats.sah_cost = root.sah() / (b.half_area() as f64).max(f64::MIN_POSITIVE);
            match &root {
                Bin2::Leaf { .. } => {
                    // A root leaf: one node whose first slot is it.
                    let mut node = Node4::EMPTY;
                    set_slot(&mut node, 0, &root, 0);
                    nodes.push(node);
                }
                Bin2::Inner { .. } => {
                    collapse(&root, &mut nodes);
                }
            }
        }
        bvh.nodes = nodes;
        bvh.tri_indices = refs;
        bvh.stats = BvhStats {
            build_ms: t0.elapsed().as_secs_f64() * 1e3,
            ..bvh.finish_stats()
        };
        bvh
    }

    /// The figures recounted from the tables (the build time and SAH cost kept).
    fn finish_stats(&self) -> BvhStats {
        let mut leaves = 0;
        let mut depth = 0;
        let mut stack = vec![(0u32, 1usize)];
        while let Some((k, d)) = stack.pop() {
            let node = &self.nodes[k as usize];
            for i in 0..WIDTH {
                if node.count[i] > 0 {
                    leaves += 1;
                    depth = depth.max(d);
                } else if !node.is_empty_slot(i) {
                    stack.push((node.child[i], d + 1));
                }
            }
        }
        let references = self.tri_indices.len();
        BvhStats {
            build_ms: self.stats.build_ms,
            nodes: self.nodes.len(),
            leaves,
            references,
            depth,
            mean_per_leaf: if leaves == 0 {
                0.0
            } else {
                references as f64 / leaves as f64
            },
            bytes: self.nodes.len() * std::mem::size_of::<Node4>() + references * 4,
            sah_cost: self.stats.sah_cost,
        }
    }
}

/// The binary tree over `refs` (whose first index is `start` in the whole list): leaves of
/// at most [`LEAF_MAX`] triangles, the SAH's cheapest split of the [`BINS`] per axis, or a
/// leaf where the SAH says one is cheaper.
fn build2(prims: &[Prim], refs: &mut [u32], start: u32, depth: usize, cost: f32) -> Bin2 {
    let n = refs.len();
    let (bounds, cb) = over_chunks(
        refs,
        |c| node_bounds(prims, c),
        (Aabb::EMPTY, Aabb::EMPTY),
        |a, b| (a.0.join(b.0), a.1.join(b.1)),
    );
    let leaf = |refs: &mut [u32]| {
        refs.sort_unstable();
        Bin2::Leaf {
            bounds,
            start,
            n: n as u32,
        }
    };
    if n <= 2 || depth >= MAX_DEPTH {
        return leaf(refs);
    }
    let split = best_split(prims, refs, &cb, bounds.half_area(), cost);
    let mid = match split {
        Some((cost, axis, bin)) => {
            let leaf_cost = n as f32 * bounds.half_area();
            if n <= LEAF_MAX && cost >= leaf_cost {
                return leaf(refs);
            }
            let k = bin_of(&cb, axis);
            partition(refs, |r| k(prims[r as usize].c[axis]) < bin)
        }
        // Every centroid in one point: halve the list (the order is the load order).
        None if n <= LEAF_MAX => return leaf(refs),
        None => n / 2,
    };
    let (l, r) = refs.split_at_mut(mid);
    let (a, b) = if n >= PAR_MIN {
        rayon::join(
            || build2(prims, l, start, depth + 1, cost),
            || build2(prims, r, start + mid as u32, depth + 1, cost),
        )
    } else {
        (
            build2(prims, l, start, depth + 1, cost),
            build2(prims, r, start + mid as u32, depth + 1, cost),
        )
    };
    Bin2::Inner {
        bounds,
        kids: Box::new([a, b]),
    }
}

/// `f` of `refs`: of the whole on this thread below [`PAR_BIN`] references, else of chunks
/// of a quarter of it in parallel, joined by `merge` from `empty` (the same value when the
/// merge is exact, as the boxes' and bins' are).
fn over_chunks<T: Send + Copy + Sync>(
    refs: &[u32],
    f: impl Fn(&[u32]) -> T + Sync,
    empty: T,
    merge: impl Fn(T, T) -> T + Sync + Send,
) -> T {
    if refs.len() < PAR_BIN {
        return f(refs);
    }
    use rayon::prelude::*;
    refs.par_chunks(PAR_BIN / 4)
        .map(&f)
        .reduce(|| empty, &merge)
}

/// The box of `refs`' triangles and the box of their centroids.
fn node_bounds(prims: &[Prim], refs: &[u32]) -> (Aabb, Aabb) {
    let (mut bounds, mut cb) = (Aabb::EMPTY, Aabb::EMPTY);
    for &r in refs {
        let p = &prims[r as usize];
        bounds.grow(p.lo, p.hi);
        cb.grow(p.c, p.c);
    }
    (bounds, cb)
}

/// The bins of a node on the three axes: each bin's box and triangle count.
#[derive(Clone, Copy)]
struct Bins {
    boxes: [[Aabb; BINS]; 3],
    counts: [[u32; BINS]; 3],
}

impl Bins {
    const EMPTY: Bins = Bins {
        boxes: [[Aabb::EMPTY; BINS]; 3],
        counts: [[0; BINS]; 3],
    };

    /// `refs` binned by centroid over the centroid box `cb` on each axis (all in bin 0 on
    /// an axis it does not spread on, which the split search skips).
    fn of(prims: &[Prim], refs: &[u32], cb: &Aabb) -> Bins {
        let mut b = Bins::EMPTY;
        let (lo, scale) = bin_scale(cb);
        for &r in refs {
            let p = &prims[r as usize];
            // `bin_of` on the three axes at once: the same products, the same truncation.
            let i = ((p.c - lo) * scale)
                .as_uvec3()
                .min(glam::UVec3::splat(BINS as u32 - 1));
            for a in 0..3 {
                let i = i[a] as usize;
                b.boxes[a][i].grow(p.lo, p.hi);
                b.counts[a][i] += 1;
            }
        }
        b
    }

    /// Both sets of bins together (exact: boxes join by min and max, counts add).
    fn merge(mut self, o: Bins) -> Bins {
        for a in 0..3 {
            for i in 0..BINS {
                self.boxes[a][i] = self.boxes[a][i].join(o.boxes[a][i]);
                self.counts[a][i] += o.counts[a][i];
            }
        }
        self
    }
}

/// The bin of a centroid coordinate on `axis` over the centroid box `cb` (clamped into
/// `0 .. BINS`).
fn bin_of(cb: &Aabb, axis: usize) -> impl Fn(f32) -> usize {
    let (lo, scale) = bin_scale(cb);
    let (lo, scale) = (lo[axis], scale[axis]);
    move |c| (((c - lo) * scale) as usize).min(BINS - 1)
}

/// Per axis, the origin and scale [`bin_of`] maps a centroid coordinate with (a zero scale
/// on an axis the centroids do not spread on: all in bin 0).
fn bin_scale(cb: &Aabb) -> (Vec3A, Vec3A) {
    let ext = cb.hi - cb.lo;
    let scale = Vec3A::select(
        ext.cmpgt(Vec3A::ZERO),
        Vec3A::splat(BINS as f32) / ext,
        Vec3A::ZERO,
    );
    (cb.lo, scale)
}

/// The cheapest SAH split of `refs` (whose box has half area `node_area`): (cost, axis,
/// first bin on the right), or `None` when the centroids do not spread on any axis. The
/// cost is in the leaf cost's units (`n * node_area` is the leaf's). A node of at least
/// [`PAR_BIN`] triangles bins them in parallel chunks (the same bins: merging is exact).
/// `node_cost` is the cost of a node visit in triangle tests.
fn best_split(
    prims: &[Prim],
    refs: &[u32],
    cb: &Aabb,
    node_area: f32,
    node_cost: f32,
) -> Option<(f32, usize, usize)> {
    let bins = over_chunks(refs, |c| Bins::of(prims, c, cb), Bins::EMPTY, Bins::merge);
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in 0..3 {
        if cb.hi[axis] <= cb.lo[axis] {
            continue;
        }
        let (boxes, counts) = (&bins.boxes[axis], &bins.counts[axis]);
        // Right-to-left sweep: the area and count of bins b.. for every b.
        let mut right_area = [0.0f32; BINS];
        let mut right_n = [0u32; BINS];
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for b in (1..BINS).rev() {
            acc = acc.join(boxes[b]);
            cnt += counts[b];
            right_area[b] = acc.half_area();
            right_n[b] = cnt;
        }
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for b in 1..BINS {
            acc = acc.join(boxes[b - 1]);
            cnt += counts[b - 1];
            if cnt == 0 || right_n[b] == 0 {
                continue;
            }
            let cost = node_cost * node_area
                + acc.half_area() * cnt as f32
                + right_area[b] * right_n[b] as f32;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, b));
            }
        }
    }
    best
}

/// Moves the elements for which `left` holds to the front, returning how many there are.
fn partition(refs: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let mut i = 0;
    for j in 0..refs.len() {
        if left(refs[j]) {
            refs.swap(i, j);
            i += 1;
        }
    }
    i
}

/// Writes binary node `b` into slot `i` of `node`: its box, and its leaf range or the node
/// index `index` of its collapsed subtree.
fn set_slot(node: &mut Node4, i: usize, b: &Bin2, index: u32) {
    let bounds = b.bounds();
    for a in 0..3 {
        node.lo[a][i] = bounds.lo[a];
        node.hi[a][i] = bounds.hi[a];
    }
    match b {
        Bin2::Leaf { start, n, .. } => {
            node.child[i] = *start;
            node.count[i] = *n;
        }
        Bin2::Inner { .. } => {
            node.child[i] = index;
            node.count[i] = 0;
        }
    }
}

/// Collapses the inner binary node `b` into 4-wide nodes appended to `nodes` (its own
/// first), returning its index: its children are its two, then the inner one of largest
/// area replaced by its own two, until there are four or only leaves.
fn collapse(b: &Bin2, nodes: &mut Vec<Node4>) -> u32 {
    let Bin2::Inner { kids, .. } = b else {
        unreachable!("collapse is called on inner nodes only")
    };
    let index = nodes.len() as u32;
    nodes.push(Node4::EMPTY);
    let mut slots: Vec<&Bin2> = vec![&kids[0], &kids[1]];
    while slots.len() < WIDTH {
        let widest = slots
            .iter()
            .enumerate()
            .filter(|(_, s)| matches!(s, Bin2::Inner { .. }))
            .max_by(|(_, a), (_, b)| a.bounds().half_area().total_cmp(&b.bounds().half_area()))
            .map(|(i, _)| i);
        let Some(i) = widest else { break };
        let Bin2::Inner { kids, .. } = slots[i] else {
            unreachable!("filtered to inner nodes")
        };
        slots[i] = &kids[0];
        slots.insert(i + 1, &kids[1]);
    }
    for (i, s) in slots.iter().enumerate() {
        let child = match s {
            Bin2::Inner { .. } => collapse(s, nodes),
            Bin2::Leaf { .. } => 0,
        };
        let mut node = nodes[index as usize];
        set_slot(&mut node, i, s, child);
        nodes[index as usize] = node;
    }
    index
}

#[cfg(test)]
#[path = "bvh_tests.rs"]
mod tests;
