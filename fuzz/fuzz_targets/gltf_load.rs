//! glTF JSON or GLB bytes in, a mesh or an `Error` out: never a panic, a hang or unbounded
//! memory. No file is read (external buffers are errors, external images texture
//! problems); data URIs and the GLB's BIN chunk are.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = fragtrace::scene::parse_gltf(data, "<gltf>");
});
