//! Reading results back to the host: the image, the primary-ray AOVs, and the final ray
//! states of a traced wave, all through the field declarations of
//! [`contract`](crate::gpu::contract).

use rayon::prelude::*;

use super::frame::Frame;
use crate::gpu::contract::{ray, RayState, StateTexels};
use crate::gpu::options::{FragmentKernel, GpuOptions};
use crate::gpu::request::aov_pixel;
use crate::gpu::scene::GpuScene;
use crate::gpu::shader::Query;
use crate::gpu::wave::{initial_state, traces_from, wave_size, GpuRay, GpuTrace};
use crate::output::{Aov, AovPixel};
use crate::scene::Scene;
use crate::Result;

/// GL rows start at the bottom; images at the top. Drops alpha.
pub(super) fn flip_rgba_to_rgb(data: &[f32], w: u32, h: u32) -> Vec<f32> {
    let mut out = vec![0f32; (w * h * 3) as usize];
    // Rows in parallel: at 4096x4096 the host's share of a render is mostly these loops.
    out.par_chunks_mut((w * 3) as usize)
        .enumerate()
        .for_each(|(j, dst)| {
            let row = (h as usize - 1 - j) * w as usize * 4;
            for (i, px) in dst.chunks_mut(3).enumerate() {
                px.copy_from_slice(&data[row + i * 4..row + i * 4 + 3]);
            }
        });
    out
}

/// Reads the current ray-state set's textures s0 and s3 (the others stay empty).
fn read_state(f: &Frame) -> Result<StateTexels> {
    let st = &f.state[f.cur];
    let read = |k: usize| st.read_attachment(f.gl(), k);
    Ok(StateTexels {
        texels: [read(0)?, Vec::new(), Vec::new(), read(3)?],
    })
}

/// Primary-ray AOVs from the finished level-0 wave.
pub(super) fn read_aov(f: &Frame, scene: &Scene, w: u32, h: u32) -> Result<Aov> {
    let s = read_state(f)?;
    let mut pixels = vec![AovPixel::miss(0.0); (w * h) as usize];
    pixels
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(j, out)| {
            let row = (h as usize - 1 - j) * w as usize;
            for (i, px) in out.iter_mut().enumerate() {
                let k = row + i;
                let hit = RayState::from_code(s.get(k, ray::STATE)) == Some(RayState::Shading);
                let best = hit.then(|| (s.get(k, ray::T_BEST), s.get(k, ray::TRI_BEST)));
                *px = aov_pixel(scene, best, s.get(k, ray::STEPS));
            }
        });
    Ok(Aov::from_vec(w, h, pixels))
}

/// Traces the wave of `rays` with `kernel` (the fragment side of `trace_rays`).
pub(crate) fn trace_wave(
    gs: &GpuScene,
    rays: &[GpuRay],
    query: Query,
    kernel: FragmentKernel,
    opts: &GpuOptions,
) -> Result<Vec<GpuTrace>> {
    let n = rays.len() as u32;
    let (w, h) = wave_size(n);
    let mut f = Frame::new(gs, w, h, 1, false, kernel, opts, opts.techniques)?;
    let s = initial_state(rays, (w * h) as usize);
    for (tex, data) in f.state[f.cur].textures().iter().zip(&s.texels) {
        tex.upload(f.gl(), data)?;
    }
    f.trace(query)?;
    Ok(traces_from(&read_state(&f)?, rays.len()))
}
