//! Scene model: what the renderers see. Everything is triangles in f32 (the precision the
//! GPU stores), with per-triangle material indices and optional vertex normals. Positions,
//! lights and the camera are stored relative to a local origin ([`Scene::origin`], kept in
//! f64), so that a scene far from the world origin keeps the f32 precision it has near it. Loaders (`toml_scene`, `obj`, `ply`, `gltf_mesh`, `model`, `shapes`) produce a [`Scene`]; renderers never see
//! files, transforms or analytic shapes.

pub mod camera;
pub mod camera_path;
mod gltf_data;
mod gltf_material;
pub mod gltf_mesh;
pub mod instance;
pub mod model;
pub mod obj;
mod obj_scan;
mod obj_textures;
pub mod ply;
pub mod shapes;
pub mod texture;
pub mod toml_scene;

use glam::{DVec3, Vec2, Vec3};

pub use camera::Camera;
pub use camera_path::{CameraPath, Interpolation, Keyframe, Orbit, PathError, PathPlace, Pose};
pub use gltf_mesh::{load_gltf, load_gltf_instanced, parse_gltf, parse_gltf_instanced};
pub use instance::{Instance, Instancing, Mesh};
pub use model::{load_mesh, load_model_scene, MeshFormat};
pub use obj::{load_obj, parse_obj_with_mtl, ObjMesh};
pub use obj_textures::mtl_texture_files;
pub use ply::{load_ply, parse_ply};
pub use texture::{TexLevel, Texture, Wrap};
pub use toml_scene::{
    builtin_scene, load_scene, load_scene_str, load_scene_str_with_files,
    load_scene_str_with_search_path, load_scene_str_with_texts, load_scene_with_search_path,
    model_search_path, parse_scene_str, MeshImages, MeshTexts, DEFAULT_SCENE_TOML,
};

/// Sentinel for "no vertex normal" in [`Triangle::n`].
pub const NO_NORMAL: u32 = u32::MAX;
/// Sentinel for "no texture coordinate" in [`Scene::tri_uvs`].
pub const NO_UV: u32 = u32::MAX;

/// Which pair of world axes a checker pattern varies over.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CheckerAxes {
    /// Varies over x and y (a wall facing z).
    Xy,
    /// Varies over x and z (a floor facing y).
    Xz,
    /// Varies over y and z (a wall facing x).
    Yz,
}

impl CheckerAxes {
    /// The two world-axis indices the pattern uses.
    pub fn indices(self) -> (usize, usize) {
        match self {
            CheckerAxes::Xy => (0, 1),
            CheckerAxes::Xz => (0, 2),
            CheckerAxes::Yz => (1, 2),
        }
    }
}

/// Procedural checker albedo: `color_a` where floor(u/scale)+floor(v/scale) is even.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Checker {
    /// Colour of the even squares.
    pub color_a: Vec3,
    /// Colour of the odd squares.
    pub color_b: Vec3,
    /// Edge length of one square in world units.
    pub scale: f32,
    /// The world axes the squares lie in.
    pub axes: CheckerAxes,
    /// Added to the two local coordinates before the squares are counted: the scene's
    /// local origin along those axes, reduced modulo two squares in f64, so that the pattern
    /// stays where it is in world space (zero when the origin is).
    pub phase: [f32; 2],
}

/// Surface description for the Whitted model
/// `L = ka*A*albedo + sum I_l*(kd*albedo*max(0,n.l) + ks*max(0,r.v)^ns) + kr*L_r + kt*L_t`.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name (from the MTL file or the scene file), for messages.
    pub name: String,
    /// Diffuse albedo (MTL `Kd`).
    pub albedo: Vec3,
    /// Procedural checker replacing `albedo` when set.
    pub checker: Option<Checker>,
    /// Ambient factor (scalar, multiplies the scene ambient light).
    pub ka: f32,
    /// Diffuse factor (scalar).
    pub kd: f32,
    /// Phong specular colour (MTL `Ks`).
    pub ks: Vec3,
    /// Phong exponent (MTL `Ns`).
    pub ns: f32,
    /// Mirror reflectance (ignored when `fresnel`).
    pub kr: Vec3,
    /// Transmittance (ignored when `fresnel`).
    pub kt: Vec3,
    /// Index of refraction (MTL `Ni`).
    pub ior: f32,
    /// When true, kr = F and kt = 1 - F from the dielectric Fresnel equations.
    pub fresnel: bool,
    /// Diffuse texture (MTL `map_Kd`): an index into [`Scene::textures`]. Where set, the
    /// albedo is `albedo x texture(uv) x vertex colour` (docs/scene-format.md); a
    /// triangle without texture coordinates sees the texture's mean (its last mip level).
    pub diffuse_map: Option<u32>,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: "default".into(),
            albedo: Vec3::splat(0.8),
            checker: None,
            ka: 1.0,
            kd: 1.0,
            ks: Vec3::ZERO,
            ns: 1.0,
            kr: Vec3::ZERO,
            kt: Vec3::ZERO,
            ior: 1.0,
            fresnel: false,
            diffuse_map: None,
        }
    }
}

