//! `render`'s start overlapped (src/overlap.rs): the scene loads and, for a scene without
//! instances, its GPU structure builds on a second thread while this one starts the GL
//! driver. What the command line renders must be what the library's sequential render
//! (`render_gl_with` after the load) gives for the same flags: the same image to the last
//! bit and the same structure (kind, resolution, cells, references), for the default
//! structure, for flags that change it (`--accel uniform --grid-density 3`), and for a
//! scene with instances (not built early: the context settles its levels). `--stats`
//! says how long the driver's start took (`gpu.context_ms`). A structure built early with
//! other settings than the flags' would show in the cells (the images of every structure
//! are the same by design, so the structure is compared apart).

mod common;

use common::{bin, tmpdir, with_test_context};
use fragtrace::choices::RenderArgs;
use fragtrace::image_io::read_image;
use fragtrace::render::render_gl_with;
use fragtrace::scene::load_scene_with_search_path;

/// The command line's render of `scene` with `extra` flags against the library's.
fn same_as_library(name: &str, scene: &str, extra: &[&str]) {
    let d = tmpdir(&format!("overlap-{name}"));
    let mut args: Vec<String> = vec![scene.into()];
    args.extend(
        ["--backend", "gl", "--width", "40", "--height", "32"]
            .iter()
            .chain(extra)
            .map(|s| s.to_string()),
    );
    let out = bin()
        .arg("render")
        .args(&args)
        .args(["-q", "-o"])
        .arg(d.join("a.exr"))
        .arg("--stats")
        .arg(d.join("s.json"))
        .env("FRAGTRACE_MODEL_PATH", common::model_path()[0].as_os_str())
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", common::text(&out));
    let img = read_image(&d.join("a.exr")).unwrap();
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("s.json")).unwrap()).unwrap();
    let scene =
        load_scene_with_search_path(std::path::Path::new(scene), &common::model_path()).unwrap();
    let opts = RenderArgs::try_parse_from_args(&args)
        .unwrap()
        .to_options(&scene)
        .unwrap();
    let want = with_test_context(|ctx| render_gl_with(ctx, &scene, &opts).unwrap());
    assert!(
        img.data == want.image.data,
        "{args:?}: the command line's image differs from the library's"
    );
    let lib = serde_json::to_value(&want.stats).unwrap();
    for key in ["kind", "resolution", "cells", "references", "bytes"] {
        assert_eq!(
            stats["accel"][key], lib["accel"][key],
            "{args:?}: accel.{key}: command line {} library {}",
            stats["accel"], lib["accel"]
        );
    }
    let context_ms = stats["gpu"]["context_ms"].as_f64().unwrap();
    assert!(context_ms > 0.0, "{args:?}: gpu.context_ms {context_ms}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn default_structure_is_the_librarys() {
    same_as_library("default", "scenes/bunny.toml", &[]);
}

#[test]
fn flags_that_change_the_structure_reach_the_early_build() {
    same_as_library(
        "uniform",
        "scenes/bunny.toml",
        &["--accel", "uniform", "--grid-density", "3"],
    );
}

#[test]
fn a_scene_with_instances_is_settled_by_the_context() {
    let d = tmpdir("overlap-instanced-scene");
    let path = d.join("instanced.toml");
    std::fs::write(&path, common::INSTANCED_SCENE).unwrap();
    same_as_library("instanced", path.to_str().unwrap(), &[]);
    let _ = std::fs::remove_dir_all(&d);
}
