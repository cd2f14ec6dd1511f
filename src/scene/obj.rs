//! Wavefront OBJ/MTL loading through `tobj`, mapped onto fragtrace's Whitted materials.
//!
//! `tobj` does the parsing and triangulation (fans, negative indices, `mtllib`), but it is
//! lenient in ways a renderer cannot afford: it accepts `nan`/`inf` coordinates, invents a
//! normal index for faces that have none, turns 3+-point `l` polylines into triangles and
//! panics on short colour lines in an MTL. So a cheap line scan runs first: it validates
//! numbers and indices with line numbers, records which faces carry normals, and strips
//! polylines; the MTL text is normalised before `tobj` sees it. The MTL→[`Material`] mapping
//! is documented in `docs/scene-format.md` and implemented by [`material_from_mtl`].

use std::cell::RefCell;
use std::collections::BTreeSet;
use std::io::Cursor;
use std::path::Path;

use glam::{Vec2, Vec3};

use super::obj_scan::{blank_lines, normalise_mtl, prescan};
use super::obj_textures::{MtlMaps, TexSource, TextureLoader};
use super::texture::Texture;
use super::{Material, Triangle, NO_NORMAL, NO_UV};
use crate::{Error, Result};

/// A loaded OBJ in its own object space.
#[derive(Clone, Debug, Default)]
pub struct ObjMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Unit vertex normals (only those some triangle references).
    pub normals: Vec<Vec3>,
    /// Triangles; `material` indexes [`ObjMesh::materials`], `n` is `[NO_NORMAL; 3]` for
    /// faces without usable normals.
    pub triangles: Vec<Triangle>,
    /// Materials from the MTL library, plus a trailing default grey one when some faces have
    /// no (known) material.
    pub materials: Vec<Material>,
    /// Texture coordinates (`vt`) some triangle references.
    pub uvs: Vec<Vec2>,
    /// Per triangle, the uv index of each corner into [`ObjMesh::uvs`] (`[NO_UV; 3]` for a
    /// face without `vt`); empty when no face has texture coordinates.
    pub tri_uvs: Vec<[u32; 3]>,
    /// Linear RGB vertex colours, one per position (`v x y z r g b`), or empty.
    pub colors: Vec<Vec3>,
    /// The images the materials' `map_Kd` name (`Material::diffuse_map` indexes this).
    pub textures: Vec<Texture>,
    /// One line per `map_Kd` that could not be read (the material keeps its colour).
    pub texture_problems: Vec<String>,
    /// Non-fatal problems (an unknown `usemtl` name, a texture map not used), one line each.
    pub warnings: Vec<String>,
    /// One line per `mtllib` that could not be read (missing, not a regular file, too
    /// large). The mesh then uses the default grey material; a scene rejects such a mesh
    /// unless the object overrides its materials (`material = ...`).
    pub missing_mtl: Vec<String>,
    /// Meshes several glTF nodes place, each stored once (only when loaded for instancing,
    /// `model::load_mesh_instanced`; else every placement is in
    /// [`ObjMesh::triangles`]): not part of [`ObjMesh::triangles`].
    pub shared: Vec<SharedMesh>,
}

/// A mesh several nodes of a glTF place: its triangles in the mesh's own space (indexing
/// the [`ObjMesh`]'s positions, normals and materials, without texture coordinates or
/// vertex colours) and each node's transform.
#[derive(Clone, Debug, Default)]
pub struct SharedMesh {
    /// The triangles, once.
    pub triangles: Vec<Triangle>,
    /// Their uv indices into [`ObjMesh::uvs`] (`[NO_UV; 3]` for a triangle without),
    /// parallel to `triangles`.
    pub tri_uvs: Vec<[u32; 3]>,
    /// The nodes' transforms (their parents' composed), in walk order.
    pub placements: Vec<glam::DMat4>,
}

/// Largest OBJ file read (checked before reading, so `/dev/zero` or a runaway file cannot
/// exhaust memory).
pub const MAX_OBJ_BYTES: u64 = 1 << 30;
/// Largest MTL file read.
pub const MAX_MTL_BYTES: u64 = 16 << 20;

