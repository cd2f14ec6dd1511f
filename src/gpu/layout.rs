//! Texel layout of the scene and the grid in RGBA32F textures: defined here, once, and
//! turned into the GLSL constants and fetch functions the shaders use
//! ([`SceneTextures::glsl`]), so the packing and the unpacking cannot drift apart.
//!
//! Every texture is a 2D array of texels addressed by a linear index i that wraps into rows
//! of a power-of-two width W (so the row `floor(i / W)` is exact in f32: dividing by a power of
//! two only changes the exponent; adding 0.5 first would round near 2^24), at most the GPU's
//! GL_MAX_TEXTURE_SIZE wide and high. `texture2D` samples a texel a quarter in from its left
//! edge ([`TEXEL_INSET`]), not at its centre: compilers may reassociate `(i - row W) + inset`
//! into `(i + inset) - row W` (Mesa's NIR does, where the product is used once), and
//! `i + 0.5` rounds to the even neighbour past 2^23, which read the next texel for every odd
//! index there; `i + 0.25` rounds to i, the texel's own edge, so either order reads it.
//!
//! Indices and counts are stored as floats, exact below 2^24. A scene whose texels or
//! references pass 2^24 is packed in the [`IndexFormat::Split`] format instead
//! (`SPLIT_INDEX` in the GLSL, compiled in only then, so smaller scenes keep their shaders
//! and images): list offsets split over two channels (hi * 2^24 + lo, exact to 2^48), the
//! ray's list cursor counted from its cell's first reference, and records fetched by
//! (record, texel) without forming their product; triangle and irregular cell ids are
//! float slots (exact floats past 2^24), voxel-map blocks start at exact floats. What
//! remains is the uniform grid's cell index (below 2^24), [`MAX_GPU_TRIANGLES`] and the
//! GPU's own limits, each refused with one line ([`SceneTextures::pack`]).
//!
//! | texture | texels per item | contents |
//! |---|---|---|
//! | `tri` | 3 per triangle | (v0, material), (v1, has_normals), (v2, 0) |
//! | `nrm` | 3 per triangle | vertex normals n0, n1, n2 (only when the scene has any) |
//! | `mat` | 7 per material | see [`contract::mat`](super::contract::mat) |
//! | `cell` | 1 per uniform grid cell | (offset into `list`, count, 0, 0) |
//! | `cell` | 2 per irregular cell | (exit box lower corner, offset), (exit box upper corner, count) |
//! | `cell` | split: 1 per uniform cell | (offset lo, count, offset hi, 0) |
//! | `cell` | split: 3 per irregular cell | as above with offset lo, then (offset hi, 0, 0, 0) |
//! | `vmap` | 1 per 4 voxel-map entries | irregular grid only: cell id, or -(child block + 1) |
//! | `list` | 1 per 4 references | four triangle indices |
//! | `tex` | see [`TexLayout`] | textured scenes only: uv records, colours, texture table, texels |
//!
//! For the irregular grid the layout also generates `irr_lookup(k)`, the voxel-map descent
//! from a virtual cell to its cell id, unrolled hop by hop with the splits of each hop as
//! constants (no loop: the multipass kernel's programs have none). The map uploaded is the
//! built one with its levels merged into hops of several levels ([`WideMap`]), so a lookup
//! waits on fewer dependent reads; the cells are the built grid's.

use super::contract::{mat as slot, Field, Unit};
use super::split_index::check_indices;
use super::split_index::{align_blocks, MapEntry};
pub use super::split_index::{
    check_triangles, float_slot, rec_coord, slot_coord, slot_record, split, split_coord,
    IndexFormat, MAX_EXACT_INDEX, MAX_GPU_TRIANGLES, MAX_SLOT_TEXELS, SPLIT_BASE, SPLIT_INDEX_ENV,
    TRI_SLOT_BANDS,
};
use crate::accel::irregular_wide::WideMap;
use crate::accel::{AccelRef, GridRef, IrregularGrid};
use crate::scene::{CheckerAxes, Scene};
use crate::{Error, Result};

/// Texels per triangle in `tri` and `nrm`.
pub const TRI_TEXELS: u32 = 3;
/// Texels per material; the slots are declared in [`contract::mat`](super::contract::mat).
pub const MAT_TEXELS: u32 = slot::TEXELS;
/// Entries per texel of an entry texture ([`PackedTexture::pack_entries`]: triangle indices
/// in `list`, voxel-map entries in `vmap`).
pub const LIST_PER_TEXEL: u32 = 4;
/// Where in its texel `texture2D` samples along a row, in texels from the left edge: an offset that still lands in the texel when a compiler adds it to the
/// linear index before subtracting the row (see the module's header); exact otherwise.
pub const TEXEL_INSET: f32 = 0.25;
/// Widest row used, even when the GPU allows wider: keeps textures compact for small
/// scenes and matches the limits of 2005-era cards.
pub const MAX_ROW: u32 = 4096;

/// How the generated `fetch_<name>(i)` functions read a texel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Fetch {
    /// `texture2D` at the texel's centre (GLSL 1.20: the fragment kernels).
    Texture2D,
    /// `texelFetch` at integer coordinates (GLSL 1.30+: the compute kernel).
    TexelFetch,
    /// A shader storage buffer of texels, the k-th texture at binding
    /// [`STORAGE_BINDING_BASE`] + k (GLSL 4.30: the compute kernel).
    Storage,
}

