//! The compute kernel's unit tests (its bands, fetch paths, kept buffers and 8-bit
//! conversion against the host's), apart from `mod.rs` so that the kernel's host side
//! reads on its own; the thread-local hooks here are the ones `mod.rs` and `bands.rs`
//! consult under `cfg(test)`.

use super::*;
use crate::gpu::context::with_test_context;
use crate::gpu::options::Kernel;
use crate::testing::builtin_irregular;

thread_local! {
    /// Test hook: a storage-block size (and no storage blocks for the scene) in place
    /// of the context's, to force bands and texelFetch.
    pub(super) static BLOCK_BYTES: std::cell::Cell<Option<u64>> = const { std::cell::Cell::new(None) };
    /// Test hook: bands sized to take this long, as when a progress bar is drawn.
    pub(super) static BAND_TIME_HOOK: std::cell::Cell<Option<Duration>> = const { std::cell::Cell::new(None) };
}

/// `--scene-fetch` changes only the compute kernel, so asking for it with another kernel
/// is a usage error naming both; with auto it is taken where auto runs compute.
#[test]
fn scene_fetch_needs_the_compute_kernel() {
    with_test_context(|ctx| {
        let with = |kernel| GpuOptions {
            kernel,
            scene_fetch: SceneFetch::TexelFetch,
            ..GpuOptions::default()
        };
        let e = with(Kernel::Looped).resolve_kernel(&ctx.info).unwrap_err();
        assert!(matches!(e, Error::Usage(_)), "{e:?}");
        assert!(
            e.to_string().contains(
                "--scene-fetch texel-fetch applies to the compute kernel; this render runs looped"
            ),
            "{e}"
        );
        // Auto runs compute where the context has it, else a fragment kernel: refused.
        let auto = with(Kernel::Auto).resolve_kernel(&ctx.info);
        assert_eq!(auto.ok(), ctx.info.compute.then_some(Kernel::Compute));
    });
}

/// Runs `f` on the built-in irregular scene uploaded to a test context, or skips (saying
/// so) where the context has no GL 4.3 compute: every render test's start.
fn with_compute_scene(f: impl FnOnce(&GlContext, &crate::scene::Scene, &GpuScene)) {
    with_test_context(|ctx| {
        if !ctx.info.compute {
            eprintln!("SKIPPED: no GL 4.3 compute in this context");
            return;
        }
        let (scene, accel) = builtin_irregular();
        let gs = GpuScene::new(ctx, &scene, accel.as_ref(), false).unwrap();
        f(ctx, &scene, &gs)
    })
}

/// A compute render of `scene` 96 pixels wide and 600 high (three bands when a test
/// narrows the storage blocks to 256 rows), everything read back.
fn tall_request(scene: &crate::scene::Scene, spp: u32, scene_fetch: SceneFetch) -> ImageRequest {
    ImageRequest {
        camera: scene.camera,
        width: 96,
        height: 600,
        spp,
        max_depth: scene.max_depth,
        techniques: Default::default(),
        progress: false,
        gpu: GpuOptions {
            kernel: Kernel::Compute,
            scene_fetch,
            ..GpuOptions::default()
        },
        readback: crate::output::Readback::default(),
        region: None,
    }
}

/// `req` reading back only the 8-bit image (no AOVs).
fn srgb8_only(req: ImageRequest) -> ImageRequest {
    ImageRequest {
        readback: crate::output::Readback {
            aov: false,
            srgb8: true,
        },
        ..req
    }
}

