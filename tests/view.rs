//! `fragtrace view` as a user meets it, under an X display (CI runs the suite under
//! `xvfb-run -a`): the window's screenshot after a complete frame equals the headless
//! render of the same scene, size and kernel (default scene and a mesh scene, in the
//! default context and in a GL 2.1 / GLSL 1.20 one), frames of a render in progress are
//! shown, the exits of a missing display and an inadequate context, and mouse input
//! (synthetic winit events through the same translation and controller as the window)
//! moving the camera to where the closed-form formula says.
//!
//! Without a display these tests fail, saying so, unless `FRAGTRACE_ALLOW_SKIP=1`
//! acknowledges the skip (docs/testing.md).

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use fragtrace::view::control::{self, Controller, ORBIT_RAD_PER_PX, ZOOM_PER_LINE};
use fragtrace::view::winit::dpi::PhysicalPosition;
use fragtrace::view::winit::event::{
    DeviceId, ElementState, MouseButton, MouseScrollDelta, TouchPhase, WindowEvent,
};

/// The GL 2.1 / GLSL 1.20 override (Mesa).
const GL21: [(&str, &str); 2] = [
    ("MESA_GL_VERSION_OVERRIDE", "2.1"),
    ("MESA_GLSL_VERSION_OVERRIDE", "120"),
];

/// Whether an X display is there; without one, [`common::acknowledged_skip`].
fn display_or_acknowledged_skip(test: &str) -> bool {
    std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty())
        || common::acknowledged_skip(
            &format!("{test} needs an X display (DISPLAY is unset)"),
            "run the tests under `xvfb-run -a` (apt-get install -y xvfb)",
        )
}

fn run(args: &[&str], env: &[(&str, &str)]) -> Output {
    common::bin()
        .args(args)
        .envs(env.iter().copied())
        .output()
        .expect("run fragtrace")
}

fn ok(out: &Output, what: &str) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{what} failed: {err}");
    err
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("fragtrace-view-tests-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn mesh_scene() -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    root.join("scenes/cornell.toml")
        .to_string_lossy()
        .into_owned()
}

/// 8-bit RGB of a PNG.
fn rgb8(path: &Path) -> (u32, u32, Vec<u8>) {
    let img = image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8();
    (img.width(), img.height(), img.into_raw())
}

/// RMSE of two 8-bit images on the [0, 1] scale.
fn rmse8(a: &Path, b: &Path) -> f64 {
    let (wa, ha, pa) = rgb8(a);
    let (wb, hb, pb) = rgb8(b);
    assert_eq!((wa, ha), (wb, hb), "sizes differ");
    let sum: f64 = pa
        .iter()
        .zip(&pb)
        .map(|(&x, &y)| ((x as f64 - y as f64) / 255.0).powi(2))
        .sum();
    (sum / pa.len() as f64).sqrt()
}

/// Renders `scene` (None: the built-in) headless and in the window with the same size,
/// kernel and samples, and returns the RMSE between the screenshot and the image, and the
/// view's stderr. The window presents the render in progress every `every` passes, each
/// time drawing in the renderer's context between two of its passes, so equality also says
/// that watching does not disturb the render (that the presenter restores the GL state it
/// touches is checked directly by `view::present`'s unit test).
fn view_against_render(
    tag: &str,
    scene: Option<&str>,
    flags: &[&str],
    every: &str,
    env: &[(&str, &str)],
) -> (f64, String) {
    let shot = scratch(&format!("{tag}-view.png"));
    let reference = scratch(&format!("{tag}-render.png"));
    let mut view_args = vec!["view"];
    let mut render_args = vec!["render", "--backend", "gl", "-q", "-o"];
    render_args.push(reference.to_str().unwrap());
    if let Some(s) = scene {
        view_args.push(s);
        render_args.push(s);
    }
    view_args.extend(flags);
    render_args.extend(flags);
    view_args.extend([
        "--passes-per-frame",
        every,
        "--screenshot",
        shot.to_str().unwrap(),
    ]);
    ok(&run(&render_args, env), "render");
    let log = ok(&run(&view_args, env), "view");
    (rmse8(&shot, &reference), log)
}

