//! The user's choices for one render, as every front door takes them: [`Choices`] is the
//! one set of render flags (one help text and one range each) that `render`, `bench`'s
//! configurations and `view` flatten into their arguments, and [`Choices::to_options`] the
//! one conversion into [`RenderOptions`], through the one rule for flags that do not apply
//! ([`Choices::check`]).
//!
//! Flags whose default is a value rather than `auto` (`--precision`, `--cpu-path`,
//! `--storage`, `--query-every`, `--spp`) are `Option`s here, so that the rule can tell a
//! flag the user gave from its default; the defaults are filled in by `to_options`.

use std::path::PathBuf;

use clap::{Args, Parser};

use crate::accel::{AccelKind, GridConfig, GridRes};
use crate::gpu::options::{GpuChoice, Kernel, Mask, SceneFetch, ShaderCache, Storage};
use crate::options::{
    check_range, AccelChoice, Backend, CpuPath, Precision, RenderOptions, TextureMode, MAX_DEPTH,
    MAX_IMAGE_SIDE, MAX_QUERY_EVERY, MAX_SPP,
};
use crate::scene::Scene;
use crate::technique::{IntersectMethod, OffsetMethod, TBound, Techniques, Terminator};
use crate::{Error, Result};

/// The front door a render's choices came through: what it renders on and which flags it
/// has, so that a refusal's advice names only flags that door takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Door {
    /// `fragtrace render` (and the default command).
    Render,
    /// A `fragtrace bench` configuration (`render`'s flags in a string).
    Bench,
    /// `fragtrace view`: always the GPU, in the window's own GL context.
    View,
    /// `fragtrace dump-shaders`: the GPU's programs for the structure and techniques
    /// chosen, every kernel's, written rather than run.
    DumpShaders,
    /// The web page (docs/web.md): its query's `key=value` pairs are these flags
    /// ([`crate::query`]); WebGL, so the fragment kernels only.
    Web,
}

impl Door {
    /// The samples per pixel when `--spp` is not given: one for an image, sixteen
    /// accumulated while the window's camera stands still.
    pub fn default_spp(self) -> u32 {
        match self {
            Door::Render | Door::Bench | Door::DumpShaders | Door::Web => 1,
            Door::View => 16,
        }
    }

    /// The front door as its refusals name it (`` `view` ``, the web page); None for
    /// `render`'s flags (a bench configuration is `render`'s flags too).
    fn command(self) -> Option<&'static str> {
        match self {
            Door::Render | Door::Bench => None,
            Door::View => Some("`view`"),
            Door::DumpShaders => Some("`dump-shaders`"),
            Door::Web => Some("the web page"),
        }
    }
}

/// Traversal iterations between termination queries when `--query-every` is not given.
pub const DEFAULT_QUERY_EVERY: u32 = 8;

