//! Image comparison, for `twinray compare A B` and for regression tests.

use crate::math::Color;
use crate::output::check_pair;
use crate::{Image, Result};

/// How two images of the same size differ, over all pixels and channels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Difference {
    /// Largest absolute channel difference.
    pub max_abs: f32,
    /// Peak signal-to-noise ratio in dB with peak 1.0 (`10 log10(1 / MSE)`,
    /// MSE over all channels); `f64::INFINITY` when the images are equal.
    /// Can be negative for HDR values differing by more than 1.
    pub psnr_db: f64,
    /// Mean absolute channel difference.
    pub mean_abs: f64,
    /// Number of pixels with at least one channel that differs.
    pub differing_pixels: usize,
}

impl Difference {
    /// True when the images are identical.
    pub fn is_identical(&self) -> bool {
        self.differing_pixels == 0
    }
}

/// Per-channel |a − b|. NaN against NaN counts as equal (0); NaN against a
/// number as infinitely different, so a NaN never hides a difference.
fn channel_diff(a: f32, b: f32) -> f32 {
    match (a.is_nan(), b.is_nan()) {
        (true, true) => 0.0,
        (false, false) if a == b => 0.0, // also ∞ == ∞ (∞ − ∞ would be NaN)
        (false, false) => (a - b).abs(),
        _ => f32::INFINITY,
    }
}

fn pixel_diff(a: Color, b: Color) -> [f32; 3] {
    [
        channel_diff(a.x, b.x),
        channel_diff(a.y, b.y),
        channel_diff(a.z, b.z),
    ]
}

/// Compares two images. Different sizes (or a malformed image) →
/// `Error::Invalid`.
pub fn compare(a: &Image, b: &Image) -> Result<Difference> {
    check_pair(a, b)?;
    let mut max_abs = 0.0f32;
    let mut sum_abs = 0.0f64;
    let mut sum_sq = 0.0f64;
    let mut differing_pixels = 0;
    for (&pa, &pb) in a.pixels.iter().zip(&b.pixels) {
        let d = pixel_diff(pa, pb);
        if d.iter().any(|&v| v != 0.0) {
            differing_pixels += 1;
        }
        for v in d {
            max_abs = max_abs.max(v);
            sum_abs += v as f64;
            sum_sq += (v as f64) * (v as f64);
        }
    }
    let n = (a.pixels.len() * 3) as f64;
    let mse = sum_sq / n;
    let psnr_db = if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (1.0 / mse).log10()
    };
    Ok(Difference {
        max_abs,
        psnr_db,
        mean_abs: sum_abs / n,
        differing_pixels,
    })
}

/// `|a − b| * gain` per channel, for looking at where two images differ.
/// Different sizes → `Error::Invalid`.
pub fn difference_image(a: &Image, b: &Image, gain: f32) -> Result<Image> {
    check_pair(a, b)?;
    let pixels = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(&pa, &pb)| Color::from_array(pixel_diff(pa, pb)) * gain)
        .collect();
    Ok(Image {
        width: a.width,
        height: a.height,
        pixels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Error;

    #[test]
    fn identical_images() {
        let a = Image::filled(4, 2, Color::new(0.1, 0.2, 0.3));
        let d = compare(&a, &a.clone()).unwrap();
        assert_eq!(d.max_abs, 0.0);
        assert_eq!(d.mean_abs, 0.0);
        assert_eq!(d.differing_pixels, 0);
        assert!(d.psnr_db.is_infinite() && d.psnr_db > 0.0);
        assert!(d.is_identical());
    }

    #[test]
    fn one_differing_pixel() {
        let a = Image::filled(4, 2, Color::ZERO);
        let mut b = a.clone();
        b.set(3, 1, Color::new(0.0, 0.5, 0.0));
        let d = compare(&a, &b).unwrap();
        assert_eq!(d.max_abs, 0.5);
        assert_eq!(d.differing_pixels, 1);
        // 24 channel values, one off by 0.5.
        assert!((d.mean_abs - 0.5 / 24.0).abs() < 1e-12);
        let mse = 0.25 / 24.0;
        assert!((d.psnr_db - 10.0 * (1.0f64 / mse).log10()).abs() < 1e-9);
        assert!(!d.is_identical());
    }

    #[test]
    fn psnr_of_a_uniform_offset() {
        let d = compare(
            &Image::filled(4, 2, Color::ZERO),
            &Image::filled(4, 2, Color::splat(0.1)),
        )
        .unwrap();
        assert!((d.psnr_db - 20.0).abs() < 1e-5, "{}", d.psnr_db);
        assert_eq!(d.differing_pixels, 8);
    }

    #[test]
    fn nan_is_a_difference_unless_both_are_nan() {
        let a = Image::filled(4, 2, Color::new(f32::NAN, 0.0, f32::INFINITY));
        let d = compare(&a, &a.clone()).unwrap();
        assert_eq!(d.differing_pixels, 0);
        assert!(d.psnr_db.is_infinite());
        let b = Image::filled(4, 2, Color::new(0.0, 0.0, f32::INFINITY));
        let d = compare(&a, &b).unwrap();
        assert_eq!(d.differing_pixels, 8);
        assert_eq!(d.max_abs, f32::INFINITY);
    }

    #[test]
    fn size_mismatch_is_an_error() {
        let a = Image::filled(4, 2, Color::ZERO);
        let b = Image::new(2, 4);
        assert!(matches!(compare(&a, &b), Err(Error::Invalid(_))));
        assert!(matches!(
            difference_image(&a, &b, 1.0),
            Err(Error::Invalid(_))
        ));
    }

    #[test]
    fn difference_image_scales_absolute_differences() {
        let a = Image::filled(4, 2, Color::new(0.5, 0.2, 0.0));
        let b = Image::filled(4, 2, Color::new(0.25, 0.2, 0.125));
        let d = difference_image(&a, &b, 4.0).unwrap();
        assert_eq!((d.width, d.height), (4, 2));
        assert_eq!(d.get(2, 1), Color::new(1.0, 0.0, 0.5));
        let swapped = difference_image(&b, &a, 4.0).unwrap();
        assert_eq!(swapped, d);
    }
}
