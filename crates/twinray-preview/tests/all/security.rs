//! Only the server's own page can drive the preview: a foreign `Origin` or
//! a rebinding `Host` is refused, ids cannot be guessed, the pages open and
//! their messages are capped, full-size renders are pruned and removed, and
//! a page gone stops its renders.

use std::time::{Duration, Instant};

use axum::http::StatusCode;
use futures_util::{SinkExt, StreamExt};
use serde_json::{json, Value};
use tokio_tungstenite::tungstenite::Message;

use twinray_preview::ids::is_id;
use twinray_preview::renders::KEPT_RENDERS;
use twinray_preview::{MAX_PAGES, MAX_PAGE_MESSAGE};

use crate::common::*;

const EVIL: &str = "http://evil.example";

/// A request another site's page makes: method, path, headers and body.
type Attempt<'a> = (&'a str, &'a str, Vec<(&'a str, &'a str)>, Option<String>);

#[tokio::test]
async fn foreign_origins_are_refused_on_the_upgrade_and_on_every_post() {
    let server = serve(base(&example())).await;
    // The WebSocket: a page of another site gets no session.
    for origin in [EVIL, "null", "http://127.0.0.1:1", "https://localhost"] {
        let refused = server.try_connect(&[("origin", origin)]).await;
        assert_eq!(refused.err(), Some(StatusCode::FORBIDDEN), "{origin}");
    }
    assert_eq!(server.preview.sessions(), 0);
    let (_socket, session) = server.connect().await;

    let view = format!("/api/session/{session}/view");
    let render = format!("/api/session/{session}/render");
    let settings = json!({ "samples": 1 }).to_string();
    let form = ("content-type", "application/x-www-form-urlencoded");
    let refused_before = server.preview.refused();
    let requests: Vec<Attempt> = vec![
        // The plain cross-site form of the attack.
        (
            "POST",
            "/api/reload",
            vec![("origin", EVIL), form],
            Some("a=1".into()),
        ),
        ("POST", "/api/reload", vec![("origin", "null"), form], None),
        (
            "POST",
            "/api/reload",
            vec![("sec-fetch-site", "cross-site")],
            None,
        ),
        (
            "POST",
            &view,
            vec![("origin", EVIL)],
            Some(settings.clone()),
        ),
        (
            "POST",
            &render,
            vec![("origin", EVIL)],
            Some(settings.clone()),
        ),
        ("GET", "/api/state", vec![("origin", EVIL)], None),
    ];
    for (method, uri, headers, body) in &requests {
        let (status, answer) = server
            .request_with(method, uri, headers, body.clone())
            .await;
        assert_eq!(status, StatusCode::FORBIDDEN, "{method} {uri} {headers:?}");
        let answer: Value = serde_json::from_slice(&answer).unwrap();
        assert!(
            answer["error"].as_str().unwrap().starts_with("refused: "),
            "{answer}"
        );
    }
    assert_eq!(
        server.preview.refused() - refused_before,
        requests.len() as u64
    );
    // The page's own requests, and a client that is not a browser.
    let (status, _) = server.request("POST", "/api/reload", None).await;
    assert_eq!(status, StatusCode::OK);
    let (status, answer) = server
        .request_with("POST", &view, &[], Some(settings))
        .await;
    assert_eq!(
        status,
        StatusCode::OK,
        "{}",
        String::from_utf8_lossy(&answer)
    );
}

