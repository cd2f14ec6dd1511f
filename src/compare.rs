//! Image comparison: the error figures every speed option is judged by (RMSE, PSNR, max
//! absolute error, share of pixels above a threshold, mean FLIP) and a difference image.
//!
//! FLIP (NVIDIA's perceptual difference, Andersson et al. 2020) comes from the `nv-flip`
//! crate, which wraps the reference C++ implementation. It judges what a viewer sees: both
//! images are clamped to [0, 1], encoded as 8-bit sRGB (as a PNG stores them) and compared
//! at [`FLIP_PIXELS_PER_DEGREE`].

use serde::Serialize;

use crate::image_io::Image;
use crate::{Error, Result};

/// Error of image `a` against reference `b` (linear RGB values).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Comparison {
    /// Root mean square error over all channels.
    pub rmse: f64,
    /// Peak signal-to-noise ratio in dB for a peak of 1; `None` when identical.
    pub psnr: Option<f64>,
    /// Largest absolute channel difference.
    pub max_abs: f64,
    /// Share of pixels whose largest channel difference exceeds `threshold`.
    pub share_above: f64,
    /// The threshold used for `share_above`.
    pub threshold: f64,
    /// Number of pixels compared.
    pub pixels: usize,
    /// Mean of the FLIP error map (0 = identical, 1 = as different as can be), on the
    /// clamped 8-bit sRGB images; see [`flip_mean`].
    pub flip_mean: f64,
}

/// Observer distance in pixels per degree for FLIP: FLIP's default observer, 0.7 m from a
/// 0.7 m wide monitor 3840 pixels across (`nv_flip::pixels_per_degree(0.7, 3840.0, 0.7)`
/// = 67.0206; `nv_flip::DEFAULT_PIXELS_PER_DEGREE` rounds it to 67.0).
pub const FLIP_PIXELS_PER_DEGREE: f32 = 67.020_64;

impl std::fmt::Display for Comparison {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let psnr = match self.psnr {
            Some(p) => format!("{p:.2} dB"),
            None => "identical".into(),
        };
        write!(
            f,
            "RMSE {:.6}  PSNR {}  FLIP {:.6}  max abs {:.6}  pixels > {}: {:.4}%  ({} pixels)",
            self.rmse,
            psnr,
            self.flip_mean,
            self.max_abs,
            self.threshold,
            self.share_above * 100.0,
            self.pixels
        )
    }
}

/// Compares two images of the same size. Values are clamped to [0, 1] first when
/// `clamp` is set (what a PNG shows), else compared raw (EXR).
pub fn compare(a: &Image, b: &Image, threshold: f64, clamp: bool) -> Result<Comparison> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(Error::Usage(format!(
            "images differ in size: {}x{} vs {}x{}",
            a.width, a.height, b.width, b.height
        )));
    }
    let c = |v: f32| {
        if clamp {
            v.clamp(0.0, 1.0) as f64
        } else {
            v as f64
        }
    };
    let (mut sq, mut max_abs, mut above) = (0.0f64, 0.0f64, 0usize);
    for (pa, pb) in a.data.chunks(3).zip(b.data.chunks(3)) {
        let mut px_max = 0.0f64;
        for k in 0..3 {
            let (x, y) = (c(pa[k]), c(pb[k]));
            // Equal values differ by 0 even when infinite: two misses in a depth AOV agree.
            // A miss against a hit (or a NaN) is infinitely wrong.
            let d = if x == y { 0.0 } else { (x - y).abs() };
            let d = if d.is_nan() { f64::INFINITY } else { d };
            sq += d * d;
            px_max = px_max.max(d);
        }
        max_abs = max_abs.max(px_max);
        above += (px_max > threshold) as usize;
    }
    let pixels = (a.width * a.height) as usize;
    let rmse = (sq / (pixels * 3).max(1) as f64).sqrt();
    Ok(Comparison {
        rmse,
        psnr: if rmse > 0.0 {
            Some(-20.0 * rmse.log10() + 0.0)
        } else {
            None
        },
        max_abs,
        share_above: above as f64 / pixels.max(1) as f64,
        threshold,
        pixels,
        flip_mean: flip_mean(a, b)?,
    })
}

/// Mean FLIP error of `test` against `reference` (same size): both are clamped to [0, 1],
/// converted to 8-bit sRGB and compared at [`FLIP_PIXELS_PER_DEGREE`]. 0 for identical
/// images; about 0.97 for black against white.
pub fn flip_mean(test: &Image, reference: &Image) -> Result<f64> {
    if (test.width, test.height) != (reference.width, reference.height) {
        return Err(Error::Usage(format!(
            "images differ in size: {}x{} vs {}x{}",
            test.width, test.height, reference.width, reference.height
        )));
    }
    if test.width == 0 || test.height == 0 {
        return Ok(0.0);
    }
    let to_flip = |img: &Image| {
        nv_flip::FlipImageRgb8::with_data(img.width, img.height, &crate::image_io::to_srgb8(img))
    };
    let error_map = nv_flip::flip(to_flip(reference), to_flip(test), FLIP_PIXELS_PER_DEGREE);
    // Averaged here in f64 rather than through the library's histogram pool.
    let map = error_map.to_vec();
    let mean = map.iter().map(|&v| v as f64).sum::<f64>() / map.len() as f64;
    if mean.is_finite() {
        Ok(mean)
    } else {
        Err(Error::Internal(format!("FLIP returned {mean}")))
    }
}