impl Material {
    /// Why this material breaks an invariant the shading model relies on, if it does:
    /// finite colours and factors, none negative (a negative `ks` would subtract light, and
    /// `light_term` skips the highlight when `ks` has no positive component), a Phong
    /// exponent of at least 1, a positive index of refraction and a positive checker scale.
    pub fn invalid(&self) -> Option<String> {
        let colours = [
            ("albedo", self.albedo),
            ("ks", self.ks),
            ("kr", self.kr),
            ("kt", self.kt),
        ];
        let checker = self.checker.iter().flat_map(|c| {
            [
                ("checker colour a", c.color_a),
                ("checker colour b", c.color_b),
            ]
        });
        for (what, c) in colours.into_iter().chain(checker) {
            if !c.is_finite() || c.min_element() < 0.0 {
                return Some(format!("{what} {c} must be finite and >= 0"));
            }
        }
        for (what, k) in [("ka", self.ka), ("kd", self.kd)] {
            if !k.is_finite() || k < 0.0 {
                return Some(format!("{what} {k} must be finite and >= 0"));
            }
        }
        if !(self.ns >= 1.0 && self.ns.is_finite()) {
            return Some(format!(
                "Phong exponent {} must be finite and >= 1",
                self.ns
            ));
        }
        if !(self.ior > 0.0 && self.ior.is_finite()) {
            return Some(format!(
                "index of refraction {} must be finite and > 0",
                self.ior
            ));
        }
        if let Some(c) = &self.checker {
            let phase_ok = c.phase.iter().all(|p| p.is_finite());
            if !(c.scale > 0.0 && c.scale.is_finite() && phase_ok) {
                return Some(format!(
                    "checker scale {} and phase {:?} must be finite, the scale > 0",
                    c.scale, c.phase
                ));
            }
        }
        None
    }

    /// True when the material spawns reflected rays.
    pub fn reflects(&self) -> bool {
        self.fresnel || self.kr.max_element() > 0.0
    }
    /// True when the material spawns refracted rays.
    pub fn refracts(&self) -> bool {
        self.fresnel || self.kt.max_element() > 0.0
    }
}

/// A point light with no distance attenuation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// Position, relative to [`Scene::origin`].
    pub position: Vec3,
    /// Colour (linear RGB).
    pub color: Vec3,
    /// Scalar intensity multiplying `color`.
    pub intensity: f32,
}

impl Light {
    /// `I_l` of the shading formula: colour times intensity.
    pub fn radiance(&self) -> Vec3 {
        self.color * self.intensity
    }
}

/// One triangle: vertex indices into [`Scene::positions`], optional normal indices into
/// [`Scene::normals`] ([`NO_NORMAL`] when the mesh has none) and a material index.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Triangle {
    /// Position indices.
    pub v: [u32; 3],
    /// Vertex-normal indices, or `[NO_NORMAL; 3]`.
    pub n: [u32; 3],
    /// Index into [`Scene::materials`].
    pub material: u32,
}

impl Triangle {
    /// True when the triangle carries vertex normals (smooth shading).
    pub fn has_normals(&self) -> bool {
        self.n[0] != NO_NORMAL
    }
}

