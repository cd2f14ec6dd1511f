//! Tests of [`CameraPath`]: keys exact bit for bit, interpolation against closed forms
//! (linear midpoints, Catmull-Rom through the keys with the parabola's tangent, a quadratic
//! reproduced), the orbit on its circle and periodic, every refused path, and a property
//! test that reasonable random paths give a valid camera on every frame.

use super::*;
use glam::Vec3;
use proptest::prelude::*;

fn pose(eye: [f64; 3], look_at: [f64; 3], up: [f64; 3], fov: f64) -> Pose {
    Pose {
        eye: DVec3::from_array(eye),
        look_at: DVec3::from_array(look_at),
        up: DVec3::from_array(up),
        fov_deg: fov,
    }
}

fn key(frame: u32, eye: [f64; 3], look_at: [f64; 3], fov: f64) -> Keyframe {
    Keyframe {
        frame,
        pose: pose(eye, look_at, [0.0, 1.0, 0.0], fov),
    }
}

/// Four keys at uneven frames, with awkward decimals so that rounding would show.
fn keys4() -> Vec<Keyframe> {
    vec![
        key(3, [0.1, 1.3, 5.7], [0.0, 0.9, 0.0], 40.0),
        key(10, [2.9, 1.1, 4.3], [0.3, 1.0, -0.2], 35.5),
        key(30, [5.3, 2.7, -1.1], [0.2, 0.8, 0.1], 52.25),
        key(33, [3.3, 2.1, -4.9], [-0.1, 1.2, 0.0], 47.0),
    ]
}

fn orbit() -> Orbit {
    Orbit {
        centre: DVec3::new(1.5, -0.25, 3.0),
        radius: 2.5,
        height: 0.75,
        turns: 1.0,
        frames: 120,
        first_frame: 0,
        start_angle_deg: 30.0,
        up: DVec3::Y,
        fov_deg: 40.0,
    }
}

#[test]
fn a_frame_on_a_keyframe_is_that_keyframe_bit_for_bit() {
    let origin = DVec3::new(0.1, 1.3, 5.7) + DVec3::splat(1e-3);
    for interp in [Interpolation::Linear, Interpolation::CatmullRom] {
        let keys = keys4();
        let p = CameraPath::keyframes(keys.clone(), interp).unwrap();
        let local = p.clone().with_origin(origin).unwrap();
        for k in &keys {
            let want = Camera {
                eye: k.pose.eye.as_vec3(),
                look_at: k.pose.look_at.as_vec3(),
                up: k.pose.up.as_vec3(),
                vfov_deg: k.pose.fov_deg as f32,
            };
            let got = p.camera_at(k.frame);
            // Compare bits, not values: -0.0 == 0.0 would hide a difference.
            let bits = |c: Camera| {
                (
                    c.eye.to_array().map(f32::to_bits),
                    c.look_at.to_array().map(f32::to_bits),
                    c.up.to_array().map(f32::to_bits),
                    c.vfov_deg.to_bits(),
                )
            };
            assert_eq!(bits(got), bits(want), "{interp} frame {}", k.frame);
            assert_eq!(p.pose_at(k.frame as f64), k.pose);
            // Relative to an origin: the eye minus the origin in f64, then rounded, as the
            // loader rounds a still camera.
            let l = local.camera_at(k.frame);
            assert_eq!(l.eye, (k.pose.eye - origin).as_vec3());
            assert_eq!(l.look_at, (k.pose.look_at - origin).as_vec3());
        }
        assert_eq!(p.frames(), 3..=33);
        assert_eq!(p.frame_count(), 31);
    }
}

#[test]
fn linear_is_the_straight_line_at_constant_speed() {
    let keys = keys4();
    let p = CameraPath::keyframes(keys.clone(), Interpolation::Linear).unwrap();
    // Frame 20 is the midpoint of keys 1 (frame 10) and 2 (frame 30).
    let (a, b) = (keys[1].pose, keys[2].pose);
    let m = p.pose_at(20.0);
    assert!(
        (m.eye - (a.eye + b.eye) / 2.0).length() < 1e-15,
        "{}",
        m.eye
    );
    assert!((m.look_at - (a.look_at + b.look_at) / 2.0).length() < 1e-15);
    assert!((m.fov_deg - (35.5 + 52.25) / 2.0).abs() < 1e-13);
    // A quarter of the way from key 0 (frame 3) to key 1 (frame 10).
    let q = p.pose_at(3.0 + 7.0 / 4.0);
    let (a, b) = (keys[0].pose, keys[1].pose);
    assert!((q.eye - (a.eye * 0.75 + b.eye * 0.25)).length() < 1e-15);
    // Camera at an integer frame: the f64 pose rounded.
    assert_eq!(p.camera_at(20), m.camera(DVec3::ZERO));
}

