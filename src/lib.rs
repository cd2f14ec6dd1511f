//! fragtrace: a Whitted-style ray tracer over grids built on the CPU (the thesis's uniform
//! grid and an irregular grid) whose faithful hot path runs as GLSL 1.20 fragment programs
//! (the multi-pass stream design of Purcell et al. 2002), with a GLSL 4.30 compute kernel
//! from the same GLSL where the context has it, and an f64 CPU reference renderer as ground
//! truth.
//!
//! Modules, bottom to top (docs/architecture.md): [`scene`] (model, loaders, camera),
//! [`accel`] (grid build), [`cpu`] (reference renderer), [`gpu`] (headless GL context,
//! owning GL objects, the Rust/GLSL contract, texel layout, shaders, the scene uploaded once,
//! the fragment and compute wings), [`output`] and [`image_io`] (what a render produces), [`options`]
//! (render options), [`query`] (the web page's query as the render flags), [`plan`] (what a render runs, resolved once), [`render`]
//! (backend-independent front door), [`farm`] (parts of images as tasks of a batch
//! scheduler, and merging them), [`choices`] (the render flags every front door shares),
//! [`bench`](mod@bench)
//! (speed against error) and [`cli`]; beside them [`region`] (the pixels a render
//! computes), [`technique`] (switches for the robustness techniques), [`aov`] (AOV files)
//! and [`compare`] (error figures).

// Every `unsafe` block says, in a `// SAFETY:` comment, the invariant that makes it sound.
#![deny(clippy::undocumented_unsafe_blocks)]
// The wasm32 build (the web page, docs/web.md) leaves out the native-only modules, so
// helpers only they use (and the x86 SIMD kernels) are unused there.
#![cfg_attr(
    target_arch = "wasm32",
    allow(dead_code, unused_imports, unused_macros)
)]

pub mod accel;
#[cfg(not(target_arch = "wasm32"))]
pub mod animate;
pub mod aov;
#[cfg(not(target_arch = "wasm32"))]
pub mod backend_choice;
#[cfg(not(target_arch = "wasm32"))]
pub mod bench;
pub mod choices;
#[cfg(not(target_arch = "wasm32"))]
pub mod cli;
pub mod clock;
#[cfg(not(target_arch = "wasm32"))]
pub mod compare;
pub mod cpu;
pub mod error;
#[cfg(not(target_arch = "wasm32"))]
pub mod farm;
pub mod fnv;
pub mod gpu;
pub mod image_io;
#[cfg(not(target_arch = "wasm32"))]
pub mod memory;
pub mod numeric;
pub mod options;
pub mod output;
#[cfg(not(target_arch = "wasm32"))]
pub mod overlap;
#[cfg(not(target_arch = "wasm32"))]
pub mod plan;
pub mod png_bands;
pub mod pool;
pub mod progress;
pub mod query;
pub mod region;
#[cfg(not(target_arch = "wasm32"))]
pub mod render;
pub mod scene;
pub mod technique;
#[cfg(test)]
pub(crate) mod testing;
#[cfg(not(target_arch = "wasm32"))]
pub mod view;

pub use error::{Error, Result};
