//! The CPU reference renderer: recursive Whitted ray tracing over the uniform or irregular
//! grid or the BVH,
//! generic over precision (f64 is the ground truth, f32 mirrors the GPU). Rows are rendered
//! in parallel with rayon; every pixel is computed independently, so the image does not
//! depend on the thread count, and a region of the image (`--tile`, `--region`) has the
//! same bits as the same pixels of the whole.

use rayon::prelude::*;

mod tree;

use super::real::{Real, V3};
use super::shade::geometric_normal;
use super::shade_lanes::Dispatch;
use super::texture;
use super::traverse::{Hit, Ray, Trace, Work};
use super::walker::Walker;
use crate::accel::GridRef;
use crate::image_io::{self, Image};
use crate::output::{Aov, AovPixel, RayCounts, Readback};
use crate::progress::Progress;
use crate::region::Region;
use crate::scene::camera::Frame;
use crate::scene::texture::TriTex;
use crate::scene::{camera, Scene};
use crate::technique::Techniques;

/// Most primary rays traced as one batch (whole pixels: all samples of a pixel are in one).
const BATCH_RAYS: usize = 256;
/// Side of the square of pixels whose rays go together: rows are rendered in bands of
/// this many, and a batch orders its pixels in squares of this side (16 rays: one
/// AVX-512 packet at one sample per pixel).
const TILE: u32 = 4;

