//! Rendering in parts (issue 28): every pixel of a region is bit-identical to the same
//! pixel of the whole render on every backend (CPU f64 and f32, the GL fragment kernels,
//! the GL compute kernel); `render --tile` parts merge to the single-process PNG byte for
//! byte; `merge` refuses a gap, an overlap or a mismatch with one line and exit 2, writing
//! nothing; `--task-index` reads Slurm's and Kubernetes' variables; `--gpu` names how many
//! devices there are. The real scheduler is tests/slurm.rs.

mod common;

use std::path::Path;
use std::process::Output;

use fragtrace::gpu::options::Kernel;
use fragtrace::options::{Backend, Precision, RenderOptions};
use fragtrace::region::{Region, Tiling};
use fragtrace::render::{render_cpu, render_gl_with, Rendered};
use fragtrace::scene::{builtin_scene, Scene};

use common::{bin, ok, refused, run, text, tmpdir};

/// Odd sizes (parts of unequal width and height), two samples per pixel (the sub-pixel
/// pattern must be the full render's too).
const W: u32 = 61;
const H: u32 = 45;

fn opts(scene: &Scene, backend: Backend, precision: Precision) -> RenderOptions {
    RenderOptions {
        width: W,
        height: H,
        spp: 2,
        backend,
        precision,
        ..RenderOptions::for_scene(scene)
    }
}

/// The regions checked: the four tiles of 2x2, a band, a single pixel at the far corner and
/// a region touching no edge.
fn regions() -> Vec<Region> {
    let mut r: Vec<Region> = (0..4)
        .map(|i| Tiling::Count(4).tile(i, W, H).unwrap())
        .collect();
    r.push(Region {
        x0: 0,
        y0: 17,
        x1: W,
        y1: 18,
    });
    r.push(Region {
        x0: W - 1,
        y0: H - 1,
        x1: W,
        y1: H,
    });
    r.push(Region {
        x0: 13,
        y0: 5,
        x1: 40,
        y1: 31,
    });
    r
}

/// Each region's pixels (colour and AOVs) equal the full render's, bit for bit.
fn check_regions(label: &str, full: &Rendered, render: impl Fn(Region) -> Rendered) {
    for r in regions() {
        let part = render(r);
        assert_eq!(
            (part.image.width, part.image.height),
            (r.width(), r.height()),
            "{label} {r}: size"
        );
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                let (a, b) = (full.image.pixel(x, y), part.image.pixel(x - r.x0, y - r.y0));
                assert_eq!(
                    a.map(f32::to_bits),
                    b.map(f32::to_bits),
                    "{label} region {r}: pixel ({x}, {y}) is {b:?} in the part, {a:?} in the whole"
                );
            }
        }
        // The rays traced scale with the pixels: a part is not a cropped full render.
        assert!(
            part.stats.rays.primary == 2 * r.area(),
            "{label} {r}: {} primary rays for {} pixels at spp 2",
            part.stats.rays.primary,
            r.area()
        );
    }
}

#[test]
fn regions_are_bit_identical_on_the_cpu() {
    let scene = builtin_scene();
    for precision in [Precision::F64, Precision::F32] {
        let o = opts(&scene, Backend::Cpu, precision);
        let full = render_cpu(&scene, &o).unwrap();
        check_regions(&format!("cpu {precision:?}"), &full, |r| {
            render_cpu(
                &scene,
                &RenderOptions {
                    region: Some(r),
                    ..o.clone()
                },
            )
            .unwrap()
        });
    }
}

