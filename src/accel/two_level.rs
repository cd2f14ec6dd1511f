//! Two-level grid after Kalojanov, Stich and Slusallek ("Two-Level Grids for Ray Tracing
//! on GPUs", HPG 2011): a coarse top grid over the scene box, and in every non-empty top
//! cell a uniform sub-grid sized by the cell's own triangle count. Dense regions get fine
//! cells, empty space stays coarse.
//!
//! Two deviations, both measured on 256x256 primary rays in f32 (`measure_bunny` in
//! `cpu/traverse_two_level_tests.rs`; figures as triangle tests / cells per ray, lambda1
//! 0.25, lambda2 4):
//! - Each sub-grid spans not its whole top cell but the bounds of the cell's triangles
//!   clipped to the cell (padded as [`Grid`] pads the scene box), so its cells go where the
//!   triangles are: `scenes/bunny.toml` from 13.9 / 56.9 to 8.2 / 35.6 (uniform grid:
//!   326 / 66). The traversal pays one ray/box clip per non-empty top cell.
//! - The top grid gets at least [`MIN_TOP_AXIS`] cells per axis ([`top_resolution`]): the
//!   uniform rule gives a flat scene one cell in height, so a floor runs through every top
//!   cell of the mesh standing on it. `scenes/bunny.toml`: 5.8 / 35.9; the bunny on a 100x
//!   larger floor: 86.7 / 17.6 (one layer: 683 / 38; 32 layers: 27 / 20, but 5.2 / 44 on
//!   `bunny.toml`).
//!
//! What neither fixes: the floor's own top cells, 3 m wide next to a 15 cm bunny, still
//! hold the bunny's lowest triangles in sub-grids spread over the whole floor piece, so a
//! mesh on a huge floor costs more than alone (the case the irregular grid of Perard-Gayot
//! et al. 2017 addresses, starting from a two-level grid like this one).
//!
//! Geometry, all in f32 as the traversals compute it:
//! - The top grid is exactly a [`Grid`]'s: the same padded scene box `min..max`, cell size
//!   `cell_size = (max - min) / res`, top cell `i` on an axis starting at
//!   `min + i * cell_size`; its resolution is [`Grid::auto_resolution`] with the top
//!   density `lambda1`, or fixed ([`TwoLevelConfig::top_res`]).
//! - A non-empty top cell stores its sub-grid's corner `lo`, resolution `r` and cell size
//!   `sub` (`(hi - lo) / r` in f32); sub-cell `j` starts at `lo + j * sub` and the sub-grid
//!   box is `lo .. lo + r * sub`. The resolution is [`Grid::auto_resolution`] on the box's
//!   extent with the cell's triangle count and the leaf density `lambda2`, capped at
//!   [`MAX_SUB_AXIS`] per axis and about [`MAX_SUB_CELLS`] cells.
//!
//! Layout, flat so that it maps onto float textures:
//! - `top[x + res[0] * (y + res[1] * z)]`: the index of the top cell's [`SubGrid`], or
//!   [`EMPTY_TOP`] (one float each, four per RGBA texel; -1 for empty there). Empty space
//!   costs 4 bytes per top cell.
//! - `subgrids[i]`: one per non-empty top cell, in top-cell order: three RGBA texels
//!   `(leaf_base, r.x, r.y, r.z)`, `(lo, 0)`, `(sub, 0)` (two if `r` is packed into one
//!   float, `r.x + 129 * (r.y + 129 * r.z) < 2^24`).
//! - `leaves[leaf_base + x + r[0] * (y + r[1] * z)]`: a [`CellRange`] `(offset, count)`
//!   into the flat `tri_indices` (two per RGBA texel), the cells of one sub-grid
//!   contiguous, sub-grids in top-cell order.
//! - `tri_indices`: triangles, leaf after leaf, ascending within each leaf.
//!
//! Binning is exact ([`tri_box_overlap`](super::tribox::tri_box_overlap)) against cell boxes grown as [`Grid`] grows them
//! (a relative margin plus a few f32 ulps of the coordinates), so a triangle on a cell face
//! is listed on both sides; a triangle on a top cell's face is in the sub-grids on both
//! sides, each sub-grid box containing its part of the triangle with a margin.
//!
//! The build is parallel (triangles for the top level, top cells for the leaves) and
//! deterministic: every parallel result is collected in index order and merged by stable
//! counting sorts, so the output is identical for any thread count. Leaf cells and
//! references are each limited to 2^24, the integers an f32 texel holds exactly.

