//! The Whitted shading model, exactly as every backend evaluates it.
//! GLSL twin: `glsl120/shade.glsl`.
//!
//! L = ka·A·albedo + Σ_visible I_l·(kd·albedo·max(0, n·l) + ks·max(0, r·v)^ns)
//!     + kr·L(reflected) + kt·L(refracted)
//!
//! Conventions shared with the GPU:
//! - The geometric normal `ng` comes from the winding (v1-v0)x(v2-v0); the shading normal
//!   interpolates vertex normals when the triangle has them. Both are flipped to face the
//!   incoming ray (opaque surfaces are two-sided).
//! - A light contributes only when it lies above both the geometric and the shading
//!   horizon and its shadow ray reaches it unblocked (every surface occludes, glass too).
//! - Refraction decides inside/outside from the unflipped geometric normal: the ray enters
//!   when d·ng < 0. Total internal reflection moves the transmitted weight to reflection.
//! - Spawned rays start at the hit point offset along ±ng by pbrt's error bound of the
//!   barycentric hit point, then nudged one more rounding step away from the surface:
//!   the offset scales with the coordinates, never with a fixed epsilon.
//! - Shadow rays of triangles with vertex normals (`Terminator::Smooth`) ignore hits
//!   while they are still within the mesh's own folds: `gap` = nf·Σ b_k·|h_k|·n_k is how
//!   far p lies from the smooth surface those normals describe (h_k = (p - v_k)·n_k its
//!   height above vertex k's tangent plane, n_k facing the side the ray came from; the
//!   below-the-planes part is Hanika 2021's lift), and the ray, from the usual offset
//!   origin, starts where it has risen 2·gap above the triangle's plane, at most a third of
//!   the longest edge away. Past that every hit counts: the ray is part of the exact one,
//!   so it reaches the light wherever the exact ray does, and otherwise only where all
//!   that blocks the exact ray lies that close to p (the neighbours' folds). Reflected and
//!   refracted rays start at `p`.

use super::real::{Real, V3};
use super::traverse::Hit;
use crate::scene::{Material, Scene};
use crate::technique::{OffsetMethod, Techniques, Terminator, OFFSET_EPSILON};

/// Everything the shading model needs about a hit.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint<T> {
    /// Hit point from the barycentric combination of the vertices.
    pub p: V3<T>,
    /// Absolute error bound of `p` per component.
    pub p_err: V3<T>,
    /// Unit geometric normal from the winding (not flipped).
    pub ng: V3<T>,
    /// Unit geometric normal facing the incoming ray.
    pub nf: V3<T>,
    /// Unit shading normal facing the incoming ray.
    pub ns: V3<T>,
    /// True when the ray arrived from the side `ng` points to (it is entering).
    pub entering: bool,
    /// Material index.
    pub material: u32,
    /// How far `p` lies from the smooth surface of the vertex normals, along `nf`
    /// (nf·Σ b_k·|h_k|·n_k, ≥ 0): the height a [`Terminator::Smooth`] shadow ray rises
    /// through, twice over, before it tests hits ([`terminator_skip`]). Zero without vertex
    /// normals or where the sum is not positive.
    pub gap: T,
    /// The most a shadow ray skips: a third of the triangle's longest edge (the folds of
    /// its neighbours lie within about that); zero where `gap` is.
    pub reach: T,
    /// True when the interpolated vertex normal faced away from the incoming ray (so `ns`
    /// is its negation): the ray sees the surface's curvature with the opposite sign.
    pub flipped: bool,
}

/// Builds the surface point of a hit of ray direction `d`.
pub fn surface<T: Real>(
    scene: &Scene,
    verts: &[V3<T>; 3],
    hit: &Hit<T>,
    d: V3<T>,
) -> SurfacePoint<T> {
    surface_with(scene, verts, geometric_normal(verts), hit, d)
}

/// The unit geometric normal of triangle `verts` (winding order): what [`surface`] uses,
/// worked out once per triangle by a renderer that shades many hits.
#[inline]
pub fn geometric_normal<T: Real>(verts: &[V3<T>; 3]) -> V3<T> {
    let n_raw = (verts[1] - verts[0]).cross(verts[2] - verts[0]);
    let len = n_raw.length();
    // Hits on zero-area triangles are impossible (`intersect` rejects a zero normal), but
    // guard anyway so no NaN can ever reach a pixel.
    if len > T::ZERO {
        n_raw * (T::ONE / len)
    } else {
        V3::new(T::ZERO, T::ONE, T::ZERO)
    }
}

