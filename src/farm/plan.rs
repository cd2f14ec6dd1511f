//! What one `render` process does when it renders parts: from `--tile`, `--region` or
//! `--task-index` (with `--tiles`), the units of work it owns and the file each one goes
//! to. Built before the scene is loaded, so a bad flag or output name costs no render.

use std::path::PathBuf;

use super::task::{resolve, units_of, TaskIndex, TaskSource, Unit};
use super::template::OutputTemplate;
use crate::image_io::Format;
use crate::region::{Region, TileSpec, Tiling};
use crate::{Error, Result};

/// The flags that cut the render into parts, as `render` takes them (flattened into its
/// arguments).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct PartArgs {
    /// Render part I of the image cut into N parts (a grid chosen for the image; I/CxR
    /// for C columns by R rows), 0-based from the top left, as an OpenEXR part for
    /// `fragtrace merge` (-o PART.exr). Each pixel is bit-identical to the whole render's.
    #[arg(long, conflicts_with_all = ["region", "task_index"])]
    pub tile: Option<TileSpec>,
    /// Render only the pixels x0..x1, y0..y1 (x1, y1 exclusive; origin top left) of the
    /// image: a part for `fragtrace merge` as .exr, a crop as .png.
    #[arg(long, value_name = "X0,Y0,X1,Y1", conflicts_with = "task_index")]
    pub region: Option<Region>,
    /// Take this task's share of the work from the scheduler: env (a Slurm job array,
    /// SLURM_ARRAY_TASK_ID), env:N (a Kubernetes Indexed Job of N completions,
    /// JOB_COMPLETION_INDEX) or I/N. The image is cut into --tiles parts (default: one per
    /// task); -o names each part with {tile} (docs/distributed.md).
    #[arg(long, value_name = "env|env:N|I/N")]
    pub task_index: Option<TaskSource>,
    /// With --task-index: the parts the image is cut into, N or CxR (default: as many as
    /// there are tasks).
    #[arg(long, value_name = "N|CxR", requires = "task_index")]
    pub tiles: Option<Tiling>,
    /// Skip the images and parts this command would write that already exist whole (a part
    /// of this scene, frame and region; an image that decodes to its size): an
    /// interrupted range continues, a truncated file is rendered again.
    #[arg(long)]
    pub resume: bool,
    /// Render nothing: say which of the files this command would write exist whole and
    /// which are missing (with --task-index 0/1 and --tiles N: every part of the job).
    /// Exit 0 when all exist, 1 when some are missing (--resume is then ignored).
    #[arg(long)]
    pub check: bool,
}

impl PartArgs {
    /// True when these flags ask for parts (or a share of an animation's frames) rather
    /// than whole images in one process (`--resume` and `--check` apply to either).
    pub fn wanted(&self) -> bool {
        self.tile.is_some() || self.region.is_some() || self.task_index.is_some()
    }
}

/// How the image is cut.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cut {
    /// A tiling; units name their tile.
    Tiles(Tiling),
    /// One explicit region (`--region`).
    Region(Region),
}

/// The parts one process renders.
#[derive(Clone, Debug)]
pub struct PartPlan {
    /// How the image is cut.
    pub cut: Cut,
    /// This task, when the work came from `--task-index`.
    pub task: Option<TaskIndex>,
    /// The units this process renders, in order.
    pub units: Vec<Unit>,
    /// One output file per unit.
    pub outputs: Vec<PathBuf>,
    /// One statistics file per unit, with `--stats`.
    pub stats: Vec<PathBuf>,
    /// The frames of the whole job (every task's), for an animation: the parts say
    /// which frames a complete set covers.
    pub frames: Option<Vec<u32>>,
}

impl PartPlan {
    /// Keeps only the units `keep` says yes to (with their files).
    pub fn retain(&mut self, keep: &[bool]) {
        let pick = |v: &mut Vec<PathBuf>| {
            if !v.is_empty() {
                let mut k = keep.iter();
                v.retain(|_| *k.next().unwrap_or(&true));
            }
        };
        pick(&mut self.outputs);
        pick(&mut self.stats);
        let mut k = keep.iter();
        self.units.retain(|_| *k.next().unwrap_or(&true));
    }

