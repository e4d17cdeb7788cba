//! The `render` command's flags, and the job spec they describe.

use std::path::PathBuf;

use clap::ValueEnum;

use twinray::job::{
    AnaglyphSpec, AnimationSpec, ApproximationSpec, CameraSpec, InterlaceSpec, JobSpec, LayoutSpec,
    LimitSpec, MethodSpec, OutputSpec, ReprojectModeSpec, RigSpec, ShotRigSpec, TileSpec,
    TraceSpec,
};
use twinray::math::Vec3;
use twinray::output::QuiltSpec;
use twinray::render::{Reprojection, SharedShading};
use twinray::rig::budget::DepthBudget;
use twinray::rig::choice::Interaxial;
use twinray::rig::report as disparity;

use crate::look_args::{ColourArgs, StudioArgs};
use crate::sampling::SamplingArgs;

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum MethodArg {
    Independent,
    Twin,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum LayoutArg {
    Separate,
    Sbs,
    Cross,
    Tb,
    Anaglyph,
    Interlace,
    Mpo,
    Multiview,
    /// Looking Glass quilt of N views (--quilt): view 0 bottom-left, the last top-right.
    Quilt,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum AnaglyphArg {
    Dubois,
    Color,
    Gray,
    GreenMagenta,
    YellowBlue,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum InterlaceArg {
    Rows,
    Columns,
    Checker,
}

#[derive(clap::Args)]
pub struct RenderArgs {
    /// Scene file: .nff, .obj (with its .mtl), .gltf or .glb (with --job: the job's
    /// scene unless given).
    #[arg(required_unless_present = "job")]
    pub scene: Option<PathBuf>,
    /// Output image: .png or .jpg (8-bit), .exr or .pfm (32-bit float, linear), .mpo
    /// (--layout mpo). Several views: NAME_L/NAME_R (--layout separate) or NAME_0, NAME_1...
    #[arg(short, long, required_unless_present_any = ["job", "print_job"])]
    pub output: Option<PathBuf>,
    /// Render the job saved in FILE (JSON, as --print-job writes it); SCENE and
    /// -o, if given, replace its scene and output.
    #[arg(long, value_name = "FILE")]
    pub job: Option<PathBuf>,
    /// Print the job these flags describe as JSON on stdout, and render nothing.
    #[arg(long)]
    pub print_job: bool,
    /// Image size WxH (default: the scene's resolution).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Worker threads, 1 to 1024 (default: all cores). The image is the same for any count.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Deepest ray level, 1 to 64 (the eye ray is level 1).
    #[arg(long, default_value_t = 5)]
    pub max_depth: u32,
    /// Adaptive cut-off: skip secondary rays whose weight in the pixel is below this
    /// (0 = off; default 1/256; not with --spd, which has none).
    #[arg(long)]
    pub min_weight: Option<f32>,
    /// SPD testing procedure: 512x512 by default, (W+1)x(H+1) corner rays averaged,
    /// every reflected/refracted ray spawned, no cut-off.
    #[arg(long)]
    pub spd: bool,
    /// Write statistics (ray counts, times, hierarchy) as JSON.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// No progress bar, no notes (warnings and errors only).
    #[arg(short, long)]
    pub quiet: bool,
    /// Print scene facts, the rig and timings on stderr (the files written are listed
    /// at the end unless --quiet).
    #[arg(short, long)]
    pub verbose: bool,
    /// Largest image side a scene file may ask for.
    #[arg(long, default_value_t = 16384)]
    pub max_resolution: u32,
    /// Most vertices one polygon or patch of the scene file may have.
    #[arg(long, default_value_t = 1_000_000)]
    pub max_vertices: usize,
    /// Most triangles an OBJ or glTF file may have.
    #[arg(long, default_value_t = 100_000_000)]
    pub max_triangles: u64,
    /// Let the scene read files in DIR and below, beside its own folder
    /// (textures kept elsewhere); repeatable. A scene reads no file outside
    /// its folder without it.
    #[arg(long, value_name = "DIR")]
    pub allow_dir: Vec<PathBuf>,

    /// Which of a glTF file's cameras to use: its name or its index (default: the first).
    #[arg(long)]
    pub camera: Option<String>,
    /// Camera position X,Y,Z (default: the file's camera, or one framing the scene).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub from: Option<Vec3>,
    /// Point the camera looks at, X,Y,Z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub at: Option<Vec3>,
    /// Camera up direction X,Y,Z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub up: Option<Vec3>,
    /// Vertical field of view in degrees, top edge of the image to bottom edge.
    #[arg(long)]
    pub fov: Option<f32>,

    /// Render a stereo pair.
    #[arg(long)]
    pub stereo: bool,
    /// Render N views for a multi-view display (spaced --interaxial apart).
    #[arg(long)]
    pub views: Option<usize>,
    /// Distance between adjacent views (the eyes), in scene units, or "auto": the
    /// largest that fits the visible depths into --depth-budget (the default).
    #[arg(long, allow_negative_numbers = true, value_name = "B|auto")]
    pub interaxial: Option<Interaxial>,
    /// Zero-parallax distance: a number, "inf" (parallel cameras), "auto" (fitted
    /// to --depth-budget) or "near" (the nearest visible point). Default: auto, or
    /// the distance to the scene's 'at' point when --interaxial is a number.
    #[arg(long, allow_negative_numbers = true, value_name = "D|inf|auto|near")]
    pub convergence: Option<String>,
    /// How the views are computed.
    #[arg(long, value_enum, default_value_t = MethodArg::Twin)]
    pub method: MethodArg,
    /// How the views are delivered.
    #[arg(long, value_enum, default_value_t = LayoutArg::Separate)]
    pub layout: LayoutArg,
    /// Half-width (sbs, cross) or half-height (tb) frames, as 3D TVs take.
    #[arg(long)]
    pub squeeze: bool,
    /// Colour method of --layout anaglyph (default dubois: red-cyan glasses, least
    /// ghosting; color and gray: plain red-cyan; green-magenta; yellow-blue).
    #[arg(long, value_enum)]
    pub anaglyph: Option<AnaglyphArg>,
    /// Pattern of --layout interlace (default rows: line-interleaved 3D monitors;
    /// columns; checker: DLP 3D displays). Left eye on even rows / columns / x+y.
    #[arg(long, value_enum)]
    pub interlace: Option<InterlaceArg>,

    /// Twin method: most views traced as one packet, 1 to 32 (default 4:
    /// more views are traced in batches of 4 neighbours).
    #[arg(long, value_name = "N")]
    pub views_per_batch: Option<usize>,

    /// Twin method: trace the eye rays of all views along a camera column in
    /// one descent of the hierarchy (the same images; see docs/stereo.md)
    #[arg(long)]
    pub strip: bool,

    /// Twin method: find the eye hits of the views along a camera column by
    /// tracing a few of them and proving the views between (the same
    /// images; see docs/stereo.md)
    #[arg(long)]
    pub eye_runs: bool,
    /// Twin method: prove the shadow rays of consecutive views' hits on one
    /// surface free with one shadow fan per light, instead of one ray per
    /// view (the same images; see docs/stereo.md)
    #[arg(long)]
    pub shadow_fans: bool,

    #[command(flatten)]
    pub sampling: SamplingArgs,

    #[command(flatten)]
    pub depth: DepthArgs,

    #[command(flatten)]
    pub approx: ApproxArgs,

    #[command(flatten)]
    pub colour: ColourArgs,

    #[command(flatten)]
    pub animation: AnimationArgs,

    #[command(flatten)]
    pub studio: StudioArgs,
}

/// Frames, camera motion and video; tiles of a still.
#[derive(clap::Args, Clone, Debug, Default)]
#[command(next_help_heading = "Animation, video and tiles")]
pub struct AnimationArgs {
    /// Render frames A to B (both included: 0..239 is 240 frames). The output
    /// name takes the frame number where it has #### (zero-padded to their
    /// count) or {frame}; otherwise _#### is added. An .mp4 or .mkv output is
    /// one video (H.264 or HEVC through ffmpeg; sbs and tb with stereo
    /// metadata; a quilt named NAME_qsCOLSxROWSaASPECT for Looking Glass).
    #[arg(long, value_name = "A..B")]
    pub frames: Option<String>,
    /// Frames per second of a video output (and of nothing else).
    #[arg(long, default_value_t = 24.0, requires = "frames")]
    pub fps: f64,
    /// A turntable: the camera turns DEG degrees about the up axis through the
    /// 'at' point over the frames (360: a seamless loop).
    #[arg(
        long,
        value_name = "DEG",
        allow_negative_numbers = true,
        requires = "frames",
        conflicts_with = "path"
    )]
    pub orbit: Option<f64>,
    /// Camera keyframes, one a line: FRAME from X,Y,Z at X,Y,Z [up X,Y,Z]
    /// [fov DEG], interpolated by a Catmull-Rom spline.
    #[arg(long, value_name = "FILE", requires = "frames")]
    pub path: Option<PathBuf>,
    /// The automatic rig of a stereo animation: chosen once from depth passes
    /// over sampled frames (per-shot: no jumps), or for each frame.
    #[arg(long, value_enum, default_value_t = ShotRigArg::PerShot, requires = "frames")]
    pub rig: ShotRigArg,
    /// Skip frames whose files exist already (resume an interrupted run).
    #[arg(long, requires = "frames")]
    pub skip_existing: bool,
    /// Render only frames C..D of --frames (one machine's share): the camera
    /// motion and the shot's rig stay those of the whole range.
    #[arg(long, value_name = "C..D", requires = "frames")]
    pub only: Option<String>,
    /// A glTF file's animation to play, by name or index (default: all of
    /// the file's animations at once).
    #[arg(long, value_name = "NAME|INDEX", requires = "frames")]
    pub animation: Option<String>,
    /// Split the still into N bands of rows, written as NAME_tileKofN, for
    /// `twinray merge` to assemble (all N, or only --tile K).
    #[arg(long, value_name = "N", conflicts_with = "frames", value_parser = clap::value_parser!(u32).range(1..))]
    pub tiles: Option<u32>,
    /// Render only tile K (0 to N-1) of --tiles N.
    #[arg(long, value_name = "K", requires = "tiles")]
    pub tile: Option<u32>,
    /// Codec of a video output: h264 (libx264) or hevc (libx265, smaller
    /// files), both through ffmpeg.
    #[arg(long, value_enum, default_value_t = CodecArg::H264, requires = "frames")]
    pub codec: CodecArg,
    /// Quality of a video output, the encoder's constant rate factor: 0
    /// (lossless) to 51; default 18 for h264, 20 for hevc (visually lossless).
    #[arg(long, value_name = "N", requires = "frames")]
    pub crf: Option<u32>,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug, Default)]
