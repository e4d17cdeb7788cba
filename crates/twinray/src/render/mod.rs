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
//! Where the rays go and how they become pixels is the same for both methods:
//! the `Sampler` (`sampler`: pixel centres, the SPD's corners, N stratified
//! samples, or the adaptive refinement of section 2.6 in `adaptive`) gives
//! rows of sample positions, the same in every view; a method traces a row for
//! its views; the `Film` (`film`) filters the samples into pixels. The methods
//! compute every ray from the same positions with the same arithmetic, so
//! their images are equal for every sampling.
//!
//! The twin method traces the views in batches of neighbouring views
//! ([`DEFAULT_VIEWS_PER_BATCH`], at most [`MAX_LANES`]), each a twin packet of
//! its own.

mod adaptive;
mod epipolar;
mod film;
mod grouping;
mod independent;
mod interpolated_views;
mod row_shadows;
pub mod sampler;
mod shading_cache;
mod strip;
mod tracer;
mod twin;
mod view_synthesis;

pub use epipolar::{EpipolarStats, EpipolarViews};
pub use interpolated_views::{InterpStats, InterpolateViews};
pub use sampler::{Filter, SampleRow, Sampling};
pub(crate) use tracer::MAX_CUTOUT_LAYERS;
pub use tracer::{Donor, Donors, SecondaryRays, TraceSettings, Tracer, TRACE_LIGHT};
pub use view_synthesis::{SynthesisStats, ViewSynthesis};

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

use rayon::prelude::*;

use crate::image::{Image, Rgb8Image};
use crate::math::Color;
use crate::rig::Camera;
use crate::rig::Rig;
use crate::stats::TraceCounts;
use crate::world::World;
use adaptive::{Refiner, RowRefinement};
use film::{Film, FilmBand};
use sampler::{Pattern, RowColors};

/// Most views one packet carries (one bit per view in the lane mask).
pub const MAX_LANES: usize = 32;

/// Most views one render takes (in batches of at most [`MAX_LANES`]).
pub const MAX_VIEWS: usize = 256;

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
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Approximations {
    /// Section 2.4: the views' reflected (refracted) rays from one planar
    /// surface merged into one ray from the midpoint.
    pub merge_secondary: bool,
    /// Section 2.5: shading reprojected from view 0 to the other views.
    pub reproject: Option<Reprojection>,
    /// Issue 16: the light of a surface point shaded once for every view that
    /// sees it (supersedes the safe reprojection when both are asked).
    pub shared_shading: Option<SharedShading>,
    /// Under the shared shading (tolerance above 0), mirror and glass points
    /// seen by several views of a group are traced in full by key views,
    /// every `key_spacing`-th of them (0: adaptive, the outermost two and
    /// halved where they disagree; 1, the default: none, every view traces
    /// its own, since key views measured slower on SPD gears and mount); the views between take their secondary
    /// colour interpolated where it is close (`twin::key_views`).
    pub key_spacing: usize,
    /// Issue 16 (`--interpolate-views`): on the eye runs' proved spans, the
    /// views between two shaded ones take their colour interpolated where
    /// it is provably close (`interpolated_views`; twin method, no cut).
    pub interpolate_views: Option<InterpolateViews>,
    /// Issue 16 (`--synthesize-views`): only every `spacing`-th view traced;
    /// the views between take the colours their nearest key view saw, warped
    /// along the row, where that is plain and proved free, and trace the rest
    /// (`view_synthesis`; twin method, three views or more).
    pub synthesize_views: Option<ViewSynthesis>,
    /// Issue 16 (`--epipolar-views`): each row's eye hits found from the
    /// primitives that cross its plane, for every view at once, and a
    /// diffuse surface's colour shaded once and interpolated for the views
    /// that see it (`epipolar`; twin method, two views or more).
    pub epipolar_views: Option<EpipolarViews>,
}

/// The multi-view shading cache (`--share-shading`, see `shading_cache`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SharedShading {
    /// Largest error, in image values (1 = white), that the shared secondary
    /// light may add per channel where radiance is at most 1: surfaces whose
    /// mirror + transmission weights exceed it are shaded exactly.
    pub tolerance: f32,
}

impl SharedShading {
    /// 1 % of the image's range: at most 0.01 per channel where it applies.
    pub const DEFAULT_TOLERANCE: f32 = 0.01;
}