    /// The plan for `args` writing to `output` (and statistics to `stats`), or None when
    /// they ask for the whole image in one process. `frames` are the animation's frames
    /// (`--frames`, resolved against the scene's camera path), None for a still; `var`
    /// reads the environment (`--task-index env`).
    pub fn new(
        args: &PartArgs,
        output: &std::path::Path,
        stats: Option<&std::path::Path>,
        frames: Option<&[u32]>,
        var: impl Fn(&str) -> Option<String>,
    ) -> Result<Option<PartPlan>> {
        // Every frame of the range, for the one part --tile or --region names.
        let each_frame = |tile: u32| -> Vec<Unit> {
            match frames {
                None => vec![Unit { frame: None, tile }],
                Some(f) => f
                    .iter()
                    .map(|&f| Unit {
                        frame: Some(f),
                        tile,
                    })
                    .collect(),
            }
        };
        let (cut, task, units) = match (&args.tile, &args.region, &args.task_index) {
            (None, None, None) => return Ok(None),
            (Some(t), _, _) => (Cut::Tiles(t.tiling), None, each_frame(t.index)),
            (None, Some(r), _) => (Cut::Region(*r), None, each_frame(0)),
            (None, None, Some(src)) => {
                let task = resolve(*src, var)?;
                // A still: one tile per task; an animation: whole frames, unless --tiles.
                let tiling = args.tiles.unwrap_or(match frames {
                    None => Tiling::Count(task.count),
                    Some(_) => Tiling::Count(1),
                });
                let units = units_of(&task, frames, tiling.count())?;
                (Cut::Tiles(tiling), Some(task), units)
            }
        };
        let template = OutputTemplate::new(output)?;
        let format = Format::from_path(output)?;
        let tiles = match cut {
            Cut::Tiles(t) => t.count(),
            Cut::Region(_) => 1,
        };
        let flag = match (&args.tile, &args.region) {
            (Some(_), _) => "--tile",
            (_, Some(_)) => "--region",
            _ => "--task-index",
        };
        // Parts are OpenEXR; whole frames (one tile of a task's share) are finished images
        // in either format, and a --region may be a PNG crop.
        if format != Format::Exr && (tiles > 1 || args.tile.is_some()) {
            return Err(Error::Usage(format!(
                "{}: {flag} writes parts for `fragtrace merge`, which are OpenEXR: name the output .exr (e.g. parts/part-{{tile}}.exr)",
                output.display()
            )));
        }
        if tiles > 1 && args.tile.is_none() && !template.has_tile() {
            return Err(Error::Usage(format!(
                "{}: the image is cut into {tiles} parts, so each needs its own file: put {{tile}} in the output name (e.g. parts/part-{{tile}}.exr)",
                output.display()
            )));
        }
        if frames.is_some_and(|f| f.len() > 1) && !template.has_frame() {
            return Err(Error::Usage(format!(
                "{}: the frames need a file each: put a run of # for the frame number in the output's file name (e.g. frames/frame_####.png, parts/f####-{{tile}}.exr)",
                output.display()
            )));
        }
        let tile_of = |u: &Unit| match cut {
            Cut::Tiles(t) => Some((u.tile, t.count())),
            Cut::Region(_) => None,
        };
        let outputs = units
            .iter()
            .map(|u| template.path(u.frame, tile_of(u)))
            .collect();
        let stats = match stats {
            None => Vec::new(),
            Some(p) => {
                let t = OutputTemplate::new(p)?;
                let paths: Vec<PathBuf> =
                    units.iter().map(|u| t.path(u.frame, tile_of(u))).collect();
                let mut sorted = paths.clone();
                sorted.sort();
                sorted.dedup();
                if sorted.len() < paths.len() {
                    return Err(Error::Usage(format!(
                        "{}: this task renders {} parts; name their statistics like the images ({{tile}}, a run of # for the frame)",
                        p.display(),
                        units.len()
                    )));
                }
                paths
            }
        };
        Ok(Some(PartPlan {
            cut,
            task,
            units,
            outputs,
            stats,
            frames: frames.map(<[u32]>::to_vec),
        }))
    }

    /// The region unit `k` covers in a `width` x `height` image.
    pub fn region(&self, k: usize, width: u32, height: u32) -> Result<Region> {
        match self.cut {
            Cut::Tiles(t) => t.tile(self.units[k].tile, width, height),
            Cut::Region(r) => Ok(r),
        }
    }

    /// `I/N` of unit `k` for the part header, when the image is tiled.
    pub fn tile_label(&self, k: usize) -> Option<String> {
        match self.cut {
            Cut::Tiles(t) => Some(format!("{}/{t}", self.units[k].tile)),
            Cut::Region(_) => None,
        }
    }
}
