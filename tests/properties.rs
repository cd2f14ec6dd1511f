//! Property tests (proptest): loaders never panic on any text, and the grid traversal finds
//! exactly what brute force finds.
//!
//! The RNG seed is fixed (so CI is reproducible) and printed; set `FRAGTRACE_PROPTEST_SEED`
//! to explore other inputs. A failure is shrunk and its case saved to
//! `tests/properties.proptest-regressions`, which is committed and replayed first.

use glam::Vec3;
use proptest::prelude::*;
use proptest::test_runner::{Config, FileFailurePersistence, RngAlgorithm, RngSeed};

use fragtrace::accel::{Grid, GridConfig, GridRes};
use fragtrace::cpu::real::V3;
use fragtrace::cpu::traverse::{GridWalker, Ray, Work};
use fragtrace::scene::{
    parse_obj_with_mtl, parse_scene_str, Camera, Material, Scene, Triangle, NO_NORMAL,
};
use fragtrace::Error;

const DEFAULT_SEED: u64 = 0x6672_6167_7472_6163; // "fragtrac"

fn config(cases: u32) -> Config {
    let seed = std::env::var("FRAGTRACE_PROPTEST_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(DEFAULT_SEED);
    eprintln!("proptest seed {seed} (FRAGTRACE_PROPTEST_SEED), {cases} cases");
    Config {
        cases,
        rng_seed: RngSeed::Fixed(seed),
        rng_algorithm: RngAlgorithm::ChaCha,
        failure_persistence: Some(Box::new(FileFailurePersistence::SourceParallel(
            "proptest-regressions",
        ))),
        max_shrink_iters: 2048,
        ..Config::default()
    }
}

const SCENES: [&str; 9] = [
    include_str!("../scenes/bunny.toml"),
    include_str!("../scenes/cornell.toml"),
    include_str!("../scenes/dragon.toml"),
    include_str!("../scenes/glass.toml"),
    include_str!("../scenes/lights.toml"),
    include_str!("../scenes/sponza.toml"),
    include_str!("../scenes/stadium.toml"),
    include_str!("../scenes/teapot.toml"),
    include_str!("../scenes/whitted.toml"),
];

/// Fragments that TOML and the scene schema care about.
const TOKENS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "1e39",
    "-1",
    "0",
    "-0.0",
    "1e-45",
    "9999999999999999999",
    "[",
    "]",
    "[[",
    "]]",
    "{",
    "}",
    "=",
    ",",
    "\"",
    "'",
    "\n",
    "#",
    ".",
    "[[objects]]\n",
    "[[lights]]\n",
    "[camera]\n",
    "[image]\n",
    "[materials.m]\n",
    "shape = \"sphere\"\n",
    "shape = \"box\"\n",
    "mesh = \"a.obj\"\n",
    "material = \"m\"\n",
    "material = { ior = 2 }\n",
    "subdivisions = 7\n",
    "scale = [1, 0, 1]\n",
    "rotate = [90, 90, 90]\n",
    "fov = 179.9999\n",
    "up = [0, 1, 0]\n",
    "checker = { a = [1, 1, 1], b = [0, 0, 0] }\n",
    "max_depth = 16\n",
    "width = 16385\n",
    "\u{e9}",
    "\u{0}",
    "\r\n",
    "\"\"\"",
    "true",
];

