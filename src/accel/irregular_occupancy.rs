//! The irregular grid's occupancy tables and the queries the exit-box growth asks of them
//! (see [`super::irregular`] for the structure): the summed-volume table of the top cells,
//! one record per voxel-map node (its children's kinds, its tight box, its child block),
//! the emptiness query (no cell with triangles in a box) and the subset query (no triangle
//! but a cell's own in a box). Split from the growth (`irregular_grow.rs`) by job; imports
//! the structure only.

use rayon::prelude::*;

use super::axes;
use super::grid::CellRange;
use super::irregular::{IrregularGrid, NODE};

/// A slot ([`Occupancy::top`]) of a cell without triangles.
pub(super) const EMPTY: u32 = 0;
/// A slot ([`Occupancy::top`]) of a cell with triangles.
pub(super) const FULL: u32 = 1;

impl IrregularGrid {
    /// True when no cell with triangles overlaps the virtual box `lo .. hi`.
    pub fn box_is_empty(&self, lo: [u32; 3], hi: [u32; 3]) -> bool {
        self.box_is_empty_with(&Occupancy::new(self), lo, hi)
    }

    /// [`IrregularGrid::box_is_empty`] with the top cells the box covers whole counted in
    /// `occ` at once; only the top cells it cuts are descended.
    pub(super) fn box_is_empty_with(&self, occ: &Occupancy, lo: [u32; 3], hi: [u32; 3]) -> bool {
        let tlo = axes(|a| lo[a] >> self.shift[a]);
        let thi = axes(|a| (hi[a] - 1) >> self.shift[a]);
        // Top cells covered whole: [flo, fhi) per axis.
        let flo = axes(|a| (lo[a] + (1 << self.shift[a]) - 1) >> self.shift[a]);
        let fhi = axes(|a| hi[a] >> self.shift[a]);
        // No node and no cell with triangles among the top cells it touches: empty, at the
        // price of one lookup in the summed-volume table (most boxes that reach past a top
        // cell lie in empty space: inside a closed mesh, beside a floor).
        if occ.count(tlo, thi.map(|t| t + 1)) == 0 {
            return true;
        }
        let whole = (0..3).all(|a| flo[a] < fhi[a]);
        if whole && occ.count(flo, fhi) > 0 {
            return false;
        }
        let inside = |v: u32, a: usize| whole && flo[a] <= v && v < fhi[a];
        let q = Query { occ, lo, hi };
        for z in tlo[2]..=thi[2] {
            for y in tlo[1]..=thi[1] {
                let yz_inside = inside(y, 1) && inside(z, 2);
                let mut x = tlo[0];
                while x <= thi[0] {
                    if yz_inside && inside(x, 0) {
                        // Counted already: jump over the run of whole cells.
                        x = fhi[0];
                        continue;
                    }
                    // A top cell: empty or not by its slot, not the cell table (which the
                    // growth fills in place while it asks).
                    let num = match occ.top[self.top_index([x, y, z])] {
                        EMPTY => {
                            x += 1;
                            continue;
                        }
                        FULL => return false,
                        s => s - 2,
                    };
                    match occ.tight_relation(num, lo, hi) {
                        Tight::Apart => {
                            x += 1;
                            continue;
                        }
                        Tight::Inside => return false,
                        Tight::Cut => {}
                    }
                    let node_lo = [x << self.shift[0], y << self.shift[1], z << self.shift[2]];
                    if !q.node_is_empty(num, node_lo, 0) {
                        return false;
                    }
                    x += 1;
                }
            }
        }
        true
    }
}

