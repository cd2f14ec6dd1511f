//! Camera paths: the camera of an animation as a function of the frame number, either
//! interpolated between keyframes or an orbit around a point.
//!
//! The maths runs in f64 world space ([`Pose`]); [`CameraPath::camera_at`] rounds the result
//! to the f32 [`Camera`] the renderers take, relative to the scene's local origin, exactly as
//! the TOML loader rounds a static `[camera]`. So a frame that falls on a keyframe is that
//! keyframe's camera bit for bit, and the first frame of a path loaded from a file is the
//! scene's [`Scene::camera`](super::Scene::camera).
//!
//! Catmull-Rom takes the keyframes' frame numbers as its knots (the Barry-Goldman form of
//! the spline): the tangent at an interior key is the derivative at that key of the parabola
//! through it and its two neighbours, in units per frame. For evenly spaced keys this is the
//! uniform Catmull-Rom spline. Not the centripetal variant: centripetal knots come from the
//! distances between keys, which would decouple the timing from the frame numbers the user
//! wrote (a key would still be reached at its frame, but the speed would jump there) and
//! would differ per channel (eye and target in metres, the field of view in degrees). With
//! the frame numbers as knots the motion is C1 in time through every key: no jerk at a key.
//! The end keys are duplicated (a phantom key equal to the end key, one segment further),
//! which gives the end tangents half the end segment's slope.

use std::f64::consts::TAU;
use std::fmt;
use std::ops::RangeInclusive;

use glam::DVec3;

use super::Camera;

/// Largest frame number a path may use: over nine hours at 30 frames a second, and small
/// enough that loading a path checks the camera of every one of its frames.
pub const MAX_FRAME: u32 = 1_000_000;

/// How keyframes are interpolated; in a scene file `"linear"` or `"catmull-rom"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Interpolation {
    /// Straight lines between keys at constant speed (`"linear"`).
    Linear,
    /// A C1 cubic through every key, knots at the frame numbers (`"catmull-rom"`).
    CatmullRom,
}

impl fmt::Display for Interpolation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Interpolation::Linear => "linear",
            Interpolation::CatmullRom => "catmull-rom",
        })
    }
}

/// A camera in f64 world space, before rounding to a [`Camera`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Eye position.
    pub eye: DVec3,
    /// Point looked at.
    pub look_at: DVec3,
    /// Up direction (as written at a keyframe, unit length between keys).
    pub up: DVec3,
    /// Vertical field of view in degrees.
    pub fov_deg: f64,
}

impl Pose {
    /// The renderers' camera, relative to `origin` (subtracted in f64, then rounded).
    pub fn camera(&self, origin: DVec3) -> Camera {
        Camera {
            eye: (self.eye - origin).as_vec3(),
            look_at: (self.look_at - origin).as_vec3(),
            up: self.up.as_vec3(),
            vfov_deg: self.fov_deg as f32,
        }
    }
}

/// One keyframe: the camera at a frame number.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keyframe {
    /// Frame number, at most [`MAX_FRAME`].
    pub frame: u32,
    /// The camera at that frame, in world space.
    pub pose: Pose,
}

/// A circle around `centre`: the camera looks at the centre from `radius` away, `height`
/// along `up`, and turns `turns` times every `frames` frames.
///
/// With `up = [0, 1, 0]` the eye at frame `f` is `centre + (radius·cos a, height,
/// radius·sin a)` with `a = start_angle + 2π·turns·(f - first_frame)/frames`. For another
/// `up` the circle lies in the plane normal to it (its first axis is world x made
/// perpendicular to `up`, or world z when `up` is within 26° of x; the second is first ×
/// up). `frames` is the period: for a whole number of turns frame `first_frame + frames`
/// is frame `first_frame` again, so a loop of the range plays seamlessly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// The point circled and looked at.
    pub centre: DVec3,
    /// Distance from the axis through the centre along `up`; > 0.
    pub radius: f64,
    /// Eye offset along `up` from the centre's plane.
    pub height: f64,
    /// Turns per `frames` frames; positive turns go from the first axis towards the second
    /// (from +x towards +z for `up = +y`: clockwise seen from above).
    pub turns: f64,
    /// The period and number of frames of the path; >= 1.
    pub frames: u32,
    /// Number of the first frame.
    pub first_frame: u32,
    /// Angle at the first frame, in degrees (0: on the first axis).
    pub start_angle_deg: f64,
    /// The camera's up and the orbit's axis; non-zero.
    pub up: DVec3,
    /// Vertical field of view in degrees.
    pub fov_deg: f64,
}

