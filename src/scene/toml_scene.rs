//! Scene files: TOML in, a world-space triangle [`Scene`] out.
//!
//! The format is documented with an example per key in `docs/scene-format.md`. Parsing goes
//! through serde with `deny_unknown_fields` everywhere, so a misspelt key is an error (with
//! the closest known key suggested), not a silently ignored setting. Values that need range
//! checks are read as [`toml::Spanned`] so that every error names the file, the 1-based line
//! and the dotted field, e.g. `scenes/x.toml:12: objects[2].material.ior: ...`.
//!
//! Numbers are read as f64 and narrowed to the f32 the renderers use only after checking that
//! they are finite, because TOML accepts `nan` and `inf` literals and 1e39 overflows f32.

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::rc::Rc;

use glam::{DMat3, DVec3, Vec2, Vec3};
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;
use toml::Spanned;

use super::obj::{load_obj, ObjMesh};
use super::shapes::{self, MAX_SPHERE_SUBDIVISIONS};
use super::{Camera, Checker, CheckerAxes, Material, Scene, Triangle, NO_NORMAL};
use crate::{Error, Result};

/// The built-in scene (a homage to Whitted's 1980 image), used when no scene file is given.
pub const DEFAULT_SCENE_TOML: &str = include_str!("../../scenes/whitted.toml");

/// The [`Scene::source`] of [`builtin_scene`].
pub const BUILTIN_SCENE_NAME: &str = "<builtin:whitted>";

/// Environment variable holding extra mesh folders, colon-separated.
pub const MODEL_PATH_VAR: &str = "FRAGTRACE_MODEL_PATH";

/// Largest accepted `max_depth`.
pub const MAX_DEPTH_LIMIT: u32 = 16;

/// Largest accepted image width or height: far beyond any sensible render, small enough
/// that width·height·16 bytes of radiance cannot overflow or exhaust memory silently.
pub const MAX_IMAGE_SIZE: u32 = 16_384;

/// Largest scene file read; scenes are short, so anything bigger is a wrong path.
pub const MAX_SCENE_BYTES: u64 = 16 << 20;

/// Default sphere subdivision level (1,280 triangles, smooth enough with vertex normals).
pub const DEFAULT_SPHERE_SUBDIVISIONS: u32 = 3;

/// Loads a scene file; meshes resolve against its folder, then [`model_search_path`].
pub fn load_scene(path: &Path) -> Result<Scene> {
    load_scene_with_search_path(path, &model_search_path())
}

/// [`load_scene`] with an explicit mesh search path instead of `FRAGTRACE_MODEL_PATH`.
pub fn load_scene_with_search_path(path: &Path, search: &[PathBuf]) -> Result<Scene> {
    let bytes = super::read_input_file(path, MAX_SCENE_BYTES, "scene file")?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        Error::scene(
            path.display().to_string(),
            line,
            "",
            "invalid UTF-8 (a TOML scene must be UTF-8 text)",
        )
    })?;
    let base = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    load_scene_str_with_search_path(&text, &path.display().to_string(), base, search)
}

/// Parses scene text. `name` is used in messages and as [`Scene::source`]; relative mesh
/// paths resolve against `base_dir`, then [`model_search_path`].
pub fn load_scene_str(text: &str, name: &str, base_dir: &Path) -> Result<Scene> {
    load_scene_str_with_search_path(text, name, base_dir, &model_search_path())
}

/// [`load_scene_str`] with an explicit mesh search path instead of `FRAGTRACE_MODEL_PATH`.
/// Non-fatal mesh problems (e.g. an unreadable MTL) are reported on stderr, one line each.
pub fn load_scene_str_with_search_path(
    text: &str,
    name: &str,
    base_dir: &Path,
    search: &[PathBuf],
) -> Result<Scene> {
    build_scene(text, name, Some((base_dir, search)))
}

/// Parses scene text without touching the file system: any `mesh = ...` is an error naming
/// the object. For fuzzing and for checking a scene's syntax and values.
pub fn parse_scene_str(text: &str, name: &str) -> Result<Scene> {
    build_scene(text, name, None)
}

/// The loader proper; `files` is where meshes are looked up, `None` to refuse them.
fn build_scene(text: &str, name: &str, files: Option<(&Path, &[PathBuf])>) -> Result<Scene> {
    let ctx = Ctx { name, text };
    let def: SceneDef = toml::from_str(text).map_err(|e| ctx.toml_error(&e))?;
    let mut builder = Builder {
        ctx,
        files,
        scene: Scene::empty(Camera {
            eye: Vec3::ZERO,
            look_at: Vec3::NEG_Z,
            up: Vec3::Y,
            vfov_deg: 45.0,
        }),
        named: HashMap::new(),
        default_material: None,
        meshes: HashMap::new(),
        warnings: Vec::new(),
    };
    builder.scene.source = name.to_owned();
    builder.build(def)?;
    for w in &builder.warnings {
        eprintln!("fragtrace: warning: {w}");
    }
    let scene = builder.scene;
    scene.validate()?;
    Ok(scene)
}

/// The built-in Whitted scene ([`DEFAULT_SCENE_TOML`]).
///
/// # Panics
/// Only if the embedded file is broken, which a unit test rules out.
pub fn builtin_scene() -> Scene {
    load_scene_str_with_search_path(DEFAULT_SCENE_TOML, BUILTIN_SCENE_NAME, Path::new("."), &[])
        .unwrap_or_else(|e| panic!("the embedded default scene is invalid: {e}"))
}

