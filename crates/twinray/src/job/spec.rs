//! `JobSpec`: a render described as plain data, the same whether it comes
//! from the command line, a saved JSON file (`twinray render --job`), the
//! preview server or a distributed driver.
//!
//! Every field has the command line's default (`#[serde(default)]`), so a
//! spec names only what differs, and unknown fields are refused (a typo in a
//! saved job is an error, not a silent default; a field that was removed is
//! refused with what replaced it, [`removed_field`]). Values that the command line
//! takes as text with a grammar of their own (an interaxial of `auto` or a
//! distance, a convergence of `near`, a depth budget `-1%,+2%`, a quilt `8x6`)
//! stay that text here and are parsed by [`Job::check`](super::Job::check),
//! so a spec reads as the command that made it.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::named::named_values;
use crate::render::{Filter, ReprojectMode};
pub use crate::rig::panorama_rig::SceneUnits;
use crate::rig::ProjectionName;

/// A whole render: what to load, how to look at it, which views, how to
/// sample and trace them, and what to write.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct JobSpec {
    /// Scene file: .nff, .obj (with its .mtl), .gltf, .glb, .stl or .ply.
    pub scene: PathBuf,
    pub camera: CameraSpec,
    pub rig: RigSpec,
    pub sampling: SamplingSpec,
    /// How the views are computed, and the method's options.
    pub method: MethodSpec,
    pub trace: TraceSpec,
    pub output: OutputSpec,
    pub limits: LimitSpec,
    /// Frames of an animation (none: a still).
    #[serde(default)]
    pub animation: AnimationSpec,
    /// One band of the image (none: the whole image).
    #[serde(default)]
    pub tile: Option<TileSpec>,
    /// What surrounds a model: the background.
    #[serde(default)]
    pub studio: StudioSpec,
    /// Files read to make this spec (its job file, an animation's camera
    /// path), which no output may replace; not part of the spec's JSON.
    #[serde(skip)]
    pub read_files: Vec<PathBuf>,
}

/// What surrounds the scene, replacing the file's where given.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StudioSpec {
    /// Background colour, linear RGB (default: the file's; black for OBJ and glTF).
    pub background: Option<[f32; 3]>,
    /// Which axis is up in a file without a camera (default: auto).
    pub up_axis: UpAxisSpec,
    /// Point lights added to the scene (`--light`); for a model file without
    /// lights they replace the default key/fill/rim rig.
    #[serde(default)]
    pub lights: Vec<LightSpec>,
    /// A diffuse grey floor under the model (`--ground`), so that its shadows show.
    #[serde(default)]
    pub ground: bool,
    /// An equirectangular environment image, `.hdr` or `.exr` (`--env`):
    /// seen by rays that leave the scene, and ambient light
    /// ([`crate::environment`]). Conflicts with `background`.
    #[serde(default)]
    pub env: Option<PathBuf>,
}

/// A point light of the command line, in scene units; no falloff with distance.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    pub position: [f32; 3],
    /// Linear RGB (default white, 1,1,1).
    #[serde(default = "white")]
    pub color: [f32; 3],
}

fn white() -> [f32; 3] {
    [1.0; 3]
}

/// The up axis of a model file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum UpAxisSpec {
    Y,
    Z,
    /// y for glTF (its specification's); for OBJ, STL and PLY, which do not
    /// say, guessed from the model's base ([`crate::rig::up_axis`]).
    #[default]
    Auto,
}

named_values!(UpAxisSpec {
    Y = "y",
    Z = "z",
    Auto = "auto",
});

/// The viewpoint and the image size; `None` keeps the file's.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraSpec {
    /// Image size in pixels, `[width, height]` (default: the scene's; 512x512
    /// with the SPD procedure; a quilt preset's view size).
    pub size: Option<[u32; 2]>,
    /// One of a glTF file's cameras: its name or its index.
    pub camera: Option<String>,
    pub from: Option<[f32; 3]>,
    pub at: Option<[f32; 3]>,
    pub up: Option<[f32; 3]>,
    /// Vertical field of view in degrees.
    pub fov: Option<f32>,
    /// How image positions become rays: `pinhole` (the default), or a
    /// panorama for headsets: `equirect` (360°, one eye), `ods` (360°
    /// omni-directional stereo), `vr180` or `vr180-fisheye`.
    pub projection: ProjectionName,
    /// `ods`: the latitudes, degrees, where the eyes start to merge toward
    /// the poles and where they are one (default 60, 75).
    pub pole_merge: Option<[f64; 2]>,
}

