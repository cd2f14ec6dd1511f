//! Texel layout of the scene and the grid in RGBA32F textures: defined here, once, and
//! turned into the GLSL constants and fetch functions the shaders use
//! ([`SceneTextures::glsl`]), so the packing and the unpacking cannot drift apart.
//!
//! Every texture is a 2D array of texels addressed by a linear index i that wraps into rows
//! of a power-of-two width W (so the row `floor(i / W)` is exact in f32: dividing by a power of
//! two only changes the exponent; adding 0.5 first would round near 2^24), at most the GPU's
//! GL_MAX_TEXTURE_SIZE wide and high. `texture2D` samples a texel a quarter in from its left
//! edge ([`TEXEL_INSET`]), not at its centre: compilers may reassociate `(i - row W) + inset`
//! into `(i + inset) - row W` (Mesa's NIR does, where the product is used once), and
//! `i + 0.5` rounds to the even neighbour past 2^23, which read the next texel for every odd
//! index there; `i + 0.25` rounds to i, the texel's own edge, so either order reads it.
//!
//! Indices and counts are stored as floats, exact below 2^24. A scene whose texels or
//! references pass 2^24 is packed in the [`IndexFormat::Split`] format instead
//! (`SPLIT_INDEX` in the GLSL, compiled in only then, so smaller scenes keep their shaders
//! and images): list offsets split over two channels (hi * 2^24 + lo, exact to 2^48), the
//! ray's list cursor counted from its cell's first reference, and records fetched by
//! (record, texel) without forming their product; triangle and irregular cell ids are
//! float slots (exact floats past 2^24), voxel-map blocks start at exact floats. What
//! remains is the uniform grid's cell index (below 2^24), [`MAX_GPU_TRIANGLES`] and the
//! GPU's own limits, each refused with one line ([`SceneTextures::pack`]), the textures'
//! sizes from the counts before any is allocated ([`LayoutPlan`]).
//!
//! | texture | texels per item | contents |
//! |---|---|---|
//! | `tri` | 3 per triangle | (v0, material), (v1, has_normals), (v2, 0) |
//! | `nrm` | 3 per triangle | vertex normals n0, n1, n2 (only when the scene has any) |
//! | `mat` | 7 per material | see [`contract::mat`](super::contract::mat) |
//! | `cell` | 1 per uniform grid cell | (offset into `list`, count, 0, 0) |
//! | `cell` | 2 per irregular cell | (exit box lower corner, offset), (exit box upper corner, count) |
//! | `cell` | split: 1 per uniform cell | (offset lo, count, offset hi, 0) |
//! | `cell` | split: 3 per irregular cell | as above with offset lo, then (offset hi, 0, 0, 0) |
//! | `vmap` | 1 per 4 voxel-map entries | irregular grid only: cell id, or -(child block + 1) |
//! | `list` | 1 per 4 references | four triangle indices |
//! | `tex` | see [`TexLayout`] | textured scenes only: uv records, colours, texture table, texels |
//! | `inst` | see [`contract::instancing`](super::contract::instancing) | instanced scenes only: placements, meshes' grids, the threaded top tree |
//!
//! For the irregular grid the layout also generates `irr_lookup(k)`, the voxel-map descent
//! from a virtual cell to its cell id, unrolled hop by hop with the splits of each hop as
//! constants (no loop: the multipass kernel's programs have none). The map uploaded is the
//! built one with its levels merged into hops of several levels ([`WideMap`](crate::accel::irregular_wide::WideMap)), so a lookup
//! waits on fewer dependent reads; the cells are the built grid's.

pub(crate) mod dense;
mod irregular;
mod packed;
mod plan;
mod tex;

pub use dense::{DenseBuffer, DenseIrregular, DENSE_PAST_2_24_ENV};
pub use irregular::{IrregularLayout, HOP_BITS_ENV};
pub use packed::{texture_dims, PackedTexture};
pub use plan::{GridCounts, LayoutCounts, LayoutPlan, TEXEL_BYTES};
pub use tex::{TexLayout, TEX_REC};

