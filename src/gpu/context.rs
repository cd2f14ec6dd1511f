//! Headless OpenGL context over EGL, plus the capability report that decides whether the GPU
//! backend can run at all.
//!
//! The backend needs nothing newer than OpenGL 2.1 + float textures + FBOs, but it must run on
//! machines with no window system (CI boxes, GPU servers). EGL is the one API that gives a
//! desktop-GL context without X11/Wayland, so `libEGL.so.1` is loaded at run time (the binary
//! still starts, and the CPU renderer still works, on machines without it).
//!
//! Display selection, in order of preference:
//! 1. `EGL_MESA_platform_surfaceless`: no device, no window system; Mesa picks a render node or
//!    falls back to llvmpipe. NVIDIA's driver implements this platform as well.
//! 2. `EGL_EXT_platform_device`: enumerate EGL devices and take the first that initialises
//!    (the classic NVIDIA headless path).
//! 3. `eglGetDisplay(EGL_DEFAULT_DISPLAY)`: whatever the EGL vendor considers default; on a
//!    desktop this is usually X11/Wayland.
//!
//! The first candidate that yields a current desktop-GL context wins; [`PLATFORM_ENV`] can
//! restrict the search to one of them.
//!
//! A [`GlContext`] is bound to the thread that created it (it is deliberately neither `Send`
//! nor `Sync`): GL calls go to the thread's *current* context, and moving one between threads
//! would silently redirect them.

use std::collections::HashMap;
use std::ffi::{c_char, c_void, CStr};
use std::fmt;
use std::sync::{Mutex, OnceLock};

use glow::HasContext;
use khronos_egl as egl;

use crate::error::{Error, Result};

/// The EGL instance type: EGL 1.4 entry points are required, 1.5 ones are used when present.
type EglInstance = egl::DynamicInstance<egl::EGL1_4>;

/// `EGL_PLATFORM_SURFACELESS_MESA` (EGL_MESA_platform_surfaceless).
const PLATFORM_SURFACELESS_MESA: egl::Enum = 0x31DD;
/// `EGL_PLATFORM_DEVICE_EXT` (EGL_EXT_platform_device).
const PLATFORM_DEVICE_EXT: egl::Enum = 0x313F;
/// `EGL_DRM_DEVICE_FILE_EXT` (EGL_EXT_device_drm), used only to name the device in reports.
const DRM_DEVICE_FILE_EXT: egl::Int = 0x3233;

/// Restricts display selection to one platform (`surfaceless`, `device` or `default`), for
/// diagnosing a machine where the automatic choice picks the wrong GPU or fails.
pub const PLATFORM_ENV: &str = "FRAGTRACE_EGL_PLATFORM";

/// Loads this EGL library (a file name or path) instead of `libEGL.so.1`, e.g. to pick a
/// vendor's library directly or to test the "no EGL" path (`/nonexistent`).
pub const EGL_LIBRARY_ENV: &str = "FRAGTRACE_EGL_LIBRARY";

/// The apt command printed when EGL is missing; the packages are the Debian/Ubuntu names of
/// the GLVND loader, the Mesa EGL vendor library and the Mesa DRI drivers (incl. llvmpipe).
const EGL_INSTALL_HINT: &str = "apt-get install -y libegl1 libegl-mesa0 libgl1-mesa-dri";

/// The lowest GL version whose API (GLSL 1.20, MRT, VBOs, occlusion queries) the backend uses.
const MIN_GL: (u32, u32) = (2, 1);
/// The passes write up to four output streams at once (one per colour attachment).
const MIN_DRAW_BUFFERS: i32 = 4;

type PfnGetString = unsafe extern "system" fn(u32) -> *const u8;
type PfnGetQueryObjectuiv = unsafe extern "system" fn(u32, u32, *mut u32);
type PfnGetQueryObjectui64v = unsafe extern "system" fn(u32, u32, *mut u64);
type PfnGetQueryiv = unsafe extern "system" fn(u32, u32, *mut i32);
type PfnGetPlatformDisplayExt =
    unsafe extern "system" fn(egl::Enum, *mut c_void, *const egl::Int) -> egl::EGLDisplay;
type PfnQueryDevicesExt =
    unsafe extern "system" fn(egl::Int, *mut *mut c_void, *mut egl::Int) -> egl::Boolean;
type PfnQueryDeviceStringExt = unsafe extern "system" fn(*mut c_void, egl::Int) -> *const c_char;

/// GL entry points called directly instead of through glow.
///
/// glow 0.16 panics when `glGetString` returns NULL (e.g. `GL_EXTENSIONS` in a core profile),
/// and its `get_query_parameter_u32` only calls `glGetQueryObjectuiv` when the GL 4.5
/// `glGetQueryBufferObjectiv` is present, otherwise the GLES-only `...EXT` name, which a real
/// GL 2.1 driver does not export. Loading these few ourselves keeps 2.1 drivers working.
pub(crate) struct RawGl {
    get_string: PfnGetString,
    get_query_objectuiv: PfnGetQueryObjectuiv,
    get_queryiv: PfnGetQueryiv,
    /// `glGetQueryObjectui64v` (GL 3.3 / ARB_timer_query) or its EXT_timer_query alias; only
    /// present when timer queries are.
    get_query_objectui64v: Option<PfnGetQueryObjectui64v>,
}

impl RawGl {
    /// `glGetString`, `None` where the driver returns NULL.
    pub(crate) fn string(&self, name: u32) -> Option<String> {
        // SAFETY: the pointer came from the current context's loader; GL returns either NULL
        // or a NUL-terminated static string.
        unsafe {
            let p = (self.get_string)(name);
            (!p.is_null()).then(|| CStr::from_ptr(p.cast()).to_string_lossy().into_owned())
        }
    }

    /// `glGetQueryObjectuiv(query, GL_QUERY_RESULT)`; blocks until the result is available.
    pub(crate) fn query_result_u32(&self, query: glow::Query) -> u32 {
        let mut value = 0u32;
        // SAFETY: valid query name from this context, one-element out pointer.
        unsafe { (self.get_query_objectuiv)(query.0.get(), glow::QUERY_RESULT, &mut value) };
        value
    }

    /// `glGetQueryObjectui64v(query, GL_QUERY_RESULT)`, `None` without timer-query support.
    pub(crate) fn query_result_u64(&self, query: glow::Query) -> Option<u64> {
        let f = self.get_query_objectui64v?;
        let mut value = 0u64;
        // SAFETY: as above; the function exists because timer queries were detected.
        unsafe { f(query.0.get(), glow::QUERY_RESULT, &mut value) };
        Some(value)
    }

