//! The Film: where samples become pixels.
//!
//! Each sample adds its colour, weighted by the reconstruction filter, to the
//! pixels within the filter's radius (also across pixel borders); a pixel is
//! the weighted sum over the weight. The film is written in bands of rows, each
//! by one task (its rows plus the halo its samples reach), and the bands are
//! added in band order: the sums, and so the images, are the same for any
//! number of threads. The filter weights depend on sample positions only, which
//! are the same in every view: one weight per pixel serves all views.

use super::sampler::{Filter, RowColors, SampleRow};
use crate::image::{Image, Rgb8Image};
use crate::math::Color;
use crate::output::{rgb8_into, WriteOptions};

/// The rows of the film one task writes: `rows` from `first_row`, with the
/// sums of every view and the weights.
pub(super) struct FilmBand {
    first_row: usize,
    rows: usize,
    width: usize,
    sums: Vec<Vec<Color>>,
    weights: Vec<f32>,
}

/// Pixel rows beyond its own that a sample reaches with a weight above zero
/// (the filters weigh zero at exactly their radius).
pub(super) fn halo(filter: Filter) -> usize {
    (filter.radius() - 0.5).ceil().max(0.0) as usize
}

impl FilmBand {
    /// The band that holds what the samples of pixel rows `rows` reach.
    pub(super) fn new(
        views: usize,
        (width, height): (usize, usize),
        rows: std::ops::Range<usize>,
        filter: Filter,
    ) -> FilmBand {
        let h = halo(filter);
        let first_row = rows.start.saturating_sub(h);
        let last_row = (rows.end + h).min(height);
        let count = last_row.saturating_sub(first_row);
        FilmBand {
            first_row,
            rows: count,
            width,
            sums: vec![vec![Color::ZERO; count * width]; views],
            weights: vec![0.0; count * width],
        }
    }

    /// Adds the samples of `row` (`colors[v][i]`: view `v`'s colour of
    /// sample `i`) to the pixels their filter reaches.
    pub(super) fn splat(&mut self, filter: Filter, row: &SampleRow, colors: &[RowColors]) {
        let r = filter.radius();
        let (w, first, rows) = (self.width as i64, self.first_row as i64, self.rows as i64);
        for (i, (&x, &(dx, y))) in row.pixels.iter().zip(&row.offsets).enumerate() {
            let sx = x as f32 + dx;
            let (x0, x1) = ((sx - r).ceil() as i64, (sx + r).floor() as i64);
            let (y0, y1) = ((y - r).ceil() as i64, (y + r).floor() as i64);
            for py in y0.max(first)..=y1.min(first + rows - 1) {
                for px in x0.max(0)..=x1.min(w - 1) {
                    let weight = filter.weight(sx - px as f32, y - py as f32);
                    if weight == 0.0 {
                        continue;
                    }
                    let k = ((py - first) * w + px) as usize;
                    self.weights[k] += weight;
                    for (sums, view_colors) in self.sums.iter_mut().zip(colors) {
                        sums[k] += view_colors[i] * weight;
                    }
                }
            }
        }
    }
}

/// The image of every view (or its rows `first_row..first_row + height`: a
/// tile), as sums and weights.
pub(super) struct Film {
    first_row: usize,
    width: usize,
    height: usize,
    sums: Vec<Vec<Color>>,
    weights: Vec<f32>,
}

impl Film {
    pub(super) fn new(views: usize, width: usize, rows: std::ops::Range<usize>) -> Film {
        let height = rows.len();
        Film {
            first_row: rows.start,
            width,
            height,
            sums: vec![vec![Color::ZERO; width * height]; views],
            weights: vec![0.0; width * height],
        }
    }

    /// Adds a band's rows that the film holds (call in band order: the sums
    /// are then the same on any run, and in a tile the same as in the whole).
    pub(super) fn add(&mut self, band: &FilmBand) {
        let first = band.first_row.max(self.first_row);
        let end = (band.first_row + band.rows).min(self.first_row + self.height);
        if first >= end {
            return;
        }
        let n = (end - first) * self.width;
        let offset = (first - self.first_row) * self.width;
        let band_offset = (first - band.first_row) * self.width;
        for (sums, band_sums) in self.sums.iter_mut().zip(&band.sums) {
            let from = &band_sums[band_offset..band_offset + n];
            for (s, b) in sums[offset..offset + n].iter_mut().zip(from) {
                *s += *b;
            }
        }
        let from = &band.weights[band_offset..band_offset + n];
        for (s, b) in self.weights[offset..offset + n].iter_mut().zip(from) {
            *s += *b;
        }
    }

