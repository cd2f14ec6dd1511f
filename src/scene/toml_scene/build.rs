//! Turning a parsed [`SceneDef`] into a [`Scene`]: range checks with file/line/field errors,
//! named and inline materials, analytic shapes, OBJ meshes (resolved against the scene's
//! folder and the search path, loaded once per file) and their placement transforms.
//!
//! Positions are kept in f64 world space (the placement is f64) until the scene is complete;
//! then the local origin is subtracted, still in f64, and only the difference is rounded to
//! f32 ([`local_origin`] says where the origin goes and why).

use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::rc::Rc;

use glam::{DMat3, DVec3, Vec2, Vec3};

use super::animation;
use super::diagnostics::{closest, Ctx};
use super::schema::{
    CameraDef, InstanceDef, MaterialDef, MaterialRef, Numbers, ObjectDef, SceneDef, ShapeKind, S,
};
use super::{DEFAULT_SPHERE_SUBDIVISIONS, MAX_DEPTH_LIMIT, MAX_IMAGE_SIZE};
use crate::scene::obj::ObjMesh;
use crate::scene::shapes::{self, MAX_SPHERE_SUBDIVISIONS};
use crate::scene::{
    Camera, Checker, CheckerAxes, Instance, Light, Material, Mesh, Scene, Triangle, NO_NORMAL,
    NO_UV,
};
use crate::{Error, Result};

// Finding and loading the OBJ meshes objects name: a second `impl Builder`, split by job.
#[path = "build_instances.rs"]
mod instances;
#[path = "build_meshes.rs"]
mod meshes;

/// Where a scene's meshes come from.
#[derive(Clone, Copy)]
pub(super) enum Meshes<'a> {
    /// Nowhere: a `mesh = ...` is an error.
    Refused,
    /// Files: the scene's folder, then the search path.
    Files(&'a Path, &'a [PathBuf]),
    /// Texts handed over with the scene (the web page's), by path or file name, and the
    /// images their MTLs name.
    Texts(&'a super::MeshTexts, &'a super::MeshImages),
}

/// The loader proper; `files` is where meshes are looked up.
pub(super) fn build_scene(text: &str, name: &str, files: Meshes<'_>) -> Result<Scene> {
    let ctx = Ctx { name, text };
    let def: SceneDef = serde_path_to_error::deserialize(toml::Deserializer::new(text))
        .map_err(|e| ctx.toml_error(&e))?;
    let mut builder = Builder {
        ctx,
        files,
        scene: Scene::empty(Camera {
            eye: Vec3::ZERO,
            look_at: Vec3::NEG_Z,
            up: Vec3::Y,
            vfov_deg: 45.0,
        }),
        world: World::default(),
        named: HashMap::new(),
        default_material: None,
        meshes: HashMap::new(),
        warnings: Vec::new(),
    };
    builder.scene.source = name.to_owned();
    builder.build(def)?;
    for w in &builder.warnings {
        eprintln!("fragtrace: warning: {w}");
    }
    let scene = builder.scene;
    scene.validate()?;
    Ok(scene)
}

/// Object-space geometry before placement; triangle materials are local indices.
#[derive(Clone)]
struct Geometry {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    triangles: Vec<Triangle>,
    /// Texture coordinates and each triangle's uv indices (both empty without), which a
    /// placement leaves as they are: texture coordinates live on the surface.
    uvs: Vec<glam::Vec2>,
    tri_uvs: Vec<[u32; 3]>,
    /// One colour per position, or none.
    colors: Vec<Vec3>,
}

impl Geometry {
    fn flat(positions: Vec<Vec3>, tris: Vec<[u32; 3]>) -> Self {
        let triangles = tris
            .into_iter()
            .map(|v| Triangle {
                v,
                n: [NO_NORMAL; 3],
                material: 0,
            })
            .collect();
        Geometry {
            positions,
            normals: Vec::new(),
            triangles,
            uvs: Vec::new(),
            tri_uvs: Vec::new(),
            colors: Vec::new(),
        }
    }

    fn smooth(positions: Vec<Vec3>, normals: Vec<Vec3>, tris: Vec<[u32; 3]>) -> Self {
        let triangles = tris
            .into_iter()
            .map(|v| Triangle {
                v,
                n: v,
                material: 0,
            })
            .collect();
        Geometry {
            positions,
            normals,
            triangles,
            uvs: Vec::new(),
            tri_uvs: Vec::new(),
            colors: Vec::new(),
        }
    }
}