impl Default for Approximations {
    /// None: exact images (and no key views: `key_spacing` 1).
    fn default() -> Self {
        Approximations {
            merge_secondary: false,
            reproject: None,
            shared_shading: None,
            key_spacing: 1,
            interpolate_views: None,
            synthesize_views: None,
            epipolar_views: None,
        }
    }
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
    /// Twin method: most views traced as one packet (0: automatic, see
    /// [`views_per_batch`]).
    pub views_per_batch: usize,
    /// Twin method (`--strip`): the eye pass traces every view's ray along a
    /// camera column in one descent (`strip`), where the rig and the sampling
    /// allow it; the images are the same.
    pub strip: bool,
    /// Twin method (`--eye-runs`): the strip pass's families resolved by
    /// eye runs (`bvh/run.rs`): a few views traced alone, the views between
    /// two that hit one primitive proved; the images are the same.
    pub eye_runs: bool,
    /// Twin method (`--shadow-fans`): the shadow rays of runs of views' eye
    /// hits on one primitive are proved free by one shadow fan per light
    /// (`row_shadows`) where they can be; the images are the same.
    pub shadow_fans: bool,
    /// `shadow_fans`: the fewest hits of a run whose fan is asked for (0: the
    /// default, 8; at least 2).
    pub shadow_fan_min_run: usize,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            trace: TraceSettings::default(),
            method: Method::Independent,
            sampling: Sampling::Centers,
            approx: Approximations::default(),
            views_per_batch: 0,
            strip: false,
            eye_runs: false,
            shadow_fans: false,
            shadow_fan_min_run: 0,
        }
    }
}

/// Views per batch when none is asked for: more than 4 neighbouring views in
/// one packet group worse than they share (8 views in one packet cost 1.04–1.23
/// of 8 independent renders on the SPD scenes, in batches of 4 0.67–0.98:
/// docs/benchmarks.md#views).
pub const DEFAULT_VIEWS_PER_BATCH: usize = 4;

/// The twin method's batch size for `views` views: `asked`, or when that is 0
/// all views up to [`DEFAULT_VIEWS_PER_BATCH`], else batches of that many.
pub fn views_per_batch(views: usize, asked: usize) -> usize {
    match asked {
        0 => views.clamp(1, DEFAULT_VIEWS_PER_BATCH),
        n => n.min(MAX_LANES),
    }
}

pub struct RenderOutput {
    /// One image per view of the rig, in rig order; empty where the views
    /// were kept as 8-bit pixels (`rgb8`).
    pub images: Vec<Image>,
    /// The views as 8-bit pixels, in rig order, when [`ViewStorage::Rgb8`]
    /// was asked for and the sampling is not [`Sampling::Corners`] (which
    /// gives `images`); else empty.
    pub rgb8: Vec<Rgb8Image>,
    pub counts: TraceCounts,
    pub seconds: f64,
    /// Samples (eye rays) per view.
    pub samples_per_view: u64,
    /// Most eye samples one pixel's colour came from.
    pub max_samples_per_pixel: u32,
    /// Pixels the adaptive sampling refined (0 for the other samplings).
    pub refined_pixels: u64,
}

/// How a render hands back its views.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ViewStorage {
    /// Linear float colours ([`RenderOutput::images`]).
    #[default]
    Float,
    /// The bytes an 8-bit file written with these options holds, from the
    /// colours clamped to [0, 1] (no exposure or tone curve), quantised row by
    /// row as the rows are traced ([`RenderOutput::rgb8`]). For a caller that
    /// only writes 8-bit files: a view takes a quarter of the fresh memory
    /// (which the kernel must clear first: 2.8 MB, about 2.4 ms on the
    /// project's VM, for a view of 420×560 in floats) and no pass of its own
    /// to quantise. Pixel centres, the adaptive sampling (its rows as they
    /// are refined; its corner lattice stays floats) and stratified samples
    /// (the film's sums, then bytes) are kept so; the SPD's corners give
    /// floats.
    Rgb8(crate::output::WriteOptions),
}

/// A flag a caller raises to stop a render in flight (a preview whose
/// parameters changed, an interrupted command). Clones share the flag.
#[derive(Clone, Debug, Default)]
pub struct CancelToken(Arc<AtomicBool>);

impl CancelToken {
    pub fn new() -> CancelToken {
        CancelToken::default()
    }

    /// Asks every render holding this token (or a clone) to stop.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
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
    render_cancellable(world, camera, rig, opts, progress, &CancelToken::new())
}

