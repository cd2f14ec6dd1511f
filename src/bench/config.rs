//! Bench configurations and inputs: the shipped configurations and presets, configuration
//! files, `--size` and `--scenes`. Everything here is resolved (and bad input refused as a
//! usage error) before the first render.

use std::path::{Path, PathBuf};

use crate::choices::{Door, RenderArgs};
use crate::options::MAX_IMAGE_SIDE;
use crate::scene;
use crate::{Error, Result};

/// One shipped configuration: a name, its `render` arguments and the presets it is in
/// (`all` holds every row).
#[derive(Clone, Copy, Debug)]
pub struct ConfigRow {
    /// Name used in `--configs`, the tables and the plot.
    pub name: &'static str,
    /// `render` arguments, separated by white space.
    pub args: &'static str,
    /// Presets besides `all` that include this row.
    pub presets: &'static [&'static str],
}

const D: &[&str] = &["default"];
const DQ: &[&str] = &["default", "quick"];
const A: &[&str] = &[];

/// The shipped configurations and their presets.
pub const CONFIG_TABLE: &[ConfigRow] = &[
    ConfigRow {
        name: "cpu-f64",
        args: "--backend cpu --precision f64 --accel irregular",
        presets: DQ,
    },
    ConfigRow {
        name: "cpu-f32",
        args: "--backend cpu --precision f32 --accel irregular --cpu-path simd",
        presets: DQ,
    },
    ConfigRow {
        name: "cpu-f32-scalar",
        args: "--backend cpu --precision f32 --accel irregular --cpu-path scalar",
        presets: D,
    },
    ConfigRow {
        name: "cpu-f32-uniform",
        args: "--backend cpu --precision f32 --accel uniform",
        presets: D,
    },
    ConfigRow {
        name: "cpu-f32-bvh",
        args: "--backend cpu --precision f32 --accel bvh --cpu-path simd",
        presets: DQ,
    },
    ConfigRow {
        name: "cpu-f32-bvh-packet",
        args: "--backend cpu --precision f32 --accel bvh --cpu-path packet",
        presets: DQ,
    },
    ConfigRow {
        name: "cpu-f32-bvh-scalar",
        args: "--backend cpu --precision f32 --accel bvh --cpu-path scalar",
        presets: D,
    },
    ConfigRow {
        name: "gl-looped",
        args: "--backend gl --kernel looped",
        presets: DQ,
    },
    ConfigRow {
        name: "gl-looped-uniform",
        args: "--backend gl --kernel looped --accel uniform",
        presets: D,
    },
    ConfigRow {
        name: "gl-compute",
        args: "--backend gl --kernel compute",
        presets: D,
    },
    ConfigRow {
        name: "gl-compute-steady",
        args: "--backend gl --kernel compute --steady",
        presets: D,
    },
    ConfigRow {
        name: "gl-compute-uniform",
        args: "--backend gl --kernel compute --accel uniform",
        presets: A,
    },
    ConfigRow {
        name: "gl-compute-texel-fetch",
        args: "--backend gl --kernel compute --scene-fetch texel-fetch",
        presets: A,
    },
    ConfigRow {
        name: "gl-compute-storage-buffer",
        args: "--backend gl --kernel compute --scene-fetch storage-buffer",
        presets: A,
    },
    ConfigRow {
        name: "gl-unrolled:16",
        args: "--backend gl --kernel unrolled:16",
        presets: D,
    },
    ConfigRow {
        name: "gl-multipass",
        args: "--backend gl --kernel multipass",
        presets: D,
    },
    ConfigRow {
        name: "gl-multipass-uniform",
        args: "--backend gl --kernel multipass --accel uniform",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-no-specialize",
        args: "--backend gl --kernel looped --no-specialize",
        presets: D,
    },
    ConfigRow {
        name: "gl-looped-f16",
        args: "--backend gl --kernel looped --storage f16",
        presets: DQ,
    },
    ConfigRow {
        name: "gl-multipass-early-z",
        args: "--backend gl --kernel multipass --mask early-z",
        presets: D,
    },
    ConfigRow {
        name: "gl-multipass-stencil",
        args: "--backend gl --kernel multipass --mask stencil",
        presets: D,
    },
    ConfigRow {
        name: "gl-unrolled:16-k64",
        args: "--backend gl --kernel unrolled:16 --query-every 64",
        presets: D,
    },
    ConfigRow {
        name: "gl-looped-k1",
        args: "--backend gl --kernel looped --query-every 1",
        presets: A,
    },
    ConfigRow {
        name: "gl-unrolled:4",
        args: "--backend gl --kernel unrolled:4",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-k32",
        args: "--backend gl --kernel looped --query-every 32",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-early-z",
        args: "--backend gl --kernel looped --mask early-z",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-stencil",
        args: "--backend gl --kernel looped --mask stencil",
        presets: A,
    },
    ConfigRow {
        name: "gl-multipass-k1",
        args: "--backend gl --kernel multipass --query-every 1",
        presets: A,
    },
    ConfigRow {
        name: "gl-multipass-k32",
        args: "--backend gl --kernel multipass --query-every 32",
        presets: A,
    },
    ConfigRow {
        name: "gl-multipass-f16",
        args: "--backend gl --kernel multipass --storage f16",
        presets: A,
    },
    ConfigRow {
        name: "gl-unrolled:16-f16",
        args: "--backend gl --kernel unrolled:16 --storage f16",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-moller-trumbore",
        args: "--backend gl --kernel looped --intersect moller-trumbore",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-no-t-bound",
        args: "--backend gl --kernel looped --t-bound off",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-epsilon",
        args: "--backend gl --kernel looped --offset epsilon",
        presets: A,
    },
    ConfigRow {
        name: "cpu-f32-moller-trumbore",
        args: "--backend cpu --precision f32 --accel irregular --intersect moller-trumbore",
        presets: A,
    },
    ConfigRow {
        name: "cpu-f32-epsilon",
        args: "--backend cpu --precision f32 --accel irregular --offset epsilon",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-density-1",
        args: "--backend gl --kernel looped --accel uniform --grid-density 1",
        presets: A,
    },
    ConfigRow {
        name: "gl-looped-density-4",
        args: "--backend gl --kernel looped --accel uniform --grid-density 4",
        presets: A,
    },
];

