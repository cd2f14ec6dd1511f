//! Output types shared by every backend and every front end: rays by kind, primary-ray
//! AOVs and GPU statistics. They sit below `cpu`, `gpu` and `render` so that the backends
//! produce them without importing the front door that dispatches to them.

use std::collections::HashMap;

use serde::Serialize;

use crate::image_io::Image;

/// What a backend renders: the same type from the CPU and from either GPU wing.
pub struct BackendOutput {
    /// Linear RGB image.
    pub image: Image,
    /// Primary-ray AOVs (first sample of each pixel).
    pub aov: Aov,
    /// Rays traced by kind.
    pub rays: RayCounts,
    /// Traversal work of all rays, where the backend counts it (the CPU and the compute
    /// kernel; the fragment kernels count cells and tests together per primary ray, in the
    /// `steps` AOV).
    pub work: Option<Work>,
    /// GPU statistics (GPU renders only).
    pub gpu: Option<GpuStats>,
    /// The image as 8-bit sRGB RGB, top row first, where the backend converted it (asked
    /// for by [`Readback::srgb8`]); `image` then holds no data.
    pub srgb8: Option<Vec<u8>>,
    /// Cells visited plus triangle tests of the first sample's primary rays, summed, where
    /// the backend counted them apart from the AOV.
    pub primary_steps: Option<u64>,
    /// Pixels whose radiance is NaN or infinite, where the backend counted them (it did
    /// when it converted to 8-bit and the linear image was not read back).
    pub nonfinite: Option<u64>,
}

impl BackendOutput {
    /// Mean cells plus tests per primary ray (first sample): from the AOV, or from the
    /// backend's own sum where the AOV was not read back.
    pub fn mean_primary_steps(&self) -> Option<f64> {
        if !self.aov.pixels.is_empty() {
            return Some(self.aov.mean_steps());
        }
        let pixels = self.image.width as f64 * self.image.height as f64;
        self.primary_steps.map(|s| s as f64 / pixels.max(1.0))
    }

    /// One output from renders of full-width bands of rows, `parts` top band first, each
    /// a render of its own rows of the same image (`ImageRequest::region`): the rows
    /// stacked, the counts summed. What only some parts counted (the compute kernel's
    /// traversal work, its primary steps, a non-finite count) is not known for the whole
    /// and is left out rather than given for a share of the pixels.
    ///
    /// How `--kernel auto`'s cold start hands a frame from the fragment fallback to the
    /// compute kernel part way down (`gpu::render`).
    pub fn stack_rows(parts: Vec<BackendOutput>) -> BackendOutput {
        let mut parts = parts.into_iter();
        let mut out = parts.next().expect("stack_rows of no parts");
        for p in parts {
            debug_assert_eq!(p.image.width, out.image.width, "bands of one width");
            out.image.height += p.image.height;
            out.image.data.extend_from_slice(&p.image.data);
            let aov_complete = !out.aov.pixels.is_empty() && !p.aov.pixels.is_empty();
            out.aov.height += p.aov.height;
            if aov_complete {
                out.aov.pixels.extend_from_slice(&p.aov.pixels);
            } else {
                out.aov.pixels.clear();
            }
            let r = p.rays;
            out.rays = RayCounts::new(
                out.rays.primary + r.primary,
                out.rays.shadow + r.shadow,
                out.rays.reflected + r.reflected,
                out.rays.refracted + r.refracted,
            );
            out.work = out.work.zip(p.work).map(|(a, b)| Work {
                cells: a.cells + b.cells,
                tests: a.tests + b.tests,
            });
            match (out.gpu.as_mut(), p.gpu) {
                (Some(a), Some(b)) => a.absorb(b),
                (None, b) => out.gpu = b,
                (Some(_), None) => {}
            }
            out.srgb8 = out.srgb8.zip(p.srgb8).map(|(mut a, b)| {
                a.extend_from_slice(&b);
                a
            });
            out.primary_steps = out.primary_steps.zip(p.primary_steps).map(|(a, b)| a + b);
            out.nonfinite = out.nonfinite.zip(p.nonfinite).map(|(a, b)| a + b);
        }
        out
    }

    /// Whether every pixel is finite (from the image, or the backend's count).
    pub fn all_finite(&self) -> bool {
        match self.nonfinite {
            Some(n) => n == 0,
            None => self.image.all_finite(),
        }
    }
}

/// What a render reads back to the host besides what the backend must.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Readback {
    /// The primary-ray AOVs (`--aov`, and the tests); without them `--stats` still gets
    /// the mean steps per primary ray where the backend counts them.
    pub aov: bool,
    /// The image as 8-bit sRGB only (a PNG): a GPU that can converts it and reads back a
    /// quarter of the bytes, the linear image is not read.
    pub srgb8: bool,
}

