//! The passes a scene needs, and their programs: which of [`Pass::ALL`] (plus the chosen
//! kernel's advancing pass) a render with this scene, depth and kernel draws, compiled with
//! their sampler units and constant uniforms set once.

use std::collections::HashMap;

use crate::accel::AccelRef;
use crate::gpu::context::GlContext;
use crate::gpu::contract::Unit;
use crate::gpu::gl::{compile_program, Program, Uniform, QUAD_VERTEX_SHADER};
use crate::gpu::layout::SceneTextures;
use crate::gpu::options::Kernel;
use crate::gpu::shader::{assemble, Count, Features, Pass, Query};
use crate::scene::Scene;
use crate::technique::Techniques;
use crate::Result;

#[cfg(test)]
thread_local! {
    /// Test hook: the pass whose source gets a line that does not compile, to exercise a
    /// render failing half-way through building its programs.
    pub(crate) static BREAK_PASS: std::cell::Cell<Option<Pass>> = const { std::cell::Cell::new(None) };
}

/// The passes a render of `scene` with `levels` tree levels draws (all shading passes when
/// `shading`; only traversal for `trace_rays`).
pub(super) fn passes_for(scene: &Scene, levels: usize, shading: bool, kernel: Kernel) -> Vec<Pass> {
    let secondary = levels > 1 && scene.materials.iter().any(|m| m.reflects() || m.refracts());
    let lights = !scene.lights.is_empty();
    Pass::ALL
        .into_iter()
        .filter(|p| match p {
            Pass::Intersect(Query::Any) => (lights || !shading) && kernel == Kernel::Multipass,
            Pass::ShadowSpawn | Pass::AccumLight => shading && lights,
            Pass::Weight | Pass::Spawn | Pass::Count(Count::Nodes) => shading && secondary,
            Pass::RayGen | Pass::Record | Pass::AccumAmbient => shading,
            Pass::TraverseInit | Pass::Count(Count::Rays) => true,
            Pass::TraverseStep | Pass::Intersect(Query::Closest) => kernel == Kernel::Multipass,
            // Not in Pass::ALL: the chosen kernel's pass is added below.
            Pass::Unrolled(..) | Pass::Looped(_) => false,
        })
        .chain(
            [Query::Closest, Query::Any]
                .into_iter()
                .filter(|q| *q == Query::Closest || lights || !shading)
                .filter_map(|q| Pass::advance(kernel, q)),
        )
        .collect()
}

/// Compiles `passes` and sets each program's sampler units, grid, scene and size uniforms.
#[allow(clippy::too_many_arguments)]
pub(super) fn build_programs(
    ctx: &GlContext,
    passes: &[Pass],
    features: Features,
    techniques: Techniques,
    layout: &SceneTextures,
    accel: AccelRef<'_>,
    scene: &Scene,
    (width, height): (u32, u32),
) -> Result<HashMap<Pass, Program>> {
    let gl = ctx.gl();
    let mut programs = HashMap::new();
    for &pass in passes {
        #[allow(unused_mut)]
        let mut a = assemble(pass, features, techniques, layout)?;
        #[cfg(test)]
        if BREAK_PASS.get() == Some(pass) {
            a.source.push_str("this line does not compile\n");
            a.lines.push(("<test hook>".into(), 1));
        }
        let program = compile_program(ctx, pass.name(), QUAD_VERTEX_SHADER, &a.source, &|n| {
            a.origin(n)
        })?;
        set_scene_uniforms(gl, &program, accel, scene);
        program.set(gl, "u_size", Uniform::Vec2([width as f32, height as f32]));
        programs.insert(pass, program);
    }
    Ok(programs)
}

/// Makes `program` current and sets what every program of a render shares: each sampler's
/// texture unit, the grid's box and resolution, ambient and background (uniforms the
/// program lacks are skipped).
pub(super) fn set_scene_uniforms(
    gl: &glow::Context,
    program: &Program,
    accel: AccelRef<'_>,
    scene: &Scene,
) {
    for unit in Unit::ALL {
        for sampler in unit.samplers() {
            program.set(gl, sampler, Uniform::Int(unit.index() as i32));
        }
    }
    let set3 = |name: &str, v: glam::Vec3| program.set(gl, name, Uniform::Vec3(v.to_array()));
    let (min, max, cell_size, res) = match accel {
        AccelRef::Uniform(g) => (g.min, g.max, g.cell_size, g.res),
        AccelRef::Irregular(g) => (g.min, g.max, g.cell_size, g.res),
    };
    set3("u_grid_min", min);
    set3("u_grid_max", max);
    set3("u_cell_size", cell_size);
    set3("u_grid_res", glam::UVec3::from(res).as_vec3());
    set3("u_ambient", scene.ambient);
    set3("u_background", scene.background);
}
