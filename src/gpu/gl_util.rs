//! Low-level GL helpers shared by the render passes: float textures, multi-target FBOs,
//! read-back, the full-screen quad, shader compilation with source-mapped errors, and
//! occlusion/timer queries.
//!
//! Everything here targets the OpenGL 2.1 API (GLSL 1.20, VBOs, ARB_framebuffer_object
//! names) so that it runs unchanged in a 2.1 context and in any newer compatibility profile.
//! Functions take the `glow::Context` of a [`GlContext`] that must be current on the calling
//! thread; they leave the objects they create unbound unless documented otherwise.
//!
//! Termination detection: a pass's fragment program ends with `discard` for rays that have
//! nothing left to do. `GL_SAMPLES_PASSED` counts only fragments that were *not* discarded,
//! so an [`OcclusionQuery`] around a pass tells the host how many rays are still active
//! without reading any texture back (Purcell et al. 2002, section 4).

use glow::HasContext;

use crate::error::{Error, Result};
use crate::gpu::context::{effective_limit, GlContext};

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
pub const QUAD_VERTEX_SHADER: &str = "#version 120
attribute vec3 a_pos;
attribute vec2 a_uv;
varying vec2 v_uv;
void main() {
    v_uv = a_uv;
    gl_Position = vec4(a_pos, 1.0);
}
";

/// Interleaved `x, y, z, u, v` of the quad's corners, counter-clockwise from bottom-left,
/// exactly as in the thesis.
const QUAD_VERTICES: [f32; 20] = [
    -1.0, -1.0, -0.5, 0.0, 0.0, //
    1.0, -1.0, -0.5, 1.0, 0.0, //
    1.0, 1.0, -0.5, 1.0, 1.0, //
    -1.0, 1.0, -0.5, 0.0, 1.0, //
];

/// Returns `Err` with every pending GL error (named) if any is set; `what` says which
/// operation was being checked. `GL_OUT_OF_MEMORY` maps to [`Error::Limit`], the rest to
/// [`Error::Internal`] because they indicate a bug or a driver fault.
pub fn check_gl_error(gl: &glow::Context, what: &str) -> Result<()> {
    let mut names = Vec::new();
    let mut out_of_memory = false;
    // Bounded: a lost context can report errors forever.
    for _ in 0..16 {
        // SAFETY: glGetError has no preconditions beyond a current context.
        let code = unsafe { gl.get_error() };
        if code == glow::NO_ERROR {
            break;
        }
        out_of_memory |= code == glow::OUT_OF_MEMORY;
        names.push(gl_error_name(code));
    }
    if names.is_empty() {
        Ok(())
    } else if out_of_memory {
        Err(Error::Limit(format!(
            "{what}: GPU out of memory ({})",
            names.join(", ")
        )))
    } else {
        Err(Error::Internal(format!(
            "{what}: OpenGL error {}",
            names.join(", ")
        )))
    }
}

fn gl_error_name(code: u32) -> String {
    match code {
        glow::INVALID_ENUM => "GL_INVALID_ENUM".into(),
        glow::INVALID_VALUE => "GL_INVALID_VALUE".into(),
        glow::INVALID_OPERATION => "GL_INVALID_OPERATION".into(),
        glow::STACK_OVERFLOW => "GL_STACK_OVERFLOW".into(),
        glow::STACK_UNDERFLOW => "GL_STACK_UNDERFLOW".into(),
        glow::OUT_OF_MEMORY => "GL_OUT_OF_MEMORY".into(),
        glow::INVALID_FRAMEBUFFER_OPERATION => "GL_INVALID_FRAMEBUFFER_OPERATION".into(),
        other => format!("0x{other:04X}"),
    }
}

fn framebuffer_status_name(status: u32) -> String {
    match status {
        glow::FRAMEBUFFER_COMPLETE => "GL_FRAMEBUFFER_COMPLETE".into(),
        glow::FRAMEBUFFER_UNDEFINED => "GL_FRAMEBUFFER_UNDEFINED".into(),
        glow::FRAMEBUFFER_INCOMPLETE_ATTACHMENT => "GL_FRAMEBUFFER_INCOMPLETE_ATTACHMENT".into(),
        glow::FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT => {
            "GL_FRAMEBUFFER_INCOMPLETE_MISSING_ATTACHMENT".into()
        }
        // Only EXT_framebuffer_object defines these two; ARB/3.0 folded them into UNSUPPORTED.
        0x8CD9 => "GL_FRAMEBUFFER_INCOMPLETE_DIMENSIONS_EXT".into(),
        0x8CDA => "GL_FRAMEBUFFER_INCOMPLETE_FORMATS_EXT".into(),
        glow::FRAMEBUFFER_INCOMPLETE_DRAW_BUFFER => "GL_FRAMEBUFFER_INCOMPLETE_DRAW_BUFFER".into(),
        glow::FRAMEBUFFER_INCOMPLETE_READ_BUFFER => "GL_FRAMEBUFFER_INCOMPLETE_READ_BUFFER".into(),
        glow::FRAMEBUFFER_UNSUPPORTED => {
            "GL_FRAMEBUFFER_UNSUPPORTED (the driver cannot render to RGBA32F here)".into()
        }
        glow::FRAMEBUFFER_INCOMPLETE_MULTISAMPLE => "GL_FRAMEBUFFER_INCOMPLETE_MULTISAMPLE".into(),
        glow::FRAMEBUFFER_INCOMPLETE_LAYER_TARGETS => {
            "GL_FRAMEBUFFER_INCOMPLETE_LAYER_TARGETS".into()
        }
        0 => "0 (glCheckFramebufferStatus itself failed)".into(),
        other => format!("0x{other:04X}"),
    }
}

/// Checks a requested texture size against `GL_MAX_TEXTURE_SIZE` (a user-controlled value:
/// image resolution or scene size decides it, hence [`Error::Limit`]).
fn check_texture_size(gl: &glow::Context, width: u32, height: u32) -> Result<()> {
    // SAFETY: plain state query.
    let max = effective_limit(
        unsafe { gl.get_parameter_i32(glow::MAX_TEXTURE_SIZE) },
        |p| p.max_texture_size,
    )
    .max(0) as u32;
    if width == 0 || height == 0 {
        return Err(Error::Internal(format!(
            "texture size {width}x{height} is empty"
        )));
    }
    if width > max || height > max {
        return Err(Error::Limit(format!(
            "texture {width}x{height} exceeds GL_MAX_TEXTURE_SIZE {max}"
        )));
    }
    Ok(())
}