pub enum CodecArg {
    #[default]
    H264,
    Hevc,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug, Default)]
pub enum ShotRigArg {
    #[default]
    PerShot,
    PerFrame,
}

/// The paper's approximations (sections 2.3–2.5): faster stereo, not exact.
#[derive(clap::Args, Clone, Debug, Default)]
#[command(next_help_heading = "Approximations (twin method; the default is exact)")]
pub struct ApproxArgs {
    /// Section 2.4: views' reflected/refracted rays from one planar surface
    /// merged into one ray from the midpoint of their hit points.
    #[arg(long)]
    pub merge_secondary: bool,
    /// Section 2.5: the other views take view 0's shading where they see the
    /// same point and its shading tree is diffuse.
    #[arg(long)]
    pub reproject: bool,
    /// safe: only where the receiving sample's own hit is the same surface point
    /// (no ghosts, no holes); paper: eq. 2.1 as published (nearest wins, holes traced).
    #[arg(long, value_enum, default_value_t = ReprojectModeArg::Safe, requires = "reproject")]
    pub reproject_mode: ReprojectModeArg,
    /// Largest specular or transmission coefficient of a surface whose shading
    /// may be reprojected.
    #[arg(long, default_value_t = Reprojection::DEFAULT_THRESHOLD, requires = "reproject")]
    pub reproject_threshold: f32,
    /// Section 2.3: objects entirely farther than this depth (scene units, along
    /// the view direction from the rig's centre) are not twinned: every view
    /// sees them as the rig's centre does.
    #[arg(long, conflicts_with = "cut_parallax")]
    pub cut_distance: Option<f32>,
    /// Section 2.3 with the depth chosen so that no cut object's disparity is off
    /// by more than PX pixels (depth = focal length in pixels x outer views'
    /// distance / PX).
    #[arg(long, value_name = "PX")]
    pub cut_parallax: Option<f64>,
    /// Every approximation at its default: with --samples 1 or --spd the
    /// epipolar rows (--epipolar-views, no cut), and --merge-secondary
    /// --reproject --share-shading for rows they cannot take; with other
    /// samplings --merge-secondary --reproject --cut-parallax 0.5
    /// --share-shading.
    #[arg(long)]
    pub fast: bool,
    /// A surface point's shadow and secondary rays traced once for every view
    /// that sees it (a shading cache shared by all views; supersedes the safe
    /// --reproject). Surfaces with mirror + transmission weights above
    /// --share-tolerance, and points next to a shadow edge, are shaded exactly.
    #[arg(long)]
    pub share_shading: bool,
    /// Largest error the shared shading may add per channel, in image values
    /// (1 = white), where radiance is at most 1.
    #[arg(long, value_name = "E", default_value_t = SharedShading::DEFAULT_TOLERANCE)]
    pub share_tolerance: f32,
    /// Under the shared shading, mirror and glass points seen by several
    /// views are traced in full by every K-th of them (key views); the views
    /// between take the key views' secondary colour, interpolated, where both
    /// hit the same primitives, nothing shadows the light between their hits,
    /// and their colours agree within --share-tolerance, and the light's
    /// curvature between their hits is within it. 0: adaptive (the outermost
    /// two, halved where they disagree); 1 (the default): no key views, every
    /// view traces its own (key views measured slower on SPD gears and mount).
    #[arg(long, value_name = "K", default_value_t = 1)]
    pub key_spacing: usize,
    /// Views between two views of a camera column that are proved to see one
    /// flat, plain, diffuse surface take their colour interpolated between
    /// those two (no shading, no shadow rays) where the two agree within
    /// --share-tolerance and the light's curvature and shadows between their
    /// hits allow; elsewhere the middle view is shaded and the halves judged
    /// again (implies --eye-runs; --fast does not turn it on: it measured
    /// slower than the exact batches on the SPD scenes).
    #[arg(long)]
    pub interpolate_views: bool,
    /// Trace only every K-th view (--synthesis-spacing K) and the last; each
    /// view between takes, row by row, the colours its nearest key view saw,
    /// moved by their disparity, where the surface is diffuse (mirror,
    /// highlight and glass weights at most --share-tolerance), the colours
    /// between two key samples are linear within --share-tolerance, and
    /// nothing the key view missed lies between its rays and the view's;
    /// every other sample is traced. Needs --samples 1 or --spd (other
    /// samplings are traced exactly).
    #[arg(long)]
    pub synthesize_views: bool,
    /// Views from one key view to the next under --synthesize-views.
    #[arg(long, value_name = "K", default_value_t = twinray::render::ViewSynthesis::DEFAULT_SPACING)]
    pub synthesis_spacing: usize,
    /// Find every view's eye hits of an image row at once, from the
    /// primitives that cross the row's plane (each sample's hit is its own
    /// ray's; no eye ray is traced), and shade a diffuse surface point once:
    /// a view's sample takes the colour between two samples of the same
    /// surface that earlier views shaded, where they lie within 1.5 of its
    /// pixels and their colours differ by at most --share-tolerance (and bend
    /// by at most half of it), or else their light toward each light they
    /// and their neighbours saw alike; mirrors, glass, highlights and edges
    /// are shaded exactly. Applies to rows of one sample a pixel at one
    /// place (--samples 1, --spd, the adaptive sampling's corners); other
    /// rows are traced exactly.
    #[arg(long)]
    pub epipolar_views: bool,
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
    pub depth_budget: Option<String>,
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
    pub quilt: Option<String>,
    /// Space the views so that the outer two span this angle, in degrees, seen
    /// from the convergence point (as light-field displays take it; the
    /// default of --layout quilt is 35).
    #[arg(long, value_name = "DEGREES", conflicts_with = "interaxial")]
    pub view_cone: Option<f64>,
}

