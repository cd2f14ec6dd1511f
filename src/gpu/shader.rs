//! Shader assembly: every pass is the dialect's header (`#version 120` natively; GLSL ES
//! 1.00's version, extension and precision lines on WebGL 1, see [`super::dialect`]), then
//! generated `#define`s (ray-state
//! codes, scene features, pass variant, the Rust/GLSL contract of [`super::contract`]),
//! then the generated texel-layout declarations,
//! then `common.glsl`, then the pass's `.frag` with its `#include "x.glsl"` lines expanded
//! from a fixed list. An unknown include is an error. A line map sends driver error lines
//! back to (file, line).

use super::contract;
pub use super::dialect::Dialect;
pub use super::layout::Fetch;
use super::layout::SceneTextures;
use crate::scene::Scene;
use crate::technique::Techniques;
use crate::{Error, Result};

mod dump;
pub use dump::{all_feature_sets, all_passes, dump_shaders, dump_shaders_as};

/// `(name, text)` of each named file of `glsl120/`, embedded in the binary; each name is
/// written once, so an entry cannot name one file and embed another.
macro_rules! glsl_sources {
    ($($name:literal),* $(,)?) => {
        &[$(($name, include_str!(concat!("../../glsl120/", $name)))),*]
    };
}

/// The GLSL sources, embedded in the binary.
const SOURCES: &[(&str, &str)] = glsl_sources![
    "common.glsl",
    "intersect.glsl",
    "traverse.glsl",
    "shade.glsl",
    "step.glsl",
    "unrolled.frag",
    "srgb8.frag",
    "raygen.frag",
    "traverse_init.frag",
    "traverse_step.frag",
    "intersect.frag",
    "record.frag",
    "weight.frag",
    "spawn.frag",
    "shadow_spawn.frag",
    "accum_light.frag",
    "accum_ambient.frag",
    "count.frag",
    "compute.glsl",
    "camera.glsl",
    "instance.glsl",
    "instance_walk.glsl",
    "render.comp",
    "wave.comp",
    "srgb8.comp",
];

/// Files a pass may `#include`.
const INCLUDABLE: &[&str] = &[
    "intersect.glsl",
    "traverse.glsl",
    "shade.glsl",
    "step.glsl",
    "compute.glsl",
    "camera.glsl",
    "instance.glsl",
    "instance_walk.glsl",
];

pub use super::contract::RayState;
use super::options::{FragmentKernel, LOOP_MAX};

/// What the intersection pass looks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Query {
    /// The closest hit (camera, reflected and refracted rays).
    Closest,
    /// Any hit below t_max (shadow rays).
    Any,
}

/// What the counting pass counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Count {
    /// Rays still being traced.
    Rays,
    /// Pixels where a ray-tree node exists.
    Nodes,
}

/// Every pass program.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Pass {
    /// Primary ray generation.
    RayGen,
    /// Traversal set-up.
    TraverseInit,
    /// One DDA step.
    TraverseStep,
    /// One triangle test.
    Intersect(Query),
    /// Store a finished trace as a hit record.
    Record,
    /// Weight of a ray-tree child.
    Weight,
    /// Rays of a ray-tree child.
    Spawn,
    /// Shadow rays towards one light.
    ShadowSpawn,
    /// One light's direct term.
    AccumLight,
    /// Ambient term and background.
    AccumAmbient,
    /// Occlusion-query counting.
    Count(Count),
    /// K traversal iterations in one pass (`--kernel unrolled:K`).
    Unrolled(Query, u32),
    /// Up to [`LOOP_MAX`] traversal iterations in one pass (`--kernel looped`).
    Looped(Query),
    /// The finished image as 8-bit sRGB (read back for a PNG).
    Srgb8,
}

impl Pass {
    /// Every program a render may use.
    pub const ALL: [Pass; 14] = [
        Pass::RayGen,
        Pass::TraverseInit,
        Pass::TraverseStep,
        Pass::Intersect(Query::Closest),
        Pass::Intersect(Query::Any),
        Pass::Record,
        Pass::Weight,
        Pass::Spawn,
        Pass::ShadowSpawn,
        Pass::AccumLight,
        Pass::AccumAmbient,
        Pass::Count(Count::Rays),
        Pass::Count(Count::Nodes),
        Pass::Srgb8,
    ];

