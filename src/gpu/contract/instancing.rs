//! The instancing data of an instanced scene (`glsl120/instance.glsl`, whose walk every
//! kernel shares): its placements, its meshes' grids and the top tree over the placements,
//! in RGBA32F texels, declared once here and generated as the GLSL's `INST_*`, `MESH_*` and
//! `ENTRY_*` constants ([`instancing_glsl`]). The layout packs it as the texture `inst`
//! (`gpu/layout`), which the fragment kernels sample and the compute kernel reads through
//! the same generated `fetch_inst`. Integers (ids, offsets, counts) are stored as float
//! values, exact below 2^24 ([`instancing_texels`] refuses more); an instance's first id,
//! which runs to 2^32, is split over two channels (hi * 2^24 + lo).
//!
//! The top tree is threaded (stackless): the CPU's 4-wide BVH over the instances
//! (`accel/grid_instances.rs`) flattened depth first, each entry a box and the entry after
//! its subtree (its skip), so a walk's place in the tree is one entry index (what the
//! fragment kernels keep between passes): a box met goes on to the next entry (an inner
//! entry's first child, or after a leaf its sibling), a box missed to its skip. A leaf of
//! several instances becomes an inner entry over one entry per instance.
//!
//! | texels | contents |
//! |---|---|
//! | header, 1 | (entries, first entry texel, first mesh texel, instances) |
//! | per instance, [`INST_TEXELS`] | inverse rows 0..2 with (mesh, first id lo, mirrors) in w; (translation, first id hi); linear rows 0..2; normal-matrix rows 0..2 |
//! | per mesh, [`MESH_TEXELS`] | (grid min, first cell), (grid max, first packed triangle), (cell size, 0), (cells per axis, 0) |
//! | per entry, [`ENTRY_TEXELS`] | (box lower corner, skip), (box upper corner, instance or -1 for an inner entry) |

use glam::Vec3;

use crate::accel::bvh::Bvh;
use crate::accel::grid_instances::GridInstances;
use crate::scene::Scene;
use crate::{Error, Result};

/// Texels per instance.
pub const INST_TEXELS: usize = 10;
/// Texels per mesh.
pub const MESH_TEXELS: usize = 4;
/// Texels per top-level entry.
pub const ENTRY_TEXELS: usize = 2;
/// Base of an instance's first id split over two floats.
const ID_SPLIT: u32 = 1 << 24;

/// One entry of the threaded top tree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Entry {
    /// Its box.
    pub lo: Vec3,
    /// Upper corner.
    pub hi: Vec3,
    /// The entry after its subtree.
    pub skip: u32,
    /// The instance of a leaf entry; None for an inner entry.
    pub instance: Option<u32>,
}

/// The top tree `top` (its leaves' references index `boxes`, the instances' boxes)
/// flattened depth first, children in slot order, with skips.
pub fn threaded(top: &Bvh, boxes: &[(Vec3, Vec3)]) -> Vec<Entry> {
    fn node(top: &Bvh, boxes: &[(Vec3, Vec3)], n: usize, out: &mut Vec<Entry>) {
        let nd = &top.nodes[n];
        for i in 0..4 {
            let lo = Vec3::new(nd.lo[0][i], nd.lo[1][i], nd.lo[2][i]);
            let hi = Vec3::new(nd.hi[0][i], nd.hi[1][i], nd.hi[2][i]);
            let (child, count) = (nd.child[i] as usize, nd.count[i] as usize);
            if count == 0 && lo.x > hi.x {
                continue; // an empty slot
            }
            let at = out.len();
            if count == 1 {
                let k = top.tri_indices[child];
                let (lo, hi) = boxes[k as usize];
                out.push(Entry {
                    lo,
                    hi,
                    skip: at as u32 + 1,
                    instance: Some(k),
                });
                continue;
            }
            out.push(Entry {
                lo,
                hi,
                skip: 0,
                instance: None,
            });
            if count == 0 {
                node(top, boxes, child, out);
            } else {
                for &k in &top.tri_indices[child..child + count] {
                    let (lo, hi) = boxes[k as usize];
                    let skip = out.len() as u32 + 1;
                    out.push(Entry {
                        lo,
                        hi,
                        skip,
                        instance: Some(k),
                    });
                }
            }
            out[at].skip = out.len() as u32;
        }
    }
    let mut out = Vec::new();
    if !boxes.is_empty() && !top.nodes.is_empty() {
        node(top, boxes, 0, &mut out);
    }
    out
}

