//! What a live preview asks of `twinray::job`: plans at a fraction of the
//! size, other sampling, the layout composed in memory, the disparity
//! histogram, a shared worker pool, and the command line of a spec.

use crate::common;

use std::sync::Arc;

use twinray::job::{CancelToken, Job, JobSpec, LayoutSpec, Pass};
use twinray::output::{self, WriteOptions};
use twinray::render::Sampling;

fn pair(size: [u32; 2]) -> JobSpec {
    let mut spec = JobSpec::new(common::scene_path("example.nff"), "unused.png");
    spec.camera.size = Some(size);
    spec.rig.stereo = true;
    spec
}

fn no_progress(_: u64, _: u64) {}

#[test]
fn a_reduced_plan_keeps_the_rig_at_a_fraction_of_the_size() {
    let mut spec = pair([81, 61]);
    spec.rig.interaxial = Some("0.4".into());
    spec.rig.convergence = Some("3".into());
    let job = Job::check(spec).unwrap();
    let loaded = job.load().unwrap();
    let plan = job.plan(&loaded).unwrap();
    let shift = plan.rig.views[0].shift - plan.rig.views[1].shift;
    assert!(shift > 8, "the test needs a convergence shift, got {shift}");

    let quarter = job.reduced_plan(&loaded, &plan, 4).unwrap();
    assert_eq!((quarter.width, quarter.height), (21, 16));
    assert_eq!((quarter.camera.width, quarter.camera.height), (21, 16));
    assert!(Arc::ptr_eq(&quarter.world, &plan.world));
    for (q, v) in quarter.rig.views.iter().zip(&plan.rig.views) {
        assert_eq!(q.offset, v.offset);
        assert_eq!(q.shift, (f64::from(v.shift) / 4.0).round() as i32);
    }
    // The same field of view: the camera's axes and eye are the plan's.
    assert_eq!(quarter.camera.forward, plan.camera.forward);
    assert_eq!(quarter.camera.eye, plan.camera.eye);
    let r = job
        .render_sampled(&quarter, None, &no_progress, &CancelToken::new())
        .unwrap();
    assert_eq!(r.output.images.len(), 2);
    assert_eq!(r.output.images[0].width, 21);

    // A divisor of 1 is the plan: its render is the job's, bit for bit.
    let same = job.reduced_plan(&loaded, &plan, 1).unwrap();
    assert_eq!(same.camera, plan.camera);
    assert_eq!(same.rig, plan.rig);
    let a = job
        .render_sampled(&same, None, &no_progress, &CancelToken::new())
        .unwrap();
    let b = job
        .render(&plan, &no_progress, &CancelToken::new())
        .unwrap();
    assert_eq!(a.output.images, b.output.images);
}

#[test]
fn render_sampled_replaces_the_sampling_only() {
    let job = Job::check(pair([40, 30])).unwrap();
    let loaded = job.load().unwrap();
    let plan = job.plan(&loaded).unwrap();
    let adaptive = job
        .render(&plan, &no_progress, &CancelToken::new())
        .unwrap();
    let centres = job
        .render_sampled(
            &plan,
            Some(Sampling::Centers),
            &no_progress,
            &CancelToken::new(),
        )
        .unwrap();
    // One eye ray per pixel centre, against the adaptive corners and more.
    assert_eq!(centres.output.samples_per_view, 40 * 30);
    assert!(adaptive.output.samples_per_view > 41 * 31);
    assert_ne!(adaptive.output.images, centres.output.images);

    // The same as a job asked for one sample per pixel.
    let mut one = pair([40, 30]);
    one.sampling.samples = Some(1);
    let one = Job::check(one).unwrap();
    let plan_one = one.plan(&loaded).unwrap();
    let reference = one
        .render(&plan_one, &no_progress, &CancelToken::new())
        .unwrap();
    assert_eq!(reference.output.images, centres.output.images);
}

#[test]
fn progressive_passes_go_coarse_to_fine_then_anti_aliased() {
    let job = Job::check(pair([40, 30])).unwrap();
    let divisors = |passes: Vec<Pass>| -> Vec<(u32, bool)> {
        passes
            .iter()
            .map(|p| (p.divisor, p.sampling.is_none()))
            .collect()
    };
    assert_eq!(
        divisors(job.progressive_passes(480)),
        vec![(8, false), (4, false), (2, false), (1, false), (1, true)]
    );
    // Passes narrower than 8 pixels are left out.
    assert_eq!(
        divisors(job.progressive_passes(40)),
        vec![(4, false), (2, false), (1, false), (1, true)]
    );
    let mut one = pair([40, 30]);
    one.sampling.samples = Some(1);
    let one = Job::check(one).unwrap();
    assert_eq!(
        divisors(one.progressive_passes(480)),
        vec![(8, false), (4, false), (2, false), (1, false)]
    );
}