#[tokio::test]
async fn rebinding_hosts_are_refused() {
    let server = serve(base(&example())).await;
    let (_socket, session) = server.connect().await;
    let port = server.address.port();
    // A full-size render whose file a rebinding page would download.
    let (status, done) = server.render_full(&session).await;
    assert_eq!(status, StatusCode::OK, "{done}");
    let download = done["files"][0]["url"].as_str().unwrap().to_string();
    let (status, _) = server.request("GET", &download, None).await;
    assert_eq!(status, StatusCode::OK);

    let view = format!("/api/session/{session}/view");
    let render = format!("/api/session/{session}/render");
    for host in [
        format!("evil.example:{port}"),
        format!("127.0.0.1.evil.example:{port}"),
        "evil.example".to_string(),
        format!("127.0.0.1:{}", port ^ 1),
        format!("192.168.0.1:{port}"),
    ] {
        let origin = format!("http://{host}");
        for (method, uri) in [
            ("GET", "/"),
            ("GET", "/api/state"),
            ("POST", view.as_str()),
            ("POST", render.as_str()),
            ("GET", download.as_str()),
            ("POST", "/api/reload"),
        ] {
            // As the rebinding page sends them: its own name as Host, and
            // as Origin on a POST (a browser sends none on its own GETs).
            let post = method == "POST";
            let headers = [("host", host.as_str()), ("origin", origin.as_str())];
            let headers = if post { &headers[..] } else { &headers[..1] };
            let body = post.then(|| json!({ "samples": 1 }).to_string());
            let (status, _) = server.request_with(method, uri, headers, body).await;
            assert_eq!(status, StatusCode::FORBIDDEN, "{method} {uri} Host {host}");
        }
        let refused = server
            .try_connect(&[("host", host.as_str()), ("origin", origin.as_str())])
            .await;
        assert_eq!(refused.err(), Some(StatusCode::FORBIDDEN), "Host {host}");
    }
    // The names of the server itself.
    for host in [
        format!("127.0.0.1:{port}"),
        format!("localhost:{port}"),
        format!("[::1]:{port}"),
    ] {
        let (status, _) = server
            .request_with("GET", "/api/state", &[("host", &host)], None)
            .await;
        assert_eq!(status, StatusCode::OK, "{host}");
    }
}

/// An id as a number, to look at the gaps between ids.
fn id_number(id: &str) -> u128 {
    u128::from_str_radix(id, 16).unwrap()
}

#[tokio::test]
async fn session_and_render_ids_are_random_128_bit_numbers() {
    let server = serve(base(&example())).await;
    let mut sessions = Vec::new();
    let mut sockets = Vec::new();
    for _ in 0..4 {
        let (socket, id) = server.connect().await;
        sockets.push(socket);
        sessions.push(id);
    }
    let session = &sessions[0];
    let mut renders = Vec::new();
    for _ in 0..3 {
        let (status, done) = server.render_full(session).await;
        assert_eq!(status, StatusCode::OK, "{done}");
        let url = done["files"][0]["url"].as_str().unwrap();
        renders.push(url.split('/').nth(3).unwrap().to_string());
    }
    for ids in [&sessions, &renders] {
        assert!(ids.iter().all(|id| is_id(id)), "{ids:?}");
        for pair in ids.windows(2) {
            let gap = id_number(&pair[0]).abs_diff(id_number(&pair[1]));
            // Sequential or clock-like ids lie close together.
            assert!(gap > 1 << 64, "{pair:?}");
        }
    }
    // Another page's session cannot be reached by a near guess.
    let last = id_number(&sessions[3]);
    for guess in [last + 1, last - 1, last ^ 1] {
        let (status, _) = server
            .change(&format!("{guess:032x}"), json!({ "samples": 1 }))
            .await;
        assert_eq!(status, StatusCode::NOT_FOUND);
    }
}

#[tokio::test]
async fn the_pages_open_are_capped() {
    let server = serve(base(&example())).await;
    let mut open = Vec::new();
    for _ in 0..MAX_PAGES {
        open.push(server.connect().await);
    }
    let origin = server.origin();
    let refused = server.try_connect(&[("origin", &origin)]).await;
    assert_eq!(refused.err(), Some(StatusCode::SERVICE_UNAVAILABLE));
    assert_eq!(server.preview.sessions(), MAX_PAGES);
    // One closed: its place is given back.
    drop(open.pop());
    server
        .wait_until(10, "the page to close", |p| p.sessions() < MAX_PAGES)
        .await;
    let (_socket, session) = server.connect().await;
    let (status, _) = server.change(&session, settings("0.2")).await;
    assert_eq!(status, StatusCode::OK);
}

