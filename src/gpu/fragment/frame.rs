//! The frame of one render: every GL object it needs (programs, scene textures, the
//! ping-ponged ray state, the per-level hit records, the colour accumulator, queries), and
//! the primitives the walk is written in: draw a pass into a target, run a ray-state pass
//! (read one set, write the other, swap), count fragments under an occlusion query.
//!
//! Everything a `Frame` holds frees itself when the frame is dropped, also when building it
//! or rendering with it fails half-way (see [`crate::gpu::context`]).

use std::collections::HashMap;
use std::rc::Rc;

use super::passes::passes_for;
use super::tiles::TileGrid;
use crate::gpu::context::GlContext;
use crate::gpu::contract::{
    uniform, GlslType, Uniform, Unit, REQUIRED_TEXTURE_UNITS, TEXTURED_TEXTURE_UNITS,
};
use crate::gpu::gl::{
    state, FullscreenQuad, OcclusionQuery, PixelRect, Program, Rects, RenderTarget, Renderbuffer,
    TexFormat, Texture, TimerQuery,
};
use crate::gpu::layout::Fetch;
use crate::gpu::options::{FragmentKernel, GpuOptions, Mask, Storage};
use crate::gpu::pause::pause;
use crate::gpu::request::{Advance, Flow, Observer, Snapshot};
use crate::gpu::scene::{bind_texture, GpuScene};
use crate::gpu::shader::{Count, Pass};
use crate::output::{Aov, GpuStats};
use crate::progress::Progress;
use crate::technique::Techniques;
use crate::{Error, Result};

/// A render in progress: programs, textures and targets.
pub(super) struct Frame<'a> {
    /// The scene on the GPU (textures, programs).
    pub(super) gs: &'a GpuScene<'a>,
    pub(super) ctx: &'a GlContext,
    quad: FullscreenQuad,
    programs: HashMap<Pass, Rc<Program>>,
    /// Ray state, two sets of four attachments (s0..s3).
    pub(super) state: [RenderTarget; 2],
    /// The set holding the current state.
    pub(super) cur: usize,
    /// Per level: records r0 (origin, tri) and r1 (direction, t).
    rec01: Vec<RenderTarget>,
    /// Per level: record r2 (weight, exists).
    rec2: Vec<RenderTarget>,
    /// Colour accumulator, ping-ponged.
    pub(super) acc: [RenderTarget; 2],
    pub(super) acc_cur: usize,
    counter: Counter,
    /// The tiles the advancing passes are cut to (`tiles.rs`).
    pub(super) grid: TileGrid,
    /// Every tile's rectangle, tile `k` at index `k`: the per-tile counts draw them one by one.
    tile_rects: Rects,
    /// Per tile, its occlusion query (made on first use; only with [`Counter::Query`]).
    tile_queries: Vec<OcclusionQuery>,
    /// The rectangles of the active tiles at the last termination query and at the one
    /// before it ([`Cover::Live`] names them; `trace.rs` swaps them).
    pub(super) live: [Rects; 2],
    /// The same rectangles on the host, and the whole image as one, for the observer.
    live_rects: [Vec<PixelRect>; 2],
    full_rect: [PixelRect; 1],
    /// What the last advancing pass covered, the pixels it drew and the active rays before
    /// it ([`Snapshot::advance`]).
    pub(super) last_advance: Option<(Cover, u64, u64)>,
    /// Depth or depth-stencil buffer shared by both ray-state targets (`--mask`).
    pub(super) mask_buffer: Option<Renderbuffer>,
    timers: Option<TimerPool>,
    /// Progress display (hidden unless asked for and stderr is a terminal).
    pub(super) progress: Progress,
    pub(super) stats: GpuStats,
    pub(super) opts: GpuOptions,
    /// The kernel the frame draws.
    pub(super) kernel: FragmentKernel,
    /// Traversal iterations after which a wave that has not finished is a bug.
    pub(super) max_iterations: u64,
    /// The render's observer, if any (the hook of an observed render).
    pub(super) watch: Option<Watch<'a>>,
    /// The last pass drawn, for the observer ([`Snapshot::pass`]).
    last_pass: &'static str,
    /// The primary-ray AOVs once read, shown to the observer and then returned.
    pub(super) aov: Option<Aov>,
    /// The primary rays' cone spread (textured scenes: [`Frame::set_root_cone`]).
    pub(super) root_spread: f32,
    /// The level whose records [`Frame::bind_records`] bound last: an instanced scene's
    /// ray-state passes that read them (the spawns) bind its instance record again after
    /// the state, which shares its unit.
    records_level: std::cell::Cell<Option<usize>>,
}

