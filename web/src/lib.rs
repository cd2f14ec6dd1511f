//! fragtrace's faithful multipass kernel in a web page (docs/web.md): the library built for
//! wasm32-unknown-unknown renders on the page's WebGL 2 context (WebGL 1 where there is no
//! 2, or with `webgl=1`) through glow, with the passes generated in GLSL ES 3.00 (1.00) from
//! the same sources as the native GLSL 1.20.
//!
//! The page ([`start`]) picks a shipped scene (embedded) or takes a dropped TOML with its
//! OBJ/MTL files and texture images (meshes and images the shipped scenes name are fetched
//! from `models/` next to the page when served, never shipped: `files`). A render shows
//! its progress in bands of rows or pass by pass (`job`); dragging orbits the camera and restarts. Controls pick what is shown
//! (the colour or a primary-ray AOV, without rendering again), the progress mode and the
//! samples per pixel. The query string (`params`) sets their first values and what a test
//! needs: `scene=NAME`, `size=WxH`, `webgl=1|2`, `aov=colour|depth|normal|primid|steps`
//! (AOVs on WebGL 2), `spp=N`, `progress=passes|passes:N|bands` (default `passes`, or
//! `bands` where `band=` is given),
//! `kernel=multipass|unrolled:K|looped` (looped on WebGL 2), `accel=irregular|uniform`,
//! `band=ROWS|full`, `tiles=on|off` (traversal passes cut to active tiles, or full), and
//! `report=URL`, to which the first finished render is POSTed (the
//! linear image, the primary-ray AOVs where read, and the canvas as shown) with the
//! passes, time and WebGL limits in the `X-Fragtrace-Report` header (JSON); an error is
//! POSTed there as `X-Fragtrace-Error`.

// Every `unsafe` block says, in a `// SAFETY:` comment, the invariant that makes it sound
// (as in the library).
#![deny(clippy::undocumented_unsafe_blocks)]

mod files;
mod job;
mod params;

use std::cell::RefCell;
use std::rc::Rc;

use fragtrace::accel::Accel;
use fragtrace::aov::{heat_map, preview, AovKind};
use fragtrace::choices::Door;
use fragtrace::clock::Instant;
use fragtrace::gpu::contract::{REQUIRED_TEXTURE_UNITS, TEXTURED_TEXTURE_UNITS};
use fragtrace::gpu::options::Kernel;
use fragtrace::gpu::{GlContext, GpuScene};
use fragtrace::options::{RenderOptions, MAX_SPP};
use fragtrace::output::{Aov, AovPixel};
use fragtrace::scene::{
    load_scene_str_with_files, mtl_texture_files, Camera, MeshImages, MeshTexts, Scene,
};
use wasm_bindgen::prelude::*;
use wasm_bindgen::JsCast;

use files::{fetch_bytes, fetch_text, install_drop, post};
use job::{empty_aov, Job};
use params::{parse_show, show_name, Params, Progress, Show};

/// The shipped scenes, embedded (their meshes are not).
const SCENES: &[(&str, &str)] = &[
    ("whitted", include_str!("../../scenes/whitted.toml")),
    ("glass", include_str!("../../scenes/glass.toml")),
    ("lights", include_str!("../../scenes/lights.toml")),
    ("turntable", include_str!("../../scenes/turntable.toml")),
    ("bunny", include_str!("../../scenes/bunny.toml")),
    ("ground", include_str!("../../scenes/ground.toml")),
    ("cornell", include_str!("../../scenes/cornell.toml")),
    ("teapot", include_str!("../../scenes/teapot.toml")),
    ("dragon", include_str!("../../scenes/dragon.toml")),
    ("stadium", include_str!("../../scenes/stadium.toml")),
    ("sponza", include_str!("../../scenes/sponza.toml")),
    ("duck-table", include_str!("../../scenes/duck-table.toml")),
];

/// A scene on the GPU. The scene and its grid are leaked boxes that the [`GpuScene`]
/// borrows for as long as it lives; `Drop` frees the GPU scene first, then them. A
/// pass-by-pass render holds the GPU scene too (an `Rc`): the page drops the render first.
struct Loaded {
    gs: Option<Rc<GpuScene<'static>>>,
    scene: *mut Scene,
    accel: *mut Accel,
}

