//! The instancing buffer of the compute kernel (`glsl120/instance.glsl`): an instanced
//! scene's placements, its meshes' grids and the top tree over the placements, in vec4
//! texels, declared once here and generated as the GLSL's `INST_*`, `MESH_*` and `NODE_*`
//! constants ([`instancing_glsl`]). Integers (ids, offsets, counts) are stored as their
//! bits (`f32::from_bits`, read by `floatBitsToUint`), exact to 2^32.
//!
//! | texels | contents |
//! |---|---|
//! | header, 1 | (instances, first mesh texel, first node texel, first reference texel) |
//! | per instance, [`INST_TEXELS`] | inverse rows 0..2 with (mesh, first id, mirrors) in w; translation; linear rows 0..2; normal-matrix rows 0..2 |
//! | per mesh, [`MESH_TEXELS`] | (grid min, first cell), (grid max, first packed triangle), (cell size, 0), (cells per axis, 0) |
//! | per top node, [`NODE_TEXELS`] | the 4-wide node's lower x, y, z and upper x, y, z of its four children, then child and count |
//! | references | the top tree's leaf entries (instance indices), four to a texel |

use crate::accel::grid_instances::{GridInstances, TOP_STACK};
use crate::scene::Scene;

/// Texels per instance.
pub const INST_TEXELS: usize = 10;
/// Texels per mesh.
pub const MESH_TEXELS: usize = 4;
/// Texels per top-level node.
pub const NODE_TEXELS: usize = 8;

/// The instancing buffer of `scene` (its placements) over its levels `gi`.
pub fn instancing_buffer(scene: &Scene, gi: &GridInstances) -> Vec<[f32; 4]> {
    let bits = |u: u32| f32::from_bits(u);
    let inst = &scene.instancing.instances;
    let mesh_base = 1 + inst.len() * INST_TEXELS;
    let node_base = mesh_base + gi.meshes.len() * MESH_TEXELS;
    let ref_base = node_base + gi.top.nodes.len() * NODE_TEXELS;
    let mut v = Vec::with_capacity(ref_base + gi.top.tri_indices.len().div_ceil(4));
    v.push([
        bits(inst.len() as u32),
        bits(mesh_base as u32),
        bits(node_base as u32),
        bits(ref_base as u32),
    ]);
    for i in inst {
        let row = |m: &glam::DMat3, k: usize, w: f32| {
            let r = m.row(k).as_vec3();
            [r.x, r.y, r.z, w]
        };
        let t = i.translate.as_vec3();
        let mirrors = if i.mirrors() { 1.0 } else { 0.0 };
        v.push(row(&i.inverse, 0, bits(i.mesh)));
        v.push(row(&i.inverse, 1, bits(i.first)));
        v.push(row(&i.inverse, 2, mirrors));
        v.push([t.x, t.y, t.z, 0.0]);
        for k in 0..3 {
            v.push(row(&i.linear, k, 0.0));
        }
        for k in 0..3 {
            v.push(row(&i.normal_matrix, k, 0.0));
        }
    }
    for m in &gi.meshes {
        let r = m.res.map(|r| r as f32);
        v.push([m.min.x, m.min.y, m.min.z, bits(m.cell_base)]);
        v.push([m.max.x, m.max.y, m.max.z, bits(m.tri_base)]);
        v.push([m.cell_size.x, m.cell_size.y, m.cell_size.z, 0.0]);
        v.push([r[0], r[1], r[2], 0.0]);
    }
    for n in &gi.top.nodes {
        v.extend(n.lo);
        v.extend(n.hi);
        v.push(n.child.map(bits));
        v.push(n.count.map(bits));
    }
    for c in gi.top.tri_indices.chunks(4) {
        let mut t = [0f32; 4];
        for (k, &r) in c.iter().enumerate() {
            t[k] = bits(r);
        }
        v.push(t);
    }
    v
}

/// The generated GLSL constants.
pub fn instancing_glsl() -> String {
    format!(
        "#define INST_TEXELS {INST_TEXELS}u\n#define MESH_TEXELS {MESH_TEXELS}u\n\
         #define NODE_TEXELS {NODE_TEXELS}u\n#define TOP_STACK {TOP_STACK}\n"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The header's offsets land on the sections they name, and a placement's texels hold
    /// its matrices' rows and its ids' bits.
    #[test]
    fn buffer_sections_are_where_the_header_says() {
        let toml = r#"
[camera]
eye = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
fov = 40
[[objects]]
shape = "box"
[[objects]]
shape = "sphere"
subdivisions = 1
instances = [{ translate = [1, 0, 0] }, { scale = [-1, 2, 1], rotate = [0, 30, 0] }]
"#;
        let scene =
            crate::scene::load_scene_str(toml, "t.toml", std::path::Path::new(".")).unwrap();
        let gi = GridInstances::build(&scene, &Default::default()).unwrap();
        let v = instancing_buffer(&scene, &gi);
        let h = v[0].map(f32::to_bits);
        let n = scene.instancing.instances.len();
        assert_eq!(h[0] as usize, n);
        assert_eq!(h[1] as usize, 1 + n * INST_TEXELS);
        assert_eq!(h[2] as usize, h[1] as usize + gi.meshes.len() * MESH_TEXELS);
        assert_eq!(
            h[3] as usize,
            h[2] as usize + gi.top.nodes.len() * NODE_TEXELS
        );
        assert_eq!(
            v.len(),
            h[3] as usize + gi.top.tri_indices.len().div_ceil(4)
        );
        let last = scene.instancing.instances[n - 1];
        let at = 1 + (n - 1) * INST_TEXELS;
        assert_eq!(v[at][3].to_bits(), last.mesh);
        assert_eq!(v[at + 1][3].to_bits(), last.first);
        assert_eq!(v[at + 4][1], last.linear.row(0).y as f32);
        let m = gi.meshes[last.mesh as usize];
        let mt = h[1] as usize + last.mesh as usize * MESH_TEXELS;
        assert_eq!(v[mt][3].to_bits(), m.cell_base);
        assert_eq!(v[mt + 1][3].to_bits(), m.tri_base);
    }
}
