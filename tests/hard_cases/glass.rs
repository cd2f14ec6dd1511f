//! Glass cases: total internal reflection in a prism (18) and the camera inside a glass
//! sphere (19), rendered on the three backends.

use crate::support::*;
use fragtrace::gpu::with_test_context;
use fragtrace::render::{render_cpu, Precision};
use fragtrace::scene::Scene;
use glam::{DVec3, Vec3};

/// Case 18's scene: a 45-degree glass prism (cross-section (x, z): (-1, 1), (1, 1),
/// (1, -1), extruded over y in [-1.5, 1.5]) before a red wall at x = 5, seen along -z.
fn prism_scene(fresnel: bool) -> Scene {
    let mut s = Scene::empty(camera(Vec3::new(0.0, 0.0, 16.0), Vec3::ZERO, 14.0));
    s.background = Vec3::new(0.1, 0.3, 0.8);
    s.ambient = Vec3::splat(0.2);
    s.max_depth = 5;
    let glass = s.add_material(glass(1.5, fresnel));
    let red = s.add_material(diffuse(Vec3::new(1.0, 0.1, 0.1)));
    let (y0, y1) = (-1.5, 1.5);
    let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let inside = v(0.4, 0.0, 0.4);
    let faces = [
        // front z = 1 (triangles 0 and 1)
        [(-1.0, 1.0), (1.0, 1.0)],
        // side x = 1
        [(1.0, 1.0), (1.0, -1.0)],
        // hypotenuse
        [(-1.0, 1.0), (1.0, -1.0)],
    ];
    for [(xa, za), (xb, zb)] in faces {
        let q = [v(xa, y0, za), v(xb, y0, zb), v(xb, y1, zb), v(xa, y1, za)];
        add_quad_outward(&mut s, q, inside, glass);
    }
    for y in [y0, y1] {
        let (a, b, c) = (v(-1.0, y, 1.0), v(1.0, y, 1.0), v(1.0, y, -1.0));
        let n = (b - a).cross(c - a);
        if n.dot(Vec3::new(0.0, y, 0.0)) > 0.0 {
            s.add_triangle(a, b, c, glass);
        } else {
            s.add_triangle(a, c, b, glass);
        }
    }
    add_quad(
        &mut s,
        [
            v(5.0, -4.0, -4.0),
            v(5.0, 4.0, -4.0),
            v(5.0, 4.0, 4.0),
            v(5.0, -4.0, 4.0),
        ],
        red,
    );
    s.lights.push(light(Vec3::new(2.5, 0.5, 1.0), 0.8));
    s
}

/// A 45-degree glass prism (ior 1.5, kt = 1): camera rays enter its front face, meet the
/// hypotenuse at about 45 degrees (beyond the 41.8-degree critical angle), are totally
/// reflected towards +x, leave through the side face and see a red wall. Every pixel whose
/// primary ray enters the prism's front face away from its rim must be red (no NaN, never
/// black) on every backend; a Fresnel variant must be finite and never black there.
#[test]
fn case_18_total_internal_reflection() {
    let plain = prism_scene(false);
    let fres = prism_scene(true);
    let (r_plain, r_fres) =
        with_test_context(|ctx| (render_all(ctx, &plain), render_all(ctx, &fres)));
    // Pixels whose f64 primary ray hits the front face (triangles 0, 1) away from the rim.
    let cam = &plain.camera;
    let eye = cam.eye.as_dvec3();
    let mut selected = Vec::new();
    for j in 0..H {
        for i in 0..W {
            let k = (j * W + i) as usize;
            let pid = r_plain[F64].aov.pixels[k].primid;
            let d = cam.pixel_direction(W, H, i, j);
            let p = eye + d * ((1.0 - eye.z) / d.z);
            if (pid == 0.0 || pid == 1.0) && p.x > -0.8 && p.x < 0.8 && p.y.abs() < 1.0 {
                selected.push(k);
            }
        }
    }
    assert!(selected.len() > 150, "only {} prism pixels", selected.len());
    let mut checks = Checks::new();
    for (variant, renders) in [("kt=1", &r_plain), ("fresnel", &r_fres)] {
        for (b, r) in BACKENDS.iter().zip(renders.iter()) {
            let finite = r.image.all_finite();
            let px: Vec<[f32; 3]> = pixels(&r.image).collect();
            let black = selected
                .iter()
                .filter(|&&k| px[k].iter().cloned().fold(0.0, f32::max) < 0.02)
                .count();
            let red = selected
                .iter()
                .filter(|&&k| px[k][0] > 0.3 && px[k][0] > 3.0 * px[k][2])
                .count();
            let vs64 = rmse(&r.image, &renders[F64].image);
            let line = format!(
                "{variant}: {} prism pixels: {black} black, {red} red (via TIR), all finite: {finite}, RMSE vs f64 {vs64:.2e}",
                selected.len(),
            );
            let red_needed = if variant == "kt=1" { selected.len() } else { 0 };
            let ok = finite && black == 0 && red >= red_needed && vs64 <= 0.02;
            if !ok {
                dump(&format!("case18-{variant}-{b}"), &r.image);
            }
            checks.line("case 18", b, ok, line);
        }
    }
    checks.done();
}

