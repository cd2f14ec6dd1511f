//! Command-line interface: argument parsing (clap) and the commands, as library functions
//! so tests can drive them without spawning the binary.

use std::path::{Path, PathBuf};

use clap::{Args, Parser, Subcommand};

use crate::choices::{clap_error_line, Choices, Door, RenderArgs};
use crate::image_io;
use crate::options::TextureMode;
use crate::region::Region;
use crate::render;
use crate::scene::{self, Scene};
use crate::{Error, Result};

mod render_cmd;

pub use render_cmd::{run_check, run_parts, run_render, verbose_report};

/// fragtrace: a Whitted ray tracer on GLSL 1.20 fragment programs, with an f64 CPU reference.
#[derive(Parser, Debug)]
#[command(name = "fragtrace", version = env!("FRAGTRACE_BUILD"), about, long_about = None, args_conflicts_with_subcommands = true)]
pub struct Cli {
    /// The command; `render` when omitted (so `fragtrace -o x.png` renders the default scene).
    #[command(subcommand)]
    pub command: Option<Command>,
    /// Render arguments when no command is given.
    #[command(flatten)]
    pub render: RenderArgs,
    /// CPU threads for rendering, building the structures and loading (default: one per
    /// core, or `RAYON_NUM_THREADS`). Any command takes it, after its name (`fragtrace
    /// render --threads 2`).
    #[arg(long, global = true, value_parser = clap::value_parser!(u16).range(1..=1024))]
    pub threads: Option<u16>,
}

/// Subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a scene (the built-in Whitted homage when no file is given).
    Render(RenderArgs),
    /// Compare two images (PNG, EXR, HDR, TIFF or PPM): RMSE, PSNR, mean FLIP, max error, share above a
    /// threshold.
    Compare(CompareArgs),
    /// Time every configuration on every scene and measure its error against the CPU f64
    /// reference: results.csv, report.md and speed_vs_error.png in --out.
    Bench(BenchArgs),
    /// Assemble parts (`render --tile/--region/--task-index` OpenEXR files) into the whole
    /// image: they must come from one scene and one set of options and cover every pixel
    /// exactly once, or nothing is written.
    Merge(MergeArgs),
    /// Print the EGL/GL context: versions, limits, required features, verdict; and the
    /// EGL devices `--gpu N` chooses from.
    Info(InfoArgs),
    /// Write the final GLSL source of every pass for a scene (`builtin` for the built-in).
    DumpShaders(DumpArgs),
    /// Render in a window (X11), showing the render as it happens: the same GPU renderer,
    /// the window's GL context. Mouse orbits, pans and zooms; keys below.
    #[command(after_help = crate::view::KEYS_HELP)]
    View(ViewArgs),
}

/// Arguments of `view`: the render flags (the same as `render`'s), and automation.
#[derive(Args, Debug, Clone)]
pub struct ViewArgs {
    /// Scene file (TOML); the built-in default scene when omitted.
    pub scene: Option<PathBuf>,
    /// The render's choices, as `render` takes them; `view` renders on the GPU, and
    /// refuses the CPU's flags ([`crate::choices::Choices::check`]).
    #[command(flatten)]
    pub choices: Choices,
    /// Present the render in progress at most every this many milliseconds.
    #[arg(long, default_value_t = 50.0)]
    pub frame_ms: f64,
    /// Play the scene's camera path (the scene file's `[animation]` table) from its first
    /// frame, one whole render per frame, in a loop (`p` pauses); with --frames N, stop
    /// after the path's N-th frame (frame N - 1 from the first), rendered to the end.
    #[arg(long)]
    pub play: bool,
    /// Outline, in the frames of a render in progress, the tiles the traversal passes
    /// draw (those that still held active rays at the last count; `t` toggles it).
    #[arg(long)]
    pub show_tiles: bool,
    /// Type these keys and mouse moves, one after the other, each once the render before
    /// it is complete: e.g. "k + a" or "orbit:40,0 zoom:2 s" (keys as listed below;
    /// orbit:DX,DY and pan:DX,DY drag by pixels, zoom:N turns the wheel N lines). With
    /// --screenshot, the window is saved after the last one.
    #[arg(
        long,
        value_name = "KEYS",
        conflicts_with = "script",
        allow_hyphen_values = true
    )]
    pub keys: Option<String>,
    /// --keys read from FILE (white space between steps, `#` comments).
    #[arg(long, value_name = "FILE")]
    pub script: Option<PathBuf>,
    /// Present every P passes instead of by time (reproducible frames for --screenshot).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    pub passes_per_frame: Option<u64>,
    /// Without input: stop after N presented frames, or when the render is complete (with
    /// --play: after N frames of the camera path).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    pub frames: Option<u64>,
    /// Without input: write the window's content (PNG) when stopping and exit; alone,
    /// stop when the render is complete.
    #[arg(long)]
    pub screenshot: Option<PathBuf>,
}

