//! Render options: [`RenderOptions`] (what one render needs, whoever asks), the word
//! choices it is made of ([`Backend`], [`Precision`], [`CpuPath`], [`AccelChoice`]) and the
//! limits every backend checks before allocating. The flags that fill them are
//! [`crate::choices`]'s; what a render runs, once resolved, is [`crate::plan::Plan`].
//!
//! This module sits below the renderers' front door (and above the backends, whose options
//! it carries), so neither the command line nor the bench is imported here.

use clap::ValueEnum;
use serde::Serialize;

use crate::accel::{AccelKind, GridConfig, IrregularConfig};
use crate::gpu::options::{Kernel, Mask, Storage};
use crate::region::Region;
use crate::scene::Scene;
use crate::{Error, Result};

/// Which renderer runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Backend {
    /// The GPU when a suitable GL context can be made on a GPU, else the CPU with a notice
    /// saying why (a software rasterizer such as llvmpipe runs GL on the CPU, slower than
    /// the CPU backend; `--backend gl` uses it anyway); `fragtrace info` says which.
    Auto,
    /// The CPU reference renderer.
    Cpu,
    /// The GPU renderer over EGL, with the kernel of --kernel (auto: compute on GL 4.3,
    /// looped on GL 3.x, the GLSL 1.20 multipass on GL 2.1); fails rather than falling back.
    Gl,
}

/// Arithmetic precision of the CPU renderer.
///
/// The default is f32, the fastest path (ray packets on the BVH), because its error
/// against the f64 reference stays below a stated bound on every shipped scene and on the
/// hard cases (`tests/cpu_reference.rs`, `f32_default_is_within_its_bound_of_f64`; the
/// figures in docs/performance.md); f64 stays the reference (`--precision f64`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// Single precision, as the GPU computes: the default.
    #[default]
    F32,
    /// Double precision: the ground truth.
    F64,
}

/// How the f32 CPU renderer tests triangles (`--cpu-path`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum CpuPath {
    /// Ray packets: batches of rays walk the BVH 16 (AVX-512) or 8 (AVX2) at a time,
    /// chosen at run time, each box and triangle test one vector operation for the whole
    /// packet; the same hits and images as scalar (the `steps` AOV counts the packet's
    /// work). The grids, and CPUs without AVX2, take `simd`.
    #[default]
    Packet,
    /// Vectorised one ray at a time: each cell's or leaf's triangles 8 (AVX2) or 4 (SSE2)
    /// at a time, chosen at run time; the same hits, images and counters as scalar.
    Simd,
    /// One triangle at a time: the twin of the GLSL code.
    Scalar,
}

impl Precision {
    /// The name `--precision` takes.
    pub fn name(self) -> &'static str {
        match self {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        }
    }
}

impl CpuPath {
    /// The name `--cpu-path` takes.
    pub fn name(self) -> &'static str {
        match self {
            CpuPath::Packet => "packet",
            CpuPath::Simd => "simd",
            CpuPath::Scalar => "scalar",
        }
    }
}

/// The structure `--accel` asks for: one by name, or `auto`, the fastest for the backend
/// that renders (the irregular grid on the GPU, the BVH on the CPU).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum AccelChoice {
    /// The irregular grid on the GPU (the structure its kernels walk fastest), the BVH on
    /// the CPU (3-4x faster to walk there, and 6x faster to build, with the same images);
    /// the irregular grid on both when a grid density is given.
    #[default]
    Auto,
    /// The thesis's uniform grid.
    Uniform,
    /// The irregular grid.
    Irregular,
    /// The 4-wide BVH (CPU backend only).
    Bvh,
}

impl AccelChoice {
    /// The structure named, or None for `auto`.
    pub fn named(self) -> Option<AccelKind> {
        match self {
            AccelChoice::Auto => None,
            AccelChoice::Uniform => Some(AccelKind::Uniform),
            AccelChoice::Irregular => Some(AccelKind::Irregular),
            AccelChoice::Bvh => Some(AccelKind::Bvh),
        }
    }
}

