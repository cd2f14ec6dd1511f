//! The context's fixed-function state the passes set between draws, behind safe calls:
//! clearing the bound target, colour writes, the depth/stencil mask of finished rays,
//! texture units, waiting for the GPU, and saving and restoring what a guest (the window's
//! presenter) touches.
//!
//! Like the rest of `gpu::gl`, each function takes the `glow::Context` of a
//! [`GlContext`](crate::gpu::GlContext), which is current on the calling thread for as long
//! as the caller can reach it: that, and the arguments' being live objects of that context
//! (which their owning types guarantee), is all GL asks of these calls. None of them takes
//! a pointer or a count that GL would trust.

use glow::HasContext;

use super::Texture;

/// Blocks until every command issued so far has finished (`glFinish`): what a timer reads
/// before it charges a phase, and what makes an upload's cost land where it was made.
pub fn finish(gl: &glow::Context) {
    // SAFETY: glFinish takes no arguments; the context is current (module doc).
    unsafe { gl.finish() };
}

/// Clears the colour buffers of the bound framebuffer to `rgba` (the clear colour stays
/// set, as GL keeps it).
pub fn clear_colour(gl: &glow::Context, rgba: [f32; 4]) {
    let [r, g, b, a] = rgba;
    // SAFETY: the context is current; the enum is a valid clear mask and the values are
    // plain floats GL clamps.
    unsafe {
        gl.clear_color(r, g, b, a);
        gl.clear(glow::COLOR_BUFFER_BIT);
    }
}

/// Clears each of `rects` (pixels of the bound framebuffer, rows from the bottom) to `rgba`
/// through the scissor test, which it leaves off: the renderer never turns it on. The clear
/// colour stays set, as [`clear_colour`] leaves it (every clear of the renderer sets its
/// own first).
pub fn clear_rects(gl: &glow::Context, rects: &[super::PixelRect], rgba: [f32; 4]) {
    let [r, g, b, a] = rgba;
    // SAFETY: the context is current; the scissor box takes any non-negative integers
    // (GL clips it to the framebuffer), the widths and heights are those of well-formed
    // rectangles, and the enums are valid.
    unsafe {
        gl.clear_color(r, g, b, a);
        gl.enable(glow::SCISSOR_TEST);
        for q in rects.iter().filter(|q| q.x1 > q.x0 && q.y1 > q.y0) {
            gl.scissor(
                q.x0 as i32,
                q.y0 as i32,
                (q.x1 - q.x0) as i32,
                (q.y1 - q.y0) as i32,
            );
            gl.clear(glow::COLOR_BUFFER_BIT);
        }
        gl.disable(glow::SCISSOR_TEST);
    }
}

/// Turns writes to all four colour channels on or off: off for a pass drawn only for its
/// occlusion count (and the mask it writes), so it leaves the target's texels as they were.
pub fn colour_writes(gl: &glow::Context, on: bool) {
    // SAFETY: the context is current; glColorMask takes any four booleans.
    unsafe { gl.color_mask(on, on, on, on) };
}

/// Which buffer of the bound framebuffer masks finished rays out of the passes: the depth
/// buffer (early-z, the thesis's choice) or the stencil buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaskBuffer {
    /// Active rays get depth 0, the rest keep the cleared 1; later quads at depth 0.5 pass
    /// `GL_GREATER` only where the depth is 0.
    Depth,
    /// Active rays get stencil 1; later draws pass `GL_EQUAL 1`.
    Stencil,
}

/// Clears the mask buffer and sets up the next draw to write it: every fragment that is not
/// discarded (an active ray) marks its pixel. The bound framebuffer must have the mask
/// buffer attached; [`end_mask_write`] undoes the write state.
pub fn begin_mask_write(gl: &glow::Context, mask: MaskBuffer) {
    // SAFETY: the context is current; every enum below is one the call accepts, and a
    // framebuffer without the buffer only makes the clear and the test no-ops.
    unsafe {
        match mask {
            MaskBuffer::Depth => {
                gl.depth_mask(true);
                gl.clear_depth_f64(1.0);
                gl.clear(glow::DEPTH_BUFFER_BIT);
                gl.enable(glow::DEPTH_TEST);
                gl.depth_func(glow::ALWAYS);
                // The quad lies at window depth 0.5; a [0, 0] range stores 0 instead.
                gl.depth_range_f64(0.0, 0.0);
            }
            MaskBuffer::Stencil => {
                gl.stencil_mask(0xff);
                gl.clear_stencil(0);
                gl.clear(glow::STENCIL_BUFFER_BIT);
                gl.enable(glow::STENCIL_TEST);
                gl.stencil_func(glow::ALWAYS, 1, 0xff);
                gl.stencil_op(glow::KEEP, glow::KEEP, glow::REPLACE);
            }
        }
    }
}

/// Ends the mask write that [`begin_mask_write`] started: the depth range back to `[0, 1]`,
/// depth and stencil writes off, both tests off.
pub fn end_mask_write(gl: &glow::Context) {
    // SAFETY: the context is current; plain state setters with valid enums.
    unsafe {
        gl.depth_range_f64(0.0, 1.0);
        gl.depth_mask(false);
        gl.stencil_mask(0);
        gl.disable(glow::DEPTH_TEST);
        gl.disable(glow::STENCIL_TEST);
    }
}