fn rgba_len(width: u32, height: u32) -> usize {
    width as usize * height as usize * 4
}

fn f32_bytes(data: &[f32]) -> &[u8] {
    // SAFETY: f32 has no padding and any byte pattern is a valid u8; the length is exact.
    unsafe { std::slice::from_raw_parts(data.as_ptr().cast::<u8>(), std::mem::size_of_val(data)) }
}

fn f32_bytes_mut(data: &mut [f32]) -> &mut [u8] {
    // SAFETY: as above, and every byte pattern written back is a valid f32.
    unsafe {
        std::slice::from_raw_parts_mut(data.as_mut_ptr().cast::<u8>(), std::mem::size_of_val(data))
    }
}

/// Creates a `width`×`height` RGBA32F 2D texture with `GL_NEAREST` filtering and
/// `GL_CLAMP_TO_EDGE` wrapping, filled from `data` (RGBA, row-major from the bottom row, as
/// GL stores it) or left uninitialised when `data` is `None`.
///
/// Nearest filtering is essential, not a style choice: streams hold indices and exact
/// coordinates, and any interpolation between texels would corrupt them. It also avoids the
/// default `GL_NEAREST_MIPMAP_LINEAR`, which would make a mip-less texture incomplete.
pub fn create_float_texture(
    gl: &glow::Context,
    width: u32,
    height: u32,
    data: Option<&[f32]>,
) -> Result<glow::Texture> {
    create_texture(gl, width, height, TexFormat::Rgba32F, data)
}

/// Internal format of a stream texture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TexFormat {
    /// 32-bit floats: exact integers to 2^24, what indices and hit distances need.
    Rgba32F,
    /// 16-bit floats (ARB_texture_float's RGBA16F, as on GeForce 6/7-class cards): half the
    /// memory traffic, 11 significant bits, integers exact only to 2048.
    Rgba16F,
}

impl TexFormat {
    fn gl_enum(self) -> u32 {
        match self {
            TexFormat::Rgba32F => glow::RGBA32F,
            TexFormat::Rgba16F => glow::RGBA16F,
        }
    }

    /// Bytes per texel.
    pub fn bytes(self) -> u64 {
        match self {
            TexFormat::Rgba32F => 16,
            TexFormat::Rgba16F => 8,
        }
    }
}

/// [`create_float_texture`] with a chosen internal format (data, when given, is f32 and is
/// rounded by the driver for [`TexFormat::Rgba16F`]).
pub fn create_texture(
    gl: &glow::Context,
    width: u32,
    height: u32,
    format: TexFormat,
    data: Option<&[f32]>,
) -> Result<glow::Texture> {
    check_texture_size(gl, width, height)?;
    if let Some(d) = data {
        if d.len() != rgba_len(width, height) {
            return Err(Error::Internal(format!(
                "texture data has {} floats, {width}x{height} RGBA needs {}",
                d.len(),
                rgba_len(width, height)
            )));
        }
    }
    // SAFETY: the context is current; the slice length was checked against the upload size.
    unsafe {
        let texture = gl
            .create_texture()
            .map_err(|e| Error::Internal(format!("glGenTextures: {e}")))?;
        gl.bind_texture(glow::TEXTURE_2D, Some(texture));
        gl.tex_parameter_i32(
            glow::TEXTURE_2D,
            glow::TEXTURE_MIN_FILTER,
            glow::NEAREST as i32,
        );
        gl.tex_parameter_i32(
            glow::TEXTURE_2D,
            glow::TEXTURE_MAG_FILTER,
            glow::NEAREST as i32,
        );
        gl.tex_parameter_i32(
            glow::TEXTURE_2D,
            glow::TEXTURE_WRAP_S,
            glow::CLAMP_TO_EDGE as i32,
        );
        gl.tex_parameter_i32(
            glow::TEXTURE_2D,
            glow::TEXTURE_WRAP_T,
            glow::CLAMP_TO_EDGE as i32,
        );
        // Rows of RGBA32F are always 16-byte multiples, but a caller may have changed the
        // unpack state; 4 is the GL default and correct for f32 data.
        gl.pixel_store_i32(glow::UNPACK_ALIGNMENT, 4);
        gl.tex_image_2d(
            glow::TEXTURE_2D,
            0,
            format.gl_enum() as i32,
            width as i32,
            height as i32,
            0,
            glow::RGBA,
            glow::FLOAT,
            glow::PixelUnpackData::Slice(data.map(f32_bytes)),
        );
        gl.bind_texture(glow::TEXTURE_2D, None);
        if let Err(e) = check_gl_error(gl, &format!("creating an {format:?} texture")) {
            gl.delete_texture(texture);
            return Err(e);
        }
        Ok(texture)
    }
}

/// Replaces the whole contents of an RGBA32F texture created by [`create_float_texture`]
/// (`data` must hold `width*height*4` floats).
pub fn upload_float_texture(
    gl: &glow::Context,
    texture: glow::Texture,
    width: u32,
    height: u32,
    data: &[f32],
) -> Result<()> {
    if data.len() != rgba_len(width, height) {
        return Err(Error::Internal(format!(
            "texture data has {} floats, {width}x{height} RGBA needs {}",
            data.len(),
            rgba_len(width, height)
        )));
    }
    // SAFETY: the context is current; the slice length was checked.
    unsafe {
        gl.bind_texture(glow::TEXTURE_2D, Some(texture));
        gl.pixel_store_i32(glow::UNPACK_ALIGNMENT, 4);
        gl.tex_sub_image_2d(
            glow::TEXTURE_2D,
            0,
            0,
            0,
            width as i32,
            height as i32,
            glow::RGBA,
            glow::FLOAT,
            glow::PixelUnpackData::Slice(Some(f32_bytes(data))),
        );
        gl.bind_texture(glow::TEXTURE_2D, None);
    }
    check_gl_error(gl, "uploading an RGBA32F texture")
}

