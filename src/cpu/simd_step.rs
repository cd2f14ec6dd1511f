//! One step of the irregular grid's walk for eight rays at once, one per lane of AVX2
//! registers (AVX2 CPUs; the scalar step elsewhere): [`IrregularWalker::exit`] and
//! [`IrregularWalker::next_cell`] of `cpu/traverse_irregular.rs`, whose GLSL twins are
//! `irr_exit`/`irr_next`, with the same result bit for bit. Not a GLSL twin itself.
//!
//! The scalar step divides about thirteen times (three exit crossings; per lateral axis the
//! exit point's cell and up to four crossings to bracket it), each waiting on the one
//! before. Here twelve vector divisions give eight rays every value the common case needs:
//! the exit crossings, the exit point's cell on each axis, and the crossings entering and
//! leaving that cell. Each lane evaluates the scalar expression in the scalar order,
//! `(min + k * cs - o) / d` and `floor((o + d * t - min) / cs)` (AVX's floor is exact), the
//! clamp as `Real::max` then `min`. When a bracket check finds the exit point's cell one off
//! (rounding at a boundary), that axis of that lane falls back to the scalar `lateral`,
//! which makes exactly the scalar choice. (Until stop 37 one ray's three axes shared an SSE
//! register instead: four dependent divisions a step, about 10% slower on the equal-work
//! view.)

use super::traverse::Ray;
use super::traverse_irregular::IrregularWalker;
use crate::accel::irregular::IrrCell;

/// What [`step8`] reads of eight walks, lane by lane and axis by axis: kept up to date by
/// the stream as each walk starts or moves, so that its vector loads read stores made a
/// round earlier (a vector load of eight fresh scalar stores waits for them all to retire).
#[derive(Clone, Copy, Debug)]
pub struct Lanes8 {
    o: [[f32; 8]; 3],
    d: [[f32; 8]; 3],
    lo: [[i32; 8]; 3],
    hi: [[i32; 8]; 3],
    t_prev: [f32; 8],
}

impl Default for Lanes8 {
    /// Eight idle lanes, each a harmless unit ray in a unit box.
    fn default() -> Self {
        Lanes8 {
            o: [[0.0; 8]; 3],
            d: [[1.0; 8]; 3],
            lo: [[0; 8]; 3],
            hi: [[1; 8]; 3],
            t_prev: [0.0; 8],
        }
    }
}

impl Lanes8 {
    /// Lane `j` now walks `ray`.
    #[inline(always)]
    pub fn set_ray(&mut self, j: usize, ray: &Ray<f32>) {
        for a in 0..3 {
            self.o[a][j] = ray.o[a];
            self.d[a][j] = ray.d[a];
        }
    }

    /// Lane `j`'s walk is in `cell`, entered at `t_prev`.
    #[inline(always)]
    pub fn set_cell(&mut self, j: usize, cell: &IrrCell, t_prev: f32) {
        for a in 0..3 {
            self.lo[a][j] = cell.exit_lo[a] as i32;
            self.hi[a][j] = cell.exit_hi[a] as i32;
        }
        self.t_prev[j] = t_prev;
    }
}

