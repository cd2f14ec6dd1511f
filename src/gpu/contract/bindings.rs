//! Every name a program is bound or set through, declared once: the uniforms with their
//! GLSL types ([`uniform`]), the samplers with their texture units ([`SAMPLERS`]), the
//! compute kernel's storage buffers ([`Buffer`]) and images ([`Image`]).
//!
//! Each declaration names the source files that read it. Shader assembly emits the GLSL
//! declaration just before the first such file of a program ([`declarations_for`]), and the
//! program remembers what it declares, so:
//! - no GLSL file declares a uniform, sampler, buffer or image by hand (a test reads every
//!   file to show it);
//! - the host sets a uniform only through a typed constant here ([`Uniform`]), whose value
//!   type is its GLSL type, and setting one on a program that does not declare it is an
//!   error ([`Program::set`](crate::gpu::gl::Program::set)) instead of a silent no-op;
//! - a declaration that no program reads fails a test (`every_declaration_is_read`), which
//!   compiles every pass and asks the driver which uniforms are active.

use std::marker::PhantomData;

use super::Unit;

/// Which programs a declaration may appear in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// GLSL 1.20 fragment programs.
    Fragment,
    /// Fragment and compute programs alike.
    Any,
}

impl Stage {
    fn admits(self, compute: bool) -> bool {
        match self {
            Stage::Fragment => !compute,
            Stage::Any => true,
        }
    }
}

/// A value type a uniform can have: its GLSL spelling and the value GL sets it to.
pub trait GlslType: Copy {
    /// The GLSL type.
    const GLSL: &'static str;
    /// The value, in the form of the `glUniform*` call that sets a uniform of this type
    /// (made by [`Program::set`](crate::gpu::gl::Program::set), the one place that does).
    fn value(self) -> UniformValue;
}

/// A uniform's value by the `glUniform*` call that sets it: the contract says what a value
/// is, `gpu::gl` alone calls GL.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum UniformValue {
    /// `float` (`glUniform1f`).
    Float(f32),
    /// `int` (`glUniform1i`).
    Int(i32),
    /// `vec3` (`glUniform3f`).
    Vec3([f32; 3]),
    /// `ivec2` (`glUniform2i`).
    IVec2([i32; 2]),
}

impl GlslType for f32 {
    const GLSL: &'static str = "float";
    fn value(self) -> UniformValue {
        UniformValue::Float(self)
    }
}

impl GlslType for i32 {
    const GLSL: &'static str = "int";
    fn value(self) -> UniformValue {
        UniformValue::Int(self)
    }
}

impl GlslType for glam::Vec3 {
    const GLSL: &'static str = "vec3";
    fn value(self) -> UniformValue {
        UniformValue::Vec3(self.to_array())
    }
}

impl GlslType for glam::IVec2 {
    const GLSL: &'static str = "ivec2";
    fn value(self) -> UniformValue {
        UniformValue::IVec2(self.to_array())
    }
}

/// A uniform of GLSL type `T::GLSL`, read by the files in `readers`.
pub struct Uniform<T> {
    /// The GLSL name.
    pub name: &'static str,
    /// Source files that read it (its declaration precedes the first of them).
    pub readers: &'static [&'static str],
    /// A comment for the generated declaration: what it holds.
    pub doc: &'static str,
    value: PhantomData<fn(T)>,
}

impl<T> Clone for Uniform<T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Uniform<T> {}

impl<T: GlslType> Uniform<T> {
    const fn new(name: &'static str, readers: &'static [&'static str], doc: &'static str) -> Self {
        Uniform {
            name,
            readers,
            doc,
            value: PhantomData,
        }
    }

    /// Its type-erased declaration.
    pub const fn decl(self) -> Decl {
        Decl {
            name: self.name,
            glsl: T::GLSL,
            readers: self.readers,
            doc: self.doc,
        }
    }
}

/// A uniform's declaration without its Rust type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Decl {
    /// The GLSL name.
    pub name: &'static str,
    /// The GLSL type.
    pub glsl: &'static str,
    /// Source files that read it.
    pub readers: &'static [&'static str],
    /// What it holds.
    pub doc: &'static str,
}

/// The uniforms the host sets, each with its type and readers.
pub mod uniform {
    use super::{Decl, Uniform};
    use glam::{IVec2, Vec3};