/// Arguments of `info`.
#[derive(Args, Debug, Clone)]
pub struct InfoArgs {
    /// Report on EGL device N (as `render --gpu N` would use it) instead of the default;
    /// `env`: the device `render --gpu env` would take, and why.
    #[arg(long, value_name = "N|env", allow_negative_numbers = true)]
    pub gpu: Option<crate::gpu::options::GpuChoice>,
}

/// Arguments of `merge`.
#[derive(Args, Debug, Clone)]
pub struct MergeArgs {
    /// The part files (OpenEXR, from `render --tile`, `--region` or `--task-index`).
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// The merged image: .png (sRGB 8-bit, the same bits as a single-process render) or
    /// .exr (linear float, itself a part covering the whole image); a run of `#` in the file name
    /// writes one image per frame of an animation's parts.
    #[arg(short, long, required_unless_present = "summary")]
    pub output: Option<PathBuf>,
    /// Print the job's parts across its tasks first (done, missing by tile and frame with
    /// the task that owed each, each task's time and node); without -o only that, exit 1
    /// when a part is missing or unreadable.
    #[arg(long)]
    pub summary: bool,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Arguments of `dump-shaders`.
#[derive(Args, Debug, Clone)]
pub struct DumpArgs {
    /// Scene file, or `builtin`.
    pub scene: PathBuf,
    /// Output folder.
    pub dir: PathBuf,
    /// Every combination of scene features, one sub-folder each, plus one sub-folder
    /// `techniques-<setting>` per non-default robustness technique (what CI validates).
    #[arg(long)]
    pub all_variants: bool,
    /// The render's choices, as `render` takes them: the programs are those of the
    /// structure (`--accel`, `--grid`, `--grid-density`) and techniques chosen, with
    /// `--no-specialize` every shading feature; the flags that change no program are
    /// refused ([`crate::choices::Choices::check`]).
    #[command(flatten)]
    pub choices: Choices,
}

/// Arguments of `compare`.
#[derive(Args, Debug, Clone)]
pub struct CompareArgs {
    /// The image to judge.
    pub a: PathBuf,
    /// The reference image.
    pub b: PathBuf,
    /// Per-pixel threshold (largest channel difference) for the share of differing pixels.
    #[arg(long, default_value_t = 0.01, allow_negative_numbers = true)]
    pub threshold: f64,
    /// Write a difference image (absolute difference times --gain) here.
    #[arg(long)]
    pub diff: Option<PathBuf>,
    /// Gain applied to the difference image.
    #[arg(long, default_value_t = 10.0, allow_negative_numbers = true)]
    pub gain: f32,
    /// Exit with code 1 when RMSE exceeds this bound.
    #[arg(long, allow_negative_numbers = true)]
    pub max_rmse: Option<f64>,
    /// Exit with code 1 when the mean FLIP error exceeds this bound.
    #[arg(long, allow_negative_numbers = true)]
    pub max_flip: Option<f64>,
    /// Compare one channel of two AOV EXR files (`depth`, `primid`, `steps`, `normal.x`,
    /// ...) instead of the colour; misses (infinite depth) are equal to each other and
    /// infinitely far from any hit.
    #[arg(long)]
    pub channel: Option<String>,
}

/// Arguments of `bench`.
#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// Scenes, comma-separated: names of files in scenes/ (`whitted` is the built-in) or
    /// paths to scene files. Default: every shipped scene.
    #[arg(long)]
    pub scenes: Option<String>,
    /// Configurations: a preset (default, quick, all), comma-separated names from the
    /// table (docs/performance.md), or a TOML file with `[configs]` lines
    /// `name = "render arguments"`. Default: the default preset, without its multipass and
    /// unrolled GL configurations on a software GL (llvmpipe), where they take tens of
    /// minutes (`--configs default` runs them).
    #[arg(long)]
    pub configs: Option<String>,
    /// Timed runs per scene and configuration, after one warm-up (the median is reported).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub runs: u32,
    /// Image size of every render, WxH.
    #[arg(long, default_value = "512x512")]
    pub size: crate::bench::Size,
    /// Skip the remaining runs of a configuration once one run takes longer than this.
    #[arg(long, default_value_t = 120.0)]
    pub max_seconds: f64,
    /// Output folder: results.csv, report.md, speed_vs_error.png, cached references.
    #[arg(long, default_value = "bench-out")]
    pub out: PathBuf,
    /// Print nothing but errors (no progress display, no per-configuration lines).
    #[arg(short, long)]
    pub quiet: bool,
}