/// Two image files compared: the figures and the images they came from.
#[derive(Clone, Debug)]
pub struct FileComparison {
    /// The figures.
    pub comparison: Comparison,
    /// The judged image as compared (one channel as grey when a channel was named).
    pub a: Image,
    /// The reference image as compared.
    pub b: Image,
}

/// Compares image files `a` (judged) and `b` (reference): PNG values clamped to [0, 1] as
/// they show, EXR raw; with `channel`, that channel of two EXR files (an AOV such as
/// `depth`), where equal infinities (two misses) agree and a miss against a hit is an
/// infinite difference.
pub fn compare_files(
    a: &std::path::Path,
    b: &std::path::Path,
    channel: Option<&str>,
    threshold: f64,
) -> Result<FileComparison> {
    use crate::image_io::{read_exr_channel, read_image, Format};
    let (ia, ib, clamp) = match channel {
        Some(ch) => (read_exr_channel(a, ch)?, read_exr_channel(b, ch)?, false),
        None => (
            read_image(a)?,
            read_image(b)?,
            Format::from_path(a)?.is_srgb8() || Format::from_path(b)?.is_srgb8(),
        ),
    };
    Ok(FileComparison {
        comparison: compare(&ia, &ib, threshold, clamp)?,
        a: ia,
        b: ib,
    })
}