impl IrregularGrid {
    /// True when every cell overlapping the virtual box `lo .. hi` holds only triangles of
    /// `own` (ascending), reading the cells' lists through `ranges` (the cell table's, which
    /// the growth takes out of the grid while it asks): then any triangle meeting the box
    /// is one of `own`. Empty top cells, and nodes whose cells with triangles all lie
    /// outside the box, are skipped through `occ` without reading a cell.
    pub(super) fn box_within_with(
        &self,
        occ: &Occupancy,
        ranges: &[CellRange],
        lo: [u32; 3],
        hi: [u32; 3],
        own: &[u32],
    ) -> bool {
        let tlo = axes(|a| lo[a] >> self.shift[a]);
        let thi = axes(|a| (hi[a] - 1) >> self.shift[a]);
        if occ.count(tlo, thi.map(|t| t + 1)) == 0 {
            return true;
        }
        let q = Within {
            g: self,
            occ,
            ranges,
            lo,
            hi,
            own,
        };
        for z in tlo[2]..=thi[2] {
            for y in tlo[1]..=thi[1] {
                for x in tlo[0]..=thi[0] {
                    let i = self.top_index([x, y, z]);
                    let ok = match occ.top[i] {
                        EMPTY => true,
                        FULL => q.cell(self.vmap[i]),
                        slot => {
                            let num = slot - 2;
                            let node_lo =
                                [x << self.shift[0], y << self.shift[1], z << self.shift[2]];
                            matches!(occ.tight_relation(num, lo, hi), Tight::Apart)
                                || q.node(num, node_lo, 0)
                        }
                    };
                    if !ok {
                        return false;
                    }
                }
            }
        }
        true
    }
}

/// One subset query ([`IrregularGrid::box_within_with`]): the box `lo .. hi` over `g`'s
/// voxel map, the cells it overlaps holding only triangles of `own`.
pub(super) struct Within<'a> {
    pub(super) g: &'a IrregularGrid,
    pub(super) occ: &'a Occupancy,
    pub(super) ranges: &'a [CellRange],
    pub(super) lo: [u32; 3],
    pub(super) hi: [u32; 3],
    pub(super) own: &'a [u32],
}

impl Within<'_> {
    /// Whether cell `id`'s triangles are all in `own` (both lists ascending).
    fn cell(&self, id: u32) -> bool {
        let r = self.ranges[id as usize];
        if r.count as usize > self.own.len() {
            return false;
        }
        let list = &self.g.tri_indices[r.offset as usize..(r.offset + r.count) as usize];
        let mut k = 0;
        list.iter().all(|&t| {
            while k < self.own.len() && self.own[k] < t {
                k += 1;
            }
            k < self.own.len() && self.own[k] == t
        })
    }

    /// Whether the cells of node `num` (at `level`, from `node_lo`) that overlap the box
    /// hold only triangles of `own`: its children with triangles the box overlaps are
    /// checked, its child nodes descended unless their tight box misses the box.
    pub(super) fn node(&self, num: u32, node_lo: [u32; 3], level: usize) -> bool {
        let (occ, lo, hi) = (self.occ, self.lo, self.hi);
        let lv = &occ.level[level];
        let overlap = lv.overlap(node_lo, lo, hi);
        let n = &occ.nodes[num as usize];
        let mut full = overlap & n.full;
        while full != 0 {
            let i = full.trailing_zeros();
            full &= full - 1;
            if !self.cell(self.g.vmap[(n.block + i) as usize]) {
                return false;
            }
        }
        let mut kids = overlap & n.kids;
        while kids != 0 {
            let i = kids.trailing_zeros();
            kids &= kids - 1;
            let child = n.child_node(i);
            if matches!(occ.tight_relation(child, lo, hi), Tight::Apart) {
                continue;
            }
            let clo = lv.child_lo(node_lo, i);
            if !self.node(child, clo, level + 1) {
                return false;
            }
        }
        true
    }
}

/// One emptiness query: the box `lo .. hi` (virtual coordinates) over `g`'s voxel map.
pub(super) struct Query<'a> {
    pub(super) occ: &'a Occupancy,
    pub(super) lo: [u32; 3],
    pub(super) hi: [u32; 3],
}

