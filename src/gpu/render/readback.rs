//! Reading results back to the host: the image, the primary-ray AOVs, and the final ray
//! states of [`trace_rays`], all through the field declarations of
//! [`contract`](crate::gpu::contract).

use super::frame::Frame;
use crate::accel::AccelRef;
use crate::gpu::context::GlContext;
use crate::gpu::contract::{ray, StateTexels, TRI_NONE, TRI_NO_RAY};
use crate::gpu::gl::Texture;
use crate::gpu::options::{GpuOptions, Kernel};
use crate::gpu::shader::{Query, RayState};
use crate::output::{Aov, AovPixel};
use crate::scene::Scene;
use crate::{Error, Result};
use rayon::prelude::*;

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

/// One primary ray's AOV pixel: its hit (t, triangle) if any and its traversal steps.
pub(super) fn aov_pixel(scene: &Scene, hit: Option<(f32, f32)>, steps: f32) -> AovPixel {
    match hit {
        Some((t, tri)) => {
            let v = scene.triangle_vertices(tri as usize);
            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
            AovPixel {
                depth: t,
                primid: tri,
                normal: n.to_array(),
                steps,
            }
        }
        None => AovPixel::miss(steps),
    }
}

/// One ray for [`trace_rays`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuRay {
    /// Origin.
    pub o: glam::Vec3,
    /// Direction (need not be unit length, must not be zero).
    pub d: glam::Vec3,
    /// Upper end of the open interval (0, t_max).
    pub t_max: f32,
}

/// What [`trace_rays`] found for one ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuTrace {
    /// (t, triangle) of the hit; for [`Query::Any`] the first hit found.
    pub hit: Option<(f32, u32)>,
    /// Final ray state.
    pub state: RayState,
    /// Cells visited plus triangle tests.
    pub steps: f32,
}

/// Traces arbitrary rays through the same traversal and intersection passes a render uses:
/// how tests put single hand-made rays through the GPU kernel.
pub fn trace_rays<'a>(
    ctx: &GlContext,
    scene: &Scene,
    accel: impl Into<AccelRef<'a>>,
    rays: &[GpuRay],
    query: Query,
    opts: GpuOptions,
) -> Result<Vec<GpuTrace>> {
    if rays.is_empty() {
        return Ok(Vec::new());
    }
    let n = rays.len() as u32;
    let w = n.min(256);
    let h = n.div_ceil(w);
    let accel = accel.into();
    let mut kernel = opts.resolve_kernel(&ctx.info)?;
    if kernel == Kernel::Compute {
        let copts = GpuOptions { kernel, ..opts };
        match trace_rays_compute(ctx, scene, accel, rays, query, &copts, (w, h)) {
            // As in render_gl: `auto` falls back to a fragment kernel where the driver cut
            // the compute kernel's loops short.
            Err(Error::Unfinished(_)) if opts.kernel == Kernel::Auto => {
                kernel = GpuOptions::fallback_kernel(&ctx.info);
            }
            r => return r,
        }
    }
    let opts = GpuOptions { kernel, ..opts };
    let mut f = Frame::new(ctx, scene, accel, w, h, 1, false, opts)?;
    let s = initial_state(rays, (w * h) as usize);
    for (tex, data) in f.state[f.cur].textures().iter().zip(&s.texels) {
        tex.upload(ctx.gl(), data)?;
    }
    f.trace(query)?;
    Ok(traces_from(&read_state(&f)?, rays.len()))
}

/// The initial ray-state texels of a wave of `rays` padded with finished non-rays to
/// `texels`.
fn initial_state(rays: &[GpuRay], texels: usize) -> StateTexels {
    let mut s = StateTexels {
        texels: std::array::from_fn(|_| vec![0f32; texels * 4]),
    };
    for k in 0..texels {
        match rays.get(k) {
            Some(r) => {
                s.set(k, ray::ORIGIN, &r.o.to_array());
                s.set(k, ray::STATE, &[RayState::Initial.code()]);
                s.set(k, ray::DIR, &r.d.to_array());
                s.set(k, ray::T_MAX, &[r.t_max]);
                s.set(k, ray::T_BEST, &[r.t_max]);
                s.set(k, ray::TRI_BEST, &[TRI_NONE]);
            }
            None => {
                s.set(k, ray::STATE, &[RayState::Done.code()]);
                s.set(k, ray::DIR, &[0.0, 0.0, 1.0]);
                s.set(k, ray::TRI_BEST, &[TRI_NO_RAY]);
            }
        }
    }
    s
}

/// [`trace_rays`] with the compute kernel: the wave in four textures, `wave.comp` over them.
fn trace_rays_compute(
    ctx: &GlContext,
    scene: &Scene,
    accel: AccelRef<'_>,
    rays: &[GpuRay],
    query: Query,
    opts: &GpuOptions,
    (w, h): (u32, u32),
) -> Result<Vec<GpuTrace>> {
    let s = initial_state(rays, (w * h) as usize);
    let textures = s
        .texels
        .iter()
        .map(|data| Texture::new_f32(ctx, w, h, Some(data)))
        .collect::<Result<Vec<_>>>()?;
    super::compute::trace_wave(ctx, scene, accel, &textures, (w, h), query, opts)?;
    let read = |k: usize| textures[k].read(ctx.gl());
    let s = StateTexels {
        texels: [read(0)?, Vec::new(), Vec::new(), read(3)?],
    };
    let out = traces_from(&s, rays.len());
    if let Some(k) = out
        .iter()
        .position(|t| matches!(t.state, RayState::Traversing | RayState::Testing))
    {
        return Err(Error::Unfinished(format!(
            "the walk of ray {k} was cut off in state {:?} (a traversal bug, or the driver's \
             limit on loop iterations: llvmpipe's is 65535)",
            out[k].state
        )));
    }
    Ok(out)
}

/// The results of the first `n` rays of a finished wave.
fn traces_from(s: &StateTexels, n: usize) -> Vec<GpuTrace> {
    (0..n)
        .map(|k| {
            let state = RayState::from_code(s.get(k, ray::STATE)).unwrap_or(RayState::Done);
            GpuTrace {
                hit: (state == RayState::Shading)
                    .then(|| (s.get(k, ray::T_BEST), s.get(k, ray::TRI_BEST) as u32)),
                state,
                steps: s.get(k, ray::STEPS),
            }
        })
        .collect()
}
