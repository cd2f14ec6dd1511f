//! The OBJ and MTL text checks that run before `tobj` sees the text (`obj.rs` says why):
//! numbers, indices and vertex colours validated line by line with line numbers, polylines
//! found and blanked, one-component MTL colours expanded and the MTL's texture statements
//! collected.

use std::collections::BTreeSet;

use super::obj_textures::{parse_map, MtlMaps};
use crate::{Error, Result};

/// What the pre-scan learned about the OBJ text.
pub(super) struct Scan {
    /// One entry per triangle tobj will emit, in order: does its face carry normals?
    pub(super) tri_has_normals: Vec<bool>,
    /// Every `usemtl` name used.
    pub(super) usemtl: BTreeSet<String>,
    /// 0-based line numbers of `l` polylines that tobj would triangulate.
    pub(super) polylines: Vec<usize>,
    /// 0-based line number and text of every `mtllib` statement.
    pub(super) mtllib: Vec<(usize, String)>,
    /// Whether the vertices carry colours (`None`: no vertex at all).
    pub(super) colours: Option<bool>,
    /// One entry per triangle tobj will emit, in order: does its face carry texture
    /// coordinates?
    pub(super) tri_has_uvs: Vec<bool>,
}

/// Validates numbers and face indices line by line (tobj reports neither line numbers nor
/// non-finite values) and records per-face normal presence.
pub(super) fn prescan(text: &str, name: &str) -> Result<Scan> {
    let mut scan = Scan {
        tri_has_normals: Vec::new(),
        usemtl: BTreeSet::new(),
        polylines: Vec::new(),
        mtllib: Vec::new(),
        colours: None,
        tri_has_uvs: Vec::new(),
    };
    let (mut nv, mut nt, mut nn) = (0usize, 0usize, 0usize);
    let err = |line: usize, message: String| Error::Mesh {
        file: name.into(),
        message: format!("line {}: {message}", line + 1),
    };
    for (ln, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some(kind @ ("v" | "vn")) => {
                let mut c = [0f32; 6];
                let mut k = 0;
                for w in words.by_ref().take(if kind == "v" { 6 } else { 4 }) {
                    c[k] = w
                        .parse()
                        .map_err(|_| err(ln, format!("`{w}` is not a number")))?;
                    k += 1;
                }
                if k < 3 {
                    return Err(err(ln, format!("`{kind}` needs three coordinates")));
                }
                // `v x y z w` is homogeneous; tobj divides by w, so check what it will store.
                let w = if kind == "v" && k == 4 { c[3] } else { 1.0 };
                if !c[..3].iter().all(|x| (x / w).is_finite()) {
                    let what = if kind == "v" { "vertex" } else { "normal" };
                    return Err(err(
                        ln,
                        format!("non-finite {what} coordinate: {}", line.trim()),
                    ));
                }
                if kind == "v" {
                    // `v x y z r g b` carries a colour; tobj needs it on every vertex or
                    // on none, and says so without a line number.
                    let coloured = k == 6;
                    if k == 5 {
                        return Err(err(
                            ln,
                            "`v` takes 3, 4 or 6 numbers (x y z [w | r g b])".into(),
                        ));
                    }
                    if coloured && !c[3..].iter().all(|x| x.is_finite() && *x >= 0.0) {
                        return Err(err(
                            ln,
                            format!("vertex colour must be finite and >= 0: {}", line.trim()),
                        ));
                    }
                    match scan.colours {
                        None => scan.colours = Some(coloured),
                        Some(had) if had != coloured => {
                            return Err(err(
                                ln,
                                "vertex colours (`v x y z r g b`) on some vertices only: give every vertex one or none".into(),
                            ))
                        }
                        Some(_) => {}
                    }
                    nv += 1;
                } else {
                    nn += 1;
                }
            }
            Some("vt") => {
                let mut k = 0;
                for w in words.by_ref().take(3) {
                    let x: f32 = w
                        .parse()
                        .map_err(|_| err(ln, format!("`{w}` is not a number")))?;
                    if !x.is_finite() {
                        return Err(err(
                            ln,
                            format!("non-finite texture coordinate: {}", line.trim()),
                        ));
                    }
                    k += 1;
                }
                if k < 2 {
                    return Err(err(ln, "`vt` needs two coordinates (u v)".into()));
                }
                nt += 1;
            }
            Some(kind @ ("f" | "l")) => {
                let mut count = 0usize;
                let mut all_normals = true;
                let mut all_uvs = true;
                for w in words {
                    count += 1;
                    let mut parts = w.split('/');
                    let limits = [(nv, "vertex"), (nt, "texture"), (nn, "normal")];
                    for (slot, (limit, what)) in limits.iter().enumerate() {
                        match parts.next() {
                            Some("") | None => {
                                if slot == 0 {
                                    return Err(err(
                                        ln,
                                        format!("face corner `{w}` has no vertex"),
                                    ));
                                }
                                if slot == 2 {
                                    all_normals = false;
                                }
                                if slot == 1 {
                                    all_uvs = false;
                                }
                            }
                            Some(s) => {
                                let i: i64 = s.parse().map_err(|_| {
                                    err(ln, format!("face index `{s}` is not an integer"))
                                })?;
                                let ok = (i > 0 && i as usize <= *limit)
                                    || (i < 0 && i.unsigned_abs() as usize <= *limit);
                                if !ok {
                                    return Err(err(
                                        ln,
                                        format!(
                                            "{what} index {i} out of range (1..={limit} or -{limit}..=-1 here)"
                                        ),
                                    ));
                                }
                            }
                        }
                    }
                }
                if kind == "f" && count < 3 {
                    // tobj drops such a face without a word; a mesh with a hole where the
                    // author expected a face is worse than a refusal.
                    return Err(err(
                        ln,
                        format!(
                            "face with {count} vert{} (a face needs at least three)",
                            if count == 1 { "ex" } else { "ices" }
                        ),
                    ));
                }
                if count >= 3 {
                    if kind == "f" {
                        scan.tri_has_normals
                            .extend(std::iter::repeat_n(all_normals, count - 2));
                        scan.tri_has_uvs
                            .extend(std::iter::repeat_n(all_uvs, count - 2));
                    } else {
                        scan.polylines.push(ln);
                    }
                }
            }
            Some("mtllib") => scan.mtllib.push((ln, line.to_owned())),
            Some("usemtl") => {
                let n = line.trim_start()["usemtl".len()..].trim();
                if !n.is_empty() {
                    scan.usemtl.insert(n.to_owned());
                }
            }
            _ => {}
        }
    }
    Ok(scan)
}

