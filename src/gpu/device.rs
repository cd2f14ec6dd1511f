//! `--gpu env`: the EGL device of a task, taken from its batch scheduler's variables, so a
//! job script that runs one task per GPU needs no per-task flag (docs/distributed.md, "One
//! GPU per task").
//!
//! The task's GPU is position k of its GPU list: the first of [`LIST_VARS`] that is set,
//! and k the local rank (the first of [`RANK_VARS`]) when the list names several, else 0.
//! Without a list the local rank alone numbers the GPU. That GPU is then found among the
//! EGL devices ([`super::egl::list_devices`]):
//!
//! - On NVIDIA's driver (devices with `EGL_NV_device_cuda`) by CUDA ordinal. The driver
//!   applies `CUDA_VISIBLE_DEVICES` to those ordinals itself: measured on an H200 (driver
//!   580.159.04), every GPU stays an EGL device, and a GPU that variable hides reports no
//!   ordinal; the k-th GPU it names is CUDA device k. So position k of
//!   `CUDA_VISIBLE_DEVICES` is the device with CUDA ordinal k, whatever the variable spells
//!   (numbers or UUIDs), and a GPU number of the other lists (Slurm's global ids) is the
//!   device with that ordinal.
//! - Elsewhere (Mesa) the GPU number is the EGL device's position in the list.
//!
//! A variable that names no device present is a usage error (exit 2) naming the devices
//! there are. [`pick`] is the rule over any variables and devices; [`from_env`] applies it
//! to this process's once.

use std::sync::OnceLock;

use super::egl::EglDevice;

/// The variables that list a task's GPUs, in the order read: CUDA's (Slurm's GPU binding
/// sets it), Slurm's global ids of the step's and the job's GPUs, and the GPU ordinal of
/// Slurm's `--gpu-bind`/AMD's runtime.
pub const LIST_VARS: [&str; 4] = [
    "CUDA_VISIBLE_DEVICES",
    "SLURM_STEP_GPUS",
    "SLURM_JOB_GPUS",
    "GPU_DEVICE_ORDINAL",
];

/// The variables that give a task's rank among the tasks of its node, in the order read:
/// Slurm's, then torchrun's and Open MPI's.
pub const RANK_VARS: [&str; 3] = ["SLURM_LOCALID", "LOCAL_RANK", "OMPI_COMM_WORLD_LOCAL_RANK"];

/// The EGL device `--gpu env` chose, and why, for the render's log.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Pick {
    /// Its position in [`super::egl::list_devices`]: what `--gpu N` takes.
    pub index: u32,
    /// One line: the variables read and the device they name.
    pub why: String,
}

