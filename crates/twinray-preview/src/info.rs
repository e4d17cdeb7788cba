//! What the page shows beside the image for one change of settings: the
//! rig's numbers, the disparity report and histogram, the window
//! violations, where each view sits in a frame (for the overlays), the
//! camera as numbers, the messages and the command that reproduces the view.
//! A panorama's comfort is in degrees: its IPD, its angular budget, the
//! nearest and farthest points' angular disparities and their histogram.

use serde::Serialize;

use twinray::job::{Job, JobSpec, Level, Loaded, Message, Plan};
use twinray::output::QuiltSpec;
use twinray::rig::histogram::DisparityHistogram;
use twinray::rig::panorama_rig::{IpdChoice, PanoramaRig, UnitsKnown};
use twinray::rig::report::DisparityReport;
use twinray::rig::{Camera, ProjectionName};

use crate::settings::{CameraSettings, View};

/// The answer to a change of settings.
#[derive(Serialize)]
pub struct Info {
    pub generation: u64,
    /// Size of one view at the full preview size.
    pub width: u32,
    pub height: u32,
    pub views: usize,
    pub view: View,
    /// The frames' images at the full preview size, and where each view
    /// sits in them: `[x, y, width, height]` per view.
    pub frame: FrameLayout,
    pub passes: usize,
    pub camera: CameraSettings,
    pub rig: RigNumbers,
    pub report: Option<DisparityReport>,
    pub histogram: Option<DisparityHistogram>,
    /// `pinhole`, or the panorama the page shows in its look-around viewer.
    pub projection: ProjectionName,
    /// A panorama pair's comfort in degrees.
    pub panorama: Option<PanoramaNumbers>,
    pub messages: Vec<Note>,
    /// `twinray render …` for this view at full size, quoted for a POSIX shell.
    pub command: String,
    /// Milliseconds spent checking and planning the change.
    pub plan_ms: f64,
}

#[derive(Serialize)]
pub struct FrameLayout {
    pub width: u32,
    pub height: u32,
    /// Each view's rectangle in the frame image that shows it.
    pub tiles: Vec<[u32; 4]>,
}

/// The rig as numbers.
#[derive(Serialize)]
pub struct RigNumbers {
    /// Distance between adjacent views, scene units.
    pub interaxial: f32,
    pub convergence: Option<f64>,
    pub effective_convergence: Option<f64>,
    pub offsets: Vec<f32>,
    /// Whole-pixel image shifts of the views.
    pub shifts: Vec<i32>,
    pub focal_px: f64,
    /// What decided the interaxial and the convergence, in one sentence.
    pub reason: Option<String>,
    /// The visible depth range (for the convergence control).
    pub nearest: Option<f32>,
    pub farthest: Option<f32>,
}

/// A panorama pair's IPD and angular disparities.
#[derive(Debug, Serialize)]
pub struct PanoramaNumbers {
    /// The IPD, scene units, and in millimetres where the scene's unit is
    /// known.
    pub ipd: f64,
    pub ipd_mm: Option<f64>,
    /// `budget` (the largest within it), `human` (the eyes' 64 mm),
    /// `given` or `at-target` (nothing visible).
    pub chosen_by: &'static str,
    /// The largest angular disparity allowed, degrees.
    pub budget_deg: f64,
    /// The nearest point: the largest angular disparity sampled.
    pub near: Option<AngleAt>,
    /// The farthest: the smallest (0 where a ray sees the background).
    pub far: Option<AngleAt>,
    pub within_budget: bool,
    /// The scene's unit (`--units`, or glTF's metres), if known.
    pub units: Option<String>,
    pub histogram: AngularHistogram,
}

/// An angular disparity, degrees, and the distance of its point from the
/// panorama's centre (`None`: the background, at infinity).
#[derive(Debug, Serialize)]
pub struct AngleAt {
    pub deg: f64,
    pub distance: Option<f64>,
}

/// The depth pass's samples by angular disparity: `counts[i]` between
/// `i * bin_deg` and `(i + 1) * bin_deg` degrees.
#[derive(Debug, Serialize)]
pub struct AngularHistogram {
    pub bin_deg: f64,
    pub counts: Vec<u32>,
}

/// Bins of the angular histogram.
const ANGULAR_BINS: usize = 48;

