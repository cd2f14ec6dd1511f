//! Progress display for long renders: an indicatif bar on stderr that stays hidden when
//! stderr is not a terminal (CI logs, pipes) or when the user asked for quiet.
//!
//! The CPU counts rows. The GL render does not know its total work in advance (how many
//! rays each ray-tree node spawns is counted only when the node is reached), so its bar
//! counts traces (one wave of rays traced to completion: a node's own rays, or one light's
//! shadow rays) against the most the render can still run:
//! - the render starts with every trace of the full ray tree, every sample: a node has its
//!   own trace, one shadow trace per light and, above the depth limit, a reflected and a
//!   refracted subtree, each as large as the full tree below it;
//! - a trace that runs moves one unit from what is left to what is done; a subtree (or a
//!   shadow trace) that an occlusion query finds empty is struck from what is left whole;
//! - within the trace running now, the share of its rays done, 1 - active / (active at the
//!   trace's first termination query), which only grows, since rays finish and never
//!   restart.
//!
//! The position, done / (done + left), only moves forward and reaches 100% exactly when the
//! last trace ends. What is left only overstates what will run (an empty subtree is struck
//! when found), so the bar never runs ahead of the traces: it shows 95% only once 95% of
//! them have run, and jumps forward where a subtree turns out empty. Traces differ in cost
//! (measured on glass.toml at 320x240 with llvmpipe: 27 ms + 5.5 us per ray, 40-600 ms),
//! so the ETA, the time so far scaled by what is left, is an estimate, and a cautious one.
//!
//! A bar over units (the CPU's rows, frames, bench renders) shows its own ETA ([`Eta`]),
//! not indicatif's: rows differ in cost (sky against mesh), and indicatif's estimate,
//! smoothed over 15 s and shown in whole seconds, read "1s" at 467 of 1,200 rows of a
//! render done at 4.2 s, and "0s" from the first rows of a 1.7 s one. Ours is the larger of
//! the average rate's and the recent rate's (the last [`ETA_WINDOW_SHARE`] of the time so
//! far): never below what the rate so far says, and up at once where the rows being
//! rendered now cost more than those before; tenths of a second below ten seconds.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A progress display; cheap to clone (clones share the bar). All methods are no-ops when
/// hidden, so renderers call them unconditionally.
#[derive(Clone)]
pub struct Progress {
    bar: Option<ProgressBar>,
    /// GPU figures shown in the message: passes drawn, rays active at the last query.
    passes: Arc<AtomicU64>,
    active: Arc<AtomicU64>,
    stage: Arc<std::sync::Mutex<String>>,
    /// The GL render's place in its ray tree (see the module documentation).
    tree: Arc<std::sync::Mutex<TreeWalk>>,
    /// A bar over units: its ETA.
    eta: Arc<std::sync::Mutex<Eta>>,
}

/// Resolution of the GL bar: the render is `TREE_STEPS` units long.
const TREE_STEPS: u64 = 10_000;

/// Where the GL render is in its ray tree, in traces (see the module documentation).
#[derive(Debug, Default)]
struct TreeWalk {
    /// Traces finished.
    done: f64,
    /// Traces the render may still run, the current one included.
    left: f64,
    /// Share of the current trace's rays finished, in [0, 1].
    partial: f64,
    /// Rays active at the current trace's first termination query (0: none yet).
    first_active: u64,
    /// Furthest position shown, in [0, 1]: the bar never moves back.
    shown: f64,
}

impl TreeWalk {
    /// done / (done + left), with the current trace's share of rays done.
    fn position(&self) -> f64 {
        let total = self.done + self.left;
        if total <= 0.0 {
            return 1.0;
        }
        ((self.done + self.partial.min(self.left)) / total).clamp(0.0, 1.0)
    }

    fn show(&mut self) {
        self.shown = self.shown.max(self.position());
    }

    fn begin(&mut self, traces: f64) {
        *self = TreeWalk {
            left: traces.max(0.0),
            ..TreeWalk::default()
        };
    }

