//! Pinhole camera. The primary-ray formula is the contract shared by every backend:
//! f = normalize(look_at - eye), r = normalize(f x up), u = r x f, s = tan(vfov/2),
//! dir(i, j) = normalize(f + (2(i+0.5)/W - 1)·s·(W/H)·r + (1 - 2(j+0.5)/H)·s·u), j = 0 at the
//! top. Every backend takes its primary directions from [`Camera::direction_at`] in f64 (the
//! GPU as a texture the host fills; the compute kernel computes the same bits itself, its
//! GLSL twin being `glsl120/camera.glsl`), so GL and the f32 CPU trace the same rays bit for bit.
//! [`Camera::window_corners`] gives the thesis's form (eye plus the four corners of the
//! window on the projection plane at distance 1), which spans the same rays by bilinear
//! interpolation.

use glam::{DVec3, Vec3};

/// A pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: Vec3,
    /// Point the camera looks at.
    pub look_at: Vec3,
    /// Approximate up direction.
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub vfov_deg: f32,
}

/// The camera's orthonormal frame in f64.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// Eye position.
    pub eye: DVec3,
    /// Forward unit vector.
    pub f: DVec3,
    /// Right unit vector.
    pub r: DVec3,
    /// Up unit vector (r x f).
    pub u: DVec3,
    /// tan(vfov / 2).
    pub s: f64,
}

impl Frame {
    /// [`Camera::direction_at`] of the camera this frame is of: the same bits, without
    /// working out the frame (a tangent and two normalisations) again for every ray.
    pub fn direction_at(&self, w: u32, h: u32, px: f64, py: f64) -> DVec3 {
        let (fa, b) = self.direction_terms(w, h, px, py);
        (fa + b * self.u).normalize()
    }

    /// The two terms of [`Frame::direction_at`]'s unnormalised direction `f + a r + b u`:
    /// `f + a r` (from the column, `px`) and `b` (from the row, `py`), the same operations.
    /// The compute kernel gets them from the host per column and row (its camera tables).
    pub fn direction_terms(&self, w: u32, h: u32, px: f64, py: f64) -> (DVec3, f64) {
        let aspect = w as f64 / h as f64;
        let a = (2.0 * px / w as f64 - 1.0) * self.s * aspect;
        let b = (1.0 - 2.0 * py / h as f64) * self.s;
        (self.f + a * self.r, b)
    }

    /// [`Frame::direction_at`] of each position (`px[k]`, `py[k]`), into `out` as three
    /// coordinate arrays (resized to the positions' count): the same bits, computed as
    /// one loop over arrays, which the widest vector unit of this CPU runs several
    /// positions at a time (the loop is compiled once per unit and picked at run time;
    /// vectorising keeps each IEEE operation, so every lane rounds as the scalar code).
    pub fn directions(&self, w: u32, h: u32, px: &[f64], py: &[f64], out: &mut [Vec<f64>; 3]) {
        assert_eq!(px.len(), py.len());
        for o in out.iter_mut() {
            o.clear();
            o.resize(px.len(), 0.0);
        }
        let [x, y, z] = out;
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU has AVX-512F, checked just above.
                return unsafe { directions_avx512(self, w, h, px, py, x, y, z) };
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has AVX2, checked just above.
                return unsafe { directions_avx2(self, w, h, px, py, x, y, z) };
            }
        }
        directions_soa(self, w, h, px, py, x, y, z);
    }
}

/// [`Frame::directions`]' loop: [`Frame::direction_at`] and glam's `normalize` operation for
/// operation (`v * (1 / sqrt((x x + y y) + z z))`).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn directions_soa(
    fr: &Frame,
    w: u32,
    h: u32,
    px: &[f64],
    py: &[f64],
    dx: &mut [f64],
    dy: &mut [f64],
    dz: &mut [f64],
) {
    let aspect = w as f64 / h as f64;
    let (wf, hf) = (w as f64, h as f64);
    let n = px.len();
    let (py, dx, dy, dz) = (&py[..n], &mut dx[..n], &mut dy[..n], &mut dz[..n]);
    for k in 0..n {
        let a = (2.0 * px[k] / wf - 1.0) * fr.s * aspect;
        let b = (1.0 - 2.0 * py[k] / hf) * fr.s;
        let x = fr.f.x + a * fr.r.x + b * fr.u.x;
        let y = fr.f.y + a * fr.r.y + b * fr.u.y;
        let z = fr.f.z + a * fr.r.z + b * fr.u.z;
        let inv = 1.0 / (x * x + y * y + z * z).sqrt();
        dx[k] = x * inv;
        dy[k] = y * inv;
        dz[k] = z * inv;
    }
}