    /// The grid's lower corner (`traverse.glsl`).
    pub const GRID_MIN: Uniform<Vec3> =
        Uniform::new("u_grid_min", &["traverse.glsl"], "grid box, lower corner");
    /// The grid's upper corner.
    pub const GRID_MAX: Uniform<Vec3> =
        Uniform::new("u_grid_max", &["traverse.glsl"], "grid box, upper corner");
    /// The size of one cell (of the irregular grid's virtual grid).
    pub const CELL_SIZE: Uniform<Vec3> =
        Uniform::new("u_cell_size", &["traverse.glsl"], "size of one cell");
    /// Cells per axis, as floats.
    pub const GRID_RES: Uniform<Vec3> =
        Uniform::new("u_grid_res", &["traverse.glsl"], "cells per axis");
    /// The scene's ambient light.
    pub const AMBIENT: Uniform<Vec3> = Uniform::new(
        "u_ambient",
        &["accum_ambient.frag", "render.comp"],
        "ambient light",
    );
    /// The colour of rays that hit nothing.
    pub const BACKGROUND: Uniform<Vec3> = Uniform::new(
        "u_background",
        &["accum_ambient.frag", "render.comp"],
        "colour of rays that hit nothing",
    );
    /// The camera's eye (every primary ray's origin).
    pub const EYE: Uniform<Vec3> =
        Uniform::new("u_eye", &["raygen.frag", "render.comp"], "camera eye");
    /// The image (or wave) size in pixels.
    pub const SIZE: Uniform<IVec2> = Uniform::new(
        "u_size",
        &["raygen.frag", "render.comp", "wave.comp"],
        "image size in pixels",
    );
    /// The band of GL rows one compute dispatch renders: first row, row count (bands keep
    /// each output buffer under GL_MAX_SHADER_STORAGE_BLOCK_SIZE).
    pub const BAND: Uniform<IVec2> = Uniform::new(
        "u_band",
        &["render.comp"],
        "band of GL rows: first row, row count",
    );
    /// 1 / samples per pixel.
    pub const SAMPLE_WEIGHT: Uniform<f32> =
        Uniform::new("u_sample_weight", &["render.comp"], "1 / samples per pixel");
    /// The light the shadow rays of a shadow pass go to.
    pub const LIGHT_POS: Uniform<Vec3> =
        Uniform::new("u_light_pos", &["shadow_spawn.frag"], "light position");
    /// The radiance of the light being accumulated.
    pub const LIGHT_RAD: Uniform<Vec3> =
        Uniform::new("u_light_rad", &["accum_light.frag"], "light radiance");
    /// Pixels in the band `srgb8.comp` converts.
    pub const PIXELS: Uniform<i32> = Uniform::new("u_pixels", &["srgb8.comp"], "pixels to convert");
    /// Which child a weight or spawn pass makes: 0 reflected, 1 refracted.
    pub const BRANCH: Uniform<f32> = Uniform::new(
        "u_branch",
        &["weight.frag", "spawn.frag"],
        "child: 0 reflected, 1 refracted",
    );

    /// Textured scenes only (declared by the layout, `gpu/layout/`): the cone of the
    /// level being shaded or spawned from, when it is the root (x = 1: the primary rays,
    /// whose cone is width 0 and spread y; else x = 0 and the level's cone record `u_r3` /
    /// `u_p3` holds it).
    pub const ROOT_CONE: Uniform<Vec3> = Uniform::new(
        "u_root_cone",
        &[super::LAYOUT],
        "(1 at the root level, primary spread, 0)",
    );

    /// Every uniform.
    pub const ALL: [Decl; 15] = [
        GRID_MIN.decl(),
        GRID_MAX.decl(),
        CELL_SIZE.decl(),
        GRID_RES.decl(),
        AMBIENT.decl(),
        BACKGROUND.decl(),
        EYE.decl(),
        SIZE.decl(),
        BAND.decl(),
        SAMPLE_WEIGHT.decl(),
        LIGHT_POS.decl(),
        LIGHT_RAD.decl(),
        BRANCH.decl(),
        PIXELS.decl(),
        ROOT_CONE.decl(),
    ];
}

/// A sampler uniform and the texture unit it is bound to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sampler {
    /// The GLSL name.
    pub name: &'static str,
    /// Its unit.
    pub unit: Unit,
    /// Source files that read it; [`LAYOUT`] for the scene textures, whose declarations
    /// and fetch functions the texel layout generates (`gpu::layout`).
    pub readers: &'static [&'static str],
    /// The programs it may appear in.
    pub stage: Stage,
    /// What it holds.
    pub doc: &'static str,
}

