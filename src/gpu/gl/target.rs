//! Render targets: a framebuffer object with float colour attachments, the output streams
//! of one pass, and their read-back.

use glow::HasContext;

use super::texture::check_texture_size;
use super::{
    check_gl_error, f32_bytes_mut, rgba_len, BufferKind, FramebufferKind, Owned, Renderbuffer,
    TexFormat, Texture,
};
use crate::error::{Error, Result};
use crate::gpu::context::GlContext;
use crate::gpu::info::effective_limit;

/// A framebuffer object with N float colour attachments of one size: the output streams of
/// one pass.
/// Dropping it deletes the FBO and its textures.
#[derive(Debug)]
pub struct RenderTarget {
    // Declared first so the FBO goes before the textures attached to it.
    framebuffer: Owned<FramebufferKind>,
    textures: Vec<Texture>,
    width: u32,
    height: u32,
}

impl RenderTarget {
    /// Creates the FBO and `attachments` fresh (uninitialised) RGBA32F textures of
    /// `width`×`height`. Fails with [`Error::Limit`] when `attachments` exceeds
    /// `GL_MAX_DRAW_BUFFERS`/`GL_MAX_COLOR_ATTACHMENTS` or the size exceeds
    /// `GL_MAX_TEXTURE_SIZE`, and with [`Error::GlUnavailable`] naming the status when the
    /// driver reports the framebuffer incomplete.
    pub fn new(ctx: &GlContext, width: u32, height: u32, attachments: usize) -> Result<Self> {
        Self::with_formats(ctx, width, height, &vec![TexFormat::Rgba32F; attachments])
    }