/// Case 19's room: a floor, a green box and a light; with `sphere`, a smooth glass
/// icosphere(4) of radius 1 around the camera (its triangle range is returned).
fn room_with_glass_sphere(sphere: bool) -> (Scene, std::ops::Range<u32>) {
    let mut s = Scene::empty(camera(Vec3::ZERO, Vec3::new(0.0, -0.3, -1.0), 60.0));
    s.background = Vec3::new(0.3, 0.4, 0.6);
    s.ambient = Vec3::splat(0.15);
    s.max_depth = 3;
    let floor = s.add_material(diffuse(Vec3::new(0.8, 0.8, 0.7)));
    let boxm = s.add_material(diffuse(Vec3::new(0.2, 0.7, 0.3)));
    let glass = s.add_material(glass(1.5, false));
    add_ground(&mut s, -3.0, 20.0, DVec3::ZERO, floor);
    add_box(
        &mut s,
        Vec3::new(3.0, 2.0, 2.0),
        boxm,
        1.0,
        DVec3::new(-1.0, -2.0, -8.0),
    );
    s.lights.push(light(Vec3::new(0.0, 10.0, -7.0), 0.9));
    let range = if sphere {
        add_sphere(&mut s, 4, true, glass, 1.0, DVec3::ZERO)
    } else {
        0..0
    };
    (s, range)
}

/// The camera sits at the centre of a smooth glass icosphere (ior 1.5, kt = 1) in a room
/// with a floor, a box and a light. Every primary ray must hit the sphere from inside;
/// since they meet it almost normally, the image must match the same scene without the
/// sphere (RMSE < 0.03, CPU f64), GL must match the f32 CPU, and every pixel be finite.
#[test]
fn case_19_camera_inside_refractive_mesh() {
    let (inside, range) = room_with_glass_sphere(true);
    let (open, _) = room_with_glass_sphere(false);
    let (renders, open64) = with_test_context(|ctx| {
        (
            render_all(ctx, &inside),
            render_cpu(&open, &opts(&open, Precision::F64)).unwrap(),
        )
    });
    let mut checks = Checks::new();
    for (b, r) in BACKENDS.iter().zip(renders.iter()) {
        let finite = r.image.all_finite();
        let on_sphere = r
            .aov
            .pixels
            .iter()
            .filter(|p| p.primid >= range.start as f32 && p.primid < range.end as f32)
            .count();
        let vs_open = rmse(&r.image, &open64.image);
        let vs32 = rmse(&r.image, &renders[1].image);
        let line = format!(
            "{on_sphere} of {} primary rays hit the sphere from inside, finite: {finite}, RMSE vs the open scene {vs_open:.2e}, vs CPU f32 {vs32:.2e}",
            W * H,
        );
        let ok = finite && on_sphere == (W * H) as usize && vs_open <= 0.03 && vs32 <= 0.02;
        if !ok {
            dump(&format!("case19-{b}"), &r.image);
        }
        checks.line("case 19", b, ok, line);
    }
    checks.done();
}
