use super::build::Placement;
use super::diagnostics::{edit_distance, field_at};
use super::*;
use glam::{DVec3, Vec3};

use crate::scene::{shapes, CheckerAxes, Material};
use crate::Error;

fn models_dir() -> PathBuf {
    std::env::var_os(MODEL_PATH_VAR)
        .and_then(|v| std::env::split_paths(&v).find(|p| !p.as_os_str().is_empty()))
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/models")))
}

fn scenes_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes"))
}

fn load(text: &str) -> Result<Scene> {
    load_scene_str_with_search_path(text, "t.toml", Path::new("."), &[])
}

/// (line, field, message) of a scene error.
fn scene_err(text: &str) -> (usize, String, String) {
    match load(text) {
        Err(Error::Scene {
            file,
            line,
            field,
            message,
        }) => {
            assert_eq!(file, "t.toml");
            (line, field, message)
        }
        other => panic!(
            "expected a scene error, got {:?}",
            other.map(|s| s.triangles.len())
        ),
    }
}

const CAM: &str = "[camera]\neye = [0, 1, 5]\nlook_at = [0, 1, 0]\nfov = 45\n";

#[test]
fn builtin_scene_has_the_whitted_setup() {
    let s = builtin_scene();
    assert_eq!(s.source, BUILTIN_SCENE_NAME);
    assert_eq!((s.width, s.height), (640, 480));
    assert!(!s.lights.is_empty());
    let by_name = |n: &str| {
        s.materials
            .iter()
            .position(|m| m.name == n)
            .unwrap_or_else(|| panic!("no material {n}"))
    };
    let glass = &s.materials[by_name("glass")];
    assert!(glass.fresnel && glass.ior == 1.5);
    let mirror = &s.materials[by_name("mirror")];
    assert!(mirror.kr.min_element() > 0.5 && !mirror.refracts());
    let floor = &s.materials[by_name("floor")];
    let checker = floor.checker.expect("floor is checkered");
    assert_eq!(checker.axes, CheckerAxes::Xz);
    assert!(
        checker.color_a.x > 0.5 && checker.color_a.z < 0.2,
        "red-ish squares"
    );
    assert!(
        checker.color_b.y > 0.5 && checker.color_b.z < 0.3,
        "yellow-ish squares"
    );
    // Two smooth spheres and a two-triangle floor.
    let count = |m: usize| {
        s.triangles
            .iter()
            .filter(|t| t.material as usize == m)
            .count()
    };
    assert_eq!(count(by_name("floor")), 2);
    let sphere_tris = count(by_name("glass"));
    assert!([5120, 20480].contains(&sphere_tris), "{sphere_tris}");
    assert_eq!(count(by_name("mirror")), sphere_tris);
    assert!(s
        .triangles
        .iter()
        .filter(|t| t.material as usize != by_name("floor"))
        .all(|t| t.has_normals()));
    assert!(s.triangles.len() < 30_000);
    assert!(s.background.z > s.background.x, "blue background");
    // The glass sphere is nearer the camera than the mirror sphere.
    let centre = |m: usize| {
        let (sum, n) = s
            .triangles
            .iter()
            .filter(|t| t.material as usize == m)
            .flat_map(|t| t.v)
            .fold((Vec3::ZERO, 0.0), |(a, n), v| {
                (a + s.positions[v as usize], n + 1.0)
            });
        sum / n
    };
    let d = |m| centre(m).distance(s.camera.eye);
    assert!(d(by_name("glass")) < d(by_name("mirror")));
    assert!(s.camera.check().is_ok());
}

#[test]
fn every_shipped_scene_loads() {
    let search = vec![models_dir()];
    let mut names = Vec::new();
    for entry in std::fs::read_dir(scenes_dir()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let s = load_scene_with_search_path(&path, &search)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert!(
                !s.triangles.is_empty() && !s.lights.is_empty(),
                "{}",
                path.display()
            );
            names.push(path.file_stem().unwrap().to_string_lossy().into_owned());
        }
    }
    names.sort();
    for want in [
        "bunny",
        "cornell",
        "dragon",
        "glass",
        "lights",
        "sponza",
        "stadium",
        "teapot",
        "turntable",
        "whitted",
    ] {
        assert!(
            names.iter().any(|n| n == want),
            "scenes/{want}.toml missing"
        );
    }
}

