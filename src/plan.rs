//! The plan of one render: the user's choices ([`RenderOptions`]) resolved once against
//! what the machine offers (the GL context's version and limits, or none) into what runs:
//! the backend, the structure, the kernel with its fallback, the mask, the ray storage and
//! the scene fetch, or the CPU's precision and triangle path. pbrt-v4's
//! `CreateAccelerator` is the model: one switch from names to things.
//!
//! The plan travels typed into the statistics ([`crate::render::RenderStats::plan`]), the
//! summary line and the part headers (`crate::farm::options_line`), which all print it
//! with the one [`Display`](std::fmt::Display); [`FromStr`] reads that
//! text back (`fragtrace merge` compares parts by it).

use std::fmt;
use std::str::FromStr;

use clap::ValueEnum;

use crate::accel::AccelKind;
use crate::gpu::options::{FragmentKernel, Kernel, KernelChoice, Mask, SceneFetch, Storage};
use crate::gpu::GlInfo;
use crate::options::{CpuPath, Precision, RenderOptions};
use crate::Result;

/// What one render runs, every `auto` resolved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plan {
    /// The CPU renderer.
    Cpu {
        /// The structure walked.
        accel: AccelKind,
        /// Its arithmetic.
        precision: Precision,
        /// Vectorised or scalar triangle tests (f32; f64 is always scalar).
        path: CpuPath,
    },
    /// A fragment kernel on the GPU.
    Fragment {
        /// The structure walked.
        accel: AccelKind,
        /// The kernel.
        kernel: FragmentKernel,
        /// How finished rays are kept out of traversal passes (`auto` resolved).
        mask: Mask,
        /// The ray textures' precision.
        storage: Storage,
    },
    /// The compute kernel on the GPU.
    Compute {
        /// The structure walked.
        accel: AccelKind,
        /// How it reads the scene, as asked (`auto` is settled with the scene's storage
        /// blocks, when the kernel is set up; the statistics report what it took).
        scene_fetch: SceneFetch,
        /// The fragment kernel that finishes the render where the driver cuts the compute
        /// kernel's loops short: only when `--kernel auto` chose compute.
        fallback: Option<FragmentKernel>,
    },
}

impl Plan {
    /// The plan of `opts` over the structure `accel` built for them, on the GPU described
    /// by `gl`, or on the CPU (None). The GPU's kernel is resolved by
    /// [`crate::gpu::options::GpuOptions::choose_kernel`], which refuses the options that
    /// do not apply to it.
    pub fn resolve(opts: &RenderOptions, accel: AccelKind, gl: Option<&GlInfo>) -> Result<Plan> {
        let Some(info) = gl else {
            return Ok(Plan::Cpu {
                accel,
                precision: opts.precision,
                path: opts.cpu_path,
            });
        };
        Ok(match opts.gpu.choose_kernel(info)? {
            KernelChoice::Fragment(kernel) => Plan::Fragment {
                accel,
                kernel,
                mask: opts.gpu.mask.resolve(kernel),
                storage: opts.gpu.storage,
            },
            KernelChoice::Compute { fallback } => Plan::Compute {
                accel,
                scene_fetch: opts.gpu.scene_fetch,
                fallback,
            },
        })
    }

    /// The structure walked.
    pub fn accel(&self) -> AccelKind {
        match *self {
            Plan::Cpu { accel, .. }
            | Plan::Fragment { accel, .. }
            | Plan::Compute { accel, .. } => accel,
        }
    }

    /// The backend, as `--backend` names it: `cpu` or `gl`.
    pub fn backend(&self) -> &'static str {
        match self {
            Plan::Cpu { .. } => "cpu",
            Plan::Fragment { .. } | Plan::Compute { .. } => "gl",
        }
    }

    /// The arithmetic: the CPU's choice, f32 on the GPU.
    pub fn precision(&self) -> Precision {
        match *self {
            Plan::Cpu { precision, .. } => precision,
            Plan::Fragment { .. } | Plan::Compute { .. } => Precision::F32,
        }
    }

    /// The GPU kernel planned, None on the CPU.
    pub fn kernel(&self) -> Option<Kernel> {
        match *self {
            Plan::Cpu { .. } => None,
            Plan::Fragment { kernel, .. } => Some(kernel.kernel()),
            Plan::Compute { .. } => Some(Kernel::Compute),
        }
    }
}

