//! Vectorised watertight ray-triangle tests over a cell's references: 8 triangles at a time
//! with AVX2, 4 with SSE2 (the x86-64 baseline), chosen at run time ([`Isa::detect`]); on
//! other CPUs the scalar per-cell step of `cpu/traverse.rs` runs instead. Not a GLSL twin:
//! the scalar f32 test (`cpu/intersect.rs`) is the twin of `glsl120/intersect.glsl`, and
//! these kernels reproduce its decisions bit for bit.
//!
//! Why they are identical: each lane runs the scalar test's operations in the same order,
//! each a single IEEE-754 f32 operation (no fused multiply-add: Rust does not contract, and
//! the kernels call `mul` and `add` separately), comparisons ordered as the scalar ones
//! (false on NaN), `max` with the operand order of `Real::max`. The zero-area rejection
//! is ray-independent and decided once in [`SoaTris`]. What cannot be done lane-parallel is
//! the tie rule: the scalar loop tests triangle `i` against an upper bound that depends on
//! the hits of triangles `0 .. i`. The lanes are therefore tested against the bound held
//! at the start of the chunk (a superset of the accepted hits, since the bound only
//! shrinks), and the candidates are then accepted one by one in reference order with the
//! scalar comparison `tt < hi * |det|` on the lane's own `tt` and `|det|`.

use super::intersect::RayShear;
use super::soa::SoaTris;
use super::traverse::{tie_limit, Ray};
use crate::technique::{TBound, Techniques};

/// Which triangle-test kernel a vectorised walk runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// 8 lanes, 256-bit AVX2.
    Avx2,
    /// 4 lanes, SSE2 (every x86-64 CPU).
    Sse2,
    /// No vector kernel: the scalar per-cell step (CPUs other than x86-64).
    Scalar,
}

impl Isa {
    /// The widest kernel this CPU runs.
    pub fn detect() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                return Isa::Avx2;
            }
            Isa::Sse2
        }
        #[cfg(not(target_arch = "x86_64"))]
        Isa::Scalar
    }

    /// Whether this CPU can run the kernel.
    pub fn available(self) -> bool {
        match self {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(target_arch = "x86_64")]
            Isa::Sse2 => true,
            #[cfg(not(target_arch = "x86_64"))]
            Isa::Avx2 | Isa::Sse2 => false,
            Isa::Scalar => true,
        }
    }

    /// Name for `--stats` and the bench ("avx2", "sse2", "scalar").
    pub fn name(self) -> &'static str {
        match self {
            Isa::Avx2 => "avx2",
            Isa::Sse2 => "sse2",
            Isa::Scalar => "scalar",
        }
    }
}

/// The per-ray constants of the kernels: origin, shear, interval and the t-bound switch.
#[derive(Clone, Copy, Debug)]
pub struct RayConsts {
    /// Origin components on the shear axes kx, ky, kz.
    pub o: [f32; 3],
    /// The shear axes kx, ky, kz.
    pub k: [usize; 3],
    /// Shear constants sx, sy, sz.
    pub s: [f32; 3],
    /// Open interval (t_min, t_max).
    pub t_min: f32,
    /// See `t_min`.
    pub t_max: f32,
    /// Reject hits within their own t error bound (`TBound::On`).
    pub t_bound: bool,
}

impl RayConsts {
    /// The constants of the ray (o, shear) over (t_min, t_max).
    #[inline(always)]
    pub fn new(o: [f32; 3], sh: &RayShear<f32>, t_min: f32, t_max: f32, t_bound: bool) -> Self {
        let k = [sh.kx, sh.ky, sh.kz];
        RayConsts {
            o: k.map(|a| o[a]),
            k,
            s: [sh.sx, sh.sy, sh.sz],
            t_min,
            t_max,
            t_bound,
        }
    }

    /// The constants of `ray` for a walk with `techniques` (their t bound).
    #[inline(always)]
    pub fn of_ray(ray: &Ray<f32>, techniques: &Techniques) -> Self {
        RayConsts::new(
            [ray.o.x, ray.o.y, ray.o.z],
            &RayShear::new(ray.d),
            ray.t_min,
            ray.t_max,
            techniques.t_bound == TBound::On,
        )
    }
}

