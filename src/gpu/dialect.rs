//! The GL dialects the one renderer speaks: desktop OpenGL 2.1+ with GLSL 1.20 (the native
//! EGL path), WebGL 1 with GLSL ES 1.00 and WebGL 2 with GLSL ES 3.00 (the web page,
//! docs/web.md). The shaders of all three are generated from the same `glsl120/` sources
//! and the same contract ([`super::contract`]); a dialect only decides the program header
//! (version line, extension and precision lines; ES 3.00's renamed built-ins and declared
//! outputs), the quad's vertex shader, the texture formats a float stream is created with,
//! and how the host learns how many rays are still active.
//!
//! The GLSL 1.20 the passes are written in is, apart from the header, also GLSL ES 1.00:
//! no loops in the `multipass` kernel, no integer bit operations, no implicit int-to-float
//! conversions, `texture2D` and `gl_FragData`. tests/glsl_es_validate.rs holds the sources
//! to that (every generated ES program passes glslangValidator), and a snapshot test holds
//! the GLSL 1.20 output byte for byte.

/// A GL dialect (see the module documentation). Every difference is an exhaustive `match`
/// here, not a string edit elsewhere.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Dialect {
    /// Desktop OpenGL 2.1 or later (compatibility profile), GLSL 1.20: the native build.
    Glsl120,
    /// WebGL 1 (OpenGL ES 2.0) with `OES_texture_float`, `WEBGL_color_buffer_float` and
    /// `WEBGL_draw_buffers`, GLSL ES 1.00. No occlusion queries: the host counts active
    /// rays by reading back a byte mask ([`Dialect::counts_by_query`]).
    Essl100,
    /// WebGL 2 (OpenGL ES 3.0) with `EXT_color_buffer_float`, GLSL ES 3.00: loops, so the
    /// `looped` kernel too. The same sources, translated token by token
    /// ([`Dialect::translate`]): `in` for `varying`, `texture` for `texture2D`, one
    /// `layout(location = k) out vec4` per `gl_FragData[k]`. WebGL 2's occlusion queries
    /// only say whether any sample passed, so the host counts a byte mask as on WebGL 1.
    Essl300,
}

impl Dialect {
    /// The first lines of every fragment program: the version line, then what the dialect
    /// needs before any other line (extensions, default precisions).
    pub fn fragment_header(self) -> &'static str {
        match self {
            Dialect::Glsl120 => "#version 120",
            // highp in fragment shaders is optional in ES 2.0; every WebGL implementation
            // with float render targets has it, and the f32 arithmetic needs it.
            Dialect::Essl100 => {
                "#version 100\n\
                 #extension GL_EXT_draw_buffers : require\n\
                 precision highp float;\n\
                 precision highp int;\n\
                 precision highp sampler2D;"
            }
            Dialect::Essl300 => {
                "#version 300 es\n\
                 precision highp float;\n\
                 precision highp int;\n\
                 precision highp sampler2D;"
            }
        }
    }

    /// Rewrites an assembled program (its header included) into this dialect's words and
    /// returns the declarations to insert after the header. GLSL 1.20 and ES 1.00 take the
    /// sources as written; ES 3.00 renames the removed built-ins whole-identifier-wise
    /// (a `#define` cannot stand for the `gl_FragData` array) and declares one output per
    /// `gl_FragData[k]` the program writes, at location k (draw buffer k).
    pub fn translate(self, source: &mut String) -> String {
        match self {
            Dialect::Glsl120 | Dialect::Essl100 => String::new(),
            Dialect::Essl300 => {
                let mut outputs = Vec::new();
                *source = map_identifiers(source, |ident, rest| match ident {
                    "varying" => Some(("in".to_string(), 0)),
                    "texture2D" => Some(("texture".to_string(), 0)),
                    "gl_FragData" => {
                        // Every write names a constant draw buffer (`gl_FragData[2]`).
                        let digits: String = rest
                            .strip_prefix('[')?
                            .chars()
                            .take_while(char::is_ascii_digit)
                            .collect();
                        let k: u32 = digits.parse().ok()?;
                        rest[1 + digits.len()..].starts_with(']').then_some(())?;
                        if !outputs.contains(&k) {
                            outputs.push(k);
                        }
                        Some((format!("frag_data_{k}"), digits.len() + 2))
                    }
                    _ => None,
                });
                outputs.sort_unstable();
                outputs
                    .iter()
                    .map(|k| format!("layout(location = {k}) out vec4 frag_data_{k};\n"))
                    .collect()
            }
        }
    }

    /// The vertex shader of the full-screen quad every pass draws
    /// ([`QUAD_VERTEX_SHADER`](crate::gpu::gl::QUAD_VERTEX_SHADER) natively).
    pub const fn quad_vertex_shader(self) -> &'static str {
        match self {
            Dialect::Glsl120 => {
                "#version 120
attribute vec3 a_pos;
attribute vec2 a_uv;
varying vec2 v_uv;
void main() {
    v_uv = a_uv;
    gl_Position = vec4(a_pos, 1.0);
}
"
            }
            Dialect::Essl100 => {
                "#version 100
precision highp float;
attribute vec3 a_pos;
attribute vec2 a_uv;
varying vec2 v_uv;
void main() {
    v_uv = a_uv;
    gl_Position = vec4(a_pos, 1.0);
}
"
            }
            Dialect::Essl300 => {
                "#version 300 es
precision highp float;
in vec3 a_pos;
in vec2 a_uv;
out vec2 v_uv;
void main() {
    v_uv = a_uv;
    gl_Position = vec4(a_pos, 1.0);
}
"
            }
        }
    }

    /// Whether `GL_SAMPLES_PASSED` occlusion queries count the `count` pass's fragments.
    /// WebGL 1 has no queries (and WebGL 2's only say whether any sample passed), so there
    /// the `count` pass writes a byte per surviving fragment into an RGBA8 target that the
    /// host reads back and counts: exact counts, one `readPixels` per termination test.
    pub fn counts_by_query(self) -> bool {
        match self {
            Dialect::Glsl120 => true,
            Dialect::Essl100 | Dialect::Essl300 => false,
        }
    }

    /// The internal format a texture of `sized` (`GL_RGBA32F`, `GL_RGBA16F`, `GL_RGBA8`) is
    /// created with: WebGL 1 takes the unsized `GL_RGBA` and gets the precision from the
    /// pixel type alone (`GL_FLOAT` through `OES_texture_float`).
    pub fn internal_format(self, sized: u32) -> u32 {
        match self {
            Dialect::Glsl120 | Dialect::Essl300 => sized,
            Dialect::Essl100 => glow::RGBA,
        }
    }

    /// Whether the context can pick a framebuffer's read buffer (`glReadBuffer`); WebGL 1
    /// reads attachment 0 only.
    pub fn has_read_buffer(self) -> bool {
        match self {
            Dialect::Glsl120 | Dialect::Essl300 => true,
            Dialect::Essl100 => false,
        }
    }

    /// A short name for reports (`GLSL 1.20`, `GLSL ES 1.00`).
    pub fn name(self) -> &'static str {
        match self {
            Dialect::Glsl120 => "GLSL 1.20",
            Dialect::Essl100 => "GLSL ES 1.00",
            Dialect::Essl300 => "GLSL ES 3.00",
        }
    }

    /// Whether the dialect has loops with run-time bounds (the `looped` kernel).
    pub fn has_loops(self) -> bool {
        match self {
            Dialect::Glsl120 | Dialect::Essl300 => true,
            Dialect::Essl100 => false,
        }
    }
}

