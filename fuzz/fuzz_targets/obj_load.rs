//! OBJ text plus MTL text in (split at the first NUL byte; no NUL: no MTL, i.e. a missing
//! library), a mesh or an `Error` out: never a panic. No file is read.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let (obj, mtl) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], Some(&data[i + 1..])),
        None => (data, None),
    };
    // The loader reads files as lossy UTF-8; do the same here.
    let obj = String::from_utf8_lossy(obj);
    let mtl = mtl.map(String::from_utf8_lossy);
    let _ = fragtrace::scene::parse_obj_with_mtl(&obj, mtl.as_deref());
});
