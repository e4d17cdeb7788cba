//! The `twinray` command: parses arguments into a job, runs its stages,
//! prints what they report, shows progress.

mod bench;
mod cpu;
mod preview;
mod progress_lines;

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::OnceLock;

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use twinray::job::{CancelToken, Job, JobSpec, Level, Message};
use twinray::output::{self, WriteOptions};

use twinray_args::RenderArgs;

mod animation;

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
    /// Set the rig by eye: a live preview in the browser (render flags as for
    /// `render`; -o names the files of "Render full size").
    #[command(mut_arg("output", |a| a.required_unless_present(clap::builder::Resettable::<clap::Id>::Reset)))]
    Preview(Box<preview::PreviewArgs>),
    /// Assemble the tiles of a still (render --tiles N) into the whole image.
    Merge(MergeArgs),
}

#[derive(clap::Args)]
struct MergeArgs {
    /// The tiles, NAME_tileKofN.ext, in any order (all N of one set).
    #[arg(required = true)]
    tiles: Vec<PathBuf>,
    /// The whole image (.png, .exr or .pfm).
    #[arg(short, long)]
    output: PathBuf,
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

/// A command-line error from clap as one line (`twinray: ...`), like every other
/// error; help and version requests are printed by clap as usual. A flag
/// that was removed is named with what replaced it.
fn parse_args() -> std::result::Result<Cli, ExitCode> {
    use clap::error::ErrorKind;
    let args: Vec<std::ffi::OsString> = std::env::args_os().skip(1).collect();
    if let Err(line) = twinray_args::refuse_removed(&args) {
        eprintln!("twinray: {line}");
        return Err(ExitCode::from(2));
    }
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

/// SIGINT, SIGTERM (and SIGHUP): a render in flight is cancelled and stops at
/// its next row; otherwise (or at a second signal) the temporary files of an
/// output being written are removed and the process exits, as a shell expects
/// of an interrupted program.
fn install_signal_handler() {
    let installed = ctrlc::set_handler(|| {
        if RENDERING.load(Ordering::Relaxed) && !cancel_token().is_cancelled() {
            cancel_token().cancel();
            return;
        }
        interrupted();
    });
    if let Err(e) = installed {
        eprintln!("twinray: warning: cannot handle interruptions ({e}); an interrupted write may leave a .twinray-*.tmp file");
    }
}

/// Removes temporary files and exits with 130.
pub(crate) fn interrupted() -> ! {
    output::remove_temporary_files();
    eprintln!("twinray: interrupted");
    std::process::exit(130);
}

/// Whether a render is in flight (a signal then cancels it).
pub(crate) static RENDERING: AtomicBool = AtomicBool::new(false);

/// Keeps glibc from raising its mmap threshold as large blocks are freed:
/// otherwise, after the first frame of an animation, the frames' images are
/// taken from the heap, whose free space is kept. Measured on 24 frames of
/// SPD teapot, 640x360 per eye (docs/benchmarks.md#animation): peak RSS
/// 36.6 MiB without, 29.9 MiB with; over a 240-frame SBS MP4, 45.7 MiB
/// without and 30.4 MiB with (1.14x a 1-frame video's).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn fix_mmap_threshold() {
    // SAFETY: mallopt only sets an allocator parameter, which glibc allows
    // at any time; it is called first thing in main, before any thread.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 128 * 1024);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn fix_mmap_threshold() {}

fn main() -> ExitCode {
    // Before anything built for the newer instructions runs.
    cpu::require();
    fix_mmap_threshold();
    let cli = match parse_args() {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    install_panic_hook();
    install_signal_handler();
    let result = match cli.command {
        Command::Render(args) => {
            run_render(&args).map(|written| list_written(&written, args.output.quiet))
        }
        Command::BenchStereo(args) => bench::run(args),
        Command::Compare(args) => run_compare(&args),
        Command::Merge(args) => twinray::job::tiles::merge(&args.tiles, &args.output)
            .map(|()| list_written(std::slice::from_ref(&args.output), false))
            .map_err(Into::into),
        Command::Preview(args) => preview::run(&args),
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

/// Raised by ctrl-c: the render in flight stops at its next row.
static CANCEL: OnceLock<CancelToken> = OnceLock::new();

pub(crate) fn cancel_token() -> &'static CancelToken {
    CANCEL.get_or_init(CancelToken::new)
}

/// The spec of a `render` command line: its flags, or `--job FILE` with
/// SCENE and -o on top.
pub(crate) fn render_spec(args: &RenderArgs) -> Result<JobSpec> {
    let flags = args.spec();
    let Some(path) = &args.output.job else {
        return Ok(flags);
    };
    let text = twinray::loaders::files::read_user_text(path, "--job")?;
    let mut spec =
        JobSpec::from_json(&text).with_context(|| format!("--job {}", path.display()))?;
    spec.read_files.push(path.clone());
    // Everything but SCENE and -o comes from the file: other flags would be
    // ignored, so they are refused.
    let mut rest = flags.clone();
    rest.scene = PathBuf::new();
    rest.output.path = PathBuf::new();
    if rest != JobSpec::default() {
        bail!("--job takes every setting from {}: give only SCENE and -o with it (or put the others in the file)", path.display());
    }
    if let Some(scene) = &args.scene {
        spec.scene = scene.clone();
    }
    if let Some(out) = &args.output.output {
        spec.output.path = out.clone();
    }
    Ok(spec)
}

/// Prints a stage's messages: warnings always, notes unless -q, details with -v.
pub(crate) fn print_messages(messages: &[Message], args: &RenderArgs) {
    for m in messages {
        match m.level {
            Level::Warning => eprintln!("twinray: warning: {}", m.text),
            Level::Note if !args.output.quiet => eprintln!("twinray: note: {}", m.text),
            Level::Info if args.output.verbose => eprintln!("{}", m.text),
            Level::Note | Level::Info => {}
        }
    }
}

fn run_render(args: &RenderArgs) -> Result<Vec<PathBuf>> {
    let spec = render_spec(args)?;
    if args.output.print_job {
        println!("{}", spec.to_json());
        return Ok(Vec::new());
    }
    if spec.animation.frames.is_some() {
        return animation::run(spec, args);
    }
    if let (Some(count), None) = (args.animation.tiles, spec.tile) {
        // Every tile, one after the other, from one loaded scene.
        let mut written = Vec::new();
        let mut loaded = None;
        for index in 0..count {
            let mut s = spec.clone();
            s.tile = Some(twinray::job::TileSpec { index, count });
            let job = Job::check(s)?;
            let loaded = match &loaded {
                Some(l) => l,
                None => {
                    let l = job.load()?;
                    print_messages(&l.messages, args);
                    loaded.insert(l)
                }
            };
            written.extend(render_still(&job, loaded, args)?);
        }
        return Ok(written);
    }
    let job = Job::check(spec)?;
    let loaded = job.load()?;
    print_messages(&loaded.messages, args);
    render_still(&job, &loaded, args)
}

/// A progress bar on a terminal; where stderr is not one, a line every few
/// seconds (`progress_lines`); nothing with --quiet.
pub(crate) fn progress_bar(args: &RenderArgs, template: &str) -> ProgressBar {
    if args.output.quiet {
        return ProgressBar::hidden();
    }
    if !std::io::stderr().is_terminal() {
        return progress_lines::bar(template);
    }
    let b = ProgressBar::new(1);
    b.set_style(
        ProgressStyle::with_template(template)
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    b
}

/// Plans, renders and writes one still of a checked job.
fn render_still(
    job: &Job,
    loaded: &twinray::job::Loaded,
    args: &RenderArgs,
) -> Result<Vec<PathBuf>> {
    print_messages(job.messages(), args);
    let plan = job.plan(loaded)?;
    print_messages(&plan.messages, args);

    let bar = progress_bar(
        args,
        "{spinner} rendering [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
    );
    let progress = |done: u64, total: u64| {
        bar.set_length(total);
        bar.set_position(done);
    };
    RENDERING.store(true, Ordering::Relaxed);
    let rendered = job.render_for_writing(&plan, &progress, cancel_token());
    RENDERING.store(false, Ordering::Relaxed);
    bar.finish_and_clear();
    if let Err(twinray::Error::Cancelled) = rendered {
        interrupted();
    }
    let rendered = rendered?;
    print_messages(&rendered.messages, args);
    Ok(job.write(loaded, &plan, &rendered)?)
}
