//! CPU reference renderer: the same algorithm the GPU runs (the uniform grid's 3D-DDA or
//! the irregular grid's cell walk, watertight triangle tests, Whitted shading), or the
//! walk of the CPU-only BVH (`traverse_bvh.rs`), in f64 for
//! ground truth or f32 to mirror the GPU's arithmetic; in f32 either the scalar walk (the
//! GLSL's twin) or the vectorised one (`simd_walk.rs`, the same decisions, faster).

pub mod closest;
pub mod intersect;
pub mod lanes;
pub mod packet_state;
pub mod real;
pub mod render;
pub mod shade;
pub mod shade_lanes;
pub mod simd;
pub mod simd_step;
pub mod simd_walk;
pub mod soa;
pub mod texture;
pub mod traverse;
pub mod traverse_bvh;
pub mod traverse_instances;
pub mod traverse_irregular;
pub mod traverse_packet;
pub mod walker;

pub use render::{CpuOutput, CpuRenderer};
