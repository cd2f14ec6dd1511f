//! The scene on the GPU: packed, uploaded and compiled for once, then rendered from as
//! often as asked (every frame of `fragtrace view`, every render of the front door).
//!
//! A [`GpuScene`] is the leaf both wings of the backend stand on: the fragment kernels
//! (`gpu::fragment`) read the scene as textures, the compute kernel (`gpu::compute`) as
//! textures or storage buffers. Each copy is uploaded on first use and kept; each program is
//! compiled on first use (keyed by pass, techniques and, for compute, its specialisation)
//! and kept, with the uniforms that are the same for every render of the scene (samplers'
//! units, the grid's box, ambient, background) set once when it is built.
//!
//! What a render spends here (packing, uploads, compiles) is charged to the render that
//! caused it ([`GpuScene::take_costs`]), so `--stats` shows it once and a second frame
//! shows none.

use std::any::{Any, TypeId};
use std::cell::{Cell, OnceCell, RefCell, RefMut};
use std::collections::HashMap;
use std::rc::Rc;

use super::context::GlContext;
use super::contract::STORAGE_BINDING_BASE;
use super::contract::{uniform, Unit};
use super::gl::compute::{start_compute, PendingCompute};
use super::gl::program::{allow_parallel_compile, link_binary, start_program, PendingProgram};
use super::gl::{compile_compute, compile_program, state, Program, StorageBuffer, Texture};
use super::layout::{IndexFormat, LayoutTarget, SceneTextures};
use super::program_cache::{ProgramCache, SourceKey};
use super::shader::{
    assemble_compute, assemble_in, Assembled, ComputePass, ComputeSpec, Features, Pass,
};
use crate::accel::grid_instances::GridInstances;
use crate::accel::{AccelRef, GridRef};
use crate::clock::Instant;
use crate::output::GpuStats;
use crate::scene::Scene;
use crate::technique::Techniques;
use crate::Result;

mod upload;

pub use upload::DENSE_BLOCK_BYTES_ENV;

#[cfg(test)]
thread_local! {
    /// Test hook: the pass whose source gets a line that does not compile, to exercise a
    /// render failing half-way through building its programs.
    pub(crate) static BREAK_PASS: std::cell::Cell<Option<Pass>> = const { std::cell::Cell::new(None) };
}

/// What a render spent on the scene's GPU copy before tracing: reported in its stats.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Costs {
    /// Packing and uploading textures or buffers (ms).
    pub upload_ms: f64,
    /// Bytes uploaded.
    pub upload_bytes: usize,
    /// Compiling and linking programs, or linking them from cached binaries (ms).
    pub compile_ms: f64,
    /// Programs compiled from source.
    pub programs_compiled: u32,
    /// Programs linked from the program-binary cache.
    pub programs_cached: u32,
}

impl Costs {
    /// Adds the programs' share (time and counts) to a render's statistics.
    pub fn charge_programs(&self, stats: &mut GpuStats) {
        stats.compile_ms += self.compile_ms;
        stats.programs_compiled += self.programs_compiled;
        stats.programs_cached += self.programs_cached;
    }
}

/// Tests only (read when a scene is made): each compute program's compile answers "not
/// done" to its first N polls ([`GpuScene::compute_program_ready`]), as on a driver that
/// compiles on threads of its own (NVIDIA), where llvmpipe compiles within the call and
/// is done at the first. The images are the same either way; only which kernel renders
/// which frame moves.
pub const COMPILE_POLLS_ENV: &str = "FRAGTRACE_COMPILE_POLLS";

/// A compute program the driver is compiling while the render goes on: its key in the
/// program cache, its source's line map, and the polls it still answers "not done" to
/// ([`COMPILE_POLLS_ENV`]).
struct Compiling {
    source: SourceKey,
    assembled: Assembled,
    pending: PendingCompute,
    polls_left: u32,
}

/// A program of the scene's cache.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum ProgramKey {
    Fragment(Pass, Techniques),
    Compute(ComputePass, ComputeSpec, Techniques),
}