impl Default for Readback {
    /// Everything: the linear image and the AOVs (what library callers and tests get).
    fn default() -> Self {
        Readback {
            aov: true,
            srgb8: false,
        }
    }
}

/// Traversal work of a render's rays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Work {
    /// Grid cells entered (the start cell included).
    pub cells: u64,
    /// Ray-triangle tests.
    pub tests: u64,
}

/// Rays traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RayCounts {
    /// Camera rays.
    pub primary: u64,
    /// Shadow rays (one per light per shaded hit above the horizon).
    pub shadow: u64,
    /// Mirror rays.
    pub reflected: u64,
    /// Transmitted rays.
    pub refracted: u64,
    /// Sum of the above.
    pub total: u64,
}

impl RayCounts {
    /// Builds the counts and their total.
    pub fn new(primary: u64, shadow: u64, reflected: u64, refracted: u64) -> Self {
        RayCounts {
            primary,
            shadow,
            reflected,
            refracted,
            total: primary + shadow + reflected + refracted,
        }
    }
}

/// A ray rate for people: `rays` in `ms` milliseconds as Mrays/s, krays/s or rays/s,
/// whichever shows three significant figures or more, so a slow render never reads
/// "0.00 Mrays/s"; "- rays/s" where no time was measured.
pub fn ray_rate(rays: u64, ms: f64) -> String {
    let per_s = rays as f64 / (ms * 1e-3);
    if !(ms > 0.0 && per_s.is_finite()) {
        return "- rays/s".into();
    }
    match per_s {
        r if r >= 1e6 => format!("{:.2} Mrays/s", r * 1e-6),
        r if r >= 1e5 => format!("{:.0} krays/s", r * 1e-3),
        r if r >= 1e4 => format!("{:.1} krays/s", r * 1e-3),
        r if r >= 1e3 => format!("{:.2} krays/s", r * 1e-3),
        0.0 => "0 rays/s".into(),
        // Three significant figures below a thousand, however few rays.
        r => {
            let decimals = (2 - r.log10().floor() as i32).clamp(0, 9) as usize;
            format!("{r:.decimals$} rays/s")
        }
    }
}

/// One AOV pixel of the primary ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AovPixel {
    /// Hit parameter t; +inf on a miss.
    pub depth: f32,
    /// Triangle index; -1 on a miss.
    pub primid: f32,
    /// Geometric normal (winding order, not flipped); zero on a miss.
    pub normal: [f32; 3],
    /// Cells visited plus triangle tests.
    pub steps: f32,
}

impl AovPixel {
    /// A miss.
    pub fn miss(steps: f32) -> Self {
        AovPixel {
            depth: f32::INFINITY,
            primid: -1.0,
            normal: [0.0; 3],
            steps,
        }
    }
}

/// Per-pixel outputs of the primary ray: what inspection and compositing need.
#[derive(Clone, Debug, PartialEq)]
pub struct Aov {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Pixels, top row first.
    pub pixels: Vec<AovPixel>,
}

impl Aov {
    /// Mean of the `steps` AOV (cells visited plus triangle tests per primary ray): the
    /// traversal work every backend reports alike, the GPU counting it in its ray state.
    pub fn mean_steps(&self) -> f64 {
        if self.pixels.is_empty() {
            return 0.0;
        }
        self.pixels.iter().map(|p| p.steps as f64).sum::<f64>() / self.pixels.len() as f64
    }

    /// From pixels in row order.
    pub fn from_pixels(width: u32, height: u32, pixels: &[AovPixel]) -> Self {
        assert_eq!(pixels.len(), (width * height) as usize);
        Aov {
            width,
            height,
            pixels: pixels.to_vec(),
        }
    }

    /// [`Aov::from_pixels`] taking the pixels by value (no copy of a large image).
    pub fn from_vec(width: u32, height: u32, pixels: Vec<AovPixel>) -> Self {
        assert_eq!(pixels.len(), (width * height) as usize);
        Aov {
            width,
            height,
            pixels,
        }
    }

    /// The pixel at (i, j).
    pub fn at(&self, i: u32, j: u32) -> &AovPixel {
        &self.pixels[(j * self.width + i) as usize]
    }
}

