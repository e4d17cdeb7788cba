//! What the page shows beside the image for one change of settings: the
//! rig's numbers, the disparity report and histogram, the window
//! violations, where each view sits in a frame (for the overlays), the
//! camera as numbers, the messages and the command that reproduces the view.

use serde::Serialize;

use twinray::job::{Job, JobSpec, Level, Loaded, Message, Plan};
use twinray::output::QuiltSpec;
use twinray::rig::histogram::DisparityHistogram;
use twinray::rig::report::DisparityReport;
use twinray::rig::Camera;

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
/// `size` (an NFF's angle spans the edge pixels' centres of the shorter side).
pub fn camera_numbers(
    job: &Job,
    loaded: &Loaded,
    size: (u32, u32),
) -> twinray::Result<CameraSettings> {
    let vp = job.viewpoint(loaded)?;
    let camera = Camera::new(&vp, size.0, size.1);
    let fov = 2.0 * (f64::from(camera.pixel_size) * f64::from(size.1) * 0.5).atan();
    Ok(CameraSettings {
        from: vp.from.to_array(),
        at: vp.at.to_array(),
        up: vp.up.to_array(),
        fov: fov.to_degrees() as f32,
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