/// The folders listed in `FRAGTRACE_MODEL_PATH` (colon-separated, empty entries skipped), in
/// order; empty when the variable is unset.
pub fn model_search_path() -> Vec<PathBuf> {
    std::env::var_os(MODEL_PATH_VAR)
        .map(|v| {
            std::env::split_paths(&v)
                .filter(|p| !p.as_os_str().is_empty())
                .collect()
        })
        .unwrap_or_default()
}

// ---------------------------------------------------------------------------------------
// The file format, as serde sees it. Optional keys are `Option` (defaults applied while
// building) so that a present key keeps its span for error messages.

type S<T> = Spanned<T>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneDef {
    camera: S<CameraDef>,
    image: Option<ImageDef>,
    background: Option<S<[f64; 3]>>,
    ambient: Option<S<[f64; 3]>>,
    max_depth: Option<S<i64>>,
    #[serde(default)]
    lights: Vec<S<LightDef>>,
    #[serde(default)]
    materials: BTreeMap<String, MaterialDef>,
    #[serde(default)]
    objects: Vec<S<ObjectDef>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDef {
    eye: S<[f64; 3]>,
    look_at: S<[f64; 3]>,
    up: Option<S<[f64; 3]>>,
    fov: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ImageDef {
    width: Option<S<i64>>,
    height: Option<S<i64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightDef {
    position: S<[f64; 3]>,
    color: Option<S<[f64; 3]>>,
    intensity: Option<S<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialDef {
    albedo: Option<S<[f64; 3]>>,
    ka: Option<S<f64>>,
    kd: Option<S<f64>>,
    ks: Option<S<[f64; 3]>>,
    ns: Option<S<f64>>,
    kr: Option<S<[f64; 3]>>,
    kt: Option<S<[f64; 3]>>,
    ior: Option<S<f64>>,
    fresnel: Option<bool>,
    checker: Option<S<CheckerDef>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CheckerDef {
    a: S<[f64; 3]>,
    b: S<[f64; 3]>,
    scale: Option<S<f64>>,
    axes: Option<CheckerAxes>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObjectDef {
    mesh: Option<S<String>>,
    shape: Option<S<ShapeKind>>,
    subdivisions: Option<S<i64>>,
    radius: Option<S<f64>>,
    size: Option<S<Numbers>>,
    material: Option<S<MaterialRef>>,
    translate: Option<S<[f64; 3]>>,
    rotate: Option<S<[f64; 3]>>,
    scale: Option<S<Numbers>>,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Eq, Debug)]
#[serde(rename_all = "lowercase")]
enum ShapeKind {
    Sphere,
    Quad,
    Box,
}

impl fmt::Display for ShapeKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ShapeKind::Sphere => "sphere",
            ShapeKind::Quad => "quad",
            ShapeKind::Box => "box",
        })
    }
}

/// A number or an array of numbers (`scale = 2` or `scale = [1, 2, 1]`); the length is
/// checked where the meaning is known.
enum Numbers {
    One(f64),
    Many(Vec<f64>),
}

impl<'de> Deserialize<'de> for Numbers {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Numbers;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an array of numbers")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> std::result::Result<Numbers, E> {
                Ok(Numbers::One(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<Numbers, E> {
                Ok(Numbers::One(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<Numbers, E> {
                Ok(Numbers::One(v as f64))
            }
            fn visit_seq<A: SeqAccess<'de>>(
                self,
                mut s: A,
            ) -> std::result::Result<Numbers, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = s.next_element::<f64>()? {
                    v.push(x);
                }
                Ok(Numbers::Many(v))
            }
        }
        d.deserialize_any(V)
    }
}

/// `material = "name"` or an inline material table. Hand-written rather than
/// `#[serde(untagged)]` so that an unknown key inside the inline table is reported as such
/// instead of "data did not match any variant".
enum MaterialRef {
    Named(String),
    Inline(Box<MaterialDef>),
}

impl<'de> Deserialize<'de> for MaterialRef {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = MaterialRef;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a material name or an inline material table")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> std::result::Result<MaterialRef, E> {
                Ok(MaterialRef::Named(v.to_owned()))
            }
            fn visit_map<A: MapAccess<'de>>(
                self,
                m: A,
            ) -> std::result::Result<MaterialRef, A::Error> {
                MaterialDef::deserialize(de::value::MapAccessDeserializer::new(m))
                    .map(|d| MaterialRef::Inline(Box::new(d)))
            }
        }
        d.deserialize_any(V)
    }
}

// ---------------------------------------------------------------------------------------
// Error reporting.

/// The file being loaded, for turning byte spans into line numbers.
#[derive(Clone, Copy)]
struct Ctx<'a> {
    name: &'a str,
    text: &'a str,
}

