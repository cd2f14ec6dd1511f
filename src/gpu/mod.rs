//! The GPU backend's foundation: a headless OpenGL context over EGL ([`context`]) and the
//! low-level GL helpers the render passes are built from ([`gl_util`]).
//!
//! The backend follows the OpenGL 2.1-era stream design: every pass is a GLSL 1.20 fragment
//! program drawn over a [`gl_util::FullscreenQuad`] into a [`gl_util::RenderTarget`] of
//! RGBA32F textures, reading the previous pass's outputs as textures. Work passes copy rays
//! that are not in their state through unchanged (so the ping-pong pair stays complete); a
//! separate `count` pass `discard`s inactive rays under an [`gl_util::OcclusionQuery`],
//! which is how the host loop knows when to stop without reading streams back. The passes
//! ([`render`]) and their assembly from `glsl120/` ([`shader`]) are described in
//! docs/gpu-design.md.

pub mod context;
pub mod gl_util;
pub mod render;
pub mod shader;

pub use context::{with_test_context, GlContext, GlInfo};
