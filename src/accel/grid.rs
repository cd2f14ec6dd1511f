//! Uniform grid over the scene's triangles.
//!
//! Layout: `cells[x + res[0] * (y + res[1] * z)]` is a [`CellRange`] into the flat
//! `tri_indices`, which lists, cell by cell, the triangles overlapping that cell in
//! ascending index order. Cell `i` on an axis spans `[min + i * cell_size, min + (i + 1) *
//! cell_size]` with `cell_size = (max - min) / res` computed in f32, which is the
//! definition the 3D-DDA of both backends uses.
//!
//! Binning is exact rather than by bounding box (a triangle goes only where
//! [`tri_box_overlap`] says it touches), but against a cell box grown by a tiny margin, so
//! that rounding in an f32 traversal can never step into a cell that is missing a triangle
//! it actually touches: a triangle lying on a cell face is listed on both sides.
//!
//! The build is parallel over triangles and deterministic: the output is identical for
//! any thread count.

use std::fmt;
use std::str::FromStr;
use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::tribox::tri_box_overlap;
use crate::clock::Instant;
use crate::scene::Scene;
use crate::{Error, Result};

/// Default `lambda`: target number of cells per triangle for [`GridRes::Auto`]. 8 rather
/// than 4 because `fragtrace bench` measured it faster at equal error on both machines
/// (GL looped, 512x512: llvmpipe whitted 1.21x, bunny 1.58x; H200 whitted 1.18x, bunny
/// 1.23x, dragon 1.45x, glass 1.44x, level elsewhere), for twice the cell memory.
pub const DEFAULT_DENSITY: f32 = 8.0;
/// Largest per-axis resolution [`GridRes::Auto`] picks.
pub const MAX_AUTO_AXIS: u32 = 512;
/// Largest total cell count [`GridRes::Auto`] picks.
pub const MAX_AUTO_CELLS: u64 = 1 << 24;
/// Largest per-axis resolution accepted for [`GridRes::Fixed`].
pub const MAX_FIXED_AXIS: u32 = 4096;
/// Largest total cell count accepted for [`GridRes::Fixed`].
pub const MAX_FIXED_CELLS: u64 = 1 << 26;
/// Largest number of (cell, triangle) references: what the `u32` offsets hold. (The GPU
/// layout splits offsets past 2^24 over two floats, `gpu::layout::IndexFormat::Split`.)
pub const MAX_REFERENCES: usize = u32::MAX as usize;

/// Smallest extent of a grid axis relative to the largest one, so flat scenes still get
/// a box of positive volume.
const MIN_EXTENT_FRACTION: f64 = 1e-3;
/// Padding of the scene bounds relative to the largest extent, so no vertex lies on the
/// grid's outer boundary where a traversal would start or end exactly on a face.
const BOUNDS_PAD_FRACTION: f64 = 1e-4;
/// Growth of each cell's half-size, relative to the cell size, for the binning test.
const CELL_PAD_FRACTION: f64 = 1e-5;
/// How many f32 ulps of the coordinate magnitude are added to either padding: at large
/// coordinates that, not the relative term, is what f32 rounding is measured in.
const PAD_ULPS: f64 = 4.0;
/// Triangles per parallel work item: big enough to amortise the per-chunk vectors.
const CHUNK: usize = 2048;

/// How the grid resolution is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GridRes {
    /// Derived from the scene extent and triangle count (see [`Grid::auto_resolution`]).
    Auto,
    /// Exactly these cells per axis (x, y, z).
    Fixed([u32; 3]),
}

impl FromStr for GridRes {
    type Err = String;

    /// Parses `auto` or `AxBxC` (e.g. `32x16x8`), each count at least 1.
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let s = s.trim();
        if s.eq_ignore_ascii_case("auto") {
            return Ok(GridRes::Auto);
        }
        let bad = || {
            format!("invalid grid resolution `{s}`: expected `auto` or `AxBxC` like `32x16x8`, each at least 1")
        };
        let parts: Vec<&str> = s.split(['x', 'X']).collect();
        if parts.len() != 3 {
            return Err(bad());
        }
        let mut res = [0u32; 3];
        for (r, p) in res.iter_mut().zip(&parts) {
            // `u32::from_str` accepts a leading `+`; a grid size written that way is a typo.
            if p.is_empty() || !p.bytes().all(|b| b.is_ascii_digit()) {
                return Err(bad());
            }
            *r = p.parse().map_err(|_| bad())?;
            if *r == 0 {
                return Err(bad());
            }
        }
        Ok(GridRes::Fixed(res))
    }
}

