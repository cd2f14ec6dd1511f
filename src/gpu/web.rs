//! The browser's WebGL 1 or 2 context as a [`GlContext`] (wasm32 only, docs/web.md): glow
//! over `web_sys::WebGlRenderingContext` or `WebGl2RenderingContext`, and the capability
//! report of what fragtrace needs there, in the terms WebGL names it. WebGL 1:
//! `OES_texture_float` (float textures), `WEBGL_color_buffer_float` (rendering into them),
//! `WEBGL_draw_buffers` (four output streams per pass), programs in [`Dialect::Essl100`].
//! WebGL 2: `EXT_color_buffer_float` (the rest is core), programs in [`Dialect::Essl300`].
//! Both: the texture units and the image size; the termination test reads back a byte
//! mask instead of an occlusion query, which WebGL 1 lacks and WebGL 2 has only as a yes/no.

use super::context::{web_context, GlContext};
use super::contract::REQUIRED_TEXTURE_UNITS;
use super::dialect::Dialect;
use super::gl::webgl::{probe, wrap_webgl1, wrap_webgl2};
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
        let gl = wrap_webgl1(webgl);
        let info = web_info(&gl, Dialect::Essl100);
        web_context(gl, info)
    }

    /// A canvas's WebGL 2 context, unjudged like [`GlContext::from_webgl1_unchecked`]:
    /// programs in [`Dialect::Essl300`], so the `looped` kernel runs too.
    pub fn from_webgl2_unchecked(webgl: web_sys::WebGl2RenderingContext) -> GlContext {
        let gl = wrap_webgl2(webgl);
        let info = web_info(&gl, Dialect::Essl300);
        web_context(gl, info)
    }
}

/// Version strings, limits and extensions of a WebGL 1 or 2 context (read by
/// `gpu::gl::webgl`), and its verdict.
fn web_info(gl: &glow::Context, dialect: Dialect) -> GlInfo {
    let webgl2 = dialect == Dialect::Essl300;
    let p = probe(gl, webgl2);
    let has = |n: &str| p.extensions.iter().any(|e| e == n);
    let mut info = GlInfo {
        egl_platform: if webgl2 {
            "WebGL 2 (browser canvas)".into()
        } else {
            "WebGL 1 (browser canvas)".into()
        },
        egl_vendor: String::new(),
        egl_version: String::new(),
        gl_version: p.gl_version.clone(),
        // The multipass design of GL 2.x is what `--kernel auto` picks here.
        // (WebGL 2 is ES 3.0; `auto` still picks multipass, the thesis's kernel.)
        gl_major_minor: (2, 0),
        renderer: p.renderer.clone(),
        vendor: p.vendor.clone(),
        glsl_version: p.glsl_version.clone(),
        max_texture_size: p.max_texture_size,
        max_viewport_dims: p.max_viewport_dims,
        max_draw_buffers: p.max_draw_buffers,
        max_texture_units: p.max_texture_units,
        limit_profile: None,
        occlusion_query_bits: 0,
        timer_query: false,
        compute: false,
        program_binary_formats: 0,
        dialect,
        features: Vec::new(),
        optional: Vec::new(),
        extensions: Vec::new(),
    };
    let max_draw_buffers = p.max_draw_buffers;
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
    info.extensions = p.extensions;
    info
}