    /// Its source file.
    pub fn file(self) -> &'static str {
        match self {
            Pass::RayGen => "raygen.frag",
            Pass::TraverseInit => "traverse_init.frag",
            Pass::TraverseStep => "traverse_step.frag",
            Pass::Intersect(_) => "intersect.frag",
            Pass::Record => "record.frag",
            Pass::Weight => "weight.frag",
            Pass::Spawn => "spawn.frag",
            Pass::ShadowSpawn => "shadow_spawn.frag",
            Pass::AccumLight => "accum_light.frag",
            Pass::AccumAmbient => "accum_ambient.frag",
            Pass::Count(_) => "count.frag",
            Pass::Unrolled(..) | Pass::Looped(_) => "unrolled.frag",
            Pass::Srgb8 => "srgb8.frag",
        }
    }

    /// A short name for messages and statistics.
    pub fn name(self) -> &'static str {
        match self {
            Pass::RayGen => "raygen",
            Pass::TraverseInit => "traverse_init",
            Pass::TraverseStep => "traverse_step",
            Pass::Intersect(Query::Closest) => "intersect",
            Pass::Intersect(Query::Any) => "intersect_any",
            Pass::Record => "record",
            Pass::Weight => "weight",
            Pass::Spawn => "spawn",
            Pass::ShadowSpawn => "shadow_spawn",
            Pass::AccumLight => "accum_light",
            Pass::AccumAmbient => "accum_ambient",
            Pass::Count(Count::Rays) => "count_rays",
            Pass::Count(Count::Nodes) => "count_nodes",
            Pass::Unrolled(Query::Closest, _) => "unrolled",
            Pass::Unrolled(Query::Any, _) => "unrolled_any",
            Pass::Looped(Query::Closest) => "looped",
            Pass::Looped(Query::Any) => "looped_any",
            Pass::Srgb8 => "srgb8",
        }
    }

    /// Pass-variant `#define`s.
    fn defines(self) -> Vec<String> {
        let any = |q: Query| match q {
            Query::Any => vec!["ANY_HIT".to_string()],
            Query::Closest => vec![],
        };
        match self {
            Pass::Intersect(q) => any(q),
            Pass::Count(Count::Rays) => vec!["COUNT_RAYS".into()],
            Pass::Count(Count::Nodes) => vec!["COUNT_NODES".into()],
            Pass::Unrolled(q, k) => {
                let mut d = any(q);
                let step = "traverse_step(s0, s1, s2, s3); intersect_step(s0, s1, s2, s3);";
                d.push(format!(
                    "UNROLLED_STEPS {}",
                    vec![step; k as usize].join(" ")
                ));
                // The same iterations of an instanced scene's two-level walk.
                let step = "lv_step(L, q0, q1, q2, q3); lv_test(L, q0, q1, q2, q3, QUERY_ANY);";
                d.push(format!(
                    "UNROLLED_LEVELS {}",
                    vec![step; k as usize].join(" ")
                ));
                d
            }
            Pass::Looped(q) => {
                let mut d = any(q);
                d.push("LOOPED".into());
                d.push(format!("LOOP_MAX {LOOP_MAX}"));
                d
            }
            Pass::RayGen
            | Pass::TraverseInit
            | Pass::TraverseStep
            | Pass::Record
            | Pass::Weight
            | Pass::Spawn
            | Pass::ShadowSpawn
            | Pass::AccumLight
            | Pass::AccumAmbient
            | Pass::Srgb8 => vec![],
        }
    }

    /// The pass that advances rays by traversal iterations under `kernel`.
    pub fn advance(kernel: FragmentKernel, query: Query) -> Option<Pass> {
        match kernel {
            FragmentKernel::Multipass => None,
            FragmentKernel::Unrolled(k) => Some(Pass::Unrolled(query, k)),
            FragmentKernel::Looped => Some(Pass::Looped(query)),
        }
    }
}

// The struct lives with the statistics that report it (`--stats` writes it as an object of
// named booleans); the GL side decides it and turns it into defines here.
pub use crate::output::Features;