/// The render flags every front door shares (`#[command(flatten)]`).
#[derive(Args, Debug, Clone)]
pub struct Choices {
    /// Image width (default: the scene's; `view`: the window's initial width).
    #[arg(long, allow_negative_numbers = true, value_parser = count_in(1, MAX_IMAGE_SIDE))]
    pub width: Option<u32>,
    /// Image height (default: the scene's; `view`: the window's initial height).
    #[arg(long, allow_negative_numbers = true, value_parser = count_in(1, MAX_IMAGE_SIDE))]
    pub height: Option<u32>,
    /// Renderer: auto, cpu or gl (`view` renders on the GPU: auto or gl).
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
    /// CPU arithmetic: f32 (the default: mirrors the GPU, within a stated bound of f64 on
    /// every shipped scene) or f64 (the ground truth).
    #[arg(long, value_enum)]
    pub precision: Option<Precision>,
    /// The f32 CPU's walk: packet (the default: ray packets through the BVH, 16 rays with
    /// AVX-512 or 8 with AVX2; the grids and other CPUs take simd), simd (one ray at a
    /// time, triangles 8 or 4 at a time, AVX2 or SSE2) or scalar (the GLSL's twin); all
    /// three give the same image. f64 is always scalar.
    #[arg(long, value_enum)]
    pub cpu_path: Option<CpuPath>,
    /// Maximum reflection/refraction depth (default: the scene's, else 5; `view`: keys
    /// `+`/`-`).
    #[arg(long, allow_negative_numbers = true, value_parser = count_in(0, MAX_DEPTH))]
    pub max_depth: Option<u32>,
    /// Samples per pixel (stratified, fixed seed; default 1; `view`: 16, accumulated while
    /// the camera stands still).
    #[arg(long, allow_negative_numbers = true, value_parser = count_in(1, MAX_SPP))]
    pub spp: Option<u32>,
    /// Textures: on (the default: what the files say; a texture that cannot be read is one
    /// warning line and its material renders with its colour), off (every material with
    /// its colour alone: the untextured twin of a scene) or strict (an unreadable texture
    /// is an error, for CI).
    #[arg(long, value_enum, default_value_t = TextureMode::On)]
    pub textures: TextureMode,
    /// Acceleration structure: auto (the default: the irregular grid on the GPU, the BVH
    /// on the CPU, each the fastest there, with the same images; the irregular grid on both
    /// when a grid density is given), irregular (adaptive cells with exit boxes grown over empty
    /// space, after Perard-Gayot et al. 2017), uniform (the thesis's grid over the scene
    /// box) or bvh (CPU backend only: a 4-wide BVH).
    #[arg(long, value_enum, default_value_t = AccelChoice::default())]
    pub accel: AccelChoice,
    /// Uniform grid resolution: auto or AxBxC (with --accel uniform).
    #[arg(long, default_value = "auto")]
    pub grid: GridRes,
    /// Cells per triangle of the auto uniform grid (lambda, default 8; with --accel
    /// uniform), or top cells per triangle of the irregular grid (default 0.125).
    #[arg(long, allow_negative_numbers = true)]
    pub grid_density: Option<f32>,
    /// GPU: traversal iterations between termination queries (K; default 8).
    #[arg(long, allow_negative_numbers = true, value_parser = count_in(1, MAX_QUERY_EVERY))]
    pub query_every: Option<u32>,
    /// GPU: kernel: auto (the fastest the context runs: compute on GL 4.3, looped on GL 3.x,
    /// multipass on GL 2.x), compute (GLSL 4.30: the whole ray tree per pixel in one
    /// dispatch), looped (bounded loop per pass), multipass (the thesis: one step per pass,
    /// no loops) or unrolled:K (K steps per pass, straight-line code, no loops). All render
    /// the same image (`view`: key `k` switches).
    #[arg(long, default_value = "auto")]
    pub kernel: Kernel,
    /// GPU: compile every shading feature in instead of only what the scene needs.
    #[arg(long)]
    pub no_specialize: bool,
    /// GPU, fragment kernels: keep finished rays out of traversal passes with the depth
    /// test (early-z) or the stencil test, refreshed at each termination query; none relies
    /// on the in-shader early-out alone; auto is early-z for the multipass kernel and none
    /// for the others (`view`: key `z`).
    #[arg(long, default_value = "auto")]
    pub mask: Mask,
    /// GPU, fragment kernels: ray textures in 32- (the default) or 16-bit floats (f16: ray
    /// directions and the colour sum; origins and every index stay in 32-bit textures).
    #[arg(long)]
    pub storage: Option<Storage>,
    /// GPU, compute kernel: how it reads the scene, through texelFetch or storage buffers;
    /// auto is the faster where measured (storage buffers on NVIDIA, texelFetch on
    /// llvmpipe), storage buffers elsewhere. Both render the same image.
    #[arg(long, value_enum, default_value_t = SceneFetch::Auto)]
    pub scene_fetch: SceneFetch,
    /// Ray-triangle test: watertight (Woop et al. 2013, the default) or moller-trumbore
    /// (1997; rays can slip through shared edges). For measuring the technique's cost.
    #[arg(long, value_enum, default_value_t = IntersectMethod::Watertight)]
    pub intersect: IntersectMethod,
    /// pbrt's t error bound on hits (on, the default) or off (spawned rays may re-hit
    /// their own surface). For measuring the technique's cost.
    #[arg(long, value_enum, default_value_t = TBound::On)]
    pub t_bound: TBound,
    /// Origin offset of spawned rays: error-bound (scale-independent, the default) or
    /// epsilon (a fixed 1e-4 along the normal). For measuring the technique's cost.
    #[arg(long, value_enum, default_value_t = OffsetMethod::ErrorBound)]
    pub offset: OffsetMethod,
    /// Shadow rays of smooth-shaded meshes: smooth (skip the neighbouring triangles' folds
    /// under the surface the vertex normals describe; the default: no dark speckles near
    /// the terminator) or exact (test from the triangle on). For measuring the technique's
    /// cost and value.
    #[arg(long, value_enum, default_value_t = Terminator::Smooth)]
    pub terminator: Terminator,
    /// GPU: keep linked programs as binaries in the user's cache folder, so the next run
    /// skips compiling them (on), or compile every program (off). Default: on, or
    /// $FRAGTRACE_SHADER_CACHE (on|off).
    #[arg(long, value_enum)]
    pub shader_cache: Option<ShaderCache>,
    /// GPU: render on EGL device N (`fragtrace info` lists them), or `env`: the GPU the
    /// batch scheduler gave the task (CUDA_VISIBLE_DEVICES, SLURM_STEP_GPUS,
    /// SLURM_JOB_GPUS, GPU_DEVICE_ORDINAL, the local rank SLURM_LOCALID:
    /// docs/distributed.md); default: the first display that works.
    #[arg(long, value_name = "N|env", allow_negative_numbers = true)]
    pub gpu: Option<GpuChoice>,
}

