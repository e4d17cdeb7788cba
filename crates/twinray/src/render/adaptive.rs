//! The paper's image coherence (section 2.6) as adaptive refinement, in the
//! manner of Whitted: the pixel corners are traced first (shared by the four
//! pixels around each); a cell whose four corners differ by more than the
//! threshold is split into four, its edge midpoints and centre traced, down to
//! cells of `1/side` pixel. A pixel is the mean of its cells' corner means,
//! each weighted by the cell's area.
//!
//! With several views each view refines its own cells, from its own
//! corners, in the order a render of that view alone would: every view's
//! pixels are its mono render's bit for bit, and a view traces only the
//! points its own edges need. A point that every view of a batch needs is
//! traced once for the batch, the views' rays as one packet; a point that
//! only some need is traced by each of them alone.

use std::ops::Range;

use super::sampler::{Pattern, RowColors, SampleRow};
use crate::math::Color;

/// Who traces a row of refined points.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Tracing {
    /// Batch `b` of views, every view of it (it returns a row per view).
    Batch(usize),
    /// View `v` alone (it returns one row).
    View(usize),
}

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
    /// Points traced beyond the corners, summed over the views.
    pub added: u64,
    /// Pixels with at least one split, summed over the views.
    pub refined: u64,
    /// Most points one pixel's colour came from (its corners included), in
    /// any view.
    pub max_per_pixel: u32,
}

/// The refinement of one pixel row at a time, with its buffers.
pub(super) struct Refiner {
    threshold: f32,
    /// Lattice points per pixel side (a power of two).
    side: usize,
    width: usize,
    /// The views of each batch (consecutive, in rig order).
    batches: Vec<Range<usize>>,
    /// `values[v][j * stride + x]`: view `v`'s colour at lattice point (x, j).
    values: Vec<Vec<Color>>,
    /// `known[v][k]`: whether view `v`'s colour at point `k` is traced.
    known: Vec<Vec<bool>>,
    /// Per view, the cells of the current level and of the next.
    cells: Vec<Vec<Cell>>,
    next: Vec<Vec<Cell>>,
    /// Per view, the points it needs traced at the current level.
    pending: Vec<Vec<(usize, usize)>>,
    /// Per lattice point, how many views of the batch at hand need it.
    needed: Vec<u16>,
    /// Points every view of a batch needs, and those one view needs alone.
    joint: Vec<(usize, usize)>,
    alone: Vec<(usize, usize)>,
    /// Per view, whether each pixel of the row was split.
    refined: Vec<Vec<bool>>,
    row_colors: Vec<RowColors>,
    /// The pixel row refined last: its bottom lattice row is the top of the next.
    last_row: Option<usize>,
}