impl From<AccelKind> for AccelChoice {
    fn from(k: AccelKind) -> Self {
        match k {
            AccelKind::Uniform => AccelChoice::Uniform,
            AccelKind::Irregular => AccelChoice::Irregular,
            AccelKind::Bvh => AccelChoice::Bvh,
        }
    }
}

impl AccelChoice {
    /// The structure a render on the GPU (`gpu`) or on the CPU builds: the one named, or
    /// for `auto` the fastest there. The one place `auto` is resolved, once the backend is
    /// settled ([`crate::plan::Plan::resolve`], [`RenderOptions::on_backend`]).
    pub fn resolve(self, gpu: bool) -> AccelKind {
        match (self.named(), gpu) {
            (Some(kind), _) => kind,
            (None, true) => AccelKind::Irregular,
            (None, false) => AccelKind::Bvh,
        }
    }
}

/// Largest image side accepted (checked before allocating anything).
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// Host memory one render may need at most; checked before allocating anything.
pub const MAX_HOST_BYTES: u64 = 8 << 30;
/// Upper estimate of the host bytes a render needs per pixel: the radiance and AOV rows
/// and their assembled copies on the CPU, or the read-back textures on the GPU, plus the
/// encoded image.
pub const HOST_BYTES_PER_PIXEL: u64 = 128;
/// Largest sample count per pixel.
pub const MAX_SPP: u32 = 1024;
/// Largest recursion depth.
pub const MAX_DEPTH: u32 = 16;
/// Largest `--query-every`: traversal iterations between termination queries.
pub const MAX_QUERY_EVERY: u32 = 4096;

/// The one range check of a count flag, in the one message every front door gives:
/// `--spp 0 is outside 1..=1024`.
pub fn check_range(flag: &str, v: u32, lo: u32, hi: u32) -> Result<()> {
    if (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(Error::Usage(format!("--{flag} {v} is outside {lo}..={hi}")))
    }
}

/// Everything that controls one render.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel (stratified, fixed seed).
    pub spp: u32,
    /// Maximum recursion depth (reflection/refraction bounces).
    pub max_depth: u32,
    /// CPU arithmetic precision.
    pub precision: Precision,
    /// Vectorised or scalar triangle tests on the CPU in f32 (f64 is always scalar).
    pub cpu_path: CpuPath,
    /// Which acceleration structure is built: one by name, or `auto`, which follows the
    /// backend that renders ([`AccelChoice::resolve`], once the backend is settled).
    pub accel: AccelChoice,
    /// Uniform grid resolution and density.
    pub grid: GridConfig,
    /// Irregular grid parameters.
    pub irregular: IrregularConfig,
    /// Which renderer runs.
    pub backend: Backend,
    /// GPU backend options.
    pub gpu: crate::gpu::options::GpuOptions,
    /// Show a progress display on stderr (only drawn when stderr is a terminal).
    pub progress: bool,
    /// Robustness techniques, on every backend (the GL render uses these, not
    /// `gpu.techniques`).
    pub techniques: crate::technique::Techniques,
    /// What to read back (default: everything; the CLI asks for less).
    pub readback: crate::output::Readback,
    /// Render only these pixels of the `width` x `height` image (`--tile`, `--region`);
    /// each is bit-identical to the same pixel of the whole render. None: the whole image.
    pub region: Option<Region>,
    /// The EGL device the GL backend opens (`--gpu N`); None: the first display that works.
    pub device: Option<u32>,
    /// Whether the GL context that renders runs the compute kernel (OpenGL 4.3), once the
    /// options are settled in it ([`RenderOptions::on_context`]); None before, and on the
    /// CPU. What the warning of an instanced scene taken flat advises from
    /// ([`RenderOptions::stored_once_advice`]).
    pub gl_compute: Option<bool>,
    /// Where `auto` chose the GPU's two levels for a scene with instances
    /// ([`RenderOptions::on_context`]): the fragment kernel that renders the scene flat
    /// instead where the driver cuts the compute kernel's loops short (llvmpipe's loop
    /// limit), as `auto` falls back for any scene (`render::Renderer::render`), with the
    /// structure the user asked for (`auto`, or the uniform grid named). None elsewhere: a
    /// compute kernel the user named fails instead.
    pub instanced_fallback: Option<(crate::gpu::options::FragmentKernel, AccelChoice)>,
}

