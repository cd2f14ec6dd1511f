//! PLY (Stanford polygon file) loading through `ply-rs-bw`, into the mesh structure OBJ
//! loading produces ([`ObjMesh`]), so a scene takes `mesh = "x.ply"` exactly as an OBJ.
//!
//! Read: the `vertex` element's `x y z` (required), `nx ny nz`, texture coordinates (`s t`,
//! `u v` or `texture_u texture_v`) and colours (`red green blue`: `uchar` as 8-bit sRGB,
//! decoded to linear as image texels are; `float`/`double` as linear, as OBJ's); the
//! `face` element's `vertex_indices` (or `vertex_index`) lists, fan-triangulated; a
//! `comment TextureFile NAME` (MeshLab's) as the diffuse texture, relative to the file's
//! folder. Every other element and property is skipped. The crate parses ASCII and both
//! binary byte orders; what it does not check is checked here, each error one line naming
//! the file and the element: a header whose counts disagree with the data (too little
//! data, or bytes left over), an index out of range, a face of fewer than three corners, a
//! non-finite number.

use std::io::{BufRead, BufReader};
use std::path::Path;

use glam::{Vec2, Vec3};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{Property, PropertyAccess, PropertyAccessResult};

use super::texture::{srgb8_to_linear, Texture, Wrap};
use super::{Material, ObjMesh, Triangle, NO_NORMAL};
use crate::{Error, Result};

/// Largest PLY file read (as for OBJ: checked before reading).
pub const MAX_PLY_BYTES: u64 = 1 << 30;

/// One element of any kind, with the properties fragtrace reads (a vertex's, a face's);
/// the parser fills one per line or record, and skips every other property.
#[derive(Clone, Debug, Default)]
struct Elem {
    /// x, y, z; nx, ny, nz; u, v; r, g, b, each `Some` once set.
    vals: [Option<f64>; 11],
    /// Whether a colour came as `uchar` (8-bit sRGB) rather than a float (linear).
    color_u8: bool,
    /// A face's corner indices (signed: a negative index is out of range, not huge).
    indices: Option<Vec<i64>>,
    /// Values the parser handed over, a list counting its length and its items: what an
    /// ASCII line must hold, no more.
    tokens: usize,
}

/// The slot of a vertex property in [`Elem::vals`].
fn slot(name: &str) -> Option<usize> {
    Some(match name {
        "x" => 0,
        "y" => 1,
        "z" => 2,
        "nx" => 3,
        "ny" => 4,
        "nz" => 5,
        "s" | "u" | "texture_u" => 6,
        "t" | "v" | "texture_v" => 7,
        "red" => 8,
        "green" => 9,
        "blue" => 10,
        _ => return None,
    })
}

impl PropertyAccess for Elem {
    fn new() -> Self {
        Elem::default()
    }

    fn set_property(&mut self, name: &str, p: Property) -> PropertyAccessResult {
        self.tokens += 1 + match &p {
            Property::ListChar(v) => v.len(),
            Property::ListUChar(v) => v.len(),
            Property::ListShort(v) => v.len(),
            Property::ListUShort(v) => v.len(),
            Property::ListInt(v) => v.len(),
            Property::ListUInt(v) => v.len(),
            Property::ListFloat(v) => v.len(),
            Property::ListDouble(v) => v.len(),
            _ => 0,
        };
        if name == "vertex_indices" || name == "vertex_index" {
            let list: Option<Vec<i64>> = match p {
                Property::ListChar(v) => Some(v.into_iter().map(i64::from).collect()),
                Property::ListUChar(v) => Some(v.into_iter().map(i64::from).collect()),
                Property::ListShort(v) => Some(v.into_iter().map(i64::from).collect()),
                Property::ListUShort(v) => Some(v.into_iter().map(i64::from).collect()),
                Property::ListInt(v) => Some(v.into_iter().map(i64::from).collect()),
                Property::ListUInt(v) => Some(v.into_iter().map(i64::from).collect()),
                _ => None,
            };
            return match list {
                Some(l) => {
                    self.indices = Some(l);
                    PropertyAccessResult::Set
                }
                None => PropertyAccessResult::UnsupportedType,
            };
        }
        let Some(k) = slot(name) else {
            return PropertyAccessResult::Ignored;
        };
        let x = match p {
            Property::UChar(c) if k >= 8 => {
                self.color_u8 = true;
                srgb8_to_linear(c) as f64
            }
            Property::Float(f) => f as f64,
            Property::Double(f) => f,
            Property::Char(i) => i as f64,
            Property::UChar(i) => i as f64,
            Property::Short(i) => i as f64,
            Property::UShort(i) => i as f64,
            Property::Int(i) => i as f64,
            Property::UInt(i) => i as f64,
            _ => return PropertyAccessResult::UnsupportedType,
        };
        self.vals[k] = Some(x);
        PropertyAccessResult::Set
    }
}