// Measured on Mesa llvmpipe (22.3.6), here and under GL 2.1: RMSE 0 in all five cases (the
// window shows the image's own 8-bit encoding, and both contexts trace the same rays with
// the same programs). The bound is the issue's 1e-3: about 6% of the values one step off.
const MAX_RMSE: f64 = 1e-3;

#[test]
fn screenshot_equals_headless_render_default_scene() {
    if !display_or_acknowledged_skip("screenshot_equals_headless_render_default_scene") {
        return;
    }
    // The looped kernel is watched between its passes; the compute kernel (what `auto`
    // runs on a GL 4.3 context) once, after its one dispatch.
    for kernel in ["looped", "compute"] {
        let flags = [
            "--width", "64", "--height", "48", "--spp", "4", "--kernel", kernel,
        ];
        let tag = format!("default-{kernel}");
        let (rmse, log) = view_against_render(&tag, None, &flags, "1", &[]);
        eprintln!("default scene, default context, {kernel}: RMSE {rmse:.6}\n{log}");
        assert!(rmse <= MAX_RMSE, "{kernel}: RMSE {rmse}");
    }
}

/// Placed meshes (instances, a mirrored one among them) in the view: by default it walks
/// them as the GPU's two levels, stored once, since every kernel of its `k` key does (no
/// "stores the instances flat" warning, the uniform grid), and with `--accel irregular`
/// flat (the one warning), each time showing `render`'s image on the looped and the
/// compute kernel. Before, the view stored them flat and then uploaded the scene as loaded
/// beside the flat scene's grid: every instance was missing from the window.
#[test]
fn view_shows_an_instanced_scene_as_render_does() {
    if !display_or_acknowledged_skip("view_shows_an_instanced_scene_as_render_does") {
        return;
    }
    let scene = scratch("instanced.toml");
    std::fs::write(&scene, common::INSTANCED_SCENE).unwrap();
    let path = scene.to_str().unwrap();
    for (accel, flat) in [(None, false), (Some("irregular"), true)] {
        for kernel in ["looped", "compute"] {
            let mut flags = vec![
                "--width", "64", "--height", "48", "--spp", "1", "--kernel", kernel,
            ];
            if let Some(a) = accel {
                flags.extend(["--accel", a]);
            }
            let tag = format!("instanced-{}-{kernel}", accel.unwrap_or("default"));
            let (rmse, log) = view_against_render(&tag, Some(path), &flags, "1", &[]);
            eprintln!("instanced, {accel:?}, {kernel}: RMSE {rmse:.6}\n{log}");
            assert!(rmse <= MAX_RMSE, "{tag}: RMSE {rmse}\n{log}");
            assert_eq!(log.contains("instances flat"), flat, "{tag}: {log}");
            let grid = if flat {
                "irregular grid"
            } else {
                "uniform grid"
            };
            assert!(
                log.contains(&format!("fragtrace view: {grid}")),
                "{tag}: {log}"
            );
        }
    }
}

/// `view` goes through the same front door as `render`: it builds the structure `--accel`
/// names (the irregular grid by default), reports it, and shows the render's image. Before,
/// the view built its own uniform grid whatever the flags said (ground.toml: a bunny in a
/// few cells of a 400 m floor's grid, about 96x the headless render's time).
#[test]
fn view_builds_the_structure_render_builds() {
    if !display_or_acknowledged_skip("view_builds_the_structure_render_builds") {
        return;
    }
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/ground.toml");
    let scene = path.to_str().unwrap();
    for accel in [None, Some("uniform")] {
        let tag = format!("ground-{}", accel.unwrap_or("default"));
        let stats = scratch(&format!("{tag}.json"));
        let mut flags = vec![
            "--width", "64", "--height", "48", "--spp", "1", "--kernel", "looped",
        ];
        if let Some(a) = accel {
            flags.extend(["--accel", a]);
        }
        let reference = scratch(&format!("{tag}-render.png"));
        let mut render_args = vec!["render", scene, "--backend", "gl", "-q", "--stats"];
        render_args.extend([stats.to_str().unwrap(), "-o", reference.to_str().unwrap()]);
        render_args.extend(&flags);
        ok(&run(&render_args, &[]), "render");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
        let a = &json["accel"];
        let expected = format!(
            "fragtrace view: {} grid, {} cells, {} references",
            a["kind"].as_str().unwrap(),
            a["cells"],
            a["references"]
        );
        assert_eq!(
            a["kind"].as_str().unwrap(),
            accel.unwrap_or("irregular"),
            "render built the wrong structure"
        );
        let shot = scratch(&format!("{tag}-view.png"));
        let mut view_args = vec!["view", scene];
        view_args.extend(&flags);
        view_args.extend(["--screenshot", shot.to_str().unwrap()]);
        let log = ok(&run(&view_args, &[]), "view");
        assert!(
            log.lines().any(|l| l.starts_with(&expected)),
            "the view reports another structure than the render's `{expected}`:\n{log}"
        );
        let rmse = rmse8(&shot, &reference);
        assert!(rmse <= MAX_RMSE, "{tag}: RMSE {rmse}");
    }
}

