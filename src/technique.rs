//! Switches for the robustness techniques (docs/robustness.md), so that their cost and their
//! value can be measured. The defaults are what fragtrace always does; each non-default
//! setting swaps one technique for the classic, cheaper and less robust alternative, on the
//! CPU (f64 and f32) and in the GLSL programs (as generated `#define`s, see
//! [`Techniques::defines`]).

use clap::ValueEnum;

/// The fixed offset of [`OffsetMethod::Epsilon`]: spawned rays start this far from the hit
/// point along the geometric normal, whatever the scene's scale (the classic fixed epsilon).
pub const OFFSET_EPSILON: f64 = 1e-4;

/// Ray-triangle intersection algorithm.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, ValueEnum)]
pub enum IntersectMethod {
    /// Watertight test of Woop, Benthin and Wald (2013): edge functions in a ray-aligned
    /// shear frame, so no ray slips between triangles sharing an edge.
    #[default]
    Watertight,
    /// Möller and Trumbore (1997): barycentrics from two cross products with the edges of
    /// the triangle, each triangle on its own; a ray through a shared edge may miss both.
    MollerTrumbore,
}

/// pbrt-v3's conservative bound on the error of the hit parameter t.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, ValueEnum)]
pub enum TBound {
    /// A hit with t no larger than its own error bound is rejected (it could lie behind the
    /// origin): a spawned ray cannot re-hit the surface it leaves.
    #[default]
    On,
    /// Any hit with t > t_min counts.
    Off,
}

/// Where rays spawned at a hit (shadow, reflected, refracted) start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, ValueEnum)]
pub enum OffsetMethod {
    /// Offset along the geometric normal by pbrt's error bound of the hit point, then one
    /// rounding step more: scale-independent.
    #[default]
    ErrorBound,
    /// Offset by a fixed 1e-4 along the geometric normal: scale-dependent.
    // The value is OFFSET_EPSILON; this doc is also `render --help` text, where a rustdoc
    // link would show raw.
    Epsilon,
}

/// Where the shadow rays of smooth-shaded triangles (those with vertex normals) start: the
/// shadow terminator problem. A coarse mesh lies under the smooth surface its normals
/// describe, so near the terminator, and wherever a neighbouring triangle folds above the
/// tangent plane, the triangles shadow points that the smooth shading lights.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, ValueEnum)]
pub enum Terminator {
    /// The shadow ray is the exact one (from the triangle, the usual offset) less its
    /// start: it tests hits only once it has risen twice the hit point's distance from the
    /// smooth surface (the mix of its heights above the vertices' tangent planes, Hanika
    /// 2021's lift on the convex side) above the triangle's plane, and at most from a
    /// third of the longest edge on. Only triangles with vertex normals.
    #[default]
    Smooth,
    /// Shadow rays start on the triangle itself: exact for the triangles, dark speckles
    /// and blotches near the terminator of a smooth-shaded coarse mesh.
    Exact,
}

/// The robustness techniques a render uses; `Default` is fragtrace's normal behaviour.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Techniques {
    /// Ray-triangle test.
    pub intersect: IntersectMethod,
    /// Rejection of hits closer than their own t error bound.
    pub t_bound: TBound,
    /// Origin offset of spawned rays.
    pub offset: OffsetMethod,
    /// Shadow-ray origin on smooth-shaded triangles.
    pub terminator: Terminator,
}

impl Techniques {
    /// These techniques with the intersection test replaced.
    pub fn with_intersect(self, intersect: IntersectMethod) -> Self {
        Techniques { intersect, ..self }
    }

    /// These techniques with the t bound switched.
    pub fn with_t_bound(self, t_bound: TBound) -> Self {
        Techniques { t_bound, ..self }
    }

    /// These techniques with the offset replaced.
    pub fn with_offset(self, offset: OffsetMethod) -> Self {
        Techniques { offset, ..self }
    }

    /// These techniques with the shadow terminator handling replaced.
    pub fn with_terminator(self, terminator: Terminator) -> Self {
        Techniques { terminator, ..self }
    }

