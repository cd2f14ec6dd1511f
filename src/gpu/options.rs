//! Options of the GPU backend: what a render asks of it ([`GpuOptions`]) and the switches it
//! is made of ([`Kernel`], [`Mask`], [`Storage`], [`SceneFetch`]).
//!
//! `Mask`, `Storage` and `SceneFetch` are plain word choices and derive `clap::ValueEnum`,
//! which gives the CLI their spellings, the error message and the `--help` list in one
//! place. `Kernel` carries a number (`unrolled:K`), which a value enum cannot express, so it
//! keeps its own `FromStr` (clap uses it through `value_parser!`) beside a matching
//! `Display`.

use super::gl::TexFormat;
use super::program_cache::ProgramCache;
use crate::technique::Techniques;

/// Options of the GPU backend.
#[derive(Clone, Copy, Debug)]
pub struct GpuOptions {
    /// Traversal iterations between two termination queries (K).
    pub query_every: u32,
    /// Measure per-pass GPU time with timer queries where the driver has them.
    pub timers: bool,
    /// Compile every shading feature in, whatever the scene needs.
    pub no_specialize: bool,
    /// Draw the fragment kernels' advancing passes over the tiles that held active rays at
    /// the last termination query only (issue 49); off, every pass covers the full-screen
    /// quad as the thesis's did. The image is the same either way; off is for the tests
    /// that check so and for measuring what the cut saves.
    pub tiles: bool,
    /// How traversal iterations map onto passes or dispatches. Default: `Auto`, the fastest
    /// kernel the context runs ([`Kernel::resolve`]); `Multipass` is the faithful GL 2.1
    /// design, and every kernel renders the same image from the same step chunk.
    pub kernel: Kernel,
    /// How rays that finished are kept out of the traversal passes.
    pub mask: Mask,
    /// Precision of the ray textures.
    pub storage: Storage,
    /// How the compute kernel reads the scene textures.
    pub scene_fetch: SceneFetch,
    /// Whether linked programs are cached as binaries between processes
    /// (`gpu::program_cache`). Off by default for library callers; the CLI's
    /// `--shader-cache` defaults to on.
    pub shader_cache: ShaderCache,
    /// Robustness techniques compiled into the programs. `render_gl` takes them from
    /// [`ImageRequest::techniques`](super::render::ImageRequest::techniques) instead;
    /// `trace_rays` uses these.
    pub techniques: Techniques,
}

impl GpuOptions {
    /// The kernel these options run in a context described by `info` (see
    /// [`Kernel::resolve`]: an explicit mask or `--storage f16` keeps `auto` on the
    /// fragment kernels, which are the ones that have them), with the options that do not
    /// apply to it refused ([`GpuOptions::refuse_inapplicable`]).
    pub fn resolve_kernel(&self, info: &super::info::GlInfo) -> crate::Result<Kernel> {
        let fragment_only =
            matches!(self.mask, Mask::EarlyZ | Mask::Stencil) || self.storage == Storage::F16;
        let kernel = self.kernel.resolve(info, fragment_only)?;
        self.refuse_inapplicable(kernel, self.kernel != Kernel::Auto)?;
        Ok(kernel)
    }

    /// The one rule for the GPU options that apply to some kernels only: a mask (early-z or
    /// stencil; `none` is what the compute kernel does anyway) and 16-bit ray textures to
    /// the fragment kernels (the compute kernel draws no passes and
    /// keeps its rays in registers), a scene fetch to the compute kernel. Each is refused
    /// with one line naming the option and why, as [`crate::Error::Usage`]; `explicit`
    /// says whether the user named `kernel` or `auto` chose it. Checked before a context is
    /// made where the kernel is named, and again once `auto` is resolved.
    pub fn refuse_inapplicable(&self, kernel: Kernel, explicit: bool) -> crate::Result<()> {
        let runs = format!(
            "this render runs {kernel} ({})",
            if explicit {
                format!("--kernel {kernel}")
            } else {
                "--kernel auto chose it".into()
            }
        );
        let why = match kernel {
            Kernel::Compute if matches!(self.mask, Mask::EarlyZ | Mask::Stencil) => Some(format!(
                "--mask {} applies to the fragment kernels' passes; {runs}, which draws none",
                self.mask
            )),
            Kernel::Compute if self.storage != Storage::F32 => Some(format!(
                "--storage {} applies to the fragment kernels' ray textures; {runs}, which \
                 keeps its rays in registers",
                self.storage
            )),
            Kernel::Multipass | Kernel::Looped | Kernel::Unrolled(_)
                if self.scene_fetch != SceneFetch::Auto =>
            {
                Some(format!(
                    "--scene-fetch {} applies to the compute kernel; {runs}, which reads the \
                     scene with texture2D",
                    self.scene_fetch
                ))
            }
            _ => None,
        };
        why.map_or(Ok(()), |m| Err(crate::Error::Usage(m)))
    }

