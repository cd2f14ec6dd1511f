//! Beyond one machine: an image or an animation rendered as many tasks of a batch
//! scheduler (Slurm job arrays, Kubernetes Indexed Jobs), each writing parts that
//! `fragtrace merge` assembles. fragtrace does not schedule anything itself: it renders the
//! share of the work its task index names and checks what comes back (docs/distributed.md).
//!
//! - [`task`]: the task index from the scheduler's environment, and the units of work
//!   (frames x tiles) a task does.
//! - [`part`]: part files (OpenEXR with a data window inside the display window, and a
//!   header naming scene, options and their hash); [`hash`] is that hash.
//! - [`merge`]: parts back into whole images, refusing gaps, overlaps and mismatches.
//! - [`plan`]: what one process renders (its units and their files), from the flags.
//! - [`template`]: `{tile}` and the frame's run of `#` in output names.
//!
//! Regions themselves ([`crate::region`]) sit at the bottom of the layers, for the
//! renderers; this module sits above [`crate::render`] and below the CLI.

pub mod hash;
pub mod merge;
pub mod part;
pub mod plan;
pub mod task;
pub mod template;

use crate::options::RenderOptions;
use crate::render::RenderStats;

/// The options that decide a render's pixels, as canonical flags with every `auto`
/// resolved to what ran (`--backend auto` may be the GPU on one node and the CPU on
/// another; their parts must not be merged as one image). Flags that only change how fast
/// or how visibly a render runs (`--query-every`, `--gpu`, `-q`, `--stats`) are left
/// out, and GPU settings are left out of CPU renders.
pub fn options_line(opts: &RenderOptions, stats: &RenderStats) -> String {
    let mut s = format!(
        "--width {} --height {} --spp {} --max-depth {} --backend {} --precision {} --accel {}",
        opts.width,
        opts.height,
        opts.spp,
        opts.max_depth,
        stats.backend,
        stats.precision,
        opts.accel.name()
    );
    match opts.accel {
        crate::accel::AccelKind::Uniform => {
            s += &format!(
                " --grid {} --grid-density {:?}",
                opts.grid.res, opts.grid.density
            )
        }
        crate::accel::AccelKind::Irregular => {
            s += &format!(
                " --grid-density {:?} --leaf-max {}",
                opts.irregular.top_density, opts.irregular.leaf_max
            )
        }
        crate::accel::AccelKind::Bvh => {}
    }
    s += &format!(" --techniques {}", opts.techniques.tag());
    if let Some(g) = &stats.gpu {
        use crate::gpu::options::{FragmentKernel, Kernel};
        // The mask a fragment kernel ran with (`auto` resolved as Mask::resolve does);
        // the compute kernel has none.
        let fragment = match g.kernel.parse::<Kernel>() {
            Ok(Kernel::Multipass) => Some(FragmentKernel::Multipass),
            Ok(Kernel::Looped) => Some(FragmentKernel::Looped),
            Ok(Kernel::Unrolled(k)) => Some(FragmentKernel::Unrolled(k)),
            _ => None,
        };
        s += &format!(" --kernel {} --scene-fetch {}", g.kernel, g.scene_fetch);
        if let Some(k) = fragment {
            s += &format!(" --mask {}", opts.gpu.mask.resolve(k));
        }
        s += &format!(
            " --storage {} --specialize {}",
            opts.gpu.storage,
            if opts.gpu.no_specialize { "no" } else { "yes" }
        );
    }
    s
}

/// Writes one rendered unit: as a part (OpenEXR with its data window and header) to a
/// `.exr` path, or as a plain crop of the region to a `.png` path (`--region`).
pub fn write_unit(
    path: &std::path::Path,
    scene: &crate::scene::Scene,
    opts: &RenderOptions,
    out: &crate::render::Rendered,
    frame: Option<u32>,
    tile: Option<String>,
) -> crate::Result<()> {
    use crate::image_io::{write_image, Format};
    match Format::from_path(path)? {
        Format::Exr => {
            let header = part::PartHeader {
                scene: scene.source.clone(),
                scene_hash: hash::scene_hash(scene),
                options: options_line(opts, &out.stats),
                frame,
                width: opts.width,
                height: opts.height,
                region: opts.pixels(),
                device: out.stats.device.clone(),
                tile,
            };
            part::write_part(
                path,
                &part::Part {
                    header,
                    image: out.image.clone(),
                },
            )
        }
        // PNG, and the other formats the output's extension can name.
        _ => write_image(path, &out.image),
    }
}
