//! The hash that ties parts to their scene and options: 64-bit FNV-1a, defined here so
//! that it stays the same across Rust versions and machines (std's `DefaultHasher` makes
//! no such promise) — parts of one image are made by different processes, possibly by
//! different builds of fragtrace on different nodes. It guards against mixing up parts
//! by accident, not against an adversary.

use crate::scene::Scene;

pub use crate::fnv::Fnv64;

/// A hash of what a scene renders: camera and camera path, lights, materials, background,
/// ambient, depth, local origin, and every vertex, normal and triangle, bit for bit (the
/// instanced meshes' too, and every instance's placement). Not its source path
/// (nodes of a cluster may mount the scene at different places) nor its default size (the
/// options carry the size rendered).
pub fn scene_hash(scene: &Scene) -> u64 {
    let mut h = Fnv64::new();
    // Debug of floats prints the shortest string that reads back to the same bits, so it
    // is an exact, stable encoding of these small structures.
    h.write_str(&format!(
        "{:?}|{:?}|{:?}|{:?}|{:?}|{:?}|{}|{:?}",
        scene.camera,
        scene.animation,
        scene.lights,
        scene.materials,
        scene.background,
        scene.ambient,
        scene.max_depth,
        scene.origin
    ));
    for p in scene.positions.iter().chain(&scene.normals) {
        for c in p.to_array() {
            h.write(&c.to_bits().to_le_bytes());
        }
    }
    h.write(&(scene.triangles.len() as u64).to_le_bytes());
    for t in &scene.triangles {
        for i in t.v.iter().chain(&t.n).chain([&t.material]) {
            h.write(&i.to_le_bytes());
        }
    }
    // Instances (nothing for a scene without: its hash is what it was before instancing).
    let inst = &scene.instancing;
    for m in &inst.meshes {
        let g = &m.geometry;
        for p in g.positions.iter().chain(&g.normals) {
            for c in p.to_array() {
                h.write(&c.to_bits().to_le_bytes());
            }
        }
        h.write(&(g.triangles.len() as u64).to_le_bytes());
        for t in &g.triangles {
            for i in t.v.iter().chain(&t.n).chain([&t.material]) {
                h.write(&i.to_le_bytes());
            }
        }
    }
    for i in &inst.instances {
        h.write(&i.mesh.to_le_bytes());
        for c in i
            .linear
            .to_cols_array()
            .iter()
            .chain(&i.translate.to_array())
        {
            h.write(&c.to_bits().to_le_bytes());
        }
    }
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The published FNV-1a 64 test vectors.
    #[test]
    fn known_answers() {
        let of = |s: &str| {
            let mut h = Fnv64::new();
            h.write(s.as_bytes());
            h.finish()
        };
        assert_eq!(of(""), 0xcbf29ce484222325);
        assert_eq!(of("a"), 0xaf63dc4c8601ec8c);
        assert_eq!(of("foobar"), 0x85944171f73967e8);
    }

    #[test]
    fn scene_hash_sees_a_moved_vertex_and_not_the_path() {
        let a = crate::scene::builtin_scene();
        let mut b = a.clone();
        b.source = "/elsewhere/scene.toml".into();
        assert_eq!(scene_hash(&a), scene_hash(&b));
        b.positions[0].x = f32::from_bits(b.positions[0].x.to_bits() + 1);
        assert_ne!(scene_hash(&a), scene_hash(&b));
        let mut c = a.clone();
        c.camera.vfov_deg += 1.0;
        assert_ne!(scene_hash(&a), scene_hash(&c));
    }
}
