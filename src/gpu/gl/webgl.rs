//! The browser's WebGL 1 or 2 context under glow (wasm32 only, docs/web.md): wrapping it,
//! reading the strings, limits and extensions that `gpu::web` judges, and
//! `drawBuffersWEBGL`, which glow gets wrong on WebGL 1. The GL calls of the web page's
//! context, sealed here like every other ([`super`]).

use glow::HasContext;

/// `WEBGL_debug_renderer_info`'s names of the implementation's vendor and renderer.
const UNMASKED_VENDOR_WEBGL: u32 = 0x9245;
const UNMASKED_RENDERER_WEBGL: u32 = 0x9246;

/// What a WebGL context reports, read once when it is wrapped.
pub(crate) struct WebProbe {
    /// `GL_VERSION`.
    pub gl_version: String,
    /// The implementation underneath (`WEBGL_debug_renderer_info` where present; WebGL's
    /// own RENDERER is a fixed string such as "WebKit WebGL").
    pub renderer: String,
    /// Its vendor, likewise.
    pub vendor: String,
    /// `GL_SHADING_LANGUAGE_VERSION`.
    pub glsl_version: String,
    /// `GL_MAX_TEXTURE_SIZE`.
    pub max_texture_size: i32,
    /// `GL_MAX_VIEWPORT_DIMS`.
    pub max_viewport_dims: (i32, i32),
    /// `GL_MAX_DRAW_BUFFERS` (WebGL 2, or WebGL 1 with `WEBGL_draw_buffers`), else 1.
    pub max_draw_buffers: i32,
    /// `GL_MAX_TEXTURE_IMAGE_UNITS`.
    pub max_texture_units: i32,
    /// The supported extensions, sorted.
    pub extensions: Vec<String>,
}

/// Wraps a canvas's WebGL 1 context (glow enables every extension it knows when it wraps
/// it), keeping its `WEBGL_draw_buffers` object for [`draw_buffers`].
pub(crate) fn wrap_webgl1(webgl: web_sys::WebGlRenderingContext) -> glow::Context {
    let ext = webgl
        .get_extension("WEBGL_draw_buffers")
        .ok()
        .flatten()
        .map(wasm_bindgen::JsCast::unchecked_into::<web_sys::WebglDrawBuffers>);
    DRAW_BUFFERS.with(|d| *d.borrow_mut() = ext);
    glow::Context::from_webgl1_context(webgl)
}

/// Wraps a canvas's WebGL 2 context (`drawBuffers` is core there).
pub(crate) fn wrap_webgl2(webgl: web_sys::WebGl2RenderingContext) -> glow::Context {
    DRAW_BUFFERS.with(|d| *d.borrow_mut() = None);
    glow::Context::from_webgl2_context(webgl)
}

/// Reads what the page's context reports (`webgl2`: a WebGL 2 context), and leaves no
/// error from the probing for the first real call to trip over.
pub(crate) fn probe(gl: &glow::Context, webgl2: bool) -> WebProbe {
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
    let debug = has("WEBGL_debug_renderer_info");
    let probe = WebProbe {
        gl_version: string(glow::VERSION),
        renderer: string(if debug {
            UNMASKED_RENDERER_WEBGL
        } else {
            glow::RENDERER
        }),
        vendor: string(if debug {
            UNMASKED_VENDOR_WEBGL
        } else {
            glow::VENDOR
        }),
        glsl_version: string(glow::SHADING_LANGUAGE_VERSION),
        max_texture_size: int(glow::MAX_TEXTURE_SIZE),
        max_viewport_dims: (dims[0], dims[1]),
        max_draw_buffers,
        max_texture_units: int(glow::MAX_TEXTURE_IMAGE_UNITS),
        extensions,
    };
    super::state::clear_errors(gl);
    probe
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
