//! The paper's image coherence (section 2.6) as adaptive refinement, in the
//! manner of Whitted: the pixel corners are traced first (shared by the four
//! pixels around each); a cell whose four corners differ by more than the
//! threshold is split into four, its edge midpoints and centre traced, down to
//! cells of `1/side` pixel. A pixel is the mean of its cells' corner means,
//! each weighted by the cell's area.
//!
//! In stereo the decision to split is taken once for all views, from all
//! views' corners: the eyes cannot disagree about where an edge is refined,
//! and the points added are traced for every view, as one packet.

use super::sampler::{Pattern, RowColors, SampleRow};
use crate::math::Color;

/// A cell of a pixel row: its top-left point on the row's lattice and its side.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Cell {
    /// Lattice column (`side` per pixel) and row (0 at the pixel row's top).
    x: usize,
    j: usize,
    size: usize,
}

/// What refining one pixel row did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct RowRefinement {
    /// Points traced (per view) beyond the corners.
    pub added: u64,
    /// Pixels with at least one split.
    pub refined: u64,
    /// Most points one pixel's colour came from (its corners included).
    pub max_per_pixel: u32,
}

/// The refinement of one pixel row at a time, with its buffers.
pub(super) struct Refiner {
    threshold: f32,
    /// Lattice points per pixel side (a power of two).
    side: usize,
    width: usize,
    /// `values[v][j * stride + x]`: view `v`'s colour at lattice point (x, j).
    values: Vec<Vec<Color>>,
    known: Vec<bool>,
    cells: Vec<Cell>,
    next: Vec<Cell>,
    pending: Vec<(usize, usize)>,
    row_colors: Vec<RowColors>,
    /// The pixel row refined last: its bottom lattice row is the top of the next.
    last_row: Option<usize>,
}

impl Refiner {
    /// A refiner for rows of `width` pixels of `views` views, splitting cells
    /// whose corners differ by more than `threshold`, down to `max_samples`
    /// cells per pixel (a power of four).
    pub(super) fn new(views: usize, width: usize, threshold: f32, max_samples: u32) -> Refiner {
        let side = (max_samples as f64).sqrt().round() as usize;
        let points = (width * side + 1) * (side + 1);
        Refiner {
            threshold,
            side,
            width,
            values: vec![vec![Color::ZERO; points]; views],
            known: vec![false; points],
            cells: Vec::new(),
            next: Vec::new(),
            pending: Vec::new(),
            row_colors: Vec::new(),
            last_row: None,
        }
    }

    fn stride(&self) -> usize {
        self.width * self.side + 1
    }

    fn index(&self, x: usize, j: usize) -> usize {
        j * self.stride() + x
    }

    /// Whether the corners of `cell` differ by more than the threshold in any
    /// colour channel of any view.
    fn differs(&self, cell: Cell) -> bool {
        let Cell { x, j, size } = cell;
        let corners = [
            self.index(x, j),
            self.index(x + size, j),
            self.index(x, j + size),
            self.index(x + size, j + size),
        ];
        self.values.iter().any(|view| {
            let c = corners.map(|k| view[k]);
            let (lo, hi) = c[1..]
                .iter()
                .fold((c[0], c[0]), |(lo, hi), &v| (lo.min(v), hi.max(v)));
            (hi - lo).max_element() > self.threshold
        })
    }

    /// The mean of a cell's corners, weighted by its share of the pixel.
    fn cell_mean(&self, view: usize, cell: Cell) -> Color {
        let Cell { x, j, size } = cell;
        let v = &self.values[view];
        let sum = v[self.index(x, j)]
            + v[self.index(x + size, j)]
            + v[self.index(x, j + size)]
            + v[self.index(x + size, j + size)];
        let area = (size * size) as f32 / (self.side * self.side) as f32;
        sum * (0.25 * area)
    }

