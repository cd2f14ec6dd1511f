//! The multi-pass GPU renderer: the host side of the thesis's stream design.
//!
//! Every pass is one fragment program drawn over the full-screen quad into RGBA32F
//! textures. The ray state lives in four textures ping-ponged between two framebuffers
//! (a pass never reads what it writes); every pass copies rays that are not in its state
//! through unchanged, so either set always holds the whole current state.
//!
//! One ray wave is traced by `traverse_init`, then alternating `traverse_step` and
//! `intersect` passes, each advancing every active ray by one cell or one triangle test,
//! until an occlusion query over the `count` pass (run every K iterations) finds no active
//! ray. The Whitted ray tree is walked depth-first in the same order for every pixel:
//! each level keeps a hit record (origin + triangle, direction + t, path weight); a
//! node's children are skipped when an occlusion query finds no pixel where they exist.

use std::collections::HashMap;
use std::time::Instant;

use glow::HasContext;

use super::context::GlContext;
use super::gl_util::{
    compile_program, create_float_texture, create_mask_buffer, FullscreenQuad, OcclusionQuery,
    RenderTarget, TexFormat, TimerQuery, QUAD_VERTEX_SHADER,
};
use super::shader::{assemble, Count, Features, Kernel, Pass, Query, RayState};
use crate::accel::layout::SceneTextures;
use crate::accel::Grid;
use crate::image_io::Image;
use crate::output::{Aov, AovPixel, GpuStats, RayCounts};
use crate::progress::Progress;
use crate::scene::{camera, Scene};
use crate::{Error, Result};

/// Options of the GPU backend.
#[derive(Clone, Copy, Debug)]
pub struct GpuOptions {
    /// Traversal iterations between two termination queries (K).
    pub query_every: u32,
    /// Measure per-pass GPU time with timer queries where the driver has them.
    pub timers: bool,
    /// Compile every shading feature in, whatever the scene needs.
    pub no_specialize: bool,
    /// How traversal iterations map onto passes. Default: `Looped`, which renders the same
    /// image as the thesis's `Multipass` kernel from the same step chunk, 25-107x faster
    /// (docs/performance.md); `Multipass` is the faithful GL 2.1 design.
    pub kernel: Kernel,
    /// How rays that finished are kept out of the traversal passes.
    pub mask: Mask,
    /// Precision of the ray textures.
    pub storage: Storage,
    /// Robustness techniques compiled into the programs. `render_gl` takes them from
    /// `RenderOptions::techniques` instead; `trace_rays` uses these.
    pub techniques: crate::technique::Techniques,
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions {
            query_every: 8,
            timers: true,
            no_specialize: false,
            kernel: Kernel::Looped,
            mask: Mask::None,
            storage: Storage::F32,
            techniques: crate::technique::Techniques::default(),
        }
    }
}

/// How finished rays are skipped during traversal.
///
/// Every pass early-outs on rays not in its state whatever the mask; a mask additionally
/// keeps the fragment program from running at all for rays that were inactive at the last
/// termination query, as Purcell et al. did with the depth test. The termination query's
/// count pass writes the mask as a side effect (only active rays survive its `discard`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mask {
    /// Run every pass on every pixel and rely on the in-shader early-out.
    #[default]
    None,
    /// Active rays get depth 0, the rest 1; passes are drawn at depth 0.5 with
    /// `GL_GREATER`, so the early depth test culls finished rays before shading.
    EarlyZ,
    /// Active rays get stencil 1; passes are drawn with `GL_EQUAL 1`.
    Stencil,
}

impl std::str::FromStr for Mask {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "none" => Ok(Mask::None),
            "early-z" => Ok(Mask::EarlyZ),
            "stencil" => Ok(Mask::Stencil),
            _ => Err(format!(
                "unknown mask `{s}` (expected none, early-z or stencil)"
            )),
        }
    }
}

impl std::fmt::Display for Mask {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Mask::None => "none",
            Mask::EarlyZ => "early-z",
            Mask::Stencil => "stencil",
        })
    }
}

/// Precision of the textures that carry rays between passes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Storage {
    /// Everything in RGBA32F.
    #[default]
    F32,
    /// Ray direction (with t_max, texture s1) and the colour accumulator in RGBA16F, as
    /// 16-bit-float hardware stored streams. A unit direction keeps 11 significant bits
    /// (about 5e-4 rad), below a pixel's angle at 512 pixels across. Indices stay exact because
    /// nothing that holds one is stored in 16 bits: the state code, cell, cursor, list end,
    /// best triangle and hit t (s0, s2, s3) and the hit records stay RGBA32F. Origins stay
    /// 32-bit too: rounded to 11 bits, a spawned ray's origin moves by up to 2^-12 of its
    /// coordinate, far more than the offset that keeps it off its surface, and shadow acne
    /// darkened most of the image when we tried it (docs/performance.md). Needs
    /// mixed-format framebuffers (GL 3.0 or ARB_framebuffer_object); refused with a clear
    /// error elsewhere.
    F16,
}

