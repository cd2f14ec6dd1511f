//! Model files: which loader a mesh file goes to (by its extension: `.obj`, `.ply`,
//! `.gltf`, `.glb`), and a model file rendered on its own, as model viewers show one: its
//! bounding box framed by a default camera (a 3/4 view from the front right, above), one
//! white light above and behind the camera, a neutral grey background, no floor. The
//! framing is in `docs/scene-format.md`.

use std::path::Path;

use glam::{DVec3, Vec3};

use super::{Camera, Light, ObjMesh, Scene};
use crate::{Error, Result};

/// The mesh file formats fragtrace reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    /// Wavefront OBJ (with MTL materials).
    Obj,
    /// Stanford PLY (ASCII or binary).
    Ply,
    /// glTF 2.0 (`.gltf` JSON or `.glb` binary).
    Gltf,
}

impl MeshFormat {
    /// The format a file's extension names (case-insensitive), if it names one.
    pub fn of(path: &Path) -> Option<MeshFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "obj" => Some(MeshFormat::Obj),
            "ply" => Some(MeshFormat::Ply),
            "gltf" | "glb" => Some(MeshFormat::Gltf),
            _ => None,
        }
    }
}

/// Loads a mesh file by its format; a file whose extension is none of the model formats
/// is read as OBJ (as before PLY and glTF were read).
pub fn load_mesh(path: &Path) -> Result<ObjMesh> {
    match MeshFormat::of(path) {
        Some(MeshFormat::Ply) => super::ply::load_ply(path),
        Some(MeshFormat::Gltf) => super::gltf_mesh::load_gltf(path),
        Some(MeshFormat::Obj) | None => super::obj::load_obj(path),
    }
}

/// [`load_mesh`] for a scene that instances: a glTF mesh several nodes place (with its
/// texture coordinates, vertex colours and materials) is stored once, in
/// [`ObjMesh::shared`](super::obj::ObjMesh::shared), instead of once per node.
pub fn load_mesh_instanced(path: &Path) -> Result<ObjMesh> {
    match MeshFormat::of(path) {
        Some(MeshFormat::Gltf) => super::gltf_mesh::load_gltf_instanced(path),
        _ => load_mesh(path),
    }
}

/// Vertical field of view of the default camera, degrees.
pub const MODEL_FOV_DEG: f32 = 40.0;
/// Share of the image's limiting side the model's bounding box spans.
pub const MODEL_FILL: f64 = 0.9;
/// Background of a model rendered on its own: a neutral grey.
pub const MODEL_BACKGROUND: Vec3 = Vec3::splat(0.3);
/// The default camera's direction from the model's centre: 35° to the right of +z, 25°
/// above the horizon.
pub fn model_view_direction() -> DVec3 {
    let (az, el) = (35f64.to_radians(), 25f64.to_radians());
    DVec3::new(az.sin() * el.cos(), el.sin(), az.cos() * el.cos())
}

/// A model file as a scene of its own: its materials and textures, framed as
/// [`frame_model`] says. Warnings of the loader are printed on stderr, one line each; a
/// missing MTL is one warning (the mesh renders grey).
pub fn load_model_scene(path: &Path) -> Result<Scene> {
    let mesh = load_mesh(path)?;
    for w in mesh.warnings.iter().chain(&mesh.missing_mtl) {
        eprintln!("fragtrace: warning: {w}");
    }
    let name = path.display().to_string();
    let mut scene = Scene::empty(Camera {
        eye: Vec3::Z,
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: MODEL_FOV_DEG,
    });
    scene.source = name.clone();
    scene.positions = mesh.positions;
    scene.normals = mesh.normals;
    scene.triangles = mesh.triangles;
    scene.materials = mesh.materials;
    scene.uvs = mesh.uvs;
    scene.tri_uvs = mesh.tri_uvs;
    scene.colors = mesh.colors;
    scene.textures = mesh.textures;
    scene.texture_problems = mesh.texture_problems;
    if scene.materials.is_empty() {
        scene.materials.push(super::Material::default());
    }
    frame_model(&mut scene).ok_or_else(|| Error::Mesh {
        file: name,
        message: "no triangles: nothing to render".into(),
    })?;
    scene.validate()?;
    Ok(scene)
}

