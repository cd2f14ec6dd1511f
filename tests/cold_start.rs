//! `--kernel auto`'s cold start (issue 52), as separate processes meet it: where the compute
//! kernel's programs are not in the program-binary cache, the looped kernel renders while
//! the driver compiles them, compute takes the frames after, and their binaries are stored
//! so that the next process goes straight to compute; `--kernel compute` waits for its
//! compile instead. Every frame is the same bytes whichever kernel rendered it, and
//! `--stats` and the summary line name the kernel of every frame.
//!
//! llvmpipe compiles within the call (it answers `GL_COMPLETION_STATUS` true at once), so
//! the driver that compiles on threads of its own is played by `FRAGTRACE_COMPILE_POLLS`:
//! each compute program answers "not done" to its first N polls (one at the start of
//! every frame, one after every frame the looped kernel rendered meanwhile).

mod common;

use std::path::Path;

use serde_json::Value;

/// `render` of turntable.toml (`--frames`, EXR frames, `--stats s.json`) in `d` with the
/// program cache in `d/cache` and Mesa's own in `d/mesa` (on, so that llvmpipe offers a
/// binary format, but empty for each test process), `extra` arguments and `env`: the
/// stats and the summary line.
fn render(d: &Path, extra: &[&str], env: &[(&str, &str)]) -> (Value, String) {
    render_at(d, (48, 36), extra, env)
}

/// [`render`] at `width` x `height`.
fn render_at(d: &Path, size: (u32, u32), extra: &[&str], env: &[(&str, &str)]) -> (Value, String) {
    render_scene(d, "turntable", size, extra, env)
}

/// [`render_at`] of scenes/`name`.toml.
fn render_scene(
    d: &Path,
    name: &str,
    (width, height): (u32, u32),
    extra: &[&str],
    env: &[(&str, &str)],
) -> (Value, String) {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{name}.toml"));
    let mut c = common::bin();
    c.current_dir(d)
        .arg(&scene)
        .args(["--backend", "gl"])
        .args([
            "--width",
            &width.to_string(),
            "--height",
            &height.to_string(),
        ])
        .args(["--shader-cache", "on", "--stats", "s.json"])
        .args(extra)
        .env("FRAGTRACE_SHADER_CACHE_DIR", d.join("cache"))
        .env("MESA_SHADER_CACHE_DIR", d.join("mesa"))
        .env(
            "FRAGTRACE_MODEL_PATH",
            std::env::join_paths(common::model_path()).unwrap(),
        )
        .env_remove("MESA_SHADER_CACHE_DISABLE")
        .env_remove("FRAGTRACE_COMPILE_POLLS")
        .envs(env.iter().copied());
    for var in common::TASK_VARS {
        c.env_remove(var);
    }
    let o = common::ok(c.output().unwrap());
    let stats = serde_json::from_slice(&std::fs::read(d.join("s.json")).unwrap()).unwrap();
    (stats, String::from_utf8_lossy(&o.stderr).into_owned())
}

/// (kernel, cold_start) of every frame of an animation's stats.
fn kernels(stats: &Value) -> Vec<(String, bool)> {
    stats["per_frame"]
        .as_array()
        .expect("per_frame")
        .iter()
        .map(|f| {
            let g = &f["render"]["gpu"];
            (
                g["kernel"].as_str().unwrap().to_string(),
                g["cold_start"].as_bool().unwrap(),
            )
        })
        .collect()
}

/// The bytes of the frames `f_000.exr`.. in `dir`.
fn frames(dir: &Path, n: usize) -> Vec<Vec<u8>> {
    (0..n)
        .map(|k| std::fs::read(dir.join(format!("f_{k:03}.exr"))).unwrap())
        .collect()
}

