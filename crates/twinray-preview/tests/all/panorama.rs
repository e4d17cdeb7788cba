//! A panorama in the preview (`--projection`): the page's rig controls
//! become the IPD and the angular budget (no convergence, no flat depth
//! budget), the answer carries the comfort in degrees for the histogram,
//! and the frames are the equirectangular (or fisheye) images the page's
//! look-around viewer turns.

use axum::http::StatusCode;
use serde_json::{json, Value};

use twinray::job::{Job, JobSpec};
use twinray::rig::ProjectionName;

use crate::common::*;
use crate::correlation::correlation;

/// The command line's spec of a small panorama of the example scene, seen
/// from among its objects.
fn panorama(projection: ProjectionName, stereo: bool) -> JobSpec {
    let mut spec = JobSpec::new(example(), "");
    spec.camera.projection = projection;
    spec.camera.size = Some(match projection {
        ProjectionName::Equirect | ProjectionName::Ods => [192, 96],
        _ => [96, 96],
    });
    spec.camera.from = Some([0.0, -2.2, 1.0]);
    spec.camera.at = Some([0.0, 0.0, 0.8]);
    spec.rig.stereo = stereo;
    spec
}

/// A change the page makes, answered 200, and its frames.
async fn accepted(
    server: &Server,
    socket: &mut Socket,
    session: &str,
    settings: Value,
) -> (Value, Vec<Frame>) {
    let (status, info) = server.change(session, settings.clone()).await;
    assert_eq!(status, StatusCode::OK, "{settings}: {info}");
    // A render that fails fails the test (`next_frame`).
    let frames = frames_of(socket, info["generation"].as_u64().unwrap()).await;
    (info, frames)
}

fn deg(v: &Value) -> f64 {
    v["deg"].as_f64().unwrap_or_else(|| panic!("no angle: {v}"))
}

#[tokio::test]
async fn an_ods_session_renders_with_the_pages_rig_controls() {
    let server = serve(panorama(ProjectionName::Ods, true)).await;
    let (status, state) = server.json("GET", "/api/state", None).await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(state["projection"], "ods");
    assert_eq!(state["preview_size"], json!([96, 48]));
    let (mut socket, session) = server.connect().await;

    // The page's first settings as it sends them: convergence `auto` is
    // the projection's own (parallel eyes), not a refused flag.
    let first = state["settings"].clone();
    assert_eq!(first["convergence"], "auto");
    let (info, frames) = accepted(&server, &mut socket, &session, first).await;
    assert_eq!(info["projection"], "ods");
    assert_eq!(info["rig"]["convergence"], Value::Null);
    let command = info["command"].as_str().unwrap();
    assert!(!command.contains("--convergence"), "{command}");
    assert!(command.contains("--projection ods --stereo"), "{command}");
    let p = &info["panorama"];
    assert_eq!(p["chosen_by"], "budget", "{p}");
    assert_eq!(p["budget_deg"], 1.0);
    // Fitted: the nearest point sits on the budget.
    assert!((deg(&p["near"]) - 1.0).abs() < 1e-3, "{p}");
    assert!(deg(&p["far"]) < deg(&p["near"]), "{p}");
    assert_eq!(p["within_budget"], true);
    let auto_ipd = p["ipd"].as_f64().unwrap();
    assert!(
        (info["rig"]["interaxial"].as_f64().unwrap() - auto_ipd).abs() < 1e-6 * auto_ipd,
        "{info}"
    );
    // The histogram holds every sample hit, up to the nearest's bin.
    let h = &p["histogram"];
    let counts: Vec<u64> = h["counts"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.as_u64().unwrap())
        .collect();
    assert!(counts.iter().sum::<u64>() > 100, "{h}");
    let bin = h["bin_deg"].as_f64().unwrap();
    let last = counts.iter().rposition(|&c| c > 0).unwrap();
    assert_eq!(last, (deg(&p["near"]) / bin).floor() as usize, "{h}");
    // The flat rig's report is not there: no convergence to report on.
    assert_eq!(info["report"], Value::Null);
    assert_eq!(info["camera"]["fov"], 180.0);
    // The equirectangular anaglyph, coarse to fine, then anti-aliased
    // (the command line's sampling).
    let sizes: Vec<(u32, u32)> = frames
        .iter()
        .map(|f| {
            assert_eq!(f.images.len(), 1);
            let i = pixels(&f.images[0]);
            (i.width(), i.height())
        })
        .collect();
    assert_eq!(sizes, vec![(12, 6), (24, 12), (48, 24), (96, 48), (96, 48)]);
    assert_eq!(frames.last().unwrap().header["sampling"], "final");

    // The IPD slider: a distance, with the convergence the page still
    // sends as `auto`.
    let (info, _) = accepted(
        &server,
        &mut socket,
        &session,
        json!({ "interaxial": "0.3", "convergence": "auto", "samples": 1 }),
    )
    .await;
    let p = &info["panorama"];
    assert_eq!(p["chosen_by"], "given");
    assert_eq!(p["ipd"].as_f64().unwrap() as f32, 0.3);
    // Over the budget: said, and marked.
    assert_eq!(p["within_budget"], false);
    assert!(deg(&p["near"]) > 1.0, "{p}");
    assert!(
        info["messages"]
            .as_array()
            .unwrap()
            .iter()
            .any(|m| m["text"].as_str().unwrap().contains("over the budget")),
        "{info}"
    );
    let command = info["command"].as_str().unwrap();
    assert!(command.contains("--interaxial 0.3"), "{command}");
    assert!(!command.contains("--convergence"), "{command}");

    // The angular budget: twice the degrees, a wider IPD fitted to it.
    let (info, _) = accepted(
        &server,
        &mut socket,
        &session,
        json!({ "angular_budget": 2.0, "samples": 1 }),
    )
    .await;
    let p = &info["panorama"];
    assert_eq!(p["budget_deg"], 2.0);
    assert!((deg(&p["near"]) - 2.0).abs() < 2e-3, "{p}");
    assert!(p["ipd"].as_f64().unwrap() > 1.9 * auto_ipd, "{p}");
    assert!(info["command"]
        .as_str()
        .unwrap()
        .contains("--angular-budget 2"));
}

