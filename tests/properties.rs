//! Property tests (proptest): scene text loads or fails with an error (and what loads
//! renders finite), OBJ text likewise, and the traversal of every structure (the uniform
//! grid, the irregular grid and the CPU's BVH) finds exactly what brute force finds, in f64
//! and f32 (the BVH's f32 also through its vectorised walk, with every kernel the CPU runs).
//!
//! Each property runs twice: with a fixed RNG seed (so CI is reproducible), then with a
//! fresh seed taken from the clock, on an eighth of the cases, so every run also explores
//! new inputs. Both seeds are printed; `FRAGTRACE_PROPTEST_SEED=N` makes the second run use
//! N, which replays a failure seen with that seed. A failure is shrunk and its case saved to
//! `tests/properties.proptest-regressions`, which is committed and replayed first.

use glam::Vec3;
use proptest::prelude::*;
use proptest::test_runner::{Config, FileFailurePersistence, RngAlgorithm, RngSeed};

use fragtrace::accel::{AccelRef, Bvh, Grid, GridConfig, GridRes, IrregularConfig, IrregularGrid};
use fragtrace::cpu::intersect::{intersect_with, RayShear};
use fragtrace::cpu::real::{Real, V3};
use fragtrace::cpu::simd::Isa;
use fragtrace::cpu::traverse::{tie_limit, CellWalk, GridWalker, Hit, Ray, Trace, Work};
use fragtrace::cpu::traverse_bvh::BvhWalker;
use fragtrace::cpu::walker::Walker;
use fragtrace::options::{Backend, Precision, RenderOptions};
use fragtrace::scene::{
    parse_obj_with_mtl, parse_scene_str, Camera, Material, Scene, Triangle, NO_NORMAL,
};
use fragtrace::technique::Techniques;
use fragtrace::Error;

const DEFAULT_SEED: u64 = 0x6672_6167_7472_6163; // "fragtrac"

/// The fresh run's seed: `FRAGTRACE_PROPTEST_SEED` when set, else from the clock.
fn fresh_seed() -> u64 {
    std::env::var("FRAGTRACE_PROPTEST_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| {
            let now = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .unwrap_or_default();
            now.as_secs().wrapping_mul(1_000_000_007) ^ now.subsec_nanos() as u64
        })
}

/// The two runs of a property: `cases` with the fixed seed, then `cases / 8` with a fresh
/// one (an eighth keeps the file's run time within 1.5x of the fixed run alone).
fn configs(name: &str, cases: u32) -> [Config; 2] {
    let fresh = fresh_seed();
    eprintln!(
        "{name}: proptest seeds {DEFAULT_SEED} ({cases} cases), then {fresh} ({} cases; \
         rerun it with FRAGTRACE_PROPTEST_SEED={fresh})",
        cases / 8
    );
    [(DEFAULT_SEED, cases), (fresh, cases / 8)].map(|(seed, cases)| Config {
        cases,
        rng_seed: RngSeed::Fixed(seed),
        rng_algorithm: RngAlgorithm::ChaCha,
        // A direct path: `SourceParallel` looks for a lib.rs or main.rs beside or above
        // this file, finds none for an integration test, and then neither reads nor writes
        // the regressions file (it printed "failed to find lib.rs or main.rs").
        failure_persistence: Some(Box::new(FileFailurePersistence::Direct(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/properties.proptest-regressions"
        )))),
        max_shrink_iters: 2048,
        ..Config::default()
    })
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