    /// `glGetQueryiv(target, pname)`.
    fn query_iv(&self, target: u32, pname: u32) -> i32 {
        let mut value = 0;
        // SAFETY: one-element out pointer; an unsupported target only raises a GL error.
        unsafe { (self.get_queryiv)(target, pname, &mut value) };
        value
    }
}

/// Environment variable naming a historical card whose limits fragtrace imposes on top of
/// the driver's (`geforce7`), to prove the GL 2.1 path fits period hardware on a modern
/// driver that cannot be told to shrink its own limits.
pub const LIMITS_ENV: &str = "FRAGTRACE_GL_LIMITS";

/// Limits fragtrace plans with instead of the driver's larger ones.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LimitProfile {
    /// Name given in [`LIMITS_ENV`].
    pub name: &'static str,
    /// `GL_MAX_TEXTURE_SIZE`.
    pub max_texture_size: i32,
    /// `GL_MAX_DRAW_BUFFERS` (and colour attachments).
    pub max_draw_buffers: i32,
    /// `GL_MAX_TEXTURE_IMAGE_UNITS`.
    pub max_texture_units: i32,
}

/// A GeForce 6/7-class card (NV40/G70, 2004-2006, the thesis's era): 4096-texel textures,
/// 4 draw buffers, 16 fragment texture units.
pub const GEFORCE7: LimitProfile = LimitProfile {
    name: "geforce7",
    max_texture_size: 4096,
    max_draw_buffers: 4,
    max_texture_units: 16,
};

/// The profile named by [`LIMITS_ENV`], read once per process; `None` when unset or empty.
///
/// # Panics
/// Never; an unknown name is reported by [`GlContext::new_unchecked`] as a usage error.
pub fn limit_profile() -> std::result::Result<Option<LimitProfile>, String> {
    static PROFILE: OnceLock<std::result::Result<Option<LimitProfile>, String>> = OnceLock::new();
    PROFILE
        .get_or_init(|| match std::env::var(LIMITS_ENV) {
            Err(_) => Ok(None),
            Ok(v) if v.is_empty() => Ok(None),
            Ok(v) if v == GEFORCE7.name => Ok(Some(GEFORCE7)),
            Ok(v) => Err(format!(
                "{LIMITS_ENV}={v} is not a known profile (expected geforce7)"
            )),
        })
        .clone()
}

/// The driver's `value` of a limit, lowered to the active [`LimitProfile`]'s.
pub(crate) fn effective_limit(value: i32, pick: impl Fn(&LimitProfile) -> i32) -> i32 {
    match limit_profile() {
        Ok(Some(p)) => value.min(pick(&p)),
        _ => value,
    }
}

/// What the driver is and whether fragtrace can use it.
///
/// Filled once when the context is created. `features` lists every *required* capability
/// with its outcome; [`GlInfo::verdict`] turns the failures into one explanation.
#[derive(Debug, Clone, PartialEq)]
pub struct GlInfo {
    /// How the EGL display was obtained (platform, device) and how the context was made current.
    pub egl_platform: String,
    /// `EGL_VENDOR` of the display, e.g. `Mesa Project` or `NVIDIA`.
    pub egl_vendor: String,
    /// `EGL_VERSION` of the display, e.g. `1.5`.
    pub egl_version: String,
    /// Raw `GL_VERSION` string.
    pub gl_version: String,
    /// `(major, minor)` parsed from `GL_VERSION`.
    pub gl_major_minor: (u32, u32),
    /// `GL_RENDERER`, e.g. `llvmpipe (LLVM 15.0.7, 256 bits)`.
    pub renderer: String,
    /// `GL_VENDOR`.
    pub vendor: String,
    /// `GL_SHADING_LANGUAGE_VERSION`, e.g. `1.20`.
    pub glsl_version: String,
    /// `GL_MAX_TEXTURE_SIZE`: bounds every stream texture's width and height.
    pub max_texture_size: i32,
    /// `GL_MAX_VIEWPORT_DIMS`: bounds the full-screen quad every pass draws.
    pub max_viewport_dims: (i32, i32),
    /// `GL_MAX_DRAW_BUFFERS`: how many streams one pass may write.
    pub max_draw_buffers: i32,
    /// `GL_MAX_TEXTURE_IMAGE_UNITS`: how many streams/scene textures one pass may read.
    pub max_texture_units: i32,
    /// The [`LimitProfile`] the three limits above were lowered to, if any.
    pub limit_profile: Option<String>,
    /// `GL_QUERY_COUNTER_BITS` of `GL_SAMPLES_PASSED`: the occlusion counter's width (GL lets
    /// a driver report 0, meaning the query always returns 0).
    pub occlusion_query_bits: i32,
    /// Whether `GL_TIME_ELAPSED` queries work (GL 3.3, ARB_timer_query or EXT_timer_query);
    /// optional, used only for per-pass timings.
    pub timer_query: bool,
    /// Every extension the context advertises.
    pub extensions: Vec<String>,
    /// Each required capability (human-readable, naming the GL version/extension that
    /// provides it) and whether this context has it.
    pub features: Vec<(String, bool)>,
}

impl GlInfo {
    /// Whether the context advertises the extension `name` (e.g. `GL_ARB_texture_float`).
    pub fn has_extension(&self, name: &str) -> bool {
        self.extensions.iter().any(|e| e == name)
    }

    /// `Ok` when a `width` x `height` image fits the stream textures
    /// (`GL_MAX_TEXTURE_SIZE`) and the viewport (`GL_MAX_VIEWPORT_DIMS`); otherwise
    /// [`Error::Limit`] naming the limit. Checked before anything is allocated.
    pub fn check_image_size(&self, width: u32, height: u32) -> Result<()> {
        let tex = self.max_texture_size.max(0) as u32;
        if width > tex || height > tex {
            return Err(Error::Limit(format!(
                "image {width}x{height} exceeds GL_MAX_TEXTURE_SIZE {tex} of {}",
                self.renderer
            )));
        }
        let (vw, vh) = (
            self.max_viewport_dims.0.max(0) as u32,
            self.max_viewport_dims.1.max(0) as u32,
        );
        if width > vw || height > vh {
            return Err(Error::Limit(format!(
                "image {width}x{height} exceeds GL_MAX_VIEWPORT_DIMS {vw}x{vh} of {}",
                self.renderer
            )));
        }
        Ok(())
    }

