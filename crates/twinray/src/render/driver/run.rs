//! The sampling loops of a render: rows of samples traced by the view
//! method as tasks on the worker threads, then filtered into the views
//! (pixel centres, the SPD's corners, stratified samples on the film, the
//! adaptive refinement). A raised `CancelToken` stops every task at its
//! next row of samples.

use std::sync::atomic::{AtomicU64, Ordering};

use rayon::prelude::*;

use super::rows::{RowContext, RowTracers};
use super::views::{Sampled, ViewStorage, Views};
use crate::image::Image;
use crate::math::Color;
use crate::render::adaptive::{Refiner, RowRefinement, Tracing};
use crate::render::batch::RenderInputs;
use crate::render::counts::TraceCounts;
use crate::render::film::{self, Film, FilmBand};
use crate::render::sampler::{Filter, Pattern, RowColors, SampleRow};
use crate::render::tracer::Tracer;

/// Rows of pixels one task samples (`--samples N`, the adaptive sampling):
/// a fixed number, so that the film's sums do not depend on the thread
/// count; the adaptive refinement traces the edges its rows share once.
pub(super) const BAND_ROWS: usize = 8;

/// One render: the job, its view method, the image size and the progress.
pub(super) struct Run<'j, 'a> {
    pub job: &'j RenderInputs<'a>,
    pub tracers: &'j RowTracers<'a>,
    pub views: usize,
    pub width: usize,
    pub height: usize,
    /// The pixel rows rendered (a tile), of `height`.
    pub rows: std::ops::Range<usize>,
    pub done: AtomicU64,
    pub total: AtomicU64,
}

/// Who counts a task's progress: the task runner, one step per task, or the
/// task itself, a step per row of samples it traces ([`Run::step`]).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Steps {
    PerTask,
    ByTask,
}

impl Run<'_, '_> {
    /// Runs `task(context, tracer, i)` for `i` in `0..count`, in parallel, a
    /// fresh tracer per task (so that no task's caches depend on which thread
    /// ran what before); returns the results in order and the work counted,
    /// or `None` when the render was cancelled (a task that sees the token
    /// raised returns `None` itself).
    fn tasks<T: Send>(
        &self,
        count: usize,
        steps: Steps,
        task: impl Fn(&mut RowContext, &mut Tracer, usize) -> Option<T> + Sync,
    ) -> Option<(Vec<T>, TraceCounts)> {
        let items = vec![(); count];
        self.tasks_over(items, steps, |ctx, tracer, i, ()| task(ctx, tracer, i))
    }

    /// [`Run::tasks`], task `i` also given `items[i]` (its share of the
    /// output, written in place). The counts are summed as the tasks finish
    /// (sums of integers: the same in any order), not kept per task.
    fn tasks_over<I: Send, T: Send>(
        &self,
        items: Vec<I>,
        steps: Steps,
        task: impl Fn(&mut RowContext, &mut Tracer, usize, I) -> Option<T> + Sync,
    ) -> Option<(Vec<T>, TraceCounts)> {
        let world = self.job.world;
        let settings = self.job.opts.trace;
        let total = std::sync::Mutex::new(TraceCounts::default());
        let results: Vec<T> = items
            .into_par_iter()
            .enumerate()
            .map_init(
                || self.tracers.context(),
                |ctx, (i, item)| {
                    if self.cancelled() {
                        return None;
                    }
                    let mut tracer = Tracer::new(world, settings);
                    let result = task(ctx, &mut tracer, i, item)?;
                    if steps == Steps::PerTask {
                        self.step();
                    }
                    // A poisoned lock means a task panicked, and the panic goes on up.
                    *total.lock().unwrap_or_else(|e| e.into_inner()) += tracer.finish();
                    Some(result)
                },
            )
            .collect::<Option<_>>()?;
        let counts = total.into_inner().unwrap_or_else(|e| e.into_inner());
        Some((results, counts))
    }

    /// Whether the caller asked the render to stop.
    fn cancelled(&self) -> bool {
        self.job.cancel.is_cancelled()
    }

    /// Tells the progress how many steps the whole render has.
    fn plan(&self, steps: usize) {
        self.total.store(steps as u64, Ordering::Relaxed);
    }

    /// One step of the render done: the progress is told.
    fn step(&self) {
        let done = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        (self.job.progress)(done, self.total.load(Ordering::Relaxed));
    }

    /// Every row of a lattice of `columns` x `rows` samples at `pattern(row)`:
    /// per view, the colours row-major.
    fn lattice(
        &self,
        columns: usize,
        rows: usize,
        pattern: impl Fn(usize) -> Pattern + Sync,
    ) -> Option<(Vec<Vec<Color>>, TraceCounts)> {
        self.lattice_into(columns, rows, 1, pattern, |from, to| {
            to.copy_from_slice(from)
        })
    }

