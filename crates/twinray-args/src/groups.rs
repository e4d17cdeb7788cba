//! The `render` command's flags, group by group as `render --help` shows
//! them, and the job spec they describe ([`RenderArgs::spec`]).
//!
//! Each flag's first line is its short help (`render -h`, one screen); the
//! rest of its comment is added by `render --help`. Flags most users never
//! set leave the short help (`hide_short_help`).

use std::path::PathBuf;

use clap::ValueEnum;

use twinray::job::{
    AnaglyphSpec, AnimationSpec, CameraSpec, CutSpec, InterlaceSpec, JobSpec, LayoutSpec,
    LightSpec, LimitSpec, MethodName, MethodSpec, OutputSpec, RigSpec, SamplingSpec, SceneUnits,
    ShotRigSpec, StudioSpec, TileSpec, TonemapSpec, TraceSpec, UpAxisSpec,
};
use twinray::math::Vec3;
use twinray::render::{Filter, ReprojectMode};
use twinray::rig::choice::Interaxial;
use twinray::rig::report as disparity;
use twinray::rig::ProjectionName;

use crate::values::{
    one_of, parse_budget, parse_light, parse_pole_merge, parse_quilt, parse_size, parse_vec3,
};

/// Everything `twinray render` (and `preview`) takes.
#[derive(clap::Args, Clone, Debug)]
pub struct RenderArgs {
    /// Scene file: .nff, .obj, .gltf, .glb, .stl or .ply.
    ///
    /// An .obj's .mtl is read beside it. With --job: the job's scene unless
    /// given.
    #[arg(required_unless_present = "job")]
    pub scene: Option<PathBuf>,

    #[command(flatten)]
    pub output: OutputArgs,

    #[command(flatten)]
    pub camera: CameraArgs,

    #[command(flatten)]
    pub rig: RigArgs,

    #[command(flatten)]
    pub sampling: SamplingArgs,

    #[command(flatten)]
    pub speed: SpeedArgs,

    #[command(flatten)]
    pub colour: ColourArgs,

    #[command(flatten)]
    pub animation: AnimationArgs,

    #[command(flatten)]
    pub studio: StudioArgs,

    #[command(flatten)]
    pub limits: LimitArgs,
}

/// What is written, and what is said.
#[derive(clap::Args, Clone, Debug)]
#[command(next_help_heading = "Output")]
pub struct OutputArgs {
    /// Output image: .png, .jpg, .exr, .pfm or .mpo.
    ///
    /// .png and .jpg are 8-bit (sRGB unless --linear), .exr and .pfm 32-bit
    /// float and linear, .mpo a stereo pair of JPEGs (--layout mpo). Several
    /// views as separate files: NAME_L/NAME_R for a pair, NAME_0, NAME_1, ...
    /// for more.
    #[arg(short, long, required_unless_present_any = ["job", "print_job"])]
    pub output: Option<PathBuf>,
    /// How the views are delivered (default: separate files).
    ///
    /// separate files, sbs (side by side), cross, tb (top-bottom), anaglyph,
    /// interlace, mpo, multiview (one EXR) or quilt.
    #[arg(long, value_name = "LAYOUT", default_value = "separate", hide_possible_values = true,
          hide_default_value = true, value_parser = one_of::<LayoutSpec>(LayoutSpec::NAMES))]
    pub layout: LayoutSpec,
    /// Half-width (sbs, cross) or half-height (tb) frames, as 3D TVs take.
    #[arg(long, hide_short_help = true)]
    pub squeeze: bool,
    /// Colours of --layout anaglyph (default dubois: red-cyan, least ghosting).
    ///
    /// dubois: red-cyan glasses, least ghosting; color and gray: plain
    /// red-cyan; green-magenta; yellow-blue.
    #[arg(long, value_name = "COLOURS", hide_short_help = true,
          value_parser = one_of::<AnaglyphSpec>(AnaglyphSpec::NAMES))]
    pub anaglyph: Option<AnaglyphSpec>,
    /// Pattern of --layout interlace: rows (the default), columns or checker.
    ///
    /// rows: line-interleaved 3D monitors; checker: DLP 3D displays. The
    /// left eye is on even rows, columns or x+y.
    #[arg(long, value_name = "PATTERN", hide_short_help = true,
          value_parser = one_of::<InterlaceSpec>(InterlaceSpec::NAMES))]
    pub interlace: Option<InterlaceSpec>,
    /// Grid of --layout quilt: COLSxROWS, or a device preset.
    ///
    /// Presets: portrait (8x6, 420x560 per view), go (11x6, 369x656),
    /// legacy (5x9, 768x480). The views default to COLS x ROWS, the size
    /// to the preset's; view 0 is bottom-left, the last top-right.
    #[arg(long, value_name = "COLSxROWS|PRESET", value_parser = parse_quilt)]
    pub quilt: Option<String>,
    /// Add depth (Z) and disparity channels to .exr outputs.
    ///
    /// Each view's depth along the view direction ("Z") and its disparity
    /// to the next view in pixels ("disparity"), for --layout separate or
    /// multiview.
    #[arg(long, hide_short_help = true)]
    pub depth: bool,
    /// Write statistics (ray counts, times, the rig) as JSON.
    #[arg(long, value_name = "FILE", hide_short_help = true)]
    pub stats: Option<PathBuf>,
    /// Render the job saved in FILE (JSON, as --print-job writes it).
    ///
    /// SCENE and -o, if given, replace its scene and output; no other flag
    /// may be given with it.
    #[arg(long, value_name = "FILE")]
    pub job: Option<PathBuf>,
    /// Print the job these flags describe as JSON, and render nothing.
    #[arg(long, hide_short_help = true)]
    pub print_job: bool,
    /// No progress bar, no notes (warnings and errors only).
    #[arg(short, long)]
    pub quiet: bool,
    /// Print the scene, the rig, the method's counts and timings.
    ///
    /// On stderr; the files written are listed at the end unless --quiet.
    #[arg(short, long)]
    pub verbose: bool,
}

