//! `fragtrace render`: one image, the parts of a tiled or distributed render, an
//! animation's frames; and the summary line, `-v` report and `--stats` file every render
//! writes.

use std::path::Path;

use super::{check_writable, load};
use crate::choices::RenderArgs;
use crate::farm::plan::PartPlan;
use crate::image_io;
use crate::region::Region;
use crate::render;
use crate::scene::Scene;
use crate::{Error, Result};

/// The `render` command: load, render, write the image (and stats). With `--tile`,
/// `--region` or `--task-index`, the parts this process owns ([`run_parts`]).
pub fn run_render(args: &RenderArgs) -> Result<Option<render::Rendered>> {
    let env = |k: &str| std::env::var(k).ok();
    image_io::remove_partials_on_signal();
    if let Some(frames) = &args.frames {
        if !args.parts.wanted() {
            run_frames(args, frames)?;
            return Ok(None);
        }
        // A share of an animation (frames x tiles): the frames come from the scene's path.
        let scene = load(args.scene.as_deref(), args.choices.textures)?;
        let path = scene.animation.as_ref().ok_or_else(|| {
            Error::Usage(format!(
                "--frames needs a camera path: {} has no [animation] table (docs/scene-format.md)",
                scene.source
            ))
        })?;
        let frames: Vec<u32> = frames.frames(&path.frames())?;
        let parts = PartPlan::new(
            &args.parts,
            &args.output,
            args.stats.as_deref(),
            Some(&frames),
            env,
        )?
        .expect("parts wanted");
        return run_parts(args, &parts, scene);
    }
    if let Some(parts) = PartPlan::new(&args.parts, &args.output, args.stats.as_deref(), None, env)?
    {
        let scene = load(args.scene.as_deref(), args.choices.textures)?;
        return run_parts(args, &parts, scene);
    }
    if args.parts.resume && args.output.is_file() {
        let scene = load(args.scene.as_deref(), args.choices.textures)?;
        let opts = args.to_options(&scene)?;
        if let Some(e) = expected(args, &scene, &opts)?.first() {
            if crate::farm::resume::done(e, crate::farm::hash::scene_hash(&scene)).is_ok() {
                if !args.quiet {
                    eprintln!(
                        "{}: exists whole (--resume); nothing to render",
                        e.path.display()
                    );
                }
                return Ok(None);
            }
        }
    }
    // Fail on an unusable output path or AOV list before loading or rendering anything;
    // a folder is reported as one, not as a file with an unknown extension.
    if args.mkdir {
        make_folder(&args.output)?;
        if let Some(stats) = &args.stats {
            make_folder(stats)?;
        }
    }
    let hint = |e: Error| match e {
        Error::Usage(m) if m.ends_with("does not exist") => {
            Error::Usage(format!("{m} (--mkdir makes it)"))
        }
        e => e,
    };
    check_writable(&args.output, "image").map_err(hint)?;
    image_io::Format::from_path(&args.output)?;
    image_io::remove_stale_partials(&args.output);
    if let Some(stats) = &args.stats {
        check_writable(stats, "statistics").map_err(hint)?;
    }
    let aovs = args
        .aov
        .as_deref()
        .map(crate::aov::AovKind::parse_list)
        .transpose()?;
    let ms = |t: crate::clock::Instant| t.elapsed().as_secs_f64() * 1e3;
    let start_ms = crate::clock::since_start_ms_f64();
    // Read back only what the output needs: an 8-bit format (PNG, PPM, JPEG) as 8-bit sRGB
    // (converted on the GPU, or in the CPU's bands), the AOVs only with --aov.
    let readback = crate::output::Readback {
        aov: aovs.is_some(),
        srgb8: image_io::Format::from_path(&args.output)?.is_srgb8(),
    };
    // The scene loads while the GL driver starts, and the image is written while the
    // context is released (crate::overlap).
    let t = crate::clock::Instant::now();
    let write = |out: &render::Rendered| -> Result<(f64, f64)> {
        let render_call_ms = ms(t);
        let finite = match out.nonfinite {
            Some(n) => n == 0,
            None => out.image.all_finite(),
        };
        if !finite {
            return Err(Error::Internal(
                "the render produced a NaN or Inf pixel".into(),
            ));
        }
        let t = crate::clock::Instant::now();
        match &out.srgb8 {
            Some(rgb) => {
                image_io::write_srgb8(&args.output, out.image.width, out.image.height, rgb)?
            }
            None => image_io::write_image(&args.output, &out.image)?,
        }
        if let Some(kinds) = &aovs {
            crate::aov::write_aovs(&args.output, &out.aov, kinds)?;
        }
        Ok((render_call_ms, ms(t)))
    };
    let (mut out, load_ms, (render_call_ms, write_ms)) = crate::overlap::render_loading(
        args.context_options().as_ref(),
        || {
            let t = crate::clock::Instant::now();
            let scene = load(args.scene.as_deref(), args.choices.textures)?;
            let load_ms = ms(t);
            let mut opts = args.to_options(&scene)?;
            opts.check_memory()?;
            opts.readback = readback;
            Ok(crate::overlap::Loaded {
                scene,
                opts,
                load_ms,
            })
        },
        write,
    )?;
    out.stats.process = Some(render::ProcessTimes {
        start_ms,
        load_ms,
        render_call_ms,
        write_ms,
        total_ms: crate::clock::since_start_ms_f64(),
        ends_at_once: crate::gpu::scene::compile_left_running(),
    });
    if let Some(path) = &args.stats {
        write_stats(path, &out.stats)?;
    }
    if !args.quiet {
        eprintln!("{}", summary_line(&args.output, &out.stats, None));
    }
    if args.verbose {
        eprint!("{}", verbose_report(&out.stats));
    }
    Ok(Some(out))
}