impl Fetch {
    /// The name `--stats` reports as `gpu.scene_fetch`: `texture2D`, or `texel-fetch` and
    /// `storage-buffer` as `--scene-fetch` spells them.
    pub fn name(self) -> &'static str {
        match self {
            Fetch::Texture2D => "texture2D",
            Fetch::TexelFetch => "texel-fetch",
            Fetch::Storage => "storage-buffer",
        }
    }
}

pub use super::contract::STORAGE_BINDING_BASE;

/// One packed RGBA32F texture.
#[derive(Clone, Debug)]
pub struct PackedTexture {
    /// Name used in GLSL (`u_<name>`, `fetch_<name>`, `<NAME>_W` ...).
    pub name: &'static str,
    /// Width in texels (a power of two).
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// RGBA data, `4 * width * height` floats (padding zero).
    pub data: Vec<f32>,
    /// True when the texels hold [`LIST_PER_TEXEL`] scalar entries each rather than one
    /// record (cell lists, the voxel map): the GLSL then also gets `entry_<name>(i)`, and a
    /// float view under [`Fetch::Storage`].
    pub entries: bool,
    /// True when records are addressed by triangle id, a [`float_slot`], and stored densely
    /// (`tri`, `nrm`): in the split format `fetch_<name>_at` then decodes the slot into the
    /// record (`slot_coord`, `slot_record`).
    pub slots: bool,
}

impl PackedTexture {
    /// Packs `texels` (RGBA each) into rows no wider than [`MAX_ROW`], or than `max_size`
    /// where rows of [`MAX_ROW`] would need more than `max_size` of them. Whether the
    /// indices that address them are exact is the caller's ([`SceneTextures::pack`]).
    pub fn pack(name: &'static str, texels: Vec<[f32; 4]>, max_size: u32) -> Result<Self> {
        let n = texels.len().max(1) as u64;
        let narrow = prev_pow2(max_size.min(MAX_ROW)).max(1);
        let cap = if n > narrow as u64 * max_size as u64 {
            prev_pow2(max_size).max(1)
        } else {
            narrow
        };
        let width = (n.next_power_of_two().min(cap as u64)) as u32;
        let height = n.div_ceil(width as u64);
        if height > max_size as u64 {
            return Err(Error::Limit(format!(
                "texture `{name}` needs {n} texels, {width}x{height}, but GL_MAX_TEXTURE_SIZE \
                 is {max_size}; render it with --backend cpu"
            )));
        }
        let height = height as u32;
        // Padded and flattened in place: no second copy of a scene's largest textures.
        let mut texels = texels;
        texels.resize(width as usize * height as usize, [0.0; 4]);
        let data = texels.into_flattened();
        Ok(PackedTexture {
            name,
            width,
            height,
            data,
            entries: false,
            slots: false,
        })
    }

    /// Packs scalar `entries`, [`LIST_PER_TEXEL`] to a texel in order (the last texel padded
    /// with zeros), as an entry texture: see [`PackedTexture::entries`].
    pub fn pack_entries(name: &'static str, entries: &[f32], max_size: u32) -> Result<Self> {
        let texels = entries
            .chunks(LIST_PER_TEXEL as usize)
            .map(|c| {
                let mut t = [0f32; 4];
                t[..c.len()].copy_from_slice(c);
                t
            })
            .collect();
        Ok(PackedTexture {
            entries: true,
            ..Self::pack(name, texels, max_size)?
        })
    }

    /// GLSL: size constants and an exact fetch by linear index, through `fetch` (`binding`:
    /// the storage-buffer binding under [`Fetch::Storage`]); for an entry texture also
    /// `entry_<name>(i)`, the i-th float in texel order.
    pub fn glsl_with(&self, fetch: Fetch, binding: u32) -> String {
        let mut s = self.texel_glsl(fetch, binding);
        if self.entries {
            s += &self.entry_glsl(fetch, binding);
        }
        s
    }