    /// `Ok` when every required feature is present, otherwise the reason fragtrace's GPU
    /// backend cannot run here (all missing features, with the renderer named).
    pub fn verdict(&self) -> std::result::Result<(), String> {
        let missing: Vec<&str> = self
            .features
            .iter()
            .filter(|(_, ok)| !ok)
            .map(|(name, _)| name.as_str())
            .collect();
        if missing.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "{} (OpenGL {}) lacks: {}",
                self.renderer,
                self.gl_version,
                missing.join("; ")
            ))
        }
    }

    /// Evaluates the requirements from the raw facts already stored in `self`.
    fn compute_features(&mut self, fbo_entry_points: bool) {
        let gl = self.gl_major_minor;
        let ext = |n: &str| self.has_extension(n);
        let glsl_ok = parse_major_minor(&self.glsl_version).is_some_and(|v| v >= (1, 20));
        // EXT_framebuffer_object alone only exports `glGenFramebuffersEXT` & co., but glow
        // calls the core names (which ARB_framebuffer_object and GL 3.0 define). Every Mesa
        // and NVIDIA driver of the last decade has ARB_framebuffer_object, so an EXT-only
        // driver counts only when the core-named entry points resolve anyway.
        let fbo = gl >= (3, 0)
            || ext("GL_ARB_framebuffer_object")
            || (ext("GL_EXT_framebuffer_object") && fbo_entry_points);
        self.features = vec![
            (format!("OpenGL >= {}.{}", MIN_GL.0, MIN_GL.1), gl >= MIN_GL),
            ("GLSL >= 1.20 (#version 120)".to_string(), glsl_ok),
            (
                "float textures (OpenGL 3.0 or GL_ARB_texture_float)".to_string(),
                gl >= (3, 0) || ext("GL_ARB_texture_float"),
            ),
            (
                "framebuffer objects (OpenGL 3.0, GL_ARB_framebuffer_object or GL_EXT_framebuffer_object)"
                    .to_string(),
                fbo,
            ),
            (
                format!("draw buffers (OpenGL 2.0, GL_MAX_DRAW_BUFFERS >= {MIN_DRAW_BUFFERS})"),
                gl >= (2, 0) && self.max_draw_buffers >= MIN_DRAW_BUFFERS,
            ),
            (
                "occlusion queries (OpenGL 1.5 or GL_ARB_occlusion_query, counter bits > 0)"
                    .to_string(),
                (gl >= (1, 5) || ext("GL_ARB_occlusion_query")) && self.occlusion_query_bits > 0,
            ),
        ];
    }
}

impl fmt::Display for GlInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let yes_no = |b: bool| if b { "yes" } else { "NO " };
        writeln!(f, "EGL platform:     {}", self.egl_platform)?;
        writeln!(f, "EGL vendor:       {}", self.egl_vendor)?;
        writeln!(f, "EGL version:      {}", self.egl_version)?;
        writeln!(
            f,
            "OpenGL version:   {} (parsed {}.{})",
            self.gl_version, self.gl_major_minor.0, self.gl_major_minor.1
        )?;
        writeln!(f, "OpenGL renderer:  {}", self.renderer)?;
        writeln!(f, "OpenGL vendor:    {}", self.vendor)?;
        writeln!(f, "GLSL version:     {}", self.glsl_version)?;
        if let Some(p) = &self.limit_profile {
            writeln!(f, "Limits lowered to: {p} ({LIMITS_ENV})")?;
        }
        writeln!(f, "Max texture size: {}", self.max_texture_size)?;
        writeln!(
            f,
            "Max viewport:     {}x{}",
            self.max_viewport_dims.0, self.max_viewport_dims.1
        )?;
        writeln!(f, "Max draw buffers: {}", self.max_draw_buffers)?;
        writeln!(
            f,
            "Max texture units (fragment): {}",
            self.max_texture_units
        )?;
        writeln!(
            f,
            "Occlusion query counter bits: {}",
            self.occlusion_query_bits
        )?;
        writeln!(f, "Extensions:       {} advertised", self.extensions.len())?;
        writeln!(f, "Required features:")?;
        for (name, ok) in &self.features {
            writeln!(f, "  [{}] {}", yes_no(*ok), name)?;
        }
        writeln!(f, "Optional features:")?;
        writeln!(
            f,
            "  [{}] timer queries (OpenGL 3.3, GL_ARB_timer_query or GL_EXT_timer_query)",
            yes_no(self.timer_query)
        )?;
        match self.verdict() {
            Ok(()) => write!(f, "Verdict: OK, the GPU backend can run on this context"),
            Err(reason) => write!(f, "Verdict: UNUSABLE, {reason}"),
        }
    }
}

/// A current, headless OpenGL context plus the report on what it can do.
///
/// Create it with [`GlContext::new`] (fails unless every requirement holds) or
/// [`GlContext::new_unchecked`] (for an `info` command that must print the report even on an
/// inadequate driver). The context is made current on the creating thread; if a thread creates
/// several, call [`GlContext::make_current`] before using one. GL objects created through
/// `gl` are freed with the context when it is dropped.
pub struct GlContext {
    /// The glow function table for this context. Every call assumes this context is current.
    pub gl: glow::Context,
    /// Driver identification, limits and the feature verdict.
    pub info: GlInfo,
    raw: RawGl,
    // Declared last so it is dropped last: the EGL context must outlive every field above.
    session: EglSession,
}

impl fmt::Debug for GlContext {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("GlContext")
            .field("info", &self.info)
            .finish_non_exhaustive()
    }
}

impl GlContext {
    /// Creates a headless context and fails with [`Error::GlUnavailable`] (naming every missing
    /// feature) unless it satisfies all of fragtrace's requirements.
    pub fn new() -> Result<GlContext> {
        let ctx = Self::new_unchecked()?;
        ctx.info.verdict().map_err(Error::GlUnavailable)?;
        Ok(ctx)
    }