/// Preset names accepted by `--configs`.
pub const PRESETS: &[&str] = &["default", "quick", "all"];

/// A configuration to run: a name, its argument string and the parsed arguments.
#[derive(Clone, Debug)]
pub struct BenchConfig {
    /// Name shown in the tables and the plot.
    pub name: String,
    /// The `render` arguments as written.
    pub args: String,
    /// The parsed arguments (scene, size, output and quiet are set by the bench).
    pub render: RenderArgs,
    /// `--steady`: time frames 2..N of one renderer (scene uploaded, programs compiled
    /// once) instead of whole renders; the warm-up is the first frame.
    pub steady: bool,
}

impl BenchConfig {
    /// Parses a configuration; a clear [`Error::Usage`] names it when its arguments are
    /// not valid `render` arguments or set what the bench decides (scene, size, outputs).
    pub fn parse(name: &str, args: &str) -> Result<Self> {
        let bad = |msg: String| Error::Usage(format!("configuration `{name}` (`{args}`): {msg}"));
        if name.trim().is_empty() || name.contains(',') {
            return Err(bad(
                "a configuration name must be non-empty and hold no comma".into(),
            ));
        }
        // `--steady` is the bench's own: the configuration's renders are frames 2..N of one
        // renderer (the scene uploaded and the programs compiled once), not fresh renders.
        let steady = args.split_whitespace().any(|w| w == "--steady");
        let words: Vec<&str> = args
            .split_whitespace()
            .filter(|w| *w != "--steady")
            .collect();
        for w in &words {
            let flag = w.split('=').next().unwrap_or(w);
            if ["-o", "--output", "--width", "--height", "--stats", "--aov"].contains(&flag)
                || (w.starts_with("-o") && !w.starts_with("--"))
            {
                return Err(bad(format!(
                    "`{flag}` is set by the bench, not by a configuration"
                )));
            }
        }
        let render = RenderArgs::try_parse_from_args(&words).map_err(|e| bad(e.to_string()))?;
        if let Some(s) = &render.scene {
            return Err(bad(format!(
                "unexpected argument `{}` (the scene is chosen with --scenes)",
                s.display()
            )));
        }
        // Value checks that the parser leaves to `Choices::to_options` (ranges, grid
        // density), and the flags that do not apply, at the bench's door.
        render
            .choices
            .to_options(&scene::builtin_scene(), Door::Bench)
            .map_err(|e| bad(e.to_string()))?;
        let mut args = words.join(" ");
        if steady {
            args.push_str(" --steady");
        }
        Ok(BenchConfig {
            name: name.trim().to_string(),
            args,
            render,
            steady,
        })
    }
}

