//! Image comparison: the error figures every speed option is judged by (RMSE, PSNR, max
//! absolute error, share of pixels above a threshold) and a difference image.

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
}

impl std::fmt::Display for Comparison {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let psnr = match self.psnr {
            Some(p) => format!("{p:.2} dB"),
            None => "identical".into(),
        };
        write!(
            f,
            "RMSE {:.6}  PSNR {}  max abs {:.6}  pixels > {}: {:.4}%  ({} pixels)",
            self.rmse,
            psnr,
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
            let d = (c(pa[k]) - c(pb[k])).abs();
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
            Some(-20.0 * rmse.log10())
        } else {
            None
        },
        max_abs,
        share_above: above as f64 / pixels.max(1) as f64,
        threshold,
        pixels,
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
        // Clamping hides out-of-range differences, as a PNG would.
        let hi = Image::from_rgb(1, 1, vec![2.0, 2.0, 2.0]);
        let one = Image::from_rgb(1, 1, vec![1.0, 1.0, 1.0]);
        assert_eq!(compare(&hi, &one, 0.1, true).unwrap().rmse, 0.0);
        assert_eq!(compare(&hi, &one, 0.1, false).unwrap().rmse, 1.0);
    }
}