    /// [`Run::lattice`] kept as `T`s, `per_sample` of them a sample:
    /// `store(colours, out)` puts a row's colours of one view into its place.
    /// Each task writes its row straight into the grids (no row kept per
    /// task, no copy of the whole).
    fn lattice_into<T: Copy + Default + Send>(
        &self,
        columns: usize,
        rows: usize,
        per_sample: usize,
        pattern: impl Fn(usize) -> Pattern + Sync,
        store: impl Fn(&[Color], &mut [T]) + Sync,
    ) -> Option<(Vec<Vec<T>>, TraceCounts)> {
        let row_len = (columns * per_sample).max(1);
        // One allocation per view (not one view's grid cloned: a copy that
        // touched every page of every view before a row was traced; zeroed
        // bytes come from the allocator untouched).
        let mut grids: Vec<Vec<T>> = (0..self.views)
            .map(|_| vec![T::default(); columns * per_sample * rows])
            .collect();
        let mut shares: Vec<Vec<&mut [T]>> =
            (0..rows).map(|_| Vec::with_capacity(self.views)).collect();
        for grid in &mut grids {
            for (share, row) in shares.iter_mut().zip(grid.chunks_mut(row_len)) {
                share.push(row);
            }
        }
        let steps = Steps::PerTask;
        let (_, counts) = self.tasks_over(shares, steps, |ctx, tracer, j, mut share| {
            let row = SampleRow::full(columns, pattern(j));
            let mut colors = std::mem::take(&mut ctx.colors);
            ctx.trace(tracer, &row, &mut colors);
            for (to, from) in share.iter_mut().zip(&colors) {
                store(from, to);
            }
            ctx.colors = colors;
            Some(())
        })?;
        Some((grids, counts))
    }

    /// One ray through each pixel centre, the views kept as `storage` asks.
    pub fn centers(&self, storage: ViewStorage) -> Option<Sampled> {
        let (w, h, y0) = (self.width, self.rows.len(), self.rows.start);
        self.plan(h);
        let pattern = |j| Pattern::Fixed {
            dx: 0.0,
            y: (y0 + j) as f32,
        };
        let (views, counts) = match storage {
            ViewStorage::Float => {
                let (grids, counts) = self.lattice(w, h, pattern)?;
                (Views::Float(grids), counts)
            }
            ViewStorage::Rgb8(opts) => {
                // The writer's own quantisation, so the bytes are the file's.
                let (grids, counts) = self.lattice_into(w, h, 3, pattern, |from, to| {
                    crate::output::rgb8_into(from, to, &opts)
                })?;
                (Views::Rgb8(grids), counts)
            }
        };
        let (images, rgb8) = views.into_images(w, h);
        Some(Sampled {
            images,
            rgb8,
            counts,
            samples_per_view: (w * h) as u64,
            max_per_pixel: 1,
            refined: 0,
        })
    }

    /// The pixel corners, traced once each (every pixel row shares its edges).
    /// Those of the rows rendered, top edge to bottom edge.
    fn corner_lattice(&self) -> Option<(Vec<Vec<Color>>, TraceCounts)> {
        let y0 = self.rows.start;
        self.lattice(self.width + 1, self.rows.len() + 1, |j| Pattern::Fixed {
            dx: -0.5,
            y: (y0 + j) as f32 - 0.5,
        })
    }

    /// The SPD procedure: each pixel the mean of its four corners.
    pub fn corners(&self) -> Option<Sampled> {
        let (w, h) = (self.width, self.rows.len());
        self.plan(h + 1);
        let (grids, counts) = self.corner_lattice()?;
        let images = grids
            .iter()
            .map(|corners| {
                let mut img = Image::new(w as u32, h as u32);
                for y in 0..h {
                    for x in 0..w {
                        let s = |i: usize, j: usize| corners[j * (w + 1) + i];
                        let c = (s(x, y) + s(x + 1, y) + s(x, y + 1) + s(x + 1, y + 1)) * 0.25;
                        img.pixels[y * w + x] = c;
                    }
                }
                img
            })
            .collect();
        Some(Sampled {
            images,
            rgb8: Vec::new(),
            counts,
            samples_per_view: ((w + 1) * (h + 1)) as u64,
            max_per_pixel: 4,
            refined: 0,
        })
    }

