//! Watertight ray-triangle intersection (Woop, Benthin, Wald 2013), and Möller–Trumbore
//! (1997) for measuring what watertightness buys (`--intersect moller-trumbore`, see
//! `crate::technique`). GLSL twin: `glsl120/intersect.glsl` (same operation order, so f32
//! results agree).
//!
//! Why watertight: the edge functions U, V, W are evaluated in a ray-aligned shear frame
//! where a point on an edge shared by two triangles gives bit-identical values (with
//! opposite sign) for both, so a ray can never slip between them. A zero edge function
//! counts as inside for both triangles; the closest-hit rule then breaks the tie by the
//! lower triangle index, the same on every backend. We do not use the paper's
//! double-precision fallback for zero edge functions because GLSL 1.20 has no doubles and
//! every backend must take the same decision. Watertightness rules out false misses on
//! shared edges, not false hits on a triangle whose edge functions are all rounding noise:
//! triangles of zero area (zero normal) are therefore rejected outright.

use super::real::{Real, V3};
use crate::technique::{IntersectMethod, TBound, Techniques};

/// Per-ray constants of the shear transform.
#[derive(Clone, Copy, Debug)]
pub struct RayShear<T> {
    /// Axis along which the ray direction is largest in magnitude.
    pub kz: usize,
    /// The other two axes, ordered to preserve winding.
    pub kx: usize,
    /// See `kx`.
    pub ky: usize,
    /// Shear constants.
    pub sx: T,
    /// See `sx`.
    pub sy: T,
    /// `1 / d[kz]`.
    pub sz: T,
}

impl<T: Real> RayShear<T> {
    /// Precomputes the shear for direction `d` (must be non-zero).
    pub fn new(d: V3<T>) -> Self {
        let a = d.abs();
        // Ties resolve to the lower axis, as in the GLSL twin.
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < T::ZERO {
            std::mem::swap(&mut kx, &mut ky);
        }
        RayShear {
            kz,
            kx,
            ky,
            sx: d[kx] / d[kz],
            sy: d[ky] / d[kz],
            sz: T::ONE / d[kz],
        }
    }
}

/// A ray-triangle hit: parameter and barycentric weights of v0, v1, v2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriHit<T> {
    /// Ray parameter.
    pub t: T,
    /// Barycentric weights (b0 for v0, ...), summing to 1.
    pub b: [T; 3],
}

/// Intersects the ray (o, shear of d) with triangle (p0, p1, p2); accepts t in
/// (t_min, t_max) open at both ends. Either winding is hit. The default techniques:
/// watertight, with the t error bound.
#[inline(always)]
pub fn intersect<T: Real>(
    o: V3<T>,
    s: &RayShear<T>,
    p: &[V3<T>; 3],
    t_min: T,
    t_max: T,
) -> Option<TriHit<T>> {
    intersect_watertight(o, s, p, t_min, t_max, TBound::On)
}

/// Intersects the ray (o, d) with triangle `p` by the method `tech` selects (`s` must be
/// the shear of `d`; Möller–Trumbore ignores it), with or without the t error bound.
#[inline(always)]
pub fn intersect_with<T: Real>(
    o: V3<T>,
    d: V3<T>,
    s: &RayShear<T>,
    p: &[V3<T>; 3],
    t_min: T,
    t_max: T,
    tech: &Techniques,
) -> Option<TriHit<T>> {
    match tech.intersect {
        IntersectMethod::Watertight => intersect_watertight(o, s, p, t_min, t_max, tech.t_bound),
        IntersectMethod::MollerTrumbore => {
            intersect_moller_trumbore(o, d, p, t_min, t_max, tech.t_bound)
        }
    }
}

/// The watertight test ([`intersect`]) with the t error bound switchable.
#[inline(always)]
pub fn intersect_watertight<T: Real>(
    o: V3<T>,
    s: &RayShear<T>,
    p: &[V3<T>; 3],
    t_min: T,
    t_max: T,
    t_bound: TBound,
) -> Option<TriHit<T>> {
    let a = p[0] - o;
    let b = p[1] - o;
    let c = p[2] - o;
    let (kx, ky, kz) = (s.kx, s.ky, s.kz);
    let ax = a[kx] - s.sx * a[kz];
    let ay = a[ky] - s.sy * a[kz];
    let bx = b[kx] - s.sx * b[kz];
    let by = b[ky] - s.sy * b[kz];
    let cx = c[kx] - s.sx * c[kz];
    let cy = c[ky] - s.sy * c[kz];
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    let z = T::ZERO;
    if (u < z || v < z || w < z) && (u > z || v > z || w > z) {
        return None;
    }
    let det = u + v + w;
    if det == z {
        // Ray parallel to the triangle's plane, or a degenerate triangle.
        return None;
    }
    // A triangle of zero area in this precision (collinear or repeated vertices: its
    // normal, computed exactly as `shade::surface` does, is the zero vector) is never hit,
    // as in pbrt-v4. Its edge functions above are pure rounding noise, which can have one
    // sign and so look like a hit (the sliver of the hard-case suite, case 6).
    let n = (p[1] - p[0]).cross(p[2] - p[0]);
    if n.dot(n) == z {
        return None;
    }
    let az = s.sz * a[kz];
    let bz = s.sz * b[kz];
    let cz = s.sz * c[kz];
    let tt = u * az + v * bz + w * cz;
    // Compare t*det against the bounds without dividing; flip signs for det < 0.
    let (tt, det_abs) = if det < z { (-tt, -det) } else { (tt, det) };
    if !(tt > t_min * det_abs && tt < t_max * det_abs) {
        return None;
    }
    let t = tt / det_abs;
    if t_bound == TBound::On && t <= watertight_t_error(s, a, b, c, [u, v, w], det_abs) {
        return None;
    }
    let inv = T::ONE / det;
    Some(TriHit {
        t,
        b: [u * inv, v * inv, w * inv],
    })
}