use super::contract::{mat as slot, Field, Unit};
use super::split_index::check_indices;
pub use super::split_index::{
    check_triangles, float_slot, irregular_cell_texels, rec_coord, slot_coord, slot_record, split,
    split_coord, IndexFormat, MAX_EXACT_INDEX, MAX_GPU_TRIANGLES, MAX_SLOT_TEXELS, SPLIT_BASE,
    SPLIT_INDEX_ENV, TRI_SLOT_BANDS,
};
use crate::accel::{AccelRef, GridRef, IrregularGrid};
use crate::scene::{CheckerAxes, Scene};
use crate::{Error, Result};

/// Texels per triangle in `tri` and `nrm`.
pub const TRI_TEXELS: u32 = 3;
/// Texels per material; the slots are declared in [`contract::mat`](super::contract::mat).
pub const MAT_TEXELS: u32 = slot::TEXELS;
/// Entries per texel of an entry texture ([`PackedTexture::pack_entries`]: triangle indices
/// in `list`, voxel-map entries in `vmap`).
pub const LIST_PER_TEXEL: u32 = 4;
/// Where in its texel `texture2D` samples along a row, in texels from the left edge: an offset that still lands in the texel when a compiler adds it to the
/// linear index before subtracting the row (see the module's header); exact otherwise.
pub const TEXEL_INSET: f32 = 0.25;
/// Widest row used, even when the GPU allows wider: keeps textures compact for small
/// scenes and matches the limits of 2005-era cards.
pub const MAX_ROW: u32 = 4096;

/// How the generated `fetch_<name>(i)` functions read a texel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Fetch {
    /// `texture2D` at the texel's centre (GLSL 1.20: the fragment kernels).
    Texture2D,
    /// `texelFetch` at integer coordinates (GLSL 1.30+: the compute kernel).
    TexelFetch,
    /// A shader storage buffer of texels, the k-th texture at binding
    /// [`STORAGE_BINDING_BASE`] + k (GLSL 4.30: the compute kernel).
    Storage,
}

impl Fetch {
    /// The name `--stats` reports as `gpu.scene_fetch`: `texture2D`, or `texel-fetch` and
    /// `storage-buffer` as `--scene-fetch` spells them.
    pub fn name(self) -> &'static str {
        match self {
            Fetch::Texture2D => "texture2D",
            Fetch::TexelFetch => "texel-fetch",
            Fetch::Storage => "storage-buffer",
        }
    }
}

pub use super::contract::STORAGE_BINDING_BASE;

/// The scene and its grid, packed for upload.
#[derive(Clone, Debug)]
pub struct SceneTextures {
    /// Triangle vertices and material indices.
    pub tri: PackedTexture,
    /// Vertex normals (`None` when no triangle has them: compiled out).
    pub nrm: Option<PackedTexture>,
    /// Materials.
    pub mat: PackedTexture,
    /// The grid: float textures, or the compute kernel's integer buffers.
    pub grid: GridTextures,
    /// Texture coordinates, vertex colours and textures (`None` for a scene without
    /// textures and vertex colours: then no texture code is compiled).
    pub tex: Option<TexLayout>,
    /// An instanced scene's instancing data (`contract::instancing`: placements, meshes'
    /// grids, the threaded top tree), at the voxel map's unit, which the uniform grid the
    /// two levels use leaves free (`None` for a scene walked flat).
    pub inst: Option<PackedTexture>,
    /// How indices are written (and read by the GLSL).
    pub format: IndexFormat,
}

/// The grid's part of the layout.
#[derive(Clone, Debug)]
pub enum GridTextures {
    /// The float layout every fragment kernel reads (and the compute kernel on the uniform
    /// grid): the cell table, the triangle-index list and, for the irregular grid, its
    /// voxel map, as RGBA32F textures.
    Float {
        /// Cell table of the grid.
        cell: PackedTexture,
        /// Triangle-index list.
        list: PackedTexture,
        /// The irregular grid's voxel map and descent (`None` for the uniform grid).
        irregular: Option<IrregularLayout>,
    },
    /// The compute kernel's integer layout of the irregular grid (`DENSE_GRID`): storage
    /// buffers, uploaded from the grid ([`DenseIrregular`]).
    Dense(DenseIrregular),
}