/// The plan as the flags that ask for it, each `auto` resolved, in a fixed order:
/// `--backend cpu --accel bvh --precision f64 --cpu-path simd`,
/// `--backend gl --accel irregular --kernel looped --mask none --storage f32`, or
/// `--backend gl --accel irregular --kernel compute --scene-fetch auto`, with
/// ` --fallback K` where `auto` keeps a fragment kernel in reserve.
impl fmt::Display for Plan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "--backend {} --accel {}",
            self.backend(),
            self.accel().name()
        )?;
        match self {
            Plan::Cpu {
                precision, path, ..
            } => write!(
                f,
                " --precision {} --cpu-path {}",
                precision.name(),
                path.name()
            ),
            Plan::Fragment {
                kernel,
                mask,
                storage,
                ..
            } => write!(f, " --kernel {kernel} --mask {mask} --storage {storage}"),
            Plan::Compute {
                scene_fetch,
                fallback,
                ..
            } => {
                write!(f, " --kernel compute --scene-fetch {scene_fetch}")?;
                match fallback {
                    Some(k) => write!(f, " --fallback {k}"),
                    None => Ok(()),
                }
            }
        }
    }
}

/// A word of a plan's text as the value type `T` spells it.
fn word<T: ValueEnum>(key: &str, v: &str) -> std::result::Result<T, String> {
    T::from_str(v, false).map_err(|_| format!("--{key} {v}: not a value it takes"))
}

/// A fragment kernel's name.
fn fragment_kernel(v: &str) -> std::result::Result<FragmentKernel, String> {
    match v.parse::<Kernel>()? {
        Kernel::Multipass => Ok(FragmentKernel::Multipass),
        Kernel::Looped => Ok(FragmentKernel::Looped),
        Kernel::Unrolled(k) => Ok(FragmentKernel::Unrolled(k)),
        Kernel::Compute | Kernel::Auto => Err(format!("`{v}` is not a fragment kernel")),
    }
}

/// The `--flag value` pairs of a line of canonical flags (a plan's text, a part header's
/// options), each flag once: what [`Plan::from_pairs`] and the part header's reader take
/// their values from.
pub(crate) fn flag_pairs(s: &str) -> std::result::Result<FlagPairs<'_>, String> {
    let words: Vec<&str> = s.split_whitespace().collect();
    if !words.len().is_multiple_of(2) {
        return Err(format!("`{s}`: expected pairs of --flag value"));
    }
    let mut pairs = std::collections::BTreeMap::new();
    for p in words.chunks(2) {
        let key = p[0]
            .strip_prefix("--")
            .ok_or_else(|| format!("`{}` is not a flag", p[0]))?;
        if pairs.insert(key, p[1]).is_some() {
            return Err(format!("--{key} given twice"));
        }
    }
    Ok(FlagPairs { text: s, pairs })
}

/// A line's flags not yet taken ([`flag_pairs`]).
pub(crate) struct FlagPairs<'a> {
    text: &'a str,
    pairs: std::collections::BTreeMap<&'a str, &'a str>,
}

impl<'a> FlagPairs<'a> {
    /// Takes the value of `--key`, which must be there.
    pub(crate) fn take(&mut self, key: &str) -> std::result::Result<&'a str, String> {
        self.pairs
            .remove(key)
            .ok_or_else(|| format!("`{}`: --{key} is missing", self.text))
    }

    /// Takes the value of `--key` where it is there.
    pub(crate) fn take_opt(&mut self, key: &str) -> Option<&'a str> {
        self.pairs.remove(key)
    }

    /// Takes `--key`'s value, parsed by `T`'s `FromStr`.
    pub(crate) fn parse<T: FromStr>(&mut self, key: &str) -> std::result::Result<T, String> {
        let v = self.take(key)?;
        v.parse()
            .map_err(|_| format!("--{key} {v}: not a value it takes"))
    }

    /// Every flag taken, or the error naming the first left over.
    pub(crate) fn finish(self) -> std::result::Result<(), String> {
        match self.pairs.keys().next() {
            Some(extra) => Err(format!("`{}`: --{extra} is not part of it", self.text)),
            None => Ok(()),
        }
    }
}

