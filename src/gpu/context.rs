//! A headless OpenGL context ([`GlContext`]) and the one rule by which GL objects find it.
//!
//! The context is an EGL session ([`super::egl`]) plus the glow function table and the
//! capability report ([`super::info`]). A [`GlContext`] is bound to the thread that created
//! it (it is deliberately neither `Send` nor `Sync`): GL calls go to the thread's *current*
//! context, and moving one between threads would silently redirect them.
//!
//! # Who frees GL objects, and in which context
//!
//! Every GL object the backend creates (texture, framebuffer, renderbuffer, program, shader,
//! query, buffer, vertex array) is an owning value from [`super::gl`] that deletes its name
//! in `Drop`. Each holds an `Rc` of the context's `GlShared` (the glow table and the EGL
//! session), so the context cannot be destroyed before the last of its objects: dropping the
//! [`GlContext`] only drops one reference. Drop finds the context through that `Rc`; when
//! another context is current on the thread (tests and tools may hold several), it makes its
//! own context current for the delete and then restores the previous one, so a name is never
//! deleted in the wrong context's namespace. Nothing is freed by hand.
//!
//! # Contexts fragtrace does not create
//!
//! [`GlContext::from_external`] wraps a context someone else created and made current (a
//! window's, in `fragtrace view`) behind the [`ExternalContext`] trait, so the same
//! renderer runs in it. `GlShared` then holds that owner instead of an EGL session
//! (`Session`); because it holds it (an `Rc` of the window's GL state, say), the
//! foreign context too lives until the last GL object made in it is gone, and Drop makes
//! it current through the trait before deleting a name.

use std::cell::RefCell;
use std::ffi::c_void;
use std::fmt;
use std::rc::Rc;

#[cfg(not(target_arch = "wasm32"))]
use super::egl::{egl_instance, open_session_on, EglSession};
#[cfg(not(target_arch = "wasm32"))]
use super::gl::probe::{load, RawGl};
#[cfg(not(target_arch = "wasm32"))]
use super::info::limit_profile;
use super::info::GlInfo;
use crate::error::{Error, Result};

/// A GL context created and owned outside fragtrace (a window's), for
/// [`GlContext::from_external`]. The implementor keeps the context alive for as long as it
/// lives itself; `GlContext` keeps the implementor until the last GL object is dropped.
pub trait ExternalContext {
    /// Makes the context current on the calling thread (a no-op when it is); false when
    /// that fails, in which case a GL object's delete is skipped rather than sent to
    /// whatever context is current.
    fn make_current(&self) -> bool;
    /// The address of GL function `name`, or null.
    fn get_proc_address(&self, name: &str) -> *const c_void;
    /// How the context was made, for the report's `EGL platform` line (e.g. `glutin EGL,
    /// X11 window`).
    fn platform(&self) -> String;
    /// The display API's version string (EGL's or GLX's), for the report.
    fn api_version(&self) -> String;
}

/// How a [`GlContext`]'s context is reached: its own headless EGL session, or a context
/// owned elsewhere. Only `with_current` and `make_current` differ.
enum Session {
    /// A headless context fragtrace created ([`super::egl`]).
    #[cfg(not(target_arch = "wasm32"))]
    Egl(EglSession),
    /// A context created by someone else (see [`ExternalContext`]).
    External(Box<dyn ExternalContext>),
    /// A browser's WebGL context ([`super::web`]): one per canvas, always current.
    #[cfg(target_arch = "wasm32")]
    Web,
}

/// What a context's GL objects share with it: the function tables and the session.
///
/// Field order is drop order: the context (in `session`) goes last.
pub(crate) struct GlShared {
    /// The glow function table.
    pub(crate) gl: glow::Context,
    /// The directly loaded entry points.
    #[cfg(not(target_arch = "wasm32"))]
    pub(crate) raw: RawGl,
    /// Deletes put off while the driver is busy with their objects ([`GlShared::defer`]).
    deferred: RefCell<Vec<Deferred>>,
    session: Session,
}

/// A GL delete put off: `done` says, without waiting, whether the driver is through with
/// the object (then `delete` no longer waits); both run with the context current.
pub(crate) struct Deferred {
    /// Whether the delete would no longer wait.
    pub(crate) done: Box<dyn Fn(&glow::Context) -> bool>,
    /// The delete.
    pub(crate) delete: Box<dyn FnOnce(&glow::Context)>,
}

