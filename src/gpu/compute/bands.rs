//! How the compute kernel splits an image into bands of rows, and the output buffers its
//! bands write, kept between renders of one shape.
//!
//! A band is one dispatch. Its outputs must fit one storage block ([`Limits`]); and a band
//! whose progress is drawn must end soon enough for the bar to move and for Ctrl-C to take
//! effect between two bands ([`BandPlan`]). Headless renders (no bar) dispatch the largest
//! bands the limits allow, which on the H200 is one band for a 4096x4096 image.

use std::time::Duration;

use crate::gpu::context::GlContext;
use crate::gpu::contract::compute::COUNTERS;
use crate::gpu::gl::{storage_limits, ReadbackRing, StorageBuffer};
use crate::{Error, Result};

/// The context's storage-buffer limits that shape a compute render.
pub(super) struct Limits {
    /// GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS.
    pub blocks: u32,
    /// GL_MAX_SHADER_STORAGE_BLOCK_SIZE (capped at what GL's 32-bit sizes express).
    pub block_bytes: u64,
}

impl Limits {
    /// The current context's limits (a test may narrow them).
    pub fn query(gl: &glow::Context) -> Self {
        #[cfg(test)]
        if let Some(block_bytes) = super::tests::BLOCK_BYTES.get() {
            return Limits {
                blocks: 0,
                block_bytes,
            };
        }
        let (blocks, block_bytes) = storage_limits(gl);
        Limits {
            blocks,
            block_bytes,
        }
    }

    /// Rows per band: as many as keep the AOV output (16 bytes per pixel) within one
    /// storage block. Each band's outputs are buffers of their own, bound whole, so no GL
    /// range alignment applies (bands were once 256-row multiples for that).
    pub fn band_rows(&self, width: u32, height: u32) -> Result<u32> {
        let per_row = width as u64 * 16;
        let fit = self.block_bytes / per_row;
        if fit >= height as u64 {
            return Ok(height);
        }
        if fit == 0 {
            return Err(Error::Limit(format!(
                "a {width}-pixel row needs {per_row} bytes of output; \
                 GL_MAX_SHADER_STORAGE_BLOCK_SIZE is {}",
                self.block_bytes
            )));
        }
        Ok(fit as u32)
    }
}

/// How long a band should take when its progress is drawn: the bar moves about four times
/// a second, and Ctrl-C (which ends the process between two GL calls) waits at most this
/// long for the band in flight.
pub(super) const BAND_TIME: Duration = Duration::from_millis(250);

/// The rows of the next band. With a target time (progress drawn), the first band is
/// 1/64 of the image and each later one is sized from the rate measured so far to take
/// about the target, but at most twice the last band, and at most 1/32 of the image once a
/// band has taken an eighth of the target. Rows of sky at the top of an image are fast: a
/// rate measured on them alone sized a band of glass.toml to take 5 s of a 15 s render
/// (llvmpipe). On a GPU where no band takes that long the bands just double (an 18 ms
/// 4096x4096 frame on the H200 would take 7 bands; capped at 1/32 it took 33 bands and 28%
/// more GPU time). Without a target every band is the largest the limits allow.
#[derive(Clone, Copy, Debug)]
pub(super) struct BandPlan {
    height: u32,
    max_rows: u32,
    target: Option<Duration>,
}

impl BandPlan {
    /// A plan for `height` rows in bands of at most `max_rows`.
    pub fn new(height: u32, max_rows: u32, target: Option<Duration>) -> Self {
        BandPlan {
            height,
            max_rows: max_rows.max(1),
            target,
        }
    }

    /// Whether bands are sized by time (and so must each finish before the next is
    /// sized: no band is left in flight).
    pub fn timed(&self) -> bool {
        self.target.is_some()
    }

    /// The rows of the band starting at row `done`, when the bands before it (all `done`
    /// rows) took `elapsed` and the last of them, `last` rows, took `last_time`.
    pub fn next(&self, done: u32, (last, last_time): (u32, Duration), elapsed: Duration) -> u32 {
        let left = self.height - done;
        let rows = match self.target {
            None => self.max_rows,
            Some(_) if done == 0 => self.height.div_ceil(64),
            Some(target) => {
                let rate = done as f64 / elapsed.as_secs_f64().max(1e-9);
                let rows = (rate * target.as_secs_f64()).clamp(1.0, u32::MAX as f64) as u32;
                let rows = rows.min(last.saturating_mul(2));
                if last_time >= target / 8 {
                    rows.min(self.height.div_ceil(32))
                } else {
                    rows
                }
            }
        };
        rows.clamp(1, self.max_rows).min(left)
    }
}

/// What kept output buffers are made for: one band's pixels and which outputs are read.
/// Bytes of each of the two staging slots the bands' output comes back through: pieces of
/// a band, not whole bands. Pinned host memory is slow to get: the two slots of a 4096²
/// frame's whole 8-bit band (50 MB each) took 18-20 ms to allocate on the H100 machine, in
/// every process's first frame. Measured on the H200 (docs/performance.md), the steady
/// 4096² frame reads back in 1.8-2.1 ms through 16 MiB slots, 2.3-2.6 ms through whole
/// bands, 3.1-3.9 ms through 4 MiB and 5.3-6.5 ms through 1 MiB ones (a fence round trip
/// per piece).
pub(super) const STAGING_SLOT_BYTES: usize = 16 << 20;

