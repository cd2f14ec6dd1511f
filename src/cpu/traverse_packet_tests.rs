//! Tests of the ray-packet walk (`traverse_packet.rs`) against the single-ray walk it claims
//! to equal: for every packet unit this CPU runs, batches of rays walked as packets give the
//! scalar f32 walk's closest hits bit for bit (t, triangle, barycentrics) and its any-hit
//! answers, and brute force's where the scene has no chains of ties. The rays: incoherent
//! (random) and coherent (from one eye, and shadow rays to one light), directions with +0
//! and -0 components, origins inside the tree's boxes aimed at edges and vertices, t
//! intervals ending (and starting) inside the box of the hit, rays leaving a surface (where
//! the t bound decides), and batch lengths that leave lanes dead. Also: the empty scene,
//! Möller-Trumbore (no packets: one ray at a time) and `TBound::Off`.
//!
//! Work is compared where the module's doc defines it: a lane counts the nodes and
//! triangles it was active for, so each packet's lane 0 (the walk takes children nearest
//! first for the lowest lane entering them: lane 0's own order, as the single-ray walk's)
//! counts what its ray counts alone, any-hit lanes (slot order, as the single-ray walk)
//! count what their rays count alone, and every lane counts at least the root.

use glam::{DVec3, Vec3};

use super::*;
use crate::cpu::real::V3;
use crate::cpu::simd::Isa;
use crate::cpu::traverse::{brute_force, Trace};
use crate::cpu::traverse_bvh::BvhWalker;
use crate::scene::Scene;
use crate::technique::{IntersectMethod, TBound, Techniques};
use crate::testing::{
    corner_clusters, primary_rays, random_rays, ray_of, rays_through, scene_of, soup, sphere,
    test_seed, Rng,
};

/// Batch lengths, taken in turn: below, at and past both widths (8 and 16), so that most
/// batches end in a packet with dead lanes and some are a single ray.
const LENGTHS: [usize; 14] = [1, 7, 9, 15, 16, 17, 8, 31, 33, 2, 64, 5, 1, 23];

/// The packet units this CPU runs (both on the development machine), their detection
/// checked against std's, so that an empty list means a CPU without AVX2 and not a broken
/// `available`.
fn units() -> Vec<PacketIsa> {
    #[cfg(target_arch = "x86_64")]
    {
        assert_eq!(
            PacketIsa::Avx512.available(),
            std::arch::is_x86_feature_detected!("avx512f")
        );
        assert_eq!(
            PacketIsa::Avx2.available(),
            std::arch::is_x86_feature_detected!("avx2")
        );
    }
    let units: Vec<_> = [PacketIsa::Avx512, PacketIsa::Avx2]
        .into_iter()
        .filter(|u| u.available())
        .collect();
    println!("packet units on this CPU: {units:?}");
    assert_eq!(PacketIsa::detect(), units.first().copied());
    units
}

/// A hit as bits: t, triangle, barycentrics.
fn bits(h: Option<Hit<f32>>) -> Option<(u32, u32, [u32; 3])> {
    h.map(|h| (h.t.to_bits(), h.tri, h.b.map(f32::to_bits)))
}

/// The ray (o, d) over (t_min, t_max) in f32.
fn ray32(o: DVec3, d: DVec3, t_min: f32, t_max: f32) -> Ray<f32> {
    Ray {
        t_min,
        ..ray_of::<f32>(o, d, t_max as f64)
    }
}

/// What a comparison saw, so that a test can require its cases to have happened.
#[derive(Default, Debug)]
struct Seen {
    rays: usize,
    hits: usize,
    occluded: usize,
}

/// The walker of `s` whose batches walk as packets of `unit`.
fn packet_walker<'a>(
    s: &Scene,
    bvh: &'a Bvh,
    tech: Techniques,
    unit: PacketIsa,
) -> BvhWalker<'a, f32> {
    let w = BvhWalker::with_packets(s, bvh, tech, Isa::detect(), unit);
    assert_eq!(w.packets(), Some(unit), "packets on");
    w
}

/// `batch` through `p`'s closest-hit query: each ray's hit and work.
fn closest_batch(p: &BvhWalker<'_, f32>, batch: &[Ray<f32>]) -> (Vec<Option<Hit<f32>>>, Vec<Work>) {
    let mut hits = vec![None; batch.len()];
    let mut work = vec![Work::default(); batch.len()];
    p.closest_hits(batch, &mut hits, &mut work);
    (hits, work)
}