#[test]
fn screenshot_equals_headless_render_mesh_scene() {
    if !display_or_acknowledged_skip("screenshot_equals_headless_render_mesh_scene") {
        return;
    }
    let scene = mesh_scene();
    let flags = [
        "--width",
        "64",
        "--height",
        "48",
        "--spp",
        "1",
        "--kernel",
        "multipass",
    ];
    let (rmse, log) = view_against_render("mesh", Some(&scene), &flags, "7", &[]);
    eprintln!("cornell, default context: RMSE {rmse:.6}\n{log}");
    assert!(rmse <= MAX_RMSE, "RMSE {rmse}");
}

#[test]
fn screenshot_equals_headless_render_in_gl21() {
    if !display_or_acknowledged_skip("screenshot_equals_headless_render_in_gl21")
        || !common::mesa_overrides_available()
    {
        return;
    }
    let flags = ["--width", "64", "--height", "48", "--spp", "2"];
    let (rmse, log) = view_against_render("default21", None, &flags, "1", &GL21);
    eprintln!("default scene, GL 2.1: RMSE {rmse:.6}\n{log}");
    assert!(rmse <= MAX_RMSE, "RMSE {rmse}");
    // The window's context really is the forced one.
    assert!(log.contains("OpenGL 2.1 "), "{log}");

    let scene = mesh_scene();
    // With the early-z mask, whose depth test the presenter turns off while it draws.
    let flags = [
        "--width",
        "64",
        "--height",
        "48",
        "--spp",
        "1",
        "--kernel",
        "multipass",
        "--mask",
        "early-z",
    ];
    let (rmse, log) = view_against_render("mesh21", Some(&scene), &flags, "7", &GL21);
    eprintln!("cornell, GL 2.1, multipass: RMSE {rmse:.6}\n{log}");
    assert!(rmse <= MAX_RMSE, "RMSE {rmse}");
    assert!(log.contains("OpenGL 2.1 "), "{log}");
}

/// A frame of a render in progress is shown and can be captured: after 2 frames of 50
/// passes, the multipass primary wave is still in flight, so the screenshot is far from the
/// finished image and shows the tint of active rays.
#[test]
fn frames_of_a_render_in_progress_show_the_wave() {
    if !display_or_acknowledged_skip("frames_of_a_render_in_progress_show_the_wave") {
        return;
    }
    let shot = scratch("wave.png");
    let done = scratch("wave-done.png");
    let size = [
        "--width",
        "64",
        "--height",
        "48",
        "--spp",
        "1",
        "--kernel",
        "multipass",
        "--mask",
        "none",
        // The uniform grid: its walk takes enough passes that a frame after 100 of them
        // still shows most of the wave (the irregular grid, the default since the view
        // builds what --accel names, finishes most rays sooner).
        "--accel",
        "uniform",
    ];
    let mut args = vec!["view"];
    args.extend(size);
    args.extend(["--passes-per-frame", "50", "--frames", "2", "--screenshot"]);
    args.push(shot.to_str().unwrap());
    ok(&run(&args, &[]), "view --frames 2");
    let mut args = vec![
        "render",
        "--backend",
        "gl",
        "-q",
        "-o",
        done.to_str().unwrap(),
    ];
    args.extend(size);
    ok(&run(&args, &[]), "render");
    let rmse = rmse8(&shot, &done);
    eprintln!("frame 2 against the finished image: RMSE {rmse:.4}");
    // Measured 0.52: the frame is black (nothing shaded yet) but for the tinted wave.
    assert!(
        rmse > 0.1,
        "the frame in progress looks finished: RMSE {rmse}"
    );
    let (_, _, px) = rgb8(&shot);
    let tinted = px
        .chunks_exact(3)
        .filter(|p| p[0] > 150 && p[1] > 60 && p[1] < 130 && p[2] < 60)
        .count();
    eprintln!("{tinted} tinted pixels of {}", px.len() / 3);
    // Measured 1651 of 3072 pixels still traversing after 100 passes.
    assert!(tinted > 300, "only {tinted} rays of the wave are tinted");
}