/// Loads an OBJ file; `mtllib` paths resolve relative to the file's folder. Only regular
/// files of at most [`MAX_OBJ_BYTES`] are read.
pub fn load_obj(path: &Path) -> Result<ObjMesh> {
    let bytes = super::read_input_file(path, MAX_OBJ_BYTES, "OBJ mesh")?;
    // OBJ files in the wild are ASCII or Latin-1; a stray byte in a comment must not make
    // the whole mesh unloadable.
    let text = String::from_utf8_lossy(&bytes);
    let base_dir = path.parent().unwrap_or(Path::new("."));
    parse_obj(&text, &path.display().to_string(), base_dir)
}

/// Parses OBJ text. `name` is used in messages; `mtllib` paths resolve against `base_dir`.
pub fn parse_obj(text: &str, name: &str, base_dir: &Path) -> Result<ObjMesh> {
    let textures = |path: &Path, wrap| Texture::load(path, wrap);
    parse_obj_with(text, name, &textures, &|mtl: &Path| {
        let full = base_dir.join(mtl);
        let shown = full.display().to_string();
        match super::read_input_file(&full, MAX_MTL_BYTES, "MTL material library") {
            Ok(bytes) => Ok((shown, String::from_utf8_lossy(&bytes).into_owned())),
            Err(e) => Err(e.to_string()),
        }
    })
}

/// Parses OBJ text whose every `mtllib` is `mtl_text` (`None`: the library is missing),
/// without touching the file system; messages name the OBJ `<obj>` and the MTL `<mtl>`.
/// The fuzz target `obj_load` drives this.
pub fn parse_obj_with_mtl(obj_text: &str, mtl_text: Option<&str>) -> Result<ObjMesh> {
    parse_obj_with(
        obj_text,
        "<obj>",
        &no_textures,
        &|_: &Path| match mtl_text {
            Some(t) => Ok(("<mtl>".to_owned(), t.to_owned())),
            None => Err("<mtl>: not found".to_owned()),
        },
    )
}

/// The texture source of meshes given as text (the fuzz target, the web page): none.
pub(crate) fn no_textures(_: &Path, _: [super::Wrap; 2]) -> std::result::Result<Texture, String> {
    Err("not given: only meshes read from files bring their textures".into())
}

/// What an `mtllib` resolves to: (name for messages, text), or why it cannot be read.
pub(crate) type MtlSource<'a> = dyn Fn(&Path) -> std::result::Result<(String, String), String> + 'a;

