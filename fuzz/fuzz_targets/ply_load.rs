//! PLY bytes in (ASCII or binary, any header), a mesh or an `Error` out: never a panic, a
//! hang or unbounded memory. No file is read (a `TextureFile` comment is reported as not
//! read).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = fragtrace::scene::parse_ply(data, "<ply>");
});
