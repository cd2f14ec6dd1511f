//! Progress display for long renders: an indicatif bar on stderr that stays hidden when
//! stderr is not a terminal (CI logs, pipes) or when the user asked for quiet.

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
        }
    }

    /// A spinner for a render whose length is unknown in advance (the GPU's pass loop):
    /// shows elapsed time, passes drawn, rays still active and the current stage. Hidden
    /// unless `enabled` and stderr is a terminal.
    pub fn spinner(enabled: bool) -> Self {
        let Some(bar) = Self::make(enabled, None) else {
            return Self::hidden();
        };
        bar.set_style(
            ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}")
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

    /// Whether anything is drawn (the unit tests check the off cases).
    #[cfg(test)]
    fn is_shown(&self) -> bool {
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

    /// Records the rays active at the latest termination query.
    pub fn active(&self, n: u64) {
        if self.bar.is_some() {
            self.active.store(n, Ordering::Relaxed);
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
            Progress::spinner(false),
            Progress::bar(false, 10, "rows"),
            Progress::bar_with_message(false, 10, "renders"),
            Progress::hidden(),
        ] {
            assert!(!p.is_shown());
            p.inc(3);
            p.passes(5);
            p.active(7);
            p.stage("x");
            p.message("y");
            p.finish();
            // Hidden displays do not even keep the figures.
            assert_eq!(p.passes.load(Ordering::Relaxed), 0);
        }
    }
}