impl std::str::FromStr for Storage {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "f32" => Ok(Storage::F32),
            "f16" => Ok(Storage::F16),
            _ => Err(format!("unknown storage `{s}` (expected f32 or f16)")),
        }
    }
}

impl std::fmt::Display for Storage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Storage::F32 => "f32",
            Storage::F16 => "f16",
        })
    }
}

impl Storage {
    /// Formats of the four ray-state attachments s0..s3.
    fn state_formats(self) -> [TexFormat; 4] {
        match self {
            Storage::F32 => [TexFormat::Rgba32F; 4],
            Storage::F16 => [
                TexFormat::Rgba32F,
                TexFormat::Rgba16F,
                TexFormat::Rgba32F,
                TexFormat::Rgba32F,
            ],
        }
    }

    /// Format of the colour accumulator.
    fn colour_format(self) -> TexFormat {
        match self {
            Storage::F32 => TexFormat::Rgba32F,
            Storage::F16 => TexFormat::Rgba16F,
        }
    }
}

/// Texture units, fixed per sampler name so bindings can be set once per program.
const UNITS: &[(&str, u32)] = &[
    ("u_tri", 0),
    ("u_mat", 1),
    ("u_cell", 2),
    ("u_list", 3),
    ("u_nrm", 4),
    ("u_s0", 5),
    ("u_s1", 6),
    ("u_s2", 7),
    ("u_s3", 8),
    ("u_p0", 9),
    ("u_r0", 9),
    ("u_p1", 10),
    ("u_r1", 10),
    ("u_p2", 11),
    ("u_r2", 11),
    ("u_c2", 12),
    ("u_acc", 13),
];
/// Texture units a render needs.
pub const REQUIRED_TEXTURE_UNITS: i32 = 14;

/// Output of a GPU render.
pub struct GpuOutput {
    /// Linear RGB image.
    pub image: Image,
    /// Primary-ray AOVs (first sample).
    pub aov: Aov,
    /// Rays by kind (from occlusion queries).
    pub rays: RayCounts,
    /// GPU statistics.
    pub stats: GpuStats,
}

/// A render in progress: programs, textures and targets.
struct Frame<'a> {
    ctx: &'a GlContext,
    quad: FullscreenQuad,
    programs: HashMap<Pass, glow::Program>,
    /// Scene textures and their units.
    scene_tex: Vec<(u32, glow::Texture)>,
    /// Ray state, two sets of four attachments.
    state: [RenderTarget; 2],
    cur: usize,
    /// Per level: (origin, tri) + (direction, t) records.
    rec01: Vec<RenderTarget>,
    /// Per level: (weight, exists).
    rec2: Vec<RenderTarget>,
    acc: [RenderTarget; 2],
    acc_cur: usize,
    count_query: OcclusionQuery,
    /// Depth or depth-stencil buffer shared by both ray-state targets (`--mask`).
    mask_buffer: Option<glow::Renderbuffer>,
    timers: Option<TimerPool>,
    /// Progress display (hidden unless asked for and stderr is a terminal).
    progress: Progress,
    stats: GpuStats,
    opts: GpuOptions,
    max_iterations: u64,
}

/// Timer queries in flight, resolved in batches so the pipeline is not stalled per pass.
struct TimerPool {
    free: Vec<TimerQuery>,
    pending: Vec<(&'static str, TimerQuery)>,
    ms: HashMap<String, f64>,
}

impl TimerPool {
    fn resolve(&mut self, ctx: &GlContext) -> Result<()> {
        for (name, q) in self.pending.drain(..) {
            let ns = q.result_ns(ctx)?;
            *self.ms.entry(name.to_string()).or_default() += ns as f64 * 1e-6;
            self.free.push(q);
        }
        Ok(())
    }
}

fn bind_texture(gl: &glow::Context, unit: u32, tex: glow::Texture) {
    // SAFETY: the context is current; `tex` is a live texture of this context.
    unsafe {
        gl.active_texture(glow::TEXTURE0 + unit);
        gl.bind_texture(glow::TEXTURE_2D, Some(tex));
    }
}

fn unit_of(name: &str) -> u32 {
    UNITS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, u)| *u)
        .expect("known sampler")
}

impl<'a> Frame<'a> {
    fn gl(&self) -> &glow::Context {
        &self.ctx.gl
    }

    fn program(&self, pass: Pass) -> glow::Program {
        self.programs[&pass]
    }

