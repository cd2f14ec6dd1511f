//! Progress display for long renders: an indicatif bar on stderr that stays hidden when
//! stderr is not a terminal (CI logs, pipes) or when the user asked for quiet.
//!
//! The CPU counts rows. The GL render does not know its total work in advance (how many
//! rays each ray-tree node spawns is counted only when the node is reached), so its bar
//! shows the share of the ray tree walked, computed as nested equal shares:
//! - each of the `spp` samples is 1/spp of the render;
//! - within its share, a ray-tree node (the primary rays, or a reflected or refracted
//!   generation) splits its share equally between its traces, in the order they run: its
//!   own rays, one shadow trace per light, then its reflected and its refracted subtree
//!   (when it may have them), each subtree split the same way;
//! - within one trace, the share of rays done: 1 - active / (active at the trace's first
//!   termination query), which only grows, since rays finish and never restart.
//!
//! The position therefore only moves forward (a subtree that spawns no ray is skipped to
//! its end) and reaches 100% exactly when the last trace ends. It is a share of the tree's
//! stages, not of time: a stage with many rays takes longer than its share says, so the
//! ETA (indicatif's, from the rate so far) is an estimate that firms up as the render runs.

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
}

/// Resolution of the GL bar: the render is `TREE_STEPS` units long.
const TREE_STEPS: u64 = 10_000;

/// Where the GL render is in its ray tree: the nodes entered, outermost first.
#[derive(Debug, Default)]
struct TreeWalk {
    /// The current sample's share of the render, `[lo, hi)` in [0, 1].
    sample: (f64, f64),
    nodes: Vec<Node>,
    /// Rays active at the current trace's first termination query (0: none yet).
    first_active: u64,
    /// Furthest position shown, in [0, 1]: the bar never moves back.
    done: f64,
}

/// A ray-tree node's share `[lo, hi)`, split into `parts` equal traces; `part` runs now.
#[derive(Debug, Clone, Copy)]
struct Node {
    lo: f64,
    hi: f64,
    parts: u32,
    part: u32,
}

impl TreeWalk {
    /// The share of the trace that runs now.
    fn current(&self) -> (f64, f64) {
        match self.nodes.last() {
            None => self.sample,
            Some(n) => {
                let w = (n.hi - n.lo) / n.parts as f64;
                let lo = n.lo + w * n.part.min(n.parts) as f64;
                (lo, (lo + w).min(n.hi))
            }
        }
    }

    fn advance(&mut self, to: f64) {
        self.done = self.done.max(to.clamp(0.0, 1.0));
    }

    fn begin_sample(&mut self, k: usize, spp: usize) {
        let spp = spp.max(1) as f64;
        self.sample = (k as f64 / spp, (k as f64 + 1.0) / spp);
        self.nodes.clear();
        self.first_active = 0;
        self.advance(self.sample.0);
    }

    fn begin_node(&mut self, parts: u32) {
        let (lo, hi) = self.current();
        self.nodes.push(Node {
            lo,
            hi,
            parts: parts.max(1),
            part: 0,
        });
        self.first_active = 0;
        self.advance(lo);
    }

    fn next_part(&mut self) {
        if let Some(n) = self.nodes.last_mut() {
            n.part += 1;
        }
        self.first_active = 0;
        let (lo, _) = self.current();
        self.advance(lo);
    }

    fn end_node(&mut self) {
        if let Some(n) = self.nodes.pop() {
            self.advance(n.hi);
        }
        self.first_active = 0;
    }

