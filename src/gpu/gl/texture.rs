//! Float textures (the streams and the scene data) and the depth/stencil renderbuffer that
//! masks finished rays out of passes.

use glow::HasContext;

use super::{
    check_gl_error, f32_bytes, f32_bytes_mut, rgba_len, FramebufferKind, Owned, RenderbufferKind,
    TextureKind,
};
use crate::error::{Error, Result};
use crate::gpu::context::GlContext;
use crate::gpu::info::effective_limit;

/// Internal format of a stream texture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TexFormat {
    /// 32-bit floats: exact integers to 2^24, what indices and hit distances need.
    Rgba32F,
    /// 16-bit floats (ARB_texture_float's RGBA16F, as on GeForce 6/7-class cards): half the
    /// memory traffic, 11 significant bits, integers exact only to 2048.
    Rgba16F,
    /// 8-bit unsigned normalised: the 8-bit sRGB image read back for a PNG, and the byte
    /// mask the WebGL page counts active rays in (no occlusion queries there); never
    /// uploaded from floats.
    Rgba8,
}

impl TexFormat {
    fn gl_enum(self) -> u32 {
        match self {
            TexFormat::Rgba32F => glow::RGBA32F,
            TexFormat::Rgba16F => glow::RGBA16F,
            TexFormat::Rgba8 => glow::RGBA8,
        }
    }

    /// The pixel type its texels are specified in.
    fn gl_type(self) -> u32 {
        match self {
            TexFormat::Rgba32F | TexFormat::Rgba16F => glow::FLOAT,
            TexFormat::Rgba8 => glow::UNSIGNED_BYTE,
        }
    }

    /// Bytes per texel.
    pub fn bytes(self) -> u64 {
        match self {
            TexFormat::Rgba32F => 16,
            TexFormat::Rgba16F => 8,
            TexFormat::Rgba8 => 4,
        }
    }
}

#[cfg(test)]
thread_local! {
    /// Test hook: a `GL_MAX_TEXTURE_SIZE` below the driver's (and the limit profile's) for
    /// the textures created on this thread, so a render can be made to fail after some of
    /// its objects exist (the context's [`GlInfo`](crate::gpu::GlInfo) keeps the real limit).
    pub(crate) static TEST_MAX_TEXTURE_SIZE: std::cell::Cell<Option<i32>> =
        const { std::cell::Cell::new(None) };
}