/// A complete, renderable scene, stored relative to its local origin.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Where the scene came from (file path or `<builtin>`), for messages and stats.
    pub source: String,
    /// The pinhole camera. For an animated scene, the camera of the path's first frame,
    /// so that a single render of the scene shows that frame.
    pub camera: Camera,
    /// The camera path of an animated scene (`[animation]` in a scene file), relative to
    /// [`Scene::origin`] like the camera; `None` for a still scene.
    pub animation: Option<CameraPath>,
    /// Default image width.
    pub width: u32,
    /// Default image height.
    pub height: u32,
    /// Colour of rays that leave the scene.
    pub background: Vec3,
    /// Ambient light colour `A`.
    pub ambient: Vec3,
    /// Point lights.
    pub lights: Vec<Light>,
    /// Maximum number of reflection/refraction bounces.
    pub max_depth: u32,
    /// Vertex positions, relative to [`Scene::origin`].
    pub positions: Vec<Vec3>,
    /// Unit vertex normals (directions: the same in world and local space).
    pub normals: Vec<Vec3>,
    /// Triangles in load order (their index is the primitive id).
    pub triangles: Vec<Triangle>,
    /// Materials referenced by the triangles.
    pub materials: Vec<Material>,
    /// Texture coordinates (OBJ `vt`), indexed by [`Scene::tri_uvs`].
    pub uvs: Vec<Vec2>,
    /// Per triangle (parallel to [`Scene::triangles`]) the uv index of each corner, or
    /// `[NO_UV; 3]`; empty when no triangle has texture coordinates, so an untextured
    /// scene stores nothing for them.
    pub tri_uvs: Vec<[u32; 3]>,
    /// Linear RGB vertex colours, one per position (OBJ `v x y z r g b`), multiplying the
    /// albedo; empty when the scene has none.
    pub colors: Vec<Vec3>,
    /// Image textures the materials reference ([`Material::diffuse_map`]).
    pub textures: Vec<Texture>,
    /// Each texture a material names that could not be read, one line each (material,
    /// file, where it was looked for); the material then renders with its colour.
    /// `--textures` decides whether these are warnings or an error
    /// ([`TextureMode`](crate::options::TextureMode)).
    pub texture_problems: Vec<String>,
    /// World position of the local origin: every position above (vertices, lights, camera
    /// eye and target) is `world - origin`, subtracted in f64 before rounding to f32. Zero
    /// for scenes built in code; the TOML loader puts it at the camera eye (see
    /// `toml_scene::build`). Depths, normals and primitive ids do not depend on it; anything
    /// that reports a world position adds it back.
    pub origin: DVec3,
    /// Meshes placed by instances (`instances = [...]` on an object; `scene/instance.rs`):
    /// their triangles come after [`Scene::triangles`] in primitive ids and are stored
    /// once per mesh, not per instance. Empty for most scenes.
    pub instancing: Instancing,
}

impl Scene {
    /// An empty scene with the given camera and defaults elsewhere.
    pub fn empty(camera: Camera) -> Self {
        Scene {
            source: "<memory>".into(),
            camera,
            animation: None,
            width: 640,
            height: 480,
            background: Vec3::new(0.1, 0.3, 0.8),
            ambient: Vec3::splat(0.1),
            lights: Vec::new(),
            max_depth: 5,
            positions: Vec::new(),
            normals: Vec::new(),
            triangles: Vec::new(),
            materials: Vec::new(),
            uvs: Vec::new(),
            tri_uvs: Vec::new(),
            colors: Vec::new(),
            textures: Vec::new(),
            texture_problems: Vec::new(),
            origin: DVec3::ZERO,
            instancing: Instancing::default(),
        }
    }

    /// True when some material has a texture (texture code is compiled and run only then).
    pub fn has_textures(&self) -> bool {
        self.materials.iter().any(|m| m.diffuse_map.is_some())
    }

    /// True when the scene, or a mesh its instances place, has vertex colours.
    pub fn has_vertex_colors(&self) -> bool {
        !self.colors.is_empty()
            || self
                .instancing
                .meshes
                .iter()
                .any(|m| !m.geometry.colors.is_empty())
    }

    /// The uv indices of triangle `i`'s corners (`[NO_UV; 3]` when it has none).
    pub fn triangle_uv_indices(&self, i: usize) -> [u32; 3] {
        self.tri_uvs.get(i).copied().unwrap_or([NO_UV; 3])
    }

    /// The scene without textures, texture coordinates and vertex colours: every material
    /// with its colour alone (`--textures off`).
    pub fn strip_textures(&mut self) {
        for m in &mut self.materials {
            m.diffuse_map = None;
        }
        self.textures.clear();
        self.uvs.clear();
        self.tri_uvs.clear();
        self.colors.clear();
        self.texture_problems.clear();
        for m in &mut self.instancing.meshes {
            m.geometry.strip_textures();
        }
    }

    /// Appends a material and returns its index.
    pub fn add_material(&mut self, m: Material) -> u32 {
        self.materials.push(m);
        (self.materials.len() - 1) as u32
    }

    /// Appends a flat-shaded triangle and returns its index.
    pub fn add_triangle(&mut self, a: Vec3, b: Vec3, c: Vec3, material: u32) -> u32 {
        let base = self.positions.len() as u32;
        self.positions.extend([a, b, c]);
        self.triangles.push(Triangle {
            v: [base, base + 1, base + 2],
            n: [NO_NORMAL; 3],
            material,
        });
        if !self.tri_uvs.is_empty() {
            self.tri_uvs.push([NO_UV; 3]);
        }
        if !self.colors.is_empty() {
            self.colors.extend([Vec3::ONE; 3]);
        }
        (self.triangles.len() - 1) as u32
    }