/// Where in a path description an error is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PathPlace {
    /// The list of keyframes as a whole.
    Keyframes,
    /// Keyframe `index`; `key` names its field, `None` the whole keyframe.
    Keyframe {
        /// Index in the list.
        index: usize,
        /// `frame`, `eye`, `look_at`, `up` or `fov`.
        key: Option<&'static str>,
    },
    /// A field of the orbit (`centre`, `radius`, ...), `None` the whole orbit.
    Orbit(Option<&'static str>),
}

impl fmt::Display for PathPlace {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PathPlace::Keyframes => f.write_str("keyframes"),
            PathPlace::Keyframe { index, key: None } => write!(f, "keyframes[{index}]"),
            PathPlace::Keyframe {
                index,
                key: Some(k),
            } => write!(f, "keyframes[{index}].{k}"),
            PathPlace::Orbit(None) => f.write_str("orbit"),
            PathPlace::Orbit(Some(k)) => write!(f, "orbit.{k}"),
        }
    }
}

/// An invalid camera path: where, and what is wrong. The scene loader turns the place into
/// the file, line and dotted field of the `[animation]` table.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{place}: {message}")]
pub struct PathError {
    /// The offending part of the description.
    pub place: PathPlace,
    /// What is wrong with it.
    pub message: String,
}

fn err(place: PathPlace, message: impl Into<String>) -> PathError {
    PathError {
        place,
        message: message.into(),
    }
}

#[derive(Clone, Debug, PartialEq)]
enum Kind {
    Keyframes {
        keys: Vec<Keyframe>,
        interpolation: Interpolation,
        /// Catmull-Rom tangents per key, per frame: eye, look_at, unit up, fov.
        tangents: Vec<(DVec3, DVec3, DVec3, f64)>,
    },
    Orbit {
        orbit: Orbit,
        /// The circle's axes: first, second (both unit, perpendicular to up) and unit up.
        axes: [DVec3; 3],
    },
}

/// A camera as a function of the frame number; see the module documentation.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraPath {
    kind: Kind,
    origin: DVec3,
}

/// The value must be a finite f32 (the renderers' precision) after rounding.
fn finite3(v: DVec3, place: PathPlace) -> Result<(), PathError> {
    if v.as_vec3().is_finite() {
        Ok(())
    } else {
        Err(err(place, format!("must be finite, got {v}")))
    }
}

fn finite(x: f64, place: PathPlace) -> Result<(), PathError> {
    if (x as f32).is_finite() {
        Ok(())
    } else {
        Err(err(place, format!("must be a finite number, got {x}")))
    }
}

fn fov_ok(x: f64, place: PathPlace) -> Result<(), PathError> {
    finite(x, place.clone())?;
    if x > 0.0 && x < 180.0 {
        Ok(())
    } else {
        Err(err(
            place,
            format!("vertical field of view must be in (0, 180) degrees, got {x}"),
        ))
    }
}

fn frame_ok(f: u32, place: PathPlace) -> Result<(), PathError> {
    if f <= MAX_FRAME {
        Ok(())
    } else {
        Err(err(
            place,
            format!("frame {f} is past the last frame a path may use, {MAX_FRAME}"),
        ))
    }
}

