//! Test-only helpers shared by the unit tests of every layer (declared `#[cfg(test)]` in
//! `lib.rs`): the seeded generator and its seed, small scenes (empty, from triangles, random
//! soups, closed spheres), random and aimed rays, primary rays of a scene's camera, and a
//! rayon pool of a given size; the 8-bit conversion's inputs and check. One home, so the
//! grid, irregular-grid, traversal, shading, layout and read-back tests build their inputs
//! the same way. (Not `gpu::context`'s GL `test_support`.)

use glam::{DVec3, Vec3};

use crate::cpu::real::{Real, V3};
use crate::cpu::traverse::Ray;
use crate::scene::{Camera, Material, Scene};

/// SplitMix64: a tiny deterministic generator so tests need no extra crate.
pub(crate) struct Rng(u64);

impl Rng {
    /// A generator started at `seed`.
    pub(crate) fn new(seed: u64) -> Self {
        Rng(seed)
    }
    /// The next 64 random bits.
    pub(crate) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub(crate) fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [lo, hi).
    pub(crate) fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f64()
    }
    /// Each component uniform in [lo, hi).
    pub(crate) fn dvec3(&mut self, lo: f64, hi: f64) -> DVec3 {
        DVec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
}

/// Seed for randomized tests: `FRAGTRACE_TEST_SEED` when set, else `default`. Always
/// printed so a failure can be replayed.
pub(crate) fn test_seed(name: &str, default: u64) -> u64 {
    let seed = std::env::var("FRAGTRACE_TEST_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default);
    println!("{name}: seed {seed} (override with FRAGTRACE_TEST_SEED)");
    seed
}

/// An empty scene with one material.
pub(crate) fn empty_scene() -> Scene {
    let mut s = Scene::empty(Camera {
        eye: Vec3::new(0.0, 0.0, 5.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 45.0,
    });
    s.add_material(Material::default());
    s
}

/// A scene of the given triangles.
pub(crate) fn scene_of(tris: &[[Vec3; 3]]) -> Scene {
    let mut s = empty_scene();
    for t in tris {
        s.add_triangle(t[0], t[1], t[2], 0);
    }
    s
}

/// Random triangle soup in roughly `[-3, 3]^3`: mostly small triangles, some large, some
/// degenerate and some axis-aligned.
pub(crate) fn soup(rng: &mut Rng, n: usize) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|i| {
            let a = rng.dvec3(-3.0, 3.0);
            let s = if i % 7 == 0 { 3.0 } else { 0.5 };
            let mut b = a + rng.dvec3(-s, s);
            let mut c = a + rng.dvec3(-s, s);
            match i % 11 {
                0 => c = b,
                1 => (b, c) = (a, a),
                2 => (b.z, c.z) = (a.z, a.z),
                3 => c = a + (b - a) * 0.25,
                _ => {}
            }
            [a.as_vec3(), b.as_vec3(), c.as_vec3()]
        })
        .collect()
}

/// A sparse scene: a soup of `n` triangles shrunk by `scale`, one in `period` scattered on
/// the floor of the `[-3, 3]^3` box, the others in two clusters at its opposite corners
/// (alternating): grids over it have empty top cells beside cut ones, and many levels.
pub(crate) fn corner_clusters(
    rng: &mut Rng,
    n: usize,
    period: usize,
    scale: f32,
) -> Vec<[Vec3; 3]> {
    let mut t = soup(rng, n);
    for (i, tri) in t.iter_mut().enumerate() {
        let at = match i % period {
            0 => Vec3::new(
                rng.f64() as f32 * 6.0 - 3.0,
                -3.0,
                rng.f64() as f32 * 6.0 - 3.0,
            ),
            k if k % 2 == 0 => Vec3::splat(-3.0),
            _ => Vec3::splat(3.0),
        };
        *tri = tri.map(|v| at + v * scale);
    }
    t
}