/// Which kernels a layout is packed for: the float layout serves every kernel; the
/// compute kernel reads the irregular grid from integer buffers instead ([`GridTextures`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LayoutTarget {
    /// Textures of floats (GLSL 1.20 and up).
    Float,
    /// The compute kernel: the irregular grid dense, in `u32` storage buffers.
    Compute,
}

/// Environment variable that forces the compute kernel's read of an irregular grid:
/// `dense` or `float` ([`SceneTextures::compute_irregular`]; other values: the choice).
pub const GRID_LAYOUT_ENV: &str = "FRAGTRACE_GRID_LAYOUT";

/// Numeric code of a checker's axes in the material texture (and in GLSL).
pub fn axes_code(a: CheckerAxes) -> f32 {
    match a {
        CheckerAxes::Xy => 0.0,
        CheckerAxes::Xz => 1.0,
        CheckerAxes::Yz => 2.0,
    }
}

impl SceneTextures {
    /// Packs `scene` and `grid` for a GPU whose textures may be `max_size` texels wide/high;
    /// the vertex-normal texture only when the scene has vertex normals.
    pub fn pack<'a>(scene: &Scene, accel: impl Into<AccelRef<'a>>, max_size: u32) -> Result<Self> {
        Self::pack_with(scene, accel, max_size, scene.has_smooth_normals())
    }

    /// As [`SceneTextures::pack`], with the vertex-normal texture packed when `normals` is
    /// set even if no triangle has normals (all zero then): shaders built with every feature
    /// on (`--no-specialize`) fetch from it, behind the per-triangle flag.
    pub fn pack_with<'a>(
        scene: &Scene,
        accel: impl Into<AccelRef<'a>>,
        max_size: u32,
        normals: bool,
    ) -> Result<Self> {
        let accel = accel.into().grid()?;
        // The voxel map the GPU reads passes 2^24 entries exactly when the built one does
        // (`WideMap::for_gpu` widens hops only within 2^24).
        let (cells, refs, per_cell) = match accel {
            GridRef::Uniform(g) => (g.cells.len(), g.tri_indices.len(), 1),
            GridRef::Irregular(g) => (g.cells.len(), g.tri_indices.len().max(g.vmap.len()), 2),
        };
        let texels =
            (scene.triangles.len() as u64 * TRI_TEXELS as u64).max(cells as u64 * per_cell);
        let format = IndexFormat::needed(texels, refs as u64);
        Self::pack_format(scene, accel, max_size, normals, format)
    }

    /// As [`SceneTextures::pack_with`], in the index format given.
    pub fn pack_format<'a>(
        scene: &Scene,
        accel: impl Into<AccelRef<'a>>,
        max_size: u32,
        normals: bool,
        format: IndexFormat,
    ) -> Result<Self> {
        Self::pack_all(scene, accel, max_size, normals, format, None)
    }

    /// An instanced scene's two levels `gi` (`given`: the scene as loaded, its placements)
    /// packed as [`SceneTextures::pack_with`] packs the scene and grid they store, with the
    /// instancing data `inst` beside them (in `format` when given).
    pub fn pack_instanced(
        given: &Scene,
        gi: &crate::accel::grid_instances::GridInstances,
        max_size: u32,
        normals: bool,
        format: Option<IndexFormat>,
    ) -> Result<Self> {
        let data = super::contract::instancing::instancing_data(given, gi)?;
        let scene = &gi.packed;
        let texels =
            (scene.triangles.len() as u64 * TRI_TEXELS as u64).max(gi.grid.cells.len() as u64);
        let format =
            format.unwrap_or_else(|| IndexFormat::needed(texels, gi.grid.tri_indices.len() as u64));
        Self::pack_all(scene, &gi.grid, max_size, normals, format, Some(data))
    }

    fn pack_all<'a>(
        scene: &Scene,
        accel: impl Into<AccelRef<'a>>,
        max_size: u32,
        normals: bool,
        format: IndexFormat,
        inst: Option<Vec<[f32; 4]>>,
    ) -> Result<Self> {
        let accel = accel.into().grid()?;
        check_indices(scene, accel)?;
        let smooth = normals || scene.has_smooth_normals();
        // Every texture's size from the counts, refused before any is allocated (the
        // irregular grid's voxel map as the GPU reads it is built first: its size is part
        // of the plan).
        let (grid, wide) = match accel {
            GridRef::Uniform(g) => (
                GridCounts::Uniform {
                    cells: g.cells.len() as u64,
                    refs: g.tri_indices.len() as u64,
                },
                None,
            ),
            GridRef::Irregular(g) => {
                // The textures known from the counts alone are checked before the voxel
                // map is built for the GPU: on the 100-sphere scene (32.8 M triangles) that
                // build took seconds and gigabytes only to be refused on `cell`.
                let counts = GridCounts::Irregular {
                    cells: g.cells.len() as u64,
                    refs: g.tri_indices.len() as u64,
                    vmap_entries: 0,
                };
                LayoutPlan::new(&LayoutCounts::of(scene, counts, smooth, format))
                    .check(max_size, None)?;
                let w = IrregularLayout::wide_map(g, max_size);
                let vmap_entries = IrregularLayout::entries(&w, format);
                IrregularLayout::check_entries(vmap_entries, format)?;
                let counts = GridCounts::Irregular {
                    cells: g.cells.len() as u64,
                    refs: g.tri_indices.len() as u64,
                    vmap_entries,
                };
                (counts, Some(w))
            }
        };
        let plan = LayoutPlan::new(&LayoutCounts {
            inst_texels: inst.as_ref().map(|d| d.len() as u64),
            ..LayoutCounts::of(scene, grid, smooth, format)
        });
        plan.check(max_size, available_memory())?;
        let (tri, nrm, mat, tex) = pack_scene(scene, max_size, smooth)?;
        // Offsets as written: one float (exact below 2^24, checked above for Float), or hi
        // and lo.
        let off = |o: u32| match format {
            IndexFormat::Float => (o as f32, 0.0),
            IndexFormat::Split => {
                let (hi, lo) = split(o as u64);
                (lo, hi)
            }
        };
        let (cell, tri_indices, irregular) = match (accel, wide) {
            (GridRef::Uniform(grid), _) => (
                grid.cells
                    .iter()
                    .map(|c| {
                        let (lo, hi) = off(c.offset);
                        [lo, c.count as f32, hi, 0.0]
                    })
                    .collect::<Vec<_>>(),
                &grid.tri_indices,
                None,
            ),
            (GridRef::Irregular(g), wide) => {
                let f = |v: [u32; 3], w: f32| [v[0] as f32, v[1] as f32, v[2] as f32, w];
                // Cell k at its float slot (k itself below 2^24: the Float format's only).
                let per = format.irregular_cell_texels() as usize;
                let texels = irregular_cell_texels(g.cells.len() as u64, format);
                let mut cell = vec![[0f32; 4]; texels as usize];
                for (k, c) in g.cells.iter().enumerate() {
                    let (lo, hi) = off(c.range.offset);
                    let at = &mut cell[float_slot(k as u64) as usize * per..][..per];
                    at[0] = f(c.exit_lo, lo);
                    at[1] = f(c.exit_hi, c.range.count as f32);
                    if format == IndexFormat::Split {
                        at[2] = [hi, 0.0, 0.0, 0.0];
                    }
                }
                (
                    cell,
                    &g.tri_indices,
                    Some(IrregularLayout::pack(
                        g,
                        wide.unwrap_or_else(|| IrregularLayout::wide_map(g, max_size)),
                        max_size,
                        format,
                    )?),
                )
            }
        };
        // Triangle ids as float slots: the index itself below 2^24 (the Float format's only).
        let list: Vec<f32> = tri_indices
            .iter()
            .map(|&i| float_slot(i as u64) as f32)
            .collect();
        let cell_texels = cell.len() as u64;
        if format == IndexFormat::Float {
            let need = [
                (
                    "triangle texels",
                    scene.triangles.len() as u64 * TRI_TEXELS as u64,
                ),
                ("cell texels", cell_texels),
                ("triangle references", list.len() as u64),
            ];
            if let Some((what, n)) = need.iter().find(|(_, n)| *n > MAX_EXACT_INDEX) {
                return Err(Error::Internal(format!(
                    "{n} {what} packed with one float per index (exact to 2^24)"
                )));
            }
        }
        let packed = SceneTextures {
            tri,
            nrm,
            mat,
            grid: GridTextures::Float {
                cell: PackedTexture::pack("cell", cell, max_size)?,
                list: PackedTexture::pack_entries("list", &list, max_size)?,
                irregular,
            },
            tex,
            inst: match inst {
                Some(d) => Some(PackedTexture::pack("inst", d, max_size)?),
                None => None,
            },
            format,
        };
        packed.check_plan(&plan, max_size)?;
        Ok(packed)
    }

    /// The compute kernel's layout of `scene` over the irregular grid `g`: the scene's
    /// textures as the float layout packs them, in the index format its triangles need, and
    /// the grid as integer storage buffers ([`DenseIrregular`]) of at most `block_bytes`
    /// each (GL_MAX_SHADER_STORAGE_BLOCK_SIZE), uploaded from the grid itself; every size
    /// checked from the counts first ([`LayoutPlan`]).
    pub fn pack_dense(
        scene: &Scene,
        g: &IrregularGrid,
        max_size: u32,
        normals: bool,
        block_bytes: u64,
    ) -> Result<Self> {
        check_triangles(scene.triangles.len())?;
        let smooth = normals || scene.has_smooth_normals();
        let format = IndexFormat::needed(scene.triangles.len() as u64 * TRI_TEXELS as u64, 0);
        let map = DenseIrregular::wide_map(g, max_size, block_bytes);
        let ref_base = DenseIrregular::ref_base_from_env();
        let (cells, refs, entries) = (
            g.cells.len() as u64,
            g.tri_indices.len() as u64,
            map.vmap.len() as u64,
        );
        let max_count = g.cells.iter().map(|c| c.range.count).max().unwrap_or(0);
        let ref_words = ref_base as u64 + refs;
        DenseIrregular::check(cells, ref_words, entries, max_count as u64, block_bytes)?;
        let counts = GridCounts::Dense {
            cells,
            refs: ref_words,
            vmap_entries: entries,
        };
        let plan = LayoutPlan::new(&LayoutCounts::of(scene, counts, smooth, format));
        plan.check(max_size, available_memory())?;
        let (tri, nrm, mat, tex) = pack_scene(scene, max_size, smooth)?;
        let packed = SceneTextures {
            tri,
            nrm,
            mat,
            grid: GridTextures::Dense(DenseIrregular {
                map,
                cells,
                refs,
                ref_base,
                skew_faces: false,
            }),
            tex,
            inst: None,
            format,
        };
        packed.check_plan(&plan, max_size)?;
        Ok(packed)
    }

    /// The layout of `scene` over `accel` for `target`: for the compute kernel over an
    /// irregular grid, [`SceneTextures::compute_irregular`]'s choice between the float
    /// layout and the dense one ([`SceneTextures::pack_dense`], buffers of at most
    /// `block_bytes`), else the float layout ([`SceneTextures::pack_with`]).
    pub fn pack_for<'a>(
        scene: &Scene,
        accel: impl Into<AccelRef<'a>>,
        max_size: u32,
        normals: bool,
        target: LayoutTarget,
        block_bytes: u64,
    ) -> Result<Self> {
        let accel = accel.into().grid()?;
        match (target, accel) {
            (LayoutTarget::Compute, GridRef::Irregular(g)) => Self::compute_irregular(
                || Self::pack_with(scene, accel, max_size, normals),
                || Self::pack_dense(scene, g, max_size, normals, block_bytes),
            ),
            (LayoutTarget::Compute | LayoutTarget::Float, _) => {
                Self::pack_with(scene, accel, max_size, normals)
            }
        }
    }

    /// The one choice of the layout the compute kernel reads an irregular grid through:
    /// the `float` one (the fragment kernels') where it fits, the `dense` one where it does
    /// not (a float texture past GL_MAX_TEXTURE_SIZE, or memory: the dense grid takes about
    /// a third of the bytes). Float first because it is the faster read: on the H200 the
    /// bunny's equal-work 4096² kernel took 8.79 ms through it against 9.76 ms through the
    /// dense buffers (2026-12-06, `FRAGTRACE_DENSE_BLOCK_BYTES=1` against the default of
    /// f65056a). Where neither fits, the refusal names both. [`GRID_LAYOUT_ENV`] forces one
    /// (tests: the dense read on scenes the float layout holds).
    pub fn compute_irregular(
        float: impl FnOnce() -> Result<Self>,
        dense: impl FnOnce() -> Result<Self>,
    ) -> Result<Self> {
        match std::env::var(GRID_LAYOUT_ENV).as_deref() {
            Ok("dense") => return dense(),
            Ok("float") => return float(),
            _ => {}
        }
        match float() {
            Err(Error::Limit(f)) => dense().map_err(|d| match d {
                Error::Limit(d) => {
                    Error::Limit(format!("{d}; the float layout does not fit either: {f}"))
                }
                other => other,
            }),
            packed => packed,
        }
    }

    /// What was checked is what was packed: every texture as the plan sized it.
    fn check_plan(&self, plan: &LayoutPlan, max_size: u32) -> Result<()> {
        for t in self.all() {
            let counted = plan.textures.iter().find(|&&(n, _)| n == t.name);
            let want = counted.map(|&(_, n)| texture_dims(n, max_size));
            if want != Some((t.width, t.height as u64)) {
                return Err(Error::Internal(format!(
                    "texture `{}` packed {}x{} where the plan counted {want:?}",
                    t.name, t.width, t.height
                )));
            }
        }
        Ok(())
    }

    /// The grid's layout as `--stats` names it (`gpu.grid_layout`): `float` or `dense`.
    pub fn grid_name(&self) -> &'static str {
        match self.grid {
            GridTextures::Float { .. } => "float",
            GridTextures::Dense(_) => "dense",
        }
    }

    /// The float layout's cell table (`None` for the dense grid).
    pub fn cell(&self) -> Option<&PackedTexture> {
        match &self.grid {
            GridTextures::Float { cell, .. } => Some(cell),
            GridTextures::Dense(_) => None,
        }
    }

    /// The float layout's triangle-index list (`None` for the dense grid).
    pub fn list(&self) -> Option<&PackedTexture> {
        match &self.grid {
            GridTextures::Float { list, .. } => Some(list),
            GridTextures::Dense(_) => None,
        }
    }

    /// The float layout's cell table and triangle-index list, to replace (tests that
    /// read synthetic texels through the generated fetches).
    pub fn float_grid_mut(&mut self) -> Option<(&mut PackedTexture, &mut PackedTexture)> {
        match &mut self.grid {
            GridTextures::Float { cell, list, .. } => Some((cell, list)),
            GridTextures::Dense(_) => None,
        }
    }

    /// The float layout's voxel map of the irregular grid (`None` otherwise).
    pub fn irregular(&self) -> Option<&IrregularLayout> {
        match &self.grid {
            GridTextures::Float { irregular, .. } => irregular.as_ref(),
            GridTextures::Dense(_) => None,
        }
    }

    /// The compute kernel's integer layout of the irregular grid (`None` otherwise).
    pub fn dense(&self) -> Option<&DenseIrregular> {
        match &self.grid {
            GridTextures::Dense(d) => Some(d),
            GridTextures::Float { .. } => None,
        }
    }

    /// Tests only: the irregular grid's walk compiled with every face crossing moved by
    /// about an ulp (`SKEW_FACES`), in either layout.
    pub fn skew_faces(&mut self) {
        match &mut self.grid {
            GridTextures::Float {
                irregular: Some(i), ..
            } => i.skew_faces = true,
            GridTextures::Dense(d) => d.skew_faces = true,
            GridTextures::Float {
                irregular: None, ..
            } => {}
        }
    }

    /// All textures, in binding order.
    pub fn all(&self) -> Vec<&PackedTexture> {
        self.with_units().into_iter().map(|(_, t)| t).collect()
    }

    /// All textures with the unit each is bound to.
    pub fn with_units(&self) -> Vec<(Unit, &PackedTexture)> {
        let mut v = vec![(Unit::Tri, &self.tri), (Unit::Mat, &self.mat)];
        if let GridTextures::Float { cell, list, .. } = &self.grid {
            v.push((Unit::Cell, cell));
            v.push((Unit::List, list));
        }
        if let Some(n) = &self.nrm {
            v.push((Unit::Nrm, n));
        }
        if let Some(i) = self.irregular() {
            v.push((Unit::Vmap, &i.vmap));
        }
        if let Some(t) = &self.tex {
            v.push((Unit::Tex, &t.texture));
        }
        if let Some(t) = &self.inst {
            v.push((Unit::Vmap, t));
        }
        v
    }

    /// GLSL 1.20 declarations of every texture and the layout constants.
    pub fn glsl(&self) -> String {
        self.glsl_with(Fetch::Texture2D)
    }

    /// GLSL declarations of every texture and the layout constants, fetching through `fetch`.
    pub fn glsl_with(&self, fetch: Fetch) -> String {
        let mut s = format!(
            "#define TRI_TEXELS {TRI_TEXELS}.0\n#define MAT_TEXELS {MAT_TEXELS}.0\n\
             #define CELL_TEXELS {}.0\n",
            self.format.irregular_cell_texels()
        );
        s.push_str(&self.format.glsl());
        // The list cursor: from the list's start, or (split, dense) from the cell's first
        // reference, whose offset the cell holds.
        s.push_str(match (&self.grid, self.format) {
            (GridTextures::Float { .. }, IndexFormat::Float) => {
                "// Cursor from the list's start (one float, exact below 2^24).\n\
                 #define CURSOR_FIRST(offset) (offset)\n\
                 #define CURSOR_END_OF(offset, count) ((offset) + (count))\n"
            }
            (GridTextures::Dense(_), _) | (GridTextures::Float { .. }, IndexFormat::Split) => {
                "// Cursor from the cell's first reference (split: list_at; dense: g_cell_first).\n\
                 #define CURSOR_FIRST(offset) 0.0\n\
                 #define CURSOR_END_OF(offset, count) (count)\n"
            }
        });
        let all = self.all();
        for (k, t) in all.iter().enumerate() {
            s.push_str(&t.glsl_format(fetch, STORAGE_BINDING_BASE + k as u32, self.format));
        }
        match &self.grid {
            GridTextures::Float {
                irregular: Some(i), ..
            } => s.push_str(&i.glsl()),
            GridTextures::Float {
                irregular: None, ..
            } => {}
            // After every texture's storage blocks (the list's and voxel map's float views
            // are the float layout's only).
            GridTextures::Dense(d) => {
                s.push_str(&d.glsl(STORAGE_BINDING_BASE + all.len() as u32));
            }
        }
        if let Some(t) = &self.tex {
            s.push_str(&t.glsl(fetch));
        }
        if self.inst.is_some() {
            // The fragment passes learn that the scene is instanced here (the compute
            // kernel from its spec as well).
            s.push_str("#ifndef INSTANCED\n#define INSTANCED\n#endif\n");
            s.push_str(&super::contract::instancing::instancing_glsl());
        }
        s
    }

    /// Storage blocks the textures take under [`Fetch::Storage`]: one per texture, and the
    /// float views the kernels read entries through (the list's, the voxel map's).
    /// The dense grid's buffers follow the textures' blocks, under either fetch.
    pub fn storage_blocks(&self) -> u32 {
        let textures = self.all().len() as u32;
        match &self.grid {
            GridTextures::Float { irregular, .. } => textures + 1 + u32::from(irregular.is_some()),
            GridTextures::Dense(_) => textures + DenseBuffer::ALL.len() as u32,
        }
    }

    /// The storage binding of the dense grid's buffer `b` (its layout only).
    pub fn dense_binding(&self, b: DenseBuffer) -> u32 {
        let k = DenseBuffer::ALL.iter().position(|&x| x == b).unwrap_or(0);
        STORAGE_BINDING_BASE + self.all().len() as u32 + k as u32
    }

    /// Total bytes of the textures (the dense grid's buffers: [`SceneTextures::dense_bytes`]).
    pub fn bytes(&self) -> usize {
        self.all().iter().map(|t| t.bytes()).sum()
    }

    /// Bytes of the dense grid's buffers (0 for the float layout).
    pub fn dense_bytes(&self) -> u64 {
        match &self.grid {
            GridTextures::Dense(d) => DenseBuffer::ALL
                .iter()
                .map(|b| {
                    b.elements(d.cells, d.ref_words(), d.map.vmap.len() as u64) * b.element_bytes()
                })
                .sum(),
            GridTextures::Float { .. } => 0,
        }
    }
}

