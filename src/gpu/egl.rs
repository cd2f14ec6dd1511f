//! The EGL session under a [`GlContext`](super::GlContext): loading libEGL, choosing a
//! display, creating a desktop-GL context and making it current, and undoing all of it in
//! `Drop`.
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
//! restrict the search to one of them. `--gpu N` (`open_session_on`) skips the search
//! and opens device N of `EGL_EXT_device_enumeration`'s list ([`list_devices`]): one GPU
//! per task on a multi-GPU node.

use std::collections::HashMap;
use std::ffi::{c_char, c_void, CStr};
use std::sync::{Mutex, OnceLock};

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

type PfnGetPlatformDisplayExt =
    unsafe extern "system" fn(egl::Enum, *mut c_void, *const egl::Int) -> egl::EGLDisplay;
type PfnQueryDevicesExt =
    unsafe extern "system" fn(egl::Int, *mut *mut c_void, *mut egl::Int) -> egl::Boolean;
type PfnQueryDeviceStringExt = unsafe extern "system" fn(*mut c_void, egl::Int) -> *const c_char;

/// Loads libEGL once per process; later calls reuse the instance (or the load error).
pub(super) fn egl_instance() -> Result<&'static EglInstance> {
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
pub(crate) struct EglSession {
    egl: &'static EglInstance,
    display: egl::Display,
    context: Option<egl::Context>,
    surface: Option<egl::Surface>,
    /// How the display was obtained and the context made current.
    pub(crate) platform: String,
    /// `EGL_VENDOR`.
    pub(crate) vendor: String,
    /// `EGL_VERSION`.
    pub(crate) version: String,
    /// libOpenGL/libGL, opened only when eglGetProcAddress cannot resolve core GL functions.
    pub(crate) fallback_lib: Option<libloading::Library>,
}

impl EglSession {
    /// Makes this session's context current on the calling thread.
    pub(crate) fn make_current(&self) -> std::result::Result<(), egl::Error> {
        self.egl
            .make_current(self.display, self.surface, self.surface, self.context)
    }

    /// Runs `f` with this session's context current, then puts back whatever was current
    /// before (or nothing). Skips `f` when the context cannot be made current.
    pub(crate) fn with_current(&self, f: impl FnOnce()) {
        let egl = self.egl;
        let previous = egl.get_current_context();
        if previous.is_some() && previous == self.context {
            f();
            return;
        }
        let display = egl.get_current_display();
        let draw = egl.get_current_surface(egl::DRAW);
        let read = egl.get_current_surface(egl::READ);
        if self.make_current().is_err() {
            return;
        }
        f();
        // Errors are ignored as in `Drop`: this runs while dropping GL objects.
        let _ = match (display, previous) {
            (Some(d), Some(_)) => egl.make_current(d, draw, read, previous),
            _ => egl.make_current(self.display, None, None, None),
        };
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
        // Frees EGL's per-thread state (Mesa keeps the last context/API there), unless
        // another context is current on this thread: the last GL object of this context
        // may be dropped while another is in use (see `with_current`).
        if egl.get_current_context().is_none() {
            let _ = egl.release_thread();
        }
    }
}

/// One EGL device (EGL_EXT_device_enumeration), as `fragtrace info` lists it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EglDevice {
    /// Its position in eglQueryDevicesEXT's list: what `--gpu N` takes.
    pub index: u32,
    /// Its DRM node (`/dev/dri/renderD128`, `/dev/dri/card1`), `software`, or `unnamed`.
    pub name: String,
    /// The CUDA device ordinal NVIDIA's driver reports for it (EGL_NV_device_cuda), the
    /// number CUDA_VISIBLE_DEVICES and Slurm's GPU binding speak.
    pub cuda: Option<i64>,
    /// The device's EGL extensions.
    pub extensions: String,
}

/// `EGL_CUDA_DEVICE_NV` (EGL_NV_device_cuda).
const CUDA_DEVICE_NV: egl::Int = 0x323A;

type PfnQueryDeviceAttribExt =
    unsafe extern "system" fn(*mut c_void, egl::Int, *mut egl::Attrib) -> egl::Boolean;

