//! The camera controller of `fragtrace view`: orbit, pan and zoom around the look-at point
//! as pure functions of a [`Camera`], and a [`Controller`] that turns mouse input into
//! calls of them. The window translates winit's events into [`Input`] with [`translate`];
//! the tests drive the same two functions with synthetic events, so what they check is
//! what a person's mouse does.
//!
//! The formulas, in the camera's own frame (`up` is the scene camera's up vector, kept):
//! - orbit by (dx, dy) pixels: the eye turns about the axis through the look-at point
//!   along `up` by `-dx·ORBIT_RAD_PER_PX` (drag right, the scene turns right) and its
//!   elevation above the plane normal to `up` grows by `dy·ORBIT_RAD_PER_PX`, held within
//!   `MAX_ELEVATION_DEG` of the poles; the distance is unchanged;
//! - pan by (dx, dy): eye and look-at move together by `(-dx·r + dy·u)·2·d·tan(fov/2)/H`
//!   (r, u the camera's right and up, d the distance, H the window height), so the point
//!   under the cursor at the look-at distance stays under the cursor;
//! - zoom by n wheel lines: the distance is multiplied by `ZOOM_PER_LINE^n` (n > 0, wheel
//!   forward, comes closer), never below `MIN_DISTANCE` of the starting distance.

use glam::DVec3;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};

use crate::scene::camera::Camera;

/// Radians of orbit per pixel of drag.
pub const ORBIT_RAD_PER_PX: f64 = 0.01;
/// Elevation stays this many degrees short of `up` and `-up`, where the frame degenerates.
pub const MAX_ELEVATION_DEG: f64 = 89.0;
/// Distance factor per wheel line (wheel forward: closer).
pub const ZOOM_PER_LINE: f64 = 0.9;
/// Pixels of a touchpad's pixel-precise scroll that count as one wheel line.
pub const PIXELS_PER_LINE: f64 = 40.0;
/// The smallest distance, as a share of the home camera's.
pub const MIN_DISTANCE: f64 = 1e-3;

/// The camera after orbiting by (`dx`, `dy`) pixels of drag (see the module documentation).
pub fn orbit(cam: &Camera, dx: f64, dy: f64) -> Camera {
    let target = cam.look_at.as_dvec3();
    let offset = cam.eye.as_dvec3() - target;
    let up = cam.up.as_dvec3().normalize();
    let dist = offset.length();
    // Azimuth and elevation in a frame (e1, up, e2) where e2 is the current horizontal
    // direction of the eye: azimuth starts at 0, so only the change matters.
    let vertical = offset.dot(up);
    let horizontal = offset - vertical * up;
    let e2 = if horizontal.length() > 1e-12 * dist {
        horizontal.normalize()
    } else {
        // Eye straight above or below: any horizontal direction will do.
        up.any_orthonormal_vector()
    };
    let e1 = up.cross(e2);
    let limit = MAX_ELEVATION_DEG.to_radians();
    let elevation = (vertical / dist).clamp(-1.0, 1.0).asin();
    let elevation = (elevation + dy * ORBIT_RAD_PER_PX).clamp(-limit, limit);
    let azimuth = -dx * ORBIT_RAD_PER_PX;
    let dir = elevation.cos() * (azimuth.cos() * e2 + azimuth.sin() * e1) + elevation.sin() * up;
    Camera {
        eye: (target + dist * dir).as_vec3(),
        ..*cam
    }
}

/// The camera after panning by (`dx`, `dy`) pixels in a window `height` pixels high.
pub fn pan(cam: &Camera, dx: f64, dy: f64, height: u32) -> Camera {
    let fr = cam.frame();
    let dist = (cam.look_at.as_dvec3() - fr.eye).length();
    let per_px = 2.0 * dist * fr.s / height.max(1) as f64;
    let shift: DVec3 = (-dx * fr.r + dy * fr.u) * per_px;
    Camera {
        eye: (fr.eye + shift).as_vec3(),
        look_at: (cam.look_at.as_dvec3() + shift).as_vec3(),
        ..*cam
    }
}

/// The camera after `lines` wheel lines (positive: closer), no closer than `min_dist`.
pub fn zoom(cam: &Camera, lines: f64, min_dist: f64) -> Camera {
    let target = cam.look_at.as_dvec3();
    let offset = cam.eye.as_dvec3() - target;
    let dist = offset.length();
    let new = (dist * ZOOM_PER_LINE.powf(lines)).max(min_dist);
    Camera {
        eye: (target + offset * (new / dist)).as_vec3(),
        ..*cam
    }
}

/// A mouse button, as far as the controller cares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Button {
    /// Drag to orbit.
    Left,
    /// Drag to pan (the middle button pans too).
    Right,
}

