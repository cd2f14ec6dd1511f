//! Which share of the work this process does, taken from the scheduler that started it
//! (`--task-index`), and how the work — frames times tiles — is shared out.
//!
//! - **Slurm job arrays** (`sbatch --array=0-15`, also `1-16` or stepped `0-30:2`): the task
//!   is `SLURM_ARRAY_TASK_ID`; `SLURM_ARRAY_TASK_MIN`, `_MAX`, `_STEP` and `_COUNT` give the
//!   array, and task k of the array (counting from 0) is `(ID - MIN) / STEP`. An array with
//!   gaps (`--array=1,4,9`) has no such numbering and is refused.
//! - **Kubernetes Indexed Jobs** (`completionMode: Indexed`): the task is
//!   `JOB_COMPLETION_INDEX` (0-based); Kubernetes does not tell the pod how many
//!   completions there are, so the count comes on the command line: `--task-index env:N`.
//! - **Anything else**: `--task-index I/N` explicitly.
//!
//! The work is `frames x tiles` units, frame-major (unit `u` is frame `u / tiles`, tile
//! `u % tiles`), and task `t` of `T` takes the consecutive units
//! `floor(t U / T) .. floor((t + 1) U / T)`: one unit each when `T = U`, several in one
//! process (one scene load, one GL context) when there are fewer tasks than units. More
//! tasks than units is refused: the extra tasks would have nothing to do, which is most
//! likely an array written for another job.

use std::fmt;

use crate::{Error, Result};

/// `SLURM_ARRAY_TASK_ID`.
pub const SLURM_ID: &str = "SLURM_ARRAY_TASK_ID";
/// `JOB_COMPLETION_INDEX` (Kubernetes Indexed Jobs).
pub const K8S_INDEX: &str = "JOB_COMPLETION_INDEX";

/// Where `--task-index` takes the task from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TaskSource {
    /// From the environment: a Slurm array, or a Kubernetes index with `count` completions.
    Env {
        /// `env:N`: the number of tasks (required for Kubernetes, checked against Slurm's).
        count: Option<u32>,
    },
    /// `I/N`: task I of N.
    Explicit {
        /// 0-based task.
        index: u32,
        /// Tasks in all.
        count: u32,
    },
}

impl std::str::FromStr for TaskSource {
    type Err = String;

    /// `env`, `env:N` or `I/N`.
    fn from_str(s: &str) -> std::result::Result<TaskSource, String> {
        let count = |c: &str| {
            c.trim()
                .parse::<u32>()
                .ok()
                .filter(|&n| n >= 1)
                .ok_or_else(|| format!("`{s}`: the task count `{c}` is not a whole number >= 1"))
        };
        if s == "env" {
            return Ok(TaskSource::Env { count: None });
        }
        if let Some(n) = s.strip_prefix("env:") {
            return Ok(TaskSource::Env {
                count: Some(count(n)?),
            });
        }
        if let Some((i, n)) = s.split_once('/') {
            let count = count(n)?;
            let index = i
                .trim()
                .parse::<u32>()
                .map_err(|_| format!("`{s}`: the task `{i}` is not a whole number"))?;
            if index >= count {
                return Err(format!("`{s}`: the task must be below {count} (0-based)"));
            }
            return Ok(TaskSource::Explicit { index, count });
        }
        Err(format!(
            "`{s}` is not env, env:N or I/N (env reads {SLURM_ID} or {K8S_INDEX})"
        ))
    }
}

/// This process's task: `index` of `count`, and where that came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TaskIndex {
    /// 0-based task.
    pub index: u32,
    /// Tasks in all.
    pub count: u32,
    /// Where it came from, for messages (`SLURM_ARRAY_TASK_ID=5 of 4-7`).
    pub origin: String,
}

impl fmt::Display for TaskIndex {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "task {} of {} ({})", self.index, self.count, self.origin)
    }
}

