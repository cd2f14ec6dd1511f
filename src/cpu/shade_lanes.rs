//! Direct lighting of [`LANES`] hits at once, structure of arrays: the surface point
//! (`shade::surface_with`), the shadow ray towards a point light (`shade::shadow_ray`)
//! and the light's term
//! (`shade::light_term`), each lane computed with exactly the scalar functions' operations
//! in their order, so every bit equals theirs (`shade_lanes_tests.rs` checks it on random
//! and degenerate inputs). Not a GLSL twin: the GPU shades one ray per invocation.
//!
//! The lane loops are plain Rust over fixed-size arrays; [`Dispatch`] compiles them for
//! AVX-512 or AVX2 where the CPU has it, where the compiler turns them into vector
//! instructions (no fused multiply-add: Rust never contracts, so the bits stay the
//! scalar code's). Branches become selects; the one `powf` (a specular exponent) stays
//! scalar, per lane.

// Lane loops index several arrays by the lane: the form that vectorises.
#![allow(clippy::needless_range_loop)]

use super::real::{Real, V3};
use super::shade::{third_of_longest_edge, SurfacePoint};
use super::traverse_packet::PacketIsa;
use crate::technique::{OffsetMethod, Techniques, Terminator, OFFSET_EPSILON};

/// Hits shaded together: one AVX-512 register of f32.
pub const LANES: usize = 16;

/// One value per lane.
pub type Lane<T> = [T; LANES];

/// A vector per lane, one array per axis.
#[derive(Clone, Copy, Debug)]
pub struct V3L<T> {
    /// x of each lane.
    pub x: Lane<T>,
    /// y of each lane.
    pub y: Lane<T>,
    /// z of each lane.
    pub z: Lane<T>,
}

impl<T: Real> V3L<T> {
    /// Zero in every lane.
    pub fn zero() -> Self {
        V3L {
            x: [T::ZERO; LANES],
            y: [T::ZERO; LANES],
            z: [T::ZERO; LANES],
        }
    }

    /// Lane `k`.
    #[inline(always)]
    pub fn get(&self, k: usize) -> V3<T> {
        V3::new(self.x[k], self.y[k], self.z[k])
    }

    /// Sets lane `k`.
    #[inline(always)]
    pub fn set(&mut self, k: usize, v: V3<T>) {
        self.x[k] = v.x;
        self.y[k] = v.y;
        self.z[k] = v.z;
    }
}

/// The inputs of [`Dispatch::surfaces`]: what a hit gathers from the scene, one lane per hit.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceIn<T> {
    /// The triangle's vertices.
    pub v: [V3L<T>; 3],
    /// Its unit geometric normal (`shade::geometric_normal`).
    pub ng: V3L<T>,
    /// Its vertex normals (zero when it has none).
    pub n: [V3L<T>; 3],
    /// True when the triangle has vertex normals.
    pub has_normals: [bool; LANES],
    /// The hit's barycentric weights.
    pub b: [Lane<T>; 3],
    /// The ray's direction.
    pub d: V3L<T>,
}

impl<T: Real> SurfaceIn<T> {
    /// All zero, no normals (lanes without a hit stay so: finite, and ignored).
    pub fn zero() -> Self {
        SurfaceIn {
            v: [V3L::zero(); 3],
            ng: V3L::zero(),
            n: [V3L::zero(); 3],
            has_normals: [false; LANES],
            b: [[T::ZERO; LANES]; 3],
            d: V3L::zero(),
        }
    }
}

/// The surface points of [`LANES`] hits: `shade::SurfacePoint`'s fields, one array each
/// (the material is the caller's).
#[derive(Clone, Copy, Debug)]
pub struct Surfaces<T> {
    /// Hit point.
    pub p: V3L<T>,
    /// Its error bound.
    pub p_err: V3L<T>,
    /// Geometric normal.
    pub ng: V3L<T>,
    /// Geometric normal facing the ray.
    pub nf: V3L<T>,
    /// Shading normal facing the ray.
    pub ns: V3L<T>,
    /// Distance of the hit point from the smooth surface (the terminator gap).
    pub gap: Lane<T>,
    /// The most a shadow ray skips under it.
    pub reach: Lane<T>,
    /// True where the ray enters the surface.
    pub entering: [bool; LANES],
    /// True where the interpolated normal was flipped to face the ray.
    pub flipped: [bool; LANES],
}

