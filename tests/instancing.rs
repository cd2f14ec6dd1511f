//! Instancing (`instances = [...]` on an object; `scene/instance.rs`): the two-level BVH's
//! walk (`cpu/traverse_instances.rs`) against the same scene stored flat
//! (`Scene::flattened`), which the one-level BVH walks:
//!
//! - a known answer: a unit icosphere placed with scale 2 is met at a vertex at the
//!   closed-form t;
//! - hits on seeded random rays in f64: the same primitive id as brute force over the
//!   flattened scene (all but 0.1%), t within a relative 1e-5 (the flattened vertices are
//!   rounded to f32 after placing);
//! - images: every CPU path (f64 scalar; f32 scalar, vectorised, packets) renders the
//!   instanced scene as it renders the flattened one, within the bounds below;
//! - the scene file's errors name file, line and field.

mod common;
use common::Rng;
use fragtrace::accel::instances::TwoLevel;
use fragtrace::cpu::real::V3;
use fragtrace::cpu::traverse::{brute_force, Ray, Trace, Work};
use fragtrace::cpu::traverse_bvh::BvhWalker;
use fragtrace::cpu::traverse_instances::InstanceWalker;
use fragtrace::options::{AccelChoice, Backend, CpuPath, Precision, RenderOptions};
use fragtrace::render::render_cpu;
use fragtrace::scene::{load_scene_str, Scene};
use fragtrace::technique::Techniques;
use glam::DVec3;

/// Spheres (one mirrored, one sheared, one scaled by 2), boxes, a floor of the scene's own
/// triangles, a mirror material so that reflected rays meet instances too.
const SCENE: &str = r#"
[camera]
eye = [0.0, 3.0, 9.0]
look_at = [0.0, 0.5, 0.0]
fov = 40
[[lights]]
position = [4.0, 8.0, 6.0]
[materials.floor]
checker = { a = [0.9, 0.9, 0.9], b = [0.2, 0.2, 0.2], scale = 1.0 }
[materials.red]
albedo = [0.9, 0.2, 0.2]
ks = [0.5, 0.5, 0.5]
ns = 50
kr = [0.3, 0.3, 0.3]
[[objects]]
shape = "quad"
size = 20
material = "floor"
[[objects]]
shape = "sphere"
subdivisions = 3
radius = 0.5
material = "red"
instances = [
  { translate = [-2, 0.5, 0] },
  { translate = [0, 1, 0], scale = 2 },
  { translate = [2, 0.5, 0], scale = [1, 2, 0.5], rotate = [0, 30, 20] },
  { translate = [0, 0.5, 2.5], scale = [-1, 1, 1] },
]
[[objects]]
shape = "box"
size = [0.5, 0.5, 0.5]
[[objects.instances]]
translate = [-1, 0.25, 2]
rotate = [0, 45, 0]
[[objects.instances]]
translate = [1, 0.25, 2]
rotate = [0, 10, 0]
"#;

fn scene() -> Scene {
    load_scene_str(SCENE, "instancing.toml", std::path::Path::new(".")).unwrap()
}

/// The scene's own triangles, then every instance placed: brute force's input.
fn flat_tris(flat: &Scene) -> Vec<[V3<f64>; 3]> {
    (0..flat.triangles.len())
        .map(|i| flat.triangle_vertices(i).map(V3::from_vec3))
        .collect()
}

fn walker(scene: &Scene, levels: &TwoLevel) -> InstanceWalker<'static, f64> {
    // The walker borrows the scene and levels: leaked, a test's few kilobytes.
    let scene: &'static Scene = Box::leak(Box::new(scene.clone()));
    let levels: &'static TwoLevel = Box::leak(Box::new(levels.clone()));
    let tech = Techniques::default();
    let own = BvhWalker::new(scene, &levels.own, tech);
    InstanceWalker::new(scene, levels, tech, own, |g, b| BvhWalker::new(g, b, tech))
}

