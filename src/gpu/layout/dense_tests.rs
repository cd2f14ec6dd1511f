//! Tests of the compute kernel's integer layout of the irregular grid: what it packs, the
//! refusal past the storage-block size, and its descent on the driver against the CPU's.

use super::*;
use crate::accel::{IrregularConfig, IrregularGrid};
use crate::gpu::layout::{GridTextures, IndexFormat, SceneTextures, STORAGE_BINDING_BASE};
use crate::scene::Scene;

/// Two icospheres apart on a floor-less scene: a voxel map several levels deep with empty
/// space between (the map of `split_index`'s aligned-blocks test).
fn two_spheres() -> (Scene, IrregularGrid) {
    use glam::Vec3;
    let (p, _, t) = crate::scene::shapes::sphere(3);
    let mut tris = Vec::new();
    for (c, r) in [(Vec3::ZERO, 1.0), (Vec3::new(3.0, 0.5, 0.0), 0.5)] {
        tris.extend(t.iter().map(|f| f.map(|i| c + p[i as usize] * r)));
    }
    let s = crate::testing::scene_of(&tris);
    let g = IrregularGrid::build(&s, &IrregularConfig::default()).unwrap();
    (s, g)
}

const BLOCK: u64 = 1 << 27;

/// The dense layout packs no cell, list or voxel-map texture; its buffers hold every cell's
/// exit box, first reference and count and every reference in order, after the textures'
/// storage blocks; the GLSL compiles the dense walk in; the plan counts what is uploaded.
#[test]
fn dense_layout_holds_the_grid_in_integer_buffers() {
    let (s, g) = two_spheres();
    let l = SceneTextures::pack_dense(&s, &g, 4096, false, BLOCK).unwrap();
    let d = l.dense().expect("the dense grid");
    assert!(l.cell().is_none() && l.list().is_none() && l.irregular().is_none());
    assert_eq!(
        l.all().iter().map(|t| t.name).collect::<Vec<_>>(),
        ["tri", "mat"]
    );
    assert_eq!(l.format, IndexFormat::Float);
    let lo = d.buffer_words(&g, DenseBuffer::CellLo);
    let hi = d.buffer_words(&g, DenseBuffer::CellHi);
    assert_eq!(lo.len(), 4 * g.cells.len());
    for (k, c) in g.cells.iter().enumerate() {
        assert_eq!(
            lo[4 * k..4 * k + 4],
            [c.exit_lo[0], c.exit_lo[1], c.exit_lo[2], c.range.offset]
        );
        assert_eq!(
            hi[4 * k..4 * k + 4],
            [c.exit_hi[0], c.exit_hi[1], c.exit_hi[2], c.range.count]
        );
    }
    assert_eq!(&*d.buffer_words(&g, DenseBuffer::Refs), &g.tri_indices[..]);
    assert_eq!(&*d.buffer_words(&g, DenseBuffer::Vmap), &d.map.vmap[..]);
    // Bindings after tri's and mat's blocks; blocks: the two textures and four buffers.
    assert_eq!(
        l.dense_binding(DenseBuffer::CellLo),
        STORAGE_BINDING_BASE + 2
    );
    assert_eq!(l.dense_binding(DenseBuffer::Refs), STORAGE_BINDING_BASE + 5);
    assert_eq!(l.storage_blocks(), 6);
    let glsl = l.glsl_with(super::super::Fetch::TexelFetch);
    for want in [
        "#define DENSE_GRID 1",
        "#define ACCEL_IRREGULAR 1",
        &format!(
            "binding = {}) readonly buffer Buf_dense_refs",
            STORAGE_BINDING_BASE + 5
        ),
        "#define CURSOR_FIRST(offset) 0.0",
        "uint irr_lookup(vec3 k)",
    ] {
        assert!(glsl.contains(want), "{want}");
    }
    assert!(!glsl.contains("fetch_cell") && !glsl.contains("entry_list"));
    let bytes = 32 * g.cells.len() as u64 + 4 * (g.tri_indices.len() + d.map.vmap.len()) as u64;
    assert_eq!(l.dense_bytes(), bytes);
    assert!(matches!(l.grid, GridTextures::Dense(_)));
}

/// A buffer past GL_MAX_SHADER_STORAGE_BLOCK_SIZE is refused before anything is packed, in
/// one line naming the buffer, its bytes, the limit and the options that exist; at the
/// largest buffer's own size it packs.
#[test]
fn buffers_past_the_block_size_are_refused_in_one_line() {
    let (s, g) = two_spheres();
    let cells = 16 * g.cells.len() as u64;
    let largest = cells.max(4 * g.tri_indices.len() as u64);
    let e = SceneTextures::pack_dense(&s, &g, 4096, false, cells - 1).unwrap_err();
    let text = e.to_string();
    assert!(
        matches!(e, crate::Error::Limit(_)) && !text.contains('\n'),
        "{text}"
    );
    for want in [
        format!("`dense_cell_lo` needs {cells} bytes"),
        format!("GL_MAX_SHADER_STORAGE_BLOCK_SIZE is {}", cells - 1),
        "--accel uniform, or --backend cpu".into(),
    ] {
        assert!(text.contains(&want), "{text}");
    }
    // The voxel map may narrow its hops to fit; the cells and references cannot.
    assert!(SceneTextures::pack_dense(&s, &g, 4096, false, largest.max(4 * 4096)).is_ok());
}

