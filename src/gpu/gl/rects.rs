//! `Rects`: rectangles of pixels of a render target, drawn as pieces of the full-screen
//! quad ([`super::FullscreenQuad`]), so that a pass rasterises only the tiles that still
//! hold active rays (issue 49: the multipass kernel's passes cut to what is left).
//!
//! Each rectangle is two triangles over its corners, split along the same diagonal as the
//! quad's fan, with the corners' texture coordinates at the same fractions of the target as
//! the quad's: a fragment of a rectangle samples the texel its pixel samples under the
//! quad. Corners sit on pixel edges and pixel centres never do, so rectangles that share an
//! edge cover every pixel of their union exactly once (occlusion counts rely on that).

use std::ops::Range;

use glow::HasContext;

use super::program::{bind_vertices, unbind_vertices, Program, VERTEX_FLOATS};
use super::{check_gl_error, f32_bytes, BufferKind, Owned, VertexArrayKind};
use crate::error::Result;
use crate::gpu::context::GlContext;

/// A rectangle of pixels `[x0, x1) x [y0, y1)`, rows counted from the bottom as GL does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelRect {
    /// First column.
    pub x0: u32,
    /// First row (from the bottom).
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl PixelRect {
    /// Its pixels.
    pub fn area(&self) -> u64 {
        (self.x1 - self.x0) as u64 * (self.y1 - self.y0) as u64
    }
}

/// Floats per vertex: x, y, z, u, v, as the quad's.
const FLOATS: usize = VERTEX_FLOATS;
/// Vertices per rectangle: two triangles.
const VERTICES: usize = 6;

/// A vertex buffer of rectangles of a `width` x `height` target.
#[derive(Debug)]
pub struct Rects {
    vbo: Owned<BufferKind>,
    /// Only on GL >= 3.0, as the quad's.
    vao: Option<Owned<VertexArrayKind>>,
    /// Rectangles uploaded.
    len: usize,
    /// Pixels they cover.
    area: u64,
}

impl Rects {
    /// An empty buffer.
    pub fn new(ctx: &GlContext) -> Result<Self> {
        let (vbo, vao) = super::program::vertex_buffer(ctx)?;
        check_gl_error(ctx.gl(), "creating a rectangle buffer")?;
        Ok(Rects {
            vbo,
            vao,
            len: 0,
            area: 0,
        })
    }

    /// Replaces the rectangles with `rects` of a `width` x `height` target.
    pub fn upload(&mut self, gl: &glow::Context, rects: &[PixelRect], width: u32, height: u32) {
        let mut v = Vec::with_capacity(rects.len() * VERTICES * FLOATS);
        let (w, h) = (width as f32, height as f32);
        for r in rects {
            // u = x / width exactly as the quad interpolates it, and x = 2u - 1, which is
            // exact for the quad's corners (0 -> -1, 1 -> 1).
            let (u0, u1, t0, t1) = (
                r.x0 as f32 / w,
                r.x1 as f32 / w,
                r.y0 as f32 / h,
                r.y1 as f32 / h,
            );
            let corner = |u: f32, t: f32| [2.0 * u - 1.0, 2.0 * t - 1.0, -0.5, u, t];
            let (a, b, c, d) = (
                corner(u0, t0),
                corner(u1, t0),
                corner(u1, t1),
                corner(u0, t1),
            );
            // The fan's triangles (0, 1, 2) and (0, 2, 3).
            for p in [a, b, c, a, c, d] {
                v.extend_from_slice(&p);
            }
        }
        // SAFETY: the context is current; the data is a local vector of whole vertices.
        unsafe {
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(self.vbo.name()));
            gl.buffer_data_u8_slice(glow::ARRAY_BUFFER, f32_bytes(&v), glow::DYNAMIC_DRAW);
            gl.bind_buffer(glow::ARRAY_BUFFER, None);
        }
        self.len = rects.len();
        self.area = rects.iter().map(PixelRect::area).sum();
    }

    /// How many rectangles it holds.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether it holds none.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The pixels its rectangles cover.
    pub fn area(&self) -> u64 {
        self.area
    }

    /// Makes `program` current and draws rectangles `range` (indices into the last upload)
    /// into the bound render target, as [`super::FullscreenQuad::draw`] draws the quad.
    pub fn draw(&self, gl: &glow::Context, program: &Program, range: Range<usize>) {
        self.bind(gl, program).draw(range);
    }

    /// Makes `program` current and binds the rectangles as its vertices, for several draws
    /// of parts of them ([`BoundRects::draw`]); unbound when the guard drops.
    pub fn bind<'a>(&'a self, gl: &'a glow::Context, program: &Program) -> BoundRects<'a> {
        // SAFETY: the context is current; the buffer holds `self.len` rectangles of
        // `VERTICES` vertices of the declared layout, and the guard's draws stay within
        // them (asserted there).
        unsafe { bind_vertices(gl, program, &self.vbo, self.vao.as_ref()) };
        BoundRects { rects: self, gl }
    }
}

/// [`Rects`] bound for drawing ([`Rects::bind`]).
pub struct BoundRects<'a> {
    rects: &'a Rects,
    gl: &'a glow::Context,
}

impl BoundRects<'_> {
    /// Draws rectangles `range` into the bound render target.
    pub fn draw(&self, range: Range<usize>) {
        assert!(
            range.end <= self.rects.len,
            "rectangles {range:?} of {}",
            self.rects.len
        );
        if range.is_empty() {
            return;
        }
        // SAFETY: the vertices are bound ([`Rects::bind`]) and `range` lies within them.
        unsafe {
            self.gl.draw_arrays(
                glow::TRIANGLES,
                (range.start * VERTICES) as i32,
                (range.len() * VERTICES) as i32,
            );
        }
    }
}

impl Drop for BoundRects<'_> {
    fn drop(&mut self) {
        // SAFETY: the context is current; plain unbinding.
        unsafe { unbind_vertices(self.gl, self.rects.vao.is_some()) };
    }
}
