//! Host memory a render will need against what the machine has: a scene too large for the
//! machine is refused with one line before the structure is built (issue 53), rather than
//! ending in an out-of-memory kill.
//!
//! The estimates are peaks per triangle of each structure's build, beside the scene already
//! loaded, measured with `/usr/bin/time -v` on `ci/measure-large.sh`'s four-sphere scene
//! (1.31 M triangles, 2 cores): whole-process peaks of 0.22 GB (BVH), 0.35 GB (uniform grid)
//! and 0.77 GB (irregular grid), less the scene and the binary. They are estimates, so the
//! check refuses only what cannot fit: more than the memory the kernel reports available.

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

/// Refuses a build of `kind` over `triangles` triangles (and, `gpu`, its GPU layout) that
/// needs more than `available` bytes: one line with the need, what there is and the
/// structure that needs least.
pub fn check_build(
    kind: AccelKind,
    triangles: usize,
    gpu: bool,
    available: Option<u64>,
) -> Result<()> {
    let Some(available) = available else {
        return Ok(());
    };
    let per = build_bytes_per_triangle(kind) + if gpu { GPU_BYTES_PER_TRIANGLE } else { 0 };
    let need = triangles as u64 * per;
    if need <= available {
        return Ok(());
    }
    let gib = |b: u64| b as f64 / (1u64 << 30) as f64;
    let advice = match kind {
        AccelKind::Bvh => "free memory or render on a larger machine".to_string(),
        _ => format!(
            "--backend cpu --accel bvh needs about {:.1} GiB",
            gib(triangles as u64 * build_bytes_per_triangle(AccelKind::Bvh))
        ),
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
        if gpu { " with its GPU layout" } else { "" },
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
        assert!(check_build(AccelKind::Irregular, 1_000_000, true, Some(gib)).is_ok());
        let e = check_build(AccelKind::Irregular, 32_768_002, true, Some(4 * gib)).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, Error::Limit(_)), "{e}");
        assert!(!text.contains('\n'), "{text}");
        assert!(
            text.contains("32768002 triangles needs about 26.2 GiB"),
            "{text}"
        );
        assert!(text.contains("4.0 GiB is available"), "{text}");
        assert!(
            text.contains("--backend cpu --accel bvh needs about 3.7 GiB"),
            "{text}"
        );
        let e = check_build(AccelKind::Bvh, 100_000_000, false, Some(gib)).unwrap_err();
        assert!(e.to_string().contains("free memory"), "{e}");
        assert!(check_build(AccelKind::Bvh, usize::MAX / 1024, false, None).is_ok());
    }

    /// The machine's figure is read where there is one (Linux).
    #[test]
    fn reads_available_memory_on_linux() {
        if cfg!(target_os = "linux") {
            assert!(available_bytes().is_some_and(|b| b > 0));
        }
    }
}