impl fmt::Display for GridRes {
    /// Writes the form [`GridRes::from_str`] reads back.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GridRes::Auto => f.write_str("auto"),
            GridRes::Fixed([x, y, z]) => write!(f, "{x}x{y}x{z}"),
        }
    }
}

/// Grid build parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridConfig {
    /// Resolution choice.
    pub res: GridRes,
    /// `lambda`: target cells per triangle when `res` is [`GridRes::Auto`].
    pub density: f32,
}

impl Default for GridConfig {
    fn default() -> Self {
        GridConfig {
            res: GridRes::Auto,
            density: DEFAULT_DENSITY,
        }
    }
}

/// One cell's slice of [`Grid::tri_indices`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct CellRange {
    /// Index of the cell's first triangle reference.
    pub offset: u32,
    /// Number of triangle references.
    pub count: u32,
}

/// Size and occupancy figures of a built grid.
#[derive(Clone, Debug, serde::Serialize)]
pub struct GridStats {
    /// Wall-clock build time in milliseconds.
    pub build_ms: f64,
    /// Memory of the cell table and reference list: `cells * 8 + references * 4`.
    pub bytes: usize,
    /// Total number of cells.
    pub cells: usize,
    /// Cells with no triangle.
    pub empty_cells: usize,
    /// `empty_cells / cells`.
    pub empty_fraction: f64,
    /// Total (cell, triangle) references, i.e. `tri_indices.len()`.
    pub references: usize,
    /// Mean references per non-empty cell (0 when all cells are empty).
    pub mean_per_nonempty: f64,
    /// Largest reference count of any cell.
    pub max_per_nonempty: u32,
}

impl fmt::Display for GridStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} cells ({:.1}% empty), {} refs (mean {:.2}, max {} per non-empty cell), {:.2} MiB, built in {:.1} ms",
            self.cells,
            self.empty_fraction * 100.0,
            self.references,
            self.mean_per_nonempty,
            self.max_per_nonempty,
            self.bytes as f64 / (1024.0 * 1024.0),
            self.build_ms
        )
    }
}

/// A uniform grid over a scene's triangles (see the module docs for the layout).
#[derive(Clone, Debug)]
pub struct Grid {
    /// Lower grid corner: the scene bounds, padded.
    pub min: Vec3,
    /// Upper grid corner: the scene bounds, padded.
    pub max: Vec3,
    /// Cells per axis.
    pub res: [u32; 3],
    /// `(max - min) / res` in f32; cell `i` spans `[min + i*cell_size, min + (i+1)*cell_size]`.
    pub cell_size: Vec3,
    /// Per-cell ranges into `tri_indices`, x fastest: `x + res[0] * (y + res[1] * z)`.
    pub cells: Vec<CellRange>,
    /// Triangle indices, grouped by cell, ascending within each cell.
    pub tri_indices: Vec<u32>,
    /// Build statistics.
    pub stats: GridStats,
}

impl Grid {
    /// Builds the grid for `scene`.
    ///
    /// Errors: [`Error::Scene`] for a non-finite vertex or an out-of-range vertex index,
    /// [`Error::Usage`] for a zero fixed resolution or a non-positive density, and
    /// [`Error::Limit`] when a fixed resolution or the reference count exceeds its limit.
    pub fn build(scene: &Scene, cfg: &GridConfig) -> Result<Grid> {
        build_with_limit(scene, cfg, MAX_REFERENCES)
    }

