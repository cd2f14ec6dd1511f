//! The scene file format as serde sees it: one struct per TOML table, `deny_unknown_fields`
//! everywhere. Optional keys are `Option` (defaults are applied while building) so that a
//! present key keeps its span for error messages; no value is checked here beyond its type.

use std::collections::BTreeMap;
use std::fmt;

use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;
use toml::Spanned;

use crate::scene::{CheckerAxes, Interpolation};

/// A value with the byte span it was read from.
pub(super) type S<T> = Spanned<T>;

/// The whole file: top-level keys and the `[camera]`, `[animation]`, `[image]`,
/// `[[lights]]`, `[materials.NAME]` and `[[objects]]` tables. Exactly one of `camera` and
/// `animation` is required; the builder says so, naming the table.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SceneDef {
    pub(super) camera: Option<S<CameraDef>>,
    // Not spanned: toml cannot give the span of a table that has no header of its own
    // (a file with only `[animation.orbit]`): "expected a borrowed string". The builder
    // finds its line instead.
    pub(super) animation: Option<AnimationDef>,
    pub(super) image: Option<ImageDef>,
    pub(super) background: Option<S<Triple>>,
    pub(super) ambient: Option<S<Triple>>,
    pub(super) max_depth: Option<S<i64>>,
    #[serde(default)]
    pub(super) lights: Vec<S<LightDef>>,
    #[serde(default)]
    pub(super) materials: BTreeMap<String, MaterialDef>,
    #[serde(default)]
    pub(super) objects: Vec<S<ObjectDef>>,
}

/// `[camera]`: a look-at pinhole camera.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CameraDef {
    pub(super) eye: S<Triple>,
    pub(super) look_at: S<Triple>,
    pub(super) up: Option<S<Triple>>,
    pub(super) fov: S<f64>,
}

/// `[animation]`: a camera path, either `[[animation.keyframes]]` or `[animation.orbit]`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct AnimationDef {
    pub(super) interpolation: Option<S<Interpolation>>,
    pub(super) keyframes: Option<Vec<S<KeyframeDef>>>,
    // Not spanned, as `SceneDef::animation`: the builder takes the line of its first key.
    pub(super) orbit: Option<OrbitDef>,
}

/// One `[[animation.keyframes]]` entry: the camera at a frame.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct KeyframeDef {
    pub(super) frame: S<i64>,
    pub(super) eye: S<Triple>,
    pub(super) look_at: S<Triple>,
    pub(super) up: Option<S<Triple>>,
    pub(super) fov: S<f64>,
}

/// `[animation.orbit]`: the camera circling a point.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct OrbitDef {
    pub(super) centre: S<Triple>,
    pub(super) radius: S<f64>,
    pub(super) height: Option<S<f64>>,
    pub(super) turns: Option<S<f64>>,
    pub(super) frames: S<i64>,
    pub(super) first_frame: Option<S<i64>>,
    pub(super) start_angle: Option<S<f64>>,
    pub(super) up: Option<S<Triple>>,
    pub(super) fov: S<f64>,
}

/// `[image]`: the default output size.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ImageDef {
    pub(super) width: Option<S<i64>>,
    pub(super) height: Option<S<i64>>,
}

/// One `[[lights]]` entry: a point light.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct LightDef {
    pub(super) position: S<Triple>,
    pub(super) color: Option<S<Triple>>,
    pub(super) intensity: Option<S<f64>>,
}

/// A `[materials.NAME]` table or an inline `material = { ... }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MaterialDef {
    pub(super) albedo: Option<S<Triple>>,
    pub(super) ka: Option<S<f64>>,
    pub(super) kd: Option<S<f64>>,
    pub(super) ks: Option<S<Triple>>,
    pub(super) ns: Option<S<f64>>,
    pub(super) kr: Option<S<Triple>>,
    pub(super) kt: Option<S<Triple>>,
    pub(super) ior: Option<S<f64>>,
    pub(super) fresnel: Option<bool>,
    pub(super) checker: Option<S<CheckerDef>>,
}

/// `checker = { ... }`: a procedural albedo replacing `albedo`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CheckerDef {
    pub(super) a: S<Triple>,
    pub(super) b: S<Triple>,
    pub(super) scale: Option<S<f64>>,
    pub(super) axes: Option<CheckerAxes>,
}

