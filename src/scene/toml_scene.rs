//! TEMPORARY stub until the loader lands.
use super::Scene;
use crate::{Error, Result};
use std::path::Path;
/// stub
pub fn load_scene(p: &Path) -> Result<Scene> {
    Err(Error::Usage(format!(
        "{}: scene loading not yet available",
        p.display()
    )))
}
/// stub
pub fn builtin_scene() -> Scene {
    use super::*;
    use glam::Vec3;
    let mut s = Scene::empty(Camera {
        eye: Vec3::new(0.0, 1.5, 6.0),
        look_at: Vec3::new(0.0, 0.8, 0.0),
        up: Vec3::Y,
        vfov_deg: 45.0,
    });
    let floor = s.add_material(Material {
        checker: Some(Checker {
            color_a: Vec3::new(1.0, 0.1, 0.1),
            color_b: Vec3::new(1.0, 0.9, 0.1),
            scale: 1.0,
            axes: CheckerAxes::Xz,
        }),
        ka: 1.0,
        ..Material::default()
    });
    let mirror = s.add_material(Material {
        albedo: Vec3::splat(0.1),
        kr: Vec3::splat(0.8),
        ks: Vec3::splat(0.5),
        ns: 50.0,
        ..Material::default()
    });
    let glass = s.add_material(Material {
        albedo: Vec3::splat(0.0),
        fresnel: true,
        ior: 1.5,
        ks: Vec3::splat(0.5),
        ns: 100.0,
        ..Material::default()
    });
    let a = Vec3::new(-8.0, 0.0, -8.0);
    let b = Vec3::new(8.0, 0.0, -8.0);
    let c = Vec3::new(8.0, 0.0, 8.0);
    let d = Vec3::new(-8.0, 0.0, 8.0);
    s.add_triangle(a, c, b, floor);
    s.add_triangle(a, d, c, floor);
    s.add_triangle(
        Vec3::new(-1.5, 0.2, -1.0),
        Vec3::new(-0.2, 0.2, -1.0),
        Vec3::new(-0.8, 2.0, -1.0),
        mirror,
    );
    s.add_triangle(
        Vec3::new(0.2, 0.3, 1.0),
        Vec3::new(1.5, 0.3, 1.0),
        Vec3::new(0.8, 1.8, 1.0),
        glass,
    );
    s.add_triangle(
        Vec3::new(0.2, 0.3, 0.6),
        Vec3::new(0.8, 1.8, 0.6),
        Vec3::new(1.5, 0.3, 0.6),
        glass,
    );
    s.lights.push(Light {
        position: Vec3::new(3.0, 6.0, 4.0),
        color: Vec3::ONE,
        intensity: 0.9,
    });
    s
}
