//! Single-image encoders and decoders: PNG, OpenEXR, PFM and JPEG.
//!
//! Conventions (both directions):
//! * PNG and JPEG are 8-bit RGB. Writing clamps each value to [0, 1] and
//!   stores `round(v * 255)`; with [`WriteOptions::srgb`] the sRGB transfer
//!   curve is applied first. Without it the values are stored as they are
//!   ("no curve"), so `k / 255` survives a PNG round trip exactly. Reading
//!   gives `byte / 255` (16-bit PNGs `word / 65535`), never undoing a curve,
//!   and drops any alpha channel.
//! * EXR is 32-bit float RGB, linear, lossless (the values round-trip bit
//!   for bit). Reading takes the channels `R`, `G`, `B` of the first layer
//!   (in a multi-view file these are the default view), or `Y` as grey.
//! * PFM is the Portable Float Map ("PF", little-endian, scale -1.0), rows
//!   stored bottom to top as the format requires; values round-trip bit for
//!   bit. Reading accepts both byte orders and grey ("Pf") maps.

use std::io::Cursor;
use std::path::Path;

use crate::math::Color;
use crate::output::atomic::{stage, Failure, Sink, Staged};
use crate::output::check_image;
use crate::{Error, Image, Result, Rgb8Image};

/// Options for 8-bit outputs (PNG, JPEG, MPO). Float outputs ignore them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WriteOptions {
    /// Apply the sRGB transfer curve before quantising to 8 bits.
    /// Default `false`: values are stored as they are (clamped to [0, 1]).
    pub srgb: bool,
}

/// A single-image file format, chosen by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    Png,
    Exr,
    Pfm,
    Jpeg,
}

impl ImageFormat {
    /// Whether the format holds 8-bit pixels (PNG, JPEG), not floats.
    pub fn is_8_bit(self) -> bool {
        matches!(self, ImageFormat::Png | ImageFormat::Jpeg)
    }

    /// The format for `path`'s extension (case-insensitive): `.png`, `.exr`,
    /// `.pfm`, `.jpg` or `.jpeg`.
    pub fn from_path(path: &Path) -> Result<ImageFormat> {
        let ext = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        match ext.as_str() {
            "png" => Ok(ImageFormat::Png),
            "exr" => Ok(ImageFormat::Exr),
            "pfm" => Ok(ImageFormat::Pfm),
            "jpg" | "jpeg" => Ok(ImageFormat::Jpeg),
            // A video's frames are an animation's: a still cannot be one.
            _ if crate::video::Container::of(path).is_some() => Err(Error::Invalid(format!(
                "{}: a video needs --frames (an animation, e.g. --frames 0..59 --orbit 360); \
                 a still is written as .png, .exr, .pfm or .jpg",
                path.display()
            ))),
            _ => {
                let shown = if ext.is_empty() {
                    "no extension".to_string()
                } else {
                    format!("'.{ext}'")
                };
                Err(Error::Invalid(format!(
                    "{}: unsupported output format {shown} (use .png, .exr, .pfm or .jpg)",
                    path.display()
                )))
            }
        }
    }
}

/// Writes `img` to `path` in the format its extension names, atomically
/// (see [`crate::output`]): on error no file (or the previous one) is left.
pub fn write_image(path: &Path, img: &Image, opts: &WriteOptions) -> Result<()> {
    stage_image(path, img, opts)?.commit()
}

/// Encodes `img` for `path` without touching `path` yet: one file of a set
/// put in place together by [`commit_all`](crate::output::commit_all).
pub fn stage_image(path: &Path, img: &Image, opts: &WriteOptions) -> Result<Staged> {
    let format = ImageFormat::from_path(path)?;
    check_image(img, "image")?;
    match format {
        ImageFormat::Png => stage(path, |w| encode_png(w, img, opts)),
        ImageFormat::Jpeg => stage(path, |w| encode_jpeg(w, img, opts)),
        ImageFormat::Exr => stage(path, |w| encode_exr(w, img)),
        ImageFormat::Pfm => stage(path, |w| encode_pfm(w, img)),
    }
}

