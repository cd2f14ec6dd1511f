//! PNG files of large images encoded in bands of rows on every core. The `png` crate's fast
//! setting (`fdeflate`: one Huffman table tuned for filtered image data, one deflate
//! block) is sequential: a 4096² frame took 27-29 ms to write on the H100 machine's host,
//! as long as its render. Here each band's rows are Paeth-filtered (against the real row
//! above, so the filtered bytes are exactly the sequential encoder's) and compressed by
//! `fdeflate` on its own core into a block of its own; the blocks are joined bit for bit
//! into one zlib stream (all but the last marked not final), their Adler-32 sums combined.
//! A block ends right after its end-of-block code, whose last bit is a 1 in `fdeflate`'s one
//! table, so a block's last set bit is its end (a round trip checks it once per process;
//! where it fails, the sequential encoder is used instead). Small images, and one core,
//! take the sequential encoder.

use std::io::Write;
use std::sync::OnceLock;

use rayon::prelude::*;

/// Raw bytes (rows with their filter byte) below which one band is the whole image.
const BAND_BYTES: usize = 1 << 20;

/// Bytes of filtered rows handed to the compressor at once (whole rows, at least one).
const FILTER_BUFFER: usize = 64 << 10;

/// The zlib header `fdeflate` writes, then its block's first bit (BFINAL) at bit 16.
const ZLIB_HEADER: [u8; 2] = [0x78, 0x01];

/// Encodes RGB8 rows (`width` x `height`, top row first) as a PNG into `out`, in bands on
/// the rayon pool; false (and nothing written) where the image is better encoded by the
/// sequential encoder (small, one thread, or an `fdeflate` whose table this module cannot
/// join), which the caller then uses.
pub fn encode(out: &mut impl Write, width: u32, height: u32, rgb: &[u8]) -> std::io::Result<bool> {
    let raw = (width as usize * 3 + 1) * height as usize;
    if raw < 2 * BAND_BYTES || rayon::current_num_threads() < 2 {
        return Ok(false);
    }
    encode_bands(out, width, height, rgb, BAND_BYTES)
}

/// [`encode`] in bands of at least `band_bytes` raw bytes (a few per thread), whatever
/// the image's size and the threads; false only where `fdeflate`'s blocks cannot be
/// joined.
pub fn encode_bands(
    out: &mut impl Write,
    width: u32,
    height: u32,
    rgb: &[u8],
    band_bytes: usize,
) -> std::io::Result<bool> {
    let row = width as usize * 3;
    assert_eq!(rgb.len(), row * height as usize, "RGB8 rows");
    if !joinable() {
        return Ok(false);
    }
    let raw = (row + 1) * height as usize;
    let threads = rayon::current_num_threads();
    let bands = (raw / band_bytes.max(1)).clamp(1, 4 * threads.max(1));
    let idat = zlib_stream(rgb, row, height as usize, bands)?;

    out.write_all(&[0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a])?;
    let mut ihdr = Vec::with_capacity(13);
    ihdr.extend_from_slice(&width.to_be_bytes());
    ihdr.extend_from_slice(&height.to_be_bytes());
    // 8 bits, truecolour, deflate, adaptive filtering, no interlace.
    ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
    chunk(out, b"IHDR", &ihdr)?;
    // IDAT chunks below 2^31 bytes each.
    for part in idat.chunks(1 << 30) {
        chunk(out, b"IDAT", part)?;
    }
    chunk(out, b"IEND", &[])?;
    Ok(true)
}

