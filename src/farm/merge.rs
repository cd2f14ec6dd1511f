//! `fragtrace merge`: parts back into whole images. Every check runs before anything is
//! written — the parts must come from one scene and one set of options, and cover each
//! image exactly once — and each failure is one line naming the files and pixels
//! involved.
//!
//! Parts of several frames of an animation merge in one call when the output's file name
//! has a run of `#` for the frame number (`frame_####.png`, as `render --frames` names
//! files); each frame's parts must then cover that frame exactly once.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::part::{read_part, write_part, Part, PartHeader};
use super::template::OutputTemplate;
use crate::image_io::{write_image, Format, Image};
use crate::region::Region;
use crate::{Error, Result};

/// What a merge wrote.
#[derive(Clone, Debug)]
pub struct Merged {
    /// The files written, one per frame (one for a still).
    pub outputs: Vec<PathBuf>,
    /// Full image size.
    pub width: u32,
    /// Full image size.
    pub height: u32,
    /// Parts read.
    pub parts: usize,
    /// Parts of each output, in the order of `outputs`.
    pub parts_per_output: Vec<usize>,
    /// Devices the parts were rendered on, when more than one (a notice, not an error:
    /// the options match, so the pixels are the same computation; across GPU vendors they
    /// may differ in the last bits).
    pub devices: Vec<String>,
}

/// The first flag on which two canonical option lines differ, as `--spp 4 against --spp 1`.
fn options_difference(a: &str, b: &str) -> String {
    let split = |s: &str| -> Vec<String> {
        s.split(" --")
            .map(|f| f.trim_start_matches("--").to_string())
            .collect()
    };
    let (fa, fb) = (split(a), split(b));
    for i in 0..fa.len().max(fb.len()) {
        let (x, y) = (fa.get(i), fb.get(i));
        if x != y {
            let show = |f: Option<&String>| f.map_or("nothing".into(), |f| format!("--{f}"));
            return format!("{} against {}", show(x), show(y));
        }
    }
    "the same options".into()
}

/// Why `b` is not a part of the same render as `a`, or None.
fn mismatch(a: &PartHeader, b: &PartHeader) -> Option<String> {
    // First: two builds may hash scenes or spell options differently, and the build is
    // then the thing to fix.
    if a.version != b.version {
        return Some(format!(
            "they were written by different fragtrace builds ({} against {}): render every part with one build",
            show(&b.version),
            show(&a.version)
        ));
    }
    if a.scene_hash != b.scene_hash {
        return Some(format!(
            "the scenes differ ({} has scene hash {:016x}, this {} has {:016x})",
            a.scene, a.scene_hash, b.scene, b.scene_hash
        ));
    }
    // The plans compared as plans: what ran, read back from the same text it was written
    // as, so a part from the CPU and one from the GPU say so in one phrase.
    if let (Some(pa), Some(pb)) = (super::plan_of(&a.options), super::plan_of(&b.options)) {
        if pa != pb {
            return Some(format!("the render plans differ ({pb} against {pa})"));
        }
    }
    if a.options != b.options {
        return Some(format!(
            "the options differ ({})",
            options_difference(&b.options, &a.options)
        ));
    }
    if (a.width, a.height) != (b.width, b.height) {
        return Some(format!(
            "the image sizes differ ({}x{} against {}x{})",
            b.width, b.height, a.width, a.height
        ));
    }
    // Parts of two tilings (a re-run that cut the image differently: `sbatch --array=3`
    // rendering the whole image as tile 0 of 1) would only overlap.
    if let (Some(ta), Some(tb)) = (tiling_of(a), tiling_of(b)) {
        if ta != tb {
            return Some(format!(
                "the image is cut differently (tile {} against tile {}, of {tb} and {ta} tiles)",
                b.tile.as_deref().unwrap_or_default(),
                a.tile.as_deref().unwrap_or_default()
            ));
        }
    }
    if a.frames != b.frames {
        return Some(format!(
            "they belong to different frame ranges (--frames {} against {})",
            b.frames.as_deref().unwrap_or("none"),
            a.frames.as_deref().unwrap_or("none")
        ));
    }
    None
}

fn show(version: &str) -> &str {
    if version.is_empty() {
        "none"
    } else {
        version
    }
}