/// `source` with each identifier for which `f(identifier, text after it)` gives `(new,
/// n)` replaced by `new`, and the `n` bytes after it dropped. Comments and the header are
/// rewritten too, which is harmless; line breaks are kept, so line maps stay valid.
fn map_identifiers(
    source: &str,
    mut f: impl FnMut(&str, &str) -> Option<(String, usize)>,
) -> String {
    let mut out = String::with_capacity(source.len());
    let bytes = source.as_bytes();
    let ident = |b: u8| b.is_ascii_alphanumeric() || b == b'_';
    let mut i = 0;
    while i < bytes.len() {
        if ident(bytes[i]) {
            let start = i;
            while i < bytes.len() && ident(bytes[i]) {
                i += 1;
            }
            let word = &source[start..i];
            match f(word, &source[i..]) {
                Some((new, skip)) => {
                    out.push_str(&new);
                    i += skip;
                }
                None => out.push_str(word),
            }
        } else {
            let start = i;
            while i < bytes.len() && !ident(bytes[i]) {
                i += 1;
            }
            out.push_str(&source[start..i]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whole identifiers only, outputs declared once each in location order, GLSL 1.20
    /// and ES 1.00 untouched.
    #[test]
    fn essl300_translates_removed_builtins() {
        let src = "#version 300 es\nvarying vec2 v_uv;\nvoid main() {\n    \
                   gl_FragData[3] = texture2D(u_s0, v_uv);\n    \
                   gl_FragData[0] = my_texture2D(v_uv) + varying_x;\n    \
                   gl_FragData[3] = vec4(0.0);\n}\n";
        let mut s = src.to_string();
        let decls = Dialect::Essl300.translate(&mut s);
        assert_eq!(
            decls,
            "layout(location = 0) out vec4 frag_data_0;\n\
             layout(location = 3) out vec4 frag_data_3;\n"
        );
        assert_eq!(
            s,
            "#version 300 es\nin vec2 v_uv;\nvoid main() {\n    \
             frag_data_3 = texture(u_s0, v_uv);\n    \
             frag_data_0 = my_texture2D(v_uv) + varying_x;\n    \
             frag_data_3 = vec4(0.0);\n}\n"
        );
        for d in [Dialect::Glsl120, Dialect::Essl100] {
            let mut s = src.to_string();
            assert_eq!(d.translate(&mut s), "");
            assert_eq!(s, src);
        }
    }
}
