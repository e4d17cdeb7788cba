//! The JSON report of `--stats`: what a job read, built, rendered and
//! wrote, from the render's counts (`render::TraceCounts`) and the plan.

use serde::Serialize;

use crate::render::{FastCounts, PaperCounts, RayCounts, TraceCounts, ViewMethod, MAX_VIEWS};

#[derive(Clone, Debug, Default, Serialize)]
pub struct Timings {
    pub load_s: f64,
    pub build_s: f64,
    pub render_s: f64,
    pub write_s: f64,
    /// Twin method: seconds spent in the eye-ray pass and in the shading pass
    /// (shadow, reflected and refracted rays and their shading), each thread's
    /// elapsed time summed over the threads. This is CPU time only while no
    /// other process takes the cores: on a loaded machine it counts the time a
    /// thread waited, so compare these between runs on a quiet machine.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub eye_pass_cpu_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shading_pass_cpu_s: Option<f64>,
    /// Stereo and multi-view: the depth passes of the rig's choice and of the
    /// disparity report (wall seconds).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub depth_s: Option<f64>,
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct SceneFacts {
    pub primitives: usize,
    pub lights: usize,
    pub materials: usize,
    pub bvh_nodes: usize,
    pub bvh_depth: usize,
    /// Bytes of shapes, materials, normals and hierarchy.
    pub memory_bytes: usize,
    pub warnings: usize,
}

/// The sampling of a render: its mode (`Sampling::describe`) and the eye
/// samples it took per pixel of one view (the corners shared by four pixels
/// count once in the mean, whole in the largest).
#[derive(Clone, Debug, Default, Serialize)]
pub struct SamplingFacts {
    pub mode: String,
    pub eye_samples_per_pixel_mean: f64,
    pub eye_samples_per_pixel_max: u32,
    /// Pixels the adaptive sampling split at least once.
    pub refined_pixels: u64,
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct Report {
    pub rays: RayCounts,
    pub time: Timings,
    pub scene: SceneFacts,
    pub width: u32,
    pub height: u32,
    pub views: usize,
    pub method: String,
    /// How the renderer kept the views: "float", or "rgb8" (the 8-bit
    /// pixels of the files, quantised as the rows were traced).
    pub views_kept_as: String,
    pub samples_per_view: u64,
    /// How the pixels were sampled, and what it took.
    pub sampling: SamplingFacts,
    pub closest_traversals: u64,
    pub eye_traversals: u64,
    /// Eye-ray descents per eye ray: 1 for independent renders, about 1/views for twin.
    pub traversals_per_eye_ray: f64,
    /// Eye rays traced in packets of neighbouring samples, and the packets.
    pub eye_packet_rays: u64,
    pub eye_packets: u64,
    pub shared_secondary: u64,
    pub shared_secondary_rays: u64,
    /// Samples shaded together with other views' samples of the same point.
    pub grouped_samples: u64,
    pub hits_per_view: Vec<u64>,
    /// The paper's techniques (the twin method with any of them, and the
    /// fast method): see `render::PaperCounts`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper_techniques: Option<PaperCounts>,
    /// The fast method's shading cache and epipolar rows: see
    /// `render::FastCounts`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fast: Option<FastCounts>,
    pub nodes_visited: u64,
    pub box_tests: u64,
    pub primitive_tests: u64,
    /// Of `primitive_tests`, those made eight lanes (rays) at a time: a
    /// packet's rays against one sphere or cone.
    pub primitive_tests_in_lanes: u64,
    /// The cut of the object tree: its depth and the primitives beyond it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cut_depth: Option<f32>,
    pub cut_primitives: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interaxial: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub convergence: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effective_convergence: Option<f64>,
    /// Stereo and multi-view: how the interaxial and convergence were chosen.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rig_choice: Option<crate::rig::choice::RigChoice>,
    /// Stereo and multi-view: visible depths, disparities against the depth
    /// budget, window violations (see `disparity::DisparityReport`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub disparity: Option<crate::rig::report::DisparityReport>,
    /// Rays traced on past a cut-away hit (alpha MASK), one per layer.
    pub cutout_continuations: u64,
    /// See `TraceCounts::shadow_cache_tests`.
    pub shadow_cache_tests: u64,
    pub shadow_cache_hits: u64,
}

impl Report {
    /// The counts of a render of `views` views by `method`: the common ones,
    /// and the method's own.
    pub fn fill_counts(&mut self, c: &TraceCounts, views: usize, method: ViewMethod) {
        self.rays = c.rays;
        self.closest_traversals = c.closest_traversals;
        self.eye_traversals = c.eye_traversals;
        self.eye_packet_rays = c.eye_packet_rays;
        self.eye_packets = c.eye_packets;
        self.traversals_per_eye_ray = if c.rays.eye > 0 {
            c.eye_traversals as f64 / c.rays.eye as f64
        } else {
            0.0
        };
        self.shared_secondary = c.shared_secondary;
        self.shared_secondary_rays = c.shared_secondary_rays;
        self.grouped_samples = c.grouped_samples;
        self.paper_techniques = (!method.is_exact()).then_some(c.paper);
        self.fast = matches!(method, ViewMethod::Fast { .. }).then_some(c.fast);
        self.cutout_continuations = c.cutout_continuations;
        if c.eye_pass_ns > 0 {
            self.time.eye_pass_cpu_s = Some(c.eye_pass_ns as f64 * 1e-9);
            self.time.shading_pass_cpu_s = Some(c.shading_pass_ns as f64 * 1e-9);
        }
        self.hits_per_view = c.per_view_hits.0[..views.min(MAX_VIEWS)].to_vec();
        self.nodes_visited = c.nodes;
        self.box_tests = c.box_tests;
        self.primitive_tests = c.prim_tests;
        self.primitive_tests_in_lanes = c.prim_tests_in_lanes;
        self.shadow_cache_tests = c.shadow_cache_tests;
        self.shadow_cache_hits = c.shadow_cache_hits;
    }

    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_of_every_view_are_merged_and_reported() {
        let mut a = TraceCounts::default();
        let mut b = TraceCounts::default();
        for v in 0..MAX_VIEWS {
            a.per_view_hits.0[v] = v as u64;
            b.per_view_hits.0[v] = 1000;
        }
        a += b;
        let mut report = Report::default();
        report.fill_counts(&a, 48, ViewMethod::twin());
        assert_eq!(report.hits_per_view.len(), 48);
        assert_eq!(report.hits_per_view[47], 1047);
        report.fill_counts(&a, MAX_VIEWS, ViewMethod::twin());
        assert_eq!(
            report.hits_per_view[MAX_VIEWS - 1],
            1000 + MAX_VIEWS as u64 - 1
        );
        // More views than a render takes: the report stops at the last one counted.
        report.fill_counts(&a, MAX_VIEWS + 5, ViewMethod::twin());
        assert_eq!(report.hits_per_view.len(), MAX_VIEWS);
    }