/// The tiling a part's `I/N` label names.
fn tiling_of(h: &PartHeader) -> Option<crate::region::Tiling> {
    h.tile
        .as_deref()?
        .parse::<crate::region::TileSpec>()
        .ok()
        .map(|t| t.tiling)
}

/// The tiles of the parts' tiling that no part is (`tile 3 of 4 (pixels ...)`), when every
/// part names its tile; empty otherwise.
fn missing_tiles(parts: &[(&Path, &Part)]) -> Vec<String> {
    let h = &parts[0].1.header;
    let Some(tiling) = tiling_of(h) else {
        return Vec::new();
    };
    let mut have = std::collections::BTreeSet::new();
    for (_, p) in parts {
        match p
            .header
            .tile
            .as_deref()
            .and_then(|t| t.parse::<crate::region::TileSpec>().ok())
        {
            Some(t) => have.insert(t.index),
            None => return Vec::new(),
        };
    }
    (0..tiling.count())
        .filter(|i| !have.contains(i))
        .map(|i| match tiling.tile(i, h.width, h.height) {
            Ok(r) => format!("tile {i} of {tiling} (pixels {r})"),
            Err(_) => format!("tile {i} of {tiling}"),
        })
        .collect()
}

/// Assembles one image from parts that share a header (checked by the caller); fails on
/// an overlap or a gap.
fn assemble(parts: &[(&Path, &Part)]) -> Result<Image> {
    let h = &parts[0].1.header;
    let (w, ht) = (h.width, h.height);
    let mut data = vec![0f32; w as usize * ht as usize * 3];
    let mut covered = vec![false; w as usize * ht as usize];
    for (k, (path, part)) in parts.iter().enumerate() {
        if let Some((earlier, _)) = parts[..k].iter().find(|(p, _)| p == path) {
            return Err(Error::Usage(format!(
                "merge: {} is given twice (each part once)",
                earlier.display()
            )));
        }
        let r = part.header.region;
        for y in r.y0..r.y1 {
            let row = (y as usize) * w as usize;
            let span = row + r.x0 as usize..row + r.x1 as usize;
            if covered[span.clone()].iter().any(|&c| c) {
                let (other, both) = parts[..k]
                    .iter()
                    .find_map(|(p, o)| o.header.region.intersect(&r).map(|i| (p, i)))
                    .expect("a covered pixel belongs to an earlier part");
                return Err(Error::Usage(format!(
                    "merge: {} (pixels {r}) overlaps {} in pixels {both}: each pixel must be in exactly one part",
                    path.display(),
                    other.display()
                )));
            }
            covered[span].iter_mut().for_each(|c| *c = true);
            let src = ((y - r.y0) * r.width() * 3) as usize;
            let n = r.width() as usize * 3;
            let dst = (row + r.x0 as usize) * 3;
            data[dst..dst + n].copy_from_slice(&part.image.data[src..src + n]);
        }
    }
    if let Some(first) = covered.iter().position(|&c| !c) {
        let missing = covered.iter().filter(|&&c| !c).count();
        let (x, y) = (first as u32 % w, first as u32 / w);
        // The run of missing pixels on that row, to say where the hole is.
        let row = &covered[(y * w) as usize..((y + 1) * w) as usize];
        let end = (x..w).find(|&i| row[i as usize]).unwrap_or(w);
        let tiles = missing_tiles(parts);
        let named = match tiles.len() {
            0 => String::new(),
            1..=8 => format!(": missing {}", tiles.join(", ")),
            n => format!(": missing {n} tiles, {} ...", tiles[..4].join(", ")),
        };
        return Err(Error::Usage(format!(
            "merge: gap: {missing} of the {w}x{ht} pixels are in no part, the first at row {y}, columns {x}..{end} ({} parts given{}){named}",
            parts.len(),
            frame_note(h)
        )));
    }
    Ok(Image::from_rgb(w, ht, data))
}

fn frame_note(h: &PartHeader) -> String {
    h.frame.map_or(String::new(), |f| format!(" for frame {f}"))
}