#[test]
fn the_scene_loads_as_instances_stored_once() {
    let s = scene();
    let inst = &s.instancing;
    assert_eq!((inst.meshes.len(), inst.instances.len()), (2, 6));
    assert_eq!(s.triangles.len(), 2);
    assert_eq!(s.instanced_triangles(), 2 + 4 * 1280 + 2 * 12);
    let flat = s.flattened(u64::MAX, "the test").unwrap();
    assert_eq!(flat.triangles.len() as u64, s.instanced_triangles());
    assert!(!flat.has_instances());
}

/// A unit icosphere placed with scale 2 at `c`: the ray from `c + 10 v` towards `-v`,
/// `v` the direction of one of its vertices, meets the vertex at t = 10 - 2 |v_f32|
/// (the f32 vertex's own length, 1 within an ulp).
#[test]
fn a_sphere_scaled_by_two_is_met_at_the_closed_form_t() {
    let text = r#"
[camera]
eye = [0, 0, 10]
look_at = [0, 0, 0]
fov = 40
[[objects]]
shape = "sphere"
subdivisions = 2
instances = [{ translate = [1, -2, 3], scale = 2 }]
"#;
    let s = load_scene_str(text, "ka.toml", std::path::Path::new(".")).unwrap();
    let levels = TwoLevel::build(&s).unwrap();
    let w = walker(&s, &levels);
    let g = &s.instancing.meshes[0].geometry;
    let c = s.instancing.instances[0].translate;
    for &vi in &[0usize, 5, 11] {
        let v = g.positions[vi].as_dvec3();
        let dir = v.normalize();
        let ray = Ray {
            o: V3::from_dvec3(c + dir * 10.0),
            d: V3::from_dvec3(-dir),
            t_min: 0.0,
            t_max: 1e30,
        };
        let h = w.closest_hit(&ray, &mut Work::default()).expect("a hit");
        let want = 10.0 - 2.0 * v.length();
        assert!(
            (h.t - want).abs() < 1e-9,
            "vertex {vi}: t {} want {want}",
            h.t
        );
    }
}

/// Seeded random rays from around the scene: the two-level walk's closest hit is brute
/// force's over the flattened scene (same id; t within 1e-12 relative), and any-hit
/// agrees.
#[test]
fn hits_match_brute_force_over_the_flattened_scene() {
    let s = scene();
    let flat = s.flattened(u64::MAX, "the test").unwrap();
    let tris = flat_tris(&flat);
    let levels = TwoLevel::build(&s).unwrap();
    let w = walker(&s, &levels);
    let tech = Techniques::default();
    let mut rng = Rng::new("instanced hits", 0x05ee_d53b);
    let (mut hits, mut placed, mut other_id, mut worst) = (0, 0, 0, 0.0f64);
    for _ in 0..20000 {
        // Local space: the origin is the camera's eye. From around the eye towards a
        // point near an instance's centre.
        let eye = s.camera.eye.as_dvec3();
        let o = eye
            + DVec3::new(
                rng.range(-6.0, 6.0),
                rng.range(-2.0, 2.0),
                rng.range(-6.0, 1.0),
            );
        let centre = s.instancing.instances[rng.below(6)].translate;
        let target = centre
            + DVec3::new(
                rng.range(-0.7, 0.7),
                rng.range(-0.7, 0.7),
                rng.range(-0.7, 0.7),
            );
        let ray = Ray {
            o: V3::from_dvec3(o),
            d: V3::from_dvec3((target - o).normalize()),
            t_min: 0.0,
            t_max: 1e30,
        };
        let got = w.closest_hit(&ray, &mut Work::default());
        let want = brute_force(&ray, &tris, &tech);
        match (got, want) {
            (None, None) => {}
            (Some(g), Some(b)) => {
                hits += 1;
                placed += usize::from(b.tri >= 2);
                if g.tri != b.tri {
                    other_id += 1;
                }
                worst = worst.max((g.t - b.t).abs() / b.t);
            }
            _ => panic!("ray {ray:?}: {got:?} vs brute force {want:?}"),
        }
        let any = w.any_hit(&ray, &mut Work::default());
        assert_eq!(any, want.is_some());
    }
    println!(
        "{hits} hits ({placed} on instances), {other_id} on another triangle, t within \
         {worst:e} relative"
    );
    assert!(placed > 10000, "only {placed} hits on instances");
    // Measured 1.3e-6 (seed 0x5eed53b): the flattened vertices are rounded to f32 after
    // placing, the instanced ones before, and grazing rays magnify the difference.
    assert!(worst < 1e-5, "t within {worst:e}");
    assert!(
        other_id * 1000 <= hits,
        "{other_id} of {hits} on another triangle"
    );
}

