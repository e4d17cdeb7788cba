//! The preview's HTTP and WebSocket API, driven in-process: a server on a
//! loopback port for the WebSocket, requests straight to its router.

use std::time::{Duration, Instant};

use axum::http::StatusCode;
use serde_json::{json, Value};

use twinray::job::{CancelToken, Job, JobSpec};

use crate::common::*;

#[tokio::test]
async fn a_change_of_interaxial_changes_the_frame() {
    let server = serve(base(&example())).await;
    let (mut socket, session) = server.connect().await;

    let (status, first) = server.change(&session, settings("0.1")).await;
    assert_eq!(status, StatusCode::OK, "{first}");
    let generation = first["generation"].as_u64().unwrap();
    let frames = frames_of(&mut socket, generation).await;
    // Coarse to fine: 1/8, 1/4, 1/2 and full size, one ray per pixel (no
    // anti-aliased pass: one sample was asked for).
    let divisors: Vec<u64> = frames
        .iter()
        .map(|f| f.header["divisor"].as_u64().unwrap())
        .collect();
    assert_eq!(divisors, vec![8, 4, 2, 1]);
    let widths: Vec<u32> = frames
        .iter()
        .map(|f| pixels(&f.images[0]).width())
        .collect();
    assert_eq!(widths, vec![12, 24, 48, 96]);
    let before = pixels(&frames[3].images[0]);
    assert_eq!((before.width(), before.height()), (96, 54));

    let (status, second) = server.change(&session, settings("0.4")).await;
    assert_eq!(status, StatusCode::OK, "{second}");
    assert!(second["generation"].as_u64().unwrap() > generation);
    assert_eq!(second["rig"]["interaxial"], 0.4);
    let frames = frames_of(&mut socket, second["generation"].as_u64().unwrap()).await;
    let after = pixels(&frames.last().unwrap().images[0]);
    let differing = before
        .pixels()
        .zip(after.pixels())
        .filter(|(a, b)| a != b)
        .count();
    assert!(differing > 200, "only {differing} pixels changed");

    // The answer carries the comfort display and the command of the view.
    assert_eq!(
        second["command"],
        format!(
            "twinray render {} -o example.png --size 192x108 --stereo --interaxial 0.4 --convergence auto --samples 1 --layout anaglyph",
            example().display()
        )
    );
    let histogram = &second["histogram"];
    assert_eq!(histogram["counts"].as_array().unwrap().len(), 64);
    assert!(second["report"]["adjacent_px"]["far"].as_f64().unwrap() > 0.0);
    assert_eq!(second["frame"]["tiles"].as_array().unwrap().len(), 2);
}

#[tokio::test]
async fn the_layouts_send_their_frames() {
    let server = serve(base(&example())).await;
    let (mut socket, session) = server.connect().await;
    for (view, images, width) in [
        ("sbs", 1, 192),
        ("cross", 1, 192),
        ("wiggle", 2, 96),
        ("single", 2, 96),
    ] {
        let (status, info) = server
            .change(
                &session,
                json!({ "view": view, "samples": 1, "interaxial": "0.2" }),
            )
            .await;
        assert_eq!(status, StatusCode::OK, "{view}: {info}");
        assert_eq!(info["frame"]["width"], width, "{view}");
        let frames = frames_of(&mut socket, info["generation"].as_u64().unwrap()).await;
        let last = frames.last().unwrap();
        assert_eq!(last.images.len(), images, "{view}");
        assert_eq!(pixels(&last.images[0]).width(), width, "{view}");
    }
    let (status, info) = server
        .change(
            &session,
            json!({ "view": "quilt", "views": 4, "quilt": "2x2", "samples": 1 }),
        )
        .await;
    assert_eq!(status, StatusCode::OK, "{info}");
    let frames = frames_of(&mut socket, info["generation"].as_u64().unwrap()).await;
    let quilt = pixels(&frames.last().unwrap().images[0]);
    assert_eq!((quilt.width(), quilt.height()), (192, 108));
    // View 0 is the bottom-left tile.
    assert_eq!(info["frame"]["tiles"][0], json!([0, 54, 96, 54]));
}