impl Features {
    /// What `scene` needs.
    pub fn of(scene: &Scene) -> Self {
        let m = &scene.materials;
        Features {
            smooth_normals: scene.has_smooth_normals(),
            checker: m.iter().any(|m| m.checker.is_some()),
            specular: m.iter().any(|m| m.ks.max_element() > 0.0),
            refraction: m.iter().any(|m| m.refracts()),
            fresnel: m.iter().any(|m| m.fresnel),
        }
    }

    /// Everything on: the one-size-fits-all build.
    pub fn all() -> Self {
        Features {
            smooth_normals: true,
            checker: true,
            specular: true,
            refraction: true,
            fresnel: true,
        }
    }

    fn defines(self) -> Vec<&'static str> {
        let Features {
            smooth_normals,
            checker,
            specular,
            refraction,
            fresnel,
        } = self;
        [
            (smooth_normals, "HAS_SMOOTH_NORMALS"),
            (checker, "HAS_CHECKER"),
            (specular, "HAS_SPECULAR"),
            (refraction, "HAS_REFRACTION"),
            (fresnel, "HAS_FRESNEL"),
        ]
        .into_iter()
        .filter_map(|(on, name)| on.then_some(name))
        .collect()
    }
}

/// An assembled program and where each of its lines came from.
#[derive(Clone, Debug)]
pub struct Assembled {
    /// The complete source.
    pub source: String,
    /// (file, 1-based line) of each source line.
    pub lines: Vec<(String, usize)>,
    /// The contract's names (uniforms, samplers, buffers, images) the source declares.
    pub declared: Vec<&'static str>,
}

impl Assembled {
    /// Maps a 1-based line of the assembled source to its origin.
    pub fn origin(&self, line: usize) -> (String, usize) {
        self.lines
            .get(line.wrapping_sub(1))
            .cloned()
            .unwrap_or_else(|| ("<assembled>".into(), line))
    }

    /// Appends the contract's declarations that `file` reads, then `text`.
    fn push_file(&mut self, file: &str, text: &str, compute: bool) {
        let decls = contract::declarations_for(file, compute, &mut self.declared);
        self.push_text("<generated declarations>", &decls);
        self.push_text(file, text);
    }

    fn push_text(&mut self, file: &str, text: &str) {
        for (k, l) in text.lines().enumerate() {
            self.source.push_str(l);
            self.source.push('\n');
            self.lines.push((file.to_string(), k + 1));
        }
    }
}

/// Every embedded GLSL file, as (name, text).
pub fn sources() -> &'static [(&'static str, &'static str)] {
    SOURCES
}

fn source(name: &str) -> Result<&'static str> {
    SOURCES
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, s)| *s)
        .ok_or_else(|| Error::Internal(format!("no embedded GLSL file `{name}`")))
}

/// Generated prelude: state codes and constants shared with Rust.
fn prelude() -> String {
    let mut s = contract::glsl_prelude();
    s.push_str("#define BIG 1.0e30\n");
    s.push_str(&format!(
        "#define TIE_EPS {:?}\n",
        crate::accel::TIE_EPS as f32
    ));
    s.push_str(&format!(
        "#define OFFSET_EPSILON {:?}\n",
        crate::technique::OFFSET_EPSILON as f32
    ));
    s
}

/// Assembles the fragment program of `pass` for a scene with `features` and `layout`,
/// specialised for `techniques`.
pub fn assemble(
    pass: Pass,
    features: Features,
    techniques: Techniques,
    layout: &SceneTextures,
) -> Result<Assembled> {
    assemble_in(Dialect::Glsl120, pass, features, techniques, layout)
}