    /// [`glsl_with`](Self::glsl_with), then the fetches of `format`: `fetch_<name>_at(item,
    /// per, k)`, texel k of record `item` of `per` texels, and (split, entry textures)
    /// `entry_<name>_split(hi, lo, j)`, entry hi * 2^24 + lo + j.
    pub fn glsl_format(&self, fetch: Fetch, binding: u32, format: IndexFormat) -> String {
        let mut s = self.glsl_with(fetch, binding);
        let n = self.name;
        let up = n.to_ascii_uppercase();
        let (mask, shift) = (self.width - 1, self.width.trailing_zeros());
        let body = match (format, fetch) {
            (IndexFormat::Float, _) => format!("    return fetch_{n}(item * per + k);\n"),
            (IndexFormat::Split, Fetch::Texture2D) if self.slots => format!(
                "    vec2 p = slot_coord(item, per, k, {up}_W, {up}_INV_W);\n\
                 \x20   return texture2D(u_{n}, vec2((p.x + {TEXEL_INSET:?}) * {up}_INV_W, (p.y + 0.5) * {up}_INV_H));\n"
            ),
            (IndexFormat::Split, Fetch::TexelFetch) if self.slots => format!(
                "    int i = int(slot_record(item)) * int(per) + int(k);\n\
                 \x20   return texelFetch(u_{n}, ivec2(i & {mask}, i >> {shift}), 0);\n"
            ),
            (IndexFormat::Split, Fetch::Storage) if self.slots => {
                format!("    return buf_{n}[slot_record(item) * uint(per) + uint(k)];\n")
            }
            (IndexFormat::Split, Fetch::Texture2D) => format!(
                "    vec2 p = rec_coord(item, per, k, {up}_W, {up}_INV_W);\n\
                 \x20   return texture2D(u_{n}, vec2((p.x + {TEXEL_INSET:?}) * {up}_INV_W, (p.y + 0.5) * {up}_INV_H));\n"
            ),
            (IndexFormat::Split, Fetch::TexelFetch) => format!(
                "    int i = int(item) * int(per) + int(k);\n\
                 \x20   return texelFetch(u_{n}, ivec2(i & {mask}, i >> {shift}), 0);\n"
            ),
            (IndexFormat::Split, Fetch::Storage) => {
                format!("    return buf_{n}[uint(item) * uint(per) + uint(k)];\n")
            }
        };
        s += &format!("vec4 fetch_{n}_at(float item, float per, float k) {{\n{body}}}\n");
        if format == IndexFormat::Split && self.entries {
            let body = match fetch {
                Fetch::Texture2D => format!(
                    "    vec3 p = split_coord(hi, lo, j, {up}_W, {up}_INV_W);\n\
                     \x20   vec4 sel = vec4(equal(vec4(p.z), vec4(0.0, 1.0, 2.0, 3.0)));\n\
                     \x20   return dot(texture2D(u_{n}, vec2((p.x + {TEXEL_INSET:?}) * {up}_INV_W, (p.y + 0.5) * {up}_INV_H)), sel);\n"
                ),
                Fetch::TexelFetch => format!(
                    "    int e = int(hi) * {base} + int(lo) + int(j);\n\
                     \x20   int i = e >> 2;\n\
                     \x20   vec4 sel = vec4(equal(ivec4(e & 3), ivec4(0, 1, 2, 3)));\n\
                     \x20   return dot(texelFetch(u_{n}, ivec2(i & {mask}, i >> {shift}), 0), sel);\n",
                    base = SPLIT_BASE
                ),
                Fetch::Storage => format!(
                    "    return entries_{n}[uint(hi) * {base}u + uint(lo) + uint(j)];\n",
                    base = SPLIT_BASE
                ),
            };
            s += &format!("float entry_{n}_split(float hi, float lo, float j) {{\n{body}}}\n");
        }
        s
    }

    /// `fetch_<name>(i)` alone.
    fn texel_glsl(&self, fetch: Fetch, binding: u32) -> String {
        let n = self.name;
        match fetch {
            Fetch::Texture2D => self.glsl(),
            Fetch::Storage => format!(
                "layout(std430, binding = {binding}) readonly buffer Buf_{n} {{ vec4 buf_{n}[]; }};\n\
                 vec4 fetch_{n}(float i) {{\n\
                 \x20   return buf_{n}[int(i)];\n\
                 }}\n",
            ),
            Fetch::TexelFetch => format!(
                "uniform sampler2D u_{n};\n\
                 vec4 fetch_{n}(float i) {{\n\
                 \x20   int k = int(i);\n\
                 \x20   return texelFetch(u_{n}, ivec2(k & {mask}, k >> {shift}), 0);\n\
                 }}\n",
                mask = self.width - 1,
                shift = self.width.trailing_zeros(),
            ),
        }
    }

    /// `entry_<name>(i)`. Under [`Fetch::Storage`] a float view of the same buffer beside
    /// the texel view: an entry is one 4-byte load, not a texel and a select. Otherwise the
    /// texel, then its component (exact: the one-hot select adds zeros to a finite entry).
    fn entry_glsl(&self, fetch: Fetch, binding: u32) -> String {
        let n = self.name;
        match fetch {
            Fetch::Storage => format!(
                "layout(std430, binding = {binding}) readonly buffer Entries_{n} {{ float entries_{n}[]; }};\n\
                 float entry_{n}(float i) {{\n\
                 \x20   return entries_{n}[int(i)];\n\
                 }}\n",
            ),
            Fetch::Texture2D | Fetch::TexelFetch => format!(
                "float entry_{n}(float i) {{\n\
                 \x20   float texel = floor(i * {inv:?});\n\
                 \x20   vec4 sel = vec4(equal(vec4(i - texel * {per:.1}), vec4(0.0, 1.0, 2.0, 3.0)));\n\
                 \x20   return dot(fetch_{n}(texel), sel);\n\
                 }}\n",
                inv = 1.0 / LIST_PER_TEXEL as f32,
                per = LIST_PER_TEXEL as f32,
            ),
        }
    }