    /// Creates a headless context without judging it: only a failure to get *any* desktop-GL
    /// context is an error. Meant for `fragtrace info`, which prints [`GlContext::info`]
    /// (including the verdict line) even when the driver is inadequate.
    pub fn new_unchecked() -> Result<GlContext> {
        limit_profile().map_err(Error::Usage)?;
        let egl = egl_instance()?;
        let session = open_session(egl)?;
        let fallback = session.fallback_lib.as_ref();
        let loader = |name: &str| -> *const c_void {
            if let Some(f) = egl.get_proc_address(name) {
                return f as *const c_void;
            }
            // Only reached on EGL 1.4 without EGL_KHR_get_all_proc_addresses, where core GL
            // 1.x functions are not available through eglGetProcAddress.
            fallback
                .and_then(|lib| {
                    // SAFETY: the symbol is only used as an opaque address by the GL loader.
                    unsafe { lib.get::<*const c_void>(name.as_bytes()) }
                        .ok()
                        .map(|s| *s)
                })
                .unwrap_or(std::ptr::null())
        };

        let raw = load_raw_gl(&loader)?;
        // glow panics on a NULL or unparsable GL_VERSION, so vet it first.
        let gl_version = raw.string(glow::VERSION).ok_or_else(|| {
            Error::GlUnavailable(format!(
                "glGetString(GL_VERSION) returned NULL on {} although the context is current",
                session.platform
            ))
        })?;
        let gl_major_minor = parse_major_minor(&gl_version).ok_or_else(|| {
            Error::GlUnavailable(format!("cannot parse GL_VERSION `{gl_version}`"))
        })?;
        // SAFETY: the context is current on this thread and `loader` resolves its functions.
        let gl = unsafe { glow::Context::from_loader_function(loader) };

        let mut raw = raw;
        let info = gather_info(&gl, &mut raw, &session, gl_version, gl_major_minor, &loader);
        Ok(GlContext {
            gl,
            info,
            raw,
            session,
        })
    }

    /// Makes this context current on the calling thread (needed only when one thread owns
    /// several contexts; creation already makes it current).
    pub fn make_current(&self) -> Result<()> {
        self.session
            .make_current()
            .map_err(|e| Error::Internal(format!("eglMakeCurrent failed: {e}")))
    }

    /// The directly loaded entry points (see [`RawGl`]).
    pub(crate) fn raw(&self) -> &RawGl {
        &self.raw
    }
}

/// Serialises GL use across threads of one process and hands `f` a fresh, checked context.
///
/// Mesa's EGL/llvmpipe is not robust against many contexts being created and destroyed
/// concurrently, and the test harness runs tests on parallel threads, so every test that
/// touches GL goes through here. A panic inside `f` does not poison the lock for later tests.
///
/// # Panics
/// When no usable context can be created: tests that need a GPU should fail loudly, not skip.
pub fn with_test_context<R>(f: impl FnOnce(&GlContext) -> R) -> R {
    static LOCK: Mutex<()> = Mutex::new(());
    let _guard = LOCK.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    let ctx = GlContext::new().unwrap_or_else(|e| panic!("{e}"));
    f(&ctx)
}

/// Loads libEGL once per process; later calls reuse the instance (or the load error).
fn egl_instance() -> Result<&'static EglInstance> {
    static EGL: OnceLock<std::result::Result<EglInstance, String>> = OnceLock::new();
    EGL.get_or_init(|| {
        let lib = std::env::var_os(EGL_LIBRARY_ENV)
            .filter(|v| !v.is_empty())
            .unwrap_or_else(|| "libEGL.so.1".into());
        // SAFETY: loading an EGL library; the symbols are the standard EGL 1.4 ABI.
        unsafe { EglInstance::load_required_from_filename(&lib) }.map_err(|e| {
            // libloading's message repeats the file name and may span lines.
            let why = e.to_string().replace('\n', " ");
            format!(
                "cannot load the EGL library {} ({why}); install an EGL runtime, \
                 e.g. on Debian/Ubuntu: {EGL_INSTALL_HINT} (with the NVIDIA driver, \
                 libegl1 alone suffices: it is the GLVND dispatcher that loads the \
                 driver's libEGL_nvidia.so.0, which exports no EGL API of its own)",
                lib.to_string_lossy()
            )
        })
    })
    .as_ref()
    .map_err(|m| Error::GlUnavailable(m.clone()))
}

/// Per-display reference counts. EGL hands out one `EGLDisplay` per (platform, native
/// display), and `eglTerminate` invalidates every context on it, so two `GlContext`s on the
/// same display must not terminate it under each other.
fn display_refs() -> &'static Mutex<HashMap<usize, usize>> {
    static REFS: OnceLock<Mutex<HashMap<usize, usize>>> = OnceLock::new();
    REFS.get_or_init(|| Mutex::new(HashMap::new()))
}

/// An initialised display with (eventually) a context; its `Drop` releases whatever exists,
/// which also cleans up after a failure half-way through [`try_display`].
struct EglSession {
    egl: &'static EglInstance,
    display: egl::Display,
    context: Option<egl::Context>,
    surface: Option<egl::Surface>,
    platform: String,
    vendor: String,
    version: String,
    /// libOpenGL/libGL, opened only when eglGetProcAddress cannot resolve core GL functions.
    fallback_lib: Option<libloading::Library>,
}

impl EglSession {
    fn make_current(&self) -> std::result::Result<(), egl::Error> {
        self.egl
            .make_current(self.display, self.surface, self.surface, self.context)
    }
}

impl Drop for EglSession {
    fn drop(&mut self) {
        let egl = self.egl;
        // Errors are ignored: there is nothing useful to do with them while dropping, and
        // every step below is safe to attempt on a half-built session.
        if self.context.is_some() && egl.get_current_context() == self.context {
            let _ = egl.make_current(self.display, None, None, None);
        }
        if let Some(surface) = self.surface.take() {
            let _ = egl.destroy_surface(self.display, surface);
        }
        if let Some(context) = self.context.take() {
            let _ = egl.destroy_context(self.display, context);
        }
        let mut refs = display_refs().lock().unwrap_or_else(|p| p.into_inner());
        let key = self.display.as_ptr() as usize;
        let count = refs.entry(key).or_insert(1);
        *count -= 1;
        if *count == 0 {
            refs.remove(&key);
            let _ = egl.terminate(self.display);
        }
        drop(refs);
        // Frees EGL's per-thread state (Mesa keeps the last context/API there).
        let _ = egl.release_thread();
    }
}

