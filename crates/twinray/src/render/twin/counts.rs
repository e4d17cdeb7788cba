//! What the paper's techniques did (`--stats`, `-v`): its cut of the object
//! tree, merged secondary rays and reprojection (the twin method's options;
//! the fast method cuts and merges too).

use serde::Serialize;

/// The paper's techniques' counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, derive_more::AddAssign)]
pub struct PaperCounts {
    /// Samples whose nearest hit lies beyond the cut of the object tree.
    pub samples_cut: u64,
    /// Secondary rays served by a merged ray of another view.
    pub merged_rays: u64,
    /// Samples given another view's shading; those refused it (another
    /// surface point, or a shading tree not diffuse enough); those traced
    /// because no reprojected value reached them (the paper's mode).
    pub reprojected: u64,
    pub reproject_rejected: u64,
    pub hole_samples: u64,
}

impl PaperCounts {
    /// The `-v` line.
    pub fn line(&self) -> String {
        format!(
            "paper's techniques: samples cut {}, secondary rays merged {}, samples reprojected {}, refused {}, traced as holes {}",
            self.samples_cut, self.merged_rays, self.reprojected, self.reproject_rejected, self.hole_samples
        )
    }
}
