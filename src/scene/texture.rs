//! Image textures of the scene model: decoded once at load time into linear RGB, with the
//! mip pyramid built here on the CPU (a 2x2 box filter in linear light), so that the CPU
//! renderer and the GPU's atlas (`gpu/layout/`) read the very same texels. Sampling
//! (bilinear, level of detail from ray cones) is the renderers' job: `cpu/texture.rs` and
//! its GLSL twin `glsl120/texture.glsl`.
//!
//! Rows are stored bottom-up: texel row 0 is the image's last row, so that OBJ's and the
//! GPU's convention (v = 0 at the bottom) need no flip when sampling: the centre of texel
//! (i, j) of a W x H level sits at uv = ((i + 0.5) / W, (j + 0.5) / H).

use std::path::Path;

/// How texture coordinates outside [0, 1] map into the image, per axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Wrap {
    /// The image tiles the plane (OBJ's default; glTF's REPEAT).
    #[default]
    Repeat,
    /// Coordinates clamp to the edge texels (MTL `-clamp on`; glTF's CLAMP_TO_EDGE).
    Clamp,
    /// The image tiles mirrored every other period (glTF's MIRRORED_REPEAT).
    Mirror,
}

impl Wrap {
    /// The code stored in the GPU's texture table (and tested in GLSL).
    pub fn code(self) -> f32 {
        match self {
            Wrap::Repeat => 0.0,
            Wrap::Clamp => 1.0,
            Wrap::Mirror => 2.0,
        }
    }
}

/// One level of a texture's mip pyramid: linear RGB texels, rows bottom-up.
#[derive(Clone, Debug, PartialEq)]
pub struct TexLevel {
    /// Width in texels (at least 1).
    pub width: u32,
    /// Height in texels (at least 1).
    pub height: u32,
    /// `width * height` linear RGB texels, row 0 at the bottom.
    pub texels: Vec<[f32; 3]>,
}

/// An image texture: its mip pyramid, its wrap modes and where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// The file it was read from, for messages.
    pub source: String,
    /// Wrap mode along u and along v.
    pub wrap: [Wrap; 2],
    /// Level 0 is the image; each next level halves each side (rounding down, at least 1)
    /// down to 1 x 1.
    pub levels: Vec<TexLevel>,
}

/// Largest texture side accepted (GeForce 6/7's largest texture; the atlas row is this wide).
pub const MAX_TEXTURE_SIDE: u32 = 4096;
/// Largest texture file read.
pub const MAX_TEXTURE_BYTES: u64 = 256 << 20;

/// 8-bit sRGB to linear, by the exact sRGB transfer function (IEC 61966-2-1) in f64.
pub fn srgb8_to_linear(c: u8) -> f32 {
    let x = c as f64 / 255.0;
    let l = if x <= 0.04045 {
        x / 12.92
    } else {
        ((x + 0.055) / 1.055).powf(2.4)
    };
    l as f32
}

impl Texture {
    /// A texture from level 0 (linear RGB, rows bottom-up), its pyramid built.
    pub fn from_linear(source: String, wrap: [Wrap; 2], base: TexLevel) -> Self {
        let mut levels = vec![base];
        loop {
            let last = levels.last().expect("level 0 exists");
            if last.width == 1 && last.height == 1 {
                break;
            }
            let next = downsample(last);
            levels.push(next);
        }
        Texture {
            source,
            wrap,
            levels,
        }
    }

    /// Decodes a PNG, JPEG or TGA image (8-bit sRGB: decoded to linear; 16-bit channels
    /// are taken as sRGB too; alpha is dropped) into a texture.
    pub fn decode(bytes: &[u8], source: String, wrap: [Wrap; 2]) -> Result<Self, String> {
        let img = image::load_from_memory(bytes).map_err(|e| e.to_string())?;
        let rgb = img.to_rgb8();
        let (w, h) = rgb.dimensions();
        if w == 0 || h == 0 || w > MAX_TEXTURE_SIDE || h > MAX_TEXTURE_SIDE {
            return Err(format!(
                "{w}x{h} texels: a texture's sides must be 1..={MAX_TEXTURE_SIDE}"
            ));
        }
        let lut: Vec<f32> = (0..=255u8).map(srgb8_to_linear).collect();
        let mut texels = Vec::with_capacity((w * h) as usize);
        for row in (0..h).rev() {
            for col in 0..w {
                let p = rgb.get_pixel(col, row).0;
                texels.push(p.map(|c| lut[c as usize]));
            }
        }
        Ok(Self::from_linear(
            source,
            wrap,
            TexLevel {
                width: w,
                height: h,
                texels,
            },
        ))
    }