/// `text` with the given 0-based lines emptied (line count preserved).
pub(super) fn blank_lines(text: &str, lines: &[usize]) -> String {
    let mut out = String::with_capacity(text.len());
    let mut skip = lines.iter().peekable();
    for (i, line) in text.lines().enumerate() {
        if skip.peek() == Some(&&i) {
            skip.next();
        } else {
            out.push_str(line);
        }
        out.push('\n');
    }
    out
}

/// Checks every numeric MTL statement fragtrace uses for finiteness (with line numbers) and
/// expands one-component colours (`Kd 0.5`, allowed by the MTL spec) to three, because tobj
/// panics on them.
pub(super) fn normalise_mtl(text: &str, file: &str) -> Result<(String, MtlMaps)> {
    let file = file.to_owned();
    let mut out = String::with_capacity(text.len() + 64);
    let mut maps = MtlMaps::default();
    let mut current = String::new();
    for (ln, line) in text.lines().enumerate() {
        // Trailing comments (`Kd 0.63 0.065 0.05 # Red`, as in the Cornell box) are legal.
        let content = line.split_once('#').map_or(line, |(before, _)| before);
        let mut words = content.split_whitespace();
        let key = words.next();
        let vals: Vec<&str> = words.collect();
        let numeric = |vals: &[&str]| -> Result<Vec<f32>> {
            vals.iter()
                .map(|w| match w.parse::<f32>() {
                    Ok(x) if x.is_finite() => Ok(x),
                    _ => Err(Error::Mesh {
                        file: file.clone(),
                        message: format!(
                            "line {}: invalid number `{w}` in `{}`",
                            ln + 1,
                            line.trim()
                        ),
                    }),
                })
                .collect()
        };
        match key {
            Some("newmtl") => {
                current = content.trim_start()["newmtl".len()..].trim().to_owned();
                out.push_str(line);
                out.push('\n');
            }
            // The texture statements are read here (tobj would keep the options in the
            // file name) and kept from tobj.
            Some("map_Kd") => {
                match parse_map(&vals) {
                    Some(stmt) => {
                        maps.kd.insert(current.clone(), stmt);
                    }
                    None => {
                        return Err(Error::Mesh {
                            file,
                            message: format!("line {}: `map_Kd` needs a file name", ln + 1),
                        })
                    }
                }
                out.push('\n');
            }
            Some(k @ ("map_Ks" | "map_d")) => {
                maps.unused
                    .entry(current.clone())
                    .or_default()
                    .push(k.to_owned());
                out.push('\n');
            }
            Some(k @ ("Ka" | "Kd" | "Ks" | "Ke" | "Tf")) => {
                // `Kd spectral file.rfl` / `Kd xyz ...` are not RGB; drop them (default used).
                if matches!(vals.first(), Some(&"spectral") | Some(&"xyz")) {
                    out.push('\n');
                    continue;
                }
                let v = numeric(&vals)?;
                // The colours fragtrace reads must not be negative (as in scene files): a
                // negative Ks would subtract light, and the shaders assume it does not.
                if matches!(k, "Kd" | "Ks" | "Tf") && v.iter().any(|x| *x < 0.0) {
                    return Err(Error::Mesh {
                        file,
                        message: format!(
                            "line {}: `{k}` components must be >= 0, got `{}`",
                            ln + 1,
                            line.trim()
                        ),
                    });
                }
                match v[..] {
                    [g] => out.push_str(&format!("{k} {g} {g} {g}\n")),
                    [r, g, b] => out.push_str(&format!("{k} {r} {g} {b}\n")),
                    _ => {
                        return Err(Error::Mesh {
                            file,
                            message: format!("line {}: `{k}` needs 1 or 3 numbers", ln + 1),
                        })
                    }
                }
            }
            Some(k @ ("Ns" | "Ni" | "d" | "Tr")) => {
                // `d -halo 0.5`: the halo variant is treated as a plain dissolve.
                let vals: Vec<&str> = vals.into_iter().filter(|w| *w != "-halo").collect();
                let v = numeric(&vals[..vals.len().min(1)])?;
                match v.first() {
                    Some(x) => out.push_str(&format!("{k} {x}\n")),
                    None => {
                        return Err(Error::Mesh {
                            file,
                            message: format!("line {}: `{k}` needs a number", ln + 1),
                        })
                    }
                }
            }
            _ => {
                out.push_str(line);
                out.push('\n');
            }
        }
    }
    Ok((out, maps))
}
