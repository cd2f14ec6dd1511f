//! Output names for work split over tasks and frames: `{tile}` in a `-o` path is replaced
//! by the part's tile index, and the frame number goes where the file name has a run of `#`
//! (padded to the run's length: `frame_####.png`) or `{frame}` (padded to
//! [`FRAME_DIGITS`]), so that every task of a job array writes its own files from one
//! command line (`-o parts/f####-{tile}.exr`).

use std::path::{Path, PathBuf};

/// Digits `{frame}` pads a frame number to (frame 7 is `0007`), so that files sort in
/// frame order for the tools that read image sequences.
pub const FRAME_DIGITS: usize = 4;

/// An output path with an optional `{tile}` placeholder and an optional frame number
/// placeholder: `{frame}`, or the one run of `#` in the file name.
#[derive(Clone, Debug)]
pub struct OutputTemplate {
    raw: String,
}

impl OutputTemplate {
    /// Wraps a `-o` path; a usage error when its file name has more than one run of `#`
    /// and no `{frame}` (which run would be the frame number is a guess: `f##_##.png`
    /// once numbered only the last).
    pub fn new(path: &Path) -> crate::error::Result<Self> {
        let t = OutputTemplate {
            raw: path.to_string_lossy().into_owned(),
        };
        let name = &t.raw[t.raw.rfind('/').map_or(0, |i| i + 1)..];
        let runs = name
            .split(|c| c != '#')
            .filter(|run| !run.is_empty())
            .count();
        if runs > 1 && !t.raw.contains("{frame}") {
            return Err(crate::error::Error::Usage(format!(
                "-o {}: the file name has {runs} runs of #; the frame number goes in one run (frame_####.png) or in {{frame}}",
                path.display()
            )));
        }
        Ok(t)
    }

    /// True when the name has `{tile}`.
    pub fn has_tile(&self) -> bool {
        self.raw.contains("{tile}")
    }

    /// Where the frame's run of `#` is in the file name.
    fn frame_run(&self) -> Option<(usize, usize)> {
        let name_start = self.raw.rfind('/').map_or(0, |i| i + 1);
        let end = self.raw[name_start..].rfind('#')? + name_start + 1;
        let start = self.raw[..end].trim_end_matches('#').len();
        Some((start, end))
    }

    /// True when the name has a place for the frame number (`{frame}` or a run of `#`).
    pub fn has_frame(&self) -> bool {
        self.raw.contains("{frame}") || self.frame_run().is_some()
    }

    /// The path for `frame` and tile `(index, count)`: `{frame}` replaced by the frame
    /// number padded to [`FRAME_DIGITS`], else the run of `#` by it padded to the run's
    /// length (longer numbers are written whole); `{tile}` by the index padded to the
    /// digits of `count - 1`. A placeholder without a value is left as it is.
    pub fn path(&self, frame: Option<u32>, tile: Option<(u32, u32)>) -> PathBuf {
        let mut s = self.raw.clone();
        if let Some(f) = frame {
            if s.contains("{frame}") {
                s = s.replace("{frame}", &format!("{f:0FRAME_DIGITS$}"));
            } else if let Some((a, b)) = self.frame_run() {
                let digits = b - a;
                s.replace_range(a..b, &format!("{f:0digits$}"));
            }
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
    fn two_runs_of_hashes_are_refused_unless_frame_is_named() {
        let e = OutputTemplate::new(Path::new("out/f##_##.png")).unwrap_err();
        assert!(e.to_string().contains("2 runs of #"), "{e}");
        // A # in a folder's name is no run of the file name; {frame} names the place.
        let t = OutputTemplate::new(Path::new("a#b/f##.png")).unwrap();
        assert_eq!(t.path(Some(3), None), PathBuf::from("a#b/f03.png"));
        let t = OutputTemplate::new(Path::new("f#_{frame}.png")).unwrap();
        assert_eq!(t.path(Some(3), None), PathBuf::from("f#_0003.png"));
    }

    #[test]
    fn placeholders() {
        let t = OutputTemplate::new(Path::new("o#t/f####-t{tile}.exr")).unwrap();
        assert!(t.has_tile() && t.has_frame());
        assert_eq!(
            t.path(Some(7), Some((3, 16))),
            PathBuf::from("o#t/f0007-t03.exr")
        );
        assert_eq!(
            t.path(Some(12345), Some((0, 1))),
            PathBuf::from("o#t/f12345-t0.exr")
        );
        assert_eq!(
            t.path(None, Some((9, 10))),
            PathBuf::from("o#t/f####-t9.exr")
        );
        assert!(OutputTemplate::new(Path::new("a##b#.png")).is_err());
        assert!(!OutputTemplate::new(Path::new("dir#/x.png"))
            .unwrap()
            .has_frame());
        let braces = OutputTemplate::new(Path::new("f{frame}-{tile}.exr")).unwrap();
        assert!(braces.has_frame());
        assert_eq!(
            braces.path(Some(3), Some((1, 4))),
            PathBuf::from("f0003-1.exr")
        );
        let plain = OutputTemplate::new(Path::new("a.png")).unwrap();
        assert!(!plain.has_tile() && !plain.has_frame());
        assert_eq!(plain.path(Some(1), Some((1, 2))), PathBuf::from("a.png"));
    }
}
