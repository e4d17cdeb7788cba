//! The rig a job asks for, and the rig it gets: the request made from the
//! interaxial, convergence, view cone and depth budget of a
//! [`RigSpec`](crate::job::RigSpec); the rig before the scene is built; the
//! rig settled on the built scene (depth passes where needed) with its
//! disparity report. The arithmetic is in `depth_budget`, `disparity` and
//! `window`; this module only puts the steps in order.

use std::fmt;
use std::str::FromStr;
use std::time::Instant;

use crate::camera::Camera;
use crate::depth::stride_for;
use crate::depth_budget::{
    choose_rig, plan_rig, Convergence, DepthBudget, PlannedRig, RigChoice, RigRequest, Spacing,
};
use crate::disparity::{self, DisparityReport, OuterPasses, REPORT_COLUMNS};
use crate::rig::Rig;
use crate::world::World;
use crate::{Error, Result};

/// The interaxial asked for: a distance or `auto`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Interaxial {
    Auto,
    Distance(f32),
}

impl FromStr for Interaxial {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        if s.trim().eq_ignore_ascii_case("auto") {
            return Ok(Interaxial::Auto);
        }
        match s.trim().parse::<f32>() {
            Ok(b) if b.is_finite() && b >= 0.0 => Ok(Interaxial::Distance(b)),
            _ => Err(format!(
                "'{s}': the interaxial is a finite distance >= 0 or 'auto'"
            )),
        }
    }
}

impl fmt::Display for Interaxial {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Interaxial::Auto => f.write_str("auto"),
            Interaxial::Distance(b) => write!(f, "{b}"),
        }
    }
}

/// The view cone a quilt uses when neither an interaxial nor a cone is given.
pub const QUILT_VIEW_CONE: f64 = 35.0;

/// What the rig flags ask, parsed.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RigFlags<'a> {
    pub interaxial: Option<Interaxial>,
    pub convergence: Option<&'a str>,
    pub view_cone: Option<f64>,
    pub budget: Option<DepthBudget>,
}

/// The rig asked for by the interaxial, view cone, convergence and depth
/// budget, for `views` views. Omitted, the interaxial is automatic (a quilt:
/// a 35° view cone), and the convergence automatic too unless the interaxial
/// is explicit, which keeps the scene's `at` point at `at_distance`.
pub fn rig_request(
    flags: &RigFlags,
    quilt: bool,
    views: usize,
    at_distance: f64,
) -> Result<RigRequest> {
    let spacing = match (flags.interaxial, flags.view_cone) {
        (_, Some(cone)) => {
            if !(cone.is_finite() && cone > 0.0 && cone < 180.0) {
                return Err(Error::Invalid(format!(
                    "--view-cone must be an angle between 0 and 180 degrees, got {cone}"
                )));
            }
            Spacing::ViewCone(cone)
        }
        (Some(Interaxial::Distance(b)), None) => Spacing::Distance(b),
        (None, None) if quilt => Spacing::ViewCone(QUILT_VIEW_CONE),
        (Some(Interaxial::Auto) | None, None) => Spacing::Auto,
    };
    let convergence = match flags.convergence {
        None if matches!(spacing, Spacing::Distance(_)) => Convergence::Distance(at_distance),
        None => Convergence::Auto,
        Some(s) => parse_convergence(s)?,
    };
    if matches!(spacing, Spacing::ViewCone(_)) && convergence == Convergence::Infinity {
        return Err(Error::Invalid(
            "--view-cone needs a finite convergence (not --convergence inf)".into(),
        ));
    }
    Ok(RigRequest {
        views,
        spacing,
        convergence,
        budget: flags.budget.unwrap_or_default(),
        fallback_distance: at_distance,
    })
}

/// `--convergence`: a distance, `auto`, `near` or `inf`.
fn parse_convergence(s: &str) -> Result<Convergence> {
    Ok(match s.trim().to_ascii_lowercase().as_str() {
        "auto" => Convergence::Auto,
        "near" | "nearest" => Convergence::Nearest,
        "inf" | "infinity" => Convergence::Infinity,
        _ => {
            let c: f64 = s.trim().parse().map_err(|e| {
                Error::Invalid(format!(
                    "--convergence '{s}' is neither a distance nor inf, auto or near: {e}"
                ))
            })?;
            if !(c.is_finite() && c > 0.0) {
                return Err(Error::Invalid(format!(
                    "--convergence must be a distance > 0, inf, auto or near, got {s}"
                )));
            }
            Convergence::Distance(c)
        }
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
    let choice = choose_rig(camera, request, None)?;
    let rig = choice
        .rig(camera, request.views)
        .map_err(|e| Error::Invalid(format!("--interaxial and --convergence: {e}")))?;
    Ok((rig, Some(choice)))
}

/// The rig to render and its disparity report.
#[derive(Clone, Debug)]
pub struct Settled {
    pub rig: Rig,
    pub choice: RigChoice,
    pub report: DisparityReport,
    /// Seconds of the depth passes.
    pub depth_seconds: f64,
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
    let report = disparity::report(camera, &rig, &request.budget, screen_width_m, &passes);
    Ok(Settled {
        rig,
        choice,
        report,
        depth_seconds: start.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interaxial_values() {
        assert_eq!("auto".parse(), Ok(Interaxial::Auto));
        assert_eq!("AUTO".parse(), Ok(Interaxial::Auto));
        assert_eq!("0.25".parse(), Ok(Interaxial::Distance(0.25)));
        for bad in ["-1", "nan", "inf", "x"] {
            assert!(bad.parse::<Interaxial>().is_err(), "{bad}");
        }
        for v in [Interaxial::Auto, Interaxial::Distance(0.1)] {
            assert_eq!(v.to_string().parse(), Ok(v));
        }
    }

    #[test]
    fn omitted_values_default_as_documented() {
        let none = RigFlags::default();
        let r = rig_request(&none, false, 2, 7.0).unwrap();
        assert_eq!(
            (r.spacing, r.convergence),
            (Spacing::Auto, Convergence::Auto)
        );
        let explicit = RigFlags {
            interaxial: Some(Interaxial::Distance(0.3)),
            ..RigFlags::default()
        };
        let r = rig_request(&explicit, false, 2, 7.0).unwrap();
        assert_eq!(
            (r.spacing, r.convergence),
            (Spacing::Distance(0.3), Convergence::Distance(7.0))
        );
        let r = rig_request(&none, true, 48, 7.0).unwrap();
        assert_eq!(r.spacing, Spacing::ViewCone(QUILT_VIEW_CONE));
        let near = RigFlags {
            convergence: Some("near"),
            ..RigFlags::default()
        };
        assert_eq!(
            rig_request(&near, false, 2, 7.0).unwrap().convergence,
            Convergence::Nearest
        );
        let zero = RigFlags {
            convergence: Some("0"),
            ..RigFlags::default()
        };
        assert!(rig_request(&zero, false, 2, 7.0).is_err());
        let cone = RigFlags {
            view_cone: Some(35.0),
            convergence: Some("inf"),
            ..RigFlags::default()
        };
        assert!(rig_request(&cone, false, 8, 7.0).is_err());
    }
}
