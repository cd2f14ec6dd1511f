//! Programs: compiling and linking GLSL 1.20 with driver error lines mapped back to their
//! source files, and the full-screen quad every pass draws them over.

use glow::HasContext;

use super::{
    check_gl_error, f32_bytes, BufferKind, Owned, ProgramKind, ShaderKind, VertexArrayKind,
};
use crate::error::{Error, Result};
use crate::gpu::context::GlContext;
use crate::gpu::contract::{GlslType, Uniform, UniformValue, SAMPLERS};
use crate::gpu::dialect::Dialect;

/// Generic attribute index of the quad's position (`a_pos`). Index 0 on purpose: in a
/// compatibility profile attribute 0 aliases `gl_Vertex`, and some drivers (NVIDIA) draw
/// nothing unless attribute 0 is an enabled array.
pub const ATTRIB_POS: u32 = 0;
/// Generic attribute index of the quad's texture coordinate (`a_uv`).
pub const ATTRIB_UV: u32 = 1;

/// The vertex shader every pass uses with [`FullscreenQuad`] (GLSL 1.20).
///
/// The thesis sets an orthographic projection over [-1,1]^2 and draws the quad at z = -0.5;
/// that projection maps the quad onto itself, so the shader passes the position through as
/// clip coordinates instead of multiplying by an identity matrix.
pub const QUAD_VERTEX_SHADER: &str = Dialect::Glsl120.quad_vertex_shader();

/// Interleaved `x, y, z, u, v` of the quad's corners, counter-clockwise from bottom-left,
/// exactly as in the thesis.
const QUAD_VERTICES: [f32; 20] = [
    -1.0, -1.0, -0.5, 0.0, 0.0, //
    1.0, -1.0, -0.5, 1.0, 0.0, //
    1.0, 1.0, -0.5, 1.0, 1.0, //
    -1.0, 1.0, -0.5, 0.0, 1.0, //
];

/// A linked program's binary as GL hands it out (`glGetProgramBinary`): its format and
/// bytes, for the program-binary cache (`gpu::program_cache`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Binary {
    /// The driver's binary format enum.
    pub format: u32,
    /// The bytes.
    pub bytes: Vec<u8>,
}

/// A linked program; deleted when dropped.
#[derive(Debug)]
pub struct Program {
    obj: Owned<ProgramKind>,
    /// The pass it was built for, for messages.
    pub(super) pass: String,
    /// The contract's names its source declares ([`Program::declaring`]).
    declared: Vec<&'static str>,
}

impl Program {
    /// Gives the program up, its delete put off until `done` says the driver is through
    /// with it or the context goes ([`Owned::delete_when`]).
    pub(crate) fn delete_when(
        self,
        done: impl Fn(&glow::Context, glow::Program) -> bool + 'static,
    ) {
        self.obj.delete_when(done);
    }

    /// Wraps a program name created in this file ([`create_program`], a cached binary's).
    fn from_owned(obj: Owned<ProgramKind>, pass: &str) -> Self {
        Program {
            obj,
            pass: pass.to_string(),
            declared: Vec::new(),
        }
    }

    /// Records the contract's names the program's source declares (shader assembly's
    /// `Assembled::declared`): [`Program::set`] accepts only those.
    pub fn declaring(mut self, declared: Vec<&'static str>) -> Self {
        self.declared = declared;
        self
    }

    /// The raw name, for `glUseProgram` and uniform look-ups.
    pub fn name(&self) -> glow::Program {
        self.obj.name()
    }

    /// Makes the program current and sets uniform `u` to `value`.
    ///
    /// A uniform the program's source does not declare is an error: the host meant another
    /// program, and a silent skip would render a wrong image. A declared uniform that the
    /// compiler dropped (this specialisation never reads it) is skipped.
    pub fn set<T: GlslType>(&self, gl: &glow::Context, u: Uniform<T>, value: T) -> Result<()> {
        if !self.declared.contains(&u.name) {
            return Err(Error::Internal(format!(
                "the `{}` program does not declare uniform {} (its readers: {})",
                self.pass,
                u.name,
                u.readers.join(", ")
            )));
        }
        self.upload(gl, u.name, value.value());
        Ok(())
    }