/// [`assemble`] in `dialect`: the same sources and contract under that dialect's header.
pub fn assemble_in(
    dialect: Dialect,
    pass: Pass,
    features: Features,
    techniques: Techniques,
    layout: &SceneTextures,
) -> Result<Assembled> {
    let defines = pass.defines();
    let defines: Vec<&str> = defines.iter().map(String::as_str).collect();
    let target = Target {
        version: dialect.fragment_header(),
        fetch: Fetch::Texture2D,
        extra: String::new(),
    };
    let mut a = assemble_for(
        &target,
        pass.name(),
        pass.file(),
        source(pass.file())?,
        &defines,
        features,
        techniques,
        layout,
    )?;
    let decls = dialect.translate(&mut a.source);
    if !decls.is_empty() {
        // After the header's lines (version and precision lines come first).
        let header = dialect.fragment_header().lines().count();
        let at = a
            .source
            .match_indices('\n')
            .nth(header - 1)
            .map_or(a.source.len(), |(i, _)| i + 1);
        a.source.insert_str(at, &decls);
        let n = decls.lines().count();
        a.lines.splice(
            header..header,
            (1..=n).map(|k| ("<generated outputs>".to_string(), k)),
        );
    }
    Ok(a)
}

/// Assembles a fragment program from `text` (named `file`) with the same prelude and
/// include rules as the passes: how tests run the GLSL twins on hand-made inputs.
pub fn assemble_text(
    pass_name: &str,
    file: &str,
    text: &str,
    extra_defines: &[&str],
    features: Features,
    techniques: Techniques,
    layout: &SceneTextures,
) -> Result<Assembled> {
    let target = Target {
        version: "#version 120",
        fetch: Fetch::Texture2D,
        extra: String::new(),
    };
    assemble_for(
        &target,
        pass_name,
        file,
        text,
        extra_defines,
        features,
        techniques,
        layout,
    )
}

/// What separates the fragment kernels' GLSL 1.20 from the compute kernel's GLSL 4.30
/// around the same sources: the version line, the fetch functions and extra generated text.
struct Target {
    version: &'static str,
    fetch: Fetch,
    extra: String,
}

#[allow(clippy::too_many_arguments)]
fn assemble_for(
    target: &Target,
    pass_name: &str,
    file: &str,
    text: &str,
    extra_defines: &[&str],
    features: Features,
    techniques: Techniques,
    layout: &SceneTextures,
) -> Result<Assembled> {
    let mut a = Assembled {
        source: String::new(),
        lines: Vec::new(),
        declared: Vec::new(),
    };
    let compute = target.fetch != Fetch::Texture2D;
    a.push_text("<generated>", target.version);
    let mut defs = String::new();
    for d in features
        .defines()
        .into_iter()
        .chain(techniques.defines())
        .chain(extra_defines.iter().copied())
    {
        defs.push_str(&format!("#define {d}\n"));
    }
    a.push_text("<generated defines>", &defs);
    a.push_text("<generated prelude>", &prelude());
    if !target.extra.is_empty() {
        a.push_text("<generated compute prelude>", &target.extra);
    }
    // The layout declares the scene textures' samplers (or buffers) with its fetch
    // functions, named after the contract's `SAMPLERS` (a test checks every one).
    a.push_text(contract::LAYOUT, &layout.glsl_with(target.fetch));
    if layout.tex.is_some() {
        // The layout declares the textured scene's cone uniforms (`TexLayout::glsl`).
        a.declared.push(contract::uniform::ROOT_CONE.name);
        if !compute {
            a.declared.extend(["u_r3", "u_p3"]);
        }
    }
    a.push_file("common.glsl", source("common.glsl")?, compute);
    let mut included = Vec::new();
    // The file's own declarations go after its includes (which its header comment and
    // `#include` lines precede): before its first other line that is not a comment.
    let body_start = text
        .lines()
        .position(|l| {
            let t = l.trim();
            !(t.is_empty() || t.starts_with("//") || t.starts_with("#include"))
        })
        .unwrap_or(0);
    for (k, line) in text.lines().enumerate() {
        let t = line.trim();
        if let Some(rest) = t.strip_prefix("#include") {
            let name = rest.trim().trim_matches('"');
            if !INCLUDABLE.contains(&name) {
                return Err(Error::Shader {
                    pass: pass_name.into(),
                    file: file.into(),
                    line: k + 1,
                    log: format!(
                        "unknown include `{name}` (allowed: {})",
                        INCLUDABLE.join(", ")
                    ),
                });
            }
            if !included.contains(&name) {
                included.push(name);
                a.push_file(name, source(name)?, compute);
            }
        } else {
            if k == body_start {
                let decls = contract::declarations_for(file, compute, &mut a.declared);
                a.push_text("<generated declarations>", &decls);
            }
            a.source.push_str(line);
            a.source.push('\n');
            a.lines.push((file.to_string(), k + 1));
        }
    }
    Ok(a)
}

