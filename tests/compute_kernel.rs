//! The compute kernel (`--kernel compute`, GLSL 4.30: the whole ray tree of every pixel in
//! one dispatch) against the looped fragment kernel, which runs the same step and shade
//! GLSL pass by pass, and against the CPU renderers, on every shipped scene and both
//! structures (`--accel uniform|irregular`, the CPU on the same one); and `--kernel
//! auto` in a GL 2.1 context (Mesa's version override, in a child process), where it must
//! pick the faithful multipass kernel while `--kernel compute` is refused.
//!
//! Bars (measured on llvmpipe, each beside its bound): compute and looped render the same
//! bits (every linear value and every AOV of every pixel) and count the same rays of every
//! kind, so which of the two ran is invisible in the output (issue 52: `--kernel auto`
//! starts on looped while compute compiles); against the f64 CPU reference compute is held to
//! tests/gpu_backend.rs's bounds for GL; its work counters (cells entered, triangle tests)
//! are the f32 CPU's to `WORK_REL`. Where the driver ends the kernel's loops early
//! (llvmpipe's loop limit, `LLVMPIPE_LOOP_LIMITED`), the render must fail with the
//! kernel's "did not finish" error, never return an image missing rays.

mod common;

use std::path::Path;
use std::process::Command;

use common::{model_path, shipped_scenes, with_test_context};
use fragtrace::accel::AccelKind;
use fragtrace::compare::compare;
use fragtrace::gpu::options::Kernel;
use fragtrace::gpu::GlContext;
use fragtrace::options::{Backend, Precision, RenderOptions};
use fragtrace::render::{prepare, render_cpu, render_gl_with, Rendered};
use fragtrace::scene::{builtin_scene, load_scene_with_search_path, Scene};

/// Image size: tests/gpu_backend.rs's, so its bounds against the f64 CPU apply as stated.
const W: u32 = 64;
const H: u32 = 48;
/// Colour RMSE of GL against the f64 CPU (tests/gpu_backend.rs's `RMSE_GL_VS_F64`, measured
/// there at most 4.5e-6 for the fragment kernels).
const RMSE_GL_VS_F64: f64 = 2e-5;
/// Both f64 bounds on `ground.toml` (tests/gpu_backend.rs's `RMSE_VS_F64_HUGE_FLOOR`: the f32
/// t of its two-triangle 400 m floor is ill-conditioned, so a few f32 hit points fall in
/// other checker squares than f64's; 6.68e-3 for the CPU and llvmpipe, 7.22e-3 on the H200).
const RMSE_VS_F64_HUGE_FLOOR: f64 = 1e-2;
/// Share of pixels whose primary triangle agrees with the f64 CPU's (tests/gpu_backend.rs's
/// `PRIMID_AGREEMENT`: one pixel of 3,072).
const PRIMID_AGREEMENT: f64 = 0.9996;
/// Relative difference of compute's cells entered and triangle tests from the f32 CPU's.
/// Measured on llvmpipe: equal on every scene and structure but glass on the irregular
/// grid, where compute counts 19 more cells of 242,291 (7.8e-5) and 69 more tests of
/// 554,834 (1.2e-4) for the same rays; about 4x.
const WORK_REL: f64 = 5e-4;

/// Whether `ctx` runs compute programs (GL 4.3); without them the comparison cannot run,
/// and the test fails saying so unless `FRAGTRACE_ALLOW_SKIP=1` acknowledges the skip.
fn compute_or_acknowledged_skip(ctx: &GlContext, test: &str) -> bool {
    ctx.info.compute
        || common::acknowledged_skip(
            &format!(
                "{test} needs OpenGL 4.3 compute shaders; {} offers OpenGL {}",
                ctx.info.renderer, ctx.info.gl_version
            ),
            "run it on a GL 4.3 driver",
        )
}

