//! Parts of an image: a [`Region`] (a rectangle of pixels of the full image) and a
//! [`Tiling`] (the image cut into a grid of N parts, `--tile I/N`). Every backend renders a
//! region by computing exactly the pixels it covers, with the primary rays of the full
//! image (the camera and the sample positions of a pixel do not depend on the region), so
//! a pixel of a part is bit-identical to the same pixel of the whole render.
//!
//! Coordinates are pixels with the origin at the top left (row 0 is the top row, as in
//! [`crate::image_io::Image`]); `x1` and `y1` are exclusive, as in OpenEXR data windows
//! one past their maximum.
//!
//! This sits at the bottom of the layers: the CPU and GPU renderers, the options and the
//! part files all use it.

use std::fmt;

use crate::{Error, Result};

/// Columns `x0..x1` and rows `y0..y1` of an image (exclusive ends, top row 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Region {
    /// First column.
    pub x0: u32,
    /// First row (0 is the top).
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Region {
    /// The whole of a `width` x `height` image.
    pub fn full(width: u32, height: u32) -> Region {
        Region {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    /// Columns covered.
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    /// Rows covered.
    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }

    /// Pixels covered.
    pub fn area(&self) -> u64 {
        self.width() as u64 * self.height() as u64
    }

    /// True when this is the whole `width` x `height` image.
    pub fn is_full(&self, width: u32, height: u32) -> bool {
        *self == Region::full(width, height)
    }

    /// The pixels both regions cover, if any.
    pub fn intersect(&self, other: &Region) -> Option<Region> {
        let r = Region {
            x0: self.x0.max(other.x0),
            y0: self.y0.max(other.y0),
            x1: self.x1.min(other.x1),
            y1: self.y1.min(other.y1),
        };
        (r.x0 < r.x1 && r.y0 < r.y1).then_some(r)
    }

    /// Fails unless the region is non-empty and lies inside a `width` x `height` image;
    /// `what` names the flag in the message.
    pub fn check_inside(&self, width: u32, height: u32, what: &str) -> Result<()> {
        if self.x0 >= self.x1 || self.y0 >= self.y1 {
            return Err(Error::Usage(format!(
                "{what} {self} is empty: x0 < x1 and y0 < y1 are needed (x1 and y1 are exclusive)"
            )));
        }
        if self.x1 > width || self.y1 > height {
            return Err(Error::Usage(format!(
                "{what} {self} reaches outside the {width}x{height} image (x1 <= {width}, y1 <= {height})"
            )));
        }
        Ok(())
    }
}

impl fmt::Display for Region {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{},{},{},{}", self.x0, self.y0, self.x1, self.y1)
    }
}

impl std::str::FromStr for Region {
    type Err = String;

    /// `x0,y0,x1,y1` in pixels, top-left origin, exclusive ends.
    fn from_str(s: &str) -> std::result::Result<Region, String> {
        let v: Vec<&str> = s.split(',').map(str::trim).collect();
        let bad = || {
            format!("`{s}` is not x0,y0,x1,y1 (four whole numbers: pixels, top-left origin, x1 and y1 exclusive)")
        };
        if v.len() != 4 {
            return Err(bad());
        }
        let n: Vec<u32> = v
            .iter()
            .map(|p| p.parse::<u32>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| bad())?;
        Ok(Region {
            x0: n[0],
            y0: n[1],
            x1: n[2],
            y1: n[3],
        })
    }
}

/// How an image is cut into parts: a number of parts whose grid is chosen for the image,
/// or an explicit grid of columns x rows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tiling {
    /// N parts; [`Tiling::grid`] picks the columns and rows.
    Count(u32),
    /// Columns x rows.
    Grid(u32, u32),
}

/// Most parts one image may be cut into (a part per pixel row of the largest image).
pub const MAX_TILES: u32 = 1 << 16;

impl Tiling {
    /// Number of parts.
    pub fn count(&self) -> u32 {
        match *self {
            Tiling::Count(n) => n,
            Tiling::Grid(c, r) => c * r,
        }
    }

