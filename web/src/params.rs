//! The page's query string: what a test, a measurement or a shared link asks for. The
//! controls on the page start from these values (`aov=`, `progress=`, `spp=`).

use fragtrace::accel::AccelKind;
use fragtrace::aov::AovKind;
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
                _ => Err(format!("progress={s}: expected bands, passes or passes:N")),
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
        .ok_or_else(|| format!("aov={s}: expected colour, depth, normal, primid or steps"))
}

/// Most samples per pixel the page takes (the control's maximum).
pub const MAX_SPP: u32 = 256;

/// What the query string asks.
pub struct Params {
    pub scene: String,
    pub size: Option<(u32, u32)>,
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
    pub accel: AccelKind,
    /// Rows per band; `None`: adaptive.
    pub band: Option<u32>,
    pub report: Option<String>,
}

impl Params {
    pub fn from_query(search: &str) -> Result<Params, String> {
        let q = web_sys::UrlSearchParams::new_with_str(search).map_err(|_| "bad query")?;
        let size = match q.get("size") {
            Some(s) => {
                let (w, h) = s.split_once('x').ok_or(format!("size={s}: expected WxH"))?;
                let n = |v: &str| {
                    v.parse::<u32>()
                        .map_err(|_| format!("size={s}: expected WxH"))
                };
                Some((n(w)?, n(h)?))
            }
            None => None,
        };
        // The kernel's one parser (`Kernel`'s `FromStr`, as `--kernel` takes it: the same
        // names and the same unrolled:K range); WebGL has no compute shaders.
        let kernel = match q.get("kernel") {
            None => Kernel::Multipass,
            Some(k) => match k.parse::<Kernel>() {
                Ok(Kernel::Compute) => {
                    return Err(
                        "kernel=compute: WebGL has no compute shaders (expected auto, looped, \
                         multipass or unrolled:K)"
                            .into(),
                    )
                }
                Ok(kernel) => kernel,
                Err(e) => return Err(format!("kernel={k}: {e}")),
            },
        };
        let webgl = match q.get("webgl").as_deref() {
            None => None,
            Some("1") => Some(1),
            Some("2") => Some(2),
            Some(v) => return Err(format!("webgl={v}: expected 1 or 2")),
        };
        let show = match q.get("aov") {
            None => None,
            Some(a) => parse_show(&a)?,
        };
        let spp = match q.get("spp") {
            None => 1,
            Some(s) => match s.parse::<u32>() {
                Ok(n) if (1..=MAX_SPP).contains(&n) => n,
                _ => return Err(format!("spp={s}: expected 1 to {MAX_SPP}")),
            },
        };
        let progress = match (q.get("progress"), q.get("band")) {
            (Some(p), _) => Progress::parse(&p)?,
            (None, Some(_)) => Progress::Bands,
            (None, None) => Progress::Passes { every: None },
        };
        let accel = match q.get("accel").as_deref() {
            None | Some("irregular") => AccelKind::Irregular,
            Some("uniform") => AccelKind::Uniform,
            Some(a) => return Err(format!("accel={a}: expected irregular or uniform")),
        };
        let band = match q.get("band").as_deref() {
            None | Some("auto") => None,
            Some("full") => Some(u32::MAX),
            Some(b) => Some(
                b.parse()
                    .map_err(|_| format!("band={b}: expected ROWS or full"))?,
            ),
        };
        Ok(Params {
            scene: q.get("scene").unwrap_or_else(|| "whitted".into()),
            size,
            kernel,
            webgl,
            show,
            spp,
            progress,
            accel,
            band,
            report: q.get("report"),
        })
    }
}