/// `render --frames`: the animation of the scene's camera path ([`crate::animate`]).
fn run_frames(args: &RenderArgs, frames: &crate::options::FrameRange) -> Result<()> {
    if args.aov.is_some() {
        return Err(Error::Usage(
            "--frames renders whole images; --aov is for single renders".into(),
        ));
    }
    if let Some(stats) = &args.stats {
        check_writable(stats, "statistics")?;
    }
    let scene = load(args.scene.as_deref(), args.choices.textures)?;
    let opts = args.to_options(&scene)?;
    let path = scene.animation.as_ref().ok_or_else(|| {
        Error::Usage(format!(
            "--frames needs a camera path: {} has no [animation] table (docs/scene-format.md)",
            scene.source
        ))
    })?;
    let mut list = frames.frames(&path.frames())?;
    if args.parts.resume {
        let hash = crate::farm::hash::scene_hash(&scene);
        let all = expected(args, &scene, &opts)?;
        let before = list.len();
        list.retain(|f| {
            !all.iter()
                .any(|e| e.frame == Some(*f) && crate::farm::resume::done(e, hash).is_ok())
        });
        if !args.quiet {
            eprintln!(
                "fragtrace: --resume: {} of {before} frames exist whole, {} to render",
                before - list.len(),
                list.len()
            );
        }
        if list.is_empty() {
            return Ok(());
        }
    }
    let stats = crate::animate::render_frames(&scene, &opts, &list, &args.output, !args.quiet)?;
    if let Some(path) = &args.stats {
        let json =
            serde_json::to_string_pretty(&stats).map_err(|e| Error::Internal(e.to_string()))?;
        image_io::write_atomic(path, |tmp| {
            std::fs::write(tmp, json.as_bytes()).map_err(|source| Error::Io {
                path: path.clone(),
                source,
            })
        })?;
    }
    if !args.quiet {
        let first = stats.per_frame.first();
        // A rate after the first frame needs a second one.
        let rate = match stats.frames {
            0 | 1 => String::new(),
            _ => format!(" ({:.1} frames/s after the first)", stats.steady_fps),
        };
        eprintln!(
            "{}: {} frame{} of {}x{} on {}{}, set-up {:.0} ms, frames {:.0} ms{rate}",
            args.output.display(),
            stats.frames,
            if stats.frames == 1 { "" } else { "s" },
            opts.width,
            opts.height,
            first.map_or("-".into(), |f| f.render.backend.clone()),
            match crate::animate::describe_kernels(&stats.kernels) {
                k if k.is_empty() => k,
                k => format!(", {k}"),
            },
            stats.setup_ms,
            stats.frames_ms,
        );
    }
    Ok(())
}

