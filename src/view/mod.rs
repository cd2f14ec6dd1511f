//! `fragtrace view`: the GPU renderer in a window, drawing the render as it happens.
//!
//! The window is another surface, not another ray tracer: its GL context (glutin, on X11)
//! is wrapped as a [`GlContext`] ([`GlContext::from_external`]) and the same
//! [`gpu::render::render`](crate::gpu::render::render) as the headless path renders into it. Its observer, called
//! between passes, pumps the window's events (a camera change cancels the render within
//! one pass) and presents the render in progress every `--frame-ms` milliseconds or every
//! `--passes-per-frame` passes, so the multipass wave is seen advancing; a finished
//! render is shown as the exact bytes `fragtrace render` would write.
//!
//! - [`control`]: orbit, pan and zoom as pure functions, and the mouse controller;
//! - [`keys`]: the key table and actions;
//! - [`script`]: keys and mouse moves given up front (`--keys`, `--script`);
//! - `present`: drawing into the window and reading it back;
//! - `window`: the winit window and glutin context.

pub mod control;
pub mod keys;
mod present;
pub mod script;
mod window;

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use winit::application::ApplicationHandler;
use winit::event::{ElementState, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::platform::pump_events::{EventLoopExtPumpEvents, PumpStatus};
use winit::window::WindowId;

use crate::aov::{self, AovKind};
use crate::gpu::options::{Kernel, Mask};
use crate::gpu::render::ImageRequest;
use crate::gpu::render::{render, Advance, Flow, GpuOutput, Snapshot};
use crate::gpu::{GlContext, GpuScene};
use crate::image_io::{to_srgb8, write_atomic, Image};
use crate::options::{RenderOptions, MAX_DEPTH};
use crate::scene::Scene;
use crate::{Error, Result};

pub use keys::KEYS_HELP;
/// Re-exported so that callers (the tests) can build the window events the controller
/// takes ([`control::translate`]).
pub use winit;

use control::Controller;
use keys::{Action, Display};
use present::Presenter;

/// How `view` runs: the render options (size, samples, depth, kernel, mask, ...) and the
/// automation flags.
#[derive(Clone, Debug)]
pub struct ViewOptions {
    /// The render: the window's initial size is `render.width` x `render.height`.
    pub render: RenderOptions,
    /// Stop after this many presented frames (or when the render is complete); playing,
    /// after this many frames of the camera path, each rendered to the end.
    pub frames: Option<u64>,
    /// Write the window's content here (PNG) when stopping for `frames` or completion.
    pub screenshot: Option<PathBuf>,
    /// Present every this many passes instead of by time (reproducible frames).
    pub passes_per_frame: Option<u64>,
    /// Present at most this often while rendering (milliseconds).
    pub frame_ms: f64,
    /// Start playing the scene's camera path (`--play`; `p` toggles it).
    pub play: bool,
    /// Start with the tiles the passes draw outlined (`--show-tiles`; `t` toggles it).
    pub show_tiles: bool,
    /// Input given up front (`--keys`, `--script`), applied one step each time the view is
    /// idle ([`script`]).
    pub script: Vec<script::Step>,
}

impl ViewOptions {
    /// Whether the view runs without a person: it stops on its own.
    fn automated(&self) -> bool {
        self.frames.is_some() || self.screenshot.is_some()
    }
}

/// The settings the keys change.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Settings {
    kernel: Kernel,
    max_depth: u32,
    mask: Mask,
    display: Display,
    /// Outline the tiles the advancing passes draw in the frames of a render in progress.
    tiles: bool,
}

/// Input state between two pumps of the event loop.
struct Handler {
    controller: Controller,
    settings: Settings,
    /// The render must start over (camera, settings or size changed).
    restart: bool,
    /// The picture must be shown again (exposed, or the display changed).
    redraw: bool,
    /// `s` was pressed.
    screenshot: bool,
    quit: bool,
    resized: Option<winit::dpi::PhysicalSize<u32>>,
    /// The window's context has compute shaders (`k` offers the compute kernel).
    compute: bool,
    /// `p`: play the scene's camera path (the frame shown next), or paused.
    playing: bool,
}

impl Handler {
    /// Applies one scripted step as the key or the mouse would.
    fn step(&mut self, step: script::Step) {
        match step {
            script::Step::Key(action) => self.apply(action),
            mouse => self.restart |= mouse.drive(&mut self.controller),
        }
    }