impl Query<'_> {
    /// Whether the box holds nothing within node `num` (numbered as
    /// [`Occupancy::nodes`]) at `level`, covering `1 << rem[a]` virtual cells from
    /// `node_lo` (`rem` the level's [`Level::rem`]). Reads the node records only, never the voxel map or the cell table (the
    /// growth fills the latter in place while it asks).
    pub(super) fn node_is_empty(&self, num: u32, node_lo: [u32; 3], level: usize) -> bool {
        let (occ, lo, hi) = (self.occ, self.lo, self.hi);
        let lv = &occ.level[level];
        // A node was split for its triangles, so one the box covers whole is not empty
        // (conservatively: its triangles may only touch its padding; the box then just
        // does not grow there). Only nodes the box cuts are descended.
        if (0..3).all(|a| lo[a] <= node_lo[a] && node_lo[a] + (1 << lv.rem[a]) <= hi[a]) {
            return false;
        }
        let overlap = lv.overlap(node_lo, lo, hi);
        let n = &occ.nodes[num as usize];
        // A cell with triangles among them answers at once; empty cells are skipped; a
        // node is skipped when the box misses its tight box, answers when the box holds
        // it, and only else descended.
        if overlap & n.full != 0 {
            return false;
        }
        let mut kids = overlap & n.kids;
        while kids != 0 {
            let i = kids.trailing_zeros();
            kids &= kids - 1;
            let child = n.child_node(i);
            match occ.tight_relation(child, lo, hi) {
                Tight::Apart => continue,
                Tight::Inside => return false,
                Tight::Cut => {}
            }
            let clo = lv.child_lo(node_lo, i);
            if !self.node_is_empty(child, clo, level + 1) {
                return false;
            }
        }
        true
    }
}

/// Per stride 1, 2, 4 of a child block: the children on the low side of that axis.
pub(super) const LOW_HALF: [u8; 3] = [0x55, 0x33, 0x0F];

/// What the queries need of one level of the split schedule, worked out once.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Level {
    /// A node's size in bits of virtual cells per axis (`1 << rem`).
    pub(super) rem: [u32; 3],
    /// Its children's.
    pub(super) crem: [u32; 3],
    /// Per split axis: the bit of a child's number that says it is the upper one (the
    /// axis's stride in the block: x before y before z among the split ones); 0 unsplit.
    pub(super) bit: [u32; 3],
    /// Per split axis: the children on its low side; 0 unsplit.
    pub(super) low: [u8; 3],
}

impl Level {
    /// The schedule's levels, from the top cells' size `shift` down.
    pub(super) fn all(levels: &[[bool; 3]], shift: [u32; 3]) -> Vec<Level> {
        let mut rem = shift;
        levels
            .iter()
            .map(|mask| {
                let mut lv = Level {
                    rem,
                    ..Level::default()
                };
                let mut stride = 1u32;
                for a in 0..3 {
                    if mask[a] {
                        rem[a] -= 1;
                        lv.bit[a] = stride;
                        lv.low[a] = LOW_HALF[stride.trailing_zeros() as usize];
                        stride *= 2;
                    }
                }
                lv.crem = rem;
                lv
            })
            .collect()
    }

    /// The children of a node at this level (from `node_lo`) that the box `lo .. hi`
    /// overlaps, as a bit set: on a split axis the low ones when the box starts below the
    /// middle, the high ones when it ends above it (a box overlapping the node overlaps at
    /// least one of them).
    #[inline]
    pub(super) fn overlap(&self, node_lo: [u32; 3], lo: [u32; 3], hi: [u32; 3]) -> u8 {
        let mut overlap = u8::MAX;
        for a in 0..3 {
            if self.low[a] != 0 {
                let mid = node_lo[a] + (1 << self.crem[a]);
                if lo[a] >= mid {
                    overlap &= !self.low[a];
                }
                if hi[a] <= mid {
                    overlap &= self.low[a];
                }
            }
        }
        overlap
    }

