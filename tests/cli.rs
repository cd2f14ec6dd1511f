//! The binary as a user meets it: outputs, statistics, exit codes and error messages.

mod common;
use common::{bin, tmpdir, words};

#[test]
fn default_command_renders_the_builtin_scene_with_stats() {
    let d = tmpdir("default");
    let out = bin()
        .current_dir(&d)
        .args([
            "--backend",
            "cpu",
            "--width",
            "40",
            "--height",
            "30",
            "--stats",
            "s.json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let png = image::open(d.join("render.png")).unwrap();
    assert_eq!((png.width(), png.height()), (40, 30));
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("s.json")).unwrap()).unwrap();
    for key in [
        "backend",
        "device",
        "width",
        "height",
        "spp",
        "triangles",
        "grid",
        "grid_build_ms",
        "render_ms",
        "mrays_per_s",
    ] {
        assert!(s.get(key).is_some(), "stats lack `{key}`: {s}");
    }
    let rays = &s["rays"];
    assert_eq!(rays["primary"], 1200);
    let sum: u64 = ["primary", "shadow", "reflected", "refracted"]
        .iter()
        .map(|k| rays[k].as_u64().unwrap())
        .sum();
    assert_eq!(rays["total"].as_u64().unwrap(), sum);
    assert!(rays["shadow"].as_u64().unwrap() > 0 && rays["reflected"].as_u64().unwrap() > 0);
    assert_eq!(s["backend"], "cpu");
    assert_eq!(s["grid"].as_array().unwrap().len(), 3);
}

/// The EXR holds the render's linear floats: exactly what an in-process CPU render of the
/// same scene and options gives (EXR is written as f32), and its sRGB encoding is the PNG
/// written by the same command line. Measured: equal to the last bit, and every PNG byte
/// equal. An EXR holding sRGB-encoded values would differ from the render: at 8x6 the
/// built-in scene has a value 0.287 away from its own sRGB encoding (bound: > 0.1, so the
/// image is one where the encoding shows).
#[test]
fn exr_output_is_linear_float() {
    let d = tmpdir("exr");
    let args = ["--backend", "cpu", "--width", "8", "--height", "6"];
    for name in ["a.exr", "a.png"] {
        let st = bin()
            .arg("render")
            .args(args)
            .args(["-q", "-o"])
            .arg(d.join(name))
            .status()
            .unwrap();
        assert!(st.success());
    }
    let img = fragtrace::image_io::read_image(&d.join("a.exr")).unwrap();
    assert_eq!((img.width, img.height), (8, 6));
    let scene = fragtrace::scene::builtin_scene();
    let opts = fragtrace::choices::RenderArgs::try_parse_from_args(&args)
        .unwrap()
        .to_options(&scene)
        .unwrap();
    let want = fragtrace::render::render_cpu(&scene, &opts).unwrap().image;
    assert!(
        img.data == want.data,
        "EXR {:?}\nrender {:?}",
        img.data,
        want.data
    );
    // Linear, not display-encoded: some value differs from its own sRGB encoding.
    let gap = img
        .data
        .iter()
        .map(|&v| (fragtrace::image_io::linear_to_srgb(v) - v).abs())
        .fold(0.0, f32::max);
    assert!(gap > 0.1, "largest linear/sRGB gap {gap}");
    let png = image::open(d.join("a.png")).unwrap().to_rgb8().into_raw();
    assert_eq!(png, fragtrace::image_io::to_srgb8(&img));
}

#[test]
fn bad_input_exits_2_with_a_precise_message() {
    let d = tmpdir("bad");
    let scene = d.join("broken.toml");
    std::fs::write(
        &scene,
        "background = [0.1, 0.2, 0.3]\n[camera]\neye = [0, 0, 1\nlook_at = [0, 0, 0]\n",
    )
    .unwrap();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec![
                "render".into(),
                scene.display().to_string(),
                "-o".into(),
                d.join("x.png").display().to_string(),
            ],
            "broken.toml:4: camera.eye",
        ),
        (
            vec![
                "render".into(),
                "--backend".into(),
                "cpu".into(),
                "-o".into(),
                d.join("x.bmp").display().to_string(),
            ],
            "unknown image extension",
        ),
        (
            vec![
                "render".into(),
                "--width".into(),
                "0".into(),
                "-o".into(),
                d.join("y.png").display().to_string(),
            ],
            "--width 0",
        ),
        (
            vec![
                "render".into(),
                "--max-depth".into(),
                "99".into(),
                "-o".into(),
                d.join("y.png").display().to_string(),
            ],
            "--max-depth 99",
        ),
        (
            vec![
                "render".into(),
                d.join("missing.toml").display().to_string(),
            ],
            "missing.toml",
        ),
        (
            vec![
                "render".into(),
                "--backend".into(),
                "cpu".into(),
                "--width".into(),
                "4".into(),
                "--height".into(),
                "4".into(),
                "-o".into(),
                d.join("no/such/dir/x.png").display().to_string(),
            ],
            "no/such/dir",
        ),
    ];
    for (args, needle) in cases {
        let out = bin().args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(needle),
            "{args:?}: message `{err}` lacks `{needle}`"
        );
        assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
    }
    // Nothing partial was left behind.
    let left: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left.len(), 1, "{left:?}");
}

#[test]
fn compare_reports_and_bounds() {
    let d = tmpdir("compare");
    for (name, depth) in [("a.exr", "5"), ("b.exr", "0")] {
        let st = bin()
            .args([
                "render",
                "--backend",
                "cpu",
                "--width",
                "24",
                "--height",
                "18",
                "-q",
                "--max-depth",
                depth,
                "-o",
            ])
            .arg(d.join(name))
            .status()
            .unwrap();
        assert!(st.success());
    }
    let same = bin()
        .arg("compare")
        .arg(d.join("a.exr"))
        .arg(d.join("a.exr"))
        .output()
        .unwrap();
    assert!(same.status.success());
    assert!(String::from_utf8_lossy(&same.stdout).contains("identical"));
    let diff = bin()
        .arg("compare")
        .arg(d.join("a.exr"))
        .arg(d.join("b.exr"))
        .args(["--max-rmse", "0.0001", "--diff"])
        .arg(d.join("d.png"))
        .output()
        .unwrap();
    assert_eq!(
        diff.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&diff.stdout)
    );
    assert!(String::from_utf8_lossy(&diff.stdout).contains("RMSE"));
    assert!(d.join("d.png").exists());
}

