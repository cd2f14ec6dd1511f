//! The contract between the Rust host and the GLSL passes, declared once: the ray-state
//! codes ([`RayState`]), the texture units every sampler is bound to ([`Unit`],
//! [`SAMPLERS`]), every uniform with its GLSL type ([`uniform`]), the compute kernel's
//! storage buffers and images ([`Buffer`], [`Image`]) and its counter, camera, light and
//! AOV layouts ([`compute`]), the fields of the ray-state texels s0..s3 ([`ray`]), of the
//! per-level hit records r0..r2 ([`rec`]) and of the material slots ([`mat`]), and the
//! sentinel values stored in them.
//!
//! No GLSL file declares a uniform, sampler, buffer or image: shader assembly emits each
//! declaration before the first file that reads it ([`declarations_for`]).
//!
//! The GLSL side is generated from these declarations ([`glsl_prelude`]): one `#define` per
//! field naming its swizzle (`s3.S3_T_BEST`), one constructor per texel listing its fields
//! in order (`S3_TEXEL(t_best, tri_best, cursor_end, steps)`), and the sentinels. The Rust
//! readers ([`StateTexels`]) and the material packing ([`super::layout`]) index by the same
//! [`Field`]s, so neither side spells a component index by hand.

mod bindings;
pub mod compute;
pub mod instancing;

pub use bindings::{
    declarations_for, uniform, view, Buffer, Decl, GlslType, Image, Sampler, Stage, Uniform,
    UniformValue, LAYOUT, SAMPLERS, STORAGE_BINDING_BASE, VIEW,
};

/// Ray states, stored in the 4th component of the ray-origin texture (the thesis's
/// *kezdeti*, *érvénytelen*, *átszelő*, *metszéspont-tesztelő*, *árnyékoló* states, plus
/// done).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayState {
    /// Generated, traversal not set up yet.
    Initial,
    /// Misses the grid's bounding box: finished without a hit.
    Invalid,
    /// Walking the grid cell by cell.
    Traversing,
    /// Testing the triangles of the current cell one per pass.
    Testing,
    /// Finished with a hit (for shadow rays: occluded).
    Shading,
    /// Finished without a hit, or no ray at all.
    Done,
}

impl RayState {
    /// All states.
    pub const ALL: [RayState; 6] = [
        RayState::Initial,
        RayState::Invalid,
        RayState::Traversing,
        RayState::Testing,
        RayState::Shading,
        RayState::Done,
    ];

    /// The float code stored in textures.
    pub fn code(self) -> f32 {
        match self {
            RayState::Initial => 0.0,
            RayState::Invalid => 1.0,
            RayState::Traversing => 2.0,
            RayState::Testing => 3.0,
            RayState::Shading => 4.0,
            RayState::Done => 5.0,
        }
    }

    /// The GLSL macro name.
    pub fn macro_name(self) -> &'static str {
        match self {
            RayState::Initial => "ST_INITIAL",
            RayState::Invalid => "ST_INVALID",
            RayState::Traversing => "ST_TRAVERSING",
            RayState::Testing => "ST_TESTING",
            RayState::Shading => "ST_SHADING",
            RayState::Done => "ST_DONE",
        }
    }

    /// Decodes a stored code.
    pub fn from_code(c: f32) -> Option<RayState> {
        RayState::ALL
            .into_iter()
            .find(|s| (s.code() - c).abs() < 0.25)
    }
}

/// Texture units, fixed per sampler so bindings are set once per program. Samplers that
/// never meet in one program share a unit (a level's records are read as `u_r*` by the
/// shading passes and as the parent's `u_p*` by the child passes).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Unit {
    /// Triangle vertices (`u_tri`).
    Tri,
    /// Materials (`u_mat`).
    Mat,
    /// Cell table of the grid (`u_cell`): one texel per uniform cell, two per irregular
    /// cell.
    Cell,
    /// Triangle-index list (`u_list`).
    List,
    /// Vertex normals (`u_nrm`).
    Nrm,
    /// Ray state s0: origin, state.
    S0,
    /// Ray state s1: direction, t_max.
    S1,
    /// Ray state s2: cell, cursor.
    S2,
    /// Ray state s3: t_best, tri_best, cursor_end, steps.
    S3,
    /// Hit record r0 (origin, tri) of this level (`u_r0`) or of the parent (`u_p0`).
    Rec0,
    /// Hit record r1 (direction, t), as `u_r1` or `u_p1`.
    Rec1,
    /// Hit record r2 (weight, exists), as `u_r2` or `u_p2`.
    Rec2,
    /// The weight record of the ray-tree node being spawned or counted (`u_c2`); in the
    /// ray-generation pass, which reads no record, the primary directions (`u_dir`).
    Node,
    /// Colour accumulated so far (`u_acc`).
    Acc,
    /// The irregular grid's voxel map (`u_vmap`; bound only with `--accel irregular`).
    Vmap,
    /// Textured scenes only: texture coordinates, the texture table and every texture's
    /// texels in one atlas (`u_tex`), the 16th unit of a GeForce 6/7.
    Tex,
}