    /// Columns and rows for a `width` x `height` image: an explicit grid as given; for a
    /// count N, the factorisation c x r = N whose parts are closest to square (the least
    /// cut edge per pixel; a prime N gives bands), fewer columns on a tie so that parts
    /// stay rows of whole scanlines as long as that is as good. Fails when a part would be
    /// empty.
    pub fn grid(&self, width: u32, height: u32) -> Result<(u32, u32)> {
        let (c, r) = match *self {
            Tiling::Grid(c, r) => (c, r),
            Tiling::Count(n) => {
                let mut best: Option<(f64, u32)> = None;
                for c in (1..=n).filter(|c| n % c == 0) {
                    let r = n / c;
                    if c > width || r > height {
                        continue;
                    }
                    let aspect = (width as f64 / c as f64) / (height as f64 / r as f64);
                    let cost = aspect.ln().abs();
                    if best.is_none_or(|(b, _)| cost < b - 1e-12) {
                        best = Some((cost, c));
                    }
                }
                match best {
                    Some((_, c)) => (c, n / c),
                    None => (n, 1), // refused below with the sizes
                }
            }
        };
        if c > width || r > height {
            return Err(Error::Usage(format!(
                "a {width}x{height} image cannot be cut into {c}x{r} parts (a part would have no pixels)"
            )));
        }
        Ok((c, r))
    }

    /// Part `index` (row-major from the top left) of a `width` x `height` image. Column
    /// and row boundaries are `floor(k * side / n)`, so parts differ by at most one pixel
    /// per side and together cover every pixel exactly once.
    pub fn tile(&self, index: u32, width: u32, height: u32) -> Result<Region> {
        let n = self.count();
        if index >= n {
            return Err(Error::Usage(format!(
                "--tile {index}/{self}: the index must be below {n} (parts are numbered 0..{n})"
            )));
        }
        let (c, r) = self.grid(width, height)?;
        let cut = |k: u32, side: u32, parts: u32| (k as u64 * side as u64 / parts as u64) as u32;
        let (i, j) = (index % c, index / c);
        Ok(Region {
            x0: cut(i, width, c),
            x1: cut(i + 1, width, c),
            y0: cut(j, height, r),
            y1: cut(j + 1, height, r),
        })
    }
}

impl fmt::Display for Tiling {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Tiling::Count(n) => write!(f, "{n}"),
            Tiling::Grid(c, r) => write!(f, "{c}x{r}"),
        }
    }
}

impl std::str::FromStr for Tiling {
    type Err = String;

    /// `N` (a count) or `CxR` (columns x rows), 1..=[`MAX_TILES`] parts.
    fn from_str(s: &str) -> std::result::Result<Tiling, String> {
        let whole = |p: &str| p.trim().parse::<u32>().ok().filter(|&v| v >= 1);
        let t = match s.split_once(['x', 'X']) {
            Some((c, r)) => whole(c).zip(whole(r)).map(|(c, r)| Tiling::Grid(c, r)),
            None => whole(s).map(Tiling::Count),
        }
        .ok_or_else(|| format!("`{s}` is not a part count N or a grid CxR (whole numbers >= 1)"))?;
        let parts = match t {
            Tiling::Count(n) => n as u64,
            Tiling::Grid(c, r) => c as u64 * r as u64,
        };
        if parts > MAX_TILES as u64 {
            return Err(format!("`{s}`: at most {MAX_TILES} parts"));
        }
        Ok(t)
    }
}

/// `--tile I/N` or `--tile I/CxR`: part I of the image cut into N parts (or a grid).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileSpec {
    /// Which part, 0-based, row-major from the top left.
    pub index: u32,
    /// How the image is cut.
    pub tiling: Tiling,
}

impl TileSpec {
    /// The region this part covers in a `width` x `height` image.
    pub fn region(&self, width: u32, height: u32) -> Result<Region> {
        self.tiling.tile(self.index, width, height)
    }
}

impl fmt::Display for TileSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.tiling)
    }
}

impl std::str::FromStr for TileSpec {
    type Err = String;