impl Loaded {
    /// The scene with the structure `opts` name built and uploaded (the GPU's: `auto` is
    /// the irregular grid).
    fn new(
        ctx: &'static GlContext,
        scene: Scene,
        opts: &RenderOptions,
    ) -> fragtrace::Result<Loaded> {
        // The page's kernels walk scenes stored flat (the two levels of `fragtrace render`
        // are not carried over to WebGL): an instanced scene's placed triangles are stored,
        // as `render` stores them for the irregular grid.
        let scene = if scene.has_instances() {
            scene.flattened(fragtrace::options::MAX_HOST_BYTES, "the web page")?
        } else {
            scene
        };
        let accel = Accel::build(
            &scene,
            opts.accel.resolve(true),
            &opts.grid,
            &opts.irregular,
        )?;
        let scene = Box::into_raw(Box::new(scene));
        let accel = Box::into_raw(Box::new(accel));
        // SAFETY: both boxes live until `drop`, which drops the GPU scene before them.
        let (s, a) = unsafe { (&*scene, &*accel) };
        let mut loaded = Loaded {
            gs: None,
            scene,
            accel,
        };
        loaded.gs = Some(Rc::new(GpuScene::new(
            ctx,
            s,
            a.as_ref(),
            opts.gpu.no_specialize,
        )?));
        Ok(loaded)
    }

    fn gs(&self) -> &GpuScene<'static> {
        self.gs.as_ref().expect("GPU scene")
    }

    /// The GPU scene, for a render that keeps it.
    fn gs_shared(&self) -> Rc<GpuScene<'static>> {
        self.gs.clone().expect("GPU scene")
    }

    fn scene(&self) -> &Scene {
        // SAFETY: `scene` came from Box::into_raw in `new` and is freed only in `drop`, so
        // it is valid for as long as `&self` is.
        unsafe { &*self.scene }
    }
}

impl Drop for Loaded {
    fn drop(&mut self) {
        if let Some(gs) = self.gs.take() {
            if Rc::strong_count(&gs) > 1 {
                // A render still holds the GPU scene, which borrows the boxes: leak them
                // rather than free what it borrows (the page drops its render first).
                std::mem::forget(gs);
                return;
            }
        }
        // SAFETY: made by Box::into_raw in `new`, no borrow of them is left.
        unsafe {
            drop(Box::from_raw(self.accel));
            drop(Box::from_raw(self.scene));
        }
    }
}

struct App {
    ctx: &'static GlContext,
    params: Params,
    width: u32,
    height: u32,
    scene_name: String,
    toml: String,
    texts: MeshTexts,
    /// The texture images the meshes' MTLs name (fetched beside them, or dropped).
    images: MeshImages,
    loaded: Option<Loaded>,
    /// The options of the scene loaded: the query's render flags over its defaults.
    opts: Option<RenderOptions>,
    camera: Option<Camera>,
    job: Option<Job>,
    /// What the controls set: the display, samples per pixel, progress mode.
    show: Show,
    spp: u32,
    progress: Progress,
    /// The linear image (RGB, top row first) and what the canvas shows (sRGB RGBA).
    image: Vec<f32>,
    display: Vec<u8>,
    /// The primary-ray AOVs (WebGL 2), top row first, and how many rows hold the current
    /// render's (the rest are misses).
    aov: Vec<AovPixel>,
    aov_rows: u32,
    status: String,
    drag: Option<(f64, f64)>,
    reported: bool,
}

fn document() -> web_sys::Document {
    web_sys::window().unwrap().document().unwrap()
}

fn element<T: JsCast>(id: &str) -> T {
    document()
        .get_element_by_id(id)
        .unwrap_or_else(|| panic!("no #{id} in the page"))
        .dyn_into::<T>()
        .unwrap_or_else(|_| panic!("#{id} has the wrong type"))
}

impl App {
    fn limits(&self) -> String {
        let i = &self.ctx.info;
        format!(
            "{} | {} | max texture {} | draw buffers {} | texture units {} | \
             viewport {}x{} | programs in {}\nextensions: {}",
            i.gl_version,
            i.renderer,
            i.max_texture_size,
            i.max_draw_buffers,
            i.max_texture_units,
            i.max_viewport_dims.0,
            i.max_viewport_dims.1,
            i.dialect.name(),
            i.extensions.join(" ")
        )
    }

