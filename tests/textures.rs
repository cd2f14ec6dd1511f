//! Textures and ray cones (issue 47): a textured quad seen head-on against the texel each
//! pixel must show, the level of detail against the cone's closed form at several
//! distances and through a curved mirror, every GL kernel against the f32 CPU on the
//! textured scenes, untextured programs free of texture code, and the command line's
//! answers to a missing texture and to bad texture coordinates.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};

use common::{model_path, with_test_context, words};
use fragtrace::gpu::options::Kernel;
use fragtrace::options::{Backend, Precision, RenderOptions};
use fragtrace::render::{render_cpu, render_gl_with};
use fragtrace::scene::texture::{pixel_spread, TexLevel, Texture, TriTex, Wrap};
use fragtrace::scene::{Camera, Material, Scene, Triangle, NO_NORMAL};
use glam::{Vec2, Vec3};

/// The CPU's precisions and every GL kernel.
const GL_KERNELS: [Kernel; 4] = [
    Kernel::Multipass,
    Kernel::Unrolled(4),
    Kernel::Looped,
    Kernel::Compute,
];

/// A scene lit by ambient light 1 alone, so a surface of albedo 1 and ka 1 shows its
/// texel unchanged; the camera at (0, 0, `d`) looks down -z with a field of view of
/// `fov` degrees onto an `n` x `n` image.
fn ambient_scene(d: f32, fov: f32, n: u32) -> Scene {
    let mut s = Scene::empty(Camera {
        eye: Vec3::new(0.0, 0.0, d),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: fov,
    });
    s.width = n;
    s.height = n;
    s.ambient = Vec3::ONE;
    s.background = Vec3::ZERO;
    s.max_depth = 2;
    s
}

/// Adds the quad of corners (-h, -h, z)..(h, h, z) facing `facing` (+1: +z), uv 0..1,
/// with material `m` and, with curvature `k`, vertex normals bent as a bowl of that
/// curvature would have them.
fn add_quad(s: &mut Scene, h: f32, z: f32, facing: f32, m: u32, k: Option<f32>) {
    let base = s.positions.len() as u32;
    let ubase = s.uvs.len() as u32;
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    for (x, y) in corners {
        s.positions.push(Vec3::new(x * h, y * h, z));
        s.uvs.push(Vec2::new((x + 1.0) / 2.0, (y + 1.0) / 2.0));
        if let Some(k) = k {
            s.normals
                .push(Vec3::new(x * h * k, y * h * k, facing).normalize());
        }
    }
    let nbase = s.normals.len() as u32 - if k.is_some() { 4 } else { 0 };
    s.tri_uvs
        .resize(s.triangles.len(), [fragtrace::scene::NO_UV; 3]);
    // Winding towards `facing`.
    let tris: [[u32; 3]; 2] = if facing > 0.0 {
        [[0, 1, 2], [0, 2, 3]]
    } else {
        [[0, 2, 1], [0, 3, 2]]
    };
    for t in tris {
        s.triangles.push(Triangle {
            v: t.map(|i| i + base),
            n: match k {
                Some(_) => t.map(|i| i + nbase),
                None => [NO_NORMAL; 3],
            },
            material: m,
        });
        s.tri_uvs.push(t.map(|i| i + ubase));
    }
}

fn texture(levels: Vec<TexLevel>) -> Texture {
    Texture {
        source: "<test>".into(),
        wrap: [Wrap::Repeat; 2],
        levels,
    }
}

fn textured(s: &mut Scene, t: Texture) -> u32 {
    s.textures.push(t);
    s.add_material(Material {
        name: "textured".into(),
        albedo: Vec3::ONE,
        ka: 1.0,
        kd: 0.0,
        diffuse_map: Some(s.textures.len() as u32 - 1),
        ..Material::default()
    })
}

fn options(s: &Scene, backend: Backend, precision: Precision) -> RenderOptions {
    let mut o = RenderOptions::for_scene(s);
    o.backend = backend;
    o.precision = precision;
    o.accel = fragtrace::accel::AccelKind::Irregular.into();
    o
}

