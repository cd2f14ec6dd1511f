//! What a GL context is and whether fragtrace can use it: the [`GlInfo`] capability report
//! (version, limits, required features and the verdict), the [`LimitProfile`]s that shrink
//! a modern driver's limits to period hardware's. Probing a context to fill the report is
//! GL's business, in `gpu::gl::probe`.

use std::fmt;
use std::sync::OnceLock;

use super::contract::REQUIRED_TEXTURE_UNITS;
use super::dialect::Dialect;
use crate::error::{Error, Result};

/// The lowest GL version whose API (GLSL 1.20, MRT, VBOs, occlusion queries) the backend uses.
const MIN_GL: (u32, u32) = (2, 1);
/// The passes write up to four output streams at once (one per colour attachment).
const MIN_DRAW_BUFFERS: i32 = 4;
/// The image size `info` checks the limits against: the default image (a scene without an
/// `[image]` table). Larger renders are checked against the limits when they start.
const CHECK_IMAGE: (u32, u32) = (640, 480);

/// One capability check of [`GlInfo`]: what is checked, the value found, and the outcome.
#[derive(Debug, Clone, PartialEq)]
pub struct Check {
    /// What is needed, naming the GL version, extension or limit that provides it.
    pub name: String,
    /// What this context has (a version, a limit, or `yes`/`no`).
    pub value: String,
    /// Whether the context passes.
    pub ok: bool,
}

impl Check {
    pub(crate) fn new(name: impl Into<String>, value: impl fmt::Display, ok: bool) -> Self {
        Check {
            name: name.into(),
            value: value.to_string(),
            ok,
        }
    }

    pub(crate) fn flag(name: impl Into<String>, ok: bool) -> Self {
        Check::new(name, if ok { "yes" } else { "no" }, ok)
    }
}

/// Environment variable naming a historical card whose limits fragtrace imposes on top of
/// the driver's (`geforce7`; `texture=N` for the texture size alone), to prove the GL 2.1 path fits period hardware on a modern
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

/// The smallest texture size `FRAGTRACE_GL_LIMITS=texture=N` accepts: GL 2.1's own minimum.
pub const MIN_TEXTURE_SIZE: i32 = 64;

