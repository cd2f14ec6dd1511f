//! A scripted `fragtrace view`: keys (and mouse moves) given up front by `--keys "..."` or
//! `--script FILE` instead of typed, so that the viewer's input handling runs, and is
//! tested, without a person (under `xvfb-run`).
//!
//! A script is words separated by white space (`#` starts a comment to the end of the
//! line): a key as [`keys::action_for`] reads it (`k`, `+`, `a`, `Escape`, ...), or a
//! mouse move of [`control`]: `orbit:DX,DY` (a left drag by DX, DY pixels), `pan:DX,DY`
//! (a right drag) and `zoom:N` (N wheel lines, positive closer). The view applies one step
//! each time it is idle: before the first step the first render completes, and after a
//! step that starts a render (a camera move, a kernel, a depth) that render completes
//! before the next step, so every step is seen, and a screenshot (`--screenshot`, or `s`
//! in the script) shows what the keys before it made.

use super::control::{self, Controller};
use super::keys::{self, Action};
use crate::{Error, Result};

/// One step of a script.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// A key's action.
    Key(Action),
    /// A left drag by (dx, dy) pixels.
    Orbit(f64, f64),
    /// A right drag by (dx, dy) pixels.
    Pan(f64, f64),
    /// Wheel lines (positive: closer).
    Zoom(f64),
}

impl Step {
    /// Moves the camera of `c` as the mouse would (a press, a move, a release; the wheel),
    /// through the same [`Controller::handle`] as the window's events; true when the camera
    /// changed. A key is not the controller's: false.
    pub fn drive(self, c: &mut Controller) -> bool {
        use control::{Button, Input};
        let drag = |c: &mut Controller, button: Button, dx: f64, dy: f64| {
            let mut changed = c.handle(Input::Cursor { x: 0.0, y: 0.0 });
            changed |= c.handle(Input::Button {
                button,
                pressed: true,
            });
            changed |= c.handle(Input::Cursor { x: dx, y: dy });
            changed |= c.handle(Input::Button {
                button,
                pressed: false,
            });
            changed | c.handle(Input::Left)
        };
        match self {
            Step::Key(_) => false,
            Step::Orbit(dx, dy) => drag(c, Button::Left, dx, dy),
            Step::Pan(dx, dy) => drag(c, Button::Right, dx, dy),
            Step::Zoom(lines) => c.handle(Input::Wheel { lines }),
        }
    }
}

/// Reads a script: `text` from `origin` (`--keys`, or the file's name), each word a
/// [`Step`]. A word that is neither a key nor a mouse move is [`Error::Usage`] naming the
/// origin, line and word.
pub fn parse(origin: &str, text: &str) -> Result<Vec<Step>> {
    let mut steps = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or_default();
        for word in line.split_whitespace() {
            steps.push(
                step(word)
                    .map_err(|why| Error::Usage(format!("{origin}:{}: `{word}`: {why}", n + 1)))?,
            );
        }
    }
    Ok(steps)
}

/// One word of a script.
fn step(word: &str) -> std::result::Result<Step, String> {
    let numbers = |args: &str, n: usize| -> std::result::Result<Vec<f64>, String> {
        let v: Vec<f64> = args
            .split(',')
            .map(|a| a.trim().parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| format!("wants {n} number(s) after the colon"))?;
        if v.len() != n || v.iter().any(|x| !x.is_finite()) {
            return Err(format!("wants {n} finite number(s) after the colon"));
        }
        Ok(v)
    };
    if let Some((name, args)) = word.split_once(':') {
        return match name {
            "orbit" => numbers(args, 2).map(|v| Step::Orbit(v[0], v[1])),
            "pan" => numbers(args, 2).map(|v| Step::Pan(v[0], v[1])),
            "zoom" => numbers(args, 1).map(|v| Step::Zoom(v[0])),
            _ => Err("not a mouse move (orbit:DX,DY, pan:DX,DY, zoom:N)".into()),
        };
    }
    let key = if word == "Esc" { "Escape" } else { word };
    keys::action_for(key).map(Step::Key).ok_or_else(|| {
        "not a key of view (k + - a z s r p ? q Escape; `fragtrace view --help` lists them) \
         nor a mouse move (orbit:DX,DY, pan:DX,DY, zoom:N)"
            .into()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::builtin_scene;

    #[test]
    fn words_become_steps_and_a_bad_word_is_named_with_its_line() {
        let s = parse(
            "keys.txt",
            "k + # depth up\n\na  orbit:10,-5 pan:3,4 zoom:2\nEsc",
        )
        .unwrap();
        assert_eq!(
            s,
            [
                Step::Key(Action::NextKernel),
                Step::Key(Action::DepthUp),
                Step::Key(Action::NextDisplay),
                Step::Orbit(10.0, -5.0),
                Step::Pan(3.0, 4.0),
                Step::Zoom(2.0),
                Step::Key(Action::Quit),
            ]
        );
        assert_eq!(parse("--keys", "  ").unwrap(), []);
        for (text, line, word) in [
            ("k\nw", 2, "w"),
            ("orbit:1", 1, "orbit:1"),
            ("zoom:x", 1, "zoom:x"),
            ("pan:1,inf", 1, "pan:1,inf"),
            ("spin:1", 1, "spin:1"),
        ] {
            let e = parse("--keys", text).unwrap_err().to_string();
            assert!(e.contains(&format!("--keys:{line}: `{word}`")), "{e}");
        }
    }

    /// A scripted drag moves the camera as the formula of `control::orbit` says, the
    /// controller left without a drag in progress; a key moves nothing.
    #[test]
    fn a_scripted_drag_moves_the_camera_by_the_formula() {
        let cam = builtin_scene().camera;
        let mut c = Controller::new(cam, 48);
        assert!(Step::Orbit(30.0, -12.0).drive(&mut c));
        assert_eq!(c.camera, control::orbit(&cam, 30.0, -12.0));
        let after = c.camera;
        assert!(
            !c.handle(control::Input::Cursor { x: 90.0, y: 9.0 }),
            "drag left on"
        );
        assert!(Step::Pan(5.0, 0.0).drive(&mut c));
        assert_eq!(c.camera, control::pan(&after, 5.0, 0.0, 48));
        assert!(!Step::Key(Action::NextKernel).drive(&mut c));
        assert!(!Step::Zoom(0.0).drive(&mut c));
    }
}
