//! Image textures: decoded once to linear RGB, sampled bilinearly with the
//! wrap modes of OBJ and glTF.
//!
//! Base-colour images are sRGB-encoded (glTF says so; OBJ files from every
//! modeller are too), so their texels are decoded to linear light when loaded:
//! the tracer multiplies and adds linear values only.

use crate::math::Color;

/// What happens to texture coordinates outside [0, 1].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Wrap {
    #[default]
    Repeat,
    MirroredRepeat,
    ClampToEdge,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    /// Linear RGB, row 0 at the top of the image (v = 0 in glTF, v = 1 in OBJ:
    /// loaders flip OBJ's v).
    pub texels: Vec<Color>,
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
}

/// Largest texture accepted, in texels (an 8k × 8k image, 768 MiB as linear
/// floats); larger ones are refused before decoding.
pub const MAX_TEXELS: u64 = 8192 * 8192;

impl Texture {
    /// A texture from 8-bit sRGB-encoded RGB(A) pixels (alpha ignored).
    pub fn from_srgb8(width: u32, height: u32, rgb: &[[u8; 3]]) -> Texture {
        let lut: Vec<f32> = (0..256).map(|i| srgb_to_linear(i as f32 / 255.0)).collect();
        Texture {
            width,
            height,
            texels: rgb
                .iter()
                .map(|p| Color::new(lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize]))
                .collect(),
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
        }
    }

    /// Decodes a PNG or JPEG colour image held in memory (sRGB-encoded).
    /// `what` names it in errors.
    pub fn decode(bytes: &[u8], what: &str) -> Result<Texture, String> {
        Texture::decode_as(bytes, what, Texels::Colour)
    }

    /// The width and height a PNG or JPEG image says it has, read from its
    /// header (nothing decoded); refused when larger than [`MAX_TEXELS`].
    pub fn dimensions(bytes: &[u8], what: &str) -> Result<(u32, u32), String> {
        let reader = image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| format!("{what}: {e}"))?;
        let (w, h) = reader
            .into_dimensions()
            .map_err(|e| format!("{what}: not a PNG or JPEG image ({e})"))?;
        if w == 0 || h == 0 || u64::from(w) * u64::from(h) > MAX_TEXELS {
            return Err(format!(
                "{what}: image of {w}x{h} pixels refused (at most {MAX_TEXELS} pixels)"
            ));
        }
        Ok((w, h))
    }

    /// Bytes a decoded texture of `width` x `height` keeps.
    pub fn kept_bytes(width: u32, height: u32) -> u64 {
        u64::from(width) * u64::from(height) * std::mem::size_of::<Color>() as u64
    }

    /// Bytes its decoding holds beside the texture for a moment: the image
    /// as its file stores it (at most four 16-bit channels), and as 8-bit
    /// RGB(A).
    pub fn decoding_bytes(width: u32, height: u32) -> u64 {
        u64::from(width) * u64::from(height) * (8 + 4)
    }

    /// Decodes a PNG or JPEG image held in memory into texels of `kind`;
    /// one larger than [`MAX_TEXELS`] is refused before it is decoded.
    pub fn decode_as(bytes: &[u8], what: &str, kind: Texels) -> Result<Texture, String> {
        let (width, height) = Texture::dimensions(bytes, what)?;
        let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| format!("{what}: {e}"))?;
        // The decoder's own allocations bounded too (it would abort on a
        // failed one): the image at its widest, 16-bit RGBA.
        let mut limits = image::Limits::default();
        limits.max_alloc = Some(u64::from(width) * u64::from(height) * 8 + (1 << 20));
        reader.limits(limits);
        let img = reader
            .decode()
            .map_err(|e| format!("{what}: not a PNG or JPEG image ({e})"))?;
        let texels = |n: usize| -> Result<Vec<Color>, String> {
            let mut v = Vec::new();
            v.try_reserve_exact(n)
                .map_err(|_| format!("{what}: no memory for {width}x{height} texels"))?;
            Ok(v)
        };
        let n = width as usize * height as usize;
        let mut out = texels(n)?;
        match kind {
            Texels::Colour | Texels::Data => {
                let rgb = img.into_rgb8();
                if kind == Texels::Colour {
                    let lut: Vec<f32> =
                        (0..256).map(|i| srgb_to_linear(i as f32 / 255.0)).collect();
                    out.extend(rgb.pixels().map(|p| {
                        Color::new(lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize])
                    }));
                } else {
                    let v = |b: u8| f32::from(b) / 255.0;
                    out.extend(rgb.pixels().map(|p| Color::new(v(p[0]), v(p[1]), v(p[2]))));
                }
            }
            Texels::Alpha | Texels::Coverage => {
                let has_alpha = img.color().has_alpha();
                let rgba = img.into_rgba8();
                let value = |p: &image::Rgba<u8>| {
                    let byte = match (has_alpha, kind) {
                        (true, _) => p.0[3],
                        (false, Texels::Coverage) => p.0[0],
                        (false, _) => 255,
                    };
                    f32::from(byte) / 255.0
                };
                out.extend(rgba.pixels().map(|p| Color::splat(value(p))));
            }
        }
        Ok(Texture {
            width,
            height,
            texels: out,
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
        })
    }

    /// Bilinear sample at (`u`, `v`), `v` = 0 on the top row; texel centres at
    /// half-integers, as in glTF and OpenGL.
    pub fn sample(&self, u: f32, v: f32) -> Color {
        let x = u * self.width as f32 - 0.5;
        let y = v * self.height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return self.texels[0];
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let xs = [
            wrap(x0, self.width, self.wrap_s),
            wrap(x0 + 1, self.width, self.wrap_s),
        ];
        let ys = [
            wrap(y0, self.height, self.wrap_t),
            wrap(y0 + 1, self.height, self.wrap_t),
        ];
        let at = |x: usize, y: usize| self.texels[y * self.width as usize + x];
        let top = at(xs[0], ys[0]) * (1.0 - fx) + at(xs[1], ys[0]) * fx;
        let bottom = at(xs[0], ys[1]) * (1.0 - fx) + at(xs[1], ys[1]) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    pub fn memory_bytes(&self) -> usize {
        self.texels.len() * std::mem::size_of::<Color>()
    }
}