use std::fmt;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::binning::{counting_sort, Frame};
use super::grid::{check_vertices, padded_bounds, CellRange, Grid};
use crate::scene::Scene;
use crate::{Error, Result};

/// Default `lambda1`: top cells per triangle. Measured on `scenes/bunny.toml` (primary
/// rays, `measure_bunny` in `cpu/traverse_two_level_tests.rs`), tests plus cells per ray
/// stay within 37 to 46 for lambda1 from 1/16 to 1 and lambda2 from 2 to 8, cells growing
/// with lambda1 and tests falling with lambda2; 0.25 with 4 gives 5.8 tests and 35.9 cells
/// per ray in 67 bytes per triangle (uniform grid: 326, 66, 69).
pub const DEFAULT_TOP_DENSITY: f32 = 0.25;
/// Default `lambda2`: leaf cells per triangle of a top cell (see [`DEFAULT_TOP_DENSITY`]).
pub const DEFAULT_LEAF_DENSITY: f32 = 4.0;
/// Fewest top cells per axis [`top_resolution`] gives a scene of enough triangles.
pub const MIN_TOP_AXIS: u32 = 16;
/// Largest per-axis resolution of one sub-grid.
pub const MAX_SUB_AXIS: u32 = 128;
/// Largest cell count one sub-grid aims at (rounding may exceed it by a few percent).
pub const MAX_SUB_CELLS: u64 = 1 << 20;
/// Largest per-axis fixed top resolution ([`TwoLevelConfig::top_res`]).
pub const MAX_FIXED_TOP_AXIS: u32 = 4096;
/// Largest total number of leaf cells: leaf indices live in f32 texels.
pub const MAX_LEAF_CELLS: usize = 1 << 24;
/// Largest number of (leaf, triangle) references: list offsets live in f32 texels.
pub const MAX_REFERENCES: usize = 1 << 24;

/// Triangles per parallel work item of the top-level binning.
const CHUNK: usize = 2048;

/// Build parameters of a [`TwoLevelGrid`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoLevelConfig {
    /// `lambda1`: target top cells per triangle.
    pub top_density: f32,
    /// `lambda2`: target leaf cells per triangle of each top cell.
    pub leaf_density: f32,
    /// A fixed top resolution instead of the one `top_density` gives (for measurements).
    pub top_res: Option<[u32; 3]>,
}

impl Default for TwoLevelConfig {
    fn default() -> Self {
        TwoLevelConfig {
            top_density: DEFAULT_TOP_DENSITY,
            leaf_density: DEFAULT_LEAF_DENSITY,
            top_res: None,
        }
    }
}

/// [`TwoLevelGrid::top`] entry of a top cell without triangles.
pub const EMPTY_TOP: u32 = u32::MAX;

/// The sub-grid of one non-empty top cell: where its leaves start and its frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubGrid {
    /// Index of the sub-grid's first leaf in [`TwoLevelGrid::leaves`].
    pub leaf_base: u32,
    /// Sub-grid cells per axis, each at least 1.
    pub res: [u32; 3],
    /// Sub-grid lower corner.
    pub lo: Vec3,
    /// Sub-grid cell size.
    pub sub: Vec3,
}

impl SubGrid {
    /// Number of leaf cells of the sub-grid.
    #[inline]
    pub fn leaf_count(&self) -> usize {
        self.res.iter().map(|&r| r as usize).product()
    }
}

/// Size and occupancy figures of a built two-level grid.
#[derive(Clone, Debug, serde::Serialize)]
pub struct TwoLevelStats {
    /// Wall-clock build time in milliseconds.
    pub build_ms: f64,
    /// Memory of the four tables: `top * 4 + subgrids * 40 + leaves * 8 + references * 4`.
    pub bytes: usize,
    /// `bytes / triangles` (0 for an empty scene).
    pub bytes_per_triangle: f64,
    /// Top cells.
    pub top_cells: usize,
    /// Top cells with no triangle.
    pub top_empty: usize,
    /// (top cell, triangle) pairs: what the sub-grids were sized by.
    pub top_references: usize,
    /// Leaf cells of all sub-grids.
    pub leaf_cells: usize,
    /// Leaf cells with no triangle.
    pub leaf_empty: usize,
    /// (leaf, triangle) references, i.e. `tri_indices.len()`.
    pub references: usize,
    /// Mean references per non-empty leaf (0 when there is none).
    pub mean_per_nonempty_leaf: f64,
    /// Largest reference count of any leaf.
    pub max_per_leaf: u32,
    /// Largest sub-grid, in cells.
    pub max_sub_cells: usize,
}

