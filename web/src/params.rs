//! The page's query string: what a test, a measurement or a shared link asks for. The
//! render flags are `fragtrace render`'s own, under their names, ranges and messages
//! (`fragtrace::query`); the page's own arguments (scene, WebGL version, display, progress,
//! bands, report) sit beside them. The controls on the page start from these values
//! (`aov=`, `progress=`, `spp=`).

use fragtrace::aov::AovKind;
use fragtrace::choices::{Choices, Door};
use fragtrace::gpu::options::Kernel;

/// How a render shows its progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Progress {
    /// Bands of rows, each the whole multipass walk over its rows.
    Bands,
    /// The whole image, pass by pass, as `fragtrace view` shows it: the walk pauses after
    /// about a frame's work (`every: None`) or every `every` observed passes, and the page
    /// shows the image so far. The default: as fast as one band of the whole image, where
    /// bands small enough to show progress repeat the walk's passes per band (docs/web.md
    /// has the figures).
    Passes { every: Option<u64> },
}

impl Progress {
    /// The query's and the control's spelling.
    pub fn name(self) -> String {
        match self {
            Progress::Bands => "bands".into(),
            Progress::Passes { every: None } => "passes".into(),
            Progress::Passes { every: Some(n) } => format!("passes:{n}"),
        }
    }

    /// Parses `bands`, `passes` or `passes:N`.
    pub fn parse(s: &str) -> Result<Progress, String> {
        match s {
            "bands" => Ok(Progress::Bands),
            "passes" => Ok(Progress::Passes { every: None }),
            _ => match s.strip_prefix("passes:").map(str::parse::<u64>) {
                Some(Ok(n)) if n > 0 => Ok(Progress::Passes { every: Some(n) }),
                _ => Err(format!("`{s}`: expected bands, passes or passes:N")),
            },
        }
    }
}

/// What the page shows: the colour image or one primary-ray AOV.
pub type Show = Option<AovKind>;

/// The control's and the query's name of `show`.
pub fn show_name(show: Show) -> &'static str {
    match show {
        None => "colour",
        Some(AovKind::Depth) => "depth",
        Some(AovKind::Normal) => "normal",
        Some(AovKind::PrimId) => "primid",
        Some(AovKind::Steps) => "steps",
    }
}

/// Every value of the display control, in its order.
pub const SHOWS: [Show; 5] = [
    None,
    Some(AovKind::Depth),
    Some(AovKind::Normal),
    Some(AovKind::PrimId),
    Some(AovKind::Steps),
];

/// Parses a display name (`colour` or an AOV).
pub fn parse_show(s: &str) -> Result<Show, String> {
    SHOWS
        .into_iter()
        .find(|&k| show_name(k) == s)
        .ok_or_else(|| format!("`{s}`: expected colour, depth, normal, primid or steps"))
}

/// `webgl=1|2`: which WebGL the page asks the browser for.
fn webgl_version(s: &str) -> Result<u32, String> {
    match s {
        "1" => Ok(1),
        "2" => Ok(2),
        _ => Err(format!("`{s}`: expected 1 or 2")),
    }
}

/// `band=ROWS|full|auto`: rows per band; `None`: adaptive.
#[derive(Clone, Copy, Debug)]
struct Band(Option<u32>);

fn band_rows(s: &str) -> Result<Band, String> {
    match s {
        "auto" => Ok(Band(None)),
        "full" => Ok(Band(Some(u32::MAX))),
        _ => s
            .parse()
            .map(|n| Band(Some(n)))
            .map_err(|_| format!("`{s}`: expected ROWS, full or auto")),
    }
}

/// `aov=`: what the display starts on.
#[derive(Clone, Copy, Debug)]
struct ShowArg(Show);

/// The page's own arguments, beside the render flags every front door shares.
#[derive(clap::Args, Debug)]
pub struct PageArgs {
    /// The shipped scene the page opens.
    #[arg(long, default_value = "whitted")]
    scene: String,
    /// The WebGL the page asks for: 1 or 2 (default: 2 where the browser has it).
    #[arg(long, value_parser = webgl_version)]
    webgl: Option<u32>,
    /// What the display control starts on: colour, depth, normal, primid or steps.
    #[arg(long, value_parser = |s: &str| parse_show(s).map(ShowArg))]
    aov: Option<ShowArg>,
    /// How a render shows its progress: bands, passes or passes:N (default passes, or
    /// bands where band= is given).
    #[arg(long, value_parser = Progress::parse)]
    progress: Option<Progress>,
    /// Rows per band: ROWS, full or auto.
    #[arg(long, value_parser = band_rows)]
    band: Option<Band>,
    /// Where the page POSTs its finished render (tests and measurements).
    #[arg(long)]
    report: Option<String>,
    /// Whether the advancing passes draw only the tiles that still hold active rays (on,
    /// the default) or the full-screen quad (off): the same image; off measures what the
    /// cut saves (issue 49).
    // A value, not a flag: a `bool` field would make clap take `tiles` alone.
    #[arg(long, value_parser = on_off)]
    tiles: Option<OnOff>,
}

/// `on` or `off`.
#[derive(Clone, Copy, Debug)]
struct OnOff(bool);

fn on_off(s: &str) -> Result<OnOff, String> {
    match s {
        "on" => Ok(OnOff(true)),
        "off" => Ok(OnOff(false)),
        _ => Err(format!("`{s}`: expected on or off")),
    }
}

/// What the query string asks: the render flags (`kernel=`, `spp=`, `width=`, `accel=`,
/// ... as `fragtrace render` takes them, through [`fragtrace::query`]) and the page's own.
pub struct Params {
    /// The render flags, turned into the options of each scene loaded
    /// ([`Choices::to_options`] at [`Door::Web`]).
    pub choices: Choices,
    pub scene: String,
    /// The kernel, as asked until the context is made, then resolved for it.
    pub kernel: Kernel,
    /// `webgl=1|2`; `None`: 2 where the browser has it.
    pub webgl: Option<u32>,
    /// `aov=depth|normal|primid|steps` (or `colour`): what the display control starts on
    /// (the AOVs on WebGL 2 only: they are read from the ray state's fourth attachment).
    pub show: Show,
    /// `spp=N`: samples per pixel, at `fragtrace render --spp N`'s offsets.
    pub spp: u32,
    /// `progress=bands|passes|passes:N`; default `passes`, or `bands` where the query
    /// sets `band=`.
    pub progress: Progress,
    /// Rows per band; `None`: adaptive.
    pub band: Option<u32>,
    pub report: Option<String>,
    /// `tiles=on|off`: [`fragtrace::gpu::options::GpuOptions::tiles`].
    pub tiles: bool,
}

impl Params {
    pub fn from_query(search: &str) -> Result<Params, String> {
        let (choices, page) =
            fragtrace::query::parse_query::<PageArgs>(search).map_err(|e| e.to_string())?;
        Ok(Params {
            scene: page.scene,
            kernel: choices.kernel,
            webgl: page.webgl,
            show: page.aov.and_then(|a| a.0),
            spp: choices.spp.unwrap_or(Door::Web.default_spp()),
            progress: match (page.progress, page.band) {
                (Some(p), _) => p,
                (None, Some(_)) => Progress::Bands,
                (None, None) => Progress::Passes { every: None },
            },
            band: page.band.and_then(|b| b.0),
            report: page.report,
            tiles: page.tiles.is_none_or(|t| t.0),
            choices,
        })
    }
}