impl Choices {
    /// The GPU-only flags given, as they were spelled: what a CPU render refuses.
    fn gpu_flags(&self) -> Vec<String> {
        let mut given = Vec::new();
        if let Some(n) = self.gpu {
            given.push(format!("--gpu {n}"));
        }
        if self.kernel != Kernel::Auto {
            given.push(format!("--kernel {}", self.kernel));
        }
        if self.mask != Mask::Auto {
            given.push(format!("--mask {}", self.mask));
        }
        if let Some(s) = self.storage {
            given.push(format!("--storage {s}"));
        }
        if self.scene_fetch != SceneFetch::Auto {
            given.push(format!("--scene-fetch {}", self.scene_fetch));
        }
        if let Some(k) = self.query_every {
            given.push(format!("--query-every {k}"));
        }
        if self.no_specialize {
            given.push("--no-specialize".into());
        }
        if let Some(c) = self.shader_cache {
            given.push(format!("--shader-cache {c}"));
        }
        given
    }

    /// The EGL device `--gpu` names: N, or the one the scheduler's variables give
    /// (`--gpu env`, [`crate::gpu::device`]: a variable naming no device present is a usage
    /// error naming those there are).
    pub fn device(&self) -> Result<Option<u32>> {
        match self.gpu {
            None => Ok(None),
            Some(GpuChoice::Index(n)) => Ok(Some(n)),
            #[cfg(not(target_arch = "wasm32"))]
            Some(GpuChoice::Env) => crate::gpu::device::from_env()
                .map(|p| Some(p.index))
                .map_err(Error::Usage),
            #[cfg(target_arch = "wasm32")]
            Some(GpuChoice::Env) => Err(Error::Usage(
                "--gpu env: a web page has no EGL devices".into(),
            )),
        }
    }

    /// The CPU-only flags given: what a GPU render refuses.
    fn cpu_flags(&self) -> Vec<String> {
        let mut given = Vec::new();
        if let Some(p) = self.precision {
            given.push(format!("--precision {}", p.name()));
        }
        if let Some(p) = self.cpu_path {
            given.push(format!("--cpu-path {}", p.name()));
        }
        given
    }