/// Every renderer's image of `s`: the CPU in f64 and f32, then each GL kernel.
fn every_image(s: &Scene) -> Vec<(String, fragtrace::image_io::Image)> {
    s.validate().unwrap();
    let mut out = Vec::new();
    for p in [Precision::F64, Precision::F32] {
        let img = render_cpu(s, &options(s, Backend::Cpu, p)).unwrap().image;
        out.push((format!("cpu {p:?}"), img));
    }
    with_test_context(|ctx| {
        for k in GL_KERNELS {
            if k == Kernel::Compute && !ctx.info.compute {
                continue;
            }
            let mut o = options(s, Backend::Gl, Precision::F32);
            o.gpu.kernel = k;
            let img = render_gl_with(ctx, s, &o).unwrap().image;
            out.push((format!("gl {k}"), img));
        }
    });
    out
}

/// A 32 x 32 texture on a quad that fills a 32 x 32 image head-on: every pixel's centre
/// lands on a texel's centre, so each pixel is that texel, (i/32, r/32, 1/2) for column i
/// and texel row r = 31 - j counted from the bottom (image row j from the top), on every
/// backend. The cone is one texel wide at the quad's centre (level of detail 0) and
/// grows off-axis as (t/d)/cos = (t/d)^2: level 0 (λ < 1/2) within 0.9 of the centre,
/// where the test looks.
#[test]
fn a_textured_quad_head_on_shows_each_texel_in_its_pixel() {
    let n = 32u32;
    // Camera 2 away from a quad of half-size 1: tan(fov/2) = 1/2.
    let fov = 2.0 * 0.5f32.atan().to_degrees();
    let mut s = ambient_scene(2.0, fov, n);
    let texels = (0..n)
        .flat_map(|r| (0..n).map(move |i| [i as f32 / n as f32, r as f32 / n as f32, 0.5]))
        .collect();
    let t = Texture::from_linear(
        "<ramp>".into(),
        [Wrap::Repeat; 2],
        TexLevel {
            width: n,
            height: n,
            texels,
        },
    );
    let m = textured(&mut s, t);
    add_quad(&mut s, 1.0, 0.0, 1.0, m, None);
    for (who, img) in every_image(&s) {
        let mut worst = 0f32;
        for j in 0..n {
            for i in 0..n {
                let (x, y) = (
                    2.0 * (i as f32 + 0.5) / n as f32 - 1.0,
                    1.0 - 2.0 * (j as f32 + 0.5) / n as f32,
                );
                if x * x + y * y > 0.81 {
                    continue;
                }
                let want = [i as f32 / n as f32, (n - 1 - j) as f32 / n as f32, 0.5];
                let got = img.pixel(i, j);
                for c in 0..3 {
                    worst = worst.max((got[c] - want[c]).abs());
                }
            }
        }
        // The uv of a pixel centre is the texel centre up to the rounding of the
        // barycentrics (about 1e-6 of a texel): the neighbour's share is that small.
        assert!(worst < 1e-4, "{who}: worst texel error {worst}");
    }
}

/// A texture whose level k is the constant k, `levels` levels from `side` x `side`.
fn level_index_texture(side: u32) -> Texture {
    let mut levels = Vec::new();
    let mut w = side;
    let mut k = 0.0f32;
    loop {
        levels.push(TexLevel {
            width: w,
            height: w,
            texels: vec![[k, k, k]; (w * w) as usize],
        });
        if w == 1 {
            break;
        }
        w /= 2;
        k += 1.0;
    }
    texture(levels)
}

/// The level the cone formula selects: round(Δ0 + log2 w) (head-on: n·d = 1), clamped.
fn predicted_level(bias: f64, width: f64, levels: usize) -> f64 {
    let lod = bias + width.log2();
    (lod + 0.5).floor().clamp(0.0, levels as f64 - 1.0)
}