    /// Index of cell `(x, y, z)` in [`Grid::cells`].
    #[inline]
    pub fn cell_index(&self, x: u32, y: u32, z: u32) -> usize {
        debug_assert!(x < self.res[0] && y < self.res[1] && z < self.res[2]);
        x as usize + self.res[0] as usize * (y as usize + self.res[1] as usize * z as usize)
    }

    /// The triangles overlapping cell `(x, y, z)`, ascending.
    #[inline]
    pub fn cell_triangles(&self, x: u32, y: u32, z: u32) -> &[u32] {
        let r = self.cells[self.cell_index(x, y, z)];
        &self.tri_indices[r.offset as usize..(r.offset + r.count) as usize]
    }

    /// Corners of cell `(x, y, z)` in f64, per the definition the build bins against
    /// (before its safety padding).
    pub fn cell_bounds(&self, x: u32, y: u32, z: u32) -> (DVec3, DVec3) {
        let min = self.min.as_dvec3();
        let cs = self.cell_size.as_dvec3();
        let i = DVec3::new(x as f64, y as f64, z as f64);
        (min + i * cs, min + (i + 1.0) * cs)
    }

    /// Resolution for [`GridRes::Auto`]: about `density * n_triangles` cells, cubical as
    /// far as possible, so cells per axis are proportional to `extent`.
    ///
    /// With `k = cbrt(density * n / volume)`, axis `i` gets `max(1, round(extent_i * k))`
    /// cells. An axis whose share `extent_i * k` is below one cell (a flat or thin scene)
    /// gets exactly one cell and `k` is recomputed over the remaining axes, so a flat scene
    /// is not over-resolved in-plane to make up for its missing depth. The total is then
    /// capped at [`MAX_AUTO_CELLS`] by scaling all axes down alike, and each axis clamped
    /// to [`MAX_AUTO_AXIS`]. Degenerate inputs (no triangles, non-positive density, zero or
    /// non-finite extent) give `[1, 1, 1]`.
    pub fn auto_resolution(extent: Vec3, n_triangles: usize, density: f32) -> [u32; 3] {
        let e = extent.as_dvec3();
        let target = density as f64 * n_triangles as f64;
        let usable = target >= 1.0 && target.is_finite() && e.is_finite() && e.max_element() > 0.0;
        if !usable {
            return [1, 1, 1];
        }
        // Axes that get a single cell; at most two can, since the largest axis always
        // gets k * extent >= 1 once the others are excluded and target >= 1.
        let mut single = [false; 3];
        let mut k = 0.0;
        for _ in 0..3 {
            let free: Vec<usize> = (0..3).filter(|&i| !single[i] && e[i] > 0.0).collect();
            let volume: f64 = free.iter().map(|&i| e[i]).product();
            k = (target / volume).powf(1.0 / free.len() as f64);
            let mut changed = false;
            for i in 0..3 {
                if !single[i] && e[i] * k < 1.0 {
                    single[i] = true;
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        // Cap the total before the per-axis clamp so a huge scene keeps its proportions
        // (clamping a long axis first would make the grid cubical).
        let free = (0..3).filter(|&i| !single[i]).count() as f64;
        let raw: f64 = (0..3).filter(|&i| !single[i]).map(|i| e[i] * k).product();
        if raw > MAX_AUTO_CELLS as f64 {
            k *= (MAX_AUTO_CELLS as f64 / raw).powf(1.0 / free);
        }
        let mut res = [1u32; 3];
        for i in 0..3 {
            if !single[i] {
                // Float-to-int `as` saturates, so absurd values land on the clamp.
                res[i] = ((e[i] * k).round() as u32).clamp(1, MAX_AUTO_AXIS);
            }
        }
        // Rounding up can still overshoot the cap by a little.
        clamp_total(res, MAX_AUTO_CELLS)
    }
}

/// Scales `res` down uniformly until it has at most `cap` cells.
fn clamp_total(mut res: [u32; 3], cap: u64) -> [u32; 3] {
    let total = |r: &[u32; 3]| r.iter().map(|&v| v as u64).product::<u64>();
    if total(&res) > cap {
        let s = (cap as f64 / total(&res) as f64).cbrt();
        for r in &mut res {
            *r = ((*r as f64 * s).floor() as u32).max(1);
        }
        // Rounding can leave a few cells too many; trim the longest axis.
        while total(&res) > cap {
            let i = (0..3).max_by_key(|&i| res[i]).unwrap_or(0);
            res[i] -= 1;
        }
    }
    res
}

/// Total cells of a resolution, without overflow.
fn cell_count(res: [u32; 3]) -> u64 {
    res.iter().map(|&v| v as u64).product()
}

/// Checks a fixed resolution against the limits.
fn check_fixed(res: [u32; 3]) -> Result<()> {
    let [x, y, z] = res;
    if res.contains(&0) {
        return Err(Error::Usage(format!(
            "grid resolution {x}x{y}x{z}: every axis needs at least 1 cell"
        )));
    }
    if res.iter().any(|&r| r > MAX_FIXED_AXIS) {
        return Err(Error::Limit(format!(
            "grid resolution {x}x{y}x{z}: at most {MAX_FIXED_AXIS} cells per axis"
        )));
    }
    if cell_count(res) > MAX_FIXED_CELLS {
        return Err(Error::Limit(format!(
            "grid resolution {x}x{y}x{z}: {} cells, at most {MAX_FIXED_CELLS} allowed",
            cell_count(res)
        )));
    }
    Ok(())
}

/// Rejects what would make the build panic or produce garbage: out-of-range vertex
/// indices and non-finite vertices.
pub(crate) fn check_vertices(scene: &Scene) -> Result<()> {
    let n = scene.positions.len();
    // Checked in parallel; the serial pass below, which names the first offender, runs
    // only when there is one.
    let bad = |v: &u32| *v as usize >= n || !scene.positions[*v as usize].is_finite();
    if !scene.triangles.par_iter().any(|t| t.v.iter().any(bad)) {
        return Ok(());
    }
    for (i, t) in scene.triangles.iter().enumerate() {
        for &v in &t.v {
            if v as usize >= n {
                return Err(Error::scene(
                    scene.source.clone(),
                    0,
                    format!("triangles[{i}]"),
                    format!("vertex index {v} out of range"),
                ));
            }
            let p = scene.positions[v as usize];
            if !p.is_finite() {
                return Err(Error::scene(
                    scene.source.clone(),
                    0,
                    format!("triangles[{i}]"),
                    format!("non-finite vertex {p}"),
                ));
            }
        }
    }
    Ok(())
}

/// `PAD_ULPS` f32 ulps of a coordinate of magnitude `mag`.
fn ulps(mag: f64) -> f64 {
    PAD_ULPS * mag * f32::EPSILON as f64
}

/// Grid corners for scene bounds `lo..hi`: thin axes widened, then everything padded so
/// every vertex lies strictly inside.
pub(crate) fn padded_bounds(scene: &Scene, lo: Vec3, hi: Vec3) -> Result<(Vec3, Vec3)> {
    let (mut a, mut b) = (lo.as_dvec3(), hi.as_dvec3());
    let largest = (b - a).max_element();
    let min_extent = if largest > 0.0 {
        largest * MIN_EXTENT_FRACTION
    } else {
        // Everything is one point: any size works, 1 keeps cell sizes ordinary.
        1.0
    };
    let largest = largest.max(min_extent);
    let mut pad = DVec3::ZERO;
    for i in 0..3 {
        if b[i] - a[i] < min_extent {
            let c = 0.5 * (a[i] + b[i]);
            a[i] = c - 0.5 * min_extent;
            b[i] = c + 0.5 * min_extent;
        }
        pad[i] = BOUNDS_PAD_FRACTION * largest + ulps(a[i].abs().max(b[i].abs()));
    }
    let mut min = (a - pad).as_vec3();
    let mut max = (b + pad).as_vec3();
    // The f32 rounding above cannot undo a pad of several ulps, but the guarantee that no
    // vertex sits on the boundary is cheap to make unconditional.
    for i in 0..3 {
        if min[i] >= lo[i] {
            min[i] = lo[i].next_down();
        }
        if max[i] <= hi[i] {
            max[i] = hi[i].next_up();
        }
    }
    if !(min.is_finite() && max.is_finite() && (max - min).is_finite()) {
        return Err(Error::scene(
            scene.source.clone(),
            0,
            "positions",
            format!("scene bounds {lo}..{hi} are too large for f32 grid arithmetic"),
        ));
    }
    Ok((min, max))
}

/// What one triangle needs to find its cells.
struct Binner {
    min: DVec3,
    cs: DVec3,
    res: [u32; 3],
    /// Growth of each cell's half-size for the overlap test and of the triangle's bounding
    /// box for the candidate range.
    pad: DVec3,
}

impl Binner {
    /// Appends to `out` the index of every cell the triangle overlaps, ascending. Stops
    /// early once `out` holds more than `budget` entries (the caller then reports the
    /// reference limit).
    fn bin(&self, tri: [DVec3; 3], out: &mut Vec<u32>, budget: usize) {
        let bb_lo = tri[0].min(tri[1]).min(tri[2]) - self.pad;
        let bb_hi = tri[0].max(tri[1]).max(tri[2]) + self.pad;
        let cell = |p: f64, i: usize| -> u32 {
            // `as i64` saturates, and the clamp absorbs anything outside the grid.
            let c = ((p - self.min[i]) / self.cs[i]).floor() as i64;
            c.clamp(0, self.res[i] as i64 - 1) as u32
        };
        let lo = [cell(bb_lo.x, 0), cell(bb_lo.y, 1), cell(bb_lo.z, 2)];
        let hi = [cell(bb_hi.x, 0), cell(bb_hi.y, 1), cell(bb_hi.z, 2)];
        let half = 0.5 * self.cs + self.pad;
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                let row = self.res[0] as usize * (y as usize + self.res[1] as usize * z as usize);
                for x in lo[0]..=hi[0] {
                    let center =
                        self.min + (DVec3::new(x as f64, y as f64, z as f64) + 0.5) * self.cs;
                    if tri_box_overlap(center, half, tri) {
                        out.push((row + x as usize) as u32);
                    }
                }
                if out.len() > budget {
                    return;
                }
            }
        }
    }
}

/// One chunk of consecutive triangles' binning output.
struct ChunkBins {
    /// Cell indices, triangle after triangle.
    cells: Vec<u32>,
    /// How many entries of `cells` each triangle of the chunk contributed.
    per_tri: Vec<u32>,
}

/// [`Grid::build`] with the reference limit as a parameter, so tests can reach it.
fn build_with_limit(scene: &Scene, cfg: &GridConfig, max_refs: usize) -> Result<Grid> {
    let start = Instant::now();
    if let GridRes::Fixed(r) = cfg.res {
        check_fixed(r)?;
    } else if !(cfg.density > 0.0 && cfg.density.is_finite()) {
        return Err(Error::Usage(format!(
            "grid density must be a positive finite number, got {}",
            cfg.density
        )));
    }
    check_vertices(scene)?;

    let Some((lo, hi)) = scene.bounds() else {
        // Nothing to bin; a 1x1x1 grid keeps every consumer free of a special case.
        let (min, max) = (Vec3::splat(-1.0), Vec3::splat(1.0));
        return Ok(finish(
            start,
            min,
            max,
            [1, 1, 1],
            vec![CellRange::default()],
            Vec::new(),
        ));
    };
    let (min, max) = padded_bounds(scene, lo, hi)?;
    let n_tris = scene.triangles.len();
    let res = match cfg.res {
        GridRes::Auto => Grid::auto_resolution(max - min, n_tris, cfg.density),
        GridRes::Fixed(r) => r,
    };
    if n_tris > u32::MAX as usize {
        return Err(Error::Limit(format!(
            "{n_tris} triangles, at most {} can be indexed",
            u32::MAX
        )));
    }
    let cell_size = (max - min) / Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
    let n_cells = cell_count(res) as usize;

    let (dmin, dmax) = (min.as_dvec3(), max.as_dvec3());
    let cs = cell_size.as_dvec3();
    let mag = dmin.abs().max(dmax.abs());
    let binner = Binner {
        min: dmin,
        cs,
        res,
        pad: CELL_PAD_FRACTION * cs + DVec3::new(ulps(mag.x), ulps(mag.y), ulps(mag.z)),
    };

    // Running reference total across all workers, only to stop early when the limit is
    // blown: it only grows, so once a worker sees it exceeded the true total exceeds it
    // too, and whether the build fails does not depend on scheduling.
    let total = AtomicUsize::new(0);
    let chunks: Vec<ChunkBins> = scene
        .triangles
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(ci, tris)| {
            let mut out = ChunkBins {
                cells: Vec::new(),
                per_tri: Vec::with_capacity(tris.len()),
            };
            for j in 0..tris.len() {
                let seen = total.load(Ordering::Relaxed);
                if seen > max_refs {
                    break;
                }
                let v = scene.triangle_vertices(ci * CHUNK + j);
                let before = out.cells.len();
                let budget = before + (max_refs - seen);
                binner.bin(
                    [v[0].as_dvec3(), v[1].as_dvec3(), v[2].as_dvec3()],
                    &mut out.cells,
                    budget,
                );
                let k = out.cells.len() - before;
                out.per_tri.push(k as u32);
                total.fetch_add(k, Ordering::Relaxed);
            }
            out
        })
        .collect();