/// Joins a possibly multi-line message (a dependency's, a driver's) into one line.
pub fn one_line(msg: &str) -> String {
    msg.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join(": ")
}

/// A clap usage error as one line ([`clap_error_line`]) with a pointer to `--help`.
pub fn one_line_clap_error(e: &clap::Error) -> String {
    format!("{} (see `fragtrace --help`)", clap_error_line(e))
}

/// Fails unless `path` can be created or replaced: its folder exists and is writable, and
/// it is not a folder itself. Checked before loading and rendering, so a typo in `-o`
/// costs no render time. Probes with (and removes) a temporary file next to `path`; an
/// existing `path` is never touched.
pub fn check_writable(path: &Path, what: &str) -> Result<()> {
    let fail = |why: String| {
        Error::Usage(format!(
            "{}: cannot write the {what}: {why}",
            path.display()
        ))
    };
    // `out/` names a folder even when it does not exist yet; the OS would only say
    // "Not a directory" or "Is a directory" about it.
    let trailing_slash = path
        .as_os_str()
        .to_string_lossy()
        .ends_with(std::path::MAIN_SEPARATOR);
    if path.is_dir() || trailing_slash {
        return Err(fail(format!(
            "{} a directory (a folder), not a file: name a file inside it, e.g. {}",
            if path.is_dir() { "is" } else { "names" },
            path.join(format!(
                "out.{}",
                if what == "image" { "png" } else { "json" }
            ))
            .display()
        )));
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    match std::fs::metadata(dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => return Err(fail(format!("{} is not a directory", dir.display()))),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(fail(format!("folder {} does not exist", dir.display())))
        }
        Err(e) => return Err(fail(format!("folder {}: {e}", dir.display()))),
    }
    if let Ok(m) = std::fs::metadata(path) {
        if !m.is_file() {
            return Err(fail("exists and is not a regular file".into()));
        }
    }
    let probe = dir.join(format!(
        ".{}.{}.probe",
        path.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        std::process::id()
    ));
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        // The folder exists (checked above), so whatever the OS says (EACCES, EROFS, or
        // ENOENT from a pseudo-filesystem such as /proc), the folder is not writable.
        Err(e) => Err(fail(format!(
            "folder {} exists but is not writable (creating a file there failed: {})",
            dir.display(),
            io_reason(&e)
        ))),
    }
}

