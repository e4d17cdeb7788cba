//! The page's controls, and the job spec they describe on top of the
//! command line's.
//!
//! `Settings` is what the page sends on every change: the rig, the layout
//! it shows, the sampling, the camera. [`Settings::spec`] lays it over the
//! spec of the `preview` command's flags; the job's own checks
//! ([`twinray::Job::check`]) then refuse bad values with the command line's
//! messages. Only what the page adds (a layout the command line has not,
//! the eye of a single-eye view) is checked here.
//!
//! A panorama (`--projection`) has no convergence and no flat depth
//! budget: its eyes are parallel, its comfort an angular disparity. The
//! page sends its IPD as the interaxial and its budget as
//! `angular_budget`; the convergence `auto` it sends for every rig means
//! the projection's own there.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use twinray::job::{JobSpec, LayoutSpec, MethodName, SamplingSpec};
use twinray::rig::ProjectionName;

/// How the page shows the views.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum View {
    /// Red-cyan (Dubois) anaglyph.
    #[default]
    Anaglyph,
    /// Left | right, for parallel viewing.
    Sbs,
    /// Right | left, for cross-eyed viewing.
    Cross,
    /// The views one after another, animated in the page.
    Wiggle,
    /// One view (`eye`).
    Single,
    /// A Looking Glass quilt (`quilt`).
    Quilt,
}

impl View {
    /// The layout of the job (wiggle and single eye take the views as they are).
    pub fn layout(self) -> LayoutSpec {
        match self {
            View::Anaglyph => LayoutSpec::Anaglyph,
            View::Sbs => LayoutSpec::Sbs,
            View::Cross => LayoutSpec::Cross,
            View::Wiggle | View::Single => LayoutSpec::Separate,
            View::Quilt => LayoutSpec::Quilt,
        }
    }
}

/// The viewpoint as the page's numbers: `--from`, `--at`, `--up`, `--fov`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSettings {
    pub from: [f32; 3],
    pub at: [f32; 3],
    pub up: [f32; 3],
    /// Vertical field of view, degrees.
    pub fov: f32,
}

/// The page's controls.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Settings {
    /// Views rendered (2: a stereo pair; 1: a panorama's one eye).
    pub views: usize,
    /// `auto` or a distance between adjacent views (scene units).
    pub interaxial: String,
    /// `auto`, `near`, `inf` or a distance.
    pub convergence: String,
    /// `NEAR,FAR` in per cent or pixels (empty: the default, -1%,+2%).
    pub depth_budget: String,
    /// A panorama's budget: the nearest point's angular disparity, degrees
    /// (`None`: the command line's, 1° by default).
    pub angular_budget: Option<f64>,
    pub view: View,
    /// The view a single-eye display shows (0: the leftmost).
    pub eye: usize,
    /// The grid of a quilt, `COLSxROWS`.
    pub quilt: String,
    /// Samples per pixel of the final pass (`None`: the command line's
    /// sampling, adaptive by default).
    pub samples: Option<u32>,
    /// The fast method (`--fast`) instead of the exact one.
    pub fast: bool,
    /// `None`: the command line's (or the scene's) camera.
    pub camera: Option<CameraSettings>,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            views: 2,
            interaxial: "auto".into(),
            convergence: "auto".into(),
            depth_budget: String::new(),
            angular_budget: None,
            view: View::Anaglyph,
            eye: 0,
            quilt: "4x2".into(),
            samples: None,
            fast: false,
            camera: None,
        }
    }
}

/// A setting the page sent that the job cannot take.
#[derive(Debug, PartialEq, Eq)]
pub struct Refused(pub String);

impl Settings {
    /// The page's first settings: the command line's rig and layout where
    /// it gave them, a stereo pair in anaglyph otherwise (one eye for a
    /// panorama of one view).
    pub fn from_spec(spec: &JobSpec) -> Settings {
        let d = Settings::default();
        let r = &spec.rig;
        let mono_panorama = is_panorama(spec) && !r.stereo && r.views.is_none_or(|n| n < 2);
        if mono_panorama {
            return Settings {
                views: 1,
                view: View::Single,
                fast: false,
                ..d
            };
        }
        let view = match spec.output.layout {
            LayoutSpec::Sbs => View::Sbs,
            LayoutSpec::Cross => View::Cross,
            LayoutSpec::Quilt => View::Quilt,
            LayoutSpec::Separate if r.views.is_some_and(|n| n > 2) => View::Wiggle,
            _ => View::Anaglyph,
        };
        let views = match (r.views, view) {
            (Some(n), _) => n,
            (None, View::Quilt) => 8,
            (None, _) => 2,
        };
        Settings {
            views,
            interaxial: r.interaxial.clone().unwrap_or(d.interaxial),
            convergence: r.convergence.clone().unwrap_or(d.convergence),
            depth_budget: r.depth_budget.clone().unwrap_or_default(),
            angular_budget: r.angular_budget,
            view,
            quilt: spec.output.quilt.clone().unwrap_or(d.quilt),
            samples: None,
            fast: spec.method.name == MethodName::Fast,
            ..d
        }
    }

