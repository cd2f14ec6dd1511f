//! A render on the page, in one of two progress modes ([`Progress`]):
//!
//! - **bands**: one band of rows per animation frame, each band the whole walk over its
//!   rows (`ImageRequest::region`: the same pixels as one full render);
//! - **passes**: the whole image in one walk that pauses after about a frame's work (or
//!   every N passes) and goes on at the next animation frame: the library's
//!   [`render_stepped`], whose observer reads the colour accumulated so far back at each
//!   pause, as `fragtrace view` draws it between passes.
//!
//! Both end with the same image, bit for bit (tests/web.rs).

use std::cell::RefCell;
use std::rc::Rc;

use fragtrace::clock::Instant;
use fragtrace::gpu::options::GpuOptions;
use fragtrace::gpu::pause::Stepped;
use fragtrace::gpu::render::{
    render, render_stepped, Flow, GpuOutput, ImageRequest, Observer, Snapshot,
};
use fragtrace::gpu::GlContext;
use fragtrace::output::{AovPixel, GpuStats, Readback};
use fragtrace::region::Region;
use fragtrace::scene::Camera;

use crate::params::Progress;
use crate::App;

/// Wall time one band aims at, so the page stays responsive while the image fills.
const BAND_TARGET_MS: f64 = 150.0;

/// Wall time of passes one resumption of a pass-by-pass render aims at: about three
/// animation frames, so that the page shows the walk advancing at some 14 frames a second
/// while costing 0 to 15% over one walk without pauses (30 ms cost 30 to 60%: docs/web.md).
const PASSES_TARGET_MS: f64 = 50.0;

/// A resumption runs at least this many times as long as showing its image took (the
/// read-back and the canvas), so that showing costs at most about a fifth of the time
/// where a pass is slow (large images: one 512x512 pass can exceed the target alone).
const PASSES_PER_SHOW: f64 = 4.0;

/// What the observer of a pass-by-pass render saw at its last pause.
#[derive(Default)]
struct Live {
    /// When the current resumption began, and how long it runs (set before each).
    stretch_start: Option<Instant>,
    stretch_ms: f64,
    /// The last pause's read-back time.
    read_ms: f64,
    /// Pause every this many observed passes instead of by time.
    every: Option<u64>,
    /// Passes drawn at the last pause.
    last_pause: u64,
    /// The colour so far: RGBA, bottom row first, each sample weighted 1/samples.
    radiance: Vec<f32>,
    pass: &'static str,
    samples_done: u32,
    samples: u32,
    pauses: u64,
    /// The primary-ray AOVs, copied at the first pause that has them (`taken` after).
    aov: Option<Vec<AovPixel>>,
    aov_taken: bool,
    /// A read-back failed: the render was cancelled for this reason.
    error: Option<String>,
}

/// A pass-by-pass render's walk.
type Walk = Stepped<'static, fragtrace::Result<GpuOutput>>;

/// A render in progress.
pub struct Job {
    pub camera: Camera,
    pub progress: Progress,
    /// Bands: the next row to render, and the band's height.
    pub next_row: u32,
    band: u32,
    /// Passes: the walk and what its observer saw.
    stepped: Option<(Walk, Rc<RefCell<Live>>)>,
    pub passes: u64,
    pub rays: u64,
    pub render_ms: f64,
    pub started: Instant,
    /// Times the canvas showed the render in progress (bands or pauses).
    pub frames: u64,
    /// How long showing the last frame took on the host (image, canvas).
    show_ms: f64,
    /// Time spent showing frames in all: read-backs at the pauses, image and canvas.
    pub show_total_ms: f64,
    /// The last pass drawn and the samples finished, in a pass-by-pass render.
    pub pass: &'static str,
    pub samples_done: u32,
    /// Passes drawn when a pass-by-pass render's AOVs reached the page.
    pub aov_at_pass: Option<u64>,
    pub done: bool,
    /// The cut of the advancing passes to active tiles, summed over the bands (issue 49).
    pub cut: Cut,
}