/// The host memory the size check weighs a layout against (the browser tells a page
/// nothing of it: there the driver refuses).
fn available_memory() -> Option<u64> {
    #[cfg(not(target_arch = "wasm32"))]
    return crate::memory::available_bytes();
    #[cfg(target_arch = "wasm32")]
    None
}

/// The scene's textures every layout packs alike: triangles, vertex normals (when
/// `smooth`), materials, and texture coordinates with their images.
#[allow(clippy::type_complexity)]
fn pack_scene(
    scene: &Scene,
    max_size: u32,
    smooth: bool,
) -> Result<(
    PackedTexture,
    Option<PackedTexture>,
    PackedTexture,
    Option<TexLayout>,
)> {
    let n_tris = scene.triangles.len();
    let mut tri = Vec::with_capacity(n_tris * 3);
    let mut nrm = Vec::with_capacity(if smooth { n_tris * 3 } else { 0 });
    for (i, t) in scene.triangles.iter().enumerate() {
        let v = scene.triangle_vertices(i);
        let has_n = t.has_normals();
        tri.push([v[0].x, v[0].y, v[0].z, t.material as f32]);
        tri.push([v[1].x, v[1].y, v[1].z, if has_n { 1.0 } else { 0.0 }]);
        tri.push([v[2].x, v[2].y, v[2].z, 0.0]);
        if smooth {
            for k in 0..3 {
                let n = if has_n {
                    scene.normals[t.n[k] as usize]
                } else {
                    glam::Vec3::ZERO
                };
                nrm.push([n.x, n.y, n.z, 0.0]);
            }
        }
    }
    let tex = TexLayout::pack(scene, max_size)?;
    let mut mat = vec![[0f32; 4]; scene.materials.len() * MAT_TEXELS as usize];
    for (i, m) in scene.materials.iter().enumerate() {
        let (ca, cb, scale, axes, phase) = match &m.checker {
            Some(c) => (c.color_a, c.color_b, c.scale, axes_code(c.axes), c.phase),
            None => (glam::Vec3::ZERO, glam::Vec3::ZERO, 0.0, 0.0, [0.0; 2]),
        };
        let texels = &mut mat[i * MAT_TEXELS as usize..][..MAT_TEXELS as usize];
        let mut put = |f: Field, v: &[f32]| {
            texels[f.texel][f.first..f.first + f.len].copy_from_slice(v);
        };
        put(slot::ALBEDO, &m.albedo.to_array());
        put(slot::KA, &[m.ka]);
        put(slot::KS, &m.ks.to_array());
        put(slot::NS, &[m.ns]);
        put(slot::KR, &m.kr.to_array());
        put(slot::KD, &[m.kd]);
        put(slot::KT, &m.kt.to_array());
        put(slot::IOR, &[m.ior]);
        put(slot::CHECKER_A, &ca.to_array());
        put(slot::CHECKER_SCALE, &[scale]);
        put(slot::CHECKER_B, &cb.to_array());
        put(slot::CHECKER_AXES, &[axes]);
        put(slot::FRESNEL, &[if m.fresnel { 1.0 } else { 0.0 }]);
        put(slot::CHECKER_PHASE, &phase);
        if let (Some(k), Some(t)) = (m.diffuse_map, &tex) {
            // `M6_MAP_KD`: the texture's header, plus one (zero: no texture).
            put(slot::PAD, &[t.headers[k as usize] as f32 + 1.0]);
        }
    }
    let slots = |t: PackedTexture| PackedTexture { slots: true, ..t };
    let tri = slots(PackedTexture::pack("tri", tri, max_size)?);
    let nrm = if smooth {
        Some(slots(PackedTexture::pack("nrm", nrm, max_size)?))
    } else {
        None
    };
    Ok((tri, nrm, PackedTexture::pack("mat", mat, max_size)?, tex))
}

#[cfg(test)]
mod tests;