/// Scene and structure pairs the compute kernel cannot finish on llvmpipe, which ends
/// every loop of a shader invocation after 65535 iterations of them all (gallivm's
/// `LP_MAX_TGSI_LOOP_ITERATIONS`; one budget per SIMD vector of invocations, spent while
/// any of its lanes loops). ground.toml's uniform grid (512x1x512) puts the bunny into a
/// few cells of up to 27,697 triangles: its primary rays take 43,505 steps each on average
/// (looped kernel, 64x48), and 3465 rays or trees are cut. glass.toml's uniform grid
/// (145x8x145) cuts 28 ray trees; before the kernel checked for it, that render exited 0
/// with 39,696 of looped's 39,873 rays and an RMSE of 2.2e-2 against looped (0.85% of the
/// pixels off by more than 0.01). There the kernel must refuse with its "did not finish"
/// error rather than render an image missing rays; on other drivers it must render.
const LLVMPIPE_LOOP_LIMITED: &[&str] = &["ground uniform", "glass uniform"];

/// Whether `ctx` is Mesa's llvmpipe (whose loop limit [`LLVMPIPE_LOOP_LIMITED`] names).
fn is_llvmpipe(ctx: &GlContext) -> bool {
    ctx.info.renderer.contains("llvmpipe")
}

/// Both structures: every comparison runs on each (the CPU on the same one as GL).
const ACCELS: [AccelKind; 2] = [AccelKind::Uniform, AccelKind::Irregular];

fn opts(scene: &Scene, backend: Backend, precision: Precision, kernel: Kernel) -> RenderOptions {
    let mut o = RenderOptions::for_scene(scene);
    o.width = W;
    o.height = H;
    o.backend = backend;
    o.precision = precision;
    o.gpu.kernel = kernel;
    o
}

/// Share of pixels whose primary-hit triangle is the same in `a` and `b`.
fn agreement(a: &Rendered, b: &Rendered) -> f64 {
    let same = (a.aov.pixels.iter().zip(&b.aov.pixels))
        .filter(|(p, q)| p.primid == q.primid)
        .count();
    same as f64 / a.aov.pixels.len() as f64
}

/// |a - b| / b (0 when both are 0).
fn rel(a: u64, b: u64) -> f64 {
    (a as f64 - b as f64).abs() / (b.max(1) as f64)
}

/// Where `a` and `b` differ in any bit of a linear value or of a primary-ray AOV: the
/// number of such values and the first one, or None where they are the same bytes.
/// Before the kernels applied the scene's factor (ambient light, radiance) last
/// (`contribution` in shade.glsl), this found 2 to 65 values of 9,216 one f32 ulp apart on
/// llvmpipe in 9 of the 12 shipped scenes (builtin 45, RMSE 3.0e-9; dragon, sponza and
/// stadium the same bytes).
fn bit_difference(a: &Rendered, b: &Rendered) -> Option<String> {
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let aov = |r: &Rendered| {
        (r.aov.pixels.iter())
            .flat_map(|p| {
                [
                    p.depth,
                    p.primid,
                    p.normal[0],
                    p.normal[1],
                    p.normal[2],
                    p.steps,
                ]
            })
            .collect::<Vec<_>>()
    };
    if a.image.data.len() != b.image.data.len() || a.aov.pixels.len() != b.aov.pixels.len() {
        return Some(format!(
            "sizes: {} and {} values, {} and {} AOV pixels",
            a.image.data.len(),
            b.image.data.len(),
            a.aov.pixels.len(),
            b.aov.pixels.len()
        ));
    }
    for (what, x, y, per) in [
        ("linear value", bits(&a.image.data), bits(&b.image.data), 3),
        ("AOV value", bits(&aov(a)), bits(&aov(b)), 6),
    ] {
        let differ: Vec<usize> = (0..x.len()).filter(|&i| x[i] != y[i]).collect();
        if let Some(&i) = differ.first() {
            let px = i / per;
            return Some(format!(
                "{} {what}s of {} differ; the first at pixel ({}, {}) component {}: {:e} vs {:e}",
                differ.len(),
                x.len(),
                px % a.image.width as usize,
                px / a.image.width as usize,
                i % per,
                f32::from_bits(x[i]),
                f32::from_bits(y[i])
            ));
        }
    }
    None
}