/// Reads a PNG, JPEG, EXR or PFM file (format by extension) into linear
/// float RGB as described in the module documentation.
pub fn read_image(path: &Path) -> Result<Image> {
    let format = ImageFormat::from_path(path)?;
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let decoded = match format {
        ImageFormat::Png => decode_8bit(&bytes, ::image::ImageFormat::Png),
        ImageFormat::Jpeg => decode_8bit(&bytes, ::image::ImageFormat::Jpeg),
        ImageFormat::Exr => decode_exr(&bytes),
        ImageFormat::Pfm => decode_pfm(&bytes),
    };
    decoded.map_err(|message| {
        Error::Invalid(format!("{}: cannot read image: {message}", path.display()))
    })
}

// ---------------------------------------------------------------------------
// 8-bit

/// The sRGB transfer curve (IEC 61966-2-1), linear → encoded, on [0, 1].
pub fn srgb_encode(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

fn quantise(v: f32, srgb: bool) -> u8 {
    // NaN becomes 0 (`as` saturates and maps NaN to 0).
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let v = if srgb { srgb_encode(v) } else { v };
    (v * 255.0).round() as u8
}

/// `quantise(v, true)` without a `powf`: the byte is the number of the 255
/// steps' thresholds at or below `v`, found from a table of buckets. The
/// thresholds are `quantise`'s own (found by bisection on the float's bits),
/// so the bytes are the same for every float; the test
/// `the_srgb_table_gives_every_float_the_byte_of_the_curve` checks all
/// floats in [0, 1]. A whole image of `powf` was 3–5 % of a mono render.
struct Srgb8 {
    /// `threshold[k]`: the least `v` in [0, 1] with `quantise(v, true) >= k`
    /// (`threshold[0]` = 0; `threshold[256]` = infinity, above every value).
    threshold: [f32; 257],
    /// The byte of each bucket's lowest value. Buckets are narrow enough
    /// (1/8192, against the curve's steepest step of 1/3294) to hold at most
    /// one threshold, so one comparison finishes the look-up.
    bucket: Vec<u8>,
}

const SRGB8_BUCKETS: usize = 8192;

impl Srgb8 {
    fn get() -> &'static Srgb8 {
        static TABLE: std::sync::OnceLock<Srgb8> = std::sync::OnceLock::new();
        TABLE.get_or_init(Srgb8::new)
    }

    fn new() -> Srgb8 {
        let mut threshold = [f32::INFINITY; 257];
        threshold[0] = 0.0;
        for (k, t) in threshold.iter_mut().enumerate().take(256).skip(1) {
            // Non-negative floats order as their bits do.
            let (mut lo, mut hi) = (0u32, 1.0f32.to_bits());
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if usize::from(quantise(f32::from_bits(mid), true)) >= k {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            *t = f32::from_bits(lo);
        }
        let bucket = (0..SRGB8_BUCKETS)
            .map(|b| Srgb8::count_below(&threshold, b as f32 / SRGB8_BUCKETS as f32, 0))
            .collect();
        Srgb8 { threshold, bucket }
    }

    /// The number of thresholds 1..=255 at or below `v`, counting up from `k`.
    fn count_below(threshold: &[f32; 257], v: f32, mut k: u8) -> u8 {
        while k < 255 && v >= threshold[usize::from(k) + 1] {
            k += 1;
        }
        k
    }

    /// Without a branch: a view's pixels are quantised as its rows are
    /// traced (`ViewStorage::Rgb8`), 11 M of them for a 48-view quilt.
    #[inline]
    fn byte(&self, v: f32) -> u8 {
        // `max` and `min` take the number where one side is NaN: NaN gives 0
        // (`clamp` would keep the NaN).
        #[allow(clippy::manual_clamp)]
        let v = v.max(0.0).min(1.0);
        // `v * 8192` is exact (a power of two), so the bucket's lowest
        // value is at or below `v`, and the bucket holds at most one
        // threshold above it.
        let b = ((v * SRGB8_BUCKETS as f32) as usize).min(SRGB8_BUCKETS - 1);
        let k = self.bucket[b];
        k + u8::from(v >= self.threshold[usize::from(k) + 1])
    }
}

/// The image as interleaved 8-bit RGB, top row first. Runs of pixels go to
/// the current thread pool: a 48-view quilt has 11 M pixels.
pub(crate) fn to_rgb8(img: &Image, opts: &WriteOptions) -> Vec<u8> {
    use rayon::prelude::*;
    const RUN: usize = 1 << 14;
    let mut bytes = vec![0u8; img.pixels.len() * 3];
    bytes
        .par_chunks_mut(3 * RUN)
        .zip(img.pixels.par_chunks(RUN))
        .for_each(|(bytes, pixels)| rgb8_into(pixels, bytes, opts));
    bytes
}

/// `pixels` as interleaved 8-bit RGB into `bytes` (three per pixel), as an
/// 8-bit file holds them.
pub(crate) fn rgb8_into(pixels: &[Color], bytes: &mut [u8], opts: &WriteOptions) {
    if opts.srgb {
        let table = Srgb8::get();
        // A pixel of the colour before it (a background: 86 % of 48 views of
        // SPD tetra) takes its bytes without the three look-ups.
        let bits = |c: &Color| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits()];
        let mut last: Option<([u32; 3], [u8; 3])> = None;
        for (b, c) in bytes.chunks_exact_mut(3).zip(pixels) {
            let key = bits(c);
            let rgb = match last {
                Some((k, rgb)) if k == key => rgb,
                _ => {
                    let rgb = [table.byte(c.x), table.byte(c.y), table.byte(c.z)];
                    last = Some((key, rgb));
                    rgb
                }
            };
            b.copy_from_slice(&rgb);
        }
    } else {
        for (b, c) in bytes.chunks_exact_mut(3).zip(pixels) {
            b.copy_from_slice(&[
                quantise(c.x, false),
                quantise(c.y, false),
                quantise(c.z, false),
            ]);
        }
    }
}