fn opts(scene: &Scene, precision: Precision, path: CpuPath) -> RenderOptions {
    RenderOptions {
        width: 96,
        height: 64,
        precision,
        cpu_path: path,
        accel: AccelChoice::Bvh,
        backend: Backend::Cpu,
        ..RenderOptions::for_scene(scene)
    }
}

/// Every CPU path renders the instanced scene as the flattened one: the largest colour
/// difference (measured 1.8e-6 in f64, 6.1e-6 in f32 on every path) and the share of
/// pixels whose primitive id differs (measured 0; at most 6 of the 6,144 allowed, for
/// silhouette pixels the vertices' rounding may move) stay within the bounds.
#[test]
fn every_cpu_path_renders_instances_as_the_flattened_scene() {
    let s = scene();
    let flat = s.flattened(u64::MAX, "the test").unwrap();
    for (precision, path, max_abs, max_share) in [
        (Precision::F64, CpuPath::Scalar, 1e-5, 0.001),
        (Precision::F32, CpuPath::Scalar, 3e-5, 0.001),
        (Precision::F32, CpuPath::Simd, 3e-5, 0.001),
        (Precision::F32, CpuPath::Packet, 3e-5, 0.001),
    ] {
        let a = render_cpu(&s, &opts(&s, precision, path)).unwrap();
        let b = render_cpu(&flat, &opts(&flat, precision, path)).unwrap();
        // Colours compared where both hit the same triangle (or both missed): a pixel
        // whose primary ray meets another triangle is counted instead.
        let same: Vec<bool> = a
            .aov
            .pixels
            .iter()
            .zip(&b.aov.pixels)
            .map(|(x, y)| x.primid == y.primid)
            .collect();
        let diff = a
            .image
            .data
            .chunks(3)
            .zip(b.image.data.chunks(3))
            .zip(&same)
            .filter(|(_, &same)| same)
            .flat_map(|((x, y), _)| x.iter().zip(y).map(|(p, q)| (p - q).abs()))
            .fold(0.0f32, f32::max);
        let share = same.iter().filter(|&&s| !s).count() as f64 / same.len() as f64;
        println!("{precision:?} {path:?}: max abs {diff:e}, primid differs on {share:.5}");
        assert!(
            (diff as f64) <= max_abs,
            "{precision:?} {path:?}: max abs {diff}"
        );
        assert!(share <= max_share, "{precision:?} {path:?}: {share}");
        assert_eq!(a.stats.triangles, b.stats.triangles);
    }
}

/// Errors in `instances` name the file, the line and the field.
#[test]
fn instance_errors_name_file_line_and_field() {
    let head =
        "[camera]\neye = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n[[objects]]\nshape = \"box\"\n";
    for (body, field, line) in [
        ("instances = [{ scale = 0 }]\n", "objects[0].instances[0].scale", 7),
        (
            "[[objects.instances]]\ntranslate = [1, 2, 3]\n[[objects.instances]]\nrotate = [0, 0]\n",
            "objects[0].instances[1].rotate",
            10,
        ),
        (
            "[[objects.instances]]\ntranslat = [1, 2, 3]\n",
            "objects[0].instances[0].translat",
            8,
        ),
        (
            "instances = [{ translate = [1e39, 0, 0] }]\n",
            "objects[0].instances[0].translate",
            7,
        ),
    ] {
        let e = load_scene_str(&format!("{head}{body}"), "bad.toml", std::path::Path::new("."))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&format!("bad.toml:{line}:")) && e.contains(field),
            "{body}: {e}"
        );
    }
}

