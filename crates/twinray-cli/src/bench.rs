//! `twinray bench-stereo`: the paper's tables 2.1 and 2.2 — the time of a stereo
//! pair (or of N views) against the time of its views rendered alone, side by
//! side.
//!
//! The baseline is what a user would otherwise run: each view as a mono
//! render of its own camera (the eye moved by the view's offset, the view's
//! image shift), a job of its own, hierarchy built and the view traced. For
//! each scene, size and interaxial distance the N mono renders and every
//! configuration run in turn (mono renders, A, B, …, mono renders, A, B, …),
//! each run building the hierarchy; the medians and their ratio are
//! reported, with each configuration's images compared with the mono renders.
//! `--method independent` is not a baseline: it traces one ray at a time.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use twinray::job::{
    CameraSpec, CancelToken, CutSpec, Job, JobSpec, MethodName, MethodSpec, OutputSpec, RigSpec,
    SamplingSpec, TraceSpec,
};
use twinray::loaders::{load_scene, LoadOptions};
use twinray::output::compare;
use twinray::render::{RenderOutput, ReprojectMode, Sampling};
use twinray::rig::{Rig, View};
use twinray::Scene;

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
    /// Configurations, comma-separated: none (the exact twin method), cut
    /// (--cut-parallax, see below), merge (--merge-secondary), reproject (safe),
    /// paper (--reproject-mode paper), fast (--fast: at this bench's one sample a
    /// pixel, the epipolar rows). Each is timed against the views rendered
    /// alone, as mono renders, and its images compared with theirs (PSNR and
    /// largest difference, worst view).
    #[arg(long, value_delimiter = ',', value_enum, default_values_t = [Approx::None])]
    approx: Vec<Approx>,
    /// Disparity error in pixels allowed to cut objects (configuration cut).
    #[arg(long, default_value_t = 0.5)]
    cut_parallax: f64,
    /// Views of the rig (2: a stereo pair), spaced by each --interaxial.
    #[arg(long, default_value_t = 2)]
    views: usize,
    /// Sampling of both methods (default here: one ray per pixel centre, as
    /// the paper's tables).
    #[command(flatten)]
    sampling: twinray_args::SamplingArgs,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Approx {
    None,
    Cut,
    Merge,
    Reproject,
    Paper,
    Fast,
}

impl Approx {
    fn name(self) -> &'static str {
        match self {
            Approx::None => "none",
            Approx::Cut => "cut",
            Approx::Merge => "merge",
            Approx::Reproject => "reproject",
            Approx::Paper => "paper",
            Approx::Fast => "fast",
        }
    }

    /// The spec's method for this configuration.
    fn spec(self, cut_parallax: f64) -> MethodSpec {
        let mut m = MethodSpec::default();
        match self {
            Approx::None => {}
            Approx::Cut => m.cut = Some(CutSpec::Parallax(cut_parallax)),
            Approx::Merge => m.merge_secondary = true,
            Approx::Reproject => m.reproject = Some(ReprojectMode::Safe),
            Approx::Paper => m.reproject = Some(ReprojectMode::Paper),
            Approx::Fast => m.name = MethodName::Fast,
        }
        m
    }
}

/// One configuration of one scene, size and interaxial distance.
struct Row {
    scene: String,
    size: u32,
    interaxial: f32,
    approx: Approx,
    /// The views rendered alone: the sum of their mono renders.
    mono_s: f64,
    twin_s: f64,
    /// Worst view's PSNR against the mono renders (infinite if equal).
    psnr_db: f64,
    /// Largest channel difference over the views.
    max_abs: f32,
    traversals_per_eye_ray: f64,
    shared_secondary_rays: u64,
    secondary_rays: u64,
    grouped_samples: u64,
    eye_hits: u64,
    merged_rays: u64,
    reprojected: u64,
}

impl Row {
    fn exact(&self) -> bool {
        self.psnr_db == f64::INFINITY
    }
}