/// One step of up to eight walks at once, one per lane of AVX2 registers: `lanes` holds
/// each lane's ray and cell (`None`: an idle lane, whose result is meaningless) and `soa`
/// the same walks as [`Lanes8`]. The same expressions in the same order as the scalar
/// walk, so the same bits: the exit crossings, the exit point's cell on each lateral axis
/// and the crossings bracketing it; an axis whose bracket check fails in a lane takes the
/// scalar `lateral` for that lane.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub unsafe fn step8(
    w: &IrregularWalker<'_, f32>,
    soa: &Lanes8,
    lanes: &[Option<(&Ray<f32>, &IrrCell)>; 8],
) -> [(f32, usize, Option<[u32; 3]>); 8] {
    use std::arch::x86_64::*;
    let Lanes8 {
        o,
        d,
        lo,
        hi,
        t_prev: tp,
    } = soa;
    let ld = |x: &[f32; 8]| _mm256_loadu_ps(x.as_ptr());
    let ldi = |x: &[i32; 8]| _mm256_cvtepi32_ps(_mm256_loadu_si256(x.as_ptr().cast()));
    let zero = _mm256_setzero_ps();
    let one = _mm256_set1_ps(1.0);
    let big = _mm256_set1_ps(1.0e30);
    let t_prev = ld(tp);
    // Per axis: the lanes' origin, direction, signs, exit box and `(min + k * cs - o) / d`.
    let axis_of = |a: usize| {
        let (oa, da) = (ld(&o[a]), ld(&d[a]));
        let dpos = _mm256_cmp_ps::<_CMP_GT_OQ>(da, zero);
        let dzero = _mm256_cmp_ps::<_CMP_EQ_OQ>(da, zero);
        (oa, da, dpos, dzero, ldi(&lo[a]), ldi(&hi[a]))
    };
    let crossing = |a: usize, oa: __m256, da: __m256, k: __m256| {
        let (mn, cs) = (_mm256_set1_ps(w.min[a]), _mm256_set1_ps(w.cs[a]));
        _mm256_div_ps(
            _mm256_sub_ps(_mm256_add_ps(mn, _mm256_mul_ps(k, cs)), oa),
            da,
        )
    };
    // Exit crossings, as in `exit`: a face behind t_prev is crossed at t_prev, none on an
    // axis the ray does not move along.
    let mut tn = [[0.0f32; 8]; 3];
    for (a, tna) in tn.iter_mut().enumerate() {
        let (oa, da, dpos, dzero, lo_f, hi_f) = axis_of(a);
        let t = crossing(a, oa, da, _mm256_blendv_ps(lo_f, hi_f, dpos));
        let t = _mm256_max_ps(t_prev, t);
        _mm256_storeu_ps(tna.as_mut_ptr(), _mm256_blendv_ps(t, big, dzero));
    }
    let mut exit = [(0.0f32, 0usize); 8];
    let mut te = [0.0f32; 8];
    for j in 0..8 {
        let (x, y, z) = (tn[0][j], tn[1][j], tn[2][j]);
        exit[j] = if x <= y && x <= z {
            (x, 0)
        } else if y <= z {
            (y, 1)
        } else {
            (z, 2)
        };
        te[j] = exit[j].0;
    }
    // Lateral cells: the exit point's virtual cell clamped into the exit box, and whether
    // its own crossings bracket t_exit (else the scalar `lateral` decides).
    let tev = ld(&te);
    let mut kf = [[0.0f32; 8]; 3];
    let mut off = [0u32; 3];
    for a in 0..3 {
        let (oa, da, dpos, dzero, lo_f, hi_f) = axis_of(a);
        let (mn, cs) = (_mm256_set1_ps(w.min[a]), _mm256_set1_ps(w.cs[a]));
        let p = _mm256_add_ps(oa, _mm256_mul_ps(da, tev));
        let f = _mm256_floor_ps(_mm256_div_ps(_mm256_sub_ps(p, mn), cs));
        let hi_m1 = _mm256_sub_ps(hi_f, one);
        let k = _mm256_min_ps(_mm256_max_ps(f, lo_f), hi_m1);
        let k1 = _mm256_add_ps(k, one);
        let c_enter = crossing(a, oa, da, _mm256_blendv_ps(k1, k, dpos));
        let c_leave = crossing(a, oa, da, _mm256_blendv_ps(k, k1, dpos));
        let up = _mm256_cmp_ps::<_CMP_LT_OQ>(k, hi_m1);
        let down = _mm256_cmp_ps::<_CMP_GT_OQ>(k, lo_f);
        let enter_off = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GT_OQ>(c_enter, tev),
            _mm256_blendv_ps(up, down, dpos),
        );
        let leave_off = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_LE_OQ>(c_leave, tev),
            _mm256_blendv_ps(down, up, dpos),
        );
        off[a] =
            _mm256_movemask_ps(_mm256_andnot_ps(dzero, _mm256_or_ps(enter_off, leave_off))) as u32;
        _mm256_storeu_ps(kf[a].as_mut_ptr(), k);
    }
    let g = w.grid;
    let mut out = [(0.0f32, 0usize, None); 8];
    for (j, l) in lanes.iter().enumerate() {
        let Some((ray, cell)) = l else { continue };
        let (t_exit, axis) = exit[j];
        out[j] = (
            t_exit,
            axis,
            next_of(w, g, ray, cell, t_exit, axis, |a| {
                if off[a] & (1 << j) != 0 {
                    None
                } else {
                    Some(kf[a][j] as u32)
                }
            }),
        );
    }
    out
}

/// The next virtual cell after leaving `cell` through `axis` at `t_exit`, with the lateral
/// cells that `vector(a)` gives (`None`: the scalar `lateral` decides that axis); `None`
/// when the ray leaves the grid.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn next_of(
    w: &IrregularWalker<'_, f32>,
    g: &crate::accel::irregular::IrregularGrid,
    ray: &Ray<f32>,
    cell: &IrrCell,
    t_exit: f32,
    axis: usize,
    vector: impl Fn(usize) -> Option<u32>,
) -> Option<[u32; 3]> {
    let mut next = [0u32; 3];
    for (a, n) in next.iter_mut().enumerate() {
        *n = if a != axis {
            match vector(a) {
                Some(k) => k,
                None => w.lateral(ray, t_exit, a, cell.exit_lo[a], cell.exit_hi[a] - 1),
            }
        } else if ray.d[a] > 0.0 {
            if cell.exit_hi[a] >= g.res[a] {
                return None;
            }
            cell.exit_hi[a]
        } else {
            if cell.exit_lo[a] == 0 {
                return None;
            }
            cell.exit_lo[a] - 1
        };
    }
    Some(next)
}
