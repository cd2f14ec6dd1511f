//! GL objects own their lifetime: many renders in one context, some failing half-way,
//! leave exactly the GL objects that existed before them.
//!
//! The count does not trust the crate's own bookkeeping: it asks the driver
//! (`glIsTexture`, `glIsProgram`, `glIsShader`, `glIsFramebuffer`, `glIsRenderbuffer`,
//! `glIsBuffer`, `glIsQuery`, `glIsVertexArray`) about every name up to well past the
//! largest name the driver handed out during the run.

use std::path::{Path, PathBuf};

use super::options::GpuOptions;
use super::render::{render, render_gl, render_stepped, trace_rays, Flow, ImageRequest, Snapshot};
use super::scene::GpuScene;
use super::scene::BREAK_PASS;
use crate::accel::{Grid, GridConfig};
use crate::gpu::context::{with_test_context, GlContext};
use crate::gpu::gl::texture::TEST_MAX_TEXTURE_SIZE;
use crate::gpu::gl::{check_gl_error, probe, OcclusionQuery, Program, RenderTarget, Texture};
use crate::gpu::options::{Kernel, Mask, Storage};
use crate::gpu::shader::{Pass, Query};
use crate::scene::{builtin_scene, load_scene_with_search_path, Scene};
use crate::Error;

/// Live names by kind, as the driver reports them, for names `1..=upto`.
fn live_objects(ctx: &GlContext, upto: u32) -> Vec<(&'static str, u32)> {
    probe::live_objects(ctx.gl(), ctx.raw(), upto)
}

/// The largest name a fresh object of each kind gets now (a driver that never reuses names
/// hands out the largest so far; one that reuses the lowest free name, a name below it).
fn probe_names(ctx: &GlContext) -> u32 {
    let t = Texture::new_f32(ctx, 1, 1, None).unwrap();
    let rt = RenderTarget::new(ctx, 1, 1, 1).unwrap();
    let q = OcclusionQuery::new(ctx).unwrap();
    let p: Program = crate::gpu::gl::compile_program(
        ctx,
        "probe",
        crate::gpu::gl::QUAD_VERTEX_SHADER,
        "#version 120\nvoid main() { gl_FragData[0] = vec4(0.0); }\n",
        &crate::gpu::gl::single_file_line_map("probe.frag"),
    )
    .unwrap();
    // Begin/end once so that the query name becomes an object glIsQuery reports.
    q.begin(ctx);
    q.end(ctx);
    let _ = q.result(ctx);
    let names = [
        t.name().0.get(),
        rt.framebuffer().0.get(),
        rt.texture(0).name().0.get(),
        p.name().0.get(),
    ];
    names.into_iter().max().unwrap_or(1)
}

fn scene(name: &str) -> Scene {
    if name == "builtin" {
        return builtin_scene();
    }
    let models: Vec<PathBuf> = match std::env::var_os("FRAGTRACE_MODEL_PATH") {
        Some(p) => std::env::split_paths(&p).collect(),
        None => vec![PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../shared/models"
        ))],
    };
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{name}.toml"));
    load_scene_with_search_path(&path, &models).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn request(scene: &Scene, w: u32, h: u32, gpu: GpuOptions) -> ImageRequest {
    ImageRequest {
        camera: scene.camera,
        width: w,
        height: h,
        spp: 1,
        max_depth: 3,
        techniques: gpu.techniques,
        progress: false,
        gpu,
        readback: crate::output::Readback::default(),
        region: None,
    }
}

/// How a configuration is expected to end.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Ends {
    Ok,
    /// Fails with `Error::Limit` once some textures and programs exist.
    LimitHalfWay,
    /// Fails with `Error::Shader` after other programs were built.
    ShaderHalfWay,
}

