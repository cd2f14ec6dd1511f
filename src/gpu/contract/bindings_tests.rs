//! Tests of `gpu/contract/bindings.rs` (its own file: bindings.rs passed 800 lines).
//! The contract against the GLSL and the driver: no file declares by hand, every
//! declaration is read by some program with the declared type, and a program refuses a
//! uniform it does not declare.

use std::collections::HashMap;

use super::*;
use crate::accel::{Accel, AccelKind, GridConfig, IrregularConfig};
use crate::gpu::context::with_test_context;
use crate::gpu::gl::{compile_compute, compile_program, Program, QUAD_VERTEX_SHADER};
use crate::gpu::layout::SceneTextures;
use crate::gpu::shader::{
    all_passes, assemble, assemble_compute, sources, ComputePass, ComputeSpec, Features, Fetch,
    Pass, Query,
};
use crate::scene::builtin_scene;
use crate::technique::Techniques;

/// No GLSL file spells a declaration the contract generates.
#[test]
fn no_glsl_file_declares_by_hand() {
    for (file, text) in sources() {
        for (k, line) in text.lines().enumerate() {
            let t = line.trim_start();
            let by_hand = (t.starts_with("uniform ") && t.contains(" u_"))
                || (t.starts_with("layout(") && (t.contains("buffer") || t.contains("image2D")));
            assert!(!by_hand, "{file}:{}: declared by hand: {t}", k + 1);
        }
    }
}

/// The built-in scene with a 2x2 image texture on its first material, every triangle
/// given texture coordinates and every vertex a colour.
fn textured_builtin() -> crate::scene::Scene {
    use crate::scene::texture::{TexLevel, Texture, Wrap};
    let mut s = builtin_scene();
    let base = TexLevel {
        width: 2,
        height: 2,
        texels: vec![
            [0.2, 0.4, 0.6],
            [0.8, 0.6, 0.4],
            [0.1, 0.9, 0.5],
            [0.7, 0.3, 0.2],
        ],
    };
    s.textures.push(Texture::from_linear(
        "<test>".into(),
        [Wrap::Repeat; 2],
        base,
    ));
    s.materials[0].diffuse_map = Some(0);
    s.uvs = vec![glam::Vec2::ZERO, glam::Vec2::X, glam::Vec2::Y];
    s.tri_uvs = vec![[0, 1, 2]; s.triangles.len()];
    s.colors = vec![glam::Vec3::ONE; s.positions.len()];
    s.validate().expect("a valid textured scene");
    s
}

/// Compiles every program (fragment passes for both structures with every feature on,
/// the irregular grid's for a textured scene,
/// the compute programs with both fetch paths) and returns, per GLSL name, the types
/// the driver reports for it where it is active, and the programs built.
fn active_everywhere(ctx: &crate::gpu::GlContext) -> (HashMap<String, Vec<u32>>, Vec<Program>) {
    let mut active: HashMap<String, Vec<u32>> = HashMap::new();
    let mut programs = Vec::new();
    // The built-in scene on the uniform grid, textured on the irregular one and with
    // instances on the two levels: the texture declarations are active in textured
    // programs only, the instancing ones in instanced programs only.
    let mut placed = builtin_scene();
    let sphere = placed.clone();
    placed.instancing.meshes.push(crate::scene::Mesh {
        name: "builtin".into(),
        geometry: sphere,
    });
    placed.instancing.instances.push(
        crate::scene::Instance::new(
            0,
            glam::DMat3::from_diagonal(glam::DVec3::new(-1.0, 1.0, 1.0)),
            glam::DVec3::X,
        )
        .unwrap(),
    );
    let n = placed.triangles.len();
    placed.instancing.number(n, "test").unwrap();
    for (kind, scene, instanced) in [
        (AccelKind::Uniform, builtin_scene(), false),
        (AccelKind::Irregular, textured_builtin(), false),
        (AccelKind::Uniform, placed, true),
    ] {
        // The fragment passes' layout, and the compute kernel's: on the irregular grid
        // its integer buffers (`DENSE_GRID`); an instanced scene's levels walk the
        // uniform grid, whose one layout (with `inst`) every kernel reads.
        let (layout, compute_layout) = if instanced {
            let gi =
                crate::accel::grid_instances::GridInstances::build(&scene, &GridConfig::default())
                    .unwrap();
            let l = SceneTextures::pack_instanced(&scene, &gi, 4096, true, None).unwrap();
            (l.clone(), l)
        } else {
            let accel = Accel::build(
                &scene,
                kind,
                &GridConfig::default(),
                &IrregularConfig::default(),
            )
            .unwrap();
            let l = SceneTextures::pack_with(&scene, accel.as_ref(), 4096, true).unwrap();
            let c = SceneTextures::pack_for(
                &scene,
                accel.as_ref(),
                4096,
                true,
                crate::gpu::layout::LayoutTarget::Compute,
                1 << 27,
            )
            .unwrap();
            (l, c)
        };
        let mut add = |p: Program| {
            for (name, utype) in p.active_uniforms(ctx.gl()) {
                active.entry(name).or_default().push(utype);
            }
            programs.push(p);
        };
        for pass in all_passes() {
            let a = assemble(pass, Features::all(), Techniques::default(), &layout).unwrap();
            let p = compile_program(ctx, pass.name(), QUAD_VERTEX_SHADER, &a.source, &|n| {
                a.origin(n)
            })
            .unwrap();
            add(p.declaring(a.declared));
        }
        if !ctx.info.compute {
            continue;
        }
        // The instanced walk (`instance_walk.glsl`) with both fetch paths.
        for fetch in [Fetch::TexelFetch, Fetch::Storage] {
            let spec = ComputeSpec {
                samples: 2,
                lights: 2,
                max_depth: 3,
                secondary: true,
                max_iterations: 1000,
                fetch,
                aov: true,
                instanced,
            };
            for pass in [
                ComputePass::Render,
                ComputePass::Wave(Query::Closest),
                ComputePass::Wave(Query::Any),
                ComputePass::Srgb8,
            ] {
                let a = assemble_compute(
                    pass,
                    &spec,
                    Features::all(),
                    Techniques::default(),
                    &compute_layout,
                )
                .unwrap();
                let p = compile_compute(ctx, pass.name(), &a.source, &|n| a.origin(n)).unwrap();
                add(p.declaring(a.declared));
            }
        }
    }
    (active, programs)
}

