//! The fast method (`ViewMethod::Fast`, `--fast`): the one approximate
//! pipeline. Its stages are decided here, in one place ([`stages`]), from
//! the sampling, the view count and the scene:
//!
//! 1. **Epipolar rows** (`epipolar`), where every row of samples lies in one
//!    plane (one ray through each pixel centre, the SPD's corners) and a
//!    row's primitives can be gathered from its plane (no cut-out
//!    materials, no instances): every view's hits of a row found at once,
//!    each sample's the one its own ray finds, and a diffuse surface's
//!    colour shaded once for the views that see it. A row the pass cannot
//!    take is traced by the views' batches, as in 2.
//! 2. **Batches of views sharing a shading cache** (`shared_shading`,
//!    `shading_cache`) elsewhere: the twin method's batches, whose samples
//!    take a surface point's light (or its whole colour) from the views
//!    that shaded it first, with the paper's merged secondary rays and its
//!    cut of the object tree at half a pixel of disparity ([`CUT_PARALLAX`]).
//!
//! In both, mirrors, glass and highlights above the tolerance, and samples
//! next to a shadow edge, are shaded exactly. What the tolerance bounds is
//! in docs/stereo.md; the choice of these stages, by measurement, in
//! docs/benchmarks.md.

pub(super) mod counts;
pub(super) mod epipolar;
pub(super) mod shading_cache;
pub(super) mod shared_shading;

use super::sampler::Sampling;

/// The cut of the object tree the batches take: objects whose disparity
/// is off by at most half a pixel are seen as from the rig's centre.
pub const CUT_PARALLAX: f64 = 0.5;

/// What the fast method does for one render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FastStages {
    /// The rows of samples found from their planes (stage 1).
    pub epipolar_rows: bool,
    /// The cut of the object tree, in pixels of disparity, for the batches
    /// (stage 2; the epipolar rows need the whole tree).
    pub cut_parallax: Option<f64>,
    /// The batches share the shading cache (stage 2, and the rows the
    /// epipolar pass does not take).
    pub shared_cache: bool,
    /// The batches merge secondary rays.
    pub merge_secondary: bool,
    /// The error each stage may add per channel, in image values.
    pub tolerance: f32,
}

/// The scene facts the stages depend on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SceneTraits {
    /// Some material's alpha matters (cut-outs, coverage).
    pub alpha: bool,
    /// The hierarchy is instances over meshes (an animation's).
    pub instances: bool,
}

/// The stages of the fast method within `tolerance` for `views` views
/// sampled as `sampling`, of a scene with `traits`: the epipolar rows where
/// the rows lie in planes and the scene allows them, the batches with a cut
/// elsewhere. The plan (for the cut) and the render (for the rows) ask the
/// same question and get the same answer.
pub fn stages(tolerance: f32, sampling: Sampling, views: usize, traits: SceneTraits) -> FastStages {
    let planar_rows = matches!(sampling, Sampling::Centers | Sampling::Corners);
    let epipolar_rows = planar_rows && views >= 2 && !traits.alpha && !traits.instances;
    FastStages {
        epipolar_rows,
        cut_parallax: (!epipolar_rows).then_some(CUT_PARALLAX),
        shared_cache: true,
        merge_secondary: true,
        tolerance,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::Filter;

    /// The epipolar rows where the rows are planar and the scene allows
    /// them, with no cut; the cut batches for every other sampling, for
    /// cut-outs and for instances.
    #[test]
    fn the_stages_follow_the_sampling_and_the_scene() {
        let plain = SceneTraits::default();
        let adaptive = Sampling::Adaptive {
            threshold: Sampling::DEFAULT_THRESHOLD,
            max_samples: 16,
        };
        let stratified = Sampling::Stratified {
            samples: 4,
            filter: Filter::Box,
            seed: 0,
        };
        for sampling in [Sampling::Centers, Sampling::Corners] {
            let s = stages(0.01, sampling, 2, plain);
            assert!(s.epipolar_rows && s.cut_parallax.is_none(), "{sampling:?}");
            for traits in [
                SceneTraits {
                    alpha: true,
                    ..plain
                },
                SceneTraits {
                    instances: true,
                    ..plain
                },
            ] {
                let s = stages(0.01, sampling, 2, traits);
                assert!(!s.epipolar_rows, "{sampling:?} {traits:?}");
                assert_eq!(s.cut_parallax, Some(CUT_PARALLAX));
            }
        }
        for sampling in [adaptive, stratified] {
            let s = stages(0.02, sampling, 8, plain);
            assert!(!s.epipolar_rows, "{sampling:?}");
            assert_eq!((s.cut_parallax, s.tolerance), (Some(CUT_PARALLAX), 0.02));
        }
    }
}