impl fmt::Display for TwoLevelStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} top cells ({:.1}% empty), {} leaves ({:.1}% empty, largest sub-grid {}), {} refs \
             (mean {:.2}, max {} per non-empty leaf), {:.2} MiB ({:.1} B/triangle), built in {:.1} ms",
            self.top_cells,
            pct(self.top_empty, self.top_cells),
            self.leaf_cells,
            pct(self.leaf_empty, self.leaf_cells),
            self.max_sub_cells,
            self.references,
            self.mean_per_nonempty_leaf,
            self.max_per_leaf,
            self.bytes as f64 / (1024.0 * 1024.0),
            self.bytes_per_triangle,
            self.build_ms
        )
    }
}

/// `100 * a / b`, 0 when `b` is 0.
fn pct(a: usize, b: usize) -> f64 {
    if b == 0 {
        0.0
    } else {
        100.0 * a as f64 / b as f64
    }
}

/// A two-level grid over a scene's triangles (see the module docs for the layout).
#[derive(Clone, Debug)]
pub struct TwoLevelGrid {
    /// Lower corner of the top grid: the scene bounds padded as [`Grid`] pads them.
    pub min: Vec3,
    /// Upper corner of the top grid.
    pub max: Vec3,
    /// Top cells per axis.
    pub res: [u32; 3],
    /// Top cell size, `(max - min) / res` in f32.
    pub cell_size: Vec3,
    /// Per top cell, x fastest: index into `subgrids`, or [`EMPTY_TOP`].
    pub top: Vec<u32>,
    /// One per non-empty top cell, in top-cell order.
    pub subgrids: Vec<SubGrid>,
    /// Per leaf cell: its range of `tri_indices`.
    pub leaves: Vec<CellRange>,
    /// Triangle indices, leaf after leaf, ascending within each leaf.
    pub tri_indices: Vec<u32>,
    /// Build statistics.
    pub stats: TwoLevelStats,
}

impl TwoLevelGrid {
    /// Builds the two-level grid for `scene`.
    ///
    /// Errors: [`Error::Scene`] for a non-finite vertex or an out-of-range vertex index,
    /// [`Error::Usage`] for a non-positive density, and [`Error::Limit`] when the leaf
    /// cells or the references exceed 2^24.
    pub fn build(scene: &Scene, cfg: &TwoLevelConfig) -> Result<TwoLevelGrid> {
        build_with_limits(scene, cfg, MAX_LEAF_CELLS, MAX_REFERENCES)
    }

    /// Index of top cell `(x, y, z)` in [`TwoLevelGrid::top`].
    #[inline]
    pub fn top_index(&self, c: [u32; 3]) -> usize {
        c[0] as usize
            + self.res[0] as usize * (c[1] as usize + self.res[1] as usize * c[2] as usize)
    }

    /// The sub-grid of top cell `c`, `None` when the cell is empty.
    pub fn subgrid(&self, c: [u32; 3]) -> Option<&SubGrid> {
        match self.top[self.top_index(c)] {
            EMPTY_TOP => None,
            i => Some(&self.subgrids[i as usize]),
        }
    }

    /// Corners of top cell `c` in f64 (before any padding), as [`Grid::cell_bounds`].
    pub fn top_bounds(&self, c: [u32; 3]) -> (DVec3, DVec3) {
        top_bounds(self.min, self.cell_size, self.res, self.top_index(c))
    }

    /// The triangles of leaf `(x, y, z)` of top cell `c`, ascending (empty for an empty
    /// top cell).
    pub fn leaf_triangles(&self, c: [u32; 3], l: [u32; 3]) -> &[u32] {
        let Some(t) = self.subgrid(c) else {
            return &[];
        };
        let i = t.leaf_base as usize
            + l[0] as usize
            + t.res[0] as usize * (l[1] as usize + t.res[1] as usize * l[2] as usize);
        let r = self.leaves[i];
        &self.tri_indices[r.offset as usize..(r.offset + r.count) as usize]
    }
}