#[test]
fn up_is_interpolated_as_a_unit_vector() {
    let mut keys = keys4();
    keys[1].pose.up = DVec3::new(0.0, 3.0, 0.0); // Length does not weigh in.
    keys[2].pose.up = DVec3::new(0.3, 1.0, 0.0);
    for interp in [Interpolation::Linear, Interpolation::CatmullRom] {
        let p = CameraPath::keyframes(keys.clone(), interp).unwrap();
        assert_eq!(
            p.pose_at(10.0).up,
            DVec3::new(0.0, 3.0, 0.0),
            "key as written"
        );
        for t in [10.5, 15.0, 20.0, 29.0] {
            let up = p.pose_at(t).up;
            assert!((up.length() - 1.0).abs() < 1e-15, "{interp} {t}: {up}");
        }
    }
    // Linear midpoint: the normalised mean of the two unit ups.
    let p = CameraPath::keyframes(keys, Interpolation::Linear).unwrap();
    let want = (DVec3::Y + DVec3::new(0.3, 1.0, 0.0).normalize()).normalize();
    assert!((p.pose_at(20.0).up - want).length() < 1e-15);
}

/// The derivative at key i of the parabola through keys i-1, i, i+1 (one channel).
fn parabola_slope(t: [f64; 3], p: [f64; 3]) -> f64 {
    let (hl, hr) = (t[1] - t[0], t[2] - t[1]);
    let (sl, sr) = ((p[1] - p[0]) / hl, (p[2] - p[1]) / hr);
    (hr * sl + hl * sr) / (hl + hr)
}

#[test]
fn catmull_rom_passes_through_keys_with_the_parabola_tangent() {
    let keys = keys4();
    let p = CameraPath::keyframes(keys.clone(), Interpolation::CatmullRom).unwrap();
    // Small steps: the second derivative jumps at a key, so a central difference there is
    // off by about h times that jump (0.06 here).
    let h = 1e-6;
    let d = |t: f64| (p.pose_at(t + h).eye - p.pose_at(t - h).eye) / (2.0 * h);
    for i in 1..keys.len() - 1 {
        let t = [i - 1, i, i + 1].map(|j| keys[j].frame as f64);
        for axis in 0..3 {
            let want = parabola_slope(t, [i - 1, i, i + 1].map(|j| keys[j].pose.eye[axis]));
            let got = d(t[1])[axis];
            // Central difference of a cubic on each side: error O(h^2) times the second
            // derivative's jump, well under 1e-6 here.
            assert!(
                (got - want).abs() < 1e-6,
                "key {i} axis {axis}: {got} vs {want}"
            );
        }
        // C1: the one-sided slopes agree at the key.
        let left = (p.pose_at(t[1]).eye - p.pose_at(t[1] - h).eye) / h;
        let right = (p.pose_at(t[1] + h).eye - p.pose_at(t[1]).eye) / h;
        assert!((left - right).length() < 1e-3, "{left} vs {right}");
    }
    // End keys (duplicated): half the end segment's slope.
    let end = (keys[1].pose.fov_deg - keys[0].pose.fov_deg) / 7.0 / 2.0;
    let got = (p.pose_at(3.0 + h).fov_deg - p.pose_at(3.0).fov_deg) / h;
    assert!((got - end).abs() < 1e-3, "{got} vs {end}");
    // Between keys it is not the straight line (the test above would pass for linear too,
    // were it not for the tangent).
    let lin = CameraPath::keyframes(keys, Interpolation::Linear).unwrap();
    assert!((p.pose_at(20.0).eye - lin.pose_at(20.0).eye).length() > 1e-2);
}

