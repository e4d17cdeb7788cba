//! What a job tells: the verbose account of a plan and of a render (each
//! view method's own counts among it), and the `--stats` report.

use super::preflight::human_bytes;
use super::stages::{Job, Loaded, Message, Plan, Rendered};
use crate::render::{RenderOptions, RenderOutput};
use crate::stats::{Report, SamplingFacts, SceneFacts, Timings};

impl Job {
    /// The verbose account of a render: what it took, how it sampled, and
    /// what its method alone counted (`TraceCounts::method_lines`).
    pub(super) fn render_messages(
        &self,
        plan: &Plan,
        o: &RenderOptions,
        r: &RenderOutput,
    ) -> Vec<Message> {
        let pixels = f64::from(plan.width) * f64::from(plan.height);
        let mut m = vec![
            Message::info(format!(
                "rendered {} view(s) {}x{} by {} in {:.3} s; eye rays {}, traversals per eye ray {:.3}",
                plan.rig.views.len(),
                plan.width,
                plan.height,
                o.method.name(),
                r.seconds,
                r.counts.rays.eye,
                r.counts.eye_traversals as f64 / r.counts.rays.eye.max(1) as f64
            )),
            Message::info(format!(
                "sampling: {}; eye samples per pixel {:.2} (most {}), pixels refined {}",
                o.sampling.describe(),
                r.samples_per_view as f64 / pixels,
                r.max_samples_per_pixel,
                r.refined_pixels
            )),
        ];
        let method = r.counts.method_lines(o.method);
        m.extend(method.into_iter().map(Message::info));
        m
    }

    /// The `--stats` report of a finished job.
    pub fn report(
        &self,
        loaded: &Loaded,
        plan: &Plan,
        rendered: &Rendered,
        write_s: f64,
    ) -> Report {
        let (width, height) = (plan.width, plan.height);
        let result = &rendered.output;
        let world = &plan.world;
        let views = plan.rig.views.len();
        let mut report = Report {
            time: Timings {
                load_s: loaded.load_seconds,
                build_s: plan.build_seconds,
                render_s: result.seconds,
                write_s,
                ..Timings::default()
            },
            scene: SceneFacts {
                primitives: world.scene.shapes.len(),
                lights: world.scene.lights.len(),
                materials: world.scene.materials.len(),
                bvh_nodes: world.bvh.nodes.len(),
                bvh_depth: world.bvh.depth(),
                memory_bytes: world.memory_bytes(),
                warnings: world.scene.warnings.len(),
            },
            width,
            height,
            views,
            method: if views == 1 {
                "mono".into()
            } else {
                self.options.method.name().to_string()
            },
            views_kept_as: if result.rgb8.is_empty() {
                "float"
            } else {
                "rgb8"
            }
            .into(),
            samples_per_view: result.samples_per_view,
            sampling: SamplingFacts {
                mode: self.options.sampling.describe(),
                eye_samples_per_pixel_mean: result.samples_per_view as f64
                    / (f64::from(width) * f64::from(height)),
                eye_samples_per_pixel_max: result.max_samples_per_pixel,
                refined_pixels: result.refined_pixels,
            },
            ..Report::default()
        };
        report.fill_counts(&result.counts, views, self.options.method);
        report.cut_depth = plan.cut.map(|c| c.depth);
        if let Some(s) = &plan.settled {
            report.time.depth_s = Some(s.depth_seconds);
            report.rig_choice = Some(s.choice.clone());
            report.disparity = Some(s.report.clone());
        }
        report.cut_primitives = world.cut_primitives();
        if self.views > 1 {
            report.interaxial = Some(plan.interaxial);
            report.convergence = plan.convergence;
            report.effective_convergence = plan.rig.effective_convergence;
        }
        report
    }
}

/// The verbose account of a plan: scene, rig, the rig's choice and report,
/// the cut; and the report's warnings.
pub(super) fn plan_messages(
    plan: &Plan,
    rig_by_default: bool,
    interaxial_given: bool,
) -> Vec<Message> {
    let world = &plan.world;
    let mut m = vec![Message::info(format!(
        "scene: {} primitives, {} lights, hierarchy {} nodes (depth {}), built in {:.3} s",
        world.scene.shapes.len(),
        world.scene.lights.len(),
        world.bvh.nodes.len(),
        world.bvh.depth(),
        plan.build_seconds
    ))];
    m.push(Message::info(format!(
        "memory: about {} for the views and the files (the scene aside)",
        human_bytes(plan.memory)
    )));
    if plan.rig.views.len() > 1 && plan.panorama.is_none() {
        let conv = match plan.convergence {
            Some(c) => format!("{c}"),
            None => "infinity".into(),
        };
        let eff = match plan.rig.effective_convergence {
            Some(c) => format!("{c:.6}"),
            None => "infinity (parallel)".into(),
        };
        m.push(Message::info(format!(
            "rig: {} views, interaxial {}, focal length {:.3} px, convergence asked {}, effective {}",
            plan.rig.views.len(),
            plan.interaxial,
            plan.camera.focal_pixels(),
            conv,
            eff
        )));
        for (i, v) in plan.rig.views.iter().enumerate() {
            m.push(Message::info(format!(
                "  view {i}: offset {:+.6} along the right axis, image shift {:+} px",
                v.offset, v.shift
            )));
        }
    }
    if let Some(s) = &plan.settled {
        m.extend(s.report_lines().into_iter().map(Message::info));
    }
    if let Some(c) = plan.cut {
        m.push(Message::info(format!(
            "cut of the object tree: {} of {} primitives beyond depth {:.3}",
            world.cut_primitives(),
            world.scene.shapes.len(),
            c.depth
        )));
    }
    if let Some(s) = &plan.settled {
        // The defaults' own choice (a quilt's 35° view cone) is not warned
        // about: the user asked for nothing the budget could contradict.
        let budget = if rig_by_default {
            Message::info
        } else {
            Message::warning
        };
        // Only an interaxial the user gave is theirs to change.
        let advice = if interaxial_given {
            "; --interaxial auto fits them"
        } else {
            ""
        };
        m.extend(
            s.report
                .budget_warning()
                .map(|w| budget(format!("{w}{advice}"))),
        );
        if rig_by_default {
            m.extend(s.report.quilt_divergence_note().map(Message::note));
        } else {
            m.extend(s.report.divergence_warning().map(Message::warning));
        }
    }
    m
}