/// `batch` through `p`'s any-hit query, its work added to `work`.
fn any_batch(p: &BvhWalker<'_, f32>, batch: &[Ray<f32>], work: &mut Work) -> Vec<bool> {
    let mut any = vec![false; batch.len()];
    p.any_hits(batch, &mut any, work);
    any
}

/// `rays` through `p`'s batch queries (batches of [`LENGTHS`] in turn) against `single`'s
/// one-ray queries: the same closest hits bit for bit, the same any-hit answers, the
/// any-hit work of each batch the sum of its rays' (added to what `work` held), the
/// closest-hit work of each packet's lane 0 its ray's alone (the walk takes children
/// nearest first for the lowest lane entering them, so lane 0 walks its own ray's order
/// and bound; other lanes may count more or less), and every lane at least the root
/// counted (and a test, where it hit).
fn batches_are_single_rays(
    p: &BvhWalker<'_, f32>,
    single: &BvhWalker<'_, f32>,
    rays: &[Ray<f32>],
    what: &str,
) -> Seen {
    let unit = p.packets().map_or("none", PacketIsa::name);
    // One ray at a time when there are no packets.
    let lanes = p.packets().map_or(1, PacketIsa::lanes);
    let mut seen = Seen::default();
    let (mut at, mut k) = (0, 0);
    while at < rays.len() {
        let n = LENGTHS[k % LENGTHS.len()].min(rays.len() - at);
        k += 1;
        let batch = &rays[at..at + n];
        let (hits, work) = closest_batch(p, batch);
        let held = Work { cells: 3, tests: 5 };
        let (mut any_work, mut want_any_work) = (held, held);
        let any = any_batch(p, batch, &mut any_work);
        for (j, r) in batch.iter().enumerate() {
            let i = at + j;
            let mut w1 = Work::default();
            let want = single.closest_hit(r, &mut w1);
            assert_eq!(
                bits(hits[j]),
                bits(want),
                "{what} {unit}: closest hit of ray {i} (lane {} of a batch of {n}) {r:?}",
                j % lanes
            );
            let want_any = single.any_hit(r, &mut want_any_work);
            assert_eq!(any[j], want_any, "{what} {unit}: any hit of ray {i} {r:?}");
            if j % lanes == 0 {
                assert_eq!(
                    work[j], w1,
                    "{what} {unit}: work of ray {i}, lane 0 of its packet, {r:?}"
                );
            }
            if r.t_min <= r.t_max {
                assert!(
                    work[j].cells >= 1,
                    "{what} {unit}: ray {i} did not count the root"
                );
            }
            if hits[j].is_some() {
                assert!(
                    work[j].tests >= 1,
                    "{what} {unit}: ray {i} hit without a test"
                );
            }
            seen.hits += usize::from(want.is_some());
            seen.occluded += usize::from(want_any);
        }
        assert_eq!(
            any_work,
            want_any_work,
            "{what} {unit}: any-hit work of rays {at}..{}",
            at + n
        );
        at += n;
    }
    seen.rays = rays.len();
    seen
}

/// [`batches_are_single_rays`] for every packet unit, against the scalar f32 walk (which
/// shares no code with the packets but the tie rule's `takes`) and, when `brute`, every
/// closest hit against brute force over all triangles. Returns what the last unit saw.
fn packets_are_single_rays(
    s: &Scene,
    tech: Techniques,
    rays: &[Ray<f32>],
    brute: bool,
    what: &str,
) -> Seen {
    let bvh = Bvh::build(s).unwrap();
    let single = BvhWalker::<f32>::new(s, &bvh, tech);
    let mut seen = Seen::default();
    for unit in units() {
        let p = packet_walker(s, &bvh, tech, unit);
        seen = batches_are_single_rays(&p, &single, rays, what);
        if brute {
            let (hits, _) = closest_batch(&p, rays);
            for (i, (r, h)) in rays.iter().zip(&hits).enumerate() {
                let want = brute_force(r, single.tris(), &tech);
                assert_eq!(
                    bits(*h),
                    bits(want),
                    "{what} {}: brute force, ray {i} {r:?}",
                    unit.name()
                );
            }
        }
    }
    println!("{what}: {seen:?}");
    seen
}