#[test]
fn renders_in_one_context_free_every_gl_object() {
    with_test_context(|ctx| {
        let scenes: Vec<(&str, Scene)> = ["builtin", "cornell", "glass", "teapot"]
            .into_iter()
            .map(|n| (n, scene(n)))
            .collect();
        // The fragment kernels' configurations pin their kernel (the default, `auto`, runs
        // the compute kernel on a GL 4.3 driver); the compute kernel has its own below.
        let base = GpuOptions {
            kernel: Kernel::Looped,
            ..GpuOptions::default()
        };
        let mut configs: Vec<(GpuOptions, Ends)> = vec![
            (
                GpuOptions {
                    kernel: Kernel::Multipass,
                    ..base
                },
                Ends::Ok,
            ),
            (
                GpuOptions {
                    kernel: Kernel::Unrolled(4),
                    ..base
                },
                Ends::Ok,
            ),
            (
                GpuOptions {
                    kernel: Kernel::Looped,
                    ..base
                },
                Ends::Ok,
            ),
            (
                GpuOptions {
                    mask: Mask::EarlyZ,
                    ..base
                },
                Ends::Ok,
            ),
            (
                GpuOptions {
                    mask: Mask::Stencil,
                    kernel: Kernel::Multipass,
                    ..base
                },
                Ends::Ok,
            ),
            (
                GpuOptions {
                    storage: Storage::F16,
                    ..base
                },
                Ends::Ok,
            ),
            (
                GpuOptions {
                    no_specialize: true,
                    timers: false,
                    ..base
                },
                Ends::Ok,
            ),
            (
                GpuOptions {
                    mask: Mask::Stencil,
                    ..base
                },
                Ends::LimitHalfWay,
            ),
            (
                GpuOptions {
                    kernel: Kernel::Multipass,
                    ..base
                },
                Ends::ShaderHalfWay,
            ),
        ];
        if ctx.info.compute {
            for no_specialize in [false, true] {
                let gpu = GpuOptions {
                    kernel: Kernel::Compute,
                    no_specialize,
                    ..base
                };
                configs.push((gpu, Ends::Ok));
            }
        }
        let before_upto = probe_names(ctx) + 4096;
        let before = live_objects(ctx, before_upto);
        let mut largest = 0;
        for (name, scene) in &scenes {
            let grid = Grid::build(scene, &GridConfig::default()).unwrap();
            for &(gpu, ends) in &configs {
                let (w, h) = match ends {
                    // Passes the context's image-size check, but every stream target is
                    // wider than the lowered limit: fails after the scene textures and
                    // every program exist.
                    Ends::LimitHalfWay => (200, 8),
                    _ => (24, 16),
                };
                TEST_MAX_TEXTURE_SIZE.set((ends == Ends::LimitHalfWay).then_some(128));
                BREAK_PASS.set((ends == Ends::ShaderHalfWay).then_some(Pass::Record));
                let r = render_gl(ctx, scene, &grid, &request(scene, w, h, gpu));
                TEST_MAX_TEXTURE_SIZE.set(None);
                BREAK_PASS.set(None);
                match (ends, &r) {
                    (Ends::Ok, Ok(out)) => assert!(out.gpu.as_ref().unwrap().passes_total > 0),
                    (Ends::LimitHalfWay, Err(Error::Limit(_)))
                    | (Ends::ShaderHalfWay, Err(Error::Shader { .. })) => {}
                    (_, Err(e)) => panic!("{name} {gpu:?}: {e}"),
                    (_, Ok(_)) => panic!("{name} {gpu:?}: expected {ends:?}"),
                }
                // trace_rays builds a frame of its own.
                let rays = [crate::gpu::render::GpuRay {
                    o: scene.camera.eye,
                    d: scene.camera.look_at - scene.camera.eye,
                    t_max: 1e30,
                }];
                trace_rays(ctx, scene, &grid, &rays, Query::Any, gpu).unwrap();
                largest = largest.max(probe_names(ctx));
            }
        }
        let upto = before_upto.max(largest + 4096);
        let after = live_objects(ctx, upto);
        assert_eq!(
            after,
            before,
            "GL objects alive after {} renders differ from before (largest name probed {largest})",
            scenes.len() * configs.len()
        );
        check_gl_error(ctx.gl(), "after the renders").unwrap();
    });
}

/// Objects outliving their `GlContext` value keep the context alive, and dropping them
/// while another context is current deletes them in their own context.
#[test]
fn objects_are_freed_in_their_own_context() {
    with_test_context(|first| {
        let before = live_objects(first, probe_names(first) + 256);
        let second = GlContext::new().expect("second context");
        let tex = Texture::new_f32(&second, 4, 4, None).unwrap();
        let name = tex.name();
        drop(second); // the texture keeps the second context alive
        first.make_current().unwrap();
        drop(tex); // deleted in the second context, the first stays current
        check_gl_error(first.gl(), "the first context after the drop").unwrap();
        let after = live_objects(first, probe_names(first) + 256);
        assert_eq!(after, before, "the first context's objects changed");
        let _ = name;
    });
}