/// Resolves `source` with `var` reading the environment (`std::env::var` in the
/// program; a table in tests).
pub fn resolve(source: TaskSource, var: impl Fn(&str) -> Option<String>) -> Result<TaskIndex> {
    let (given, explicit) = match source {
        TaskSource::Explicit { index, count } => (Some(count), Some(index)),
        TaskSource::Env { count } => (count, None),
    };
    if let Some(index) = explicit {
        return Ok(TaskIndex {
            index,
            count: given.unwrap_or(1),
            origin: "--task-index".into(),
        });
    }
    let bad = |m: String| Error::Usage(format!("--task-index env: {m}"));
    let num = |name: &str| -> Result<Option<u64>> {
        match var(name) {
            None => Ok(None),
            Some(v) => v
                .trim()
                .parse::<u64>()
                .map(Some)
                .map_err(|_| bad(format!("{name}={v} is not a whole number"))),
        }
    };
    let slurm = num(SLURM_ID)?;
    let k8s = num(K8S_INDEX)?;
    match (slurm, k8s) {
        (Some(_), Some(_)) => Err(bad(format!(
            "both {SLURM_ID} and {K8S_INDEX} are set; give the task as --task-index I/N"
        ))),
        (None, None) => Err(bad(format!(
            "neither {SLURM_ID} (a Slurm job array: sbatch --array) nor {K8S_INDEX} (a Kubernetes Indexed Job) is set"
        ))),
        (None, Some(i)) => {
            let count = given.ok_or_else(|| {
                bad(format!(
                    "{K8S_INDEX}={i} is set but the number of completions is not: give it as --task-index env:N"
                ))
            })?;
            if i >= count as u64 {
                return Err(bad(format!(
                    "{K8S_INDEX}={i} is not below the {count} completions of env:{count}"
                )));
            }
            Ok(TaskIndex {
                index: i as u32,
                count,
                origin: format!("{K8S_INDEX}={i}"),
            })
        }
        (Some(id), None) => {
            let (min, max) = match (num("SLURM_ARRAY_TASK_MIN")?, num("SLURM_ARRAY_TASK_MAX")?) {
                (Some(a), Some(b)) => (a, b),
                _ => {
                    return Err(bad(format!(
                        "{SLURM_ID}={id} is set without SLURM_ARRAY_TASK_MIN and SLURM_ARRAY_TASK_MAX"
                    )))
                }
            };
            let step = num("SLURM_ARRAY_TASK_STEP")?.unwrap_or(1).max(1);
            let span = (max.saturating_sub(min)) / step + 1;
            let count = num("SLURM_ARRAY_TASK_COUNT")?.unwrap_or(span);
            let array = if step == 1 {
                format!("{min}-{max}")
            } else {
                format!("{min}-{max}:{step}")
            };
            if id < min || id > max || (id - min) % step != 0 {
                return Err(bad(format!(
                    "{SLURM_ID}={id} is not a task of the array {array}"
                )));
            }
            // A re-run of some tasks of an array of N (`sbatch --array=3` after task 3
            // failed): fewer tasks than env:N says, so the array's own numbering is not
            // the job's, and the task is SLURM_ARRAY_TASK_ID itself, 0-based.
            if let Some(n) = given.filter(|&n| count < n as u64) {
                if id >= n as u64 {
                    return Err(bad(format!(
                        "{SLURM_ID}={id} re-runs a task of env:{n}, whose tasks are 0..{}: give the 0-based task (--array=0-{})",
                        n - 1,
                        n - 1
                    )));
                }
                return Ok(TaskIndex {
                    index: id as u32,
                    count: n,
                    origin: format!("{SLURM_ID}={id}, a re-run of task {id} of env:{n}"),
                });
            }
            // `sbatch --array=3` without the task count: an array of one task, which would
            // render the whole image as task 0 of 1 over part 0 of the real job.
            if given.is_none() && count == 1 && id != 0 {
                return Err(bad(format!(
                    "{SLURM_ID}={id} in an array of one task (--array={id}): to re-run task {id} of a job of N tasks give --task-index env:N (docs/distributed.md)"
                )));
            }
            if count != span {
                return Err(bad(format!(
                    "the array has {count} tasks but spans {array} ({span} slots): an array with gaps (--array=1,4,9) has no task numbering; use a range such as --array=0-{}",
                    count - 1
                )));
            }
            if let Some(n) = given {
                if n as u64 != count {
                    return Err(bad(format!(
                        "env:{n} says {n} tasks but the Slurm array {array} has {count}"
                    )));
                }
            }
            let count = u32::try_from(count).map_err(|_| bad("too many tasks".into()))?;
            Ok(TaskIndex {
                index: ((id - min) / step) as u32,
                count,
                origin: format!("{SLURM_ID}={id} of --array={array}"),
            })
        }
    }
}

