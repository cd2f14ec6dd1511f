//! Ray packets through the 4-wide BVH (`accel/bvh.rs`): 16 rays (AVX-512) or 8 (AVX2) walk
//! the tree together, one vector operation testing a child's box or a triangle against
//! every ray of the packet (Wald et al. 2001, "Interactive Rendering with Coherent Ray
//! Tracing"; Embree's `rtcIntersect16`). The CPU's default walk for batches of rays
//! (primary rays, shadow rays to a light, and each depth's reflected and refracted rays);
//! the single-ray walks of `cpu/traverse_bvh.rs` stay for single queries and as the twin it
//! is checked against. Not a GLSL twin (the GPU walks the grids).
//!
//! Why the same hits as the single-ray walk: each lane computes the single-ray walk's box
//! test (`traverse_bvh::BoxRay::slabs`) and the scalar watertight test
//! (`cpu/intersect.rs`) operation for operation, in f32 lanes (`cpu/lanes.rs`), against its
//! own bound; its shear axes are picked lane by lane with blends, which move bits and
//! compute nothing. A lane is masked off where its own box test fails, so it enters every
//! box the single-ray walk enters while its bound is at least the single-ray walk's final
//! one, and so tests every triangle whose hit the tie rule could take; and it offers each
//! candidate to [`Closest::offer`], the single-ray walk's own rule. What differs is the
//! order in which a lane meets triangles (the packet's order, nearest child first for the
//! first ray entering it), which the tie rule makes irrelevant except for chains of three
//! or more hits each within `TIE_EPS` of the next (coplanar piles), exactly as between the
//! single-ray walk and brute force. Any-hit answers do not depend on order at all.
//!
//! Counters: a lane counts the nodes and the triangles it was active for (its `cells` and
//! `tests`), so the `steps` AOV shows what the packet made each ray do.

#[cfg(target_arch = "x86_64")]
use super::closest::Closest;
use super::soa::SoaTris;
use super::traverse::{Hit, Ray, Work};
use crate::accel::bvh::Bvh;

pub use super::packet_state::MAX_W;
use super::packet_state::{Entry, Lanes, Packet, Stack};

/// The vector unit a packet walk runs on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PacketIsa {
    /// 16 rays, AVX-512F.
    Avx512,
    /// 8 rays, AVX2.
    Avx2,
}

impl PacketIsa {
    /// The widest unit this CPU runs, or `None` (SSE-only or not x86-64: the single-ray
    /// vectorised walk is the fastest there).
    pub fn detect() -> Option<PacketIsa> {
        [PacketIsa::Avx512, PacketIsa::Avx2]
            .into_iter()
            .find(|isa| isa.available())
    }

    /// Whether this CPU runs it.
    pub fn available(self) -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            match self {
                // POPCNT too (every CPU with AVX2 has it): the walks count lanes by
                // their masks, which without it is a dozen instructions.
                PacketIsa::Avx512 => {
                    std::arch::is_x86_feature_detected!("avx512f")
                        && std::arch::is_x86_feature_detected!("popcnt")
                }
                PacketIsa::Avx2 => {
                    std::arch::is_x86_feature_detected!("avx2")
                        && std::arch::is_x86_feature_detected!("popcnt")
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let _ = self;
            false
        }
    }

    /// Rays per packet.
    pub fn lanes(self) -> usize {
        match self {
            PacketIsa::Avx512 => 16,
            PacketIsa::Avx2 => 8,
        }
    }

    /// Name for `--stats` and the summary ("avx512", "avx2").
    pub fn name(self) -> &'static str {
        match self {
            PacketIsa::Avx512 => "avx512",
            PacketIsa::Avx2 => "avx2",
        }
    }
}

/// What the packet walks read: the tree, its leaves' triangles in reference order and
/// whether hits within their own t error are rejected (`TBound::On`).
#[derive(Clone, Copy)]
pub struct PacketScene<'a> {
    /// The tree.
    pub bvh: &'a Bvh,
    /// Its leaves' triangles, reference `r` at index `r`.
    pub soa: &'a SoaTris,
    /// Reject hits within their own t error bound.
    pub t_bound: bool,
}

