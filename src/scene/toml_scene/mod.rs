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

//!
//! The loader is split by job: `schema` is the file format as serde sees it, `build` turns
//! it into a [`Scene`] (transforms, materials, shapes, meshes), `animation` turns an
//! `[animation]` table into the scene's [`CameraPath`](crate::scene::CameraPath), and
//! `diagnostics` words the errors (file, line, dotted field, "did you mean"). This module
//! holds the entry points.

mod animation;
mod build;
mod diagnostics;
mod schema;

use std::path::{Path, PathBuf};

use super::Scene;
use crate::{Error, Result};

/// The built-in scene (a homage to Whitted's 1980 image), used when no scene file is given.
pub const DEFAULT_SCENE_TOML: &str = include_str!("../../../scenes/whitted.toml");

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

/// Loads a scene file; meshes resolve against its folder, then [`model_search_path`]. A
/// model file (`.obj`, `.ply`, `.gltf`, `.glb`) is a scene of its own, framed by a default
/// camera and light ([`load_model_scene`](crate::scene::load_model_scene)).
pub fn load_scene(path: &Path) -> Result<Scene> {
    if crate::scene::MeshFormat::of(path).is_some() {
        return crate::scene::load_model_scene(path);
    }
    load_scene_with_search_path(path, &model_search_path())
}

/// [`load_scene`] with an explicit mesh search path instead of `FRAGTRACE_MODEL_PATH`.
pub fn load_scene_with_search_path(path: &Path, search: &[PathBuf]) -> Result<Scene> {
    let bytes = super::read_input_file(path, MAX_SCENE_BYTES, "scene file")?;
    let text = String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let before = &e.as_bytes()[..at];
        let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
        let column = at
            - before
                .iter()
                .rposition(|&b| b == b'\n')
                .map_or(0, |i| i + 1)
            + 1;
        Error::scene(
            path.display().to_string(),
            line,
            format!("column {column}"),
            format!(
                "invalid UTF-8 (byte 0x{:02x}); a TOML scene must be UTF-8 text",
                e.as_bytes()[at]
            ),
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
    build::build_scene(text, name, build::Meshes::Files(base_dir, search))
}

/// Mesh files handed over as text with a scene: path or file name -> contents (OBJ or MTL).
pub type MeshTexts = std::collections::HashMap<String, String>;

/// Image files handed over with a scene: path or file name -> the file's bytes (PNG, JPEG
/// or TGA), the textures its meshes' MTL `map_Kd` statements name.
pub type MeshImages = std::collections::HashMap<String, Vec<u8>>;

/// Parses scene text whose meshes and their MTL libraries are in `files` (looked up by the
/// path the scene writes, else by its file name), without touching the file system: how
/// the web page loads a shipped or dropped scene with dropped or fetched OBJ files. Their
/// textures are not given: each `map_Kd` is one warning and the material keeps its colour
/// ([`load_scene_str_with_files`] takes the images too).
pub fn load_scene_str_with_texts(text: &str, name: &str, files: &MeshTexts) -> Result<Scene> {
    load_scene_str_with_files(text, name, files, &MeshImages::new())
}

/// [`load_scene_str_with_texts`] with the texture images in `images`, looked up by the path
/// the MTL writes joined to the OBJ's folder as the scene writes it
/// (`duck/duck.obj` + `duckCM.png`: `duck/duckCM.png`), else as written, else by file name. A `map_Kd` whose image is not there, or does not decode,
/// is one warning, as a missing file is natively.
pub fn load_scene_str_with_files(
    text: &str,
    name: &str,
    files: &MeshTexts,
    images: &MeshImages,
) -> Result<Scene> {
    build::build_scene(text, name, build::Meshes::Texts(files, images))
}

/// Parses scene text without touching the file system: any `mesh = ...` is an error naming
/// the object. For fuzzing and for checking a scene's syntax and values.
pub fn parse_scene_str(text: &str, name: &str) -> Result<Scene> {
    build::build_scene(text, name, build::Meshes::Refused)
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

#[cfg(test)]
mod animation_tests;
#[cfg(test)]
mod tests;