impl CameraPath {
    /// A path through `keys` (at least two, frames strictly increasing, each a valid camera
    /// by [`Camera::check`]). Every frame in between must interpolate to a valid camera too
    /// (an eye passing through its target, or `up` turning through the viewing direction,
    /// is refused, naming the first such frame).
    pub fn keyframes(keys: Vec<Keyframe>, interpolation: Interpolation) -> Result<Self, PathError> {
        if keys.len() < 2 {
            return Err(err(
                PathPlace::Keyframes,
                format!(
                    "a keyframed path needs at least 2 keyframes, got {}{}",
                    keys.len(),
                    if keys.len() == 1 {
                        " (a still camera is a `[camera]` table)"
                    } else {
                        ""
                    }
                ),
            ));
        }
        for (index, k) in keys.iter().enumerate() {
            let at = |key| PathPlace::Keyframe {
                index,
                key: Some(key),
            };
            frame_ok(k.frame, at("frame"))?;
            if index > 0 && k.frame <= keys[index - 1].frame {
                return Err(err(
                    at("frame"),
                    format!(
                        "frame {} does not come after keyframes[{}]'s frame {}; keyframe \
                         frames must be strictly increasing",
                        k.frame,
                        index - 1,
                        keys[index - 1].frame
                    ),
                ));
            }
            finite3(k.pose.eye, at("eye"))?;
            finite3(k.pose.look_at, at("look_at"))?;
            finite3(k.pose.up, at("up"))?;
            fov_ok(k.pose.fov_deg, at("fov"))?;
            // The still camera's rule (toml_scene's `[camera]`): refuse an up within about
            // 1e-6 rad of the view, which f32 rounding can hide from Camera::check.
            let view = k.pose.look_at - k.pose.eye;
            if view.length() > 0.0 && super::camera::up_parallel(view, k.pose.up) {
                return Err(err(
                    at("up"),
                    format!(
                        "up {} is parallel to the viewing direction {}; choose another `up`",
                        k.pose.up,
                        view.normalize()
                    ),
                ));
            }
            k.pose.camera(DVec3::ZERO).check().map_err(|m| {
                err(
                    PathPlace::Keyframe { index, key: None },
                    format!("the keyframe's camera is degenerate: {m}"),
                )
            })?;
        }
        let tangents = tangents(&keys);
        let path = CameraPath {
            kind: Kind::Keyframes {
                keys,
                interpolation,
                tangents,
            },
            origin: DVec3::ZERO,
        };
        path.check_frames()?;
        Ok(path)
    }

    /// An orbit (see [`Orbit`]); every value finite, `radius > 0`, `frames >= 1`, `up`
    /// non-zero, the last frame at most [`MAX_FRAME`].
    pub fn orbit(orbit: Orbit) -> Result<Self, PathError> {
        let at = |k| PathPlace::Orbit(Some(k));
        finite3(orbit.centre, at("centre"))?;
        finite(orbit.radius, at("radius"))?;
        if orbit.radius <= 0.0 {
            return Err(err(
                at("radius"),
                format!("must be > 0, got {}", orbit.radius),
            ));
        }
        finite(orbit.height, at("height"))?;
        finite(orbit.turns, at("turns"))?;
        finite(orbit.start_angle_deg, at("start_angle"))?;
        if orbit.frames < 1 {
            return Err(err(at("frames"), "an orbit needs at least 1 frame, got 0"));
        }
        frame_ok(orbit.first_frame, at("first_frame"))?;
        let last = orbit.first_frame as u64 + orbit.frames as u64 - 1;
        if last > MAX_FRAME as u64 {
            return Err(err(
                at("frames"),
                format!(
                    "the last frame, {last}, is past the last frame a path may use, {MAX_FRAME}"
                ),
            ));
        }
        finite3(orbit.up, at("up"))?;
        if orbit.up.length() == 0.0 {
            return Err(err(
                at("up"),
                "up is [0, 0, 0], which has no direction; give the orbit's axis, e.g. [0, 1, 0]",
            ));
        }
        fov_ok(orbit.fov_deg, at("fov"))?;
        // The eye looks at the centre from `radius` out and `height` up the axis: the same
        // angle to up in every frame, refused by the still camera's rule.
        if super::camera::up_parallel(DVec3::new(-orbit.radius, -orbit.height, 0.0), DVec3::Y) {
            return Err(err(
                at("radius"),
                format!(
                    "radius {} at height {} looks along the orbit's axis (up) from every frame; raise the radius or lower the height",
                    orbit.radius, orbit.height
                ),
            ));
        }
        let u = orbit.up.normalize();
        // World x for up = +y, so that the eye is exactly centre + (r cos a, h, r sin a).
        let reference = if u.x.abs() < 0.9 { DVec3::X } else { DVec3::Z };
        let first = (reference - reference.dot(u) * u).normalize();
        let second = first.cross(u);
        let path = CameraPath {
            kind: Kind::Orbit {
                orbit,
                axes: [first, second, u],
            },
            origin: DVec3::ZERO,
        };
        path.check_frames()?;
        Ok(path)
    }

