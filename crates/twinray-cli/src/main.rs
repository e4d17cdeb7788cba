//! The `twinray` command: parses arguments, shows progress, calls the library.

mod bench;
mod rig_choice;
mod sampling;
mod view_outputs;

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};

use twinray::camera::Camera;
use twinray::loaders::{load_scene, LoadOptions};
use twinray::math::Vec3;
use twinray::output::{self, AnaglyphMethod, InterlaceMode, Layout, WriteOptions};
use twinray::render::{
    self, Approximations, Method, RenderOptions, ReprojectMode, Reprojection, TraceSettings,
};
use twinray::rig::Rig;
use twinray::scene::SceneFormat;
use twinray::stats::{Report, SamplingFacts, SceneFacts, Timings};
use twinray::view::{self, ViewOverrides};
use twinray::world::Cut;
use twinray::World;

#[derive(Parser)]
#[command(
    name = "twinray",
    version,
    about = "Stereoscopic and multi-view ray tracer (twin objects)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (NFF, OBJ, glTF) to an image, or a stereo pair / view set in a layout.
    Render(Box<RenderArgs>),
    /// Time stereo pairs: the twin method against two independent renders (the paper's tables 2.1, 2.2).
    BenchStereo(bench::BenchArgs),
    /// Compare two images: PSNR, largest difference, differing pixels. Exits 1 when
    /// they differ beyond --max-diff or --min-psnr.
    Compare(CompareArgs),
}

