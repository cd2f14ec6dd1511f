//! Tracing one ray wave to completion: the termination loop, shared by every kernel.
//!
//! Traversal set-up, then advancing passes (multipass: a step pass and a test pass per
//! iteration; unrolled/looped: one pass of several iterations), with an occlusion query over
//! the `count` pass every `query_every` iterations' worth of passes; the wave is done when it
//! finds no active ray. With `--mask`, that count pass also writes the mask. The count is
//! taken per tile (`tiles.rs`), and the advancing passes until the next one draw only the
//! tiles that still hold active rays (`Cut`).

use super::frame::{Cover, Frame, Slot};
use crate::gpu::gl::{state, MaskBuffer};
use crate::gpu::options::Mask;
use crate::gpu::shader::{Count, Pass, Query};
use crate::{Error, Result};

impl Frame<'_> {
    /// Traces the current ray wave to completion.
    ///
    /// With a mask, a masked pass leaves finished rays unwritten in its target, so the
    /// ping-pong pair may disagree on them. The first pass after each mask refresh therefore
    /// runs unmasked: its write-through copies every finished ray into the other target, and
    /// from then on both hold the same state for every ray outside the mask.
    pub(super) async fn trace(&mut self, query: Query) -> Result<()> {
        self.progress.begin_trace();
        let r = self.trace_inner(query).await;
        self.set_mask_test(false);
        self.progress.end_trace();
        r
    }

    async fn trace_inner(&mut self, query: Query) -> Result<()> {
        self.state_pass(Pass::TraverseInit).await?;
        let kernel = self.kernel;
        let advance = Pass::advance(kernel, query);
        // Several iterations per pass: query every `query_every` iterations' worth.
        let per_pass = kernel.iterations_per_pass();
        let every = (self.opts.query_every as u64 / per_pass).max(1);
        // With one pass between queries, that pass is the one after a query, which draws
        // the old tiles: cutting would cost the per-tile counts and save nothing.
        let mut cut = Cut::new(self, self.opts.tiles && every > 1);
        let mut synced = false;
        let mut passes = 0u64;
        loop {
            if passes.is_multiple_of(every) {
                self.set_mask_test(false);
                self.progress.passes(self.stats.passes_total);
                let counts = self.count_and_mask(cut.on.then_some(&cut.drawn[..]))?;
                let n = counts.iter().sum();
                self.progress.active(n);
                if n == 0 {
                    return Ok(());
                }
                // The bound is judged here, where rays are known to be still active, and on
                // the iterations every ray has had: a pass advances each ray by up to
                // `per_pass` iterations (a looped pass runs a ray until it finishes or
                // LOOP_MAX), so a ray still active after them has really run that many.
                // Judged after each pass instead, one looped pass (1024 nominal iterations)
                // overshot the bound of a small grid (304 for an empty scene) before any
                // query could see that every ray had finished.
                let iterations = passes * per_pass;
                if iterations > self.max_iterations {
                    return Err(Error::Internal(format!(
                        "traversal did not terminate after {iterations} iterations"
                    )));
                }
                cut.counted(self, &counts);
                synced = false;
            }
            self.set_mask_test(synced);
            match advance {
                Some(pass) => self.advance(pass, &mut cut).await?,
                None => {
                    self.advance(Pass::TraverseStep, &mut cut).await?;
                    self.set_mask_test(true);
                    self.advance(Pass::Intersect(query), &mut cut).await?;
                }
            }
            synced = true;
            passes += 1;
        }
    }

    /// Draws advancing pass `pass` over what `cut` says, then moves it on.
    async fn advance(&mut self, pass: Pass, cut: &mut Cut) -> Result<()> {
        let (cover, area) = if cut.on {
            (Cover::Live(cut.drawn_at), self.live[cut.drawn_at].area())
        } else {
            let (w, h) = self.grid.size();
            (Cover::Full, w as u64 * h as u64)
        };
        self.stats.advance_pixels += area;
        self.stats.advance_active += cut.active;
        self.last_advance = Some((cover, area, cut.active));
        self.state_pass_over(pass, cover).await?;
        if let Some(at) = cut.pending.take() {
            cut.drawn_at = at;
        }
        Ok(())
    }

    /// Counts active rays and, with `--mask`, writes the mask of them: per tile when
    /// `region` is given (only the tiles it sets are drawn), else one count over the
    /// full-screen quad. The count pass is drawn (colour writes off) into the ray-state
    /// target that is not being read, whose depth/stencil buffer both state targets share.
    fn count_and_mask(&mut self, region: Option<&[bool]>) -> Result<Vec<u64>> {
        let slot = match self.mask_buffer {
            None => Slot::Acc(1 - self.acc_cur),
            Some(_) => Slot::State(1 - self.cur),
        };
        let mask = self.mask_kind().filter(|_| self.mask_buffer.is_some());
        if let Some(buffer) = mask {
            self.target(slot).bind(self.gl());
            // The bound target has the mask buffer attached.
            state::begin_mask_write(self.gl(), buffer);
        }
        let n = match region {
            Some(region) => self.count_tiles(region, slot),
            None => self.count_into(Count::Rays, None, slot).map(|n| vec![n]),
        };
        if mask.is_some() {
            state::end_mask_write(self.gl());
        }
        n
    }

    /// Turns the mask test on or off for the draws that follow.
    fn set_mask_test(&self, on: bool) {
        state::mask_test(self.gl(), self.mask_kind().filter(|_| on));
    }

    /// The buffer `--mask` writes, `None` without a mask.
    fn mask_kind(&self) -> Option<MaskBuffer> {
        match self.opts.mask {
            Mask::EarlyZ => Some(MaskBuffer::Depth),
            Mask::Stencil => Some(MaskBuffer::Stencil),
            Mask::None | Mask::Auto => None,
        }
    }
}

/// Where a wave's advancing passes draw (`tiles.rs`): with `on`, the tiles in `drawn`,
/// whose rectangles are `Frame::live[drawn_at]`; else the full-screen quad.
///
/// Outside the tiles drawn both ray-state sets hold the same final state, so a pass that
/// leaves them out leaves the state whole. A query finds the tiles still active, a subset;
/// the first pass after it still draws the old tiles (`pending` holds the new ones until
/// then), and its write-through copies the rays that finished there into the other set, as
/// the mask's first pass does.
struct Cut {
    on: bool,
    drawn: Vec<bool>,
    drawn_at: usize,
    pending: Option<usize>,
    /// Active rays at the last query.
    active: u64,
}

impl Cut {
    /// Every tile drawn, its rectangles uploaded when `on`.
    fn new(f: &mut Frame<'_>, on: bool) -> Self {
        let drawn = vec![true; f.grid.len()];
        if on {
            f.set_live(0, &f.grid.runs(&drawn));
        }
        Cut {
            on,
            drawn,
            drawn_at: 0,
            pending: None,
            active: 0,
        }
    }

    /// Takes a query's counts: the total, and with `on` the tiles still active, which the
    /// passes after the next one draw.
    fn counted(&mut self, f: &mut Frame<'_>, counts: &[u64]) {
        self.active = counts.iter().sum();
        if self.on {
            self.drawn = counts.iter().map(|&c| c > 0).collect();
            let at = 1 - self.drawn_at;
            f.set_live(at, &f.grid.runs(&self.drawn));
            self.pending = Some(at);
        }
    }
}