    // Every binned reference was added to `total` too, so this is its final value; a
    // worker that stopped early did so because it was already over the limit.
    let n_refs: usize = chunks.iter().map(|c| c.cells.len()).sum();
    if n_refs > max_refs {
        return Err(Error::Limit(format!(
            "the grid needs more than {max_refs} triangle references \
             (grid {}x{}x{}, {n_tris} triangles); lower the grid resolution or density",
            res[0], res[1], res[2]
        )));
    }

    // Counting sort, walking the chunks in triangle order: stable, so each cell's list
    // comes out ascending without a sort, and independent of how the work was scheduled.
    let mut cells = vec![CellRange::default(); n_cells];
    for c in chunks.iter().flat_map(|c| &c.cells) {
        cells[*c as usize].count += 1;
    }
    let mut offset = 0u32;
    for c in &mut cells {
        c.offset = offset;
        // Cannot overflow: the total is at most `max_refs` <= u32::MAX.
        offset += c.count;
    }
    let mut cursor: Vec<u32> = cells.iter().map(|c| c.offset).collect();
    let mut tri_indices = vec![0u32; n_refs];
    for (ci, chunk) in chunks.iter().enumerate() {
        let mut k = 0;
        for (j, &n) in chunk.per_tri.iter().enumerate() {
            let tri = (ci * CHUNK + j) as u32;
            for &c in &chunk.cells[k..k + n as usize] {
                let slot = &mut cursor[c as usize];
                tri_indices[*slot as usize] = tri;
                *slot += 1;
            }
            k += n as usize;
        }
    }

