//! Textured and vertex-coloured instances (issue 53): a mesh with texture coordinates, a
//! texture or vertex colours is stored once and placed by its instances
//! (`scene/instance.rs`), on the CPU's two-level walk and the compute kernel's, shading each
//! hit as the flattened scene's triangle (`Scene::flattened`) would:
//!
//! - the scene: the textured duck (`duck/duck.obj`, `duckCM.png`) placed four times (as
//!   loaded, mirrored, non-uniformly scaled and rotated, scaled up), an octahedron with
//!   vertex colours and vertex normals placed three times (one mirrored, one non-uniformly
//!   scaled) in a reflective material (its child cones bent by the placed curvature), a
//!   mirror sphere and the floor of the scene's own triangles;
//! - the CPU's two-level walk in f64 against the flattened scene's render in f64 (the
//!   reference), and in f32 on every CPU path against the flattened scene's f32 render;
//! - every GPU kernel (compute, looped, unrolled, multipass: all two levels) against the
//!   CPU's two-level f64 image, and the fragment kernels' bytes against the compute
//!   kernel's (the record pass copies a level's cone beside its instance, so the passes
//!   that shade read both from one texture unit);
//! - the flattened scene stores each instance's uvs and colours as the flat path did.

mod common;
use fragtrace::gpu::options::Kernel;
use fragtrace::options::{AccelChoice, Backend, CpuPath, Precision, RenderOptions};
use fragtrace::render::{render_cpu, render_gl_with, Rendered};
use fragtrace::scene::{load_scene_str_with_search_path, Scene};

/// An octahedron (radius 1) with a colour per vertex and smooth vertex normals.
const COLOURED_OBJ: &str = "\
v 1 0 0 1 0 0
v -1 0 0 0 1 0
v 0 1 0 0 0 1
v 0 -1 0 1 1 0
v 0 0 1 0 1 1
v 0 0 -1 1 0 1
vn 1 0 0
vn -1 0 0
vn 0 1 0
vn 0 -1 0
vn 0 0 1
vn 0 0 -1
f 1//1 3//3 5//5
f 5//5 3//3 2//2
f 2//2 3//3 6//6
f 6//6 3//3 1//1
f 5//5 4//4 1//1
f 2//2 4//4 5//5
f 6//6 4//4 2//2
f 1//1 4//4 6//6
";

const SCENE: &str = r#"
background = [0.55, 0.65, 0.8]
ambient = [0.15, 0.15, 0.15]
max_depth = 4
[camera]
eye = [0.0, 2.2, 5.0]
look_at = [0.0, 0.5, 0.0]
fov = 45
[[lights]]
position = [3.0, 6.0, 4.0]
[materials.floor]
checker = { a = [0.9, 0.9, 0.9], b = [0.3, 0.3, 0.3], scale = 0.5 }
[materials.mirror]
albedo = [0.6, 0.6, 0.6]
kd = 0.1
ks = [0.6, 0.6, 0.6]
ns = 80
kr = [0.8, 0.8, 0.8]
[materials.shiny]
albedo = [1.0, 1.0, 1.0]
ks = [0.4, 0.4, 0.4]
ns = 40
kr = [0.4, 0.4, 0.4]
[[objects]]
shape = "quad"
size = 8
material = "floor"
[[objects]]
shape = "sphere"
subdivisions = 3
radius = 0.5
translate = [1.6, 0.5, -0.8]
material = "mirror"
[[objects]]
mesh = "duck/duck.obj"
instances = [
  { translate = [-1.2, 0.0, 0.0], scale = 0.8 },
  { translate = [0.2, 0.0, 0.3], scale = [-0.8, 0.8, 0.8], rotate = [0, 30, 0] },
  { translate = [-0.3, 0.0, -1.2], scale = [1.2, 0.6, 0.7], rotate = [0, -70, 0] },
  { translate = [0.9, 0.0, 1.2], scale = 0.5, rotate = [0, 200, 0] },
]
[[objects]]
mesh = "coloured.obj"
material = "shiny"
instances = [
  { translate = [1.3, 0.4, 0.7], scale = 0.4 },
  { translate = [-1.6, 0.35, 1.2], scale = [-0.35, 0.35, 0.35], rotate = [0, 25, 0] },
  { translate = [-0.2, 0.3, 1.5], scale = [0.5, 0.3, 0.2], rotate = [20, 40, 0] },
]
"#;

