//! Acceleration structure: a uniform grid over the scene's triangles, built on the CPU and
//! traversed with a 3D-DDA by both renderers.
//!
//! [`grid`] holds the grid itself and its build (auto resolution, conservative binning,
//! parallel counting sort, statistics); [`tribox`] holds the exact triangle/box overlap
//! test the binning relies on.

pub mod grid;
pub mod layout;
pub mod tribox;
pub mod two_level;

pub use grid::{CellRange, Grid, GridConfig, GridRes, GridStats};