/// How many views, and how they are spaced and converged.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RigSpec {
    /// A stereo pair (the same as `views: 2`).
    pub stereo: bool,
    /// Views of a multi-view set (default 1, 2 with `stereo`, a quilt's tiles).
    pub views: Option<usize>,
    /// Distance between adjacent views: a number of scene units or `auto`
    /// (the default: fitted to the depth budget).
    pub interaxial: Option<String>,
    /// Zero-parallax distance: a number, `inf`, `auto` or `near`.
    pub convergence: Option<String>,
    /// Disparity allowed between adjacent views, `NEAR,FAR` (default `-1%,+2%`).
    pub depth_budget: Option<String>,
    /// The angle the outer views span, seen from the convergence point, degrees.
    pub view_cone: Option<f64>,
    /// Width of the screen the pair is for, metres (for the divergence check).
    pub screen_width: f64,
    /// Black bars where objects in front of the screen touch the frame's edges.
    pub floating_window: bool,
    /// A panorama's depth budget: the angular disparity allowed for the
    /// nearest visible point, degrees (default 1).
    pub angular_budget: Option<f64>,
    /// The scene's length unit: a panorama's automatic IPD is then at most
    /// the eyes' 64 mm (default: metres for glTF, whose unit it is;
    /// unknown for the other formats).
    pub units: Option<SceneUnits>,
}

impl Default for RigSpec {
    fn default() -> Self {
        RigSpec {
            stereo: false,
            views: None,
            interaxial: None,
            convergence: None,
            depth_budget: None,
            view_cone: None,
            screen_width: crate::rig::report::DEFAULT_SCREEN_WIDTH_M,
            floating_window: false,
            angular_budget: None,
            units: None,
        }
    }
}

/// Anti-aliasing. The default is the paper's adaptive refinement.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SamplingSpec {
    /// The SPD procedure: 512x512, corner rays averaged, every secondary ray.
    pub spd: bool,
    /// N stratified samples per pixel (1: the pixel centre).
    pub samples: Option<u32>,
    pub filter: Option<Filter>,
    /// Pattern of `samples` (default 0).
    pub seed: Option<u32>,
    /// Adaptive threshold (default 1/32).
    pub adaptive: Option<f32>,
    /// Most cells per pixel of adaptive sampling (default 16).
    pub max_samples: Option<u32>,
}

/// How the views are computed (`twin`, the default: exact), and the options
/// of the method chosen. Options of another method are refused by
/// [`Job::check`](super::Job::check), not ignored.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MethodSpec {
    pub name: MethodName,
    /// `fast`: the error it may add per channel, in image values (1 =
    /// white; default 0.01).
    pub tolerance: Option<f32>,
    /// `twin`: the paper's merged secondary rays.
    pub merge_secondary: bool,
    /// `twin`: the paper's reprojection, `safe` or `paper`.
    pub reproject: Option<ReprojectMode>,
    /// `twin`, with `reproject`: the largest mirror, highlight or
    /// transmission weight treated as diffuse (default 0.1).
    pub reproject_threshold: Option<f32>,
    /// `twin`: the paper's cut of the object tree.
    pub cut: Option<CutSpec>,
}

/// The view methods by name (see `render::ViewMethod`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MethodName {
    /// Each view rendered alone: the reference.
    Independent,
    /// Twin objects (the paper's method): exact, and faster.
    #[default]
    Twin,
    /// The one approximate method, within `tolerance`.
    Fast,
}

named_values!(MethodName {
    Independent = "independent",
    Twin = "twin",
    Fast = "fast",
});

/// Where the paper's cut of the object tree lies: objects entirely beyond
/// it are seen by every view as the rig's centre sees them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", deny_unknown_fields)]
pub enum CutSpec {
    /// At this depth (scene units, along the view direction from the rig's
    /// centre).
    Distance(f32),
    /// At the depth where a cut object's disparity is off by at most this
    /// many pixels (depth = focal length in pixels × the outer views'
    /// distance / pixels).
    Parallax(f64),
}