/// [`render`], stopping early with [`Error::Cancelled`](crate::Error::Cancelled)
/// once `cancel` is raised: no new row or band of samples starts after that.
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
    let aligned = |r: u32| r.is_multiple_of(TILE_ROW_ALIGNMENT);
    if rows.start >= rows.end
        || rows.end > camera.height
        || !aligned(rows.start)
        || !(aligned(rows.end) || rows.end == camera.height)
    {
        return Err(crate::Error::Invalid(format!(
            "rows {}..{} of a {}-row image: a band starts at a multiple of {TILE_ROW_ALIGNMENT} and ends at one or at the last row",
            rows.start, rows.end, camera.height
        )));
    }
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
    if let Some(sh) = opts.approx.shared_shading {
        if !(sh.tolerance >= 0.0 && sh.tolerance.is_finite()) {
            return Err(crate::Error::Invalid(format!(
                "shared-shading tolerance {}: a value >= 0 is needed",
                sh.tolerance
            )));
        }
        if matches!(opts.approx.reproject, Some(r) if r.mode == ReprojectMode::Paper) {
            return Err(crate::Error::Invalid(
                "the shared shading does not combine with the paper's reprojection mode".into(),
            ));
        }
    }
    if world.far.is_some()
        && matches!(opts.approx.reproject, Some(r) if r.mode == ReprojectMode::Paper)
    {
        return Err(crate::Error::Invalid(
            "the paper's reprojection mode does not combine with a cut of the object tree".into(),
        ));
    }
    if let Some(sy) = opts.approx.synthesize_views {
        if sy.spacing < 2 || !(sy.tolerance >= 0.0 && sy.tolerance.is_finite()) {
            return Err(crate::Error::Invalid(format!(
                "view synthesis: a key view every {} views with tolerance {}: a spacing of at least 2 and a tolerance >= 0 are needed",
                sy.spacing, sy.tolerance
            )));
        }
    }
    if let Some(e) = opts.approx.epipolar_views {
        if !(e.tolerance >= 0.0 && e.tolerance.is_finite()) {
            return Err(crate::Error::Invalid(format!(
                "epipolar views: tolerance {}: a value >= 0 is needed",
                e.tolerance
            )));
        }
    }
    opts.sampling.validate()?;
    let start = Instant::now();
    let job = RenderInputs {
        world,
        camera,
        rig,
        opts,
        progress,
        cancel,
    };
    let paper = matches!(opts.approx.reproject, Some(r) if r.mode == ReprojectMode::Paper);
    // Key-view synthesis traces each view alone (a key view, or a view's
    // samples that cannot be synthesized): batches of one view.
    let synthesis = opts
        .approx
        .synthesize_views
        .filter(|_| opts.method == Method::Twin && !paper)
        .and_then(|sy| view_synthesis::SynthesisPass::new(world, camera, rig, sy));
    // The epipolar rows trace a view's samples alone too.
    let epipolar = opts
        .approx
        .epipolar_views
        .filter(|_| opts.method == Method::Twin && !paper && synthesis.is_none())
        .and_then(|e| epipolar::EpipolarPass::new(world, camera, rig, e));
    let batches = match opts.method {
        Method::Independent => {
            vec![Box::new(independent::Independent::new(&job)) as Box<dyn ViewBatch>]
        }
        Method::Twin if synthesis.is_some() || epipolar.is_some() => twin_batches(&job, 1)?,
        Method::Twin => twin_batches(&job, views_per_batch(views, opts.views_per_batch))?,
    };
    let interpolate = opts
        .approx
        .interpolate_views
        .filter(|_| opts.method == Method::Twin && !paper);
    let runs = opts.eye_runs || interpolate.is_some();
    let single = synthesis.is_some() || epipolar.is_some();
    let strip = ((opts.strip || runs) && opts.method == Method::Twin && !paper && !single)
        .then(|| strip::StripEyePass::new(world, camera, rig))
        .flatten()
        .map(|p| if runs { p.with_runs() } else { p });
    let interpolation = interpolate
        .filter(|_| strip.is_some())
        .map(|s| interpolated_views::ViewInterpolation::new(world, camera, rig, s));
    let fans = (opts.shadow_fans && opts.method == Method::Twin && !paper && !single)
        .then(|| row_shadows::RowShadowPass::new(world, camera, rig, opts.shadow_fan_min_run))
        .flatten();
    let run = Run {
        job: &job,
        batches: &batches,
        strip: strip.as_ref(),
        fans: fans.as_ref(),
        interpolation: interpolation.as_ref(),
        synthesis: synthesis.as_ref(),
        epipolar: epipolar.as_ref(),
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

/// The views of the rig in batches of `size` neighbours, each traced by the
/// twin method as packets of its own (its first view leads its groups).
fn twin_batches<'a>(
    job: &RenderInputs<'a>,
    size: usize,
) -> crate::Result<Vec<Box<dyn ViewBatch + 'a>>> {
    let mut batches: Vec<Box<dyn ViewBatch + 'a>> = Vec::new();
    for (b, views) in job.rig.views.chunks(size.max(1)).enumerate() {
        let rig = Rig {
            views: views.to_vec(),
            ..job.rig.clone()
        };
        let first = b * size;
        batches.push(match views.len() {
            1 => Box::new(twin::TwinBatch::<1>::new(job, rig, first)),
            2 => Box::new(twin::TwinBatch::<2>::new(job, rig, first)),
            3..=4 => Box::new(twin::TwinBatch::<4>::new(job, rig, first)),
            5..=8 => Box::new(twin::TwinBatch::<8>::new(job, rig, first)),
            9..=16 => Box::new(twin::TwinBatch::<16>::new(job, rig, first)),
            17..=MAX_LANES => Box::new(twin::TwinBatch::<32>::new(job, rig, first)),
            n => {
                return Err(crate::Error::Invalid(format!(
                    "{n} views in one packet: at most {MAX_LANES}"
                )))
            }
        });
    }
    Ok(batches)
}

