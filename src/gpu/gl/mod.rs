//! Owning GL objects and the low-level helpers the render passes are built from: float
//! textures and mask renderbuffers ([`texture`]), multi-target FBOs ([`target`]), programs
//! compiled with source-mapped errors and the full-screen quad ([`program`]), and
//! occlusion/timer queries ([`query`]), the fixed-function state between draws ([`state`]),
//! the probing of a desktop context (`probe`) or of the page's WebGL one (`webgl`, wasm32),
//! and for the compute kernel (GL 4.3) compute programs, storage buffers, image bindings and
//! dispatches ([`compute`]).
//!
//! This is the only module that calls GL (`tests/gl_sealed.rs` checks it): the rest of the
//! crate draws, reads and binds through the safe functions and owning types here, so each
//! `unsafe` GL call and the invariant it relies on are stated once, in this module.
//!
//! Every object here owns its GL name and deletes it in `Drop`, in its own context: the rule
//! is stated once in [`super::context`]. Constructors take the [`GlContext`] (which must be
//! current on the calling thread) so the object can keep the context alive; methods that
//! draw or read take `&glow::Context` or the `GlContext` as before.
//!
//! Everything here targets the OpenGL 2.1 API (GLSL 1.20, VBOs, ARB_framebuffer_object
//! names) so that it runs unchanged in a 2.1 context and in any newer compatibility profile.
//! Functions leave the objects they create unbound unless documented otherwise.
//!
//! Termination detection: a pass's fragment program ends with `discard` for rays that have
//! nothing left to do. `GL_SAMPLES_PASSED` counts only fragments that were *not* discarded,
//! so an [`OcclusionQuery`] around a pass tells the host how many rays are still active
//! without reading any texture back (Purcell et al. 2002, section 4).

use std::rc::Rc;

use glow::HasContext;

use super::context::{Deferred, GlContext, GlShared};
use crate::error::{Error, Result};

pub mod compute;
#[cfg(not(target_arch = "wasm32"))]
pub mod probe;
pub mod program;
pub mod query;
pub mod readback;
pub mod rects;
pub mod state;
pub mod target;
pub mod texture;
#[cfg(target_arch = "wasm32")]
pub(crate) mod webgl;

pub use compute::{bind_image, compile_compute, dispatch, storage_limits, StorageBuffer};
pub use program::{
    compile_program, single_file_line_map, FullscreenQuad, Program, ATTRIB_POS, ATTRIB_UV,
    QUAD_VERTEX_SHADER,
};
pub use query::{OcclusionQuery, TimerQuery};
pub use readback::{has_buffer_storage, ReadbackRing};
pub use rects::{PixelRect, Rects};
pub use state::{MaskBuffer, SavedState};
pub use target::{bind_window, read_window, RenderTarget};
pub use texture::{Renderbuffer, TexFormat, Texture};

/// A kind of GL object: how its name is typed and how it is deleted.
pub trait GlKind {
    /// glow's name type for this kind.
    type Name: Copy + std::fmt::Debug;
    /// Deletes `name`.
    ///
    /// # Safety
    /// The owning context must be current and `name` must not be used afterwards.
    unsafe fn delete(gl: &glow::Context, name: Self::Name);
}

/// One GL name of kind `K`, deleted in its own context when dropped.
pub struct Owned<K: GlKind> {
    shared: Rc<GlShared>,
    name: K::Name,
}

impl<K: GlKind> Owned<K> {
    /// Takes ownership of `name`, just created in `ctx`.
    pub(crate) fn new(ctx: &GlContext, name: K::Name) -> Self {
        Owned {
            shared: Rc::clone(ctx.shared()),
            name,
        }
    }

    /// The raw name, for GL calls (valid while `self` lives).
    pub fn name(&self) -> K::Name {
        self.name
    }

    /// Takes ownership of `name`, just created in the context `self` belongs to: for a
    /// helper that has an object of the context at hand but not the `GlContext`.
    pub(crate) fn beside<J: GlKind>(&self, name: J::Name) -> Owned<J> {
        Owned {
            shared: Rc::clone(&self.shared),
            name,
        }
    }
}

impl<K: GlKind> Owned<K>
where
    K::Name: 'static,
{
    /// Gives the name up without deleting it now: its delete runs once `done` (asked with
    /// the context current, of the name) says the driver is through with it, or when the
    /// context goes ([`GlShared::defer`]), for an object whose delete the driver would make
    /// wait.
    pub(crate) fn delete_when(self, done: impl Fn(&glow::Context, K::Name) -> bool + 'static) {
        let this = std::mem::ManuallyDrop::new(self);
        let name = this.name;
        // SAFETY: `this` is never dropped, so its `Rc` is moved out exactly once.
        let shared = unsafe { std::ptr::read(&this.shared) };
        shared.defer(Deferred {
            done: Box::new(move |gl| done(gl, name)),
            // SAFETY: the deferred delete runs with the owning context current, once, and
            // the name is used by nothing else after `self`.
            delete: Box::new(move |gl| unsafe { K::delete(gl, name) }),
        });
    }
}

impl<K: GlKind> std::fmt::Debug for Owned<K> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:?}", self.name)
    }
}

impl<K: GlKind> Drop for Owned<K> {
    fn drop(&mut self) {
        let name = self.name;
        // SAFETY: `with_current` runs the delete with the owning context current, and the
        // name dies with `self`.
        self.shared
            .with_current(|gl| unsafe { K::delete(gl, name) });
    }
}

macro_rules! gl_kind {
    ($(#[$doc:meta])* $kind:ident, $name:ty, $delete:ident) => {
        $(#[$doc])*
        #[derive(Debug)]
        pub enum $kind {}
        impl GlKind for $kind {
            type Name = $name;
            unsafe fn delete(gl: &glow::Context, name: $name) {
                gl.$delete(name);
            }
        }
    };
}

gl_kind!(
    /// Texture objects.
    TextureKind, glow::Texture, delete_texture
);
gl_kind!(
    /// Framebuffer objects.
    FramebufferKind, glow::Framebuffer, delete_framebuffer
);
gl_kind!(
    /// Renderbuffer objects.
    RenderbufferKind, glow::Renderbuffer, delete_renderbuffer
);
/// Linked programs.
#[derive(Debug)]
pub enum ProgramKind {}
impl GlKind for ProgramKind {
    type Name = glow::Program;
    unsafe fn delete(gl: &glow::Context, name: glow::Program) {
        // A program in use survives glDeleteProgram until another is made current, so the
        // last program a frame drew with would outlive the frame.
        // WebGL names are opaque (and WebGL defers the delete itself).
        #[cfg(not(target_arch = "wasm32"))]
        if gl.get_parameter_i32(glow::CURRENT_PROGRAM) as u32 == name.0.get() {
            gl.use_program(None);
        }
        gl.delete_program(name);
    }
}
gl_kind!(
    /// Shader objects (alive only until their program is linked).
    ShaderKind, glow::Shader, delete_shader
);
gl_kind!(
    /// Query objects (occlusion and timer).
    QueryKind, glow::Query, delete_query
);
gl_kind!(
    /// Buffer objects.
    BufferKind, glow::Buffer, delete_buffer
);
gl_kind!(
    /// Vertex array objects (GL 3.0+).
    VertexArrayKind, glow::VertexArray, delete_vertex_array
);

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

#[cfg(test)]
mod tests;