    /// Loads `self.toml`, fetching meshes it names from `models/` when they were not
    /// dropped, and starts a render from the scene's camera.
    fn load(&mut self) -> Result<(), String> {
        // The render first: it may hold the GPU scene.
        self.job = None;
        self.loaded = None;
        let mut fetched = 0;
        let scene = loop {
            match load_scene_str_with_files(&self.toml, &self.scene_name, &self.texts, &self.images)
            {
                Ok(s) => break s,
                Err(fragtrace::Error::Mesh { file, message }) if fetched < 8 => {
                    let obj = fetch_text(&format!("models/{file}")).ok_or_else(|| {
                        format!("{file}: {message}; or serve it under models/{file}")
                    })?;
                    // The MTL libraries it names sit beside it.
                    let dir = file.rsplit_once('/').map_or("", |(d, _)| d);
                    for lib in obj.lines().filter_map(|l| l.trim().strip_prefix("mtllib ")) {
                        let path = if dir.is_empty() {
                            lib.trim().to_string()
                        } else {
                            format!("{dir}/{}", lib.trim())
                        };
                        if let Some(t) = fetch_text(&format!("models/{path}")) {
                            // The images its `map_Kd` name, beside the OBJ (MTL paths are
                            // relative to it), under the key the loader looks for first.
                            for image in mtl_texture_files(&t) {
                                let key = if dir.is_empty() {
                                    image
                                } else {
                                    format!("{dir}/{image}")
                                };
                                if let Some(b) = fetch_bytes(&format!("models/{key}")) {
                                    self.images.insert(key, b);
                                }
                            }
                            self.texts.insert(lib.trim().to_string(), t);
                        }
                    }
                    self.texts.insert(file, obj);
                    fetched += 1;
                }
                Err(e) => return Err(e.to_string()),
            }
        };
        // The render flags of the query, as `fragtrace render` turns them into options.
        let opts = self
            .params
            .choices
            .to_options(&scene, Door::Web)
            .map_err(|e| e.to_string())?;
        let (w, h) = (opts.width, opts.height);
        self.width = w;
        self.height = h;
        self.camera = Some(scene.camera);
        let t = Instant::now();
        self.loaded = Some(Loaded::new(self.ctx, scene, &opts).map_err(|e| e.to_string())?);
        self.opts = Some(opts);
        let canvas: web_sys::HtmlCanvasElement = element("view");
        canvas.set_width(w);
        canvas.set_height(h);
        // Small renders are shown enlarged by a whole factor (pixelated), to about 512 wide.
        let zoom = (512 / w.max(1)).max(1);
        let _ = canvas
            .style()
            .set_property("width", &format!("{}px", w * zoom));
        self.image = vec![0.0; (w * h * 3) as usize];
        self.display = vec![0; (w * h * 4) as usize];
        self.aov = empty_aov(w, h);
        let s = self.loaded.as_ref().unwrap().scene();
        // A texture not found is the material's colour and one line, as natively.
        let textures = match (s.textures.len(), &s.texture_problems[..]) {
            (0, []) => String::new(),
            (n, []) => format!(", {n} image textures"),
            (n, p) => format!(", {n} image textures; not read: {}", p.join("; ")),
        };
        self.status = format!(
            "{}: {} triangles{textures}, grid and upload {:.0} ms",
            self.scene_name,
            s.triangles.len(),
            t.elapsed().as_secs_f64() * 1e3
        );
        self.restart();
        Ok(())
    }

    /// Starts the render again from the current camera (and spp, progress mode).
    fn restart(&mut self) {
        let Some(camera) = self.camera else { return };
        // Dropped before the next render starts: a pass-by-pass render's GL objects go now.
        self.job = None;
        self.aov = empty_aov(self.width, self.height);
        self.aov_rows = 0;
        let band = self.params.band.unwrap_or(8).min(self.height).max(1);
        self.job = Some(Job::new(camera, self.progress, band));
    }

    /// Whether the AOV shown is there: read (WebGL 2) and rendered (from the top row
    /// down in bands; at the end pass by pass).
    fn aov_shown(&self) -> bool {
        self.show.is_some() && self.reads_aov() && self.aov_rows > 0
    }