/// Creates the folder `path` goes in, when missing (the parts and frames of a farm land in
/// folders no one made on a fresh shared volume); a whole render's `-o` in a folder that
/// does not exist is refused instead ([`check_writable`]: a typo costs no render).
pub(crate) fn make_folder(path: &Path) -> Result<()> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() && !dir.exists() => std::fs::create_dir_all(dir)
            .map_err(|e| {
                Error::Usage(format!(
                    "{}: cannot write the image: cannot create its folder {}: {}",
                    path.display(),
                    dir.display(),
                    super::one_line(&e.to_string())
                ))
            }),
        _ => Ok(()),
    }
}

/// Writes render statistics as JSON (atomically).
fn write_stats(path: &Path, stats: &render::RenderStats) -> Result<()> {
    let json = serde_json::to_string_pretty(stats).map_err(|e| Error::Internal(e.to_string()))?;
    image_io::write_atomic(path, |tmp| {
        std::fs::write(tmp, json.as_bytes()).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })
    })
}

/// The files this `render` command writes, with what each must hold ([`crate::farm::resume`]):
/// the parts of its plan, the frames of `--frames`, or the one image.
fn expected(
    args: &RenderArgs,
    scene: &Scene,
    opts: &crate::options::RenderOptions,
) -> Result<Vec<crate::farm::resume::Expected>> {
    use crate::farm::resume::Expected;
    let env = |k: &str| std::env::var(k).ok();
    let (w, h) = (opts.width, opts.height);
    let frames = match (&args.frames, &scene.animation) {
        (None, _) => None,
        (Some(f), Some(path)) => Some(f.frames(&path.frames())?),
        (Some(_), None) => {
            return Err(Error::Usage(format!(
                "--frames needs a camera path: {} has no [animation] table (docs/scene-format.md)",
                scene.source
            )))
        }
    };
    if let Some(plan) = PartPlan::new(
        &args.parts,
        &args.output,
        args.stats.as_deref(),
        frames.as_deref(),
        env,
    )? {
        return (0..plan.units.len())
            .map(|k| {
                let path = plan.outputs[k].clone();
                Ok(Expected {
                    part: image_io::Format::from_path(&path)? == image_io::Format::Exr,
                    path,
                    frame: plan.units[k].frame,
                    region: plan.region(k, w, h)?,
                    width: w,
                    height: h,
                })
            })
            .collect();
    }
    let whole = |frame: Option<u32>, path: std::path::PathBuf| Expected {
        path,
        frame,
        region: Region::full(w, h),
        width: w,
        height: h,
        part: false,
    };
    let template = crate::farm::template::OutputTemplate::new(&args.output)?;
    Ok(match frames {
        Some(list) => list
            .into_iter()
            .map(|f| whole(Some(f), template.path(Some(f), None)))
            .collect(),
        None => vec![whole(None, args.output.clone())],
    })
}

/// `render --check`: renders nothing; prints each file this command would write that is
/// missing or not whole, then `N of M files exist whole`. True when all do.
pub fn run_check(args: &RenderArgs) -> Result<bool> {
    let scene = load(args.scene.as_deref(), args.choices.textures)?;
    let opts = args.to_options(&scene)?;
    let hash = crate::farm::hash::scene_hash(&scene);
    let all = expected(args, &scene, &opts)?;
    let mut missing = 0;
    for e in &all {
        if let Err(why) = crate::farm::resume::done(e, hash) {
            missing += 1;
            println!("{}: {why}", e.path.display());
        }
    }
    println!(
        "{} of {} files exist whole{}",
        all.len() - missing,
        all.len(),
        if missing == 0 {
            String::new()
        } else {
            format!(", {missing} missing")
        }
    );
    Ok(missing == 0)
}