/// Rendering in bands (with texelFetch, as a context with few storage blocks would)
/// gives the same bits as one dispatch with storage buffers.
#[test]
fn bands_and_fetch_paths_render_the_same_bits() {
    with_compute_scene(|_, scene, gs| {
        let req = tall_request(scene, 1, SceneFetch::Auto);
        // Storage buffers asked for (llvmpipe's preferred fetch is texelFetch).
        let asked = |scene_fetch| ImageRequest {
            gpu: GpuOptions {
                scene_fetch,
                ..req.gpu
            },
            ..req
        };
        let render = |req: &ImageRequest| render(gs, req, None);
        let whole = render(&asked(SceneFetch::StorageBuffer)).unwrap();
        assert_eq!(whole.gpu.as_ref().unwrap().scene_fetch, "storage-buffer");
        BLOCK_BYTES.set(Some(96 * 16 * 256));
        let banded = render(&req);
        // Too few storage blocks: auto falls back, an explicit request says why not.
        let refused = render(&asked(SceneFetch::StorageBuffer));
        BLOCK_BYTES.set(None);
        let banded = banded.unwrap();
        assert_eq!(banded.gpu.as_ref().unwrap().scene_fetch, "texel-fetch");
        let e = refused
            .err()
            .expect("storage buffers without storage blocks")
            .to_string();
        assert!(e.contains("storage blocks"), "{e}");
        assert_eq!(
            banded.gpu.as_ref().unwrap().passes_total,
            3,
            "600 rows in bands of 256"
        );
        assert_eq!(whole.gpu.as_ref().unwrap().passes_total, 1);
        assert_eq!(whole.image.data, banded.image.data);
        assert_eq!(whole.rays.total, banded.rays.total);
        assert_eq!(whole.work, banded.work);
        let ids = |o: &GpuOutput| o.aov.pixels.iter().map(|p| p.primid).collect::<Vec<_>>();
        assert_eq!(ids(&whole), ids(&banded));
    });
}

/// Bands sized by time (as with a progress bar drawn: here every band after the
/// first is one row) give the headless render's bytes and counts; the kept output
/// buffers serve the next render of the same shape with their counters zeroed, and are
/// remade for another shape.
#[test]
fn timed_bands_and_kept_buffers_keep_the_bits() {
    with_compute_scene(|_, scene, gs| {
        let full = tall_request(scene, 1, SceneFetch::TexelFetch);
        let lean = srgb8_only(full);
        let first = render(gs, &lean, None).unwrap();
        BAND_TIME_HOOK.set(Some(Duration::ZERO));
        let timed = render(gs, &lean, None);
        BAND_TIME_HOOK.set(None);
        let timed = timed.unwrap();
        let passes = |o: &GpuOutput| o.gpu.as_ref().unwrap().passes_total;
        assert_eq!(passes(&first), 2, "one band, render and convert");
        // 600 rows: 10 (1/64), then 590 bands of one row; two dispatches each.
        assert_eq!(passes(&timed), 2 * 591);
        let with_aov = render(gs, &full, None).unwrap();
        let again = render(gs, &lean, None).unwrap();
        for o in [&timed, &again] {
            assert_eq!(o.srgb8, first.srgb8);
            assert_eq!(o.rays, first.rays, "counters zeroed for each render");
            assert_eq!(o.work, first.work);
            assert_eq!(o.primary_steps, first.primary_steps);
        }
        assert_eq!(with_aov.rays, first.rays);
        assert_eq!(with_aov.aov.pixels.len(), 96 * 600);
        assert!(first.rays.total > 0);
    });
}

/// Reading back less gives the same answers: the image converted to 8-bit sRGB on the
/// GPU is byte for byte the host's conversion of the linear image (`to_srgb8`), over
/// bands and with the staging ring; without the AOVs the primary rays' steps still come
/// back (summed on the GPU) and equal the AOV's sum; the counters equal the per-pixel
/// read.
#[test]
fn srgb8_on_the_gpu_is_the_host_conversion_and_counters_match_the_aov() {
    with_compute_scene(|_, scene, gs| {
        let full = tall_request(scene, 2, SceneFetch::TexelFetch);
        let lean = srgb8_only(full);
        let a = render(gs, &full, None).unwrap();
        // Three bands: the ring's two slots are each reused.
        BLOCK_BYTES.set(Some(96 * 16 * 256));
        let b = render(gs, &lean, None);
        BLOCK_BYTES.set(None);
        let b = b.unwrap();
        assert_eq!(
            b.gpu.as_ref().unwrap().passes_total,
            6,
            "3 bands, 2 dispatches each"
        );
        let host = crate::image_io::to_srgb8(&a.image);
        let gpu = b.srgb8.as_ref().expect("8-bit image");
        assert!(b.image.data.is_empty() && b.aov.pixels.is_empty());
        let diff = host.iter().zip(gpu).filter(|(x, y)| x != y).count();
        assert_eq!(diff, 0, "bytes differ from the host conversion");
        assert_eq!(gpu.len(), host.len());
        let steps: f64 = a.aov.pixels.iter().map(|p| p.steps as f64).sum();
        assert_eq!(b.primary_steps, Some(steps as u64));
        assert_eq!(a.primary_steps, b.primary_steps);
        assert_eq!((a.nonfinite, b.nonfinite), (Some(0), Some(0)));
        assert_eq!(a.rays, b.rays);
        assert_eq!(a.work, b.work);
        assert!(steps > 0.0);
    });
}

