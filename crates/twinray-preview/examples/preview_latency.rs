//! How fast the preview answers, per scene (`bench/preview.sh` runs it over
//! the SPD scenes): the first frame of a page, and the latency from a change
//! of interaxial to the first (1/8) frame of the new rig, median over 20
//! changes made one after another (each cancelling the render in flight, as
//! a slider being dragged does), how long the renders go on once a page is
//! gone in the middle of one (median of 5), and the server's memory over 10
//! quick reconnects.
//!
//! `cargo run --release -p twinray-preview --example preview_latency -- WxH SCENE...`
//!
//! Times are measured at a WebSocket client on the loopback interface, from
//! sending the change (an HTTP request to the server's router, in-process)
//! to receiving the encoded frame; the browser's decoding and painting are
//! not included.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use axum::body::Body;
use axum::http::Request;
use futures_util::StreamExt;
use serde_json::{json, Value};
use tokio::net::TcpListener;
use tokio_tungstenite::tungstenite::Message;
use tower::ServiceExt;

use twinray::job::{CancelToken, JobSpec};
use twinray_preview::session::parse_frame;
use twinray_preview::Preview;

type Socket =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

async fn connect(address: std::net::SocketAddr) -> (Socket, String) {
    let (mut socket, _) = tokio_tungstenite::connect_async(format!("ws://{address}/api/session"))
        .await
        .expect("the server answers");
    loop {
        if let Some(Ok(Message::Text(t))) = socket.next().await {
            let hello: Value = serde_json::from_str(t.as_str()).unwrap_or_default();
            let id = hello["session"].as_str().unwrap_or_default();
            return (socket, id.to_string());
        }
    }
}

/// Posts `settings`; returns the change's generation.
async fn change(preview: &Preview, address: SocketAddr, session: &str, settings: &Value) -> u64 {
    let answer = post_view(preview, address, session, settings).await;
    let status = answer.status();
    let body = axum::body::to_bytes(answer.into_body(), 1 << 24)
        .await
        .unwrap_or_default();
    let info: Value = serde_json::from_slice(&body).unwrap_or_default();
    assert!(status.is_success(), "{status}: {info}");
    info["generation"].as_u64().unwrap_or(0)
}

/// Waits for the first frame of `generation`; returns its header.
async fn first_frame(socket: &mut Socket, generation: u64) -> Value {
    loop {
        let next = tokio::time::timeout(Duration::from_secs(120), socket.next()).await;
        if let Ok(Some(Ok(Message::Binary(bytes)))) = next {
            if let Some((header, _)) = parse_frame(&bytes) {
                if header["generation"].as_u64() >= Some(generation) {
                    return header;
                }
            }
        } else if !matches!(next, Ok(Some(Ok(_)))) {
            panic!("no frame: {next:?}");
        }
    }
}

fn rss_kib() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse().ok())
        })
        .unwrap_or(0)
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn median(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[v.len() / 2], v[(v.len() * 9 / 10).min(v.len() - 1)])
}

