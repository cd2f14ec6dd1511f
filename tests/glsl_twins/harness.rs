//! The harness the twin tests share: one row of fragments through an assembled program,
//! inputs as textures, outputs read back; distances in ulps and epsilons that fail on NaN.

use fragtrace::accel::{Grid, GridConfig};
use fragtrace::cpu::real::V3;
use fragtrace::gpu::gl::{
    compile_program, FullscreenQuad, RenderTarget, Texture, QUAD_VERTEX_SHADER,
};
use fragtrace::gpu::layout::SceneTextures;
use fragtrace::gpu::shader::{assemble_text, sources, Features};
use fragtrace::gpu::GlContext;
use fragtrace::scene::{Camera, Material, Scene};
use fragtrace::technique::Techniques;
use glam::Vec3;

/// One triangle and its grid: the scene the twin tests pack when only the programs matter.
pub(crate) fn one_triangle() -> (Scene, Grid) {
    let mut s = Scene::empty(Camera {
        eye: Vec3::Z,
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
    });
    let m = s.add_material(Material::default());
    s.add_triangle(Vec3::ZERO, Vec3::X, Vec3::Y, m);
    let g = Grid::build(&s, &GridConfig::default()).unwrap();
    (s, g)
}

pub(crate) fn dummy_layout() -> SceneTextures {
    let (s, g) = one_triangle();
    SceneTextures::pack(&s, &g, 4096).unwrap()
}

/// Runs `body` (GLSL computing `vec4 result` from `vec4 in0..in{K-1}`) once per case,
/// with the grid uniforms of `grid` set and the programs built for `techniques`.
pub(crate) fn run_cases_grid(
    ctx: &GlContext,
    body: &str,
    cases: &[Vec<[f32; 4]>],
    grid: Option<&Grid>,
    techniques: Techniques,
) -> Vec<[f32; 4]> {
    let n = cases.len() as u32;
    let k = cases[0].len() as u32;
    let mut data = Vec::with_capacity((n * k * 4) as usize);
    for row in 0..k {
        for c in cases {
            data.extend_from_slice(&c[row as usize]);
        }
    }
    let mut reads = String::new();
    for r in 0..k {
        reads.push_str(&format!(
            "    vec4 in{r} = texture2D(u_in, vec2(gl_FragCoord.x / {n}.0, ({r}.0 + 0.5) / {k}.0));\n"
        ));
    }
    let text = format!(
        "#include \"intersect.glsl\"\n#include \"traverse.glsl\"\nuniform sampler2D u_in;\nvoid main() {{\n{reads}    vec4 result;\n{body}\n    gl_FragData[0] = result;\n}}\n"
    );
    let a = assemble_text(
        "test",
        "test.frag",
        &text,
        &[],
        Features::all(),
        techniques,
        &dummy_layout(),
    )
    .unwrap();
    let prog = compile_program(ctx, "test", QUAD_VERTEX_SHADER, &a.source, &|l| a.origin(l))
        .unwrap()
        .declaring(a.declared.clone());
    let tex = Texture::new_f32(ctx, n, k, Some(&data)).unwrap();
    let target = RenderTarget::new(ctx, n, 1, 1).unwrap();
    let quad = FullscreenQuad::new(ctx).unwrap();
    prog.set_by_name(ctx, "u_in", 0i32);
    if let Some(g) = grid {
        use fragtrace::gpu::contract::uniform;
        let res = glam::UVec3::from(g.res).as_vec3();
        for (u, v) in [
            (uniform::GRID_MIN, g.min),
            (uniform::GRID_MAX, g.max),
            (uniform::CELL_SIZE, g.cell_size),
            (uniform::GRID_RES, res),
        ] {
            assert!(prog.declares(u), "{}", u.name);
            prog.set_by_name(ctx, u.name, v);
        }
    }
    quad.draw_into(ctx, &target, &prog, &[(0, &tex)]);
    let out = target.texture(0).read_f32(ctx).unwrap();
    out.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect()
}

pub(crate) struct Rng(pub(crate) u64);
impl Rng {
    pub(crate) fn f(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    }
}

/// Distance in units in the last place between two f32 (0 when equal, +0 and -0 equal);
/// `u32::MAX` when either is NaN, so a NaN never passes a bound.
pub(crate) fn ulps(a: f32, b: f32) -> u32 {
    if a.is_nan() || b.is_nan() {
        return u32::MAX;
    }
    // Map the sign-magnitude bit patterns onto one monotonic integer line.
    let key = |x: f32| {
        let i = x.to_bits() as i32;
        if i < 0 {
            i32::MIN.wrapping_sub(i) as i64
        } else {
            i as i64
        }
    };
    (key(a) - key(b)).unsigned_abs().min(u32::MAX as u64) as u32
}

// ---------------------------------------------------------------------------------------
// Shading and spawning: glsl120/shade.glsl, spawn.frag and shadow_spawn.frag against
// src/cpu/shade.rs and the spawn logic of src/cpu/render.rs (`CpuRenderer::shade`).