/// Where the camera is and what it sees.
#[derive(clap::Args, Clone, Debug, Default)]
#[command(next_help_heading = "Camera")]
pub struct CameraArgs {
    /// Image size WxH of each view (default: the scene's).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// One of a glTF file's cameras, by name or index (default: the first).
    #[arg(long, hide_short_help = true)]
    pub camera: Option<String>,
    /// Camera position X,Y,Z (default: the file's camera, or one framing the scene).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub from: Option<Vec3>,
    /// The point the camera looks at, X,Y,Z.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub at: Option<Vec3>,
    /// Camera up direction X,Y,Z.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true,
          hide_short_help = true)]
    pub up: Option<Vec3>,
    /// Vertical field of view in degrees, top edge of the image to bottom.
    #[arg(long, value_name = "DEGREES")]
    pub fov: Option<f32>,
    /// pinhole (the default), or a panorama: equirect, ods, vr180, vr180-fisheye.
    ///
    /// equirect: 360°x180°, one eye. ods: omni-directional stereo, 360°
    /// with both eyes (--stereo; --layout tb puts the left on top). vr180:
    /// 180°x180° equirectangular; vr180-fisheye: an equidistant 180° fisheye
    /// (--stereo --layout sbs). The camera's from, at and up orient it;
    /// the default size is the scene's height, twice it across for 360°.
    #[arg(long, value_name = "PROJECTION", default_value = "pinhole",
          hide_default_value = true, value_parser = one_of::<ProjectionName>(ProjectionName::NAMES))]
    pub projection: ProjectionName,
    /// --projection ods: the latitudes where the eyes start to merge toward the poles, and are one (default 60,75).
    #[arg(long, value_name = "FROM,TO", value_parser = parse_pole_merge, hide_short_help = true)]
    pub pole_merge: Option<[f64; 2]>,
}