    /// [`RenderTarget::new`] with one internal format per attachment. Mixing formats in
    /// one FBO needs GL 3.0 or ARB_framebuffer_object (EXT_framebuffer_object reports
    /// `INCOMPLETE_FORMATS`), which is reported as [`Error::GlUnavailable`].
    pub fn with_formats(
        ctx: &GlContext,
        width: u32,
        height: u32,
        formats: &[TexFormat],
    ) -> Result<Self> {
        let gl = ctx.gl();
        let attachments = formats.len();
        // SAFETY: the context is current; both limits are one integer each, the one that
        // GetIntegerv writes.
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
        let textures = formats
            .iter()
            .map(|&format| Texture::new(ctx, width, height, format, None))
            .collect::<Result<Vec<_>>>()?;
        // SAFETY: the context is current; every name used was created above and is owned.
        unsafe {
            let framebuffer = gl
                .create_framebuffer()
                .map_err(|e| Error::Internal(format!("glGenFramebuffers: {e}")))?;
            let target = RenderTarget {
                framebuffer: Owned::new(ctx, framebuffer),
                textures,
                width,
                height,
            };
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(framebuffer));
            for (i, t) in target.textures.iter().enumerate() {
                gl.framebuffer_texture_2d(
                    glow::FRAMEBUFFER,
                    glow::COLOR_ATTACHMENT0 + i as u32,
                    glow::TEXTURE_2D,
                    Some(t.name()),
                    0,
                );
            }
            // Completeness depends on the draw/read buffer state (GL 2.1 + ARB_fbo rule
            // INCOMPLETE_DRAW_BUFFER), so set them before checking.
            target.set_draw_buffers(gl);
            if ctx.info.dialect.has_read_buffer() {
                gl.read_buffer(glow::COLOR_ATTACHMENT0);
            }
            let status = gl.check_framebuffer_status(glow::FRAMEBUFFER);
            gl.bind_framebuffer(glow::FRAMEBUFFER, None);
            if status != glow::FRAMEBUFFER_COMPLETE {
                return Err(Error::GlUnavailable(format!(
                    "framebuffer with attachment(s) {formats:?} of {width}x{height} \
                     is incomplete: {}",
                    framebuffer_status_name(status)
                )));
            }
            check_gl_error(gl, "creating a render target")?;
            Ok(target)
        }
    }

    /// Attaches `buffer` as this FBO's depth buffer, and as its stencil buffer when it has
    /// one. Several targets may share one buffer: that is how a mask written while drawing
    /// into one ping-pong target tests the draws into the other. The buffer must outlive
    /// the draws that use it (GL keeps an attached renderbuffer's storage alive anyway).
    pub fn attach_mask_buffer(&self, gl: &glow::Context, buffer: &Renderbuffer) -> Result<()> {
        let stencil = buffer.has_stencil();
        let buffer = buffer.name();
        // SAFETY: the context is current; both names belong to it.
        unsafe {
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(self.framebuffer.name()));
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
        #[cfg(not(target_arch = "wasm32"))]
        unsafe {
            gl.draw_buffers(&buffers)
        };
        // glow 0.16 hands WEBGL_draw_buffers a nested array on WebGL 1 (drawing nothing);
        // the page's context calls the extension itself.
        // WebGL 2 has drawBuffers itself (glow's call is right there).
        #[cfg(target_arch = "wasm32")]
        super::webgl::draw_buffers(gl, &buffers);
    }

    /// Makes this the render destination: binds the FBO, routes `gl_FragData[i]` to
    /// attachment `i` for every attachment, and sets the viewport to the whole target
    /// (a surfaceless context starts with a 0×0 viewport, so this must not be skipped).
    pub fn bind(&self, gl: &glow::Context) {
        // SAFETY: the FBO is complete (checked at creation) and owned by this context.
        unsafe {
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(self.framebuffer.name()));
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
        self.framebuffer.name()
    }

    /// The texture behind attachment `index` (to bind as the next pass's input).
    ///
    /// # Panics
    /// When `index` is not below the attachment count.
    pub fn texture(&self, index: usize) -> &Texture {
        &self.textures[index]
    }

    /// All attachment textures, attachment 0 first.
    pub fn textures(&self) -> &[Texture] {
        &self.textures
    }

    /// Reads attachment 0 of an RGBA8 target back as `width*height*4` bytes (bottom row
    /// first): the byte mask the WebGL page counts active rays in. Leaves this target bound.
    pub fn read_bytes(&self, gl: &glow::Context) -> Result<Vec<u8>> {
        let mut out = vec![0u8; rgba_len(self.width, self.height)];
        // SAFETY: the buffer holds exactly width*height RGBA bytes; RGBA/UNSIGNED_BYTE is
        // the read format every GL and WebGL accepts from a normalised colour buffer.
        unsafe {
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(self.framebuffer.name()));
            gl.pixel_store_i32(glow::PACK_ALIGNMENT, 4);
            gl.read_pixels(
                0,
                0,
                self.width as i32,
                self.height as i32,
                glow::RGBA,
                glow::UNSIGNED_BYTE,
                glow::PixelPackData::Slice(Some(&mut out)),
            );
        }
        check_gl_error(gl, "reading a byte mask")?;
        Ok(out)
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
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(self.framebuffer.name()));
            // WebGL 1 has no glReadBuffer: it reads attachment 0 (WebGL 2 has it).
            #[cfg(target_arch = "wasm32")]
            if gl.version().major < 3 {
                if index != 0 {
                    return Err(Error::GlUnavailable(format!(
                        "WebGL 1 reads colour attachment 0 only, {index} requested"
                    )));
                }
            } else {
                gl.read_buffer(glow::COLOR_ATTACHMENT0 + index as u32);
            }
            #[cfg(not(target_arch = "wasm32"))]
            gl.read_buffer(glow::COLOR_ATTACHMENT0 + index as u32);
            gl.pixel_store_i32(glow::PACK_ALIGNMENT, 4);
            // WebGL 2 cannot map buffers: the pack-buffer read is native only.
            if cfg!(not(target_arch = "wasm32"))
                && out.len() >= PACK_BUFFER_MIN_FLOATS
                && gl.version().major >= 3
            {
                read_through_pack_buffer(gl, &self.framebuffer, (x, y, width, height), &mut out)?;
                check_gl_error(gl, "reading a render target attachment")?;
                return Ok(out);
            }
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
}

