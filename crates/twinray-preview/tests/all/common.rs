//! What the in-process tests share: a server on a loopback port, requests
//! to its router as the page sends them, and its WebSocket.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use axum::body::Body;
use axum::http::{Request, StatusCode};
use futures_util::StreamExt;
use serde_json::{json, Value};
use tokio::net::TcpListener;
use tokio_tungstenite::tungstenite::client::IntoClientRequest;
use tokio_tungstenite::tungstenite::Message;
use tower::ServiceExt;

use twinray::job::{CancelToken, JobSpec};
use twinray_preview::session::parse_frame;
use twinray_preview::Preview;

pub type Socket =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

pub fn example() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/example.nff")
}

/// The command line's spec of a small preview of the example scene.
pub fn base(scene: &Path) -> JobSpec {
    let mut spec = JobSpec::new(scene, "");
    spec.camera.size = Some([192, 108]);
    spec
}

pub struct Server {
    pub preview: Preview,
    pub address: std::net::SocketAddr,
    pub stop: CancelToken,
    pub serving: tokio::task::JoinHandle<std::io::Result<()>>,
}

impl Drop for Server {
    fn drop(&mut self) {
        self.stop.cancel();
    }
}

/// A server of `spec` with 96-pixel-wide previews, on a free loopback port.
pub async fn serve(spec: JobSpec) -> Server {
    let preview = Preview::new(spec, 96).expect("the flags are valid");
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap();
    let stop = CancelToken::new();
    let serving = tokio::spawn(preview.clone().serve(listener, stop.clone()));
    Server {
        preview,
        address,
        stop,
        serving,
    }
}

impl Server {
    /// The server's own origin, as its page sends it.
    pub fn origin(&self) -> String {
        format!("http://{}", self.address)
    }

    /// A request with `headers` (the page's Host unless they give one).
    pub async fn request_with(
        &self,
        method: &str,
        uri: &str,
        headers: &[(&str, &str)],
        body: Option<String>,
    ) -> (StatusCode, Vec<u8>) {
        let mut request = Request::builder().method(method).uri(uri);
        if !headers.iter().any(|(h, _)| h.eq_ignore_ascii_case("host")) {
            request = request.header("host", self.address.to_string());
        }
        for (name, value) in headers {
            request = request.header(*name, *value);
        }
        if body.is_some()
            && !headers
                .iter()
                .any(|(h, _)| h.eq_ignore_ascii_case("content-type"))
        {
            request = request.header("content-type", "application/json");
        }
        let request = request
            .body(body.map_or_else(Body::empty, Body::from))
            .unwrap();
        let answer = self
            .preview
            .router(self.address)
            .oneshot(request)
            .await
            .unwrap();
        let status = answer.status();
        let bytes = axum::body::to_bytes(answer.into_body(), 1 << 28)
            .await
            .unwrap();
        (status, bytes.to_vec())
    }

    /// A request as the page sends it (its Host and Origin).
    pub async fn request(
        &self,
        method: &str,
        uri: &str,
        body: Option<String>,
    ) -> (StatusCode, Vec<u8>) {
        let origin = self.origin();
        self.request_with(method, uri, &[("origin", &origin)], body)
            .await
    }

    pub async fn json(&self, method: &str, uri: &str, body: Option<Value>) -> (StatusCode, Value) {
        let (status, bytes) = self.request(method, uri, body.map(|b| b.to_string())).await;
        let value = serde_json::from_slice(&bytes)
            .unwrap_or_else(|_| panic!("{uri}: not JSON: {}", String::from_utf8_lossy(&bytes)));
        (status, value)
    }

    /// Opens a WebSocket to `/api/session` with `headers`: the socket, or
    /// the status it was refused with.
    pub async fn try_connect(&self, headers: &[(&str, &str)]) -> Result<Socket, StatusCode> {
        let mut request = format!("ws://{}/api/session", self.address)
            .into_client_request()
            .unwrap();
        for (name, value) in headers {
            request.headers_mut().insert(
                axum::http::HeaderName::from_bytes(name.as_bytes()).unwrap(),
                value.parse().unwrap(),
            );
        }
        match tokio_tungstenite::connect_async(request).await {
            Ok((socket, _)) => Ok(socket),
            Err(tokio_tungstenite::tungstenite::Error::Http(answer)) => Err(answer.status()),
            Err(e) => panic!("the WebSocket failed: {e}"),
        }
    }