/// What a rendering method is given: the scene, the camera and its views, the
/// options, and whom to tell of finished rows.
struct RenderInputs<'a> {
    world: &'a World,
    camera: &'a Camera,
    rig: &'a Rig,
    opts: &'a RenderOptions,
    progress: &'a (dyn Fn(u64, u64) + Sync),
    cancel: &'a CancelToken,
}

/// Some consecutive views of the rig that a method traces together.
trait ViewBatch: Sync {
    fn view_count(&self) -> usize;
    /// A worker for one thread (its scratch space is reused from row to row).
    fn worker(&self) -> Box<dyn RowWorker + '_>;
}

/// One thread's strip pass (`--strip`) and its row of hits.
type RowStrip<'b> = (&'b strip::StripEyePass<'b>, strip::StripRow);

/// Traces rows of samples for the views of its batch.
trait RowWorker {
    /// `out[v][i]`: the colour of the batch's view `v` through sample `i` of
    /// `row` (`out` has one entry per view of the batch, each `row.len()` long).
    fn trace(&mut self, tracer: &mut Tracer, row: &SampleRow, out: &mut [RowColors]);

    /// `trace`, given every view's eye hits through `row` (the strip pass);
    /// a worker without an eye pass of its own ignores them.
    fn trace_with_hits(
        &mut self,
        tracer: &mut Tracer,
        row: &SampleRow,
        eye: &strip::StripRow,
        out: &mut [RowColors],
    ) {
        let _ = eye;
        self.trace(tracer, row, out);
    }

    /// `trace` for a batch of one view, its eye hits kept in `hits` (the key
    /// views of `view_synthesis`); `false`, with nothing traced, for a worker
    /// that cannot.
    fn trace_keeping_hits(
        &mut self,
        tracer: &mut Tracer,
        row: &SampleRow,
        out: &mut [RowColors],
        hits: &mut Vec<(u32, crate::shapes::SurfaceHit)>,
    ) -> bool {
        let _ = (tracer, row, out, hits);
        false
    }

    /// The eye pass alone: the nearest hit of each of the batch's views
    /// through every sample of `row`, into `hits[v]`, for `trace_with_hits`
    /// to shade; `false` for a worker that has no separate eye pass.
    fn eye_hits(
        &mut self,
        tracer: &mut Tracer,
        row: &SampleRow,
        hits: &mut [Vec<(u32, crate::shapes::SurfaceHit)>],
    ) -> bool {
        let _ = (tracer, row, hits);
        false
    }
}

/// One thread's workers, one per batch: traces a row for every view.
struct RowContext<'b> {
    workers: Vec<(usize, Box<dyn RowWorker + 'b>)>,
    strip: Option<RowStrip<'b>>,
    /// `--shadow-fans`: the rows' shared shadows, and (without the strip
    /// pass) the row's eye hits gathered from the batches' eye passes.
    fans: Option<(&'b row_shadows::RowShadowPass<'b>, strip::StripRow)>,
    /// A row's colours per view, reused from row to row (`Run::lattice`).
    colors: Vec<RowColors>,
    /// `--interpolate-views`: the interpolation of the strip's proved spans.
    interpolation: Option<(
        &'b interpolated_views::ViewInterpolation<'b>,
        interpolated_views::InterpScratch,
    )>,
    /// `--synthesize-views`: the key views' pass (the workers are then one
    /// per view, in rig order).
    synthesis: Option<(
        &'b view_synthesis::SynthesisPass<'b>,
        view_synthesis::SynthScratch,
    )>,
    /// `--epipolar-views`: the rows' planes (the workers are then one per
    /// view, in rig order).
    epipolar: Option<(&'b epipolar::EpipolarPass<'b>, epipolar::EpiScratch)>,
}