    /// The lower corner of child `i` of a node at this level from `node_lo`.
    #[inline]
    pub(super) fn child_lo(&self, node_lo: [u32; 3], i: u32) -> [u32; 3] {
        axes(|a| node_lo[a] + (((i & self.bit[a] != 0) as u32) << self.crem[a]))
    }

    /// The number of the child of a node at this level holding virtual cell `p`.
    #[inline]
    pub(super) fn child_of(&self, p: [u32; 3]) -> u32 {
        (0..3)
            .filter(|&a| self.bit[a] != 0)
            .map(|a| ((p[a] >> self.crem[a]) & 1) * self.bit[a])
            .sum()
    }
}

/// How a query box meets a node's tight box ([`NodeRec::tight_lo`] .. `tight_hi`).
pub(super) enum Tight {
    /// They share no cell: the node holds nothing in the box.
    Apart,
    /// The query box holds it whole: a cell with triangles (or, in a node holding none,
    /// the node) lies in the box, which is therefore not empty.
    Inside,
    /// Neither: descend.
    Cut,
}

/// What an emptiness query knows of one voxel-map node: its children's kinds as bit
/// sets and its tight box, in one record, so that a query reads neither the voxel map nor
/// the cell table, and one record per node it descends (a child's entry, kind and box
/// used to lie in three tables: the bunny's growth 8% slower).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct NodeRec {
    /// The box around the part of the node an emptiness query can find non-empty: its
    /// cells with triangles (and, should it hold none, the node whole). A box missing it
    /// is empty there: no cell with triangles overlaps it, and it covers no node below
    /// whole (a node with a cell with triangles below contains that cell, which the box
    /// would then overlap). So the query skips the nodes it only cuts on their empty side,
    /// with the same answer.
    pub(super) tight_lo: [u32; 3],
    pub(super) tight_hi: [u32; 3],
    /// Number of the first child that is a node: a block's nodes are numbered one after
    /// the other (nodes are numbered in map order).
    pub(super) first: u32,
    /// Index of the node's child block in the voxel map: where a subset query
    /// ([`Within`]) finds the cell ids of its children with triangles.
    pub(super) block: u32,
    /// Bit `i`: child `i` is a cell with triangles.
    pub(super) full: u8,
    /// Bit `i`: child `i` is a node.
    pub(super) kids: u8,
    /// Whether a cell with triangles lies below (a node's triangles may all only touch its
    /// padding, which its children's smaller padding leaves out).
    pub(super) holds_full: bool,
}

impl NodeRec {
    /// The number of child `i`, a node (children that are nodes are numbered one after
    /// the other in block order).
    #[inline]
    pub(super) fn child_node(&self, i: u32) -> u32 {
        self.first + (self.kids & ((1u8 << i) - 1)).count_ones()
    }
}

/// Summed-volume table of the top cells that are not empty (a node, or a cell with
/// triangles): how many lie in a block of top cells, in constant time; and the node
/// records the emptiness queries descend.
pub(super) struct Occupancy {
    /// `(res + 1)^3` prefix sums, x fastest, zero on the low faces.
    pub(super) sum: Vec<u32>,
    /// Top resolution plus one.
    pub(super) dim: [usize; 3],
    /// Per top cell: [`EMPTY`] (a cell without triangles), [`FULL`] (a cell with
    /// triangles) or, for a node, `2 +` its number.
    pub(super) top: Vec<u32>,
    /// Per node, numbered in voxel-map order (the order of their entries).
    pub(super) nodes: Vec<NodeRec>,
    /// `holding[a][d]`: one more than the deepest level whose nodes span at least `d` bits
    /// of axis `a` (`1 << rem >= 1 << d`), 0 when not even a top cell does: where a growth
    /// query starts, from how many low bits its box differs in from its cell.
    pub(super) holding: [[u8; 33]; 3],
    /// The split schedule's levels as the queries use them.
    pub(super) level: Vec<Level>,
    /// Every node holds a cell with triangles below. Then a box is empty exactly when it
    /// overlaps no cell with triangles (a node it covers whole, or a tight box it holds,
    /// contains one), so a box inside an exit box already grown is empty ([`Recent`]).
    pub(super) full_below_every_node: bool,
    /// Whether the node records were built tree by tree in parallel (the build's layout
    /// was recognised); false means the serial pass ran, the same tables more slowly.
    /// Read by the tests only: a silent fall back to the serial pass is a slowdown that
    /// no comparison of tables can see.
    #[cfg_attr(not(test), allow(dead_code))]
    pub(super) by_tree: bool,
}

