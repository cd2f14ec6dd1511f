//! The GLSL twins run on hand-made inputs next to their CPU originals, so a difference in
//! the shader code shows up as a failing case rather than as a blurry image difference.
//! Covered: intersection (t and barycentrics, every technique), the DDA helpers, the
//! shading functions of shade.glsl, the spawn and shadow-spawn passes, the split index
//! format's address arithmetic past 2^24 (triangle slots included), and the generated
//! `texture2D` fetches at every index below 2^24. Each bound sits at a small multiple of the
//! measured difference (both in comments) and fails on NaN.

mod common;
#[path = "glsl_twins/harness.rs"]
mod harness;
#[path = "glsl_twins/intersect.rs"]
mod intersect;
#[path = "glsl_twins/shading.rs"]
mod shading;
#[path = "glsl_twins/split_index.rs"]
mod split_index;
#[path = "glsl_twins/texture_fetch.rs"]
mod texture_fetch;
