//! Rendering the views of a rig.
//!
//! * `Method::Independent` — the paper's "traditional algorithm" and the
//!   reference: every view is a complete mono render of its own camera.
//! * `Method::Twin` — the paper's twin objects (sections 2–2.2): one descent of
//!   the hierarchy returns the nearest hit of every view's eye ray through a
//!   sample; then the views' samples that see one surface point are shaded as
//!   one packet, whose shadow, reflected and refracted rays share their
//!   descents. The images equal the reference bit for bit.
//!
//! Both methods evaluate a grid of samples per view (pixel centres, or the
//! pixel corners of the SPD procedure) with the same ray arithmetic.

mod tracer;

pub use tracer::{TraceSettings, Tracer};

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use crate::bvh::{Packet, PacketHits};
use crate::camera::Camera;
use crate::image::Image;
use crate::math::{Color, Vec3};
use crate::rig::{Rig, View};
use crate::shapes::SurfaceHit;
use crate::stats::TraceCounts;
use crate::world::World;

/// Most views one packet carries (one bit per view in the lane mask).
pub const MAX_VIEWS: usize = 32;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    Independent,
    Twin,
}

impl Method {
    pub fn name(&self) -> &'static str {
        match self {
            Method::Independent => "independent",
            Method::Twin => "twin",
        }
    }
}

/// Where a pixel's rays go.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sampling {
    /// One ray through each pixel centre.
    Centers,
    /// SPD procedure: rays through the (W+1)×(H+1) pixel corners, each pixel
    /// the mean of its four corners.
    Corners,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    pub trace: TraceSettings,
    pub method: Method,
    pub sampling: Sampling,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            trace: TraceSettings::default(),
            method: Method::Independent,
            sampling: Sampling::Centers,
        }
    }
}

pub struct RenderOutput {
    /// One image per view of the rig, in rig order.
    pub images: Vec<Image>,
    pub counts: TraceCounts,
    pub seconds: f64,
    /// Samples (eye rays) per view.
    pub samples_per_view: u64,
}

/// Renders every view of `rig`. `progress(done, total)` is called from worker
/// threads as sample rows complete.
pub fn render(
    world: &World,
    camera: &Camera,
    rig: &Rig,
    opts: &RenderOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> crate::Result<RenderOutput> {
    let views = rig.views.len();
    if views == 0 || views > MAX_VIEWS {
        return Err(crate::Error::Invalid(format!(
            "{views} views: twinray renders 1 to {MAX_VIEWS} views at once"
        )));
    }
    let start = Instant::now();
    let grid = Grid::for_camera(camera, opts.sampling);
    let (grids, counts) = match opts.method {
        Method::Independent => render_independent(world, camera, rig, opts, &grid, progress),
        Method::Twin => match views {
            1 => render_twin::<1>(world, camera, rig, opts, &grid, progress),
            2 => render_twin::<2>(world, camera, rig, opts, &grid, progress),
            3..=4 => render_twin::<4>(world, camera, rig, opts, &grid, progress),
            5..=8 => render_twin::<8>(world, camera, rig, opts, &grid, progress),
            9..=16 => render_twin::<16>(world, camera, rig, opts, &grid, progress),
            _ => render_twin::<32>(world, camera, rig, opts, &grid, progress),
        },
    };
    let images = grids.iter().map(|g| grid.resolve(g, camera)).collect();
    Ok(RenderOutput {
        images,
        counts,
        seconds: start.elapsed().as_secs_f64(),
        samples_per_view: (grid.width * grid.height) as u64,
    })
}

/// The sample positions of one view, in pixel units of its image.
struct Grid {
    width: usize,
    height: usize,
    /// Added to the integer sample index: 0 for centres, -0.5 for corners.
    offset: f32,
}

impl Grid {
    fn for_camera(camera: &Camera, sampling: Sampling) -> Grid {
        let (w, h) = (camera.width as usize, camera.height as usize);
        match sampling {
            Sampling::Centers => Grid {
                width: w,
                height: h,
                offset: 0.0,
            },
            Sampling::Corners => Grid {
                width: w + 1,
                height: h + 1,
                offset: -0.5,
            },
        }
    }

    /// Turns one view's samples into its image.
    fn resolve(&self, samples: &[Color], camera: &Camera) -> Image {
        let (w, h) = (camera.width, camera.height);
        if self.offset == 0.0 {
            return Image {
                width: w,
                height: h,
                pixels: samples.to_vec(),
            };
        }
        let mut img = Image::new(w, h);
        for y in 0..h as usize {
            for x in 0..w as usize {
                let s = |i: usize, j: usize| samples[j * self.width + i];
                let c = (s(x, y) + s(x + 1, y) + s(x, y + 1) + s(x + 1, y + 1)) * 0.25;
                img.pixels[y * w as usize + x] = c;
            }
        }
        img
    }
}

/// Every view a complete mono render: rays one at a time (packets of one lane).
fn render_independent(
    world: &World,
    camera: &Camera,
    rig: &Rig,
    opts: &RenderOptions,
    grid: &Grid,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> (Vec<Vec<Color>>, TraceCounts) {
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
fn render_twin<const K: usize>(
    world: &World,
    camera: &Camera,
    rig: &Rig,
    opts: &RenderOptions,
    grid: &Grid,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> (Vec<Vec<Color>>, TraceCounts) {
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