    /// World position of a stored (local) position: `p + origin`, in f64.
    pub fn world(&self, p: Vec3) -> DVec3 {
        p.as_dvec3() + self.origin
    }

    /// The three vertex positions of triangle `i`.
    pub fn triangle_vertices(&self, i: usize) -> [Vec3; 3] {
        let t = &self.triangles[i];
        [
            self.positions[t.v[0] as usize],
            self.positions[t.v[1] as usize],
            self.positions[t.v[2] as usize],
        ]
    }

    /// Axis-aligned bounds of all triangle vertices, or `None` for an empty scene.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let mut it = self
            .triangles
            .iter()
            .flat_map(|t| t.v.iter().map(|&i| self.positions[i as usize]));
        let first = it.next()?;
        Some(it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))))
    }

    /// True when any triangle uses vertex normals.
    pub fn has_smooth_normals(&self) -> bool {
        self.triangles.iter().any(|t| t.has_normals())
    }

    /// Texture coordinates, vertex colours and textures: one uv index triple per triangle
    /// (or none at all), indices in range, finite uvs, finite colours >= 0, one colour per
    /// position (or none at all), textures as [`Texture::invalid`] requires.
    fn validate_surface_data(&self) -> crate::Result<()> {
        use crate::Error;
        let bad =
            |field: String, message: String| Error::scene(self.source.clone(), 0, field, message);
        if !self.tri_uvs.is_empty() && self.tri_uvs.len() != self.triangles.len() {
            return Err(bad(
                "tri_uvs".into(),
                format!(
                    "{} uv index triples for {} triangles",
                    self.tri_uvs.len(),
                    self.triangles.len()
                ),
            ));
        }
        for (i, uv) in self.uvs.iter().enumerate() {
            if !uv.is_finite() {
                return Err(bad(
                    format!("uvs[{i}]"),
                    format!("non-finite texture coordinate {uv}"),
                ));
            }
        }
        for (i, t) in self.tri_uvs.iter().enumerate() {
            let none = t.iter().all(|&k| k == NO_UV);
            if !none && t.iter().any(|&k| k as usize >= self.uvs.len()) {
                return Err(bad(
                    format!("triangles[{i}]"),
                    format!("uv index {t:?} out of range (0..{})", self.uvs.len()),
                ));
            }
        }
        if !self.colors.is_empty() && self.colors.len() != self.positions.len() {
            return Err(bad(
                "colors".into(),
                format!(
                    "{} vertex colours for {} positions",
                    self.colors.len(),
                    self.positions.len()
                ),
            ));
        }
        for (i, c) in self.colors.iter().enumerate() {
            if !c.is_finite() || c.min_element() < 0.0 {
                return Err(bad(
                    format!("colors[{i}]"),
                    format!("vertex colour {c} must be finite and >= 0"),
                ));
            }
        }
        for (i, t) in self.textures.iter().enumerate() {
            if let Some(why) = t.invalid() {
                return Err(bad(format!("textures[{i}] ({})", t.source), why));
            }
        }
        Ok(())
    }

    /// Checks invariants every renderer relies on: indices in range, finite numbers,
    /// materials as [`Material::invalid`] requires, texture coordinates, vertex colours and
    /// textures as `validate_surface_data` does.
    pub fn validate(&self) -> crate::Result<()> {
        let bad =
            |field: String, message: String| Error::scene(self.source.clone(), 0, field, message);
        use crate::Error;
        for (i, p) in self.positions.iter().enumerate() {
            if !p.is_finite() {
                return Err(bad(
                    format!("positions[{i}]"),
                    format!("non-finite vertex {p}"),
                ));
            }
        }
        for (i, t) in self.triangles.iter().enumerate() {
            for &v in &t.v {
                if v as usize >= self.positions.len() {
                    return Err(bad(
                        format!("triangles[{i}]"),
                        format!("vertex index {v} out of range"),
                    ));
                }
            }
            if t.has_normals() {
                for &n in &t.n {
                    if n as usize >= self.normals.len() {
                        return Err(bad(
                            format!("triangles[{i}]"),
                            format!("normal index {n} out of range"),
                        ));
                    }
                }
            }
            if t.material as usize >= self.materials.len() {
                return Err(bad(
                    format!("triangles[{i}]"),
                    format!("material index {} out of range", t.material),
                ));
            }
        }
        for (i, m) in self.materials.iter().enumerate() {
            if let Some(why) = m.invalid() {
                return Err(bad(format!("materials[{i}] ({})", m.name), why));
            }
            if let Some(t) = m.diffuse_map {
                if t as usize >= self.textures.len() {
                    return Err(bad(
                        format!("materials[{i}] ({})", m.name),
                        format!("texture index {t} out of range"),
                    ));
                }
            }
        }
        self.validate_surface_data()?;
        self.validate_instances()?;
        if !(1..=16).contains(&self.max_depth) && self.max_depth != 0 {
            return Err(bad(
                "max_depth".into(),
                format!("{} is outside 0..=16", self.max_depth),
            ));
        }
        Ok(())
    }
}