    /// The one rule for flags that do not apply to the backend or kernel chosen: each is
    /// refused with one line saying why, and advice that names only flags `door` has.
    /// Flags whose use is only known once the GL context is made (a mask or a scene fetch
    /// under `--kernel auto`) are refused by the same words when the kernel is resolved
    /// ([`crate::gpu::options::GpuOptions::resolve_kernel`]); under `--backend auto`,
    /// either backend's flags are accepted, since either may run.
    pub fn check(&self, door: Door) -> Result<()> {
        let command = door.command();
        let gpu_only = command.is_some() || self.backend == Backend::Gl;
        if let Some(cmd) = command {
            if self.backend == Backend::Cpu {
                return Err(Error::Usage(format!(
                    "--backend cpu: {cmd} is for the GPU; `fragtrace render --backend cpu` \
                     renders on the CPU"
                )));
            }
            if let Some(n) = self.gpu {
                return Err(Error::Usage(format!(
                    "--gpu {n} picks the EGL device of a headless render; {cmd} opens \
                     none: drop --gpu"
                )));
            }
        }
        if door == Door::Bench && self.textures != TextureMode::On {
            // The bench loads each scene once for all its configurations.
            return Err(Error::Usage(format!(
                "--textures {}: the bench loads each scene once, with its textures; time \
                 `fragtrace render --textures off --stats FILE` for the untextured twin",
                clap::ValueEnum::to_possible_value(&self.textures)
                    .map_or_else(String::new, |v| v.get_name().to_owned())
            )));
        }
        if door == Door::DumpShaders {
            // Every kernel's programs are written, whatever the kernel, mask or storage, and
            // the size, samples, depth and query interval are uniforms, not source.
            if let Some(flag) = self.dump_unused().first() {
                let what = flag.split(' ').next().unwrap_or(flag);
                return Err(Error::Usage(format!(
                    "{flag} does not change the programs `dump-shaders` writes (every \
                     kernel's, for the structure and techniques chosen): drop {what}"
                )));
            }
        }
        if self.backend == Backend::Cpu {
            if let Some(flag) = self.gpu_flags().first() {
                return Err(Error::Usage(format!(
                    "{flag} applies to the GPU backend; --backend cpu renders on the CPU: \
                     drop it, or take --backend gl"
                )));
            }
        }
        if gpu_only {
            if let Some(flag) = self.cpu_flags().first() {
                let what = flag.split(' ').next().unwrap_or(flag);
                return Err(Error::Usage(match command {
                    Some(cmd) => format!(
                        "{flag} applies to the CPU backend; {cmd} is for the GPU, in f32: \
                         drop {what}"
                    ),
                    None => format!(
                        "{flag} applies to the CPU backend; --backend gl renders on the GPU, \
                         in f32: drop {what}, or take --backend cpu"
                    ),
                }));
            }
            if self.accel == AccelChoice::Bvh {
                return Err(Error::Usage(match command {
                    Some(cmd) => format!(
                        "--accel bvh is walked on the CPU backend only; {cmd} is for the \
                         GPU: take --accel irregular or uniform"
                    ),
                    None => "--accel bvh is walked on the CPU backend only: take --backend \
                             cpu, or --accel irregular for the GPU"
                        .into(),
                }));
            }
        }
        if door == Door::Web {
            self.check_web()?;
        }
        if self.kernel != Kernel::Auto {
            self.gpu_options().refuse_inapplicable(self.kernel, true)?;
        }
        self.check_ranges()
    }

    /// What WebGL lacks: compute shaders (the compute kernel and its scene fetch), 16-bit
    /// float render targets (`--storage`), and the page compiles only what the scene needs.
    fn check_web(&self) -> Result<()> {
        let lacks = |flag: String, what: &str| {
            Err(Error::Usage(format!(
                "{flag}: WebGL has no {what}; the web page runs the fragment kernels \
                 (--kernel auto, looped, multipass or unrolled:K)"
            )))
        };
        if self.kernel == Kernel::Compute {
            return lacks("--kernel compute".into(), "compute shaders");
        }
        if self.scene_fetch != SceneFetch::Auto {
            let flag = format!("--scene-fetch {}", self.scene_fetch);
            return lacks(flag, "compute shaders, which the scene fetch is for");
        }
        if let Some(s) = self.storage {
            return lacks(format!("--storage {s}"), "choice of ray texture precision");
        }
        if self.no_specialize {
            return Err(Error::Usage(
                "--no-specialize: the web page compiles only what the scene needs: drop it".into(),
            ));
        }
        Ok(())
    }