    /// Refines pixel row `y` (best called for consecutive rows: the points
    /// on their shared edge are then traced once). `corners(v, x, top)` is view `v`'s colour at the
    /// corner left of pixel `x` on the row's top (`top`) or bottom edge;
    /// `trace(row, out)` traces a row of samples for every view; `out[v][x]`
    /// receives the pixels.
    pub(super) fn refine_row(
        &mut self,
        y: usize,
        corners: impl Fn(usize, usize, bool) -> Color,
        trace: &mut dyn FnMut(&SampleRow, &mut Vec<RowColors>),
        out: &mut [RowColors],
    ) -> RowRefinement {
        let (side, width, views) = (self.side, self.width, self.values.len());
        // The points traced on the previous row's bottom edge are this row's
        // top edge: kept, not traced again.
        let stride = self.stride();
        if self.last_row.is_some_and(|r| r + 1 == y) {
            let bottom = side * stride;
            self.known.copy_within(bottom..bottom + stride, 0);
            for values in &mut self.values {
                values.copy_within(bottom..bottom + stride, 0);
            }
            self.known[stride..].fill(false);
        } else {
            self.known.fill(false);
        }
        self.last_row = Some(y);
        for x in 0..=width {
            for (j, top) in [(0, true), (side, false)] {
                let k = self.index(x * side, j);
                self.known[k] = true;
                for v in 0..views {
                    self.values[v][k] = corners(v, x, top);
                }
            }
        }
        for view_out in out.iter_mut() {
            view_out.clear();
            view_out.resize(width, Color::ZERO);
        }
        let mut report = RowRefinement::default();
        let mut refined = vec![false; width];
        self.cells.clear();
        self.cells.extend((0..width).map(|x| Cell {
            x: x * side,
            j: 0,
            size: side,
        }));
        while !self.cells.is_empty() {
            self.next.clear();
            self.pending.clear();
            let cells = std::mem::take(&mut self.cells);
            for &cell in &cells {
                if cell.size > 1 && self.differs(cell) {
                    refined[cell.x / side] = true;
                    let (Cell { x, j, size }, h) = (cell, cell.size / 2);
                    for (px, pj) in [
                        (x + h, j),
                        (x, j + h),
                        (x + h, j + h),
                        (x + size, j + h),
                        (x + h, j + size),
                    ] {
                        let k = self.index(px, pj);
                        if !self.known[k] {
                            self.known[k] = true;
                            self.pending.push((px, pj));
                        }
                    }
                    for (dx, dj) in [(0, 0), (h, 0), (0, h), (h, h)] {
                        self.next.push(Cell {
                            x: x + dx,
                            j: j + dj,
                            size: h,
                        });
                    }
                } else {
                    let pixel = cell.x / side;
                    for (v, view_out) in out.iter_mut().enumerate() {
                        view_out[pixel] += self.cell_mean(v, cell);
                    }
                }
            }
            self.cells = cells;
            report.added += self.pending.len() as u64;
            self.trace_pending(y, trace);
            std::mem::swap(&mut self.cells, &mut self.next);
        }
        report.refined = refined.iter().filter(|&&r| r).count() as u64;
        report.max_per_pixel = if report.refined > 0 {
            (0..width)
                .filter(|&x| refined[x])
                .map(|x| self.points_in_pixel(x))
                .max()
                .unwrap_or(4)
        } else {
            4
        };
        report
    }

