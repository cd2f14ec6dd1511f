//! The Whitted ray tree, walked depth-first in the same order for every pixel: primary
//! rays per sample, then at each level the ambient and light terms (one shadow wave per
//! light) and the reflected and refracted children, skipping a child's whole subtree when
//! an occlusion query finds no pixel where it exists.
//!
//! The walk is `async` ([`walk`]): the observer may pause it after any pass and the web
//! page resumes it on the next animation frame ([`crate::gpu::pause`]); [`render`] runs it
//! to the end. Either way the passes drawn are the same.

use crate::clock::Instant;

use rayon::prelude::*;

use super::frame::{ray_texture_budget, ray_texture_bytes, Frame, Slot, Watch};
use super::readback::{flip_rgba_to_rgb, read_aov, read_srgb8};
use crate::gpu::contract::{uniform, Unit};
use crate::gpu::gl::{state, Texture};
use crate::gpu::options::FragmentKernel;
use crate::gpu::pause::block_on;
use crate::gpu::request::{GpuOutput, ImageRequest, Observer};
use crate::gpu::scene::{bind_texture, GpuScene};
use crate::gpu::shader::{Count, Pass, Query};
use crate::image_io::Image;
use crate::output::{Aov, RayCounts};
use crate::progress::Progress;
use crate::region::Region;
use crate::scene::{camera, Scene};
use crate::Result;

/// A child of a ray-tree node.
#[derive(Clone, Copy, Debug)]
enum Branch {
    Reflect,
    Refract,
}

impl Branch {
    /// The `u_branch` uniform of the weight and spawn passes.
    fn uniform(self) -> f32 {
        match self {
            Branch::Reflect => 0.0,
            Branch::Refract => 1.0,
        }
    }

    /// Its rays, for the progress display.
    fn rays_name(self) -> &'static str {
        match self {
            Branch::Reflect => "reflected",
            Branch::Refract => "refracted",
        }
    }

    /// Adds `n` rays of this branch to `rays`.
    fn tally(self, rays: &mut RayCounts, n: u64) {
        match self {
            Branch::Reflect => rays.reflected += n,
            Branch::Refract => rays.refracted += n,
        }
    }
}

/// Renders `req` with the fragment kernel `kernel`, calling `observer` (if any) between
/// passes; it may cancel the render (a pause is run straight through). An unwatched frame
/// whose ray textures would pass the budget (`frame::RAY_TEXTURE_BUDGET`, 8 GiB) is rendered in full-width bands of
/// rows that each fit, stacked: a region renders exactly its pixels of the whole image
/// (`crate::region`), so the frame is the same bytes (the 100-duck scene at 4096² and depth
/// 5, two levels: 8.5 GiB in one go, refused before).
pub(crate) fn render<'a>(
    gs: &'a GpuScene<'a>,
    req: &ImageRequest,
    kernel: FragmentKernel,
    observer: Option<&'a mut Observer<'a>>,
) -> Result<GpuOutput> {
    let px = req.pixels();
    let levels = req.max_depth as usize + 1;
    let per_row = ray_texture_bytes(gs, px.width(), 1, levels).max(1);
    let rows = (ray_texture_budget() / per_row).min(u32::MAX as u64) as u32;
    if observer.is_some() || rows == 0 || rows >= px.height() {
        // A watched frame stays whole (the viewer shows one frame's passes); a row that
        // does not fit is refused by `Frame::new`.
        return block_on(walk(gs, *req, kernel, observer));
    }
    let mut parts = Vec::new();
    let mut y = px.y0;
    while y < px.y1 {
        let band = Region {
            y0: y,
            y1: (y + rows).min(px.y1),
            ..px
        };
        let part = ImageRequest {
            region: Some(band),
            ..*req
        };
        parts.push(block_on(walk(gs, part, kernel, None))?);
        y = band.y1;
    }
    Ok(crate::output::BackendOutput::stack_rows(parts))
}