/// Reads a whole RGBA32F texture back with `glGetTexImage` (`width`/`height` must be the
/// texture's size). Use [`RenderTarget::read_attachment`] for a texture attached to an FBO
/// that was just rendered; both return the same data.
pub fn read_texture_rgba32f(
    gl: &glow::Context,
    texture: glow::Texture,
    width: u32,
    height: u32,
) -> Result<Vec<f32>> {
    let mut out = vec![0.0f32; rgba_len(width, height)];
    // SAFETY: the buffer holds exactly width*height RGBA floats, the size of level 0.
    unsafe {
        gl.bind_texture(glow::TEXTURE_2D, Some(texture));
        gl.pixel_store_i32(glow::PACK_ALIGNMENT, 4);
        gl.get_tex_image(
            glow::TEXTURE_2D,
            0,
            glow::RGBA,
            glow::FLOAT,
            glow::PixelPackData::Slice(Some(f32_bytes_mut(&mut out))),
        );
        gl.bind_texture(glow::TEXTURE_2D, None);
    }
    check_gl_error(gl, "reading an RGBA32F texture")?;
    Ok(out)
}

/// Creates a `width`×`height` renderbuffer for masking rays out of passes: 24-bit depth, or
/// packed depth 24 + stencil 8 when `stencil` (EXT_packed_depth_stencil, core in GL 3.0;
/// stencil-only renderbuffers were never widely supported).
pub fn create_mask_buffer(
    gl: &glow::Context,
    width: u32,
    height: u32,
    stencil: bool,
) -> Result<glow::Renderbuffer> {
    check_texture_size(gl, width, height)?;
    // SAFETY: the context is current.
    unsafe {
        let rb = gl
            .create_renderbuffer()
            .map_err(|e| Error::Internal(format!("glGenRenderbuffers: {e}")))?;
        gl.bind_renderbuffer(glow::RENDERBUFFER, Some(rb));
        let format = if stencil {
            glow::DEPTH24_STENCIL8
        } else {
            glow::DEPTH_COMPONENT24
        };
        gl.renderbuffer_storage(glow::RENDERBUFFER, format, width as i32, height as i32);
        gl.bind_renderbuffer(glow::RENDERBUFFER, None);
        if let Err(e) = check_gl_error(gl, "creating a mask renderbuffer") {
            gl.delete_renderbuffer(rb);
            return Err(e);
        }
        Ok(rb)
    }
}

/// A framebuffer object with N float colour attachments of one size: the output streams of
/// one pass.
///
/// GL objects are not freed on drop (that would need the context); call
/// [`RenderTarget::delete`], or let them go with the [`GlContext`].
#[derive(Debug)]
pub struct RenderTarget {
    framebuffer: glow::Framebuffer,
    textures: Vec<glow::Texture>,
    width: u32,
    height: u32,
}

impl RenderTarget {
    /// Creates the FBO and `attachments` fresh (uninitialised) RGBA32F textures of
    /// `width`×`height`. Fails with [`Error::Limit`] when `attachments` exceeds
    /// `GL_MAX_DRAW_BUFFERS`/`GL_MAX_COLOR_ATTACHMENTS` or the size exceeds
    /// `GL_MAX_TEXTURE_SIZE`, and with [`Error::GlUnavailable`] naming the status when the
    /// driver reports the framebuffer incomplete.
    pub fn new(gl: &glow::Context, width: u32, height: u32, attachments: usize) -> Result<Self> {
        Self::with_formats(gl, width, height, &vec![TexFormat::Rgba32F; attachments])
    }

