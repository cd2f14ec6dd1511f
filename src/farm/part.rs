//! Part files: one region of an image as OpenEXR, in the format's own terms for "this part
//! of that image" — a data window (the region) inside a display window (the full image) —
//! with a header that says what the part is of: the scene, the render options, a hash of
//! both, and for information the device and the tile.
//!
//! Custom attributes (all text, in the single layer's header):
//!
//! | attribute             | value                                                      |
//! |-----------------------|------------------------------------------------------------|
//! | `fragtrace.scene`     | where the scene came from (path or `<builtin>`)            |
//! | `fragtrace.sceneHash` | hash of the loaded scene's content (16 hex digits)         |
//! | `fragtrace.options`   | the options that decide the pixels, as canonical flags    |
//! | `fragtrace.hash`      | hash of the scene hash, the options and the frame          |
//! | `fragtrace.frame`     | the animation frame (absent for a still)                   |
//! | `fragtrace.device`    | the device that rendered it (information only)             |
//! | `fragtrace.tile`      | `I/N` when made with `--tile` (information only)           |
//! | `fragtrace.version`   | the build that wrote it, version+commit (`merge` compares) |
//! | `fragtrace.frames`    | the frames of the job the part belongs to (`merge` checks  |
//! |                       | each has its parts), as `--frames` writes them             |
//! | `fragtrace.task`, `.host`, `.renderMs`, `.taskMs` | task `t/T`, node, the part's   |
//! |                       | render time and the task's time so far (information only:  |
//! |                       | `merge --summary`)                                         |
//!
//! Pixels are linear RGB f32 (channels `R`, `G`, `B`), stored losslessly (ZIP), so a
//! merged image has the rendered bits.

use std::path::Path;

use exr::meta::attribute::{AttributeValue, IntegerBounds, Text};
use exr::prelude::*;

use crate::image_io::{write_atomic, Image};
use crate::region::Region;
use crate::{Error, Result};

/// What a part is a part of, and where it sits in it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PartHeader {
    /// Scene source (path or `<builtin>`), as the rendering task named it.
    pub scene: String,
    /// [`super::hash::scene_hash`] of the loaded scene.
    pub scene_hash: u64,
    /// The pixel-deciding options as canonical flags ([`super::options_line`]).
    pub options: String,
    /// The animation frame, for a part of an animation.
    pub frame: Option<u32>,
    /// Full image width (the display window).
    pub width: u32,
    /// Full image height (the display window).
    pub height: u32,
    /// The pixels this part holds (the data window).
    pub region: Region,
    /// The device that rendered it (not checked by `merge`).
    pub device: String,
    /// `I/N` of the tile, when the image was tiled: `merge` names a missing tile by it,
    /// and refuses parts of two tilings.
    pub tile: Option<String>,
    /// The frames of the whole job, for a part of an animation ([`frames_text`]): `merge`
    /// refuses a set of parts with a frame of them missing.
    pub frames: Option<String>,
    /// The build that wrote it ([`VERSION`]: `merge` refuses parts of two builds).
    pub version: String,
    /// Where it came from, for `merge --summary` only (not checked, not hashed).
    pub provenance: Provenance,
}

/// Who rendered a part and how long it took: what `merge --summary` reports per task.
/// Information only: `merge` checks none of it and the hash does not cover it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Provenance {
    /// `t/T`: task t of a job of T tasks, for a part rendered with `--task-index`.
    pub task: Option<String>,
    /// The node's name (`SLURMD_NODENAME`, else the kernel's host name).
    pub host: Option<String>,
    /// Wall time of this part's render, milliseconds.
    pub render_ms: Option<u64>,
    /// Wall time of the task's process from its start to this part's write, milliseconds:
    /// the task's time so far, scene load and structure build included.
    pub task_ms: Option<u64>,
}

/// The build parts written by this binary carry: the crate version and the commit of the
/// code (`0.1.0+3f9c2d1e4b5a`, `-dirty` when built from changed code, `+unknown` without
/// git; `build.rs`), so that `merge` refuses parts of two builds of one version.
pub const VERSION: &str = env!("FRAGTRACE_BUILD");

/// Frames as `--frames` takes them, short: runs of three or more frames a constant step
/// apart as `A..B` or `A..B:S`, the rest one by one (`0..10:2,13,17`).
pub fn frames_text(frames: &[u32]) -> String {
    let mut items = Vec::new();
    let mut i = 0;
    while i < frames.len() {
        let a = frames[i];
        let mut j = i + 1;
        if let Some(&b) = frames.get(i + 1).filter(|&&b| b > a) {
            let step = b - a;
            while j + 1 < frames.len() + 1 && frames.get(j) == Some(&(frames[j - 1] + step)) {
                j += 1;
            }
            if j - i >= 3 {
                let last = frames[j - 1];
                items.push(if step == 1 {
                    format!("{a}..{last}")
                } else {
                    format!("{a}..{last}:{step}")
                });
                i = j;
                continue;
            }
            j = i + 1;
        }
        items.push(a.to_string());
        i = j;
    }
    items.join(",")
}