/// Tries each display candidate in turn; the error lists why each one failed.
fn open_session(egl: &'static EglInstance) -> Result<EglSession> {
    // Without EGL_EXT_client_extensions this query fails; then only eglGetDisplay is left.
    let client_exts = egl
        .query_string(None, egl::EXTENSIONS)
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let has_client = |name: &str| client_exts.split_ascii_whitespace().any(|e| e == name);
    let mut failures: Vec<String> = Vec::new();
    let only = std::env::var(PLATFORM_ENV).unwrap_or_default();
    if !["", "surfaceless", "device", "default"].contains(&only.as_str()) {
        return Err(Error::Usage(format!(
            "{PLATFORM_ENV}={only}: expected surfaceless, device or default"
        )));
    }
    let wanted = |name: &str| only.is_empty() || only == name;

    if wanted("surfaceless") && has_client("EGL_MESA_platform_surfaceless") {
        let label = "EGL_MESA_platform_surfaceless";
        // SAFETY: the surfaceless platform takes no native display (EGL_DEFAULT_DISPLAY).
        match unsafe {
            platform_display(
                egl,
                &client_exts,
                PLATFORM_SURFACELESS_MESA,
                std::ptr::null_mut(),
            )
        } {
            Ok((display, via)) => {
                match try_display(egl, display, format!("{label} ({via})"), &client_exts) {
                    Ok(s) => return Ok(s),
                    Err(e) => failures.push(format!("{label}: {e}")),
                }
            }
            Err(e) => failures.push(format!("{label}: {e}")),
        }
    }

    if wanted("device")
        && has_client("EGL_EXT_platform_device")
        && (has_client("EGL_EXT_device_enumeration") || has_client("EGL_EXT_device_base"))
    {
        match enumerate_devices(egl) {
            Ok(devices) if devices.is_empty() => {
                failures.push("EGL_EXT_platform_device: no EGL devices".to_string())
            }
            Ok(devices) => {
                for (i, device) in devices.into_iter().enumerate() {
                    let label = format!(
                        "EGL_EXT_platform_device #{i} ({})",
                        device_name(egl, device)
                    );
                    // SAFETY: `device` is an EGLDeviceEXT just returned by eglQueryDevicesEXT.
                    match unsafe {
                        platform_display(egl, &client_exts, PLATFORM_DEVICE_EXT, device)
                    } {
                        Ok((display, via)) => {
                            match try_display(
                                egl,
                                display,
                                format!("{label} ({via})"),
                                &client_exts,
                            ) {
                                Ok(s) => return Ok(s),
                                Err(e) => failures.push(format!("{label}: {e}")),
                            }
                        }
                        Err(e) => failures.push(format!("{label}: {e}")),
                    }
                }
            }
            Err(e) => failures.push(format!("EGL_EXT_platform_device: {e}")),
        }
    }

    if wanted("default") {
        // SAFETY: EGL_DEFAULT_DISPLAY is always a valid argument.
        match unsafe { egl.get_display(egl::DEFAULT_DISPLAY) } {
            Some(display) => {
                let label = "eglGetDisplay(EGL_DEFAULT_DISPLAY)".to_string();
                match try_display(egl, display, label, &client_exts) {
                    Ok(s) => return Ok(s),
                    Err(e) => failures.push(format!("default display: {e}")),
                }
            }
            None => failures.push("default display: eglGetDisplay returned EGL_NO_DISPLAY".into()),
        }
    }
    if failures.is_empty() {
        failures.push(format!("{PLATFORM_ENV}={only} is not offered by this EGL"));
    }

    Err(Error::GlUnavailable(format!(
        "no EGL display gave a desktop OpenGL context ({}); without a vendor EGL driver, \
         install Mesa (Debian/Ubuntu: {EGL_INSTALL_HINT})",
        failures.join("; ")
    )))
}

/// `eglGetPlatformDisplay` (EGL 1.5) or `eglGetPlatformDisplayEXT`; also says which was used.
///
/// # Safety
/// `native` must be valid for `platform` as its extension specifies.
unsafe fn platform_display(
    egl: &EglInstance,
    client_exts: &str,
    platform: egl::Enum,
    native: *mut c_void,
) -> std::result::Result<(egl::Display, &'static str), String> {
    let mut errors = Vec::new();
    if let Some(egl15) = egl.upcast::<egl::EGL1_5>() {
        match egl15.get_platform_display(platform, native, &[egl::ATTRIB_NONE]) {
            Ok(d) => return Ok((d, "eglGetPlatformDisplay")),
            Err(e) => errors.push(format!("eglGetPlatformDisplay: {e}")),
        }
    }
    if client_exts
        .split_ascii_whitespace()
        .any(|e| e == "EGL_EXT_platform_base")
    {
        if let Some(f) = egl.get_proc_address("eglGetPlatformDisplayEXT") {
            let f: PfnGetPlatformDisplayExt =
                std::mem::transmute::<extern "system" fn(), PfnGetPlatformDisplayExt>(f);
            let attribs = [egl::NONE];
            let d = f(platform, native, attribs.as_ptr());
            if !d.is_null() {
                return Ok((egl::Display::from_ptr(d), "eglGetPlatformDisplayEXT"));
            }
            errors.push(format!(
                "eglGetPlatformDisplayEXT: {}",
                egl.get_error()
                    .map_or("no display".to_string(), |e| e.to_string())
            ));
        }
    }
    if errors.is_empty() {
        errors.push("neither EGL 1.5 nor EGL_EXT_platform_base is available".to_string());
    }
    Err(errors.join(", "))
}

/// All EGL devices (EGL_EXT_device_enumeration).
fn enumerate_devices(egl: &EglInstance) -> std::result::Result<Vec<*mut c_void>, String> {
    let f = egl
        .get_proc_address("eglQueryDevicesEXT")
        .ok_or("eglQueryDevicesEXT not found")?;
    // SAFETY: signature from the EGL_EXT_device_enumeration specification.
    let f: PfnQueryDevicesExt =
        unsafe { std::mem::transmute::<extern "system" fn(), PfnQueryDevicesExt>(f) };
    let mut count: egl::Int = 0;
    // SAFETY: a NULL device array with max 0 asks only for the count.
    if unsafe { f(0, std::ptr::null_mut(), &mut count) } != egl::TRUE {
        return Err("eglQueryDevicesEXT failed".into());
    }
    let mut devices = vec![std::ptr::null_mut(); count.max(0) as usize];
    // SAFETY: the array holds `count` entries.
    if unsafe { f(count, devices.as_mut_ptr(), &mut count) } != egl::TRUE {
        return Err("eglQueryDevicesEXT failed".into());
    }
    devices.truncate(count.max(0) as usize);
    Ok(devices)
}

