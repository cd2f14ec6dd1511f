//! Instancing: one mesh stored once and placed many times, each placement ([`Instance`])
//! an affine transform from the mesh's object space to the scene's local space. The CPU's
//! BVH walks instances as a two-level structure (`accel/instances.rs`,
//! `cpu/traverse_instances.rs`), and so does the GPU's compute kernel over uniform grids
//! (`accel/grid_instances.rs`, `glsl120/instance.glsl`); every other structure and GPU
//! kernel renders [`Scene::flattened`], the same triangles stored once per instance.
//!
//! Primitive ids: an instanced triangle has the id it would have in the flattened scene:
//! the scene's own triangles first (`0 .. triangles.len()`), then each instance's mesh
//! triangles in instance order ([`Instance::first`]). The tie rule between equally close
//! hits (lower id wins) is therefore "the scene's own triangles, then instances in file
//! order, then triangles in mesh order", on every path, and the `primid` AOV of an
//! instanced scene is its flattened scene's. Ids are 32-bit: at most 2^32 - 1 triangles
//! once instanced (4.29 billion).
//!
//! One rounding decides both the two-level shading and the flattened scene: a world
//! vertex is [`Instance::point`] of its f32 object-space vertex (the product in f64,
//! rounded once), a world normal [`Instance::normal`] (the inverse transpose in f64,
//! renormalised, rounded once), so a hit shades on the very triangle the flattened scene
//! stores; only the hit's t and barycentrics, computed in object space, differ by rounding.

use glam::{DMat3, DVec3, Vec2, Vec3};

use super::{Scene, Triangle};
use crate::{Error, Result};

/// A mesh that instances place: its geometry in object space, its triangles' materials
/// indices into the owning scene's [`Scene::materials`] (and so its textures the owning
/// scene's [`Scene::textures`]). Held as a [`Scene`] of geometry alone (positions, normals,
/// triangles, and where the mesh has them texture coordinates and vertex colours; no
/// camera, lights, materials or textures) so that the BVH build and walk take it as they
/// take a scene.
#[derive(Clone, Debug)]
pub struct Mesh {
    /// What placed it (`objects[3]`), for messages.
    pub name: String,
    /// The geometry, in object space.
    pub geometry: Scene,
}

/// One placement of a mesh: `p_local = linear · p + translate` (local space: the scene's
/// world minus [`Scene::origin`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// Index into [`Instancing::meshes`].
    pub mesh: u32,
    /// The linear part (scale, then rotation).
    pub linear: DMat3,
    /// The translation, relative to the scene's local origin.
    pub translate: DVec3,
    /// `linear`'s inverse: rays into object space.
    pub inverse: DMat3,
    /// `linear`'s inverse transpose: normals to local space.
    pub normal_matrix: DMat3,
    /// Primitive id of the mesh's first triangle here (see the module documentation).
    pub first: u32,
}

impl Instance {
    /// The placement `linear`, `translate` of mesh `mesh` (its `first` id set later by
    /// [`Instancing::number`]); `None` when `linear` is singular or not finite.
    pub fn new(mesh: u32, linear: DMat3, translate: DVec3) -> Option<Instance> {
        let det = linear.determinant();
        if !(det.is_finite() && det != 0.0 && translate.is_finite()) {
            return None;
        }
        let inverse = linear.inverse();
        Some(Instance {
            mesh,
            linear,
            translate,
            inverse,
            normal_matrix: inverse.transpose(),
            first: 0,
        })
    }

    /// True when the placement mirrors (negative determinant): the flattened triangle's
    /// winding is then reversed, so that its geometric normal still points outward.
    pub fn mirrors(&self) -> bool {
        self.linear.determinant() < 0.0
    }

    /// An object-space vertex in local space, in f64.
    pub fn point_f64(&self, p: Vec3) -> DVec3 {
        self.linear * p.as_dvec3() + self.translate
    }