    /// The kernel these options run, resolved once into the wing that runs it: a fragment
    /// kernel, or the compute kernel with the fragment kernel `auto` falls back to where
    /// the driver cuts the compute kernel's loops short (llvmpipe's loop limit).
    pub fn choose_kernel(&self, info: &super::info::GlInfo) -> crate::Result<KernelChoice> {
        Ok(match self.resolve_kernel(info)? {
            Kernel::Multipass => KernelChoice::Fragment(FragmentKernel::Multipass),
            Kernel::Unrolled(k) => KernelChoice::Fragment(FragmentKernel::Unrolled(k)),
            Kernel::Looped => KernelChoice::Fragment(FragmentKernel::Looped),
            Kernel::Compute => KernelChoice::Compute {
                fallback: (self.kernel == Kernel::Auto).then(|| Kernel::fastest_fragment(info)),
            },
            Kernel::Auto => unreachable!("Kernel::resolve never answers auto"),
        })
    }
}

/// Iterations of one `looped` pass at most (a bounded loop, as Shader Model 3 requires).
pub const LOOP_MAX: u32 = 1024;

/// A kernel resolved for one context: which wing of the GPU backend runs the render.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KernelChoice {
    /// Fragment passes over the full-screen quad (`gpu::fragment`).
    Fragment(FragmentKernel),
    /// One compute dispatch per band (`gpu::compute`); `fallback` is the fragment kernel
    /// that finishes the render where the driver cut the compute kernel's loops short
    /// (only when the user asked for `auto`: an explicit `compute` fails instead).
    Compute {
        /// The fragment kernel to fall back to, if any.
        fallback: Option<FragmentKernel>,
    },
}

/// The kernels that draw fragment passes: how traversal iterations map onto passes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FragmentKernel {
    /// The thesis's design: one step pass and one test pass per iteration.
    Multipass,
    /// K iterations per pass as straight-line code (no loops).
    Unrolled(u32),
    /// Up to [`LOOP_MAX`] iterations per pass in a bounded loop.
    Looped,
}

impl FragmentKernel {
    /// Traversal iterations one advancing pass performs at most (multipass: one step pass
    /// plus one test pass count as one).
    pub fn iterations_per_pass(self) -> u64 {
        match self {
            FragmentKernel::Multipass => 1,
            FragmentKernel::Unrolled(k) => k as u64,
            FragmentKernel::Looped => LOOP_MAX as u64,
        }
    }

    /// The same kernel as `--kernel` names it.
    pub fn kernel(self) -> Kernel {
        match self {
            FragmentKernel::Multipass => Kernel::Multipass,
            FragmentKernel::Unrolled(k) => Kernel::Unrolled(k),
            FragmentKernel::Looped => Kernel::Looped,
        }
    }
}

impl std::fmt::Display for FragmentKernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.kernel().fmt(f)
    }
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions {
            query_every: 8,
            timers: true,
            no_specialize: false,
            tiles: true,
            kernel: Kernel::Auto,
            mask: Mask::Auto,
            storage: Storage::F32,
            scene_fetch: SceneFetch::Auto,
            shader_cache: ShaderCache::Off,
            techniques: Techniques::default(),
        }
    }
}

/// How the compute kernel reads the scene (triangles, materials, grid): the two are
/// equally exact and render the same bits; which is faster depends on the driver.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum SceneFetch {
    /// storage buffers, except texelFetch on llvmpipe: the faster of the two where measured
    /// (docs/performance.md); texelFetch also where the context has too few storage blocks
    #[default]
    Auto,
    /// `texelFetch` from the scene textures
    TexelFetch,
    /// shader storage buffers (an error where the context has too few storage blocks)
    StorageBuffer,
}

