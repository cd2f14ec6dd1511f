//! The web page's shaders (docs/web.md): every fragment pass the WebGL 1 page can draw, in
//! GLSL ES 1.00 as [`Dialect::Essl100`] generates it from the same sources and contract as
//! the native GLSL 1.20, is valid for the Khronos reference compiler (glslangValidator),
//! with GLSL ES 1.00's Appendix A limits on (WebGL enforces them: only constant-bounded
//! `for` loops, constant or loop-index array indexing); every pass the WebGL 2 page can
//! draw (the `looped` kernel's too), in GLSL ES 3.00 ([`Dialect::Essl300`]), is valid
//! under glslangValidator's default limits. And the native GLSL 1.20 output is
//! unchanged by the dialect generator: a hash of every pass of every feature set against
//! the value the generator gave before dialects existed.

use std::path::Path;
use std::process::Command;

use fragtrace::accel::{AccelRef, Grid, GridConfig, IrregularConfig, IrregularGrid};
use fragtrace::gpu::layout::{SceneTextures, MAX_ROW};
use fragtrace::gpu::shader::{
    all_feature_sets, all_passes, assemble, assemble_in, Dialect, Features, Pass,
};
use fragtrace::scene::builtin_scene;
use fragtrace::technique::Techniques;

/// glslangValidator's default limits with GLSL ES 1.00's Appendix A restrictions on.
fn appendix_a_config(dir: &Path) -> std::path::PathBuf {
    let out = Command::new("glslangValidator")
        .arg("-c")
        .output()
        .unwrap_or_else(|e| {
            panic!("glslangValidator not found ({e}): apt-get install -y glslang-tools")
        });
    let mut conf = String::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let key = line.split_whitespace().next().unwrap_or("");
        let limited = [
            "nonInductiveForLoops",
            "whileLoops",
            "doWhileLoops",
            "generalUniformIndexing",
            "generalVariableIndexing",
            "generalSamplerIndexing",
            "generalVaryingIndexing",
            "generalAttributeMatrixVectorIndexing",
            "generalConstantMatrixVectorIndexing",
        ];
        if limited.contains(&key) {
            conf.push_str(&format!("{key} 0\n"));
        } else {
            conf.push_str(line);
            conf.push('\n');
        }
    }
    let path = dir.join("appendix-a.conf");
    std::fs::write(&path, conf).unwrap();
    path
}