/// Whatever loads renders: a 4x4 CPU f32 render of every accepted scene is finite. (That
/// the scene passes `validate()` is what the loader enforces; the render is what users
/// get.) A render may still refuse a scene over a limit, with a usage-class error.
#[test]
fn scene_text_loads_or_fails_with_an_error() {
    let rendered = std::cell::Cell::new(0usize);
    for cfg in configs("scene text", 4096) {
        proptest!(cfg, |(text in prop_oneof![mutated_scene(), scene_soup()])| {
            match parse_scene_str(&text, "p.toml") {
                Ok(s) => {
                    let mut o = RenderOptions::for_scene(&s);
                    (o.width, o.height) = (4, 4);
                    o.backend = Backend::Cpu;
                    o.precision = Precision::F32;
                    match fragtrace::render::render_cpu(&s, &o) {
                        Ok(r) => {
                            prop_assert!(r.image.all_finite(), "{:?}", r.image.data);
                            rendered.set(rendered.get() + 1);
                        }
                        Err(e) => check_error(&e, usize::MAX),
                    }
                }
                Err(e) => check_error(&e, text.lines().count()),
            }
        });
    }
    eprintln!("scene text: {} accepted scenes rendered", rendered.get());
    // Most edits break a scene; measured 58 to 65 accepted and rendered per run (fixed seed
    // plus fresh seeds). Fewer than 20 would mean the render check hardly ran.
    assert!(
        rendered.get() >= 20,
        "only {} scenes rendered",
        rendered.get()
    );
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
    for cfg in configs("obj text", 8192) {
        proptest!(cfg, |(obj in obj_text(), mtl in mtl_text())| {
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
}

/// A random mesh: `n` triangles whose vertices come from a small pool (so edges and
/// vertices are shared, as in real meshes), some snapped to a coarse lattice (axis-aligned
/// and coplanar triangles, cell-face coincidences).
fn mesh() -> impl Strategy<Value = (Vec<Vec3>, Vec<[u32; 3]>)> + Clone {
    mesh_from_pool(3)
}

/// [`mesh`] with a vertex pool of at least `min_pool` vertices.
fn mesh_from_pool(min_pool: usize) -> impl Strategy<Value = (Vec<Vec3>, Vec<[u32; 3]>)> + Clone {
    let coord = prop_oneof![
        3 => -4.0f32..4.0,
        1 => (-8i32..=8).prop_map(|k| k as f32 * 0.5),
    ];
    let vertex = (coord.clone(), coord.clone(), coord).prop_map(|(x, y, z)| Vec3::new(x, y, z));
    prop::collection::vec(vertex, min_pool..40).prop_flat_map(|pool| {
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

/// A ray aimed at a point of a triangle's edge: (origin, triangle, edge, position along
/// the edge), the position 0 or 1 (a vertex) a third of the time. Shared edges and
/// vertices are where two triangles tie and where a walk may step between cells.
fn aimed_ray() -> impl Strategy<Value = ([f64; 3], prop::sample::Index, usize, f64)> {
    let along = prop_oneof![2 => 0.0f64..1.0, 1 => Just(0.0), 1 => Just(1.0)];
    (
        prop::array::uniform3(-6.0f64..6.0),
        any::<prop::sample::Index>(),
        0usize..3,
        along,
    )
}

/// Per precision: rays traced, rays that hit, hits within 1e-6 of an edge (barycentric).
#[derive(Default)]
struct Tally {
    rays: usize,
    hits: usize,
    edge_hits: usize,
    /// Irregular grid only: rays where the walk kept a different triangle within the tie
    /// margin of brute force's (see `agree`).
    ties: usize,
    /// BVH only: rays where the walk kept another hit of a chain of hits each within the
    /// tie margin of the next but spanning more ([`tie_chain`]).
    chains: usize,
}

/// Which walk [`agree_with`] checks, for its exemptions.
#[derive(Clone, Copy, PartialEq)]
enum Walk {
    /// The uniform grid: no exemption.
    Uniform,
    /// The irregular grid: ties within twice the margin across a cell face.
    Irregular,
    /// The BVH: chains of three or more hits ([`tie_chain`]).
    Bvh,
}

/// The structure and brute force agree on `rays` in precision `T`: both miss, or both hit
/// the same triangle at the same t, and the any-hit query says whether brute force hits.
/// Ties (shared edges and vertices, coplanar overlaps) included: brute force gives a tie to
/// the lowest index (`TIE_EPS`), and so must the grid, whatever cell it finds the hit in,
/// and the BVH, whatever leaf it meets first. An earlier version allowed different
/// triangles within a relative 1e-9 of each other and counted them; the count was 0 in f64
/// and f32, with the edge-aimed rays too (184,320 rays each), so any such tie is now a
/// failure (the irregular grid's cell-face ties and the BVH's documented tie chains
/// excepted, below). The grids are walked by [`Walker`], the BVH by the scalar
/// [`BvhWalker::new`] ([`agree_vectorised`] for its vectorised f32 walk).
fn agree<T: Real>(
    s: &Scene,
    accel: AccelRef<'_>,
    rays: &[([f64; 3], [f64; 3])],
    tally: &mut Tally,
) -> Result<(), TestCaseError> {
    match accel {
        AccelRef::Bvh(b) => {
            let w = BvhWalker::<T>::new(s, b, Default::default());
            agree_with(s, &w, "bvh", Walk::Bvh, rays, tally)
        }
        grid => {
            let w = Walker::<T>::new(s, grid.grid().unwrap(), Default::default());
            let (what, walk) = match w {
                Walker::Irregular(_) => ("irregular grid", Walk::Irregular),
                Walker::Uniform(_) => ("uniform grid", Walk::Uniform),
            };
            agree_with(s, &w, what, walk, rays, tally)
        }
    }
}

/// [`agree`] for the BVH's vectorised f32 walk with the kernel `isa`, as strictly.
fn agree_vectorised(
    s: &Scene,
    bvh: &Bvh,
    isa: Isa,
    rays: &[([f64; 3], [f64; 3])],
    tally: &mut Tally,
) -> Result<(), TestCaseError> {
    let w = BvhWalker::vectorised(s, bvh, Default::default(), isa);
    prop_assert_eq!(w.isa(), isa);
    agree_with(
        s,
        &w,
        &format!("bvh {}", isa.name()),
        Walk::Bvh,
        rays,
        tally,
    )
}

/// Whether the BVH's closest hit `g`, another than brute force's `w`, is the exception its
/// tie rule documents (src/cpu/traverse_bvh.rs): the rule is applied pair by pair in the
/// walk's order, so where three or more hits lie each within `TIE_EPS` of the next but
/// not all within it of each other, the pairs met decide. "Within the margin" is judged by
/// the rule's own comparison: the intersection test of each against the other's
/// `tie_limit` (in `t * |det|`, which at the margin can put two hits of the same t on
/// different sides; by the divided t it is the old check on sorted neighbours). True when,
/// among every hit of the ray (each triangle's test alone), `g` and `w` lie, with their
/// exact t, in one set linked by such steps whose members are not all within the margin
/// of each other; any other difference (a pair, or hits farther apart) is not the
/// documented exception.
fn tie_chain<T: Real>(tris: &[[V3<T>; 3]], ray: &Ray<T>, g: &Hit<T>, w: &Hit<T>) -> bool {
    let shear = RayShear::new(ray.d);
    let tech = Techniques::default();
    let test = |i: u32, hi: T| {
        intersect_with(
            ray.o,
            ray.d,
            &shear,
            &tris[i as usize],
            ray.t_min,
            hi,
            &tech,
        )
    };
    let hits: Vec<(T, u32)> = (0..tris.len() as u32)
        .filter_map(|i| test(i, ray.t_max).map(|h| (h.t, i)))
        .collect();
    // Neither is closer than the other by more than TIE_EPS: neither passes its test
    // against the other's tie limit.
    let near = |a: (T, u32), b: (T, u32)| {
        test(a.1, tie_limit(b.0)).is_none() && test(b.1, tie_limit(a.0)).is_none()
    };
    let at = |h: &Hit<T>| hits.iter().position(|&(t, i)| i == h.tri && t == h.t);
    let (Some(i), Some(j)) = (at(g), at(w)) else {
        return false;
    };
    // The hits linked to `g` by steps within the margin.
    let mut linked = vec![i];
    let mut k = 0;
    while k < linked.len() {
        let a = hits[linked[k]];
        for (m, &b) in hits.iter().enumerate() {
            if !linked.contains(&m) && near(a, b) {
                linked.push(m);
            }
        }
        k += 1;
    }
    linked.contains(&j)
        && linked
            .iter()
            .any(|&a| linked.iter().any(|&b| !near(hits[a], hits[b])))
}

/// [`agree`] with the walk `accel` (named `what` in failures) of the kind `walk`, for its
/// exemptions.
fn agree_with<T: Real>(
    s: &Scene,
    accel: &dyn Trace<T>,
    what: &str,
    walk: Walk,
    rays: &[([f64; 3], [f64; 3])],
    tally: &mut Tally,
) -> Result<(), TestCaseError> {
    // Brute force over every triangle (`CellWalk::brute_force`), held by a grid of one
    // cell: the same triangles, converted to `T` the same way, whatever the structure.
    let one = Grid::build(
        s,
        &GridConfig {
            res: GridRes::Fixed([1, 1, 1]),
            ..GridConfig::default()
        },
    )
    .unwrap();
    let oracle = GridWalker::<T>::new(s, &one);
    let brute = |ray: &Ray<T>| oracle.brute_force(ray);
    for (o, d) in rays {
        let v = |a: &[f64; 3]| V3::new(T::from_f64(a[0]), T::from_f64(a[1]), T::from_f64(a[2]));
        let ray = Ray {
            o: v(o),
            d: v(d),
            t_min: T::ZERO,
            t_max: T::BIG,
        };
        if ray.d.x == T::ZERO && ray.d.y == T::ZERO && ray.d.z == T::ZERO {
            continue;
        }
        tally.rays += 1;
        let got = accel.closest_hit(&ray, &mut Work::default());
        let want = brute(&ray);
        let any = accel.any_hit(&ray, &mut Work::default());
        prop_assert!(
            any == want.is_some(),
            "{what}: any-hit {any}, brute force {:?}; ray {o:?} {d:?}",
            want.map(|h: Hit<T>| (h.tri, h.t.to_f64()))
        );
        if let Some(w) = &want {
            tally.hits += 1;
            let low =
                w.b.iter()
                    .map(|b| b.to_f64().abs())
                    .fold(f64::INFINITY, f64::min);
            tally.edge_hits += (low < 1e-6) as usize;
        }
        match (got, want) {
            (None, None) => {}
            // The irregular walk decides ties per cell like the DDA, but its cells are
            // small: two hits within the tie margin on two sides of a cell face go to the
            // first cell's triangle, brute force's to the lower index. Both are answers of
            // the tie rule; they are counted and bounded by the caller.
            (Some(g), Some(w))
                if walk == Walk::Irregular
                    && g.tri != w.tri
                    && (g.t.to_f64() - w.t.to_f64()).abs()
                        <= 2.0 * fragtrace::accel::TIE_EPS * w.t.to_f64().abs() =>
            {
                tally.ties += 1;
            }
            // The BVH applies the tie rule pair by pair in its own order: in a chain of
            // hits each within the margin of the next but spanning more, the first pair met
            // decides (its module doc). Counted and bounded by the caller; a difference
            // that is no such chain fails below.
            (Some(g), Some(w))
                if walk == Walk::Bvh
                    && (g.tri, g.t) != (w.tri, w.t)
                    && tie_chain(CellWalk::tris(&oracle), &ray, &g, &w) =>
            {
                tally.chains += 1;
            }
            (Some(g), Some(w)) => {
                prop_assert!(
                    g.tri == w.tri && g.t == w.t,
                    "{what} hit triangle {} at t = {}, brute force {} at t = {}; ray {o:?} {d:?}",
                    g.tri,
                    g.t.to_f64(),
                    w.tri,
                    w.t.to_f64()
                );
            }
            (g, w) => prop_assert!(
                false,
                "{what} {:?} vs brute force {:?}; ray {o:?} {d:?}",
                g.map(|h: Hit<T>| (h.tri, h.t.to_f64())),
                w.map(|h: Hit<T>| (h.tri, h.t.to_f64()))
            ),
        }
    }
    Ok(())
}

/// Build parameters of a structure (the BVH has none).
#[derive(Clone, Debug)]
enum Structure {
    Uniform(GridRes),
    Irregular(IrregularConfig),
    Bvh,
}

#[test]
fn grid_traversal_agrees_with_brute_force() {
    let grid_res = prop_oneof![
        Just(GridRes::Auto),
        prop::array::uniform3(1u32..9).prop_map(GridRes::Fixed)
    ];
    traversal_agrees_with_brute_force(
        "grid traversal",
        mesh(),
        grid_res.prop_map(Structure::Uniform),
    );
}

/// Smallest vertex pool of the irregular grid's meshes: as small as the uniform grid's.
/// Pools of 3-6 vertices with 20-60 triangles (many coincident and zero-area triangles along
/// the same few edges) made the build split to its depth limit until it required a split
/// to separate something (see `irregular_build_of_coincident_degenerate_triangles_stays_small`).
const IRREGULAR_MIN_POOL: usize = 3;

/// The irregular grid's walk against brute force, with the default build and with top
/// densities from 1/64 (one top cell for these meshes: everything is in the voxel map's
/// split) to 8 cells per triangle, and leaves split down to 1..8 triangles. Measured with
/// the tie check counted instead of failing (fixed seed plus a fresh eighth, 8 s): f64
/// 184,400 rays, 82,351 hits (44.7%), 24,253 within 1e-6 of an edge (13.2%); f32 75,007
/// hits (40.7%), 15,978 at an edge (8.7%); the bounds below (25%, 4%) hold with margin.
/// It failed on one f32 ray of 184,400 with the build of 4c4f014 (the walk returned
/// triangle 1 at t = 0.99999994 where brute force gives the tie to triangle 0 at t = 1;
/// shrunk: `irregular_tie_at_a_shared_vertex_goes_to_the_lowest_index`).
#[test]
fn irregular_traversal_agrees_with_brute_force() {
    let cfg = prop_oneof![
        Just(IrregularConfig::default()),
        (0.015625f32..8.0, 1u32..9).prop_map(|(top_density, leaf_max)| IrregularConfig {
            top_density,
            leaf_max
        })
    ];
    traversal_agrees_with_brute_force(
        "irregular traversal",
        mesh_from_pool(IRREGULAR_MIN_POOL),
        cfg.prop_map(Structure::Irregular),
    );
}

/// The BVH's walks against brute force on the uniform grid's meshes and rays, as strictly
/// as the uniform grid's (the same triangle at the same t bits, and the any-hit answer):
/// the scalar walk in f64 and f32 and the vectorised f32 walk with each kernel this CPU
/// runs (AVX2 and SSE2 on x86-64; none elsewhere). Only its documented exception to brute
/// force, a chain of three or more hits each within `TIE_EPS` of the next but spanning
/// more (src/cpu/traverse_bvh.rs), is counted instead of failing ([`tie_chain`]), and
/// bounded. Measured (fixed seed plus the fresh seed 1): f64 184,480 rays, 80,483 hits
/// (43.6%), 27,063 within 1e-6 of an edge; f32 (each walk alike) 72,102 hits (39.1%),
/// 17,713 at an edge. The fresh seeds 1796296070110771985 and 121 failed it before the
/// BVH decided its ties with the intersection test's own comparison, on a pair of hits one
/// ulp past the margin (`bvh_tie_at_the_margin_goes_as_brute_force`); they pass now. The
/// fresh seed 1796533127666601044 failed it on a chain that [`tie_chain`] missed while it
/// judged the margin by the divided t, not the intersection test's comparison the rule
/// uses (`bvh_tie_chain_at_the_margin_is_the_documented_exception`); counted now.
#[test]
fn bvh_traversal_agrees_with_brute_force() {
    traversal_agrees_with_brute_force("bvh traversal", mesh(), Just(Structure::Bvh));
}

/// The vectorised kernels of the BVH's f32 walk that this CPU runs, widest first.
fn vector_isas() -> Vec<Isa> {
    [Isa::Avx2, Isa::Sse2]
        .into_iter()
        .filter(|i| i.available())
        .collect()
}

/// Random meshes, free rays and rays aimed at triangle edges and vertices: the walk of the
/// structure `structure` builds finds what brute force finds, in f64 and f32 (and, for the
/// BVH, its vectorised f32 walk with every kernel of [`vector_isas`]).
fn traversal_agrees_with_brute_force(
    name: &str,
    meshes: impl Strategy<Value = (Vec<Vec3>, Vec<[u32; 3]>)> + Clone,
    structure: impl Strategy<Value = Structure> + Clone,
) {
    let cam = Camera {
        eye: Vec3::new(0.0, 0.0, 10.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
    };
    let isas = vector_isas();
    // f64, f32, then the vectorised f32 walk per kernel (the BVH's only).
    let labels: Vec<String> = ["f64".to_string(), "f32".to_string()]
        .into_iter()
        .chain(isas.iter().map(|i| format!("f32 {}", i.name())))
        .collect();
    let tally =
        std::cell::RefCell::new(labels.iter().map(|_| Tally::default()).collect::<Vec<_>>());
    for cfg in configs(name, 4096) {
        proptest!(cfg, |((positions, tris) in meshes.clone(), st in structure.clone(), free in prop::collection::vec(ray(), 24), aimed in prop::collection::vec(aimed_ray(), 16))| {
            let mut s = Scene::empty(cam);
            let m = s.add_material(Material::default());
            s.positions = positions;
            s.triangles = tris
                .into_iter()
                .map(|v| Triangle { v, n: [NO_NORMAL; 3], material: m })
                .collect();
            let mut rays = free;
            for (o, tri, k, along) in aimed {
                let v = s.triangles[tri.index(s.triangles.len())].v;
                let (a, b) = (
                    s.positions[v[k] as usize].as_dvec3(),
                    s.positions[v[(k + 1) % 3] as usize].as_dvec3(),
                );
                let target = a + (b - a) * along;
                rays.push((o, (target - glam::DVec3::from_array(o)).to_array()));
            }
            let (grid, irregular, bvh);
            let accel: AccelRef = match st {
                Structure::Uniform(res) => {
                    grid = Grid::build(&s, &GridConfig { res, ..GridConfig::default() }).unwrap();
                    (&grid).into()
                }
                Structure::Irregular(cfg) => {
                    irregular = IrregularGrid::build(&s, &cfg).unwrap();
                    (&irregular).into()
                }
                Structure::Bvh => {
                    bvh = Bvh::build(&s).unwrap();
                    (&bvh).into()
                }
            };
            let mut t = tally.borrow_mut();
            agree::<f64>(&s, accel, &rays, &mut t[0])?;
            agree::<f32>(&s, accel, &rays, &mut t[1])?;
            if let AccelRef::Bvh(b) = accel {
                for (k, &isa) in isas.iter().enumerate() {
                    agree_vectorised(&s, b, isa, &rays, &mut t[2 + k])?;
                }
            }
        });
    }
    for (prec, t) in labels.iter().zip(tally.borrow().iter()) {
        if t.rays == 0 {
            continue; // a vectorised walk of a grid: not run here
        }
        eprintln!(
            "{name} {prec}: {} rays, {} hits, {} within 1e-6 of an edge, {} tie disagreements, {} tie chains",
            t.rays, t.hits, t.edge_hits, t.ties, t.chains
        );
        // The property says something only if rays hit, and hit edges. Measured (fixed
        // seed plus a fresh eighth): 43% of the rays hit in f64, 39% in f32; 15% (f64)
        // and 10% (f32) of all rays hit within 1e-6 of an edge, all of them aimed rays.
        // Bounds: 25% and 4%. Without the aimed rays 12% hit and none near an edge,
        // and both bounds fail (tried). The irregular grid's run (meshes from pools of at
        // least 8 vertices) measured 45% / 41% hits and 13% / 8.7% edge hits.
        let share = |n: usize| n as f64 / t.rays.max(1) as f64;
        assert!(
            share(t.hits) >= 0.25,
            "{name} {prec}: hit share {}",
            share(t.hits)
        );
        assert!(
            share(t.edge_hits) >= 0.04,
            "{name} {prec}: edge-hit share {}",
            share(t.edge_hits)
        );
        // Measured: 5 of 184,480 f32 rays (2.7e-5) and none in f64 on the irregular grid;
        // the uniform grid never counts any (the exemption is the irregular grid's).
        assert!(
            share(t.ties) <= 2e-4,
            "{name} {prec}: {} tie disagreements in {} rays",
            t.ties,
            t.rays
        );
        // The BVH's tie chains (only the BVH counts any). Measured over the fixed seed and
        // 31 fresh ones (13, 100-129): one ray, with the fresh seed 13, in f32 on every
        // walk (`bvh_tie_chain_is_the_documented_exception`), none in f64; so at most one
        // in 184,480 per run. Again with the margin judged by the intersection test's
        // comparison, fresh seeds 1-60, 121, 1796296070110771985 and 1796533127666601044:
        // one ray in f32 (every walk) with each of 45, 47, 121 and 1796533127666601044,
        // none otherwise and none in f64. Bound: 2e-5 (3 rays).
        assert!(
            share(t.chains) <= 2e-5,
            "{name} {prec}: {} tie chains in {} rays",
            t.chains,
            t.rays
        );
    }
}

/// The first mesh the irregular property found (minimal after shrinking, fixed seed): 36
/// triangles of 8 vertices, many of them zero-area, default build. The ray is one of the
/// property's edge-aimed rays: it passes exactly through vertex 4 at t = 1, shared by
/// triangles 7 = (2, 4, 1) and 14 = (7, 4, 0). Brute force gives the tie to the lowest
/// index, 7 (the tie rule of every backend); the irregular walk returned 14 in f32 with the
/// build of 4c4f014 (f64 returned 7, and so does the uniform grid in both precisions); a
/// regression test since the build stopped splitting where nothing separates.
#[test]
fn irregular_tie_at_a_shared_vertex_goes_to_the_lowest_index() {
    let v = Vec3::new;
    let positions = vec![
        v(0.0, 1.926633, 4.0),
        v(-0.61507684, -1.5361048, -0.23404135),
        v(-1.0718173, -2.2072625, 1.991431),
        v(1.2216182, -3.5, -0.7779404),
        v(0.40074542, -3.0, 1.515402),
        v(-2.9772787, 2.5, -1.0),
        v(3.5, 3.0, 0.9271845),
        v(3.5, -3.0, 1.0),
    ];
    #[rustfmt::skip]
    let tris: [[u32; 3]; 36] = [
        [0, 0, 0], [0, 0, 0], [4, 4, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0], [2, 4, 1],
        [0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0], [1, 2, 3], [5, 6, 5], [7, 4, 0], [0, 2, 6],
        [3, 0, 0], [1, 4, 3], [4, 2, 2], [0, 0, 4], [5, 1, 5], [5, 5, 2], [6, 7, 6], [4, 2, 4],
        [3, 3, 3], [3, 3, 0], [5, 0, 6], [5, 3, 5], [2, 6, 5], [7, 2, 2], [1, 5, 6], [5, 4, 0],
        [6, 7, 2], [1, 1, 1], [0, 2, 1], [4, 3, 5],
    ];
    let mut s = Scene::empty(Camera {
        eye: Vec3::new(0.0, 0.0, 10.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
    });
    let m = s.add_material(Material::default());
    s.positions = positions;
    s.triangles = tris
        .iter()
        .map(|&v| Triangle {
            v,
            n: [NO_NORMAL; 3],
            material: m,
        })
        .collect();
    let ray = (
        [3.5635393917881357, -3.2413478447709942, 5.209184557984009],
        [-3.16279397014011, 0.24134784477099425, -3.6937825985647583],
    );
    let grid = IrregularGrid::build(&s, &IrregularConfig::default()).unwrap();
    let uniform = Grid::build(&s, &GridConfig::default()).unwrap();
    let bvh = Bvh::build(&s).unwrap();
    let mut t = Tally::default();
    // The uniform grid and the BVH (every walk) keep the tie rule on this ray (controls).
    agree::<f64>(&s, (&uniform).into(), &[ray], &mut t).unwrap();
    agree::<f32>(&s, (&uniform).into(), &[ray], &mut t).unwrap();
    agree::<f64>(&s, (&bvh).into(), &[ray], &mut t).unwrap();
    agree::<f32>(&s, (&bvh).into(), &[ray], &mut t).unwrap();
    for isa in vector_isas() {
        agree_vectorised(&s, &bvh, isa, &[ray], &mut t).unwrap();
    }
    let r64 = agree::<f64>(&s, (&grid).into(), &[ray], &mut t);
    let r32 = agree::<f32>(&s, (&grid).into(), &[ray], &mut t);
    assert!(r64.is_ok() && r32.is_ok(), "f64: {r64:?}\nf32: {r32:?}");
}

/// A scene of the property's kind: `positions`, and `tris` listed by index (the others
/// `[0, 0, 0]`, zero-area triangles that are never hit), default camera and material.
fn scene_of(positions: Vec<Vec3>, n: usize, tris: &[(usize, [u32; 3])]) -> Scene {
    let mut s = Scene::empty(Camera {
        eye: Vec3::new(0.0, 0.0, 10.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
    });
    let m = s.add_material(Material::default());
    s.positions = positions;
    s.triangles = vec![
        Triangle {
            v: [0; 3],
            n: [NO_NORMAL; 3],
            material: m,
        };
        n
    ];
    for &(i, v) in tris {
        s.triangles[i].v = v;
    }
    s
}

/// A closest hit in f32 as (triangle, t bits), or a miss.
type Answer = Option<(u32, u32)>;

/// The closest hit of `ray` in f32 by brute force and by every BVH walk (scalar, then each
/// vectorised kernel), as (triangle, t bits).
fn bvh_answers(s: &Scene, ray: ([f64; 3], [f64; 3])) -> (Answer, Vec<Answer>) {
    let r = Ray {
        o: V3::new(ray.0[0] as f32, ray.0[1] as f32, ray.0[2] as f32),
        d: V3::new(ray.1[0] as f32, ray.1[1] as f32, ray.1[2] as f32),
        t_min: 0.0,
        t_max: f32::BIG,
    };
    let one = Grid::build(
        s,
        &GridConfig {
            res: GridRes::Fixed([1, 1, 1]),
            ..GridConfig::default()
        },
    )
    .unwrap();
    let key = |h: Option<Hit<f32>>| h.map(|h| (h.tri, h.t.to_bits()));
    let brute = key(GridWalker::<f32>::new(s, &one).brute_force(&r));
    let bvh = Bvh::build(s).unwrap();
    let mut walks = vec![BvhWalker::<f32>::new(s, &bvh, Default::default())];
    for isa in vector_isas() {
        walks.push(BvhWalker::vectorised(s, &bvh, Default::default(), isa));
    }
    let got = walks
        .iter()
        .map(|w| key(w.closest_hit(&r, &mut Work::default())))
        .collect();
    (brute, got)
}

/// [`bvh_answers`]'s answers for a message: triangle, t and its bits.
fn show(h: &[Answer]) -> String {
    h.iter()
        .map(|h| match h {
            Some((tri, b)) => format!("{tri} at t = {:e} ({b:#010x})", f32::from_bits(*b)),
            None => "miss".into(),
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Found by `bvh_traversal_agrees_with_brute_force` with the fresh seed
/// 1796296070110771985 (shrunk; the seed 121 found one of the same kind): a ray aimed at
/// the edge 0-3 shared by triangles 9 = (3, 1, 0) and 26 = (0, 4, 3) (8 and 17 are
/// zero-area triangles on that edge, never hit). In f32 triangle 9 is hit at t =
/// 0x3f7ffffe and 26, which the ray meets at a grazing angle, at 0x3f7fffdd: one ulp below
/// `tie_limit(t9)` = 0x3f7fffde, so by the divided t 26 is closer by more than `TIE_EPS`
/// (in f64 the two lie 5.6e-8 apart, a tie). Two hits, no chain. Brute force meets 9 first
/// and tests 26 against the bound `tie_limit(t9)` inside the intersection test, which
/// compares `tt < bound * |det|` and rounds that to a rejection: brute force (and the
/// grids, which share its per-cell step) answer 9. The BVH's leaf lists 26 first; its
/// `takes` then keeps 26 over 9 by comparing the divided t (`t26 < tie_limit(t9)`), and
/// answered 26 (scalar and vectorised alike). The module doc promises brute force's answer
/// for any pair, so that was a failure of the BVH, not of the check; the BVH now decides
/// each pair with the intersection test's own comparison (the later index's test against
/// the earlier's tie limit) and answers 9 on every walk.
#[test]
fn bvh_tie_at_the_margin_goes_as_brute_force() {
    let v = Vec3::new;
    let s = scene_of(
        vec![
            v(-1.3139267, 3.533847, -1.1232452),
            v(-2.986162, 3.3324988, 3.2213686),
            v(0.0, -3.8282645, -1.0),
            v(-3.820194, 3.195389, 2.5887568),
            v(-3.5, -4.0, 1.134179),
            v(3.7252297, 3.1781821, -1.0),
        ],
        32,
        &[
            (8, [3, 0, 0]),
            (9, [3, 1, 0]),
            (14, [1, 0, 0]),
            (17, [0, 3, 0]),
            (26, [0, 4, 3]),
        ],
    );
    let ray = (
        [-1.3500417677849195, -5.173491625166071, -2.5710431077228644],
        [-1.9869180295344575, 8.434138865532475, 4.4440875964419675],
    );
    let (brute, got) = bvh_answers(&s, ray);
    println!("brute force {}; BVH walks {}", show(&[brute]), show(&got));
    assert_eq!(brute, Some((9, 0x3f7f_fffe)));
    for g in &got {
        assert!(
            *g == brute,
            "the BVH's walks (scalar, then vectorised) answer {}; brute force {}",
            show(&got),
            show(&[brute])
        );
    }
}

/// The documented exception, found by `bvh_traversal_agrees_with_brute_force` with the
/// fresh seed 13 (shrunk): a ray aimed at the edge 3-2 shared by triangles 1 = (1, 2, 3),
/// its reversed copy 10 = (1, 3, 2), and 19 = (0, 3, 2). In f32 they are hit at t =
/// 0x3f800011, 0x3f800010 and 0x3f800000: 19 lies exactly at `tie_limit(t10)` =
/// 0x3f800000 (within the margin of 10), 10 one ulp from 1, but 19 below
/// `tie_limit(t1)` = 0x3f800001 (closer than 1 by more than the margin): a chain of three.
/// Brute force meets 1 first, rejects 10 against it and takes 19, closer by the margin.
/// With the tie rule on divided t the BVH met 19, then 1 (19 closer: kept), then 10
/// (within the margin of 19 and of lower index: taken), and answered 10, a hit brute force
/// never picks. Deciding each pair as brute force does (the later index's intersection
/// test against the earlier's tie limit), 19's own test against `tie_limit(t10)` passes
/// (in `t * |det|` it lies below the limit), so 10 does not displace it: every walk now
/// answers 19, brute force's answer (measured). Chains remain
/// where the module doc of src/cpu/traverse_bvh.rs allows the BVH to differ, and the
/// property counts such rays ([`tie_chain`]) instead of failing. Asserted: brute force's
/// answer, and that each BVH walk gives it or another hit of the chain, as [`tie_chain`]
/// recognises it.
#[test]
fn bvh_tie_chain_is_the_documented_exception() {
    let v = Vec3::new;
    let s = scene_of(
        vec![
            v(1.6623226, -3.0826209, -2.5611625),
            v(3.8368146, -3.002395, 0.1704698),
            v(-0.5, 1.7310702, -0.64373577),
            v(0.73258317, 1.7776021, -1.1254395),
        ],
        24,
        &[
            (1, [1, 2, 3]),
            (4, [1, 3, 0]),
            (10, [1, 3, 2]),
            (18, [1, 1, 1]),
            (19, [0, 3, 2]),
            (20, [0, 2, 0]),
            (23, [0, 2, 2]),
        ],
    );
    let ray = (
        [1.276452788786673, 5.903439863491041, -3.5599252819401075],
        [-0.5438696236179108, -4.1258377869605845, 2.4344857572895338],
    );
    let (brute, got) = bvh_answers(&s, ray);
    println!("brute force {}; BVH walks {}", show(&[brute]), show(&got));
    assert_eq!(brute, Some((19, 0x3f80_0000)));
    let bvh = Bvh::build(&s).unwrap();
    let mut t = Tally::default();
    agree::<f32>(&s, (&bvh).into(), &[ray], &mut t).unwrap();
    for isa in vector_isas() {
        agree_vectorised(&s, &bvh, isa, &[ray], &mut t).unwrap();
    }
    let differ = got.iter().filter(|g| **g != brute).count();
    assert_eq!(t.chains, differ, "{}", show(&got));
}

/// Found by `bvh_traversal_agrees_with_brute_force` with the fresh seed
/// 1796533127666601044 (shrunk): a ray aimed at the edge 1-4 shared by triangles
/// 6 = (2, 1, 4), 9 = (4, 0, 1) (10 and 30 are copies of it, rotated and reversed) and
/// 20 = (3, 4, 1). In f32, 9, 10, 20 and 30 are hit at the same t = 0x3f800001, which is
/// exactly `tie_limit(t6)` (6 is hit at 0x3f800011); the intersection test compares in
/// `t * |det|`, and there 9, 10 and 30 fail against 6's tie limit while 20 passes. So by
/// the rule's own comparison 6 beats 9, 9 beats 20 (same t, lower index) and 20 beats 6:
/// a chain of three, each within the margin of the next, spanning more. Brute force meets
/// 6, rejects 9 and 10 against it and takes 20; the BVH (its leaf order lists 6 and 20
/// before 9) meets 9 last of the three: 20 displaces 6, then 9 (a tie with 20, lower
/// index) displaces 20, and every f32 walk answers 9 (in f64 the BVH gives brute force's
/// answer, asserted below as a control). No order-free answer exists for
/// such a cycle; [`tie_chain`] recognises it only by judging "within the margin" with
/// the intersection test's comparison (by the divided t all five hits lie within it).
#[test]
fn bvh_tie_chain_at_the_margin_is_the_documented_exception() {
    let v = Vec3::new;
    let s = scene_of(
        vec![
            v(0.87019193, -2.9741428, 3.340042),
            v(-4.0, -3.211921, -1.8494841),
            v(2.6331174, -1.8452139, -1.1780137),
            v(-1.3753439, -1.8717312, -0.33658478),
            v(0.61204237, 3.455055, 0.5),
        ],
        33,
        &[
            (6, [2, 1, 4]),
            (9, [4, 0, 1]),
            (10, [1, 4, 0]),
            (14, [2, 2, 4]),
            (18, [0, 0, 1]),
            (19, [3, 4, 0]),
            (20, [3, 4, 1]),
            (21, [0, 3, 0]),
            (26, [0, 0, 4]),
            (27, [1, 0, 0]),
            (28, [4, 0, 0]),
            (30, [4, 1, 0]),
            (32, [1, 0, 0]),
        ],
    );
    let ray = (
        [-2.5324225141032155, 5.11053676337834, 1.0289923695443233],
        [1.2520566755377414, -4.3910680929690535, -1.493030123340683],
    );
    let (brute, got) = bvh_answers(&s, ray);
    println!("brute force {}; BVH walks {}", show(&[brute]), show(&got));
    assert_eq!(brute, Some((20, 0x3f80_0001)));
    let bvh = Bvh::build(&s).unwrap();
    let mut t = Tally::default();
    agree::<f64>(&s, (&bvh).into(), &[ray], &mut t).unwrap();
    assert_eq!(t.chains, 0, "f64 has no chain here");
    agree::<f32>(&s, (&bvh).into(), &[ray], &mut t).unwrap();
    for isa in vector_isas() {
        agree_vectorised(&s, &bvh, isa, &[ray], &mut t).unwrap();
    }
    let differ = got.iter().filter(|g| **g != brute).count();
    assert_eq!(t.chains, differ, "{}", show(&got));
}

/// Thirty zero-area triangles lying on the three edges of one triangle (ten per edge, as
/// (a, a, b)): the default irregular build splits to its depth limit (17 levels, virtual
/// resolution 131072 x 393216 x 131072) and makes 3,129,493 cells in 216 s (measured at
/// 4c4f014, this machine); the uniform grid needs 240. Random meshes with 3-6 vertices
/// and 20-60 triangles did the same on a smaller scale (225,522 cells, 9.7 s for 57
/// triangles). Fixed by splitting only where some child holds fewer triangles than its
/// node: 1,074 cells now. Bound: 64 cells per triangle (bunny.toml's irregular grid has 2.2).
#[test]
fn irregular_build_of_coincident_degenerate_triangles_stays_small() {
    let mut s = Scene::empty(Camera {
        eye: Vec3::new(0.0, 0.0, 10.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
    });
    let m = s.add_material(Material::default());
    s.positions = vec![
        Vec3::new(-0.8702472, 2.868926, 0.059936617),
        Vec3::new(0.79125667, -3.0, -2.0),
        Vec3::new(0.41053656, 2.9636889, -1.5538367),
    ];
    s.triangles = (0..30u32)
        .map(|k| {
            let a = k % 3;
            Triangle {
                v: [a, a, (a + 1) % 3],
                n: [NO_NORMAL; 3],
                material: m,
            }
        })
        .collect();
    let t0 = std::time::Instant::now();
    let g = IrregularGrid::build(&s, &IrregularConfig::default()).unwrap();
    let ms = t0.elapsed().as_secs_f64() * 1e3;
    println!(
        "{} cells, virtual resolution {:?}, {} levels, built in {ms:.0} ms",
        g.cells.len(),
        g.res,
        g.levels.len()
    );
    assert!(
        g.cells.len() <= 64 * s.triangles.len(),
        "{} cells for {} triangles",
        g.cells.len(),
        s.triangles.len()
    );
}