/// Random rays (some axis-parallel, some with a short t_max) and rays aimed at every
/// fifth triangle's edge midpoints and vertices from all around, where neighbours tie.
fn incoherent(rng: &mut Rng, tris: &[[Vec3; 3]]) -> Vec<Ray<f32>> {
    let mut rays = random_rays(rng, 1500, 3.0);
    for t in tris.iter().step_by(5) {
        rays_through(rng, ((t[0] + t[1]) * 0.5).as_dvec3(), &mut rays);
        rays_through(rng, t[2].as_dvec3(), &mut rays);
    }
    rays.into_iter()
        .map(|(o, d, t_max)| ray_of(o, d, t_max))
        .collect()
}

/// Rays from `eye` through the pixels of a 40x30 view of `s`'s camera, in 4x4 squares
/// (as the renderer batches them): coherent packets.
fn coherent(s: &Scene, eye: DVec3) -> Vec<Ray<f32>> {
    let (w, h) = (40u32, 30u32);
    let dirs = primary_rays(s, w, h);
    let mut rays = Vec::new();
    for j0 in (0..h).step_by(4) {
        for i0 in (0..w).step_by(4) {
            for j in j0..(j0 + 4).min(h) {
                for i in i0..(i0 + 4).min(w) {
                    let d = dirs[(j * w + i) as usize].1;
                    rays.push(ray32(eye, d, 0.0, f32::MAX));
                }
            }
        }
    }
    rays
}

/// Closest and any hits of random soups, a closed sphere and corner clusters: incoherent
/// rays, and against brute force too.
#[test]
fn incoherent_packets_are_single_rays() {
    let seed = test_seed("packet incoherent", 0x9AC4_0001);
    let mut rng = Rng::new(seed);
    let scenes = [
        soup(&mut rng, 2000),
        sphere(Vec3::new(0.2, -0.1, 0.3), 2.5, 16),
        corner_clusters(&mut rng, 500, 5, 0.1),
    ];
    for (si, tris) in scenes.iter().enumerate() {
        let s = scene_of(tris);
        let rays = incoherent(&mut rng, tris);
        let seen = packets_are_single_rays(
            &s,
            Techniques::default(),
            &rays,
            true,
            &format!("seed {seed} scene {si}"),
        );
        // Measured at the default seed: 4389, 2351 and 306 hits (of 4700, 3140 and 2300 rays).
        assert!(
            seen.hits > 150 && seen.occluded >= seen.hits,
            "scene {si}: {seen:?}"
        );
    }
}

/// Points on triangles of `tris` (every `step`th, inside, random barycentrics).
fn surface_points(rng: &mut Rng, tris: &[[Vec3; 3]], step: usize) -> Vec<DVec3> {
    tris.iter()
        .step_by(step)
        .map(|t| {
            let (a, b) = (rng.f64(), rng.f64());
            let (a, b) = if a + b > 1.0 {
                (1.0 - a, 1.0 - b)
            } else {
                (a, b)
            };
            let [p, q, r] = t.map(|v| v.as_dvec3());
            p + (q - p) * a + (r - p) * b
        })
        .collect()
}

/// Coherent packets: primary rays from an eye outside the soup and from one inside it
/// (every box on the way entered from within), and shadow rays from points on the soup's
/// triangles to one light, ending there (the renderer's any-hit batches).
#[test]
fn coherent_packets_are_single_rays() {
    let seed = test_seed("packet coherent", 0x9AC4_0002);
    let mut rng = Rng::new(seed);
    let tris = soup(&mut rng, 2000);
    let s = scene_of(&tris);
    let tech = Techniques::default();
    let outside = coherent(&s, s.camera.eye.as_dvec3());
    let seen = packets_are_single_rays(&s, tech, &outside, true, "eye outside");
    // Measured at the default seed: all 1200 rays hit (the soup fills the view), from
    // outside and from inside.
    assert!(seen.hits > 600, "{seen:?}");
    let inside = coherent(&s, DVec3::new(0.1, 0.2, 0.3));
    let seen = packets_are_single_rays(&s, tech, &inside, true, "eye inside");
    assert!(seen.hits > 600, "{seen:?}");
    let light = DVec3::new(1.5, 4.5, 2.0);
    let shadows: Vec<_> = surface_points(&mut rng, &tris, 1)
        .into_iter()
        .map(|p| {
            let d = (light - p).normalize();
            ray32(p, d, 0.0, (light - p).length() as f32)
        })
        .collect();
    let seen = packets_are_single_rays(&s, tech, &shadows, false, "shadow rays");
    // Occluded and lit rays both (measured: 1860 of 2000 occluded).
    assert!(
        seen.occluded > 100 && seen.occluded + 100 < seen.rays,
        "{seen:?}"
    );
}

