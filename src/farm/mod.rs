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
pub mod summary;
pub mod task;
pub mod template;

use std::fmt;
use std::str::FromStr;

use crate::accel::{AccelKind, GridRes};
use crate::options::RenderOptions;
use crate::plan::{flag_pairs, Plan};
use crate::render::RenderStats;
use crate::technique::Techniques;

/// The options that decide a render's pixels, as a part header carries them: the size,
/// samples and depth, the render's [`Plan`] (every `auto` resolved to what ran: `--backend
/// auto` may be the GPU on one node and the CPU on another; their parts must not be merged
/// as one image), the structure's parameters, the techniques and, on the GPU, whether the
/// programs were specialised. Flags that only change how fast or how visibly a render runs
/// (`--query-every`, `--gpu`, `-q`, `--stats`) are left out.
///
/// Written by one [`Display`](std::fmt::Display) and read back by one
/// [`FromStr`] over the same flag names (the plan's by the plan's own),
/// so `merge` compares what `render` wrote with the code that wrote it.
#[derive(Clone, Debug, PartialEq)]
pub struct PartOptions {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Maximum recursion depth.
    pub max_depth: u32,
    /// What ran.
    pub plan: Plan,
    /// The parameters of the structure the plan names.
    pub structure: StructureParams,
    /// The robustness techniques.
    pub techniques: Techniques,
    /// GPU plans: whether the programs were specialised to the scene; None on the CPU.
    pub specialize: Option<bool>,
}

/// The build parameters of a part's structure ([`PartOptions::structure`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StructureParams {
    /// The uniform grid's resolution choice and density.
    Uniform {
        /// `--grid`.
        res: GridRes,
        /// `--grid-density` (lambda).
        density: f32,
    },
    /// The irregular grid's top density and leaf size.
    Irregular {
        /// `--grid-density` (top cells per triangle).
        top_density: f32,
        /// `--leaf-max`.
        leaf_max: u32,
    },
    /// The BVH: nothing to set.
    Bvh,
}

impl PartOptions {
    /// The pixel-deciding options of a render of `opts` that ran `plan`.
    pub fn of(opts: &RenderOptions, plan: Plan) -> PartOptions {
        PartOptions {
            width: opts.width,
            height: opts.height,
            spp: opts.spp,
            max_depth: opts.max_depth,
            plan,
            structure: match plan.accel() {
                AccelKind::Uniform => StructureParams::Uniform {
                    res: opts.grid.res,
                    density: opts.grid.density,
                },
                AccelKind::Irregular => StructureParams::Irregular {
                    top_density: opts.irregular.top_density,
                    leaf_max: opts.irregular.leaf_max,
                },
                AccelKind::Bvh => StructureParams::Bvh,
            },
            techniques: opts.techniques,
            specialize: plan.kernel().map(|_| !opts.gpu.no_specialize),
        }
    }
}

/// `--width W --height H --spp S --max-depth D`, the plan, the structure's parameters
/// (`--grid R --grid-density L`, `--grid-density L --leaf-max N`, or none for the BVH),
/// `--techniques TAG` and on the GPU `--specialize yes|no`. Floats are written so that they
/// read back to the same value.
impl fmt::Display for PartOptions {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "--width {} --height {} --spp {} --max-depth {} {}",
            self.width, self.height, self.spp, self.max_depth, self.plan
        )?;
        match self.structure {
            StructureParams::Uniform { res, density } => {
                write!(f, " --grid {res} --grid-density {density:?}")?
            }
            StructureParams::Irregular {
                top_density,
                leaf_max,
            } => write!(f, " --grid-density {top_density:?} --leaf-max {leaf_max}")?,
            StructureParams::Bvh => {}
        }
        write!(f, " --techniques {}", self.techniques.tag())?;
        if let Some(s) = self.specialize {
            write!(f, " --specialize {}", if s { "yes" } else { "no" })?;
        }
        Ok(())
    }
}

impl FromStr for PartOptions {
    type Err = String;

    /// Reads what [`Display`](fmt::Display) writes, every flag once and no other.
    fn from_str(s: &str) -> std::result::Result<PartOptions, String> {
        let mut pairs = flag_pairs(s)?;
        let (width, height) = (pairs.parse("width")?, pairs.parse("height")?);
        let (spp, max_depth) = (pairs.parse("spp")?, pairs.parse("max-depth")?);
        let plan = Plan::from_pairs(&mut pairs)?;
        let structure = match plan.accel() {
            AccelKind::Uniform => StructureParams::Uniform {
                res: pairs.parse("grid")?,
                density: pairs.parse("grid-density")?,
            },
            AccelKind::Irregular => StructureParams::Irregular {
                top_density: pairs.parse("grid-density")?,
                leaf_max: pairs.parse("leaf-max")?,
            },
            AccelKind::Bvh => StructureParams::Bvh,
        };
        let techniques = pairs.parse("techniques")?;
        let specialize = match plan.kernel() {
            None => None,
            Some(_) => Some(match pairs.take("specialize")? {
                "yes" => true,
                "no" => false,
                v => return Err(format!("--specialize {v}: expected yes or no")),
            }),
        };
        pairs.finish()?;
        Ok(PartOptions {
            width,
            height,
            spp,
            max_depth,
            plan,
            structure,
            techniques,
            specialize,
        })
    }
}