    /// [`RenderTarget::new`] with one internal format per attachment. Mixing formats in
    /// one FBO needs GL 3.0 or ARB_framebuffer_object (EXT_framebuffer_object reports
    /// `INCOMPLETE_FORMATS`), which is reported as [`Error::GlUnavailable`].
    pub fn with_formats(
        gl: &glow::Context,
        width: u32,
        height: u32,
        formats: &[TexFormat],
    ) -> Result<Self> {
        let attachments = formats.len();
        // SAFETY: plain state queries.
        let (max_draw, max_color) = unsafe {
            (
                gl.get_parameter_i32(glow::MAX_DRAW_BUFFERS),
                gl.get_parameter_i32(glow::MAX_COLOR_ATTACHMENTS),
            )
        };
        let max = effective_limit(max_draw.min(max_color), |p| p.max_draw_buffers).max(0) as usize;
        if attachments == 0 || attachments > max {
            return Err(Error::Limit(format!(
                "{attachments} colour attachments requested, the driver allows 1..={max}"
            )));
        }
        check_texture_size(gl, width, height)?;
        let mut textures = Vec::with_capacity(attachments);
        for &format in formats {
            match create_texture(gl, width, height, format, None) {
                Ok(t) => textures.push(t),
                Err(e) => {
                    // SAFETY: deleting textures this function just created.
                    unsafe { textures.iter().for_each(|&t| gl.delete_texture(t)) };
                    return Err(e);
                }
            }
        }
        // SAFETY: the context is current; every name used was created above.
        unsafe {
            let framebuffer = match gl.create_framebuffer() {
                Ok(f) => f,
                Err(e) => {
                    textures.iter().for_each(|&t| gl.delete_texture(t));
                    return Err(Error::Internal(format!("glGenFramebuffers: {e}")));
                }
            };
            let target = RenderTarget {
                framebuffer,
                textures,
                width,
                height,
            };
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(framebuffer));
            for (i, &t) in target.textures.iter().enumerate() {
                gl.framebuffer_texture_2d(
                    glow::FRAMEBUFFER,
                    glow::COLOR_ATTACHMENT0 + i as u32,
                    glow::TEXTURE_2D,
                    Some(t),
                    0,
                );
            }
            // Completeness depends on the draw/read buffer state (GL 2.1 + ARB_fbo rule
            // INCOMPLETE_DRAW_BUFFER), so set them before checking.
            target.set_draw_buffers(gl);
            gl.read_buffer(glow::COLOR_ATTACHMENT0);
            let status = gl.check_framebuffer_status(glow::FRAMEBUFFER);
            gl.bind_framebuffer(glow::FRAMEBUFFER, None);
            if status != glow::FRAMEBUFFER_COMPLETE {
                target.delete(gl);
                return Err(Error::GlUnavailable(format!(
                    "framebuffer with attachment(s) {formats:?} of {width}x{height} \
                     is incomplete: {}",
                    framebuffer_status_name(status)
                )));
            }
            if let Err(e) = check_gl_error(gl, "creating a render target") {
                target.delete(gl);
                return Err(e);
            }
            Ok(target)
        }
    }

    /// Attaches `buffer` (from [`create_mask_buffer`]) as this FBO's depth buffer, and as
    /// its stencil buffer when `stencil`. Several targets may share one buffer: that is how
    /// a mask written while drawing into one ping-pong target tests the draws into the other.
    pub fn attach_mask_buffer(
        &self,
        gl: &glow::Context,
        buffer: glow::Renderbuffer,
        stencil: bool,
    ) -> Result<()> {
        // SAFETY: the context is current; both names belong to it.
        unsafe {
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(self.framebuffer));
            // Two attachment points rather than GL 3.0's DEPTH_STENCIL_ATTACHMENT, which
            // EXT_packed_depth_stencil-era drivers do not know.
            gl.framebuffer_renderbuffer(
                glow::FRAMEBUFFER,
                glow::DEPTH_ATTACHMENT,
                glow::RENDERBUFFER,
                Some(buffer),
            );
            if stencil {
                gl.framebuffer_renderbuffer(
                    glow::FRAMEBUFFER,
                    glow::STENCIL_ATTACHMENT,
                    glow::RENDERBUFFER,
                    Some(buffer),
                );
            }
            self.set_draw_buffers(gl);
            let status = gl.check_framebuffer_status(glow::FRAMEBUFFER);
            gl.bind_framebuffer(glow::FRAMEBUFFER, None);
            if status != glow::FRAMEBUFFER_COMPLETE {
                return Err(Error::GlUnavailable(format!(
                    "framebuffer with a {} mask buffer is incomplete: {}",
                    if stencil { "depth-stencil" } else { "depth" },
                    framebuffer_status_name(status)
                )));
            }
        }
        check_gl_error(gl, "attaching a mask buffer")
    }

    fn set_draw_buffers(&self, gl: &glow::Context) {
        let buffers: Vec<u32> = (0..self.textures.len() as u32)
            .map(|i| glow::COLOR_ATTACHMENT0 + i)
            .collect();
        // SAFETY: every listed attachment exists and the count is within MAX_DRAW_BUFFERS.
        unsafe { gl.draw_buffers(&buffers) };
    }

    /// Makes this the render destination: binds the FBO, routes `gl_FragData[i]` to
    /// attachment `i` for every attachment, and sets the viewport to the whole target
    /// (a surfaceless context starts with a 0×0 viewport, so this must not be skipped).
    pub fn bind(&self, gl: &glow::Context) {
        // SAFETY: the FBO is complete (checked at creation) and owned by this context.
        unsafe {
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(self.framebuffer));
            self.set_draw_buffers(gl);
            gl.viewport(0, 0, self.width as i32, self.height as i32);
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The FBO name, for callers that need raw GL access.
    pub fn framebuffer(&self) -> glow::Framebuffer {
        self.framebuffer
    }

    /// The texture behind attachment `index` (to bind as the next pass's input).
    ///
    /// # Panics
    /// When `index` is not below the attachment count.
    pub fn texture(&self, index: usize) -> glow::Texture {
        self.textures[index]
    }

    /// All attachment textures, attachment 0 first.
    pub fn textures(&self) -> &[glow::Texture] {
        &self.textures
    }

    /// Reads attachment `index` back as `width*height*4` floats (bottom row first). Leaves
    /// this target bound as the framebuffer.
    pub fn read_attachment(&self, gl: &glow::Context, index: usize) -> Result<Vec<f32>> {
        self.read_attachment_region(gl, index, 0, 0, self.width, self.height)
    }

    /// Reads a `width`×`height` rectangle at (`x`,`y`) of attachment `index`, e.g. the few
    /// texels a pass's reduction left its answer in. Leaves this target bound.
    pub fn read_attachment_region(
        &self,
        gl: &glow::Context,
        index: usize,
        x: u32,
        y: u32,
        width: u32,
        height: u32,
    ) -> Result<Vec<f32>> {
        if index >= self.textures.len() {
            return Err(Error::Internal(format!(
                "attachment {index} requested, render target has {}",
                self.textures.len()
            )));
        }
        if x.checked_add(width).is_none_or(|r| r > self.width)
            || y.checked_add(height).is_none_or(|t| t > self.height)
        {
            return Err(Error::Internal(format!(
                "read region {width}x{height}+{x}+{y} outside {}x{} target",
                self.width, self.height
            )));
        }
        let mut out = vec![0.0f32; rgba_len(width, height)];
        // SAFETY: the buffer holds exactly width*height RGBA floats; the region is in range.
        unsafe {
            // GL_FRAMEBUFFER rather than GL_READ_FRAMEBUFFER: EXT_framebuffer_object has no
            // separate read binding. Float buffers are not clamped on read because
            // GL_CLAMP_READ_COLOR defaults to GL_FIXED_ONLY.
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(self.framebuffer));
            gl.read_buffer(glow::COLOR_ATTACHMENT0 + index as u32);
            gl.pixel_store_i32(glow::PACK_ALIGNMENT, 4);
            gl.read_pixels(
                x as i32,
                y as i32,
                width as i32,
                height as i32,
                glow::RGBA,
                glow::FLOAT,
                glow::PixelPackData::Slice(Some(f32_bytes_mut(&mut out))),
            );
        }
        check_gl_error(gl, "reading a render target attachment")?;
        Ok(out)
    }

    /// Deletes the FBO and its textures.
    pub fn delete(self, gl: &glow::Context) {
        // SAFETY: the names belong to this context and are not used after this.
        unsafe {
            gl.delete_framebuffer(self.framebuffer);
            self.textures.iter().for_each(|&t| gl.delete_texture(t));
        }
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
    vbo: glow::Buffer,
    /// Only on GL >= 3.0, where a core-profile driver would reject drawing without a VAO;
    /// a 2.1 context has no VAOs and uses the default vertex state.
    vao: Option<glow::VertexArray>,
}

