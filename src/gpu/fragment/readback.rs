//! Reading results back to the host: the image, the primary-ray AOVs, and the final ray
//! states of a traced wave, all through the field declarations of
//! [`contract`](crate::gpu::contract).

use rayon::prelude::*;

use super::frame::Frame;
use crate::gpu::contract::{ray, RayState, StateTexels, Unit};
use crate::gpu::gl::{state, ReadbackRing, RenderTarget, TexFormat};
use crate::gpu::options::{FragmentKernel, GpuOptions};
use crate::gpu::request::aov_pixel_id;
use crate::gpu::scene::bind_texture;
use crate::gpu::scene::GpuScene;
use crate::gpu::shader::{Pass, Query};
use crate::gpu::wave::{initial_state, traces_from, wave_size, GpuRay, GpuTrace};
use crate::output::{Aov, AovPixel};
use crate::scene::Scene;
use crate::Result;

/// GL rows start at the bottom; images at the top. Drops alpha.
pub(super) fn flip_rgba_to_rgb(data: &[f32], w: u32, h: u32) -> Vec<f32> {
    let mut out = vec![0f32; (w * h * 3) as usize];
    // Rows in parallel: at 4096x4096 the host's share of a render is mostly these loops.
    out.par_chunks_mut((w * 3) as usize)
        .enumerate()
        .for_each(|(j, dst)| {
            let row = (h as usize - 1 - j) * w as usize * 4;
            for (i, px) in dst.chunks_mut(3).enumerate() {
                px.copy_from_slice(&data[row + i * 4..row + i * 4 + 3]);
            }
        });
    out
}

/// The 8-bit target `srgb8.frag` draws into and the staging ring its pixels come back
/// through (none without persistent mapping: GL < 4.4), kept between renders of one size.
struct Srgb8Target(RenderTarget, Option<ReadbackRing>);

/// The finished image as 8-bit sRGB, rows from the top (`srgb8.frag`, the host's rounding),
/// and its number of non-finite pixels: 4 bytes a pixel read back where the linear image
/// costs 16.
pub(super) fn read_srgb8(f: &mut Frame, w: u32, h: u32) -> Result<(Vec<u8>, u64)> {
    // The RGBA8 target is kept in the GPU scene per image size (as the compute kernel's
    // outputs are), so an animation's frames do not each allocate one. Made before
    // binding: creating a texture unbinds the active unit's.
    let gs = f.gs;
    let mut kept = gs.kept::<Srgb8Target>();
    if kept
        .as_ref()
        .is_none_or(|t| (t.0.width(), t.0.height()) != (w, h))
    {
        *kept = None;
        let target = RenderTarget::with_formats(f.ctx, w, h, &[TexFormat::Rgba8])?;
        let ring = ReadbackRing::new(f.ctx, w as usize * h as usize * 4).ok();
        *kept = Some(Srgb8Target(target, ring));
    }
    let Srgb8Target(target, ring) = kept.as_mut().expect("made above");
    let thresholds = gs.srgb_texture()?;
    bind_texture(f.gl(), Unit::Acc, f.acc[f.acc_cur].texture(0));
    bind_texture(f.gl(), Unit::Node, thresholds);
    f.draw_into(Pass::Srgb8, target)?;
    // The conversion pass timed apart from the transfer (the transfer waits for it anyway).
    let t = crate::clock::Instant::now();
    state::finish(f.gl());
    f.stats
        .phases_ms
        .insert("srgb8".into(), t.elapsed().as_secs_f64() * 1e3);
    // Pages an earlier frame touched (`pool`); every byte is written below.
    let mut rgb = crate::pool::take(w as usize * h as usize * 3);
    if let Some(ring) = ring {
        // Through a staging buffer (H200, 4096x4096: see docs/performance.md).
        let k = ring.read_pixels(f.ctx, glow::COLOR_ATTACHMENT0, w, h)?;
        let nonfinite = ring.take(f.ctx, k, |rgba| rgba_to_rgb(rgba, &mut rgb))?;
        return Ok((rgb, nonfinite));
    }
    // Attachment 0, the only one, is the framebuffer's read buffer from its creation.
    let rgba = target.read_bytes(f.gl())?;
    let nonfinite = rgba_to_rgb(&rgba, &mut rgb);
    Ok((rgb, nonfinite))
}

/// Drops alpha, which marks the finite pixels (0: not finite), and counts the others.
fn rgba_to_rgb(rgba: &[u8], rgb: &mut [u8]) -> u64 {
    rgb.par_chunks_mut(3 << 12)
        .zip(rgba.par_chunks(4 << 12))
        .map(|(dst, src)| {
            let mut bad = 0u64;
            for (d, s) in dst.chunks_exact_mut(3).zip(src.chunks_exact(4)) {
                d.copy_from_slice(&s[..3]);
                bad += u64::from(s[3] == 0);
            }
            bad
        })
        .sum()
}

