//! The distribution of the visible disparities: how much of the image sits
//! at each depth in front of and behind the screen, for a front end to plot
//! against the depth budget (the preview's comfort display).
//!
//! Read from the same depth passes as the disparity report (`report.rs`):
//! every sample of the outer views that hits a surface, its disparity
//! between adjacent views (the outer views' divided by the N − 1 gaps, as the
//! report's `adjacent_px`), in pixels.

use serde::Serialize;

use super::budget::DepthBudget;
use super::depth_pass::OuterPasses;
use super::{pair_disparity, Camera, Rig};

/// Counts of samples per disparity bin, in pixels between adjacent views.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DisparityHistogram {
    /// Disparity at the left edge of the first bin, pixels.
    pub start_px: f64,
    /// Width of every bin, pixels (> 0).
    pub bin_px: f64,
    /// Samples per bin; bin `i` holds `[start + i·bin, start + (i+1)·bin)`,
    /// the last bin its right edge too.
    pub counts: Vec<u32>,
    /// Samples that hit nothing (the background).
    pub misses: u32,
    /// Image width in pixels: a disparity of `d` px is `100·d/width` per cent.
    pub width: u32,
}

impl DisparityHistogram {
    /// Bins of a histogram.
    pub const BINS: usize = 64;

    /// The histogram of the disparities the passes see, over a range that
    /// holds every sample, the budget and zero (the screen plane).
    pub fn measure(
        camera: &Camera,
        rig: &Rig,
        budget: &DepthBudget,
        passes: &OuterPasses,
    ) -> DisparityHistogram {
        let gaps = (rig.views.len().max(2) - 1) as f64;
        let (first, last) = match (rig.views.first(), rig.views.last()) {
            (Some(&a), Some(&b)) => (a, b),
            _ => (
                super::View {
                    offset: 0.0,
                    shift: 0,
                },
                super::View {
                    offset: 0.0,
                    shift: 0,
                },
            ),
        };
        let mut misses = 0u32;
        let disparities: Vec<f64> = passes
            .left
            .depth
            .iter()
            .chain(&passes.right.depth)
            .filter_map(|&d| {
                if d.is_finite() {
                    Some(pair_disparity(camera, first, last, f64::from(d)) / gaps)
                } else {
                    misses += 1;
                    None
                }
            })
            .filter(|d| d.is_finite())
            .collect();
        let (near_px, far_px) = budget.pixels(camera.width);
        let lo = disparities.iter().copied().fold(near_px.min(0.0), f64::min);
        let hi = disparities.iter().copied().fold(far_px.max(0.0), f64::max);
        let span = hi - lo;
        let bin_px = if span > 0.0 {
            span / Self::BINS as f64
        } else {
            1.0
        };
        let mut counts = vec![0u32; Self::BINS];
        for d in disparities {
            let i = (((d - lo) / bin_px) as usize).min(Self::BINS - 1);
            counts[i] += 1;
        }
        DisparityHistogram {
            start_px: lo,
            bin_px,
            counts,
            misses,
            width: camera.width,
        }
    }

    /// Samples that hit a surface.
    pub fn hits(&self) -> u64 {
        self.counts.iter().map(|&c| u64::from(c)).sum()
    }

    /// The disparity range of the bins that hold samples, pixels (`None`:
    /// nothing visible).
    pub fn occupied_px(&self) -> Option<(f64, f64)> {
        let first = self.counts.iter().position(|&c| c > 0)?;
        let last = self.counts.iter().rposition(|&c| c > 0)?;
        Some((
            self.start_px + first as f64 * self.bin_px,
            self.start_px + (last + 1) as f64 * self.bin_px,
        ))
    }
}
