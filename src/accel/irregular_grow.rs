//! The irregular grid's exit boxes (see [`super::irregular`]): the growth of a cell's box
//! face by face, over empty cells, or for a cell with triangles over cells holding none but
//! its own, asking the queries of `irregular_occupancy.rs`. Split from the build by job;
//! imports the structure, never the build (`irregular_build.rs` imports this).

use super::axes;
use super::grid::CellRange;
use super::irregular::{IrrCell, IrregularGrid, MAX_LEVELS};
use super::irregular_occupancy::{Occupancy, Query, Tight, Within};

/// Rounds of exit-box growth (each round tries all six faces once).
const GROW_ROUNDS: usize = 4;

/// What a slab must hold for an exit box to grow over it.
#[derive(Clone, Copy)]
pub(super) enum Rule<'a> {
    /// No triangle: the rule of a cell without triangles.
    Empty,
    /// No triangle but the cell's own (`own`, ascending; the cells' lists through
    /// `ranges`): the rule of a cell with triangles. A ray in the cell tests them all, so
    /// any hit inside the grown box is found there, as it is in the own box; a triangle
    /// as large as a floor then costs one cell where it costs one per cell it crosses.
    Within {
        ranges: &'a [CellRange],
        own: &'a [u32],
    },
}

/// Grows the exit box of cell `c` over neighbours that `rule` allows: each face in turn
/// moves out by a step (the cell's own size at first, doubled after each success and
/// halved after each failure down to that size) while the slab it sweeps holds no
/// triangle (with [`Rule::Within`], none but the cell's own). `recent` holds the exit
/// boxes of empty cells grown just before, whose insides it knows to be empty; with the
/// faces' walls these answer some slabs without a query, the same answers as the
/// queries'.
pub(super) fn grow(
    g: &IrregularGrid,
    occ: &Occupancy,
    c: &IrrCell,
    recent: &Recent,
    rule: Rule,
) -> ([u32; 3], [u32; 3]) {
    let path = Ancestors::of(g, occ, c);
    let (mut lo, mut hi) = (c.lo, c.hi);
    let own = axes(|a| c.hi[a] - c.lo[a]);
    // Per face (axis, upward): current step, or 0 once the face is done.
    let mut step = [[own[0]; 2], [own[1]; 2], [own[2]; 2]];
    // Per face: how far its last slab found not empty reached, as a distance from the
    // grid's side behind the face (`u32::MAX`: none yet). Where every node holds a cell
    // with triangles, that slab overlaps one, outside what the face grew over since (found
    // empty, with a cross-section that only grew), so a later slab of the face reaching as
    // far overlaps it too: not empty, known without asking (the same answer, so the same
    // box): the doubled step after a retry, and the first halving after it.
    let mut wall = [[u32::MAX; 2]; 3];
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
                // Built by selection, not by a store at index `a` into a copy: read back
                // whole straight after such a store, the box waited on the store buffer.
                let blo = axes(|k| if k == a { slo } else { lo[k] });
                let bhi = axes(|k| if k == a { shi } else { hi[k] });
                any = true;
                let reach = if up { shi } else { g.res[a] - slo };
                let blocked = reach >= wall[a][up as usize];
                let allowed = |blo, bhi| match rule {
                    Rule::Empty => path.box_is_empty(g, occ, blo, bhi),
                    Rule::Within { ranges, own } => path.box_within(g, occ, ranges, blo, bhi, own),
                };
                if !blocked && (recent.holds(blo, bhi) || allowed(blo, bhi)) {
                    if up {
                        hi[a] = shi;
                    } else {
                        lo[a] = slo;
                    }
                    step[a][up as usize] = s.saturating_mul(2);
                } else {
                    if recent.on {
                        wall[a][up as usize] = wall[a][up as usize].min(reach);
                    }
                    step[a][up as usize] = if s > own[a] { (s / 2).max(own[a]) } else { 0 };
                }
            }
        }
        if !any {
            break;
        }
    }
    (lo, hi)
}

/// The exit boxes of the two cells grown last (in map order, so mostly neighbours): where
/// every node holds a cell with triangles ([`Occupancy`]), an exit box overlaps no such
/// cell (it is its cell and slabs found empty), so neither does a box inside it, which is
/// therefore empty: the answer the query would give, without it (the same exit boxes). A
/// growth next to an empty sibling asks many such boxes. The bunny, one thread: 30% of its
/// 902 k queries lie in the last exit box, 38% in one of the last four; growth 55.3 ms
/// without, 50.2 / 48.8 / 49.9 / 51.3 ms keeping one to four (the check runs before every
/// query).
pub(super) struct Recent {
    boxes: [([u32; 3], [u32; 3]); RECENT],
    next: usize,
    /// Every node holds a cell with triangles: answers from what is known are exact (these
    /// boxes, and the faces' walls in [`grow`]).
    on: bool,
}

/// Exit boxes a [`Recent`] keeps.
const RECENT: usize = 2;

impl Recent {
    /// None yet; answering only where `occ` allows it.
    pub(super) fn new(occ: &Occupancy) -> Recent {
        Recent {
            boxes: [([u32::MAX; 3], [0; 3]); RECENT],
            next: 0,
            on: occ.full_below_every_node,
        }
    }