#[test]
fn catmull_rom_reproduces_a_quadratic_between_interior_keys() {
    // Keys sampled from q(t) = a + b t + c t^2 at uneven frames: on a segment between two
    // interior keys both tangents are q's derivative, and a cubic Hermite with exact
    // end slopes is q itself.
    let (a, b, c) = (
        DVec3::new(1.0, -2.0, 0.5),
        DVec3::new(0.3, 0.1, -0.2),
        DVec3::new(-0.01, 0.004, 0.002),
    );
    let q = |t: f64| a + b * t + c * t * t;
    let frames = [0u32, 4, 13, 20, 31, 33];
    let keys: Vec<Keyframe> = frames
        .iter()
        .map(|&f| Keyframe {
            frame: f,
            pose: Pose {
                eye: q(f as f64),
                look_at: q(f as f64) + DVec3::new(0.0, 0.0, -5.0),
                up: DVec3::Y,
                fov_deg: 40.0 + 0.5 * f as f64 - 0.01 * (f * f) as f64,
            },
        })
        .collect();
    let p = CameraPath::keyframes(keys, Interpolation::CatmullRom).unwrap();
    for t in (4..=31).map(|f| f as f64).chain([5.5, 17.25, 30.9]) {
        let got = p.pose_at(t);
        assert!(
            (got.eye - q(t)).length() < 1e-12,
            "t {t}: {} vs {}",
            got.eye,
            q(t)
        );
        let fov = 40.0 + 0.5 * t - 0.01 * t * t;
        assert!((got.fov_deg - fov).abs() < 1e-12, "t {t}");
    }
    // The end segments are not quadratic (half-slope ends): frame 2 is off q.
    assert!((p.pose_at(2.0).eye - q(2.0)).length() > 1e-3);
}

#[test]
fn keyframed_paths_hold_their_end_keys_outside_their_frames() {
    let keys = keys4();
    let p = CameraPath::keyframes(keys.clone(), Interpolation::CatmullRom).unwrap();
    assert_eq!(p.pose_at(0.0), keys[0].pose);
    assert_eq!(p.pose_at(1e9), keys[3].pose);
    assert_eq!(p.pose_at(f64::NAN), keys[0].pose);
    assert_eq!(p.camera_at(u32::MAX), keys[3].pose.camera(DVec3::ZERO));
}

#[test]
fn the_orbit_eye_is_on_its_circle_at_the_right_angle() {
    let o = orbit();
    let p = CameraPath::orbit(o).unwrap();
    assert_eq!(p.frames(), 0..=119);
    for f in [0u32, 1, 17, 30, 60, 119] {
        let a = 30f64.to_radians() + std::f64::consts::TAU * f as f64 / 120.0;
        let want = o.centre + DVec3::new(2.5 * a.cos(), 0.75, 2.5 * a.sin());
        let got = p.pose_at(f as f64);
        assert!(
            (got.eye - want).length() < 1e-14,
            "frame {f}: {} vs {want}",
            got.eye
        );
        assert_eq!(got.look_at, o.centre);
        assert_eq!(got.up, DVec3::Y);
        assert_eq!(got.fov_deg, 40.0);
    }
    // Frame 0 is the start angle computed directly: bit for bit.
    let a = 30f64.to_radians();
    let e0 = o.centre + DVec3::new(2.5 * a.cos(), 0.75, 2.5 * a.sin());
    assert_eq!(p.pose_at(0.0).eye, e0);
    // A quarter period later the camera is a quarter turn on, from +x towards +z.
    let d0 = p.pose_at(0.0).eye - o.centre;
    let d30 = p.pose_at(30.0).eye - o.centre;
    assert!((d0.x * d30.x + d0.z * d30.z).abs() < 1e-14, "perpendicular");
    assert!(
        d0.z * d30.x - d0.x * d30.z < 0.0,
        "turning from +x towards +z"
    );
}

#[test]
fn the_orbit_period_wraps_bit_for_bit() {
    for (turns, first) in [(1.0, 0u32), (3.0, 7), (-2.0, 100)] {
        let o = Orbit {
            turns,
            first_frame: first,
            ..orbit()
        };
        let p = CameraPath::orbit(o).unwrap();
        assert_eq!(p.frames(), first..=first + 119);
        for k in [0u32, 1, 59, 119] {
            assert_eq!(
                p.camera_at(first + k),
                p.camera_at(first + k + 120),
                "turns {turns} frame {k}"
            );
            assert_eq!(
                p.pose_at((first + k) as f64),
                p.pose_at((first + k + 360) as f64)
            );
        }
    }
    // Half a turn is not periodic in `frames`: frame 120 is opposite frame 0.
    let p = CameraPath::orbit(Orbit {
        turns: 0.5,
        ..orbit()
    })
    .unwrap();
    let (c, e0, e120) = (orbit().centre, p.pose_at(0.0).eye, p.pose_at(120.0).eye);
    let (a, b) = (e0 - c, e120 - c);
    assert!((a.x + b.x).abs() < 1e-14 && (a.z + b.z).abs() < 1e-14 && a.y == b.y);
}

