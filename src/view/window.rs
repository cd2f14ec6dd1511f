//! The window and its GL context: a winit window on X11 with a glutin context (EGL on
//! X11, or GLX where EGL is missing), asking for OpenGL 2.1, the most the kernels need.
//! [`WindowGl`] owns the context, the surface and the window; the renderer's
//! [`GlContext`] holds an `Rc` of it ([`SharedWindowGl`]), so the window's context lives
//! until the last GL object made in it is gone.

use std::ffi::{c_void, CString};
use std::num::NonZeroU32;
use std::rc::Rc;

use glutin::config::{Config, ConfigTemplateBuilder, GlConfig};
use glutin::context::{
    ContextApi, ContextAttributesBuilder, GlProfile, NotCurrentGlContext, PossiblyCurrentContext,
    Version,
};
use glutin::display::{Display, GetGlDisplay, GlDisplay};
use glutin::prelude::{GlSurface, PossiblyCurrentGlContext};
use glutin::surface::{Surface, SwapInterval, WindowSurface};
use glutin_winit::{ApiPreference, DisplayBuilder, GlWindow};
use raw_window_handle::HasWindowHandle;
use winit::dpi::PhysicalSize;
use winit::event_loop::EventLoop;
use winit::window::{Window, WindowAttributes};

use crate::gpu::context::ExternalContext;
use crate::gpu::GlContext;
use crate::{Error, Result};

/// A window with a current GL context. Field order is drop order: surface and context
/// before the window they draw into.
pub(super) struct WindowGl {
    surface: Surface<WindowSurface>,
    context: PossiblyCurrentContext,
    display: Display,
    /// The window.
    pub(super) window: Window,
}

impl WindowGl {
    /// Shows the back buffer.
    pub(super) fn swap(&self) -> Result<()> {
        self.surface
            .swap_buffers(&self.context)
            .map_err(|e| Error::Internal(format!("swapping the window's buffers: {e}")))
    }

    /// Resizes the surface to the window's new size (nothing for a zero size).
    pub(super) fn resize(&self, size: PhysicalSize<u32>) {
        if let (Some(w), Some(h)) = (NonZeroU32::new(size.width), NonZeroU32::new(size.height)) {
            self.surface.resize(&self.context, w, h);
        }
    }
}

/// The window's context as the renderer sees it (see [`ExternalContext`]).
pub(super) struct SharedWindowGl(pub(super) Rc<WindowGl>);

impl ExternalContext for SharedWindowGl {
    fn make_current(&self) -> bool {
        let w = &self.0;
        w.context.is_current() || w.context.make_current(&w.surface).is_ok()
    }

    fn get_proc_address(&self, name: &str) -> *const c_void {
        match CString::new(name) {
            Ok(c) => self.0.display.get_proc_address(&c),
            Err(_) => std::ptr::null(),
        }
    }

    fn platform(&self) -> String {
        match &self.0.display {
            Display::Egl(_) => "glutin EGL, X11 window".into(),
            Display::Glx(_) => "glutin GLX, X11 window".into(),
        }
    }

    fn api_version(&self) -> String {
        self.0.display.version_string()
    }
}

/// The event loop, or [`Error::GlUnavailable`] naming why there is no display.
pub(super) fn event_loop() -> Result<EventLoop<()>> {
    EventLoop::new().map_err(|e| {
        // winit says where in its source the error arose (`os error at FILE.rs:LINE: `).
        let msg = e.to_string();
        let why = match msg
            .find(".rs:")
            .and_then(|i| msg[i..].find(": ").map(|j| i + j + 2))
        {
            Some(k) => &msg[k..],
            None => &msg,
        };
        Error::GlUnavailable(no_window_message(
            why,
            std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty()),
        ))
    })
}

/// Why no window could be opened, for a user: the view speaks X11 only (winit is built
/// without Wayland), so winit's "neither WAYLAND_DISPLAY nor ... DISPLAY is set" would
/// suggest that a Wayland session could do; there it runs through XWayland, which sets
/// DISPLAY.
fn no_window_message(why: &str, display_set: bool) -> String {
    if display_set {
        format!("cannot open a window on the X11 display: {why}")
    } else {
        "cannot open a window: DISPLAY is not set (the view speaks X11 only: on a Wayland \
         desktop it runs through XWayland, which sets DISPLAY; without a desktop, run it \
         under xvfb-run -a)"
            .into()
    }
}