impl Drop for GlShared {
    fn drop(&mut self) {
        let deferred = std::mem::take(self.deferred.get_mut());
        if !deferred.is_empty() {
            self.with_current(|gl| deferred.into_iter().for_each(|d| (d.delete)(gl)));
        }
    }
}

impl GlShared {
    /// Puts a delete off until the driver is done with its object ([`GlShared::reap`]) or
    /// the context goes: for an object whose delete the driver would make wait (a program
    /// it is still compiling on its own threads: NVIDIA holds the delete until the compile
    /// ends, 300 ms on the H100 after a cold start's looped frame, docs/performance.md).
    /// The context's release waits for it anyway, or never comes (a command line that ends
    /// with the process, `crate::overlap::end_now`).
    pub(crate) fn defer(&self, d: Deferred) {
        self.deferred.borrow_mut().push(d);
    }

    /// Runs the put-off deletes whose objects the driver is done with, so that a context
    /// that lives on (the viewer's, a library user's) frees them once their compiles end
    /// (`GpuScene::new` asks).
    pub(crate) fn reap(&self) {
        if self.deferred.borrow().is_empty() {
            return;
        }
        self.with_current(|gl| {
            let all = std::mem::take(&mut *self.deferred.borrow_mut());
            let (done, waiting): (Vec<Deferred>, Vec<Deferred>) =
                all.into_iter().partition(|d| (d.done)(gl));
            done.into_iter().for_each(|d| (d.delete)(gl));
            self.deferred.borrow_mut().extend(waiting);
        });
    }

    /// Runs `f` with this context current: directly when it already is, otherwise after
    /// making it current, restoring the thread's previous context afterwards. If it cannot be
    /// made current, `f` is skipped (leaking a name beats deleting another context's).
    ///
    /// An external context is made current and left current: its owner runs one context
    /// per thread (the window's), so there is no previous one to restore.
    pub(crate) fn with_current(&self, f: impl FnOnce(&glow::Context)) {
        match &self.session {
            #[cfg(not(target_arch = "wasm32"))]
            Session::Egl(s) => s.with_current(|| f(&self.gl)),
            Session::External(e) => {
                if e.make_current() {
                    f(&self.gl)
                }
            }
            #[cfg(target_arch = "wasm32")]
            Session::Web => f(&self.gl),
        }
    }
}

/// A current, headless OpenGL context plus the report on what it can do.
///
/// Create it with [`GlContext::new`] (fails unless every requirement holds) or
/// [`GlContext::new_unchecked`] (for an `info` command that must print the report even on an
/// inadequate driver). The context is made current on the creating thread; if a thread creates
/// several, call [`GlContext::make_current`] before using one. The EGL context lives until
/// this value and every GL object made from it are dropped (see the module documentation).
pub struct GlContext {
    shared: Rc<GlShared>,
    /// Driver identification, limits and the feature verdict.
    pub info: GlInfo,
}

impl fmt::Debug for GlContext {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("GlContext")
            .field("info", &self.info)
            .finish_non_exhaustive()
    }
}

impl GlContext {
    #[cfg(not(target_arch = "wasm32"))]
    /// Creates a headless context and fails with [`Error::GlUnavailable`] (naming every missing
    /// feature) unless it satisfies all of fragtrace's requirements.
    pub fn new() -> Result<GlContext> {
        Self::on_device(None)
    }

    #[cfg(not(target_arch = "wasm32"))]
    /// [`GlContext::new`] on EGL device `device` of [`super::egl::list_devices`] (`--gpu
    /// N`), or on the first display that works when None. A device number beyond the list
    /// is [`Error::Usage`] naming how many there are.
    pub fn on_device(device: Option<u32>) -> Result<GlContext> {
        let ctx = Self::new_unchecked_on(device)?;
        ctx.info.verdict().map_err(Error::GlUnavailable)?;
        Ok(ctx)
    }

    #[cfg(not(target_arch = "wasm32"))]
    /// Creates a headless context without judging it: only a failure to get *any* desktop-GL
    /// context is an error. Meant for `fragtrace info`, which prints [`GlContext::info`]
    /// (including the verdict line) even when the driver is inadequate.
    pub fn new_unchecked() -> Result<GlContext> {
        Self::new_unchecked_on(None)
    }

