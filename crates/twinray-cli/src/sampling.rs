//! The anti-aliasing flags, shared by `render` and `bench-stereo`.

use clap::ValueEnum;
use twinray::job::{FilterSpec, SamplingSpec};

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
    /// Whether any of the flags is given.
    pub fn given(&self) -> bool {
        self.samples.is_some() || self.adaptive.is_some() || self.max_samples.is_some()
    }

    /// The flags as the job spec's sampling (checked by `Job::check`).
    pub fn spec(&self, spd: bool) -> SamplingSpec {
        SamplingSpec {
            spd,
            samples: self.samples,
            filter: self.filter.map(|f| match f {
                FilterArg::Box => FilterSpec::Box,
                FilterArg::Tent => FilterSpec::Tent,
                FilterArg::Gaussian => FilterSpec::Gaussian,
            }),
            seed: self.seed,
            adaptive: self.adaptive,
            max_samples: self.max_samples,
        }
    }
}