/// `-v` logs every pass kind with its count (GPU fragment kernels; the compute kernel's one
/// dispatch) or the traversal work (CPU, and the compute kernel's counters).
#[test]
fn verbose_logs_pass_kinds_and_cpu_work() {
    let d = tmpdir("verbose");
    let run = |backend: &str, kernel: &[&str]| {
        let out = bin()
            .current_dir(&d)
            .args(kernel)
            .args([
                "--backend",
                backend,
                "--width",
                "24",
                "--height",
                "18",
                "-v",
                "-o",
                "v.png",
            ])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    // The CPU's default structure is the BVH: its steps are nodes, a grid's are cells.
    let cpu = run("cpu", &[]);
    assert!(
        cpu.contains("nodes visited") && cpu.contains("triangle tests"),
        "{cpu}"
    );
    assert!(
        cpu.contains("steps (nodes + triangle tests) per ray"),
        "{cpu}"
    );
    let grid = run("cpu", &["--accel", "irregular"]);
    assert!(grid.contains("cells visited"), "{grid}");
    // The fragment passes: the default kernel (`auto`) is the compute kernel on GL 4.3.
    let gl = run("gl", &["--kernel", "looped"]);
    for pass in [
        "raygen",
        "traverse_init",
        "count_rays",
        "record",
        "accum_ambient",
    ] {
        assert!(
            gl.lines()
                .any(|l| l.split_whitespace().next() == Some(pass)),
            "no `{pass}` line in:\n{gl}"
        );
    }
    assert!(gl.contains("termination queries"), "{gl}");
    // The looped kernel counts no steps without the AOV: said in one sentence.
    assert!(
        gl.lines()
            .any(|l| l
                == "primary rays: steps per ray not counted by this kernel (--aov reads them)"),
        "{gl}"
    );
    let compute = run("gl", &["--kernel", "compute"]);
    assert!(
        compute
            .lines()
            .any(|l| l.split_whitespace().take(2).eq(["compute", "1"])),
        "no `compute 1` line in:\n{compute}"
    );
    assert!(
        compute.contains("cells visited") && compute.contains("triangle tests"),
        "{compute}"
    );
    // GPU time: where timers measured something a figure, else "n/a" (and `--stats` null).
    // On llvmpipe the fragment passes' timers measure the rasterizer's work (measured: the
    // looped kernel's passes sum to 29.9 s of a 29.7 s trace on the default scene), while
    // a compute dispatch, which runs outside the rasterizer, times at 1 ns.
    let gpu_total = |log: &str| -> String {
        let total = log.lines().find(|l| l.starts_with("total: ")).unwrap();
        total
            .split(", gpu ")
            .nth(1)
            .unwrap()
            .split(',')
            .next()
            .unwrap()
            .to_owned()
    };
    let looped = gpu_total(&gl);
    assert!(looped.ends_with(" ms"), "{gl}");
    assert!(
        looped.trim_end_matches(" ms").parse::<f64>().unwrap() > 0.0,
        "{gl}"
    );
    let software = fragtrace::gpu::GlContext::new().unwrap().info.is_software();
    if software {
        assert_eq!(gpu_total(&compute), "n/a", "{compute}");
        assert!(
            compute
                .lines()
                .any(|l| l.starts_with("compute ") && l.ends_with("n/a")),
            "{compute}"
        );
        let s = stats_of(
            &d,
            &words("--backend gl --kernel compute --width 24 --height 18 -o c.png"),
            "c.json",
        );
        assert!(
            s["gpu"]["gpu_ms"].is_null() && s["gpu"]["gpu_ms_total"].is_null(),
            "{}",
            s["gpu"]
        );
    }
}

/// On a terminal the render shows a progress display; off a terminal (this test's pipes)
/// and with `-q` it draws nothing. The terminal is a pseudo-terminal from util-linux's
/// `script`, present on every Debian system.
#[test]
fn progress_shows_on_a_terminal_only() {
    let d = tmpdir("progress");
    let args = "--backend cpu --width 64 --height 2000 -o p.png";
    let piped = bin()
        .current_dir(&d)
        .args(args.split(' '))
        .output()
        .unwrap();
    assert!(piped.status.success());
    assert!(
        !String::from_utf8_lossy(&piped.stderr).contains("rows"),
        "progress drawn into a pipe"
    );
    let on_tty = |extra: &str| common::on_terminal(&d, &format!("{args} {extra}"));
    let shown = on_tty("");
    assert!(
        shown.contains("/2000 rows"),
        "no progress bar on a terminal:\n{shown}"
    );
    let quiet = on_tty("-q");
    assert!(
        !quiet.contains("rows"),
        "progress drawn despite -q:\n{quiet}"
    );
}

/// The CPU bar's ETA is honest from early on: between a tenth and half of the rows, it
/// shows at least a fifth of the whole render's time (the time left then is over half of
/// it). The rows run in an order spread over the image and the ETA takes the larger of the
/// average and the recent rate, so cheap rows of sky done first do not make it read low.
/// Before, indicatif's estimate read "0s" at 4 of 1,200 rows and up to 360 of them on a
/// 6.5 s render (and "1s" at 467 of 1,200 on a 4.2 s one). Measured: at least 0.5 of the
/// render's time in that stretch.
#[test]
fn row_eta_is_not_below_a_fifth_of_the_render_until_half_the_rows() {
    let d = tmpdir("eta");
    let shown = common::on_terminal(
        &d,
        "--backend cpu --precision f64 --width 240 --height 600 --spp 2 -o e.png",
    );
    let render_s = shown
        .split(", render ")
        .nth(1)
        .and_then(|r| r.split(" ms").next())
        .and_then(|ms| ms.parse::<f64>().ok())
        .unwrap_or_else(|| panic!("no render time:\n{shown}"))
        * 1e-3;
    let seconds = |eta: &str| -> Option<f64> {
        match eta.split_once('m') {
            Some((m, s)) => Some(
                m.parse::<f64>().ok()? * 60.0
                    + s.trim().trim_end_matches('s').parse::<f64>().ok()?,
            ),
            None => eta.trim_end_matches('s').parse().ok(),
        }
    };
    let mut checked = 0;
    for line in shown.split(['\r', '\n']) {
        let Some((rows, rest)) = line.split_once(" rows (eta ") else {
            continue;
        };
        let Some((p, t)) = rows.rsplit(' ').next().and_then(|f| f.split_once('/')) else {
            continue;
        };
        let (p, t): (f64, f64) = (p.parse().unwrap(), t.parse().unwrap());
        let eta = rest.split(')').next().unwrap();
        if p < t / 10.0 || p > t / 2.0 {
            continue;
        }
        let eta = seconds(eta).unwrap_or_else(|| panic!("eta `{eta}` in `{line}`"));
        assert!(
            eta >= 0.2 * render_s,
            "`{line}`: eta {eta} s of a {render_s} s render at {p} of {t} rows"
        );
        checked += 1;
    }
    assert!(checked >= 2, "{checked} bars checked in:\n{shown}");
}

/// `compare` prints the mean FLIP and `--max-flip` bounds it (exit 1 above), on PNG and EXR.
#[test]
fn compare_max_flip_bounds_png_and_exr() {
    let d = tmpdir("flip");
    let n = 16 * 12 * 3;
    let black = fragtrace::image_io::Image::from_rgb(16, 12, vec![0.0; n]);
    let white = fragtrace::image_io::Image::from_rgb(16, 12, vec![1.0; n]);
    for ext in ["png", "exr"] {
        let (b, w) = (d.join(format!("b.{ext}")), d.join(format!("w.{ext}")));
        fragtrace::image_io::write_image(&b, &black).unwrap();
        fragtrace::image_io::write_image(&w, &white).unwrap();
        let run = |x: &std::path::Path, y: &std::path::Path, bound: &str| {
            bin()
                .arg("compare")
                .arg(x)
                .arg(y)
                .args(["--max-flip", bound])
                .output()
                .unwrap()
        };
        let out = run(&b, &w, "0.5");
        let text = String::from_utf8_lossy(&out.stdout);
        assert_eq!(out.status.code(), Some(1), "{ext}: {text}");
        assert!(text.contains("FLIP 0.967"), "{ext}: {text}");
        assert_eq!(run(&b, &w, "0.99").status.code(), Some(0), "{ext}");
        let same = run(&w, &w, "0");
        assert_eq!(same.status.code(), Some(0), "{ext}");
        assert!(String::from_utf8_lossy(&same.stdout).contains("FLIP 0.000000"));
        // Both bounds apply: a loose FLIP bound does not hide a tight RMSE bound.
        // Captured, not inherited: compare's report would otherwise print among the test
        // results and read like a failure.
        let both = bin()
            .arg("compare")
            .arg(&b)
            .arg(&w)
            .args(["--max-flip", "1", "--max-rmse", "0.5"])
            .output()
            .unwrap();
        assert_eq!(both.status.code(), Some(1), "{ext}");
    }
}

/// `info` prints every check the README's "Minimum GL feature set" names, each on one line
/// with its value and outcome (pass, FAIL, or optional for a missing optional capability),
/// then the verdict.
#[test]
fn info_prints_every_check_with_value_and_outcome() {
    let out = bin().arg("info").output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let checks = [
        "OpenGL >= 2.1",
        "GLSL >= 1.20",
        "float textures",
        "framebuffer objects",
        "draw buffers",
        "occlusion queries",
        // 15 since the irregular grid's voxel map (still within a GeForce 6/7's 16).
        "fragment texture units (GL_MAX_TEXTURE_IMAGE_UNITS >= 15)",
        "image size (GL_MAX_TEXTURE_SIZE and GL_MAX_VIEWPORT_DIMS",
        "timer queries",
        "depth renderbuffer, for --mask early-z",
        "packed depth-stencil renderbuffer, for --mask stencil",
        "mixed-format framebuffers (RGBA16F beside RGBA32F), for --storage f16",
    ];
    for check in checks {
        let line = text
            .lines()
            .find(|l| l.trim_start().starts_with('[') && l.contains(check))
            .unwrap_or_else(|| panic!("`{check}` missing in\n{text}"));
        let outcome = ["[pass] ", "[FAIL] ", "[optional] "]
            .iter()
            .any(|s| line.trim_start().starts_with(s));
        assert!(outcome, "no outcome on `{line}`");
        let value = line.rsplit_once(": ").map(|(_, v)| v.trim());
        assert!(value.is_some_and(|v| !v.is_empty()), "no value on `{line}`");
    }
    assert!(text.contains("Verdict: OK"), "{text}");
}

/// `--stats` on GL reports the compiled-in scene features as an object of named booleans,
/// not a debug string.
#[test]
fn gl_stats_report_features_as_named_booleans() {
    let d = tmpdir("features");
    let out = bin()
        .current_dir(&d)
        .args([
            "--backend",
            "gl",
            "--width",
            "16",
            "--height",
            "12",
            "--stats",
            "s.json",
            "-q",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("s.json")).unwrap()).unwrap();
    let f = s["gpu"]["features"]
        .as_object()
        .unwrap_or_else(|| panic!("gpu.features is not an object: {}", s["gpu"]));
    let mut names: Vec<&str> = f.keys().map(String::as_str).collect();
    names.sort_unstable();
    assert_eq!(
        names,
        [
            "checker",
            "fresnel",
            "refraction",
            "smooth_normals",
            "specular"
        ]
    );
    assert!(f.values().all(|v| v.is_boolean()), "{f:?}");
}

/// `render_ms` means one thing on both backends: tracing, shading and read-back. A GL
/// render's first frame compiles its programs and uploads the scene; those are
/// `setup_ms` (= `gpu.compile_ms` + `gpu.upload_ms`) and shown apart on the summary line,
/// and the ray rate is over `render_ms` in a unit that keeps its figures. Before, GL's
/// `render_ms` held the compile (cornell.toml at 96x72: "render 9159 ms ... (0.00
/// Mrays/s)", the next run 271 ms). Bound: what `render_ms` holds besides the pass loop
/// (`gpu.trace_ms`, which may hold a late upload itself) is under the compile it no longer
/// holds (measured with both shader caches off: compile 318 ms against a few ms of render
/// targets and state).
#[test]
fn gl_render_ms_excludes_compile_and_upload_as_the_cpu_excludes_its_build() {
    let d = tmpdir("render-ms");
    for (backend, kernel) in [("gl", "looped"), ("gl", "compute"), ("cpu", "")] {
        let gl = ["--kernel", kernel, "--shader-cache", "off"];
        // Mesa's own shader cache off too: the compile is a real one, as on a first run.
        let out = bin()
            .current_dir(&d)
            .env("MESA_SHADER_CACHE_DISABLE", "true")
            .args(["--backend", backend])
            .args(if backend == "gl" { &gl[..] } else { &[] })
            .args(["--width", "48", "--height", "36", "--stats", "s.json"])
            .args(["-o", "r.png"])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{backend} {kernel}: {err}");
        let s: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join("s.json")).unwrap()).unwrap();
        let num = |v: &serde_json::Value| v.as_f64().unwrap_or_else(|| panic!("{v} in {s}"));
        let (render_ms, setup_ms) = (num(&s["render_ms"]), num(&s["setup_ms"]));
        let case = format!("{backend} {kernel}: {err}");
        assert!(render_ms > 0.0, "{case}");
        let rays = s["rays"]["total"].as_u64().unwrap();
        let rate = fragtrace::output::ray_rate(rays, render_ms);
        assert!(
            err.contains(&format!("render {render_ms:.1} ms, {rays} rays ({rate})")),
            "want the rate over render_ms, {rate}: {case}"
        );
        assert!(!err.contains(" 0.00 Mrays/s"), "{case}");
        assert!(
            (num(&s["mrays_per_s"]) - rays as f64 / render_ms * 1e-3).abs() < 1e-9,
            "{case}"
        );
        if backend == "cpu" {
            assert_eq!(setup_ms, 0.0, "{case}");
            assert!(!err.contains("compile "), "{case}");
            continue;
        }
        let g = &s["gpu"];
        let (compile, upload) = (num(&g["compile_ms"]), num(&g["upload_ms"]));
        assert!(g["programs_compiled"].as_u64().unwrap() > 0, "{case}");
        assert!((setup_ms - (compile + upload)).abs() < 1e-9, "{case}");
        assert!(
            err.contains(&format!(
                "compile {compile:.1} ms, upload {upload:.1} ms, render"
            )),
            "{case}"
        );
        let trace = num(&g["trace_ms"]);
        assert!(
            render_ms + setup_ms >= trace && render_ms < trace + compile,
            "render_ms {render_ms} against trace {trace} and compile {compile}: {case}"
        );
    }
}