    /// Reads and decodes an image file (a regular file of at most [`MAX_TEXTURE_BYTES`]).
    pub fn load(path: &Path, wrap: [Wrap; 2]) -> Result<Self, String> {
        let bytes = super::read_input_file(path, MAX_TEXTURE_BYTES, "texture image")
            .map_err(|e| e.to_string())?;
        Self::decode(&bytes, path.display().to_string(), wrap)
    }

    /// Texels of all levels.
    pub fn texel_count(&self) -> usize {
        self.levels.iter().map(|l| l.texels.len()).sum()
    }

    /// Why this texture cannot be sampled, if it cannot: a level whose size or texel count
    /// is wrong, a non-finite or negative texel.
    pub fn invalid(&self) -> Option<String> {
        if self.levels.is_empty() {
            return Some("no texels".into());
        }
        for (k, l) in self.levels.iter().enumerate() {
            if l.width == 0 || l.height == 0 || l.texels.len() != (l.width * l.height) as usize {
                return Some(format!(
                    "level {k}: {}x{} with {} texels",
                    l.width,
                    l.height,
                    l.texels.len()
                ));
            }
            if let Some(t) = l
                .texels
                .iter()
                .find(|t| t.iter().any(|c| !c.is_finite() || *c < 0.0))
            {
                return Some(format!("level {k}: texel {t:?} must be finite and >= 0"));
            }
        }
        None
    }
}

/// The next mip level: each side halved (rounding down, at least 1), each texel the mean of
/// the 2x2 texels it covers (clamped at an odd edge), summed in f64.
fn downsample(l: &TexLevel) -> TexLevel {
    let (w, h) = ((l.width / 2).max(1), (l.height / 2).max(1));
    let at =
        |x: u32, y: u32| l.texels[(y.min(l.height - 1) * l.width + x.min(l.width - 1)) as usize];
    let mut texels = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let mut s = [0f64; 3];
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let t = at(2 * x + dx, 2 * y + dy);
                for c in 0..3 {
                    s[c] += t[c] as f64;
                }
            }
            texels.push(s.map(|v| (v * 0.25) as f32));
        }
    }
    TexLevel {
        width: w,
        height: h,
        texels,
    }
}

/// Smallest |width| and |n·d| the level of detail's logarithms see (a zero would give
/// -inf), on every backend.
pub const LOD_TINY: f32 = 1.0e-30;

/// The spread angle of a primary ray's cone: one pixel of an image `height` pixels high
/// under a vertical field of view of `vfov_deg`, `atan(2 tan(fov/2) / H)`, in f64 (the f32
/// CPU and the GPU take it rounded to f32).
pub fn pixel_spread(vfov_deg: f32, height: u32) -> f64 {
    (2.0 * ((vfov_deg as f64).to_radians() * 0.5).tan() / height as f64).atan()
}

/// `lod_bias` of a triangle without texture coordinates: so large that every lookup takes
/// the last level, the texture's mean.
pub const NO_UV_BIAS: f32 = 1.0e6;

/// What shading needs of a triangle for textures and ray cones, worked out once per
/// triangle in f64 and rounded to f32 (the CPU renderer and the GPU's `tex` records read
/// the same numbers): corner texture coordinates, the level-of-detail bias
/// `0.5 log2(texel area / world area)` of its material's texture (Akenine-Moeller et al.
/// 2021, eq. 34: Δ0), and the mean curvature of its vertex normals along its edges.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriTex {
    /// Texture coordinates of the three corners (zero without).
    pub uv: [[f32; 2]; 3],
    /// Δ0 (0 for an untextured material, [`NO_UV_BIAS`] without texture coordinates).
    pub lod_bias: f32,
    /// Mean over the three edges of `(n_j - n_i)·(p_j - p_i) / |p_j - p_i|^2`: positive
    /// where the surface bulges towards its vertex normals (1/r on a sphere of radius r,
    /// normals outwards); 0 without vertex normals.
    pub curvature: f32,
}