/// An affine placement: `p' = linear·p + translate`, normals by the inverse transpose.
#[derive(Clone, Copy, Debug)]
pub(super) struct Placement {
    pub(super) linear: DMat3,
    pub(super) translate: DVec3,
}

impl Placement {
    /// Scale first, then rotate about X, then Y, then Z (degrees), then translate.
    pub(super) fn new(scale: DVec3, rotate_deg: DVec3, translate: DVec3) -> Self {
        let r = DMat3::from_rotation_z(rotate_deg.z.to_radians())
            * DMat3::from_rotation_y(rotate_deg.y.to_radians())
            * DMat3::from_rotation_x(rotate_deg.x.to_radians());
        Placement {
            linear: r * DMat3::from_diagonal(scale),
            translate,
        }
    }

    /// The placement that leaves everything where it is.
    const IDENTITY: Placement = Placement {
        linear: DMat3::IDENTITY,
        translate: DVec3::ZERO,
    };

    /// This placement applied after `inner`.
    fn then(&self, inner: Placement) -> Placement {
        Placement {
            linear: self.linear * inner.linear,
            translate: self.linear * inner.translate + self.translate,
        }
    }

    #[cfg(test)]
    pub(super) fn point(&self, p: Vec3) -> Vec3 {
        self.point_f64(p).as_vec3()
    }

    /// [`Placement::point`] before rounding: the world position in f64.
    fn point_f64(&self, p: Vec3) -> DVec3 {
        self.linear * p.as_dvec3() + self.translate
    }

    /// Transforms geometry in place (positions rounded to f32, for the finiteness check)
    /// and returns the world positions in f64. A mirroring transform (negative determinant)
    /// would turn triangles inside out, so their winding is reversed to keep geometric
    /// normals outward.
    fn apply(&self, g: &mut Geometry) -> Vec<DVec3> {
        let normal_matrix = self.linear.inverse().transpose();
        let world: Vec<DVec3> = g.positions.iter().map(|&p| self.point_f64(p)).collect();
        for (p, w) in g.positions.iter_mut().zip(&world) {
            *p = w.as_vec3();
        }
        for n in &mut g.normals {
            // Unit input and a non-singular matrix give a non-zero result.
            *n = (normal_matrix * n.as_dvec3()).normalize().as_vec3();
        }
        if self.linear.determinant() < 0.0 {
            for t in &mut g.triangles {
                t.v.swap(1, 2);
                t.n.swap(1, 2);
            }
            for uv in &mut g.tri_uvs {
                uv.swap(1, 2);
            }
        }
        world
    }
}

/// World positions in f64, parallel to the scene's f32 ones until [`Builder::localise`].
#[derive(Default)]
struct World {
    eye: DVec3,
    look_at: DVec3,
    lights: Vec<DVec3>,
    positions: Vec<DVec3>,
}

/// The local origin of a scene: its camera eye.
///
/// Measured against the scene's bounding-box centre on tests/far_from_origin.rs
/// (docs/robustness.md): both keep a scene translated by up to 1e6 or scaled by 1e-4..1e4
/// identical to the untranslated one, but a large object far behind the camera moves the
/// centre away from the view and costs the visible objects their precision (lit/shadowed
/// flips against f64), while the eye does not. The eye is chosen because the f32
/// error it leaves grows with the distance from the eye, as the footprint of a pixel does:
/// geometry near the camera, which covers the most pixels per unit of area, gets the finest
/// spacing, and primary rays start exactly at zero. The centre instead spends precision
/// evenly over the scene and leaves a camera near the edge of a large scene (a stadium,
/// a city) with the coarse spacing of the scene's radius right in front of it.
fn local_origin(world: &World) -> DVec3 {
    world.eye
}

/// `[x, y, z]` of a TOML triple in f64 (its range is checked by `Ctx::vec3`).
fn triple_f64(v: &S<super::schema::Triple>) -> DVec3 {
    let a = v.get_ref();
    DVec3::new(a[0], a[1], a[2])
}

/// A loaded mesh and the resolved path it is cached under.
type LoadedMesh = (Rc<ObjMesh>, PathBuf);

