//! The browser's WebGL 1 or 2 context as a [`GlContext`] (wasm32 only, docs/web.md): glow
//! over `web_sys::WebGlRenderingContext` or `WebGl2RenderingContext`, and the capability
//! report of what fragtrace needs there, in the terms WebGL names it. WebGL 1:
//! `OES_texture_float` (float textures), `WEBGL_color_buffer_float` (rendering into them),
//! `WEBGL_draw_buffers` (four output streams per pass), programs in [`Dialect::Essl100`].
//! WebGL 2: `EXT_color_buffer_float` (the rest is core), programs in [`Dialect::Essl300`].
//! Both: the texture units and the image size; the termination test reads back a byte
//! mask instead of an occlusion query, which WebGL 1 lacks and WebGL 2 has only as a yes/no.

use glow::HasContext;

use super::context::{web_context, GlContext};
use super::contract::REQUIRED_TEXTURE_UNITS;
use super::dialect::Dialect;
use super::info::{Check, GlInfo};
use crate::error::{Error, Result};

/// The extensions the WebGL 1 path needs, each with what it gives.
pub const REQUIRED_EXTENSIONS: [(&str, &str); 3] = [
    ("OES_texture_float", "float textures"),
    ("WEBGL_color_buffer_float", "float render targets"),
    ("WEBGL_draw_buffers", "several output streams per pass"),
];

/// The extension the WebGL 2 path needs (float textures, draw buffers and loops are core).
pub const REQUIRED_EXTENSIONS_WEBGL2: [(&str, &str); 1] =
    [("EXT_color_buffer_float", "float render targets")];

/// `WEBGL_debug_renderer_info`'s names of the implementation's vendor and renderer.
const UNMASKED_VENDOR_WEBGL: u32 = 0x9245;
const UNMASKED_RENDERER_WEBGL: u32 = 0x9246;

/// The passes write up to four streams at once.
const MIN_DRAW_BUFFERS: i32 = 4;

impl GlContext {
    /// Wraps a canvas's WebGL 1 context (glow enables every extension it knows when it
    /// wraps the context) and fails with [`Error::GlUnavailable`], naming what is missing,
    /// unless it has everything the multipass kernel needs. The report is returned either
    /// way inside the error's text, so the page can show the limits it met.
    pub fn from_webgl1(webgl: web_sys::WebGlRenderingContext) -> Result<GlContext> {
        let ctx = Self::from_webgl1_unchecked(webgl);
        ctx.info.verdict().map_err(Error::GlUnavailable)?;
        Ok(ctx)
    }

    /// [`GlContext::from_webgl1`] without judging the context, for a page that prints the
    /// report (`info.verdict()` says whether it can render).
    pub fn from_webgl1_unchecked(webgl: web_sys::WebGlRenderingContext) -> GlContext {
        let ext = webgl
            .get_extension("WEBGL_draw_buffers")
            .ok()
            .flatten()
            .map(wasm_bindgen::JsCast::unchecked_into::<web_sys::WebglDrawBuffers>);
        DRAW_BUFFERS.with(|d| *d.borrow_mut() = ext);
        let gl = glow::Context::from_webgl1_context(webgl);
        let info = gather_web_info(&gl, Dialect::Essl100);
        web_context(gl, info)
    }

    /// A canvas's WebGL 2 context, unjudged like [`GlContext::from_webgl1_unchecked`]:
    /// programs in [`Dialect::Essl300`], so the `looped` kernel runs too.
    pub fn from_webgl2_unchecked(webgl: web_sys::WebGl2RenderingContext) -> GlContext {
        DRAW_BUFFERS.with(|d| *d.borrow_mut() = None);
        let gl = glow::Context::from_webgl2_context(webgl);
        let info = gather_web_info(&gl, Dialect::Essl300);
        web_context(gl, info)
    }
}

