//! `twinray::job` as a front end other than the command line uses it: one
//! loaded scene planned and rendered with several rigs (what the preview
//! server does on every change), cancellation, and the spec as JSON.

use crate::common;

use std::sync::Arc;

use twinray::job::{CancelToken, Job, JobSpec, Level, MethodSpec};
use twinray::render::Sampling;

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

/// `--key-spacing` belongs to the shared shading: alone it says so; with
/// `--share-shading` or `--fast` it is taken without a word.
#[test]
fn key_spacing_without_shared_shading_is_said_to_do_nothing() {
    let warned = |share: bool, fast: bool| {
        let mut spec = pair("0.1");
        spec.approximations.key_spacing = 0;
        spec.approximations.share_shading = share;
        spec.approximations.fast = fast;
        Job::check(spec)
            .unwrap()
            .messages()
            .iter()
            .any(|m| m.level == Level::Warning && m.text.contains("--key-spacing"))
    };
    assert!(warned(false, false));
    assert!(!warned(true, false));
    assert!(!warned(false, true));
    // At its default, nothing to say.
    assert!(!Job::check(pair("0.1"))
        .unwrap()
        .messages()
        .iter()
        .any(|m| m.text.contains("--key-spacing")));
}

/// `--fast` takes the approximations that measured faster than the exact
/// batches (the epipolar rows, and for the rows they do not take the shared
/// shading, merged secondary rays, the reprojection), not the interpolated
/// views, which measured slower (benchmarks.md, "Issue 16, eighth pass");
/// `--interpolate-views` still asks for them.
#[test]
fn fast_at_many_views_shares_shading_but_does_not_interpolate_views() {
    let options = |fast: bool, interpolate: bool| {
        let mut spec = pair("0.1");
        spec.rig.stereo = false;
        spec.rig.views = Some(8);
        spec.approximations.fast = fast;
        spec.approximations.interpolate_views = interpolate;
        Job::check(spec).unwrap().render_options().approx
    };
    let fast = options(true, false);
    assert!(fast.epipolar_views.is_some());
    assert!(options(false, false).epipolar_views.is_none());
    // With the adaptive sampling (the default) most rows are refined ones,
    // traced view by view: `--fast` leaves the epipolar rows out.
    let mut adaptive = pair("0.1");
    adaptive.sampling.samples = None;
    adaptive.approximations.fast = true;
    let adaptive = *Job::check(adaptive).unwrap().render_options();
    assert!(matches!(adaptive.sampling, Sampling::Adaptive { .. }));
    assert!(adaptive.approx.epipolar_views.is_none());
    assert!(adaptive.approx.shared_shading.is_some());
    assert!(fast.shared_shading.is_some());
    assert!(fast.merge_secondary);
    assert!(fast.reproject.is_some());
    assert!(fast.interpolate_views.is_none());
    assert!(options(false, true).interpolate_views.is_some());
    assert!(options(true, true).interpolate_views.is_some());
}

/// `--fast` cuts the object tree only where the epipolar rows cannot take
/// the views (they need the whole tree); a cut asked for is made.
#[test]
fn fast_does_not_cut_the_tree_the_epipolar_rows_need() {
    let cut = |fast: bool, parallax: Option<f64>| {
        let mut spec = pair("0.1");
        spec.approximations.fast = fast;
        spec.approximations.cut_parallax = parallax;
        let job = Job::check(spec).unwrap();
        let loaded = job.load().unwrap();
        job.plan(&loaded).unwrap().cut
    };
    // The rig has a depth beyond which the parallax is below `--fast`'s half
    // pixel: asked for, the cut is made there.
    assert!(cut(false, Some(0.5)).is_some());
    assert!(cut(true, Some(0.5)).is_some());
    assert!(cut(true, None).is_none());
}

/// Where the epipolar rows cannot take the views (a material whose alpha
/// matters), `--fast` cuts the object tree as it always did; the same quad
/// opaque is not cut.
#[test]
fn fast_cuts_the_tree_where_the_epipolar_rows_do_not_apply() {
    let dir = tempfile::tempdir().unwrap();
    let cut = |alpha: &str| {
        let material = serde_json::json!({
            "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 0.5]},
            "alphaMode": alpha
        });
        let sub = dir.path().join(alpha);
        std::fs::create_dir_all(&sub).unwrap();
        let mut spec = JobSpec::new(common::gltf_quad(&sub, material, &[]), "unused.png");
        spec.camera.size = Some([40, 30]);
        spec.rig.stereo = true;
        spec.rig.interaxial = Some("0.1".into());
        spec.sampling.samples = Some(1);
        spec.approximations.fast = true;
        let job = Job::check(spec).unwrap();
        let loaded = job.load().unwrap();
        assert_eq!(loaded.scene.has_alpha(), alpha != "OPAQUE", "{alpha}");
        job.plan(&loaded).unwrap().cut
    };
    assert!(cut("BLEND").is_some());
    assert!(cut("OPAQUE").is_none());
}

/// `--eye-runs` and `--shadow-fans` share work between the twin method's
/// views: with `--method independent` each says it does nothing.
#[test]
fn view_sharing_flags_with_independent_renders_are_said_to_do_nothing() {
    for flag in ["--eye-runs", "--shadow-fans"] {
        let warned = |method: MethodSpec| {
            let mut spec = pair("0.1");
            spec.rig.method = method;
            spec.rig.eye_runs = flag == "--eye-runs";
            spec.rig.shadow_fans = flag == "--shadow-fans";
            Job::check(spec)
                .unwrap()
                .messages()
                .iter()
                .any(|m| m.level == Level::Warning && m.text.contains(flag))
        };
        assert!(warned(MethodSpec::Independent), "{flag}");
        assert!(!warned(MethodSpec::Twin), "{flag}");
    }
}
