//! Images in memory (linear RGB f32) and on disk: PNG (sRGB-encoded, clamped, 8-bit) or
//! OpenEXR (linear f32), chosen by the file extension. Files are written to a temporary
//! name in the same folder and renamed, so a failed or interrupted write never leaves a
//! partial file and never replaces an existing one.

use std::path::{Path, PathBuf};

use crate::{Error, Result};

/// A linear-light RGB image, row-major with the top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// RGB triples, `3 * width * height` values (none in a render that returned the
    /// image as 8-bit sRGB only: [`Image::size_only`]).
    pub data: Vec<f32>,
}

impl Image {
    /// The size of an image whose linear data was not read back.
    pub fn size_only(width: u32, height: u32) -> Self {
        Image {
            width,
            height,
            data: Vec::new(),
        }
    }

    /// Wraps RGB data (panics on a size mismatch: a programming error).
    pub fn from_rgb(width: u32, height: u32, data: Vec<f32>) -> Self {
        assert_eq!(data.len(), (width * height * 3) as usize, "image data size");
        Image {
            width,
            height,
            data,
        }
    }

    /// The pixel at column `i`, row `j` (0 = top).
    pub fn pixel(&self, i: u32, j: u32) -> [f32; 3] {
        let k = ((j * self.width + i) * 3) as usize;
        [self.data[k], self.data[k + 1], self.data[k + 2]]
    }

    /// True when every value is finite.
    pub fn all_finite(&self) -> bool {
        self.data.iter().all(|v| v.is_finite())
    }
}

/// Output format, from the file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// 8-bit sRGB PNG (`.png`).
    Png,
    /// 32-bit float linear OpenEXR (`.exr`).
    Exr,
    /// Radiance RGBE (`.hdr`): linear, a shared 8-bit exponent per pixel (about 1% relative
    /// precision, no negative values).
    Hdr,
    /// 32-bit float linear TIFF (`.tif`, `.tiff`).
    Tiff,
    /// 8-bit sRGB binary PPM (`.ppm`, netpbm P6).
    Ppm,
    /// 8-bit sRGB baseline JPEG (`.jpg`, `.jpeg`), quality [`JPEG_QUALITY`]: lossy, for
    /// sharing and previews (the tests and `compare` want PNG or EXR).
    Jpeg,
}

/// The JPEG quality `-o x.jpg` writes (the image crate's scale, 1-100): visually lossless
/// for renders, about a tenth of the PNG's size.
pub const JPEG_QUALITY: u8 = 95;

/// The extensions [`Format::from_path`] knows, as the error message lists them.
pub const EXTENSIONS: &str = ".png, .exr, .hdr, .tif/.tiff, .ppm or .jpg/.jpeg";

impl Format {
    /// Format from a path's extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<Format> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .as_deref()
        {
            Some("png") => Ok(Format::Png),
            Some("exr") => Ok(Format::Exr),
            Some("hdr") => Ok(Format::Hdr),
            Some("tif" | "tiff") => Ok(Format::Tiff),
            Some("ppm") => Ok(Format::Ppm),
            Some("jpg" | "jpeg") => Ok(Format::Jpeg),
            _ => Err(Error::Usage(format!(
                "{}: unknown image extension (use {EXTENSIONS})",
                path.display()
            ))),
        }
    }

    /// True for the 8-bit sRGB formats, whose values are quantised and clamped to 0..=1.
    pub fn is_srgb8(self) -> bool {
        matches!(self, Format::Png | Format::Ppm | Format::Jpeg)
    }
}

/// Linear to sRGB transfer function (IEC 61966-2-1).
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v >= 1.0 {
        1.0
    } else if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// sRGB to linear transfer function.
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// 8-bit sRGB bytes of an image.
pub fn to_srgb8(img: &Image) -> Vec<u8> {
    img.data.iter().map(|&v| srgb8_fast(v)).collect()
}

/// The 8-bit sRGB code of one linear value (clamped to [0, 1]; NaN gives 0): the
/// definition, one `powf` per value. [`srgb8_fast`] gives the same code without it.
pub fn srgb8(v: f32) -> u8 {
    (linear_to_srgb(v) * 255.0 + 0.5).floor() as u8
}