impl Unit {
    /// Every unit.
    pub const ALL: [Unit; 16] = [
        Unit::Tri,
        Unit::Mat,
        Unit::Cell,
        Unit::List,
        Unit::Nrm,
        Unit::S0,
        Unit::S1,
        Unit::S2,
        Unit::S3,
        Unit::Rec0,
        Unit::Rec1,
        Unit::Rec2,
        Unit::Node,
        Unit::Acc,
        Unit::Vmap,
        Unit::Tex,
    ];

    /// The ray-state units, in attachment order s0..s3.
    pub const STATE: [Unit; 4] = [Unit::S0, Unit::S1, Unit::S2, Unit::S3];

    /// The hit-record units, r0..r2.
    pub const RECORD: [Unit; 3] = [Unit::Rec0, Unit::Rec1, Unit::Rec2];

    /// The texture unit number (`GL_TEXTURE0 + index`).
    pub fn index(self) -> u32 {
        match self {
            Unit::Tri => 0,
            Unit::Mat => 1,
            Unit::Cell => 2,
            Unit::List => 3,
            Unit::Nrm => 4,
            Unit::S0 => 5,
            Unit::S1 => 6,
            Unit::S2 => 7,
            Unit::S3 => 8,
            Unit::Rec0 => 9,
            Unit::Rec1 => 10,
            Unit::Rec2 => 11,
            Unit::Node => 12,
            Unit::Acc => 13,
            Unit::Vmap => 14,
            Unit::Tex => 15,
        }
    }
}

/// Texture units a render of an untextured scene needs (all but [`Unit::Tex`]).
pub const REQUIRED_TEXTURE_UNITS: i32 = Unit::ALL.len() as i32 - 1;
/// Texture units a render of a textured scene needs: all 16 of a GeForce 6/7, none left
/// (the cone records share s2's unit).
pub const TEXTURED_TEXTURE_UNITS: i32 = Unit::ALL.len() as i32;

/// Components of an RGBA texel, for swizzles.
const COMPONENTS: [char; 4] = ['x', 'y', 'z', 'w'];

/// A named run of components of one texel of a texel group.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Field {
    /// Which texel of the group (s0..s3, r0..r2).
    pub texel: usize,
    /// First component (0 = x).
    pub first: usize,
    /// Number of components.
    pub len: usize,
    /// Lower-case name, as in GLSL constructor parameters and comments.
    pub name: &'static str,
}

impl Field {
    pub(crate) const fn new(texel: usize, first: usize, len: usize, name: &'static str) -> Field {
        Field {
            texel,
            first,
            len,
            name,
        }
    }

    /// The swizzle selecting this field, e.g. `xyz` or `w`.
    pub fn swizzle(&self) -> String {
        COMPONENTS[self.first..self.first + self.len]
            .iter()
            .collect()
    }

    /// Index of this field's first float within RGBA texel `k` of a read-back array.
    pub fn at(&self, k: usize) -> usize {
        k * 4 + self.first
    }
}

/// The ray state: four RGBA32F (or, with `--storage f16`, s1 in RGBA16F) texels per ray,
/// ping-ponged between two targets.
pub mod ray {
    use super::Field;

    /// s0.xyz: ray origin.
    pub const ORIGIN: Field = Field::new(0, 0, 3, "origin");
    /// s0.w: ray state code ([`RayState`](crate::gpu::shader::RayState)).
    pub const STATE: Field = Field::new(0, 3, 1, "state");
    /// s1.xyz: ray direction.
    pub const DIR: Field = Field::new(1, 0, 3, "dir");
    /// s1.w: upper end of the ray's interval.
    pub const T_MAX: Field = Field::new(1, 3, 1, "t_max");
    /// s2.xyz: current grid cell (uniform grid), or (cell id, previous exit t, t where the
    /// ray leaves the grid's box) (irregular grid).
    pub const CELL: Field = Field::new(2, 0, 3, "cell");
    /// s2.w: next index into the triangle list.
    pub const CURSOR: Field = Field::new(2, 3, 1, "cursor");
    /// s3.x: closest hit distance so far.
    pub const T_BEST: Field = Field::new(3, 0, 1, "t_best");
    /// s3.y: triangle of that hit, [`TRI_NONE`](super::TRI_NONE) or
    /// [`TRI_NO_RAY`](super::TRI_NO_RAY).
    pub const TRI_BEST: Field = Field::new(3, 1, 1, "tri_best");
    /// s3.z: end of the current cell's list.
    pub const CURSOR_END: Field = Field::new(3, 2, 1, "cursor_end");
    /// s3.w: cells visited plus triangle tests.
    pub const STEPS: Field = Field::new(3, 3, 1, "steps");
    /// s3.xy: t_best and tri_best together (a hit is written as one).
    pub const HIT: Field = Field::new(3, 0, 2, "hit");