/// A slow last pass: 256 samples per pixel.
fn slow() -> Value {
    json!({ "interaxial": "0.2", "samples": 256 })
}

#[tokio::test]
async fn a_change_cancels_the_render_in_flight() {
    let server = serve(base(&example())).await;
    let (mut socket, session) = server.connect().await;
    let (_, slow_info) = server.change(&session, slow()).await;
    let slow_generation = slow_info["generation"].as_u64().unwrap();
    // Its coarse passes arrive; the anti-aliased one is being rendered.
    let frame = next_frame(&mut socket).await;
    assert_eq!(frame.generation(), slow_generation);

    let (status, quick) = server.change(&session, settings("0.3")).await;
    assert_eq!(status, StatusCode::OK);
    let frames = frames_of(&mut socket, quick["generation"].as_u64().unwrap()).await;
    assert_eq!(frames[0].header["divisor"], 8);
    // The slow render was stopped, not finished first.
    let (finished, cancelled) = server.preview.render_counts();
    assert_eq!(cancelled, 1, "finished {finished}, cancelled {cancelled}");
}

#[tokio::test]
async fn a_client_that_disconnects_stops_its_render() {
    let server = serve(base(&example())).await;
    // Quick reconnects, each gone in the middle of a slow render: nothing
    // is left behind (sessions, renders, threads).
    for _ in 0..3 {
        let (mut socket, session) = server.connect().await;
        let (status, _) = server.change(&session, slow()).await;
        assert_eq!(status, StatusCode::OK);
        next_frame(&mut socket).await;
        assert!(server.preview.rendering());
        drop(socket);
        let start = Instant::now();
        while server.preview.sessions() > 0 || server.preview.rendering() {
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "the render went on"
            );
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }
    let (finished, cancelled) = server.preview.render_counts();
    assert_eq!((finished, cancelled), (0, 3));
    // The sessions' render threads have ended.
    let start = Instant::now();
    while server.preview.render_threads() > 0 {
        assert!(start.elapsed() < Duration::from_secs(10), "threads left");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// The message `Job::check` (and so `twinray render`) gives for `spec`.
fn library_message(edit: impl Fn(&mut JobSpec)) -> String {
    let mut spec = base(&example());
    spec.rig.stereo = true;
    spec.output.path = "x.png".into();
    edit(&mut spec);
    Job::check(spec).err().expect("refused").to_string()
}

#[tokio::test]
async fn bad_values_are_refused_with_the_command_lines_messages() {
    let server = serve(base(&example())).await;
    let (_socket, session) = server.connect().await;
    let cases: Vec<(Value, String)> = vec![
        (
            json!({ "interaxial": "-1" }),
            library_message(|s| s.rig.interaxial = Some("-1".into())),
        ),
        (
            json!({ "depth_budget": "+3%,-1%" }),
            library_message(|s| s.rig.depth_budget = Some("+3%,-1%".into())),
        ),
        (
            json!({ "convergence": "nowhere" }),
            library_message(|s| s.rig.convergence = Some("nowhere".into())),
        ),
        (
            json!({ "views": 300, "view": "wiggle" }),
            library_message(|s| {
                s.rig.stereo = false;
                s.rig.views = Some(300)
            }),
        ),
        (
            json!({ "samples": 0 }),
            library_message(|s| s.sampling.samples = Some(0)),
        ),
        (
            json!({ "views": 3 }),
            "--layout anaglyph takes exactly two views".to_string(),
        ),
    ];
    for (settings, message) in cases {
        let (status, answer) = server.change(&session, settings.clone()).await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "{settings}");
        assert_eq!(answer["error"], message, "{settings}");
    }
    // What only the page can get wrong, and malformed requests.
    let (status, answer) = server
        .change(&session, json!({ "view": "single", "eye": 2 }))
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST);
    assert_eq!(answer["error"], "eye 2: the views are numbered 0 to 1");
    for body in ["{", "[1,2]", r#"{"interaxial": 3}"#, r#"{"colour": "red"}"#] {
        let (status, answer) = server
            .request(
                "POST",
                &format!("/api/session/{session}/view"),
                Some(body.into()),
            )
            .await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "{body}");
        let answer: Value = serde_json::from_slice(&answer).unwrap();
        assert!(
            answer["error"]
                .as_str()
                .unwrap()
                .starts_with("bad settings"),
            "{answer}"
        );
    }
    let guessed = format!("{}0", &session[..session.len() - 1]);
    let guessed = if guessed == session {
        format!("{}1", &session[..session.len() - 1])
    } else {
        guessed
    };
    let (status, _) = server.change(&guessed, json!({})).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    let (status, _) = server.request("GET", "/api/nothing", None).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    let (status, _) = server
        .request(
            "GET",
            "/api/download/00000000000000000000000000000000/..%2F..%2Fetc%2Fpasswd",
            None,
        )
        .await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    // And the server still works.
    let (status, answer) = server.change(&session, settings("0.2")).await;
    assert_eq!(status, StatusCode::OK, "{answer}");
}