    /// Makes the program current and sets the uniform called `name` to `value`, skipping
    /// one the compiler dropped: for a program assembled by hand (the GLSL twin tests'),
    /// whose uniforms and samplers are its own rather than the contract's.
    pub fn set_by_name<T: GlslType>(&self, ctx: &GlContext, name: &str, value: T) {
        self.upload(ctx.gl(), name, value.value());
    }

    /// `glUseProgram` and `glUniform*` of `name`, where the program has it.
    fn upload(&self, gl: &glow::Context, name: &str, value: UniformValue) {
        // SAFETY: the context is current (every caller renders on it) and the program is a
        // linked program of it; a location is used only with the program it came from.
        unsafe {
            gl.use_program(Some(self.name()));
            if let Some(loc) = gl.get_uniform_location(self.name(), name) {
                let loc = Some(&loc);
                match value {
                    UniformValue::Float(v) => gl.uniform_1_f32(loc, v),
                    UniformValue::Int(v) => gl.uniform_1_i32(loc, v),
                    UniformValue::Vec3([x, y, z]) => gl.uniform_3_f32(loc, x, y, z),
                    UniformValue::IVec2([x, y]) => gl.uniform_2_i32(loc, x, y),
                }
            }
        }
    }

    /// The program's binary (`glGetProgramBinary`), or None where the driver gives none.
    pub fn binary(&self, ctx: &GlContext) -> Option<Binary> {
        if ctx.info.program_binary_formats < 1 {
            return None;
        }
        let gl = ctx.gl();
        // SAFETY: the context is current and the program a linked program of it; glow sizes
        // the buffer by GL_PROGRAM_BINARY_LENGTH and reports a GL error as None.
        let b = unsafe {
            while gl.get_error() != glow::NO_ERROR {}
            gl.get_program_binary(self.name())?
        };
        (!b.buffer.is_empty()).then_some(Binary {
            format: b.format,
            bytes: b.buffer,
        })
    }

    /// Whether the program's source declares uniform `u`.
    pub fn declares<T>(&self, u: Uniform<T>) -> bool {
        self.declared.contains(&u.name)
    }

    /// Makes the program current and binds each of its samplers to its unit (the
    /// contract's [`SAMPLERS`]; those the program lacks are skipped).
    pub fn bind_samplers(&self, gl: &glow::Context) {
        // SAFETY: as in `set`: the context is current, the program a linked program of it,
        // and each location is used with the program it came from.
        unsafe {
            gl.use_program(Some(self.name()));
            for s in &SAMPLERS {
                if let Some(loc) = gl.get_uniform_location(self.name(), s.name) {
                    gl.uniform_1_i32(Some(&loc), s.unit.index() as i32);
                }
            }
        }
    }
}

#[cfg(test)]
impl Program {
    /// Every active uniform's name and GL type, as the driver reports them (what the
    /// contract's tests check the declarations against).
    pub(crate) fn active_uniforms(&self, gl: &glow::Context) -> Vec<(String, u32)> {
        // SAFETY: the context is current and the program a linked program of it; each
        // index is below the count GL reported.
        unsafe {
            (0..gl.get_active_uniforms(self.name()))
                .filter_map(|i| gl.get_active_uniform(self.name(), i))
                .map(|u| (u.name, u.utype))
                .collect()
        }
    }

    /// The value of `vec3` uniform `u` read back from the program (`None` where the
    /// compiler dropped it).
    pub(crate) fn uniform_vec3(
        &self,
        gl: &glow::Context,
        u: Uniform<glam::Vec3>,
    ) -> Option<[f32; 3]> {
        let mut back = [0f32; 3];
        // SAFETY: the context is current; the location is the program's own, and a vec3
        // uniform writes exactly the three floats `back` holds.
        unsafe {
            let loc = gl.get_uniform_location(self.name(), u.name)?;
            gl.get_uniform_f32(self.name(), &loc, &mut back);
        }
        Some(back)
    }
}

