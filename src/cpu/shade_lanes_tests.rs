//! The lanes against the scalar shading functions they mirror (`shade::surface_with`,
//! `shade::shadow_ray`, `shade::light_term`), bit for bit, on every compilation the CPU
//! runs ([`Dispatch::available`]), in f32 and f64: random triangles with and without
//! vertex normals, degenerate normals (zero, overflowing, opposite the face), hits on
//! edges and corners, directions with zero components, lights on the surface's plane and
//! behind it, every terminator and offset technique. Seeded (`FRAGTRACE_TEST_SEED`).

#![allow(clippy::needless_range_loop)]

use glam::Vec3;

use super::*;
use crate::cpu::shade::{geometric_normal, light_term, shadow_ray, specular, surface_with};
use crate::cpu::traverse::Hit;
use crate::scene::{Material, Scene, Triangle};
use crate::technique::{OffsetMethod, Techniques, Terminator};
use crate::testing::{scene_of, soup, test_seed, Rng};

/// Bits of a vector (f64 holds every f32 exactly, NaN payloads included).
fn bits<T: Real>(v: V3<T>) -> [u64; 3] {
    [v.x, v.y, v.z].map(|c| c.to_f64().to_bits())
}

/// A scene of random triangles whose vertex normals run through the hard cases.
fn scene(rng: &mut Rng, n: usize) -> Scene {
    let mut scene = scene_of(&soup(rng, n));
    scene.add_material(Material {
        ks: Vec3::new(0.3, 0.2, 0.1),
        ns: 12.0,
        ..Material::default()
    });
    for t in 0..n {
        let kind = rng.next_u64() % 6;
        let tri = scene.triangles[t];
        let face = {
            let p = tri.v.map(|i| scene.positions[i as usize]);
            (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero()
        };
        let normal = |rng: &mut Rng| -> Vec3 {
            match kind {
                1 => (face + rng.dvec3(-0.4, 0.4).as_vec3()).normalize_or_zero(),
                2 => rng.dvec3(-1.0, 1.0).as_vec3(),
                3 => Vec3::ZERO,
                4 => Vec3::splat(3e38),
                _ => -face + rng.dvec3(-0.1, 0.1).as_vec3(),
            }
        };
        if kind == 0 {
            continue; // no vertex normals
        }
        let first = scene.normals.len() as u32;
        for _ in 0..3 {
            let nv = normal(rng);
            scene.normals.push(nv);
        }
        scene.triangles[t] = Triangle {
            n: [first, first + 1, first + 2],
            material: (t % 2) as u32,
            ..tri
        };
    }
    scene
}

/// Barycentric weights: random, or on an edge or a corner.
fn barycentric<T: Real>(rng: &mut Rng) -> [T; 3] {
    let b = match rng.next_u64() % 4 {
        0 => [1.0, 0.0, 0.0],
        1 => {
            let u = rng.f64();
            [u, 1.0 - u, 0.0]
        }
        _ => {
            let (u, v) = (rng.f64(), rng.f64());
            let (u, v) = if u + v > 1.0 {
                (1.0 - u, 1.0 - v)
            } else {
                (u, v)
            };
            [1.0 - u - v, u, v]
        }
    };
    b.map(T::from_f64)
}

/// A direction, sometimes with zero components.
fn direction<T: Real>(rng: &mut Rng) -> V3<T> {
    let d = rng.dvec3(-1.0, 1.0);
    let d = match rng.next_u64() % 4 {
        0 => glam::DVec3::new(0.0, d.y, d.z),
        1 => glam::DVec3::new(0.0, 0.0, d.z.signum()),
        _ => d,
    };
    V3::from_dvec3(d.normalize())
}

fn techniques() -> Vec<Techniques> {
    let mut all = Vec::new();
    for terminator in [Terminator::Exact, Terminator::Smooth] {
        for offset in [OffsetMethod::ErrorBound, OffsetMethod::Epsilon] {
            all.push(Techniques {
                terminator,
                offset,
                ..Techniques::default()
            });
        }
    }
    all
}

fn lanes_match_the_scalar_functions<T: Real>(seed: u64) {
    let mut rng = Rng::new(seed);
    let scene = scene(&mut rng, 48);
    let verts: Vec<[V3<T>; 3]> = scene
        .triangles
        .iter()
        .map(|t| t.v.map(|i| V3::from_vec3(scene.positions[i as usize])))
        .collect();
    let ng: Vec<V3<T>> = verts.iter().map(geometric_normal).collect();
    let mut checked = [0usize; 3];
    for round in 0..64u32 {
        // The lanes' inputs, gathered as the renderer gathers them.
        let mut inp = SurfaceIn::<T>::zero();
        let mut hits = [None; LANES];
        for (k, slot) in hits.iter_mut().enumerate() {
            if rng.next_u64().is_multiple_of(5) {
                continue; // a miss: the lane is dead
            }
            let tri = (rng.next_u64() % scene.triangles.len() as u64) as usize;
            let hit = Hit {
                t: T::ONE,
                tri: tri as u32,
                b: barycentric(&mut rng),
            };
            for a in 0..3 {
                inp.v[a].set(k, verts[tri][a]);
                inp.b[a][k] = hit.b[a];
            }
            inp.ng.set(k, ng[tri]);
            let t = &scene.triangles[tri];
            if t.has_normals() {
                inp.has_normals[k] = true;
                for a in 0..3 {
                    inp.n[a].set(k, V3::from_vec3(scene.normals[t.n[a] as usize]));
                }
            }
            inp.d.set(k, direction(&mut rng));
            *slot = Some(hit);
        }
        let live = hits.map(|h| h.is_some());
        let lp = if round.is_multiple_of(8) {
            // On a surface point's plane: the horizon test's boundary.
            match hits.iter().flatten().next() {
                Some(h) => verts[h.tri as usize][0],
                None => V3::splat(T::ZERO),
            }
        } else {
            V3::from_dvec3(rng.dvec3(-3.0, 3.0))
        };
        for dispatch in Dispatch::available() {
            let mut s = Surfaces::zero();
            dispatch.surfaces(&inp, &mut s);
            for (k, hit) in hits.iter().enumerate() {
                let Some(hit) = hit else { continue };
                let tri = hit.tri as usize;
                let want = surface_with(&scene, &verts[tri], ng[tri], hit, inp.d.get(k));
                let got = s.point(k, want.material);
                let what = format!("seed {seed}, {dispatch:?}, round {round}, lane {k}");
                for (name, a, b) in [
                    ("p", got.p, want.p),
                    ("p_err", got.p_err, want.p_err),
                    ("ng", got.ng, want.ng),
                    ("nf", got.nf, want.nf),
                    ("ns", got.ns, want.ns),
                ] {
                    assert_eq!(bits(a), bits(b), "{what}: {name} {a:?} vs {b:?}");
                }
                for (name, a, b) in [("gap", got.gap, want.gap), ("reach", got.reach, want.reach)] {
                    assert_eq!(a.to_f64().to_bits(), b.to_f64().to_bits(), "{what}: {name}");
                }
                assert_eq!(
                    (got.entering, got.flipped),
                    (want.entering, want.flipped),
                    "{what}"
                );
                checked[0] += 1;
            }
            for tech in techniques() {
                let mut sh = Shadows::zero();
                dispatch.shadows(&s, &live, lp, tech, &mut sh);
                let mut add = [false; LANES];
                let mut spec = V3L::zero();
                let (mut alb, mut kd) = (V3L::zero(), [T::ZERO; LANES]);
                let mut has_spec = [false; LANES];
                let mut want_color = V3L::zero();
                let mut color = V3L::zero();
                let radiance = V3::from_vec3(Vec3::new(0.9, 0.7, 1.3));
                for (k, hit) in hits.iter().enumerate() {
                    let Some(hit) = hit else { continue };
                    let tri = hit.tri as usize;
                    let sp = s.point(k, scene.triangles[tri].material);
                    let what = format!("seed {seed}, {dispatch:?}, {tech:?}, lane {k}");
                    let want = shadow_ray(&sp, lp, tech);
                    assert_eq!(sh.cast[k], want.is_some(), "{what}: cast");
                    let Some((o, l, dist)) = want else { continue };
                    assert_eq!(bits(sh.o.get(k)), bits(o), "{what}: origin");
                    assert_eq!(bits(sh.l.get(k)), bits(l), "{what}: direction");
                    assert_eq!(
                        sh.dist[k].to_f64().to_bits(),
                        dist.to_f64().to_bits(),
                        "{what}: distance"
                    );
                    checked[1] += 1;
                    // The light's term where the ray is unblocked (every other lane).
                    let m = &scene.materials[sp.material as usize];
                    let a = V3::from_dvec3(rng.dvec3(0.0, 1.0));
                    let v = -inp.d.get(k);
                    let c0 = V3::from_dvec3(rng.dvec3(0.0, 0.5));
                    alb.set(k, a);
                    kd[k] = T::from_f32(m.kd);
                    has_spec[k] = m.ks.max_element() > 0.0;
                    if has_spec[k] {
                        spec.set(k, specular(m, sp.ns, l, v));
                    }
                    color.set(k, c0);
                    add[k] = k % 2 == 0;
                    want_color.set(
                        k,
                        if add[k] {
                            c0 + light_term(m, a, &sp, l, v, radiance)
                        } else {
                            c0
                        },
                    );
                }
                dispatch.add_light(
                    &mut color, &s, &sh.l, &alb, &kd, &spec, &has_spec, &add, radiance,
                );
                for k in 0..LANES {
                    assert_eq!(
                        bits(color.get(k)),
                        bits(want_color.get(k)),
                        "seed {seed}, {dispatch:?}, {tech:?}, lane {k}: colour"
                    );
                    checked[2] += add[k] as usize;
                }
            }
        }
    }
    // The random cases reach every part (a test that checked nothing would pass).
    assert!(
        checked.iter().all(|&c| c > 100),
        "too few lanes checked: {checked:?}"
    );
}

#[test]
fn lanes_are_the_scalar_shading_bit_for_bit() {
    let seed = test_seed("shade_lanes", 0x5ade_1a9e);
    lanes_match_the_scalar_functions::<f32>(seed);
    lanes_match_the_scalar_functions::<f64>(seed);
}

/// Vertex normals lying in the triangle's own plane make a shading normal at exactly right
/// angles to the face (`ns . nf` is zero): it is kept as it is, not flipped (the flip is
/// for `ns . nf < 0` only, strictly, as `shade::surface_with` has it), whichever side the
/// ray comes from. Independent answer: the interpolated normal itself, `flipped` false.
fn in_plane_normals_are_kept<T: Real>() {
    let tri = [
        V3::new(T::ZERO, T::ZERO, T::ZERO),
        V3::new(T::ONE, T::ZERO, T::ZERO),
        V3::new(T::ZERO, T::ONE, T::ZERO),
    ];
    let ng = geometric_normal(&tri);
    assert_eq!(bits(ng), bits(V3::new(T::ZERO, T::ZERO, T::ONE)));
    // Weights in powers of two: the interpolated normal is the vertices' one exactly.
    let b = [0.5, 0.25, 0.25].map(T::from_f64);
    let mut inp = SurfaceIn::<T>::zero();
    let mut want = Vec::new();
    for k in 0..LANES {
        // Along +x, -x, +y or -y: unit already, so normalising leaves it as it is.
        let s = if k % 2 == 0 { T::ONE } else { -T::ONE };
        let n = if k % 4 < 2 {
            V3::new(s, T::ZERO, T::ZERO)
        } else {
            V3::new(T::ZERO, s, T::ZERO)
        };
        let dz = if k < LANES / 2 { -T::ONE } else { T::ONE };
        for a in 0..3 {
            inp.v[a].set(k, tri[a]);
            inp.n[a].set(k, n);
            inp.b[a][k] = b[a];
        }
        inp.ng.set(k, ng);
        inp.has_normals[k] = true;
        inp.d
            .set(k, V3::new(T::from_f64(0.25), T::from_f64(-0.5), dz));
        want.push(n);
    }
    for dispatch in Dispatch::available() {
        let mut s = Surfaces::zero();
        dispatch.surfaces(&inp, &mut s);
        for (k, n) in want.iter().enumerate() {
            let what = format!("{dispatch:?} {}, lane {k}", T::NAME);
            assert_eq!(bits(s.ns.get(k)), bits(*n), "{what}: ns");
            assert!(!s.flipped[k], "{what}: flipped");
            assert_eq!(s.entering[k], k < LANES / 2, "{what}: entering");
        }
    }
}

#[test]
fn normals_in_the_face_plane_are_not_flipped() {
    in_plane_normals_are_kept::<f32>();
    in_plane_normals_are_kept::<f64>();
}

/// Triangles so small and so near the origin that the error-bound offset's floor (`1e-30`,
/// added to each coordinate's nudge) is larger than the coordinates' own ulp: in f64 at
/// 1e-15 the floor decides the nudge's bits (at unit size it vanishes in the rounding, so
/// the random scenes cannot see it). The shadow ray's origin is the scalar code's bit for
/// bit, and leaves the surface towards the light (checked in f64 against the plane
/// through the hit point: an independent answer).
fn tiny_triangles_are_left_towards_the_light<T: Real>(scale: f64) {
    let tech = Techniques {
        offset: OffsetMethod::ErrorBound,
        terminator: Terminator::Exact,
        ..Techniques::default()
    };
    let seed = test_seed("shade_lanes tiny", 0x71e1_0001);
    let mut rng = Rng::new(seed);
    let mut inp = SurfaceIn::<T>::zero();
    for k in 0..LANES {
        let tri: [V3<T>; 3] = std::array::from_fn(|_| V3::from_dvec3(rng.dvec3(-1.0, 1.0) * scale));
        let ng = geometric_normal(&tri);
        let b = [0.25, 0.5, 0.25].map(T::from_f64);
        for a in 0..3 {
            inp.v[a].set(k, tri[a]);
            inp.b[a][k] = b[a];
        }
        inp.ng.set(k, ng);
        inp.d.set(k, -ng);
    }
    let live = [true; LANES];
    for dispatch in Dispatch::available() {
        let mut s = Surfaces::zero();
        dispatch.surfaces(&inp, &mut s);
        // Each lane's light along its face normal: every ray is cast.
        for k in 0..LANES {
            let (p, ng) = (s.p.get(k), s.ng.get(k));
            let lp = p + ng * T::from_f64(scale);
            let mut sh = Shadows::zero();
            dispatch.shadows(&s, &live, lp, tech, &mut sh);
            let what = format!(
                "seed {seed}, {dispatch:?} {} at {scale:e}, lane {k}",
                T::NAME
            );
            let want = shadow_ray(&s.point(k, 0), lp, tech).expect("a light above");
            assert!(sh.cast[k], "{what}: cast");
            assert_eq!(bits(sh.o.get(k)), bits(want.0), "{what}: origin");
            let lift = (sh.o.get(k).to_dvec3() - p.to_dvec3()).dot(ng.to_dvec3());
            assert!(lift > 0.0, "{what}: origin {lift:e} off the surface");
        }
    }
}

#[test]
fn tiny_triangles_near_the_origin_are_left_towards_the_light() {
    tiny_triangles_are_left_towards_the_light::<f64>(1e-15);
    // Where f32's cross products stay normal numbers: the floor is below its ulps.
    tiny_triangles_are_left_towards_the_light::<f32>(1e-18);
}
