//! The anti-aliasing flags, shared by `render` and `bench-stereo`.

use anyhow::{bail, Result};
use clap::ValueEnum;
use twinray::render::{Filter, Sampling};

#[derive(clap::Args, Clone, Debug, Default)]
#[command(next_help_heading = "Anti-aliasing (default: --adaptive)")]
pub struct SamplingArgs {
    /// N stratified samples per pixel (scrambled Sobol points, the same in every
    /// view), weighed by --filter; 1 = one ray through each pixel centre, as
    /// before anti-aliasing existed.
    #[arg(long, value_name = "N", conflicts_with = "adaptive")]
    pub samples: Option<u32>,
    /// Reconstruction filter of --samples N: box (the pixel's area, radius 0.5,
    /// the default), tent (radius 1) or gaussian (sigma 0.5, radius 1.5).
    #[arg(long, value_enum, requires = "samples")]
    pub filter: Option<FilterArg>,
    /// Section 2.6, image coherence (the default): trace the pixel corners, then
    /// split a cell in four where its corners differ by more than THRESHOLD
    /// (linear colour, any channel, any view; default 1/32), down to
    /// --max-samples cells per pixel.
    #[arg(long, value_name = "THRESHOLD", num_args = 0..=1,
          default_missing_value = "0.03125", allow_negative_numbers = true)]
    pub adaptive: Option<f32>,
    /// Most cells per pixel of --adaptive: 4, 16 (default), 64, 256 or 1024.
    #[arg(long, value_name = "N", conflicts_with = "samples")]
    pub max_samples: Option<u32>,
    /// Another pattern of --samples N (0, the default, is the fixed pattern):
    /// renders that differ only in the seed are uncorrelated.
    #[arg(long, value_name = "N", requires = "samples")]
    pub seed: Option<u32>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FilterArg {
    Box,
    Tent,
    Gaussian,
}

impl SamplingArgs {
    /// The sampling asked for, checked; `spd` (the SPD procedure's corners)
    /// takes none of these flags.
    /// Whether any of the flags is given.
    pub fn given(&self) -> bool {
        self.samples.is_some() || self.adaptive.is_some() || self.max_samples.is_some()
    }

    pub fn sampling(&self, spd: bool) -> Result<Sampling> {
        let given = self.given();
        if spd {
            if given {
                bail!("--spd samples the pixel corners: --samples, --adaptive and --max-samples do not apply");
            }
            return Ok(Sampling::Corners);
        }
        let sampling = match (self.samples, self.adaptive) {
            (Some(0), _) => bail!("--samples must be at least 1"),
            (Some(1), _) if self.filter.is_some_and(|f| f != FilterArg::Box) => {
                bail!("--samples 1 traces the pixel centre alone: a --filter needs more samples")
            }
            (Some(1), _) if self.seed.is_some() => {
                bail!("--samples 1 traces the pixel centre: --seed needs more samples")
            }
            (Some(1), _) => Sampling::Centers,
            (Some(samples), _) => Sampling::Stratified {
                samples,
                seed: self.seed.unwrap_or(0),
                filter: match self.filter.unwrap_or(FilterArg::Box) {
                    FilterArg::Box => Filter::Box,
                    FilterArg::Tent => Filter::Tent,
                    FilterArg::Gaussian => Filter::Gaussian,
                },
            },
            // The default: the paper's adaptive refinement (section 2.6) —
            // anti-aliased edges for about one ray per pixel where the image is
            // smooth (docs/benchmarks.md#anti-aliasing compares it with --samples N).
            (None, threshold) => Sampling::Adaptive {
                threshold: threshold.unwrap_or(Sampling::DEFAULT_THRESHOLD),
                max_samples: self.max_samples.unwrap_or(Sampling::DEFAULT_MAX_SAMPLES),
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
            anyhow::anyhow!("{flag}: {e}")
        })?;
        Ok(sampling)
    }
}