/// The GL render's progress on a terminal: a percentage of the ray traces run with an ETA,
/// never moving back; nothing in a pipe. The fragment kernels report it between passes
/// (the compute kernel's one dispatch has no in-between).
#[test]
fn gl_progress_shows_a_monotone_percentage_and_eta() {
    let d = tmpdir("glprogress");
    let args = "--backend gl --kernel looped --width 64 --height 48 -o p.png";
    let piped = bin()
        .current_dir(&d)
        .args(args.split(' '))
        .output()
        .unwrap();
    assert!(piped.status.success());
    assert!(
        !String::from_utf8_lossy(&piped.stderr).contains("% (eta"),
        "progress drawn into a pipe"
    );
    let shown = common::on_terminal(&d, args);
    let percents: Vec<u32> = shown
        .split("% (eta ")
        .filter_map(|before| {
            let digits = before
                .trim_end()
                .rsplit(|c: char| !c.is_ascii_digit())
                .next()?;
            digits.parse().ok()
        })
        .collect();
    assert!(
        !percents.is_empty(),
        "no percentage on a terminal:\n{shown}"
    );
    assert!(
        percents.windows(2).all(|w| w[0] <= w[1]),
        "the percentage moved back: {percents:?}"
    );
    assert!(
        percents.iter().all(|&p| p <= 100) && *percents.last().unwrap() > 0,
        "{percents:?}"
    );
    assert!(shown.contains("rays active"), "{shown}");
}

