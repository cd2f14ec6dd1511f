//! What a GPU render is asked ([`ImageRequest`]) and gives back ([`GpuOutput`], [`Work`]),
//! and how a render is watched while it runs: an [`Observer`] is called after every
//! ray-state and accumulation pass with a [`Snapshot`] of the colour so far and the ray
//! state, and may cancel the render or pause it ([`Flow::Pause`]: the web page's
//! pass-by-pass display, `gpu::pause`). This is how `fragtrace view` shows the wave of
//! rays advancing; the headless path passes no observer. Both wings of the backend
//! (`gpu::fragment`, `gpu::compute`) speak these types.

use crate::gpu::gl::Texture;
use crate::gpu::options::GpuOptions;
use crate::output::AovPixel;
use crate::region::Region;
use crate::scene::{Camera, Scene};

/// What a render draws: the camera, the image's size, samples and depth, and how.
#[derive(Clone, Copy, Debug)]
pub struct ImageRequest {
    /// The camera (the scene's own, or the view's as the user moves it).
    pub camera: Camera,
    /// Width in pixels of the whole image.
    pub width: u32,
    /// Height in pixels of the whole image.
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
    /// What to read back (the AOVs; the image as 8-bit sRGB only).
    pub readback: crate::output::Readback,
    /// Render only these pixels of the `width` x `height` image (each the whole render's
    /// pixel, bit for bit); None: all of them.
    pub region: Option<Region>,
}

impl ImageRequest {
    /// The pixels rendered: the region, or the whole image.
    pub fn pixels(&self) -> Region {
        self.region
            .unwrap_or_else(|| Region::full(self.width, self.height))
    }
}

/// Output of a GPU render: the one backend output type (`gpu` is always set).
pub type GpuOutput = crate::output::BackendOutput;

pub use crate::output::Work;

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
    /// The kind of the last pass drawn ([`crate::gpu::shader::Pass::name`], e.g.
    /// `traverse_step`; `compute` for the compute kernel), for a display of the walk.
    pub pass: &'static str,
    /// The primary-ray AOVs, once read (after the first sample's primary wave, where the
    /// request reads them: [`crate::output::Readback::aov`]).
    pub aov: Option<&'f crate::output::Aov>,
    /// What the last advancing pass drew (the fragment kernels; `None` before the first
    /// and for the compute kernel): the passes cut to the tiles that still hold active
    /// rays (issue 49), for a display of the reduction at work.
    pub advance: Option<Advance<'f>>,
}

/// What an advancing pass (a traversal step or intersection, an unrolled or looped pass)
/// drew: the tiles that held active rays at the termination query before it.
#[derive(Clone, Copy, Debug)]
pub struct Advance<'f> {
    /// Its rectangles of pixels (rows from the bottom): runs of active tiles, or the whole
    /// image where the passes are not cut.
    pub rects: &'f [crate::gpu::gl::PixelRect],
    /// The pixels they cover.
    pub pixels: u64,
    /// Active rays at the termination query before it: what a pass over the compacted
    /// active rays alone would draw.
    pub active: u64,
}

/// An observer's answer: go on, or stop the render (which then returns
/// [`crate::Error::Cancelled`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    /// Draw the next pass.
    Continue,
    /// Abandon the render now.
    Cancel,
    /// Hand control back to whoever polls the render ([`crate::gpu::pause::Stepped`]) and
    /// go on with the next pass when polled again: how the web page shows the image
    /// between passes without blocking the browser. A render run to completion
    /// ([`crate::gpu::render::render`]) polls again at once, so there it is `Continue`.
    Pause,
}

/// The hook an observed render calls after every ray-state and accumulation pass (and
/// after each finished sample), with this render's context current. The fragment kernels'
/// walk pauses there on [`Flow::Pause`]; the compute kernel (native only) goes on.
pub type Observer<'o> = dyn FnMut(&Snapshot<'_>) -> Flow + 'o;

/// One primary ray's AOV pixel: its hit (t, triangle) if any and its traversal steps.
pub(crate) fn aov_pixel(scene: &Scene, hit: Option<(f32, f32)>, steps: f32) -> AovPixel {
    // The GPU carries a triangle's id as its float slot (the index below 2^24).
    let hit = hit.map(|(t, slot)| (t, crate::gpu::layout::slot_record(slot)));
    aov_pixel_id(scene, hit, steps)
}

/// [`aov_pixel`] of a hit whose triangle id is known exactly.
pub(crate) fn aov_pixel_id(scene: &Scene, hit: Option<(f32, u64)>, steps: f32) -> AovPixel {
    match hit {
        Some((t, tri)) => {
            let v = scene.placed_vertices(tri as usize);
            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
            AovPixel {
                depth: t,
                primid: tri as f32,
                normal: n.to_array(),
                steps,
            }
        }
        None => AovPixel::miss(steps),
    }
}
