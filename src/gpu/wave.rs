//! Waves of given rays: what `trace_rays` takes ([`GpuRay`]) and returns ([`GpuTrace`]),
//! and the ray-state texels a wave starts from and ends in, through the field declarations
//! of [`contract`](crate::gpu::contract). Both wings trace waves from these texels: the
//! fragment kernels in their ping-pong targets, the compute kernel in four images.

use crate::gpu::contract::{ray, RayState, StateTexels, TRI_NONE, TRI_NO_RAY};
use crate::{Error, Result};

/// One ray for [`trace_rays`](super::render::trace_rays).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuRay {
    /// Origin.
    pub o: glam::Vec3,
    /// Direction (need not be unit length, must not be zero).
    pub d: glam::Vec3,
    /// Upper end of the open interval (0, t_max).
    pub t_max: f32,
}

/// What [`trace_rays`](super::render::trace_rays) found for one ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuTrace {
    /// (t, triangle) of the hit; for [`Query::Any`](crate::gpu::shader::Query::Any) the first hit found.
    pub hit: Option<(f32, u32)>,
    /// Final ray state.
    pub state: RayState,
    /// Cells visited plus triangle tests.
    pub steps: f32,
}

/// The initial ray-state texels of a wave of `rays` padded with finished non-rays to
/// `texels`.
pub(crate) fn initial_state(rays: &[GpuRay], texels: usize) -> StateTexels {
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

/// The results of the first `n` rays of a finished wave.
pub(crate) fn traces_from(s: &StateTexels, n: usize) -> Vec<GpuTrace> {
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

/// An error where a wave's walk was cut off before its end (a traversal bug, or a driver's
/// limit on loop iterations).
pub(crate) fn check_finished(out: &[GpuTrace]) -> Result<()> {
    match out
        .iter()
        .position(|t| matches!(t.state, RayState::Traversing | RayState::Testing))
    {
        Some(k) => Err(Error::Unfinished(format!(
            "the walk of ray {k} was cut off in state {:?} (a traversal bug, or the driver's \
             limit on loop iterations: llvmpipe's is 65535)",
            out[k].state
        ))),
        None => Ok(()),
    }
}

/// The texture size a wave of `n` rays is traced in: rows of 256.
pub(crate) fn wave_size(n: u32) -> (u32, u32) {
    let w = n.clamp(1, 256);
    (w, n.div_ceil(w).max(1))
}
