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
//! The paper's approximations (sections 2.4, 2.5) are options of the twin
//! method (`Approximations`); without them its images are exact.
//!
//! Both methods evaluate a grid of samples per view (pixel centres, or the
//! pixel corners of the SPD procedure) with the same ray arithmetic.

mod grouping;
mod independent;
mod tracer;
mod twin;

pub use tracer::{Donor, TraceSettings, Tracer};

use std::time::Instant;

use crate::camera::Camera;
use crate::image::Image;
use crate::math::Color;
use crate::rig::Rig;
use crate::stats::TraceCounts;
use crate::world::World;

/// Most views one packet carries (one bit per view in the lane mask).
pub const MAX_VIEWS: usize = 32;

/// Deepest ray level accepted (`TraceSettings::max_depth`). The tracer recurses
/// once per level; with 32 views a closed box of mirrors overflowed a 2 MiB
/// worker stack from about level 180 (measured, see docs/reliability.md), so 64
/// leaves room. Past a handful of bounces the contribution is invisible anyway.
pub const MAX_DEPTH: u32 = 64;

impl TraceSettings {
    /// Refuses settings the tracer cannot honour: a depth outside `1..=MAX_DEPTH`,
    /// a cut-off weight that is not a finite number >= 0.
    pub fn validate(&self) -> crate::Result<()> {
        if !(1..=MAX_DEPTH).contains(&self.max_depth) {
            return Err(crate::Error::Invalid(format!(
                "the ray depth must be between 1 (eye rays only) and {MAX_DEPTH}, got {}",
                self.max_depth
            )));
        }
        if !(self.min_weight.is_finite() && self.min_weight >= 0.0) {
            return Err(crate::Error::Invalid(format!(
                "the cut-off weight must be a finite number >= 0, got {}",
                self.min_weight
            )));
        }
        Ok(())
    }
}

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

/// How the paper's reprojection (section 2.5) decides that a view's sample may
/// take another view's shading.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReprojectMode {
    /// Only where the receiving sample's own nearest hit (from the eye pass)
    /// is the same surface point, within a pixel's footprint: no ghost, no hole.
    /// It takes the light visibility and secondary colour; its ambient,
    /// diffuse and highlight terms are its own.
    Safe,
    /// Eq. 2.1 as published: view 0's colour goes where its hit projects in
    /// the other views, the nearest wins, samples that receive nothing are traced.
    Paper,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reprojection {
    pub mode: ReprojectMode,
    /// Largest specular (`ks`) or transmission (`t`) coefficient a surface of
    /// a shading tree may have for its shading to be reprojected.
    pub threshold: f32,
}

impl Reprojection {
    /// The default threshold: surfaces whose mirror and transmission weights
    /// are at most this are treated as diffuse (see docs/stereo.md for the
    /// error it gives on the SPD scenes).
    pub const DEFAULT_THRESHOLD: f32 = 0.1;
}

/// The paper's speed-for-quality trade-offs (twin method only). The default,
/// none, gives exact images.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Approximations {
    /// Section 2.4: the views' reflected (refracted) rays from one planar
    /// surface merged into one ray from the midpoint.
    pub merge_secondary: bool,
    /// Section 2.5: shading reprojected from view 0 to the other views.
    pub reproject: Option<Reprojection>,
}

impl Approximations {
    pub fn is_exact(&self) -> bool {
        *self == Approximations::default()
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    pub trace: TraceSettings,
    pub method: Method,
    pub sampling: Sampling,
    pub approx: Approximations,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            trace: TraceSettings::default(),
            method: Method::Independent,
            sampling: Sampling::Centers,
            approx: Approximations::default(),
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
    opts.trace.validate()?;
    let views = rig.views.len();
    if views == 0 || views > MAX_VIEWS {
        return Err(crate::Error::Invalid(format!(
            "{views} views: twinray renders 1 to {MAX_VIEWS} views at once"
        )));
    }
    if opts.method == Method::Independent && !opts.approx.is_exact() {
        return Err(crate::Error::Invalid(
            "the approximations (merged secondary rays, reprojection) need the twin method".into(),
        ));
    }
    if let Some(r) = opts.approx.reproject {
        if !(r.threshold >= 0.0 && r.threshold.is_finite()) {
            return Err(crate::Error::Invalid(format!(
                "reprojection threshold {}: a coefficient >= 0 is needed",
                r.threshold
            )));
        }
    }
    if world.far.is_some()
        && matches!(opts.approx.reproject, Some(r) if r.mode == ReprojectMode::Paper)
    {
        return Err(crate::Error::Invalid(
            "the paper's reprojection mode does not combine with a cut of the object tree".into(),
        ));
    }
    let start = Instant::now();
    let grid = Grid::for_camera(camera, opts.sampling);
    let job = Job {
        world,
        camera,
        rig,
        opts,
        grid: &grid,
        progress,
    };
    let (grids, counts) = match opts.method {
        Method::Independent => independent::render(&job),
        Method::Twin => match views {
            1 => twin::render::<1>(&job),
            2 => twin::render::<2>(&job),
            3..=4 => twin::render::<4>(&job),
            5..=8 => twin::render::<8>(&job),
            9..=16 => twin::render::<16>(&job),
            _ => twin::render::<32>(&job),
        },
    };
    let images = grids.into_iter().map(|g| grid.resolve(g, camera)).collect();
    Ok(RenderOutput {
        images,
        counts,
        seconds: start.elapsed().as_secs_f64(),
        samples_per_view: (grid.width * grid.height) as u64,
    })
}

/// What a rendering method is given: the scene, the camera and its views, the
/// options, the sample grid, and whom to tell of finished rows.
struct Job<'a> {
    world: &'a World,
    camera: &'a Camera,
    rig: &'a Rig,
    opts: &'a RenderOptions,
    grid: &'a Grid,
    progress: &'a (dyn Fn(u64, u64) + Sync),
}

/// Per-view samples (row-major, one `Vec` per view) and the work counted.
type Samples = (Vec<Vec<Color>>, TraceCounts);

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

    /// Turns one view's samples into its image (pixel centres: the samples
    /// themselves, not copied, which keeps the peak memory down).
    fn resolve(&self, samples: Vec<Color>, camera: &Camera) -> Image {
        let (w, h) = (camera.width, camera.height);
        if self.offset == 0.0 {
            return Image {
                width: w,
                height: h,
                pixels: samples,
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