/// Defines `$name`, [`directions_soa`] compiled with the target feature `$feature`.
macro_rules! directions_for {
    ($name:ident, $feature:literal) => {
        #[doc = concat!("[`directions_soa`] compiled for `", $feature, "`.")]
        ///
        /// # Safety
        /// The CPU must have that feature.
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $feature)]
        #[allow(clippy::too_many_arguments)]
        unsafe fn $name(
            fr: &Frame,
            w: u32,
            h: u32,
            px: &[f64],
            py: &[f64],
            dx: &mut [f64],
            dy: &mut [f64],
            dz: &mut [f64],
        ) {
            directions_soa(fr, w, h, px, py, dx, dy, dz)
        }
    };
}

directions_for!(directions_avx512, "avx512f");
directions_for!(directions_avx2, "avx2");

/// The least sine of the angle between a scene file's viewing direction and its `up`
/// (about 1e-6 rad): closer, f32 rounding can hide the degenerate frame from
/// [`Camera::check`] and the image spins with the rounding.
pub const MIN_UP_SINE: f64 = 1e-6;

/// True when `up` is within [`MIN_UP_SINE`] of the viewing direction `view` (either way):
/// the one rule of `[camera]`, keyframes and orbits.
pub fn up_parallel(view: DVec3, up: DVec3) -> bool {
    view.normalize().cross(up.normalize()).length() < MIN_UP_SINE
}

impl Camera {
    /// Checks that the camera defines a frame (distinct eye and target, up not parallel).
    pub fn check(&self) -> Result<(), String> {
        // A NaN up would pass the tests below (NaN compares false), so refuse it first.
        if !(self.eye.is_finite() && self.look_at.is_finite() && self.up.is_finite()) {
            return Err("a camera position or direction is not finite".into());
        }
        let f = (self.look_at - self.eye).as_dvec3();
        if f.length() == 0.0 || !f.is_finite() {
            return Err("eye and look_at coincide".into());
        }
        if self.up.as_dvec3().length() == 0.0 {
            return Err("up is zero".into());
        }
        if f.normalize().cross(self.up.as_dvec3()).length() < 1e-9 {
            return Err("up is parallel to the viewing direction".into());
        }
        if !(self.vfov_deg > 0.0 && self.vfov_deg < 180.0) {
            return Err(format!("vfov {} is outside (0, 180)", self.vfov_deg));
        }
        Ok(())
    }

    /// The camera frame, computed in f64.
    pub fn frame(&self) -> Frame {
        let f = (self.look_at.as_dvec3() - self.eye.as_dvec3()).normalize();
        let r = f.cross(self.up.as_dvec3()).normalize();
        let u = r.cross(f);
        let s = (self.vfov_deg as f64).to_radians().mul_add(0.5, 0.0).tan();
        Frame {
            eye: self.eye.as_dvec3(),
            f,
            r,
            u,
            s,
        }
    }

    /// Primary ray direction (unit, f64) through image-plane position (px, py) in pixels,
    /// where (i + 0.5, j + 0.5) is the centre of pixel (i, j).
    pub fn direction_at(&self, w: u32, h: u32, px: f64, py: f64) -> DVec3 {
        self.frame().direction_at(w, h, px, py)
    }

    /// Primary ray direction through the centre of pixel (i, j).
    pub fn pixel_direction(&self, w: u32, h: u32, i: u32, j: u32) -> DVec3 {
        self.direction_at(w, h, i as f64 + 0.5, j as f64 + 0.5)
    }

    /// The thesis's window on the projection plane (distance 1 from the eye):
    /// corners `[bottom_left, bottom_right, top_right, top_left]` as points, so that the
    /// unnormalised direction at normalised window coordinates (x, y) in the unit square (y up) is
    /// `lerp(lerp(bl, br, x), lerp(tl, tr, x), y) - eye`.
    pub fn window_corners(&self, w: u32, h: u32) -> [DVec3; 4] {
        let fr = self.frame();
        let aspect = w as f64 / h as f64;
        let c = fr.eye + fr.f;
        let rx = fr.s * aspect * fr.r;
        let uy = fr.s * fr.u;
        [c - rx - uy, c + rx - uy, c + rx + uy, c - rx + uy]
    }
}