/// The full-screen quad each pass rasterises: one fragment per stream element.
///
/// Drawn from a GL 1.5 vertex buffer of interleaved position + texture coordinate, bound to
/// generic attributes [`ATTRIB_POS`] and [`ATTRIB_UV`] (which [`compile_program`] binds to
/// `a_pos`/`a_uv`). With the viewport set to a W×H target, `v_uv` at pixel (i, j) is the
/// pixel centre ((i+0.5)/W, (j+0.5)/H), so `texture2D(stream, v_uv)` with nearest filtering
/// fetches exactly texel (i, j) of a same-sized input.
#[derive(Debug)]
pub struct FullscreenQuad {
    vbo: Owned<BufferKind>,
    /// Only on GL >= 3.0, where a core-profile driver would reject drawing without a VAO;
    /// a 2.1 context has no VAOs and uses the default vertex state.
    vao: Option<Owned<VertexArrayKind>>,
}

/// A new vertex buffer, and a vertex array where the context has them (GL >= 3.0, where a
/// core-profile driver rejects drawing without one; a 2.1 context uses the default vertex
/// state): what the full-screen quad and the tile rectangles ([`super::rects::Rects`]) draw
/// from.
pub(crate) fn vertex_buffer(
    ctx: &GlContext,
) -> Result<(Owned<BufferKind>, Option<Owned<VertexArrayKind>>)> {
    let gl = ctx.gl();
    // SAFETY: the context is current; the new names are owned at once.
    unsafe {
        let vbo = Owned::new(
            ctx,
            gl.create_buffer()
                .map_err(|e| Error::Internal(format!("glGenBuffers: {e}")))?,
        );
        let vao = if gl.version().major >= 3 {
            gl.create_vertex_array().ok().map(|v| Owned::new(ctx, v))
        } else {
            None
        };
        Ok((vbo, vao))
    }
}

/// Floats a vertex of the quad and the tile rectangles holds: x, y, z, u, v.
pub(crate) const VERTEX_FLOATS: usize = 5;

/// Makes `program` current and binds `vbo` (through `vao` where the context has vertex
/// arrays) as vertices of [`VERTEX_FLOATS`]: position at [`ATTRIB_POS`], texture
/// coordinate at [`ATTRIB_UV`]; the layout the quad and the tile rectangles
/// ([`super::rects::Rects`]) share. [`unbind_vertices`] undoes it.
///
/// # Safety
/// The context is current and `vbo` holds whole vertices of that layout.
pub(crate) unsafe fn bind_vertices(
    gl: &glow::Context,
    program: &Program,
    vbo: &Owned<BufferKind>,
    vao: Option<&Owned<VertexArrayKind>>,
) {
    const STRIDE: i32 = (VERTEX_FLOATS * std::mem::size_of::<f32>()) as i32;
    gl.use_program(Some(program.name()));
    if let Some(vao) = vao {
        gl.bind_vertex_array(Some(vao.name()));
    }
    gl.bind_buffer(glow::ARRAY_BUFFER, Some(vbo.name()));
    gl.enable_vertex_attrib_array(ATTRIB_POS);
    gl.vertex_attrib_pointer_f32(ATTRIB_POS, 3, glow::FLOAT, false, STRIDE, 0);
    gl.enable_vertex_attrib_array(ATTRIB_UV);
    gl.vertex_attrib_pointer_f32(ATTRIB_UV, 2, glow::FLOAT, false, STRIDE, 12);
}

