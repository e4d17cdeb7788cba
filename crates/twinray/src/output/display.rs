//! The display transform of 8-bit outputs: exposure, then a tone curve,
//! applied to the rendered (scene-linear) views before they are composed
//! and encoded. The encoder then applies the sRGB curve
//! ([`WriteOptions::srgb`](super::WriteOptions)). Float outputs (EXR, PFM)
//! skip all of it: they keep the values as rendered.
//!
//! The curves map scene-linear values to display-linear values in [0, 1]:
//! * `Clamp`: values above 1 clip (the renderer's values as they are; the
//!   default, so that a plain render keeps its numbers).
//! * `Aces`: Narkowicz's fit of the ACES filmic curve (2015), per channel:
//!   a toe and a soft shoulder; 1.0 maps to 0.80, highlights roll off.
//! * `Agx`: Troy Sobotka's AgX as Blender 4 and three.js ship it (the
//!   three.js fit): Rec.2020 working space, inset matrix, log2 encoding
//!   between −12.47 and +4.03 stops around middle grey, a sigmoid
//!   polynomial, outset matrix. Bright saturated colours desaturate toward
//!   white instead of clipping to a hue.

use crate::math::Color;
use crate::Image;

/// A tone curve of 8-bit outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Tonemap {
    #[default]
    Clamp,
    Aces,
    Agx,
}

/// Exposure and tone curve: scene-linear → display-linear in [0, 1].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DisplayTransform {
    /// Stops: values are multiplied by 2^`exposure` before the curve.
    pub exposure: f32,
    pub tonemap: Tonemap,
}

impl DisplayTransform {
    /// Whether the transform leaves every value the encoder's clamp would
    /// give anyway (no exposure, the clamp curve).
    pub fn is_identity(&self) -> bool {
        self.exposure == 0.0 && self.tonemap == Tonemap::Clamp
    }

    /// One pixel.
    pub fn map(&self, c: Color) -> Color {
        let c = c * self.exposure.exp2();
        // NaN and negative values are black before any curve.
        let c = Color::new(
            finite_or_zero(c.x),
            finite_or_zero(c.y),
            finite_or_zero(c.z),
        );
        match self.tonemap {
            Tonemap::Clamp => c.clamp(Color::ZERO, Color::ONE),
            Tonemap::Aces => Color::new(aces(c.x), aces(c.y), aces(c.z)),
            Tonemap::Agx => agx(c),
        }
    }

    /// The image with every pixel mapped.
    pub fn apply(&self, img: &Image) -> Image {
        Image {
            width: img.width,
            height: img.height,
            pixels: img.pixels.iter().map(|&c| self.map(c)).collect(),
        }
    }
}

fn finite_or_zero(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.max(0.0)
    }
}

/// Narkowicz, "ACES Filmic Tone Mapping Curve" (2015).
fn aces(x: f32) -> f32 {
    let (a, b, c, d, e) = (2.51, 0.03, 2.43, 0.59, 0.14);
    ((x * (a * x + b)) / (x * (c * x + d) + e)).clamp(0.0, 1.0)
}

/// A 3×3 matrix given by its columns, as GLSL's `mat3` constructor takes them.
type Columns = [[f32; 3]; 3];

fn mul(m: &Columns, v: Color) -> Color {
    Color::from(m[0]) * v.x + Color::from(m[1]) * v.y + Color::from(m[2]) * v.z
}

const SRGB_TO_REC2020: Columns = [
    [0.6274, 0.0691, 0.0164],
    [0.3293, 0.9195, 0.0880],
    [0.0433, 0.0113, 0.8956],
];
const REC2020_TO_SRGB: Columns = [
    [1.6605, -0.1246, -0.0182],
    [-0.5876, 1.1329, -0.1006],
    [-0.0728, -0.0083, 1.1187],
];
const AGX_INSET: Columns = [
    [0.856_627_15, 0.137_318_97, 0.111_898_21],
    [0.095_121_24, 0.761_242, 0.076_799_42],
    [0.048_251_6, 0.101_439_04, 0.811_302_37],
];
const AGX_OUTSET: Columns = [
    [1.127_100_6, -0.141_329_76, -0.141_329_76],
    [-0.110_606_64, 1.157_823_7, -0.110_606_64],
    [-0.016_493_94, -0.016_493_94, 1.251_936_4],
];
const AGX_MIN_EV: f32 = -12.473_93;
const AGX_MAX_EV: f32 = 4.026_069;