    /// `I/N` or `I/CxR`, I in 0..N.
    fn from_str(s: &str) -> std::result::Result<TileSpec, String> {
        let (i, t) = s
            .split_once('/')
            .ok_or_else(|| format!("`{s}` is not I/N or I/CxR (part I of N, 0-based)"))?;
        let tiling: Tiling = t.parse()?;
        let index = i
            .trim()
            .parse::<u32>()
            .map_err(|_| format!("`{s}`: the part index `{i}` is not a whole number"))?;
        if index >= tiling.count() {
            return Err(format!(
                "`{s}`: the part index must be below {} (parts are numbered from 0)",
                tiling.count()
            ));
        }
        Ok(TileSpec { index, tiling })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pixel of the image in exactly one part, for many sizes and counts.
    #[test]
    fn tiles_cover_every_pixel_once() {
        for (w, h) in [(1, 1), (7, 5), (64, 48), (100, 3), (3, 100), (17, 17)] {
            for n in 1..=12u32 {
                let t = Tiling::Count(n);
                let Ok((c, r)) = t.grid(w, h) else {
                    assert!(n > w.max(h) || n > w * h, "{w}x{h} n={n} refused");
                    continue;
                };
                assert_eq!(c * r, n);
                let mut seen = vec![0u8; (w * h) as usize];
                for i in 0..n {
                    let reg = t.tile(i, w, h).unwrap();
                    assert!(reg.width() >= 1 && reg.height() >= 1, "{w}x{h} {i}/{n}");
                    reg.check_inside(w, h, "tile").unwrap();
                    for y in reg.y0..reg.y1 {
                        for x in reg.x0..reg.x1 {
                            seen[(y * w + x) as usize] += 1;
                        }
                    }
                }
                assert!(seen.iter().all(|&s| s == 1), "{w}x{h} n={n}");
            }
        }
    }

    #[test]
    fn count_picks_the_squarest_grid() {
        assert_eq!(Tiling::Count(4).grid(512, 512).unwrap(), (2, 2));
        assert_eq!(Tiling::Count(4).grid(2048, 512).unwrap(), (4, 1));
        assert_eq!(Tiling::Count(4).grid(512, 2048).unwrap(), (1, 4));
        assert_eq!(Tiling::Count(6).grid(300, 200).unwrap(), (3, 2));
        // A prime count: bands of rows, not columns, on a square image (the tie rule).
        assert_eq!(Tiling::Count(7).grid(700, 700).unwrap(), (1, 7));
        // Fewer rows than parts: columns.
        assert_eq!(Tiling::Count(3).grid(30, 2).unwrap(), (3, 1));
        assert!(Tiling::Count(5).grid(2, 2).is_err());
        assert!(Tiling::Grid(3, 1).grid(2, 9).is_err());
    }

    #[test]
    fn parse_and_print() {
        let t: TileSpec = "3/2x4".parse().unwrap();
        assert_eq!(t.tiling, Tiling::Grid(2, 4));
        assert_eq!(t.to_string(), "3/2x4");
        assert_eq!(
            t.region(10, 8).unwrap(),
            Region {
                x0: 5,
                y0: 2,
                x1: 10,
                y1: 4
            }
        );
        assert!("4/4".parse::<TileSpec>().is_err());
        assert!("0/0".parse::<TileSpec>().is_err());
        assert!("1".parse::<TileSpec>().is_err());
        assert!("a/3".parse::<TileSpec>().is_err());
        assert!(format!("0/{}", MAX_TILES + 1).parse::<TileSpec>().is_err());
        let r: Region = " 1, 2,30,40".parse().unwrap();
        assert_eq!(
            r,
            Region {
                x0: 1,
                y0: 2,
                x1: 30,
                y1: 40
            }
        );
        assert_eq!(r.to_string(), "1,2,30,40");
        assert!("1,2,3".parse::<Region>().is_err());
        assert!("1,2,3,-4".parse::<Region>().is_err());
        assert!(r.check_inside(30, 40, "--region").is_ok());
        assert!(r.check_inside(29, 40, "--region").is_err());
        assert!("5,5,5,9"
            .parse::<Region>()
            .unwrap()
            .check_inside(9, 9, "--region")
            .is_err());
    }

    #[test]
    fn intersections() {
        let a = Region {
            x0: 0,
            y0: 0,
            x1: 4,
            y1: 4,
        };
        let b = Region {
            x0: 4,
            y0: 0,
            x1: 8,
            y1: 4,
        };
        assert_eq!(a.intersect(&b), None);
        let c = Region {
            x0: 3,
            y0: 3,
            x1: 8,
            y1: 8,
        };
        assert_eq!(
            a.intersect(&c),
            Some(Region {
                x0: 3,
                y0: 3,
                x1: 4,
                y1: 4
            })
        );
    }
}