    /// An object-space vertex in local space, rounded once to f32.
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.point_f64(p).as_vec3()
    }

    /// A unit object-space normal in local space: the inverse transpose, renormalised.
    pub fn normal(&self, n: Vec3) -> Vec3 {
        self.normal_f64(n).as_vec3()
    }

    /// [`Instance::normal`] before its rounding to f32.
    pub fn normal_f64(&self, n: Vec3) -> DVec3 {
        (self.normal_matrix * n.as_dvec3()).normalize()
    }

    /// A local-space ray (origin, direction) in object space, in f64: the same parameter
    /// t reaches the same point in both (the direction is not renormalised).
    pub fn ray_to_object(&self, o: DVec3, d: DVec3) -> (DVec3, DVec3) {
        (self.inverse * (o - self.translate), self.inverse * d)
    }

    /// The local-space box of the object-space box `lo..hi`: its eight corners placed,
    /// widened by a relative 1e-6 (and 1e-30 absolute) so that the f32 box holds every
    /// placed triangle whatever the roundings.
    pub fn bounds(&self, lo: Vec3, hi: Vec3) -> (Vec3, Vec3) {
        let (mut a, mut b) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for k in 0..8 {
            let c = Vec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            let p = self.point_f64(c);
            a = a.min(p);
            b = b.max(p);
        }
        let pad = (b - a).max(a.abs().max(b.abs())) * 1e-6 + DVec3::splat(1e-30);
        ((a - pad).as_vec3(), (b + pad).as_vec3())
    }
}

/// The meshes a scene places by instances and their placements (both empty for a scene
/// without instances).
#[derive(Clone, Debug, Default)]
pub struct Instancing {
    /// The meshes.
    pub meshes: Vec<Mesh>,
    /// The placements, in file order.
    pub instances: Vec<Instance>,
}

impl Instancing {
    /// True when the scene has no instances.
    pub fn is_empty(&self) -> bool {
        self.instances.is_empty()
    }

    /// Triangles of all instances together (each mesh counted once per instance).
    pub fn triangles(&self) -> u64 {
        self.instances
            .iter()
            .map(|i| self.meshes[i.mesh as usize].geometry.triangles.len() as u64)
            .sum()
    }

    /// Gives each instance its [`Instance::first`] id after the scene's `own` triangles;
    /// refuses more than 2^32 - 1 triangles in all.
    pub fn number(&mut self, own: usize, source: &str) -> Result<()> {
        let mut next = own as u64;
        for inst in &mut self.instances {
            inst.first = next as u32;
            next += self.meshes[inst.mesh as usize].geometry.triangles.len() as u64;
        }
        if next >= u32::MAX as u64 {
            return Err(Error::Limit(format!(
                "{source}: {next} triangles once instanced; primitive ids are 32-bit, so at \
                 most {} (place fewer instances, or smaller meshes)",
                u32::MAX - 1
            )));
        }
        Ok(())
    }

    /// The instance triangle `id` (an id past the scene's own triangles) lies in, and its
    /// index in that instance's mesh.
    pub fn locate(&self, id: u32) -> (usize, usize) {
        let k = self.instances.partition_point(|i| i.first <= id) - 1;
        (k, (id - self.instances[k].first) as usize)
    }

    /// What a two-level structure holds, for the stats: `instances` instances of
    /// `meshes` meshes, `stored` triangles stored (the scene's own and each mesh's once),
    /// `placed` placed.
    pub fn holds(instances: usize, meshes: usize, stored: usize, placed: u64) -> String {
        format!(
            "{instances} instances of {meshes} meshes, {stored} triangles stored, {placed} placed"
        )
    }

    /// Memory of the meshes (positions, normals, triangles, texture coordinates, vertex
    /// colours) and placements, in bytes.
    pub fn bytes(&self) -> usize {
        let mesh: usize = self
            .meshes
            .iter()
            .map(|m| {
                let g = &m.geometry;
                g.positions.len() * 12
                    + g.normals.len() * 12
                    + g.triangles.len() * std::mem::size_of::<Triangle>()
                    + g.uvs.len() * 8
                    + g.tri_uvs.len() * 12
                    + g.colors.len() * 12
            })
            .sum();
        mesh + self.instances.len() * std::mem::size_of::<Instance>()
    }
}