impl Ctx<'_> {
    fn line_of(&self, offset: usize) -> usize {
        let end = offset.min(self.text.len());
        self.text.as_bytes()[..end]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1
    }

    fn err(
        &self,
        span: Range<usize>,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Error {
        Error::scene(self.name, self.line_of(span.start), field, message)
    }

    /// A parse/type error from toml, with the field located from its span and a "did you
    /// mean" hint for unknown keys and values.
    fn toml_error(&self, e: &toml::de::Error) -> Error {
        let (line, field) = match e.span() {
            Some(s) => (self.line_of(s.start), field_at(self.text, s.start)),
            None => (0, String::new()),
        };
        Error::scene(self.name, line, field, improve_message(e.message()))
    }

    fn finite(&self, v: &S<f64>, field: &str) -> Result<f32> {
        let x = *v.get_ref();
        let y = x as f32;
        if !y.is_finite() {
            return Err(self.err(v.span(), field, format!("must be a finite number, got {x}")));
        }
        Ok(y)
    }

    /// A finite scalar satisfying `ok`, else an error saying `expect`.
    fn scalar(
        &self,
        v: &S<f64>,
        field: &str,
        ok: impl Fn(f64) -> bool,
        expect: &str,
    ) -> Result<f32> {
        let y = self.finite(v, field)?;
        if !ok(*v.get_ref()) {
            return Err(self.err(v.span(), field, format!("{expect}, got {}", v.get_ref())));
        }
        Ok(y)
    }

    fn vec3(&self, v: &S<[f64; 3]>, field: &str) -> Result<Vec3> {
        let a = v.get_ref();
        let f = Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
        if !f.is_finite() {
            return Err(self.err(v.span(), field, format!("must be finite, got {a:?}")));
        }
        Ok(f)
    }

    fn color(&self, v: &S<[f64; 3]>, field: &str) -> Result<Vec3> {
        let c = self.vec3(v, field)?;
        if c.min_element() < 0.0 {
            return Err(self.err(
                v.span(),
                field,
                format!("colour components must be >= 0, got {:?}", v.get_ref()),
            ));
        }
        Ok(c)
    }

    fn opt_color(&self, v: &Option<S<[f64; 3]>>, field: &str, default: Vec3) -> Result<Vec3> {
        v.as_ref().map_or(Ok(default), |v| self.color(v, field))
    }

    fn integer(
        &self,
        v: &S<i64>,
        field: &str,
        range: std::ops::RangeInclusive<i64>,
        why: &str,
    ) -> Result<u32> {
        let x = *v.get_ref();
        if !range.contains(&x) {
            return Err(self.err(
                v.span(),
                field,
                format!("{x} is outside {}..={}{why}", range.start(), range.end()),
            ));
        }
        Ok(x as u32)
    }
}

/// Rewrites serde's "unknown field/variant" messages into "unknown key ...; did you mean".
fn improve_message(msg: &str) -> String {
    // toml's messages can span lines ("invalid array\nexpected `]`"); errors are one line.
    let joined = msg
        .trim()
        .lines()
        .map(str::trim)
        .collect::<Vec<_>>()
        .join(": ");
    let msg = joined.as_str();
    for (prefix, what) in [("unknown field `", "key"), ("unknown variant `", "value")] {
        let Some(rest) = msg.strip_prefix(prefix) else {
            continue;
        };
        let Some((bad, tail)) = rest.split_once('`') else {
            continue;
        };
        let known: Vec<&str> = tail.split('`').skip(1).step_by(2).collect();
        let hint = closest(bad, &known)
            .map(|k| format!("; did you mean `{k}`?"))
            .unwrap_or_default();
        let list = if known.is_empty() {
            " (no keys are allowed here)".to_owned()
        } else {
            format!(
                " (expected one of {})",
                known
                    .iter()
                    .map(|k| format!("`{k}`"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        };
        return format!("unknown {what} `{bad}`{hint}{list}");
    }
    msg.to_owned()
}

/// The candidate nearest to `word` by edit distance (with transpositions), if it is near
/// enough to be a plausible typo.
fn closest<'a>(word: &str, candidates: &[&'a str]) -> Option<&'a str> {
    let limit = (word.chars().count() / 3).max(1);
    candidates
        .iter()
        .map(|c| (edit_distance(&word.to_lowercase(), &c.to_lowercase()), *c))
        .filter(|&(d, _)| d <= limit)
        .min_by_key(|&(d, _)| d)
        .map(|(_, c)| c)
}

/// Optimal-string-alignment distance: Levenshtein plus adjacent transpositions, so that
/// `fvo` is one edit from `fov`.
fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    let mut d = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in d.iter_mut().enumerate() {
        row[0] = i;
    }
    d[0] = (0..=b.len()).collect();
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            d[i][j] = (d[i - 1][j] + 1)
                .min(d[i][j - 1] + 1)
                .min(d[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                d[i][j] = d[i][j].min(d[i - 2][j - 2] + 1);
            }
        }
    }
    d[a.len()][b.len()]
}

