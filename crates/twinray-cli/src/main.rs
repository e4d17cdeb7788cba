//! The `twinray` command: parses arguments, shows progress, calls the library.

mod bench;

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
use twinray::render::{self, Method, RenderOptions, Sampling, TraceSettings};
use twinray::rig::Rig;
use twinray::scene::SceneFormat;
use twinray::stats::{Report, SceneFacts, Timings};
use twinray::view::{self, ViewOverrides};
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
    Render(RenderArgs),
    /// Time stereo pairs: the twin method against two independent renders (the paper's tables 2.1, 2.2).
    BenchStereo(bench::BenchArgs),
    /// Compare two images: PSNR, largest difference, differing pixels.
    Compare {
        a: PathBuf,
        b: PathBuf,
        /// Also write |a - b| scaled by --gain to this image.
        #[arg(long)]
        diff: Option<PathBuf>,
        #[arg(long, default_value_t = 10.0)]
        gain: f32,
    },
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
    /// Output image: .png (8-bit), .exr or .pfm (32-bit float, linear), .mpo.
    #[arg(short, long)]
    output: PathBuf,
    /// Image size WxH (default: the scene's resolution).
    #[arg(long, value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Worker threads (default: all cores). The image is the same for any count.
    #[arg(long)]
    threads: Option<usize>,
    /// Deepest ray level (the eye ray is level 1).
    #[arg(long, default_value_t = 5)]
    max_depth: u32,
    /// Adaptive cut-off: skip secondary rays whose weight in the pixel is below this (0 = off).
    #[arg(long, default_value_t = 1.0 / 256.0)]
    min_weight: f32,
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
    /// Print scene facts, the rig and timings on stderr.
    #[arg(short, long)]
    verbose: bool,
    /// Apply the sRGB transfer curve to 8-bit outputs (default: values as computed).
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
    /// Distance between the eyes, in scene units.
    #[arg(long, allow_negative_numbers = true)]
    interaxial: Option<f32>,
    /// Zero-parallax distance: a number, or "inf" for parallel cameras (default: distance to the NFF 'at' point).
    #[arg(long, allow_negative_numbers = true)]
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
    #[arg(long, value_enum, default_value_t = AnaglyphArg::Dubois)]
    anaglyph: AnaglyphArg,
    #[arg(long, value_enum, default_value_t = InterlaceArg::Rows)]
    interlace: InterlaceArg,
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