/// One `[[objects]]` entry: a mesh or an analytic shape, with its placement.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ObjectDef {
    pub(super) mesh: Option<S<String>>,
    pub(super) shape: Option<S<ShapeKind>>,
    pub(super) subdivisions: Option<S<i64>>,
    pub(super) radius: Option<S<f64>>,
    pub(super) size: Option<S<Numbers>>,
    pub(super) material: Option<S<MaterialRef>>,
    pub(super) translate: Option<S<Triple>>,
    pub(super) rotate: Option<S<Triple>>,
    pub(super) scale: Option<S<Numbers>>,
    /// Placements of the object, each after its own `scale`, `rotate`, `translate`: the
    /// object stored once and placed once per entry (`[[objects.instances]]`).
    pub(super) instances: Option<Vec<S<InstanceDef>>>,
}

/// One entry of an object's `instances`: a placement, applied after the object's own.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct InstanceDef {
    pub(super) translate: Option<S<Triple>>,
    pub(super) rotate: Option<S<Triple>>,
    pub(super) scale: Option<S<Numbers>>,
}

/// The analytic shapes `shape = "..."` names.
#[derive(Deserialize, Clone, Copy, PartialEq, Eq, Debug)]
#[serde(rename_all = "lowercase")]
pub(super) enum ShapeKind {
    Sphere,
    Quad,
    Box,
}

impl fmt::Display for ShapeKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ShapeKind::Sphere => "sphere",
            ShapeKind::Quad => "quad",
            ShapeKind::Box => "box",
        })
    }
}

/// Exactly three numbers (`eye = [0, 1, 5]`). serde's `[f64; 3]` reads three elements and
/// leaves the rest unread, and toml does not complain, so `[0, 1, 5, 9]` would load as
/// `[0, 1, 5]`; this reads the whole array and reports its length either way.
pub(super) struct Triple(pub(super) [f64; 3]);

impl std::ops::Deref for Triple {
    type Target = [f64; 3];
    fn deref(&self) -> &[f64; 3] {
        &self.0
    }
}

/// Prints as the bare array, so messages read `[0.0, 1.0, 5.0]`.
impl fmt::Debug for Triple {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        self.0.fmt(f)
    }
}

impl<'de> Deserialize<'de> for Triple {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Triple;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an array of length 3")
            }
            fn visit_seq<A: SeqAccess<'de>>(
                self,
                mut s: A,
            ) -> std::result::Result<Triple, A::Error> {
                let mut v = [0.0; 3];
                let mut n = 0;
                while let Some(x) = s.next_element::<f64>()? {
                    if n < 3 {
                        v[n] = x;
                    }
                    n += 1;
                }
                if n != 3 {
                    return Err(de::Error::invalid_length(n, &self));
                }
                Ok(Triple(v))
            }
        }
        d.deserialize_seq(V)
    }
}

/// A number or an array of numbers (`scale = 2` or `scale = [1, 2, 1]`); the length is
/// checked where the meaning is known.
pub(super) enum Numbers {
    One(f64),
    Many(Vec<f64>),
}

impl<'de> Deserialize<'de> for Numbers {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Numbers;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an array of numbers")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> std::result::Result<Numbers, E> {
                Ok(Numbers::One(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<Numbers, E> {
                Ok(Numbers::One(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<Numbers, E> {
                Ok(Numbers::One(v as f64))
            }
            fn visit_seq<A: SeqAccess<'de>>(
                self,
                mut s: A,
            ) -> std::result::Result<Numbers, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = s.next_element::<f64>()? {
                    v.push(x);
                }
                Ok(Numbers::Many(v))
            }
        }
        d.deserialize_any(V)
    }
}

/// `material = "name"` or an inline material table. Hand-written rather than
/// `#[serde(untagged)]` so that an unknown key inside the inline table is reported as such
/// instead of "data did not match any variant".
pub(super) enum MaterialRef {
    Named(String),
    Inline(Box<MaterialDef>),
}

impl<'de> Deserialize<'de> for MaterialRef {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = MaterialRef;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a material name or an inline material table")
            }
            fn visit_str<E: de::Error>(self, v: &str) -> std::result::Result<MaterialRef, E> {
                Ok(MaterialRef::Named(v.to_owned()))
            }
            fn visit_map<A: MapAccess<'de>>(
                self,
                m: A,
            ) -> std::result::Result<MaterialRef, A::Error> {
                MaterialDef::deserialize(de::value::MapAccessDeserializer::new(m))
                    .map(|d| MaterialRef::Inline(Box::new(d)))
            }
        }
        d.deserialize_any(V)
    }
}