/// How many views, how far apart, where they converge.
#[derive(clap::Args, Clone, Debug)]
#[command(next_help_heading = "Views and rig")]
pub struct RigArgs {
    /// Render a stereo pair.
    #[arg(long)]
    pub stereo: bool,
    /// Render N views for a multi-view display.
    #[arg(long, value_name = "N")]
    pub views: Option<usize>,
    /// Distance between adjacent views, or auto (the default).
    ///
    /// In scene units; auto is the largest that fits the visible depths
    /// into --depth-budget.
    #[arg(long, allow_negative_numbers = true, value_name = "B|auto")]
    pub interaxial: Option<Interaxial>,
    /// Zero-parallax distance: a number, inf, auto or near.
    ///
    /// inf: parallel cameras; auto: fitted to --depth-budget; near: the
    /// nearest visible point. Default: auto, or the distance to the scene's
    /// 'at' point when --interaxial is a number.
    #[arg(long, allow_negative_numbers = true, value_name = "D|inf|auto|near")]
    pub convergence: Option<String>,
    /// Disparity allowed between adjacent views, NEAR,FAR (default -1%,+2%).
    ///
    /// In per cent of the image width (-1%,+2%: Sky's 3D guidelines) or
    /// pixels (-6px,12px). The automatic rig fits the visible depths into
    /// it; an explicit rig that exceeds it is warned about.
    #[arg(long, value_name = "NEAR,FAR", allow_hyphen_values = true, value_parser = parse_budget)]
    pub depth_budget: Option<String>,
    /// Space the views so that the outer two span this angle, in degrees.
    ///
    /// Seen from the convergence point, as light-field displays take it
    /// (the default of --layout quilt is 35).
    #[arg(
        long,
        value_name = "DEGREES",
        conflicts_with = "interaxial",
        hide_short_help = true
    )]
    pub view_cone: Option<f64>,
    /// Width of the screen the pair is for, in metres.
    ///
    /// Far points whose disparity there exceeds the eyes' 65 mm diverge
    /// (warned about).
    #[arg(long, value_name = "METRES", default_value_t = disparity::DEFAULT_SCREEN_WIDTH_M,
          hide_short_help = true)]
    pub screen_width: f64,
    /// Mask the frame's edges where objects in front of the screen touch them.
    ///
    /// Black bars on the left of the left view and the right of the right
    /// view, as wide as the violating disparity.
    #[arg(long, hide_short_help = true)]
    pub floating_window: bool,
    /// A panorama's depth budget: the angular disparity of the nearest point, degrees (default 1).
    ///
    /// The automatic IPD (--interaxial auto) is the largest that keeps
    /// every visible point within it, and at most 64 mm where the scene's
    /// unit is known (--units).
    #[arg(long, value_name = "DEGREES")]
    pub angular_budget: Option<f64>,
    /// The scene's length unit: m, cm, mm, in or ft (glTF: m).
    ///
    /// A panorama's automatic IPD is then at most the eyes' 64 mm.
    #[arg(long, value_name = "UNIT", value_parser = one_of::<SceneUnits>(SceneUnits::NAMES))]
    pub units: Option<SceneUnits>,
}

/// Anti-aliasing (default: the adaptive refinement).
#[derive(clap::Args, Clone, Debug, Default)]
#[command(next_help_heading = "Sampling (default: adaptive)")]
pub struct SamplingArgs {
    /// N samples per pixel (1: one ray through each pixel centre).
    ///
    /// Scrambled Sobol points, the same in every view, weighed by --filter.
    #[arg(long, value_name = "N", conflicts_with = "adaptive")]
    pub samples: Option<u32>,
    /// Reconstruction filter of --samples N: box (the default), tent or gaussian.
    ///
    /// box: the pixel's area, radius 0.5; tent: radius 1; gaussian: sigma
    /// 0.5, radius 1.5.
    #[arg(long, value_name = "FILTER", requires = "samples", hide_short_help = true,
          value_parser = one_of::<Filter>(Filter::NAMES))]
    pub filter: Option<Filter>,
    /// Another pattern of --samples N (0, the default, is the fixed one).
    ///
    /// Renders that differ only in the seed are uncorrelated.
    #[arg(long, value_name = "N", requires = "samples", hide_short_help = true)]
    pub seed: Option<u32>,
    /// Adaptive refinement (the default) with this threshold (default 1/32).
    ///
    /// The pixel corners are traced, then a cell is split in four where its
    /// corners differ by more than THRESHOLD (linear colour, any channel),
    /// down to --max-samples cells per pixel; each view refines its own.
    #[arg(long, value_name = "THRESHOLD", num_args = 0..=1, default_missing_value = "0.03125",
          allow_negative_numbers = true, hide_short_help = true)]
    pub adaptive: Option<f32>,
    /// Most cells per pixel of the adaptive sampling: 4, 16 (default), 64, 256 or 1024.
    #[arg(
        long,
        value_name = "N",
        conflicts_with = "samples",
        hide_short_help = true
    )]
    pub max_samples: Option<u32>,
    /// The SPD test procedure: corner rays averaged, every secondary ray.
    ///
    /// 512x512 unless --size, (W+1)x(H+1) rays through the pixel corners,
    /// each pixel the mean of its four; every reflected and refracted ray
    /// spawned, no cut-off.
    #[arg(long, hide_short_help = true)]
    pub spd: bool,
}

