//! The passes a scene needs: which of [`Pass::ALL`] (plus the chosen kernel's advancing
//! pass) a render with this scene, depth and kernel draws. The GPU scene compiles them on
//! first use (`gpu::scene`).

use crate::gpu::options::FragmentKernel;
use crate::gpu::shader::{Count, Pass, Query};
use crate::scene::Scene;

/// The passes a render of `scene` with `levels` tree levels draws (all shading passes when
/// `shading`; only traversal for `trace_rays`).
pub(super) fn passes_for(
    scene: &Scene,
    levels: usize,
    shading: bool,
    kernel: FragmentKernel,
) -> Vec<Pass> {
    let secondary = levels > 1 && scene.materials.iter().any(|m| m.reflects() || m.refracts());
    let lights = !scene.lights.is_empty();
    Pass::ALL
        .into_iter()
        .filter(|p| match p {
            Pass::Intersect(Query::Any) => {
                (lights || !shading) && kernel == FragmentKernel::Multipass
            }
            Pass::ShadowSpawn | Pass::AccumLight => shading && lights,
            Pass::Weight | Pass::Spawn | Pass::Count(Count::Nodes) => shading && secondary,
            Pass::RayGen | Pass::Record | Pass::AccumAmbient => shading,
            Pass::TraverseInit | Pass::Count(Count::Rays) => true,
            Pass::TraverseStep | Pass::Intersect(Query::Closest) => {
                kernel == FragmentKernel::Multipass
            }
            // Not in Pass::ALL: the chosen kernel's pass is added below.
            Pass::Unrolled(..) | Pass::Looped(_) => false,
            // Compiled when an image is read back as 8-bit sRGB (`readback`).
            Pass::Srgb8 => false,
        })
        .chain(
            [Query::Closest, Query::Any]
                .into_iter()
                .filter(|q| *q == Query::Closest || lights || !shading)
                .filter_map(|q| Pass::advance(kernel, q)),
        )
        .collect()
}