/// Texture unit of the first test input: above every unit of the contract (0..13). The
/// inputs then reach unit 17 and the shading program writes 5 attachments: llvmpipe offers
/// 32 units and 8 draw buffers (period hardware may not, but these tests run here).
pub(crate) const FIRST_INPUT_UNIT: u32 = 14;

/// Runs the fragment program `text` (assembled as a pass is, every feature on) over one row
/// of fragments with `layout`'s textures bound to their contract units. `inputs` are
/// (sampler, one texel per fragment); `u3`/`u1` set uniforms. Returns `outputs` attachments.
#[allow(clippy::too_many_arguments)]
pub(crate) fn run_program(
    ctx: &GlContext,
    text: &str,
    defines: &[&str],
    layout: &SceneTextures,
    techniques: Techniques,
    inputs: &[(&str, &[[f32; 4]])],
    u3: &[(&str, Vec3)],
    u1: &[(&str, f32)],
    outputs: usize,
) -> Vec<Vec<[f32; 4]>> {
    use fragtrace::gpu::contract::Unit;
    let n = inputs[0].1.len() as u32;
    // A shipped pass under its own name, so assembly declares what the contract says it
    // reads; a test's own text under `test.frag`, declaring its inputs itself.
    let file = sources()
        .iter()
        .find(|(_, t)| *t == text)
        .map_or("test.frag", |(name, _)| *name);
    let a = assemble_text(
        "test",
        file,
        text,
        defines,
        Features::all(),
        techniques,
        layout,
    )
    .unwrap();
    let prog =
        compile_program(ctx, "test", QUAD_VERTEX_SHADER, &a.source, &|l| a.origin(l)).unwrap();
    let scene_tex: Vec<_> = layout
        .with_units()
        .into_iter()
        .map(|(u, t)| {
            (
                u,
                Texture::new_f32(ctx, t.width, t.height, Some(&t.data)).unwrap(),
            )
        })
        .collect();
    let in_tex: Vec<_> = inputs
        .iter()
        .map(|(_, d)| Texture::new_f32(ctx, n, 1, Some(d.as_flattened())).unwrap())
        .collect();
    let target = RenderTarget::new(ctx, n, 1, outputs).unwrap();
    let quad = FullscreenQuad::new(ctx).unwrap();
    let mut textures: Vec<(u32, &Texture)> =
        scene_tex.iter().map(|(u, t)| (u.index(), t)).collect();
    for unit in Unit::ALL {
        for s in unit.samplers() {
            prog.set_by_name(ctx, s, unit.index() as i32);
        }
    }
    for (k, ((name, _), t)) in inputs.iter().zip(&in_tex).enumerate() {
        let unit = FIRST_INPUT_UNIT + k as u32;
        textures.push((unit, t));
        prog.set_by_name(ctx, name, unit as i32);
    }
    for (name, v) in u3 {
        prog.set_by_name(ctx, name, *v);
    }
    for (name, v) in u1 {
        prog.set_by_name(ctx, name, *v);
    }
    quad.draw_into(ctx, &target, &prog, &textures);
    (0..outputs)
        .map(|k| {
            let out = target.texture(k).read_f32(ctx).unwrap();
            out.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect()
        })
        .collect()
}

/// Largest difference between `gpu` and `cpu` (first `len` components) in units of
/// f32::EPSILON relative to max(|cpu|, 1); infinite when either holds a NaN.
pub(crate) fn eps_diff(gpu: &[f32], cpu: &[f32]) -> f32 {
    gpu.iter().zip(cpu).fold(0.0, |m: f32, (&g, &c)| {
        let d = (g - c).abs() / (f32::EPSILON * c.abs().max(1.0));
        if d.is_nan() {
            f32::INFINITY
        } else {
            m.max(d)
        }
    })
}

/// Largest per-component distance in ulps of a spawned origin (`u32::MAX` on NaN).
pub(crate) fn origin_ulps(gpu: &[f32; 4], cpu: V3<f32>) -> u32 {
    (0..3).map(|k| ulps(gpu[k], cpu[k])).max().unwrap()
}

pub(crate) fn v3(v: V3<f32>) -> [f32; 3] {
    [v.x, v.y, v.z]
}

/// Whether the driver evaluates the shaders in their CPU twins' operation order and rounding.
/// Mesa's llvmpipe does (bit-exact where the twins promise it), so the strict bounds, which
/// catch a one-ulp slip, apply there. NVIDIA's compiler contracts `a * b + c` into fused
/// multiply-adds and reorders sums: on the H200 the same code differs by tens of f32
/// epsilons (barycentrics 48.5, surface points 40.6; run logs in git, b97da3f:docs/bench/h200/house/), so
/// other drivers get the `*_CONTRACTING` bounds, measured there.
pub(crate) fn exact_driver(ctx: &GlContext) -> bool {
    ctx.info.renderer.contains("llvmpipe")
}