impl RowContext<'_> {
    /// `out[v][i]`: view `v`'s colour of sample `i` of `row`, every view.
    fn trace(&mut self, tracer: &mut Tracer, row: &SampleRow, out: &mut Vec<RowColors>) {
        let views: usize = self.workers.iter().map(|(n, _)| n).sum();
        out.resize_with(views, Vec::new);
        for o in out.iter_mut() {
            o.clear();
            o.resize(row.len(), Color::ZERO);
        }
        if let Some((pass, scratch)) = &mut self.synthesis {
            let start = Instant::now();
            pass.trace_row(&mut self.workers, tracer, row, scratch, out);
            tracer.counts.shading_pass_ns += start.elapsed().as_nanos() as u64;
            return;
        }
        if let Some((pass, scratch)) = &mut self.epipolar {
            let start = Instant::now();
            pass.trace_row(&mut self.workers, tracer, row, scratch, out);
            tracer.counts.shading_pass_ns += start.elapsed().as_nanos() as u64;
            return;
        }
        if let Some((pass, hits)) = &mut self.strip {
            let start = Instant::now();
            pass.trace_row(tracer, row, hits);
            tracer.counts.eye_pass_ns += start.elapsed().as_nanos() as u64;
            if let Some((interpolation, scratch)) = &mut self.interpolation {
                interpolation.claim(tracer, hits, scratch);
            }
        }
        let eye = self.shared_shadows(tracer, row, views);
        let mut first = 0;
        for (n, worker) in &mut self.workers {
            let out = &mut out[first..first + *n];
            match eye {
                Some(Known::Strip) => {
                    if let Some((_, hits)) = &self.strip {
                        worker.trace_with_hits(tracer, row, hits, out)
                    }
                }
                Some(Known::Batches) => {
                    if let Some((_, hits)) = &self.fans {
                        worker.trace_with_hits(tracer, row, hits, out)
                    }
                }
                None => worker.trace(tracer, row, out),
            }
            first += *n;
        }
        if let Some((interpolation, scratch)) = &mut self.interpolation {
            let start = Instant::now();
            interpolation.finish_row(tracer, row, scratch, out);
            tracer.counts.shading_pass_ns += start.elapsed().as_nanos() as u64;
        }
        tracer.row_shadows.clear();
    }

    /// `--shadow-fans`: the row's shadow rays proved free, into the tracer;
    /// without the strip pass, every batch's eye pass is run first to know
    /// every view's hits. Returns where the row's eye hits are (`None`: each
    /// batch traces its own).
    fn shared_shadows(
        &mut self,
        tracer: &mut Tracer,
        row: &SampleRow,
        views: usize,
    ) -> Option<Known> {
        let strip = self.strip.as_ref().filter(|(_, hits)| hits.traced);
        let Some((pass, gathered)) = &mut self.fans else {
            return strip.map(|_| Known::Strip);
        };
        if let Some((_, hits)) = strip {
            pass.prove_row(tracer, row, hits);
            return Some(Known::Strip);
        }
        let start = Instant::now();
        gathered.hits.resize_with(views, Vec::new);
        let mut first = 0;
        for (n, worker) in &mut self.workers {
            if !worker.eye_hits(tracer, row, &mut gathered.hits[first..first + *n]) {
                return None;
            }
            first += *n;
        }
        gathered.traced = true;
        tracer.counts.eye_pass_ns += start.elapsed().as_nanos() as u64;
        pass.prove_row(tracer, row, gathered);
        Some(Known::Batches)
    }
}

/// Where a row's eye hits for every view are known.
#[derive(Clone, Copy)]
enum Known {
    /// The strip pass traced them.
    Strip,
    /// The batches' eye passes did, for the shared shadows.
    Batches,
}

/// The images of a sampling, with what it cost.
struct Sampled {
    images: Vec<Image>,
    rgb8: Vec<Rgb8Image>,
    counts: TraceCounts,
    samples_per_view: u64,
    max_per_pixel: u32,
    refined: u64,
}

/// Every view's pixels (or a row of them), in floats or as the files'
/// bytes, as [`ViewStorage`] asks.
enum Views {
    Float(Vec<Vec<Color>>),
    Rgb8(Vec<Vec<u8>>),
}

impl Views {
    /// No pixels yet, room for `pixels` a view.
    fn empty(storage: ViewStorage, views: usize, pixels: usize) -> Views {
        match storage {
            ViewStorage::Float => {
                Views::Float((0..views).map(|_| Vec::with_capacity(pixels)).collect())
            }
            ViewStorage::Rgb8(_) => {
                Views::Rgb8((0..views).map(|_| Vec::with_capacity(3 * pixels)).collect())
            }
        }
    }

    /// A row of every view's colours, kept as `storage` asks (quantised with
    /// the writer's routine).
    fn of_row(colors: Vec<RowColors>, storage: ViewStorage) -> Views {
        match storage {
            ViewStorage::Float => Views::Float(colors),
            ViewStorage::Rgb8(opts) => Views::Rgb8(
                colors
                    .iter()
                    .map(|c| {
                        let mut bytes = vec![0u8; 3 * c.len()];
                        crate::output::rgb8_into(c, &mut bytes, &opts);
                        bytes
                    })
                    .collect(),
            ),
        }
    }

