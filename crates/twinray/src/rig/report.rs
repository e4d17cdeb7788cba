//! The disparity report: how far in front of and behind the screen a stereo
//! or multi-view render puts what is visible, against the depth budget.
//!
//! Measured on depth passes of the rig's two outer views (eye rays only, every
//! `stride`-th pixel, see `depth.rs`): the visible depths and their
//! percentiles, the disparities of the nearest and farthest points between
//! adjacent views (what the budget limits) and between the outer views, in
//! pixels and per cent of the width, whether far points diverge on a screen of
//! a given width, and the window violations (`window.rs`).
//!
//! Disparity is `x_b − x_a` for view `b` right of view `a`: negative in front
//! of the screen, positive behind it. Between views `a` and `b` a point at
//! depth `z` has `(shift_a − shift_b) − f·(offset_b − offset_a)/z`
//! ([`pair_disparity`]). "Adjacent" is the outer views' disparity divided by
//! the N − 1 gaps: the mean over the adjacent pairs, whose whole-pixel shifts
//! differ by at most a pixel.

use std::time::Instant;

use serde::Serialize;

use super::budget::DepthBudget;
use super::choice::{plan_rig, PlannedRig, RigChoice, RigRequest};
use super::depth_pass::{stride_for, DepthStats, OuterPasses, REPORT_COLUMNS};
use super::histogram::DisparityHistogram;
use super::window::{find_violations, FloatingWindow, WindowViolation};
use super::{pair_disparity, Camera, Rig, View};
use crate::world::World;
use crate::{Error, Result};

/// The eyes' separation that far points must not exceed on the screen, in
/// metres (the adult mean is about 63 mm; 65 mm is the figure stereographers use).
pub const EYE_SEPARATION_M: f64 = 0.065;

/// The screen assumed for the divergence check: 1.2 m wide, a 55-inch 16:9
/// television (Sky's budget is written for television).
pub const DEFAULT_SCREEN_WIDTH_M: f64 = 1.2;

/// Disparities within this many pixels of the budget count as inside it.
const BUDGET_TOLERANCE_PX: f64 = 0.01;

/// Near and far ends of a range of disparities.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Span {
    pub near: f64,
    pub far: f64,
}

/// The report of `-v` and of `--stats` (`disparity`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DisparityReport {
    /// The views whose depth passes were measured: the outer two.
    pub views_measured: [usize; 2],
    /// Every `sample_stride`-th pixel was sampled, in both directions.
    pub sample_stride: u32,
    pub samples_per_view: usize,
    /// Depths of both views' samples (`None`: nothing visible).
    pub depth: Option<DepthStats>,
    /// Disparity of the nearest and farthest visible points between adjacent
    /// views, in pixels and in per cent of the image width.
    pub adjacent_px: Option<Span>,
    pub adjacent_percent: Option<Span>,
    /// The same between the outer views (equal to `adjacent_px` for a pair).
    pub outer_px: Option<Span>,
    /// The disparity of points at infinity between adjacent views (the
    /// convergence shift; 0 for parallel cameras).
    pub infinity_px: f64,
    pub budget: DepthBudget,
    pub budget_px: Span,
    pub within_budget: bool,
    /// The divergence check: the far disparity on a screen this wide.
    pub screen_width_m: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub far_on_screen_mm: Option<f64>,
    /// Far points need the eyes to turn outwards (more than 65 mm apart on the screen).
    pub diverges: bool,
    pub window_violations: Vec<WindowViolation>,
    /// The masks `--floating-window` applies (or would apply) to cure them.
    pub floating_window: FloatingWindow,
}