/// A part header's options line ([`PartOptions`]'s text) for a render of `opts` whose
/// statistics are `stats`.
pub fn options_line(opts: &RenderOptions, stats: &RenderStats) -> String {
    PartOptions::of(opts, stats.plan).to_string()
}

/// The plan in a part's options line ([`PartOptions`], read back), or None where the line
/// is not one (a part from another version).
pub fn plan_of(options: &str) -> Option<Plan> {
    options.parse::<PartOptions>().ok().map(|o| o.plan)
}

/// This node's name, as a part records it: Slurm's for the node, else the kernel's.
fn host() -> Option<String> {
    std::env::var("SLURMD_NODENAME")
        .ok()
        .or_else(|| std::fs::read_to_string("/proc/sys/kernel/hostname").ok())
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
}

/// Writes unit `k` of `plan`, rendered as `out`, to its file: as a part (OpenEXR with its
/// data window and a header naming its frame, tile, the job's frames and the task) to a
/// `.exr` path, or as a plain crop of the region to a `.png` path (`--region`).
pub fn write_unit(
    scene: &crate::scene::Scene,
    opts: &RenderOptions,
    out: &crate::render::Rendered,
    plan: &plan::PartPlan,
    k: usize,
) -> crate::Result<()> {
    use crate::image_io::{write_image, Format};
    let path = &plan.outputs[k];
    let (frame, tile, frames, task) = (
        plan.units[k].frame,
        plan.tile_label(k),
        plan.frames.as_deref(),
        plan.task.as_ref(),
    );
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
                provenance: part::Provenance {
                    task: task.map(|t| format!("{}/{}", t.index, t.count)),
                    host: host(),
                    render_ms: Some(out.stats.render_ms.round() as u64),
                    task_ms: Some(crate::clock::since_start_ms()),
                },
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

    /// The plan a part header carries reads back as the plan that was written; a line
    /// that is not a whole header has none.
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

    /// Every field of a part header's options is written by the one `Display` and read
    /// back by its `FromStr`: size, samples, depth, plan, each structure's parameters,
    /// the techniques and the specialisation (before, only the plan was read back; the
    /// rest was written by hand and compared as text). The text is the one earlier
    /// versions wrote, so their parts still merge with these.
    #[test]
    fn part_options_round_trip_through_their_text() {
        use crate::gpu::options::{FragmentKernel, Mask, SceneFetch, Storage};
        use crate::options::{CpuPath, Precision};
        use crate::technique::{OffsetMethod, TBound};
        let scene = crate::scene::builtin_scene();
        let mut opts = RenderOptions::for_scene(&scene);
        opts.width = 48;
        opts.height = 36;
        opts.spp = 4;
        opts.max_depth = 3;
        opts.grid.res = GridRes::Fixed([4, 5, 6]);
        opts.grid.density = 2.5;
        opts.irregular.top_density = 0.1;
        opts.irregular.leaf_max = 9;
        opts.gpu.no_specialize = true;
        opts.techniques = Techniques::default()
            .with_t_bound(TBound::Off)
            .with_offset(OffsetMethod::Epsilon);
        let plans = [
            Plan::Cpu {
                accel: AccelKind::Bvh,
                precision: Precision::F64,
                path: CpuPath::Scalar,
            },
            Plan::Cpu {
                accel: AccelKind::Irregular,
                precision: Precision::F32,
                path: CpuPath::Packet,
            },
            Plan::Fragment {
                accel: AccelKind::Uniform,
                kernel: FragmentKernel::Looped,
                mask: Mask::Stencil,
                storage: Storage::F16,
            },
            Plan::Compute {
                accel: AccelKind::Irregular,
                scene_fetch: SceneFetch::Auto,
                fallback: Some(FragmentKernel::Multipass),
            },
        ];
        for plan in plans {
            let o = PartOptions::of(&opts, plan);
            let text = o.to_string();
            assert_eq!(text.parse::<PartOptions>(), Ok(o.clone()), "{text}");
            assert_eq!(o.specialize, plan.kernel().map(|_| false));
        }
        // The text earlier versions wrote by hand, field for field.
        let o = PartOptions::of(&opts, plans[2]);
        assert_eq!(
            o.to_string(),
            "--width 48 --height 36 --spp 4 --max-depth 3 --backend gl --accel uniform \
             --kernel looped --mask stencil --storage f16 --grid 4x5x6 --grid-density 2.5 \
             --techniques t-bound-off+offset-epsilon --specialize no"
        );
        let irr = PartOptions::of(&opts, plans[1]).to_string();
        assert!(
            irr.ends_with(
                "--grid-density 0.1 --leaf-max 9 --techniques t-bound-off+offset-epsilon"
            ),
            "{irr}"
        );
        // Lines that are not one: a flag missing, one too many, a value misspelt.
        let good = o.to_string();
        for bad in [
            good.replace(" --specialize no", ""),
            good.clone() + " --leaf-max 8",
            good.replace("4x5x6", "4x5"),
            good.replace("t-bound-off+offset-epsilon", "offset-epsilon+t-bound-off"),
            good.replace("--spp 4", "--spp four"),
        ] {
            assert!(bad.parse::<PartOptions>().is_err(), "{bad}");
        }
    }
}