/// Issue 49 in the window: with `--show-tiles`, frames of a multipass render in progress
/// outline the tiles the last traversal pass drew (cyan, `view::present`), and each frame's
/// title (on stderr when automated) says what share of the image that pass drew and how
/// many rays were active; the share falls as a wave's rays finish (and rises with the next
/// wave). Without the flag no outline is drawn. Measured (128x96, built-in scene, frames
/// every 100 passes): the passes drew 35, 12, 62 and 29% of the image (295, 17, 2,511 and
/// 77 rays active).
#[test]
fn frames_in_progress_show_the_passes_cut_to_active_tiles() {
    if !display_or_acknowledged_skip("frames_in_progress_show_the_passes_cut_to_active_tiles") {
        return;
    }
    let args = |shot: &Path, tiles: bool| {
        let mut a: Vec<String> = [
            "view",
            "--width",
            "128",
            "--height",
            "96",
            "--spp",
            "1",
            "--kernel",
            "multipass",
            "--mask",
            "none",
            "--passes-per-frame",
            "100",
            "--frames",
            "4",
            "--screenshot",
        ]
        .map(String::from)
        .to_vec();
        a.push(shot.to_string_lossy().into_owned());
        if tiles {
            a.push("--show-tiles".into());
        }
        a
    };
    let outlined = |shot: &Path| {
        let (_, _, px) = rgb8(shot);
        // TILE_OUTLINE, (0.1, 0.9, 1.0) in the 8-bit window.
        px.chunks_exact(3)
            .filter(|p| p[0] < 40 && p[1] > 215 && p[1] < 245 && p[2] > 245)
            .count()
    };
    let shot = scratch("tiles.png");
    let a = args(&shot, true);
    let err = ok(
        &run(&a.iter().map(String::as_str).collect::<Vec<_>>(), &[]),
        "view --show-tiles",
    );
    let shares: Vec<f64> = err
        .lines()
        .filter_map(|l| l.split("pass drew ").nth(1))
        .map(|r| r.split('%').next().unwrap().parse().unwrap())
        .collect();
    let n = outlined(&shot);
    eprintln!("shares drawn per frame {shares:?}; {n} outline pixels\n{err}");
    assert_eq!(shares.len(), 4, "one title per frame");
    assert!(
        err.lines().any(|l| l.contains("rays active")),
        "the title names the active rays"
    );
    let least = shares.iter().copied().fold(100.0, f64::min);
    assert!(least < 50.0, "the passes did not shrink: {shares:?}");
    assert!(n > 200, "only {n} outline pixels");
    let plain = scratch("no-tiles.png");
    let a = args(&plain, false);
    ok(
        &run(&a.iter().map(String::as_str).collect::<Vec<_>>(), &[]),
        "view",
    );
    assert_eq!(outlined(&plain), 0, "outlines drawn without --show-tiles");
}