/// Runs the binary in `d` with `args`, requires success, and returns the `--stats` JSON
/// it wrote to `stats`.
fn stats_of(d: &std::path::Path, args: &[&str], stats: &str) -> serde_json::Value {
    let out = bin()
        .current_dir(d)
        .args(args)
        .args(["--stats", stats, "-q"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&std::fs::read(d.join(stats)).unwrap()).unwrap()
}

/// `--accel uniform`, `irregular` and `bvh` render on the CPU, the grids on GL too, and
/// `--stats` reports the structure built: its kind, resolution (none for the BVH), memory
/// and cell (node) counts, the top resolution only for the irregular grid. `auto`, the
/// default, is the BVH on the CPU and the irregular grid on GL, and the irregular grid on
/// the CPU with `--grid-density`. The three structures find the same closest hits, so the
/// f64 CPU renders the same PNG on each (measured: every byte equal).
#[test]
fn accel_flag_selects_the_structure_and_stats_report_it() {
    let d = tmpdir("accel");
    let size = ["--width", "40", "--height", "30"];
    let mut pngs = Vec::new();
    for (accel, backend, want) in [
        (None, "cpu", "bvh"),
        (Some("auto"), "cpu", "bvh"),
        (Some("uniform"), "cpu", "uniform"),
        (Some("irregular"), "cpu", "irregular"),
        (Some("bvh"), "cpu", "bvh"),
        (None, "gl", "irregular"),
        (Some("uniform"), "gl", "uniform"),
        (Some("irregular"), "gl", "irregular"),
    ] {
        let png = format!("{}-{backend}.png", accel.unwrap_or("default"));
        let mut args = vec!["--backend", backend, "-o", &png];
        args.extend(size);
        if let Some(a) = accel {
            args.extend(["--accel", a]);
        }
        let s = stats_of(&d, &args, "s.json");
        let a = &s["accel"];
        assert_eq!(a["kind"], want, "{args:?}: {a}");
        assert_eq!(s["backend"], backend);
        let res = a["resolution"].as_array().unwrap();
        assert_eq!(res.len(), 3, "{a}");
        assert!(
            res.iter().all(|r| r.as_u64().unwrap() >= 1) == (want != "bvh"),
            "{a}"
        );
        assert_eq!(
            a.get("top_resolution").is_some(),
            want == "irregular",
            "{a}"
        );
        let cells = a["cells"].as_u64().unwrap();
        assert!(
            cells > 0 && a["empty_cells"].as_u64().unwrap() < cells,
            "{a}"
        );
        // The BVH holds every triangle once; a grid at least once.
        let (refs, tris) = (a["references"].as_u64().unwrap(), s["triangles"].as_u64());
        assert!(
            refs >= tris.unwrap() && (want != "bvh" || Some(refs) == tris),
            "{a}"
        );
        assert!(a["bytes"].as_u64().unwrap() > 0, "{a}");
        assert!(a["bytes_per_triangle"].as_f64().unwrap() > 0.0, "{a}");
        assert!(a["build_ms"].as_f64().unwrap() >= 0.0, "{a}");
        assert!(!a["detail"].as_str().unwrap().is_empty(), "{a}");
        let img = image::open(d.join(&png)).unwrap();
        assert_eq!((img.width(), img.height()), (40, 30));
        if backend == "cpu" {
            pngs.push(img.to_rgb8().into_raw());
        }
    }
    assert!(
        pngs.iter().all(|p| *p == pngs[0]),
        "the f64 CPU renders differ between structures"
    );
    // `auto` with a grid density asks for a grid: the irregular one.
    let s = stats_of(
        &d,
        &words("--backend cpu --grid-density 0.5 -o dens.png"),
        "s.json",
    );
    assert_eq!(s["accel"]["kind"], "irregular", "{s}");
}

/// Output formats by extension, as the `image` crate writes them: Radiance HDR, TIFF and
/// PPM besides PNG and EXR. Each file is what its extension says (magic bytes), and reads
/// back as the render: TIFF is the EXR's linear f32 exactly, PPM the PNG's 8-bit sRGB
/// exactly, HDR within RGBE's shared-exponent rounding (measured RMSE 2.4e-3, max 5.4e-3
/// against the EXR on the built-in scene at 32x24; bound 1e-2).
#[test]
fn output_formats_by_extension() {
    use fragtrace::image_io::read_image;
    let d = tmpdir("formats");
    for (name, magic) in [
        ("a.exr", &b"\x76\x2f\x31\x01"[..]),
        ("a.png", &b"\x89PNG"[..]),
        ("a.hdr", &b"#?RADIANCE"[..]),
        ("a.tif", &b"II*\0"[..]),
        ("a.TIFF", &b"II*\0"[..]),
        ("a.ppm", &b"P6\n32 24 255\n"[..]),
    ] {
        let out = bin()
            .current_dir(&d)
            .args(["--backend", "cpu", "--width", "32", "--height", "24", "-q"])
            .args(["-o", name])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let bytes = std::fs::read(d.join(name)).unwrap();
        assert!(bytes.starts_with(magic), "{name}: {:?}", &bytes[..16]);
    }
    let read = |n: &str| read_image(&d.join(n)).unwrap();
    let (exr, png) = (read("a.exr"), read("a.png"));
    assert_eq!(read("a.tif").data, exr.data, "TIFF is the linear f32 image");
    assert_eq!(read("a.TIFF").data, exr.data);
    assert_eq!(read("a.ppm").data, png.data, "PPM is the PNG's 8-bit sRGB");
    let hdr = read("a.hdr");
    let rmse = (hdr
        .data
        .iter()
        .zip(&exr.data)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f32>()
        / exr.data.len() as f32)
        .sqrt();
    assert!(rmse > 0.0 && rmse < 1e-2, "HDR RMSE {rmse}");
    // An unknown extension names the ones there are.
    let out = bin()
        .current_dir(&d)
        .args(["--backend", "cpu", "-q", "-o", "a.bmp"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains(".hdr") && err.contains(".tif") && err.contains(".ppm"),
        "{err}"
    );
}

/// The summary line names the structure by what it is, and each figure as `--stats` labels
/// it: the uniform grid's cells per axis (`grid`); for the irregular grid its top grid
/// (`grid_top`), its finest cells per axis (`grid`, the virtual resolution, labelled
/// "finest" so that e.g. 1998848x65536x1998848 on ground.toml does not read as a cell
/// count) and its cells. Before, the JSON's `grid` said 352x352x352 where the summary said
/// only "top 11x11x11".
#[test]
fn summary_line_and_stats_label_the_irregular_grid_alike() {
    let d = tmpdir("summary-accel");
    for accel in ["irregular", "uniform"] {
        let out = bin()
            .current_dir(&d)
            .args(["--backend", "cpu", "--width", "40", "--height", "30"])
            .args(["--accel", accel, "--stats", "s.json", "-o", "s.png"])
            .output()
            .unwrap();
        assert!(out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        let s: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join("s.json")).unwrap()).unwrap();
        let a = &s["accel"];
        let axes = |v: &serde_json::Value| {
            let r: Vec<String> = v
                .as_array()
                .unwrap_or_else(|| panic!("not three axes: {v}"))
                .iter()
                .map(|x| x.to_string())
                .collect();
            r.join("x")
        };
        assert_eq!(s["grid"], a["resolution"], "{s}");
        let want = if accel == "irregular" {
            assert_eq!(s["grid_top"], a["top_resolution"], "{s}");
            format!(
                "irregular grid (top {}, finest {}, {} cells) (",
                axes(&s["grid_top"]),
                axes(&s["grid"]),
                a["cells"]
            )
        } else {
            assert!(s.get("grid_top").is_none(), "{s}");
            format!("uniform grid {} (", axes(&s["grid"]))
        };
        assert!(err.contains(&want), "{accel}: want `{want}` in\n{err}");
    }
}

/// `--grid-density` sets the uniform grid's cells per triangle with `--accel uniform` and
/// the irregular grid's top cells per triangle with `--accel irregular` (the default):
/// 8x the density gives 8x the cells up to rounding of each axis (bounds 4x..16x; the
/// built-in scene's uniform and top grids are flat, so one axis rounds coarsely).
/// `--grid AxBxC` fixes the uniform grid's resolution.
#[test]
fn grid_density_applies_to_either_structure() {
    let d = tmpdir("density");
    let base = [
        "--backend",
        "cpu",
        "--width",
        "8",
        "--height",
        "6",
        "-o",
        "x.png",
    ];
    let cells = |extra: &[&str], key: &str| -> u64 {
        let mut args = base.to_vec();
        args.extend(extra);
        let s = stats_of(&d, &args, "s.json");
        s["accel"][key]
            .as_array()
            .unwrap_or_else(|| panic!("{extra:?}: no {key} in {}", s["accel"]))
            .iter()
            .map(|v| v.as_u64().unwrap())
            .product()
    };
    for (accel, key, lo, hi) in [
        ("uniform", "resolution", "1", "8"),
        ("irregular", "top_resolution", "0.125", "1"),
    ] {
        let a = cells(&["--accel", accel, "--grid-density", lo], key);
        let b = cells(&["--accel", accel, "--grid-density", hi], key);
        println!("{accel}: density {lo}: {a} cells, {hi}: {b} cells");
        assert!(b >= 4 * a && b <= 16 * a, "{accel}: {a} -> {b} cells");
    }
    let fixed = stats_of(
        &d,
        &[&base[..], &["--accel", "uniform", "--grid", "8x8x8"]].concat(),
        "s.json",
    );
    assert_eq!(fixed["accel"]["resolution"], serde_json::json!([8, 8, 8]));
}

/// The irregular grid in a GL 2.1 / GLSL 1.20 context (Mesa's version override) with the
/// faithful multipass kernel renders what the f32 CPU renders on the same structure, on
/// the built-in scene and the bunny. Bound: RMSE 2e-5 of the linear EXR values, as
/// tests/gpu_backend.rs bounds GL against its f32 twin (measured here: see the printed
/// values).
#[test]
fn gl21_irregular_multipass_equals_cpu_f32() {
    let d = tmpdir("gl21");
    let models = std::env::var("FRAGTRACE_MODEL_PATH")
        .unwrap_or_else(|_| concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/models").to_string());
    let bunny = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/bunny.toml");
    for scene in [None, Some(bunny)] {
        let mut images = Vec::new();
        for (backend, out) in [("gl", "gl.exr"), ("cpu", "cpu.exr")] {
            let mut cmd = bin();
            cmd.current_dir(&d)
                .env("FRAGTRACE_MODEL_PATH", &models)
                .args(["render", "--backend", backend, "--accel", "irregular"])
                .args(["--width", "48", "--height", "36", "--stats", "s.json", "-q"])
                .args(["-o", out]);
            // Each backend's own flags: the other's are refused.
            match backend {
                "gl" => cmd.args(["--kernel", "multipass"]),
                _ => cmd.args(["--precision", "f32"]),
            };
            if backend == "gl" {
                cmd.env("MESA_GL_VERSION_OVERRIDE", "2.1")
                    .env("MESA_GLSL_VERSION_OVERRIDE", "120");
            }
            if let Some(s) = scene {
                cmd.arg(s);
            }
            let o = cmd.output().unwrap();
            assert!(
                o.status.success(),
                "{backend} {scene:?}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            let s: serde_json::Value =
                serde_json::from_slice(&std::fs::read(d.join("s.json")).unwrap()).unwrap();
            assert_eq!(s["accel"]["kind"], "irregular");
            if backend == "gl" {
                let v = s["gpu"]["gl_version"].as_str().unwrap().to_owned();
                let mesa = v.contains("Mesa");
                assert!(!mesa || v.starts_with("2.1"), "not a GL 2.1 context: {v}");
            }
            images.push(fragtrace::image_io::read_image(&d.join(out)).unwrap());
        }
        let c = fragtrace::compare::compare(&images[0], &images[1], 0.02, true).unwrap();
        println!(
            "{}: GL 2.1 irregular multipass vs CPU f32: RMSE {:.2e}, {c}",
            scene.unwrap_or("builtin"),
            c.rmse
        );
        assert!(images[0].all_finite());
        assert!(c.rmse <= 2e-5, "{scene:?}: {c}");
    }
}

/// `--backend auto` on a software rasterizer (llvmpipe here and in CI) takes the CPU and
/// says why in one line naming the driver and `--backend gl` (nothing with `-q`), rendering
/// the image `--backend cpu` renders (every PNG byte equal); `--backend gl` still renders on
/// that GL, and `info` says which backend `auto` takes. Whole renders, parts (`--tile`)
/// and animations (`--frames`) resolve it the same way, and build the structure `--accel
/// auto` names for the backend taken (the BVH on the CPU, the irregular grid on GL). On a
/// hardware GL `auto` takes GL without a word.
#[test]
fn auto_backend_takes_the_cpu_over_a_software_gl_and_says_so() {
    let d = tmpdir("auto");
    let renderer = match fragtrace::gpu::GlContext::new() {
        Ok(ctx) => ctx.info.renderer.clone(),
        Err(e) => {
            println!("no usable GL ({e}): auto falls back to the CPU for that reason instead");
            return;
        }
    };
    let software = fragtrace::gpu::info::software_renderer(&renderer);
    // The shortcut `auto` takes before making a context (every EGL device Mesa's software
    // one) must agree with the context's own renderer string.
    let shortcut = fragtrace::gpu::egl::software_only(None);
    assert!(
        !shortcut || software,
        "software-only devices, yet {renderer}"
    );
    let want = if software { "cpu" } else { "gl" };
    let (want_accel, accel_brief) = if software {
        ("bvh", "4-wide BVH")
    } else {
        ("irregular", "irregular grid")
    };
    let run = |args: &[&str]| {
        let o = bin().current_dir(&d).args(args).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{args:?}: {err}");
        err
    };
    let size = ["--width", "24", "--height", "18"];
    let render = |extra: &[&str], out: &str| -> (String, String) {
        let mut a = vec!["render", "-o", out, "--stats", "s.json"];
        a.extend(size);
        a.extend(extra);
        let err = run(&a);
        let s: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join("s.json")).unwrap()).unwrap();
        let kind = s["accel"]["kind"].as_str().unwrap();
        let backend = s["backend"].as_str().unwrap();
        assert_eq!(
            kind == "bvh",
            backend == "cpu",
            "{extra:?}: {kind} on {backend}"
        );
        (backend.to_owned(), err)
    };
    let notices = |err: &str| -> Vec<String> {
        err.lines()
            .filter(|l| l.contains("notice"))
            .map(str::to_owned)
            .collect()
    };
    let (backend, err) = render(&[], "auto.png");
    assert_eq!(backend, want, "{renderer}: {err}");
    let seen = notices(&err);
    if software {
        assert_eq!(seen.len(), 1, "{err}");
        let n = &seen[0];
        // Named by its renderer string, or, where no context was needed to know, as
        // Mesa's software device.
        let driver = match shortcut {
            true => "Mesa's software rasterizer (EGL_MESA_device_software",
            false => renderer.as_str(),
        };
        for part in [
            "fragtrace: notice: using the CPU backend: ",
            driver,
            "software rasterizer",
            "--backend gl",
        ] {
            assert!(n.contains(part), "`{part}` missing in: {n}");
        }
        // A GPU setting under `auto` is accepted (either backend may run); where the CPU
        // runs, the same one-line notice says it was not used (it used to be silent).
        let (_, err) = render(&["--kernel", "looped", "--mask", "stencil"], "k.png");
        let seen = notices(&err);
        assert_eq!(seen.len(), 1, "{err}");
        assert!(
            seen[0].ends_with("; --kernel looped, --mask stencil do not apply on the CPU"),
            "{err}"
        );
        render(&["--backend", "cpu"], "cpu.png");
        assert!(
            std::fs::read(d.join("auto.png")).unwrap() == std::fs::read(d.join("cpu.png")).unwrap(),
            "auto and --backend cpu rendered different images"
        );
    } else {
        assert!(seen.is_empty(), "{err}");
    }
    let mut quiet = vec!["render", "-q", "-o", "q.png"];
    quiet.extend(size);
    assert_eq!(run(&quiet), "", "-q printed something");
    assert_eq!(render(&["--backend", "gl"], "gl.png").0, "gl");
    // Parts: the summary line of each names the backend.
    let mut tile = vec!["render", "--tile", "0/2", "-o", "t.exr"];
    tile.extend(size);
    let err = run(&tile);
    assert!(err.contains(&format!(" on {want} [")), "{err}");
    assert!(err.contains(accel_brief), "{err}");
    assert_eq!(notices(&err).len(), usize::from(software), "{err}");
    // An animation: one camera path over a sphere, two frames.
    std::fs::write(
        d.join("anim.toml"),
        "[animation.orbit]\ncentre = [0, 0, 0]\nradius = 4\nheight = 1\nframes = 8\nfov = 40\n\
         [[lights]]\nposition = [2, 4, 3]\n[[objects]]\nshape = \"sphere\"\n",
    )
    .unwrap();
    let mut frames = vec!["render", "anim.toml", "--frames", "0..1", "-o", "f_#.png"];
    frames.extend(size);
    frames.extend(["--stats", "f.json"]);
    let err = run(&frames);
    assert!(
        err.contains(&format!("2 frames of 24x18 on {want}")),
        "{err}"
    );
    let f: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("f.json")).unwrap()).unwrap();
    assert_eq!(
        f["per_frame"][0]["render"]["accel"]["kind"], want_accel,
        "{f}"
    );
    assert_eq!(notices(&err).len(), usize::from(software), "{err}");
    let o = bin().arg("info").output().unwrap();
    let info = String::from_utf8_lossy(&o.stdout);
    let line = info
        .lines()
        .find(|l| l.starts_with("--backend auto:"))
        .unwrap_or_else(|| panic!("no `--backend auto:` line in:\n{info}"));
    assert!(
        line.split_whitespace().nth(2) == Some(want),
        "{renderer}: {line}"
    );
    if software {
        assert!(line.contains("software rasterizer"), "{line}");
    }
}

