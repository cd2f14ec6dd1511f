//! Tests of the irregular grid's own table functions (`accel/irregular.rs`): the summary
//! line of its statistics. The build's tests are in `irregular_tests.rs`, the traversal's
//! in `cpu/traverse_irregular_tests.rs`.

use super::*;

/// The statistics line, every figure in its place and rounding, worked out by hand; a grid
/// without cells says 0% empty rather than NaN.
#[test]
fn stats_line_reports_every_figure() {
    let mut s = IrregularStats {
        build_ms: 12.34,
        expand_ms: 3.46,
        phases: IrregularPhases {
            setup_ms: 0.01,
            convert_ms: 0.12,
            top_bin_ms: 1.26,
            sort_ms: 0.34,
            voxel_map_ms: 5.56,
            flatten_ms: 0.66,
            occupancy_ms: 0.26,
            grow_ms: 3.21,
            finish_ms: 0.94,
        },
        bytes: 3 << 19,
        bytes_per_triangle: 96.04,
        top_cells: 100,
        vmap_entries: 180,
        levels: 3,
        cells: 400,
        empty_cells: 100,
        references: 1200,
        mean_per_nonempty: 4.0,
        max_per_cell: 9,
        mean_growth: 6.44,
    };
    assert_eq!(
        s.to_string(),
        "100 top cells, 3 levels, 400 cells (25.0% empty, exit boxes 6.4x own), 1200 refs \
         (mean 4.00, max 9 per non-empty cell), 1.50 MiB (96.0 B/triangle), built in 12.3 ms \
         (3.5 ms growing exit boxes; phases ms: setup 0.0, convert 0.1, top bins 1.3, sort 0.3, \
         voxel map 5.6, flatten 0.7, occupancy 0.3, growth 3.2, finish 0.9)"
    );
    s.cells = 0;
    s.empty_cells = 0;
    assert!(s.to_string().contains(" 0 cells (0.0% empty,"), "{s}");
}

/// `world_box` maps virtual corners to world ones by `min + k * cell_size` in f64: values
/// chosen so every product and sum is exact, worked out by hand.
#[test]
fn world_box_is_min_plus_corner_times_cell_size() {
    let mut scene = crate::scene::Scene::empty(crate::scene::Camera {
        eye: Vec3::Z,
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
    });
    let m = scene.add_material(crate::scene::Material::default());
    scene.add_triangle(Vec3::ZERO, Vec3::X, Vec3::Y, m);
    let mut g = IrregularGrid::build(&scene, &IrregularConfig::default()).unwrap();
    g.min = Vec3::new(-1.0, 0.0, 2.0);
    g.cell_size = Vec3::new(0.5, 0.25, 2.0);
    let (lo, hi) = g.world_box([1, 2, 3], [4, 5, 6]);
    assert_eq!(lo, DVec3::new(-0.5, 0.5, 8.0));
    assert_eq!(hi, DVec3::new(1.0, 1.25, 14.0));
}