/// [`srgb8`] by one table look-up and one comparison, the same code for every f32 (a test
/// checks all of [0, 1] and the values outside it) at a fraction of a `powf`'s cost: the
/// host converts whole images to 8-bit with it. The value, clamped to [0, 1] (NaN to 0),
/// picks a bucket by its top 16 bits (sign, exponent, 7 bits of mantissa); a bucket holds at
/// most one of [`srgb8_thresholds`] (the table's build checks it), so the code is the
/// bucket's lowest code plus one where the value reaches that threshold. The GPU converts
/// with the thresholds themselves (`srgb8.comp`, `srgb8.frag`): the same bytes.
#[inline]
pub fn srgb8_fast(v: f32) -> u8 {
    let t = srgb8_buckets();
    // `max` returns 0 for NaN, as `srgb8` gives (`clamp` would keep the NaN); 1.0's bucket
    // is the table's last.
    #[allow(clippy::manual_clamp)]
    let v = v.max(0.0).min(1.0);
    let b = (v.to_bits() >> SRGB8_BUCKET_SHIFT) as usize;
    t.base[b] + u8::from(v >= t.threshold[b])
}

/// Bits of an f32 below [`srgb8_fast`]'s bucket index: with 16, a bucket spans 2^-7 of an
/// octave (0.0039 in [0.5, 1)), less than the thresholds' spacing there (0.0060 at 0.5);
/// 17 puts two thresholds in one bucket near 0.53.
const SRGB8_BUCKET_SHIFT: u32 = 16;

/// [`srgb8_fast`]'s table: per bucket of the f32 bit patterns of [0, 1], the code of its
/// lowest value and the one threshold inside it (+inf where none is).
struct Srgb8Buckets {
    base: Vec<u8>,
    threshold: Vec<f32>,
}

fn srgb8_buckets() -> &'static Srgb8Buckets {
    static B: std::sync::OnceLock<Srgb8Buckets> = std::sync::OnceLock::new();
    B.get_or_init(|| {
        let t = srgb8_thresholds();
        let n = (1f32.to_bits() >> SRGB8_BUCKET_SHIFT) as usize + 1;
        let mut base = vec![0u8; n];
        let mut threshold = vec![f32::INFINITY; n];
        for b in 0..n {
            let lo = f32::from_bits((b as u32) << SRGB8_BUCKET_SHIFT);
            let hi = f32::from_bits(((b as u32 + 1) << SRGB8_BUCKET_SHIFT) - 1);
            let (c_lo, c_hi) = (
                t.partition_point(|&x| x <= lo),
                t.partition_point(|&x| x <= hi),
            );
            assert!(c_hi - c_lo <= 1, "sRGB bucket {b} holds two thresholds");
            base[b] = c_lo as u8;
            if c_hi > c_lo {
                threshold[b] = t[c_lo];
            }
        }
        Srgb8Buckets { base, threshold }
    })
}

/// The 255 linear values at which [`srgb8`] steps up: entry `c - 1` is the smallest f32
/// whose code is at least `c`. Since the code never decreases as the value grows (checked
/// for every f32 in [0, 1] by a test), the code of `v` is the number of entries `<= v`:
/// how the GPU converts to 8-bit sRGB with exactly this function's rounding, comparisons
/// only, so a PNG is the same bytes whichever side converted it.
pub fn srgb8_thresholds() -> &'static [f32; 255] {
    static T: std::sync::OnceLock<[f32; 255]> = std::sync::OnceLock::new();
    T.get_or_init(|| {
        let mut t = [0f32; 255];
        for (k, slot) in t.iter_mut().enumerate() {
            let code = k as u8 + 1;
            // Binary search over the bit patterns of [0, 1], which order like the values.
            let (mut lo, mut hi) = (0u32, 1f32.to_bits());
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if srgb8(f32::from_bits(mid)) >= code {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            *slot = f32::from_bits(lo);
        }
        t
    })
}

/// Makes the folder `dir` (and its parents) where output goes: a usage error naming it
/// when a file of that name is in the way (the OS alone would say "File exists"), an I/O
/// error naming it otherwise.
pub fn create_folder(dir: &Path, what: &str) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        return Err(Error::Usage(format!(
            "{}: cannot make the {what} folder there: a file of that name exists",
            dir.display()
        )));
    }
    std::fs::create_dir_all(dir).map_err(|source| Error::Io {
        path: dir.to_path_buf(),
        source,
    })
}

fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().into_owned())
        .unwrap_or_default();
    // Keep the real extension last: the encoder is picked explicitly, but tools that look
    // at a half-written file should still see what it is.
    path.with_file_name(format!(".{name}.{}.partial.{ext}", std::process::id()))
}

/// The temporary files being written now, for [`remove_partials_on_signal`]'s handler.
static WRITING: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Writes `bytes` atomically to `path` by way of a temporary file and a rename.
pub fn write_atomic(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = temp_path(path);
    if let Ok(mut w) = WRITING.lock() {
        w.push(tmp.clone());
    }
    let res = write(&tmp).and_then(|_| {
        std::fs::rename(&tmp, path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })
    });
    if res.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    if let Ok(mut w) = WRITING.lock() {
        w.retain(|p| p != &tmp);
    }
    res
}