/// How fast the views are computed, and what that may cost.
#[derive(clap::Args, Clone, Debug, Default)]
#[command(next_help_heading = "Speed (the default is exact)")]
pub struct SpeedArgs {
    /// Faster views, each within --tolerance of the exact view.
    ///
    /// The one approximate method. Where every row of samples lies in one
    /// plane (--samples 1, --spd) the views' hits of a row are found from
    /// the primitives that cross its plane, and a diffuse surface's colour
    /// is shaded once for the views that see it; elsewhere more than two
    /// views share a shading cache of surface points' light (a pair is the
    /// exact pair). Mirrors, glass, highlights and shadow edges are traced
    /// by every view. See docs/stereo.md for the bound.
    #[arg(long)]
    pub fast: bool,
    /// Error --fast may add per colour channel, in image values (default 0.01).
    ///
    /// 1 is white; the bound holds where radiance is at most 1.
    #[arg(long, value_name = "E")]
    pub tolerance: Option<f32>,
    /// Worker threads, 1 to 1024 (default: all cores); the image is the same for any count.
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// The paper's merged secondary rays (approximate).
    ///
    /// The views' reflected and refracted rays from one planar surface are
    /// merged into one ray from the midpoint of their hits.
    #[arg(long, hide_short_help = true)]
    pub merge_secondary: bool,
    /// The paper's reprojection (approximate): views take view 0's diffuse shading.
    ///
    /// Where the other views see the point view 0 sees and its shading tree
    /// is diffuse (--reproject-threshold), they take its shading.
    #[arg(long, hide_short_help = true)]
    pub reproject: bool,
    /// How --reproject decides: safe (the default) or paper.
    ///
    /// safe: only where the receiving sample's own hit is the same surface
    /// point (no ghosts, no holes); paper: as published (view 0's colour
    /// goes where its hit projects, the nearest wins, holes are traced).
    #[arg(long, value_name = "MODE", requires = "reproject", hide_short_help = true,
          value_parser = one_of::<ReprojectMode>(ReprojectMode::NAMES))]
    pub reproject_mode: Option<ReprojectMode>,
    /// Largest mirror, highlight or transmission weight that --reproject treats as diffuse (default 0.1).
    #[arg(long, value_name = "W", requires = "reproject", hide_short_help = true)]
    pub reproject_threshold: Option<f32>,
    /// The paper's cut of the object tree at this depth (approximate).
    ///
    /// Objects entirely farther than the depth (scene units, along the view
    /// direction from the rig's centre) are seen by every view as the rig's
    /// centre sees them.
    #[arg(
        long,
        value_name = "DEPTH",
        conflicts_with = "cut_parallax",
        hide_short_help = true
    )]
    pub cut_distance: Option<f32>,
    /// The cut at the depth where a cut object's disparity is off by at most PX pixels.
    ///
    /// depth = focal length in pixels x the outer views' distance / PX.
    #[arg(long, value_name = "PX", hide_short_help = true)]
    pub cut_parallax: Option<f64>,
    /// How the views are computed: twin (the default) or independent (each view alone).
    ///
    /// independent renders each view on its own, one ray at a time: the
    /// reference every exactness test compares with, not a faster way.
    #[arg(long, value_name = "METHOD", hide = true,
          value_parser = one_of::<MethodName>(&["twin", "independent"]))]
    pub method: Option<MethodName>,
}