/// 8-bit RGB pixels, `width` x `height`, top row first: what a PNG or a
/// JPEG holds.
pub(crate) struct Rgb8<'a> {
    pub bytes: &'a [u8],
    pub width: u32,
    pub height: u32,
}

/// Encodes a view kept as 8-bit pixels
/// ([`ViewStorage::Rgb8`](crate::render::ViewStorage::Rgb8)) for `path`, a
/// PNG or JPEG, without touching `path` yet.
pub fn stage_rgb8_image(path: &Path, img: &Rgb8Image) -> Result<Staged> {
    check_rgb8(img, "image")?;
    let rgb = Rgb8 {
        bytes: &img.bytes,
        width: img.width,
        height: img.height,
    };
    stage_rgb8(path, &rgb)
}

/// `img` is well-formed: non-empty, three bytes a pixel.
pub(crate) fn check_rgb8(img: &Rgb8Image, what: &str) -> Result<()> {
    let expected = (img.width as usize)
        .checked_mul(img.height as usize)
        .and_then(|n| n.checked_mul(3));
    if img.width == 0 || img.height == 0 || expected != Some(img.bytes.len()) {
        return Err(Error::Invalid(format!(
            "{what} is malformed: {}x{} with {} bytes of 8-bit RGB",
            img.width,
            img.height,
            img.bytes.len()
        )));
    }
    Ok(())
}

/// Encodes 8-bit pixels for `path` (PNG or JPEG; float formats are refused)
/// without touching `path` yet.
pub(crate) fn stage_rgb8(path: &Path, rgb: &Rgb8) -> Result<Staged> {
    match ImageFormat::from_path(path)? {
        ImageFormat::Png => stage(path, |w| png_from_rgb8(w, rgb)),
        ImageFormat::Jpeg => stage(path, |w| {
            w.write_all(&jpeg_from_rgb8(rgb)?)?;
            Ok(())
        }),
        ImageFormat::Exr | ImageFormat::Pfm => Err(Error::Invalid(format!(
            "{}: an 8-bit picture goes to a PNG or JPEG file",
            path.display()
        ))),
    }
}

fn encode_png(
    w: &mut dyn Sink,
    img: &Image,
    opts: &WriteOptions,
) -> std::result::Result<(), Failure> {
    let bytes = to_rgb8(img, opts);
    png_from_rgb8(
        w,
        &Rgb8 {
            bytes: &bytes,
            width: img.width,
            height: img.height,
        },
    )
}