/// `irr_lookup` of the dense layout (the generated integer descent) on the driver gives
/// every virtual cell of a map several levels deep the cell the built grid's own lookup
/// gives (`IrregularGrid::lookup`), for hops of one level and of several.
#[test]
fn dense_descent_on_the_driver_is_the_built_grids_lookup() {
    use crate::gpu::context::with_test_context;
    use crate::gpu::gl::{compile_compute, dispatch, StorageBuffer};
    let (_, g) = two_spheres();
    let cells: Vec<[u32; 3]> = (0..g.res[2])
        .flat_map(|z| (0..g.res[1]).flat_map(move |y| (0..g.res[0]).map(move |x| [x, y, z])))
        .collect();
    let want: Vec<u32> = cells.iter().map(|&k| g.lookup(k)).collect();
    for bits in [1, 3] {
        let d = DenseIrregular {
            map: WideMap::build(&g, bits),
            cells: g.cells.len() as u64,
            refs: g.tri_indices.len() as u64,
            ref_base: 0,
            skew_faces: false,
        };
        assert!(d.map.hops.len() > 1, "{:?}", d.map.hops);
        let src = format!(
            "#version 430\n{}\nlayout(local_size_x = 64) in;\n\
             layout(std430, binding = 4) readonly buffer In {{ uint k[]; }};\n\
             layout(std430, binding = 5) writeonly buffer Out {{ uint r[]; }};\n\
             void main() {{\n\
             \x20   uint i = gl_GlobalInvocationID.x;\n\
             \x20   if (i < {n}u) r[i] = irr_lookup(vec3(k[3u * i], k[3u * i + 1u], k[3u * i + 2u]));\n\
             }}\n",
            d.glsl(0),
            n = cells.len()
        );
        let got = with_test_context(|ctx| {
            if !ctx.info.compute {
                println!("skipped: no compute shaders on this context");
                return None;
            }
            let p = compile_compute(ctx, "dense_lookup", &src, &|n| ("test".into(), n)).unwrap();
            let input: Vec<u32> = cells.iter().flatten().copied().collect();
            let bufs: Vec<StorageBuffer> = DenseBuffer::ALL
                .iter()
                .map(|&b| StorageBuffer::from_u32(ctx, &d.buffer_words(&g, b)).unwrap())
                .collect();
            for (k, b) in bufs.iter().enumerate() {
                b.bind(ctx.gl(), k as u32);
            }
            let input = StorageBuffer::from_u32(ctx, &input).unwrap();
            let out = StorageBuffer::zeroed_u32(ctx, cells.len()).unwrap();
            input.bind(ctx.gl(), 4);
            out.bind(ctx.gl(), 5);
            dispatch(ctx.gl(), &p, [cells.len().div_ceil(64) as u32, 1, 1]);
            Some(out.read_u32(ctx.gl()).unwrap())
        });
        let Some(got) = got else { return };
        for ((k, w), g) in cells.iter().zip(&want).zip(&got) {
            assert_eq!(g, w, "virtual cell {k:?}, hops of {bits} splits");
        }
        println!(
            "dense irr_lookup: {} virtual cells, hops {:?}",
            cells.len(),
            d.map.hops
        );
    }
}

/// The compute kernel's layout: the float one where it fits (the faster read; the dense
/// one is then never packed); the dense one where the float one is refused; where
/// neither fits, one line naming both refusals (here textures 64 texels wide and blocks
/// one byte short of the cells).
#[test]
fn compute_takes_the_dense_layout_only_where_the_float_one_does_not_fit() {
    use crate::gpu::layout::LayoutTarget;
    let (s, g) = two_spheres();
    let pack =
        |max, block| SceneTextures::pack_for(&s, &g, max, false, LayoutTarget::Compute, block);
    let l = pack(4096, BLOCK).unwrap();
    assert!(l.dense().is_none() && l.cell().is_some() && l.irregular().is_some());
    let float = || SceneTextures::pack_with(&s, &g, 4096, false);
    let dense = || SceneTextures::pack_dense(&s, &g, 4096, false, BLOCK);
    let refused = || Err(Error::Limit("float refused".into()));
    let unused = || -> Result<SceneTextures> { panic!("the dense layout packed as well") };
    assert!(SceneTextures::compute_irregular(float, unused)
        .unwrap()
        .dense()
        .is_none());
    assert!(SceneTextures::compute_irregular(refused, dense)
        .unwrap()
        .dense()
        .is_some());
    let small = 16 * g.cells.len() as u64 - 1;
    let e = pack(64, small).unwrap_err().to_string();
    assert!(!e.contains('\n'), "{e}");
    for want in [
        "GL_MAX_SHADER_STORAGE_BLOCK_SIZE",
        "the float layout does not fit either",
        "GL_MAX_TEXTURE_SIZE is 64",
    ] {
        assert!(e.contains(want), "{e}");
    }
}