/// The instances' boxes in local space (what the top tree was built over).
fn instance_boxes(scene: &Scene, gi: &GridInstances) -> Vec<(Vec3, Vec3)> {
    scene
        .instancing
        .instances
        .iter()
        .map(|i| {
            let m = &gi.meshes[i.mesh as usize];
            i.bounds(m.min, m.max)
        })
        .collect()
}

/// Texels the instancing data of `scene` over `gi` takes (what the layout plan counts
/// before packing it).
pub fn instancing_texels(scene: &Scene, gi: &GridInstances) -> u64 {
    let entries = threaded(&gi.top, &instance_boxes(scene, gi)).len();
    (1 + scene.instancing.instances.len() * INST_TEXELS
        + gi.meshes.len() * MESH_TEXELS
        + entries * ENTRY_TEXELS) as u64
}

/// The instancing data of `scene` (its placements) over its levels `gi`; refused where an
/// index it stores as a float passes 2^24.
pub fn instancing_data(scene: &Scene, gi: &GridInstances) -> Result<Vec<[f32; 4]>> {
    let inst = &scene.instancing.instances;
    let entries = threaded(&gi.top, &instance_boxes(scene, gi));
    let mesh_base = 1 + inst.len() * INST_TEXELS;
    let entry_base = mesh_base + gi.meshes.len() * MESH_TEXELS;
    let total = entry_base + entries.len() * ENTRY_TEXELS;
    let biggest = gi
        .meshes
        .iter()
        .map(|m| m.cell_base.max(m.tri_base) as usize)
        .chain([total])
        .max()
        .unwrap_or(0);
    if biggest >= ID_SPLIT as usize {
        return Err(Error::Limit(format!(
            "{}: the GPU's instancing data indexes {biggest} texels, cells or triangles with              floats exact to 2^24; place fewer instances or smaller meshes, or render with              --backend cpu --accel bvh",
            scene.source
        )));
    }
    let mut v = Vec::with_capacity(total);
    v.push([
        entries.len() as f32,
        entry_base as f32,
        mesh_base as f32,
        inst.len() as f32,
    ]);
    for i in inst {
        let row = |m: &glam::DMat3, k: usize, w: f32| {
            let r = m.row(k).as_vec3();
            [r.x, r.y, r.z, w]
        };
        let t = i.translate.as_vec3();
        let mirrors = if i.mirrors() { 1.0 } else { 0.0 };
        let (hi, lo) = (i.first / ID_SPLIT, i.first % ID_SPLIT);
        v.push(row(&i.inverse, 0, i.mesh as f32));
        v.push(row(&i.inverse, 1, lo as f32));
        v.push(row(&i.inverse, 2, mirrors));
        v.push([t.x, t.y, t.z, hi as f32]);
        for k in 0..3 {
            v.push(row(&i.linear, k, 0.0));
        }
        for k in 0..3 {
            v.push(row(&i.normal_matrix, k, 0.0));
        }
    }
    for m in &gi.meshes {
        let r = m.res.map(|r| r as f32);
        v.push([m.min.x, m.min.y, m.min.z, m.cell_base as f32]);
        v.push([m.max.x, m.max.y, m.max.z, m.tri_base as f32]);
        v.push([m.cell_size.x, m.cell_size.y, m.cell_size.z, 0.0]);
        v.push([r[0], r[1], r[2], 0.0]);
    }
    for e in &entries {
        let inst = e.instance.map_or(-1.0, |k| k as f32);
        v.push([e.lo.x, e.lo.y, e.lo.z, e.skip as f32]);
        v.push([e.hi.x, e.hi.y, e.hi.z, inst]);
    }
    Ok(v)
}

