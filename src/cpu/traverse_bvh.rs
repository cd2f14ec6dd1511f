//! The walk of the 4-wide BVH (`accel/bvh.rs`, `--accel bvh`): a stack of children met,
//! nearest first for closest hits, in slot order for shadow rays. The CPU backend's only
//! structure without a GLSL twin (the GPU walks the grids). Generic over precision (f64
//! the reference, f32 the render's) with one scalar walk; in f32 the vectorised variant
//! tests a node's four boxes with one SSE operation per axis and side and its leaves'
//! triangles with the 8- or 4-wide kernel of `cpu/simd.rs`, taking the same decisions in
//! the same order as the scalar f32 walk (the same IEEE operations in each lane; the tests
//! compare the two bit for bit).
//!
//! Boxes are met conservatively (Ize 2013): a slab's far distance is padded by
//! `2 gamma(3)` relative, so a ray that meets a triangle meets every box around it. Node
//! visits count as the `cells` of [`Work`].
//!
//! The tie rule: hits closer than the held one by more than [`TIE_EPS`]
//! replace it; within it, the lower triangle index wins whichever was met first. The
//! grids' walk meets a cell's triangles in index order, so there the lower index wins
//! within the margin by construction; the BVH meets triangles in its own order and decides
//! each pair as brute force does when it meets them in index order (the later one's
//! intersection test against the earlier's tie limit), which gives brute force's answer
//! except for chains of three or more hits each within the margin of the next (coplanar
//! piles), where the pairs met decide. Only hits within `2 TIE_EPS` of the closest one
//! seen are tested at all.

use super::intersect::{intersect_with, RayShear};
use super::real::{Real, V3};
use super::simd::{self, Isa, RayConsts};
use super::soa::SoaTris;
use super::traverse::{tie_limit, Hit, Ray, Trace, Work};
use crate::accel::bvh::{Bvh, Node4, WIDTH};
use crate::accel::TIE_EPS;
use crate::scene::Scene;
use crate::technique::{IntersectMethod, Techniques};

/// Stack entries: three per level of the deepest tree the build makes, and a node's four.
const STACK: usize = 3 * crate::accel::bvh::MAX_DEPTH + WIDTH + 1;

/// The BVH walked in precision `T`.
pub struct BvhWalker<'a, T> {
    tris: Vec<[V3<T>; 3]>,
    bvh: &'a Bvh,
    techniques: Techniques,
    /// The leaves' triangles in reference order, for the vector kernel (empty when `isa`
    /// is scalar).
    soa: SoaTris,
    isa: Isa,
    /// The closest-hit walk: scalar, or (f32 only) vectorised; chosen by the constructor,
    /// so that one generic [`Trace`] impl serves both precisions.
    closest: fn(&Self, &Ray<T>, &mut Work) -> Option<Hit<T>>,
    /// The any-hit walk, as `closest`.
    any: fn(&Self, &Ray<T>, &mut Work) -> bool,
}

/// An entry of the walk's stack: a child (node, or leaf range when `count > 0`) and the
/// distance at which the ray enters its box.
#[derive(Clone, Copy)]
struct Entry<T> {
    child: u32,
    count: u32,
    near: T,
}

/// The walk's stack, left uninitialised: zeroing its 2 KB per query cost 3% of a render.
struct Stack<T> {
    items: [std::mem::MaybeUninit<Entry<T>>; STACK],
    len: usize,
}

impl<T: Copy> Stack<T> {
    #[inline(always)]
    fn with(first: Entry<T>) -> Self {
        let mut s = Stack {
            items: [const { std::mem::MaybeUninit::uninit() }; STACK],
            len: 0,
        };
        s.push(first);
        s
    }

    #[inline(always)]
    fn push(&mut self, e: Entry<T>) {
        // Indexing checks the bound: the build's depth limit keeps it unreachable.
        self.items[self.len].write(e);
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<Entry<T>> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: every slot below `len` was written by `push`.
        Some(unsafe { self.items[self.len].assume_init() })
    }
}

/// The closest hit held, and the closest t of any hit seen: what bounds the tests.
struct Closest<T> {
    hit: Option<Hit<T>>,
    /// The held hit's `t * |det|` and `|det|` (the vectorised walk's, for the tie rule).
    tt_det: (T, T),
    t_low: T,
}