/// The scene, its acceleration structure and their GPU copies (see the module docs).
pub struct GpuScene<'s> {
    ctx: &'s GlContext,
    /// The scene packed: the one given, or an instanced scene's own triangles and meshes
    /// (`GridInstances::packed`).
    scene: &'s Scene,
    /// The scene as given: whose ids the hits carry.
    given: &'s Scene,
    accel: GridRef<'s>,
    features: Features,
    /// The layouts, each packed on first use ([`LayoutSlot`]): the float one and the
    /// compute kernel's over the irregular grid; and each one's uploaded copies.
    layouts: [OnceCell<SceneTextures>; 2],
    textures: [OnceCell<Vec<(Unit, Texture)>>; 2],
    buffers: [OnceCell<Vec<(u32, StorageBuffer)>>; 2],
    /// The slot the compute kernel's layout took over an irregular grid (float where it
    /// fits), once [`GpuScene::layout`] has chosen.
    compute_slot: OnceCell<usize>,
    /// The dense grid's storage buffers at their bindings, uploaded on first use.
    dense_buffers: OnceCell<Vec<(u32, StorageBuffer)>>,
    /// Tests only: the index format the float layout is packed in
    /// ([`GpuScene::with_index_format`]), and faces skewed ([`GpuScene::with_skewed_faces`]).
    index_format: Option<IndexFormat>,
    skew_faces: bool,
    programs: RefCell<HashMap<ProgramKey, Rc<Program>>>,
    /// Compute programs started and not yet finished ([`GpuScene::compute_program_ready`]).
    compiling: RefCell<HashMap<ProgramKey, Compiling>>,
    /// [`COMPILE_POLLS_ENV`], read once.
    compile_polls: u32,
    /// Where linked programs are looked up before compiling, and stored after.
    cache: Option<ProgramCache>,
    /// The compute kernel's light buffer and 8-bit sRGB thresholds, made on first use.
    lights: OnceCell<StorageBuffer>,
    srgb_thresholds: OnceCell<StorageBuffer>,
    /// The same thresholds as a 256 x 1 texture (in .r), for `srgb8.frag`.
    srgb_texture: OnceCell<Texture>,
    /// An instanced scene's levels (every kernel walks them; their instancing data is
    /// the layout's texture `inst`).
    instancing: Option<&'s GridInstances>,
    /// What a wing keeps between renders of this scene, one value per type (see
    /// [`GpuScene::kept`]).
    kept: RefCell<HashMap<TypeId, Box<dyn Any>>>,
    costs: Cell<Costs>,
}

/// Set once a scene goes while the driver still compiles one of its programs.
static COMPILE_LEFT_RUNNING: std::sync::atomic::AtomicBool =
    std::sync::atomic::AtomicBool::new(false);

/// Whether a scene of this process went while the driver still compiled one of its
/// programs on its own threads (a cold start that ended on the looped kernel): NVIDIA's
/// driver then holds the process at its exit until that compile ends (210-260 ms on the
/// H100 machine, docs/performance.md), which the command line skips
/// ([`crate::overlap::end_now`]).
pub fn compile_left_running() -> bool {
    COMPILE_LEFT_RUNNING.load(std::sync::atomic::Ordering::Relaxed)
}

/// A compute program whose compile the driver had not finished when the scene goes (the
/// process ends after a cold start's looped frames) is marked in the program-binary cache,
/// so that the next run waits for it ([`ProgramCache::was_unfinished`]), and given up
/// without waiting: its delete runs when the context goes ([`PendingCompute::abandon`]).
impl Drop for GpuScene<'_> {
    fn drop(&mut self) {
        if !self.compiling.get_mut().is_empty() {
            COMPILE_LEFT_RUNNING.store(true, std::sync::atomic::Ordering::Relaxed);
        }
        if let Some(cache) = &self.cache {
            for c in self.compiling.get_mut().values() {
                cache.mark_unfinished(c.source);
            }
        }
        for (_, c) in self.compiling.get_mut().drain() {
            c.pending.abandon(self.ctx);
        }
    }
}