/// Timer queries in flight, resolved in batches so the pipeline is not stalled per pass.
struct TimerPool {
    free: Vec<TimerQuery>,
    pending: Vec<(&'static str, TimerQuery)>,
}

impl TimerPool {
    /// Adds the pending queries' times to `stats`.
    fn resolve(&mut self, ctx: &GlContext, stats: &mut GpuStats) -> Result<()> {
        for (name, q) in self.pending.drain(..) {
            stats.add_gpu_time(name, q.result_ns(ctx)?);
            self.free.push(q);
        }
        Ok(())
    }
}

/// Names a render target of a [`Frame`].
#[derive(Clone, Copy, Debug)]
pub(super) enum Slot {
    /// Ray-state set 0 or 1.
    State(usize),
    /// Records r0 and r1 of a level.
    Rec01(usize),
    /// Record r2 of a level.
    Rec2(usize),
    /// Colour accumulator 0 or 1.
    Acc(usize),
    /// The byte mask of [`Counter::Bytes`].
    Count,
}

/// What a draw covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Cover {
    /// The full-screen quad.
    Full,
    /// The rectangles of `Frame::live[k]`.
    Live(usize),
}

/// How the host counts the fragments that survive the `count` pass
/// ([`Dialect::counts_by_query`](crate::gpu::dialect::Dialect::counts_by_query)).
enum Counter {
    /// A `GL_SAMPLES_PASSED` occlusion query around the pass (colour writes off).
    Query(OcclusionQuery),
    /// WebGL 1: an RGBA8 target cleared to 1 into which the pass writes 0 where a fragment
    /// survives, read back and counted (exact, at one `readPixels` of a byte per channel).
    Bytes(RenderTarget),
}

/// The most bytes of ray textures one frame (or band) allocates: 8 GiB.
pub(crate) const RAY_TEXTURE_BUDGET: u64 = 8 << 30;

/// Environment variable that lowers [`RAY_TEXTURE_BUDGET`] (tests: a frame split into bands
/// at a size CI renders); other values are ignored.
pub const RAY_TEXTURE_BUDGET_ENV: &str = "FRAGTRACE_RAY_TEXTURE_BUDGET";

/// [`RAY_TEXTURE_BUDGET`], or [`RAY_TEXTURE_BUDGET_ENV`]'s bytes where lower.
pub(crate) fn ray_texture_budget() -> u64 {
    std::env::var(RAY_TEXTURE_BUDGET_ENV)
        .ok()
        .and_then(|v| v.parse::<u64>().ok())
        .map_or(RAY_TEXTURE_BUDGET, |b| b.min(RAY_TEXTURE_BUDGET))
}

/// Bytes of the ray textures a `width` x `height` frame of `levels` ray-tree levels
/// allocates: ray state (8 RGBA32F texels a pixel), records (3 per level, 4 with instances),
/// colour (2).
pub(crate) fn ray_texture_bytes(gs: &GpuScene, width: u32, height: u32, levels: usize) -> u64 {
    let per_level = if gs.instanced() { 4 } else { 3 };
    (width as u64 * height as u64) * 16 * (8 + per_level * levels as u64 + 2)
}

