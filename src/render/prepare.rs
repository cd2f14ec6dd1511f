//! The one front door that builds what a render walks: [`prepare`] checks the options and
//! builds the structure they name (an instanced scene as two levels where the backend walks
//! them, else flat with one warning), refusing before allocation what the machine cannot
//! hold; [`prepare_owned`] does it for a scene it takes (the overlapped start,
//! `crate::overlap`). Split from `render.rs` by job.

use std::borrow::Cow;

use crate::accel::grid_instances::GridInstances;
use crate::accel::{Accel, AccelKind};
use crate::gpu::options::Kernel;
use crate::options::{Backend, RenderOptions};
use crate::scene::Scene;
use crate::Result;

use super::Prepared;

/// Checks `opts` and builds the acceleration structure they name for `scene`.
pub fn prepare<'s>(scene: &'s Scene, opts: &RenderOptions) -> Result<Prepared<'s>> {
    opts.validate()?;
    let kind = opts.accel_kind();
    let gpu = opts.backend == Backend::Gl;
    // The CPU's BVH and every GPU kernel over uniform grids walk instances as two levels
    // (the kernel named: `RenderOptions::on_context` names it where `auto` may take it;
    // a fragment kernel, or `auto` still open as in `view`, whose key switches between
    // every kernel, for what `two_level_blocks` lets through); every other structure takes
    // them flat.
    let any_kernel = opts.fragment_kernel_named() || opts.gpu.kernel == Kernel::Auto;
    let two_level_gpu = gpu
        && kind == AccelKind::Uniform
        && (opts.gpu.kernel == Kernel::Compute
            || (any_kernel && opts.two_level_blocks(true).is_empty()));
    if scene.has_instances() && two_level_gpu {
        // What the GPU stores: the scene's own triangles and each mesh's once.
        let meshes = &scene.instancing.meshes;
        let stored = scene.triangles.len()
            + meshes
                .iter()
                .map(|m| m.geometry.triangles.len())
                .sum::<usize>();
        crate::gpu::layout::check_triangles(stored)?;
        crate::memory::check_build(
            kind,
            stored,
            gpu_layout(opts),
            crate::memory::available_bytes(),
        )?;
        let levels = GridInstances::build(scene, &opts.grid)?;
        let accel = Accel::GridInstanced(Box::new(levels));
        let summary = accel.as_ref().summary(scene.instanced_triangles() as usize);
        return Ok(Prepared {
            scene: Cow::Borrowed(scene),
            accel,
            summary,
            flat: Default::default(),
        });
    }
    prepare_flat(scene, opts, || opts.stored_once_advice())
}

/// The GPU layout the render `opts` asks for packs (what the memory check counts): the
/// compute kernel's dense one where that kernel is named, else the float one (`auto` may
/// render with a fragment kernel).
fn gpu_layout(opts: &RenderOptions) -> crate::memory::GpuLayout {
    use crate::memory::GpuLayout;
    match (opts.backend, opts.gpu.kernel) {
        (Backend::Gl, crate::gpu::options::Kernel::Compute) => GpuLayout::Dense,
        (Backend::Gl, _) => GpuLayout::Float,
        (_, _) => GpuLayout::None,
    }
}

/// [`prepare`] of a structure other than the two levels: an instanced scene is taken flat
/// (but for the CPU's BVH), with one warning line ending in `advice`, what would walk it
/// stored once.
pub(super) fn prepare_flat<'s>(
    scene: &'s Scene,
    opts: &RenderOptions,
    advice: impl FnOnce() -> String,
) -> Result<Prepared<'s>> {
    let kind = opts.accel_kind();
    let gpu = opts.backend == Backend::Gl;
    let scene = if scene.has_instances() && kind != AccelKind::Bvh {
        let why = format!("the {} grid", kind.name());
        let flat = scene.flattened(crate::options::MAX_HOST_BYTES, &why)?;
        eprintln!(
            "fragtrace: warning: {}: {why} stores the {} instances flat ({} triangles, about {:.1} MB more); {}",
            scene.source,
            scene.instancing.instances.len(),
            flat.triangles.len(),
            (flat.triangles.len() - scene.triangles.len()) as f64 * 100.0 / 1e6,
            advice()
        );
        Cow::Owned(flat)
    } else {
        Cow::Borrowed(scene)
    };
    // What the machine cannot hold, refused before the structure is allocated: the GPU's
    // index limit (its layout's), then memory (of the triangles stored, instanced or not).
    if gpu {
        crate::gpu::layout::check_triangles(scene.triangles.len())?;
    }
    crate::memory::check_build(
        kind,
        scene.triangles.len(),
        gpu_layout(opts),
        crate::memory::available_bytes(),
    )?;
    let accel = Accel::build(&scene, kind, &opts.grid, &opts.irregular)?;
    let summary = accel.as_ref().summary(scene.instanced_triangles() as usize);
    Ok(Prepared {
        scene,
        accel,
        summary,
        flat: Default::default(),
    })
}

/// [`prepare`] of a scene it takes, which travels with its structure (from the thread
/// that loaded and built it: [`crate::overlap`]); on an error the scene comes back with it.
#[allow(clippy::result_large_err)]
pub fn prepare_owned(
    scene: Scene,
    opts: &RenderOptions,
) -> std::result::Result<Prepared<'static>, (crate::Error, Scene)> {
    let Prepared {
        scene: taken,
        accel,
        summary,
        flat,
    } = match prepare(&scene, opts) {
        Ok(p) => p,
        Err(e) => return Err((e, scene)),
    };
    let scene = match taken {
        Cow::Owned(flattened) => flattened,
        Cow::Borrowed(_) => scene,
    };
    Ok(Prepared {
        scene: Cow::Owned(scene),
        accel,
        summary,
        flat,
    })
}