impl FullscreenQuad {
    /// Uploads the quad's vertices.
    pub fn new(gl: &glow::Context) -> Result<Self> {
        // SAFETY: the context is current; the buffer data is a local constant.
        unsafe {
            let vbo = gl
                .create_buffer()
                .map_err(|e| Error::Internal(format!("glGenBuffers: {e}")))?;
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(vbo));
            gl.buffer_data_u8_slice(
                glow::ARRAY_BUFFER,
                f32_bytes(&QUAD_VERTICES),
                glow::STATIC_DRAW,
            );
            gl.bind_buffer(glow::ARRAY_BUFFER, None);
            let vao = if gl.version().major >= 3 {
                gl.create_vertex_array().ok()
            } else {
                None
            };
            check_gl_error(gl, "creating the full-screen quad")?;
            Ok(FullscreenQuad { vbo, vao })
        }
    }

    /// Makes `program` current and draws the quad into the bound render target. Uniforms
    /// may be set before (after `gl.use_program(Some(program))`); textures must be bound to
    /// the units the program's samplers name.
    pub fn draw(&self, gl: &glow::Context, program: glow::Program) {
        const STRIDE: i32 = 5 * std::mem::size_of::<f32>() as i32;
        // SAFETY: the buffer holds 4 vertices of the declared layout.
        unsafe {
            gl.use_program(Some(program));
            if let Some(vao) = self.vao {
                gl.bind_vertex_array(Some(vao));
            }
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(self.vbo));
            gl.enable_vertex_attrib_array(ATTRIB_POS);
            gl.vertex_attrib_pointer_f32(ATTRIB_POS, 3, glow::FLOAT, false, STRIDE, 0);
            gl.enable_vertex_attrib_array(ATTRIB_UV);
            gl.vertex_attrib_pointer_f32(ATTRIB_UV, 2, glow::FLOAT, false, STRIDE, 12);
            // A fan over the 4 corners covers the same pixels as GL_QUADS, which core
            // profiles lack; the shared diagonal is rasterised once by the fill rule, so every
            // pixel gets exactly one fragment (occlusion counts rely on that).
            gl.draw_arrays(glow::TRIANGLE_FAN, 0, 4);
            gl.disable_vertex_attrib_array(ATTRIB_POS);
            gl.disable_vertex_attrib_array(ATTRIB_UV);
            gl.bind_buffer(glow::ARRAY_BUFFER, None);
            if self.vao.is_some() {
                gl.bind_vertex_array(None);
            }
        }
    }

    /// Deletes the vertex buffer (and VAO).
    pub fn delete(self, gl: &glow::Context) {
        // SAFETY: the names belong to this context and are not used after this.
        unsafe {
            gl.delete_buffer(self.vbo);
            if let Some(vao) = self.vao {
                gl.delete_vertex_array(vao);
            }
        }
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
    gl: &glow::Context,
    pass: &str,
    vertex_src: &str,
    fragment_src: &str,
    line_map: &dyn Fn(usize) -> (String, usize),
) -> Result<glow::Program> {
    let shader_error = |file: String, line: usize, log: String| Error::Shader {
        pass: pass.to_string(),
        file,
        line,
        log: log.trim_end().to_string(),
    };
    // SAFETY: the context is current; every name used is created here.
    unsafe {
        let vs = compile_shader(gl, glow::VERTEX_SHADER, vertex_src).map_err(|log| {
            let line = parse_error_line(&log).unwrap_or(0);
            shader_error("<vertex shader>".into(), line, log)
        })?;
        let fs = match compile_shader(gl, glow::FRAGMENT_SHADER, fragment_src) {
            Ok(fs) => fs,
            Err(log) => {
                gl.delete_shader(vs);
                let (file, line) = match parse_error_line(&log) {
                    Some(n) => line_map(n),
                    None => ("<fragment shader>".to_string(), 0),
                };
                return Err(shader_error(file, line, log));
            }
        };
        let program = match gl.create_program() {
            Ok(p) => p,
            Err(e) => {
                gl.delete_shader(vs);
                gl.delete_shader(fs);
                return Err(Error::Internal(format!("glCreateProgram: {e}")));
            }
        };
        gl.attach_shader(program, vs);
        gl.attach_shader(program, fs);
        gl.bind_attrib_location(program, ATTRIB_POS, "a_pos");
        gl.bind_attrib_location(program, ATTRIB_UV, "a_uv");
        gl.link_program(program);
        // Shaders are only needed until link; detaching lets the driver free them now.
        gl.detach_shader(program, vs);
        gl.detach_shader(program, fs);
        gl.delete_shader(vs);
        gl.delete_shader(fs);
        if !gl.get_program_link_status(program) {
            let log = gl.get_program_info_log(program);
            gl.delete_program(program);
            let line = parse_error_line(&log).unwrap_or(0);
            return Err(shader_error("<link>".into(), line, log));
        }
        check_gl_error(gl, &format!("building the `{pass}` program"))?;
        Ok(program)
    }
}