    /// GLSL 1.20: size constants and an exact fetch by linear index.
    pub fn glsl(&self) -> String {
        let up = self.name.to_ascii_uppercase();
        format!(
            "uniform sampler2D u_{n};\n\
             #define {up}_W {w:.1}\n\
             #define {up}_INV_W {iw:?}\n\
             #define {up}_INV_H {ih:?}\n\
             vec4 fetch_{n}(float i) {{\n\
             \x20   float y = floor(i * {up}_INV_W);\n\
             \x20   float x = i - y * {up}_W;\n\
             \x20   return texture2D(u_{n}, vec2((x + {inset:?}) * {up}_INV_W, (y + 0.5) * {up}_INV_H));\n\
             }}\n",
            n = self.name,
            w = self.width as f32,
            iw = 1.0 / self.width as f32,
            ih = 1.0 / self.height as f32,
            inset = TEXEL_INSET,
        )
    }

    /// Bytes of texel data.
    pub fn bytes(&self) -> usize {
        self.data.len() * 4
    }
}

fn prev_pow2(v: u32) -> u32 {
    if v == 0 {
        0
    } else {
        1 << (31 - v.leading_zeros())
    }
}

/// The scene and its grid, packed for upload.
#[derive(Clone, Debug)]
pub struct SceneTextures {
    /// Triangle vertices and material indices.
    pub tri: PackedTexture,
    /// Vertex normals (`None` when no triangle has them: compiled out).
    pub nrm: Option<PackedTexture>,
    /// Materials.
    pub mat: PackedTexture,
    /// Cell table of the grid.
    pub cell: PackedTexture,
    /// Triangle-index list.
    pub list: PackedTexture,
    /// The irregular grid's voxel map and descent (`None` for the uniform grid).
    pub irregular: Option<IrregularLayout>,
    /// Texture coordinates, vertex colours and textures (`None` for a scene without
    /// textures and vertex colours: then no texture code is compiled).
    pub tex: Option<TexLayout>,
    /// How indices are written (and read by the GLSL).
    pub format: IndexFormat,
}

/// Texels of `tex` per triangle record: (u0, v0, u1, v1), (u2, v2, lod_bias, curvature)
/// ([`TriTex`](crate::scene::texture::TriTex)).
pub const TEX_REC: u32 = 2;

/// The `tex` texture of a textured scene, one linear run of texels: every triangle's
/// [`TEX_REC`] record texels, then (with vertex colours) three colour texels per triangle
/// from `colors`, then per texture a header (levels, wrap u, wrap v, 0) and one texel per
/// level (first texel, width, height, 0), then the levels' texels (linear RGB, row by row
/// from the bottom). All the scene's image textures sit in this one atlas, so a textured
/// scene takes one texture unit (the 16th) whatever its number of textures; the mip levels
/// are the scene's ([`Texture::levels`](crate::scene::Texture::levels)), built on the CPU,
/// and the GLSL filters them by hand from nearest fetches (`glsl120/texture.glsl`).
#[derive(Clone, Debug)]
pub struct TexLayout {
    /// The texels.
    pub texture: PackedTexture,
    /// First colour texel (`None` without vertex colours).
    pub colors: Option<u32>,
    /// Index of each texture's header.
    pub headers: Vec<u32>,
}

impl TexLayout {
    /// The layout of `scene`, or `None` when it has neither textures nor vertex colours.
    fn pack(scene: &Scene, max_size: u32) -> Result<Option<Self>> {
        use crate::scene::texture::TriTex;
        if !scene.has_textures() && !scene.has_vertex_colors() {
            return Ok(None);
        }
        let n = scene.triangles.len();
        let mut texels: Vec<[f32; 4]> = Vec::with_capacity(n * TEX_REC as usize);
        for i in 0..n {
            let r = TriTex::of(scene, i);
            texels.push([r.uv[0][0], r.uv[0][1], r.uv[1][0], r.uv[1][1]]);
            texels.push([r.uv[2][0], r.uv[2][1], r.lod_bias, r.curvature]);
        }
        let colors = if scene.has_vertex_colors() {
            let base = texels.len() as u32;
            for t in &scene.triangles {
                for v in t.v {
                    let c = scene.colors[v as usize];
                    texels.push([c.x, c.y, c.z, 0.0]);
                }
            }
            Some(base)
        } else {
            None
        };
        let table: usize = scene.textures.iter().map(|t| 1 + t.levels.len()).sum();
        let mut next = (texels.len() + table) as u64;
        let mut headers = Vec::with_capacity(scene.textures.len());
        for t in &scene.textures {
            headers.push(texels.len() as u32);
            texels.push([
                t.levels.len() as f32,
                t.wrap[0].code(),
                t.wrap[1].code(),
                0.0,
            ]);
            for l in &t.levels {
                texels.push([next as f32, l.width as f32, l.height as f32, 0.0]);
                next += l.texels.len() as u64;
            }
        }
        if next > MAX_EXACT_INDEX {
            return Err(Error::Limit(format!(
                "the scene's textures and texture coordinates need {next} texels; the GPU's \
                 one texture of them keeps indices exact only below 2^24"
            )));
        }
        for t in &scene.textures {
            for l in &t.levels {
                texels.extend(l.texels.iter().map(|c| [c[0], c[1], c[2], 0.0]));
            }
        }
        Ok(Some(TexLayout {
            texture: PackedTexture::pack("tex", texels, max_size)?,
            colors,
            headers,
        }))
    }