/// Makes the default framebuffer (the window's back buffer, where there is a window) the
/// render destination, with a `width` x `height` viewport.
pub fn bind_window(gl: &glow::Context, width: u32, height: u32) {
    // SAFETY: the context is current; binding framebuffer 0 and any viewport size are
    // always valid (a size past the limit is clamped by GL).
    unsafe {
        gl.bind_framebuffer(glow::FRAMEBUFFER, None);
        gl.viewport(0, 0, width as i32, height as i32);
    }
}

/// Reads the window's back buffer (`width` x `height`) as RGBA8, bottom row first, and
/// leaves the default framebuffer bound.
pub fn read_window(gl: &glow::Context, width: u32, height: u32) -> Result<Vec<u8>> {
    let mut rgba = vec![0u8; rgba_len(width, height)];
    // SAFETY: the context is current and `rgba` holds exactly width*height RGBA bytes at
    // the pack alignment of 1 set for the read (put back to GL's default 4 after).
    unsafe {
        gl.bind_framebuffer(glow::FRAMEBUFFER, None);
        gl.read_buffer(glow::BACK);
        gl.pixel_store_i32(glow::PACK_ALIGNMENT, 1);
        gl.read_pixels(
            0,
            0,
            width as i32,
            height as i32,
            glow::RGBA,
            glow::UNSIGNED_BYTE,
            glow::PixelPackData::Slice(Some(&mut rgba)),
        );
        gl.pixel_store_i32(glow::PACK_ALIGNMENT, 4);
    }
    check_gl_error(gl, "reading the window back")?;
    Ok(rgba)
}

/// Reads at least this many floats through a pixel pack buffer (smaller reads, such as a
/// reduction's few texels, are not worth a buffer).
const PACK_BUFFER_MIN_FLOATS: usize = 1 << 18;

/// `glReadPixels` of the bound read buffer's rectangle `(x, y, w, h)` into a
/// `GL_STREAM_READ` pixel pack buffer, then a parallel copy out of the mapped buffer: on the
/// H200 a 4096x4096 RGBA32F read went from 0.7 GB/s straight into client memory to several
/// GB/s this way (the compute kernel's read-back, docs/performance.md). GL 3.0 (mapping a
/// range); the pack buffer is owned (in `fb`'s context) and deleted on return, also on
/// failure.
///
/// # Safety
/// The context must be current with the framebuffer `fb` and the read buffer to read from
/// bound, and `out` must hold exactly `w * h * 4` floats.
unsafe fn read_through_pack_buffer(
    gl: &glow::Context,
    fb: &Owned<FramebufferKind>,
    (x, y, w, h): (u32, u32, u32, u32),
    out: &mut [f32],
) -> Result<()> {
    use rayon::prelude::*;
    let bytes = out.len() * 4;
    let size = i32::try_from(bytes)
        .map_err(|_| Error::Limit(format!("a read of {bytes} bytes exceeds GL's 2 GiB size")))?;
    let pbo = fb.beside::<BufferKind>(
        gl.create_buffer()
            .map_err(|e| Error::Internal(format!("glGenBuffers: {e}")))?,
    );
    gl.bind_buffer(glow::PIXEL_PACK_BUFFER, Some(pbo.name()));
    gl.buffer_data_size(glow::PIXEL_PACK_BUFFER, size, glow::STREAM_READ);
    gl.read_pixels(
        x as i32,
        y as i32,
        w as i32,
        h as i32,
        glow::RGBA,
        glow::FLOAT,
        glow::PixelPackData::BufferOffset(0),
    );
    let ptr = gl.map_buffer_range(glow::PIXEL_PACK_BUFFER, 0, size, glow::MAP_READ_BIT);
    let r = if ptr.is_null() {
        Err(Error::Internal(
            "glMapBufferRange of the pixel pack buffer returned null".into(),
        ))
    } else {
        let src = std::slice::from_raw_parts(ptr.cast::<f32>().cast_const(), out.len());
        out.par_chunks_mut(1 << 16)
            .zip(src.par_chunks(1 << 16))
            .for_each(|(d, s)| d.copy_from_slice(s));
        gl.unmap_buffer(glow::PIXEL_PACK_BUFFER);
        Ok(())
    };
    gl.bind_buffer(glow::PIXEL_PACK_BUFFER, None);
    r
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
