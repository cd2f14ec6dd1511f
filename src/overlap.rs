//! The process's start and end, overlapped: the scene loads (and its structure builds) on
//! a second thread while this one decides whether to open a context (`auto` lists the
//! devices, which starts the drivers) and starts the GL driver; at the end the image is
//! written on a second thread while this one releases the context. On the H100 machine the
//! driver's start is about 150 ms of a 4096² render's whole process and the context's
//! release 16 ms; the bunny's load and build 45 and 16 ms (docs/performance.md): side by
//! side, the shorter is hidden. Where `auto` takes the CPU, the load still runs beside the
//! device listing; where the flags alone do not make the options, the render is the plain
//! [`crate::render::render`] after the load.

use crate::backend_choice::{open_context, start_of, Start};
use crate::options::{Backend, RenderOptions};
use crate::render::{prepare_owned, render_cpu, render_gl_built, Prepared, Rendered};
use crate::scene::Scene;
use crate::Result;

/// A scene loaded with the options to render it, and the load's time.
pub struct Loaded {
    /// The scene.
    pub scene: Scene,
    /// Its render options (the command line's, for this scene).
    pub opts: RenderOptions,
    /// Loading the scene and its meshes, in ms.
    pub load_ms: f64,
}

/// What the loading thread hands back: the scene, and its structure where it could be
/// built before the context was open (with the options it was built with).
enum Ready {
    Scene(Box<Scene>),
    Built(Box<Prepared<'static>>, RenderOptions),
}

/// Renders the scene `load` gives, as [`crate::render::render`] would, with `load` run on
/// a second thread while this one decides whether to open a context and opens it, as
/// `early` asks: the options the flags alone give
/// ([`crate::choices::RenderArgs::context_options`]), None where they could not be made
/// without the scene (then nothing overlaps). The decision itself may start the driver
/// (`auto` lists the devices to see whether only Mesa's software one is there: about 100
/// ms on the H100 machine), so it runs beside the load too. Where a context is opened, the
/// loading thread also builds a scene without instances its GPU structure (the options a
/// context settles build the same one for it; where the context turns out otherwise, the
/// structure is built again for what it asks). The load's error comes first, as it did when
/// the load came first.
///
/// `deliver` gets the render (to write its image) while the GPU's context is released on
/// this thread (about 16 ms at 4096² on the H100 machine, with the staging memory it
/// pinned); its answer is returned beside the render and the load's time.
pub fn render_loading<F, D, T>(
    early: Option<&RenderOptions>,
    load: F,
    deliver: D,
) -> Result<(Rendered, f64, T)>
where
    F: FnOnce() -> Result<Loaded> + Send,
    D: FnOnce(&Rendered) -> Result<T> + Send,
    T: Send,
{
    let Some(early) = early else {
        let l = load()?;
        let out = crate::render::render(&l.scene, &l.opts)?;
        let t = deliver(&out)?;
        return Ok((out, l.load_ms, t));
    };
    // Whether a context is being opened, from this thread to the loading one.
    let (open_tx, open_rx) = std::sync::mpsc::channel::<bool>();
    let (ctx, ready) = std::thread::scope(|s| {
        let worker = s.spawn(move || -> Result<(Ready, RenderOptions, f64)> {
            let Loaded {
                scene,
                opts,
                load_ms,
            } = load()?;
            // A closed channel (this thread's sibling failed) opens nothing.
            if scene.has_instances() || !open_rx.recv().unwrap_or(false) {
                return Ok((Ready::Scene(Box::new(scene)), opts, load_ms));
            }
            let gpu = RenderOptions {
                backend: Backend::Gl,
                ..opts.clone()
            }
            .on_backend(true);
            // A structure the GPU refuses (its size) is refused again, in the same words,
            // where the context asks for it; the CPU may still take the scene.
            let ready = match prepare_owned(scene, &gpu) {
                Ok(p) => Ready::Built(Box::new(p), gpu),
                Err((_, scene)) => Ready::Scene(Box::new(scene)),
            };
            Ok((ready, opts, load_ms))
        });
        let open = matches!(start_of(early), Start::Open);
        let _ = open_tx.send(open);
        let t = crate::clock::Instant::now();
        let ctx = open.then(|| open_context(early, early.progress).map(|c| (c, t.elapsed())));
        let ready = worker
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (ctx, ready)
    });
    let (ready, opts, load_ms) = ready?;
    let (scene, built) = match &ready {
        Ready::Scene(scene) => (&**scene, None),
        Ready::Built(p, o) => (&*p.scene, Some((&**p, o))),
    };
    let (ctx, opened) = match ctx.transpose()? {
        // `auto` without a context worth opening: the whole choice again, with the scene's
        // options (the devices are listed once per process).
        None => {
            let out = crate::render::render(scene, &opts)?;
            let t = deliver(&out)?;
            return Ok((out, load_ms, t));
        }
        Some(c) => c,
    };
    let Some(ctx) = ctx else {
        let out = render_cpu(scene, &opts)?;
        let t = deliver(&out)?;
        return Ok((out, load_ms, t));
    };
    let mut out = render_gl_built(&ctx, scene, &opts, built)?;
    if let Some(g) = out.stats.gpu.as_mut() {
        g.context_ms = opened.as_secs_f64() * 1e3;
    }
    let t = std::thread::scope(|s| {
        let writer = s.spawn(|| deliver(&out));
        if crate::gpu::scene::compile_left_running() {
            // The process ends after the write (end_now): the context's release would
            // wait for the driver's compile.
            std::mem::forget(ctx);
        } else {
            drop(ctx);
        }
        writer
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    })?;
    Ok((out, load_ms, t))
}

/// Ends the process with `code` at once, without the exit handlers of the libraries it
/// loaded, where a GPU driver still compiles a program on its own threads
/// ([`crate::gpu::scene::compile_left_running`]): NVIDIA's exit handlers wait for that
/// compile (210-260 ms after a cold start on the H100 machine, against 60-70 ms this way;
/// docs/performance.md). The files are written by then; standard output is flushed first
/// (standard error is unbuffered). Elsewhere (or off Linux) it returns, and the process
/// ends as usual.
pub fn end_now(code: i32) {
    if !crate::gpu::scene::compile_left_running() {
        return;
    }
    #[cfg(target_os = "linux")]
    {
        use std::io::Write;
        let _ = std::io::stdout().flush();
        // SAFETY: _exit ends the process; nothing after it runs.
        unsafe { libc::_exit(code) }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = code;
}