/// The scene, loaded with the shipped models and the coloured octahedron written next to
/// it.
fn scene() -> Scene {
    load(SCENE, "scene")
}

/// Scene `text` loaded from a scratch folder of its own holding the octahedron, the shipped models on the search path.
fn load(text: &str, name: &str) -> Scene {
    // One folder per call: `tmpdir` empties its folder, and several tests load at once.
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let k = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = common::tmpdir(&format!("{name}-{k}"));
    std::fs::write(dir.join("coloured.obj"), COLOURED_OBJ).unwrap();
    let mut search = vec![dir.clone()];
    search.extend(common::model_path());
    let name = format!("{name}.toml");
    load_scene_str_with_search_path(text, &name, &dir, &search).unwrap()
}

fn opts(
    scene: &Scene,
    backend: Backend,
    precision: Precision,
    accel: AccelChoice,
) -> RenderOptions {
    let mut o = RenderOptions {
        width: 64,
        height: 48,
        precision,
        accel,
        backend,
        ..RenderOptions::for_scene(scene)
    };
    o.readback.aov = true;
    o
}

/// The CPU render of `s` in `precision` on `path` with the BVH (two levels for an
/// instanced scene, one for its flattened copy).
fn cpu(s: &Scene, precision: Precision, path: CpuPath) -> Rendered {
    let mut o = opts(s, Backend::Cpu, precision, AccelChoice::Bvh);
    o.cpu_path = path;
    render_cpu(s, &o).unwrap()
}

/// The share of pixels whose primary triangle ids differ.
fn ids_differ(a: &Rendered, b: &Rendered) -> f64 {
    let n = (a.aov.pixels.iter().zip(&b.aov.pixels))
        .filter(|(p, q)| p.primid != q.primid)
        .count();
    n as f64 / a.aov.pixels.len() as f64
}

/// The largest colour difference over the pixels whose primary ray met the same triangle
/// (or missed) in both.
fn max_abs_same_id(a: &Rendered, b: &Rendered) -> f32 {
    (a.image.data.chunks(3).zip(b.image.data.chunks(3)))
        .zip(a.aov.pixels.iter().zip(&b.aov.pixels))
        .filter(|(_, (p, q))| p.primid == q.primid)
        .flat_map(|((x, y), _)| x.iter().zip(y).map(|(p, q)| (p - q).abs()))
        .fold(0.0, f32::max)
}

/// The scene with every instance written as an object of its own (what the scene file's
/// loader stored flat before textured meshes were instanced), in the same order.
fn flat_objects_text() -> String {
    let mut blocks = SCENE.split("[[objects]]\n");
    let mut out = blocks.next().unwrap().to_string();
    for block in blocks {
        let Some((header, list)) = block.split_once("instances = [\n") else {
            out += "[[objects]]\n";
            out += block;
            continue;
        };
        for line in list.lines().take_while(|l| *l != "]") {
            out += "[[objects]]\n";
            out += header;
            // `{ key = value, ... },`: the values bare numbers or arrays.
            let mut rest = line
                .trim()
                .trim_end_matches(',')
                .trim_matches(['{', '}', ' ']);
            while let Some(eq) = rest.find(" = ") {
                let key = rest[..eq].trim_matches([',', ' ']);
                let v = &rest[eq + 3..];
                let end = match v.strip_prefix('[') {
                    Some(_) => v.find(']').unwrap() + 1,
                    None => v.find(',').unwrap_or(v.len()),
                };
                out += &format!("{key} = {}\n", &v[..end]);
                rest = &v[end..];
            }
        }
    }
    out
}