/// The closest hit of each of `rays` into `hits` and its work into `work` (all three the
/// same length), in packets of `isa`'s width. `isa` must be available.
pub fn closest_hits(
    isa: PacketIsa,
    sc: &PacketScene<'_>,
    rays: &[Ray<f32>],
    hits: &mut [Option<Hit<f32>>],
    work: &mut [Work],
) {
    assert!(
        isa.available(),
        "this CPU cannot run {} packets",
        isa.name()
    );
    debug_assert!(rays.len() == hits.len() && rays.len() == work.len());
    #[cfg(target_arch = "x86_64")]
    {
        let w = isa.lanes();
        for ((rays, hits), work) in rays
            .chunks(w)
            .zip(hits.chunks_mut(w))
            .zip(work.chunks_mut(w))
        {
            let mut best: [Closest<f32>; MAX_W] =
                std::array::from_fn(|i| Closest::new(rays[i.min(rays.len() - 1)].t_max));
            let mut cells = [0u32; MAX_W];
            let mut tests = [0u32; MAX_W];
            // SAFETY: `isa` is available (asserted above).
            unsafe {
                match isa {
                    PacketIsa::Avx512 => {
                        let p = k16::packet(rays);
                        k16::closest(sc, &p, &mut best, &mut cells, &mut tests)
                    }
                    PacketIsa::Avx2 => {
                        let p = k8::packet(rays);
                        k8::closest(sc, &p, &mut best, &mut cells, &mut tests)
                    }
                }
            }
            for (i, (h, wk)) in hits.iter_mut().zip(work.iter_mut()).enumerate() {
                *h = best[i].hit;
                wk.cells += cells[i] as u64;
                wk.tests += tests[i] as u64;
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (sc, rays, hits, work);
}

/// Whether each of `rays` hits anything in its interval, into `hit`, the work of all added
/// to `work`, in packets of `isa`'s width. `isa` must be available.
pub fn any_hits(
    isa: PacketIsa,
    sc: &PacketScene<'_>,
    rays: &[Ray<f32>],
    hit: &mut [bool],
    work: &mut Work,
) {
    assert!(
        isa.available(),
        "this CPU cannot run {} packets",
        isa.name()
    );
    debug_assert!(rays.len() == hit.len());
    #[cfg(target_arch = "x86_64")]
    {
        let w = isa.lanes();
        for (rays, hit) in rays.chunks(w).zip(hit.chunks_mut(w)) {
            // SAFETY: `isa` is available (asserted above).
            let occluded = unsafe {
                match isa {
                    PacketIsa::Avx512 => k16::any(sc, &k16::packet(rays), work),
                    PacketIsa::Avx2 => k8::any(sc, &k8::packet(rays), work),
                }
            };
            for (i, h) in hit.iter_mut().enumerate() {
                *h = occluded & (1 << i) != 0;
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (sc, rays, hit, work);
}

/// The packet walks, written once over the lane operations of the module they expand in
/// (`cpu/lanes.rs`).
#[cfg(target_arch = "x86_64")]
macro_rules! packet_walks {
    ($feature:literal) => {
        use super::{Entry, Lanes, Packet, PacketScene, Stack, MAX_W};
        use crate::accel::bvh::{Node4, WIDTH};
        use crate::cpu::closest::Closest;
        use crate::cpu::real::Real;
        use crate::cpu::simd::Candidate;
        use crate::cpu::traverse::Ray;

        /// The packet of `rays` (1 to W of them): the single-ray walks' constants
        /// (`traverse_bvh::BoxRay::new`, `RayShear::new`, `RayConsts::new`) W rays at a
        /// time, with the same operations; lanes past the rays repeat the last one and are
        /// not live.
        ///
        /// # Safety
        /// The CPU must have the module's feature.
        #[target_feature(enable = $feature)]
        pub(super) unsafe fn packet(rays: &[Ray<f32>]) -> Packet {
            debug_assert!(!rays.is_empty() && rays.len() <= W);
            let n = rays.len();
            // Origin, direction and interval, lane by lane: the rays' eight f32 each,
            // transposed in registers (`packet_state::RAY_FIELDS`: a ray is those eight, in order).
            let p = rays.as_ptr() as *const f32;
            // SAFETY: rays `0..n` exist, eight f32 each.
            let [ox, oy, oz, dx, dy, dz, t_min, t_max] = unsafe { rows8(p, n) };
            let (o, d) = ([ox, oy, oz], [dx, dy, dz]);
            let (zero, one) = (splat(0.0), splat(1.0));
            let all = from_bits(if W == 32 { u32::MAX } else { (1u32 << W) - 1 });
            let inv = [div(one, d[0]), div(one, d[1]), div(one, d[2])];
            // `RayShear::new`: kz the largest |d| (ties to the lower axis), kx and ky the
            // next two, swapped when d[kz] < 0.
            let a = [abs(d[0]), abs(d[1]), abs(d[2])];
            let z0 = mand(le(a[1], a[0]), le(a[2], a[0]));
            let z1 = mandnot(z0, le(a[2], a[1]));
            let z2 = mandnot(mor(z0, z1), all);
            let dz = select(z0, d[0], select(z1, d[1], d[2]));
            let sw = lt(dz, zero);
            let keep = mandnot(sw, all);
            let either = |p: M, q: M| mor(mand(p, keep), mand(q, sw));
            // axis[j][c]: shear axis j is axis c.
            let axis = [
                [either(z2, z1), either(z0, z2), either(z1, z0)],
                [either(z1, z2), either(z2, z0), either(z0, z1)],
                [z0, z1, z2],
            ];
            let pick3 = |m: &[M; 3], v: &[V; 3]| select(m[1], v[1], select(m[2], v[2], v[0]));
            let (dx, dy) = (pick3(&axis[0], &d), pick3(&axis[1], &d));
            let s = [div(dx, dz), div(dy, dz), div(one, dz)];
            let ok = [
                pick3(&axis[0], &o),
                pick3(&axis[1], &o),
                pick3(&axis[2], &o),
            ];
            let mut p = Packet::empty(n);
            // SAFETY: each array holds MAX_W >= W f32.
            unsafe {
                store(p.t_min.as_mut_ptr(), t_min);
                store(p.t_max.as_mut_ptr(), t_max);
            }
            for k in 0..3 {
                // SAFETY: each array holds MAX_W >= W f32.
                unsafe {
                    store(p.o[k].as_mut_ptr(), o[k]);
                    store(p.inv[k].as_mut_ptr(), inv[k]);
                    store(p.ok[k].as_mut_ptr(), ok[k]);
                    store(p.s[k].as_mut_ptr(), s[k]);
                }
                // 1 / -0 is -inf: negative, as the zero's sign says.
                p.neg[k] = bits(lt(inv[k], zero));
                for c in 0..3 {
                    p.axis[k][c] = bits(axis[k][c]);
                }
            }
            p
        }

        /// A packet's constants in lanes.
        struct Lv {
            o: [V; 3],
            inv: [V; 3],
            neg: [M; 3],
            ok: [V; 3],
            s: [V; 3],
            axis: [[M; 3]; 3],
            /// The shear axes (kx, ky, kz) when every live lane has the same ones, as
            /// coherent packets do: the triangle test then loads each vertex coordinate
            /// straight into all lanes instead of picking it per lane.
            uniform: Option<[usize; 3]>,
            /// Per axis, whether the direction is negative, when every live lane agrees:
            /// the box test then takes each slab's near and far plane once for all lanes.
            signs: Option<[bool; 3]>,
            t_min: V,
            /// The box test's far padding, `2 gamma(3)`.
            pad: V,
        }

        impl Lv {
            #[inline]
            #[target_feature(enable = $feature)]
            fn new(p: &Packet) -> Lv {
                // SAFETY: each array holds MAX_W >= W f32.
                unsafe {
                    Lv {
                        o: [
                            load(p.o[0].as_ptr()),
                            load(p.o[1].as_ptr()),
                            load(p.o[2].as_ptr()),
                        ],
                        inv: [
                            load(p.inv[0].as_ptr()),
                            load(p.inv[1].as_ptr()),
                            load(p.inv[2].as_ptr()),
                        ],
                        neg: [
                            from_bits(p.neg[0]),
                            from_bits(p.neg[1]),
                            from_bits(p.neg[2]),
                        ],
                        ok: [
                            load(p.ok[0].as_ptr()),
                            load(p.ok[1].as_ptr()),
                            load(p.ok[2].as_ptr()),
                        ],
                        s: [
                            load(p.s[0].as_ptr()),
                            load(p.s[1].as_ptr()),
                            load(p.s[2].as_ptr()),
                        ],
                        axis: [axes(&p.axis[0]), axes(&p.axis[1]), axes(&p.axis[2])],
                        uniform: uniform_axes(p),
                        signs: uniform_signs(p),
                        t_min: load(p.t_min.as_ptr()),
                        pad: splat(2.0 * <f32 as Real>::gamma(3)),
                    }
                }
            }
        }

        /// The shear axes every live lane of `p` shares, if they do ([`Lv::uniform`]).
        #[inline]
        fn uniform_axes(p: &Packet) -> Option<[usize; 3]> {
            let shared = |j: usize| (0..3).find(|&c| p.axis[j][c] & p.live == p.live);
            Some([shared(0)?, shared(1)?, shared(2)?])
        }

        /// The direction signs every live lane of `p` shares, if they do ([`Lv::signs`]).
        #[inline]
        fn uniform_signs(p: &Packet) -> Option<[bool; 3]> {
            let shared = |a: usize| match p.neg[a] & p.live {
                0 => Some(false),
                n if n == p.live => Some(true),
                _ => None,
            };
            Some([shared(0)?, shared(1)?, shared(2)?])
        }

        /// The masks of one shear axis' three choices.
        #[inline]
        #[target_feature(enable = $feature)]
        fn axes(a: &[u32; 3]) -> [M; 3] {
            [from_bits(a[0]), from_bits(a[1]), from_bits(a[2])]
        }

        /// Coordinate `c[k]` of each lane, for the lanes' axis `k` given as masks.
        #[inline]
        #[target_feature(enable = $feature)]
        fn pick(axis: &[M; 3], c: [f32; 3]) -> V {
            select(
                axis[1],
                splat(c[1]),
                select(axis[2], splat(c[2]), splat(c[0])),
            )
        }

        /// The watertight test of reference `r` of `soa` in the lanes `live` against the
        /// upper bounds `hi`: `intersect_watertight`'s operations, as `simd.rs`'s chunk
        /// kernel orders them. Returns the candidate lanes as bits, their values in `out`
        /// when `keep`. The triangle's zero-area rejection is the caller's.
        #[inline]
        #[target_feature(enable = $feature)]
        fn triangle(
            lv: &Lv,
            soa: &SoaTris,
            r: usize,
            live: M,
            hi: V,
            t_bound: bool,
            keep: Option<&mut Lanes>,
        ) -> u32 {
            let v = &soa.packed[r].v;
            let [ox, oy, oz] = lv.ok;
            let [sx, sy, sz] = lv.s;
            // Vertex k's coordinates on each lane's shear axes, minus the lane's origin.
            let rel = |k: usize| match lv.uniform {
                Some([x, y, z]) => [
                    sub(splat(v[k][x]), ox),
                    sub(splat(v[k][y]), oy),
                    sub(splat(v[k][z]), oz),
                ],
                None => {
                    let q = v[k];
                    let [kx, ky, kz] = &lv.axis;
                    [
                        sub(pick(kx, q), ox),
                        sub(pick(ky, q), oy),
                        sub(pick(kz, q), oz),
                    ]
                }
            };
            let [a_x, a_y, a_z] = rel(0);
            let [b_x, b_y, b_z] = rel(1);
            let [c_x, c_y, c_z] = rel(2);
            let (ax, ay, bx, by, cx, cy, az, bz, cz, u, v, w, det, bad, tt, det_abs) =
                crate::cpu::simd::edge_lanes!(mor, mand; a_x, a_y, a_z, b_x, b_y, b_z, c_x, c_y, c_z, sx, sy, sz);
            let inside = mand(gt(tt, mul(lv.t_min, det_abs)), lt(tt, mul(hi, det_abs)));
            let t = div(tt, det_abs);
            let mut good = mandnot(bad, mand(inside, live));
            if t_bound && bits(good) != 0 {
                let err = crate::cpu::simd::t_error_lanes!(
                    ax, ay, bx, by, cx, cy, az, bz, cz, u, v, w, det_abs
                );
                good = mandnot(le(t, err), good);
            }
            let hits = bits(good);
            if let Some(out) = keep {
                if hits != 0 {
                    // SAFETY: each array holds MAX_W >= W f32.
                    unsafe {
                        store(out.tt.as_mut_ptr(), tt);
                        store(out.det_abs.as_mut_ptr(), det_abs);
                        store(out.t.as_mut_ptr(), t);
                        store(out.u.as_mut_ptr(), u);
                        store(out.v.as_mut_ptr(), v);
                        store(out.w.as_mut_ptr(), w);
                        store(out.det.as_mut_ptr(), det);
                    }
                }
            }
            hits
        }

        /// The four children's box tests (`BoxRay::slabs` lane by lane) in the lanes `m`
        /// against the upper bounds `hi`: the lanes meeting each child, and each lane's
        /// entry distance into `near`.
        #[inline]
        #[target_feature(enable = $feature)]
        fn children(
            lv: &Lv,
            node: &Node4,
            m: M,
            hi: V,
            near_out: &mut [[f32; MAX_W]; WIDTH],
        ) -> [u32; WIDTH] {
            let mut out = [0u32; WIDTH];
            for c in 0..WIDTH {
                let mut near = lv.t_min;
                let mut far = splat(f32::INFINITY);
                for a in 0..3 {
                    let (lo, up) = (node.lo[a][c], node.hi[a][c]);
                    let (n, f) = match lv.signs {
                        Some(neg) if neg[a] => (splat(up), splat(lo)),
                        Some(_) => (splat(lo), splat(up)),
                        None => {
                            let (lo, up) = (splat(lo), splat(up));
                            (select(lv.neg[a], up, lo), select(lv.neg[a], lo, up))
                        }
                    };
                    near = max(mul(sub(n, lv.o[a]), lv.inv[a]), near);
                    far = min(mul(sub(f, lv.o[a]), lv.inv[a]), far);
                }
                far = add(far, mul(abs(far), lv.pad));
                far = min(hi, far);
                out[c] = bits(mand(m, le(near, far)));
                // SAFETY: the array holds MAX_W >= W f32.
                unsafe { store(near_out[c].as_mut_ptr(), near) };
            }
            out
        }

        /// The closest-hit walk of packet `p`: each lane's hit into `best` (empty at the
        /// start), its node visits and triangle tests added to `cells` and `tests`.
        ///
        /// # Safety
        /// The CPU must have the module's feature.
        #[target_feature(enable = $feature)]
        pub(super) unsafe fn closest(
            sc: &PacketScene<'_>,
            p: &Packet,
            best: &mut [Closest<f32>; MAX_W],
            cells_out: &mut [u32; MAX_W],
            tests_out: &mut [u32; MAX_W],
        ) {
            let lv = Lv::new(p);
            let (soa, list) = (sc.soa, &sc.bvh.tri_indices);
            // Each lane's bound (`Closest::bound`), kept beside `best` as lanes, in a
            // register: a lane written through memory and then read as a vector would
            // stall the load until the store retires (no store forwarding).
            // SAFETY: the array holds MAX_W >= W f32.
            let mut hv = unsafe { load(p.t_max.as_ptr()) };
            let (zero, one) = (splat(0.0), splat(1.0));
            let (mut cells, mut tests) = (zero, zero);
            let mut lanes = Lanes::default();
            let mut near = [[0.0f32; MAX_W]; WIDTH];
            let mut stack = Stack::with(Entry {
                child: 0,
                count: 0,
                mask: p.live,
                near: p.t_min,
            });
            while let Some(e) = stack.pop() {
                // SAFETY: the array holds MAX_W >= W f32.
                let en = unsafe { load(e.near.as_ptr()) };
                // The lanes still entering: as the single-ray walk's `e.near > hi` cull.
                let m = mand(from_bits(e.mask), le(en, hv));
                if bits(m) == 0 {
                    continue;
                }
                if e.count > 0 {
                    let (off, n) = (e.child as usize, e.count as usize);
                    tests = add(tests, select(m, splat(n as f32), zero));
                    for r in off..off + n {
                        if soa.packed[r].ok.to_bits() == 0 {
                            continue; // zero area: never hit
                        }
                        let mut cand = triangle(&lv, soa, r, m, hv, sc.t_bound, Some(&mut lanes));
                        while cand != 0 {
                            let i = cand.trailing_zeros() as usize;
                            cand &= cand - 1;
                            let c = Candidate {
                                r,
                                tt: lanes.tt[i],
                                det_abs: lanes.det_abs[i],
                                t: lanes.t[i],
                                uvwd: [lanes.u[i], lanes.v[i], lanes.w[i], lanes.det[i]],
                            };
                            best[i].offer(p.t_max[i], &c, list[r]);
                            let b = splat(best[i].bound(p.t_max[i]));
                            hv = select(from_bits(1 << i), b, hv);
                        }
                    }
                    continue;
                }
                cells = add(cells, select(m, one, zero));
                let node = &sc.bvh.nodes[e.child as usize];
                let met = children(&lv, node, m, hv, &mut near);
                // Nearest first for the first lane entering each child, ties in slot order.
                let mut order = [0usize; WIDTH];
                let mut key = [0.0f32; WIDTH];
                let mut k = 0;
                for c in 0..WIDTH {
                    if met[c] == 0 {
                        continue;
                    }
                    let d = near[c][met[c].trailing_zeros() as usize];
                    let mut j = k;
                    while j > 0 && key[j - 1] > d {
                        order[j] = order[j - 1];
                        key[j] = key[j - 1];
                        j -= 1;
                    }
                    order[j] = c;
                    key[j] = d;
                    k += 1;
                }
                for &c in order[..k].iter().rev() {
                    stack.push(Entry {
                        child: node.child[c],
                        count: node.count[c],
                        mask: met[c],
                        near: near[c],
                    });
                }
            }
            // SAFETY: as above.
            unsafe {
                store_u32(cells_out.as_mut_ptr(), cells);
                store_u32(tests_out.as_mut_ptr(), tests);
            }
        }

        /// The any-hit walk of packet `p`: the lanes that hit something, as bits; node
        /// visits and triangle tests added to `work`.
        ///
        /// # Safety
        /// The CPU must have the module's feature.
        #[target_feature(enable = $feature)]
        pub(super) unsafe fn any(
            sc: &PacketScene<'_>,
            p: &Packet,
            work: &mut crate::cpu::traverse::Work,
        ) -> u32 {
            let lv = Lv::new(p);
            let soa = sc.soa;
            // SAFETY: the array holds MAX_W >= W f32.
            let t_max = unsafe { load(p.t_max.as_ptr()) };
            let mut open = p.live; // lanes not yet occluded
            let (mut cells, mut tests) = (0u64, 0u64);
            let mut near = [[0.0f32; MAX_W]; WIDTH];
            let mut stack = Stack::with(Entry {
                child: 0,
                count: 0,
                mask: p.live,
                near: p.t_min,
            });
            while let Some(e) = stack.pop() {
                let mut m = e.mask & open;
                if m == 0 {
                    continue;
                }
                if e.count > 0 {
                    let (off, n) = (e.child as usize, e.count as usize);
                    for r in off..off + n {
                        tests += m.count_ones() as u64;
                        if soa.packed[r].ok.to_bits() == 0 {
                            continue; // zero area: never hit
                        }
                        let hit = triangle(&lv, soa, r, from_bits(m), t_max, sc.t_bound, None);
                        m &= !hit;
                        open &= !hit;
                        if m == 0 {
                            break;
                        }
                    }
                    if open == 0 {
                        break;
                    }
                    continue;
                }
                cells += m.count_ones() as u64;
                let node = &sc.bvh.nodes[e.child as usize];
                let met = children(&lv, node, from_bits(m), t_max, &mut near);
                // Slot order, as the single-ray any-hit walk (the answer does not depend
                // on it).
                for c in (0..WIDTH).rev() {
                    if met[c] != 0 {
                        stack.push(Entry {
                            child: node.child[c],
                            count: node.count[c],
                            mask: met[c],
                            near: p.t_min,
                        });
                    }
                }
            }
            work.cells += cells;
            work.tests += tests;
            p.live & !open
        }
    };
}

/// The walks in 16 lanes (AVX-512F).
#[cfg(target_arch = "x86_64")]
mod k16 {
    use super::SoaTris;
    use crate::cpu::lanes::avx512::*;
    packet_walks!("avx512f,popcnt");
}

/// The walks in 8 lanes (AVX2).
#[cfg(target_arch = "x86_64")]
mod k8 {
    use super::SoaTris;
    use crate::cpu::lanes::avx2::*;
    packet_walks!("avx2,popcnt");
}

#[cfg(test)]
#[path = "traverse_packet_tests.rs"]
mod tests;

/// The vectorised packet set-up against the ray-by-ray one, bit for bit.
#[cfg(all(test, target_arch = "x86_64"))]
mod build_tests {
    use super::*;
    use crate::testing::{random_rays, ray_of, test_seed, Rng};
    use glam::DVec3;

    /// Every field of the packet, as bits, for comparison.
    fn fields(p: &Packet) -> Vec<u32> {
        let mut v = vec![p.live];
        for a in [&p.o, &p.inv, &p.ok, &p.s] {
            v.extend(a.iter().flatten().map(|x| x.to_bits()));
        }
        v.extend(p.t_min.iter().chain(&p.t_max).map(|x| x.to_bits()));
        v.extend(p.neg);
        v.extend(p.axis.iter().flatten());
        v
    }

    #[test]
    fn vector_setup_is_the_ray_by_ray_setup() {
        let seed = test_seed("packet setup", 0x9ACE_0001);
        let mut rng = Rng::new(seed);
        let mut rays: Vec<Ray<f32>> = random_rays(&mut rng, 300, 2.0)
            .into_iter()
            .map(|(o, d, t)| ray_of(o, d, t))
            .collect();
        // Zero components of both signs, ties between |d| components, negative kz.
        for d in [
            [0.0, 0.0, 1.0],
            [-0.0, 0.0, -1.0],
            [1.0, 1.0, 0.0],
            [-1.0, 1.0, 1.0],
            [0.0, -1.0, -0.0],
            [-2.0, 2.0, -2.0],
            [0.5, -0.0, -0.5],
        ] {
            rays.push(ray_of(DVec3::new(0.1, 0.2, 0.3), DVec3::from_array(d), 5.0));
        }
        for isa in [PacketIsa::Avx512, PacketIsa::Avx2] {
            if !isa.available() {
                continue;
            }
            let w = isa.lanes();
            for n in [1, 3, w - 1, w] {
                for chunk in rays.chunks(n) {
                    // SAFETY: `isa` is available.
                    let p = unsafe {
                        match isa {
                            PacketIsa::Avx512 => k16::packet(chunk),
                            PacketIsa::Avx2 => k8::packet(chunk),
                        }
                    };
                    let mut want = Packet::new(chunk);
                    // The reference fills all MAX_W lanes; the unit only its W.
                    for i in w..MAX_W {
                        for a in 0..3 {
                            want.o[a][i] = 0.0;
                            want.inv[a][i] = 0.0;
                            want.ok[a][i] = 0.0;
                            want.s[a][i] = 0.0;
                            want.neg[a] &= (1 << w) - 1;
                            for c in 0..3 {
                                want.axis[a][c] &= (1 << w) - 1;
                            }
                        }
                        want.t_min[i] = 0.0;
                        want.t_max[i] = 0.0;
                    }
                    assert_eq!(
                        fields(&p),
                        fields(&want),
                        "seed {seed} {}: {n} rays",
                        isa.name()
                    );
                }
            }
        }
    }
}