    fn begin_trace(&mut self) {
        self.partial = 0.0;
        self.first_active = 0;
    }

    fn end_trace(&mut self) {
        let unit = self.left.min(1.0);
        self.done += unit;
        self.left -= unit;
        self.begin_trace();
        self.show();
    }

    fn skip(&mut self, traces: f64) {
        self.left = (self.left - traces.max(0.0)).max(0.0);
        self.show();
    }

    fn active(&mut self, n: u64) {
        if self.first_active == 0 {
            self.first_active = n;
        }
        if self.first_active > 0 {
            let done = 1.0 - n.min(self.first_active) as f64 / self.first_active as f64;
            self.partial = self.partial.max(done);
            self.show();
        }
    }
}

/// The share of the time so far that the recent rate of [`Eta`] is measured over.
pub const ETA_WINDOW_SHARE: f64 = 0.25;
/// The recent rate's shortest window, in seconds (the first moments of a render see a
/// few bands finish at once).
const ETA_MIN_WINDOW_S: f64 = 0.2;

/// The ETA of a bar over units (see the module documentation): fed the time and the units
/// done as they complete, it answers the larger of the average-rate and the recent-rate
/// estimates. The clock is the caller's, so a test drives it with synthetic times.
#[derive(Debug, Default)]
pub struct Eta {
    /// (seconds since the start, units done), oldest first: the last one at or before the
    /// recent window's start, and every one after it.
    samples: std::collections::VecDeque<(f64, f64)>,
}

impl Eta {
    /// `done` units are complete at `t` seconds.
    pub fn record(&mut self, t: f64, done: f64) {
        self.samples.push_back((t, done));
        let start = t - Self::window(t);
        // Keep one sample at or before the window's start: the rate spans the whole window.
        while self.samples.len() > 2 && self.samples[1].0 <= start {
            self.samples.pop_front();
        }
    }

    fn window(t: f64) -> f64 {
        (t * ETA_WINDOW_SHARE).max(ETA_MIN_WINDOW_S)
    }

    /// Seconds still to go at `t` with `done` of `total` units complete (the last
    /// [`Eta::record`]ed); None before any unit is done.
    pub fn seconds_left(&self, t: f64, done: f64, total: f64) -> Option<f64> {
        if !(done > 0.0 && t > 0.0) {
            return None;
        }
        let left = (total - done).max(0.0);
        let average = t * left / done;
        let recent = self
            .samples
            .front()
            .filter(|&&(t0, d0)| t - t0 >= Self::window(t) && done > d0)
            .map_or(0.0, |&(t0, d0)| (t - t0) * left / (done - d0));
        Some(average.max(recent))
    }
}

/// Seconds for a person: tenths below ten seconds, then seconds, then minutes.
pub fn human_seconds(s: f64) -> String {
    match s {
        s if !s.is_finite() => "-".into(),
        s if s < 9.95 => format!("{s:.1}s"),
        s if s < 59.5 => format!("{s:.0}s"),
        s if s < 3600.0 => format!("{}m {:02}s", (s / 60.0) as u64, (s % 60.0) as u64),
        s => format!(
            "{}h {:02}m",
            (s / 3600.0) as u64,
            ((s % 3600.0) / 60.0) as u64
        ),
    }
}

/// The time still to go when a share `done` in (0, 1] of the work took `elapsed`, at the
/// same rate; None before anything is done.
fn eta(elapsed: Duration, done: f64) -> Option<Duration> {
    (done > 0.0 && done.is_finite()).then(|| elapsed.mul_f64((1.0 - done.min(1.0)) / done))
}

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Progress")
            .field("shown", &self.bar.is_some())
            .finish()
    }
}

impl Progress {
    /// A display that draws nothing.
    pub fn hidden() -> Self {
        Progress {
            bar: None,
            passes: Arc::default(),
            active: Arc::default(),
            stage: Arc::default(),
            tree: Arc::default(),
            eta: Arc::default(),
        }
    }