/// What an image's texels hold once decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Texels {
    /// sRGB-encoded colour, decoded to linear light (base colour, emission).
    Colour,
    /// Non-colour data, `byte / 255` (occlusion, normal maps, heights).
    Data,
    /// The alpha channel (glTF base colour alpha), 1 where the image has none;
    /// in every channel.
    Alpha,
    /// The alpha channel if the image has one, else its red channel (OBJ
    /// `map_d`, a scalar texture often saved as a grey image); in every channel.
    Coverage,
}

/// Texel index of integer coordinate `i` on an axis of `n` texels.
fn wrap(i: i64, n: u32, mode: Wrap) -> usize {
    let n = n as i64;
    let i = match mode {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::ClampToEdge => i.clamp(0, n - 1),
        Wrap::MirroredRepeat => {
            let m = i.rem_euclid(2 * n);
            if m < n {
                m
            } else {
                2 * n - 1 - m
            }
        }
    };
    i as usize
}

/// The sRGB transfer curve inverted: an encoded value in [0, 1] to linear light.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A PNG of one colour.
    pub fn png(width: u32, height: u32, rgb: [u8; 3]) -> Vec<u8> {
        let mut png = Vec::new();
        image::RgbImage::from_pixel(width, height, image::Rgb(rgb))
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        png
    }

    fn checker() -> Texture {
        // 2x2: black, white / white, black.
        Texture::from_srgb8(2, 2, &[[0; 3], [255; 3], [255; 3], [0; 3]])
    }

    #[test]
    fn srgb_is_decoded_to_linear() {
        let t = Texture::from_srgb8(1, 1, &[[188, 0, 255]]);
        assert!((t.texels[0].x - 0.5029).abs() < 1e-3, "{}", t.texels[0]);
        assert_eq!(t.texels[0].y, 0.0);
        assert_eq!(t.texels[0].z, 1.0);
    }

    #[test]
    fn texel_centres_and_bilinear_midpoints() {
        let t = checker();
        assert_eq!(t.sample(0.25, 0.25), Color::ZERO);
        assert_eq!(t.sample(0.75, 0.25), Color::ONE);
        assert_eq!(t.sample(0.25, 0.75), Color::ONE);
        let mid = t.sample(0.5, 0.25);
        assert!((mid.x - 0.5).abs() < 1e-6, "{mid}");
    }

    #[test]
    fn wrap_modes() {
        let mut t = checker();
        // One texel right of the image: repeat comes back to column 0.
        assert_eq!(t.sample(1.25, 0.25), Color::ZERO);
        t.wrap_s = Wrap::ClampToEdge;
        assert_eq!(t.sample(1.25, 0.25), Color::ONE);
        t.wrap_s = Wrap::MirroredRepeat;
        assert_eq!(t.sample(1.25, 0.25), Color::ONE);
        assert_eq!(t.sample(1.75, 0.25), Color::ZERO);
        assert_eq!(t.sample(f32::NAN, 0.0), t.texels[0]);
    }

    #[test]
    fn alpha_and_coverage_texels() {
        let mut rgba = Vec::new();
        image::RgbaImage::from_pixel(2, 1, image::Rgba([50, 0, 0, 100]))
            .write_to(
                &mut std::io::Cursor::new(&mut rgba),
                image::ImageFormat::Png,
            )
            .unwrap();
        let rgb = png(2, 1, [50, 0, 0]);
        let value =
            |bytes: &[u8], kind| Texture::decode_as(bytes, "t.png", kind).unwrap().texels[1];
        // With an alpha channel both read it; without, alpha is 1 and
        // coverage (OBJ map_d) the red channel.
        assert_eq!(value(&rgba, Texels::Alpha), Color::splat(100.0 / 255.0));
        assert_eq!(value(&rgba, Texels::Coverage), Color::splat(100.0 / 255.0));
        assert_eq!(value(&rgb, Texels::Alpha), Color::ONE);
        assert_eq!(value(&rgb, Texels::Coverage), Color::splat(50.0 / 255.0));
        assert!(Texture::decode_as(b"junk", "j.png", Texels::Alpha).is_err());
    }

    #[test]
    fn png_decodes_and_garbage_is_an_error() {
        let png = png(3, 2, [255, 0, 0]);
        let t = Texture::decode(&png, "red.png").unwrap();
        assert_eq!((t.width, t.height), (3, 2));
        assert_eq!(t.texels[5], Color::new(1.0, 0.0, 0.0));
        let e = Texture::decode(b"not an image", "x.png").unwrap_err();
        assert!(e.starts_with("x.png: "), "{e}");
    }
}