    /// Makes the canvas bytes from the colour image or the AOV the control picks, in
    /// `--aov`'s preview colours (the steps heat map without its colour bar, scaled to the
    /// image's most steps).
    fn redraw(&mut self) {
        let (w, h) = (self.width, self.height);
        let shown: Option<Vec<f32>> = match self.show {
            _ if !self.aov_shown() => None,
            Some(AovKind::Steps) => {
                let steps: Vec<f32> = self.aov.iter().map(|p| p.steps).collect();
                let map = heat_map(w, h, &steps);
                let rows = map.data.chunks(map.width as usize * 3);
                Some(rows.flat_map(|r| r[..w as usize * 3].to_vec()).collect())
            }
            Some(k) => Some(preview(&Aov::from_vec(w, h, self.aov.clone()), k).data),
            None => None,
        };
        let shown: &[f32] = shown.as_deref().unwrap_or(&self.image);
        for (px, rgb) in self.display.chunks_mut(4).zip(shown.chunks(3)) {
            for k in 0..3 {
                px[k] = srgb8(rgb[k]);
            }
            px[3] = 255;
        }
    }

    /// Switches the display (the control): redraws from what is there, renders nothing.
    fn set_show(&mut self, show: Show) {
        self.show = show;
        if self.width == 0 {
            return; // no scene loaded
        }
        self.redraw();
        if let Err(e) = self.present() {
            web_sys::console::error_1(&e.into());
        }
    }

    fn present(&self) -> Result<(), String> {
        let canvas: web_sys::HtmlCanvasElement = element("view");
        let c2d = canvas
            .get_context("2d")
            .ok()
            .flatten()
            .and_then(|c| c.dyn_into::<web_sys::CanvasRenderingContext2d>().ok())
            .ok_or("no 2d context")?;
        let data = web_sys::ImageData::new_with_u8_clamped_array_and_sh(
            wasm_bindgen::Clamped(&self.display),
            self.width,
            self.height,
        )
        .map_err(|e| format!("{e:?}"))?;
        c2d.put_image_data(&data, 0.0, 0.0)
            .map_err(|e| format!("{e:?}"))?;
        Ok(())
    }

    /// POSTs the finished render: the body is the linear image (f32 RGB, little-endian,
    /// top row first), then where `aov_read` the primary-ray AOVs (f32 depth, primid,
    /// normal x, y, z and steps per pixel, top row first), then the canvas as shown (sRGB
    /// RGBA bytes).
    fn post_report(&self, url: &str, job: &Job) {
        let i = &self.ctx.info;
        let scene = self
            .loaded
            .as_ref()
            .expect("a render has its scene")
            .scene();
        // The fragment kernels' texture units (`gpu::contract::Unit`): the scene textures'
        // 16th only where the scene has image textures or texture coordinates.
        let units = if self.loaded.as_ref().unwrap().gs().textured() {
            TEXTURED_TEXTURE_UNITS
        } else {
            REQUIRED_TEXTURE_UNITS
        };
        let json = format!(
            "{{\"scene\":{:?},\"width\":{},\"height\":{},\"kernel\":\"{}\",\"spp\":{},\
             \"progress\":\"{}\",\"frames\":{},\"shown\":\"{}\",\"aov_read\":{},\"aov_at_pass\":{},\"show_ms\":{:.1},\"passes\":{},\
             \"rays\":{},\"render_ms\":{:.1},\"wall_ms\":{:.1},\"renderer\":{:?},\
             \"gl_version\":{:?},\"glsl\":{:?},\"dialect\":{:?},\"max_texture_size\":{},\"max_draw_buffers\":{},\
             \"max_texture_units\":{},\"max_viewport\":[{},{}],\"textures\":{},\"texture_problems\":{},\
             \"texture_units\":{},{}\"extensions\":{:?}}}",
            self.scene_name,
            self.width,
            self.height,
            self.params.kernel,
            self.spp,
            job.progress.name(),
            job.frames,
            show_name(self.show),
            self.aov_rows == self.height && self.reads_aov(),
            job.aov_at_pass.map_or(-1, |p| p as i64),
            job.show_total_ms,
            job.passes,
            job.rays,
            job.render_ms,
            job.started.elapsed().as_secs_f64() * 1e3,
            i.renderer,
            i.gl_version,
            i.glsl_version,
            i.dialect.name(),
            i.max_texture_size,
            i.max_draw_buffers,
            i.max_texture_units,
            i.max_viewport_dims.0,
            i.max_viewport_dims.1,
            scene.textures.len(),
            scene.texture_problems.len(),
            units,
            job.cut.json(),
            i.extensions
        );
        let mut floats = self.image.clone();
        if self.aov_rows == self.height && self.reads_aov() {
            floats.extend(self.aov.iter().flat_map(|p| {
                [
                    p.depth,
                    p.primid,
                    p.normal[0],
                    p.normal[1],
                    p.normal[2],
                    p.steps,
                ]
            }));
        }
        let mut bytes: Vec<u8> = floats.iter().flat_map(|v| v.to_le_bytes()).collect();
        bytes.extend_from_slice(&self.display);
        post(url, "X-Fragtrace-Report", &json, &bytes);
    }

