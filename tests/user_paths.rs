//! What a new user runs into, through the real binary: messages that say what is wrong
//! (each one line, exit 2), `compare` saying which bound failed, `--help` text, AOV
//! previews and comparing an AOV channel.

mod common;

use common::words;

use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};

const CAM: &str = "[camera]\neye = [0, 1, 5]\nlook_at = [0, 1, 0]\nfov = 45\n";

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fragtrace-user-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(dir: &Path, name: &str, bytes: impl AsRef<[u8]>) {
    std::fs::write(dir.join(name), bytes).unwrap();
}

fn run_in(dir: &Path, args: &[&str]) -> Output {
    common::bin()
        .current_dir(dir)
        .args(args)
        .env_remove("FRAGTRACE_GL_LIMITS")
        .env("FRAGTRACE_MODEL_PATH", dir.join("no-models"))
        .stdin(Stdio::null())
        .output()
        .unwrap()
}

/// Exit 2 and exactly one `fragtrace: error:` line holding every needle; returns the line.
fn fails(dir: &Path, args: &[&str], needles: &[&str]) -> String {
    let out = run_in(dir, args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(lines.len(), 1, "{args:?}: not one line: {err}");
    assert!(
        lines[0].starts_with("fragtrace: error: "),
        "{args:?}: {err}"
    );
    for n in needles {
        assert!(lines[0].contains(n), "{args:?}: `{}` lacks `{n}`", lines[0]);
    }
    lines[0].to_owned()
}

/// A CPU render of the built-in scene at 32x24 into `out` (extra flags appended).
fn render(dir: &Path, out: &str, extra: &[&str]) {
    let mut args = vec![
        "render",
        "--backend",
        "cpu",
        "--width",
        "32",
        "--height",
        "24",
        "-q",
        "-o",
        out,
    ];
    args.extend_from_slice(extra);
    let o = run_in(dir, &args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn output_paths_say_what_is_wrong_with_them() {
    let d = tmpdir("out");
    std::fs::create_dir_all(d.join("pics")).unwrap();
    // An existing folder: said to be one, not "unknown image extension".
    let line = fails(
        &d,
        &["render", "-o", "pics"],
        &["pics", "is a directory (a folder)"],
    );
    assert!(!line.contains("extension"), "{line}");
    fails(
        &d,
        &["render", "-o", "pics/"],
        &["a directory (a folder)", "pics/out.png"],
    );
    // A folder that does not exist, and one that exists but cannot be written.
    fails(
        &d,
        &["render", "-o", "nope/x.png"],
        &["folder nope does not exist", "--mkdir makes it"],
    );
    assert!(!d.join("nope").exists());
    // --mkdir makes the folders asked for (image and statistics).
    render(
        &d,
        "made/deep/x.png",
        &["--mkdir", "--stats", "made/s/x.json"],
    );
    assert!(d.join("made/deep/x.png").is_file() && d.join("made/s/x.json").is_file());
    if Path::new("/proc").is_dir() {
        let line = fails(
            &d,
            &["render", "-o", "/proc/x.png"],
            &["folder /proc exists but is not writable"],
        );
        assert!(!line.contains("(os error"), "{line}");
    }
}

#[test]
fn scene_messages_name_the_real_problem() {
    let d = tmpdir("scene");
    for (name, text, needles) in [
        (
            "up.toml",
            format!("{CAM}up = [0, 0, 0]\n"),
            vec!["up.toml:5: camera.up:", "[0, 0, 0]", "no direction"],
        ),
        (
            "nocam.toml",
            "background = [0, 0, 0]\n[[lights]]\nposition = [0, 1, 0]\n".to_owned(),
            vec!["nocam.toml:1: camera:", "no `[camera]` table"],
        ),
        (
            "empty.toml",
            String::new(),
            vec!["empty.toml:1: camera:", "no `[camera]` table"],
        ),
        (
            "garbage.toml",
            "}}}} {{\n".to_owned(),
            vec!["garbage.toml:1: at `}}}} {{`:"],
        ),
    ] {
        write(&d, name, text);
        let line = fails(
            &d,
            &["render", name, "--backend", "cpu", "-o", "x.png"],
            &needles,
        );
        assert!(
            !line.contains("parallel") && !line.contains("background"),
            "{line}"
        );
    }
    write(&d, "bin.toml", b"ambient = 1\n# \xff\xfe\n");
    fails(
        &d,
        &["render", "bin.toml", "-o", "x.png"],
        &["bin.toml:2: column 3: invalid UTF-8 (byte 0xff)"],
    );
}

#[test]
fn command_line_slips_get_a_useful_message() {
    let d = tmpdir("cli");
    // A negative number is an invalid value, not an argument to put after `--`.
    for (flag, v) in [("--width", "-5"), ("--spp", "-1"), ("--max-depth", "-2")] {
        let line = fails(
            &d,
            &["render", flag, v, "-o", "x.png"],
            &[flag, v, "negative"],
        );
        assert!(!line.contains("-- "), "{line}");
    }
    let line = fails(&d, &["--height", "-3"], &["--height", "negative"]);
    assert!(!line.contains("tip"), "{line}");
    // The expected range is the flag's own: 0 is no width, and no depth is negative.
    for (flag, range) in [
        ("--width", "1..=16384"),
        ("--spp", "1..=1024"),
        ("--query-every", "1..=4096"),
        ("--max-depth", "0..=16"),
    ] {
        let line = fails(&d, &["render", flag, "-5", "-o", "x.png"], &[flag, range]);
        assert!(!line.contains(">= 0"), "{line}");
    }
    // A mistyped subcommand is not a scene file.
    for (typo, meant) in [
        ("rendr", "render"),
        ("comapre", "compare"),
        ("ifno", "info"),
    ] {
        fails(
            &d,
            &[typo],
            &[&format!(
                "no such file `{typo}`; did you mean the subcommand `{meant}`?"
            )],
        );
    }
    // A real file of that name is still a scene.
    write(&d, "rendr", "not toml at all = = =\n");
    let line = fails(&d, &["rendr", "-o", "x.png"], &["rendr:1:"]);
    assert!(!line.contains("subcommand"), "{line}");
}

#[test]
fn render_help_shows_defaults_and_no_rustdoc_links() {
    let d = tmpdir("help");
    let out = run_in(&d, &["render", "--help"]);
    assert!(out.status.success());
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(!help.contains("[`"), "{help}");
    let density = help
        .split("--grid-density")
        .nth(1)
        .and_then(|s| s.split("\n      -").next())
        .unwrap();
    // No clap default (the flag means a different density per structure): both are named.
    assert!(
        density.contains("default 8") && density.contains("default 0.125"),
        "{density}"
    );
}

#[test]
fn compare_says_which_bound_failed_and_rejects_bad_numbers() {
    let d = tmpdir("compare");
    render(&d, "a.png", &[]);
    render(&d, "b.png", &["--spp", "4"]);
    let out = run_in(
        &d,
        &words("compare a.png b.png --max-rmse 1e-6 --max-flip 0.5"),
    );
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(
        lines[0].contains("RMSE") && lines[0].contains("exceeds --max-rmse 0.000001 by"),
        "{err}"
    );
    // Within both bounds: exit 0, nothing on stderr.
    let out = run_in(&d, &words("compare a.png a.png --max-rmse 0 --max-flip 0"));
    assert_eq!(out.status.code(), Some(0));
    assert!(out.stderr.is_empty());
    for (flag, v) in [
        ("--threshold", "-1"),
        ("--threshold", "nan"),
        ("--max-rmse", "-0.5"),
        ("--max-flip", "inf"),
        ("--gain", "-2"),
    ] {
        fails(
            &d,
            &["compare", "a.png", "b.png", flag, v],
            &[flag, "must be a finite number >= 0"],
        );
    }
}

#[test]
fn aov_previews_are_written_beside_the_exr() {
    let d = tmpdir("aov");
    render(&d, "r.png", &["--aov", "depth,normal,primid,steps"]);
    for name in [
        "r.aov.exr",
        "r.depth.png",
        "r.normal.png",
        "r.primid.png",
        "r.steps.png",
    ] {
        assert!(d.join(name).is_file(), "{name} missing");
    }
    let ids = image::open(d.join("r.primid.png")).unwrap().to_rgb8();
    let depth = image::open(d.join("r.depth.png")).unwrap().to_rgb8();
    // The built-in scene has background at the top corner and geometry at the bottom
    // centre: a miss is black in both previews, a hit is not.
    assert_eq!(ids.get_pixel(0, 0).0, [0, 0, 0]);
    assert_eq!(depth.get_pixel(0, 0).0, [0, 0, 0]);
    assert_ne!(ids.get_pixel(16, 23).0, [0, 0, 0]);
    assert_ne!(depth.get_pixel(16, 23).0, [0, 0, 0]);
    // Several triangles, several colours.
    let colours: std::collections::BTreeSet<[u8; 3]> = ids.pixels().map(|p| p.0).collect();
    assert!(colours.len() > 3, "{colours:?}");
}

#[test]
fn compare_reads_a_named_aov_channel() {
    let d = tmpdir("channel");
    render(&d, "a.png", &["--aov", "depth,primid"]);
    render(&d, "b.png", &["--aov", "depth,primid"]);
    // Same render: identical depth, misses (+inf) included.
    let out = run_in(
        &d,
        &words("compare a.aov.exr b.aov.exr --channel depth --max-rmse 0"),
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.starts_with("RMSE 0.000000"), "{text}");
    // A different camera: hits against misses are infinitely far apart.
    write(&d, "moved.toml", "[camera]\neye = [0, 3, 9]\nlook_at = [0, 0, 0]\nfov = 30\n[[objects]]\nshape = \"sphere\"\n");
    let o = run_in(
        &d,
        &words("render moved.toml --backend cpu --width 32 --height 24 -q -o m.png --aov depth"),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = run_in(
        &d,
        &["compare", "a.aov.exr", "m.aov.exr", "--channel", "depth"],
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.starts_with("RMSE inf"), "{text}");
    // A channel the file lacks, and a PNG, are bad input.
    fails(
        &d,
        &["compare", "a.aov.exr", "b.aov.exr", "--channel", "steps"],
        &["a.aov.exr", "no channel `steps`", "depth", "primid"],
    );
    fails(
        &d,
        &["compare", "a.png", "b.png", "--channel", "depth"],
        &["a.png", "EXR files only"],
    );
}

/// The README's recipe for the models (next to the two commands) makes every shipped
/// scene load.
#[test]
fn readme_model_path_recipe_loads_every_shipped_scene() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let section = readme
        .split("## The two commands")
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .unwrap();
    let export = section
        .lines()
        .find_map(|l| l.trim().strip_prefix("export FRAGTRACE_MODEL_PATH=$PWD/"))
        .expect("the two-commands section shows how to set FRAGTRACE_MODEL_PATH");
    let rel = export.split_whitespace().next().unwrap();
    let models = root.join(rel);
    if !models.is_dir() {
        eprintln!("skipped: {} is not here", models.display());
        return;
    }
    let mut n = 0;
    for e in std::fs::read_dir(root.join("scenes")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            fragtrace::scene::load_scene_with_search_path(&p, std::slice::from_ref(&models))
                .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            n += 1;
        }
    }
    assert!(n >= 9, "{n} scenes");
}

/// A scene with nothing to hit still renders (exit 0, the background), but says so in one
/// warning line naming the file that has no triangles: an empty OBJ, an OBJ with vertices
/// but no faces (both named, not the scene), and a scene without objects.
#[test]
fn nothing_to_render_warns_once_naming_the_file() {
    let d = tmpdir("no-triangles");
    let camera = "[camera]\neye = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n";
    write(&d, "empty.obj", "# nothing\n");
    write(&d, "points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    write(&d, "none.toml", camera);
    for (obj, why) in [("empty.obj", "no faces"), ("points.obj", "no faces")] {
        let scene = format!("{obj}.toml");
        write(
            &d,
            &scene,
            format!(
                "{camera}\n[[objects]]\nmesh = \"{}\"\n",
                d.join(obj).display()
            ),
        );
        check_one_warning(&d, &scene, &[obj, "no triangles", why]);
    }
    check_one_warning(
        &d,
        "none.toml",
        &["none.toml", "no objects", "no triangles"],
    );
}

fn check_one_warning(d: &Path, scene: &str, needles: &[&str]) {
    let out = run_in(
        d,
        &[
            "render",
            scene,
            "--backend",
            "cpu",
            "--width",
            "8",
            "--height",
            "6",
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(0), "{scene}: {err}");
    let warnings: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("fragtrace: warning:"))
        .collect();
    assert_eq!(warnings.len(), 1, "{scene}: {err}");
    for n in needles {
        assert!(
            warnings[0].contains(n),
            "{scene}: `{}` lacks `{n}`",
            warnings[0]
        );
    }
    assert!(d.join("render.png").exists());
}
