//! Every bad input, through the real binary: exit code 2, one line on stderr naming the
//! file, line and field where that applies, no panic, no hang, no file written, and an
//! existing output never replaced.

mod common;

use common::words;

use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};
use std::time::{Duration, Instant};

const CAM: &str = "[camera]\neye = [0, 1, 5]\nlook_at = [0, 1, 0]\nfov = 45\n";
const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fragtrace-bad-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Runs the binary in `dir` with `args` (and `env`), with a deadline: a hang is a failure.
fn run_in(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = common::bin();
    cmd.current_dir(dir)
        .args(args)
        .env_remove("FRAGTRACE_GL_LIMITS")
        .env_remove("FRAGTRACE_EGL_LIBRARY")
        .env("FRAGTRACE_MODEL_PATH", dir.join("no-models"))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    for (k, v) in env {
        cmd.env(k, v);
    }
    let mut child = cmd.spawn().unwrap();
    let t0 = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            return child.wait_with_output().unwrap();
        }
        if t0.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("fragtrace {args:?} hung");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Asserts exit code 2, a single `fragtrace: error:` line containing every needle, and
/// returns that line.
fn fails(dir: &Path, args: &[&str], env: &[(&str, &str)], needles: &[&str]) -> String {
    let out = run_in(dir, args, env);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert!(!err.contains("panicked"), "{args:?}: {err}");
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

/// Renders `scene` at 4x4 on the CPU into `out` in `dir`; must fail with `needles`.
fn scene_fails(dir: &Path, scene: &str, needles: &[&str]) -> String {
    let line = fails(
        dir,
        &[
            "render",
            scene,
            "--backend",
            "cpu",
            "--width",
            "4",
            "--height",
            "4",
            "-q",
            "-o",
            "out.png",
        ],
        &[],
        needles,
    );
    assert!(
        !dir.join("out.png").exists(),
        "{scene}: an image was written"
    );
    line
}

/// Nothing but the inputs is left in `dir`: no image, no temporary or probe file.
fn only_inputs(dir: &Path, inputs: &[&str]) {
    let mut left: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !inputs.contains(&n.as_str()))
        .collect();
    left.sort();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn malformed_toml_names_file_line_and_field() {
    let d = tmpdir("malformed");
    write(
        &d,
        "broken.toml",
        "ambient = [0.1, 0.1, 0.1]\n[camera]\neye = [0, 0, 1\nlook_at = [0, 0, 0]\n",
    );
    scene_fails(&d, "broken.toml", &["broken.toml:4:", "camera.eye"]);
    write(
        &d,
        "dup.toml",
        &format!("{CAM}[image]\nwidth = 4\nwidth = 8\n"),
    );
    scene_fails(&d, "dup.toml", &["dup.toml:7:", "image.width", "duplicate"]);
    write(
        &d,
        "type.toml",
        &format!("{CAM}[[lights]]\nposition = \"up\"\n"),
    );
    scene_fails(&d, "type.toml", &["type.toml:6:", "lights[0].position"]);
    std::fs::write(d.join("latin1.toml"), b"# caf\xe9\n[camera]\n").unwrap();
    scene_fails(&d, "latin1.toml", &["latin1.toml:1:", "UTF-8"]);
    only_inputs(&d, &["broken.toml", "dup.toml", "type.toml", "latin1.toml"]);
}

#[test]
fn unknown_keys_suggest_the_known_one() {
    let d = tmpdir("unknown");
    write(
        &d,
        "k.toml",
        "[camera]\neye = [0, 1, 5]\nlook_at = [0, 1, 0]\nfvo = 45\n",
    );
    scene_fails(
        &d,
        "k.toml",
        &[
            "k.toml:4:",
            "camera.fvo",
            "unknown key `fvo`",
            "did you mean `fov`?",
        ],
    );
    write(
        &d,
        "o.toml",
        &format!("{CAM}[[objects]]\nshape = \"box\"\ntranslation = [1, 2, 3]\n"),
    );
    scene_fails(
        &d,
        "o.toml",
        &[
            "o.toml:7:",
            "objects[0].translation",
            "did you mean `translate`?",
        ],
    );
    write(
        &d,
        "v.toml",
        &format!("{CAM}[[objects]]\nshape = \"sphre\"\n"),
    );
    scene_fails(
        &d,
        "v.toml",
        &["v.toml:6:", "objects[0].shape", "did you mean `sphere`?"],
    );
}

#[test]
fn missing_obj_names_the_scene_line_and_the_folders_searched() {
    let d = tmpdir("noobj");
    write(
        &d,
        "s.toml",
        &format!("{CAM}[[objects]]\nmesh = \"gone/missing.obj\"\n"),
    );
    scene_fails(
        &d,
        "s.toml",
        &[
            "gone/missing.obj",
            "mesh not found",
            "s.toml:6",
            "objects[0].mesh",
            "FRAGTRACE_MODEL_PATH",
        ],
    );
}

#[test]
fn missing_mtl_is_an_error_unless_the_scene_overrides_materials() {
    let d = tmpdir("nomtl");
    write(
        &d,
        "m.obj",
        &format!("# a triangle\nmtllib nowhere.mtl\nusemtl red\n{TRI}"),
    );
    write(
        &d,
        "s.toml",
        &format!("{CAM}[[lights]]\nposition = [0, 3, 3]\n[[objects]]\nmesh = \"m.obj\"\n"),
    );
    scene_fails(
        &d,
        "s.toml",
        &[
            "s.toml:8:",
            "objects[0].mesh",
            "m.obj: line 2: mtllib `nowhere.mtl`",
            "material =",
        ],
    );
    // With an override the MTL is not needed: it renders.
    write(&d, "ok.toml", &format!("{CAM}[[lights]]\nposition = [0, 3, 3]\n[[objects]]\nmesh = \"m.obj\"\nmaterial = {{ albedo = [1, 0, 0] }}\n"));
    let out = run_in(
        &d,
        &words("render ok.toml --backend cpu --width 4 --height 4 -q -o ok.png"),
        &[],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(d.join("ok.png").is_file());
    // An MTL that is a directory counts as missing.
    std::fs::create_dir_all(d.join("nowhere.mtl")).unwrap();
    scene_fails(&d, "s.toml", &["s.toml:8:", "nowhere.mtl", "directory"]);
}

#[test]
fn obj_face_index_out_of_range_and_non_finite_coordinates() {
    let d = tmpdir("obj");
    write(&d, "idx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
    write(&d, "nan.obj", "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
    write(
        &d,
        "inf.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 inf\nf 1//1 2//1 3//1\n",
    );
    for (obj, needles) in [
        (
            "idx.obj",
            ["idx.obj: line 4:", "vertex index 4 out of range"],
        ),
        ("nan.obj", ["nan.obj: line 2:", "non-finite vertex"]),
        ("inf.obj", ["inf.obj: line 4:", "non-finite normal"]),
    ] {
        let scene = format!("{obj}.toml");
        write(
            &d,
            &scene,
            &format!("{CAM}[[objects]]\nmesh = \"{obj}\"\nmaterial = {{}}\n"),
        );
        scene_fails(&d, &scene, &needles);
    }
}

#[test]
fn obj_face_with_fewer_than_three_vertices_names_scene_object_obj_and_line() {
    let d = tmpdir("obj-short-face");
    write(&d, "two.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\n");
    write(&d, "one.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 3\n");
    write(&d, "none.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf\n");
    for (obj, needles) in [
        ("two.obj", ["two.obj: line 5:", "face with 2 vertices"]),
        ("one.obj", ["one.obj: line 4:", "face with 1 vertex "]),
        ("none.obj", ["none.obj: line 4:", "face with 0 vertices"]),
    ] {
        let scene = format!("{obj}.toml");
        // The mesh is the third object, so the prefix must name objects[2] and its line.
        write(
            &d,
            &scene,
            &format!(
                "{CAM}[[objects]]\nshape = \"box\"\n[[objects]]\nshape = \"box\"\n\
                 [[objects]]\nmesh = \"{obj}\"\nmaterial = {{}}\n"
            ),
        );
        let line = scene_fails(&d, &scene, &needles);
        assert!(
            line.contains(&format!("{scene}:10: objects[2].mesh: ./{obj}: line")),
            "{line}"
        );
    }
    // A two-point polyline stays legal (it is ignored, as every `l` is).
    write(&d, "l.obj", &format!("{TRI}l 1 2\n"));
    write(
        &d,
        "l.toml",
        &format!("{CAM}[[objects]]\nmesh = \"l.obj\"\nmaterial = {{}}\n"),
    );
    let out = run_in(
        &d,
        &words("render l.toml --backend cpu --width 4 --height 4 -q -o l.png"),
        &[],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn non_finite_toml_numbers_name_the_field() {
    let d = tmpdir("toml-nan");
    for (body, needles) in [
        (
            format!("ambient = [0.1, nan, 0.1]\n{CAM}"),
            ["n.toml:1:", "ambient", "finite"],
        ),
        (
            format!("{CAM}[[lights]]\nposition = [0, inf, 0]\n"),
            ["n.toml:6:", "lights[0].position", "finite"],
        ),
        (
            format!("{CAM}[[objects]]\nshape = \"box\"\ntranslate = [1e39, 0, 0]\n"),
            ["n.toml:7:", "objects[0].translate", "finite"],
        ),
        (
            format!("{CAM}[materials.g]\nior = -inf\n"),
            ["n.toml:6:", "materials.g.ior", "finite"],
        ),
    ] {
        write(&d, "n.toml", &body);
        scene_fails(&d, "n.toml", &needles);
    }
}

/// `[animation]` errors through the binary: exit 2, one line with file, line and field.
#[test]
fn bad_camera_paths_name_file_line_and_field() {
    let d = tmpdir("anim");
    let orbit = "[animation.orbit]\ncentre = [0, 1, 0]\nradius = 2\nframes = 24\nfov = 40\n";
    let key = |f: u32, eye: &str| {
        format!(
            "[[animation.keyframes]]\nframe = {f}\neye = {eye}\nlook_at = [0, 0, 0]\nfov = 40\n"
        )
    };
    for (body, needles) in [
        (
            orbit.replace("radius = 2", "radius = 0"),
            vec!["a.toml:3:", "animation.orbit.radius", "must be > 0, got 0"],
        ),
        (
            orbit.replace("frames = 24", "frames = 0"),
            vec!["a.toml:4:", "animation.orbit.frames", "at least 1 frame"],
        ),
        (
            orbit.replace("centre", "center"),
            vec![
                "a.toml:2:",
                "animation.orbit.center",
                "did you mean `centre`?",
            ],
        ),
        (
            format!("{CAM}{orbit}"),
            vec!["a.toml:5:", "animation", "not both"],
        ),
        (
            key(0, "[0, 0, 5]"),
            vec![
                "a.toml:1:",
                "animation.keyframes",
                "at least 2 keyframes, got 1",
            ],
        ),
        (
            format!("{}{}", key(10, "[0, 0, 5]"), key(10, "[1, 0, 5]")),
            vec![
                "a.toml:7:",
                "animation.keyframes[1].frame",
                "strictly increasing",
            ],
        ),
        (
            format!("{}{}", key(0, "[0, 0, 5]"), key(10, "[0, nan, 5]")),
            vec!["a.toml:8:", "animation.keyframes[1].eye", "finite"],
        ),
        (
            format!("{}{}", key(0, "[0, 0, 5]"), key(10, "[0, 0, -5]")),
            vec![
                "a.toml:6:",
                "animation.keyframes[1]",
                "frame 5, between",
                "eye and look_at coincide",
            ],
        ),
    ] {
        write(
            &d,
            "a.toml",
            &format!("{body}[[objects]]\nshape = \"box\"\n"),
        );
        scene_fails(&d, "a.toml", &needles);
    }
}

#[test]
fn undefined_material_suggests_the_defined_one() {
    let d = tmpdir("mat");
    write(&d, "m.toml", &format!("{CAM}[materials.glass]\nior = 1.5\n[[objects]]\nshape = \"box\"\nmaterial = \"glas\"\n"));
    scene_fails(
        &d,
        "m.toml",
        &[
            "m.toml:9:",
            "objects[0].material",
            "undefined material `glas`",
            "did you mean `glass`?",
        ],
    );
}

#[test]
fn image_sizes_zero_negative_and_too_large() {
    let d = tmpdir("size");
    let base = ["render", "--backend", "cpu", "-q", "-o", "out.png"];
    let with = |extra: &[&'static str]| -> Vec<&str> {
        base.iter().copied().chain(extra.iter().copied()).collect()
    };
    fails(
        &d,
        &with(&["--width", "0"]),
        &[],
        &["--width 0", "1..=16384"],
    );
    fails(&d, &with(&["--height", "0"]), &[], &["--height 0"]);
    // Negative values are clap's to reject: still one line and exit code 2.
    fails(&d, &with(&["--width=-5"]), &[], &["'-5'", "--width"]);
    fails(&d, &with(&["--height", "-5"]), &[], &["-5"]);
    fails(&d, &with(&["--width", "16385"]), &[], &["--width 16385"]);
    // Within the per-side bound but beyond the host-memory bound: refused before allocating.
    fails(
        &d,
        &with(&["--width", "16384", "--height", "16384"]),
        &[],
        &["16384x16384", "host memory", "8 GiB"],
    );
    write(&d, "w.toml", &format!("{CAM}[image]\nwidth = 0\n"));
    scene_fails(&d, "w.toml", &["w.toml:6:", "image.width", "1..=16384"]);
    write(&d, "h.toml", &format!("{CAM}[image]\nheight = -480\n"));
    scene_fails(&d, "h.toml", &["h.toml:6:", "image.height"]);
    only_inputs(&d, &["w.toml", "h.toml"]);
}

#[test]
fn image_beyond_the_gl_limits_is_refused_before_allocating() {
    let d = tmpdir("gl-limit");
    std::fs::write(d.join("out.png"), b"previous image").unwrap();
    // The geforce7 profile lowers GL_MAX_TEXTURE_SIZE and the viewport to 4096.
    fails(
        &d,
        &words("render --backend gl --width 5000 --height 8 -q -o out.png"),
        &[("FRAGTRACE_GL_LIMITS", "geforce7")],
        &["5000x8", "GL_MAX_TEXTURE_SIZE 4096"],
    );
    // A failed render leaves the existing image as it was.
    assert_eq!(std::fs::read(d.join("out.png")).unwrap(), b"previous image");
    only_inputs(&d, &["out.png"]);
}

#[test]
fn max_depth_out_of_range() {
    let d = tmpdir("depth");
    fails(
        &d,
        &words("render --backend cpu --max-depth 17 -o out.png"),
        &[],
        &["--max-depth 17", "0..=16"],
    );
    fails(
        &d,
        &["render", "--max-depth", "-1", "-o", "out.png"],
        &[],
        &["-1"],
    );
    write(&d, "d.toml", &format!("max_depth = 99\n{CAM}"));
    scene_fails(&d, "d.toml", &["d.toml:1:", "max_depth", "0..=16"]);
}

#[test]
fn unwritable_output_is_refused_before_the_scene_is_loaded() {
    let d = tmpdir("out");
    write(&d, "file", "not a folder");
    std::fs::create_dir_all(d.join("folder.png")).unwrap();
    // The scene does not exist: the output is checked first, so the message is about it.
    for (out, needle) in [
        ("no/such/dir/x.png", "no/such/dir"),
        ("file/x.png", "not a directory"),
        ("folder.png", "is a directory"),
    ] {
        let line = fails(
            &d,
            &["render", "missing.toml", "-o", out],
            &[],
            &[out, needle, "cannot write"],
        );
        assert!(!line.contains("missing.toml"), "{line}");
    }
    fails(
        &d,
        &words("render missing.toml -o x.png --stats no/dir/s.json"),
        &[],
        &["no/dir/s.json", "statistics"],
    );
    fails(
        &d,
        &["render", "missing.toml", "-o", "x.bmp"],
        &[],
        &["x.bmp", "unknown image extension"],
    );
    only_inputs(&d, &["file", "folder.png"]);
}

#[test]
fn existing_output_is_untouched_by_a_failed_run() {
    let d = tmpdir("keep");
    std::fs::write(d.join("out.png"), b"previous image").unwrap();
    write(
        &d,
        "bad.toml",
        &format!("{CAM}[[objects]]\nshape = \"box\"\nmaterial = \"nope\"\n"),
    );
    scene_fails_keeping(&d, "bad.toml");
    // A render that fails after loading (no EGL with --backend gl) keeps it too.
    fails(
        &d,
        &words("render --backend gl --width 4 --height 4 -q -o out.png"),
        &[("FRAGTRACE_EGL_LIBRARY", "/nonexistent/libEGL.so.1")],
        &["/nonexistent/libEGL.so.1"],
    );
    assert_eq!(std::fs::read(d.join("out.png")).unwrap(), b"previous image");
    only_inputs(&d, &["out.png", "bad.toml"]);
}

fn scene_fails_keeping(d: &Path, scene: &str) {
    fails(
        d,
        &[
            "render",
            scene,
            "--backend",
            "cpu",
            "--width",
            "4",
            "--height",
            "4",
            "-q",
            "-o",
            "out.png",
        ],
        &[],
        &[scene],
    );
    assert_eq!(std::fs::read(d.join("out.png")).unwrap(), b"previous image");
}

#[test]
fn directories_and_devices_are_not_read_as_scenes_or_meshes() {
    let d = tmpdir("special");
    std::fs::create_dir_all(d.join("adir.toml")).unwrap();
    std::fs::create_dir_all(d.join("adir.obj")).unwrap();
    scene_fails(
        &d,
        "adir.toml",
        &["adir.toml", "is a directory", "regular file"],
    );
    scene_fails(&d, "/dev/zero", &["/dev/zero", "not a regular file"]);
    write(
        &d,
        "zero.toml",
        &format!("{CAM}[[objects]]\nmesh = \"/dev/zero\"\nmaterial = {{}}\n"),
    );
    scene_fails(
        &d,
        "zero.toml",
        &["/dev/zero", "not a regular file", "zero.toml:6"],
    );
    write(
        &d,
        "dir.toml",
        &format!("{CAM}[[objects]]\nmesh = \"adir.obj\"\nmaterial = {{}}\n"),
    );
    scene_fails(&d, "dir.toml", &["adir.obj", "a directory", "dir.toml:6"]);
    // Bigger than any scene: refused without reading it (a sparse file, nothing written).
    let big = std::fs::File::create(d.join("big.toml")).unwrap();
    big.set_len(17 << 20).unwrap();
    scene_fails(&d, "big.toml", &["big.toml", "limit"]);
}

#[test]
fn no_egl_library_names_it_and_the_packages() {
    let d = tmpdir("egl");
    fails(
        &d,
        &words("render --backend gl --width 4 --height 4 -o out.png"),
        &[("FRAGTRACE_EGL_LIBRARY", "/nonexistent")],
        &["/nonexistent", "libegl1 libegl-mesa0 libgl1-mesa-dri"],
    );
    fails(
        &d,
        &["info"],
        &[("FRAGTRACE_EGL_LIBRARY", "/nonexistent")],
        &["/nonexistent", "libegl1"],
    );
    only_inputs(&d, &[]);
}

#[test]
fn clap_usage_errors_are_one_line_with_exit_code_2() {
    let d = tmpdir("clap");
    fails(&d, &["--bogus"], &[], &["--bogus", "--help"]);
    fails(
        &d,
        &["render", "--backend", "vulkan"],
        &[],
        &["vulkan", "--backend"],
    );
    fails(&d, &["render", "--spp", "many"], &[], &["many", "--spp"]);
    fails(&d, &["compare"], &[], &["required"]);
    fails(&d, &["frobnicate", "x", "y"], &[], &["'x'"]);
    // Help is an answer, not an error.
    let out = run_in(&d, &["--help"], &[]);
    assert_eq!(out.status.code(), Some(0));
}

/// `--grid AxBxC` sets the uniform grid's resolution: with the irregular grid (the default,
/// or `--accel irregular`) it is a usage error naming the flag and the fix, one line, exit
/// code 2; an unknown `--accel` value and a `--grid-density` out of range likewise, for
/// either structure.
#[test]
fn grid_without_accel_uniform_and_bad_accel_flags_are_usage_errors() {
    let d = tmpdir("accel");
    for args in [
        &["render", "--backend", "cpu", "--grid", "8x8x8"][..],
        &words("render --backend cpu --accel irregular --grid 8x8x8"),
    ] {
        fails(&d, args, &[], &["--grid 8x8x8", "--accel uniform"]);
    }
    fails(
        &d,
        &["render", "--accel", "kdtree"],
        &[],
        &["kdtree", "--accel"],
    );
    // The BVH is the CPU's alone: the GPU backend refuses it, and it has no grid density.
    fails(
        &d,
        &["render", "--backend", "gl", "--accel", "bvh"],
        &[],
        &["--accel bvh", "CPU backend only"],
    );
    for (accel, density, said) in [
        ("bvh", "2", &["--grid-density", "BVH"][..]),
        ("uniform", "0", &["--grid-density 0"][..]),
        ("irregular", "0", &["--grid-density 0"][..]),
    ] {
        let args = ["render", "--backend", "cpu", "--accel", accel];
        let args = [&args[..], &["--grid-density", density]].concat();
        fails(&d, &args, &[], said);
    }
    // Nothing was rendered by any of them.
    only_inputs(&d, &[]);
}

/// The one rule for flags that do not apply to the backend or kernel chosen (issue 51):
/// on every front door (render, view, a bench configuration) each is refused in one line
/// naming the flag and why, exit code 2, before anything renders, and the advice names
/// only flags that door has. Before, `--backend cpu --gpu 7`, `--backend cpu --kernel
/// multipass`, `--backend gl --precision f32` and `--kernel compute --mask stencil`
/// rendered and ignored the flag, `--kernel compute --storage f16` was refused as a
/// limit, `-q -v` printed the verbose tables, and `view --accel bvh` advised
/// `--backend cpu`, which `view` does not take.
#[test]
fn flags_that_do_not_apply_are_refused_on_every_front_door() {
    let d = tmpdir("apply");
    let size = ["--width", "8", "--height", "6", "-o", "out.png"];
    for (flags, said) in [
        (
            &["--backend", "cpu", "--gpu", "7"][..],
            &["--gpu 7", "applies to the GPU backend"][..],
        ),
        (
            &["--backend", "cpu", "--kernel", "multipass"],
            &["--kernel multipass", "applies to the GPU backend"],
        ),
        (
            &["--backend", "gl", "--precision", "f32"],
            &["--precision f32", "applies to the CPU backend"],
        ),
        (
            &["--kernel", "compute", "--mask", "stencil"],
            &["--mask stencil", "applies to the fragment kernels"],
        ),
        (
            &["--kernel", "looped", "--scene-fetch", "storage-buffer"],
            &[
                "--scene-fetch storage-buffer",
                "applies to the compute kernel",
            ],
        ),
        (
            &["--kernel", "compute", "--storage", "f16"],
            &["--storage f16", "applies to the fragment kernels"],
        ),
    ] {
        let args = [&["render"][..], flags, &size].concat();
        let line = fails(&d, &args, &[], said);
        assert!(!line.contains("limit exceeded"), "{line}");
    }
    fails(
        &d,
        &[&["render", "-q", "-v"][..], &size].concat(),
        &[],
        &["--verbose"],
    );
    // `view` has no --backend cpu to advise: the structures it does have instead.
    for (flags, said) in [
        (
            &["--accel", "bvh"][..],
            &["--accel bvh", "--accel irregular"][..],
        ),
        (
            &["--precision", "f32"],
            &["--precision f32", "applies to the CPU backend"],
        ),
        (
            &["--kernel", "compute", "--mask", "stencil"],
            &["--mask stencil"],
        ),
    ] {
        let line = fails(&d, &[&["view"][..], flags].concat(), &[], said);
        assert!(!line.contains("--backend"), "{line}");
    }
    // A bench configuration goes through the same rule.
    write(
        &d,
        "c.toml",
        "[configs]\nodd = \"--backend cpu --kernel looped\"\n",
    );
    let line = fails(
        &d,
        &words("bench --configs c.toml --scenes whitted --out b"),
        &[],
        &["--kernel looped", "applies to the GPU backend"],
    );
    assert!(line.contains("odd"), "{line}");
    only_inputs(&d, &["c.toml"]);
}

/// A folder that cannot be made because a file has its name (`dump-shaders builtin FILE`,
/// `bench --out FILE`) is one line naming it, not the OS's "File exists"; a difference
/// image `compare` cannot write is refused before any figure is printed; `--threads 0` is
/// out of range. Each exits 2 and leaves the file as it was.
#[test]
fn output_folders_and_compare_diff_are_checked_first() {
    let d = tmpdir("folders");
    let file = write(&d, "afile", "keep me");
    for args in [
        &["dump-shaders", "builtin", "afile"][..],
        &["bench", "--out", "afile", "--scenes", "builtin"][..],
    ] {
        let line = fails(&d, args, &[], &["afile", "a file of that name exists"]);
        assert!(!line.contains("os error"), "{line}");
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "keep me");
    }
    let ok = run_in(
        &d,
        &["render", "--width", "8", "--height", "6", "-o", "a.png"],
        &[],
    );
    assert!(ok.status.success(), "{ok:?}");
    let out = run_in(
        &d,
        &["compare", "a.png", "a.png", "--diff", "nodir/d.png"],
        &[],
    );
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    assert!(
        out.stdout.is_empty(),
        "figures printed before the refusal: {out:?}"
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("nodir") && err.lines().count() == 1, "{err}");
    fails(
        &d,
        &["render", "--threads", "0"],
        &[],
        &["--threads", "1..=1024"],
    );
}