/// [`parse_obj`] with the MTL libraries supplied by `mtl` and the texture images by
/// `textures` (given the path resolved against the MTL's folder).
pub(crate) fn parse_obj_with(
    text: &str,
    name: &str,
    textures: &TexSource<'_>,
    mtl: &MtlSource<'_>,
) -> Result<ObjMesh> {
    let scan = prescan(text, name)?;
    let filtered;
    let tobj_text: &str = if scan.polylines.is_empty() {
        text
    } else {
        filtered = blank_lines(text, &scan.polylines);
        &filtered
    };

    let mtl_problem: RefCell<Option<Error>> = RefCell::new(None);
    // Each MTL's texture statements, with the MTL's name (its folder resolves them).
    let maps: RefCell<Vec<(String, MtlMaps)>> = RefCell::new(Vec::new());
    let missing: RefCell<Vec<String>> = RefCell::new(Vec::new());
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let loaded = tobj::load_obj_buf(&mut Cursor::new(tobj_text), &options, |mtl_path| match mtl(
        mtl_path,
    ) {
        Ok((file, text)) => match normalise_mtl(&text, &file) {
            Ok((fixed, m)) => {
                maps.borrow_mut().push((file, m));
                tobj::load_mtl_buf(&mut Cursor::new(fixed))
            }
            Err(e) => {
                mtl_problem.borrow_mut().get_or_insert(e);
                Err(tobj::LoadError::MaterialParseError)
            }
        },
        Err(why) => {
            let written = mtl_path.display().to_string();
            let line = scan
                .mtllib
                .iter()
                .find(|(_, l)| l.contains(written.as_str()))
                .map(|(n, _)| format!("line {}: ", n + 1))
                .unwrap_or_default();
            missing.borrow_mut().push(format!(
                "{name}: {line}mtllib `{written}`: cannot read the material library ({why})"
            ));
            Err(tobj::LoadError::OpenFileFailed)
        }
    });
    if let Some(e) = mtl_problem.into_inner() {
        return Err(e);
    }
    let (models, tobj_materials) = loaded.map_err(|e| Error::Mesh {
        file: name.into(),
        message: format!("cannot parse OBJ: {e}"),
    })?;
    let mut warnings = Vec::new();
    let tobj_materials = tobj_materials.unwrap_or_default();

    let mut mesh = ObjMesh::default();
    let mut material_names = BTreeSet::new();
    let maps = maps.into_inner();
    let mut loader = TextureLoader::new(textures);
    for m in &tobj_materials {
        material_names.insert(m.name.as_str());
        let mut material = material_from_mtl(m);
        // The last library that defines the material wins, as in tobj.
        for (mtl_name, lib) in maps.iter().rev() {
            if let Some(stmt) = lib.kd.get(&m.name) {
                match loader.load(name, &m.name, mtl_name, stmt) {
                    Ok(t) => material.diffuse_map = Some(t),
                    Err(problem) => mesh.texture_problems.push(problem),
                }
                if !stmt.ignored.is_empty() {
                    warnings.push(format!(
                        "{name}: material `{}`: map_Kd options {} ignored (not supported)",
                        m.name,
                        stmt.ignored.join(", ")
                    ));
                }
                break;
            }
        }
        if let Some(unused) = maps
            .iter()
            .rev()
            .find_map(|(_, lib)| lib.unused.get(&m.name))
        {
            warnings.push(format!(
                "{name}: material `{}`: {} ignored (fragtrace textures the diffuse colour only: map_Kd)",
                m.name,
                unused.join(", ")
            ));
        }
        mesh.materials.push(material);
    }
    mesh.textures = loader.textures;
    for used in &scan.usemtl {
        if !material_names.contains(used.as_str()) {
            warnings.push(format!(
                "{name}: usemtl `{used}` is not defined in any loaded MTL; using the default grey material"
            ));
        }
    }

    let total_tris: usize = models.iter().map(|m| m.mesh.indices.len() / 3).sum();
    // The scan's per-face flags line up with tobj's triangles because tobj emits models in
    // file order and triangulates each face into n-2 triangles; if that ever stops holding,
    // trusting tobj's normal indices is the safe degradation.
    let flags_match = scan.tri_has_normals.len() == total_tris;
    let uv_flags_match = scan.tri_has_uvs.len() == total_tris;
    let any_uvs = scan.tri_has_uvs.iter().any(|&b| b);
    let coloured = scan.colours == Some(true);
    if total_tris > u32::MAX as usize / 3 {
        return Err(Error::Mesh {
            file: name.into(),
            message: format!("{total_tris} triangles exceed the supported index range"),
        });
    }
    mesh.triangles.reserve(total_tris);

    let mut default_material: Option<u32> = None;
    let mut tri_index = 0usize;
    for model in &models {
        let m = &model.mesh;
        let pos_base = mesh.positions.len() as u32;
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2])),
        );
        if coloured {
            if m.vertex_color.len() != m.positions.len() {
                return Err(Error::Mesh {
                    file: name.into(),
                    message: "vertex colours do not match the vertices".into(),
                });
            }
            mesh.colors.extend(
                m.vertex_color
                    .chunks_exact(3)
                    .map(|c| Vec3::new(c[0], c[1], c[2])),
            );
        }
        let uv_base = mesh.uvs.len() as u32;
        mesh.uvs
            .extend(m.texcoords.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])));
        let has_uv_data = !m.texcoord_indices.is_empty() && !m.texcoords.is_empty();
        // Model-local normal index -> slot in mesh.normals, filled on first use so that only
        // referenced, non-degenerate normals are kept.
        let mut normal_slot: Vec<u32> = vec![u32::MAX; m.normals.len() / 3];
        let material = match m.material_id {
            Some(i) if i < mesh.materials.len() => i as u32,
            _ => *default_material.get_or_insert_with(|| {
                mesh.materials.push(Material {
                    name: format!("{name}:default"),
                    ..Material::default()
                });
                (mesh.materials.len() - 1) as u32
            }),
        };
        let has_normal_data = !m.normal_indices.is_empty() && !m.normals.is_empty();
        for (t, idx) in m.indices.chunks_exact(3).enumerate() {
            let face_has_normals = if flags_match {
                scan.tri_has_normals[tri_index]
            } else {
                true
            };
            let face_has_uvs = !uv_flags_match || scan.tri_has_uvs[tri_index];
            tri_index += 1;
            let v = [idx[0] + pos_base, idx[1] + pos_base, idx[2] + pos_base];
            if any_uvs {
                let uv = if face_has_uvs && has_uv_data {
                    let local = &m.texcoord_indices[3 * t..3 * t + 3];
                    [local[0], local[1], local[2]].map(|k| k + uv_base)
                } else {
                    [NO_UV; 3]
                };
                mesh.tri_uvs.push(uv);
            }
            let mut n = [NO_NORMAL; 3];
            if face_has_normals && has_normal_data {
                let local = &m.normal_indices[3 * t..3 * t + 3];
                let usable = local.iter().all(|&k| {
                    let k = k as usize;
                    Vec3::new(m.normals[3 * k], m.normals[3 * k + 1], m.normals[3 * k + 2])
                        .try_normalize()
                        .is_some()
                });
                // A zero (or denormal) normal has no direction; the face normal is the only
                // honest fallback, and it must replace all three so shading stays consistent.
                if usable {
                    for (slot, &k) in n.iter_mut().zip(local) {
                        let k = k as usize;
                        if normal_slot[k] == u32::MAX {
                            let nv = Vec3::new(
                                m.normals[3 * k],
                                m.normals[3 * k + 1],
                                m.normals[3 * k + 2],
                            );
                            mesh.normals.push(nv.normalize());
                            normal_slot[k] = (mesh.normals.len() - 1) as u32;
                        }
                        *slot = normal_slot[k];
                    }
                }
            }
            mesh.triangles.push(Triangle { v, n, material });
        }
    }
    if mesh.positions.len() > u32::MAX as usize {
        return Err(Error::Mesh {
            file: name.into(),
            message: format!(
                "{} vertices exceed the supported index range",
                mesh.positions.len()
            ),
        });
    }
    if mesh.triangles.is_empty() {
        // Not an error (an empty placeholder renders as nothing), but never silent.
        // (tobj keeps no vertices without faces, so the two cases read the same here.)
        warnings.push(format!(
            "{name}: no faces, so no triangles; the object adds nothing to the scene"
        ));
    }
    mesh.warnings = warnings;
    mesh.missing_mtl = missing.into_inner();
    Ok(mesh)
}

