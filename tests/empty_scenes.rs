//! Scenes with nothing (or almost nothing) to hit, on every backend and kernel: no objects,
//! only lights, an empty OBJ. They render the background with every AOV saying "miss" on
//! the CPU (f64, f32) and on GL (multipass, unrolled:4, looped, with and without a mask;
//! compute).
//!
//! Their grid is the smallest there is, so they are also where the traversal bound is
//! tightest: the default `looped` kernel once failed them ("traversal did not terminate")
//! because one looped pass counted as more iterations than the bound of a tiny grid. A
//! two-triangle scene seen face on, which rays do traverse, checks the same on the kernels.

mod common;

use std::path::{Path, PathBuf};

use common::with_test_context;
use fragtrace::gpu::options::{Kernel, Mask};
use fragtrace::options::{Backend, Precision, RenderOptions};
use fragtrace::output::AovPixel;
use fragtrace::render::{render_cpu, render_gl_with, Rendered};
use fragtrace::scene::{load_scene_with_search_path, Scene};

const CAMERA: &str =
    "background = [0.2, 0.3, 0.4]\n\n[camera]\neye = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n";
const LIGHT: &str =
    "\n[[lights]]\nposition = [0.0, 3.0, 3.0]\ncolor = [1.0, 1.0, 1.0]\nintensity = 1.0\n";

fn dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("fragtrace-empty-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn load(dir: &Path, name: &str, toml: &str) -> Scene {
    let f = dir.join(format!("{name}.toml"));
    std::fs::write(&f, toml).unwrap();
    load_scene_with_search_path(&f, &[dir.to_path_buf()]).unwrap_or_else(|e| panic!("{e}"))
}

/// The scenes with no triangle at all.
fn empty_scenes() -> Vec<(&'static str, Scene)> {
    let d = dir();
    std::fs::write(d.join("empty.obj"), "# no vertices, no faces\n").unwrap();
    vec![
        ("no objects", load(&d, "none", CAMERA)),
        (
            "only lights",
            load(&d, "lights", &format!("{CAMERA}{LIGHT}")),
        ),
        (
            "empty OBJ",
            load(
                &d,
                "emptyobj",
                &format!("{CAMERA}{LIGHT}\n[[objects]]\nmesh = \"empty.obj\"\n"),
            ),
        ),
    ]
}

fn opts(scene: &Scene) -> RenderOptions {
    let mut o = RenderOptions::for_scene(scene);
    o.width = 24;
    o.height = 18;
    o
}

/// The GL configurations: every fragment kernel, unmasked and with both masks, and the
/// compute kernel (which has no passes to mask).
fn gl_configs() -> Vec<(Kernel, Mask)> {
    let mut v = Vec::new();
    for kernel in [Kernel::Multipass, Kernel::Unrolled(4), Kernel::Looped] {
        for mask in [Mask::None, Mask::EarlyZ, Mask::Stencil] {
            v.push((kernel, mask));
        }
    }
    v.push((Kernel::Compute, Mask::None));
    v
}

fn assert_background(what: &str, scene: &Scene, r: &Rendered) {
    assert!(scene.triangles.is_empty(), "{what}: not an empty scene");
    let bg = scene.background.to_array();
    for (i, px) in r.image.data.chunks(3).enumerate() {
        assert_eq!(px, bg, "{what}: pixel {i} is not the background");
    }
    for (i, a) in r.aov.pixels.iter().enumerate() {
        let miss = AovPixel::miss(a.steps);
        assert_eq!(
            (a.depth, a.primid, a.normal),
            (miss.depth, miss.primid, miss.normal),
            "{what}: AOV pixel {i} is not a miss"
        );
    }
}

#[test]
fn empty_scenes_render_the_background_on_every_backend() {
    let scenes = empty_scenes();
    for (name, scene) in &scenes {
        for precision in [Precision::F64, Precision::F32] {
            let mut o = opts(scene);
            o.precision = precision;
            let r = render_cpu(scene, &o).unwrap_or_else(|e| panic!("{name} cpu: {e}"));
            assert_background(&format!("{name}, cpu {precision:?}"), scene, &r);
        }
    }
    with_test_context(|ctx| {
        for (name, scene) in &scenes {
            for (kernel, mask) in gl_configs() {
                let what = format!("{name}, gl {kernel} mask {mask}");
                let mut o = opts(scene);
                o.backend = Backend::Gl;
                o.precision = Precision::F32;
                o.gpu.kernel = kernel;
                o.gpu.mask = mask;
                let r = render_gl_with(ctx, scene, &o).unwrap_or_else(|e| panic!("{what}: {e}"));
                assert_background(&what, scene, &r);
            }
        }
    });
}

/// Two triangles filling part of the view: the grid is tiny (its iteration bound below one
/// looped pass's 1024) but rays do traverse it. Every kernel and mask renders what the
/// faithful multipass kernel renders.
#[test]
fn a_tiny_grid_renders_the_same_on_every_kernel() {
    let d = dir();
    let toml = "[camera]\neye = [0, 4, 3]\nlook_at = [0, 0, 0]\nfov = 40\n".to_string()
        + LIGHT
        + "\n[[objects]]\nshape = \"quad\"\nsize = [1, 1]\n";
    let scene = load(&d, "quad", &toml);
    assert_eq!(scene.triangles.len(), 2);
    with_test_context(|ctx| {
        let mut o = opts(&scene);
        o.backend = Backend::Gl;
        o.precision = Precision::F32;
        o.gpu.kernel = Kernel::Multipass;
        let base = render_gl_with(ctx, &scene, &o).unwrap();
        let hits = base.aov.pixels.iter().filter(|p| p.primid >= 0.0).count();
        assert!(hits > 0, "the quad is not in view");
        for (kernel, mask) in gl_configs() {
            let what = format!("gl {kernel} mask {mask}");
            o.gpu.kernel = kernel;
            o.gpu.mask = mask;
            let r = render_gl_with(ctx, &scene, &o).unwrap_or_else(|e| panic!("{what}: {e}"));
            assert_eq!(r.image.data, base.image.data, "{what}: image differs");
            assert_eq!(r.aov, base.aov, "{what}: AOVs differ");
        }
    });
}