/// Every shipped scene on both structures: compute against looped (same primary triangles,
/// rays by kind and linear values), against the f64 CPU (gpu_backend.rs's GL bounds) and
/// its work counters against the f32 CPU's.
#[test]
fn compute_equals_looped_and_cpu_on_every_shipped_scene() {
    let scenes = shipped_scenes();
    let mut report = String::new();
    let mut failures = Vec::new();
    with_test_context(|ctx| {
        if !compute_or_acknowledged_skip(
            ctx,
            "compute_equals_looped_and_cpu_on_every_shipped_scene",
        ) {
            return;
        }
        report.push_str(&format!("device: {}\n", ctx.info.renderer));
        for (accel, (name, scene)) in ACCELS
            .iter()
            .flat_map(|a| scenes.iter().map(move |s| (*a, s)))
        {
            let label = format!("{name} {}", accel.name());
            let o = |backend, precision, kernel| RenderOptions {
                accel: accel.into(),
                ..opts(scene, backend, precision, kernel)
            };
            let gl = |k| render_gl_with(ctx, scene, &o(Backend::Gl, Precision::F32, k));
            if is_llvmpipe(ctx) && LLVMPIPE_LOOP_LIMITED.contains(&label.as_str()) {
                match gl(Kernel::Compute) {
                    Err(e) if e.to_string().contains("the compute kernel did not finish") => {
                        report.push_str(&format!(
                            "{label:>18}: refused as expected on llvmpipe (loop limit): {e}\n"
                        ));
                    }
                    r => failures.push(format!(
                        "{label}: expected llvmpipe's loop limit to stop the compute kernel \
                         with its \"did not finish\" error, got {:?}",
                        r.map(|r| r.stats.rays)
                    )),
                }
                // `auto` (the default) falls back to looped there and renders every ray.
                match (gl(Kernel::Auto), gl(Kernel::Looped)) {
                    (Ok(auto), Ok(looped)) => {
                        let k = auto.stats.gpu.as_ref().map(|g| g.kernel.clone());
                        if k.as_deref() != Some("looped") || auto.stats.rays != looped.stats.rays {
                            failures.push(format!(
                                "{label}: auto ran {k:?} with {:?}, looped {:?}",
                                auto.stats.rays, looped.stats.rays
                            ));
                        }
                        report.push_str(&format!(
                            "{label:>18}: auto fell back to looped ({} rays)\n",
                            auto.stats.rays.total
                        ));
                    }
                    (a, l) => failures.push(format!(
                        "{label}: auto {:?}, looped {:?}",
                        a.err().map(|e| e.to_string()),
                        l.err().map(|e| e.to_string())
                    )),
                }
                continue;
            }
            let comp = match gl(Kernel::Compute) {
                Ok(r) => r,
                Err(e) => {
                    failures.push(format!("{label} compute: {e}"));
                    continue;
                }
            };
            let looped = gl(Kernel::Looped).unwrap_or_else(|e| panic!("{label} looped: {e}"));
            let cpu = |p| render_cpu(scene, &o(Backend::Cpu, p, Kernel::Auto)).unwrap();
            let (c32, c64) = (cpu(Precision::F32), cpu(Precision::F64));
            let kernel = |r: &Rendered| r.stats.gpu.as_ref().map(|g| g.kernel.clone());
            assert_eq!(kernel(&comp).as_deref(), Some("compute"), "{label}");
            assert_eq!(kernel(&looped).as_deref(), Some("looped"), "{label}");

            let same = agreement(&comp, &looped);
            let bits = bit_difference(&comp, &looped);
            let agree64 = agreement(&comp, &c64);
            let vs64 = compare(&comp.image, &c64.image, 0.02, true).unwrap();
            let work = |r: &Rendered| (r.stats.cells_visited, r.stats.triangle_tests);
            let ((cc, ct), (fc, ft)) = match (work(&comp), work(&c32)) {
                ((Some(a), Some(b)), (Some(c), Some(d))) => ((a, b), (c, d)),
                (w, x) => panic!("{label}: work counters missing: compute {w:?}, cpu f32 {x:?}"),
            };
            let (rc, rt) = (rel(cc, fc), rel(ct, ft));
            report.push_str(&format!(
                "{label:>18}: compute-looped {}  primid compute-f64 {:.3}%  RMSE compute-f64 {:.2e}  rays {:?}  cells {cc} vs f32 {fc} ({rc:.1e})  tests {ct} vs f32 {ft} ({rt:.1e}){}\n",
                bits.as_deref().unwrap_or("identical"),
                agree64 * 100.0,
                vs64.rmse,
                comp.stats.rays,
                if comp.stats.rays == c32.stats.rays {
                    ""
                } else {
                    "  (f32 CPU rays differ)"
                },
            )
            );
            let f64_bound = if name == "ground" {
                RMSE_VS_F64_HUGE_FLOOR
            } else {
                RMSE_GL_VS_F64
            };
            let mut fail = |ok: bool, what: String| {
                if !ok {
                    failures.push(format!("{label}: {what}"));
                }
            };
            fail(
                same == 1.0,
                format!(
                    "primary triangles agree with looped on {:.4}%",
                    same * 100.0
                ),
            );
            fail(
                bits.is_none(),
                format!("not the looped kernel's bytes: {bits:?}"),
            );
            fail(comp.image.all_finite(), "NaN or Inf pixel".into());
            fail(
                comp.stats.rays == looped.stats.rays,
                format!("rays {:?}, looped {:?}", comp.stats.rays, looped.stats.rays),
            );
            fail(
                agree64 >= PRIMID_AGREEMENT,
                format!(
                    "primary triangles agree with f64 on {:.4}%",
                    agree64 * 100.0
                ),
            );
            fail(
                vs64.rmse <= f64_bound,
                format!("RMSE vs f64 {:.3e} > {f64_bound:.0e}", vs64.rmse),
            );
            fail(
                rc <= WORK_REL && rt <= WORK_REL,
                format!("cells {cc} vs f32 {fc}, tests {ct} vs f32 {ft}"),
            );
        }
    });
    println!("{report}");
    assert!(failures.is_empty(), "{}\n{report}", failures.join("\n"));
}