    /// The ranges of the counts given, in [`check_range`]'s words (the parser only
    /// refuses what is not a whole number, so `--width 0` says which range it left).
    fn check_ranges(&self) -> Result<()> {
        for (flag, v, lo, hi) in [
            ("width", self.width, 1, MAX_IMAGE_SIDE),
            ("height", self.height, 1, MAX_IMAGE_SIDE),
            ("spp", self.spp, 1, MAX_SPP),
            ("max-depth", self.max_depth, 0, MAX_DEPTH),
            ("query-every", self.query_every, 1, MAX_QUERY_EVERY),
        ] {
            if let Some(v) = v {
                check_range(flag, v, lo, hi)?;
            }
        }
        Ok(())
    }

    /// The flags given that do not change the programs `dump-shaders` writes.
    fn dump_unused(&self) -> Vec<String> {
        let mut given: Vec<String> = self
            .gpu_flags()
            .into_iter()
            .filter(|f| f != "--no-specialize")
            .collect();
        for (flag, v) in [
            ("--width", self.width),
            ("--height", self.height),
            ("--spp", self.spp),
            ("--max-depth", self.max_depth),
        ] {
            if let Some(v) = v {
                given.push(format!("{flag} {v}"));
            }
        }
        given
    }

    /// The GPU backend's options these choices ask for (defaults filled in).
    fn gpu_options(&self) -> crate::gpu::options::GpuOptions {
        crate::gpu::options::GpuOptions {
            query_every: self.query_every.unwrap_or(DEFAULT_QUERY_EVERY),
            no_specialize: self.no_specialize,
            kernel: self.kernel,
            mask: self.mask,
            storage: self.storage.unwrap_or_default(),
            scene_fetch: self.scene_fetch,
            shader_cache: self.shader_cache.unwrap_or_else(shader_cache_default),
            ..Default::default()
        }
    }

    /// Turns the choices made at `door` into render options for `scene`: the flags that do
    /// not apply refused ([`Choices::check`]), the ranges the parser leaves open (grid
    /// density, sizes and counts) checked, and each default filled in.
    pub fn to_options(&self, scene: &Scene, door: Door) -> Result<RenderOptions> {
        self.check(door)?;
        let mut opts = RenderOptions::for_scene(scene);
        opts.width = self.width.unwrap_or(scene.width);
        opts.height = self.height.unwrap_or(scene.height);
        opts.spp = self.spp.unwrap_or(door.default_spp());
        opts.max_depth = self.max_depth.unwrap_or(scene.max_depth);
        opts.precision = self.precision.unwrap_or_default();
        opts.cpu_path = self.cpu_path.unwrap_or_default();
        opts.backend = match door {
            Door::View | Door::DumpShaders | Door::Web => Backend::Gl,
            Door::Render | Door::Bench => self.backend,
        };
        // `auto` with a density asks for a grid: the irregular one, on either backend.
        // Otherwise `auto` stays `auto` until the backend is settled (`crate::plan`).
        opts.accel = match (self.accel, self.grid_density) {
            (AccelChoice::Auto, Some(_)) => AccelChoice::Irregular,
            (choice, _) => choice,
        };
        let mut grid = GridConfig {
            res: self.grid,
            ..GridConfig::default()
        };
        if let Some(d) = self.grid_density {
            if !(d.is_finite() && d > 0.0 && d <= 1024.0) {
                return Err(Error::Usage(format!(
                    "--grid-density {d} is outside (0, 1024]"
                )));
            }
            match opts.accel.named() {
                Some(AccelKind::Uniform) => grid.density = d,
                Some(AccelKind::Irregular) => opts.irregular.top_density = d,
                Some(AccelKind::Bvh) | None => {
                    return Err(Error::Usage(
                        "--grid-density sets a grid's cells; the BVH has none".into(),
                    ))
                }
            }
        }
        if opts.accel != AccelChoice::Uniform && self.grid != GridRes::Auto {
            return Err(Error::Usage(format!(
                "--grid {} sets the uniform grid; add --accel uniform",
                self.grid
            )));
        }
        opts.grid = grid;
        opts.gpu = self.gpu_options();
        opts.device = self.device()?;
        opts.techniques = Techniques {
            intersect: self.intersect,
            t_bound: self.t_bound,
            offset: self.offset,
            terminator: self.terminator,
        };
        // The memory limit applies to the pixels a process renders, which a tile learns
        // later (`RenderOptions::check_memory` then).
        opts.check_flags()?;
        Ok(opts)
    }
}