    fn set_vec3(&self, pass: Pass, name: &str, v: [f32; 3]) {
        let gl = self.gl();
        let p = self.program(pass);
        // SAFETY: the context is current and `p` is a linked program of it.
        unsafe {
            gl.use_program(Some(p));
            let loc = gl.get_uniform_location(p, name);
            gl.uniform_3_f32(loc.as_ref(), v[0], v[1], v[2]);
        }
    }

    fn set_vec2(&self, pass: Pass, name: &str, v: [f32; 2]) {
        let gl = self.gl();
        let p = self.program(pass);
        // SAFETY: as in `set_vec3`.
        unsafe {
            gl.use_program(Some(p));
            let loc = gl.get_uniform_location(p, name);
            gl.uniform_2_f32(loc.as_ref(), v[0], v[1]);
        }
    }

    fn set_float(&self, pass: Pass, name: &str, v: f32) {
        let gl = self.gl();
        let p = self.program(pass);
        // SAFETY: as in `set_vec3`.
        unsafe {
            gl.use_program(Some(p));
            let loc = gl.get_uniform_location(p, name);
            gl.uniform_1_f32(loc.as_ref(), v);
        }
    }

    fn target(&self, slot: Slot) -> &RenderTarget {
        match slot {
            Slot::State(k) => &self.state[k],
            Slot::Rec01(l) => &self.rec01[l],
            Slot::Rec2(l) => &self.rec2[l],
            Slot::Acc(k) => &self.acc[k],
        }
    }

    /// Draws `pass` into the target in `slot`, timing it when timers are on.
    fn draw(&mut self, pass: Pass, slot: Slot) -> Result<()> {
        // Re-bound every pass: creating or reading textures elsewhere changes the binding
        // of whatever unit is active, and five binds cost nothing next to a pass.
        for &(unit, tex) in &self.scene_tex {
            bind_texture(self.gl(), unit, tex);
        }
        self.target(slot).bind(self.gl());
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
        self.quad.draw(self.gl(), self.program(pass));
        if let Some(t) = timer {
            t.end(self.ctx);
            let pool = self.timers.as_mut().expect("timer pool");
            pool.pending.push((pass.name(), t));
            if pool.pending.len() >= 256 {
                pool.resolve(self.ctx)?;
            }
        }
        *self
            .stats
            .passes
            .entry(pass.name().to_string())
            .or_default() += 1;
        self.stats.passes_total += 1;
        Ok(())
    }

    /// Binds the current ray-state set as input.
    fn bind_state_input(&self) {
        for (k, t) in self.state[self.cur].textures().iter().enumerate() {
            bind_texture(self.gl(), 5 + k as u32, *t);
        }
    }

    /// Runs a ray-state pass: reads the current set, writes the other, swaps.
    fn state_pass(&mut self, pass: Pass) -> Result<()> {
        self.bind_state_input();
        let other = 1 - self.cur;
        self.draw(pass, Slot::State(other))?;
        self.cur = other;
        Ok(())
    }

    /// Counts fragments that survive the `count` pass: active rays or existing nodes.
    fn count(&mut self, what: Count, node: Option<glow::Texture>) -> Result<u64> {
        self.count_into(what, node, Slot::Acc(1 - self.acc_cur))
    }

    /// Counts active rays and, with `--mask`, writes the mask of them: the count pass is
    /// drawn (colour writes off) into the ray-state target that is not being read, whose
    /// depth/stencil buffer both state targets share.
    fn count_and_mask(&mut self) -> Result<u64> {
        let Some(_) = self.mask_buffer else {
            return self.count(Count::Rays, None);
        };
        let slot = Slot::State(1 - self.cur);
        self.target(slot).bind(self.gl());
        let gl = &self.ctx.gl;
        // SAFETY: the context is current; the bound FBO has the mask buffer attached.
        unsafe {
            match self.opts.mask {
                Mask::EarlyZ => {
                    gl.depth_mask(true);
                    gl.clear_depth_f64(1.0);
                    gl.clear(glow::DEPTH_BUFFER_BIT);
                    gl.enable(glow::DEPTH_TEST);
                    gl.depth_func(glow::ALWAYS);
                    // The quad lies at window depth 0.5; a [0, 0] range stores 0 instead.
                    gl.depth_range_f64(0.0, 0.0);
                }
                Mask::Stencil => {
                    gl.stencil_mask(0xff);
                    gl.clear_stencil(0);
                    gl.clear(glow::STENCIL_BUFFER_BIT);
                    gl.enable(glow::STENCIL_TEST);
                    gl.stencil_func(glow::ALWAYS, 1, 0xff);
                    gl.stencil_op(glow::KEEP, glow::KEEP, glow::REPLACE);
                }
                Mask::None => unreachable!("no mask buffer without a mask"),
            }
        }
        let n = self.count_into(Count::Rays, None, slot);
        // SAFETY: as above.
        unsafe {
            gl.depth_range_f64(0.0, 1.0);
            gl.depth_mask(false);
            gl.stencil_mask(0);
            gl.disable(glow::DEPTH_TEST);
            gl.disable(glow::STENCIL_TEST);
        }
        n
    }