impl RenderOptions {
    /// The scene's own size and depth, one sample, f64, the irregular grid (named, not
    /// `auto`), the CPU backend.
    pub fn for_scene(scene: &Scene) -> Self {
        RenderOptions {
            width: scene.width,
            height: scene.height,
            spp: 1,
            max_depth: scene.max_depth,
            precision: Precision::default(),
            cpu_path: CpuPath::default(),
            accel: AccelKind::default().into(),
            grid: GridConfig::default(),
            irregular: IrregularConfig::default(),
            backend: Backend::Cpu,
            gpu: crate::gpu::options::GpuOptions::default(),
            progress: false,
            techniques: crate::technique::Techniques::default(),
            readback: crate::output::Readback::default(),
            region: None,
            device: None,
            gl_compute: None,
            instanced_fallback: None,
        }
    }

    /// These options for a render on the GPU (`gpu`) or the CPU: `--accel auto` resolved
    /// for that backend ([`AccelChoice::resolve`]), so a second call changes nothing.
    pub fn on_backend(&self, gpu: bool) -> RenderOptions {
        RenderOptions {
            accel: self.accel.resolve(gpu).into(),
            ..self.clone()
        }
    }

    /// These options for rendering `scene` in the GL context `gl` describes, or on the CPU
    /// (None): [`on_backend`](Self::on_backend), and the one rule for a scene with
    /// instances on the GPU. Every kernel walks its instances as two levels over uniform
    /// grids, stored once (`accel/grid_instances.rs`; a fragment kernel in 32-bit ray
    /// state only): where the structure is left to `auto` (or named
    /// uniform) and nothing else keeps the scene flat ([`two_level_blocks`](Self::two_level_blocks)),
    /// it becomes the uniform grid, and `auto`'s kernel is named: the compute kernel where
    /// the context runs it (its fallback for the driver's loop limit, the fastest fragment
    /// kernel, kept aside: [`instanced_fallback`](Self::instanced_fallback)), else the
    /// fastest fragment kernel. Elsewhere the options stay as given and
    /// [`crate::render::prepare`] takes the instances flat, with one warning naming what
    /// would walk them stored once. The backend is settled too (`auto` that took the
    /// context is `gl`). A second call changes nothing.
    pub fn on_context(&self, scene: &Scene, gl: Option<&crate::gpu::GlInfo>) -> RenderOptions {
        let Some(info) = gl else {
            return self.on_backend(false);
        };
        // The backend settled: `auto` that took the context renders on GL.
        let mut o = RenderOptions {
            backend: Backend::Gl,
            gl_compute: Some(info.compute),
            ..self.clone()
        };
        let fragment = match self.gpu.kernel {
            Kernel::Compute => false,
            Kernel::Auto => !info.compute || self.fragment_only(),
            Kernel::Multipass | Kernel::Unrolled(_) | Kernel::Looped => true,
        };
        if scene.has_instances() && self.two_level_blocks(fragment).is_empty() {
            o.accel = AccelChoice::Uniform;
            if self.gpu.kernel == Kernel::Auto {
                let fastest = Kernel::fastest_fragment(info);
                if fragment {
                    o.gpu.kernel = fastest.kernel();
                } else {
                    o.gpu.kernel = Kernel::Compute;
                    o.instanced_fallback = Some((fastest, self.accel));
                }
            }
        }
        o.on_backend(true)
    }