/// Many samples per pixel (glass.toml at 64 spp: about 830 rays and 25,000 traversal steps
/// a pixel): the compute kernel renders what the f32 CPU renders (the same rays by kind,
/// RMSE at most gpu_backend.rs's GL-vs-f32 2e-5), or, where the driver ends its loops early,
/// refuses with its "did not finish" error; never an image missing rays. On llvmpipe it
/// refuses (measured: 9,504 of 12,288 primary rays traced, 38 ray trees cut; before the
/// check it rendered 94,283 of the 159,719 rays, RMSE 0.14 against the CPU, exit 0).
#[test]
fn compute_finishes_or_refuses_at_many_samples() {
    let scene = load_scene_with_search_path(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/glass.toml"),
        &model_path(),
    )
    .unwrap();
    let mut o = opts(&scene, Backend::Cpu, Precision::F32, Kernel::Compute);
    (o.width, o.height, o.spp) = (16, 12, 64);
    let cpu = render_cpu(&scene, &o).unwrap();
    o.backend = Backend::Gl;
    with_test_context(|ctx| {
        if !compute_or_acknowledged_skip(ctx, "compute_finishes_or_refuses_at_many_samples") {
            return;
        }
        match render_gl_with(ctx, &scene, &o) {
            Ok(r) => {
                let c = compare(&r.image, &cpu.image, 0.02, true).unwrap();
                println!(
                    "glass 64 spp: rendered, rays {:?}, RMSE vs f32 CPU {:.2e}",
                    r.stats.rays, c.rmse
                );
                assert_eq!(r.stats.rays, cpu.stats.rays, "an image missing rays");
                assert!(c.rmse <= 2e-5, "{c}");
            }
            Err(e) => {
                println!("glass 64 spp on {}: {e}", ctx.info.renderer);
                assert!(
                    e.to_string().contains("the compute kernel did not finish"),
                    "{e}"
                );
                assert_eq!(e.exit_code(), 1);
            }
        }
    });
}

