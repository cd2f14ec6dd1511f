//! Unit tests of the render choices (`choices.rs`): flags of the other backend or kernel
//! refused in one line naming them, `view`'s advice in its own flags, the choices
//! `dump-shaders` takes, `--accel auto` following the backend and keeping the refusals,
//! `-q` with `-v` refused.

use super::*;

fn options(door: Door, flags: &[&str]) -> Result<RenderOptions> {
    RenderArgs::try_parse_from_args(flags)?
        .choices
        .to_options(&crate::scene::builtin_scene(), door)
}

fn refusal(door: Door, flags: &[&str]) -> String {
    match options(door, flags) {
        Err(Error::Usage(m)) => m,
        other => panic!("{flags:?} at {door:?}: expected a usage error, got {other:?}"),
    }
}

/// GPU flags on a CPU render and CPU flags on a GPU render are refused (they used to
/// be ignored, with exit 0), each in one line naming the flag.
#[test]
fn flags_of_the_other_backend_are_refused() {
    for (flags, flag) in [
        (&["--backend", "cpu", "--gpu", "7"][..], "--gpu 7"),
        (
            &["--backend", "cpu", "--kernel", "multipass"][..],
            "--kernel multipass",
        ),
        (
            &["--backend", "cpu", "--mask", "stencil"][..],
            "--mask stencil",
        ),
        (
            &["--backend", "cpu", "--storage", "f32"][..],
            "--storage f32",
        ),
        (
            &["--backend", "cpu", "--query-every", "8"][..],
            "--query-every 8",
        ),
        (
            &["--backend", "gl", "--precision", "f32"][..],
            "--precision f32",
        ),
        (
            &["--backend", "gl", "--precision", "f64"][..],
            "--precision f64",
        ),
        (
            &["--backend", "gl", "--cpu-path", "scalar"][..],
            "--cpu-path scalar",
        ),
    ] {
        let m = refusal(Door::Render, flags);
        assert!(m.starts_with(flag), "{flags:?}: {m}");
        assert!(!m.contains('\n'), "{m}");
    }
    // `auto` may run either backend: both kinds of flags stand.
    assert!(options(Door::Render, &["--precision", "f32", "--kernel", "looped"]).is_ok());
    assert!(options(Door::Render, &["--backend", "cpu", "--precision", "f32"]).is_ok());
}

/// A mask or 16-bit ray textures with the compute kernel, and a scene fetch with a
/// fragment kernel, are refused as not applying (usage), not as a limit.
#[test]
fn flags_of_the_other_kernel_are_refused() {
    for (flags, flag) in [
        (
            &["--kernel", "compute", "--mask", "stencil"][..],
            "--mask stencil",
        ),
        (
            &["--kernel", "compute", "--storage", "f16"][..],
            "--storage f16",
        ),
        (
            &["--kernel", "looped", "--scene-fetch", "storage-buffer"][..],
            "--scene-fetch storage-buffer",
        ),
    ] {
        for door in [Door::Render, Door::View] {
            let m = refusal(door, flags);
            assert!(m.starts_with(flag) && m.contains("applies to"), "{m}");
        }
    }
    assert!(options(Door::Render, &["--kernel", "looped", "--mask", "stencil"]).is_ok());
    assert!(options(Door::Render, &["--kernel", "compute", "--storage", "f32"]).is_ok());
}

/// `view` renders on the GPU: its refusals advise only flags `view` has (never
/// `--backend cpu`), and its defaults are its own.
#[test]
fn view_advice_names_its_own_flags() {
    let m = refusal(Door::View, &["--accel", "bvh"]);
    assert!(m.contains("--accel irregular"), "{m}");
    assert!(!m.contains("--backend"), "{m}");
    let m = refusal(Door::View, &["--precision", "f32"]);
    assert!(!m.contains("--backend"), "{m}");
    assert!(refusal(Door::View, &["--gpu", "0"]).starts_with("--gpu 0"));
    assert!(refusal(Door::View, &["--backend", "cpu"]).starts_with("--backend cpu"));
    let render = refusal(Door::Render, &["--backend", "gl", "--accel", "bvh"]);
    assert!(render.contains("--backend cpu"), "{render}");
    let v = options(Door::View, &[]).unwrap();
    assert_eq!((v.spp, v.backend), (16, Backend::Gl));
    assert_eq!(options(Door::Render, &[]).unwrap().spp, 1);
}