    fn apply(&mut self, action: Action) {
        let s = &mut self.settings;
        match action {
            Action::NextKernel => s.kernel = keys::next_kernel(s.kernel, self.compute),
            Action::DepthUp => s.max_depth = (s.max_depth + 1).min(MAX_DEPTH),
            Action::DepthDown => s.max_depth = s.max_depth.saturating_sub(1),
            Action::ToggleMask => {
                s.mask = match s.mask {
                    Mask::None => Mask::EarlyZ,
                    _ => Mask::None,
                }
            }
            Action::NextDisplay => {
                s.display = s.display.next();
                self.redraw = true;
                return;
            }
            // Shown from the next frame of a render in progress; a finished picture has
            // no tiles.
            Action::ToggleTiles => {
                s.tiles = !s.tiles;
                return;
            }
            Action::Screenshot => {
                self.screenshot = true;
                return;
            }
            Action::ResetCamera => {
                self.restart |= self.controller.reset();
                return;
            }
            Action::Play => {
                self.playing = !self.playing;
                self.restart |= self.playing;
                return;
            }
            Action::Help => {
                println!("{KEYS_HELP}");
                return;
            }
            Action::Quit => {
                self.quit = true;
                return;
            }
        }
        self.restart = true;
    }

    /// Whether the render in flight must stop.
    fn interrupted(&self) -> bool {
        self.quit || self.restart || self.resized.is_some()
    }
}

impl ApplicationHandler for Handler {
    fn resumed(&mut self, _: &ActiveEventLoop) {}

    fn window_event(&mut self, _: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        if let Some(input) = control::translate(&event) {
            self.restart |= self.controller.handle(input);
            return;
        }
        match event {
            WindowEvent::CloseRequested | WindowEvent::Destroyed => self.quit = true,
            WindowEvent::Resized(size) => self.resized = Some(size),
            WindowEvent::RedrawRequested => self.redraw = true,
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                let key = match &event.logical_key {
                    Key::Character(c) => c.to_string(),
                    Key::Named(NamedKey::Escape) => "Escape".to_string(),
                    _ => return,
                };
                if let Some(action) = keys::action_for(&key) {
                    self.apply(action);
                }
            }
            _ => {}
        }
    }
}

/// The figures the title shows.
#[derive(Default)]
struct TitleStats {
    passes: u64,
    samples_done: u32,
    /// Rays traced and the milliseconds they took (the trace, set-up excluded).
    rays: Option<(u64, f64)>,
    ms_per_frame: f64,
    note: String,
    /// The reduction at work ([`cut_note`]), empty for the compute kernel.
    cut: String,
}

/// What the last advancing pass of a render in progress drew: its share of the image's
/// pixels, the rectangles (runs of active tiles), and the rays active in them.
fn cut_note(a: &Advance, pixels: u64) -> String {
    format!(
        " | pass drew {:.0}% ({} px, {} rects), {} rays active",
        100.0 * a.pixels as f64 / pixels.max(1) as f64,
        a.pixels,
        a.rects.len(),
        a.active
    )
}

/// A finished render's reduction: the advancing passes' pixels against as many full-screen
/// quads, and the active rays' share (the floor of stream reduction).
fn cut_total(g: &crate::output::GpuStats, pixels: u64) -> String {
    let passes: u64 = g
        .passes
        .iter()
        .filter(|(k, _)| {
            ["traverse_step", "intersect", "unrolled", "looped"]
                .iter()
                .any(|p| k.starts_with(p))
        })
        .map(|(_, n)| n)
        .sum();
    if passes == 0 {
        return String::new();
    }
    let full = (passes * pixels).max(1) as f64;
    format!(
        " | traversal passes drew {:.0}% of the image ({:.0}% active)",
        100.0 * g.advance_pixels as f64 / full,
        100.0 * g.advance_active as f64 / full
    )
}

fn title(s: &Settings, spp: u32, t: &TitleStats) -> String {
    let rays = t.rays.map_or("- rays/s".to_string(), |(n, ms)| {
        crate::output::ray_rate(n, ms)
    });
    let mask = if s.mask == Mask::EarlyZ {
        " | early-z"
    } else {
        ""
    };
    format!(
        "fragtrace view: {} | depth {} | {} passes | {rays} | {:.0} ms/frame | {}/{spp} spp | {}{}{mask}{}",
        s.kernel,
        s.max_depth,
        t.passes,
        t.ms_per_frame,
        t.samples_done,
        s.display.name(),
        t.note,
        t.cut,
    )
}