impl<'a> Frame<'a> {
    /// Takes the programs `gs` has for the passes a render with `kernel` draws (all
    /// shading passes when `shading`), compiled on first use, and allocates `width` x
    /// `height` targets for `levels` tree levels.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        gs: &'a GpuScene<'a>,
        width: u32,
        height: u32,
        levels: usize,
        shading: bool,
        kernel: FragmentKernel,
        opts: &GpuOptions,
        techniques: Techniques,
    ) -> Result<Self> {
        let ctx = gs.ctx();
        let mask = match (
            opts.mask.resolve(kernel),
            ctx.info.dialect.counts_by_query(),
        ) {
            (m, true) => m,
            // The masks are written by the counting pass into the ray-state targets' depth
            // buffer, and WebGL 1 counts into a byte target of its own instead.
            (_, false) if opts.mask == Mask::Auto => Mask::None,
            (m @ (Mask::EarlyZ | Mask::Stencil), false) => {
                return Err(Error::GlUnavailable(format!(
                    "--mask {m} needs occlusion queries, which {} lacks",
                    ctx.info.dialect.name()
                )))
            }
            (m, false) => m,
        };
        let opts = GpuOptions {
            mask,
            techniques,
            ..*opts
        };
        let info = &ctx.info;
        info.check_image_size(width, height)?;
        let textured = gs.textured();
        let units = if textured {
            TEXTURED_TEXTURE_UNITS
        } else {
            REQUIRED_TEXTURE_UNITS
        };
        if info.max_texture_units < units {
            return Err(Error::GlUnavailable(format!(
                "{} texture image units, fragtrace needs {units}{}",
                info.max_texture_units,
                if textured {
                    " for a textured scene"
                } else {
                    ""
                }
            )));
        }
        // Check memory before allocating (`tree::render` splits a frame past it into bands).
        let bytes = ray_texture_bytes(gs, width, height, levels);
        let budget = ray_texture_budget();
        if bytes > budget {
            let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
            return Err(Error::Limit(format!(
                "{width}x{height} with {levels} ray-tree levels needs {:.1} MiB of ray \
                 textures, more than one frame may take ({:.1} MiB); a narrower image or a \
                 lower --max-depth fits",
                mib(bytes),
                mib(budget)
            )));
        }
        // The scene's textures, then the programs: only the passes this scene and depth use.
        gs.textures()?;
        let size = glam::IVec2::new(width as i32, height as i32);
        let mut programs = HashMap::new();
        let passes = passes_for(gs.scene(), levels, shading, kernel);
        let built = gs.fragment_programs(&passes, techniques)?;
        for (pass, program) in passes.into_iter().zip(built) {
            if pass == Pass::RayGen {
                program.set(ctx.gl(), uniform::SIZE, size)?;
            }
            programs.insert(pass, program);
        }
        let costs = gs.take_costs();
        let mut stats = GpuStats {
            renderer: info.renderer.clone(),
            gl_version: info.gl_version.clone(),
            query_every: opts.query_every,
            scene_fetch: Fetch::Texture2D.name().into(),
            features: gs.features(),
            kernel: kernel.to_string(),
            upload_ms: costs.upload_ms,
            upload_bytes: costs.upload_bytes,
            ..GpuStats::default()
        };
        costs.charge_programs(&mut stats);

        let targets = |n: usize| RenderTarget::new(ctx, width, height, n);
        let state_formats = opts.storage.state_formats();
        let state_target = || {
            RenderTarget::with_formats(ctx, width, height, &state_formats).map_err(|e| match e {
                Error::GlUnavailable(m) if opts.storage == Storage::F16 => {
                    Error::GlUnavailable(format!(
                        "--storage f16 mixes RGBA16F and RGBA32F attachments in one \
                         framebuffer, which needs GL 3.0 or ARB_framebuffer_object: {m}"
                    ))
                }
                e => e,
            })
        };
        let colour = [opts.storage.colour_format()];
        let state = [state_target()?, state_target()?];
        let mask_buffer = match opts.mask {
            Mask::None | Mask::Auto => None,
            Mask::EarlyZ | Mask::Stencil => {
                let rb = Renderbuffer::new_mask(ctx, width, height, opts.mask == Mask::Stencil)?;
                for t in &state {
                    t.attach_mask_buffer(ctx.gl(), &rb)?;
                }
                Some(rb)
            }
        };
        Ok(Frame {
            gs,
            ctx,
            quad: FullscreenQuad::new(ctx)?,
            programs,
            state,
            cur: 0,
            // An instanced scene's record target also holds the hit's instance (ri).
            rec01: (0..levels)
                .map(|_| targets(if gs.instanced() { 3 } else { 2 }))
                .collect::<Result<_>>()?,
            // With textures, r2's target also holds the level's cone record r3, which the
            // weight pass writes beside the weight.
            rec2: (0..levels)
                .map(|_| targets(if textured { 2 } else { 1 }))
                .collect::<Result<_>>()?,
            acc: [
                RenderTarget::with_formats(ctx, width, height, &colour)?,
                RenderTarget::with_formats(ctx, width, height, &colour)?,
            ],
            acc_cur: 0,
            counter: if info.dialect.counts_by_query() {
                Counter::Query(OcclusionQuery::new(ctx)?)
            } else {
                Counter::Bytes(RenderTarget::with_formats(
                    ctx,
                    width,
                    height,
                    &[TexFormat::Rgba8],
                )?)
            },
            grid: TileGrid::new(width, height),
            tile_rects: {
                let mut r = Rects::new(ctx)?;
                let grid = TileGrid::new(width, height);
                r.upload(ctx.gl(), &grid.rects(), width, height);
                r
            },
            tile_queries: Vec::new(),
            live: [Rects::new(ctx)?, Rects::new(ctx)?],
            live_rects: [Vec::new(), Vec::new()],
            full_rect: [PixelRect {
                x0: 0,
                y0: 0,
                x1: width,
                y1: height,
            }],
            last_advance: None,
            mask_buffer,
            progress: Progress::hidden(),
            timers: (opts.timers && info.timer_query).then(|| TimerPool {
                free: Vec::new(),
                pending: Vec::new(),
            }),
            stats,
            opts,
            kernel,
            max_iterations: gs.ray_iterations(),
            watch: None,
            last_pass: "none",
            aov: None,
            root_spread: 0.0,
            records_level: Default::default(),
        })
    }

    /// The context's glow table.
    pub(super) fn gl(&self) -> &glow::Context {
        self.ctx.gl()
    }

    fn program(&self, pass: Pass) -> &Program {
        &self.programs[&pass]
    }

    /// Sets uniform `u` of `pass`'s program ([`Program::set`]).
    pub(super) fn set<T: GlslType>(&self, pass: Pass, u: Uniform<T>, value: T) -> Result<()> {
        self.program(pass).set(self.gl(), u, value)
    }

    /// The render target in `slot`.
    pub(super) fn target(&self, slot: Slot) -> &RenderTarget {
        match slot {
            Slot::State(k) => &self.state[k],
            Slot::Rec01(l) => &self.rec01[l],
            Slot::Rec2(l) => &self.rec2[l],
            Slot::Acc(k) => &self.acc[k],
            Slot::Count => match &self.counter {
                Counter::Bytes(t) => t,
                Counter::Query(_) => unreachable!("no count target beside an occlusion query"),
            },
        }
    }

    /// Texture of record r`k` (0..3) of `level`.
    pub(super) fn record_texture(&self, level: usize, k: usize) -> &Texture {
        match k {
            0 | 1 => self.rec01[level].texture(k),
            _ => self.rec2[level].texture(0),
        }
    }

    /// Binds level `level`'s records r0..r2 to their units (`u_r*` / `u_p*`), and with
    /// textures its cone record r3 to s2's unit, which no pass reading records reads
    /// (so this comes after the ray state is bound).
    pub(super) fn bind_records(&self, level: usize) {
        self.records_level.set(Some(level));
        for (k, unit) in Unit::RECORD.into_iter().enumerate() {
            bind_texture(self.gl(), unit, self.record_texture(level, k));
        }
        if let Some(cone) = self.rec2[level].textures().get(1) {
            bind_texture(self.gl(), Unit::S2, cone);
        }
        self.bind_instance_record(level);
    }

    /// An instanced scene's record of level `level`'s hit instances, on s2's unit (with
    /// textures, the level's cones beside them: the record pass copies them there, so the
    /// passes that shade read both from this one unit, a textured scene having none free).
    fn bind_instance_record(&self, level: usize) {
        if let Some(ri) = self.rec01[level].textures().get(2) {
            bind_texture(self.gl(), Unit::S2, ri);
        }
    }

    /// With textures, tells the passes that shade level `level` or spawn from it whether
    /// it is the root, whose cone (width 0, spread `spread`) has no record.
    pub(super) fn set_root_cone(&self, level: usize, spread: f32) -> Result<()> {
        if !self.gs.textured() {
            return Ok(());
        }
        let v = glam::Vec3::new(if level == 0 { 1.0 } else { 0.0 }, spread, 0.0);
        // An instanced scene's record pass copies the level's cone beside its instance.
        let record = self.gs.instanced().then_some(Pass::Record);
        for pass in [Pass::AccumAmbient, Pass::AccumLight, Pass::Weight]
            .into_iter()
            .chain(record)
        {
            if self.programs.contains_key(&pass) {
                self.set(pass, uniform::ROOT_CONE, v)?;
            }
        }
        Ok(())
    }

    /// Binds level `level`'s weight record r2 as the node being spawned or counted (`u_c2`).
    pub(super) fn bind_node(&self, level: usize) {
        bind_texture(self.gl(), Unit::Node, self.record_texture(level, 2));
    }

    /// Draws `pass` into the target in `slot`, timing it when timers are on.
    pub(super) fn draw(&mut self, pass: Pass, slot: Slot) -> Result<()> {
        self.draw_over(pass, slot, Cover::Full)
    }

    /// [`Frame::draw`] over `cover` only.
    pub(super) fn draw_over(&mut self, pass: Pass, slot: Slot, cover: Cover) -> Result<()> {
        self.target(slot).bind(self.gl());
        self.draw_bound(pass, cover)
    }

    /// Draws `pass` into `target`, a target of no slot (the 8-bit image read back),
    /// compiling the pass's program first if the frame has not got it.
    pub(super) fn draw_into(&mut self, pass: Pass, target: &RenderTarget) -> Result<()> {
        if !self.programs.contains_key(&pass) {
            let program = self.gs.fragment_program(pass, self.opts.techniques)?;
            self.gs.take_costs().charge_programs(&mut self.stats);
            self.programs.insert(pass, program);
        }
        target.bind(self.gl());
        self.draw_bound(pass, Cover::Full)
    }

    /// Draws `pass` over `cover` into the bound target, timing it when timers are on.
    fn draw_bound(&mut self, pass: Pass, cover: Cover) -> Result<()> {
        // Re-bound every pass: creating or reading textures elsewhere changes the binding
        // of whatever unit is active, and five binds cost nothing next to a pass.
        self.gs.bind_textures()?;
        let timer = self.begin_timer()?;
        match cover {
            Cover::Full => self.quad.draw(self.gl(), self.program(pass)),
            Cover::Live(k) => {
                let rects = &self.live[k];
                rects.draw(self.gl(), self.program(pass), 0..rects.len());
            }
        }
        self.end_timer(pass, timer)
    }

    /// Starts a timer query for the draws of one pass, when timers are on.
    fn begin_timer(&mut self) -> Result<Option<TimerQuery>> {
        let timer = match &mut self.timers {
            Some(pool) => Some(match pool.free.pop() {
                Some(q) => q,
                None => TimerQuery::new(self.ctx)?,
            }),
            None => None,
        };
        if let Some(t) = &timer {
            t.begin(self.ctx);
        }
        Ok(timer)
    }

    /// Ends `pass`'s timer and counts the pass.
    fn end_timer(&mut self, pass: Pass, timer: Option<TimerQuery>) -> Result<()> {
        if let Some(t) = timer {
            t.end(self.ctx);
            let pool = self.timers.as_mut().expect("timer pool");
            pool.pending.push((pass.name(), t));
            if pool.pending.len() >= 256 {
                pool.resolve(self.ctx, &mut self.stats)?;
            }
        }
        *self
            .stats
            .passes
            .entry(pass.name().to_string())
            .or_default() += 1;
        self.stats.passes_total += 1;
        self.last_pass = pass.name();
        Ok(())
    }

    /// Binds the current ray-state set as input.
    pub(super) fn bind_state_input(&self) {
        for (unit, t) in Unit::STATE.into_iter().zip(self.state[self.cur].textures()) {
            bind_texture(self.gl(), unit, t);
        }
    }

    /// Runs a ray-state pass: reads the current set, writes the other, swaps; then
    /// observes (and may pause there).
    pub(super) async fn state_pass(&mut self, pass: Pass) -> Result<()> {
        self.state_pass_over(pass, Cover::Full).await
    }

    /// [`Frame::state_pass`] over `cover` only: outside it the set written keeps what it
    /// held, which must be the current state there (`trace.rs` sees to it).
    pub(super) async fn state_pass_over(&mut self, pass: Pass, cover: Cover) -> Result<()> {
        self.bind_state_input();
        if let (Pass::Spawn | Pass::ShadowSpawn, Some(level)) = (pass, self.records_level.get()) {
            self.bind_instance_record(level);
        }
        let other = 1 - self.cur;
        self.draw_over(pass, Slot::State(other), cover)?;
        self.cur = other;
        self.observe().await
    }

    /// Counts fragments that survive the `count` pass (active rays, or pixels where the
    /// node whose weight record is level `node`'s r2 exists), drawn with colour writes off
    /// into `slot`.
    pub(super) fn count_into(
        &mut self,
        what: Count,
        node: Option<usize>,
        slot: Slot,
    ) -> Result<u64> {
        let pass = Pass::Count(what);
        self.bind_state_input();
        if let Some(level) = node {
            self.bind_node(level);
        }
        self.stats.termination_queries += (what == Count::Rays) as u64;
        if let Counter::Bytes(target) = &self.counter {
            target.bind(self.gl());
            state::clear_colour(self.gl(), [1.0; 4]);
            self.draw(pass, Slot::Count)?;
            let Counter::Bytes(target) = &self.counter else {
                unreachable!()
            };
            let bytes = target.read_bytes(self.gl())?;
            // count.frag writes 0 where it does not discard.
            return Ok(bytes.chunks_exact(4).filter(|px| px[0] == 0).count() as u64);
        }
        let Counter::Query(query) = &self.counter else {
            unreachable!()
        };
        state::colour_writes(self.gl(), false);
        query.begin(self.ctx);
        let r = self.draw(pass, slot);
        let Counter::Query(query) = &self.counter else {
            unreachable!()
        };
        query.end(self.ctx);
        state::colour_writes(self.gl(), true);
        r?;
        Ok(query.result(self.ctx)? as u64)
    }

    /// Counts active rays per tile of [`Frame::grid`] (the `count` pass drawn tile by tile
    /// under one occlusion query each, colour writes off, into `slot`; WebGL 1: into the
    /// byte target, read back once and tallied per tile). Only the tiles where `region` is
    /// set are drawn (the others count 0): outside them no ray is active.
    pub(super) fn count_tiles(&mut self, region: &[bool], slot: Slot) -> Result<Vec<u64>> {
        let pass = Pass::Count(Count::Rays);
        self.bind_state_input();
        self.stats.termination_queries += 1;
        if let Counter::Bytes(target) = &self.counter {
            target.bind(self.gl());
            // Cleared to "no ray" (1): the tiles not drawn count none.
            state::clear_colour(self.gl(), [1.0; 4]);
            self.gs.bind_textures()?;
            let timer = self.begin_timer()?;
            {
                // Runs of consecutive tiles, one draw each (`tile_rects` holds tile k at k).
                let bound = self.tile_rects.bind(self.ctx.gl(), &self.programs[&pass]);
                let mut k = 0;
                while k < region.len() {
                    let end = (k..region.len())
                        .find(|&e| !region[e])
                        .unwrap_or(region.len());
                    bound.draw(k..end);
                    k = end + 1;
                }
            }
            self.end_timer(pass, timer)?;
            let Counter::Bytes(target) = &self.counter else {
                unreachable!()
            };
            let bytes = target.read_bytes(self.gl())?;
            return Ok(self.grid.tally_bytes(&bytes));
        }
        while self.tile_queries.len() < self.grid.len() {
            self.tile_queries.push(OcclusionQuery::new(self.ctx)?);
        }
        self.target(slot).bind(self.gl());
        self.gs.bind_textures()?;
        state::colour_writes(self.gl(), false);
        let timer = self.begin_timer()?;
        let tiles: Vec<usize> = (0..self.grid.len()).filter(|&k| region[k]).collect();
        {
            let bound = self.tile_rects.bind(self.ctx.gl(), &self.programs[&pass]);
            for &k in &tiles {
                self.tile_queries[k].begin(self.ctx);
                bound.draw(k..k + 1);
                self.tile_queries[k].end(self.ctx);
            }
        }
        let r = self.end_timer(pass, timer);
        state::colour_writes(self.gl(), true);
        r?;
        let mut counts = vec![0u64; self.grid.len()];
        for k in tiles {
            counts[k] = self.tile_queries[k].result(self.ctx)? as u64;
        }
        Ok(counts)
    }

    /// Uploads `rects` into `live[k]`.
    pub(super) fn set_live(&mut self, k: usize, rects: &[PixelRect]) {
        let (w, h) = self.grid.size();
        self.live[k].upload(self.ctx.gl(), rects, w, h);
        self.live_rects[k] = rects.to_vec();
    }

    /// [`Frame::count_into`] the colour accumulator that is not being read.
    pub(super) fn count(&mut self, what: Count, node: Option<usize>) -> Result<u64> {
        self.count_into(what, node, Slot::Acc(1 - self.acc_cur))
    }

    /// Accumulation pass: reads level `level` records and the colour so far.
    pub(super) async fn accumulate(&mut self, pass: Pass, level: usize) -> Result<()> {
        self.bind_state_input();
        self.bind_records(level);
        bind_texture(self.gl(), Unit::Acc, self.acc[self.acc_cur].texture(0));
        let other = 1 - self.acc_cur;
        self.draw(pass, Slot::Acc(other))?;
        self.acc_cur = other;
        self.observe().await
    }

    /// Stores the finished wave in level `level`'s records (a textured instanced scene's
    /// with the level's cone beside the instance: its cone record, on s2's unit, which the
    /// record pass does not read as state, or the root's).
    pub(super) fn record(&mut self, level: usize) -> Result<()> {
        self.bind_state_input();
        if self.gs.instanced() && self.gs.textured() {
            self.set_root_cone(level, self.root_spread)?;
            if let Some(cone) = self.rec2[level].textures().get(1) {
                bind_texture(self.gl(), Unit::S2, cone);
            }
        }
        self.draw(Pass::Record, Slot::Rec01(level))
    }

    /// Resolves pending timers into the statistics.
    pub(super) fn finish_timers(&mut self) -> Result<()> {
        if let Some(pool) = &mut self.timers {
            pool.resolve(self.ctx, &mut self.stats)?;
        }
        Ok(())
    }
}