/// The reader of the scene textures' samplers: the generated layout.
pub const LAYOUT: &str = "<generated layout>";

const fn sampler(
    name: &'static str,
    unit: Unit,
    readers: &'static [&'static str],
    stage: Stage,
    doc: &'static str,
) -> Sampler {
    Sampler {
        name,
        unit,
        readers,
        stage,
        doc,
    }
}

const ACCUM: &[&str] = &["accum_ambient.frag", "accum_light.frag"];
const CHILD: &[&str] = &["weight.frag", "spawn.frag"];

/// Every sampler. Samplers that never meet in one program share a unit (a level's records
/// are read as `u_r*` by the shading passes and as the parent's `u_p*` by the child
/// passes; the node weight `u_c2`, the primary directions `u_dir` and the 8-bit sRGB
/// thresholds `u_srgb` likewise).
pub const SAMPLERS: [Sampler; 27] = [
    sampler("u_tri", Unit::Tri, &[LAYOUT], Stage::Any, "triangles"),
    sampler("u_mat", Unit::Mat, &[LAYOUT], Stage::Any, "materials"),
    sampler("u_cell", Unit::Cell, &[LAYOUT], Stage::Any, "cell table"),
    sampler("u_list", Unit::List, &[LAYOUT], Stage::Any, "triangle list"),
    sampler("u_nrm", Unit::Nrm, &[LAYOUT], Stage::Any, "vertex normals"),
    sampler("u_vmap", Unit::Vmap, &[LAYOUT], Stage::Any, "voxel map"),
    // The two levels of an instanced scene walk uniform grids only: the voxel map's unit
    // is free for them.
    sampler(
        "u_inst",
        Unit::Vmap,
        &[LAYOUT],
        Stage::Any,
        "instanced scenes: placements, meshes' grids, the threaded top tree",
    ),
    // As the cone records: s2's unit, which no pass reading records reads.
    sampler(
        "u_ri",
        Unit::S2,
        &[
            "accum_ambient.frag",
            "accum_light.frag",
            "shadow_spawn.frag",
            "spawn.frag",
            "weight.frag",
        ],
        Stage::Fragment,
        "instanced scenes: the instance of this level's (or the parent's) hit, -1 for the \
         scene's own, and with textures the level's cone (record.frag's third output)",
    ),
    sampler(
        "u_tex",
        Unit::Tex,
        &[LAYOUT],
        Stage::Any,
        "textured scenes: uv records, texture table, texels",
    ),
    // The cone records share the unit of the ray state's s2: no program that reads a
    // record reads s2 (the shading and child passes read no traversal state but s0, s1,
    // s3), and the host binds them after the state (`Frame::bind_records`). An instanced
    // scene's record pass reads `u_r3` there too (it reads no s2) to copy the cone into
    // `u_ri`, which then takes the unit in the passes that shade.
    sampler(
        "u_r3",
        Unit::S2,
        &[LAYOUT],
        Stage::Fragment,
        "textured scenes: this level's cone (width at origin, spread)",
    ),
    sampler(
        "u_p3",
        Unit::S2,
        &[LAYOUT],
        Stage::Fragment,
        "textured scenes: the parent's cone (width at origin, spread)",
    ),
    sampler(
        "u_s0",
        Unit::S0,
        &["common.glsl"],
        Stage::Fragment,
        "S0_TEXEL(origin, state)",
    ),
    sampler(
        "u_s1",
        Unit::S1,
        &["common.glsl"],
        Stage::Fragment,
        "S1_TEXEL(dir, t_max)",
    ),
    sampler(
        "u_s2",
        Unit::S2,
        &["common.glsl"],
        Stage::Fragment,
        "S2_TEXEL(cell, cursor): cursor = next index into the triangle list",
    ),
    sampler(
        "u_s3",
        Unit::S3,
        &["common.glsl"],
        Stage::Fragment,
        "S3_TEXEL(t_best, tri_best, cursor_end, steps)",
    ),
    sampler(
        "u_r0",
        Unit::Rec0,
        &[
            "accum_ambient.frag",
            "accum_light.frag",
            "shadow_spawn.frag",
        ],
        Stage::Fragment,
        "this level's R0_TEXEL(origin, tri)",
    ),
    sampler(
        "u_r1",
        Unit::Rec1,
        &[
            "accum_ambient.frag",
            "accum_light.frag",
            "shadow_spawn.frag",
        ],
        Stage::Fragment,
        "this level's R1_TEXEL(dir, t)",
    ),
    sampler(
        "u_r2",
        Unit::Rec2,
        ACCUM,
        Stage::Fragment,
        "this level's R2_TEXEL(weight, exists)",
    ),
    sampler(
        "u_p0",
        Unit::Rec0,
        CHILD,
        Stage::Fragment,
        "the parent's R0_TEXEL(origin, tri)",
    ),
    sampler(
        "u_p1",
        Unit::Rec1,
        CHILD,
        Stage::Fragment,
        "the parent's R1_TEXEL(dir, t)",
    ),
    sampler(
        "u_p2",
        Unit::Rec2,
        &["weight.frag"],
        Stage::Fragment,
        "the parent's R2_TEXEL(weight, exists)",
    ),
    sampler(
        "u_c2",
        Unit::Node,
        &["count.frag", "spawn.frag"],
        Stage::Fragment,
        "the node's R2_TEXEL(weight, exists)",
    ),
    sampler(
        "u_dir",
        Unit::Node,
        &["raygen.frag"],
        Stage::Fragment,
        "unit primary directions of this sample",
    ),
    sampler(
        "u_srgb",
        Unit::Node,
        &["srgb8.frag"],
        Stage::Fragment,
        "the 8-bit sRGB thresholds (256 x 1, in .r; the last +inf)",
    ),
    sampler(
        "u_acc",
        Unit::Acc,
        &["accum_ambient.frag", "accum_light.frag", "srgb8.frag"],
        Stage::Fragment,
        "colour accumulated so far",
    ),
    // The wave's ray-state images of `wave.comp` are images, not samplers: see [`Image`].
    sampler(
        "u_view_img",
        Unit::Tri,
        &[VIEW],
        Stage::Fragment,
        "the picture or colour so far",
    ),
    sampler(
        "u_view_state",
        Unit::Mat,
        &[VIEW],
        Stage::Fragment,
        "ray state s0 of the wave in flight",
    ),
];