/// The generated GLSL constants.
pub fn instancing_glsl() -> String {
    format!(
        "#define INST_TEXELS {INST_TEXELS}.0\n#define MESH_TEXELS {MESH_TEXELS}.0\n\
         #define ENTRY_TEXELS {ENTRY_TEXELS}.0\n#define ID_SPLIT {ID_SPLIT}.0\n"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const TOML: &str = r#"
[camera]
eye = [0.0, 0.0, 5.0]
look_at = [0.0, 0.0, 0.0]
fov = 40
[[objects]]
shape = "box"
[[objects]]
shape = "sphere"
subdivisions = 1
instances = [{ translate = [1, 0, 0] }, { scale = [-1, 2, 1], rotate = [0, 30, 0] }, { translate = [3, 0, 0] }, { translate = [0, 3, 0] }, { translate = [0, -3, 0] }, { translate = [-3, 0, 0] }]
"#;

    /// The header's offsets land on the sections they name, and a placement's texels hold
    /// its matrices' rows and its ids.
    #[test]
    fn data_sections_are_where_the_header_says() {
        let scene =
            crate::scene::load_scene_str(TOML, "t.toml", std::path::Path::new(".")).unwrap();
        let gi = GridInstances::build(&scene, &Default::default()).unwrap();
        let v = instancing_data(&scene, &gi).unwrap();
        let h = v[0].map(|x| x as usize);
        let n = scene.instancing.instances.len();
        assert_eq!(h[3], n);
        assert_eq!(h[2], 1 + n * INST_TEXELS);
        assert_eq!(h[1], h[2] + gi.meshes.len() * MESH_TEXELS);
        assert_eq!(v.len(), h[1] + h[0] * ENTRY_TEXELS);
        assert_eq!(v.len() as u64, instancing_texels(&scene, &gi));
        let last = scene.instancing.instances[n - 1];
        let at = 1 + (n - 1) * INST_TEXELS;
        assert_eq!(v[at][3], last.mesh as f32);
        assert_eq!(
            v[at + 1][3] as u32 + v[at + 3][3] as u32 * ID_SPLIT,
            last.first
        );
        assert_eq!(v[at + 4][1], last.linear.row(0).y as f32);
        let m = gi.meshes[last.mesh as usize];
        let mt = h[2] + last.mesh as usize * MESH_TEXELS;
        assert_eq!(v[mt][3], m.cell_base as f32);
        assert_eq!(v[mt + 1][3], m.tri_base as f32);
    }

    /// The threaded walk (next entry on a box met, skip on a miss) visits every instance
    /// once when every box is met, a subtree's entries lie inside its box, and for random
    /// query boxes the instances the walk reaches are brute force's (those whose boxes meet
    /// the query), with fewer box tests than entries where the query is small.
    #[test]
    fn threaded_tree_visits_each_instance_once_and_skips_subtrees() {
        let mut toml = TOML.replace("instances = [", "instances = [\n");
        for i in 0..60 {
            let at = format!("{{ translate = [{}, {}, 0] }},\n", i % 8 * 3, i / 8 * 3);
            toml = toml.replacen("instances = [\n", &format!("instances = [\n{at}"), 1);
        }
        let scene =
            crate::scene::load_scene_str(&toml, "t.toml", std::path::Path::new(".")).unwrap();
        let gi = GridInstances::build(&scene, &Default::default()).unwrap();
        let boxes = instance_boxes(&scene, &gi);
        let e = threaded(&gi.top, &boxes);
        let mut seen: Vec<u32> = e.iter().filter_map(|e| e.instance).collect();
        seen.sort_unstable();
        assert_eq!(seen, (0..boxes.len() as u32).collect::<Vec<_>>());
        for (k, x) in e.iter().enumerate() {
            assert!(x.skip as usize > k && x.skip as usize <= e.len());
            for y in &e[k + 1..x.skip as usize] {
                assert!(y.lo.cmpge(x.lo).all() && y.hi.cmple(x.hi).all(), "{k}");
            }
        }
        assert!(threaded(&gi.top, &[]).is_empty());
        let meets =
            |lo: Vec3, hi: Vec3, q: (Vec3, Vec3)| lo.cmple(q.1).all() && hi.cmpge(q.0).all();
        let mut rng = crate::testing::Rng::new(53);
        let mut fewer = 0;
        for _ in 0..200 {
            let c = rng.dvec3(-3.0, 24.0).as_vec3();
            let r = rng.range(0.1, 4.0) as f32;
            let q = (c - Vec3::splat(r), c + Vec3::splat(r));
            let (mut k, mut tests, mut reached) = (0usize, 0, Vec::new());
            while k < e.len() {
                tests += 1;
                if !meets(e[k].lo, e[k].hi, q) {
                    k = e[k].skip as usize;
                    continue;
                }
                reached.extend(e[k].instance);
                k += 1;
            }
            reached.sort_unstable();
            let want: Vec<u32> = (0..boxes.len() as u32)
                .filter(|&i| meets(boxes[i as usize].0, boxes[i as usize].1, q))
                .collect();
            assert_eq!(reached, want);
            fewer += usize::from(tests < e.len());
        }
        assert!(fewer > 100, "{fewer} of 200 queries skipped a subtree");
    }
}