impl Occupancy {
    /// Built in parallel: the summed-volume table slab by slab, [`Occupancy::nodes`] tree
    /// by tree (each top cell's subtree owns one stretch of the voxel map when laid out as
    /// the build lays it out; any other layout is built serially).
    pub(super) fn new(g: &IrregularGrid) -> Occupancy {
        Occupancy::build(g, true)
    }

    /// [`Occupancy::new`], its node records tree by tree in parallel only when `by_tree`
    /// (else in one serial pass, as for a voxel map laid out otherwise).
    pub(super) fn build(g: &IrregularGrid, by_tree: bool) -> Occupancy {
        let dim = g.top_res.map(|r| r as usize + 1);
        let slab = dim[0] * dim[1];
        let mut sum = vec![0u32; slab * dim[2]];
        let occupied = |x: usize, y: usize, z: usize| {
            let e = g.vmap[g.top_index([x as u32, y as u32, z as u32])];
            (e & NODE != 0 || g.cells[e as usize].range.count > 0) as u32
        };
        // Each top cell's count at (x+1, y+1, z+1), then prefix sums along x and y within
        // every z slab, then along z: the same integers as the 3-D recurrence.
        sum.par_chunks_mut(slab)
            .enumerate()
            .skip(1)
            .for_each(|(z, s)| {
                for y in 1..dim[1] {
                    for x in 1..dim[0] {
                        s[x + dim[0] * y] = s[x - 1 + dim[0] * y] + occupied(x - 1, y - 1, z - 1);
                    }
                }
                for y in 2..dim[1] {
                    for x in 1..dim[0] {
                        s[x + dim[0] * y] += s[x + dim[0] * (y - 1)];
                    }
                }
            });
        for z in 2..dim[2] {
            let (done, rest) = sum.split_at_mut(z * slab);
            rest[..slab]
                .par_chunks_mut(4096)
                .zip(done[(z - 1) * slab..].par_chunks(4096))
                .for_each(|(c, p)| c.iter_mut().zip(p).for_each(|(c, p)| *c += p));
        }
        let n_top = dim.iter().map(|d| d - 1).product::<usize>();
        let n_vmap = g.vmap.len();
        // The top cells that are nodes, in top order, with the start of their stretch.
        let roots: Vec<(usize, u32)> = (0..n_top)
            .filter(|&i| g.vmap[i] & NODE != 0)
            .map(|i| (i, g.vmap[i]))
            .collect();
        let starts: Vec<usize> = roots
            .iter()
            .map(|&(_, e)| (e & !NODE) as usize)
            .chain([n_vmap])
            .collect();
        let top_lo = |i: usize| {
            let r = g.top_res;
            let t = [
                i as u32 % r[0],
                (i as u32 / r[0]) % r[1],
                i as u32 / (r[0] * r[1]),
            ];
            axes(|a| t[a] << g.shift[a])
        };
        let laid_out = by_tree && starts[0] >= n_top && starts.windows(2).all(|w| w[0] < w[1]);
        // The map in pieces numbered in parallel: the top cells, then every tree's stretch
        // (one piece when the layout is another).
        let cuts: Vec<usize> = if laid_out {
            [0].into_iter().chain(starts.iter().copied()).collect()
        } else {
            vec![0, n_vmap]
        };
        let node_counts: Vec<usize> = cuts
            .par_windows(2)
            .map(|w| {
                g.vmap[w[0]..w[1]]
                    .iter()
                    .filter(|&&e| e & NODE != 0)
                    .count()
            })
            .collect();
        let first = offsets(node_counts.iter().copied(), 0);
        let n_nodes = node_counts.iter().sum::<usize>();
        // Every entry's slot (as [`Occupancy::top`]'s), for the records' bit sets.
        let mut slot = vec![EMPTY; n_vmap];
        let slot_pieces = split_lens(&mut slot, cuts.windows(2).map(|w| w[1] - w[0]));
        slot_pieces
            .into_par_iter()
            .zip(cuts.par_windows(2))
            .zip(&first)
            .for_each(|((out, w), &first)| {
                let mut k = first as u32;
                for (s, &e) in out.iter_mut().zip(&g.vmap[w[0]..w[1]]) {
                    *s = if e & NODE != 0 {
                        k += 1;
                        k + 1
                    } else if g.cells[e as usize].range.count > 0 {
                        FULL
                    } else {
                        EMPTY
                    };
                }
            });
        // Filled in parallel: `vec!` writes structs' copies on one thread.
        let mut nodes: Vec<NodeRec> = (0..n_nodes)
            .into_par_iter()
            .map(|_| NodeRec::default())
            .collect();
        let recs: Vec<NodeRec> = if laid_out {
            // Tree j's nodes are those of piece j + 1.
            let below = &mut nodes[first.get(1).copied().unwrap_or(n_nodes)..];
            let stretches: Vec<Stretch> = split_lens(below, node_counts[1..].iter().copied())
                .into_iter()
                .zip(&first[1..])
                .map(|(nodes, &off)| Stretch { nodes, off })
                .collect();
            roots
                .par_iter()
                .zip(stretches)
                .map(|(&(i, e), mut out)| node_rec(g, &slot, e, top_lo(i), g.shift, 0, &mut out))
                .collect()
        } else {
            let mut out = Stretch {
                nodes: &mut nodes,
                off: 0,
            };
            roots
                .iter()
                .map(|&(i, e)| node_rec(g, &slot, e, top_lo(i), g.shift, 0, &mut out))
                .collect()
        };
        for (&(i, _), r) in roots.iter().zip(recs) {
            nodes[(slot[i] - 2) as usize] = r;
        }
        slot.truncate(n_top);
        let level = Level::all(&g.levels, g.shift);
        // Deeper levels overwrite: each entry ends as the deepest level wide enough.
        let mut holding = [[0u8; 33]; 3];
        for (l, lv) in level.iter().enumerate() {
            for a in 0..3 {
                holding[a][..=lv.rem[a] as usize].fill(l as u8 + 1);
            }
        }
        let full_below_every_node = nodes.par_iter().all(|n| n.holds_full);
        Occupancy {
            sum,
            dim,
            top: slot,
            nodes,
            full_below_every_node,
            holding,
            level,
            by_tree: laid_out,
        }
    }