/// Checks a requested texture size against `GL_MAX_TEXTURE_SIZE` (a user-controlled value:
/// image resolution or scene size decides it, hence [`Error::Limit`]).
pub(super) fn check_texture_size(gl: &glow::Context, width: u32, height: u32) -> Result<()> {
    // SAFETY: the context is current; GL_MAX_TEXTURE_SIZE is one integer, the one that
    // GetIntegerv writes.
    let max = effective_limit(
        unsafe { gl.get_parameter_i32(glow::MAX_TEXTURE_SIZE) },
        |p| p.max_texture_size,
    );
    #[cfg(test)]
    let max = TEST_MAX_TEXTURE_SIZE.get().map_or(max, |m| max.min(m));
    let max = max.max(0) as u32;
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

/// A 2D RGBA float texture with `GL_NEAREST` filtering and `GL_CLAMP_TO_EDGE` wrapping.
///
/// Nearest filtering is essential, not a style choice: streams hold indices and exact
/// coordinates, and any interpolation between texels would corrupt them. It also avoids the
/// default `GL_NEAREST_MIPMAP_LINEAR`, which would make a mip-less texture incomplete.
#[derive(Debug)]
pub struct Texture {
    obj: Owned<TextureKind>,
    width: u32,
    height: u32,
}

impl Texture {
    /// Creates a `width`×`height` RGBA32F texture filled from `data` (RGBA, row-major from
    /// the bottom row, as GL stores it) or left uninitialised when `data` is `None`.
    pub fn new_f32(ctx: &GlContext, width: u32, height: u32, data: Option<&[f32]>) -> Result<Self> {
        Self::new(ctx, width, height, TexFormat::Rgba32F, data)
    }

    /// [`Texture::new_f32`] with a chosen internal format (data, when given, is f32 and is
    /// rounded by the driver for [`TexFormat::Rgba16F`]).
    pub fn new(
        ctx: &GlContext,
        width: u32,
        height: u32,
        format: TexFormat,
        data: Option<&[f32]>,
    ) -> Result<Self> {
        let gl = ctx.gl();
        check_texture_size(gl, width, height)?;
        if let Some(d) = data {
            if format == TexFormat::Rgba8 {
                return Err(Error::Internal(
                    "an RGBA8 texture is not filled from floats".into(),
                ));
            }
            if d.len() != rgba_len(width, height) {
                return Err(Error::Internal(format!(
                    "texture data has {} floats, {width}x{height} RGBA needs {}",
                    d.len(),
                    rgba_len(width, height)
                )));
            }
        }
        // SAFETY: the context is current; the slice length was checked against the upload
        // size.
        unsafe {
            let name = gl
                .create_texture()
                .map_err(|e| Error::Internal(format!("glGenTextures: {e}")))?;
            let texture = Texture {
                obj: Owned::new(ctx, name),
                width,
                height,
            };
            gl.bind_texture(glow::TEXTURE_2D, Some(name));
            for (pname, value) in [
                (glow::TEXTURE_MIN_FILTER, glow::NEAREST),
                (glow::TEXTURE_MAG_FILTER, glow::NEAREST),
                (glow::TEXTURE_WRAP_S, glow::CLAMP_TO_EDGE),
                (glow::TEXTURE_WRAP_T, glow::CLAMP_TO_EDGE),
            ] {
                gl.tex_parameter_i32(glow::TEXTURE_2D, pname, value as i32);
            }
            // Rows of RGBA32F are always 16-byte multiples, but a caller may have changed the
            // unpack state; 4 is the GL default and correct for f32 data.
            gl.pixel_store_i32(glow::UNPACK_ALIGNMENT, 4);
            gl.tex_image_2d(
                glow::TEXTURE_2D,
                0,
                ctx.info.dialect.internal_format(format.gl_enum()) as i32,
                width as i32,
                height as i32,
                0,
                glow::RGBA,
                format.gl_type(),
                glow::PixelUnpackData::Slice(data.map(f32_bytes)),
            );
            gl.bind_texture(glow::TEXTURE_2D, None);
            check_gl_error(gl, &format!("creating an {format:?} texture"))?;
            Ok(texture)
        }
    }

    /// The raw name, to bind as a pass's input.
    pub fn name(&self) -> glow::Texture {
        self.obj.name()
    }

    /// Reads the texture back as `width*height*4` floats (bottom row first) through a
    /// framebuffer made for this read: how an observer that holds only a texture (the
    /// radiance of a [`Snapshot`](crate::gpu::request::Snapshot)) sees it. Leaves no
    /// framebuffer bound.
    pub fn read_f32(&self, ctx: &GlContext) -> Result<Vec<f32>> {
        let gl = ctx.gl();
        let mut out = vec![0.0f32; rgba_len(self.width, self.height)];
        // SAFETY: the context is current; the framebuffer is owned here and deleted on
        // return; the buffer holds exactly width*height RGBA floats.
        unsafe {
            let fb = gl
                .create_framebuffer()
                .map_err(|e| Error::Internal(format!("glGenFramebuffers: {e}")))?;
            let fb: Owned<FramebufferKind> = Owned::new(ctx, fb);
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(fb.name()));
            gl.framebuffer_texture_2d(
                glow::FRAMEBUFFER,
                glow::COLOR_ATTACHMENT0,
                glow::TEXTURE_2D,
                Some(self.name()),
                0,
            );
            // A new framebuffer reads attachment 0 (WebGL 1 knows no other).
            gl.pixel_store_i32(glow::PACK_ALIGNMENT, 4);
            gl.read_pixels(
                0,
                0,
                self.width as i32,
                self.height as i32,
                glow::RGBA,
                glow::FLOAT,
                glow::PixelPackData::Slice(Some(f32_bytes_mut(&mut out))),
            );
            gl.bind_framebuffer(glow::FRAMEBUFFER, None);
        }
        check_gl_error(gl, "reading a texture")?;
        Ok(out)
    }

    /// Width in texels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in texels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Replaces the whole contents (`data` must hold `width*height*4` floats).
    pub fn upload(&self, gl: &glow::Context, data: &[f32]) -> Result<()> {
        let (width, height) = (self.width, self.height);
        if data.len() != rgba_len(width, height) {
            return Err(Error::Internal(format!(
                "texture data has {} floats, {width}x{height} RGBA needs {}",
                data.len(),
                rgba_len(width, height)
            )));
        }
        // SAFETY: the context is current; the slice length was checked.
        unsafe {
            gl.bind_texture(glow::TEXTURE_2D, Some(self.name()));
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

    /// Reads the whole texture back as f32 RGBA with `glGetTexImage`. Use
    /// [`RenderTarget::read_attachment`](super::RenderTarget::read_attachment) for a texture
    /// attached to an FBO that was just rendered; both return the same data. WebGL has no
    /// `glGetTexImage`: [`Texture::read_f32`] reads through a framebuffer of its own and
    /// works on every context (two ways kept: this one binds no framebuffer).
    pub fn read(&self, gl: &glow::Context) -> Result<Vec<f32>> {
        let mut out = vec![0.0f32; rgba_len(self.width, self.height)];
        // SAFETY: the buffer holds exactly width*height RGBA floats, the size of level 0.
        unsafe {
            gl.bind_texture(glow::TEXTURE_2D, Some(self.name()));
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
}

/// A renderbuffer for masking rays out of passes: 24-bit depth, or packed depth 24 +
/// stencil 8 (EXT_packed_depth_stencil, core in GL 3.0; stencil-only renderbuffers were
/// never widely supported).
#[derive(Debug)]
pub struct Renderbuffer {
    obj: Owned<RenderbufferKind>,
    stencil: bool,
}

impl Renderbuffer {
    /// Creates a `width`×`height` mask buffer, with stencil when `stencil`.
    pub fn new_mask(ctx: &GlContext, width: u32, height: u32, stencil: bool) -> Result<Self> {
        let gl = ctx.gl();
        check_texture_size(gl, width, height)?;
        // SAFETY: the context is current; the renderbuffer is created here and owned
        // (`Owned`) before the first call that can fail, and its storage is specified
        // without host data.
        unsafe {
            let name = gl
                .create_renderbuffer()
                .map_err(|e| Error::Internal(format!("glGenRenderbuffers: {e}")))?;
            let rb = Renderbuffer {
                obj: Owned::new(ctx, name),
                stencil,
            };
            gl.bind_renderbuffer(glow::RENDERBUFFER, Some(name));
            let format = if stencil {
                glow::DEPTH24_STENCIL8
            } else {
                glow::DEPTH_COMPONENT24
            };
            gl.renderbuffer_storage(glow::RENDERBUFFER, format, width as i32, height as i32);
            gl.bind_renderbuffer(glow::RENDERBUFFER, None);
            check_gl_error(gl, "creating a mask renderbuffer")?;
            Ok(rb)
        }
    }

    /// The raw name.
    pub fn name(&self) -> glow::Renderbuffer {
        self.obj.name()
    }

    /// Whether it has a stencil part.
    pub fn has_stencil(&self) -> bool {
        self.stencil
    }
}