/// The colour of 8-bit outputs.
#[derive(clap::Args, Clone, Debug, Default)]
#[command(next_help_heading = "Colour of 8-bit outputs (.exr and .pfm stay as rendered)")]
pub struct ColourArgs {
    /// Store linear values in 8-bit outputs (the default applies the sRGB curve).
    #[arg(long, conflicts_with = "srgb", hide_short_help = true)]
    pub linear: bool,
    /// The default (sRGB-encoded 8-bit outputs); kept so older commands run.
    #[arg(long, hide = true)]
    pub srgb: bool,
    /// Exposure in stops: values times 2^EV before the tone curve.
    #[arg(
        long,
        value_name = "EV",
        default_value_t = 0.0,
        allow_negative_numbers = true,
        hide_short_help = true
    )]
    pub exposure: f32,
    /// Tone curve: clamp (the default), aces or agx.
    ///
    /// clamp: values above 1 clip; aces: a filmic shoulder (Narkowicz's
    /// fit); agx: Blender's default view.
    #[arg(long, value_name = "CURVE", default_value = "clamp", hide_short_help = true,
          value_parser = one_of::<TonemapSpec>(TonemapSpec::NAMES))]
    pub tonemap: TonemapSpec,
}

/// Frames, camera motion and video; tiles of a still.
#[derive(clap::Args, Clone, Debug, Default)]
#[command(next_help_heading = "Animation, video and tiles")]
pub struct AnimationArgs {
    /// Render frames A to B (both included), or a video (.mp4, .mkv).
    ///
    /// 0..239 is 240 frames. The output name takes the frame number where
    /// it has #### (zero-padded to their count) or {frame}; otherwise _####
    /// is added. An .mp4 or .mkv output is one video (H.264 or HEVC through
    /// ffmpeg; sbs and tb with stereo metadata; a quilt named
    /// NAME_qsCOLSxROWSaASPECT for Looking Glass).
    #[arg(long, value_name = "A..B")]
    pub frames: Option<String>,
    /// Frames per second of a video output (and of nothing else).
    #[arg(
        long,
        default_value_t = 24.0,
        requires = "frames",
        hide_short_help = true
    )]
    pub fps: f64,
    /// A turntable: the camera turns DEG degrees about the up axis over the frames.
    ///
    /// About the 'at' point; 360 is a seamless loop.
    #[arg(
        long,
        value_name = "DEG",
        allow_negative_numbers = true,
        requires = "frames",
        conflicts_with = "path",
        hide_short_help = true
    )]
    pub orbit: Option<f64>,
    /// Camera keyframes, one a line: FRAME from X,Y,Z at X,Y,Z [up X,Y,Z] [fov DEG].
    ///
    /// Interpolated by a Catmull-Rom spline.
    #[arg(long, value_name = "FILE", requires = "frames", hide_short_help = true)]
    pub path: Option<PathBuf>,
    /// The automatic rig of a stereo animation: per-shot (the default) or per-frame.
    ///
    /// per-shot: chosen once, from the depths of sampled frames (no jumps);
    /// per-frame: for each frame.
    #[arg(long, value_name = "WHEN", default_value = "per-shot", requires = "frames",
          hide_short_help = true, value_parser = one_of::<ShotRigSpec>(ShotRigSpec::NAMES))]
    pub rig: ShotRigSpec,
    /// Skip frames whose files exist already (resume an interrupted run).
    #[arg(long, requires = "frames", hide_short_help = true)]
    pub skip_existing: bool,
    /// Render only frames C..D of --frames (one machine's share).
    ///
    /// The camera motion and the shot's rig stay those of the whole range.
    #[arg(long, value_name = "C..D", requires = "frames", hide_short_help = true)]
    pub only: Option<String>,
    /// A glTF file's animation to play, by name or index (default: all at once).
    #[arg(
        long,
        value_name = "NAME|INDEX",
        requires = "frames",
        hide_short_help = true
    )]
    pub animation: Option<String>,
    /// Split the still into N bands of rows, written as NAME_tileKofN.
    ///
    /// `twinray merge` assembles them (all N, or only --tile K).
    #[arg(
        long,
        value_name = "N",
        conflicts_with = "frames",
        value_parser = clap::value_parser!(u32).range(1..),
        hide_short_help = true
    )]
    pub tiles: Option<u32>,
    /// Render only tile K (0 to N-1) of --tiles N.
    #[arg(long, value_name = "K", requires = "tiles", hide_short_help = true)]
    pub tile: Option<u32>,
    /// Codec of a video output: h264 (libx264) or hevc (libx265, smaller files).
    #[arg(long, value_enum, default_value_t = CodecArg::H264, requires = "frames",
          hide_short_help = true)]
    pub codec: CodecArg,
    /// Quality of a video output: 0 (lossless) to 51; default 18 for h264, 20 for hevc.
    ///
    /// The encoder's constant rate factor; the defaults are visually lossless.
    #[arg(long, value_name = "N", requires = "frames", hide_short_help = true)]
    pub crf: Option<u32>,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug, Default)]