/// The compute kernel's programs (`--kernel compute`, GLSL 4.30).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ComputePass {
    /// The whole ray tree of every pixel and sample (`render.comp`).
    Render,
    /// A wave of given rays traced to their end (`wave.comp`, for `trace_rays`).
    Wave(Query),
    /// A band's radiance converted to 8-bit sRGB (`srgb8.comp`).
    Srgb8,
}

/// Work-group size of the compute programs: 8 x 4 invocations, one NVIDIA warp over a
/// compact tile (neighbouring rays walk the same cells). Measured on the H200 against 8x8,
/// 16x8, 16x4, 16x16, 32x4 and 32x2: the lowest sum over bunny.toml and the default scene
/// (docs/performance.md).
pub const LOCAL_SIZE: (u32, u32) = (8, 4);

/// What a compute program is specialised for besides the scene's features.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ComputeSpec {
    /// Samples per pixel (the loop over them runs in the program).
    pub samples: u32,
    /// Point lights.
    pub lights: u32,
    /// Maximum ray-tree depth.
    pub max_depth: u32,
    /// Whether any material reflects or refracts (else no children are ever spawned).
    pub secondary: bool,
    /// Traversal iterations after which a ray is cut off and counted as unfinished.
    pub max_iterations: u32,
    /// How the scene is read: texelFetch or storage buffers.
    pub fetch: Fetch,
    /// Whether the render writes the primary rays' AOV texels.
    pub aov: bool,
    /// Whether the scene is walked as instances over meshes' grids (`instance.glsl`).
    pub instanced: bool,
}

impl ComputeSpec {
    /// The one specialisation of the programs that trace nothing (`srgb8.comp`).
    pub const CONVERT: ComputeSpec = ComputeSpec {
        samples: 1,
        lights: 0,
        max_depth: 0,
        secondary: false,
        max_iterations: 0,
        fetch: Fetch::TexelFetch,
        aov: false,
        instanced: false,
    };
}

impl ComputePass {
    /// Its source file.
    pub fn file(self) -> &'static str {
        match self {
            ComputePass::Render => "render.comp",
            ComputePass::Wave(_) => "wave.comp",
            ComputePass::Srgb8 => "srgb8.comp",
        }
    }

    /// A short name for messages and statistics.
    pub fn name(self) -> &'static str {
        match self {
            ComputePass::Render => "compute",
            ComputePass::Wave(Query::Closest) => "compute_wave",
            ComputePass::Wave(Query::Any) => "compute_wave_any",
            ComputePass::Srgb8 => "compute_srgb8",
        }
    }

    fn defines(self, spec: &ComputeSpec) -> Vec<String> {
        let mut d = vec![
            "KERNEL_COMPUTE".to_string(),
            format!("LOCAL_X {}", LOCAL_SIZE.0),
            format!("LOCAL_Y {}", LOCAL_SIZE.1),
            format!("MAX_ITERATIONS {}", spec.max_iterations),
        ];
        match self {
            ComputePass::Render => {
                d.push(format!("SAMPLES {}", spec.samples.max(1)));
                d.push(format!("LIGHTS {}", spec.lights));
                d.push(format!("MAX_DEPTH {}", spec.max_depth));
                d.push(format!("STACK_SIZE {}", spec.max_depth + 1));
                if spec.secondary && spec.max_depth > 0 {
                    d.push("HAS_SECONDARY".into());
                }
                if spec.aov {
                    d.push("WRITE_AOV".into());
                }
                if spec.instanced {
                    d.push("INSTANCED".into());
                }
            }
            ComputePass::Wave(Query::Any) => d.push("ANY_HIT".into()),
            ComputePass::Wave(Query::Closest) | ComputePass::Srgb8 => {}
        }
        d
    }
}