/// Reads `inputs`, checks them and writes the merged image(s) to `output` (`.png` or
/// `.exr`; a run of `#` in the file name for parts of several frames). Nothing is written unless
/// every check passes for every frame.
pub fn merge(inputs: &[PathBuf], output: &Path) -> Result<Merged> {
    if inputs.is_empty() {
        return Err(Error::Usage("merge: no parts given".into()));
    }
    let format = Format::from_path(output)?;
    let template = OutputTemplate::new(output)?;
    let mut parts = Vec::with_capacity(inputs.len());
    for path in inputs {
        parts.push((path.as_path(), read_part(path)?));
    }
    let (first_path, first) = (&parts[0].0, &parts[0].1.header);
    for (path, p) in &parts[1..] {
        if let Some(why) = mismatch(first, &p.header) {
            return Err(Error::Usage(format!(
                "merge: {} is not a part of the same render as {}: {why}",
                path.display(),
                first_path.display()
            )));
        }
    }
    let mut frames: BTreeMap<Option<u32>, Vec<(&Path, &Part)>> = BTreeMap::new();
    for (path, p) in &parts {
        frames.entry(p.header.frame).or_default().push((path, p));
    }
    if frames.len() > 1 && !template.has_frame() {
        let list: Vec<String> = frames
            .keys()
            .map(|f| f.map_or("still".into(), |f| f.to_string()))
            .collect();
        return Err(Error::Usage(format!(
            "merge: the parts are of {} frames ({}); put a run of # in the output's file name for the frame number (frame_####.png) to write one image each, or merge each frame's parts on their own",
            frames.len(),
            list.join(", ")
        )));
    }
    // Every frame of the job has its parts: a frame whose every part is missing leaves no
    // gap in the frames that are there.
    if let Some(text) = &first.frames {
        let all = text
            .parse::<crate::options::FrameRange>()
            .ok()
            .and_then(|r| r.frames(&(0..=u32::MAX)).ok())
            .ok_or_else(|| {
                Error::Usage(format!(
                    "merge: {}: `fragtrace.frames` {text} is not a frame list",
                    first_path.display()
                ))
            })?;
        let missing: Vec<u32> = all
            .iter()
            .copied()
            .filter(|f| !frames.contains_key(&Some(*f)))
            .collect();
        if !missing.is_empty() {
            let shown: Vec<String> = missing.iter().take(10).map(|f| f.to_string()).collect();
            return Err(Error::Usage(format!(
                "merge: the parts are of the frames {text}, but frame{} {}{} {} no parts ({} parts given)",
                if missing.len() > 1 { "s" } else { "" },
                shown.join(", "),
                if missing.len() > 10 { ", ..." } else { "" },
                if missing.len() > 1 { "have" } else { "has" },
                parts.len()
            )));
        }
    }
    if template.has_tile() {
        return Err(Error::Usage(format!(
            "merge: {}: {{tile}} has no meaning in a merged image's name",
            output.display()
        )));
    }
    let mut images = Vec::with_capacity(frames.len());
    for (frame, group) in &frames {
        let image = assemble(group)?;
        if !image.all_finite() {
            return Err(Error::Usage(format!(
                "merge: a part holds a NaN or infinite pixel{}",
                frame_note(&group[0].1.header)
            )));
        }
        images.push((*frame, image, group[0].1.header.clone(), group.len()));
    }
    let mut devices: Vec<String> = parts.iter().map(|(_, p)| p.header.device.clone()).collect();
    devices.sort();
    devices.dedup();
    if devices.len() == 1 {
        devices.clear();
    }
    let mut outputs = Vec::new();
    let mut parts_per_output = Vec::new();
    for (frame, image, header, n) in images {
        parts_per_output.push(n);
        let path = template.path(frame, None);
        match format {
            Format::Exr => {
                // A merged EXR is a part that covers its whole image: readable by any EXR
                // tool, and by `merge` again.
                let header = PartHeader {
                    region: Region::full(header.width, header.height),
                    tile: None,
                    provenance: Default::default(),
                    device: if devices.is_empty() {
                        header.device
                    } else {
                        devices.join(" + ")
                    },
                    ..header
                };
                write_part(&path, &Part { header, image })?
            }
            // PNG, and the other formats the output's extension can name.
            _ => write_image(&path, &image)?,
        }
        outputs.push(path);
    }
    // Every part merged is whole: what a killed task left half-written beside one is litter.
    for p in inputs {
        crate::image_io::remove_stale_partials(p);
    }
    Ok(Merged {
        outputs,
        width: first.width,
        height: first.height,
        parts: parts.len(),
        parts_per_output,
        devices,
    })
}
