//! `twinray::job` as a front end other than the command line uses it: one
//! loaded scene planned and rendered with several rigs (what the preview
//! server does on every change), cancellation, and the spec as JSON.

use crate::common;

use std::sync::Arc;

use twinray::job::{CancelToken, CutSpec, Job, JobSpec, Level, MethodName};
use twinray::render::{ReprojectMode, ViewMethod};

fn pair(interaxial: &str) -> JobSpec {
    let mut spec = JobSpec::new(common::scene_path("example.nff"), "unused.png");
    spec.camera.size = Some([40, 30]);
    spec.rig.stereo = true;
    spec.rig.interaxial = Some(interaxial.into());
    spec.sampling.samples = Some(1);
    spec
}

#[test]
fn one_loaded_scene_serves_several_rigs() {
    let first = Job::check(pair("0.1")).unwrap();
    let loaded = first.load().unwrap();
    let plan_a = first.plan(&loaded).unwrap();
    let a = first
        .render(&plan_a, &|_, _| {}, &CancelToken::new())
        .unwrap();

    let second = Job::check(pair("0.4")).unwrap();
    let plan_b = second.plan(&loaded).unwrap();
    let b = second
        .render(&plan_b, &|_, _| {}, &CancelToken::new())
        .unwrap();
    // The hierarchy was built once and shared by both plans.
    assert!(Arc::ptr_eq(&plan_a.world, &plan_b.world));
    assert_eq!(plan_b.interaxial, 0.4);
    assert_ne!(a.output.images[1].pixels, b.output.images[1].pixels);

    // The second rig rendered on the shared scene equals a fresh job's render.
    let fresh = Job::check(pair("0.4")).unwrap();
    let fresh_loaded = fresh.load().unwrap();
    let fresh_plan = fresh.plan(&fresh_loaded).unwrap();
    let c = fresh
        .render(&fresh_plan, &|_, _| {}, &CancelToken::new())
        .unwrap();
    for (x, y) in b.output.images.iter().zip(&c.output.images) {
        assert_eq!(x.pixels, y.pixels);
    }
}

#[test]
fn a_cancelled_render_stops_with_cancelled() {
    let job = Job::check(pair("0.1")).unwrap();
    let loaded = job.load().unwrap();
    let plan = job.plan(&loaded).unwrap();
    let cancel = CancelToken::new();
    let rows = std::sync::atomic::AtomicU64::new(0);
    let progress = |_done: u64, _total: u64| {
        // Cancel after the first row: the rest must not be traced.
        if rows.fetch_add(1, std::sync::atomic::Ordering::Relaxed) == 0 {
            cancel.cancel();
        }
    };
    let err = job.render(&plan, &progress, &cancel).err();
    assert!(matches!(err, Some(twinray::Error::Cancelled)), "{err:?}");
    let traced = rows.load(std::sync::atomic::Ordering::Relaxed);
    assert!(traced < 30, "{traced} rows traced after the cancel");
}

/// At a huge sample count a band of rows holds millions of samples: the
/// render stops within a row of samples of the token raised, counted by the
/// progress (a step per row of samples), not after the band.
#[test]
fn a_render_of_many_samples_stops_within_a_row_of_samples() {
    use std::sync::atomic::{AtomicU64, Ordering};
    let mut spec = pair("0.1");
    spec.camera.size = Some([16, 16]);
    spec.sampling.samples = Some(4096);
    spec.trace.threads = Some(2);
    let job = Job::check(spec).unwrap();
    let loaded = job.load().unwrap();
    let plan = job.plan(&loaded).unwrap();
    let cancel = CancelToken::new();
    let (last, total) = (AtomicU64::new(0), AtomicU64::new(0));
    const AT: u64 = 10;
    let progress = |done: u64, all: u64| {
        last.fetch_max(done, Ordering::Relaxed);
        total.store(all, Ordering::Relaxed);
        if done >= AT {
            cancel.cancel();
        }
    };
    let err = job.render(&plan, &progress, &cancel).err();
    assert!(matches!(err, Some(twinray::Error::Cancelled)), "{err:?}");
    // A step per row of 16 samples of each view: 16 rows of 4096.
    assert_eq!(total.load(Ordering::Relaxed), 16 * 4096);
    // Each of the two threads finishes at most the row it was tracing.
    let last = last.load(Ordering::Relaxed);
    assert!(
        last <= AT + 2,
        "{last} rows of samples traced, cancelled at {AT}"
    );
}

