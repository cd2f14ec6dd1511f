//! The monotonic clock every timing in the library reads: `std::time::Instant` natively;
//! on wasm32-unknown-unknown, where `Instant::now` panics, the browser's
//! `performance.now()` through `web-time`, with the same API.

#[cfg(not(target_arch = "wasm32"))]
pub use std::time::Instant;
#[cfg(target_arch = "wasm32")]
pub use web_time::Instant;

/// The process's start as the command line saw it ([`mark_start`]), for the task times
/// parts record.
static START: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();

/// Marks the process's start: the command line calls it first (later calls keep the first
/// mark).
pub fn mark_start() {
    START.get_or_init(Instant::now);
}

/// Milliseconds since [`mark_start`] (since the first call here when nothing marked it).
pub fn since_start_ms() -> u64 {
    START.get_or_init(Instant::now).elapsed().as_millis() as u64
}

/// [`since_start_ms`] to the microsecond.
pub fn since_start_ms_f64() -> f64 {
    START.get_or_init(Instant::now).elapsed().as_secs_f64() * 1e3
}