#[tokio::test]
async fn a_scene_that_fails_to_load_shows_its_error() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("broken.nff");
    std::fs::write(
        &scene,
        "v\nfrom 0 0 1\nat 0 0 0\nup 0 1 0\nangle 40\nhither 0\nresolution 10 10\ns 0 0 0 zero\n",
    )
    .unwrap();
    let server = serve(base(&scene)).await;
    let error = server.preview.load_error().expect("a load error");
    assert!(error.contains("broken.nff:8"), "{error}");
    assert!(!error.contains('\n'), "one line: {error}");
    let (status, state) = server.json("GET", "/api/state", None).await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(state["error"], error);
    let (_socket, session) = server.connect().await;
    let (status, answer) = server.change(&session, json!({})).await;
    assert_eq!(status, StatusCode::CONFLICT);
    assert_eq!(answer["error"], error);

    // Fixed and reloaded from the page.
    std::fs::write(&scene, "v\nfrom 0 0 1\nat 0 0 0\nup 0 1 0\nangle 40\nhither 0\nresolution 10 10\nf 1 1 1 1 0 0 0 1\ns 0 0 -2 0.5\n").unwrap();
    let (status, state) = server.json("POST", "/api/reload", None).await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(state["error"], Value::Null, "{state}");
    let (status, answer) = server.change(&session, json!({ "samples": 1 })).await;
    assert_eq!(status, StatusCode::OK, "{answer}");
}

#[tokio::test]
async fn render_full_size_offers_the_files() {
    let server = serve(base(&example())).await;
    let (_socket, session) = server.connect().await;
    let (status, answer) = server
        .json(
            "POST",
            &format!("/api/session/{session}/render"),
            Some(json!({ "view": "sbs", "samples": 1, "interaxial": "0.2" })),
        )
        .await;
    assert_eq!(status, StatusCode::OK, "{answer}");
    let files = answer["files"].as_array().unwrap();
    assert_eq!(files.len(), 1);
    assert_eq!(files[0]["name"], "example.png");
    let (status, png) = server
        .request("GET", files[0]["url"].as_str().unwrap(), None)
        .await;
    assert_eq!(status, StatusCode::OK);
    let image = pixels(&png);
    assert_eq!((image.width(), image.height()), (384, 108));
    assert_eq!(png.len() as u64, files[0]["bytes"].as_u64().unwrap());
    // The same bytes as the command it shows.
    let mut spec = base(&example());
    spec.rig.stereo = true;
    spec.rig.interaxial = Some("0.2".into());
    spec.rig.convergence = Some("auto".into());
    spec.sampling.samples = Some(1);
    spec.output.layout = twinray::job::LayoutSpec::Sbs;
    let dir = tempfile::tempdir().unwrap();
    spec.output.path = dir.path().join("example.png");
    assert_eq!(
        answer["command"],
        format!(
            "twinray render {} -o example.png --size 192x108 --stereo --interaxial 0.2 --convergence auto --samples 1 --layout sbs",
            example().display()
        )
    );
    let (written, _) = Job::run(spec, &|_, _| {}, &CancelToken::new()).unwrap();
    assert_eq!(std::fs::read(&written[0]).unwrap(), png);
}

