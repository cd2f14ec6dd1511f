//! Analytic shapes tessellated into triangles: the icosphere, the quad and the box that scene
//! files can place with `shape = "..."`. Every shape is built in its own object space, centred
//! on the origin, with counter-clockwise winding seen from outside, so that the geometric
//! normal `(b - a) x (c - a)` points outward; renderers and the grid rely on that convention
//! for back-face decisions and for entering/leaving refractive objects.

use std::collections::HashMap;

use glam::{DVec3, Vec3};

/// Largest accepted sphere subdivision level: 20·4⁷ = 327,680 triangles. One more level
/// (1.3M triangles) is far past what a smooth-shaded sphere needs and would only eat memory.
pub const MAX_SPHERE_SUBDIVISIONS: u32 = 7;

/// Number of triangles [`sphere`] produces for `subdivisions`: 20·4ⁿ.
pub fn sphere_triangle_count(subdivisions: u32) -> usize {
    20 * 4usize.pow(subdivisions)
}

/// A unit-radius icosphere centred on the origin: the icosahedron with every triangle split
/// into four `subdivisions` times, new vertices pushed out onto the sphere.
///
/// Returns `(positions, normals, triangles)` where `normals[i] == positions[i]` (the exact
/// smooth normal of the sphere) and each triangle indexes both arrays with the same index.
/// Yields [`sphere_triangle_count`]`(subdivisions)` triangles; `subdivisions` is clamped to
/// [`MAX_SPHERE_SUBDIVISIONS`] (the scene loader rejects larger values with an error first).
pub fn sphere(subdivisions: u32) -> (Vec<Vec3>, Vec<Vec3>, Vec<[u32; 3]>) {
    let subdivisions = subdivisions.min(MAX_SPHERE_SUBDIVISIONS);
    // Work in f64 so that every f32 vertex is the correctly rounded point on the sphere, not
    // the accumulation of several rounded midpoints.
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut verts: Vec<DVec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];

    for _ in 0..subdivisions {
        // Each edge is shared by two triangles; caching its midpoint keeps the mesh welded
        // (no cracks, and shared vertices for smooth shading).
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::with_capacity(tris.len() * 3 / 2);
        let mut midpoint = |a: u32, b: u32, verts: &mut Vec<DVec3>| -> u32 {
            let key = (a.min(b), a.max(b));
            *midpoints.entry(key).or_insert_with(|| {
                verts.push((verts[a as usize] + verts[b as usize]).normalize());
                (verts.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(tris.len() * 4);
        for &[a, b, c] in &tris {
            let ab = midpoint(a, b, &mut verts);
            let bc = midpoint(b, c, &mut verts);
            let ca = midpoint(c, a, &mut verts);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }

    let positions: Vec<Vec3> = verts.iter().map(|v| v.as_vec3()).collect();
    let normals = positions.clone();
    (positions, normals, tris)
}

/// A flat `width` × `depth` rectangle in the XZ plane at y = 0, centred on the origin and
/// facing +Y (two triangles, no vertex normals). A unit quad spans -0.5..0.5 in x and z.
pub fn quad(width: f32, depth: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let (x, z) = (0.5 * width, 0.5 * depth);
    let positions = vec![
        Vec3::new(-x, 0.0, -z),
        Vec3::new(-x, 0.0, z),
        Vec3::new(x, 0.0, z),
        Vec3::new(x, 0.0, -z),
    ];
    (positions, vec![[0, 1, 2], [0, 2, 3]])
}

/// An axis-aligned box of the given edge lengths centred on the origin (12 triangles, outward
/// facing, no vertex normals). `cuboid(Vec3::ONE)` is the unit cube -0.5..0.5. (`box` is a
/// reserved word in Rust, hence the name.)
///
/// Each face has its own four vertices, so that a caller adding per-face data later never
/// has to split shared corners.
pub fn cuboid(size: Vec3) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let h = 0.5 * size;
    let mut positions = Vec::with_capacity(24);
    let mut tris = Vec::with_capacity(12);
    // For each face: its outward axis and two in-plane axes (u, v) with u x v = outward, so
    // that the corners taken in (−u−v, +u−v, +u+v, −u+v) order wind counter-clockwise.
    let faces = [
        (Vec3::X, Vec3::NEG_Z, Vec3::Y),
        (Vec3::NEG_X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::X, Vec3::NEG_Z),
        (Vec3::NEG_Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (Vec3::NEG_Z, Vec3::NEG_X, Vec3::Y),
    ];
    for (n, u, v) in faces {
        let base = positions.len() as u32;
        for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            positions.push((n + su * u + sv * v) * h);
        }
        tris.push([base, base + 1, base + 2]);
        tris.push([base, base + 2, base + 3]);
    }
    (positions, tris)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometric_normal(p: &[Vec3], t: [u32; 3]) -> Vec3 {
        let [a, b, c] = t.map(|i| p[i as usize]);
        (b - a).cross(c - a)
    }

    #[test]
    fn sphere_has_20_times_4_pow_n_triangles_on_the_unit_sphere() {
        for n in 0..=4 {
            let (p, nrm, t) = sphere(n);
            assert_eq!(t.len(), sphere_triangle_count(n));
            assert_eq!(t.len(), 20 * 4usize.pow(n));
            // Euler: a closed genus-0 triangle mesh has V = F/2 + 2 (welded midpoints).
            assert_eq!(p.len(), t.len() / 2 + 2, "level {n} is not welded");
            assert_eq!(p, nrm, "normals must equal positions on a unit sphere");
            for v in &p {
                assert!((v.length() - 1.0).abs() < 1e-6, "{v} off the sphere");
            }
        }
    }

    #[test]
    fn sphere_winds_outward() {
        let (p, _, t) = sphere(3);
        for &tri in &t {
            let g = geometric_normal(&p, tri);
            let centroid = tri.map(|i| p[i as usize]).iter().sum::<Vec3>() / 3.0;
            assert!(g.dot(centroid) > 0.0, "triangle {tri:?} faces inward");
        }
    }

    #[test]
    fn sphere_subdivisions_are_clamped() {
        assert_eq!(
            sphere(MAX_SPHERE_SUBDIVISIONS + 3).2.len(),
            sphere_triangle_count(MAX_SPHERE_SUBDIVISIONS)
        );
    }

    #[test]
    fn quad_faces_up_and_spans_its_size() {
        let (p, t) = quad(2.0, 4.0);
        assert_eq!(t.len(), 2);
        for &tri in &t {
            let g = geometric_normal(&p, tri);
            assert!(g.normalize().abs_diff_eq(Vec3::Y, 1e-6), "{g}");
        }
        let lo = p.iter().copied().reduce(Vec3::min).unwrap();
        let hi = p.iter().copied().reduce(Vec3::max).unwrap();
        assert_eq!(
            (lo, hi),
            (Vec3::new(-1.0, 0.0, -2.0), Vec3::new(1.0, 0.0, 2.0))
        );
        // Two triangles cover the full area (no overlap, no gap).
        let area: f32 = t
            .iter()
            .map(|&tri| geometric_normal(&p, tri).length() / 2.0)
            .sum();
        assert!((area - 8.0).abs() < 1e-6);
    }

    #[test]
    fn box_is_closed_and_outward_facing() {
        let (p, t) = cuboid(Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(t.len(), 12);
        for v in &p {
            assert_eq!(
                v.abs(),
                Vec3::new(0.5, 1.0, 1.5),
                "corner {v} not on the box"
            );
        }
        // Outward: the geometric normal is a unit axis pointing the same way as the
        // triangle's centroid along that axis.
        let mut per_axis = HashMap::new();
        for &tri in &t {
            let g = geometric_normal(&p, tri).normalize();
            let centroid = tri.map(|i| p[i as usize]).iter().sum::<Vec3>() / 3.0;
            assert!(g.dot(centroid) > 0.0, "triangle {tri:?} faces inward");
            assert!(
                (g.abs().max_element() - 1.0).abs() < 1e-6,
                "{g} not axis-aligned"
            );
            *per_axis
                .entry(g.to_array().map(|c| c as i32))
                .or_insert(0.0) += geometric_normal(&p, tri).length() / 2.0;
        }
        // Closed: every face direction is present with the full face area, and the signed
        // area vectors cancel.
        assert_eq!(per_axis.len(), 6);
        let expected = |n: [i32; 3]| match n {
            [_, 0, 0] => 6.0,
            [0, _, 0] => 3.0,
            _ => 2.0,
        };
        for (n, a) in per_axis {
            assert!((a - expected(n)).abs() < 1e-5, "face {n:?} area {a}");
        }
        let total: Vec3 = t.iter().map(|&tri| geometric_normal(&p, tri)).sum();
        assert!(total.length() < 1e-5);
        // Every edge is shared by exactly two triangles in opposite directions once corners
        // are identified by position.
        let key = |v: Vec3| v.to_array().map(|c| (c * 2.0) as i32);
        let mut edges: HashMap<([i32; 3], [i32; 3]), i32> = HashMap::new();
        for &[a, b, c] in &t {
            for (x, y) in [(a, b), (b, c), (c, a)] {
                *edges
                    .entry((key(p[x as usize]), key(p[y as usize])))
                    .or_default() += 1;
            }
        }
        for (&(x, y), &n) in &edges {
            // Diagonals of a face appear once in each direction, box edges likewise.
            assert_eq!(n, 1, "edge {x:?}->{y:?} used {n} times");
            assert_eq!(
                edges.get(&(y, x)),
                Some(&1),
                "edge {x:?}->{y:?} has no twin"
            );
        }
    }
}
