//! The first stage: a spec's values and combinations checked, everything
//! that can be refused before the scene is read, in one place; the view
//! method it asks for (`view_method`: each option against its method), and
//! the render options the later stages use.

use super::panorama;
use crate::rig::Projection;
use std::sync::Arc;

use super::preflight::check_threads;
use super::spec::{CutSpec, JobSpec, LayoutSpec, MethodName, MethodSpec, SamplingSpec, StudioSpec};
use super::stages::{worker_pool, Job};
use super::{outputs, tiles};
use crate::output::QuiltSpec;
use crate::render::{
    Filter, PaperTechniques, RenderOptions, Reprojection, Sampling, TraceSettings, ViewMethod,
    MAX_DEPTH, MAX_VIEWS,
};
use crate::rig::budget::DepthBudget;
use crate::rig::choice::{self as rig_choice, Interaxial, RigFlags};
use crate::{Error, Result};

impl Job {
    /// Checks the spec: every value and combination that can be refused
    /// before the scene is read, and the worker threads.
    pub fn check(spec: JobSpec) -> Result<Job> {
        Job::checked(spec, None)
    }

    /// Checks the spec as [`Job::check`] does, for a job that runs on
    /// `pool` (whose threads replace the spec's `threads`): a front end that
    /// checks a spec per change (the preview) keeps one pool.
    pub fn check_in(spec: JobSpec, pool: Arc<rayon::ThreadPool>) -> Result<Job> {
        Job::checked(spec, Some(pool))
    }

    /// [`Job::check`] with the worker threads of `other` (the frames of an
    /// animation share one pool instead of starting threads per frame).
    pub fn check_sharing_threads(spec: JobSpec, other: &Job) -> Result<Job> {
        Job::checked(spec, Some(Arc::clone(&other.pool)))
    }

    fn checked(mut spec: JobSpec, pool: Option<Arc<rayon::ThreadPool>>) -> Result<Job> {
        if spec.animation.frames.is_some() {
            return Err(invalid(
                "a spec with frames is an animation: run it with twinray::animation::Animation",
            ));
        }
        if let Some(tile) = spec.tile {
            tiles::check(&spec, tile)?;
            // The tile's files are named after it: NAME_tileKofN.ext.
            spec.output.path = tiles::tile_path(&spec.output.path, tile);
        }
        let checked = Checked::of(&spec)?;
        let pool = match pool {
            Some(pool) => pool,
            None => Arc::new(worker_pool(spec.trace.threads)?),
        };
        let messages = outputs::check_display(&spec.output)?;
        check_studio(&spec.studio)?;
        Ok(Job {
            spec,
            views: checked.views,
            quilt: checked.quilt,
            budget: checked.budget,
            interaxial: checked.interaxial,
            options: checked.options,
            cut: checked.cut,
            projection: checked.projection,
            pool,
            messages,
            environments: Default::default(),
        })
    }
}

/// What [`Job::check`] derives from a spec.
struct Checked {
    views: usize,
    quilt: Option<QuiltSpec>,
    budget: Option<DepthBudget>,
    interaxial: Option<Interaxial>,
    options: RenderOptions,
    cut: Option<CutSpec>,
    projection: Projection,
}

pub(super) fn invalid(message: impl Into<String>) -> Error {
    Error::Invalid(message.into())
}

