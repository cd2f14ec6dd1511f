//! Probing a new desktop context: the few GL entry points loaded directly (`RawGl`)
//! because glow's wrappers break on real GL 2.1 drivers, and the queries that fill its
//! [`GlInfo`] report (version strings, limits, extensions, timer queries).
//!
//! Every call here runs on the context being probed, current on this thread (the
//! `GlContext` constructors make it current before they probe, and keep it so).

use std::ffi::{c_void, CStr};

use glow::HasContext;

use crate::error::{Error, Result};
use crate::gpu::dialect::Dialect;
use crate::gpu::info::{effective_limit, limit_profile, parse_major_minor, GlInfo};

type PfnGetString = unsafe extern "system" fn(u32) -> *const u8;
type PfnGetQueryObjectuiv = unsafe extern "system" fn(u32, u32, *mut u32);
type PfnGetQueryObjectui64v = unsafe extern "system" fn(u32, u32, *mut u64);
type PfnGetQueryiv = unsafe extern "system" fn(u32, u32, *mut i32);
#[cfg(test)]
type PfnIsName = unsafe extern "system" fn(u32) -> u8;

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
    /// `glIsQuery` and `glIsVertexArray` (GL 3.0; `None` below), only for the tests' count
    /// of live GL objects, which glow does not wrap.
    #[cfg(test)]
    is_query: Option<PfnIsName>,
    #[cfg(test)]
    is_vertex_array: Option<PfnIsName>,
}

impl RawGl {
    /// `glGetString`, `None` where the driver returns NULL.
    pub(crate) fn string(&self, name: u32) -> Option<String> {
        // SAFETY: the pointer came from the current context's loader and has glGetString's
        // C signature; GL returns either NULL or a NUL-terminated static string.
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

    /// `glIsQuery(name)` and `glIsVertexArray(name)` (false where the driver lacks it).
    #[cfg(test)]
    pub(crate) fn is_query_and_vertex_array(&self, name: u32) -> (bool, bool) {
        // SAFETY: both take any name and only read state.
        let is = |f: Option<PfnIsName>| f.is_some_and(|f| unsafe { f(name) } != 0);
        (is(self.is_query), is(self.is_vertex_array))
    }

    /// `glGetQueryiv(target, pname)`.
    fn query_iv(&self, target: u32, pname: u32) -> i32 {
        let mut value = 0;
        // SAFETY: one-element out pointer; an unsupported target only raises a GL error.
        unsafe { (self.get_queryiv)(target, pname, &mut value) };
        value
    }
}

/// Loads the function tables of the current context through `loader`, vets its
/// GL_VERSION and gathers the report; `names` are the display API's platform, vendor and
/// version, as reported.
pub(crate) fn load(
    loader: &dyn Fn(&str) -> *const c_void,
    names: &[String; 3],
) -> Result<(glow::Context, RawGl, GlInfo)> {
    let mut raw = load_raw_gl(loader)?;
    // glow panics on a NULL or unparsable GL_VERSION, so vet it first.
    let gl_version = raw.string(glow::VERSION).ok_or_else(|| {
        Error::GlUnavailable(format!(
            "glGetString(GL_VERSION) returned NULL on {} although the context is current",
            names[0]
        ))
    })?;
    let gl_major_minor = parse_major_minor(&gl_version)
        .ok_or_else(|| Error::GlUnavailable(format!("cannot parse GL_VERSION `{gl_version}`")))?;
    // SAFETY: the context is current on this thread and `loader` resolves its functions.
    let gl = unsafe { glow::Context::from_loader_function(loader) };
    let info = gather_info(&gl, &mut raw, names, gl_version, gl_major_minor, loader);
    Ok((gl, raw, info))
}

/// Resolves the [`RawGl`] entry points; only the always-present GL 1.x/1.5 ones are mandatory.
pub(crate) fn load_raw_gl(loader: &dyn Fn(&str) -> *const c_void) -> Result<RawGl> {
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
            #[cfg(test)]
            is_query: (!loader("glIsQuery").is_null())
                .then(|| std::mem::transmute::<*const c_void, PfnIsName>(loader("glIsQuery"))),
            #[cfg(test)]
            is_vertex_array: (!loader("glIsVertexArray").is_null()).then(|| {
                std::mem::transmute::<*const c_void, PfnIsName>(loader("glIsVertexArray"))
            }),
        })
    }
}

