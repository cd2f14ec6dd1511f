//! Tests of `[animation]` in scene files: both path kinds load into [`CameraPath`] with the
//! scene's camera at the first frame (bit for bit what a `[camera]` gives), and every error
//! names the file, the line and the dotted field.

use std::path::Path;

use glam::{DVec3, Vec3};

use super::*;
use crate::scene::{Camera, Interpolation};
use crate::Error;

fn load(text: &str) -> Result<Scene> {
    load_scene_str_with_search_path(text, "t.toml", Path::new("."), &[])
}

/// (line, field, message) of a scene error.
fn scene_err(text: &str) -> (usize, String, String) {
    match load(text) {
        Err(Error::Scene {
            file,
            line,
            field,
            message,
        }) => {
            assert_eq!(file, "t.toml");
            (line, field, message)
        }
        other => panic!(
            "expected a scene error, got {:?}",
            other.map(|s| s.triangles.len())
        ),
    }
}

const BALL: &str = "[[objects]]\nshape = \"sphere\"\n\n[[lights]]\nposition = [5, 5, 5]\n";

/// Three keyframes (lines 4-8, 10-13, 15-19).
const KEYS: &str = "\
[animation]
interpolation = \"catmull-rom\"

[[animation.keyframes]]
frame = 0
eye = [0.25, 1.5, 5.125]
look_at = [0, 0.5, 0]
fov = 40

[[animation.keyframes]]
frame = 12
eye = [4, 1, 3]
look_at = [0, 0.5, 0]
fov = 45

[[animation.keyframes]]
frame = 48
eye = [5, 2, -2]
look_at = [0.1, 0.4, 0]
up = [0, 1, 0.1]
fov = 50
";

const ORBIT: &str = "\
[animation.orbit]
centre = [1, 0.5, -2]
radius = 4
height = 1.5
turns = 2
frames = 90
first_frame = 10
start_angle = 45
fov = 35
";

#[test]
fn keyframes_load_with_the_first_key_as_the_scene_camera() {
    let s = load(&format!("{KEYS}{BALL}")).unwrap();
    let p = s.animation.as_ref().expect("an animated scene");
    assert_eq!(p.frames(), 0..=48);
    let (keys, interp) = p.keys().unwrap();
    assert_eq!(interp, Interpolation::CatmullRom);
    assert_eq!(keys.len(), 3);
    assert_eq!(keys[2].pose.up, DVec3::new(0.0, 1.0, 0.1));
    assert_eq!(keys[0].pose.up, DVec3::Y, "default up");
    // The local origin is the first frame's eye, and the scene's camera is that frame's.
    assert_eq!(s.origin, DVec3::new(0.25, 1.5, 5.125));
    assert_eq!(p.origin(), s.origin);
    assert_eq!(s.camera, p.camera_at(0));
    // The same camera, bit for bit, as the still scene with the first key as `[camera]`.
    let still = load(&format!(
        "[camera]\neye = [0.25, 1.5, 5.125]\nlook_at = [0, 0.5, 0]\nfov = 40\n{BALL}"
    ))
    .unwrap();
    assert_eq!(still.origin, s.origin);
    assert_eq!(still.camera, s.camera);
    assert_eq!(
        still.positions, s.positions,
        "same geometry relative to the same origin"
    );
    // A later key, relative to the origin.
    let k = p.camera_at(12);
    assert_eq!(k.eye, (DVec3::new(4.0, 1.0, 3.0) - s.origin).as_vec3());
    assert_eq!(k.vfov_deg, 45.0);
    assert!(still.animation.is_none());
}

#[test]
fn interpolation_defaults_to_linear() {
    let text = KEYS.replace("interpolation = \"catmull-rom\"\n", "");
    let s = load(&format!("{text}{BALL}")).unwrap();
    assert_eq!(
        s.animation.unwrap().keys().unwrap().1,
        Interpolation::Linear
    );
}

