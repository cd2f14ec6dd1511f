//! The irregular grid's exit boxes (see [`super::irregular`]): the emptiness query over
//! the voxel map, the summed-volume table that answers it for whole top cells, and the
//! growth of an empty cell's box face by face. Split from the build by job; imports the
//! structure, never the build (`irregular_build.rs` imports this).

use rayon::prelude::*;

use super::irregular::{IrrCell, IrregularGrid, MAX_LEVELS, NODE};

/// [`Occupancy::slot`] of a cell without triangles.
const EMPTY: u32 = 0;
/// [`Occupancy::slot`] of a cell with triangles.
const FULL: u32 = 1;

/// Rounds of exit-box growth (each round tries all six faces once).
const GROW_ROUNDS: usize = 4;

impl IrregularGrid {
    /// True when no cell with triangles overlaps the virtual box `lo .. hi`.
    pub fn box_is_empty(&self, lo: [u32; 3], hi: [u32; 3]) -> bool {
        self.box_is_empty_with(&Occupancy::new(self), lo, hi)
    }

    /// [`IrregularGrid::box_is_empty`] with the top cells the box covers whole counted in
    /// `occ` at once; only the top cells it cuts are descended.
    pub(super) fn box_is_empty_with(&self, occ: &Occupancy, lo: [u32; 3], hi: [u32; 3]) -> bool {
        let tlo = [0, 1, 2].map(|a| lo[a] >> self.shift[a]);
        let thi = [0, 1, 2].map(|a| (hi[a] - 1) >> self.shift[a]);
        // Top cells covered whole: [flo, fhi) per axis.
        let flo = [0, 1, 2].map(|a| (lo[a] + (1 << self.shift[a]) - 1) >> self.shift[a]);
        let fhi = [0, 1, 2].map(|a| hi[a] >> self.shift[a]);
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
        let q = Query {
            g: self,
            occ,
            lo,
            hi,
        };
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
                    let idx = self.top_index([x, y, z]);
                    let e = self.vmap[idx];
                    if e & NODE == 0 {
                        // A top cell: empty or not by its slot, not the cell table (which
                        // the growth fills in place while it asks).
                        if occ.slot[idx] == FULL {
                            return false;
                        }
                        x += 1;
                        continue;
                    }
                    match occ.tight_relation(idx, lo, hi) {
                        Tight::Apart => {
                            x += 1;
                            continue;
                        }
                        Tight::Inside => return false,
                        Tight::Cut => {}
                    }
                    let node_lo = [x << self.shift[0], y << self.shift[1], z << self.shift[2]];
                    if !q.node_is_empty(e, node_lo, self.shift, 0) {
                        return false;
                    }
                    x += 1;
                }
            }
        }
        true
    }
}

/// One emptiness query: the box `lo .. hi` (virtual coordinates) over `g`'s voxel map.
struct Query<'a> {
    g: &'a IrregularGrid,
    occ: &'a Occupancy,
    lo: [u32; 3],
    hi: [u32; 3],
}