/// The zlib stream of the filtered rows of `rgb` (`height` rows of `row` bytes), in `bands`
/// blocks compressed on the rayon pool and joined after the zlib header, then the combined
/// Adler-32 sum.
fn zlib_stream(rgb: &[u8], row: usize, height: usize, bands: usize) -> std::io::Result<Vec<u8>> {
    let rows_per = height.div_ceil(bands.max(1));
    let ranges: Vec<(usize, usize)> = (0..height)
        .step_by(rows_per)
        .map(|r0| (r0, (r0 + rows_per).min(height)))
        .collect();
    let last = ranges.len() - 1;
    let blocks: Vec<Block> = ranges
        .par_iter()
        .enumerate()
        .map(|(k, &(r0, r1))| Block::encode(rgb, row, r0, r1, k == last))
        .collect::<std::io::Result<_>>()?;
    let bits: usize = blocks.iter().map(|b| b.bits).sum();
    let mut idat = Vec::with_capacity(2 + bits.div_ceil(8) + 4);
    idat.extend_from_slice(&ZLIB_HEADER);
    let mut joined = BitJoin::new(idat);
    let mut adler = 1u32;
    for b in &blocks {
        joined.push(&b.bytes, b.bits);
        adler = adler32_combine(adler, b.adler, b.len);
    }
    let mut idat = joined.finish();
    idat.extend_from_slice(&adler.to_be_bytes());
    Ok(idat)
}

/// One band's deflate block: its bits (from BFINAL on, through its end-of-block code) in
/// `bytes`, LSB first; the Adler-32 of its `len` filtered bytes.
struct Block {
    bytes: Vec<u8>,
    bits: usize,
    adler: u32,
    len: usize,
}

impl Block {
    fn encode(rgb: &[u8], row: usize, r0: usize, r1: usize, last: bool) -> std::io::Result<Self> {
        // Rows filtered into one small buffer, reused (cache-warm, no fresh pages), and
        // handed to the compressor a few at a time.
        let rows_at_once = (FILTER_BUFFER / (row + 1)).max(1);
        let mut filtered = Vec::with_capacity((row + 1) * rows_at_once);
        let mut c = fdeflate::Compressor::new(Vec::with_capacity((row + 1) * (r1 - r0) / 8))?;
        for r in r0..r1 {
            let cur = &rgb[r * row..][..row];
            let up = (r > 0).then(|| &rgb[(r - 1) * row..][..row]);
            filtered.push(4); // Paeth
            paeth_row(cur, up, &mut filtered);
            if filtered.len() + row + 1 > filtered.capacity() || r + 1 == r1 {
                c.write_data(&filtered)?;
                filtered.clear();
            }
        }
        let mut stream = c.finish()?;
        let len = (row + 1) * (r1 - r0);
        // zlib header, the block, padding to a byte, Adler-32 (big endian).
        let n = stream.len();
        let adler = u32::from_be_bytes(stream[n - 4..].try_into().expect("4 bytes"));
        stream.truncate(n - 4);
        stream.drain(..2);
        let end = stream.last().copied().unwrap_or(0);
        if end == 0 {
            return Err(std::io::Error::other("fdeflate block without its end code"));
        }
        let bits = (stream.len() - 1) * 8 + (8 - end.leading_zeros() as usize);
        if !last {
            stream[0] &= !1; // BFINAL: more blocks follow
        }
        Ok(Block {
            bytes: stream,
            bits,
            adler,
            len,
        })
    }
}

/// Appends the Paeth filter of `cur` (3 bytes a pixel) against the row above (`up`, or
/// zeros for the first row) to `out`: the PNG specification's predictor, branch-free.
fn paeth_row(cur: &[u8], up: Option<&[u8]>, out: &mut Vec<u8>) {
    let at = out.len();
    out.resize(at + cur.len(), 0);
    let dst = &mut out[at..];
    match up {
        // Above the first row all is zero: the predictor is the left byte (Sub).
        None => {
            dst[..3.min(cur.len())].copy_from_slice(&cur[..3.min(cur.len())]);
            if cur.len() > 3 {
                for ((d, &x), &a) in dst[3..].iter_mut().zip(&cur[3..]).zip(cur) {
                    *d = x.wrapping_sub(a);
                }
            }
        }
        Some(up) => {
            for i in 0..3.min(cur.len()) {
                dst[i] = cur[i].wrapping_sub(up[i]);
            }
            if cur.len() > 3 {
                let n = cur.len() - 3;
                // Zipped slices (no index checks), so the loop vectorises.
                let left = &cur[..n];
                let above = &up[3..];
                let corner = &up[..n];
                // Fixed-size chunks first: their inner loop vectorises.
                const CHUNK: usize = 32;
                let mut d = dst[3..].chunks_exact_mut(CHUNK);
                let mut x = cur[3..].chunks_exact(CHUNK);
                let mut a = left.chunks_exact(CHUNK);
                let mut b = above.chunks_exact(CHUNK);
                let mut c = corner.chunks_exact(CHUNK);
                for ((((d, x), a), b), c) in
                    (&mut d).zip(&mut x).zip(&mut a).zip(&mut b).zip(&mut c)
                {
                    for k in 0..CHUNK {
                        d[k] = x[k].wrapping_sub(paeth(a[k], b[k], c[k]));
                    }
                }
                for ((((d, &x), &a), &b), &c) in d
                    .into_remainder()
                    .iter_mut()
                    .zip(x.remainder())
                    .zip(a.remainder())
                    .zip(b.remainder())
                    .zip(c.remainder())
                {
                    *d = x.wrapping_sub(paeth(a, b, c));
                }
            }
        }
    }
}