impl Checked {
    fn of(spec: &JobSpec) -> Result<Checked> {
        let (rig, out) = (&spec.rig, &spec.output);
        if let Some([w, h]) = spec.camera.size.filter(|[w, h]| *w == 0 || *h == 0) {
            return Err(invalid(format!(
                "--size {w}x{h}: width and height must be at least 1"
            )));
        }
        let quilt_layout = out.layout == LayoutSpec::Quilt;
        let several_views =
            rig.stereo || rig.views.is_some_and(|n| n > 1) || (quilt_layout && rig.views.is_none());
        check_combinations(spec, several_views)?;
        let interaxial = rig
            .interaxial
            .as_deref()
            .map(|s| {
                s.parse::<Interaxial>()
                    .map_err(|e| invalid(format!("--interaxial {e}")))
            })
            .transpose()?;
        let budget = rig
            .depth_budget
            .as_deref()
            .map(|s| s.parse::<DepthBudget>())
            .transpose()?;
        check_rig_flags(spec, several_views || quilt_layout, quilt_layout)?;
        let quilt = out
            .quilt
            .as_deref()
            .map(str::parse::<QuiltSpec>)
            .transpose()?;
        if out.depth {
            outputs::check_depth_output(
                &out.path,
                matches!(out.layout, LayoutSpec::Separate | LayoutSpec::Multiview),
            )?;
        }
        if let Some(n) = spec.trace.threads {
            check_threads(n).map_err(|e| invalid(format!("--threads: {e}")))?;
        }
        let sampling = sampling(&spec.sampling)?;
        let trace = trace_settings(spec);
        trace.validate().map_err(|e| {
            let flag = if (1..=MAX_DEPTH).contains(&spec.trace.max_depth) {
                "--min-weight"
            } else {
                "--max-depth"
            };
            invalid(format!("{flag}: {e}"))
        })?;
        let views = view_count(spec, quilt.filter(|_| quilt_layout))?;
        let projection = panorama::check(spec, views)?;
        if views > 1 && !projection.is_panorama() {
            // The request's own checks (convergence, view cone), on a stand-in
            // distance: the scene's is known only once it is loaded.
            let flags = RigFlags {
                interaxial,
                convergence: rig.convergence.as_deref(),
                view_cone: rig.view_cone,
                budget,
            };
            rig_choice::rig_request(&flags, quilt_layout, views, 1.0)?;
        }
        let (method, cut) = view_method(&spec.method)?;
        let options = RenderOptions {
            trace,
            method,
            sampling,
            views_per_batch: 0,
            fast_stages: None,
        };
        options.validate(views, cut.is_some())?;
        Ok(Checked {
            views,
            quilt: quilt.filter(|_| quilt_layout),
            budget,
            interaxial,
            options,
            cut,
            projection,
        })
    }
}

/// Flag combinations that would be silently ignored or coerced.
fn check_combinations(spec: &JobSpec, several_views: bool) -> Result<()> {
    let (rig, out) = (&spec.rig, &spec.output);
    if !several_views {
        if rig.interaxial.is_some() {
            return Err(invalid("--interaxial needs --stereo or --views N (N > 1)"));
        }
        if rig.convergence.is_some() {
            return Err(invalid("--convergence needs --stereo or --views N (N > 1)"));
        }
    }
    if out.squeeze
        && !matches!(
            out.layout,
            LayoutSpec::Sbs | LayoutSpec::Cross | LayoutSpec::Tb
        )
    {
        return Err(invalid(
            "--squeeze applies to --layout sbs, cross or tb only",
        ));
    }
    if out.anaglyph.is_some() && out.layout != LayoutSpec::Anaglyph {
        return Err(invalid(
            "--anaglyph chooses the colours of --layout anaglyph; add it or drop --anaglyph",
        ));
    }
    if out.interlace.is_some() && out.layout != LayoutSpec::Interlace {
        return Err(invalid(
            "--interlace chooses the pattern of --layout interlace; add it or drop --interlace",
        ));
    }
    if spec.sampling.spd && spec.trace.min_weight.is_some() {
        return Err(invalid(
            "--spd traces every ray (no cut-off): --min-weight does not apply",
        ));
    }
    Ok(())
}

/// The depth-budget, window and quilt settings against the rest.
fn check_rig_flags(spec: &JobSpec, several_views: bool, quilt_layout: bool) -> Result<()> {
    let rig = &spec.rig;
    if !several_views {
        if rig.floating_window {
            return Err(invalid(
                "--floating-window needs --stereo or --views N (N > 1)",
            ));
        }
        if rig.view_cone.is_some() {
            return Err(invalid(
                "--view-cone needs --stereo, --views N (N > 1) or --layout quilt",
            ));
        }
        if rig.depth_budget.is_some() {
            return Err(invalid(
                "--depth-budget needs --stereo, --views N (N > 1) or --layout quilt",
            ));
        }
    }
    if rig.view_cone.is_some() && rig.interaxial.is_some() {
        return Err(invalid(
            "--view-cone and --interaxial both set the interaxial: give one",
        ));
    }
    if !(rig.screen_width.is_finite() && rig.screen_width > 0.0) {
        return Err(invalid(format!(
            "--screen-width must be a width in metres > 0, got {}",
            rig.screen_width
        )));
    }
    match (quilt_layout, spec.output.quilt.is_some()) {
        (true, false) => Err(invalid(
            "--layout quilt needs --quilt COLSxROWS or a preset (portrait, go, legacy)",
        )),
        (false, true) => Err(invalid(
            "--quilt sets the grid of --layout quilt; add it or drop --quilt",
        )),
        _ => Ok(()),
    }
}

