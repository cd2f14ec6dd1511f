//! Acceleration structure: a uniform grid over the scene's triangles, built on the CPU and
//! traversed with a 3D-DDA by both renderers.
//!
//! [`grid`] holds the grid itself and its build (auto resolution, conservative binning,
//! parallel counting sort, statistics); [`tribox`] holds the exact triangle/box overlap
//! test the binning relies on.

pub mod binning;
pub mod grid;
pub mod irregular;
pub mod tribox;
pub mod two_level;

pub use grid::{CellRange, Grid, GridConfig, GridRes, GridStats};

/// Relative margin by which a later (higher-index) triangle must be closer than the current
/// best hit to replace it. Coplanar duplicates and hits on shared edges give t values that
/// differ by an ulp or two between f32, f64 and GPU arithmetic; with this margin all of them
/// keep the lowest index. 2^-19 is about 8 f32 ulps. Part of the traversal contract every
/// backend follows, so it lives with the structure: `cpu::traverse` uses it and the GLSL
/// prelude gets it as `TIE_EPS`.
pub const TIE_EPS: f64 = 1.0 / 524_288.0;