/// `--kernel auto` (the default) runs the compute kernel where the context offers GL 4.3:
/// from the first frame on a driver that compiles within the call (llvmpipe), else once the
/// driver has compiled it, the looped kernel rendering the frames before (a cold start,
/// issue 52; tests/cold_start.rs). Frames of one renderer until compute takes over, within
/// a minute (the H200 compiles it in 2-3 s).
#[test]
fn auto_runs_compute_on_a_gl43_context() {
    let scene = builtin_scene();
    with_test_context(|ctx| {
        if !compute_or_acknowledged_skip(ctx, "auto_runs_compute_on_a_gl43_context") {
            return;
        }
        let mut o = opts(&scene, Backend::Gl, Precision::F32, Kernel::Auto).on_backend(true);
        (o.width, o.height) = (16, 12);
        assert_eq!(o.gpu.kernel, Kernel::Auto);
        let prepared = prepare(&scene, &o).unwrap();
        let mut renderer = prepared.gl_renderer(ctx, &o).unwrap();
        let t0 = std::time::Instant::now();
        let mut looped = 0;
        loop {
            let g = renderer.render(&scene.camera).unwrap().stats.gpu.unwrap();
            if g.kernel == "compute" {
                assert!(!g.cold_start);
                break;
            }
            assert_eq!((g.kernel.as_str(), g.cold_start), ("looped", true));
            looped += 1;
            assert!(
                t0.elapsed().as_secs() < 60,
                "still looped after {looped} frames"
            );
        }
        println!(
            "auto: compute after {looped} looped frames on {}",
            ctx.info.renderer
        );
        if is_llvmpipe(ctx) {
            assert_eq!(looped, 0, "llvmpipe compiles within the call");
        }
    });
}

fn bin() -> Command {
    common::bin()
}

/// Mesa's variables that give a GL 2.1 / GLSL 1.20 context.
const GL21: [(&str, &str); 2] = [
    ("MESA_GL_VERSION_OVERRIDE", "2.1"),
    ("MESA_GLSL_VERSION_OVERRIDE", "120"),
];

