//! What the driver asks of a view method: a row of samples traced for
//! every view. A method is a set of batches of consecutive views
//! ([`ViewBatch`]), each tracing its views with a worker per thread
//! ([`RowWorker`]).

use super::cancel::CancelToken;
use super::options::RenderOptions;
use super::sampler::{RowColors, SampleRow};
use super::tracer::Tracer;
use crate::rig::{Camera, Rig};
use crate::world::World;

/// What a view method is given: the scene, the camera and its views, the
/// options, and whom to tell of finished rows.
pub(super) struct RenderInputs<'a> {
    pub world: &'a World,
    pub camera: &'a Camera,
    pub rig: &'a Rig,
    pub opts: &'a RenderOptions,
    pub progress: &'a (dyn Fn(u64, u64) + Sync),
    pub cancel: &'a CancelToken,
}

/// Some consecutive views of the rig that a method traces together.
pub(super) trait ViewBatch: Sync {
    fn view_count(&self) -> usize;
    /// A worker for one thread (its scratch space is reused from row to row).
    fn worker(&self) -> Box<dyn RowWorker + '_>;
}

/// Traces rows of samples for the views of its batch.
pub(super) trait RowWorker {
    /// `out[v][i]`: the colour of the batch's view `v` through sample `i` of
    /// `row` (`out` has one entry per view of the batch, each `row.len()` long).
    fn trace(&mut self, tracer: &mut Tracer, row: &SampleRow, out: &mut [RowColors]);
}

/// Every batch's views of `row` traced by its worker, into `out` (rig order).
pub(super) fn trace_all(
    workers: &mut [(usize, Box<dyn RowWorker + '_>)],
    tracer: &mut Tracer,
    row: &SampleRow,
    out: &mut [RowColors],
) {
    let mut first = 0;
    for (n, worker) in workers.iter_mut() {
        worker.trace(tracer, row, &mut out[first..first + *n]);
        first += *n;
    }
}
