//! The reference method, the paper's "traditional algorithm": every view a
//! complete mono render of its own camera, its rays traced one at a time.

use super::batch::{RenderInputs, RowWorker, ViewBatch};
use super::sampler::{RowColors, SampleRow};
use super::tracer::Tracer;
use crate::bvh::Packet;
use crate::math::Color;
use crate::rig::Camera;
use crate::rig::View;

/// Views of the rig from `first_view` on, each traced on its own.
pub(in crate::render) struct Independent<'a> {
    camera: &'a Camera,
    views: Vec<View>,
    first_view: usize,
}

impl<'a> Independent<'a> {
    /// Every view of the rig.
    pub(in crate::render) fn new(job: &RenderInputs<'a>) -> Independent<'a> {
        Independent {
            camera: job.camera,
            views: job.rig.views.clone(),
            first_view: 0,
        }
    }

    /// View `view` of the rig alone.
    pub(in crate::render) fn solo(job: &RenderInputs<'a>, view: usize) -> Independent<'a> {
        Independent {
            camera: job.camera,
            views: vec![job.rig.views[view]],
            first_view: view,
        }
    }
}

impl ViewBatch for Independent<'_> {
    fn view_count(&self) -> usize {
        self.views.len()
    }

    fn worker(&self) -> Box<dyn RowWorker + '_> {
        Box::new(IndependentWorker { batch: self })
    }
}

struct IndependentWorker<'s, 'a> {
    batch: &'s Independent<'a>,
}

impl RowWorker for IndependentWorker<'_, '_> {
    /// View by view, one ray (a packet of one lane) per sample.
    fn trace(&mut self, tracer: &mut Tracer, row: &SampleRow, out: &mut [RowColors]) {
        let camera = self.batch.camera;
        for (v, (view, view_out)) in self.batch.views.iter().zip(out).enumerate() {
            for (i, sample_out) in view_out.iter_mut().enumerate() {
                let (column, y) = row.camera_point(i, view.shift);
                // No ray (outside a fisheye panorama's circle): black.
                let Some((origin, dir)) = camera.view_ray(view.offset, column, y) else {
                    *sample_out = Color::ZERO;
                    continue;
                };
                let packet = Packet {
                    origins: [origin],
                    dirs: [dir],
                    t_min: camera.hither,
                    t_max: [f32::INFINITY],
                    mask: 1,
                };
                *sample_out = tracer.trace_eye(&packet, &[self.batch.first_view + v])[0];
            }
        }
    }
}