    /// Opens a page's WebSocket: the socket and the session's id.
    pub async fn connect(&self) -> (Socket, String) {
        let origin = self.origin();
        let mut socket = self
            .try_connect(&[("origin", &origin)])
            .await
            .unwrap_or_else(|status| panic!("the WebSocket was refused: {status}"));
        let hello = next_text(&mut socket).await;
        assert_eq!(hello["type"], "hello");
        (socket, hello["session"].as_str().unwrap().to_string())
    }

    pub async fn change(&self, session: &str, settings: Value) -> (StatusCode, Value) {
        self.json(
            "POST",
            &format!("/api/session/{session}/view"),
            Some(settings),
        )
        .await
    }

    /// A full-size render of `session` at one sample a pixel: the status
    /// and the answer.
    pub async fn render_full(&self, session: &str) -> (StatusCode, Value) {
        self.json(
            "POST",
            &format!("/api/session/{session}/render"),
            Some(json!({ "samples": 1 })),
        )
        .await
    }

    /// Waits until `done` holds, for at most `seconds`.
    pub async fn wait_until(&self, seconds: u64, what: &str, done: impl Fn(&Preview) -> bool) {
        let start = Instant::now();
        while !done(&self.preview) {
            assert!(
                start.elapsed() < Duration::from_secs(seconds),
                "waited {seconds} s for {what}"
            );
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    }
}

pub async fn next_text(socket: &mut Socket) -> Value {
    loop {
        match tokio::time::timeout(Duration::from_secs(60), socket.next()).await {
            Ok(Some(Ok(Message::Text(t)))) => return serde_json::from_str(t.as_str()).unwrap(),
            Ok(Some(Ok(_))) => continue,
            other => panic!("no text message: {other:?}"),
        }
    }
}

/// A frame: its header and its PNG images.
pub struct Frame {
    pub header: Value,
    pub images: Vec<Vec<u8>>,
}

impl Frame {
    pub fn generation(&self) -> u64 {
        self.header["generation"].as_u64().unwrap()
    }
    pub fn is_last(&self) -> bool {
        self.header["pass"].as_u64().unwrap() + 1 == self.header["passes"].as_u64().unwrap()
    }
}

/// The next frame; a render that fails instead (the session's `error`
/// message) fails the test.
pub async fn next_frame(socket: &mut Socket) -> Frame {
    loop {
        match tokio::time::timeout(Duration::from_secs(120), socket.next()).await {
            Ok(Some(Ok(Message::Binary(bytes)))) => {
                let (header, images) = parse_frame(&bytes).expect("a well-formed frame");
                return Frame { header, images };
            }
            Ok(Some(Ok(Message::Text(text)))) => {
                let m: Value = serde_json::from_str(text.as_str()).unwrap();
                assert_ne!(m["type"], "error", "the render failed: {m}");
            }
            Ok(Some(Ok(_))) => continue,
            other => panic!("no frame: {other:?}"),
        }
    }
}

/// The frames of `generation` up to its last pass (older ones skipped).
pub async fn frames_of(socket: &mut Socket, generation: u64) -> Vec<Frame> {
    let mut frames = Vec::new();
    loop {
        let frame = next_frame(socket).await;
        assert!(frame.generation() <= generation, "a frame from the future");
        if frame.generation() < generation {
            continue;
        }
        let last = frame.is_last();
        frames.push(frame);
        if last {
            return frames;
        }
    }
}

pub fn pixels(png: &[u8]) -> image::RgbImage {
    image::load_from_memory(png).unwrap().to_rgb8()
}

pub fn settings(interaxial: &str) -> Value {
    json!({ "interaxial": interaxial, "samples": 1 })
}
