//! The CPU reference renderer: recursive Whitted ray tracing over the uniform or irregular
//! grid or the BVH,
//! generic over precision (f64 is the ground truth, f32 mirrors the GPU). Rows are rendered
//! in parallel with rayon; every pixel is computed independently, so the image does not
//! depend on the thread count, and a region of the image (`--tile`, `--region`) has the
//! same bits as the same pixels of the whole.

use rayon::prelude::*;

use super::real::{Real, V3};
use super::shade::{
    albedo, light_term, offset_origin_with, secondary, shadow_origin, surface, SurfacePoint,
};
use super::traverse::{Hit, Ray, Trace, Work};
use super::walker::Walker;
use crate::accel::GridRef;
use crate::image_io::Image;
use crate::output::{Aov, AovPixel, RayCounts};
use crate::progress::Progress;
use crate::region::Region;
use crate::scene::{camera, Light, Material, Scene};
use crate::technique::Techniques;

/// Most primary rays traced as one batch (whole pixels: all samples of a pixel are in one).
const BATCH_RAYS: usize = 256;

/// A hit being shaded: its surface, material and albedo, the view direction and the
/// colour summed so far.
struct Shading<'s, T> {
    sp: SurfacePoint<T>,
    m: &'s Material,
    alb: V3<T>,
    v: V3<T>,
    color: V3<T>,
}

/// Per-row tallies, summed after the parallel loop so counting stays off shared state.
#[derive(Default, Clone, Copy)]
struct Tally {
    primary: u64,
    shadow: u64,
    reflected: u64,
    refracted: u64,
    work: Work,
}

/// A scene prepared for CPU rendering in precision `T`, its structure walked by `W` (the
/// grids' scalar [`Walker`] by default; the vectorised f32 walk of the grids is
/// [`SimdWalker`](super::simd_walk::SimdWalker), the BVH's
/// [`BvhWalker`](super::traverse_bvh::BvhWalker)).
pub struct CpuRenderer<'a, T, W = Walker<'a, T>> {
    scene: &'a Scene,
    /// The camera primary rays start from (the scene's, or a frame's of an animation).
    camera: crate::scene::Camera,
    walker: W,
    max_depth: u32,
    background: V3<T>,
    ambient: V3<T>,
    techniques: Techniques,
}

/// Output of a CPU render: the one backend output type, with `work` always counted.
pub type CpuOutput = crate::output::BackendOutput;

impl<'a, T: Real> CpuRenderer<'a, T> {
    /// Prepares `scene` with its grid (a `&Grid`, `&IrregularGrid` or [`GridRef`]; the BVH
    /// goes through [`CpuRenderer::with_walker`]); `max_depth` bounds the recursion;
    /// `techniques` selects the robustness techniques (`Techniques::default()` for the
    /// normal ones).
    pub fn new(
        scene: &'a Scene,
        grid: impl Into<GridRef<'a>>,
        max_depth: u32,
        techniques: Techniques,
    ) -> Self {
        let walker = Walker::new(scene, grid, techniques);
        Self::with_walker(scene, walker, max_depth, techniques)
    }
}

impl<'a, T: Real, W: Trace<T>> CpuRenderer<'a, T, W> {
    /// Prepares `scene` with `walker` over its structure (built with the same
    /// `techniques`).
    pub fn with_walker(
        scene: &'a Scene,
        walker: W,
        max_depth: u32,
        techniques: Techniques,
    ) -> Self {
        CpuRenderer {
            scene,
            camera: scene.camera,
            walker,
            techniques,
            max_depth,
            background: V3::from_vec3(scene.background),
            ambient: V3::from_vec3(scene.ambient),
        }
    }

    /// Renders from `camera` from now on (a frame of an animation): nothing else changes,
    /// so the scene's converted geometry is kept.
    pub fn set_camera(&mut self, camera: crate::scene::Camera) {
        self.camera = camera;
    }

    /// Radiance along a unit-direction ray at recursion depth `depth` (primary = 0).
    fn radiance(&self, ray: &Ray<T>, depth: u32, tally: &mut Tally) -> V3<T> {
        match self.walker.closest_hit(ray, &mut tally.work) {
            None => self.background,
            Some(hit) => self.shade(ray, &hit, depth, tally),
        }
    }

    /// Whitted shading of a hit (see `cpu::shade` for the conventions).
    fn shade(&self, ray: &Ray<T>, hit: &Hit<T>, depth: u32, tally: &mut Tally) -> V3<T> {
        let mut s = self.begin(ray, hit);
        for light in &self.scene.lights {
            if let Some((shadow, l)) = self.shadow_ray(&s, light) {
                tally.shadow += 1;
                if !self.walker.any_hit(&shadow, &mut tally.work) {
                    s.color = s.color + self.light(&s, light, l);
                }
            }
        }
        self.finish(&s, ray, depth, tally)
    }