/// The centre pixel of a quad seen head-on at distance d shows the level the cone
/// predicts: width = spread·d, one level up per doubling of the distance, on every
/// backend.
#[test]
fn the_level_of_detail_grows_with_distance_as_the_cone_predicts() {
    let n = 16u32;
    let fov = 30.0f32;
    let spread = pixel_spread(fov, n);
    let mut seen = Vec::new();
    for d in [3.0f32, 6.5, 13.0, 26.0, 52.0] {
        let mut s = ambient_scene(d, fov, n);
        let m = textured(&mut s, level_index_texture(256));
        add_quad(&mut s, 8.0, 0.0, 1.0, m, None);
        let bias = TriTex::of(&s, 0).lod_bias as f64;
        // The centre pixel's ray (pixel n/2 - 1/2 is off-centre by half a pixel: its t
        // differs from d by a factor cos, under 1e-4 here).
        let want = predicted_level(bias, spread * d as f64, 9);
        let lod = bias + (spread * d as f64).log2();
        assert!(
            (lod - lod.floor() - 0.5).abs() > 0.05,
            "d {d}: lod {lod} too near a level boundary to test"
        );
        for (who, img) in every_image(&s) {
            let got = img.pixel(n / 2, n / 2)[0];
            assert_eq!(got as f64, want, "{who} at distance {d}: lod {lod}");
        }
        seen.push(want);
    }
    assert!(seen.windows(2).all(|w| w[1] == w[0] + 1.0), "{seen:?}");
}

/// Through a mirror: the camera looks at a mirror quad 4 away whose vertex normals bend
/// as a bowl of curvature k would; the reflection comes straight back onto a textured
/// quad 4 behind the camera. The cone at the mirror is w1 = spread·4, leaves with
/// spread' = spread + 2·k·w1 (k as the triangle's record estimates it) and is
/// w1 + spread'·8 wide at the texture: the level shown is the cone's, flat mirror and curved alike, on every backend.
#[test]
fn a_curved_mirror_widens_the_cone_as_predicted() {
    let n = 16u32;
    let fov = 30.0f32;
    let spread = pixel_spread(fov, n);
    let mut levels_seen = Vec::new();
    for k in [0.0f32, 0.3, 1.0] {
        let mut s = ambient_scene(0.0, fov, n);
        s.camera.look_at = Vec3::new(0.0, 0.0, -1.0);
        let mirror = s.add_material(Material {
            name: "mirror".into(),
            ka: 0.0,
            kd: 0.0,
            kr: Vec3::ONE,
            ..Material::default()
        });
        add_quad(&mut s, 1.0, -4.0, 1.0, mirror, Some(k));
        let m = textured(&mut s, level_index_texture(1024));
        add_quad(&mut s, 20.0, 4.0, -1.0, m, None);
        let curv = TriTex::of(&s, 0).curvature as f64;
        let bias = TriTex::of(&s, 2).lod_bias as f64;
        let w1 = spread * 4.0;
        let spread2 = spread + 2.0 * curv * w1;
        let w2 = w1 + spread2 * 8.0;
        let want = predicted_level(bias, w2, 11);
        let lod = bias + w2.log2();
        assert!(
            (lod - lod.floor() - 0.5).abs() > 0.05,
            "k {k}: lod {lod} too near a level boundary to test"
        );
        for (who, img) in every_image(&s) {
            let got = img.pixel(n / 2, n / 2)[0];
            assert_eq!(got as f64, want, "{who} with curvature {k}: lod {lod}");
        }
        levels_seen.push(want);
    }
    assert!(
        levels_seen[2] >= levels_seen[0] + 2.0,
        "the curved mirror must blur: {levels_seen:?}"
    );
}

/// The textured shipped scene on every GL kernel against the f32 CPU: measured max
/// 3.3e-5 (640 x 480, llvmpipe); the bound 1e-3 on every pixel at 96 x 72 leaves room for
/// a level chosen the other way where the level of detail sits at a boundary, which moves
/// a pixel by the difference of two mip levels' means times its bilinear weight.
#[test]
fn every_gl_kernel_matches_the_f32_cpu_on_the_textured_scene() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/duck-table.toml");
    let mut s = fragtrace::scene::load_scene_with_search_path(&path, &model_path()).unwrap();
    assert!(s.has_textures() && s.texture_problems.is_empty());
    s.width = 96;
    s.height = 72;
    let images = every_image(&s);
    let (_, cpu) = images
        .iter()
        .find(|(w, _)| w == "cpu F32")
        .expect("the f32 CPU");
    for (who, img) in images.iter().filter(|(w, _)| w.starts_with("gl")) {
        let mut bad = 0;
        for (a, b) in cpu.data.iter().zip(&img.data) {
            if (a - b).abs() > 1e-3 {
                bad += 1;
            }
        }
        assert!(bad <= 3, "{who}: {bad} components differ by more than 1e-3");
    }
}

