//! The Sampler: where each view's eye rays cross the image plane.
//!
//! A sample position depends only on the pixel, the sample's index and a fixed
//! seed, **never on the view**: pixel (x, y) of every view is sampled at the same
//! points of its pixel ("locked" sampling), so the eyes cannot see an edge
//! differently because their patterns differ, and the twin method finds the
//! views' rays through one position side by side.
//!
//! The methods trace **sample rows**: samples of one sub-pixel pattern across
//! a row of pixels (`SampleRow`). Pixel centres and the SPD's pixel corners are
//! one such row per image row; `--samples N` is N rows per image row (sample
//! `k` of every pixel); the adaptive refinement (`super::adaptive`) traces
//! sparse rows of the points it adds.

use crate::math::Color;
use crate::named::named_values;

/// How many samples a pixel gets and how they make its colour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sampling {
    /// One ray through each pixel centre.
    Centers,
    /// SPD procedure: rays through the (W+1)×(H+1) pixel corners, each pixel
    /// the mean of its four corners.
    Corners,
    /// `samples` points per pixel of an Owen-scrambled Sobol sequence (one per
    /// stratum when `samples` is a power of two), weighted by `filter`. The
    /// sequences of the pixels are scrambled by `seed` (0: the default
    /// pattern); another seed gives another, uncorrelated, pattern.
    Stratified {
        samples: u32,
        filter: Filter,
        seed: u32,
    },
    /// The paper's image coherence (section 2.6): the pixel corners first; a
    /// cell whose four corners differ by more than `threshold` (in any colour
    /// channel) is split in four, down to `max_samples` cells per pixel; each
    /// view refines its own cells. Each pixel is the area-weighted mean of its
    /// cells' corners.
    Adaptive { threshold: f32, max_samples: u32 },
}

/// Most samples per pixel: the length of the scrambled Sobol sequence.
pub const MAX_SAMPLES: u32 = 1 << 16;

/// Deepest adaptive subdivision: cells of 1/32 pixel (1024 per pixel).
pub const MAX_ADAPTIVE_SAMPLES: u32 = 1024;

impl Sampling {
    /// The adaptive threshold when `--adaptive` is given without one: a
    /// difference of 1/32 between corners (linear colour in 0..1) — about
    /// eight 8-bit steps. docs/benchmarks.md#anti-aliasing measures others.
    pub const DEFAULT_THRESHOLD: f32 = 1.0 / 32.0;
    /// The adaptive depth when `--max-samples` is not given: 4x4 cells.
    pub const DEFAULT_MAX_SAMPLES: u32 = 16;

    /// Refuses what cannot be sampled: no samples, more than [`MAX_SAMPLES`],
    /// a threshold that is not a finite number >= 0, an adaptive depth that is
    /// not a power of four from 4 to [`MAX_ADAPTIVE_SAMPLES`].
    pub fn validate(&self) -> crate::Result<()> {
        let invalid = |m: String| Err(crate::Error::Invalid(m));
        match *self {
            Sampling::Stratified { samples, .. } if !(1..=MAX_SAMPLES).contains(&samples) => {
                invalid(format!(
                    "{samples} samples per pixel: use 1 to {MAX_SAMPLES}"
                ))
            }
            Sampling::Adaptive { threshold, .. }
                if !(threshold.is_finite() && threshold >= 0.0) =>
            {
                invalid(format!(
                    "adaptive threshold {threshold}: a colour difference >= 0 is needed"
                ))
            }
            Sampling::Adaptive { max_samples, .. }
                if !(4..=MAX_ADAPTIVE_SAMPLES).contains(&max_samples)
                    || !max_samples.is_power_of_two()
                    || max_samples.trailing_zeros() % 2 != 0 =>
            {
                invalid(format!(
                    "at most {max_samples} adaptive samples per pixel: each split makes four \
                     cells of one, so use 4, 16, 64, 256 or 1024"
                ))
            }
            _ => Ok(()),
        }
    }

