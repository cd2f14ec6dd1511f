//! The scene builder's meshes (`toml_scene/build.rs`, split from it by job): the OBJ an
//! object names, found in the scene's folder and then the search path (or among the texts
//! handed over with the scene, on the web page), loaded once per file, with errors that
//! name the scene file, line and field that asked for it.

use std::path::{Path, PathBuf};
use std::rc::Rc;

use super::super::schema::S;
use super::super::MODEL_PATH_VAR;
use super::{Builder, Geometry, LoadedMesh, Meshes};
use crate::scene::model::{load_mesh_instanced, MeshFormat};
use crate::scene::obj::{no_textures, parse_obj_with, ObjMesh};
use crate::scene::{Texture, Wrap};
use crate::{Error, Result};

impl Builder<'_> {
    /// The mesh an object names, as geometry to place, and the mesh with its path key.
    pub(super) fn mesh_geometry(
        &mut self,
        path: &S<String>,
        field: &str,
    ) -> Result<(Geometry, Option<LoadedMesh>)> {
        let (mesh, path_key) = self.mesh(path, field)?;
        let g = Geometry {
            positions: mesh.positions.clone(),
            normals: mesh.normals.clone(),
            triangles: mesh.triangles.clone(),
            uvs: mesh.uvs.clone(),
            tri_uvs: mesh.tri_uvs.clone(),
            colors: mesh.colors.clone(),
        };
        Ok((g, Some((mesh, path_key))))
    }

    /// [`Builder::mesh`] from texts handed over with the scene: the OBJ (and each of its
    /// `mtllib`s) by the path written, else by its file name; the images its materials name
    /// from `images` the same way.
    fn mesh_from_text(
        &mut self,
        path: &S<String>,
        field: &str,
        texts: &super::super::MeshTexts,
        images: &super::super::MeshImages,
    ) -> Result<LoadedMesh> {
        let written = path.get_ref();
        let key = PathBuf::from(written);
        if let Some((m, _)) = self.meshes.get(&key) {
            return Ok((m.clone(), key));
        }
        let lookup = |p: &str| {
            texts
                .get(p)
                .or_else(|| texts.get(Path::new(p).file_name()?.to_str()?))
                .map(String::as_str)
        };
        let Some(obj) = lookup(written) else {
            let line = self.ctx.line_of(path.span().start);
            return Err(Error::Mesh {
                file: written.clone(),
                message: format!(
                    "mesh not given (referenced by {field} at {}:{line}); hand over {} with \
                     the scene",
                    self.ctx.name,
                    Path::new(written)
                        .file_name()
                        .map_or(written.clone(), |n| n.to_string_lossy().into_owned())
                ),
            });
        };
        let mtl = |m: &Path| {
            let shown = m.display().to_string();
            lookup(&shown)
                .map(|t| (shown.clone(), t.to_owned()))
                .ok_or_else(|| format!("{shown}: not given"))
        };
        // `p` is relative to the OBJ's folder (MTL paths are): first beside the OBJ as the
        // scene writes it, then as is, then by file name.
        let obj_dir = Path::new(written).parent().unwrap_or(Path::new(""));
        let image = |p: &Path, wrap: [Wrap; 2]| -> std::result::Result<Texture, String> {
            let bytes = images
                .get(&obj_dir.join(p).display().to_string())
                .or_else(|| images.get(&p.display().to_string()))
                .or_else(|| images.get(p.file_name()?.to_str()?))
                .ok_or("not given with the scene")?;
            Texture::decode(bytes, p.display().to_string(), wrap)
        };
        let parsed = match MeshFormat::of(Path::new(written)) {
            Some(MeshFormat::Ply) => crate::scene::parse_ply(obj.as_bytes(), written),
            Some(MeshFormat::Gltf) => crate::scene::parse_gltf_instanced(obj.as_bytes(), written),
            Some(MeshFormat::Obj) | None if images.is_empty() => {
                parse_obj_with(obj, written, &no_textures, &mtl)
            }
            Some(MeshFormat::Obj) | None => parse_obj_with(obj, written, &image, &mtl),
        };
        let mesh = Rc::new(parsed.map_err(|e| match e {
            Error::Mesh { .. } | Error::Io { .. } => {
                self.ctx.err(path.span(), field, e.to_string())
            }
            other => other,
        })?);
        self.warnings.extend(mesh.warnings.iter().cloned());
        self.meshes.insert(key.clone(), (mesh.clone(), None));
        Ok((mesh, key))
    }

    /// Resolves and loads (once per file) the mesh an object names, with the path it was
    /// found at as its key.
    pub(super) fn mesh(&mut self, path: &S<String>, field: &str) -> Result<(Rc<ObjMesh>, PathBuf)> {
        let written = path.get_ref();
        let (base_dir, search) = match self.files {
            Meshes::Refused => {
                return Err(self.ctx.err(
                    path.span(),
                    field,
                    "mesh files are not read by this text-only parser",
                ))
            }
            Meshes::Texts(texts, images) => return self.mesh_from_text(path, field, texts, images),
            Meshes::Files(base_dir, search) => (base_dir, search),
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
        // An error inside the mesh file names the file and its line or element; prefix the scene file, line
        // and object that loaded it, so a mesh shared by several scenes points at the right one.
        let mesh = Rc::new(load_mesh_instanced(&found).map_err(|e| match e {
            Error::Mesh { .. } | Error::Io { .. } => {
                self.ctx.err(path.span(), field, e.to_string())
            }
            other => other,
        })?);
        self.warnings.extend(mesh.warnings.iter().cloned());
        self.meshes.insert(found.clone(), (mesh.clone(), None));
        Ok((mesh, found))
    }
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