    /// `view`'s options for `scene`, settled on the GPU ([`on_backend`](Self::on_backend)):
    /// one upload serves every kernel its `k` key switches to, so an instanced scene takes
    /// the two levels (the uniform grid, where the structure is left to `auto`) exactly
    /// where every kernel walks them ([`two_level_blocks`](Self::two_level_blocks) of the
    /// fragment kernels empty); else [`crate::render::prepare`] stores them flat, with its
    /// one warning.
    pub fn for_view(&self, scene: &Scene) -> RenderOptions {
        let mut o = self.clone();
        if scene.has_instances() && self.two_level_blocks(true).is_empty() {
            o.accel = AccelChoice::Uniform;
        }
        o.on_backend(true)
    }

    /// Whether these options ask for something only the fragment kernels have (a mask, or
    /// 16-bit ray storage: what makes `--kernel auto` a fragment kernel).
    fn fragment_only(&self) -> bool {
        matches!(self.gpu.mask, Mask::EarlyZ | Mask::Stencil) || self.gpu.storage != Storage::F32
    }

    /// What keeps a scene's instances off the GPU's two levels with these options on a
    /// fragment kernel (`fragment`) or the compute kernel: the flags to give or drop
    /// (`--accel uniform`, `without --storage f16`); empty where nothing does. Textures and
    /// vertex colours keep nothing off (a fragment kernel's record pass copies a textured
    /// level's cone beside its instance: `glsl120/record.frag`).
    pub fn two_level_blocks(&self, fragment: bool) -> Vec<String> {
        let g = &self.gpu;
        let mut change = Vec::new();
        if !matches!(self.accel, AccelChoice::Auto | AccelChoice::Uniform) {
            change.push("--accel uniform".to_string());
        }
        if fragment {
            // s1 in half floats holds the held hit's bound too coarsely.
            if g.storage != Storage::F32 {
                change.push(format!("without --storage {}", g.storage));
            }
        }
        change
    }

    /// Whether these options' kernel is a fragment kernel (named; `auto` is not).
    pub fn fragment_kernel_named(&self) -> bool {
        matches!(
            self.gpu.kernel,
            Kernel::Multipass | Kernel::Unrolled(_) | Kernel::Looped
        )
    }

    /// What would render a scene's instances stored once, where these options (settled:
    /// [`on_context`](Self::on_context)) take them flat: the end of the one warning
    /// [`crate::render::prepare`] gives.
    pub fn stored_once_advice(&self) -> String {
        match (self.backend == Backend::Gl, self.gl_compute) {
            (false, _) => "--backend cpu --accel bvh walks them as placed, stored once".into(),
            // Not settled in a context: `view` (one scene uploaded for every kernel its
            // key switches to), or a library caller.
            (true, None) if self.two_level_blocks(true) == ["--accel uniform"] => {
                "--accel uniform walks them on the GPU as placed, stored once (two levels over \
                 uniform grids)"
                    .into()
            }
            (true, None) => "`fragtrace render --backend gl` walks them on the GPU as placed, \
                 stored once (two levels over uniform grids)"
                .into(),
            (true, Some(_)) => {
                let fragment = self.gpu.kernel != Kernel::Compute;
                let mut change = self.two_level_blocks(fragment);
                if change.is_empty() {
                    change.push("--accel uniform".into());
                }
                format!(
                    "{} would walk them on the GPU as placed, stored once (two levels over \
                     uniform grids)",
                    change.join(" ")
                )
            }
        }
    }

    /// The structure these options build: named, or `auto` for the backend asked, where
    /// `--backend auto` not yet settled counts as the GPU's.
    pub fn accel_kind(&self) -> AccelKind {
        self.accel.resolve(self.backend != Backend::Cpu)
    }

    /// The pixels rendered: the region, or the whole image.
    pub fn pixels(&self) -> Region {
        self.region
            .unwrap_or_else(|| Region::full(self.width, self.height))
    }

    /// Rejects sizes and counts out of range ([`check_range`]) before any allocation, and
    /// pixels rendered (the region's, else the whole image's) that need more memory than
    /// the limit (which flags apply to the backend is [`crate::choices::Choices::check`]'s).
    pub fn validate(&self) -> Result<()> {
        self.check_flags()?;
        self.check_memory()
    }