impl Plan {
    /// Takes the plan's flags (those [`Display`](fmt::Display) writes) out of `pairs`.
    pub(crate) fn from_pairs(pairs: &mut FlagPairs<'_>) -> std::result::Result<Plan, String> {
        let accel: AccelKind = word("accel", pairs.take("accel")?)?;
        Ok(match pairs.take("backend")? {
            "cpu" => Plan::Cpu {
                accel,
                precision: word("precision", pairs.take("precision")?)?,
                path: word("cpu-path", pairs.take("cpu-path")?)?,
            },
            "gl" => match pairs.take("kernel")? {
                "compute" => Plan::Compute {
                    accel,
                    scene_fetch: word("scene-fetch", pairs.take("scene-fetch")?)?,
                    fallback: pairs
                        .take_opt("fallback")
                        .map(fragment_kernel)
                        .transpose()?,
                },
                k => Plan::Fragment {
                    accel,
                    kernel: fragment_kernel(k)?,
                    mask: word("mask", pairs.take("mask")?)?,
                    storage: word("storage", pairs.take("storage")?)?,
                },
            },
            b => return Err(format!("--backend {b}: a plan runs on cpu or gl")),
        })
    }
}

impl FromStr for Plan {
    type Err = String;

    /// Reads what [`Display`](fmt::Display) writes (and nothing else: every flag of the
    /// backend once, no other).
    fn from_str(s: &str) -> std::result::Result<Plan, String> {
        let mut pairs = flag_pairs(s)?;
        let plan = Plan::from_pairs(&mut pairs)?;
        pairs.finish()?;
        Ok(plan)
    }
}

/// Serialized as its text (`--stats`).
impl serde::Serialize for Plan {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every plan reads back from its text, and text that is not a plan is refused.
    #[test]
    fn display_round_trips() {
        let plans = [
            Plan::Cpu {
                accel: AccelKind::Bvh,
                precision: Precision::F64,
                path: CpuPath::Simd,
            },
            Plan::Cpu {
                accel: AccelKind::Uniform,
                precision: Precision::F32,
                path: CpuPath::Scalar,
            },
            Plan::Fragment {
                accel: AccelKind::Irregular,
                kernel: FragmentKernel::Unrolled(16),
                mask: Mask::Stencil,
                storage: Storage::F16,
            },
            Plan::Fragment {
                accel: AccelKind::Uniform,
                kernel: FragmentKernel::Multipass,
                mask: Mask::EarlyZ,
                storage: Storage::F32,
            },
            Plan::Compute {
                accel: AccelKind::Irregular,
                scene_fetch: SceneFetch::TexelFetch,
                fallback: Some(FragmentKernel::Looped),
            },
            Plan::Compute {
                accel: AccelKind::Irregular,
                scene_fetch: SceneFetch::Auto,
                fallback: None,
            },
        ];
        for p in plans {
            let text = p.to_string();
            assert_eq!(text.parse::<Plan>(), Ok(p), "{text}");
        }
        assert_eq!(
            plans[4].to_string(),
            "--backend gl --accel irregular --kernel compute --scene-fetch texel-fetch --fallback looped"
        );
        for bad in [
            "--backend cpu --accel bvh --precision f64",
            "--backend cpu --accel bvh --precision f64 --cpu-path simd --mask none",
            "--backend gl --accel irregular --kernel auto --mask none --storage f32",
            "--backend gl --accel irregular --kernel looped --mask none",
            "--backend vulkan --accel irregular",
            "--backend cpu --accel bvh --accel bvh --precision f64 --cpu-path simd",
        ] {
            assert!(bad.parse::<Plan>().is_err(), "{bad}");
        }
    }
}
