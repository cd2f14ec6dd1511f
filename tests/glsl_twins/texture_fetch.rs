//! The generated `texture2D` fetches by linear index (`fetch_<name>(i)`, `entry_<name>(i)`,
//! `fetch_<name>_at`, `gpu/layout.rs`) read the texel they name for every index below 2^24,
//! odd ones past 2^23 included: there `i + 0.5` rounds to the even neighbour, and Mesa's NIR
//! reassociates `(i - row W) + 0.5` into `(i + 0.5) - row W`, which read the next texel for
//! every odd index (the uniform grid's cells past 2^23 and the triangles past 2^23 / 3 on
//! llvmpipe: a 3.9 M-triangle scene lost whole spheres on every fragment kernel). Each fetch
//! runs alone in its program, the context in which the compiler rewrote it.
//!
//! The textures are a few rows of 4096 texels (CI-cheap): an index past the last row reads
//! the last row's texel of its column (`GL_CLAMP_TO_EDGE` on the row coordinate), so the
//! column arithmetic of indices up to 2^24 is checked without 2^24 texels.

use super::harness::*;
use crate::common::with_test_context;
use fragtrace::gpu::layout::{IndexFormat, PackedTexture, SceneTextures};
use fragtrace::technique::Techniques;

/// Texels per row and rows of the test textures.
const W: u64 = 4096;
const ROWS: u64 = 4;

/// Indices around 2^22, 2^23 and up to 2^24, odd and even, and a seeded spread between.
fn indices() -> Vec<u64> {
    let mut v: Vec<u64> = (0..64).collect();
    for base in [1u64 << 22, 1 << 23, (1 << 24) - 64] {
        v.extend(base - 32..base + 32);
    }
    let seed = 53u64;
    println!("texture_fetch seed {seed}");
    let mut rng = Rng(seed);
    v.extend((0..4000).map(|_| ((rng.f() * 0.5 + 0.5) * ((1u64 << 24) - 1) as f32) as u64));
    v.retain(|&i| i < 1 << 24);
    v
}

/// The texel index an index reads in a texture of `ROWS` rows: its own below the last row,
/// else the last row's in its column.
fn read_at(i: u64) -> u64 {
    if i / W < ROWS {
        i
    } else {
        (ROWS - 1) * W + i % W
    }
}

/// Runs `expr` (of the index `q.x`, returning a float) once per index, alone in its program.
fn run(layout: &SceneTextures, expr: &str, idx: &[u64]) -> Vec<f32> {
    let cases: Vec<[f32; 4]> = idx.iter().map(|&i| [i as f32, 0.0, 0.0, 0.0]).collect();
    assert!(idx.iter().all(|&i| i as f32 as u64 == i));
    let text = format!(
        "uniform sampler2D u_in;\n\
         void main() {{\n\
         \x20   vec4 q = texture2D(u_in, v_uv);\n\
         \x20   gl_FragData[0] = vec4({expr});\n\
         }}\n"
    );
    let out = with_test_context(|ctx| {
        run_program(
            ctx,
            &text,
            &[],
            layout,
            Techniques::default(),
            &[("u_in", &cases[..])],
            &[],
            &[],
            1,
        )
    });
    out[0].iter().map(|t| t[0]).collect()
}

/// Checks `got[k]` against `want(idx[k])`, listing the first misses.
fn check(what: &str, idx: &[u64], got: &[f32], want: impl Fn(u64) -> f32) {
    let bad: Vec<_> = idx
        .iter()
        .zip(got)
        .filter(|(&i, &g)| g != want(i))
        .map(|(&i, &g)| format!("{i}: got {g}, want {}", want(i)))
        .collect();
    println!("{what}: {} indices, {} wrong", idx.len(), bad.len());
    assert!(
        bad.is_empty(),
        "{what}: {} wrong: {:?}",
        bad.len(),
        &bad[..bad.len().min(8)]
    );
}

/// `fetch_tri(i)` and `fetch_cell(i)` (records: the fetch the uniform grid's cells and the
/// triangles take) and `fetch_tri_at(i, 1, 0)`, texel i's own value for every i below 2^24.
#[test]
fn record_fetches_read_their_texel_past_2_pow_23() {
    let value = |t: u64| t as f32;
    let texels: Vec<[f32; 4]> = (0..W * ROWS).map(|t| [value(t), 0.0, 0.0, 0.0]).collect();
    let mut layout = dummy_layout();
    assert_eq!(layout.format, IndexFormat::Float);
    layout.tri = PackedTexture::pack("tri", texels.clone(), 16384).unwrap();
    *layout.float_grid_mut().unwrap().0 = PackedTexture::pack("cell", texels, 16384).unwrap();
    assert_eq!(
        (layout.tri.width as u64, layout.tri.height as u64),
        (W, ROWS)
    );
    let idx = indices();
    for expr in [
        "fetch_tri(q.x).x",
        "fetch_cell(q.x).x",
        "fetch_tri_at(q.x, 1.0, 0.0).x",
    ] {
        let got = run(&layout, expr, &idx);
        check(expr, &idx, &got, |i| value(read_at(i)));
    }
}

/// `entry_list(i)`: the i-th float of an entry texture (four to a texel).
#[test]
fn entry_fetches_read_their_entry_past_2_pow_23() {
    let entries: Vec<f32> = (0..W * ROWS * 4).map(|e| e as f32).collect();
    let mut layout = dummy_layout();
    *layout.float_grid_mut().unwrap().1 =
        PackedTexture::pack_entries("list", &entries, 16384).unwrap();
    assert_eq!(layout.list().unwrap().width as u64, W);
    let idx: Vec<u64> = indices().into_iter().filter(|&i| i < 1 << 24).collect();
    let got = run(&layout, "entry_list(q.x)", &idx);
    check("entry_list", &idx, &got, |e| {
        (read_at(e / 4) * 4 + e % 4) as f32
    });
}
