//! Colour anaglyphs: both eyes in one image, separated by coloured glasses.
//!
//! Every method is a pair of 3×3 matrices: `out = clamp(ML · left + MR · right, 0, 1)`.
//!
//! **Which values.** The matrices are applied to the pixel values as given
//! and the result is clamped to [0, 1]. Dubois derived his matrices for
//! (roughly) display RGB values, and twinray's images are linear; they are
//! *not* converted here, so feed display-referred values if that matters.
//! With the default PNG output (no transfer curve) the values written are the
//! values the matrices produced.
//!
//! **Sources of the matrices.**
//! * [`AnaglyphMethod::Dubois`] (red–cyan), [`AnaglyphMethod::GreenMagenta`]
//!   and [`AnaglyphMethod::YellowBlue`] use Eric Dubois' published
//!   least-squares projection matrices (red–cyan, green–magenta and
//!   amber–blue, the same coefficients as e.g. ffmpeg's `stereo3d` filter's
//!   `arcd`, `agmd` and `aybd` modes). Green–magenta glasses: green filter on
//!   the left eye. Yellow(amber)–blue (ColorCode 3-D): amber on the left.
//! * [`AnaglyphMethod::Color`]: red channel from the left eye, green and blue
//!   from the right.
//! * [`AnaglyphMethod::Gray`]: Rec. 601 luma (0.299, 0.587, 0.114) of the left
//!   eye in red, of the right eye in green and blue.

use crate::math::Color;
use crate::output::check_pair;
use crate::{Image, Result};

/// How [`anaglyph`] mixes the eyes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AnaglyphMethod {
    /// Red–cyan, Dubois least-squares matrices (least ghosting, good colour).
    Dubois,
    /// Red–cyan, red channel of the left eye + green/blue of the right.
    Color,
    /// Red–cyan, grey: luma of the left eye in red, of the right in cyan.
    Gray,
    /// Green–magenta (green on the left eye), Dubois matrices.
    GreenMagenta,
    /// Yellow(amber)–blue (amber on the left eye, ColorCode 3-D), Dubois matrices.
    YellowBlue,
}

type Mat3 = [[f32; 3]; 3];

const LUMA: [f32; 3] = [0.299, 0.587, 0.114];
const ZERO: [f32; 3] = [0.0; 3];

