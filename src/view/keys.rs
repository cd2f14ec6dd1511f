//! The keys of `fragtrace view`: one table ([`KEYS_HELP`], shown by `fragtrace view --help`
//! and printed on `?`) and the mapping from a key to an [`Action`], kept in step by a test.

use crate::gpu::options::Kernel;

/// The keys and the mouse, as `--help` and `?` show them.
pub const KEYS_HELP: &str = "\
Mouse:
  left drag          orbit around the look-at point
  right/middle drag  pan
  wheel              zoom
Keys:
  k                  next kernel (multipass, unrolled:8, looped, compute on GL 4.3)
  + / -              maximum depth up / down
  a                  next display: image, steps heat map, depth, normals, primitive ids
  z                  early-z mask on / off
  t                  outline the tiles the passes draw (multipass, unrolled) on / off
  s                  save a screenshot (fragtrace-view-N.png in the current folder)
  r                  reset the camera
  p                  play / pause the scene's camera path ([animation]), frame after frame
  ?                  print this list
  q / Esc            quit
The title shows the kernel, passes, rays/s, ms per frame and samples done, and what the
last traversal pass drew: its share of the image (the tiles still holding active rays)
and the rays active in them; at the end, the share over all traversal passes. When the
camera stops, samples accumulate up to --spp (the stratified pattern of `render --spp`).";

/// What a key does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// Switch to the next kernel of [`KERNELS`].
    NextKernel,
    /// Maximum depth + 1.
    DepthUp,
    /// Maximum depth - 1.
    DepthDown,
    /// Next [`Display`].
    NextDisplay,
    /// Early-z mask on or off.
    ToggleMask,
    /// The outline of the tiles the passes draw on or off.
    ToggleTiles,
    /// Save a screenshot.
    Screenshot,
    /// Camera back to the scene's.
    ResetCamera,
    /// Play or pause the scene's camera path.
    Play,
    /// Print [`KEYS_HELP`].
    Help,
    /// Close the window.
    Quit,
}

/// The action of a key, from the text it types (`"k"`, `"+"`) or its name (`"Escape"`).
pub fn action_for(key: &str) -> Option<Action> {
    Some(match key {
        "k" | "K" => Action::NextKernel,
        "+" | "=" => Action::DepthUp,
        "-" | "_" => Action::DepthDown,
        "a" | "A" => Action::NextDisplay,
        "z" | "Z" => Action::ToggleMask,
        "t" | "T" => Action::ToggleTiles,
        "s" | "S" => Action::Screenshot,
        "r" | "R" => Action::ResetCamera,
        "p" | "P" => Action::Play,
        "?" | "h" | "H" => Action::Help,
        "q" | "Q" | "Escape" => Action::Quit,
        _ => return None,
    })
}

/// The kernels `k` cycles through (compute only where the context has compute shaders).
pub const KERNELS: [Kernel; 4] = [
    Kernel::Multipass,
    Kernel::Unrolled(8),
    Kernel::Looped,
    Kernel::Compute,
];

/// The kernel after `k` in [`KERNELS`] (the first when `k` is not in the list, as `auto`
/// is not), skipping `compute` where the context lacks compute shaders.
pub fn next_kernel(k: Kernel, compute: bool) -> Kernel {
    let i = KERNELS.iter().position(|&x| x == k);
    let next = KERNELS[i.map_or(0, |i| (i + 1) % KERNELS.len())];
    if next == Kernel::Compute && !compute {
        KERNELS[0]
    } else {
        next
    }
}

/// What the window shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Display {
    /// The rendered image.
    Image,
    /// An AOV of the primary rays, coloured as `render --aov` previews it.
    Aov(crate::aov::AovKind),
}

impl Display {
    /// The next display in the order of [`KEYS_HELP`].
    pub fn next(self) -> Display {
        use crate::aov::AovKind;
        match self {
            Display::Image => Display::Aov(AovKind::Steps),
            Display::Aov(AovKind::Steps) => Display::Aov(AovKind::Depth),
            Display::Aov(AovKind::Depth) => Display::Aov(AovKind::Normal),
            Display::Aov(AovKind::Normal) => Display::Aov(AovKind::PrimId),
            Display::Aov(AovKind::PrimId) => Display::Image,
        }
    }

    /// Its name in the title.
    pub fn name(self) -> &'static str {
        use crate::aov::AovKind;
        match self {
            Display::Image => "image",
            Display::Aov(AovKind::Steps) => "steps",
            Display::Aov(AovKind::Depth) => "depth",
            Display::Aov(AovKind::Normal) => "normals",
            Display::Aov(AovKind::PrimId) => "primitive ids",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_listed_key_has_its_action_and_cycles_close() {
        for (key, action) in [
            ("k", Action::NextKernel),
            ("+", Action::DepthUp),
            ("-", Action::DepthDown),
            ("a", Action::NextDisplay),
            ("z", Action::ToggleMask),
            ("t", Action::ToggleTiles),
            ("s", Action::Screenshot),
            ("r", Action::ResetCamera),
            ("?", Action::Help),
            ("q", Action::Quit),
            ("Escape", Action::Quit),
        ] {
            assert_eq!(action_for(key), Some(action), "{key}");
            let shown = if key == "Escape" { "Esc" } else { key };
            assert!(
                KEYS_HELP
                    .lines()
                    .any(|l| l.split_whitespace().any(|w| w == shown)),
                "{key} missing from the help"
            );
        }
        assert_eq!(action_for("x"), None);
        // With compute shaders the cycle has every kernel once; without, compute never.
        let cycle = |compute: bool, from: Kernel| {
            let mut k = from;
            (0..KERNELS.len())
                .map(|_| {
                    k = next_kernel(k, compute);
                    k
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(
            cycle(true, Kernel::Compute),
            KERNELS.to_vec(),
            "the full cycle from compute"
        );
        assert_eq!(
            cycle(false, Kernel::Looped),
            [KERNELS[..3].to_vec(), vec![Kernel::Multipass]].concat()
        );
        assert_eq!(next_kernel(Kernel::Auto, true), Kernel::Multipass);
        let mut d = Display::Image;
        for _ in 0..5 {
            d = d.next();
        }
        assert_eq!(d, Display::Image);
    }
}
