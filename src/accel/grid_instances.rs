//! The two-level structure of a scene with instances (`scene/instance.rs`) for the GPU's
//! kernels (`glsl120/instance.glsl`, `instance_walk.glsl`): a uniform grid over the scene's own
//! triangles, one uniform grid per instanced mesh in its object space (built once however
//! many times the mesh is placed), and the CPU's top BVH over the instances' local-space
//! boxes (`Bvh::over_boxes`, as `accel/instances.rs` builds it: the top level is then the
//! same tree on both backends, logarithmic in instances; the GPU walks it threaded,
//! without a stack: `gpu/contract/instancing.rs`). Memory grows with the meshes' triangles and the instances, not with the
//! triangles they place.
//!
//! What the GPU packs is one scene and one grid ([`GridInstances::packed`],
//! [`GridInstances::grid`]): the scene's own triangles first (their ids are their indices),
//! then each mesh's triangles in object space; the own grid's cells, then each mesh grid's
//! cells, their references pointing at the packed triangles. So the scene textures and
//! their fetches are the flat scene's, and a mesh walk differs from the own walk only by
//! its grid's box, resolution and first cell ([`MeshGrid`]).

use glam::Vec3;
use std::time::Instant;

use super::bvh::Bvh;
use super::grid::{CellRange, Grid, GridConfig};
use crate::scene::Scene;
use crate::{Error, Result};

/// SAH cost of a top-level node visit, in instance walks (as `accel/instances.rs`).
const TOP_NODE_COST: f32 = 0.1;

/// One instanced mesh's grid within the packed grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshGrid {
    /// Its grid's box, in object space.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
    /// Cell size per axis.
    pub cell_size: Vec3,
    /// Cells per axis.
    pub res: [u32; 3],
    /// Index of its first cell in the packed grid's cells.
    pub cell_base: u32,
    /// Index of its first triangle in the packed scene.
    pub tri_base: u32,
    /// Its triangles.
    pub triangles: u32,
    /// Its grid's (cell, triangle) references.
    pub references: u32,
}

/// The levels (see the module documentation).
#[derive(Clone, Debug)]
pub struct GridInstances {
    /// The scene's own triangles, then every mesh's in object space (materials, lights and
    /// camera the scene's; no instances).
    pub packed: Scene,
    /// The own grid (its box and resolution), with every mesh grid's cells and references
    /// appended.
    pub grid: Grid,
    /// Each mesh's grid.
    pub meshes: Vec<MeshGrid>,
    /// Over the instances' boxes: its leaves' indices are instance indices.
    pub top: Bvh,
    /// Instances placed.
    pub instances: usize,
    /// Triangles the instances place (each mesh counted once per instance).
    pub placed: u64,
    /// Wall-clock build time of all levels, in milliseconds.
    pub build_ms: f64,
}

impl GridInstances {
    /// Builds the levels of `scene` (its grids with `cfg`, the meshes' in parallel).
    pub fn build(scene: &Scene, cfg: &GridConfig) -> Result<GridInstances> {
        use rayon::prelude::*;
        let t0 = Instant::now();
        let inst = &scene.instancing;
        let (own, grids) = rayon::join(
            || Grid::build(scene, cfg),
            || {
                inst.meshes
                    .par_iter()
                    .map(|m| Grid::build(&m.geometry, cfg))
                    .collect::<Result<Vec<_>>>()
            },
        );
        let (mut grid, grids) = (own?, grids?);
        let mut packed = scene.clone();
        packed.instancing = Default::default();
        let mut meshes = Vec::with_capacity(grids.len());
        let too_many = |what: &str| {
            Error::Limit(format!(
                "{}: the instanced meshes' {what} pass 2^32; place smaller meshes, or render \
                 with --backend cpu --accel bvh",
                scene.source
            ))
        };
        // Texture coordinates and vertex colours as `Scene::flattened` stores them (once
        // any triangle has them, every triangle and position), but each mesh's once, in
        // object space: the kernels read a hit's by its packed triangle, in the placed
        // winding (`glsl120/instance.glsl`).
        let uvs = !packed.tri_uvs.is_empty()
            || inst.meshes.iter().any(|m| !m.geometry.tri_uvs.is_empty());
        let colors = scene.has_vertex_colors();
        if uvs {
            packed
                .tri_uvs
                .resize(packed.triangles.len(), [crate::scene::NO_UV; 3]);
        }
        if colors {
            packed.colors.resize(packed.positions.len(), Vec3::ONE);
        }
        for (m, g) in inst.meshes.iter().zip(&grids) {
            let geo = &m.geometry;
            if uvs {
                let ubase = packed.uvs.len() as u32;
                if geo.tri_uvs.is_empty() {
                    packed.tri_uvs.extend(std::iter::repeat_n(
                        [crate::scene::NO_UV; 3],
                        geo.triangles.len(),
                    ));
                } else {
                    packed.tri_uvs.extend(geo.tri_uvs.iter().map(|t| {
                        if t[0] == crate::scene::NO_UV {
                            *t
                        } else {
                            t.map(|k| k + ubase)
                        }
                    }));
                }
                packed.uvs.extend_from_slice(&geo.uvs);
            }
            if colors {
                if geo.colors.is_empty() {
                    packed
                        .colors
                        .extend(std::iter::repeat_n(Vec3::ONE, geo.positions.len()));
                } else {
                    packed.colors.extend_from_slice(&geo.colors);
                }
            }
            let tri_base =
                u32::try_from(packed.triangles.len()).map_err(|_| too_many("triangles"))?;
            let cell_base = u32::try_from(grid.cells.len()).map_err(|_| too_many("cells"))?;
            let list_base =
                u32::try_from(grid.tri_indices.len()).map_err(|_| too_many("references"))?;
            let (vbase, nbase) = (packed.positions.len() as u32, packed.normals.len() as u32);
            packed.positions.extend_from_slice(&geo.positions);
            packed.normals.extend_from_slice(&geo.normals);
            packed.triangles.extend(geo.triangles.iter().map(|t| {
                let mut t = *t;
                t.v = t.v.map(|v| v + vbase);
                if t.has_normals() {
                    t.n = t.n.map(|n| n + nbase);
                }
                t
            }));
            grid.cells.extend(g.cells.iter().map(|c| CellRange {
                offset: c.offset + list_base,
                count: c.count,
            }));
            grid.tri_indices
                .extend(g.tri_indices.iter().map(|&i| i + tri_base));
            meshes.push(MeshGrid {
                min: g.min,
                max: g.max,
                cell_size: g.cell_size,
                res: g.res,
                cell_base,
                tri_base,
                triangles: geo.triangles.len() as u32,
                references: g.tri_indices.len() as u32,
            });
        }
        let boxes: Vec<(Vec3, Vec3)> = inst
            .instances
            .iter()
            .map(|i| {
                let m = &meshes[i.mesh as usize];
                i.bounds(m.min, m.max)
            })
            .collect();
        let top = Bvh::over_boxes(&boxes, TOP_NODE_COST)?;
        // The grid's figures: all levels' cells and references together.
        let s = &mut grid.stats;
        s.cells = grid.cells.len();
        s.empty_cells = grid.cells.iter().filter(|c| c.count == 0).count();
        s.empty_fraction = s.empty_cells as f64 / s.cells.max(1) as f64;
        s.references = grid.tri_indices.len();
        s.bytes = s.cells * 8 + s.references * 4;
        let build_ms = t0.elapsed().as_secs_f64() * 1e3;
        s.build_ms = build_ms;
        Ok(GridInstances {
            packed,
            grid,
            meshes,
            top,
            instances: inst.instances.len(),
            placed: inst.triangles(),
            build_ms,
        })
    }