/// A cold cache: frame 0 on the looped kernel (marked a cold start), frames 1-3 on compute,
/// the summary line naming both; the frames equal an all-compute run's byte for byte. The
/// next process finds the compute programs in the cache (stored as soon as the driver had
/// finished them) and renders every frame with compute, compiling none of its programs.
#[test]
fn a_cold_cache_starts_on_looped_and_the_next_run_is_warm() {
    let d = common::tmpdir("animation");
    let polls = [("FRAGTRACE_COMPILE_POLLS", "1")];
    let (cold, line) = render(&d, &["--frames", "0..3", "-o", "cold/f_###.exr"], &polls);
    let looped = ("looped".to_string(), true);
    let compute = ("compute".to_string(), false);
    assert_eq!(
        kernels(&cold),
        vec![looped, compute.clone(), compute.clone(), compute.clone()],
        "{cold}"
    );
    assert_eq!(cold["kernels"][0]["kernel"], "looped", "{cold}");
    assert_eq!(cold["kernels"][1]["first"], 1, "{cold}");
    assert!(
        line.contains(
            "looped kernel for frame 0 (compute compiling), compute kernel for frames 1-3"
        ),
        "{line}"
    );

    // The same frames from a warm cache, and from the compute kernel alone.
    let (warm, line) = render(&d, &["--frames", "0..3", "-o", "warm/f_###.exr"], &polls);
    assert_eq!(kernels(&warm), vec![compute.clone(); 4], "{warm}");
    assert!(line.contains("compute kernel,"), "{line}");
    let first = &warm["per_frame"][0]["render"]["gpu"];
    assert_eq!(first["programs_compiled"], 0, "{first}");
    assert!(first["programs_cached"].as_u64().unwrap() >= 1, "{first}");
    render(
        &d,
        &[
            "--kernel",
            "compute",
            "--frames",
            "0..3",
            "-o",
            "compute/f_###.exr",
        ],
        &[],
    );
    let reference = frames(&d.join("compute"), 4);
    assert!(
        frames(&d.join("cold"), 4) == reference,
        "cold frames differ"
    );
    assert!(
        frames(&d.join("warm"), 4) == reference,
        "warm frames differ"
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// One frame: a cold cache renders it on the looped kernel (`-v` says why), the same bytes
/// as compute's, and stores the compute programs the driver finished meanwhile, so the
/// next process renders with compute from the cache. `--kernel compute` never starts on
/// another kernel: it waits for its compile.
#[test]
fn a_single_cold_frame_ends_on_looped_and_compute_waits_for_its_compile() {
    let d = common::tmpdir("single");
    let polls = [("FRAGTRACE_COMPILE_POLLS", "1")];
    let (cold, line) = render(&d, &["-o", "cold.exr", "-v"], &polls);
    assert_eq!(cold["gpu"]["kernel"], "looped", "{cold}");
    assert_eq!(cold["gpu"]["cold_start"], true, "{cold}");
    assert!(line.contains("looped kernel (compute compiling)"), "{line}");
    assert!(
        line.contains("kernel: looped while the compute kernel compiled"),
        "{line}"
    );
    let (warm, _) = render(&d, &["-o", "warm.exr"], &polls);
    assert_eq!(warm["gpu"]["kernel"], "compute", "{warm}");
    assert_eq!(warm["gpu"]["cold_start"], false, "{warm}");
    assert_eq!(warm["gpu"]["programs_compiled"], 0, "{warm}");

    let fresh = d.join("fresh");
    std::fs::create_dir_all(&fresh).unwrap();
    let many = [("FRAGTRACE_COMPILE_POLLS", "5")];
    let (explicit, _) = render(&fresh, &["--kernel", "compute", "-o", "c.exr"], &many);
    assert_eq!(explicit["gpu"]["kernel"], "compute", "{explicit}");
    assert_eq!(explicit["gpu"]["cold_start"], false, "{explicit}");
    let read = |p: &Path| std::fs::read(p).unwrap();
    assert!(read(&d.join("cold.exr")) == read(&fresh.join("c.exr")));
    assert!(read(&d.join("warm.exr")) == read(&fresh.join("c.exr")));
    let _ = std::fs::remove_dir_all(&d);
}

/// A frame larger than the fallback's first band (65,536 pixels: 256 rows at 256 wide) on
/// a cold cache: the looped kernel renders the first band, the compute programs are then
/// linked (the second poll), and compute renders rows 256..319; the stats and the summary
/// line say so. The image, its AOVs and the 8-bit PNG are the bytes of compute's whole
/// render: the bands are stacked exactly.
#[test]
fn a_large_cold_frame_is_handed_to_compute_part_way_down() {
    let d = common::tmpdir("handover");
    let polls = [("FRAGTRACE_COMPILE_POLLS", "1")];
    let size = (256, 320);
    let aov = ["--aov", "depth,normal,primid,steps"];
    for sub in ["a", "b", "c"] {
        std::fs::create_dir_all(d.join(sub)).unwrap();
    }
    let (cold, line) = render_at(
        &d.join("a"),
        size,
        &[&aov[..], &["-o", "h.exr", "-v"]].concat(),
        &polls,
    );
    assert_eq!(cold["gpu"]["kernel"], "looped", "{cold}");
    assert_eq!(cold["gpu"]["cold_start"], true, "{cold}");
    assert_eq!(cold["gpu"]["handover_row"], 256, "{cold}");
    assert_eq!(cold["rays"]["primary"], 256 * 320, "{cold}");
    assert!(
        line.contains("looped kernel (compute compiling; compute from row 256)"),
        "{line}"
    );
    assert!(line.contains("then compute from row 256"), "{line}");
    let (png, _) = render_at(&d.join("b"), size, &["-o", "h.png"], &polls);
    assert_eq!(png["gpu"]["handover_row"], 256, "{png}");
    let (whole, _) = render_at(
        &d.join("c"),
        size,
        &[&aov[..], &["--kernel", "compute", "-o", "c.exr"]].concat(),
        &[],
    );
    assert_eq!(whole["gpu"]["handover_row"], Value::Null, "{whole}");
    render_at(
        &d.join("c"),
        size,
        &["--kernel", "compute", "-o", "c.png"],
        &[],
    );
    let read = |p: &str| std::fs::read(d.join(p)).unwrap();
    assert!(
        read("a/h.exr") == read("c/c.exr"),
        "the handed-over image differs"
    );
    assert!(
        read("a/h.aov.exr") == read("c/c.aov.exr"),
        "its AOVs differ"
    );
    assert!(read("b/h.png") == read("c/c.png"), "its PNG differs");
    let _ = std::fs::remove_dir_all(&d);
}

/// Where the fallback's float layout does not fit but the compute kernel's dense one does
/// (the dragon's irregular grid: its `cell` texture is 954 rows high, past a texture size
/// of 640, `FRAGTRACE_GL_LIMITS=texture=640`), a cold start waits for the compute compile
/// instead of failing on the fallback (on the H100 the 100-sphere scene's float layout
/// needs 2.1 G texels): the frame is compute's whole render, not marked a cold start, and
/// the same bytes as `--kernel compute`'s; `--kernel looped` is refused in one line that
/// names `--kernel compute`.
#[test]
fn a_cold_start_waits_for_compute_where_the_fallback_cannot_hold_the_scene() {
    let d = common::tmpdir("no-fallback");
    let small = ("FRAGTRACE_GL_LIMITS", "texture=640");
    let size = (32, 24);
    let irregular = ["--accel", "irregular"];
    for sub in ["a", "b"] {
        std::fs::create_dir_all(d.join(sub)).unwrap();
    }
    let polls = [("FRAGTRACE_COMPILE_POLLS", "1"), small];
    let (cold, _) = render_scene(
        &d.join("a"),
        "dragon",
        size,
        &[&irregular[..], &["-o", "a.exr"]].concat(),
        &polls,
    );
    assert_eq!(cold["gpu"]["kernel"], "compute", "{cold}");
    assert_eq!(cold["gpu"]["cold_start"], false, "{cold}");
    assert_eq!(cold["gpu"]["grid_layout"], "dense", "{cold}");
    let (whole, _) = render_scene(
        &d.join("b"),
        "dragon",
        size,
        &[&irregular[..], &["--kernel", "compute", "-o", "b.exr"]].concat(),
        &[small],
    );
    assert_eq!(whole["gpu"]["kernel"], "compute", "{whole}");
    let read = |p: &str| std::fs::read(d.join(p)).unwrap();
    assert!(
        read("a/a.exr") == read("b/b.exr"),
        "the waited-for frame differs"
    );
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/dragon.toml");
    let o = common::bin()
        .arg(&scene)
        .args([
            "--backend",
            "gl",
            "--kernel",
            "looped",
            "--accel",
            "irregular",
        ])
        .args(["--width", "32", "--height", "24", "-o"])
        .arg(d.join("l.png"))
        .env(small.0, small.1)
        .env(
            "FRAGTRACE_MODEL_PATH",
            std::env::join_paths(common::model_path()).unwrap(),
        )
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("texture `cell` needs") && err.contains("is 640"),
        "{err}"
    );
    // The refusal names the kernel that renders the scene on this context.
    assert!(err.contains("--kernel compute"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    let _ = std::fs::remove_dir_all(&d);
}

/// One frame at a time on a driver slower to compile than the frame takes (polls that
/// never answer "done" in the first process): the first run ends on the looped kernel with
/// the compute compile unfinished, marks it so and ends at once after its files (without
/// the driver's exit handlers, which would wait for the compile); the second waits for that compile
/// (compute, compiled, no cold start) and stores it; the third links it from the cache.
/// Without the mark every run would start the compile anew and end on looped, never
/// reaching the faster kernel.
#[test]
fn a_compile_left_unfinished_is_waited_for_by_the_next_run() {
    let d = common::tmpdir("unfinished");
    let never = [("FRAGTRACE_COMPILE_POLLS", "1000")];
    let (first, _) = render(&d, &["-o", "1.exr"], &never);
    assert_eq!(first["gpu"]["kernel"], "looped", "{first}");
    assert_eq!(first["gpu"]["cold_start"], true, "{first}");
    // The compile still running, the process ends at once after its files (its driver's
    // exit handlers would wait for the compile).
    assert_eq!(first["process"]["ends_at_once"], true, "{first}");
    let (second, _) = render(&d, &["-o", "2.exr"], &never);
    assert_eq!(second["gpu"]["kernel"], "compute", "{second}");
    assert_eq!(second["gpu"]["cold_start"], false, "{second}");
    assert_eq!(second["process"]["ends_at_once"], false, "{second}");
    assert!(
        second["gpu"]["programs_compiled"].as_u64().unwrap() >= 1,
        "{second}"
    );
    let (third, _) = render(&d, &["-o", "3.exr"], &never);
    assert_eq!(third["gpu"]["kernel"], "compute", "{third}");
    assert_eq!(third["gpu"]["programs_compiled"], 0, "{third}");
    let read = |n: &str| std::fs::read(d.join(n)).unwrap();
    assert!(read("1.exr") == read("2.exr") && read("2.exr") == read("3.exr"));
    let _ = std::fs::remove_dir_all(&d);
}

/// A driver that compiles within the call (llvmpipe: `GL_COMPLETION_STATUS` is true as soon
/// as it is asked) has the compute programs ready at the first poll, so even a cold cache
/// renders with compute, as before the cold start existed: waiting there costs nothing the
/// looped kernel would save.
#[test]
fn a_driver_that_compiles_in_the_call_runs_compute_at_once() {
    let renderer = common::with_test_context(|ctx| ctx.info.renderer.clone());
    if !renderer.contains("llvmpipe")
        && !common::acknowledged_skip(
            &format!("this test knows llvmpipe's compile; the driver is {renderer:?}"),
            "run it on llvmpipe",
        )
    {
        return;
    }
    let d = common::tmpdir("in-call");
    let (s, _) = render(&d, &["-o", "a.exr"], &[]);
    assert_eq!(s["gpu"]["kernel"], "compute", "{s}");
    assert_eq!(s["gpu"]["cold_start"], false, "{s}");
    assert!(s["gpu"]["programs_compiled"].as_u64().unwrap() >= 1, "{s}");
    let _ = std::fs::remove_dir_all(&d);
}

/// A farm whose tasks met different caches: part 0 rendered on a cold cache (the looped
/// kernel, the compute programs compiling), part 1 on the cache that left warm (compute);
/// `fragtrace merge` takes them as parts of one render (the same plan in their headers)
/// and the merged PNG is the single compute render's byte for byte.
#[test]
fn parts_from_cold_and_warm_tasks_merge_to_the_single_render() {
    let d = common::tmpdir("parts");
    let polls = [("FRAGTRACE_COMPILE_POLLS", "1")];
    let (cold, _) = render(&d, &["--tile", "0/2", "-o", "part-0.exr"], &polls);
    assert_eq!(cold["gpu"]["kernel"], "looped", "{cold}");
    let (warm, _) = render(&d, &["--tile", "1/2", "-o", "part-1.exr"], &polls);
    assert_eq!(warm["gpu"]["kernel"], "compute", "{warm}");
    render(&d, &["--kernel", "compute", "-o", "whole.png"], &[]);
    common::ok(common::run(
        &d,
        &["merge", "part-0.exr", "part-1.exr", "-o", "merged.png"],
        &[],
    ));
    let read = |f: &str| std::fs::read(d.join(f)).unwrap();
    assert!(
        read("merged.png") == read("whole.png"),
        "merged parts differ"
    );
    let _ = std::fs::remove_dir_all(&d);
}