/// Arguments of `render`.
#[cfg(not(target_arch = "wasm32"))]
#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// Scene file (TOML); the built-in default scene when omitted.
    pub scene: Option<PathBuf>,
    /// Output image, by extension: .png or .ppm (sRGB 8-bit), .jpg/.jpeg (sRGB 8-bit,
    /// lossy, quality 95), .exr or .tif/.tiff (linear 32-bit float), .hdr (Radiance RGBE,
    /// linear).
    #[arg(short, long, default_value = "render.png")]
    pub output: PathBuf,
    /// The render's choices, shared with `view` and the bench's configurations.
    #[command(flatten)]
    pub choices: Choices,
    /// Write primary-ray AOVs next to the image: any of depth,normal,primid,steps
    /// (`<stem>.aov.exr`, and a PNG preview of each, `<stem>.<aov>.png`: depth as grey,
    /// normals as colour, primid in false colour, steps as a heat map).
    #[arg(long)]
    pub aov: Option<String>,
    /// Write render statistics as JSON to this file.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Make the folders of -o and --stats when missing (parts and frames always make
    /// theirs); without it a missing folder is refused before anything is rendered, so a
    /// typo costs nothing.
    #[arg(long)]
    pub mkdir: bool,
    /// Which parts of the image this process renders (`--tile`, `--region`,
    /// `--task-index`, `--tiles`).
    #[command(flatten)]
    pub parts: crate::farm::plan::PartArgs,
    /// Render the frames A..B (both included), A..B:S (every S-th), A,B,C (a list of
    /// these), or all, of the scene's camera path (the scene file's `[animation]` table),
    /// uploading the scene once; -o names each frame with a run of # (out/frame_####.png)
    /// or {frame}.
    #[arg(long, value_name = "A..B[:S],...|all")]
    pub frames: Option<crate::options::FrameRange>,
    /// Print nothing but errors (no progress display, no summary); not with -v.
    #[arg(short, long, conflicts_with = "verbose")]
    pub quiet: bool,
    /// After the render, log each pass kind's count and GPU time (or the CPU's work).
    #[arg(short, long)]
    pub verbose: bool,
}

/// `render`'s arguments as a command of their own, for parsing lists of them.
#[cfg(not(target_arch = "wasm32"))]
#[derive(Parser)]
#[command(name = "render")]
struct RenderArgsParser {
    #[command(flatten)]
    inner: RenderArgs,
}

#[cfg(not(target_arch = "wasm32"))]
impl RenderArgs {
    /// Parses `render` arguments from a list (a bench configuration's, for one), returning
    /// [`Error::Usage`] with clap's one-line message instead of exiting.
    pub fn try_parse_from_args<S: AsRef<str>>(args: &[S]) -> Result<Self> {
        let all = std::iter::once("render").chain(args.iter().map(|a| a.as_ref()));
        RenderArgsParser::try_parse_from(all)
            .map(|p| p.inner)
            .map_err(|e| {
                // The first line and the accepted values; clap's tips are about typing a
                // command line, not a configuration string.
                let lines = clap_error_lines(&e)
                    .into_iter()
                    .enumerate()
                    .filter(|(i, l)| *i == 0 || l.starts_with("[possible values"))
                    .map(|(_, l)| l)
                    .collect();
                Error::Usage(join_clap_lines(lines))
            })
    }

    /// The options that choose the backend and open its context, from the flags alone,
    /// before the scene is loaded ([`crate::overlap::render_loading`] opens the context
    /// while the scene loads): an empty scene stands in for what a scene gives (size,
    /// depth), which the choice does not read. None where these flags refuse that stand-in
    /// (the scene's own options say why, after its load, as before).
    pub fn context_options(&self) -> Option<RenderOptions> {
        let stand_in = Scene::empty(crate::scene::Camera {
            eye: glam::Vec3::Z,
            look_at: glam::Vec3::ZERO,
            up: glam::Vec3::Y,
            vfov_deg: 45.0,
        });
        self.to_options(&stand_in).ok()
    }

