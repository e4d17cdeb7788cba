//! What a render did, counted per task without contention and summed at
//! the end: the rays and descents every method makes, and each method's
//! own counters (the paper's techniques, `twin/counts.rs`; the fast
//! method's, `fast/counts.rs`), each with its `-v` lines.

use serde::Serialize;

use super::fast::counts::FastCounts;
use super::options::{ViewMethod, MAX_VIEWS};
use super::twin::counts::PaperCounts;
use crate::bvh::TraversalStats;

/// Ray counts. A stereo method counts one eye ray per view and pixel sample, as
/// two independent renders would, so the counts of the two methods compare.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, derive_more::AddAssign)]
pub struct RayCounts {
    pub eye: u64,
    pub eye_hit: u64,
    pub reflected: u64,
    pub refracted: u64,
    pub shadow: u64,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, derive_more::AddAssign)]
pub struct TraceCounts {
    pub rays: RayCounts,
    /// Descents of the hierarchy for nearest hits (a packet of views is one).
    pub closest_traversals: u64,
    /// Of those, the eye-ray descents.
    pub eye_traversals: u64,
    /// Eye rays traced in packets of neighbouring samples (the mono row's
    /// packets of eight, `Bvh::closest_packet8`: one descent each,
    /// counted per ray in the traversals above), and those packets.
    pub eye_packet_rays: u64,
    pub eye_packets: u64,
    /// Secondary (reflected or refracted) descents that served more than one view.
    pub shared_secondary: u64,
    /// Views' secondary rays served by those shared descents.
    pub shared_secondary_rays: u64,
    /// Samples shaded in one packet with the samples of other views that see
    /// the same surface point (twin and fast methods).
    pub grouped_samples: u64,
    /// CPU time of the twin method's two passes, summed over threads (ns): eye
    /// rays (nearest hits of all views), then shading (everything else).
    pub eye_pass_ns: u64,
    pub shading_pass_ns: u64,
    /// Hits per view (index = view), for stereo and multi-view renders.
    #[serde(skip)]
    pub per_view_hits: HitsPerView,
    pub nodes: u64,
    pub box_tests: u64,
    pub prim_tests: u64,
    /// Of `prim_tests`, those made eight lanes at a time.
    pub prim_tests_in_lanes: u64,
    /// Rays traced on past a cut-away hit (alpha MASK), one per layer.
    pub cutout_continuations: u64,
    /// Shadow rays that first tested the shadow cache's blocker, and of those
    /// the ones it blocked (no traversal).
    pub shadow_cache_tests: u64,
    pub shadow_cache_hits: u64,
    /// The paper's techniques: the twin method's options, and the fast
    /// method's cut and merged rays.
    pub paper: PaperCounts,
    /// The fast method's shading cache and epipolar rows.
    pub fast: FastCounts,
}

/// Eye rays that hit something, per view, for every view a render may have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HitsPerView(pub [u64; MAX_VIEWS]);

impl std::ops::AddAssign for HitsPerView {
    fn add_assign(&mut self, o: HitsPerView) {
        for (a, b) in self.0.iter_mut().zip(o.0) {
            *a += b;
        }
    }
}

impl Default for HitsPerView {
    fn default() -> Self {
        HitsPerView([0; MAX_VIEWS])
    }
}

impl TraceCounts {
    pub fn add_traversal(&mut self, t: &TraversalStats) {
        self.nodes += t.nodes;
        self.box_tests += t.box_tests;
        self.prim_tests += t.prim_tests;
        self.prim_tests_in_lanes += t.prim_tests_in_lanes;
    }

    /// The `-v` lines of what `method` alone counts (none for the exact
    /// methods, whose work the common counters say).
    pub fn method_lines(&self, method: ViewMethod) -> Vec<String> {
        match method {
            ViewMethod::Fast { .. } => self.fast.lines(),
            m if !m.is_exact() => vec![self.paper.line()],
            _ => Vec::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_add_field_by_field() {
        let mut a = TraceCounts::default();
        a.rays.eye = 3;
        a.rays.shadow = 5;
        a.nodes = 7;
        a.eye_pass_ns = 11;
        // Each method's counts, summed field by field too.
        a.paper.reprojected = 13;
        a.fast.cache.hits = 17;
        a.fast.epipolar.shade_points = 29;
        let b = a;
        a += b;
        assert_eq!(
            (a.rays.eye, a.rays.shadow, a.nodes, a.eye_pass_ns),
            (6, 10, 14, 22)
        );
        assert_eq!(
            (
                a.paper.reprojected,
                a.fast.cache.hits,
                a.fast.epipolar.shade_points
            ),
            (26, 34, 58)
        );
        a.add_traversal(&TraversalStats {
            nodes: 1,
            box_tests: 2,
            prim_tests: 3,
            prim_tests_in_lanes: 2,
        });
        assert_eq!((a.nodes, a.box_tests, a.prim_tests), (15, 2, 3));
        assert_eq!(a.prim_tests_in_lanes, 2);
    }

    /// Each method says what it alone counted: nothing for the exact ones.
    #[test]
    fn each_method_has_its_own_lines() {
        let c = TraceCounts::default();
        assert!(c.method_lines(ViewMethod::Independent).is_empty());
        assert!(c.method_lines(ViewMethod::twin()).is_empty());
        let paper = ViewMethod::Twin {
            paper: crate::render::PaperTechniques {
                merge_secondary: true,
                reproject: None,
            },
        };
        let lines = c.method_lines(paper);
        assert!(lines.len() == 1 && lines[0].starts_with("paper's techniques"));
        // The fast method: a line per stage that did something.
        let lines = c.method_lines(ViewMethod::fast());
        assert_eq!(lines, ["fast: nothing shared, every view traced exactly"]);
        let mut cached = c;
        cached.fast.cache.entries = 3;
        let lines = cached.method_lines(ViewMethod::fast());
        assert!(lines.len() == 1 && lines[0].starts_with("fast, shared shading"));
        let mut rows = c;
        rows.fast.epipolar.rows = 2;
        let lines = rows.method_lines(ViewMethod::fast());
        assert!(lines.len() == 1 && lines[0].starts_with("fast, epipolar rows"));
    }
}
