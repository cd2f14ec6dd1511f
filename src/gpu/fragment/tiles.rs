//! The tiles a wave's passes are cut to: the image split into a grid of tiles, an occlusion
//! count per tile at each termination query, and the tiles that still hold active rays
//! merged into row runs, which the advancing passes then draw instead of the full-screen
//! quad (issue 49; the scissoring of GL 2.x hardware, as a list of rectangles).
//!
//! Correctness rests on one invariant of the ping-ponged ray state (`trace.rs` keeps it):
//! outside the tiles drawn, both state sets hold the same, final, state.

use crate::gpu::gl::PixelRect;

/// Tiles per side at most: a termination query then issues up to 8 x 8 = 64 occlusion
/// queries, one draw each. On llvmpipe (2 shared cores under load, 256x256, built-in
/// scene, multipass) 4, 8 and 16 per side drew 21%, 12% and 7.9% of a full quad per
/// advancing pass, and the render took 5.8-6.3, 5.3-5.9 and 7.4-9.0 s of GPU time: finer
/// tiles cut more pixels than their counts cost only down to 8.
const MAX_PER_SIDE: u32 = 8;
/// The smallest tile side in pixels: smaller tiles cut little more and cost draws.
const MIN_SIDE: u32 = 16;

/// A grid of tiles over a `width` x `height` target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct TileGrid {
    width: u32,
    height: u32,
    /// Tile side in pixels (the last column and row of tiles may be narrower).
    side: u32,
    /// Tiles across and down.
    nx: u32,
    ny: u32,
}

impl TileGrid {
    /// The grid for a `width` x `height` target.
    pub(super) fn new(width: u32, height: u32) -> Self {
        let side = width
            .max(height)
            .div_ceil(MAX_PER_SIDE)
            .max(MIN_SIDE)
            .max(1);
        TileGrid {
            width,
            height,
            side,
            nx: width.div_ceil(side),
            ny: height.div_ceil(side),
        }
    }

    /// How many tiles.
    pub(super) fn len(&self) -> usize {
        (self.nx * self.ny) as usize
    }

    /// The target's size.
    pub(super) fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Tile `k`'s pixels (tiles row by row from the bottom).
    pub(super) fn rect(&self, k: usize) -> PixelRect {
        let (i, j) = (k as u32 % self.nx, k as u32 / self.nx);
        PixelRect {
            x0: i * self.side,
            y0: j * self.side,
            x1: ((i + 1) * self.side).min(self.width),
            y1: ((j + 1) * self.side).min(self.height),
        }
    }

    /// Every tile's rectangle, tile `k` at index `k`.
    pub(super) fn rects(&self) -> Vec<PixelRect> {
        (0..self.len()).map(|k| self.rect(k)).collect()
    }

    /// The tiles where `live` is set, horizontally adjacent ones merged: fewer triangles
    /// over the same pixels.
    pub(super) fn runs(&self, live: &[bool]) -> Vec<PixelRect> {
        assert_eq!(live.len(), self.len());
        let mut out: Vec<PixelRect> = Vec::new();
        for (k, _) in live.iter().enumerate().filter(|(_, &l)| l) {
            let r = self.rect(k);
            match out.last_mut() {
                Some(last) if last.y0 == r.y0 && last.x1 == r.x0 => last.x1 = r.x1,
                _ => out.push(r),
            }
        }
        out
    }

    /// Per tile, how many of the RGBA bytes of a full-target read-back (bottom row first)
    /// have a red byte of 0: the WebGL 1 count (`count.frag` writes 0 where a ray is active).
    pub(super) fn tally_bytes(&self, bytes: &[u8]) -> Vec<u64> {
        assert_eq!(bytes.len(), self.width as usize * self.height as usize * 4);
        let mut counts = vec![0u64; self.len()];
        for (y, row) in bytes.chunks_exact(self.width as usize * 4).enumerate() {
            let j = y as u32 / self.side;
            for (x, px) in row.chunks_exact(4).enumerate() {
                if px[0] == 0 {
                    counts[(j * self.nx + x as u32 / self.side) as usize] += 1;
                }
            }
        }
        counts
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tiles cover every pixel once, for sizes that divide and that do not.
    #[test]
    fn tiles_partition_the_target() {
        for (w, h) in [
            (1, 1),
            (7, 300),
            (256, 256),
            (1000, 37),
            (1024, 1024),
            (33, 17),
        ] {
            let g = TileGrid::new(w, h);
            let mut hits = vec![0u8; (w * h) as usize];
            for r in g.rects() {
                assert!(r.x0 < r.x1 && r.y0 < r.y1, "{w}x{h}: empty tile {r:?}");
                for y in r.y0..r.y1 {
                    for x in r.x0..r.x1 {
                        hits[(y * w + x) as usize] += 1;
                    }
                }
            }
            assert!(hits.iter().all(|&n| n == 1), "{w}x{h}: not a partition");
            assert!(g.len() <= (MAX_PER_SIDE * MAX_PER_SIDE) as usize);
        }
    }

    /// Runs merge neighbours in a row and cover exactly the live tiles.
    #[test]
    fn runs_cover_the_live_tiles() {
        let g = TileGrid::new(256, 256);
        let live: Vec<bool> = (0..g.len()).map(|k| k % 3 != 0 || k == 9).collect();
        let runs = g.runs(&live);
        let area: u64 = runs.iter().map(PixelRect::area).sum();
        let want: u64 = (0..g.len())
            .filter(|&k| live[k])
            .map(|k| g.rect(k).area())
            .sum();
        assert_eq!(area, want);
        assert!(runs.len() < live.iter().filter(|&&l| l).count());
        for r in &runs {
            for (k, &l) in live.iter().enumerate() {
                let t = g.rect(k);
                let inside = t.x0 >= r.x0 && t.x1 <= r.x1 && t.y0 >= r.y0 && t.y1 <= r.y1;
                assert!(!inside || l, "run {r:?} covers dead tile {k}");
            }
        }
        assert!(g.runs(&vec![false; g.len()]).is_empty());
        assert_eq!(g.runs(&vec![true; g.len()]).len(), 8);
    }

    /// The byte tally counts each zero byte in its tile.
    #[test]
    fn byte_tally_counts_per_tile() {
        let g = TileGrid::new(40, 20);
        let mut bytes = vec![255u8; 40 * 20 * 4];
        for (x, y) in [(0, 0), (17, 3), (39, 19), (16, 16)] {
            bytes[(y * 40 + x) * 4] = 0;
        }
        let counts = g.tally_bytes(&bytes);
        // 16-pixel tiles: three across (16, 16, 8 wide), two down (16, 4 high).
        assert_eq!(counts, [1, 1, 0, 0, 1, 1]);
    }
}
