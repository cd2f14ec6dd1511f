//! The `tex` texture of a textured scene ([`TexLayout`]): texture coordinates, vertex
//! colours and every image texture with its mip levels in one atlas. GLSL twin of the
//! reads: `glsl120/texture.glsl`.

use super::{Fetch, PackedTexture, MAX_EXACT_INDEX};
use crate::scene::Scene;
use crate::{Error, Result};

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
    /// Texels [`TexLayout::pack`] lays out for `scene` (`None`: no `tex` texture), counted
    /// before anything is allocated.
    pub(super) fn texels(scene: &Scene) -> Option<u64> {
        if !scene.has_textures() && !scene.has_vertex_colors() {
            return None;
        }
        let n = scene.triangles.len() as u64;
        let colors = if scene.has_vertex_colors() { 3 * n } else { 0 };
        let textures: u64 = scene
            .textures
            .iter()
            .map(|t| {
                1 + t
                    .levels
                    .iter()
                    .map(|l| 1 + l.texels.len() as u64)
                    .sum::<u64>()
            })
            .sum();
        Some(n * TEX_REC as u64 + colors + textures)
    }

    /// The layout of `scene`, or `None` when it has neither textures nor vertex colours.
    pub(super) fn pack(scene: &Scene, max_size: u32) -> Result<Option<Self>> {
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
        // The size check counted these texels before any was allocated (`LayoutPlan`).
        if Some(texels.len() as u64) != Self::texels(scene) {
            return Err(Error::Internal(format!(
                "`tex` packed {} texels where {:?} were counted",
                texels.len(),
                Self::texels(scene)
            )));
        }
        Ok(Some(TexLayout {
            texture: PackedTexture::pack("tex", texels, max_size)?,
            colors,
            headers,
        }))
    }

    /// GLSL after the `tex` fetch: the constants, the fragment kernels' cone records and
    /// root cone (`fetch` [`Fetch::Texture2D`]), and `glsl120/texture.glsl`.
    pub(super) fn glsl(&self, fetch: Fetch) -> String {
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
        s + include_str!("../../../glsl120/texture.glsl")
    }
}