/// Resolves `--configs`: a preset name ([`PRESETS`]), a TOML file (`[configs] name =
/// "args"`, in file order), or comma-separated names from [`CONFIG_TABLE`].
pub fn resolve_configs(spec: &str) -> Result<Vec<BenchConfig>> {
    let spec = spec.trim();
    let path = Path::new(spec);
    let configs = if PRESETS.contains(&spec) {
        CONFIG_TABLE
            .iter()
            .filter(|r| spec == "all" || r.presets.contains(&spec))
            .map(|r| BenchConfig::parse(r.name, r.args))
            .collect::<Result<Vec<_>>>()?
    } else if spec.ends_with(".toml") || path.is_file() {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        parse_config_file(&text, &path.display().to_string())?
    } else {
        spec.split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(|name| match CONFIG_TABLE.iter().find(|r| r.name == name) {
                Some(r) => BenchConfig::parse(r.name, r.args),
                None => Err(Error::Usage(format!(
                    "unknown configuration `{name}`: --configs takes a preset ({}), a TOML file, or names from: {}",
                    PRESETS.join(", "),
                    CONFIG_TABLE.iter().map(|r| r.name).collect::<Vec<_>>().join(", ")
                ))),
            })
            .collect::<Result<Vec<_>>>()?
    };
    if configs.is_empty() {
        return Err(Error::Usage(format!(
            "--configs `{spec}` names no configuration"
        )));
    }
    let mut seen = std::collections::HashSet::new();
    for c in &configs {
        if !seen.insert(c.name.clone()) {
            return Err(Error::Usage(format!(
                "configuration `{}` is named twice",
                c.name
            )));
        }
    }
    Ok(configs)
}

/// Parses a configuration file: a TOML table `[configs]` of `name = "render args"`,
/// kept in file order. `origin` names the file in messages.
pub fn parse_config_file(text: &str, origin: &str) -> Result<Vec<BenchConfig>> {
    let doc: toml::Table =
        toml::from_str(text).map_err(|e| Error::Usage(format!("{origin}: {}", e.message())))?;
    let unknown: Vec<&String> = doc.keys().filter(|k| *k != "configs").collect();
    if !unknown.is_empty() {
        return Err(Error::Usage(format!(
            "{origin}: unknown table or key `{}` (expected only [configs])",
            unknown[0]
        )));
    }
    let Some(table) = doc.get("configs").and_then(|v| v.as_table()) else {
        return Err(Error::Usage(format!(
            "{origin}: no [configs] table (expected `[configs]` with lines `name = \"render args\"`)"
        )));
    };
    // toml::Table sorts its keys; recover the file order from the key positions.
    let mut named: Vec<(usize, &String, &toml::Value)> = table
        .iter()
        .map(|(k, v)| (key_position(text, k), k, v))
        .collect();
    named.sort_by_key(|(pos, k, _)| (*pos, (*k).clone()));
    named
        .into_iter()
        .map(|(_, name, value)| match value.as_str() {
            Some(args) => {
                BenchConfig::parse(name, args).map_err(|e| Error::Usage(format!("{origin}: {e}")))
            }
            None => Err(Error::Usage(format!(
                "{origin}: configs.{name}: expected a string of render arguments, found {}",
                value.type_str()
            ))),
        })
        .collect()
}