impl AnaglyphMethod {
    /// (left matrix, right matrix), row = output channel R, G, B.
    fn matrices(self) -> (Mat3, Mat3) {
        match self {
            AnaglyphMethod::Dubois => (
                [
                    [0.456, 0.500, 0.176],
                    [-0.040, -0.038, -0.016],
                    [-0.015, -0.021, -0.005],
                ],
                [
                    [-0.043, -0.088, -0.002],
                    [0.378, 0.734, -0.018],
                    [-0.072, -0.113, 1.226],
                ],
            ),
            AnaglyphMethod::Color => (
                [[1.0, 0.0, 0.0], ZERO, ZERO],
                [ZERO, [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            ),
            AnaglyphMethod::Gray => ([LUMA, ZERO, ZERO], [ZERO, LUMA, LUMA]),
            AnaglyphMethod::GreenMagenta => (
                [
                    [-0.062, -0.158, -0.039],
                    [0.284, 0.668, 0.143],
                    [-0.015, -0.027, 0.021],
                ],
                [
                    [0.529, 0.705, 0.024],
                    [-0.016, -0.015, -0.065],
                    [0.009, 0.075, 0.937],
                ],
            ),
            AnaglyphMethod::YellowBlue => (
                [
                    [1.062, -0.205, 0.299],
                    [-0.026, 0.908, 0.068],
                    [-0.038, -0.173, 0.022],
                ],
                [
                    [-0.016, -0.123, -0.017],
                    [0.006, 0.062, -0.017],
                    [0.094, 0.185, 0.911],
                ],
            ),
        }
    }
}

fn apply(m: &Mat3, c: Color) -> Color {
    let row = |r: &[f32; 3]| r[0] * c.x + r[1] * c.y + r[2] * c.z;
    Color::new(row(&m[0]), row(&m[1]), row(&m[2]))
}

/// One eye-sized anaglyph of `left` and `right` (see the module notes).
/// Mismatched eye sizes → `Error::Invalid`.
pub fn anaglyph(left: &Image, right: &Image, method: AnaglyphMethod) -> Result<Image> {
    check_pair(left, right)?;
    let (ml, mr) = method.matrices();
    let pixels = left
        .pixels
        .iter()
        .zip(&right.pixels)
        .map(|(&l, &r)| {
            let c = apply(&ml, l) + apply(&mr, r);
            // `clamp` keeps NaN; make it black instead.
            Color::new(clamp01(c.x), clamp01(c.y), clamp01(c.z))
        })
        .collect();
    Ok(Image {
        width: left.width,
        height: left.height,
        pixels,
    })
}

fn clamp01(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Error;

    const RED: Color = Color::new(1.0, 0.0, 0.0);
    const GREEN: Color = Color::new(0.0, 1.0, 0.0);
    const BLUE: Color = Color::new(0.0, 0.0, 1.0);
    const WHITE: Color = Color::new(1.0, 1.0, 1.0);
    const BLACK: Color = Color::ZERO;

    fn one(c: Color) -> Image {
        Image {
            width: 2,
            height: 1,
            pixels: vec![c; 2],
        }
    }

    fn pixel(l: Color, r: Color, m: AnaglyphMethod) -> Color {
        let out = anaglyph(&one(l), &one(r), m).unwrap();
        assert_eq!((out.width, out.height), (2, 1));
        out.pixels[0]
    }

    fn close(a: Color, b: Color) {
        assert!((a - b).abs().max_element() < 1e-5, "{a} != {b}");
    }

    #[test]
    fn color_takes_red_from_left_and_cyan_from_right() {
        close(
            pixel(RED, BLUE, AnaglyphMethod::Color),
            Color::new(1.0, 0.0, 1.0),
        );
        close(pixel(BLUE, RED, AnaglyphMethod::Color), BLACK);
        close(pixel(WHITE, BLACK, AnaglyphMethod::Color), RED);
        close(
            pixel(BLACK, WHITE, AnaglyphMethod::Color),
            Color::new(0.0, 1.0, 1.0),
        );
        close(pixel(GREEN, GREEN, AnaglyphMethod::Color), GREEN);
    }

    #[test]
    fn gray_uses_luma() {
        close(
            pixel(RED, BLUE, AnaglyphMethod::Gray),
            Color::new(0.299, 0.114, 0.114),
        );
        close(pixel(WHITE, WHITE, AnaglyphMethod::Gray), WHITE);
        close(
            pixel(GREEN, BLACK, AnaglyphMethod::Gray),
            Color::new(0.587, 0.0, 0.0),
        );
    }

    #[test]
    fn dubois_red_cyan() {
        // Left eye sees through red: a red left image shows up in red.
        close(
            pixel(RED, BLACK, AnaglyphMethod::Dubois),
            Color::new(0.456, 0.0, 0.0),
        );
        // Right eye sees through cyan: a blue right image in blue (clamped).
        close(
            pixel(BLACK, BLUE, AnaglyphMethod::Dubois),
            Color::new(0.0, 0.0, 1.0),
        );
        close(
            pixel(BLACK, GREEN, AnaglyphMethod::Dubois),
            Color::new(0.0, 0.734, 0.0),
        );
        close(
            pixel(RED, BLUE, AnaglyphMethod::Dubois),
            Color::new(0.454, 0.0, 1.0),
        );
        // White in both eyes: row sums.
        close(
            pixel(WHITE, WHITE, AnaglyphMethod::Dubois),
            Color::new(0.999, 1.0, 1.0),
        );
    }

    #[test]
    fn green_magenta_puts_left_in_green() {
        close(
            pixel(GREEN, BLACK, AnaglyphMethod::GreenMagenta),
            Color::new(0.0, 0.668, 0.0),
        );
        close(
            pixel(BLACK, RED, AnaglyphMethod::GreenMagenta),
            Color::new(0.529, 0.0, 0.009),
        );
        close(
            pixel(BLACK, BLUE, AnaglyphMethod::GreenMagenta),
            Color::new(0.024, 0.0, 0.937),
        );
        close(
            pixel(RED, BLUE, AnaglyphMethod::GreenMagenta),
            Color::new(0.0, 0.219, 0.922),
        );
    }

    #[test]
    fn yellow_blue_puts_left_in_amber() {
        close(
            pixel(RED, BLACK, AnaglyphMethod::YellowBlue),
            Color::new(1.0, 0.0, 0.0),
        );
        close(
            pixel(GREEN, BLACK, AnaglyphMethod::YellowBlue),
            Color::new(0.0, 0.908, 0.0),
        );
        close(
            pixel(BLACK, BLUE, AnaglyphMethod::YellowBlue),
            Color::new(0.0, 0.0, 0.911),
        );
        close(
            pixel(RED, BLUE, AnaglyphMethod::YellowBlue),
            Color::new(1.0, 0.0, 0.873),
        );
    }

    #[test]
    fn output_is_clamped_and_nan_free() {
        for m in [
            AnaglyphMethod::Dubois,
            AnaglyphMethod::Color,
            AnaglyphMethod::Gray,
            AnaglyphMethod::GreenMagenta,
            AnaglyphMethod::YellowBlue,
        ] {
            let c = pixel(Color::splat(50.0), Color::new(f32::NAN, -4.0, 9.0), m);
            for v in c.to_array() {
                assert!((0.0..=1.0).contains(&v), "{m:?}: {c}");
            }
        }
    }

    #[test]
    fn mismatched_eyes_are_an_error() {
        let a = one(RED);
        let b = Image::new(1, 2);
        assert!(matches!(
            anaglyph(&a, &b, AnaglyphMethod::Dubois),
            Err(Error::Invalid(_))
        ));
    }
}