impl Query<'_> {
    /// Whether the box holds nothing within voxel-map entry `e`, a node at `level`
    /// covering `1 << rem[a]` virtual cells from `node_lo`. Reads no cell of the cell table
    /// (the growth fills it in place while it asks).
    fn node_is_empty(&self, e: u32, node_lo: [u32; 3], rem: [u32; 3], level: usize) -> bool {
        let (g, occ, lo, hi) = (self.g, self.occ, self.lo, self.hi);
        debug_assert!(e & NODE != 0, "asked about a cell entry");
        // A node was split for its triangles, so one the box covers whole is not empty
        // (conservatively: its triangles may only touch its padding; the box then just
        // does not grow there). Only nodes the box cuts are descended.
        if (0..3).all(|a| lo[a] <= node_lo[a] && node_lo[a] + (1 << rem[a]) <= hi[a]) {
            return false;
        }
        let mask = g.levels[level];
        let crem = [0, 1, 2].map(|a| rem[a] - mask[a] as u32);
        // The children the box overlaps, per axis `b0[a] .. b1[a]`: on a split axis the
        // low one when the box starts below the middle, the high one when it ends above
        // it (the box overlaps this node, so at least one of them); one child on an
        // unsplit axis. Child `b` sits at `base + b . stride`.
        let mut b0 = [0u32; 3];
        let mut b1 = [1u32; 3];
        let mut stride = [0u32; 3];
        let mut next = 1;
        for a in 0..3 {
            if mask[a] {
                let mid = node_lo[a] + (1 << crem[a]);
                b0[a] = (lo[a] >= mid) as u32;
                b1[a] = 1 + (hi[a] > mid) as u32;
                stride[a] = next;
                next *= 2;
            }
        }
        let base = e & !NODE;
        for bz in b0[2]..b1[2] {
            for by in b0[1]..b1[1] {
                for bx in b0[0]..b1[0] {
                    let idx = (base + bx * stride[0] + by * stride[1] + bz * stride[2]) as usize;
                    // Empty cells are skipped and cells with triangles answer, both by the
                    // slot alone; a node is skipped when the box misses its tight box,
                    // answers when the box holds it, and only else descended.
                    match occ.slot[idx] {
                        EMPTY => continue,
                        FULL => return false,
                        _ => {}
                    }
                    let child = g.vmap[idx];
                    match occ.tight_relation(idx, lo, hi) {
                        Tight::Apart => continue,
                        Tight::Inside => return false,
                        Tight::Cut => {}
                    }
                    let clo = [
                        node_lo[0] + (bx << crem[0]),
                        node_lo[1] + (by << crem[1]),
                        node_lo[2] + (bz << crem[2]),
                    ];
                    if !self.node_is_empty(child, clo, crem, level + 1) {
                        return false;
                    }
                }
            }
        }
        true
    }
}

/// How a query box meets a node's [`Occupancy::tight`] box.
enum Tight {
    /// They share no cell: the node holds nothing in the box.
    Apart,
    /// The query box holds it whole: a cell with triangles (or, in a node holding none,
    /// the node) lies in the box, which is therefore not empty.
    Inside,
    /// Neither: descend.
    Cut,
}

/// Summed-volume table of the top cells that are not empty (a node, or a cell with
/// triangles): how many lie in a block of top cells, in constant time.
pub(super) struct Occupancy {
    /// `(res + 1)^3` prefix sums, x fastest, zero on the low faces.
    sum: Vec<u32>,
    /// Top resolution plus one.
    dim: [usize; 3],
    /// Per voxel-map entry: [`EMPTY`] (a cell without triangles), [`FULL`] (a cell with
    /// triangles) or, for a node, `2 +` its number, nodes numbered in map order: what an
    /// emptiness query decides a child by, and where it finds a node's tight box.
    slot: Vec<u32>,
    /// Per node (by number): the box around the part of it an emptiness query can find
    /// non-empty, its cells with triangles (and, should a node hold none, that node
    /// whole). A box missing it is empty there: no cell with triangles overlaps it, and it
    /// covers no node below whole (a node with a cell with triangles below contains that
    /// cell, which the box would then overlap). So the query skips the nodes it only cuts
    /// on their empty side, with the same answer. One box per node rather than per map
    /// entry: with the slots, about a third of the memory of a box and a flag per entry
    /// (a node holds two to eight entries; the queries wait on memory, not arithmetic).
    tight: Vec<([u32; 3], [u32; 3])>,
    /// Whether the tight boxes were built tree by tree in parallel (the build's layout
    /// was recognised); false means the serial pass ran, the same tables more slowly.
    /// Read by the tests only: a silent fall back to the serial pass is a slowdown that
    /// no comparison of tables can see.
    #[cfg_attr(not(test), allow(dead_code))]
    by_tree: bool,
}

impl Occupancy {
    /// Built in parallel: the summed-volume table slab by slab, [`Occupancy::tight`] tree
    /// by tree (each top cell's subtree owns one stretch of the voxel map when laid out as
    /// the build lays it out; any other layout is built serially).
    pub(super) fn new(g: &IrregularGrid) -> Occupancy {
        Occupancy::build(g, true)
    }

