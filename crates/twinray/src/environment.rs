//! An environment image (`--env FILE.hdr|.exr`): light from every direction
//! at infinity, in an equirectangular (latitude–longitude) image.
//!
//! * Rays that leave the scene (eye rays that miss, mirror and refracted
//!   rays) see it, instead of the background colour.
//! * Surfaces take it as ambient light: a diffuse surface receives `Kd` ×
//!   colour × the image's irradiance at its normal over π (nine spherical
//!   harmonics, Ramamoorthi and Hanrahan 2001: exact for a Lambertian
//!   surface to within 3 % on average), and the material's ambient
//!   coefficient takes the image's mean colour instead of white. Neither is
//!   shadowed: it is an ambient term, not a light that casts shadows.
//!
//! Orientation: the image's top row is up (+y, or +z under `--up-axis z`),
//! its centre column is seen looking along −z (y up; +y when z is up: the
//! direction the default camera looks), and longitude grows toward +x, so the
//! panorama is seen unmirrored from inside. Values are linear, as HDR and
//! EXR files store them.

use std::f32::consts::PI;
use std::path::Path;

use crate::error::{Error, Result};
use crate::math::{Color, Vec3};

/// Largest image accepted (a 16k × 8k panorama).
const MAX_TEXELS: u64 = 16_384 * 8_192;

/// Brightest texel kept: above any captured sky (a sun disk is about 1e9
/// times a white surface's radiance at most), far enough below the largest
/// float that the irradiance's sums and a pixel's samples stay finite.
const MAX_TEXEL: f32 = 1e9;

/// An equirectangular image of linear radiance, with what shading needs of
/// it precomputed.
#[derive(Clone, PartialEq)]
pub struct Environment {
    width: u32,
    height: u32,
    /// Row 0 is the top (up).
    texels: Vec<Color>,
    /// Whether the scene's up axis is z (else y).
    z_up: bool,
    /// Mean radiance over the sphere (solid-angle weighted).
    mean: Color,
    /// Radiance projected on the nine real spherical harmonics of bands
    /// 0–2, in the image's own frame (y up).
    sh: [Color; 9],
}

impl std::fmt::Debug for Environment {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Environment")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("z_up", &self.z_up)
            .field("mean", &self.mean)
            .finish_non_exhaustive()
    }
}

impl Environment {
    /// Reads a Radiance HDR (`.hdr`) or OpenEXR (`.exr`) file.
    pub fn load(path: &Path, z_up: bool) -> Result<Environment> {
        let bad = |what: String| Error::Invalid(format!("--env {}: {what}", path.display()));
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        if !matches!(ext.as_deref(), Some("hdr" | "exr")) {
            return Err(bad("an equirectangular .hdr or .exr image is needed".into()));
        }
        // A regular file, read with a bound: `--env /dev/zero` was read
        // until the memory ran out.
        let bytes =
            crate::loaders::files::read_user_file(path, crate::loaders::files::MAX_FILE_BYTES)?;
        let reader = image::ImageReader::new(std::io::Cursor::new(&bytes[..]))
            .with_guessed_format()
            .map_err(|source| Error::Io {
                path: path.to_path_buf(),
                source,
            })?;
        let mut limits = image::Limits::default();
        limits.max_alloc = Some(MAX_TEXELS * 16);
        let mut reader = reader;
        reader.limits(limits);
        let img = reader
            .decode()
            .map_err(|e| bad(format!("not a readable HDR or EXR image ({e})")))?
            .into_rgb32f();
        let (w, h) = img.dimensions();
        if w == 0 || h == 0 || w as u64 * h as u64 > MAX_TEXELS {
            return Err(bad(format!(
                "image of {w}x{h} pixels refused (at most {MAX_TEXELS} pixels)"
            )));
        }
        let texels = img
            .pixels()
            .map(|p| {
                // Negative or non-finite values (a broken file) would give
                // negative or infinite light, and values near the largest
                // float an infinite irradiance (a sum of them).
                Color::from(p.0.map(|c| {
                    if c.is_finite() {
                        c.clamp(0.0, MAX_TEXEL)
                    } else {
                        0.0
                    }
                }))
            })
            .collect();
        Ok(Environment::from_texels(w, h, texels, z_up))
    }

