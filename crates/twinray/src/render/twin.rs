//! The twin-object method (the paper's sections 2–2.2): one descent of the
//! hierarchy for every view's eye ray through a sample, then the views' samples
//! of one surface point shaded as one packet. See `render` below and
//! docs/stereo.md.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use super::{Grid, Job, Samples, Tracer};
use crate::bvh::{Packet, PacketHits};
use crate::camera::Camera;
use crate::math::{Color, Vec3};
use crate::rig::View;
use crate::shapes::SurfaceHit;
use crate::stats::TraceCounts;

/// The sample of `view`'s row nearest to where `point` projects in it, if any.
fn nearest_sample(camera: &Camera, grid: &Grid, view: &View, point: Vec3) -> Option<usize> {
    let (column, _) = camera.project(point, view.offset)?;
    // View v's sample k looks along camera column k + shift_v + grid offset.
    let k = (column - grid.offset as f64).round() - view.shift as f64;
    (k >= 0.0 && k < grid.width as f64).then_some(k as usize)
}

/// Twin objects, in two passes per row of samples:
///
/// 1. **Eye rays**: one packet per sample position `x`, lane `v` holding view
///    `v`'s ray through it (camera column `x + shift_v`) — the paper's one eye
///    ray through the twin objects, returning the nearest hit of every view.
/// 2. **Shading**: each sample of view 0 that hit something is grouped with the
///    sample of every other view that sees the same surface point (its hit
///    projected into that view, rounded to the nearest sample of the same row:
///    the rig's views differ along rows only), and the group is shaded as one
///    packet. Their shadow rays start from nearly one point toward one light and
///    their reflected rays from nearly one point, so the packet's lanes stay
///    together down the hierarchy. Every lane's rays are its own view's (the
///    grouping only decides which rays share a descent), so the images equal
///    the independent renders bit for bit. Samples left out are shaded alone.
pub(super) fn render<const K: usize>(job: &Job) -> Samples {
    let Job {
        world,
        camera,
        rig,
        opts,
        grid,
        progress,
    } = *job;
    let n = rig.views.len();
    let shifts: Vec<i32> = rig.views.iter().map(|v| v.shift).collect();
    let (lo, hi) = rig.column_range(grid.width as u32);
    let mut origins = [camera.eye; K];
    let mut view_of_lane = [0usize; K];
    for (v, view) in rig.views.iter().enumerate() {
        origins[v] = camera.eye_at(view.offset);
        view_of_lane[v] = v;
    }
    let width = grid.width;
    let none = SurfaceHit {
        t: f32::INFINITY,
        u: 0.0,
        v: 0.0,
    };
    let total = grid.height as u64;
    let done = AtomicU64::new(0);
    // A row's hits and bookkeeping, kept per worker thread from row to row.
    struct RowScratch<const K: usize> {
        dirs: Vec<Vec3>,
        hits: Vec<Vec<(u32, SurfaceHit)>>,
        shaded: Vec<Vec<bool>>,
    }
    let scratch = || RowScratch::<K> {
        dirs: Vec::with_capacity((hi - lo + 1) as usize),
        hits: vec![vec![(PacketHits::<K>::NO_HIT, none); width]; n],
        shaded: vec![vec![false; width]; n],
    };
    let rows: Vec<(Vec<Vec<Color>>, TraceCounts)> = (0..grid.height)
        .into_par_iter()
        .map_init(scratch, |scratch, j| {
            let mut tracer = Tracer::new(world, opts.trace);
            let row = j as f32 + grid.offset;
            let start = Instant::now();
            // Pass 1: the nearest hit of every view's sample, one descent for the
            // views' rays through the same sample position.
            let RowScratch { dirs, hits, shaded } = scratch;
            dirs.clear();
            dirs.extend((lo..=hi).map(|c| camera.direction(c as f32 + grid.offset, row)));
            let dir_of = |v: usize, i: usize| dirs[(i as i32 + shifts[v] - lo) as usize];
            let all = if n == 32 { u32::MAX } else { (1u32 << n) - 1 };
            for i in 0..width {
                let packet = Packet {
                    origins,
                    dirs: std::array::from_fn(|v| if v < n { dir_of(v, i) } else { Vec3::Z }),
                    t_min: camera.hither,
                    t_max: [f32::INFINITY; K],
                    mask: all,
                };
                let h = tracer.eye_hits(&packet, &view_of_lane);
                for (v, view_hits) in hits.iter_mut().enumerate() {
                    view_hits[i] = (h.prim[v], h.hit[v]);
                }
            }
            let eye_pass = start.elapsed();
            // Pass 2: group the samples that see one point, shade each group at once.
            let mut out = vec![vec![Color::ZERO; width]; n];
            for view in shaded.iter_mut() {
                view.fill(false);
            }
            let background = world.scene.background;
            let mut shade = |tracer: &mut Tracer, group: &[Option<usize>; K]| {
                // A sample that hit nothing is the background (what shading it gives).
                let missed = |(v, s): (usize, &Option<usize>)| {
                    s.is_none_or(|i| hits[v][i].0 == PacketHits::<K>::NO_HIT)
                };
                if group.iter().enumerate().all(missed) {
                    for (v, sample) in group.iter().enumerate() {
                        if let Some(i) = *sample {
                            out[v][i] = background;
                        }
                    }
                    return;
                }
                let mut packet = Packet {
                    origins,
                    dirs: [Vec3::Z; K],
                    t_min: camera.hither,
                    t_max: [f32::INFINITY; K],
                    mask: 0,
                };
                let mut lane_hits = PacketHits {
                    prim: [PacketHits::<K>::NO_HIT; K],
                    hit: [none; K],
                };
                for (v, sample) in group.iter().enumerate() {
                    if let Some(i) = *sample {
                        packet.mask |= 1 << v;
                        packet.dirs[v] = dir_of(v, i);
                        (lane_hits.prim[v], lane_hits.hit[v]) = hits[v][i];
                    }
                }
                let colors = tracer.shade_eye(&packet, &lane_hits);
                for (v, sample) in group.iter().enumerate() {
                    if let Some(i) = *sample {
                        out[v][i] = colors[v];
                    }
                }
            };
            for i in 0..width {
                let mut group = [None; K];
                group[0] = Some(i);
                let (prim, hit) = hits[0][i];
                if prim != PacketHits::<K>::NO_HIT {
                    let point = origins[0] + dir_of(0, i) * hit.t;
                    for (v, view) in rig.views.iter().enumerate().skip(1) {
                        let Some(k) = nearest_sample(camera, grid, view, point) else {
                            continue;
                        };
                        if !shaded[v][k] && hits[v][k].0 != PacketHits::<K>::NO_HIT {
                            shaded[v][k] = true;
                            group[v] = Some(k);
                        }
                    }
                }
                shade(&mut tracer, &group);
            }
            // Samples of the other views that no sample of view 0 claimed.
            for (v, claimed) in shaded.iter().enumerate().skip(1) {
                for (i, _) in claimed.iter().enumerate().filter(|(_, &c)| !c) {
                    let mut group = [None; K];
                    group[v] = Some(i);
                    shade(&mut tracer, &group);
                }
            }
            tracer.counts.eye_pass_ns += eye_pass.as_nanos() as u64;
            tracer.counts.shading_pass_ns += (start.elapsed() - eye_pass).as_nanos() as u64;
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
            (out, tracer.finish())
        })
        .collect();
    let mut grids = vec![Vec::with_capacity(grid.width * grid.height); n];
    let mut counts = TraceCounts::default();
    for (per_view, c) in rows {
        for (g, r) in grids.iter_mut().zip(per_view) {
            g.extend(r);
        }
        counts.add(&c);
    }
    (grids, counts)
}