/// The rule of the module docs: the device among `devices` that the variables `var` gives
/// name, or one line saying why there is none.
pub fn pick(var: &dyn Fn(&str) -> Option<String>, devices: &[EglDevice]) -> Result<Pick, String> {
    let first = |names: &[&'static str]| {
        names
            .iter()
            .find_map(|&n| var(n).map(|v| (n, v.trim().to_string())))
    };
    let rank = match first(&RANK_VARS) {
        Some((n, v)) => Some((
            n,
            v.parse::<usize>()
                .map_err(|_| format!("--gpu env: {n}={v} is not a local rank"))?,
        )),
        None => None,
    };
    let list = first(&LIST_VARS);
    let mut read = Vec::new();
    // k: the position in the list; `number`: the GPU's number where the list spells one.
    let (k, number) = match &list {
        Some((n, v)) => {
            read.push(format!("{n}={v}"));
            let gpus: Vec<&str> = v.split(',').map(str::trim).collect();
            if v.is_empty() || v == "NoDevFiles" {
                return Err(format!(
                    "--gpu env: {n}={v}: the scheduler gave this task no GPU"
                ));
            }
            let k = match rank {
                _ if gpus.len() == 1 => 0,
                Some((rn, r)) => {
                    read.push(format!("{rn}={r}"));
                    if r >= gpus.len() {
                        return Err(format!(
                            "--gpu env: {rn}={r}, but {n}={v} names {} GPUs: one task per GPU takes the local ranks 0 to {}",
                            gpus.len(),
                            gpus.len() - 1
                        ));
                    }
                    r
                }
                None => 0,
            };
            (k, gpus[k].parse::<u32>().ok())
        }
        None => match rank {
            Some((rn, r)) => {
                read.push(format!("{rn}={r}"));
                (r, u32::try_from(r).ok())
            }
            None => {
                return Err(format!(
                    "--gpu env: none of {} is set, so the scheduler names no GPU: pass --gpu N",
                    LIST_VARS
                        .iter()
                        .chain(&RANK_VARS)
                        .copied()
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            }
        },
    };
    let read = read.join(", ");
    let nvidia = devices.iter().any(|d| {
        d.extensions
            .split_ascii_whitespace()
            .any(|e| e == "EGL_NV_device_cuda")
    });
    let chosen = if nvidia {
        // CUDA numbers what CUDA_VISIBLE_DEVICES lets it see from 0; the other lists give
        // the GPU's own number.
        let ordinal = match &list {
            Some((n, _)) if *n == "CUDA_VISIBLE_DEVICES" => Some(k as i64),
            Some(_) => number.map(i64::from),
            None => Some(k as i64),
        };
        let Some(ordinal) = ordinal else {
            return Err(format!(
                "--gpu env: {read}: GPU {k} of the list is not a number; pass --gpu N (`fragtrace info` lists the devices)"
            ));
        };
        devices
            .iter()
            .find(|d| d.cuda == Some(ordinal))
            .ok_or_else(|| {
                format!(
                    "--gpu env: {read} is CUDA device {ordinal}, which no EGL device is; the devices: {}",
                    present(devices)
                )
            })?
    } else {
        let Some(n) = number else {
            return Err(format!(
                "--gpu env: {read}: GPU {k} of the list is not a device number; pass --gpu N (`fragtrace info` lists the devices)"
            ));
        };
        devices.get(n as usize).ok_or_else(|| {
            format!(
                "--gpu env: {read} names device {n}, but this machine has {}",
                present(devices)
            )
        })?
    };
    Ok(Pick {
        index: chosen.index,
        why: format!("--gpu env: {read}: EGL device {}", describe(chosen)),
    })
}

/// [`pick`] over this process's variables and EGL devices, decided once (the variables do
/// not change under a running task); an error is a usage error's one line.
pub fn from_env() -> Result<&'static Pick, String> {
    static PICK: OnceLock<Result<Pick, String>> = OnceLock::new();
    PICK.get_or_init(|| {
        let devices = super::egl::list_devices().map_err(|e| format!("--gpu env: {e}"))?;
        pick(&|n| std::env::var(n).ok(), &devices)
    })
    .as_ref()
    .map_err(Clone::clone)
}

/// `1 EGL device: --gpu 0 (software)`, `2 EGL devices: --gpu 0 (unnamed, CUDA device 0),
/// --gpu 1 (unnamed)`.
fn present(devices: &[EglDevice]) -> String {
    match devices.len() {
        0 => "no EGL device".into(),
        k => format!(
            "{k} EGL device{}: {}",
            if k == 1 { "" } else { "s" },
            devices.iter().map(describe).collect::<Vec<_>>().join(", ")
        ),
    }
}

/// `--gpu 1 (/dev/dri/renderD129, CUDA device 0)`.
fn describe(d: &EglDevice) -> String {
    format!(
        "--gpu {} ({}{})",
        d.index,
        d.name,
        d.cuda
            .map_or(String::new(), |c| format!(", CUDA device {c}"))
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mesa(n: usize) -> Vec<EglDevice> {
        (0..n)
            .map(|i| EglDevice {
                index: i as u32,
                name: if i + 1 == n {
                    "software".into()
                } else {
                    format!("/dev/dri/renderD{}", 128 + i)
                },
                cuda: None,
                extensions: if i + 1 == n {
                    "EGL_MESA_device_software".into()
                } else {
                    "EGL_EXT_device_drm".into()
                },
            })
            .collect()
    }

    /// NVIDIA's list as measured: every GPU a device, the ordinal only on those CUDA sees.
    fn nvidia(ordinals: &[Option<i64>]) -> Vec<EglDevice> {
        ordinals
            .iter()
            .enumerate()
            .map(|(i, &cuda)| EglDevice {
                index: i as u32,
                name: "unnamed".into(),
                cuda,
                extensions: "EGL_NV_device_cuda EGL_EXT_device_drm".into(),
            })
            .collect()
    }

    fn with(vars: &[(&str, &str)], devices: &[EglDevice]) -> Result<u32, String> {
        let var = |n: &str| {
            vars.iter()
                .find(|(k, _)| *k == n)
                .map(|(_, v)| v.to_string())
        };
        pick(&var, devices).map(|p| p.index)
    }

    #[test]
    fn mesa_takes_the_number_as_the_device_position() {
        let d = mesa(3);
        assert_eq!(with(&[("CUDA_VISIBLE_DEVICES", "1")], &d), Ok(1));
        assert_eq!(with(&[("SLURM_STEP_GPUS", "2")], &d), Ok(2));
        assert_eq!(with(&[("GPU_DEVICE_ORDINAL", "0")], &d), Ok(0));
        // The local rank picks among several, and alone numbers the device.
        let two = [("SLURM_JOB_GPUS", "2,0"), ("SLURM_LOCALID", "1")];
        assert_eq!(with(&two, &d), Ok(0));
        assert_eq!(with(&[("LOCAL_RANK", "2")], &d), Ok(2));
        // One GPU in the list: the rank (of a task among several, each given its own) is
        // not a position in it.
        let own = [("CUDA_VISIBLE_DEVICES", "1"), ("SLURM_LOCALID", "3")];
        assert_eq!(with(&own, &d), Ok(1));
        // The list is read before the rank, CUDA's first.
        let both = [("SLURM_STEP_GPUS", "0"), ("CUDA_VISIBLE_DEVICES", "2")];
        assert_eq!(with(&both, &d), Ok(2));
    }

    #[test]
    fn nvidia_finds_the_cuda_ordinal() {
        // CUDA_VISIBLE_DEVICES=2 on a 4-GPU node: the driver shows GPU 2 as CUDA device 0.
        let d = nvidia(&[None, None, Some(0), None]);
        assert_eq!(with(&[("CUDA_VISIBLE_DEVICES", "2")], &d), Ok(2));
        let uuid = [(
            "CUDA_VISIBLE_DEVICES",
            "GPU-53a8142b-43c5-54a6-44a7-9f64572320f1",
        )];
        assert_eq!(with(&uuid, &d), Ok(2));
        // Two GPUs for a node's two tasks, the second task.
        let d = nvidia(&[None, Some(1), None, Some(0)]);
        let second = [("CUDA_VISIBLE_DEVICES", "3,1"), ("SLURM_LOCALID", "1")];
        assert_eq!(with(&second, &d), Ok(1));
        // Slurm's global ids with every GPU visible to CUDA.
        let d = nvidia(&[Some(0), Some(1), Some(2), Some(3)]);
        assert_eq!(with(&[("SLURM_STEP_GPUS", "3")], &d), Ok(3));
        assert_eq!(with(&[("SLURM_LOCALID", "1")], &d), Ok(1));
    }

    #[test]
    fn no_such_device_is_one_line_naming_those_present() {
        let e = with(&[("CUDA_VISIBLE_DEVICES", "3")], &mesa(1)).unwrap_err();
        assert_eq!(
            e,
            "--gpu env: CUDA_VISIBLE_DEVICES=3 names device 3, but this machine has 1 EGL device: --gpu 0 (software)"
        );
        let e = with(&[("CUDA_VISIBLE_DEVICES", "1")], &nvidia(&[None])).unwrap_err();
        assert_eq!(
            e,
            "--gpu env: CUDA_VISIBLE_DEVICES=1 is CUDA device 0, which no EGL device is; the devices: 1 EGL device: --gpu 0 (unnamed)"
        );
        for (vars, want) in [
            (&[][..], "none of CUDA_VISIBLE_DEVICES, SLURM_STEP_GPUS"),
            (&[("CUDA_VISIBLE_DEVICES", "")][..], "gave this task no GPU"),
            (
                &[("CUDA_VISIBLE_DEVICES", "NoDevFiles")][..],
                "gave this task no GPU",
            ),
            (
                &[("SLURM_LOCALID", "x")][..],
                "SLURM_LOCALID=x is not a local rank",
            ),
            (
                &[("SLURM_JOB_GPUS", "0,1"), ("SLURM_LOCALID", "2")][..],
                "SLURM_LOCALID=2, but SLURM_JOB_GPUS=0,1 names 2 GPUs",
            ),
            (&[("SLURM_JOB_GPUS", "GPU-x")][..], "is not a device number"),
        ] {
            let e = with(vars, &mesa(2)).unwrap_err();
            assert!(
                e.starts_with("--gpu env: ") && e.contains(want),
                "{vars:?}: {e}"
            );
            assert_eq!(e.lines().count(), 1);
        }
    }

    #[test]
    fn the_reason_names_what_was_read() {
        let var = |n: &str| (n == "CUDA_VISIBLE_DEVICES").then(|| "0".to_string());
        let p = pick(&var, &nvidia(&[Some(0)])).unwrap();
        assert_eq!(
            p.why,
            "--gpu env: CUDA_VISIBLE_DEVICES=0: EGL device --gpu 0 (unnamed, CUDA device 0)"
        );
    }
}