    /// The GL render's bar: the share of the ray tree walked (see the module documentation),
    /// in percent with an ETA, then passes drawn, rays still active and the current stage.
    /// Hidden unless `enabled` and stderr is a terminal.
    pub fn tree_bar(enabled: bool) -> Self {
        let Some(bar) = Self::make(enabled, Some(TREE_STEPS)) else {
            return Self::hidden();
        };
        bar.set_style(
            ProgressStyle::with_template("[{elapsed_precise}] {bar:30} {percent:>3}% {msg}")
                .expect("static template"),
        );
        bar.enable_steady_tick(Duration::from_millis(200));
        Progress {
            bar: Some(bar),
            ..Self::hidden()
        }
    }

    /// A bar over `total` units of work (the CPU's rows). Hidden unless `enabled` and stderr
    /// is a terminal.
    pub fn bar(enabled: bool, total: u64, unit: &str) -> Self {
        let Some(bar) = Self::make(enabled, Some(total)) else {
            return Self::hidden();
        };
        bar.set_style(
            ProgressStyle::with_template(&format!(
                "[{{elapsed_precise}}] {{bar:40}} {{pos}}/{{len}} {unit} (eta {{prefix}})"
            ))
            .expect("static template"),
        );
        Progress {
            bar: Some(bar),
            ..Self::hidden()
        }
    }

    /// A bar over `total` units of work with a message after it (what runs now). Hidden
    /// unless `enabled` and stderr is a terminal.
    pub fn bar_with_message(enabled: bool, total: u64, unit: &str) -> Self {
        let Some(bar) = Self::make(enabled, Some(total)) else {
            return Self::hidden();
        };
        bar.set_style(
            ProgressStyle::with_template(&format!(
                "[{{elapsed_precise}}] {{bar:30}} {{pos}}/{{len}} {unit} (eta {{prefix}}) {{msg}}"
            ))
            .expect("static template"),
        );
        bar.enable_steady_tick(Duration::from_millis(500));
        Progress {
            bar: Some(bar),
            ..Self::hidden()
        }
    }

    fn make(enabled: bool, total: Option<u64>) -> Option<ProgressBar> {
        if !enabled || !std::io::stderr().is_terminal() {
            return None;
        }
        let bar = ProgressBar::with_draw_target(total, ProgressDrawTarget::stderr());
        bar.set_prefix("-");
        Some(bar)
    }

    /// Whether anything is drawn (renderers that can split their work finer for a visible
    /// bar ask; the unit tests check the off cases).
    pub fn is_shown(&self) -> bool {
        self.bar.is_some()
    }

    /// Advances a [`Progress::bar`] by `n` units (thread-safe), and its ETA.
    pub fn inc(&self, n: u64) {
        if let Some(b) = &self.bar {
            let mut eta = self.eta.lock().expect("progress eta lock");
            b.inc(n);
            let (t, done) = (b.elapsed().as_secs_f64(), b.position() as f64);
            eta.record(t, done);
            let total = b.length().unwrap_or(0) as f64;
            b.set_prefix(
                eta.seconds_left(t, done, total)
                    .map_or("-".into(), human_seconds),
            );
        }
    }

    /// Sets the message shown after the bar.
    pub fn message(&self, s: impl Into<String>) {
        if let Some(b) = &self.bar {
            b.set_message(s.into());
        }
    }

    /// Prints a line on stderr above the display (plainly when hidden).
    pub fn println(&self, line: impl AsRef<str>) {
        match &self.bar {
            Some(b) => b.println(line.as_ref()),
            None => eprintln!("{}", line.as_ref()),
        }
    }

    /// Records the passes drawn so far.
    pub fn passes(&self, n: u64) {
        if self.bar.is_some() {
            self.passes.store(n, Ordering::Relaxed);
            self.refresh();
        }
    }