    /// The spec these settings describe over `base` (the command line's),
    /// rendering `size` to `output`.
    pub fn spec(&self, base: &JobSpec, size: Option<[u32; 2]>, output: &Path) -> JobSpec {
        let panorama = is_panorama(base);
        let mut spec = base.clone();
        spec.camera.size = size;
        if let Some(c) = self.camera {
            spec.camera.from = Some(c.from);
            spec.camera.at = Some(c.at);
            spec.camera.up = Some(c.up);
            // A panorama's field of view is its projection's.
            if !panorama {
                spec.camera.fov = Some(c.fov);
            }
        }
        let r = &mut spec.rig;
        // A pair is --stereo; a quilt of as many views as tiles needs no --views.
        let quilt_tiles = self
            .quilt
            .parse::<twinray::output::QuiltSpec>()
            .ok()
            .map(|q| q.layout.tiles());
        r.stereo = self.views == 2 && self.view != View::Quilt;
        let whole_quilt = self.view == View::Quilt && quilt_tiles == Some(self.views);
        r.views = (!r.stereo && !whole_quilt && self.views != 1).then_some(self.views);
        let text = |s: &str| (!s.trim().is_empty()).then(|| s.trim().to_string());
        // `auto` is the default interaxial, and then the default convergence
        // (with a given interaxial the default is the scene's `at` point).
        let auto = |s: &Option<String>| s.as_deref() == Some("auto");
        r.interaxial = text(&self.interaxial).filter(|i| i != "auto");
        r.convergence = text(&self.convergence);
        if r.interaxial.is_none() && auto(&r.convergence) {
            r.convergence = None;
        }
        r.depth_budget = text(&self.depth_budget);
        if self.angular_budget.is_some() {
            r.angular_budget = self.angular_budget;
        }
        if panorama && auto(&r.convergence) {
            r.convergence = None;
        }
        // The command line's --view-cone spaces the views until the page
        // asks for an interaxial of its own.
        if r.interaxial.is_some() {
            r.view_cone = None;
        }
        let o = &mut spec.output;
        o.path = output.to_path_buf();
        o.layout = self.view.layout();
        o.quilt = (self.view == View::Quilt).then(|| self.quilt.clone());
        o.anaglyph = o.anaglyph.filter(|_| self.view == View::Anaglyph);
        o.squeeze = false;
        o.interlace = None;
        o.depth = false;
        o.stats = None;
        if let Some(n) = self.samples {
            spec.sampling = SamplingSpec {
                samples: Some(n),
                ..SamplingSpec::default()
            };
        }
        // The page's switch between the exact and the fast method; the
        // command line's reference method stays unless the page asks for
        // the fast one.
        let m = &mut spec.method;
        m.name = match (self.fast, m.name) {
            (true, _) => MethodName::Fast,
            (false, MethodName::Fast) => MethodName::Twin,
            (false, name) => name,
        };
        if !self.fast {
            m.tolerance = None;
        }
        spec
    }

    /// What only the page can get wrong (the job checks the rest): for the
    /// command line's `base`, whose projection decides whether one view is
    /// a preview (a panorama's one eye) or not.
    pub fn check(&self, base: &JobSpec) -> Result<(), Refused> {
        if self.view == View::Single && self.eye >= self.views {
            return Err(Refused(format!(
                "eye {}: the views are numbered 0 to {}",
                self.eye,
                self.views.saturating_sub(1)
            )));
        }
        if self.views < 2 && !(self.views == 1 && is_panorama(base)) {
            return Err(Refused(format!(
                "views {}: a stereo preview needs at least 2 views (one eye: a panorama's only)",
                self.views
            )));
        }
        if let Some(c) = &self.camera {
            let finite = c
                .from
                .iter()
                .chain(&c.at)
                .chain(&c.up)
                .all(|v| v.is_finite());
            if !finite || !c.fov.is_finite() {
                return Err(Refused("the camera's numbers must be finite".into()));
            }
        }
        Ok(())
    }
}

