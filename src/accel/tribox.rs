//! Exact triangle / axis-aligned box overlap, after Akenine-Möller ("Fast 3D Triangle-Box
//! Overlap Testing", 2001): the two are disjoint iff one of 13 candidate axes separates
//! them (the 3 box normals, the triangle normal, and the 9 cross products of a box normal
//! with a triangle edge).
//!
//! The grid build uses this instead of bounding-box binning so that large or diagonal
//! triangles do not pollute cells they only pass near. It runs in f64 on f32 input, and
//! every comparison is inclusive, so touching counts as overlapping: the build relies on
//! that (plus a small padding of the box) to put a triangle lying on a cell face into the
//! cells on both sides.

use glam::DVec3;

/// True when triangle `tri` and the closed box `center ± half` share at least one point.
///
/// `half` must be non-negative. Degenerate triangles (segments, points) are handled
/// exactly: their zero-length cross-product axes project everything to 0 and separate
/// nothing, and the remaining axes are precisely the separating axes of a segment or a
/// point against a box.
pub fn tri_box_overlap(center: DVec3, half: DVec3, tri: [DVec3; 3]) -> bool {
    match box_normals_and_inside(center, half, tri) {
        Ok(v) => !cross_axes_separate(half, &v),
        Err(answer) => answer,
    }
}

/// [`tri_box_overlap`] for a triangle lying inside the box's slab on axis `k`, its extent
/// on `k` within the box's by a margin far above the rounding error: the two overlap
/// exactly when their projections along `k` do, so only the two other box normals and
/// the three axes `k x edge` can separate them (the other eight of the full test never do
/// then: each would separate the projections too). The same arithmetic as the full test
/// on those axes, so the same answer; a third of its work for the triangles of a grid
/// build that cross cell boundaries on two axes only. Crate-internal: outside that
/// precondition (which the binning checks) its answer can be wrong.
pub(crate) fn tri_box_overlap_in_slab(
    center: DVec3,
    half: DVec3,
    tri: [DVec3; 3],
    k: usize,
) -> bool {
    match box_normals_and_inside(center, half, tri) {
        Ok(v) => {
            let edges = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
            !edges.iter().any(|&e| edge_axis_separates(half, &v, e, k))
        }
        Err(answer) => answer,
    }
}

/// [`tri_box_overlap`] of the triangle against each of the first `n` (at most four) boxes
/// `center[l] ± half[l]`, or, with `slab = Some(k)`, [`tri_box_overlap_in_slab`] (under its
/// precondition): bit `l` of the result. The same answers box by box (the same
/// arithmetic, in the same order), four boxes at once without a branch where the CPU has
/// AVX: every axis is computed, rather than stopping at the first that decides, which
/// costs less than the branches it spares (the binning's answers are about even).
pub(crate) fn tri_boxes_overlap(
    center: &[DVec3; 4],
    half: &[DVec3; 4],
    n: usize,
    tri: [DVec3; 3],
    slab: Option<usize>,
) -> u8 {
    debug_assert!(n <= 4);
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU has AVX, checked just above.
        return unsafe { avx::tri_boxes_overlap(center, half, tri, slab) } & ((1u8 << n) - 1);
    }
    let mut bits = 0;
    for l in 0..n {
        let yes = match slab {
            Some(k) => tri_box_overlap_in_slab(center[l], half[l], tri, k),
            None => tri_box_overlap(center[l], half[l], tri),
        };
        bits |= (yes as u8) << l;
    }
    bits
}

/// The four-box test with AVX: a lane a box.
#[cfg(target_arch = "x86_64")]
mod avx {
    use glam::DVec3;
    use std::arch::x86_64::*;

