//! AOV output: per-pixel data of the primary ray for inspection and compositing, written as
//! a multi-channel OpenEXR file, and the `steps` channel as a heat map with a colour bar
//! (the classic picture of where a uniform grid costs time).

use std::path::{Path, PathBuf};

use clap::ValueEnum;

use crate::image_io::{write_exr_channels, write_image, Image};
use crate::output::Aov;
use crate::{Error, Result};

/// One requestable AOV. Spelled on the command line as clap's [`ValueEnum`] names it; `--aov`
/// takes a comma-separated list of them ([`AovKind::parse_list`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum AovKind {
    /// Ray parameter t of the closest hit; +inf on a miss.
    Depth,
    /// Geometric normal (winding order), x y z; 0 on a miss.
    Normal,
    /// Triangle index in load order; -1 on a miss.
    #[value(name = "primid")]
    PrimId,
    /// Grid cells visited plus triangle tests.
    Steps,
}

impl AovKind {
    /// Parses a comma-separated list such as `depth,normal,primid,steps`.
    pub fn parse_list(s: &str) -> Result<Vec<AovKind>> {
        let mut v = Vec::new();
        for name in s.split(',').map(str::trim).filter(|n| !n.is_empty()) {
            let k = <AovKind as ValueEnum>::from_str(name, false).map_err(|_| {
                let known: Vec<String> = AovKind::value_variants()
                    .iter()
                    .filter_map(|k| k.to_possible_value())
                    .map(|v| v.get_name().to_owned())
                    .collect();
                Error::Usage(format!(
                    "--aov: unknown AOV `{name}` (expected {})",
                    known.join(", ")
                ))
            })?;
            if !v.contains(&k) {
                v.push(k);
            }
        }
        if v.is_empty() {
            return Err(Error::Usage("--aov: empty list".into()));
        }
        Ok(v)
    }
}

/// Paths of the AOV files written next to `output`: `<stem>.aov.exr` and
/// `<stem>.steps.png`.
pub fn aov_paths(output: &Path) -> (PathBuf, PathBuf) {
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "render".into());
    (
        output.with_file_name(format!("{stem}.aov.exr")),
        output.with_file_name(format!("{stem}.steps.png")),
    )
}

/// Writes the requested AOVs next to `output`; returns the files written.
pub fn write_aovs(output: &Path, aov: &Aov, kinds: &[AovKind]) -> Result<Vec<PathBuf>> {
    let (exr_path, png_path) = aov_paths(output);
    let px = &aov.pixels;
    let mut channels: Vec<(&str, Vec<f32>)> = Vec::new();
    for k in kinds {
        match k {
            AovKind::Depth => channels.push(("depth", px.iter().map(|p| p.depth).collect())),
            AovKind::PrimId => channels.push(("primid", px.iter().map(|p| p.primid).collect())),
            AovKind::Normal => {
                for (c, name) in ["normal.x", "normal.y", "normal.z"].into_iter().enumerate() {
                    channels.push((name, px.iter().map(|p| p.normal[c]).collect()));
                }
            }
            AovKind::Steps => channels.push(("steps", px.iter().map(|p| p.steps).collect())),
        }
    }
    let refs: Vec<(&str, &[f32])> = channels.iter().map(|(n, v)| (*n, v.as_slice())).collect();
    write_exr_channels(&exr_path, aov.width, aov.height, &refs)?;
    let mut written = vec![exr_path];
    if kinds.contains(&AovKind::Steps) {
        let steps: Vec<f32> = px.iter().map(|p| p.steps).collect();
        write_image(&png_path, &heat_map(aov.width, aov.height, &steps))?;
        written.push(png_path);
    }
    Ok(written)
}

/// A perceptually ordered colour ramp (dark blue, purple, orange, yellow), linear RGB.
fn ramp(x: f32) -> [f32; 3] {
    const STOPS: [[f32; 3]; 5] = [
        [0.001, 0.001, 0.02],
        [0.05, 0.02, 0.35],
        [0.55, 0.05, 0.35],
        [0.95, 0.35, 0.02],
        [1.0, 0.95, 0.35],
    ];
    let x = x.clamp(0.0, 1.0) * (STOPS.len() - 1) as f32;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f32;
    [0, 1, 2].map(|c| STOPS[i][c] * (1.0 - f) + STOPS[i + 1][c] * f)
}

/// 3x5 bitmaps of the digits 0-9, row by row, most significant bit left.
const DIGITS: [[u8; 5]; 10] = [
    [7, 5, 5, 5, 7],
    [2, 6, 2, 2, 7],
    [7, 1, 7, 4, 7],
    [7, 1, 7, 1, 7],
    [5, 5, 7, 1, 1],
    [7, 4, 7, 1, 7],
    [7, 4, 7, 5, 7],
    [7, 1, 1, 1, 1],
    [7, 5, 7, 5, 7],
    [7, 5, 7, 1, 7],
];

