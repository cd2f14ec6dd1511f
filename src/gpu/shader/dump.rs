//! `fragtrace dump-shaders`: the final sources of every program a render can compile,
//! written to a folder so that glslangValidator can check them offline (tests/
//! glsl120_validate.rs): every fragment pass (GLSL 1.20, `.frag`) and the compute kernel's
//! programs (GLSL 4.30, `.comp`, the extension that makes the validator pick the stage).

use super::{assemble, assemble_compute, ComputePass, ComputeSpec, Features, Fetch, Pass, Query};
use crate::accel::AccelRef;
use crate::gpu::layout::{self, SceneTextures};
use crate::scene::Scene;
use crate::technique::Techniques;
use crate::{Error, Result};

/// Every combination of scene features (for `dump-shaders --all-variants`).
pub fn all_feature_sets() -> Vec<Features> {
    (0..32u32)
        .map(|b| Features {
            smooth_normals: b & 1 != 0,
            checker: b & 2 != 0,
            specular: b & 4 != 0,
            refraction: b & 8 != 0,
            fresnel: b & 16 != 0,
        })
        .collect()
}

impl Features {
    /// A short tag naming the features on, e.g. `n-c-s-r-f` or `none`.
    pub fn tag(self) -> String {
        let on: Vec<&str> = [
            (self.smooth_normals, "normals"),
            (self.checker, "checker"),
            (self.specular, "specular"),
            (self.refraction, "refraction"),
            (self.fresnel, "fresnel"),
        ]
        .into_iter()
        .filter_map(|(b, n)| b.then_some(n))
        .collect();
        if on.is_empty() {
            "plain".into()
        } else {
            on.join("+")
        }
    }
}

/// Every pass program a render can use, for every kernel variant (unrolled at 4 and 16).
pub fn all_passes() -> Vec<Pass> {
    let mut v = Pass::ALL.to_vec();
    for q in [Query::Closest, Query::Any] {
        v.push(Pass::Unrolled(q, 4));
        v.push(Pass::Unrolled(q, 16));
        v.push(Pass::Looped(q));
    }
    v
}

/// The compute programs to write, as (file stem, pass, specialisation). `scene` gives the
/// one a render of it compiles (one sample, its lights and depth; a ray tree only where a
/// material reflects or refracts); with `all_variants` a render program with several
/// samples, lights and the whole ray tree, and one of primary and shadow rays only (the
/// code `HAS_SECONDARY` leaves out), so both sides of every `#ifdef` are checked. Both
/// wave programs (closest and any hit) either way.
fn compute_programs(
    scene: &Scene,
    max_iterations: u32,
    all_variants: bool,
) -> Vec<(&'static str, ComputePass, ComputeSpec)> {
    let waves = ComputeSpec {
        samples: 1,
        lights: 0,
        max_depth: 0,
        secondary: false,
        max_iterations,
        fetch: Fetch::Storage,
        aov: false,
        instanced: false,
    };
    let mut v = if all_variants {
        vec![
            (
                "compute",
                ComputePass::Render,
                ComputeSpec {
                    samples: 4,
                    lights: 2,
                    max_depth: 5,
                    secondary: true,
                    max_iterations,
                    fetch: Fetch::Storage,
                    aov: true,
                    instanced: false,
                },
            ),
            (
                "compute_primary",
                ComputePass::Render,
                ComputeSpec {
                    samples: 1,
                    lights: 1,
                    max_depth: 0,
                    secondary: false,
                    max_iterations,
                    fetch: Fetch::Storage,
                    aov: true,
                    instanced: false,
                },
            ),
        ]
    } else {
        vec![(
            "compute",
            ComputePass::Render,
            ComputeSpec {
                samples: 1,
                lights: scene.lights.len() as u32,
                max_depth: scene.max_depth,
                secondary: scene.materials.iter().any(|m| m.reflects() || m.refracts()),
                max_iterations,
                fetch: Fetch::Storage,
                aov: true,
                instanced: false,
            },
        )]
    };
    if all_variants {
        // The same full program reading the scene through texelFetch (contexts with too few
        // storage blocks).
        let (_, pass, spec) = v[0];
        v.push((
            "compute_texelfetch",
            pass,
            ComputeSpec {
                fetch: Fetch::TexelFetch,
                ..spec
            },
        ));
    }
    v.push((
        ComputePass::Srgb8.name(),
        ComputePass::Srgb8,
        ComputeSpec::CONVERT,
    ));
    for q in [Query::Closest, Query::Any] {
        let pass = ComputePass::Wave(q);
        v.push((pass.name(), pass, waves));
    }
    v
}

/// Writes the final sources of every program for `scene` into `dir`: every fragment pass
/// (`<pass>.frag`), the compute kernel's programs (`<program>.comp`, see
/// `compute_programs`) and the vertex shader. With `all_variants`, for every combination
/// of scene features, one sub-folder each, plus one sub-folder `techniques-<tag>` per
/// non-default technique setting of [`Techniques::one_off`], with every scene feature on.
/// Returns the files written.
pub fn dump_shaders<'a>(
    scene: &Scene,
    accel: impl Into<AccelRef<'a>>,
    dir: &std::path::Path,
    all_variants: bool,
) -> Result<Vec<std::path::PathBuf>> {
    dump_shaders_as(
        scene,
        accel,
        dir,
        all_variants,
        Techniques::default(),
        false,
    )
}