/// A shipped scene with a few random edits: byte deletions, token insertions, line
/// duplications and byte overwrites.
fn mutated_scene() -> impl Strategy<Value = String> {
    let edit = prop_oneof![
        (any::<prop::sample::Index>(), 1usize..40).prop_map(|(i, n)| (0u8, i, n, 0usize)),
        (any::<prop::sample::Index>(), 0..TOKENS.len()).prop_map(|(i, t)| (1u8, i, 0, t)),
        any::<prop::sample::Index>().prop_map(|i| (2u8, i, 0, 0)),
        (any::<prop::sample::Index>(), any::<u8>()).prop_map(|(i, b)| (3u8, i, b as usize, 0)),
    ];
    (0..SCENES.len(), prop::collection::vec(edit, 1..6)).prop_map(|(s, edits)| {
        let mut b = SCENES[s].as_bytes().to_vec();
        for (kind, at, n, t) in edits {
            let i = at.index(b.len() + 1);
            match kind {
                0 => {
                    let end = (i + n).min(b.len());
                    b.drain(i..end);
                }
                1 => {
                    b.splice(i..i, TOKENS[t].bytes());
                }
                2 => {
                    let start = b[..i]
                        .iter()
                        .rposition(|&c| c == b'\n')
                        .map_or(0, |p| p + 1);
                    let end = b[i..]
                        .iter()
                        .position(|&c| c == b'\n')
                        .map_or(b.len(), |p| i + p);
                    let line: Vec<u8> = b[start..end].to_vec();
                    b.splice(start..start, line.into_iter().chain([b'\n']));
                }
                _ => {
                    if i < b.len() {
                        b[i] = n as u8;
                    }
                }
            }
        }
        String::from_utf8_lossy(&b).into_owned()
    })
}

/// A random "key = value" soup under random headers, with the schema's real keys.
fn scene_soup() -> impl Strategy<Value = String> {
    let headers = prop::sample::select(vec![
        "[camera]",
        "[image]",
        "[[lights]]",
        "[[objects]]",
        "[materials.a]",
        "[materials.b]",
        "[materials.a.checker]",
        "[objects]",
        "[camera.eye]",
        "",
    ]);
    let keys = prop::sample::select(vec![
        "eye",
        "look_at",
        "up",
        "fov",
        "width",
        "height",
        "position",
        "color",
        "intensity",
        "albedo",
        "ka",
        "kd",
        "ks",
        "ns",
        "kr",
        "kt",
        "ior",
        "fresnel",
        "checker",
        "a",
        "b",
        "scale",
        "axes",
        "mesh",
        "shape",
        "subdivisions",
        "radius",
        "size",
        "material",
        "translate",
        "rotate",
        "background",
        "ambient",
        "max_depth",
        "fvo",
        "x",
    ]);
    let number = prop_oneof![
        any::<f64>().prop_map(|x| format!("{x:?}")),
        (-1000i64..1000).prop_map(|x| x.to_string()),
        prop::sample::select(vec!["nan", "inf", "-inf", "1e39", "-0.0", "0", "1e308"])
            .prop_map(str::to_owned),
    ];
    let value = prop_oneof![
        number.clone(),
        prop::collection::vec(number, 0..5).prop_map(|v| format!("[{}]", v.join(", "))),
        prop::sample::select(vec![
            "\"sphere\"",
            "\"quad\"",
            "\"box\"",
            "\"a\"",
            "\"xz\"",
            "\"/dev/zero\"",
            "true",
            "{ a = [1, 0, 0], b = [0, 0, 0] }",
            "{ ior = 1.5, fresnel = true }",
            "{}",
            "[[1]]",
        ])
        .prop_map(str::to_owned),
    ];
    let line = prop_oneof![
        headers.prop_map(|h| format!("{h}\n")),
        (keys, value).prop_map(|(k, v)| format!("{k} = {v}\n")),
    ];
    prop::collection::vec(line, 0..40).prop_map(|v| v.concat())
}

/// A loader error is one of the input variants and prints on one line.
fn check_error(e: &Error, text_lines: usize) {
    let msg = e.to_string();
    assert_eq!(e.exit_code(), 2, "{e:?}");
    assert!(!msg.is_empty());
    if let Error::Scene { line, .. } = e {
        assert!(
            *line <= text_lines + 1,
            "line {line} of {text_lines}: {msg}"
        );
    }
}

#[test]
fn scene_text_loads_or_fails_with_an_error() {
    proptest!(config(4096), |(text in prop_oneof![mutated_scene(), scene_soup()])| {
        match parse_scene_str(&text, "p.toml") {
            Ok(s) => {
                prop_assert!(s.validate().is_ok());
                prop_assert!(s.positions.iter().all(|p| p.is_finite()));
            }
            Err(e) => check_error(&e, text.lines().count()),
        }
    });
}