/// How many views: checked against the layout and the quilt.
fn view_count(spec: &JobSpec, quilt: Option<QuiltSpec>) -> Result<usize> {
    let (rig, out) = (&spec.rig, &spec.output);
    let count = match (rig.stereo, rig.views) {
        (true, Some(n)) if n != 2 => {
            return Err(invalid(format!(
                "--stereo renders 2 views; use --views {n} alone for a multi-view set"
            )))
        }
        (_, Some(0)) => return Err(invalid("--views must be at least 1")),
        (_, Some(n)) if n > MAX_VIEWS => {
            return Err(invalid(format!("--views {n}: at most {} views", MAX_VIEWS)))
        }
        (_, Some(n)) => n,
        (true, None) => 2,
        (false, None) => quilt.map_or(1, |q| q.layout.tiles()),
    };
    if let Some(q) = quilt {
        let (c, r) = (q.layout.columns, q.layout.rows);
        if count > MAX_VIEWS {
            return Err(invalid(format!(
                "--quilt {c}x{r} takes {count} views: at most {} views (--views N renders fewer, the other tiles black)",
                MAX_VIEWS
            )));
        }
        if count > q.layout.tiles() {
            return Err(invalid(format!(
                "--views {count} do not fit a {c}x{r} quilt ({} tiles)",
                q.layout.tiles()
            )));
        }
    }
    if count == 1 && out.layout != LayoutSpec::Separate {
        return Err(invalid("--layout needs --stereo (or --views)"));
    }
    if count != 2
        && !matches!(
            out.layout,
            LayoutSpec::Separate | LayoutSpec::Multiview | LayoutSpec::Quilt
        )
    {
        return Err(invalid(format!(
            "--layout {} takes exactly two views",
            out.layout.name()
        )));
    }
    outputs::check_layout_format(out.layout, &out.path)?;
    Ok(count)
}

fn trace_settings(spec: &JobSpec) -> TraceSettings {
    TraceSettings {
        max_depth: spec.trace.max_depth,
        min_weight: match (spec.sampling.spd, spec.trace.min_weight) {
            (true, _) => 0.0,
            (false, Some(w)) => w,
            (false, None) => TraceSettings::default().min_weight,
        },
        spd: spec.sampling.spd,
    }
}

/// The sampling asked for, checked; the SPD procedure (the pixel corners)
/// takes none of the other settings.
pub fn sampling(s: &SamplingSpec) -> Result<Sampling> {
    let given = s.samples.is_some() || s.adaptive.is_some() || s.max_samples.is_some();
    if s.spd {
        if given {
            return Err(invalid("--spd samples the pixel corners: --samples, --adaptive and --max-samples do not apply"));
        }
        return Ok(Sampling::Corners);
    }
    if s.samples.is_some() && (s.adaptive.is_some() || s.max_samples.is_some()) {
        return Err(invalid(
            "--samples N takes fixed samples: --adaptive and --max-samples do not apply",
        ));
    }
    if s.samples.is_none() && (s.filter.is_some() || s.seed.is_some()) {
        return Err(invalid("--filter and --seed need --samples N"));
    }
    let sampling = match (s.samples, s.adaptive) {
        (Some(0), _) => return Err(invalid("--samples must be at least 1")),
        (Some(1), _) if s.filter.is_some_and(|f| f != Filter::Box) => {
            return Err(invalid(
                "--samples 1 traces the pixel centre alone: a --filter needs more samples",
            ))
        }
        (Some(1), _) if s.seed.is_some() => {
            return Err(invalid(
                "--samples 1 traces the pixel centre: --seed needs more samples",
            ))
        }
        (Some(1), _) => Sampling::Centers,
        (Some(samples), _) => Sampling::Stratified {
            samples,
            seed: s.seed.unwrap_or(0),
            filter: s.filter.unwrap_or_default(),
        },
        // The default: the paper's adaptive refinement (section 2.6) —
        // anti-aliased edges for about one ray per pixel where the image is
        // smooth (docs/benchmarks.md#anti-aliasing compares it with --samples N).
        (None, threshold) => Sampling::Adaptive {
            threshold: threshold.unwrap_or(Sampling::DEFAULT_THRESHOLD),
            max_samples: s.max_samples.unwrap_or(Sampling::DEFAULT_MAX_SAMPLES),
        },
    };
    sampling.validate().map_err(|e| {
        let flag = match sampling {
            Sampling::Adaptive { threshold, .. }
                if !(threshold.is_finite() && threshold >= 0.0) =>
            {
                "--adaptive"
            }
            Sampling::Adaptive { .. } => "--max-samples",
            _ => "--samples",
        };
        invalid(format!("{flag}: {e}"))
    })?;
    Ok(sampling)
}

