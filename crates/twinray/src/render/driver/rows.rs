//! One thread's share of a render: the view method's workers for every
//! view, and the fast method's epipolar rows where they take the row.

use std::time::Instant;

use crate::math::Color;
use crate::render::batch::{trace_all, RowWorker, ViewBatch};
use crate::render::fast::epipolar::{EpiScratch, EpipolarPass};
use crate::render::sampler::{RowColors, SampleRow};
use crate::render::tracer::Tracer;

/// A view method as the driver runs it: its batches of views, in rig order,
/// and the fast method's epipolar rows where they apply.
pub(super) struct RowTracers<'a> {
    pub batches: Vec<Box<dyn ViewBatch + 'a>>,
    pub epipolar: Option<EpipolarPass<'a>>,
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
            colors: Vec::new(),
            epipolar: self.epipolar.as_ref().map(|p| (p, EpiScratch::default())),
        }
    }
}

/// One thread's workers, one per batch: traces a row for every view.
pub(super) struct RowContext<'b> {
    workers: Vec<(usize, Box<dyn RowWorker + 'b>)>,
    /// A row's colours per view, reused from row to row (`Run::lattice`).
    pub colors: Vec<RowColors>,
    /// The epipolar rows (the workers are then one per view, in rig order).
    epipolar: Option<(&'b EpipolarPass<'b>, EpiScratch)>,
}

impl RowContext<'_> {
    /// `out[v][i]`: view `v`'s colour of sample `i` of `row`, every view.
    pub fn trace(&mut self, tracer: &mut Tracer, row: &SampleRow, out: &mut Vec<RowColors>) {
        let views: usize = self.workers.iter().map(|(n, _)| n).sum();
        out.resize_with(views, Vec::new);
        for o in out.iter_mut() {
            o.clear();
            o.resize(row.len(), Color::ZERO);
        }
        if let Some((pass, scratch)) = &mut self.epipolar {
            let start = Instant::now();
            pass.trace_row(&mut self.workers, tracer, row, scratch, out);
            tracer.counts.shading_pass_ns += start.elapsed().as_nanos() as u64;
            return;
        }
        trace_all(&mut self.workers, tracer, row, out);
    }
}
