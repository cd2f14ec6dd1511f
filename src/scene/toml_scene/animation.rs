//! `[animation]`: the camera path of a scene file, turned into a [`CameraPath`]. The path's
//! own constructors check every value (they are the contract, as `Camera::check` is for the
//! still camera); this module converts the TOML, refuses what only the file can get wrong
//! (keyframes and an orbit at once, `interpolation` on an orbit), and puts every error of
//! the path back on the file's line and dotted field.

use std::ops::Range;

use glam::DVec3;

use super::diagnostics::Ctx;
use super::schema::{AnimationDef, KeyframeDef, OrbitDef, Triple, S};
use crate::scene::camera_path::MAX_FRAME;
use crate::scene::{CameraPath, Interpolation, Keyframe, Orbit, PathError, PathPlace, Pose};
use crate::{Error, Result};

/// Default `interpolation` of keyframes: constant speed, no overshoot; Catmull-Rom is asked
/// for by name.
const DEFAULT_INTERPOLATION: Interpolation = Interpolation::Linear;

fn dvec3(v: &S<Triple>) -> DVec3 {
    DVec3::from_array(**v.get_ref())
}

/// The camera path an `[animation]` table describes, in world space (origin zero).
pub(super) fn camera_path(ctx: Ctx, d: &AnimationDef) -> Result<CameraPath> {
    let frame_range = 0..=MAX_FRAME as i64;
    let why = format!(" (frame numbers are 0..={MAX_FRAME})");
    let path = match (&d.keyframes, &d.orbit) {
        (Some(_), Some(o)) => {
            return Err(ctx.err(
                orbit_span(ctx, o),
                "animation.orbit",
                "an animation has either `[[animation.keyframes]]` or `[animation.orbit]`, not both",
            ));
        }
        (None, None) => {
            return Err(ctx.err(
                animation_span(ctx, d),
                "animation",
                "an `[animation]` needs `[[animation.keyframes]]` (two or more) or \
                 `[animation.orbit]`",
            ));
        }
        (Some(keys), None) => {
            let mut out = Vec::with_capacity(keys.len());
            for (i, k) in keys.iter().enumerate() {
                let kd = k.get_ref();
                let frame = ctx.integer(
                    &kd.frame,
                    &format!("animation.keyframes[{i}].frame"),
                    frame_range.clone(),
                    &why,
                )?;
                out.push(Keyframe {
                    frame,
                    pose: Pose {
                        eye: dvec3(&kd.eye),
                        look_at: dvec3(&kd.look_at),
                        up: kd.up.as_ref().map_or(DVec3::Y, dvec3),
                        fov_deg: *kd.fov.get_ref(),
                    },
                });
            }
            let interpolation = d
                .interpolation
                .as_ref()
                .map_or(DEFAULT_INTERPOLATION, |s| *s.get_ref());
            CameraPath::keyframes(out, interpolation)
        }
        (None, Some(o)) => {
            if let Some(i) = &d.interpolation {
                return Err(ctx.err(
                    i.span(),
                    "animation.interpolation",
                    "`interpolation` applies to `[[animation.keyframes]]`; an orbit is a circle",
                ));
            }
            let od = o;
            let int = |v: &S<i64>, k: &str, range| {
                ctx.integer(v, &format!("animation.orbit.{k}"), range, &why)
            };
            let frames = int(&od.frames, "frames", 0..=MAX_FRAME as i64 + 1)?;
            let first_frame = match &od.first_frame {
                Some(f) => int(f, "first_frame", frame_range)?,
                None => 0,
            };
            let num = |v: &Option<S<f64>>, default| v.as_ref().map_or(default, |v| *v.get_ref());
            CameraPath::orbit(Orbit {
                centre: dvec3(&od.centre),
                radius: *od.radius.get_ref(),
                height: num(&od.height, 0.0),
                turns: num(&od.turns, 1.0),
                frames,
                first_frame,
                start_angle_deg: num(&od.start_angle, 0.0),
                up: od.up.as_ref().map_or(DVec3::Y, dvec3),
                fov_deg: *od.fov.get_ref(),
            })
        }
    };
    path.map_err(|e| path_error(ctx, d, &e))
}