/// GPU statistics of one render.
#[derive(Clone, Debug, Default, Serialize)]
pub struct GpuStats {
    /// GL_RENDERER.
    pub renderer: String,
    /// GL_VERSION.
    pub gl_version: String,
    /// The kernel that ran (`--kernel auto` resolved): compute, looped, unrolled:K or
    /// multipass.
    pub kernel: String,
    /// `--kernel auto` chose the compute kernel, whose programs were still compiling (a
    /// cold start: not in the program-binary cache, the driver compiling them on threads
    /// of its own), and `kernel`, its fragment fallback, rendered this one meanwhile: the
    /// same image (issue 52).
    pub cold_start: bool,
    /// On a cold start, the row of the whole image (0 the top) from which the compute
    /// kernel rendered the rest of the frame, its compile having finished while the
    /// fallback rendered the bands above; None where the fallback rendered the whole frame
    /// (or there was no cold start).
    pub handover_row: Option<u32>,
    /// How the kernel read the scene textures (named by `gpu::layout::Fetch::name`):
    /// `texel-fetch` or `storage-buffer` (compute, `--scene-fetch` resolved), `texture2D`
    /// (the fragment kernels).
    pub scene_fetch: String,
    /// How the compute kernel read the grid (named by `gpu::layout::SceneTextures::grid_name`):
    /// `dense` (the irregular grid's `u32` storage buffers) or `float` (the textures every
    /// fragment kernel reads); empty for the fragment kernels, which read `float` always.
    pub grid_layout: String,
    /// Passes drawn, by kind (the compute kernel: dispatches).
    pub passes: HashMap<String, u64>,
    /// Total passes drawn.
    pub passes_total: u64,
    /// GPU time per pass kind from timer queries; None (`null`) where the GL has no timer
    /// queries or one of them measured nothing ([`GpuStats::add_gpu_time`]).
    pub gpu_ms: Option<HashMap<String, f64>>,
    /// Sum of `gpu_ms` (None with it).
    pub gpu_ms_total: Option<f64>,
    /// A timer query of this render measured nothing: its GPU time stays unknown.
    #[serde(skip)]
    pub(crate) timers_void: bool,
    /// Wall time of the render's phases: the compute kernel's setup, dispatch, read_back,
    /// aov; the fragment kernels' drain (waiting for the walk's queued passes), srgb8 (the
    /// 8-bit conversion pass of a PNG) and read_back (their passes' GPU time is in `gpu_ms`).
    pub phases_ms: HashMap<String, f64>,
    /// Opening the EGL display and the GL context in the render call (the driver's start;
    /// 0 where the caller gave the context: the window, an animation's later frames).
    pub context_ms: f64,
    /// Shader compile and link time (programs linked from the program-binary cache
    /// included).
    pub compile_ms: f64,
    /// Programs compiled from source for this render.
    pub programs_compiled: u32,
    /// Programs linked from the program-binary cache for this render (`gpu::program_cache`).
    pub programs_cached: u32,
    /// Scene texture upload time.
    pub upload_ms: f64,
    /// Scene texture bytes.
    pub upload_bytes: usize,
    /// Wall time of the pass loop including read-back.
    pub trace_ms: f64,
    /// Termination queries issued.
    pub termination_queries: u64,
    /// Pixels the fragment kernels' advancing passes rasterised, summed over those passes:
    /// each draws only the tiles that held active rays at the last termination query, so
    /// this falls below passes x pixels as rays finish (0 for the compute kernel).
    pub advance_pixels: u64,
    /// Active rays at the last termination query, summed over the same passes: what a
    /// pass over the compacted active rays alone would draw (the floor of stream reduction).
    pub advance_active: u64,
    /// K.
    pub query_every: u32,
    /// Scene features compiled in.
    pub features: Features,
}

impl GpuStats {
    /// Adds the figures of `other`, a render of other pixels of the same frame
    /// ([`BackendOutput::stack_rows`]): passes, times and counts summed; the context, the
    /// kernel and the features stay this render's (the frame's first).
    pub fn absorb(&mut self, other: GpuStats) {
        for (k, n) in other.passes {
            *self.passes.entry(k).or_default() += n;
        }
        self.passes_total += other.passes_total;
        self.timers_void |= other.timers_void;
        match (self.gpu_ms.as_mut(), other.gpu_ms) {
            (Some(a), Some(b)) if !self.timers_void => {
                for (k, ms) in b {
                    *a.entry(k).or_default() += ms;
                }
                self.gpu_ms_total = Some(a.values().sum());
            }
            _ => {
                self.gpu_ms = None;
                self.gpu_ms_total = None;
            }
        }
        for (k, ms) in other.phases_ms {
            *self.phases_ms.entry(k).or_default() += ms;
        }
        self.context_ms += other.context_ms;
        self.compile_ms += other.compile_ms;
        self.programs_compiled += other.programs_compiled;
        self.programs_cached += other.programs_cached;
        self.upload_ms += other.upload_ms;
        self.upload_bytes += other.upload_bytes;
        self.trace_ms += other.trace_ms;
        self.termination_queries += other.termination_queries;
        self.advance_pixels += other.advance_pixels;
        self.advance_active += other.advance_active;
    }

