//! glTF 2.0 loading (`.gltf` with external or embedded buffers and images, `.glb`) through
//! the `gltf` crate, into the mesh structure OBJ loading produces ([`ObjMesh`]), so a scene
//! takes `mesh = "x.glb"` exactly as an OBJ.
//!
//! The crate parses and validates the document (indices that name objects, required
//! extensions); the bytes are read here: buffers (the GLB's `BIN` chunk, base64 data URIs,
//! files beside the document), accessors with checked arithmetic (a range past its buffer
//! view or buffer is an error naming the accessor and what it holds, never a panic), and
//! images decoded by [`Texture::decode`]. The default scene's node hierarchy is walked with
//! each node's transform composed in f64 (positions by the matrix, normals by its inverse
//! transpose, the winding reversed where it mirrors); every mesh a node names is emitted,
//! each primitive in TRIANGLES mode with its POSITION, NORMAL, TEXCOORD_0 (v flipped: glTF's
//! v runs down the image, fragtrace's up) and COLOR_0. Materials map as
//! `gltf_material.rs` says; what is not read is named in one warning line.

use std::collections::{BTreeSet, HashMap};
use std::path::Path;

use glam::{DMat3, DMat4, DQuat, DVec3, Vec2, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::{Mode, Semantic};

use super::gltf_data::{
    load_buffers, mesh_err, read_accessor, read_uri, short, view_bytes, Files, Role,
};
use super::gltf_material::material_from_gltf;
use super::texture::{Texture, Wrap};
use super::{Material, ObjMesh, Triangle, NO_NORMAL, NO_UV};
use crate::{Error, Result};

pub use super::gltf_data::MAX_GLTF_BYTES;
/// Deepest node hierarchy walked (deeper is taken for a cycle).
pub const MAX_NODE_DEPTH: usize = 64;
/// Most triangles a file may expand to once its nodes instance their meshes.
pub const MAX_GLTF_TRIANGLES: usize = 1 << 27;

/// Loads a `.gltf` or `.glb` file (a regular file of at most [`MAX_GLTF_BYTES`]); external
/// buffers and images resolve against its folder.
pub fn load_gltf(path: &Path) -> Result<ObjMesh> {
    let bytes = super::read_input_file(path, MAX_GLTF_BYTES, "glTF model")?;
    let base = path.parent().unwrap_or(Path::new("."));
    parse_gltf_with(&bytes, &path.display().to_string(), Some(base), false)
}

/// [`load_gltf`] with each mesh that several nodes place (and that has no texture
/// coordinates, vertex colours or textured material) stored once in
/// [`ObjMesh::shared`] with the nodes' transforms: what a scene's instancing takes.
pub fn load_gltf_instanced(path: &Path) -> Result<ObjMesh> {
    let bytes = super::read_input_file(path, MAX_GLTF_BYTES, "glTF model")?;
    let base = path.parent().unwrap_or(Path::new("."));
    parse_gltf_with(&bytes, &path.display().to_string(), Some(base), true)
}

/// [`parse_gltf`] with shared meshes stored once, as [`load_gltf_instanced`].
pub fn parse_gltf_instanced(bytes: &[u8], name: &str) -> Result<ObjMesh> {
    parse_gltf_with(bytes, name, None, true)
}

/// Parses glTF JSON or GLB bytes without touching the file system (external buffers are
/// errors, external images texture problems); `name` is used in messages. The fuzz target
/// `gltf_load` drives this.
pub fn parse_gltf(bytes: &[u8], name: &str) -> Result<ObjMesh> {
    parse_gltf_with(bytes, name, None, false)
}

fn parse_gltf_with(bytes: &[u8], name: &str, files: Files<'_>, share: bool) -> Result<ObjMesh> {
    let err = |m: String| mesh_err(name, m);
    // The crate subtracts the header size from the GLB's length field unchecked.
    if bytes.starts_with(b"glTF") {
        let len = bytes
            .get(8..12)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        if len.is_none_or(|l| l < 12) {
            return Err(err(
                "GLB header: length field shorter than the header".into()
            ));
        }
    }
    let g = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| err(one_line(&e.to_string())))?;
    // The crate's validation indexes the accessors by each primitive's POSITION before it
    // checks that index (a panic on a bad one): check it first.
    let json = g.document.into_json();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let pos = gltf::json::validation::Checked::Valid(Semantic::Positions);
            if let Some(a) = prim.attributes.get(&pos) {
                if a.value() >= json.accessors.len() {
                    return Err(err(format!(
                        "meshes[{m}].primitives[{p}].attributes.POSITION: accessor {} does not \
                         exist ({} accessors)",
                        a.value(),
                        json.accessors.len()
                    )));
                }
            }
        }
    }
    let document = gltf::Document::from_json(json).map_err(|e| err(one_line(&e.to_string())))?;
    let doc = &document;
    let buffers = load_buffers(doc, g.blob, name, files)?;
    let mut b = Builder {
        name,
        doc,
        buffers: &buffers,
        files,
        mesh: ObjMesh::default(),
        materials: HashMap::new(),
        textures: HashMap::new(),
        ignored: BTreeSet::new(),
        any_uv: false,
        any_color: false,
        skipped_modes: BTreeSet::new(),
        share,
        first_shared: None,
    };
    b.walk()?;
    b.finish()
}

