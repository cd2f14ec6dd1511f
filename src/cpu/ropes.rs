//! Neighbour links ("ropes", after Havran's kd-tree ropes) for the irregular grid's
//! vectorised walk (`cpu/simd_walk.rs`): for each cell and each face of its exit box, the
//! one cell beyond that face when a single cell covers the whole layer of virtual cells
//! just past it, kept with what a step reads of the cell (exit box, triangle range) in one
//! 64-byte record, so that a step whose face has a rope costs one cache line instead of
//! the cell record, the voxel map's levels and the next record. Not a GLSL twin and not
//! part of the structure: the CPU builds the table per render, and the walk takes the same
//! cells as without it, bit for bit.
//!
//! Why it is exact: the walk's next virtual cell after leaving through a face lies in that
//! layer (the exit axis's first virtual cell past the face, the lateral axes clamped into
//! the exit box's range; [`IrregularWalker::next_cell`](super::traverse_irregular::IrregularWalker::next_cell)),
//! so when one cell's own box holds the whole layer the voxel-map lookup can only answer
//! that cell, wherever in the layer the ray crosses. The rope then spares the lateral cells'
//! crossings and the lookup's dependent loads (one per level of the voxel map).

use rayon::prelude::*;

use super::traverse_irregular::ExitBox;
use crate::accel::irregular::IrregularGrid;
use crate::accel::CellRange;

/// A face with no rope: several cells lie beyond it, or the grid ends there.
pub const NO_ROPE: u32 = u32::MAX;

/// The face a ray leaves through: `2 * axis`, plus one when it moves up that axis.
#[inline(always)]
pub fn face(axis: usize, up: bool) -> usize {
    2 * axis + up as usize
}

/// What the vectorised walk reads of one cell, in one cache line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C, align(64))]
pub struct RopedCell {
    /// Lower corner of the exit box (virtual coordinates).
    pub exit_lo: [u32; 3],
    /// Upper corner (exclusive) of the exit box.
    pub exit_hi: [u32; 3],
    /// The cell's slice of the triangle references.
    pub range: CellRange,
    /// The cell beyond each face of the exit box, indexed by [`face`]; [`NO_ROPE`] where
    /// several cells lie beyond it or the grid ends there.
    pub ropes: [u32; 6],
}

impl ExitBox for RopedCell {
    #[inline(always)]
    fn exit_lo(&self) -> [u32; 3] {
        self.exit_lo
    }
    #[inline(always)]
    fn exit_hi(&self) -> [u32; 3] {
        self.exit_hi
    }
}

/// Every cell of `g` as a [`RopedCell`], in cell order.
pub fn build(g: &IrregularGrid) -> Vec<RopedCell> {
    g.cells
        .par_iter()
        .map(|c| {
            let mut ropes = [NO_ROPE; 6];
            for a in 0..3 {
                for up in [false, true] {
                    let layer = if up {
                        if c.exit_hi[a] >= g.res[a] {
                            continue;
                        }
                        c.exit_hi[a]
                    } else {
                        if c.exit_lo[a] == 0 {
                            continue;
                        }
                        c.exit_lo[a] - 1
                    };
                    let mut k = c.exit_lo;
                    k[a] = layer;
                    let id = g.lookup(k);
                    let n = &g.cells[id as usize];
                    if (0..3)
                        .all(|b| b == a || (n.lo[b] <= c.exit_lo[b] && c.exit_hi[b] <= n.hi[b]))
                    {
                        ropes[face(a, up)] = id;
                    }
                }
            }
            RopedCell {
                exit_lo: c.exit_lo,
                exit_hi: c.exit_hi,
                range: c.range,
                ropes,
            }
        })
        .collect()
}

#[cfg(test)]
#[path = "ropes_tests.rs"]
mod tests;