/// Bytes per flattened triangle the memory check counts: the triangle record and its
/// three positions and normals (meshes share vertices, so this is an upper bound).
const FLAT_BYTES_PER_TRIANGLE: u64 = std::mem::size_of::<Triangle>() as u64 + 3 * 12 + 3 * 12;

impl Scene {
    /// True when the scene places meshes by instances.
    pub fn has_instances(&self) -> bool {
        !self.instancing.is_empty()
    }

    /// The vertices of triangle `id` (one of the scene's own, or an instance's past them)
    /// as [`Scene::flattened`] stores them: placed, rounded once, the winding reversed
    /// under a mirroring placement.
    pub fn placed_vertices(&self, id: usize) -> [Vec3; 3] {
        if id < self.triangles.len() {
            return self.triangle_vertices(id);
        }
        let inst = &self.instancing;
        let (k, j) = inst.locate(id as u32);
        let place = &inst.instances[k];
        let g = &inst.meshes[place.mesh as usize].geometry;
        let mut v = g.triangles[j]
            .v
            .map(|i| place.point(g.positions[i as usize]));
        if place.mirrors() {
            v.swap(1, 2);
        }
        v
    }

    /// The instance, mesh geometry and mesh triangle of an instanced id (past the scene's
    /// own triangles).
    fn placed_parts(&self, id: usize) -> (&Instance, &Scene, usize) {
        let inst = &self.instancing;
        let (k, j) = inst.locate(id as u32);
        let place = &inst.instances[k];
        (place, &inst.meshes[place.mesh as usize].geometry, j)
    }

    /// The unit vertex normals of triangle `id` (None without) as [`Scene::flattened`]
    /// stores them: an instance's placed by [`Instance::normal`], in the placed winding.
    pub fn placed_normals(&self, id: usize) -> Option<[Vec3; 3]> {
        if id < self.triangles.len() {
            let t = &self.triangles[id];
            return t
                .has_normals()
                .then(|| t.n.map(|k| self.normals[k as usize]));
        }
        let (place, g, j) = self.placed_parts(id);
        let t = &g.triangles[j];
        let mut n = t
            .has_normals()
            .then(|| t.n.map(|k| place.normal(g.normals[k as usize])))?;
        if place.mirrors() {
            n.swap(1, 2);
        }
        Some(n)
    }

    /// The texture coordinates of triangle `id`'s corners (None without), in the placed
    /// winding for an instance's: [`Scene::flattened`]'s.
    pub fn placed_uvs(&self, id: usize) -> Option<[Vec2; 3]> {
        let (uvi, uvs, mirror) = if id < self.triangles.len() {
            (self.triangle_uv_indices(id), &self.uvs, false)
        } else {
            let (place, g, j) = self.placed_parts(id);
            (g.triangle_uv_indices(j), &g.uvs, place.mirrors())
        };
        if uvi[0] == super::NO_UV {
            return None;
        }
        let mut uv = uvi.map(|k| uvs[k as usize]);
        if mirror {
            uv.swap(1, 2);
        }
        Some(uv)
    }

    /// The vertex colours of triangle `id`'s corners (None when neither the scene nor the
    /// instance's mesh has any; white corners where only the other has), in the placed
    /// winding for an instance's: [`Scene::flattened`]'s.
    pub fn placed_colors(&self, id: usize) -> Option<[Vec3; 3]> {
        if id < self.triangles.len() {
            if self.colors.is_empty() {
                return None;
            }
            return Some(self.triangles[id].v.map(|k| self.colors[k as usize]));
        }
        let (place, g, j) = self.placed_parts(id);
        if g.colors.is_empty() {
            return None;
        }
        let mut c = g.triangles[j].v.map(|k| g.colors[k as usize]);
        if place.mirrors() {
            c.swap(1, 2);
        }
        Some(c)
    }

    /// The material index of triangle `id` (one of the scene's own, or an instance's).
    pub fn placed_material(&self, id: usize) -> u32 {
        if id < self.triangles.len() {
            return self.triangles[id].material;
        }
        let (_, g, j) = self.placed_parts(id);
        g.triangles[j].material
    }