impl<'s> GpuScene<'s> {
    /// The scene and `accel` for `ctx`: each layout is packed, and each copy uploaded, on
    /// first use by the kernel that reads it ([`GpuScene::layout`]). With `no_specialize`
    /// every shading feature is compiled in, whatever the scene needs.
    pub fn new(
        ctx: &'s GlContext,
        scene: &'s Scene,
        accel: impl Into<AccelRef<'s>>,
        no_specialize: bool,
    ) -> Result<Self> {
        let accel = accel.into();
        let t = Instant::now();
        let given = scene;
        // An instanced scene packs its own triangles and its meshes' (`GridInstances`).
        let (scene, instancing) = match accel {
            AccelRef::GridInstanced(gi) => (&gi.packed, Some(gi)),
            _ => (scene, None),
        };
        let accel = accel.grid()?;
        allow_parallel_compile(ctx);
        // Objects of compiles an earlier scene gave up, which the driver is through with.
        ctx.shared().reap();
        let features = if no_specialize {
            Features::all()
        } else {
            Features::of(scene)
        };
        let costs = Costs {
            upload_ms: ms_since(t),
            ..Costs::default()
        };
        Ok(GpuScene {
            ctx,
            scene,
            given,
            accel,
            features,
            layouts: Default::default(),
            textures: Default::default(),
            buffers: Default::default(),
            compute_slot: OnceCell::new(),
            dense_buffers: OnceCell::new(),
            index_format: None,
            skew_faces: false,
            programs: RefCell::new(HashMap::new()),
            compiling: RefCell::new(HashMap::new()),
            compile_polls: std::env::var(COMPILE_POLLS_ENV)
                .ok()
                .and_then(|v| v.parse().ok())
                .unwrap_or(0),
            cache: None,
            lights: OnceCell::new(),
            srgb_thresholds: OnceCell::new(),
            srgb_texture: OnceCell::new(),
            instancing,
            kept: RefCell::new(HashMap::new()),
            costs: Cell::new(costs),
        })
    }

    /// Tests only: programs compiled from here on move every face crossing of the
    /// irregular grid's walk by about an ulp (`SKEW_FACES` in `glsl120/traverse.glsl`), as
    /// NVIDIA's fused multiply-add rounds `min + k * cell_size` otherwise than IEEE
    /// arithmetic does, so that a driver with IEEE arithmetic (llvmpipe in CI) shows
    /// whether the walk still finds every hit (`tests/hard_cases/grid.rs`, case 08/09).
    /// The uniform grid is left as it is.
    pub fn with_skewed_faces(mut self) -> Self {
        self.skew_faces = true;
        self
    }

    /// Programs are looked up in `cache` before they are compiled, and stored there after
    /// (`--shader-cache`; None compiles every program).
    pub fn with_program_cache(mut self, cache: Option<ProgramCache>) -> Self {
        self.cache = cache;
        self
    }

    /// The program-binary cache, where the scene has one.
    pub fn program_cache(&self) -> Option<&ProgramCache> {
        self.cache.as_ref()
    }

    /// Tests only: the float layout packed in `format` (an instanced scene's, which every
    /// kernel reads; [`IndexFormat::Split`] takes a scene that fits in floats down the split
    /// path, which must render the same image).
    pub fn with_index_format(mut self, format: IndexFormat) -> Result<Self> {
        self.index_format = Some(format);
        Ok(self)
    }