impl PartHeader {
    /// The hash `merge` compares: scene content, options and frame.
    pub fn hash(&self) -> u64 {
        let mut h = super::hash::Fnv64::new();
        h.write(&self.scene_hash.to_le_bytes());
        h.write(self.options.as_bytes());
        h.write(&self.frame.map_or(-1, |f| f as i64).to_le_bytes());
        h.finish()
    }
}

/// A part: its header and the region's pixels (an image of the region's size).
#[derive(Clone, Debug)]
pub struct Part {
    /// What it is a part of.
    pub header: PartHeader,
    /// The region's pixels, linear RGB.
    pub image: Image,
}

const ATTR_SCENE: &str = "fragtrace.scene";
const ATTR_SCENE_HASH: &str = "fragtrace.sceneHash";
const ATTR_OPTIONS: &str = "fragtrace.options";
const ATTR_HASH: &str = "fragtrace.hash";
const ATTR_FRAME: &str = "fragtrace.frame";
const ATTR_DEVICE: &str = "fragtrace.device";
const ATTR_TILE: &str = "fragtrace.tile";
const ATTR_VERSION: &str = "fragtrace.version";
const ATTR_FRAMES: &str = "fragtrace.frames";
const ATTR_TASK: &str = "fragtrace.task";
const ATTR_HOST: &str = "fragtrace.host";
const ATTR_RENDER_MS: &str = "fragtrace.renderMs";
const ATTR_TASK_MS: &str = "fragtrace.taskMs";

/// EXR text is bytes; fragtrace writes UTF-8 (a scene path may need more than Latin-1).
fn text(s: &str) -> AttributeValue {
    AttributeValue::Text(Text::from_slice_unchecked(s.as_bytes()))
}

/// Writes `part` to `path` (atomically: a temporary name, then a rename).
pub fn write_part(path: &Path, part: &Part) -> Result<()> {
    write_pixels(path, &part.header, &part.image)
}