/// Reads the current ray-state set's textures s0 and s3 (the others stay empty).
fn read_state(f: &Frame) -> Result<StateTexels> {
    let st = &f.state[f.cur];
    let read = |k: usize| st.read_attachment(f.gl(), k);
    Ok(StateTexels {
        texels: [read(0)?, Vec::new(), Vec::new(), read(3)?],
    })
}

/// Primary-ray AOVs from the finished level-0 wave.
pub(super) fn read_aov(f: &Frame, scene: &Scene, w: u32, h: u32) -> Result<Aov> {
    let s = read_state(f)?;
    if let Some(gi) = f.gs.instancing() {
        return Ok(instanced_aov(&s, f.gs.given_scene(), gi, w, h));
    }
    // A flat scene's hit carries its triangle's id as the float slot.
    Ok(aov_image(&s, scene, w, h, |k| {
        crate::gpu::layout::slot_record(s.get(k, ray::TRI_BEST))
    }))
}

/// [`read_aov`] of an instanced scene: its finished state (`instance_walk.glsl`) holds the
/// hit's packed triangle and, in s3's third channel, its instance (-1: the scene's own),
/// which give its primitive id exactly (the instance's first id plus the triangle's index
/// in its mesh), whatever its size.
fn instanced_aov(
    s: &StateTexels,
    given: &Scene,
    gi: &crate::accel::grid_instances::GridInstances,
    w: u32,
    h: u32,
) -> Aov {
    let instances = &given.instancing.instances;
    aov_image(s, given, w, h, |k| {
        let rec = crate::gpu::layout::slot_record(s.get(k, ray::TRI_BEST));
        let inst = s.get(k, ray::CURSOR_END);
        if inst < 0.0 {
            return rec;
        }
        let i = &instances[inst as usize];
        let base = gi.meshes[i.mesh as usize].tri_base as u64;
        i.first as u64 + (rec - base)
    })
}

/// The AOV image of the finished state `s` (rows flipped: GL's start at the bottom), `id`
/// giving the exact triangle id of the hit at texel `k`; one loop for the flat and the
/// instanced scene, which differ only in how a hit names its triangle.
fn aov_image(
    s: &StateTexels,
    scene: &Scene,
    w: u32,
    h: u32,
    id: impl Fn(usize) -> u64 + Sync,
) -> Aov {
    let mut pixels = vec![AovPixel::miss(0.0); (w * h) as usize];
    pixels
        .par_chunks_mut(w as usize)
        .enumerate()
        .for_each(|(j, out)| {
            let row = (h as usize - 1 - j) * w as usize;
            for (i, px) in out.iter_mut().enumerate() {
                let k = row + i;
                let hit = RayState::from_code(s.get(k, ray::STATE)) == Some(RayState::Shading);
                let best = hit.then(|| (s.get(k, ray::T_BEST), id(k)));
                *px = aov_pixel_id(scene, best, s.get(k, ray::STEPS));
            }
        });
    Aov::from_vec(w, h, pixels)
}

/// Traces the wave of `rays` with `kernel` (the fragment side of `trace_rays`).
pub(crate) fn trace_wave(
    gs: &GpuScene,
    rays: &[GpuRay],
    query: Query,
    kernel: FragmentKernel,
    opts: &GpuOptions,
) -> Result<Vec<GpuTrace>> {
    if gs.instanced() {
        return Err(crate::Error::Internal(
            "a wave of given rays walks scenes stored flat; an instanced scene renders whole \
             images"
                .into(),
        ));
    }
    let n = rays.len() as u32;
    let (w, h) = wave_size(n);
    let mut f = Frame::new(gs, w, h, 1, false, kernel, opts, opts.techniques)?;
    let s = initial_state(rays, (w * h) as usize);
    for (tex, data) in f.state[f.cur].textures().iter().zip(&s.texels) {
        tex.upload(f.gl(), data)?;
    }
    crate::gpu::pause::block_on(f.trace(query))?;
    Ok(traces_from(&read_state(&f)?, rays.len()))
}

#[cfg(test)]
mod tests {
    use crate::gpu::context::with_test_context;
    use crate::gpu::options::{FragmentKernel, GpuOptions, Kernel};
    use crate::gpu::request::ImageRequest;
    use crate::gpu::scene::GpuScene;
    use crate::output::Readback;
    use crate::testing::builtin_irregular;