    /// Orbits the camera about its look-at point by a mouse move of (dx, dy) pixels.
    fn orbit(&mut self, dx: f64, dy: f64) {
        let Some(c) = self.camera.as_mut() else {
            return;
        };
        let offset = (c.eye - c.look_at).as_dvec3();
        let r = offset.length();
        let yaw = offset.x.atan2(offset.z) - dx * 0.01;
        let pitch = (offset.y / r).clamp(-1.0, 1.0).asin() + dy * 0.01;
        let pitch = pitch.clamp(-1.5, 1.5);
        let d = glam::DVec3::new(
            pitch.cos() * yaw.sin(),
            pitch.sin(),
            pitch.cos() * yaw.cos(),
        );
        c.eye = c.look_at + (d * r).as_vec3();
        self.restart();
    }
}

/// Linear to 8-bit sRGB.
fn srgb8(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// The status line (with a note while the AOV picked is not there yet) and the limits.
fn show_status(app: &App) {
    let note = match app.show {
        Some(k) if app.reads_aov() && !app.aov_shown() => format!(
            "\nshowing the colour until the {} AOV comes (after the first sample's primary \
             rays)",
            show_name(Some(k))
        ),
        _ => String::new(),
    };
    let stats: web_sys::HtmlElement = element("stats");
    stats.set_text_content(Some(&format!("{}{note}\n{}", app.status, app.limits())));
}

/// Reports `msg` on the page, on the console and, when the page reports, to the test.
fn fail(app: &mut App, msg: &str) {
    app.status = format!("error: {msg}");
    app.job = None;
    web_sys::console::error_1(&msg.into());
    if let (Some(url), false) = (app.params.report.clone(), app.reported) {
        app.reported = true;
        post(
            &url,
            "X-Fragtrace-Error",
            &msg.replace(['\n', '\r'], " "),
            &[],
        );
    }
    show_status(app);
}

/// The page's entry: sets up WebGL, the scene list, the events and the frame loop.
#[wasm_bindgen(start)]
pub fn start() -> Result<(), JsValue> {
    std::panic::set_hook(Box::new(|info| {
        web_sys::console::error_1(&format!("fragtrace panicked: {info}").into());
        let url = web_sys::window()
            .and_then(|w| w.location().search().ok())
            .and_then(|s| web_sys::UrlSearchParams::new_with_str(&s).ok())
            .and_then(|q| q.get("report"));
        if let Some(url) = url {
            let msg = format!("panic: {info}").replace(['\n', '\r'], " ");
            post(&url, "X-Fragtrace-Error", &msg, &[]);
        }
    }));
    let window = web_sys::window().ok_or("no window")?;
    let search = window.location().search()?;
    let params = Params::from_query(&search).map_err(|e| JsValue::from_str(&e))?;
    // The WebGL canvas is never shown: every pass draws into float textures, and the page
    // shows the image read back through a 2D canvas.
    let gl_canvas: web_sys::HtmlCanvasElement = document().create_element("canvas")?.dyn_into()?;
    let webgl2 = if params.webgl == Some(1) {
        None
    } else {
        gl_canvas.get_context("webgl2")?
    };
    let ctx = match webgl2 {
        Some(webgl2) => GlContext::from_webgl2_unchecked(webgl2.dyn_into()?),
        None if params.webgl == Some(2) => {
            return Err("webgl=2: this browser gives no WebGL 2 context".into())
        }
        None => {
            let webgl: web_sys::WebGlRenderingContext = gl_canvas
                .get_context("webgl")?
                .ok_or("this browser gives no WebGL 1 context")?
                .dyn_into()?;
            GlContext::from_webgl1_unchecked(webgl)
        }
    };
    // `auto` resolved for this context by the one resolver (`--kernel`'s).
    let mut params = params;
    params.kernel = params
        .kernel
        .resolve(&ctx.info, false)
        .map_err(|e| JsValue::from_str(&e.to_string()))?;
    if params.kernel == Kernel::Looped && !ctx.info.dialect.has_loops() {
        return Err("kernel=looped needs WebGL 2 (GLSL ES 1.00 has no run-time loops)".into());
    }
    if params.show.is_some() && !ctx.info.dialect.has_read_buffer() {
        return Err(format!("aov=: {AOV_NEEDS_WEBGL2}").into());
    }
    let ctx: &'static GlContext = Box::leak(Box::new(ctx));
    let scene_name = params.scene.clone();
    let toml = SCENES
        .iter()
        .find(|(n, _)| *n == scene_name)
        .map(|(_, t)| t.to_string());
    let (show, spp, progress) = (params.show, params.spp, params.progress);
    let app = Rc::new(RefCell::new(App {
        ctx,
        params,
        width: 0,
        height: 0,
        scene_name: scene_name.clone(),
        toml: toml.clone().unwrap_or_default(),
        texts: MeshTexts::new(),
        images: MeshImages::new(),
        loaded: None,
        opts: None,
        camera: None,
        job: None,
        // Set by the control's handler below (from the query's value).
        show: None,
        spp,
        progress,
        image: Vec::new(),
        display: Vec::new(),
        aov: Vec::new(),
        aov_rows: 0,
        status: String::new(),
        drag: None,
        reported: false,
    }));

    // The scene list.
    let select: web_sys::HtmlSelectElement = element("scene");
    for (name, _) in SCENES {
        let opt = web_sys::HtmlOptionElement::new_with_text_and_value(name, name)?;
        opt.set_selected(*name == scene_name);
        select.add_with_html_option_element(&opt)?;
    }
    {
        let app = app.clone();
        let on_change = Closure::<dyn FnMut()>::new(move || {
            let name = element::<web_sys::HtmlSelectElement>("scene").value();
            let mut a = app.borrow_mut();
            if let Some((n, t)) = SCENES.iter().find(|(n, _)| *n == name) {
                a.scene_name = n.to_string();
                a.toml = t.to_string();
                a.reported = true; // only the first render reports
                if let Err(e) = a.load() {
                    fail(&mut a, &e);
                }
            }
        });
        select.add_event_listener_with_callback("change", on_change.as_ref().unchecked_ref())?;
        on_change.forget();
    }
    install_controls(&app)?;
    install_mouse(&app)?;
    install_drop(&app)?;

    {
        let mut a = app.borrow_mut();
        if let Err(e) = a.ctx.info.verdict() {
            fail(&mut a, &format!("WebGL 1 context unusable: {e}"));
        } else if toml.is_none() {
            let msg = format!("scene={scene_name}: not a shipped scene");
            fail(&mut a, &msg);
        } else if let Err(e) = a.load() {
            fail(&mut a, &e);
        } else {
            show_status(&a);
        }
    }
    if show.is_some() {
        // The query's display goes through the control's own handler, as a person's
        // choice would (the test of the AOV display checks the canvas it draws).
        element::<web_sys::HtmlSelectElement>("show")
            .dispatch_event(&web_sys::Event::new("change")?)?;
    }
    frame_loop(app)
}

/// Why the display control is off on WebGL 1.
const AOV_NEEDS_WEBGL2: &str = "AOVs need WebGL 2 (WebGL 1 reads colour attachment 0 only)";

/// What a control does with its new value.
type OnChange = dyn Fn(&mut App, String);

/// The display, progress and samples controls: they start from the query's values; the
/// display redraws what is there, the others render again.
fn install_controls(app: &Rc<RefCell<App>>) -> Result<(), JsValue> {
    let a = app.borrow();
    let show: web_sys::HtmlSelectElement = element("show");
    show.set_value(show_name(a.params.show));
    if !a.reads_aov() {
        show.set_disabled(true);
        element::<web_sys::HtmlElement>("show-why").set_text_content(Some(AOV_NEEDS_WEBGL2));
    }
    let progress: web_sys::HtmlSelectElement = element("progress");
    // `passes:N` is the query's (reproducible) form of the control's `passes`.
    progress.set_value(match a.progress {
        Progress::Bands => "bands",
        Progress::Passes { .. } => "passes",
    });
    let spp: web_sys::HtmlInputElement = element("spp");
    spp.set_max(&MAX_SPP.to_string());
    spp.set_value(&a.spp.to_string());
    drop(a);

    let on = |id: &str, f: Box<OnChange>| -> Result<(), JsValue> {
        let app = app.clone();
        let id2 = id.to_string();
        let cb = Closure::<dyn FnMut()>::new(move || {
            let value = element::<web_sys::HtmlElement>(&id2)
                .dyn_into::<web_sys::HtmlSelectElement>()
                .map(|s| s.value())
                .or_else(|e| e.dyn_into::<web_sys::HtmlInputElement>().map(|i| i.value()))
                .unwrap_or_default();
            let mut a = app.borrow_mut();
            f(&mut a, value);
            show_status(&a);
        });
        element::<web_sys::HtmlElement>(id)
            .add_event_listener_with_callback("change", cb.as_ref().unchecked_ref())?;
        cb.forget();
        Ok(())
    };
    on(
        "show",
        Box::new(|a, v| match parse_show(&v) {
            Ok(s) => a.set_show(s),
            Err(e) => web_sys::console::error_1(&e.into()),
        }),
    )?;
    on(
        "progress",
        Box::new(|a, v| {
            if let Ok(p) = Progress::parse(&v) {
                a.progress = p;
                a.restart();
            }
        }),
    )?;
    on(
        "spp",
        Box::new(|a, v| {
            if let Ok(n) = v.trim().parse::<u32>() {
                a.spp = n.clamp(1, MAX_SPP);
                a.restart();
            }
        }),
    )?;
    Ok(())
}

/// The animation-frame callback, which schedules itself again.
type FrameCallback = Closure<dyn FnMut()>;

/// Renders a band per animation frame while a job runs.
fn frame_loop(app: Rc<RefCell<App>>) -> Result<(), JsValue> {
    let f: Rc<RefCell<Option<FrameCallback>>> = Rc::new(RefCell::new(None));
    let g = f.clone();
    *g.borrow_mut() = Some(Closure::new(move || {
        {
            let mut a = app.borrow_mut();
            if a.job.is_some() {
                match a.step() {
                    Ok(()) => show_status(&a),
                    Err(e) => fail(&mut a, &e),
                }
            }
        }
        let w = web_sys::window().unwrap();
        let cb = f.borrow();
        let _ = w.request_animation_frame(cb.as_ref().unwrap().as_ref().unchecked_ref());
    }));
    let w = web_sys::window().ok_or("no window")?;
    w.request_animation_frame(g.borrow().as_ref().unwrap().as_ref().unchecked_ref())?;
    Ok(())
}

fn install_mouse(app: &Rc<RefCell<App>>) -> Result<(), JsValue> {
    let canvas: web_sys::HtmlCanvasElement = element("view");
    let a = app.clone();
    let down = Closure::<dyn FnMut(web_sys::MouseEvent)>::new(move |e: web_sys::MouseEvent| {
        a.borrow_mut().drag = Some((e.client_x() as f64, e.client_y() as f64));
    });
    canvas.add_event_listener_with_callback("mousedown", down.as_ref().unchecked_ref())?;
    down.forget();
    let a = app.clone();
    let moved = Closure::<dyn FnMut(web_sys::MouseEvent)>::new(move |e: web_sys::MouseEvent| {
        let mut app = a.borrow_mut();
        let Some((x, y)) = app.drag else { return };
        if e.buttons() == 0 {
            app.drag = None;
            return;
        }
        let (nx, ny) = (e.client_x() as f64, e.client_y() as f64);
        app.drag = Some((nx, ny));
        app.orbit(nx - x, ny - y);
    });
    canvas.add_event_listener_with_callback("mousemove", moved.as_ref().unchecked_ref())?;
    moved.forget();
    Ok(())
}