/// An untextured scene's programs hold no texture code and no texture declaration.
#[test]
fn untextured_programs_have_no_texture_code() {
    use fragtrace::gpu::layout::SceneTextures;
    use fragtrace::gpu::shader::{assemble, Features, Pass};
    use fragtrace::technique::Techniques;
    let s = fragtrace::scene::builtin_scene();
    let accel = fragtrace::accel::Accel::build(
        &s,
        fragtrace::accel::AccelKind::Irregular,
        &Default::default(),
        &Default::default(),
    )
    .unwrap();
    let layout = SceneTextures::pack(&s, accel.as_ref(), 4096).unwrap();
    assert!(layout.tex.is_none());
    for pass in Pass::ALL {
        let a = assemble(pass, Features::of(&s), Techniques::default(), &layout).unwrap();
        // Mentions inside `#ifdef HAS_TEXTURES` blocks are compiled out; no declaration,
        // definition or define may be there.
        for word in [
            "#define HAS_TEXTURES",
            "sampler2D u_tex",
            "sampler2D u_r3",
            "sampler2D u_p3",
            "vec3 u_root_cone",
            "vec3 tex_bilinear(",
            "vec4 fetch_tex(",
        ] {
            assert!(!a.source.contains(word), "{pass:?} has {word}");
        }
    }
}

fn tmpdir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fragtrace-tex-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(dir: &Path, args: &[&str]) -> Output {
    common::bin()
        .current_dir(dir)
        .args(args)
        .stdin(Stdio::null())
        .output()
        .unwrap()
}

const OBJ: &str = "mtllib m.mtl\nusemtl wood\nv -1 -1 0\nv 1 -1 0\nv 0 1 0\n\
                   vt 0 0\nvt 1 0\nvt 0.5 1\nf 1/1 2/2 3/3\n";

fn scene_with(dir: &Path, obj: &str) {
    std::fs::write(dir.join("m.obj"), obj).unwrap();
    std::fs::write(
        dir.join("m.mtl"),
        "newmtl wood\nKd 0.5 0.4 0.3\nmap_Kd wood.png\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("s.toml"),
        "[camera]\neye = [0, 0, 3]\nlook_at = [0, 0, 0]\nfov = 40\n[image]\nwidth = 16\nheight = 12\n\
         [[objects]]\nmesh = \"m.obj\"\n",
    )
    .unwrap();
}

/// A missing texture: one warning line naming the material, the file and where it was
/// looked for, and the image is written; `--textures strict` refuses with one line,
/// exit 2, and writes nothing.
#[test]
fn a_missing_texture_is_one_warning_or_with_strict_an_error() {
    let dir = tmpdir("missing");
    scene_with(&dir, OBJ);
    let out = run(
        &dir,
        &["render", "s.toml", "--backend", "cpu", "-o", "a.png"],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let warnings: Vec<&str> = err.lines().filter(|l| l.contains("warning")).collect();
    // Where it looked: the MTL's folder (the scene's, named as the scene was: `./`).
    let at = "cannot be read at ./wood.png";
    assert!(
        warnings.len() == 1
            && warnings[0].contains("`wood`")
            && warnings[0].contains("`wood.png`")
            && warnings[0].contains(at),
        "{err}"
    );
    assert!(dir.join("a.png").exists());
    let out = run(
        &dir,
        &words("render s.toml --backend cpu --textures strict -o b.png"),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("wood.png") && !dir.join("b.png").exists(),
        "{err}"
    );
}

/// A uv index out of range and a NaN texture coordinate: one line naming the file and the
/// line, exit 2.
#[test]
fn bad_texture_coordinates_are_one_line_and_exit_2() {
    for (tag, obj, what) in [
        (
            "index",
            OBJ.replace("f 1/1 2/2 3/3", "f 1/1 2/2 3/4"),
            "texture index 4",
        ),
        (
            "nan",
            OBJ.replace("vt 1 0", "vt nan 0"),
            "non-finite texture coordinate",
        ),
    ] {
        let dir = tmpdir(tag);
        scene_with(&dir, &obj);
        let out = run(
            &dir,
            &["render", "s.toml", "--backend", "cpu", "-o", "a.png"],
        );
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(
            err.contains("m.obj") && err.contains("line ") && err.contains(what),
            "{err}"
        );
    }
}
