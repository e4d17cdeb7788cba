//! The page in a real browser: Debian's Chromium, headless, driven through
//! the DevTools protocol (a few commands over its WebSocket). It waits for
//! the first frames, moves the interaxial slider with the mouse, checks that
//! the image changed, and saves a screenshot that it inspects (not blank,
//! the frame and the controls drawn). A panorama's look-around viewer turns
//! with a drag of the mouse or a finger, and its anaglyph shows both eyes.
//! Pages of other sites, and a page served under a rebound name, are
//! refused.
//!
//! A harness of its own (libtest-mimic), so that where Chromium is missing
//! the tests show as ignored, with the reason, instead of passing. Under CI
//! (`CI=true`), where `.ci/run` installs Chromium, they always run, and a
//! missing browser fails them.

use std::future::Future;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitCode, Stdio};
use std::time::{Duration, Instant};

use base64::Engine;
use futures_util::{SinkExt, StreamExt};
use libtest_mimic::{Arguments, Failed, Trial};
use serde_json::{json, Value};
use tokio::net::TcpListener;
use tokio_tungstenite::tungstenite::Message;

use twinray::job::{CancelToken, JobSpec};
use twinray_preview::Preview;

#[path = "all/correlation.rs"]
mod correlation;
use correlation::correlation;

type Socket =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

fn chromium() -> Option<PathBuf> {
    // TWINRAY_CHROMIUM names the browser (and only it).
    if let Ok(p) = std::env::var("TWINRAY_CHROMIUM") {
        return Some(PathBuf::from(p)).filter(|p| p.exists());
    }
    ["/usr/bin/chromium", "/usr/bin/chromium-browser"]
        .iter()
        .map(PathBuf::from)
        .find(|p| p.exists())
}

