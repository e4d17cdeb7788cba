//! Rendering the views of a rig.
//!
//! * `Method::Independent` — the paper's "traditional algorithm" and the
//!   reference: every view is a complete mono render of its own camera.
//! * `Method::Twin` — the paper's twin objects (sections 2–2.2): one eye ray per
//!   camera column returns the nearest hit of every view whose image holds
//!   that column, and flat-surface reflections and refractions of several views
//!   are traced again as one ray. The images equal the reference bit for bit.
//!
//! Both methods evaluate a grid of samples per view (pixel centres, or the
//! pixel corners of the SPD procedure) with the same ray arithmetic.

mod tracer;

pub use tracer::{TraceSettings, Tracer};

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use rayon::prelude::*;

use crate::bvh::Packet;
use crate::camera::Camera;
use crate::image::Image;
use crate::math::Color;
use crate::rig::Rig;
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
                        dir: camera.direction(column, row),
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

/// Twin objects: one packet per camera column and row, one lane per view that
/// has this column in its image.
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
    let total = grid.height as u64;
    let done = AtomicU64::new(0);
    let rows: Vec<(Vec<Vec<Color>>, TraceCounts)> = (0..grid.height)
        .into_par_iter()
        .map(|j| {
            let mut tracer = Tracer::new(world, opts.trace);
            let row = j as f32 + grid.offset;
            let mut out = vec![vec![Color::ZERO; grid.width]; n];
            for c in lo..=hi {
                let mut mask = 0u32;
                for (v, &s) in shifts.iter().enumerate() {
                    let i = c - s;
                    if i >= 0 && (i as usize) < grid.width {
                        mask |= 1 << v;
                    }
                }
                if mask == 0 {
                    continue; // a gap between views' images (shifts wider than the image)
                }
                let packet = Packet {
                    origins,
                    dir: camera.direction(c as f32 + grid.offset, row),
                    t_min: camera.hither,
                    t_max: [f32::INFINITY; K],
                    mask,
                };
                let colors = tracer.trace_eye(&packet, &view_of_lane);
                for (v, &s) in shifts.iter().enumerate() {
                    if mask & (1 << v) != 0 {
                        out[v][(c - s) as usize] = colors[v];
                    }
                }
            }
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