    /// [`Occupancy::new`], its tight boxes tree by tree in parallel only when `by_tree`
    /// (else in one serial pass, as for a voxel map laid out otherwise).
    fn build(g: &IrregularGrid, by_tree: bool) -> Occupancy {
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
            [0, 1, 2].map(|a| t[a] << g.shift[a])
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
        // Filled in parallel: `vec!` writes tuples' copies on one thread.
        let mut tight: Vec<([u32; 3], [u32; 3])> = (0..n_nodes)
            .into_par_iter()
            .map(|_| ([0; 3], [0; 3]))
            .collect();
        let boxes: Vec<([u32; 3], [u32; 3])> = if laid_out {
            // Tree j's nodes are those of piece j + 1.
            let below = &mut tight[first.get(1).copied().unwrap_or(n_nodes)..];
            let stretches: Vec<Stretch> = split_lens(below, node_counts[1..].iter().copied())
                .into_iter()
                .zip(&first[1..])
                .map(|(tight, &off)| Stretch { tight, off })
                .collect();
            roots
                .par_iter()
                .zip(stretches)
                .map(|(&(i, e), mut out)| tight_box(g, &slot, e, top_lo(i), g.shift, 0, &mut out))
                .collect()
        } else {
            let mut out = Stretch {
                tight: &mut tight,
                off: 0,
            };
            roots
                .iter()
                .map(|&(i, e)| tight_box(g, &slot, e, top_lo(i), g.shift, 0, &mut out))
                .collect()
        };
        for (&(i, _), b) in roots.iter().zip(boxes) {
            tight[(slot[i] - 2) as usize] = b;
        }
        Occupancy {
            sum,
            dim,
            slot,
            tight,
            by_tree: laid_out,
        }
    }