#[test]
fn the_stages_report_as_data() {
    let mut spec = pair("0.1");
    spec.output.exposure = 1.0;
    spec.output.path = "pair.exr".into();
    let job = Job::check(spec).unwrap();
    assert!(job
        .messages()
        .iter()
        .any(|m| m.level == Level::Warning && m.text.contains("float files keep")));
    let loaded = job.load().unwrap();
    let plan = job.plan(&loaded).unwrap();
    assert!(plan
        .messages
        .iter()
        .any(|m| m.level == Level::Info && m.text.starts_with("rig: 2 views, interaxial 0.1")));
}

#[test]
fn specs_read_back_and_refuse_unknown_fields() {
    let spec = pair("auto");
    let back = JobSpec::from_json(&spec.to_json()).unwrap();
    assert_eq!(back, spec);
    // Everything omitted takes the command line's defaults.
    let minimal = JobSpec::from_json(r#"{"scene": "a.nff", "output": {"path": "a.png"}}"#).unwrap();
    assert_eq!(minimal, JobSpec::new("a.nff", "a.png"));
    let err = JobSpec::from_json(r#"{"scene": "a.nff", "sampling": {"sample": 4}}"#)
        .unwrap_err()
        .to_string();
    assert!(err.contains("unknown field `sample`"), "{err}");
    // Values with a grammar of their own are checked by the check stage.
    let mut bad = pair("0.1");
    bad.rig.depth_budget = Some("+1%,+2%".into());
    let err = Job::check(bad).err().map(|e| e.to_string());
    assert!(
        err.as_deref()
            .is_some_and(|e| e.contains("NEAR must be 0 or negative")),
        "{err:?}"
    );
}

/// The fast method is one choice, its tolerance its one setting; an option
/// of another method with it (or without the method it belongs to) is
/// refused with a message naming both, not ignored.
#[test]
fn the_fast_method_is_one_choice_and_options_of_others_are_refused() {
    let check = |edit: &dyn Fn(&mut JobSpec)| {
        let mut spec = pair("0.1");
        spec.rig.stereo = false;
        spec.rig.views = Some(8);
        edit(&mut spec);
        Job::check(spec).map(|j| j.render_options().method)
    };
    let fast = check(&|s| s.method.name = MethodName::Fast).unwrap();
    assert_eq!(fast, ViewMethod::fast());
    let tight = check(&|s| {
        s.method.name = MethodName::Fast;
        s.method.tolerance = Some(0.002);
    });
    assert_eq!(tight.unwrap(), ViewMethod::Fast { tolerance: 0.002 });
    assert_eq!(check(&|_| {}).unwrap(), ViewMethod::twin());
    for (what, edit, fragment) in [
        (
            "fast and merged rays",
            &(|s: &mut JobSpec| {
                s.method.name = MethodName::Fast;
                s.method.merge_secondary = true;
            }) as &dyn Fn(&mut JobSpec),
            "--merge-secondary",
        ),
        (
            "fast and a cut",
            &|s: &mut JobSpec| {
                s.method.name = MethodName::Fast;
                s.method.cut = Some(CutSpec::Parallax(0.5));
            },
            "--cut-*",
        ),
        (
            "a tolerance without fast",
            &|s: &mut JobSpec| s.method.tolerance = Some(0.02),
            "--tolerance",
        ),
        (
            "a threshold without the reprojection",
            &|s: &mut JobSpec| s.method.reproject_threshold = Some(0.2),
            "--reproject-threshold",
        ),
        (
            "the reference and the reprojection",
            &|s: &mut JobSpec| {
                s.method.name = MethodName::Independent;
                s.method.reproject = Some(ReprojectMode::Safe);
            },
            "--method independent",
        ),
        (
            "a negative tolerance",
            &|s: &mut JobSpec| {
                s.method.name = MethodName::Fast;
                s.method.tolerance = Some(-0.1);
            },
            "--tolerance",
        ),
    ] {
        let err = check(edit).err().map(|e| e.to_string());
        assert!(
            err.as_deref().is_some_and(|e| e.contains(fragment)),
            "{what}: {err:?}"
        );
    }
}

/// The twin method cuts the object tree where asked; the fast method never
/// does (its images are checked against the whole tree's), under any
/// sampling.
#[test]
fn only_the_twin_method_cuts_the_tree() {
    let cut = |edit: &dyn Fn(&mut JobSpec)| {
        let mut spec = pair("0.1");
        edit(&mut spec);
        let job = Job::check(spec).unwrap();
        let loaded = job.load().unwrap();
        job.plan(&loaded).unwrap().cut
    };
    assert!(cut(&|s| s.method.cut = Some(CutSpec::Parallax(0.5))).is_some());
    assert!(cut(&|_| {}).is_none());
    assert!(cut(&|s| s.method.name = MethodName::Fast).is_none());
    assert!(cut(&|s| {
        s.method.name = MethodName::Fast;
        s.sampling.samples = None;
    })
    .is_none());
}