/// The Paeth predictor of left `a`, above `b`, above-left `c`, in unsigned 8-bit
/// operations only (Versari's formulation for FPNGE: `pc` matters only where `c` lies
/// between `a` and `b`, and is then `|pa - pb|`), which vectorises; ties as the
/// specification breaks them (a, then b, then c).
#[inline(always)]
fn paeth(a: u8, b: u8, c: u8) -> u8 {
    let pa = b.max(c) - b.min(c);
    let pb = a.max(c) - a.min(c);
    let pc = if (a < c) == (c < b) {
        pa.max(pb) - pa.min(pb)
    } else {
        255
    };
    if pa <= pb && pa <= pc {
        a
    } else if pb <= pc {
        b
    } else {
        c
    }
}

/// A bit stream (LSB first) built by appending whole blocks at any bit position.
struct BitJoin {
    out: Vec<u8>,
    /// Bits in `out` (the last byte's bits past them are zero).
    bits: usize,
}

impl BitJoin {
    /// A stream that starts with the whole bytes `out`.
    fn new(out: Vec<u8>) -> Self {
        let bits = out.len() * 8;
        BitJoin { out, bits }
    }

    /// Appends the first `bits` bits of `src` (the bits past them in its last byte zero).
    fn push(&mut self, src: &[u8], bits: usize) {
        let src = &src[..bits.div_ceil(8)];
        let phase = (self.bits % 8) as u32;
        if phase == 0 {
            self.out.extend_from_slice(src);
        } else {
            // The partial last byte's bits below `phase` are the stream's; each source
            // word is shifted up by `phase`, its top bits carried into the next.
            let mut carry = self.out.pop().expect("a partial byte");
            let mut words = src.chunks_exact(8);
            for w in &mut words {
                let v = u64::from_le_bytes(w.try_into().expect("8 bytes"));
                self.out
                    .extend_from_slice(&((v << phase) | u64::from(carry)).to_le_bytes());
                carry = (v >> (64 - phase)) as u8;
            }
            for &b in words.remainder() {
                self.out.push((b << phase) | carry);
                carry = b >> (8 - phase);
            }
            self.out.push(carry);
        }
        self.bits += bits;
        self.out.truncate(self.bits.div_ceil(8));
    }

    fn finish(self) -> Vec<u8> {
        self.out
    }
}

/// Adler-32 of a followed by b (`len_b` bytes), from the two sums (zlib's
/// `adler32_combine`).
fn adler32_combine(a: u32, b: u32, len_b: usize) -> u32 {
    const BASE: u64 = 65521;
    let rem = (len_b as u64) % BASE;
    let (a1, a2) = (u64::from(a & 0xffff), u64::from(a >> 16));
    let (b1, b2) = (u64::from(b & 0xffff), u64::from(b >> 16));
    let s1 = (a1 + b1 + BASE - 1) % BASE;
    let s2 = (a2 + b2 + rem * a1 % BASE + BASE - rem) % BASE;
    ((s2 << 16) | s1) as u32
}