    #[cfg(not(target_arch = "wasm32"))]
    /// [`GlContext::new_unchecked`] on a chosen EGL device (see [`GlContext::on_device`]).
    pub fn new_unchecked_on(device: Option<u32>) -> Result<GlContext> {
        limit_profile().map_err(Error::Usage)?;
        let egl = egl_instance()?;
        let session = open_session_on(egl, device)?;
        let fallback = session.fallback_lib.as_ref();
        let loader = |name: &str| -> *const c_void {
            if let Some(f) = egl.get_proc_address(name) {
                return f as *const c_void;
            }
            // Only reached on EGL 1.4 without EGL_KHR_get_all_proc_addresses, where core GL
            // 1.x functions are not available through eglGetProcAddress.
            fallback
                .and_then(|lib| {
                    // SAFETY: the symbol is only used as an opaque address by the GL loader.
                    unsafe { lib.get::<*const c_void>(name.as_bytes()) }
                        .ok()
                        .map(|s| *s)
                })
                .unwrap_or(std::ptr::null())
        };

        let names = [
            session.platform.clone(),
            session.vendor.clone(),
            session.version.clone(),
        ];
        let (gl, raw, info) = load(&loader, &names)?;
        // The loader's borrow of `session` ends here; the session moves into the context.
        Ok(GlContext {
            shared: Rc::new(GlShared {
                gl,
                raw,
                deferred: RefCell::default(),
                session: Session::Egl(session),
            }),
            info,
        })
    }

    #[cfg(not(target_arch = "wasm32"))]
    /// Runs fragtrace in a context created elsewhere, current on this thread (a window's:
    /// see [`ExternalContext`]), and fails with [`Error::GlUnavailable`] unless it
    /// satisfies all of fragtrace's requirements, as [`GlContext::new`] does.
    pub fn from_external(context: Box<dyn ExternalContext>) -> Result<GlContext> {
        limit_profile().map_err(Error::Usage)?;
        if !context.make_current() {
            return Err(Error::GlUnavailable(format!(
                "cannot make the {} context current",
                context.platform()
            )));
        }
        let names = [context.platform(), String::new(), context.api_version()];
        let loader = |name: &str| context.get_proc_address(name);
        let (gl, raw, info) = load(&loader, &names)?;
        let ctx = GlContext {
            shared: Rc::new(GlShared {
                gl,
                raw,
                deferred: RefCell::default(),
                session: Session::External(context),
            }),
            info,
        };
        ctx.info.verdict().map_err(Error::GlUnavailable)?;
        Ok(ctx)
    }

    /// Makes this context current on the calling thread (needed only when one thread owns
    /// several contexts; creation already makes it current).
    pub fn make_current(&self) -> Result<()> {
        match &self.shared.session {
            #[cfg(not(target_arch = "wasm32"))]
            Session::Egl(s) => s
                .make_current()
                .map_err(|e| Error::Internal(format!("eglMakeCurrent failed: {e}"))),
            Session::External(e) => e.make_current().then_some(()).ok_or_else(|| {
                Error::Internal(format!("cannot make the {} context current", e.platform()))
            }),
            #[cfg(target_arch = "wasm32")]
            Session::Web => Ok(()),
        }
    }

    /// The glow function table, for `gpu::gl`'s safe wrappers (crate-private: outside the
    /// crate, GL is reached only through them). Every call assumes this context is current.
    pub(crate) fn gl(&self) -> &glow::Context {
        &self.shared.gl
    }

    /// The directly loaded entry points (see [`RawGl`]).
    #[cfg(not(target_arch = "wasm32"))]
    pub(crate) fn raw(&self) -> &RawGl {
        &self.shared.raw
    }

    /// The state GL objects keep alive (see the module documentation).
    pub(crate) fn shared(&self) -> &Rc<GlShared> {
        &self.shared
    }
}

/// A context around a browser's WebGL context (`gpu::web`), with its report.
#[cfg(target_arch = "wasm32")]
pub(crate) fn web_context(gl: glow::Context, info: GlInfo) -> GlContext {
    GlContext {
        shared: Rc::new(GlShared {
            gl,
            deferred: RefCell::default(),
            session: Session::Web,
        }),
        info,
    }
}