#[test]
fn an_orbit_loads_with_its_first_frame_as_the_scene_camera() {
    let s = load(&format!("{ORBIT}{BALL}")).unwrap();
    let p = s.animation.as_ref().unwrap();
    assert_eq!(p.frames(), 10..=99);
    let o = p.as_orbit().unwrap();
    assert_eq!((o.radius, o.height, o.turns, o.frames), (4.0, 1.5, 2.0, 90));
    let a = 45f64.to_radians();
    let eye0 = DVec3::new(1.0 + 4.0 * a.cos(), 2.0, -2.0 + 4.0 * a.sin());
    assert_eq!(s.origin, eye0);
    assert_eq!(s.camera, p.camera_at(10));
    assert_eq!(s.camera.eye, Vec3::ZERO);
    assert_eq!(
        s.camera.look_at,
        (DVec3::new(1.0, 0.5, -2.0) - eye0).as_vec3()
    );
    assert_eq!((s.camera.up, s.camera.vfov_deg), (Vec3::Y, 35.0));
    // Defaults: one turn, no height, from frame 0 at angle 0.
    let min = "[animation.orbit]\ncentre = [0, 0, 0]\nradius = 2\nframes = 8\nfov = 40\n";
    let s = load(&format!("{min}{BALL}")).unwrap();
    let p = s.animation.unwrap();
    assert_eq!(p.frames(), 0..=7);
    assert_eq!(s.origin, DVec3::new(2.0, 0.0, 0.0));
    let quarter = p.pose_at(2.0).eye;
    assert!(
        (quarter - DVec3::new(0.0, 0.0, 2.0)).length() < 1e-15,
        "{quarter}"
    );
}

#[test]
fn the_shipped_turntable_is_the_bunny_turning_once_in_120_frames() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/turntable.toml"
    ))
    .unwrap();
    let bunny =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/bunny.toml")).unwrap();
    // Without meshes: everything but the bunny's mesh, so this runs without the models.
    let strip = |t: &str| t.replace("mesh = \"bunny/stanford-bunny.obj\"", "shape = \"sphere\"");
    let s = parse_scene_str(&strip(&text), "turntable.toml").unwrap();
    let b = parse_scene_str(&strip(&bunny), "bunny.toml").unwrap();
    let p = s.animation.as_ref().unwrap();
    assert_eq!(p.frames(), 0..=119);
    assert_eq!(p.as_orbit().unwrap().turns, 1.0);
    // Frame 0 is bunny.toml's camera: the orbit's numbers are given to 12 digits, so the
    // eye agrees to about 1e-11 m in f64, which rounds to bunny's f32 eye.
    assert!(
        (s.origin - b.origin).length() < 1e-10,
        "{} vs {}",
        s.origin,
        b.origin
    );
    let w = |sc: &Scene, c: Camera| (c.look_at.as_dvec3() + sc.origin, c.up, c.vfov_deg);
    assert_eq!(w(&s, s.camera).1, w(&b, b.camera).1);
    assert_eq!(w(&s, s.camera).2, w(&b, b.camera).2);
    assert!((w(&s, s.camera).0 - w(&b, b.camera).0).length() < 1e-7);
    // Everything else is bunny.toml's.
    assert_eq!((s.background, s.ambient), (b.background, b.ambient));
    assert_eq!(s.lights.len(), b.lights.len());
    // The checker phase follows the origin, which differs by 1e-11 m.
    let no_phase = |sc: &Scene| {
        let mut m = sc.materials.clone();
        for c in m.iter_mut().filter_map(|m| m.checker.as_mut()) {
            c.phase = [0.0; 2];
        }
        m
    };
    assert_eq!(no_phase(&s), no_phase(&b));
    assert_eq!(s.triangles.len(), b.triangles.len());
    // Frame 60 is half a turn on: the eye opposite frame 0's across the bunny's axis.
    let (c, e0, e60) = (
        DVec3::new(-0.015, 0.1, 0.0),
        p.pose_at(0.0).eye,
        p.pose_at(60.0).eye,
    );
    assert!(((e0 - c) + (e60 - c) - DVec3::new(0.0, 0.14, 0.0)).length() < 1e-12);
    // The period: frame 120 is frame 0.
    assert_eq!(p.camera_at(120), p.camera_at(0));
}

