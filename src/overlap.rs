//! The process's start, overlapped: the scene loads (and its structure builds) on a second
//! thread while this one starts the GL driver. On the H100 machine the driver's start is
//! about 150 ms of a 4096² render's whole process (`gpu.context_ms`), the bunny's load and
//! build 45 and 16 ms (issue 52's breakdown, docs/performance.md): side by side, the
//! shorter is hidden. Only where a context is to be opened
//! (`gl`, or `auto` on a device that is not Mesa's software one); every other render is the plain
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
/// a second thread while this one opens the context that `early` asks for: the options
/// the flags alone give ([`crate::choices::RenderArgs::context_options`]), None where
/// they could not be made without the scene (then nothing overlaps). On that thread a
/// scene without instances also gets its GPU structure built (the options a context
/// settles build the same one for it; where the context turns out otherwise, the
/// structure is built again for what it asks). The load's error comes first, as it did
/// when the load came first. Returns the render and the load's time.
pub fn render_loading<F>(early: Option<&RenderOptions>, load: F) -> Result<(Rendered, f64)>
where
    F: FnOnce() -> Result<Loaded> + Send,
{
    let Some(early) = early.filter(|o| matches!(start_of(o), Start::Open)) else {
        let l = load()?;
        return Ok((crate::render::render(&l.scene, &l.opts)?, l.load_ms));
    };
    let (ctx, ready) = std::thread::scope(|s| {
        let worker = s.spawn(move || -> Result<(Ready, RenderOptions, f64)> {
            let Loaded {
                scene,
                opts,
                load_ms,
            } = load()?;
            if scene.has_instances() {
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
        let t = crate::clock::Instant::now();
        let ctx = open_context(early, early.progress).map(|c| (c, t.elapsed()));
        let ready = worker
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (ctx, ready)
    });
    let (ready, opts, load_ms) = ready?;
    let (ctx, opened) = ctx?;
    let (scene, built) = match &ready {
        Ready::Scene(scene) => (&**scene, None),
        Ready::Built(p, o) => (&*p.scene, Some((&**p, o))),
    };
    let out = match ctx {
        None => render_cpu(scene, &opts)?,
        Some(ctx) => {
            let mut out = render_gl_built(&ctx, scene, &opts, built)?;
            if let Some(g) = out.stats.gpu.as_mut() {
                g.context_ms = opened.as_secs_f64() * 1e3;
            }
            out
        }
    };
    Ok((out, load_ms))
}