/// Assembles a compute program: `#version 430`, the same generated prelude and shared GLSL
/// as the fragment passes, fetch functions through `texelFetch`, and the compute contract
/// ([`contract::compute`]).
pub fn assemble_compute(
    pass: ComputePass,
    spec: &ComputeSpec,
    features: Features,
    techniques: Techniques,
    layout: &SceneTextures,
) -> Result<Assembled> {
    let target = Target {
        version: "#version 430",
        fetch: spec.fetch,
        extra: contract::compute::compute_glsl(),
    };
    let defines = pass.defines(spec);
    let defines: Vec<&str> = defines.iter().map(String::as_str).collect();
    assemble_for(
        &target,
        pass.name(),
        pass.file(),
        source(pass.file())?,
        &defines,
        features,
        techniques,
        layout,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{Grid, GridConfig};
    use crate::scene::{Camera, Material};
    use glam::Vec3;

    fn layout() -> (Scene, SceneTextures) {
        let mut s = Scene::empty(Camera {
            eye: Vec3::Z,
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 45.0,
        });
        let m = s.add_material(Material::default());
        s.add_triangle(Vec3::ZERO, Vec3::X, Vec3::Y, m);
        let g = Grid::build(&s, &GridConfig::default()).unwrap();
        let l = SceneTextures::pack(&s, &g, 4096).unwrap();
        (s, l)
    }

    #[test]
    fn every_pass_assembles_and_maps_lines_back() {
        let (s, l) = layout();
        for pass in Pass::ALL {
            let a = assemble(pass, Features::of(&s), Techniques::default(), &l).unwrap();
            assert!(a.source.starts_with("#version 120\n"));
            assert_eq!(a.source.lines().count(), a.lines.len());
            assert!(!a.source.contains("#include"), "{pass:?}");
            // The last line maps back to the pass's own file.
            let (file, _) = a.origin(a.lines.len());
            assert_eq!(file, pass.file());
        }
        let a = assemble(
            Pass::Intersect(Query::Any),
            Features::of(&s),
            Techniques::default(),
            &l,
        )
        .unwrap();
        assert!(a.source.contains("#define ANY_HIT"));
        let n = a
            .source
            .lines()
            .position(|x| x.contains("vec4 intersect_tri("))
            .unwrap()
            + 1;
        let (file, line) = a.origin(n);
        assert_eq!(file, "intersect.glsl");
        assert!(source("intersect.glsl")
            .unwrap()
            .lines()
            .nth(line - 1)
            .unwrap()
            .contains("vec4 intersect_tri("));
    }

    #[test]
    fn features_follow_the_scene() {
        let (mut s, l) = layout();
        let f = Features::of(&s);
        assert!(!f.refraction && !f.checker && !f.smooth_normals);
        let a = assemble(Pass::AccumLight, f, Techniques::default(), &l).unwrap();
        assert!(!a.source.contains("#define HAS_REFRACTION"));
        s.materials[0].fresnel = true;
        let f = Features::of(&s);
        assert!(f.refraction && f.fresnel);
        assert!(assemble(Pass::Spawn, f, Techniques::default(), &l)
            .unwrap()
            .source
            .contains("#define HAS_FRESNEL"));
    }

    /// Every sampler a pass declares has a texture unit in the contract, so binding by
    /// [`Unit`](crate::gpu::contract::Unit) reaches it.
    #[test]
    fn every_sampler_has_a_unit() {
        use crate::gpu::contract::Unit;
        let (_, l) = layout();
        let known: Vec<&str> = Unit::ALL.iter().flat_map(|u| u.samplers()).collect();
        for pass in all_passes() {
            let a = assemble(pass, Features::all(), Techniques::default(), &l).unwrap();
            for line in a.source.lines() {
                if let Some(rest) = line.trim().strip_prefix("uniform sampler2D ") {
                    let name = rest.split([';', ' ']).next().unwrap();
                    assert!(
                        known.contains(&name),
                        "{pass:?}: sampler {name} has no unit"
                    );
                }
            }
        }
    }

    #[test]
    fn state_codes_round_trip() {
        for st in RayState::ALL {
            assert_eq!(RayState::from_code(st.code()), Some(st));
        }
    }
}