/// [`surface`] with the triangle's [`geometric_normal`] `ng` given.
#[inline]
pub fn surface_with<T: Real>(
    scene: &Scene,
    verts: &[V3<T>; 3],
    ng: V3<T>,
    hit: &Hit<T>,
    d: V3<T>,
) -> SurfacePoint<T> {
    let [b0, b1, b2] = hit.b;
    let p = verts[0] * b0 + verts[1] * b1 + verts[2] * b2;
    let p_err =
        ((verts[0] * b0).abs() + (verts[1] * b1).abs() + (verts[2] * b2).abs()) * T::gamma(7);
    let entering = d.dot(ng) < T::ZERO;
    let nf = if entering { ng } else { -ng };
    let tri = &scene.triangles[hit.tri as usize];
    let mut ns = nf;
    let (mut gap, mut reach) = (T::ZERO, T::ZERO);
    let mut flipped = false;
    if tri.has_normals() {
        let n = |k: usize| V3::<T>::from_vec3(scene.normals[tri.n[k] as usize]);
        let s = n(0) * b0 + n(1) * b1 + n(2) * b2;
        let l = s.length();
        if l > T::ZERO && l.is_finite() {
            let s = s * (T::ONE / l);
            let flip = s.dot(nf) < T::ZERO;
            flipped = flip;
            ns = if flip { -s } else { s };
            // The vertex normals on the side the shading normal faces, as ns is.
            let nk = |k: usize| if flip { -n(k) } else { n(k) };
            let away = terminator_gap(p, verts[0], nk(0), b0)
                + terminator_gap(p, verts[1], nk(1), b1)
                + terminator_gap(p, verts[2], nk(2), b2);
            // Only its component along the facing normal: the shadow ray's rise off the
            // triangle is measured along it (a vertex normal far from the face, as at
            // Sponza's sharp edges, adds nothing).
            let up = away.dot(nf);
            if up > T::ZERO {
                gap = up;
                reach = third_of_longest_edge(verts);
            }
        }
    }
    SurfacePoint {
        p,
        p_err,
        ng,
        nf,
        ns,
        entering,
        material: tri.material,
        gap,
        reach,
        flipped,
    }
}

/// A third of the longest edge of triangle `verts`: [`SurfacePoint::reach`].
#[inline(always)]
pub fn third_of_longest_edge<T: Real>(verts: &[V3<T>; 3]) -> T {
    let e2 = |a: V3<T>, b: V3<T>| (b - a).dot(b - a);
    let m = e2(verts[0], verts[1])
        .max(e2(verts[1], verts[2]))
        .max(e2(verts[2], verts[0]));
    m.sqrt() * T::from_f64(1.0 / 3.0)
}

/// Vertex `v`'s share of the terminator gap of hit point `p` with barycentric weight `b`:
/// `b·|h|·n`, `h` = (p - v)·n the height of `p` above the tangent plane of unit normal `n`
/// at `v`. Below the plane (a convex region: the triangle lies under the smooth surface)
/// it is Hanika's lift, "Hacking the Shadow Terminator" (Ray Tracing Gems II, 2021);
/// above it (concave: the neighbours fold up above the triangle's plane) it is the same
/// distance the other way.
#[inline(always)]
fn terminator_gap<T: Real>(p: V3<T>, v: V3<T>, n: V3<T>, b: T) -> V3<T> {
    n * (b * (p - v).dot(n).abs())
}

/// Origin for a ray leaving `sp` in direction `w`: offset to the side of the surface that
/// `w` points to, by the error bound projected on the normal, then one more step away.
pub fn offset_origin<T: Real>(sp: &SurfacePoint<T>, w: V3<T>) -> V3<T> {
    offset_origin_with(sp, w, OffsetMethod::ErrorBound)
}