    /// GLSL after the `tex` fetch: the constants, the fragment kernels' cone records and
    /// root cone (`fetch` [`Fetch::Texture2D`]), and `glsl120/texture.glsl`.
    fn glsl(&self, fetch: Fetch) -> String {
        let mut s = format!(
            "#define HAS_TEXTURES 1\n#define TEX_REC {TEX_REC}.0\n#define LOD_TINY {:e}\n\
             // m6.w: 1 + the header index of the material's map_Kd texture, 0 for none.\n\
             #define M6_MAP_KD w\n",
            crate::scene::texture::LOD_TINY
        );
        if let Some(c) = self.colors {
            s += &format!("#define HAS_VERTEX_COLORS 1\n#define TEX_COLORS {c}.0\n");
        }
        s += "uniform vec3 u_root_cone; // (1 at the root level, primary spread, 0)\n";
        if fetch == Fetch::Texture2D {
            s += "uniform sampler2D u_r3; // this level's cone (width at origin, spread)\n\
                  uniform sampler2D u_p3; // the parent's cone (width at origin, spread)\n";
        }
        s + include_str!("../../glsl120/texture.glsl")
    }
}

/// The irregular grid's part of the layout: its voxel map and the constants of the descent.
#[derive(Clone, Debug)]
pub struct IrregularLayout {
    /// Voxel map, four entries per texel.
    pub vmap: PackedTexture,
    /// Top cells per axis.
    pub top_res: [u32; 3],
    /// Splits per axis of each hop of the descent, top-down ([`WideMap`]).
    pub hops: Vec<[u32; 3]>,
    /// Splits per axis.
    pub shift: [u32; 3],
    /// Tests only: compile the walk with every face crossing moved by about an ulp
    /// (`SKEW_FACES` in `glsl120/traverse.glsl`; see [`GpuScene::with_skewed_faces`]).
    ///
    /// [`GpuScene::with_skewed_faces`]: super::scene::GpuScene::with_skewed_faces
    pub skew_faces: bool,
    /// How node entries address their child blocks: minus (block + 1), one float (Float),
    /// or minus the block's start, an exact float split into hi * 2^24 + lo for the read
    /// ([`align_blocks`], Split).
    pub format: IndexFormat,
}

/// Exact decimal literal of 2^-n (every such power has a finite decimal expansion).
fn pow2_literal(n: u32) -> String {
    format!("{:e}", 2f64.powi(-(n as i32)))
}

impl IrregularLayout {
    fn pack(g: &IrregularGrid, max_size: u32, format: IndexFormat) -> Result<Self> {
        let w = match hop_bits_override() {
            Some(bits) => WideMap::build(g, bits),
            None => {
                // Entries the largest texture of this GPU holds (as `PackedTexture::pack`
                // lays it out).
                let row = prev_pow2(max_size.min(MAX_ROW)).max(1) as usize;
                WideMap::for_gpu(g, row * max_size as usize * LIST_PER_TEXEL as usize)
            }
        };
        let cell = |id: u32| float_slot(id as u64) as f32;
        let entries: Vec<f32> = match format {
            IndexFormat::Float => w
                .vmap
                .iter()
                .map(|&e| {
                    if e & crate::accel::irregular::NODE != 0 {
                        -((e & !crate::accel::irregular::NODE) as f32) - 1.0
                    } else {
                        cell(e)
                    }
                })
                .collect(),
            IndexFormat::Split => align_blocks(&w, f32::MANTISSA_DIGITS)
                .into_iter()
                .map(|e| match e {
                    MapEntry::Cell(id) => cell(id),
                    MapEntry::Node(start) => -(start as f32),
                })
                .collect(),
        };
        let limit = match format {
            IndexFormat::Float => MAX_EXACT_INDEX,
            // The compute kernel's integer reads (`entry_vmap_split`).
            IndexFormat::Split => MAX_SLOT_TEXELS,
        };
        if entries.len() as u64 > limit {
            return Err(Error::Limit(format!(
                "{} voxel-map entries; the GPU's descent reads at most {limit}; --accel \
                 uniform, or render it with --backend cpu",
                entries.len()
            )));
        }
        Ok(IrregularLayout {
            vmap: PackedTexture::pack_entries("vmap", &entries, max_size)?,
            top_res: g.top_res,
            hops: w.hops,
            shift: g.shift,
            skew_faces: false,
            format,
        })
    }