    fn active(&mut self, n: u64) {
        if self.first_active == 0 {
            self.first_active = n;
        }
        if self.first_active > 0 {
            let (lo, hi) = self.current();
            let done = 1.0 - n.min(self.first_active) as f64 / self.first_active as f64;
            self.advance(lo + (hi - lo) * done);
        }
    }
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
            ProgressStyle::with_template(
                "[{elapsed_precise}] {bar:30} {percent:>3}% (eta {eta}) {msg}",
            )
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
                "[{{elapsed_precise}}] {{bar:40}} {{pos}}/{{len}} {unit} (eta {{eta}})"
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
                "[{{elapsed_precise}}] {{bar:30}} {{pos}}/{{len}} {unit} (eta {{eta}}) {{msg}}"
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
        Some(ProgressBar::with_draw_target(
            total,
            ProgressDrawTarget::stderr(),
        ))
    }

    /// Whether anything is drawn (renderers that can split their work finer for a visible
    /// bar ask; the unit tests check the off cases).
    pub fn is_shown(&self) -> bool {
        self.bar.is_some()
    }

    /// Advances a [`Progress::bar`] by `n` units (thread-safe).
    pub fn inc(&self, n: u64) {
        if let Some(b) = &self.bar {
            b.inc(n);
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
            self.refresh();
        }
    }

    /// Names what is being traced (e.g. "sample 1/4, depth 2, shadow rays").
    pub fn stage(&self, s: impl Into<String>) {
        if self.bar.is_some() {
            *self.stage.lock().expect("progress stage lock") = s.into();
            self.refresh();
        }
    }

    /// Starts sample `k` of `spp` (from 0): its share is `[k/spp, (k+1)/spp)`.
    pub fn begin_sample(&self, k: usize, spp: usize) {
        self.walk(|t| t.begin_sample(k, spp));
    }

    /// Enters a ray-tree node of `parts` traces (its own rays' first) within the share of
    /// the trace running now (the sample, or the parent's subtree part).
    pub fn begin_node(&self, parts: u32) {
        self.walk(|t| t.begin_node(parts));
    }

    /// Moves the current node on to its next trace (the previous one is done or skipped).
    pub fn next_part(&self) {
        self.walk(TreeWalk::next_part);
    }

    /// Leaves the current node: its whole share is done.
    pub fn end_node(&self) {
        self.walk(TreeWalk::end_node);
    }

    /// Applies `f` to the tree walk and shows the new position; nothing when hidden.
    fn walk(&self, f: impl FnOnce(&mut TreeWalk)) {
        if let Some(b) = &self.bar {
            let mut t = self.tree.lock().expect("progress tree lock");
            f(&mut t);
            b.set_position((t.done * TREE_STEPS as f64) as u64);
        }
    }

    fn refresh(&self) {
        if let Some(b) = &self.bar {
            let stage = self.stage.lock().expect("progress stage lock").clone();
            b.set_message(format!(
                "{} passes, {} rays active  {stage}",
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
            p.begin_sample(0, 1);
            p.begin_node(3);
            p.next_part();
            p.end_node();
            p.message("y");
            p.finish();
            // Hidden displays do not even keep the figures.
            assert_eq!(p.passes.load(Ordering::Relaxed), 0);
        }
    }

    /// The GL bar's position walks a two-sample render with a two-level ray tree (one
    /// light, so a node is its rays, a shadow trace, a reflected and a refracted subtree)
    /// forward only, lands on each sample's end and ends at 100%.
    #[test]
    fn tree_walk_is_monotone_and_ends_at_one() {
        let mut t = TreeWalk::default();
        let mut seen = vec![0.0];
        let mut step = |t: &mut TreeWalk, f: &dyn Fn(&mut TreeWalk)| {
            f(t);
            assert!(
                t.done >= *seen.last().unwrap(),
                "moved back: {seen:?} then {}",
                t.done
            );
            seen.push(t.done);
        };
        for k in 0..2 {
            step(&mut t, &|t| t.begin_sample(k, 2));
            assert_eq!(t.done, k as f64 / 2.0);
            step(&mut t, &|t| t.begin_node(4)); // primary rays
            for n in [1000, 600, 10, 0] {
                step(&mut t, &|t| t.active(n));
            }
            assert!(
                (t.done - (k as f64 + 0.25) / 2.0).abs() < 1e-12,
                "{}",
                t.done
            );
            step(&mut t, &TreeWalk::next_part); // shadow rays
            step(&mut t, &|t| t.active(300));
            step(&mut t, &|t| t.active(100));
            step(&mut t, &TreeWalk::next_part); // reflected subtree: a leaf node
            step(&mut t, &|t| t.begin_node(2));
            step(&mut t, &|t| t.active(50));
            step(&mut t, &|t| t.active(0));
            step(&mut t, &TreeWalk::next_part);
            step(&mut t, &TreeWalk::end_node);
            step(&mut t, &TreeWalk::next_part); // refracted subtree: no ray, skipped
            step(&mut t, &TreeWalk::end_node); // the primary node
            assert!(
                (t.done - (k as f64 + 1.0) / 2.0).abs() < 1e-12,
                "{}",
                t.done
            );
        }
        assert_eq!(t.done, 1.0);
    }
}
