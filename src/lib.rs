//! fragtrace: a Whitted-style ray tracer over a uniform grid whose hot path runs as GLSL 1.20
//! fragment programs (the multi-pass stream design of Purcell et al. 2002), with an f64 CPU
//! reference renderer as ground truth.
//!
//! Modules: [`scene`] (model, loaders, camera), [`accel`] (grid build), [`cpu`] (reference
//! renderer), [`image_io`] (PNG/EXR output), [`cli`] (command line).

pub mod accel;
pub mod cli;
pub mod cpu;
pub mod error;
pub mod image_io;
pub mod render;
pub mod scene;

pub use error::{Error, Result};