/// Corners of top cell `i` (flat index) in f64, as [`Grid::cell_bounds`].
fn top_bounds(min: Vec3, cs: Vec3, res: [u32; 3], i: usize) -> (DVec3, DVec3) {
    let i = i as u32;
    let c = DVec3::new(
        (i % res[0]) as f64,
        ((i / res[0]) % res[1]) as f64,
        (i / (res[0] * res[1])) as f64,
    );
    let lo = min.as_dvec3() + c * cs.as_dvec3();
    (lo, lo + cs.as_dvec3())
}

/// Top resolution for [`TwoLevelConfig::top_density`]: [`Grid::auto_resolution`], then
/// every axis raised to at least `min(MIN_TOP_AXIS, ceil(cbrt(density * n)))` cells.
///
/// The uniform grid's rule gives a flat scene (a mesh on a large floor) a single cell in
/// height, so the floor runs through every top cell of the mesh and the mesh's sub-grids
/// are spread over the whole floor piece. Layers put the floor in its own top cells and
/// the mesh above it in others, whose tight sub-grid boxes then fit the mesh.
pub fn top_resolution(extent: Vec3, n: usize, density: f32) -> [u32; 3] {
    let res = Grid::auto_resolution(extent, n, density);
    let cubic = (density as f64 * n as f64).cbrt().ceil();
    let floor = if cubic.is_finite() {
        (cubic as u32).clamp(1, MIN_TOP_AXIS)
    } else {
        1
    };
    res.map(|r| r.max(floor))
}

/// Sub-grid resolution for a top cell of extent `extent` holding `n` triangles.
pub fn sub_resolution(extent: Vec3, n: usize, leaf_density: f32) -> [u32; 3] {
    // Capping the target count caps the cell count (auto_resolution aims at density * n).
    let density = (leaf_density as f64).min(MAX_SUB_CELLS as f64 / n.max(1) as f64) as f32;
    Grid::auto_resolution(extent, n, density).map(|r| r.min(MAX_SUB_AXIS))
}

/// One top cell's finished sub-grid, with leaf offsets relative to its own list.
struct SubBuild {
    res: [u32; 3],
    lo: Vec3,
    sub: Vec3,
    leaves: Vec<CellRange>,
    list: Vec<u32>,
}