#[tokio::test]
async fn a_panorama_in_metres_gives_its_ipd_in_millimetres() {
    let mut spec = panorama(ProjectionName::Vr180, true);
    spec.rig.units = Some(twinray::rig::panorama_rig::SceneUnits::M);
    let server = serve(spec).await;
    let (mut socket, session) = server.connect().await;
    let (info, _) = accepted(&server, &mut socket, &session, json!({ "samples": 1 })).await;
    let p = &info["panorama"];
    assert_eq!(p["units"], "m");
    // Seen from among the example's objects, the budget keeps the IPD
    // under the eyes' 64 mm.
    assert_eq!(p["chosen_by"], "budget", "{p}");
    let mm = p["ipd_mm"].as_f64().unwrap();
    assert!(
        (mm - 1000.0 * p["ipd"].as_f64().unwrap()).abs() < 1e-9,
        "{p}"
    );
    assert!(mm < 64.0, "{p}");
    assert!(info["command"].as_str().unwrap().contains("--units m"));
}

/// The message `Job::check` (and so `twinray render`) gives for `spec`.
fn library_message(mut spec: JobSpec, edit: impl Fn(&mut JobSpec)) -> String {
    spec.output.path = "x.png".into();
    spec.output.layout = twinray::job::LayoutSpec::Anaglyph;
    edit(&mut spec);
    Job::check(spec).err().expect("refused").to_string()
}

#[tokio::test]
async fn the_flat_rigs_controls_are_refused_for_a_panorama_and_the_angular_budget_for_a_flat_rig() {
    let ods = panorama(ProjectionName::Ods, true);
    let server = serve(ods.clone()).await;
    let (_socket, session) = server.connect().await;
    let cases = [
        (
            json!({ "interaxial": "0.1", "convergence": "2" }),
            library_message(ods.clone(), |s| {
                s.rig.interaxial = Some("0.1".into());
                s.rig.convergence = Some("2".into())
            }),
        ),
        (
            json!({ "depth_budget": "-1%,+3%" }),
            library_message(ods.clone(), |s| s.rig.depth_budget = Some("-1%,+3%".into())),
        ),
        (
            json!({ "fast": true }),
            library_message(ods.clone(), |s| {
                s.method.name = twinray::job::MethodName::Fast
            }),
        ),
        (
            json!({ "angular_budget": 20.0 }),
            library_message(ods.clone(), |s| s.rig.angular_budget = Some(20.0)),
        ),
        (
            json!({ "views": 4, "view": "wiggle" }),
            library_message(ods.clone(), |s| {
                s.rig.stereo = false;
                s.rig.views = Some(4);
                s.output.layout = twinray::job::LayoutSpec::Separate;
            }),
        ),
    ];
    for (settings, message) in cases {
        let (status, answer) = server.change(&session, settings.clone()).await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "{settings}");
        assert_eq!(answer["error"], message, "{settings}");
    }

    // A flat rig has no angular budget, and no one-eye preview.
    let flat = serve(base(&example())).await;
    let (_socket, session) = flat.connect().await;
    let (status, answer) = flat
        .change(&session, json!({ "angular_budget": 1.5 }))
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST);
    let mut spec = base(&example());
    spec.rig.stereo = true;
    assert_eq!(
        answer["error"],
        library_message(spec, |s| s.rig.angular_budget = Some(1.5))
    );
    let (status, answer) = flat
        .change(&session, json!({ "views": 1, "view": "single" }))
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST);
    assert_eq!(
        answer["error"],
        "views 1: a stereo preview needs at least 2 views (one eye: a panorama's only)"
    );
}

