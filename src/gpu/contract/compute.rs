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

/// Camera buffer (f64): the up vector u, then the primary directions' tables: for each
/// sample, each column of the pixels rendered (from the left) `f + a r` (3 values), then
/// for each sample, each row (from the top) `b`, where `Frame::direction_at` forms the
/// direction as normalize(f + a r + b u) with a from the column and b from the row (the
/// same operations in the same order, so the kernel's directions are its bits). The
/// tables take the kernel's two f64 divisions and most of its f64 products per pixel to
/// the host (one column and one row each).
pub const CAM_U: usize = 0;
/// First value of the column table.
pub const CAM_COLUMNS: usize = 3;

/// The camera buffer of a `w` x `h` image of which the `pw` x `ph` pixels from column `x0`,
/// row `y0` on are rendered, with sample `offsets` (see [`CAM_COLUMNS`]).
pub fn camera_buffer(
    frame: &crate::scene::camera::Frame,
    (w, h): (u32, u32),
    (x0, y0): (u32, u32),
    (pw, ph): (u32, u32),
    offsets: &[(f64, f64)],
) -> Vec<f64> {
    let mut v = Vec::with_capacity(CAM_COLUMNS + offsets.len() * (3 * pw + ph) as usize);
    v.extend(frame.u.to_array());
    for &(ox, _) in offsets {
        for c in 0..pw {
            let (fa, _) = frame.direction_terms(w, h, (x0 + c) as f64 + ox, 0.0);
            v.extend(fa.to_array());
        }
    }
    for &(_, oy) in offsets {
        for r in 0..ph {
            let (_, b) = frame.direction_terms(w, h, 0.0, (y0 + r) as f64 + oy);
            v.push(b);
        }
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
    for (name, v) in [("CAM_U", CAM_U), ("CAM_COLUMNS", CAM_COLUMNS)] {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::camera::{sample_offsets, Camera};
    use crate::testing::{test_seed, Rng};
    use glam::{DVec3, Vec3};

    /// The kernel's direction from the camera buffer (`primary_dir` in `render.comp`: the
    /// column's `f + a r` plus the row's `b` times u, normalised in f64) is
    /// `Frame::direction_at`'s, bit for bit, at every pixel and sample of random cameras,
    /// image sizes and regions (the GPU's rounding to f32 is `camera_tests`').
    #[test]
    fn camera_tables_give_direction_at_bits() {
        let seed = test_seed("camera_tables_give_direction_at_bits", 65);
        let mut rng = Rng::new(seed);
        for _ in 0..20 {
            let cam = Camera {
                eye: rng.dvec3(-5.0, 5.0).as_vec3(),
                look_at: rng.dvec3(-1.0, 1.0).as_vec3(),
                up: Vec3::Y,
                vfov_deg: rng.range(10.0, 120.0) as f32,
            };
            let frame = cam.frame();
            let (w, h) = (rng.range(1.0, 300.0) as u32, rng.range(1.0, 300.0) as u32);
            let (x0, y0) = (
                rng.range(0.0, w as f64) as u32,
                rng.range(0.0, h as f64) as u32,
            );
            let (pw, ph) = (w - x0, h - y0);
            let offsets = sample_offsets([1, 4, 9][rng.range(0.0, 3.0) as usize]);
            let buf = camera_buffer(&frame, (w, h), (x0, y0), (pw, ph), &offsets);
            assert_eq!(
                buf.len(),
                CAM_COLUMNS + offsets.len() * (3 * pw + ph) as usize
            );
            let u = DVec3::from_slice(&buf[CAM_U..CAM_U + 3]);
            let n = offsets.len();
            for (k, &(ox, oy)) in offsets.iter().enumerate() {
                for r in 0..ph as usize {
                    for c in 0..pw as usize {
                        let col = CAM_COLUMNS + 3 * (k * pw as usize + c);
                        let fa = DVec3::from_slice(&buf[col..col + 3]);
                        let b = buf[CAM_COLUMNS + 3 * n * pw as usize + k * ph as usize + r];
                        let got = (fa + b * u).normalize();
                        let want = frame.direction_at(
                            w,
                            h,
                            (x0 as usize + c) as f64 + ox,
                            (y0 as usize + r) as f64 + oy,
                        );
                        assert_eq!(
                            got.to_array().map(f64::to_bits),
                            want.to_array().map(f64::to_bits)
                        );
                    }
                }
            }
        }
    }
}
