//! Counters kept per thread without contention and merged at the end, and the
//! JSON report of `--stats`.

use serde::Serialize;

use crate::bvh::{RunStats, StripStats, TraversalStats};
use crate::render::MAX_VIEWS;

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
    /// packets of eight, `Bvh::closest_eye_packet8`: one descent each,
    /// counted per ray in the traversals above), and those packets.
    pub eye_packet_rays: u64,
    pub eye_packets: u64,
    /// Secondary (reflected or refracted) descents that served more than one view.
    pub shared_secondary: u64,
    /// Views' secondary rays served by those shared descents.
    pub shared_secondary_rays: u64,
    /// Samples shaded in one packet with the samples of other views that see
    /// the same surface point (twin method).
    pub grouped_samples: u64,
    /// Approximations (the paper's sections 2.4, 2.5): secondary rays served by
    /// a merged ray of another view; samples given another view's shading
    /// (`reprojected`), refused it (`reproject_rejected`: another surface point,
    /// or a shading tree not diffuse enough), and traced because no reprojected
    /// value reached them (`hole_samples`, the paper mode).
    pub merged_rays: u64,
    /// Samples whose nearest hit lies beyond the cut (section 2.3).
    pub samples_cut: u64,
    pub reprojected: u64,
    pub reproject_rejected: u64,
    pub hole_samples: u64,
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
    /// `--share-shading`: samples shaded exactly and kept for other views
    /// (`cache_entries`), of those refused for a shadow edge next to them
    /// (`cache_edge_refusals`); samples that took a kept sample's light
    /// (`cache_hits`), and samples that might have but found none and were
    /// shaded exactly (`cache_fallbacks`); of the hits, those that took the
    /// entry's finished colour, computing nothing (`cache_colour_hits`).
    pub cache_entries: u64,
    pub cache_edge_refusals: u64,
    pub cache_hits: u64,
    pub cache_fallbacks: u64,
    pub cache_colour_hits: u64,
    /// Rays traced on past a cut-away hit (alpha MASK), one per layer.
    pub cutout_continuations: u64,
    /// `--strip`: the eye pass's descents for all the views of a camera
    /// column, their nodes, family and single-ray primitive tests.
    pub strip: StripStats,
    /// Key views (`--share-shading`, mirror and glass surfaces): samples
    /// traced in full as key views, probe rays of the views between them,
    /// samples between key views that took the interpolated secondary
    /// colour, and those that traced their own (the key views disagreed, or
    /// the probe or a light's fan did).
    pub key_view_samples: u64,
    pub key_view_probes: u64,
    pub interpolated_samples: u64,
    pub key_view_fallbacks: u64,
    /// Groups traced as packets because their primitive's last key views
    /// interpolated nothing.
    pub key_view_skipped_groups: u64,
    /// Shadow fans (`bvh::ShadowFan`): one descent for the shadow segments of
    /// several hits toward one light (`fan_queries`, key views' checks); of
    /// those, the fans proved free of occluders (`fan_free`).
    pub fan_queries: u64,
    pub fan_free: u64,
    /// `--eye-runs`: families, rays traced alone and filled by proofs, the
    /// proofs and their work (`bvh::RunStats`).
    pub runs: RunStats,
    /// `--shadow-fans`: eye hits' shadow rays not traced, their run's fan
    /// toward the light proved free (`rays.shadow` counts the rays traced).
    pub shadow_rays_proved: u64,
    /// Shadow rays that first tested the shadow cache's blocker, and of those
    /// the ones it blocked (no traversal).
    pub shadow_cache_tests: u64,
    pub shadow_cache_hits: u64,
    /// `--interpolate-views`: spans, samples shaded and interpolated, and
    /// refusals by rule (`render::InterpStats`).
    pub interp: crate::render::InterpStats,
    /// `--synthesize-views`: key samples, synthesized and traced samples,
    /// and the region proofs (`render::SynthesisStats`).
    pub synthesis: crate::render::SynthesisStats,
    /// `--epipolar-views`: what the rows' planes did.
    pub epipolar: crate::render::EpipolarStats,
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
}

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
    /// Approximations: secondary rays served by a merged ray; samples given
    /// view 0's shading, refused it, or traced as holes (paper mode).
    pub merged_rays: u64,
    pub samples_cut: u64,
    pub reprojected_samples: u64,
    pub reproject_rejected: u64,
    pub hole_samples: u64,
    pub hits_per_view: Vec<u64>,
    /// Shared shading (`--share-shading`): see `TraceCounts`.
    pub cache_entries: u64,
    pub cache_edge_refusals: u64,
    pub cache_hits: u64,
    pub cache_fallbacks: u64,
    pub cache_colour_hits: u64,
    /// Key views and shadow fans (`--share-shading`): see `TraceCounts`.
    pub key_view_samples: u64,
    pub key_view_probes: u64,
    pub interpolated_samples: u64,
    pub key_view_fallbacks: u64,
    pub key_view_skipped_groups: u64,
    pub fan_queries: u64,
    pub fan_free: u64,
    /// `--shadow-fans`: see `TraceCounts`.
    pub shadow_rays_proved: u64,
    pub nodes_visited: u64,
    pub box_tests: u64,
    pub primitive_tests: u64,
    /// Of `primitive_tests`, those made eight lanes (rays) at a time: a
    /// packet's rays against one sphere or cone.
    pub primitive_tests_in_lanes: u64,
    /// Section 2.3: the depth of the cut and the primitives beyond it.
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
    /// `--strip`: the eye pass's descents for all the views of a camera
    /// column, their nodes, family and single-ray primitive tests.
    pub strip: StripStats,
    /// `--eye-runs`: see `TraceCounts::runs`.
    pub eye_runs: RunStats,
    /// See `TraceCounts::shadow_cache_tests`.
    pub shadow_cache_tests: u64,
    pub shadow_cache_hits: u64,
    /// `--interpolate-views`: see `TraceCounts::interp`.
    pub interpolated_views: crate::render::InterpStats,
    /// `--synthesize-views`: see `TraceCounts::synthesis`.
    pub view_synthesis: crate::render::SynthesisStats,
    /// `--epipolar-views`: see `TraceCounts::epipolar`.
    pub epipolar_views: crate::render::EpipolarStats,
}