impl<T: Real> Surfaces<T> {
    /// All zero.
    pub fn zero() -> Self {
        Surfaces {
            p: V3L::zero(),
            p_err: V3L::zero(),
            ng: V3L::zero(),
            nf: V3L::zero(),
            ns: V3L::zero(),
            gap: [T::ZERO; LANES],
            reach: [T::ZERO; LANES],
            entering: [false; LANES],
            flipped: [false; LANES],
        }
    }

    /// Lane `k` as the scalar code's surface point, with `material`.
    pub fn point(&self, k: usize, material: u32) -> SurfacePoint<T> {
        SurfacePoint {
            p: self.p.get(k),
            p_err: self.p_err.get(k),
            ng: self.ng.get(k),
            nf: self.nf.get(k),
            ns: self.ns.get(k),
            entering: self.entering[k],
            material,
            gap: self.gap[k],
            reach: self.reach[k],
            flipped: self.flipped[k],
        }
    }
}

/// Shadow rays of [`LANES`] hits towards one light.
#[derive(Clone, Copy, Debug)]
pub struct Shadows<T> {
    /// True where the light is above both horizons (a shadow ray is cast).
    pub cast: [bool; LANES],
    /// The ray's origin (offset off the surface).
    pub o: V3L<T>,
    /// Its unit direction towards the light.
    pub l: V3L<T>,
    /// The distance to the light (the ray's `t_max`).
    pub dist: Lane<T>,
}

impl<T: Real> Shadows<T> {
    /// No ray cast.
    pub fn zero() -> Self {
        Shadows {
            cast: [false; LANES],
            o: V3L::zero(),
            l: V3L::zero(),
            dist: [T::ZERO; LANES],
        }
    }
}

#[inline(always)]
fn dot<T: Real>(a: V3<T>, b: V3<T>) -> T {
    a.dot(b)
}

/// `shade::surface_with` for every lane (the material left out), into `s` (written in
/// place: the lanes are large to move).
#[inline(always)]
pub fn surfaces_generic<T: Real>(i: &SurfaceIn<T>, s: &mut Surfaces<T>) {
    let g7 = T::gamma(7);
    s.ng = i.ng;
    for k in 0..LANES {
        let (b0, b1, b2) = (i.b[0][k], i.b[1][k], i.b[2][k]);
        let (v0, v1, v2) = (i.v[0].get(k), i.v[1].get(k), i.v[2].get(k));
        let ng = i.ng.get(k);
        let d = i.d.get(k);
        let p = v0 * b0 + v1 * b1 + v2 * b2;
        let p_err = ((v0 * b0).abs() + (v1 * b1).abs() + (v2 * b2).abs()) * g7;
        let entering = dot(d, ng) < T::ZERO;
        let nf = if entering { ng } else { -ng };
        let (n0, n1, n2) = (i.n[0].get(k), i.n[1].get(k), i.n[2].get(k));
        let sn = n0 * b0 + n1 * b1 + n2 * b2;
        let l = sn.length();
        let ok = i.has_normals[k] && l > T::ZERO && l.is_finite();
        let sn = sn * (T::ONE / l);
        let flip = dot(sn, nf) < T::ZERO;
        let nk = |n: V3<T>| if flip { -n } else { n };
        let gap_of = |v: V3<T>, n: V3<T>, b: T| n * (b * (p - v).dot(n).abs());
        let away = gap_of(v0, nk(n0), b0) + gap_of(v1, nk(n1), b1) + gap_of(v2, nk(n2), b2);
        let up = away.dot(nf);
        let lifted = ok && up > T::ZERO;
        s.p.set(k, p);
        s.p_err.set(k, p_err);
        s.nf.set(k, nf);
        s.ns.set(k, if ok { nk(sn) } else { nf });
        s.gap[k] = if lifted { up } else { T::ZERO };
        let reach = third_of_longest_edge(&[v0, v1, v2]);
        s.reach[k] = if lifted { reach } else { T::ZERO };
        s.entering[k] = entering;
        s.flipped[k] = ok && flip;
    }
}