    /// [`validate`](Self::validate) without the memory check: what the flags can be
    /// checked for before the region a process renders is known (a tile of a poster is
    /// told its region after the flags are read).
    pub fn check_flags(&self) -> Result<()> {
        check_range("width", self.width, 1, MAX_IMAGE_SIDE)?;
        check_range("height", self.height, 1, MAX_IMAGE_SIDE)?;
        if let Some(r) = &self.region {
            r.check_inside(self.width, self.height, "the region")?;
        }
        check_range("spp", self.spp, 1, MAX_SPP)?;
        check_range("max-depth", self.max_depth, 0, MAX_DEPTH)?;
        check_range("query-every", self.gpu.query_every, 1, MAX_QUERY_EVERY)?;
        // "No BVH on the GPU" is not checked here: the flags are refused at their front
        // door ([`crate::choices::Choices::check`], with advice naming that door's flags),
        // and a library caller handing the GPU a BVH meets `AccelRef::grid`, the one
        // conversion from a structure to what the GPU walks.
        Ok(())
    }

    /// The host-memory limit on the pixels rendered: memory goes with the pixels, so a
    /// poster too large for one process renders as tiles that each fit.
    pub fn check_memory(&self) -> Result<()> {
        let px = self.pixels();
        let bytes = px.area() * HOST_BYTES_PER_PIXEL;
        if bytes > MAX_HOST_BYTES {
            let part = if self.region.is_some() {
                format!(
                    " (a {}x{} part of {}x{})",
                    px.width(),
                    px.height(),
                    self.width,
                    self.height
                )
            } else {
                String::new()
            };
            return Err(Error::Limit(format!(
                "a {}x{} image{part} needs about {:.1} GiB of host memory, more than the {} GiB limit{}",
                px.width(),
                px.height(),
                bytes as f64 / (1u64 << 30) as f64,
                MAX_HOST_BYTES >> 30,
                if self.region.is_some() { "; cut it into more tiles" } else { "; render it in tiles (--tile I/N, docs/distributed.md)" }
            )));
        }
        Ok(())
    }
}

/// The frames of `--frames`: `all` (the path's), or a comma-separated list of items, each
/// a frame `A`, a range `A..B` (both included) or a stepped range `A..B:S` (A, A+S, ...
/// up to B): `0..10:2`, `0,5,9`, `1..3,7..20:4` (Blender's `-f 1,3,5..10` and `-j`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FrameRange {
    /// Every frame of the scene's path.
    All,
    /// Items `(A, B, S)`, in the order given: frames A, A+S, ... up to B.
    List(Vec<(u32, u32, u32)>),
}

impl std::str::FromStr for FrameRange {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        if s == "all" {
            return Ok(FrameRange::All);
        }
        let mut items = Vec::new();
        for item in s.split(',') {
            let bad = || {
                format!("`{item}` in `{s}` is not a frame, A..B or A..B:STEP (frames: A..B, A..B:S, A,B,C or all)")
            };
            let (range, step) = match item.split_once(':') {
                Some((r, st)) => (
                    r,
                    st.trim()
                        .parse::<u32>()
                        .ok()
                        .filter(|&n| n >= 1)
                        .ok_or_else(|| {
                            format!("`{item}`: the step `{st}` is not a whole number >= 1")
                        })?,
                ),
                None => (item, 1),
            };
            let (a, b) = match range.split_once("..") {
                Some((a, b)) => (a, b.strip_prefix('=').unwrap_or(b)),
                None if step == 1 => (range, range),
                None => return Err(bad()),
            };
            let (a, b): (u32, u32) = (
                a.trim().parse().map_err(|_| bad())?,
                b.trim().parse().map_err(|_| bad())?,
            );
            if a > b {
                return Err(format!("frame range {item} runs backwards"));
            }
            items.push((a, b, step));
        }
        Ok(FrameRange::List(items))
    }
}