    /// Every field, texel by texel in component order (`HIT` aside: it overlaps two).
    pub const ALL: [Field; 10] = [
        ORIGIN, STATE, DIR, T_MAX, CELL, CURSOR, T_BEST, TRI_BEST, CURSOR_END, STEPS,
    ];
}

/// The hit record of one ray-tree level: three RGBA32F texels per pixel.
pub mod rec {
    use super::Field;

    /// r0.xyz: origin of the level's ray.
    pub const ORIGIN: Field = Field::new(0, 0, 3, "origin");
    /// r0.w: hit triangle, [`TRI_NONE`](super::TRI_NONE) for a miss or
    /// [`TRI_NO_RAY`](super::TRI_NO_RAY).
    pub const TRI: Field = Field::new(0, 3, 1, "tri");
    /// r1.xyz: direction of the level's ray.
    pub const DIR: Field = Field::new(1, 0, 3, "dir");
    /// r1.w: hit distance.
    pub const T: Field = Field::new(1, 3, 1, "t");
    /// r2.xyz: path weight of the node.
    pub const WEIGHT: Field = Field::new(2, 0, 3, "weight");
    /// r2.w: 1 where the node exists, else 0.
    pub const EXISTS: Field = Field::new(2, 3, 1, "exists");

    /// Every field, texel by texel.
    pub const ALL: [Field; 6] = [ORIGIN, TRI, DIR, T, WEIGHT, EXISTS];
}

/// The material slots: [`MAT_TEXELS`](mat::TEXELS) RGBA32F texels per material in the
/// `mat` scene texture. GLSL fetches texel k with `mat_texel(mat, M<k>_SLOT)`.
pub mod mat {
    use super::Field;

    /// m0.xyz: diffuse albedo.
    pub const ALBEDO: Field = Field::new(0, 0, 3, "albedo");
    /// m0.w: ambient coefficient.
    pub const KA: Field = Field::new(0, 3, 1, "ka");
    /// m1.xyz: specular colour.
    pub const KS: Field = Field::new(1, 0, 3, "ks");
    /// m1.w: Phong exponent.
    pub const NS: Field = Field::new(1, 3, 1, "ns");
    /// m2.xyz: mirror reflectance.
    pub const KR: Field = Field::new(2, 0, 3, "kr");
    /// m2.w: diffuse coefficient.
    pub const KD: Field = Field::new(2, 3, 1, "kd");
    /// m3.xyz: transmittance.
    pub const KT: Field = Field::new(3, 0, 3, "kt");
    /// m3.w: index of refraction.
    pub const IOR: Field = Field::new(3, 3, 1, "ior");
    /// m4.xyz: checker colour a.
    pub const CHECKER_A: Field = Field::new(4, 0, 3, "checker_a");
    /// m4.w: checker scale (0 = no checker).
    pub const CHECKER_SCALE: Field = Field::new(4, 3, 1, "checker_scale");
    /// m5.xyz: checker colour b.
    pub const CHECKER_B: Field = Field::new(5, 0, 3, "checker_b");
    /// m5.w: checker axes code ([`axes_code`](crate::gpu::layout::axes_code)).
    pub const CHECKER_AXES: Field = Field::new(5, 3, 1, "checker_axes");
    /// m6.x: 1 when reflection and refraction use Fresnel weights.
    pub const FRESNEL: Field = Field::new(6, 0, 1, "fresnel");
    /// m6.yz: checker phase ([`Checker::phase`](crate::scene::Checker::phase)).
    pub const CHECKER_PHASE: Field = Field::new(6, 1, 2, "checker_phase");
    /// m6.w: unused, zero.
    pub const PAD: Field = Field::new(6, 3, 1, "pad");

    /// Every field, texel by texel.
    pub const ALL: [Field; 15] = [
        ALBEDO,
        KA,
        KS,
        NS,
        KR,
        KD,
        KT,
        IOR,
        CHECKER_A,
        CHECKER_SCALE,
        CHECKER_B,
        CHECKER_AXES,
        FRESNEL,
        CHECKER_PHASE,
        PAD,
    ];

