//! The bytes behind a glTF file (`gltf_mesh.rs` reads the scene from them): data URIs
//! and percent-encoded file names, the buffers (the `.glb` chunk, embedded or external),
//! and accessors read with every range checked, so a file that lies about its sizes is one
//! error line, never a panic.

use std::path::Path;

use base64::Engine as _;
use gltf::accessor::{DataType, Dimensions};

use crate::{Error, Result};

/// Largest `.gltf`/`.glb` file read, and largest external buffer.
pub const MAX_GLTF_BYTES: u64 = 1 << 30;

/// Where a document's external files (buffers, images) come from: a folder, or nowhere.
pub(super) type Files<'a> = Option<&'a Path>;

/// One-line error naming the file.
pub(super) fn mesh_err(name: &str, message: String) -> Error {
    Error::Mesh {
        file: name.into(),
        message,
    }
}

/// Decodes a `data:[...][;base64],DATA` URI, or `None` when `uri` is not one.
pub(super) fn data_uri(uri: &str) -> Option<std::result::Result<Vec<u8>, String>> {
    let rest = uri.strip_prefix("data:")?;
    let Some((_, data)) = rest.split_once(";base64,") else {
        return Some(Err("a data URI without `;base64,`".into()));
    };
    Some(
        base64::engine::general_purpose::STANDARD
            .decode(data)
            .map_err(|e| format!("base64: {e}")),
    )
}

/// A relative URI's percent-escapes decoded (`%20` -> space), or why it cannot be.
pub(super) fn percent_decode(uri: &str) -> std::result::Result<String, String> {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = b
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or_else(|| format!("bad percent-escape in `{uri}`"))?;
            out.push(hex);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| format!("`{uri}` is not UTF-8 once decoded"))
}

/// The bytes an external URI (data URI or a file relative to the document) names, with
/// where it was looked for; `limit` bounds a file's size.
pub(super) fn read_uri(
    uri: &str,
    files: Files<'_>,
    limit: u64,
    what: &str,
) -> std::result::Result<Vec<u8>, (String, String)> {
    if let Some(d) = data_uri(uri) {
        return d.map_err(|why| ("the data URI".into(), why));
    }
    if uri.contains(':') && !uri.starts_with("file:") {
        return Err((uri.into(), "unsupported URI scheme".into()));
    }
    let rel = percent_decode(
        uri.trim_start_matches("file://")
            .trim_start_matches("file:"),
    )
    .map_err(|why| (uri.to_owned(), why))?;
    let Some(base) = files else {
        return Err((
            uri.into(),
            "not given: only models read from files bring external files".into(),
        ));
    };
    let path = base.join(rel);
    super::read_input_file(&path, limit, what)
        .map_err(|e| (path.display().to_string(), e.to_string()))
}

pub(super) fn load_buffers(
    doc: &gltf::Document,
    mut blob: Option<Vec<u8>>,
    name: &str,
    files: Files<'_>,
) -> Result<Vec<Vec<u8>>> {
    let mut out = Vec::new();
    for buf in doc.buffers() {
        let data = match buf.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                mesh_err(
                    name,
                    format!(
                        "buffer {}: refers to a GLB BIN chunk the file lacks",
                        buf.index()
                    ),
                )
            })?,
            gltf::buffer::Source::Uri(uri) => read_uri(uri, files, MAX_GLTF_BYTES, "glTF buffer")
                .map_err(|(at, why)| {
                mesh_err(
                    name,
                    format!(
                        "buffer {}: cannot read `{}` at {at} ({why})",
                        buf.index(),
                        short(uri)
                    ),
                )
            })?,
        };
        if data.len() < buf.length() {
            return Err(mesh_err(
                name,
                format!(
                    "buffer {}: {} bytes, shorter than its byteLength {}",
                    buf.index(),
                    data.len(),
                    buf.length()
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// A URI for a message: a data URI is not quoted whole.
pub(super) fn short(uri: &str) -> String {
    if uri.starts_with("data:") || uri.len() > 80 {
        format!(
            "{}...",
            &uri[..uri.char_indices().nth(30).map_or(uri.len(), |(i, _)| i)]
        )
    } else {
        uri.to_owned()
    }
}

/// The bytes of a buffer view, range-checked.
pub(super) fn view_bytes<'b>(
    view: &gltf::buffer::View<'_>,
    buffers: &'b [Vec<u8>],
) -> Option<&'b [u8]> {
    let data = buffers.get(view.buffer().index())?;
    let end = view.offset().checked_add(view.length())?;
    data.get(view.offset()..end)
}

/// What an accessor holds, for messages: "accessor 3 (POSITION of mesh 0 `duck` primitive 1)".
pub(super) struct Role<'a> {
    pub(super) what: &'a str,
    pub(super) mesh: usize,
    pub(super) mesh_name: &'a str,
    pub(super) prim: usize,
}

impl std::fmt::Display for Role<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} of mesh {}", self.what, self.mesh)?;
        if !self.mesh_name.is_empty() {
            write!(f, " `{}`", self.mesh_name)?;
        }
        write!(f, " primitive {}", self.prim)
    }
}