/// The browser process, killed when dropped.
struct Browser {
    child: Child,
    _profile: tempfile::TempDir,
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts headless Chromium with a fresh profile (and `extra` flags);
/// returns it and the DevTools WebSocket URL of the browser.
async fn launch(binary: &Path, extra: &[&str]) -> (Browser, String) {
    let profile = tempfile::tempdir().unwrap();
    let child = Command::new(binary)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--remote-debugging-port=0",
            "--window-size=1400,1150",
        ])
        .args(extra)
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .arg("about:blank")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("chromium starts");
    let browser = Browser {
        child,
        _profile: profile,
    };
    // Chromium writes its port and the browser's path when it listens.
    let port_file = browser._profile.path().join("DevToolsActivePort");
    let start = Instant::now();
    loop {
        if let Ok(text) = std::fs::read_to_string(&port_file) {
            let mut lines = text.lines();
            if let (Some(port), Some(path)) = (lines.next(), lines.next()) {
                return (browser, format!("ws://127.0.0.1:{port}{path}"));
            }
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "chromium did not open its DevTools port"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// A DevTools connection, with the page's session once attached.
struct DevTools {
    socket: Socket,
    next_id: u64,
    session: Option<String>,
}

impl DevTools {
    async fn call(&mut self, method: &str, params: Value) -> Value {
        self.next_id += 1;
        let id = self.next_id;
        let mut message = json!({ "id": id, "method": method, "params": params });
        if let Some(s) = &self.session {
            message["sessionId"] = json!(s);
        }
        self.socket
            .send(Message::Text(message.to_string().into()))
            .await
            .unwrap();
        loop {
            let answer = tokio::time::timeout(Duration::from_secs(60), self.socket.next())
                .await
                .unwrap_or_else(|_| panic!("{method}: no answer"));
            let Some(Ok(Message::Text(text))) = answer else {
                continue;
            };
            let value: Value = serde_json::from_str(text.as_str()).unwrap();
            if value["id"] == id {
                assert!(value.get("error").is_none(), "{method}: {value}");
                return value["result"].clone();
            }
        }
    }

    /// The value of a JavaScript expression in the page.
    async fn eval(&mut self, expression: &str) -> Value {
        let r = self
            .call(
                "Runtime.evaluate",
                json!({ "expression": expression, "returnByValue": true, "awaitPromise": true }),
            )
            .await;
        assert!(r.get("exceptionDetails").is_none(), "{expression}: {r}");
        r["result"]["value"].clone()
    }

    /// A click of the mouse in the middle of the element `id`.
    async fn click(&mut self, id: &str) {
        let centre = self
            .eval(&format!("(() => {{ const r = document.getElementById('{id}').getBoundingClientRect(); return [r.x + r.width / 2, r.y + r.height / 2]; }})()"))
            .await;
        for kind in ["mousePressed", "mouseReleased"] {
            self.call(
                "Input.dispatchMouseEvent",
                json!({ "type": kind, "x": centre[0], "y": centre[1], "button": "left", "clickCount": 1 }),
            )
            .await;
        }
    }

    /// A drag of the left mouse button from (`x`, `y`) by `dx` across, in
    /// two moves.
    async fn drag(&mut self, x: f64, y: f64, dx: f64) {
        for (kind, by) in [
            ("mousePressed", 0.0),
            ("mouseMoved", dx / 2.0),
            ("mouseMoved", dx),
            ("mouseReleased", dx),
        ] {
            self.call(
                "Input.dispatchMouseEvent",
                json!({ "type": kind, "x": x + by, "y": y, "button": "left", "buttons": 1, "clickCount": 1 }),
            )
            .await;
        }
    }

    /// Sets the control `id` to `value` as the user does, and waits for
    /// the change the page sends to be accepted.
    async fn set_control(&mut self, id: &str, value: &str) {
        let generation = self.eval("window.twinrayPreview.generation").await;
        self.eval(&format!("(() => {{ const e = document.getElementById('{id}'); e.value = '{value}'; e.dispatchEvent(new Event('change')); return true; }})()"))
            .await;
        self.wait_for(
            &format!("window.twinrayPreview.generation > {generation}"),
            &format!("the change of {id}"),
        )
        .await;
    }

    /// A screenshot of the page, saved as `name` in the tests' folder.
    async fn screenshot(&mut self, name: &str) -> Vec<u8> {
        let shot = self
            .call("Page.captureScreenshot", json!({ "format": "png" }))
            .await;
        let png = base64::engine::general_purpose::STANDARD
            .decode(shot["data"].as_str().unwrap())
            .unwrap();
        let path = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
        std::fs::write(&path, &png).unwrap();
        eprintln!("screenshot: {}", path.display());
        png
    }

    /// Waits until `expression` is true in the page (an exception, as
    /// before the page has loaded, counts as false).
    async fn wait_for(&mut self, expression: &str, what: &str) {
        let start = Instant::now();
        loop {
            let r = self
                .call(
                    "Runtime.evaluate",
                    json!({ "expression": expression, "returnByValue": true }),
                )
                .await;
            if r["result"]["value"] == json!(true) {
                return;
            }
            assert!(
                start.elapsed() < Duration::from_secs(90),
                "waited for {what}"
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }
}

/// The frame as drawn: a fingerprint of its pixels (the page decodes the
/// server's PNG; the test reads it back through a canvas).
const FRAME_PIXELS: &str = r#"(() => {
  const img = document.getElementById("frame");
  const c = document.createElement("canvas");
  c.width = img.naturalWidth; c.height = img.naturalHeight;
  const g = c.getContext("2d");
  g.drawImage(img, 0, 0);
  const d = g.getImageData(0, 0, c.width, c.height).data;
  let sum = 0, weighted = 0;
  for (let i = 0; i < d.length; i++) { sum += d[i]; weighted = (weighted + d[i] * (i % 9973)) % 1000000007; }
  return { width: c.width, height: c.height, sum, weighted };
})()"#;

/// Waits for the last pass of the newest change, drawn.
const FINAL_FRAME: &str = "(() => { const p = window.twinrayPreview; const h = p && p.lastHeader; \
     return !!h && h.generation === p.generation && h.pass + 1 === h.passes \
       && document.getElementById('frame').complete; })()";

/// The browser the tests drive (a test that runs without it fails: under
/// CI, or when asked for with `--include-ignored`).
fn chromium_or_fail() -> PathBuf {
    chromium()
        .expect("chromium is not installed (apt-get install chromium; CI installs it: .ci/run)")
}

/// A DevTools connection to the browser at `devtools_url`, attached to a
/// new page showing `url`.
async fn attach(devtools_url: &str, url: &str) -> DevTools {
    let (socket, _) = tokio_tungstenite::connect_async(devtools_url)
        .await
        .unwrap();
    let mut dt = DevTools {
        socket,
        next_id: 0,
        session: None,
    };
    let target = dt.call("Target.createTarget", json!({ "url": url })).await;
    let attached = dt
        .call(
            "Target.attachToTarget",
            json!({ "targetId": target["targetId"], "flatten": true }),
        )
        .await;
    dt.session = attached["sessionId"].as_str().map(String::from);
    dt
}

/// Chromium showing `url`, and a DevTools connection to the page.
async fn open_page(binary: &Path, url: &str) -> (Browser, DevTools) {
    let (browser, devtools_url) = launch(binary, &[]).await;
    let dt = attach(&devtools_url, url).await;
    (browser, dt)
}

/// A preview of `spec` served on a free loopback port: it and its URL.
async fn serve(spec: JobSpec, width: u32, stop: &CancelToken) -> (Preview, String) {
    let preview = Preview::new(spec, width).unwrap();
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let url = format!("http://{}/", listener.local_addr().unwrap());
    tokio::spawn(preview.clone().serve(listener, stop.clone()));
    (preview, url)
}

fn example() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../scenes/example.nff")
}

async fn a_scene_that_fails_to_load_shows_its_error_on_the_page() {
    let binary = chromium_or_fail();
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("broken.nff");
    std::fs::write(
        &scene,
        "v\nfrom 0 0 1\nat 0 0 0\nup 0 1 0\nangle 40\nhither 0\nresolution 10 10\nq 1 2 3\n",
    )
    .unwrap();
    let stop = CancelToken::new();
    let (preview, url) = serve(JobSpec::new(&scene, ""), 64, &stop).await;
    let error = preview.load_error().expect("a load error");
    let (_browser, mut dt) = open_page(&binary, &url).await;
    dt.wait_for(
        "!document.getElementById('error').hidden && !document.getElementById('reload').hidden",
        "the error",
    )
    .await;
    assert_eq!(
        dt.eval("document.getElementById('error').textContent")
            .await,
        json!(error)
    );
    stop.cancel();
}

async fn the_page_in_chromium() {
    let binary = chromium_or_fail();
    // TWINRAY_PREVIEW_URL: drive a running `twinray preview` instead (the
    // README's screenshot, saved where TWINRAY_PREVIEW_SCREENSHOT says).
    // That server is not the test's: nothing that writes a file (a
    // full-size render) is asked of it.
    let given = std::env::var("TWINRAY_PREVIEW_URL").ok();
    let stop = CancelToken::new();
    let url = match &given {
        Some(url) => url.clone(),
        None => {
            let mut spec = JobSpec::new(example(), "");
            spec.camera.size = Some([640, 360]);
            spec.sampling.samples = Some(1);
            serve(spec, 320, &stop).await.1
        }
    };

    let (_browser, mut dt) = open_page(&binary, &url).await;

    dt.wait_for(
        "!!(window.twinrayPreview && window.twinrayPreview.frames > 0)",
        "the first frame",
    )
    .await;
    dt.wait_for(FINAL_FRAME, "the full-size frame").await;
    let before = dt.eval(FRAME_PIXELS).await;
    if given.is_none() {
        assert_eq!(before["width"], 320, "{before}");
    }
    let generation = dt.eval("window.twinrayPreview.generation").await;
    let interaxial = dt.eval("window.twinrayPreview.info.rig.interaxial").await;

    // Move the interaxial slider: a click near its right end.
    let rect = dt
        .eval("(() => { const r = document.getElementById('interaxial').getBoundingClientRect(); return [r.x, r.y, r.width, r.height]; })()")
        .await;
    // Where on the slider (TWINRAY_PREVIEW_SLIDER, 0 to 1): 0.85 makes the
    // interaxial about 2.9 times the automatic one.
    let at: f64 = std::env::var("TWINRAY_PREVIEW_SLIDER")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0.85);
    let (x, y) = (
        rect[0].as_f64().unwrap() + rect[2].as_f64().unwrap() * at,
        rect[1].as_f64().unwrap() + rect[3].as_f64().unwrap() * 0.5,
    );
    for kind in ["mousePressed", "mouseReleased"] {
        dt.call(
            "Input.dispatchMouseEvent",
            json!({ "type": kind, "x": x, "y": y, "button": "left", "clickCount": 1 }),
        )
        .await;
    }
    dt.wait_for(
        &format!("window.twinrayPreview.generation > {generation}"),
        "the change to reach the server",
    )
    .await;
    dt.wait_for(FINAL_FRAME, "the new frame").await;
    let after = dt.eval(FRAME_PIXELS).await;
    assert_ne!(before, after, "the frame did not change");
    let moved = dt.eval("window.twinrayPreview.info.rig.interaxial").await;
    assert!(
        moved.as_f64().unwrap() > interaxial.as_f64().unwrap(),
        "interaxial {interaxial} -> {moved}"
    );
    assert_eq!(
        dt.eval("document.getElementById('interaxial-auto').checked")
            .await,
        json!(false)
    );
    assert_eq!(
        dt.eval("window.twinrayPreview.errors.length").await,
        json!(0)
    );

    // Orbit: a drag across the image turns the camera about its `at` point;
    // the wheel dollies it.
    let stage = dt
        .eval("(() => { const r = document.getElementById('stage').getBoundingClientRect(); return [r.x + r.width / 2, r.y + r.height / 2]; })()")
        .await;
    let (cx, cy) = (stage[0].as_f64().unwrap(), stage[1].as_f64().unwrap());
    let before_orbit = dt.eval("window.twinrayPreview.info.camera").await;
    let generation = dt.eval("window.twinrayPreview.generation").await;
    dt.drag(cx, cy, 80.0).await;
    dt.wait_for(
        &format!("window.twinrayPreview.generation > {generation}"),
        "the orbit to reach the server",
    )
    .await;
    dt.wait_for(FINAL_FRAME, "the orbited frame").await;
    let orbited = dt.eval("window.twinrayPreview.info.camera").await;
    assert_eq!(
        orbited["at"], before_orbit["at"],
        "the orbit keeps its centre"
    );
    assert_ne!(
        orbited["from"], before_orbit["from"],
        "the camera did not move"
    );
    let distance = |c: &Value| {
        let (f, a) = (c["from"].as_array().unwrap(), c["at"].as_array().unwrap());
        f.iter()
            .zip(a)
            .map(|(f, a)| (f.as_f64().unwrap() - a.as_f64().unwrap()).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    assert!((distance(&orbited) - distance(&before_orbit)).abs() < 1e-3 * distance(&before_orbit));
    let shown = dt.eval("document.getElementById('from').value").await;
    assert_ne!(shown, json!(""));
    let generation = dt.eval("window.twinrayPreview.generation").await;
    dt.call(
        "Input.dispatchMouseEvent",
        json!({ "type": "mouseWheel", "x": cx, "y": cy, "deltaX": 0, "deltaY": 120 }),
    )
    .await;
    dt.wait_for(
        &format!("window.twinrayPreview.generation > {generation}"),
        "the dolly to reach the server",
    )
    .await;
    let dollied = dt.eval("window.twinrayPreview.info.camera").await;
    assert!(
        distance(&dollied) > distance(&orbited) * 1.05,
        "{dollied} {orbited}"
    );
    assert!(dt
        .eval("document.getElementById('command').value")
        .await
        .as_str()
        .unwrap()
        .contains("--from"));
    dt.wait_for(FINAL_FRAME, "the dollied frame").await;

    // Render full size: the button runs the job and offers the file (only
    // on the test's own server).
    if given.is_none() {
        dt.click("render-full").await;
        dt.wait_for(
            "document.querySelectorAll('#downloads a').length > 0",
            "the full-size render's file",
        )
        .await;
        let download = dt
            .eval("(async () => { const a = document.querySelector('#downloads a'); const r = await fetch(a.href); const b = await r.arrayBuffer(); return [a.download, r.status, b.byteLength]; })()")
            .await;
        assert_eq!(download[1], 200, "{download}");
        assert!(download[2].as_u64().unwrap() > 1000, "{download}");
    }

    // The command, copied.
    dt.click("copy").await;
    dt.wait_for(
        "document.getElementById('copy').textContent === 'Copied'",
        "the copy",
    )
    .await;

    // The controls are on the page, drawn with a size.
    let layout = dt
        .eval(r#"(() => { const out = {}; for (const id of ["frame", "interaxial", "convergence", "budget-near", "views", "layout", "samples", "fast", "histogram", "command", "render-full", "from"]) { const e = document.getElementById(id); const r = e && e.getBoundingClientRect(); out[id] = r ? [r.x, r.y, r.width, r.height] : null; } out.scale = window.devicePixelRatio; out.command = document.getElementById("command").value; return out; })()"#)
        .await;
    for (id, r) in layout.as_object().unwrap() {
        if let Some(r) = r.as_array() {
            assert!(
                r[2].as_f64().unwrap() > 0.0 && r[3].as_f64().unwrap() > 0.0,
                "{id}: {r:?}"
            );
        }
    }
    assert!(layout["command"]
        .as_str()
        .unwrap()
        .starts_with("twinray render "));

    // The screenshot, saved and inspected.
    let png = dt.screenshot("preview-page.png").await;
    if let Ok(copy) = std::env::var("TWINRAY_PREVIEW_SCREENSHOT") {
        std::fs::write(copy, &png).unwrap();
    }
    let image = image::load_from_memory(&png).unwrap().to_rgb8();
    let scale = layout["scale"].as_f64().unwrap_or(1.0);
    let region = |id: &str| {
        let r = layout[id].as_array().unwrap();
        let v: Vec<u32> = r
            .iter()
            .map(|v| (v.as_f64().unwrap() * scale) as u32)
            .collect();
        (v[0], v[1], v[2], v[3])
    };
    // Distinct colours in a rectangle of the screenshot.
    let colours = |(x, y, w, h): (u32, u32, u32, u32)| {
        let mut seen = std::collections::HashSet::new();
        for j in y..(y + h).min(image.height()) {
            for i in x..(x + w).min(image.width()) {
                seen.insert(image.get_pixel(i, j).0);
            }
        }
        seen.len()
    };
    let whole = colours((0, 0, image.width(), image.height()));
    assert!(whole > 500, "the screenshot looks blank: {whole} colours");
    let frame = colours(region("frame"));
    assert!(frame > 200, "the frame looks blank: {frame} colours");
    let histogram = colours(region("histogram"));
    assert!(
        histogram > 3,
        "the histogram is not drawn: {histogram} colours"
    );
    let slider = colours(region("interaxial"));
    assert!(
        slider > 3,
        "the interaxial slider is not drawn: {slider} colours"
    );

    // Wiggle: the page alternates the views by itself.
    if given.is_none() {
        dt.eval("(() => { const l = document.getElementById('layout'); l.value = 'wiggle'; l.dispatchEvent(new Event('change')); return true; })()")
            .await;
        dt.wait_for(
            "window.twinrayPreview.info.view === 'wiggle'",
            "the wiggle layout",
        )
        .await;
        dt.wait_for(FINAL_FRAME, "the wiggle frames").await;
        let mut shown = std::collections::HashSet::new();
        for _ in 0..10 {
            shown.insert(
                dt.eval("document.getElementById('frame').src")
                    .await
                    .to_string(),
            );
            tokio::time::sleep(Duration::from_millis(60)).await;
        }
        assert_eq!(shown.len(), 2, "wiggle showed {shown:?}");
    }
    stop.cancel();
}

/// The look-around viewer's canvas as drawn: a fingerprint of its pixels,
/// and the red, green and blue of every fourth pixel of every fourth row.
const LOOK_PIXELS: &str = r#"(() => {
  const c = document.getElementById("look");
  const d = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
  let sum = 0, weighted = 0;
  const rgb = [];
  for (let i = 0; i < d.length; i++) { sum += d[i]; weighted = (weighted + d[i] * (i % 9973)) % 1000000007; }
  for (let y = 0; y < c.height; y += 4) for (let x = 0; x < c.width; x += 4) {
    const k = (y * c.width + x) * 4; rgb.push(d[k], d[k + 1], d[k + 2]);
  }
  return { width: c.width, height: c.height, print: [sum, weighted], rgb };
})()"#;

/// The last pass of the newest change drawn in the viewer.
const LOOK_READY: &str = "(() => { const p = window.twinrayPreview; const h = p && p.lastHeader; \
     return !!h && h.generation === p.generation && h.pass + 1 === h.passes \
       && p.look.drawn === p.frames; })()";

/// The viewer drawn with its newest direction and field of view, at full
/// resolution (a drag draws at half).
const LOOK_TURNED: &str = "(() => { const l = window.twinrayPreview.look; \
     return !!l.shown && l.shown[0] === l.yaw && l.shown[1] === l.pitch && l.shown[2] === l.fov \
       && l.shown[3]; })()";

/// LOOK_PIXELS's `rgb` as numbers.
fn rgb(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// A panorama in the page: the ODS pair shown in the look-around viewer,
/// turned by a mouse drag and by a finger's, zoomed by the wheel, all in
/// the page (no change reaches the server); the anaglyph shows both eyes
/// (its red follows the left eye, its green the right); the histogram
/// marks the angular budget and the nearest and farthest points.
async fn the_panorama_viewer_in_chromium() {
    let binary = chromium_or_fail();
    let stop = CancelToken::new();
    let mut spec = JobSpec::new(example(), "");
    spec.camera.projection = twinray::rig::ProjectionName::Ods;
    spec.camera.size = Some([640, 320]);
    spec.camera.from = Some([0.0, -2.2, 1.0]);
    spec.camera.at = Some([0.0, 0.0, 0.8]);
    spec.rig.stereo = true;
    spec.sampling.samples = Some(1);
    let (_preview, url) = serve(spec, 320, &stop).await;
    let (_browser, mut dt) = open_page(&binary, &url).await;
    dt.wait_for(LOOK_READY, "the viewer's first full-size frame")
        .await;

    // The panorama's controls: the IPD and the angular budget, no
    // convergence or flat budget; the viewer instead of the flat image.
    let shown = dt
        .eval(r#"(() => { const on = (id) => { const e = document.getElementById(id); return !!e && e.offsetParent !== null && e.getBoundingClientRect().width > 0; }; return { look: on("look"), frame: on("frame"), fov: on("look-fov"), angular: on("angular-budget"), convergence: on("convergence"), budget: on("budget-near"), views: on("views"), label: document.getElementById("interaxial-label").textContent }; })()"#)
        .await;
    assert_eq!(
        shown,
        json!({ "look": true, "frame": false, "fov": true, "angular": true, "convergence": false, "budget": false, "views": false, "label": "IPD" })
    );
    let before = dt.eval(LOOK_PIXELS).await;
    assert!(
        before["width"].as_u64().unwrap() >= 320,
        "{}",
        before["width"]
    );
    let generation = dt.eval("window.twinrayPreview.generation").await;
    let changes = dt.eval("window.twinrayPreview.changes").await;

    // A mouse drag turns the view.
    let centre = dt
        .eval("(() => { const r = document.getElementById('look').getBoundingClientRect(); return [r.x + r.width / 2, r.y + r.height / 2]; })()")
        .await;
    let (cx, cy) = (centre[0].as_f64().unwrap(), centre[1].as_f64().unwrap());
    dt.drag(cx, cy, 120.0).await;
    dt.wait_for(
        "window.twinrayPreview.look.yaw < -5",
        "the drag to turn the view left",
    )
    .await;
    dt.wait_for(LOOK_TURNED, "the turned view").await;
    let turned = dt.eval(LOOK_PIXELS).await;
    eprintln!(
        "viewer: {}x{} drawn in {} ms, at half resolution while dragged in {} ms",
        turned["width"],
        turned["height"],
        dt.eval("window.twinrayPreview.look.ms").await,
        dt.eval("window.twinrayPreview.look.dragMs").await
    );
    assert_ne!(turned["print"], before["print"], "the view did not change");

    // A finger's drag: up and down.
    dt.call(
        "Emulation.setTouchEmulationEnabled",
        json!({ "enabled": true, "maxTouchPoints": 1 }),
    )
    .await;
    for (kind, dy) in [
        ("touchStart", 0.0),
        ("touchMove", 30.0),
        ("touchMove", 60.0),
    ] {
        dt.call(
            "Input.dispatchTouchEvent",
            json!({ "type": kind, "touchPoints": [{ "x": cx, "y": cy + dy }] }),
        )
        .await;
    }
    dt.call(
        "Input.dispatchTouchEvent",
        json!({ "type": "touchEnd", "touchPoints": [] }),
    )
    .await;
    dt.wait_for(
        "window.twinrayPreview.look.pitch > 5",
        "the swipe to tilt the view up",
    )
    .await;
    dt.wait_for(LOOK_TURNED, "the tilted view").await;
    let tilted = dt.eval(LOOK_PIXELS).await;
    assert_ne!(
        tilted["print"], turned["print"],
        "the swipe changed nothing"
    );

    // The wheel widens the field of view.
    dt.call(
        "Input.dispatchMouseEvent",
        json!({ "type": "mouseWheel", "x": cx, "y": cy, "deltaX": 0, "deltaY": 120 }),
    )
    .await;
    dt.wait_for("window.twinrayPreview.look.fov > 80", "the wider view")
        .await;
    assert_eq!(
        dt.eval("document.getElementById('look-fov').value").await,
        json!("83")
    );
    // All of it in the page.
    assert_eq!(
        dt.eval("window.twinrayPreview.generation").await,
        generation
    );
    assert_eq!(dt.eval("window.twinrayPreview.changes").await, changes);

    // The histogram marks the angular budget, the nearest and the farthest.
    let marks = dt.eval("window.twinrayPreview.histogramMarks").await;
    let p = dt.eval("window.twinrayPreview.info.panorama").await;
    assert_eq!(marks["budget"], p["budget_deg"], "{marks} {p}");
    assert_eq!(marks["nearest"], p["near"]["deg"], "{marks} {p}");
    assert_eq!(marks["farthest"], p["far"]["deg"], "{marks} {p}");
    let colours = dt
        .eval(r#"(() => { const c = document.getElementById("histogram"); const d = c.getContext("2d").getImageData(0, 0, c.width, c.height).data; const near = (k, r, g, b) => Math.abs(d[k] - r) < 24 && Math.abs(d[k + 1] - g) < 24 && Math.abs(d[k + 2] - b) < 24; let budget = 0, nearest = 0, bars = 0; for (let k = 0; k < d.length; k += 4) { if (near(k, 123, 216, 143)) budget++; if (near(k, 255, 207, 107)) nearest++; if (near(k, 108, 182, 255)) bars++; } return { budget, nearest, bars }; })()"#)
        .await;
    for what in ["budget", "nearest", "bars"] {
        assert!(colours[what].as_u64().unwrap() > 20, "{what}: {colours}");
    }

    // The whole panorama, as the server sent it, and back.
    let mode = |m: &str| {
        format!("(() => {{ const s = document.getElementById('look-mode'); s.value = '{m}'; s.dispatchEvent(new Event('change')); const on = (id) => document.getElementById(id).getBoundingClientRect().width > 0; return [on('frame'), on('look')]; }})()")
    };
    assert_eq!(dt.eval(&mode("whole")).await, json!([true, false]));
    let whole = dt.eval(FRAME_PIXELS).await;
    assert_eq!(whole["width"], 320, "{whole}");
    assert_eq!(whole["height"], 160, "{whole}");
    assert_eq!(dt.eval(&mode("look")).await, json!([false, true]));

    // The anaglyph shows both eyes: with a wide IPD, the viewer's red
    // follows the left eye's view, its green the right eye's.
    dt.set_control("interaxial-value", "0.3").await;
    assert!(
        dt.eval("window.twinrayPreview.info.panorama.ipd")
            .await
            .as_f64()
            .unwrap()
            > 0.29
    );
    dt.wait_for(LOOK_READY, "the wide anaglyph").await;
    let anaglyph = dt.eval(LOOK_PIXELS).await;
    dt.set_control("layout", "single").await;
    dt.wait_for(LOOK_READY, "the left eye").await;
    let left = dt.eval(LOOK_PIXELS).await;
    dt.set_control("eye", "1").await;
    dt.wait_for(LOOK_READY, "the right eye").await;
    let right = dt.eval(LOOK_PIXELS).await;
    assert_ne!(left["print"], right["print"], "the eyes are alike");
    let (a, left, right) = (rgb(&anaglyph["rgb"]), rgb(&left["rgb"]), rgb(&right["rgb"]));
    let (red_left, red_right) = (correlation(&a, 0, &left), correlation(&a, 0, &right));
    let (green_left, green_right) = (correlation(&a, 1, &left), correlation(&a, 1, &right));
    eprintln!(
        "anaglyph: red ~ left {red_left:.3}, right {red_right:.3}; green ~ left {green_left:.3}, right {green_right:.3}"
    );
    assert!(
        red_left > red_right + 0.05 && green_right > green_left + 0.05,
        "red ~ left {red_left:.3}, right {red_right:.3}; green ~ left {green_left:.3}, right {green_right:.3}"
    );
    assert_eq!(
        dt.eval("window.twinrayPreview.errors.length").await,
        json!(0)
    );

    // The screenshot, kept for a look.
    dt.screenshot("preview-panorama.png").await;
    stop.cancel();
}

/// The benchmark of `bench/preview-browser.sh`: 20 changes of interaxial
/// in the page of a running `twinray preview` (TWINRAY_PREVIEW_URL), each
/// made when the previous one's first frame is painted; prints the median
/// and 90th percentile of change -> first frame painted, as the page times
/// it (from sending the change to the animation frame after the image
/// loaded).
async fn on_screen_latency() {
    let url = std::env::var("TWINRAY_PREVIEW_URL").expect("TWINRAY_PREVIEW_URL");
    let binary = chromium().expect("chromium");
    let (_browser, mut dt) = open_page(&binary, &url).await;
    dt.wait_for(FINAL_FRAME, "the first full-size frame").await;
    let mut measured = dt
        .eval("window.twinrayPreview.latencies.length")
        .await
        .as_u64()
        .unwrap();
    let first = dt.eval("window.twinrayPreview.latencies[0]").await;
    for i in 0..20 {
        let position = 200 + 20 * (i % 10);
        dt.eval(&format!(
            "(() => {{ const s = document.getElementById('interaxial'); s.value = {position}; \
             s.dispatchEvent(new Event('input')); return true; }})()"
        ))
        .await;
        dt.wait_for(
            &format!("window.twinrayPreview.latencies.length > {measured}"),
            "the change's first frame",
        )
        .await;
        measured += 1;
    }
    let all = dt.eval("window.twinrayPreview.latencies").await;
    let mut changes: Vec<f64> = all.as_array().unwrap()[1..]
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    changes.sort_by(f64::total_cmp);
    println!(
        "on-screen: first frame {:.0} ms after the page's first change; change -> first frame painted: median {:.0} ms, p90 {:.0} ms over {} changes",
        first.as_f64().unwrap_or(f64::NAN),
        changes[changes.len() / 2],
        changes[changes.len() * 9 / 10],
        changes.len()
    );
}

/// Pages of other sites are refused, through a real browser: another local
/// server's page (another origin) tries the preview's WebSocket, a fetch
/// and a plain form post; a page loaded under a name rebound to this
/// machine (`evil.test`, mapped to 127.0.0.1 by Chromium's resolver) is
/// refused as a whole. The preview's own page still works.
async fn pages_of_other_sites_are_refused() {
    let binary = chromium_or_fail();
    let stop = CancelToken::new();
    let mut spec = JobSpec::new(example(), "");
    spec.camera.size = Some([320, 180]);
    spec.sampling.samples = Some(1);
    let (preview, url) = serve(spec.clone(), 160, &stop).await;
    let (_, other_url) = serve(spec, 160, &stop).await;
    let target = url.trim_end_matches('/').to_string();
    let port = target.rsplit(':').next().unwrap().to_string();
    let (_browser, devtools_url) =
        launch(&binary, &["--host-resolver-rules=MAP evil.test 127.0.0.1"]).await;

    // Another site's page. (It is a preview too: its own page opens a
    // session with its own server, not with this one.)
    let mut other = attach(&devtools_url, &other_url).await;
    other
        .wait_for(
            "!!(window.twinrayPreview && window.twinrayPreview.session)",
            "the other page's session",
        )
        .await;
    let refused = preview.refused();
    let attempt = format!(
        r#"(async () => {{
  const target = "{target}";
  const socket = await new Promise((done) => {{
    const s = new WebSocket(target.replace("http:", "ws:") + "/api/session");
    s.onopen = () => done("open");
    s.onerror = () => done("refused");
  }});
  // A fetch the page cannot read the answer of: the server must refuse it.
  await fetch(target + "/api/reload", {{ method: "POST", mode: "no-cors" }}).catch(() => null);
  // The plain cross-site form, posted into a frame.
  const sink = document.createElement("iframe");
  sink.name = "sink";
  document.body.appendChild(sink);
  const form = document.createElement("form");
  form.method = "POST"; form.action = target + "/api/reload"; form.target = "sink";
  document.body.appendChild(form);
  form.submit();
  return socket;
}})()"#
    );
    assert_eq!(other.eval(&attempt).await, json!("refused"));
    let start = Instant::now();
    while preview.refused() < refused + 3 {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "refused {} of the 3 requests",
            preview.refused() - refused
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    assert_eq!(
        preview.sessions(),
        0,
        "another site's page opened a session"
    );

    // DNS rebinding: the preview's port under another name.
    let mut rebound = attach(&devtools_url, &format!("http://evil.test:{port}/")).await;
    rebound
        .wait_for(
            "document.readyState === 'complete' && document.body && document.body.innerText.length > 0",
            "the rebound page",
        )
        .await;
    let text = rebound.eval("document.body.innerText").await;
    assert!(
        text.as_str().unwrap().contains("refused: Host evil.test"),
        "{text}"
    );
    let status = rebound
        .eval("fetch('/api/state').then((r) => r.status)")
        .await;
    assert_eq!(status, 403);
    assert_eq!(preview.sessions(), 0);

    // The preview's own page works: a session and its first frames.
    let mut own = attach(&devtools_url, &url).await;
    own.wait_for(FINAL_FRAME, "the own page's full-size frame")
        .await;
    assert_eq!(preview.sessions(), 1);
    assert_eq!(
        own.eval("window.twinrayPreview.errors.length").await,
        json!(0)
    );
    stop.cancel();
}

/// Runs an async test on a runtime of its own.
fn run(test: impl Future<Output = ()>) -> Result<(), Failed> {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| Failed::from(e.to_string()))?
        .block_on(test);
    Ok(())
}

fn main() -> ExitCode {
    let args = Arguments::from_args();
    // Ignored where Chromium is missing, except under CI, which installs it.
    let missing = chromium().is_none() && std::env::var("CI").as_deref() != Ok("true");
    let needs_chromium = |trial: Trial| {
        if missing {
            trial
                .with_ignored_flag(true)
                .with_kind("needs chromium: apt-get install chromium")
        } else {
            trial
        }
    };
    let tests = vec![
        needs_chromium(Trial::test("the_page_in_chromium", || {
            run(the_page_in_chromium())
        })),
        needs_chromium(Trial::test("the_panorama_viewer_in_chromium", || {
            run(the_panorama_viewer_in_chromium())
        })),
        needs_chromium(Trial::test(
            "a_scene_that_fails_to_load_shows_its_error_on_the_page",
            || run(a_scene_that_fails_to_load_shows_its_error_on_the_page()),
        )),
        needs_chromium(Trial::test("pages_of_other_sites_are_refused", || {
            run(pages_of_other_sites_are_refused())
        })),
        Trial::test("on_screen_latency", || run(on_screen_latency()))
            .with_ignored_flag(true)
            .with_kind("benchmark: bench/preview-browser.sh runs it"),
    ];
    libtest_mimic::run(&args, tests).exit_code()
}