    /// `row` (of the same kind) after every view's pixels.
    fn append(&mut self, row: Views) {
        match (self, row) {
            (Views::Float(all), Views::Float(row)) => {
                all.iter_mut().zip(row).for_each(|(a, r)| a.extend(r))
            }
            (Views::Rgb8(all), Views::Rgb8(row)) => {
                all.iter_mut().zip(row).for_each(|(a, r)| a.extend(r))
            }
            _ => unreachable!("one render keeps its views one way"),
        }
    }

    /// The views as `w` x `h` images: float ones, or the files' bytes.
    fn into_images(self, w: usize, h: usize) -> (Vec<Image>, Vec<Rgb8Image>) {
        let (width, height) = (w as u32, h as u32);
        match self {
            Views::Float(views) => {
                let images = views.into_iter().map(|pixels| Image {
                    width,
                    height,
                    pixels,
                });
                (images.collect(), Vec::new())
            }
            Views::Rgb8(views) => {
                let images = views.into_iter().map(|bytes| Rgb8Image {
                    width,
                    height,
                    bytes,
                });
                (Vec::new(), images.collect())
            }
        }
    }
}

/// Rows of pixels one task samples (`--samples N`, `--adaptive`): a fixed
/// number, so that the film's sums do not depend on the thread count; the
/// adaptive refinement traces the edges its rows share once.
const BAND_ROWS: usize = 8;

/// One render: the job, its batches of views, the image size and the progress.
struct Run<'j, 'a> {
    job: &'j RenderInputs<'a>,
    batches: &'j [Box<dyn ViewBatch + 'a>],
    /// `--strip`: the eye pass of every view at once, where it applies.
    strip: Option<&'j strip::StripEyePass<'a>>,
    /// `--shadow-fans`: the shared shadows of the eye hits.
    fans: Option<&'j row_shadows::RowShadowPass<'a>>,
    /// `--interpolate-views`: the views between proved ones interpolated.
    interpolation: Option<&'j interpolated_views::ViewInterpolation<'a>>,
    /// `--synthesize-views`: the views between key views synthesized.
    synthesis: Option<&'j view_synthesis::SynthesisPass<'a>>,
    /// `--epipolar-views`: the rows' planes.
    epipolar: Option<&'j epipolar::EpipolarPass<'a>>,
    views: usize,
    width: usize,
    height: usize,
    /// The pixel rows rendered (a tile), of `height`.
    rows: std::ops::Range<usize>,
    done: AtomicU64,
    total: AtomicU64,
}

impl Run<'_, '_> {
    /// Runs `task(context, tracer, i)` for `i` in `0..count`, in parallel, a
    /// fresh tracer per task (so that no task's caches depend on which thread
    /// ran what before); returns the results in order and the work counted,
    /// or `None` when the render was cancelled.
    fn tasks<T: Send>(
        &self,
        count: usize,
        task: impl Fn(&mut RowContext, &mut Tracer, usize) -> T + Sync,
    ) -> Option<(Vec<T>, TraceCounts)> {
        self.tasks_over(vec![(); count], |ctx, tracer, i, ()| task(ctx, tracer, i))
    }

    /// [`Run::tasks`], task `i` also given `items[i]` (its share of the
    /// output, written in place). The counts are summed as the tasks finish
    /// (sums of integers: the same in any order), not kept per task.
    fn tasks_over<I: Send, T: Send>(
        &self,
        items: Vec<I>,
        task: impl Fn(&mut RowContext, &mut Tracer, usize, I) -> T + Sync,
    ) -> Option<(Vec<T>, TraceCounts)> {
        let world = self.job.world;
        let settings = self.job.opts.trace;
        let context = || RowContext {
            workers: self
                .batches
                .iter()
                .map(|b| (b.view_count(), b.worker()))
                .collect(),
            strip: self.strip.map(|p| (p, strip::StripRow::default())),
            fans: self.fans.map(|p| (p, strip::StripRow::default())),
            colors: Vec::new(),
            interpolation: self.interpolation.map(|p| (p, Default::default())),
            synthesis: self.synthesis.map(|p| (p, Default::default())),
            epipolar: self.epipolar.map(|p| (p, Default::default())),
        };
        let cancel = self.job.cancel;
        let total = std::sync::Mutex::new(TraceCounts::default());
        let results: Vec<T> = items
            .into_par_iter()
            .enumerate()
            .map_init(context, |ctx, (i, item)| {
                if cancel.is_cancelled() {
                    return None;
                }
                let mut tracer = Tracer::new(world, settings);
                let result = task(ctx, &mut tracer, i, item);
                let done = self.done.fetch_add(1, Ordering::Relaxed) + 1;
                (self.job.progress)(done, self.total.load(Ordering::Relaxed));
                // A poisoned lock means a task panicked, and the panic goes on up.
                *total.lock().unwrap_or_else(|e| e.into_inner()) += tracer.finish();
                Some(result)
            })
            .collect::<Option<_>>()?;
        let counts = total.into_inner().unwrap_or_else(|e| e.into_inner());
        Some((results, counts))
    }