    /// Turns the mask test on or off for the draws that follow.
    fn set_mask_test(&self, on: bool) {
        let gl = self.gl();
        // SAFETY: the context is current.
        unsafe {
            match (self.opts.mask, on) {
                (Mask::EarlyZ, true) => {
                    gl.enable(glow::DEPTH_TEST);
                    gl.depth_func(glow::GREATER);
                    gl.depth_mask(false);
                }
                (Mask::Stencil, true) => {
                    gl.enable(glow::STENCIL_TEST);
                    gl.stencil_func(glow::EQUAL, 1, 0xff);
                    gl.stencil_op(glow::KEEP, glow::KEEP, glow::KEEP);
                    gl.stencil_mask(0);
                }
                _ => {
                    gl.disable(glow::DEPTH_TEST);
                    gl.disable(glow::STENCIL_TEST);
                }
            }
        }
    }

    fn count_into(&mut self, what: Count, node: Option<glow::Texture>, slot: Slot) -> Result<u64> {
        let pass = Pass::Count(what);
        self.bind_state_input();
        if let Some(t) = node {
            bind_texture(self.gl(), unit_of("u_c2"), t);
        }
        let gl = &self.ctx.gl;
        // SAFETY: the context is current.
        unsafe { gl.color_mask(false, false, false, false) };
        self.count_query.begin(self.ctx);
        let r = self.draw(pass, slot);
        self.count_query.end(self.ctx);
        // SAFETY: as above.
        unsafe { self.ctx.gl.color_mask(true, true, true, true) };
        r?;
        self.stats.termination_queries += (what == Count::Rays) as u64;
        Ok(self.count_query.result(self.ctx)? as u64)
    }

    /// Traces the current ray wave to completion.
    ///
    /// With a mask, a masked pass leaves finished rays unwritten in its target, so the
    /// ping-pong pair may disagree on them. The first pass after each mask refresh therefore
    /// runs unmasked: its write-through copies every finished ray into the other target, and
    /// from then on both hold the same state for every ray outside the mask.
    fn trace(&mut self, query: Query) -> Result<()> {
        let r = self.trace_inner(query);
        self.set_mask_test(false);
        r
    }

    fn trace_inner(&mut self, query: Query) -> Result<()> {
        self.state_pass(Pass::TraverseInit)?;
        let mut synced = false;
        if let Some(pass) = Pass::advance(self.opts.kernel, query) {
            // Several iterations per pass: query every `query_every` iterations' worth.
            let per_pass = match self.opts.kernel {
                Kernel::Unrolled(k) => k as u64,
                Kernel::Looped => super::shader::LOOP_MAX as u64,
                Kernel::Multipass => 1,
            };
            let every = (self.opts.query_every as u64 / per_pass).max(1);
            let mut passes = 0u64;
            loop {
                if passes.is_multiple_of(every) {
                    self.set_mask_test(false);
                    self.progress.passes(self.stats.passes_total);
                    let n = self.count_and_mask()?;
                    self.progress.active(n);
                    if n == 0 {
                        return Ok(());
                    }
                    synced = false;
                }
                self.set_mask_test(synced);
                self.state_pass(pass)?;
                synced = true;
                passes += 1;
                if passes * per_pass > self.max_iterations {
                    return Err(Error::Internal(format!(
                        "traversal did not terminate after {} iterations",
                        passes * per_pass
                    )));
                }
            }
        }
        let k = self.opts.query_every.max(1) as u64;
        let mut it = 0u64;
        loop {
            if it.is_multiple_of(k) {
                self.set_mask_test(false);
                self.progress.passes(self.stats.passes_total);
                let n = self.count_and_mask()?;
                self.progress.active(n);
                if n == 0 {
                    return Ok(());
                }
                synced = false;
            }
            self.set_mask_test(synced);
            self.state_pass(Pass::TraverseStep)?;
            synced = true;
            self.set_mask_test(true);
            self.state_pass(Pass::Intersect(query))?;
            it += 1;
            if it > self.max_iterations {
                return Err(Error::Internal(format!(
                    "traversal did not terminate after {it} iterations"
                )));
            }
        }
    }

    /// Accumulation pass: reads level `level` records and the colour so far.
    fn accumulate(&mut self, pass: Pass, level: usize) -> Result<()> {
        self.bind_state_input();
        let (r0, r1, r2) = (
            self.rec01[level].texture(0),
            self.rec01[level].texture(1),
            self.rec2[level].texture(0),
        );
        bind_texture(self.gl(), unit_of("u_r0"), r0);
        bind_texture(self.gl(), unit_of("u_r1"), r1);
        bind_texture(self.gl(), unit_of("u_r2"), r2);
        bind_texture(
            self.gl(),
            unit_of("u_acc"),
            self.acc[self.acc_cur].texture(0),
        );
        let other = 1 - self.acc_cur;
        self.draw(pass, Slot::Acc(other))?;
        self.acc_cur = other;
        Ok(())
    }