/// Per-row tallies, summed after the parallel loop so counting stays off shared state.
#[derive(Default, Clone, Copy)]
struct Tally {
    primary: u64,
    shadow: u64,
    reflected: u64,
    refracted: u64,
    work: Work,
    /// Cells plus tests of each pixel's first primary ray, summed (when the AOVs, which
    /// hold them per pixel, are not kept).
    primary_steps: u64,
    /// Pixels with a NaN or infinite colour (counted when only 8-bit sRGB is kept).
    nonfinite: u64,
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
    /// Each triangle's unit geometric normal, worked out once (`shade::geometric_normal`)
    /// rather than at every hit.
    ng: Vec<V3<T>>,
    /// Each of the scene's own triangles' texture record when the scene has textures or
    /// vertex colours (else empty: an untextured scene stores and runs nothing for them).
    /// An instanced triangle's is worked out at its hit (`TriTex::of`), the mesh stored
    /// once.
    tex: Vec<TriTex>,
    /// True when some material has a texture: rays then carry cones.
    textured: bool,
    /// True when the scene or an instanced mesh has vertex colours.
    coloured: bool,
    /// The compilation of the direct-lighting lanes that runs (the widest the CPU has).
    dispatch: Dispatch,
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
        let ng = walker.tris().par_iter().map(geometric_normal).collect();
        let textured = scene.has_textures();
        let coloured = scene.has_vertex_colors();
        let tex = if textured || coloured {
            (0..scene.triangles.len())
                .into_par_iter()
                .map(|i| TriTex::of(scene, i))
                .collect()
        } else {
            Vec::new()
        };
        CpuRenderer {
            scene,
            camera: scene.camera,
            ng,
            tex,
            textured,
            coloured,
            dispatch: Dispatch::detect(),
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

    /// Primary ray for sample position (px, py) in pixel units.
    pub fn primary_ray(&self, w: u32, h: u32, px: f64, py: f64) -> Ray<T> {
        self.primary_ray_in(&self.camera.frame(), w, h, px, py)
    }

    /// [`CpuRenderer::primary_ray`] with the camera's frame worked out once.
    #[inline]
    fn primary_ray_in(&self, frame: &Frame, w: u32, h: u32, px: f64, py: f64) -> Ray<T> {
        Ray {
            o: V3::from_vec3(self.camera.eye),
            d: V3::from_dvec3(frame.direction_at(w, h, px, py)),
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
        let all = Readback::default();
        self.render_region(w, h, Region::full(w, h), spp, all, progress)
    }

    /// The pixels of `region` of a W x H image, as an image (and AOVs) of the region's
    /// size. Each pixel's rays are those of the full image (the camera maps pixel (i, j)
    /// of W x H), so every pixel is bit-identical to the same pixel of a full render.
    /// `readback` says what to keep besides the colours, as on the GPU: the AOVs only when
    /// asked (else the primary steps are summed), and with `srgb8` the image as 8-bit sRGB
    /// only, converted by the bands ([`image_io::srgb8`], the bytes the host conversion of
    /// the linear image gives) with the non-finite pixels counted. Output not asked for is
    /// never allocated: at 1024x1024 the AOVs alone are 24 MB of pages to fault in.
    /// `progress` advances by one per finished row of the region.
    pub fn render_region(
        &self,
        w: u32,
        h: u32,
        region: Region,
        spp: u32,
        readback: Readback,
        progress: &Progress,
    ) -> CpuOutput {
        debug_assert!(region.x1 <= w && region.y1 <= h, "region inside the image");
        let offsets = camera::sample_offsets(spp);
        let inv = T::ONE / T::from_f32(offsets.len() as f32);
        let frame = self.camera.frame();
        let primary = texture::primary_cone::<T>(self.camera.vfov_deg, h);
        let rw = region.width() as usize;
        let n_off = offsets.len();
        // Pixels per batch: their primary rays are traced, and then each depth's shadow and
        // secondary rays, as one batch each. A band's batch takes whole columns of TILE
        // pixels, TILE columns at a time, so that consecutive rays (a packet) cover a
        // square of the image, not a line: a narrower cone, fewer boxes entered.
        let batch = (BATCH_RAYS / n_off).max(1);
        // The outputs, written in place by the bands: the image zeroed by the allocator
        // (pages first touched by the thread that renders them), the AOVs filled in
        // parallel.
        let n = rw * region.height() as usize;
        let band = TILE as usize * rw;
        let mut pixels = Vec::new();
        if readback.aov {
            pixels.reserve_exact(n);
            pixels.par_extend((0..n).into_par_iter().map(|_| AovPixel::miss(0.0)));
        }
        let (mut data, mut bytes) = (Vec::new(), Vec::new());
        let colours = if readback.srgb8 {
            bytes = vec![0u8; n * 3];
            Colours::Srgb8(bytes.par_chunks_mut(band * 3))
        } else {
            data = vec![0.0f32; n * 3];
            Colours::Linear(data.par_chunks_mut(band * 3))
        };
        // A band without AOVs gets an empty slice; the zip needs one per band.
        let aov_bands = pixels.par_chunks_mut(band).map(Some).chain(
            (0..if readback.aov { 0 } else { n.div_ceil(band) })
                .into_par_iter()
                .map(|_| None),
        );
        // The bands run in an order spread over the region (`spread_order`), so that the
        // rows done at any moment sample the whole image, sky and mesh alike: the progress
        // bar's rate, and so its ETA, is the image's, not that of its cheap top rows.
        let mut bands: Vec<_> = colours
            .into_bands()
            .zip(aov_bands)
            .enumerate()
            .map(Some)
            .collect();
        // Spread by groups of SPREAD_GROUP bands, each group's bands in a row: what a
        // band leaves in the caches (the structure's nodes near the rows) serves the next.
        let n_bands = bands.len();
        let spread: Vec<_> = spread_order(n_bands.div_ceil(SPREAD_GROUP))
            .into_iter()
            .flat_map(|g| g * SPREAD_GROUP..((g + 1) * SPREAD_GROUP).min(n_bands))
            .map(|b| bands[b].take().expect("a permutation"))
            .collect();
        let tallies: Vec<Tally> = spread
            .into_par_iter()
            .map(|(b, (mut out, mut aov))| {
                let j0 = region.y0 + b as u32 * TILE;
                let j1 = (j0 + TILE).min(region.y1);
                let rows = (j1 - j0) as usize;
                let mut tally = Tally::default();
                let (mut pixels, mut rays, mut hits, mut work) =
                    (Vec::new(), Vec::new(), Vec::new(), Vec::new());
                let (mut colors, mut normals) = (Vec::new(), Vec::new());
                let mut scratch = Vec::new();
                let (mut pos, mut dirs) = ([Vec::new(), Vec::new()], Default::default());
                let cols = (batch / rows).max(1) as u32;
                for i0 in (region.x0..region.x1).step_by(cols as usize) {
                    let i1 = (i0 + cols).min(region.x1);
                    pixels.clear();
                    for t0 in (i0..i1).step_by(TILE as usize) {
                        for j in j0..j1 {
                            for i in t0..(t0 + TILE).min(i1) {
                                pixels.push((i, j));
                            }
                        }
                    }
                    pos.iter_mut().for_each(Vec::clear);
                    for &(i, j) in &pixels {
                        for &(ox, oy) in &offsets {
                            pos[0].push(i as f64 + ox);
                            pos[1].push(j as f64 + oy);
                        }
                    }
                    frame.directions(w, h, &pos[0], &pos[1], &mut dirs);
                    let eye = V3::from_vec3(self.camera.eye);
                    rays.clear();
                    rays.extend((0..pos[0].len()).map(|k| Ray {
                        o: eye,
                        d: V3::new(
                            T::from_f64(dirs[0][k]),
                            T::from_f64(dirs[1][k]),
                            T::from_f64(dirs[2][k]),
                        ),
                        t_min: T::ZERO,
                        t_max: T::BIG,
                    }));
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
                    let cones = if self.textured {
                        vec![primary; rays.len()]
                    } else {
                        Vec::new()
                    };
                    self.shade_hits(
                        &rays,
                        &cones,
                        &hits,
                        0,
                        &mut tally,
                        &mut scratch,
                        &mut colors,
                        aov.is_some().then_some(&mut normals),
                    );
                    for (p, &(i, j)) in pixels.iter().enumerate() {
                        let first = p * n_off;
                        let steps = work[first].cells + work[first].tests;
                        let at = (j - j0) as usize * rw + (i - region.x0) as usize;
                        match aov.as_deref_mut() {
                            Some(aov) => {
                                aov[at] = aov_of(hits[first].as_ref(), normals[first], steps)
                            }
                            None => tally.primary_steps += steps,
                        }
                        let mut sum = V3::splat(T::ZERO);
                        for c in &colors[first..first + n_off] {
                            sum = sum + *c;
                        }
                        let c = sum * inv;
                        let px = [c.x, c.y, c.z].map(|v| v.to_f64() as f32);
                        match &mut out {
                            Band::Linear(rgb) => rgb[at * 3..at * 3 + 3].copy_from_slice(&px),
                            Band::Srgb8(rgb) => {
                                tally.nonfinite += px.iter().any(|v| !v.is_finite()) as u64;
                                for (o, v) in rgb[at * 3..at * 3 + 3].iter_mut().zip(px) {
                                    *o = image_io::srgb8_fast(v);
                                }
                            }
                        }
                    }
                }
                progress.inc(rows as u64);
                tally
            })
            .collect();
        progress.finish();
        let (w, h) = (region.width(), region.height());
        let mut total = Tally::default();
        for t in tallies {
            total.primary += t.primary;
            total.shadow += t.shadow;
            total.reflected += t.reflected;
            total.refracted += t.refracted;
            total.work.cells += t.work.cells;
            total.work.tests += t.work.tests;
            total.primary_steps += t.primary_steps;
            total.nonfinite += t.nonfinite;
        }
        let (image, srgb8, nonfinite) = match readback.srgb8 {
            true => (Image::size_only(w, h), Some(bytes), Some(total.nonfinite)),
            false => (Image::from_rgb(w, h, data), None, None),
        };
        let (aov, primary_steps) = match readback.aov {
            true => (Aov::from_vec(w, h, pixels), None),
            false => (Aov::from_vec(0, 0, Vec::new()), Some(total.primary_steps)),
        };
        CpuOutput {
            image,
            aov,
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
            srgb8,
            primary_steps,
            nonfinite,
        }
    }
}

/// The colour output of a render, split into bands of rows: linear f32 RGB, or 8-bit sRGB
/// only.
enum Colours<L, S> {
    Linear(L),
    Srgb8(S),
}

/// One band's part of [`Colours`].
enum Band<'b> {
    Linear(&'b mut [f32]),
    Srgb8(&'b mut [u8]),
}

impl<'b, L, S> Colours<L, S>
where
    L: IndexedParallelIterator<Item = &'b mut [f32]>,
    S: IndexedParallelIterator<Item = &'b mut [u8]>,
{
    /// The bands, one item each, whichever the output.
    fn into_bands(self) -> impl IndexedParallelIterator<Item = Band<'b>> {
        match self {
            Colours::Linear(l) => rayon::iter::Either::Left(l.map(Band::Linear)),
            Colours::Srgb8(s) => rayon::iter::Either::Right(s.map(Band::Srgb8)),
        }
    }
}

/// Bands rendered one after another before the order jumps elsewhere in the image.
const SPREAD_GROUP: usize = 4;

/// 0..n in steps of about n/φ (the golden ratio), modulo n: a permutation (the step is
/// made coprime with n) in which every stretch, the first items and the items from the
/// middle on alike, is spread over 0..n with gaps of at most three sizes (the three-gap
/// theorem), so that two threads each taking half of it in turn both sample the whole
/// range from their first item on.
fn spread_order(n: usize) -> Vec<usize> {
    fn gcd(a: usize, b: usize) -> usize {
        if b == 0 {
            a
        } else {
            gcd(b, a % b)
        }
    }
    let mut step = ((n as f64) * 0.618_033_988_75).round().max(1.0) as usize;
    while gcd(step, n) > 1 {
        step += 1;
    }
    (0..n).map(|k| k * step % n).collect()
}

/// AOV values (depth, primitive id, geometric normal `ng`, steps) of a primary ray.
fn aov_of<T: Real>(hit: Option<&Hit<T>>, ng: V3<T>, steps: u64) -> AovPixel {
    match hit {
        None => AovPixel::miss(steps as f32),
        Some(hit) => AovPixel {
            depth: hit.t.to_f64() as f32,
            primid: hit.tri as f32,
            normal: ng.to_dvec3().as_vec3().to_array(),
            steps: steps as f32,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::spread_order;

    /// A permutation of 0..n whose first k items, and the first k of its second half, each
    /// leave no gap wider than about 2n/k: the rows done early sample the whole image.
    #[test]
    fn spread_order_is_a_permutation_spread_from_the_start_of_either_half() {
        for n in [0, 1, 2, 3, 7, 8, 150, 300, 1000] {
            let order = spread_order(n);
            let mut sorted = order.clone();
            sorted.sort_unstable();
            assert_eq!(sorted, (0..n).collect::<Vec<_>>(), "n {n}");
            for start in [0, n / 2] {
                for k in [4, 8, 16].into_iter().filter(|&k| start + k <= n && k < n) {
                    let mut seen: Vec<usize> = order[start..start + k].to_vec();
                    seen.sort_unstable();
                    let gap = seen
                        .windows(2)
                        .map(|w| w[1] - w[0])
                        .chain([seen[0], n - seen[k - 1]])
                        .max()
                        .unwrap();
                    assert!(
                        gap <= 4 * n / k + 1,
                        "n {n}, items {start}..+{k}: gap {gap}"
                    );
                }
            }
        }
        assert_eq!(spread_order(8), [0, 5, 2, 7, 4, 1, 6, 3]);
    }
}
