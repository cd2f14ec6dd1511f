//! AOV output: per-pixel data of the primary ray for inspection and compositing, written as
//! a multi-channel OpenEXR file, plus a PNG preview of each requested AOV that an image
//! viewer can show: depth as grey (near bright), normals as colour (`n/2 + 1/2`), primitive
//! ids in false colour (a stable hash colour per id) with misses black, and `steps` as a
//! heat map with a colour bar (the classic picture of where a uniform grid costs time).

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

/// Path of the PNG preview of `kind` next to `output`: `<stem>.<kind>.png` (`depth`,
/// `normal`, `primid`, `steps`).
pub fn preview_path(output: &Path, kind: AovKind) -> PathBuf {
    let stem = output
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "render".into());
    let name = kind
        .to_possible_value()
        .map(|v| v.get_name().to_owned())
        .unwrap_or_default();
    output.with_file_name(format!("{stem}.{name}.png"))
}

/// Writes the requested AOVs next to `output`: the EXR with every channel, then one PNG
/// preview per kind ([`preview_path`]); returns the files written.
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
    for &k in kinds {
        let (path, img) = match k {
            AovKind::Steps => {
                let steps: Vec<f32> = px.iter().map(|p| p.steps).collect();
                (png_path.clone(), heat_map(aov.width, aov.height, &steps))
            }
            _ => (preview_path(output, k), preview(aov, k)),
        };
        write_image(&path, &img)?;
        written.push(path);
    }
    Ok(written)
}

/// A viewable picture of one AOV (not `steps`, which is [`heat_map`]), misses black:
/// - depth: grey from 1 at the nearest hit to 0.1 at the farthest (so the farthest hit
///   still differs from a miss);
/// - normal: `n/2 + 1/2` as RGB, the usual normal-map colours;
/// - primid: [`id_colour`] of the triangle index.
///
/// Values are display values: they are stored so that the PNG holds them as they are.
pub fn preview(aov: &Aov, kind: AovKind) -> Image {
    let px = &aov.pixels;
    let finite = px.iter().map(|p| p.depth).filter(|d| d.is_finite());
    let (near, far) = finite.fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), d| {
        (a.min(d), b.max(d))
    });
    let span = (far - near).max(f32::MIN_POSITIVE);
    let data = px
        .iter()
        .flat_map(|p| {
            let hit = p.depth.is_finite() && p.primid >= 0.0;
            let display = match kind {
                _ if !hit => [0.0; 3],
                AovKind::Depth => [1.0 - 0.9 * ((p.depth - near) / span).clamp(0.0, 1.0); 3],
                AovKind::Normal => p.normal.map(|c| (c * 0.5 + 0.5).clamp(0.0, 1.0)),
                AovKind::PrimId => id_colour(p.primid as u32),
                AovKind::Steps => [0.0; 3],
            };
            // write_image encodes linear values as sRGB; undo that so the file shows these.
            display.map(crate::image_io::srgb_to_linear)
        })
        .collect();
    Image::from_rgb(aov.width, aov.height, data)
}

/// A stable, well-spread display colour for a primitive id (the same id is the same
/// colour in every render), never black or near-black so misses stay distinguishable.
pub fn id_colour(id: u32) -> [f32; 3] {
    // splitmix64's finaliser: neighbouring ids get unrelated colours.
    let mut z = (id as u64).wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    [0, 1, 2].map(|c| 0.25 + 0.75 * ((z >> (c * 16)) & 0xFFFF) as f32 / 65535.0)
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
    fn previews_show_hits_and_black_misses() {
        let hit = |depth: f32, primid: f32, normal: [f32; 3]| AovPixel {
            depth,
            primid,
            normal,
            steps: 1.0,
        };
        let px = vec![
            hit(1.0, 0.0, [0.0, 0.0, 1.0]),
            hit(3.0, 1.0, [1.0, 0.0, 0.0]),
            AovPixel::miss(1.0),
        ];
        let aov = Aov::from_pixels(3, 1, &px);
        let depth = preview(&aov, AovKind::Depth);
        let grey = |i: u32| crate::image_io::linear_to_srgb(depth.pixel(i, 0)[0]);
        assert!((grey(0) - 1.0).abs() < 1e-5 && (grey(1) - 0.1).abs() < 1e-5);
        assert_eq!(depth.pixel(2, 0), [0.0; 3]);
        let normal = preview(&aov, AovKind::Normal);
        let n = normal.pixel(0, 0).map(crate::image_io::linear_to_srgb);
        assert!(
            (n[0] - 0.5).abs() < 1e-5 && (n[2] - 1.0).abs() < 1e-5,
            "{n:?}"
        );
        assert_eq!(normal.pixel(2, 0), [0.0; 3]);
        let ids = preview(&aov, AovKind::PrimId);
        assert_ne!(ids.pixel(0, 0), ids.pixel(1, 0));
        assert_eq!(ids.pixel(2, 0), [0.0; 3]);
        // Stable and never dark.
        assert_eq!(id_colour(12345), id_colour(12345));
        assert!((0..1000).all(|i| id_colour(i).iter().all(|&c| c >= 0.25)));
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
        assert_eq!(files.len(), 5);
        for (f, name) in files[1..]
            .iter()
            .zip(["depth", "normal", "primid", "steps"])
        {
            assert_eq!(f, &dir.join(format!("r.{name}.png")));
        }
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
