//! Scenes past the GPU's old 2^24 cliff (issue 53, part A), through the real binary: the
//! split index format (`SPLIT_INDEX`, forced on here with `FRAGTRACE_SPLIT_INDICES=1` on a
//! scene CI can afford) renders the CPU's image on the compute and looped kernels, and a
//! scene too large for the machine is refused in one line before anything is built.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fragtrace-large-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = common::bin();
    cmd.current_dir(dir)
        .args(args)
        .env_remove("FRAGTRACE_SPLIT_INDICES");
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().unwrap()
}

/// `n` icospheres of `subdivisions` on a floor quad, a light and a camera above them.
fn spheres(n: usize, subdivisions: u32) -> String {
    let side = (n as f64).sqrt().ceil() as usize;
    let half = side as f64 - 1.0;
    let mut s = format!(
        "max_depth = 2\nambient = [0.1, 0.1, 0.1]\n\
         [camera]\neye = [0.0, {:.1}, {:.1}]\nlook_at = [0.0, 0.0, 0.0]\nfov = 45\n\
         [[lights]]\nposition = [{side}.0, {}.0, {side}.0]\ncolor = [1.0, 1.0, 1.0]\n\
         [materials.ball]\nalbedo = [0.8, 0.3, 0.2]\nkd = 0.7\nks = [0.3, 0.3, 0.3]\nns = 40\n\
         [materials.floor]\nalbedo = [0.6, 0.6, 0.6]\nkd = 0.8\n\
         [[objects]]\nshape = \"quad\"\nsize = [{}.0, {}.0]\nmaterial = \"floor\"\n",
        side as f64 * 1.1 + 1.0,
        side as f64 * 1.9 + 2.0,
        2 * side,
        2 * side + 2,
        2 * side + 2
    );
    for i in 0..n {
        let (x, z) = ((i % side) as f64, (i / side) as f64);
        s += &format!(
            "[[objects]]\nshape = \"sphere\"\nsubdivisions = {subdivisions}\nradius = 0.8\n\
             translate = [{:.1}, 0.8, {:.1}]\nmaterial = \"ball\"\n",
            2.0 * x - half,
            2.0 * z - half
        );
    }
    s
}