/// The picture of a finished render for `display`: 8-bit sRGB RGB, top row first, and a
/// note for the title.
fn picture(out: &GpuOutput, display: Display) -> (Vec<u8>, String) {
    let (w, h) = (out.image.width, out.image.height);
    match display {
        Display::Image => (to_srgb8(&out.image), String::new()),
        Display::Aov(AovKind::Steps) => {
            let steps: Vec<f32> = out.aov.pixels.iter().map(|p| p.steps).collect();
            let max = steps
                .iter()
                .copied()
                .filter(|s| s.is_finite())
                .fold(0.0, f32::max);
            // The heat map carries its colour bar on the right; the window shows the map.
            let map = aov::heat_map(w, h, &steps);
            let mut data = Vec::with_capacity((w * h * 3) as usize);
            for j in 0..h {
                let row = (j * map.width * 3) as usize;
                data.extend_from_slice(&map.data[row..row + (w * 3) as usize]);
            }
            (
                to_srgb8(&Image::from_rgb(w, h, data)),
                format!(" (max {max})"),
            )
        }
        Display::Aov(kind) => (to_srgb8(&aov::preview(&out.aov, kind)), String::new()),
    }
}

/// Writes 8-bit RGB (top row first) as a PNG, atomically.
fn write_png(path: &Path, w: u32, h: u32, rgb: &[u8]) -> Result<()> {
    write_atomic(path, |tmp| {
        image::save_buffer_with_format(
            tmp,
            rgb,
            w,
            h,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| Error::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    })
}

/// Reads the window's back buffer and writes it to `path`.
fn screenshot(ctx: &GlContext, size: (u32, u32), path: &Path) -> Result<()> {
    let rgb = present::read_window(ctx, size.0, size.1)?;
    write_png(path, size.0, size.1, &rgb)
}

/// `fragtrace-view-N.png` with the first N not taken in the current folder.
fn screenshot_name() -> PathBuf {
    (1..)
        .map(|n| PathBuf::from(format!("fragtrace-view-{n}.png")))
        .find(|p| !p.exists())
        .expect("some free name")
}

/// Opens the window and runs the view until it is closed (or, automated, until the frames
/// are shown and the screenshot written). No display or no adequate GL context is
/// [`Error::GlUnavailable`].
pub fn run(scene: Scene, opts: &ViewOptions) -> Result<()> {
    // The same front door as `render`: the structure `--accel` names, built once (an
    // instanced scene's two levels where every kernel of the `k` key walks them:
    // `RenderOptions::for_view`).
    let ro = &opts.render;
    let prepared = crate::render::prepare(&scene, ro)?;
    let mut event_loop: EventLoop<()> = window::event_loop()?;
    let (win, ctx) = window::open(&event_loop, ro.width, ro.height, "fragtrace view")?;
    eprintln!(
        "fragtrace view: {}: OpenGL {} ({})",
        ctx.info.egl_platform, ctx.info.gl_version, ctx.info.renderer
    );
    let built = &prepared.summary;
    eprintln!(
        "fragtrace view: {} grid, {} cells, {} references, built in {:.1} ms",
        built.kind.name(),
        built.cells,
        built.references,
        built.build_ms
    );
    // Uploaded once: every render of the view (each camera move, each key) reuses the
    // scene's textures and programs.
    // The scene prepared: an instanced scene taken flat has its placed triangles there.
    let gs = GpuScene::new(&ctx, &prepared.scene, &prepared.accel, ro.gpu.no_specialize)?
        .with_program_cache(ro.gpu.shader_cache.open(&ctx.info));
    let mut presenter = Presenter::new(&ctx)?;
    let inner = win.window.inner_size();
    let mut size = (inner.width, inner.height);
    let mut h = Handler {
        controller: Controller::new(scene.camera, size.1),
        settings: Settings {
            kernel: ro.gpu.kernel,
            max_depth: ro.max_depth,
            mask: ro.gpu.mask,
            display: Display::Image,
            tiles: opts.show_tiles,
        },
        restart: true,
        redraw: false,
        screenshot: false,
        quit: false,
        resized: None,
        compute: ctx.info.compute,
        playing: opts.play,
    };
    // The camera path `p` plays: its frames in a loop, each the camera of a whole render.
    // `frame` moves on only when its render completes: a render cut short (a resize as the
    // window maps, a key) renders the same frame again, so `--play --frames N` shows
    // frame N - 1 of the path however the renders were interrupted or watched.
    let path = scene.animation.clone();
    let mut frame = path.as_ref().map_or(0, |p| *p.frames().start());
    if h.playing && path.is_none() {
        // `fragtrace view --play` refuses a still scene before the window opens.
        eprintln!("fragtrace view: the scene has no [animation] to play");
        h.playing = false;
    }
    let mut last: Option<GpuOutput> = None;
    let mut stats = TitleStats::default();
    let mut frames = 0u64;
    // Path frames rendered to the end while playing.
    let mut played = 0u64;
    let mut script: VecDeque<script::Step> = opts.script.iter().copied().collect();
    // No render is due or running: the script's next step may be applied.
    let mut idle = false;
    let budget = Duration::from_secs_f64(opts.frame_ms.max(0.0) / 1e3);
    let automated = opts.automated();
    loop {
        // Checked before waiting: a quit seen during a render must not wait for an event.
        if h.quit {
            return Ok(());
        }
        let wait = if h.restart || automated || (idle && !script.is_empty()) {
            Some(Duration::ZERO)
        } else {
            None
        };
        if let PumpStatus::Exit(_) = event_loop.pump_app_events(wait, &mut h) {
            return Ok(());
        }
        if h.quit {
            return Ok(());
        }
        if idle {
            if let Some(step) = script.pop_front() {
                let due = std::mem::take(&mut h.restart);
                h.step(step);
                // A step that starts a render is seen through before the next one.
                idle = !h.restart;
                h.restart |= due;
            }
        }
        if let Some(s) = h.resized.take() {
            win.resize(s);
            if (s.width, s.height) != size && s.width > 0 && s.height > 0 {
                size = (s.width, s.height);
                h.controller.height = size.1;
                h.restart = true;
            }
            h.redraw = true;
        }
        if h.redraw {
            h.redraw = false;
            if let Some(out) = &last {
                let (rgb, note) = picture(out, h.settings.display);
                presenter.set_picture(&ctx, out.image.width, out.image.height, &rgb)?;
                stats.note = note;
                win.window.set_title(&title(&h.settings, ro.spp, &stats));
            }
            if presenter.has_picture() {
                presenter.draw_picture(&ctx, size.0, size.1)?;
                win.swap()?;
            }
        }
        if h.screenshot {
            h.screenshot = false;
            if !presenter.has_picture() {
                eprintln!("fragtrace: no finished frame to save yet");
                continue;
            }
            presenter.draw_picture(&ctx, size.0, size.1)?;
            let path = screenshot_name();
            screenshot(&ctx, size, &path)?;
            win.swap()?;
            println!("fragtrace: wrote {}", path.display());
        }
        // Automated, the view stops once the script is through and the last render is
        // complete (playing with --frames N: the N-th frame of the path), the screenshot
        // showing that render as the window does.
        let through = idle
            && script.is_empty()
            && match (h.playing, opts.frames) {
                (true, Some(n)) => played >= n,
                _ => true,
            };
        if automated && through && presenter.has_picture() {
            presenter.draw_picture(&ctx, size.0, size.1)?;
            if let Some(path) = &opts.screenshot {
                screenshot(&ctx, size, path)?;
            }
            win.swap()?;
            return Ok(());
        }
        if !h.restart {
            continue;
        }
        h.restart = false;
        idle = false;

        // One render of the whole image at the current camera and settings; playing, the
        // camera of the path's current frame.
        if let (true, Some(p)) = (h.playing, &path) {
            h.controller.camera = p.camera_at(frame);
        }
        let req = ImageRequest {
            camera: h.controller.camera,
            width: size.0,
            height: size.1,
            spp: ro.spp,
            max_depth: h.settings.max_depth,
            techniques: ro.techniques,
            progress: false,
            gpu: crate::gpu::options::GpuOptions {
                kernel: h.settings.kernel,
                // Key `z` masks the fragment kernels' passes; the compute kernel (key `k`)
                // draws none, and would refuse a mask it cannot use.
                mask: match h.settings.kernel {
                    Kernel::Compute => Mask::Auto,
                    _ => h.settings.mask,
                },
                ..ro.gpu
            },
            readback: crate::output::Readback::default(),
            region: None,
        };
        presenter.start_render();
        let t0 = Instant::now();
        let mut last_present = t0;
        let mut passes_at_present = 0u64;
        let mut failure: Option<Error> = None;
        let mut done = false;
        let result = {
            let mut observer = |snap: &Snapshot| -> Flow {
                let _ = event_loop.pump_app_events(Some(Duration::ZERO), &mut h);
                if h.interrupted() {
                    return Flow::Cancel;
                }
                // `s` during a render saves the frame in progress: present it now.
                let due = h.screenshot
                    || match opts.passes_per_frame {
                        Some(p) => snap.passes >= passes_at_present + p,
                        None => last_present.elapsed() >= budget,
                    };
                if !due {
                    return Flow::Continue;
                }
                stats.ms_per_frame = last_present.elapsed().as_secs_f64() * 1e3;
                stats.passes = snap.passes;
                stats.samples_done = snap.samples_done;
                stats.cut = snap.advance.map_or(String::new(), |a| {
                    cut_note(&a, size.0 as u64 * size.1 as u64)
                });
                passes_at_present = snap.passes;
                last_present = Instant::now();
                let tiles = h.settings.tiles.then_some(()).and(snap.advance);
                let shown = presenter
                    .draw_live(&ctx, snap, size.0, size.1, tiles.as_ref())
                    .and_then(|()| {
                        frames += 1;
                        // Playing, --frames counts the path's frames, rendered to the end.
                        let count = opts.frames.filter(|_| !h.playing);
                        match (&opts.screenshot, count) {
                            (Some(path), Some(n)) if frames >= n => {
                                done = true;
                                screenshot(&ctx, size, path)
                            }
                            _ if h.screenshot => {
                                h.screenshot = false;
                                let path = screenshot_name();
                                println!("fragtrace: wrote {}", path.display());
                                screenshot(&ctx, size, &path)
                            }
                            _ => {
                                done = count.is_some_and(|n| frames >= n);
                                Ok(())
                            }
                        }
                    })
                    .and_then(|()| win.swap());
                let t = title(&h.settings, ro.spp, &stats);
                win.window.set_title(&t);
                // Without a person the title is not seen: each frame's goes to stderr.
                if automated {
                    eprintln!("{t}");
                }
                if let Err(e) = shown {
                    failure = Some(e);
                    return Flow::Cancel;
                }
                if done {
                    Flow::Cancel
                } else {
                    Flow::Continue
                }
            };
            render(&gs, &req, Some(&mut observer))
        };
        if let Some(e) = failure {
            return Err(e);
        }
        match result {
            Ok(out) => {
                let ms = t0.elapsed().as_secs_f64() * 1e3;
                stats.ms_per_frame = ms;
                let gpu = out.gpu.as_ref().expect("a GPU render has GPU statistics");
                stats.passes = gpu.passes_total;
                stats.samples_done = ro.spp;
                stats.rays = Some((out.rays.total, gpu.trace_ms));
                stats.cut = cut_total(gpu, size.0 as u64 * size.1 as u64);
                let (rgb, note) = picture(&out, h.settings.display);
                stats.note = note;
                presenter.set_picture(&ctx, size.0, size.1, &rgb)?;
                presenter.draw_picture(&ctx, size.0, size.1)?;
                frames += 1;
                last = Some(out);
                let t = title(&h.settings, ro.spp, &stats);
                win.window.set_title(&t);
                // Without a person the title is not seen: each frame's goes to stderr.
                if automated {
                    eprintln!("{t}");
                }
                win.swap()?;
                idle = true;
                // Playing: the next frame of the path starts at once.
                if let (true, Some(p)) = (h.playing, &path) {
                    played += 1;
                    frame = if frame >= *p.frames().end() {
                        *p.frames().start()
                    } else {
                        frame + 1
                    };
                    h.restart = true;
                }
            }
            Err(Error::Cancelled) if done => return Ok(()),
            // Input arrived: start over once it is handled (a resize to the same size, say,
            // changes nothing but still stopped this render).
            Err(Error::Cancelled) => h.restart = true,
            Err(e) => return Err(e),
        }
    }
}