    /// Keeps the exit box just grown.
    pub(super) fn push(&mut self, lo: [u32; 3], hi: [u32; 3]) {
        if self.on {
            self.boxes[self.next] = (lo, hi);
            self.next = (self.next + 1) % RECENT;
        }
    }

    /// Whether a box kept holds `lo .. hi` (all comparisons, one branch).
    #[inline]
    fn holds(&self, lo: [u32; 3], hi: [u32; 3]) -> bool {
        let mut any = false;
        for (elo, ehi) in &self.boxes {
            let mut inside = true;
            for a in 0..3 {
                inside &= (elo[a] <= lo[a]) & (hi[a] <= ehi[a]);
            }
            any |= inside;
        }
        any
    }
}

/// The voxel-map nodes holding one cell, top cell first: an emptiness query about a box
/// near the cell starts at the deepest of them that holds the whole box instead of at the
/// top grid. The answer is the same (a node holding the box is the only child the query
/// from the top would descend into at every level above it, and it is covered whole only
/// when it equals the box, which both ask first); most slabs a cell's growth sweeps lie in
/// a node a few levels up, so the query skips the ten or more levels above it.
struct Ancestors {
    /// Node numbers, top cell first (the node at level `l` is the aligned block of
    /// [`Level::rem`] bits around the cell).
    nums: [u32; MAX_LEVELS],
    len: usize,
    /// The cell's lower corner.
    cell: [u32; 3],
}

impl Ancestors {
    fn of(g: &IrregularGrid, occ: &Occupancy, c: &IrrCell) -> Ancestors {
        let mut anc = Ancestors {
            nums: [0; MAX_LEVELS],
            len: 0,
            cell: c.lo,
        };
        let s = occ.top[g.top_index(axes(|a| c.lo[a] >> g.shift[a]))];
        if s < 2 {
            return anc;
        }
        let mut num = s - 2;
        loop {
            anc.nums[anc.len] = num;
            let lv = &occ.level[anc.len];
            let i = lv.child_of(c.lo);
            let n = &occ.nodes[num as usize];
            anc.len += 1;
            if n.kids & (1 << i) == 0 {
                return anc;
            }
            num = n.child_node(i);
        }
    }

    /// The level of the deepest ancestor holding `lo .. hi`, or `None` when no node does
    /// (a top cell, or top cells, hold it).
    fn deepest_holding(&self, occ: &Occupancy, lo: [u32; 3], hi: [u32; 3]) -> Option<usize> {
        // The node at level `l` holds the box when the box's corners agree with the cell's
        // above its `rem` bits on every axis (nodes are aligned blocks of `1 << rem`).
        let mut l = u8::MAX;
        for a in 0..3 {
            let differ = (lo[a] ^ self.cell[a]) | ((hi[a] - 1) ^ self.cell[a]);
            l = l.min(occ.holding[a][(u32::BITS - differ.leading_zeros()) as usize]);
        }
        (self.len != 0 && l != 0).then(|| (l as usize).min(self.len) - 1)
    }

    /// [`IrregularGrid::box_is_empty_with`], starting at the deepest ancestor holding
    /// `lo .. hi`.
    fn box_is_empty(&self, g: &IrregularGrid, occ: &Occupancy, lo: [u32; 3], hi: [u32; 3]) -> bool {
        let Some(level) = self.deepest_holding(occ, lo, hi) else {
            return g.box_is_empty_with(occ, lo, hi);
        };
        let rem = occ.level[level].rem;
        let node_lo = axes(|a| self.cell[a] >> rem[a] << rem[a]);
        debug_assert!((0..3).all(|a| node_lo[a] <= lo[a] && hi[a] <= node_lo[a] + (1 << rem[a])));
        debug_assert!(
            level + 1 == self.len
                || (0..3).any(|a| {
                    let r = occ.level[level + 1].rem[a];
                    lo[a] >> r != self.cell[a] >> r || (hi[a] - 1) >> r != self.cell[a] >> r
                })
        );
        Query { occ, lo, hi }.node_is_empty(self.nums[level], node_lo, level)
    }
}

impl Ancestors {
    /// [`IrregularGrid::box_within_with`], starting at the deepest ancestor holding
    /// `lo .. hi` (the nodes a query from the top would descend into are the same).
    fn box_within(
        &self,
        g: &IrregularGrid,
        occ: &Occupancy,
        ranges: &[CellRange],
        lo: [u32; 3],
        hi: [u32; 3],
        own: &[u32],
    ) -> bool {
        let Some(level) = self.deepest_holding(occ, lo, hi) else {
            return g.box_within_with(occ, ranges, lo, hi, own);
        };
        let num = self.nums[level];
        if matches!(occ.tight_relation(num, lo, hi), Tight::Apart) {
            return true;
        }
        let rem = occ.level[level].rem;
        let node_lo = axes(|a| self.cell[a] >> rem[a] << rem[a]);
        Within {
            g,
            occ,
            ranges,
            lo,
            hi,
            own,
        }
        .node(num, node_lo, level)
    }
}

#[cfg(test)]
#[path = "irregular_grow_tests.rs"]
mod tests;
