//! The distributed render against a real Slurm (issue 28): `ci/slurm/test.sh` starts a
//! single-node cluster from Debian's packages on this host, submits the job arrays of
//! `ci/slurm/` with `sbatch --wait` (tiles of a still, frames of an animation, frames cut
//! into tiles), merges, and compares the results with the single-process renders bit for
//! bit; then the faults of issue 48: a task cancelled (the submission exits 1 naming the
//! part; the documented re-run of that index alone completes the set), a killed task's
//! partial file (gone after the re-run and the merge), a frame range resumed, a frame
//! without parts (the merge refuses naming it). This test runs it with the binary under
//! test.
//!
//! It needs root and the packages `slurmd slurmctld slurm-client munge` (`ci/test.sh`
//! installs them). Without them it fails, saying so, unless `FRAGTRACE_ALLOW_SKIP=1`
//! acknowledges the skip: in CI it runs, and a cluster that does not start fails it.

mod common;

use std::path::Path;
use std::process::Command;

#[test]
fn tiles_and_frames_on_a_real_slurm_cluster_equal_the_single_process_bits() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let missing: Vec<&str> = ["munged", "slurmctld", "slurmd", "sbatch"]
        .into_iter()
        .filter(|tool| {
            !Command::new("sh")
                .args(["-c", &format!("command -v {tool}")])
                .output()
                .is_ok_and(|o| o.status.success())
        })
        .collect();
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
    let why = match (missing.is_empty(), root) {
        (true, true) => None,
        (false, _) => Some(format!(
            "{} not installed (apt-get install -y slurmd slurmctld slurm-client munge; ci/test.sh does)",
            missing.join(", ")
        )),
        (true, false) => Some("not root (the test starts munged, slurmctld and slurmd)".into()),
    };
    if let Some(why) = why {
        if !common::acknowledged_skip(
            &format!("the Slurm test cannot run: {why}"),
            "install them and run as root (ci/test.sh does)",
        ) {
            return;
        }
    }
    let out = Command::new("bash")
        .arg(repo.join("ci/slurm/test.sh"))
        .arg(common::exe())
        .env("FRAGTRACE_SHADER_CACHE_DIR", common::shader_cache_dir())
        .output()
        .expect("run ci/slurm/test.sh");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    println!("{text}");
    assert!(out.status.success(), "ci/slurm/test.sh failed:\n{text}");
    // The script's own checks printed these; a script that skipped them would not.
    for line in [
        "whitted.png is bit-identical",
        "bunny.exr (8 tiles on 4 tasks) has the single-process render's floats",
        "frame_0007.png is bit-identical",
        "frame_0004.png is bit-identical",
        // Issue 48's faults: a cancelled task fails the submission naming its part; the
        // re-run of that index alone completes the set; a resumed range; a missing frame.
        "a cancelled task: submit-tiles.sh --wait exits 1 naming part-2.exr",
        "cancelled.png is bit-identical",
        "a frame without parts: the merge refuses, naming frame 4",
        "slurm test: passed",
    ] {
        assert!(text.contains(line), "missing `{line}` in:\n{text}");
    }
}