/// Axis-parallel rays whose zero components are +0 or -0 (1 / -0 is -inf: the slab's near
/// plane is then the box's upper bound), from origins on the planes of triangle vertices
/// (so on box faces), straight at the vertices and at edge midpoints, and rays in an axis
/// plane (one zero component); the packets mix the signs lane by lane.
#[test]
fn zero_direction_components_are_single_rays() {
    let seed = test_seed("packet zeros", 0x9AC4_0003);
    let mut rng = Rng::new(seed);
    let mut tris = soup(&mut rng, 800);
    // Axis-aligned triangles too: their planes are box faces.
    tris.extend(
        sphere(Vec3::ZERO, 1.0, 3)
            .into_iter()
            .map(|t| t.map(|v| v.round())),
    );
    let s = scene_of(&tris);
    let mut rays = Vec::new();
    let zeros = [0.0f32, -0.0];
    for (n, t) in tris.iter().enumerate() {
        let targets = [t[0], (t[1] + t[2]) * 0.5];
        for (k, target) in targets.into_iter().enumerate() {
            let a = (n + k) % 3;
            let sign: f32 = if rng.f64() < 0.5 { 1.0 } else { -1.0 };
            let mut d = [zeros[n % 2], zeros[(n / 2) % 2], zeros[(n / 4) % 2]];
            d[a] = sign;
            let mut o = target;
            o[a] -= sign * (1.0 + 4.0 * rng.f64()) as f32;
            let r = ray32(o.as_dvec3(), DVec3::ZERO, 0.0, f32::MAX);
            rays.push(Ray {
                d: V3::new(d[0], d[1], d[2]),
                ..r
            });
            // In the plane of axes a and b: one zero component, signed as `d`'s.
            let b = (a + 1) % 3;
            let mut d2 = d;
            d2[b] = if rng.f64() < 0.5 { 0.5 } else { -0.5 };
            let mut o2 = target;
            o2[a] -= d2[a] * 3.0;
            o2[b] -= d2[b] * 3.0;
            let r = ray32(o2.as_dvec3(), DVec3::ZERO, 0.0, f32::MAX);
            rays.push(Ray {
                d: V3::new(d2[0], d2[1], d2[2]),
                ..r
            });
        }
    }
    let negative_zeros = rays
        .iter()
        .filter(|r| (0..3).any(|a| r.d[a] == 0.0 && r.d[a].is_sign_negative()))
        .count();
    assert!(
        negative_zeros > rays.len() / 3,
        "{negative_zeros} rays with a -0"
    );
    // Not against brute force: the BVH's own single-ray walk misses some hits just short
    // of t_max (see `intervals_ending_just_past_a_hit_are_brute_force`).
    let seen = packets_are_single_rays(
        &s,
        Techniques::default(),
        &rays,
        false,
        &format!("seed {seed}"),
    );
    // Measured at the default seed: 3203 hits of 3344 rays.
    assert!(seen.hits > rays.len() / 4, "{seen:?}");
}

/// Origins inside the tree's boxes (near the soup's triangles), aimed at edge midpoints and
/// vertices: neighbours tie there, and the first box is entered at t_min.
#[test]
fn rays_from_inside_boxes_at_edges_and_vertices_are_single_rays() {
    let seed = test_seed("packet inside", 0x9AC4_0004);
    let mut rng = Rng::new(seed);
    let mut tris = soup(&mut rng, 1500);
    tris.extend(sphere(Vec3::new(0.5, 0.0, -0.5), 1.5, 12));
    let s = scene_of(&tris);
    let mut rays = Vec::new();
    for t in tris.iter().step_by(2) {
        for target in [t[0], (t[0] + t[2]) * 0.5, t[1]] {
            let o = target.as_dvec3() + rng.dvec3(-0.4, 0.4);
            rays.push(ray32(o, target.as_dvec3() - o, 0.0, f32::MAX));
        }
    }
    // Not against brute force: the BVH's own single-ray walk misses some hits just short
    // of t_max (see `intervals_ending_just_past_a_hit_are_brute_force`).
    let seen = packets_are_single_rays(
        &s,
        Techniques::default(),
        &rays,
        false,
        &format!("seed {seed}"),
    );
    // Measured at the default seed: 2855 hits of 3114 rays.
    assert!(seen.hits > rays.len() / 2, "{seen:?}");
}

