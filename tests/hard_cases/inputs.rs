//! Cases of bad input and limits: non-finite numbers in scene and mesh files (20) and
//! scenes beyond the GPU's texture limits (22) are refused with clear errors, never
//! rendered wrongly.

use crate::common::with_test_context;
use crate::support::*;
use fragtrace::accel::{AccelKind, AccelRef, GridConfig, GridRes};
use fragtrace::gpu::layout::SceneTextures;
use fragtrace::options::Precision;
use fragtrace::render::{render_cpu, render_gl_with};
use fragtrace::Error;
use glam::{DVec3, Vec3};
use std::path::PathBuf;

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fragtrace-hard-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Scene files and OBJ meshes with nan, inf and f32-overflowing numbers: the binary exits
/// with code 2, prints one `fragtrace: error:` line naming the file and the problem, and
/// writes no image.
#[test]
fn case_20_non_finite_input_is_a_clear_error() {
    let dir = tmpdir("case20");
    let base = "[camera]\neye = [0, 1, 5]\nlook_at = [0, 0, 0]\nfov = 40\n\n[[lights]]\nposition = [2, 4, 3]\n\n";
    let obj_ok = "v -1 0 -1\nv 1 0 -1\nv 0 0 1\nf 1 2 3\n";
    std::fs::write(dir.join("ok.obj"), obj_ok).unwrap();
    std::fs::write(
        dir.join("nan.obj"),
        "v -1 0 -1\nv 1 nan -1\nv 0 0 1\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("inf.obj"),
        "v -1 0 -1\nv 1 0 -1\nv 0 0 inf\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("big.obj"),
        "v -1 0 -1\nv 1e39 0 -1\nv 0 0 1\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("vn.obj"),
        "v -1 0 -1\nv 1 0 -1\nv 0 0 1\nvn 0 nan 0\nf 1//1 2//1 3//1\n",
    )
    .unwrap();
    let mesh = |f: &str| format!("{base}[[objects]]\nmesh = \"{f}\"\n");
    let cases: Vec<(&str, String, &str)> = vec![
        ("ok", mesh("ok.obj"), ""),
        (
            "scene-nan-ambient",
            format!("ambient = [0.1, nan, 0.1]\n{}", mesh("ok.obj")),
            "finite",
        ),
        (
            "scene-inf-eye",
            mesh("ok.obj").replace("eye = [0, 1, 5]", "eye = [0, inf, 5]"),
            "finite",
        ),
        (
            "scene-overflow-light",
            mesh("ok.obj").replace("position = [2, 4, 3]", "position = [2, 1e39, 3]"),
            "finite",
        ),
        (
            "scene-nan-translate",
            format!("{}translate = [0, nan, 0]\n", mesh("ok.obj")),
            "finite",
        ),
        ("obj-nan", mesh("nan.obj"), "non-finite"),
        ("obj-inf", mesh("inf.obj"), "non-finite"),
        ("obj-overflow", mesh("big.obj"), "non-finite"),
        ("obj-nan-normal", mesh("vn.obj"), "non-finite"),
    ];
    let mut checks = Checks::new();
    for (name, toml, needle) in &cases {
        let scene = dir.join(format!("{name}.toml"));
        std::fs::write(&scene, toml).unwrap();
        let out_png = dir.join(format!("{name}.png"));
        let out = crate::common::bin()
            .args(["render"])
            .arg(&scene)
            .args(["--backend", "cpu", "--width", "8", "--height", "6", "-o"])
            .arg(&out_png)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr).trim().to_string();
        let code = out.status.code();
        println!("[case 20] {name}: exit {code:?}: {stderr}");
        if *name == "ok" {
            if code != Some(0) || !out_png.exists() {
                checks.fail(format!("{name}: the control scene failed: {stderr}"));
            }
            continue;
        }
        let file = if name.starts_with("obj") {
            toml.split('"').nth(1).unwrap().to_string()
        } else {
            format!("{name}.toml")
        };
        let one_line = stderr.lines().count() == 1 && stderr.starts_with("fragtrace: error:");
        if code != Some(2)
            || !one_line
            || !stderr.contains(needle)
            || !stderr.contains(&file)
            || out_png.exists()
        {
            checks.fail(format!("{name}: exit {code:?}, stderr `{stderr}` (want code 2, one line naming {file} and `{needle}`, no image)"));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    checks.done();
}

/// A scene or grid beyond the GPU's texture limits is refused with `Error::Limit` naming
/// GL_MAX_TEXTURE_SIZE (exit code 2), for the triangle and the cell textures; a grid with
/// more cells than the float cell ids of the ray state address (2^24) is refused by the GL
/// render itself in one line naming options that exist, while the CPU renders it; the same
/// scenes pack fine at the real limit.
#[test]
fn case_22_texture_limits_are_clear_errors() {
    let (mut s, m) = plain_scene();
    add_sphere(&mut s, 4, true, m, 1.0, DVec3::ZERO); // 5120 triangles: 15360 tri texels
    let grid = fixed_grid(&s, [64, 64, 64]); // 262144 cells
    let both = accels(&s);
    let mut checks = Checks::new();
    for (accel, max, what) in [
        (AccelRef::from(&grid), 64u32, "tri"),
        ((&grid).into(), 128, "cell"),
        (both.get(AccelKind::Irregular), 64, "tri"),
    ] {
        match SceneTextures::pack(&s, accel, max) {
            Err(e @ Error::Limit(_)) => {
                let msg = e.to_string();
                let kind = accel.kind().name();
                println!(
                    "[case 22] all backends, {kind}: pack with GL_MAX_TEXTURE_SIZE {max}: {msg}"
                );
                if !msg.contains("GL_MAX_TEXTURE_SIZE")
                    || !msg.contains(&format!("`{what}`"))
                    || e.exit_code() != 2
                {
                    checks.fail(format!("unclear message for max {max}: {msg}"));
                }
            }
            Err(e) => checks.fail(format!("max {max}: wrong error kind: {e}")),
            Ok(_) => checks.fail(format!(
                "max {max}: packed a {what} texture beyond the limit"
            )),
        }
    }
    // More cells than exact float indices: only the GL backend must refuse (the uniform
    // grid's fixed resolution: `opts` builds the uniform grid).
    let (mut tiny, m) = plain_scene();
    tiny.add_triangle(
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.1),
        m,
    );
    let mut o = opts(&tiny, Precision::F32);
    o.width = 8;
    o.height = 6;
    o.grid = GridConfig {
        res: GridRes::Fixed([257, 256, 256]),
        ..GridConfig::default()
    };
    let (gl_err, real_ok, ctx_max) = with_test_context(|ctx| {
        let gl_err = render_gl_with(ctx, &tiny, &o).err();
        let max = ctx.info.max_texture_size as u32;
        let real = SceneTextures::pack(&s, &grid, max).is_ok()
            && SceneTextures::pack(&s, &both.irregular, max).is_ok();
        (gl_err, real, ctx.info.max_texture_size)
    });
    match &gl_err {
        Some(e @ Error::Limit(msg)) => {
            println!("[case 22] GL: {} cells: {e}", 257 * 256 * 256);
            if !msg.contains("16842752 grid cells")
                || !msg.contains("16777216")
                || !msg.contains("--grid-density")
                || !msg.contains("--backend cpu")
            {
                checks.fail(format!("unclear message: {e}"));
            }
        }
        other => checks.fail(format!(
            "GL render of a 2^24+ cell grid: {:?}",
            other.as_ref().map(|e| e.to_string())
        )),
    }
    let cpu = render_cpu(&tiny, &o);
    println!(
        "[case 22] CPU f32: the same 2^24+ cell grid renders: {}; real GL_MAX_TEXTURE_SIZE {ctx_max} packs the 5120-triangle scene on both structures: {real_ok}",
        cpu.is_ok()
    );
    if cpu.is_err() || !real_ok {
        checks.fail("the CPU or the real limit refused a valid scene");
    }
    checks.done();
}