/// The dotted field path (`objects[2].material.ior`) at byte `offset` of a TOML document.
///
/// toml's errors carry a span but no key path, so this re-lexes the document up to the
/// offset: table headers (counting `[[array]]` entries), keys, inline tables and strings.
/// It only has to be right for the documents the scene schema accepts.
fn field_at(text: &str, offset: usize) -> String {
    let bytes = text.as_bytes();
    let offset = offset.min(bytes.len());
    let mut header = String::new();
    let mut aot_count: HashMap<String, usize> = HashMap::new();
    // Keys of the enclosing inline tables, and the key whose value is being read.
    let mut stack: Vec<String> = Vec::new();
    let mut key: Option<String> = None;
    let mut brackets = 0usize;
    let mut expect_key = true;
    let mut line_start = true;
    let is_key_char = |c: u8| c.is_ascii_alphanumeric() || c == b'_' || c == b'-' || c == b'.';
    let mut i = 0;
    let read_key = |i: usize| -> (String, usize) {
        let mut j = i;
        while j < bytes.len() && (is_key_char(bytes[j]) || bytes[j] == b'"') {
            j += 1;
        }
        (text[i..j].replace('"', ""), j)
    };
    let parse_header =
        |i: usize, aot_count: &mut HashMap<String, usize>, count: bool| -> (String, usize) {
            let double = bytes.get(i + 1) == Some(&b'[');
            let start = if double { i + 2 } else { i + 1 };
            let end = text[start..].find(']').map_or(bytes.len(), |e| start + e);
            let name: String = text[start..end].trim().replace(['"', ' '], "");
            let next = text[end..].find('\n').map_or(bytes.len(), |e| end + e);
            if double {
                let n = aot_count.entry(name.clone()).or_insert(0);
                if count {
                    *n += 1;
                }
                (format!("{name}[{}]", n.saturating_sub(1)), next)
            } else {
                (name, next)
            }
        };
    let join = |header: &str, stack: &[String], last: Option<&str>| -> String {
        let mut parts: Vec<&str> = Vec::new();
        if !header.is_empty() {
            parts.push(header);
        }
        parts.extend(stack.iter().map(String::as_str));
        parts.extend(last);
        parts.join(".")
    };
    while i < bytes.len() {
        let c = bytes[i];
        if i >= offset {
            if line_start && brackets == 0 && stack.is_empty() && c == b'[' {
                return parse_header(i, &mut aot_count, true).0;
            }
            if expect_key && is_key_char(c) {
                return join(&header, &stack, Some(&read_key(i).0));
            }
            return join(&header, &stack, key.as_deref());
        }
        match c {
            b'\n' => {
                if brackets == 0 && stack.is_empty() {
                    expect_key = true;
                    key = None;
                }
                line_start = true;
                i += 1;
                continue;
            }
            b' ' | b'\t' | b'\r' => {
                i += 1;
                continue;
            }
            b'#' => {
                i = text[i..].find('\n').map_or(bytes.len(), |e| i + e);
                continue;
            }
            b'"' | b'\'' if !expect_key => {
                // Skip a string value, honouring escapes in basic strings.
                let mut j = i + 1;
                while j < bytes.len() && bytes[j] != c && bytes[j] != b'\n' {
                    j += if c == b'"' && bytes[j] == b'\\' { 2 } else { 1 };
                }
                i = j + 1;
            }
            b'[' if line_start && brackets == 0 && stack.is_empty() => {
                let (h, next) = parse_header(i, &mut aot_count, true);
                header = h;
                key = None;
                i = next;
                line_start = false;
                continue;
            }
            b'[' => {
                brackets += 1;
                i += 1;
            }
            b']' => {
                brackets = brackets.saturating_sub(1);
                i += 1;
            }
            b'{' => {
                stack.extend(key.take());
                expect_key = true;
                i += 1;
            }
            b'}' => {
                key = stack.pop();
                expect_key = false;
                i += 1;
            }
            b',' if !stack.is_empty() && brackets == 0 => {
                expect_key = true;
                i += 1;
            }
            b'=' => {
                expect_key = false;
                i += 1;
            }
            _ if expect_key && (is_key_char(c) || c == b'"') => {
                let (k, next) = read_key(i);
                key = Some(k);
                i = next;
            }
            _ => i += 1,
        }
        line_start = false;
    }
    join(&header, &stack, key.as_deref())
}

// ---------------------------------------------------------------------------------------
// Building the scene.

/// Object-space geometry before placement; triangle materials are local indices.
struct Geometry {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    triangles: Vec<Triangle>,
}

impl Geometry {
    fn flat(positions: Vec<Vec3>, tris: Vec<[u32; 3]>) -> Self {
        let triangles = tris
            .into_iter()
            .map(|v| Triangle {
                v,
                n: [NO_NORMAL; 3],
                material: 0,
            })
            .collect();
        Geometry {
            positions,
            normals: Vec::new(),
            triangles,
        }
    }

    fn smooth(positions: Vec<Vec3>, normals: Vec<Vec3>, tris: Vec<[u32; 3]>) -> Self {
        let triangles = tris
            .into_iter()
            .map(|v| Triangle {
                v,
                n: v,
                material: 0,
            })
            .collect();
        Geometry {
            positions,
            normals,
            triangles,
        }
    }
}

/// An affine placement: `p' = linear·p + translate`, normals by the inverse transpose.
#[derive(Clone, Copy, Debug)]
struct Placement {
    linear: DMat3,
    translate: DVec3,
}

impl Placement {
    /// Scale first, then rotate about X, then Y, then Z (degrees), then translate.
    fn new(scale: DVec3, rotate_deg: DVec3, translate: DVec3) -> Self {
        let r = DMat3::from_rotation_z(rotate_deg.z.to_radians())
            * DMat3::from_rotation_y(rotate_deg.y.to_radians())
            * DMat3::from_rotation_x(rotate_deg.x.to_radians());
        Placement {
            linear: r * DMat3::from_diagonal(scale),
            translate,
        }
    }

    fn point(&self, p: Vec3) -> Vec3 {
        (self.linear * p.as_dvec3() + self.translate).as_vec3()
    }

