//! The reference method, the paper's "traditional algorithm": every view a
//! complete mono render of its own camera.

use std::sync::atomic::{AtomicU64, Ordering};

use rayon::prelude::*;

use super::{Job, Samples, Tracer};
use crate::bvh::Packet;
use crate::math::Color;
use crate::stats::TraceCounts;

/// Every view a complete mono render: rays one at a time (packets of one lane).
pub(super) fn render(job: &Job) -> Samples {
    let Job {
        world,
        camera,
        rig,
        opts,
        grid,
        progress,
    } = *job;
    let total = (rig.views.len() * grid.height) as u64;
    let done = AtomicU64::new(0);
    let mut grids = Vec::with_capacity(rig.views.len());
    let mut counts = TraceCounts::default();
    for (v, view) in rig.views.iter().enumerate() {
        let rows: Vec<(Vec<Color>, TraceCounts)> = (0..grid.height)
            .into_par_iter()
            .map(|j| {
                let mut tracer = Tracer::new(world, opts.trace);
                let origin = camera.eye_at(view.offset);
                let row = j as f32 + grid.offset;
                let mut out = Vec::with_capacity(grid.width);
                for i in 0..grid.width {
                    let column = (i as i32 + view.shift) as f32 + grid.offset;
                    let packet = Packet {
                        origins: [origin],
                        dirs: [camera.direction(column, row)],
                        t_min: camera.hither,
                        t_max: [f32::INFINITY],
                        mask: 1,
                    };
                    out.push(tracer.trace_eye(&packet, &[v])[0]);
                }
                progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
                (out, tracer.finish())
            })
            .collect();
        let mut samples = Vec::with_capacity(grid.width * grid.height);
        for (row, c) in rows {
            samples.extend(row);
            counts.add(&c);
        }
        grids.push(samples);
    }
    (grids, counts)
}
