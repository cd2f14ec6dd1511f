//! The MTL's texture statements (split from `obj.rs` by job): `map_Kd`, `map_Ks` and
//! `map_d` parsed with their options, the image resolved relative to the MTL's folder and
//! loaded once per file.
//!
//! fragtrace's Whitted shader takes `map_Kd` (the diffuse colour, multiplied by `Kd`:
//! the MTL rule) and no other map. `map_Ks` would scale only the Phong highlight, which
//! exporters rarely texture and which a point light shows as a dot; `map_d` cut-outs
//! change what a ray hits, so every traversal (each CPU walk, both any-hit and
//! closest-hit, and the GPU's step) would fetch textures: a cost for every scene. Both are
//! named in one warning line per material and otherwise ignored; `map_Ka` is ignored
//! silently, as `Ka` is (see `material_from_mtl`).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::texture::{Texture, Wrap};

/// A `map_Kd` statement: the image file as written and the wrap modes its options ask for.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct MapStmt {
    /// The file name as written (relative to the MTL's folder unless absolute).
    pub file: String,
    /// `-clamp on` clamps both axes; the default repeats.
    pub wrap: [Wrap; 2],
    /// Options read and ignored (`-o`, `-s`, `-mm`, ...), for the warning.
    pub ignored: Vec<String>,
}

/// The texture statements of one MTL's materials, by material name.
#[derive(Clone, Debug, Default)]
pub(super) struct MtlMaps {
    /// `map_Kd` per material.
    pub kd: HashMap<String, MapStmt>,
    /// Statements named and not used (`map_Ks`, `map_d`), per material.
    pub unused: HashMap<String, Vec<String>>,
}

/// Texture options and how many arguments each takes (`-o`, `-s`, `-t` take one to three
/// numbers).
fn option_args(opt: &str) -> Option<usize> {
    match opt {
        "-blendu" | "-blendv" | "-cc" | "-clamp" | "-bm" | "-boost" | "-texres" | "-imfchan"
        | "-type" => Some(1),
        "-mm" => Some(2),
        "-o" | "-s" | "-t" => Some(3),
        _ => None,
    }
}

/// Parses the arguments of a `map_*` statement: options, then the file name (the rest of
/// the line, spaces kept). `None` when no file name is left.
pub(super) fn parse_map(args: &[&str]) -> Option<MapStmt> {
    let mut wrap = [Wrap::Repeat; 2];
    let mut ignored = Vec::new();
    let mut i = 0;
    while i < args.len() {
        let Some(n) = option_args(args[i]) else { break };
        let opt = args[i];
        i += 1;
        let mut taken = Vec::new();
        while taken.len() < n && i < args.len() {
            let a = args[i];
            // `-o u [v [w]]`: the optional numbers end at the first word that is not one.
            if n == 3 && !taken.is_empty() && a.parse::<f32>().is_err() {
                break;
            }
            taken.push(a);
            i += 1;
        }
        match (opt, taken.as_slice()) {
            ("-clamp", ["on"]) => wrap = [Wrap::Clamp; 2],
            ("-clamp", ["off"]) => wrap = [Wrap::Repeat; 2],
            // Blending, bump and channel options do not change a diffuse lookup.
            ("-blendu" | "-blendv" | "-bm" | "-imfchan" | "-type", _) => {}
            _ => ignored.push(format!("{opt} {}", taken.join(" "))),
        }
    }
    let file = args[i..].join(" ");
    (!file.is_empty()).then_some(MapStmt {
        file,
        wrap,
        ignored,
    })
}

/// The image files an MTL library's `map_Kd` statements name, as written (relative to the
/// MTL's folder unless absolute), each once: what the web page fetches beside the MTL so
/// that a scene loaded from texts brings its textures ([`super::MeshImages`]).
pub fn mtl_texture_files(mtl: &str) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for line in mtl.lines() {
        let content = line.split_once('#').map_or(line, |(before, _)| before);
        let mut words = content.split_whitespace();
        if words.next() != Some("map_Kd") {
            continue;
        }
        let args: Vec<&str> = words.collect();
        if let Some(stmt) = parse_map(&args) {
            if !out.contains(&stmt.file) {
                out.push(stmt.file);
            }
        }
    }
    out
}

/// Loads a texture by its resolved path, or says why it cannot.
pub(crate) type TexSource<'a> = dyn Fn(&Path, [Wrap; 2]) -> Result<Texture, String> + 'a;

/// The textures of a mesh's materials, loaded once per resolved file and wrap mode.
pub(super) struct TextureLoader<'a> {
    source: &'a TexSource<'a>,
    /// Resolved path and wrap -> index into `textures`.
    loaded: HashMap<(PathBuf, [Wrap; 2]), usize>,
    pub textures: Vec<Texture>,
}

impl<'a> TextureLoader<'a> {
    pub fn new(source: &'a TexSource<'a>) -> Self {
        TextureLoader {
            source,
            loaded: HashMap::new(),
            textures: Vec::new(),
        }
    }

    /// The texture of `stmt` in the MTL `mtl` (its name for messages and folder), or the
    /// one-line problem naming the material, the file and where it was looked for.
    pub fn load(
        &mut self,
        obj: &str,
        material: &str,
        mtl: &str,
        stmt: &MapStmt,
    ) -> Result<u32, String> {
        let written = Path::new(&stmt.file);
        let path = Path::new(mtl)
            .parent()
            .unwrap_or(Path::new(""))
            .join(written);
        let key = (path.clone(), stmt.wrap);
        if let Some(&i) = self.loaded.get(&key) {
            return Ok(i as u32);
        }
        match (self.source)(&path, stmt.wrap) {
            Ok(t) => {
                self.textures.push(t);
                let i = self.textures.len() - 1;
                self.loaded.insert(key, i);
                Ok(i as u32)
            }
            Err(why) => Err(format!(
                "{obj}: material `{material}` ({mtl}): map_Kd `{}` cannot be read at {} ({why}); \
                 the material renders with its colour Kd",
                stmt.file,
                path.display()
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_options_are_read_and_the_file_keeps_its_spaces() {
        let m = parse_map(&["duckCM.png"]).unwrap();
        assert_eq!((m.file.as_str(), m.wrap), ("duckCM.png", [Wrap::Repeat; 2]));
        let m = parse_map(&["-clamp", "on", "-bm", "2", "my", "wood.tga"]).unwrap();
        assert_eq!((m.file.as_str(), m.wrap), ("my wood.tga", [Wrap::Clamp; 2]));
        assert!(m.ignored.is_empty());
        let m = parse_map(&["-s", "2", "2", "-o", "0.5", "a.png"]).unwrap();
        assert_eq!(m.file, "a.png");
        assert_eq!(m.ignored, ["-s 2 2", "-o 0.5"]);
        assert!(parse_map(&["-clamp", "on"]).is_none());
    }

    #[test]
    fn an_mtl_names_its_diffuse_images_once() {
        let mtl = "newmtl a\nmap_Kd -clamp on tex/a b.png # comment\nmap_Ks s.png\n\
                   newmtl b\n  map_Kd tex/a b.png\nmap_Kd c.jpg\n";
        assert_eq!(mtl_texture_files(mtl), ["tex/a b.png", "c.jpg"]);
        assert!(mtl_texture_files("newmtl a\nKd 1 1 1\n").is_empty());
    }
}