/// Environment variable that sets the staging slots' bytes instead (at least 16), so tests
/// can read a small image back in many pieces.
pub const STAGING_SLOT_ENV: &str = "FRAGTRACE_STAGING_SLOT_BYTES";

fn staging_slot_bytes() -> usize {
    std::env::var(STAGING_SLOT_ENV)
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
        .map_or(STAGING_SLOT_BYTES, |b| b.max(16))
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Shape {
    /// Pixels of the largest band.
    pub band_px: usize,
    /// The AOV buffer is written and read.
    pub aov: bool,
    /// The image comes back as 8-bit sRGB (else as linear RGB floats).
    pub srgb8: bool,
}

impl Shape {
    /// Bytes one band of `px` pixels hands back: 8-bit RGB, or linear RGB floats.
    pub fn out_bytes(&self, px: usize) -> usize {
        if self.srgb8 {
            px * 3
        } else {
            px * 12
        }
    }
}

/// The output buffers of a render's bands, kept in the GPU scene for the next render of
/// the same [`Shape`] (an animation's frames, the view's, `bench --steady`'s).
pub(super) struct Outputs {
    /// What they were made for.
    pub shape: Shape,
    /// Linear RGB per pixel of the band.
    pub radiance: StorageBuffer,
    /// One AOV texel per pixel of the band, when asked.
    pub aov: Option<StorageBuffer>,
    /// The band's 8-bit sRGB bytes, when asked.
    pub srgb8: Option<StorageBuffer>,
    /// Two persistently mapped staging slots of one band's output (None without
    /// `GL_ARB_buffer_storage`: the bytes are then read through a staging copy per band).
    pub ring: Option<ReadbackRing>,
    /// The render's counter sums (zeroed before each render).
    pub counters: StorageBuffer,
}

impl Outputs {
    /// Buffers for `shape`.
    pub fn new(ctx: &GlContext, shape: Shape) -> Result<Self> {
        let px = shape.band_px;
        Ok(Outputs {
            shape,
            radiance: StorageBuffer::uninit(ctx, px * 3 * 4)?,
            aov: shape
                .aov
                .then(|| StorageBuffer::uninit(ctx, px * 4 * 4))
                .transpose()?,
            srgb8: shape
                .srgb8
                .then(|| StorageBuffer::uninit(ctx, (px * 3).div_ceil(4) * 4))
                .transpose()?,
            ring: ReadbackRing::new(ctx, shape.out_bytes(px).min(staging_slot_bytes())).ok(),
            counters: StorageBuffer::zeroed_u32(ctx, 2 * COUNTERS)?,
        })
    }

    /// Zeroes the counter sums for a new render.
    pub fn reset_counters(&self, gl: &glow::Context) -> Result<()> {
        self.counters.write(gl, &[0u8; 2 * COUNTERS * 4])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn band_rows_fit_the_block() {
        let l = |block_bytes| Limits {
            blocks: 16,
            block_bytes,
        };
        assert_eq!(l(1 << 30).band_rows(640, 480).unwrap(), 480);
        // 600 rows of 300 pixels at 16 bytes (4800 bytes a row).
        assert_eq!(l(300 * 16 * 600).band_rows(300, 600).unwrap(), 600);
        assert_eq!(l(300 * 16 * 300 + 4799).band_rows(300, 600).unwrap(), 300);
        assert_eq!(l(300 * 16).band_rows(300, 600).unwrap(), 1);
        let e = l(300 * 16 - 1).band_rows(300, 600).unwrap_err();
        assert!(e.to_string().contains("needs 4800 bytes"), "{e}");
    }

    /// Headless: the limit's bands. Timed: 1/64 of the image first, then bands sized by
    /// the measured rate to the target, within the limit, never past the last row.
    #[test]
    fn bands_follow_the_measured_rate_within_the_limit() {
        let ms = Duration::from_millis;
        let headless = BandPlan::new(600, 256, None);
        assert!(!headless.timed());
        assert_eq!(headless.next(0, (0, ms(0)), ms(0)), 256);
        assert_eq!(headless.next(512, (256, ms(300)), ms(900)), 88);
        let timed = BandPlan::new(4800, 4800, Some(ms(250)));
        assert!(timed.timed());
        assert_eq!(timed.next(0, (0, ms(0)), ms(0)), 75, "1/64 of the image");
        // 75 rows in 1.25 s: 60 rows a second, 15 rows in 250 ms.
        assert_eq!(timed.next(75, (75, ms(1250)), ms(1250)), 15);
        // 90 rows in 300 ms: 75 rows in 250 ms, but at most twice the last band.
        assert_eq!(timed.next(90, (15, ms(50)), ms(300)), 30);
        // Fast bands double; once a band took an eighth of the target, at most 1/32 of
        // the image; within the limit, never past the last row.
        assert_eq!(timed.next(75, (75, ms(1)), ms(1)), 150);
        assert_eq!(timed.next(1200, (600, ms(20)), ms(40)), 1200);
        assert_eq!(timed.next(1200, (600, ms(40)), ms(60)), 150);
        assert_eq!(timed.next(4700, (150, ms(40)), ms(2000)), 100);
        let limited = BandPlan::new(4800, 100, Some(ms(250)));
        assert_eq!(limited.next(200, (100, ms(1)), ms(2)), 100);
        // Slow: never less than a row.
        assert_eq!(timed.next(75, (75, ms(100_000)), ms(100_000)), 1);
        assert_eq!(
            BandPlan::new(10, 10, Some(ms(250))).next(0, (0, ms(0)), ms(0)),
            1
        );
    }
}