/// [`offset_origin`] by `method`: `Epsilon` moves the hit point by the fixed
/// [`OFFSET_EPSILON`] along the geometric normal, on the side `w` points to.
#[inline]
#[allow(clippy::double_comparisons)]
pub fn offset_origin_with<T: Real>(sp: &SurfacePoint<T>, w: V3<T>, method: OffsetMethod) -> V3<T> {
    if method == OffsetMethod::Epsilon {
        let eps = T::from_f64(OFFSET_EPSILON);
        let off = if w.dot(sp.ng) < T::ZERO { -eps } else { eps };
        return sp.p + sp.ng * off;
    }
    let dist = sp.ng.abs().dot(sp.p_err);
    let mut off = sp.ng * dist;
    if w.dot(sp.ng) < T::ZERO {
        off = -off;
    }
    let po = sp.p + off;
    // Written as selects, not branches: the offset's signs follow the normal's, which
    // change from pixel to pixel, and mispredicted branches here cost more than the sum.
    // The same values: `x - step` is `x + (-step)`, and a zero (or NaN) offset keeps `x`
    // (hence `o > 0 || o < 0`, not `o != 0`, which a NaN passes).
    let nudge = |x: T, o: T| {
        let step = x.abs() * (T::UNIT_ROUNDOFF + T::UNIT_ROUNDOFF) + T::from_f32(1e-30);
        let moved = x + if o > T::ZERO { step } else { -step };
        if o > T::ZERO || o < T::ZERO {
            moved
        } else {
            x
        }
    };
    V3::new(nudge(po.x, off.x), nudge(po.y, off.y), nudge(po.z, off.z))
}

/// The shadow ray from `sp` towards a point light at `lp`: its origin (offset off the
/// surface by `tech`), unit direction and length, or `None` when the light is below the
/// geometric or shading horizon. The scalar reference of `shade_lanes::shadows_generic`.
///
/// With [`Terminator::Smooth`] the ray starts [`terminator_skip`] further along the exact
/// ray (from `p` offset by `tech.offset`): the stretch within the neighbours' folds is not
/// tested, the rest is.
pub fn shadow_ray<T: Real>(
    sp: &SurfacePoint<T>,
    lp: V3<T>,
    tech: Techniques,
) -> Option<(V3<T>, V3<T>, T)> {
    let to_l = lp - sp.p;
    if to_l.dot(sp.nf) <= T::ZERO || sp.ns.dot(to_l) <= T::ZERO {
        return None; // below the geometric or shading horizon
    }
    let o = offset_origin_with(sp, to_l, tech.offset);
    let dl = lp - o;
    let dist = dl.length();
    let l = dl * (T::ONE / dist);
    match tech.terminator {
        Terminator::Exact => Some((o, l, dist)),
        Terminator::Smooth => {
            let skip = terminator_skip(sp, l, dist);
            if skip > T::ZERO {
                Some((o + l * skip, l, dist - skip))
            } else {
                Some((o, l, dist))
            }
        }
    }
}

/// How far a shadow ray of unit direction `l` and length `dist` from `sp` runs before
/// hits count: until it has risen `2·sp.gap` above the triangle's plane
/// (`2·gap / (l·nf)`), but at most `sp.reach` and `dist`; zero without a gap. Twice the
/// gap: the neighbours' folds rise up to about 1.25 gaps above the plane where they block
/// (dragon.toml's speckles, docs/robustness.md).
#[inline(always)]
pub fn terminator_skip<T: Real>(sp: &SurfacePoint<T>, l: V3<T>, dist: T) -> T {
    if sp.gap > T::ZERO {
        let rise = sp.nf.dot(l);
        let height = sp.gap + sp.gap;
        // height / rise where that is below reach (no division by a tiny rise).
        let skip = if height < sp.reach * rise {
            height / rise
        } else {
            sp.reach
        };
        skip.min(dist)
    } else {
        T::ZERO
    }
}

/// Albedo at point `p` (the checker replaces the flat colour when present).
pub fn albedo<T: Real>(m: &Material, p: V3<T>) -> V3<T> {
    match &m.checker {
        None => V3::from_vec3(m.albedo),
        Some(c) => {
            let (a, b) = c.axes.indices();
            let inv = T::ONE / T::from_f32(c.scale);
            let (u, v) = (
                p[a] + T::from_f32(c.phase[0]),
                p[b] + T::from_f32(c.phase[1]),
            );
            let s = (u * inv).floor() + (v * inv).floor();
            let half = s * T::from_f32(0.5);
            if half.floor() == half {
                V3::from_vec3(c.color_a)
            } else {
                V3::from_vec3(c.color_b)
            }
        }
    }
}