/// Tests the draws that follow against `mask` (only pixels the last mask write marked are
/// drawn), without writing it; `None` turns both the depth and the stencil test off.
pub fn mask_test(gl: &glow::Context, mask: Option<MaskBuffer>) {
    // SAFETY: the context is current; plain state setters with valid enums.
    unsafe {
        match mask {
            Some(MaskBuffer::Depth) => {
                gl.enable(glow::DEPTH_TEST);
                gl.depth_func(glow::GREATER);
                gl.depth_mask(false);
            }
            Some(MaskBuffer::Stencil) => {
                gl.enable(glow::STENCIL_TEST);
                gl.stencil_func(glow::EQUAL, 1, 0xff);
                gl.stencil_op(glow::KEEP, glow::KEEP, glow::KEEP);
                gl.stencil_mask(0);
            }
            None => {
                gl.disable(glow::DEPTH_TEST);
                gl.disable(glow::STENCIL_TEST);
            }
        }
    }
}

/// Binds `tex` (nothing, with `None`) to the 2D target of texture unit `unit`, which stays
/// the active unit.
pub fn bind_texture(gl: &glow::Context, unit: u32, tex: Option<&Texture>) {
    // SAFETY: the context is current and `tex`, borrowed, is a live texture of it; a unit
    // past the driver's limit is a GL error, not undefined behaviour.
    unsafe {
        gl.active_texture(glow::TEXTURE0 + unit);
        gl.bind_texture(glow::TEXTURE_2D, tex.map(Texture::name));
    }
}

/// Drops every pending GL error (a bounded number, as a lost context reports errors
/// forever): for a caller that expects errors it does not answer for, such as drawing into
/// the incomplete default framebuffer of a context without a window.
pub fn clear_errors(gl: &glow::Context) {
    for _ in 0..16 {
        // SAFETY: glGetError has no preconditions beyond a current context.
        if unsafe { gl.get_error() } == glow::NO_ERROR {
            break;
        }
    }
}

/// The GL state a guest drawing between two of the renderer's passes changes (the window's
/// presenter), saved before it draws and put back after: framebuffer, viewport, program,
/// active unit, the 2D textures of units 0 and 1, and the depth and stencil tests. The
/// renderer then never learns that it was watched.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SavedState {
    pub(crate) framebuffer: Option<glow::Framebuffer>,
    pub(crate) viewport: [i32; 4],
    pub(crate) program: Option<glow::Program>,
    /// The active unit as GL names it (`GL_TEXTURE0 + k`).
    pub(crate) active_unit: u32,
    pub(crate) units: [(u32, Option<glow::Texture>); 2],
    pub(crate) depth_test: bool,
    pub(crate) stencil_test: bool,
}

impl SavedState {
    /// Reads the state from the current context.
    pub fn save(gl: &glow::Context) -> SavedState {
        // SAFETY: the context is current; GL_VIEWPORT writes exactly the four integers the
        // slice holds, every other query returns one value, and the active unit is put back
        // to what GL reported.
        unsafe {
            let mut viewport = [0; 4];
            gl.get_parameter_i32_slice(glow::VIEWPORT, &mut viewport);
            let active_unit = gl.get_parameter_i32(glow::ACTIVE_TEXTURE) as u32;
            let units = [0, 1].map(|k| {
                gl.active_texture(glow::TEXTURE0 + k);
                (k, gl.get_parameter_texture(glow::TEXTURE_BINDING_2D))
            });
            gl.active_texture(active_unit);
            SavedState {
                framebuffer: gl.get_parameter_framebuffer(glow::FRAMEBUFFER_BINDING),
                viewport,
                program: gl.get_parameter_program(glow::CURRENT_PROGRAM),
                active_unit,
                units,
                depth_test: gl.is_enabled(glow::DEPTH_TEST),
                stencil_test: gl.is_enabled(glow::STENCIL_TEST),
            }
        }
    }

    /// Puts the saved state back.
    pub fn restore(&self, gl: &glow::Context) {
        // SAFETY: the context is current and every value was read from it by `save`; a name
        // deleted in between binds as a GL error or a fresh object, never out of bounds.
        unsafe {
            for (k, t) in self.units {
                gl.active_texture(glow::TEXTURE0 + k);
                gl.bind_texture(glow::TEXTURE_2D, t);
            }
            gl.active_texture(self.active_unit);
            gl.bind_framebuffer(glow::FRAMEBUFFER, self.framebuffer);
            let [x, y, w, h] = self.viewport;
            gl.viewport(x, y, w, h);
            gl.use_program(self.program);
            for (cap, on) in [
                (glow::DEPTH_TEST, self.depth_test),
                (glow::STENCIL_TEST, self.stencil_test),
            ] {
                if on {
                    gl.enable(cap)
                } else {
                    gl.disable(cap)
                }
            }
        }
    }
}

/// Sets a renderer's state for a test of [`SavedState`]: the depth test on and texture
/// unit `unit` active.
#[cfg(test)]
pub(crate) fn depth_test_on_with_active_unit(gl: &glow::Context, unit: u32) {
    // SAFETY: the context is current; valid enums.
    unsafe {
        gl.enable(glow::DEPTH_TEST);
        gl.active_texture(glow::TEXTURE0 + unit);
    }
}