    /// [`super::tri_boxes_overlap`] for all four lanes. Every value is formed as the
    /// scalar tests form it (`box_normals_and_inside`, `vertex_well_inside`,
    /// `edge_axis_separates`, `separates` with glam's `cross` and `dot`), as separate
    /// multiplications and additions (no fused multiply-add), so each lane's answer is the
    /// scalar test's; min and max see no NaN (finite input) and the sign of a zero
    /// changes no comparison with a non-negative radius.
    #[target_feature(enable = "avx")]
    pub(super) unsafe fn tri_boxes_overlap(
        center: &[DVec3; 4],
        half: &[DVec3; 4],
        tri: [DVec3; 3],
        slab: Option<usize>,
    ) -> u8 {
        let sign = _mm256_set1_pd(-0.0);
        let abs = |a: __m256d| _mm256_andnot_pd(sign, a);
        let neg = |a: __m256d| _mm256_xor_pd(a, sign);
        let (add, sub, mul) = (_mm256_add_pd, _mm256_sub_pd, _mm256_mul_pd);
        let (min, max, or, and) = (_mm256_min_pd, _mm256_max_pd, _mm256_or_pd, _mm256_and_pd);
        let gt = |a, b| _mm256_cmp_pd::<_CMP_GT_OQ>(a, b);
        let lt = |a, b| _mm256_cmp_pd::<_CMP_LT_OQ>(a, b);
        let le = |a, b| _mm256_cmp_pd::<_CMP_LE_OQ>(a, b);
        let lanes = |b: &[DVec3; 4], k: usize| _mm256_set_pd(b[3][k], b[2][k], b[1][k], b[0][k]);
        let c = [lanes(center, 0), lanes(center, 1), lanes(center, 2)];
        let h = [lanes(half, 0), lanes(half, 1), lanes(half, 2)];
        // The triangle relative to each box's centre.
        let mut v = [[_mm256_setzero_pd(); 3]; 3];
        for i in 0..3 {
            for k in 0..3 {
                v[i][k] = sub(_mm256_set1_pd(tri[i][k]), c[k]);
            }
        }
        // Box normals.
        let mut sep = _mm256_setzero_pd();
        for k in 0..3 {
            let lo = min(min(v[0][k], v[1][k]), v[2][k]);
            let hi = max(max(v[0][k], v[1][k]), v[2][k]);
            sep = or(sep, or(gt(lo, h[k]), lt(hi, neg(h[k]))));
        }
        // A vertex well inside.
        let margin = mul(_mm256_set1_pd(1e-9), max(h[0], max(h[1], h[2])));
        let inner = [sub(h[0], margin), sub(h[1], margin), sub(h[2], margin)];
        let mut inside = _mm256_setzero_pd();
        for p in &v {
            let all = and(
                and(le(abs(p[0]), inner[0]), le(abs(p[1]), inner[1])),
                le(abs(p[2]), inner[2]),
            );
            inside = or(inside, all);
        }
        // Edge axes: `k x e` is `a * s + b * t` on the two other axes `s`, `t`.
        let mut e = [[_mm256_setzero_pd(); 3]; 3];
        for j in 0..3 {
            for k in 0..3 {
                e[j][k] = sub(v[(j + 1) % 3][k], v[j][k]);
            }
        }
        let mut cross = _mm256_setzero_pd();
        let (k_lo, k_hi) = match slab {
            Some(k) => (k, k + 1),
            None => (0, 3),
        };
        for ej in &e {
            for k in k_lo..k_hi {
                let (a, s, b, t) = match k {
                    0 => (neg(ej[2]), 1, ej[1], 2),
                    1 => (ej[2], 0, neg(ej[0]), 2),
                    _ => (neg(ej[1]), 0, ej[0], 1),
                };
                let p = |i: usize| add(mul(a, v[i][s]), mul(b, v[i][t]));
                let (p0, p1, p2) = (p(0), p(1), p(2));
                let lo = min(min(p0, p1), p2);
                let hi = max(max(p0, p1), p2);
                let r = add(mul(h[s], abs(a)), mul(h[t], abs(b)));
                cross = or(cross, or(gt(lo, r), lt(hi, neg(r))));
            }
        }
        if slab.is_none() {
            // The triangle's normal, `e0 x e1` as glam's `cross` forms it.
            let (e0, e1) = (&e[0], &e[1]);
            let nv = [
                sub(mul(e0[1], e1[2]), mul(e1[1], e0[2])),
                sub(mul(e0[2], e1[0]), mul(e1[2], e0[0])),
                sub(mul(e0[0], e1[1]), mul(e1[0], e0[1])),
            ];
            let dot = |a: &[__m256d; 3], b: &[__m256d; 3]| {
                add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]))
            };
            let (p0, p1, p2) = (dot(&nv, &v[0]), dot(&nv, &v[1]), dot(&nv, &v[2]));
            let lo = min(min(p0, p1), p2);
            let hi = max(max(p0, p1), p2);
            let r = dot(&h, &[abs(nv[0]), abs(nv[1]), abs(nv[2])]);
            cross = or(cross, or(gt(lo, r), lt(hi, neg(r))));
        }
        // Not separated by a box normal, and a vertex well inside or no other axis (the
        // scalar test's order of answers; the caller keeps the lanes it filled).
        let bits = |m: __m256d| _mm256_movemask_pd(m) as u8;
        !bits(sep) & (bits(inside) | !bits(cross)) & 0xF
    }
}