fn png_from_rgb8(w: &mut dyn Sink, rgb: &Rgb8) -> std::result::Result<(), Failure> {
    use ::image::ImageEncoder;
    ::image::codecs::png::PngEncoder::new(&mut *w)
        .write_image(
            rgb.bytes,
            rgb.width,
            rgb.height,
            ::image::ExtendedColorType::Rgb8,
        )
        .map_err(image_failure)
}

/// Encodes `img` as an 8-bit PNG in memory with the fastest compression:
/// for frames sent as they are rendered (a preview), where encoding time
/// matters more than size. Lossless, unlike JPEG, whose chroma subsampling
/// would blur an anaglyph's colour fringes, which carry the depth.
pub fn png_bytes(img: &Image, opts: &WriteOptions) -> Result<Vec<u8>> {
    use ::image::codecs::png::{CompressionType, FilterType, PngEncoder};
    use ::image::ImageEncoder;
    check_image(img, "image")?;
    let rgb = to_rgb8(img, opts);
    let mut out = Vec::new();
    PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Adaptive)
        .write_image(
            &rgb,
            img.width,
            img.height,
            ::image::ExtendedColorType::Rgb8,
        )
        .map_err(|e| Error::Invalid(format!("cannot encode a PNG: {e}")))?;
    Ok(out)
}

/// Quality of every JPEG twinray writes (also the eyes of an MPO).
pub const JPEG_QUALITY: u8 = 95;

/// Encodes `img` as a baseline JPEG (quality [`JPEG_QUALITY`]) into memory.
pub(crate) fn jpeg_bytes(
    img: &Image,
    opts: &WriteOptions,
) -> std::result::Result<Vec<u8>, Failure> {
    let bytes = to_rgb8(img, opts);
    jpeg_from_rgb8(&Rgb8 {
        bytes: &bytes,
        width: img.width,
        height: img.height,
    })
}

fn jpeg_from_rgb8(rgb: &Rgb8) -> std::result::Result<Vec<u8>, Failure> {
    let mut out = Vec::new();
    ::image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, JPEG_QUALITY)
        .encode(
            rgb.bytes,
            rgb.width,
            rgb.height,
            ::image::ExtendedColorType::Rgb8,
        )
        .map_err(image_failure)?;
    Ok(out)
}

fn encode_jpeg(
    w: &mut dyn Sink,
    img: &Image,
    opts: &WriteOptions,
) -> std::result::Result<(), Failure> {
    let bytes = jpeg_bytes(img, opts)?;
    w.write_all(&bytes)?;
    Ok(())
}

fn image_failure(e: ::image::ImageError) -> Failure {
    match e {
        ::image::ImageError::IoError(e) => Failure::Io(e),
        other => Failure::encode(other),
    }
}

fn decode_8bit(bytes: &[u8], format: ::image::ImageFormat) -> std::result::Result<Image, String> {
    let decoded =
        ::image::load_from_memory_with_format(bytes, format).map_err(|e| e.to_string())?;
    let (width, height) = (decoded.width(), decoded.height());
    let pixels: Vec<Color> =
        match decoded.color().bytes_per_pixel() / decoded.color().channel_count() {
            1 => decoded
                .to_rgb8()
                .pixels()
                .map(|p| Color::new(p[0] as f32, p[1] as f32, p[2] as f32) / 255.0)
                .collect(),
            _ => decoded
                .to_rgb16()
                .pixels()
                .map(|p| Color::new(p[0] as f32, p[1] as f32, p[2] as f32) / 65535.0)
                .collect(),
        };
    Ok(Image {
        width,
        height,
        pixels,
    })
}

// ---------------------------------------------------------------------------
// OpenEXR

fn encode_exr(w: &mut dyn Sink, img: &Image) -> std::result::Result<(), Failure> {
    use exr::prelude::{Encoding, SpecificChannels, Vec2, WritableImage};
    let width = img.width as usize;
    let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
        let c = img.pixels[pos.y() * width + pos.x()];
        (c.x, c.y, c.z)
    });
    let mut image = exr::prelude::Image::from_channels((width, img.height as usize), channels);
    image.layer_data.encoding = Encoding::FAST_LOSSLESS;
    image.write().to_buffered(w).map_err(exr_failure)
}