fn render(dir: &Path, out: &str, extra: &[&str], env: &[(&str, &str)]) -> Vec<f32> {
    let mut args = vec![
        "render", "s.toml", "--width", "40", "--height", "32", "-q", "-o", out,
    ];
    args.extend_from_slice(extra);
    let o = run(dir, &args, env);
    assert!(
        o.status.success(),
        "{extra:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    fragtrace::image_io::read_image(&dir.join(out))
        .unwrap()
        .data
}

/// Four spheres at subdivisions 7 (1,310,722 triangles) with the split format forced on:
/// every kernel and grid gives its float-format image bit for bit, and the compute kernel
/// on both grids and the looped kernel on the irregular grid give the CPU's image bit for
/// bit (measured identical here, so any difference fails). The looped kernel on the uniform
/// grid differs from the CPU in 12 of 3,840 values in both formats alike (as on main: a
/// fragment-kernel difference of its own, not the format's), so it is held to its float
/// image only. The shaders that ran were the split ones.
#[test]
fn split_indices_render_the_cpu_image_on_compute_and_looped() {
    let d = tmpdir("split");
    std::fs::write(d.join("s.toml"), spheres(4, 7)).unwrap();
    let split = [("FRAGTRACE_SPLIT_INDICES", "1")];
    let cpu = render(&d, "cpu.png", &["--backend", "cpu"], &[]);
    let differ = |a: &[f32], b: &[f32]| a.iter().zip(b).filter(|(x, y)| x != y).count();
    for accel in ["irregular", "uniform"] {
        for kernel in ["compute", "looped"] {
            let flags = ["--backend", "gl", "--accel", accel, "--kernel", kernel];
            let gl = render(&d, &format!("{accel}-{kernel}.png"), &flags, &split);
            let float = render(&d, &format!("{accel}-{kernel}-float.png"), &flags, &[]);
            let (to_float, to_cpu) = (differ(&gl, &float), differ(&gl, &cpu));
            println!(
                "{accel} {kernel} (split): {to_float} values differ from the float format's, \
                 {to_cpu} from the CPU's"
            );
            assert_eq!(to_float, 0, "{accel} {kernel}: split against float");
            if (accel, kernel) != ("uniform", "looped") {
                assert_eq!(to_cpu, 0, "{accel} {kernel}: split against the CPU");
            }
        }
    }
    // The programs were the split ones: the dumped shaders define SPLIT_INDEX.
    std::fs::create_dir_all(d.join("dump")).unwrap();
    let o = run(&d, &["dump-shaders", "s.toml", "dump"], &split);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut split_files = 0;
    for e in std::fs::read_dir(d.join("dump")).unwrap() {
        let text = std::fs::read_to_string(e.unwrap().path()).unwrap_or_default();
        split_files += text.contains("#define SPLIT_INDEX 1") as usize;
    }
    assert!(split_files > 0, "no dumped shader defines SPLIT_INDEX");
    let _ = std::fs::remove_dir_all(&d);
}

/// The compute kernel's dense grid (issue 53: cells, voxel map and references as `u32` in
/// storage buffers) with its references uploaded after 2^24 unused words
/// (`FRAGTRACE_DENSE_PAST_2_24=1`), so that every reference it reads lies past 2^24, on
/// four spheres at subdivisions 6 (327,682 triangles, a scene CI can afford), the dense
/// read forced (`FRAGTRACE_GRID_LAYOUT=dense`: the float layout fits this scene, and the
/// kernel takes that where it fits): its image is the unpadded render's and the CPU's bit
/// for bit (measured identical here, so any difference fails), and the padding was
/// uploaded (64 MiB more). Left to choose, the kernel reads the float layout, again with
/// the CPU's image; with storage blocks too small for the dense buffers
/// (`FRAGTRACE_DENSE_BLOCK_BYTES`) the forced dense read is refused in one line.
#[test]
fn dense_grid_reads_references_past_2_pow_24() {
    let d = tmpdir("dense");
    std::fs::write(d.join("s.toml"), spheres(4, 6)).unwrap();
    let dense = ("FRAGTRACE_GRID_LAYOUT", "dense");
    let past = [("FRAGTRACE_DENSE_PAST_2_24", "1"), dense];
    let cpu = render(&d, "cpu.png", &["--backend", "cpu"], &[]);
    let flags = |stats: &'static str| {
        [
            "--backend",
            "gl",
            "--accel",
            "irregular",
            "--kernel",
            "compute",
            "--stats",
            stats,
        ]
    };
    let padded = render(&d, "padded.png", &flags("padded.json"), &past);
    let plain = render(&d, "plain.png", &flags("plain.json"), &[dense]);
    let differ = |a: &[f32], b: &[f32]| a.iter().zip(b).filter(|(x, y)| x != y).count();
    let (to_plain, to_cpu) = (differ(&padded, &plain), differ(&padded, &cpu));
    println!("dense past 2^24: {to_plain} values differ from the unpadded render, {to_cpu} from the CPU's");
    assert_eq!(to_plain, 0, "padded against unpadded");
    assert_eq!(to_cpu, 0, "padded against the CPU");
    let gpu = |f: &str, key: &str| {
        let text = std::fs::read_to_string(d.join(f)).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        v["gpu"][key].clone()
    };
    let uploaded = |f: &str| gpu(f, "upload_bytes").as_u64().unwrap();
    assert_eq!(gpu("padded.json", "grid_layout"), "dense");
    assert_eq!(
        uploaded("padded.json") - uploaded("plain.json"),
        4 << 24,
        "the padding was not uploaded"
    );
    assert_eq!(gpu("plain.json", "grid_layout"), "dense");
    // Left to choose: the float layout (`gpu.grid_layout`), with the same image.
    let float = render(&d, "float.png", &flags("float.json"), &[]);
    assert_eq!(differ(&float, &cpu), 0, "float layout against the CPU");
    assert_eq!(gpu("float.json", "grid_layout"), "float");
    // Storage blocks too small for the dense buffers (a stand-in limit of 4 KiB).
    let small = [("FRAGTRACE_DENSE_BLOCK_BYTES", "4096"), dense];
    let o = run(
        &d,
        &[
            &["render", "s.toml", "-o", "small.png"][..],
            &flags("small.json"),
        ]
        .concat(),
        &small,
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("GL_MAX_SHADER_STORAGE_BLOCK_SIZE"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    let _ = std::fs::remove_dir_all(&d);
}

/// A machine with 1 MiB available (a stand-in /proc/meminfo): a 20,482-triangle scene's
/// irregular grid (560 bytes per triangle) is refused in one line naming the need, what
/// there is and an option, exit code 2, before the build, and the existing image is kept.
#[test]
fn a_scene_too_large_for_the_machine_is_refused_in_one_line() {
    let d = tmpdir("memory");
    std::fs::write(d.join("s.toml"), spheres(1, 5)).unwrap();
    std::fs::write(
        d.join("meminfo"),
        "MemTotal: 2048 kB\nMemAvailable: 1024 kB\n",
    )
    .unwrap();
    std::fs::write(d.join("out.png"), b"previous image").unwrap();
    let meminfo = d.join("meminfo");
    let env = [("FRAGTRACE_MEMINFO", meminfo.to_str().unwrap())];
    let args = [
        "render",
        "s.toml",
        "--backend",
        "cpu",
        "--accel",
        "irregular",
        "-q",
        "-o",
        "out.png",
    ];
    let o = run(&d, &args, &env);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "{err}");
    for needle in [
        "20482 triangles needs about",
        "GiB is available",
        "--accel bvh",
    ] {
        assert!(lines[0].contains(needle), "`{}` lacks `{needle}`", lines[0]);
    }
    assert_eq!(std::fs::read(d.join("out.png")).unwrap(), b"previous image");
    // With the machine's own figure the same render goes through.
    let o = run(&d, &args, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let _ = std::fs::remove_dir_all(&d);
}