/// Undoes [`bind_vertices`] (`with_vao`: it bound a vertex array).
///
/// # Safety
/// The context is current.
pub(crate) unsafe fn unbind_vertices(gl: &glow::Context, with_vao: bool) {
    gl.disable_vertex_attrib_array(ATTRIB_POS);
    gl.disable_vertex_attrib_array(ATTRIB_UV);
    gl.bind_buffer(glow::ARRAY_BUFFER, None);
    if with_vao {
        gl.bind_vertex_array(None);
    }
}

impl FullscreenQuad {
    /// Uploads the quad's vertices.
    pub fn new(ctx: &GlContext) -> Result<Self> {
        let gl = ctx.gl();
        let (vbo, vao) = vertex_buffer(ctx)?;
        // SAFETY: the context is current; the buffer data is a local constant.
        unsafe {
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(vbo.name()));
            gl.buffer_data_u8_slice(
                glow::ARRAY_BUFFER,
                f32_bytes(&QUAD_VERTICES),
                glow::STATIC_DRAW,
            );
            gl.bind_buffer(glow::ARRAY_BUFFER, None);
            check_gl_error(gl, "creating the full-screen quad")?;
            Ok(FullscreenQuad { vbo, vao })
        }
    }

    /// One pass run by hand (the GLSL twin tests'): binds `target` as the destination and
    /// each texture of `textures` to its unit, then draws `program` over the whole target.
    /// Uniforms are set before ([`Program::set_by_name`]).
    pub fn draw_into(
        &self,
        ctx: &GlContext,
        target: &super::RenderTarget,
        program: &Program,
        textures: &[(u32, &super::Texture)],
    ) {
        let gl = ctx.gl();
        target.bind(gl);
        for &(unit, tex) in textures {
            super::state::bind_texture(gl, unit, Some(tex));
        }
        self.draw(gl, program);
    }

    /// Makes `program` current and draws the quad into the bound render target. Uniforms
    /// may be set before (after `gl.use_program(Some(program))`); textures must be bound to
    /// the units the program's samplers name.
    pub fn draw(&self, gl: &glow::Context, program: &Program) {
        // SAFETY: the buffer holds 4 vertices of the declared layout.
        unsafe {
            bind_vertices(gl, program, &self.vbo, self.vao.as_ref());
            // A fan over the 4 corners covers the same pixels as GL_QUADS, which core
            // profiles lack; the shared diagonal is rasterised once by the fill rule, so every
            // pixel gets exactly one fragment (occlusion counts rely on that).
            gl.draw_arrays(glow::TRIANGLE_FAN, 0, 4);
            unbind_vertices(gl, self.vao.is_some());
        }
    }
}

/// The program `pass` linked from a cached `binary` (`glProgramBinary`), or None where the
/// driver refuses it (another driver build, a damaged entry the header could not see): its
/// link status is the driver's verdict, and a refused binary leaves no error behind.
pub fn link_binary(ctx: &GlContext, pass: &str, binary: &Binary) -> Option<Program> {
    if ctx.info.program_binary_formats < 1 {
        return None;
    }
    let gl = ctx.gl();
    // SAFETY: the context is current; the program is created and owned here, and GL reads
    // exactly `binary.bytes.len()` bytes of the slice.
    unsafe {
        let program = Program::from_owned(Owned::new(ctx, gl.create_program().ok()?), pass);
        gl.program_binary(
            program.name(),
            &glow::ProgramBinary {
                buffer: binary.bytes.clone(),
                format: binary.format,
            },
        );
        let ok = gl.get_error() == glow::NO_ERROR && gl.get_program_link_status(program.name());
        while gl.get_error() != glow::NO_ERROR {}
        ok.then_some(program)
    }
}

/// Asks the driver to keep program `p`'s binary retrievable (before linking), where the
/// context can hand binaries out at all.
///
/// # Safety
/// The context is current and `p` one of its programs.
pub(super) unsafe fn keep_binary(ctx: &GlContext, p: glow::Program) {
    if ctx.info.program_binary_formats > 0 {
        ctx.gl().program_binary_retrievable_hint(p, true);
    }
}

