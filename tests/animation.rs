//! `render --frames`: an animation in one process renders every frame exactly as a single
//! render from that frame's camera would (bit for bit, on the CPU in f64 and f32 and on the
//! GL kernels), names its files from the frame number, writes per-frame statistics, and
//! refuses what it cannot do with one line and exit 2.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{model_path, with_test_context};
use fragtrace::image_io::to_srgb8;
use fragtrace::options::{Backend, Precision, RenderOptions};
use fragtrace::render::{render_cpu, render_gl_with};
use fragtrace::scene::{load_scene_with_search_path, Scene};

fn fragtrace(args: &[&str]) -> Output {
    common::bin().args(args).output().expect("run fragtrace")
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("animation")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn turntable() -> (PathBuf, Scene) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/turntable.toml");
    let scene = load_scene_with_search_path(&path, &model_path()).unwrap();
    (path, scene)
}

fn png_bytes(path: &Path) -> Vec<u8> {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
        .into_raw()
}

/// Every frame of a short run equals a single render of the scene with that frame's
/// camera, for each backend the CLI offers.
#[test]
fn frames_equal_single_renders_from_their_cameras() {
    let (path, scene) = turntable();
    let anim = scene
        .animation
        .as_ref()
        .expect("turntable.toml has a camera path");
    let first = *anim.frames().start();
    let frames = [first, first + 1, first + 37];
    let (w, h) = (40u32, 30u32);
    for (tag, flags) in [
        ("cpu64", &["--backend", "cpu", "--precision", "f64"][..]),
        ("cpu32", &["--backend", "cpu", "--precision", "f32"][..]),
        ("looped", &["--backend", "gl", "--kernel", "looped"][..]),
        ("compute", &["--backend", "gl", "--kernel", "compute"][..]),
    ] {
        let dir = scratch(tag);
        let pattern = dir.join("frame_####.png");
        for &k in &frames {
            let range = format!("{k}..{k}");
            let mut args = vec![
                "render",
                path.to_str().unwrap(),
                "--frames",
                &range,
                "-q",
                "-o",
                pattern.to_str().unwrap(),
            ];
            let (ws, hs) = (w.to_string(), h.to_string());
            args.extend(["--width", &ws, "--height", &hs]);
            args.extend(flags);
            let out = fragtrace(&args);
            assert!(
                out.status.success(),
                "{tag} frame {k}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        let opts = |backend, precision| RenderOptions {
            width: w,
            height: h,
            backend,
            precision,
            gpu: fragtrace::gpu::options::GpuOptions {
                kernel: match tag {
                    "compute" => "compute".parse().unwrap(),
                    _ => "looped".parse().unwrap(),
                },
                ..Default::default()
            },
            ..RenderOptions::for_scene(&scene)
        };
        for &k in &frames {
            let mut single = scene.clone();
            single.camera = anim.camera_at(k);
            let image = match tag {
                "cpu64" => render_cpu(&single, &opts(Backend::Cpu, Precision::F64)).unwrap(),
                "cpu32" => render_cpu(&single, &opts(Backend::Cpu, Precision::F32)).unwrap(),
                _ => with_test_context(|ctx| {
                    render_gl_with(ctx, &single, &opts(Backend::Gl, Precision::F32)).unwrap()
                }),
            }
            .image;
            let file = dir.join(format!("frame_{k:04}.png"));
            assert_eq!(
                png_bytes(&file),
                to_srgb8(&image),
                "{tag} frame {k}: the animation's frame differs from a single render"
            );
        }
        eprintln!("{tag}: frames {frames:?} equal single renders");
    }
}

/// One process renders a range: one file per frame, named by the run of `#`, and
/// `--stats` gives every frame's render with its phases.
#[test]
fn a_range_writes_every_frame_and_its_stats() {
    let (path, scene) = turntable();
    let first = *scene.animation.as_ref().unwrap().frames().start();
    let dir = scratch("range");
    let stats = dir.join("stats.json");
    let range = format!("{}..{}", first, first + 3);
    let out = fragtrace(&[
        "render",
        path.to_str().unwrap(),
        "--frames",
        &range,
        "--width",
        "24",
        "--height",
        "16",
        "--backend",
        "gl",
        "--stats",
        stats.to_str().unwrap(),
        "-o",
        dir.join("f_##.png").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("4 frames of 24x16"), "{err}");
    for k in first..=first + 3 {
        assert!(
            dir.join(format!("f_{k:02}.png")).is_file(),
            "frame {k} missing"
        );
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    let frames = json["per_frame"].as_array().unwrap();
    assert_eq!(frames.len(), 4);
    assert_eq!(json["frames"], 4);
    for (i, f) in frames.iter().enumerate() {
        assert_eq!(f["frame"], first + i as u32);
        assert!(f["render"]["render_ms"].as_f64().unwrap() > 0.0);
        assert!(f["render"]["gpu"]["passes_total"].as_u64().unwrap() > 0);
    }
    // The scene is uploaded and compiled once: only the first frame pays.
    let compile = |i: usize| frames[i]["render"]["gpu"]["compile_ms"].as_f64().unwrap();
    assert!(compile(0) > 0.0);
    assert_eq!((compile(1), compile(2), compile(3)), (0.0, 0.0, 0.0));
}

/// What an animation cannot do is one line and exit 2, and writes nothing.
#[test]
fn animation_errors_are_one_line_and_exit_2() {
    let (path, scene) = turntable();
    let frames = scene.animation.as_ref().unwrap().frames();
    let dir = scratch("errors");
    let p = path.to_str().unwrap();
    let past = format!("{}..{}", frames.start(), frames.end() + 5);
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec!["render".into(), "--frames".into(), "0..3".into()],
            "has no [animation]",
        ),
        (
            vec!["render".into(), p.into(), "--frames".into(), "0..3".into()],
            "no frame number",
        ),
        (
            vec!["render".into(), p.into(), "--frames".into(), past],
            "outside the scene's camera path",
        ),
        (
            vec!["render".into(), p.into(), "--frames".into(), "5..2".into()],
            "runs backwards",
        ),
    ];
    for (mut args, expect) in cases {
        let out_name = if args.iter().any(|a| a == "0..3") && args.len() == 3 {
            dir.join("f_####.png")
        } else {
            dir.join("still.png")
        };
        args.extend(["-o".into(), out_name.to_string_lossy().into_owned()]);
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = fragtrace(&refs);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(expect), "{args:?}: {err}");
    }
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        0,
        "an error wrote a file"
    );
}
