//! The split index format (`glsl120/split_index.glsl`, `SPLIT_INDEX`) on the driver against
//! its CPU twins (`layout::rec_coord`, `layout::split_coord`) and against u64 arithmetic, for
//! a synthetic stream of indices around 2^24 and far past it, and the generated
//! `entry_list_split` reading a real list of more than 2^24 entries.

use super::harness::*;
use crate::common::with_test_context;
use fragtrace::gpu::layout::{
    rec_coord, split, split_coord, IndexFormat, PackedTexture, SceneTextures, SPLIT_BASE,
};
use fragtrace::technique::Techniques;

/// A one-triangle scene packed in the split format (its shaders get `split_index.glsl`).
fn split_layout(max_size: u32) -> SceneTextures {
    let (s, g) = one_triangle();
    let l = SceneTextures::pack_format(&s, &g, max_size, false, IndexFormat::Split).unwrap();
    assert_eq!(l.format, IndexFormat::Split);
    l
}

/// The indices tested: around 2^24 (where one float stops counting), 2^31, 2^32 and beyond,
/// each split as the layout splits it and again with part of it moved into the cursor j.
fn stream() -> Vec<u64> {
    let mut v = Vec::new();
    for base in [0u64, 1 << 14, 1 << 24, 1 << 31, 1 << 32, (1 << 36) + 12345] {
        for d in [0u64, 1, 2, 3, 4, 16383, 16384, 16385] {
            v.push(base + d);
            if base >= 5 {
                v.push(base - 1 - d.min(4));
            }
        }
    }
    v
}

/// Reads `q = (hi, lo, j, w)` per fragment and writes `split_coord` and, from (item = lo,
/// per = hi + 1, k = j), `rec_coord`.
const COORDS: &str = "uniform sampler2D u_in;\n\
void main() {\n\
    vec4 q = texture2D(u_in, v_uv);\n\
    gl_FragData[0] = vec4(split_coord(q.x, q.y, q.z, q.w, 1.0 / q.w), 0.0);\n\
    gl_FragData[1] = vec4(rec_coord(q.y, q.x + 1.0, q.z, q.w, 1.0 / q.w), 0.0, 0.0);\n\
}\n";

/// `split_coord` and `rec_coord` on the driver give their CPU twins' answers bit for bit,
/// and those are the u64 truth (entry e = hi 2^24 + lo + j at texel e / 4 of rows w wide;
/// texel per item + k of records of per texels), for the stream at row widths 1 to 4096.
#[test]
fn split_coordinates_match_the_cpu_twins_and_the_u64_truth() {
    let mut cases = Vec::new();
    let mut truth = Vec::new();
    for &e in &stream() {
        for w in [1u32, 64, 4096] {
            for j in [0u64, 1, 7, 1000] {
                if j > e {
                    continue;
                }
                let (hi, lo) = split(e - j);
                // The layout's rows stay below GL_MAX_TEXTURE_SIZE; the arithmetic is exact
                // while the row is an exact float.
                let row = e / (4 * w as u64);
                if row >= 1 << 24 {
                    continue;
                }
                cases.push([hi, lo, j as f32, w as f32]);
                truth.push((e, w, j));
            }
        }
    }
    let layout = split_layout(4096);
    let out = with_test_context(|ctx| {
        run_program(
            ctx,
            COORDS,
            &[],
            &layout,
            Techniques::default(),
            &[("u_in", &cases[..])],
            &[],
            &[],
            2,
        )
    });
    let mut checked = 0;
    for (k, (q, &(e, w, j))) in cases.iter().zip(&truth).enumerate() {
        let gpu = out[0][k];
        let cpu = split_coord(q[0], q[1], q[2], q[3]);
        assert_eq!(
            (gpu[0], gpu[1], gpu[2]),
            cpu,
            "split_coord of {e} (j {j}, w {w})"
        );
        let texel = e / 4;
        let want = (
            (texel % w as u64) as f32,
            (texel / w as u64) as f32,
            (e % 4) as f32,
        );
        assert_eq!(cpu, want, "split_coord of {e} (j {j}, w {w}) against u64");
        // rec_coord: record `lo` of hi + 1 texels, texel j (all below 2^24 here).
        let (item, per, kk) = (q[1] as u64, q[0] as u64 + 1, j);
        let t = item * per + kk;
        if per * (item / w as u64 + 1) < 1 << 24 && per * w as u64 + kk < 1 << 24 {
            let gpu = out[1][k];
            let cpu = rec_coord(q[1], q[0] + 1.0, q[2], q[3]);
            assert_eq!(
                (gpu[0], gpu[1]),
                cpu,
                "rec_coord of {item} x {per} + {kk}, w {w}"
            );
            assert_eq!(
                cpu,
                ((t % w as u64) as f32, (t / w as u64) as f32),
                "rec_coord of {item} x {per} + {kk}, w {w} against u64"
            );
            checked += 1;
        }
    }
    println!(
        "split_coord: {} cases bit for bit on the driver, rec_coord: {checked}",
        cases.len()
    );
    assert!(checked > 100 && cases.len() > 300);
}