    /// Records the rays active at the latest termination query of the current trace, and
    /// moves the bar by the share of that trace's rays done.
    pub fn active(&self, n: u64) {
        if self.bar.is_some() {
            self.active.store(n, Ordering::Relaxed);
            self.walk(|t| t.active(n));
        }
    }

    /// Names what is being traced (e.g. "sample 1/4, depth 2, shadow rays").
    pub fn stage(&self, s: impl Into<String>) {
        if self.bar.is_some() {
            *self.stage.lock().expect("progress stage lock") = s.into();
            self.refresh();
        }
    }

    /// Starts the GL render's walk: at most `traces` traces in all (the full ray tree of
    /// every sample).
    pub fn begin_tree(&self, traces: f64) {
        self.walk(|t| t.begin(traces));
    }

    /// A trace starts.
    pub fn begin_trace(&self) {
        self.walk(TreeWalk::begin_trace);
    }

    /// The trace running now has ended.
    pub fn end_trace(&self) {
        self.walk(TreeWalk::end_trace);
    }

    /// `traces` that the render will not run (an empty subtree, a light without shadow
    /// rays) are struck from what is left.
    pub fn skip(&self, traces: f64) {
        self.walk(|t| t.skip(traces));
    }

    /// Applies `f` to the tree walk and shows the new position; nothing when hidden.
    fn walk(&self, f: impl FnOnce(&mut TreeWalk)) {
        if let Some(b) = &self.bar {
            {
                let mut t = self.tree.lock().expect("progress tree lock");
                f(&mut t);
                b.set_position((t.shown * TREE_STEPS as f64) as u64);
            }
            self.refresh();
        }
    }

    fn refresh(&self) {
        if let Some(b) = &self.bar {
            let stage = self.stage.lock().expect("progress stage lock").clone();
            let shown = self.tree.lock().expect("progress tree lock").shown;
            let eta =
                eta(b.elapsed(), shown).map_or("-".into(), |d| human_seconds(d.as_secs_f64()));
            b.set_message(format!(
                "(eta {eta}) {} passes, {} rays active  {stage}",
                self.passes.load(Ordering::Relaxed),
                self.active.load(Ordering::Relaxed)
            ));
        }
    }

    /// Removes the display from the terminal.
    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disabled_progress_is_hidden_and_inert() {
        for p in [
            Progress::tree_bar(false),
            Progress::bar(false, 10, "rows"),
            Progress::bar_with_message(false, 10, "renders"),
            Progress::hidden(),
        ] {
            assert!(!p.is_shown());
            p.inc(3);
            p.passes(5);
            p.active(7);
            p.stage("x");
            p.begin_tree(12.0);
            p.begin_trace();
            p.end_trace();
            p.skip(3.0);
            p.message("y");
            p.finish();
            // Hidden displays do not even keep the figures.
            assert_eq!(p.passes.load(Ordering::Relaxed), 0);
            assert_eq!(p.tree.lock().unwrap().left, 0.0);
        }
    }

    /// The most traces a node at `level` of a tree `depth` deep with `lights` lights runs:
    /// (1 + lights) (2^(depth - level + 1) - 1), the full binary tree's nodes below it.
    fn full(level: u32, depth: u32, lights: u32) -> f64 {
        f64::from(1 + lights) * ((1u64 << (depth - level + 1)) - 1) as f64
    }