/// An OS error without the `(os error N)` suffix, for one-line messages.
fn io_reason(e: &std::io::Error) -> String {
    let s = e.to_string();
    match s.find(" (os error") {
        Some(i) => s[..i].to_owned(),
        None => s,
    }
}

/// Loads the scene named on the command line, or the built-in one, with its textures as
/// `textures` asks (`--textures`: stripped, warned about, or refused when unreadable).
pub fn load(scene_path: Option<&Path>, textures: TextureMode) -> Result<Scene> {
    let mut scene = match scene_path {
        Some(p) => scene::load_scene(p)?,
        None => scene::builtin_scene(),
    };
    textures.apply(&mut scene)?;
    Ok(scene)
}

/// The `compare` command: prints the figures; `Ok(false)` when a bound is exceeded, after
/// one line on stderr per exceeded bound saying by how much.
pub fn run_compare(args: &CompareArgs) -> Result<bool> {
    // A negative or NaN bound can never be met and a negative threshold counts every
    // pixel: reject them before reading anything.
    for (flag, v) in [
        ("--threshold", Some(args.threshold)),
        ("--max-rmse", args.max_rmse),
        ("--max-flip", args.max_flip),
        ("--gain", Some(args.gain as f64)),
    ] {
        if let Some(v) = v.filter(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(Error::Usage(format!(
                "{flag} {v} must be a finite number >= 0"
            )));
        }
    }
    // A difference image that cannot be written is refused before anything is printed.
    if let Some(path) = &args.diff {
        check_writable(path, "image")?;
        image_io::Format::from_path(path)?;
    }
    let c = match compare_parts(args)? {
        Some(c) => c,
        None => crate::compare::compare_files(
            &args.a,
            &args.b,
            args.channel.as_deref(),
            args.threshold,
        )?,
    };
    println!("{}", c.comparison);
    if let Some(path) = &args.diff {
        image_io::write_image(path, &crate::compare::diff_image(&c.a, &c.b, args.gain))?;
    }
    let mut ok = true;
    for (name, flag, value, bound) in [
        ("RMSE", "--max-rmse", c.comparison.rmse, args.max_rmse),
        (
            "mean FLIP",
            "--max-flip",
            c.comparison.flip_mean,
            args.max_flip,
        ),
    ] {
        if let Some(bound) = bound.filter(|&b| value > b || value.is_nan()) {
            ok = false;
            eprintln!(
                "fragtrace: compare: {name} {value:.6} exceeds {flag} {bound} by {:.6} ({:.1}x the bound)",
                value - bound,
                if bound > 0.0 { value / bound } else { f64::INFINITY }
            );
        }
    }
    Ok(ok)
}

/// A part (`render --tile/--region/--task-index`'s OpenEXR, a region of an image) read as
/// a part, or None for any other file.
fn part_of(path: &Path) -> Option<crate::farm::part::Part> {
    if image_io::Format::from_path(path).ok()? != image_io::Format::Exr {
        return None;
    }
    crate::farm::part::read_part(path)
        .ok()
        .filter(|p| p.header.region != Region::full(p.header.width, p.header.height))
}