/// Sub-pixel sample offsets for `spp` samples: stratified on a ceil(sqrt(spp))² grid with
/// jitter from a fixed seed. The same pattern is used for every pixel and every backend, so
/// CPU and GPU render identical sample positions (the GPU receives them as uniforms).
pub fn sample_offsets(spp: u32) -> Vec<(f64, f64)> {
    if spp <= 1 {
        return vec![(0.5, 0.5)];
    }
    let m = (spp as f64).sqrt().ceil() as u32;
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        // splitmix64: small, well known, and reproducible everywhere.
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    };
    // Spread the spp samples over the m*m strata with a fixed stride so that a non-square
    // count still covers the pixel evenly.
    (0..spp)
        .map(|k| {
            let cell = (k as u64 * (m * m) as u64 / spp as u64) as u32;
            let (sx, sy) = (cell % m, cell / m);
            let jx = next();
            let jy = next();
            ((sx as f64 + jx) / m as f64, (sy as f64 + jy) / m as f64)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera {
            eye: Vec3::new(1.0, 2.0, 3.0),
            look_at: Vec3::new(-0.5, 0.25, -4.0),
            up: Vec3::Y,
            vfov_deg: 50.0,
        }
    }

    #[test]
    fn centre_ray_is_forward_for_odd_sizes() {
        let c = cam();
        let d = c.pixel_direction(5, 3, 2, 1);
        let f = (c.look_at - c.eye).as_dvec3().normalize();
        assert!((d - f).length() < 1e-15, "{d} vs {f}");
    }

    #[test]
    fn formula_matches_explicit_expression() {
        let c = cam();
        let (w, h) = (7u32, 4u32);
        let f = (c.look_at.as_dvec3() - c.eye.as_dvec3()).normalize();
        let r = f.cross(c.up.as_dvec3()).normalize();
        let u = r.cross(f);
        let s = (50f64.to_radians() / 2.0).tan();
        for j in 0..h {
            for i in 0..w {
                let a = (2.0 * (i as f64 + 0.5) / w as f64 - 1.0) * s * (w as f64 / h as f64);
                let b = (1.0 - 2.0 * (j as f64 + 0.5) / h as f64) * s;
                let want = (f + a * r + b * u).normalize();
                let got = c.pixel_direction(w, h, i, j);
                assert!((want - got).length() < 1e-15);
            }
        }
        // Top-left pixel looks up and left.
        let tl = c.pixel_direction(w, h, 0, 0);
        assert!(tl.dot(r) < 0.0 && tl.dot(u) > 0.0);
    }

    #[test]
    fn thesis_corners_give_the_same_rays() {
        let c = cam();
        let (w, h) = (9u32, 6u32);
        let [bl, br, tr, tl] = c.window_corners(w, h);
        for j in 0..h {
            for i in 0..w {
                let x = (i as f64 + 0.5) / w as f64;
                let y = 1.0 - (j as f64 + 0.5) / h as f64;
                let p = bl.lerp(br, x).lerp(tl.lerp(tr, x), y);
                let d = (p - c.eye.as_dvec3()).normalize();
                assert!((d - c.pixel_direction(w, h, i, j)).length() < 1e-14);
            }
        }
    }

    #[test]
    fn sample_offsets_are_stratified_and_deterministic() {
        let a = sample_offsets(16);
        assert_eq!(a, sample_offsets(16));
        let mut seen = [false; 16];
        for &(x, y) in &a {
            assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
            seen[(y * 4.0) as usize * 4 + (x * 4.0) as usize] = true;
        }
        assert!(seen.iter().all(|&s| s), "one sample per stratum");
        assert_eq!(sample_offsets(1), vec![(0.5, 0.5)]);
        assert_eq!(sample_offsets(5).len(), 5);
    }

    /// The array form, on whichever unit this CPU picks, against the ray-by-ray form bit
    /// for bit: odd counts (a vector loop's remainder), sub-pixel positions, a wide and a
    /// tall image, a camera looking down an axis.
    #[test]
    fn directions_are_direction_at() {
        let cams = [
            Camera {
                eye: Vec3::new(0.3, 1.7, -4.2),
                look_at: Vec3::new(-0.1, 0.2, 0.9),
                up: Vec3::Y,
                vfov_deg: 37.0,
            },
            Camera {
                eye: Vec3::new(0.0, 0.0, 5.0),
                look_at: Vec3::ZERO,
                up: Vec3::Y,
                vfov_deg: 90.0,
            },
        ];
        for cam in cams {
            let fr = cam.frame();
            for (w, h) in [(640, 480), (3, 1000), (1, 1)] {
                for n in [1, 7, 8, 9, 33] {
                    let px: Vec<f64> = (0..n)
                        .map(|k| (k * 37 % w as usize) as f64 + 0.25)
                        .collect();
                    let py: Vec<f64> = (0..n).map(|k| (k * 11 % h as usize) as f64 + 0.8).collect();
                    let mut out = Default::default();
                    fr.directions(w, h, &px, &py, &mut out);
                    for k in 0..n {
                        let want = cam.direction_at(w, h, px[k], py[k]);
                        let got = [out[0][k], out[1][k], out[2][k]];
                        assert_eq!(
                            got.map(f64::to_bits),
                            want.to_array().map(f64::to_bits),
                            "{w}x{h} position {k} of {n}"
                        );
                    }
                }
            }
        }
    }
}