#[derive(clap::Args)]
struct CompareArgs {
    /// First input image (.png, .jpg, .exr, .pfm).
    a: PathBuf,
    /// Second input image, of the same size.
    b: PathBuf,
    /// Also write |a - b| scaled by --gain to this image.
    #[arg(long)]
    diff: Option<PathBuf>,
    /// Brightness of the --diff image: each channel is |a - b| x gain.
    #[arg(long, default_value_t = 10.0)]
    gain: f32,
    /// Fail (exit 1) if any channel differs by more than this.
    #[arg(long)]
    max_diff: Option<f32>,
    /// Fail (exit 1) if the PSNR is below this, in dB.
    #[arg(long)]
    min_psnr: Option<f64>,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum MethodArg {
    Independent,
    Twin,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum LayoutArg {
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
enum AnaglyphArg {
    Dubois,
    Color,
    Gray,
    GreenMagenta,
    YellowBlue,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum InterlaceArg {
    Rows,
    Columns,
    Checker,
}

#[derive(clap::Args)]
struct RenderArgs {
    /// Scene file: .nff, .obj (with its .mtl), .gltf or .glb.
    scene: PathBuf,
    /// Output image: .png or .jpg (8-bit), .exr or .pfm (32-bit float, linear), .mpo
    /// (--layout mpo). Several views: NAME_L/NAME_R (--layout separate) or NAME_0, NAME_1...
    #[arg(short, long)]
    output: PathBuf,
    /// Image size WxH (default: the scene's resolution).
    #[arg(long, value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Worker threads, 1 to 1024 (default: all cores). The image is the same for any count.
    #[arg(long)]
    threads: Option<usize>,
    /// Deepest ray level, 1 to 64 (the eye ray is level 1).
    #[arg(long, default_value_t = 5)]
    max_depth: u32,
    /// Adaptive cut-off: skip secondary rays whose weight in the pixel is below this
    /// (0 = off; default 1/256; not with --spd, which has none).
    #[arg(long)]
    min_weight: Option<f32>,
    /// SPD testing procedure: 512x512 by default, (W+1)x(H+1) corner rays averaged,
    /// every reflected/refracted ray spawned, no cut-off.
    #[arg(long)]
    spd: bool,
    /// Write statistics (ray counts, times, hierarchy) as JSON.
    #[arg(long)]
    stats: Option<PathBuf>,
    /// No progress bar.
    #[arg(short, long)]
    quiet: bool,
    /// Print scene facts, the rig and timings on stderr (the files written are listed
    /// at the end unless --quiet).
    #[arg(short, long)]
    verbose: bool,
    /// Apply the sRGB transfer curve to 8-bit outputs, .png .jpg .mpo (default: values as
    /// computed).
    #[arg(long)]
    srgb: bool,
    /// Largest image side a scene file may ask for.
    #[arg(long, default_value_t = 16384)]
    max_resolution: u32,
    /// Most vertices one polygon or patch of the scene file may have.
    #[arg(long, default_value_t = 1_000_000)]
    max_vertices: usize,
    /// Most triangles an OBJ or glTF file may have.
    #[arg(long, default_value_t = 100_000_000)]
    max_triangles: u64,

    /// Which of a glTF file's cameras to use: its name or its index (default: the first).
    #[arg(long)]
    camera: Option<String>,
    /// Camera position X,Y,Z (default: the file's camera, or one framing the scene).
    #[arg(long, value_parser = parse_vec3, allow_negative_numbers = true)]
    from: Option<Vec3>,
    /// Point the camera looks at, X,Y,Z.
    #[arg(long, value_parser = parse_vec3, allow_negative_numbers = true)]
    at: Option<Vec3>,
    /// Camera up direction X,Y,Z.
    #[arg(long, value_parser = parse_vec3, allow_negative_numbers = true)]
    up: Option<Vec3>,
    /// Vertical field of view in degrees, top edge of the image to bottom edge.
    #[arg(long)]
    fov: Option<f32>,

    /// Render a stereo pair.
    #[arg(long)]
    stereo: bool,
    /// Render N views for a multi-view display (spaced --interaxial apart).
    #[arg(long)]
    views: Option<usize>,
    /// Distance between adjacent views (the eyes), in scene units, or "auto": the
    /// largest that fits the visible depths into --depth-budget (the default).
    #[arg(long, allow_negative_numbers = true, value_name = "B|auto")]
    interaxial: Option<rig_choice::InteraxialArg>,
    /// Zero-parallax distance: a number, "inf" (parallel cameras), "auto" (fitted
    /// to --depth-budget) or "near" (the nearest visible point). Default: auto, or
    /// the distance to the scene's 'at' point when --interaxial is a number.
    #[arg(long, allow_negative_numbers = true, value_name = "D|inf|auto|near")]
    convergence: Option<String>,
    /// How the views are computed.
    #[arg(long, value_enum, default_value_t = MethodArg::Twin)]
    method: MethodArg,
    /// How the views are delivered.
    #[arg(long, value_enum, default_value_t = LayoutArg::Separate)]
    layout: LayoutArg,
    /// Half-width (sbs, cross) or half-height (tb) frames, as 3D TVs take.
    #[arg(long)]
    squeeze: bool,
    /// Colour method of --layout anaglyph (default dubois: red-cyan glasses, least
    /// ghosting; color and gray: plain red-cyan; green-magenta; yellow-blue).
    #[arg(long, value_enum)]
    anaglyph: Option<AnaglyphArg>,
    /// Pattern of --layout interlace (default rows: line-interleaved 3D monitors;
    /// columns; checker: DLP 3D displays). Left eye on even rows / columns / x+y.
    #[arg(long, value_enum)]
    interlace: Option<InterlaceArg>,

    /// Twin method: most views traced as one packet, 1 to 32 (default 4:
    /// more views are traced in batches of 4 neighbours).
    #[arg(long, value_name = "N")]
    views_per_batch: Option<usize>,

    #[command(flatten)]
    sampling: sampling::SamplingArgs,

    #[command(flatten)]
    depth: rig_choice::DepthArgs,

    #[command(flatten)]
    approx: ApproxArgs,
}

/// The paper's approximations (sections 2.3–2.5): faster stereo, not exact.
#[derive(clap::Args, Clone, Debug, Default)]
#[command(next_help_heading = "Approximations (twin method; the default is exact)")]
pub struct ApproxArgs {
    /// Section 2.4: views' reflected/refracted rays from one planar surface
    /// merged into one ray from the midpoint of their hit points.
    #[arg(long)]
    merge_secondary: bool,
    /// Section 2.5: the other views take view 0's shading where they see the
    /// same point and its shading tree is diffuse.
    #[arg(long)]
    reproject: bool,
    /// safe: only where the receiving sample's own hit is the same surface point
    /// (no ghosts, no holes); paper: eq. 2.1 as published (nearest wins, holes traced).
    #[arg(long, value_enum, default_value_t = ReprojectModeArg::Safe, requires = "reproject")]
    reproject_mode: ReprojectModeArg,
    /// Largest specular or transmission coefficient of a surface whose shading
    /// may be reprojected.
    #[arg(long, default_value_t = Reprojection::DEFAULT_THRESHOLD, requires = "reproject")]
    reproject_threshold: f32,
    /// Section 2.3: objects entirely farther than this depth (scene units, along
    /// the view direction from the rig's centre) are not twinned: every view
    /// sees them as the rig's centre does.
    #[arg(long, conflicts_with = "cut_parallax")]
    cut_distance: Option<f32>,
    /// Section 2.3 with the depth chosen so that no cut object's disparity is off
    /// by more than PX pixels (depth = focal length in pixels x outer views'
    /// distance / PX).
    #[arg(long, value_name = "PX")]
    cut_parallax: Option<f64>,
    /// Every approximation at its default: --merge-secondary --reproject
    /// --cut-parallax 0.5.
    #[arg(long)]
    fast: bool,
}

/// --fast's cut: half a pixel of disparity.
const FAST_CUT_PARALLAX: f64 = 0.5;

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug, Default)]
pub enum ReprojectModeArg {
    #[default]
    Safe,
    Paper,
}

impl ApproxArgs {
    /// The approximations asked for, checked.
    pub fn approximations(&self) -> Result<Approximations> {
        let threshold = self.reproject_threshold;
        if !(threshold.is_finite() && threshold >= 0.0) {
            bail!("--reproject-threshold must be a coefficient >= 0, got {threshold}");
        }
        let reproject = (self.reproject || self.fast).then_some(Reprojection {
            mode: match self.reproject_mode {
                ReprojectModeArg::Safe => ReprojectMode::Safe,
                ReprojectModeArg::Paper => ReprojectMode::Paper,
            },
            threshold,
        });
        Ok(Approximations {
            merge_secondary: self.merge_secondary || self.fast,
            reproject,
        })
    }

    /// Where to cut the object tree, if asked (needs the rig: the parallax
    /// bound depends on the views' spacing).
    pub fn cut(&self, camera: &Camera, rig: &Rig) -> Result<Option<Cut>> {
        let parallax = self.cut_parallax.or(self.fast.then_some(FAST_CUT_PARALLAX));
        let depth = match (self.cut_distance, parallax) {
            (Some(d), _) if !(d.is_finite() && d > 0.0) => {
                bail!("--cut-distance must be a distance > 0, got {d}")
            }
            (Some(d), _) => d as f64,
            (None, Some(px)) if !(px.is_finite() && px > 0.0) => {
                bail!("--cut-parallax must be a number of pixels > 0, got {px}")
            }
            (None, Some(px)) => match rig.cut_depth_for_parallax(camera, px) {
                Some(d) => d,
                None => return Ok(None),
            },
            (None, None) => return Ok(None),
        };
        Ok(Some(Cut::at_depth(camera, depth as f32)))
    }
}

fn parse_size(s: &str) -> std::result::Result<(u32, u32), String> {
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

fn parse_vec3(s: &str) -> std::result::Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let numbers: Vec<f32> = parts.iter().filter_map(|p| p.parse().ok()).collect();
    match numbers[..] {
        [x, y, z] if parts.len() == 3 && numbers.iter().all(|v| v.is_finite()) => {
            Ok(Vec3::new(x, y, z))
        }
        _ => Err(format!("'{s}' is not X,Y,Z (three numbers)")),
    }
}

/// A command-line error from clap as one line (`twinray: ...`), like every other
/// error; help and version requests are printed by clap as usual.
fn parse_args() -> std::result::Result<Cli, ExitCode> {
    use clap::error::ErrorKind;
    match Cli::try_parse() {
        Ok(cli) => Ok(cli),
        Err(e)
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) =>
        {
            e.exit()
        }
        Err(e) => {
            let mut line = String::new();
            for part in e.to_string().lines().map(str::trim) {
                if part.starts_with("Usage:") || part.starts_with("For more information") {
                    break;
                }
                if part.is_empty() {
                    continue;
                }
                if !line.is_empty() {
                    line.push_str(if line.ends_with(':') { " " } else { "; " });
                }
                line.push_str(part.strip_prefix("error: ").unwrap_or(part));
            }
            eprintln!("twinray: {line} (see --help)");
            Err(ExitCode::from(2))
        }
    }
}

/// A panic (a bug) as one line in twinray's style, with where it happened,
/// instead of Rust's multi-line report; temporary files are removed.
fn install_panic_hook() {
    std::panic::set_hook(Box::new(|info| {
        let what = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown cause".into());
        let at = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        output::remove_temporary_files();
        eprintln!("twinray: internal error (a bug, please report it): {what}{at}");
    }));
}

/// SIGINT, SIGTERM (and SIGHUP): remove the temporary files of an output being
/// written, then exit as a shell expects of an interrupted program.
fn install_signal_handler() {
    let installed = ctrlc::set_handler(|| {
        output::remove_temporary_files();
        eprintln!("twinray: interrupted");
        std::process::exit(130);
    });
    if let Err(e) = installed {
        eprintln!("twinray: warning: cannot handle interruptions ({e}); an interrupted write may leave a .twinray-*.tmp file");
    }
}

fn main() -> ExitCode {
    let cli = match parse_args() {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    install_panic_hook();
    install_signal_handler();
    let result = match cli.command {
        Command::Render(args) => {
            run_render(&args).map(|written| list_written(&written, args.quiet))
        }
        Command::BenchStereo(args) => bench::run(args),
        Command::Compare(args) => run_compare(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line: the error and its causes, each cause only once.
            let mut line = String::new();
            for cause in e.chain() {
                let text = cause.to_string();
                if !line.contains(&text) {
                    if !line.is_empty() {
                        line.push_str(": ");
                    }
                    line.push_str(&text);
                }
            }
            eprintln!("twinray: {line}");
            ExitCode::FAILURE
        }
    }
}

fn list_written(written: &[PathBuf], quiet: bool) {
    if !quiet {
        for path in written {
            eprintln!("wrote {}", path.display());
        }
    }
}

fn run_compare(args: &CompareArgs) -> Result<()> {
    if let Some(path) = &args.diff {
        output::check_distinct(std::slice::from_ref(path), &[&args.a, &args.b])?;
    }
    let read = |p: &Path| output::read_image(p).with_context(|| format!("input {}", p.display()));
    let (ia, ib) = (read(&args.a)?, read(&args.b)?);
    let d = output::compare(&ia, &ib)?;
    println!(
        "psnr_db {:.3}  max_abs {:.6}  mean_abs {:.6}  differing_pixels {}",
        d.psnr_db, d.max_abs, d.mean_abs, d.differing_pixels
    );
    if let Some(path) = &args.diff {
        output::write_image(
            path,
            &output::difference_image(&ia, &ib, args.gain)?,
            &WriteOptions::default(),
        )?;
    }
    if let Some(max) = args.max_diff {
        if d.max_abs > max || d.max_abs.is_nan() {
            bail!(
                "the images differ by up to {:.6}, more than --max-diff {max}",
                d.max_abs
            );
        }
    }
    if let Some(min) = args.min_psnr {
        if d.psnr_db < min || d.psnr_db.is_nan() {
            bail!("PSNR {:.3} dB is below --min-psnr {min}", d.psnr_db);
        }
    }
    Ok(())
}

/// How many views, how far apart, converging where: checked before any work.
struct ViewPlan {
    count: usize,
    /// The rig's spacing and convergence, final once the rig is settled
    /// (`rig_choice::settle`).
    interaxial: f32,
    convergence: Option<f64>,
    /// What the flags ask of the rig (several views only).
    request: Option<twinray::depth_budget::RigRequest>,
}

fn plan_views(args: &RenderArgs, default_convergence: f64) -> Result<ViewPlan> {
    let quilt = args.depth.quilt.filter(|_| args.layout == LayoutArg::Quilt);
    let count = match (args.stereo, args.views) {
        (true, Some(n)) if n != 2 => {
            bail!("--stereo renders 2 views; use --views {n} alone for a multi-view set")
        }
        (_, Some(0)) => bail!("--views must be at least 1"),
        (_, Some(n)) if n > render::MAX_VIEWS => {
            bail!("--views {n}: at most {} views", render::MAX_VIEWS)
        }
        (_, Some(n)) => n,
        (true, None) => 2,
        (false, None) => quilt.map_or(1, |q| q.layout.tiles()),
    };
    if let Some(q) = quilt {
        let (c, r) = (q.layout.columns, q.layout.rows);
        if count > render::MAX_VIEWS {
            bail!(
                "--quilt {c}x{r} takes {count} views: at most {} views (--views N renders fewer, the other tiles black)",
                render::MAX_VIEWS
            );
        }
        if count > q.layout.tiles() {
            bail!(
                "--views {count} do not fit a {c}x{r} quilt ({} tiles)",
                q.layout.tiles()
            );
        }
    }
    let request = if count > 1 {
        Some(rig_choice::rig_request(
            args.interaxial,
            args.convergence.as_deref(),
            &args.depth,
            quilt.is_some(),
            count,
            default_convergence,
        )?)
    } else {
        None
    };
    if count == 1 && args.layout != LayoutArg::Separate {
        bail!("--layout needs --stereo (or --views)");
    }
    if count != 2
        && !matches!(
            args.layout,
            LayoutArg::Separate | LayoutArg::Multiview | LayoutArg::Quilt
        )
    {
        bail!(
            "--layout {} takes exactly two views",
            args.layout
                .to_possible_value()
                .map(|v| v.get_name().to_string())
                .unwrap_or_default()
        );
    }
    check_layout_format(args.layout, &args.output)?;
    Ok(ViewPlan {
        count,
        interaxial: 0.0,
        convergence: None,
        request,
    })
}

fn check_layout_format(layout: LayoutArg, out: &Path) -> Result<()> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    match layout {
        LayoutArg::Mpo if ext != "mpo" => {
            bail!("--layout mpo writes a .mpo file; got '{}'", out.display())
        }
        LayoutArg::Multiview if ext != "exr" => {
            bail!("--layout multiview writes one multi-view OpenEXR file: the output must end in .exr")
        }
        LayoutArg::Mpo | LayoutArg::Multiview => Ok(()),
        _ if ext == "mpo" => bail!("a .mpo output needs --layout mpo"),
        _ => {
            output::ImageFormat::from_path(out)?;
            Ok(())
        }
    }
}

/// Flag combinations that would be silently ignored or coerced, and values
/// the library refuses, found before the scene is read.
fn check_flags(args: &RenderArgs) -> Result<()> {
    let several_views = args.stereo
        || args.views.is_some_and(|n| n > 1)
        || (args.layout == LayoutArg::Quilt && args.views.is_none());
    if !several_views {
        if args.interaxial.is_some() {
            bail!("--interaxial needs --stereo or --views N (N > 1)");
        }
        if args.convergence.is_some() {
            bail!("--convergence needs --stereo or --views N (N > 1)");
        }
    }
    if args.squeeze
        && !matches!(
            args.layout,
            LayoutArg::Sbs | LayoutArg::Cross | LayoutArg::Tb
        )
    {
        bail!("--squeeze applies to --layout sbs, cross or tb only");
    }
    if args.anaglyph.is_some() && args.layout != LayoutArg::Anaglyph {
        bail!("--anaglyph chooses the colours of --layout anaglyph; add it or drop --anaglyph");
    }
    if args.interlace.is_some() && args.layout != LayoutArg::Interlace {
        bail!("--interlace chooses the pattern of --layout interlace; add it or drop --interlace");
    }
    if args.spd && args.min_weight.is_some() {
        bail!("--spd traces every ray (no cut-off): --min-weight does not apply");
    }
    let quilt_layout = args.layout == LayoutArg::Quilt;
    rig_choice::check_flags(&args.depth, several_views || quilt_layout, quilt_layout)?;
    if args.depth.depth {
        view_outputs::check_depth_output(
            &args.output,
            matches!(args.layout, LayoutArg::Separate | LayoutArg::Multiview),
        )?;
    }
    if let Some(n) = args.threads {
        twinray::job::check_threads(n).context("--threads")?;
    }
    args.sampling.sampling(args.spd)?;
    if let Some(n) = args.views_per_batch {
        if !(1..=render::MAX_LANES).contains(&n) {
            bail!(
                "--views-per-batch must be 1 to {}, got {n}",
                render::MAX_LANES
            );
        }
    }
    trace_settings(args).validate().map_err(|e| {
        let flag = if (1..=render::MAX_DEPTH).contains(&args.max_depth) {
            "--min-weight"
        } else {
            "--max-depth"
        };
        anyhow::anyhow!("{flag}: {e}")
    })?;
    Ok(())
}

fn trace_settings(args: &RenderArgs) -> TraceSettings {
    TraceSettings {
        max_depth: args.max_depth,
        min_weight: match (args.spd, args.min_weight) {
            (true, _) => 0.0,
            (false, Some(w)) => w,
            (false, None) => TraceSettings::default().min_weight,
        },
        spd: args.spd,
    }
}

/// Warnings for options that do nothing here but are harmless.
fn warn_about_flags(args: &RenderArgs) {
    let ext = args
        .output
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let float_output = matches!(ext.as_str(), "exr" | "pfm");
    if args.srgb && float_output {
        eprintln!(
            "twinray: warning: --srgb applies to 8-bit outputs; the .{ext} file stays linear"
        );
    }
}

/// The files this render will write, checked before rendering: formats, size
/// limits, directories, targets that may be replaced, and no output that is an
/// input or another output.
fn plan_outputs(
    args: &RenderArgs,
    plan: &ViewPlan,
    rig: &Rig,
    (width, height): (u32, u32),
) -> Result<Vec<PathBuf>> {
    let out = &args.output;
    let (w, h) = (u64::from(width), u64::from(height));
    let mut files = if plan.count == 1 {
        output::check_image_target(out, w, h)?;
        vec![out.clone()]
    } else if let (LayoutArg::Quilt, Some(spec)) = (args.layout, &args.depth.quilt) {
        vec![view_outputs::quilt_target(out, spec, width, height)?]
    } else if args.layout == LayoutArg::Multiview {
        output::check_stereo_targets(
            out,
            Layout::MultiviewExr,
            width,
            height,
            &stereo_options(args, plan, rig),
        )?
    } else if plan.count > 2 {
        let files: Vec<PathBuf> = (0..plan.count).map(|i| numbered(out, i)).collect();
        for f in &files {
            output::check_image_target(f, w, h)?;
        }
        files
    } else {
        output::check_stereo_targets(
            out,
            stereo_layout(args),
            width,
            height,
            &stereo_options(args, plan, rig),
        )?
    };
    if let Some(stats) = &args.stats {
        output::check_file_target(stats)?;
        files.push(stats.clone());
    }
    output::check_distinct(&files, &[&args.scene])?;
    Ok(files)
}

fn run_render(args: &RenderArgs) -> Result<Vec<PathBuf>> {
    let t0 = Instant::now();
    check_flags(args)?;
    warn_about_flags(args);
    let load_opts = LoadOptions {
        max_resolution: args.max_resolution,
        max_vertices: args.max_vertices,
        max_triangles: args.max_triangles,
    };
    let mut scene = load_scene(&args.scene, &load_opts)?;
    let load_s = t0.elapsed().as_secs_f64();
    let lights_warning = twinray::job::lights_warning(scene.lights.len());
    for w in scene.warnings.iter().chain(&lights_warning) {
        eprintln!("twinray: warning: {w}");
    }
    let overrides = ViewOverrides {
        camera: args.camera.clone(),
        from: args.from,
        at: args.at,
        up: args.up,
        fov_deg: args.fov,
    };
    view::apply(&mut scene, &overrides)?;
    if !scene.viewpoint_given && args.from.is_none() {
        eprintln!(
            "twinray: note: {} has no camera: looking at the whole scene from the front (set one with --from, --at, --up, --fov)",
            args.scene.display()
        );
    }
    if scene.format != SceneFormat::Nff && scene.add_headlight_if_dark() {
        eprintln!(
            "twinray: warning: {} has no lights: added a white point light at the camera",
            args.scene.display()
        );
    }
    let preset = args.depth.quilt.and_then(|q| q.preset);
    let (width, height) = match (args.size, args.spd, preset) {
        (Some(s), _, _) => s,
        (None, _, Some(p)) => (p.view_width, p.view_height),
        (None, true, None) => (512, 512),
        (None, false, None) => (scene.viewpoint.width, scene.viewpoint.height),
    };
    if width > args.max_resolution || height > args.max_resolution {
        bail!(
            "--size {width}x{height} exceeds the limit of {} per side (raise it with --max-resolution)",
            args.max_resolution
        );
    }
    let camera = Camera::new(&scene.viewpoint, width, height);
    let default_convergence = (scene.viewpoint.at - scene.viewpoint.from).length() as f64;
    let mut plan = plan_views(args, default_convergence)?;
    // The rig, or with an automatic spacing or convergence a stand-in until
    // the depth pass on the built scene (rig_choice::settle).
    let (mut rig, explicit_choice) = match &plan.request {
        None => (Rig::mono(), None),
        Some(request) => rig_choice::rig_before_depths(&camera, request)?,
    };
    if let Some(c) = &explicit_choice {
        (plan.interaxial, plan.convergence) = (c.interaxial, c.convergence);
    }
    let trace = trace_settings(args);
    let opts = RenderOptions {
        trace,
        method: match args.method {
            MethodArg::Independent => Method::Independent,
            MethodArg::Twin => Method::Twin,
        },
        sampling: args.sampling.sampling(args.spd)?,
        approx: args.approx.approximations()?,
        views_per_batch: args.views_per_batch.unwrap_or(0),
    };
    let mut cut = args.approx.cut(&camera, &rig)?;
    let approximate = !opts.approx.is_exact() || cut.is_some();
    if approximate && (plan.count == 1 || opts.method == Method::Independent) {
        bail!("the approximations (--fast, --merge-secondary, --reproject, --cut-*) need --stereo or --views and the twin method");
    }
    let files = plan_outputs(args, &plan, &rig, (width, height))?;
    let quilt_tiles = match (args.layout, &args.depth.quilt) {
        (LayoutArg::Quilt, Some(q)) => q.layout.tiles(),
        _ => 0,
    };
    let needed = twinray::job::estimate_render_memory(width, height, plan.count, opts.sampling)
        .saturating_add(view_outputs::extra_memory(
            width,
            height,
            plan.count,
            quilt_tiles,
            args.depth.depth,
        ));
    twinray::job::check_memory(
        needed,
        twinray::job::available_memory(),
        &format!("rendering {} view(s) of {width}x{height}", plan.count),
    )?;

    let pool = {
        // Worker stacks of 8 MiB (reserved, not used): room beyond the depth cap.
        let mut b = rayon::ThreadPoolBuilder::new().stack_size(8 << 20);
        if let Some(n) = args.threads {
            b = b.num_threads(n);
        }
        b.build().context("cannot start worker threads")?
    };
    let t_build = Instant::now();
    let mut world = pool.install(|| World::with_cut(scene, cut));
    let mut build_s = t_build.elapsed().as_secs_f64();
    let settled =
        match &plan.request {
            Some(request) => Some(pool.install(|| {
                rig_choice::settle(&world, &camera, request, args.depth.screen_width)
            })?),
            None => None,
        };
    if let (Some(s), None) = (&settled, &explicit_choice) {
        // The rig fitted to the depths: its outputs checked again (an MPO's
        // baseline), and the cut that depends on it made now.
        rig = s.rig.clone();
        (plan.interaxial, plan.convergence) = (s.choice.interaxial, s.choice.convergence);
        plan_outputs(args, &plan, &rig, (width, height))?;
        let fitted_cut = args.approx.cut(&camera, &rig)?;
        if fitted_cut.is_some() {
            let t = Instant::now();
            let scene = std::mem::take(&mut world.scene);
            world = pool.install(|| World::with_cut(scene, fitted_cut));
            build_s += t.elapsed().as_secs_f64();
            cut = fitted_cut;
        }
    }
    if args.verbose {
        eprintln!(
            "scene: {} primitives, {} lights, hierarchy {} nodes (depth {}), built in {:.3} s",
            world.scene.shapes.len(),
            world.scene.lights.len(),
            world.bvh.nodes.len(),
            world.bvh.depth(),
            build_s
        );
        describe_rig(&rig, &camera, &plan);
        if let Some(s) = &settled {
            rig_choice::print_report(s);
        }
        if let Some(c) = cut {
            eprintln!(
                "cut (section 2.3): {} of {} primitives beyond depth {:.3}",
                world.cut_primitives(),
                world.scene.shapes.len(),
                c.depth
            );
        }
    }

    let bar = if args.quiet || !std::io::stderr().is_terminal() {
        ProgressBar::hidden()
    } else {
        let b = ProgressBar::new(1);
        b.set_style(
            ProgressStyle::with_template(
                "{spinner} rendering [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        b
    };
    let progress = |done: u64, total: u64| {
        bar.set_length(total);
        bar.set_position(done);
    };
    if let Some(s) = &settled {
        rig_choice::print_warnings(s);
    }
    let mut result = pool.install(|| render::render(&world, &camera, &rig, &opts, &progress))?;
    bar.finish_and_clear();
    if let (Some(s), true) = (&settled, args.depth.floating_window) {
        output::apply_floating_window(&mut result.images, &s.report.floating_window);
        if args.verbose {
            let w = s.report.floating_window;
            eprintln!(
                "floating window: {} px masked at the left edge, {} px at the right",
                w.left_px, w.right_px
            );
        }
    }
    let depth_channels = args
        .depth
        .depth
        .then(|| pool.install(|| view_outputs::measure_depth(&world, &camera, &rig)));

    let t_write = Instant::now();
    let mut written = match (&depth_channels, args.layout, &args.depth.quilt) {
        (Some(depth), layout, _) => view_outputs::write_with_depth(
            (layout == LayoutArg::Multiview && plan.count > 1).then_some(args.output.as_path()),
            &files,
            &result.images,
            depth,
            plan.interaxial,
            rig.effective_convergence,
        )?,
        (None, LayoutArg::Quilt, Some(spec)) => view_outputs::write_quilt(
            &files[0],
            spec,
            &result.images,
            &WriteOptions { srgb: args.srgb },
        )?,
        _ => write_outputs(args, &result.images, &plan, &rig)?,
    };
    let write_s = t_write.elapsed().as_secs_f64();

    if args.verbose {
        eprintln!(
            "rendered {} view(s) {}x{} by {} in {:.3} s; eye rays {}, traversals per eye ray {:.3}",
            rig.views.len(),
            width,
            height,
            opts.method.name(),
            result.seconds,
            result.counts.rays.eye,
            result.counts.eye_traversals as f64 / result.counts.rays.eye.max(1) as f64
        );
        eprintln!(
            "sampling: {}; eye samples per pixel {:.2} (most {}), pixels refined {}",
            opts.sampling.describe(),
            result.samples_per_view as f64 / (f64::from(width) * f64::from(height)),
            result.max_samples_per_pixel,
            result.refined_pixels
        );
        if approximate {
            let c = &result.counts;
            eprintln!(
                "approximations: samples cut {}, secondary rays merged {}, samples reprojected {}, refused {}, traced as holes {}",
                c.samples_cut, c.merged_rays, c.reprojected, c.reproject_rejected, c.hole_samples
            );
        }
    }
    if let Some(path) = &args.stats {
        let mut report = Report {
            time: Timings {
                load_s,
                build_s,
                render_s: result.seconds,
                write_s,
                ..Timings::default()
            },
            scene: SceneFacts {
                primitives: world.scene.shapes.len(),
                lights: world.scene.lights.len(),
                materials: world.scene.materials.len(),
                bvh_nodes: world.bvh.nodes.len(),
                bvh_depth: world.bvh.depth(),
                memory_bytes: world.memory_bytes(),
                warnings: world.scene.warnings.len(),
            },
            width,
            height,
            views: rig.views.len(),
            method: if rig.views.len() == 1 {
                "mono".into()
            } else {
                opts.method.name().to_string()
            },
            samples_per_view: result.samples_per_view,
            sampling: SamplingFacts {
                mode: opts.sampling.describe(),
                eye_samples_per_pixel_mean: result.samples_per_view as f64
                    / (f64::from(width) * f64::from(height)),
                eye_samples_per_pixel_max: result.max_samples_per_pixel,
                refined_pixels: result.refined_pixels,
            },
            ..Report::default()
        };
        report.fill_counts(&result.counts, rig.views.len());
        report.cut_depth = cut.map(|c| c.depth);
        if let Some(s) = settled {
            report.time.depth_s = Some(s.depth_seconds);
            report.rig_choice = Some(s.choice);
            report.disparity = Some(s.report);
        }
        report.cut_primitives = world.cut_primitives();
        if plan.count > 1 {
            report.interaxial = Some(plan.interaxial);
            report.convergence = plan.convergence;
            report.effective_convergence = rig.effective_convergence;
        }
        output::write_text(path, &report.to_json())?;
        written.push(path.clone());
    }
    debug_assert_eq!(written.len(), files.len());
    Ok(written)
}

fn describe_rig(rig: &Rig, camera: &Camera, plan: &ViewPlan) {
    if rig.views.len() < 2 {
        return;
    }
    let conv = match plan.convergence {
        Some(c) => format!("{c}"),
        None => "infinity".into(),
    };
    let eff = match rig.effective_convergence {
        Some(c) => format!("{c:.6}"),
        None => "infinity (parallel)".into(),
    };
    eprintln!(
        "rig: {} views, interaxial {}, focal length {:.3} px, convergence asked {}, effective {}",
        rig.views.len(),
        plan.interaxial,
        camera.focal_pixels(),
        conv,
        eff
    );
    for (i, v) in rig.views.iter().enumerate() {
        eprintln!(
            "  view {i}: offset {:+.6} along the right axis, image shift {:+} px",
            v.offset, v.shift
        );
    }
}

fn stereo_options(args: &RenderArgs, plan: &ViewPlan, rig: &Rig) -> output::StereoOptions {
    output::StereoOptions {
        image: WriteOptions { srgb: args.srgb },
        squeeze: args.squeeze,
        baseline_m: plan.interaxial as f64,
        convergence_m: rig.effective_convergence,
    }
}

/// Writes the images (a set of files: all or none); returns the files written.
fn write_outputs(
    args: &RenderArgs,
    images: &[twinray::Image],
    plan: &ViewPlan,
    rig: &Rig,
) -> Result<Vec<PathBuf>> {
    let wo = WriteOptions { srgb: args.srgb };
    let out = &args.output;
    if images.len() == 1 {
        output::write_image(out, &images[0], &wo)?;
        return Ok(vec![out.clone()]);
    }
    if args.layout == LayoutArg::Multiview {
        let names: Vec<String> = if images.len() == 2 {
            vec!["left".into(), "right".into()]
        } else {
            (0..images.len()).map(|i| format!("view{i}")).collect()
        };
        let views: Vec<(&str, &twinray::Image)> = names
            .iter()
            .map(|n| n.as_str())
            .zip(images.iter())
            .collect();
        output::write_multiview_exr(
            out,
            &views,
            plan.interaxial,
            rig.effective_convergence.map(|c| c as f32),
        )?;
        return Ok(vec![out.clone()]);
    }
    if images.len() > 2 {
        // Separate files, one per view: scene_0.png, scene_1.png, ... encoded
        // first, then put in place together.
        let staged = images
            .iter()
            .enumerate()
            .map(|(i, img)| output::stage_image(&numbered(out, i), img, &wo))
            .collect::<twinray::Result<Vec<_>>>()?;
        return Ok(output::commit_all(staged)?);
    }
    let opts = stereo_options(args, plan, rig);
    Ok(output::write_stereo(
        out,
        stereo_layout(args),
        &images[0],
        &images[1],
        &opts,
    )?)
}

fn stereo_layout(args: &RenderArgs) -> Layout {
    match args.layout {
        // A quilt is written by view_outputs, never as a pair.
        LayoutArg::Separate | LayoutArg::Quilt => Layout::Separate,
        LayoutArg::Sbs => Layout::SideBySide,
        LayoutArg::Cross => Layout::Cross,
        LayoutArg::Tb => Layout::TopBottom,
        LayoutArg::Mpo => Layout::Mpo,
        LayoutArg::Multiview => Layout::MultiviewExr,
        LayoutArg::Anaglyph => {
            Layout::Anaglyph(match args.anaglyph.unwrap_or(AnaglyphArg::Dubois) {
                AnaglyphArg::Dubois => AnaglyphMethod::Dubois,
                AnaglyphArg::Color => AnaglyphMethod::Color,
                AnaglyphArg::Gray => AnaglyphMethod::Gray,
                AnaglyphArg::GreenMagenta => AnaglyphMethod::GreenMagenta,
                AnaglyphArg::YellowBlue => AnaglyphMethod::YellowBlue,
            })
        }
        LayoutArg::Interlace => {
            Layout::Interlace(match args.interlace.unwrap_or(InterlaceArg::Rows) {
                InterlaceArg::Rows => InterlaceMode::Rows,
                InterlaceArg::Columns => InterlaceMode::Columns,
                InterlaceArg::Checker => InterlaceMode::Checker,
            })
        }
    }
}

fn numbered(out: &Path, i: usize) -> PathBuf {
    let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("view");
    let name = match out.extension().and_then(|e| e.to_str()) {
        Some(ext) => format!("{stem}_{i}.{ext}"),
        None => format!("{stem}_{i}"),
    };
    out.with_file_name(name)
}