/// A message of the crate (JSON errors, validation lists) on one line.
fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The scene walk's state: the mesh being built and what was loaded once.
struct Builder<'a> {
    name: &'a str,
    doc: &'a gltf::Document,
    buffers: &'a [Vec<u8>],
    files: Files<'a>,
    mesh: ObjMesh,
    /// glTF material index (None: no material) -> index in `mesh.materials`.
    materials: HashMap<Option<usize>, u32>,
    /// (image index, wrap) -> index in `mesh.textures`, or `None` once it failed.
    textures: HashMap<(usize, [Wrap; 2]), Option<u32>>,
    /// What the file has that fragtrace does not read, for the one warning line.
    ignored: BTreeSet<String>,
    any_uv: bool,
    any_color: bool,
    skipped_modes: BTreeSet<String>,
    /// Whether meshes several nodes place are stored once ([`ObjMesh::shared`]).
    share: bool,
    /// The first triangle of the shared meshes, emitted after every other.
    first_shared: Option<usize>,
}

/// A node's local transform in f64.
fn node_matrix(node: &gltf::Node<'_>) -> DMat4 {
    match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            DMat4::from_cols_array_2d(&matrix.map(|c| c.map(|x| x as f64)))
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let [x, y, z, w] = rotation.map(|c| c as f64);
            let q = DQuat::from_xyzw(x, y, z, w);
            let q = if q.length_squared() > 0.0 {
                q.normalize()
            } else {
                DQuat::IDENTITY
            };
            DMat4::from_scale_rotation_translation(
                DVec3::from_array(scale.map(|c| c as f64)),
                q,
                DVec3::from_array(translation.map(|c| c as f64)),
            )
        }
    }
}