/// Mirror direction of `d` about unit normal `n`.
#[inline(always)]
pub fn reflect<T: Real>(d: V3<T>, n: V3<T>) -> V3<T> {
    d - n * ((T::ONE + T::ONE) * d.dot(n))
}

/// Secondary-ray weights and directions at a hit.
#[derive(Clone, Copy, Debug)]
pub struct Secondary<T> {
    /// Effective reflection weight (after Fresnel and total internal reflection).
    pub kr: V3<T>,
    /// Effective transmission weight.
    pub kt: V3<T>,
    /// Unit reflected direction.
    pub reflected: V3<T>,
    /// Unit refracted direction (meaningful only when `kt` is non-zero).
    pub refracted: V3<T>,
}

/// Reflection and refraction for unit incoming direction `d`.
pub fn secondary<T: Real>(m: &Material, sp: &SurfacePoint<T>, d: V3<T>) -> Secondary<T> {
    let zero = V3::splat(T::ZERO);
    let mut reflected = reflect(d, sp.ns);
    if reflected.dot(sp.nf) <= T::ZERO {
        // The shading normal sent the mirror ray under the surface: use the true normal.
        reflected = reflect(d, sp.nf);
    }
    let mut kr = if m.fresnel { zero } else { V3::from_vec3(m.kr) };
    let mut kt = if m.fresnel { zero } else { V3::from_vec3(m.kt) };
    let mut refracted = zero;
    if m.refracts() {
        let ior = T::from_f32(m.ior);
        let (n1, n2) = if sp.entering {
            (T::ONE, ior)
        } else {
            (ior, T::ONE)
        };
        let eta = n1 / n2;
        let cos_i = (-d.dot(sp.ns)).min(T::ONE);
        let k = T::ONE - eta * eta * (T::ONE - cos_i * cos_i);
        if k < T::ZERO {
            // Total internal reflection: all energy goes to the mirror ray.
            kr = if m.fresnel {
                V3::splat(T::ONE)
            } else {
                kr + kt
            };
            kt = zero;
        } else {
            let cos_t = k.sqrt();
            refracted = (d * eta + sp.ns * (eta * cos_i - cos_t)).normalize();
            if refracted.dot(sp.nf) >= T::ZERO {
                // Shading normal put the transmitted ray on the wrong side: bend with ng.
                let cos_g = -d.dot(sp.nf);
                let kg = T::ONE - eta * eta * (T::ONE - cos_g * cos_g);
                refracted = (d * eta + sp.nf * (eta * cos_g - kg.max(T::ZERO).sqrt())).normalize();
            }
            if m.fresnel {
                let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
                let rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
                let f = (rs * rs + rp * rp) * T::from_f32(0.5);
                kr = V3::splat(f);
                kt = V3::splat(T::ONE - f);
            }
        }
    }
    Secondary {
        kr,
        kt,
        reflected,
        refracted,
    }
}

/// Direct term of one visible light: kd·albedo·max(0,n·l) + ks·max(0,r·v)^ns, times I_l.
/// `l` is the unit direction to the light, `v` the unit direction to the viewer.
pub fn light_term<T: Real>(
    m: &Material,
    albedo: V3<T>,
    sp: &SurfacePoint<T>,
    l: V3<T>,
    v: V3<T>,
    radiance: V3<T>,
) -> V3<T> {
    let ndotl = sp.ns.dot(l);
    if ndotl <= T::ZERO {
        return V3::splat(T::ZERO);
    }
    let mut c = albedo * (T::from_f32(m.kd) * ndotl);
    if m.ks.max_element() > 0.0 {
        c = c + specular(m, sp.ns, l, v);
    }
    c.mul_elem(radiance)
}

/// The specular highlight of [`light_term`] (Phong: `ks (r.v)^ns`, `r` the light's
/// direction mirrored about the shading normal `ns`), before the light's radiance.
#[inline]
pub fn specular<T: Real>(m: &Material, ns: V3<T>, l: V3<T>, v: V3<T>) -> V3<T> {
    let r = reflect(-l, ns);
    let rv = r.dot(v).max(T::ZERO);
    V3::from_vec3(m.ks) * rv.powf(T::from_f32(m.ns))
}

#[cfg(test)]
#[path = "shade_tests.rs"]
mod tests;