impl std::fmt::Display for SceneFetch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SceneFetch::Auto => "auto",
            SceneFetch::TexelFetch => "texel-fetch",
            SceneFetch::StorageBuffer => "storage-buffer",
        })
    }
}

/// Whether programs go through the program-binary cache ([`ProgramCache`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum ShaderCache {
    /// link programs from their cached binaries where the driver accepts them, and store
    /// the ones compiled (in $FRAGTRACE_SHADER_CACHE_DIR, $XDG_CACHE_HOME/fragtrace or
    /// ~/.cache/fragtrace)
    #[default]
    On,
    /// compile every program from source
    Off,
}

impl ShaderCache {
    /// Environment variable giving the default of `--shader-cache` (`on` or `off`).
    pub const ENV: &'static str = "FRAGTRACE_SHADER_CACHE";

    /// The cache this choice opens on a context described by `info`: None when off, when
    /// the context offers no binary format, or when no cache folder is known.
    pub fn open(self, info: &super::info::GlInfo) -> Option<ProgramCache> {
        match self {
            ShaderCache::On => ProgramCache::open(info),
            ShaderCache::Off => None,
        }
    }
}

impl std::fmt::Display for ShaderCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ShaderCache::On => "on",
            ShaderCache::Off => "off",
        })
    }
}

/// How traversal iterations (a DDA step then a triangle test) map onto passes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// The thesis's design: one step pass and one test pass per iteration.
    Multipass,
    /// K iterations per pass as straight-line code (no loops).
    Unrolled(u32),
    /// Up to [`LOOP_MAX`] iterations per pass in a bounded loop.
    Looped,
    /// GLSL 4.30 compute: the whole ray tree of every pixel in one dispatch (GL 4.3).
    Compute,
    /// The fastest kernel the context runs: `Compute` on GL 4.3, `Looped` on GL 3.x,
    /// `Multipass` on period (GL 2.x) contexts. Resolved before a render starts.
    Auto,
}

impl Kernel {
    /// The kernel a render in a context described by `info` runs: `Auto` becomes the
    /// fastest one the context supports (compute where GL 4.3 is; a bounded loop on a GL
    /// 3.x driver; the multipass design of the period in a GL 2.x context, whose hardware
    /// had no dynamic loops to rely on), and the fastest fragment kernel when the render
    /// asks for something only those have (`fragment_only`: a mask or 16-bit ray storage);
    /// `Compute` without GL 4.3 is refused.
    pub fn resolve(self, info: &super::info::GlInfo, fragment_only: bool) -> crate::Result<Kernel> {
        match self {
            Kernel::Auto if info.compute && !fragment_only => Ok(Kernel::Compute),
            Kernel::Auto => Ok(Kernel::fastest_fragment(info).kernel()),
            Kernel::Compute if !info.compute => Err(crate::Error::GlUnavailable(format!(
                "--kernel compute needs OpenGL 4.3 and GLSL 4.30; {} offers OpenGL {} and GLSL {}",
                info.renderer, info.gl_version, info.glsl_version
            ))),
            k => Ok(k),
        }
    }

    /// The fastest fragment kernel for `info`: looped on GL 3.x and later, the multipass
    /// design of the period on GL 2.x, whose hardware had no dynamic loops to rely on.
    pub fn fastest_fragment(info: &super::info::GlInfo) -> FragmentKernel {
        if info.gl_major_minor >= (3, 0) {
            FragmentKernel::Looped
        } else {
            FragmentKernel::Multipass
        }
    }
}

impl std::str::FromStr for Kernel {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "multipass" => Ok(Kernel::Multipass),
            "looped" => Ok(Kernel::Looped),
            "compute" => Ok(Kernel::Compute),
            "auto" => Ok(Kernel::Auto),
            _ => match s.strip_prefix("unrolled:").map(str::parse::<u32>) {
                Some(Ok(k)) if (1..=64).contains(&k) => Ok(Kernel::Unrolled(k)),
                _ => Err(format!("unknown kernel `{s}` (expected auto, compute, looped, multipass, or unrolled:K with K in 1..=64)")),
            },
        }
    }
}

