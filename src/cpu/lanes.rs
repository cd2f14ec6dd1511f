//! Lane operations of the ray-packet walk (`cpu/traverse_packet.rs`): one module per vector
//! unit, each defining the same names over its own types, so that the walk is written once
//! (a macro) and expanded in each with the unit's target feature. Not a GLSL twin.
//!
//! Every operation is one IEEE-754 f32 operation per lane (no fused multiply-add), and
//! `max`/`min` keep the operand order of SSE's `maxps`/`minps` (`a > b ? a : b`, the second
//! operand on NaN), so a lane computes the bits the scalar walk computes.
//!
//! Names: `W` (lanes), `V` (f32 lanes), `M` (a lane mask: a bit mask on AVX-512, a vector
//! of all-ones lanes on AVX2), `splat`, `load`, `store`, `add`, `sub`, `mul`, `div`, `max`,
//! `min`, `abs`, `neg`, `lt`, `gt`, `le`, `eq`, `mand`, `mor`, `mandnot` (`!a & b`),
//! `select` (`m ? a : b`), `bits` (the mask as lane bits), `from_bits`, `gather_rows`
//! (one f32 field of an array of records, lane `i` from record `min(i, last)`) and
//! `store_u32` (counts kept in f32 lanes, stored as integers) and `rows8` (records of
//! eight f32 transposed into eight vectors: the packet's rays).

#![cfg(target_arch = "x86_64")]
// Every function here needs its module's target feature, which its callers (the walks
// compiled with that feature) have: that is the one safety contract, stated per module;
// `load` and `store` say theirs in `# Safety`.
#![allow(clippy::missing_safety_doc)]

/// Sixteen lanes: AVX-512F, its mask registers for the lane masks.
pub mod avx512 {
    use std::arch::x86_64::*;

    /// Lanes of a vector.
    pub const W: usize = 16;
    /// f32 lanes.
    pub type V = __m512;
    /// Lane mask.
    pub type M = __mmask16;

