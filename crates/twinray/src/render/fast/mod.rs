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
//!    `shading_cache`) elsewhere, for more than two views: the twin
//!    method's batches, whose samples take a surface point's light (or its
//!    whole colour) from the views that shaded it first. Not under the
//!    adaptive sampling, where each view refines its own edges and most
//!    refined points are traced by one view alone: there the cache saved
//!    nothing, and the fast views are the exact ones. (The paper's merged secondary rays took mirror
//!    pixels off by up to 0.6 under adaptive sampling, and its cut of the
//!    object tree did not pay: neither is a stage.)
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

/// What the fast method does for one render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FastStages {
    /// The rows of samples found from their planes (stage 1).
    pub epipolar_rows: bool,
    /// The batches share the shading cache (stage 2, and the rows the
    /// epipolar pass does not take).
    pub shared_cache: bool,
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
/// the rows lie in planes and the scene allows them, elsewhere the batches,
/// sharing the cache where there are more than two views and the sampling
/// is not adaptive.
pub fn stages(tolerance: f32, sampling: Sampling, views: usize, traits: SceneTraits) -> FastStages {
    let planar_rows = matches!(sampling, Sampling::Centers | Sampling::Corners);
    let epipolar_rows = planar_rows && views >= 2 && !traits.alpha && !traits.instances;
    let adaptive = matches!(sampling, Sampling::Adaptive { .. });
    FastStages {
        epipolar_rows,
        // A pair's batches gain nothing from the cache: they group the two
        // views' samples of a point into one packet, whose shadow rays go
        // down together; nor do the adaptive sampling's, whose refined
        // points are mostly one view's (docs/benchmarks.md).
        shared_cache: epipolar_rows || (views > 2 && !adaptive),
        tolerance,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::Filter;

    /// The epipolar rows where the rows are planar and the scene allows
    /// them; the batches for every other sampling, for cut-outs and for
    /// instances, sharing the cache for more than two views unless the
    /// sampling is adaptive.
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
            assert!(s.epipolar_rows && s.shared_cache, "{sampling:?}");
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
                assert!(
                    !s.epipolar_rows && !s.shared_cache,
                    "{sampling:?} {traits:?}"
                );
                assert!(stages(0.01, sampling, 3, traits).shared_cache);
            }
        }
        for sampling in [adaptive, stratified] {
            let s = stages(0.02, sampling, 8, plain);
            assert!(!s.epipolar_rows, "{sampling:?}");
            let cache = sampling == stratified;
            assert_eq!((s.shared_cache, s.tolerance), (cache, 0.02));
            let pair = stages(0.02, sampling, 2, plain);
            assert!(!pair.shared_cache, "a pair: the exact batches");
        }
    }
}