    /// Texels per material.
    pub const TEXELS: u32 = 7;
}

/// `tri_best`/`tri` of a ray that found no hit.
pub const TRI_NONE: f32 = -1.0;
/// `tri_best`/`tri` where there is no ray at all (the node does not exist).
pub const TRI_NO_RAY: f32 = -2.0;

/// GLSL for one texel group: a swizzle `#define` per field (`<PREFIX><k>_<NAME>`) and a
/// constructor per texel (`<PREFIX><k>_TEXEL(fields...)`).
pub(crate) fn group_glsl(prefix: &str, fields: &[Field], slots: bool) -> String {
    let mut s = String::new();
    let texels = fields.iter().map(|f| f.texel).max().map_or(0, |m| m + 1);
    for k in 0..texels {
        let mine: Vec<&Field> = fields.iter().filter(|f| f.texel == k).collect();
        let comment: Vec<String> = mine
            .iter()
            .map(|f| format!("{}.{}", f.name, f.swizzle()))
            .collect();
        s.push_str(&format!("// {prefix}{k}: {}\n", comment.join(", ")));
        if slots {
            s.push_str(&format!(
                "#define {}{k}_SLOT {k}.0\n",
                prefix.to_ascii_uppercase()
            ));
        }
        for f in &mine {
            s.push_str(&format!(
                "#define {}{k}_{} {}\n",
                prefix.to_ascii_uppercase(),
                f.name.to_ascii_uppercase(),
                f.swizzle()
            ));
        }
        let args: Vec<&str> = mine.iter().map(|f| f.name).collect();
        s.push_str(&format!(
            "#define {}{k}_TEXEL({a}) vec4({a})\n",
            prefix.to_ascii_uppercase(),
            a = args.join(", ")
        ));
    }
    s
}

/// The generated GLSL for the whole contract (field swizzles, texel constructors,
/// sentinels). Sampler uniforms stay declared in the files that read them, whose header
/// comments list them; [`Unit::samplers`] names every one.
pub fn glsl_prelude() -> String {
    let mut s = String::new();
    for st in RayState::ALL {
        s.push_str(&format!("#define {} {:.1}\n", st.macro_name(), st.code()));
    }
    s.push_str(&group_glsl("s", &ray::ALL, false));
    s.push_str(&format!("#define S3_HIT {}\n", ray::HIT.swizzle()));
    s.push_str(&group_glsl("r", &rec::ALL, false));
    s.push_str(&group_glsl("m", &mat::ALL, true));
    s.push_str(&format!("#define TRI_NONE {TRI_NONE:.1}\n"));
    s.push_str(&format!("#define TRI_NO_RAY {TRI_NO_RAY:.1}\n"));
    s
}

/// The four ray-state textures of a wave read back to the host (RGBA, bottom row first).
pub struct StateTexels {
    /// s0..s3 (only those read; the others are empty).
    pub texels: [Vec<f32>; 4],
}

impl StateTexels {
    /// Scalar field `f` of ray `k`.
    pub fn get(&self, k: usize, f: Field) -> f32 {
        debug_assert_eq!(f.len, 1, "{} is not a scalar", f.name);
        self.texels[f.texel][f.at(k)]
    }

    /// Writes field `f` of ray `k` (as many components as `v` holds, which must be `f.len`).
    pub fn set(&mut self, k: usize, f: Field, v: &[f32]) {
        assert_eq!(v.len(), f.len, "{}", f.name);
        let at = f.at(k);
        self.texels[f.texel][at..at + f.len].copy_from_slice(v);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_are_distinct_and_fields_tile_the_texels() {
        let mut seen: Vec<u32> = Unit::ALL.iter().map(|u| u.index()).collect();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), Unit::ALL.len());
        for group in [&ray::ALL[..], &rec::ALL[..], &mat::ALL[..]] {
            let texels = group.iter().map(|f| f.texel).max().unwrap() + 1;
            for k in 0..texels {
                let n: usize = group.iter().filter(|f| f.texel == k).map(|f| f.len).sum();
                assert_eq!(n, 4, "texel {k} not exactly covered");
            }
        }
        let g = glsl_prelude();
        assert!(g.contains("#define S3_T_BEST x\n"), "{g}");
        assert!(g.contains("#define S3_TEXEL(t_best, tri_best, cursor_end, steps) vec4(t_best, tri_best, cursor_end, steps)\n"), "{g}");
        assert!(g.contains("#define R0_TRI w\n"), "{g}");
        assert!(g.contains("#define M6_SLOT 6.0\n"), "{g}");
        assert_eq!(
            mat::ALL.iter().map(|f| f.texel).max(),
            Some(mat::TEXELS as usize - 1)
        );
    }
}