    /// How `lo .. hi` meets the tight box of node `num`.
    #[inline]
    pub(super) fn tight_relation(&self, num: u32, lo: [u32; 3], hi: [u32; 3]) -> Tight {
        let n = &self.nodes[num as usize];
        let (tlo, thi) = (n.tight_lo, n.tight_hi);
        if (0..3).any(|a| thi[a] <= lo[a] || hi[a] <= tlo[a]) {
            Tight::Apart
        } else if (0..3).all(|a| lo[a] <= tlo[a] && thi[a] <= hi[a]) {
            Tight::Inside
        } else {
            Tight::Cut
        }
    }

    /// Non-empty top cells in `lo .. hi` (top coordinates, upper bound exclusive).
    pub(super) fn count(&self, lo: [u32; 3], hi: [u32; 3]) -> u32 {
        let d = self.dim;
        let s = |x: u32, y: u32, z: u32| {
            self.sum[x as usize + d[0] * (y as usize + d[1] * z as usize)] as i64
        };
        let (a, b) = (lo, hi);
        (s(b[0], b[1], b[2]) - s(a[0], b[1], b[2]) - s(b[0], a[1], b[2]) - s(b[0], b[1], a[2])
            + s(a[0], a[1], b[2])
            + s(a[0], b[1], a[2])
            + s(b[0], a[1], a[2])
            - s(a[0], a[1], a[2])) as u32
    }
}