/// Maps one MTL material onto the Whitted model (see the table in `docs/scene-format.md`).
///
/// - `Kd` → `albedo` (0.8 grey when absent); `ka` = `kd` = opacity (1 for opaque), so the
///   ambient term is `ambient · albedo` and `Ka` is ignored: exporters write `Ka` as a copy
///   of `Kd`, as 0 or as 1, none of which means "ambient factor".
/// - `Ks` → `ks` for illum ≥ 2, `Ns` → `ns` (at least 1).
/// - illum 3, 5, 8: mirror, `kr = Ks`; illum 4, 6, 9: glass, `kr = Ks`, `kt = (1 - opacity)·Tf`;
///   illum 7: dielectric with `fresnel = true` and `ior = Ni`.
/// - `d` < 1 (or `Tr` > 0 without `d`) on any other model: see-through with `ior` = 1.
/// - `Ke` is ignored: fragtrace only has point lights.
pub fn material_from_mtl(m: &tobj::Material) -> Material {
    let illum = m.illumination_model.unwrap_or(2);
    let ks = m.specular.map(Vec3::from_array).unwrap_or(Vec3::ZERO);
    let tf = m
        .unknown_param
        .get("Tf")
        .and_then(|s| parse_color(s))
        .unwrap_or(Vec3::ONE);
    let tr = m
        .unknown_param
        .get("Tr")
        .and_then(|s| s.split_whitespace().next()?.parse::<f32>().ok());
    let glass = matches!(illum, 4 | 6 | 7 | 9);
    // `d` wins over `Tr` because some old exporters wrote Tr as an opacity; when a glass
    // model gives neither, it is clear glass.
    let opacity = match (m.dissolve, tr) {
        (Some(d), _) => d,
        (None, Some(tr)) => 1.0 - tr,
        (None, None) if glass => 0.0,
        (None, None) => 1.0,
    }
    .clamp(0.0, 1.0);
    let transmit = (1.0 - opacity) * tf;
    let ior = m
        .optical_density
        .filter(|n| n.is_finite() && *n > 0.0)
        .unwrap_or(1.0);

    let mut out = Material {
        name: m.name.clone(),
        albedo: m.diffuse.map(Vec3::from_array).unwrap_or(Vec3::splat(0.8)),
        ka: opacity,
        kd: opacity,
        ks: if illum >= 2 { ks } else { Vec3::ZERO },
        ns: m.shininess.unwrap_or(1.0).max(1.0),
        ..Material::default()
    };
    match illum {
        3 | 5 | 8 => out.kr = ks,
        4 | 6 | 9 => {
            out.kr = ks;
            out.kt = transmit;
            out.ior = ior;
        }
        7 => {
            out.fresnel = true;
            out.ior = ior;
        }
        _ => {}
    }
    if !glass && opacity < 1.0 {
        // Dissolve, not refraction: light passes straight through.
        out.kt = transmit;
        out.ior = 1.0;
    }
    out
}