pub(crate) fn exr_failure(e: exr::error::Error) -> Failure {
    match e {
        exr::error::Error::Io(e) => Failure::Io(e),
        other => Failure::encode(other),
    }
}

fn decode_exr(bytes: &[u8]) -> std::result::Result<Image, String> {
    use exr::prelude::traits::*;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| e.to_string())?;
    let layer = &image.layer_data;
    let (width, height) = (layer.size.x(), layer.size.y());
    let channel = |name: &str| -> Option<Vec<f32>> {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.eq(name))
            .map(|c| c.sample_data.values_as_f32().collect())
    };
    let (r, g, b) = match (channel("R"), channel("G"), channel("B"), channel("Y")) {
        (Some(r), Some(g), Some(b), _) => (r, g, b),
        (_, _, _, Some(y)) => (y.clone(), y.clone(), y),
        _ => return Err("no R, G, B (or Y) channels in the first layer".to_string()),
    };
    let pixels = r
        .iter()
        .zip(&g)
        .zip(&b)
        .map(|((&r, &g), &b)| Color::new(r, g, b))
        .collect::<Vec<_>>();
    let (w32, h32) = (
        u32::try_from(width).map_err(|e| e.to_string())?,
        u32::try_from(height).map_err(|e| e.to_string())?,
    );
    if pixels.len() != width * height {
        return Err("channel sizes do not match the layer size".to_string());
    }
    Ok(Image {
        width: w32,
        height: h32,
        pixels,
    })
}

// ---------------------------------------------------------------------------
// PFM

fn encode_pfm(w: &mut dyn Sink, img: &Image) -> std::result::Result<(), Failure> {
    // Negative scale = little-endian samples.
    write!(w, "PF\n{} {}\n-1.0\n", img.width, img.height)?;
    let width = img.width as usize;
    // The format stores the bottom row first.
    for row in img.pixels.chunks_exact(width).rev() {
        let mut buf = Vec::with_capacity(width * 12);
        for c in row {
            for v in [c.x, c.y, c.z] {
                buf.extend_from_slice(&v.to_le_bytes());
            }
        }
        w.write_all(&buf)?;
    }
    Ok(())
}