    /// Stores the finished wave in level `level`'s records.
    fn record(&mut self, level: usize) -> Result<()> {
        self.bind_state_input();
        self.draw(Pass::Record, Slot::Rec01(level))
    }
}

/// Names a render target of a [`Frame`].
#[derive(Clone, Copy, Debug)]
enum Slot {
    State(usize),
    Rec01(usize),
    Rec2(usize),
    Acc(usize),
}

impl<'a> Frame<'a> {
    /// Uploads the scene, compiles the programs `scene` needs (all shading passes when
    /// `shading`), and allocates `width` x `height` targets for `levels` tree levels.
    #[allow(clippy::too_many_arguments)]
    fn new(
        ctx: &'a GlContext,
        scene: &Scene,
        grid: &Grid,
        width: u32,
        height: u32,
        levels: usize,
        shading: bool,
        opts: GpuOptions,
    ) -> Result<Self> {
        let gl = &ctx.gl;
        let info = &ctx.info;
        let max_size = info.max_texture_size.max(0) as u32;
        info.check_image_size(width, height)?;
        if info.max_texture_units < REQUIRED_TEXTURE_UNITS {
            return Err(Error::GlUnavailable(format!(
                "{} texture image units, fragtrace needs {REQUIRED_TEXTURE_UNITS}",
                info.max_texture_units
            )));
        }
        // Check memory before allocating: ray state (8), records (3 per level), colour (2).
        let bytes = (width as u64 * height as u64) * 16 * (8 + 3 * levels as u64 + 2);
        if bytes > 8 << 30 {
            return Err(Error::Limit(format!(
                "{width}x{height} with {levels} ray-tree levels needs {:.1} GiB of ray textures",
                bytes as f64 / (1u64 << 30) as f64
            )));
        }
        let mut stats = GpuStats {
            renderer: info.renderer.clone(),
            gl_version: info.gl_version.clone(),
            query_every: opts.query_every,
            ..GpuStats::default()
        };

        let features = if opts.no_specialize {
            Features::all()
        } else {
            Features::of(scene)
        };
        let t_up = Instant::now();
        let layout = SceneTextures::pack_with(scene, grid, max_size, features.smooth_normals)?;
        let mut scene_tex = Vec::new();
        for t in layout.all() {
            let tex = create_float_texture(gl, t.width, t.height, Some(&t.data))?;
            scene_tex.push((unit_of(&format!("u_{}", t.name)), tex));
        }
        // SAFETY: the context is current.
        unsafe { gl.finish() };
        stats.upload_ms = t_up.elapsed().as_secs_f64() * 1e3;
        stats.upload_bytes = layout.bytes();

        // Programs: only the passes this scene and depth use.
        stats.features = format!("{features:?}");
        let secondary = levels > 1 && scene.materials.iter().any(|m| m.reflects() || m.refracts());
        let lights = !scene.lights.is_empty();
        let passes: Vec<Pass> = Pass::ALL
            .into_iter()
            .filter(|p| match p {
                Pass::Intersect(Query::Any) => {
                    (lights || !shading) && opts.kernel == Kernel::Multipass
                }
                Pass::ShadowSpawn | Pass::AccumLight => shading && lights,
                Pass::Weight | Pass::Spawn | Pass::Count(Count::Nodes) => shading && secondary,
                Pass::RayGen | Pass::Record | Pass::AccumAmbient => shading,
                Pass::TraverseInit | Pass::Count(Count::Rays) => true,
                Pass::TraverseStep | Pass::Intersect(Query::Closest) => {
                    opts.kernel == Kernel::Multipass
                }
                // Not in Pass::ALL: the chosen kernel's pass is added below.
                Pass::Unrolled(..) | Pass::Looped(_) => false,
            })
            .chain(
                [Query::Closest, Query::Any]
                    .into_iter()
                    .filter(|q| *q == Query::Closest || lights || !shading)
                    .filter_map(|q| Pass::advance(opts.kernel, q)),
            )
            .collect();
        let t_c = Instant::now();
        let mut programs = HashMap::new();
        for pass in passes {
            let a = assemble(pass, features, opts.techniques, &layout)?;
            let p = compile_program(gl, pass.name(), QUAD_VERTEX_SHADER, &a.source, &|n| {
                a.origin(n)
            })?;
            // SAFETY: the context is current and `p` is linked.
            unsafe {
                gl.use_program(Some(p));
                for (name, unit) in UNITS {
                    if let Some(loc) = gl.get_uniform_location(p, name) {
                        gl.uniform_1_i32(Some(&loc), *unit as i32);
                    }
                }
                let set3 = |name: &str, v: glam::Vec3| {
                    if let Some(loc) = gl.get_uniform_location(p, name) {
                        gl.uniform_3_f32(Some(&loc), v.x, v.y, v.z);
                    }
                };
                set3("u_grid_min", grid.min);
                set3("u_grid_max", grid.max);
                set3("u_cell_size", grid.cell_size);
                set3("u_grid_res", glam::UVec3::from(grid.res).as_vec3());
                set3("u_ambient", scene.ambient);
                set3("u_background", scene.background);
                if let Some(loc) = gl.get_uniform_location(p, "u_size") {
                    gl.uniform_2_f32(Some(&loc), width as f32, height as f32);
                }
            }
            programs.insert(pass, p);
        }
        stats.compile_ms = t_c.elapsed().as_secs_f64() * 1e3;

        let targets = |n: usize| RenderTarget::new(gl, width, height, n);
        let state_formats = opts.storage.state_formats();
        let state_target = || {
            RenderTarget::with_formats(gl, width, height, &state_formats).map_err(|e| match e {
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
            Mask::None => None,
            Mask::EarlyZ | Mask::Stencil => {
                let stencil = opts.mask == Mask::Stencil;
                let rb = create_mask_buffer(gl, width, height, stencil)?;
                for t in &state {
                    t.attach_mask_buffer(gl, rb, stencil)?;
                }
                Some(rb)
            }
        };
        Ok(Frame {
            ctx,
            quad: FullscreenQuad::new(gl)?,
            programs,
            scene_tex,
            state,
            cur: 0,
            rec01: (0..levels).map(|_| targets(2)).collect::<Result<_>>()?,
            rec2: (0..levels).map(|_| targets(1)).collect::<Result<_>>()?,
            acc: [
                RenderTarget::with_formats(gl, width, height, &colour)?,
                RenderTarget::with_formats(gl, width, height, &colour)?,
            ],
            acc_cur: 0,
            count_query: OcclusionQuery::new(ctx)?,
            mask_buffer,
            progress: Progress::hidden(),
            timers: if opts.timers && info.timer_query {
                Some(TimerPool {
                    free: Vec::new(),
                    pending: Vec::new(),
                    ms: HashMap::new(),
                })
            } else {
                None
            },
            stats,
            opts,
            // A DDA visits at most rx+ry+rz cells; each test is one iteration; be generous.
            max_iterations: 16
                * (grid.res.iter().map(|&r| r as u64).sum::<u64>()
                    + grid.tri_indices.len() as u64
                    + 16),
        })
    }

    /// Resolves pending timers into the statistics.
    fn finish_timers(&mut self) -> Result<()> {
        if let Some(pool) = &mut self.timers {
            pool.resolve(self.ctx)?;
            self.stats.gpu_ms = pool.ms.clone();
            self.stats.gpu_ms_total = pool.ms.values().sum();
        }
        Ok(())
    }

    /// Deletes every GL object of the frame (the context may render again).
    fn delete(self) -> GpuStats {
        let gl = &self.ctx.gl;
        self.quad.delete(gl);
        for t in self
            .state
            .into_iter()
            .chain(self.rec01)
            .chain(self.rec2)
            .chain(self.acc)
        {
            t.delete(gl);
        }
        self.count_query.delete(self.ctx);
        if let Some(rb) = self.mask_buffer {
            // SAFETY: the FBOs it was attached to are deleted above.
            unsafe { gl.delete_renderbuffer(rb) };
        }
        if let Some(pool) = self.timers {
            for q in pool.free {
                q.delete(self.ctx);
            }
        }
        // SAFETY: the context is current; names are not used after this.
        unsafe {
            for p in self.programs.values() {
                gl.delete_program(*p);
            }
            for (_, t) in self.scene_tex {
                gl.delete_texture(t);
            }
        }
        self.stats
    }
}

/// Renders `scene` over `grid` on the GPU.
pub fn render_gl(
    ctx: &GlContext,
    scene: &Scene,
    grid: &Grid,
    render: &crate::render::RenderOptions,
) -> Result<GpuOutput> {
    let (width, height, spp, max_depth) =
        (render.width, render.height, render.spp, render.max_depth);
    let gl = &ctx.gl;
    let levels = max_depth as usize + 1;
    let gpu = GpuOptions {
        techniques: render.techniques,
        ..render.gpu
    };
    let mut f = Frame::new(ctx, scene, grid, width, height, levels, true, gpu)?;
    f.progress = Progress::spinner(render.progress);
    let secondary = max_depth > 0 && scene.materials.iter().any(|m| m.reflects() || m.refracts());
    let t_trace = Instant::now();
    // Clear the colour accumulator.
    // SAFETY: the context is current.
    unsafe {
        f.acc[0].bind(gl);
        gl.clear_color(0.0, 0.0, 0.0, 0.0);
        gl.clear(glow::COLOR_BUFFER_BIT);
    }
    let offsets = camera::sample_offsets(spp);
    let corners = scene
        .camera
        .window_corners(width, height)
        .map(|c| c.as_vec3().to_array());
    let mut rays = [0u64; 4];
    let mut aov = None;
    for (k, &(ox, oy)) in offsets.iter().enumerate() {
        // Level-0 weight: 1/spp everywhere, and every pixel has a primary ray.
        let w = 1.0 / offsets.len() as f32;
        // SAFETY: the context is current.
        unsafe {
            f.rec2[0].bind(gl);
            gl.clear_color(w, w, w, 1.0);
            gl.clear(glow::COLOR_BUFFER_BIT);
        }
        f.set_vec3(Pass::RayGen, "u_eye", scene.camera.eye.to_array());
        f.set_vec3(Pass::RayGen, "u_bl", corners[0]);
        f.set_vec3(Pass::RayGen, "u_br", corners[1]);
        f.set_vec3(Pass::RayGen, "u_tr", corners[2]);
        f.set_vec3(Pass::RayGen, "u_tl", corners[3]);
        f.set_vec2(Pass::RayGen, "u_offset", [ox as f32, oy as f32]);
        f.progress
            .stage(format!("sample {}/{}: primary rays", k + 1, offsets.len()));
        f.state_pass(Pass::RayGen)?;
        rays[0] += width as u64 * height as u64;
        f.trace(Query::Closest)?;
        if k == 0 {
            aov = Some(read_aov(&f, scene, width, height)?);
        }
        f.record(0)?;
        shade_node(&mut f, scene, 0, max_depth, secondary, &mut rays)?;
    }
    let data = f.acc[f.acc_cur].read_attachment(gl, 0)?;
    f.progress.finish();
    f.finish_timers()?;
    f.stats.trace_ms = t_trace.elapsed().as_secs_f64() * 1e3;
    let image = Image::from_rgb(width, height, flip_rgba_to_rgb(&data, width, height));

    let stats = f.delete();
    Ok(GpuOutput {
        image,
        aov: aov.expect("at least one sample"),
        rays: RayCounts::new(rays[0], rays[1], rays[2], rays[3]),
        stats,
    })
}

/// Shades level `level`'s records (ambient, every light) and recurses into the node's
/// reflected and refracted children.
fn shade_node(
    f: &mut Frame,
    scene: &Scene,
    level: usize,
    max_depth: u32,
    secondary: bool,
    rays: &mut [u64; 4],
) -> Result<()> {
    f.accumulate(Pass::AccumAmbient, level)?;
    for light in &scene.lights {
        f.set_vec3(Pass::ShadowSpawn, "u_light_pos", light.position.to_array());
        f.set_vec3(Pass::AccumLight, "u_light_rad", light.radiance().to_array());
        bind_texture(f.gl(), unit_of("u_r0"), f.rec01[level].texture(0));
        bind_texture(f.gl(), unit_of("u_r1"), f.rec01[level].texture(1));
        f.progress.stage(format!("depth {level}: shadow rays"));
        f.state_pass(Pass::ShadowSpawn)?;
        let n = f.count(Count::Rays, None)?;
        rays[1] += n;
        if n > 0 {
            f.trace(Query::Any)?;
        }
        f.accumulate(Pass::AccumLight, level)?;
    }
    if !secondary || level as u32 >= max_depth {
        return Ok(());
    }
    for (branch, slot) in [(0.0f32, 2usize), (1.0, 3)] {
        let child = level + 1;
        f.set_float(Pass::Weight, "u_branch", branch);
        f.set_float(Pass::Spawn, "u_branch", branch);
        bind_texture(f.gl(), unit_of("u_p0"), f.rec01[level].texture(0));
        bind_texture(f.gl(), unit_of("u_p1"), f.rec01[level].texture(1));
        bind_texture(f.gl(), unit_of("u_p2"), f.rec2[level].texture(0));
        f.draw(Pass::Weight, Slot::Rec2(child))?;
        let node = f.rec2[child].texture(0);
        let n = f.count(Count::Nodes, Some(node))?;
        if n == 0 {
            continue; // no pixel has this node: skip its whole subtree
        }
        rays[slot] += n;
        f.progress.stage(format!(
            "depth {child}: {} rays",
            if slot == 2 { "reflected" } else { "refracted" }
        ));
        bind_texture(f.gl(), unit_of("u_p0"), f.rec01[level].texture(0));
        bind_texture(f.gl(), unit_of("u_p1"), f.rec01[level].texture(1));
        bind_texture(f.gl(), unit_of("u_c2"), node);
        f.state_pass(Pass::Spawn)?;
        f.trace(Query::Closest)?;
        f.record(child)?;
        shade_node(f, scene, child, max_depth, secondary, rays)?;
    }
    Ok(())
}

/// GL rows start at the bottom; images at the top. Drops alpha.
fn flip_rgba_to_rgb(data: &[f32], w: u32, h: u32) -> Vec<f32> {
    let mut out = Vec::with_capacity((w * h * 3) as usize);
    for j in 0..h {
        let row = (h - 1 - j) as usize * w as usize * 4;
        for i in 0..w as usize {
            out.extend_from_slice(&data[row + i * 4..row + i * 4 + 3]);
        }
    }
    out
}

/// Primary-ray AOVs from the finished level-0 wave.
fn read_aov(f: &Frame, scene: &Scene, w: u32, h: u32) -> Result<Aov> {
    let st = &f.state[f.cur];
    let s0 = st.read_attachment(f.gl(), 0)?;
    let s3 = st.read_attachment(f.gl(), 3)?;
    let mut pixels = Vec::with_capacity((w * h) as usize);
    for j in 0..h {
        let row = (h - 1 - j) as usize * w as usize;
        for i in 0..w as usize {
            let k = (row + i) * 4;
            let steps = s3[k + 3];
            let hit = RayState::from_code(s0[k + 3]) == Some(RayState::Shading);
            pixels.push(if hit {
                let tri = s3[k + 1] as usize;
                let v = scene.triangle_vertices(tri);
                let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
                AovPixel {
                    depth: s3[k],
                    primid: s3[k + 1],
                    normal: n.to_array(),
                    steps,
                }
            } else {
                AovPixel::miss(steps)
            });
        }
    }
    Ok(Aov::from_pixels(w, h, &pixels))
}

/// One ray for [`trace_rays`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuRay {
    /// Origin.
    pub o: glam::Vec3,
    /// Direction (need not be unit length, must not be zero).
    pub d: glam::Vec3,
    /// Upper end of the open interval (0, t_max).
    pub t_max: f32,
}

/// What [`trace_rays`] found for one ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuTrace {
    /// (t, triangle) of the hit; for [`Query::Any`] the first hit found.
    pub hit: Option<(f32, u32)>,
    /// Final ray state.
    pub state: RayState,
    /// Cells visited plus triangle tests.
    pub steps: f32,
}

