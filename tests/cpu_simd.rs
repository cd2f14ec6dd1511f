//! The vectorised f32 CPU path (`--cpu-path simd`, the default in f32) against the scalar
//! f32 path (`--cpu-path scalar`, the GLSL's twin) on every shipped scene: the same image
//! bit for bit, the same AOVs (depth, primitive id, normal, steps) and the same rays,
//! cells and tests. The query-level comparison on random scenes and boundary rays, for each
//! kernel the CPU runs, is in `src/cpu/simd_walk_tests.rs`; the hard cases compare both
//! paths on every case (`hard_cases/support.rs`).

mod common;
use common::shipped_scenes;
use fragtrace::accel::AccelKind;
use fragtrace::options::{CpuPath, Precision, RenderOptions};
use fragtrace::render::render_cpu;

/// Every shipped scene on both structures at 160x120 (the uniform grid only where it is
/// sized for the scene: ground.toml's 400 m floor makes it impractically slow, which is the
/// irregular grid's reason to exist).
#[test]
fn simd_equals_scalar_on_every_shipped_scene() {
    for (name, scene) in shipped_scenes() {
        for accel in [AccelKind::Irregular, AccelKind::Uniform] {
            if accel == AccelKind::Uniform && name == "ground" {
                continue;
            }
            let render = |path| {
                let mut o = RenderOptions::for_scene(&scene);
                (o.width, o.height) = (160, 120);
                o.precision = Precision::F32;
                o.accel = accel;
                o.cpu_path = path;
                render_cpu(&scene, &o).unwrap()
            };
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
