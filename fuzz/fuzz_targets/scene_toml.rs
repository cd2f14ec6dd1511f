//! Scene TOML text in, a `Scene` or an `Error` out: never a panic. No file is read
//! (`parse_scene_str` refuses `mesh = ...`).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = fragtrace::scene::parse_scene_str(text, "fuzz.toml");
    }
});