/// A render's observer and what it is told besides the frame (see [`Frame::observe`]).
pub(super) struct Watch<'a> {
    pub(super) observer: &'a mut Observer<'a>,
    pub(super) samples_done: u32,
    pub(super) samples: u32,
}

impl Frame<'_> {
    /// The one hook of an observed render, called after every ray-state and accumulation
    /// pass and after each finished sample: shows the observer a [`Snapshot`] and turns
    /// its [`Flow::Cancel`] into [`Error::Cancelled`], which unwinds the walk (every GL
    /// object of the frame frees itself), and its [`Flow::Pause`] into a suspension of the
    /// walk's future ([`crate::gpu::pause`]).
    pub(super) async fn observe(&mut self) -> Result<()> {
        let Some(w) = self.watch.as_mut() else {
            return Ok(());
        };
        let snap = Snapshot {
            radiance: self.acc[self.acc_cur].texture(0),
            state: self.state[self.cur].textures(),
            samples_done: w.samples_done,
            samples: w.samples,
            passes: self.stats.passes_total,
            pass: self.last_pass,
            aov: self.aov.as_ref(),
            advance: self.last_advance.map(|(cover, pixels, active)| Advance {
                rects: match cover {
                    Cover::Full => &self.full_rect[..],
                    Cover::Live(k) => &self.live_rects[k][..],
                },
                pixels,
                active,
            }),
        };
        match (w.observer)(&snap) {
            Flow::Continue => Ok(()),
            Flow::Cancel => Err(Error::Cancelled),
            Flow::Pause => {
                pause().await;
                Ok(())
            }
        }
    }
}
