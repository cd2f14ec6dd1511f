//! Irregular grid after Perard-Gayot, Kalojanov and Slusallek ("GPU Ray Tracing using
//! Irregular Grids", Eurographics 2017): a uniform top grid whose cells are subdivided
//! adaptively (an octree-like voxel map below each top cell, to a common virtual
//! resolution), every leaf cell then given an *exit box* grown over the neighbours that
//! hold no triangle but its own (none, for an empty cell).
//! A ray walks it one cell at a time: it leaves the current cell through the exit box, the
//! cell holding the exit point is looked up in the voxel map, and so on. Empty space costs
//! one step per exit box, however many cells it spans, so a mesh on a huge floor costs
//! about what the mesh alone costs (the case a uniform or a two-level grid cannot fit);
//! and a large triangle costs one step where its cells' own boxes would cost one per cell
//! (a ray grazing a floor).
//!
//! Why this and not the two-level grid of Kalojanov et al. 2011 (removed, recoverable with
//! `git show 5d36e05:src/accel/two_level.rs`): both were built and measured here
//! (`docs/performance.md`, "Tried and not kept"). The two-level grid meets the bunny target, but a mesh on a floor
//! 100x its size puts the whole mesh in one top cell whose uniform sub-grid is spread over
//! the floor piece: 86.7 triangle tests per ray against 5.8 for `scenes/bunny.toml`. The
//! voxel map subdivides only where the triangles are, and the exit boxes skip the floor's
//! empty space. It also keeps the GPU state machine of the uniform grid: one cell index
//! and a list cursor per ray, no nested DDA state.
//!
//! Deviation from the paper: cells are the voxel map's leaves, not merged further (the
//! paper merges neighbouring cells by a cost estimate); the expansion gives most of the
//! merge's gain in empty space, which is where the rays spend their steps here (figures in
//! `docs/performance.md`).
//!
//! # Geometry, all in integer *virtual* coordinates
//! - The top grid is a [`Grid`](super::Grid)'s frame: padded scene box `min..max`, `top_res` cells per
//!   axis chosen by [`Grid::auto_resolution`](super::Grid::auto_resolution) with the density `top_density`.
//! - Below it, a global schedule of `levels` split masks: level `l` halves the axes
//!   `levels[l]` marks, chosen so cells get closer to cubes (an axis is split when it is
//!   more than half the longest). Axis `a` is split `shift[a]` times in all, so the virtual
//!   grid has `res[a] = top_res[a] << shift[a]` cells of size `cell_size = (max - min) /
//!   res` (f32), and virtual boundary `k` sits at `min + k * cell_size` (the expression
//!   the uniform DDA evaluates, in the traversal's precision).
//! - A voxel-map node at level `l` covers `1 << rem[a]` virtual cells per axis, `rem` being
//!   `shift` minus the splits of the levels above it. A node with more than `leaf_max`
//!   triangles is split (while levels remain and splitting separates something); its
//!   children sit in one block of `2^(split axes)` entries, child `(bx, by, bz)` at
//!   `bx + nx * (by + ny * bz)` with `n = 2` on a split axis and 1 otherwise.
//!
//! # Layout, flat so that it maps onto float textures
//! - `vmap[0 .. top cells]`: one entry per top cell, x fastest; then the child blocks, in
//!   depth-first order. An entry is a cell id, or [`NODE`] plus the index of the node's child
//!   block (in GLSL: `id >= 0`, or `-(block + 1)`).
//! - `cells[id]`: the cell's own box `lo .. hi` and its exit box `exit_lo .. exit_hi`
//!   (virtual coordinates, upper bound exclusive) and its range of `tri_indices`, cells in
//!   depth-first order. Empty top cells and empty voxel-map leaves are cells too.
//! - `tri_indices`: triangles, cell after cell, ascending within each cell.
//!
//! Binning is exact ([`super::tribox::tri_box_overlap`]) against boxes grown as [`Grid`](super::Grid)
//! grows them (`binning::Frame`), node after node, so a triangle on a cell face is in the cells on
//! both sides. An exit box grows only over cells whose padded boxes no triangle but the
//! cell's own touches, so any hit inside the exit box is a hit on one of the cell's own
//! triangles, which a ray in the cell tests.
//!
//! The build is parallel (triangles for the top level, top cells for the voxel map, cells
//! for the expansion) and deterministic: every parallel result is collected in index order,
//! so the output does not depend on the thread count. Cells and voxel-map entries are each
//! limited to 2^31 (an entry holds a cell id or a child block beside [`NODE`]), references
//! to 2^32 (`u32` offsets); what the GPU can index is its layout's (`gpu::layout`).

use std::fmt;

use glam::{DVec3, Vec3};

use super::grid::CellRange;