/// A line map for a shader made of one file: line `n` of the source is line `n` of `file`.
pub fn single_file_line_map(file: &str) -> impl Fn(usize) -> (String, usize) + '_ {
    move |line| (file.to_string(), line)
}

/// Compiles and links a program from GLSL 1.20 sources, binding `a_pos`/`a_uv` to
/// [`ATTRIB_POS`]/[`ATTRIB_UV`] before linking.
///
/// On failure returns [`Error::Shader`] with the driver's full log. The first error line
/// number in the log (Mesa `0:12(5): error: ...`, NVIDIA `0(12) : error C0000: ...`,
/// AMD/Apple `ERROR: 0:12: ...`) is a line of the *assembled* fragment source; `line_map`
/// turns it into the original `(file, line)`. Vertex-shader errors name `<vertex shader>`
/// (always [`QUAD_VERTEX_SHADER`] in practice) and link errors `<link>`, unmapped.
pub fn compile_program(
    ctx: &GlContext,
    pass: &str,
    vertex_src: &str,
    fragment_src: &str,
    line_map: &dyn Fn(usize) -> (String, usize),
) -> Result<Program> {
    start_program(ctx, pass, vertex_src, fragment_src)?.finish(ctx, line_map)
}

/// A program whose shaders were handed to the driver to compile and link, and whose
/// outcome nobody has asked for yet: a driver with `GL_KHR_parallel_shader_compile` works
/// on several such at once, on its own threads, until [`PendingProgram::finish`] waits.
#[derive(Debug)]
pub struct PendingProgram {
    program: Program,
    vertex: Owned<ShaderKind>,
    fragment: Owned<ShaderKind>,
}

/// Starts compiling and linking the program [`compile_program`] builds, without waiting
/// for either (no status is queried until [`PendingProgram::finish`]).
pub fn start_program(
    ctx: &GlContext,
    pass: &str,
    vertex_src: &str,
    fragment_src: &str,
) -> Result<PendingProgram> {
    let gl = ctx.gl();
    // SAFETY: the context is current; every name used is created and owned here.
    unsafe {
        let vertex = start_shader(ctx, glow::VERTEX_SHADER, vertex_src)?;
        let fragment = start_shader(ctx, glow::FRAGMENT_SHADER, fragment_src)?;
        let program = create_program(ctx, pass)?;
        let p = program.name();
        gl.attach_shader(p, vertex.name());
        gl.attach_shader(p, fragment.name());
        gl.bind_attrib_location(p, ATTRIB_POS, "a_pos");
        gl.bind_attrib_location(p, ATTRIB_UV, "a_uv");
        keep_binary(ctx, p);
        gl.link_program(p);
        Ok(PendingProgram {
            program,
            vertex,
            fragment,
        })
    }
}

impl PendingProgram {
    /// Waits for the link and returns the program, or [`compile_program`]'s error: the
    /// first shader that did not compile (its error line mapped by `line_map` for the
    /// fragment shader), else the link's log.
    pub fn finish(
        self,
        ctx: &GlContext,
        line_map: &dyn Fn(usize) -> (String, usize),
    ) -> Result<Program> {
        let gl = ctx.gl();
        let pass = self.program.pass.clone();
        let shader_error = |file: String, line: usize, log: String| Error::Shader {
            pass: pass.clone(),
            file,
            line,
            log: log.trim_end().to_string(),
        };
        // SAFETY: the context is current; the shaders and the program are this value's.
        unsafe {
            let p = self.program.name();
            if !gl.get_program_link_status(p) {
                if let Err(log) = shader_outcome(gl, &self.vertex) {
                    let line = parse_error_line(&log).unwrap_or(0);
                    return Err(shader_error("<vertex shader>".into(), line, log));
                }
                if let Err(log) = shader_outcome(gl, &self.fragment) {
                    let (file, line) = match parse_error_line(&log) {
                        Some(n) => line_map(n),
                        None => ("<fragment shader>".to_string(), 0),
                    };
                    return Err(shader_error(file, line, log));
                }
                let log = gl.get_program_info_log(p);
                let line = parse_error_line(&log).unwrap_or(0);
                return Err(shader_error("<link>".into(), line, log));
            }
            // Shaders are only needed until link; detaching (and dropping them) lets the
            // driver free them now.
            gl.detach_shader(p, self.vertex.name());
            gl.detach_shader(p, self.fragment.name());
            check_gl_error(gl, &format!("building the `{pass}` program"))?;
        }
        Ok(self.program)
    }
}

