//! One thread's share of a render: the view method's workers for every
//! view, and the fast method's epipolar rows where they take the row.

use std::time::Instant;

use crate::math::Color;
use crate::render::batch::{trace_all, RowWorker, ViewBatch};
use crate::render::fast::epipolar::{EpiScratch, EpipolarPass};
use crate::render::sampler::{RowColors, SampleRow};
use crate::render::tracer::Tracer;

/// A view method as the driver runs it: its batches of views, in rig order,
/// the fast method's epipolar rows where they apply, and, for the adaptive
/// refinement of several views, each view as a batch of its own (else
/// empty).
pub(super) struct RowTracers<'a> {
    pub batches: Vec<Box<dyn ViewBatch + 'a>>,
    pub epipolar: Option<EpipolarPass<'a>>,
    pub solo: Vec<Box<dyn ViewBatch + 'a>>,
}

impl RowTracers<'_> {
    /// One thread's workers (and epipolar scratch space).
    pub fn context(&self) -> RowContext<'_> {
        RowContext {
            workers: self
                .batches
                .iter()
                .map(|b| (b.view_count(), b.worker()))
                .collect(),
            solo: self.solo.iter().map(|b| b.worker()).collect(),
            colors: Vec::new(),
            epipolar: self.epipolar.as_ref().map(|p| (p, EpiScratch::default())),
        }
    }

    /// The views the adaptive refinement traces together, as counts of
    /// consecutive views: the batches, or every view where the epipolar
    /// rows take a row of all of them.
    pub fn groups(&self) -> Vec<usize> {
        match self.epipolar {
            Some(_) => vec![self.batches.iter().map(|b| b.view_count()).sum()],
            None => self.batches.iter().map(|b| b.view_count()).collect(),
        }
    }
}

/// One thread's workers, one per batch: traces a row for every view.
pub(super) struct RowContext<'b> {
    workers: Vec<(usize, Box<dyn RowWorker + 'b>)>,
    /// Per view, a worker that traces it alone (see [`RowTracers::solo`]).
    solo: Vec<Box<dyn RowWorker + 'b>>,
    /// A row's colours per view, reused from row to row (`Run::lattice`).
    pub colors: Vec<RowColors>,
    /// The epipolar rows (the workers are then one per view, in rig order).
    epipolar: Option<(&'b EpipolarPass<'b>, EpiScratch)>,
}

/// Sizes `out` to `views` rows of `len` black samples.
fn clear(out: &mut Vec<RowColors>, views: usize, len: usize) {
    out.resize_with(views, Vec::new);
    for o in out.iter_mut() {
        o.clear();
        o.resize(len, Color::ZERO);
    }
}

impl RowContext<'_> {
    /// `out[v][i]`: view `v`'s colour of sample `i` of `row`, every view.
    pub fn trace(&mut self, tracer: &mut Tracer, row: &SampleRow, out: &mut Vec<RowColors>) {
        let views: usize = self.workers.iter().map(|(n, _)| n).sum();
        clear(out, views, row.len());
        if let Some((pass, scratch)) = &mut self.epipolar {
            let start = Instant::now();
            pass.trace_row(&mut self.workers, tracer, row, scratch, out);
            tracer.counts.shading_pass_ns += start.elapsed().as_nanos() as u64;
            return;
        }
        trace_all(&mut self.workers, tracer, row, out);
    }

    /// [`RowContext::trace`] for the views of group `group` of
    /// [`RowTracers::groups`] only: `out[v]` is the group's view `v`.
    pub fn trace_group(
        &mut self,
        group: usize,
        tracer: &mut Tracer,
        row: &SampleRow,
        out: &mut Vec<RowColors>,
    ) {
        if self.epipolar.is_some() {
            return self.trace(tracer, row, out);
        }
        let (views, worker) = &mut self.workers[group];
        clear(out, *views, row.len());
        worker.trace(tracer, row, out);
    }

    /// View `view` of `row` alone, into `out[0]`, by its one-view batch
    /// (which the adaptive refinement of several views has).
    pub fn trace_view(
        &mut self,
        view: usize,
        tracer: &mut Tracer,
        row: &SampleRow,
        out: &mut Vec<RowColors>,
    ) {
        clear(out, 1, row.len());
        self.solo[view].trace(tracer, row, out);
    }
}