pub enum CodecArg {
    #[default]
    H264,
    Hevc,
}

/// What surrounds the scene.
#[derive(clap::Args, Clone, Debug, Default)]
#[command(next_help_heading = "Surroundings")]
pub struct StudioArgs {
    /// Background colour R,G,B, linear (default: the file's; black for OBJ and glTF).
    #[arg(long, value_name = "R,G,B", value_parser = parse_vec3, hide_short_help = true)]
    pub background: Option<Vec3>,
    /// The up axis of a file without a camera: y, z or auto (the default).
    ///
    /// y is glTF's; z is that of CAD and robotics models (pybullet's, most
    /// STL files); auto: y for glTF, and for OBJ, STL and PLY the axis along
    /// which the model's base is widest, said in a note.
    #[arg(long, value_name = "AXIS", default_value = "auto", hide_short_help = true,
          value_parser = one_of::<UpAxisSpec>(UpAxisSpec::NAMES))]
    pub up_axis: UpAxisSpec,
    /// A point light at X,Y,Z, white or of colour R,G,B; repeat for more.
    ///
    /// In scene units, linear colour, without falloff. For a file without
    /// lights they replace the default key, fill and rim lights.
    #[arg(long = "light", value_name = "X,Y,Z[:R,G,B]", value_parser = parse_light,
          allow_hyphen_values = true, hide_short_help = true)]
    pub lights: Vec<LightSpec>,
    /// A diffuse grey floor just below the model, so that its shadows show.
    ///
    /// Along --up-axis; framing still fits the model alone.
    #[arg(long, hide_short_help = true)]
    pub ground: bool,
    /// An equirectangular environment image (.hdr or .exr) around the scene.
    ///
    /// Linear; seen where rays leave the scene (the background, mirrors,
    /// glass), and lighting surfaces as ambient light (no shadows). Its top
    /// is up (--up-axis), its centre is what the default camera looks
    /// toward.
    #[arg(long, value_name = "FILE", conflicts_with = "background")]
    pub env: Option<PathBuf>,
}

/// Limits of the ray tree and of what a scene file may ask for.
#[derive(clap::Args, Clone, Debug)]
#[command(next_help_heading = "Limits")]
pub struct LimitArgs {
    /// Deepest ray level, 1 to 64 (the eye ray is level 1).
    #[arg(long, value_name = "N", default_value_t = TraceSpec::default().max_depth,
          hide_short_help = true)]
    pub max_depth: u32,
    /// Skip secondary rays whose weight in the pixel is below W (default 1/256; 0: off).
    ///
    /// Not with --spd, which traces every ray.
    #[arg(long, value_name = "W", hide_short_help = true)]
    pub min_weight: Option<f32>,
    /// Largest image side a scene file may ask for.
    #[arg(long, value_name = "PIXELS", default_value_t = LimitSpec::default().max_resolution,
          hide_short_help = true)]
    pub max_resolution: u32,
    /// Most vertices one polygon or patch of the scene file may have.
    #[arg(long, value_name = "N", default_value_t = LimitSpec::default().max_vertices,
          hide_short_help = true)]
    pub max_vertices: usize,
    /// Most triangles an OBJ, glTF, STL or PLY file may have.
    #[arg(long, value_name = "N", default_value_t = LimitSpec::default().max_triangles,
          hide_short_help = true)]
    pub max_triangles: u64,
    /// Let the scene read files in DIR and below, beside its own folder
    /// (textures kept elsewhere); repeatable. A scene reads no file outside
    /// its folder without it.
    #[arg(long, value_name = "DIR", hide_short_help = true)]
    pub allow_dir: Vec<std::path::PathBuf>,
}