#[test]
fn shipped_scenes_have_the_promised_content() {
    let search = vec![models_dir()];
    let load = |n: &str| load_scene_with_search_path(&scenes_dir().join(n), &search).unwrap();
    let lights = load("lights.toml");
    assert!(lights.lights.len() >= 8);
    let colours: std::collections::HashSet<_> = lights
        .lights
        .iter()
        .map(|l| l.color.to_array().map(f32::to_bits))
        .collect();
    assert!(colours.len() >= 6, "lights should be differently coloured");
    let cornell = load("cornell.toml");
    assert!(cornell.materials.iter().any(|m| m.name == "leftWall"));
    assert!(cornell.materials.iter().any(|m| m.fresnel));
    assert!(cornell.materials.iter().any(|m| m.kr.min_element() > 0.5));
    // The light sits below the ceiling's light quad (y = 1.98) inside the box.
    assert!(cornell
        .lights
        .iter()
        .all(|l| cornell.world(l.position).y < 1.98 && cornell.world(l.position).y > 1.5));
    let stadium = load("stadium.toml");
    let (lo, hi) = stadium.bounds().unwrap();
    assert!((hi - lo).max_element() > 100.0, "stadium must be huge");
    let glass = load("glass.toml");
    assert!(glass.materials.iter().filter(|m| m.refracts()).count() >= 2);
}

#[test]
fn defaults_apply() {
    let s = load(&format!("{CAM}[[objects]]\nshape = \"sphere\"\n")).unwrap();
    assert_eq!((s.width, s.height, s.max_depth), (640, 480, 5));
    assert_eq!(s.camera.up, Vec3::Y);
    assert_eq!(
        s.triangles.len(),
        shapes::sphere_triangle_count(DEFAULT_SPHERE_SUBDIVISIONS)
    );
    assert_eq!(s.materials.len(), 1);
    assert_eq!(s.materials[0], Material::default());
    let s = load(&format!("{CAM}[materials.m]\n[[lights]]\nposition = [1, 2, 3]\n[[objects]]\nshape = \"box\"\nmaterial = \"m\"\n")).unwrap();
    let m = &s.materials[0];
    assert_eq!(
        (m.ka, m.kd, m.ns, m.ior, m.fresnel),
        (1.0, 1.0, 32.0, 1.0, false)
    );
    assert_eq!(s.lights[0].radiance(), Vec3::ONE);
}

#[test]
fn malformed_toml_reports_the_line() {
    let (line, _, msg) = scene_err("[camera]\neye = [0, 1, 5]\nlook_at = [0, 1,\nfov = 45\n");
    assert!((3..=4).contains(&line), "line {line}: {msg}");
    let (line, _, _) = scene_err(&format!("{CAM}\n[image]\nwidth = 640\nwidth = 320\n"));
    assert_eq!(line, 8);
    let (line, _, _) = scene_err(&format!(
        "ambient = [0.1, 0.1, 0.1]\nbackground = [0.1, 0.2 0.3]\n{CAM}"
    ));
    assert_eq!(line, 2);
}

#[test]
fn unknown_keys_are_rejected_with_a_suggestion() {
    let (line, field, msg) =
        scene_err("[camera]\neye = [0, 1, 5]\nlook_at = [0, 1, 0]\nfvo = 45\n");
    assert_eq!((line, field.as_str()), (4, "camera.fvo"));
    assert!(
        msg.contains("unknown key `fvo`") && msg.contains("did you mean `fov`?"),
        "{msg}"
    );

    let text = format!("{CAM}\n[[objects]]\nshape = \"box\"\n\n[[objects]]\nshape = \"sphere\"\ntranslation = [1, 2, 3]\n");
    let (line, field, msg) = scene_err(&text);
    assert_eq!((line, field.as_str()), (11, "objects[1].translation"));
    assert!(msg.contains("did you mean `translate`?"), "{msg}");

    let text = format!(
        "{CAM}[[objects]]\nshape = \"box\"\nmaterial = {{ albedo = [1, 0, 0], iorr = 1.5 }}\n"
    );
    let (line, field, msg) = scene_err(&text);
    assert_eq!((line, field.as_str()), (7, "objects[0].material.iorr"));
    assert!(msg.contains("did you mean `ior`?"), "{msg}");

    let text = format!("{CAM}[materials.floor]\nalbedo = [1, 1, 1]\nchecker = {{ a = [1, 0, 0], b = [1, 1, 0], axis = \"xz\" }}\n");
    let (line, field, msg) = scene_err(&text);
    assert_eq!((line, field.as_str()), (7, "materials.floor.checker.axis"));
    assert!(msg.contains("did you mean `axes`?"), "{msg}");

    let (line, field, msg) = scene_err(&format!("{CAM}[[objects]]\nshape = \"sphre\"\n"));
    assert_eq!((line, field.as_str()), (6, "objects[0].shape"));
    assert!(msg.contains("did you mean `sphere`?"), "{msg}");

    let (line, field, msg) = scene_err(&format!("\nmaxdepth = 3\n{CAM}"));
    assert_eq!((line, field.as_str()), (2, "maxdepth"));
    assert!(msg.contains("did you mean `max_depth`?"), "{msg}");

    // Nothing close: no suggestion, but the list of keys.
    let (_, _, msg) = scene_err(&format!(
        "{CAM}[[lights]]\nposition = [0, 1, 0]\nzzzzzz = 1\n"
    ));
    assert!(
        !msg.contains("did you mean") && msg.contains("`intensity`"),
        "{msg}"
    );
}