#[test]
fn animation_errors_name_file_line_and_field() {
    let cases: Vec<(String, usize, &str, &str)> = vec![
        // Unknown keys, with a suggestion.
        (
            KEYS.replace("interpolation", "interpolaton"),
            2,
            "animation.interpolaton",
            "did you mean `interpolation`?",
        ),
        (
            KEYS.replace("fov = 45", "fvo = 45"),
            14,
            "animation.keyframes[1].fvo",
            "did you mean `fov`?",
        ),
        (
            ORBIT.replace("centre", "center"),
            2,
            "animation.orbit.center",
            "did you mean `centre`?",
        ),
        (
            KEYS.replace("\"catmull-rom\"", "\"catmullrom\""),
            2,
            "animation.interpolation",
            "did you mean `catmull-rom`?",
        ),
        (
            "[animation]\nkeyframe = []\n".into(),
            2,
            "animation.keyframe",
            "did you mean `keyframes`?",
        ),
        // Fewer than two keyframes.
        (
            KEYS.split("\n[[animation.keyframes]]\nframe = 12").next().unwrap().into(),
            4,
            "animation.keyframes",
            "at least 2 keyframes, got 1",
        ),
        // Frames not strictly increasing.
        (
            KEYS.replace("frame = 48", "frame = 12"),
            17,
            "animation.keyframes[2].frame",
            "strictly increasing",
        ),
        (
            KEYS.replace("frame = 12", "frame = -1"),
            11,
            "animation.keyframes[1].frame",
            "-1 is outside 0..=1000000",
        ),
        // A degenerate keyframe camera.
        (
            KEYS.replace("eye = [4, 1, 3]", "eye = [0, 0.5, 0]"),
            10,
            "animation.keyframes[1]",
            "degenerate: eye and look_at coincide",
        ),
        (
            KEYS.replace("up = [0, 1, 0.1]", "up = [-4.9, -1.6, 2]"),
            20,
            "animation.keyframes[2].up",
            "parallel to the viewing direction",
        ),
        // Non-finite numbers.
        (
            KEYS.replace("eye = [4, 1, 3]", "eye = [4, nan, 3]"),
            12,
            "animation.keyframes[1].eye",
            "must be finite",
        ),
        (
            KEYS.replace("fov = 50", "fov = inf"),
            21,
            "animation.keyframes[2].fov",
            "finite",
        ),
        (
            ORBIT.replace("height = 1.5", "height = 1e39"),
            4,
            "animation.orbit.height",
            "must be a finite number, got 1000000000000000000000000000000000000000",
        ),
        // Orbit values.
        (
            ORBIT.replace("radius = 4", "radius = 0"),
            3,
            "animation.orbit.radius",
            "must be > 0, got 0",
        ),
        (
            // The [camera] rule: an eye 1e-6 out at height 5 looks along up.
            ORBIT.replace("radius = 4", "radius = 1e-6").replace("height = 1.5", "height = 5"),
            3,
            "animation.orbit.radius",
            "looks along the orbit's axis",
        ),
        (
            ORBIT.replace("radius = 4", "radius = -2.5"),
            3,
            "animation.orbit.radius",
            "must be > 0",
        ),
        (
            ORBIT.replace("frames = 90", "frames = 0"),
            6,
            "animation.orbit.frames",
            "at least 1 frame",
        ),
        (
            ORBIT.replace("frames = 90", "frames = -3"),
            6,
            "animation.orbit.frames",
            "outside",
        ),
        (
            ORBIT.replace("fov = 35", "fov = 35\nup = [0, 0, 0]"),
            10,
            "animation.orbit.up",
            "no direction",
        ),
        (
            ORBIT.replace("fov = 35", "fov = 0"),
            9,
            "animation.orbit.fov",
            "(0, 180)",
        ),
        // What only a file can get wrong.
        (
            format!("{KEYS}\n{ORBIT}"),
            23,
            "animation.orbit",
            "either `[[animation.keyframes]]` or `[animation.orbit]`, not both",
        ),
        (
            format!("{ORBIT}\n[animation]\ninterpolation = \"linear\"\n"),
            12,
            "animation.interpolation",
            "applies to `[[animation.keyframes]]`",
        ),
        (
            "[animation]\ninterpolation = \"linear\"\n".into(),
            1,
            "animation",
            "needs `[[animation.keyframes]]` (two or more) or `[animation.orbit]`",
        ),
        (
            format!("[camera]\neye = [0, 1, 5]\nlook_at = [0, 0, 0]\nfov = 40\n\n{ORBIT}"),
            6,
            "animation",
            "either `[camera]` or `[animation]`, not both",
        ),
        // An interpolated frame that is degenerate: the eye walks through the target.
        (
            "[[animation.keyframes]]\nframe = 0\neye = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n\
             [[animation.keyframes]]\nframe = 10\neye = [0, 0, -5]\nlook_at = [0, 0, 0]\nfov = 40\n"
                .into(),
            6,
            "animation.keyframes[1]",
            "frame 5, between keyframes[0] (frame 0) and this one (frame 10), interpolates (linear)",
        ),
    ];
    for (text, line, field, needle) in cases {
        let (l, f, m) = scene_err(&format!("{text}{BALL}"));
        assert_eq!((l, f.as_str()), (line, field), "{m}\n{text}");
        assert!(m.contains(needle), "{field}: `{m}` lacks `{needle}`");
    }
    // No camera at all: the old message, now naming the animation as the alternative.
    let (l, f, m) = scene_err(BALL);
    assert_eq!((l, f.as_str()), (1, "camera"));
    assert!(
        m.contains("no `[camera]` table") && m.contains("`[animation]`"),
        "{m}"
    );
}