#[tokio::test]
async fn a_mono_equirect_panorama_shows_its_one_eye() {
    let server = serve(panorama(ProjectionName::Equirect, false)).await;
    let (status, state) = server.json("GET", "/api/state", None).await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(state["projection"], "equirect");
    assert_eq!(state["settings"]["views"], 1);
    assert_eq!(state["settings"]["view"], "single");
    let (mut socket, session) = server.connect().await;
    let mut first = state["settings"].clone();
    first["samples"] = json!(1);
    let (info, frames) = accepted(&server, &mut socket, &session, first).await;
    assert_eq!(info["views"], 1);
    assert_eq!(info["panorama"], Value::Null);
    let last = frames.last().unwrap();
    assert_eq!(last.images.len(), 1);
    let image = pixels(&last.images[0]);
    assert_eq!((image.width(), image.height()), (96, 48));
    let command = info["command"].as_str().unwrap();
    assert!(command.contains("--projection equirect"), "{command}");
    assert!(!command.contains("--stereo"), "{command}");
}

#[tokio::test]
async fn a_vr180_pair_sends_its_eyes_for_one_eye_and_the_anaglyph_of_both() {
    let server = serve(panorama(ProjectionName::Vr180Fisheye, true)).await;
    let (mut socket, session) = server.connect().await;
    let wide = json!({ "interaxial": "0.4", "samples": 1 });
    let mut single = wide.clone();
    single["view"] = json!("single");
    let (info, frames) = accepted(&server, &mut socket, &session, single).await;
    assert_eq!(info["projection"], "vr180-fisheye");
    let eyes = &frames.last().unwrap().images;
    assert_eq!(eyes.len(), 2);
    let (left, right) = (pixels(&eyes[0]), pixels(&eyes[1]));
    assert_eq!((left.width(), left.height()), (96, 96));
    assert_ne!(left, right, "the eyes are alike");
    // Outside the fisheye's circle: black.
    assert_eq!(left.get_pixel(0, 0).0, [0, 0, 0]);

    let mut anaglyph = wide.clone();
    anaglyph["view"] = json!("anaglyph");
    let (_, frames) = accepted(&server, &mut socket, &session, anaglyph).await;
    let images = &frames.last().unwrap().images;
    assert_eq!(images.len(), 1);
    let a = pixels(&images[0]);
    // Red-cyan: the red channel follows the left eye, green the right.
    let rgb = |i: &image::RgbImage| i.as_raw().iter().map(|&v| f64::from(v)).collect::<Vec<_>>();
    let (a, left, right) = (rgb(&a), rgb(&left), rgb(&right));
    let (red_left, red_right) = (correlation(&a, 0, &left), correlation(&a, 0, &right));
    let (green_left, green_right) = (correlation(&a, 1, &left), correlation(&a, 1, &right));
    assert!(
        red_left > red_right && green_right > green_left,
        "red ~ left {red_left:.3}, right {red_right:.3}; green ~ left {green_left:.3}, right {green_right:.3}"
    );
}

#[tokio::test]
async fn the_page_has_the_look_around_viewer_and_loads_nothing_from_elsewhere() {
    let server = serve(panorama(ProjectionName::Ods, true)).await;
    let mut page = String::new();
    for file in ["/", "/app.js", "/app.css"] {
        let (status, body) = server.request("GET", file, None).await;
        assert_eq!(status, StatusCode::OK, "{file}");
        page.push_str(&String::from_utf8(body).unwrap());
    }
    for id in ["look", "look-fov", "angular-budget", "histogram"] {
        assert!(page.contains(&format!("id=\"{id}\"")), "{id}");
    }
    // Every URL the page names is its own server's.
    for pattern in ["http://", "https://", "src=\"//", "url(", "@import"] {
        assert!(!page.contains(pattern), "the page names {pattern}");
    }
}
