//! fragtrace: a Whitted-style ray tracer over a uniform grid whose hot path runs as GLSL 1.20
//! fragment programs (the multi-pass stream design of Purcell et al. 2002), with an f64 CPU
//! reference renderer as ground truth.
//!
//! Modules: [`scene`] (model, loaders, camera), [`accel`] (grid build),
//! [`cpu`] (reference renderer), [`gpu`] (headless GL context, texel layout, shaders, passes),
//! [`render`] (backend-independent front door), [`technique`] (switches for the robustness
//! techniques), [`image_io`] (PNG/EXR), [`compare`] (error figures), [`bench`](mod@bench)
//! (speed against error), [`cli`].

pub mod accel;
pub mod aov;
pub mod bench;
pub mod cli;
pub mod compare;
pub mod cpu;
pub mod error;
pub mod gpu;
pub mod image_io;
pub mod output;
pub mod progress;
pub mod render;
pub mod scene;
pub mod technique;

pub use error::{Error, Result};
