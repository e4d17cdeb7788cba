//! The twin-object method (the paper's sections 2–2.2), row by row in named
//! stages, each in a file of its own; and the paper's techniques of
//! sections 2.3–2.5, its options:
//!
//! The unit of work is a row of samples (`SampleRow`: one sub-pixel position
//! in each pixel of a row, the same in every view).
//!
//! 1. **Eye pass** (`eye_pass.rs`): one packet per sample, lane `v` holding view
//!    `v`'s ray through it (camera column `x + shift_v` plus the sample's offset) — the
//!    paper's one eye ray through the twin objects, returning the nearest hit
//!    of every view.
//! 2. **Grouping** (`grouping.rs`, `groups.rs`): each sample of view 0 that hit
//!    something is grouped with the sample of every other view that sees the
//!    same surface point (its hit projected into that view, rounded to the
//!    nearest sample of the same row: the rig's views differ along rows only).
//! 3. **Shading of groups** (`groups.rs`): a group is shaded in one packet,
//!    with its neighbours in the row up to eight lanes (`packed.rs`: a pair's
//!    four groups). Their shadow rays start from nearly one point toward one light
//!    and their reflected rays from nearly one point, so the packet's lanes
//!    stay together down the hierarchy. Every lane's rays are its own view's
//!    (the grouping only decides which rays share a descent), so the images
//!    equal the independent renders bit for bit.
//! 4. **Sharing** (approximate, only when asked, [`Sharing`]): the paper's
//!    merged secondary rays (section 2.4) inside the tracer
//!    (`tracer/merged_rays.rs`); its reprojection (section 2.5) in
//!    `reprojection.rs`, safe or as published; the fast method's shading
//!    cache (`fast/shared_shading.rs`). With a cut of the object tree
//!    (section 2.3), what lies beyond it is traced once per camera column
//!    (`cut.rs`).
//!
//! A batch of one view with nothing to share is a mono row (`mono.rs`).

pub(in crate::render) mod batch;
pub(super) mod counts;
mod cut;
mod eye_pass;
pub(in crate::render) mod grouping;
mod groups;
mod kept;
pub(in crate::render) mod lanes;
mod mono;
pub(in crate::render) mod packed;
mod reprojection;
#[cfg(test)]
mod tests;

pub(in crate::render) use batch::{Shading, Sharing};

use std::time::Instant;

use crate::render::batch::{RenderInputs, RowWorker, ViewBatch};
use crate::render::options::MAX_LANES;
use crate::render::sampler::{RowColors, SampleRow};
use crate::render::tracer::Tracer;
use crate::rig::Rig;
use batch::{RowScratch, TwinBatch};

/// The views of the rig in batches of `size` neighbours, each traced by the
/// twin method as packets of its own (its first view leads its groups),
/// sharing their shading as `shading` says.
pub(in crate::render) fn batches<'a>(
    job: &RenderInputs<'a>,
    size: usize,
    shading: Shading,
) -> crate::Result<Vec<Box<dyn ViewBatch + 'a>>> {
    let mut batches: Vec<Box<dyn ViewBatch + 'a>> = Vec::new();
    for (b, views) in job.rig.views.chunks(size.max(1)).enumerate() {
        let rig = Rig {
            views: views.to_vec(),
            ..job.rig.clone()
        };
        let (first, s) = (b * size, shading);
        batches.push(match views.len() {
            1 => Box::new(TwinBatch::<1>::new(job, rig, first, s)),
            2 => Box::new(TwinBatch::<2>::new(job, rig, first, s)),
            3..=4 => Box::new(TwinBatch::<4>::new(job, rig, first, s)),
            5..=8 => Box::new(TwinBatch::<8>::new(job, rig, first, s)),
            9..=16 => Box::new(TwinBatch::<16>::new(job, rig, first, s)),
            17..=MAX_LANES => Box::new(TwinBatch::<32>::new(job, rig, first, s)),
            n => {
                return Err(crate::Error::Invalid(format!(
                    "{n} views in one packet: at most {MAX_LANES}"
                )))
            }
        });
    }
    Ok(batches)
}

impl<const K: usize> TwinBatch<'_, K> {
    /// Every stage for one row of samples: `out[v][i]` is view `v`'s colour
    /// of sample `i`.
    pub(in crate::render) fn trace_row(
        &self,
        tracer: &mut Tracer,
        row: &SampleRow,
        scratch: &mut RowScratch<K>,
        out: &mut [RowColors],
    ) {
        if self.is_mono() {
            return self.trace_mono_row(tracer, row, scratch, out);
        }
        let start = Instant::now();
        let forward = matches!(self.shading.sharing, Sharing::ReprojectForward { .. });
        if !forward {
            self.eye_pass(tracer, row, scratch);
        }
        let eye_pass = start.elapsed();
        self.shade_cut(tracer, row, scratch, out);
        match self.shading.sharing {
            Sharing::Exact => {
                self.group(row, scratch);
                self.shade_groups(tracer, scratch, out);
            }
            Sharing::Reproject { threshold } => {
                self.share_row(tracer, row, scratch, threshold, out)
            }
            Sharing::ReprojectForward { threshold } => {
                self.reproject_forward(tracer, row, scratch, threshold, out)
            }
            Sharing::Cache { tolerance } => {
                self.group(row, scratch);
                self.share_shading(tracer, row, scratch, tolerance, out);
            }
        }
        tracer.counts.eye_pass_ns += eye_pass.as_nanos() as u64;
        tracer.counts.shading_pass_ns += (start.elapsed() - eye_pass).as_nanos() as u64;
    }
}

/// The twin method's worker: a twin batch and its scratch space.
struct TwinWorker<'s, 'a, const K: usize> {
    batch: &'s TwinBatch<'a, K>,
    scratch: RowScratch<K>,
}

impl<const K: usize> RowWorker for TwinWorker<'_, '_, K> {
    fn trace(&mut self, tracer: &mut Tracer, row: &SampleRow, out: &mut [RowColors]) {
        self.batch.trace_row(tracer, row, &mut self.scratch, out);
    }
}

impl<const K: usize> ViewBatch for TwinBatch<'_, K> {
    fn view_count(&self) -> usize {
        self.views
    }

    fn worker(&self) -> Box<dyn RowWorker + '_> {
        Box::new(TwinWorker {
            batch: self,
            scratch: RowScratch::<K>::default(),
        })
    }
}