/// Closed UV sphere of `n` x `2n` quads (each two triangles) with bitwise-shared vertices.
pub(crate) fn sphere(center: Vec3, radius: f32, n: usize) -> Vec<[Vec3; 3]> {
    let p = |i: usize, j: usize| {
        let th = std::f32::consts::PI * i as f32 / n as f32;
        let ph = std::f32::consts::PI * (j % (2 * n)) as f32 / n as f32;
        if i == 0 || i == n {
            // The poles: one vertex, not 2n almost-equal ones.
            return center + Vec3::new(0.0, if i == 0 { radius } else { -radius }, 0.0);
        }
        center + radius * Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin())
    };
    let mut tris = Vec::new();
    for i in 0..n {
        for j in 0..2 * n {
            let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    tris
}

/// Runs `f` in a rayon pool of `n` threads (builds must not depend on the count).
pub(crate) fn with_threads<T: Send>(n: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .expect("thread pool")
        .install(f)
}

/// The ray (o, d) over (0, t_max) in precision `T`, as the random ray lists give them.
pub(crate) fn ray_of<T: Real>(o: DVec3, d: DVec3, t_max: f64) -> Ray<T> {
    Ray {
        o: V3::from_dvec3(o),
        d: V3::from_dvec3(d),
        t_min: T::ZERO,
        t_max: T::from_f64(t_max),
    }
}

/// Random rays: from inside and outside the box `[-r, r]^3` towards random points in it,
/// some with zeroed direction components (axis-parallel) and some with a finite t_max.
pub(crate) fn random_rays(rng: &mut Rng, n: usize, r: f64) -> Vec<(DVec3, DVec3, f64)> {
    (0..n)
        .map(|i| {
            let o = rng.dvec3(-2.0 * r, 2.0 * r);
            let mut d = rng.dvec3(-r, r) - o;
            match i % 9 {
                0 => d.x = 0.0,
                1 => (d.y, d.z) = (0.0, 0.0),
                _ => {}
            }
            if d == DVec3::ZERO {
                d = DVec3::X;
            }
            let t_max = if i % 5 == 0 {
                rng.range(0.2, 1.0)
            } else {
                1.0e30
            };
            (o, d, t_max)
        })
        .collect()
}

/// Rays from random origins through `target` (and axis-parallel ones where possible).
pub(crate) fn rays_through(rng: &mut Rng, target: DVec3, out: &mut Vec<(DVec3, DVec3, f64)>) {
    for _ in 0..3 {
        let o = target + rng.dvec3(-4.0, 4.0);
        out.push((o, target - o, 1.0e30));
    }
    let a = (rng.f64() * 3.0) as usize % 3;
    let mut o = target;
    o[a] -= 5.0;
    let mut d = DVec3::ZERO;
    d[a] = 1.0;
    out.push((o, d, 1.0e30));
}

/// Primary rays of `s.camera` at w x h (one sample at each pixel centre, as the CPU
/// renderer's first sample).
pub(crate) fn primary_rays(s: &Scene, w: u32, h: u32) -> Vec<(DVec3, DVec3)> {
    let (ox, oy) = crate::scene::camera::sample_offsets(1)[0];
    let eye = s.camera.eye.as_dvec3();
    (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .map(|(i, j)| {
            (
                eye,
                s.camera.direction_at(w, h, i as f64 + ox, j as f64 + oy),
            )
        })
        .collect()
}

/// pbrt's gamma(n) in f64: `n u / (1 - n u)`, u the unit roundoff, for bounds computed in
/// the tests independently of `Real::gamma`.
pub(crate) fn gamma64(n: f64) -> f64 {
    let u = f64::EPSILON / 2.0;
    n * u / (1.0 - n * u)
}

/// The built-in scene and its irregular grid (default configuration).
pub(crate) fn builtin_irregular() -> (Scene, crate::accel::Accel) {
    use crate::accel::{Accel, AccelKind, GridConfig, IrregularConfig};
    let scene = crate::scene::builtin_scene();
    let accel = Accel::build(
        &scene,
        AccelKind::Irregular,
        &GridConfig::default(),
        &IrregularConfig::default(),
    )
    .unwrap();
    (scene, accel)
}

/// `n` linear values spanning everything the 8-bit conversion meets, in an order drawn
/// from `seed` (printed): each code's threshold and the float just below it (so codes 0
/// through 255 and every step between them), 0 and -0, subnormals, values above 1 up to
/// the largest float, negative values, both infinities, NaNs of either sign and payload,
/// and uniform values in [0, 1]; cycled to fill `n`.
pub(crate) fn full_range_values(n: usize, seed: u64) -> Vec<f32> {
    println!("full_range_values seed = {seed:#x}");
    let t = crate::image_io::srgb8_thresholds();
    let mut rng = Rng::new(seed);
    let mut set: Vec<f32> = t
        .iter()
        .flat_map(|&v| [v, f32::from_bits(v.to_bits() - 1)])
        .collect();
    set.extend([
        0.0,
        -0.0,
        f32::from_bits(1),
        f32::MIN_POSITIVE,
        1.0,
        f32::from_bits(1f32.to_bits() + 1),
        1.5,
        1e30,
        f32::MAX,
        -1e-30,
        -0.5,
        -1.0,
        f32::MIN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        -f32::NAN,
        f32::from_bits(0x7fc0_1234),
    ]);
    set.extend((0..64).map(|_| rng.f64() as f32));
    (0..n)
        .map(|k| {
            if k % set.len() == 0 {
                // A fresh order for each round, so neighbours differ between rounds.
                for i in (1..set.len()).rev() {
                    set.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
                }
            }
            set[k % set.len()]
        })
        .collect()
}

/// Asserts that `bytes` are the host's 8-bit sRGB of the linear values `rgb`, byte for
/// byte (naming the first that differs, with its value), and, where `rgb` is long enough
/// to hold them all, that every code appears: the check both GPU conversions
/// (`srgb8.frag`, `srgb8.comp`) are held to. `label` names the frame.
pub(crate) fn assert_host_srgb8(label: &str, rgb: &[f32], bytes: &[u8]) {
    let host: Vec<u8> = rgb.iter().map(|&v| crate::image_io::srgb8(v)).collect();
    assert_eq!(bytes.len(), host.len(), "{label}");
    let diff: Vec<_> = (0..host.len()).filter(|&b| bytes[b] != host[b]).collect();
    assert!(
        diff.is_empty(),
        "{label}: {} bytes differ, first at {:?}: value {:e}, gpu {}, host {}",
        diff.len(),
        diff.first(),
        rgb[diff[0]],
        bytes[diff[0]],
        host[diff[0]]
    );
    if rgb.len() >= 2 * 256 + 64 {
        assert!(
            (0..=255u8).all(|c| host.contains(&c)),
            "{label}: every code"
        );
    }
}
