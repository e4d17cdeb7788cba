//! The render driver: checks what it is asked, sets up the view method
//! (its batches of views, the fast method's stages), and runs the sampling
//! loops (`run`) over bands and rows of samples on the worker threads,
//! keeping the views as the caller asks (`views`).

mod rows;
mod run;
mod views;

pub use views::{RenderOutput, ViewStorage};

use std::sync::atomic::AtomicU64;
use std::time::Instant;

use rows::RowTracers;
use run::{Run, BAND_ROWS};

use crate::render::batch::{RenderInputs, ViewBatch};
use crate::render::cancel::CancelToken;
use crate::render::fast::epipolar::EpipolarPass;
use crate::render::fast::{self, SceneTraits};
use crate::render::independent::Independent;
use crate::render::options::{PaperTechniques, RenderOptions, ViewMethod};
use crate::render::panorama::{self, PanoramaTwin};
use crate::render::sampler::Sampling;
use crate::render::twin::{self, Shading};
use crate::rig::{Camera, Rig};
use crate::world::World;

/// Renders every view of `rig`. `progress(done, total)` is called from worker
/// threads as rows of samples complete.
pub fn render(
    world: &World,
    camera: &Camera,
    rig: &Rig,
    opts: &RenderOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> crate::Result<RenderOutput> {
    render_cancellable(world, camera, rig, opts, progress, &CancelToken::new())
}

/// [`render`], stopping early with [`Error::Cancelled`](crate::Error::Cancelled)
/// once `cancel` is raised: no row of samples starts after that.
pub fn render_cancellable(
    world: &World,
    camera: &Camera,
    rig: &Rig,
    opts: &RenderOptions,
    progress: &(dyn Fn(u64, u64) + Sync),
    cancel: &CancelToken,
) -> crate::Result<RenderOutput> {
    let rows = 0..camera.height;
    render_rows(world, camera, rig, opts, rows, progress, cancel)
}

/// [`render_rows_as`] with the views in floats ([`ViewStorage::Float`]).
#[allow(clippy::too_many_arguments)]
pub fn render_rows(
    world: &World,
    camera: &Camera,
    rig: &Rig,
    opts: &RenderOptions,
    rows: std::ops::Range<u32>,
    progress: &(dyn Fn(u64, u64) + Sync),
    cancel: &CancelToken,
) -> crate::Result<RenderOutput> {
    let storage = ViewStorage::Float;
    render_rows_as(world, camera, rig, opts, rows, storage, progress, cancel)
}

/// Rows from which a band of the image may start or end: the bands of
/// samples the film and the adaptive refinement are made of (see
/// [`render_rows`]).
pub const TILE_ROW_ALIGNMENT: u32 = BAND_ROWS as u32;

/// Pixel rows `rows` of every view (a tile of the image: one machine's
/// share), each pixel bit for bit as [`render_cancellable`] makes it: the
/// samples are those of the whole image, with the halo of bands a filter
/// reaches across the tile's edges. `rows` must start at a multiple of
/// [`TILE_ROW_ALIGNMENT`] and end at one or at the image's height. The views
/// come back as `storage` asks (see [`ViewStorage`]).
#[allow(clippy::too_many_arguments)]
pub fn render_rows_as(
    world: &World,
    camera: &Camera,
    rig: &Rig,
    opts: &RenderOptions,
    rows: std::ops::Range<u32>,
    storage: ViewStorage,
    progress: &(dyn Fn(u64, u64) + Sync),
    cancel: &CancelToken,
) -> crate::Result<RenderOutput> {
    check_rows(&rows, camera.height)?;
    let views = rig.views.len();
    opts.validate(views, world.far.is_some())?;
    let start = Instant::now();
    let job = RenderInputs {
        world,
        camera,
        rig,
        opts,
        progress,
        cancel,
    };
    let tracers = row_tracers(&job)?;
    let run = Run {
        job: &job,
        tracers: &tracers,
        views,
        width: camera.width as usize,
        height: camera.height as usize,
        rows: rows.start as usize..rows.end as usize,
        done: AtomicU64::new(0),
        total: AtomicU64::new(0),
    };
    let sampled = match opts.sampling {
        Sampling::Centers => run.centers(storage),
        Sampling::Corners => run.corners(),
        Sampling::Stratified {
            samples,
            filter,
            seed,
        } => run.stratified(samples, filter, seed, storage),
        Sampling::Adaptive {
            threshold,
            max_samples,
        } => run.adaptive(threshold, max_samples, storage),
    }
    .ok_or(crate::Error::Cancelled)?;
    Ok(RenderOutput {
        images: sampled.images,
        rgb8: sampled.rgb8,
        counts: sampled.counts,
        seconds: start.elapsed().as_secs_f64(),
        samples_per_view: sampled.samples_per_view,
        max_samples_per_pixel: sampled.max_per_pixel,
        refined_pixels: sampled.refined,
    })
}

/// Refuses rows that are not a band of the image (see [`render_rows_as`]).
fn check_rows(rows: &std::ops::Range<u32>, height: u32) -> crate::Result<()> {
    let aligned = |r: u32| r.is_multiple_of(TILE_ROW_ALIGNMENT);
    if rows.start >= rows.end
        || rows.end > height
        || !aligned(rows.start)
        || !(aligned(rows.end) || rows.end == height)
    {
        return Err(crate::Error::Invalid(format!(
            "rows {}..{} of a {height}-row image: a band starts at a multiple of {TILE_ROW_ALIGNMENT} and ends at one or at the last row",
            rows.start, rows.end
        )));
    }
    Ok(())
}

/// The view method of `job`, as the driver runs it: the reference's one
/// batch of every view; the twin method's batches of neighbouring views;
/// the fast method's stages (`fast::stages`): its epipolar rows, whose
/// views each trace alone the rows they cannot take, or batches sharing
/// the shading cache. Under adaptive sampling, also each view as a batch
/// of its own, exact, for the points only some views refine.
fn row_tracers<'a>(job: &RenderInputs<'a>) -> crate::Result<RowTracers<'a>> {
    let views = job.rig.views.len();
    let per_batch = job.opts.views_per_batch(views);
    if job.camera.projection.is_panorama() {
        panorama::check(job.camera, job.rig)?;
    }
    let adaptive = matches!(job.opts.sampling, Sampling::Adaptive { .. }) && views > 1;
    let exact = Shading::of_paper(PaperTechniques::NONE);
    let (batches, epipolar, solo): (Vec<Box<dyn ViewBatch + 'a>>, _, _) = match job.opts.method {
        ViewMethod::Independent => {
            let solo = each_view(adaptive, views, |v| Independent::solo(job, v));
            (vec![Box::new(Independent::new(job))], None, solo)
        }
        ViewMethod::Twin { paper } if job.camera.projection.is_panorama() => {
            if paper != PaperTechniques::NONE {
                return Err(crate::Error::Invalid(
                    "the paper's techniques are for flat rigs, not panoramas".into(),
                ));
            }
            let solo = each_view(adaptive, views, |v| PanoramaTwin::solo(job, v));
            (vec![Box::new(PanoramaTwin::new(job))], None, solo)
        }
        ViewMethod::Fast { .. } if job.camera.projection.is_panorama() => {
            return Err(crate::Error::Invalid(
                "--fast is for flat rigs; a panorama's twin method is exact and as fast".into(),
            ))
        }
        ViewMethod::Twin { paper } => {
            let shading = Shading::of_paper(paper);
            let solo = match adaptive {
                true => twin::batches(job, 1, exact)?,
                false => Vec::new(),
            };
            (twin::batches(job, per_batch, shading)?, None, solo)
        }
        ViewMethod::Fast { tolerance } => {
            let world = job.world;
            let traits = SceneTraits {
                alpha: world.has_alpha,
                instances: world.instances.is_some(),
            };
            let stages = job
                .opts
                .fast_stages
                .unwrap_or_else(|| fast::stages(tolerance, job.opts.sampling, views, traits));
            let epipolar = stages
                .epipolar_rows
                .then(|| EpipolarPass::new(world, job.camera, job.rig, stages.tolerance))
                .flatten();
            let size = if epipolar.is_some() { 1 } else { per_batch };
            let shading = Shading::of_fast(&stages);
            let solo = match adaptive {
                true => twin::batches(job, 1, exact)?,
                false => Vec::new(),
            };
            (twin::batches(job, size, shading)?, epipolar, solo)
        }
    };
    Ok(RowTracers {
        batches,
        epipolar,
        solo,
    })
}

/// `make(v)` for each of `views` views where `wanted` (else none): the
/// one-view batches of a method.
fn each_view<'a, B: ViewBatch + 'a>(
    wanted: bool,
    views: usize,
    make: impl Fn(usize) -> B,
) -> Vec<Box<dyn ViewBatch + 'a>> {
    match wanted {
        true => (0..views)
            .map(|v| Box::new(make(v)) as Box<dyn ViewBatch + 'a>)
            .collect(),
        false => Vec::new(),
    }
}