#[test]
fn an_orbit_about_another_axis_circles_that_axis() {
    for up in [
        DVec3::Z,
        DVec3::new(1.0, 0.2, 0.0),
        DVec3::new(-0.3, -2.0, 0.7),
    ] {
        let o = Orbit { up, ..orbit() };
        let p = CameraPath::orbit(o).unwrap();
        let u = up.normalize();
        let mut prev: Option<DVec3> = None;
        for f in 0..120 {
            let d = p.pose_at(f as f64).eye - o.centre;
            let along = d.dot(u);
            assert!((along - 0.75).abs() < 1e-14, "{up} {f}: height {along}");
            let radial = (d - along * u).length();
            assert!((radial - 2.5).abs() < 1e-14, "{up} {f}: radius {radial}");
            // Equal steps: the chord between neighbours is 2 r sin(pi / 120).
            if let Some(q) = prev {
                let chord = (d - q).length();
                let want = 5.0 * (std::f64::consts::PI / 120.0).sin();
                assert!((chord - want).abs() < 1e-13, "{up} {f}: chord {chord}");
            }
            prev = Some(d);
            assert!(p.camera_at(f).check().is_ok());
        }
    }
}

fn refused(r: Result<CameraPath, PathError>) -> (String, String) {
    let e = r.expect_err("a bad path was accepted");
    (e.place.to_string(), e.message)
}

#[test]
fn bad_keyframed_paths_are_refused_naming_the_key() {
    let k = keys4();
    let (at, m) = refused(CameraPath::keyframes(vec![k[0]], Interpolation::Linear));
    assert_eq!(at, "keyframes");
    assert!(m.contains("at least 2 keyframes, got 1"), "{m}");
    let (at, _) = refused(CameraPath::keyframes(vec![], Interpolation::Linear));
    assert_eq!(at, "keyframes");

    let mut same = k.clone();
    same[2].frame = 10;
    let (at, m) = refused(CameraPath::keyframes(same, Interpolation::Linear));
    assert_eq!(at, "keyframes[2].frame");
    assert!(m.contains("strictly increasing"), "{m}");

    let mut eye_on_target = k.clone();
    eye_on_target[1].pose.look_at = eye_on_target[1].pose.eye;
    let (at, m) = refused(CameraPath::keyframes(eye_on_target, Interpolation::Linear));
    assert_eq!(
        (at.as_str(), m.as_str()),
        (
            "keyframes[1]",
            "the keyframe's camera is degenerate: eye and look_at coincide"
        )
    );

    let mut up_along_view = k.clone();
    up_along_view[3].pose.up = up_along_view[3].pose.look_at - up_along_view[3].pose.eye;
    let (at, m) = refused(CameraPath::keyframes(
        up_along_view,
        Interpolation::CatmullRom,
    ));
    assert_eq!(at, "keyframes[3].up");
    assert!(m.contains("parallel"), "{m}");

    let mut nan = k.clone();
    nan[2].pose.eye.y = f64::NAN;
    assert_eq!(
        refused(CameraPath::keyframes(nan, Interpolation::Linear)).0,
        "keyframes[2].eye"
    );
    let mut big = k.clone();
    big[0].pose.look_at.x = 1e39; // Finite in f64, not in the renderers' f32.
    assert_eq!(
        refused(CameraPath::keyframes(big, Interpolation::Linear)).0,
        "keyframes[0].look_at"
    );
    let mut inf_up = k.clone();
    inf_up[0].pose.up.z = f64::INFINITY;
    assert_eq!(
        refused(CameraPath::keyframes(inf_up, Interpolation::Linear)).0,
        "keyframes[0].up"
    );
    for fov in [0.0, 180.0, -3.0, f64::NAN] {
        let mut f = k.clone();
        f[1].pose.fov_deg = fov;
        assert_eq!(
            refused(CameraPath::keyframes(f, Interpolation::Linear)).0,
            "keyframes[1].fov"
        );
    }
    let mut far = k.clone();
    far[3].frame = MAX_FRAME + 1;
    assert_eq!(
        refused(CameraPath::keyframes(far, Interpolation::Linear)).0,
        "keyframes[3].frame"
    );
}

