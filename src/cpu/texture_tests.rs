//! Tests of the texture lookups and ray cones against closed forms.

use super::*;
use crate::scene::texture::TexLevel;

fn ramp(w: u32, h: u32, wrap: [Wrap; 2]) -> Texture {
    // Texel (i, j) = (i, j, 0): a lookup's answer names the texels it mixed.
    let texels = (0..h)
        .flat_map(|j| (0..w).map(move |i| [i as f32, j as f32, 0.0]))
        .collect();
    Texture::from_linear(
        "ramp".into(),
        wrap,
        TexLevel {
            width: w,
            height: h,
            texels,
        },
    )
}

#[test]
fn wrap_modes_fold_indices_as_defined() {
    let n = 4.0f32;
    let got = |m| {
        (-6..10)
            .map(|i| wrap_index(i as f32, n, m) as i32)
            .collect::<Vec<_>>()
    };
    assert_eq!(
        got(Wrap::Repeat),
        [2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1]
    );
    assert_eq!(
        got(Wrap::Clamp),
        [0, 0, 0, 0, 0, 0, 0, 1, 2, 3, 3, 3, 3, 3, 3, 3]
    );
    // Mirrored: 0 1 2 3 3 2 1 0, repeating; index -1 mirrors onto 0.
    assert_eq!(
        got(Wrap::Mirror),
        [2, 3, 3, 2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0, 0, 1]
    );
}

#[test]
fn bilinear_hits_texel_centres_exactly_and_mixes_between() {
    let t = ramp(8, 4, [Wrap::Repeat, Wrap::Clamp]);
    for j in 0..4 {
        for i in 0..8 {
            let (u, v) = ((i as f64 + 0.5) / 8.0, (j as f64 + 0.5) / 4.0);
            let c = bilinear::<f64>(&t, 0, u, v);
            assert_eq!((c.x, c.y), (i as f64, j as f64));
        }
    }
    // A quarter texel right of texel 2's centre: 2.25. Half-way between the last column
    // and the first (repeat along u): 7 + (0 - 7)/2.
    let c = bilinear::<f64>(&t, 0, 2.75 / 8.0, 0.5 / 4.0);
    assert_eq!(c.x, 2.25);
    let c = bilinear::<f64>(&t, 0, 1.0, 0.5 / 4.0);
    assert_eq!(c.x, 3.5);
    // Above the top row, clamped along v: row 3.
    assert_eq!(bilinear::<f64>(&t, 0, 0.5 / 8.0, 1.7).y, 3.0);
}

#[test]
fn level_of_detail_rounds_to_the_nearest_level_and_clamps() {
    assert_eq!(level_of(-3.0f32, 5), 0);
    assert_eq!(level_of(0.49f32, 5), 0);
    assert_eq!(level_of(0.5f32, 5), 1);
    assert_eq!(level_of(2.2f32, 5), 2);
    assert_eq!(level_of(40.0f32, 5), 4);
    // A cone twice as wide is one level up; seen at 60 degrees (cos 1/2), one more.
    let l1 = lod(0.0f64, 0.25, 1.0);
    assert_eq!(lod(0.0f64, 0.5, 1.0) - l1, 1.0);
    assert_eq!(lod(0.0f64, 0.5, -0.5) - l1, 2.0);
}

/// A mirror sphere of radius r doubles the normal's turn across the footprint: a cone of
/// width w leaves with its spread grown by 2w/r; a glass surface of index 1.5 entered
/// head-on bends a parallel beam (spread 0) towards its focus by (1/1.5 - 1) w/r.
#[test]
fn child_cones_follow_the_paraxial_mirror_and_lens() {
    let (w, r) = (0.01f64, 2.0);
    let c = child_cone(w, 0.001, 1.0 / r, None);
    assert_eq!(c.width, w);
    assert!((c.spread - (0.001 + 2.0 * w / r)).abs() < 1e-15);
    let g = child_cone(w, 0.0, 1.0 / r, Some(1.0 / 1.5));
    assert!((g.spread - (1.0 / 1.5 - 1.0) * w / r).abs() < 1e-15);
    assert!(g.spread < 0.0, "a convex glass surface focuses");
    // A flat mirror keeps the spread.
    assert_eq!(child_cone(w, 0.003, 0.0, None).spread, 0.003);
}

#[test]
fn a_pixel_spread_is_the_angle_of_one_pixel_at_the_centre() {
    // 90 degrees over 2 pixels: each pixel spans atan(1) at the image centre.
    assert!((pixel_spread(90.0, 2) - std::f64::consts::FRAC_PI_4).abs() < 1e-15);
    let s = pixel_spread(45.0, 480);
    // atan(x) = x - x^3/3 + ...: within x^3/3 of the small-angle value.
    let x = 2.0 * (22.5f64.to_radians()).tan() / 480.0;
    assert!((s - x).abs() < x * x * x / 3.0 * 1.01 && s < x);
}