fn decode_pfm(bytes: &[u8]) -> std::result::Result<Image, String> {
    // Header: three whitespace-separated tokens then exactly one whitespace
    // byte, then the samples.
    let mut pos = 0;
    let mut tokens = Vec::new();
    for _ in 0..4 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos || pos - start > 32 {
            return Err("truncated or malformed PFM header".to_string());
        }
        tokens.push(String::from_utf8_lossy(&bytes[start..pos]).into_owned());
    }
    pos += 1; // the single whitespace byte after the scale
    let channels = match tokens[0].as_str() {
        "PF" => 3,
        "Pf" => 1,
        other => return Err(format!("not a PFM file (magic '{other}')")),
    };
    let parse_dim = |s: &str| -> std::result::Result<u32, String> {
        s.parse::<u32>()
            .ok()
            .filter(|&v| v > 0)
            .ok_or_else(|| format!("bad PFM dimension '{s}'"))
    };
    let width = parse_dim(&tokens[1])?;
    let height = parse_dim(&tokens[2])?;
    let scale: f32 = tokens[3]
        .parse()
        .map_err(|_| format!("bad PFM scale '{}'", tokens[3]))?;
    if scale == 0.0 || !scale.is_finite() {
        return Err(format!("bad PFM scale '{}'", tokens[3]));
    }
    let little_endian = scale < 0.0;
    let data = bytes.get(pos..).unwrap_or(&[]);
    let needed = (width as u128) * (height as u128) * channels as u128 * 4;
    if (data.len() as u128) < needed {
        return Err(format!(
            "PFM data truncated: {} bytes for {width}x{height}, need {needed}",
            data.len()
        ));
    }
    let sample = |i: usize| {
        let b = [
            data[4 * i],
            data[4 * i + 1],
            data[4 * i + 2],
            data[4 * i + 3],
        ];
        if little_endian {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        }
    };
    let (w, h) = (width as usize, height as usize);
    let mut pixels = vec![Color::ZERO; w * h];
    for file_row in 0..h {
        let y = h - 1 - file_row; // bottom row first in the file
        for x in 0..w {
            let i = (file_row * w + x) * channels;
            pixels[y * w + x] = if channels == 3 {
                Color::new(sample(i), sample(i + 1), sample(i + 2))
            } else {
                Color::splat(sample(i))
            };
        }
    }
    Ok(Image {
        width,
        height,
        pixels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient(width: u32, height: u32) -> Image {
        let mut img = Image::new(width, height);
        for y in 0..height {
            for x in 0..width {
                let i = (y * width + x) as f32;
                img.set(
                    x,
                    y,
                    Color::new(i * 0.37 - 1.5, 1.0 / (i + 3.0), i * 1e-3 + 1e6),
                );
            }
        }
        img
    }

    #[test]
    fn format_from_extension() {
        assert_eq!(
            ImageFormat::from_path(Path::new("a.png")).unwrap(),
            ImageFormat::Png
        );
        assert_eq!(
            ImageFormat::from_path(Path::new("a.PNG")).unwrap(),
            ImageFormat::Png
        );
        assert_eq!(
            ImageFormat::from_path(Path::new("d/a.exr")).unwrap(),
            ImageFormat::Exr
        );
        assert_eq!(
            ImageFormat::from_path(Path::new("a.pfm")).unwrap(),
            ImageFormat::Pfm
        );
        assert_eq!(
            ImageFormat::from_path(Path::new("a.jpg")).unwrap(),
            ImageFormat::Jpeg
        );
        assert_eq!(
            ImageFormat::from_path(Path::new("a.jpeg")).unwrap(),
            ImageFormat::Jpeg
        );
        let err = ImageFormat::from_path(Path::new("a.xyz")).unwrap_err();
        assert!(matches!(err, Error::Invalid(_)));
        let msg = err.to_string();
        assert!(
            msg.contains("unsupported output format '.xyz' (use .png, .exr, .pfm or .jpg)"),
            "{msg}"
        );
        assert!(ImageFormat::from_path(Path::new("noext")).is_err());
    }

    #[test]
    fn png_round_trip_is_exact_for_k_over_255() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("k.png");
        let mut img = Image::new(16, 16);
        for k in 0..256u32 {
            let v = k as f32 / 255.0;
            img.set(
                k % 16,
                k / 16,
                Color::new(v, (255 - k) as f32 / 255.0, (k % 7) as f32 / 255.0),
            );
        }
        write_image(&path, &img, &WriteOptions::default()).unwrap();
        let back = read_image(&path).unwrap();
        assert_eq!(back, img);
    }

    #[test]
    fn png_clamps_and_rounds() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.png");
        let mut img = Image::new(2, 1);
        img.set(0, 0, Color::new(-3.0, 7.0, f32::NAN));
        img.set(1, 0, Color::new(0.5, 0.2, 1.0));
        write_image(&path, &img, &WriteOptions::default()).unwrap();
        let back = read_image(&path).unwrap();
        assert_eq!(back.get(0, 0), Color::new(0.0, 1.0, 0.0));
        // 0.5 * 255 = 127.5 rounds to 128; 0.2 * 255 = 51.
        assert_eq!(back.get(1, 0), Color::new(128.0 / 255.0, 51.0 / 255.0, 1.0));
    }

    #[test]
    fn the_srgb_table_gives_every_float_the_byte_of_the_curve() {
        use rayon::prelude::*;
        let table = Srgb8::get();
        // Every float in [0, 1], in chunks on the thread pool (about 1e9).
        let last = 1.0f32.to_bits();
        let wrong = (0..=last / (1 << 20))
            .into_par_iter()
            .map(|chunk| {
                let start = chunk << 20;
                let end = (start + (1 << 20)).min(last + 1);
                (start..end)
                    .filter(|&bits| {
                        let v = f32::from_bits(bits);
                        table.byte(v) != quantise(v, true)
                    })
                    .count()
            })
            .sum::<usize>();
        assert_eq!(wrong, 0, "floats whose table byte is not the curve's");
        for v in [f32::NAN, -1.0, -0.0, 2.0, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(table.byte(v), quantise(v, true), "{v}");
        }
    }

    #[test]
    fn every_pixel_gets_the_bytes_of_the_curve_after_runs_of_one_colour() {
        // Runs of one colour (whose bytes are reused), changes in one
        // channel only, NaN and the two zeros.
        let c = Color::new;
        let pixels = [
            c(0.5, 0.25, 0.0),
            c(0.5, 0.25, 0.0),
            c(0.5, 0.25, 0.001),
            c(0.5, 0.25, 0.001),
            c(f32::NAN, 0.25, 0.001),
            c(f32::NAN, 0.25, 0.001),
            c(-0.0, 2.0, 0.001),
            c(0.0, 2.0, 0.001),
            c(0.5, 0.25, 0.0),
            c(0.9, 0.25, 0.0),
        ];
        for srgb in [true, false] {
            let mut bytes = vec![0u8; 3 * pixels.len()];
            rgb8_into(&pixels, &mut bytes, &WriteOptions { srgb });
            let expected: Vec<u8> = pixels
                .iter()
                .flat_map(|p| [p.x, p.y, p.z].map(|v| quantise(v, srgb)))
                .collect();
            assert_eq!(bytes, expected, "srgb {srgb}");
        }
    }

    #[test]
    fn png_srgb_curve_maps_half_to_188() {
        assert_eq!(quantise(0.5, true), 188);
        assert_eq!(quantise(0.5, false), 128);
        assert_eq!(quantise(0.0, true), 0);
        assert_eq!(quantise(1.0, true), 255);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.png");
        let img = Image {
            width: 1,
            height: 1,
            pixels: vec![Color::splat(0.5)],
        };
        write_image(&path, &img, &WriteOptions { srgb: true }).unwrap();
        let decoded = ::image::open(&path).unwrap().to_rgb8();
        assert_eq!(decoded.get_pixel(0, 0).0, [188, 188, 188]);
    }

    #[test]
    fn png_is_8bit_rgb_with_the_right_size() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("size.png");
        write_image(&path, &gradient(5, 3), &WriteOptions::default()).unwrap();
        let decoded = ::image::open(&path).unwrap();
        assert_eq!((decoded.width(), decoded.height()), (5, 3));
        assert_eq!(decoded.color(), ::image::ColorType::Rgb8);
    }

    #[test]
    fn pfm_round_trip_is_bit_exact_and_keeps_orientation() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.pfm");
        let img = gradient(7, 5);
        write_image(&path, &img, &WriteOptions::default()).unwrap();
        let back = read_image(&path).unwrap();
        assert_eq!((back.width, back.height), (7, 5));
        for (a, b) in img.pixels.iter().zip(&back.pixels) {
            assert_eq!(a.x.to_bits(), b.x.to_bits());
            assert_eq!(a.y.to_bits(), b.y.to_bits());
            assert_eq!(a.z.to_bits(), b.z.to_bits());
        }
    }

    #[test]
    fn pfm_layout_on_disk() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("o.pfm");
        let mut img = Image::new(1, 2);
        img.set(0, 0, Color::new(1.0, 2.0, 3.0)); // top
        img.set(0, 1, Color::new(4.0, 5.0, 6.0)); // bottom
        write_image(&path, &img, &WriteOptions::default()).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let header = b"PF\n1 2\n-1.0\n";
        assert_eq!(&bytes[..header.len()], header);
        let data = &bytes[header.len()..];
        assert_eq!(data.len(), 24);
        let first = f32::from_le_bytes([data[0], data[1], data[2], data[3]]);
        assert_eq!(first, 4.0, "the file starts with the bottom row");
        let back = read_image(&path).unwrap();
        assert_eq!(
            back.get(0, 0),
            Color::new(1.0, 2.0, 3.0),
            "top row stays on top"
        );
    }

    #[test]
    fn pfm_reads_big_endian_and_grey() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("be.pfm");
        let mut bytes = b"Pf\n2 1\n1.0\n".to_vec();
        bytes.extend_from_slice(&0.25f32.to_be_bytes());
        bytes.extend_from_slice(&(-2.0f32).to_be_bytes());
        std::fs::write(&path, bytes).unwrap();
        let back = read_image(&path).unwrap();
        assert_eq!(back.pixels, vec![Color::splat(0.25), Color::splat(-2.0)]);
    }

    #[test]
    fn pfm_rejects_truncated_and_malformed_files() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.pfm");
        for bytes in [
            b"PF\n2 2\n-1.0\n\0\0\0\0".to_vec(),
            b"PF\n".to_vec(),
            b"P6\n1 1\n255\n\0\0\0".to_vec(),
            b"PF\n0 1\n-1.0\n".to_vec(),
            b"PF\n4000000000 4000000000\n-1.0\n".to_vec(),
            b"PF\n1 1\nnan\n\0\0\0\0\0\0\0\0\0\0\0\0".to_vec(),
        ] {
            std::fs::write(&path, &bytes).unwrap();
            let err = read_image(&path).unwrap_err();
            assert!(matches!(err, Error::Invalid(_)), "{err:?}");
        }
    }

    #[test]
    fn exr_round_trip_is_bit_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.exr");
        let img = gradient(9, 4);
        write_image(&path, &img, &WriteOptions::default()).unwrap();
        let back = read_image(&path).unwrap();
        assert_eq!((back.width, back.height), (9, 4));
        for (a, b) in img.pixels.iter().zip(&back.pixels) {
            assert_eq!(
                a.to_array().map(f32::to_bits),
                b.to_array().map(f32::to_bits)
            );
        }
    }

    #[test]
    fn jpeg_writes_a_decodable_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.jpg");
        let mut img = Image::new(8, 8);
        img.pixels.fill(Color::new(0.2, 0.6, 0.8));
        write_image(&path, &img, &WriteOptions::default()).unwrap();
        let back = read_image(&path).unwrap();
        assert_eq!((back.width, back.height), (8, 8));
        for p in &back.pixels {
            assert!(
                (*p - Color::new(0.2, 0.6, 0.8)).abs().max_element() < 0.02,
                "{p}"
            );
        }
    }

    #[test]
    fn write_errors() {
        let dir = tempfile::tempdir().unwrap();
        // Unknown format: nothing written.
        let path = dir.path().join("a.tiff");
        assert!(matches!(
            write_image(&path, &gradient(2, 2), &WriteOptions::default()),
            Err(Error::Invalid(_))
        ));
        // Inconsistent or empty image.
        let bad = Image {
            width: 3,
            height: 3,
            pixels: vec![Color::ZERO; 4],
        };
        let path = dir.path().join("a.png");
        assert!(matches!(
            write_image(&path, &bad, &WriteOptions::default()),
            Err(Error::Invalid(_))
        ));
        assert!(matches!(
            write_image(&path, &Image::new(0, 5), &WriteOptions::default()),
            Err(Error::Invalid(_))
        ));
        // Missing directory: an error naming the path, nothing created.
        let path = dir.path().join("missing").join("a.exr");
        let err = write_image(&path, &gradient(2, 2), &WriteOptions::default()).unwrap_err();
        assert!(
            err.to_string().contains("missing/a.exr: no directory"),
            "{err}"
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn jpeg_encoder_failure_leaves_no_file() {
        // JPEG cannot hold more than 65535 columns: the encoder refuses,
        // and the atomic writer removes its temporary file.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("wide.jpg");
        let img = Image::new(70_000, 1);
        let err = write_image(&path, &img, &WriteOptions::default()).unwrap_err();
        assert!(matches!(err, Error::Encode { .. }), "{err:?}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn read_errors() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("missing.png");
        assert!(matches!(read_image(&missing), Err(Error::Io { .. })));
        let garbage = dir.path().join("garbage.exr");
        std::fs::write(&garbage, b"not an exr").unwrap();
        assert!(matches!(read_image(&garbage), Err(Error::Invalid(_))));
        let garbage = dir.path().join("garbage.png");
        std::fs::write(&garbage, b"not a png").unwrap();
        assert!(matches!(read_image(&garbage), Err(Error::Invalid(_))));
    }
}