/// Default `top_density`: top cells per triangle. Measured with `leaf_max` 8 on 256x256
/// primary rays (`measure_bunny` in `cpu/traverse_irregular_tests.rs`): `scenes/bunny.toml`
/// 11.5 tests and 11.0 cells per ray at 0.125 (16.4 / 14.2 at 1/32, 9.4 / 9.2 at 0.5 for
/// twice the build time).
pub const DEFAULT_TOP_DENSITY: f32 = 0.125;
/// Default `leaf_max`: a voxel-map node with more triangles than this may be split (when
/// the cost estimate says so). 2 and 4 save 2 to 3 tests per ray on the bunny for five
/// times the cells (about 450 bytes per triangle against 94).
pub const DEFAULT_LEAF_MAX: u32 = 8;
/// Most split levels below the top grid.
pub const MAX_LEVELS: usize = 20;
/// Largest virtual resolution per axis: virtual coordinates and their sums stay exact in
/// f32.
pub const MAX_VIRTUAL_AXIS: u32 = 1 << 22;
/// Largest number of cells: an id a voxel-map entry holds beside the [`NODE`] flag.
pub const MAX_CELLS: usize = (NODE - 1) as usize;
/// Largest number of voxel-map entries: a child block an entry holds beside [`NODE`].
pub const MAX_ENTRIES: usize = (NODE - 1) as usize;
/// Largest number of (cell, triangle) references and of triangles: `u32` offsets and
/// indices.
pub const MAX_REFERENCES: usize = u32::MAX as usize;
/// Flag of a [`IrregularGrid::vmap`] entry that points to a child block.
pub const NODE: u32 = 1 << 31;
/// Build parameters of an [`IrregularGrid`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IrregularConfig {
    /// Top cells per triangle.
    pub top_density: f32,
    /// Largest triangle count of a voxel-map leaf that could still be split.
    pub leaf_max: u32,
}

impl Default for IrregularConfig {
    fn default() -> Self {
        IrregularConfig {
            top_density: DEFAULT_TOP_DENSITY,
            leaf_max: DEFAULT_LEAF_MAX,
        }
    }
}

/// One cell: its own box, its exit box and its triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IrrCell {
    /// Lower corner of the cell's own box (virtual coordinates).
    pub lo: [u32; 3],
    /// Upper corner (exclusive) of the cell's own box.
    pub hi: [u32; 3],
    /// Lower corner of the exit box: the own box grown over neighbours that hold no
    /// triangle but the cell's own.
    pub exit_lo: [u32; 3],
    /// Upper corner (exclusive) of the exit box.
    pub exit_hi: [u32; 3],
    /// The cell's slice of [`IrregularGrid::tri_indices`].
    pub range: CellRange,
}

/// Size and occupancy figures of a built irregular grid.
#[derive(Clone, Debug, serde::Serialize)]
pub struct IrregularStats {
    /// Wall-clock build time in milliseconds.
    pub build_ms: f64,
    /// Of which the exit-box growth (its occupancy tables included).
    pub expand_ms: f64,
    /// The build's wall-clock time phase by phase.
    pub phases: IrregularPhases,
    /// Memory of the tables: `vmap * 4 + cells * 32 + references * 4` (as the GPU stores
    /// them: one float per entry, two RGBA texels per cell).
    pub bytes: usize,
    /// `bytes / triangles` (0 for an empty scene).
    pub bytes_per_triangle: f64,
    /// Top cells.
    pub top_cells: usize,
    /// Voxel-map entries (top cells and child slots).
    pub vmap_entries: usize,
    /// Split levels below the top grid.
    pub levels: usize,
    /// Cells (voxel-map leaves).
    pub cells: usize,
    /// Cells with no triangle.
    pub empty_cells: usize,
    /// (cell, triangle) references.
    pub references: usize,
    /// Mean references per non-empty cell (0 when there is none).
    pub mean_per_nonempty: f64,
    /// Largest reference count of any cell.
    pub max_per_cell: u32,
    /// Geometric mean of exit-box volume over own-box volume, over all cells.
    pub mean_growth: f64,
}

impl fmt::Display for IrregularStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} top cells, {} levels, {} cells ({:.1}% empty, exit boxes {:.1}x own), {} refs \
             (mean {:.2}, max {} per non-empty cell), {:.2} MiB ({:.1} B/triangle), built in \
             {:.1} ms ({:.1} ms growing exit boxes; {})",
            self.top_cells,
            self.levels,
            self.cells,
            if self.cells == 0 {
                0.0
            } else {
                100.0 * self.empty_cells as f64 / self.cells as f64
            },
            self.mean_growth,
            self.references,
            self.mean_per_nonempty,
            self.max_per_cell,
            self.bytes as f64 / (1024.0 * 1024.0),
            self.bytes_per_triangle,
            self.build_ms,
            self.expand_ms,
            self.phases
        )
    }
}

