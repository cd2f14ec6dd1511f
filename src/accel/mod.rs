//! Acceleration structures over the scene's triangles, built on the CPU and walked one
//! step at a time by every backend: the thesis's uniform grid ([`grid`], a 3D-DDA) and the
//! irregular grid ([`irregular`], adaptive cells with exit boxes), chosen with `--accel`
//! ([`AccelKind`]); and for the CPU backend alone a bounding volume hierarchy ([`bvh`], the
//! structure CPU ray tracers such as Embree use, walked with a stack, no GLSL twin). (The
//! two-level grid they were measured against was removed; see docs/architecture.md.)
//!
//! [`binning`] bins triangles into a level's cells conservatively; [`tribox`] holds the
//! exact triangle/box overlap test the binning relies on.

pub mod binning;
pub mod bvh;
pub mod grid;
pub mod grid_instances;
pub mod instances;
pub mod irregular;
mod irregular_build;
mod irregular_grow;
mod irregular_occupancy;
pub mod irregular_wide;
pub mod tribox;

pub use grid::{CellRange, Grid, GridConfig, GridRes, GridStats};

/// Relative margin by which a later (higher-index) triangle must be closer than the current
/// best hit to replace it. Coplanar duplicates and hits on shared edges give t values that
/// differ by an ulp or two between f32, f64 and GPU arithmetic; with this margin all of them
/// keep the lowest index. 2^-19 is about 8 f32 ulps. Part of the traversal contract every
/// backend follows, so it lives with the structure: `cpu::traverse` uses it and the GLSL
/// prelude gets it as `TIE_EPS`.
pub const TIE_EPS: f64 = 1.0 / 524_288.0;

pub use bvh::Bvh;
pub use irregular::{IrregularConfig, IrregularGrid};

use crate::scene::Scene;
use crate::Result;

/// `[f(0), f(1), f(2)]`: what `[0, 1, 2].map(f)` means, written out. The builds' hot paths
/// use it because `map` on arrays was left as an out-of-line call there (a few percent of
/// the irregular build in `perf`).
#[inline(always)]
pub(crate) fn axes<T>(mut f: impl FnMut(usize) -> T) -> [T; 3] {
    [f(0), f(1), f(2)]
}

/// Which acceleration structure a render builds (`--accel`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum AccelKind {
    /// The thesis's uniform grid over the scene box, walked by a 3D-DDA.
    Uniform,
    /// The irregular grid (after Perard-Gayot et al. 2017): adaptive cells, empty ones with
    /// exit boxes grown over empty space, walked one cell at a time.
    #[default]
    Irregular,
    /// A 4-wide bounding volume hierarchy (binned SAH build), walked with a stack: the CPU
    /// backend's fastest structure; the GPU backend does not walk it.
    Bvh,
}

impl AccelKind {
    /// The name `--accel` takes.
    pub fn name(self) -> &'static str {
        match self {
            AccelKind::Uniform => "uniform",
            AccelKind::Irregular => "irregular",
            AccelKind::Bvh => "bvh",
        }
    }

    /// Whether the GPU backend walks this structure (the grids; not the BVH).
    pub fn on_gpu(self) -> bool {
        match self {
            AccelKind::Uniform | AccelKind::Irregular => true,
            AccelKind::Bvh => false,
        }
    }
}

/// A built acceleration structure.
#[derive(Clone, Debug)]
pub enum Accel {
    /// Uniform grid.
    Uniform(Grid),
    /// Irregular grid.
    Irregular(IrregularGrid),
    /// Bounding volume hierarchy (CPU only).
    Bvh(Bvh),
    /// The BVH of a scene with instances: two levels (CPU only; `--accel bvh`).
    Instanced(instances::TwoLevel),
    /// The uniform grids of a scene with instances: two levels (the GPU's compute kernel,
    /// `--accel uniform`).
    GridInstanced(Box<grid_instances::GridInstances>),
}