/// `compare` where either file is a part: the part against the same pixels of the other
/// (a whole image of the part's full size, or a part of the same region); None when
/// neither is a part. Anything else is refused in one line: a part is not an image.
fn compare_parts(args: &CompareArgs) -> Result<Option<crate::compare::FileComparison>> {
    let (pa, pb) = (part_of(&args.a), part_of(&args.b));
    let (part, part_path, other_path, part_first) = match (&pa, &pb) {
        (None, None) => return Ok(None),
        (Some(p), _) => (p, &args.a, &args.b, true),
        (None, Some(p)) => (p, &args.b, &args.a, false),
    };
    let h = &part.header;
    let r = h.region;
    if args.channel.is_some() {
        return Err(Error::Usage(format!(
            "compare: {} is a part (pixels {r} of {}x{}); --channel compares AOV files",
            part_path.display(),
            h.width,
            h.height
        )));
    }
    let other = match (&pa, &pb) {
        (Some(a), Some(b)) => {
            if (a.header.region, a.header.width, a.header.height)
                != (b.header.region, b.header.width, b.header.height)
            {
                return Err(Error::Usage(format!(
                    "compare: {} is pixels {} of {}x{} but {} is pixels {} of {}x{}: compare parts of the same region, or a part with the whole image",
                    args.a.display(),
                    a.header.region,
                    a.header.width,
                    a.header.height,
                    args.b.display(),
                    b.header.region,
                    b.header.width,
                    b.header.height
                )));
            }
            b.image.clone()
        }
        _ => {
            let whole = image_io::read_image(other_path)?;
            if (whole.width, whole.height) != (h.width, h.height) {
                return Err(Error::Usage(format!(
                    "compare: {} is pixels {r} of a {}x{} image, but {} is {}x{}: compare a part with the whole image it is a part of (or merge the parts first)",
                    part_path.display(),
                    h.width,
                    h.height,
                    other_path.display(),
                    whole.width,
                    whole.height
                )));
            }
            crop(&whole, r)
        }
    };
    let (ia, ib) = if part_first {
        (part.image.clone(), other)
    } else {
        (other, part.image.clone())
    };
    let clamp = [&args.a, &args.b]
        .iter()
        .any(|p| image_io::Format::from_path(p).is_ok_and(|f| f.is_srgb8()));
    Ok(Some(crate::compare::FileComparison {
        comparison: crate::compare::compare(&ia, &ib, args.threshold, clamp)?,
        a: ia,
        b: ib,
    }))
}

/// The pixels `r` of `img`.
fn crop(img: &image_io::Image, r: Region) -> image_io::Image {
    let mut data = Vec::with_capacity(r.area() as usize * 3);
    for y in r.y0..r.y1 {
        let row = (y * img.width) as usize * 3;
        data.extend_from_slice(&img.data[row + r.x0 as usize * 3..row + r.x1 as usize * 3]);
    }
    image_io::Image::from_rgb(r.width(), r.height(), data)
}

/// The `bench` command: resolves scenes and configurations (bad ones are usage errors,
/// before anything renders), then runs [`crate::bench::run_bench`].
pub fn run_bench(args: &BenchArgs) -> Result<crate::bench::BenchReport> {
    let opts = crate::bench::BenchOptions {
        scenes: crate::bench::resolve_scenes(args.scenes.as_deref())?,
        configs: crate::bench::resolve_configs(args.configs.as_deref().unwrap_or("default"))?,
        runs: args.runs,
        size: args.size,
        max_seconds: args.max_seconds,
        out: args.out.clone(),
        quiet: args.quiet,
        fit_to_machine: args.configs.is_none(),
    };
    crate::bench::run_bench(&opts)
}

/// The `merge` command: with `--summary` the parts across their tasks
/// ([`crate::farm::summary`]; without `-o` false when one is missing), then with `-o` the
/// output path checked and [`crate::farm::merge::merge`].
pub fn run_merge(args: &MergeArgs) -> Result<bool> {
    let summary = args.summary.then(|| {
        let parts: Vec<_> = args
            .parts
            .iter()
            .map(|p| {
                let header = crate::farm::part::read_part(p)
                    .map(|part| part.header)
                    .map_err(|e| {
                        let e = e.to_string();
                        let prefix = format!("{}: ", p.display());
                        e.strip_prefix(&prefix).unwrap_or(&e).to_string()
                    });
                (p.clone(), header)
            })
            .collect();
        let s = crate::farm::summary::summarize(&parts);
        for l in &s.lines {
            println!("{l}");
        }
        s.complete
    });
    match &args.output {
        Some(output) => merge_to(args, output).map(|_| true),
        None => Ok(summary.unwrap_or(true)),
    }
}

