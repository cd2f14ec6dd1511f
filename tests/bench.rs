//! `fragtrace bench` as a user runs it: the three output files, one sane CSV row per
//! configuration, error columns checked against a planted reference and recomputed by hand,
//! Pareto fronts on hand-made points, the reference cached, bad input refused (exit 2).

mod common;
use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    let mut c = common::bin();
    c.current_dir(env!("CARGO_MANIFEST_DIR"));
    c
}

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fragtrace-bench-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The CSV as header-keyed rows.
fn read_csv(path: &Path) -> Vec<std::collections::HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    assert_eq!(header.join(","), fragtrace::bench::CSV_HEADER);
    lines
        .map(|l| {
            let f = split_csv_line(l);
            assert_eq!(f.len(), header.len(), "{l}");
            header.iter().cloned().zip(f).collect()
        })
        .collect()
}

/// One CSV line's fields (RFC 4180 quoting; no line breaks inside fields here).
fn split_csv_line(line: &str) -> Vec<String> {
    let (mut fields, mut cur, mut quoted) = (Vec::new(), String::new(), false);
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                chars.next();
                cur.push('"');
            }
            ('"', _) => quoted = !quoted,
            (',', false) => fields.push(std::mem::take(&mut cur)),
            _ => cur.push(c),
        }
    }
    fields.push(cur);
    fields
}

fn num(row: &std::collections::HashMap<String, String>, key: &str) -> f64 {
    row[key]
        .parse()
        .unwrap_or_else(|_| panic!("{key} = `{}` in {row:?}", row[key]))
}

