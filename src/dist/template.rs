//! Output names for work split over tasks: `{tile}` and `{frame}` in a `-o` path are
//! replaced by the part's tile index and frame number, so that every task of a job array
//! writes its own files from one command line (`-o parts/part-{tile}.exr`).

use std::path::{Path, PathBuf};

/// Digits a frame number is padded to (`{frame}` of frame 7 is `0007`), so that files
/// sort in frame order for the tools that read image sequences.
pub const FRAME_DIGITS: usize = 4;

/// An output path with optional `{tile}` and `{frame}` placeholders.
#[derive(Clone, Debug)]
pub struct OutputTemplate {
    raw: String,
}

impl OutputTemplate {
    /// Wraps a `-o` path.
    pub fn new(path: &Path) -> Self {
        OutputTemplate {
            raw: path.to_string_lossy().into_owned(),
        }
    }

    /// True when the name has `{tile}`.
    pub fn has_tile(&self) -> bool {
        self.raw.contains("{tile}")
    }

    /// True when the name has `{frame}`.
    pub fn has_frame(&self) -> bool {
        self.raw.contains("{frame}")
    }

    /// The path for `frame` and tile `(index, count)`: `{frame}` padded to
    /// [`FRAME_DIGITS`], `{tile}` to the digits of `count - 1`. A placeholder without a
    /// value is left as it is.
    pub fn path(&self, frame: Option<u32>, tile: Option<(u32, u32)>) -> PathBuf {
        let mut s = self.raw.clone();
        if let Some(f) = frame {
            s = s.replace("{frame}", &format!("{f:0FRAME_DIGITS$}"));
        }
        if let Some((i, n)) = tile {
            let digits = (n.max(2) - 1).to_string().len();
            s = s.replace("{tile}", &format!("{i:0digits$}"));
        }
        PathBuf::from(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placeholders() {
        let t = OutputTemplate::new(Path::new("out/f{frame}-t{tile}.exr"));
        assert!(t.has_tile() && t.has_frame());
        assert_eq!(
            t.path(Some(7), Some((3, 16))),
            PathBuf::from("out/f0007-t03.exr")
        );
        assert_eq!(
            t.path(Some(12345), Some((0, 1))),
            PathBuf::from("out/f12345-t0.exr")
        );
        assert_eq!(
            t.path(None, Some((9, 10))),
            PathBuf::from("out/f{frame}-t9.exr")
        );
        let plain = OutputTemplate::new(Path::new("a.png"));
        assert!(!plain.has_tile() && !plain.has_frame());
        assert_eq!(plain.path(Some(1), Some((1, 2))), PathBuf::from("a.png"));
    }
}