/// The shadow rays of every lane in `live` towards a light at `lp` into `out`:
/// `shade::shadow_ray`.
#[inline(always)]
#[allow(clippy::double_comparisons)] // `o != 0` is true for NaN, `o > 0 || o < 0` is not
pub fn shadows_generic<T: Real>(
    s: &Surfaces<T>,
    live: &[bool; LANES],
    lp: V3<T>,
    tech: Techniques,
    out: &mut Shadows<T>,
) {
    let smooth = match tech.terminator {
        Terminator::Exact => false,
        Terminator::Smooth => true,
    };
    let u2 = T::UNIT_ROUNDOFF + T::UNIT_ROUNDOFF;
    let tiny = T::from_f32(1e-30);
    let eps = T::from_f64(OFFSET_EPSILON);
    for k in 0..LANES {
        let (p, nf, ns, ng) = (s.p.get(k), s.nf.get(k), s.ns.get(k), s.ng.get(k));
        let to_l = lp - p;
        out.cast[k] = live[k] && !(to_l.dot(nf) <= T::ZERO || ns.dot(to_l) <= T::ZERO);
        let below = to_l.dot(ng) < T::ZERO;
        let o = match tech.offset {
            OffsetMethod::Epsilon => p + ng * if below { -eps } else { eps },
            OffsetMethod::ErrorBound => {
                let dist = ng.abs().dot(s.p_err.get(k));
                let off = ng * dist;
                let off = if below { -off } else { off };
                let po = p + off;
                let nudge = |x: T, o: T| {
                    let step = x.abs() * u2 + tiny;
                    let moved = x + if o > T::ZERO { step } else { -step };
                    if o > T::ZERO || o < T::ZERO {
                        moved
                    } else {
                        x
                    }
                };
                V3::new(nudge(po.x, off.x), nudge(po.y, off.y), nudge(po.z, off.z))
            }
        };
        let dl = lp - o;
        let dist = dl.length();
        let l = dl * (T::ONE / dist);
        // The terminator's skip (`shade::terminator_skip`), zero with `Exact`.
        let (gap, reach) = (s.gap[k], s.reach[k]);
        let rise = dot(nf, l);
        let height = gap + gap;
        let skip = if height < reach * rise {
            height / rise
        } else {
            reach
        };
        let skip = if smooth && gap > T::ZERO {
            skip.min(dist)
        } else {
            T::ZERO
        };
        let skipped = skip > T::ZERO;
        out.dist[k] = if skipped { dist - skip } else { dist };
        out.l.set(k, l);
        out.o.set(k, if skipped { o + l * skip } else { o });
    }
}

/// Adds the diffuse part of a light's term (`shade::light_term` up to its specular
/// highlight) to `color` in every lane in `add`: `alb * (kd * ns.l)`, zero where
/// `ns.l <= 0`, times `radiance`. `spec` holds each lane's specular highlight
/// `ks * (r.v)^ns` (zero where the material has none, added as `light_term` adds it).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn add_light_generic<T: Real>(
    color: &mut V3L<T>,
    s: &Surfaces<T>,
    l: &V3L<T>,
    alb: &V3L<T>,
    kd: &Lane<T>,
    spec: &V3L<T>,
    has_spec: &[bool; LANES],
    add: &[bool; LANES],
    radiance: V3<T>,
) {
    for k in 0..LANES {
        let ndotl = s.ns.get(k).dot(l.get(k));
        let c = alb.get(k) * (kd[k] * ndotl);
        let c = if has_spec[k] { c + spec.get(k) } else { c };
        let term = if ndotl <= T::ZERO {
            V3::splat(T::ZERO)
        } else {
            c.mul_elem(radiance)
        };
        let sum = color.get(k) + term;
        if add[k] {
            color.set(k, sum);
        }
    }
}

/// Which compilation of the lane loops runs: the widest the CPU has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dispatch {
    /// AVX-512F (x86-64).
    Avx512,
    /// AVX2 (x86-64).
    Avx2,
    /// The target's baseline (SSE2 on x86-64).
    Baseline,
}

impl Dispatch {
    /// The widest this CPU runs: the packet walk's choice ([`PacketIsa::detect`]), so that
    /// which units the CPU has is decided in one place.
    pub fn detect() -> Dispatch {
        PacketIsa::detect().into()
    }

    /// Every compilation this CPU can run (for the tests).
    pub fn available() -> Vec<Dispatch> {
        std::iter::once(Dispatch::Baseline)
            .chain(
                [PacketIsa::Avx2, PacketIsa::Avx512]
                    .into_iter()
                    .filter(|isa| isa.available())
                    .map(|isa| Some(isa).into()),
            )
            .collect()
    }
}