/// A delete put off while the driver is busy (`Owned::delete_when`: a compute compile the
/// driver is still running when its scene goes, `PendingCompute::abandon`) leaves the
/// object alive while the driver is not done with it, runs once it is (`GlShared::reap`,
/// which a new scene asks), and the rest runs when the context goes, in that context (a
/// flag deferred last shows when), the first context untouched.
#[test]
fn deferred_deletes_run_when_done_or_when_their_context_goes() {
    with_test_context(|first| {
        let before = live_objects(first, probe_names(first) + 256);
        let second = GlContext::new().expect("second context");
        let program = |label: &str| -> Program {
            crate::gpu::gl::compile_program(
                &second,
                label,
                crate::gpu::gl::QUAD_VERTEX_SHADER,
                "#version 120\nvoid main() { gl_FragData[0] = vec4(1.0); }\n",
                &crate::gpu::gl::single_file_line_map("deferred.frag"),
            )
            .unwrap()
        };
        let (busy, through) = (program("busy"), program("through"));
        let (busy_name, through_name) = (busy.name().0.get(), through.name().0.get());
        busy.delete_when(|_, _| false);
        through.delete_when(|_, _| true);
        let live = |n: u32| live_objects(&second, n + 8).contains(&("program", n));
        assert!(
            live(busy_name) && live(through_name),
            "deleted before it was asked"
        );
        second.shared().reap();
        assert!(
            !live(through_name),
            "a program the driver is through with was kept"
        );
        assert!(
            live(busy_name),
            "a program the driver is busy with was deleted"
        );
        let ran = std::rc::Rc::new(std::cell::Cell::new(false));
        let flag = std::rc::Rc::clone(&ran);
        second.shared().defer(crate::gpu::context::Deferred {
            done: Box::new(|_| false),
            delete: Box::new(move |_| flag.set(true)),
        });
        drop(second);
        assert!(
            ran.get(),
            "the deferred deletes did not run when the context went"
        );
        first.make_current().unwrap();
        check_gl_error(first.gl(), "the first context after the second went").unwrap();
        let after = live_objects(first, probe_names(first) + 256);
        assert_eq!(after, before, "the first context's objects changed");
    });
}

/// The render hook (`render_gl_observed`): watching changes nothing in the image, the
/// observer sees passes advance and samples finish, and a cancel stops the render at the
/// pass it was asked in, with every GL object of the frame freed.
#[test]
fn an_observer_watches_without_changing_and_cancels_at_once() {
    with_test_context(|ctx| {
        let scene = builtin_scene();
        let grid = Grid::build(&scene, &GridConfig::default()).unwrap();
        let gpu = GpuOptions {
            kernel: Kernel::Multipass,
            ..GpuOptions::default()
        };
        let req = ImageRequest {
            spp: 2,
            ..request(&scene, 24, 16, gpu)
        };
        let plain = render_gl(ctx, &scene, &grid, &req).unwrap();

        let (mut calls, mut last, mut done) = (0u64, 0u64, Vec::new());
        let mut watch = |s: &Snapshot| {
            calls += 1;
            assert!(s.passes >= last, "passes went back");
            last = s.passes;
            assert_eq!((s.samples, s.state.len()), (2, 4));
            assert_eq!(s.radiance.width(), 24);
            if done.last() != Some(&s.samples_done) {
                done.push(s.samples_done);
            }
            Flow::Continue
        };
        let gs = GpuScene::new(ctx, &scene, &grid, false).unwrap();
        let watched = render(&gs, &req, Some(&mut watch)).unwrap();
        drop(gs);
        assert_eq!(watched.image.data, plain.image.data);
        assert_eq!(
            watched.gpu.as_ref().unwrap().passes_total,
            plain.gpu.as_ref().unwrap().passes_total
        );
        assert_eq!(done, vec![0, 1, 2]);
        // Called between passes: at least once per traversal iteration of the primary wave.
        assert!(
            calls > 100 && calls <= plain.gpu.as_ref().unwrap().passes_total + 2,
            "{calls}"
        );

        let before_upto = probe_names(ctx) + 4096;
        let before = live_objects(ctx, before_upto);
        let mut calls = 0u64;
        let mut cancel = |_: &Snapshot| {
            calls += 1;
            if calls == 50 {
                Flow::Cancel
            } else {
                Flow::Continue
            }
        };
        let gs = GpuScene::new(ctx, &scene, &grid, false).unwrap();
        let r = render(&gs, &req, Some(&mut cancel));
        drop(gs);
        assert!(matches!(r, Err(Error::Cancelled)), "{:?}", r.err());
        assert_eq!(calls, 50, "the render went on after the cancel");
        let upto = before_upto.max(probe_names(ctx) + 4096);
        assert_eq!(live_objects(ctx, upto), before, "a cancelled render leaked");
    });
}