    /// Adds the `ns` a timer query measured for one pass or dispatch of `kind`. A result of
    /// 0 or 1 ns measured nothing, and makes the whole render's GPU time unknown rather
    /// than a figure that reads as real: llvmpipe's `GL_TIME_ELAPSED` is stamped by its
    /// rasterizer threads as they run the draws' bins, and a compute dispatch runs outside
    /// the rasterizer, so the query of a 3-second dispatch returns the unsigned difference
    /// of no stamps, 0 - (2^64 - 1) = 1 ns. A GPU pass, however small, takes microseconds.
    pub fn add_gpu_time(&mut self, kind: &str, ns: u64) {
        if ns <= 1 {
            self.timers_void = true;
        }
        if self.timers_void {
            self.gpu_ms = None;
            self.gpu_ms_total = None;
            return;
        }
        let ms = ns as f64 * 1e-6;
        *self
            .gpu_ms
            .get_or_insert_with(HashMap::new)
            .entry(kind.to_owned())
            .or_default() += ms;
        *self.gpu_ms_total.get_or_insert(0.0) += ms;
    }
}

/// Scene features that decide which shading code the GL backend compiles in (decided in
/// `gpu::shader`, which re-exports it; here so that [`GpuStats`] reports it typed).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize)]
pub struct Features {
    /// Some triangle has vertex normals.
    pub smooth_normals: bool,
    /// Some material uses the procedural checker.
    pub checker: bool,
    /// Some material has a Phong highlight.
    pub specular: bool,
    /// Some material refracts.
    pub refraction: bool,
    /// Some material uses Fresnel weights.
    pub fresnel: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The case, 15,343 rays in 1.2 s, read "0.01 Mrays/s" and a slower GL 2.1
    /// render "0.00 Mrays/s": every rate keeps three figures in a unit that fits.
    #[test]
    fn ray_rates_keep_three_figures_and_never_read_zero() {
        assert_eq!(ray_rate(15_343, 909.6), "16.9 krays/s");
        assert_eq!(ray_rate(15_343, 9159.0), "1.68 krays/s");
        assert_eq!(ray_rate(500, 9159.0), "54.6 rays/s");
        assert_eq!(ray_rate(1, 1e6), "0.00100 rays/s");
        assert_eq!(ray_rate(0, 5.0), "0 rays/s");
        assert_eq!(ray_rate(2_000_000, 1000.0), "2.00 Mrays/s");
        assert_eq!(ray_rate(250_000, 1000.0), "250 krays/s");
        assert_eq!(ray_rate(10, 0.0), "- rays/s");
        for (rays, ms) in [(1, 1e6), (7, 3e4), (15_343, 9159.0), (1 << 40, 1.0)] {
            let r = ray_rate(rays, ms);
            assert!(
                !r.contains("0.00 ") && r != "0 rays/s",
                "{rays} in {ms} ms: {r}"
            );
        }
    }

    /// Timer results add up per kind and in the total; one result that measured nothing
    /// (llvmpipe's 1 ns for a compute dispatch) makes the render's GPU time unknown, `null`
    /// in `--stats`, for the rest of the render too; without any timer it is unknown as well.
    #[test]
    fn gpu_time_adds_up_and_is_unknown_after_a_timer_that_measured_nothing() {
        let mut s = GpuStats::default();
        let json = |s: &GpuStats| serde_json::to_value(s).unwrap();
        assert!(json(&s)["gpu_ms"].is_null() && json(&s)["gpu_ms_total"].is_null());
        s.add_gpu_time("step", 2_000_000);
        s.add_gpu_time("step", 500_000);
        s.add_gpu_time("count", 2);
        let ms = s.gpu_ms.clone().unwrap();
        assert!((ms["step"] - 2.5).abs() < 1e-12, "{ms:?}");
        assert!((ms["count"] - 2e-6).abs() < 1e-18, "{ms:?}");
        assert!((s.gpu_ms_total.unwrap() - 2.500002).abs() < 1e-12);
        assert_eq!(json(&s)["gpu_ms"]["step"], ms["step"]);
        for ns in [1, 0] {
            let mut v = s.clone();
            v.add_gpu_time("compute", ns);
            assert_eq!((v.gpu_ms.clone(), v.gpu_ms_total), (None, None), "{ns} ns");
            v.add_gpu_time("step", 1_000_000);
            assert_eq!((v.gpu_ms.clone(), v.gpu_ms_total), (None, None), "{ns} ns");
            assert!(json(&v)["gpu_ms"].is_null() && json(&v)["gpu_ms_total"].is_null());
        }
    }
}