    /// Transforms geometry in place. A mirroring transform (negative determinant) would turn
    /// triangles inside out, so their winding is reversed to keep geometric normals outward.
    fn apply(&self, g: &mut Geometry) {
        let normal_matrix = self.linear.inverse().transpose();
        for p in &mut g.positions {
            *p = self.point(*p);
        }
        for n in &mut g.normals {
            // Unit input and a non-singular matrix give a non-zero result.
            *n = (normal_matrix * n.as_dvec3()).normalize().as_vec3();
        }
        if self.linear.determinant() < 0.0 {
            for t in &mut g.triangles {
                t.v.swap(1, 2);
                t.n.swap(1, 2);
            }
        }
    }
}

/// A loaded mesh and the resolved path it is cached under.
type LoadedMesh = (Rc<ObjMesh>, PathBuf);

struct Builder<'a> {
    ctx: Ctx<'a>,
    /// The scene's folder and the mesh search path; `None` when no file may be read.
    files: Option<(&'a Path, &'a [PathBuf])>,
    scene: Scene,
    /// Named material → index in `scene.materials`.
    named: HashMap<String, u32>,
    default_material: Option<u32>,
    /// Resolved mesh path → mesh, and the index of its first MTL material once added.
    meshes: HashMap<PathBuf, (Rc<ObjMesh>, Option<u32>)>,
    warnings: Vec<String>,
}