/// The GL type enum of a GLSL type name.
fn gl_type(glsl: &str) -> u32 {
    match glsl {
        "float" => glow::FLOAT,
        "int" => glow::INT,
        "vec3" => glow::FLOAT_VEC3,
        "ivec2" => glow::INT_VEC2,
        "sampler2D" => glow::SAMPLER_2D,
        other => panic!("no GL type for {other}"),
    }
}

/// Every uniform and sampler of the renderer's contract is active in at least one
/// program, with the declared type: a declaration no program reads fails here.
#[test]
fn every_declaration_is_read_with_its_type() {
    with_test_context(|ctx| {
        let (active, _) = active_everywhere(ctx);
        let mut checked = 0;
        for d in uniform::ALL {
            if !ctx.info.compute && d.readers.iter().all(|r| r.ends_with(".comp")) {
                continue;
            }
            let types = active.get(d.name).unwrap_or_else(|| {
                panic!("uniform {} is declared but no program reads it", d.name)
            });
            assert!(
                types.iter().all(|&t| t == gl_type(d.glsl)),
                "{}: declared {}, the driver reports {types:?}",
                d.name,
                d.glsl
            );
            checked += 1;
        }
        for s in SAMPLERS.iter().filter(|s| !s.readers.contains(&VIEW)) {
            let types = active.get(s.name).unwrap_or_else(|| {
                panic!("sampler {} is declared but no program reads it", s.name)
            });
            assert!(types.iter().all(|&t| t == glow::SAMPLER_2D), "{}", s.name);
            checked += 1;
        }
        // And nothing is active that the contract does not declare.
        let known: Vec<&str> = uniform::ALL
            .iter()
            .map(|d| d.name)
            .chain(SAMPLERS.iter().map(|s| s.name))
            .chain(Image::ALL.iter().map(|i| i.name()))
            .collect();
        for name in active.keys() {
            assert!(
                known.contains(&name.as_str()),
                "{name} is active but not in the contract"
            );
        }
        eprintln!("{checked} declarations read with their declared types");
    });
}

/// Setting a uniform a program does not declare is an error naming both; one it
/// declares is set (and reads back).
#[test]
fn setting_an_undeclared_uniform_is_an_error() {
    with_test_context(|ctx| {
        let (_, programs) = active_everywhere(ctx);
        let gl = ctx.gl();
        let ambient = &programs[Pass::ALL
            .iter()
            .position(|p| *p == Pass::AccumAmbient)
            .unwrap()];
        let e = ambient
            .set(gl, uniform::LIGHT_POS, glam::Vec3::ONE)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("accum_ambient") && e.contains("u_light_pos"),
            "{e}"
        );
        let v = glam::Vec3::new(0.25, 0.5, 0.75);
        ambient.set(gl, uniform::AMBIENT, v).unwrap();
        assert_eq!(
            ambient.uniform_vec3(gl, uniform::AMBIENT),
            Some(v.to_array())
        );
    });
}

/// Each declaration lands once, before the first file that reads it, and only in the
/// programs of its stage.
#[test]
fn declarations_go_where_their_readers_are() {
    let mut declared = Vec::new();
    let a = declarations_for("accum_light.frag", false, &mut declared);
    assert!(a.contains("uniform vec3 u_light_rad;"), "{a}");
    assert!(a.contains("uniform sampler2D u_acc;"), "{a}");
    assert!(!a.contains("u_light_pos"), "{a}");
    assert!(declarations_for("accum_light.frag", false, &mut declared).is_empty());
    let mut declared = Vec::new();
    let c = declarations_for("common.glsl", true, &mut declared);
    assert!(
        c.is_empty(),
        "compute programs read no ray-state sampler: {c}"
    );
    let r = declarations_for("render.comp", true, &mut declared);
    for b in Buffer::ALL {
        let declared = r.contains(&format!("binding = {}", b.binding()));
        assert_eq!(declared, b.readers().contains(&"render.comp"), "{b:?}: {r}");
    }
    let c = declarations_for("srgb8.comp", true, &mut Vec::new());
    assert!(
        c.contains("float srgb_thresholds[256]") && c.contains("u_pixels"),
        "{c}"
    );
    assert!(r.contains("uniform ivec2 u_size;"), "{r}");
    let w = declarations_for("wave.comp", true, &mut Vec::new());
    assert!(
        w.contains("layout(rgba32f, binding = 3) uniform image2D u_w3;"),
        "{w}"
    );
    assert_eq!(STORAGE_BINDING_BASE, Buffer::ALL.len() as u32);
}