impl Refiner {
    /// A refiner for rows of `width` pixels of the views of `batches` (view
    /// counts of consecutive batches), splitting cells whose corners differ
    /// by more than `threshold`, down to `max_samples` cells per pixel (a
    /// power of four).
    pub(super) fn new(
        batches: &[usize],
        width: usize,
        threshold: f32,
        max_samples: u32,
    ) -> Refiner {
        let side = (max_samples as f64).sqrt().round() as usize;
        let points = (width * side + 1) * (side + 1);
        let mut ranges = Vec::with_capacity(batches.len());
        let mut first = 0;
        for &n in batches {
            ranges.push(first..first + n);
            first += n;
        }
        let views = first;
        Refiner {
            threshold,
            side,
            width,
            batches: ranges,
            values: vec![vec![Color::ZERO; points]; views],
            known: vec![vec![false; points]; views],
            cells: vec![Vec::new(); views],
            next: vec![Vec::new(); views],
            pending: vec![Vec::new(); views],
            needed: vec![0; points],
            joint: Vec::new(),
            alone: Vec::new(),
            refined: vec![vec![false; width]; views],
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
    /// colour channel of view `view`.
    fn differs(&self, view: usize, cell: Cell) -> bool {
        let Cell { x, j, size } = cell;
        let v = &self.values[view];
        let c = [
            v[self.index(x, j)],
            v[self.index(x + size, j)],
            v[self.index(x, j + size)],
            v[self.index(x + size, j + size)],
        ];
        let (lo, hi) = c[1..]
            .iter()
            .fold((c[0], c[0]), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        (hi - lo).max_element() > self.threshold
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
    /// on their shared edge are then traced once). `corners(v, x, top)` is
    /// view `v`'s colour at the corner left of pixel `x` on the row's top
    /// (`top`) or bottom edge; `trace(who, row, out)` traces a row of samples
    /// for a batch's views or one view ([`Tracing`]); `out[v][x]` receives
    /// the pixels.
    pub(super) fn refine_row(
        &mut self,
        y: usize,
        corners: impl Fn(usize, usize, bool) -> Color,
        trace: &mut dyn FnMut(Tracing, &SampleRow, &mut Vec<RowColors>),
        out: &mut [RowColors],
    ) -> RowRefinement {
        let (side, width, views) = (self.side, self.width, self.values.len());
        // The points traced on the previous row's bottom edge are this row's
        // top edge: kept, not traced again.
        let stride = self.stride();
        let carried = self.last_row.is_some_and(|r| r + 1 == y);
        let bottom = side * stride;
        for (known, values) in self.known.iter_mut().zip(&mut self.values) {
            if carried {
                known.copy_within(bottom..bottom + stride, 0);
                values.copy_within(bottom..bottom + stride, 0);
                known[stride..].fill(false);
            } else {
                known.fill(false);
            }
        }
        self.last_row = Some(y);
        for x in 0..=width {
            for (j, top) in [(0, true), (side, false)] {
                let k = self.index(x * side, j);
                for v in 0..views {
                    self.known[v][k] = true;
                    self.values[v][k] = corners(v, x, top);
                }
            }
        }
        for view_out in out.iter_mut() {
            view_out.clear();
            view_out.resize(width, Color::ZERO);
        }
        let mut report = RowRefinement::default();
        for v in 0..views {
            self.refined[v].fill(false);
            self.cells[v].clear();
            self.cells[v].extend((0..width).map(|x| Cell {
                x: x * side,
                j: 0,
                size: side,
            }));
        }
        while self.cells.iter().any(|c| !c.is_empty()) {
            for (v, view_out) in out.iter_mut().enumerate() {
                report.added += self.split_level(v, view_out);
            }
            self.trace_level(y, trace);
            std::mem::swap(&mut self.cells, &mut self.next);
        }
        for v in 0..views {
            for x in 0..width {
                if self.refined[v][x] {
                    report.refined += 1;
                    report.max_per_pixel = report.max_per_pixel.max(self.points_in_pixel(v, x));
                }
            }
        }
        report.max_per_pixel = report.max_per_pixel.max(4);
        report
    }

    /// One level of view `view`'s cells: a cell whose corners differ is
    /// split (the points it needs become pending, its quarters the next
    /// level's cells), any other adds its mean to its pixel of `out`.
    /// Returns the points made pending.
    fn split_level(&mut self, view: usize, out: &mut [Color]) -> u64 {
        let side = self.side;
        let cells = std::mem::take(&mut self.cells[view]);
        let mut next = std::mem::take(&mut self.next[view]);
        let mut pending = std::mem::take(&mut self.pending[view]);
        next.clear();
        pending.clear();
        for &cell in &cells {
            if cell.size > 1 && self.differs(view, cell) {
                self.refined[view][cell.x / side] = true;
                let (Cell { x, j, size }, h) = (cell, cell.size / 2);
                for (px, pj) in [
                    (x + h, j),
                    (x, j + h),
                    (x + h, j + h),
                    (x + size, j + h),
                    (x + h, j + size),
                ] {
                    let k = self.index(px, pj);
                    if !self.known[view][k] {
                        self.known[view][k] = true;
                        pending.push((px, pj));
                    }
                }
                for (dx, dj) in [(0, 0), (h, 0), (0, h), (h, h)] {
                    next.push(Cell {
                        x: x + dx,
                        j: j + dj,
                        size: h,
                    });
                }
            } else {
                out[cell.x / side] += self.cell_mean(view, cell);
            }
        }
        let added = pending.len() as u64;
        self.cells[view] = cells;
        self.next[view] = next;
        self.pending[view] = pending;
        added
    }

    /// Traces the points the views made pending at one level: for each
    /// batch, those every view of it needs as the batch, the others by
    /// each view that needs them, alone.
    fn trace_level(
        &mut self,
        y: usize,
        trace: &mut dyn FnMut(Tracing, &SampleRow, &mut Vec<RowColors>),
    ) {
        let stride = self.stride();
        for b in 0..self.batches.len() {
            let views = self.batches[b].clone();
            let all = views.len() as u16;
            let mut joint = std::mem::take(&mut self.joint);
            joint.clear();
            for v in views.clone() {
                for &(x, j) in &self.pending[v] {
                    let k = j * stride + x;
                    self.needed[k] += 1;
                    if self.needed[k] == all {
                        joint.push((x, j));
                    }
                }
            }
            self.trace_points(y, Tracing::Batch(b), &mut joint, trace);
            for v in views.clone() {
                let mut alone = std::mem::take(&mut self.alone);
                alone.clear();
                let needed = &self.needed;
                alone.extend(
                    self.pending[v]
                        .iter()
                        .filter(|&&(x, j)| needed[j * stride + x] < all),
                );
                self.trace_points(y, Tracing::View(v), &mut alone, trace);
                self.alone = alone;
            }
            for v in views {
                for &(x, j) in &self.pending[v] {
                    self.needed[j * stride + x] = 0;
                }
            }
            self.joint = joint;
        }
    }

    /// Traces `points` for `who`, a row of samples per lattice row and
    /// position within the pixel (one pattern each), into their views' values.
    fn trace_points(
        &mut self,
        y: usize,
        who: Tracing,
        points: &mut [(usize, usize)],
        trace: &mut dyn FnMut(Tracing, &SampleRow, &mut Vec<RowColors>),
    ) {
        let side = self.side;
        let first_view = match who {
            Tracing::Batch(b) => self.batches[b].start,
            Tracing::View(v) => v,
        };
        // By lattice row, then position in the pixel, then pixel.
        points.sort_unstable_by_key(|&(x, j)| (j, x % side, x / side));
        let mut start = 0;
        let mut colors = std::mem::take(&mut self.row_colors);
        while start < points.len() {
            let (x0, j) = points[start];
            let phase = x0 % side;
            let end = start
                + points[start..]
                    .iter()
                    .take_while(|&&(x, jj)| jj == j && x % side == phase)
                    .count();
            let pixels: Vec<i32> = points[start..end]
                .iter()
                .map(|&(x, _)| (x / side) as i32)
                .collect();
            // Exact in f32: the lattice steps are powers of two.
            let pattern = Pattern::Fixed {
                dx: phase as f32 / side as f32 - 0.5,
                y: (y as f32 - 0.5) + j as f32 / side as f32,
            };
            let row = SampleRow::new(pixels, pattern);
            trace(who, &row, &mut colors);
            for (i, &(x, j)) in points[start..end].iter().enumerate() {
                let k = self.index(x, j);
                for (view_colors, values) in colors.iter().zip(&mut self.values[first_view..]) {
                    values[k] = view_colors[i];
                }
            }
            start = end;
        }
        self.row_colors = colors;
    }

    /// Lattice points of view `view` known within pixel `x` (its border
    /// included).
    fn points_in_pixel(&self, view: usize, x: usize) -> u32 {
        let side = self.side;
        let mut n = 0;
        for j in 0..=side {
            for px in x * side..=(x + 1) * side {
                n += u32::from(self.known[view][self.index(px, j)]);
            }
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One vertical edge per view, at image column `edges[v]` (white to its
    /// right).
    fn shade(edges: &[f32], view: usize, column: f32) -> Color {
        if column >= edges[view] {
            Color::ONE
        } else {
            Color::ZERO
        }
    }

    /// Per view, its pixel rows.
    type Images = Vec<Vec<RowColors>>;

    /// Rows `rows` of views with edges at `edges` (in batches as the refiner
    /// was made), traced by a closure that records who was asked for how
    /// many samples.
    fn refine(
        rows: &[usize],
        edges: &[f32],
        refiner: &mut Refiner,
    ) -> (Images, Vec<(Tracing, usize)>) {
        let mut traced = Vec::new();
        let batches = refiner.batches.clone();
        let mut trace = |who: Tracing, row: &SampleRow, out: &mut Vec<RowColors>| {
            traced.push((who, row.len()));
            let views = match who {
                Tracing::Batch(b) => batches[b].clone(),
                Tracing::View(v) => v..v + 1,
            };
            out.resize_with(views.len(), Vec::new);
            for (o, v) in out.iter_mut().zip(views) {
                *o = (0..row.len())
                    .map(|i| shade(edges, v, row.camera_point(i, 0).0))
                    .collect();
            }
        };
        let mut images = vec![Vec::new(); edges.len()];
        for &y in rows {
            let mut out = vec![Vec::new(); edges.len()];
            refiner.refine_row(
                y,
                |v, x, _| shade(edges, v, x as f32 - 0.5),
                &mut trace,
                &mut out,
            );
            for (image, row) in images.iter_mut().zip(out) {
                image.push(row);
            }
        }
        (images, traced)
    }

    fn samples(traced: &[(Tracing, usize)], who: Tracing) -> usize {
        traced.iter().filter(|t| t.0 == who).map(|t| t.1).sum()
    }

    #[test]
    fn an_edge_is_refined_to_its_coverage_and_flat_pixels_are_not() {
        let mut refiner = Refiner::new(&[1], 6, 0.1, 16);
        let (rows, _) = refine(&[0], &[2.8], &mut refiner);
        let row = &rows[0][0];
        // Pixel 3 spans columns 2.5..3.5: the edge at 2.8 leaves 0.7 of it white;
        // on a 5 x 5 lattice (steps of 0.25) the trapezoid rule gives 0.625.
        assert_eq!(row[3].x, 0.625);
        assert_eq!(&row[..3], &[Color::ZERO; 3]);
        assert_eq!(&row[4..], &[Color::ONE; 2]);
    }

    #[test]
    fn consecutive_rows_trace_their_shared_edge_once() {
        let mut carried = Refiner::new(&[1], 6, 0.1, 16);
        let (a, with_carry) = refine(&[0, 1, 2], &[2.8], &mut carried);
        let with_carry = samples(&with_carry, Tracing::Batch(0));
        let mut traced_alone = 0;
        let mut b = Vec::new();
        for y in 0..3 {
            let mut fresh = Refiner::new(&[1], 6, 0.1, 16);
            let (rows, traced) = refine(&[y], &[2.8], &mut fresh);
            traced_alone += samples(&traced, Tracing::Batch(0));
            b.extend(rows.into_iter().flatten());
        }
        assert_eq!(a[0], b, "the same pixels");
        // The edge pixel's bottom edge gets 2 lattice points (its midpoint, and
        // the midpoint of the half the edge crosses), which a fresh refiner
        // traces again in each of the two rows below.
        assert_eq!(
            traced_alone - with_carry,
            2 * 2,
            "{with_carry} vs {traced_alone}"
        );
    }

    #[test]
    fn each_view_refines_its_own_edges_as_it_would_alone() {
        // A pair whose eyes see the edge in different pixels (3 and 5), and
        // in the same pixel (3): each view's pixels are those of the view
        // refined alone, and its points are traced for it alone unless the
        // other view needs them too.
        let alone = |edge: f32| {
            let mut refiner = Refiner::new(&[1], 8, 0.1, 16);
            let (rows, traced) = refine(&[0, 1], &[edge], &mut refiner);
            (rows.into_iter().next(), samples(&traced, Tracing::Batch(0)))
        };
        let (left, left_points) = alone(2.8);
        let (right, right_points) = alone(4.7);
        let mut pair = Refiner::new(&[2], 8, 0.1, 16);
        let (rows, traced) = refine(&[0, 1], &[2.8, 4.7], &mut pair);
        assert_eq!(Some(&rows[0]), left.as_ref());
        assert_eq!(Some(&rows[1]), right.as_ref());
        assert_eq!(samples(&traced, Tracing::Batch(0)), 0);
        assert_eq!(samples(&traced, Tracing::View(0)), left_points);
        assert_eq!(samples(&traced, Tracing::View(1)), right_points);

        // Edges in one pixel: the points both need go as the pair, once.
        let (near, near_points) = alone(2.9);
        let mut pair = Refiner::new(&[2], 8, 0.1, 16);
        let (rows, traced) = refine(&[0, 1], &[2.8, 2.9], &mut pair);
        assert_eq!(Some(&rows[0]), left.as_ref());
        assert_eq!(Some(&rows[1]), near.as_ref());
        let joint = samples(&traced, Tracing::Batch(0));
        assert!(joint > 0);
        assert_eq!(joint + samples(&traced, Tracing::View(0)), left_points);
        assert_eq!(joint + samples(&traced, Tracing::View(1)), near_points);
    }

    #[test]
    fn a_batch_of_one_view_traces_its_points_as_the_batch() {
        // Two batches of one view: every point is its batch's, none alone.
        let mut refiner = Refiner::new(&[1, 1], 8, 0.1, 16);
        let (_, traced) = refine(&[0], &[2.8, 4.7], &mut refiner);
        assert!(samples(&traced, Tracing::Batch(0)) > 0);
        assert!(samples(&traced, Tracing::Batch(1)) > 0);
        assert!(traced.iter().all(|t| matches!(t.0, Tracing::Batch(_))));
    }
}