/// Loads a PLY file (a regular file of at most [`MAX_PLY_BYTES`]); a `TextureFile`
/// comment resolves against its folder.
pub fn load_ply(path: &Path) -> Result<ObjMesh> {
    let bytes = super::read_input_file(path, MAX_PLY_BYTES, "PLY mesh")?;
    let base = path.parent().unwrap_or(Path::new("."));
    parse_ply_with(&bytes, &path.display().to_string(), &|file: &str| {
        let p = base.join(file);
        Texture::load(&p, [Wrap::Repeat; 2]).map_err(|why| (p.display().to_string(), why))
    })
}

/// Parses PLY bytes without touching the file system (a `TextureFile` is reported as not
/// read); `name` is used in messages. The fuzz target `ply_load` drives this.
pub fn parse_ply(bytes: &[u8], name: &str) -> Result<ObjMesh> {
    parse_ply_with(bytes, name, &|file: &str| {
        Err((
            file.to_owned(),
            "not given: only meshes read from files bring their textures".into(),
        ))
    })
}

/// Loads a texture by the name a `TextureFile` comment gives, or says where it looked and
/// why it could not.
type PlyTexSource<'a> = dyn Fn(&str) -> std::result::Result<Texture, (String, String)> + 'a;

fn parse_ply_with(bytes: &[u8], name: &str, textures: &PlyTexSource<'_>) -> Result<ObjMesh> {
    let err = |message: String| Error::Mesh {
        file: name.into(),
        message,
    };
    let parser = Parser::<Elem>::new();
    let mut reader = Reader::new(BufReader::new(bytes));
    let header = parser
        .read_header(&mut reader)
        .map_err(|e| err(format!("header: {}", one_line(&e.to_string()))))?;
    let vertex_def = header
        .elements
        .get("vertex")
        .ok_or_else(|| err("no `vertex` element in the header".into()))?;
    for p in ["x", "y", "z"] {
        if !vertex_def.properties.contains_key(p) {
            return Err(err(format!("element `vertex`: no property `{p}`")));
        }
    }
    if let Some(f) = header.elements.get("face") {
        if !f.properties.contains_key("vertex_indices")
            && !f.properties.contains_key("vertex_index")
        {
            return Err(err(
                "element `face`: no list property `vertex_indices` (or `vertex_index`)".into(),
            ));
        }
    }
    let ascii = header.encoding == ply_rs_bw::ply::Encoding::Ascii;
    let mut payload = std::collections::HashMap::new();
    let mut rest = if ascii {
        // ASCII is read line by line here: the crate ignores values past the last property
        // of a line, which would hide a list length that disagrees with its line.
        let mut rest = reader.into_inner();
        for (key, def) in &header.elements {
            let mut elems = Vec::new();
            let mut line = String::new();
            while elems.len() < def.count {
                line.clear();
                let bad = |m: String| err(format!("element `{key}` {}: {m}", elems.len()));
                match rest.read_line(&mut line) {
                    Ok(0) => {
                        return Err(bad(format!(
                            "the data ends after {} of the {} declared",
                            elems.len(),
                            def.count
                        )))
                    }
                    Ok(_) => {}
                    Err(e) => return Err(bad(format!("cannot read a line ({e})"))),
                }
                if line.trim().is_empty() {
                    continue;
                }
                let e = parser
                    .read_ascii_element(&line, def)
                    .map_err(|e| bad(one_line(&e.to_string())))?;
                let on_line = line.split_whitespace().count();
                if e.tokens != on_line {
                    return Err(bad(format!(
                        "{on_line} values on its line, but its properties (and list lengths) \
                         take {}",
                        e.tokens
                    )));
                }
                elems.push(e);
            }
            if key == "vertex" || key == "face" {
                payload.insert(key.clone(), elems);
            }
        }
        rest
    } else {
        for (key, def) in &header.elements {
            let elems = parser
                .read_payload_for_element(&mut reader, def, &header)
                .map_err(|e| {
                    err(format!(
                        "element `{key}` ({} declared): {}",
                        def.count,
                        one_line(&e.to_string())
                    ))
                })?;
            // Only what is read is kept; other elements cost one pass, not memory.
            if key == "vertex" || key == "face" {
                payload.insert(key.clone(), elems);
            }
        }
        reader.into_inner()
    };
    // The counts the header declares must use up the data: bytes left over mean a count
    // (or a list length) disagrees with what was written.
    let leftover = leftover_bytes(&mut rest, ascii);
    if leftover > 0 {
        let last = header.elements.keys().last().cloned().unwrap_or_default();
        return Err(err(format!(
            "{leftover} bytes of data after the last element (`{last}`): the header's element \
             counts disagree with the data"
        )));
    }
    let vertices = payload.remove("vertex").unwrap_or_default();
    let faces = payload.remove("face").unwrap_or_default();
    build_mesh(name, &header.comments, vertices, faces, textures)
}

