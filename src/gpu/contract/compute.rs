//! The compute kernel's buffers (`glsl120/render.comp`): the slots of the per-work-group
//! counter records, of the camera buffer, of the light buffer and of the AOV texel, declared
//! once here and generated as the GLSL's `C_*`, `CAM_*`, `LIGHT_*` and `A0_*` constants
//! ([`compute_glsl`]).

/// One count a compute invocation keeps (a slot of its work group's counter record).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Counter {
    /// Primary rays traced.
    Primary,
    /// Shadow rays traced.
    Shadow,
    /// Reflected rays traced.
    Reflected,
    /// Refracted rays traced.
    Refracted,
    /// Grid cells entered (the start cell included), as the CPU's `Work::cells`.
    Cells,
    /// Ray-triangle tests, as the CPU's `Work::tests`.
    Tests,
    /// Rays cut off by the iteration bound (a traversal bug if ever non-zero).
    Unfinished,
    /// Cells visited plus triangle tests of the first sample's primary rays (the sum of
    /// the `steps` AOV, for `--stats` without reading the AOV back).
    PrimarySteps,
    /// Pixels whose radiance is NaN or infinite (a bug if ever non-zero; counted so the
    /// host need not read linear radiance back to check).
    NonFinite,
}

impl Counter {
    /// Every counter, in slot order.
    pub const ALL: [Counter; 9] = [
        Counter::Primary,
        Counter::Shadow,
        Counter::Reflected,
        Counter::Refracted,
        Counter::Cells,
        Counter::Tests,
        Counter::Unfinished,
        Counter::PrimarySteps,
        Counter::NonFinite,
    ];

    /// Its slot in a record.
    pub fn slot(self) -> usize {
        self as usize
    }

    /// The GLSL constant naming the slot.
    pub fn macro_name(self) -> &'static str {
        match self {
            Counter::Primary => "C_PRIMARY",
            Counter::Shadow => "C_SHADOW",
            Counter::Reflected => "C_REFLECTED",
            Counter::Refracted => "C_REFRACTED",
            Counter::Cells => "C_CELLS",
            Counter::Tests => "C_TESTS",
            Counter::Unfinished => "C_UNFINISHED",
            Counter::PrimarySteps => "C_PRIMARY_STEPS",
            Counter::NonFinite => "C_NONFINITE",
        }
    }
}

/// Counters kept. The counter buffer holds each as a 64-bit sum, two `u32`s (low word,
/// high word) per counter: work groups add their totals with `atomicAdd` on the low word
/// and carry into the high word ([`sum_words`]), so one render reads back 16 words.
pub const COUNTERS: usize = Counter::ALL.len();

/// The 64-bit sums of a counter buffer read back as `u32` words (low, high per counter).
pub fn sum_words(words: &[u32]) -> [u64; COUNTERS] {
    let mut total = [0u64; COUNTERS];
    for (t, w) in total.iter_mut().zip(words.chunks_exact(2)) {
        *t = u64::from(w[0]) | u64::from(w[1]) << 32;
    }
    total
}

/// Camera buffer (f64): forward, right, up (3 each), tan(vfov/2), aspect, width, height
/// (of the whole image), the first column and row of the pixels rendered (a region's
/// corner: `--tile`, `--region`), then (ox, oy) per sample.
pub const CAM_F: usize = 0;
/// Right vector.
pub const CAM_R: usize = 3;
/// Up vector.
pub const CAM_U: usize = 6;
/// tan(vfov / 2).
pub const CAM_S: usize = 9;
/// Width / height.
pub const CAM_ASPECT: usize = 10;
/// Image width.
pub const CAM_W: usize = 11;
/// Image height.
pub const CAM_H: usize = 12;
/// First column rendered (0 for the whole image).
pub const CAM_X0: usize = 13;
/// First row rendered, from the top (0 for the whole image).
pub const CAM_Y0: usize = 14;
/// First sample offset.
pub const CAM_OFFSETS: usize = 15;