    /// GLSL: the voxel-map fetch and `irr_lookup`, the descent unrolled over the hops.
    fn glsl(&self) -> String {
        let v3 = |v: [String; 3]| format!("vec3({}, {}, {})", v[0], v[1], v[2]);
        let mut s = String::from(
            "#define ACCEL_IRREGULAR 1\n\
             // NVIDIA: no fast-math contraction, so one crossing is evaluated alike everywhere.\n\
             #pragma optionNV(fastmath off)\n\
             // Voxel-map entry i.\n\
             float vmap_entry(float i) { return entry_vmap(i); }\n\
             // Cell id of virtual cell k: the top entry, then one child block per hop of\n\
             // levels while the entry is a node (CPU twins: WideMap::lookup and\n\
             // IrregularGrid::lookup, the same cell). Every product is an integer times a power of two and\n\
             // every mod by a power of two of an integer, so exact.\n\
             float irr_lookup(vec3 k) {\n",
        );
        s += &format!(
            "    vec3 t = floor(k * {});\n    float e = vmap_entry(t.x + {:.1} * (t.y + {:.1} * t.z));\n",
            v3(self.shift.map(pow2_literal)),
            self.top_res[0] as f32,
            self.top_res[1] as f32
        );
        let mut rem = self.shift;
        for n in &self.hops {
            for a in 0..3 {
                rem[a] -= n[a];
            }
            let span = n.map(|b| format!("{:.1}", (1u32 << b) as f32));
            let stride = [1u32, 1 << n[0], 1 << (n[0] + n[1])].map(|v| format!("{:.1}", v as f32));
            let child = format!(
                "dot(mod(floor(k * {}), {}), {})",
                v3(rem.map(pow2_literal)),
                v3(span),
                v3(stride)
            );
            s += &match self.format {
                IndexFormat::Float => format!("    if (e < 0.0) e = vmap_entry(-e - 1.0 + {child});\n"),
                // The block's start -e, an exact float, as hi * 2^24 + lo; the child's
                // offset added in the split address arithmetic.
                IndexFormat::Split => format!(
                    "    if (e < 0.0) {{ float hi = floor(-e * {}); e = entry_vmap_split(hi, -e - hi * SPLIT_BASE, {child}); }}\n",
                    pow2_literal(24)
                ),
            };
        }
        s += "    return e;\n}\n";
        if self.skew_faces {
            s += "#define SKEW_FACES 1\n";
        }
        s
    }
}

/// Environment variable that fixes the hop width of the GPU's voxel map (1 to
/// [`MAX_HOP_BITS`](crate::accel::irregular_wide::MAX_HOP_BITS) splits a hop; 1 uploads the
/// built map's levels one per hop) instead of [`WideMap::for_gpu`]'s choice: for
/// measuring what the hops buy. Other values are ignored.
pub const HOP_BITS_ENV: &str = "FRAGTRACE_VMAP_HOP_BITS";

fn hop_bits_override() -> Option<u32> {
    let bits: u32 = std::env::var(HOP_BITS_ENV).ok()?.parse().ok()?;
    (1..=crate::accel::irregular_wide::MAX_HOP_BITS)
        .contains(&bits)
        .then_some(bits)
}

/// Numeric code of a checker's axes in the material texture (and in GLSL).
pub fn axes_code(a: CheckerAxes) -> f32 {
    match a {
        CheckerAxes::Xy => 0.0,
        CheckerAxes::Xz => 1.0,
        CheckerAxes::Yz => 2.0,
    }
}