/// A short description of an EGL device for reports: its DRM node, or "software".
fn device_name(egl: &EglInstance, device: *mut c_void) -> String {
    let Some(f) = egl.get_proc_address("eglQueryDeviceStringEXT") else {
        return "unnamed".into();
    };
    // SAFETY: signature from EGL_EXT_device_query.
    let f: PfnQueryDeviceStringExt =
        unsafe { std::mem::transmute::<extern "system" fn(), PfnQueryDeviceStringExt>(f) };
    let query = |name| {
        // SAFETY: valid device; EGL returns NULL or a static NUL-terminated string.
        let p = unsafe { f(device, name) };
        (!p.is_null()).then(|| unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned())
    };
    let exts = query(egl::EXTENSIONS).unwrap_or_default();
    let has = |n: &str| exts.split_ascii_whitespace().any(|e| e == n);
    if has("EGL_EXT_device_drm") {
        if let Some(node) = query(DRM_DEVICE_FILE_EXT) {
            return node;
        }
    }
    if has("EGL_MESA_device_software") {
        return "software".into();
    }
    "unnamed".into()
}

/// Initialises `display`, creates a desktop-GL context on it and makes it current.
fn try_display(
    egl: &'static EglInstance,
    display: egl::Display,
    platform: String,
    client_exts: &str,
) -> std::result::Result<EglSession, String> {
    egl.initialize(display)
        .map_err(|e| format!("eglInitialize: {e}"))?;
    *display_refs()
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .entry(display.as_ptr() as usize)
        .or_insert(0) += 1;
    // From here on, dropping `session` undoes everything done so far.
    let query = |name| {
        egl.query_string(Some(display), name)
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    let mut session = EglSession {
        egl,
        display,
        context: None,
        surface: None,
        platform,
        vendor: query(egl::VENDOR),
        version: query(egl::VERSION),
        fallback_lib: None,
    };
    let display_exts = query(egl::EXTENSIONS);
    let has_display = |n: &str| display_exts.split_ascii_whitespace().any(|e| e == n);

    egl.bind_api(egl::OPENGL_API)
        .map_err(|e| format!("eglBindAPI(EGL_OPENGL_API): {e}"))?;

    // eglChooseConfig defaults EGL_SURFACE_TYPE to EGL_WINDOW_BIT, which no surfaceless or
    // device display offers, so the fallback must say EGL_DONT_CARE explicitly.
    let config_attribs = |surface_type| {
        [
            egl::RENDERABLE_TYPE,
            egl::OPENGL_BIT,
            egl::SURFACE_TYPE,
            surface_type,
            egl::RED_SIZE,
            8,
            egl::GREEN_SIZE,
            8,
            egl::BLUE_SIZE,
            8,
            egl::ALPHA_SIZE,
            8,
            egl::NONE,
        ]
    };
    let mut config = None;
    for surface_type in [egl::PBUFFER_BIT, egl::DONT_CARE] {
        config = egl
            .choose_first_config(display, &config_attribs(surface_type))
            .map_err(|e| format!("eglChooseConfig: {e}"))?;
        if config.is_some() {
            break;
        }
    }
    let config = config.ok_or("no RGBA8 config with EGL_OPENGL_BIT")?;

    // No attributes: the driver's default is a compatibility-profile context of the highest
    // version it has, which includes the whole GL 2.1 API the backend is written against.
    let context = egl
        .create_context(display, config, None, &[egl::NONE])
        .map_err(|e| format!("eglCreateContext: {e}"))?;
    session.context = Some(context);

    let mut how = String::new();
    if has_display("EGL_KHR_surfaceless_context")
        && egl.make_current(display, None, None, Some(context)).is_ok()
    {
        how.push_str("no surface (EGL_KHR_surfaceless_context)");
    } else {
        // All rendering goes to FBOs, so a 1x1 pbuffer only exists to satisfy eglMakeCurrent.
        let surface = egl
            .create_pbuffer_surface(display, config, &[egl::WIDTH, 1, egl::HEIGHT, 1, egl::NONE])
            .map_err(|e| format!("surfaceless eglMakeCurrent unavailable and eglCreatePbufferSurface failed: {e}"))?;
        session.surface = Some(surface);
        egl.make_current(display, Some(surface), Some(surface), Some(context))
            .map_err(|e| format!("eglMakeCurrent with a 1x1 pbuffer: {e}"))?;
        how.push_str("1x1 pbuffer");
    }
    session.platform = format!("{}, {how}", session.platform);

    let all_procs = client_exts
        .split_ascii_whitespace()
        .any(|e| e == "EGL_KHR_client_get_all_proc_addresses")
        || has_display("EGL_KHR_get_all_proc_addresses")
        || session.version.starts_with("1.5");
    if !all_procs {
        // SAFETY: opening the system GL dispatch library; only used for symbol lookup.
        session.fallback_lib = ["libOpenGL.so.0", "libGL.so.1"]
            .iter()
            .find_map(|name| unsafe { libloading::Library::new(name) }.ok());
    }
    Ok(session)
}

/// Resolves the [`RawGl`] entry points; only the always-present GL 1.x/1.5 ones are mandatory.
fn load_raw_gl(loader: &dyn Fn(&str) -> *const c_void) -> Result<RawGl> {
    let get = |name: &str| -> Result<*const c_void> {
        let p = loader(name);
        if p.is_null() {
            Err(Error::GlUnavailable(format!(
                "the driver does not export {name}"
            )))
        } else {
            Ok(p)
        }
    };
    // SAFETY: each pointer is the named GL function, whose C signature the type spells out.
    unsafe {
        Ok(RawGl {
            get_string: std::mem::transmute::<*const c_void, PfnGetString>(get("glGetString")?),
            get_query_objectuiv: std::mem::transmute::<*const c_void, PfnGetQueryObjectuiv>(get(
                "glGetQueryObjectuiv",
            )?),
            get_queryiv: std::mem::transmute::<*const c_void, PfnGetQueryiv>(get("glGetQueryiv")?),
            get_query_objectui64v: None,
        })
    }
}

/// Reads version strings, limits and extensions, and evaluates the requirements.
fn gather_info(
    gl: &glow::Context,
    raw: &mut RawGl,
    session: &EglSession,
    gl_version: String,
    gl_major_minor: (u32, u32),
    loader: &dyn Fn(&str) -> *const c_void,
) -> GlInfo {
    let string = |name| raw.string(name).unwrap_or_default();
    // SAFETY (all `gl` calls below): the context is current; plain state queries.
    let int = |name| unsafe { gl.get_parameter_i32(name) };

    // GL_EXTENSIONS through glGetString is the only way in a 2.1 context and still works in
    // 3.x compatibility profiles; a core profile returns NULL (+ GL_INVALID_ENUM) and needs
    // glGetStringi.
    let extensions: Vec<String> = match raw.string(glow::EXTENSIONS) {
        Some(s) => s.split_ascii_whitespace().map(str::to_owned).collect(),
        None => unsafe {
            while gl.get_error() != glow::NO_ERROR {}
            let n = gl.get_parameter_i32(glow::NUM_EXTENSIONS).max(0) as u32;
            (0..n)
                .map(|i| gl.get_parameter_indexed_string(glow::EXTENSIONS, i))
                .collect()
        },
    };
    let mut info = GlInfo {
        egl_platform: session.platform.clone(),
        egl_vendor: session.vendor.clone(),
        egl_version: session.version.clone(),
        gl_version,
        gl_major_minor,
        renderer: string(glow::RENDERER),
        vendor: string(glow::VENDOR),
        glsl_version: string(glow::SHADING_LANGUAGE_VERSION),
        max_texture_size: effective_limit(int(glow::MAX_TEXTURE_SIZE), |p| p.max_texture_size),
        max_viewport_dims: {
            let mut dims = [0i32; 2];
            // SAFETY: the context is current; GL_MAX_VIEWPORT_DIMS writes two integers.
            unsafe { gl.get_parameter_i32_slice(glow::MAX_VIEWPORT_DIMS, &mut dims) };
            let lim = |v: i32| effective_limit(v, |p| p.max_texture_size);
            (lim(dims[0]), lim(dims[1]))
        },
        max_draw_buffers: effective_limit(int(glow::MAX_DRAW_BUFFERS), |p| p.max_draw_buffers),
        max_texture_units: effective_limit(int(glow::MAX_TEXTURE_IMAGE_UNITS), |p| {
            p.max_texture_units
        }),
        limit_profile: limit_profile().ok().flatten().map(|p| p.name.to_string()),
        occlusion_query_bits: raw.query_iv(glow::SAMPLES_PASSED, glow::QUERY_COUNTER_BITS),
        timer_query: false,
        extensions,
        features: Vec::new(),
    };

    // Mesa's eglGetProcAddress returns a dispatch stub for *any* gl* name, so whether a
    // function resolves says nothing on Mesa; decide by version/extension first.
    let core_timer = gl_major_minor >= (3, 3) || info.has_extension("GL_ARB_timer_query");
    let timer_fn = if core_timer {
        Some("glGetQueryObjectui64v")
    } else if info.has_extension("GL_EXT_timer_query") {
        Some("glGetQueryObjectui64vEXT")
    } else {
        None
    };
    raw.get_query_objectui64v = timer_fn.and_then(|name| {
        let p = loader(name);
        // SAFETY: the named function has exactly this C signature.
        (!p.is_null())
            .then(|| unsafe { std::mem::transmute::<*const c_void, PfnGetQueryObjectui64v>(p) })
    });
    info.timer_query = raw.get_query_objectui64v.is_some();

    let fbo_entry_points = !loader("glGenFramebuffers").is_null();
    info.compute_features(fbo_entry_points);
    // Leave no error from the probing above for the first real GL call to trip over.
    unsafe { while gl.get_error() != glow::NO_ERROR {} }
    info
}

/// Parses the leading `major.minor` of a GL/GLSL version string (`4.5 (Compat...) Mesa`,
/// `2.1 Mesa 24.0`, `1.20`, `OpenGL ES 3.2 ...`).
pub(crate) fn parse_major_minor(s: &str) -> Option<(u32, u32)> {
    let s = s.trim_start_matches(|c: char| !c.is_ascii_digit());
    let mut parts = s.splitn(2, '.');
    let major = parts.next()?.parse().ok()?;
    let minor_str: String = parts
        .next()?
        .chars()
        .take_while(|c| c.is_ascii_digit())
        .collect();
    Some((major, minor_str.parse().ok()?))
}

/// Running one `#[ignore]`d test of this binary in a child process with extra environment,
/// for checks that need a differently configured driver (Mesa reads its overrides once).
#[cfg(test)]
pub(crate) mod test_support {
    /// Runs test `name` (full path, e.g. `gpu::context::tests::x`) in a child process with
    /// `env` set; returns whether it passed and its combined output. A filter that matches
    /// nothing counts as a failure.
    pub(crate) fn run_ignored_test_in_child(name: &str, env: &[(&str, &str)]) -> (bool, String) {
        let exe = std::env::current_exe().expect("test binary path");
        let out = std::process::Command::new(exe)
            .args([
                "--exact",
                name,
                "--ignored",
                "--nocapture",
                "--test-threads=1",
            ])
            .envs(env.iter().copied())
            .output()
            .expect("spawn test binary");
        let stdout = String::from_utf8_lossy(&out.stdout);
        let text = format!("{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
        (out.status.success() && stdout.contains("1 passed"), text)
    }
}

#[cfg(test)]
mod tests {
    use super::test_support::run_ignored_test_in_child;
    use super::*;

    fn sample_info() -> GlInfo {
        let mut info = GlInfo {
            egl_platform: "test".into(),
            egl_vendor: "test".into(),
            egl_version: "1.5".into(),
            gl_version: "2.1 Test".into(),
            gl_major_minor: (2, 1),
            renderer: "TestGPU".into(),
            vendor: "test".into(),
            glsl_version: "1.20".into(),
            max_texture_size: 4096,
            max_viewport_dims: (4096, 4096),
            max_draw_buffers: 4,
            max_texture_units: 16,
            limit_profile: None,
            occlusion_query_bits: 32,
            timer_query: false,
            extensions: vec![
                "GL_ARB_texture_float".into(),
                "GL_ARB_framebuffer_object".into(),
            ],
            features: Vec::new(),
        };
        info.compute_features(true);
        info
    }

    #[test]
    fn version_parsing() {
        assert_eq!(
            parse_major_minor("4.5 (Compatibility Profile) Mesa 24.0.1"),
            Some((4, 5))
        );
        assert_eq!(parse_major_minor("2.1 Mesa 24.0.1"), Some((2, 1)));
        assert_eq!(parse_major_minor("1.20"), Some((1, 20)));
        assert_eq!(parse_major_minor("4.60 NVIDIA"), Some((4, 60)));
        assert_eq!(parse_major_minor("OpenGL ES 3.2 Mesa"), Some((3, 2)));
        assert_eq!(parse_major_minor("garbage"), None);
    }

    #[test]
    fn verdict_accepts_minimal_gl21_and_names_missing_features() {
        let info = sample_info();
        assert_eq!(info.verdict(), Ok(()));

        let mut old = sample_info();
        old.gl_major_minor = (2, 0);
        old.extensions.clear();
        old.max_draw_buffers = 1;
        old.compute_features(false);
        let reason = old.verdict().unwrap_err();
        assert!(reason.contains("TestGPU"), "{reason}");
        assert!(reason.contains("OpenGL >= 2.1"), "{reason}");
        assert!(reason.contains("float textures"), "{reason}");
        assert!(reason.contains("framebuffer objects"), "{reason}");
        assert!(reason.contains("draw buffers"), "{reason}");
        assert!(!reason.contains("occlusion"), "{reason}");
        assert!(old.to_string().contains("Verdict: UNUSABLE"));
    }

    #[test]
    fn ext_only_fbo_needs_core_entry_points() {
        let mut info = sample_info();
        info.extensions = vec![
            "GL_ARB_texture_float".into(),
            "GL_EXT_framebuffer_object".into(),
        ];
        info.compute_features(false);
        assert!(info.verdict().unwrap_err().contains("framebuffer objects"));
        info.compute_features(true);
        assert_eq!(info.verdict(), Ok(()));
    }

    #[test]
    fn context_reports_gl21_and_all_required_features() {
        with_test_context(|ctx| {
            let info = &ctx.info;
            assert!(info.gl_major_minor >= (2, 1), "{info}");
            assert!(info.features.len() >= 6);
            for (name, ok) in &info.features {
                assert!(ok, "missing {name}\n{info}");
            }
            assert_eq!(info.verdict(), Ok(()));
            assert!(!info.extensions.is_empty());
            assert!(
                info.max_draw_buffers >= 4 && info.max_texture_size >= 2048,
                "{info}"
            );
            assert!(info.max_texture_units >= 2, "{info}");
            let report = info.to_string();
            for needle in [
                "EGL platform:",
                "OpenGL version:",
                "GLSL version:",
                "Verdict: OK",
            ] {
                assert!(report.contains(needle), "{needle} missing in\n{report}");
            }
            // The context really is current and usable.
            assert_eq!(unsafe { ctx.gl.get_error() }, glow::NO_ERROR);
        });
    }

    #[test]
    fn two_contexts_on_one_display_survive_each_other() {
        with_test_context(|first| {
            let second = GlContext::new().expect("second context");
            drop(second);
            // Dropping the second must neither terminate the shared display nor leave the
            // thread without a current context once the first is made current again.
            first.make_current().expect("make first current again");
            let v = first.raw().string(glow::VERSION);
            assert_eq!(v.as_deref(), Some(first.info.gl_version.as_str()));
        });
    }

    fn default_is_mesa() -> bool {
        with_test_context(|ctx| ctx.info.gl_version.contains("Mesa"))
    }

    /// An inadequate driver (Mesa forced to GL 2.0) makes `new` fail with GlUnavailable
    /// naming the missing version, while `new_unchecked` still reports it.
    #[test]
    fn too_old_gl_is_gl_unavailable() {
        if !default_is_mesa() {
            eprintln!("not Mesa: cannot force an old GL version, skipping");
            return;
        }
        let (ok, out) = run_ignored_test_in_child(
            "gpu::context::tests::gl20_inner",
            &[
                ("MESA_GL_VERSION_OVERRIDE", "2.0"),
                ("MESA_GLSL_VERSION_OVERRIDE", "110"),
            ],
        );
        assert!(ok, "{out}");
    }

    #[test]
    #[ignore = "run by too_old_gl_is_gl_unavailable with Mesa forced to GL 2.0"]
    fn gl20_inner() {
        match GlContext::new() {
            Err(Error::GlUnavailable(reason)) => {
                eprintln!("{reason}");
                assert!(reason.contains("OpenGL >= 2.1"), "{reason}");
                assert!(reason.contains("GLSL >= 1.20"), "{reason}");
            }
            Err(other) => panic!("wrong error kind: {other}"),
            Ok(ctx) => panic!("GL 2.0 accepted:\n{}", ctx.info),
        }
        let ctx = GlContext::new_unchecked().expect("unchecked context");
        assert_eq!(ctx.info.gl_major_minor, (2, 0));
        assert!(
            ctx.info.to_string().contains("Verdict: UNUSABLE"),
            "{}",
            ctx.info
        );
    }

    /// Each display path on its own: the surfaceless platform must work here; the others
    /// must either work or fail with GlUnavailable naming that path (never panic or hang).
    #[test]
    fn each_egl_platform_can_be_forced() {
        for platform in ["surfaceless", "device", "default"] {
            let (ok, out) = run_ignored_test_in_child(
                "gpu::context::tests::forced_platform_inner",
                &[(PLATFORM_ENV, platform)],
            );
            eprintln!(
                "--- {PLATFORM_ENV}={platform}: {}\n{out}",
                if ok { "ok" } else { "failed" }
            );
            assert!(ok, "{platform}: {out}");
        }
        let (ok, out) = run_ignored_test_in_child(
            "gpu::context::tests::forced_platform_inner",
            &[(PLATFORM_ENV, "bogus")],
        );
        assert!(ok, "{out}");
    }

    #[test]
    #[ignore = "run by each_egl_platform_can_be_forced with FRAGTRACE_EGL_PLATFORM set"]
    fn forced_platform_inner() {
        let platform = std::env::var(PLATFORM_ENV).unwrap_or_default();
        match GlContext::new() {
            Ok(ctx) => {
                eprintln!("{}", ctx.info);
                let expect = match platform.as_str() {
                    "surfaceless" => "EGL_MESA_platform_surfaceless",
                    "device" => "EGL_EXT_platform_device",
                    _ => "EGL_DEFAULT_DISPLAY",
                };
                assert!(
                    ctx.info.egl_platform.contains(expect),
                    "{}",
                    ctx.info.egl_platform
                );
            }
            Err(Error::Usage(msg)) => assert_eq!(platform, "bogus", "{msg}"),
            Err(Error::GlUnavailable(reason)) => {
                eprintln!("{reason}");
                assert_ne!(platform, "surfaceless", "{reason}");
                assert!(reason.contains(&platform), "{reason}");
            }
            Err(other) => panic!("{other}"),
        }
    }
}