/// [`dump_shaders`] with the techniques a render would compile in (the set without
/// `all_variants`), and every scene feature where `no_specialize` asks for them: what
/// `fragtrace dump-shaders` writes for the choices it is given.
pub fn dump_shaders_as<'a>(
    scene: &Scene,
    accel: impl Into<AccelRef<'a>>,
    dir: &std::path::Path,
    all_variants: bool,
    techniques: Techniques,
    no_specialize: bool,
) -> Result<Vec<std::path::PathBuf>> {
    let accel = accel.into().grid()?;
    // Variants with smooth normals on fetch from the normal texture, so it is declared.
    let layout = SceneTextures::pack_with(scene, accel, layout::MAX_ROW, all_variants)?;
    // The compute programs read the compute kernel's layout (over the irregular grid, its
    // integer buffers), sized against the largest block GL's sizes express: no context here.
    let compute_layout = SceneTextures::pack_for(
        scene,
        accel,
        layout::MAX_ROW,
        all_variants,
        layout::LayoutTarget::Compute,
        i32::MAX as u64,
    )?;
    let max_iterations = crate::gpu::scene::max_iterations(accel).min(i32::MAX as u64) as u32;
    let compute = compute_programs(scene, max_iterations, all_variants);
    let d = Techniques::default();
    let sets: Vec<(Features, Techniques, Option<String>)> = if all_variants {
        all_feature_sets()
            .into_iter()
            .map(|f| (f, d, Some(f.tag())))
            .chain(
                Techniques::one_off()
                    .into_iter()
                    .map(|t| (Features::all(), t, Some(format!("techniques-{}", t.tag())))),
            )
            .collect()
    } else if no_specialize {
        vec![(Features::all(), techniques, None)]
    } else {
        vec![(Features::of(scene), techniques, None)]
    };
    let io = |path: &std::path::Path, e: std::io::Error| Error::Io {
        path: path.to_path_buf(),
        source: e,
    };
    let mut written = Vec::new();
    let mut write = |path: std::path::PathBuf, text: &str| -> Result<()> {
        std::fs::write(&path, text).map_err(|e| io(&path, e))?;
        written.push(path);
        Ok(())
    };
    crate::image_io::create_folder(dir, "shader")?;
    write(dir.join("quad.vert"), crate::gpu::gl::QUAD_VERTEX_SHADER)?;
    for (f, t, tag) in sets {
        let sub = match tag {
            Some(tag) => dir.join(tag),
            None => dir.to_path_buf(),
        };
        crate::image_io::create_folder(&sub, "shader")?;
        for pass in all_passes() {
            let name = match pass {
                Pass::Unrolled(_, k) => format!("{}{k}.frag", pass.name()),
                _ => format!("{}.frag", pass.name()),
            };
            write(sub.join(name), &assemble(pass, f, t, &layout)?.source)?;
        }
        for (stem, pass, spec) in &compute {
            let a = assemble_compute(*pass, spec, f, t, &compute_layout)?;
            write(sub.join(format!("{stem}.comp")), &a.source)?;
        }
    }
    if all_variants {
        // An instanced scene's programs (`instance.glsl`, `instance_walk.glsl`), every
        // feature on, in `instanced/`: the scene placed as a mesh of its own, mirrored.
        let placed = instanced_twin(scene)?;
        let gi = crate::accel::grid_instances::GridInstances::build(&placed, &Default::default())?;
        let layout = SceneTextures::pack_instanced(&placed, &gi, layout::MAX_ROW, true, None)?;
        let sub = dir.join("instanced");
        crate::image_io::create_folder(&sub, "shader")?;
        let (f, t) = (Features::all(), Techniques::default());
        for pass in all_passes() {
            let name = match pass {
                Pass::Unrolled(_, k) => format!("{}{k}.frag", pass.name()),
                _ => format!("{}.frag", pass.name()),
            };
            write(sub.join(name), &assemble(pass, f, t, &layout)?.source)?;
        }
        let (_, pass, spec) = compute[0];
        let spec = ComputeSpec {
            instanced: true,
            ..spec
        };
        let a = assemble_compute(pass, &spec, f, t, &layout)?;
        write(sub.join("compute_instanced.comp"), &a.source)?;
    }
    Ok(written)
}

/// `scene` with a copy of itself placed once as an instance (mirrored), for the instanced
/// programs of `--all-variants`.
fn instanced_twin(scene: &Scene) -> Result<Scene> {
    let mut placed = scene.clone();
    placed.instancing = Default::default();
    let mesh = placed.clone();
    placed.instancing.meshes.push(crate::scene::Mesh {
        name: "twin".into(),
        geometry: mesh,
    });
    let mirror = glam::DMat3::from_diagonal(glam::DVec3::new(-1.0, 1.0, 1.0));
    let inst = crate::scene::Instance::new(0, mirror, glam::DVec3::X)
        .ok_or_else(|| Error::Internal("a mirroring placement is invertible".into()))?;
    placed.instancing.instances.push(inst);
    let own = placed.triangles.len();
    let source = placed.source.clone();
    placed.instancing.number(own, &source)?;
    Ok(placed)
}
