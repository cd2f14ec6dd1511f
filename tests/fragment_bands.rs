//! A fragment-kernel frame whose ray textures pass the budget one frame may take (8 GiB:
//! the 100-duck scene at 4096² with depth 5 walked in two levels needs 8.5 GiB) is
//! rendered in full-width bands of rows that each fit. Played at a size CI renders by
//! lowering the budget (`FRAGTRACE_RAY_TEXTURE_BUDGET`) to a few rows: the banded looped
//! and multipass frames are the compute kernel's whole frame byte for byte (image and
//! AOVs; the kernels agree to the bit, tests/compute_kernel.rs), on a textured scene and on
//! an instanced one; a budget below one row is refused in one line, exit 2.

mod common;

use std::path::Path;
use std::process::Output;

/// `render` of `scene` at 64x48 with the AOVs, `flags` and `env`, into `out` in `d`.
fn render(d: &Path, scene: &Path, out: &str, flags: &[&str], env: &[(&str, &str)]) -> Output {
    common::bin()
        .current_dir(d)
        .arg("render")
        .arg(scene)
        .args(["--backend", "gl", "--width", "64", "--height", "48"])
        .args(["--aov", "primid,steps", "-q", "-o", out])
        .args(flags)
        .env(
            "FRAGTRACE_MODEL_PATH",
            std::env::join_paths(common::model_path()).unwrap(),
        )
        .env_remove("FRAGTRACE_RAY_TEXTURE_BUDGET")
        .envs(env.iter().copied())
        .output()
        .unwrap()
}

#[test]
fn frames_past_the_ray_texture_budget_render_in_bands_with_the_same_bytes() {
    let d = common::tmpdir("fragment-bands");
    std::fs::write(d.join("instanced.toml"), common::INSTANCED_SCENE).unwrap();
    let duck = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/duck-table.toml");
    let read = |f: &str| std::fs::read(d.join(f)).unwrap();
    // Bytes of one 64-pixel row of ray textures at 6 levels: 64 x 16 x (8 + 3 x 6 + 2), and
    // 4 record texels a level with instances; seven rows' worth makes seven bands of 48.
    for (name, scene, per_level) in [
        ("duck", duck, 3u64),
        ("instanced", d.join("instanced.toml"), 4),
    ] {
        let row = 64 * 16 * (8 + per_level * 6 + 2);
        let budget = (7 * row).to_string();
        let small = [("FRAGTRACE_RAY_TEXTURE_BUDGET", budget.as_str())];
        let whole = format!("{name}-compute.exr");
        let o = render(
            &d,
            &scene,
            &whole,
            &["--kernel", "compute", "--max-depth", "5"],
            &[],
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        for kernel in ["looped", "multipass"] {
            let out = format!("{name}-{kernel}.exr");
            let flags = ["--kernel", kernel, "--max-depth", "5"];
            let o = render(&d, &scene, &out, &flags, &small);
            assert!(
                o.status.success(),
                "{name} {kernel}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            assert!(
                read(&out) == read(&whole),
                "{name} {kernel}: the banded image differs"
            );
            let aov = |f: &str| read(&f.replace(".exr", ".aov.exr"));
            assert!(
                aov(&out) == aov(&whole),
                "{name} {kernel}: the banded AOVs differ"
            );
        }
        // Below one row: refused in one line before anything is allocated.
        let tiny = [("FRAGTRACE_RAY_TEXTURE_BUDGET", "1000")];
        let o = render(&d, &scene, "tiny.exr", &["--kernel", "looped"], &tiny);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(
            err.contains("of ray textures") && err.contains("--max-depth"),
            "{err}"
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}