    /// An environment of `width`×`height` linear texels, row 0 at the top.
    pub fn from_texels(width: u32, height: u32, texels: Vec<Color>, z_up: bool) -> Environment {
        assert_eq!(texels.len(), width as usize * height as usize);
        let mut env = Environment {
            width,
            height,
            texels,
            z_up,
            mean: Color::ZERO,
            sh: [Color::ZERO; 9],
        };
        env.project();
        env
    }

    /// The mean colour and the spherical-harmonic coefficients, each texel
    /// weighted by its solid angle.
    fn project(&mut self) {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut sum_weight = 0.0f64;
        let mut mean = [0.0f64; 3];
        let mut sh = [[0.0f64; 3]; 9];
        for y in 0..h {
            let lat = PI * 0.5 - PI * (y as f32 + 0.5) / h as f32;
            let weight = f64::from(lat.cos())
                * (2.0 * std::f64::consts::PI / w as f64)
                * (std::f64::consts::PI / h as f64);
            for x in 0..w {
                let c = self.texels[y * w + x];
                let dir = Self::frame_dir(x as f32 + 0.5, y as f32 + 0.5, w, h);
                let basis = sh_basis(dir);
                for ch in 0..3 {
                    mean[ch] += weight * f64::from(c[ch]);
                    for (k, b) in basis.iter().enumerate() {
                        sh[k][ch] += weight * f64::from(c[ch] * b);
                    }
                }
                sum_weight += weight;
            }
        }
        fn to_color(v: [f64; 3]) -> Color {
            Color::new(v[0] as f32, v[1] as f32, v[2] as f32)
        }
        self.mean = to_color(mean.map(|m| m / sum_weight.max(f64::MIN_POSITIVE)));
        self.sh = sh.map(to_color);
    }

    /// The unit direction, in the image's frame, of image position (x, y)
    /// in texels.
    fn frame_dir(x: f32, y: f32, w: usize, h: usize) -> Vec3 {
        let lon = (x / w as f32 - 0.5) * 2.0 * PI;
        let lat = PI * 0.5 - PI * y / h as f32;
        Vec3::new(lat.cos() * lon.sin(), lat.sin(), -lat.cos() * lon.cos())
    }

    /// A scene direction in the image's frame (y up, −z at the centre).
    #[inline]
    fn to_frame(&self, d: Vec3) -> Vec3 {
        if self.z_up {
            Vec3::new(d.x, d.z, -d.y)
        } else {
            d
        }
    }