/// `render` of parts: the units of work of `plan` ([`crate::farm`]), each rendered with
/// its region and written as a part (or a crop); None when `--resume` found every one
/// whole.
pub fn run_parts(
    args: &RenderArgs,
    parts: &PartPlan,
    scene: Scene,
) -> Result<Option<render::Rendered>> {
    let mut parts = parts.clone();
    if args.parts.resume {
        let opts = args.to_options(&scene)?;
        let hash = crate::farm::hash::scene_hash(&scene);
        let all = expected(args, &scene, &opts)?;
        let todo: Vec<bool> = all
            .iter()
            .map(|e| crate::farm::resume::done(e, hash).is_err())
            .collect();
        let n = todo.iter().filter(|t| **t).count();
        if !args.quiet {
            eprintln!(
                "fragtrace: --resume: {} of {} parts exist whole, {n} to render",
                todo.len() - n,
                todo.len()
            );
        }
        if n == 0 {
            return Ok(None);
        }
        parts.retain(&todo);
    }
    let parts = &parts;
    for p in &parts.outputs {
        // A fresh volume of a scheduler: the parts' folders are made here.
        make_folder(p)?;
        check_writable(p, "image")?;
        image_io::remove_stale_partials(p);
    }
    for p in &parts.stats {
        check_writable(p, "statistics")?;
    }
    if args.aov.is_some() {
        return Err(Error::Usage(
            "--aov writes whole-image files; it cannot be combined with --tile, --region or --task-index"
                .into(),
        ));
    }
    let mut base = args.to_options(&scene)?;
    // Parts carry linear floats (merged, or encoded on the host like any PNG); no AOVs.
    base.readback = crate::output::Readback {
        aov: false,
        srgb8: false,
    };
    // The limits (host memory, and GL's texture size when the renderer is made) apply to
    // the part, not the whole image: every unit's region is checked before anything
    // renders, and the renderer is made for the first one.
    let regions = (0..parts.units.len())
        .map(|k| parts.region(k, base.width, base.height))
        .collect::<Result<Vec<Region>>>()?;
    for r in &regions {
        crate::options::RenderOptions {
            region: Some(*r),
            ..base.clone()
        }
        .validate()?;
    }
    base.region = regions.first().copied();
    // Once per process, whatever the number of parts: the context, the structure (`auto`
    // resolved for the backend the context settles) and the renderer (the GPU scene
    // uploaded once); each part sets its region and camera.
    base.validate()?;
    let (ctx, base) = render::context_for(&base, &scene, !args.quiet)?;
    let prepared = render::prepare(&scene, &base)?;
    let mut renderer = match &ctx {
        Some(ctx) => prepared.gl_renderer(ctx, &base)?,
        None => prepared.cpu_renderer(&base),
    };
    if let (Some(task), false) = (&parts.task, args.quiet) {
        eprintln!(
            "fragtrace: {task}: {} part(s) of {} tiles",
            parts.units.len(),
            match parts.cut {
                crate::farm::plan::Cut::Tiles(t) => t.count(),
                crate::farm::plan::Cut::Region(_) => 1,
            }
        );
    }
    let mut last = None;
    for (k, unit) in parts.units.iter().enumerate() {
        let region = regions[k];
        let opts = crate::options::RenderOptions {
            region: Some(region),
            ..base.clone()
        };
        renderer.set_region(Some(region))?;
        let camera = match (unit.frame, &scene.animation) {
            (Some(f), Some(path)) => path.camera_at(f),
            _ => scene.camera,
        };
        let out = renderer.render(&camera)?;
        if !out.image.all_finite() {
            return Err(Error::Internal(
                "the render produced a NaN or Inf pixel".into(),
            ));
        }
        crate::farm::write_unit(&scene, &opts, &out, parts, k)?;
        if let Some(path) = parts.stats.get(k) {
            write_stats(path, &out.stats)?;
        }
        if !args.quiet {
            eprintln!(
                "{}",
                summary_line(&parts.outputs[k], &out.stats, Some(region))
            );
        }
        if args.verbose {
            eprint!("{}", verbose_report(&out.stats));
        }
        last = Some(out);
    }
    last.ok_or_else(|| Error::Internal("a plan without units".into()))
        .map(Some)
}