#[tokio::main(flavor = "current_thread")]
async fn main() {
    let mut args = std::env::args().skip(1);
    let size = args.next().unwrap_or_else(|| "480x270".into());
    let (w, h) = size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
        .expect("WxH");
    println!("scene\tload_ms\tfirst_frame_ms\tfirst_frame_warm_ms\tchange_median_ms\tchange_p90_ms\tfull_frame_ms\tgone_stop_ms\trss_before_kib\trss_after_10_reconnects_kib");
    for scene in args.map(PathBuf::from) {
        let mut spec = JobSpec::new(&scene, "");
        spec.camera.size = Some([w, h]);
        let start = Instant::now();
        let preview = Preview::new(spec, w).expect("valid flags");
        let load = start.elapsed();
        if let Some(e) = preview.load_error() {
            eprintln!("{}: {e}", scene.display());
            continue;
        }
        let listener = TcpListener::bind("127.0.0.1:0").await.expect("a port");
        let address = listener.local_addr().expect("an address");
        let stop = CancelToken::new();
        tokio::spawn(preview.clone().serve(listener, stop.clone()));
        let anaglyph = json!({});

        // A fresh server: the first plan builds the hierarchy.
        let (mut socket, session) = connect(address).await;
        let t = Instant::now();
        let g = change(&preview, address, &session, &anaglyph).await;
        first_frame(&mut socket, g).await;
        let first = t.elapsed();
        // The full-size frame (one ray per pixel) of that first view.
        let full = loop {
            let header = first_frame(&mut socket, g).await;
            if header["divisor"] == 1 {
                break t.elapsed();
            }
        };
        drop(socket);

        // A second page: the hierarchy is built.
        let (mut socket, session) = connect(address).await;
        let t = Instant::now();
        let g = change(&preview, address, &session, &anaglyph).await;
        first_frame(&mut socket, g).await;
        let warm = t.elapsed();
        let interaxial = preview_interaxial(&preview, address, &session).await;

        // 20 changes of interaxial, each made as soon as the previous one's
        // coarse frame is in: the renders in flight are cancelled.
        let mut latencies = Vec::new();
        for i in 0..20 {
            let factor = 0.6 + 0.05 * f64::from(i);
            let settings = json!({ "interaxial": format!("{}", interaxial * factor) });
            let t = Instant::now();
            let g = change(&preview, address, &session, &settings).await;
            first_frame(&mut socket, g).await;
            latencies.push(ms(t.elapsed()));
        }
        let (med, p90) = median(latencies);
        drop(socket);
        while preview.sessions() > 0 || preview.render_threads() > 0 {
            tokio::time::sleep(Duration::from_millis(1)).await;
        }

        // Pages gone in the middle of a render: how long until nothing
        // renders and their threads have ended.
        let mut gone = Vec::new();
        for _ in 0..5 {
            let (mut socket, session) = connect(address).await;
            let g = change(&preview, address, &session, &anaglyph).await;
            first_frame(&mut socket, g).await;
            drop(socket);
            let t = Instant::now();
            while preview.sessions() > 0 || preview.rendering() || preview.render_threads() > 0 {
                tokio::time::sleep(Duration::from_millis(1)).await;
            }
            gone.push(ms(t.elapsed()));
        }
        let (gone, _) = median(gone);

        let before = rss_kib();
        for _ in 0..10 {
            let (mut socket, session) = connect(address).await;
            let g = change(&preview, address, &session, &anaglyph).await;
            first_frame(&mut socket, g).await;
        }
        while preview.sessions() > 0 || preview.render_threads() > 0 {
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
        let after = rss_kib();
        stop.cancel();
        println!(
            "{}\t{:.0}\t{:.0}\t{:.0}\t{:.0}\t{:.0}\t{:.0}\t{:.0}\t{before}\t{after}",
            scene
                .file_stem()
                .map(|s| s.to_string_lossy())
                .unwrap_or_default(),
            ms(load),
            ms(first),
            ms(warm),
            med,
            p90,
            ms(full),
            gone,
        );
    }
}

/// Posts `settings` to the session's view, as its page does.
async fn post_view(
    preview: &Preview,
    address: SocketAddr,
    session: &str,
    settings: &Value,
) -> axum::response::Response {
    let request = Request::post(format!("/api/session/{session}/view"))
        .header("host", address.to_string())
        .header("content-type", "application/json")
        .body(Body::from(settings.to_string()))
        .unwrap_or_default();
    preview
        .router(address)
        .oneshot(request)
        .await
        .expect("an answer")
}

/// The automatic interaxial of the scene (the changes scale it).
async fn preview_interaxial(preview: &Preview, address: SocketAddr, session: &str) -> f64 {
    let answer = post_view(preview, address, session, &json!({})).await;
    let body = axum::body::to_bytes(answer.into_body(), 1 << 24)
        .await
        .unwrap_or_default();
    let info: Value = serde_json::from_slice(&body).unwrap_or_default();
    info["rig"]["interaxial"].as_f64().unwrap_or(0.1)
}