/// The first steps of both tests: the triangle relative to the box centre (so that the
/// box is symmetric and its projection onto an axis `a` is just `[-r, r]` with
/// `r = half · |a|`), or the answer when the box normals or a vertex well inside give it.
#[inline(always)]
fn box_normals_and_inside(center: DVec3, half: DVec3, tri: [DVec3; 3]) -> Result<[DVec3; 3], bool> {
    let v = [tri[0] - center, tri[1] - center, tri[2] - center];

    // Box normals: the triangle's bounding box against the box.
    for k in 0..3 {
        let lo = v[0][k].min(v[1][k]).min(v[2][k]);
        let hi = v[0][k].max(v[1][k]).max(v[2][k]);
        if lo > half[k] || hi < -half[k] {
            return Err(false);
        }
    }

    // A vertex inside the box by a margin far above the rounding error (1e-9 of the box
    // against 1e-16): the triangle overlaps, and none of the remaining axes can separate it
    // in floating point either (each projects that vertex inside the box's projection by
    // the margin times the axis length), so the answer is what the full test gives,
    // without its ten cross products. The build meets this for most of the triangles it
    // tests against the cells they lie in.
    if vertex_well_inside(half, &v) {
        return Err(true);
    }
    Ok(v)
}

/// Whether box normal `k` crossed with edge `e` separates the centred box `±half` from
/// the triangle `v`. Written out: `X x e = (0, -e.z, e.y)` and so on; the zero
/// component's products (`0 * v.x`) only add a zero, so these are the values
/// `separates(DVec3::AXES[k].cross(e), ..)` computes, up to the sign of a zero result,
/// with a third of the multiplications. Projecting all three vertices (rather than the two
/// distinct values the paper exploits) keeps the rounding of the general form.
#[inline(always)]
fn edge_axis_separates(half: DVec3, v: &[DVec3; 3], e: DVec3, k: usize) -> bool {
    let a = e.abs();
    let (p, r): ([f64; 3], f64) = match k {
        0 => (
            v.map(|p| -e.z * p.y + e.y * p.z),
            half.y * a.z + half.z * a.y,
        ),
        1 => (
            v.map(|p| e.z * p.x + -e.x * p.z),
            half.x * a.z + half.z * a.x,
        ),
        _ => (
            v.map(|p| -e.y * p.x + e.x * p.y),
            half.x * a.y + half.y * a.x,
        ),
    };
    let lo = p[0].min(p[1]).min(p[2]);
    let hi = p[0].max(p[1]).max(p[2]);
    lo > r || hi < -r
}