pub fn run(args: BenchArgs) -> Result<()> {
    check_args(&args)?;
    let mut rows = Vec::new();
    println!("| scene | size | interaxial | approx | views alone (s) | views (s) | views / views alone | PSNR (dB, worst view) | max abs | eye traversals per eye ray | shared secondary rays | hit samples grouped | merged rays | samples reprojected |");
    println!("|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for path in &args.scenes {
        let scene = load_scene(path, &LoadOptions::default())?;
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        for &size in &args.sizes {
            for &b in &args.interaxial {
                for row in measure(&scene, &name, size, b, &args)? {
                    println!(
                        "| {} | {}² | {} | {} | {:.3} | {:.3} | {:.3} | {} | {:.4} | {:.3} | {} of {} | {:.0} % | {} | {} |",
                        row.scene,
                        row.size,
                        row.interaxial,
                        row.approx.name(),
                        row.mono_s,
                        row.twin_s,
                        row.twin_s / row.mono_s,
                        if row.exact() { "exact".to_string() } else { format!("{:.1}", row.psnr_db) },
                        row.max_abs,
                        row.traversals_per_eye_ray,
                        row.shared_secondary_rays,
                        row.secondary_rays,
                        100.0 * row.grouped_samples as f64 / row.eye_hits.max(1) as f64,
                        row.merged_rays,
                        row.reprojected,
                    );
                    rows.push(row);
                }
            }
        }
    }
    if let Some(path) = &args.csv {
        let mut csv = String::from(
            "scene,size,interaxial,approx,mono_s,views_s,ratio,exact,psnr_db,max_abs,traversals_per_eye_ray\n",
        );
        for r in &rows {
            let _ = writeln!(
                csv,
                "{},{},{},{},{:.5},{:.5},{:.5},{},{:.3},{:.6},{:.5}",
                r.scene,
                r.size,
                r.interaxial,
                r.approx.name(),
                r.mono_s,
                r.twin_s,
                r.twin_s / r.mono_s,
                r.exact(),
                r.psnr_db,
                r.max_abs,
                r.traversals_per_eye_ray
            );
        }
        twinray::output::write_text(path, &csv)?;
    }
    if rows.iter().any(|r| r.approx == Approx::None && !r.exact()) {
        bail!("the exact method's views differ from the views rendered alone");
    }
    Ok(())
}