    /// [`CpuRenderer::shade`] of a batch of primary hits (`None` for a miss, which gets the
    /// background) into `out`: the same terms added in the same order for each ray, with
    /// the shadow rays to each light traced as one batch ([`Trace::any_hits`]).
    fn shade_batch(
        &self,
        rays: &[Ray<T>],
        hits: &[Option<Hit<T>>],
        tally: &mut Tally,
        out: &mut Vec<V3<T>>,
    ) {
        let mut shading: Vec<Option<Shading<'_, T>>> = rays
            .iter()
            .zip(hits)
            .map(|(ray, hit)| hit.as_ref().map(|h| self.begin(ray, h)))
            .collect();
        let mut shadows = Vec::with_capacity(rays.len());
        let mut lit = Vec::with_capacity(rays.len());
        let mut occluded = Vec::new();
        for light in &self.scene.lights {
            shadows.clear();
            lit.clear();
            for (i, s) in shading.iter().enumerate() {
                if let Some((shadow, l)) = s.as_ref().and_then(|s| self.shadow_ray(s, light)) {
                    shadows.push(shadow);
                    lit.push((i, l));
                }
            }
            tally.shadow += shadows.len() as u64;
            occluded.resize(shadows.len(), false);
            self.walker
                .any_hits(&shadows, &mut occluded, &mut tally.work);
            for (&(i, l), &blocked) in lit.iter().zip(&occluded) {
                if !blocked {
                    let s = shading[i].as_mut().expect("a shadow ray comes from a hit");
                    s.color = s.color + self.light(s, light, l);
                }
            }
        }
        out.clear();
        for (ray, s) in rays.iter().zip(&shading) {
            out.push(match s {
                None => self.background,
                Some(s) => self.finish(s, ray, 0, tally),
            });
        }
    }