impl From<Option<PacketIsa>> for Dispatch {
    /// The lanes' compilation for a packet unit (`None`: the target's baseline).
    fn from(isa: Option<PacketIsa>) -> Dispatch {
        match isa {
            Some(PacketIsa::Avx512) => Dispatch::Avx512,
            Some(PacketIsa::Avx2) => Dispatch::Avx2,
            None => Dispatch::Baseline,
        }
    }
}

macro_rules! lanes_for {
    ($surf:ident, $shad:ident, $light:ident, $feature:literal) => {
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $feature)]
        unsafe fn $surf<T: Real>(i: &SurfaceIn<T>, s: &mut Surfaces<T>) {
            surfaces_generic(i, s)
        }
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $feature)]
        unsafe fn $shad<T: Real>(
            s: &Surfaces<T>,
            live: &[bool; LANES],
            lp: V3<T>,
            tech: Techniques,
            out: &mut Shadows<T>,
        ) {
            shadows_generic(s, live, lp, tech, out)
        }
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $feature)]
        #[allow(clippy::too_many_arguments)]
        unsafe fn $light<T: Real>(
            color: &mut V3L<T>,
            s: &Surfaces<T>,
            l: &V3L<T>,
            alb: &V3L<T>,
            kd: &Lane<T>,
            spec: &V3L<T>,
            has_spec: &[bool; LANES],
            add: &[bool; LANES],
            radiance: V3<T>,
        ) {
            add_light_generic(color, s, l, alb, kd, spec, has_spec, add, radiance)
        }
    };
}

lanes_for!(surfaces_avx512, shadows_avx512, light_avx512, "avx512f");
lanes_for!(surfaces_avx2, shadows_avx2, light_avx2, "avx2");

impl Dispatch {
    /// [`surfaces_generic`] compiled for this choice.
    #[inline]
    pub fn surfaces<T: Real>(self, i: &SurfaceIn<T>, s: &mut Surfaces<T>) {
        match self {
            // SAFETY: `Dispatch::detect`/`available` chose these only where the CPU has
            // the feature.
            #[cfg(target_arch = "x86_64")]
            Dispatch::Avx512 => unsafe { surfaces_avx512(i, s) },
            // SAFETY: as above.
            #[cfg(target_arch = "x86_64")]
            Dispatch::Avx2 => unsafe { surfaces_avx2(i, s) },
            _ => surfaces_generic(i, s),
        }
    }

    /// [`shadows_generic`] compiled for this choice.
    #[inline]
    pub fn shadows<T: Real>(
        self,
        s: &Surfaces<T>,
        live: &[bool; LANES],
        lp: V3<T>,
        tech: Techniques,
        out: &mut Shadows<T>,
    ) {
        match self {
            // SAFETY: as in `surfaces`.
            #[cfg(target_arch = "x86_64")]
            Dispatch::Avx512 => unsafe { shadows_avx512(s, live, lp, tech, out) },
            // SAFETY: as in `surfaces`.
            #[cfg(target_arch = "x86_64")]
            Dispatch::Avx2 => unsafe { shadows_avx2(s, live, lp, tech, out) },
            _ => shadows_generic(s, live, lp, tech, out),
        }
    }

    /// [`add_light_generic`] compiled for this choice.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn add_light<T: Real>(
        self,
        color: &mut V3L<T>,
        s: &Surfaces<T>,
        l: &V3L<T>,
        alb: &V3L<T>,
        kd: &Lane<T>,
        spec: &V3L<T>,
        has_spec: &[bool; LANES],
        add: &[bool; LANES],
        radiance: V3<T>,
    ) {
        match self {
            // SAFETY: as in `surfaces`.
            #[cfg(target_arch = "x86_64")]
            Dispatch::Avx512 => unsafe {
                light_avx512(color, s, l, alb, kd, spec, has_spec, add, radiance)
            },
            // SAFETY: as in `surfaces`.
            #[cfg(target_arch = "x86_64")]
            Dispatch::Avx2 => unsafe {
                light_avx2(color, s, l, alb, kd, spec, has_spec, add, radiance)
            },
            _ => add_light_generic(color, s, l, alb, kd, spec, has_spec, add, radiance),
        }
    }
}

#[cfg(test)]
#[path = "shade_lanes_tests.rs"]
mod tests;