/// Puts the default camera and light on `scene` for its triangles' bounding box: the
/// camera looks at the box's centre along [`model_view_direction`], as far away as makes
/// the eight corners span [`MODEL_FILL`] of the image's height, or of a centred square's
/// width where that limits (exactly, by each corner's projection); the light sits above
/// and behind it. `None` for an empty scene.
pub fn frame_model(scene: &mut Scene) -> Option<()> {
    let (lo, hi) = scene.bounds()?;
    let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-6);
    let back = model_view_direction();
    let right = DVec3::Y.cross(back).normalize();
    let up = back.cross(right);
    // Framed for a square: any image at least as wide as high (`--width`, `--height` may
    // change the scene's 4:3) shows the whole box.
    let tan_v = ((MODEL_FOV_DEG as f64).to_radians() * 0.5).tan() * MODEL_FILL;
    let tan_h = tan_v;
    // A corner q (relative to the centre) at depth d - q·back must satisfy
    // |q·right| <= tan_h (d - q·back) and |q·up| <= tan_v (d - q·back).
    let mut d: f64 = radius * 1e-3;
    for i in 0..8 {
        let c = DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        ) - centre;
        let z = c.dot(back);
        d = d
            .max(z + c.dot(right).abs() / tan_h)
            .max(z + c.dot(up).abs() / tan_v)
            .max(z + radius * 0.05);
    }
    let eye = centre + back * d;
    scene.camera = Camera {
        eye: eye.as_vec3(),
        look_at: centre.as_vec3(),
        up: Vec3::Y,
        vfov_deg: MODEL_FOV_DEG,
    };
    // Above and behind the camera, so the side the camera sees is lit and the shadows fall
    // behind the model.
    let light = centre + back * (d * 1.5) + DVec3::Y * (d * 1.0) + right * (d * 0.3);
    scene.lights = vec![Light {
        position: light.as_vec3(),
        color: Vec3::ONE,
        intensity: 1.0,
    }];
    scene.background = MODEL_BACKGROUND;
    scene.ambient = Vec3::splat(0.15);
    Some(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_by_extension() {
        for (p, f) in [
            ("a/b.OBJ", Some(MeshFormat::Obj)),
            ("x.ply", Some(MeshFormat::Ply)),
            ("x.glb", Some(MeshFormat::Gltf)),
            ("x.gltf", Some(MeshFormat::Gltf)),
            ("x.toml", None),
            ("x", None),
        ] {
            assert_eq!(MeshFormat::of(Path::new(p)), f, "{p}");
        }
    }

    /// Every corner of the framed box projects inside the image, and the box spans the
    /// fill share of the limiting side (to rounding).
    #[test]
    fn the_box_fills_the_frame() {
        let mut s = Scene::empty(Camera {
            eye: Vec3::Z,
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 45.0,
        });
        let m = s.add_material(super::super::Material::default());
        let (lo, hi) = (Vec3::new(-3.0, 1.0, 2.0), Vec3::new(5.0, 2.0, 4.0));
        s.add_triangle(lo, Vec3::new(hi.x, lo.y, lo.z), hi, m);
        s.add_triangle(lo, Vec3::new(lo.x, hi.y, hi.z), hi, m);
        frame_model(&mut s).unwrap();
        let cam = s.camera;
        let fwd = (cam.look_at - cam.eye).normalize();
        let right = fwd.cross(Vec3::Y).normalize();
        let up = right.cross(fwd);
        let tv = (cam.vfov_deg.to_radians() * 0.5).tan();
        let th = tv;
        let (mut mx, mut my) = (0f32, 0f32);
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            ) - cam.eye;
            let depth = c.dot(fwd);
            mx = mx.max((c.dot(right) / depth / th).abs());
            my = my.max((c.dot(up) / depth / tv).abs());
        }
        let fill = mx.max(my);
        assert!((fill - MODEL_FILL as f32).abs() < 1e-4, "{mx} {my}");
        assert!(s.lights[0].position.y > cam.eye.y);
    }
}