/// Checks a depth budget as clap parses it; the spec keeps the text.
fn parse_budget(s: &str) -> Result<String, String> {
    s.parse::<DepthBudget>().map_err(|e| e.to_string())?;
    Ok(s.to_string())
}

/// Checks a quilt grid as clap parses it; the spec keeps the text.
fn parse_quilt(s: &str) -> Result<String, String> {
    s.parse::<QuiltSpec>().map_err(|e| e.to_string())?;
    Ok(s.to_string())
}

impl RenderArgs {
    /// The job these flags describe.
    pub fn spec(&self) -> JobSpec {
        let approx = &self.approx;
        JobSpec {
            scene: self.scene.clone().unwrap_or_default(),
            camera: CameraSpec {
                size: self.size.map(|(w, h)| [w, h]),
                camera: self.camera.clone(),
                from: self.from.map(|v| v.to_array()),
                at: self.at.map(|v| v.to_array()),
                up: self.up.map(|v| v.to_array()),
                fov: self.fov,
            },
            rig: RigSpec {
                stereo: self.stereo,
                views: self.views,
                interaxial: self.interaxial.map(|i| i.to_string()),
                convergence: self.convergence.clone(),
                depth_budget: self.depth.depth_budget.clone(),
                view_cone: self.depth.view_cone,
                screen_width: self.depth.screen_width,
                floating_window: self.depth.floating_window,
                method: match self.method {
                    MethodArg::Independent => MethodSpec::Independent,
                    MethodArg::Twin => MethodSpec::Twin,
                },
                views_per_batch: self.views_per_batch,
                strip: self.strip,
                eye_runs: self.eye_runs,
                shadow_fans: self.shadow_fans,
            },
            sampling: self.sampling.spec(self.spd),
            approximations: ApproximationSpec {
                merge_secondary: approx.merge_secondary,
                reproject: approx.reproject,
                reproject_mode: match approx.reproject_mode {
                    ReprojectModeArg::Safe => ReprojectModeSpec::Safe,
                    ReprojectModeArg::Paper => ReprojectModeSpec::Paper,
                },
                reproject_threshold: approx.reproject_threshold,
                cut_distance: approx.cut_distance,
                cut_parallax: approx.cut_parallax,
                fast: approx.fast,
                share_shading: approx.share_shading,
                share_tolerance: approx.share_tolerance,
                key_spacing: approx.key_spacing,
                interpolate_views: approx.interpolate_views,
                synthesize_views: approx.synthesize_views,
                synthesis_spacing: approx.synthesis_spacing,
                epipolar_views: approx.epipolar_views,
            },
            trace: TraceSpec {
                max_depth: self.max_depth,
                min_weight: self.min_weight,
                threads: self.threads,
            },
            output: OutputSpec {
                path: self.output.clone().unwrap_or_default(),
                layout: self.layout.into(),
                squeeze: self.squeeze,
                anaglyph: self.anaglyph.map(|a| match a {
                    AnaglyphArg::Dubois => AnaglyphSpec::Dubois,
                    AnaglyphArg::Color => AnaglyphSpec::Color,
                    AnaglyphArg::Gray => AnaglyphSpec::Gray,
                    AnaglyphArg::GreenMagenta => AnaglyphSpec::GreenMagenta,
                    AnaglyphArg::YellowBlue => AnaglyphSpec::YellowBlue,
                }),
                interlace: self.interlace.map(|i| match i {
                    InterlaceArg::Rows => InterlaceSpec::Rows,
                    InterlaceArg::Columns => InterlaceSpec::Columns,
                    InterlaceArg::Checker => InterlaceSpec::Checker,
                }),
                srgb: self.colour.srgb,
                depth: self.depth.depth,
                quilt: self.depth.quilt.clone(),
                stats: self.stats.clone(),
                linear: self.colour.linear,
                exposure: self.colour.exposure,
                tonemap: self.colour.tonemap.into(),
            },
            animation: AnimationSpec {
                frames: self.animation.frames.clone(),
                fps: self.animation.fps,
                orbit: self.animation.orbit,
                path: self.animation.path.clone(),
                rig: match self.animation.rig {
                    ShotRigArg::PerShot => ShotRigSpec::PerShot,
                    ShotRigArg::PerFrame => ShotRigSpec::PerFrame,
                },
                skip_existing: self.animation.skip_existing,
                only: self.animation.only.clone(),
                codec: match self.animation.codec {
                    CodecArg::H264 => twinray::video::Codec::H264,
                    CodecArg::Hevc => twinray::video::Codec::Hevc,
                },
                crf: self.animation.crf,
                clip: self.animation.animation.clone(),
            },
            tile: match (self.animation.tiles, self.animation.tile) {
                (Some(count), Some(index)) => Some(TileSpec { index, count }),
                _ => None,
            },
            limits: LimitSpec {
                max_resolution: self.max_resolution,
                max_vertices: self.max_vertices,
                max_triangles: self.max_triangles,
                allow_dirs: self.allow_dir.clone(),
            },
            studio: self.studio.spec(),
            read_files: Vec::new(),
        }
    }
}