/// Absolute difference image, scaled by `gain` so small errors are visible.
pub fn diff_image(a: &Image, b: &Image, gain: f32) -> Image {
    let data = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y).abs() * gain)
        .collect();
    Image::from_rgb(a.width, a.height, data)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mean FLIP of black against white, as nv-flip 0.1.2 computes it at 67.02 pixels per
    /// degree (and as `flip_of_uniform` derives it independently).
    const BLACK_WHITE: f64 = 0.967_388;

    #[test]
    fn known_errors() {
        let a = Image::from_rgb(2, 1, vec![0.5, 0.5, 0.5, 1.0, 1.0, 1.0]);
        let mut b = a.clone();
        let same = compare(&a, &b, 0.01, false).unwrap();
        assert_eq!((same.rmse, same.psnr, same.max_abs), (0.0, None, 0.0));
        b.data[0] = 0.6;
        let c = compare(&a, &b, 0.05, false).unwrap();
        assert!((c.rmse - (0.01f64 / 6.0).sqrt()).abs() < 1e-7);
        assert!((c.max_abs - 0.1).abs() < 1e-6);
        assert_eq!(c.share_above, 0.5);
        assert!((c.psnr.unwrap() - (-20.0 * c.rmse.log10())).abs() < 1e-9);
        assert!(compare(&a, &Image::from_rgb(1, 1, vec![0.0; 3]), 0.1, false).is_err());
        assert_eq!(same.flip_mean, 0.0);
        // Clamping hides out-of-range differences, as a PNG would.
        let hi = Image::from_rgb(1, 1, vec![2.0, 2.0, 2.0]);
        let one = Image::from_rgb(1, 1, vec![1.0, 1.0, 1.0]);
        assert_eq!(compare(&hi, &one, 0.1, true).unwrap().rmse, 0.0);
        assert_eq!(compare(&hi, &one, 0.1, false).unwrap().rmse, 1.0);
    }

    /// Mean FLIP of two uniform images (8-bit sRGB colours), derived by hand from the LDR-FLIP
    /// paper (Andersson et al., HPG 2020, sections 3-4) in f64, independently of nv-flip: on a
    /// uniform image the contrast-sensitivity filters (normalised, edge-clamped) return the
    /// image, and the edge and point detectors find nothing, so the error is the colour term
    /// alone: sRGB -> linear -> XYZ (D65) -> CIELAB -> Hunt-adjusted (a, b scaled by L/100),
    /// HyAB distance raised to qc = 0.7, then mapped piecewise-linearly so that pc = 0.4 of
    /// cmax (the green-blue distance) maps to pt = 0.95 and cmax to 1.
    fn flip_of_uniform(test: [u8; 3], reference: [u8; 3]) -> f64 {
        let lab = |rgb: [f64; 3]| {
            // sRGB primaries, D65 white (IEC 61966-2-1).
            let m = [
                [0.412_456_4, 0.357_576_1, 0.180_437_5],
                [0.212_672_9, 0.715_152_2, 0.072_175_0],
                [0.019_333_9, 0.119_192_0, 0.950_304_1],
            ];
            let white = [0.950_47, 1.0, 1.088_83];
            let f = |t: f64| {
                let d = 6.0 / 29.0;
                if t > d * d * d {
                    t.cbrt()
                } else {
                    t / (3.0 * d * d) + 4.0 / 29.0
                }
            };
            let xyz: Vec<f64> = (0..3)
                .map(|i| (0..3).map(|k| m[i][k] * rgb[k]).sum::<f64>() / white[i])
                .collect();
            let l = 116.0 * f(xyz[1]) - 16.0;
            let (a, b) = (
                500.0 * (f(xyz[0]) - f(xyz[1])),
                200.0 * (f(xyz[1]) - f(xyz[2])),
            );
            [l, 0.01 * l * a, 0.01 * l * b]
        };
        let hyab =
            |p: [f64; 3], q: [f64; 3]| (p[0] - q[0]).abs() + (p[1] - q[1]).hypot(p[2] - q[2]);
        let decode = |c: [u8; 3]| {
            c.map(|v| {
                let s = v as f64 / 255.0;
                if s <= 0.040_45 {
                    s / 12.92
                } else {
                    ((s + 0.055) / 1.055).powf(2.4)
                }
            })
        };
        let (qc, pc, pt) = (0.7, 0.4, 0.95);
        let cmax = hyab(lab([0.0, 1.0, 0.0]), lab([0.0, 0.0, 1.0])).powf(qc);
        let e = hyab(lab(decode(test)), lab(decode(reference))).powf(qc);
        if e < pc * cmax {
            e * pt / (pc * cmax)
        } else {
            pt + (e - pc * cmax) / (cmax - pc * cmax) * (1.0 - pt)
        }
    }

    /// nv-flip agrees with the hand derivation above on uniform pairs that take both branches
    /// of the final mapping. Measured: differences of 3e-6 to 2.3e-5 (nv-flip works in f32
    /// with its own rounding of the colour matrices); the bound is 1e-4, while a 1-2% change
    /// of any one constant (qc, pc, pt, the Hunt factor) or the D50 white point instead of
    /// D65 moves at least one of these values by 9e-3 or more.
    #[test]
    fn flip_matches_an_independent_derivation_on_uniform_images() {
        let (w, h) = (32u32, 24u32);
        let uniform = |c: [u8; 3]| {
            let lin = c.map(|v| crate::image_io::srgb_to_linear(v as f32 / 255.0));
            Image::from_rgb(w, h, lin.repeat((w * h) as usize))
        };
        for (t, r) in [
            ([0, 0, 0], [255, 255, 255]),
            ([118, 118, 118], [255, 255, 255]),
            ([255, 0, 0], [0, 255, 0]),
            ([128, 128, 128], [133, 133, 133]),
            ([200, 120, 40], [190, 125, 60]),
        ] {
            let got = flip_mean(&uniform(t), &uniform(r)).unwrap();
            let want = flip_of_uniform(t, r);
            assert!(
                (got - want).abs() < 1e-4,
                "{t:?} vs {r:?}: nv-flip {got}, derived {want}"
            );
        }
        // Both branches were taken: a small difference maps below pt, a large one above.
        assert!(flip_of_uniform([128; 3], [133; 3]) < 0.95);
        assert!((flip_of_uniform([0; 3], [255; 3]) - BLACK_WHITE).abs() < 1e-4);
    }

    #[test]
    fn flip_known_answers() {
        assert!(
            (FLIP_PIXELS_PER_DEGREE - nv_flip::pixels_per_degree(0.7, 3840.0, 0.7)).abs() < 1e-3
        );
        let (w, h) = (32u32, 24u32);
        let n = (w * h * 3) as usize;
        let black = Image::from_rgb(w, h, vec![0.0; n]);
        let white = Image::from_rgb(w, h, vec![1.0; n]);
        let grey = Image::from_rgb(w, h, vec![0.18; n]);
        assert_eq!(flip_mean(&black, &black).unwrap(), 0.0);
        assert_eq!(flip_mean(&grey, &grey).unwrap(), 0.0);
        let bw = flip_mean(&black, &white).unwrap();
        println!("black vs white {bw}");
        assert!((bw - BLACK_WHITE).abs() < 1e-4, "{bw}");
        // Symmetric here, and between the extremes for a smaller difference.
        assert!((flip_mean(&white, &black).unwrap() - bw).abs() < 1e-4);
        let gw = flip_mean(&grey, &white).unwrap();
        println!("grey vs white {gw}");
        assert!((gw - 0.894_242).abs() < 1e-4 && gw < bw, "{gw}");
        // Values above 1 are clamped first: 2.0 looks like 1.0.
        let over = Image::from_rgb(w, h, vec![2.0; n]);
        assert_eq!(flip_mean(&over, &white).unwrap(), 0.0);
        // One white pixel in 768 black ones: its error spreads over its neighbours
        // (FLIP filters spatially), so the mean is above 1/768; compare() carries it.
        let mut dot = black.clone();
        dot.data[3 * (12 * w as usize + 16)..][..3].copy_from_slice(&[1.0, 1.0, 1.0]);
        let c = compare(&dot, &black, 0.01, false).unwrap();
        assert!((c.flip_mean - 0.018_634).abs() < 1e-4, "{}", c.flip_mean);
        assert!(flip_mean(&black, &Image::from_rgb(1, 1, vec![0.0; 3])).is_err());
    }
}