/// [`TwoLevelGrid::build`] with both limits as parameters, so tests can reach them.
fn build_with_limits(
    scene: &Scene,
    cfg: &TwoLevelConfig,
    max_leaves: usize,
    max_refs: usize,
) -> Result<TwoLevelGrid> {
    let start = Instant::now();
    for (name, v) in [("top", cfg.top_density), ("leaf", cfg.leaf_density)] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(Error::Usage(format!(
                "two-level grid {name} density must be a positive finite number, got {v}"
            )));
        }
    }
    check_vertices(scene)?;
    let n_tris = scene.triangles.len();
    if n_tris > u32::MAX as usize {
        return Err(Error::Limit(format!(
            "{n_tris} triangles, at most {} can be indexed",
            u32::MAX
        )));
    }
    let Some((lo, hi)) = scene.bounds() else {
        // Nothing to bin: one empty top cell keeps consumers free of a special case.
        let (min, max) = (Vec3::splat(-1.0), Vec3::splat(1.0));
        return Ok(finish(
            start,
            n_tris,
            min,
            max,
            [1, 1, 1],
            vec![EMPTY_TOP],
            Vec::new(),
            Vec::new(),
            Vec::new(),
            0,
        ));
    };
    let (min, max) = padded_bounds(scene, lo, hi)?;
    let res = match cfg.top_res {
        Some(r) if r.iter().all(|&v| (1..=MAX_FIXED_TOP_AXIS).contains(&v)) => r,
        Some([x, y, z]) => {
            return Err(Error::Usage(format!(
            "two-level top resolution {x}x{y}x{z}: each axis needs 1 to {MAX_FIXED_TOP_AXIS} cells"
        )))
        }
        None => top_resolution(max - min, n_tris, cfg.top_density),
    };
    if res.iter().map(|&v| v as usize).product::<usize>() > MAX_LEAF_CELLS {
        return Err(Error::Limit(format!(
            "two-level top resolution {}x{}x{}: at most {MAX_LEAF_CELLS} top cells",
            res[0], res[1], res[2]
        )));
    }
    let cell_size = (max - min) / Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
    let n_top = res.iter().map(|&r| r as usize).product::<usize>();
    let tri64 = |t: usize| scene.triangle_vertices(t).map(|v| v.as_dvec3());

    // Level 1: which top cells each triangle touches, chunk by chunk in triangle order.
    let frame = Frame::new(
        min.as_dvec3(),
        cell_size.as_dvec3(),
        res,
        min.as_dvec3(),
        max.as_dvec3(),
    );
    let chunks: Vec<(Vec<u32>, Vec<u32>)> = (0..n_tris)
        .collect::<Vec<_>>()
        .par_chunks(CHUNK)
        .map(|ids| {
            let mut cells = Vec::new();
            let mut per_tri = Vec::with_capacity(ids.len());
            for &t in ids {
                let before = cells.len();
                frame.bin(tri64(t), &mut cells);
                per_tri.push((cells.len() - before) as u32);
            }
            (cells, per_tri)
        })
        .collect();
    let pairs = chunks
        .iter()
        .enumerate()
        .flat_map(|(ci, (cells, per_tri))| {
            per_tri
                .iter()
                .enumerate()
                .flat_map(move |(j, &n)| std::iter::repeat_n((ci * CHUNK + j) as u32, n as usize))
                .zip(cells.iter().copied())
                .map(|(t, c)| (c, t))
        });
    let (top_ranges, top_list) = counting_sort(n_top, pairs);
    drop(chunks);

    // Sub-grid boxes and sizes first, so the leaf limit is checked before any leaf is
    // binned: the triangles' bounding boxes clipped to the top cell, then padded.
    let frames: Vec<Option<(Vec3, Vec3, [u32; 3])>> = (0..n_top)
        .into_par_iter()
        .map(|i| {
            let r = top_ranges[i];
            if r.count == 0 {
                return Ok(None);
            }
            let (clo, chi) = top_bounds(min, cell_size, res, i);
            let tris = &top_list[r.offset as usize..(r.offset + r.count) as usize];
            let (mut a, mut b) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for &t in tris {
                let v = tri64(t as usize);
                // Clamped rather than intersected: a triangle listed only through the
                // padding still gives a (flat) box on the face.
                a = a.min(v[0].min(v[1]).min(v[2]).clamp(clo, chi));
                b = b.max(v[0].max(v[1]).max(v[2]).clamp(clo, chi));
            }
            // Rounded outwards to f32, then padded as the scene box is.
            let lo = a.as_vec3().min(Vec3::new(
                (a.x as f32).next_down(),
                (a.y as f32).next_down(),
                (a.z as f32).next_down(),
            ));
            let hi = b.as_vec3().max(Vec3::new(
                (b.x as f32).next_up(),
                (b.y as f32).next_up(),
                (b.z as f32).next_up(),
            ));
            let (lo, hi) = padded_bounds(scene, lo, hi)?;
            let sres = sub_resolution(hi - lo, r.count as usize, cfg.leaf_density);
            let sub = (hi - lo) / Vec3::new(sres[0] as f32, sres[1] as f32, sres[2] as f32);
            Ok(Some((lo, sub, sres)))
        })
        .collect::<Result<_>>()?;
    let n_leaves: usize = frames
        .iter()
        .flatten()
        .map(|f| f.2.iter().map(|&v| v as usize).product::<usize>())
        .sum();
    if n_leaves > max_leaves {
        return Err(Error::Limit(format!(
            "the two-level grid needs {n_leaves} leaf cells, at most {max_leaves} allowed \
             (top grid {}x{}x{}, {n_tris} triangles); lower the leaf density",
            res[0], res[1], res[2]
        )));
    }

    // Level 2: every non-empty top cell bins its own triangles into its sub-grid. The
    // running total only stops the work early once the limit is blown; whether the build
    // fails is decided on the exact sum below, so it does not depend on scheduling.
    let total = AtomicUsize::new(0);
    let subs: Vec<Option<SubBuild>> = (0..n_top)
        .into_par_iter()
        .map(|i| {
            let r = top_ranges[i];
            let (lo, sub, sres) = frames[i]?;
            if total.load(Ordering::Relaxed) > max_refs {
                return None;
            }
            let lo64 = lo.as_dvec3();
            let hi64 =
                lo64 + DVec3::new(sres[0] as f64, sres[1] as f64, sres[2] as f64) * sub.as_dvec3();
            let frame = Frame::new(lo64, sub.as_dvec3(), sres, lo64, hi64);
            let tris = &top_list[r.offset as usize..(r.offset + r.count) as usize];
            let mut pairs = Vec::new();
            let mut cells = Vec::new();
            for &t in tris {
                cells.clear();
                frame.bin(tri64(t as usize), &mut cells);
                pairs.extend(cells.iter().map(|&l| (l, t)));
            }
            total.fetch_add(pairs.len(), Ordering::Relaxed);
            let n_cells = sres.iter().map(|&v| v as usize).product();
            let (leaves, list) = counting_sort(n_cells, pairs.iter().copied());
            Some(SubBuild {
                res: sres,
                lo,
                sub,
                leaves,
                list,
            })
        })
        .collect();
    let n_refs: usize = subs.iter().flatten().map(|s| s.list.len()).sum();
    if n_refs > max_refs || total.load(Ordering::Relaxed) > max_refs {
        return Err(Error::Limit(format!(
            "the two-level grid needs more than {max_refs} triangle references \
             (top grid {}x{}x{}, {n_tris} triangles); lower the leaf density",
            res[0], res[1], res[2]
        )));
    }

    // Concatenate in top-cell order.
    let mut top = vec![EMPTY_TOP; n_top];
    let mut subgrids = Vec::new();
    let mut leaves = Vec::with_capacity(n_leaves);
    let mut tri_indices = Vec::with_capacity(n_refs);
    for (t, s) in top.iter_mut().zip(&subs) {
        if let Some(s) = s {
            *t = subgrids.len() as u32;
            subgrids.push(SubGrid {
                leaf_base: leaves.len() as u32,
                res: s.res,
                lo: s.lo,
                sub: s.sub,
            });
            let base = tri_indices.len() as u32;
            leaves.extend(s.leaves.iter().map(|r| CellRange {
                offset: r.offset + base,
                count: r.count,
            }));
            tri_indices.extend_from_slice(&s.list);
        }
    }
    let top_refs = top_list.len();
    Ok(finish(
        start,
        n_tris,
        min,
        max,
        res,
        top,
        subgrids,
        leaves,
        tri_indices,
        top_refs,
    ))
}