    /// The context the scene lives in.
    pub fn ctx(&self) -> &'s GlContext {
        self.ctx
    }

    /// The scene packed (for an instanced scene its own triangles, then its meshes' in
    /// object space; materials, lights and camera as given).
    pub fn scene(&self) -> &'s Scene {
        self.scene
    }

    /// The scene as given, whose primitive ids the hits carry (an instanced scene's
    /// placed triangles among them: [`Scene::placed_vertices`]).
    pub fn given_scene(&self) -> &'s Scene {
        self.given
    }

    /// Its acceleration structure.
    pub fn accel(&self) -> GridRef<'s> {
        self.accel
    }

    /// The shading features the programs are compiled with.
    pub fn features(&self) -> Features {
        self.features
    }

    /// Whether the scene has texture coordinates or vertex colours (then the layouts pack
    /// `tex` and the programs compile `HAS_TEXTURES`).
    pub fn textured(&self) -> bool {
        self.scene.has_textures() || self.scene.has_vertex_colors()
    }

    /// Whether any material reflects or refracts (else no ray has children).
    pub fn has_secondary(&self) -> bool {
        self.scene
            .materials
            .iter()
            .any(|m| m.reflects() || m.refracts())
    }

    /// Traversal iterations after which a ray that has not finished is a bug: a DDA visits
    /// at most rx+ry+rz cells (an irregular walk at most as many as its virtual grid's) and
    /// each test is one iteration; generously.
    pub fn max_iterations(&self) -> u64 {
        // Each walk of an instanced scene (its own grid's, a mesh's) is bounded alone.
        let meshes = self.instancing.iter().flat_map(|gi| &gi.meshes);
        meshes
            .map(|m| walk_iterations(m.res, m.references as u64))
            .fold(max_iterations(self.accel), u64::max)
    }

    /// The fragment kernels' bound on one ray's iterations: [`GpuScene::max_iterations`],
    /// or for an instanced scene, whose walks a fragment kernel counts together, the own
    /// walk's, one per top-level entry (at most two per instance) and every instance's.
    pub fn ray_iterations(&self) -> u64 {
        let Some(gi) = self.instancing else {
            return self.max_iterations();
        };
        let instances = &self.given.instancing.instances;
        let placed: u64 = instances
            .iter()
            .map(|i| {
                let m = &gi.meshes[i.mesh as usize];
                walk_iterations(m.res, m.references as u64)
            })
            .sum();
        max_iterations(self.accel) + 2 * instances.len() as u64 + placed
    }

    /// Whether the scene is walked as instances (the compute kernel's `INSTANCED`).
    pub fn instanced(&self) -> bool {
        self.instancing.is_some()
    }

    /// An instanced scene's levels (None for a scene walked flat).
    pub fn instancing(&self) -> Option<&'s GridInstances> {
        self.instancing
    }

    /// What was spent since the last call (the first render also pays for the packing).
    pub fn take_costs(&self) -> Costs {
        self.costs.take()
    }

    fn charge(&self, f: impl FnOnce(&mut Costs)) {
        let mut c = self.costs.get();
        f(&mut c);
        self.costs.set(c);
    }

    /// The lights as the compute kernel's light buffer (`contract::compute::light_buffer`),
    /// uploaded on first use.
    pub fn light_buffer(&self) -> Result<&StorageBuffer> {
        if let Some(b) = self.lights.get() {
            return Ok(b);
        }
        let bytes: Vec<u8> = super::contract::compute::light_buffer(&self.scene.lights)
            .into_iter()
            .flat_map(f32::to_ne_bytes)
            .collect();
        let b = StorageBuffer::new(self.ctx, &bytes)?;
        Ok(self.lights.get_or_init(|| b))
    }

    /// The 256 linear values at which the 8-bit sRGB code steps up (the host's
    /// `image_io::srgb8_thresholds`, padded with +inf), for `srgb8.comp`; uploaded once.
    pub fn srgb_thresholds(&self) -> Result<&StorageBuffer> {
        if let Some(b) = self.srgb_thresholds.get() {
            return Ok(b);
        }
        let mut t = crate::image_io::srgb8_thresholds().to_vec();
        t.push(f32::INFINITY);
        let bytes: Vec<u8> = t.iter().flat_map(|v| v.to_ne_bytes()).collect();
        let b = StorageBuffer::new(self.ctx, &bytes)?;
        Ok(self.srgb_thresholds.get_or_init(|| b))
    }

    /// The 8-bit sRGB thresholds of [`GpuScene::srgb_thresholds`] as a 256 x 1 RGBA32F
    /// texture (value in .r) for the fragment kernels' `srgb8.frag`; uploaded once.
    pub fn srgb_texture(&self) -> Result<&Texture> {
        if let Some(t) = self.srgb_texture.get() {
            return Ok(t);
        }
        let mut texels = vec![0f32; 256 * 4];
        for (k, v) in crate::image_io::srgb8_thresholds().iter().enumerate() {
            texels[4 * k] = *v;
        }
        texels[4 * 255] = f32::INFINITY;
        let t = Texture::new_f32(self.ctx, 256, 1, Some(&texels))?;
        Ok(self.srgb_texture.get_or_init(|| t))
    }

    /// The value of type `T` a wing keeps between renders of this scene (None until it
    /// stores one): the compute kernel's output buffers for one image shape, which cost
    /// 50-350 MB of storage and mapped staging memory at 4096x4096 and so are made once per
    /// shape, not per frame. The type is the wing's own, so this leaf names no wing; the
    /// value lives (and its GL objects are freed) with the scene. Borrowed for one render:
    /// a second borrow while the first is held panics.
    pub(crate) fn kept<T: 'static>(&self) -> RefMut<'_, Option<T>> {
        RefMut::map(self.kept.borrow_mut(), |m| {
            m.entry(TypeId::of::<T>())
                .or_insert_with(|| Box::new(None::<T>))
                .downcast_mut::<Option<T>>()
                .expect("kept values are stored under their own type")
        })
    }

    /// The fragment program of `pass`, compiled (or linked from the cache) on first use.
    pub fn fragment_program(&self, pass: Pass, techniques: Techniques) -> Result<Rc<Program>> {
        // Packed first, so that packing counts as upload time, not as compile time.
        self.layout(LayoutTarget::Float)?;
        self.program(ProgramKey::Fragment(pass, techniques), || {
            let a = self.assemble_fragment(pass, techniques)?;
            let vertex = self.ctx.info.dialect.quad_vertex_shader();
            let key = SourceKey::of(pass.name(), &[vertex, &a.source]);
            let program = self.cached_or(pass.name(), key, || {
                compile_program(self.ctx, pass.name(), vertex, &a.source, &|n| a.origin(n))
            })?;
            Ok(program.declaring(a.declared))
        })
    }

    /// The fragment programs of `passes`, as [`GpuScene::fragment_program`] gives each, with
    /// every one that is neither kept nor cached handed to the driver before any is waited
    /// for: a driver that compiles on threads of its own (`GL_KHR_parallel_shader_compile`)
    /// builds them at once.
    pub fn fragment_programs(
        &self,
        passes: &[Pass],
        techniques: Techniques,
    ) -> Result<Vec<Rc<Program>>> {
        self.layout(LayoutTarget::Float)?;
        let t0 = Instant::now();
        let mut pending: Vec<(ProgramKey, SourceKey, Assembled, PendingProgram)> = Vec::new();
        for &pass in passes {
            let key = ProgramKey::Fragment(pass, techniques);
            if self.programs.borrow().contains_key(&key) || pending.iter().any(|(k, ..)| *k == key)
            {
                continue;
            }
            let a = self.assemble_fragment(pass, techniques)?;
            let vertex = self.ctx.info.dialect.quad_vertex_shader();
            let source = SourceKey::of(pass.name(), &[vertex, &a.source]);
            match self.cached(pass.name(), source) {
                Some(p) => {
                    self.keep(key, p.declaring(a.declared))?;
                }
                None => {
                    let started = start_program(self.ctx, pass.name(), vertex, &a.source)?;
                    pending.push((key, source, a, started));
                }
            }
        }
        for (key, source, a, started) in pending {
            let program = started.finish(self.ctx, &|n| a.origin(n))?;
            self.compiled(source, &program);
            self.keep(key, program.declaring(a.declared))?;
        }
        self.charge(|c| c.compile_ms += ms_since(t0));
        passes
            .iter()
            .map(|&pass| self.fragment_program(pass, techniques))
            .collect()
    }

    /// The assembled source of fragment pass `pass`.
    fn assemble_fragment(&self, pass: Pass, techniques: Techniques) -> Result<Assembled> {
        let dialect = self.ctx.info.dialect;
        let layout = self.layout(LayoutTarget::Float)?;
        #[allow(unused_mut)]
        let mut a = assemble_in(dialect, pass, self.features, techniques, layout)?;
        #[cfg(test)]
        if BREAK_PASS.get() == Some(pass) {
            a.source.push_str("this line does not compile\n");
            a.lines.push(("<test hook>".into(), 1));
        }
        Ok(a)
    }

    /// The compute program of `pass` specialised for `spec`, compiled (or linked from the
    /// cache) on first use.
    pub fn compute_program(
        &self,
        pass: ComputePass,
        spec: &ComputeSpec,
        techniques: Techniques,
    ) -> Result<Rc<Program>> {
        let key = ProgramKey::Compute(pass, *spec, techniques);
        self.layout(LayoutTarget::Compute)?;
        self.program(key, || {
            // Started by compute_program_ready: wait for it.
            let started = self.compiling.borrow_mut().remove(&key);
            if let Some(c) = started {
                return self.finish_compiling(c);
            }
            let a = self.assemble_compute(pass, spec, techniques)?;
            let key = SourceKey::of(pass.name(), &[&a.source]);
            let program = self.cached_or(pass.name(), key, || {
                compile_compute(self.ctx, pass.name(), &a.source, &|n| a.origin(n))
            })?;
            Ok(program.declaring(a.declared))
        })
    }

    /// The source of the compute program of `pass` for `spec`, over the compute kernel's
    /// layout (the one place both the waiting and the polling compile assemble it).
    fn assemble_compute(
        &self,
        pass: ComputePass,
        spec: &ComputeSpec,
        techniques: Techniques,
    ) -> Result<Assembled> {
        assemble_compute(
            pass,
            spec,
            self.features,
            techniques,
            self.layout(LayoutTarget::Compute)?,
        )
    }

    /// Whether the compute program of `pass` for `spec` can run without waiting for a
    /// compile: kept, linked now from the program-binary cache, or compiled by the driver
    /// on threads of its own since this started it. Otherwise its compile is started
    /// (where it was not yet) and the answer is false: the caller renders with a fragment
    /// kernel meanwhile and asks again later (`--kernel auto`'s cold start, issue 52).
    /// A driver without `GL_KHR_parallel_shader_compile` cannot tell, and compiles on the
    /// caller's thread anyway: there the compile is waited for and the answer is true.
    pub fn compute_program_ready(
        &self,
        pass: ComputePass,
        spec: &ComputeSpec,
        techniques: Techniques,
    ) -> Result<bool> {
        let key = ProgramKey::Compute(pass, *spec, techniques);
        if self.programs.borrow().contains_key(&key) {
            return Ok(true);
        }
        self.layout(LayoutTarget::Compute)?;
        let t0 = Instant::now();
        let ready = self.start_or_poll(key, pass, spec, techniques);
        self.charge(|c| c.compile_ms += ms_since(t0));
        ready
    }

    /// [`GpuScene::compute_program_ready`] past its first question.
    fn start_or_poll(
        &self,
        key: ProgramKey,
        pass: ComputePass,
        spec: &ComputeSpec,
        techniques: Techniques,
    ) -> Result<bool> {
        if !self.compiling.borrow().contains_key(&key) {
            let a = self.assemble_compute(pass, spec, techniques)?;
            let source = SourceKey::of(pass.name(), &[&a.source]);
            if let Some(p) = self.cached(pass.name(), source) {
                self.keep(key, p.declaring(a.declared))?;
                return Ok(true);
            }
            let pending = start_compute(self.ctx, pass.name(), &a.source)?;
            let c = Compiling {
                source,
                assembled: a,
                pending,
                polls_left: self.compile_polls,
            };
            if self
                .cache
                .as_ref()
                .is_some_and(|c| c.was_unfinished(source))
            {
                // The run before ended with this compile unfinished: wait for it this
                // time, so that the next run finds its binary.
                let program = self.finish_compiling(c)?;
                self.keep(key, program)?;
                return Ok(true);
            }
            self.compiling.borrow_mut().insert(key, c);
        }
        self.finish_if_done(key)
    }

    /// Polls the compile of `key` (started): when the driver is done, the program is
    /// finished, kept and stored in the program-binary cache, and the answer is true.
    fn finish_if_done(&self, key: ProgramKey) -> Result<bool> {
        let done = match self.compiling.borrow_mut().get_mut(&key) {
            None => return Ok(self.programs.borrow().contains_key(&key)),
            Some(c) if c.polls_left > 0 => {
                c.polls_left -= 1;
                false
            }
            Some(c) => c.pending.is_complete(self.ctx),
        };
        if !done {
            return Ok(false);
        }
        let c = self
            .compiling
            .borrow_mut()
            .remove(&key)
            .expect("polled above");
        let program = self.finish_compiling(c)?;
        self.keep(key, program)?;
        Ok(true)
    }

    /// Every compute program started whose compile the driver has finished meanwhile,
    /// kept and stored in the program-binary cache; none is waited for. Called after a
    /// render that ran a fragment kernel while they compiled, so that a single frame that
    /// outlasts the compile leaves the next run a warm cache.
    pub fn settle_compiles(&self) -> Result<()> {
        let t0 = Instant::now();
        let keys: Vec<ProgramKey> = self.compiling.borrow().keys().copied().collect();
        for key in keys {
            self.finish_if_done(key)?;
        }
        self.charge(|c| c.compile_ms += ms_since(t0));
        Ok(())
    }

    /// Waits for the compile `c` and returns its program, counted as compiled and stored
    /// in the program-binary cache.
    fn finish_compiling(&self, c: Compiling) -> Result<Program> {
        let program = c.pending.finish(self.ctx, &|n| c.assembled.origin(n))?;
        self.compiled(c.source, &program);
        Ok(program.declaring(c.assembled.declared))
    }

    /// The program of `key` linked from its cached binary where the cache has one the
    /// driver accepts, else compiled by `compile` and stored.
    fn cached_or(
        &self,
        pass: &str,
        key: SourceKey,
        compile: impl FnOnce() -> Result<Program>,
    ) -> Result<Program> {
        if let Some(p) = self.cached(pass, key) {
            return Ok(p);
        }
        let program = compile()?;
        self.compiled(key, &program);
        Ok(program)
    }

    /// The program of `key` linked from its cached binary, where the cache has one the
    /// driver accepts.
    fn cached(&self, pass: &str, key: SourceKey) -> Option<Program> {
        let cache = self.cache.as_ref()?;
        let binary = cache.load(key)?;
        match link_binary(self.ctx, pass, &binary) {
            Some(p) => {
                cache.hit();
                self.charge(|c| c.programs_cached += 1);
                Some(p)
            }
            None => {
                cache.refused();
                None
            }
        }
    }

    /// Counts a program compiled from source and stores its binary as entry `key`.
    fn compiled(&self, key: SourceKey, program: &Program) {
        self.charge(|c| c.programs_compiled += 1);
        if let Some(cache) = &self.cache {
            if let Some(binary) = program.binary(self.ctx) {
                cache.store(key, &binary);
            }
        }
    }

    fn program(
        &self,
        key: ProgramKey,
        build: impl FnOnce() -> Result<Program>,
    ) -> Result<Rc<Program>> {
        if let Some(p) = self.programs.borrow().get(&key) {
            return Ok(Rc::clone(p));
        }
        let t0 = Instant::now();
        let program = self.keep(key, build()?)?;
        self.charge(|c| c.compile_ms += ms_since(t0));
        Ok(program)
    }

    /// Sets the scene's uniforms in `program` and keeps it as the program of `key`.
    fn keep(&self, key: ProgramKey, program: Program) -> Result<Rc<Program>> {
        self.set_scene_uniforms(&program)?;
        let program = Rc::new(program);
        self.programs.borrow_mut().insert(key, Rc::clone(&program));
        Ok(program)
    }

    /// Sets what the programs of the scene share, in each program that declares it: each
    /// sampler's texture unit, the grid's box and resolution, ambient and background.
    fn set_scene_uniforms(&self, program: &Program) -> Result<()> {
        let gl = self.ctx.gl();
        program.bind_samplers(gl);
        let (min, max, cell_size, res) = match self.accel {
            GridRef::Uniform(g) => (g.min, g.max, g.cell_size, g.res),
            GridRef::Irregular(g) => (g.min, g.max, g.cell_size, g.res),
        };
        let res = glam::UVec3::from(res).as_vec3();
        for (u, v) in [
            (uniform::GRID_MIN, min),
            (uniform::GRID_MAX, max),
            (uniform::CELL_SIZE, cell_size),
            (uniform::GRID_RES, res),
            (uniform::AMBIENT, self.scene.ambient),
            (uniform::BACKGROUND, self.scene.background),
        ] {
            if program.declares(u) {
                program.set(gl, u, v)?;
            }
        }
        Ok(())
    }
}

/// Traversal iterations after which a ray on `accel` that has not finished is a bug (see
/// [`GpuScene::max_iterations`]).
pub fn max_iterations(accel: GridRef<'_>) -> u64 {
    let (res, refs) = match accel {
        GridRef::Uniform(g) => (g.res, g.tri_indices.len()),
        GridRef::Irregular(g) => (g.res, g.tri_indices.len()),
    };
    walk_iterations(res, refs as u64)
}

/// The bound of one grid walk over cells `res` holding `refs` references.
fn walk_iterations(res: [u32; 3], refs: u64) -> u64 {
    16 * (res.iter().map(|&r| r as u64).sum::<u64>() + refs + 16)
}

/// Binds `tex` to `unit`.
pub fn bind_texture(gl: &glow::Context, unit: Unit, tex: &Texture) {
    state::bind_texture(gl, unit.index(), Some(tex));
}

/// Milliseconds since `t`.
pub(crate) fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}