impl Report {
    pub fn fill_counts(&mut self, c: &TraceCounts, views: usize) {
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
        self.merged_rays = c.merged_rays;
        self.samples_cut = c.samples_cut;
        self.reprojected_samples = c.reprojected;
        self.reproject_rejected = c.reproject_rejected;
        self.hole_samples = c.hole_samples;
        self.cutout_continuations = c.cutout_continuations;
        self.strip = c.strip;
        if c.eye_pass_ns > 0 {
            self.time.eye_pass_cpu_s = Some(c.eye_pass_ns as f64 * 1e-9);
            self.time.shading_pass_cpu_s = Some(c.shading_pass_ns as f64 * 1e-9);
        }
        self.hits_per_view = c.per_view_hits.0[..views.min(MAX_VIEWS)].to_vec();
        self.cache_entries = c.cache_entries;
        self.cache_edge_refusals = c.cache_edge_refusals;
        self.cache_hits = c.cache_hits;
        self.cache_fallbacks = c.cache_fallbacks;
        self.cache_colour_hits = c.cache_colour_hits;
        self.key_view_samples = c.key_view_samples;
        self.key_view_probes = c.key_view_probes;
        self.interpolated_samples = c.interpolated_samples;
        self.key_view_fallbacks = c.key_view_fallbacks;
        self.key_view_skipped_groups = c.key_view_skipped_groups;
        self.fan_queries = c.fan_queries;
        self.fan_free = c.fan_free;
        self.eye_runs = c.runs;
        self.interpolated_views = c.interp;
        self.view_synthesis = c.synthesis;
        self.epipolar_views = c.epipolar;
        self.shadow_rays_proved = c.shadow_rays_proved;
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
        report.fill_counts(&a, 48);
        assert_eq!(report.hits_per_view.len(), 48);
        assert_eq!(report.hits_per_view[47], 1047);
        report.fill_counts(&a, MAX_VIEWS);
        assert_eq!(
            report.hits_per_view[MAX_VIEWS - 1],
            1000 + MAX_VIEWS as u64 - 1
        );
        // More views than a render takes: the report stops at the last one counted.
        report.fill_counts(&a, MAX_VIEWS + 5);
        assert_eq!(report.hits_per_view.len(), MAX_VIEWS);
    }

    #[test]
    fn counts_add_field_by_field() {
        let mut a = TraceCounts::default();
        a.rays.eye = 3;
        a.rays.shadow = 5;
        a.nodes = 7;
        a.eye_pass_ns = 11;
        // The counts of each method, summed field by field too.
        a.strip.covers = 13;
        a.runs.filled = 17;
        a.interp.spans = 19;
        a.synthesis.holes = 23;
        a.epipolar.shade_points = 29;
        let b = a;
        a += b;
        assert_eq!(
            (a.rays.eye, a.rays.shadow, a.nodes, a.eye_pass_ns),
            (6, 10, 14, 22)
        );
        assert_eq!(
            (
                a.strip.covers,
                a.runs.filled,
                a.interp.spans,
                a.synthesis.holes,
                a.epipolar.shade_points
            ),
            (26, 34, 38, 46, 58)
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

    #[test]
    fn report_divides_descents_by_eye_rays_and_skips_absent_times() {
        let mut c = TraceCounts::default();
        let mut report = Report::default();
        report.fill_counts(&c, 2);
        assert_eq!(report.traversals_per_eye_ray, 0.0);
        assert_eq!(report.time.eye_pass_cpu_s, None);
        c.rays.eye = 200;
        c.eye_traversals = 100;
        c.eye_pass_ns = 2_000_000_000;
        c.shading_pass_ns = 500_000_000;
        report.fill_counts(&c, 2);
        assert_eq!(report.traversals_per_eye_ray, 0.5);
        assert_eq!(report.time.eye_pass_cpu_s, Some(2.0));
        assert_eq!(report.time.shading_pass_cpu_s, Some(0.5));
        let json: serde_json::Value = serde_json::from_str(&report.to_json()).expect("json");
        assert_eq!(json["traversals_per_eye_ray"], 0.5);
        assert_eq!(json["hits_per_view"].as_array().map(Vec::len), Some(2));
        assert!(json.get("cut_depth").is_none());
    }
}
