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
//! The tie rule: hits closer than the held one by more than [`TIE_EPS`](crate::accel::TIE_EPS)
//! replace it; within it, the lower triangle index wins whichever was met first. The
//! grids' walk meets a cell's triangles in index order, so there the lower index wins
//! within the margin by construction; the BVH meets triangles in its own order and decides
//! each pair as brute force does when it meets them in index order (the later one's
//! intersection test against the earlier's tie limit), which gives brute force's answer
//! except for chains of three or more hits each within the margin of the next (coplanar
//! piles, or three triangles on one edge), where the pairs met decide. "Within the
//! margin" is the intersection test's comparison in `t * |det|`, so hits of the same t
//! can fall on both sides of another's tie limit and close such a chain (the tests'
//! `bvh_tie_chain_at_the_margin_is_the_documented_exception`): the rule is then not
//! transitive, the answer depends on the order the hits are met, and brute force's is
//! that of index order. Only hits within `2 TIE_EPS` of the closest one seen are tested.

use super::closest::Closest;
use super::intersect::{intersect_with, RayShear};
use super::real::{Real, V3};
use super::simd::{self, Isa, RayConsts};
use super::soa::SoaTris;
use super::traverse::{Hit, Ray, Trace, Work};
use super::traverse_packet::{self, PacketIsa, PacketScene};
use crate::accel::bvh::{Bvh, Node4, WIDTH};
use crate::scene::Scene;
use crate::technique::{IntersectMethod, TBound, Techniques};

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
    /// The packet walks' vector unit, when batches of rays walk as packets
    /// (`cpu/traverse_packet.rs`; f32 only).
    packets: Option<PacketIsa>,
    /// Batches of closest-hit queries: one by one, or (f32 only) in packets.
    closest_many: ClosestMany<Self, T>,
    /// Batches of any-hit queries, as `closest_many`.
    any_many: fn(&Self, &[Ray<T>], &mut [bool], &mut Work),
}

/// A walk of a batch of closest-hit queries (rays, their hits, their work).
type ClosestMany<W, T> = fn(&W, &[Ray<T>], &mut [Option<Hit<T>>], &mut [Work]);

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
            packets: None,
            closest_many: Self::each_closest,
            any_many: Self::each_any,
        }
    }

    /// The closest hits of a batch, one ray at a time.
    fn each_closest(&self, rays: &[Ray<T>], hits: &mut [Option<Hit<T>>], work: &mut [Work]) {
        for ((ray, hit), w) in rays.iter().zip(hits.iter_mut()).zip(work.iter_mut()) {
            *hit = (self.closest)(self, ray, w);
        }
    }

    /// The any-hit answers of a batch, one ray at a time.
    fn each_any(&self, rays: &[Ray<T>], hit: &mut [bool], work: &mut Work) {
        for (ray, h) in rays.iter().zip(hit.iter_mut()) {
            *h = (self.any)(self, ray, work);
        }
    }

    /// The packet walks' vector unit, or `None` when batches go one ray at a time.
    pub fn packets(&self) -> Option<PacketIsa> {
        self.packets
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

    /// The scalar closest-hit walk with the caller's leaf test: `leaf(offset, count,
    /// best, tests)` tests the references `offset .. offset + count` of the tree's list
    /// into `best` (the top level of instancing, whose leaves hold instances).
    pub(super) fn closest_leaves(
        &self,
        ray: &Ray<T>,
        work: &mut Work,
        leaf: impl FnMut(usize, usize, &mut Closest<T>, &mut u64),
        best: &mut Closest<T>,
    ) {
        let br = BoxRay::new(ray);
        self.closest_walk(ray, work, |k, near, hi| br.slabs(k, near, hi), leaf, best);
    }

    /// The scalar any-hit walk with the caller's leaf test (as
    /// [`BvhWalker::closest_leaves`]).
    pub(super) fn any_leaves(
        &self,
        ray: &Ray<T>,
        work: &mut Work,
        leaf: impl FnMut(usize, usize, &mut u64) -> bool,
    ) -> bool {
        let br = BoxRay::new(ray);
        self.any_walk(ray, work, |k| br.slabs(k, ray.t_min, ray.t_max), leaf)
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

    /// [`BvhWalker::vectorised`] whose batches of rays (primary rays, each light's shadow
    /// rays, each depth's secondary rays) walk as packets of `packets`' width
    /// (`cpu/traverse_packet.rs`): the same hits (see there), single queries as
    /// `vectorised`. Packets need the vectorised triangle test: with `isa` scalar (or
    /// Möller-Trumbore, or off x86-64) batches go one ray at a time. Panics when this CPU
    /// cannot run `isa` or `packets`.
    pub fn with_packets(
        scene: &Scene,
        bvh: &'a Bvh,
        techniques: Techniques,
        isa: Isa,
        packets: PacketIsa,
    ) -> Self {
        assert!(
            packets.available(),
            "this CPU cannot run {} packets",
            packets.name()
        );
        let mut w = BvhWalker::vectorised(scene, bvh, techniques, isa);
        if w.isa != Isa::Scalar {
            w.soa.pack();
            w.packets = Some(packets);
            w.closest_many = Self::packet_closest;
            w.any_many = Self::packet_any;
        }
        w
    }

    /// What the packet walks read.
    fn packet_scene(&self) -> PacketScene<'_> {
        PacketScene {
            bvh: self.bvh,
            soa: &self.soa,
            t_bound: self.techniques.t_bound == TBound::On,
        }
    }

    /// The closest hits of a batch, in packets.
    fn packet_closest(&self, rays: &[Ray<f32>], hits: &mut [Option<Hit<f32>>], work: &mut [Work]) {
        let isa = self.packets.expect("set with the packet walks");
        traverse_packet::closest_hits(isa, &self.packet_scene(), rays, hits, work);
    }

    /// The any-hit answers of a batch, in packets.
    fn packet_any(&self, rays: &[Ray<f32>], hit: &mut [bool], work: &mut Work) {
        let isa = self.packets.expect("set with the packet walks");
        traverse_packet::any_hits(isa, &self.packet_scene(), rays, hit, work);
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
                    |best, c| best.offer(ray.t_max, &c, list[c.r]),
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

    fn closest_hits(&self, rays: &[Ray<T>], hits: &mut [Option<Hit<T>>], work: &mut [Work]) {
        (self.closest_many)(self, rays, hits, work)
    }

    fn any_hits(&self, rays: &[Ray<T>], hit: &mut [bool], work: &mut Work) {
        (self.any_many)(self, rays, hit, work)
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
