//! `merge --summary`: a job's parts across its tasks, read from the parts' headers: how
//! many units are done and which are missing (by tile and frame, and the task that owed
//! each), one line per task (its parts, its time, its node), and the spread of task times.
//! A job's units and their tasks follow from any part of it: the tiling (`fragtrace.tile`),
//! the frames (`fragtrace.frames`) and the task count (`fragtrace.task`) give every unit
//! and the task it belongs to ([`super::task::units_of`]), so a task that wrote nothing is
//! named too.

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

use super::part::PartHeader;
use super::task::{units_of, TaskIndex, Unit};

/// What the summary found: its lines, and whether every unit is there and readable.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// The report, one line each.
    pub lines: Vec<String>,
    /// Every unit of the job has a readable part, and no file given is unreadable.
    pub complete: bool,
}

/// The summary of `parts`: each file with its header, or why it could not be read.
pub fn summarize(parts: &[(PathBuf, Result<PartHeader, String>)]) -> Summary {
    let mut lines = Vec::new();
    let broken: Vec<String> = parts
        .iter()
        .filter_map(|(p, h)| {
            h.as_ref()
                .err()
                .map(|why| format!("{}: {why}", p.display()))
        })
        .collect();
    let good: Vec<(&PathBuf, &PartHeader)> = parts
        .iter()
        .filter_map(|(p, h)| h.as_ref().ok().map(|h| (p, h)))
        .collect();
    let Some((_, first)) = good.first() else {
        lines.extend(broken.iter().cloned());
        lines.push(format!(
            "no readable part among {} file{}",
            parts.len(),
            plural(parts.len())
        ));
        return Summary {
            lines,
            complete: false,
        };
    };
    let tiles = tiling(first).unwrap_or(1);
    let frames: Option<Vec<u32>> = first.frames.as_deref().and_then(|t| {
        t.parse::<crate::options::FrameRange>()
            .ok()?
            .frames(&(0..=u32::MAX))
            .ok()
    });
    let tasks = good
        .iter()
        .find_map(|(_, h)| h.provenance.task.as_deref().and_then(task_count));
    let unit_of = |h: &PartHeader| Unit {
        frame: h.frame,
        tile: tile_index(h).unwrap_or(0),
    };
    // The parts by unit (a unit given twice keeps its first part: merge refuses the pair).
    let mut have: BTreeMap<(Option<u32>, u32), &PartHeader> = BTreeMap::new();
    for (_, h) in &good {
        let u = unit_of(h);
        have.entry((u.frame, u.tile)).or_insert(h);
    }
    let all: Vec<Unit> = match &frames {
        Some(f) => f
            .iter()
            .flat_map(|&frame| {
                (0..tiles).map(move |tile| Unit {
                    frame: Some(frame),
                    tile,
                })
            })
            .collect(),
        None => (0..tiles)
            .map(|tile| Unit {
                frame: first.frame,
                tile,
            })
            .collect(),
    };
    let name = |u: &Unit| match (u.frame, tiles) {
        (Some(f), 1) => format!("frame {f}"),
        (Some(f), n) => format!("frame {f} tile {} of {n}", u.tile),
        (None, n) => format!("tile {} of {n}", u.tile),
    };
    let missing: Vec<&Unit> = all
        .iter()
        .filter(|u| !have.contains_key(&(u.frame, u.tile)))
        .collect();
    let mut times = Vec::new();
    if let Some(count) = tasks {
        for t in 0..count {
            let task = TaskIndex {
                index: t,
                count,
                origin: String::new(),
            };
            let Ok(units) = units_of(&task, frames.as_deref(), tiles) else {
                break;
            };
            let done: Vec<&PartHeader> = units
                .iter()
                .filter_map(|u| have.get(&(u.frame, u.tile)).copied())
                .collect();
            let lacking: Vec<String> = units
                .iter()
                .filter(|u| !have.contains_key(&(u.frame, u.tile)))
                .map(name)
                .collect();
            let task_ms = done.iter().filter_map(|h| h.provenance.task_ms).max();
            let render_ms: u64 = done.iter().filter_map(|h| h.provenance.render_ms).sum();
            let hosts: BTreeSet<&str> = done
                .iter()
                .filter_map(|h| h.provenance.host.as_deref())
                .collect();
            if let (Some(ms), true) = (task_ms, lacking.is_empty()) {
                times.push((ms, t));
            }
            let mut line = format!(
                "task {t} of {count}: {} of {} part{}",
                done.len(),
                units.len(),
                plural(units.len())
            );
            if let Some(ms) = task_ms {
                line += &format!(", {} (rendering {})", seconds(ms), seconds(render_ms));
            }
            if !hosts.is_empty() {
                line += &format!(" on {}", hosts.into_iter().collect::<Vec<_>>().join(", "));
            }
            if !lacking.is_empty() {
                line += &format!("; missing {}", lacking.join(", "));
            }
            lines.push(line);
        }
    }
    lines.extend(broken.iter().cloned());
    lines.push(format!(
        "{} of {} part{} done{}{}",
        all.len() - missing.len(),
        all.len(),
        plural(all.len()),
        if missing.is_empty() {
            String::new()
        } else {
            format!(
                ", missing: {}",
                missing
                    .iter()
                    .map(|u| name(u))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        },
        if broken.is_empty() {
            String::new()
        } else {
            format!(", {} unreadable", broken.len())
        }
    ));
    if let Some(count) = tasks {
        let failed: Vec<u32> = (0..count)
            .filter(|t| !times.iter().any(|(_, k)| k == t))
            .collect();
        if !failed.is_empty() {
            lines.push(format!(
                "to re-run: task{} {} (sbatch --array={} ... --task-index env:{count})",
                plural(failed.len()),
                list(&failed),
                list(&failed)
            ));
        }
    }
    if !times.is_empty() {
        times.sort();
        let (lo, hi) = (times[0], times[times.len() - 1]);
        lines.push(format!(
            "time per task: {} to {} (median {}, task {} the slowest) over {} complete task{}",
            seconds(lo.0),
            seconds(hi.0),
            seconds(times[times.len() / 2].0),
            hi.1,
            times.len(),
            plural(times.len())
        ));
    }
    Summary {
        lines,
        complete: missing.is_empty() && broken.is_empty(),
    }
}

/// The tile count of a part's `I/N` label.
fn tiling(h: &PartHeader) -> Option<u32> {
    h.tile
        .as_deref()?
        .parse::<crate::region::TileSpec>()
        .ok()
        .map(|t| t.tiling.count())
}

/// The tile index of a part's `I/N` label.
fn tile_index(h: &PartHeader) -> Option<u32> {
    h.tile
        .as_deref()?
        .parse::<crate::region::TileSpec>()
        .ok()
        .map(|t| t.index)
}

/// T of a `t/T` task label.
fn task_count(label: &str) -> Option<u32> {
    label.split_once('/')?.1.parse().ok().filter(|&n| n > 0)
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}

fn seconds(ms: u64) -> String {
    format!("{:.2} s", ms as f64 / 1000.0)
}

/// `2,5,7` (as `sbatch --array` takes them).
fn list(tasks: &[u32]) -> String {
    tasks
        .iter()
        .map(u32::to_string)
        .collect::<Vec<_>>()
        .join(",")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::farm::part::Provenance;
    use crate::region::Region;

    fn part(tile: u32, tiles: u32, frame: Option<u32>, task: &str, ms: u64) -> PartHeader {
        PartHeader {
            scene: "s.toml".into(),
            scene_hash: 1,
            options: "--width 8".into(),
            frame,
            width: 8,
            height: 8,
            region: Region::full(8, 8),
            device: "cpu".into(),
            tile: Some(format!("{tile}/{tiles}")),
            frames: frame.map(|_| "3..5".into()),
            version: "0.1.0+x".into(),
            provenance: Provenance {
                task: Some(task.into()),
                host: Some("n1".into()),
                render_ms: Some(ms / 2),
                task_ms: Some(ms),
            },
        }
    }

    fn ok(h: PartHeader, i: usize) -> (PathBuf, Result<PartHeader, String>) {
        (PathBuf::from(format!("p{i}.exr")), Ok(h))
    }

    /// 8 tiles over 4 tasks, tile 5 (task 2's second) missing: task 2 is named with the
    /// tile, the others with their times; the slowest complete task is named.
    #[test]
    fn a_missing_tile_names_its_task() {
        let parts: Vec<_> = [0, 1, 2, 3, 4, 6, 7]
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                ok(
                    part(t, 8, None, &format!("{}/4", t / 2), 1000 + 100 * t as u64),
                    i,
                )
            })
            .collect();
        let s = summarize(&parts);
        assert!(!s.complete);
        let text = s.lines.join("\n");
        assert!(
            text.contains("task 0 of 4: 2 of 2 parts, 1.10 s (rendering 1.05 s) on n1"),
            "{text}"
        );
        assert!(
            text.contains(
                "task 2 of 4: 1 of 2 parts, 1.40 s (rendering 0.70 s) on n1; missing tile 5 of 8"
            ),
            "{text}"
        );
        assert!(
            text.contains("7 of 8 parts done, missing: tile 5 of 8"),
            "{text}"
        );
        assert!(
            text.contains("to re-run: task 2 (sbatch --array=2"),
            "{text}"
        );
        assert!(text.contains("time per task: 1.10 s to 1.70 s (median 1.30 s, task 3 the slowest) over 3 complete tasks"), "{text}");
    }

    /// Frames 3..5 x 2 tiles over 2 tasks, every part of frame 4 missing and one file
    /// unreadable: the frame is named, and a task that wrote nothing is named too.
    #[test]
    fn a_missing_frame_and_an_unreadable_file() {
        let mut parts = vec![
            ok(part(0, 2, Some(3), "0/3", 500), 0),
            ok(part(1, 2, Some(3), "0/3", 900), 1),
            ok(part(0, 2, Some(5), "2/3", 700), 2),
            ok(part(1, 2, Some(5), "2/3", 800), 3),
        ];
        parts.push((
            PathBuf::from("cut.exr"),
            Err("unreadable: truncated".into()),
        ));
        let s = summarize(&parts);
        assert!(!s.complete);
        let text = s.lines.join("\n");
        assert!(
            text.contains(
                "task 1 of 3: 0 of 2 parts; missing frame 4 tile 0 of 2, frame 4 tile 1 of 2"
            ),
            "{text}"
        );
        assert!(text.contains("cut.exr: unreadable: truncated"), "{text}");
        assert!(text.contains("4 of 6 parts done, missing: frame 4 tile 0 of 2, frame 4 tile 1 of 2, 1 unreadable"), "{text}");
        assert!(text.contains("to re-run: task 1 "), "{text}");
    }

    #[test]
    fn a_whole_set_is_complete() {
        let parts: Vec<_> = (0..4)
            .map(|t| ok(part(t, 4, None, &format!("{t}/4"), 2000), t as usize))
            .collect();
        let s = summarize(&parts);
        assert!(s.complete, "{:?}", s.lines);
        assert_eq!(s.lines.last().unwrap(), "time per task: 2.00 s to 2.00 s (median 2.00 s, task 3 the slowest) over 4 complete tasks");
    }
}