fn main() -> ExitCode {
    let cli = match parse_args() {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    let result = match cli.command {
        Command::Render(args) => run_render(args),
        Command::BenchStereo(args) => bench::run(args),
        Command::Compare { a, b, diff, gain } => run_compare(&a, &b, diff.as_deref(), gain),
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

fn run_compare(a: &Path, b: &Path, diff: Option<&Path>, gain: f32) -> Result<()> {
    let ia = output::read_image(a)?;
    let ib = output::read_image(b)?;
    let d = output::compare(&ia, &ib)?;
    println!(
        "psnr_db {:.3}  max_abs {:.6}  mean_abs {:.6}  differing_pixels {}",
        d.psnr_db, d.max_abs, d.mean_abs, d.differing_pixels
    );
    if let Some(path) = diff {
        output::write_image(
            path,
            &output::difference_image(&ia, &ib, gain)?,
            &WriteOptions::default(),
        )?;
    }
    Ok(())
}

/// How many views, how far apart, converging where: checked before any work.
struct ViewPlan {
    count: usize,
    interaxial: f32,
    convergence: Option<f64>,
}

fn plan_views(args: &RenderArgs, default_convergence: f64) -> Result<ViewPlan> {
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
        (false, None) => 1,
    };
    let interaxial = match args.interaxial {
        Some(b) if !(b.is_finite() && b >= 0.0) => bail!("--interaxial must be a finite distance >= 0, got {b}"),
        Some(b) => b,
        None if count > 1 => bail!("--interaxial B is required with --stereo or --views (distance between the eyes, in scene units)"),
        None => 0.0,
    };
    let convergence = match args.convergence.as_deref() {
        None => Some(default_convergence),
        Some("inf") | Some("infinity") => None,
        Some(s) => {
            let c: f64 = s
                .parse()
                .with_context(|| format!("--convergence '{s}' is neither a distance nor 'inf'"))?;
            if !(c.is_finite() && c > 0.0) {
                bail!("--convergence must be a distance > 0 or 'inf', got {s}");
            }
            Some(c)
        }
    };
    if count == 1 && args.layout != LayoutArg::Separate {
        bail!("--layout needs --stereo (or --views)");
    }
    if count != 2 && !matches!(args.layout, LayoutArg::Separate | LayoutArg::Multiview) {
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
        interaxial,
        convergence,
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

fn run_render(args: RenderArgs) -> Result<()> {
    let t0 = Instant::now();
    if let Some(0) = args.threads {
        bail!("--threads must be at least 1");
    }
    let load_opts = LoadOptions {
        max_resolution: args.max_resolution,
        max_vertices: args.max_vertices,
        max_triangles: args.max_triangles,
    };
    let mut scene = load_scene(&args.scene, &load_opts)?;
    let load_s = t0.elapsed().as_secs_f64();
    for w in &scene.warnings {
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
    let (width, height) = match (args.size, args.spd) {
        (Some(s), _) => s,
        (None, true) => (512, 512),
        (None, false) => (scene.viewpoint.width, scene.viewpoint.height),
    };
    if width > args.max_resolution || height > args.max_resolution {
        bail!(
            "--size {width}x{height} exceeds the limit of {} per side (raise it with --max-resolution)",
            args.max_resolution
        );
    }
    let camera = Camera::new(&scene.viewpoint, width, height);
    let default_convergence = (scene.viewpoint.at - scene.viewpoint.from).length() as f64;
    let plan = plan_views(&args, default_convergence)?;
    let rig = if plan.count == 1 {
        Rig::mono()
    } else {
        Rig::multi_view(&camera, plan.count, plan.interaxial, plan.convergence)
    };
    let trace = TraceSettings {
        max_depth: args.max_depth.max(1),
        min_weight: if args.spd {
            0.0
        } else {
            args.min_weight.max(0.0)
        },
        spd: args.spd,
    };
    let opts = RenderOptions {
        trace,
        method: match args.method {
            MethodArg::Independent => Method::Independent,
            MethodArg::Twin => Method::Twin,
        },
        sampling: if args.spd {
            Sampling::Corners
        } else {
            Sampling::Centers
        },
    };

    let pool = {
        let mut b = rayon::ThreadPoolBuilder::new();
        if let Some(n) = args.threads {
            b = b.num_threads(n);
        }
        b.build().context("cannot start worker threads")?
    };
    let t_build = Instant::now();
    let world = pool.install(|| World::new(scene));
    let build_s = t_build.elapsed().as_secs_f64();
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
    let result = pool.install(|| render::render(&world, &camera, &rig, &opts, &progress))?;
    bar.finish_and_clear();

    let t_write = Instant::now();
    write_outputs(&args, &result.images, &plan, &rig)?;
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
            ..Report::default()
        };
        report.fill_counts(&result.counts, rig.views.len());
        if plan.count > 1 {
            report.interaxial = Some(plan.interaxial);
            report.convergence = plan.convergence;
            report.effective_convergence = rig.effective_convergence;
        }
        output::write_text(path, &report.to_json())?;
    }
    Ok(())
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

fn write_outputs(
    args: &RenderArgs,
    images: &[twinray::Image],
    plan: &ViewPlan,
    rig: &Rig,
) -> Result<()> {
    let wo = WriteOptions { srgb: args.srgb };
    let out = &args.output;
    if images.len() == 1 {
        output::write_image(out, &images[0], &wo)?;
        return Ok(());
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
        return Ok(());
    }
    if images.len() > 2 {
        // Separate files, one per view: scene_0.png, scene_1.png, ...
        for (i, img) in images.iter().enumerate() {
            output::write_image(&numbered(out, i), img, &wo)?;
        }
        return Ok(());
    }
    let layout = stereo_layout(args);
    let opts = output::StereoOptions {
        image: wo,
        squeeze: args.squeeze,
        baseline_m: plan.interaxial as f64,
        convergence_m: rig.effective_convergence,
    };
    output::write_stereo(out, layout, &images[0], &images[1], &opts)?;
    Ok(())
}

fn stereo_layout(args: &RenderArgs) -> Layout {
    match args.layout {
        LayoutArg::Separate => Layout::Separate,
        LayoutArg::Sbs => Layout::SideBySide,
        LayoutArg::Cross => Layout::Cross,
        LayoutArg::Tb => Layout::TopBottom,
        LayoutArg::Mpo => Layout::Mpo,
        LayoutArg::Multiview => Layout::MultiviewExr,
        LayoutArg::Anaglyph => Layout::Anaglyph(match args.anaglyph {
            AnaglyphArg::Dubois => AnaglyphMethod::Dubois,
            AnaglyphArg::Color => AnaglyphMethod::Color,
            AnaglyphArg::Gray => AnaglyphMethod::Gray,
            AnaglyphArg::GreenMagenta => AnaglyphMethod::GreenMagenta,
            AnaglyphArg::YellowBlue => AnaglyphMethod::YellowBlue,
        }),
        LayoutArg::Interlace => Layout::Interlace(match args.interlace {
            InterlaceArg::Rows => InterlaceMode::Rows,
            InterlaceArg::Columns => InterlaceMode::Columns,
            InterlaceArg::Checker => InterlaceMode::Checker,
        }),
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