    /// The GL render's walk (gpu::fragment::tree) of one node and its subtree, where
    /// `rng` decides which shadow traces and subtrees exist (`p_child` each) and how the
    /// active rays fall; each step's position and the traces run so far go to `seen`.
    #[allow(clippy::too_many_arguments)]
    fn walk_node(
        t: &mut TreeWalk,
        level: u32,
        depth: u32,
        lights: u32,
        p_child: f64,
        rng: &mut crate::testing::Rng,
        ran: &mut u64,
        seen: &mut Vec<(f64, f64)>,
    ) {
        fn trace(
            t: &mut TreeWalk,
            rng: &mut crate::testing::Rng,
            ran: &mut u64,
            seen: &mut Vec<(f64, f64)>,
        ) {
            t.begin_trace();
            let mut n = 1 + (rng.f64() * 5000.0) as u64;
            while n > 0 {
                t.active(n);
                seen.push((t.shown, *ran as f64 + t.partial));
                n = (n as f64 * rng.f64()) as u64;
            }
            t.active(0);
            t.end_trace();
            *ran += 1;
            seen.push((t.shown, *ran as f64));
        }
        trace(t, rng, ran, seen);
        for _ in 0..lights {
            if rng.f64() < 0.9 {
                trace(t, rng, ran, seen);
            } else {
                t.skip(1.0);
                seen.push((t.shown, *ran as f64));
            }
        }
        if level < depth {
            for _ in 0..2 {
                if rng.f64() < p_child {
                    walk_node(t, level + 1, depth, lights, p_child, rng, ran, seen);
                } else {
                    t.skip(full(level + 1, depth, lights));
                    seen.push((t.shown, *ran as f64));
                }
            }
        }
    }

    /// The GL bar on scripted ray trees: glass.toml's shape (depth 6, two lights), the
    /// issue's case, where the bar once showed 95% after a tenth of the render; a sparse
    /// tree; a mirror chain; two samples. The position only moves forward, ends at exactly
    /// 100%, never runs ahead of the traces run (shown <= run / total, the current trace's
    /// share of rays included), and on the full tree it is exactly that share.
    #[test]
    fn tree_walk_is_monotone_never_ahead_of_the_traces_and_ends_at_one() {
        let seed = crate::testing::test_seed("tree walk", 0x07E5_7BA4);
        let mut rng = crate::testing::Rng::new(seed);
        for (depth, lights, p_child, spp) in [
            (6, 2, 1.0, 1),
            (6, 2, 0.8, 1),
            (5, 1, 0.5, 2),
            (16, 1, 0.5, 1),
            (0, 3, 1.0, 3),
        ] {
            let mut t = TreeWalk::default();
            t.begin(f64::from(spp) * full(0, depth, lights));
            let (mut ran, mut seen) = (0u64, vec![(0.0, 0.0)]);
            for _ in 0..spp {
                walk_node(
                    &mut t, 0, depth, lights, p_child, &mut rng, &mut ran, &mut seen,
                );
            }
            let case = format!("depth {depth}, {lights} lights, p {p_child}, spp {spp}");
            assert_eq!(t.shown, 1.0, "{case}");
            assert_eq!(t.left, 0.0, "{case}");
            for w in seen.windows(2) {
                assert!(w[1].0 >= w[0].0, "{case}: moved back: {w:?}");
            }
            for &(shown, run) in &seen {
                assert!(
                    shown <= run / ran as f64 + 1e-12,
                    "{case}: {shown} shown after {run} of {ran} traces"
                );
                if p_child == 1.0 && depth == 6 {
                    // No subtree struck (shadow traces may be): at most the one skipped
                    // unit per light ahead of the run share.
                    assert!(shown >= run / (ran as f64 + 1e-9) * 0.9, "{case}");
                }
            }
        }
    }

    /// On the full tree the position is the share of traces run, trace for trace.
    #[test]
    fn tree_walk_counts_traces_on_the_full_tree() {
        let mut t = TreeWalk::default();
        let total = full(0, 3, 2);
        assert_eq!(total, 45.0); // 15 nodes, 3 traces each
        t.begin(total);
        for k in 1..=45 {
            t.begin_trace();
            t.active(100);
            t.active(25);
            assert!((t.shown - (k as f64 - 0.25) / total).abs() < 1e-12, "{k}");
            t.end_trace();
            assert!((t.shown - k as f64 / total).abs() < 1e-12, "{k}");
        }
        assert_eq!(t.shown, 1.0);
        // A subtree found empty is struck whole: the position jumps forward.
        let mut t = TreeWalk::default();
        t.begin(total);
        t.begin_trace();
        t.end_trace();
        t.skip(full(1, 3, 2));
        assert!(
            (t.shown - 1.0 / (total - 21.0)).abs() < 1e-12,
            "{}",
            t.shown
        );
    }