impl<T: Real> Closest<T> {
    fn new(t_max: T) -> Self {
        Closest {
            hit: None,
            tt_det: (T::ZERO, T::ZERO),
            t_low: t_max,
        }
    }

    /// Upper bound on the t of any hit the rule could still take: `2 TIE_EPS` past the
    /// closest seen (the ray's t_max before any). Never grows.
    #[inline(always)]
    fn bound(&self, t_max: T) -> T {
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
    fn takes(&mut self, t: T, tri: u32, later_passes: impl FnOnce(bool, T) -> bool) -> bool {
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

/// SSE's `max`: `a` when `a > b`, else `b` (so a NaN `a`, from `0 * inf` on a slab the
/// ray runs inside, leaves `b`).
#[inline(always)]
fn max_ps<T: Real>(a: T, b: T) -> T {
    if a > b {
        a
    } else {
        b
    }
}

/// SSE's `min`: `a` when `a < b`, else `b`.
#[inline(always)]
fn min_ps<T: Real>(a: T, b: T) -> T {
    if a < b {
        a
    } else {
        b
    }
}

/// The ray's slab constants: origin, reciprocal direction, and per axis whether the
/// direction is negative (then the near plane is a box's upper bound).
#[derive(Clone, Copy)]
struct BoxRay<T> {
    o: [T; 3],
    inv: [T; 3],
    neg: [bool; 3],
    /// The far distances' padding, `2 gamma(3)`.
    pad: T,
}

impl<T: Real> BoxRay<T> {
    #[inline(always)]
    fn new(ray: &Ray<T>) -> Self {
        let inv = [0, 1, 2].map(|a| T::ONE / ray.d[a]);
        BoxRay {
            o: [ray.o.x, ray.o.y, ray.o.z],
            inv,
            // 1 / -0 is -inf: negative, as the sign of the zero says.
            neg: inv.map(|v| v < T::ZERO),
            pad: T::from_f64(2.0) * T::gamma(3),
        }
    }

    /// The four children's entry distances and which of them the ray meets in
    /// (`t_min`, `hi`), as bits: the scalar twin of [`sse::slabs`], operation for
    /// operation.
    #[inline(always)]
    fn slabs(&self, node: &Node4, t_min: T, hi: T) -> ([T; WIDTH], u32) {
        let mut near_all = [T::ZERO; WIDTH];
        let mut bits = 0;
        for (i, near_i) in near_all.iter_mut().enumerate() {
            let mut near = t_min;
            let mut far = T::from_f32(f32::INFINITY);
            for a in 0..3 {
                let (n, f) = if self.neg[a] {
                    (node.hi[a][i], node.lo[a][i])
                } else {
                    (node.lo[a][i], node.hi[a][i])
                };
                near = max_ps((T::from_f32(n) - self.o[a]) * self.inv[a], near);
                far = min_ps((T::from_f32(f) - self.o[a]) * self.inv[a], far);
            }
            // A far distance of -inf (a ray parallel to a slab it runs outside of) pads to
            // NaN, which `hi` first in the `min` keeps: a miss, as it should be.
            far = far + far.abs() * self.pad;
            far = min_ps(hi, far);
            *near_i = near;
            if near <= far {
                bits |= 1 << i;
            }
        }
        (near_all, bits)
    }
}

/// The children `bits` of `node` with entry distances `near`, in the order the walk takes
/// them: nearest first (ties in slot order) when `ordered`, slot order otherwise. The
/// first is returned, to be walked next; the others are pushed so that they pop in order.
#[inline(always)]
fn push_children<T: Real>(
    node: &Node4,
    near: &[T; WIDTH],
    mut bits: u32,
    ordered: bool,
    stack: &mut Stack<T>,
) -> Option<Entry<T>> {
    let mut order = [0usize; WIDTH];
    let mut m = 0;
    while bits != 0 {
        let i = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        // Insertion by entry distance, stable: slot order among equal distances.
        let mut k = m;
        while ordered && k > 0 && near[order[k - 1]] > near[i] {
            order[k] = order[k - 1];
            k -= 1;
        }
        order[k] = i;
        m += 1;
    }
    let entry = |i: usize| Entry {
        child: node.child[i],
        count: node.count[i],
        near: near[i],
    };
    for &i in order[1..m.max(1)].iter().rev() {
        stack.push(entry(i));
    }
    (m > 0).then(|| entry(order[0]))
}

impl<'a, T: Real> BvhWalker<'a, T> {
    /// Prepares `scene` and its `bvh` for the scalar walk in precision `T`.
    pub fn new(scene: &Scene, bvh: &'a Bvh, techniques: Techniques) -> Self {
        let tris = (0..scene.triangles.len())
            .map(|i| scene.triangle_vertices(i).map(V3::from_vec3))
            .collect();
        BvhWalker {
            tris,
            bvh,
            techniques,
            soa: SoaTris::new(&[], &[]),
            isa: Isa::Scalar,
            closest: Self::scalar_closest,
            any: Self::scalar_any,
        }
    }

    /// The kernel the queries run.
    pub fn isa(&self) -> Isa {
        self.isa
    }

    /// The closest hit, by the scalar walk.
    fn scalar_closest(&self, ray: &Ray<T>, work: &mut Work) -> Option<Hit<T>> {
        let shear = RayShear::new(ray.d);
        let br = BoxRay::new(ray);
        let mut best = Closest::new(ray.t_max);
        self.closest_walk(
            ray,
            work,
            |k, near, hi| br.slabs(k, near, hi),
            {
                |off, n, best: &mut Closest<T>, tests: &mut u64| {
                    for r in off..off + n {
                        *tests += 1;
                        let tri = self.bvh.tri_indices[r];
                        let hi = best.bound(ray.t_max);
                        let test = |tri: u32, hi: T| {
                            let p = &self.tris[tri as usize];
                            intersect_with(ray.o, ray.d, &shear, p, ray.t_min, hi, &self.techniques)
                        };
                        if let Some(h) = test(tri, hi) {
                            let held = best.hit.map_or(tri, |h| h.tri);
                            // The pair's later triangle tested again against the other's
                            // tie limit: the very comparison brute force makes.
                            let later = |cand: bool, hi: T| {
                                test(if cand { tri } else { held }, hi).is_some()
                            };
                            if best.takes(h.t, tri, later) {
                                best.hit = Some(Hit {
                                    t: h.t,
                                    tri,
                                    b: h.b,
                                });
                            }
                        }
                    }
                }
            },
            &mut best,
        );
        best.hit
    }

    /// Whether anything is hit, by the scalar walk.
    fn scalar_any(&self, ray: &Ray<T>, work: &mut Work) -> bool {
        let shear = RayShear::new(ray.d);
        let br = BoxRay::new(ray);
        self.any_walk(
            ray,
            work,
            |k| br.slabs(k, ray.t_min, ray.t_max),
            |off, n, tests| {
                for r in off..off + n {
                    *tests += 1;
                    let p = &self.tris[self.bvh.tri_indices[r] as usize];
                    let h = intersect_with(
                        ray.o,
                        ray.d,
                        &shear,
                        p,
                        ray.t_min,
                        ray.t_max,
                        &self.techniques,
                    );
                    if h.is_some() {
                        return true;
                    }
                }
                false
            },
        )
    }

    /// The closest-hit walk: `slabs(node, t_min, bound)` tests a node's children, `leaf`
    /// tests a leaf's references into the hit held.
    #[inline(always)]
    fn closest_walk(
        &self,
        ray: &Ray<T>,
        work: &mut Work,
        slabs: impl Fn(&Node4, T, T) -> ([T; WIDTH], u32),
        mut leaf: impl FnMut(usize, usize, &mut Closest<T>, &mut u64),
        best: &mut Closest<T>,
    ) {
        let nodes = &self.bvh.nodes;
        let mut stack = Stack::with(Entry {
            child: 0,
            count: 0,
            near: ray.t_min,
        });
        let mut tests = 0u64;
        let mut next = None;
        while let Some(e) = next.take().or_else(|| stack.pop()) {
            let hi = best.bound(ray.t_max);
            if e.near > hi {
                continue;
            }
            if e.count > 0 {
                leaf(e.child as usize, e.count as usize, best, &mut tests);
                continue;
            }
            work.cells += 1;
            let node = &nodes[e.child as usize];
            let (near, bits) = slabs(node, ray.t_min, hi);
            next = push_children(node, &near, bits, true, &mut stack);
        }
        work.tests += tests;
    }

    /// The any-hit walk: children in slot order, stopping at the first leaf `leaf` says
    /// is hit.
    #[inline(always)]
    fn any_walk(
        &self,
        ray: &Ray<T>,
        work: &mut Work,
        slabs: impl Fn(&Node4) -> ([T; WIDTH], u32),
        mut leaf: impl FnMut(usize, usize, &mut u64) -> bool,
    ) -> bool {
        let nodes = &self.bvh.nodes;
        let mut stack = Stack::with(Entry {
            child: 0,
            count: 0,
            near: ray.t_min,
        });
        let mut tests = 0u64;
        let mut found = false;
        let mut next = None;
        while let Some(e) = next.take().or_else(|| stack.pop()) {
            if e.count > 0 {
                if leaf(e.child as usize, e.count as usize, &mut tests) {
                    found = true;
                    break;
                }
                continue;
            }
            work.cells += 1;
            let node = &nodes[e.child as usize];
            let (near, bits) = slabs(node);
            next = push_children(node, &near, bits, false, &mut stack);
        }
        work.tests += tests;
        found
    }
}

impl<'a> BvhWalker<'a, f32> {
    /// Prepares `scene` and its `bvh` for the vectorised f32 walk with kernel `isa`
    /// ([`Isa::detect`] for the widest this CPU runs; the scalar walk with
    /// [`Isa::Scalar`], with Möller-Trumbore, which has no vector kernel, or off x86-64).
    /// Panics when this CPU cannot run `isa`.
    pub fn vectorised(scene: &Scene, bvh: &'a Bvh, techniques: Techniques, isa: Isa) -> Self {
        assert!(
            isa.available(),
            "this CPU cannot run the {} kernel",
            isa.name()
        );
        let mut w = BvhWalker::new(scene, bvh, techniques);
        if techniques.intersect == IntersectMethod::Watertight && cfg!(target_arch = "x86_64") {
            w.isa = isa;
        }
        #[cfg(target_arch = "x86_64")]
        if w.isa != Isa::Scalar {
            w.soa = SoaTris::new(&w.tris, &bvh.tri_indices);
            w.closest = Self::simd_closest;
            w.any = Self::simd_any;
        }
        w
    }

    /// The vector kernels' constants for `ray`.
    #[inline(always)]
    fn consts(&self, ray: &Ray<f32>) -> RayConsts {
        RayConsts::of_ray(ray, &self.techniques)
    }

    /// The closest hit, by the vectorised walk.
    #[cfg(target_arch = "x86_64")]
    fn simd_closest(&self, ray: &Ray<f32>, work: &mut Work) -> Option<Hit<f32>> {
        let rc = self.consts(ray);
        let br = BoxRay::new(ray);
        let sr = sse::SseRay::new(&br);
        let mut best = Closest::new(ray.t_max);
        let list = &self.bvh.tri_indices;
        self.closest_walk(
            ray,
            work,
            // SAFETY: SSE2 is part of x86-64.
            |k, t_min, hi| unsafe { sse::slabs(&sr, k, t_min, hi) },
            |off, n, best: &mut Closest<f32>, tests: &mut u64| {
                *tests += n as u64;
                simd::scan(
                    self.isa,
                    &rc,
                    &self.soa,
                    (off, n),
                    best,
                    |best| best.bound(ray.t_max),
                    |best, c| {
                        // The scalar test's own comparison, against the bound of now.
                        if c.tt >= best.bound(ray.t_max) * c.det_abs {
                            return; // never NaN: the kernel passed it against a bound
                        }
                        let tri = list[c.r];
                        let (tt_h, det_h) = best.tt_det;
                        // The scalar test's comparison on the lanes' values (the scalar
                        // walk reruns the test: the same operations, the same bits).
                        let later = |cand: bool, hi: f32| {
                            if cand {
                                c.tt < hi * c.det_abs
                            } else {
                                tt_h < hi * det_h
                            }
                        };
                        if best.takes(c.t, tri, later) {
                            let [u, v, w, det] = c.uvwd;
                            let inv = 1.0 / det;
                            best.hit = Some(Hit {
                                t: c.t,
                                tri,
                                b: [u * inv, v * inv, w * inv],
                            });
                            best.tt_det = (c.tt, c.det_abs);
                        }
                    },
                );
            },
            &mut best,
        );
        best.hit
    }

    /// Whether anything is hit, by the vectorised walk.
    #[cfg(target_arch = "x86_64")]
    fn simd_any(&self, ray: &Ray<f32>, work: &mut Work) -> bool {
        let rc = self.consts(ray);
        let br = BoxRay::new(ray);
        let sr = sse::SseRay::new(&br);
        self.any_walk(
            ray,
            work,
            // SAFETY: SSE2 is part of x86-64.
            |k| unsafe { sse::slabs(&sr, k, ray.t_min, ray.t_max) },
            |off, n, tests| match simd::first_hit(self.isa, &rc, &self.soa, off, n) {
                Some(i) => {
                    *tests += i as u64 + 1;
                    true
                }
                None => {
                    *tests += n as u64;
                    false
                }
            },
        )
    }
}

impl<T: Real> Trace<T> for BvhWalker<'_, T> {
    fn tris(&self) -> &[[V3<T>; 3]] {
        &self.tris
    }

    #[inline]
    fn closest_hit(&self, ray: &Ray<T>, work: &mut Work) -> Option<Hit<T>> {
        (self.closest)(self, ray, work)
    }

    #[inline]
    fn any_hit(&self, ray: &Ray<T>, work: &mut Work) -> bool {
        (self.any)(self, ray, work)
    }
}

/// The four slab tests of a node in SSE lanes.
#[cfg(target_arch = "x86_64")]
mod sse {
    use std::arch::x86_64::*;

    use super::BoxRay;
    use crate::accel::bvh::{Node4, WIDTH};

    /// [`BoxRay`] splatted into lanes.
    pub(super) struct SseRay {
        o: [__m128; 3],
        inv: [__m128; 3],
        neg: [bool; 3],
        pad: __m128,
    }

    impl SseRay {
        #[inline(always)]
        pub(super) fn new(br: &BoxRay<f32>) -> Self {
            // SAFETY: SSE2 is part of x86-64.
            unsafe {
                SseRay {
                    o: br.o.map(|v| _mm_set1_ps(v)),
                    inv: br.inv.map(|v| _mm_set1_ps(v)),
                    neg: br.neg,
                    pad: _mm_set1_ps(br.pad),
                }
            }
        }
    }

    /// [`BoxRay::slabs`] with the four children in lanes: the same operations in the same
    /// order (`_mm_max_ps(a, b)` is `a > b ? a : b`, `_mm_min_ps(a, b)` is `a < b ? a : b`,
    /// no fused multiply-add).
    ///
    /// # Safety
    /// SSE2 (every x86-64 CPU).
    #[inline(always)]
    pub(super) unsafe fn slabs(
        r: &SseRay,
        node: &Node4,
        t_min: f32,
        hi: f32,
    ) -> ([f32; WIDTH], u32) {
        // SAFETY: `Node4` is 64-byte aligned and its arrays of four f32 start at multiples
        // of 16 bytes, so the aligned loads are in bounds and aligned.
        unsafe {
            let mut near = _mm_set1_ps(t_min);
            let mut far = _mm_set1_ps(f32::INFINITY);
            for a in 0..3 {
                let lo = _mm_load_ps(node.lo[a].as_ptr());
                let up = _mm_load_ps(node.hi[a].as_ptr());
                let (n, f) = if r.neg[a] { (up, lo) } else { (lo, up) };
                near = _mm_max_ps(_mm_mul_ps(_mm_sub_ps(n, r.o[a]), r.inv[a]), near);
                far = _mm_min_ps(_mm_mul_ps(_mm_sub_ps(f, r.o[a]), r.inv[a]), far);
            }
            let abs = _mm_andnot_ps(_mm_set1_ps(-0.0), far);
            far = _mm_add_ps(far, _mm_mul_ps(abs, r.pad));
            far = _mm_min_ps(_mm_set1_ps(hi), far);
            let bits = _mm_movemask_ps(_mm_cmple_ps(near, far)) as u32;
            let mut out = [0.0f32; WIDTH];
            _mm_storeu_ps(out.as_mut_ptr(), near);
            (out, bits)
        }
    }
}

#[cfg(test)]
#[path = "traverse_bvh_tests.rs"]
mod tests;