/// The GPU renders the flattened scene (every kernel walks the grids): the compute kernel
/// and the thesis's multipass kernel against the f64 CPU's two-level walk, the colour
/// RMSE below [`RMSE_GL_VS_CPU64`] and the primary-hit triangle the same on all but
/// [`PRIMID_DISAGREEMENT`] of the pixels.
#[test]
fn the_gpu_renders_instances_as_the_cpu() {
    use fragtrace::gpu::options::Kernel;
    /// Measured 1.2e-7 on llvmpipe (both kernels); about 8x.
    const RMSE_GL_VS_CPU64: f64 = 1e-6;
    const PRIMID_DISAGREEMENT: f64 = 0.001;
    let s = scene();
    let cpu = render_cpu(&s, &opts(&s, Precision::F64, CpuPath::Scalar)).unwrap();
    common::with_test_context(|ctx| {
        for kernel in [Kernel::Compute, Kernel::Multipass] {
            let mut o = opts(&s, Precision::F32, CpuPath::Packet);
            o.backend = Backend::Gl;
            o.accel = AccelChoice::Irregular;
            o.gpu.kernel = kernel;
            let gl = fragtrace::render::render_gl_with(ctx, &s, &o).unwrap();
            let c = fragtrace::compare::compare(&gl.image, &cpu.image, 0.01, true).unwrap();
            let same = gl
                .aov
                .pixels
                .iter()
                .zip(&cpu.aov.pixels)
                .filter(|(p, q)| p.primid == q.primid)
                .count() as f64
                / cpu.aov.pixels.len() as f64;
            println!("{kernel:?}: RMSE {:e}, primid agrees on {same:.5}", c.rmse);
            assert!(c.rmse < RMSE_GL_VS_CPU64, "{kernel:?}: RMSE {}", c.rmse);
            assert!(1.0 - same <= PRIMID_DISAGREEMENT, "{kernel:?}: {same}");
            assert_eq!(gl.stats.triangles, cpu.stats.triangles);
        }
    });
}

/// A scene whose instances would not fit flat is refused before anything is allocated
/// where a grid would need them flat, naming the BVH that walks them as placed; the BVH
/// builds it (3,000 spheres of 327,680 triangles: 983 million placed).
#[test]
fn a_scene_too_large_to_flatten_is_refused_and_the_bvh_takes_it() {
    let mut text = String::from(
        "[camera]\neye = [0, 5, 80]\nlook_at = [0, 0, 0]\nfov = 40\n[[objects]]\nshape = \
         \"sphere\"\nsubdivisions = 7\ninstances = [\n",
    );
    for i in 0..3000 {
        text += &format!(
            "{{ translate = [{}, 0, {}] }},\n",
            (i % 60) * 3,
            (i / 60) * 3
        );
    }
    text += "]\n";
    let s = load_scene_str(&text, "big.toml", std::path::Path::new(".")).unwrap();
    assert_eq!(s.instanced_triangles(), 3000 * 327_680);
    let mut o = opts(&s, Precision::F32, CpuPath::Packet);
    o.accel = AccelChoice::Irregular;
    let e = fragtrace::render::prepare(&s, &o).err().expect("refused");
    let msg = e.to_string();
    assert!(
        matches!(e, fragtrace::Error::Limit(_)) && msg.contains("--accel bvh"),
        "{msg}"
    );
    o.accel = AccelChoice::Bvh;
    let p = fragtrace::render::prepare(&s, &o).unwrap();
    assert!(p.summary.bytes < 100 << 20, "{} bytes", p.summary.bytes);
}

/// A glTF whose mesh 0 three nodes place (one under a scaled parent, one mirroring) and
/// whose mesh 1 one node places: in a scene, mesh 0 is stored once and placed three times
/// (then by the object's own placement), mesh 1 stored flat; flattened, the scene holds
/// the very triangles the glTF loaded flat gives, placed by the object (within f32
/// rounding). An object's `instances` place the shared mesh once per instance and node.
#[test]
fn gltf_nodes_sharing_a_mesh_become_instances() {
    use base64::Engine as _;
    let mut bin = Vec::new();
    // Mesh 0: a triangle facing +z with normals; mesh 1: a larger one at z = -1.
    for p in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        bin.extend(p.iter().flat_map(|c| c.to_le_bytes()));
    }
    for _ in 0..3 {
        bin.extend([0f32, 0.0, 1.0].iter().flat_map(|c| c.to_le_bytes()));
    }
    for p in [[0f32, 0.0, -1.0], [3.0, 0.0, -1.0], [0.0, 3.0, -1.0]] {
        bin.extend(p.iter().flat_map(|c| c.to_le_bytes()));
    }
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    );
    let doc = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,