/// Intervals ending inside the box of the hit: t_max at the hit (open interval: missed),
/// just past it, short of it; and starting inside it: t_min half way, at the hit, just
/// before it. Each variant of a ray that hits, so the box is entered and the interval
/// decides.
#[test]
fn intervals_ending_inside_boxes_are_single_rays() {
    let seed = test_seed("packet intervals", 0x9AC4_0005);
    let mut rng = Rng::new(seed);
    let tris = soup(&mut rng, 1500);
    let s = scene_of(&tris);
    let bvh = Bvh::build(&s).unwrap();
    let single = BvhWalker::<f32>::new(&s, &bvh, Techniques::default());
    let mut rays = Vec::new();
    for r in incoherent(&mut rng, &tris) {
        let Some(h) = single.closest_hit(&r, &mut Work::default()) else {
            continue;
        };
        let t = h.t;
        for t_max in [t, t.next_up(), t * 0.999, t * 0.5] {
            rays.push(Ray { t_max, ..r });
        }
        for t_min in [t * 0.5, t, t.next_down()] {
            rays.push(Ray { t_min, ..r });
        }
    }
    // Not against brute force: the BVH's own single-ray walk misses some hits just short
    // of t_max (see `intervals_ending_just_past_a_hit_are_brute_force`).
    let seen = packets_are_single_rays(
        &s,
        Techniques::default(),
        &rays,
        false,
        &format!("seed {seed}"),
    );
    // Measured at the default seed: 13976 hits of 25053 rays (hit and missed variants).
    assert!(
        seen.hits > rays.len() / 4 && seen.hits + rays.len() / 4 < rays.len(),
        "{seen:?}"
    );
}

/// A ray's answers do not depend on its batch: the same rays in batches of every length
/// from 1 to 40 (every count of dead lanes in both widths), each answer the single ray's.
#[test]
fn every_batch_length_gives_the_same_answers() {
    let seed = test_seed("packet lengths", 0x9AC4_0006);
    let mut rng = Rng::new(seed);
    let tris = soup(&mut rng, 600);
    let s = scene_of(&tris);
    let bvh = Bvh::build(&s).unwrap();
    let single = BvhWalker::<f32>::new(&s, &bvh, Techniques::default());
    let rays = incoherent(&mut rng, &tris);
    let want: Vec<_> = rays
        .iter()
        .map(|r| bits(single.closest_hit(r, &mut Work::default())))
        .collect();
    let want_any: Vec<_> = rays
        .iter()
        .map(|r| single.any_hit(r, &mut Work::default()))
        .collect();
    for unit in units() {
        let p = packet_walker(&s, &bvh, Techniques::default(), unit);
        for n in 1..=40 {
            for (c, batch) in rays.chunks(n).enumerate().take(60) {
                let at = c * n;
                let (hits, _) = closest_batch(&p, batch);
                let any = any_batch(&p, batch, &mut Work::default());
                for j in 0..batch.len() {
                    assert_eq!(
                        bits(hits[j]),
                        want[at + j],
                        "{} batches of {n}: ray {}",
                        unit.name(),
                        at + j
                    );
                    assert_eq!(
                        any[j],
                        want_any[at + j],
                        "{} batches of {n}: ray {}",
                        unit.name(),
                        at + j
                    );
                }
            }
        }
    }
    assert!(want.iter().filter(|h| h.is_some()).count() > 100);
}

