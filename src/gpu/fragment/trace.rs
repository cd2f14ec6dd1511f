//! Tracing one ray wave to completion: the termination loop, shared by every kernel.
//!
//! Traversal set-up, then advancing passes (multipass: a step pass and a test pass per
//! iteration; unrolled/looped: one pass of several iterations), with an occlusion query over
//! the `count` pass every `query_every` iterations' worth of passes; the wave is done when it
//! finds no active ray. With `--mask`, that count pass also writes the mask.

use super::frame::{Cover, Frame, Slot};
use crate::gpu::gl::{state, MaskBuffer};
use crate::gpu::options::Mask;
use crate::gpu::shader::{Pass, Query};
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
        let grid = self.grid;
        // The tiles the passes draw, and `live[drawn_at]` their rectangles. Outside them
        // both ray-state sets hold the same final state, so a pass that leaves them out
        // leaves the state whole. A query finds the tiles still active, a subset; the
        // first pass after it still draws the old tiles, and its write-through copies the
        // rays that finished there into the other set (as the mask's first pass does).
        let mut drawn = vec![true; grid.len()];
        let mut drawn_at = 0;
        self.set_live(drawn_at, &grid.runs(&drawn));
        let mut pending = None;
        let mut active = 0;
        let mut synced = false;
        let mut passes = 0u64;
        loop {
            if passes.is_multiple_of(every) {
                self.set_mask_test(false);
                self.progress.passes(self.stats.passes_total);
                let counts = self.count_and_mask(&drawn)?;
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
                if self.opts.tiles {
                    drawn = counts.iter().map(|&c| c > 0).collect();
                }
                let at = 1 - drawn_at;
                self.set_live(at, &grid.runs(&drawn));
                pending = Some(at);
                active = n;
                synced = false;
            }
            self.set_mask_test(synced);
            match advance {
                Some(pass) => self.advance(pass, &mut drawn_at, &mut pending, active).await?,
                None => {
                    self.advance(Pass::TraverseStep, &mut drawn_at, &mut pending, active)
                        .await?;
                    self.set_mask_test(true);
                    self.advance(Pass::Intersect(query), &mut drawn_at, &mut pending, active)
                        .await?;
                }
            }
            synced = true;
            passes += 1;
        }
    }

    /// Draws advancing pass `pass` over `live[drawn_at]`, then moves `drawn_at` to the
    /// tiles `pending` names (the last query's, which the passes after this one draw).
    async fn advance(
        &mut self,
        pass: Pass,
        drawn_at: &mut usize,
        pending: &mut Option<usize>,
        active: u64,
    ) -> Result<()> {
        let (cover, area) = if self.opts.tiles {
            (Cover::Live(*drawn_at), self.live[*drawn_at].area())
        } else {
            let (w, h) = self.grid.size();
            (Cover::Full, w as u64 * h as u64)
        };
        self.stats.advance_pixels += area;
        self.stats.advance_active += active;
        self.state_pass_over(pass, cover).await?;
        if let Some(at) = pending.take() {
            *drawn_at = at;
        }
        Ok(())
    }

    /// Counts active rays per tile (only the tiles `region` sets are drawn) and, with
    /// `--mask`, writes the mask of them: the count pass is drawn (colour writes off) into
    /// the ray-state target that is not being read, whose depth/stencil buffer both state
    /// targets share.
    fn count_and_mask(&mut self, region: &[bool]) -> Result<Vec<u64>> {
        if self.mask_buffer.is_none() {
            return self.count_tiles(region, Slot::Acc(1 - self.acc_cur));
        }
        let slot = Slot::State(1 - self.cur);
        self.target(slot).bind(self.gl());
        let buffer = self.mask_kind().expect("no mask buffer without a mask");
        // The bound target has the mask buffer attached.
        state::begin_mask_write(self.gl(), buffer);
        let n = self.count_tiles(region, slot);
        state::end_mask_write(self.gl());
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
