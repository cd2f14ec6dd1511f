//! Tracing one ray wave to completion: the termination loop, shared by every kernel.
//!
//! Traversal set-up, then advancing passes (multipass: a step pass and a test pass per
//! iteration; unrolled/looped: one pass of several iterations), with an occlusion query over
//! the `count` pass every `query_every` iterations' worth of passes; the wave is done when it
//! finds no active ray. With `--mask`, that count pass also writes the mask.

use super::frame::{Frame, Slot};
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
        let mut synced = false;
        let mut passes = 0u64;
        loop {
            if passes.is_multiple_of(every) {
                self.set_mask_test(false);
                self.progress.passes(self.stats.passes_total);
                let n = self.count_and_mask()?;
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
                synced = false;
            }
            self.set_mask_test(synced);
            match advance {
                Some(pass) => self.state_pass(pass).await?,
                None => {
                    self.state_pass(Pass::TraverseStep).await?;
                    self.set_mask_test(true);
                    self.state_pass(Pass::Intersect(query)).await?;
                }
            }
            synced = true;
            passes += 1;
        }
    }

    /// Counts active rays and, with `--mask`, writes the mask of them: the count pass is
    /// drawn (colour writes off) into the ray-state target that is not being read, whose
    /// depth/stencil buffer both state targets share.
    fn count_and_mask(&mut self) -> Result<u64> {
        if self.mask_buffer.is_none() {
            return self.count(Count::Rays, None);
        }
        let slot = Slot::State(1 - self.cur);
        self.target(slot).bind(self.gl());
        let buffer = self.mask_kind().expect("no mask buffer without a mask");
        // The bound target has the mask buffer attached.
        state::begin_mask_write(self.gl(), buffer);
        let n = self.count_into(Count::Rays, None, slot);
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