#[tokio::test]
async fn the_page_is_served() {
    let server = serve(base(&example())).await;
    let (status, html) = server.request("GET", "/", None).await;
    assert_eq!(status, StatusCode::OK);
    let html = String::from_utf8(html).unwrap();
    assert!(html.contains("<script src=\"/app.js\">"));
    for id in [
        "frame",
        "interaxial",
        "convergence",
        "histogram",
        "command",
        "render-full",
    ] {
        assert!(html.contains(&format!("id=\"{id}\"")), "{id}");
    }
    let (status, js) = server.request("GET", "/app.js", None).await;
    assert_eq!(status, StatusCode::OK);
    assert!(String::from_utf8(js).unwrap().contains("/api/session"));
    let (status, state) = server.json("GET", "/api/state", None).await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(state["preview_size"], json!([96, 54]));
    assert_eq!(state["full_size"], json!([192, 108]));
    assert_eq!(state["settings"]["view"], "anaglyph");
}

#[tokio::test]
async fn fast_and_the_camera_reach_the_job() {
    let server = serve(base(&example())).await;
    let (mut socket, session) = server.connect().await;
    let camera = json!({ "from": [1.0, -6.0, 2.5], "at": [0.0, 0.0, 0.8], "up": [0.0, 0.0, 1.0], "fov": 35.0 });
    let (status, info) = server
        .change(
            &session,
            json!({ "fast": true, "samples": 1, "interaxial": "0.2", "camera": camera }),
        )
        .await;
    assert_eq!(status, StatusCode::OK, "{info}");
    let command = info["command"].as_str().unwrap();
    for flag in [
        "--fast",
        "--from '1,-6,2.5'",
        "--at '0,0,0.8'",
        "--up '0,0,1'",
        "--fov 35",
    ] {
        assert!(command.contains(flag), "{flag} not in {command}");
    }
    assert_eq!(info["camera"]["from"], json!([1.0, -6.0, 2.5]));
    assert!((info["camera"]["fov"].as_f64().unwrap() - 35.0).abs() < 1e-3);
    let frames = frames_of(&mut socket, info["generation"].as_u64().unwrap()).await;
    assert_eq!(frames.len(), 4);
}

#[tokio::test]
async fn a_change_refused_by_the_plan_leaves_the_last_view_rendering() {
    let server = serve(base(&example())).await;
    let (mut socket, session) = server.connect().await;
    let (status, good) = server
        .change(&session, json!({ "interaxial": "0.2", "samples": 64 }))
        .await;
    assert_eq!(status, StatusCode::OK);
    let generation = good["generation"].as_u64().unwrap();
    next_frame(&mut socket).await;
    // Views converged so near that their image shifts exceed the width: the
    // plan refuses it, with the library's message, after the render in
    // flight was stopped.
    let (status, answer) = server
        .change(
            &session,
            json!({ "interaxial": "0.4", "convergence": "0.001" }),
        )
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST);
    assert!(
        answer["error"]
            .as_str()
            .unwrap()
            .contains("more than the image is wide"),
        "{answer}"
    );
    // The last view goes on to its anti-aliased pass.
    let frames = frames_of(&mut socket, generation).await;
    assert_eq!(frames.last().unwrap().header["sampling"], "final");
}