impl RenderArgs {
    /// The job these flags describe (checked by [`twinray::Job::check`]).
    pub fn spec(&self) -> JobSpec {
        let (o, c, r) = (&self.output, &self.camera, &self.rig);
        JobSpec {
            scene: self.scene.clone().unwrap_or_default(),
            camera: CameraSpec {
                size: c.size.map(|(w, h)| [w, h]),
                camera: c.camera.clone(),
                from: c.from.map(|v| v.to_array()),
                at: c.at.map(|v| v.to_array()),
                up: c.up.map(|v| v.to_array()),
                fov: c.fov,
                projection: c.projection,
                pole_merge: c.pole_merge,
            },
            rig: RigSpec {
                stereo: r.stereo,
                views: r.views,
                interaxial: r.interaxial.map(|i| i.to_string()),
                convergence: r.convergence.clone(),
                depth_budget: r.depth_budget.clone(),
                view_cone: r.view_cone,
                screen_width: r.screen_width,
                floating_window: r.floating_window,
                angular_budget: r.angular_budget,
                units: r.units,
            },
            sampling: self.sampling.spec(),
            method: self.speed.spec(),
            trace: TraceSpec {
                max_depth: self.limits.max_depth,
                min_weight: self.limits.min_weight,
                threads: self.speed.threads,
            },
            output: OutputSpec {
                path: o.output.clone().unwrap_or_default(),
                layout: o.layout,
                squeeze: o.squeeze,
                anaglyph: o.anaglyph,
                interlace: o.interlace,
                srgb: self.colour.srgb,
                depth: o.depth,
                quilt: o.quilt.clone(),
                stats: o.stats.clone(),
                linear: self.colour.linear,
                exposure: self.colour.exposure,
                tonemap: self.colour.tonemap,
            },
            animation: self.animation.spec(),
            tile: match (self.animation.tiles, self.animation.tile) {
                (Some(count), Some(index)) => Some(TileSpec { index, count }),
                _ => None,
            },
            limits: LimitSpec {
                max_resolution: self.limits.max_resolution,
                max_vertices: self.limits.max_vertices,
                max_triangles: self.limits.max_triangles,
                allow_dirs: self.limits.allow_dir.clone(),
            },
            studio: self.studio.spec(),
            read_files: Vec::new(),
        }
    }
}

impl SamplingArgs {
    /// Whether any of the sampling flags but --spd is given.
    pub fn given(&self) -> bool {
        self.samples.is_some() || self.adaptive.is_some() || self.max_samples.is_some()
    }

    /// The flags as the job spec's sampling.
    pub fn spec(&self) -> SamplingSpec {
        SamplingSpec {
            spd: self.spd,
            samples: self.samples,
            filter: self.filter,
            seed: self.seed,
            adaptive: self.adaptive,
            max_samples: self.max_samples,
        }
    }
}

impl SpeedArgs {
    /// The flags as the job spec's method; combinations the method cannot
    /// take are refused by the job's check, in one place.
    pub fn spec(&self) -> MethodSpec {
        let name = match (self.fast, self.method) {
            (true, _) => MethodName::Fast,
            (false, Some(m)) => m,
            (false, None) => MethodName::Twin,
        };
        let cut = match (self.cut_distance, self.cut_parallax) {
            (Some(d), _) => Some(CutSpec::Distance(d)),
            (None, Some(px)) => Some(CutSpec::Parallax(px)),
            (None, None) => None,
        };
        MethodSpec {
            name,
            tolerance: self.tolerance,
            merge_secondary: self.merge_secondary,
            reproject: self
                .reproject
                .then(|| self.reproject_mode.unwrap_or(ReprojectMode::Safe)),
            reproject_threshold: self.reproject_threshold,
            cut,
        }
    }
}

impl AnimationArgs {
    fn spec(&self) -> AnimationSpec {
        AnimationSpec {
            frames: self.frames.clone(),
            fps: self.fps,
            orbit: self.orbit,
            path: self.path.clone(),
            rig: self.rig,
            skip_existing: self.skip_existing,
            only: self.only.clone(),
            codec: match self.codec {
                CodecArg::H264 => twinray::video::Codec::H264,
                CodecArg::Hevc => twinray::video::Codec::Hevc,
            },
            crf: self.crf,
            clip: self.animation.clone(),
        }
    }
}

impl StudioArgs {
    fn spec(&self) -> StudioSpec {
        StudioSpec {
            background: self.background.map(|v| v.to_array()),
            up_axis: self.up_axis,
            lights: self.lights.clone(),
            ground: self.ground,
            env: self.env.clone(),
        }
    }
}