impl Builder<'_> {
    fn build(&mut self, def: SceneDef) -> Result<()> {
        let ctx = self.ctx;
        self.camera(&def.camera)?;
        if let Some(img) = &def.image {
            let why = format!(" (image sizes are 1..={MAX_IMAGE_SIZE} pixels)");
            let max = MAX_IMAGE_SIZE as i64;
            if let Some(w) = &img.width {
                self.scene.width = ctx.integer(w, "image.width", 1..=max, &why)?;
            }
            if let Some(h) = &img.height {
                self.scene.height = ctx.integer(h, "image.height", 1..=max, &why)?;
            }
        } else {
            self.scene.width = 640;
            self.scene.height = 480;
        }
        self.scene.background =
            ctx.opt_color(&def.background, "background", Vec3::new(0.1, 0.3, 0.8))?;
        self.scene.ambient = ctx.opt_color(&def.ambient, "ambient", Vec3::splat(0.1))?;
        self.scene.max_depth = match &def.max_depth {
            Some(d) => ctx.integer(d, "max_depth", 0..=MAX_DEPTH_LIMIT as i64, "")?,
            None => 5,
        };
        for (i, l) in def.lights.iter().enumerate() {
            let f = format!("lights[{i}]");
            let intensity = match &l.get_ref().intensity {
                Some(v) => {
                    ctx.scalar(v, &format!("{f}.intensity"), |x| x >= 0.0, "must be >= 0")?
                }
                None => 1.0,
            };
            self.scene.lights.push(super::Light {
                position: ctx.vec3(&l.get_ref().position, &format!("{f}.position"))?,
                color: ctx.opt_color(&l.get_ref().color, &format!("{f}.color"), Vec3::ONE)?,
                intensity,
            });
        }
        // Named materials first, in name order, so their indices do not depend on which
        // object happens to use them first.
        for (name, m) in &def.materials {
            let mat = self.material(m, name.clone(), &format!("materials.{name}"))?;
            let idx = self.scene.add_material(mat);
            self.named.insert(name.clone(), idx);
        }
        for (i, o) in def.objects.iter().enumerate() {
            self.object(i, o)?;
        }
        Ok(())
    }

    fn camera(&mut self, c: &S<CameraDef>) -> Result<()> {
        let ctx = self.ctx;
        let d = c.get_ref();
        let eye = ctx.vec3(&d.eye, "camera.eye")?;
        let look_at = ctx.vec3(&d.look_at, "camera.look_at")?;
        let up = match &d.up {
            Some(u) => ctx.vec3(u, "camera.up")?,
            None => Vec3::Y,
        };
        let fov = ctx.scalar(
            &d.fov,
            "camera.fov",
            |x| x > 0.0 && x < 180.0,
            "vertical field of view must be in (0, 180) degrees",
        )?;
        let cam = Camera {
            eye,
            look_at,
            up,
            vfov_deg: fov,
        };
        let forward = (look_at - eye).as_dvec3();
        if forward.length() == 0.0 {
            return Err(ctx.err(
                d.look_at.span(),
                "camera.look_at",
                "equals camera.eye; the camera has no viewing direction",
            ));
        }
        if forward.normalize().cross(up.as_dvec3()).length() < 1e-6 {
            let (span, field) = match &d.up {
                Some(u) => (u.span(), "camera.up"),
                None => (d.look_at.span(), "camera.look_at"),
            };
            return Err(ctx.err(
                span,
                field,
                format!(
                    "up {up} is parallel to the viewing direction {}; choose another `up`",
                    forward.normalize().as_vec3()
                ),
            ));
        }
        // Camera::check is the renderers' contract; keep it authoritative.
        cam.check().map_err(|m| ctx.err(c.span(), "camera", m))?;
        self.scene.camera = cam;
        Ok(())
    }

    fn material(&self, m: &MaterialDef, name: String, field: &str) -> Result<Material> {
        let ctx = self.ctx;
        let f = |k: &str| format!("{field}.{k}");
        let nonneg = |v: &Option<S<f64>>, k: &str, default: f32| -> Result<f32> {
            v.as_ref().map_or(Ok(default), |v| {
                ctx.scalar(v, &f(k), |x| x >= 0.0, "must be >= 0")
            })
        };
        let checker = match &m.checker {
            Some(c) => {
                let c = c.get_ref();
                Some(Checker {
                    color_a: ctx.color(&c.a, &f("checker.a"))?,
                    color_b: ctx.color(&c.b, &f("checker.b"))?,
                    scale: match &c.scale {
                        Some(s) => {
                            ctx.scalar(s, &f("checker.scale"), |x| x > 0.0, "must be > 0")?
                        }
                        None => 1.0,
                    },
                    axes: c.axes.unwrap_or(CheckerAxes::Xz),
                })
            }
            None => None,
        };
        Ok(Material {
            name,
            albedo: ctx.opt_color(&m.albedo, &f("albedo"), Vec3::splat(0.8))?,
            checker,
            ka: nonneg(&m.ka, "ka", 1.0)?,
            kd: nonneg(&m.kd, "kd", 1.0)?,
            ks: ctx.opt_color(&m.ks, &f("ks"), Vec3::ZERO)?,
            ns: match &m.ns {
                Some(v) => ctx.scalar(v, &f("ns"), |x| x >= 1.0, "Phong exponent must be >= 1")?,
                None => 32.0,
            },
            kr: ctx.opt_color(&m.kr, &f("kr"), Vec3::ZERO)?,
            kt: ctx.opt_color(&m.kt, &f("kt"), Vec3::ZERO)?,
            ior: match &m.ior {
                Some(v) => {
                    ctx.scalar(v, &f("ior"), |x| x > 0.0, "index of refraction must be > 0")?
                }
                None => 1.0,
            },
            fresnel: m.fresnel.unwrap_or(false),
        })
    }

    fn default_material(&mut self) -> u32 {
        if let Some(i) = self.default_material {
            return i;
        }
        let i = self.scene.add_material(Material::default());
        self.default_material = Some(i);
        i
    }

    /// The scene material index an object's `material` key names or defines.
    fn object_material(&mut self, m: &S<MaterialRef>, field: &str) -> Result<u32> {
        match m.get_ref() {
            MaterialRef::Named(name) => self.named.get(name).copied().ok_or_else(|| {
                let known: Vec<&str> = self.named.keys().map(String::as_str).collect();
                let hint = closest(name, &known)
                    .map(|k| format!("; did you mean `{k}`?"))
                    .unwrap_or_default();
                let listing = if known.is_empty() {
                    " (no [materials.NAME] tables are defined)".to_owned()
                } else {
                    let mut k = known.clone();
                    k.sort_unstable();
                    format!(" (defined: {})", k.join(", "))
                };
                self.ctx.err(
                    m.span(),
                    field,
                    format!("undefined material `{name}`{hint}{listing}"),
                )
            }),
            MaterialRef::Inline(def) => {
                let mat = self.material(def, field.to_owned(), field)?;
                Ok(self.scene.add_material(mat))
            }
        }
    }

    fn object(&mut self, i: usize, o: &S<ObjectDef>) -> Result<()> {
        let ctx = self.ctx;
        let f = |k: &str| format!("objects[{i}].{k}");
        let d = o.get_ref();

        // Keys that only make sense for some kinds of object.
        let kind = d.shape.as_ref().map(|s| *s.get_ref());
        let only_for =
            |key: &str, span: Option<Range<usize>>, allowed: &[ShapeKind]| -> Result<()> {
                match span {
                    Some(span) if !kind.is_some_and(|k| allowed.contains(&k)) => {
                        let shapes: Vec<String> =
                            allowed.iter().map(|s| format!("shape = \"{s}\"")).collect();
                        Err(ctx.err(
                            span,
                            f(key),
                            format!("`{key}` applies only to {}", shapes.join(" or ")),
                        ))
                    }
                    _ => Ok(()),
                }
            };
        only_for(
            "subdivisions",
            d.subdivisions.as_ref().map(|s| s.span()),
            &[ShapeKind::Sphere],
        )?;
        only_for(
            "radius",
            d.radius.as_ref().map(|s| s.span()),
            &[ShapeKind::Sphere],
        )?;
        only_for(
            "size",
            d.size.as_ref().map(|s| s.span()),
            &[ShapeKind::Quad, ShapeKind::Box],
        )?;

        let (mut geometry, mesh_materials) = match (&d.mesh, &d.shape) {
            (Some(path), None) if d.material.is_none() => {
                let (mesh, _) = self.mesh(path, &f("mesh"))?;
                // Without an override the MTL decides how the mesh looks: a missing one is
                // an error, not a silently grey mesh.
                if let Some(problem) = mesh.missing_mtl.first() {
                    return Err(ctx.err(
                        path.span(),
                        f("mesh"),
                        format!(
                            "{problem}; fix the mtllib, or set `material = \"NAME\"` on this \
                             object to render the mesh without its MTL"
                        ),
                    ));
                }
                self.mesh_geometry(path, &f("mesh"))?
            }
            (Some(_), Some(s)) => {
                return Err(ctx.err(
                    s.span(),
                    f("shape"),
                    "an object has either `mesh` or `shape`, not both",
                ));
            }
            (None, None) => {
                return Err(ctx.err(o.span(), format!("objects[{i}]"), "an object needs `mesh = \"file.obj\"` or `shape = \"sphere\" | \"quad\" | \"box\"`"));
            }
            (Some(path), None) => self.mesh_geometry(path, &f("mesh"))?,
            (None, Some(s)) => (self.shape(*s.get_ref(), d, &f)?, None),
        };

        let scale = match &d.scale {
            None => DVec3::ONE,
            Some(s) => {
                let v = numbers(ctx, s, &f("scale"), 3)?;
                if v.contains(&0.0) {
                    return Err(ctx.err(s.span(), f("scale"), "scale factors must be non-zero (a flat object has no inside and its normals are undefined)"));
                }
                DVec3::from_array([v[0], v[1], v[2]])
            }
        };
        let rotate = match &d.rotate {
            Some(r) => ctx.vec3(r, &f("rotate"))?.as_dvec3(),
            None => DVec3::ZERO,
        };
        let translate = match &d.translate {
            Some(t) => ctx.vec3(t, &f("translate"))?.as_dvec3(),
            None => DVec3::ZERO,
        };
        let placement = Placement::new(scale, rotate, translate);
        placement.apply(&mut geometry);
        if let Some(p) = geometry.positions.iter().find(|p| !p.is_finite()) {
            return Err(ctx.err(
                o.span(),
                format!("objects[{i}]"),
                format!(
                    "a transformed vertex is not finite ({p}); scale or translate is too large"
                ),
            ));
        }

        // Material indices: an override replaces everything; a mesh otherwise brings its
        // MTL materials (added once per mesh file); a shape without one is default grey.
        let material_map: Box<dyn Fn(u32) -> u32> = match (&d.material, mesh_materials) {
            (Some(m), _) => {
                let idx = self.object_material(m, &f("material"))?;
                Box::new(move |_| idx)
            }
            (None, Some((mesh, key))) => {
                let base = match self.meshes.get(&key).and_then(|e| e.1) {
                    Some(b) => b,
                    None => {
                        let b = self.scene.materials.len() as u32;
                        self.scene.materials.extend(mesh.materials.iter().cloned());
                        if let Some(e) = self.meshes.get_mut(&key) {
                            e.1 = Some(b);
                        }
                        b
                    }
                };
                Box::new(move |m| base + m)
            }
            (None, None) => {
                let idx = self.default_material();
                Box::new(move |_| idx)
            }
        };
        self.append(geometry, &*material_map, o.span(), i)
    }

    fn shape(
        &self,
        kind: ShapeKind,
        d: &ObjectDef,
        f: &dyn Fn(&str) -> String,
    ) -> Result<Geometry> {
        let ctx = self.ctx;
        Ok(match kind {
            ShapeKind::Sphere => {
                let n = match &d.subdivisions {
                    Some(s) => ctx.integer(
                        s,
                        &f("subdivisions"),
                        0..=MAX_SPHERE_SUBDIVISIONS as i64,
                        &format!(
                            " (level {MAX_SPHERE_SUBDIVISIONS} is already {} triangles)",
                            shapes::sphere_triangle_count(MAX_SPHERE_SUBDIVISIONS)
                        ),
                    )?,
                    None => DEFAULT_SPHERE_SUBDIVISIONS,
                };
                let r = match &d.radius {
                    Some(r) => ctx.scalar(r, &f("radius"), |x| x > 0.0, "must be > 0")?,
                    None => 1.0,
                };
                let (p, n, t) = shapes::sphere(n);
                // Scaling a unit sphere uniformly leaves its normals unchanged.
                Geometry::smooth(p.into_iter().map(|p| p * r).collect(), n, t)
            }
            ShapeKind::Quad => {
                let size = match &d.size {
                    Some(s) => {
                        let v = numbers(ctx, s, &f("size"), 2)?;
                        positive(ctx, s, &f("size"), &v)?;
                        Vec2::new(v[0] as f32, v[1] as f32)
                    }
                    None => Vec2::ONE,
                };
                let (p, t) = shapes::quad(size.x, size.y);
                Geometry::flat(p, t)
            }
            ShapeKind::Box => {
                let size = match &d.size {
                    Some(s) => {
                        let v = numbers(ctx, s, &f("size"), 3)?;
                        positive(ctx, s, &f("size"), &v)?;
                        Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
                    }
                    None => Vec3::ONE,
                };
                let (p, t) = shapes::cuboid(size);
                Geometry::flat(p, t)
            }
        })
    }

    /// The mesh an object names, as geometry to place, and the mesh with its path key.
    fn mesh_geometry(
        &mut self,
        path: &S<String>,
        field: &str,
    ) -> Result<(Geometry, Option<LoadedMesh>)> {
        let (mesh, path_key) = self.mesh(path, field)?;
        let g = Geometry {
            positions: mesh.positions.clone(),
            normals: mesh.normals.clone(),
            triangles: mesh.triangles.clone(),
        };
        Ok((g, Some((mesh, path_key))))
    }

    /// Resolves and loads (once per file) the mesh an object names.
    fn mesh(&mut self, path: &S<String>, field: &str) -> Result<(Rc<ObjMesh>, PathBuf)> {
        let written = path.get_ref();
        let Some((base_dir, search)) = self.files else {
            return Err(self.ctx.err(
                path.span(),
                field,
                "mesh files are not read by this text-only parser",
            ));
        };
        let found = resolve_mesh(written, base_dir, search).map_err(|searched| {
            let line = self.ctx.line_of(path.span().start);
            let list: Vec<String> = searched
                .iter()
                .map(|p| match std::fs::metadata(p) {
                    Ok(m) if m.is_dir() => format!("{} (a directory)", p.display()),
                    Ok(_) => format!("{} (not a regular file)", p.display()),
                    Err(_) => p.display().to_string(),
                })
                .collect();
            Error::Mesh {
                file: written.clone(),
                message: format!(
                    "mesh not found (referenced by {field} at {}:{line}); searched: {}; \
                     set {MODEL_PATH_VAR} to the folder that holds it",
                    self.ctx.name,
                    list.join(", ")
                ),
            }
        })?;
        if let Some((m, _)) = self.meshes.get(&found) {
            return Ok((m.clone(), found));
        }
        let mesh = Rc::new(load_obj(&found)?);
        self.warnings.extend(mesh.warnings.iter().cloned());
        self.meshes.insert(found.clone(), (mesh.clone(), None));
        Ok((mesh, found))
    }

    fn append(
        &mut self,
        g: Geometry,
        material: &dyn Fn(u32) -> u32,
        span: Range<usize>,
        i: usize,
    ) -> Result<()> {
        let s = &mut self.scene;
        let vbase = s.positions.len();
        let nbase = s.normals.len();
        if vbase + g.positions.len() > u32::MAX as usize
            || nbase + g.normals.len() >= u32::MAX as usize
        {
            return Err(self.ctx.err(
                span,
                format!("objects[{i}]"),
                "the scene exceeds 2^32 vertices",
            ));
        }
        let (vbase, nbase) = (vbase as u32, nbase as u32);
        s.positions.extend(g.positions);
        s.normals.extend(g.normals);
        s.triangles
            .extend(g.triangles.into_iter().map(|t| Triangle {
                v: t.v.map(|v| v + vbase),
                n: if t.has_normals() {
                    t.n.map(|n| n + nbase)
                } else {
                    [NO_NORMAL; 3]
                },
                material: material(t.material),
            }));
        Ok(())
    }
}