impl FrameRange {
    /// Frames `A..=B`.
    pub fn range(a: u32, b: u32) -> FrameRange {
        FrameRange::List(vec![(a, b, 1)])
    }

    /// The frames this range takes of `path`'s frames, in order, checked against them: each
    /// frame once (a list naming one twice is refused: two tasks would write one file).
    pub fn frames(&self, path: &std::ops::RangeInclusive<u32>) -> Result<Vec<u32>> {
        let items = match self {
            FrameRange::All => return Ok(path.clone().collect()),
            FrameRange::List(items) => items,
        };
        let mut out = Vec::new();
        for &(a, b, step) in items {
            if !(path.contains(&a) && path.contains(&b)) {
                let item = if a == b {
                    format!("{a}")
                } else {
                    format!("{a}..{b}")
                };
                return Err(Error::Usage(format!(
                    "--frames {item} is outside the scene's camera path, frames {}..{}",
                    path.start(),
                    path.end()
                )));
            }
            out.extend((a..=b).step_by(step as usize));
        }
        let mut seen = std::collections::BTreeSet::new();
        if let Some(f) = out.iter().find(|f| !seen.insert(**f)) {
            return Err(Error::Usage(format!(
                "--frames names frame {f} twice: each frame once"
            )));
        }
        Ok(out)
    }
}

/// Which textures a render uses: `--textures on|off|strict`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum TextureMode {
    /// Textures, texture coordinates and vertex colours as the files say; a texture that
    /// cannot be read is one warning line, and its material renders with its colour.
    #[default]
    On,
    /// None of them: every material renders with its colour (the untextured twin of a
    /// scene, for measuring what textures cost).
    Off,
    /// As `on`, but a texture that cannot be read is an error (for CI).
    Strict,
}