#[test]
fn a_degenerate_frame_between_valid_keys_is_refused() {
    // The eye walks through the target: frame 5 is eye == look_at.
    let keys = vec![
        key(0, [0.0, 0.0, 5.0], [0.0, 0.0, 0.0], 40.0),
        key(10, [0.0, 0.0, -5.0], [0.0, 0.0, 0.0], 40.0),
    ];
    let (at, m) = refused(CameraPath::keyframes(keys, Interpolation::Linear));
    assert_eq!(at, "keyframes[1]");
    assert!(
        m.contains("frame 5, between keyframes[0] (frame 0) and this one (frame 10)")
            && m.contains("eye and look_at coincide"),
        "{m}"
    );
    // up turning through itself: [0, 1, 0] to [0, -1, 0] is zero halfway.
    let mut flip = vec![
        key(0, [0.0, 0.0, 5.0], [0.0, 0.0, 0.0], 40.0),
        key(4, [1.0, 0.0, 5.0], [0.0, 0.0, 0.0], 40.0),
    ];
    flip[1].pose.up = DVec3::NEG_Y;
    let (at, m) = refused(CameraPath::keyframes(flip, Interpolation::Linear));
    assert_eq!(at, "keyframes[1]");
    assert!(m.contains("frame 2,") && m.contains("up is zero"), "{m}");
    // Catmull-Rom overshoots where linear does not: the field of view leaves (0, 180).
    let fov = vec![
        key(0, [0.0, 0.0, 5.0], [0.0, 0.0, 0.0], 170.0),
        key(1, [0.0, 0.0, 5.0], [0.0, 0.0, 0.0], 179.0),
        key(20, [0.0, 0.0, 5.0], [0.0, 0.0, 0.0], 179.5),
    ];
    assert!(CameraPath::keyframes(fov.clone(), Interpolation::Linear).is_ok());
    let (at, m) = refused(CameraPath::keyframes(fov, Interpolation::CatmullRom));
    assert_eq!(at, "keyframes[2]");
    assert!(
        m.contains("catmull-rom") && m.contains("outside (0, 180)"),
        "{m}"
    );
}

#[test]
fn bad_orbits_are_refused_naming_the_field() {
    let cases: Vec<(Orbit, &str, &str)> = vec![
        (
            Orbit {
                radius: 0.0,
                ..orbit()
            },
            "orbit.radius",
            "must be > 0",
        ),
        (
            Orbit {
                radius: -1.0,
                ..orbit()
            },
            "orbit.radius",
            "must be > 0",
        ),
        (
            Orbit {
                radius: f64::INFINITY,
                ..orbit()
            },
            "orbit.radius",
            "finite",
        ),
        (
            Orbit {
                frames: 0,
                ..orbit()
            },
            "orbit.frames",
            "at least 1 frame",
        ),
        (
            Orbit {
                turns: f64::NAN,
                ..orbit()
            },
            "orbit.turns",
            "finite",
        ),
        (
            Orbit {
                height: 1e300,
                ..orbit()
            },
            "orbit.height",
            "finite",
        ),
        (
            Orbit {
                start_angle_deg: f64::NEG_INFINITY,
                ..orbit()
            },
            "orbit.start_angle",
            "finite",
        ),
        (
            Orbit {
                centre: DVec3::new(0.0, f64::NAN, 0.0),
                ..orbit()
            },
            "orbit.centre",
            "finite",
        ),
        (
            Orbit {
                up: DVec3::ZERO,
                ..orbit()
            },
            "orbit.up",
            "no direction",
        ),
        (
            Orbit {
                fov_deg: 180.0,
                ..orbit()
            },
            "orbit.fov",
            "(0, 180)",
        ),
        (
            Orbit {
                first_frame: MAX_FRAME,
                ..orbit()
            },
            "orbit.frames",
            "past the last frame",
        ),
        (
            Orbit {
                first_frame: MAX_FRAME + 1,
                frames: 1,
                ..orbit()
            },
            "orbit.first_frame",
            "past the last frame",
        ),
        // Too small a radius to tell the eye from the centre in f32.
        (
            Orbit {
                radius: 1e-30,
                height: 0.0,
                ..orbit()
            },
            "orbit.radius",
            "frame 0 gives a degenerate camera",
        ),
    ];
    for (o, at, needle) in cases {
        let (got, m) = refused(CameraPath::orbit(o));
        assert_eq!(got, at, "{m}");
        assert!(m.contains(needle), "{at}: {m}");
    }
    // One frame, and the last allowed frame, are fine.
    assert!(CameraPath::orbit(Orbit {
        frames: 1,
        ..orbit()
    })
    .is_ok());
    let last = CameraPath::orbit(Orbit {
        first_frame: MAX_FRAME - 119,
        ..orbit()
    })
    .unwrap();
    assert_eq!(*last.frames().end(), MAX_FRAME);
}