/// Rays leaving a surface, as the renderer spawns them (origin on a triangle, rounded to
/// f32): the t bound rejects the re-hit of that triangle, and `TBound::Off` accepts it.
/// The packets follow each setting (the answers differ between the two, counted).
#[test]
fn t_bound_on_and_off_are_single_rays() {
    let seed = test_seed("packet t bound", 0x9AC4_0007);
    let mut rng = Rng::new(seed);
    let tris = soup(&mut rng, 1000);
    let s = scene_of(&tris);
    let rays: Vec<_> = surface_points(&mut rng, &tris, 1)
        .into_iter()
        .map(|p| {
            let mut d = DVec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            if d == DVec3::ZERO {
                d = DVec3::Z;
            }
            ray32(p, d, 0.0, f32::MAX)
        })
        .collect();
    let on = Techniques::default().with_t_bound(TBound::On);
    let off = Techniques::default().with_t_bound(TBound::Off);
    let bvh = Bvh::build(&s).unwrap();
    let (w_on, w_off) = (
        BvhWalker::<f32>::new(&s, &bvh, on),
        BvhWalker::<f32>::new(&s, &bvh, off),
    );
    let differ = rays
        .iter()
        .filter(|r| {
            let a = w_on.closest_hit(r, &mut Work::default());
            let b = w_off.closest_hit(r, &mut Work::default());
            bits(a) != bits(b)
        })
        .count();
    println!(
        "seed {seed}: {differ} of {} rays answered otherwise without the t bound",
        rays.len()
    );
    assert!(
        differ > rays.len() / 10,
        "the t bound changes nothing here: {differ}"
    );
    packets_are_single_rays(&s, on, &rays, true, "t bound on");
    packets_are_single_rays(&s, off, &rays, true, "t bound off");
}

/// Möller-Trumbore has no vector kernel: the walker asked for packets walks one ray at a
/// time (no packet unit), and its batches answer as the scalar walk's single queries. So
/// does a scalar kernel. The SSE2 kernel still walks batches as packets.
#[test]
fn without_the_vector_kernel_batches_walk_one_by_one() {
    let seed = test_seed("packet fallback", 0x9AC4_0008);
    let mut rng = Rng::new(seed);
    let tris = soup(&mut rng, 500);
    let s = scene_of(&tris);
    let bvh = Bvh::build(&s).unwrap();
    let rays = incoherent(&mut rng, &tris);
    let mt = Techniques::default().with_intersect(IntersectMethod::MollerTrumbore);
    for unit in units() {
        for (tech, isa, packets) in [
            (mt, Isa::detect(), None),
            (Techniques::default(), Isa::Scalar, None),
            (Techniques::default(), Isa::Sse2, Some(unit)),
        ] {
            let p = BvhWalker::with_packets(&s, &bvh, tech, isa, unit);
            assert_eq!(p.packets(), packets, "{tech:?} {isa:?}");
            let single = BvhWalker::<f32>::new(&s, &bvh, tech);
            let seen = batches_are_single_rays(
                &p,
                &single,
                &rays,
                &format!("{:?} {isa:?}", tech.intersect),
            );
            assert!(seen.hits > 100, "{seen:?}");
        }
    }
}

/// The empty scene: every ray of every batch misses and counts the root alone, as the
/// single-ray walk.
#[test]
fn empty_scene_is_missed_by_every_lane() {
    let s = crate::testing::empty_scene();
    let mut rng = Rng::new(test_seed("packet empty", 0x9AC4_0009));
    let rays: Vec<_> = random_rays(&mut rng, 100, 3.0)
        .into_iter()
        .map(|(o, d, t_max)| ray_of(o, d, t_max))
        .collect();
    let seen = packets_are_single_rays(&s, Techniques::default(), &rays, true, "empty");
    assert_eq!((seen.hits, seen.occluded), (0, 0));
    let bvh = Bvh::build(&s).unwrap();
    for unit in units() {
        let p = packet_walker(&s, &bvh, Techniques::default(), unit);
        let (_, work) = closest_batch(&p, &rays[..21]);
        assert!(
            work.iter().all(|w| *w == Work { cells: 1, tests: 0 }),
            "{work:?}"
        );
    }
}