/// pbrt-v3's bound on the error of the watertight t (`a`, `b`, `c`: vertices relative to
/// the origin; `e`: the edge functions).
#[inline(always)]
fn watertight_t_error<T: Real>(
    s: &RayShear<T>,
    a: V3<T>,
    b: V3<T>,
    c: V3<T>,
    e: [T; 3],
    det_abs: T,
) -> T {
    let (kx, ky, kz) = (s.kx, s.ky, s.kz);
    let ax = a[kx] - s.sx * a[kz];
    let ay = a[ky] - s.sy * a[kz];
    let bx = b[kx] - s.sx * b[kz];
    let by = b[ky] - s.sy * b[kz];
    let cx = c[kx] - s.sx * c[kz];
    let cy = c[ky] - s.sy * c[kz];
    let az = s.sz * a[kz];
    let bz = s.sz * b[kz];
    let cz = s.sz * c[kz];
    let [u, v, w] = e;
    // pbrt-v3's conservative bound on the error of t: a hit closer than its own error could
    // be behind the origin, which is how a ray spawned on a surface re-hits that surface.
    let max_zt = az.abs().max(bz.abs()).max(cz.abs());
    let max_xt = ax.abs().max(bx.abs()).max(cx.abs());
    let max_yt = ay.abs().max(by.abs()).max(cy.abs());
    let delta_z = T::gamma(3) * max_zt;
    let delta_x = T::gamma(5) * (max_xt + max_zt);
    let delta_y = T::gamma(5) * (max_yt + max_zt);
    let two = T::ONE + T::ONE;
    let delta_e = two * (T::gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let max_e = u.abs().max(v.abs()).max(w.abs());
    let three = two + T::ONE;
    three * (T::gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) / det_abs
}

/// Component-wise |a| x |b| with a plus: bounds the magnitudes summed in each component of
/// a cross product (for error bounds).
#[inline(always)]
fn abs_cross<T: Real>(a: V3<T>, b: V3<T>) -> V3<T> {
    let (a, b) = (a.abs(), b.abs());
    V3::new(
        a.y * b.z + a.z * b.y,
        a.z * b.x + a.x * b.z,
        a.x * b.y + a.y * b.x,
    )
}

/// Möller–Trumbore (1997) for the ray (o, d) and triangle `p`, t in (t_min, t_max), either
/// winding. Barycentrics u (of p1) and v (of p2) are inside when u >= 0, v >= 0 and
/// u + v <= 1 (zero counts as inside, as in the watertight test); `det == 0` (ray parallel
/// to the plane) and zero-area triangles (zero normal, as in the watertight test) miss.
/// There is no epsilon on det: the 1997 paper's `EPSILON` is scale-dependent. Each
/// triangle is decided on its own, so rounding can put a point of a shared edge outside
/// both neighbours. GLSL twin: `intersect_tri` under `INTERSECT_MOLLER_TRUMBORE`.
///
/// With `TBound::On`, a hit with t below a first-order forward error bound of t (same
/// reasoning as pbrt's for the watertight test: γ-bounds of the numerator e2·(s×e1) and
/// of det = e1·(d×e2), s = o − p0) is rejected.
#[inline(always)]
pub fn intersect_moller_trumbore<T: Real>(
    o: V3<T>,
    d: V3<T>,
    p: &[V3<T>; 3],
    t_min: T,
    t_max: T,
    t_bound: TBound,
) -> Option<TriHit<T>> {
    let z = T::ZERO;
    let e1 = p[1] - p[0];
    let e2 = p[2] - p[0];
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det == z {
        return None;
    }
    let n = e1.cross(e2);
    if n.dot(n) == z {
        return None;
    }
    let inv = T::ONE / det;
    let sv = o - p[0];
    let u = sv.dot(pv) * inv;
    if u < z || u > T::ONE {
        return None;
    }
    let qv = sv.cross(e1);
    let v = d.dot(qv) * inv;
    if v < z || u + v > T::ONE {
        return None;
    }
    let t = e2.dot(qv) * inv;
    if !(t > t_min && t < t_max) {
        return None;
    }
    if t_bound == TBound::On && t <= moller_trumbore_t_error(d, e1, e2, sv, t, det) {
        return None;
    }
    Some(TriHit {
        t,
        b: [T::ONE - u - v, u, v],
    })
}

/// First-order forward error bound of Möller–Trumbore's t (γ-bounds of the numerator
/// e2·(s×e1) and of det = e1·(d×e2), s = o − p0).
#[inline(always)]
fn moller_trumbore_t_error<T: Real>(d: V3<T>, e1: V3<T>, e2: V3<T>, sv: V3<T>, t: T, det: T) -> T {
    let num_err = T::gamma(7) * e2.abs().dot(abs_cross(sv, e1));
    let det_err = T::gamma(5) * e1.abs().dot(abs_cross(d, e2));
    (num_err + t.abs() * det_err) / det.abs()
}

#[cfg(test)]
#[path = "intersect_tests.rs"]
pub(crate) mod tests;