/// `-o x.jpg` writes a JPEG (8-bit sRGB, quality `JPEG_QUALITY`) of the image the PNG holds,
/// within JPEG's loss; `--threads N` renders on N threads (the summary says so) the same
/// image as the default pool.
#[test]
fn jpeg_output_and_threads() {
    let d = tmpdir("jpeg");
    let size = ["--width", "64", "--height", "48", "--backend", "cpu"];
    let run = |extra: &[&str]| {
        let o = bin()
            .current_dir(&d)
            .arg("render")
            .args(size)
            .args(extra)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{extra:?}: {err}");
        err
    };
    run(&["-o", "a.png"]);
    run(&["-o", "a.jpg", "--threads", "1", "--stats", "s.json"]);
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("s.json")).unwrap()).unwrap();
    let device = s["device"].as_str().unwrap();
    assert!(device.starts_with("cpu (1 thread,"), "{device}");
    let jpg = std::fs::read(d.join("a.jpg")).unwrap();
    assert_eq!(&jpg[..3], &[0xFF, 0xD8, 0xFF], "a JPEG file");
    let a = image::open(d.join("a.png")).unwrap().to_rgb8();
    let b = image::load_from_memory(&jpg).unwrap().to_rgb8();
    assert_eq!(a.dimensions(), b.dimensions());
    let diffs: Vec<f64> = a
        .as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(&x, &y)| (x as f64 - y as f64).abs())
        .collect();
    let mean = diffs.iter().sum::<f64>() / diffs.len() as f64;
    // Measured 1.0 on the built-in scene at 64x48; JPEG at quality 95 is far closer than a
    // wrong image (every other image differs by tens of codes).
    assert!(mean < 3.0, "mean absolute difference {mean} codes");
    // EXR as the farm's parts are written: ZIP-compressed scanlines, not tiles.
    run(&["-o", "a.exr"]);
    let exr = std::fs::read(d.join("a.exr")).unwrap();
    let has = |attr: &[u8]| exr.windows(attr.len()).any(|w| w == attr);
    assert!(has(b"compression\0compression\0") && !has(b"tiles\0tiledesc"));
    assert!(
        exr.len() < 64 * 48 * 12,
        "{} bytes: not compressed",
        exr.len()
    );
    run(&["-o", "b.png", "--threads", "2"]);
    assert_eq!(
        std::fs::read(d.join("a.png")).unwrap(),
        std::fs::read(d.join("b.png")).unwrap(),
        "--threads changed the image"
    );
}

