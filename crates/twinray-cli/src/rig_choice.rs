//! The command line's side of the depth budget: the flags, the rig they ask
//! for, and the disparity report printed with `-v` and warnings on stderr.
//! The arithmetic is the library's (`depth_budget`, `disparity`, `window`).

use std::str::FromStr;
use std::time::Instant;

use anyhow::{bail, Context, Result};

use twinray::camera::Camera;
use twinray::depth::stride_for;
use twinray::depth_budget::{
    plan_rig, Convergence, DepthBudget, PlannedRig, RigChoice, RigRequest, Spacing,
};
use twinray::disparity::{self, DisparityReport, OuterPasses, REPORT_COLUMNS};
use twinray::output::QuiltSpec;
use twinray::rig::Rig;
use twinray::World;

/// `--interaxial`: a distance or `auto`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InteraxialArg {
    Auto,
    Distance(f32),
}

impl FromStr for InteraxialArg {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        if s.trim().eq_ignore_ascii_case("auto") {
            return Ok(InteraxialArg::Auto);
        }
        match s.trim().parse::<f32>() {
            Ok(b) if b.is_finite() && b >= 0.0 => Ok(InteraxialArg::Distance(b)),
            _ => Err(format!(
                "'{s}': the interaxial is a finite distance >= 0 or 'auto'"
            )),
        }
    }
}

/// Depth budget, floating window, depth outputs and quilts.
#[derive(clap::Args, Clone, Debug)]
#[command(next_help_heading = "Depth budget and multi-view displays")]
pub struct DepthArgs {
    /// Disparity allowed between adjacent views, NEAR,FAR: in per cent of the
    /// image width (-1%,+2%: Sky's 3D guidelines) or pixels (-6px,12px). The
    /// automatic rig fits the visible depths into it; an explicit rig that
    /// exceeds it is warned about.
    #[arg(long, value_name = "NEAR,FAR", allow_hyphen_values = true, value_parser = parse_budget)]
    pub depth_budget: Option<DepthBudget>,
    /// Width of the screen the pair is for, in metres: far points whose
    /// disparity there exceeds the eyes' 65 mm diverge (warned about).
    #[arg(long, value_name = "METRES", default_value_t = disparity::DEFAULT_SCREEN_WIDTH_M)]
    pub screen_width: f64,
    /// Mask the frame's edges where objects in front of the screen touch them
    /// (window violations): black bars on the left of the left view and the
    /// right of the right view, as wide as the violating disparity.
    #[arg(long)]
    pub floating_window: bool,
    /// Add each view's depth (Z, along the view direction) and disparity to the
    /// next view (pixels) as channels "Z" and "disparity" of .exr outputs
    /// (--layout separate or multiview).
    #[arg(long)]
    pub depth: bool,
    /// Quilt grid of --layout quilt: COLSxROWS, or a device preset: portrait
    /// (8x6, 420x560 per view), go (11x6, 369x656), legacy (5x9, 768x480).
    /// The views default to COLS x ROWS, the size to the preset's.
    #[arg(long, value_name = "COLSxROWS|PRESET", value_parser = parse_quilt)]
    pub quilt: Option<QuiltSpec>,
    /// Space the views so that the outer two span this angle, in degrees, seen
    /// from the convergence point (as light-field displays take it; the
    /// default of --layout quilt is 35).
    #[arg(long, value_name = "DEGREES", conflicts_with = "interaxial")]
    pub view_cone: Option<f64>,
}

impl Default for DepthArgs {
    fn default() -> Self {
        DepthArgs {
            depth_budget: None,
            screen_width: disparity::DEFAULT_SCREEN_WIDTH_M,
            floating_window: false,
            depth: false,
            quilt: None,
            view_cone: None,
        }
    }
}

fn parse_budget(s: &str) -> std::result::Result<DepthBudget, String> {
    s.parse().map_err(|e: twinray::Error| e.to_string())
}

fn parse_quilt(s: &str) -> std::result::Result<QuiltSpec, String> {
    s.parse().map_err(|e: twinray::Error| e.to_string())
}

/// The view cone a quilt uses when neither an interaxial nor a cone is given.
pub const QUILT_VIEW_CONE: f64 = 35.0;

/// The rig asked for by `--interaxial`, `--view-cone`, `--convergence` and
/// `--depth-budget`, for `views` views. Omitted, the interaxial is automatic
/// (a quilt: a 35° view cone), and the convergence automatic too unless the
/// interaxial is explicit, which keeps the scene's `at` point as before.
pub fn rig_request(
    interaxial: Option<InteraxialArg>,
    convergence: Option<&str>,
    depth: &DepthArgs,
    quilt: bool,
    views: usize,
    at_distance: f64,
) -> Result<RigRequest> {
    let spacing = match (interaxial, depth.view_cone) {
        (_, Some(cone)) => {
            if !(cone.is_finite() && cone > 0.0 && cone < 180.0) {
                bail!("--view-cone must be an angle between 0 and 180 degrees, got {cone}");
            }
            Spacing::ViewCone(cone)
        }
        (Some(InteraxialArg::Distance(b)), None) => Spacing::Distance(b),
        (None, None) if quilt => Spacing::ViewCone(QUILT_VIEW_CONE),
        (Some(InteraxialArg::Auto) | None, None) => Spacing::Auto,
    };
    let convergence = match convergence {
        None if matches!(spacing, Spacing::Distance(_)) => Convergence::Distance(at_distance),
        None => Convergence::Auto,
        Some(s) => match s.trim().to_ascii_lowercase().as_str() {
            "auto" => Convergence::Auto,
            "near" | "nearest" => Convergence::Nearest,
            "inf" | "infinity" => Convergence::Infinity,
            _ => {
                let c: f64 = s.parse().with_context(|| {
                    format!("--convergence '{s}' is neither a distance nor inf, auto or near")
                })?;
                if !(c.is_finite() && c > 0.0) {
                    bail!("--convergence must be a distance > 0, inf, auto or near, got {s}");
                }
                Convergence::Distance(c)
            }
        },
    };
    if matches!(spacing, Spacing::ViewCone(_)) && convergence == Convergence::Infinity {
        bail!("--view-cone needs a finite convergence (not --convergence inf)");
    }
    Ok(RigRequest {
        views,
        spacing,
        convergence,
        budget: depth.depth_budget.unwrap_or_default(),
        fallback_distance: at_distance,
    })
}