/// Everything that can be refused before the first render: counts, sizes,
/// distances, and the memory of the largest pair (the views and the views
/// rendered alone are kept, so twice a pair).
fn check_args(args: &BenchArgs) -> Result<()> {
    if args.runs == 0 {
        bail!("--runs must be at least 1");
    }
    if !(args.cut_parallax.is_finite() && args.cut_parallax > 0.0) {
        bail!("--cut-parallax must be a number of pixels > 0");
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
        // Its pairs are compared as floats.
        let pair = twinray::job::estimate_render_memory(
            size,
            size,
            2,
            Sampling::Centers,
            twinray::job::ViewsKeptAs::Floats,
        );
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

/// Times the views rendered alone and every configuration asked for, in
/// turn (mono renders, A, B, … mono renders, A, B, …), and compares each
/// configuration's images with the mono renders. Each run is a job of its
/// own on the parsed scene.
fn measure(scene: &Scene, name: &str, size: u32, b: f32, args: &BenchArgs) -> Result<Vec<Row>> {
    let spec = |views: usize, method: MethodSpec| JobSpec {
        camera: CameraSpec {
            size: Some([size, size]),
            ..CameraSpec::default()
        },
        rig: match views {
            1 => RigSpec::default(),
            _ => RigSpec {
                views: Some(views),
                interaxial: Some(b.to_string()),
                convergence: args.convergence.clone(),
                ..RigSpec::default()
            },
        },
        trace: TraceSpec {
            threads: args.threads,
            ..TraceSpec::default()
        },
        // The paper's tables trace one ray per pixel centre.
        sampling: if args.sampling.given() {
            args.sampling.spec()
        } else {
            SamplingSpec {
                samples: Some(1),
                ..SamplingSpec::default()
            }
        },
        method,
        output: OutputSpec {
            path: "bench.png".into(),
            ..OutputSpec::default()
        },
        ..JobSpec::default()
    };
    // Build + render, as a user would wait for it (the file is already
    // parsed; the disparity report's depth pass is not counted).
    let timed = |a: Approx| -> Result<(f64, RenderOutput)> {
        let job = Job::check(spec(args.views, a.spec(args.cut_parallax)))?;
        let loaded = job.prepare(scene.clone())?;
        let plan = job.plan(&loaded)?;
        let rendered = job.render(&plan, &|_, _| {}, &CancelToken::new())?;
        Ok((
            plan.build_seconds + rendered.output.seconds,
            rendered.output,
        ))
    };
    // The rig's camera and views, as the exact method plans them.
    let (camera, rig) = {
        let job = Job::check(spec(args.views, MethodSpec::default()))?;
        let loaded = job.prepare(scene.clone())?;
        let plan = job.plan(&loaded)?;
        (plan.camera, plan.rig)
    };
    // Each view alone: a mono job whose camera is the view's (its eye moved
    // along the right axis, its image shift), as the oracle test renders it.
    let alone = || -> Result<(f64, RenderOutput)> {
        let mut seconds = 0.0;
        let mut out: Option<RenderOutput> = None;
        for view in &rig.views {
            let job = Job::check(spec(1, MethodSpec::default()))?;
            let loaded = job.prepare(scene.clone())?;
            let mut plan = job.plan(&loaded)?;
            plan.camera.eye = camera.eye_at(view.offset);
            plan.rig = Rig {
                views: vec![View {
                    offset: 0.0,
                    shift: view.shift,
                }],
                convergence: None,
                effective_convergence: None,
            };
            let rendered = job.render(&plan, &|_, _| {}, &CancelToken::new())?;
            seconds += plan.build_seconds + rendered.output.seconds;
            match out.as_mut() {
                None => out = Some(rendered.output),
                Some(o) => o.images.extend(rendered.output.images),
            }
        }
        let Some(out) = out else {
            bail!("no view");
        };
        Ok((seconds, out))
    };
    let mut mono = Vec::new();
    let mut times = vec![Vec::new(); args.approx.len()];
    let mut outputs: Vec<Option<RenderOutput>> = args.approx.iter().map(|_| None).collect();
    let mut reference = None;
    for _ in 0..args.runs {
        let (t, out) = alone()?;
        mono.push(t);
        reference = Some(out);
        for (k, &a) in args.approx.iter().enumerate() {
            let (t, out) = timed(a)?;
            times[k].push(t);
            outputs[k] = Some(out);
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let mono_s = median(&mut mono);
    let Some(reference) = reference else {
        bail!("no run");
    };
    let mut rows = Vec::new();
    for (k, &approx) in args.approx.iter().enumerate() {
        let Some(out) = outputs[k].take() else {
            continue;
        };
        let mut row = Row::of(&reference, &out)?;
        (row.scene, row.size, row.interaxial, row.approx) = (name.to_string(), size, b, approx);
        (row.mono_s, row.twin_s) = (mono_s, median(&mut times[k]));
        rows.push(row);
    }
    Ok(rows)
}

impl Row {
    /// A configuration's row: its images against the mono renders
    /// (worst view), and its counts; the scene, size and times to fill.
    fn of(reference: &RenderOutput, out: &RenderOutput) -> Result<Row> {
        let (mut psnr_db, mut max_abs) = (f64::INFINITY, 0.0f32);
        for (a, b) in reference.images.iter().zip(&out.images) {
            let d = compare(a, b)?;
            psnr_db = psnr_db.min(d.psnr_db);
            max_abs = max_abs.max(d.max_abs);
        }
        let c = out.counts;
        Ok(Row {
            scene: String::new(),
            size: 0,
            interaxial: 0.0,
            approx: Approx::None,
            mono_s: 0.0,
            twin_s: 0.0,
            psnr_db,
            max_abs,
            traversals_per_eye_ray: c.eye_traversals as f64 / c.rays.eye.max(1) as f64,
            shared_secondary_rays: c.shared_secondary_rays,
            secondary_rays: c.rays.reflected + c.rays.refracted,
            grouped_samples: c.grouped_samples,
            eye_hits: c.rays.eye_hit,
            merged_rays: c.paper.merged_rays,
            reprojected: c.paper.reprojected,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each configuration is one method of the spec: `fast` the fast
    /// method alone, the others the twin method with one of the paper's
    /// techniques (the combinations the job's check refuses are not among
    /// them).
    #[test]
    fn each_configuration_is_one_method() {
        let fast = Approx::Fast.spec(0.7);
        assert_eq!(fast.name, MethodName::Fast);
        assert!(fast.cut.is_none() && !fast.merge_secondary && fast.reproject.is_none());
        let cut = Approx::Cut.spec(0.7);
        assert_eq!(
            (cut.name, cut.cut),
            (MethodName::Twin, Some(CutSpec::Parallax(0.7)))
        );
        assert_eq!(
            Approx::Paper.spec(0.7).reproject,
            Some(ReprojectMode::Paper)
        );
    }
}