impl From<LayoutArg> for LayoutSpec {
    fn from(l: LayoutArg) -> LayoutSpec {
        match l {
            LayoutArg::Separate => LayoutSpec::Separate,
            LayoutArg::Sbs => LayoutSpec::Sbs,
            LayoutArg::Cross => LayoutSpec::Cross,
            LayoutArg::Tb => LayoutSpec::Tb,
            LayoutArg::Anaglyph => LayoutSpec::Anaglyph,
            LayoutArg::Interlace => LayoutSpec::Interlace,
            LayoutArg::Mpo => LayoutSpec::Mpo,
            LayoutArg::Multiview => LayoutSpec::Multiview,
            LayoutArg::Quilt => LayoutSpec::Quilt,
        }
    }
}

pub fn parse_size(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}' is not WxH"))?;
    let w: u32 = w.parse().map_err(|_| format!("'{w}' is not a width"))?;
    let h: u32 = h.parse().map_err(|_| format!("'{h}' is not a height"))?;
    if w == 0 || h == 0 {
        return Err("width and height must be at least 1".into());
    }
    Ok((w, h))
}

pub fn parse_vec3(s: &str) -> std::result::Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let numbers: Vec<f32> = parts.iter().filter_map(|p| p.parse().ok()).collect();
    match numbers[..] {
        [x, y, z] if parts.len() == 3 && numbers.iter().all(|v| v.is_finite()) => {
            Ok(Vec3::new(x, y, z))
        }
        _ => Err(format!("'{s}' is not X,Y,Z (three numbers)")),
    }
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug, Default)]
pub enum ReprojectModeArg {
    #[default]
    Safe,
    Paper,
}