/// The reader of the view's presentation shader (`view::present`), which binds its own
/// two textures to units 0 and 1 and sets its own uniforms ([`view`]).
pub const VIEW: &str = "present.frag";

/// The uniforms of `fragtrace view`'s presentation shader.
pub mod view {
    use super::{Decl, Uniform, VIEW};

    /// What to draw: 0 the picture, 1 the colour so far, 2 the ray states.
    pub const MODE: Uniform<f32> = Uniform::new("u_view_mode", &[VIEW], "what to draw");
    /// Scale of the colour so far (samples done / samples).
    pub const SCALE: Uniform<f32> =
        Uniform::new("u_view_scale", &[VIEW], "scale of the colour so far");
    /// 1 where a wave's ray state is overlaid.
    pub const WAVE: Uniform<f32> = Uniform::new("u_view_wave", &[VIEW], "1: overlay the wave");

    /// Every uniform of the view.
    pub const ALL: [Decl; 3] = [MODE.decl(), SCALE.decl(), WAVE.decl()];
}

impl Unit {
    /// The GLSL sampler uniforms bound to this unit.
    pub fn samplers(self) -> impl Iterator<Item = &'static str> {
        SAMPLERS
            .iter()
            .filter(move |s| s.unit == self)
            .map(|s| s.name)
    }
}

/// The compute kernel's storage buffers, at fixed bindings; the scene's own storage
/// buffers (`--scene-fetch storage-buffer`) follow from [`STORAGE_BINDING_BASE`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Buffer {
    /// The camera: `CAM_*` slots of f64 ([`super::compute::camera_buffer`]).
    Camera,
    /// Per light `LIGHT_TEXELS` vec4 ([`super::compute::light_buffer`]).
    Lights,
    /// One `COUNTERS`-slot record per work group.
    Counters,
    /// Linear RGB per pixel of the band, in image order.
    Radiance,
    /// One `A0_TEXEL` per pixel of the band, in image order.
    Aov,
    /// 8-bit sRGB RGB of the band's pixels, four bytes to a word, in image order.
    Srgb8,
    /// The 256 linear values at which the 8-bit sRGB code steps up (the host's
    /// `image_io::srgb8_thresholds`, padded with +inf).
    SrgbThresholds,
}

impl Buffer {
    /// Every buffer, in binding order.
    pub const ALL: [Buffer; 7] = [
        Buffer::Camera,
        Buffer::Lights,
        Buffer::Counters,
        Buffer::Radiance,
        Buffer::Aov,
        Buffer::Srgb8,
        Buffer::SrgbThresholds,
    ];

    /// Its binding point.
    pub fn binding(self) -> u32 {
        self as u32
    }