/// The camera buffer of a `w` x `h` image of which the pixels from column `x0`, row
/// `y0` on are rendered, with sample `offsets` (what `render.comp` reads to compute
/// `Camera::direction_at` of the whole image itself).
pub fn camera_buffer(
    frame: &crate::scene::camera::Frame,
    (w, h): (u32, u32),
    (x0, y0): (u32, u32),
    offsets: &[(f64, f64)],
) -> Vec<f64> {
    let mut v = vec![0f64; CAM_OFFSETS];
    v[CAM_F..CAM_F + 3].copy_from_slice(&frame.f.to_array());
    v[CAM_R..CAM_R + 3].copy_from_slice(&frame.r.to_array());
    v[CAM_U..CAM_U + 3].copy_from_slice(&frame.u.to_array());
    v[CAM_S] = frame.s;
    v[CAM_ASPECT] = w as f64 / h as f64;
    v[CAM_W] = w as f64;
    v[CAM_H] = h as f64;
    v[CAM_X0] = x0 as f64;
    v[CAM_Y0] = y0 as f64;
    for &(ox, oy) in offsets {
        v.push(ox);
        v.push(oy);
    }
    v
}

/// The light buffer: [`LIGHT_TEXELS`] vec4 per light, (position, 0) then (radiance, 0).
pub fn light_buffer(lights: &[crate::scene::Light]) -> Vec<f32> {
    lights
        .iter()
        .flat_map(|l| {
            let (p, r) = (l.position, l.radiance());
            [p.x, p.y, p.z, 0.0, r.x, r.y, r.z, 0.0]
        })
        .collect()
}

/// vec4 texels per light in the light buffer.
pub const LIGHT_TEXELS: usize = 2;

/// The primary-ray AOV texel `render.comp` writes per pixel (first sample), generated as
/// `A0_*` swizzles and the `A0_TEXEL(t_best, tri, steps, state)` constructor.
pub mod aov {
    use super::super::Field;

    /// a0.x: hit distance (t_best of the primary ray).
    pub const T_BEST: Field = Field::new(0, 0, 1, "t_best");
    /// a0.y: hit triangle, or [`TRI_NONE`](super::super::TRI_NONE) for a miss.
    pub const TRI: Field = Field::new(0, 1, 1, "tri");
    /// a0.z: cells visited plus triangle tests.
    pub const STEPS: Field = Field::new(0, 2, 1, "steps");
    /// a0.w: final ray state code.
    pub const STATE: Field = Field::new(0, 3, 1, "state");

    /// Every field.
    pub const ALL: [Field; 4] = [T_BEST, TRI, STEPS, STATE];
}

/// The generated GLSL constants.
pub fn compute_glsl() -> String {
    let mut s = format!("#define COUNTERS {COUNTERS}\n");
    for c in Counter::ALL {
        s.push_str(&format!("#define {} {}\n", c.macro_name(), c.slot()));
    }
    for (name, v) in [
        ("CAM_F", CAM_F),
        ("CAM_R", CAM_R),
        ("CAM_U", CAM_U),
        ("CAM_S", CAM_S),
        ("CAM_ASPECT", CAM_ASPECT),
        ("CAM_W", CAM_W),
        ("CAM_H", CAM_H),
        ("CAM_X0", CAM_X0),
        ("CAM_Y0", CAM_Y0),
        ("CAM_OFFSETS", CAM_OFFSETS),
    ] {
        s.push_str(&format!("#define {name} {v}\n"));
    }
    s.push_str(&format!(
        "#define LIGHT_POS(k) lights[{LIGHT_TEXELS} * (k)].xyz\n\
         #define LIGHT_RAD(k) lights[{LIGHT_TEXELS} * (k) + 1].xyz\n"
    ));
    s.push_str(&super::group_glsl("a", &aov::ALL, false));
    s.push_str(&super::instancing::instancing_glsl());
    s
}
