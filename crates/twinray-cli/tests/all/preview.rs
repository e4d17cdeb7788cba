//! `twinray preview` as a user runs it: it prints the URL of a server on
//! loopback that answers, warns when told to listen beyond it, refuses bad
//! flags as `render` does, and stops cleanly on Ctrl-C (SIGINT).

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
    let mut child = Command::new(env!("CARGO_BIN_EXE_twinray"))
        .arg("preview")
        .arg(example())
        .args(args)
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
    let pid = running.0.id().to_string();
    let Ok(sent) = Command::new("kill").args(["-INT", &pid]).status() else {
        eprintln!("notice: no kill command: the Ctrl-C part is skipped");
        return;
    };
    assert!(sent.success());
    let start = Instant::now();
    let status = loop {
        if let Some(status) = running.0.try_wait().unwrap() {
            break status;
        }
        assert!(start.elapsed() < Duration::from_secs(20), "still running");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert!(status.success(), "{status:?}");
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