    /// Every view's image as 8-bit pixels quantised with `opts`: the bytes
    /// of [`Film::images`] written to an 8-bit file, without the float images.
    pub(super) fn rgb8(self, opts: &WriteOptions) -> Vec<Rgb8Image> {
        let (width, height, weights) = (self.width, self.height, &self.weights);
        let mut row = Vec::with_capacity(width);
        self.sums
            .iter()
            .map(|sums| {
                let mut bytes = vec![0u8; 3 * width * height];
                for ((to, sums), weights) in bytes
                    .chunks_mut(3 * width.max(1))
                    .zip(sums.chunks(width.max(1)))
                    .zip(weights.chunks(width.max(1)))
                {
                    row.clear();
                    row.extend(sums.iter().zip(weights).map(|(&s, &w)| pixel(s, w)));
                    rgb8_into(&row, to, opts);
                }
                Rgb8Image {
                    width: width as u32,
                    height: height as u32,
                    bytes,
                }
            })
            .collect()
    }

    /// Every view's image: each pixel its weighted sum over its weight.
    pub(super) fn images(self) -> Vec<Image> {
        let (width, height, weights) = (self.width, self.height, self.weights);
        self.sums
            .into_iter()
            .map(|sums| Image {
                width: width as u32,
                height: height as u32,
                pixels: sums
                    .into_iter()
                    .zip(&weights)
                    .map(|(s, &w)| pixel(s, w))
                    .collect(),
            })
            .collect()
    }
}

/// A pixel's colour from its weighted sum `s` and its weight `w`.
#[inline]
fn pixel(s: Color, w: f32) -> Color {
    if w > 0.0 {
        s * (1.0 / w)
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::sampler::Pattern;

    fn splat_one(filter: Filter, x: i32, dx: f32, y: f32) -> (Film, usize) {
        let row = SampleRow::new(vec![x], Pattern::Fixed { dx, y });
        let mut band = FilmBand::new(1, (5, 5), 0..5, filter);
        band.splat(filter, &row, &[vec![Color::new(1.0, 1.0, 1.0)]]);
        let mut film = Film::new(1, 5, 0..5);
        film.add(&band);
        let touched = film.weights.iter().filter(|&&w| w > 0.0).count();
        (film, touched)
    }

    #[test]
    fn a_box_sample_counts_in_its_own_pixel_only() {
        // On the border between two pixels: only the one it belongs to.
        let (film, touched) = splat_one(Filter::Box, 2, -0.5, 2.0);
        assert_eq!(touched, 1);
        assert!(film.weights[2 * 5 + 2] > 0.0);
    }

    #[test]
    fn wider_filters_reach_the_neighbours() {
        assert_eq!(splat_one(Filter::Tent, 2, 0.0, 2.0).1, 1);
        assert_eq!(splat_one(Filter::Tent, 2, 0.25, 2.25).1, 4);
        assert_eq!(splat_one(Filter::Gaussian, 2, 0.0, 2.0).1, 9);
    }

    #[test]
    fn a_band_with_its_halo_holds_all_its_samples_reach() {
        for filter in [Filter::Box, Filter::Tent, Filter::Gaussian] {
            let row = SampleRow::new(vec![2], Pattern::Fixed { dx: 0.3, y: 1.6 });
            let mut band = FilmBand::new(1, (5, 9), 2..3, filter);
            band.splat(filter, &row, &[vec![Color::new(1.0, 1.0, 1.0)]]);
            let mut all = FilmBand::new(1, (5, 9), 0..9, filter);
            all.splat(filter, &row, &[vec![Color::new(1.0, 1.0, 1.0)]]);
            let sum = |b: &FilmBand| b.weights.iter().sum::<f32>();
            assert_eq!(sum(&band), sum(&all), "{filter:?}");
        }
    }
}