    /// The surface, material and albedo of a hit, and its ambient term.
    #[inline]
    fn begin(&self, ray: &Ray<T>, hit: &Hit<T>) -> Shading<'a, T> {
        let verts = &self.walker.tris()[hit.tri as usize];
        let sp = surface(self.scene, verts, hit, ray.d);
        let m = &self.scene.materials[sp.material as usize];
        let alb = albedo(m, sp.p);
        let color = alb.mul_elem(self.ambient) * T::from_f32(m.ka);
        Shading {
            sp,
            m,
            alb,
            v: -ray.d,
            color,
        }
    }

    /// The shadow ray from the hit towards `light` and the unit direction to it, or `None`
    /// when the light is below the geometric or shading horizon.
    #[inline]
    fn shadow_ray(&self, s: &Shading<'_, T>, light: &Light) -> Option<(Ray<T>, V3<T>)> {
        let lp = V3::<T>::from_vec3(light.position);
        let to_l = lp - s.sp.p;
        if to_l.dot(s.sp.nf) <= T::ZERO || s.sp.ns.dot(to_l) <= T::ZERO {
            return None; // below the geometric or shading horizon
        }
        let o = shadow_origin(&s.sp, to_l, self.techniques);
        let dl = lp - o;
        let dist = dl.length();
        let l = dl * (T::ONE / dist);
        let shadow = Ray {
            o,
            d: l,
            t_min: T::ZERO,
            t_max: dist,
        };
        Some((shadow, l))
    }

    /// The term of an unoccluded `light` in direction `l`.
    #[inline]
    fn light(&self, s: &Shading<'_, T>, light: &Light, l: V3<T>) -> V3<T> {
        light_term(s.m, s.alb, &s.sp, l, s.v, V3::from_vec3(light.radiance()))
    }

    /// The shaded colour: the terms so far plus the reflected and refracted children.
    fn finish(&self, s: &Shading<'_, T>, ray: &Ray<T>, depth: u32, tally: &mut Tally) -> V3<T> {
        let (m, sp) = (s.m, &s.sp);
        let mut color = s.color;
        if depth < self.max_depth && (m.reflects() || m.refracts()) {
            let s = secondary(m, sp, ray.d);
            // Reflected child first, then refracted: the order the GPU walks the tree in.
            for (k, dir, refracted) in [(s.kr, s.reflected, false), (s.kt, s.refracted, true)] {
                if k.max_elem() > T::ZERO {
                    if refracted {
                        tally.refracted += 1;
                    } else {
                        tally.reflected += 1;
                    }
                    let r = Ray {
                        o: offset_origin_with(sp, dir, self.techniques.offset),
                        d: dir,
                        t_min: T::ZERO,
                        t_max: T::BIG,
                    };
                    color = color + self.radiance(&r, depth + 1, tally).mul_elem(k);
                }
            }
        }
        color
    }

    /// Primary ray for sample position (px, py) in pixel units.
    pub fn primary_ray(&self, w: u32, h: u32, px: f64, py: f64) -> Ray<T> {
        let cam = &self.camera;
        Ray {
            o: V3::from_vec3(cam.eye),
            d: V3::from_dvec3(cam.direction_at(w, h, px, py)),
            t_min: T::ZERO,
            t_max: T::BIG,
        }
    }

    /// Renders a W x H image with `spp` samples per pixel.
    pub fn render(&self, w: u32, h: u32, spp: u32) -> CpuOutput {
        self.render_with_progress(w, h, spp, &Progress::hidden())
    }

    /// [`CpuRenderer::render`], advancing `progress` by one per finished row.
    pub fn render_with_progress(&self, w: u32, h: u32, spp: u32, progress: &Progress) -> CpuOutput {
        self.render_region(w, h, Region::full(w, h), spp, progress)
    }

    /// The pixels of `region` of a W x H image, as an image (and AOVs) of the region's
    /// size. Each pixel's rays are those of the full image (the camera maps pixel (i, j)
    /// of W x H), so every pixel is bit-identical to the same pixel of a full render.
    /// `progress` advances by one per finished row of the region.
    pub fn render_region(
        &self,
        w: u32,
        h: u32,
        region: Region,
        spp: u32,
        progress: &Progress,
    ) -> CpuOutput {
        debug_assert!(region.x1 <= w && region.y1 <= h, "region inside the image");
        let offsets = camera::sample_offsets(spp);
        let inv = T::ONE / T::from_f32(offsets.len() as f32);
        let rw = region.width();
        let n_off = offsets.len();
        // Pixels per batch: their primary rays are traced, and their shadow rays to each
        // light, as one batch each.
        let batch = (BATCH_RAYS / n_off).max(1) as u32;
        let rows: Vec<(Vec<f32>, Vec<AovPixel>, Tally)> = (region.y0..region.y1)
            .into_par_iter()
            .map(|j| {
                let mut tally = Tally::default();
                let mut rgb = Vec::with_capacity(rw as usize * 3);
                let mut aov = Vec::with_capacity(rw as usize);
                let (mut rays, mut hits, mut work, mut colors) =
                    (Vec::new(), Vec::new(), Vec::new(), Vec::new());
                for i0 in (region.x0..region.x1).step_by(batch as usize) {
                    let i1 = (i0 + batch).min(region.x1);
                    rays.clear();
                    for i in i0..i1 {
                        for &(ox, oy) in &offsets {
                            rays.push(self.primary_ray(w, h, i as f64 + ox, j as f64 + oy));
                        }
                    }
                    tally.primary += rays.len() as u64;
                    hits.clear();
                    hits.resize(rays.len(), None);
                    work.clear();
                    work.resize(rays.len(), Work::default());
                    self.walker.closest_hits(&rays, &mut hits, &mut work);
                    for wk in &work {
                        tally.work.cells += wk.cells;
                        tally.work.tests += wk.tests;
                    }
                    self.shade_batch(&rays, &hits, &mut tally, &mut colors);
                    for p in 0..(i1 - i0) as usize {
                        let first = p * n_off;
                        let steps = work[first].cells + work[first].tests;
                        aov.push(self.aov_of(&rays[first], hits[first].as_ref(), steps));
                        let mut sum = V3::splat(T::ZERO);
                        for c in &colors[first..first + n_off] {
                            sum = sum + *c;
                        }
                        let c = sum * inv;
                        rgb.extend([c.x, c.y, c.z].map(|v| v.to_f64() as f32));
                    }
                }
                progress.inc(1);
                (rgb, aov, tally)
            })
            .collect();
        progress.finish();
        let (w, h) = (rw, region.height());
        let mut data = Vec::with_capacity((w * h * 3) as usize);
        let mut pixels = Vec::with_capacity((w * h) as usize);
        let mut total = Tally::default();
        for (rgb, aov, t) in rows {
            data.extend(rgb);
            pixels.extend(aov);
            total.primary += t.primary;
            total.shadow += t.shadow;
            total.reflected += t.reflected;
            total.refracted += t.refracted;
            total.work.cells += t.work.cells;
            total.work.tests += t.work.tests;
        }
        CpuOutput {
            image: Image::from_rgb(w, h, data),
            aov: Aov::from_pixels(w, h, &pixels),
            rays: RayCounts::new(
                total.primary,
                total.shadow,
                total.reflected,
                total.refracted,
            ),
            work: Some(crate::output::Work {
                cells: total.work.cells,
                tests: total.work.tests,
            }),
            gpu: None,
            srgb8: None,
            primary_steps: None,
            nonfinite: None,
        }
    }

    /// AOV values (depth, primitive id, geometric normal, steps) of a primary ray.
    fn aov_of(&self, ray: &Ray<T>, hit: Option<&Hit<T>>, steps: u64) -> AovPixel {
        match hit {
            None => AovPixel::miss(steps as f32),
            Some(hit) => {
                let verts = &self.walker.tris()[hit.tri as usize];
                let sp = surface(self.scene, verts, hit, ray.d);
                AovPixel {
                    depth: hit.t.to_f64() as f32,
                    primid: hit.tri as f32,
                    normal: sp.ng.to_dvec3().as_vec3().to_array(),
                    steps: steps as f32,
                }
            }
        }
    }
}
