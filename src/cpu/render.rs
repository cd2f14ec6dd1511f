//! The CPU reference renderer: recursive Whitted ray tracing over the uniform or irregular grid,
//! generic over precision (f64 is the ground truth, f32 mirrors the GPU). Rows are rendered
//! in parallel with rayon; every pixel is computed independently, so the image does not
//! depend on the thread count, and a region of the image (`--tile`, `--region`) has the
//! same bits as the same pixels of the whole.

use rayon::prelude::*;

use super::real::{Real, V3};
use super::shade::{albedo, light_term, offset_origin_with, secondary, shadow_origin, surface};
use super::traverse::{CellWalk, Hit, Ray, Work};
use super::walker::Walker;
use crate::accel::AccelRef;
use crate::image_io::Image;
use crate::output::{Aov, AovPixel, RayCounts};
use crate::progress::Progress;
use crate::region::Region;
use crate::scene::{camera, Scene};
use crate::technique::Techniques;

/// Per-row tallies, summed after the parallel loop so counting stays off shared state.
#[derive(Default, Clone, Copy)]
struct Tally {
    primary: u64,
    shadow: u64,
    reflected: u64,
    refracted: u64,
    work: Work,
}

/// A scene prepared for CPU rendering in precision `T`.
pub struct CpuRenderer<'a, T> {
    scene: &'a Scene,
    /// The camera primary rays start from (the scene's, or a frame's of an animation).
    camera: crate::scene::Camera,
    walker: Walker<'a, T>,
    max_depth: u32,
    background: V3<T>,
    ambient: V3<T>,
    techniques: Techniques,
}

/// Output of a CPU render: the one backend output type, with `work` always counted.
pub type CpuOutput = crate::output::BackendOutput;

impl<'a, T: Real> CpuRenderer<'a, T> {
    /// Prepares `scene` with its acceleration structure (a `&Grid`, `&IrregularGrid` or
    /// `&Accel`); `max_depth` bounds the recursion; `techniques` selects the robustness
    /// techniques (`Techniques::default()` for the normal ones).
    pub fn new(
        scene: &'a Scene,
        accel: impl Into<AccelRef<'a>>,
        max_depth: u32,
        techniques: Techniques,
    ) -> Self {
        CpuRenderer {
            scene,
            camera: scene.camera,
            walker: Walker::new(scene, accel.into(), techniques),
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
        let verts = &self.walker.tris()[hit.tri as usize];
        let sp = surface(self.scene, verts, hit, ray.d);
        let m = &self.scene.materials[sp.material as usize];
        let alb = albedo(m, sp.p);
        let v = -ray.d;
        let mut color = alb.mul_elem(self.ambient) * T::from_f32(m.ka);
        for light in &self.scene.lights {
            let lp = V3::<T>::from_vec3(light.position);
            let to_l = lp - sp.p;
            if to_l.dot(sp.nf) <= T::ZERO || sp.ns.dot(to_l) <= T::ZERO {
                continue; // below the geometric or shading horizon
            }
            let o = shadow_origin(&sp, to_l, self.techniques);
            let dl = lp - o;
            let dist = dl.length();
            let l = dl * (T::ONE / dist);
            tally.shadow += 1;
            let shadow = Ray {
                o,
                d: l,
                t_min: T::ZERO,
                t_max: dist,
            };
            if self.walker.any_hit(&shadow, &mut tally.work) {
                continue;
            }
            color = color + light_term(m, alb, &sp, l, v, V3::from_vec3(light.radiance()));
        }
        if depth < self.max_depth && (m.reflects() || m.refracts()) {
            let s = secondary(m, &sp, ray.d);
            // Reflected child first, then refracted: the order the GPU walks the tree in.
            for (k, dir, refracted) in [(s.kr, s.reflected, false), (s.kt, s.refracted, true)] {
                if k.max_elem() > T::ZERO {
                    if refracted {
                        tally.refracted += 1;
                    } else {
                        tally.reflected += 1;
                    }
                    let r = Ray {
                        o: offset_origin_with(&sp, dir, self.techniques.offset),
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
        let rows: Vec<(Vec<f32>, Vec<AovPixel>, Tally)> = (region.y0..region.y1)
            .into_par_iter()
            .map(|j| {
                let mut tally = Tally::default();
                let mut rgb = Vec::with_capacity(rw as usize * 3);
                let mut aov = Vec::with_capacity(rw as usize);
                for i in region.x0..region.x1 {
                    let mut sum = V3::splat(T::ZERO);
                    for (k, &(ox, oy)) in offsets.iter().enumerate() {
                        let ray = self.primary_ray(w, h, i as f64 + ox, j as f64 + oy);
                        tally.primary += 1;
                        let before = tally.work;
                        let hit = self.walker.closest_hit(&ray, &mut tally.work);
                        if k == 0 {
                            let steps = (tally.work.cells - before.cells)
                                + (tally.work.tests - before.tests);
                            aov.push(self.aov_of(&ray, hit.as_ref(), steps));
                        }
                        let c = match hit {
                            None => self.background,
                            Some(h) => self.shade(&ray, &h, 0, &mut tally),
                        };
                        sum = sum + c;
                    }
                    let c = sum * inv;
                    rgb.extend([c.x, c.y, c.z].map(|v| v.to_f64() as f32));
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
