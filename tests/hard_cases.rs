//! The hard-case robustness suite: 22 geometric and numeric corner cases, each run on every
//! backend — the CPU reference in f64 (ground truth), the CPU in f32 (the GPU's arithmetic),
//! the GLSL 1.20 backend with the faithful multipass kernel and the GL backend with the
//! GLSL 4.30 compute kernel (llvmpipe here) — on both grids (the uniform grid and the
//! irregular grid, `--accel`), and the two CPU backends once more on the CPU-only BVH
//! (`--accel bvh`), through single rays (`Walker::<T>`, `BvhWalker::<T>` and
//! `gpu::render::trace_rays`) or small images (`render_cpu` / `render_gl_with`). The BVH's
//! f32 answers are also checked against its vectorised walk (single rays) and its
//! `--cpu-path scalar` render (images), bit for bit, as the grids' are.
//!
//! Every case reads as its set-up and its bound: the shared machinery (the f32 test ray,
//! tracing and rendering on the ten backends, scene builders, the per-backend report)
//! is in `hard_cases/support.rs`, the cases are grouped by what they exercise:
//!
//! - `watertight`: cases 1-4, 6, 12, 15 (the intersection test);
//! - `grid`: cases 7-11 (the traversal; case 7's cell counts on the uniform grid only, its
//!   misses and signed zeros on the BVH too);
//! - `spawned`: cases 5, 16, 17 (rays spawned at hits);
//! - `images`: cases 13, 14, 21 (whole images); `glass`: cases 18, 19;
//! - `inputs`: cases 20, 22 (bad input and limits).
//!
//! Every test prints what it measured, one line per backend, prefixed `[case NN]`;
//! `docs/robustness.md` tabulates those numbers. Reproduce with
//! `cargo test --release --test hard_cases -- --nocapture`.
//!
//! Rays are built in f32 (the precision the GPU stores), so every backend traces the
//! very same ray; the f64 backend converts them exactly. Seeded randomness prints its seed.
//! GL work is kept small (llvmpipe on two cores): images are 48x36, ray batches one
//! `trace_rays` call per scene, query and GL kernel.

mod common;
#[path = "hard_cases/glass.rs"]
mod glass;
#[path = "hard_cases/grid.rs"]
mod grid;
#[path = "hard_cases/images.rs"]
mod images;
#[path = "hard_cases/inputs.rs"]
mod inputs;
#[path = "hard_cases/spawned.rs"]
mod spawned;
#[path = "hard_cases/support.rs"]
mod support;
#[path = "hard_cases/watertight.rs"]
mod watertight;