/// [`render`] as a future that suspends where the observer answers
/// [`Flow::Pause`](crate::gpu::request::Flow::Pause).
pub(crate) async fn walk<'a>(
    gs: &'a GpuScene<'a>,
    req: ImageRequest,
    kernel: FragmentKernel,
    observer: Option<&'a mut Observer<'a>>,
) -> Result<GpuOutput> {
    // The pixels rendered: a region of the image (`--tile`, `--region`) or all of it.
    let px = req.pixels();
    let (width, height, spp, max_depth) = (px.width(), px.height(), req.spp, req.max_depth);
    let levels = max_depth as usize + 1;
    let scene = gs.scene();
    let mut f = Frame::new(
        gs,
        width,
        height,
        levels,
        true,
        kernel,
        &req.gpu,
        req.techniques,
    )?;
    f.progress = Progress::tree_bar(req.progress);
    f.root_spread = crate::scene::texture::pixel_spread(req.camera.vfov_deg, req.height) as f32;
    let secondary = max_depth > 0 && gs.has_secondary();
    let samples = camera::sample_offsets(spp).len();
    f.progress
        .begin_tree(samples as f64 * subtree_traces(scene, 0, max_depth, secondary));
    f.watch = observer.map(|observer| Watch {
        observer,
        samples_done: 0,
        samples: samples as u32,
    });
    let t_trace = Instant::now();
    // Clear the colour accumulator.
    f.acc[0].bind(f.gl());
    state::clear_colour(f.gl(), [0.0; 4]);
    let offsets = camera::sample_offsets(spp);
    let mut rays = RayCounts::default();
    f.set(Pass::RayGen, uniform::EYE, req.camera.eye)?;
    // The primary directions of one sample, re-filled per sample into one texture.
    let dir_tex = Texture::new_f32(f.ctx, width, height, None)?;
    let mut dirs = Vec::with_capacity(width as usize * height as usize * 4);
    for (k, &(ox, oy)) in offsets.iter().enumerate() {
        // Level-0 weight: 1/spp everywhere, and every pixel has a primary ray.
        let w = 1.0 / offsets.len() as f32;
        f.target(Slot::Rec2(0)).bind(f.gl());
        state::clear_colour(f.gl(), [w, w, w, 1.0]);
        // The primary directions, computed on the host in f64 by the camera's formula and
        // rounded to f32: bit for bit the directions the f32 CPU traces. Interpolating
        // window corners in f32 on the GPU instead picks the other side of an exact tie (a
        // ray through the edge where two walls meet) on some pixels, and with absolute
        // corners far from the origin rounds every direction to the spacing at the eye.
        dirs.resize(width as usize * height as usize * 4, 0.0);
        dirs.par_chunks_mut(width as usize * 4)
            .enumerate()
            .for_each(|(row, out)| {
                // GL rows run from the bottom; the ray is the whole image's through
                // pixel (x0 + i, y0 + j), as on the CPU.
                let j = px.y0 + height - 1 - row as u32;
                for (i, texel) in out.chunks_mut(4).enumerate() {
                    let i = px.x0 + i as u32;
                    let d = req
                        .camera
                        .direction_at(req.width, req.height, i as f64 + ox, j as f64 + oy)
                        .as_vec3();
                    texel.copy_from_slice(&[d.x, d.y, d.z, 0.0]);
                }
            });
        dir_tex.upload(f.gl(), &dirs)?;
        bind_texture(f.gl(), Unit::Node, &dir_tex);
        f.progress
            .stage(format!("sample {}/{}: primary rays", k + 1, offsets.len()));
        f.state_pass(Pass::RayGen).await?;
        rays.primary += width as u64 * height as u64;
        f.trace(Query::Closest).await?;
        if k == 0 && req.readback.aov {
            f.aov = Some(read_aov(&f, scene, width, height)?);
        }
        f.record(0)?;
        shade_node(&mut f, scene, 0, max_depth, secondary, &mut rays).await?;
        if let Some(w) = f.watch.as_mut() {
            w.samples_done = k as u32 + 1;
        }
        f.observe().await?;
    }
    // The passes are queued, not done: wait for them here, so that `read_back` times the
    // copy and not the GPU's last passes (measured apart: run 4 of the notebook,
    // `git show b97da3f:docs/performance.md`).
    let t = crate::clock::Instant::now();
    state::finish(f.gl());
    f.stats
        .phases_ms
        .insert("drain".into(), t.elapsed().as_secs_f64() * 1e3);
    let t = crate::clock::Instant::now();
    let (image, srgb8, nonfinite) = if req.readback.srgb8 {
        let (bytes, nonfinite) = read_srgb8(&mut f, width, height)?;
        (
            Image::size_only(width, height),
            Some(bytes),
            Some(nonfinite),
        )
    } else {
        let data = f.acc[f.acc_cur].read_attachment(f.gl(), 0)?;
        let rgb = flip_rgba_to_rgb(&data, width, height);
        (Image::from_rgb(width, height, rgb), None, None)
    };
    f.stats
        .phases_ms
        .insert("read_back".into(), t.elapsed().as_secs_f64() * 1e3);
    f.progress.finish();
    f.finish_timers()?;
    f.stats.trace_ms = t_trace.elapsed().as_secs_f64() * 1e3;
    Ok(GpuOutput {
        image,
        aov: f
            .aov
            .take()
            .unwrap_or_else(|| Aov::from_vec(0, 0, Vec::new())),
        rays: RayCounts::new(rays.primary, rays.shadow, rays.reflected, rays.refracted),
        work: None,
        gpu: Some(std::mem::take(&mut f.stats)),
        srgb8,
        primary_steps: None,
        nonfinite,
    })
}