    /// Every lane `x`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn splat(x: f32) -> V {
        _mm512_set1_ps(x)
    }
    /// Sixteen lanes from `p`.
    ///
    /// # Safety
    /// `p .. p + 16` must be readable.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub unsafe fn load(p: *const f32) -> V {
        // SAFETY: the caller's contract.
        unsafe { _mm512_loadu_ps(p) }
    }
    /// Sixteen lanes to `p`.
    ///
    /// # Safety
    /// `p .. p + 16` must be writable.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub unsafe fn store(p: *mut f32, v: V) {
        // SAFETY: the caller's contract.
        unsafe { _mm512_storeu_ps(p, v) }
    }
    /// `a + b`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn add(a: V, b: V) -> V {
        _mm512_add_ps(a, b)
    }
    /// `a - b`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn sub(a: V, b: V) -> V {
        _mm512_sub_ps(a, b)
    }
    /// `a * b`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn mul(a: V, b: V) -> V {
        _mm512_mul_ps(a, b)
    }
    /// `a / b`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn div(a: V, b: V) -> V {
        _mm512_div_ps(a, b)
    }
    /// `a > b ? a : b`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn max(a: V, b: V) -> V {
        _mm512_max_ps(a, b)
    }
    /// `a < b ? a : b`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn min(a: V, b: V) -> V {
        _mm512_min_ps(a, b)
    }
    /// `|a|` (the sign bit cleared).
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn abs(a: V) -> V {
        _mm512_castsi512_ps(_mm512_and_si512(
            _mm512_castps_si512(a),
            _mm512_set1_epi32(i32::MAX),
        ))
    }
    /// `-a` (the sign bit flipped).
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn neg(a: V) -> V {
        _mm512_castsi512_ps(_mm512_xor_si512(
            _mm512_castps_si512(a),
            _mm512_set1_epi32(i32::MIN),
        ))
    }
    /// `a < b` (false on NaN).
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn lt(a: V, b: V) -> M {
        _mm512_cmp_ps_mask::<_CMP_LT_OQ>(a, b)
    }
    /// `a > b` (false on NaN).
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn gt(a: V, b: V) -> M {
        _mm512_cmp_ps_mask::<_CMP_GT_OQ>(a, b)
    }
    /// `a <= b` (false on NaN).
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn le(a: V, b: V) -> M {
        _mm512_cmp_ps_mask::<_CMP_LE_OQ>(a, b)
    }
    /// `a == b` (false on NaN).
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn eq(a: V, b: V) -> M {
        _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(a, b)
    }
    /// `a & b`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn mand(a: M, b: M) -> M {
        a & b
    }
    /// `a | b`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn mor(a: M, b: M) -> M {
        a | b
    }
    /// `!a & b`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn mandnot(a: M, b: M) -> M {
        !a & b
    }
    /// `m ? a : b` lane by lane.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn select(m: M, a: V, b: V) -> V {
        _mm512_mask_blend_ps(m, b, a)
    }
    /// The mask as lane bits.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn bits(m: M) -> u32 {
        m as u32
    }
    /// The mask of lane bits `b`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub fn from_bits(b: u32) -> M {
        b as M
    }
    /// Lane `i` from `p[min(i, last) * stride]`: one f32 field of records `stride` f32
    /// apart, the last record repeated past `last`.
    ///
    /// # Safety
    /// `p[j * stride]` must be readable for `j` in `0..=last`, and `last * stride`
    /// must fit an `i32`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub unsafe fn gather_rows(p: *const f32, stride: usize, last: usize) -> V {
        let lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
        let rec = _mm512_min_epi32(lane, _mm512_set1_epi32(last as i32));
        let idx = _mm512_mullo_epi32(rec, _mm512_set1_epi32(stride as i32));
        // SAFETY: the caller's contract; the indices count f32 (scale 4).
        unsafe { _mm512_i32gather_ps::<4>(idx, p as *const _) }
    }
    /// Sixteen lanes, each a whole number in `0..2^31`, to `p` as integers.
    ///
    /// # Safety
    /// `p .. p + 16` must be writable.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub unsafe fn store_u32(p: *mut u32, v: V) {
        // SAFETY: the caller's contract.
        unsafe { _mm512_storeu_si512(p as *mut _, _mm512_cvttps_epi32(v)) }
    }
    /// `n` (1 to 16) records of eight f32 at `p`, transposed: lane `i` of vector `k` is
    /// field `k` of record `min(i, n - 1)`. Sixteen records are eight loads and a
    /// transpose by permutes (three rounds each exchanging one bit of the register index
    /// with one of the lane index, then one permute putting the lanes in record order);
    /// fewer are gathered.
    ///
    /// # Safety
    /// `p .. p + 8 n` must be readable.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub unsafe fn rows8(p: *const f32, n: usize) -> [V; 8] {
        if n != W {
            // SAFETY: the caller's contract.
            return std::array::from_fn(|k| unsafe { gather_rows(p.add(k), 8, n - 1) });
        }
        // Register j holds records 2j and 2j + 1: lane 8 (r & 1) + f is field f of
        // record r.
        // SAFETY: the caller's contract: 128 f32.
        let mut r: [V; 8] = std::array::from_fn(|j| unsafe { _mm512_loadu_ps(p.add(16 * j)) });
        /// Per round: the register bit, and the two permutes' lane indices.
        const ROUNDS: [(usize, [[i32; 16]; 2]); 3] = [(4, idx(4)), (2, idx(2)), (1, idx(1))];
        const fn idx(m: i32) -> [[i32; 16]; 2] {
            let mut out = [[0; 16]; 2];
            let mut l = 0;
            while l < 16 {
                let hi = l & m != 0;
                out[0][l as usize] = if hi { 16 + (l & !m) } else { l };
                out[1][l as usize] = if hi { 16 + l } else { l | m };
                l += 1;
            }
            out
        }
        const ORDER: [i32; 16] = {
            let mut o = [0; 16];
            let mut i = 0;
            while i < 16 {
                o[i] = (((i & 1) << 3) | (i >> 1)) as i32;
                i += 1;
            }
            o
        };
        for (bit, [x, y]) in ROUNDS {
            // SAFETY: 16 i32 read from each array.
            let (ix, iy) = unsafe {
                (
                    _mm512_loadu_si512(x.as_ptr() as *const _),
                    _mm512_loadu_si512(y.as_ptr() as *const _),
                )
            };
            for j in (0..8).filter(|j| j & bit == 0) {
                let (a, b) = (r[j], r[j | bit]);
                r[j] = _mm512_permutex2var_ps(a, ix, b);
                r[j | bit] = _mm512_permutex2var_ps(a, iy, b);
            }
        }
        // Record i now sits in lane 8 (i & 1) + (i >> 1) of every register.
        // SAFETY: 16 i32 read from the array.
        let order = unsafe { _mm512_loadu_si512(ORDER.as_ptr() as *const _) };
        r.map(|v| _mm512_permutexvar_ps(order, v))
    }
}

/// Eight lanes: AVX2, lane masks as vectors of all-ones lanes.
pub mod avx2 {
    use std::arch::x86_64::*;

    /// Lanes of a vector.
    pub const W: usize = 8;
    /// f32 lanes.
    pub type V = __m256;
    /// Lane mask.
    pub type M = __m256;