/// The EGL devices of this machine, in the order `--gpu N` numbers them, with their CUDA
/// ordinals. An EGL without device enumeration is an error saying so. Listed once per
/// process.
pub fn list_devices() -> Result<Vec<EglDevice>> {
    static DEVICES: OnceLock<std::result::Result<Vec<EglDevice>, String>> = OnceLock::new();
    cached(&DEVICES, true)
}

/// [`list_devices`] without the CUDA ordinals (`cuda` None): asking NVIDIA's driver for
/// one starts CUDA, 185-190 ms on the H100 machine, which `--backend auto`'s look at the
/// devices ([`software_only`]) does not need. Listed once per process.
fn list_devices_without_cuda() -> Result<Vec<EglDevice>> {
    static DEVICES: OnceLock<std::result::Result<Vec<EglDevice>, String>> = OnceLock::new();
    cached(&DEVICES, false)
}

fn cached(
    cell: &OnceLock<std::result::Result<Vec<EglDevice>, String>>,
    cuda: bool,
) -> Result<Vec<EglDevice>> {
    cell.get_or_init(|| {
        list_devices_now(cuda).map_err(|e| match e {
            Error::GlUnavailable(m) => m,
            other => other.to_string(),
        })
    })
    .clone()
    .map_err(Error::GlUnavailable)
}

fn list_devices_now(with_cuda: bool) -> Result<Vec<EglDevice>> {
    let egl = egl_instance()?;
    let client_exts = egl
        .query_string(None, egl::EXTENSIONS)
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let has_client = |name: &str| client_exts.split_ascii_whitespace().any(|e| e == name);
    if !(has_client("EGL_EXT_device_enumeration") || has_client("EGL_EXT_device_base")) {
        return Err(Error::GlUnavailable(
            "this EGL cannot list devices (no EGL_EXT_device_enumeration)".into(),
        ));
    }
    let devices = enumerate_devices(egl).map_err(Error::GlUnavailable)?;
    Ok(devices
        .into_iter()
        .enumerate()
        .map(|(i, d)| {
            let extensions = device_string(egl, d, egl::EXTENSIONS).unwrap_or_default();
            let cuda = (with_cuda
                && extensions
                    .split_ascii_whitespace()
                    .any(|e| e == "EGL_NV_device_cuda"))
            .then(|| device_attrib(egl, d, CUDA_DEVICE_NV))
            .flatten();
            EglDevice {
                index: i as u32,
                name: device_name(egl, d),
                cuda,
                extensions,
            }
        })
        .collect())
}

/// Whether the EGL devices a context would be made on (device `device` of
/// [`list_devices`], or every device when None) are all Mesa's software rasterizer: each
/// advertises `EGL_MESA_device_software`, which Mesa gives its software device alone. Then
/// any context made there is llvmpipe or softpipe, and `--backend auto` can take the CPU
/// without making one (about 40 ms of driver start-up here, in every CPU render). False
/// when the devices cannot be listed: the context's own renderer string decides then.
pub fn software_only(device: Option<u32>) -> bool {
    let Ok(devices) = list_devices_without_cuda() else {
        return false;
    };
    let software = |d: &EglDevice| {
        d.extensions
            .split_ascii_whitespace()
            .any(|e| e == "EGL_MESA_device_software")
    };
    let chosen: Vec<&EglDevice> = match device {
        Some(n) => devices.iter().filter(|d| d.index == n).collect(),
        None => devices.iter().collect(),
    };
    !chosen.is_empty() && chosen.into_iter().all(software)
}

/// `eglQueryDeviceAttribEXT`, None when it fails or is missing.
fn device_attrib(egl: &EglInstance, device: *mut c_void, name: egl::Int) -> Option<i64> {
    let f = egl.get_proc_address("eglQueryDeviceAttribEXT")?;
    // SAFETY: signature from EGL_EXT_device_query.
    let f: PfnQueryDeviceAttribExt =
        unsafe { std::mem::transmute::<extern "system" fn(), PfnQueryDeviceAttribExt>(f) };
    let mut value: egl::Attrib = 0;
    // SAFETY: a valid device and a pointer to one EGLAttrib.
    (unsafe { f(device, name, &mut value) } == egl::TRUE).then_some(value as i64)
}