#[test]
fn tiny_bench_writes_csv_report_and_plot() {
    let d = tmpdir("tiny");
    let out = d.join("out");
    let run = |configs: &str| {
        bin()
            .args([
                "bench", "--size", "32x24", "--runs", "1", "--scenes", "whitted",
            ])
            .args(["--configs", configs, "-q", "--out"])
            .arg(&out)
            .output()
            .unwrap()
    };
    let res = run("quick");
    assert!(
        res.status.success(),
        "{}",
        String::from_utf8_lossy(&res.stderr)
    );
    assert!(
        res.stderr.is_empty(),
        "-q printed: {}",
        String::from_utf8_lossy(&res.stderr)
    );
    for f in ["results.csv", "report.md", "speed_vs_error.png"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }

    let quick: Vec<String> = fragtrace::bench::resolve_configs("quick")
        .unwrap()
        .into_iter()
        .map(|c| c.name)
        .collect();
    let rows = read_csv(&out.join("results.csv"));
    assert_eq!(rows.len(), quick.len());
    for (row, name) in rows.iter().zip(&quick) {
        assert_eq!(&row["config"], name);
        assert_eq!(row["scene"], "whitted");
        assert_eq!(row["error"], "", "{name} failed: {row:?}");
        assert_eq!(
            (row["width"].as_str(), row["height"].as_str()),
            ("32", "24")
        );
        assert_eq!(row["runs"], "1");
        let t = num(row, "time_s");
        assert!(t > 0.0 && t < 60.0, "{name}: time {t}");
        assert_eq!(row["times_s"].split(' ').count(), 1);
        assert_eq!(num(row, "rays_primary"), 768.0, "{name}");
        let kinds: f64 = [
            "rays_primary",
            "rays_shadow",
            "rays_reflected",
            "rays_refracted",
        ]
        .iter()
        .map(|k| num(row, k))
        .sum();
        assert_eq!(kinds, num(row, "rays_total"), "{name}");
        let mrays = num(row, "mrays_per_s");
        // Both columns are written with 6 decimals: allow exactly that rounding (time_s's
        // half-unit, relative to t, carried into the rate, plus the rate's own half-unit).
        let rounding = mrays * 5e-7 / t + 5e-7 + 1e-12;
        assert!(
            (mrays - num(row, "rays_total") / t / 1e6).abs() <= rounding,
            "{name}: {mrays} Mrays/s against {} rays in {t} s",
            num(row, "rays_total")
        );
        let (rmse, flip) = (num(row, "rmse"), num(row, "flip_mean"));
        assert!((0.0..0.1).contains(&rmse), "{name}: rmse {rmse}");
        assert!((0.0..0.1).contains(&flip), "{name}: flip {flip}");
        if row["backend"] == "gl" {
            assert!(num(row, "passes") > 0.0, "{name}");
        } else {
            assert_eq!(row["backend"], "cpu");
            assert_eq!(row["passes"], "");
            assert_eq!(row["gpu_ms"], "");
        }
    }
    // The f64 CPU configuration renders what the reference holds (the CPU renders are
    // deterministic), so it has no error and is on the RMSE front whatever its time. That
    // the error column measures anything is shown below, with a planted reference.
    let f64_row = rows.iter().find(|r| r["config"] == "cpu-f64").unwrap();
    assert_eq!(num(f64_row, "rmse"), 0.0);
    assert_eq!(num(f64_row, "flip_mean"), 0.0);
    assert_eq!(f64_row["pareto_rmse"], "true");
    // Pareto marks agree with the figures in the table, by the definition written out here
    // (not with `pareto_front`, which made them; that one is tested on hand-made points in
    // `pareto_front_known_answers`).
    for (err, mark) in [("rmse", "pareto_rmse"), ("flip_mean", "pareto_flip")] {
        for r in &rows {
            let (t, e) = (num(r, "time_s"), num(r, err));
            let dominated = rows.iter().any(|q| {
                let (qt, qe) = (num(q, "time_s"), num(q, err));
                qt <= t && qe <= e && (qt < t || qe < e)
            });
            assert_eq!(r[mark], (!dominated).to_string(), "{mark}: {r:?}");
        }
    }
    let quick_f32_rmse = num(
        rows.iter().find(|r| r["config"] == "cpu-f32").unwrap(),
        "rmse",
    );

    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("## whitted"), "{md}");
    for name in &quick {
        assert!(
            md.contains(&format!("| {name} |")),
            "{name} missing from the report"
        );
    }
    assert!(md.contains("**RMSE**") && md.contains("speed_vs_error.png"));
    let png = image::open(out.join("speed_vs_error.png")).unwrap();
    assert!(png.width() >= 600 && png.height() >= 300);
    // Not a blank canvas: the plot has dark pixels (axes, text) and coloured ones (points).
    let rgb = png.to_rgb8();
    assert!(rgb.pixels().any(|p| p.0.iter().all(|&c| c < 80)));
    assert!(rgb
        .pixels()
        .any(|p| p.0.iter().max().unwrap() - p.0.iter().min().unwrap() > 100));

    // The reference is cached: a second bench reuses the file.
    let refs: Vec<PathBuf> = std::fs::read_dir(out.join("references"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(refs.len(), 1, "{refs:?}");
    let stamp = std::fs::metadata(&refs[0]).unwrap().modified().unwrap();
    let again = run("cpu-f64");
    assert!(
        again.status.success(),
        "{}",
        String::from_utf8_lossy(&again.stderr)
    );
    assert_eq!(
        std::fs::metadata(&refs[0]).unwrap().modified().unwrap(),
        stamp
    );
    let rows = read_csv(&out.join("results.csv"));
    assert_eq!(rows.len(), 1);
    assert_eq!(num(&rows[0], "rmse"), 0.0);

    // The f32 row's RMSE, recomputed here from the cached reference and an in-process f32
    // render with the formula written out (not `compare`). The CSV keeps 7 significant
    // digits: relative 1e-5 allows that rounding, nothing more (measured: 1.054065e-6 in
    // the CSV, 1.0540646e-6 recomputed).
    let reference = fragtrace::image_io::read_image(&refs[0]).unwrap();
    let scene = fragtrace::scene::builtin_scene();
    let mut o = fragtrace::options::RenderOptions::for_scene(&scene);
    (o.width, o.height) = (32, 24);
    o.backend = fragtrace::options::Backend::Cpu;
    o.precision = fragtrace::options::Precision::F32;
    let f32_img = fragtrace::render::render_cpu(&scene, &o).unwrap().image;
    let rmse = |a: &[f32], b: &[f32]| {
        let sq: f64 = a
            .iter()
            .zip(b)
            .map(|(x, y)| (*x as f64 - *y as f64).powi(2))
            .sum();
        (sq / a.len() as f64).sqrt()
    };
    let want_f32 = rmse(&f32_img.data, &reference.data);
    assert!(
        want_f32 > 0.0 && (quick_f32_rmse - want_f32).abs() <= 1e-5 * want_f32,
        "cpu-f32 rmse {quick_f32_rmse}, recomputed {want_f32}"
    );

    // A planted reference with a known error: the cached reference plus 0.25 in every
    // channel. The f64 row, rendered afresh, must now be exactly 0.25 away from it (up to
    // the f32 rounding of the planted values, ~1e-7; measured 2.500000e-1), and the f32 row
    // at the RMSE computed above against the planted image (measured 0.24999996). A bench that re-rendered its reference, or compared
    // a render with itself, would report 0.
    let mut planted = reference.clone();
    planted.data.iter_mut().for_each(|v| *v += 0.25);
    fragtrace::image_io::write_image(&refs[0], &planted).unwrap();
    let res = run("cpu-f64,cpu-f32");
    assert!(
        res.status.success(),
        "{}",
        String::from_utf8_lossy(&res.stderr)
    );
    let rows = read_csv(&out.join("results.csv"));
    let f64_rmse = num(
        rows.iter().find(|r| r["config"] == "cpu-f64").unwrap(),
        "rmse",
    );
    assert!(
        (f64_rmse - 0.25).abs() < 1e-6,
        "planted reference: cpu-f64 rmse {f64_rmse}"
    );
    let want_planted = rmse(&f32_img.data, &planted.data);
    let got = num(
        rows.iter().find(|r| r["config"] == "cpu-f32").unwrap(),
        "rmse",
    );
    assert!(
        (got - want_planted).abs() <= 1e-5 * want_planted,
        "cpu-f32 rmse {got} against the planted reference, recomputed {want_planted}"
    );
    let _ = std::fs::remove_file(&refs[0]);
}

/// The Pareto front on hand-made points with known answers: dominated points, trade-offs,
/// ties, a single point, and non-finite coordinates (failed configurations).
#[test]
fn pareto_front_known_answers() {
    use fragtrace::bench::pareto_front;
    let (nan, inf) = (f64::NAN, f64::INFINITY);
    for (pts, want) in [
        (vec![], vec![]),
        (vec![(5.0, 5.0)], vec![true]),
        (vec![(1.0, 1.0), (2.0, 2.0)], vec![true, false]),
        // A trade-off curve, one point behind it, one equal in time but worse in error.
        (
            vec![(1.0, 3.0), (2.0, 2.0), (3.0, 1.0), (3.0, 3.0), (2.0, 2.5)],
            vec![true, true, true, false, false],
        ),
        // Equal points are all optimal; equal in one coordinate, worse in the other is not.
        (vec![(1.0, 1.0), (1.0, 1.0)], vec![true, true]),
        (vec![(1.0, 2.0), (1.0, 1.0)], vec![false, true]),
        (vec![(2.0, 1.0), (1.0, 1.0)], vec![false, true]),
        // Non-finite points are never optimal and dominate nothing (-inf would otherwise
        // dominate everything).
        (vec![(nan, 0.0), (1.0, 1.0)], vec![false, true]),
        (vec![(0.0, nan), (1.0, 1.0)], vec![false, true]),
        (vec![(0.0, -inf), (1.0, 1.0)], vec![false, true]),
        (vec![(inf, 0.0)], vec![false]),
        (vec![(nan, nan), (nan, nan)], vec![false, false]),
    ] {
        assert_eq!(pareto_front(&pts), want, "{pts:?}");
    }
}

/// `mark_pareto` marks each front from its own error column: hand-made rows whose RMSE and
/// FLIP fronts differ, plus a failed row.
#[test]
fn mark_pareto_uses_each_error_column() {
    let row = |config: &str, time_s: f64, rmse: f64, flip_mean: f64| fragtrace::bench::BenchRow {
        scene: "s".into(),
        config: config.into(),
        args: String::new(),
        backend: "cpu".into(),
        width: 1,
        height: 1,
        runs: 1,
        warmup_reused: false,
        times_s: vec![time_s],
        time_s,
        render_ms: 0.0,
        gpu_ms: None,
        passes: None,
        rays: Default::default(),
        mrays_per_s: 0.0,
        rmse,
        flip_mean,
        // Start from the wrong answer, so a mark left alone shows.
        pareto_rmse: config == "c",
        pareto_flip: config == "b",
        error: None,
    };
    let mut rows = vec![
        row("a", 1.0, 0.3, 0.1),
        row("b", 2.0, 0.1, 0.2),
        row("c", 3.0, 0.2, 0.05),
        row("failed", f64::NAN, f64::NAN, f64::NAN),
    ];
    fragtrace::bench::mark_pareto(&mut rows);
    let marks: Vec<(bool, bool)> = rows
        .iter()
        .map(|r| (r.pareto_rmse, r.pareto_flip))
        .collect();
    // RMSE: c (3 s, 0.2) is dominated by b (2 s, 0.1). FLIP: b (2 s, 0.2) by a (1 s, 0.1).
    assert_eq!(
        marks,
        [(true, true), (true, false), (false, true), (false, false)]
    );
}

#[test]
fn bad_bench_input_exits_2_with_a_clear_message() {
    let d = tmpdir("bad");
    let file = d.join("c.toml");
    std::fs::write(
        &file,
        "[configs]\nok = \"--backend cpu\"\nwarp = \"--backend gl --kernel warp\"\n",
    )
    .unwrap();
    let file = file.to_string_lossy().into_owned();
    for (args, want) in [
        (
            vec!["--configs", "gl-looped,gl-nonsense"],
            "unknown configuration `gl-nonsense`",
        ),
        (vec!["--configs", &file], "configuration `warp`"),
        (vec!["--configs", "missing.toml"], "missing.toml"),
        (
            vec!["--scenes", "nosuchscene"],
            "unknown scene `nosuchscene`",
        ),
        (vec!["--size", "32"], "WxH"),
        (vec!["--runs", "0"], "--runs"),
    ] {
        let out = bin()
            .args(["bench", "-q", "--out"])
            .arg(d.join("out"))
            .args(&args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(want), "{args:?}: {err}");
        if !want.starts_with('-') && want != "WxH" {
            // fragtrace's own messages are one line (clap's own carry a usage hint).
            assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        }
    }
    // Nothing was rendered or written for bad input.
    assert!(!d.join("out").join("results.csv").exists());
}

/// The progress bar is drawn on a terminal only (a pseudo-terminal from util-linux's
/// `script`), never into a pipe and never with `-q`; off a terminal one line per
/// configuration remains.
#[test]
fn bench_progress_on_a_terminal_only() {
    let d = tmpdir("progress");
    let args = "bench --scenes whitted --configs cpu-f64,cpu-f32 --size 48x32 --runs 2 --out o";
    let piped = common::bin()
        .current_dir(&d)
        .args(args.split(' '))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&piped.stderr);
    assert!(piped.status.success(), "{err}");
    assert!(
        !err.contains("renders"),
        "progress drawn into a pipe: {err}"
    );
    assert!(
        err.contains("whitted / cpu-f32: ") && err.contains("wrote "),
        "{err}"
    );
    let on_tty = |extra: &str| common::on_terminal(&d, &format!("{args} {extra}"));
    let shown = on_tty("");
    assert!(
        shown.contains("/6 renders"),
        "no progress bar on a terminal:\n{shown}"
    );
    let quiet = on_tty("-q");
    assert!(quiet.trim().is_empty(), "output despite -q:\n{quiet}");
}