/// One unit of work: a frame (None for a still) and a tile of the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Unit {
    /// The frame, for an animation.
    pub frame: Option<u32>,
    /// Tile index, `0..tiles`.
    pub tile: u32,
}

/// The units task `task` does, of `frames` (None for a still) times `tiles` tiles.
pub fn units_of(task: &TaskIndex, frames: Option<&[u32]>, tiles: u32) -> Result<Vec<Unit>> {
    let nf = frames.map_or(1, |f| f.len() as u64);
    let total = nf * tiles as u64;
    let t = task.count as u64;
    if t > total {
        let what = match frames {
            Some(f) => format!("{} frames x {tiles} tiles", f.len()),
            None => format!("{tiles} tiles"),
        };
        return Err(Error::Usage(format!(
            "{task}: {} tasks for {total} units of work ({what}) would leave tasks with nothing to do; run {total} tasks (--array=0-{}), or cut the image into more tiles with --tiles",
            task.count,
            total - 1
        )));
    }
    let i = task.index as u64;
    let (a, b) = (i * total / t, (i + 1) * total / t);
    Ok((a..b)
        .map(|u| Unit {
            frame: frames.map(|f| f[(u / tiles as u64) as usize]),
            tile: (u % tiles as u64) as u32,
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn env(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let m: HashMap<String, String> = pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        move |k| m.get(k).cloned()
    }

    fn slurm(id: u32, min: u32, max: u32, step: Option<u32>, count: u32) -> Vec<(String, String)> {
        let mut v = vec![
            (SLURM_ID.to_string(), id.to_string()),
            ("SLURM_ARRAY_TASK_MIN".into(), min.to_string()),
            ("SLURM_ARRAY_TASK_MAX".into(), max.to_string()),
            ("SLURM_ARRAY_TASK_COUNT".into(), count.to_string()),
        ];
        if let Some(s) = step {
            v.push(("SLURM_ARRAY_TASK_STEP".into(), s.to_string()));
        }
        v
    }

    fn run(src: &str, vars: &[(String, String)]) -> Result<TaskIndex> {
        let pairs: Vec<(&str, &str)> = vars.iter().map(|(a, b)| (a.as_str(), b.as_str())).collect();
        resolve(src.parse().unwrap(), env(&pairs))
    }

    #[test]
    fn slurm_arrays() {
        let t = run("env", &slurm(2, 0, 3, None, 4)).unwrap();
        assert_eq!((t.index, t.count), (2, 4));
        let t = run("env", &slurm(7, 4, 7, Some(1), 4)).unwrap();
        assert_eq!((t.index, t.count), (3, 4));
        let t = run("env:8", &slurm(14, 0, 14, Some(2), 8)).unwrap();
        assert_eq!((t.index, t.count), (7, 8));
        // A list with gaps: COUNT 3 but the range 1-9 spans 9.
        let e = run("env", &slurm(4, 1, 9, None, 3))
            .unwrap_err()
            .to_string();
        assert!(e.contains("gaps"), "{e}");
        // More tasks than env:N says: an array written for another job.
        let e = run("env:3", &slurm(0, 0, 3, None, 4))
            .unwrap_err()
            .to_string();
        assert!(e.contains("env:3") && e.contains("has 4"), "{e}");
        // Fewer: a re-run of some of the job's tasks, numbered by their IDs.
        let t = run("env:5", &slurm(2, 0, 3, None, 4)).unwrap();
        assert_eq!((t.index, t.count), (2, 5));
        let e = run("env", &slurm(3, 0, 6, Some(2), 4))
            .unwrap_err()
            .to_string();
        assert!(e.contains("not a task"), "{e}");
    }

    /// `sbatch --array=3` re-running task 3 of a job of 4: with env:4, task 3 of 4 (and
    /// `--array=1,3` likewise, gaps and all); without the count, refused rather than
    /// rendered as task 0 of 1; a task beyond the count refused.
    #[test]
    fn a_rerun_of_one_index_is_that_task_of_the_job() {
        let t = run("env:4", &slurm(3, 3, 3, None, 1)).unwrap();
        assert_eq!((t.index, t.count), (3, 4));
        let t = run("env:4", &slurm(3, 1, 3, None, 2)).unwrap();
        assert_eq!((t.index, t.count), (3, 4));
        let e = run("env", &slurm(3, 3, 3, None, 1))
            .unwrap_err()
            .to_string();
        assert!(e.contains("env:N") && e.contains("--array=3"), "{e}");
        let e = run("env:4", &slurm(4, 4, 4, None, 1))
            .unwrap_err()
            .to_string();
        assert!(e.contains("0..3"), "{e}");
        // The whole array of the count: its own numbering, as before (1-based here).
        let t = run("env:4", &slurm(4, 1, 4, None, 4)).unwrap();
        assert_eq!((t.index, t.count), (3, 4));
    }

    #[test]
    fn kubernetes_and_explicit() {
        let k = |i: &str| vec![(K8S_INDEX.to_string(), i.to_string())];
        let t = run("env:4", &k("3")).unwrap();
        assert_eq!((t.index, t.count), (3, 4));
        assert!(run("env", &k("3"))
            .unwrap_err()
            .to_string()
            .contains("env:N"));
        assert!(run("env:3", &k("3")).is_err());
        assert!(run("env:3", &k("x")).is_err());
        let e = run("env", &[]).unwrap_err().to_string();
        assert!(e.contains(SLURM_ID) && e.contains(K8S_INDEX), "{e}");
        let mut both = slurm(0, 0, 1, None, 2);
        both.extend(k("0"));
        assert!(run("env:2", &both).is_err());
        let t = run("5/6", &[]).unwrap();
        assert_eq!((t.index, t.count), (5, 6));
        assert!("6/6".parse::<TaskSource>().is_err());
        assert!("env:0".parse::<TaskSource>().is_err());
        assert!("slurm".parse::<TaskSource>().is_err());
    }

    /// Every unit to exactly one task, in order, for any task count up to the units.
    #[test]
    fn units_are_shared_out_exactly_once() {
        let frames: Vec<u32> = (10..15).collect();
        for tiles in 1..=4u32 {
            for fr in [None, Some(&frames[..])] {
                let total = fr.map_or(1, |f| f.len() as u32) * tiles;
                for count in 1..=total {
                    let mut all = Vec::new();
                    for index in 0..count {
                        let t = TaskIndex {
                            index,
                            count,
                            origin: String::new(),
                        };
                        let u = units_of(&t, fr, tiles).unwrap();
                        assert!(!u.is_empty());
                        all.extend(u);
                    }
                    assert_eq!(all.len() as u32, total);
                    for (k, u) in all.iter().enumerate() {
                        let k = k as u32;
                        assert_eq!(u.tile, k % tiles);
                        assert_eq!(u.frame, fr.map(|f| f[(k / tiles) as usize]));
                    }
                }
                let t = TaskIndex {
                    index: 0,
                    count: total + 1,
                    origin: String::new(),
                };
                assert!(units_of(&t, fr, tiles).is_err());
            }
        }
    }
}