    /// A short description, for reports: `centres`, `spd-corners`,
    /// `16 samples, box filter`, `adaptive 0.03125, at most 16`.
    pub fn describe(&self) -> String {
        match *self {
            Sampling::Centers => "centres".into(),
            Sampling::Corners => "spd-corners".into(),
            Sampling::Stratified {
                samples,
                filter,
                seed,
            } => match seed {
                0 => format!("{samples} samples, {} filter", filter.name()),
                _ => format!("{samples} samples, {} filter, seed {seed}", filter.name()),
            },
            Sampling::Adaptive {
                threshold,
                max_samples,
            } => format!("adaptive {threshold}, at most {max_samples}"),
        }
    }
}

/// The reconstruction filter of `--samples N`: how much a sample at offset
/// (dx, dy) from a pixel's centre counts in that pixel. Samples reach the
/// pixels within `radius` of them, also across pixel borders.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Filter {
    /// The pixel's own area (radius 0.5): the mean of its samples, the
    /// integral the adaptive sampling approximates. The default.
    #[default]
    Box,
    /// Linear falloff to zero at one pixel.
    Tent,
    /// Gaussian of standard deviation 0.5 pixel, cut at 1.5 pixels and
    /// shifted to reach zero there.
    Gaussian,
}

impl Filter {
    /// How far (in pixels, along each axis) a sample reaches.
    pub fn radius(&self) -> f32 {
        match self {
            Filter::Box => 0.5,
            Filter::Tent => 1.0,
            Filter::Gaussian => 1.5,
        }
    }

    /// The weight of a sample `(dx, dy)` pixels from a pixel's centre
    /// (sample minus centre).
    pub fn weight(&self, dx: f32, dy: f32) -> f32 {
        match self {
            // Half-open, as the pixel is: a sample on a border counts in one pixel.
            Filter::Box => {
                if (-0.5..0.5).contains(&dx) && (-0.5..0.5).contains(&dy) {
                    1.0
                } else {
                    0.0
                }
            }
            Filter::Tent => (1.0 - dx.abs()).max(0.0) * (1.0 - dy.abs()).max(0.0),
            Filter::Gaussian => {
                const SIGMA: f32 = 0.5;
                let g = |d: f32| (-d * d / (2.0 * SIGMA * SIGMA)).exp();
                let floor = g(1.5);
                (g(dx) - floor).max(0.0) * (g(dy) - floor).max(0.0)
            }
        }
    }
}

named_values!(Filter {
    Box = "box",
    Tent = "tent",
    Gaussian = "gaussian",
});

/// Mixed into every pixel's seed: the pattern is fixed, so renders repeat exactly.
const SEED: u32 = 0x7c1d_5eed;

/// Where within their pixels the samples of a row lie.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Pattern {
    /// The same point of every pixel: `dx` from the pixel's centre along the
    /// row, and image row `y` (integers are pixel centres).
    Fixed { dx: f32, y: f32 },
    /// Sample `index` of image row `row`: a point of the pixel's own
    /// scrambled Sobol sequence (seeded by the pixel and `seed`, not the view).
    Sobol { row: u32, index: u32, seed: u32 },
}

impl Pattern {
    /// The offset along the row and the image row of the sample of pixel `x`.
    #[inline]
    pub(super) fn at(&self, x: i32) -> (f32, f32) {
        match *self {
            Pattern::Fixed { dx, y } => (dx, y),
            Pattern::Sobol { row, index, seed } => {
                let seed = pixel_seed(x, row, seed);
                let dx = sobol_burley::sample(index, 0, seed) - 0.5;
                let dy = sobol_burley::sample(index, 1, seed) - 0.5;
                (dx, row as f32 + dy)
            }
        }
    }
}

/// A seed per pixel (a hash of its coordinates): scrambles each pixel's
/// sequence differently, so neighbouring pixels do not share a pattern.
fn pixel_seed(x: i32, y: u32, seed: u32) -> u32 {
    // The finaliser of MurmurHash3 over both coordinates and the seed.
    let mut h = (x as u32).wrapping_mul(0x9e37_79b1)
        ^ y.wrapping_mul(0x85eb_ca77)
        ^ seed.wrapping_mul(0xcc9e_2d51)
        ^ SEED;
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^ (h >> 16)
}