    /// Triangles once instances are counted: the scene's own and every instance's.
    pub fn instanced_triangles(&self) -> u64 {
        self.triangles.len() as u64 + self.instancing.triangles()
    }

    /// The scene with every instance's triangles stored in it, placed (what structures
    /// other than the BVH, and the GPU, render): the same primitive ids, vertices and
    /// normals as the two-level walk shades with. Refused before anything is allocated
    /// when it would take more than `limit` bytes, naming `why` it is flattened.
    pub fn flattened(&self, limit: u64, why: &str) -> Result<Scene> {
        let extra = self.instancing.triangles();
        let need = extra * FLAT_BYTES_PER_TRIANGLE;
        if need > limit {
            return Err(Error::Limit(format!(
                "{}: {why} stores instances flat: {extra} instanced triangles need about \
                 {:.1} GiB, more than the {:.1} GiB limit; render on the CPU with \
                 --accel bvh, which walks instances without copying them",
                self.source,
                need as f64 / (1u64 << 30) as f64,
                limit as f64 / (1u64 << 30) as f64
            )));
        }
        let mut out = self.clone();
        out.instancing = Instancing::default();
        out.triangles.reserve(extra as usize);
        // Texture coordinates and colours as the scene file's loader appends an object
        // stored flat (`toml_scene::build`'s `append`): once any triangle has them, every
        // triangle (NO_UV) and position (white) has, and each instance its own copy.
        let meshes = &self.instancing.meshes;
        let uvs = !self.tri_uvs.is_empty() || meshes.iter().any(|m| !m.geometry.tri_uvs.is_empty());
        let colors =
            !self.colors.is_empty() || meshes.iter().any(|m| !m.geometry.colors.is_empty());
        if uvs {
            out.tri_uvs.resize(out.triangles.len(), [super::NO_UV; 3]);
        }
        if colors {
            out.colors.resize(out.positions.len(), Vec3::ONE);
        }
        for inst in &self.instancing.instances {
            let g = &meshes[inst.mesh as usize].geometry;
            let (vbase, nbase) = (out.positions.len() as u32, out.normals.len() as u32);
            out.positions
                .extend(g.positions.iter().map(|&p| inst.point(p)));
            out.normals
                .extend(g.normals.iter().map(|&n| inst.normal(n)));
            let mirror = inst.mirrors();
            out.triangles.extend(g.triangles.iter().map(|t| {
                let mut t = Triangle {
                    v: t.v.map(|v| v + vbase),
                    n: if t.has_normals() {
                        t.n.map(|n| n + nbase)
                    } else {
                        t.n
                    },
                    material: t.material,
                };
                if mirror {
                    t.v.swap(1, 2);
                    t.n.swap(1, 2);
                }
                t
            }));
            if uvs {
                let ubase = out.uvs.len() as u32;
                if g.tri_uvs.is_empty() {
                    out.tri_uvs
                        .extend(std::iter::repeat_n([super::NO_UV; 3], g.triangles.len()));
                } else {
                    out.tri_uvs.extend(g.tri_uvs.iter().map(|t| {
                        let mut t = if t[0] == super::NO_UV {
                            *t
                        } else {
                            t.map(|k| k + ubase)
                        };
                        if mirror {
                            t.swap(1, 2);
                        }
                        t
                    }));
                }
                out.uvs.extend_from_slice(&g.uvs);
            }
            if colors {
                if g.colors.is_empty() {
                    out.colors
                        .extend(std::iter::repeat_n(Vec3::ONE, g.positions.len()));
                } else {
                    out.colors.extend_from_slice(&g.colors);
                }
            }
        }
        Ok(out)
    }