/// Traces arbitrary rays through the same traversal and intersection passes a render uses:
/// how tests put single hand-made rays through the GPU kernel.
pub fn trace_rays(
    ctx: &GlContext,
    scene: &Scene,
    grid: &Grid,
    rays: &[GpuRay],
    query: Query,
    opts: GpuOptions,
) -> Result<Vec<GpuTrace>> {
    if rays.is_empty() {
        return Ok(Vec::new());
    }
    let n = rays.len() as u32;
    let w = n.min(256);
    let h = n.div_ceil(w);
    let mut f = Frame::new(ctx, scene, grid, w, h, 1, false, opts)?;
    let texels = (w * h) as usize;
    let mut s = [
        vec![0f32; texels * 4],
        vec![0f32; texels * 4],
        vec![0f32; texels * 4],
        vec![0f32; texels * 4],
    ];
    for k in 0..texels {
        let (s0, s1, s3) = match rays.get(k) {
            Some(r) => (
                [r.o.x, r.o.y, r.o.z, RayState::Initial.code()],
                [r.d.x, r.d.y, r.d.z, r.t_max],
                [r.t_max, -1.0, 0.0, 0.0],
            ),
            None => (
                [0.0, 0.0, 0.0, RayState::Done.code()],
                [0.0, 0.0, 1.0, 0.0],
                [0.0, -2.0, 0.0, 0.0],
            ),
        };
        s[0][k * 4..k * 4 + 4].copy_from_slice(&s0);
        s[1][k * 4..k * 4 + 4].copy_from_slice(&s1);
        s[3][k * 4..k * 4 + 4].copy_from_slice(&s3);
    }
    for (k, data) in s.iter().enumerate() {
        super::gl_util::upload_float_texture(&ctx.gl, f.state[f.cur].texture(k), w, h, data)?;
    }
    f.trace(query)?;
    let st = &f.state[f.cur];
    let s0 = st.read_attachment(&ctx.gl, 0)?;
    let s3 = st.read_attachment(&ctx.gl, 3)?;
    let out = (0..rays.len())
        .map(|k| {
            let state = RayState::from_code(s0[k * 4 + 3]).unwrap_or(RayState::Done);
            GpuTrace {
                hit: (state == RayState::Shading).then(|| (s3[k * 4], s3[k * 4 + 1] as u32)),
                state,
                steps: s3[k * 4 + 3],
            }
        })
        .collect();
    f.delete();
    Ok(out)
}
