//! `JobSpec`: a render described as plain data, the same whether it comes
//! from the command line, a saved JSON file (`twinray render --job`), the
//! preview server or a distributed driver.
//!
//! Every field has the command line's default (`#[serde(default)]`), so a
//! spec names only what differs, and unknown fields are refused (a typo in a
//! saved job is an error, not a silent default). Values that the command line
//! takes as text with a grammar of their own (an interaxial of `auto` or a
//! distance, a convergence of `near`, a depth budget `-1%,+2%`, a quilt `8x6`)
//! stay that text here and are parsed by [`Job::check`](super::Job::check),
//! so a spec reads as the command that made it.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

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
    pub approximations: ApproximationSpec,
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
    pub method: MethodSpec,
    /// Twin method: most views traced as one packet (default 4).
    pub views_per_batch: Option<usize>,
    /// Twin method: the eye pass of every view in one descent per camera
    /// column (`--strip`); the same images.
    pub strip: bool,
    /// Twin method: the strip's families resolved by eye runs (`--eye-runs`:
    /// a few views traced alone, the views between proved); the same images.
    #[serde(default)]
    pub eye_runs: bool,
    /// Twin method: shadow rays of runs of views' hits on one primitive
    /// proved free by one shadow fan per light (`--shadow-fans`); the same
    /// images.
    #[serde(default)]
    pub shadow_fans: bool,
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
            method: MethodSpec::Twin,
            views_per_batch: None,
            strip: false,
            eye_runs: false,
            shadow_fans: false,
        }
    }
}

/// How the views are computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MethodSpec {
    /// Every view a render of its own: the reference.
    Independent,
    /// Twin objects (the paper's method): exact, and faster.
    #[default]
    Twin,
}

/// Anti-aliasing. The default is the paper's adaptive refinement.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SamplingSpec {
    /// The SPD procedure: 512x512, corner rays averaged, every secondary ray.
    pub spd: bool,
    /// N stratified samples per pixel (1: the pixel centre).
    pub samples: Option<u32>,
    pub filter: Option<FilterSpec>,
    /// Pattern of `samples` (default 0).
    pub seed: Option<u32>,
    /// Adaptive threshold (default 1/32).
    pub adaptive: Option<f32>,
    /// Most cells per pixel of adaptive sampling (default 16).
    pub max_samples: Option<u32>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FilterSpec {
    Box,
    Tent,
    Gaussian,
}

/// The paper's approximations (sections 2.3–2.5); none by default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ApproximationSpec {
    /// Section 2.4: merged reflected/refracted rays of one planar surface.
    pub merge_secondary: bool,
    /// Section 2.5: shading reprojected from view 0.
    pub reproject: bool,
    pub reproject_mode: ReprojectModeSpec,
    pub reproject_threshold: f32,
    /// Section 2.3: no twins beyond this depth.
    pub cut_distance: Option<f32>,
    /// Section 2.3, the depth chosen for at most this disparity error (pixels).
    pub cut_parallax: Option<f64>,
    /// All three at their defaults.
    pub fast: bool,
    /// Issue 16: the multi-view shading cache (also under `fast`).
    pub share_shading: bool,
    /// Its tolerance, in image values (see `render::SharedShading`).
    pub share_tolerance: f32,
    /// Key views for mirrors and glass under the shared shading: every K-th
    /// view of a group traced in full, 0 = adaptive, 1 (default) = none (see
    /// `render::Approximations`).
    pub key_spacing: usize,
    /// Issue 16: the views between proved key views of a camera column
    /// interpolated (`--interpolate-views`; not under `fast`, where it
    /// measured slower), within `share_tolerance`.
    pub interpolate_views: bool,
    /// Issue 16: only every `synthesis_spacing`-th view traced, the views
    /// between synthesized from them where that is plain and proved free
    /// (`--synthesize-views`), within `share_tolerance`.
    pub synthesize_views: bool,
    pub synthesis_spacing: usize,
    /// Issue 16: every view's eye hits of a row from the primitives that
    /// cross its plane, and diffuse colours shaded once for the views that
    /// see them (`--epipolar-views`), within `share_tolerance`.
    pub epipolar_views: bool,
}

impl Default for ApproximationSpec {
    fn default() -> Self {
        ApproximationSpec {
            merge_secondary: false,
            reproject: false,
            reproject_mode: ReprojectModeSpec::Safe,
            reproject_threshold: crate::render::Reprojection::DEFAULT_THRESHOLD,
            cut_distance: None,
            cut_parallax: None,
            fast: false,
            share_shading: false,
            share_tolerance: crate::render::SharedShading::DEFAULT_TOLERANCE,
            key_spacing: 1,
            interpolate_views: false,
            synthesize_views: false,
            synthesis_spacing: crate::render::ViewSynthesis::DEFAULT_SPACING,
            epipolar_views: false,
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReprojectModeSpec {
    #[default]
    Safe,
    Paper,
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

impl LayoutSpec {
    /// The command line's name of the layout.
    pub fn name(self) -> &'static str {
        match self {
            LayoutSpec::Separate => "separate",
            LayoutSpec::Sbs => "sbs",
            LayoutSpec::Cross => "cross",
            LayoutSpec::Tb => "tb",
            LayoutSpec::Anaglyph => "anaglyph",
            LayoutSpec::Interlace => "interlace",
            LayoutSpec::Mpo => "mpo",
            LayoutSpec::Multiview => "multiview",
            LayoutSpec::Quilt => "quilt",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AnaglyphSpec {
    Dubois,
    Color,
    Gray,
    GreenMagenta,
    YellowBlue,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum InterlaceSpec {
    Rows,
    Columns,
    Checker,
}

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

    /// A spec from JSON, with the position of the first error.
    pub fn from_json(text: &str) -> crate::Result<JobSpec> {
        serde_json::from_str(text).map_err(|e| crate::Error::Invalid(format!("job spec: {e}")))
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

/// One horizontal band of a still, for rendering across machines: tile
/// `index` of `count`, merged by `twinray merge` into the one-machine image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TileSpec {
    pub index: u32,
    pub count: u32,
}