    #[test]
    fn report_divides_descents_by_eye_rays_and_skips_absent_times() {
        let mut c = TraceCounts::default();
        let mut report = Report::default();
        report.fill_counts(&c, 2, ViewMethod::twin());
        assert_eq!(report.traversals_per_eye_ray, 0.0);
        assert_eq!(report.time.eye_pass_cpu_s, None);
        c.rays.eye = 200;
        c.eye_traversals = 100;
        c.eye_pass_ns = 2_000_000_000;
        c.shading_pass_ns = 500_000_000;
        report.fill_counts(&c, 2, ViewMethod::twin());
        assert_eq!(report.traversals_per_eye_ray, 0.5);
        assert_eq!(report.time.eye_pass_cpu_s, Some(2.0));
        assert_eq!(report.time.shading_pass_cpu_s, Some(0.5));
        let json: serde_json::Value = serde_json::from_str(&report.to_json()).expect("json");
        assert_eq!(json["traversals_per_eye_ray"], 0.5);
        assert_eq!(json["hits_per_view"].as_array().map(Vec::len), Some(2));
        assert!(json.get("cut_depth").is_none());
        // The exact twin method has no counters of its own; the fast method
        // reports its own and the paper's techniques it takes.
        assert!(json.get("fast").is_none() && json.get("paper_techniques").is_none());
        c.fast.cache.hits = 7;
        c.paper.merged_rays = 3;
        report.fill_counts(&c, 2, ViewMethod::fast());
        let json: serde_json::Value = serde_json::from_str(&report.to_json()).expect("json");
        assert_eq!(json["fast"]["cache"]["hits"], 7);
        assert_eq!(json["paper_techniques"]["merged_rays"], 3);
    }
}
