//! What one `render` process does when it renders parts: from `--tile`, `--region` or
//! `--task-index` (with `--tiles`), the units of work it owns and the file each one goes
//! to. Built before the scene is loaded, so a bad flag or output name costs no render.

use std::path::PathBuf;

use super::task::{resolve, units_of, TaskIndex, Unit};
use super::template::OutputTemplate;
use crate::image_io::Format;
use crate::options::RenderArgs;
use crate::region::{Region, Tiling};
use crate::{Error, Result};

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
pub struct Plan {
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
}

impl Plan {
    /// The plan for `args`, or None when they ask for the whole image in one process.
    /// `var` reads the environment (for `--task-index env`).
    pub fn new(args: &RenderArgs, var: impl Fn(&str) -> Option<String>) -> Result<Option<Plan>> {
        let (cut, task, units) = match (&args.tile, &args.region, &args.task_index) {
            (None, None, None) => return Ok(None),
            (Some(t), _, _) => (
                Cut::Tiles(t.tiling),
                None,
                vec![Unit {
                    frame: None,
                    tile: t.index,
                }],
            ),
            (None, Some(r), _) => (
                Cut::Region(*r),
                None,
                vec![Unit {
                    frame: None,
                    tile: 0,
                }],
            ),
            (None, None, Some(src)) => {
                let task = resolve(*src, var)?;
                let tiling = args.tiles.unwrap_or(Tiling::Count(task.count));
                let units = units_of(&task, None, tiling.count())?;
                (Cut::Tiles(tiling), Some(task), units)
            }
        };
        let template = OutputTemplate::new(&args.output);
        let format = Format::from_path(&args.output)?;
        let tiles = match cut {
            Cut::Tiles(t) => t.count(),
            Cut::Region(_) => 1,
        };
        let flag = match (&args.tile, &args.region) {
            (Some(_), _) => "--tile",
            (_, Some(_)) => "--region",
            _ => "--task-index",
        };
        if format != Format::Exr && matches!(cut, Cut::Tiles(_)) {
            return Err(Error::Usage(format!(
                "{}: {flag} writes parts for `fragtrace merge`, which are OpenEXR: name the output .exr (e.g. parts/part-{{tile}}.exr)",
                args.output.display()
            )));
        }
        if tiles > 1 && args.tile.is_none() && !template.has_tile() {
            return Err(Error::Usage(format!(
                "{}: the image is cut into {tiles} parts, so each needs its own file: put {{tile}} in the output name (e.g. parts/part-{{tile}}.exr)",
                args.output.display()
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
        let stats = match &args.stats {
            None => Vec::new(),
            Some(p) => {
                let t = OutputTemplate::new(p);
                if units.len() > 1 && !t.has_tile() {
                    return Err(Error::Usage(format!(
                        "{}: this task renders {} parts; put {{tile}} in the --stats name too",
                        p.display(),
                        units.len()
                    )));
                }
                units.iter().map(|u| t.path(u.frame, tile_of(u))).collect()
            }
        };
        Ok(Some(Plan {
            cut,
            task,
            units,
            outputs,
            stats,
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