/// Limits of the ray tree, and the worker threads.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TraceSpec {
    /// Deepest ray level (the eye ray is 1).
    pub max_depth: u32,
    /// Secondary rays below this weight are not traced (default 1/256).
    pub min_weight: Option<f32>,
    /// Worker threads (default: every core). The image does not depend on it.
    pub threads: Option<usize>,
}

impl Default for TraceSpec {
    fn default() -> Self {
        TraceSpec {
            max_depth: 5,
            min_weight: None,
            threads: None,
        }
    }
}

/// What is written, where, and how.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OutputSpec {
    /// The output image (several views: `NAME_L`/`NAME_R` or `NAME_0`, …).
    pub path: PathBuf,
    pub layout: LayoutSpec,
    /// Half-width (sbs, cross) or half-height (tb) frames.
    pub squeeze: bool,
    pub anaglyph: Option<AnaglyphSpec>,
    pub interlace: Option<InterlaceSpec>,
    /// Accepted for jobs saved before sRGB became the default of 8-bit
    /// outputs; it changes nothing (see `linear`).
    pub srgb: bool,
    /// Z and disparity channels in .exr outputs.
    pub depth: bool,
    /// Grid of a quilt: `COLSxROWS` or a preset (`portrait`, `go`, `legacy`).
    pub quilt: Option<String>,
    /// Statistics as JSON.
    pub stats: Option<PathBuf>,
    /// 8-bit outputs store linear values (no sRGB curve; the default encodes
    /// them with the sRGB curve, as viewers expect). Float outputs are always linear.
    #[serde(default)]
    pub linear: bool,
    /// Exposure of 8-bit outputs in stops (values times 2^EV before the tone curve).
    #[serde(default)]
    pub exposure: f32,
    /// Tone curve of 8-bit outputs.
    #[serde(default)]
    pub tonemap: TonemapSpec,
}

/// The tone curve of 8-bit outputs (see [`crate::output::display`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TonemapSpec {
    /// Values above 1 clip.
    #[default]
    Clamp,
    /// Narkowicz's ACES filmic fit.
    Aces,
    /// AgX (Blender 4's default view).
    Agx,
}

named_values!(TonemapSpec {
    Clamp = "clamp",
    Aces = "aces",
    Agx = "agx",
});

/// How the views are delivered.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LayoutSpec {
    #[default]
    Separate,
    Sbs,
    Cross,
    Tb,
    Anaglyph,
    Interlace,
    Mpo,
    Multiview,
    Quilt,
}

named_values!(LayoutSpec {
    Separate = "separate",
    Sbs = "sbs",
    Cross = "cross",
    Tb = "tb",
    Anaglyph = "anaglyph",
    Interlace = "interlace",
    Mpo = "mpo",
    Multiview = "multiview",
    Quilt = "quilt",
});

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AnaglyphSpec {
    Dubois,
    Color,
    Gray,
    GreenMagenta,
    YellowBlue,
}

named_values!(AnaglyphSpec {
    Dubois = "dubois",
    Color = "color",
    Gray = "gray",
    GreenMagenta = "green-magenta",
    YellowBlue = "yellow-blue",
});

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum InterlaceSpec {
    Rows,
    Columns,
    Checker,
}

named_values!(InterlaceSpec {
    Rows = "rows",
    Columns = "columns",
    Checker = "checker",
});

/// Caps on what a scene file may ask for.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LimitSpec {
    /// Largest image side.
    pub max_resolution: u32,
    /// Most vertices of one polygon or patch.
    pub max_vertices: usize,
    /// Most triangles of an OBJ or glTF file.
    pub max_triangles: u64,
    /// Folders beside the scene's own whose files the scene may name
    /// (`--allow-dir`): textures and buffers kept elsewhere.
    pub allow_dirs: Vec<PathBuf>,
}

impl Default for LimitSpec {
    fn default() -> Self {
        let load = crate::loaders::LoadOptions::default();
        LimitSpec {
            max_resolution: load.max_resolution,
            max_vertices: load.max_vertices,
            max_triangles: load.max_triangles,
            allow_dirs: load.allow_dirs,
        }
    }
}

