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
//! - [`resume`]: whether a file a render would write exists whole (`--resume`, `--check`).
//!
//! Regions themselves ([`crate::region`]) sit at the bottom of the layers, for the
//! renderers; this module sits above [`crate::render`] and below the CLI.

pub mod hash;
pub mod merge;
pub mod part;
pub mod plan;
pub mod resume;
pub mod task;
pub mod template;

use crate::options::RenderOptions;
use crate::render::RenderStats;

/// The options that decide a render's pixels, as canonical flags: the size, samples and
/// depth, the render's [`Plan`](crate::plan::Plan) (every `auto` resolved to what ran:
/// `--backend auto` may be the GPU on one node and the CPU on another; their parts must
/// not be merged as one image), the structure's parameters and the techniques. Flags that
/// only change how fast or how visibly a render runs (`--query-every`, `--gpu`, `-q`,
/// `--stats`) are left out.
pub fn options_line(opts: &RenderOptions, stats: &RenderStats) -> String {
    let plan = stats.plan;
    let mut s = format!(
        "--width {} --height {} --spp {} --max-depth {} {plan}",
        opts.width, opts.height, opts.spp, opts.max_depth,
    );
    match plan.accel() {
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
    if plan.kernel().is_some() {
        s += &format!(
            " --specialize {}",
            if opts.gpu.no_specialize { "no" } else { "yes" }
        );
    }
    s
}

/// The plan in a part's options line ([`options_line`]): the words after the size, samples
/// and depth, up to the structure's parameters, read by [`Plan`](crate::plan::Plan)'s
/// `FromStr`. None where the line holds no plan (a part from another version).
pub fn plan_of(options: &str) -> Option<crate::plan::Plan> {
    let words: Vec<&str> = options.split_whitespace().collect();
    let start = words.iter().position(|w| *w == "--backend")?;
    let end = words[start..]
        .chunks(2)
        .position(|p| matches!(p[0], "--grid" | "--grid-density" | "--techniques"))
        .map_or(words.len(), |k| start + 2 * k);
    words[start..end].join(" ").parse().ok()
}

/// Writes one rendered unit: as a part (OpenEXR with its data window and header) to a
/// `.exr` path, or as a plain crop of the region to a `.png` path (`--region`); `frames`
/// are the job's frames, for a part of an animation.
pub fn write_unit(
    path: &std::path::Path,
    scene: &crate::scene::Scene,
    opts: &RenderOptions,
    out: &crate::render::Rendered,
    frame: Option<u32>,
    tile: Option<String>,
    frames: Option<&[u32]>,
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
                frames: frames.map(part::frames_text),
                version: part::VERSION.to_string(),
            };
            part::write_pixels(path, &header, &out.image)
        }
        // PNG, and the other formats the output's extension can name.
        _ => write_image(path, &out.image),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Plan;

    /// The plan a part header carries reads back as the plan that was written, between the
    /// size flags before it and the structure's parameters after it; a line without one
    /// has none.
    #[test]
    fn the_plan_reads_back_from_a_part_header() {
        let plan = Plan::Fragment {
            accel: crate::accel::AccelKind::Uniform,
            kernel: crate::gpu::options::FragmentKernel::Unrolled(4),
            mask: crate::gpu::options::Mask::EarlyZ,
            storage: crate::gpu::options::Storage::F32,
        };
        let line = format!(
            "--width 8 --height 6 --spp 1 --max-depth 5 {plan} --grid auto --grid-density 8.0 \
             --techniques default --specialize yes"
        );
        assert_eq!(plan_of(&line), Some(plan));
        let cpu = "--width 8 --height 6 --spp 1 --max-depth 5 --backend cpu --accel bvh \
                   --precision f64 --cpu-path simd --techniques default";
        assert!(matches!(plan_of(cpu), Some(Plan::Cpu { .. })));
        assert_eq!(plan_of("--width 8 --height 6 --spp 1"), None);
    }
}