#[test]
fn a_camera_with_a_non_finite_up_fails_the_check() {
    let c = Camera {
        eye: Vec3::ZERO,
        look_at: Vec3::NEG_Z,
        up: Vec3::new(0.0, f32::NAN, 0.0),
        vfov_deg: 45.0,
    };
    assert!(c.check().unwrap_err().contains("not finite"));
}

/// Keys whose viewing directions stay within 26° of a common direction at most 19° from
/// level, ups within 26° of +y, fields of view 30 to 90 degrees, and spacing at most 2:1
/// uneven (more uneven spacing or wilder keys make Catmull-Rom overshoot into degenerate
/// cameras, which the path then refuses: see the tests above).
fn reasonable_keys() -> impl Strategy<Value = Vec<Keyframe>> {
    let one = (
        2u32..=4,
        prop::array::uniform3(-10.0f64..10.0),
        (-0.35f64..0.35, -0.35f64..0.35, 1.0f64..2.0),
        (-0.35f64..0.35, -0.35f64..0.35),
        30.0f64..90.0,
    );
    (
        prop::collection::vec(one, 2..7),
        0.0f64..std::f64::consts::TAU,
        0u32..1000,
    )
        .prop_map(|(ks, yaw, start)| {
            let mut frame = start;
            ks.into_iter()
                .map(|(gap, eye, (dx, dy, len), (ux, uz), fov)| {
                    frame += gap * 5;
                    let eye = DVec3::from_array(eye);
                    // About -z, tilted by at most atan(0.35 * sqrt 2) (26°), turned by yaw.
                    let dir = DVec3::new(dx, dy, -1.0).normalize() * len;
                    let dir = glam::DMat3::from_rotation_y(yaw) * dir;
                    Keyframe {
                        frame,
                        pose: Pose {
                            eye,
                            look_at: eye + dir,
                            up: DVec3::new(ux, 1.0, uz),
                            fov_deg: fov,
                        },
                    }
                })
                .collect()
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn every_frame_of_a_reasonable_keyframed_path_is_a_valid_camera(
        keys in reasonable_keys(),
        catmull in any::<bool>(),
    ) {
        let interp = if catmull { Interpolation::CatmullRom } else { Interpolation::Linear };
        let p = CameraPath::keyframes(keys.clone(), interp);
        prop_assert!(p.is_ok(), "{:?}", p.err());
        let p = p.unwrap();
        for f in p.frames() {
            let c = p.camera_at(f);
            prop_assert!(c.check().is_ok(), "frame {}: {:?} {:?}", f, c, c.check());
        }
        for k in &keys {
            prop_assert_eq!(p.camera_at(k.frame), k.pose.camera(DVec3::ZERO));
        }
    }

    #[test]
    fn every_frame_of_an_orbit_is_a_valid_camera_on_its_circle(
        centre in prop::array::uniform3(-100.0f64..100.0),
        radius in 0.01f64..50.0,
        height in -20.0f64..20.0,
        turns in -4i32..=4,
        frames in 1u32..400,
        start in -720.0f64..720.0,
        up in prop::array::uniform3(-1.0f64..1.0),
    ) {
        let up = DVec3::from_array(up);
        prop_assume!(up.length() > 0.1);
        let o = Orbit {
            centre: DVec3::from_array(centre),
            radius,
            height,
            turns: turns as f64,
            frames,
            first_frame: 0,
            start_angle_deg: start,
            up,
            fov_deg: 50.0,
        };
        let p = CameraPath::orbit(o).unwrap();
        let u = up.normalize();
        for f in p.frames() {
            prop_assert!(p.camera_at(f).check().is_ok(), "frame {}", f);
            let d = p.pose_at(f as f64).eye - o.centre;
            let along = d.dot(u);
            let scale = o.centre.length() + radius + height.abs();
            prop_assert!((along - height).abs() < 1e-13 * scale);
            prop_assert!(((d - along * u).length() - radius).abs() < 1e-13 * scale);
        }
        prop_assert_eq!(p.camera_at(frames), p.camera_at(0));
    }
}