/// The closest hit found so far in one cell: reference index and the lane values the
/// scalar test would have returned them from.
#[derive(Clone, Copy, Debug, Default)]
pub struct Best {
    /// Whether a hit is held.
    pub found: bool,
    /// Its t.
    pub t: f32,
    /// Its reference index (into the structure's list).
    pub r: usize,
    /// Edge functions u, v, w and det, for the barycentrics.
    pub uvwd: [f32; 4],
}

/// Lane values of one chunk, for the one-by-one acceptance.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
struct Lanes {
    tt: [f32; 8],
    det_abs: [f32; 8],
    t: [f32; 8],
    u: [f32; 8],
    v: [f32; 8],
    w: [f32; 8],
    det: [f32; 8],
}

/// Accepts the candidate lanes `bits` of the chunk at reference `r0` one by one, in order,
/// with the scalar test's final comparison against the bound of the tie rule.
#[inline(always)]
fn accept(mut bits: u32, lanes: &Lanes, r0: usize, t_max: f32, best: &mut Best) {
    while bits != 0 {
        let i = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let hi = if best.found { tie_limit(best.t) } else { t_max };
        if lanes.tt[i] < hi * lanes.det_abs[i] {
            *best = Best {
                found: true,
                t: lanes.t[i],
                r: r0 + i,
                uvwd: [lanes.u[i], lanes.v[i], lanes.w[i], lanes.det[i]],
            };
        }
    }
}

/// Tests references `r .. r + W` (those past `left` masked off) with the kernel `isa`
/// against the upper bound `hi`: the candidate lanes as bits, their values in `lanes`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn chunk(
    isa: Isa,
    rc: &RayConsts,
    soa: &SoaTris,
    r: usize,
    left: usize,
    hi: f32,
    lanes: &mut Lanes,
) -> u32 {
    debug_assert!(isa.available() && isa != Isa::Scalar && r < soa.len);
    // SAFETY: `isa` was detected on this CPU (the callers' contract); the loads read
    // `r .. r + W`, inside the padded arrays since `r < soa.len` and the padding is a full
    // AVX2 load.
    unsafe {
        if isa == Isa::Avx2 {
            avx2::chunk(rc, soa, r, left, hi, lanes)
        } else {
            sse2::chunk(rc, soa, r, left, hi, lanes)
        }
    }
}