/// `merge -o OUTPUT`: the parts checked and assembled, the outputs reported.
fn merge_to(args: &MergeArgs, output: &Path) -> Result<crate::farm::merge::Merged> {
    image_io::remove_partials_on_signal();
    // A probe next to where frame 0 would go: the folder must exist and be writable.
    let probe = crate::farm::template::OutputTemplate::new(output)?.path(Some(0), None);
    check_writable(&probe, "image")?;
    image_io::Format::from_path(output)?;
    let merged = crate::farm::merge::merge(&args.parts, output)?;
    if !args.quiet {
        if !merged.devices.is_empty() {
            eprintln!(
                "fragtrace: notice: the parts were rendered on {} devices: {}",
                merged.devices.len(),
                merged.devices.join("; ")
            );
        }
        for (out, n) in merged.outputs.iter().zip(&merged.parts_per_output) {
            eprintln!(
                "{}: {}x{} merged from {n} parts",
                out.display(),
                merged.width,
                merged.height,
            );
        }
    }
    Ok(merged)
}

/// The `info` command: what the GL driver offers and whether fragtrace can run on it.
pub fn run_info(args: &InfoArgs) -> Result<bool> {
    let device = match args.gpu {
        None => None,
        Some(crate::gpu::options::GpuChoice::Index(n)) => Some(n),
        Some(crate::gpu::options::GpuChoice::Env) => {
            let pick = crate::gpu::device::from_env().map_err(Error::Usage)?;
            println!("{}", pick.why);
            Some(pick.index)
        }
    };
    let ctx = crate::gpu::GlContext::new_unchecked_on(device)?;
    println!("{}", ctx.info);
    match render::auto_declines(&ctx.info) {
        None => println!("--backend auto:   gl (this GL)"),
        Some(why) => println!("--backend auto:   cpu ({why})"),
    }
    // The devices `--gpu N` picks from, and how they meet CUDA's numbering (Slurm's GPU
    // binding sets CUDA_VISIBLE_DEVICES).
    match crate::gpu::egl::list_devices() {
        Ok(devices) => {
            println!("EGL devices ({}; render --gpu N):", devices.len());
            for d in &devices {
                println!(
                    "  --gpu {}: {}{}{}",
                    d.index,
                    d.name,
                    d.cuda
                        .map_or(String::new(), |c| format!(", CUDA device {c}")),
                    if device == Some(d.index) {
                        " (this report)"
                    } else {
                        ""
                    }
                );
            }
        }
        Err(e) => println!("EGL devices: none listed ({e})"),
    }
    if let Ok(v) = std::env::var("CUDA_VISIBLE_DEVICES") {
        println!("CUDA_VISIBLE_DEVICES={v}");
    }
    Ok(ctx.info.verdict().is_ok())
}

/// The `view` command: check the screenshot path, load the scene, open the window.
pub fn run_view(args: &ViewArgs) -> Result<()> {
    if let Some(path) = &args.screenshot {
        check_writable(path, "screenshot")?;
        if image_io::Format::from_path(path)? != image_io::Format::Png {
            return Err(Error::Usage(format!(
                "{}: --screenshot writes PNG; use a .png name",
                path.display()
            )));
        }
    }
    if !(args.frame_ms.is_finite() && args.frame_ms >= 0.0) {
        return Err(Error::Usage(format!(
            "--frame-ms {} is not a finite number >= 0",
            args.frame_ms
        )));
    }
    let script = match (&args.keys, &args.script) {
        (Some(keys), _) => crate::view::script::parse("--keys", keys)?,
        (None, Some(file)) => {
            let text = std::fs::read_to_string(file)
                .map_err(|e| Error::Usage(format!("--script {}: {e}", file.display())))?;
            crate::view::script::parse(&file.display().to_string(), &text)?
        }
        (None, None) => Vec::new(),
    };
    let scene = load(args.scene.as_deref(), args.choices.textures)?;
    if args.play && scene.animation.is_none() {
        // As `render --frames` refuses it: nothing would play.
        return Err(Error::Usage(format!(
            "--play needs a camera path: {} has no [animation] table (docs/scene-format.md)",
            scene.source
        )));
    }
    // The render flags go through `render`'s own conversion and checks, at `view`'s door;
    // the window renders on the GPU, so `--accel auto` is the GPU's structure (for an
    // instanced scene, the two levels where every kernel walks them).
    let render = args
        .choices
        .to_options(&scene, Door::View)?
        .for_view(&scene);
    render.check_memory()?;
    let opts = crate::view::ViewOptions {
        render,
        frames: args.frames,
        screenshot: args.screenshot.clone(),
        passes_per_frame: args.passes_per_frame,
        frame_ms: args.frame_ms,
        play: args.play,
        show_tiles: args.show_tiles,
        script,
    };
    crate::view::run(scene, &opts)
}