/// The rig before the scene is built: the final one when nothing depends on
/// the visible depths, else a parallel stand-in with no spacing (used only to
/// check the outputs before rendering; [`settle`] replaces it).
pub fn rig_before_depths(
    camera: &Camera,
    request: &RigRequest,
) -> Result<(Rig, Option<RigChoice>)> {
    if request.needs_depth() {
        let rig = Rig::multi_view(camera, request.views, 0.0, None)?;
        return Ok((rig, None));
    }
    let choice = twinray::depth_budget::choose_rig(camera, request, None)?;
    let rig = choice
        .rig(camera, request.views)
        .context("--interaxial and --convergence")?;
    Ok((rig, Some(choice)))
}

/// The rig to render and its disparity report.
pub struct Settled {
    pub rig: Rig,
    pub choice: RigChoice,
    pub report: DisparityReport,
    /// Seconds of the depth passes.
    pub depth_seconds: f64,
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
    } = plan_rig(world, camera, request, stride).context("choosing the rig")?;
    let passes = match passes {
        Some(p) => p,
        None => OuterPasses::measure(world, camera, &rig, stride),
    };
    let report = disparity::report(camera, &rig, &request.budget, screen_width_m, &passes);
    Ok(Settled {
        rig,
        choice,
        report,
        depth_seconds: start.elapsed().as_secs_f64(),
    })
}

/// `-v`: what was chosen and why, then the report.
pub fn print_report(settled: &Settled) {
    eprintln!("rig choice: {}", settled.choice.reason);
    for line in settled.report.lines() {
        eprintln!("{line}");
    }
    eprintln!("depth passes: {:.3} s", settled.depth_seconds);
}

/// Warnings that do not stop the render: the budget exceeded, divergence.
pub fn print_warnings(settled: &Settled) {
    for w in settled.report.warnings() {
        eprintln!("twinray: warning: {w}");
    }
}

/// Checks the flags of this module against the rest, before any work.
pub fn check_flags(depth: &DepthArgs, several_views: bool, quilt_layout: bool) -> Result<()> {
    if !several_views {
        if depth.floating_window {
            bail!("--floating-window needs --stereo or --views N (N > 1)");
        }
        if depth.view_cone.is_some() {
            bail!("--view-cone needs --stereo, --views N (N > 1) or --layout quilt");
        }
        if depth.depth_budget.is_some() {
            bail!("--depth-budget needs --stereo, --views N (N > 1) or --layout quilt");
        }
    }
    if !(depth.screen_width.is_finite() && depth.screen_width > 0.0) {
        bail!(
            "--screen-width must be a width in metres > 0, got {}",
            depth.screen_width
        );
    }
    match (quilt_layout, depth.quilt.is_some()) {
        (true, false) => {
            bail!("--layout quilt needs --quilt COLSxROWS or a preset (portrait, go, legacy)")
        }
        (false, true) => bail!("--quilt sets the grid of --layout quilt; add it or drop --quilt"),
        _ => {}
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interaxial_values() {
        assert_eq!("auto".parse(), Ok(InteraxialArg::Auto));
        assert_eq!("AUTO".parse(), Ok(InteraxialArg::Auto));
        assert_eq!("0.25".parse(), Ok(InteraxialArg::Distance(0.25)));
        for bad in ["-1", "nan", "inf", "x"] {
            assert!(bad.parse::<InteraxialArg>().is_err(), "{bad}");
        }
    }

    #[test]
    fn omitted_values_default_as_documented() {
        let depth = DepthArgs::default();
        let r = rig_request(None, None, &depth, false, 2, 7.0).unwrap();
        assert_eq!(
            (r.spacing, r.convergence),
            (Spacing::Auto, Convergence::Auto)
        );
        let r = rig_request(
            Some(InteraxialArg::Distance(0.3)),
            None,
            &depth,
            false,
            2,
            7.0,
        )
        .unwrap();
        assert_eq!(
            (r.spacing, r.convergence),
            (Spacing::Distance(0.3), Convergence::Distance(7.0))
        );
        let r = rig_request(None, None, &depth, true, 48, 7.0).unwrap();
        assert_eq!(r.spacing, Spacing::ViewCone(QUILT_VIEW_CONE));
        let r = rig_request(None, Some("near"), &depth, false, 2, 7.0).unwrap();
        assert_eq!(r.convergence, Convergence::Nearest);
        assert!(rig_request(None, Some("0"), &depth, false, 2, 7.0).is_err());
        let cone = DepthArgs {
            view_cone: Some(35.0),
            ..DepthArgs::default()
        };
        assert!(rig_request(None, Some("inf"), &cone, false, 8, 7.0).is_err());
    }
}