/// In a GL 2.1 context (Mesa's override; the binary runs as a child process, since the
/// override must be set before the driver loads) `--kernel auto` picks the multipass kernel
/// (`--stats` names it) and renders what the f32 CPU renders (RMSE of the linear EXR values
/// at most 2e-5, tests/gpu_backend.rs's GL-vs-f32 bound; measured: see the printed value),
/// and `--kernel compute` is refused in one line with the GL-unavailable exit code 2.
#[test]
fn gl21_auto_picks_multipass_and_compute_is_refused() {
    if !common::mesa_overrides_available() {
        return;
    }
    let d = std::env::temp_dir().join(format!("fragtrace-compute-gl21-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let size = ["--width", "48", "--height", "36"];
    let mut images = Vec::new();
    for (backend, out) in [("gl", "gl.exr"), ("cpu", "cpu.exr")] {
        let mut cmd = bin();
        cmd.current_dir(&d)
            .args(["render", "--backend", backend])
            .args(size)
            .args(["--stats", "s.json", "-q", "-o", out]);
        // Each backend's own flags: the other's are refused.
        if backend == "gl" {
            cmd.args(["--kernel", "auto"]).envs(GL21);
        } else {
            cmd.args(["--precision", "f32"]);
        }
        let o = cmd.output().unwrap();
        assert!(
            o.status.success(),
            "{backend}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        if backend == "gl" {
            let s: serde_json::Value =
                serde_json::from_slice(&std::fs::read(d.join("s.json")).unwrap()).unwrap();
            let v = s["gpu"]["gl_version"].as_str().unwrap();
            assert!(v.starts_with("2.1"), "not a GL 2.1 context: {v}");
            assert_eq!(s["gpu"]["kernel"], "multipass", "{s}");
        }
        images.push(fragtrace::image_io::read_image(&d.join(out)).unwrap());
    }
    let c = compare(&images[0], &images[1], 0.02, true).unwrap();
    println!("GL 2.1 --kernel auto vs CPU f32: RMSE {:.2e}, {c}", c.rmse);
    assert!(images[0].all_finite());
    assert!(c.rmse <= 2e-5, "{c}");

    let o = bin()
        .current_dir(&d)
        .args(["render", "--backend", "gl", "--kernel", "compute", "-q"])
        .args(size)
        .envs(GL21)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    println!("GL 2.1 --kernel compute: exit {:?}: {err}", o.status.code());
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("fragtrace: error: "), "{err}");
    assert!(
        err.contains("--kernel compute needs OpenGL 4.3") && err.contains("OpenGL 2.1"),
        "{err}"
    );
    assert!(!d.join("render.png").exists(), "an image was written");
    std::fs::remove_dir_all(&d).unwrap();
}

/// `--scene-fetch` reaches the compute kernel from the command line: both ways of reading
/// the scene render the same bits and `--stats` names the one that ran; with a fragment
/// kernel the flag is refused in one line with the usage exit code 2.
#[test]
fn scene_fetch_flag_picks_the_read_path_and_keeps_the_image() {
    let has_compute = with_test_context(|ctx| {
        compute_or_acknowledged_skip(ctx, "scene_fetch_flag_picks_the_read_path")
    });
    if !has_compute {
        return;
    }
    let d = std::env::temp_dir().join(format!("fragtrace-scene-fetch-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let size = ["--width", "48", "--height", "36"];
    let mut images = Vec::new();
    for fetch in ["texel-fetch", "storage-buffer"] {
        let (out, stats) = (format!("{fetch}.exr"), format!("{fetch}.json"));
        let o = bin()
            .current_dir(&d)
            .args(["render", "--backend", "gl", "--kernel", "compute"])
            .args(["--scene-fetch", fetch, "--stats", &stats, "-q", "-o", &out])
            .args(size)
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{fetch}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let s: serde_json::Value =
            serde_json::from_slice(&std::fs::read(d.join(&stats)).unwrap()).unwrap();
        assert_eq!(s["gpu"]["scene_fetch"], fetch, "{s}");
        images.push(fragtrace::image_io::read_image(&d.join(&out)).unwrap());
    }
    assert!(images[0].all_finite());
    assert_eq!(
        images[0].data, images[1].data,
        "texel-fetch and storage-buffer differ"
    );

    let o = bin()
        .current_dir(&d)
        .args(["render", "--backend", "gl", "--kernel", "looped", "-q"])
        .args(["--scene-fetch", "texel-fetch"])
        .args(size)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("applies to the compute kernel; this render runs looped"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&d);
}

/// The compute kernel's two reads of the irregular grid (issue 53: the dense `u32` buffers,
/// taken where the float layout does not fit, and the float textures, taken where it does:
/// `FRAGTRACE_GRID_LAYOUT` forces each) render the same bytes, image and AOVs, on every
/// shipped scene, and `--stats` names the read that ran. With the float read equal to the
/// looped kernel's and the CPU's ([`compute_equals_looped_and_cpu_on_every_shipped_scene`]),
/// this holds the dense read to them too on scenes the float layout holds.
#[test]
fn dense_and_float_grid_reads_render_the_same_bytes_on_every_shipped_scene() {
    let has_compute = with_test_context(|ctx| {
        compute_or_acknowledged_skip(ctx, "dense_and_float_grid_reads_render_the_same_bytes")
    });
    if !has_compute {
        return;
    }
    let d = common::tmpdir("grid-reads");
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut names: Vec<_> = std::fs::read_dir(&scenes)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    names.sort();
    assert!(names.len() >= 10, "{names:?}");
    let mut differ = Vec::new();
    for scene in &names {
        let name = scene.file_stem().unwrap().to_string_lossy().into_owned();
        let mut outputs = Vec::new();
        for layout in ["dense", "float"] {
            let (out, stats) = (
                format!("{name}-{layout}.exr"),
                format!("{name}-{layout}.json"),
            );
            let o = bin()
                .current_dir(&d)
                .arg("render")
                .arg(scene)
                .args([
                    "--backend",
                    "gl",
                    "--kernel",
                    "compute",
                    "--accel",
                    "irregular",
                ])
                .args(["--width", "40", "--height", "30", "--aov", "primid,steps"])
                .args(["--stats", &stats, "-q", "-o", &out])
                .env("FRAGTRACE_GRID_LAYOUT", layout)
                .env(
                    "FRAGTRACE_MODEL_PATH",
                    std::env::join_paths(common::model_path()).unwrap(),
                )
                .output()
                .unwrap();
            assert!(
                o.status.success(),
                "{name} {layout}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            let s: serde_json::Value =
                serde_json::from_slice(&std::fs::read(d.join(&stats)).unwrap()).unwrap();
            assert_eq!(s["gpu"]["grid_layout"], layout, "{name}: {s}");
            let aov = format!("{name}-{layout}.aov.exr");
            outputs.push((
                std::fs::read(d.join(&out)).unwrap(),
                std::fs::read(d.join(&aov)).unwrap(),
            ));
        }
        if outputs[0] != outputs[1] {
            differ.push(name);
        }
    }
    assert!(
        differ.is_empty(),
        "dense and float reads differ on {differ:?}"
    );
    let _ = std::fs::remove_dir_all(&d);
}
