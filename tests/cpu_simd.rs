//! The vectorised f32 CPU path (`--cpu-path simd`, the default in f32) against the scalar
//! f32 path (`--cpu-path scalar`, the GLSL's twin) on every shipped scene and each of the
//! three structures (the grids and the CPU's BVH): the same image bit for bit, the same
//! AOVs (depth, primitive id, normal, steps) and the same rays, cells (the BVH: nodes) and
//! tests. The query-level comparison on random scenes and boundary rays, for each kernel
//! the CPU runs, is in `src/cpu/simd_walk_tests.rs` (the BVH's in
//! `src/cpu/traverse_bvh_tests.rs`); the hard cases compare both paths on every case
//! (`hard_cases/support.rs`). Last, the BVH's f32 render of every shipped scene against the
//! irregular grid's: the same picture up to ties.

mod common;
use common::shipped_scenes;
use fragtrace::accel::AccelKind;
use fragtrace::compare::compare;
use fragtrace::options::{CpuPath, Precision, RenderOptions};
use fragtrace::render::{render_cpu, Rendered};

/// A 160x120 f32 CPU render of `scene` on `accel` by the path `path`.
fn render_f32(scene: &fragtrace::scene::Scene, accel: AccelKind, path: CpuPath) -> Rendered {
    let mut o = RenderOptions::for_scene(scene);
    (o.width, o.height) = (160, 120);
    o.precision = Precision::F32;
    o.accel = accel.into();
    o.cpu_path = path;
    render_cpu(scene, &o).unwrap()
}

/// Every shipped scene on the three structures at 160x120 (the uniform grid only where it
/// is sized for the scene: ground.toml's 400 m floor makes it impractically slow, which is
/// the irregular grid's reason to exist; the BVH, which has no cells, renders it too).
#[test]
fn simd_equals_scalar_on_every_shipped_scene() {
    for (name, scene) in shipped_scenes() {
        for accel in [AccelKind::Irregular, AccelKind::Uniform, AccelKind::Bvh] {
            if accel == AccelKind::Uniform && name == "ground" {
                continue;
            }
            let render = |path| render_f32(&scene, accel, path);
            let (simd, scalar) = (render(CpuPath::Simd), render(CpuPath::Scalar));
            let label = format!("{name} {}", accel.name());
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert!(
                bits(&simd.image.data) == bits(&scalar.image.data),
                "{label}: images differ"
            );
            let px = |a: &fragtrace::output::Aov| {
                a.pixels
                    .iter()
                    .map(|p| {
                        let n = p.normal.map(f32::to_bits);
                        (p.depth.to_bits(), p.primid.to_bits(), n, p.steps.to_bits())
                    })
                    .collect::<Vec<_>>()
            };
            assert!(px(&simd.aov) == px(&scalar.aov), "{label}: AOVs differ");
            assert_eq!(simd.stats.rays, scalar.stats.rays, "{label}: rays");
            assert_eq!(
                simd.stats.cells_visited, scalar.stats.cells_visited,
                "{label}"
            );
            assert_eq!(
                simd.stats.triangle_tests, scalar.stats.triangle_tests,
                "{label}"
            );
            println!(
                "{label:>16}: identical ({}, {} rays)",
                simd.stats.device, simd.stats.rays.total
            );
        }
    }
}

/// The BVH's f32 render (the default, vectorised path) of every shipped scene at 160x120
/// against the irregular grid's. The two may differ only where hits tie (the grid decides
/// ties cell by cell, the BVH pair by pair in its own order, src/cpu/traverse_bvh.rs), so
/// the test measures the pixels with another primary triangle (or another depth or normal)
/// and the image RMSE. Measured: none, on all 12 scenes (the builtin scene and the 11 of
/// scenes/, ground.toml included): 0 of 19,200 pixels with another primary triangle, depth
/// or normal, 0 pixels of another colour, RMSE 0, bit for bit. A multiple of nothing is
/// nothing, so the bound is identity: the picture, primary triangles, depths and normals
/// of the grid, bit for bit (only the `steps` AOV, cells against nodes, differs).
#[test]
fn bvh_renders_as_the_irregular_grid_on_every_shipped_scene() {
    let mut fails = Vec::new();
    for (name, scene) in shipped_scenes() {
        let bvh = render_f32(&scene, AccelKind::Bvh, CpuPath::Simd);
        let grid = render_f32(&scene, AccelKind::Irregular, CpuPath::Simd);
        let aov = |r: &Rendered| {
            r.aov
                .pixels
                .iter()
                .map(|p| {
                    (
                        p.primid.to_bits(),
                        p.depth.to_bits(),
                        p.normal.map(f32::to_bits),
                    )
                })
                .collect::<Vec<_>>()
        };
        let (a, b) = (aov(&bvh), aov(&grid));
        let primid = a.iter().zip(&b).filter(|(x, y)| x.0 != y.0).count();
        let hit = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        let colour = bvh
            .image
            .data
            .chunks(3)
            .zip(grid.image.data.chunks(3))
            .filter(|(x, y)| x.iter().zip(*y).any(|(p, q)| p.to_bits() != q.to_bits()))
            .count();
        let rmse = compare(&bvh.image, &grid.image, 0.05, true).unwrap().rmse;
        println!(
            "{name:>10}: {primid} of {} pixels with another primary triangle, {hit} with another primary hit (triangle, depth or normal), {colour} of another colour, RMSE {rmse:.2e}",
            a.len()
        );
        if primid + hit + colour > 0 || rmse > 0.0 {
            fails.push(format!(
                "{name}: {primid} primary triangles, {hit} primary hits, {colour} colours, RMSE {rmse:.2e}"
            ));
        }
    }
    assert!(
        fails.is_empty(),
        "the BVH's f32 render differs from the irregular grid's: {fails:?}"
    );
}