fn parse_color(s: &str) -> Option<Vec3> {
    let v: Vec<f32> = s
        .split_whitespace()
        .map(str::parse)
        .collect::<std::result::Result<_, _>>()
        .ok()?;
    match v[..] {
        [g] => Some(Vec3::splat(g)),
        [r, g, b] => Some(Vec3::new(r, g, b)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn models_dir() -> PathBuf {
        PathBuf::from(
            std::env::var("FRAGTRACE_MODEL_PATH")
                .ok()
                .and_then(|p| p.split(':').find(|s| !s.is_empty()).map(str::to_owned))
                .unwrap_or_else(|| concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/models").into()),
        )
    }

    fn tmpdir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("fragtrace-obj-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn mesh_err(r: Result<ObjMesh>) -> String {
        match r {
            Err(Error::Mesh { file, message }) => format!("{file}: {message}"),
            other => panic!("expected a mesh error, got {other:?}"),
        }
    }

    #[test]
    fn nan_and_inf_coordinates_are_errors_with_line_numbers() {
        let e = mesh_err(parse_obj(
            "v 0 0 0\nv 1 0 0\n\nv 0 nan 0\nf 1 2 3\n",
            "bad.obj",
            Path::new("."),
        ));
        assert!(e.starts_with("bad.obj: line 4:"), "{e}");
        assert!(e.contains("non-finite"), "{e}");
        let e = mesh_err(parse_obj(
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 inf\nf 1//1 2//1 3//1\n",
            "n.obj",
            Path::new("."),
        ));
        assert!(e.contains("line 4") && e.contains("normal"), "{e}");
        // Overflowing f32 is as bad as a literal inf.
        let e = mesh_err(parse_obj("v 0 0 1e39\n", "big.obj", Path::new(".")));
        assert!(e.contains("line 1"), "{e}");
    }

    #[test]
    fn face_index_out_of_range_is_an_error() {
        for (src, line) in [
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", 4),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 -2 -1\n", 4),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 4),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//2 3//1\n", 5),
        ] {
            let e = mesh_err(parse_obj(src, "idx.obj", Path::new(".")));
            assert!(
                e.contains(&format!("line {line}:")) && e.contains("out of range"),
                "{e}"
            );
        }
    }

    #[test]
    fn normals_only_where_the_face_has_them_and_zero_normals_fall_back() {
        let src = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n\
                   vn 0 0 2\nvn 0 0 0\n\
                   f 1//1 2//1 3//1\n\
                   f 2 4 3\n\
                   f 2//1 4//2 3//1\n\
                   f 1//1 2//1 4//1 3//1\n";
        let m = parse_obj(src, "mixed.obj", Path::new(".")).unwrap();
        assert_eq!(m.triangles.len(), 5);
        assert!(m.triangles[0].has_normals());
        assert!(
            !m.triangles[1].has_normals(),
            "face without vn must be flat"
        );
        assert!(!m.triangles[2].has_normals(), "zero normal must fall back");
        assert!(m.triangles[3].has_normals() && m.triangles[4].has_normals());
        // Normalised, and only the referenced one kept.
        assert_eq!(m.normals, vec![Vec3::Z]);
        // No mtllib: one default material, no warnings.
        assert_eq!(m.materials.len(), 1);
        assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    }

    #[test]
    fn polylines_and_points_are_not_triangles() {
        let src = "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\np 1\nl 1 2\nf 1 2 3\n";
        let m = parse_obj(src, "lines.obj", Path::new(".")).unwrap();
        assert_eq!(m.triangles.len(), 1);
    }

    #[test]
    fn missing_mtl_is_recorded_and_uses_grey() {
        let src = "mtllib nowhere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n";
        let m = parse_obj(src, "m.obj", &tmpdir("missing")).unwrap();
        assert_eq!(m.materials.len(), 1);
        assert_eq!(m.materials[0].albedo, Vec3::splat(0.8));
        assert!(
            m.missing_mtl.len() == 1
                && m.missing_mtl[0].contains("nowhere.mtl")
                && m.missing_mtl[0].contains("line 1:"),
            "{:?}",
            m.missing_mtl
        );
        assert!(
            m.warnings.iter().any(|w| w.contains("`red`")),
            "{:?}",
            m.warnings
        );
    }

    #[test]
    fn mtl_mapping_follows_the_documented_table() {
        let dir = tmpdir("mtl");
        std::fs::write(
            dir.join("t.mtl"),
            "newmtl plain\nKd 0.5\nKs 0.3 0.3 0.3\nNs 50\nillum 1\n\
             newmtl shiny\nKd 0.1 0.2 0.3\nKs 0.3 0.3 0.3\nNs 0\nillum 2\nKe 5 5 5\n\
             newmtl mirror\nKs 0.9 0.8 0.7\nillum 3\n\
             newmtl glass\nKs 0.1 0.1 0.1\nTf 0.9 1 0.9\nNi 1.5\nillum 4\n\
             newmtl dielectric\nNi 1.33\nillum 7\n\
             newmtl veil\nKd 1 0 0\nd 0.25\nillum 2\nNi 1.7\n\
             newmtl oldtr\nTr 0.5\nillum 6\nNi 1.2\n",
        )
        .unwrap();
        let src = "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n\
                   usemtl plain\nf 1 2 3\nusemtl shiny\nf 1 2 3\nusemtl mirror\nf 1 2 3\n\
                   usemtl glass\nf 1 2 3\nusemtl dielectric\nf 1 2 3\nusemtl veil\nf 1 2 3\n\
                   usemtl oldtr\nf 1 2 3\n";
        let m = parse_obj(src, "t.obj", &dir).unwrap();
        assert!(m.warnings.is_empty(), "{:?}", m.warnings);
        let by = |n: &str| m.materials.iter().find(|x| x.name == n).unwrap().clone();
        let plain = by("plain");
        assert_eq!(plain.albedo, Vec3::splat(0.5), "one-component Kd expands");
        assert_eq!(plain.ks, Vec3::ZERO, "illum 1 drops the highlight");
        assert!(!plain.reflects() && !plain.refracts());
        let shiny = by("shiny");
        assert_eq!((shiny.ks, shiny.ns, shiny.ka), (Vec3::splat(0.3), 1.0, 1.0));
        let mirror = by("mirror");
        assert_eq!(mirror.kr, Vec3::new(0.9, 0.8, 0.7));
        assert!(!mirror.refracts());
        let glass = by("glass");
        assert_eq!(
            (glass.kr, glass.kt, glass.ior),
            (Vec3::splat(0.1), Vec3::new(0.9, 1.0, 0.9), 1.5)
        );
        assert_eq!(glass.kd, 0.0, "clear glass has no diffuse term");
        let d = by("dielectric");
        assert!(d.fresnel && d.ior == 1.33);
        let veil = by("veil");
        assert_eq!((veil.kt, veil.ior, veil.kd), (Vec3::splat(0.75), 1.0, 0.25));
        let oldtr = by("oldtr");
        assert_eq!((oldtr.kt, oldtr.ior), (Vec3::splat(0.5), 1.2));
        // Triangles point at the right materials.
        let names: Vec<_> = m
            .triangles
            .iter()
            .map(|t| m.materials[t.material as usize].name.as_str())
            .collect();
        assert_eq!(
            names,
            [
                "plain",
                "shiny",
                "mirror",
                "glass",
                "dielectric",
                "veil",
                "oldtr"
            ]
        );
    }

    #[test]
    fn negative_mtl_colours_are_errors_naming_the_line() {
        let dir = tmpdir("mtlneg");
        for (i, stmt) in ["Kd -0.5", "Ks 0.2 -0.1 0.2", "Tf 1 1 -1e-9"]
            .iter()
            .enumerate()
        {
            let name = format!("n{i}.mtl");
            std::fs::write(dir.join(&name), format!("newmtl a\nillum 4\n{stmt}\n")).unwrap();
            let obj = format!("mtllib {name}\nv 0 0 0\n");
            let e = mesh_err(parse_obj(&obj, "n.obj", &dir));
            assert!(
                e.contains(&name) && e.contains("line 3") && e.contains(">= 0"),
                "{e}"
            );
        }
        // Ka and Ke are not read (see material_from_mtl), so they may be anything finite.
        std::fs::write(dir.join("ok.mtl"), "newmtl a\nKa -1 0 0\nKe -1\n").unwrap();
        let obj = "mtllib ok.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        let m = parse_obj(obj, "n.obj", &dir).unwrap();
        assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    }

    #[test]
    fn mtl_with_nan_is_an_error_naming_the_mtl() {
        let dir = tmpdir("mtlnan");
        std::fs::write(dir.join("n.mtl"), "newmtl a\nKd 0.5 nan 0.5\n").unwrap();
        let e = mesh_err(parse_obj("mtllib n.mtl\nv 0 0 0\n", "n.obj", &dir));
        assert!(e.contains("n.mtl") && e.contains("line 2"), "{e}");
    }

    #[test]
    fn cornell_box_loads_with_negative_indices_and_materials() {
        let path = models_dir().join("cornell_box/CornellBox-Original.obj");
        let m = load_obj(&path).unwrap();
        assert!(m.warnings.is_empty(), "{:?}", m.warnings);
        assert_eq!(m.triangles.len(), 36);
        assert_eq!(m.materials.len(), 8, "8 MTL materials, no default needed");
        let mat = |i: usize| &m.materials[m.triangles[i].material as usize];
        // The floor is the first quad.
        assert_eq!(mat(0).name, "floor");
        assert!(m.triangles.iter().all(|t| !t.has_normals()));
        let left = m.materials.iter().find(|x| x.name == "leftWall").unwrap();
        assert_eq!(left.albedo, Vec3::new(0.63, 0.065, 0.05));
        assert!(!left.reflects() && !left.refracts());
        // Negative indices resolved against the right vertices: the floor lies at y = 0 and
        // the light quad at y = 1.98.
        for t in 0..2 {
            for &v in &m.triangles[t].v {
                assert_eq!(m.positions[v as usize].y, 0.0);
            }
        }
        let light: Vec<_> = m
            .triangles
            .iter()
            .filter(|t| m.materials[t.material as usize].name == "light")
            .collect();
        assert_eq!(light.len(), 2);
        for t in light {
            for &v in &t.v {
                assert_eq!(m.positions[v as usize].y, 1.98);
            }
        }
        let lo = m.positions.iter().copied().reduce(Vec3::min).unwrap();
        let hi = m.positions.iter().copied().reduce(Vec3::max).unwrap();
        assert!(lo.abs_diff_eq(Vec3::new(-1.02, 0.0, -1.04), 1e-6), "{lo}");
        assert!(hi.abs_diff_eq(Vec3::new(1.0, 1.99, 0.99), 1e-6), "{hi}");
    }

    #[test]
    fn dragon_zero_normals_fall_back_and_others_are_unit() {
        let m = load_obj(&models_dir().join("dragon/dragon.obj")).unwrap();
        assert_eq!(m.triangles.len(), 47_794);
        let smooth = m.triangles.iter().filter(|t| t.has_normals()).count();
        assert!(smooth > 40_000 && smooth < m.triangles.len(), "{smooth}");
        for n in &m.normals {
            assert!((n.length() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn duck_and_table_bring_their_uvs_and_textures() {
        let duck = load_obj(&models_dir().join("duck/duck.obj")).unwrap();
        assert_eq!(duck.tri_uvs.len(), duck.triangles.len());
        assert!(duck.tri_uvs.iter().all(|t| t[0] != NO_UV));
        assert!(
            duck.texture_problems.is_empty(),
            "{:?}",
            duck.texture_problems
        );
        assert_eq!(duck.textures.len(), 1);
        let t = &duck.textures[0];
        assert!(t.source.ends_with("duck/duckCM.png"), "{}", t.source);
        assert_eq!(
            (t.levels[0].width, t.levels[0].height, t.levels.len()),
            (512, 512, 10)
        );
        assert_eq!(duck.materials[0].diffuse_map, Some(0));
        assert!(duck.colors.is_empty());
        let table = load_obj(&models_dir().join("table/table.obj")).unwrap();
        assert_eq!(table.uvs.len(), 4);
        assert_eq!(table.tri_uvs[0], [0, 1, 2]);
        assert_eq!(table.textures[0].levels[0].width, 1024);
        // map_Ka is ignored without a word, as Ka is.
        assert!(table.warnings.is_empty(), "{:?}", table.warnings);
    }

    #[test]
    fn a_missing_texture_is_one_line_naming_material_file_and_place() {
        let dir = tmpdir("notex");
        std::fs::write(
            dir.join("m.mtl"),
            "newmtl wood\nKd 0.5 0.4 0.3\nmap_Kd -clamp on gone.png\nmap_Ks spec.png\n",
        )
        .unwrap();
        let obj = "mtllib m.mtl\nusemtl wood\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
        let m = parse_obj(obj, "w.obj", &dir).unwrap();
        assert_eq!(m.texture_problems.len(), 1, "{:?}", m.texture_problems);
        let p = &m.texture_problems[0];
        let at = dir.join("gone.png").display().to_string();
        assert!(
            p.contains("`wood`")
                && p.contains("`gone.png`")
                && p.contains(&at)
                && !p.contains('\n'),
            "{p}"
        );
        assert_eq!(m.materials[0].diffuse_map, None);
        assert_eq!(m.materials[0].albedo, Vec3::new(0.5, 0.4, 0.3));
        assert!(
            m.warnings.len() == 1 && m.warnings[0].contains("map_Ks"),
            "{:?}",
            m.warnings
        );
    }

    #[test]
    fn bad_texture_coordinates_and_colours_are_errors_with_line_numbers() {
        for (src, line, what) in [
            ("v 0 0 0\nvt 0 nan\n", 2, "non-finite texture"),
            ("v 0 0 0\nvt 0.5\n", 2, "two coordinates"),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n",
                5,
                "texture index 2 out of range",
            ),
            ("v 0 0 0 1 0 0\nv 1 0 0\n", 2, "some vertices only"),
            ("v 0 0 0 1 -1 0\n", 1, "colour"),
        ] {
            let e = mesh_err(parse_obj(src, "uv.obj", Path::new(".")));
            assert!(
                e.contains(&format!("line {line}:")) && e.contains(what),
                "{e}"
            );
        }
    }

    #[test]
    fn vertex_colours_and_partial_uvs_are_kept_per_vertex_and_face() {
        let src = "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nv 1 1 0 1 1 1\nvt 0.25 0.75\n\
                   f 1/1 2/1 3/1\nf 2 4 3\n";
        let m = parse_obj(src, "c.obj", Path::new(".")).unwrap();
        assert_eq!(m.colors, [Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE]);
        assert_eq!(m.uvs, [Vec2::new(0.25, 0.75)]);
        assert_eq!(m.tri_uvs, [[0, 0, 0], [NO_UV; 3]]);
    }
}