fn validate(conf: Option<&Path>, path: &Path) -> (bool, String) {
    let out = Command::new("glslangValidator")
        .args(conf)
        .arg(path)
        .output()
        .expect("glslangValidator");
    (
        out.status.success(),
        format!(
            "{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ),
    )
}

/// The passes of the kernels the web page runs: `multipass` and `unrolled:K` on WebGL 1,
/// and `looped` too on WebGL 2.
fn web_passes(dialect: Dialect) -> Vec<Pass> {
    all_passes()
        .into_iter()
        .filter(|p| dialect.has_loops() || !matches!(p, Pass::Looped(_)))
        .collect()
}

fn check_dialect(dialect: Dialect, accel: AccelRef, tag: &str) -> usize {
    let dir = std::env::temp_dir().join(format!(
        "fragtrace-essl-{tag}-{dialect:?}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // GLSL ES 3.00 has no Appendix A loop and indexing limits: the defaults.
    let conf = match dialect {
        Dialect::Essl100 => Some(appendix_a_config(&dir)),
        _ => None,
    };
    let version = dialect.fragment_header().lines().next().unwrap();
    let scene = builtin_scene();
    let layout = SceneTextures::pack_with(&scene, accel, MAX_ROW, true).unwrap();
    let vert = dir.join("quad.vert");
    std::fs::write(&vert, dialect.quad_vertex_shader()).unwrap();
    let mut files = vec![vert];
    for f in all_feature_sets() {
        for pass in web_passes(dialect) {
            let a = assemble_in(dialect, pass, f, Techniques::default(), &layout).unwrap();
            assert!(a.source.starts_with(&format!("{version}\n")), "{pass:?}");
            assert_eq!(a.source.lines().count(), a.lines.len());
            if dialect == Dialect::Essl300 {
                // Nothing of GLSL 1.20's removed words is left for the compiler to accept
                // as an extension.
                for word in ["gl_FragData", "texture2D(", "varying "] {
                    assert!(!a.source.contains(word), "{pass:?}: {word}");
                }
            }
            let name = match pass {
                Pass::Unrolled(_, k) => format!("{}-{}{k}.frag", f.tag(), pass.name()),
                _ => format!("{}-{}.frag", f.tag(), pass.name()),
            };
            let path = dir.join(name);
            // glslangValidator does not know GL_EXT_draw_buffers (it allows gl_FragData[n]
            // up to its MaxDrawBuffers anyway); the browser test compiles the line as is.
            let ext = "#extension GL_EXT_draw_buffers : require\n";
            assert_eq!(
                a.source.contains(ext),
                dialect == Dialect::Essl100,
                "{pass:?}"
            );
            std::fs::write(&path, a.source.replacen(ext, "", 1)).unwrap();
            files.push(path);
        }
    }
    let mut bad = Vec::new();
    for f in &files {
        let (ok, log) = validate(conf.as_deref(), f);
        if !ok {
            bad.push(format!("{}:\n{log}", f.display()));
        }
    }
    assert!(
        bad.is_empty(),
        "{} of {} invalid as {}:\n{}",
        bad.len(),
        files.len(),
        dialect.name(),
        bad[..bad.len().min(3)].join("\n")
    );
    std::fs::remove_dir_all(&dir).unwrap();
    files.len()
}

#[test]
fn every_web_pass_is_valid_glsl_es_100_uniform_grid() {
    let scene = builtin_scene();
    let grid = Grid::build(&scene, &GridConfig::default()).unwrap();
    let n = check_dialect(Dialect::Essl100, (&grid).into(), "uniform");
    println!("{n} GLSL ES 1.00 shaders validated");
}

#[test]
fn every_web_pass_is_valid_glsl_es_100_irregular_grid() {
    let scene = builtin_scene();
    let grid = IrregularGrid::build(&scene, &IrregularConfig::default()).unwrap();
    let n = check_dialect(Dialect::Essl100, (&grid).into(), "irregular");
    println!("{n} GLSL ES 1.00 shaders validated");
}

#[test]
fn every_web_pass_is_valid_glsl_es_300_uniform_grid() {
    let scene = builtin_scene();
    let grid = Grid::build(&scene, &GridConfig::default()).unwrap();
    let n = check_dialect(Dialect::Essl300, (&grid).into(), "uniform");
    println!("{n} GLSL ES 3.00 shaders validated");
}

#[test]
fn every_web_pass_is_valid_glsl_es_300_irregular_grid() {
    let scene = builtin_scene();
    let grid = IrregularGrid::build(&scene, &IrregularConfig::default()).unwrap();
    let n = check_dialect(Dialect::Essl300, (&grid).into(), "irregular");
    println!("{n} GLSL ES 3.00 shaders validated");
}

/// The native programs are byte-identical to what the generator gave before the dialects:
/// one hash over every pass of every feature set and both grids, `assemble` and
/// `assemble_in(Glsl120)` alike. The value was taken from the generator at commit e763231
/// (before `Dialect`), 0x6d98f3e4f7cc9983, and updated when `srgb8.frag` became a pass (the
/// other passes still hash to that value without it), and again when `irr_lateral`
/// computed each crossing once and the voxel map was read in hops (stop 36: the same
/// images, other source), and when the texture code joined the shared files under
/// `#ifdef HAS_TEXTURES` (issue 47: the built-in scene is untextured, so its programs
/// preprocess to the code they were; the text around it changed), when `srgb8.frag`
/// tested finiteness per channel (issue 52: llvmpipe folded the vector test and called NaN
/// finite), and when the split index format joined the layout (issue 53: a scene that fits
/// in floats gets `fetch_<name>_at` and the cursor macros as wrappers of the same
/// arithmetic, and renders bit for bit as before), when every term a pixel gains became
/// `(w * term) * factor` (issue 52: `contribution` in shade.glsl, so that Mesa compiles the
/// compute and looped kernels to the same bytes), and when the compute kernel's instanced
/// walk joined `traverse.glsl` and `shade.glsl` under `#ifdef INSTANCED` (issue 53: every
/// fragment program, its comments, blank lines and `INSTANCED` blocks left out, is the
/// text it was); any change to `glsl120/`, the
/// contract or the layout changes it, and then this value is updated in the same commit,
/// deliberately.
#[test]
fn glsl_120_output_is_unchanged() {
    let scene = builtin_scene();
    let uniform = Grid::build(&scene, &GridConfig::default()).unwrap();
    let irregular = IrregularGrid::build(&scene, &IrregularConfig::default()).unwrap();
    let mut h = Fnv1a::default();
    let mut bytes = 0;
    for accel in [AccelRef::from(&uniform), AccelRef::from(&irregular)] {
        let layout = SceneTextures::pack_with(&scene, accel, MAX_ROW, true).unwrap();
        for f in all_feature_sets().into_iter().chain([Features::all()]) {
            for pass in all_passes() {
                let a = assemble(pass, f, Techniques::default(), &layout).unwrap();
                let b =
                    assemble_in(Dialect::Glsl120, pass, f, Techniques::default(), &layout).unwrap();
                assert_eq!(a.source, b.source);
                h.add(a.source.as_bytes());
                bytes += a.source.len();
            }
        }
    }
    let quad = fragtrace::gpu::gl::QUAD_VERTEX_SHADER;
    assert_eq!(Dialect::Glsl120.quad_vertex_shader(), quad);
    h.add(quad.as_bytes());
    let hash = h.0;
    println!("GLSL 1.20: {bytes} bytes, hash {hash:#018x}");
    assert_eq!(
        hash, GLSL_120_HASH,
        "GLSL 1.20 output changed ({bytes} bytes)"
    );
}

/// 64-bit FNV-1a: a hash whose value is fixed by its definition (std's `DefaultHasher`
/// may change between Rust releases).
struct Fnv1a(u64);

impl Default for Fnv1a {
    fn default() -> Self {
        Fnv1a(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv1a {
    fn add(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    }
}

/// See [`glsl_120_output_is_unchanged`].
const GLSL_120_HASH: u64 = 0x5a19_3416_1485_cf4e;