fn agx(c: Color) -> Color {
    let c = mul(&AGX_INSET, mul(&SRGB_TO_REC2020, c));
    let encode =
        |v: f32| ((v.max(1e-10).log2() - AGX_MIN_EV) / (AGX_MAX_EV - AGX_MIN_EV)).clamp(0.0, 1.0);
    let c = Color::new(encode(c.x), encode(c.y), encode(c.z));
    let c = Color::new(agx_contrast(c.x), agx_contrast(c.y), agx_contrast(c.z));
    let c = mul(&AGX_OUTSET, c);
    // The sigmoid's output is display-encoded (gamma 2.2): back to linear.
    let c = Color::new(
        c.x.max(0.0).powf(2.2),
        c.y.max(0.0).powf(2.2),
        c.z.max(0.0).powf(2.2),
    );
    mul(&REC2020_TO_SRGB, c).clamp(Color::ZERO, Color::ONE)
}

/// AgX's default contrast sigmoid, a polynomial fit.
fn agx_contrast(x: f32) -> f32 {
    let x2 = x * x;
    let x4 = x2 * x2;
    15.5 * x4 * x2 - 40.14 * x4 * x + 31.96 * x4 - 6.868 * x2 * x + 0.4298 * x2 + 0.1191 * x
        - 0.00232
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(exposure: f32, tonemap: Tonemap) -> DisplayTransform {
        DisplayTransform { exposure, tonemap }
    }

    #[test]
    fn exposure_is_in_stops() {
        let c = t(1.0, Tonemap::Clamp).map(Color::splat(0.25));
        assert_eq!(c, Color::splat(0.5));
        let c = t(-2.0, Tonemap::Clamp).map(Color::splat(2.0));
        assert_eq!(c, Color::splat(0.5));
    }

    #[test]
    fn clamp_clips_and_drops_nan() {
        let c = t(0.0, Tonemap::Clamp).map(Color::new(2.0, -1.0, f32::NAN));
        assert_eq!(c, Color::new(1.0, 0.0, 0.0));
    }

    #[test]
    fn aces_rolls_off_highlights_and_keeps_order() {
        let curve = t(0.0, Tonemap::Aces);
        assert!((curve.map(Color::ONE).x - 0.8038).abs() < 1e-3);
        assert_eq!(curve.map(Color::ZERO), Color::ZERO);
        let mut last = 0.0;
        for i in 1..100 {
            let v = curve.map(Color::splat(i as f32 * 0.2)).x;
            // Rising until it reaches white (the fit's asymptote is 1.03).
            assert!((v > last || v == 1.0) && v <= 1.0, "{i}: {v}");
            last = v;
        }
        // Far above 1: close to white, not clipped at 1 already at 1.
        assert!(curve.map(Color::splat(20.0)).x > 0.98);
    }

    #[test]
    fn agx_keeps_grey_grey_and_desaturates_bright_colours() {
        let curve = t(0.0, Tonemap::Agx);
        // Middle grey lands mid-screen (three.js: about 0.17–0.20 linear).
        let g = curve.map(Color::splat(0.18));
        assert!((g.x - g.y).abs() < 2e-3 && (g.y - g.z).abs() < 2e-3, "{g}");
        assert!(g.x > 0.1 && g.x < 0.3, "{g}");
        // A very bright pure red goes toward white: green and blue rise.
        let r = curve.map(Color::new(50.0, 0.0, 0.0));
        assert!(r.x > 0.9 && r.y > 0.2 && r.z > 0.2, "{r}");
        // Monotonic on grey.
        let mut last = -1.0;
        for i in 0..60 {
            let v = curve.map(Color::splat(0.01 * 1.2f32.powi(i))).x;
            assert!(v >= last, "{i}: {v}");
            last = v;
        }
    }

    #[test]
    fn identity_is_recognised() {
        assert!(DisplayTransform::default().is_identity());
        assert!(!t(0.5, Tonemap::Clamp).is_identity());
        assert!(!t(0.0, Tonemap::Aces).is_identity());
    }
}