/// Serialises GL use across threads of one process and hands `f` a fresh, checked context.
///
/// Mesa's EGL/llvmpipe is not robust against many contexts being created and destroyed
/// concurrently, and the test harness runs tests on parallel threads, so every test that
/// touches GL goes through here. A panic inside `f` does not poison the lock for later tests.
///
/// # Panics
/// When no usable context can be created: tests that need a GPU should fail loudly, not skip.
#[cfg(test)]
pub(crate) fn with_test_context<R>(f: impl FnOnce(&GlContext) -> R) -> R {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _guard = LOCK.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    let ctx = GlContext::new().unwrap_or_else(|e| panic!("{e}"));
    f(&ctx)
}

/// Running one `#[ignore]`d test of this binary in a child process with extra environment,
/// for checks that need a differently configured driver (Mesa reads its overrides once).
#[cfg(test)]
pub(crate) mod test_support {
    /// Runs test `name` (full path, e.g. `gpu::context::tests::x`) in a child process with
    /// `env` set; returns whether it passed and its combined output. A filter that matches
    /// nothing counts as a failure.
    pub(crate) fn run_ignored_test_in_child(name: &str, env: &[(&str, &str)]) -> (bool, String) {
        let exe = std::env::current_exe().expect("test binary path");
        let out = std::process::Command::new(exe)
            .args([
                "--exact",
                name,
                "--ignored",
                "--nocapture",
                "--test-threads=1",
            ])
            .envs(env.iter().copied())
            .output()
            .expect("spawn test binary");
        let stdout = String::from_utf8_lossy(&out.stdout);
        let text = format!("{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
        (out.status.success() && stdout.contains("1 passed"), text)
    }

    /// Environment variable that acknowledges skipping the Mesa-only checks on another
    /// driver (`FRAGTRACE_ALLOW_SKIP=1`).
    pub(crate) const ALLOW_SKIP_ENV: &str = "FRAGTRACE_ALLOW_SKIP";

    /// Whether the Mesa-only check `what` can run: true on Mesa. Other drivers ignore
    /// Mesa's override variables, so the check cannot run there; rather than pass silently,
    /// the test then fails with the reason, unless `FRAGTRACE_ALLOW_SKIP=1` acknowledges
    /// the skip (false, after a `SKIPPED` line on stderr). docs/testing.md explains.
    ///
    /// # Panics
    /// Off Mesa without the acknowledgement.
    pub(crate) fn mesa_or_acknowledged_skip(what: &str) -> bool {
        let version = super::with_test_context(|ctx| ctx.info.gl_version.clone());
        if version.contains("Mesa") {
            return true;
        }
        let why = format!(
            "{what} needs Mesa (its MESA_*_OVERRIDE variables), and this driver is {version:?}"
        );
        if std::env::var(ALLOW_SKIP_ENV).as_deref() == Ok("1") {
            eprintln!("SKIPPED ({ALLOW_SKIP_ENV}=1): {why}");
            false
        } else {
            panic!(
                "{why}: the check cannot run here. Run it on Mesa (under glvnd, \
                 __EGL_VENDOR_LIBRARY_FILENAMES=/usr/share/glvnd/egl_vendor.d/50_mesa.json \
                 picks it), or set {ALLOW_SKIP_ENV}=1 to acknowledge the skip."
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::test_support::{mesa_or_acknowledged_skip, run_ignored_test_in_child};
    use super::*;
    use crate::gpu::egl::PLATFORM_ENV;

    #[test]
    fn context_reports_gl21_and_all_required_features() {
        with_test_context(|ctx| {
            let info = &ctx.info;
            assert!(info.gl_major_minor >= (2, 1), "{info}");
            assert!(info.features.len() >= 8);
            for c in &info.features {
                assert!(c.ok, "missing {}\n{info}", c.name);
            }
            assert_eq!(info.verdict(), Ok(()));
            assert!(!info.extensions.is_empty());
            assert!(
                info.max_draw_buffers >= 4 && info.max_texture_size >= 2048,
                "{info}"
            );
            assert!(info.max_texture_units >= 2, "{info}");
            let report = info.to_string();
            for needle in [
                "EGL platform:",
                "OpenGL version:",
                "GLSL version:",
                "Verdict: OK",
            ] {
                assert!(report.contains(needle), "{needle} missing in\n{report}");
            }
            // The context really is current and usable.
            crate::gpu::gl::check_gl_error(ctx.gl(), "a new context").unwrap();
        });
    }

    #[test]
    fn two_contexts_on_one_display_survive_each_other() {
        with_test_context(|first| {
            let second = GlContext::new().expect("second context");
            drop(second);
            // Dropping the second must neither terminate the shared display nor leave the
            // thread without a current context once the first is made current again.
            first.make_current().expect("make first current again");
            let v = first.raw().string(glow::VERSION);
            assert_eq!(v.as_deref(), Some(first.info.gl_version.as_str()));
        });
    }

    /// An inadequate driver (Mesa forced to GL 2.0) makes `new` fail with GlUnavailable
    /// naming the missing version, while `new_unchecked` still reports it.
    #[test]
    fn too_old_gl_is_gl_unavailable() {
        if !mesa_or_acknowledged_skip("forcing GL 2.0 to see it refused") {
            return;
        }
        let (ok, out) = run_ignored_test_in_child(
            "gpu::context::tests::gl20_inner",
            &[
                ("MESA_GL_VERSION_OVERRIDE", "2.0"),
                ("MESA_GLSL_VERSION_OVERRIDE", "110"),
            ],
        );
        assert!(ok, "{out}");
    }

    #[test]
    #[ignore = "run by too_old_gl_is_gl_unavailable with Mesa forced to GL 2.0"]
    fn gl20_inner() {
        match GlContext::new() {
            Err(Error::GlUnavailable(reason)) => {
                eprintln!("{reason}");
                assert!(reason.contains("OpenGL >= 2.1"), "{reason}");
                assert!(reason.contains("GLSL >= 1.20"), "{reason}");
            }
            Err(other) => panic!("wrong error kind: {other}"),
            Ok(ctx) => panic!("GL 2.0 accepted:\n{}", ctx.info),
        }
        let ctx = GlContext::new_unchecked().expect("unchecked context");
        assert_eq!(ctx.info.gl_major_minor, (2, 0));
        assert!(
            ctx.info.to_string().contains("Verdict: UNUSABLE"),
            "{}",
            ctx.info
        );
    }

    /// Each display path on its own: the surfaceless platform must work here; the others
    /// must either work or fail with GlUnavailable naming that path (never panic or hang).
    #[test]
    fn each_egl_platform_can_be_forced() {
        for platform in ["surfaceless", "device", "default"] {
            let (ok, out) = run_ignored_test_in_child(
                "gpu::context::tests::forced_platform_inner",
                &[(PLATFORM_ENV, platform)],
            );
            eprintln!(
                "--- {PLATFORM_ENV}={platform}: {}\n{out}",
                if ok { "ok" } else { "failed" }
            );
            assert!(ok, "{platform}: {out}");
        }
        let (ok, out) = run_ignored_test_in_child(
            "gpu::context::tests::forced_platform_inner",
            &[(PLATFORM_ENV, "bogus")],
        );
        assert!(ok, "{out}");
    }

    #[test]
    #[ignore = "run by each_egl_platform_can_be_forced with FRAGTRACE_EGL_PLATFORM set"]
    fn forced_platform_inner() {
        let platform = std::env::var(PLATFORM_ENV).unwrap_or_default();
        match GlContext::new() {
            Ok(ctx) => {
                eprintln!("{}", ctx.info);
                let expect = match platform.as_str() {
                    "surfaceless" => "EGL_MESA_platform_surfaceless",
                    "device" => "EGL_EXT_platform_device",
                    _ => "EGL_DEFAULT_DISPLAY",
                };
                assert!(
                    ctx.info.egl_platform.contains(expect),
                    "{}",
                    ctx.info.egl_platform
                );
            }
            Err(Error::Usage(msg)) => assert_eq!(platform, "bogus", "{msg}"),
            Err(Error::GlUnavailable(reason)) => {
                eprintln!("{reason}");
                assert_ne!(platform, "surfaceless", "{reason}");
                assert!(reason.contains(&platform), "{reason}");
            }
            Err(other) => panic!("{other}"),
        }
    }
}