/// Version strings, limits and extensions of a WebGL 1 or 2 context, and its verdict.
fn gather_web_info(gl: &glow::Context, dialect: Dialect) -> GlInfo {
    let webgl2 = dialect == Dialect::Essl300;
    // SAFETY: the page's context is the one WebGL context of this thread, and `int` is only
    // asked for single-valued limits (glow reads the WebGL value, no pointer is written).
    let int = |name| unsafe { gl.get_parameter_i32(name) };
    // SAFETY: as above; WebGL returns the string by value.
    let string = |name| unsafe { gl.get_parameter_string(name) };
    let mut extensions: Vec<String> = gl.supported_extensions().iter().cloned().collect();
    extensions.sort();
    let has = |n: &str| extensions.iter().any(|e| e == n);
    let mut dims = [0i32; 2];
    // SAFETY: GL_MAX_VIEWPORT_DIMS writes two integers.
    unsafe { gl.get_parameter_i32_slice(glow::MAX_VIEWPORT_DIMS, &mut dims) };
    // WEBGL_draw_buffers' MAX_DRAW_BUFFERS_WEBGL has the value of GL_MAX_DRAW_BUFFERS;
    // without the extension the query is an error, and one buffer is what there is.
    let max_draw_buffers = if webgl2 || has("WEBGL_draw_buffers") {
        int(glow::MAX_DRAW_BUFFERS)
    } else {
        1
    };
    let mut info = GlInfo {
        egl_platform: if webgl2 {
            "WebGL 2 (browser canvas)".into()
        } else {
            "WebGL 1 (browser canvas)".into()
        },
        egl_vendor: String::new(),
        egl_version: String::new(),
        gl_version: string(glow::VERSION),
        // The multipass design of GL 2.x is what `--kernel auto` picks here.
        // (WebGL 2 is ES 3.0; `auto` still picks multipass, the thesis's kernel.)
        gl_major_minor: (2, 0),
        // WebGL's RENDERER is a fixed string ("WebKit WebGL"); the debug extension names
        // the implementation underneath (SwiftShader, ANGLE on a GPU).
        renderer: if has("WEBGL_debug_renderer_info") {
            string(UNMASKED_RENDERER_WEBGL)
        } else {
            string(glow::RENDERER)
        },
        vendor: if has("WEBGL_debug_renderer_info") {
            string(UNMASKED_VENDOR_WEBGL)
        } else {
            string(glow::VENDOR)
        },
        glsl_version: string(glow::SHADING_LANGUAGE_VERSION),
        max_texture_size: int(glow::MAX_TEXTURE_SIZE),
        max_viewport_dims: (dims[0], dims[1]),
        max_draw_buffers,
        max_texture_units: int(glow::MAX_TEXTURE_IMAGE_UNITS),
        limit_profile: None,
        occlusion_query_bits: 0,
        timer_query: false,
        compute: false,
        dialect,
        features: Vec::new(),
        optional: Vec::new(),
        extensions: Vec::new(),
    };
    let required: &[(&str, &str)] = if webgl2 {
        &REQUIRED_EXTENSIONS_WEBGL2
    } else {
        &REQUIRED_EXTENSIONS
    };
    let mut features: Vec<Check> = required
        .iter()
        .map(|(ext, what)| Check::flag(format!("{what} ({ext})"), has(ext)))
        .collect();
    features.push(Check::new(
        format!("draw buffers (MAX_DRAW_BUFFERS_WEBGL >= {MIN_DRAW_BUFFERS})"),
        max_draw_buffers,
        max_draw_buffers >= MIN_DRAW_BUFFERS,
    ));
    features.push(Check::new(
        format!("fragment texture units (MAX_TEXTURE_IMAGE_UNITS >= {REQUIRED_TEXTURE_UNITS})"),
        info.max_texture_units,
        info.max_texture_units >= REQUIRED_TEXTURE_UNITS,
    ));
    info.features = features;
    info.extensions = extensions;
    // Leave no error from the probing for the first real call to trip over.
    // SAFETY: as above.
    unsafe { while gl.get_error() != glow::NO_ERROR {} }
    info
}

thread_local! {
    /// The page's `WEBGL_draw_buffers` object (one WebGL context per page), for
    /// [`draw_buffers`].
    static DRAW_BUFFERS: std::cell::RefCell<Option<web_sys::WebglDrawBuffers>> =
        const { std::cell::RefCell::new(None) };
}

/// `drawBuffersWEBGL(buffers)` on the page's context. glow 0.16 wraps the list in a second
/// array, which WebGL reads as `[GL_NONE]`: every pass would draw nothing.
/// On WebGL 2 (no extension object) glow's `drawBuffers` is right.
pub(crate) fn draw_buffers(gl: &glow::Context, buffers: &[u32]) {
    DRAW_BUFFERS.with(|d| {
        if let Some(ext) = d.borrow().as_ref() {
            let list = js_sys::Array::new();
            for &b in buffers {
                list.push(&wasm_bindgen::JsValue::from(b));
            }
            ext.draw_buffers_webgl(&list);
        } else {
            // SAFETY: every listed attachment exists (the caller's target's).
            unsafe { gl.draw_buffers(buffers) };
        }
    });
}