/// The profile named by [`LIMITS_ENV`], read once per process; `None` when unset or empty.
/// Besides the named cards, `texture=N` lowers only `GL_MAX_TEXTURE_SIZE` to N (tests: a
/// layout past the texture size on a scene small enough to build in a moment).
///
/// # Panics
/// Never; an unknown name is reported by [`GlContext::new_unchecked`](super::GlContext::new_unchecked) as a usage error.
pub fn limit_profile() -> std::result::Result<Option<LimitProfile>, String> {
    static PROFILE: OnceLock<std::result::Result<Option<LimitProfile>, String>> = OnceLock::new();
    PROFILE
        .get_or_init(|| match std::env::var(LIMITS_ENV) {
            Err(_) => Ok(None),
            Ok(v) if v.is_empty() => Ok(None),
            Ok(v) if v == GEFORCE7.name => Ok(Some(GEFORCE7)),
            Ok(v) => match v.strip_prefix("texture=").map(str::parse::<i32>) {
                Some(Ok(size)) if size >= MIN_TEXTURE_SIZE => Ok(Some(LimitProfile {
                    // Read once per process (the `OnceLock`), so the name is leaked once.
                    name: Box::leak(v.into_boxed_str()),
                    max_texture_size: size,
                    max_draw_buffers: i32::MAX,
                    max_texture_units: i32::MAX,
                })),
                _ => Err(format!(
                    "{LIMITS_ENV}={v} is not a known profile (expected geforce7, or \
                     texture=N with N >= {MIN_TEXTURE_SIZE})"
                )),
            },
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
/// `optional` lists the capabilities only some options need.
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
    /// Whether the compute kernel can run: OpenGL 4.3 and GLSL 4.30 (compute shaders,
    /// storage buffers, image load/store, f64 arithmetic for the primary directions).
    pub compute: bool,
    /// `GL_NUM_PROGRAM_BINARY_FORMATS` (GL 4.1 or `GL_ARB_get_program_binary`; 0 without
    /// them): at least one, and programs can be cached as binaries
    /// (`gpu::program_cache`). Mesa offers one only while its own disk cache is on.
    pub program_binary_formats: i32,
    /// Every extension the context advertises.
    pub extensions: Vec<String>,
    /// The GL dialect the programs are generated in and the host speaks
    /// ([`Dialect::Glsl120`] natively, [`Dialect::Essl100`] on WebGL 1).
    pub dialect: Dialect,
    /// Each required capability (human-readable, naming the GL version/extension that
    /// provides it), the value found and whether this context has it.
    pub features: Vec<Check>,
    /// Each optional capability and the option that needs it: without one, only that
    /// option is refused (or, for timer queries, per-pass times are left out).
    pub optional: Vec<Check>,
}

/// Whether `renderer` (a `GL_RENDERER` string) names one of Mesa's software rasterizers
/// (llvmpipe, softpipe, swrast): GL run on the CPU, not on a GPU.
pub fn software_renderer(renderer: &str) -> bool {
    let r = renderer.to_ascii_lowercase();
    ["llvmpipe", "softpipe", "swrast"]
        .iter()
        .any(|s| r.contains(s))
}

impl GlInfo {
    /// Whether the context advertises the extension `name` (e.g. `GL_ARB_texture_float`).
    pub fn has_extension(&self, name: &str) -> bool {
        self.extensions.iter().any(|e| e == name)
    }

    /// Whether this GL is a software rasterizer ([`software_renderer`] of its renderer).
    pub fn is_software(&self) -> bool {
        software_renderer(&self.renderer)
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
            .filter(|c| !c.ok)
            .map(|c| c.name.as_str())
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
    pub(crate) fn compute_features(&mut self, fbo_entry_points: bool) {
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
        let float_tex = gl >= (3, 0) || ext("GL_ARB_texture_float");
        let (tw, th) = (self.max_texture_size, self.max_texture_size);
        let (vw, vh) = self.max_viewport_dims;
        let (iw, ih) = (tw.min(vw).max(0) as u32, th.min(vh).max(0) as u32);
        // The mask buffer is a depth renderbuffer attached to the ray-state framebuffers
        // (any FBO has depth attachments); the stencil mask needs it packed with stencil.
        let packed =
            gl >= (3, 0) || ext("GL_ARB_framebuffer_object") || ext("GL_EXT_packed_depth_stencil");
        // Attachments of different formats in one framebuffer: EXT_framebuffer_object
        // alone requires one format for all of them.
        let mixed = (gl >= (3, 0) || ext("GL_ARB_framebuffer_object")) && float_tex;
        self.features = vec![
            Check::new(
                format!("OpenGL >= {}.{}", MIN_GL.0, MIN_GL.1),
                format!("{}.{}", gl.0, gl.1),
                gl >= MIN_GL,
            ),
            Check::new("GLSL >= 1.20 (#version 120)", &self.glsl_version, glsl_ok),
            Check::flag(
                "float textures (OpenGL 3.0 or GL_ARB_texture_float)",
                float_tex,
            ),
            Check::flag(
                "framebuffer objects (OpenGL 3.0, GL_ARB_framebuffer_object or GL_EXT_framebuffer_object)",
                fbo,
            ),
            Check::new(
                format!("draw buffers (OpenGL 2.0, GL_MAX_DRAW_BUFFERS >= {MIN_DRAW_BUFFERS})"),
                self.max_draw_buffers,
                gl >= (2, 0) && self.max_draw_buffers >= MIN_DRAW_BUFFERS,
            ),
            Check::new(
                "occlusion queries (OpenGL 1.5 or GL_ARB_occlusion_query, counter bits > 0)",
                format!("{} bits", self.occlusion_query_bits),
                (gl >= (1, 5) || ext("GL_ARB_occlusion_query")) && self.occlusion_query_bits > 0,
            ),
            Check::new(
                format!(
                    "fragment texture units (GL_MAX_TEXTURE_IMAGE_UNITS >= {REQUIRED_TEXTURE_UNITS})"
                ),
                self.max_texture_units,
                self.max_texture_units >= REQUIRED_TEXTURE_UNITS,
            ),
            Check::new(
                format!(
                    "image size (GL_MAX_TEXTURE_SIZE and GL_MAX_VIEWPORT_DIMS >= {}x{}, the default image)",
                    CHECK_IMAGE.0, CHECK_IMAGE.1
                ),
                format!("up to {iw}x{ih}"),
                iw >= CHECK_IMAGE.0 && ih >= CHECK_IMAGE.1,
            ),
        ];
        self.compute =
            gl >= (4, 3) && parse_major_minor(&self.glsl_version).is_some_and(|v| v >= (4, 30));
        self.optional = vec![
            Check::flag(
                "compute shaders, for --kernel compute and its choice by --kernel auto (OpenGL 4.3, GLSL 4.30)",
                self.compute,
            ),
            Check::flag(
                "timer queries, for per-pass GPU times (OpenGL 3.3, GL_ARB_timer_query or GL_EXT_timer_query)",
                self.timer_query,
            ),
            Check::flag(
                "depth renderbuffer, for --mask early-z (framebuffer objects)",
                fbo,
            ),
            Check::flag(
                "packed depth-stencil renderbuffer, for --mask stencil (OpenGL 3.0, GL_ARB_framebuffer_object or GL_EXT_packed_depth_stencil)",
                fbo && packed,
            ),
            Check::flag(
                "mixed-format framebuffers (RGBA16F beside RGBA32F), for --storage f16 (OpenGL 3.0 or GL_ARB_framebuffer_object)",
                mixed,
            ),
        ];
    }
}

impl fmt::Display for GlInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
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
        writeln!(
            f,
            "Program binaries: {} formats (the shader cache: {})",
            self.program_binary_formats,
            if self.program_binary_formats > 0 {
                "on"
            } else {
                "off, programs compiled every run"
            }
        )?;
        // Each check on one line: outcome, what is checked, the value found. A missing
        // optional capability reads "optional": it only refuses the option it names.
        writeln!(f, "Required:")?;
        for c in &self.features {
            let status = if c.ok { "pass" } else { "FAIL" };
            writeln!(f, "  [{status}] {}: {}", c.name, c.value)?;
        }
        writeln!(f, "Optional:")?;
        for c in &self.optional {
            let status = if c.ok { "pass" } else { "optional" };
            writeln!(f, "  [{status}] {}: {}", c.name, c.value)?;
        }
        match self.verdict() {
            Ok(()) => write!(f, "Verdict: OK, the GPU backend can run on this context"),
            Err(reason) => write!(f, "Verdict: UNUSABLE, {reason}"),
        }
    }
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

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn sample_info() -> GlInfo {
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
            compute: false,
            program_binary_formats: 0,
            extensions: vec![
                "GL_ARB_texture_float".into(),
                "GL_ARB_framebuffer_object".into(),
            ],
            dialect: Dialect::Glsl120,
            features: Vec::new(),
            optional: Vec::new(),
        };
        info.compute_features(true);
        info
    }

    #[test]
    fn software_renderers_are_recognised_by_name() {
        for r in [
            "llvmpipe (LLVM 15.0.7, 256 bits)",
            "softpipe",
            "Mesa X11 swrast",
            "LLVMPIPE",
        ] {
            assert!(software_renderer(r), "{r}");
        }
        for r in ["NVIDIA H200/PCIe/SSE2", "AMD Radeon RX 7900", "TestGPU", ""] {
            assert!(!software_renderer(r), "{r}");
        }
        assert!(!sample_info().is_software());
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
    fn optional_checks_do_not_decide_the_verdict() {
        let mut info = sample_info();
        info.extensions = vec![
            "GL_ARB_texture_float".into(),
            "GL_EXT_framebuffer_object".into(),
        ];
        // EXT_framebuffer_object with core entry points: usable, but one format per
        // framebuffer and no packed depth-stencil.
        info.compute_features(true);
        assert_eq!(info.verdict(), Ok(()));
        let report = info.to_string();
        for line in ["--mask stencil", "--storage f16", "timer queries"] {
            let l = report.lines().find(|l| l.contains(line)).unwrap();
            assert!(l.contains("[optional]") && l.ends_with(": no"), "{l}");
        }
        assert!(report.contains("[pass] depth renderbuffer"), "{report}");

        info.max_texture_units = 8;
        info.max_viewport_dims = (512, 4096);
        info.compute_features(true);
        let reason = info.verdict().unwrap_err();
        assert!(reason.contains("texture units"), "{reason}");
        assert!(reason.contains("image size"), "{reason}");
        let report = info.to_string();
        assert!(report.contains("[FAIL] fragment texture units"), "{report}");
        assert!(report.contains(": up to 512x4096"), "{report}");
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
}