/// The one-line summary of a render on stderr (`-q` turns it off).
fn summary_line(output: &Path, s: &render::RenderStats, region: Option<Region>) -> String {
    format!(
            "{}: {}x{}{} spp {} on {} [{}{}{}], {} triangles, {} ({:.1} ms), {}render {:.1} ms, {} rays ({})",
            output.display(),
            s.width,
            s.height,
            region.map_or(String::new(), |r| format!(" pixels {r}")),
            s.spp,
            s.backend,
            s.precision,
            match (&s.gpu, &s.plan) {
                (Some(g), _) if g.cold_start => match g.handover_row {
                    Some(row) => format!(
                        ", {} kernel (compute compiling; compute from row {row})",
                        g.kernel
                    ),
                    None => format!(", {} kernel (compute compiling)", g.kernel),
                },
                (Some(g), _) => format!(", {} kernel", g.kernel),
                // The CPU path that ran (the plan records it: packets need the BVH and AVX2).
                (None, crate::plan::Plan::Cpu { path, .. }) => format!(", {} path", path.name()),
                (None, _) => String::new(),
            },
            if s.techniques == "default" {
                String::new()
            } else {
                format!(", {}", s.techniques)
            },
            s.triangles,
            s.accel.line(),
            s.grid_build_ms,
            // The GPU's set-up apart: render_ms means tracing on both backends.
            match &s.gpu {
                Some(g) if s.setup_ms > 0.0 => format!(
                    "compile {:.1} ms, upload {:.1} ms, ",
                    g.compile_ms, g.upload_ms
                ),
                _ => String::new(),
            },
            s.render_ms,
            s.rays.total,
            crate::output::ray_rate(s.rays.total, s.render_ms)
        )
}

/// The `-v` log: per pass kind, how many passes and how much GPU time; where the backend
/// counts it (CPU, compute kernel), the traversal work of all rays. One line per entry, most expensive first.
pub fn verbose_report(s: &render::RenderStats) -> String {
    // What a step of the walk enters: a BVH's nodes, a grid's cells.
    let unit = match s.accel.kind {
        crate::accel::AccelKind::Bvh => "nodes",
        crate::accel::AccelKind::Uniform | crate::accel::AccelKind::Irregular => "cells",
    };
    let mut out = format!("{}: {}\n", s.accel.kind.name(), s.accel.detail);
    out += &match s.primary_steps_per_ray {
        Some(v) => format!("primary rays: {v:.1} steps ({unit} + triangle tests) per ray\n"),
        None => {
            "primary rays: steps per ray not counted by this kernel (--aov reads them)\n".into()
        }
    };
    if let (Some(c), Some(t)) = (s.cells_visited, s.triangle_tests) {
        out += &format!(
            "all rays: {c} {unit} visited, {t} triangle tests ({:.1} {unit} and {:.1} tests per ray)\n",
            c as f64 / s.rays.total.max(1) as f64,
            t as f64 / s.rays.total.max(1) as f64
        );
    }
    if let Some(g) = &s.gpu {
        if g.cold_start {
            out += &format!(
                "kernel: {} while the compute kernel compiled (a cold start: its programs \
                 were not in the program-binary cache; the same image){}\n",
                g.kernel,
                match g.handover_row {
                    Some(row) => format!(", then compute from row {row}, its compile done"),
                    None => String::new(),
                }
            );
        }
        let mut rows: Vec<(String, u64, Option<f64>)> = g
            .passes
            .iter()
            .map(|(k, &n)| {
                (
                    k.clone(),
                    n,
                    g.gpu_ms.as_ref().and_then(|m| m.get(k).copied()),
                )
            })
            .collect();
        rows.sort_by(|a, b| {
            b.2.unwrap_or(0.0)
                .total_cmp(&a.2.unwrap_or(0.0))
                .then(b.1.cmp(&a.1))
        });
        out += &format!(
            "{:<24} {:>10} {:>12} {:>12}\n",
            "pass", "count", "gpu ms", "ms/pass"
        );
        for (name, n, t) in rows {
            let (t, per) = match t {
                Some(t) => (format!("{t:.2}"), format!("{:.4}", t / n.max(1) as f64)),
                // No timer queries, or they measured nothing (GpuStats::add_gpu_time).
                None => ("n/a".into(), "n/a".into()),
            };
            out += &format!("{name:<24} {n:>10} {t:>12} {per:>12}\n");
        }
        out += &format!(
            "total: {} passes, {} termination queries, {} pixels drawn by advancing passes \
             ({} active), gpu {}, context {:.1} ms, compile {:.1} ms, upload {:.1} ms\n",
            g.passes_total,
            g.termination_queries,
            g.advance_pixels,
            g.advance_active,
            g.gpu_ms_total
                .map_or("n/a".into(), |t| format!("{t:.2} ms")),
            g.context_ms,
            g.compile_ms,
            g.upload_ms,
        );
    }
    out
}