/// One PNG chunk: length, type, data, CRC-32 of type and data.
fn chunk(out: &mut impl Write, kind: &[u8; 4], data: &[u8]) -> std::io::Result<()> {
    out.write_all(&(data.len() as u32).to_be_bytes())?;
    out.write_all(kind)?;
    out.write_all(data)?;
    let mut crc = crc32fast::Hasher::new();
    crc.update(kind);
    crc.update(data);
    out.write_all(&crc.finalize().to_be_bytes())
}

/// Whether `fdeflate`'s blocks can be joined here: a small image's three blocks, joined as
/// [`encode_bands`] joins them, inflate (by `fdeflate` itself, its Adler-32 checked) to the
/// rows filtered. That holds where every block ends with a 1 bit: its end-of-block code,
/// whose last bit `fdeflate`'s one table fixes (1 in 0.3). Checked once per process.
fn joinable() -> bool {
    static OK: OnceLock<bool> = OnceLock::new();
    *OK.get_or_init(|| {
        let (row, height) = (3 * 7, 9);
        let rgb: Vec<u8> = (0..row * height).map(|i| (i * 37 % 251) as u8).collect();
        let mut want = Vec::new();
        for r in 0..height {
            want.push(4);
            let up = (r > 0).then(|| &rgb[(r - 1) * row..][..row]);
            paeth_row(&rgb[r * row..][..row], up, &mut want);
        }
        zlib_stream(&rgb, row, height, 3)
            .ok()
            .and_then(|z| fdeflate::decompress_to_vec(&z).ok())
            .is_some_and(|raw| raw == want)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (the seed printed by each test that uses it).
    struct Lcg(u64);
    impl Lcg {
        fn byte(&mut self) -> u8 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 56) as u8
        }
    }

    /// The specification's Paeth predictor, as written there (PNG 1.2, 6.6).
    fn paeth_spec(a: u8, b: u8, c: u8) -> u8 {
        let p = i16::from(a) + i16::from(b) - i16::from(c);
        let (pa, pb, pc) = (
            (p - i16::from(a)).abs(),
            (p - i16::from(b)).abs(),
            (p - i16::from(c)).abs(),
        );
        if pa <= pb && pa <= pc {
            a
        } else if pb <= pc {
            b
        } else {
            c
        }
    }

    /// Images of every kind the encoder meets: flat, ramps, noise, and mixed rows.
    fn image(w: usize, h: usize, kind: u32, seed: u64) -> Vec<u8> {
        let mut g = Lcg(seed);
        (0..w * h * 3)
            .map(|i| match kind {
                0 => 7,
                1 => (i % 251) as u8,
                2 => g.byte(),
                _ => {
                    if (i / (w * 3)).is_multiple_of(3) {
                        g.byte()
                    } else {
                        (i / 3 % 17) as u8
                    }
                }
            })
            .collect()
    }

    /// The IDAT bytes of a PNG file, joined.
    fn idat(png: &[u8]) -> Vec<u8> {
        let mut at = 8;
        let mut out = Vec::new();
        while at < png.len() {
            let n = u32::from_be_bytes(png[at..at + 4].try_into().unwrap()) as usize;
            let kind = &png[at + 4..at + 8];
            let data = &png[at + 8..at + 8 + n];
            let crc = u32::from_be_bytes(png[at + 8 + n..at + 12 + n].try_into().unwrap());
            let mut h = crc32fast::Hasher::new();
            h.update(kind);
            h.update(data);
            assert_eq!(
                h.finalize(),
                crc,
                "CRC of {}",
                String::from_utf8_lossy(kind)
            );
            if kind == b"IDAT" {
                out.extend_from_slice(data);
            }
            at += 12 + n;
        }
        out
    }

    #[test]
    fn fdeflates_blocks_can_be_joined() {
        assert!(joinable());
    }

    #[test]
    fn images_in_bands_decode_to_their_pixels_with_the_specifications_filter() {
        let seed = 0x5eed_0000_0000_0063u64;
        println!("seed {seed:#x}");
        for (w, h) in [
            (1, 1),
            (2, 1),
            (1, 9),
            (3, 7),
            (31, 17),
            (257, 31),
            (640, 48),
        ] {
            for kind in 0..4 {
                let rgb = image(w, h, kind, seed ^ (w * 1000 + h) as u64);
                let row = w * 3;
                // The reference filtered stream: Paeth on every row, from the specification.
                let mut want = Vec::new();
                for r in 0..h {
                    want.push(4);
                    for i in 0..row {
                        let a = if i >= 3 { rgb[r * row + i - 3] } else { 0 };
                        let b = if r > 0 { rgb[(r - 1) * row + i] } else { 0 };
                        let c = if r > 0 && i >= 3 {
                            rgb[(r - 1) * row + i - 3]
                        } else {
                            0
                        };
                        want.push(rgb[r * row + i].wrapping_sub(paeth_spec(a, b, c)));
                    }
                }
                // One row a band, a few rows, and one band.
                for band in [1, 3 * (row + 1) + 1, 1 << 30] {
                    let what = format!("{w}x{h} kind {kind} bands of {band} bytes");
                    let mut png = Vec::new();
                    assert!(encode_bands(&mut png, w as u32, h as u32, &rgb, band).unwrap());
                    // The zlib stream, its Adler-32 checked.
                    let raw = miniz_oxide::inflate::decompress_to_vec_zlib(&idat(&png))
                        .unwrap_or_else(|e| panic!("{what}: {e:?}"));
                    assert!(raw == want, "{what}: the filtered rows differ");
                    let img = image::load_from_memory(&png).unwrap().to_rgb8();
                    assert_eq!((img.width(), img.height()), (w as u32, h as u32), "{what}");
                    assert!(img.into_raw() == rgb, "{what}: the pixels differ");
                }
            }
        }
    }

    #[test]
    fn a_large_image_takes_the_bands_on_two_threads_or_more() {
        let (w, h) = (1024usize, 768usize); // 2.25 MiB raw, past two bands' worth
        let rgb = image(w, h, 3, 0x63);
        let mut png = Vec::new();
        let banded = encode(&mut png, w as u32, h as u32, &rgb).unwrap();
        assert_eq!(banded, rayon::current_num_threads() >= 2);
        if banded {
            let img = image::load_from_memory(&png).unwrap().to_rgb8();
            assert!(img.into_raw() == rgb);
        } else {
            assert!(png.is_empty(), "nothing written where the caller encodes");
        }
        // Small images are the sequential encoder's.
        assert!(!encode(&mut Vec::new(), 64, 64, &image(64, 64, 1, 1)).unwrap());
    }

    #[test]
    fn adler32_sums_combine_as_one_over_the_whole() {
        let adler = |d: &[u8]| {
            let (mut a, mut b) = (1u32, 0u32);
            for &x in d {
                a = (a + u32::from(x)) % 65521;
                b = (b + a) % 65521;
            }
            (b << 16) | a
        };
        let mut g = Lcg(63);
        let data: Vec<u8> = (0..200_000).map(|_| g.byte()).collect();
        for cut in [0, 1, 5551, 65521, 100_000, 200_000] {
            let (x, y) = data.split_at(cut);
            assert_eq!(
                adler32_combine(adler(x), adler(y), y.len()),
                adler(&data),
                "cut {cut}"
            );
        }
    }

    #[test]
    fn bits_join_at_every_phase() {
        let mut g = Lcg(7);
        let mut want: Vec<bool> = Vec::new();
        let mut j = BitJoin::new(vec![0xa5]);
        want.extend((0..8).map(|k| (0xa5 >> k) & 1 == 1));
        for n in [1usize, 3, 8, 9, 63, 64, 65, 130, 7, 200] {
            let mut src: Vec<u8> = (0..n.div_ceil(8)).map(|_| g.byte()).collect();
            if !n.is_multiple_of(8) {
                *src.last_mut().unwrap() &= (1u8 << (n % 8)) - 1; // bits past n are zero
            }
            want.extend((0..n).map(|k| (src[k / 8] >> (k % 8)) & 1 == 1));
            j.push(&src, n);
        }
        let out = j.finish();
        assert_eq!(out.len(), want.len().div_ceil(8));
        for (k, &bit) in want.iter().enumerate() {
            assert_eq!((out[k / 8] >> (k % 8)) & 1 == 1, bit, "bit {k}");
        }
    }
}