/// Shades level `level`'s records (ambient, every light) and recurses into the node's
/// reflected and refracted children.
async fn shade_node(
    f: &mut Frame<'_>,
    scene: &Scene,
    level: usize,
    max_depth: u32,
    secondary: bool,
    rays: &mut RayCounts,
) -> Result<()> {
    f.set_root_cone(level, f.root_spread)?;
    f.accumulate(Pass::AccumAmbient, level).await?;
    shade_children(f, scene, level, max_depth, secondary, rays).await
}

/// The most traces a node at `level` and its subtree can run, what the progress bar counts
/// against (crate::progress): its own rays, one shadow trace per light, and below the
/// depth limit a reflected and a refracted subtree, each the full tree below.
fn subtree_traces(scene: &Scene, level: usize, max_depth: u32, secondary: bool) -> f64 {
    let own = 1.0 + scene.lights.len() as f64;
    if secondary && (level as u32) < max_depth {
        own + 2.0 * subtree_traces(scene, level + 1, max_depth, secondary)
    } else {
        own
    }
}

/// The body of [`shade_node`]: the lights, then the children.
async fn shade_children(
    f: &mut Frame<'_>,
    scene: &Scene,
    level: usize,
    max_depth: u32,
    secondary: bool,
    rays: &mut RayCounts,
) -> Result<()> {
    for light in &scene.lights {
        f.set(Pass::ShadowSpawn, uniform::LIGHT_POS, light.position)?;
        f.set(Pass::AccumLight, uniform::LIGHT_RAD, light.radiance())?;
        f.bind_records(level);
        f.progress.stage(format!("depth {level}: shadow rays"));
        f.state_pass(Pass::ShadowSpawn).await?;
        let n = f.count(Count::Rays, None)?;
        rays.shadow += n;
        if n > 0 {
            f.trace(Query::Any).await?;
        } else {
            f.progress.skip(1.0);
        }
        f.accumulate(Pass::AccumLight, level).await?;
    }
    if !secondary || level as u32 >= max_depth {
        return Ok(());
    }
    for branch in [Branch::Reflect, Branch::Refract] {
        let child = level + 1;
        f.set(Pass::Weight, uniform::BRANCH, branch.uniform())?;
        f.set(Pass::Spawn, uniform::BRANCH, branch.uniform())?;
        f.set_root_cone(level, f.root_spread)?;
        f.bind_records(level);
        f.draw(Pass::Weight, Slot::Rec2(child))?;
        let n = f.count(Count::Nodes, Some(child))?;
        if n == 0 {
            // No pixel has this node: skip its whole subtree.
            f.progress
                .skip(subtree_traces(scene, child, max_depth, secondary));
            continue;
        }
        branch.tally(rays, n);
        f.progress
            .stage(format!("depth {child}: {} rays", branch.rays_name()));
        f.bind_records(level);
        f.bind_node(child);
        f.state_pass(Pass::Spawn).await?;
        f.trace(Query::Closest).await?;
        f.record(child)?;
        // The recursion goes through a box: a future cannot contain itself.
        Box::pin(shade_node(f, scene, child, max_depth, secondary, rays)).await?;
    }
    Ok(())
}