/// The report for `rig` from its outer views' depth passes.
pub fn report(
    camera: &Camera,
    rig: &Rig,
    budget: &DepthBudget,
    screen_width_m: f64,
    passes: &OuterPasses,
) -> DisparityReport {
    let n = rig.views.len().max(1);
    let gaps = (n.max(2) - 1) as f64;
    let first = rig.views.first().copied().unwrap_or(View {
        offset: 0.0,
        shift: 0,
    });
    let last = rig.views.last().copied().unwrap_or(first);
    let width = f64::from(camera.width.max(1));
    let depth = DepthStats::of(
        passes
            .left
            .depth
            .iter()
            .chain(passes.right.depth.iter())
            .copied(),
    );
    let outer = depth.map(|d| Span {
        near: pair_disparity(camera, first, last, f64::from(d.nearest)),
        far: pair_disparity(camera, first, last, f64::from(d.farthest)),
    });
    let adjacent = outer.map(|o| Span {
        near: o.near / gaps,
        far: o.far / gaps,
    });
    let (near_px, far_px) = budget.pixels(camera.width);
    let within_budget = adjacent.is_none_or(|a| {
        a.near >= near_px - BUDGET_TOLERANCE_PX && a.far <= far_px + BUDGET_TOLERANCE_PX
    });
    let far_on_screen_mm = adjacent.map(|a| a.far / width * screen_width_m * 1000.0);
    let violations = find_violations(camera, rig, &passes.left, &passes.right);
    DisparityReport {
        views_measured: [0, n - 1],
        sample_stride: passes.stride,
        samples_per_view: passes.left.depth.len(),
        depth,
        adjacent_px: adjacent,
        adjacent_percent: adjacent.map(|a| Span {
            near: a.near / width * 100.0,
            far: a.far / width * 100.0,
        }),
        outer_px: outer,
        infinity_px: f64::from(first.shift - last.shift) / gaps,
        budget: *budget,
        budget_px: Span {
            near: near_px,
            far: far_px,
        },
        within_budget,
        screen_width_m,
        far_on_screen_mm,
        diverges: far_on_screen_mm.is_some_and(|mm| mm > EYE_SEPARATION_M * 1000.0),
        floating_window: FloatingWindow::for_violations(&violations),
        window_violations: violations,
    }
}

impl DisparityReport {
    /// The report as lines for `-v`.
    pub fn lines(&self) -> Vec<String> {
        let [a, b] = self.views_measured;
        let mut out = vec![format!(
            "depth pass: views {a} and {b}, every {} pixel(s) ({} samples each)",
            self.sample_stride, self.samples_per_view
        )];
        let (Some(d), Some(adj), Some(pct), Some(outer)) = (
            self.depth,
            self.adjacent_px,
            self.adjacent_percent,
            self.outer_px,
        ) else {
            out.push("depth: nothing visible".into());
            return out;
        };
        out.push(format!(
            "depth: nearest {:.4}, 1% {:.4}, median {:.4}, 99% {:.4}, farthest {:.4}; {:.1}% of the samples hit",
            d.nearest, d.p1, d.median, d.p99, d.farthest, d.hit_fraction * 100.0
        ));
        let pair = if b == 1 {
            "disparity".to_string()
        } else {
            "disparity between adjacent views (mean)".to_string()
        };
        out.push(format!(
            "{pair}: {:+.2} px ({:+.2}% of the width) to {:+.2} px ({:+.2}%); budget {} ({:+.2} to {:+.2} px): {}",
            adj.near,
            pct.near,
            adj.far,
            pct.far,
            self.budget,
            self.budget_px.near,
            self.budget_px.far,
            if self.within_budget { "within" } else { "EXCEEDED" }
        ));
        if b > 1 {
            out.push(format!(
                "disparity between views 0 and {b}: {:+.2} to {:+.2} px",
                outer.near, outer.far
            ));
        }
        if let Some(mm) = self.far_on_screen_mm {
            out.push(format!(
                "far points on a {} m screen: {mm:+.1} mm apart{}",
                self.screen_width_m,
                if self.diverges {
                    " (diverge: more than the eyes' 65 mm)"
                } else {
                    ""
                }
            ));
        }
        if self.window_violations.is_empty() {
            out.push("window violations: none".into());
        }
        for v in &self.window_violations {
            out.push(format!(
                "window violation: {} edge of view {}, rows {}-{} (nearest depth {:.4}, disparity {:+.2} px): --floating-window masks {} px",
                v.edge.name(),
                v.view,
                v.first_row,
                v.last_row,
                v.nearest_depth,
                v.disparity_px,
                v.mask_px
            ));
        }
        out
    }

    /// Warnings: the budget exceeded, far points diverging.
    pub fn warnings(&self) -> Vec<String> {
        self.budget_warning()
            .into_iter()
            .chain(self.divergence_warning())
            .collect()
    }

    /// The disparities beyond the depth budget, if they are.
    pub fn budget_warning(&self) -> Option<String> {
        let (Some(pct), Some(d), false) = (self.adjacent_percent, self.depth, self.within_budget)
        else {
            return None;
        };
        Some(format!(
            "the rig's disparities {:+.2}% to {:+.2}% of the width exceed the depth budget {} \
             (visible depths {:.4} to {:.4})",
            pct.near, pct.far, self.budget, d.nearest, d.farthest
        ))
    }

