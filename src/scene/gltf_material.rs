//! glTF 2.0's metallic-roughness material mapped onto the Whitted material (split from
//! `gltf_mesh.rs` by job); the table is in `docs/scene-format.md`.
//!
//! A Whitted surface is a diffuse term, a Phong highlight, a perfect mirror and a perfect
//! refraction. So: the base colour (factor times texture times `COLOR_0`) is the diffuse
//! albedo; a smooth metal is a mirror tinted by its base colour, and a rough one (which
//! scatters its reflection, as no Whitted mirror can) is taken as diffuse:
//! `w = metallic·(1 - roughness)`, `kr = w·base`, `kd = ka = (1 - w)·(1 - transmission)`;
//! the highlight is the specular lobe's peak, `ks = (1 - roughness)·F0` with `F0` 0.04 for
//! a dielectric and the base colour for a metal, and `ns = 2/α² - 2` with `α = roughness²`
//! (the Blinn-Phong exponent whose lobe matches GGX's, Walter et al. 2007), clamped to
//! `1..=10000`; `KHR_materials_transmission` > 0 makes it a dielectric (`fresnel`, its
//! `ior` from `KHR_materials_ior`, 1.5 by default). Everything else is named once in the
//! file's one "ignored" warning line.

use std::collections::BTreeSet;

use glam::Vec3;

use super::Material;

/// glTF's default index of refraction (`KHR_materials_ior`).
pub const DEFAULT_IOR: f32 = 1.5;
/// Largest Phong exponent a roughness maps to (roughness 0 would be infinite).
pub const MAX_NS: f32 = 10_000.0;

/// The Whitted material of a glTF material (without its texture, which the caller
/// resolves), adding what it ignores to `ignored`.
pub(super) fn material_from_gltf(
    m: &gltf::Material<'_>,
    name: String,
    ignored: &mut BTreeSet<String>,
) -> Material {
    let pbr = m.pbr_metallic_roughness();
    // Alpha matters only under MASK or BLEND, both named as ignored below.
    let [r, g, b, _alpha] = pbr.base_color_factor();
    let base = Vec3::new(r, g, b);
    let metallic = pbr.metallic_factor().clamp(0.0, 1.0);
    let roughness = pbr.roughness_factor().clamp(0.0, 1.0);
    let transmission = m
        .transmission()
        .map_or(0.0, |t| t.transmission_factor().clamp(0.0, 1.0));
    let w = metallic * (1.0 - roughness);
    let diffuse = (1.0 - w) * (1.0 - transmission);
    let f0 = Vec3::splat(0.04).lerp(base, metallic);
    let alpha = roughness * roughness;
    let ns = if alpha > 0.0 {
        (2.0 / (alpha * alpha) - 2.0).clamp(1.0, MAX_NS)
    } else {
        MAX_NS
    };
    let refracts = transmission > 0.0;
    let ior = m.ior().unwrap_or(DEFAULT_IOR);
    if pbr.metallic_roughness_texture().is_some() {
        ignored.insert("metallicRoughnessTexture".into());
    }
    if m.normal_texture().is_some() {
        ignored.insert("normalTexture".into());
    }
    if m.occlusion_texture().is_some() {
        ignored.insert("occlusionTexture".into());
    }
    if m.emissive_texture().is_some() || m.emissive_factor() != [0.0; 3] {
        ignored.insert("emission (point lights only)".into());
    }
    if m.transmission()
        .is_some_and(|t| t.transmission_texture().is_some())
    {
        ignored.insert("transmissionTexture".into());
    }
    match m.alpha_mode() {
        gltf::material::AlphaMode::Opaque => {}
        gltf::material::AlphaMode::Mask => {
            ignored.insert("alphaMode MASK (cut-outs)".into());
        }
        gltf::material::AlphaMode::Blend => {
            ignored.insert("alphaMode BLEND".into());
        }
    }
    Material {
        name,
        albedo: base.max(Vec3::ZERO),
        checker: None,
        ka: diffuse,
        kd: diffuse,
        ks: (f0 * (1.0 - roughness)).max(Vec3::ZERO),
        ns,
        kr: (base * w).max(Vec3::ZERO),
        kt: Vec3::ZERO,
        ior: if refracts && ior > 0.0 && ior.is_finite() {
            ior
        } else {
            1.0
        },
        fresnel: refracts,
        diffuse_map: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mapped(json_material: &str) -> (Material, BTreeSet<String>) {
        let doc = format!(
            r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":["KHR_materials_transmission","KHR_materials_ior"],"materials":[{json_material}]}}"#
        );
        let g = gltf::Gltf::from_slice(doc.as_bytes()).unwrap();
        let m = g.document.materials().next().unwrap();
        let mut ignored = BTreeSet::new();
        (material_from_gltf(&m, "m".into(), &mut ignored), ignored)
    }

    #[test]
    fn the_documented_mapping() {
        // A rough dielectric: diffuse only, no highlight.
        let (m, ig) = mapped(
            r#"{"pbrMetallicRoughness":{"baseColorFactor":[0.64,0.5,0.25,1],"metallicFactor":0,"roughnessFactor":1}}"#,
        );
        assert_eq!(m.albedo, Vec3::new(0.64, 0.5, 0.25));
        assert_eq!((m.ka, m.kd, m.ks, m.ns), (1.0, 1.0, Vec3::ZERO, 1.0));
        assert!(!m.reflects() && !m.refracts() && ig.is_empty());
        // A smooth metal: a mirror tinted by its base colour, no diffuse term.
        let (m, _) = mapped(
            r#"{"pbrMetallicRoughness":{"baseColorFactor":[0.9,0.6,0.3,1],"metallicFactor":1,"roughnessFactor":0}}"#,
        );
        assert_eq!((m.kr, m.kd, m.ns), (Vec3::new(0.9, 0.6, 0.3), 0.0, MAX_NS));
        assert_eq!(m.ks, Vec3::new(0.9, 0.6, 0.3));
        // Half-rough half-metal: w = 0.25; alpha = 0.25, ns = 2/0.0625 - 2 = 30.
        let (m, _) = mapped(
            r#"{"pbrMetallicRoughness":{"baseColorFactor":[1,1,1,1],"metallicFactor":0.5,"roughnessFactor":0.5}}"#,
        );
        assert_eq!((m.kr, m.kd, m.ns), (Vec3::splat(0.25), 0.75, 30.0));
        // The defaults (metallic 1, roughness 1): a rough metal, taken as diffuse.
        let (m, _) = mapped("{}");
        assert_eq!((m.albedo, m.kd, m.kr), (Vec3::ONE, 1.0, Vec3::ZERO));
        // Transmission and ior: a Fresnel dielectric.
        let (m, ig) = mapped(
            r#"{"pbrMetallicRoughness":{"metallicFactor":0,"roughnessFactor":0},"extensions":{"KHR_materials_transmission":{"transmissionFactor":1},"KHR_materials_ior":{"ior":1.33}},"emissiveFactor":[1,0,0],"alphaMode":"BLEND"}"#,
        );
        assert!(m.fresnel && m.ior == 1.33 && m.kd == 0.0);
        assert_eq!(
            ig.into_iter().collect::<Vec<_>>(),
            ["alphaMode BLEND", "emission (point lights only)"]
        );
        assert_eq!(m.invalid(), None);
    }
}