fn obj_text() -> impl Strategy<Value = String> {
    let num = prop_oneof![
        (-100.0f32..100.0).prop_map(|x| x.to_string()),
        prop::sample::select(vec!["nan", "inf", "1e39", "-0", "x", "", "1e-45", "0x1"])
            .prop_map(str::to_owned),
    ];
    let idx = prop_oneof![
        (-12i64..12).prop_map(|i| i.to_string()),
        (-12i64..12, -3i64..3).prop_map(|(a, b)| format!("{a}/{b}")),
        (-12i64..12, -3i64..3).prop_map(|(a, b)| format!("{a}//{b}")),
        (-12i64..12, -3i64..3, -3i64..3).prop_map(|(a, b, c)| format!("{a}/{b}/{c}")),
        prop::sample::select(vec!["/", "//", "a", "99999999999999999999", "1/"])
            .prop_map(str::to_owned),
    ];
    let line = prop_oneof![
        4 => prop::collection::vec(num.clone(), 0..5).prop_map(|v| format!("v {}", v.join(" "))),
        2 => prop::collection::vec(num.clone(), 0..4).prop_map(|v| format!("vn {}", v.join(" "))),
        1 => prop::collection::vec(num, 0..3).prop_map(|v| format!("vt {}", v.join(" "))),
        4 => prop::collection::vec(idx.clone(), 0..6).prop_map(|v| format!("f {}", v.join(" "))),
        1 => prop::collection::vec(idx, 0..5).prop_map(|v| format!("l {}", v.join(" "))),
        1 => prop::sample::select(vec![
            "usemtl a", "usemtl b", "usemtl", "mtllib x.mtl", "mtllib", "g g1", "o o1", "s 1",
            "p 1", "# comment", "", "\u{e9}\u{0}", "f", "v",
        ])
        .prop_map(str::to_owned),
    ];
    prop::collection::vec(line, 0..30).prop_map(|v| v.join("\n"))
}

fn mtl_text() -> impl Strategy<Value = Option<String>> {
    let num = prop_oneof![
        (-2.0f32..200.0).prop_map(|x| x.to_string()),
        prop::sample::select(vec!["nan", "inf", "-halo", "spectral", "xyz", ""])
            .prop_map(str::to_owned),
    ];
    let key = prop::sample::select(vec![
        "newmtl a", "newmtl b", "newmtl", "Ka", "Kd", "Ks", "Ke", "Tf", "Ns", "Ni", "d", "Tr",
        "illum", "map_Kd", "#",
    ]);
    let line =
        (key, prop::collection::vec(num, 0..5)).prop_map(|(k, v)| format!("{k} {}", v.join(" ")));
    prop::option::of(prop::collection::vec(line, 0..20).prop_map(|v| v.join("\n")))
}

#[test]
fn obj_text_loads_or_fails_with_an_error() {
    proptest!(config(8192), |(obj in obj_text(), mtl in mtl_text())| {
        match parse_obj_with_mtl(&obj, mtl.as_deref()) {
            Ok(m) => {
                // Everything the renderers index is in range and finite.
                prop_assert!(m.positions.iter().all(|p| p.is_finite()));
                prop_assert!(m.normals.iter().all(|n| n.is_finite()));
                for t in &m.triangles {
                    prop_assert!(t.v.iter().all(|&v| (v as usize) < m.positions.len()));
                    prop_assert!(t.n.iter().all(|&n| n == NO_NORMAL || (n as usize) < m.normals.len()));
                    prop_assert!((t.material as usize) < m.materials.len());
                }
            }
            Err(e) => check_error(&e, obj.lines().count()),
        }
    });
}

