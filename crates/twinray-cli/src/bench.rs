//! `twinray bench-stereo`: the paper's tables 2.1 and 2.2 — the time of a stereo
//! pair by the twin method against two independent renders, side by side.
//!
//! For each scene, size and interaxial distance the two methods run alternately
//! (A B A B A B), each run building the hierarchy and rendering both eyes; the
//! medians and their ratio are reported, with a check that the images agree.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use twinray::camera::Camera;
use twinray::loaders::{load_scene, LoadOptions};
use twinray::render::{self, Method, RenderOptions, Sampling, TraceSettings};
use twinray::rig::Rig;
use twinray::{Scene, World};

#[derive(clap::Args)]
pub struct BenchArgs {
    /// Scene files (.nff).
    #[arg(required = true)]
    scenes: Vec<PathBuf>,
    /// Image sizes (square), comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [128u32, 256, 512, 1024])]
    sizes: Vec<u32>,
    /// Interaxial distances in scene units, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [0.0f32, 0.05, 0.1, 0.2])]
    interaxial: Vec<f32>,
    /// Runs of each method per configuration (the median is reported).
    #[arg(long, default_value_t = 3)]
    runs: usize,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Convergence: a distance, or "inf" (default: distance to the NFF 'at' point).
    #[arg(long)]
    convergence: Option<String>,
    /// Also write the table as CSV.
    #[arg(long)]
    csv: Option<PathBuf>,
}

struct Row {
    scene: String,
    size: u32,
    interaxial: f32,
    independent_s: f64,
    twin_s: f64,
    exact: bool,
    traversals_per_eye_ray: f64,
    shared_secondary_rays: u64,
    secondary_rays: u64,
    grouped_samples: u64,
    eye_hits: u64,
}

pub fn run(args: BenchArgs) -> Result<()> {
    check_args(&args)?;
    let pool = {
        let mut b = rayon::ThreadPoolBuilder::new();
        if let Some(n) = args.threads {
            b = b.num_threads(n);
        }
        b.build()?
    };
    let mut rows = Vec::new();
    println!("| scene | size | interaxial | independent (s) | twin (s) | twin / independent | exact | eye traversals per eye ray | shared secondary rays | hit samples grouped |");
    println!("|---|---:|---:|---:|---:|---:|:---:|---:|---:|---:|");
    for path in &args.scenes {
        let scene = load_scene(path, &LoadOptions::default())?;
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        for &size in &args.sizes {
            for &b in &args.interaxial {
                let row = pool.install(|| measure(&scene, &name, size, b, &args))?;
                println!(
                    "| {} | {}² | {} | {:.3} | {:.3} | {:.3} | {} | {:.3} | {} of {} | {:.0} % |",
                    row.scene,
                    row.size,
                    row.interaxial,
                    row.independent_s,
                    row.twin_s,
                    row.twin_s / row.independent_s,
                    if row.exact { "yes" } else { "**no**" },
                    row.traversals_per_eye_ray,
                    row.shared_secondary_rays,
                    row.secondary_rays,
                    100.0 * row.grouped_samples as f64 / row.eye_hits.max(1) as f64
                );
                rows.push(row);
            }
        }
    }
    if let Some(path) = &args.csv {
        let mut csv = String::from(
            "scene,size,interaxial,independent_s,twin_s,ratio,exact,traversals_per_eye_ray\n",
        );
        for r in &rows {
            let _ = writeln!(
                csv,
                "{},{},{},{:.5},{:.5},{:.5},{},{:.5}",
                r.scene,
                r.size,
                r.interaxial,
                r.independent_s,
                r.twin_s,
                r.twin_s / r.independent_s,
                r.exact,
                r.traversals_per_eye_ray
            );
        }
        twinray::output::write_text(path, &csv)?;
    }
    if rows.iter().any(|r| !r.exact) {
        bail!("the twin method's images differ from the independent renders");
    }
    Ok(())
}

/// Everything that can be refused before the first render: counts, sizes,
/// distances, and the memory of the largest pair (both methods' images are
/// kept, so twice a pair).
fn check_args(args: &BenchArgs) -> Result<()> {
    if args.runs == 0 {
        bail!("--runs must be at least 1");
    }
    if let Some(n) = args.threads {
        twinray::job::check_threads(n).context("--threads")?;
    }
    if let Some(&b) = args
        .interaxial
        .iter()
        .find(|b| !(b.is_finite() && **b >= 0.0))
    {
        bail!("--interaxial must be finite distances >= 0, got {b}");
    }
    if args.sizes.contains(&0) {
        bail!("--sizes must be at least 1");
    }
    if let Some(&size) = args.sizes.iter().max() {
        let pair = twinray::job::estimate_render_memory(size, size, 2, Sampling::Centers);
        twinray::job::check_memory(
            pair.saturating_mul(2),
            twinray::job::available_memory(),
            &format!("--sizes {size} (two stereo pairs of {size}x{size})"),
        )?;
    }
    if let Some(csv) = &args.csv {
        twinray::output::check_file_target(csv)?;
        let scenes: Vec<&std::path::Path> = args.scenes.iter().map(|p| p.as_path()).collect();
        twinray::output::check_distinct(std::slice::from_ref(csv), &scenes)?;
    }
    Ok(())
}

fn measure(scene: &Scene, name: &str, size: u32, b: f32, args: &BenchArgs) -> Result<Row> {
    let camera = Camera::new(&scene.viewpoint, size, size);
    let convergence = match args.convergence.as_deref() {
        None => Some((scene.viewpoint.at - scene.viewpoint.from).length() as f64),
        Some("inf") => None,
        Some(s) => Some(s.parse::<f64>()?),
    };
    let rig = Rig::stereo(&camera, b, convergence)?;
    let opts = |method| RenderOptions {
        trace: TraceSettings::default(),
        method,
        sampling: Sampling::Centers,
    };
    // Build + render, as a user would wait for it (the file is already parsed).
    let timed = |method| -> Result<(f64, render::RenderOutput)> {
        let start = Instant::now();
        let world = World::new(scene.clone());
        let out = render::render(&world, &camera, &rig, &opts(method), &|_, _| {})?;
        Ok((start.elapsed().as_secs_f64(), out))
    };
    let (mut ti, mut tt) = (Vec::new(), Vec::new());
    let mut exact = true;
    let mut twin_counts = None;
    for _ in 0..args.runs {
        let (a, ia) = timed(Method::Independent)?;
        let (t, it) = timed(Method::Twin)?;
        exact &= ia.images == it.images;
        ti.push(a);
        tt.push(t);
        twin_counts = Some(it.counts);
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let c = twin_counts.unwrap_or_default();
    Ok(Row {
        scene: name.to_string(),
        size,
        interaxial: b,
        independent_s: median(&mut ti),
        twin_s: median(&mut tt),
        exact,
        traversals_per_eye_ray: c.eye_traversals as f64 / c.rays.eye.max(1) as f64,
        shared_secondary_rays: c.shared_secondary_rays,
        secondary_rays: c.rays.reflected + c.rays.refracted,
        grouped_samples: c.grouped_samples,
        eye_hits: c.rays.eye_hit,
    })
}