/// Picks an 8-bit RGB, single-sampled config, so that the window holds exactly the bytes
/// drawn and read back (no multisample resolve).
fn pick_config(configs: Box<dyn Iterator<Item = Config> + '_>) -> Option<Config> {
    use glutin::config::ColorBufferType;
    configs
        .filter(|c| c.num_samples() == 0)
        .filter(|c| {
            matches!(
                c.color_buffer_type(),
                Some(ColorBufferType::Rgb {
                    r_size: 8,
                    g_size: 8,
                    b_size: 8
                })
            )
        })
        .min_by_key(|c| (c.alpha_size(), c.depth_size(), c.stencil_size()))
}

/// Opens a `width` x `height` window titled `title` with a current GL context and wraps it
/// as a checked [`GlContext`].
pub(super) fn open(
    event_loop: &EventLoop<()>,
    width: u32,
    height: u32,
    title: &str,
) -> Result<(Rc<WindowGl>, GlContext)> {
    let unavailable = |what: &str, e: &dyn std::fmt::Display| {
        let why = e
            .to_string()
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        Error::GlUnavailable(format!("{what}: {why}"))
    };
    let attrs = WindowAttributes::default()
        .with_title(title)
        .with_inner_size(PhysicalSize::new(width, height));
    let mut picked = true;
    let (window, config) = DisplayBuilder::new()
        .with_preference(ApiPreference::PreferEgl)
        .with_window_attributes(Some(attrs))
        .build(event_loop, ConfigTemplateBuilder::new(), |configs| {
            let mut all: Vec<Config> = configs.collect();
            let best = pick_config(Box::new(all.clone().into_iter()));
            picked = best.is_some();
            best.unwrap_or_else(|| all.remove(0))
        })
        .map_err(|e| unavailable("cannot create a window with a GL configuration", &*e))?;
    if !picked {
        return Err(Error::GlUnavailable(
            "the display offers no single-sampled 8-bit RGB GL configuration".into(),
        ));
    }
    let window = window.ok_or_else(|| Error::GlUnavailable("no window was created".into()))?;
    let handle = window
        .window_handle()
        .map_err(|e| unavailable("window handle", &e))?
        .as_raw();
    let display = config.display();
    // OpenGL 2.1 is all any kernel needs; a driver may hand out a newer compatibility
    // context, which runs the same GLSL 1.20.
    let attrs = ContextAttributesBuilder::new()
        .with_context_api(ContextApi::OpenGl(Some(Version::new(2, 1))))
        .with_profile(GlProfile::Compatibility)
        .build(Some(handle));
    // SAFETY: the raw handle belongs to `window`, which outlives the context: WindowGl
    // holds both, and its fields drop in order, surface and context before the window.
    let not_current = unsafe { display.create_context(&config, &attrs) }.or_else(|e| {
        // A driver below 2.1 refuses the request; take what it has, so that the verdict
        // names what is missing.
        let any = ContextAttributesBuilder::new().build(Some(handle));
        // SAFETY: as above: the same handle, the same window.
        unsafe { display.create_context(&config, &any) }.map_err(|_| {
            unavailable(
                "cannot create an OpenGL 2.1 context (fragtrace needs OpenGL >= 2.1 \
                     with GLSL >= 1.20)",
                &e,
            )
        })
    })?;
    let surface_attrs = window
        .build_surface_attributes(Default::default())
        .map_err(|e| unavailable("window surface", &e))?;
    // SAFETY: as above.
    let surface = unsafe { display.create_window_surface(&config, &surface_attrs) }
        .map_err(|e| unavailable("cannot create the window surface", &e))?;
    let context = not_current
        .make_current(&surface)
        .map_err(|e| unavailable("cannot make the window's context current", &e))?;
    // Presenting must not wait for the display's refresh between passes.
    let _ = surface.set_swap_interval(&context, SwapInterval::DontWait);
    let wgl = Rc::new(WindowGl {
        surface,
        context,
        display,
        window,
    });
    let ctx = GlContext::from_external(Box::new(SharedWindowGl(wgl.clone())))?;
    Ok((wgl, ctx))
}