    /// The 8-bit image converted on the GPU (`srgb8.frag`) is byte for byte the host's
    /// conversion of the linear image read back, on the thesis's kernel and the looped
    /// one, and counts no non-finite pixel in a finite image.
    #[test]
    fn srgb8_pass_is_the_host_conversion() {
        with_test_context(|ctx| {
            let (scene, accel) = builtin_irregular();
            let gs = GpuScene::new(ctx, &scene, accel.as_ref(), false).unwrap();
            for (kernel, fk) in [
                (Kernel::Multipass, FragmentKernel::Multipass),
                (Kernel::Looped, FragmentKernel::Looped),
            ] {
                let linear = ImageRequest {
                    camera: scene.camera,
                    width: 67,
                    height: 45,
                    spp: 2,
                    max_depth: scene.max_depth,
                    techniques: Default::default(),
                    progress: false,
                    gpu: GpuOptions {
                        kernel,
                        ..GpuOptions::default()
                    },
                    readback: Readback::default(),
                    region: None,
                };
                let bytes = ImageRequest {
                    readback: Readback {
                        aov: false,
                        srgb8: true,
                    },
                    ..linear
                };
                let a = super::super::render(&gs, &linear, fk, None).unwrap();
                let b = super::super::render(&gs, &bytes, fk, None).unwrap();
                let host = crate::image_io::to_srgb8(&a.image);
                let gpu = b.srgb8.as_ref().expect("8-bit image");
                assert_eq!(gpu.len(), host.len(), "{kernel:?}");
                let diff = host.iter().zip(gpu).filter(|(x, y)| x != y).count();
                assert_eq!(diff, 0, "{kernel:?}: bytes differ from the host conversion");
                assert!(b.image.data.is_empty());
                assert_eq!(b.nonfinite, Some(0));
                assert_eq!(b.gpu.as_ref().unwrap().passes.get("srgb8"), Some(&1));
                // Not a blank image: the conversion has something to get wrong.
                assert!(host.iter().any(|&v| v > 200) && host.iter().any(|&v| v < 50));
            }
        });
    }

    /// Every linear value `srgb8.frag` can meet (each code's threshold and the float below
    /// it, so codes 0 through 255; values above 1; negative, infinite and NaN values)
    /// converts to the host's byte, and its non-finite pixels are counted as the host
    /// counts them, through the read-back a PNG takes, on every fragment kernel's frame;
    /// frames of different sizes in one process, each read into a buffer the one before
    /// handed back (`pool`), show none of an earlier frame's bytes.
    #[test]
    fn srgb8_pass_converts_the_whole_range_as_the_host_does_at_every_size() {
        use super::Frame;
        with_test_context(|ctx| {
            let (scene, accel) = builtin_irregular();
            let gs = GpuScene::new(ctx, &scene, accel.as_ref(), false).unwrap();
            let opts = GpuOptions::default();
            let seed = crate::testing::test_seed("srgb8 frag", 0x5e9b_8a11);
            let sizes = [(300, 200), (67, 45), (300, 200), (1, 1), (256, 3), (67, 45)];
            let kernels = [
                FragmentKernel::Multipass,
                FragmentKernel::Looped,
                FragmentKernel::Unrolled(4),
            ];
            for (k, &(w, h)) in sizes.iter().enumerate() {
                let kernel = kernels[k % kernels.len()];
                let px = (w * h) as usize;
                let rgb = crate::testing::full_range_values(px * 3, seed + k as u64);
                // Texels as the accumulation target holds them: GL rows from the bottom.
                let mut rgba = vec![1f32; px * 4];
                for j in 0..h as usize {
                    for i in 0..w as usize {
                        let (at, from) = (
                            ((h as usize - 1 - j) * w as usize + i) * 4,
                            (j * w as usize + i) * 3,
                        );
                        rgba[at..at + 3].copy_from_slice(&rgb[from..from + 3]);
                    }
                }
                let mut f =
                    Frame::new(&gs, w, h, 1, false, kernel, &opts, opts.techniques).unwrap();
                f.acc[f.acc_cur].texture(0).upload(f.gl(), &rgba).unwrap();
                let (bytes, nonfinite) = super::read_srgb8(&mut f, w, h).unwrap();
                crate::testing::assert_host_srgb8(&format!("{kernel} {w}x{h}"), &rgb, &bytes);
                let bad = rgb
                    .chunks(3)
                    .filter(|p| p.iter().any(|v| !v.is_finite()))
                    .count();
                assert_eq!(nonfinite, bad as u64, "{kernel} {w}x{h}");
                assert!(
                    bad > 0 || px < 100,
                    "the image has non-finite pixels to count"
                );
                crate::pool::give_back(bytes);
            }
        });
    }
}