    /// What far points diverging means for a quilt whose rig is the
    /// defaults' own (its view cone), if they do: a note, not a warning, for
    /// nothing the user set is at fault, and a Looking Glass does not show
    /// two neighbouring views as a pair on a screen that wide.
    pub fn quilt_divergence_note(&self) -> Option<String> {
        let (Some(mm), true) = (self.far_on_screen_mm, self.diverges) else {
            return None;
        };
        Some(format!(
            "the quilt's neighbouring views put far points {mm:.0} mm apart on a {} m screen, \
             more than the eyes' 65 mm: shown as a stereo pair that wide they would diverge; \
             on a Looking Glass, which shows each eye views further apart through its lens, \
             far points look soft instead (a narrower --view-cone brings them closer)",
            self.screen_width_m
        ))
    }

    /// Far points that make the eyes diverge, if any.
    pub fn divergence_warning(&self) -> Option<String> {
        let (Some(mm), true) = (self.far_on_screen_mm, self.diverges) else {
            return None;
        };
        Some(format!(
            "far points diverge: {mm:.0} mm apart on a {} m screen, more than the eyes' 65 mm \
             (a smaller interaxial or a nearer convergence helps; --screen-width sets the screen)",
            self.screen_width_m
        ))
    }
}
/// The rig to render and its disparity report.
#[derive(Clone, Debug)]
pub struct Settled {
    pub rig: Rig,
    pub choice: RigChoice,
    pub report: DisparityReport,
    /// Seconds of the depth passes.
    pub depth_seconds: f64,
    /// The visible disparities, binned (from the report's depth passes).
    pub histogram: DisparityHistogram,
}

impl Settled {
    /// What was chosen and why, then the report (the command line's `-v`).
    pub fn report_lines(&self) -> Vec<String> {
        let mut lines = vec![format!("rig choice: {}", self.choice.reason)];
        lines.extend(self.report.lines());
        lines.push(format!("depth passes: {:.3} s", self.depth_seconds));
        lines
    }
}

/// Chooses the rig on the built scene (depth passes where the request needs
/// them) and measures its disparity report.
pub fn settle(
    world: &World,
    camera: &Camera,
    request: &RigRequest,
    screen_width_m: f64,
) -> Result<Settled> {
    let start = Instant::now();
    let stride = stride_for(camera.width, REPORT_COLUMNS);
    let PlannedRig {
        rig,
        choice,
        passes,
    } = plan_rig(world, camera, request, stride)
        .map_err(|e| Error::Invalid(format!("choosing the rig: {e}")))?;
    let passes = match passes {
        Some(p) => p,
        None => OuterPasses::measure(world, camera, &rig, stride),
    };
    let report = report(camera, &rig, &request.budget, screen_width_m, &passes);
    let histogram = DisparityHistogram::measure(camera, &rig, &request.budget, &passes);
    Ok(Settled {
        rig,
        choice,
        report,
        depth_seconds: start.elapsed().as_secs_f64(),
        histogram,
    })
}

#[cfg(test)]
mod tests {
    use super::super::depth_pass::DepthPass;
    use super::super::test_camera as camera;
    use super::*;

    /// Depth passes of the outer views: one row of the image's middle
    /// columns (no window edge in reach), at the given depths.
    fn passes(rig: &Rig, depths: &[f32]) -> OuterPasses {
        let pass = |view: View| DepthPass {
            view,
            columns: (0..depths.len() as u32).map(|i| 90 + i).collect(),
            rows: vec![50],
            depth: depths.to_vec(),
        };
        OuterPasses {
            left: pass(rig.views[0]),
            right: pass(*rig.views.last().expect("views")),
            stride: 1,
        }
    }

    /// `x_b − x_a` for a point at depth `z`, from the views' offsets and shifts.
    fn disparity(cam: &Camera, a: View, b: View, z: f64) -> f64 {
        f64::from(a.shift - b.shift)
            - f64::from(b.offset - a.offset) / f64::from(cam.pixel_size) / z
    }

