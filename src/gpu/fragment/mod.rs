//! The fragment kernels (`multipass`, `unrolled:K`, `looped`): the host side of the
//! thesis's stream design.
//!
//! Every pass is one fragment program drawn over the full-screen quad into RGBA32F
//! textures (the advancing passes: over the tiles of it that still hold active rays). The
//! ray state lives in four textures ping-ponged between two framebuffers (a pass never
//! reads what it writes); every pass copies rays that are not in its state through
//! unchanged, so either set always holds the whole current state.
//!
//! One job per file: `frame` owns the GL objects of a render and draws passes; `passes`
//! decides which programs a scene needs; `trace` is the one termination loop that traces a
//! ray wave (traversal passes until an occlusion query over the `count` pass, run every K
//! iterations, finds no active ray), and `tiles` the tiles its passes are cut to; `tree`
//! walks the Whitted ray tree (each level keeps a hit record; a node's children are skipped
//! when an occlusion query finds no pixel where they exist) and calls the observer;
//! `readback` brings images, AOVs and traced waves back to the host.
//!
//! This wing stands on the GPU scene (`gpu::scene`) alone; it never imports the compute
//! wing.

mod frame;
mod passes;
mod readback;
mod tiles;
mod trace;
mod tree;

pub(crate) use readback::trace_wave;
pub(crate) use tree::{render, walk};