/// Reads an input file (scene, OBJ, MTL) that must be a regular file of at most `limit`
/// bytes. Directories, devices (`/dev/zero`), FIFOs and sockets are refused before anything
/// is read, so a wrong path can neither hang the loader nor exhaust memory; `what` names
/// the kind of file in the message.
pub fn read_input_file(path: &std::path::Path, limit: u64, what: &str) -> crate::Result<Vec<u8>> {
    use std::io::Read;
    let io = |source: std::io::Error| crate::Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        let kind = if meta.is_dir() {
            "a directory"
        } else {
            "not a regular file (a device, FIFO or socket)"
        };
        return Err(io(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("is {kind}; a {what} must be a regular file"),
        )));
    }
    let too_big = |n: u64| {
        io(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("{n} bytes exceed the {limit}-byte limit for a {what}"),
        ))
    };
    if meta.len() > limit {
        return Err(too_big(meta.len()));
    }
    let file = std::fs::File::open(path).map_err(io)?;
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    // The file may grow between the two calls: never read past the limit.
    file.take(limit + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > limit {
        return Err(too_big(bytes.len() as u64));
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each material the shading model cannot take is refused by `validate`, naming the
    /// material; the default one and a checker with a phase pass.
    #[test]
    fn validate_refuses_materials_the_shading_model_cannot_take() {
        let scene_with = |m: Material| {
            let mut s = Scene::empty(Camera {
                eye: Vec3::new(0.0, 0.0, 5.0),
                look_at: Vec3::ZERO,
                up: Vec3::Y,
                vfov_deg: 45.0,
            });
            let id = s.add_material(m);
            s.add_triangle(Vec3::ZERO, Vec3::X, Vec3::Y, id);
            s
        };
        let checker = Checker {
            color_a: Vec3::ONE,
            color_b: Vec3::ZERO,
            scale: 0.5,
            axes: CheckerAxes::Xz,
            phase: [0.25, -3.0],
        };
        for ok in [
            Material::default(),
            Material {
                checker: Some(checker),
                ..Material::default()
            },
        ] {
            scene_with(ok).validate().unwrap();
        }
        let d = Material::default;
        let bad = [
            (
                Material {
                    ks: Vec3::new(-0.5, 0.0, 0.0),
                    ..d()
                },
                "ks",
            ),
            (
                Material {
                    albedo: Vec3::new(0.5, f32::NAN, 0.5),
                    ..d()
                },
                "albedo",
            ),
            (
                Material {
                    kr: Vec3::splat(f32::INFINITY),
                    ..d()
                },
                "kr",
            ),
            (
                Material {
                    kt: Vec3::splat(-1e-9),
                    ..d()
                },
                "kt",
            ),
            (Material { ka: -1.0, ..d() }, "ka"),
            (
                Material {
                    kd: f32::NAN,
                    ..d()
                },
                "kd",
            ),
            (Material { ns: 0.5, ..d() }, "Phong exponent"),
            (Material { ior: 0.0, ..d() }, "index of refraction"),
            (
                Material {
                    ior: f32::NAN,
                    ..d()
                },
                "index of refraction",
            ),
            (
                Material {
                    checker: Some(Checker {
                        color_b: Vec3::splat(-1.0),
                        ..checker
                    }),
                    ..d()
                },
                "checker colour b",
            ),
            (
                Material {
                    checker: Some(Checker {
                        scale: 0.0,
                        ..checker
                    }),
                    ..d()
                },
                "checker scale",
            ),
            (
                Material {
                    checker: Some(Checker {
                        phase: [f32::NAN, 0.0],
                        ..checker
                    }),
                    ..d()
                },
                "checker scale",
            ),
        ];
        for (m, what) in bad {
            let e = scene_with(Material {
                name: "m".into(),
                ..m
            })
            .validate()
            .unwrap_err()
            .to_string();
            assert!(
                e.contains("materials[0] (m)") && e.contains(what),
                "{what}: {e}"
            );
        }
    }
}
