//! Host memory a render will need against what the machine has: a scene too large for the
//! machine is refused with one line before the structure is built (issue 53), rather than
//! ending in an out-of-memory kill.
//!
//! The estimates are peaks per triangle of each structure's build, beside the scene already
//! loaded, measured with `/usr/bin/time -v` on `ci/measure-large.sh`'s four-sphere scene
//! (1.31 M triangles, 2 cores): whole-process peaks of 0.22 GB (BVH), 0.35 GB (uniform grid)
//! and 0.77 GB (irregular grid), less the scene and the binary. They are estimates, so the
//! check refuses only what cannot fit: more than the memory the kernel reports available.
//! Re-measured on the 12-sphere scene (3.93 M triangles, 2 cores, llvmpipe, at b70a83e):
//! 2.19 GB whole process for the CPU's irregular grid, 2.87 GB for the compute kernel over
//! it, under the estimates' 2.2 and 3.4 GB beside the scene. The irregular grid's GPU
//! layout is not linear in the triangles past 2^24 cells ([`gpu_bytes`]); once the grid is
//! built, the layout's exact sizes are checked again before anything is packed
//! ([`LayoutPlan`](crate::gpu::layout::LayoutPlan)). The compute kernel's dense layout of
//! the irregular grid ([`GpuLayout::Dense`]) is linear: on the 12-sphere scene (llvmpipe,
//! 0ac6d95) 767 MB uploaded (195 bytes per triangle) and 2.29 GB whole process (582 bytes
//! per triangle), under the estimate's 860 beside the scene.

use crate::accel::AccelKind;
use crate::{Error, Result};

/// Bytes per triangle a structure's build takes at its peak, beside the scene.
pub fn build_bytes_per_triangle(kind: AccelKind) -> u64 {
    match kind {
        AccelKind::Bvh => 120,
        AccelKind::Uniform => 230,
        AccelKind::Irregular => 560,
    }
}

/// Bytes per triangle the GPU layout takes on the host (triangle, normal, cell and list
/// texels, about 140 for the irregular grid) and again in the driver's copy (llvmpipe keeps
/// its textures in host memory).
pub const GPU_BYTES_PER_TRIANGLE: u64 = 300;

/// Irregular cells per triangle the GPU estimate assumes: 2.13 measured on
/// `ci/measure-large.sh`'s 12-sphere scene (8,368,508 cells for 3,932,162 triangles), 1.88 on
/// its 100-sphere scene (61.5 M cells for 32.8 M triangles, from the H100's refusal); the
/// lower, as the estimate refuses only what cannot fit.
pub const IRREGULAR_CELLS_PER_TRIANGLE: f64 = 1.875;

/// Which GPU layout a render packs beside its structure (what [`gpu_bytes`] counts).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuLayout {
    /// None: a CPU render.
    None,
    /// The float layout of the fragment kernels (and of `--kernel auto`, which may render
    /// with one of them): its irregular cells at float slots.
    Float,
    /// `--kernel compute`: the irregular grid in dense integer buffers
    /// (`gpu::layout::DenseIrregular`), linear in the triangles.
    Dense,
}

/// Bytes the GPU layout of a `kind` structure over `triangles` triangles takes on the host
/// (with the driver's copy): [`GPU_BYTES_PER_TRIANGLE`] each, and in the float layout for
/// the irregular grid the float slots of its cells past 2^24
/// ([`float_slot`](crate::gpu::layout::float_slot)), sparser every 2^23 cells, which its
/// cell texture leaves empty: not linear in the triangles (about 43 bytes more per triangle
/// at 11.8 M triangles, 1,900 at 32.8 M). The compute kernel's dense layout has no such
/// term ([`GpuLayout::Dense`]).
pub fn gpu_bytes(kind: AccelKind, triangles: u64, layout: GpuLayout) -> u64 {
    use crate::gpu::split_index::{irregular_cell_texels, IndexFormat};
    // RGBA32F (`gpu::layout::TEXEL_BYTES`; the layout reads this file, not the other way).
    let texel_bytes = std::mem::size_of::<[f32; 4]>() as u64;
    let linear = triangles * GPU_BYTES_PER_TRIANGLE;
    match (layout, kind) {
        (GpuLayout::None, _) => return 0,
        (GpuLayout::Float, AccelKind::Irregular) => {}
        (GpuLayout::Dense | GpuLayout::Float, _) => return linear,
    }
    let cells = (triangles as f64 * IRREGULAR_CELLS_PER_TRIANGLE) as u64;
    let per = IndexFormat::Split.irregular_cell_texels() as u64;
    let empty = irregular_cell_texels(cells, IndexFormat::Split) - cells * per;
    linear + 2 * empty * texel_bytes
}

/// Environment variable naming a file read instead of `/proc/meminfo` (tests: a machine
/// with less memory than this one).
pub const MEMINFO_ENV: &str = "FRAGTRACE_MEMINFO";