/// Wall-clock milliseconds of the irregular build's phases, in build order; they add up to
/// about [`IrregularStats::build_ms`]. Kept so that a run on many cores shows which phase
/// does not scale.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct IrregularPhases {
    /// Checks, bounds and the split schedule.
    pub setup_ms: f64,
    /// The triangles' vertices gathered, and their bounds.
    pub convert_ms: f64,
    /// Every triangle binned to the top cells it overlaps.
    pub top_bin_ms: f64,
    /// The (top cell, triangle) pairs sorted by cell.
    pub sort_ms: f64,
    /// The voxel map below every top cell.
    pub voxel_map_ms: f64,
    /// The runs of subtrees (built in the final layout) assembled into the voxel map, cell
    /// and reference tables (unused levels dropped from the cells' coordinates on the way).
    pub flatten_ms: f64,
    /// The occupancy tables the exit-box growth queries.
    pub occupancy_ms: f64,
    /// The exit boxes grown.
    pub grow_ms: f64,
    /// The statistics.
    pub finish_ms: f64,
}

impl fmt::Display for IrregularPhases {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "phases ms: setup {:.1}, convert {:.1}, top bins {:.1}, sort {:.1}, voxel map {:.1}, \
             flatten {:.1}, occupancy {:.1}, growth {:.1}, finish {:.1}",
            self.setup_ms,
            self.convert_ms,
            self.top_bin_ms,
            self.sort_ms,
            self.voxel_map_ms,
            self.flatten_ms,
            self.occupancy_ms,
            self.grow_ms,
            self.finish_ms
        )
    }
}

/// An irregular grid over a scene's triangles (see the module docs for the layout).
#[derive(Clone, Debug)]
pub struct IrregularGrid {
    /// Lower corner: the scene bounds padded as [`Grid`](super::Grid) pads them.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
    /// Top cells per axis.
    pub top_res: [u32; 3],
    /// Split masks of the levels below the top grid, top-down.
    pub levels: Vec<[bool; 3]>,
    /// Splits per axis over all levels: a top cell spans `1 << shift[a]` virtual cells.
    pub shift: [u32; 3],
    /// Virtual cells per axis, `top_res[a] << shift[a]`.
    pub res: [u32; 3],
    /// Virtual cell size, `(max - min) / res` in f32.
    pub cell_size: Vec3,
    /// Voxel map: top entries, then child blocks (see the module docs).
    pub vmap: Vec<u32>,
    /// Cells in depth-first order.
    pub cells: Vec<IrrCell>,
    /// Triangle indices, cell after cell, ascending within each cell.
    pub tri_indices: Vec<u32>,
    /// Build statistics.
    pub stats: IrregularStats,
}

impl IrregularGrid {
    /// Index of top cell `t` in [`IrregularGrid::vmap`].
    #[inline]
    pub fn top_index(&self, t: [u32; 3]) -> usize {
        t[0] as usize
            + self.top_res[0] as usize * (t[1] as usize + self.top_res[1] as usize * t[2] as usize)
    }

    /// The cell holding virtual cell `k` (each axis below [`IrregularGrid::res`]).
    #[inline]
    pub fn lookup(&self, k: [u32; 3]) -> u32 {
        let mut rem = self.shift;
        let mut e = self.vmap[self.top_index([0, 1, 2].map(|a| k[a] >> rem[a]))];
        for mask in &self.levels {
            if e & NODE == 0 {
                return e;
            }
            let mut idx = e & !NODE;
            let mut stride = 1;
            for a in 0..3 {
                if mask[a] {
                    rem[a] -= 1;
                    idx += ((k[a] >> rem[a]) & 1) * stride;
                    stride *= 2;
                }
            }
            e = self.vmap[idx as usize];
        }
        debug_assert_eq!(e & NODE, 0, "voxel map deeper than its levels");
        e
    }

    /// The triangles of cell `id`, ascending.
    pub fn cell_triangles(&self, id: u32) -> &[u32] {
        let r = self.cells[id as usize].range;
        &self.tri_indices[r.offset as usize..(r.offset + r.count) as usize]
    }

    /// Corners of the virtual box `lo .. hi` in f64 (before any padding).
    pub fn world_box(&self, lo: [u32; 3], hi: [u32; 3]) -> (DVec3, DVec3) {
        let min = self.min.as_dvec3();
        let cs = self.cell_size.as_dvec3();
        let v = |k: [u32; 3]| DVec3::new(k[0] as f64, k[1] as f64, k[2] as f64);
        (min + v(lo) * cs, min + v(hi) * cs)
    }
}

#[cfg(test)]
#[path = "irregular_grid_tests.rs"]
mod tests;