/// A [`PathError`] as a scene error on the line of the value it names.
pub(super) fn path_error(ctx: Ctx, d: &AnimationDef, e: &PathError) -> Error {
    let span = place_span(ctx, d, e).unwrap_or_else(|| animation_span(ctx, d));
    ctx.err(span, format!("animation.{}", e.place), e.message.clone())
}

/// The span of the value a path error names, if the file has it.
fn place_span(ctx: Ctx, d: &AnimationDef, e: &PathError) -> Option<Range<usize>> {
    match &e.place {
        PathPlace::Keyframes => d.keyframes.as_ref()?.first().map(|k| k.span()),
        PathPlace::Keyframe { index, key } => {
            let k = d.keyframes.as_ref()?.get(*index)?;
            Some(
                key.and_then(|key| keyframe_key(k.get_ref(), key))
                    .unwrap_or(k.span()),
            )
        }
        PathPlace::Orbit(key) => {
            let o = d.orbit.as_ref()?;
            Some(
                key.and_then(|key| orbit_key(o, key))
                    .unwrap_or_else(|| orbit_span(ctx, o)),
            )
        }
    }
}

fn keyframe_key(k: &KeyframeDef, key: &str) -> Option<Range<usize>> {
    Some(match key {
        "frame" => k.frame.span(),
        "eye" => k.eye.span(),
        "look_at" => k.look_at.span(),
        "up" => k.up.as_ref()?.span(),
        "fov" => k.fov.span(),
        _ => return None,
    })
}

/// The first line of the document that opens the table `name` or a table under it with a
/// header (`[name]`, `[name.sub]`, `[[name.sub]]`) or `name = {`.
fn header_line(ctx: Ctx, name: &str) -> Option<Range<usize>> {
    let mut offset = 0;
    for line in ctx.text.split_inclusive('\n') {
        let t: String = line.chars().filter(|c| !c.is_whitespace()).collect();
        let opens = t
            .trim_start_matches('[')
            .strip_prefix(name)
            .is_some_and(|rest| rest.starts_with(['.', ']']))
            || t.starts_with(&format!("{name}={{"));
        if opens {
            return Some(offset..offset + line.len());
        }
        offset += line.len();
    }
    None
}

/// Where the `[animation]` table is: the first line that opens it or one of its subtables,
/// else its first value.
pub(super) fn animation_span(ctx: Ctx, d: &AnimationDef) -> Range<usize> {
    header_line(ctx, "animation").unwrap_or_else(|| {
        let first = [
            d.interpolation.as_ref().map(|v| v.span()),
            d.keyframes
                .as_ref()
                .and_then(|k| k.first())
                .map(|k| k.span()),
            d.orbit.as_ref().map(|o| orbit_span(ctx, o)),
        ];
        first
            .into_iter()
            .flatten()
            .min_by_key(|s| s.start)
            .unwrap_or(0..0)
    })
}

/// Where the orbit table is: its `[animation.orbit]` header, else its first key (an inline
/// `orbit = { ... }` inside `[animation]`).
fn orbit_span(ctx: Ctx, o: &OrbitDef) -> Range<usize> {
    if let Some(h) = header_line(ctx, "animation.orbit") {
        return h;
    }
    let required = [
        o.centre.span(),
        o.radius.span(),
        o.frames.span(),
        o.fov.span(),
    ];
    let optional = [
        o.height.as_ref().map(|v| v.span()),
        o.turns.as_ref().map(|v| v.span()),
        o.first_frame.as_ref().map(|v| v.span()),
        o.start_angle.as_ref().map(|v| v.span()),
        o.up.as_ref().map(|v| v.span()),
    ];
    required
        .into_iter()
        .chain(optional.into_iter().flatten())
        .min_by_key(|s| s.start)
        .unwrap_or(0..0)
}

fn orbit_key(o: &OrbitDef, key: &str) -> Option<Range<usize>> {
    Some(match key {
        "centre" => o.centre.span(),
        "radius" => o.radius.span(),
        "height" => o.height.as_ref()?.span(),
        "turns" => o.turns.as_ref()?.span(),
        "frames" => o.frames.span(),
        "first_frame" => o.first_frame.as_ref()?.span(),
        "start_angle" => o.start_angle.as_ref()?.span(),
        "up" => o.up.as_ref()?.span(),
        "fov" => o.fov.span(),
        _ => return None,
    })
}
