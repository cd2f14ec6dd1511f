//! The GPU backend's foundation: a headless OpenGL context over EGL ([`context`]) and the
//! low-level GL helpers the render passes are built from ([`gl_util`]).
//!
//! The backend follows the OpenGL 2.1-era stream design: every pass is a GLSL 1.20 fragment
//! program drawn over a [`gl_util::FullscreenQuad`] into a [`gl_util::RenderTarget`] of
//! RGBA32F textures, reading the previous pass's outputs as textures. Fragments of finished
//! rays `discard`, and an [`gl_util::OcclusionQuery`] around a pass counts the rest, which
//! is how the host loop knows when to stop without reading streams back.

pub mod context;
pub mod gl_util;
pub mod render;
pub mod shader;

pub use context::{with_test_context, GlContext, GlInfo};