    /// The instances' invariants: meshes in range, indices in range within each mesh,
    /// finite vertices, materials in the scene's range, ids numbered.
    pub(super) fn validate_instances(&self) -> Result<()> {
        let bad =
            |field: String, message: String| Error::scene(self.source.clone(), 0, field, message);
        let inst = &self.instancing;
        for (k, m) in inst.meshes.iter().enumerate() {
            let g = &m.geometry;
            let uvs_ok = (g.tri_uvs.is_empty() || g.tri_uvs.len() == g.triangles.len())
                && g.tri_uvs
                    .iter()
                    .all(|t| t[0] == super::NO_UV || t.iter().all(|&k| (k as usize) < g.uvs.len()));
            let colors_ok = g.colors.is_empty() || g.colors.len() == g.positions.len();
            if !uvs_ok || !colors_ok || !g.textures.is_empty() {
                return Err(bad(
                    format!("instancing.meshes[{k}] ({})", m.name),
                    "texture coordinates or vertex colours out of range, or textures held \
                     by the mesh (its materials' textures are the scene's)"
                        .into(),
                ));
            }
            for (i, t) in g.triangles.iter().enumerate() {
                let vs = t.v.iter().all(|&v| (v as usize) < g.positions.len());
                let ns = !t.has_normals() || t.n.iter().all(|&n| (n as usize) < g.normals.len());
                if !vs || !ns || t.material as usize >= self.materials.len() {
                    return Err(bad(
                        format!("instancing.meshes[{k}].triangles[{i}]"),
                        "vertex, normal or material index out of range".into(),
                    ));
                }
            }
            if let Some(p) = g.positions.iter().find(|p| !p.is_finite()) {
                return Err(bad(
                    format!("instancing.meshes[{k}]"),
                    format!("non-finite vertex {p}"),
                ));
            }
        }
        let mut next = self.triangles.len() as u64;
        for (k, i) in inst.instances.iter().enumerate() {
            let Some(m) = inst.meshes.get(i.mesh as usize) else {
                return Err(bad(
                    format!("instancing.instances[{k}]"),
                    format!("mesh {} out of range", i.mesh),
                ));
            };
            if i.first as u64 != next {
                return Err(bad(
                    format!("instancing.instances[{k}]"),
                    format!("first id {} where {next} was due", i.first),
                ));
            }
            next += m.geometry.triangles.len() as u64;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A placement's ray into object space reaches, at the same t, the object-space point
    /// that the placement takes to the ray's point; its normals stay perpendicular to
    /// placed tangents; its box holds its placed corners.
    #[test]
    fn placement_maps_rays_normals_and_boxes_consistently() {
        let linear = DMat3::from_rotation_y(0.7) * DMat3::from_diagonal(DVec3::new(2.0, 0.5, -3.0));
        let inst = Instance::new(0, linear, DVec3::new(1.0, -2.0, 5.0)).unwrap();
        assert!(inst.mirrors());
        let (o, d) = (DVec3::new(0.3, 0.1, -4.0), DVec3::new(0.2, -0.4, 1.0));
        let (oo, dd) = inst.ray_to_object(o, d);
        for t in [0.0, 1.5, 7.25] {
            let back = inst.linear * (oo + dd * t) + inst.translate;
            assert!((back - (o + d * t)).length() < 1e-12, "t {t}: {back}");
        }
        let tangent = Vec3::new(1.0, 1.0, 0.0);
        let n = Vec3::new(1.0, -1.0, 0.0).normalize();
        let placed_t = inst.linear * tangent.as_dvec3();
        assert!(placed_t.dot(inst.normal(n).as_dvec3()).abs() < 1e-6);
        let (lo, hi) = inst.bounds(Vec3::splat(-1.0), Vec3::splat(1.0));
        for k in 0..8 {
            let c = Vec3::new(
                if k & 1 == 0 { -1.0 } else { 1.0 },
                if k & 2 == 0 { -1.0 } else { 1.0 },
                if k & 4 == 0 { -1.0 } else { 1.0 },
            );
            let p = inst.point(c);
            assert!(
                p.cmpge(lo).all() && p.cmple(hi).all(),
                "{p} outside {lo}..{hi}"
            );
        }
        assert!(Instance::new(
            0,
            DMat3::from_diagonal(DVec3::new(1.0, 0.0, 1.0)),
            DVec3::ZERO
        )
        .is_none());
    }
}