/// Lets a driver with `GL_KHR_parallel_shader_compile` (or the ARB one) compile on as many
/// threads as it likes, where the default may be fewer.
pub fn allow_parallel_compile(ctx: &GlContext) {
    if super::compute::has_parallel_compile(ctx) {
        // SAFETY: the context is current and offers the entry point (its extension).
        unsafe { ctx.gl().max_shader_compiler_threads(0xFFFF_FFFF) };
    }
}

/// A new program with no shaders yet, named for `pass` in its errors.
///
/// # Safety
/// The context is current.
pub(super) unsafe fn create_program(ctx: &GlContext, pass: &str) -> Result<Program> {
    let name = ctx
        .gl()
        .create_program()
        .map_err(|e| Error::Internal(format!("glCreateProgram: {e}")))?;
    Ok(Program::from_owned(Owned::new(ctx, name), pass))
}

/// Hands `src` to the driver to compile as a shader of `kind`, without waiting (the
/// render and the compute programs alike).
///
/// # Safety
/// The context is current.
pub(super) unsafe fn start_shader(
    ctx: &GlContext,
    kind: u32,
    src: &str,
) -> Result<Owned<ShaderKind>> {
    let gl = ctx.gl();
    let shader = Owned::<ShaderKind>::new(
        ctx,
        gl.create_shader(kind)
            .map_err(|e| Error::Internal(format!("glCreateShader({kind:#x}): {e}")))?,
    );
    gl.shader_source(shader.name(), src);
    gl.compile_shader(shader.name());
    Ok(shader)
}

/// Whether `shader` compiled; `Err` carries the info log.
unsafe fn shader_outcome(
    gl: &glow::Context,
    shader: &Owned<ShaderKind>,
) -> std::result::Result<(), String> {
    if gl.get_shader_compile_status(shader.name()) {
        return Ok(());
    }
    let log = gl.get_shader_info_log(shader.name());
    Err(if log.trim().is_empty() {
        "compilation failed, the driver gave no log".to_string()
    } else {
        log
    })
}

/// The 1-based source line of the first error in a driver info log, or `None`. Prefers
/// lines that say "error" so that a warning listed first does not misdirect.
pub(crate) fn parse_error_line(log: &str) -> Option<usize> {
    log.lines()
        .filter(|l| l.to_ascii_lowercase().contains("error"))
        .find_map(parse_log_line)
        .or_else(|| log.lines().find_map(parse_log_line))
}

/// Line number of one log line in any of the known `<string>:<line>` layouts.
fn parse_log_line(line: &str) -> Option<usize> {
    fn digits(s: &str) -> Option<(usize, &str)> {
        let end = s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len());
        Some((s[..end].parse().ok()?, &s[end..]))
    }
    let s = line.trim_start();
    let s = s.strip_prefix("ERROR:").map_or(s, str::trim_start);
    let (_source_string, rest) = digits(s)?;
    if let Some(rest) = rest.strip_prefix(':') {
        // Mesa `0:12(5):` or AMD/Apple `0:12:`.
        let (line, rest) = digits(rest)?;
        (rest.starts_with('(') || rest.starts_with(':')).then_some(line)
    } else if let Some(rest) = rest.strip_prefix('(') {
        // NVIDIA `0(12) :`.
        let (line, rest) = digits(rest)?;
        rest.starts_with(')').then_some(line)
    } else {
        None
    }
}