/// Compiles one shader; `Err` carries the info log.
unsafe fn compile_shader(
    gl: &glow::Context,
    kind: u32,
    src: &str,
) -> std::result::Result<glow::Shader, String> {
    let shader = gl.create_shader(kind)?;
    gl.shader_source(shader, src);
    gl.compile_shader(shader);
    if gl.get_shader_compile_status(shader) {
        Ok(shader)
    } else {
        let log = gl.get_shader_info_log(shader);
        gl.delete_shader(shader);
        Err(if log.trim().is_empty() {
            "compilation failed, the driver gave no log".to_string()
        } else {
            log
        })
    }
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

/// Counts the fragments that survive (are not `discard`ed and pass any enabled tests)
/// between [`OcclusionQuery::begin`] and [`OcclusionQuery::end`]: `GL_SAMPLES_PASSED`,
/// which equals fragments because render targets are never multisampled.
#[derive(Debug)]
pub struct OcclusionQuery {
    query: glow::Query,
}

impl OcclusionQuery {
    /// Creates the query object.
    pub fn new(ctx: &GlContext) -> Result<Self> {
        // SAFETY: the context is current.
        let query = unsafe { ctx.gl.create_query() }
            .map_err(|e| Error::Internal(format!("glGenQueries: {e}")))?;
        Ok(OcclusionQuery { query })
    }

    /// Starts counting. Only one `GL_SAMPLES_PASSED` query may be active at a time.
    pub fn begin(&self, ctx: &GlContext) {
        // SAFETY: valid query name of this context.
        unsafe { ctx.gl.begin_query(glow::SAMPLES_PASSED, self.query) };
    }

    /// Stops counting.
    pub fn end(&self, ctx: &GlContext) {
        // SAFETY: ends the query started by `begin`.
        unsafe { ctx.gl.end_query(glow::SAMPLES_PASSED) };
    }

    /// The count; waits for the GPU to finish the counted draws.
    pub fn result(&self, ctx: &GlContext) -> Result<u32> {
        let n = ctx.raw().query_result_u32(self.query);
        check_gl_error(&ctx.gl, "reading an occlusion query")?;
        Ok(n)
    }

    /// Deletes the query object.
    pub fn delete(self, ctx: &GlContext) {
        // SAFETY: the name belongs to this context and is not used after this.
        unsafe { ctx.gl.delete_query(self.query) };
    }
}

/// GPU time of the commands between [`TimerQuery::begin`] and [`TimerQuery::end`]
/// (`GL_TIME_ELAPSED`); optional, see [`GlInfo::timer_query`](crate::gpu::GlInfo::timer_query).
#[derive(Debug)]
pub struct TimerQuery {
    query: glow::Query,
}

impl TimerQuery {
    /// Creates the query object, or fails with [`Error::GlUnavailable`] when the context has
    /// no timer queries (check `ctx.info.timer_query` to skip timing instead).
    pub fn new(ctx: &GlContext) -> Result<Self> {
        if !ctx.info.timer_query {
            return Err(Error::GlUnavailable(
                "timer queries need OpenGL 3.3, GL_ARB_timer_query or GL_EXT_timer_query".into(),
            ));
        }
        // SAFETY: the context is current.
        let query = unsafe { ctx.gl.create_query() }
            .map_err(|e| Error::Internal(format!("glGenQueries: {e}")))?;
        Ok(TimerQuery { query })
    }

    /// Starts timing. Only one `GL_TIME_ELAPSED` query may be active at a time (an
    /// occlusion query may run concurrently).
    pub fn begin(&self, ctx: &GlContext) {
        // SAFETY: valid query name of this context.
        unsafe { ctx.gl.begin_query(glow::TIME_ELAPSED, self.query) };
    }

    /// Stops timing.
    pub fn end(&self, ctx: &GlContext) {
        // SAFETY: ends the query started by `begin`.
        unsafe { ctx.gl.end_query(glow::TIME_ELAPSED) };
    }

    /// Elapsed GPU time in nanoseconds; waits for the timed commands to finish.
    pub fn result_ns(&self, ctx: &GlContext) -> Result<u64> {
        let ns = ctx
            .raw()
            .query_result_u64(self.query)
            .ok_or_else(|| Error::Internal("timer query without timer-query support".into()))?;
        check_gl_error(&ctx.gl, "reading a timer query")?;
        Ok(ns)
    }

    /// Deletes the query object.
    pub fn delete(self, ctx: &GlContext) {
        // SAFETY: the name belongs to this context and is not used after this.
        unsafe { ctx.gl.delete_query(self.query) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::context::test_support::run_ignored_test_in_child;
    use crate::gpu::context::with_test_context;

    /// Environment that makes Mesa expose exactly OpenGL 2.1 / GLSL 1.20.
    const GL21_ENV: [(&str, &str); 2] = [
        ("MESA_GL_VERSION_OVERRIDE", "2.1"),
        ("MESA_GLSL_VERSION_OVERRIDE", "120"),
    ];

    fn build(ctx: &GlContext, pass: &str, fragment: &str) -> glow::Program {
        compile_program(
            &ctx.gl,
            pass,
            QUAD_VERTEX_SHADER,
            fragment,
            &single_file_line_map("test.frag"),
        )
        .unwrap_or_else(|e| panic!("{e}"))
    }

    /// Renders `fragment` over a fresh `w`×`h` target with `attachments` outputs, with
    /// `input` (if any) bound to unit 0 as `u_input`; returns the target for read-back.
    fn render(
        ctx: &GlContext,
        fragment: &str,
        w: u32,
        h: u32,
        attachments: usize,
        input: Option<glow::Texture>,
    ) -> RenderTarget {
        let gl = &ctx.gl;
        let program = build(ctx, "test", fragment);
        let target = RenderTarget::new(gl, w, h, attachments).unwrap();
        let quad = FullscreenQuad::new(gl).unwrap();
        target.bind(gl);
        unsafe {
            gl.use_program(Some(program));
            if let Some(tex) = input {
                gl.active_texture(glow::TEXTURE0);
                gl.bind_texture(glow::TEXTURE_2D, Some(tex));
                let loc = gl.get_uniform_location(program, "u_input");
                assert!(loc.is_some(), "u_input not active");
                gl.uniform_1_i32(loc.as_ref(), 0);
            }
        }
        quad.draw(gl, program);
        check_gl_error(gl, "test draw").unwrap();
        unsafe {
            gl.bind_texture(glow::TEXTURE_2D, None);
            gl.delete_program(program);
        }
        quad.delete(gl);
        target
    }

    /// Float MRT: attachment 0 gets the pixel centre and two constants (one negative, to
    /// prove no clamping), attachment 1 a copy of an input texture sampled at `v_uv`.
    fn check_mrt_exact_floats(ctx: &GlContext) {
        let (w, h) = (7u32, 5u32);
        let input: Vec<f32> = (0..w * h * 4).map(|i| i as f32 * 0.25 - 3.0).collect();
        let tex = create_float_texture(&ctx.gl, w, h, Some(&input)).unwrap();
        // `input` is a reserved word in GLSL 1.20, hence `u_input`.
        let fs = "#version 120
uniform sampler2D u_input;
varying vec2 v_uv;
void main() {
    gl_FragData[0] = vec4(gl_FragCoord.xy, 1.5, -2.25);
    gl_FragData[1] = texture2D(u_input, v_uv);
}
";
        let target = render(ctx, fs, w, h, 2, Some(tex));
        let a0 = target.read_attachment(&ctx.gl, 0).unwrap();
        let a1 = target.read_attachment(&ctx.gl, 1).unwrap();
        for j in 0..h as usize {
            for i in 0..w as usize {
                let p = (j * w as usize + i) * 4;
                let want = [i as f32 + 0.5, j as f32 + 0.5, 1.5, -2.25];
                assert_eq!(&a0[p..p + 4], &want, "attachment 0 at ({i},{j})");
                assert_eq!(&a1[p..p + 4], &input[p..p + 4], "attachment 1 at ({i},{j})");
            }
        }
        // glGetTexImage sees the same data as glReadPixels.
        let via_tex = read_texture_rgba32f(&ctx.gl, target.texture(1), w, h).unwrap();
        assert_eq!(via_tex, a1);
        target.delete(&ctx.gl);
        unsafe { ctx.gl.delete_texture(tex) };
    }

    /// The interpolated texture coordinate is the pixel centre over the target size.
    fn check_uv_at_pixel_centres(ctx: &GlContext) {
        let (w, h) = (9u32, 4u32);
        let fs = "#version 120
varying vec2 v_uv;
void main() { gl_FragData[0] = vec4(v_uv, 0.0, 1.0); }
";
        let target = render(ctx, fs, w, h, 1, None);
        let out = target.read_attachment(&ctx.gl, 0).unwrap();
        for j in 0..h as usize {
            for i in 0..w as usize {
                let p = (j * w as usize + i) * 4;
                let (u, v) = ((i as f32 + 0.5) / w as f32, (j as f32 + 0.5) / h as f32);
                assert!(
                    (out[p] - u).abs() < 1e-6 && (out[p + 1] - v).abs() < 1e-6,
                    "v_uv at ({i},{j}) = ({}, {}), want ({u}, {v})",
                    out[p],
                    out[p + 1]
                );
            }
        }
        target.delete(&ctx.gl);
    }

    /// `discard` removes fragments from GL_SAMPLES_PASSED: a pass that discards every
    /// even column of an 8x6 target reports exactly the 24 odd-column fragments.
    fn check_discard_occlusion_count(ctx: &GlContext) {
        let gl = &ctx.gl;
        let (w, h) = (8u32, 6u32);
        let fs = "#version 120
void main() {
    if (mod(floor(gl_FragCoord.x), 2.0) == 0.0) discard;
    gl_FragData[0] = vec4(1.0);
}
";
        let program = build(ctx, "discard", fs);
        let target = RenderTarget::new(gl, w, h, 1).unwrap();
        let quad = FullscreenQuad::new(gl).unwrap();
        let query = OcclusionQuery::new(ctx).unwrap();
        target.bind(gl);
        unsafe {
            gl.clear_color(0.0, 0.0, 0.0, 0.0);
            gl.clear(glow::COLOR_BUFFER_BIT);
        }
        query.begin(ctx);
        quad.draw(gl, program);
        query.end(ctx);
        assert_eq!(query.result(ctx).unwrap(), w * h / 2);
        // And the surviving fragments are exactly the odd columns.
        let out = target.read_attachment(gl, 0).unwrap();
        for (k, px) in out.chunks(4).enumerate() {
            let want = if k % w as usize % 2 == 1 { 1.0 } else { 0.0 };
            assert_eq!(px[0], want, "pixel {k}");
        }
        // With nothing discarded the count is the whole target (each pixel once, the fan's
        // shared diagonal included).
        let all = build(
            ctx,
            "all",
            "#version 120\nvoid main() { gl_FragData[0] = vec4(2.0); }\n",
        );
        query.begin(ctx);
        quad.draw(gl, all);
        query.end(ctx);
        assert_eq!(query.result(ctx).unwrap(), w * h);
        if ctx.info.timer_query {
            let timer = TimerQuery::new(ctx).unwrap();
            timer.begin(ctx);
            quad.draw(gl, all);
            timer.end(ctx);
            timer.result_ns(ctx).unwrap();
            timer.delete(ctx);
        } else {
            assert!(TimerQuery::new(ctx).is_err());
        }
        query.delete(ctx);
        quad.delete(gl);
        target.delete(gl);
        unsafe {
            gl.delete_program(program);
            gl.delete_program(all);
        }
    }

    /// A compile error in the third line of the second of two concatenated files comes back
    /// as Error::Shader naming the pass and that file/line.
    fn check_broken_shader_maps_line(ctx: &GlContext) {
        let header = "#version 120\nvarying vec2 v_uv;\nuniform float u_scale;\n"; // common.glsl 1-3
        let body = "void main() {\n    float x = u_scale;\n    gl_FragData[0] = vec4(x, undefined_thing, 0.0, 1.0);\n}\n"; // trace.frag 1-4
        let src = format!("{header}{body}");
        let map = |line: usize| {
            if line <= 3 {
                ("common.glsl".to_string(), line)
            } else {
                ("trace.frag".to_string(), line - 3)
            }
        };
        match compile_program(&ctx.gl, "intersect", QUAD_VERTEX_SHADER, &src, &map) {
            Err(Error::Shader {
                pass,
                file,
                line,
                log,
            }) => {
                eprintln!("driver log for the broken shader:\n{log}");
                assert_eq!(pass, "intersect");
                assert_eq!((file.as_str(), line), ("trace.frag", 3), "log: {log}");
                assert!(log.contains("undefined_thing"), "log: {log}");
            }
            other => panic!("expected Error::Shader, got {other:?}"),
        }
        // A broken vertex shader is reported against the vertex shader, not the map.
        let err = compile_program(
            &ctx.gl,
            "quad",
            "#version 120\nvoid main() { oops }\n",
            "#version 120\nvoid main() { gl_FragData[0] = vec4(0.0); }\n",
            &map,
        )
        .unwrap_err();
        assert!(
            matches!(&err, Error::Shader { file, line: 2, .. } if file == "<vertex shader>"),
            "{err:?}"
        );
        check_gl_error(&ctx.gl, "after failed compiles").unwrap();
    }

    /// Indices up to 2^24 - 1 survive texture upload, sampling, render-to-texture and
    /// read-back unchanged, and so do integer-valued results computed in the shader.
    fn check_large_values_exact(ctx: &GlContext) {
        let (w, h) = (3u32, 2u32);
        let specials = [
            16777215.0f32,
            16777214.0,
            -16777215.0,
            8388607.5,
            1.0e30,
            -0.0,
        ];
        let input: Vec<f32> = (0..w * h)
            .flat_map(|k| {
                let s = specials[k as usize % specials.len()];
                [s, 16777215.0 - k as f32, k as f32, f32::MIN_POSITIVE]
            })
            .collect();
        let tex = create_float_texture(&ctx.gl, w, h, Some(&input)).unwrap();
        assert_eq!(read_texture_rgba32f(&ctx.gl, tex, w, h).unwrap(), input);
        let fs = "#version 120
uniform sampler2D u_input;
varying vec2 v_uv;
void main() {
    gl_FragData[0] = texture2D(u_input, v_uv);
    // A linear index computed in the shader, offset to the top of the exact range.
    float index = floor(gl_FragCoord.y) * 3.0 + floor(gl_FragCoord.x);
    gl_FragData[1] = vec4(16777215.0 - index, index, 16777215.0, -16777215.0);
}
";
        let target = render(ctx, fs, w, h, 2, Some(tex));
        let copy = target.read_attachment(&ctx.gl, 0).unwrap();
        assert_eq!(
            copy.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            input.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        let computed = target.read_attachment(&ctx.gl, 1).unwrap();
        for (k, px) in computed.chunks(4).enumerate() {
            assert_eq!(
                px,
                [16777215.0 - k as f32, k as f32, 16777215.0, -16777215.0]
            );
        }
        // Region read-back addresses the right texels.
        let region = target
            .read_attachment_region(&ctx.gl, 1, 1, 1, 2, 1)
            .unwrap();
        assert_eq!(region, [&computed[16..20], &computed[20..24]].concat());
        target.delete(&ctx.gl);
        unsafe { ctx.gl.delete_texture(tex) };
    }

    fn check_limits_and_errors(ctx: &GlContext) {
        let gl = &ctx.gl;
        let too_many = ctx.info.max_draw_buffers as usize + 1;
        assert!(matches!(
            RenderTarget::new(gl, 4, 4, too_many),
            Err(Error::Limit(_))
        ));
        let too_wide = ctx.info.max_texture_size as u32 + 1;
        assert!(matches!(
            create_float_texture(gl, too_wide, 1, None),
            Err(Error::Limit(_))
        ));
        assert!(matches!(
            create_float_texture(gl, 2, 2, Some(&[0.0; 3])),
            Err(Error::Internal(_))
        ));
        let rt = RenderTarget::new(gl, 4, 4, 1).unwrap();
        assert!(rt.read_attachment(gl, 1).is_err());
        assert!(rt.read_attachment_region(gl, 0, 3, 0, 2, 1).is_err());
        rt.delete(gl);
        check_gl_error(gl, "limits").unwrap();
    }

    fn all_checks(ctx: &GlContext) {
        check_mrt_exact_floats(ctx);
        check_uv_at_pixel_centres(ctx);
        check_discard_occlusion_count(ctx);
        check_broken_shader_maps_line(ctx);
        check_large_values_exact(ctx);
        check_limits_and_errors(ctx);
    }

    #[test]
    fn mrt_float_fbo_reads_back_exact_floats() {
        with_test_context(check_mrt_exact_floats);
    }

    #[test]
    fn quad_texcoords_are_pixel_centres() {
        with_test_context(check_uv_at_pixel_centres);
    }

    #[test]
    fn discard_is_excluded_from_occlusion_count() {
        with_test_context(check_discard_occlusion_count);
    }

    #[test]
    fn broken_shader_reports_mapped_line() {
        with_test_context(check_broken_shader_maps_line);
    }

    #[test]
    fn large_values_round_trip_exactly() {
        with_test_context(check_large_values_exact);
    }

    #[test]
    fn limits_are_reported_as_errors() {
        with_test_context(check_limits_and_errors);
    }

    #[test]
    fn error_line_parsing() {
        assert_eq!(
            parse_error_line("0:12(5): error: `x' undeclared\n"),
            Some(12)
        );
        assert_eq!(
            parse_error_line("0(7) : error C1008: undefined variable \"x\"\n"),
            Some(7)
        );
        assert_eq!(
            parse_error_line("ERROR: 0:33: 'x' : undeclared identifier\n"),
            Some(33)
        );
        assert_eq!(
            parse_error_line("0:3(1): warning: unused\n0:9(2): error: syntax error\n"),
            Some(9)
        );
        assert_eq!(parse_error_line("error: linking failed\n"), None);
        assert_eq!(parse_error_line(""), None);
    }

    /// Runs every check in a child process whose Mesa is forced to OpenGL 2.1 / GLSL 1.20,
    /// proving the backend needs nothing newer. Skipped (with a note) on non-Mesa drivers,
    /// which ignore the override variables.
    #[test]
    fn gl21_override_passes_all_checks() {
        let is_mesa = with_test_context(|ctx| ctx.info.gl_version.contains("Mesa"));
        if !is_mesa {
            eprintln!("not Mesa: MESA_GL_VERSION_OVERRIDE has no effect, skipping");
            return;
        }
        let (ok, out) =
            run_ignored_test_in_child("gpu::gl_util::tests::gl21_override_inner", &GL21_ENV);
        assert!(ok, "{out}");
    }

    /// The body of [`gl21_override_passes_all_checks`]; run only in that child process.
    #[test]
    #[ignore = "run by gl21_override_passes_all_checks with Mesa overridden to GL 2.1"]
    fn gl21_override_inner() {
        with_test_context(|ctx| {
            let forced = GL21_ENV
                .iter()
                .all(|(k, v)| std::env::var(k).as_deref() == Ok(*v));
            if forced {
                assert_eq!(ctx.info.gl_major_minor, (2, 1), "{}", ctx.info);
                assert_eq!(ctx.info.glsl_version, "1.20", "{}", ctx.info);
                // The override must really cap GLSL, or this test would prove nothing.
                let newer = "#version 130\nout vec4 c;\nvoid main() { c = vec4(0.0); }\n";
                let map = single_file_line_map("v130.frag");
                assert!(compile_program(&ctx.gl, "v130", QUAD_VERTEX_SHADER, newer, &map).is_err());
            }
            eprintln!("{}", ctx.info);
            all_checks(ctx);
        });
    }
}
