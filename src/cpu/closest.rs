//! The closest hit a BVH walk holds and its tie rule, shared by the single-ray walk
//! (`cpu/traverse_bvh.rs`) and the ray-packet walk (`cpu/traverse_packet.rs`), so that both
//! take a candidate hit by the very same comparisons. Not a GLSL twin: the GPU walks the
//! grids, whose cells meet triangles in index order (`traverse::closest_of`).
//!
//! The tie rule: hits closer than the held one by more than [`TIE_EPS`] replace it; within
//! it, the lower triangle index wins whichever was met first (see `cpu/traverse_bvh.rs`).

use super::real::Real;
use super::simd::Candidate;
use super::traverse::{tie_limit, Hit};
use crate::accel::TIE_EPS;

/// The closest hit held, and the closest t of any hit seen: what bounds the tests.
pub struct Closest<T> {
    /// The hit held.
    pub hit: Option<Hit<T>>,
    /// The held hit's `t * |det|` and `|det|` (the vectorised walk's, for the tie rule).
    pub tt_det: (T, T),
    /// The closest t of any hit seen.
    pub t_low: T,
}

impl<T: Real> Closest<T> {
    /// Nothing held yet, for a ray whose interval ends at `t_max`.
    pub fn new(t_max: T) -> Self {
        Closest {
            hit: None,
            tt_det: (T::ZERO, T::ZERO),
            t_low: t_max,
        }
    }

    /// Upper bound on the t of any hit the rule could still take: `2 TIE_EPS` past the
    /// closest seen (the ray's t_max before any). Never grows.
    #[inline(always)]
    pub fn bound(&self, t_max: T) -> T {
        match self.hit {
            None => t_max,
            Some(_) => self.t_low + self.t_low.abs() * T::from_f64(2.0 * TIE_EPS),
        }
    }

    /// Whether a hit at `t` on triangle `tri` replaces the one held; it is seen either
    /// way. Brute force meets the pair in index order and keeps the earlier unless the
    /// later passes its intersection test against the earlier's [`tie_limit`]; so does
    /// this, in whichever order the walk met them: `later_passes(candidate_is_later, hi)`
    /// answers that test (the test's own comparison `t * |det| < hi * |det|`, not one on
    /// the divided t, which can differ by an ulp at the margin).
    #[inline(always)]
    pub fn takes(&mut self, t: T, tri: u32, later_passes: impl FnOnce(bool, T) -> bool) -> bool {
        let take = match &self.hit {
            None => true,
            Some(h) if tri > h.tri => later_passes(true, tie_limit(h.t)),
            Some(_) => !later_passes(false, tie_limit(t)),
        };
        if t < self.t_low {
            self.t_low = t;
        }
        take
    }
}

impl Closest<f32> {
    /// Offers a candidate of the vectorised triangle test (`cpu/simd.rs`'s [`Candidate`],
    /// on triangle `tri`), which passed the test against a bound at least the one held
    /// now: taken or not as the scalar walk would take the same test's hit. Its values are
    /// the scalar test's bit for bit, so the scalar test's own comparisons decide.
    #[inline(always)]
    pub fn offer(&mut self, t_max: f32, c: &Candidate, tri: u32) {
        // The scalar test's own comparison, against the bound of now.
        if c.tt >= self.bound(t_max) * c.det_abs {
            return; // never NaN: the kernel passed it against a bound
        }
        let (tt_h, det_h) = self.tt_det;
        // The scalar test's comparison on the lanes' values (the scalar walk reruns the
        // test: the same operations, the same bits).
        let later = |cand: bool, hi: f32| {
            if cand {
                c.tt < hi * c.det_abs
            } else {
                tt_h < hi * det_h
            }
        };
        if self.takes(c.t, tri, later) {
            let [u, v, w, det] = c.uvwd;
            let inv = 1.0 / det;
            self.hit = Some(Hit {
                t: c.t,
                tri,
                b: [u * inv, v * inv, w * inv],
            });
            self.tt_det = (c.tt, c.det_abs);
        }
    }
}
