//! Occlusion queries (how the host learns how many rays are still active) and timer
//! queries (per-pass GPU time).

use glow::HasContext;

use super::{check_gl_error, Owned, QueryKind};
use crate::error::{Error, Result};
use crate::gpu::context::GlContext;

/// Counts the fragments that survive (are not `discard`ed and pass any enabled tests)
/// between [`OcclusionQuery::begin`] and [`OcclusionQuery::end`]: `GL_SAMPLES_PASSED`,
/// which equals fragments because render targets are never multisampled.
#[derive(Debug)]
pub struct OcclusionQuery {
    query: Owned<QueryKind>,
}

impl OcclusionQuery {
    /// Creates the query object.
    pub fn new(ctx: &GlContext) -> Result<Self> {
        // SAFETY: the context is current (the rule of gpu::context); the new name is
        // owned at once below.
        let query = unsafe { ctx.gl().create_query() }
            .map_err(|e| Error::Internal(format!("glGenQueries: {e}")))?;
        Ok(OcclusionQuery {
            query: Owned::new(ctx, query),
        })
    }

    /// Starts counting. Only one `GL_SAMPLES_PASSED` query may be active at a time.
    pub fn begin(&self, ctx: &GlContext) {
        // SAFETY: the context is current and the name is this context's (`Owned` keeps it
        // alive); a second active query is a GL error, not undefined behaviour.
        unsafe {
            ctx.gl()
                .begin_query(glow::SAMPLES_PASSED, self.query.name())
        };
    }

    /// Stops counting.
    pub fn end(&self, ctx: &GlContext) {
        // SAFETY: the context is current; ending a query takes no name, and without an
        // active one it is a GL error.
        unsafe { ctx.gl().end_query(glow::SAMPLES_PASSED) };
    }

    /// The count; waits for the GPU to finish the counted draws.
    pub fn result(&self, ctx: &GlContext) -> Result<u32> {
        #[cfg(not(target_arch = "wasm32"))]
        let n = ctx.raw().query_result_u32(self.query.name());
        // WebGL's queries are read through glow (no GL 2.1 driver quirks to avoid there).
        #[cfg(target_arch = "wasm32")]
        // SAFETY: valid query name of this context.
        let n = unsafe {
            ctx.gl()
                .get_query_parameter_u32(self.query.name(), glow::QUERY_RESULT)
        };
        check_gl_error(ctx.gl(), "reading an occlusion query")?;
        Ok(n)
    }
}

/// GPU time of the commands between [`TimerQuery::begin`] and [`TimerQuery::end`]
/// (`GL_TIME_ELAPSED`); optional, see [`GlInfo::timer_query`](crate::gpu::GlInfo::timer_query).
#[derive(Debug)]
pub struct TimerQuery {
    query: Owned<QueryKind>,
}

impl TimerQuery {
    /// Creates the query object, or fails with [`Error::GlUnavailable`] when the context has
    /// no timer queries (check `ctx.info.timer_query` to skip timing instead).
    pub fn new(ctx: &GlContext) -> Result<Self> {
        if !ctx.info.timer_query {
            return Err(Error::GlUnavailable(
                "timer queries need OpenGL 3.3, GL_ARB_timer_query or GL_EXT_timer_query".into(),
            ));
        }
        // SAFETY: the context is current (the rule of gpu::context); the new name is
        // owned at once below.
        let query = unsafe { ctx.gl().create_query() }
            .map_err(|e| Error::Internal(format!("glGenQueries: {e}")))?;
        Ok(TimerQuery {
            query: Owned::new(ctx, query),
        })
    }

    /// Starts timing. Only one `GL_TIME_ELAPSED` query may be active at a time (an
    /// occlusion query may run concurrently).
    pub fn begin(&self, ctx: &GlContext) {
        // SAFETY: valid query name of this context.
        unsafe { ctx.gl().begin_query(glow::TIME_ELAPSED, self.query.name()) };
    }

    /// Stops timing.
    pub fn end(&self, ctx: &GlContext) {
        // SAFETY: the context is current; ending a query takes no name, and without an
        // active one it is a GL error.
        unsafe { ctx.gl().end_query(glow::TIME_ELAPSED) };
    }

    /// Elapsed GPU time in nanoseconds; waits for the timed commands to finish.
    pub fn result_ns(&self, ctx: &GlContext) -> Result<u64> {
        #[cfg(not(target_arch = "wasm32"))]
        let ns = ctx.raw().query_result_u64(self.query.name());
        // The web page never times passes with queries (`GlInfo::timer_query` is false).
        #[cfg(target_arch = "wasm32")]
        let ns: Option<u64> = None;
        let ns =
            ns.ok_or_else(|| Error::Internal("timer query without timer-query support".into()))?;
        check_gl_error(ctx.gl(), "reading a timer query")?;
        Ok(ns)
    }
}