impl Builder<'_> {
    fn err(&self, m: String) -> Error {
        mesh_err(self.name, m)
    }

    /// Walks the default scene (else the first; without scenes, every root node).
    fn walk(&mut self) -> Result<()> {
        let doc = self.doc;
        let roots: Vec<gltf::Node<'_>> = match doc.default_scene().or_else(|| doc.scenes().next()) {
            Some(s) => s.nodes().collect(),
            None => {
                let children: BTreeSet<usize> = doc
                    .nodes()
                    .flat_map(|n| n.children().map(|c| c.index()).collect::<Vec<_>>())
                    .collect();
                doc.nodes()
                    .filter(|n| !children.contains(&n.index()))
                    .collect()
            }
        };
        let mut placed = Vec::new();
        let mut stack: Vec<(gltf::Node<'_>, DMat4, usize)> = roots
            .into_iter()
            .rev()
            .map(|n| (n, DMat4::IDENTITY, 0))
            .collect();
        while let Some((node, parent, depth)) = stack.pop() {
            if depth >= MAX_NODE_DEPTH {
                return Err(self.err(format!(
                    "node {}: the node hierarchy is deeper than {MAX_NODE_DEPTH} (a cycle?)",
                    node.index()
                )));
            }
            let m = parent * node_matrix(&node);
            if let Some(mesh) = node.mesh() {
                placed.push((mesh, m, node.index()));
            }
            for c in node.children().collect::<Vec<_>>().into_iter().rev() {
                stack.push((c, m, depth + 1));
            }
        }
        // A mesh several nodes place is stored once when sharing (with its texture
        // coordinates and vertex colours); every other placement is emitted placed.
        let mut uses: HashMap<usize, usize> = HashMap::new();
        for (mesh, _, _) in &placed {
            *uses.entry(mesh.index()).or_default() += 1;
        }
        let mut shared: Vec<(gltf::Mesh<'_>, Vec<DMat4>, usize)> = Vec::new();
        for (mesh, m, node) in placed {
            if self.share && uses[&mesh.index()] > 1 {
                match shared.iter_mut().find(|s| s.0.index() == mesh.index()) {
                    Some(s) => s.1.push(m),
                    None => shared.push((mesh, vec![m], node)),
                }
                continue;
            }
            for prim in mesh.primitives() {
                self.primitive(&mesh, &prim, &m, node)?;
            }
        }
        for (mesh, placements, node) in shared {
            let t0 = self.mesh.triangles.len();
            self.first_shared.get_or_insert(t0);
            for prim in mesh.primitives() {
                self.primitive(&mesh, &prim, &DMat4::IDENTITY, node)?;
            }
            let t1 = self.mesh.triangles.len();
            self.mesh.shared.push(super::obj::SharedMesh {
                triangles: self.mesh.triangles[t0..t1].to_vec(),
                tri_uvs: self.mesh.tri_uvs[t0..t1].to_vec(),
                placements,
            });
        }
        for (what, present) in [
            ("cameras", doc.cameras().len() > 0),
            ("skins", doc.skins().len() > 0),
            ("animations", doc.animations().len() > 0),
        ] {
            if present {
                self.ignored.insert(what.into());
            }
        }
        for e in doc.extensions_used() {
            if !["KHR_materials_transmission", "KHR_materials_ior"].contains(&e) {
                self.ignored.insert(format!("extension {e}"));
            }
        }
        Ok(())
    }

    fn primitive(
        &mut self,
        mesh: &gltf::Mesh<'_>,
        prim: &gltf::Primitive<'_>,
        m: &DMat4,
        node: usize,
    ) -> Result<()> {
        if prim.mode() != Mode::Triangles {
            self.skipped_modes.insert(format!("{:?}", prim.mode()));
            return Ok(());
        }
        if prim.morph_targets().len() > 0 {
            self.ignored.insert("morph targets".into());
        }
        let mesh_name = mesh.name().unwrap_or("");
        let role = |what: &'static str| Role {
            what,
            mesh: mesh.index(),
            mesh_name,
            prim: prim.index(),
        };
        let (name, bufs) = (self.name, self.buffers);
        let Some(pos_acc) = prim.get(&Semantic::Positions) else {
            return Err(self.err(format!(
                "mesh {} primitive {}: no POSITION attribute",
                mesh.index(),
                prim.index()
            )));
        };
        const F: &[DataType] = &[DataType::F32];
        const UV: &[DataType] = &[DataType::F32, DataType::U8, DataType::U16];
        let (pos, _) = read_accessor(
            &pos_acc,
            bufs,
            &[(Dimensions::Vec3, F)],
            &role("POSITION"),
            name,
        )?;
        let nv = pos.len() / 3;
        let count_ok = |acc: &gltf::Accessor<'_>, what: &'static str| -> Result<()> {
            if acc.count() != nv {
                return Err(mesh_err(
                    name,
                    format!(
                        "accessor {} ({}): {} elements, but POSITION has {nv}",
                        acc.index(),
                        role(what),
                        acc.count()
                    ),
                ));
            }
            Ok(())
        };
        let normals = match prim.get(&Semantic::Normals) {
            Some(a) => {
                count_ok(&a, "NORMAL")?;
                Some(read_accessor(&a, bufs, &[(Dimensions::Vec3, F)], &role("NORMAL"), name)?.0)
            }
            None => None,
        };
        let uvs = match prim.get(&Semantic::TexCoords(0)) {
            Some(a) => {
                count_ok(&a, "TEXCOORD_0")?;
                Some(
                    read_accessor(
                        &a,
                        bufs,
                        &[(Dimensions::Vec2, UV)],
                        &role("TEXCOORD_0"),
                        name,
                    )?
                    .0,
                )
            }
            None => None,
        };
        let colors = match prim.get(&Semantic::Colors(0)) {
            Some(a) => {
                count_ok(&a, "COLOR_0")?;
                let (c, n) = read_accessor(
                    &a,
                    bufs,
                    &[(Dimensions::Vec3, UV), (Dimensions::Vec4, UV)],
                    &role("COLOR_0"),
                    name,
                )?;
                if let Some(bad) = c.iter().find(|&&x| x < 0.0) {
                    return Err(self.err(format!(
                        "accessor {} ({}): colour component {bad} must be >= 0",
                        a.index(),
                        role("COLOR_0")
                    )));
                }
                Some((c, n))
            }
            None => None,
        };
        let indices: Vec<u32> = match prim.indices() {
            Some(a) => {
                let ints = &[DataType::U8, DataType::U16, DataType::U32][..];
                let (ix, _) = read_accessor(
                    &a,
                    bufs,
                    &[(Dimensions::Scalar, ints)],
                    &role("indices"),
                    name,
                )?;
                if let Some((i, &bad)) = ix.iter().enumerate().find(|(_, &k)| k as usize >= nv) {
                    return Err(self.err(format!(
                        "accessor {} ({}): element {i}: vertex index {bad} out of range (0..{nv})",
                        a.index(),
                        role("indices")
                    )));
                }
                ix.into_iter().map(|k| k as u32).collect()
            }
            None => (0..nv as u32).collect(),
        };
        if !indices.len().is_multiple_of(3) {
            return Err(self.err(format!(
                "{}: {} indices, not a multiple of 3 (TRIANGLES)",
                role("indices"),
                indices.len()
            )));
        }
        if self.mesh.triangles.len() + indices.len() / 3 > MAX_GLTF_TRIANGLES
            || self.mesh.positions.len() + nv > u32::MAX as usize / 2
        {
            return Err(self.err(format!(
                "node {node}: the nodes instance more than {MAX_GLTF_TRIANGLES} triangles"
            )));
        }
        let material = self.material(prim)?;

        // Place the vertices: f64 matrices, rounded once to f32.
        let identity = *m == DMat4::IDENTITY;
        let normal_m = DMat3::from_mat4(*m).inverse().transpose();
        let mirrors = DMat3::from_mat4(*m).determinant() < 0.0;
        let vbase = self.mesh.positions.len() as u32;
        for (i, p) in pos.chunks_exact(3).enumerate() {
            let q = if identity {
                Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32)
            } else {
                m.transform_point3(DVec3::new(p[0], p[1], p[2])).as_vec3()
            };
            if !q.is_finite() {
                return Err(self.err(format!(
                    "node {node}: {} vertex {i} is not finite once transformed ({q})",
                    role("POSITION")
                )));
            }
            self.mesh.positions.push(q);
        }
        let nbase = self.mesh.normals.len() as u32;
        let mut usable = Vec::new();
        if let Some(ns) = &normals {
            for n in ns.chunks_exact(3) {
                let v = DVec3::new(n[0], n[1], n[2]);
                let v = if identity {
                    v.as_vec3()
                } else {
                    (normal_m * v).as_vec3()
                };
                // A zero normal has no direction: its triangles fall back to flat shading.
                match v.try_normalize() {
                    Some(u) => {
                        self.mesh.normals.push(u);
                        usable.push(true);
                    }
                    None => {
                        self.mesh.normals.push(Vec3::Z);
                        usable.push(false);
                    }
                }
            }
        }
        let uvbase = self.mesh.uvs.len() as u32;
        if let Some(uv) = &uvs {
            self.any_uv = true;
            self.mesh.uvs.extend(
                uv.chunks_exact(2)
                    .map(|c| Vec2::new(c[0] as f32, 1.0 - c[1] as f32)),
            );
        }
        match &colors {
            Some((c, n)) => {
                self.any_color = true;
                self.mesh.colors.extend(
                    c.chunks_exact(*n)
                        .map(|c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32)),
                );
            }
            None => self.mesh.colors.extend(std::iter::repeat_n(Vec3::ONE, nv)),
        }
        for t in indices.chunks_exact(3) {
            let local = if mirrors {
                [t[0], t[2], t[1]]
            } else {
                [t[0], t[1], t[2]]
            };
            let v = local.map(|k| vbase + k);
            let smooth = normals.is_some() && local.iter().all(|&k| usable[k as usize]);
            self.mesh.triangles.push(Triangle {
                v,
                n: if smooth {
                    local.map(|k| nbase + k)
                } else {
                    [NO_NORMAL; 3]
                },
                material,
            });
            self.mesh.tri_uvs.push(if uvs.is_some() {
                local.map(|k| uvbase + k)
            } else {
                [NO_UV; 3]
            });
        }
        Ok(())
    }

    /// The mesh material of a primitive's glTF material, made once per material.
    fn material(&mut self, prim: &gltf::Primitive<'_>) -> Result<u32> {
        let gm = prim.material();
        let key = gm.index();
        if let Some(&i) = self.materials.get(&key) {
            return Ok(i);
        }
        let mat = match key {
            // No material: fragtrace's default grey, as an OBJ face without one.
            None => Material {
                name: format!("{}:default", self.name),
                ..Material::default()
            },
            Some(k) => {
                let name = gm.name().map_or(format!("material {k}"), str::to_owned);
                let mut mat = material_from_gltf(&gm, name.clone(), &mut self.ignored);
                if let Some(info) = gm.pbr_metallic_roughness().base_color_texture() {
                    if info.tex_coord() != 0 {
                        self.ignored
                            .insert(format!("baseColorTexture on TEXCOORD_{}", info.tex_coord()));
                    } else {
                        if info.texture_transform().is_some() {
                            self.ignored.insert("KHR_texture_transform".into());
                        }
                        mat.diffuse_map = self.texture(&info.texture(), &name);
                    }
                }
                mat
            }
        };
        self.mesh.materials.push(mat);
        let i = (self.mesh.materials.len() - 1) as u32;
        self.materials.insert(key, i);
        Ok(i)
    }

    /// A texture's image with its sampler's wrap modes, loaded once; a failure is one
    /// texture-problem line (the material keeps its base colour).
    fn texture(&mut self, t: &gltf::Texture<'_>, material: &str) -> Option<u32> {
        use gltf::texture::WrappingMode as W;
        let wrap = |w: W| match w {
            W::ClampToEdge => Wrap::Clamp,
            W::MirroredRepeat => Wrap::Mirror,
            W::Repeat => Wrap::Repeat,
        };
        let s = t.sampler();
        let wraps = [wrap(s.wrap_s()), wrap(s.wrap_t())];
        let img = t.source();
        let key = (img.index(), wraps);
        if let Some(&r) = self.textures.get(&key) {
            return r;
        }
        // The image's JSON, not `Image::source`, which unwraps a missing mimeType.
        let json = &self.doc.as_json().images[img.index()];
        let view = json
            .buffer_view
            .as_ref()
            .and_then(|v| self.doc.views().nth(v.value()));
        let (label, bytes) = match (view, &json.uri) {
            (Some(view), _) => (
                format!("image {} (buffer view {})", img.index(), view.index()),
                view_bytes(&view, self.buffers)
                    .map(<[u8]>::to_vec)
                    .ok_or_else(|| {
                        (
                            "its buffer".to_owned(),
                            "buffer view out of range".to_owned(),
                        )
                    }),
            ),
            (None, Some(uri)) => (
                format!("image {} `{}`", img.index(), short(uri)),
                read_uri(
                    uri,
                    self.files,
                    super::texture::MAX_TEXTURE_BYTES,
                    "texture image",
                ),
            ),
            (None, None) => (
                format!("image {}", img.index()),
                Err((
                    "the document".to_owned(),
                    "neither a bufferView nor a uri".to_owned(),
                )),
            ),
        };
        let source = format!("{}: {label}", self.name);
        let r = match bytes.and_then(|b| {
            Texture::decode(&b, source.clone(), wraps).map_err(|why| (label.clone(), why))
        }) {
            Ok(tex) => {
                self.mesh.textures.push(tex);
                Some((self.mesh.textures.len() - 1) as u32)
            }
            Err((at, why)) => {
                self.mesh.texture_problems.push(format!(
                    "{}: material `{material}`: baseColorTexture {label} cannot be read at {at} \
                     ({why}); the material renders with its base colour",
                    self.name
                ));
                None
            }
        };
        self.textures.insert(key, r);
        r
    }

    fn finish(mut self) -> Result<ObjMesh> {
        // The shared meshes' triangles live in `shared` alone (their uv indices too; their
        // positions, colours and uvs stay, which `shared` indexes).
        if let Some(t0) = self.first_shared {
            self.mesh.triangles.truncate(t0);
            self.mesh.tri_uvs.truncate(t0);
        }
        if !self.any_uv {
            self.mesh.tri_uvs.clear();
        }
        if !self.any_color {
            self.mesh.colors.clear();
        }
        for mode in &self.skipped_modes {
            self.ignored.insert(format!("primitives in mode {mode}"));
        }
        if !self.ignored.is_empty() {
            let list: Vec<&str> = self.ignored.iter().map(String::as_str).collect();
            self.mesh.warnings.push(format!(
                "{}: ignored (no Whitted equivalent, or not read): {}",
                self.name,
                list.join(", ")
            ));
        }
        if self.mesh.triangles.is_empty() && self.mesh.shared.is_empty() {
            self.mesh.warnings.push(format!(
                "{}: no triangles in the scene's nodes; the object adds nothing to the scene",
                self.name
            ));
        }
        Ok(self.mesh)
    }
}