    /// The rows' ETA on synthetic clocks (rows done one after another, each taking its
    /// cost): where rows grow dearer (a mesh below the sky: 1 ms a row for 480 rows, then
    /// 6 ms), the estimate is up to within 10% of the truth once the dearer rows have run
    /// for a window, where the average rate (what indicatif's 15-second smoothing amounts
    /// to over a render of seconds) reads under half of it; it is never below the average
    /// rate's estimate; where rows grow cheaper it over-reads, never under; done, it is 0.
    #[test]
    fn row_eta_follows_dearer_rows_and_never_reads_below_the_average_rate() {
        let seed = crate::testing::test_seed("row eta", 0x0E7A_2026);
        let mut rng = crate::testing::Rng::new(seed);
        let dearer: Vec<f64> = (0..1200)
            .map(|j| if j < 480 { 1e-3 } else { 6e-3 })
            .collect();
        let cheaper: Vec<f64> = dearer.iter().rev().copied().collect();
        let noisy: Vec<f64> = (0..1200).map(|_| 1e-3 * (0.2 + 5.0 * rng.f64())).collect();
        for (name, costs) in [
            ("dearer", &dearer),
            ("cheaper", &cheaper),
            ("noisy", &noisy),
        ] {
            let total = costs.len() as f64;
            let mut eta = Eta::default();
            assert_eq!(eta.seconds_left(0.0, 0.0, total), None);
            let (mut t, mut worst_average, mut worst_ours) = (0.0, f64::INFINITY, f64::INFINITY);
            for (k, c) in costs.iter().enumerate() {
                t += c;
                let done = (k + 1) as f64;
                eta.record(t, done);
                let ours = eta.seconds_left(t, done, total).unwrap();
                let average = t * (total - done) / done;
                assert!(
                    ours >= average * (1.0 - 1e-12),
                    "{name} row {k}: {ours} < {average}"
                );
                let truth: f64 = costs[k + 1..].iter().sum();
                // Past the change by a window (25% of the time so far, 0.2 s at least).
                if name == "dearer" && k >= 480 && t - 0.48 >= Eta::window(t) && k < 1190 {
                    worst_ours = worst_ours.min(ours / truth);
                    worst_average = worst_average.min(average / truth);
                }
                if name == "cheaper" {
                    assert!(ours >= truth * 0.999, "{name} row {k}: {ours} < {truth}");
                }
            }
            assert_eq!(eta.seconds_left(t, total, total), Some(0.0), "{name}");
            if name == "dearer" {
                eprintln!("dearer rows: ours at least {worst_ours:.3} of the truth, the average rate {worst_average:.3}");
                assert!(worst_ours >= 0.9, "ours read {worst_ours} of the truth");
                assert!(
                    worst_average < 0.5,
                    "the profile does not tell: {worst_average}"
                );
            }
        }
    }

    #[test]
    fn seconds_read_in_tenths_then_seconds_then_minutes() {
        assert_eq!(human_seconds(0.84), "0.8s");
        assert_eq!(human_seconds(0.04), "0.0s");
        assert_eq!(human_seconds(9.94), "9.9s");
        assert_eq!(human_seconds(9.96), "10s");
        assert_eq!(human_seconds(42.4), "42s");
        assert_eq!(human_seconds(75.0), "1m 15s");
        assert_eq!(human_seconds(3725.0), "1h 02m");
        assert_eq!(human_seconds(f64::INFINITY), "-");
    }

    #[test]
    fn eta_scales_the_time_so_far_by_the_work_left() {
        let s = Duration::from_secs;
        assert_eq!(eta(s(10), 0.25), Some(s(30)));
        assert_eq!(eta(s(10), 1.0), Some(s(0)));
        assert_eq!(eta(s(10), 0.0), None);
        assert_eq!(eta(s(0), 0.5), Some(s(0)));
    }
}