#[test]
fn no_display_is_one_line_and_exit_2() {
    let out = common::bin()
        .args(["view", "--width", "32", "--height", "24", "--frames", "1"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET")
        .output()
        .expect("run fragtrace");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("fragtrace: error: "), "{err}");
    // X11 only: Wayland through XWayland, never WAYLAND_DISPLAY as if it could do.
    for needle in ["DISPLAY is not set", "XWayland", "xvfb-run"] {
        assert!(err.contains(needle), "{needle}: {err}");
    }
    assert!(!err.contains("WAYLAND_DISPLAY"), "{err}");
}

/// A context too old for the kernels (Mesa forced to GL 2.0) is refused the same way.
#[test]
fn inadequate_context_is_one_line_and_exit_2() {
    if !display_or_acknowledged_skip("inadequate_context_is_one_line_and_exit_2")
        || !common::mesa_overrides_available()
    {
        return;
    }
    let out = run(
        &["view", "--width", "32", "--height", "24", "--frames", "1"],
        &[
            ("MESA_GL_VERSION_OVERRIDE", "2.0"),
            ("MESA_GLSL_VERSION_OVERRIDE", "110"),
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("OpenGL >= 2.1"), "{err}");
}

/// A bad screenshot path fails before any window opens.
#[test]
fn screenshot_must_be_a_writable_png() {
    let out = run(&["view", "--screenshot", "/nonexistent/x.png"], &[]);
    assert_eq!(out.status.code(), Some(2));
    let out = run(&["view", "--screenshot", "x.exr"], &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("PNG"), "{err}");
}

/// `view --play --frames N --screenshot` shows frame N - 1 of the camera path, rendered to
/// the end, every time, however often the render in progress is presented: the same image
/// as `render --frames` writes for that frame. Before, presented frames of renders in
/// progress counted too, and a render cut short moved the path on: N = 5 gave frame 3, 4,
/// 4, 3, 3, and once a frame in progress (with `--passes-per-frame 2`, always one).
#[test]
fn play_frames_n_shows_frame_n_minus_1_every_time() {
    if !display_or_acknowledged_skip("play_frames_n_shows_frame_n_minus_1_every_time") {
        return;
    }
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/turntable.toml");
    let scene = scene.to_str().unwrap();
    let size = [
        "--width", "48", "--height", "36", "--spp", "1", "--kernel", "looped",
    ];
    let frames = scratch("play-f_###.png");
    let mut args = vec!["render", scene, "--backend", "gl", "-q", "--frames", "0..3"];
    args.extend(size);
    args.extend(["-o", frames.to_str().unwrap()]);
    ok(&run(&args, &[]), "render --frames");
    let frame = |k: u32| scratch(&format!("play-f_{k:03}.png"));
    for (i, present) in [
        ["--passes-per-frame", "2"],
        ["--frame-ms", "0"],
        ["--frame-ms", "50"],
    ]
    .iter()
    .enumerate()
    {
        let shot = scratch(&format!("play-{i}.png"));
        let mut args = vec!["view", scene, "--play", "--frames", "3"];
        args.extend(size);
        args.extend(present);
        args.extend(["--screenshot", shot.to_str().unwrap()]);
        ok(&run(&args, &[]), "view --play");
        let rmse: Vec<f64> = (0..=3).map(|k| rmse8(&shot, &frame(k))).collect();
        eprintln!("{present:?}: RMSE against frames 0..3 {rmse:?}");
        assert!(rmse[2] <= MAX_RMSE, "{present:?}: not frame 2: {rmse:?}");
    }
}

/// `view --play` on a scene without a camera path exits 2 as `render --frames` does, before
/// any window opens; so does a script word that is neither a key nor a mouse move, naming
/// where it stands.
#[test]
fn play_on_a_still_scene_and_a_bad_script_exit_2() {
    let shot = scratch("still.png");
    let out = run(
        &[
            "view",
            "--play",
            "--frames",
            "1",
            "--screenshot",
            shot.to_str().unwrap(),
        ],
        &[],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with("fragtrace: error: --play needs a camera path:")
            && err.contains("[animation]"),
        "{err}"
    );
    let script = scratch("bad-keys.txt");
    std::fs::write(&script, "a # next display\nk w\n").unwrap();
    for (args, want) in [
        (
            vec!["view", "--keys", "k w"],
            "--keys:1: `w`: not a key".to_string(),
        ),
        (
            vec!["view", "--script", script.to_str().unwrap()],
            format!("{}:2: `w`: not a key", script.display()),
        ),
        (
            vec!["view", "--keys", "zoom:x"],
            "--keys:1: `zoom:x`".into(),
        ),
    ] {
        let out = run(&args, &[]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(&want), "{args:?}: want {want} in {err}");
    }
}

/// The view's keys, scripted (`--keys`, `--script`) and seen headless: each step is applied
/// once the render before it is complete, and the screenshot shows what they made, equal to
/// the headless render of the same thing: `a a` shows the depth AOV (`render --aov depth`'s
/// preview), `- -` lowers the depth by two, a scripted drag and two wheel lines move the
/// camera where `control::orbit` and `control::zoom` say (cornell.toml rendered from that
/// camera), `r` brings it back, and `s` saves the window in the current folder.
#[test]
fn scripted_keys_do_what_the_keys_do() {
    if !display_or_acknowledged_skip("scripted_keys_do_what_the_keys_do") {
        return;
    }
    let size = [
        "--width", "48", "--height", "36", "--spp", "1", "--kernel", "looped",
    ];
    let view = |tag: &str, scene: Option<&str>, extra: &[&str]| -> PathBuf {
        let shot = scratch(&format!("keys-{tag}.png"));
        let mut args = vec!["view"];
        args.extend(scene);
        args.extend(size);
        args.extend(extra);
        args.extend(["--screenshot", shot.to_str().unwrap()]);
        ok(&run(&args, &[]), &format!("view {extra:?}"));
        shot
    };
    let render = |tag: &str, scene: Option<&str>, extra: &[&str]| -> PathBuf {
        let out = scratch(&format!("keys-{tag}-render.png"));
        let mut args = vec![
            "render",
            "--backend",
            "gl",
            "-q",
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend(scene);
        args.extend(size);
        args.extend(extra);
        ok(&run(&args, &[]), &format!("render {extra:?}"));
        out
    };
    let depth = view("depth", None, &["--keys", "a a"]);
    render("depth", None, &["--aov", "depth"]);
    let rmse = rmse8(&depth, &scratch("keys-depth-render.depth.png"));
    assert!(rmse <= MAX_RMSE, "`a a`: RMSE {rmse} against the depth AOV");
    let script = scratch("keys.txt");
    std::fs::write(&script, "- # depth down\n-\n").unwrap();
    let shallow = view(
        "shallow",
        None,
        &["--max-depth", "3", "--script", script.to_str().unwrap()],
    );
    let rmse = rmse8(&shallow, &render("shallow", None, &["--max-depth", "1"]));
    assert!(
        rmse <= MAX_RMSE,
        "`- -` from depth 3: RMSE {rmse} against depth 1"
    );

    // cornell.toml from the camera the scripted drag and wheel give.
    let cornell = mesh_scene();
    let text = std::fs::read_to_string(&cornell).unwrap();
    let home = fragtrace::scene::camera::Camera {
        eye: glam::Vec3::new(0.0, 1.0, 3.9),
        look_at: glam::Vec3::new(0.0, 1.0, 0.0),
        up: glam::Vec3::Y,
        vfov_deg: 38.0,
    };
    assert!(
        text.contains("eye = [0.0, 1.0, 3.9]\nlook_at = [0.0, 1.0, 0.0]\nfov = 38\n"),
        "cornell.toml's camera moved: update this test"
    );
    let moved = control::orbit(&home, 40.0, -10.0);
    let dist = (home.eye - home.look_at).length() as f64;
    let moved = control::zoom(&moved, 2.0, dist * control::MIN_DISTANCE);
    let e = moved.eye;
    // Its mesh is found through FRAGTRACE_MODEL_PATH, as the shipped scene's.
    let moved_scene = scratch("moved.toml");
    std::fs::write(
        &moved_scene,
        text.replace(
            "eye = [0.0, 1.0, 3.9]",
            &format!("eye = [{:?}, {:?}, {:?}]", e.x, e.y, e.z),
        ),
    )
    .unwrap();
    let expected = render("moved", Some(moved_scene.to_str().unwrap()), &[]);
    let shot = view("moved", Some(&cornell), &["--keys", "orbit:40,-10 zoom:2"]);
    let rmse = rmse8(&shot, &expected);
    let home_png = render("home", Some(&cornell), &[]);
    let rmse_home = rmse8(&shot, &home_png);
    eprintln!("orbit + zoom: RMSE {rmse} against the moved camera, {rmse_home} against home");
    assert!(rmse <= MAX_RMSE && rmse_home > 0.02, "{rmse} {rmse_home}");
    let back = view("back", Some(&cornell), &["--keys", "orbit:40,-10 zoom:2 r"]);
    assert!(
        rmse8(&back, &home_png) <= MAX_RMSE,
        "`r` did not reset the camera"
    );

    // `s` saves the window (fragtrace-view-1.png in the current folder), `q` ends the view
    // without --screenshot.
    let dir = scratch("keys-s");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let out = common::bin()
        .current_dir(&dir)
        .args(["view", "--keys", "a a s q"])
        .args(size)
        .output()
        .unwrap();
    ok(&out, "view --keys 'a a s q'");
    let saved = dir.join("fragtrace-view-1.png");
    assert!(saved.is_file(), "{}", String::from_utf8_lossy(&out.stdout));
    assert!(
        rmse8(&saved, &depth) <= MAX_RMSE,
        "`s` saved another picture"
    );
}

fn cursor(x: f64, y: f64) -> WindowEvent {
    WindowEvent::CursorMoved {
        device_id: DeviceId::dummy(),
        position: PhysicalPosition::new(x, y),
    }
}

fn button(button: MouseButton, state: ElementState) -> WindowEvent {
    WindowEvent::MouseInput {
        device_id: DeviceId::dummy(),
        state,
        button,
    }
}

/// Synthetic window events drive the controller as the window does (translate, then
/// handle): a left drag orbits, the wheel zooms, and the camera ends where the spherical
/// coordinates about the look-at point say; a right drag pans without turning.
#[test]
fn synthetic_mouse_events_orbit_and_zoom_by_the_formula() {
    let scene = fragtrace::scene::builtin_scene();
    let start = scene.camera;
    let mut c = Controller::new(start, 480);
    let mut feed = |e: WindowEvent| {
        let input = control::translate(&e).expect("a mouse event");
        c.handle(input);
    };
    // Left drag from (100, 100) to (130, 90) in two moves: dx = 30, dy = -10.
    feed(cursor(100.0, 100.0));
    feed(button(MouseButton::Left, ElementState::Pressed));
    feed(cursor(112.0, 96.0));
    feed(cursor(130.0, 90.0));
    feed(button(MouseButton::Left, ElementState::Released));
    feed(cursor(300.0, 300.0)); // moving without a button does nothing
    feed(WindowEvent::MouseWheel {
        device_id: DeviceId::dummy(),
        delta: MouseScrollDelta::LineDelta(0.0, 2.0),
        phase: TouchPhase::Moved,
    });
    let cam = c.camera;

    // Closed form (up = +y): azimuth atan2(x, z) and elevation asin(y / r) of eye - look_at.
    let o = (start.eye - start.look_at).as_dvec3();
    let r = o.length();
    let (az0, el0) = (o.x.atan2(o.z), (o.y / r).asin());
    let (az, el) = (az0 - 30.0 * ORBIT_RAD_PER_PX, el0 - 10.0 * ORBIT_RAD_PER_PX);
    let r1 = r * ZOOM_PER_LINE.powi(2);
    let expect = start.look_at.as_dvec3()
        + r1 * glam::DVec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos());
    let err = (cam.eye.as_dvec3() - expect).length();
    eprintln!("orbit + zoom: eye off the formula by {err:e}");
    // Measured 2.3e-8. The eye is stored in f32, which rounds coordinates near 6 by up to
    // 2.4e-7 each; a wrong sign or factor is off by more than 0.05.
    assert!(
        err < 1e-6,
        "eye {:?}, expected {expect:?} (off by {err})",
        cam.eye
    );
    assert_eq!(cam.look_at, start.look_at);
    assert_eq!(cam.up, start.up);

    // Right drag by (-20, 8): eye and target shift by (20 r + 8 u) * 2 d tan(fov/2) / H.
    let before = c.camera;
    let fr = before.frame();
    let d = (before.look_at - before.eye).length() as f64;
    for e in [
        cursor(50.0, 50.0),
        button(MouseButton::Right, ElementState::Pressed),
        cursor(30.0, 58.0),
        button(MouseButton::Right, ElementState::Released),
    ] {
        c.handle(control::translate(&e).unwrap());
    }
    let shift = (20.0 * fr.r + 8.0 * fr.u) * (2.0 * d * fr.s / 480.0);
    let moved = c.camera.eye.as_dvec3() - before.eye.as_dvec3();
    let moved_target = c.camera.look_at.as_dvec3() - before.look_at.as_dvec3();
    eprintln!("pan: off by {:e}", (moved - shift).length());
    // Measured 6.2e-8; the bound is the f32 rounding above.
    assert!((moved - shift).length() < 1e-6, "{moved:?} vs {shift:?}");
    assert!((moved_target - shift).length() < 1e-6, "{moved_target:?}");
    assert!(c.reset());
    assert_eq!(c.camera, start);
}