/// Reads version strings, limits and extensions, and evaluates the requirements.
/// `session` is the display API's platform, vendor and version, as reported.
pub(crate) fn gather_info(
    gl: &glow::Context,
    raw: &mut RawGl,
    session: &[String; 3],
    gl_version: String,
    gl_major_minor: (u32, u32),
    loader: &dyn Fn(&str) -> *const c_void,
) -> GlInfo {
    let string = |name| raw.string(name).unwrap_or_default();
    // SAFETY: the context is current, and `int` is only asked for single-valued limits
    // (GetIntegerv writes one integer for each of them).
    let int = |name| unsafe { gl.get_parameter_i32(name) };

    // GL_EXTENSIONS through glGetString is the only way in a 2.1 context and still works in
    // 3.x compatibility profiles; a core profile returns NULL (+ GL_INVALID_ENUM) and needs
    // glGetStringi.
    let extensions: Vec<String> = match raw.string(glow::EXTENSIONS) {
        Some(s) => s.split_ascii_whitespace().map(str::to_owned).collect(),
        // SAFETY: the context is current; NUM_EXTENSIONS is one integer, and every index
        // asked for glGetStringi is below it.
        None => unsafe {
            while gl.get_error() != glow::NO_ERROR {}
            let n = gl.get_parameter_i32(glow::NUM_EXTENSIONS).max(0) as u32;
            (0..n)
                .map(|i| gl.get_parameter_indexed_string(glow::EXTENSIONS, i))
                .collect()
        },
    };
    let mut info = GlInfo {
        egl_platform: session[0].clone(),
        egl_vendor: session[1].clone(),
        egl_version: session[2].clone(),
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
        compute: false,
        program_binary_formats: 0,
        extensions,
        dialect: Dialect::Glsl120,
        features: Vec::new(),
        optional: Vec::new(),
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

    if gl_major_minor >= (4, 1) || info.has_extension("GL_ARB_get_program_binary") {
        info.program_binary_formats = int(glow::NUM_PROGRAM_BINARY_FORMATS).max(0);
    }

    let fbo_entry_points = !loader("glGenFramebuffers").is_null();
    info.compute_features(fbo_entry_points);
    // Leave no error from the probing above for the first real GL call to trip over.
    // SAFETY: glGetError has no preconditions beyond a current context.
    unsafe { while gl.get_error() != glow::NO_ERROR {} }
    info
}

/// Live names by kind, as the driver reports them, for names `1..=upto`: what the tests
/// that GL objects free themselves compare before and after.
#[cfg(test)]
pub(crate) fn live_objects(gl: &glow::Context, raw: &RawGl, upto: u32) -> Vec<(&'static str, u32)> {
    use std::num::NonZeroU32;
    let mut live = Vec::new();
    for n in 1..=upto {
        let id = NonZeroU32::new(n).expect("names start at 1");
        // SAFETY: the context is current; glIs* accept any name and only read state.
        let kinds = unsafe {
            [
                ("texture", gl.is_texture(glow::NativeTexture(id))),
                ("program", gl.is_program(glow::NativeProgram(id))),
                ("shader", gl.is_shader(glow::NativeShader(id))),
                (
                    "framebuffer",
                    gl.is_framebuffer(glow::NativeFramebuffer(id)),
                ),
                (
                    "renderbuffer",
                    gl.is_renderbuffer(glow::NativeRenderbuffer(id)),
                ),
                ("buffer", gl.is_buffer(glow::NativeBuffer(id))),
            ]
        };
        let (query, vao) = raw.is_query_and_vertex_array(n);
        for (kind, is) in kinds
            .into_iter()
            .chain([("query", query), ("vertex array", vao)])
        {
            if is {
                live.push((kind, n));
            }
        }
    }
    live
}
