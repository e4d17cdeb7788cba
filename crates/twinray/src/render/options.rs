//! What a render is asked to do: how the views are computed (one closed
//! choice, [`ViewMethod`]), how the pixels are sampled, how deep rays go;
//! and every rule of their combinations, checked in one place
//! ([`RenderOptions::validate`]).

use serde::{Deserialize, Serialize};

use super::fast::FastStages;
use super::sampler::Sampling;
use crate::named::named_values;

/// Most views one packet carries (one bit per view in the lane mask).
pub const MAX_LANES: usize = 32;

/// Most views one render takes (in batches of at most [`MAX_LANES`]).
pub const MAX_VIEWS: usize = 256;

/// Deepest ray level accepted (`TraceSettings::max_depth`). The tracer recurses
/// once per level; with 32 views a closed box of mirrors overflowed a 2 MiB
/// worker stack from about level 180 (measured, see docs/reliability.md), so 64
/// leaves room. Past a handful of bounces the contribution is invisible anyway.
pub const MAX_DEPTH: u32 = 64;

/// Views per batch of the twin method: more than 4 neighbouring views in one
/// packet group worse than they share, and no other size measured faster at
/// 48 views (docs/benchmarks.md#views).
pub const DEFAULT_VIEWS_PER_BATCH: usize = 4;

/// How deep and how far the tracer follows rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceSettings {
    /// Deepest ray level traced; the eye ray is level 1.
    pub max_depth: u32,
    /// Adaptive cut-off: a secondary ray is not traced when its weight in the
    /// pixel (product of the coefficients on its path) is below this. 0 = off.
    pub min_weight: f32,
    /// SPD testing procedure: every reflecting or transmitting hit spawns its
    /// reflected ray and every transmitting hit its refracted ray, whatever the weight.
    pub spd: bool,
}

impl Default for TraceSettings {
    fn default() -> Self {
        TraceSettings {
            max_depth: 5,
            min_weight: 1.0 / 256.0,
            spd: false,
        }
    }
}

/// How the views of a rig are computed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ViewMethod {
    /// Each view rendered on its own, one ray at a time: the paper's
    /// "traditional algorithm", and the reference every exactness test
    /// compares with (`independent`).
    Independent,
    /// The paper's twin objects (`twin`): one descent of the hierarchy finds
    /// the nearest hit of every view's eye ray through a sample, and the
    /// views' samples of one surface point are shaded as one packet. Exact,
    /// bit for bit each view rendered alone, unless the paper's techniques
    /// are asked for.
    Twin { paper: PaperTechniques },
    /// The one approximate pipeline (`fast`): every view within `tolerance`
    /// of its exact image (see `fast` for its stages and their bound).
    Fast { tolerance: f32 },
}

impl Default for ViewMethod {
    /// The twin method, exact.
    fn default() -> Self {
        ViewMethod::twin()
    }
}

impl ViewMethod {
    /// The twin method without the paper's techniques: exact.
    pub const fn twin() -> ViewMethod {
        ViewMethod::Twin {
            paper: PaperTechniques::NONE,
        }
    }

    /// The fast method at its default tolerance.
    pub const fn fast() -> ViewMethod {
        ViewMethod::Fast {
            tolerance: ViewMethod::DEFAULT_TOLERANCE,
        }
    }

    /// The fast method's default tolerance: 1 % of the image's range, at
    /// most 0.01 per channel where radiance is at most 1.
    pub const DEFAULT_TOLERANCE: f32 = 0.01;

    /// `independent`, `twin` or `fast`, as reports name the method.
    pub fn name(&self) -> &'static str {
        match self {
            ViewMethod::Independent => "independent",
            ViewMethod::Twin { .. } => "twin",
            ViewMethod::Fast { .. } => "fast",
        }
    }

    /// Whether the images are exact: every view bit for bit as rendered alone.
    pub fn is_exact(&self) -> bool {
        match self {
            ViewMethod::Independent => true,
            ViewMethod::Twin { paper } => *paper == PaperTechniques::NONE,
            ViewMethod::Fast { .. } => false,
        }
    }
}

/// The paper's speed-for-quality techniques, options of the twin method.
/// None by default: exact images. (Its cut of the object tree is the
/// world's, `world::Cut`.)
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PaperTechniques {
    /// Merged secondary rays: the views' reflected (refracted) rays from one
    /// planar surface merged into one ray from the midpoint of their hits
    /// (`tracer/merged_rays.rs`).
    pub merge_secondary: bool,
    /// Reprojection: view 0's shading given to the other views
    /// (`twin/reprojection.rs`).
    pub reproject: Option<Reprojection>,
}