/// The part of [`Occupancy::nodes`] from node `off` on that one build of it writes.
pub(super) struct Stretch<'a> {
    pub(super) nodes: &'a mut [NodeRec],
    pub(super) off: usize,
}

/// The record of node `e` at `level` covering `1 << rem[a]` virtual cells from
/// `node_lo`, writing that of every node below into `out` (`slot`: every entry's, as
/// [`Occupancy::top`]'s).
fn node_rec(
    g: &IrregularGrid,
    slot: &[u32],
    e: u32,
    node_lo: [u32; 3],
    rem: [u32; 3],
    level: usize,
    out: &mut Stretch,
) -> NodeRec {
    let mask = g.levels[level];
    let crem = axes(|a| rem[a] - mask[a] as u32);
    let n = mask.map(|m| if m { 2u32 } else { 1 });
    let (mut lo, mut hi) = ([u32::MAX; 3], [0u32; 3]);
    let mut rec = NodeRec {
        block: e & !NODE,
        ..NodeRec::default()
    };
    for bz in 0..n[2] {
        for by in 0..n[1] {
            for bx in 0..n[0] {
                let i = bx + n[0] * (by + n[1] * bz);
                let idx = ((e & !NODE) + i) as usize;
                let child = g.vmap[idx];
                let clo = [
                    node_lo[0] + (bx << crem[0]),
                    node_lo[1] + (by << crem[1]),
                    node_lo[2] + (bz << crem[2]),
                ];
                let b = if child & NODE != 0 {
                    if rec.kids == 0 {
                        rec.first = slot[idx] - 2;
                    }
                    rec.kids |= 1 << i;
                    let r = node_rec(g, slot, child, clo, crem, level + 1, out);
                    out.nodes[(slot[idx] - 2) as usize - out.off] = r;
                    rec.holds_full |= r.holds_full;
                    (r.tight_lo, r.tight_hi)
                } else if slot[idx] == FULL {
                    rec.full |= 1 << i;
                    rec.holds_full = true;
                    (clo, axes(|a| clo[a] + (1 << crem[a])))
                } else {
                    continue;
                };
                for a in 0..3 {
                    lo[a] = lo[a].min(b.0[a]);
                    hi[a] = hi[a].max(b.1[a]);
                }
            }
        }
    }
    (rec.tight_lo, rec.tight_hi) = if lo[0] == u32::MAX {
        // No cell with triangles below: the node itself blocks a box covering it whole.
        (node_lo, axes(|a| node_lo[a] + (1 << rem[a])))
    } else {
        (lo, hi)
    };
    rec
}

/// Splits `s` into consecutive slices of the given lengths.
pub(super) fn split_lens<T>(mut s: &mut [T], lens: impl Iterator<Item = usize>) -> Vec<&mut [T]> {
    lens.map(|n| {
        let (a, b) = std::mem::take(&mut s).split_at_mut(n);
        s = b;
        a
    })
    .collect()
}

/// Exclusive prefix sums of `v`, from `base`.
pub(super) fn offsets(v: impl Iterator<Item = usize>, base: usize) -> Vec<usize> {
    v.scan(base, |acc, n| {
        let o = *acc;
        *acc += n;
        Some(o)
    })
    .collect()
}