/// What the advancing passes drew ([`GpuStats::advance_pixels`] and its neighbours).
#[derive(Clone, Copy, Debug, Default)]
pub struct Cut {
    /// Advancing passes (traversal steps and intersections, unrolled or looped passes).
    pub passes: u64,
    /// Pixels they would draw as full-screen quads.
    pub full: u64,
    /// Pixels they drew.
    pub drawn: u64,
    /// Active rays at the termination query before each, summed.
    pub active: u64,
    pub termination_queries: u64,
}

impl Cut {
    /// Adds a render's (or a band's) stats, of `pixels` pixels.
    fn add(&mut self, g: &GpuStats, pixels: u64) {
        let passes: u64 = g
            .passes
            .iter()
            .filter(|(k, _)| {
                ["traverse_step", "intersect", "looped", "unrolled"]
                    .iter()
                    .any(|p| k.starts_with(p))
            })
            .map(|(_, n)| n)
            .sum();
        self.passes += passes;
        self.full += passes * pixels;
        self.drawn += g.advance_pixels;
        self.active += g.advance_active;
        self.termination_queries += g.termination_queries;
    }

    /// The report's fields, each followed by a comma.
    pub fn json(&self) -> String {
        format!(
            "\"advance_passes\":{},\"advance_full_pixels\":{},\"advance_pixels\":{},\
             \"advance_active\":{},\"termination_queries\":{},",
            self.passes, self.full, self.drawn, self.active, self.termination_queries
        )
    }
}

impl Job {
    /// A render from `camera`; `band`: the first band's rows (bands only).
    pub fn new(camera: Camera, progress: Progress, band: u32) -> Job {
        Job {
            camera,
            progress,
            next_row: 0,
            band,
            stepped: None,
            passes: 0,
            rays: 0,
            render_ms: 0.0,
            started: Instant::now(),
            frames: 0,
            show_ms: 0.0,
            show_total_ms: 0.0,
            pass: "",
            samples_done: 0,
            aov_at_pass: None,
            done: false,
            cut: Cut::default(),
        }
    }
}