/// A stepped render (the web page's pass-by-pass display) that pauses after every pass
/// and reads the radiance back at each pause draws the same passes and gives the same
/// image, bit for bit, as the plain render; the radiance read at the pauses grows from
/// black to the final image; the AOVs are shown from the first sample's primary wave on,
/// as the render returns them; a stepped render dropped half-way frees every GL object.
#[test]
fn a_stepped_render_pauses_after_every_pass_and_ends_as_the_plain_one() {
    with_test_context(|ctx| {
        let scene = builtin_scene();
        let grid = Grid::build(&scene, &GridConfig::default()).unwrap();
        let gpu = GpuOptions {
            kernel: Kernel::Multipass,
            ..GpuOptions::default()
        };
        let req = ImageRequest {
            spp: 2,
            readback: crate::output::Readback {
                aov: true,
                srgb8: false,
            },
            ..request(&scene, 24, 16, gpu)
        };
        let plain = render_gl(ctx, &scene, &grid, &req).unwrap();
        let passes = plain.gpu.as_ref().unwrap().passes_total;
        let first_aov = std::rc::Rc::new(std::cell::RefCell::new(None));
        let aov_sink = first_aov.clone();

        let gs = GpuScene::new(ctx, &scene, &grid, false).unwrap();
        let seen = std::rc::Rc::new(std::cell::RefCell::new(Vec::new()));
        let sink = seen.clone();
        let mut stepped = render_stepped(
            &gs,
            req,
            Box::new(move |s: &Snapshot| {
                let sum: f64 = s
                    .radiance
                    .read_f32(ctx)
                    .unwrap()
                    .iter()
                    .map(|&v| v as f64)
                    .sum();
                sink.borrow_mut().push((s.passes, s.pass, sum));
                let first = aov_sink.borrow().is_none();
                if let (Some(a), true) = (s.aov, first) {
                    *aov_sink.borrow_mut() = Some((s.passes, a.pixels.clone()));
                }
                Flow::Pause
            }),
        );
        let mut resumes = 0u64;
        let out = loop {
            resumes += 1;
            if let Some(out) = stepped.resume() {
                break out.unwrap();
            }
        };
        assert!(stepped.is_done());
        drop(stepped);
        assert_eq!(out.image.data, plain.image.data);
        assert_eq!(out.gpu.as_ref().unwrap().passes_total, passes);
        let seen = seen.borrow();
        // One pause per observed pass (ray-state and accumulation passes, and one per
        // sample), and a last resume that finishes.
        assert_eq!(resumes, seen.len() as u64 + 1);
        assert!(
            seen.len() as u64 > passes / 2,
            "{} pauses, {passes} passes",
            seen.len()
        );
        assert!(seen.iter().any(|s| s.1 == "traverse_step"));
        assert!(seen.iter().any(|s| s.1 == "accum_light"));
        // Black before the first accumulation, the whole image's sum at the end.
        let final_sum: f64 = plain.image.data.iter().map(|&v| v as f64).sum();
        assert_eq!(seen[0].2, 0.0);
        let last = seen.last().unwrap().2;
        assert!(
            (last - final_sum).abs() <= 1e-3 * final_sum,
            "{last} vs {final_sum}"
        );
        assert!(seen.iter().any(|s| s.2 > 0.0 && s.2 < 0.9 * final_sum));
        drop(seen);
        let (at, aov) = first_aov.borrow_mut().take().expect("the AOVs were shown");
        assert!(at < passes / 2, "AOVs first shown at pass {at} of {passes}");
        assert_eq!(aov, out.aov.pixels);
        assert_eq!(out.aov.pixels, plain.aov.pixels);

        // Abandoned after 40 pauses: nothing is left.
        let before_upto = probe_names(ctx) + 4096;
        let before = live_objects(ctx, before_upto);
        let mut stepped = render_stepped(&gs, req, Box::new(|_: &Snapshot| Flow::Pause));
        for _ in 0..40 {
            assert!(stepped.resume().is_none());
        }
        drop(stepped);
        let upto = before_upto.max(probe_names(ctx) + 4096);
        assert_eq!(
            live_objects(ctx, upto),
            before,
            "a dropped stepped render leaked"
        );
        drop(gs);
    });
}