/// Samples of one pattern across a row of pixels: what a method traces in
/// one go. The same for every view: view `v`'s sample `i` looks along camera
/// column `pixels[i] + shift_v + dx_i`.
#[derive(Clone, Debug, PartialEq)]
pub struct SampleRow {
    /// The image column of each sample's pixel, ascending.
    pub(super) pixels: Vec<i32>,
    /// Per sample: its offset along the row from its pixel's centre, and its
    /// image row.
    pub(super) offsets: Vec<(f32, f32)>,
    pub(super) pattern: Pattern,
    /// `pixels` is every column from `pixels[0]` on (no gaps).
    contiguous: bool,
}

impl SampleRow {
    /// Samples of `pattern` in the pixels of `pixels` (ascending).
    pub(super) fn new(pixels: Vec<i32>, pattern: Pattern) -> SampleRow {
        let offsets = match pattern {
            // Every sample of a fixed pattern has the same offset.
            Pattern::Fixed { dx, y } => vec![(dx, y); pixels.len()],
            Pattern::Sobol { .. } => pixels.iter().map(|&x| pattern.at(x)).collect(),
        };
        let contiguous = match (pixels.first(), pixels.last()) {
            (Some(&a), Some(&b)) => (b - a) as usize + 1 == pixels.len(),
            _ => true,
        };
        SampleRow {
            pixels,
            offsets,
            pattern,
            contiguous,
        }
    }

    /// `pattern` in every pixel of columns `0..count`.
    pub(super) fn full(count: usize, pattern: Pattern) -> SampleRow {
        SampleRow::new((0..count as i32).collect(), pattern)
    }

    /// The centres of the pixels of columns `0..count` of image row `y`
    /// (the render stages' tests' rows).
    #[cfg(test)]
    pub(super) fn centres(count: usize, y: u32) -> SampleRow {
        SampleRow::full(
            count,
            Pattern::Fixed {
                dx: 0.0,
                y: y as f32,
            },
        )
    }

    pub fn len(&self) -> usize {
        self.pixels.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pixels.is_empty()
    }

    /// The camera column and row that the view shifted by `shift` looks along
    /// through sample `i`. Every method computes its rays from this, so their
    /// rays are the same bit for bit.
    pub(super) fn camera_point(&self, i: usize, shift: i32) -> (f32, f32) {
        let (dx, y) = self.offsets[i];
        ((self.pixels[i] + shift) as f32 + dx, y)
    }

    /// The camera point of this row's pattern in camera column `column` of a
    /// view with no shift (the rig's centre, which the cut of section 2.3
    /// shades once per column).
    pub(super) fn centre_point(&self, column: i32) -> (f32, f32) {
        let (dx, y) = self.pattern.at(column);
        (column as f32 + dx, y)
    }

    /// The sample nearest to image column `u` of a view (integers are pixel
    /// centres), if the row has one in that pixel.
    #[cfg(test)]
    fn nearest(&self, u: f64) -> Option<usize> {
        let dx = match self.pattern {
            Pattern::Fixed { dx, .. } => dx as f64,
            Pattern::Sobol { .. } => 0.0,
        };
        self.sample_of_pixel((u - dx).round())
    }

    /// The sample of the pixel that a point seen by sample `source` (of another
    /// view) falls in, at image column `u`, counted as if it lay at `source`'s
    /// own offset in its pixel: the pixels of the two views then match one to
    /// one where the disparity is smooth, also when the samples' offsets differ
    /// from pixel to pixel (`--samples N`), so no two samples claim one.
    pub(super) fn nearest_to_sample(&self, u: f64, source: usize) -> Option<usize> {
        let dx = self.offsets.get(source).map_or(0.0, |&(dx, _)| dx as f64);
        self.sample_of_pixel((u - dx).round())
    }

    /// The sample in pixel `p` (a whole number), if the row has one.
    fn sample_of_pixel(&self, p: f64) -> Option<usize> {
        let first = *self.pixels.first()? as f64;
        if self.contiguous {
            let k = p - first;
            (k >= 0.0 && k < self.pixels.len() as f64).then_some(k as usize)
        } else if p.abs() < i32::MAX as f64 {
            self.pixels.binary_search(&(p as i32)).ok()
        } else {
            None
        }
    }
}