    /// `samples` points of each pixel's sequence, filtered into the film.
    pub fn stratified(
        &self,
        samples: u32,
        filter: Filter,
        seed: u32,
        storage: ViewStorage,
    ) -> Option<Sampled> {
        let (w, h) = (self.width, self.height);
        // The bands whose samples reach the rows rendered, halo included.
        let halo = film::halo(filter);
        let first = self.rows.start.saturating_sub(halo) / BAND_ROWS;
        let end = (self.rows.end + halo).min(h).div_ceil(BAND_ROWS);
        let band_rows = |b: usize| b * BAND_ROWS..((b + 1) * BAND_ROWS).min(h);
        // A step per row of samples: a band of many samples is long.
        self.plan((band_rows(first).start..band_rows(end - 1).end).len() * samples as usize);
        let (bands, counts) = self.tasks(end - first, Steps::ByTask, |ctx, tracer, i| {
            let rows = band_rows(first + i);
            let mut band = FilmBand::new(self.views, (w, h), rows.clone(), filter);
            let mut colors = Vec::new();
            for y in rows {
                for index in 0..samples {
                    if self.cancelled() {
                        return None;
                    }
                    let pattern = Pattern::Sobol {
                        row: y as u32,
                        index,
                        seed,
                    };
                    let row = SampleRow::full(w, pattern);
                    ctx.trace(tracer, &row, &mut colors);
                    band.splat(filter, &row, &colors);
                    self.step();
                }
            }
            Some(band)
        })?;
        let mut film = Film::new(self.views, w, self.rows.clone());
        for band in &bands {
            film.add(band);
        }
        drop(bands);
        let (images, rgb8) = match storage {
            ViewStorage::Float => (film.images(), Vec::new()),
            ViewStorage::Rgb8(opts) => (Vec::new(), film.rgb8(&opts)),
        };
        Some(Sampled {
            images,
            rgb8,
            counts,
            samples_per_view: (w * self.rows.len()) as u64 * u64::from(samples),
            max_per_pixel: samples,
            refined: 0,
        })
    }

    /// Section 2.6: the corners, then each pixel row refined where its
    /// cells' corners differ, each view's by its own corners.
    pub fn adaptive(
        &self,
        threshold: f32,
        max_samples: u32,
        storage: ViewStorage,
    ) -> Option<Sampled> {
        let (w, h) = (self.width, self.rows.len());
        let (y0, y_end) = (self.rows.start, self.rows.end);
        // The rows start on a band's first row (render_rows checks it).
        let first_band = y0 / BAND_ROWS;
        let bands = y_end.div_ceil(BAND_ROWS) - first_band;
        self.plan(h + 1 + bands);
        let (corners, mut counts) = self.corner_lattice()?;
        let corner = |v: usize, x: usize, y: usize| corners[v][(y - y0) * (w + 1) + x];
        let groups = self.tracers.groups();
        let (bands, refine_counts) = self.tasks(bands, Steps::PerTask, |ctx, tracer, i| {
            let b = first_band + i;
            let mut refiner = Refiner::new(&groups, w, threshold, max_samples);
            // Once the render is cancelled, the rest of the row traces
            // nothing (its colours are dropped with it).
            let mut trace = |who: Tracing, row: &SampleRow, colors: &mut Vec<RowColors>| {
                if self.cancelled() {
                    let views = match who {
                        Tracing::Batch(g) => groups[g],
                        Tracing::View(_) => 1,
                    };
                    colors.resize_with(views, Vec::new);
                    colors
                        .iter_mut()
                        .for_each(|c| c.resize(row.len(), Color::ZERO));
                    return;
                }
                match who {
                    Tracing::Batch(g) => ctx.trace_group(g, tracer, row, colors),
                    Tracing::View(v) => ctx.trace_view(v, tracer, row, colors),
                }
            };
            (b * BAND_ROWS..((b + 1) * BAND_ROWS).min(y_end))
                .map(|y| {
                    let mut out = vec![Vec::new(); self.views];
                    let report = refiner.refine_row(
                        y,
                        |v, x, top| corner(v, x, if top { y } else { y + 1 }),
                        &mut trace,
                        &mut out,
                    );
                    // Kept as bytes, a row is a quarter of its colours.
                    (!self.cancelled()).then(|| (Views::of_row(out, storage), report))
                })
                .collect::<Option<Vec<_>>>()
        })?;
        drop(corners);
        counts += refine_counts;
        let mut views = Views::empty(storage, self.views, w * h);
        let mut total = RowRefinement::default();
        for (row, report) in bands.into_iter().flatten() {
            views.append(row);
            total.added += report.added;
            total.refined += report.refined;
            total.max_per_pixel = total.max_per_pixel.max(report.max_per_pixel);
        }
        let (images, rgb8) = views.into_images(w, h);
        // Each view refines its own pixels: the means over the views.
        let per_view = |n: u64| n / self.views.max(1) as u64;
        Some(Sampled {
            images,
            rgb8,
            counts,
            samples_per_view: ((w + 1) * (h + 1)) as u64 + per_view(total.added),
            max_per_pixel: total.max_per_pixel,
            refined: per_view(total.refined),
        })
    }
}