/// A borrowed acceleration structure: what renderers take, so that a `&Grid` or a
/// `&IrregularGrid` can be passed where a structure is expected.
#[derive(Clone, Copy, Debug)]
pub enum AccelRef<'a> {
    /// Uniform grid.
    Uniform(&'a Grid),
    /// Irregular grid.
    Irregular(&'a IrregularGrid),
    /// Bounding volume hierarchy (CPU only).
    Bvh(&'a Bvh),
    /// The two-level BVH of a scene with instances (CPU only).
    Instanced(&'a instances::TwoLevel),
    /// The two-level uniform grids of a scene with instances (the compute kernel).
    GridInstanced(&'a grid_instances::GridInstances),
}

impl<'a> From<&'a Grid> for AccelRef<'a> {
    fn from(g: &'a Grid) -> Self {
        AccelRef::Uniform(g)
    }
}

impl<'a> From<&'a IrregularGrid> for AccelRef<'a> {
    fn from(g: &'a IrregularGrid) -> Self {
        AccelRef::Irregular(g)
    }
}

impl<'a> From<&'a Bvh> for AccelRef<'a> {
    fn from(b: &'a Bvh) -> Self {
        AccelRef::Bvh(b)
    }
}

impl<'a> From<&'a Accel> for AccelRef<'a> {
    fn from(a: &'a Accel) -> Self {
        match a {
            Accel::Uniform(g) => AccelRef::Uniform(g),
            Accel::Irregular(g) => AccelRef::Irregular(g),
            Accel::Bvh(b) => AccelRef::Bvh(b),
            Accel::Instanced(t) => AccelRef::Instanced(t),
            Accel::GridInstanced(t) => AccelRef::GridInstanced(t),
        }
    }
}

/// A borrowed grid: the structures the GPU backend and the grids' CPU walkers
/// ([`Walker`](crate::cpu::walker::Walker)) step through cell by cell.
#[derive(Clone, Copy, Debug)]
pub enum GridRef<'a> {
    /// Uniform grid.
    Uniform(&'a Grid),
    /// Irregular grid.
    Irregular(&'a IrregularGrid),
}

impl<'a> From<&'a Grid> for GridRef<'a> {
    fn from(g: &'a Grid) -> Self {
        GridRef::Uniform(g)
    }
}

impl<'a> From<&'a IrregularGrid> for GridRef<'a> {
    fn from(g: &'a IrregularGrid) -> Self {
        GridRef::Irregular(g)
    }
}

impl<'a> From<GridRef<'a>> for AccelRef<'a> {
    fn from(g: GridRef<'a>) -> Self {
        match g {
            GridRef::Uniform(g) => AccelRef::Uniform(g),
            GridRef::Irregular(g) => AccelRef::Irregular(g),
        }
    }
}

impl<'a> GridRef<'a> {
    /// Which structure this is.
    pub fn kind(&self) -> AccelKind {
        AccelRef::from(*self).kind()
    }

    /// The triangle-index list the cells' ranges point into.
    pub fn tri_indices(&self) -> &'a [u32] {
        match self {
            GridRef::Uniform(g) => &g.tri_indices,
            GridRef::Irregular(g) => &g.tri_indices,
        }
    }
}

/// What `--stats` reports of the structure, whichever it is.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AccelSummary {
    /// Which structure.
    pub kind: AccelKind,
    /// Cells per axis: the uniform grid's, or the irregular grid's virtual resolution
    /// (zeros for the BVH, which has no cells).
    pub resolution: [u32; 3],
    /// Top cells per axis (irregular grid only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub top_resolution: Option<[u32; 3]>,
    /// Wall-clock build time in milliseconds.
    pub build_ms: f64,
    /// Memory of the tables as the GPU stores them.
    pub bytes: usize,
    /// `bytes / triangles` (0 for an empty scene).
    pub bytes_per_triangle: f64,
    /// Cells (the BVH: its nodes).
    pub cells: usize,
    /// Cells with no triangle.
    pub empty_cells: usize,
    /// (cell, triangle) references.
    pub references: usize,
    /// The structure's own one-line description.
    pub detail: String,
    /// For a scene walked as instances (two levels: the CPU's BVH, the compute kernel's
    /// uniform grids), what they hold: "N instances of M meshes, T triangles stored, P
    /// placed"; absent where the scene is walked as stored (flat).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub instanced: Option<String>,
}

impl Accel {
    /// Builds the structure `kind` for `scene`, with `grid` for the uniform grid and
    /// `irregular` for the irregular one (the BVH has no settings).
    pub fn build(
        scene: &Scene,
        kind: AccelKind,
        grid: &GridConfig,
        irregular: &IrregularConfig,
    ) -> Result<Accel> {
        Ok(match kind {
            AccelKind::Uniform => Accel::Uniform(Grid::build(scene, grid)?),
            AccelKind::Irregular => Accel::Irregular(IrregularGrid::build(scene, irregular)?),
            AccelKind::Bvh if scene.has_instances() => {
                Accel::Instanced(instances::TwoLevel::build(scene)?)
            }
            AccelKind::Bvh => Accel::Bvh(Bvh::build(scene)?),
        })
    }

    /// The structure borrowed.
    pub fn as_ref(&self) -> AccelRef<'_> {
        self.into()
    }
}