/// Assembles the grid and its statistics.
#[allow(clippy::too_many_arguments)]
fn finish(
    start: Instant,
    n_tris: usize,
    min: Vec3,
    max: Vec3,
    res: [u32; 3],
    top: Vec<u32>,
    subgrids: Vec<SubGrid>,
    leaves: Vec<CellRange>,
    tri_indices: Vec<u32>,
    top_references: usize,
) -> TwoLevelGrid {
    let cell_size = (max - min) / Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
    let leaf_empty = leaves.iter().filter(|c| c.count == 0).count();
    let nonempty = leaves.len() - leaf_empty;
    let references = tri_indices.len();
    let bytes = top.len() * std::mem::size_of::<u32>()
        + subgrids.len() * std::mem::size_of::<SubGrid>()
        + leaves.len() * std::mem::size_of::<CellRange>()
        + references * std::mem::size_of::<u32>();
    let stats = TwoLevelStats {
        build_ms: start.elapsed().as_secs_f64() * 1e3,
        bytes,
        bytes_per_triangle: if n_tris == 0 {
            0.0
        } else {
            bytes as f64 / n_tris as f64
        },
        top_cells: top.len(),
        top_empty: top.len() - subgrids.len(),
        top_references,
        leaf_cells: leaves.len(),
        leaf_empty,
        references,
        mean_per_nonempty_leaf: if nonempty == 0 {
            0.0
        } else {
            references as f64 / nonempty as f64
        },
        max_per_leaf: leaves.iter().map(|c| c.count).max().unwrap_or(0),
        max_sub_cells: subgrids.iter().map(|t| t.leaf_count()).max().unwrap_or(0),
    };
    TwoLevelGrid {
        min,
        max,
        res,
        cell_size,
        top,
        subgrids,
        leaves,
        tri_indices,
        stats,
    }
}

#[cfg(test)]
#[path = "two_level_tests.rs"]
pub(crate) mod tests;