/// Whether the command line asks for a panorama (`--projection`).
pub fn is_panorama(spec: &JobSpec) -> bool {
    spec.camera.projection != ProjectionName::Pinhole
}

/// The file name a full-size render of `scene` writes: `-o`'s if given,
/// else the scene's stem with `.png`.
pub fn output_name(scene: &Path, output: &Path) -> PathBuf {
    if !output.as_os_str().is_empty() {
        return output.to_path_buf();
    }
    let stem = scene
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "render".into());
    PathBuf::from(format!("{stem}.png"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_lay_over_the_command_line() {
        let mut base = JobSpec::new("s.nff", "");
        base.trace.max_depth = 3;
        base.output.srgb = true;
        let mut s = Settings::from_spec(&base);
        assert_eq!(s, Settings::default());
        s.interaxial = "0.25".into();
        s.view = View::Cross;
        s.samples = Some(4);
        let spec = s.spec(&base, Some([48, 27]), Path::new("/tmp/x.png"));
        assert_eq!(spec.trace.max_depth, 3);
        assert!(spec.output.srgb);
        assert!(spec.rig.stereo);
        assert_eq!(spec.rig.views, None);
        assert_eq!(spec.rig.interaxial.as_deref(), Some("0.25"));
        assert_eq!(spec.rig.depth_budget, None);
        assert_eq!(spec.output.layout, LayoutSpec::Cross);
        assert_eq!(spec.sampling.samples, Some(4));
        assert_eq!(spec.camera.size, Some([48, 27]));
    }

    #[test]
    fn a_panoramas_rig_is_its_ipd_and_angular_budget() {
        let mut base = JobSpec::new("s.nff", "");
        base.camera.projection = ProjectionName::Ods;
        base.rig.stereo = true;
        base.rig.angular_budget = Some(1.5);
        let mut s = Settings::from_spec(&base);
        assert_eq!((s.views, s.angular_budget), (2, Some(1.5)));
        // The page's `auto` convergence is the projection's own.
        s.interaxial = "0.2".into();
        let spec = s.spec(&base, None, Path::new("x.png"));
        assert_eq!(spec.rig.convergence, None);
        assert_eq!(spec.rig.interaxial.as_deref(), Some("0.2"));
        assert_eq!(spec.rig.angular_budget, Some(1.5));
        s.angular_budget = Some(3.0);
        s.convergence = "2".into();
        let spec = s.spec(&base, None, Path::new("x.png"));
        assert_eq!(spec.rig.angular_budget, Some(3.0));
        // A distance is passed on, for the job to refuse with its message.
        assert_eq!(spec.rig.convergence.as_deref(), Some("2"));

        // One eye: a panorama's preview, not a flat rig's.
        base.rig.stereo = false;
        base.camera.projection = ProjectionName::Equirect;
        let s = Settings::from_spec(&base);
        assert_eq!((s.views, s.view), (1, View::Single));
        assert_eq!(s.check(&base), Ok(()));
        let spec = s.spec(&base, None, Path::new("x.png"));
        assert!(!spec.rig.stereo);
        assert_eq!(spec.rig.views, None);
        assert!(s.check(&JobSpec::new("s.nff", "")).is_err());
    }

    #[test]
    fn the_command_lines_rig_becomes_the_first_settings() {
        let mut base = JobSpec::new("s.nff", "");
        base.rig.views = Some(8);
        base.rig.interaxial = Some("0.1".into());
        base.output.layout = LayoutSpec::Quilt;
        base.output.quilt = Some("4x2".into());
        let s = Settings::from_spec(&base);
        assert_eq!((s.views, s.view), (8, View::Quilt));
        assert_eq!(s.interaxial, "0.1");
    }

    #[test]
    fn what_only_the_page_can_get_wrong_is_refused() {
        let s = Settings {
            view: View::Single,
            eye: 2,
            ..Settings::default()
        };
        assert_eq!(
            s.check(&JobSpec::new("s.nff", "")),
            Err(Refused("eye 2: the views are numbered 0 to 1".into()))
        );
        assert!(Settings {
            views: 1,
            ..Settings::default()
        }
        .check(&JobSpec::new("s.nff", ""))
        .is_err());
        assert!(Settings::default()
            .check(&JobSpec::new("s.nff", ""))
            .is_ok());
    }

    #[test]
    fn the_output_is_named_after_the_scene() {
        assert_eq!(
            output_name(Path::new("a/balls.nff"), Path::new("")),
            PathBuf::from("balls.png")
        );
        assert_eq!(
            output_name(Path::new("a/balls.nff"), Path::new("x.jpg")),
            PathBuf::from("x.jpg")
        );
    }
}