    /// The same path, its cameras relative to `origin` (the scene's local origin,
    /// [`Scene::origin`](super::Scene::origin)); checks every frame again, since rounding
    /// relative to another origin can differ.
    pub fn with_origin(mut self, origin: DVec3) -> Result<Self, PathError> {
        self.origin = origin;
        self.check_frames()?;
        Ok(self)
    }

    /// The local origin the cameras are relative to (zero unless set by
    /// [`CameraPath::with_origin`]).
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// The frames of the path: first to last keyframe, or the orbit's `frames` frames from
    /// its `first_frame`.
    pub fn frames(&self) -> RangeInclusive<u32> {
        match &self.kind {
            Kind::Keyframes { keys, .. } => keys[0].frame..=keys[keys.len() - 1].frame,
            Kind::Orbit { orbit, .. } => orbit.first_frame..=orbit.first_frame + (orbit.frames - 1),
        }
    }

    /// Number of frames in [`CameraPath::frames`].
    pub fn frame_count(&self) -> u32 {
        let r = self.frames();
        r.end() - r.start() + 1
    }

    /// The keyframes and their interpolation, for a keyframed path.
    pub fn keys(&self) -> Option<(&[Keyframe], Interpolation)> {
        match &self.kind {
            Kind::Keyframes {
                keys,
                interpolation,
                ..
            } => Some((keys, *interpolation)),
            Kind::Orbit { .. } => None,
        }
    }

    /// The orbit, for an orbiting path.
    pub fn as_orbit(&self) -> Option<&Orbit> {
        match &self.kind {
            Kind::Orbit { orbit, .. } => Some(orbit),
            Kind::Keyframes { .. } => None,
        }
    }

    /// The camera at `frame`, relative to [`CameraPath::origin`]. Outside
    /// [`CameraPath::frames`] a keyframed path holds its first or last key and an orbit
    /// keeps turning.
    pub fn camera_at(&self, frame: u32) -> Camera {
        self.pose_at(frame as f64).camera(self.origin)
    }

    /// The world-space camera at time `t` in frames; fractional times interpolate (for
    /// motion blur or smooth playback). At a keyframe's frame it is that keyframe exactly.
    pub fn pose_at(&self, t: f64) -> Pose {
        match &self.kind {
            Kind::Keyframes {
                keys,
                interpolation,
                tangents,
            } => keyed_pose(keys, *interpolation, tangents, t),
            Kind::Orbit { orbit, axes } => orbit_pose(orbit, axes, t),
        }
    }

    /// Checks that every frame of the path gives a camera that passes [`Camera::check`]
    /// (relative to the origin), naming the first that does not and where it comes from.
    pub fn check_frames(&self) -> Result<(), PathError> {
        for f in self.frames() {
            let Err(m) = self.camera_at(f).check() else {
                continue;
            };
            return Err(match &self.kind {
                Kind::Keyframes {
                    keys,
                    interpolation,
                    ..
                } => {
                    let i = keys.partition_point(|k| k.frame < f);
                    let place = PathPlace::Keyframe {
                        index: i,
                        key: None,
                    };
                    if keys[i].frame == f {
                        err(place, format!("the keyframe's camera is degenerate: {m}"))
                    } else {
                        err(
                            place,
                            format!(
                                "frame {f}, between keyframes[{}] (frame {}) and this one \
                                 (frame {}), interpolates ({interpolation}) to a degenerate \
                                 camera: {m}; add a keyframe in between",
                                i - 1,
                                keys[i - 1].frame,
                                keys[i].frame
                            ),
                        )
                    }
                }
                Kind::Orbit { .. } => err(
                    PathPlace::Orbit(Some("radius")),
                    format!("frame {f} gives a degenerate camera: {m}"),
                ),
            });
        }
        Ok(())
    }
}