/// Bytes the kernel says can be allocated without swapping (`MemAvailable` of
/// `/proc/meminfo`, or of the file [`MEMINFO_ENV`] names), or `None` where there is no such
/// file.
pub fn available_bytes() -> Option<u64> {
    let path = std::env::var_os(MEMINFO_ENV).unwrap_or_else(|| "/proc/meminfo".into());
    let text = std::fs::read_to_string(path).ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Refuses a build of `kind` over `triangles` triangles (and its GPU layout `gpu`) that
/// needs more than `available` bytes: one line with the need, what there is and the
/// structure that needs least.
pub fn check_build(
    kind: AccelKind,
    triangles: usize,
    gpu: GpuLayout,
    available: Option<u64>,
) -> Result<()> {
    let Some(available) = available else {
        return Ok(());
    };
    let build = triangles as u64 * build_bytes_per_triangle(kind);
    let need = build + gpu_bytes(kind, triangles as u64, gpu);
    let per = need / (triangles as u64).max(1);
    if need <= available {
        return Ok(());
    }
    let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
    let bvh = gib(triangles as u64 * build_bytes_per_triangle(AccelKind::Bvh));
    let advice = match (kind, gpu) {
        (AccelKind::Bvh, _) => "free memory or render on a larger machine".to_string(),
        (AccelKind::Irregular, GpuLayout::Float | GpuLayout::Dense) => {
            let n = triangles as u64;
            let uniform = n * build_bytes_per_triangle(AccelKind::Uniform)
                + gpu_bytes(AccelKind::Uniform, n, gpu);
            let dense = match gpu {
                GpuLayout::Float => format!(
                    "--kernel compute needs about {:.1} GiB, ",
                    gib(build + gpu_bytes(kind, n, GpuLayout::Dense))
                ),
                GpuLayout::Dense | GpuLayout::None => String::new(),
            };
            format!(
                "{dense}--accel uniform needs about {:.1} GiB, --backend cpu --accel bvh about {bvh:.1} GiB",
                gib(uniform)
            )
        }
        _ => format!("--backend cpu --accel bvh needs about {bvh:.1} GiB"),
    };
    Err(Error::Limit(format!(
        "the {} of {triangles} triangles needs about {:.1} GiB of memory ({per} bytes per \
         triangle{}), and {:.1} GiB is available; {advice}",
        match kind {
            AccelKind::Bvh => "BVH",
            AccelKind::Uniform => "uniform grid",
            AccelKind::Irregular => "irregular grid",
        },
        gib(need),
        match gpu {
            GpuLayout::None => "",
            GpuLayout::Float => " with its GPU layout",
            GpuLayout::Dense => " with the compute kernel's GPU layout",
        },
        gib(available),
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What fits passes, what does not is refused with one line naming the need, what there
    /// is and an option that exists; no file to read means no check.
    #[test]
    fn refuses_only_what_does_not_fit() {
        let gib = 1u64 << 30;
        let float = GpuLayout::Float;
        assert!(check_build(AccelKind::Irregular, 1_000_000, float, Some(gib)).is_ok());
        let e = check_build(AccelKind::Irregular, 32_768_002, float, Some(4 * gib)).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, Error::Limit(_)), "{e}");
        assert!(!text.contains('\n'), "{text}");
        assert!(
            text.contains("32768002 triangles needs about 84.3 GiB"),
            "{text}"
        );
        assert!(text.contains("4.0 GiB is available"), "{text}");
        assert!(
            text.contains(
                "--kernel compute needs about 26.2 GiB, --accel uniform needs about 16.2 GiB, \
                 --backend cpu --accel bvh about 3.7 GiB"
            ),
            "{text}"
        );
        // The compute kernel's dense layout: linear, 860 bytes per triangle.
        let dense = GpuLayout::Dense;
        let e = check_build(AccelKind::Irregular, 32_768_002, dense, Some(4 * gib)).unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains(
                "needs about 26.2 GiB of memory (860 bytes per triangle with the compute kernel's"
            ),
            "{text}"
        );
        assert!(
            text.contains(" --accel uniform needs about 16.2 GiB"),
            "{text}"
        );
        assert!(!text.contains("--kernel compute"), "{text}");
        let none = GpuLayout::None;
        let e = check_build(AccelKind::Uniform, 32_768_002, none, Some(gib)).unwrap_err();
        assert!(
            e.to_string()
                .contains("--backend cpu --accel bvh needs about 3.7 GiB"),
            "{e}"
        );
        let e = check_build(AccelKind::Bvh, 100_000_000, none, Some(gib)).unwrap_err();
        assert!(e.to_string().contains("free memory"), "{e}");
        assert!(check_build(AccelKind::Bvh, usize::MAX / 1024, none, None).is_ok());
    }

    /// The GPU layout's estimate: linear below 2^24 cells (all structures), then the
    /// irregular grid's empty float slots on top: 2,200 bytes per triangle for the layout
    /// at the 100-sphere scene's 32.8 M triangles (its 61.4 M estimated cells at slots that
    /// take 2.1 G texels, the 34 GB the H100's host allocated), 343 at the 36-sphere
    /// scene's 11.8 M.
    #[test]
    fn gpu_estimate_counts_the_slot_spacing() {
        let n = 32_768_002u64;
        let float = GpuLayout::Float;
        assert_eq!(
            gpu_bytes(AccelKind::Uniform, n, float),
            n * GPU_BYTES_PER_TRIANGLE
        );
        let small = 8_000_000u64; // 15 M cells: below 2^24, no slots skipped
        assert_eq!(
            gpu_bytes(AccelKind::Irregular, small, float),
            small * GPU_BYTES_PER_TRIANGLE
        );
        let per = |n: u64| gpu_bytes(AccelKind::Irregular, n, float) as f64 / n as f64;
        let (big, mid) = (per(n), per(11_796_482));
        assert!((2100.0..2300.0).contains(&big), "{big}");
        assert!((330.0..360.0).contains(&mid), "{mid}");
        // The compute kernel's dense layout stays linear; a CPU render packs none.
        let dense = GpuLayout::Dense;
        assert_eq!(
            gpu_bytes(AccelKind::Irregular, n, dense),
            n * GPU_BYTES_PER_TRIANGLE
        );
        assert_eq!(gpu_bytes(AccelKind::Irregular, n, GpuLayout::None), 0);
    }

    /// The machine's figure is read where there is one (Linux).
    #[test]
    fn reads_available_memory_on_linux() {
        if cfg!(target_os = "linux") {
            assert!(available_bytes().is_some_and(|b| b > 0));
        }
    }
}