impl JobSpec {
    /// A spec that renders `scene` to `output` with every default.
    pub fn new(scene: impl Into<PathBuf>, output: impl Into<PathBuf>) -> JobSpec {
        JobSpec {
            scene: scene.into(),
            output: OutputSpec {
                path: output.into(),
                ..OutputSpec::default()
            },
            ..JobSpec::default()
        }
    }

    /// The spec as pretty JSON (what `twinray render --print-job` writes).
    pub fn to_json(&self) -> String {
        // Plain data with string keys: serialisation cannot fail.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// A spec from JSON, with the position of the first error; a field
    /// that was removed is refused with what replaced it.
    pub fn from_json(text: &str) -> crate::Result<JobSpec> {
        let invalid = |e: String| crate::Error::Invalid(format!("job spec: {e}"));
        if let Ok(value) = serde_json::from_str::<serde_json::Value>(text) {
            if let Some(removed) = removed_field(&value) {
                return Err(invalid(removed));
            }
        }
        serde_json::from_str(text).map_err(|e| invalid(e.to_string()))
    }
}

/// A sequence of frames (`--frames A..B`): the camera's motion, the rate and
/// how the rig is chosen over the shot. Run by
/// [`Animation`](crate::animation::Animation); a still ([`Job`](super::Job))
/// refuses a spec with frames.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AnimationSpec {
    /// Inclusive frame range `A..B` (`None`: a still).
    pub frames: Option<String>,
    /// Frames per second of a video output, and of keyframe times.
    pub fps: f64,
    /// A turntable: `from` turns this many degrees about the `up` axis
    /// through `at` over the range (360: a seamless loop).
    pub orbit: Option<f64>,
    /// Keyframes of from/at/up/fov, interpolated by a Catmull-Rom spline.
    pub path: Option<PathBuf>,
    /// The automatic rig chosen once per shot (default) or per frame.
    pub rig: ShotRigSpec,
    /// Skip frames whose files already exist (a resumed run).
    pub skip_existing: bool,
    /// Render only these frames `C..D` of the shot (a machine's share): the
    /// motion and the shot's rig stay those of the whole range.
    #[serde(default)]
    pub only: Option<String>,
    /// The codec of a video output.
    #[serde(default)]
    pub codec: crate::video::Codec,
    /// The encoder's constant rate factor of a video output, 0 (lossless)
    /// to 51 (`None`: the codec's visually lossless default).
    #[serde(default)]
    pub crf: Option<u32>,
    /// glTF: the one animation that plays (`--animation NAME|INDEX`); `None`:
    /// every animation of the file at once.
    #[serde(default)]
    pub clip: Option<String>,
}

impl Default for AnimationSpec {
    fn default() -> Self {
        AnimationSpec {
            frames: None,
            fps: 24.0,
            orbit: None,
            path: None,
            rig: ShotRigSpec::PerShot,
            skip_existing: false,
            only: None,
            codec: Default::default(),
            crf: None,
            clip: None,
        }
    }
}

/// When the automatic rig (interaxial, convergence) is chosen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ShotRigSpec {
    /// Once, from depth passes over sampled frames: a rig that does not jump.
    #[default]
    PerShot,
    /// For every frame on its own depths.
    PerFrame,
}

named_values!(ShotRigSpec {
    PerShot = "per-shot",
    PerFrame = "per-frame",
});

/// One horizontal band of a still, for rendering across machines: tile
/// `index` of `count`, merged by `twinray merge` into the one-machine image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TileSpec {
    pub index: u32,
    pub count: u32,
}

/// A field a saved job may still have that the spec no longer takes, and
/// what replaced it.
#[derive(Clone, Copy, Debug)]
pub struct RemovedField {
    /// Its path, `section.field`.
    pub path: &'static str,
    pub instead: &'static str,
}

const EXACT: &str = "the twin method computes every view exactly and measured faster; for speed set \"method\": {\"name\": \"fast\"}";