impl PaperTechniques {
    /// None of them: the twin method is exact.
    pub const NONE: PaperTechniques = PaperTechniques {
        merge_secondary: false,
        reproject: None,
    };
}

/// How the paper's reprojection decides that a view's sample may take
/// another view's shading.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReprojectMode {
    /// Only where the receiving sample's own nearest hit (from the eye pass)
    /// is the same surface point, within a pixel's footprint: no ghost, no hole.
    /// It takes the light visibility and secondary colour; its ambient,
    /// diffuse and highlight terms are its own.
    #[default]
    Safe,
    /// As published (its eq. 2.1): view 0's colour goes where its hit
    /// projects in the other views, the nearest wins, samples that receive
    /// nothing are traced.
    Paper,
}

named_values!(ReprojectMode {
    Safe = "safe",
    Paper = "paper",
});

/// The paper's reprojection, as asked for.
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

/// Everything a render is asked to do.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    pub trace: TraceSettings,
    pub method: ViewMethod,
    pub sampling: Sampling,
    /// Views the twin method traces as one packet (0: the default,
    /// [`DEFAULT_VIEWS_PER_BATCH`]). Not a user setting: tests use it to
    /// check every packet width, benchmarks to measure them.
    pub views_per_batch: usize,
    /// The fast method's stages, where not those `fast::stages` decides
    /// for the sampling and the scene (`None`, always for a user). Not a
    /// user setting: tests use it to check one stage alone.
    pub fast_stages: Option<FastStages>,
}

impl Default for RenderOptions {
    /// The twin method, exact, one ray through each pixel centre.
    fn default() -> Self {
        RenderOptions {
            trace: TraceSettings::default(),
            method: ViewMethod::default(),
            sampling: Sampling::Centers,
            views_per_batch: 0,
            fast_stages: None,
        }
    }
}

impl RenderOptions {
    /// Every rule of the options, in one place: the trace limits and the
    /// sampling within range; the view count; the method's values; and the
    /// combinations no method takes: an approximation of one view, the
    /// paper's reprojection as published with a cut of the object tree
    /// (`cut`: whether the world is cut), and a batch wider than a packet.
    pub fn validate(&self, views: usize, cut: bool) -> crate::Result<()> {
        let invalid = |m: String| Err(crate::Error::Invalid(m));
        self.trace.validate()?;
        self.sampling.validate()?;
        if views == 0 || views > MAX_VIEWS {
            return invalid(format!(
                "{views} views: twinray renders 1 to {MAX_VIEWS} views at once"
            ));
        }
        if self.views_per_batch > MAX_LANES {
            return invalid(format!(
                "{} views in one packet: at most {MAX_LANES}",
                self.views_per_batch
            ));
        }
        match self.method {
            ViewMethod::Independent => Ok(()),
            ViewMethod::Fast { tolerance } => {
                if !(tolerance.is_finite() && tolerance >= 0.0) {
                    return invalid(format!(
                        "tolerance {tolerance}: an image value >= 0 is needed"
                    ));
                }
                if views < 2 {
                    return invalid(
                        "the fast method shares work between views: it needs two or more".into(),
                    );
                }
                Ok(())
            }
            ViewMethod::Twin { paper } => paper.validate(views, cut),
        }
    }

    /// The twin method's batch size for `views` views: the asked
    /// `views_per_batch`, or all views up to [`DEFAULT_VIEWS_PER_BATCH`],
    /// else batches of that many.
    pub fn views_per_batch(&self, views: usize) -> usize {
        match self.views_per_batch {
            0 => views.clamp(1, DEFAULT_VIEWS_PER_BATCH),
            n => n.min(MAX_LANES),
        }
    }
}

impl PaperTechniques {
    /// The techniques' own rules: a threshold >= 0; approximations need
    /// two views; the reprojection as published takes no cut.
    fn validate(&self, views: usize, cut: bool) -> crate::Result<()> {
        let invalid = |m: String| Err(crate::Error::Invalid(m));
        if let Some(r) = self.reproject {
            if !(r.threshold >= 0.0 && r.threshold.is_finite()) {
                return invalid(format!(
                    "reprojection threshold {}: a coefficient >= 0 is needed",
                    r.threshold
                ));
            }
            if r.mode == ReprojectMode::Paper && cut {
                return invalid(
                    "the paper's reprojection mode does not combine with a cut of the object tree"
                        .into(),
                );
            }
        }
        if (*self != PaperTechniques::NONE || cut) && views < 2 {
            return invalid(
                "the paper's techniques share work between views: they need two or more".into(),
            );
        }
        Ok(())
    }
}

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
