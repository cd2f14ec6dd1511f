//! Tests of `gpu/layout/mod.rs` (moved out of it: the file passed 800 lines).

use super::*;

/// Emulates the GLSL fetch arithmetic in f32 and checks it lands on the packed texel.
#[test]
fn fetch_arithmetic_is_exact_up_to_2_pow_24() {
    let t = PackedTexture::pack("x", vec![[0.0; 4]; 5000], 2048).unwrap();
    assert_eq!((t.width, t.height), (2048, 3));
    for w in [1u32, 2, 64, 2048, 4096] {
        let inv_w = 1.0 / w as f32;
        for i in [0u32, 1, w - 1, w, w + 1, 12345, (1 << 24) - 1] {
            let fi = i as f32;
            let y = (fi * inv_w).floor();
            let x = fi - y * w as f32;
            assert_eq!((x as u32, y as u32), (i % w, i / w), "w {w} i {i}");
        }
    }
}

/// Entry textures hold their scalars in order, four to a texel with the last padded, and
/// only they get `entry_<name>`: the cell list and the voxel map of a real build, not the
/// record textures.
#[test]
fn entry_textures_pack_in_order_and_only_they_get_entry_functions() {
    let e: Vec<f32> = (1..=6).map(|i| i as f32).collect();
    let t = PackedTexture::pack_entries("list", &e, 64).unwrap();
    assert!(t.entries);
    assert_eq!((t.width, t.height), (2, 1));
    assert_eq!(t.data, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 0.0, 0.0]);

    use crate::accel::{IrregularConfig, IrregularGrid};
    use crate::testing::scene_of;
    use glam::Vec3;
    let s = scene_of(&[[Vec3::ZERO, Vec3::X, Vec3::Y], [Vec3::Z, Vec3::X, Vec3::Y]]);
    let g = IrregularGrid::build(&s, &IrregularConfig::default()).unwrap();
    let l = SceneTextures::pack(&s, &g, 4096).unwrap();
    let vmap = &l.irregular().unwrap().vmap;
    let (list, cell) = (l.list().unwrap(), l.cell().unwrap());
    for fetch in [Fetch::Texture2D, Fetch::TexelFetch, Fetch::Storage] {
        for t in [list, vmap] {
            assert!(t.entries, "{}", t.name);
            let glsl = t.glsl_with(fetch, 9);
            assert!(glsl.contains(&format!("entry_{}(", t.name)), "{fetch:?}");
        }
        for t in [&l.tri, &l.mat, cell] {
            assert!(!t.entries, "{}", t.name);
            assert!(!t.glsl_with(fetch, 9).contains("entry_"), "{}", t.name);
        }
    }
    // Every triangle index of the grid's lists, in order.
    let n = g.tri_indices.len();
    let listed: Vec<u32> = list.data[..n].iter().map(|&x| x as u32).collect();
    assert_eq!(listed, g.tri_indices);
}

/// A real irregular grid (a 5,120-triangle icosphere) whose cell texture, in the split
/// format (3 texels a cell), passes a limit its triangle texture fits: refused by the
/// size check before the cell texture is allocated, naming `cell`, the limit and both
/// options that exist; at the next size up it packs.
#[test]
fn irregular_cells_beyond_the_limit_are_refused_before_packing() {
    use crate::accel::{IrregularConfig, IrregularGrid};
    let (p, _, t) = crate::scene::shapes::sphere(4);
    let tris: Vec<_> = t.iter().map(|f| f.map(|i| p[i as usize])).collect();
    let s = crate::testing::scene_of(&tris);
    let g = IrregularGrid::build(&s, &IrregularConfig::default()).unwrap();
    let cells = irregular_cell_texels(g.cells.len() as u64, IndexFormat::Split);
    let tri = s.triangles.len() as u64 * TRI_TEXELS as u64;
    // The smallest square power-of-two limit the triangles fit.
    let max = (1u32..)
        .map(|b| 1 << b)
        .find(|&m| m as u64 * m as u64 >= tri)
        .unwrap();
    println!("{tri} triangle texels, {cells} cell texels (split), limit {max}");
    assert!(
        cells > max as u64 * max as u64,
        "{cells} cell texels fit {max}"
    );
    let e = SceneTextures::pack_format(&s, &g, max, false, IndexFormat::Split).unwrap_err();
    let text = e.to_string();
    assert!(
        matches!(e, Error::Limit(_)) && !text.contains('\n'),
        "{text}"
    );
    for want in [
        format!("texture `cell` needs {cells} texels"),
        format!("GL_MAX_TEXTURE_SIZE is {max}"),
        "--accel uniform, or --backend cpu".into(),
    ] {
        assert!(text.contains(&want), "{text}");
    }
    assert!(SceneTextures::pack_format(&s, &g, 2 * max, false, IndexFormat::Split).is_ok());
}

#[test]
fn too_large_is_a_clear_error() {
    let e = PackedTexture::pack("big", vec![[0.0; 4]; 64 * 64 + 1], 64).unwrap_err();
    assert!(e.to_string().contains("GL_MAX_TEXTURE_SIZE is 64"), "{e}");
    let ok = PackedTexture::pack("fit", vec![[0.0; 4]; 64 * 64], 64).unwrap();
    assert_eq!((ok.width, ok.height), (64, 64));
}