/// The observer of a pass-by-pass render: pauses when the resumption has run its time (or
/// `every` passes) and reads the colour so far back for the page.
fn pausing_observer(ctx: &'static GlContext, live: Rc<RefCell<Live>>) -> Box<Observer<'static>> {
    Box::new(move |s: &Snapshot| {
        let mut l = live.borrow_mut();
        let due = match l.every {
            Some(n) => s.passes >= l.last_pause + n,
            None => l
                .stretch_start
                .is_some_and(|t| t.elapsed().as_secs_f64() * 1e3 >= l.stretch_ms),
        };
        if !due {
            return Flow::Continue;
        }
        let t = Instant::now();
        let read = s.radiance.read_f32(ctx);
        l.read_ms = t.elapsed().as_secs_f64() * 1e3;
        match read {
            Ok(r) => l.radiance = r,
            Err(e) => {
                l.error = Some(format!("reading the image between passes: {e}"));
                return Flow::Cancel;
            }
        }
        l.last_pause = s.passes;
        l.pass = s.pass;
        l.samples_done = s.samples_done;
        l.samples = s.samples;
        l.pauses += 1;
        if let (Some(a), false) = (s.aov, l.aov_taken) {
            l.aov = Some(a.pixels.clone());
            l.aov_taken = true;
        }
        Flow::Pause
    })
}

impl App {
    /// Whether renders read the primary-ray AOVs back (WebGL 2: the fourth attachment).
    pub fn reads_aov(&self) -> bool {
        self.ctx.info.dialect.has_read_buffer()
    }

    /// The request for `camera` over `region` (None: the whole image).
    fn request(&self, camera: Camera, region: Option<Region>) -> ImageRequest {
        // The scene's options (the query's render flags), with the control's samples and
        // the kernel resolved for this context.
        let opts = self.opts.as_ref().expect("a scene");
        ImageRequest {
            camera,
            width: self.width,
            height: self.height,
            spp: self.spp,
            max_depth: opts.max_depth,
            techniques: opts.techniques,
            progress: false,
            gpu: GpuOptions {
                kernel: self.params.kernel,
                tiles: self.params.tiles,
                ..opts.gpu
            },
            readback: Readback {
                aov: self.reads_aov(),
                srgb8: false,
            },
            region,
        }
    }

    /// Advances the job by one band or one resumption, and shows the result.
    pub fn step(&mut self) -> Result<(), String> {
        let Some(job) = self.job.as_ref() else {
            return Ok(());
        };
        match job.progress {
            Progress::Bands => self.step_band()?,
            Progress::Passes { every } => self.step_passes(every)?,
        }
        let t = Instant::now();
        self.status = self.job_status();
        self.redraw();
        self.present()?;
        let job = self.job.as_mut().expect("job");
        let ms = t.elapsed().as_secs_f64() * 1e3;
        job.show_ms += ms;
        job.show_total_ms += ms;
        job.frames += 1;
        if job.done {
            let job = self.job.take().expect("job");
            if !self.reported {
                if let Some(url) = self.params.report.clone() {
                    self.reported = true;
                    self.post_report(&url, &job);
                }
            }
        }
        Ok(())
    }

    fn step_band(&mut self) -> Result<(), String> {
        let (w, h) = (self.width, self.height);
        let job = self.job.as_ref().expect("job");
        let (y0, y1) = (job.next_row, (job.next_row + job.band).min(h));
        let req = self.request(
            job.camera,
            Some(Region {
                x0: 0,
                y0,
                x1: w,
                y1,
            }),
        );
        let gs = self.loaded.as_ref().expect("scene").gs();
        let t = Instant::now();
        let out = render(gs, &req, None).map_err(|e| e.to_string())?;
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let start = y0 as usize * w as usize;
        let end = y1 as usize * w as usize;
        self.image[start * 3..end * 3].copy_from_slice(&out.image.data);
        if self.reads_aov() {
            self.aov[start..end].copy_from_slice(&out.aov.pixels);
            self.aov_rows = y1;
        }
        let fixed_band = self.params.band.is_some();
        let job = self.job.as_mut().expect("job");
        job.render_ms += ms;
        job.passes += out.gpu.as_ref().map_or(0, |g| g.passes_total);
        job.rays += out.rays.total;
        if let Some(g) = &out.gpu {
            job.cut.add(g, w as u64 * (y1 - y0) as u64);
        }
        job.next_row = y1;
        job.done = y1 >= h;
        // Adapt the band to the frame budget (a fixed band when the query string sets one).
        if !fixed_band {
            let per_row = ms / (y1 - y0) as f64;
            job.band = ((BAND_TARGET_MS / per_row.max(1e-3)) as u32).clamp(1, h);
        }
        Ok(())
    }

    fn step_passes(&mut self, every: Option<u64>) -> Result<(), String> {
        if self.job.as_ref().expect("job").stepped.is_none() {
            let camera = self.job.as_ref().expect("job").camera;
            let req = self.request(camera, None);
            let live = Rc::new(RefCell::new(Live {
                every,
                ..Live::default()
            }));
            let gs = self.loaded.as_ref().expect("scene").gs_shared();
            let stepped = render_stepped(gs, req, pausing_observer(self.ctx, live.clone()));
            self.job.as_mut().expect("job").stepped = Some((stepped, live));
        }
        let reads_aov = self.reads_aov();
        let job = self.job.as_mut().expect("job");
        let (stepped, live) = job.stepped.as_mut().expect("stepped");
        {
            let mut l = live.borrow_mut();
            l.stretch_ms = PASSES_TARGET_MS.max(PASSES_PER_SHOW * (l.read_ms + job.show_ms));
            l.stretch_start = Some(Instant::now());
        }
        let t = Instant::now();
        let r = stepped.resume();
        job.render_ms += t.elapsed().as_secs_f64() * 1e3;
        let mut l = live.borrow_mut();
        if let Some(e) = l.error.take() {
            return Err(e);
        }
        match r {
            None => {
                job.passes = l.last_pause;
                job.pass = l.pass;
                job.samples_done = l.samples_done;
                // The accumulator weighs each sample 1/spp: scale the samples begun so far
                // to full brightness.
                let begun = (l.samples_done + 1).min(l.samples.max(1));
                let scale = l.samples.max(1) as f32 / begun as f32;
                let radiance = std::mem::take(&mut l.radiance);
                let l_read_ms = l.read_ms;
                if let Some(aov) = l.aov.take() {
                    // After the first sample's primary wave: the display can show it now.
                    self.aov = aov;
                    self.aov_rows = self.height;
                    job.aov_at_pass = Some(l.last_pause);
                }
                drop(l);
                let t = Instant::now();
                flip_into(&radiance, self.width, self.height, scale, &mut self.image);
                job.show_ms = t.elapsed().as_secs_f64() * 1e3;
                job.show_total_ms += job.show_ms + l_read_ms;
            }
            Some(Err(e)) => return Err(e.to_string()),
            Some(Ok(out)) => {
                drop(l);
                job.passes = out.gpu.as_ref().map_or(0, |g| g.passes_total);
                job.rays = out.rays.total;
                if let Some(g) = &out.gpu {
                    job.cut.add(g, self.width as u64 * self.height as u64);
                }
                job.samples_done = self.spp;
                job.done = true;
                job.stepped = None;
                self.image = out.image.data;
                if reads_aov {
                    job.aov_at_pass.get_or_insert(job.passes);
                    self.aov = out.aov.pixels;
                    self.aov_rows = self.height;
                }
            }
        }
        Ok(())
    }

    /// The status line of the job.
    fn job_status(&self) -> String {
        let job = self.job.as_ref().expect("job");
        let (w, h) = (self.width, self.height);
        let head = format!(
            "{}: {w}x{h}, {} kernel, {} spp",
            self.scene_name, self.params.kernel, self.spp
        );
        let wall = job.started.elapsed().as_secs_f64() * 1e3;
        if job.done {
            // No rate where the clock did not move (a browser's virtual time).
            let rate = match job.render_ms {
                ms if ms > 0.0 => format!(" ({:.3} Mrays/s)", job.rays as f64 / ms * 1e-3),
                _ => String::new(),
            };
            return format!(
                "{head}, {}: {} passes, {} rays, render {:.0} ms{rate}, wall {:.0} ms, \
                 {} frames - done",
                job.progress.name(),
                job.passes,
                job.rays,
                job.render_ms,
                wall,
                job.frames + 1
            );
        }
        match job.progress {
            Progress::Bands => format!(
                "{head}, bands: rows {}/{h}, {} passes, {} rays, render {:.0} ms, wall {:.0} ms",
                job.next_row, job.passes, job.rays, job.render_ms, wall
            ),
            Progress::Passes { .. } => format!(
                "{head}, pass by pass: sample {}/{}, pass {} ({}), render {:.0} ms, \
                 wall {:.0} ms, frame {}",
                (job.samples_done + 1).min(self.spp),
                self.spp,
                job.passes,
                job.pass,
                job.render_ms,
                wall,
                job.frames + 1
            ),
        }
    }
}

/// GL's RGBA rows (bottom first) into the page's RGB rows (top first), times `scale`.
fn flip_into(rgba: &[f32], w: u32, h: u32, scale: f32, rgb: &mut [f32]) {
    let w = w as usize;
    for (row, out) in rgb.chunks_mut(w * 3).enumerate() {
        let gl_row = h as usize - 1 - row;
        let src = &rgba[gl_row * w * 4..(gl_row + 1) * w * 4];
        for (o, i) in out.chunks_mut(3).zip(src.chunks(4)) {
            for k in 0..3 {
                o[k] = i[k] * scale;
            }
        }
    }
}

/// A miss everywhere: the AOV of rows not rendered yet.
pub fn empty_aov(w: u32, h: u32) -> Vec<AovPixel> {
    vec![AovPixel::miss(0.0); (w * h) as usize]
}
