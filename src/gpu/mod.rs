//! The GPU backend: a headless OpenGL context over EGL ([`context`], [`egl`], [`info`];
//! `device`: `--gpu env`'s device from the scheduler's variables),
//! owning GL objects ([`gl`]), the Rust/GLSL contract ([`contract`]), the scene's texel
//! layout ([`layout`]), shader assembly ([`shader`]), options ([`options`]), the scene
//! uploaded once ([`scene`]), what a render is asked and gives back ([`request`], [`wave`]),
//! how a render pauses between passes ([`pause`]),
//! the two wings that render (`fragment`: the thesis's passes; `compute`: one dispatch) and
//! the one entry that picks the wing ([`render`]).
//!
//! Imports run one way inside: `context`/`gl`/`contract`/`layout`/`shader`/`options` ->
//! `scene`, `request`, `wave`, `pause` -> `fragment` | `compute` (never each other) -> `render`.
//!
//! The backend follows the OpenGL 2.1-era stream design: every pass is a GLSL 1.20 fragment
//! program drawn over a [`gl::FullscreenQuad`] into a [`gl::RenderTarget`] of RGBA32F
//! textures, reading the previous pass's outputs as textures. Work passes copy rays that are
//! not in their state through unchanged (so the ping-pong pair stays complete); a separate
//! `count` pass `discard`s inactive rays under an [`gl::OcclusionQuery`], which is how the
//! host loop knows when to stop without reading streams back. The passes ([`render`]) and
//! their assembly from `glsl120/` ([`shader`]) are described in docs/gpu-design.md.
//!
//! This layer depends on `scene`, `accel` and the shared output types only, never on the
//! render front door, the CLI or the bench.

#[cfg(not(target_arch = "wasm32"))]
mod compute;
pub mod context;
pub mod contract;
#[cfg(not(target_arch = "wasm32"))]
pub mod device;
pub mod dialect;
#[cfg(not(target_arch = "wasm32"))]
pub mod egl;
mod fragment;
pub mod gl;
pub mod info;
pub mod layout;
pub mod options;
pub mod pause;
pub mod program_cache;
pub mod render;
pub mod request;
pub mod scene;
pub mod shader;
pub mod split_index;
pub mod wave;
#[cfg(target_arch = "wasm32")]
pub mod web;

#[cfg(test)]
mod lifetime_tests;

pub use context::GlContext;
pub use info::GlInfo;
pub use scene::GpuScene;
