//! Historical-hardware proof: every fragment-pass variant fragtrace can generate (every
//! pass, every fragment kernel, every combination of scene features) is valid GLSL 1.20
//! according to the Khronos reference compiler, glslangValidator (Debian package
//! glslang-tools), which checks the `#version 120` rules independently of any driver. The
//! compute kernel's programs (`render.comp`, `wave.comp`; `.comp` files, so the validator
//! takes them as compute shaders) are checked the same way as GLSL 4.30.

use std::path::Path;
use std::process::Command;

use fragtrace::accel::{Grid, GridConfig};
use fragtrace::gpu::shader::dump_shaders;
use fragtrace::scene::builtin_scene;
use fragtrace::technique::Techniques;

fn validate(path: &Path) -> (bool, String) {
    let out = Command::new("glslangValidator")
        .arg(path)
        .output()
        .unwrap_or_else(|e| {
            panic!("glslangValidator not found ({e}): apt-get install -y glslang-tools")
        });
    (
        out.status.success(),
        format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ),
    )
}

#[test]
fn every_generated_shader_is_valid_glsl_120() {
    let dir = std::env::temp_dir().join(format!("fragtrace-glsl-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let scene = builtin_scene();
    let grid = Grid::build(&scene, &GridConfig::default()).unwrap();
    let files = dump_shaders(&scene, &grid, &dir, true).unwrap();
    assert!(files.len() > 500, "only {} shaders", files.len());
    // One folder per non-default robustness technique, each with its specialised code.
    for (tag, marker) in [
        (
            "intersect-moller-trumbore",
            "#define INTERSECT_MOLLER_TRUMBORE",
        ),
        ("t-bound-off", "#define T_BOUND_OFF"),
        ("offset-epsilon", "#define OFFSET_EPSILON_FIXED"),
        ("terminator-exact", "#define TERMINATOR_EXACT"),
    ] {
        let sub = dir.join(format!("techniques-{tag}"));
        let in_sub: Vec<_> = files.iter().filter(|f| f.starts_with(&sub)).collect();
        assert!(
            in_sub.len() > 10,
            "{}: {} files",
            sub.display(),
            in_sub.len()
        );
        for f in in_sub {
            let text = std::fs::read_to_string(f).unwrap();
            assert!(text.contains(marker), "{} lacks {marker}", f.display());
        }
    }
    // Per feature set and technique folder: the full ray-tree program (storage-buffer and
    // texelFetch scene reads), the primary-only one, the sRGB8 conversion and both wave
    // programs; and in `instanced/`, an instanced scene's every fragment pass (the
    // two-level walk in GLSL 1.20) and its ray-tree program.
    let compute = files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "comp"))
        .count();
    assert_eq!(
        compute,
        6 * (32 + Techniques::one_off().len()) + 1,
        "compute programs written"
    );
    let instanced = dir.join("instanced");
    let walks = files
        .iter()
        .filter(|f| f.starts_with(&instanced))
        .filter(|f| std::fs::read_to_string(f).unwrap().contains("lv_unpack("))
        .count();
    assert!(walks >= 10, "{walks} instanced passes walk the two levels");
    let mut bad = Vec::new();
    for f in &files {
        let (ok, log) = validate(f);
        if !ok {
            bad.push(format!("{}:\n{log}", f.display()));
        }
        let text = std::fs::read_to_string(f).unwrap();
        let version = if f.extension().is_some_and(|e| e == "comp") {
            "#version 430\n"
        } else {
            "#version 120\n"
        };
        assert!(text.starts_with(version), "{}", f.display());
    }
    assert!(
        bad.is_empty(),
        "{} invalid:\n{}",
        bad.len(),
        bad[..bad.len().min(3)].join("\n")
    );
    println!(
        "{} shaders validated ({} as GLSL 1.20, {compute} compute programs as GLSL 4.30)",
        files.len(),
        files.len() - compute
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The irregular grid's variant of every pass (its traversal under `ACCEL_IRREGULAR` and the
/// generated voxel-map descent, unrolled over the levels of the bunny-sized grid of the
/// built-in scene) is valid GLSL 1.20 too.
#[test]
fn irregular_grid_shaders_are_valid_glsl_120() {
    use fragtrace::accel::{IrregularConfig, IrregularGrid};
    let dir = std::env::temp_dir().join(format!("fragtrace-glsl-irr-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let scene = builtin_scene();
    let grid = IrregularGrid::build(&scene, &IrregularConfig::default()).unwrap();
    assert!(
        !grid.levels.is_empty(),
        "the built-in scene's grid never splits"
    );
    let files = dump_shaders(&scene, &grid, &dir, false).unwrap();
    let mut checked = 0;
    let mut compute = 0;
    for f in files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "frag" || e == "comp"))
    {
        compute += f.extension().is_some_and(|e| e == "comp") as usize;
        let text = std::fs::read_to_string(f).unwrap();
        assert!(text.contains("#define ACCEL_IRREGULAR"), "{}", f.display());
        let (ok, log) = validate(f);
        assert!(ok, "{}:\n{log}", f.display());
        checked += 1;
    }
    assert!(checked >= 8, "only {checked} programs");
    // The render program, the 8-bit sRGB conversion and both wave programs of the scene.
    assert_eq!(compute, 4, "compute programs");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The validator really enforces 1.20: a GLSL 1.30 built-in is rejected.
#[test]
fn validator_rejects_post_120_features() {
    let dir = std::env::temp_dir().join(format!("fragtrace-glsl-neg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("bad.frag");
    std::fs::write(&f, "#version 120\nuniform sampler2D t;\nvoid main() { gl_FragColor = texelFetch(t, ivec2(0), 0); }\n").unwrap();
    let (ok, log) = validate(&f);
    assert!(!ok, "texelFetch accepted in GLSL 1.20: {log}");
    let g = dir.join("good.frag");
    std::fs::write(&g, "#version 120\nuniform sampler2D t;\nvoid main() { gl_FragColor = texture2D(t, vec2(0.5)); }\n").unwrap();
    assert!(validate(&g).0);
    std::fs::remove_dir_all(&dir).unwrap();
}