/// The flattened scene renders the image of the scene whose instances are written as
/// objects of their own (the scene file's flat path, an independent placement of each
/// vertex): in f64 on the uniform grid, bit for bit (measured: the same bytes).
#[test]
fn the_flattened_scene_renders_the_flat_objects_image_bit_for_bit() {
    let s = scene();
    let text = flat_objects_text();
    let objects = load(&text, "flat");
    assert!(!objects.has_instances(), "{text}");
    let flat = s.flattened(u64::MAX, "the test").unwrap();
    assert_eq!(flat.triangles.len(), objects.triangles.len());
    let render = |sc: &Scene| {
        render_cpu(
            sc,
            &opts(sc, Backend::Cpu, Precision::F64, AccelChoice::Uniform),
        )
        .unwrap()
    };
    let (a, b) = (render(&flat), render(&objects));
    let bits = |r: &Rendered| r.image.data.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let differ = bits(&a)
        .iter()
        .zip(&bits(&b))
        .filter(|(x, y)| x != y)
        .count();
    assert_eq!(differ, 0, "{differ} image values differ");
    assert!(a.image.data.iter().any(|&v| v > 0.0));
}

/// The scene holds the duck and the octahedron once each with their uvs and colours, and
/// the flattened scene stores each instance's copy of them in its placed winding.
#[test]
fn textured_and_coloured_meshes_are_stored_once() {
    let s = scene();
    let inst = &s.instancing;
    assert_eq!((inst.meshes.len(), inst.instances.len()), (2, 7));
    let (duck, oct) = (&inst.meshes[0].geometry, &inst.meshes[1].geometry);
    assert_eq!(duck.tri_uvs.len(), duck.triangles.len());
    assert!(!duck.uvs.is_empty() && duck.colors.is_empty());
    assert_eq!(oct.colors.len(), oct.positions.len());
    assert!(s.has_textures() && s.has_vertex_colors());
    assert!(
        s.textures.len() == 1,
        "the duck's texture, held by the scene once"
    );
    let flat = s.flattened(u64::MAX, "the test").unwrap();
    assert_eq!(flat.triangles.len() as u64, s.instanced_triangles());
    assert_eq!(flat.tri_uvs.len(), flat.triangles.len());
    assert_eq!(flat.colors.len(), flat.positions.len());
    // Every triangle's corners, flattened and read through the placed helpers, agree.
    for id in 0..flat.triangles.len() {
        let uvi = flat.triangle_uv_indices(id);
        let want_uv =
            (uvi[0] != fragtrace::scene::NO_UV).then(|| uvi.map(|k| flat.uvs[k as usize]));
        assert_eq!(s.placed_uvs(id), want_uv, "triangle {id}");
        let want_c = flat.triangles[id].v.map(|k| flat.colors[k as usize]);
        let got_c = s.placed_colors(id).unwrap_or([glam::Vec3::ONE; 3]);
        assert_eq!(got_c, want_c, "triangle {id}");
        assert_eq!(
            s.placed_vertices(id),
            flat.triangle_vertices(id),
            "triangle {id}"
        );
    }
}