/// `scale`/`size` values: one number (used for every axis) or exactly `len` numbers, finite.
fn numbers(ctx: Ctx, v: &S<Numbers>, field: &str, len: usize) -> Result<Vec<f64>> {
    let out = match v.get_ref() {
        Numbers::One(x) => vec![*x; len],
        Numbers::Many(xs) if xs.len() == len => xs.clone(),
        Numbers::Many(xs) => {
            return Err(ctx.err(
                v.span(),
                field,
                format!("expected a number or {len} numbers, got {}", xs.len()),
            ));
        }
    };
    if out.iter().any(|x| !(*x as f32).is_finite()) {
        return Err(ctx.err(v.span(), field, format!("must be finite, got {out:?}")));
    }
    Ok(out)
}

fn positive(ctx: Ctx, v: &S<Numbers>, field: &str, xs: &[f64]) -> Result<()> {
    if xs.iter().any(|&x| x <= 0.0) {
        return Err(ctx.err(v.span(), field, format!("sizes must be > 0, got {xs:?}")));
    }
    Ok(())
}

/// Where a mesh path written in a scene file lives: absolute as is; otherwise relative to
/// the scene's folder, then `folder/path` for each search folder, first existing file wins.
/// On failure returns every location tried.
fn resolve_mesh(
    written: &str,
    base_dir: &Path,
    search: &[PathBuf],
) -> std::result::Result<PathBuf, Vec<PathBuf>> {
    let p = Path::new(written);
    let candidates: Vec<PathBuf> = if p.is_absolute() {
        vec![p.to_path_buf()]
    } else {
        std::iter::once(base_dir.join(p))
            .chain(search.iter().map(|d| d.join(p)))
            .collect()
    };
    match candidates.iter().find(|c| c.is_file()) {
        Some(c) => Ok(c.clone()),
        None => Err(candidates),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn models_dir() -> PathBuf {
        std::env::var_os(MODEL_PATH_VAR)
            .and_then(|v| std::env::split_paths(&v).find(|p| !p.as_os_str().is_empty()))
            .unwrap_or_else(|| {
                PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/models"))
            })
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
            "bunny", "cornell", "dragon", "glass", "lights", "sponza", "stadium", "teapot",
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
            .all(|l| l.position.y < 1.98 && l.position.y > 1.5));
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
        let s =
            load_scene_str_with_search_path(&text, "t.toml", Path::new("/nonexistent"), &search)
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
                let p = s.positions[t.v[k] as usize].as_dvec3();
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
            let [a, b, c] = [0, 1, 2].map(|k| s.positions[t.v[k] as usize]);
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
            .map(|v| s.positions[v as usize])
            .collect();
        let lo = quad_pts.iter().copied().reduce(Vec3::min).unwrap();
        let hi = quad_pts.iter().copied().reduce(Vec3::max).unwrap();
        assert_eq!(
            (lo, hi),
            (Vec3::new(-2.0, -1.0, -1.0), Vec3::new(2.0, -1.0, 1.0))
        );
        for t in &s.triangles[2..] {
            for &v in &t.v {
                assert!((s.positions[v as usize].length() - 0.5).abs() < 1e-6);
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
}