/// The subcommand a scene path that does not exist was probably meant to be
/// (`fragtrace rendr` parses as rendering the scene file `rendr`).
fn mistyped_subcommand(scene: &Path) -> Option<String> {
    use clap::CommandFactory;
    if scene.exists() || scene.components().count() != 1 || scene.extension().is_some() {
        return None;
    }
    let word = scene.to_str()?.to_lowercase();
    let cmd = Cli::command();
    let names: Vec<&str> = cmd.get_subcommands().map(|c| c.get_name()).collect();
    let limit = (word.chars().count() / 3).max(1);
    names
        .iter()
        .map(|n| (strsim::osa_distance(&word, n), *n))
        .filter(|&(d, n)| d <= limit || n.starts_with(word.as_str()))
        .min_by_key(|&(d, _)| d)
        .map(|(_, n)| n.to_owned())
}

/// Runs a parsed command line; `Ok(false)` means "ran, but the answer is no" (exit 1).
pub fn run(cli: Cli) -> Result<bool> {
    crate::clock::mark_start();
    if let Some(n) = cli.threads {
        // The global pool, before anything uses it: every parallel loop takes this size.
        rayon::ThreadPoolBuilder::new()
            .num_threads(n.into())
            .build_global()
            .map_err(|e| Error::Internal(format!("--threads {n}: {e}")))?;
    }
    if let (None, Some(scene)) = (&cli.command, &cli.render.scene) {
        if let Some(name) = mistyped_subcommand(scene) {
            return Err(Error::Usage(format!(
                "no such file `{}`; did you mean the subcommand `{name}`?",
                scene.display()
            )));
        }
    }
    match cli.command {
        None if cli.render.parts.check => run_check(&cli.render),
        None => run_render(&cli.render).map(|_| true),
        Some(Command::Render(args)) if args.parts.check => run_check(&args),
        Some(Command::Render(args)) => run_render(&args).map(|_| true),
        Some(Command::Compare(args)) => run_compare(&args),
        Some(Command::Bench(args)) => run_bench(&args).map(|_| true),
        Some(Command::Merge(args)) => run_merge(&args),
        Some(Command::Info(args)) => run_info(&args),
        Some(Command::View(args)) => run_view(&args).map(|()| true),
        Some(Command::DumpShaders(args)) => {
            let scene = if args.scene.as_os_str() == "builtin" {
                load(None, args.choices.textures)?
            } else {
                load(Some(&args.scene), args.choices.textures)?
            };
            // The structure and techniques the choices name, on the GPU: what `render`
            // compiles for them.
            let opts = args
                .choices
                .to_options(&scene, Door::DumpShaders)?
                .on_backend(true);
            let accel =
                crate::accel::Accel::build(&scene, opts.accel_kind(), &opts.grid, &opts.irregular)?;
            let files = crate::gpu::shader::dump_shaders_as(
                &scene,
                &accel,
                &args.dir,
                args.all_variants,
                opts.techniques,
                opts.gpu.no_specialize,
            )?;
            println!("{} files written to {}", files.len(), args.dir.display());
            Ok(true)
        }
    }
}
