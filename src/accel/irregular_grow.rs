//! The irregular grid's exit boxes (see [`super::irregular`]): the emptiness query over
//! the voxel map, the summed-volume table that answers it for whole top cells, and the
//! growth of an empty cell's box face by face. Split from the build by job; imports the
//! structure, never the build (`irregular_build.rs` imports this).

use super::irregular::{IrrCell, IrregularGrid, NODE};

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
        let whole = (0..3).all(|a| flo[a] < fhi[a]);
        if whole && occ.count(flo, fhi) > 0 {
            return false;
        }
        let inside = |v: u32, a: usize| whole && flo[a] <= v && v < fhi[a];
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
                    let e = self.vmap[self.top_index([x, y, z])];
                    let node_lo = [x << self.shift[0], y << self.shift[1], z << self.shift[2]];
                    if !self.node_is_empty(e, node_lo, self.shift, 0, lo, hi) {
                        return false;
                    }
                    x += 1;
                }
            }
        }
        true
    }

    /// [`IrregularGrid::box_is_empty`] within one node at `level` covering `1 << rem[a]`
    /// virtual cells from `node_lo`.
    pub(super) fn node_is_empty(
        &self,
        e: u32,
        node_lo: [u32; 3],
        rem: [u32; 3],
        level: usize,
        lo: [u32; 3],
        hi: [u32; 3],
    ) -> bool {
        if e & NODE == 0 {
            return self.cells[e as usize].range.count == 0;
        }
        // A node was split for its triangles, so one the box covers whole is not empty
        // (conservatively: its triangles may only touch its padding; the box then just
        // does not grow there). Only nodes the box cuts are descended.
        if (0..3).all(|a| lo[a] <= node_lo[a] && node_lo[a] + (1 << rem[a]) <= hi[a]) {
            return false;
        }
        let mask = self.levels[level];
        let crem = [0, 1, 2].map(|a| rem[a] - mask[a] as u32);
        let n = mask.map(|m| if m { 2u32 } else { 1 });
        for bz in 0..n[2] {
            for by in 0..n[1] {
                for bx in 0..n[0] {
                    let b = [bx, by, bz];
                    let clo = [0, 1, 2].map(|a| node_lo[a] + (b[a] << crem[a]));
                    let overlaps =
                        (0..3).all(|a| clo[a] < hi[a] && lo[a] < clo[a] + (1 << crem[a]));
                    if !overlaps {
                        continue;
                    }
                    let idx = (e & !NODE) + bx + n[0] * (by + n[1] * bz);
                    let child = self.vmap[idx as usize];
                    if !self.node_is_empty(child, clo, crem, level + 1, lo, hi) {
                        return false;
                    }
                }
            }
        }
        true
    }
}

/// Summed-volume table of the top cells that are not empty (a node, or a cell with
/// triangles): how many lie in a block of top cells, in constant time.
pub(super) struct Occupancy {
    /// `(res + 1)^3` prefix sums, x fastest, zero on the low faces.
    sum: Vec<u32>,
    /// Top resolution plus one.
    dim: [usize; 3],
}

impl Occupancy {
    pub(super) fn new(g: &IrregularGrid) -> Occupancy {
        let dim = g.top_res.map(|r| r as usize + 1);
        let mut sum = vec![0u32; dim[0] * dim[1] * dim[2]];
        let at = |x: usize, y: usize, z: usize| x + dim[0] * (y + dim[1] * z);
        for z in 1..dim[2] {
            for y in 1..dim[1] {
                for x in 1..dim[0] {
                    let e = g.vmap[g.top_index([x as u32 - 1, y as u32 - 1, z as u32 - 1])];
                    let full = (e & NODE != 0 || g.cells[e as usize].range.count > 0) as u32;
                    sum[at(x, y, z)] =
                        full + sum[at(x - 1, y, z)] + sum[at(x, y - 1, z)] + sum[at(x, y, z - 1)]
                            - sum[at(x - 1, y - 1, z)]
                            - sum[at(x - 1, y, z - 1)]
                            - sum[at(x, y - 1, z - 1)]
                            + sum[at(x - 1, y - 1, z - 1)];
                }
            }
        }
        Occupancy { sum, dim }
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

/// Grows the exit box of cell `c` over empty neighbours: each face in turn moves out by a
/// step (the cell's own size at first, doubled after each success and halved after each
/// failure down to that size) while the slab it sweeps holds no triangle.
pub(super) fn grow(g: &IrregularGrid, occ: &Occupancy, c: &IrrCell) -> ([u32; 3], [u32; 3]) {
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
                if g.box_is_empty_with(occ, blo, bhi) {
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