#[tokio::test]
async fn a_page_message_past_the_cap_closes_the_page() {
    let server = serve(base(&example())).await;
    let (mut socket, first) = server.connect().await;
    // Small messages (a ping, a note) are taken and ignored.
    socket.send(Message::Text("hello".into())).await.unwrap();
    socket.send(Message::Ping(vec![1].into())).await.unwrap();
    let (mut other, _) = server.connect().await;
    assert_eq!(server.preview.sessions(), 2);
    let big = "x".repeat(MAX_PAGE_MESSAGE + 1);
    // The server may close before the whole message is sent.
    let _ = other.send(Message::Text(big.into())).await;
    let closed = tokio::time::timeout(Duration::from_secs(10), async {
        loop {
            match other.next().await {
                None | Some(Err(_)) | Some(Ok(Message::Close(_))) => return,
                Some(Ok(_)) => {}
            }
        }
    })
    .await;
    assert!(
        closed.is_ok(),
        "the page with the large message stayed open"
    );
    server
        .wait_until(10, "the session to close", |p| p.sessions() == 1)
        .await;
    // The first page still works.
    let (status, info) = server.change(&first, settings("0.2")).await;
    assert_eq!(status, StatusCode::OK);
    let frames = frames_of(&mut socket, info["generation"].as_u64().unwrap()).await;
    assert_eq!(frames.len(), 4);
}

#[tokio::test]
async fn full_renders_are_pruned_and_removed_when_the_server_stops() {
    let server = serve(base(&example())).await;
    let (_socket, session) = server.connect().await;
    let mut urls = Vec::new();
    for _ in 0..KEPT_RENDERS + 2 {
        let (status, done) = server.render_full(&session).await;
        assert_eq!(status, StatusCode::OK, "{done}");
        urls.push(done["files"][0]["url"].as_str().unwrap().to_string());
    }
    assert_eq!(server.preview.kept_renders().len(), KEPT_RENDERS);
    let folder = server.preview.render_folder().to_path_buf();
    let folders = || {
        std::fs::read_dir(&folder)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.path().is_dir())
            .count()
    };
    assert_eq!(folders(), KEPT_RENDERS);
    for (i, url) in urls.iter().enumerate() {
        let (status, _) = server.request("GET", url, None).await;
        let expected = if i < 2 {
            StatusCode::NOT_FOUND
        } else {
            StatusCode::OK
        };
        assert_eq!(status, expected, "render {i}");
    }
    server.stop.cancel();
    let start = Instant::now();
    while !server.serving.is_finished() {
        assert!(start.elapsed() < Duration::from_secs(10), "still serving");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    assert_eq!(folders(), 0);
    assert!(server.preview.kept_renders().is_empty());
}

/// A full-size render far longer than the tests wait: 4096 samples per
/// pixel.
fn slow_full() -> Value {
    json!({ "samples": 4096, "interaxial": "0.2" })
}

/// Starts a slow full-size render of `session` in a task, and waits for its
/// first progress message.
async fn start_slow_full_render(
    server: &Server,
    socket: &mut Socket,
    session: &str,
) -> tokio::task::JoinHandle<StatusCode> {
    let preview = server.preview.clone();
    let (address, origin) = (server.address, server.origin());
    let uri = format!("/api/session/{session}/render");
    let task = tokio::spawn(async move {
        use tower::ServiceExt;
        let request = axum::http::Request::post(uri)
            .header("host", address.to_string())
            .header("origin", origin)
            .header("content-type", "application/json")
            .body(axum::body::Body::from(slow_full().to_string()))
            .unwrap();
        preview
            .router(address)
            .oneshot(request)
            .await
            .unwrap()
            .status()
    });
    loop {
        let m = next_text(socket).await;
        if m["type"] == "full-progress" {
            return task;
        }
    }
}

#[tokio::test]
async fn a_page_gone_stops_its_full_size_render() {
    // Tall and narrow: the renderer looks at its token between bands of
    // rows, each short here, while the whole render is long.
    let mut spec = base(&example());
    spec.camera.size = Some([8, 480]);
    let server = serve(spec).await;
    let (mut socket, session) = server.connect().await;
    let task = start_slow_full_render(&server, &mut socket, &session).await;
    // One at a time per page.
    let (status, _) = server.render_full(&session).await;
    assert_eq!(status, StatusCode::CONFLICT);
    let gone = Instant::now();
    drop(socket);
    server
        .wait_until(60, "the full-size render to stop", |p| {
            p.full_render_counts() == (0, 1)
        })
        .await;
    let stopped = gone.elapsed();
    assert_eq!(task.await.unwrap(), StatusCode::BAD_REQUEST);
    // Nothing kept: its folder went with it.
    assert!(server.preview.kept_renders().is_empty());
    let left = std::fs::read_dir(server.preview.render_folder())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_dir())
        .count();
    assert_eq!(left, 0);
    eprintln!("full-size render stopped {stopped:?} after the page went");
}