    Ok(finish(start, min, max, res, cells, tri_indices))
}

/// Assembles the grid and its statistics.
fn finish(
    start: Instant,
    min: Vec3,
    max: Vec3,
    res: [u32; 3],
    cells: Vec<CellRange>,
    tri_indices: Vec<u32>,
) -> Grid {
    let cell_size = (max - min) / Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
    let empty_cells = cells.iter().filter(|c| c.count == 0).count();
    let nonempty = cells.len() - empty_cells;
    let references = tri_indices.len();
    let stats = GridStats {
        build_ms: start.elapsed().as_secs_f64() * 1e3,
        bytes: cells.len() * std::mem::size_of::<CellRange>()
            + references * std::mem::size_of::<u32>(),
        cells: cells.len(),
        empty_cells,
        empty_fraction: empty_cells as f64 / cells.len() as f64,
        references,
        mean_per_nonempty: if nonempty == 0 {
            0.0
        } else {
            references as f64 / nonempty as f64
        },
        max_per_nonempty: cells.iter().map(|c| c.count).max().unwrap_or(0),
    };
    Grid {
        min,
        max,
        res,
        cell_size,
        cells,
        tri_indices,
        stats,
    }
}

#[cfg(test)]
#[path = "grid_tests.rs"]
mod tests;