/// Every linear value `srgb8.comp` can meet (each code's threshold and the float below
/// it, so codes 0 through 255; values above 1; negative, infinite and NaN values)
/// converts to the host's byte, through the staging ring a render reads bands with,
/// into buffers the frame before handed back (`pool`), frames of different sizes in
/// one process (byte counts that are and are not whole words): no byte of an earlier
/// frame shows.
#[test]
fn srgb8_comp_converts_the_whole_range_as_the_host_does_at_every_size() {
    with_compute_scene(|ctx, _, gs| {
        let gl = ctx.gl();
        let p = gs
            .compute_program(
                ComputePass::Srgb8,
                &ComputeSpec::CONVERT,
                Techniques::default(),
            )
            .unwrap();
        let thresholds = gs.srgb_thresholds().unwrap();
        let seed = crate::testing::test_seed("srgb8 comp", 0x5e9b_8a12);
        for (k, px) in [60_000usize, 3015, 60_000, 1, 2, 3, 769, 3015]
            .into_iter()
            .enumerate()
        {
            let rgb = crate::testing::full_range_values(px * 3, seed + k as u64);
            let floats: Vec<u8> = rgb.iter().flat_map(|v| v.to_ne_bytes()).collect();
            let radiance = StorageBuffer::new(ctx, &floats).unwrap();
            radiance.bind(gl, Buffer::Radiance.binding());
            let len = px * 3;
            let dst = StorageBuffer::uninit(ctx, len.div_ceil(4) * 4).unwrap();
            convert_srgb8(gl, &p, thresholds, &dst, px).unwrap();
            let mut out = crate::pool::take(len);
            match ReadbackRing::new(ctx, len) {
                Ok(mut ring) => {
                    let slot = ring.copy(ctx, &dst, 0, len).unwrap();
                    ring.take(ctx, slot, |b| out.copy_from_slice(&b[..len]))
                        .unwrap();
                }
                Err(_) => read_bytes_staged(ctx, &dst, &mut out).unwrap(),
            }
            crate::testing::assert_host_srgb8(&format!("{px} pixels"), &rgb, &out);
            crate::pool::give_back(out);
        }
    });
}

/// Renders of different sizes in one process, each read back into a buffer an earlier
/// one handed back (`pool`), are each byte for byte the host's conversion of their
/// linear image: a reused buffer shows nothing of the frame before.
#[test]
fn renders_of_different_sizes_reuse_buffers_without_leaking_bytes() {
    with_compute_scene(|_, scene, gs| {
        let base = tall_request(scene, 1, SceneFetch::TexelFetch);
        for (w, h) in [(96, 600), (40, 30), (96, 600), (7, 5), (61, 47)] {
            let full = ImageRequest {
                width: w,
                height: h,
                ..base
            };
            let a = render(gs, &full, None).unwrap();
            let b = render(gs, &srgb8_only(full), None).unwrap();
            let host = crate::image_io::to_srgb8(&a.image);
            let gpu = b.srgb8.expect("8-bit image");
            assert_eq!(gpu.len(), host.len(), "{w}x{h}");
            assert!(
                gpu == host,
                "{w}x{h}: bytes differ from the host conversion"
            );
            crate::pool::give_back(gpu);
        }
    });
}