#[test]
fn regions_are_bit_identical_on_every_gl_kernel() {
    let scene = builtin_scene();
    common::with_test_context(|ctx| {
        let mut kernels = vec![Kernel::Multipass, Kernel::Looped, Kernel::Unrolled(4)];
        if ctx.info.compute {
            kernels.push(Kernel::Compute);
        } else {
            panic!(
                "{} has no compute shaders: the compute kernel's regions are untested",
                ctx.info.renderer
            );
        }
        for kernel in kernels {
            let mut o = opts(&scene, Backend::Gl, Precision::F32);
            o.gpu.kernel = kernel;
            let full = render_gl_with(ctx, &scene, &o).unwrap();
            assert_eq!(full.stats.gpu.as_ref().unwrap().kernel, kernel.to_string());
            check_regions(&format!("gl {kernel}"), &full, |r| {
                render_gl_with(
                    ctx,
                    &scene,
                    &RenderOptions {
                        region: Some(r),
                        ..o.clone()
                    },
                )
                .unwrap()
            });
        }
    });
}

fn render_args(extra: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = [
        "render",
        "--backend",
        "cpu",
        "--width",
        "48",
        "--height",
        "36",
        "-q",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    v.extend(extra.iter().map(|s| s.to_string()));
    v
}

fn merge(dir: &Path, parts: &[&str], out: &str) -> Output {
    let mut a = vec!["merge".to_string()];
    a.extend(parts.iter().map(|s| s.to_string()));
    a.extend(["-o".to_string(), out.to_string()]);
    run(dir, &a, &[])
}

#[test]
fn tiles_merge_to_the_single_process_png_and_merge_refuses_bad_sets() {
    let d = tmpdir("merge");
    ok(run(&d, &render_args(&["-o", "single.png"]), &[]));
    for i in 0..3 {
        let tile = format!("{i}/3");
        ok(run(
            &d,
            &render_args(&["--tile", &tile, "-o", &format!("t{i}.exr")]),
            &[],
        ));
    }
    ok(merge(&d, &["t2.exr", "t0.exr", "t1.exr"], "merged.png"));
    assert_eq!(
        std::fs::read(d.join("merged.png")).unwrap(),
        std::fs::read(d.join("single.png")).unwrap(),
        "merged PNG differs from the single-process PNG"
    );
    // A merged EXR is itself a part of the whole image: it merges again, to the same PNG.
    ok(merge(&d, &["t0.exr", "t1.exr", "t2.exr"], "merged.exr"));
    ok(merge(&d, &["merged.exr"], "again.png"));
    assert_eq!(
        std::fs::read(d.join("again.png")).unwrap(),
        std::fs::read(d.join("single.png")).unwrap()
    );

    // A gap, an overlap, another option, another scene: refused, nothing written.
    refused(
        &merge(&d, &["t0.exr", "t2.exr"], "bad.png"),
        "gap: 576 of the 48x36 pixels",
    );
    refused(
        &merge(&d, &["t0.exr", "t1.exr", "t2.exr", "t1.exr"], "bad.png"),
        "t1.exr is given twice",
    );
    // Half of the image (a region; parts of two tilings are refused before their pixels
    // are looked at: tests/farm_faults.rs) with two thirds of it (tiles of 3): a real
    // overlap.
    ok(run(
        &d,
        &render_args(&["--region", "0,0,24,36", "-o", "half.exr"]),
        &[],
    ));
    refused(
        &merge(&d, &["half.exr", "t1.exr", "t2.exr"], "bad.png"),
        "t1.exr (pixels 16,0,32,36) overlaps half.exr in pixels 16,0,24,36",
    );
    ok(run(
        &d,
        &render_args(&["--tile", "1/3", "--spp", "2", "-o", "spp2.exr"]),
        &[],
    ));
    refused(
        &merge(&d, &["t0.exr", "spp2.exr", "t2.exr"], "bad.png"),
        "the options differ (--spp 2 against --spp 1)",
    );
    let other = d.join("other.toml");
    let whitted =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/whitted.toml"))
            .unwrap();
    std::fs::write(&other, whitted.replace("fov = 40", "fov = 41")).unwrap();
    let mut a = render_args(&["--tile", "1/3", "-o", "other.exr"]);
    a.insert(1, other.to_string_lossy().into_owned());
    ok(run(&d, &a, &[]));
    refused(
        &merge(&d, &["t0.exr", "other.exr", "t2.exr"], "bad.png"),
        "the scenes differ",
    );
    refused(
        &merge(&d, &["t0.exr", "t1.exr", "single.png"], "bad.png"),
        "single.png",
    );
    assert!(
        !d.join("bad.png").exists(),
        "a refused merge wrote its output"
    );
    let leftovers: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("bad") || n.contains("partial"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");

    // Parts must be EXR; a region may be a PNG crop with the whole render's bytes.
    refused(
        &run(&d, &render_args(&["--tile", "0/3", "-o", "t.png"]), &[]),
        "OpenEXR",
    );
    ok(run(
        &d,
        &render_args(&["--region", "10,5,30,20", "-o", "crop.png"]),
        &[],
    ));
    let crop = image::open(d.join("crop.png")).unwrap().to_rgb8();
    let single = image::open(d.join("single.png")).unwrap().to_rgb8();
    assert_eq!(crop.dimensions(), (20, 15));
    for (x, y, p) in crop.enumerate_pixels() {
        assert_eq!(p, single.get_pixel(x + 10, y + 5), "crop pixel ({x}, {y})");
    }
    refused(
        &run(
            &d,
            &render_args(&["--region", "10,5,49,20", "-o", "c.png"]),
            &[],
        ),
        "reaches outside",
    );
}

#[test]
fn task_index_from_slurm_and_kubernetes() {
    let d = tmpdir("task");
    ok(run(&d, &render_args(&["-o", "single.png"]), &[]));
    // A Slurm array 4-7 (not starting at 0) over 4 tiles, and the same as a Kubernetes
    // Indexed Job of 4 completions.
    for id in 4..8 {
        let id = id.to_string();
        ok(run(
            &d,
            &render_args(&["--task-index", "env", "-o", "s-{tile}.exr"]),
            &[
                ("SLURM_ARRAY_TASK_ID", &id),
                ("SLURM_ARRAY_TASK_MIN", "4"),
                ("SLURM_ARRAY_TASK_MAX", "7"),
                ("SLURM_ARRAY_TASK_COUNT", "4"),
            ],
        ));
    }
    ok(merge(
        &d,
        &["s-0.exr", "s-1.exr", "s-2.exr", "s-3.exr"],
        "slurm.png",
    ));
    // Kubernetes: 2 completions sharing 6 tiles (3 each).
    for i in ["0", "1"] {
        ok(run(
            &d,
            &render_args(&[
                "--task-index",
                "env:2",
                "--tiles",
                "6",
                "-o",
                "k-{tile}.exr",
            ]),
            &[("JOB_COMPLETION_INDEX", i)],
        ));
    }
    let k: Vec<String> = (0..6).map(|i| format!("k-{i}.exr")).collect();
    let k: Vec<&str> = k.iter().map(String::as_str).collect();
    ok(merge(&d, &k, "k8s.png"));
    for name in ["slurm.png", "k8s.png"] {
        assert_eq!(
            std::fs::read(d.join(name)).unwrap(),
            std::fs::read(d.join("single.png")).unwrap(),
            "{name}"
        );
    }
    let slurm = |id: &'static str| {
        [
            ("SLURM_ARRAY_TASK_ID", id),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "7"),
            ("SLURM_ARRAY_TASK_COUNT", "8"),
        ]
    };
    refused(
        &run(
            &d,
            &render_args(&["--task-index", "env", "--tiles", "4", "-o", "x-{tile}.exr"]),
            &slurm("0"),
        ),
        "8 tasks for 4 units",
    );
    refused(
        &run(
            &d,
            &render_args(&["--task-index", "env", "-o", "x.exr"]),
            &slurm("0"),
        ),
        "{tile}",
    );
    refused(
        &run(
            &d,
            &render_args(&["--task-index", "env", "-o", "x-{tile}.exr"]),
            &[],
        ),
        "SLURM_ARRAY_TASK_ID",
    );
    refused(
        &run(
            &d,
            &render_args(&["--task-index", "env", "-o", "x-{tile}.exr"]),
            &[("JOB_COMPLETION_INDEX", "1")],
        ),
        "env:N",
    );
}

