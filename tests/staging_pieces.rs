//! The compute kernel's output comes back through two staging slots of a fixed size
//! (16 MiB), a band in as many pieces as it takes, instead of slots as large as a band.
//! Played with slots of 1,000 bytes (`FRAGTRACE_STAGING_SLOT_BYTES`), so that a 97x61
//! image comes back in pieces that end inside pixels and rows: its float image is byte
//! for byte the one read back in a single piece, and its 8-bit PNG is the host's
//! conversion of that float image, code for code.

mod common;

use fragtrace::image_io::{read_image, to_srgb8};

#[test]
fn a_band_read_back_in_pieces_is_the_whole_band() {
    let d = common::tmpdir("staging-pieces");
    let render = |out: &str, slot: Option<&str>| {
        let args =
            common::words("render --backend gl --kernel compute --width 97 --height 61 -q -o");
        let mut args: Vec<&str> = args;
        args.push(out);
        let env: Vec<(&str, &str)> = slot
            .map(|s| vec![("FRAGTRACE_STAGING_SLOT_BYTES", s)])
            .unwrap_or_default();
        common::ok(common::run(&d, &args, &env));
    };
    render("whole.exr", None);
    render("pieces.exr", Some("1000"));
    render("pieces.png", Some("1000"));
    let read = |f: &str| std::fs::read(d.join(f)).unwrap();
    assert!(
        read("pieces.exr") == read("whole.exr"),
        "the float image read back in 1,000-byte pieces differs from the one read whole"
    );
    // 97 x 61 x 12 bytes of floats: 71 pieces; 97 x 61 x 3 bytes of sRGB: 18.
    let whole = read_image(&d.join("whole.exr")).unwrap();
    let want = to_srgb8(&whole);
    let got = image::open(d.join("pieces.png"))
        .unwrap()
        .to_rgb8()
        .into_raw();
    assert_eq!(got.len(), want.len());
    let off: Vec<usize> = (0..want.len()).filter(|&i| got[i] != want[i]).collect();
    assert!(
        off.is_empty(),
        "{} of {} 8-bit codes differ from the host's conversion, first at byte {}",
        off.len(),
        want.len(),
        off[0]
    );
}