/// A panorama's numbers, its histogram spanning the budget and the
/// nearest point with a margin.
pub fn panorama_numbers(p: &PanoramaRig) -> PanoramaNumbers {
    let units = match p.units {
        UnitsKnown::Given(u) | UnitsKnown::Guessed(u) => Some(u),
        UnitsKnown::Unknown => None,
    };
    let metres = units.map(|u| u.metres());
    let near_deg = p.near.map_or(0.0, |n| n.0);
    let span = (p.budget_deg * 1.25).max(near_deg * 1.05);
    let bin_deg = span / ANGULAR_BINS as f64;
    let mut counts = vec![0u32; ANGULAR_BINS];
    for &d in &p.disparities_deg {
        let i = (f64::from(d) / bin_deg).floor();
        if i.is_finite() && i >= 0.0 {
            counts[(i as usize).min(ANGULAR_BINS - 1)] += 1;
        }
    }
    let at = |(deg, distance): (f64, f64)| AngleAt {
        deg,
        distance: distance.is_finite().then_some(distance),
    };
    PanoramaNumbers {
        ipd: p.ipd,
        ipd_mm: metres.map(|m| p.ipd * m * 1000.0),
        chosen_by: match p.chosen_by {
            IpdChoice::Budget => "budget",
            IpdChoice::Human => "human",
            IpdChoice::Given => "given",
            IpdChoice::AtTarget => "at-target",
        },
        budget_deg: p.budget_deg,
        near: p.near.map(at),
        far: p.far.map(at),
        within_budget: p.budget_warning().is_none(),
        units: units.map(|u| u.to_string()),
        histogram: AngularHistogram { bin_deg, counts },
    }
}

#[derive(Serialize)]
pub struct Note {
    pub level: &'static str,
    pub text: String,
}

impl Note {
    pub fn of(m: &Message) -> Note {
        Note {
            level: match m.level {
                Level::Info => "info",
                Level::Note => "note",
                Level::Warning => "warning",
            },
            text: m.text.clone(),
        }
    }
}

/// The notes and warnings of a change (the details stay out).
pub fn notes<'a>(messages: impl IntoIterator<Item = &'a Message>) -> Vec<Note> {
    messages
        .into_iter()
        .filter(|m| m.level != Level::Info)
        .map(Note::of)
        .collect()
}

/// The camera as `--from/--at/--up/--fov` numbers: the viewpoint the job
/// looks from, with its field of view as the vertical angle of an image of
/// `size` (an NFF's angle spans the edge pixels' centres of the shorter side),
/// or a panorama's vertical span.
pub fn camera_numbers(
    job: &Job,
    loaded: &Loaded,
    size: (u32, u32),
) -> twinray::Result<CameraSettings> {
    let vp = job.viewpoint(loaded)?;
    let camera = Camera::new(&vp, size.0, size.1);
    let projection = job.spec().camera.projection.projection(Default::default());
    let fov = match projection.is_panorama() {
        true => projection.span_deg().1,
        false => {
            (2.0 * (f64::from(camera.pixel_size) * f64::from(size.1) * 0.5).atan()).to_degrees()
        }
    };
    Ok(CameraSettings {
        from: vp.from.to_array(),
        at: vp.at.to_array(),
        up: vp.up.to_array(),
        fov: fov as f32,
    })
}

/// Where each view sits in the frames of `view`.
pub fn frame_layout(spec: &JobSpec, view: View, plan: &Plan) -> FrameLayout {
    let (w, h) = (plan.width, plan.height);
    let n = plan.rig.views.len();
    let quilt = spec
        .output
        .quilt
        .as_deref()
        .and_then(|q| q.parse::<QuiltSpec>().ok());
    let (width, height, tiles) = match (view, quilt) {
        (View::Sbs, _) => (2 * w, h, vec![[0, 0, w, h], [w, 0, w, h]]),
        (View::Cross, _) => (2 * w, h, vec![[w, 0, w, h], [0, 0, w, h]]),
        (View::Quilt, Some(q)) => {
            let (qw, qh) = q.layout.size(w, h);
            let tiles = (0..n)
                .map(|i| {
                    let (x, y) = q.layout.tile_origin(i, w, h);
                    [x, y, w, h]
                })
                .collect();
            (qw as u32, qh as u32, tiles)
        }
        _ => (w, h, vec![[0, 0, w, h]; n]),
    };
    FrameLayout {
        width,
        height,
        tiles,
    }
}

/// The rig of a plan as numbers.
pub fn rig_numbers(plan: &Plan) -> RigNumbers {
    let depth = plan.settled.as_ref().and_then(|s| s.report.depth);
    RigNumbers {
        interaxial: plan.interaxial,
        convergence: plan.convergence,
        effective_convergence: plan.rig.effective_convergence,
        offsets: plan.rig.views.iter().map(|v| v.offset).collect(),
        shifts: plan.rig.views.iter().map(|v| v.shift).collect(),
        focal_px: plan.camera.focal_pixels(),
        reason: plan.settled.as_ref().map(|s| s.choice.reason.clone()),
        nearest: depth.map(|d| d.nearest),
        farthest: depth.map(|d| d.farthest),
    }
}

/// `twinray render` with `args`, each quoted for a POSIX shell where needed.
pub fn command_line(args: &[String]) -> String {
    let mut line = String::from("twinray render");
    for a in args {
        line.push(' ');
        match shlex::try_quote(a) {
            Ok(q) => line.push_str(&q),
            // A NUL byte cannot be passed on a command line at all.
            Err(_) => line.push_str(&a.replace('\0', "")),
        }
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_are_quoted_for_the_shell() {
        let args: Vec<String> = ["my scene.nff", "-o", "a.png", "--depth-budget=-1%,+2%"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        assert_eq!(
            command_line(&args),
            "twinray render 'my scene.nff' -o a.png '--depth-budget=-1%,+2%'"
        );
    }
}
