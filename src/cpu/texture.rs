//! Texture lookups and ray cones, exactly as every backend evaluates them.
//! GLSL twin: `glsl120/texture.glsl`.
//!
//! Ray cones (Akenine-Moeller et al., "Improved Shader and Texture Level of Detail Using
//! Ray Cones", JCGT 10(1), 2021): every ray carries a cone, its signed width at the ray's
//! origin and its signed spread angle. A primary ray starts with width 0 and the spread of
//! one pixel, `atan(2 tan(fov/2) / H)`. At a hit at distance t the width is
//! `w = w0 + spread·t`; the level of detail there is
//! `λ = Δ0 + log2|w| - log2|n·d|` (Δ0: `TriTex::lod_bias`, n the geometric normal), and
//! the lookup is bilinear in mip level `clamp(floor(λ + 1/2), 0, levels - 1)`.
//! A reflected or refracted child starts with width w and the spread bent by the surface's
//! curvature k (`TriTex::curvature`, negated when the ray sees the surface from the side
//! opposite its vertex normals): reflection `spread + 2·k·w`, refraction with η = n1/n2
//! `η·spread + (η - 1)·k·w` (the paraxial lens: a convex glass surface focuses, η < 1).
//!
//! Bilinear filtering is written out from four nearest fetches (no hardware filtering), in
//! the order the GLSL writes it, so the CPU's f32 and the GPU compute the same texel:
//! x = u·W - 1/2, i0 = floor(x), f = x - i0, each index wrapped by the texture's mode, then
//! `a + (b - a)·f` along u and then along v.

use super::real::{Real, V3};
use crate::scene::texture::{Texture, TriTex, Wrap};
use crate::scene::Scene;

/// A ray cone: signed width at the ray's origin and signed spread angle (radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone<T> {
    /// Width at the origin.
    pub width: T,
    /// Spread angle: the width grows by this much per unit of distance.
    pub spread: T,
}

pub use crate::scene::texture::LOD_TINY;

pub use crate::scene::texture::pixel_spread;

/// The primary ray's cone.
pub fn primary_cone<T: Real>(vfov_deg: f32, height: u32) -> Cone<T> {
    Cone {
        width: T::ZERO,
        spread: T::from_f64(pixel_spread(vfov_deg, height)),
    }
}

/// The level of detail at a hit: `bias + log2|w| - log2|cos|`.
#[inline]
pub fn lod<T: Real>(bias: T, width: T, cos: T) -> T {
    let tiny = T::from_f32(LOD_TINY);
    bias + width.abs().max(tiny).log2() - cos.abs().max(tiny).log2()
}

/// The mip level a level of detail selects among `levels`.
#[inline]
pub fn level_of<T: Real>(lod: T, levels: usize) -> usize {
    let l = (lod + T::from_f32(0.5)).floor();
    let top = T::from_f32((levels - 1) as f32);
    if l > T::ZERO {
        l.min(top).to_f64() as usize
    } else {
        0
    }
}

/// Integer texel index `i` (a whole number) wrapped into `0..n` by `mode`. The division's
/// quotient is corrected by one step either way, so a GPU whose division is inexact lands
/// on the same index.
#[inline]
pub fn wrap_index<T: Real>(i: T, n: T, mode: Wrap) -> T {
    let period = |p: T| {
        let mut r = i - p * (i / p).floor();
        if r >= p {
            r = r - p;
        }
        if r < T::ZERO {
            r = r + p;
        }
        r
    };
    match mode {
        Wrap::Repeat => period(n),
        Wrap::Clamp => i.max(T::ZERO).min(n - T::ONE),
        Wrap::Mirror => {
            let r = period(n + n);
            if r >= n {
                n + n - T::ONE - r
            } else {
                r
            }
        }
    }
}

/// `a + (b - a)·f`, per component.
#[inline(always)]
fn lerp<T: Real>(a: V3<T>, b: V3<T>, f: T) -> V3<T> {
    a + (b - a) * f
}

/// The bilinear lookup of `tex` at (u, v) in mip level `level`.
pub fn bilinear<T: Real>(tex: &Texture, level: usize, u: T, v: T) -> V3<T> {
    let l = &tex.levels[level];
    let (w, h) = (T::from_f32(l.width as f32), T::from_f32(l.height as f32));
    let half = T::from_f32(0.5);
    let (x, y) = (u * w - half, v * h - half);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (xa, xb) = (
        wrap_index(x0, w, tex.wrap[0]),
        wrap_index(x0 + T::ONE, w, tex.wrap[0]),
    );
    let (ya, yb) = (
        wrap_index(y0, h, tex.wrap[1]),
        wrap_index(y0 + T::ONE, h, tex.wrap[1]),
    );
    let at = |x: T, y: T| {
        let k = y.to_f64() as usize * l.width as usize + x.to_f64() as usize;
        let t = l.texels[k];
        V3::new(T::from_f32(t[0]), T::from_f32(t[1]), T::from_f32(t[2]))
    };
    let bottom = lerp(at(xa, ya), at(xb, ya), fx);
    let top = lerp(at(xa, yb), at(xb, yb), fx);
    lerp(bottom, top, fy)
}

/// The interpolated texture coordinates of barycentrics `b` on a triangle's record.
#[inline]
pub fn uv_at<T: Real>(rec: &TriTex, b: [T; 3]) -> (T, T) {
    let c = |k: usize, j: usize| T::from_f32(rec.uv[k][j]);
    (
        c(0, 0) * b[0] + c(1, 0) * b[1] + c(2, 0) * b[2],
        c(0, 1) * b[0] + c(1, 1) * b[1] + c(2, 1) * b[2],
    )
}

/// The interpolated vertex colour of triangle `tri` (one of the scene's own, or an
/// instance's: its corners in the placed winding) at barycentrics `b`: white without
/// vertex colours (`coloured`: [`Scene::has_vertex_colors`]), and white corners
/// interpolated for a triangle without where others have them, as the flattened scene
/// stores it.
#[inline]
pub fn vertex_color<T: Real>(scene: &Scene, coloured: bool, tri: usize, b: [T; 3]) -> V3<T> {
    if !coloured {
        return V3::splat(T::ONE);
    }
    let c = scene.placed_colors(tri).unwrap_or([glam::Vec3::ONE; 3]);
    let c = |k: usize| V3::<T>::from_vec3(c[k]);
    c(0) * b[0] + c(1) * b[1] + c(2) * b[2]
}

/// The child cone of a hit whose cone has width `width` there and spread `spread`, on a
/// surface of curvature `k` as the ray sees it: reflected (`eta` = None) or refracted with
/// `eta` = n1/n2.
#[inline]
pub fn child_cone<T: Real>(width: T, spread: T, k: T, eta: Option<T>) -> Cone<T> {
    let kw = k * width;
    let spread = match eta {
        None => spread + (kw + kw),
        Some(eta) => eta * spread + (eta - T::ONE) * kw,
    };
    Cone { width, spread }
}

#[cfg(test)]
#[path = "texture_tests.rs"]
mod tests;