    /// Every lane `x`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn splat(x: f32) -> V {
        _mm256_set1_ps(x)
    }
    /// Eight lanes from `p`.
    ///
    /// # Safety
    /// `p .. p + 8` must be readable.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn load(p: *const f32) -> V {
        // SAFETY: the caller's contract.
        unsafe { _mm256_loadu_ps(p) }
    }
    /// Eight lanes to `p`.
    ///
    /// # Safety
    /// `p .. p + 8` must be writable.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn store(p: *mut f32, v: V) {
        // SAFETY: the caller's contract.
        unsafe { _mm256_storeu_ps(p, v) }
    }
    /// `a + b`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn add(a: V, b: V) -> V {
        _mm256_add_ps(a, b)
    }
    /// `a - b`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn sub(a: V, b: V) -> V {
        _mm256_sub_ps(a, b)
    }
    /// `a * b`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn mul(a: V, b: V) -> V {
        _mm256_mul_ps(a, b)
    }
    /// `a / b`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn div(a: V, b: V) -> V {
        _mm256_div_ps(a, b)
    }
    /// `a > b ? a : b`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn max(a: V, b: V) -> V {
        _mm256_max_ps(a, b)
    }
    /// `a < b ? a : b`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn min(a: V, b: V) -> V {
        _mm256_min_ps(a, b)
    }
    /// `|a|` (the sign bit cleared).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn abs(a: V) -> V {
        _mm256_andnot_ps(_mm256_set1_ps(-0.0), a)
    }
    /// `-a` (the sign bit flipped).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn neg(a: V) -> V {
        _mm256_xor_ps(_mm256_set1_ps(-0.0), a)
    }
    /// `a < b` (false on NaN).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn lt(a: V, b: V) -> M {
        _mm256_cmp_ps::<_CMP_LT_OQ>(a, b)
    }
    /// `a > b` (false on NaN).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn gt(a: V, b: V) -> M {
        _mm256_cmp_ps::<_CMP_GT_OQ>(a, b)
    }
    /// `a <= b` (false on NaN).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn le(a: V, b: V) -> M {
        _mm256_cmp_ps::<_CMP_LE_OQ>(a, b)
    }
    /// `a == b` (false on NaN).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn eq(a: V, b: V) -> M {
        _mm256_cmp_ps::<_CMP_EQ_OQ>(a, b)
    }
    /// `a & b`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn mand(a: M, b: M) -> M {
        _mm256_and_ps(a, b)
    }
    /// `a | b`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn mor(a: M, b: M) -> M {
        _mm256_or_ps(a, b)
    }
    /// `!a & b`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn mandnot(a: M, b: M) -> M {
        _mm256_andnot_ps(a, b)
    }
    /// `m ? a : b` lane by lane.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn select(m: M, a: V, b: V) -> V {
        _mm256_blendv_ps(b, a, m)
    }
    /// The mask as lane bits.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn bits(m: M) -> u32 {
        _mm256_movemask_ps(m) as u32
    }
    /// The mask of lane bits `b`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn from_bits(b: u32) -> M {
        let lane = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        let hit = _mm256_and_si256(_mm256_set1_epi32(b as i32), lane);
        _mm256_castsi256_ps(_mm256_cmpeq_epi32(hit, lane))
    }
    /// Lane `i` from `p[min(i, last) * stride]`: one f32 field of records `stride` f32
    /// apart, the last record repeated past `last`.
    ///
    /// # Safety
    /// `p[j * stride]` must be readable for `j` in `0..=last`, and `last * stride`
    /// must fit an `i32`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn gather_rows(p: *const f32, stride: usize, last: usize) -> V {
        let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        let rec = _mm256_min_epi32(lane, _mm256_set1_epi32(last as i32));
        let idx = _mm256_mullo_epi32(rec, _mm256_set1_epi32(stride as i32));
        // SAFETY: the caller's contract; the indices count f32 (scale 4).
        unsafe { _mm256_i32gather_ps::<4>(p, idx) }
    }
    /// Eight lanes, each a whole number in `0..2^31`, to `p` as integers.
    ///
    /// # Safety
    /// `p .. p + 8` must be writable.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn store_u32(p: *mut u32, v: V) {
        // SAFETY: the caller's contract.
        unsafe { _mm256_storeu_si256(p as *mut __m256i, _mm256_cvttps_epi32(v)) }
    }
    /// `n` (1 to 8) records of eight f32 at `p`, transposed: lane `i` of vector `k` is
    /// field `k` of record `min(i, n - 1)` (gathered).
    ///
    /// # Safety
    /// `p .. p + 8 n` must be readable.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn rows8(p: *const f32, n: usize) -> [V; 8] {
        // SAFETY: the caller's contract.
        std::array::from_fn(|k| unsafe { gather_rows(p.add(k), 8, n - 1) })
    }
}

#[cfg(test)]
#[path = "lanes_tests.rs"]
mod tests;