/// Catmull-Rom tangents (per frame) at every key: the derivative of the parabola through
/// the key and its neighbours; half the end segment's slope at the ends.
fn tangents(keys: &[Keyframe]) -> Vec<(DVec3, DVec3, DVec3, f64)> {
    let chan = |k: &Keyframe| {
        (
            k.pose.eye,
            k.pose.look_at,
            k.pose.up.normalize(),
            k.pose.fov_deg,
        )
    };
    let n = keys.len();
    // Slope of segment i (key i to i + 1), per frame.
    let slope = |i: usize| {
        let (a, b) = (chan(&keys[i]), chan(&keys[i + 1]));
        let h = (keys[i + 1].frame - keys[i].frame) as f64;
        (
            (b.0 - a.0) / h,
            (b.1 - a.1) / h,
            (b.2 - a.2) / h,
            (b.3 - a.3) / h,
        )
    };
    (0..n)
        .map(|i| {
            if i == 0 || i == n - 1 {
                let s = slope(if i == 0 { 0 } else { n - 2 });
                return (s.0 * 0.5, s.1 * 0.5, s.2 * 0.5, s.3 * 0.5);
            }
            let (l, r) = (slope(i - 1), slope(i));
            let hl = (keys[i].frame - keys[i - 1].frame) as f64;
            let hr = (keys[i + 1].frame - keys[i].frame) as f64;
            let w = 1.0 / (hl + hr);
            (
                (hr * l.0 + hl * r.0) * w,
                (hr * l.1 + hl * r.1) * w,
                (hr * l.2 + hl * r.2) * w,
                (hr * l.3 + hl * r.3) * w,
            )
        })
        .collect()
}

fn keyed_pose(
    keys: &[Keyframe],
    interpolation: Interpolation,
    tangents: &[(DVec3, DVec3, DVec3, f64)],
    t: f64,
) -> Pose {
    let last = keys.len() - 1;
    if t.is_nan() || t <= keys[0].frame as f64 {
        return keys[0].pose;
    }
    if t >= keys[last].frame as f64 {
        return keys[last].pose;
    }
    // The segment [i, i + 1] holding t; i < last because t is before the last key.
    let i = keys.partition_point(|k| k.frame as f64 <= t) - 1;
    let (a, b) = (&keys[i], &keys[i + 1]);
    if t == a.frame as f64 {
        return a.pose;
    }
    let h = (b.frame - a.frame) as f64;
    let u = (t - a.frame as f64) / h;
    let (ua, ub) = (a.pose.up.normalize(), b.pose.up.normalize());
    let (eye, look_at, up, fov_deg) = match interpolation {
        Interpolation::Linear => (
            a.pose.eye.lerp(b.pose.eye, u),
            a.pose.look_at.lerp(b.pose.look_at, u),
            ua.lerp(ub, u),
            a.pose.fov_deg + (b.pose.fov_deg - a.pose.fov_deg) * u,
        ),
        Interpolation::CatmullRom => {
            // Cubic Hermite basis; the tangents are per frame, so scale them by h.
            let (u2, u3) = (u * u, u * u * u);
            let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
            let h10 = (u3 - 2.0 * u2 + u) * h;
            let h01 = -2.0 * u3 + 3.0 * u2;
            let h11 = (u3 - u2) * h;
            let (ma, mb) = (tangents[i], tangents[i + 1]);
            (
                h00 * a.pose.eye + h10 * ma.0 + h01 * b.pose.eye + h11 * mb.0,
                h00 * a.pose.look_at + h10 * ma.1 + h01 * b.pose.look_at + h11 * mb.1,
                h00 * ua + h10 * ma.2 + h01 * ub + h11 * mb.2,
                h00 * a.pose.fov_deg + h10 * ma.3 + h01 * b.pose.fov_deg + h11 * mb.3,
            )
        }
    };
    Pose {
        eye,
        look_at,
        // A zero result (up turning through itself) stays zero for Camera::check to refuse.
        up: up.normalize_or_zero(),
        fov_deg,
    }
}

fn orbit_pose(o: &Orbit, axes: &[DVec3; 3], t: f64) -> Pose {
    let k = t - o.first_frame as f64;
    // The fraction of a turn, reduced modulo one period first: for a whole number of turns
    // frame first + frames gives exactly the angle of frame first (bit for bit), and the
    // angle stays small, so cos and sin lose nothing to a large argument.
    let frac = (o.turns * k).rem_euclid(o.frames as f64) / o.frames as f64;
    let a = o.start_angle_deg.to_radians() + TAU * frac;
    let [first, second, up] = *axes;
    let offset = o.radius * (a.cos() * first + a.sin() * second) + o.height * up;
    Pose {
        eye: o.centre + offset,
        look_at: o.centre,
        up: o.up,
        fov_deg: o.fov_deg,
    }
}

#[cfg(test)]
#[path = "camera_path_tests.rs"]
mod tests;