    /// Tells the progress how many tasks the whole render has.
    fn plan(&self, tasks: usize) {
        self.total.store(tasks as u64, Ordering::Relaxed);
    }

    /// Every row of a lattice of `columns` x `rows` samples at `pattern(row)`:
    /// per view, the colours row-major.
    fn lattice(
        &self,
        columns: usize,
        rows: usize,
        pattern: impl Fn(usize) -> Pattern + Sync,
    ) -> Option<(Vec<Vec<Color>>, TraceCounts)> {
        self.lattice_into(columns, rows, 1, pattern, |from, to| {
            to.copy_from_slice(from)
        })
    }

    /// [`Run::lattice`] kept as `T`s, `per_sample` of them a sample:
    /// `store(colours, out)` puts a row's colours of one view into its place.
    /// Each task writes its row straight into the grids (no row kept per
    /// task, no copy of the whole).
    fn lattice_into<T: Copy + Default + Send>(
        &self,
        columns: usize,
        rows: usize,
        per_sample: usize,
        pattern: impl Fn(usize) -> Pattern + Sync,
        store: impl Fn(&[Color], &mut [T]) + Sync,
    ) -> Option<(Vec<Vec<T>>, TraceCounts)> {
        let row_len = (columns * per_sample).max(1);
        // One allocation per view (not one view's grid cloned: a copy that
        // touched every page of every view before a row was traced; zeroed
        // bytes come from the allocator untouched).
        let mut grids: Vec<Vec<T>> = (0..self.views)
            .map(|_| vec![T::default(); columns * per_sample * rows])
            .collect();
        let mut shares: Vec<Vec<&mut [T]>> =
            (0..rows).map(|_| Vec::with_capacity(self.views)).collect();
        for grid in &mut grids {
            for (share, row) in shares.iter_mut().zip(grid.chunks_mut(row_len)) {
                share.push(row);
            }
        }
        let (_, counts) = self.tasks_over(shares, |ctx, tracer, j, mut share| {
            let row = SampleRow::full(columns, pattern(j));
            let mut colors = std::mem::take(&mut ctx.colors);
            ctx.trace(tracer, &row, &mut colors);
            for (to, from) in share.iter_mut().zip(&colors) {
                store(from, to);
            }
            ctx.colors = colors;
        })?;
        Some((grids, counts))
    }

    /// One ray through each pixel centre, the views kept as `storage` asks.
    fn centers(&self, storage: ViewStorage) -> Option<Sampled> {
        let (w, h, y0) = (self.width, self.rows.len(), self.rows.start);
        self.plan(h);
        let pattern = |j| Pattern::Fixed {
            dx: 0.0,
            y: (y0 + j) as f32,
        };
        let (views, counts) = match storage {
            ViewStorage::Float => {
                let (grids, counts) = self.lattice(w, h, pattern)?;
                (Views::Float(grids), counts)
            }
            ViewStorage::Rgb8(opts) => {
                // The writer's own quantisation, so the bytes are the file's.
                let (grids, counts) = self.lattice_into(w, h, 3, pattern, |from, to| {
                    crate::output::rgb8_into(from, to, &opts)
                })?;
                (Views::Rgb8(grids), counts)
            }
        };
        let (images, rgb8) = views.into_images(w, h);
        Some(Sampled {
            images,
            rgb8,
            counts,
            samples_per_view: (w * h) as u64,
            max_per_pixel: 1,
            refined: 0,
        })
    }

    /// The pixel corners, traced once each (every pixel row shares its edges).
    /// Those of the rows rendered, top edge to bottom edge.
    fn corner_lattice(&self) -> Option<(Vec<Vec<Color>>, TraceCounts)> {
        let y0 = self.rows.start;
        self.lattice(self.width + 1, self.rows.len() + 1, |j| Pattern::Fixed {
            dx: -0.5,
            y: (y0 + j) as f32 - 0.5,
        })
    }

    /// The SPD procedure: each pixel the mean of its four corners.
    fn corners(&self) -> Option<Sampled> {
        let (w, h) = (self.width, self.rows.len());
        self.plan(h + 1);
        let (grids, counts) = self.corner_lattice()?;
        let images = grids
            .iter()
            .map(|corners| {
                let mut img = Image::new(w as u32, h as u32);
                for y in 0..h {
                    for x in 0..w {
                        let s = |i: usize, j: usize| corners[j * (w + 1) + i];
                        let c = (s(x, y) + s(x + 1, y) + s(x, y + 1) + s(x + 1, y + 1)) * 0.25;
                        img.pixels[y * w + x] = c;
                    }
                }
                img
            })
            .collect();
        Some(Sampled {
            images,
            rgb8: Vec::new(),
            counts,
            samples_per_view: ((w + 1) * (h + 1)) as u64,
            max_per_pixel: 4,
            refined: 0,
        })
    }

