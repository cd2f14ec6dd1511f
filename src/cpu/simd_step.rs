//! One step of the irregular grid's walk with the three axes in the lanes of one SSE
//! register (AVX2 CPUs; the scalar step elsewhere): [`IrregularWalker::exit`] and
//! [`IrregularWalker::next_cell`] of `cpu/traverse_irregular.rs`, whose GLSL twins are
//! `irregular_exit`/`irregular_next`, with the same result bit for bit. Not a GLSL twin
//! itself.
//!
//! The scalar step divides about thirteen times (three exit crossings; per lateral axis the
//! exit point's cell and up to four crossings to bracket it); here four vector divisions
//! give every value the common case needs: the exit crossings, the exit point's cell on
//! each axis, and the crossings entering and leaving that cell. Each lane evaluates the
//! scalar expression in the scalar order (`(min + k * cs - o) / d`, `floor((o + d * t -
//! min) / cs)` with SSE4.1's exact floor, the clamp as `Real::max` then `min`). When a
//! bracket check finds the exit point's cell one off (rounding at a boundary), that axis
//! falls back to the scalar `lateral`, which makes exactly the scalar choice.

use super::traverse::Ray;
use super::traverse_irregular::IrregularWalker;
use crate::accel::irregular::IrrCell;

/// [`IrregularWalker::exit`] (t_exit, axis) and [`IrregularWalker::next_cell`] for `ray`
/// in `cell` after `t_prev`.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub unsafe fn step(
    w: &IrregularWalker<'_, f32>,
    ray: &Ray<f32>,
    cell: &IrrCell,
    t_prev: f32,
) -> (f32, usize, Option<[u32; 3]>) {
    use std::arch::x86_64::*;
    let v3 = |x: [f32; 3]| _mm_setr_ps(x[0], x[1], x[2], 0.0);
    let o = v3([ray.o.x, ray.o.y, ray.o.z]);
    let d = v3([ray.d.x, ray.d.y, ray.d.z]);
    let min = v3([w.min.x, w.min.y, w.min.z]);
    let cs = v3([w.cs.x, w.cs.y, w.cs.z]);
    let zero = _mm_setzero_ps();
    let big = _mm_set1_ps(1.0e30);
    let dpos = _mm_cmpgt_ps(d, zero);
    let dzero = _mm_cmpeq_ps(d, zero);
    let lo_i = _mm_setr_epi32(
        cell.exit_lo[0] as i32,
        cell.exit_lo[1] as i32,
        cell.exit_lo[2] as i32,
        0,
    );
    let hi_i = _mm_setr_epi32(
        cell.exit_hi[0] as i32,
        cell.exit_hi[1] as i32,
        cell.exit_hi[2] as i32,
        0,
    );
    let lo_f = _mm_cvtepi32_ps(lo_i);
    let hi_f = _mm_cvtepi32_ps(hi_i);
    // Exit crossings: the box's far face on each axis, `(min + k * cs - o) / d`.
    let face = _mm_blendv_ps(lo_f, hi_f, dpos);
    let crossing = |k: __m128| _mm_div_ps(_mm_sub_ps(_mm_add_ps(min, _mm_mul_ps(k, cs)), o), d);
    let t = crossing(face);
    // A face behind the previous exit is crossed at once (t_prev), as in `exit`. maxps
    // returns its second operand on equal values (and NaN, which only d = 0 lanes make,
    // replaced below), so t itself there, as the scalar `exit` keeps it (-0 stays -0).
    let t = _mm_max_ps(_mm_set1_ps(t_prev), t);
    let t = _mm_blendv_ps(t, big, dzero);
    let mut tn = [0.0f32; 4];
    _mm_storeu_ps(tn.as_mut_ptr(), t);
    let (t_exit, axis) = if tn[0] <= tn[1] && tn[0] <= tn[2] {
        (tn[0], 0)
    } else if tn[1] <= tn[2] {
        (tn[1], 1)
    } else {
        (tn[2], 2)
    };
    // Lateral cells: the exit point's virtual cell, clamped into the exit box.
    let te = _mm_set1_ps(t_exit);
    let p = _mm_add_ps(o, _mm_mul_ps(d, te));
    let f = _mm_floor_ps(_mm_div_ps(_mm_sub_ps(p, min), cs));
    let hi_m1 = _mm_sub_ps(hi_f, _mm_set1_ps(1.0));
    let k = _mm_min_ps(_mm_max_ps(f, lo_f), hi_m1);
    let one = _mm_set1_ps(1.0);
    // Entering and leaving boundaries of cell k: k and k + 1 for d > 0, else k + 1 and k.
    let k1 = _mm_add_ps(k, one);
    let c_enter = crossing(_mm_blendv_ps(k1, k, dpos));
    let c_leave = crossing(_mm_blendv_ps(k, k1, dpos));
    // Where the scalar bracketing loops would move k: then that axis runs them itself.
    let up = _mm_cmplt_ps(k, hi_m1);
    let down = _mm_cmpgt_ps(k, lo_f);
    let enter_off = _mm_and_ps(_mm_cmpgt_ps(c_enter, te), _mm_blendv_ps(up, down, dpos));
    let leave_off = _mm_and_ps(_mm_cmple_ps(c_leave, te), _mm_blendv_ps(down, up, dpos));
    let off = _mm_andnot_ps(dzero, _mm_or_ps(enter_off, leave_off));
    let off_bits = _mm_movemask_ps(off) as u32;
    let mut kf = [0.0f32; 4];
    _mm_storeu_ps(kf.as_mut_ptr(), k);
    let g = w.grid;
    let mut next = [0u32; 3];
    for (a, n) in next.iter_mut().enumerate() {
        *n = if a != axis {
            if off_bits & (1 << a) != 0 {
                w.lateral(ray, t_exit, a, cell.exit_lo[a], cell.exit_hi[a] - 1)
            } else {
                kf[a] as u32
            }
        } else if ray.d[a] > 0.0 {
            if cell.exit_hi[a] >= g.res[a] {
                return (t_exit, axis, None);
            }
            cell.exit_hi[a]
        } else {
            if cell.exit_lo[a] == 0 {
                return (t_exit, axis, None);
            }
            cell.exit_lo[a] - 1
        };
    }
    (t_exit, axis, Some(next))
}