    #[test]
    fn adjacent_disparities_are_the_outer_ones_over_the_gaps() {
        let cam = camera();
        for views in [2, 5] {
            let rig = Rig::multi_view(&cam, views, 0.1, Some(8.0)).expect("rig");
            let (first, last) = (rig.views[0], rig.views[views - 1]);
            let depths = [6.0, 4.0, f32::INFINITY, 20.0, 9.0];
            let r = report(
                &cam,
                &rig,
                &DepthBudget::default(),
                1.2,
                &passes(&rig, &depths),
            );
            let gaps = (views - 1) as f64;
            let outer = r.outer_px.expect("something visible");
            let adjacent = r.adjacent_px.expect("something visible");
            for (got, z) in [(outer.near, 4.0), (outer.far, 20.0)] {
                assert!(
                    (got - disparity(&cam, first, last, z)).abs() < 1e-9,
                    "{views} views"
                );
            }
            assert!((adjacent.near - outer.near / gaps).abs() < 1e-12);
            assert!((adjacent.far - outer.far / gaps).abs() < 1e-12);
            let percent = r.adjacent_percent.expect("percent");
            assert!((percent.near - adjacent.near / 201.0 * 100.0).abs() < 1e-12);
            assert_eq!(r.infinity_px, f64::from(first.shift - last.shift) / gaps);
            assert_eq!(r.views_measured, [0, views - 1]);
            assert_eq!(r.samples_per_view, depths.len());
            let d = r.depth.expect("stats");
            assert_eq!((d.nearest, d.farthest, d.hit_fraction), (4.0, 20.0, 0.8));
            // Nearer is further in front of the screen.
            assert!(adjacent.near < adjacent.far);
        }
    }

    #[test]
    fn a_rig_beyond_the_budget_or_diverging_is_warned_about() {
        let cam = camera();
        let budget = DepthBudget::default(); // -1 % .. +2 %: -2.01 .. +4.02 px
        let gentle = Rig::stereo(&cam, 0.02, Some(8.0)).expect("rig");
        let r = report(&cam, &gentle, &budget, 1.2, &passes(&gentle, &[6.0, 12.0]));
        assert!(r.within_budget && !r.diverges, "{:?}", r.adjacent_px);
        assert!(r.warnings().is_empty());
        assert!(r.lines().iter().any(|l| l.contains("): within")));
        // Ten times the interaxial: the near point far in front of the screen.
        let wide = Rig::stereo(&cam, 0.5, Some(8.0)).expect("rig");
        let r = report(&cam, &wide, &budget, 1.2, &passes(&wide, &[2.0, 12.0]));
        assert!(!r.within_budget);
        assert!(r.adjacent_px.is_some_and(|a| a.near < r.budget_px.near));
        assert!(r.lines().iter().any(|l| l.ends_with("EXCEEDED")));
        assert!(r.warnings()[0].contains("exceed the depth budget"));
        // Converged near, points far away: on a cinema screen they diverge.
        let near = Rig::stereo(&cam, 0.15, Some(3.0)).expect("rig");
        let far = passes(&near, &[3.0, 1e6]);
        let tv = report(&cam, &near, &budget, 1.2, &far);
        let cinema = report(&cam, &near, &budget, 20.0, &far);
        let mm = |r: &DisparityReport| r.far_on_screen_mm.expect("far");
        assert!((mm(&cinema) / mm(&tv) - 20.0 / 1.2).abs() < 1e-9);
        assert!(
            !tv.diverges && cinema.diverges,
            "{} mm, {} mm",
            mm(&tv),
            mm(&cinema)
        );
        assert!(cinema
            .warnings()
            .iter()
            .any(|w| w.contains("far points diverge")));
    }

    #[test]
    fn nothing_visible_is_reported_as_such_and_within_the_budget() {
        let cam = camera();
        let rig = Rig::stereo(&cam, 0.3, None).expect("rig");
        let r = report(
            &cam,
            &rig,
            &DepthBudget::default(),
            1.2,
            &passes(&rig, &[f32::INFINITY; 4]),
        );
        assert_eq!(
            (r.depth, r.adjacent_px, r.far_on_screen_mm),
            (None, None, None)
        );
        assert!(r.within_budget && !r.diverges && r.window_violations.is_empty());
        assert_eq!(
            r.lines().last().map(String::as_str),
            Some("depth: nothing visible")
        );
        assert!(r.warnings().is_empty());
        assert_eq!(r.infinity_px, 0.0, "parallel views");
    }
}
