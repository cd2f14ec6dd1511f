//! CPU reference renderer: the same algorithm the GPU runs (3D-DDA over the uniform grid,
//! watertight triangle tests, Whitted shading), in f64 for ground truth or f32 to mirror
//! the GPU's arithmetic.

pub mod intersect;
pub mod real;
pub mod render;
pub mod shade;
pub mod traverse;
pub mod traverse_irregular;
pub mod walker;

pub use render::{CpuOutput, CpuRenderer};