/// Where `key` is defined in `text` (bare or quoted), for ordering; `usize::MAX` if not found.
fn key_position(text: &str, key: &str) -> usize {
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        let t = line.trim_start();
        for cand in [key.to_string(), format!("\"{key}\""), format!("'{key}'")] {
            if let Some(rest) = t.strip_prefix(&cand) {
                if rest.trim_start().starts_with('=') {
                    return offset;
                }
            }
        }
        offset += line.len();
    }
    usize::MAX
}

/// Image size for `--size WxH`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Size {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl std::str::FromStr for Size {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let bad = || format!("size `{s}` is not WxH with both in 1..={}", MAX_IMAGE_SIDE);
        let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
        let side = |v: &str| {
            v.trim()
                .parse::<u32>()
                .ok()
                .filter(|v| (1..=MAX_IMAGE_SIDE).contains(v))
        };
        match (side(w), side(h)) {
            (Some(width), Some(height)) => Ok(Size { width, height }),
            _ => Err(bad()),
        }
    }
}

impl std::fmt::Display for Size {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

/// The folder of the shipped scenes: `scenes/` in the working directory when it holds a
/// scene file, else the one in the source tree fragtrace was built from.
pub fn shipped_scenes_dir() -> PathBuf {
    let local = PathBuf::from("scenes");
    if !scene_files(&local).is_empty() {
        local
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
    }
}

/// The stems of the `.toml` files in `dir`, sorted (none when it cannot be read).
fn scene_files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = match std::fs::read_dir(dir) {
        Ok(rd) => rd
            .filter_map(|e| e.ok())
            .map(|e| e.path())
            .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "toml"))
            .filter_map(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
            .collect(),
        Err(_) => Vec::new(),
    };
    v.sort();
    v
}

/// A scene to bench: its name and where it comes from (`None`: the built-in).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneSpec {
    /// Name in the tables (file stem).
    pub name: String,
    /// Scene file; `None` for the built-in `whitted`.
    pub path: Option<PathBuf>,
}