    /// How `lo .. hi` meets [`Occupancy::tight`] of node entry `idx`.
    #[inline]
    fn tight_relation(&self, idx: usize, lo: [u32; 3], hi: [u32; 3]) -> Tight {
        let (tlo, thi) = self.tight[(self.slot[idx] - 2) as usize];
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

/// The part of [`Occupancy::tight`] from node `off` on that one build of it writes.
struct Stretch<'a> {
    tight: &'a mut [([u32; 3], [u32; 3])],
    off: usize,
}

/// [`Occupancy::tight`] of node `e` at `level` covering `1 << rem[a]` virtual cells from
/// `node_lo`, writing that of every node below into `tight`.
fn tight_box(
    g: &IrregularGrid,
    slot: &[u32],
    e: u32,
    node_lo: [u32; 3],
    rem: [u32; 3],
    level: usize,
    tight: &mut Stretch,
) -> ([u32; 3], [u32; 3]) {
    let mask = g.levels[level];
    let crem = [0, 1, 2].map(|a| rem[a] - mask[a] as u32);
    let n = mask.map(|m| if m { 2u32 } else { 1 });
    let (mut lo, mut hi) = ([u32::MAX; 3], [0u32; 3]);
    for bz in 0..n[2] {
        for by in 0..n[1] {
            for bx in 0..n[0] {
                let idx = ((e & !NODE) + bx + n[0] * (by + n[1] * bz)) as usize;
                let child = g.vmap[idx];
                let clo = [
                    node_lo[0] + (bx << crem[0]),
                    node_lo[1] + (by << crem[1]),
                    node_lo[2] + (bz << crem[2]),
                ];
                let b = if child & NODE != 0 {
                    let b = tight_box(g, slot, child, clo, crem, level + 1, tight);
                    tight.tight[(slot[idx] - 2) as usize - tight.off] = b;
                    b
                } else if slot[idx] == FULL {
                    (clo, [0, 1, 2].map(|a| clo[a] + (1 << crem[a])))
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
    if lo[0] == u32::MAX {
        // No cell with triangles below: the node itself blocks a box covering it whole.
        return (node_lo, [0, 1, 2].map(|a| node_lo[a] + (1 << rem[a])));
    }
    (lo, hi)
}

/// Grows the exit box of cell `c` over empty neighbours: each face in turn moves out by a
/// step (the cell's own size at first, doubled after each success and halved after each
/// failure down to that size) while the slab it sweeps holds no triangle.
pub(super) fn grow(g: &IrregularGrid, occ: &Occupancy, c: &IrrCell) -> ([u32; 3], [u32; 3]) {
    let path = Ancestors::of(g, c);
    let (mut lo, mut hi) = (c.lo, c.hi);
    let own = [0, 1, 2].map(|a| c.hi[a] - c.lo[a]);
    // Per face (axis, upward): current step, or 0 once the face is done.
    let mut step = [[own[0]; 2], [own[1]; 2], [own[2]; 2]];
    for _ in 0..GROW_ROUNDS {
        let mut any = false;
        for a in 0..3 {
            for up in [true, false] {
                let s = step[a][up as usize];
                if s == 0 {
                    continue;
                }
                let (slo, shi) = if up {
                    (hi[a], (hi[a] + s).min(g.res[a]))
                } else {
                    (lo[a].saturating_sub(s), lo[a])
                };
                if slo >= shi {
                    step[a][up as usize] = 0;
                    continue;
                }
                let (mut blo, mut bhi) = (lo, hi);
                blo[a] = slo;
                bhi[a] = shi;
                any = true;
                if path.box_is_empty(g, occ, blo, bhi) {
                    if up {
                        hi[a] = shi;
                    } else {
                        lo[a] = slo;
                    }
                    step[a][up as usize] = s.saturating_mul(2);
                } else if s > own[a] {
                    step[a][up as usize] = (s / 2).max(own[a]);
                } else {
                    step[a][up as usize] = 0;
                }
            }
        }
        if !any {
            break;
        }
    }
    (lo, hi)
}

/// The voxel-map nodes holding one cell, top cell first: an emptiness query about a box
/// near the cell starts at the deepest of them that holds the whole box instead of at the
/// top grid. The answer is the same (a node holding the box is the only child the query
/// from the top would descend into at every level above it, and it is covered whole only
/// when it equals the box, which both ask first); most slabs a cell's growth sweeps lie in
/// a node a few levels up, so the query skips the ten or more levels above it.
struct Ancestors {
    /// `(vmap entry, node_lo, rem, level)`, top cell first, the cell's own entry at `len - 1`.
    nodes: [(u32, [u32; 3], [u32; 3], usize); MAX_LEVELS + 1],
    len: usize,
}

impl Ancestors {
    fn of(g: &IrregularGrid, c: &IrrCell) -> Ancestors {
        let t = [0, 1, 2].map(|a| c.lo[a] >> g.shift[a]);
        let mut e = g.vmap[g.top_index(t)];
        let mut node_lo = [0, 1, 2].map(|a| t[a] << g.shift[a]);
        let mut rem = g.shift;
        let mut nodes = [(e, node_lo, rem, 0); MAX_LEVELS + 1];
        let mut level = 0;
        while e & NODE != 0 {
            let mask = g.levels[level];
            let mut idx = e & !NODE;
            let mut stride = 1;
            for a in 0..3 {
                if mask[a] {
                    rem[a] -= 1;
                    let bit = (c.lo[a] >> rem[a]) & 1;
                    node_lo[a] += bit << rem[a];
                    idx += bit * stride;
                    stride *= 2;
                }
            }
            e = g.vmap[idx as usize];
            level += 1;
            nodes[level] = (e, node_lo, rem, level);
        }
        Ancestors {
            nodes,
            len: level + 1,
        }
    }

    /// [`IrregularGrid::box_is_empty_with`], starting at the deepest ancestor holding
    /// `lo .. hi`.
    fn box_is_empty(&self, g: &IrregularGrid, occ: &Occupancy, lo: [u32; 3], hi: [u32; 3]) -> bool {
        let holds = |n: &(u32, [u32; 3], [u32; 3], usize)| {
            (0..3).all(|a| n.1[a] <= lo[a] && hi[a] <= n.1[a] + (1 << n.2[a]))
        };
        // The nodes only: the cell's own entry never holds a box its growth asks about.
        match self.nodes[..self.len - 1].iter().rev().find(|n| holds(n)) {
            Some(&(e, node_lo, rem, level)) => {
                Query { g, occ, lo, hi }.node_is_empty(e, node_lo, rem, level)
            }
            None => g.box_is_empty_with(occ, lo, hi),
        }
    }
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

#[cfg(test)]
#[path = "irregular_grow_tests.rs"]
mod tests;