/// One frame is "1 frame", with no rate "after the first" (there is no second).
#[test]
fn one_frame_is_one_frame() {
    let d = tmpdir("oneframe");
    std::fs::write(
        d.join("anim.toml"),
        "[animation.orbit]\ncentre = [0, 0, 0]\nradius = 4\nheight = 1\nframes = 8\nfov = 40\n\
         [[lights]]\nposition = [2, 4, 3]\n[[objects]]\nshape = \"sphere\"\n",
    )
    .unwrap();
    let run = |frames: &str| {
        let o = bin()
            .current_dir(&d)
            .args(["render", "anim.toml", "--backend", "cpu", "--width", "16"])
            .args(["--height", "12", "--frames", frames, "-o", "f_#.png"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{o:?}");
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let one = run("3..3");
    assert!(
        one.contains(": 1 frame of 16x12") && !one.contains("frames/s"),
        "{one}"
    );
    let two = run("0..1");
    assert!(
        two.contains(": 2 frames of 16x12") && two.contains("frames/s after the first"),
        "{two}"
    );
}

/// No test writes into the user's home: the binary's program-binary cache (on by default,
/// in `~/.cache/fragtrace`) goes to the test process's own folder. Every test crate runs
/// the binary through `common::bin()` (or hands `common::exe()` to a script together with
/// that folder), and a GL render through it with HOME elsewhere leaves HOME untouched and
/// its programs in `common::shader_cache_dir()`.
#[test]
fn tests_keep_the_shader_cache_out_of_the_home_folder() {
    let tests = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let mut sources = Vec::new();
    let mut stack = vec![tests.clone()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                sources.push(p);
            }
        }
    }
    let mut offenders = Vec::new();
    for p in &sources {
        let src = std::fs::read_to_string(p).unwrap();
        let name = p.strip_prefix(&tests).unwrap().display().to_string();
        if name == "common/mod.rs" {
            continue;
        }
        if src.contains(concat!("CARGO_BIN_EXE_", "fragtrace")) {
            offenders.push(format!("{name} names the binary itself"));
        }
        if src.contains("common::exe()") && !src.contains("common::shader_cache_dir()") {
            offenders.push(format!(
                "{name} runs common::exe() without the cache folder"
            ));
        }
    }
    assert!(
        offenders.is_empty(),
        "run the binary through common::bin(): {offenders:?}"
    );

    let d = tmpdir("home");
    let home = d.join("home");
    std::fs::create_dir_all(&home).unwrap();
    let out = bin()
        .current_dir(&d)
        .env("HOME", &home)
        .env_remove("XDG_CACHE_HOME")
        .env("FRAGTRACE_SHADER_CACHE", "on")
        // Mesa's own disk cache on (llvmpipe offers program binaries only with it), in d.
        .env("MESA_SHADER_CACHE_DIR", d.join("mesa"))
        .env_remove("MESA_SHADER_CACHE_DISABLE")
        .args(["--backend", "gl", "--width", "16", "--height", "12", "-q"])
        .args(["-o", "g.png"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", common::text(&out));
    let left: Vec<_> = std::fs::read_dir(&home)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert!(left.is_empty(), "the render wrote into HOME: {left:?}");
    let programs = common::shader_cache_dir().join("programs");
    assert!(
        std::fs::read_dir(&programs).is_ok_and(|mut r| r.next().is_some()),
        "no program binaries in {}",
        programs.display()
    );
}