/// Resolves `--scenes`: comma-separated names of files in [`shipped_scenes_dir`] (`whitted`
/// is the built-in scene) or paths to scene files; `None` means every shipped scene.
pub fn resolve_scenes(spec: Option<&str>) -> Result<Vec<SceneSpec>> {
    let dir = shipped_scenes_dir();
    let names: Vec<String> = match spec {
        Some(s) => s
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(String::from)
            .collect(),
        None => {
            let v = scene_files(&dir);
            if v.is_empty() {
                return Err(Error::Usage(format!(
                    "no scene to bench: neither ./scenes nor {} holds a .toml file; name \
                     scenes with --scenes (whitted is the built-in scene, or paths to scene \
                     files)",
                    dir.display()
                )));
            }
            v
        }
    };
    if names.is_empty() {
        return Err(Error::Usage("--scenes names no scene".into()));
    }
    let mut out: Vec<SceneSpec> = Vec::new();
    for n in names {
        let spec = if n == "whitted" || n == "builtin" {
            SceneSpec {
                name: "whitted".into(),
                path: None,
            }
        } else if n.ends_with(".toml") || n.contains('/') {
            let p = PathBuf::from(&n);
            SceneSpec {
                name: p
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or(n.clone()),
                path: Some(p),
            }
        } else {
            let p = dir.join(format!("{n}.toml"));
            if !p.is_file() {
                return Err(Error::Usage(format!(
                    "unknown scene `{n}`: no {} (give a name of a file in {} or a path to a scene file)",
                    p.display(),
                    dir.display()
                )));
            }
            SceneSpec {
                name: n.clone(),
                path: Some(p),
            }
        };
        if out.iter().any(|s| s.name == spec.name) {
            return Err(Error::Usage(format!(
                "scene `{}` is named twice",
                spec.name
            )));
        }
        out.push(spec);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_shipped_configuration_parses_and_presets_resolve() {
        for r in CONFIG_TABLE {
            BenchConfig::parse(r.name, r.args).unwrap();
            // A row measures one kernel whatever the default (`auto`) resolves to.
            assert!(
                !r.args.contains("--backend gl") || r.args.contains("--kernel "),
                "{}: a GL row must name its kernel",
                r.name
            );
        }
        assert_eq!(resolve_configs("all").unwrap().len(), CONFIG_TABLE.len());
        let default: Vec<String> = resolve_configs("default")
            .unwrap()
            .into_iter()
            .map(|c| c.name)
            .collect();
        assert_eq!(default.len(), 18);
        assert!(default.iter().any(|c| c == "gl-compute"), "{default:?}");
        for bvh in ["cpu-f32-bvh", "cpu-f32-bvh-packet", "cpu-f32-bvh-scalar"] {
            assert!(default.iter().any(|c| c == bvh), "{bvh}: {default:?}");
        }
        assert_eq!(default[0], "cpu-f64");
        let quick = resolve_configs("quick").unwrap();
        assert!(quick.len() >= 3 && quick.iter().any(|c| c.name == "cpu-f64"));
        let two = resolve_configs("gl-looped, cpu-f32").unwrap();
        assert_eq!(
            (two[0].name.as_str(), two[1].name.as_str()),
            ("gl-looped", "cpu-f32")
        );
        assert_eq!(
            two[0].render.choices.kernel,
            crate::gpu::options::Kernel::Looped
        );
    }

    #[test]
    fn bad_configurations_are_refused_clearly() {
        let e = resolve_configs("gl-looped,nope").unwrap_err().to_string();
        assert!(
            e.contains("unknown configuration `nope`") && e.contains("gl-multipass"),
            "{e}"
        );
        for (args, want) in [
            ("--kernel warp", "unknown kernel"),
            ("--frobnicate", "--frobnicate"),
            ("--query-every 0", "--query-every"),
            ("--width 10", "set by the bench"),
            ("-o x.png", "set by the bench"),
            ("scenes/cornell.toml", "--scenes"),
        ] {
            let e = BenchConfig::parse("x", args).unwrap_err();
            assert_eq!(e.exit_code(), 2);
            let e = e.to_string();
            assert!(
                e.contains("configuration `x`") && e.contains(want),
                "{args}: {e}"
            );
        }
    }

    #[test]
    fn config_files_keep_their_order() {
        let text = "[configs]\nzeta = \"--backend cpu\"\n\"gl-k4\" = \"--backend gl --query-every 4\"\nalpha = \"--backend cpu --precision f32\"\n";
        let c = parse_config_file(text, "c.toml").unwrap();
        let names: Vec<&str> = c.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["zeta", "gl-k4", "alpha"]);
        assert_eq!(c[1].render.choices.query_every, Some(4));
        for bad in [
            "[configs]\na = 3\n",
            "x = 1\n",
            "[configs]\na = \"--nope\"\n",
            "[configs\n",
        ] {
            let e = parse_config_file(bad, "c.toml").unwrap_err();
            assert_eq!(e.exit_code(), 2);
            assert!(e.to_string().starts_with("c.toml: "), "{e}");
        }
    }

    #[test]
    fn sizes_and_scenes() {
        assert_eq!(
            "32x24".parse::<Size>().unwrap(),
            Size {
                width: 32,
                height: 24
            }
        );
        for bad in ["32", "0x4", "axb", "32x99999"] {
            assert!(bad.parse::<Size>().is_err(), "{bad}");
        }
        let all = resolve_scenes(None).unwrap();
        assert!(all.iter().any(|s| s.name == "whitted" && s.path.is_none()));
        assert!(all.iter().any(|s| s.name == "cornell"));
        let two = resolve_scenes(Some("whitted,cornell")).unwrap();
        assert_eq!(two[0].path, None);
        assert!(two[1].path.as_ref().unwrap().ends_with("cornell.toml"));
        assert!(resolve_scenes(Some("nope")).is_err());
        assert!(resolve_scenes(Some("whitted,builtin")).is_err());
    }
}