/// `entry_list_split` (the generated fetch over `split_coord`) reads the entry
/// hi 2^24 + lo + j of a list texture of 2^24 + 2^16 entries (64 MiB, 4096 x 1028 texels), each entry a
/// distinct hash, for offsets and cursors around 2^24: the split path's reads on the driver.
#[test]
fn entry_list_split_reads_past_2_pow_24() {
    let n = (1usize << 24) + (1 << 16);
    let value = |i: u64| ((i.wrapping_mul(2654435761)) % SPLIT_BASE) as f32;
    let entries: Vec<f32> = (0..n as u64).map(value).collect();
    let mut layout = split_layout(16384);
    *layout.float_grid_mut().unwrap().1 =
        PackedTexture::pack_entries("list", &entries, 16384).unwrap();
    assert_eq!(layout.list().unwrap().width, 4096);
    let mut cases = Vec::new();
    let mut want = Vec::new();
    let near = 1u64 << 24;
    for e in (near - 40..near + 40).chain([0, 1, 16383, 16384, n as u64 - 1, n as u64 - 16385]) {
        for j in [0u64, 1, 5, 3000] {
            if j <= e {
                let (hi, lo) = split(e - j);
                cases.push([hi, lo, j as f32, 0.0]);
                want.push(value(e));
            }
        }
    }
    let text = "uniform sampler2D u_in;\n\
        void main() {\n\
            vec4 q = texture2D(u_in, v_uv);\n\
            gl_FragData[0] = vec4(entry_list_split(q.x, q.y, q.z));\n\
        }\n";
    let out = with_test_context(|ctx| {
        run_program(
            ctx,
            text,
            &[],
            &layout,
            Techniques::default(),
            &[("u_in", &cases[..])],
            &[],
            &[],
            1,
        )
    });
    for (k, q) in cases.iter().enumerate() {
        assert_eq!(
            out[0][k][0], want[k],
            "entry hi {} lo {} j {}",
            q[0], q[1], q[2]
        );
    }
    println!("entry_list_split: {} reads around 2^24 exact", cases.len());
}

/// `slot_coord` (a triangle id's float slot to its dense record's texel) on the driver gives
/// its CPU twin's answer bit for bit, and that is the u64 truth, for ids around 2^24, at
/// every slot band's edges up to the last id the GPU carries, and a seeded spread.
#[test]
fn slot_coordinates_match_the_cpu_twin_past_2_pow_24() {
    use fragtrace::gpu::layout::{
        float_slot, slot_coord, slot_record, MAX_EXACT_INDEX, MAX_GPU_TRIANGLES, TRI_SLOT_BANDS,
    };
    let mut ids: Vec<u64> = (0..4).collect();
    for b in 0..=TRI_SLOT_BANDS {
        let edge = MAX_EXACT_INDEX + b * (1 << 23);
        ids.extend(edge - 3..edge + 4);
    }
    let seed = 0x53u64;
    println!("slot ids seed {seed}");
    let mut rng = Rng(seed);
    ids.extend((0..3000).map(|_| ((rng.f() * 0.5 + 0.5) * MAX_GPU_TRIANGLES as f32) as u64));
    ids.retain(|&k| k < MAX_GPU_TRIANGLES);
    let mut cases = Vec::new();
    let mut truth = Vec::new();
    for &k in &ids {
        for (w, j) in [(4096u64, 0u64), (16384, 2), (4096, 1)] {
            let s = float_slot(k) as f32;
            assert_eq!(slot_record(s), k);
            cases.push([s, 3.0, j as f32, w as f32]);
            let t = 3 * k + j;
            truth.push(((t % w) as f32, (t / w) as f32));
        }
    }
    let text = "uniform sampler2D u_in;\n\
        void main() {\n\
            vec4 q = texture2D(u_in, v_uv);\n\
            gl_FragData[0] = vec4(slot_coord(q.x, q.y, q.z, q.w, 1.0 / q.w), 0.0, 0.0);\n\
        }\n";
    let layout = split_layout(4096);
    let out = with_test_context(|ctx| {
        run_program(
            ctx,
            text,
            &[],
            &layout,
            Techniques::default(),
            &[("u_in", &cases[..])],
            &[],
            &[],
            1,
        )
    });
    for (k, q) in cases.iter().enumerate() {
        let cpu = slot_coord(q[0], q[1], q[2], q[3]);
        assert_eq!(
            (out[0][k][0], out[0][k][1]),
            cpu,
            "slot {} texel {} w {}",
            q[0],
            q[2],
            q[3]
        );
        assert_eq!(
            cpu, truth[k],
            "slot {} texel {} w {} against u64",
            q[0], q[2], q[3]
        );
    }
    println!(
        "slot_coord: {} cases bit for bit on the driver",
        cases.len()
    );
}