"scenes":[{{"nodes":[0,2,3,4]}}],
"nodes":[{{"translation":[10,0,0],"scale":[2,2,2],"children":[1]}},
 {{"rotation":[0,0.7071067811865476,0,0.7071067811865476],"mesh":0}},
 {{"matrix":[-1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,-5,1],"mesh":0}},
 {{"translation":[0,3,0],"mesh":0}},
 {{"mesh":1}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1}}}}]}},
 {{"primitives":[{{"attributes":{{"POSITION":2}}}}]}}],
"buffers":[{{"byteLength":{},"uri":"{uri}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":108}}],
"accessors":[{{"bufferView":0,"byteOffset":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
 {{"bufferView":0,"byteOffset":36,"componentType":5126,"count":3,"type":"VEC3"}},
 {{"bufferView":0,"byteOffset":72,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,-1],"max":[3,3,-1]}}]}}"#,
        bin.len()
    );
    let dir = std::env::temp_dir().join(format!("fragtrace-inst-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("shared.gltf");
    std::fs::write(&file, doc).unwrap();
    let head = "[camera]\neye = [0, 2, 30]\nlook_at = [0, 0, 0]\nfov = 40\n[[objects]]\n";
    let object = format!(
        "mesh = \"{}\"\nscale = 2\ntranslate = [1, 2, 3]\n",
        file.display()
    );
    let s = load_scene_str(&format!("{head}{object}"), "g.toml", &dir).unwrap();
    assert_eq!(s.triangles.len(), 1, "mesh 1 stays flat");
    assert_eq!(s.instancing.meshes.len(), 1);
    assert_eq!(s.instancing.instances.len(), 3);
    assert_eq!(
        s.instancing
            .instances
            .iter()
            .filter(|i| i.mirrors())
            .count(),
        1
    );
    let flat = s.flattened(u64::MAX, "the test").unwrap();
    // The glTF loaded flat, placed as the object places it, in the scene's local space.
    let m = fragtrace::scene::load_gltf(&file).unwrap();
    assert_eq!(m.triangles.len(), 4);
    assert!(m.shared.is_empty());
    let corner = |p: glam::Vec3| -> [i64; 3] {
        let w = (p.as_dvec3() * 2.0 + DVec3::new(1.0, 2.0, 3.0)) - s.origin;
        w.to_array().map(|c| (c * 1e4).round() as i64)
    };
    let tris = |sc: &[[i64; 3]]| {
        let mut v: Vec<[i64; 3]> = sc.to_vec();
        v.sort();
        v
    };
    let want: Vec<[i64; 3]> = m
        .triangles
        .iter()
        .flat_map(|t| t.v.map(|k| corner(m.positions[k as usize])))
        .collect();
    let got: Vec<[i64; 3]> = (0..flat.triangles.len())
        .flat_map(|i| {
            flat.triangle_vertices(i)
                .map(|p| p.as_dvec3().to_array().map(|c| (c * 1e4).round() as i64))
        })
        .collect();
    assert_eq!(tris(&got), tris(&want));
    // Every flattened triangle winds towards its vertex normal, the mirrored one too.
    for t in flat.triangles.iter().filter(|t| t.has_normals()) {
        let [a, b, c] = t.v.map(|i| flat.positions[i as usize]);
        let n = flat.normals[t.n[0] as usize];
        assert!((b - a).cross(c - a).normalize().dot(n) > 0.999);
    }
    // With two instances of the object: the shared mesh placed 2 x 3 times, mesh 1 twice
    // (one instanced mesh of its own).
    let object2 = format!(
        "mesh = \"{}\"\ninstances = [{{ translate = [0, 0, 0] }}, {{ translate = [5, 0, 0] }}]\n",
        file.display()
    );
    let s2 = load_scene_str(&format!("{head}{object2}"), "g2.toml", &dir).unwrap();
    assert_eq!(s2.instancing.instances.len(), 6 + 2);
    assert_eq!(s2.instanced_triangles(), 8);
    std::fs::remove_dir_all(&dir).ok();
}