    /// The GLSL name of its array.
    pub fn name(self) -> &'static str {
        match self {
            Buffer::Camera => "cam",
            Buffer::Lights => "lights",
            Buffer::Counters => "counters",
            Buffer::Radiance => "radiance",
            Buffer::Aov => "aov_out",
            Buffer::Srgb8 => "srgb8_out",
            Buffer::SrgbThresholds => "srgb_thresholds",
        }
    }

    /// The GLSL block declaration.
    fn glsl(self) -> String {
        let (access, block, member) = match self {
            Buffer::Camera => ("readonly", "CameraBuffer", "double cam[]"),
            Buffer::Lights => ("readonly", "LightBuffer", "vec4 lights[]"),
            Buffer::Counters => ("", "CounterBuffer", "uint counters[]"),
            // Written by render.comp, read by srgb8.comp.
            Buffer::Radiance => ("", "RadianceBuffer", "float radiance[]"),
            Buffer::Aov => ("writeonly", "AovBuffer", "vec4 aov_out[]"),
            Buffer::Srgb8 => ("writeonly", "Srgb8Buffer", "uint srgb8_out[]"),
            Buffer::SrgbThresholds => (
                "readonly",
                "SrgbThresholdBuffer",
                "float srgb_thresholds[256]",
            ),
        };
        let access = if access.is_empty() {
            String::new()
        } else {
            format!("{access} ")
        };
        format!(
            "layout(std430, binding = {}) {access}buffer {block} {{ {member}; }};\n",
            self.binding()
        )
    }

    /// Source files that read or write it.
    fn readers(self) -> &'static [&'static str] {
        match self {
            Buffer::Radiance => &["render.comp", "srgb8.comp"],
            Buffer::Srgb8 | Buffer::SrgbThresholds => &["srgb8.comp"],
            Buffer::Camera | Buffer::Lights | Buffer::Counters | Buffer::Aov => &["render.comp"],
        }
    }
}

/// Storage-buffer binding of the first scene texture under `Fetch::Storage`: the first
/// after the kernel's own [`Buffer`]s.
pub const STORAGE_BINDING_BASE: u32 = Buffer::ALL.len() as u32;

/// The images `wave.comp` reads and writes: the wave's ray state s0..s3, RGBA32F.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Image {
    /// s0..s3 of the wave, by index.
    Wave(u32),
}

impl Image {
    /// Every image, in binding order.
    pub const ALL: [Image; 4] = [
        Image::Wave(0),
        Image::Wave(1),
        Image::Wave(2),
        Image::Wave(3),
    ];

    /// Its image unit.
    pub fn binding(self) -> u32 {
        match self {
            Image::Wave(k) => k,
        }
    }

    /// The GLSL name.
    pub fn name(self) -> &'static str {
        match self {
            Image::Wave(k) => ["u_w0", "u_w1", "u_w2", "u_w3"][k as usize],
        }
    }

    fn glsl(self) -> String {
        format!(
            "layout(rgba32f, binding = {}) uniform image2D {};\n",
            self.binding(),
            self.name()
        )
    }
}

/// The GLSL declarations of everything in this contract that `file` reads and that
/// `declared` does not hold yet, for a compute (`compute`) or fragment program; the names
/// declared are added to `declared`.
pub fn declarations_for(file: &str, compute: bool, declared: &mut Vec<&'static str>) -> String {
    let mut s = String::new();
    let mut add = |name: &'static str, text: String, s: &mut String| {
        if !declared.contains(&name) {
            declared.push(name);
            s.push_str(&text);
        }
    };
    for d in uniform::ALL.iter().chain(&view::ALL) {
        if d.readers.contains(&file) {
            let text = format!("uniform {} {}; // {}\n", d.glsl, d.name, d.doc);
            add(d.name, text, &mut s);
        }
    }
    for smp in &SAMPLERS {
        if smp.readers.contains(&file) && smp.stage.admits(compute) {
            let text = format!("uniform sampler2D {}; // {}\n", smp.name, smp.doc);
            add(smp.name, text, &mut s);
        }
    }
    if compute {
        for b in Buffer::ALL {
            if b.readers().contains(&file) {
                add(b.name(), b.glsl(), &mut s);
            }
        }
        if file == "wave.comp" {
            for img in Image::ALL {
                add(img.name(), img.glsl(), &mut s);
            }
        }
    }
    s
}

#[cfg(test)]
#[path = "bindings_tests.rs"]
mod tests;
