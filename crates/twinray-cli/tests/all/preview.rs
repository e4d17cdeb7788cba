//! `twinray preview` as a user runs it: it prints the URL of a server on
//! loopback that answers, warns when told to listen beyond it, refuses bad
//! flags as `render` does, stops cleanly on Ctrl-C (SIGINT), and on SIGTERM
//! within a second even while a page's full-size render runs.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn example() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/example.nff")
}

/// A running `twinray preview`, killed if the test fails.
struct Running(Child);

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn start(args: &[&str]) -> (Running, String) {
    start_in(&std::env::temp_dir(), args)
}

/// `twinray preview` with `temp` as its temporary folder.
fn start_in(temp: &std::path::Path, args: &[&str]) -> (Running, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_twinray"))
        .arg("preview")
        .arg(example())
        .args(args)
        .env("TMPDIR", temp)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the binary runs");
    let stdout = child.stdout.take().expect("stdout");
    let mut line = String::new();
    BufReader::new(stdout).read_line(&mut line).unwrap();
    let url = line
        .split_whitespace()
        .find(|w| w.starts_with("http://"))
        .unwrap_or_else(|| panic!("no URL in {line:?}"))
        .to_string();
    (Running(child), url)
}

/// One GET over a plain connection (the test's own client, HTTP/1.0).
fn get(url: &str, path: &str) -> String {
    let host = url.trim_start_matches("http://").trim_end_matches('/');
    let mut stream = TcpStream::connect(host).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(30)))
        .unwrap();
    write!(stream, "GET {path} HTTP/1.0\r\nHost: {host}\r\n\r\n").unwrap();
    let mut answer = String::new();
    stream.read_to_string(&mut answer).unwrap();
    answer
}

#[test]
fn preview_serves_on_loopback_and_stops_on_ctrl_c() {
    let (mut running, url) = start(&["--size", "96x72"]);
    assert!(url.starts_with("http://127.0.0.1:"), "{url}");
    let state = get(&url, "/api/state");
    assert!(state.starts_with("HTTP/1.0 200"), "{state}");
    assert!(state.contains("\"full_size\":[96,72]"), "{state}");
    let page = get(&url, "/");
    assert!(page.contains("twinray preview"), "{page}");

    // SIGINT: the server stops and the command exits 0.
    let (status, _) = signal(&mut running, "INT", Duration::from_secs(20));
    assert!(status.success(), "{status:?}");
}

/// Sends `running` the signal `name` (with the system's `kill`) and waits
/// at most `limit` for it to exit: its status and how long it took.
fn signal(
    running: &mut Running,
    name: &str,
    limit: Duration,
) -> (std::process::ExitStatus, Duration) {
    let pid = running.0.id().to_string();
    let sent = Command::new("kill")
        .args([&format!("-{name}"), &pid])
        .status()
        .expect("the system's kill command");
    assert!(sent.success());
    let start = Instant::now();
    loop {
        if let Some(status) = running.0.try_wait().unwrap() {
            return (status, start.elapsed());
        }
        assert!(start.elapsed() < limit, "still running after {limit:?}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn sigterm_stops_the_server_at_once_while_a_page_renders_full_size() {
    let temp = tempfile::tempdir().unwrap();
    let (mut running, url) = start_in(temp.path(), &["--size", "320x180"]);
    let host = url.trim_start_matches("http://").trim_end_matches('/');
    let origin = format!("http://{host}");
    // The page: its WebSocket and session.
    let mut request = tungstenite::client::IntoClientRequest::into_client_request(format!(
        "ws://{host}/api/session"
    ))
    .unwrap();
    request
        .headers_mut()
        .insert("origin", origin.parse().unwrap());
    let (mut socket, _) = tungstenite::connect(request).unwrap();
    let hello: serde_json::Value = match socket.read().unwrap() {
        tungstenite::Message::Text(t) => serde_json::from_str(t.as_str()).unwrap(),
        other => panic!("no hello: {other:?}"),
    };
    let session = hello["session"].as_str().unwrap();
    // "Render full size" at 65536 samples a pixel: hours of work, posted
    // and not waited for.
    let body = r#"{"samples": 65536}"#;
    let mut post = TcpStream::connect(host).unwrap();
    write!(
        post,
        "POST /api/session/{session}/render HTTP/1.1\r\nHost: {host}\r\nOrigin: {origin}\r\n\
         Content-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}",
        body.len()
    )
    .unwrap();
    // Its render folder appears when the render starts.
    let start = Instant::now();
    while !has_render_folder(temp.path()) {
        assert!(start.elapsed() < Duration::from_secs(20), "no render began");
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(Duration::from_millis(500));
    let (status, took) = signal(&mut running, "TERM", Duration::from_secs(5));
    assert!(status.success(), "{status:?}");
    eprintln!("stopped {took:?} after SIGTERM");
    // Its temporary files went with it.
    let left: Vec<_> = std::fs::read_dir(temp.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

/// Whether the server's temporary folder under `temp` holds a full-size
/// render's folder.
fn has_render_folder(temp: &std::path::Path) -> bool {
    let Ok(entries) = std::fs::read_dir(temp) else {
        return false;
    };
    entries.filter_map(|e| e.ok()).any(|server| {
        std::fs::read_dir(server.path())
            .map(|inner| inner.filter_map(|e| e.ok()).any(|e| e.path().is_dir()))
            .unwrap_or(false)
    })
}

#[test]
fn bind_beyond_loopback_warns() {
    let (mut running, url) = start(&["--bind", "0.0.0.0", "--size", "32x24"]);
    assert!(url.starts_with("http://0.0.0.0:"), "{url}");
    let _ = running.0.kill();
    let mut stderr = String::new();
    running
        .0
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut stderr)
        .unwrap();
    assert!(
        stderr.contains("warning: --bind 0.0.0.0: the preview listens beyond this machine"),
        "{stderr}"
    );
}

#[test]
fn bad_flags_are_refused_as_render_refuses_them() {
    let run = |command: &str, flags: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_twinray"))
            .arg(command)
            .arg(example())
            .args(flags)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{command} {flags:?} was accepted");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    for flags in [
        &["--stereo", "--convergence", "-3"][..],
        &["--stereo", "--samples", "0"][..],
        &["--views", "3", "--layout", "sbs"][..],
    ] {
        let render = run("render", &[flags, &["-o", "x.png"]].concat());
        let preview = run("preview", flags);
        assert_eq!(preview, render, "{flags:?}");
        assert!(preview.starts_with("twinray: "), "{preview}");
    }
}