/// Opens the EGL session on device `device` of [`list_devices`] only (`--gpu N`), or
/// on the first display that works ([`open_session`]) when None. A device number beyond
/// the list is a usage error naming how many there are.
pub(super) fn open_session_on(
    egl: &'static EglInstance,
    device: Option<u32>,
) -> Result<EglSession> {
    let Some(n) = device else {
        return open_session(egl);
    };
    let client_exts = egl
        .query_string(None, egl::EXTENSIONS)
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let has_client = |name: &str| client_exts.split_ascii_whitespace().any(|e| e == name);
    if !has_client("EGL_EXT_platform_device")
        || !(has_client("EGL_EXT_device_enumeration") || has_client("EGL_EXT_device_base"))
    {
        return Err(Error::GlUnavailable(format!(
            "--gpu {n}: this EGL cannot open a chosen device (it lacks EGL_EXT_device_enumeration or EGL_EXT_platform_device)"
        )));
    }
    let devices = enumerate_devices(egl).map_err(Error::GlUnavailable)?;
    let Some(&dev) = devices.get(n as usize) else {
        return Err(Error::Usage(match devices.len() {
            0 => format!("--gpu {n}: this machine has no EGL device"),
            1 => format!("--gpu {n}: this machine has 1 EGL device, --gpu 0 (`fragtrace info` lists it)"),
            k => format!(
                "--gpu {n}: this machine has {k} EGL devices, --gpu 0 to --gpu {} (`fragtrace info` lists them)",
                k - 1
            ),
        }));
    };
    let label = format!("EGL_EXT_platform_device #{n} ({})", device_name(egl, dev));
    // SAFETY: `dev` is an EGLDeviceEXT just returned by eglQueryDevicesEXT.
    let (display, via) = unsafe { platform_display(egl, &client_exts, PLATFORM_DEVICE_EXT, dev) }
        .map_err(|e| Error::GlUnavailable(format!("{label}: {e}")))?;
    try_display(
        egl,
        display,
        format!("{label} ({via}), chosen by --gpu"),
        &client_exts,
    )
    .map_err(|e| Error::GlUnavailable(format!("{label}: {e}")))
}

/// Tries each display candidate in turn; the error lists why each one failed.
pub(super) fn open_session(egl: &'static EglInstance) -> Result<EglSession> {
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

/// `eglQueryDeviceStringEXT`, None when it fails or is missing.
fn device_string(egl: &EglInstance, device: *mut c_void, name: egl::Int) -> Option<String> {
    let f = egl.get_proc_address("eglQueryDeviceStringEXT")?;
    // SAFETY: signature from EGL_EXT_device_query.
    let f: PfnQueryDeviceStringExt =
        unsafe { std::mem::transmute::<extern "system" fn(), PfnQueryDeviceStringExt>(f) };
    // SAFETY: valid device; EGL returns NULL or a static NUL-terminated string.
    let p = unsafe { f(device, name) };
    // SAFETY: `p` is checked non-NULL first, and EGL's device strings are NUL-terminated
    // and live as long as the display.
    (!p.is_null()).then(|| unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned())
}

/// A short description of an EGL device for reports: its DRM node, or "software".
fn device_name(egl: &EglInstance, device: *mut c_void) -> String {
    let query = |name| device_string(egl, device, name);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// `auto`'s listing without the CUDA ordinals names the same devices, in the same
    /// order and with the same extensions, as the whole one (`info`, `--gpu env`).
    #[test]
    fn the_listing_without_cuda_is_the_whole_one_less_the_ordinals() {
        let (Ok(whole), Ok(light)) = (list_devices(), list_devices_without_cuda()) else {
            // Both fail alike where EGL cannot list devices.
            assert_eq!(
                list_devices().is_err(),
                list_devices_without_cuda().is_err()
            );
            return;
        };
        let less = |d: &EglDevice| EglDevice {
            cuda: None,
            ..d.clone()
        };
        assert_eq!(whole.iter().map(less).collect::<Vec<_>>(), light);
        assert!(light.iter().all(|d| d.cuda.is_none()));
    }
}
