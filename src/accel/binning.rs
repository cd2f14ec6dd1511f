//! Conservative binning of triangles into the cells of a uniform frame, and the stable
//! counting sort that turns (cell, triangle) pairs into per-cell lists: shared by the
//! two-level and the irregular grid builds, which bin level after level into frames of
//! their own.

use crate::numeric::Floor;
use glam::DVec3;

use super::grid::CellRange;
use super::tribox::tri_box_overlap;

/// Growth of each cell's half-size, relative to the cell size (as in [`super::Grid`]).
const CELL_PAD_FRACTION: f64 = 1e-5;
/// f32 ulps of the coordinate magnitude added to the padding (as in [`super::Grid`]).
const PAD_ULPS: f64 = 4.0;

/// `PAD_ULPS` f32 ulps of a coordinate of magnitude `mag`.
fn ulps(mag: f64) -> f64 {
    PAD_ULPS * mag * f32::EPSILON as f64
}

/// A uniform grid frame to bin into: cell `j` spans `lo + j * cs .. lo + (j + 1) * cs`,
/// except that the first and last cell of each axis reach out to `outer_lo`/`outer_hi`.
pub(crate) struct Frame {
    lo: DVec3,
    cs: DVec3,
    res: [u32; 3],
    outer_lo: DVec3,
    outer_hi: DVec3,
    pad: DVec3,
}

impl Frame {
    /// A frame whose padding is [`Grid`]'s: relative to the cell size plus ulps of the
    /// largest coordinate.
    pub(crate) fn new(
        lo: DVec3,
        cs: DVec3,
        res: [u32; 3],
        outer_lo: DVec3,
        outer_hi: DVec3,
    ) -> Frame {
        let mag = outer_lo.abs().max(outer_hi.abs()).max(lo.abs());
        Frame {
            lo,
            cs,
            res,
            outer_lo,
            outer_hi,
            pad: CELL_PAD_FRACTION * cs + DVec3::new(ulps(mag.x), ulps(mag.y), ulps(mag.z)),
        }
    }

    /// Lower and upper boundary of cell `j` on `axis`.
    #[inline]
    fn span(&self, axis: usize, j: u32) -> (f64, f64) {
        let a = if j == 0 {
            self.outer_lo[axis].min(self.lo[axis])
        } else {
            self.lo[axis] + j as f64 * self.cs[axis]
        };
        let b = if j + 1 == self.res[axis] {
            self.outer_hi[axis].max(self.lo[axis] + self.res[axis] as f64 * self.cs[axis])
        } else {
            self.lo[axis] + (j + 1) as f64 * self.cs[axis]
        };
        (a, b)
    }

    /// Appends the index (x fastest) of every cell the triangle overlaps, ascending.
    pub(crate) fn bin(&self, tri: [DVec3; 3], out: &mut Vec<u32>) {
        let bb_lo = tri[0].min(tri[1]).min(tri[2]) - self.pad;
        let bb_hi = tri[0].max(tri[1]).max(tri[2]) + self.pad;
        // `as i64` saturates; the clamp below absorbs anything outside the frame.
        let raw = |p: f64, i: usize| ((p - self.lo[i]) / self.cs[i]).floor_exact() as i64;
        let raw_lo = [raw(bb_lo.x, 0), raw(bb_lo.y, 1), raw(bb_lo.z, 2)];
        let raw_hi = [raw(bb_hi.x, 0), raw(bb_hi.y, 1), raw(bb_hi.z, 2)];
        // A padded bounding box inside one cell of the frame: the triangle lies in that
        // cell's box with the padding to spare on every side, where the exact test can only
        // say yes (every one of its 13 axes projects the triangle inside the box's
        // projection by about the padding, 1e-5 of a cell, against rounding errors of
        // 1e-16), so it is skipped. Most triangles of the finer levels are such.
        if raw_lo == raw_hi && (0..3).all(|i| (0..self.res[i] as i64).contains(&raw_lo[i])) {
            let [x, y, z] = raw_lo.map(|c| c as usize);
            out.push((x + self.res[0] as usize * (y + self.res[1] as usize * z)) as u32);
            return;
        }
        let clamp = |c: i64, i: usize| c.clamp(0, self.res[i] as i64 - 1) as u32;
        let lo = [0, 1, 2].map(|i| clamp(raw_lo[i], i));
        let hi = [0, 1, 2].map(|i| clamp(raw_hi[i], i));
        for z in lo[2]..=hi[2] {
            let sz = self.span(2, z);
            for y in lo[1]..=hi[1] {
                let sy = self.span(1, y);
                let row = self.res[0] as usize * (y as usize + self.res[1] as usize * z as usize);
                for x in lo[0]..=hi[0] {
                    let sx = self.span(0, x);
                    let a = DVec3::new(sx.0, sy.0, sz.0);
                    let b = DVec3::new(sx.1, sy.1, sz.1);
                    if tri_box_overlap(0.5 * (a + b), 0.5 * (b - a) + self.pad, tri) {
                        out.push((row + x as usize) as u32);
                    }
                }
            }
        }
    }
}

/// Stable counting sort of `(cell, triangle)` pairs given triangle after triangle in
/// ascending order: per-cell ranges and the list, each cell's triangles ascending.
pub(crate) fn counting_sort(
    n_cells: usize,
    pairs: impl Iterator<Item = (u32, u32)> + Clone,
) -> (Vec<CellRange>, Vec<u32>) {
    let mut cells = vec![CellRange::default(); n_cells];
    let mut n = 0usize;
    for (c, _) in pairs.clone() {
        cells[c as usize].count += 1;
        n += 1;
    }
    let mut offset = 0u32;
    for c in &mut cells {
        c.offset = offset;
        offset += c.count;
    }
    let mut cursor: Vec<u32> = cells.iter().map(|c| c.offset).collect();
    let mut list = vec![0u32; n];
    for (c, t) in pairs {
        let slot = &mut cursor[c as usize];
        list[*slot as usize] = t;
        *slot += 1;
    }
    (cells, list)
}