    /// The settings that differ from the default in exactly one technique, in the order
    /// intersect, t bound, offset, terminator (what `dump-shaders --all-variants` and the
    /// measurements cover).
    pub fn one_off() -> [Techniques; 4] {
        let d = Techniques::default();
        [
            d.with_intersect(IntersectMethod::MollerTrumbore),
            d.with_t_bound(TBound::Off),
            d.with_offset(OffsetMethod::Epsilon),
            d.with_terminator(match d.terminator {
                Terminator::Smooth => Terminator::Exact,
                Terminator::Exact => Terminator::Smooth,
            }),
        ]
    }

    /// The GLSL `#define`s selecting these techniques (one per technique, from an exhaustive
    /// match, so a new variant cannot be forgotten).
    pub fn defines(self) -> Vec<&'static str> {
        let Techniques {
            intersect,
            t_bound,
            offset,
            terminator,
        } = self;
        vec![
            match intersect {
                IntersectMethod::Watertight => "INTERSECT_WATERTIGHT",
                IntersectMethod::MollerTrumbore => "INTERSECT_MOLLER_TRUMBORE",
            },
            match t_bound {
                TBound::On => "T_BOUND_ON",
                TBound::Off => "T_BOUND_OFF",
            },
            match offset {
                OffsetMethod::ErrorBound => "OFFSET_ERROR_BOUND",
                OffsetMethod::Epsilon => "OFFSET_EPSILON_FIXED",
            },
            match terminator {
                Terminator::Smooth => "TERMINATOR_SMOOTH",
                Terminator::Exact => "TERMINATOR_EXACT",
            },
        ]
    }

    /// A short tag naming the non-default settings (`default` when none), as on the command
    /// line: e.g. `intersect-moller-trumbore`, `t-bound-off`, `offset-epsilon`.
    pub fn tag(self) -> String {
        let mut parts = Vec::new();
        if self.intersect != IntersectMethod::default() {
            parts.push(format!("intersect-{}", name(self.intersect)));
        }
        if self.t_bound != TBound::default() {
            parts.push(format!("t-bound-{}", name(self.t_bound)));
        }
        if self.offset != OffsetMethod::default() {
            parts.push(format!("offset-{}", name(self.offset)));
        }
        if self.terminator != Terminator::default() {
            parts.push(format!("terminator-{}", name(self.terminator)));
        }
        if parts.is_empty() {
            "default".into()
        } else {
            parts.join("+")
        }
    }
}

impl std::str::FromStr for Techniques {
    type Err = String;

    /// Reads what [`Techniques::tag`] writes: `default`, or the non-default settings joined
    /// by `+`, each once.
    fn from_str(s: &str) -> Result<Techniques, String> {
        let mut t = Techniques::default();
        if s == "default" {
            return Ok(t);
        }
        let bad = |part: &str| format!("`{s}`: `{part}` is not a technique setting");
        fn value<E: ValueEnum>(v: &str) -> Option<E> {
            E::from_str(v, false).ok()
        }
        for part in s.split('+') {
            let set = if let Some(v) = part.strip_prefix("intersect-") {
                value(v).map(|v| t.intersect = v)
            } else if let Some(v) = part.strip_prefix("t-bound-") {
                value(v).map(|v| t.t_bound = v)
            } else if let Some(v) = part.strip_prefix("offset-") {
                value(v).map(|v| t.offset = v)
            } else if let Some(v) = part.strip_prefix("terminator-") {
                value(v).map(|v| t.terminator = v)
            } else {
                None
            };
            set.ok_or_else(|| bad(part))?;
        }
        // One spelling per set of techniques: a default written out, or a setting twice,
        // is not a tag `tag` writes.
        if t.tag() != s {
            return Err(format!(
                "`{s}` is not how these techniques are written ({})",
                t.tag()
            ));
        }
        Ok(t)
    }
}

/// The command-line spelling of a value.
fn name<E: ValueEnum>(v: E) -> String {
    v.to_possible_value()
        .map(|p| p.get_name().to_string())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_and_tags() {
        let d = Techniques::default();
        assert_eq!(d.tag(), "default");
        assert_eq!(
            d.defines(),
            [
                "INTERSECT_WATERTIGHT",
                "T_BOUND_ON",
                "OFFSET_ERROR_BOUND",
                "TERMINATOR_SMOOTH"
            ]
        );
        let tags: Vec<String> = Techniques::one_off().iter().map(|t| t.tag()).collect();
        assert_eq!(
            tags,
            [
                "intersect-moller-trumbore",
                "t-bound-off",
                "offset-epsilon",
                "terminator-exact"
            ]
        );
    }
}