fn draw_number(img: &mut Image, x0: u32, y0: u32, value: u64, scale: u32) {
    for (k, ch) in value.to_string().bytes().enumerate() {
        let glyph = DIGITS[(ch - b'0') as usize];
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..3u32 {
                if bits & (4 >> col) == 0 {
                    continue;
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        let x = x0 + (k as u32 * 4 + col) * scale + dx;
                        let y = y0 + row as u32 * scale + dy;
                        if x < img.width && y < img.height {
                            let i = ((y * img.width + x) * 3) as usize;
                            img.data[i..i + 3].copy_from_slice(&[1.0, 1.0, 1.0]);
                        }
                    }
                }
            }
        }
    }
}

/// Heat map of `steps` (0 to the maximum) with a vertical colour bar on the right labelled
/// with the maximum at the top and 0 at the bottom.
pub fn heat_map(width: u32, height: u32, steps: &[f32]) -> Image {
    let max = steps
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0f32, f32::max)
        .max(1.0);
    let scale = (height / 120).max(1);
    let label_w = (max as u64).to_string().len() as u32 * 4 * scale + 2 * scale;
    let bar_w = (width / 24).max(6);
    let pad = 2 * scale;
    let total_w = width + pad + bar_w + pad + label_w;
    let mut img = Image::from_rgb(total_w, height, vec![0.0; (total_w * height * 3) as usize]);
    for j in 0..height {
        for i in 0..width {
            let c = ramp(steps[(j * width + i) as usize] / max);
            let k = ((j * total_w + i) * 3) as usize;
            img.data[k..k + 3].copy_from_slice(&c);
        }
        let c = ramp(1.0 - j as f32 / (height - 1).max(1) as f32);
        for i in width + pad..width + pad + bar_w {
            let k = ((j * total_w + i) * 3) as usize;
            img.data[k..k + 3].copy_from_slice(&c);
        }
    }
    let lx = width + pad + bar_w + pad;
    draw_number(&mut img, lx, 0, max as u64, scale);
    draw_number(&mut img, lx, height.saturating_sub(5 * scale), 0, scale);
    img
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::AovPixel;

    #[test]
    fn parse_list_and_errors() {
        assert_eq!(
            AovKind::parse_list("depth, steps,depth").unwrap(),
            vec![AovKind::Depth, AovKind::Steps]
        );
        assert!(AovKind::parse_list("depth,albedo")
            .unwrap_err()
            .to_string()
            .contains("albedo"));
        assert!(AovKind::parse_list("").is_err());
    }

    #[test]
    fn heat_map_ramps_and_labels() {
        let steps = [0.0, 10.0, 20.0, 40.0];
        let img = heat_map(4, 1, &steps);
        assert!(img.width > 4);
        // Monotone brightness along the ramp.
        let lum = |i: u32| img.pixel(i, 0).iter().sum::<f32>();
        assert!(lum(0) < lum(1) && lum(1) < lum(2) && lum(2) < lum(3));
        let tall = heat_map(8, 60, &[5.0; 480]);
        // The "5" label is drawn in white somewhere right of the bar.
        let white = (8..tall.width).any(|i| (0..5).any(|j| tall.pixel(i, j) == [1.0, 1.0, 1.0]));
        assert!(white);
    }

    #[test]
    fn writes_exr_channels_and_png() {
        let dir = std::env::temp_dir().join(format!("fragtrace-aov-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let px = vec![
            AovPixel {
                depth: 2.5,
                primid: 7.0,
                normal: [0.0, 1.0, 0.0],
                steps: 12.0,
            },
            AovPixel::miss(3.0),
        ];
        let aov = Aov::from_pixels(2, 1, &px);
        let files = write_aovs(
            &dir.join("r.png"),
            &aov,
            &AovKind::parse_list("depth,normal,primid,steps").unwrap(),
        )
        .unwrap();
        assert_eq!(files.len(), 2);
        let img = exr::prelude::read_all_flat_layers_from_file(&files[0]).unwrap();
        let ch = &img.layer_data[0].channel_data.list;
        let get = |name: &str| {
            ch.iter()
                .find(|c| c.name.to_string() == name)
                .map(|c| c.sample_data.values_as_f32().collect::<Vec<_>>())
                .unwrap()
        };
        assert_eq!(get("depth")[0], 2.5);
        assert_eq!(get("depth")[1], f32::INFINITY);
        assert_eq!(get("primid"), vec![7.0, -1.0]);
        assert_eq!(get("normal.y")[0], 1.0);
        assert_eq!(get("steps"), vec![12.0, 3.0]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