/// A view's colours for the samples of a row, by sample.
pub(super) type RowColors = Vec<Color>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sobol_samples_stay_in_their_pixel_and_fill_its_strata() {
        for x in [-3, 0, 17] {
            let mut strata = [0u32; 16];
            for index in 0..16 {
                let (dx, y) = Pattern::Sobol {
                    row: 5,
                    index,
                    seed: 0,
                }
                .at(x);
                assert!((-0.5..0.5).contains(&dx), "{dx}");
                let dy = y - 5.0;
                assert!((-0.5..0.5).contains(&dy), "{dy}");
                let (sx, sy) = (((dx + 0.5) * 4.0) as usize, ((dy + 0.5) * 4.0) as usize);
                strata[sy * 4 + sx] += 1;
            }
            assert_eq!(strata, [1; 16], "pixel {x}: one sample per stratum");
        }
    }

    #[test]
    fn every_view_samples_its_pixels_at_the_same_points() {
        // Locked sampling: view v's sample of pixel x lies at the same point
        // of that pixel whatever the view's image shift.
        let row = SampleRow::full(
            9,
            Pattern::Sobol {
                row: 4,
                index: 2,
                seed: 0,
            },
        );
        for i in 0..row.len() {
            let (c0, y0) = row.camera_point(i, 0);
            for shift in [-7, 3, 40] {
                let (c, y) = row.camera_point(i, shift);
                // (Up to the rounding of the larger column number.)
                assert!(
                    (c - shift as f32 - c0).abs() < 1e-4,
                    "sample {i}, shift {shift}"
                );
                assert_eq!(y, y0);
            }
        }
    }

    #[test]
    fn neighbouring_pixels_have_different_patterns() {
        let a = Pattern::Sobol {
            row: 2,
            index: 0,
            seed: 0,
        }
        .at(10);
        let b = Pattern::Sobol {
            row: 2,
            index: 0,
            seed: 0,
        }
        .at(11);
        let c = Pattern::Sobol {
            row: 3,
            index: 0,
            seed: 0,
        }
        .at(10);
        assert_ne!(a, b);
        assert_ne!(a.0, c.0);
    }

    #[test]
    fn nearest_finds_the_sample_of_a_pixel() {
        let row = SampleRow::full(8, Pattern::Fixed { dx: -0.5, y: 0.0 });
        assert_eq!(row.nearest(2.4), Some(3)); // corner 3 is at 2.5
        assert_eq!(row.nearest(-0.6), Some(0));
        assert_eq!(row.nearest(-1.2), None);
        let sparse = SampleRow::new(vec![1, 4, 9], Pattern::Fixed { dx: 0.0, y: 0.0 });
        assert_eq!(sparse.nearest(4.3), Some(1));
        assert_eq!(sparse.nearest(5.0), None);
        assert_eq!(sparse.nearest(8.6), Some(2));
        let jittered = SampleRow::full(
            4,
            Pattern::Sobol {
                row: 0,
                index: 3,
                seed: 0,
            },
        );
        assert_eq!(jittered.nearest(2.45), Some(2));
        assert_eq!(jittered.nearest(f64::NAN), None);
    }

    #[test]
    fn bad_sampling_is_refused() {
        let bad = [
            Sampling::Stratified {
                samples: 0,
                filter: Filter::Box,
                seed: 0,
            },
            Sampling::Stratified {
                samples: MAX_SAMPLES + 1,
                filter: Filter::Box,
                seed: 0,
            },
            Sampling::Adaptive {
                threshold: -0.1,
                max_samples: 16,
            },
            Sampling::Adaptive {
                threshold: f32::NAN,
                max_samples: 16,
            },
            Sampling::Adaptive {
                threshold: 0.1,
                max_samples: 8,
            },
            Sampling::Adaptive {
                threshold: 0.1,
                max_samples: 1,
            },
        ];
        for s in bad {
            assert!(s.validate().is_err(), "{s:?}");
        }
        assert!(Sampling::Adaptive {
            threshold: 0.0,
            max_samples: 64
        }
        .validate()
        .is_ok());
    }

    #[test]
    fn filters_weigh_the_centre_most_and_stop_at_their_radius() {
        for f in [Filter::Box, Filter::Tent, Filter::Gaussian] {
            let r = f.radius();
            assert!(f.weight(0.0, 0.0) > 0.0);
            assert_eq!(f.weight(r + 0.01, 0.0), 0.0, "{f:?}");
            assert!(f.weight(0.2, 0.1) <= f.weight(0.0, 0.0));
        }
    }
}