/// Writes the pixels `image` of the region `header` names to `path` as a part, as
/// [`write_part`] does, without making them a [`Part`] (a rendered tile is written
/// where it lies: a copy would double the memory a task of a poster needs).
pub fn write_pixels(path: &Path, header: &PartHeader, image: &Image) -> Result<()> {
    let h = header;
    let r = h.region;
    if image.width != r.width() || image.height != r.height() {
        return Err(Error::Internal(format!(
            "part image {}x{} does not match its region {r}",
            image.width, image.height
        )));
    }
    let mut attrs = LayerAttributes {
        layer_position: Vec2(r.x0 as i32, r.y0 as i32),
        ..LayerAttributes::default()
    };
    let mut other = vec![
        (ATTR_SCENE, h.scene.clone()),
        (ATTR_SCENE_HASH, format!("{:016x}", h.scene_hash)),
        (ATTR_OPTIONS, h.options.clone()),
        (ATTR_HASH, format!("{:016x}", h.hash())),
        (ATTR_DEVICE, h.device.clone()),
        (ATTR_VERSION, h.version.clone()),
    ];
    if let Some(f) = &h.frames {
        other.push((ATTR_FRAMES, f.clone()));
    }
    if let Some(f) = h.frame {
        other.push((ATTR_FRAME, f.to_string()));
    }
    if let Some(t) = &h.tile {
        other.push((ATTR_TILE, t.clone()));
    }
    let p = &h.provenance;
    for (k, v) in [
        (ATTR_TASK, p.task.clone()),
        (ATTR_HOST, p.host.clone()),
        (ATTR_RENDER_MS, p.render_ms.map(|m| m.to_string())),
        (ATTR_TASK_MS, p.task_ms.map(|m| m.to_string())),
    ] {
        if let Some(v) = v {
            other.push((k, v));
        }
    }
    for (k, v) in other {
        attrs.other.insert(Text::from(k), text(&v));
    }
    let rw = r.width() as usize;
    let data = &image.data;
    let channels = SpecificChannels::rgb(|p: Vec2<usize>| {
        let k = (p.y() * rw + p.x()) * 3;
        (data[k], data[k + 1], data[k + 2])
    });
    let layer = Layer::new(
        (rw, r.height() as usize),
        attrs,
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    let image = exr::image::Image::new(
        ImageAttributes::new(IntegerBounds::from_dimensions((
            h.width as usize,
            h.height as usize,
        ))),
        layer,
    );
    write_atomic(path, |tmp| {
        image.write().to_file(tmp).map_err(|e| Error::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    })
}

/// Reads a part written by [`write_part`]; an EXR without fragtrace's header, with a data
/// window outside its display window or with a hash that does not match its contents is
/// an error naming the file.
pub fn read_part(path: &Path) -> Result<Part> {
    let bad = |message: String| Error::Usage(format!("{}: {message}", path.display()));
    read_part_inner(path).map_err(|e| match e {
        PartReadError::Exr(m) => bad(format!("not a readable OpenEXR part: {m}")),
        PartReadError::Header(m) => bad(m),
    })
}

enum PartReadError {
    Exr(String),
    Header(String),
}

fn read_part_inner(path: &Path) -> std::result::Result<Part, PartReadError> {
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgb_channels(
            |res, _| (res.width(), vec![0f32; res.width() * res.height() * 3]),
            |(w, v): &mut (usize, Vec<f32>), p: Vec2<usize>, (r, g, b): (f32, f32, f32)| {
                let k = (p.y() * *w + p.x()) * 3;
                v[k] = r;
                v[k + 1] = g;
                v[k + 2] = b;
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| PartReadError::Exr(e.to_string()))?;
    let header_err = PartReadError::Header;
    let layer = &image.layer_data;
    let get = |k: &str| -> Option<String> {
        let v = layer
            .attributes
            .other
            .get(&Text::from(k))
            .or_else(|| image.attributes.other.get(&Text::from(k)))?;
        match v {
            AttributeValue::Text(t) => Some(String::from_utf8_lossy(t.bytes()).into_owned()),
            _ => None,
        }
    };
    let need = |k: &str| {
        get(k).ok_or_else(|| {
            header_err(format!(
                "has no `{k}` attribute: not a part written by `fragtrace render --tile/--region`"
            ))
        })
    };
    let scene = need(ATTR_SCENE)?;
    let scene_hash = u64::from_str_radix(&need(ATTR_SCENE_HASH)?, 16)
        .map_err(|_| header_err(format!("`{ATTR_SCENE_HASH}` is not a hex number")))?;
    let options = need(ATTR_OPTIONS)?;
    let stored = need(ATTR_HASH)?;
    let frame = match get(ATTR_FRAME) {
        None => None,
        Some(f) => Some(
            f.parse::<u32>()
                .map_err(|_| header_err(format!("`{ATTR_FRAME}` {f} is not a frame number")))?,
        ),
    };
    let dw = image.attributes.display_window;
    let pos = layer.attributes.layer_position;
    let size = layer.size;
    if dw.position != Vec2(0, 0) || pos.x() < 0 || pos.y() < 0 {
        return Err(header_err(format!(
            "display window at {:?} or data window at {:?}: fragtrace parts start at the origin",
            dw.position, pos
        )));
    }
    let region = Region {
        x0: pos.x() as u32,
        y0: pos.y() as u32,
        x1: pos.x() as u32 + size.width() as u32,
        y1: pos.y() as u32 + size.height() as u32,
    };
    let (width, height) = (dw.size.width() as u32, dw.size.height() as u32);
    if region.x1 > width || region.y1 > height {
        return Err(header_err(format!(
            "data window {region} reaches outside the {width}x{height} display window"
        )));
    }
    let (w, data) = &layer.channel_data.pixels;
    debug_assert_eq!(*w, size.width());
    let header = PartHeader {
        scene,
        scene_hash,
        options,
        frame,
        width,
        height,
        region,
        device: get(ATTR_DEVICE).unwrap_or_default(),
        tile: get(ATTR_TILE),
        frames: get(ATTR_FRAMES),
        version: get(ATTR_VERSION).unwrap_or_default(),
        provenance: Provenance {
            task: get(ATTR_TASK),
            host: get(ATTR_HOST),
            render_ms: get(ATTR_RENDER_MS).and_then(|m| m.parse().ok()),
            task_ms: get(ATTR_TASK_MS).and_then(|m| m.parse().ok()),
        },
    };
    if format!("{:016x}", header.hash()) != stored {
        return Err(header_err(format!(
            "`{ATTR_HASH}` {stored} does not match its scene hash, options and frame \
             (the header was edited or damaged)"
        )));
    }
    Ok(Part {
        image: Image::from_rgb(region.width(), region.height(), data.clone()),
        header,
    })
}

#[cfg(test)]
mod tests {
    use super::frames_text;
    use crate::options::FrameRange;

    /// The frames' text reads back as the same frames through `--frames`' parser.
    #[test]
    fn frames_text_reads_back() {
        for frames in [
            vec![0, 1, 2, 3],
            vec![0, 2, 4, 6, 8, 10],
            vec![0, 5, 9],
            vec![7],
            vec![1, 2, 3, 7, 20, 24, 28, 29],
            vec![5, 6],
        ] {
            let t = frames_text(&frames);
            let back: FrameRange = t.parse().unwrap();
            assert_eq!(back.frames(&(0..=100)).unwrap(), frames, "{t}");
        }
        assert_eq!(frames_text(&[0, 2, 4, 6, 8, 10]), "0..10:2");
        assert_eq!(frames_text(&[0, 5, 9]), "0,5,9");
    }
}