#[test]
fn compose_gives_what_write_writes() {
    let dir = tempfile::tempdir().unwrap();
    for (layout, frames, width) in [
        (LayoutSpec::Anaglyph, 1, 40),
        (LayoutSpec::Sbs, 1, 80),
        (LayoutSpec::Cross, 1, 80),
        (LayoutSpec::Separate, 2, 40),
    ] {
        let mut spec = pair([40, 30]);
        spec.rig.interaxial = Some("0.3".into());
        spec.output.layout = layout;
        // A display transform that is not the identity: compose must apply it.
        spec.output.exposure = 0.5;
        spec.output.path = dir.path().join(format!("{}.png", layout.name()));
        let job = Job::check(spec).unwrap();
        let loaded = job.load().unwrap();
        let plan = job.plan(&loaded).unwrap();
        let rendered = job
            .render(&plan, &no_progress, &CancelToken::new())
            .unwrap();
        let composed = job.compose(&plan, &rendered).unwrap();
        assert_eq!(composed.len(), frames, "{layout:?}");
        assert_eq!(composed[0].width, width, "{layout:?}");
        let written = job.write(&loaded, &plan, &rendered).unwrap();
        assert_eq!(written.len(), frames);
        for (image, file) in composed.iter().zip(&written) {
            // The composed image, encoded as the job encodes 8-bit files
            // (sRGB by default), reads back as the written file does.
            let encoded = dir.path().join("encoded.png");
            std::fs::write(
                &encoded,
                output::png_bytes(image, &job.write_options()).unwrap(),
            )
            .unwrap();
            let read = output::read_image(file).unwrap();
            assert_eq!(read, output::read_image(&encoded).unwrap(), "{layout:?}");
        }
    }
}

#[test]
fn png_bytes_hold_the_image() {
    let job = Job::check(pair([40, 30])).unwrap();
    let loaded = job.load().unwrap();
    let plan = job.plan(&loaded).unwrap();
    let rendered = job
        .render(&plan, &no_progress, &CancelToken::new())
        .unwrap();
    let image = &rendered.output.images[0];
    let bytes = output::png_bytes(image, &WriteOptions::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frame.png");
    std::fs::write(&path, &bytes).unwrap();
    let reference = dir.path().join("reference.png");
    output::write_image(&reference, image, &WriteOptions::default()).unwrap();
    assert_eq!(
        output::read_image(&path).unwrap(),
        output::read_image(&reference).unwrap()
    );
}

#[test]
fn the_histogram_counts_every_sample_of_the_report() {
    let mut spec = pair([120, 90]);
    spec.rig.interaxial = Some("0.3".into());
    let job = Job::check(spec).unwrap();
    let loaded = job.load().unwrap();
    let plan = job.plan(&loaded).unwrap();
    let settled = plan.settled.as_ref().unwrap();
    let (h, report) = (&settled.histogram, &settled.report);
    assert_eq!(h.width, 120);
    assert_eq!(
        h.hits() + u64::from(h.misses),
        2 * report.samples_per_view as u64
    );
    let hit_fraction = report.depth.unwrap().hit_fraction;
    assert!((h.hits() as f64 / (2 * report.samples_per_view) as f64 - hit_fraction).abs() < 1e-9);
    // The occupied bins span the report's nearest and farthest disparities.
    let (lo, hi) = h.occupied_px().unwrap();
    let adjacent = report.adjacent_px.unwrap();
    assert!(
        lo <= adjacent.near && adjacent.near <= lo + h.bin_px,
        "{lo} {adjacent:?}"
    );
    assert!(
        hi - h.bin_px <= adjacent.far && adjacent.far <= hi,
        "{hi} {adjacent:?}"
    );
    // The range holds the budget.
    let end = h.start_px + h.bin_px * h.counts.len() as f64;
    assert!(h.start_px <= report.budget_px.near && report.budget_px.far <= end + 1e-9);

    // A wider interaxial spreads the same samples over more disparity.
    let mut wide = pair([120, 90]);
    wide.rig.interaxial = Some("0.6".into());
    let wide = Job::check(wide).unwrap();
    let wide_plan = wide.plan(&loaded).unwrap();
    let (wlo, whi) = wide_plan.settled.unwrap().histogram.occupied_px().unwrap();
    assert!(
        whi - wlo > (hi - lo) * 1.5,
        "{wlo}..{whi} against {lo}..{hi}"
    );
}

#[test]
fn check_in_runs_on_the_callers_pool() {
    let pool = Arc::new(
        rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap(),
    );
    let job = Job::check_in(pair([40, 30]), Arc::clone(&pool)).unwrap();
    assert_eq!(job.pool().current_num_threads(), 1);
    assert!(std::ptr::eq(job.pool(), &*pool));
    // The spec's checks are those of Job::check, with the same messages.
    let mut bad = pair([40, 30]);
    bad.rig.interaxial = Some("-1".into());
    let a = Job::check_in(bad.clone(), pool).err().unwrap().to_string();
    let b = Job::check(bad).err().unwrap().to_string();
    assert_eq!(a, b);
    assert!(a.contains("--interaxial"), "{a}");
}

#[test]
fn image_size_and_viewpoint_follow_the_spec() {
    let mut spec = pair([64, 48]);
    spec.camera.fov = Some(30.0);
    let job = Job::check(spec).unwrap();
    let loaded = job.load().unwrap();
    assert_eq!(job.image_size(&loaded).unwrap(), (64, 48));
    assert_eq!(job.viewpoint(&loaded).unwrap().angle_deg, 30.0);
    let plain = Job::check(JobSpec::new(common::scene_path("example.nff"), "x.png")).unwrap();
    let vp = &loaded.scene.viewpoint;
    assert_eq!(plain.image_size(&loaded).unwrap(), (vp.width, vp.height));
}