impl TextureMode {
    /// Applies the mode to a loaded scene: `off` strips its textures, texture coordinates
    /// and vertex colours; `on` prints each texture problem as one warning line; `strict`
    /// refuses a scene with any.
    pub fn apply(self, scene: &mut crate::scene::Scene) -> crate::Result<()> {
        match self {
            TextureMode::Off => {
                scene.strip_textures();
                Ok(())
            }
            TextureMode::On => {
                for w in &scene.texture_problems {
                    eprintln!("fragtrace: warning: {w}");
                }
                Ok(())
            }
            TextureMode::Strict => match scene.texture_problems.first() {
                None => Ok(()),
                Some(p) => Err(crate::Error::Usage(format!(
                    "{p} (--textures strict; `--textures on` renders it with the material's colour)"
                ))),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::options::FragmentKernel;

    /// The one rule for a scene with instances on the GPU: `auto` (or the uniform grid
    /// named) takes the two levels on any kernel: `auto`'s kernel becomes the compute
    /// kernel where the context runs it (its fallback kept aside for the loop limit), else
    /// (no compute, or a mask asked for) the fastest fragment kernel; a named fragment
    /// kernel keeps its name; a textured scene as an untextured one. The irregular grid and
    /// 16-bit ray storage on a fragment kernel leave the options as given, and the
    /// warning's advice names what to change; no instances changes nothing. Settling twice
    /// changes nothing.
    #[test]
    fn instances_go_to_the_two_levels_on_every_kernel() {
        let text = "[camera]\neye = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n[[objects]]\nshape = \"box\"\ninstances = [{ translate = [1, 0, 0] }]\n";
        let inst = crate::scene::load_scene_str(text, "i.toml", std::path::Path::new(".")).unwrap();
        let flat = crate::scene::builtin_scene();
        let old = crate::gpu::info::tests::sample_info();
        let mut new = old.clone();
        new.compute = true;
        new.gl_major_minor = (4, 5);
        let base = RenderOptions {
            backend: Backend::Gl,
            accel: AccelChoice::Auto,
            ..RenderOptions::for_scene(&inst)
        };
        let with = |f: &dyn Fn(&mut RenderOptions)| {
            let mut o = base.clone();
            f(&mut o);
            o
        };
        let two = |o: &RenderOptions| (o.gpu.kernel, o.accel_kind());
        let auto = base.on_context(&inst, Some(&new));
        assert_eq!(two(&auto), (Kernel::Compute, AccelKind::Uniform));
        assert_eq!(
            auto.instanced_fallback,
            Some((FragmentKernel::Looped, AccelChoice::Auto))
        );
        let again = auto.on_context(&inst, Some(&new));
        assert_eq!(
            (two(&again), again.instanced_fallback),
            (two(&auto), auto.instanced_fallback)
        );
        let named = with(&|o| {
            o.gpu.kernel = Kernel::Compute;
            o.accel = AccelChoice::Uniform;
        })
        .on_context(&inst, Some(&new));
        assert_eq!(two(&named), (Kernel::Compute, AccelKind::Uniform));
        assert_eq!(named.instanced_fallback, None);
        for (change, kernel) in [
            (
                &(|o: &mut RenderOptions| o.gpu.kernel = Kernel::Looped)
                    as &dyn Fn(&mut RenderOptions),
                Kernel::Looped,
            ),
            (
                &|o: &mut RenderOptions| o.gpu.kernel = Kernel::Multipass,
                Kernel::Multipass,
            ),
            (
                &|o: &mut RenderOptions| o.gpu.mask = Mask::Stencil,
                Kernel::Looped,
            ),
        ] {
            let o = with(change).on_context(&inst, Some(&new));
            assert_eq!(two(&o), (kernel, AccelKind::Uniform));
            assert_eq!(o.instanced_fallback, None);
        }
        for (change, advice) in [
            (
                &(|o: &mut RenderOptions| o.accel = AccelChoice::Irregular)
                    as &dyn Fn(&mut RenderOptions),
                "--accel uniform",
            ),
            (
                &|o: &mut RenderOptions| o.gpu.storage = Storage::F16,
                "without --storage f16",
            ),
        ] {
            let given = with(change);
            let o = given.on_context(&inst, Some(&new));
            assert_eq!(
                (o.gpu.kernel, o.accel),
                (given.gpu.kernel, given.accel.resolve(true).into())
            );
            assert_eq!(o.instanced_fallback, None);
            let a = o.stored_once_advice();
            assert!(a.contains(advice), "{a}");
        }
        let o = base.on_context(&inst, Some(&old));
        assert_eq!(
            two(&o),
            (Kernel::fastest_fragment(&old).kernel(), AccelKind::Uniform)
        );
        let mut textured = inst.clone();
        textured.materials[0].diffuse_map = Some(0);
        // Textures keep nothing off the two levels: the fastest fragment kernel walks them
        // where compute is missing.
        let o = base.on_context(&textured, Some(&old));
        assert_eq!(
            two(&o),
            (Kernel::fastest_fragment(&old).kernel(), AccelKind::Uniform)
        );
        let o = base.on_context(&textured, Some(&new));
        assert_eq!(two(&o), (Kernel::Compute, AccelKind::Uniform));
        let o = base.on_context(&flat, Some(&new));
        assert_eq!(two(&o), (Kernel::Auto, AccelKind::Irregular));
        let cpu = RenderOptions {
            backend: Backend::Auto,
            ..base.clone()
        }
        .on_context(&inst, None);
        assert_eq!(two(&cpu), (Kernel::Auto, AccelKind::Bvh));
    }

    /// `--accel auto` resolves to the BVH on the CPU and the irregular grid on the GPU;
    /// a named structure is the same on both.
    #[test]
    fn accel_choice_resolves_by_backend() {
        assert_eq!(AccelChoice::Auto.resolve(false), AccelKind::Bvh);
        assert_eq!(AccelChoice::Auto.resolve(true), AccelKind::Irregular);
        for k in [AccelKind::Uniform, AccelKind::Irregular, AccelKind::Bvh] {
            assert_eq!(AccelChoice::from(k).resolve(false), k);
            assert_eq!(AccelChoice::from(k).resolve(true), k);
        }
    }
}