#[test]
fn wrong_types_name_the_field() {
    let (line, field, _) = scene_err(&format!(
        "{CAM}[[objects]]\nshape = \"quad\"\nrotate = \"x\"\n"
    ));
    assert_eq!((line, field.as_str()), (7, "objects[0].rotate"));
    let (line, field, _) = scene_err(&format!("{CAM}[[lights]]\nposition = [0, 1]\n"));
    assert_eq!((line, field.as_str()), (6, "lights[0].position"));
}

/// Three-number keys take exactly three: serde's fixed arrays would read the first three of
/// `[1, 2, 3, 4]` and drop the rest without a word.
#[test]
fn extra_numbers_in_a_triple_are_an_error() {
    for (text, line, field) in [
        (
            format!("{CAM}[[lights]]\nposition = [0, 1, 2, 3]\n"),
            6,
            "lights[0].position",
        ),
        (
            "[camera]\neye = [0, 1, 5]\nlook_at = [0, 1, 0, 0]\nfov = 45\n".to_string(),
            3,
            "camera.look_at",
        ),
        (
            format!("{CAM}[[objects]]\nshape = \"quad\"\ntranslate = [1, 2, 3, 4]\n"),
            7,
            "objects[0].translate",
        ),
    ] {
        let (l, f, msg) = scene_err(&text);
        assert_eq!((l, f.as_str()), (line, field), "{msg}");
        assert!(
            msg.contains("invalid length 4, expected an array of length 3"),
            "{msg}"
        );
    }
}