impl std::fmt::Display for Kernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Kernel::Multipass => write!(f, "multipass"),
            Kernel::Unrolled(k) => write!(f, "unrolled:{k}"),
            Kernel::Looped => write!(f, "looped"),
            Kernel::Compute => write!(f, "compute"),
            Kernel::Auto => write!(f, "auto"),
        }
    }
}

/// How finished rays are skipped during traversal.
///
/// Every pass early-outs on rays not in its state whatever the mask; a mask additionally
/// keeps the fragment program from running at all for rays that were inactive at the last
/// termination query, as Purcell et al. did with the depth test. The termination query's
/// count pass writes the mask as a side effect (only active rays survive its `discard`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Mask {
    /// early-z for the multipass kernel (it cut the multipass render time 3x on llvmpipe
    /// and 7x on the H200: docs/performance.md), none for the others
    #[default]
    Auto,
    /// Run every pass on every pixel and rely on the in-shader early-out.
    None,
    /// Active rays get depth 0, the rest 1; passes are drawn at depth 0.5 with
    /// `GL_GREATER`, so the early depth test culls finished rays before shading.
    EarlyZ,
    /// Active rays get stencil 1; passes are drawn with `GL_EQUAL 1`.
    Stencil,
}

impl Mask {
    /// The mask a render with `kernel` uses: `Auto` resolved, the others as given.
    pub fn resolve(self, kernel: FragmentKernel) -> Mask {
        match (self, kernel) {
            (Mask::Auto, FragmentKernel::Multipass) => Mask::EarlyZ,
            (Mask::Auto, _) => Mask::None,
            (m, _) => m,
        }
    }
}

impl std::fmt::Display for Mask {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Mask::Auto => "auto",
            Mask::None => "none",
            Mask::EarlyZ => "early-z",
            Mask::Stencil => "stencil",
        })
    }
}

/// Precision of the textures that carry rays between passes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
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
    pub(crate) fn state_formats(self) -> [TexFormat; 4] {
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
    pub(crate) fn colour_format(self) -> TexFormat {
        match self {
            Storage::F32 => TexFormat::Rgba32F,
            Storage::F16 => TexFormat::Rgba16F,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::ValueEnum;

    /// The derived spellings are the ones the hand-written parsers accepted.
    #[test]
    fn option_spellings() {
        for (s, m) in [
            ("auto", Mask::Auto),
            ("none", Mask::None),
            ("early-z", Mask::EarlyZ),
            ("stencil", Mask::Stencil),
        ] {
            assert_eq!(Mask::from_str(s, false), Ok(m));
            assert_eq!(m.to_string(), s);
        }
        for (s, v) in [("f32", Storage::F32), ("f16", Storage::F16)] {
            assert_eq!(Storage::from_str(s, false), Ok(v));
            assert_eq!(v.to_string(), s);
        }
        assert!(Mask::from_str("earlyz", false).is_err());
        for k in [
            Kernel::Multipass,
            Kernel::Looped,
            Kernel::Unrolled(7),
            Kernel::Compute,
            Kernel::Auto,
        ] {
            assert_eq!(k.to_string().parse::<Kernel>(), Ok(k));
        }
        assert!("unrolled:65".parse::<Kernel>().is_err());
    }
}

/// `--gpu`'s value: an EGL device by its number, or `env`, the one the batch scheduler's
/// variables give the task (`gpu::device`, resolved when the options are made).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuChoice {
    /// Device N of the EGL device list (`fragtrace info` lists them).
    Index(u32),
    /// From `CUDA_VISIBLE_DEVICES`, Slurm's GPU ids or the local rank.
    Env,
}

impl std::str::FromStr for GpuChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "env" {
            return Ok(GpuChoice::Env);
        }
        s.parse::<u32>().map(GpuChoice::Index).map_err(|_| {
            format!("`{s}` is neither a device number (0, 1, ...) nor env (the GPU the batch scheduler gave the task)")
        })
    }
}

impl std::fmt::Display for GpuChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GpuChoice::Index(n) => write!(f, "{n}"),
            GpuChoice::Env => f.write_str("env"),
        }
    }
}