/// Some vertex of `v` lies inside the centred box `±half` by 1e-9 of its largest half
/// side on every axis.
#[inline]
fn vertex_well_inside(half: DVec3, v: &[DVec3; 3]) -> bool {
    let inner = half - DVec3::splat(1e-9 * half.max_element());
    v.iter().any(|p| p.abs().cmple(inner).all())
}

/// The remaining ten axes of the separating-axis test (after the box normals).
#[inline]
fn cross_axes_separate(half: DVec3, v: &[DVec3; 3]) -> bool {
    let edges = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    if edges
        .iter()
        .any(|&e| (0..3).any(|k| edge_axis_separates(half, v, e, k)))
    {
        return true;
    }

    // Triangle normal: the plane through the triangle against the box. A zero normal
    // (degenerate triangle) projects everything to 0 and never separates.
    let normal = edges[0].cross(edges[1]);
    separates(normal, half, v)
}

/// True when `axis` separates the centred box `±half` from the triangle `v`.
#[inline]
fn separates(axis: DVec3, half: DVec3, v: &[DVec3; 3]) -> bool {
    let p = [axis.dot(v[0]), axis.dot(v[1]), axis.dot(v[2])];
    let lo = p[0].min(p[1]).min(p[2]);
    let hi = p[0].max(p[1]).max(p[2]);
    let r = half.dot(axis.abs());
    lo > r || hi < -r
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::testing::{test_seed, Rng};

    /// Independent reference: clip the triangle against the six slabs of `center ± half`
    /// (Sutherland-Hodgman) and report whether anything is left. Exact up to f64 rounding,
    /// and shares no code with the separating-axis test.
    pub(crate) fn clip_overlap(center: DVec3, half: DVec3, tri: [DVec3; 3]) -> bool {
        let mut poly: Vec<DVec3> = tri.to_vec();
        for k in 0..3 {
            for sign in [1.0, -1.0] {
                // Keep the half-space sign * (p[k] - center[k]) <= half[k].
                let d = |p: DVec3| sign * (p[k] - center[k]) - half[k];
                let mut out = Vec::with_capacity(poly.len() + 2);
                for i in 0..poly.len() {
                    let a = poly[i];
                    let b = poly[(i + 1) % poly.len()];
                    let (da, db) = (d(a), d(b));
                    if da <= 0.0 {
                        out.push(a);
                    }
                    if (da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0) {
                        out.push(a + (b - a) * (da / (da - db)));
                    }
                }
                poly = out;
                if poly.is_empty() {
                    return false;
                }
            }
        }
        true
    }

    /// Any point of a dense barycentric lattice over the triangle strictly inside the box
    /// by at least `margin`.
    fn sampled_inside(center: DVec3, half: DVec3, tri: [DVec3; 3], n: u32, margin: f64) -> bool {
        for i in 0..=n {
            for j in 0..=(n - i) {
                let (u, w) = (i as f64 / n as f64, j as f64 / n as f64);
                let p = tri[0] * (1.0 - u - w) + tri[1] * u + tri[2] * w;
                let d = (p - center).abs();
                if d.x < half.x - margin && d.y < half.y - margin && d.z < half.z - margin {
                    return true;
                }
            }
        }
        false
    }

    fn v(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    #[test]
    fn agrees_with_sampling_and_clipping() {
        let seed = test_seed("tri_box random", 0x5EED_7B0C);
        let mut rng = Rng::new(seed);
        let (mut hits, mut misses, mut sampled_hits) = (0, 0, 0);
        for case in 0..20_000 {
            let center = rng.dvec3(-0.5, 0.5);
            let half = DVec3::new(
                rng.range(0.05, 1.0),
                rng.range(0.05, 1.0),
                rng.range(0.05, 1.0),
            );
            // Mix big triangles (mostly crossing) and small ones (often near misses).
            let scale = if case % 2 == 0 { 2.5 } else { 0.6 };
            let a = rng.dvec3(-2.0, 2.0);
            let tri = [
                a,
                a + rng.dvec3(-scale, scale),
                a + rng.dvec3(-scale, scale),
            ];
            let got = tri_box_overlap(center, half, tri);
            let ctx = format!("seed {seed} case {case}: center {center} half {half} tri {tri:?}");

            if sampled_inside(center, half, tri, 48, 1e-9) {
                sampled_hits += 1;
                assert!(got, "sample inside but no overlap reported; {ctx}");
            }
            // Clipping against a slightly shrunk/grown box gives a verdict that must agree
            // wherever the case is not within rounding distance of touching.
            let tol = DVec3::splat(1e-9);
            if clip_overlap(center, half - tol, tri) {
                assert!(got, "clipping finds overlap, test does not; {ctx}");
            }
            if got {
                assert!(
                    clip_overlap(center, half + tol, tri),
                    "test reports overlap, clipping finds none; {ctx}"
                );
                hits += 1;
            } else {
                misses += 1;
            }
        }
        println!("hits {hits} misses {misses} sampled hits {sampled_hits}");
        // Both verdicts must be well exercised or the test proves little.
        assert!(hits > 1500 && misses > 1500 && sampled_hits > 1000);
    }

    #[test]
    fn degenerate_triangles_agree_with_clipping() {
        let seed = test_seed("tri_box degenerate", 0xDE6E_0001);
        let mut rng = Rng::new(seed);
        let (mut hits, mut misses) = (0, 0);
        for case in 0..5_000 {
            let center = rng.dvec3(-0.5, 0.5);
            let half = rng.dvec3(0.05, 1.0);
            let a = rng.dvec3(-1.5, 1.5);
            let b = rng.dvec3(-1.5, 1.5);
            // A segment (collinear vertices, midpoint included) or a single point.
            let tri = if case % 3 == 0 {
                [a, a, a]
            } else {
                [a, b, (a + b) * 0.5]
            };
            let got = tri_box_overlap(center, half, tri);
            let tol = DVec3::splat(1e-9);
            let ctx = format!("seed {seed} case {case}: center {center} half {half} tri {tri:?}");
            if clip_overlap(center, half - tol, tri) {
                assert!(got, "clipping finds overlap, test does not; {ctx}");
            }
            if got {
                assert!(clip_overlap(center, half + tol, tri), "spurious; {ctx}");
                hits += 1;
            } else {
                misses += 1;
            }
        }
        assert!(hits > 300 && misses > 300, "hits {hits} misses {misses}");
    }

    /// The written-out edge axes decide as the general form `separates(AXES[k].cross(e))`
    /// does, axis by axis, on random triangles and on triangles whose projections touch
    /// the box's (a vertex moved onto the box's face, edge or corner).
    #[test]
    fn written_out_axes_match_the_general_form() {
        let seed = test_seed("tri_box axes", 0x5EED_7B0E);
        let mut rng = Rng::new(seed);
        let general = |half: DVec3, v: &[DVec3; 3]| {
            let edges = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
            edges
                .iter()
                .any(|e| (0..3).any(|k| separates(DVec3::AXES[k].cross(*e), half, v)))
                || separates(edges[0].cross(edges[1]), half, v)
        };
        let (mut sep, mut total) = (0, 0);
        for case in 0..200_000 {
            let half = rng.dvec3(0.0, 1.0) * 10f64.powf(rng.range(-3.0, 2.0));
            let mut v = [0; 3].map(|_| rng.dvec3(-2.0, 2.0) * half.max_element());
            if case % 2 == 0 {
                for k in 0..3 {
                    if rng.f64() < 0.6 {
                        v[0][k] = if rng.f64() < 0.5 { half[k] } else { -half[k] };
                    }
                }
            }
            if case % 3 == 0 {
                v[2] = v[1];
            }
            let want = general(half, &v);
            assert_eq!(
                cross_axes_separate(half, &v),
                want,
                "seed {seed} case {case}: half {half} v {v:?}"
            );
            sep += want as u32;
            total += 1;
        }
        // Measured: 81,048 of 200,000 separated.
        both_answers_often(seed, sep, total, "separated");
    }

    /// The early accept (a vertex well inside the box) never answers yes where the ten
    /// cross axes would separate: vertices just inside the accept margin, boxes from 1e-6 to
    /// 1e3 wide at distances up to 1e4 from the origin, the other two vertices anywhere.
    #[test]
    fn early_accept_agrees_with_the_cross_axes() {
        let seed = test_seed("tri_box early accept", 0x5EED_7B0D);
        let mut rng = Rng::new(seed);
        let mut accepted = 0;
        for case in 0..200_000 {
            let half = rng.dvec3(0.0, 1.0) * 10f64.powf(rng.range(-6.0, 3.0)) + 1e-9;
            let center = rng.dvec3(-1.0, 1.0) * 10f64.powf(rng.range(-2.0, 4.0));
            // One vertex on the accept margin's boundary (an ulp either side), on a random
            // face, edge or corner; the others near or far.
            let m = 1e-9 * half.max_element();
            let mut p = rng.dvec3(-1.0, 1.0) * (half - DVec3::splat(m));
            for k in 0..3 {
                if rng.f64() < 0.5 {
                    let s = if rng.f64() < 0.5 { -1.0 } else { 1.0 };
                    p[k] = s * (half[k] - m);
                }
            }
            let reach = half.max_element() * 10f64.powf(rng.range(-1.0, 2.0));
            let tri = [
                center + p,
                center + p + rng.dvec3(-reach, reach),
                center + p + rng.dvec3(-reach, reach),
            ];
            let v = tri.map(|t| t - center);
            if vertex_well_inside(half, &v) {
                accepted += 1;
                assert!(
                    !cross_axes_separate(half, &v),
                    "seed {seed} case {case}: center {center} half {half} tri {tri:?}"
                );
            }
        }
        // Measured: 123,651 of 200,000 (the rest: the margin rounded the vertex outside).
        assert!(accepted > 50_000, "seed {seed}: {accepted} accepted");
    }

    /// The two-axis test decides as the full test for triangles inside the box's slab on
    /// the third axis (by at least 1e-6 of the box there): random boxes and triangles,
    /// half of them with a vertex moved onto the box's face, edge or corner in the other
    /// two axes, where the projections touch. Both answers are required often.
    #[test]
    fn slab_test_matches_the_full_test_inside_the_slab() {
        let seed = test_seed("tri_box slab", 0x5EED_7B0F);
        let mut rng = Rng::new(seed);
        let (mut yes, mut total) = (0, 0);
        for case in 0..200_000 {
            let k = case % 3;
            let half = rng.dvec3(0.01, 1.0) * 10f64.powf(rng.range(-3.0, 2.0));
            let center = rng.dvec3(-1.0, 1.0) * 10f64.powf(rng.range(-2.0, 3.0));
            let mut tri = [0; 3].map(|_| center + rng.dvec3(-4.0, 4.0) * half);
            let inside = half[k] * (1.0 - 1e-6);
            for v in &mut tri {
                v[k] = center[k] + rng.range(-inside, inside);
            }
            if case % 2 == 0 {
                for a in (0..3).filter(|&a| a != k) {
                    if rng.f64() < 0.6 {
                        tri[0][a] = center[a] + if rng.f64() < 0.5 { half[a] } else { -half[a] };
                    }
                }
            }
            let want = tri_box_overlap(center, half, tri);
            assert_eq!(
                tri_box_overlap_in_slab(center, half, tri, k),
                want,
                "seed {seed} case {case}: axis {k} center {center} half {half} tri {tri:?}"
            );
            yes += want as u32;
            total += 1;
        }
        both_answers_often(seed, yes, total, "overlap");
    }

    /// The four-box test answers as the scalar tests, box by box and bit for bit, full and
    /// two-axis: random boxes and triangles (degenerate ones too), with vertices moved onto
    /// a box's faces, edges and corners (where the projections touch) and onto the early
    /// accept's margin, four boxes sharing faces as a node's children do, and batches of
    /// one to four. Prints which path ran (AVX or the scalar loop).
    #[test]
    fn four_box_test_matches_the_scalar_tests() {
        let seed = test_seed("tri_box four boxes", 0x5EED_7B10);
        let mut rng = Rng::new(seed);
        #[cfg(target_arch = "x86_64")]
        println!("AVX: {}", std::arch::is_x86_feature_detected!("avx"));
        let (mut yes, mut total) = (0, 0);
        for case in 0..100_000 {
            let scale = 10f64.powf(rng.range(-3.0, 2.0));
            let origin = rng.dvec3(-1.0, 1.0) * 10f64.powf(rng.range(-2.0, 3.0));
            // A 2x2 block of boxes sharing faces (a node's children), in a random plane.
            let size = rng.dvec3(0.05, 1.0) * scale;
            let pad = 1e-5 * size;
            let (a, b) = (
                (case % 3) as usize,
                (case % 3 + 1 + case / 3 % 2) as usize % 3,
            );
            let mut center = [DVec3::ZERO; 4];
            let mut half = [DVec3::ZERO; 4];
            for l in 0..4 {
                let mut lo = origin;
                lo[a] += (l % 2) as f64 * size[a];
                lo[b] += (l / 2) as f64 * size[b];
                center[l] = lo + 0.5 * size;
                half[l] = 0.5 * size + pad;
            }
            let block = origin + size;
            let mut tri = [0; 3].map(|_| block + rng.dvec3(-1.5, 1.5) * size);
            match case % 4 {
                0 => {
                    // A vertex onto a face, edge or corner of one box.
                    let l = (rng.next_u64() % 4) as usize;
                    for k in 0..3 {
                        if rng.f64() < 0.6 {
                            let s = if rng.f64() < 0.5 { -1.0 } else { 1.0 };
                            tri[0][k] = center[l][k] + s * half[l][k];
                        }
                    }
                }
                1 => {
                    // A vertex onto the early accept's margin of one box.
                    let l = (rng.next_u64() % 4) as usize;
                    let m = 1e-9 * half[l].max_element();
                    let k = (rng.next_u64() % 3) as usize;
                    tri[0] = center[l] + rng.dvec3(-0.5, 0.5) * half[l];
                    tri[0][k] = center[l][k] + half[l][k] - m;
                }
                2 => tri[2] = tri[1],
                _ => {}
            }
            let n = 1 + (rng.next_u64() % 4) as usize;
            let slab = (case % 5 < 2).then_some((case % 3) as usize);
            let bits = tri_boxes_overlap(&center, &half, n, tri, slab);
            for l in 0..4 {
                let want = l < n
                    && match slab {
                        Some(k) => tri_box_overlap_in_slab(center[l], half[l], tri, k),
                        None => tri_box_overlap(center[l], half[l], tri),
                    };
                assert_eq!(
                    bits >> l & 1 == 1,
                    want,
                    "seed {seed} case {case}: box {l} of {n}, slab {slab:?}, center {center:?} \
                     half {half:?} tri {tri:?}"
                );
                yes += want as u32;
                total += (l < n) as u32;
            }
        }
        both_answers_often(seed, yes, total, "overlap");
    }

    /// A random-case comparison proves little unless both answers came up often: at least
    /// 20,000 of each among `total` cases (`yes` of them answered yes).
    fn both_answers_often(seed: u64, yes: u32, total: u32, what: &str) {
        assert!(
            yes > 20_000 && total - yes > 20_000,
            "seed {seed}: {yes} of {total} {what}"
        );
    }

    #[test]
    fn hand_cases() {
        let c = DVec3::ZERO;
        let h = DVec3::ONE;
        // Fully inside.
        assert!(tri_box_overlap(
            c,
            h,
            [v(0.1, 0.1, 0.1), v(0.5, 0.1, 0.2), v(0.1, 0.4, -0.3)]
        ));
        // Large triangle whose plane passes through a small box's centre; no vertex near it.
        assert!(tri_box_overlap(
            c,
            DVec3::splat(0.01),
            [
                v(-100.0, -100.0, 1.0),
                v(100.0, -100.0, 1.0),
                v(0.0, 100.0, -1.0)
            ]
        ));
        // Same triangle shifted so its plane passes beside the small box.
        assert!(!tri_box_overlap(
            c,
            DVec3::splat(0.01),
            [
                v(-100.0, -100.0, 1.5),
                v(100.0, -100.0, 1.5),
                v(0.0, 100.0, -0.5)
            ]
        ));
        // Touching only a face: the triangle lies in the plane x = 1.
        assert!(tri_box_overlap(
            c,
            h,
            [v(1.0, -0.5, -0.5), v(1.0, 0.5, -0.5), v(1.0, 0.0, 0.5)]
        ));
        // Touching a face with a single vertex.
        assert!(tri_box_overlap(
            c,
            h,
            [v(1.0, 0.0, 0.0), v(3.0, 0.5, 0.0), v(3.0, -0.5, 0.2)]
        ));
        // Just beyond that face.
        assert!(!tri_box_overlap(
            c,
            h,
            [
                v(1.0 + 1e-12, 0.0, 0.0),
                v(3.0, 0.5, 0.0),
                v(3.0, -0.5, 0.2)
            ]
        ));
        // Far away.
        assert!(!tri_box_overlap(
            c,
            h,
            [
                v(10.0, 10.0, 10.0),
                v(11.0, 10.0, 10.0),
                v(10.0, 11.0, 10.0)
            ]
        ));
        // Bounding boxes overlap but the triangle passes diagonally beside the box corner:
        // only an edge x axis cross product separates this one.
        let diag = [v(3.0, -0.5, 0.0), v(-0.5, 3.0, 0.0), v(3.0, 3.0, 0.0)];
        assert!(!tri_box_overlap(c, h, diag));
        // The same triangle moved to just cut the corner.
        let cut = [v(1.5, 0.4, 0.0), v(0.4, 1.5, 0.0), v(3.0, 3.0, 0.0)];
        assert!(tri_box_overlap(c, h, cut));
        // Axis-parallel triangle (in the plane z = 0.5) crossing the box.
        assert!(tri_box_overlap(
            c,
            h,
            [v(-5.0, -5.0, 0.5), v(5.0, -5.0, 0.5), v(0.0, 5.0, 0.5)]
        ));
        // Axis-parallel triangle above the box.
        assert!(!tri_box_overlap(
            c,
            h,
            [v(-5.0, -5.0, 1.5), v(5.0, -5.0, 1.5), v(0.0, 5.0, 1.5)]
        ));
        // Box entirely inside an axis-parallel triangle's footprint, zero-thickness box.
        assert!(tri_box_overlap(
            v(0.0, 0.0, 0.5),
            v(0.1, 0.1, 0.0),
            [v(-5.0, -5.0, 0.5), v(5.0, -5.0, 0.5), v(0.0, 5.0, 0.5)]
        ));
        // Degenerate: a segment through the box, and one beside it diagonally.
        let a = v(-3.0, -3.0, 0.0);
        let b = v(3.0, 3.0, 0.0);
        assert!(tri_box_overlap(c, h, [a, b, b]));
        let a2 = v(0.5, 3.0, 0.0);
        let b2 = v(3.0, 0.5, 0.0);
        assert!(!tri_box_overlap(c, h, [a2, b2, (a2 + b2) * 0.5]));
        // Degenerate: a point inside, a point outside.
        let p = v(0.2, 0.3, 0.4);
        assert!(tri_box_overlap(c, h, [p, p, p]));
        let q = v(0.2, 1.3, 0.4);
        assert!(!tri_box_overlap(c, h, [q, q, q]));
    }
}