/// Reads an accessor's components as f64, `dims` per element (checked against `allowed`
/// types), normalising integers where the accessor says so.
pub(super) fn read_accessor(
    acc: &gltf::Accessor<'_>,
    buffers: &[Vec<u8>],
    allowed: &[(Dimensions, &[DataType])],
    role: &Role<'_>,
    name: &str,
) -> Result<(Vec<f64>, usize)> {
    let err = |m: String| mesh_err(name, format!("accessor {} ({role}): {m}", acc.index()));
    let (dt, dim) = (acc.data_type(), acc.dimensions());
    if !allowed.iter().any(|(d, ts)| *d == dim && ts.contains(&dt)) {
        return Err(err(format!("type {dim:?} of {dt:?} is not allowed here")));
    }
    if acc.sparse().is_some() {
        return Err(err("sparse accessors are not read".into()));
    }
    let n = dim.multiplicity();
    let csize = dt.size();
    let count = acc.count();
    let Some(view) = acc.view() else {
        // No buffer view and not sparse: all zeros, by the specification.
        return Ok((
            vec![
                0.0;
                count
                    .checked_mul(n)
                    .ok_or_else(|| err("count overflows".into()))?
            ],
            n,
        ));
    };
    let bytes = view_bytes(&view, buffers).ok_or_else(|| {
        err(format!(
            "buffer view {} (bytes {}..+{}) is out of range of buffer {}",
            view.index(),
            view.offset(),
            view.length(),
            view.buffer().index()
        ))
    })?;
    let esize = n * csize;
    let stride = view.stride().unwrap_or(esize);
    if count == 0 {
        return Ok((Vec::new(), n));
    }
    let end = stride
        .checked_mul(count - 1)
        .and_then(|x| x.checked_add(acc.offset()))
        .and_then(|x| x.checked_add(esize));
    if stride < esize || end.is_none_or(|e| e > bytes.len()) {
        return Err(err(format!(
            "{count} elements of {esize} bytes (stride {stride}, offset {}) are out of range of \
             buffer view {} ({} bytes)",
            acc.offset(),
            view.index(),
            bytes.len()
        )));
    }
    let norm = acc.normalized();
    let mut out = Vec::with_capacity(count * n);
    for e in 0..count {
        let at = acc.offset() + e * stride;
        for c in 0..n {
            let p = &bytes[at + c * csize..at + (c + 1) * csize];
            let x = match dt {
                DataType::F32 => f32::from_le_bytes([p[0], p[1], p[2], p[3]]) as f64,
                DataType::U8 => p[0] as f64 / if norm { 255.0 } else { 1.0 },
                DataType::I8 => {
                    let v = p[0] as i8 as f64;
                    if norm {
                        (v / 127.0).max(-1.0)
                    } else {
                        v
                    }
                }
                DataType::U16 => {
                    u16::from_le_bytes([p[0], p[1]]) as f64 / if norm { 65535.0 } else { 1.0 }
                }
                DataType::I16 => {
                    let v = i16::from_le_bytes([p[0], p[1]]) as f64;
                    if norm {
                        (v / 32767.0).max(-1.0)
                    } else {
                        v
                    }
                }
                DataType::U32 => u32::from_le_bytes([p[0], p[1], p[2], p[3]]) as f64,
            };
            if !x.is_finite() {
                return Err(err(format!("element {e}: non-finite component {x}")));
            }
            out.push(x);
        }
    }
    Ok((out, n))
}