    /// `samples` points of each pixel's sequence, filtered into the film.
    fn stratified(
        &self,
        samples: u32,
        filter: Filter,
        seed: u32,
        storage: ViewStorage,
    ) -> Option<Sampled> {
        let (w, h) = (self.width, self.height);
        // The bands whose samples reach the rows rendered, halo included.
        let halo = film::halo(filter);
        let first = self.rows.start.saturating_sub(halo) / BAND_ROWS;
        let end = (self.rows.end + halo).min(h).div_ceil(BAND_ROWS);
        self.plan(end - first);
        let (bands, counts) = self.tasks(end - first, |ctx, tracer, i| {
            let b = first + i;
            let rows = b * BAND_ROWS..((b + 1) * BAND_ROWS).min(h);
            let mut band = FilmBand::new(self.views, (w, h), rows.clone(), filter);
            let mut colors = Vec::new();
            for y in rows {
                for index in 0..samples {
                    let pattern = Pattern::Sobol {
                        row: y as u32,
                        index,
                        seed,
                    };
                    let row = SampleRow::full(w, pattern);
                    ctx.trace(tracer, &row, &mut colors);
                    band.splat(filter, &row, &colors);
                }
            }
            band
        })?;
        let mut film = Film::new(self.views, w, self.rows.clone());
        for band in &bands {
            film.add(band);
        }
        drop(bands);
        let (images, rgb8) = match storage {
            ViewStorage::Float => (film.images(), Vec::new()),
            ViewStorage::Rgb8(opts) => (Vec::new(), film.rgb8(&opts)),
        };
        Some(Sampled {
            images,
            rgb8,
            counts,
            samples_per_view: (w * self.rows.len()) as u64 * u64::from(samples),
            max_per_pixel: samples,
            refined: 0,
        })
    }

    /// Section 2.6: the corners, then each pixel row refined where its
    /// cells' corners differ (in any view).
    fn adaptive(&self, threshold: f32, max_samples: u32, storage: ViewStorage) -> Option<Sampled> {
        let (w, h) = (self.width, self.rows.len());
        let (y0, y_end) = (self.rows.start, self.rows.end);
        // The rows start on a band's first row (render_rows checks it).
        let first_band = y0 / BAND_ROWS;
        let bands = y_end.div_ceil(BAND_ROWS) - first_band;
        self.plan(h + 1 + bands);
        let (corners, mut counts) = self.corner_lattice()?;
        let corner = |v: usize, x: usize, y: usize| corners[v][(y - y0) * (w + 1) + x];
        let (bands, refine_counts) = self.tasks(bands, |ctx, tracer, i| {
            let b = first_band + i;
            let mut refiner = Refiner::new(self.views, w, threshold, max_samples);
            let mut trace = |row: &SampleRow, colors: &mut Vec<RowColors>| {
                ctx.trace(tracer, row, colors);
            };
            (b * BAND_ROWS..((b + 1) * BAND_ROWS).min(y_end))
                .map(|y| {
                    let mut out = vec![Vec::new(); self.views];
                    let report = refiner.refine_row(
                        y,
                        |v, x, top| corner(v, x, if top { y } else { y + 1 }),
                        &mut trace,
                        &mut out,
                    );
                    // Kept as bytes, a row is a quarter of its colours.
                    (Views::of_row(out, storage), report)
                })
                .collect::<Vec<_>>()
        })?;
        drop(corners);
        counts += refine_counts;
        let mut views = Views::empty(storage, self.views, w * h);
        let mut total = RowRefinement::default();
        for (row, report) in bands.into_iter().flatten() {
            views.append(row);
            total.added += report.added;
            total.refined += report.refined;
            total.max_per_pixel = total.max_per_pixel.max(report.max_per_pixel);
        }
        let (images, rgb8) = views.into_images(w, h);
        Some(Sampled {
            images,
            rgb8,
            counts,
            samples_per_view: ((w + 1) * (h + 1)) as u64 + total.added,
            max_per_pixel: total.max_per_pixel,
            refined: total.refined,
        })
    }
}

/// The shipped example scene (spheres, a cone, polygons), loaded for the
/// render stages' unit tests.
#[cfg(test)]
fn example_scene() -> crate::Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/example.nff");
    crate::loaders::load_scene(&path, &crate::loaders::LoadOptions::default())
        .expect("shipped scene")
}
