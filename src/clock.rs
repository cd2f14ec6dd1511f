//! The monotonic clock every timing in the library reads: `std::time::Instant` natively;
//! on wasm32-unknown-unknown, where `Instant::now` panics, the browser's
//! `performance.now()` through `web-time`, with the same API.

#[cfg(not(target_arch = "wasm32"))]
pub use std::time::Instant;
#[cfg(target_arch = "wasm32")]
pub use web_time::Instant;