impl TriTex {
    /// The record of triangle `i` of `scene`: one of its own, or (an id past them) an
    /// instance's, worked out on the triangle [`Scene::flattened`](super::Scene::flattened)
    /// stores (placed vertices and normals rounded to f32, corners in the placed winding),
    /// so a two-level walk's hit reads the flattened scene's record.
    pub fn of(scene: &super::Scene, i: usize) -> TriTex {
        let p = scene.placed_vertices(i).map(|v| v.as_dvec3());
        let corners = scene.placed_uvs(i);
        let has_uv = corners.is_some();
        let uv = corners.map_or([[0.0; 2]; 3], |c| c.map(|v| v.to_array()));
        let map = scene.materials[scene.placed_material(i) as usize].diffuse_map;
        let lod_bias = match (map, has_uv) {
            (None, _) => 0.0,
            (Some(_), false) => NO_UV_BIAS,
            (Some(k), true) => {
                let l0 = &scene.textures[k as usize].levels[0];
                let d = |a: [f32; 2], b: [f32; 2]| {
                    glam::DVec2::new((b[0] - a[0]) as f64, (b[1] - a[1]) as f64)
                };
                let (e1, e2) = (d(uv[0], uv[1]), d(uv[0], uv[2]));
                let ta = l0.width as f64 * l0.height as f64 * (e1.perp_dot(e2)).abs();
                let pa = (p[1] - p[0]).cross(p[2] - p[0]).length();
                if ta > 0.0 && pa > 0.0 {
                    (0.5 * (ta / pa).log2()) as f32
                } else if pa > 0.0 {
                    // One texel stretched over the triangle: the finest level.
                    -NO_UV_BIAS
                } else {
                    0.0
                }
            }
        };
        let normals = scene.placed_normals(i).map(|n| n.map(|v| v.as_dvec3()));
        let curvature = curvature(p, normals);
        TriTex {
            uv,
            lod_bias,
            curvature,
        }
    }
}

/// [`TriTex::curvature`] of a triangle of vertices `p` and vertex normals `n` (0 without):
/// also what the GPU's walk of instances works out for an instanced hit.
pub fn curvature(p: [glam::DVec3; 3], n: Option<[glam::DVec3; 3]>) -> f32 {
    let Some(n) = n else { return 0.0 };
    let mut sum = 0.0;
    for (a, b) in [(0, 1), (1, 2), (2, 0)] {
        let dp = p[b] - p[a];
        let l2 = dp.length_squared();
        if l2 > 0.0 {
            sum += (n[b] - n[a]).dot(dp) / l2;
        }
    }
    (sum / 3.0) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_decoding_hits_the_transfer_function_ends_and_knee() {
        assert_eq!(srgb8_to_linear(0), 0.0);
        assert_eq!(srgb8_to_linear(255), 1.0);
        assert!((srgb8_to_linear(10) - (10.0 / 255.0 / 12.92) as f32).abs() < 1e-9);
        assert!((srgb8_to_linear(188) - 0.5029).abs() < 1e-3);
    }

    #[test]
    fn pyramid_halves_to_one_texel_and_keeps_the_mean() {
        let texels: Vec<[f32; 3]> = (0..6 * 3).map(|i| [i as f32, 1.0, 0.0]).collect();
        let t = Texture::from_linear(
            "t".into(),
            [Wrap::Repeat; 2],
            TexLevel {
                width: 6,
                height: 3,
                texels,
            },
        );
        let sizes: Vec<(u32, u32)> = t.levels.iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, [(6, 3), (3, 1), (1, 1)]);
        // Level 1 texel 0: texels (0,0),(1,0),(0,1),(1,1) = 0, 1, 6, 7.
        assert_eq!(t.levels[1].texels[0], [3.5, 1.0, 0.0]);
        assert!(t.invalid().is_none());
    }
}
