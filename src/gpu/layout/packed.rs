//! [`PackedTexture`]: one RGBA32F texture of the layout, its row packing and the GLSL
//! fetches (`fetch_<name>`, `entry_<name>`, and the split format's `fetch_<name>_at` and
//! `entry_<name>_split`) that read it back exactly.

use super::{Fetch, IndexFormat, LIST_PER_TEXEL, MAX_ROW, SPLIT_BASE, TEXEL_INSET};
use crate::{Error, Result};

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
    /// True when records are addressed by triangle id, a [`float_slot`](super::float_slot), and stored densely
    /// (`tri`, `nrm`): in the split format `fetch_<name>_at` then decodes the slot into the
    /// record (`slot_coord`, `slot_record`).
    pub slots: bool,
}

impl PackedTexture {
    /// Packs `texels` (RGBA each) into rows no wider than [`MAX_ROW`], or than `max_size`
    /// where rows of [`MAX_ROW`] would need more than `max_size` of them. Whether the
    /// indices that address them are exact is the caller's ([`SceneTextures::pack`](super::SceneTextures::pack)).
    pub fn pack(name: &'static str, texels: Vec<[f32; 4]>, max_size: u32) -> Result<Self> {
        let (width, height) = texture_dims(texels.len() as u64, max_size);
        if height > max_size as u64 {
            return Err(too_large(
                name,
                texels.len() as u64,
                max_size,
                "--backend cpu",
            ));
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
            // The record's index in integers: one conversion of `item` for the record's
            // texels where the float sum took one per texel (the same index below 2^24;
            // 1% off the H100's equal-work kernel, docs/performance.md).
            (IndexFormat::Float, Fetch::Storage) => {
                format!("    return buf_{n}[int(item) * int(per) + int(k)];\n")
            }
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
            // The compute kernels' fetches (GLSL 4.30) also take the index as a `uint`
            // (`entry_<name>_u`), for the integer descent of the voxel map.
            Fetch::Storage => format!(
                "layout(std430, binding = {binding}) readonly buffer Entries_{n} {{ float entries_{n}[]; }};\n\
                 float entry_{n}(float i) {{\n\
                 \x20   return entries_{n}[int(i)];\n\
                 }}\n\
                 float entry_{n}_u(uint i) {{\n\
                 \x20   return entries_{n}[i];\n\
                 }}\n",
            ),
            Fetch::Texture2D | Fetch::TexelFetch => {
                let mut s = format!(
                    "float entry_{n}(float i) {{\n\
                     \x20   float texel = floor(i * {inv:?});\n\
                     \x20   vec4 sel = vec4(equal(vec4(i - texel * {per:.1}), vec4(0.0, 1.0, 2.0, 3.0)));\n\
                     \x20   return dot(fetch_{n}(texel), sel);\n\
                     }}\n",
                    inv = 1.0 / LIST_PER_TEXEL as f32,
                    per = LIST_PER_TEXEL as f32,
                );
                if matches!(fetch, Fetch::TexelFetch) {
                    s += &format!("float entry_{n}_u(uint i) {{\n\x20   return entry_{n}(float(i));\n}}\n");
                }
                s
            }
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

/// (width, height) of a texture of `texels` texels as [`PackedTexture::pack`] lays it out
/// under a limit of `max_size`: rows of [`MAX_ROW`] (a power of two), or rows as wide as
/// the limit allows where rows of [`MAX_ROW`] would need more than `max_size` of them. The
/// height may pass `max_size`: then the texture does not fit.
pub fn texture_dims(texels: u64, max_size: u32) -> (u32, u64) {
    let n = texels.max(1);
    let narrow = prev_pow2(max_size.min(MAX_ROW)).max(1);
    let cap = if n > narrow as u64 * max_size as u64 {
        prev_pow2(max_size).max(1)
    } else {
        narrow
    };
    let width = (n.next_power_of_two().min(cap as u64)) as u32;
    (width, n.div_ceil(width as u64))
}

/// The one line refusing texture `name` of `texels` texels beyond `max_size`, naming
/// `options` that render the scene instead.
pub(super) fn too_large(name: &str, texels: u64, max_size: u32, options: &str) -> Error {
    let (width, height) = texture_dims(texels, max_size);
    Error::Limit(format!(
        "texture `{name}` needs {} texels, {width}x{height}, but GL_MAX_TEXTURE_SIZE is \
         {max_size}; render it with {options}",
        texels.max(1)
    ))
}

pub(super) fn prev_pow2(v: u32) -> u32 {
    if v == 0 {
        0
    } else {
        1 << (31 - v.leading_zeros())
    }
}