    /// Triangles stored: the scene's own and each mesh's once.
    pub fn stored(&self) -> usize {
        self.packed.triangles.len()
    }

    /// What the levels hold (`AccelSummary::instanced`).
    pub fn holds(&self) -> String {
        crate::scene::Instancing::holds(
            self.instances,
            self.meshes.len(),
            self.stored(),
            self.placed,
        )
    }

    /// The stats line: what instancing holds and the grids' figures.
    pub fn detail(&self) -> String {
        format!("instanced: {}; {}", self.holds(), self.grid.stats)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The packed levels hold the scene's own triangles first, then each mesh's once in
    /// object space; each mesh grid's cells lie after the own grid's and list only that
    /// mesh's packed triangles, as its own grid lists them; the top tree's leaves hold
    /// every instance once.
    #[test]
    fn packed_levels_keep_each_mesh_apart() {
        let toml = r#"
[camera]
eye = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
fov = 40
[[objects]]
shape = "quad"
[[objects]]
shape = "sphere"
subdivisions = 1
instances = [{ translate = [1, 0, 0] }, { scale = [-1, 2, 1] }, { translate = [0, 3, 0] }]
[[objects]]
shape = "box"
instances = [{ translate = [-2, 0, 0] }]
"#;
        let s = crate::scene::load_scene_str(toml, "t.toml", std::path::Path::new(".")).unwrap();
        let cfg = GridConfig::default();
        let gi = GridInstances::build(&s, &cfg).unwrap();
        let own = Grid::build(&s, &cfg).unwrap();
        assert_eq!(gi.grid.res, own.res);
        assert_eq!(gi.grid.cells[..own.cells.len()], own.cells[..]);
        assert_eq!(gi.packed.triangles.len(), s.triangles.len() + 80 + 12);
        for (m, mg) in s.instancing.meshes.iter().zip(&gi.meshes) {
            let g = Grid::build(&m.geometry, &cfg).unwrap();
            assert_eq!((mg.min, mg.max, mg.res), (g.min, g.max, g.res));
            for (k, c) in g.cells.iter().enumerate() {
                let p = gi.grid.cells[mg.cell_base as usize + k];
                let listed = &gi.grid.tri_indices[p.offset as usize..][..p.count as usize];
                let cell = &g.tri_indices[c.offset as usize..][..c.count as usize];
                let want: Vec<u32> = cell.iter().map(|&i| i + mg.tri_base).collect();
                assert_eq!((p.count, listed), (c.count, &want[..]));
            }
            for i in 0..mg.triangles as usize {
                let packed = gi.packed.triangle_vertices(mg.tri_base as usize + i);
                assert_eq!(packed, m.geometry.triangle_vertices(i));
            }
        }
        let mut leaves = gi.top.tri_indices.clone();
        leaves.sort_unstable();
        assert_eq!(leaves, (0..4).collect::<Vec<u32>>());
        assert!(gi
            .detail()
            .starts_with("instanced: 4 instances of 2 meshes, 94 triangles stored"));
    }
}