/// `dump-shaders` takes the same flags: those that change its programs (structure,
/// techniques, `--no-specialize`) apply, the others are refused, naming the command.
#[test]
fn dump_shaders_takes_the_choices_that_change_programs() {
    let d = Door::DumpShaders;
    let o = options(
        d,
        &[
            "--accel",
            "uniform",
            "--intersect",
            "moller-trumbore",
            "--no-specialize",
        ],
    )
    .unwrap();
    assert_eq!(o.on_backend(true).accel_kind(), AccelKind::Uniform);
    assert_eq!(o.techniques.intersect, IntersectMethod::MollerTrumbore);
    assert!(o.gpu.no_specialize);
    for (flags, flag) in [
        (&["--spp", "4"][..], "--spp 4"),
        (&["--kernel", "looped"][..], "--kernel looped"),
        (&["--accel", "bvh"][..], "--accel bvh"),
        (&["--precision", "f32"][..], "--precision f32"),
    ] {
        let m = refusal(d, flags);
        assert!(m.starts_with(flag) && m.contains("dump-shaders"), "{m}");
        assert!(!m.contains("--backend"), "{m}");
    }
}

/// `--accel auto` (the default) stays `auto` until the backend is settled, when
/// `on_backend` takes the BVH for the CPU and the irregular grid for the GPU; a density
/// asks for the irregular grid on either; a named structure is never changed.
#[test]
fn accel_auto_follows_the_backend() {
    let choice = |flags: &[&str]| options(Door::Render, flags).unwrap().accel;
    use AccelKind::*;
    assert_eq!(choice(&["--backend", "cpu"]), AccelChoice::Auto);
    assert_eq!(choice(&[]), AccelChoice::Auto);
    for backend in ["cpu", "gl", "auto"] {
        let flags = ["--backend", backend, "--grid-density", "0.5"];
        assert_eq!(choice(&flags), AccelChoice::Irregular, "{backend}");
        let o = options(Door::Render, &flags).unwrap();
        assert_eq!(o.irregular.top_density, 0.5);
        for (name, k) in [("uniform", Uniform), ("irregular", Irregular)] {
            let o = options(Door::Render, &["--backend", backend, "--accel", name]).unwrap();
            assert_eq!(
                (
                    o.on_backend(false).accel_kind(),
                    o.on_backend(true).accel_kind()
                ),
                (k, k)
            );
        }
    }
    assert_eq!(
        choice(&["--backend", "cpu", "--accel", "bvh"]),
        AccelChoice::Bvh
    );

    let auto = options(Door::Render, &[]).unwrap();
    assert_eq!(auto.on_backend(false).accel_kind(), Bvh);
    assert_eq!(auto.on_backend(true).accel_kind(), Irregular);
    // Resolved once: a second call for the other backend changes nothing.
    assert_eq!(auto.on_backend(false).on_backend(true).accel_kind(), Bvh);
    // Unsettled, `auto` is the GPU's for `--backend auto` and `gl`, the CPU's for `cpu`.
    assert_eq!(auto.accel_kind(), Irregular);
    assert_eq!(
        options(Door::Render, &["--backend", "cpu"])
            .unwrap()
            .accel_kind(),
        Bvh
    );
    // The library's own defaults name the irregular grid.
    let lib = RenderOptions::for_scene(&crate::scene::builtin_scene());
    assert_eq!(lib.accel, AccelChoice::Irregular);
    assert_eq!(lib.on_backend(false).accel_kind(), Irregular);
}

/// `-q` and `-v` contradict each other: refused, instead of `-v` printing its tables
/// under `-q`.
#[test]
fn quiet_and_verbose_are_refused_together() {
    let e = RenderArgs::try_parse_from_args(&["-q", "-v"]).unwrap_err();
    assert!(
        matches!(e, Error::Usage(ref m) if m.contains("--verbose")),
        "{e}"
    );
    assert!(RenderArgs::try_parse_from_args(&["-v"]).is_ok());
}

/// What `auto` cannot mean: the BVH's density, and `--grid` without the uniform grid.
#[test]
fn accel_auto_keeps_the_refusals() {
    for flags in [
        &["--backend", "cpu", "--accel", "bvh", "--grid-density", "2"][..],
        &["--backend", "cpu", "--grid", "4x4x4"][..],
        &["--backend", "gl", "--grid", "4x4x4"][..],
    ] {
        assert!(
            matches!(options(Door::Render, flags), Err(Error::Usage(_))),
            "{flags:?}"
        );
    }
    assert!(options(
        Door::Render,
        &["--backend", "cpu", "--accel", "uniform", "--grid", "4x4x4"]
    )
    .is_ok());
}