/// A pile of copies of one triangle, each in another leaf, and far triangles between
/// them: every lane's hit is the lowest copy, whichever leaf its packet met first.
#[test]
fn coplanar_piles_go_to_the_lowest_index() {
    let t = [
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let mut rng = Rng::new(test_seed("packet ties", 0x9AC4_000A));
    let mut tris = Vec::new();
    for k in 0..40 {
        tris.extend(
            soup(&mut rng, 3)
                .into_iter()
                .map(|x| x.map(|v| v * 0.1 + Vec3::new(0.0, 0.0, 5.0 + k as f32))),
        );
        tris.push(t);
    }
    let s = scene_of(&tris);
    let first = tris.iter().position(|x| *x == t).unwrap() as u32;
    // Through the pile from both sides, from a spread of origins.
    let rays: Vec<_> = (0..200)
        .map(|i| {
            let (x, y) = (rng.range(-0.3, 0.3), rng.range(-0.8, 0.0));
            let z = if i % 2 == 0 { -3.0 } else { 50.0 };
            let o = DVec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), z);
            ray32(o, DVec3::new(x, y, 0.0) - o, 0.0, f32::MAX)
        })
        .collect();
    let bvh = Bvh::build(&s).unwrap();
    packets_are_single_rays(&s, Techniques::default(), &rays, true, "pile");
    for unit in units() {
        let p = packet_walker(&s, &bvh, Techniques::default(), unit);
        let (hits, _) = closest_batch(&p, &rays);
        let on_pile = hits
            .iter()
            .filter(|h| h.is_some_and(|h| h.t > 0.0 && h.b.iter().all(|&b| b > 0.0)))
            .count();
        for (i, h) in hits.iter().enumerate().step_by(2) {
            assert_eq!(h.map(|h| h.tri), Some(first), "{} ray {i}", unit.name());
        }
        assert!(on_pile > 100);
    }
}

/// The interval variants of `intervals_ending_inside_boxes_are_single_rays` against brute
/// force, for the scalar single-ray walk (the packets match it there, tested above): a hit
/// just short of t_max is missed where the computed entry distance of the hit's box rounds
/// past t_max (the box test pads the far distance, not the near one). Found at the default
/// seed: one ray of 3579 with t_max one ulp past its hit (`t_max = t + 1 ulp`), o (2.8368738,
/// 4.12502, -3.2389798), d (-5.3416476, -6.744644, 5.7069793), t_max 0.18542255
/// (0x3e3ddf69): brute force hits triangle 1267 (in the plane z = -2.180777, the leaf box's
/// lower z face) at t 0.18542254 (0x3e3ddf68); the box's entry distance computes to
/// 0.18542257 (0x3e3ddf6a) > t_max, so the walk (single ray and packets) culls the box and
/// misses. A finding about the BVH's box test, not about packets; ignored until the walk
/// is fixed (the renderer's shadow rays end at a light, so only a triangle through a
/// light could be missed).
#[test]
#[ignore = "the BVH box test (single ray and packets alike) culls a hit's box whose entry rounds past a t_max just past the hit: reported to the lead"]
fn intervals_ending_just_past_a_hit_are_brute_force() {
    let seed = test_seed("packet intervals", 0x9AC4_0005);
    let mut rng = Rng::new(seed);
    let tris = soup(&mut rng, 1500);
    let s = scene_of(&tris);
    let bvh = Bvh::build(&s).unwrap();
    let tech = Techniques::default();
    let single = BvhWalker::<f32>::new(&s, &bvh, tech);
    let names = [
        "t_max = t",
        "t_max = t + 1 ulp",
        "t_max = 0.999 t",
        "t_max = t / 2",
        "t_min = t / 2",
        "t_min = t",
        "t_min = t - 1 ulp",
    ];
    let mut missed = [0usize; 7];
    let mut first = Vec::new();
    for r in incoherent(&mut rng, &tris) {
        let Some(h) = single.closest_hit(&r, &mut Work::default()) else {
            continue;
        };
        let t = h.t;
        let variants = [
            Ray { t_max: t, ..r },
            Ray {
                t_max: t.next_up(),
                ..r
            },
            Ray {
                t_max: t * 0.999,
                ..r
            },
            Ray {
                t_max: t * 0.5,
                ..r
            },
            Ray {
                t_min: t * 0.5,
                ..r
            },
            Ray { t_min: t, ..r },
            Ray {
                t_min: t.next_down(),
                ..r
            },
        ];
        for (k, v) in variants.iter().enumerate() {
            let want = brute_force(v, single.tris(), &tech);
            let got = single.closest_hit(v, &mut Work::default());
            if bits(got) != bits(want) {
                missed[k] += 1;
                if first.len() < 3 {
                    first.push(format!(
                        "{}: {v:?}: walk {got:?}, brute force {want:?}",
                        names[k]
                    ));
                }
            }
        }
    }
    for (n, m) in names.iter().zip(missed) {
        println!("{n}: {m} rays answered otherwise than brute force");
    }
    assert!(
        missed.iter().all(|&m| m == 0),
        "seed {seed}: {missed:?}, first {first:#?}"
    );
}