/// Every removed field of a saved job.
pub const REMOVED_FIELDS: &[RemovedField] = &[
    RemovedField {
        path: "rig.method",
        instead: "the method is \"method\": {\"name\": \"twin\" | \"independent\" | \"fast\"} now",
    },
    RemovedField {
        path: "rig.views_per_batch",
        instead: "the views are traced in batches of 4 neighbours, which measured fastest",
    },
    RemovedField {
        path: "rig.strip",
        instead: EXACT,
    },
    RemovedField {
        path: "rig.eye_runs",
        instead: EXACT,
    },
    RemovedField {
        path: "rig.shadow_fans",
        instead: EXACT,
    },
    RemovedField {
        path: "approximations",
        instead: "the method and its options are \"method\" now: {\"name\": \"fast\", \"tolerance\": E} for the approximate method (it takes the shared shading and the epipolar rows), or the twin method's \"merge_secondary\", \"reproject\" (\"safe\" or \"paper\"), \"reproject_threshold\" and \"cut\" ({\"distance\": D} or {\"parallax\": PX})",
    },
];

/// The first removed field of a job's JSON, as `PATH was removed: ...`.
pub fn removed_field(json: &serde_json::Value) -> Option<String> {
    REMOVED_FIELDS.iter().find_map(|r| {
        let pointer = format!("/{}", r.path.replace('.', "/"));
        json.pointer(&pointer)
            .map(|_| format!("{} was removed: {}", r.path, r.instead))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::named::serde_names_agree;

    /// Each named value is spelt alike by a saved job and the command line.
    #[test]
    fn named_values_are_their_serde_names() {
        assert!(serde_names_agree(&[
            MethodName::Independent,
            MethodName::Twin,
            MethodName::Fast
        ]));
        assert!(serde_names_agree(&[
            UpAxisSpec::Y,
            UpAxisSpec::Z,
            UpAxisSpec::Auto
        ]));
        assert!(serde_names_agree(&[
            TonemapSpec::Clamp,
            TonemapSpec::Aces,
            TonemapSpec::Agx
        ]));
        let layouts = LayoutSpec::NAMES
            .iter()
            .map(|n| n.parse::<LayoutSpec>().unwrap());
        assert!(serde_names_agree(&layouts.collect::<Vec<_>>()));
        let anaglyphs = AnaglyphSpec::NAMES
            .iter()
            .map(|n| n.parse::<AnaglyphSpec>().unwrap());
        assert!(serde_names_agree(&anaglyphs.collect::<Vec<_>>()));
        let patterns = InterlaceSpec::NAMES
            .iter()
            .map(|n| n.parse::<InterlaceSpec>().unwrap());
        assert!(serde_names_agree(&patterns.collect::<Vec<_>>()));
        assert!(serde_names_agree(&[
            ShotRigSpec::PerShot,
            ShotRigSpec::PerFrame
        ]));
        assert!(serde_names_agree(&[
            Filter::Box,
            Filter::Tent,
            Filter::Gaussian
        ]));
        assert!(serde_names_agree(&[
            ReprojectMode::Safe,
            ReprojectMode::Paper
        ]));
        assert!("hologram".parse::<LayoutSpec>().is_err());
    }

    /// A saved job with a field that was removed is refused with what
    /// replaced it, not serde's list of expected fields.
    #[test]
    fn removed_fields_are_refused_with_their_replacement() {
        for (json, fragment) in [
            (
                r#"{"rig": {"strip": true}}"#,
                "rig.strip was removed: the twin method",
            ),
            (r#"{"rig": {"method": "twin"}}"#, "\"method\": {\"name\""),
            (
                r#"{"approximations": {"fast": true}}"#,
                "\"name\": \"fast\"",
            ),
            (r#"{"rig": {"views_per_batch": 8}}"#, "batches of 4"),
        ] {
            let err = JobSpec::from_json(json).err().map(|e| e.to_string());
            assert!(
                err.as_deref().is_some_and(|e| e.contains(fragment)),
                "{json}: {err:?}"
            );
        }
        let fast = JobSpec::from_json(r#"{"method": {"name": "fast", "tolerance": 0.02}}"#);
        let fast = fast.expect("the fast method");
        assert_eq!(
            (fast.method.name, fast.method.tolerance),
            (MethodName::Fast, Some(0.02))
        );
        let cut = JobSpec::from_json(r#"{"method": {"cut": {"parallax": 0.5}}}"#).expect("a cut");
        assert_eq!(cut.method.cut, Some(CutSpec::Parallax(0.5)));
    }
}