#[test]
fn a_gpu_beyond_the_devices_is_refused_naming_how_many() {
    let d = tmpdir("gpu");
    let o = run(&d, &["info".to_string()], &[]);
    let out = text(&o);
    let count: usize = out
        .lines()
        .find_map(|l| l.strip_prefix("EGL devices ("))
        .and_then(|l| l.split(';').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("`fragtrace info` lists no EGL devices:\n{out}"));
    assert!(count >= 1, "{out}");
    let bad = count.to_string();
    for backend in ["gl", "auto"] {
        let a: Vec<String> = [
            "render",
            "--backend",
            backend,
            "--gpu",
            &bad,
            "--width",
            "8",
            "--height",
            "6",
            "-o",
            "g.png",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let o = run(&d, &a, &[]);
        let want = if count == 1 {
            "has 1 EGL device".to_string()
        } else {
            format!("has {count} EGL devices")
        };
        refused(&o, &want);
    }
    let a: Vec<String> = [
        "render",
        "--backend",
        "gl",
        "--gpu",
        "0",
        "--width",
        "8",
        "--height",
        "6",
        "-q",
        "-o",
        "g.png",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    ok(run(&d, &a, &[]));
}

/// `--gpu env` takes the EGL device the scheduler's variables name: the position in
/// CUDA_VISIBLE_DEVICES (or Slurm's GPU lists) or the local rank, said on stderr; a
/// variable naming a device beyond those present is one line, exit 2, naming them (also
/// under `--backend auto`, which must not fall back to the CPU then); no variable at all is
/// refused; `info --gpu env` reports on the device and says why. Here the device list is
/// Mesa's (llvmpipe), so the number is the device's position.
#[test]
fn gpu_env_takes_the_device_the_scheduler_names() {
    let d = tmpdir("gpuenv");
    let gpu_vars = [
        "CUDA_VISIBLE_DEVICES",
        "SLURM_STEP_GPUS",
        "SLURM_JOB_GPUS",
        "GPU_DEVICE_ORDINAL",
        "SLURM_LOCALID",
        "LOCAL_RANK",
        "OMPI_COMM_WORLD_LOCAL_RANK",
    ];
    let render = |backend: &str, env: &[(&str, &str)]| {
        let mut c = bin();
        c.current_dir(&d)
            .args(["render", "--backend", backend, "--gpu", "env"])
            .args(["--width", "8", "--height", "6", "-o", "g.png"]);
        for v in gpu_vars {
            c.env_remove(v);
        }
        c.envs(env.iter().copied()).output().unwrap()
    };
    let info = text(&ok(run(&d, &["info"], &[])));
    let count: usize = info
        .lines()
        .find_map(|l| l.strip_prefix("EGL devices ("))
        .and_then(|l| l.split(';').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("`fragtrace info` lists no EGL devices:\n{info}"));
    let bad = count.to_string();
    for backend in ["gl", "auto"] {
        refused(
            &render(backend, &[("CUDA_VISIBLE_DEVICES", &bad)]),
            &format!(
                "--gpu env: CUDA_VISIBLE_DEVICES={bad} names device {bad}, but this machine has {count} EGL device{}: --gpu 0 (",
                if count == 1 { "" } else { "s" }
            ),
        );
    }
    refused(
        &render("gl", &[]),
        "--gpu env: none of CUDA_VISIBLE_DEVICES",
    );
    refused(
        &render("gl", &[("SLURM_JOB_GPUS", "0,1"), ("SLURM_LOCALID", "5")]),
        "SLURM_LOCALID=5, but SLURM_JOB_GPUS=0,1 names 2 GPUs",
    );
    for env in [
        &[("CUDA_VISIBLE_DEVICES", "0")][..],
        &[("SLURM_STEP_GPUS", "0"), ("SLURM_LOCALID", "0")][..],
        &[("SLURM_LOCALID", "0")][..],
    ] {
        let o = ok(render("gl", env));
        let err = String::from_utf8_lossy(&o.stderr);
        let (k, v) = env[0];
        assert!(
            err.contains(&format!("--gpu env: {k}={v}")) && err.contains(": EGL device --gpu 0 ("),
            "{env:?}: {err}"
        );
    }
    let mut c = bin();
    c.current_dir(&d).args(["info", "--gpu", "env"]);
    for v in gpu_vars {
        c.env_remove(v);
    }
    let o = ok(c.env("CUDA_VISIBLE_DEVICES", "0").output().unwrap());
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("--gpu env: CUDA_VISIBLE_DEVICES=0: EGL device --gpu 0 (")
            && out.contains("(this report)"),
        "{out}"
    );
}

/// An animation shared out: `--frames` with `--task-index` over a Slurm array writes whole
/// frames byte-identical to `render --frames` in one process; frames cut into tiles merge
/// frame by frame to the same bytes; parts of two frames refuse a merge into one file, and
/// a range without a frame number in the name is refused.
#[test]
fn frames_shared_over_tasks_equal_the_one_process_animation() {
    let d = tmpdir("frames");
    std::fs::create_dir_all(d.join("one")).unwrap();
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/turntable.toml");
    let anim = |extra: &[&str]| -> Vec<String> {
        let mut v: Vec<String> = [
            "render",
            scene,
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
    ok(run(
        &d,
        &anim(&["--frames", "5..9", "-o", "one/f_##.png"]),
        &[],
    ));
    // 5 frames over a Slurm array of 3 (2 + 1 + 2 frames: consecutive runs).
    for id in ["0", "1", "2"] {
        ok(run(
            &d,
            &anim(&["--frames", "5..9", "--task-index", "env", "-o", "f_##.png"]),
            &[
                ("SLURM_ARRAY_TASK_ID", id),
                ("SLURM_ARRAY_TASK_MIN", "0"),
                ("SLURM_ARRAY_TASK_MAX", "2"),
                ("SLURM_ARRAY_TASK_COUNT", "3"),
            ],
        ));
    }
    let frame =
        |dir: &str, f: u32| std::fs::read(d.join(dir).join(format!("f_{f:02}.png"))).unwrap();
    for f in 5..=9 {
        assert_eq!(frame(".", f), frame("one", f), "frame {f}");
    }
    // Frames 6..7 x 3 tiles over 2 Kubernetes completions, merged per frame.
    for i in ["0", "1"] {
        ok(run(
            &d,
            &anim(&[
                "--frames",
                "6..7",
                "--tiles",
                "3",
                "--task-index",
                "env:2",
                "-o",
                "p{frame}-{tile}.exr",
            ]),
            &[("JOB_COMPLETION_INDEX", i)],
        ));
    }
    let parts: Vec<String> = [6, 7]
        .iter()
        .flat_map(|f| (0..3).map(move |t| format!("p{f:04}-{t}.exr")))
        .collect();
    let parts: Vec<&str> = parts.iter().map(String::as_str).collect();
    std::fs::create_dir_all(d.join("merged")).unwrap();
    ok(merge(&d, &parts, "merged/f_##.png"));
    for f in 6..=7 {
        assert_eq!(frame("merged", f), frame("one", f), "merged frame {f}");
    }
    refused(
        &merge(&d, &parts, "both.png"),
        "the parts are of 2 frames (6, 7)",
    );
    refused(&merge(&d, &parts[..5], "merged/g_##.png"), "gap: 420 of the 40x30 pixels are in no part, the first at row 0, columns 26..40 (2 parts given for frame 7)");
    refused(
        &run(
            &d,
            &anim(&["--frames", "5..6", "--task-index", "0/1", "-o", "nonum.png"]),
            &[],
        ),
        "run of # for the frame number",
    );
    refused(
        &run(
            &d,
            &anim(&["--frames", "5..9", "--task-index", "0/6", "-o", "f_##.png"]),
            &[],
        ),
        "6 tasks for 5 units of work (5 frames x 1 tiles)",
    );
}