#[test]
fn invalid_values_name_file_line_and_field() {
    let cases: &[(&str, usize, &str, &str)] = &[
        (
            "[camera]\neye = [0, 1, 5]\nlook_at = [0, 1, 0]\nfov = 180\n",
            4,
            "camera.fov",
            "(0, 180)",
        ),
        (
            "[camera]\neye = [0, 1, 5]\nlook_at = [0, 1, 0]\nfov = 0\n",
            4,
            "camera.fov",
            "(0, 180)",
        ),
        (
            "[camera]\neye = [0, nan, 5]\nlook_at = [0, 1, 0]\nfov = 40\n",
            2,
            "camera.eye",
            "finite",
        ),
        (
            "[camera]\neye = [0, 1, 5]\nlook_at = [0, 1, 5]\nfov = 40\n",
            3,
            "camera.look_at",
            "equals",
        ),
        (
            "[camera]\neye = [0, 5, 0]\nlook_at = [0, 0, 0]\nup = [0, 2, 0]\nfov = 40\n",
            4,
            "camera.up",
            "parallel",
        ),
        (
            "[camera]\neye = [0, 5, 0]\nlook_at = [0, 0, 0]\nfov = 40\n",
            3,
            "camera.look_at",
            "parallel",
        ),
    ];
    for &(text, line, field, needle) in cases {
        let (l, f, m) = scene_err(text);
        assert_eq!((l, f.as_str()), (line, field), "{m}");
        assert!(m.contains(needle), "{m}");
    }
    let with_cam: &[(&str, usize, &str, &str)] = &[
        ("[image]\nwidth = 0\n", 6, "image.width", "1..=16384"),
        (
            "[image]\nwidth = 64\nheight = -480\n",
            7,
            "image.height",
            "1..=16384",
        ),
        ("max_depth = 17\n", 1, "max_depth", "0..=16"),
        ("\nambient = [0.1, inf, 0.1]\n", 2, "ambient", "finite"),
        ("background = [0.1, -1, 0.1]\n", 1, "background", ">= 0"),
        (
            "[[lights]]\nposition = [0, 1, 0]\nintensity = -1\n",
            7,
            "lights[0].intensity",
            ">= 0",
        ),
        ("[materials.g]\nior = nan\n", 6, "materials.g.ior", "finite"),
        ("[materials.g]\nns = 0.5\n", 6, "materials.g.ns", ">= 1"),
        (
            "[materials.g]\nchecker = { a = [1, 0, 0], b = [0, 0, 0], scale = 0 }\n",
            6,
            "materials.g.checker.scale",
            "> 0",
        ),
        (
            "[[objects]]\nshape = \"sphere\"\nsubdivisions = 9\n",
            7,
            "objects[0].subdivisions",
            "0..=7",
        ),
        (
            "[[objects]]\nshape = \"box\"\nsubdivisions = 2\n",
            7,
            "objects[0].subdivisions",
            "only to shape = \"sphere\"",
        ),
        (
            "[[objects]]\nshape = \"quad\"\nsize = [1, 2, 3]\n",
            7,
            "objects[0].size",
            "2 numbers",
        ),
        (
            "[[objects]]\nshape = \"box\"\nscale = [1, 0, 1]\n",
            7,
            "objects[0].scale",
            "non-zero",
        ),
        (
            "[[objects]]\nshape = \"box\"\ntranslate = [1e39, 0, 0]\n",
            7,
            "objects[0].translate",
            "finite",
        ),
        (
            "[[objects]]\nshape = \"box\"\n\nmaterial = \"glas\"\n[materials.glass]\n",
            8,
            "objects[0].material",
            "did you mean `glass`?",
        ),
        (
            "[[objects]]\nshape = \"box\"\nmaterial = { kr = [0.5, 0.5, -0.5] }\n",
            7,
            "objects[0].material.kr",
            ">= 0",
        ),
        (
            "[[objects]]\nshape = \"box\"\nmesh = \"a.obj\"\n",
            6,
            "objects[0].shape",
            "not both",
        ),
    ];
    for &(body, line, field, needle) in with_cam {
        // Top-level keys must come before the first table header.
        let text = if body.trim_start().starts_with('[') {
            format!("{CAM}{body}")
        } else {
            format!("{body}{CAM}")
        };
        let (l, f, m) = scene_err(&text);
        assert_eq!((l, f.as_str()), (line, field), "{body}: {m}");
        assert!(m.contains(needle), "{body}: {m}");
    }
    // An object with neither mesh nor shape points at the object.
    let (l, f, m) = scene_err(&format!("{CAM}\n[[objects]]\ntranslate = [0, 0, 0]\n"));
    assert_eq!(f, "objects[0]", "{m}");
    assert!((6..=7).contains(&l), "{l}");
}

#[test]
fn missing_mesh_lists_every_folder_searched() {
    let text = format!("{CAM}[[objects]]\nmesh = \"nope/missing.obj\"\n");
    let search = [
        PathBuf::from("/tmp/fragtrace-a"),
        PathBuf::from("/tmp/fragtrace-b"),
    ];
    match load_scene_str_with_search_path(&text, "t.toml", Path::new("scenes-dir"), &search) {
        Err(Error::Mesh { file, message }) => {
            assert_eq!(file, "nope/missing.obj");
            for folder in [
                "scenes-dir/nope/missing.obj",
                "/tmp/fragtrace-a/nope/missing.obj",
                "/tmp/fragtrace-b/nope/missing.obj",
            ] {
                assert!(message.contains(folder), "{message}");
            }
            assert!(
                message.contains("t.toml:6") && message.contains(MODEL_PATH_VAR),
                "{message}"
            );
        }
        other => panic!("{:?}", other.map(|s| s.triangles.len())),
    }
}