/// A random mesh: `n` triangles whose vertices come from a small pool (so edges and
/// vertices are shared, as in real meshes), some snapped to a coarse lattice (axis-aligned
/// and coplanar triangles, cell-face coincidences).
fn mesh() -> impl Strategy<Value = (Vec<Vec3>, Vec<[u32; 3]>)> {
    let coord = prop_oneof![
        3 => -4.0f32..4.0,
        1 => (-8i32..=8).prop_map(|k| k as f32 * 0.5),
    ];
    let vertex = (coord.clone(), coord.clone(), coord).prop_map(|(x, y, z)| Vec3::new(x, y, z));
    prop::collection::vec(vertex, 3..40).prop_flat_map(|pool| {
        let n = pool.len() as u32;
        let tri = (0..n, 0..n, 0..n).prop_map(|(a, b, c)| [a, b, c]);
        (Just(pool), prop::collection::vec(tri, 1..60))
    })
}

fn ray() -> impl Strategy<Value = ([f64; 3], [f64; 3])> {
    let o = prop::array::uniform3(-6.0f64..6.0);
    let comp = prop_oneof![4 => -1.0f64..1.0, 1 => Just(0.0), 1 => Just(-0.0)];
    let d = prop::array::uniform3(comp)
        .prop_filter("non-zero direction", |d| d.iter().any(|c| *c != 0.0));
    (o, d)
}

/// Relative window within which two different triangles count as a tie, i.e. as the same
/// distance: far below the renderer's own tie margin (`TIE_EPS` = 2^-19), because in f64
/// different surfaces are essentially never that close by accident; only shared edges and
/// vertices and coplanar overlaps (equal t up to a few ulps) fall into it.
const TIE_WINDOW: f64 = 1e-9;

#[test]
fn grid_traversal_agrees_with_brute_force() {
    let cam = Camera {
        eye: Vec3::new(0.0, 0.0, 10.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
    };
    let grid_res = prop_oneof![
        Just(GridRes::Auto),
        prop::array::uniform3(1u32..9).prop_map(GridRes::Fixed)
    ];
    let ties = std::cell::Cell::new(0usize);
    let rays_total = std::cell::Cell::new(0usize);
    proptest!(config(4096), |((positions, tris) in mesh(), res in grid_res, rays in prop::collection::vec(ray(), 48))| {
        let mut s = Scene::empty(cam);
        let m = s.add_material(Material::default());
        s.positions = positions;
        s.triangles = tris
            .into_iter()
            .map(|v| Triangle { v, n: [NO_NORMAL; 3], material: m })
            .collect();
        let grid = Grid::build(&s, &GridConfig { res, ..GridConfig::default() }).unwrap();
        let accel = GridWalker::<f64>::new(&s, &grid);
        for (o, d) in rays {
            rays_total.set(rays_total.get() + 1);
            let ray = Ray {
                o: V3::new(o[0], o[1], o[2]),
                d: V3::new(d[0], d[1], d[2]),
                t_min: 0.0,
                t_max: f64::INFINITY,
            };
            let got = accel.closest_hit(&ray, &mut Work::default());
            let want = accel.brute_force(&ray);
            match (got, want) {
                (None, None) => {}
                (Some(g), Some(w)) if g.tri == w.tri => {
                    prop_assert_eq!(g.t, w.t, "same triangle {}, different t", g.tri);
                }
                (Some(g), Some(w)) => {
                    let rel = (g.t - w.t).abs() / w.t.abs().max(f64::MIN_POSITIVE);
                    prop_assert!(
                        rel <= TIE_WINDOW,
                        "grid hit triangle {} at t = {}, brute force {} at t = {} (relative {rel:e}); ray {o:?} {d:?}",
                        g.tri, g.t, w.tri, w.t
                    );
                    ties.set(ties.get() + 1);
                }
                (g, w) => prop_assert!(false, "grid {g:?} vs brute force {w:?}; ray {o:?} {d:?}"),
            }
        }
    });
    eprintln!(
        "{} rays, {} different-triangle ties within {TIE_WINDOW:e}",
        rays_total.get(),
        ties.get()
    );
}