    /// Turns the flags into render options for `scene` ([`Choices::to_options`] at
    /// `render`'s door), with the progress display unless `-q` (and then `--gpu env`'s
    /// device and why on stderr).
    pub fn to_options(&self, scene: &Scene) -> Result<RenderOptions> {
        let mut opts = self.choices.to_options(scene, Door::Render)?;
        opts.progress = !self.quiet;
        if self.choices.gpu == Some(GpuChoice::Env) && !self.quiet {
            // A task's log says which device the scheduler's variables gave it, once.
            static TOLD: std::sync::Once = std::sync::Once::new();
            if let Ok(p) = crate::gpu::device::from_env() {
                TOLD.call_once(|| eprintln!("{}", p.why));
            }
        }
        Ok(opts)
    }
}

/// The parser of a count flag whose valid values are `lo..=hi`. Negative numbers reach it
/// (the flags allow them) so that `--width -5` says what is wrong with -5 instead of clap's
/// "unexpected argument" and its tip to write `-- -5`. It refuses negative numbers
/// and non-numbers, naming that range (so `--width -5` does not suggest that 0 would do);
/// the range itself is checked with the other options ([`RenderOptions::validate`]), whose
/// message names the flag and the same range.
pub fn count_in(
    lo: u32,
    hi: u32,
) -> impl Fn(&str) -> std::result::Result<u32, String> + Clone + Send + Sync + 'static {
    move |s: &str| {
        s.parse::<u32>()
            .map_err(|_| match s.trim().parse::<i128>() {
                Ok(v) if v < 0 => {
                    format!("{v} is negative; a whole number in {lo}..={hi} is expected")
                }
                _ => format!("`{s}` is not a whole number in {lo}..={hi}"),
            })
    }
}

/// A clap error as one line: clap's own first line without its `error:` prefix and any
/// further lines of explanation (possible values, a tip), not the usage block.
pub fn clap_error_line(e: &clap::Error) -> String {
    join_clap_lines(clap_error_lines(e))
}

/// The lines of a clap error before its usage block, trimmed, without the `error:` prefix;
/// the error kind when clap gave no text.
fn clap_error_lines(e: &clap::Error) -> Vec<String> {
    let rendered = e.render().to_string();
    let mut parts: Vec<String> = Vec::new();
    for line in rendered.lines().map(str::trim) {
        if line.starts_with("Usage:") || line.starts_with("For more information") {
            break;
        }
        if line.is_empty() {
            continue;
        }
        // clap suggests `-- -5` for a value that looks like a flag; after `--` it would be
        // read as the scene file, so the tip misleads.
        if line.starts_with("tip: to pass '") && line.contains("use '-- ") {
            continue;
        }
        parts.push(line.strip_prefix("error: ").unwrap_or(line).to_owned());
    }
    if parts.is_empty() {
        parts.push(format!("{}", e.kind()));
    }
    parts
}

/// Joins message lines with `: ` (one space after a line that already ends in a colon).
fn join_clap_lines(parts: Vec<String>) -> String {
    let mut out = String::new();
    for p in parts {
        if !out.is_empty() {
            out += if out.ends_with(':') { " " } else { ": " };
        }
        out += &p;
    }
    out
}

/// `--shader-cache`'s default: `$FRAGTRACE_SHADER_CACHE` where it says `on` or `off`,
/// else on (an unknown value is named on stderr and ignored, as a cache is never needed
/// for a right image).
fn shader_cache_default() -> ShaderCache {
    match std::env::var(ShaderCache::ENV).as_deref() {
        Ok("off") => ShaderCache::Off,
        Ok("on") | Ok("") | Err(_) => ShaderCache::On,
        Ok(v) => {
            eprintln!(
                "{}={v} is neither on nor off: the shader cache stays on",
                ShaderCache::ENV
            );
            ShaderCache::On
        }
    }
}

#[cfg(test)]
#[path = "choices_tests.rs"]
mod tests;