/// The closest hit among references `off .. off + n` of `soa` with the tie rule of
/// `traverse::closest_of` (`best` starts empty for each cell). `isa` must be available.
#[inline(always)]
pub fn closest(isa: Isa, rc: &RayConsts, soa: &SoaTris, off: usize, n: usize, best: &mut Best) {
    debug_assert!(isa.available() && isa != Isa::Scalar && off + n <= soa.len);
    #[cfg(target_arch = "x86_64")]
    {
        let mut lanes = Lanes::default();
        let w = if isa == Isa::Avx2 { 8 } else { 4 };
        let mut r = off;
        while r < off + n {
            let hi = if best.found {
                tie_limit(best.t)
            } else {
                rc.t_max
            };
            let left = off + n - r;
            let bits = chunk(isa, rc, soa, r, left, hi, &mut lanes);
            accept(bits, &lanes, r, rc.t_max, best);
            r += w;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (rc, soa, off, n, best);
}

/// A candidate of [`scan`]: a lane that passed the test against the chunk's bound, with
/// the values the scalar test computes.
#[derive(Clone, Copy, Debug)]
pub struct Candidate {
    /// Reference index (into the structure's list).
    pub r: usize,
    /// `t * |det|`, for the scalar test's final comparison `tt < hi * |det|`.
    pub tt: f32,
    /// `|det|`.
    pub det_abs: f32,
    /// The hit's t.
    pub t: f32,
    /// Edge functions u, v, w and det, for the barycentrics.
    pub uvwd: [f32; 4],
}

/// References `off .. off + n` tested a chunk at a time against the bound `bound(state)`
/// gives at the chunk's start, each candidate handed to `offer` in reference order: the
/// BVH's leaf step (`cpu/traverse_bvh.rs`), whose tie rule is not [`closest`]'s. `offer`
/// must repeat the scalar comparison against the bound of its own moment (the bound may
/// only shrink as `offer` changes `state`, so the chunk's candidates are a superset).
/// `isa` must be available.
#[inline(always)]
pub fn scan<S>(
    isa: Isa,
    rc: &RayConsts,
    soa: &SoaTris,
    (off, n): (usize, usize),
    state: &mut S,
    bound: impl Fn(&S) -> f32,
    mut offer: impl FnMut(&mut S, Candidate),
) {
    debug_assert!(isa.available() && isa != Isa::Scalar && off + n <= soa.len);
    #[cfg(target_arch = "x86_64")]
    {
        let mut lanes = Lanes::default();
        let w = if isa == Isa::Avx2 { 8 } else { 4 };
        let mut r = off;
        while r < off + n {
            let left = off + n - r;
            let hi = bound(state);
            let mut bits = chunk(isa, rc, soa, r, left, hi, &mut lanes);
            while bits != 0 {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                offer(
                    state,
                    Candidate {
                        r: r + i,
                        tt: lanes.tt[i],
                        det_abs: lanes.det_abs[i],
                        t: lanes.t[i],
                        uvwd: [lanes.u[i], lanes.v[i], lanes.w[i], lanes.det[i]],
                    },
                );
            }
            r += w;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (rc, soa, off, n, state, bound, &mut offer);
}

/// Position (0-based, in reference order) of the first of references `off .. off + n` the
/// ray hits in (t_min, t_max), or `None`: the any-hit step, which counts tests up to it.
#[inline(always)]
pub fn first_hit(isa: Isa, rc: &RayConsts, soa: &SoaTris, off: usize, n: usize) -> Option<usize> {
    debug_assert!(isa.available() && isa != Isa::Scalar && off + n <= soa.len);
    #[cfg(target_arch = "x86_64")]
    {
        let mut lanes = Lanes::default();
        let w = if isa == Isa::Avx2 { 8 } else { 4 };
        let mut r = off;
        while r < off + n {
            let left = off + n - r;
            let bits = chunk(isa, rc, soa, r, left, rc.t_max, &mut lanes);
            if bits != 0 {
                return Some(r - off + bits.trailing_zeros() as usize);
            }
            r += w;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (rc, soa, off, n);
    None
}

/// The watertight test's shear, edge functions, determinant and scaled hit distance in
/// lanes (`intersect_watertight`'s operations in its order), over the lane operations of
/// the module it expands in; `$or` and `$and` combine its masks. From the vertices
/// relative to the origin on the shear axes and the shear: `(ax, ay, bx, by, cx, cy, az,
/// bz, cz, u, v, w, det, bad, tt, det_abs)`, `bad` the lanes whose edge functions differ in
/// sign or whose determinant is zero. Shared, like [`t_error_lanes`], by the
/// triangle-lane kernel here and the ray-lane kernel of `cpu/traverse_packet.rs`.
macro_rules! edge_lanes {
    ($or:ident, $and:ident; $a_x:ident, $a_y:ident, $a_z:ident, $b_x:ident, $b_y:ident,
     $b_z:ident, $c_x:ident, $c_y:ident, $c_z:ident, $sx:ident, $sy:ident, $sz:ident) => {{
        let ax = sub($a_x, mul($sx, $a_z));
        let ay = sub($a_y, mul($sy, $a_z));
        let bx = sub($b_x, mul($sx, $b_z));
        let by = sub($b_y, mul($sy, $b_z));
        let cx = sub($c_x, mul($sx, $c_z));
        let cy = sub($c_y, mul($sy, $c_z));
        let u = sub(mul(cx, by), mul(cy, bx));
        let v = sub(mul(ax, cy), mul(ay, cx));
        let w = sub(mul(bx, ay), mul(by, ax));
        let z = splat(0.0);
        let negs = $or($or(lt(u, z), lt(v, z)), lt(w, z));
        let poss = $or($or(gt(u, z), gt(v, z)), gt(w, z));
        let det = add(add(u, v), w);
        let bad = $or($and(negs, poss), eq(det, z));
        let az = mul($sz, $a_z);
        let bz = mul($sz, $b_z);
        let cz = mul($sz, $c_z);
        let tt = add(add(mul(u, az), mul(v, bz)), mul(w, cz));
        let dneg = lt(det, z);
        let tt = select(dneg, neg(tt), tt);
        let det_abs = select(dneg, neg(det), det);
        (
            ax, ay, bx, by, cx, cy, az, bz, cz, u, v, w, det, bad, tt, det_abs,
        )
    }};
}
#[cfg(target_arch = "x86_64")]
pub(crate) use edge_lanes;

/// `intersect::watertight_t_error` term by term in lanes, over the lane operations of the
/// module it expands in (`add`, `mul`, `div`, `max`, `abs`, `splat`): the bound below which a
/// hit is rejected. Shared by the triangle-lane kernel here and the ray-lane kernel of
/// `cpu/traverse_packet.rs`, so that both compute the scalar test's bits.
macro_rules! t_error_lanes {
    ($ax:expr, $ay:expr, $bx:expr, $by:expr, $cx:expr, $cy:expr, $az:expr, $bz:expr, $cz:expr,
     $u:expr, $v:expr, $w:expr, $det_abs:expr) => {{
        let max_zt = max(max(abs($az), abs($bz)), abs($cz));
        let max_xt = max(max(abs($ax), abs($bx)), abs($cx));
        let max_yt = max(max(abs($ay), abs($by)), abs($cy));
        let (g2, g3, g5) = (
            splat(<f32 as Real>::gamma(2)),
            splat(<f32 as Real>::gamma(3)),
            splat(<f32 as Real>::gamma(5)),
        );
        let delta_z = mul(g3, max_zt);
        let delta_x = mul(g5, add(max_xt, max_zt));
        let delta_y = mul(g5, add(max_yt, max_zt));
        let delta_e = mul(
            splat(2.0),
            add(
                add(mul(mul(g2, max_xt), max_yt), mul(delta_y, max_xt)),
                mul(delta_x, max_yt),
            ),
        );
        let max_e = max(max(abs($u), abs($v)), abs($w));
        div(
            mul(
                splat(3.0),
                add(
                    add(mul(mul(g3, max_e), max_zt), mul(delta_e, max_zt)),
                    mul(delta_z, max_e),
                ),
            ),
            $det_abs,
        )
    }};
}
#[cfg(target_arch = "x86_64")]
pub(crate) use t_error_lanes;

/// The chunk kernel, written once over the lane operations of the module it expands in
/// (`avx2` or `sse2`), which define `W`, `V`, `splat`, `load`, `add`, `sub`, `mul`, `div`,
/// `max`, `abs`, `neg`, `lt`, `gt`, `le`, `eq`, `and`, `or`, `andnot`, `select`, `mask`,
/// `store` and `lane_ids`.
macro_rules! chunk_kernel {
    ($feature:literal) => {
        /// Tests references `r .. r + W` (lanes past `left` masked off) against the ray
        /// with upper bound `hi`; returns the candidate lanes as bits and stores their
        /// values in `out`.
        ///
        /// # Safety
        /// The CPU must have the module's feature, and `r + W` must be within the padded
        /// arrays of `soa`.
        #[target_feature(enable = $feature)]
        pub(super) unsafe fn chunk(
            rc: &RayConsts,
            soa: &SoaTris,
            r: usize,
            left: usize,
            hi: f32,
            out: &mut Lanes,
        ) -> u32 {
            let [kx, ky, kz] = rc.k;
            let (ox, oy, oz) = (splat(rc.o[0]), splat(rc.o[1]), splat(rc.o[2]));
            let (sx, sy, sz) = (splat(rc.s[0]), splat(rc.s[1]), splat(rc.s[2]));
            // Vertices relative to the origin, on the shear axes: `p[k] - o`.
            let [p0, p1, p2] = &soa.v;
            // SAFETY: the caller keeps `r + W` within the padded arrays.
            let (a_x, a_y, a_z, b_x, b_y, b_z, c_x, c_y, c_z, ok) = unsafe {
                (
                    sub(load(p0[kx].as_ptr().add(r)), ox),
                    sub(load(p0[ky].as_ptr().add(r)), oy),
                    sub(load(p0[kz].as_ptr().add(r)), oz),
                    sub(load(p1[kx].as_ptr().add(r)), ox),
                    sub(load(p1[ky].as_ptr().add(r)), oy),
                    sub(load(p1[kz].as_ptr().add(r)), oz),
                    sub(load(p2[kx].as_ptr().add(r)), ox),
                    sub(load(p2[ky].as_ptr().add(r)), oy),
                    sub(load(p2[kz].as_ptr().add(r)), oz),
                    load(soa.ok.as_ptr().add(r)),
                )
            };
            let (ax, ay, bx, by, cx, cy, az, bz, cz, u, v, w, det, bad, tt, det_abs) =
                edge_lanes!(or, and; a_x, a_y, a_z, b_x, b_y, b_z, c_x, c_y, c_z, sx, sy, sz);
            let inside = and(
                gt(tt, mul(splat(rc.t_min), det_abs)),
                lt(tt, mul(splat(hi), det_abs)),
            );
            let t = div(tt, det_abs);
            let live = lt(lane_ids(), splat(left.min(W) as f32));
            let mut good = andnot(bad, and(and(inside, live), ok));
            if rc.t_bound {
                let err = t_error_lanes!(ax, ay, bx, by, cx, cy, az, bz, cz, u, v, w, det_abs);
                good = andnot(le(t, err), good);
            }
            let bits = mask(good);
            if bits != 0 {
                // SAFETY: each field of `Lanes` holds 8 f32 (W is 8 or 4), so a W-lane store at
                // its start stays inside it; the caller's CPU has the module's feature.
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
            bits
        }
    };
}

/// The 8-lane operations (AVX2).
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{Lanes, RayConsts, SoaTris};
    use crate::cpu::real::Real;
    use std::arch::x86_64::*;

    const W: usize = 8;

    #[inline]
    #[target_feature(enable = "avx2")]
    fn splat(x: f32) -> __m256 {
        _mm256_set1_ps(x)
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn load(p: *const f32) -> __m256 {
        // SAFETY: the caller (the chunk kernel) passes a pointer with 8 readable f32
        // (the padded arrays); unaligned loads, and AVX2 is enabled by this function.
        unsafe { _mm256_loadu_ps(p) }
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn store(p: *mut f32, v: __m256) {
        // SAFETY: the caller passes a pointer with room for 8 f32 (a `Lanes` field);
        // unaligned stores, and AVX2 is enabled by this function.
        unsafe { _mm256_storeu_ps(p, v) }
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    fn add(a: __m256, b: __m256) -> __m256 {
        _mm256_add_ps(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    fn sub(a: __m256, b: __m256) -> __m256 {
        _mm256_sub_ps(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    fn mul(a: __m256, b: __m256) -> __m256 {
        _mm256_mul_ps(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    fn div(a: __m256, b: __m256) -> __m256 {
        _mm256_div_ps(a, b)
    }
    /// `a > b ? a : b`, as `Real::max(a, b)`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn max(a: __m256, b: __m256) -> __m256 {
        _mm256_max_ps(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    fn abs(a: __m256) -> __m256 {
        _mm256_andnot_ps(_mm256_set1_ps(-0.0), a)
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    fn neg(a: __m256) -> __m256 {
        _mm256_xor_ps(_mm256_set1_ps(-0.0), a)
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    fn lt(a: __m256, b: __m256) -> __m256 {
        _mm256_cmp_ps::<_CMP_LT_OQ>(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    fn gt(a: __m256, b: __m256) -> __m256 {
        _mm256_cmp_ps::<_CMP_GT_OQ>(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    fn le(a: __m256, b: __m256) -> __m256 {
        _mm256_cmp_ps::<_CMP_LE_OQ>(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    fn eq(a: __m256, b: __m256) -> __m256 {
        _mm256_cmp_ps::<_CMP_EQ_OQ>(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    fn and(a: __m256, b: __m256) -> __m256 {
        _mm256_and_ps(a, b)
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    fn or(a: __m256, b: __m256) -> __m256 {
        _mm256_or_ps(a, b)
    }
    /// `!a & b`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn andnot(a: __m256, b: __m256) -> __m256 {
        _mm256_andnot_ps(a, b)
    }
    /// `m ? a : b` lane by lane.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn select(m: __m256, a: __m256, b: __m256) -> __m256 {
        _mm256_blendv_ps(b, a, m)
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    fn mask(m: __m256) -> u32 {
        _mm256_movemask_ps(m) as u32
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    fn lane_ids() -> __m256 {
        _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0)
    }

    chunk_kernel!("avx2");
}

/// The 4-lane operations (SSE2, the x86-64 baseline).
#[cfg(target_arch = "x86_64")]
mod sse2 {
    use super::{Lanes, RayConsts, SoaTris};
    use crate::cpu::real::Real;
    use std::arch::x86_64::*;

    const W: usize = 4;

    #[inline]
    #[target_feature(enable = "sse2")]
    fn splat(x: f32) -> __m128 {
        _mm_set1_ps(x)
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    unsafe fn load(p: *const f32) -> __m128 {
        // SAFETY: the caller (the chunk kernel) passes a pointer with 4 readable f32
        // (the padded arrays); unaligned loads, and SSE2 is enabled by this function.
        unsafe { _mm_loadu_ps(p) }
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    unsafe fn store(p: *mut f32, v: __m128) {
        // SAFETY: the caller passes a pointer with room for 4 f32 (a `Lanes` field);
        // unaligned stores, and SSE2 is enabled by this function.
        unsafe { _mm_storeu_ps(p, v) }
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    fn add(a: __m128, b: __m128) -> __m128 {
        _mm_add_ps(a, b)
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    fn sub(a: __m128, b: __m128) -> __m128 {
        _mm_sub_ps(a, b)
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    fn mul(a: __m128, b: __m128) -> __m128 {
        _mm_mul_ps(a, b)
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    fn div(a: __m128, b: __m128) -> __m128 {
        _mm_div_ps(a, b)
    }
    /// `a > b ? a : b`, as `Real::max(a, b)`.
    #[inline]
    #[target_feature(enable = "sse2")]
    fn max(a: __m128, b: __m128) -> __m128 {
        _mm_max_ps(a, b)
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    fn abs(a: __m128) -> __m128 {
        _mm_andnot_ps(_mm_set1_ps(-0.0), a)
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    fn neg(a: __m128) -> __m128 {
        _mm_xor_ps(_mm_set1_ps(-0.0), a)
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    fn lt(a: __m128, b: __m128) -> __m128 {
        _mm_cmplt_ps(a, b)
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    fn gt(a: __m128, b: __m128) -> __m128 {
        _mm_cmpgt_ps(a, b)
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    fn le(a: __m128, b: __m128) -> __m128 {
        _mm_cmple_ps(a, b)
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    fn eq(a: __m128, b: __m128) -> __m128 {
        _mm_cmpeq_ps(a, b)
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    fn and(a: __m128, b: __m128) -> __m128 {
        _mm_and_ps(a, b)
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    fn or(a: __m128, b: __m128) -> __m128 {
        _mm_or_ps(a, b)
    }
    /// `!a & b`.
    #[inline]
    #[target_feature(enable = "sse2")]
    fn andnot(a: __m128, b: __m128) -> __m128 {
        _mm_andnot_ps(a, b)
    }
    /// `m ? a : b` lane by lane (SSE2 has no blend).
    #[inline]
    #[target_feature(enable = "sse2")]
    fn select(m: __m128, a: __m128, b: __m128) -> __m128 {
        _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b))
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    fn mask(m: __m128) -> u32 {
        _mm_movemask_ps(m) as u32
    }
    #[inline]
    #[target_feature(enable = "sse2")]
    fn lane_ids() -> __m128 {
        _mm_setr_ps(0.0, 1.0, 2.0, 3.0)
    }

    chunk_kernel!("sse2");
}