/// From now on, SIGTERM, SIGINT and SIGHUP (a scheduler's time limit, preemption,
/// `scancel`, Ctrl-C) remove the temporary files of the writes in progress and end the
/// process with exit code 143, so an interrupted task leaves no hidden
/// `.NAME.<pid>.partial.EXT` behind. SIGKILL cannot be caught: [`remove_stale_partials`]
/// clears what it leaves at the next write of the same file. Once per process; later calls
/// do nothing.
#[cfg(not(target_arch = "wasm32"))]
pub fn remove_partials_on_signal() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The handler runs on ctrlc's own thread, not in signal context: it may lock and
        // touch the file system. A failure to install it leaves the default action.
        let _ = ctrlc::set_handler(|| {
            // A writer holding the lock is between two statements; wait for it.
            let files = WRITING.lock().map(|w| w.clone()).unwrap_or_default();
            for f in files {
                let _ = std::fs::remove_file(f);
            }
            eprintln!("fragtrace: stopped by a signal; no partial file left");
            std::process::exit(143);
        });
    });
}

/// Removes the temporary files ([`write_atomic`]'s `.NAME.<pid>.partial.EXT`) that earlier
/// processes left next to `path` when they were killed (SIGKILL, a node lost) while
/// writing it: those whose process is no longer running on this machine. Returns how
/// many were removed. Called before a file is written anew and after a merge.
pub fn remove_stale_partials(path: &Path) -> usize {
    let Some(name) = path.file_name().map(|n| n.to_string_lossy().into_owned()) else {
        return 0;
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    // Without /proc no process can be told alive: remove nothing.
    let (Ok(entries), true) = (std::fs::read_dir(dir), Path::new("/proc/self").exists()) else {
        return 0;
    };
    let prefix = format!(".{name}.");
    let mut removed = 0;
    for e in entries.flatten() {
        let f = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = f.strip_prefix(&prefix) else {
            continue;
        };
        let Some((pid, tail)) = rest.split_once('.') else {
            continue;
        };
        let Ok(pid) = pid.parse::<u32>() else {
            continue;
        };
        if !tail.starts_with("partial") || pid == std::process::id() {
            continue;
        }
        if Path::new(&format!("/proc/{pid}")).exists() {
            continue;
        }
        if std::fs::remove_file(e.path()).is_ok() {
            removed += 1;
        }
    }
    removed
}

/// Writes an image in the format of `path`'s extension ([`Format`]): 8-bit sRGB for PNG and
/// PPM, linear float for EXR, TIFF and Radiance HDR.
pub fn write_image(path: &Path, img: &Image) -> Result<()> {
    let format = Format::from_path(path)?;
    let img_err = |e: image::ImageError| Error::Image {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let size_err = || Error::Internal(format!("{format:?} buffer size"));
    if format.is_srgb8() {
        return write_srgb8(path, img.width, img.height, &to_srgb8(img));
    }
    if format == Format::Exr {
        return write_exr_rgb(path, img);
    }
    write_atomic(path, |tmp| {
        let buf = image::Rgb32FImage::from_raw(img.width, img.height, img.data.clone())
            .ok_or_else(size_err)?;
        let f = match format {
            Format::Hdr => image::ImageFormat::Hdr,
            _ => image::ImageFormat::Tiff,
        };
        buf.save_with_format(tmp, f).map_err(img_err)
    })
}

/// Writes a linear image as OpenEXR the way the farm's parts are written: R, G, B as
/// 32-bit floats, ZIP-compressed scanlines (`exr`'s `SMALL_LOSSLESS`), so every EXR
/// fragtrace writes has one layout (the image crate's encoder wrote uncompressed tiles).
fn write_exr_rgb(path: &Path, img: &Image) -> Result<()> {
    use exr::prelude::*;
    if img.data.len() != img.width as usize * img.height as usize * 3 {
        return Err(crate::Error::Internal("EXR buffer size".into()));
    }
    let w = img.width as usize;
    let channels = SpecificChannels::rgb(|p: Vec2<usize>| {
        let k = (p.y() * w + p.x()) * 3;
        (img.data[k], img.data[k + 1], img.data[k + 2])
    });
    let layer = Layer::new(
        (w, img.height as usize),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    let image = exr::image::Image::from_layer(layer);
    write_atomic(path, |tmp| {
        image.write().to_file(tmp).map_err(|e| crate::Error::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    })
}

/// Writes 8-bit sRGB RGB bytes (top row first) in the 8-bit format of `path`'s extension
/// (PNG, PPM or JPEG), atomically: what a render that converted to 8-bit (on the GPU, or
/// in the CPU's bands) hands over, and [`write_image`]'s 8-bit path.
pub fn write_srgb8(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
    let format = Format::from_path(path)?;
    if rgb.len() != width as usize * height as usize * 3 || !format.is_srgb8() {
        return Err(Error::Internal(format!("{format:?}: 8-bit buffer")));
    }
    let img_err = |e: image::ImageError| Error::Image {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    write_atomic(path, |tmp| {
        let file = || {
            std::fs::File::create(tmp)
                .map(std::io::BufWriter::new)
                .map_err(|source| Error::Io {
                    path: path.to_path_buf(),
                    source,
                })
        };
        use image::ImageEncoder;
        match format {
            Format::Png => encode_png(tmp, path, width, height, rgb),
            // The image crate's PNM default is PAM (P7); PPM readers want P6.
            Format::Ppm => {
                use image::codecs::pnm::{PnmEncoder, PnmSubtype, SampleEncoding};
                PnmEncoder::new(file()?)
                    .with_subtype(PnmSubtype::Pixmap(SampleEncoding::Binary))
                    .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
                    .map_err(img_err)
            }
            Format::Jpeg => {
                image::codecs::jpeg::JpegEncoder::new_with_quality(file()?, JPEG_QUALITY)
                    .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
                    .map_err(img_err)
            }
            Format::Exr | Format::Hdr | Format::Tiff => unreachable!("checked 8-bit above"),
        }
    })
}

/// Encodes RGB8 as a PNG at `tmp` with the fast deflate setting (`fdeflate`, through the
/// `png` crate's `Compression::Fast`): at 4096x4096 the default setting took longer than
/// the render itself (docs/performance.md). Every row Paeth-filtered rather than the
/// adaptive choice of the five filters per row: encoding 28-32% faster (the built-in scene
/// at 4096² 21.8 against 30.4 ms here, 44-49 against 73-76 ms on the H200 host) for files
/// within 0.6% of the adaptive ones, smaller on two of three renders tried. Pixels are
/// the same. Images of 2 MiB and more are encoded the same way in bands on every core
/// ([`crate::png_bands`]: the built-in scene at 4096² 13 against 21-23 ms here, 2 cores).
fn encode_png(tmp: &Path, path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    use image::ImageEncoder;
    let file = std::fs::File::create(tmp).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut w = std::io::BufWriter::with_capacity(1 << 20, file);
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    // Large images in bands on every core (crate::png_bands), else the crate's encoder.
    if crate::png_bands::encode(&mut w, width, height, rgb).map_err(io)? {
        return std::io::Write::flush(&mut w).map_err(io);
    }
    PngEncoder::new_with_quality(w, CompressionType::Fast, FilterType::Paeth)
        .write_image(rgb, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| Error::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
}

/// Reads an image written by [`write_image`] (any [`Format`]; the 8-bit sRGB ones decoded
/// to linear).
pub fn read_image(path: &Path) -> Result<Image> {
    let format = Format::from_path(path)?;
    let dynimg = image::open(path).map_err(|e| Error::Image {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let (w, h) = (dynimg.width(), dynimg.height());
    let data = if format.is_srgb8() {
        dynimg
            .to_rgb8()
            .into_raw()
            .into_iter()
            .map(|b| srgb_to_linear(b as f32 / 255.0))
            .collect()
    } else {
        dynimg.to_rgb32f().into_raw()
    };
    Ok(Image::from_rgb(w, h, data))
}

/// Reads one named channel (`depth`, `normal.x`, ...) of an EXR file, such as the AOV file
/// `render --aov` writes, as a grey image (the value in all three components).
pub fn read_exr_channel(path: &Path, channel: &str) -> Result<Image> {
    use exr::prelude::read_all_flat_layers_from_file;
    if Format::from_path(path)? != Format::Exr {
        return Err(Error::Usage(format!(
            "{}: --channel reads EXR files only",
            path.display()
        )));
    }
    let bad = |message: String| Error::Image {
        path: path.to_path_buf(),
        message,
    };
    let img = read_all_flat_layers_from_file(path).map_err(|e| bad(e.to_string()))?;
    let mut names = Vec::new();
    for layer in &img.layer_data {
        for ch in &layer.channel_data.list {
            let name = ch.name.to_string();
            if name == channel {
                let (w, h) = (layer.size.width() as u32, layer.size.height() as u32);
                let data = ch
                    .sample_data
                    .values_as_f32()
                    .flat_map(|v| [v, v, v])
                    .collect();
                return Ok(Image::from_rgb(w, h, data));
            }
            names.push(name);
        }
    }
    Err(bad(format!(
        "no channel `{channel}` (it has {})",
        if names.is_empty() {
            "none".to_owned()
        } else {
            names.join(", ")
        }
    )))
}

/// Writes named float channels (all the same size) as a multi-channel OpenEXR file.
/// The `image` crate only writes RGB(A), so AOVs go through the `exr` crate it depends on.
pub fn write_exr_channels(
    path: &Path,
    width: u32,
    height: u32,
    channels: &[(&str, &[f32])],
) -> Result<()> {
    use exr::prelude::*;
    let n = (width * height) as usize;
    for (name, c) in channels {
        if c.len() != n {
            return Err(crate::Error::Internal(format!(
                "AOV channel {name} has {} values, want {n}",
                c.len()
            )));
        }
    }
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = channels
        .iter()
        .map(|(name, c)| AnyChannel::new(*name, FlatSamples::F32(c.to_vec())))
        .collect();
    let layer = Layer::new(
        (width as usize, height as usize),
        LayerAttributes::named("aov"),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    let image = exr::image::Image::from_layer(layer);
    write_atomic(path, |tmp| {
        image.write().to_file(tmp).map_err(|e| crate::Error::Image {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb8_thresholds_reproduce_the_host_rounding_for_every_f32() {
        use rayon::prelude::*;
        let t = srgb8_thresholds();
        let by_count = |v: f32| t.iter().filter(|&&x| x <= v).count() as u8;
        // Every f32 in [0, 1] (1,065,353,217 values): monotone, and the count agrees.
        let one = 1f32.to_bits();
        let bad: usize = (0..=one >> 16)
            .into_par_iter()
            .map(|block| {
                let first = block << 16;
                (first..=(first | 0xffff).min(one))
                    .filter(|&b| {
                        let v = f32::from_bits(b);
                        let code = srgb8(v);
                        let prev = if b == 0 {
                            0
                        } else {
                            srgb8(f32::from_bits(b - 1))
                        };
                        code < prev
                            || t.partition_point(|&x| x <= v) as u8 != code
                            || srgb8_fast(v) != code
                    })
                    .count()
            })
            .sum();
        assert_eq!(bad, 0, "f32 values in [0, 1] where the thresholds disagree");
        for v in [-1.0, -0.0, f32::NEG_INFINITY, 1.5, f32::INFINITY, f32::NAN] {
            assert_eq!(by_count(v), srgb8(v), "{v}");
            assert_eq!(srgb8_fast(v), srgb8(v), "{v}");
        }
        for b in [
            1f32.to_bits() + 1,
            0x8000_0001,
            0x7f7f_ffff,
            0xff7f_ffff,
            0x7fc0_0001,
        ] {
            let v = f32::from_bits(b);
            assert_eq!(srgb8_fast(v), srgb8(v), "{v} ({b:#x})");
        }
        assert_eq!((srgb8(t[0]), srgb8(t[254])), (1, 255));
    }

    #[test]
    fn srgb_round_trip() {
        for k in 0..=255u32 {
            let v = k as f32 / 255.0;
            let back = linear_to_srgb(srgb_to_linear(v));
            assert!((back - v).abs() < 1e-5, "{k}");
        }
        assert_eq!(linear_to_srgb(-1.0), 0.0);
        assert_eq!(linear_to_srgb(7.0), 1.0);
    }

    #[test]
    fn png_and_exr_round_trip_and_atomic() {
        let dir = std::env::temp_dir().join(format!("fragtrace-io-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let img = Image::from_rgb(
            3,
            2,
            vec![
                0.0, 0.5, 1.0, 0.25, 2.0, -1.0, 0.1, 0.2, 0.3, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.7,
                0.8, 0.9,
            ],
        );
        let exr = dir.join("a.exr");
        write_image(&exr, &img).unwrap();
        assert_eq!(read_image(&exr).unwrap(), img, "EXR is exact");
        let png = dir.join("a.png");
        write_image(&png, &img).unwrap();
        let back = read_image(&png).unwrap();
        assert_eq!((back.width, back.height), (3, 2));
        assert!((back.pixel(1, 0)[0] - 0.25).abs() < 0.01);
        assert_eq!(back.pixel(1, 0)[1], 1.0, "clamped");
        // No temporary files left behind.
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
        // A failed write keeps the old file.
        assert!(write_image(&dir.join("nope/x.png"), &img).is_err());
        assert!(write_image(&dir.join("x.bmp"), &img).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
