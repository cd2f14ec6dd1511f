//! `unit_f32` (`glsl120/camera.glsl`: the compute kernel's primary directions) on the driver
//! against its CPU twin, glam's f64 `normalize` rounded to f32 (as `Frame::direction_at`
//! computes every backend's primary directions), bit for bit, on vectors whose normalised
//! component sits at the midpoint between two f32 values: where a reciprocal square root
//! that errs by even an f64 ulp rounds to the other f32 unless the exact fallback catches it.

use crate::gpu::context::with_test_context;
use crate::gpu::gl::{compile_compute, dispatch, StorageBuffer};
use crate::gpu::shader::sources;
use crate::testing::{test_seed, Rng};
use glam::DVec3;

/// `n` vectors, one component of each (axis and sign in turn) the midpoint between an f32
/// in (0.05, 0.95) and its upper neighbour (every seventh: between a power of two from 1/2
/// to 1/16 and its lower neighbour), the others sharing the rest of a unit length,
/// scaled by 1, 1/2, 4, 3 or 1/3 (the last two move the normalised value off the midpoint
/// by an f64 rounding or two, to either side).
fn cases(rng: &mut Rng, n: usize) -> Vec<DVec3> {
    (0..n)
        .map(|i| {
            let f = rng.range(0.05, 0.95) as f32;
            let m = if i % 7 == 6 {
                // Below a power of two, where the f32 spacing halves.
                let p = 0.5f32.powi(1 + (i / 7 % 4) as i32);
                0.5 * (p as f64 + f32::from_bits(p.to_bits() - 1) as f64)
            } else {
                0.5 * (f as f64 + f32::from_bits(f.to_bits() + 1) as f64)
            };
            let m = if i % 2 == 0 { m } else { -m };
            let rest = (1.0 - m * m).sqrt();
            let phi = rng.range(0.0, std::f64::consts::TAU);
            let mut v = [0.0; 3];
            let axis = (i / 2) % 3;
            v[axis] = m;
            v[(axis + 1) % 3] = rest * phi.cos();
            v[(axis + 2) % 3] = rest * phi.sin();
            DVec3::from(v) * [1.0, 0.5, 4.0, 3.0, 1.0 / 3.0][(i / 6) % 5]
        })
        .collect()
}

/// `unit_f32` of each vector on the driver, with `defines`; None without compute shaders.
fn on_driver(vs: &[DVec3], defines: &[&str]) -> Option<Vec<f32>> {
    let camera = sources()
        .iter()
        .find(|(n, _)| *n == "camera.glsl")
        .map(|(_, s)| *s)
        .unwrap();
    let defines: String = defines.iter().map(|d| format!("#define {d}\n")).collect();
    let src = format!(
        "#version 430\n{defines}{camera}\nlayout(local_size_x = 64) in;\n\
         layout(std430, binding = 0) readonly buffer In {{ double v[]; }};\n\
         layout(std430, binding = 1) writeonly buffer Out {{ float r[]; }};\n\
         void main() {{\n\
         \x20   uint i = gl_GlobalInvocationID.x;\n\
         \x20   if (i >= {n}u) return;\n\
         \x20   precise dvec3 a = dvec3(v[3u * i], v[3u * i + 1u], v[3u * i + 2u]);\n\
         \x20   precise double len2 = a.x * a.x + a.y * a.y + a.z * a.z;\n\
         \x20   vec3 d = unit_f32(a, len2);\n\
         \x20   r[3u * i] = d.x;\n\
         \x20   r[3u * i + 1u] = d.y;\n\
         \x20   r[3u * i + 2u] = d.z;\n\
         }}\n",
        n = vs.len()
    );
    with_test_context(|ctx| {
        if !ctx.info.compute {
            println!("skipped: no compute shaders on this context");
            return None;
        }
        let p = compile_compute(ctx, "unit_f32", &src, &|n| ("test".into(), n)).unwrap();
        let bytes: Vec<u8> = vs
            .iter()
            .flat_map(|v| v.to_array())
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let input = StorageBuffer::new(ctx, &bytes).unwrap();
        let out = StorageBuffer::zeroed_u32(ctx, 3 * vs.len()).unwrap();
        input.bind(ctx.gl(), 0);
        out.bind(ctx.gl(), 1);
        dispatch(ctx.gl(), &p, [vs.len().div_ceil(64) as u32, 1, 1]);
        let words = out.read_u32(ctx.gl()).unwrap();
        Some(words.into_iter().map(f32::from_bits).collect())
    })
}

/// How many components of `got` differ from the CPU twin's bits.
fn mismatches(vs: &[DVec3], got: &[f32]) -> usize {
    vs.iter()
        .zip(got.chunks(3))
        .flat_map(|(v, g)| {
            let want = v.normalize().as_vec3().to_array();
            (0..3).map(move |k| (want[k].to_bits() != g[k].to_bits()) as usize)
        })
        .sum()
}

/// The driver's `unit_f32` equals the CPU twin bit for bit, as it is and with its fast
/// reciprocal made wrong by 2^-40 either way (within the bound its check allows for, as a
/// driver's `inversesqrt` may err); the same wrong reciprocal trusted without the check
/// gives other bits, so the vectors do sit where the check is needed.
#[test]
fn unit_f32_on_the_driver_rounds_as_the_cpu_twin() {
    let seed = test_seed("unit_f32_on_the_driver_rounds_as_the_cpu_twin", 65);
    let vs = cases(&mut Rng::new(seed), 6000);
    // 1 + 2^-40 and 1 - 2^-40, exactly.
    let up = "UNIT_DIR_SCALE 1.0000000000009094947017729282379150390625LF";
    let down = "UNIT_DIR_SCALE 0.9999999999990905052982270717620849609375LF";
    let Some(plain) = on_driver(&vs, &[]) else {
        return;
    };
    assert_eq!(mismatches(&vs, &plain), 0, "as it is");
    for scale in [up, down] {
        let got = on_driver(&vs, &[scale]).unwrap();
        assert_eq!(mismatches(&vs, &got), 0, "{scale}");
    }
    let unchecked = on_driver(&vs, &[up, "UNIT_DIR_UNCHECKED"]).unwrap();
    let wrong = mismatches(&vs, &unchecked);
    println!(
        "unit_f32: {} vectors; the unchecked wrong reciprocal: {wrong} components off",
        vs.len()
    );
    assert!(
        wrong > 0,
        "no vector needed the check: the cases are not sharp"
    );
}