/// Mouse input, independent of the window system.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Input {
    /// The cursor is at (x, y) window pixels (y down).
    Cursor {
        /// Pixels from the left edge.
        x: f64,
        /// Pixels from the top edge.
        y: f64,
    },
    /// A button went down or up.
    Button {
        /// Which.
        button: Button,
        /// Down (true) or up.
        pressed: bool,
    },
    /// The wheel turned by this many lines (positive: forward, away from the user).
    Wheel {
        /// Lines.
        lines: f64,
    },
    /// The cursor left the window (ends a drag).
    Left,
}

/// Translates a winit window event into controller input, or `None` for events the
/// controller ignores.
pub fn translate(event: &WindowEvent) -> Option<Input> {
    match event {
        WindowEvent::CursorMoved { position, .. } => Some(Input::Cursor {
            x: position.x,
            y: position.y,
        }),
        WindowEvent::CursorLeft { .. } => Some(Input::Left),
        WindowEvent::MouseInput { state, button, .. } => {
            let button = match button {
                MouseButton::Left => Button::Left,
                MouseButton::Right | MouseButton::Middle => Button::Right,
                _ => return None,
            };
            Some(Input::Button {
                button,
                pressed: *state == ElementState::Pressed,
            })
        }
        WindowEvent::MouseWheel { delta, .. } => Some(Input::Wheel {
            lines: match delta {
                MouseScrollDelta::LineDelta(_, y) => *y as f64,
                MouseScrollDelta::PixelDelta(p) => p.y / PIXELS_PER_LINE,
            },
        }),
        _ => None,
    }
}

/// The camera and the state of a drag in progress.
#[derive(Clone, Debug)]
pub struct Controller {
    /// The camera now.
    pub camera: Camera,
    home: Camera,
    cursor: Option<(f64, f64)>,
    drag: Option<Button>,
    /// Window height in pixels (the pan scale).
    pub height: u32,
}

impl Controller {
    /// A controller starting at (and resetting to) `camera`, in a window `height` pixels high.
    pub fn new(camera: Camera, height: u32) -> Self {
        Controller {
            camera,
            home: camera,
            cursor: None,
            drag: None,
            height,
        }
    }

    /// Applies one input; true when the camera changed.
    pub fn handle(&mut self, input: Input) -> bool {
        let before = self.camera;
        match input {
            Input::Cursor { x, y } => {
                if let (Some((x0, y0)), Some(button)) = (self.cursor, self.drag) {
                    let (dx, dy) = (x - x0, y - y0);
                    self.camera = match button {
                        Button::Left => orbit(&self.camera, dx, dy),
                        Button::Right => pan(&self.camera, dx, dy, self.height),
                    };
                }
                self.cursor = Some((x, y));
            }
            Input::Button { button, pressed } => {
                self.drag = if pressed {
                    Some(button)
                } else if self.drag == Some(button) {
                    None
                } else {
                    self.drag
                };
            }
            Input::Wheel { lines } => {
                let home_dist = (self.home.eye - self.home.look_at).length() as f64;
                self.camera = zoom(&self.camera, lines, home_dist * MIN_DISTANCE);
            }
            Input::Left => {
                self.drag = None;
                self.cursor = None;
            }
        }
        self.camera != before
    }

    /// Back to the starting camera; true when that changed it.
    pub fn reset(&mut self) -> bool {
        let changed = self.camera != self.home;
        self.camera = self.home;
        changed
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn cam() -> Camera {
        Camera {
            eye: Vec3::new(0.0, 1.5, 6.0),
            look_at: Vec3::new(0.0, 0.8, 0.0),
            up: Vec3::Y,
            vfov_deg: 45.0,
        }
    }

    #[test]
    fn orbit_keeps_distance_and_target_and_clamps_at_the_pole() {
        let c = cam();
        let d0 = (c.eye - c.look_at).length();
        let o = orbit(&c, 123.0, -45.0);
        assert!(((o.eye - o.look_at).length() - d0).abs() < 1e-5);
        assert_eq!(o.look_at, c.look_at);
        // A huge upward drag stops 1 degree short of straight above.
        let top = orbit(&c, 0.0, 1e6);
        let el = ((top.eye - top.look_at).normalize().dot(Vec3::Y) as f64).asin();
        assert!((el.to_degrees() - MAX_ELEVATION_DEG).abs() < 1e-3, "{el}");
        assert!(top.check().is_ok());
    }

    #[test]
    fn pan_moves_eye_and_target_together_and_zoom_scales_distance() {
        let c = cam();
        let p = pan(&c, 10.0, -4.0, 480);
        assert!(((p.eye - p.look_at) - (c.eye - c.look_at)).length() < 1e-5);
        assert!((p.eye - c.eye).length() > 0.0);
        let z = zoom(&c, 2.0, 0.0);
        let d0 = (c.eye - c.look_at).length() as f64;
        let d1 = (z.eye - z.look_at).length() as f64;
        assert!((d1 - d0 * 0.81).abs() < 1e-5, "{d1}");
        assert!(((zoom(&c, 1e4, 0.5).eye - c.look_at).length() - 0.5).abs() < 1e-5);
    }
}