impl AccelSummary {
    /// The structure in a few words for the summary line: the uniform grid's cells per
    /// axis; the irregular grid's top grid and its number of cells (its virtual resolution,
    /// the finest level's cells per axis, is no cell count: a million cells per axis may
    /// hold a few hundred thousand cells).
    pub fn brief(&self) -> String {
        let [x, y, z] = self.resolution;
        match (self.kind, self.top_resolution) {
            (AccelKind::Irregular, Some([tx, ty, tz])) => {
                // Both resolutions, labelled: `--stats` reports them as `grid_top` and
                // `grid` (the finest cells', which the JSON had alone).
                format!(
                    "irregular grid (top {tx}x{ty}x{tz}, finest {x}x{y}x{z}, {} cells)",
                    self.cells
                )
            }
            (AccelKind::Bvh, _) => format!("4-wide BVH ({} nodes)", self.cells),
            _ => format!("{} grid {x}x{y}x{z}", self.kind.name()),
        }
    }

    /// [`AccelSummary::brief`], and for instances what the two levels hold.
    pub fn line(&self) -> String {
        match &self.instanced {
            Some(i) => format!("{}, instanced: {i}", self.brief()),
            None => self.brief(),
        }
    }
}

impl<'a> AccelRef<'a> {
    /// The grid this is, or the error saying a walk of cells (the GPU backend) cannot take
    /// the BVH.
    pub fn grid(self) -> Result<GridRef<'a>> {
        match self {
            AccelRef::Uniform(g) => Ok(GridRef::Uniform(g)),
            AccelRef::Irregular(g) => Ok(GridRef::Irregular(g)),
            // The packed grid: what the GPU walks, over the packed scene.
            AccelRef::GridInstanced(t) => Ok(GridRef::Uniform(&t.grid)),
            AccelRef::Bvh(_) | AccelRef::Instanced(_) => Err(crate::Error::Usage(
                "--accel bvh is walked on the CPU backend only: the GPU walks the grids \
                 (--accel irregular or uniform)"
                    .into(),
            )),
        }
    }

    /// Which structure this is.
    pub fn kind(&self) -> AccelKind {
        match self {
            AccelRef::Uniform(_) | AccelRef::GridInstanced(_) => AccelKind::Uniform,
            AccelRef::Irregular(_) => AccelKind::Irregular,
            AccelRef::Bvh(_) | AccelRef::Instanced(_) => AccelKind::Bvh,
        }
    }

    /// The figures `--stats` reports; `triangles` for the per-triangle memory.
    pub fn summary(&self, triangles: usize) -> AccelSummary {
        let per_tri = |b: usize| {
            if triangles == 0 {
                0.0
            } else {
                b as f64 / triangles as f64
            }
        };
        // A BVH, flat or the instances' top level over per-mesh BVHs.
        let bvh = |s: &bvh::BvhStats, detail: String| AccelSummary {
            kind: AccelKind::Bvh,
            resolution: [0; 3],
            top_resolution: None,
            build_ms: s.build_ms,
            bytes: s.bytes,
            bytes_per_triangle: per_tri(s.bytes),
            cells: s.nodes,
            empty_cells: 0,
            references: s.references,
            detail,
            instanced: None,
        };
        match self {
            AccelRef::Uniform(g) => AccelSummary {
                kind: AccelKind::Uniform,
                resolution: g.res,
                top_resolution: None,
                build_ms: g.stats.build_ms,
                bytes: g.stats.bytes,
                bytes_per_triangle: per_tri(g.stats.bytes),
                cells: g.stats.cells,
                empty_cells: g.stats.empty_cells,
                references: g.stats.references,
                detail: g.stats.to_string(),
                instanced: None,
            },
            AccelRef::Irregular(g) => AccelSummary {
                kind: AccelKind::Irregular,
                resolution: g.res,
                top_resolution: Some(g.top_res),
                build_ms: g.stats.build_ms,
                bytes: g.stats.bytes,
                bytes_per_triangle: g.stats.bytes_per_triangle,
                cells: g.stats.cells,
                empty_cells: g.stats.empty_cells,
                references: g.stats.references,
                detail: g.stats.to_string(),
                instanced: None,
            },
            AccelRef::Bvh(b) => bvh(&b.stats, b.stats.to_string()),
            AccelRef::Instanced(t) => AccelSummary {
                instanced: Some(t.holds()),
                ..bvh(&t.stats, t.detail(t.boxes.len()))
            },
            AccelRef::GridInstanced(t) => {
                let g = &t.grid;
                AccelSummary {
                    kind: AccelKind::Uniform,
                    resolution: g.res,
                    top_resolution: None,
                    build_ms: t.build_ms,
                    bytes: g.stats.bytes,
                    bytes_per_triangle: per_tri(g.stats.bytes),
                    cells: g.stats.cells,
                    empty_cells: g.stats.empty_cells,
                    references: g.stats.references,
                    detail: t.detail(),
                    instanced: Some(t.holds()),
                }
            }
        }
    }
}