/// The view method a spec asks for, and the cut of the object tree: every
/// option checked against the method it belongs to (one of another method
/// would be ignored, so it is refused) and its range.
fn view_method(m: &MethodSpec) -> Result<(ViewMethod, Option<CutSpec>)> {
    let paper = m.merge_secondary || m.reproject.is_some() || m.cut.is_some();
    if m.reproject_threshold.is_some() && m.reproject.is_none() {
        return Err(invalid(
            "--reproject-threshold sets the threshold of --reproject: add --reproject or drop it",
        ));
    }
    match m.name {
        MethodName::Independent if paper || m.tolerance.is_some() => Err(invalid(
            "--method independent renders each view alone, exactly: --fast, --tolerance, --merge-secondary, --reproject and --cut-* do not apply",
        )),
        MethodName::Independent => Ok((ViewMethod::Independent, None)),
        MethodName::Fast if paper => Err(invalid(
            "--fast is a method of its own, which takes merged rays and a cut where they pay: --merge-secondary, --reproject and --cut-* are options of the default method (give them without --fast)",
        )),
        MethodName::Fast => {
            let tolerance = m.tolerance.unwrap_or(ViewMethod::DEFAULT_TOLERANCE);
            if !(tolerance.is_finite() && tolerance >= 0.0) {
                return Err(invalid(format!(
                    "--tolerance must be an image value >= 0, got {tolerance}"
                )));
            }
            Ok((ViewMethod::Fast { tolerance }, None))
        }
        MethodName::Twin if m.tolerance.is_some() => Err(invalid(
            "--tolerance is the error --fast may add: add --fast, or drop --tolerance",
        )),
        MethodName::Twin => twin_method(m),
    }
}

/// The twin method with the paper's techniques asked for, their values
/// checked.
fn twin_method(m: &MethodSpec) -> Result<(ViewMethod, Option<CutSpec>)> {
    let threshold = m
        .reproject_threshold
        .unwrap_or(Reprojection::DEFAULT_THRESHOLD);
    if !(threshold.is_finite() && threshold >= 0.0) {
        return Err(invalid(format!(
            "--reproject-threshold must be a coefficient >= 0, got {threshold}"
        )));
    }
    match m.cut {
        Some(CutSpec::Distance(d)) if !(d.is_finite() && d > 0.0) => {
            return Err(invalid(format!(
                "--cut-distance must be a distance > 0, got {d}"
            )))
        }
        Some(CutSpec::Parallax(px)) if !(px.is_finite() && px > 0.0) => {
            return Err(invalid(format!(
                "--cut-parallax must be a number of pixels > 0, got {px}"
            )))
        }
        _ => {}
    }
    let paper = PaperTechniques {
        merge_secondary: m.merge_secondary,
        reproject: m.reproject.map(|mode| Reprojection { mode, threshold }),
    };
    Ok((ViewMethod::Twin { paper }, m.cut))
}

/// The background, the lights and the environment, against each other.
fn check_studio(studio: &StudioSpec) -> Result<()> {
    if let Some(bg) = studio.background {
        if !bg.iter().all(|v| v.is_finite() && *v >= 0.0) {
            return Err(invalid(format!(
                "--background takes three finite values >= 0 (linear RGB), got {bg:?}"
            )));
        }
    }
    super::studio::check_lights(&studio.lights)?;
    if let (Some(_), Some(env)) = (studio.background, &studio.env) {
        return Err(invalid(format!(
            "--background and --env {} conflict: the environment image is the background (give one of them)",
            env.display()
        )));
    }
    Ok(())
}