/// Bytes left in `r` (for ASCII, not counting whitespace).
fn leftover_bytes(r: &mut impl BufRead, ascii: bool) -> usize {
    let mut rest = Vec::new();
    if r.read_to_end(&mut rest).is_err() {
        return 0;
    }
    if ascii {
        rest.iter().filter(|b| !b.is_ascii_whitespace()).count()
    } else {
        rest.len()
    }
}

/// An error message of the crate (which may span lines) on one line.
fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

fn build_mesh(
    name: &str,
    comments: &[String],
    vertices: Vec<Elem>,
    faces: Vec<Elem>,
    textures: &PlyTexSource<'_>,
) -> Result<ObjMesh> {
    let err = |message: String| Error::Mesh {
        file: name.into(),
        message,
    };
    let n = vertices.len();
    if n > u32::MAX as usize / 2 {
        return Err(err(format!(
            "element `vertex`: {n} vertices exceed the supported index range"
        )));
    }
    let has = |k: usize| vertices.first().is_some_and(|v| v.vals[k].is_some());
    let (has_n, has_uv, has_c) = (
        has(3) && has(4) && has(5),
        has(6) && has(7),
        has(8) && has(9) && has(10),
    );
    let mut mesh = ObjMesh::default();
    mesh.positions.reserve(n);
    let mut usable_normal = Vec::new();
    for (i, v) in vertices.iter().enumerate() {
        let get = |k: usize, what: &str| -> Result<f32> {
            let x = v.vals[k].unwrap_or(0.0);
            let f = x as f32;
            if !f.is_finite() {
                return Err(err(format!("element `vertex` {i}: non-finite {what} {x}")));
            }
            Ok(f)
        };
        mesh.positions
            .push(Vec3::new(get(0, "x")?, get(1, "y")?, get(2, "z")?));
        if has_n {
            let nv = Vec3::new(get(3, "nx")?, get(4, "ny")?, get(5, "nz")?);
            // A zero normal has no direction: its triangles fall back to flat shading.
            match nv.try_normalize() {
                Some(u) => {
                    mesh.normals.push(u);
                    usable_normal.push(true);
                }
                None => {
                    mesh.normals.push(Vec3::Z);
                    usable_normal.push(false);
                }
            }
        }
        if has_uv {
            mesh.uvs.push(Vec2::new(get(6, "u")?, get(7, "v")?));
        }
        if has_c {
            let c = Vec3::new(get(8, "red")?, get(9, "green")?, get(10, "blue")?);
            if c.min_element() < 0.0 {
                return Err(err(format!(
                    "element `vertex` {i}: colour {c} must be >= 0"
                )));
            }
            mesh.colors.push(c);
        }
    }
    let mut material = Material {
        name: format!("{name}:default"),
        ..Material::default()
    };
    if let Some(file) = comments
        .iter()
        .find_map(|c| c.trim().strip_prefix("TextureFile").map(str::trim))
        .filter(|f| !f.is_empty())
    {
        match textures(file) {
            Ok(t) => {
                mesh.textures.push(t);
                material.diffuse_map = Some(0);
            }
            Err((at, why)) => mesh.texture_problems.push(format!(
                "{name}: TextureFile `{file}` cannot be read at {at} ({why}); the mesh renders \
                 with its colour"
            )),
        }
    }
    mesh.materials.push(material);
    for (f, face) in faces.iter().enumerate() {
        let Some(idx) = &face.indices else { continue };
        if idx.len() < 3 {
            return Err(err(format!(
                "element `face` {f}: {} corners (a face needs at least three)",
                idx.len()
            )));
        }
        if let Some(&bad) = idx.iter().find(|&&k| k < 0 || k as usize >= n) {
            return Err(err(format!(
                "element `face` {f}: vertex index {bad} out of range (0..{n})"
            )));
        }
        let idx: Vec<u32> = idx.iter().map(|&k| k as u32).collect();
        for k in 1..idx.len() - 1 {
            let v = [idx[0], idx[k], idx[k + 1]];
            let smooth = has_n && v.iter().all(|&i| usable_normal[i as usize]);
            mesh.triangles.push(Triangle {
                v,
                n: if smooth { v } else { [NO_NORMAL; 3] },
                material: 0,
            });
            if has_uv {
                mesh.tri_uvs.push(v);
            }
        }
        if mesh.triangles.len() > u32::MAX as usize / 3 {
            return Err(err(format!(
                "element `face`: {} triangles exceed the supported index range",
                mesh.triangles.len()
            )));
        }
    }
    if mesh.triangles.is_empty() {
        mesh.warnings.push(format!(
            "{name}: no faces, so no triangles; the object adds nothing to the scene"
        ));
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err_of(bytes: &[u8]) -> String {
        match parse_ply(bytes, "t.ply") {
            Err(Error::Mesh { file, message }) => format!("{file}: {message}"),
            other => panic!("expected a mesh error, got {other:?}"),
        }
    }

    const HEAD: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n\
                        property float y\nproperty float z\nproperty float nx\nproperty float ny\n\
                        property float nz\nproperty float s\nproperty float t\n\
                        property uchar red\nproperty uchar green\nproperty uchar blue\n\
                        element face 1\nproperty list uchar int vertex_indices\nend_header\n";

    #[test]
    fn ascii_quad_with_normals_uvs_and_colours_is_a_fan() {
        let body = "0 0 0 0 0 2 0 0 255 0 0\n1 0 0 0 0 1 1 0 0 255 0\n\
                    1 1 0 0 0 1 1 1 0 0 255\n0 1 0 0 0 0 0 1 188 188 188\n4 0 1 2 3\n";
        let m = parse_ply(format!("{HEAD}{body}").as_bytes(), "q.ply").unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.triangles.len(), 2);
        assert_eq!(m.triangles[0].v, [0, 1, 2]);
        assert_eq!(m.triangles[1].v, [0, 2, 3]);
        assert_eq!(m.triangles[0].n, [0, 1, 2], "unit normals: smooth");
        assert!(!m.triangles[1].has_normals(), "a zero normal: flat");
        assert_eq!(m.normals[0], Vec3::Z, "normalised");
        assert_eq!(m.uvs[2], Vec2::new(1.0, 1.0));
        assert_eq!(m.tri_uvs, [[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.colors[0], Vec3::X, "uchar 255: linear 1");
        assert_eq!(m.colors[3], Vec3::splat(srgb8_to_linear(188)));
        assert_eq!(m.materials.len(), 1);
    }

    #[test]
    fn binary_both_byte_orders_read_the_same_triangle() {
        for (fmt, be) in [("binary_little_endian", false), ("binary_big_endian", true)] {
            let mut b = format!(
                "ply\nformat {fmt} 1.0\ncomment made by a test\nelement vertex 3\n\
                 property double x\nproperty double y\nproperty double z\n\
                 property float u\nproperty float v\n\
                 element face 1\nproperty list uchar uint vertex_index\nend_header\n"
            )
            .into_bytes();
            for (i, p) in [[0.0f64, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 3.0, 0.5]]
                .iter()
                .enumerate()
            {
                for c in p {
                    b.extend(if be { c.to_be_bytes() } else { c.to_le_bytes() });
                }
                for c in [i as f32 * 0.25, 0.5] {
                    b.extend(if be { c.to_be_bytes() } else { c.to_le_bytes() });
                }
            }
            b.push(3);
            for k in [0u32, 1, 2] {
                b.extend(if be { k.to_be_bytes() } else { k.to_le_bytes() });
            }
            let m = parse_ply(&b, "b.ply").unwrap();
            assert_eq!(m.positions[2], Vec3::new(0.0, 3.0, 0.5), "{fmt}");
            assert_eq!(m.uvs[1], Vec2::new(0.25, 0.5));
            assert_eq!(m.triangles.len(), 1);
            // One byte more than the header declares: the counts disagree.
            let mut longer = b.clone();
            longer.push(0);
            let e = err_of(&longer);
            assert!(
                e.contains("1 bytes of data after") && e.contains("`face`"),
                "{e}"
            );
            // A NaN coordinate: vertex 1's y. Each vertex is 32 bytes (3 doubles, 2 floats),
            // the face 13 (a count byte, 3 uints).
            let at = b.len() - 13 - 2 * 32 + 8;
            let mut nan = b.clone();
            let bytes = if be {
                f64::NAN.to_be_bytes()
            } else {
                f64::NAN.to_le_bytes()
            };
            nan[at..at + 8].copy_from_slice(&bytes);
            let e = err_of(&nan);
            assert!(e.contains("element `vertex` 1: non-finite y"), "{e}");
        }
    }

    #[test]
    fn bad_input_is_one_line_naming_the_file_and_element() {
        let head3 = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                     property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                     end_header\n";
        for (body, want) in [
            // Fewer vertices than declared: the face line is read as a vertex, then the
            // data ends.
            (
                "0 0 0\n1 0 0\n3 0 1 2\n",
                "element `vertex` 2: 4 values on its line",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n",
                "element `face` 0: the data ends after 0 of the 1",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n3 0 1 2 0\n",
                "element `face` 0: 5 values",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n",
                "element `face` 0: Expected",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
                "element `face` 0: vertex index 3 out of range",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n",
                "vertex index -1 out of range",
            ),
            ("0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n", "element `vertex` 1: "),
            (
                "0 0 0\n1 0 1e39\n0 1 0\n3 0 1 2\n",
                "element `vertex` 1: non-finite z",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
                "element `face` 0: 2 corners",
            ),
            (
                "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 2\n",
                "bytes of data after",
            ),
        ] {
            let e = err_of(format!("{head3}{body}").as_bytes());
            assert!(
                e.starts_with("t.ply: ") && e.contains(want),
                "{body:?}: {e}"
            );
            assert!(!e.contains('\n'), "{e}");
        }
        let e =
            err_of(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n");
        assert!(e.contains("no property `y`"), "{e}");
        let e = err_of(b"not a ply\n");
        assert!(e.contains("header"), "{e}");
    }
}