impl SceneTextures {
    /// Packs `scene` and `grid` for a GPU whose textures may be `max_size` texels wide/high;
    /// the vertex-normal texture only when the scene has vertex normals.
    pub fn pack<'a>(scene: &Scene, accel: impl Into<AccelRef<'a>>, max_size: u32) -> Result<Self> {
        Self::pack_with(scene, accel, max_size, scene.has_smooth_normals())
    }

    /// As [`SceneTextures::pack`], with the vertex-normal texture packed when `normals` is
    /// set even if no triangle has normals (all zero then): shaders built with every feature
    /// on (`--no-specialize`) fetch from it, behind the per-triangle flag.
    pub fn pack_with<'a>(
        scene: &Scene,
        accel: impl Into<AccelRef<'a>>,
        max_size: u32,
        normals: bool,
    ) -> Result<Self> {
        let accel = accel.into().grid()?;
        // The voxel map the GPU reads passes 2^24 entries exactly when the built one does
        // (`WideMap::for_gpu` widens hops only within 2^24).
        let (cells, refs, per_cell) = match accel {
            GridRef::Uniform(g) => (g.cells.len(), g.tri_indices.len(), 1),
            GridRef::Irregular(g) => (g.cells.len(), g.tri_indices.len().max(g.vmap.len()), 2),
        };
        let texels =
            (scene.triangles.len() as u64 * TRI_TEXELS as u64).max(cells as u64 * per_cell);
        let format = IndexFormat::needed(texels, refs as u64);
        Self::pack_format(scene, accel, max_size, normals, format)
    }

    /// As [`SceneTextures::pack_with`], in the index format given.
    pub fn pack_format<'a>(
        scene: &Scene,
        accel: impl Into<AccelRef<'a>>,
        max_size: u32,
        normals: bool,
        format: IndexFormat,
    ) -> Result<Self> {
        let accel = accel.into().grid()?;
        check_indices(scene, accel)?;
        let smooth = normals || scene.has_smooth_normals();
        let n_tris = scene.triangles.len();
        let mut tri = Vec::with_capacity(n_tris * 3);
        let mut nrm = Vec::with_capacity(if smooth { n_tris * 3 } else { 0 });
        for (i, t) in scene.triangles.iter().enumerate() {
            let v = scene.triangle_vertices(i);
            let has_n = t.has_normals();
            tri.push([v[0].x, v[0].y, v[0].z, t.material as f32]);
            tri.push([v[1].x, v[1].y, v[1].z, if has_n { 1.0 } else { 0.0 }]);
            tri.push([v[2].x, v[2].y, v[2].z, 0.0]);
            if smooth {
                for k in 0..3 {
                    let n = if has_n {
                        scene.normals[t.n[k] as usize]
                    } else {
                        glam::Vec3::ZERO
                    };
                    nrm.push([n.x, n.y, n.z, 0.0]);
                }
            }
        }
        let tex = TexLayout::pack(scene, max_size)?;
        let mut mat = vec![[0f32; 4]; scene.materials.len() * MAT_TEXELS as usize];
        for (i, m) in scene.materials.iter().enumerate() {
            let (ca, cb, scale, axes, phase) = match &m.checker {
                Some(c) => (c.color_a, c.color_b, c.scale, axes_code(c.axes), c.phase),
                None => (glam::Vec3::ZERO, glam::Vec3::ZERO, 0.0, 0.0, [0.0; 2]),
            };
            let texels = &mut mat[i * MAT_TEXELS as usize..][..MAT_TEXELS as usize];
            let mut put = |f: Field, v: &[f32]| {
                texels[f.texel][f.first..f.first + f.len].copy_from_slice(v);
            };
            put(slot::ALBEDO, &m.albedo.to_array());
            put(slot::KA, &[m.ka]);
            put(slot::KS, &m.ks.to_array());
            put(slot::NS, &[m.ns]);
            put(slot::KR, &m.kr.to_array());
            put(slot::KD, &[m.kd]);
            put(slot::KT, &m.kt.to_array());
            put(slot::IOR, &[m.ior]);
            put(slot::CHECKER_A, &ca.to_array());
            put(slot::CHECKER_SCALE, &[scale]);
            put(slot::CHECKER_B, &cb.to_array());
            put(slot::CHECKER_AXES, &[axes]);
            put(slot::FRESNEL, &[if m.fresnel { 1.0 } else { 0.0 }]);
            put(slot::CHECKER_PHASE, &phase);
            if let (Some(k), Some(t)) = (m.diffuse_map, &tex) {
                // `M6_MAP_KD`: the texture's header, plus one (zero: no texture).
                put(slot::PAD, &[t.headers[k as usize] as f32 + 1.0]);
            }
        }
        // Offsets as written: one float (exact below 2^24, checked above for Float), or hi
        // and lo.
        let off = |o: u32| match format {
            IndexFormat::Float => (o as f32, 0.0),
            IndexFormat::Split => {
                let (hi, lo) = split(o as u64);
                (lo, hi)
            }
        };
        let (cell, tri_indices, irregular) = match accel {
            GridRef::Uniform(grid) => (
                grid.cells
                    .iter()
                    .map(|c| {
                        let (lo, hi) = off(c.offset);
                        [lo, c.count as f32, hi, 0.0]
                    })
                    .collect::<Vec<_>>(),
                &grid.tri_indices,
                None,
            ),
            GridRef::Irregular(g) => {
                let f = |v: [u32; 3], w: f32| [v[0] as f32, v[1] as f32, v[2] as f32, w];
                // Cell k at its float slot (k itself below 2^24: the Float format's only).
                let per = format.irregular_cell_texels() as usize;
                let slots = g
                    .cells
                    .len()
                    .checked_sub(1)
                    .map_or(0, |k| float_slot(k as u64) + 1);
                let mut cell = vec![[0f32; 4]; slots as usize * per];
                for (k, c) in g.cells.iter().enumerate() {
                    let (lo, hi) = off(c.range.offset);
                    let at = &mut cell[float_slot(k as u64) as usize * per..][..per];
                    at[0] = f(c.exit_lo, lo);
                    at[1] = f(c.exit_hi, c.range.count as f32);
                    if format == IndexFormat::Split {
                        at[2] = [hi, 0.0, 0.0, 0.0];
                    }
                }
                (
                    cell,
                    &g.tri_indices,
                    Some(IrregularLayout::pack(g, max_size, format)?),
                )
            }
        };
        // Triangle ids as float slots: the index itself below 2^24 (the Float format's only).
        let list: Vec<f32> = tri_indices
            .iter()
            .map(|&i| float_slot(i as u64) as f32)
            .collect();
        let cell_texels = cell.len() as u64;
        if format == IndexFormat::Float {
            let need = [
                ("triangle texels", n_tris as u64 * TRI_TEXELS as u64),
                ("cell texels", cell_texels),
                ("triangle references", list.len() as u64),
            ];
            if let Some((what, n)) = need.iter().find(|(_, n)| *n > MAX_EXACT_INDEX) {
                return Err(Error::Internal(format!(
                    "{n} {what} packed with one float per index (exact to 2^24)"
                )));
            }
        }
        let slots = |t: PackedTexture| PackedTexture { slots: true, ..t };
        Ok(SceneTextures {
            tri: slots(PackedTexture::pack("tri", tri, max_size)?),
            nrm: if smooth {
                Some(slots(PackedTexture::pack("nrm", nrm, max_size)?))
            } else {
                None
            },
            mat: PackedTexture::pack("mat", mat, max_size)?,
            cell: PackedTexture::pack("cell", cell, max_size)?,
            list: PackedTexture::pack_entries("list", &list, max_size)?,
            irregular,
            tex,
            format,
        })
    }

    /// All textures, in binding order.
    pub fn all(&self) -> Vec<&PackedTexture> {
        self.with_units().into_iter().map(|(_, t)| t).collect()
    }

    /// All textures with the unit each is bound to.
    pub fn with_units(&self) -> Vec<(Unit, &PackedTexture)> {
        let mut v = vec![
            (Unit::Tri, &self.tri),
            (Unit::Mat, &self.mat),
            (Unit::Cell, &self.cell),
            (Unit::List, &self.list),
        ];
        if let Some(n) = &self.nrm {
            v.push((Unit::Nrm, n));
        }
        if let Some(i) = &self.irregular {
            v.push((Unit::Vmap, &i.vmap));
        }
        if let Some(t) = &self.tex {
            v.push((Unit::Tex, &t.texture));
        }
        v
    }

    /// GLSL 1.20 declarations of every texture and the layout constants.
    pub fn glsl(&self) -> String {
        self.glsl_with(Fetch::Texture2D)
    }

    /// GLSL declarations of every texture and the layout constants, fetching through `fetch`.
    pub fn glsl_with(&self, fetch: Fetch) -> String {
        let mut s = format!(
            "#define TRI_TEXELS {TRI_TEXELS}.0\n#define MAT_TEXELS {MAT_TEXELS}.0\n\
             #define CELL_TEXELS {}.0\n",
            self.format.irregular_cell_texels()
        );
        s.push_str(&self.format.glsl());
        for (k, t) in self.all().into_iter().enumerate() {
            s.push_str(&t.glsl_format(fetch, STORAGE_BINDING_BASE + k as u32, self.format));
        }
        if let Some(i) = &self.irregular {
            s.push_str(&i.glsl());
        }
        if let Some(t) = &self.tex {
            s.push_str(&t.glsl(fetch));
        }
        s
    }

    /// Storage blocks the textures take under [`Fetch::Storage`]: one per texture, and the
    /// float views the kernels read entries through (the list's, the voxel map's).
    pub fn storage_blocks(&self) -> u32 {
        self.all().len() as u32 + 1 + u32::from(self.irregular.is_some())
    }

    /// Total bytes uploaded.
    pub fn bytes(&self) -> usize {
        self.all().iter().map(|t| t.bytes()).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Emulates the GLSL fetch arithmetic in f32 and checks it lands on the packed texel.
    #[test]
    fn fetch_arithmetic_is_exact_up_to_2_pow_24() {
        let t = PackedTexture::pack("x", vec![[0.0; 4]; 5000], 2048).unwrap();
        assert_eq!((t.width, t.height), (2048, 3));
        for w in [1u32, 2, 64, 2048, 4096] {
            let inv_w = 1.0 / w as f32;
            for i in [0u32, 1, w - 1, w, w + 1, 12345, (1 << 24) - 1] {
                let fi = i as f32;
                let y = (fi * inv_w).floor();
                let x = fi - y * w as f32;
                assert_eq!((x as u32, y as u32), (i % w, i / w), "w {w} i {i}");
            }
        }
    }

    /// Entry textures hold their scalars in order, four to a texel with the last padded, and
    /// only they get `entry_<name>`: the cell list and the voxel map of a real build, not the
    /// record textures.
    #[test]
    fn entry_textures_pack_in_order_and_only_they_get_entry_functions() {
        let e: Vec<f32> = (1..=6).map(|i| i as f32).collect();
        let t = PackedTexture::pack_entries("list", &e, 64).unwrap();
        assert!(t.entries);
        assert_eq!((t.width, t.height), (2, 1));
        assert_eq!(t.data, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 0.0, 0.0]);

        use crate::accel::{IrregularConfig, IrregularGrid};
        use crate::testing::scene_of;
        use glam::Vec3;
        let s = scene_of(&[[Vec3::ZERO, Vec3::X, Vec3::Y], [Vec3::Z, Vec3::X, Vec3::Y]]);
        let g = IrregularGrid::build(&s, &IrregularConfig::default()).unwrap();
        let l = SceneTextures::pack(&s, &g, 4096).unwrap();
        let vmap = &l.irregular.as_ref().unwrap().vmap;
        for fetch in [Fetch::Texture2D, Fetch::TexelFetch, Fetch::Storage] {
            for t in [&l.list, vmap] {
                assert!(t.entries, "{}", t.name);
                let glsl = t.glsl_with(fetch, 9);
                assert!(glsl.contains(&format!("entry_{}(", t.name)), "{fetch:?}");
            }
            for t in [&l.tri, &l.mat, &l.cell] {
                assert!(!t.entries, "{}", t.name);
                assert!(!t.glsl_with(fetch, 9).contains("entry_"), "{}", t.name);
            }
        }
        // Every triangle index of the grid's lists, in order.
        let n = g.tri_indices.len();
        let listed: Vec<u32> = l.list.data[..n].iter().map(|&x| x as u32).collect();
        assert_eq!(listed, g.tri_indices);
    }

    #[test]
    fn too_large_is_a_clear_error() {
        let e = PackedTexture::pack("big", vec![[0.0; 4]; 64 * 64 + 1], 64).unwrap_err();
        assert!(e.to_string().contains("GL_MAX_TEXTURE_SIZE is 64"), "{e}");
        let ok = PackedTexture::pack("fit", vec![[0.0; 4]; 64 * 64], 64).unwrap();
        assert_eq!((ok.width, ok.height), (64, 64));
    }
}