struct Builder<'a> {
    ctx: Ctx<'a>,
    /// Where meshes are looked up.
    files: Meshes<'a>,
    scene: Scene,
    /// World positions in f64, before the local origin is subtracted.
    world: World,
    /// Named material → index in `scene.materials`.
    named: HashMap<String, u32>,
    default_material: Option<u32>,
    /// Resolved mesh path → mesh, and the index of its first MTL material once added.
    meshes: HashMap<PathBuf, (Rc<ObjMesh>, Option<u32>)>,
    warnings: Vec<String>,
}

impl Builder<'_> {
    fn build(&mut self, def: SceneDef) -> Result<()> {
        let ctx = self.ctx;
        let path = match (&def.camera, &def.animation) {
            (Some(c), None) => {
                self.camera(c)?;
                None
            }
            (None, Some(a)) => {
                let path = animation::camera_path(ctx, a)?;
                // The still camera is the first frame's, in world space until localise.
                let first = path.pose_at(*path.frames().start() as f64);
                self.scene.camera = first.camera(DVec3::ZERO);
                self.world.eye = first.eye;
                self.world.look_at = first.look_at;
                Some((path, a))
            }
            (Some(_), Some(a)) => {
                return Err(ctx.err(
                    animation::animation_span(ctx, a),
                    "animation",
                    "a scene has either `[camera]` or `[animation]`, not both: an animated \
                     scene's camera (for a single render too) is its path's first frame",
                ));
            }
            (None, None) => {
                return Err(Error::scene(
                    ctx.name,
                    1,
                    "camera",
                    "the scene has no `[camera]` table, which is required (e.g. `[camera]` \
                     with `eye`, `look_at` and `fov`, or an `[animation]` camera path)",
                ));
            }
        };
        if let Some(img) = &def.image {
            let why = format!(" (image sizes are 1..={MAX_IMAGE_SIZE} pixels)");
            let max = MAX_IMAGE_SIZE as i64;
            if let Some(w) = &img.width {
                self.scene.width = ctx.integer(w, "image.width", 1..=max, &why)?;
            }
            if let Some(h) = &img.height {
                self.scene.height = ctx.integer(h, "image.height", 1..=max, &why)?;
            }
        } else {
            self.scene.width = 640;
            self.scene.height = 480;
        }
        self.scene.background =
            ctx.opt_color(&def.background, "background", Vec3::new(0.1, 0.3, 0.8))?;
        self.scene.ambient = ctx.opt_color(&def.ambient, "ambient", Vec3::splat(0.1))?;
        self.scene.max_depth = match &def.max_depth {
            Some(d) => ctx.integer(d, "max_depth", 0..=MAX_DEPTH_LIMIT as i64, "")?,
            None => 5,
        };
        for (i, l) in def.lights.iter().enumerate() {
            let f = format!("lights[{i}]");
            let intensity = match &l.get_ref().intensity {
                Some(v) => {
                    ctx.scalar(v, &format!("{f}.intensity"), |x| x >= 0.0, "must be >= 0")?
                }
                None => 1.0,
            };
            let position = ctx.vec3(&l.get_ref().position, &format!("{f}.position"))?;
            self.world.lights.push(triple_f64(&l.get_ref().position));
            self.scene.lights.push(Light {
                position,
                color: ctx.opt_color(&l.get_ref().color, &format!("{f}.color"), Vec3::ONE)?,
                intensity,
            });
        }
        // Named materials first, in name order, so their indices do not depend on which
        // object happens to use them first.
        for (name, m) in &def.materials {
            let mat = self.material(m, name.clone(), &format!("materials.{name}"))?;
            let idx = self.scene.add_material(mat);
            self.named.insert(name.clone(), idx);
        }
        for (i, o) in def.objects.iter().enumerate() {
            self.object(i, o)?;
        }
        if def.objects.is_empty() {
            // (An object whose mesh is empty has its own warning, naming the OBJ.)
            self.warnings.push(format!(
                "{}: no objects, so no triangles; the render shows only the background",
                ctx.name
            ));
        }
        self.localise();
        let own = self.scene.triangles.len();
        self.scene.instancing.number(own, ctx.name)?;
        if let Some((path, a)) = path {
            // Relative to the local origin, which is the first frame's eye.
            let path = path
                .with_origin(self.scene.origin)
                .map_err(|e| animation::path_error(ctx, a, &e))?;
            self.scene.camera = path.camera_at(*path.frames().start());
            self.scene.animation = Some(path);
        }
        Ok(())
    }

    /// Moves the scene to its local origin: subtracts it from every world position in f64,
    /// rounds the differences to f32 and gives each checker the phase that keeps its squares
    /// in place.
    fn localise(&mut self) {
        let o = local_origin(&self.world);
        let s = &mut self.scene;
        s.origin = o;
        let local = |p: DVec3| (p - o).as_vec3();
        s.camera.eye = local(self.world.eye);
        s.camera.look_at = local(self.world.look_at);
        for (l, &w) in s.lights.iter_mut().zip(&self.world.lights) {
            l.position = local(w);
        }
        for (p, &w) in s.positions.iter_mut().zip(&self.world.positions) {
            *p = local(w);
        }
        for inst in &mut s.instancing.instances {
            inst.translate -= o;
        }
        for m in &mut s.materials {
            if let Some(c) = &mut m.checker {
                let (a, b) = c.axes.indices();
                let period = 2.0 * c.scale as f64;
                c.phase = [
                    o[a].rem_euclid(period) as f32,
                    o[b].rem_euclid(period) as f32,
                ];
            }
        }
    }

    fn camera(&mut self, c: &S<CameraDef>) -> Result<()> {
        let ctx = self.ctx;
        let d = c.get_ref();
        let eye = ctx.vec3(&d.eye, "camera.eye")?;
        let look_at = ctx.vec3(&d.look_at, "camera.look_at")?;
        let up = match &d.up {
            Some(u) => ctx.vec3(u, "camera.up")?,
            None => Vec3::Y,
        };
        let fov = ctx.scalar(
            &d.fov,
            "camera.fov",
            |x| x > 0.0 && x < 180.0,
            "vertical field of view must be in (0, 180) degrees",
        )?;
        let cam = Camera {
            eye,
            look_at,
            up,
            vfov_deg: fov,
        };
        let forward = (look_at - eye).as_dvec3();
        if forward.length() == 0.0 {
            return Err(ctx.err(
                d.look_at.span(),
                "camera.look_at",
                "equals camera.eye; the camera has no viewing direction",
            ));
        }
        if let Some(u) = d.up.as_ref().filter(|_| up.as_dvec3().length() == 0.0) {
            return Err(ctx.err(
                u.span(),
                "camera.up",
                "up is [0, 0, 0], which has no direction; give the camera's up, e.g. [0, 1, 0]",
            ));
        }
        if crate::scene::camera::up_parallel(forward, up.as_dvec3()) {
            let (span, field) = match &d.up {
                Some(u) => (u.span(), "camera.up"),
                None => (d.look_at.span(), "camera.look_at"),
            };
            return Err(ctx.err(
                span,
                field,
                format!(
                    "up {up} is parallel to the viewing direction {}; choose another `up`",
                    forward.normalize().as_vec3()
                ),
            ));
        }
        // Camera::check is the renderers' contract; keep it authoritative.
        cam.check().map_err(|m| ctx.err(c.span(), "camera", m))?;
        self.scene.camera = cam;
        self.world.eye = triple_f64(&d.eye);
        self.world.look_at = triple_f64(&d.look_at);
        Ok(())
    }

    fn material(&self, m: &MaterialDef, name: String, field: &str) -> Result<Material> {
        let ctx = self.ctx;
        let f = |k: &str| format!("{field}.{k}");
        let nonneg = |v: &Option<S<f64>>, k: &str, default: f32| -> Result<f32> {
            v.as_ref().map_or(Ok(default), |v| {
                ctx.scalar(v, &f(k), |x| x >= 0.0, "must be >= 0")
            })
        };
        let checker = match &m.checker {
            Some(c) => {
                let c = c.get_ref();
                Some(Checker {
                    color_a: ctx.color(&c.a, &f("checker.a"))?,
                    color_b: ctx.color(&c.b, &f("checker.b"))?,
                    scale: match &c.scale {
                        Some(s) => {
                            ctx.scalar(s, &f("checker.scale"), |x| x > 0.0, "must be > 0")?
                        }
                        None => 1.0,
                    },
                    axes: c.axes.unwrap_or(CheckerAxes::Xz),
                    phase: [0.0; 2],
                })
            }
            None => None,
        };
        Ok(Material {
            name,
            albedo: ctx.opt_color(&m.albedo, &f("albedo"), Vec3::splat(0.8))?,
            checker,
            ka: nonneg(&m.ka, "ka", 1.0)?,
            kd: nonneg(&m.kd, "kd", 1.0)?,
            ks: ctx.opt_color(&m.ks, &f("ks"), Vec3::ZERO)?,
            ns: match &m.ns {
                Some(v) => ctx.scalar(v, &f("ns"), |x| x >= 1.0, "Phong exponent must be >= 1")?,
                None => 32.0,
            },
            kr: ctx.opt_color(&m.kr, &f("kr"), Vec3::ZERO)?,
            kt: ctx.opt_color(&m.kt, &f("kt"), Vec3::ZERO)?,
            ior: match &m.ior {
                Some(v) => {
                    ctx.scalar(v, &f("ior"), |x| x > 0.0, "index of refraction must be > 0")?
                }
                None => 1.0,
            },
            fresnel: m.fresnel.unwrap_or(false),
            diffuse_map: None,
        })
    }

    fn default_material(&mut self) -> u32 {
        if let Some(i) = self.default_material {
            return i;
        }
        let i = self.scene.add_material(Material::default());
        self.default_material = Some(i);
        i
    }

    /// The scene material index an object's `material` key names or defines.
    fn object_material(&mut self, m: &S<MaterialRef>, field: &str) -> Result<u32> {
        match m.get_ref() {
            MaterialRef::Named(name) => self.named.get(name).copied().ok_or_else(|| {
                let known: Vec<&str> = self.named.keys().map(String::as_str).collect();
                let hint = closest(name, &known)
                    .map(|k| format!("; did you mean `{k}`?"))
                    .unwrap_or_default();
                let listing = if known.is_empty() {
                    " (no [materials.NAME] tables are defined)".to_owned()
                } else {
                    let mut k = known.clone();
                    k.sort_unstable();
                    format!(" (defined: {})", k.join(", "))
                };
                self.ctx.err(
                    m.span(),
                    field,
                    format!("undefined material `{name}`{hint}{listing}"),
                )
            }),
            MaterialRef::Inline(def) => {
                let mat = self.material(def, field.to_owned(), field)?;
                Ok(self.scene.add_material(mat))
            }
        }
    }

    fn object(&mut self, i: usize, o: &S<ObjectDef>) -> Result<()> {
        let ctx = self.ctx;
        let f = |k: &str| format!("objects[{i}].{k}");
        let d = o.get_ref();

        // Keys that only make sense for some kinds of object.
        let kind = d.shape.as_ref().map(|s| *s.get_ref());
        let only_for =
            |key: &str, span: Option<Range<usize>>, allowed: &[ShapeKind]| -> Result<()> {
                match span {
                    Some(span) if !kind.is_some_and(|k| allowed.contains(&k)) => {
                        let shapes: Vec<String> =
                            allowed.iter().map(|s| format!("shape = \"{s}\"")).collect();
                        Err(ctx.err(
                            span,
                            f(key),
                            format!("`{key}` applies only to {}", shapes.join(" or ")),
                        ))
                    }
                    _ => Ok(()),
                }
            };
        only_for(
            "subdivisions",
            d.subdivisions.as_ref().map(|s| s.span()),
            &[ShapeKind::Sphere],
        )?;
        only_for(
            "radius",
            d.radius.as_ref().map(|s| s.span()),
            &[ShapeKind::Sphere],
        )?;
        only_for(
            "size",
            d.size.as_ref().map(|s| s.span()),
            &[ShapeKind::Quad, ShapeKind::Box],
        )?;

        let (mut geometry, mesh_materials): (Geometry, Option<LoadedMesh>) = match (
            &d.mesh, &d.shape,
        ) {
            (Some(path), None) if d.material.is_none() => {
                let (mesh, _) = self.mesh(path, &f("mesh"))?;
                // Without an override the MTL decides how the mesh looks: a missing one is
                // an error, not a silently grey mesh.
                if let Some(problem) = mesh.missing_mtl.first() {
                    return Err(ctx.err(
                        path.span(),
                        f("mesh"),
                        format!(
                            "{problem}; fix the mtllib, or set `material = \"NAME\"` on this \
                             object to render the mesh without its MTL"
                        ),
                    ));
                }
                self.mesh_geometry(path, &f("mesh"))?
            }
            (Some(_), Some(s)) => {
                return Err(ctx.err(
                    s.span(),
                    f("shape"),
                    "an object has either `mesh` or `shape`, not both",
                ));
            }
            (None, None) => {
                return Err(ctx.err(o.span(), format!("objects[{i}]"), "an object needs `mesh = \"file.obj\"` or `shape = \"sphere\" | \"quad\" | \"box\"`"));
            }
            (Some(path), None) => self.mesh_geometry(path, &f("mesh"))?,
            (None, Some(s)) => (self.shape(*s.get_ref(), d, &f)?, None),
        };

        // A glTF's meshes that several nodes place, stored once (`ObjMesh::shared`).
        let loaded = mesh_materials.as_ref().map(|(m, _)| m.clone());
        let placement = self.placement(&d.scale, &d.rotate, &d.translate, &f)?;
        let world = placement.apply(&mut geometry);
        self.check_finite(&geometry, o.span(), &format!("objects[{i}]"))?;

        // Material indices: an override replaces everything; a mesh otherwise brings its
        // MTL materials (added once per mesh file); a shape without one is default grey.
        let material_map: Box<dyn Fn(u32) -> u32> = match (&d.material, mesh_materials) {
            (Some(m), _) => {
                let idx = self.object_material(m, &f("material"))?;
                Box::new(move |_| idx)
            }
            (None, Some((mesh, key))) => {
                let base = match self.meshes.get(&key).and_then(|e| e.1) {
                    Some(b) => b,
                    None => {
                        let b = self.scene.materials.len() as u32;
                        // The mesh's textures come with its materials, once per file.
                        let tbase = self.scene.textures.len() as u32;
                        self.scene.textures.extend(mesh.textures.iter().cloned());
                        self.scene
                            .texture_problems
                            .extend(mesh.texture_problems.iter().cloned());
                        self.scene
                            .materials
                            .extend(mesh.materials.iter().map(|m| Material {
                                diffuse_map: m.diffuse_map.map(|t| t + tbase),
                                ..m.clone()
                            }));
                        if let Some(e) = self.meshes.get_mut(&key) {
                            e.1 = Some(b);
                        }
                        b
                    }
                };
                Box::new(move |m| base + m)
            }
            (None, None) => {
                let idx = self.default_material();
                Box::new(move |_| idx)
            }
        };
        let outer = match &d.instances {
            Some(list) => self.instance_placements(i, list)?,
            None => vec![(Placement::IDENTITY, o.span(), 0)],
        };
        if let Some(mesh) = loaded.filter(|m| !m.shared.is_empty()) {
            self.shared_meshes(i, o, &mesh, placement, &outer, &*material_map)?;
        }
        if let Some(list) = &d.instances {
            return self.instances(i, list, outer, geometry, &*material_map);
        }
        self.append(geometry, &*material_map, o.span(), i)?;
        self.world.positions.extend(world);
        Ok(())
    }

    /// Refuses placed geometry with a vertex that is not finite in f32.
    fn check_finite(&self, g: &Geometry, span: Range<usize>, field: &str) -> Result<()> {
        match g.positions.iter().find(|p| !p.is_finite()) {
            Some(p) => Err(self.ctx.err(
                span,
                field,
                format!(
                    "a transformed vertex is not finite ({p}); scale or translate is too large"
                ),
            )),
            None => Ok(()),
        }
    }

    fn shape(
        &self,
        kind: ShapeKind,
        d: &ObjectDef,
        f: &dyn Fn(&str) -> String,
    ) -> Result<Geometry> {
        let ctx = self.ctx;
        Ok(match kind {
            ShapeKind::Sphere => {
                let n = match &d.subdivisions {
                    Some(s) => ctx.integer(
                        s,
                        &f("subdivisions"),
                        0..=MAX_SPHERE_SUBDIVISIONS as i64,
                        &format!(
                            " (level {MAX_SPHERE_SUBDIVISIONS} is already {} triangles)",
                            shapes::sphere_triangle_count(MAX_SPHERE_SUBDIVISIONS)
                        ),
                    )?,
                    None => DEFAULT_SPHERE_SUBDIVISIONS,
                };
                let r = match &d.radius {
                    Some(r) => ctx.scalar(r, &f("radius"), |x| x > 0.0, "must be > 0")?,
                    None => 1.0,
                };
                let (p, n, t) = shapes::sphere(n);
                // Scaling a unit sphere uniformly leaves its normals unchanged.
                Geometry::smooth(p.into_iter().map(|p| p * r).collect(), n, t)
            }
            ShapeKind::Quad => {
                let size = match &d.size {
                    Some(s) => {
                        let v = numbers(ctx, s, &f("size"), 2)?;
                        positive(ctx, s, &f("size"), &v)?;
                        Vec2::new(v[0] as f32, v[1] as f32)
                    }
                    None => Vec2::ONE,
                };
                let (p, t) = shapes::quad(size.x, size.y);
                Geometry::flat(p, t)
            }
            ShapeKind::Box => {
                let size = match &d.size {
                    Some(s) => {
                        let v = numbers(ctx, s, &f("size"), 3)?;
                        positive(ctx, s, &f("size"), &v)?;
                        Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
                    }
                    None => Vec3::ONE,
                };
                let (p, t) = shapes::cuboid(size);
                Geometry::flat(p, t)
            }
        })
    }

    fn append(
        &mut self,
        g: Geometry,
        material: &dyn Fn(u32) -> u32,
        span: Range<usize>,
        i: usize,
    ) -> Result<()> {
        let s = &mut self.scene;
        let vbase = s.positions.len();
        let nbase = s.normals.len();
        if vbase + g.positions.len() > u32::MAX as usize
            || nbase + g.normals.len() >= u32::MAX as usize
        {
            return Err(self.ctx.err(
                span,
                format!("objects[{i}]"),
                "the scene exceeds 2^32 vertices",
            ));
        }
        let (vbase, nbase) = (vbase as u32, nbase as u32);
        // Texture coordinates and colours: stored only once some object has them, then
        // for every triangle (NO_UV) and position (white) before and after.
        if !g.tri_uvs.is_empty() || !s.tri_uvs.is_empty() {
            let ubase = s.uvs.len() as u32;
            s.tri_uvs.resize(s.triangles.len(), [NO_UV; 3]);
            if g.tri_uvs.is_empty() {
                s.tri_uvs
                    .extend(std::iter::repeat_n([NO_UV; 3], g.triangles.len()));
            } else {
                s.tri_uvs.extend(g.tri_uvs.iter().map(|t| {
                    if t[0] == NO_UV {
                        *t
                    } else {
                        t.map(|k| k + ubase)
                    }
                }));
            }
            s.uvs.extend(g.uvs);
        }
        if !g.colors.is_empty() || !s.colors.is_empty() {
            s.colors.resize(s.positions.len(), Vec3::ONE);
            if g.colors.is_empty() {
                s.colors
                    .extend(std::iter::repeat_n(Vec3::ONE, g.positions.len()));
            } else {
                s.colors.extend(g.colors);
            }
        }
        s.positions.extend(g.positions);
        s.normals.extend(g.normals);
        s.triangles
            .extend(g.triangles.into_iter().map(|t| Triangle {
                v: t.v.map(|v| v + vbase),
                n: if t.has_normals() {
                    t.n.map(|n| n + nbase)
                } else {
                    [NO_NORMAL; 3]
                },
                material: material(t.material),
            }));
        Ok(())
    }
}

/// `scale`/`size` values: one number (used for every axis) or exactly `len` numbers, finite.
fn numbers(ctx: Ctx, v: &S<Numbers>, field: &str, len: usize) -> Result<Vec<f64>> {
    let out = match v.get_ref() {
        Numbers::One(x) => vec![*x; len],
        Numbers::Many(xs) if xs.len() == len => xs.clone(),
        Numbers::Many(xs) => {
            return Err(ctx.err(
                v.span(),
                field,
                format!("expected a number or {len} numbers, got {}", xs.len()),
            ));
        }
    };
    if out.iter().any(|x| !(*x as f32).is_finite()) {
        return Err(ctx.err(v.span(), field, format!("must be finite, got {out:?}")));
    }
    Ok(out)
}

fn positive(ctx: Ctx, v: &S<Numbers>, field: &str, xs: &[f64]) -> Result<()> {
    if xs.iter().any(|&x| x <= 0.0) {
        return Err(ctx.err(v.span(), field, format!("sizes must be > 0, got {xs:?}")));
    }
    Ok(())
}
