//! `render --resume` and `render --check`: whether a file a render would write already
//! exists whole. A part must read back (every chunk decompresses, the header's hash holds)
//! as a part of this scene, frame, image size and region; any other image must decode to
//! its size. A file cut short by a killed task fails either test and is rendered again.
//! The options are not compared here: `merge` refuses parts of other options.

use std::path::{Path, PathBuf};

use crate::region::Region;

/// A file a render writes, and what it must hold to count as done.
#[derive(Clone, Debug)]
pub struct Expected {
    /// The file.
    pub path: PathBuf,
    /// The animation frame, for a part of one.
    pub frame: Option<u32>,
    /// The pixels it holds.
    pub region: Region,
    /// The whole image's size.
    pub width: u32,
    /// The whole image's size.
    pub height: u32,
    /// True for an OpenEXR part (`merge`'s input); false for a finished image or a crop.
    pub part: bool,
}

/// Ok when `e` exists whole for a scene of hash `scene_hash`; otherwise why not, in a few
/// words (`missing`, `unreadable: ...`, `a part of another frame`).
pub fn done(e: &Expected, scene_hash: u64) -> std::result::Result<(), String> {
    if !e.path.is_file() {
        return Err("missing".into());
    }
    if e.part {
        let p = super::part::read_part(&e.path).map_err(|err| unreadable(&e.path, err))?;
        let h = &p.header;
        if h.scene_hash != scene_hash {
            return Err("a part of another scene".into());
        }
        if h.frame != e.frame {
            return Err(format!(
                "a part of frame {} (this one is of {})",
                h.frame.map_or("none".into(), |f| f.to_string()),
                e.frame.map_or("none".into(), |f| f.to_string())
            ));
        }
        if (h.width, h.height, h.region) != (e.width, e.height, e.region) {
            return Err(format!(
                "pixels {} of {}x{}, not {} of {}x{}",
                h.region, h.width, h.height, e.region, e.width, e.height
            ));
        }
        return Ok(());
    }
    let img = image::open(&e.path)
        .map_err(|err| format!("unreadable: {}", one_line(&err.to_string())))?;
    let (w, h) = (e.region.width(), e.region.height());
    if (img.width(), img.height()) != (w, h) {
        return Err(format!("{}x{}, not {w}x{h}", img.width(), img.height()));
    }
    Ok(())
}

fn unreadable(path: &Path, err: crate::Error) -> String {
    let msg = err.to_string();
    let msg = msg
        .strip_prefix(&format!("{}: ", path.display()))
        .unwrap_or(&msg)
        .to_string();
    format!("unreadable: {}", one_line(&msg))
}

/// A possibly multi-line message (a decoder's) as one line.
fn one_line(msg: &str) -> String {
    msg.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join(": ")
}