/// A configuration that parses but fails to render on a scene (here: a grid over the cell
/// limit) is recorded with its error; the bench goes on and succeeds.
#[test]
fn a_failing_configuration_is_recorded_not_fatal() {
    let d = tmpdir("failing");
    let file = d.join("c.toml");
    std::fs::write(
        &file,
        "[configs]\nref = \"--backend cpu\"\nhuge = \"--backend cpu --accel uniform --grid 4000x4000x4000\"\n",
    )
    .unwrap();
    let out = bin()
        .args([
            "bench", "-q", "--size", "16x12", "--runs", "1", "--scenes", "whitted",
        ])
        .arg("--configs")
        .arg(&file)
        .arg("--out")
        .arg(d.join("out"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows = read_csv(&d.join("out").join("results.csv"));
    let names: Vec<&str> = rows.iter().map(|r| r["config"].as_str()).collect();
    assert_eq!(names, ["ref", "huge"]);
    assert_eq!(rows[0]["error"], "");
    assert!(rows[1]["error"].contains("limit exceeded"), "{:?}", rows[1]);
    assert_eq!(
        (rows[1]["time_s"].as_str(), rows[1]["pareto_rmse"].as_str()),
        ("", "false")
    );
    let md = std::fs::read_to_string(d.join("out").join("report.md")).unwrap();
    assert!(
        md.contains("huge (`--backend cpu --accel uniform --grid 4000x4000x4000`) failed"),
        "{md}"
    );
}

/// A bare `fragtrace bench` on a software GL (llvmpipe here) leaves out the default
/// preset's multipass and unrolled GL configurations (tens of minutes of passes on a CPU)
/// and says so on stderr and in report.md; `--configs default` keeps them. Run from a
/// folder whose `scenes/` holds no scene file, the bench takes the shipped scenes instead
/// of refusing with "--scenes names no scene" (`--scenes` was not given).
#[test]
fn bare_bench_fits_a_software_gl_and_takes_the_shipped_scenes() {
    let d = tmpdir("fit");
    std::fs::create_dir_all(d.join("scenes")).unwrap();
    std::fs::write(d.join("scenes").join("notes.txt"), "no scenes here").unwrap();
    let out = bin()
        .current_dir(&d)
        .args([
            "bench", "--scenes", "whitted", "--runs", "1", "--size", "16x12",
        ])
        .args(["--out", "fit"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let rows = read_csv(&d.join("fit").join("results.csv"));
    let names: Vec<&str> = rows.iter().map(|r| r["config"].as_str()).collect();
    let software = err.contains("renders GL on the CPU");
    let slow = |n: &&str| n.starts_with("gl-multipass") || n.starts_with("gl-unrolled");
    let md = std::fs::read_to_string(d.join("fit").join("report.md")).unwrap();
    if software {
        assert!(!names.iter().any(slow), "{names:?}");
        let notice = err
            .lines()
            .find(|l| l.starts_with("fragtrace: notice: bench:"))
            .unwrap();
        for left in ["gl-multipass", "gl-multipass-early-z", "gl-unrolled:16"] {
            assert!(notice.contains(left), "{notice}");
            assert!(md.contains(left), "{md}");
        }
        assert!(md.contains("- Left out: "), "{md}");
        assert!(
            names.contains(&"gl-looped") && names.contains(&"cpu-f64"),
            "{names:?}"
        );
    } else {
        // A hardware GL keeps the whole preset.
        assert!(names.iter().any(slow), "{names:?}");
        assert!(!md.contains("Left out"), "{md}");
    }
    // The shipped scenes, although ./scenes exists (the first of them, to keep it short).
    let out = bin()
        .current_dir(&d)
        .args([
            "bench",
            "--configs",
            "cpu-f32",
            "--runs",
            "1",
            "--size",
            "8x6",
        ])
        .args(["--out", "shipped", "-q"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let rows = read_csv(&d.join("shipped").join("results.csv"));
    assert!(rows.len() >= 10, "{} rows: {err}", rows.len());
}