    /// Traces the points added at one level, a row of samples per lattice
    /// row and position within the pixel (one pattern each).
    fn trace_pending(&mut self, y: usize, trace: &mut dyn FnMut(&SampleRow, &mut Vec<RowColors>)) {
        let side = self.side;
        // By lattice row, then position in the pixel, then pixel.
        self.pending
            .sort_unstable_by_key(|&(x, j)| (j, x % side, x / side));
        let mut start = 0;
        let mut colors = std::mem::take(&mut self.row_colors);
        while start < self.pending.len() {
            let (x0, j) = self.pending[start];
            let phase = x0 % side;
            let end = start
                + self.pending[start..]
                    .iter()
                    .take_while(|&&(x, jj)| jj == j && x % side == phase)
                    .count();
            let pixels: Vec<i32> = self.pending[start..end]
                .iter()
                .map(|&(x, _)| (x / side) as i32)
                .collect();
            // Exact in f32: the lattice steps are powers of two.
            let pattern = Pattern::Fixed {
                dx: phase as f32 / side as f32 - 0.5,
                y: (y as f32 - 0.5) + j as f32 / side as f32,
            };
            let row = SampleRow::new(pixels, pattern);
            trace(&row, &mut colors);
            for (i, &(x, j)) in self.pending[start..end].iter().enumerate() {
                let k = self.index(x, j);
                for (values, view_colors) in self.values.iter_mut().zip(&colors) {
                    values[k] = view_colors[i];
                }
            }
            start = end;
        }
        self.row_colors = colors;
    }

    /// Lattice points known within pixel `x` (its border included).
    fn points_in_pixel(&self, x: usize) -> u32 {
        let side = self.side;
        let mut n = 0;
        for j in 0..=side {
            for px in x * side..=(x + 1) * side {
                n += u32::from(self.known[self.index(px, j)]);
            }
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scene of one vertical edge at image column `edge` (white to its
    /// right), traced by a closure that counts the samples it is asked for.
    fn refine(rows: &[usize], edge: f32, refiner: &mut Refiner) -> (Vec<Vec<Color>>, u64) {
        let mut traced = 0;
        let shade = |column: f32| {
            if column >= edge {
                Color::ONE
            } else {
                Color::ZERO
            }
        };
        let mut trace = |row: &SampleRow, out: &mut Vec<RowColors>| {
            traced += row.len() as u64;
            out.resize_with(1, Vec::new);
            out[0] = (0..row.len())
                .map(|i| shade(row.camera_point(i, 0).0))
                .collect();
        };
        let mut images = Vec::new();
        for &y in rows {
            let mut out = vec![Vec::new()];
            refiner.refine_row(y, |_, x, _| shade(x as f32 - 0.5), &mut trace, &mut out);
            images.push(out.remove(0));
        }
        (images, traced)
    }

    #[test]
    fn an_edge_is_refined_to_its_coverage_and_flat_pixels_are_not() {
        let mut refiner = Refiner::new(1, 6, 0.1, 16);
        let (rows, _) = refine(&[0], 2.8, &mut refiner);
        let row = &rows[0];
        // Pixel 3 spans columns 2.5..3.5: the edge at 2.8 leaves 0.7 of it white;
        // on a 5 x 5 lattice (steps of 0.25) the trapezoid rule gives 0.625.
        assert_eq!(row[3].x, 0.625);
        assert_eq!(&row[..3], &[Color::ZERO; 3]);
        assert_eq!(&row[4..], &[Color::ONE; 2]);
    }

    #[test]
    fn consecutive_rows_trace_their_shared_edge_once() {
        let mut carried = Refiner::new(1, 6, 0.1, 16);
        let (a, with_carry) = refine(&[0, 1, 2], 2.8, &mut carried);
        let mut traced_alone = 0;
        let mut b = Vec::new();
        for y in 0..3 {
            let mut fresh = Refiner::new(1, 6, 0.1, 16);
            let (rows, traced) = refine(&[y], 2.8, &mut fresh);
            traced_alone += traced;
            b.extend(rows);
        }
        assert_eq!(a, b, "the same pixels");
        // The edge pixel's bottom edge gets 2 lattice points (its midpoint, and
        // the midpoint of the half the edge crosses), which a fresh refiner
        // traces again in each of the two rows below.
        assert_eq!(
            traced_alone - with_carry,
            2 * 2,
            "{with_carry} vs {traced_alone}"
        );
    }
}