    /// The radiance arriving along `-dir` (what a ray going along `dir`
    /// sees), bilinear between texels; `dir` need not be unit.
    pub fn radiance(&self, dir: Vec3) -> Color {
        let d = self.to_frame(dir);
        let lon = d.x.atan2(-d.z);
        let lat = d.y.atan2((d.x * d.x + d.z * d.z).sqrt());
        if !(lon.is_finite() && lat.is_finite()) {
            return Color::ZERO;
        }
        let (w, h) = (self.width as i64, self.height as i64);
        let fx = (0.5 + lon / (2.0 * PI)) * w as f32 - 0.5;
        let fy = (0.5 - lat / PI) * h as f32 - 0.5;
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - x0, fy - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let at = |x: i64, y: i64| {
            let x = x.rem_euclid(w);
            let y = y.clamp(0, h - 1);
            self.texels[(y * w + x) as usize]
        };
        let top = at(x0, y0) * (1.0 - tx) + at(x0 + 1, y0) * tx;
        let bottom = at(x0, y0 + 1) * (1.0 - tx) + at(x0 + 1, y0 + 1) * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// The angle one texel spans (the smaller of its width and height), in
    /// radians: directions closer than this see at most neighbouring texels.
    pub fn texel_angle(&self) -> f32 {
        (2.0 * PI / self.width as f32).min(PI / self.height as f32)
    }

    /// The light a white Lambertian surface of normal `n` (unit) reflects:
    /// irradiance over π.
    pub fn diffuse(&self, n: Vec3) -> Color {
        // Ramamoorthi and Hanrahan's convolution of the radiance with the
        // clamped cosine: A0 = π, A1 = 2π/3, A2 = π/4.
        const A: [f32; 9] = [
            PI,
            2.0 * PI / 3.0,
            2.0 * PI / 3.0,
            2.0 * PI / 3.0,
            PI / 4.0,
            PI / 4.0,
            PI / 4.0,
            PI / 4.0,
            PI / 4.0,
        ];
        let basis = sh_basis(self.to_frame(n));
        let mut e = Color::ZERO;
        for k in 0..9 {
            e += self.sh[k] * (A[k] * basis[k]);
        }
        // Nine harmonics ring below zero behind a bright sun: no negative light.
        (e / PI).max(Color::ZERO)
    }

    /// Mean radiance over the sphere.
    pub fn mean(&self) -> Color {
        self.mean
    }

    pub fn memory_bytes(&self) -> usize {
        self.texels.len() * std::mem::size_of::<Color>()
    }
}

/// The real spherical harmonics of bands 0–2 at unit direction `d`.
fn sh_basis(d: Vec3) -> [f32; 9] {
    let (x, y, z) = (d.x, d.y, d.z);
    [
        0.282_095,
        0.488_603 * y,
        0.488_603 * z,
        0.488_603 * x,
        1.092_548 * x * y,
        1.092_548 * y * z,
        0.315_392 * (3.0 * z * z - 1.0),
        1.092_548 * x * z,
        0.546_274 * (x * x - y * y),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Top half `top`, bottom half `bottom`.
    fn halves(top: Color, bottom: Color, z_up: bool) -> Environment {
        let (w, h) = (64, 32);
        let texels = (0..w * h)
            .map(|i| if i / w < h / 2 { top } else { bottom })
            .collect();
        Environment::from_texels(w, h, texels, z_up)
    }

    #[test]
    fn a_uniform_sky_lights_a_white_surface_with_its_own_radiance() {
        let c = Color::new(0.5, 1.0, 2.0);
        let env = halves(c, c, false);
        for n in [Vec3::X, Vec3::Y, -Vec3::Z, Vec3::new(0.6, -0.8, 0.0)] {
            let d = env.diffuse(n);
            // Within the quadrature's error over 64×32 texels.
            assert!((d - c).abs().max_element() < 2e-3 * 2.0, "{n}: {d}");
            assert!((env.radiance(n) - c).abs().max_element() < 1e-6);
        }
        assert!((env.mean() - c).abs().max_element() < 1e-4);
    }

    #[test]
    fn up_is_the_top_row_and_follows_the_up_axis() {
        let (red, blue) = (Color::X, Color::Z);
        let y_up = halves(red, blue, false);
        assert_eq!(y_up.radiance(Vec3::Y), red);
        assert_eq!(y_up.radiance(-Vec3::Y), blue);
        assert_eq!(y_up.radiance(Vec3::new(1.0, 0.3, -0.5)), red);
        let z_up = halves(red, blue, true);
        assert_eq!(z_up.radiance(Vec3::Z), red);
        assert_eq!(z_up.radiance(Vec3::new(0.3, 1.0, -0.2)), blue);
        // Half the sky red, half blue: a surface facing up gets mostly red,
        // one facing down mostly blue, a wall half of each. The exact values
        // for a clamped cosine over a hemisphere are 0.75/0.25 of a white
        // surface's; nine harmonics come within a few per cent.
        let up = y_up.diffuse(Vec3::Y);
        let down = y_up.diffuse(-Vec3::Y);
        let wall = y_up.diffuse(Vec3::X);
        assert!((up.x - 1.0).abs() < 0.05 && up.z < 0.05, "{up}");
        assert!((down.z - 1.0).abs() < 0.05 && down.x < 0.05, "{down}");
        assert!(
            (wall.x - 0.5).abs() < 0.02 && (wall.z - 0.5).abs() < 0.02,
            "{wall}"
        );
        assert_eq!(z_up.diffuse(Vec3::Z), up);
    }

    #[test]
    fn the_centre_column_is_seen_looking_along_minus_z_and_x_is_to_its_right() {
        // A red column in the middle, a green one at three quarters.
        let (w, h) = (64u32, 16u32);
        let texels = (0..w * h)
            .map(|i| match i % w {
                31 | 32 => Color::X,
                47 | 48 => Color::Y,
                _ => Color::ZERO,
            })
            .collect();
        let env = Environment::from_texels(w, h, texels, false);
        assert_eq!(env.radiance(-Vec3::Z), Color::X);
        assert_eq!(env.radiance(Vec3::X), Color::Y);
        assert_eq!(env.radiance(Vec3::Z), Color::ZERO);
        let z_up = Environment::from_texels(w, h, env.texels.clone(), true);
        assert_eq!(z_up.radiance(Vec3::Y), Color::X);
    }
}
