//! A render farm when things go wrong (issue 48), without a scheduler (the real Slurm is
//! tests/slurm.rs): a part of a poster larger than one process may hold renders (the limits
//! apply to the part); a re-run of one Slurm index renders that task of the job, and an
//! array of one task without the job's count is refused; SIGTERM leaves no partial file
//! and what SIGKILL leaves is removed by the next write and by the merge; merge names a
//! missing tile and a missing frame and refuses parts of another build, tiling or frame
//! set; parts' folders are made; `compare` compares a part with its region; stepped and
//! listed frames; `--check` and `--resume`. Bad input: one line, exit 2, outputs kept.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::{ok, refused, run, text, tmpdir, words};

const WHITTED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/whitted.toml");
const TURNTABLE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/turntable.toml");

/// `render WHITTED --backend cpu --width 48 --height 36 -q` and `extra`.
fn small<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    let mut v = vec![
        "render",
        WHITTED,
        "--backend",
        "cpu",
        "--width",
        "48",
        "--height",
        "36",
        "-q",
    ];
    v.extend_from_slice(extra);
    v
}

fn files(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Parts of a 16384x16384 image (32 GiB of host memory whole, past the 8 GiB limit):
/// `--tile`, `--region` and `--task-index` render them, on the CPU and on GL, because the
/// limits apply to the part; the whole image is still refused, and a part too large itself
/// is refused naming its size.
#[test]
fn parts_of_a_poster_larger_than_the_limit_render() {
    let d = tmpdir("poster");
    let size = ["--width", "16384", "--height", "16384", "--spp", "1", "-q"];
    let with = |extra: &[&'static str]| -> Vec<&'static str> {
        let mut v = vec!["render", WHITTED];
        v.extend_from_slice(&size);
        v.extend_from_slice(extra);
        v
    };
    for (extra, file) in [
        (
            &["--backend", "cpu", "--tile", "2080/64x64", "-o", "t.exr"][..],
            "t.exr",
        ),
        (
            &words("--backend cpu --region 8000,8000,8100,8060 -o r.exr"),
            "r.exr",
        ),
        (
            &[
                "--backend",
                "cpu",
                "--task-index",
                "5/4096",
                "--tiles",
                "64x64",
                "-o",
                "k-{tile}.exr",
            ],
            "k-0005.exr",
        ),
        (
            &words("--backend gl --region 8000,8000,8064,8048 -o g.exr"),
            "g.exr",
        ),
    ] {
        ok(run(&d, &with(extra), &[]));
        let p = fragtrace::farm::part::read_part(&d.join(file)).unwrap();
        assert_eq!((p.header.width, p.header.height), (16384, 16384), "{file}");
    }
    refused(
        &run(&d, &with(&["--backend", "cpu", "-o", "whole.png"]), &[]),
        "16384x16384 image needs about 32.0 GiB",
    );
    refused(
        &run(
            &d,
            &with(&["--backend", "cpu", "--tile", "0/2", "-o", "half.exr"]),
            &[],
        ),
        "a 16384x8192 part of 16384x16384",
    );
    assert!(!d.join("whole.png").exists() && !d.join("half.exr").exists());
}

/// `sbatch --array=3` re-running task 3 of a job of 4: with `--task-index env:4` it
/// renders tile 3 of 4 only; with `env` alone it is refused and part 0 is kept.
#[test]
fn a_rerun_of_one_index_renders_only_that_task() {
    let d = tmpdir("rerun");
    for i in 0..4 {
        ok(run(
            &d,
            &small(&["--task-index", &format!("{i}/4"), "-o", "p-{tile}.exr"]),
            &[],
        ));
    }
    let part0 = std::fs::read(d.join("p-0.exr")).unwrap();
    std::fs::remove_file(d.join("p-3.exr")).unwrap();
    let one = [
        ("SLURM_ARRAY_TASK_ID", "3"),
        ("SLURM_ARRAY_TASK_MIN", "3"),
        ("SLURM_ARRAY_TASK_MAX", "3"),
        ("SLURM_ARRAY_TASK_COUNT", "1"),
    ];
    refused(
        &run(
            &d,
            &small(&["--task-index", "env", "-o", "p-{tile}.exr"]),
            &one,
        ),
        "--task-index env:N",
    );
    assert_eq!(std::fs::read(d.join("p-0.exr")).unwrap(), part0);
    assert!(!d.join("p-3.exr").exists());
    ok(run(
        &d,
        &small(&["--task-index", "env:4", "-o", "p-{tile}.exr"]),
        &one,
    ));
    assert_eq!(std::fs::read(d.join("p-0.exr")).unwrap(), part0);
    let p = fragtrace::farm::part::read_part(&d.join("p-3.exr")).unwrap();
    assert_eq!(p.header.tile.as_deref(), Some("3/4"));
    ok(run(
        &d,
        &[
            "merge", "p-0.exr", "p-1.exr", "p-2.exr", "p-3.exr", "-o", "m.png",
        ],
        &[],
    ));
}

/// The child of [`sigterm_removes_the_partial_file`]: writes a file atomically and, with
/// the temporary file open, says so and waits to be stopped. Does nothing unless the
/// parent started it.
#[test]
fn child_writing_a_file() {
    let Ok(dir) = std::env::var("FRAGTRACE_FAULTS_CHILD") else {
        return;
    };
    let dir = PathBuf::from(dir);
    fragtrace::image_io::remove_partials_on_signal();
    let _ = fragtrace::image_io::write_atomic(&dir.join("out.exr"), |tmp| {
        std::fs::write(tmp, b"half an image").unwrap();
        std::fs::write(dir.join("ready"), b"").unwrap();
        std::thread::sleep(std::time::Duration::from_secs(60));
        Ok(())
    });
}

fn start_child(dir: &Path) -> std::process::Child {
    let child = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", "child_writing_a_file", "--nocapture"])
        .env("FRAGTRACE_FAULTS_CHILD", dir)
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while !dir.join("ready").exists() {
        assert!(
            t0.elapsed().as_secs() < 60,
            "the child never started writing"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child
}

fn partials(d: &Path) -> Vec<String> {
    files(d)
        .into_iter()
        .filter(|f| f.contains(".partial."))
        .collect()
}

/// SIGTERM (a time limit, preemption, `scancel`) while a file is being written removes the
/// temporary file; SIGKILL cannot be caught, and what it leaves is removed by the next
/// render of that file, and beside a part by the merge that takes it.
#[test]
fn sigterm_removes_the_partial_file_and_sigkill_litter_is_cleared() {
    let d = tmpdir("signal");
    let mut child = start_child(&d);
    assert_eq!(partials(&d).len(), 1, "{:?}", files(&d));
    let kill = |sig: &str, pid: u32| {
        assert!(Command::new("kill")
            .args([sig, &pid.to_string()])
            .status()
            .unwrap()
            .success())
    };
    kill("-TERM", child.id());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(143), "{status:?}");
    assert!(partials(&d).is_empty(), "{:?}", files(&d));
    assert!(!d.join("out.exr").exists());

    // SIGKILL: the partial stays, until the file is written again.
    std::fs::remove_file(d.join("ready")).unwrap();
    let mut child = start_child(&d);
    kill("-KILL", child.id());
    child.wait().unwrap();
    let left = partials(&d);
    assert_eq!(left.len(), 1, "{:?}", files(&d));
    ok(run(&d, &small(&["-o", "out.exr"]), &[]));
    assert!(partials(&d).is_empty(), "{:?}", files(&d));

    // Beside parts: a dead task's partial of part 1 goes with the merge.
    for i in 0..2 {
        ok(run(
            &d,
            &small(&["--tile", &format!("{i}/2"), "-o", &format!("p{i}.exr")]),
            &[],
        ));
    }
    let dead = left[0].split('.').nth(3).unwrap().to_string();
    std::fs::write(d.join(format!(".p1.exr.{dead}.partial.exr")), b"x").unwrap();
    ok(run(&d, &["merge", "p0.exr", "p1.exr", "-o", "m.png"], &[]));
    assert!(partials(&d).is_empty(), "{:?}", files(&d));
}

/// Merge names the missing tile; refuses a part of another fragtrace build and of
/// another tiling; refuses a set of parts of frames 3..5 whose frame 4 has no parts,
/// naming it, where today frames 3 and 5 were written; nothing is written on refusal.
#[test]
fn merge_names_what_is_missing_and_refuses_other_builds() {
    let d = tmpdir("merge");
    for i in 0..4 {
        ok(run(
            &d,
            &small(&["--task-index", &format!("{i}/4"), "-o", "p-{tile}.exr"]),
            &[],
        ));
    }
    refused(
        &run(
            &d,
            &["merge", "p-0.exr", "p-1.exr", "p-3.exr", "-o", "m.png"],
            &[],
        ),
        "missing tile 2 of 4 (pixels 0,18,24,36)",
    );
    // The same part as written by another build of this version: another commit.
    let mut other = fragtrace::farm::part::read_part(&d.join("p-1.exr")).unwrap();
    let ours = other.header.version.clone();
    let theirs = format!("{}+0123456789ab", env!("CARGO_PKG_VERSION"));
    other.header.version = theirs.clone();
    fragtrace::farm::part::write_part(&d.join("v.exr"), &other).unwrap();
    refused(
        &run(
            &d,
            &[
                "merge", "p-0.exr", "v.exr", "p-2.exr", "p-3.exr", "-o", "m.png",
            ],
            &[],
        ),
        &format!("different fragtrace builds ({theirs} against {ours})"),
    );
    // A whole image as tile 0 of 1 (what `sbatch --array=3` wrote before) with the rest.
    ok(run(
        &d,
        &small(&["--task-index", "0/1", "--tiles", "1", "-o", "w-{tile}.exr"]),
        &[],
    ));
    refused(
        &run(
            &d,
            &[
                "merge", "p-0.exr", "p-1.exr", "p-2.exr", "w-0.exr", "-o", "m.png",
            ],
            &[],
        ),
        "the image is cut differently",
    );
    assert!(!d.join("m.png").exists());

    // Frames 3..5 x 2 tiles, frame 4's parts missing.
    let anim = |extra: &[&str]| -> Vec<String> {
        let mut v: Vec<String> = [
            "render",
            TURNTABLE,
            "--backend",
            "cpu",
            "--width",
            "40",
            "--height",
            "30",
            "-q",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        v.extend(extra.iter().map(|s| s.to_string()));
        v
    };
    let a = anim(&[
        "--frames",
        "3..5",
        "--tiles",
        "2",
        "--task-index",
        "0/1",
        "-o",
        "f####-{tile}.exr",
    ]);
    ok(run(
        &d,
        &a.iter().map(String::as_str).collect::<Vec<_>>(),
        &[],
    ));
    refused(
        &run(
            &d,
            &words("merge f0003-0.exr f0003-1.exr f0005-0.exr f0005-1.exr -o m_##.png"),
            &[],
        ),
        "the parts are of the frames 3..5, but frame 4 has no parts (4 parts given)",
    );
    assert!(
        !files(&d).iter().any(|f| f.starts_with("m_")),
        "{:?}",
        files(&d)
    );
}

/// `render --task-index` into a folder that does not exist (a fresh volume: the
/// Kubernetes manifest's /parts/bunny/) makes it; so does `--frames`; a whole render into
/// a missing folder is still refused (a typo costs nothing).
#[test]
fn parts_and_frames_folders_are_made() {
    let d = tmpdir("folders");
    ok(run(
        &d,
        &small(&["--task-index", "env:2", "-o", "fresh/bunny/part-{tile}.exr"]),
        &[("JOB_COMPLETION_INDEX", "1")],
    ));
    assert!(d.join("fresh/bunny/part-1.exr").is_file());
    ok(run(
        &d,
        &[
            "render",
            TURNTABLE,
            "--backend",
            "cpu",
            "--width",
            "16",
            "--height",
            "12",
            "-q",
            "--frames",
            "0..1",
            "-o",
            "new/frames/f_##.png",
        ],
        &[],
    ));
    assert!(d.join("new/frames/f_01.png").is_file());
    refused(
        &run(&d, &small(&["-o", "nope/x.png"]), &[]),
        "folder nope does not exist",
    );
    assert!(!d.join("nope").exists());
}

/// `compare` of a part with the whole render it is a part of compares the part's pixels
/// (RMSE 0: they are the same bits), either way round; with an image of another size, or
/// a part of another region, it refuses in one line.
#[test]
fn compare_takes_a_part_as_its_region() {
    let d = tmpdir("compare");
    ok(run(&d, &small(&["-o", "whole.exr"]), &[]));
    ok(run(&d, &small(&["--tile", "1/4", "-o", "t1.exr"]), &[]));
    ok(run(&d, &small(&["--tile", "2/4", "-o", "t2.exr"]), &[]));
    for args in [
        ["compare", "t1.exr", "whole.exr", "--max-rmse", "0"],
        ["compare", "whole.exr", "t1.exr", "--max-rmse", "0"],
    ] {
        let o = ok(run(&d, &args, &[]));
        assert!(text(&o).contains("RMSE 0.000000"), "{}", text(&o));
        assert!(text(&o).contains("(432 pixels)"), "{}", text(&o));
    }
    refused(
        &run(&d, &["compare", "t1.exr", "t2.exr"], &[]),
        "compare parts of the same region",
    );
    ok(run(
        &d,
        &[
            "render",
            WHITTED,
            "--backend",
            "cpu",
            "--width",
            "40",
            "--height",
            "30",
            "-q",
            "-o",
            "other.exr",
        ],
        &[],
    ));
    refused(
        &run(&d, &["compare", "t1.exr", "other.exr"], &[]),
        "is pixels 24,0,48,18 of a 48x36 image, but other.exr is 40x30",
    );
}

/// Stepped and listed frames (`0..6:3`, `1,4`) render exactly those frames, each equal to
/// the same frame of a plain range; a frame named twice is refused.
#[test]
fn stepped_and_listed_frames() {
    let d = tmpdir("stepped");
    let anim = |frames: &str, out: &str| -> Output {
        run(
            &d,
            &[
                "render",
                TURNTABLE,
                "--backend",
                "cpu",
                "--width",
                "24",
                "--height",
                "18",
                "-q",
                "--frames",
                frames,
                "-o",
                out,
            ],
            &[],
        )
    };
    ok(anim("0..6", "all/f_##.png"));
    ok(anim("0..6:3", "step/f_##.png"));
    ok(anim("1,4", "list/f_##.png"));
    assert_eq!(files(&d.join("step")), ["f_00.png", "f_03.png", "f_06.png"]);
    assert_eq!(files(&d.join("list")), ["f_01.png", "f_04.png"]);
    for (dir, f) in [
        ("step", 0),
        ("step", 3),
        ("step", 6),
        ("list", 1),
        ("list", 4),
    ] {
        let name = format!("f_{f:02}.png");
        assert_eq!(
            std::fs::read(d.join(dir).join(&name)).unwrap(),
            std::fs::read(d.join("all").join(&name)).unwrap(),
            "{dir}/{name}"
        );
    }
    refused(&anim("1,3,1", "dup/f_##.png"), "names frame 1 twice");
    refused(
        &anim("0..6:0", "z/f_##.png"),
        "the step `0` is not a whole number >= 1",
    );
}

/// `--check` lists what a job has not written whole (missing, cut short) and exits 1;
/// `--resume` renders exactly those, leaving the whole files untouched, and the set then
/// merges to the single-process image.
#[test]
fn check_and_resume_find_and_fill_the_holes() {
    let d = tmpdir("resume");
    ok(run(&d, &small(&["-o", "single.png"]), &[]));
    let job = |extra: &[&str]| -> Output {
        let mut a = small(&["--task-index", "0/1", "--tiles", "4", "-o", "p-{tile}.exr"]);
        a.extend_from_slice(extra);
        run(&d, &a, &[])
    };
    ok(job(&[]));
    assert!(job(&["--check"]).status.success());
    std::fs::remove_file(d.join("p-2.exr")).unwrap();
    let p1 = std::fs::read(d.join("p-1.exr")).unwrap();
    std::fs::write(d.join("p-1.exr"), &p1[..p1.len() / 2]).unwrap();
    let p0 = std::fs::metadata(d.join("p-0.exr"))
        .unwrap()
        .modified()
        .unwrap();
    let o = job(&["--check"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("p-1.exr: unreadable"), "{out}");
    assert!(out.contains("p-2.exr: missing"), "{out}");
    assert!(out.contains("2 of 4 files exist whole, 2 missing"), "{out}");
    ok(job(&["--resume"]));
    assert_eq!(
        std::fs::metadata(d.join("p-0.exr"))
            .unwrap()
            .modified()
            .unwrap(),
        p0,
        "--resume rewrote a whole part"
    );
    assert!(job(&["--check"]).status.success());
    ok(run(
        &d,
        &[
            "merge", "p-0.exr", "p-1.exr", "p-2.exr", "p-3.exr", "-o", "m.png",
        ],
        &[],
    ));
    assert_eq!(
        std::fs::read(d.join("m.png")).unwrap(),
        std::fs::read(d.join("single.png")).unwrap()
    );
}

/// A part's `fragtrace.version` names the commit of the code the binary was built from
/// (`0.1.0+<12 hex digits>`, `-dirty` when built from changed code), where it was the crate
/// version alone and two builds of one version merged. `fragtrace --version` says the same.
/// Without a `-dirty` mark the code at that commit is the code of this tree.
#[test]
fn parts_name_the_commit_of_their_build() {
    let d = tmpdir("version");
    ok(run(&d, &small(&["--tile", "0/2", "-o", "p.exr"]), &[]));
    let version = fragtrace::farm::part::read_part(&d.join("p.exr"))
        .unwrap()
        .header
        .version;
    let shown = text(&ok(run(&d, &["--version"], &[])));
    assert_eq!(shown.trim(), format!("fragtrace {version}"));
    let build = version
        .strip_prefix(concat!(env!("CARGO_PKG_VERSION"), "+"))
        .unwrap_or_else(|| panic!("{version}: not the crate version and a build"));
    let (commit, dirty) = match build.strip_suffix("-dirty") {
        Some(c) => (c, true),
        None => (build, false),
    };
    let git = |args: &[&str]| {
        Command::new("git")
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .args(args)
            .output()
    };
    if git(&["rev-parse", "--git-dir"]).is_ok_and(|o| o.status.success()) {
        assert!(
            commit.len() >= 12 && commit.chars().all(|c| c.is_ascii_hexdigit()),
            "{version}: the build names no commit in a git checkout"
        );
        let exists = git(&["cat-file", "-e", &format!("{commit}^{{commit}}")]).unwrap();
        assert!(exists.status.success(), "{version}: no such commit");
        if !dirty {
            let mut diff = vec!["diff", "--quiet", commit, "--"];
            diff.extend(["src", "glsl120", "Cargo.toml", "Cargo.lock", "build.rs"]);
            let same = git(&diff).unwrap();
            assert!(same.status.success(), "{version}: the code differs from it");
        }
    } else {
        assert_eq!(build, "unknown", "{version} outside a git checkout");
    }
}

/// `merge --summary` reads a job's parts across its tasks: with task 2 of 4 missing it
/// names the task, its tiles and the re-run, gives each task's time and node, and exits 1
/// (where there was no summary at all); once task 2 is re-run the set is complete (exit 0)
/// with the spread of task times, and `-o` merges after the summary.
#[test]
fn merge_summary_across_tasks() {
    let d = tmpdir("summary");
    let task = |i: u32| {
        ok(run(
            &d,
            &small(&[
                "--task-index",
                &format!("{i}/4"),
                "--tiles",
                "8",
                "-o",
                "part-{tile}.exr",
            ]),
            &[("SLURMD_NODENAME", &format!("node{i}"))],
        ))
    };
    for i in [0, 1, 3] {
        task(i);
    }
    let parts: Vec<String> = (0..8)
        .filter(|t| ![4, 5].contains(t))
        .map(|t| format!("part-{t}.exr"))
        .collect();
    let mut args: Vec<&str> = vec!["merge", "--summary"];
    args.extend(parts.iter().map(String::as_str));
    let o = run(&d, &args, &[]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    for want in [
        "task 0 of 4: 2 of 2 parts, ",
        " on node0\n",
        "task 2 of 4: 0 of 2 parts; missing tile 4 of 8, tile 5 of 8\n",
        "6 of 8 parts done, missing: tile 4 of 8, tile 5 of 8\n",
        "to re-run: task 2 (sbatch --array=2 ... --task-index env:4)\n",
        " over 3 complete tasks\n",
    ] {
        assert!(out.contains(want), "want `{want}` in:\n{out}");
    }
    task(2);
    let all: Vec<String> = (0..8).map(|t| format!("part-{t}.exr")).collect();
    let mut args: Vec<&str> = vec!["merge", "--summary"];
    args.extend(all.iter().map(String::as_str));
    let o = ok(run(&d, &args, &[]));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("8 of 8 parts done\n") && out.contains(" over 4 complete tasks\n"),
        "{out}"
    );
    args.extend(["-o", "m.png"]);
    let o = ok(run(&d, &args, &[]));
    assert!(String::from_utf8_lossy(&o.stdout).contains("8 of 8 parts done"));
    assert!(d.join("m.png").is_file());
}