#[test]
fn mesh_resolution_order_and_sharing() {
    let search = vec![models_dir()];
    let text = format!(
        "{CAM}[materials.red]\nalbedo = [1, 0, 0]\n\
         [[objects]]\nmesh = \"cornell_box/CornellBox-Original.obj\"\n\
         [[objects]]\nmesh = \"cornell_box/CornellBox-Original.obj\"\ntranslate = [5, 0, 0]\n\
         [[objects]]\nmesh = \"cornell_box/CornellBox-Original.obj\"\nmaterial = \"red\"\n"
    );
    let s = load_scene_str_with_search_path(&text, "t.toml", Path::new("/nonexistent"), &search)
        .unwrap();
    assert_eq!(s.triangles.len(), 3 * 36);
    // red + the 8 MTL materials, added once for the two instances without override.
    assert_eq!(s.materials.len(), 9);
    assert!(s.triangles[72..].iter().all(|t| t.material == 0));
    assert_eq!(s.triangles[0].material, s.triangles[36].material);
    assert_eq!(s.materials[s.triangles[0].material as usize].name, "floor");
    // The scene folder wins over the search path.
    let dir = std::env::temp_dir().join(format!("fragtrace-scene-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("cornell_box")).unwrap();
    std::fs::write(
        dir.join("cornell_box/CornellBox-Original.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let s = load_scene_str_with_search_path(&text, "t.toml", &dir, &search).unwrap();
    assert_eq!(s.triangles.len(), 3);
}

#[test]
fn transforms_place_vertices_and_normals() {
    // A box scaled, rotated 90° about Y (x -> -z), then translated.
    let s = load(&format!("{CAM}[[objects]]\nshape = \"box\"\nscale = [2, 4, 6]\nrotate = [0, 90, 0]\ntranslate = [10, 20, 30]\n")).unwrap();
    let (lo, hi) = s.bounds().unwrap();
    // Stored relative to the local origin (the eye); world = stored + origin.
    let (lo, hi) = (s.world(lo).as_vec3(), s.world(hi).as_vec3());
    assert!(lo.abs_diff_eq(Vec3::new(7.0, 18.0, 29.0), 1e-5), "{lo}");
    assert!(hi.abs_diff_eq(Vec3::new(13.0, 22.0, 31.0), 1e-5), "{hi}");

    // X then Y then Z: the point (1,0,0) rotated 90° about X stays, about Y goes to
    // (0,0,-1), about Z stays; the opposite order (Z, Y, X) would end at (0,0,1).
    let p = Placement::new(DVec3::ONE, DVec3::new(90.0, 90.0, 90.0), DVec3::ZERO);
    assert!(
        p.point(Vec3::X).abs_diff_eq(Vec3::NEG_Z, 1e-6),
        "{}",
        p.point(Vec3::X)
    );
    assert!(
        p.point(Vec3::Y).abs_diff_eq(Vec3::Y, 1e-6),
        "{}",
        p.point(Vec3::Y)
    );

    // Non-uniform scale of a sphere: normals stay unit and perpendicular to the surface
    // (ellipsoid gradient), not the naively scaled normal.
    let s = load(&format!("{CAM}[[objects]]\nshape = \"sphere\"\nsubdivisions = 2\nscale = [1, 3, 0.5]\nrotate = [30, 0, 0]\n")).unwrap();
    let inv = Placement::new(
        DVec3::new(1.0, 3.0, 0.5),
        DVec3::new(30.0, 0.0, 0.0),
        DVec3::ZERO,
    )
    .linear
    .inverse();
    for t in &s.triangles {
        for k in 0..3 {
            let p = s.world(s.positions[t.v[k] as usize]);
            let n = s.normals[t.n[k] as usize].as_dvec3();
            assert!((n.length() - 1.0).abs() < 1e-6);
            // Ellipsoid |inv·p| = 1 has gradient invᵀ·inv·p.
            let g = (inv.transpose() * (inv * p)).normalize();
            assert!(n.dot(g) > 1.0 - 1e-5, "normal {n} vs gradient {g}");
        }
        // Winding still agrees with the normals (outward).
        let [a, b, c] = [0, 1, 2].map(|k| s.positions[t.v[k] as usize]);
        assert!((b - a).cross(c - a).dot(s.normals[t.n[0] as usize]) > 0.0);
    }
}

#[test]
fn mirroring_scale_keeps_winding_outward() {
    let s = load(&format!("{CAM}[[objects]]\nshape = \"box\"\nscale = [-1, 1, 1]\n[[objects]]\nshape = \"sphere\"\nsubdivisions = 1\nscale = [1, -2, 1]\n")).unwrap();
    for (i, t) in s.triangles.iter().enumerate() {
        let [a, b, c] = [0, 1, 2].map(|k| s.world(s.positions[t.v[k] as usize]).as_vec3());
        let g = (b - a).cross(c - a);
        let centroid = (a + b + c) / 3.0;
        assert!(g.dot(centroid) > 0.0, "triangle {i} turned inside out");
        if t.has_normals() {
            assert!(g.dot(s.normals[t.n[0] as usize]) > 0.0);
        }
    }
}

#[test]
fn quad_and_sphere_sizes() {
    let s = load(&format!("{CAM}[[objects]]\nshape = \"quad\"\nsize = [4, 2]\ntranslate = [0, -1, 0]\n[[objects]]\nshape = \"sphere\"\nradius = 0.5\nsubdivisions = 0\n")).unwrap();
    let quad_pts: Vec<Vec3> = s.triangles[..2]
        .iter()
        .flat_map(|t| t.v)
        .map(|v| s.world(s.positions[v as usize]).as_vec3())
        .collect();
    let lo = quad_pts.iter().copied().reduce(Vec3::min).unwrap();
    let hi = quad_pts.iter().copied().reduce(Vec3::max).unwrap();
    assert_eq!(
        (lo, hi),
        (Vec3::new(-2.0, -1.0, -1.0), Vec3::new(2.0, -1.0, 1.0))
    );
    for t in &s.triangles[2..] {
        for &v in &t.v {
            assert!((s.world(s.positions[v as usize]).length() - 0.5).abs() < 1e-6);
        }
    }
    assert_eq!(s.triangles.len(), 2 + 20);
}

#[test]
fn field_locator_handles_headers_and_inline_tables() {
    let text = "a = 1\n[[objects]]\nx = 1\n[[objects]]\nm = { p = [1, 2], q = { r = 3 } }\n[t.u]\nk = \"s = [\"\n";
    let at = |needle: &str| field_at(text, text.find(needle).unwrap());
    assert_eq!(at("a ="), "a");
    assert_eq!(at("x ="), "objects[0].x");
    assert_eq!(at("p ="), "objects[1].m.p");
    assert_eq!(at("2]"), "objects[1].m.p");
    assert_eq!(at("r ="), "objects[1].m.q.r");
    assert_eq!(at("k ="), "t.u.k");
    assert_eq!(at("\"s"), "t.u.k");
    assert_eq!(edit_distance("fvo", "fov"), 1);
    assert_eq!(edit_distance("kitten", "sitting"), 3);
}

#[test]
fn serde_path_names_array_elements_and_quoted_keys() {
    // A wrong element is named by its index, not just the array.
    let (line, field, _) = scene_err(&format!(
        "{CAM}[[objects]]\nshape = \"box\"\nsize = [1, \"a\", 2]\n"
    ));
    assert_eq!((line, field.as_str()), (7, "objects[0].size[1]"));
    // A key that is not bare stays quoted, as written (the re-lexer dropped the space).
    let (line, field, _) = scene_err(&format!("{CAM}[materials.\"my mat\"]\nns = \"x\"\n"));
    assert_eq!((line, field.as_str()), (6, "materials.\"my mat\".ns"));
    // Syntax errors have no serde path: the re-lexer still names the field.
    let (line, field, _) = scene_err(&format!(
        "{CAM}[[objects]]\nshape = \"box\"\nmaterial = {{ albedo = [1, 0, 0] ior = 1.5 }}\n"
    ));
    assert_eq!((line, field.as_str()), (7, "objects[0].material.albedo"));
}

/// Meshes handed over as text (the web page's drop or fetch): found by the path the scene
/// writes or by file name, with the MTL the OBJ names, giving the scene the same files
/// give; a mesh not handed over is a mesh error naming it.
#[test]
fn meshes_from_texts_load_like_files() {
    let obj = "mtllib tri.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n";
    let mtl = "newmtl red\nKd 1 0 0\nKs 0.5 0.5 0.5\nNs 20\n";
    let text = format!("{CAM}[[objects]]\nmesh = \"some/dir/tri.obj\"\n");
    let dir = std::env::temp_dir().join(format!("fragtrace-texts-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("some/dir")).unwrap();
    std::fs::write(dir.join("some/dir/tri.obj"), obj).unwrap();
    std::fs::write(dir.join("some/dir/tri.mtl"), mtl).unwrap();
    let from_files = load_scene_str_with_search_path(&text, "t.toml", &dir, &[]).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    for obj_key in ["some/dir/tri.obj", "tri.obj"] {
        let texts: MeshTexts = [(obj_key, obj), ("tri.mtl", mtl)]
            .into_iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        let s = load_scene_str_with_texts(&text, "t.toml", &texts).unwrap();
        assert_eq!(s.positions, from_files.positions, "{obj_key}");
        assert_eq!(s.triangles.len(), 1);
        let look = |s: &Scene| -> Vec<(String, Vec3, Vec3, f32)> {
            s.materials
                .iter()
                .map(|m| (m.name.clone(), m.albedo, m.ks, m.ns))
                .collect()
        };
        assert_eq!(look(&s), look(&from_files), "{obj_key}");
        let used = &s.materials[s.triangles[0].material as usize];
        assert_eq!((used.name.as_str(), used.albedo), ("red", Vec3::X));
    }
    match load_scene_str_with_texts(&text, "t.toml", &MeshTexts::new()) {
        Err(Error::Mesh { file, message }) => {
            assert_eq!(file, "some/dir/tri.obj");
            assert!(
                message.contains("tri.obj") && message.contains("t.toml:"),
                "{message}"
            );
        }
        other => panic!(
            "expected a mesh error, got {:?}",
            other.map(|s| s.triangles.len())
        ),
    }
}

#[test]
fn a_key_without_a_value_is_named_as_such() {
    let (line, field, msg) = scene_err("[camera]\neye = [0, 1, 5]\nlook_at = [0, 1, 0]\nfov =\n");
    assert_eq!((line, field.as_str()), (4, "camera.fov"), "{msg}");
    assert!(msg.contains("`fov =` has no value after it"), "{msg}");
    let (line, _, msg) = scene_err(&format!("{CAM}[[lights]]\nposition = # later\n"));
    assert_eq!(line, 6, "{msg}");
    assert!(msg.contains("`position =` has no value"), "{msg}");
}

/// Images handed over with the texts (the web page's fetched `map_Kd` files): the scene
/// gets the texture files give, found by the path resolved against the MTL's folder or by
/// file name; without the image the material keeps its colour and the problem names it.
#[test]
fn textures_from_handed_over_images_load_like_files() {
    let obj = "mtllib tri.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n\
               usemtl wood\nf 1/1 2/2 3/3\n";
    let mtl = "newmtl wood\nKd 1 1 1\nmap_Kd tex/wood.png\n";
    let mut png = Vec::new();
    let img = image::RgbImage::from_fn(4, 2, |x, y| image::Rgb([x as u8 * 60, y as u8 * 200, 7]));
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let text = format!("{CAM}[[objects]]\nmesh = \"some/dir/tri.obj\"\n");
    let dir = std::env::temp_dir().join(format!("fragtrace-images-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("some/dir/tex")).unwrap();
    std::fs::write(dir.join("some/dir/tri.obj"), obj).unwrap();
    std::fs::write(dir.join("some/dir/tri.mtl"), mtl).unwrap();
    std::fs::write(dir.join("some/dir/tex/wood.png"), &png).unwrap();
    let from_files = load_scene_str_with_search_path(&text, "t.toml", &dir, &[]).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(crate::scene::mtl_texture_files(mtl), ["tex/wood.png"]);
    let texts: MeshTexts = [("some/dir/tri.obj", obj), ("tri.mtl", mtl)]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    for key in ["some/dir/tex/wood.png", "wood.png"] {
        let images: MeshImages = [(key.to_string(), png.clone())].into_iter().collect();
        let s = load_scene_str_with_files(&text, "t.toml", &texts, &images).unwrap();
        assert!(
            s.has_textures() && s.texture_problems.is_empty(),
            "{key}: {:?}",
            s.texture_problems
        );
        assert_eq!(s.textures.len(), 1);
        assert_eq!(s.textures[0].levels, from_files.textures[0].levels, "{key}");
        assert_eq!(s.textures[0].wrap, from_files.textures[0].wrap);
        assert_eq!(s.tri_uvs, from_files.tri_uvs);
    }
    let s = load_scene_str_with_files(&text, "t.toml", &texts, &MeshImages::new()).unwrap();
    assert!(s.textures.is_empty());
    assert_eq!(s.texture_problems.len(), 1);
    assert!(
        s.texture_problems[0].contains("wood") && s.texture_problems[0].contains("tex/wood.png"),
        "{}",
        s.texture_problems[0]
    );
}