/// The CPU's two-level walk renders the flattened scene's image, in f64 and in f32 on every
/// path (the bounds below, a small multiple above the measured figures): the same texels,
/// levels of detail and vertex colours, up to the hit's t and barycentrics, which the
/// two-level walk computes in object space (so not bit for bit, as for untextured
/// instances: `tests/instancing.rs`).
#[test]
fn the_cpu_two_level_walk_shades_as_the_flattened_scene() {
    let s = scene();
    let flat = s.flattened(u64::MAX, "the test").unwrap();
    for (precision, path, max_abs, max_rmse, max_share) in [
        (
            Precision::F64,
            CpuPath::Scalar,
            MAX_ABS_F64,
            RMSE_F64,
            ID_SHARE,
        ),
        (
            Precision::F32,
            CpuPath::Scalar,
            MAX_ABS_F32,
            RMSE_F32,
            ID_SHARE,
        ),
        (
            Precision::F32,
            CpuPath::Simd,
            MAX_ABS_F32,
            RMSE_F32,
            ID_SHARE,
        ),
        (
            Precision::F32,
            CpuPath::Packet,
            MAX_ABS_F32,
            RMSE_F32,
            ID_SHARE,
        ),
    ] {
        let two = cpu(&s, precision, path);
        let one = cpu(&flat, precision, path);
        assert!(
            two.stats.accel.detail.contains("7 instances of 2 meshes"),
            "{}",
            two.stats.accel.detail
        );
        let diff = max_abs_same_id(&two, &one);
        let rmse = fragtrace::compare::compare(&two.image, &one.image, 0.01, true)
            .unwrap()
            .rmse;
        let share = ids_differ(&two, &one);
        println!("{precision:?} {path:?}: max abs {diff:e} (same ids), RMSE {rmse:e}, ids differ on {share:.5}");
        assert!(diff <= max_abs, "{precision:?} {path:?}: max abs {diff}");
        assert!(rmse <= max_rmse, "{precision:?} {path:?}: RMSE {rmse}");
        assert!(
            share <= max_share,
            "{precision:?} {path:?}: ids differ on {share}"
        );
    }
}

// Measured (64x48, llvmpipe host): f64 max abs 4.9e-6, RMSE 3.5e-7; f32 (every path)
// max abs 3.3e-6, RMSE 9.6e-8; no pixel's primary id differs (3 of 3,072 allowed, for
// silhouette pixels the object-space test may move).
const MAX_ABS_F64: f32 = 1.5e-5;
const RMSE_F64: f64 = 2e-6;
const MAX_ABS_F32: f32 = 1e-5;
const RMSE_F32: f64 = 5e-7;
const ID_SHARE: f64 = 0.001;

/// Every GPU kernel walks the textured instances as two levels (its stats say so) and
/// renders the CPU's two-level f64 image within the bound; the fragment kernels render the
/// compute kernel's bytes, image and primary AOVs alike.
#[test]
fn every_gpu_kernel_renders_textured_instances_as_the_cpu() {
    let s = scene();
    let reference = cpu(&s, Precision::F64, CpuPath::Scalar);
    common::with_test_context(|ctx| {
        let mut compute = None;
        for kernel in [
            Kernel::Compute,
            Kernel::Looped,
            Kernel::Unrolled(3),
            Kernel::Multipass,
        ] {
            let mut o = opts(&s, Backend::Gl, Precision::F32, AccelChoice::Uniform);
            o.gpu.kernel = kernel;
            let gl = render_gl_with(ctx, &s, &o).unwrap();
            assert!(
                gl.stats.accel.detail.starts_with("instanced: 7 instances"),
                "{kernel:?}: {}",
                gl.stats.accel.detail
            );
            let rmse = fragtrace::compare::compare(&gl.image, &reference.image, 0.01, true)
                .unwrap()
                .rmse;
            let share = ids_differ(&gl, &reference);
            println!("{kernel:?}: RMSE {rmse:e}, ids differ on {share:.5}");
            assert!(rmse < RMSE_GL_VS_CPU64, "{kernel:?}: RMSE {rmse}");
            assert!(share <= ID_SHARE, "{kernel:?}: ids differ on {share}");
            match &compute {
                None => compute = Some(gl),
                Some(c) => assert_eq!(bit_difference(&gl, c), None, "{kernel:?}"),
            }
        }
    });
}

/// Where `a` and `b` differ in any bit of the image or of a primary-ray AOV value (depth,
/// primitive id): the count, or None for the same bytes.
fn bit_difference(a: &Rendered, b: &Rendered) -> Option<String> {
    let bits = |r: &Rendered| {
        let image = r.image.data.iter().map(|x| x.to_bits());
        let aov = r
            .aov
            .pixels
            .iter()
            .flat_map(|p| [p.depth.to_bits(), p.primid.to_bits()]);
        image.chain(aov).collect::<Vec<u32>>()
    };
    let (x, y) = (bits(a), bits(b));
    let n = x.iter().zip(&y).filter(|(p, q)| p != q).count();
    (n > 0 || x.len() != y.len()).then(|| format!("{n} values differ"))
}

