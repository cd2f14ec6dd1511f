//! The multi-pass GPU renderer: the host side of the thesis's stream design.
//!
//! Every pass is one fragment program drawn over the full-screen quad into RGBA32F
//! textures. The ray state lives in four textures ping-ponged between two framebuffers
//! (a pass never reads what it writes); every pass copies rays that are not in its state
//! through unchanged, so either set always holds the whole current state.
//!
//! One job per file: `frame` owns the GL objects of a render and draws passes;
//! `passes` decides which programs a scene needs and builds them; `trace` is the one
//! termination loop that traces a ray wave (traversal passes until an occlusion query over
//! the `count` pass, run every K iterations, finds no active ray); `tree` walks the
//! Whitted ray tree (each level keeps a hit record; a node's children are skipped when an
//! occlusion query finds no pixel where they exist); `readback` brings images, AOVs and
//! traced rays back to the host.
//!
//! A render can be watched while it runs ([`render_gl_observed`]): an [`Observer`] is
//! called after every ray-state and accumulation pass with a [`Snapshot`] of the colour so
//! far and the ray state, and may cancel the render. This is how `fragtrace view` shows the
//! wave of rays advancing; the headless path passes no observer and is unchanged.

mod compute;
mod frame;
mod passes;
mod readback;
mod trace;
mod tree;

#[cfg(test)]
mod tests;

use super::options::GpuOptions;
pub(crate) use frame::max_iterations;
pub use readback::{trace_rays, GpuRay, GpuTrace};
pub use tree::{render_gl, render_gl_observed};

use crate::gpu::gl::Texture;
use crate::image_io::Image;
use crate::output::{Aov, GpuStats, RayCounts};

/// What [`render_gl`] renders: the image's size, samples and depth, and how.
#[derive(Clone, Copy, Debug)]
pub struct ImageRequest {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Maximum reflection/refraction depth.
    pub max_depth: u32,
    /// Robustness techniques compiled into the programs (override `gpu.techniques`).
    pub techniques: crate::technique::Techniques,
    /// Show a progress display on stderr (drawn only when stderr is a terminal).
    pub progress: bool,
    /// Backend options.
    pub gpu: GpuOptions,
}

/// Output of a GPU render.
pub struct GpuOutput {
    /// Linear RGB image.
    pub image: Image,
    /// Primary-ray AOVs (first sample).
    pub aov: Aov,
    /// Rays by kind (from occlusion queries, or the compute kernel's counters).
    pub rays: RayCounts,
    /// Traversal work of all rays, where the kernel counts it (compute; the fragment
    /// kernels count cells and tests together per primary ray, in the `steps` AOV).
    pub work: Option<Work>,
    /// GPU statistics.
    pub stats: GpuStats,
}

/// Traversal work of a render's rays, counted as the CPU's `Work` counts it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Work {
    /// Grid cells entered (the start cell included).
    pub cells: u64,
    /// Ray-triangle tests.
    pub tests: u64,
}

/// What an [`Observer`] sees between two passes of a render in progress.
///
/// The textures belong to the render and are only valid during the call; the observer may
/// draw with them in the same context (it must leave the GL state as it found it: see
/// `view::present` for one that does).
pub struct Snapshot<'f> {
    /// The colour accumulated so far (RGBA, linear RGB in `.rgb`): the finished samples
    /// and the finished parts of the one in flight, each sample weighted 1/`samples`.
    pub radiance: &'f Texture,
    /// The current ray-state textures s0..s3 (see `gpu::contract::ray`): the wave in
    /// flight, or the last one traced.
    pub state: &'f [Texture],
    /// Samples per pixel finished so far.
    pub samples_done: u32,
    /// Samples per pixel of the whole render.
    pub samples: u32,
    /// Passes drawn so far in this render.
    pub passes: u64,
}

/// An observer's answer: go on, or stop the render (which then returns
/// [`crate::Error::Cancelled`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    /// Draw the next pass.
    Continue,
    /// Abandon the render now.
    Cancel,
}

/// The hook [`render_gl_observed`] calls after every ray-state and accumulation pass (and
/// after each finished sample), with this render's context current.
pub type Observer<'o> = dyn FnMut(&Snapshot<'_>) -> Flow + 'o;