// Measured on llvmpipe: compute (two levels) 3.5e-7, looped and multipass (flat) 3.7e-7.
const RMSE_GL_VS_CPU64: f64 = 2e-6;

/// A glTF whose one mesh (texture coordinates and vertex colours) two nodes place, one
/// mirroring: in a scene the mesh is stored once with its coordinates and colours, and the
/// flattened scene's corners carry the very coordinates and colours the glTF loaded flat
/// gives (each triangle's corners in the same order: the mirrored one's winding reversed
/// alike).
#[test]
fn a_gltf_mesh_shared_by_nodes_keeps_its_uvs_and_colours_stored_once() {
    use base64::Engine as _;
    let mut bin = Vec::new();
    let put = |bin: &mut Vec<u8>, v: &[f32]| bin.extend(v.iter().flat_map(|c| c.to_le_bytes()));
    put(&mut bin, &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    put(&mut bin, &[0.0, 0.0, 1.0, 0.0, 0.25, 0.75]);
    put(&mut bin, &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    );
    let doc = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,
"scenes":[{{"nodes":[0,1]}}],
"nodes":[{{"translation":[2,0,0],"mesh":0}},
 {{"matrix":[-1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,-1,1],"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"TEXCOORD_0":1,"COLOR_0":2}}}}]}}],
"buffers":[{{"byteLength":{},"uri":"{uri}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":96}}],
"accessors":[{{"bufferView":0,"byteOffset":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
 {{"bufferView":0,"byteOffset":36,"componentType":5126,"count":3,"type":"VEC2"}},
 {{"bufferView":0,"byteOffset":60,"componentType":5126,"count":3,"type":"VEC3"}}]}}"#,
        bin.len()
    );
    let dir = common::tmpdir("gltf");
    let file = dir.join("shared.gltf");
    std::fs::write(&file, doc).unwrap();
    let text = format!(
        "[camera]\neye = [0, 2, 30]\nlook_at = [0, 0, 0]\nfov = 40\n[[objects]]\nmesh = \"{}\"\n",
        file.display()
    );
    let s = load_scene_str_with_search_path(&text, "g.toml", &dir, &[]).unwrap();
    assert_eq!(s.triangles.len(), 0);
    assert_eq!(
        (s.instancing.meshes.len(), s.instancing.instances.len()),
        (1, 2)
    );
    let g = &s.instancing.meshes[0].geometry;
    assert_eq!((g.uvs.len(), g.tri_uvs.len(), g.colors.len()), (3, 1, 3));
    let flat = s.flattened(u64::MAX, "the test").unwrap();
    let loaded = fragtrace::scene::load_gltf(&file).unwrap();
    assert_eq!(loaded.triangles.len(), 2);
    // Each triangle's corners as (u, v, r, g, b) bits, the triangles sorted.
    let corners = |tris: &[fragtrace::scene::Triangle],
                   tri_uvs: &[[u32; 3]],
                   uvs: &[glam::Vec2],
                   colors: &[glam::Vec3]| {
        let mut v: Vec<Vec<[u32; 5]>> = (tris.iter().zip(tri_uvs))
            .map(|(t, uv)| {
                (0..3)
                    .map(|k| {
                        let (u, c) = (uvs[uv[k] as usize], colors[t.v[k] as usize]);
                        [u.x, u.y, c.x, c.y, c.z].map(f32::to_bits)
                    })
                    .collect()
            })
            .collect();
        v.sort();
        v
    };
    let got = corners(&flat.triangles, &flat.tri_uvs, &flat.uvs, &flat.colors);
    let want = corners(
        &loaded.triangles,
        &loaded.tri_uvs,
        &loaded.uvs,
        &loaded.colors,
    );
    assert_eq!(got, want);
    assert_ne!(
        got[0], got[1],
        "the mirrored triangle's corners come in another order"
    );
}
