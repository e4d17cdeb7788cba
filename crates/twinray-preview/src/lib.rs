//! `twinray preview`: a local web server and one page to set a stereo rig by
//! eye. The page renders progressively (1/8, 1/4, 1/2 and full size with one
//! ray per pixel, then the job's anti-aliasing), shows the disparities
//! against the depth budget, the window violations and the rig's numbers,
//! and gives the `twinray render` command that reproduces the view, or runs
//! it at full size for download.
//!
//! Every render is a [`twinray::job`]: the page's settings become a
//! [`JobSpec`] over the command line's (`settings.rs`), checked by the
//! library with the command line's messages, planned on the one scene
//! loaded at start, and rendered by the session of the page's WebSocket
//! (`session.rs`). The HTTP API:
//!
//! | request | does |
//! |---|---|
//! | `GET /`, `/app.js`, `/app.css` | the page (in the binary) |
//! | `GET /api/state` | the scene, its load error, the first settings, the projection, the sizes |
//! | `GET /api/session` | WebSocket: `hello` with the session's id, then frames |
//! | `POST /api/session/{id}/view` | new settings: 200 with the rig, report and command; 4xx with the message |
//! | `POST /api/session/{id}/render` | the view at full size: the files to download |
//! | `GET /api/download/{render}/{file}` | one of them |
//! | `POST /api/reload` | reads the scene file again |
//!
//! A panorama (`--projection`) is shown in the page's look-around viewer,
//! its rig the IPD and the angular budget (`settings.rs`, `info.rs`).
//!
//! Only the server's own page may use it (`guard.rs`: `Host` and `Origin`).
//! Session and render ids are 128 random bits (`ids.rs`). At most
//! [`MAX_PAGES`] pages are open at once, each WebSocket takes messages of
//! at most [`MAX_PAGE_MESSAGE`] bytes, and the newest
//! [`renders::KEPT_RENDERS`] full-size renders are kept for download.

pub mod guard;
pub mod ids;
pub mod info;
pub mod renders;
pub mod session;
pub mod settings;

use std::collections::HashMap;
use std::future::IntoFuture;
use std::net::SocketAddr;
use std::path::{Path as FsPath, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, RwLock};
use std::time::{Duration, Instant};

use axum::extract::rejection::JsonRejection;
use axum::extract::ws::{Message as WsMessage, WebSocket, WebSocketUpgrade};
use axum::extract::{Path, State};
use axum::http::{header, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::{Json, Router};
use futures_util::{SinkExt, StreamExt};
use serde::Serialize;
use serde_json::json;
use tokio::net::TcpListener;
use tokio::sync::{mpsc, OwnedSemaphorePermit, Semaphore};
use tower_http::validate_request::ValidateRequestHeaderLayer;

use twinray::job::{CancelToken, Job, JobSpec, Loaded, Message};
use twinray::rig::ProjectionName;
use twinray_args::ToArgs;

use guard::Guard;
use info::{Info, Note};
use renders::{file_name_of, Renders};
use session::{Counts, Outgoing, Prepared, Session};
use settings::{Refused, Settings};

/// Widest preview image by default, pixels per view.
pub const DEFAULT_PREVIEW_WIDTH: u32 = 480;

/// Pages open at once (each a WebSocket, a render thread and a queue of
/// frames); the next is refused with 503 until one closes.
pub const MAX_PAGES: usize = 8;

/// Largest message a page's WebSocket takes, bytes. The page sends its
/// settings over HTTP and nothing over the socket.
pub const MAX_PAGE_MESSAGE: usize = 4096;

/// Messages queued for a page: frames wait here while the socket sends.
const PAGE_QUEUE: usize = 4;

/// How long a stopping server waits for its renders to see their
/// cancellation before it returns regardless.
const STOP_WAIT: Duration = Duration::from_millis(500);

/// The page, served from the binary.
const INDEX_HTML: &str = include_str!("page/index.html");
const APP_JS: &str = include_str!("page/app.js");
const APP_CSS: &str = include_str!("page/app.css");

/// The scene, or why it could not be read.
enum SceneState {
    Loaded {
        loaded: Arc<Loaded>,
        messages: Vec<Message>,
    },
    Failed(String),
}

struct App {
    /// The command line's spec: the page's settings are laid over it.
    base: JobSpec,
    initial: Settings,
    preview_width: u32,
    pool: Arc<rayon::ThreadPool>,
    scene: RwLock<SceneState>,
    sessions: Mutex<HashMap<String, Arc<Session>>>,
    /// One permit per page open.
    pages: Arc<Semaphore>,
    /// The full-size renders kept for download.
    renders: Renders,
    counts: Arc<Counts>,
    /// Requests refused by the guard.
    refused: Arc<AtomicU64>,
    /// The preview jobs' nominal output and the full-size renders' files.
    dir: tempfile::TempDir,
}

/// A preview server for one scene (clones share it).
#[derive(Clone)]
pub struct Preview {
    app: Arc<App>,
}

/// An error answer: a status and `{"error": message}`.
fn refuse(status: StatusCode, message: impl Into<String>) -> Response {
    (status, Json(json!({ "error": message.into() }))).into_response()
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Preview {
    /// Checks the command line's spec (its errors are the command line's)
    /// and reads the scene. A scene that cannot be read is not an error
    /// here: the server runs and shows why ([`Preview::load_error`]).
    pub fn new(base: JobSpec, preview_width: u32) -> twinray::Result<Preview> {
        let initial = Settings::from_spec(&base);
        let pool = Arc::new(
            rayon::ThreadPoolBuilder::new()
                .num_threads(base.trace.threads.unwrap_or(0))
                .stack_size(8 << 20)
                .thread_name(|i| format!("preview-worker-{i}"))
                .build()
                .map_err(|e| {
                    twinray::Error::Invalid(format!("cannot start worker threads: {e}"))
                })?,
        );
        let dir = tempfile::Builder::new()
            .prefix("twinray-preview-")
            .tempdir()
            .map_err(|source| twinray::Error::Io {
                path: std::env::temp_dir(),
                source,
            })?;
        let app = App {
            base,
            initial,
            preview_width: preview_width.max(8),
            pool,
            scene: RwLock::new(SceneState::Failed("not loaded yet".into())),
            sessions: Mutex::new(HashMap::new()),
            pages: Arc::new(Semaphore::new(MAX_PAGES)),
            renders: Renders::default(),
            counts: Arc::default(),
            refused: Arc::default(),
            dir,
        };
        // The flags, as the page's first settings will use them.
        app.full_job(&app.initial)?;
        let state = app.load();
        *app.scene.write().unwrap_or_else(|e| e.into_inner()) = state;
        Ok(Preview { app: Arc::new(app) })
    }

    /// Why the scene could not be read, in one line.
    pub fn load_error(&self) -> Option<String> {
        match &*self.app.scene.read().unwrap_or_else(|e| e.into_inner()) {
            SceneState::Failed(e) => Some(e.clone()),
            SceneState::Loaded { .. } => None,
        }
    }

    /// The notes and warnings of loading the scene.
    pub fn load_messages(&self) -> Vec<Message> {
        match &*self.app.scene.read().unwrap_or_else(|e| e.into_inner()) {
            SceneState::Loaded { messages, .. } => messages.clone(),
            SceneState::Failed(_) => Vec::new(),
        }
    }

    /// The HTTP API and the page, for a server listening on `address`
    /// (the addresses its requests must name).
    pub fn router(&self, address: SocketAddr) -> Router {
        let guard = Guard::new(address, Arc::clone(&self.app.refused));
        Router::new()
            .route("/", get(index))
            .route("/app.js", get(app_js))
            .route("/app.css", get(app_css))
            .route("/api/state", get(state))
            .route("/api/session", get(open_session))
            .route("/api/session/{id}/view", post(change))
            .route("/api/session/{id}/render", post(render_full))
            .route("/api/download/{render}/{file}", get(download))
            .route("/api/reload", post(reload))
            .with_state(Arc::clone(&self.app))
            .layer(ValidateRequestHeaderLayer::custom(guard))
    }

    /// Sessions open (pages connected).
    pub fn sessions(&self) -> usize {
        lock(&self.app.sessions).len()
    }

    /// Whether any session is rendering (for the tests).
    pub fn rendering(&self) -> bool {
        lock(&self.app.sessions).values().any(|s| s.is_busy())
    }

    /// Renders finished and cancelled so far, all sessions together.
    pub fn render_counts(&self) -> (u64, u64) {
        let c = &self.app.counts;
        (
            c.finished.load(Ordering::Relaxed),
            c.cancelled.load(Ordering::Relaxed),
        )
    }

    /// Full-size renders finished and cancelled so far.
    pub fn full_render_counts(&self) -> (u64, u64) {
        let c = &self.app.counts;
        (
            c.full_finished.load(Ordering::Relaxed),
            c.full_cancelled.load(Ordering::Relaxed),
        )
    }

    /// Requests refused because they did not come from the server's page.
    pub fn refused(&self) -> u64 {
        self.app.refused.load(Ordering::Relaxed)
    }

    /// The folder of the full-size renders' files (removed when the
    /// server stops).
    pub fn render_folder(&self) -> &FsPath {
        self.app.dir.path()
    }

    /// The ids of the full-size renders kept for download, oldest first.
    pub fn kept_renders(&self) -> Vec<String> {
        self.app.renders.ids()
    }

    /// Sessions' render threads still running.
    pub fn render_threads(&self) -> u64 {
        self.app.counts.threads.load(Ordering::SeqCst)
    }

    /// Serves on `listener` until `shutdown` is raised; then every session
    /// is closed (its renders cancelled) and the full-size renders' files
    /// are deleted.
    pub async fn serve(self, listener: TcpListener, shutdown: CancelToken) -> std::io::Result<()> {
        let router = self.router(listener.local_addr()?);
        let server = axum::serve(listener, router).into_future();
        let stop = async {
            while !shutdown.is_cancelled() {
                tokio::time::sleep(Duration::from_millis(20)).await;
            }
        };
        let result = tokio::select! {
            r = server => r,
            _ = stop => Ok(()),
        };
        self.stop();
        result
    }

    /// Closes every session (their renders are cancelled) and deletes the
    /// full-size renders' files.
    fn stop(&self) {
        let sessions: Vec<_> = lock(&self.app.sessions).drain().map(|(_, s)| s).collect();
        for session in sessions {
            session.close();
        }
        self.app.renders.remove_all();
    }
}

/// Serves `preview` on `addr` on a runtime of its own, calling `ready` with
/// the address bound (port 0: a free port), until `shutdown` is raised.
pub fn run(
    preview: Preview,
    addr: SocketAddr,
    ready: impl FnOnce(SocketAddr),
    shutdown: CancelToken,
) -> std::io::Result<()> {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?;
    let result = runtime.block_on(async move {
        let listener = TcpListener::bind(addr).await?;
        ready(listener.local_addr()?);
        preview.serve(listener, shutdown).await
    });
    // The renders were cancelled: a render that has not yet seen it is not
    // waited for past STOP_WAIT (dropping the runtime would wait for it).
    runtime.shutdown_timeout(STOP_WAIT);
    result
}

/// Opens `url` in the desktop's browser.
pub fn open_in_browser(url: &str) -> std::io::Result<()> {
    open::that_detached(url)
}

impl App {
    fn load(&self) -> SceneState {
        let loading = self
            .full_job(&self.initial)
            .and_then(|job| Ok((job.load()?, job)));
        match loading {
            Ok((loaded, job)) => {
                let messages = [job.messages(), &loaded.messages].concat();
                SceneState::Loaded {
                    loaded: Arc::new(loaded),
                    messages,
                }
            }
            Err(e) => SceneState::Failed(e.to_string()),
        }
    }

    fn loaded(&self) -> Result<Arc<Loaded>, String> {
        match &*self.scene.read().unwrap_or_else(|e| e.into_inner()) {
            SceneState::Loaded { loaded, .. } => Ok(Arc::clone(loaded)),
            SceneState::Failed(e) => Err(e.clone()),
        }
    }

    fn session(&self, id: &str) -> Option<Arc<Session>> {
        lock(&self.sessions).get(id).cloned()
    }

    /// The file name of full-size renders (`-o`'s, or the scene's stem).
    fn output_name(&self) -> PathBuf {
        settings::output_name(&self.base.scene, &self.base.output.path)
    }

    /// The job of `settings` at full size, writing `-o` (or SCENE.png).
    fn full_job(&self, settings: &Settings) -> twinray::Result<Job> {
        let spec = settings.spec(&self.base, self.base.camera.size, &self.output_name());
        Job::check_in(spec, Arc::clone(&self.pool))
    }

    /// The preview's size for a full size: at most `preview_width` wide,
    /// the same shape.
    fn preview_size(&self, (w, h): (u32, u32)) -> [u32; 2] {
        if w <= self.preview_width {
            return [w, h];
        }
        let height = (f64::from(h) * f64::from(self.preview_width) / f64::from(w)).round();
        [self.preview_width, (height as u32).max(1)]
    }
}

async fn index() -> impl IntoResponse {
    (
        [(header::CONTENT_TYPE, "text/html; charset=utf-8")],
        INDEX_HTML,
    )
}

async fn app_js() -> impl IntoResponse {
    (
        [(header::CONTENT_TYPE, "text/javascript; charset=utf-8")],
        APP_JS,
    )
}

async fn app_css() -> impl IntoResponse {
    ([(header::CONTENT_TYPE, "text/css; charset=utf-8")], APP_CSS)
}

#[derive(Serialize)]
struct StateAnswer {
    scene: String,
    error: Option<String>,
    settings: Settings,
    /// `pinhole`, or the panorama the page shows in its look-around viewer.
    projection: ProjectionName,
    messages: Vec<Note>,
    /// Size of a full render and of the preview, `[width, height]`.
    full_size: Option<[u32; 2]>,
    preview_size: Option<[u32; 2]>,
    /// Pages that may be open at once.
    max_pages: usize,
    version: &'static str,
}

fn state_answer(app: &App) -> StateAnswer {
    let (error, messages, sizes) = match &*app.scene.read().unwrap_or_else(|e| e.into_inner()) {
        SceneState::Loaded { loaded, messages } => {
            let sizes = app
                .full_job(&app.initial)
                .and_then(|job| job.image_size(loaded))
                .ok()
                .map(|(w, h)| ([w, h], app.preview_size((w, h))));
            (None, info::notes(messages), sizes)
        }
        SceneState::Failed(e) => (Some(e.clone()), Vec::new(), None),
    };
    StateAnswer {
        scene: app.base.scene.display().to_string(),
        error,
        settings: app.initial.clone(),
        projection: app.base.camera.projection,
        messages,
        full_size: sizes.map(|s| s.0),
        preview_size: sizes.map(|s| s.1),
        max_pages: MAX_PAGES,
        version: env!("CARGO_PKG_VERSION"),
    }
}

async fn state(State(app): State<Arc<App>>) -> Json<StateAnswer> {
    Json(state_answer(&app))
}

async fn reload(State(app): State<Arc<App>>) -> Response {
    let worker = Arc::clone(&app);
    match tokio::task::spawn_blocking(move || worker.load()).await {
        Ok(state) => {
            if let SceneState::Failed(e) = &state {
                eprintln!("twinray: {e}");
            }
            *app.scene.write().unwrap_or_else(|e| e.into_inner()) = state;
            Json(state_answer(&app)).into_response()
        }
        Err(e) => refuse(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()),
    }
}

/// A random id for a `what`, or the answer saying why there is none.
fn new_id(what: &str) -> Result<String, Box<Response>> {
    ids::random_id().map_err(|e| {
        Box::new(refuse(
            StatusCode::INTERNAL_SERVER_ERROR,
            format!("no random id for the {what}: {e}"),
        ))
    })
}

async fn open_session(State(app): State<Arc<App>>, ws: WebSocketUpgrade) -> Response {
    let Ok(page) = Arc::clone(&app.pages).try_acquire_owned() else {
        return refuse(
            StatusCode::SERVICE_UNAVAILABLE,
            format!("{MAX_PAGES} pages are open: close one to open another"),
        );
    };
    let id = match new_id("page") {
        Ok(id) => id,
        Err(answer) => return *answer,
    };
    ws.max_message_size(MAX_PAGE_MESSAGE)
        .max_frame_size(MAX_PAGE_MESSAGE)
        .on_upgrade(move |socket| run_session(app, socket, id, page))
}

/// A page's WebSocket: frames out until the page goes away, then the
/// session is closed and its renders cancelled; `_page` is its place among
/// the pages open, given back then.
async fn run_session(app: Arc<App>, socket: WebSocket, id: String, _page: OwnedSemaphorePermit) {
    let (tx, mut rx) = mpsc::channel::<Outgoing>(PAGE_QUEUE);
    let session = Session::start(id.clone(), tx, Arc::clone(&app.counts));
    lock(&app.sessions).insert(id.clone(), Arc::clone(&session));
    let (mut sink, mut stream) = socket.split();
    let hello = json!({ "type": "hello", "session": id }).to_string();
    if sink.send(WsMessage::Text(hello.into())).await.is_ok() {
        loop {
            tokio::select! {
                incoming = stream.next() => match incoming {
                    None | Some(Err(_)) | Some(Ok(WsMessage::Close(_))) => break,
                    Some(Ok(_)) => {}
                },
                outgoing = rx.recv() => {
                    let message = match outgoing {
                        // Frames of a change since replaced are not sent.
                        Some(Outgoing::Frame { generation, .. }) if generation < session.accepted() => continue,
                        Some(Outgoing::Frame { bytes, .. }) => WsMessage::Binary(bytes.into()),
                        Some(Outgoing::Text(text)) => WsMessage::Text(text.into()),
                        None => break,
                    };
                    if sink.send(message).await.is_err() {
                        break;
                    }
                }
            }
        }
    }
    session.close();
    lock(&app.sessions).remove(&id);
}

/// The settings of a request, or the answer refusing them.
fn settings_of(
    base: &JobSpec,
    body: Result<Json<Settings>, JsonRejection>,
) -> Result<Settings, Box<Response>> {
    let settings = match body {
        Ok(Json(s)) => s,
        Err(rejection) => {
            return Err(Box::new(refuse(
                StatusCode::BAD_REQUEST,
                format!("bad settings: {}", rejection.body_text()),
            )))
        }
    };
    settings
        .check(base)
        .map_err(|Refused(m)| Box::new(refuse(StatusCode::BAD_REQUEST, m)))?;
    Ok(settings)
}

/// What a change or a full-size render needs: the settings, checked as far
/// as the page can get them wrong, the page's session and the scene; or
/// the answer that refuses the request.
fn change_request(
    app: &App,
    id: &str,
    body: Result<Json<Settings>, JsonRejection>,
) -> Result<(Settings, Arc<Session>, Arc<Loaded>), Box<Response>> {
    let settings = settings_of(&app.base, body)?;
    let Some(session) = app.session(id) else {
        return Err(Box::new(refuse(
            StatusCode::NOT_FOUND,
            "no such session: the page has closed (reload it)",
        )));
    };
    let loaded = app
        .loaded()
        .map_err(|e| Box::new(refuse(StatusCode::CONFLICT, e)))?;
    Ok((settings, session, loaded))
}

/// New settings from the page: checked (the command line's messages),
/// planned, answered with the rig and report, and rendered by the session.
async fn change(
    State(app): State<Arc<App>>,
    Path(id): Path<String>,
    body: Result<Json<Settings>, JsonRejection>,
) -> Response {
    let received = Instant::now();
    let (settings, session, loaded) = match change_request(&app, &id, body) {
        Ok(r) => r,
        Err(answer) => return *answer,
    };
    // Checked before the render in flight is stopped: a refused value
    // leaves it running.
    let checked = app.full_job(&settings).and_then(|full| {
        let size = full.image_size(&loaded)?;
        let spec = settings.spec(
            &app.base,
            Some(app.preview_size(size)),
            &app.dir.path().join("preview.png"),
        );
        Ok((full, size, Job::check_in(spec, Arc::clone(&app.pool))?))
    });
    let (full, full_size, job) = match checked {
        Ok(c) => c,
        Err(e) => return refuse(StatusCode::BAD_REQUEST, e.to_string()),
    };
    let generation = session.begin_change();
    let worker = Arc::clone(&session);
    let planned = tokio::task::spawn_blocking(move || -> twinray::Result<Info> {
        let plan = job.plan(&loaded)?;
        let view = settings.view;
        let info = Info {
            generation,
            width: plan.width,
            height: plan.height,
            views: plan.rig.views.len(),
            view,
            frame: info::frame_layout(job.spec(), view, &plan),
            passes: job.progressive_passes(plan.width).len(),
            camera: info::camera_numbers(&job, &loaded, full_size)?,
            rig: info::rig_numbers(&plan),
            report: plan.settled.as_ref().map(|s| s.report.clone()),
            histogram: plan.settled.as_ref().map(|s| s.histogram.clone()),
            projection: job.spec().camera.projection,
            panorama: plan.panorama.as_ref().map(info::panorama_numbers),
            messages: info::notes(job.messages().iter().chain(&plan.messages)),
            command: info::command_line(&full.spec().to_args()),
            plan_ms: received.elapsed().as_secs_f64() * 1e3,
        };
        worker.submit(Arc::new(Prepared {
            generation,
            job,
            plan,
            loaded,
            received,
        }));
        Ok(info)
    })
    .await;
    match planned {
        Ok(Ok(info)) => Json(info).into_response(),
        Ok(Err(e)) => {
            session.resume();
            refuse(StatusCode::BAD_REQUEST, e.to_string())
        }
        Err(e) => {
            session.resume();
            refuse(StatusCode::INTERNAL_SERVER_ERROR, e.to_string())
        }
    }
}

#[derive(Serialize)]
struct RenderedFile {
    name: String,
    url: String,
    bytes: u64,
}

/// The page's view at full size, with the command line's sampling: the
/// files, offered for download. Cancelled if the page goes away or the
/// request is dropped; one at a time per page.
async fn render_full(
    State(app): State<Arc<App>>,
    Path(id): Path<String>,
    body: Result<Json<Settings>, JsonRejection>,
) -> Response {
    let (settings, session, loaded) = match change_request(&app, &id, body) {
        Ok(r) => r,
        Err(answer) => return *answer,
    };
    let Some(full) = session.begin_full() else {
        return refuse(
            StatusCode::CONFLICT,
            "a full-size render of this page is running: wait for it",
        );
    };
    let render = match new_id("render") {
        Ok(id) => id,
        Err(answer) => return *answer,
    };
    let dir = app.dir.path().join(&render);
    if let Err(e) = std::fs::create_dir(&dir) {
        return refuse(StatusCode::INTERNAL_SERVER_ERROR, e.to_string());
    }
    // The folder goes with the request unless its files are kept.
    let mut folder = RenderFolder(Some(dir.clone()));
    let name = app.output_name();
    let file_name = name.file_name().map(PathBuf::from).unwrap_or(name.clone());
    let spec = settings.spec(&app.base, app.base.camera.size, &dir.join(file_name));
    // The command shown names the output as the user gave it, not the
    // server's directory.
    let command = info::command_line(
        &settings
            .spec(&app.base, app.base.camera.size, &name)
            .to_args(),
    );
    let job = match Job::check_in(spec, Arc::clone(&app.pool)) {
        Ok(j) => j,
        Err(e) => return refuse(StatusCode::BAD_REQUEST, e.to_string()),
    };
    let worker = Arc::clone(&session);
    let cancel = full.cancel.clone();
    let start = Instant::now();
    let done = tokio::task::spawn_blocking(move || {
        let plan = job.plan(&loaded)?;
        let last = Mutex::new(Instant::now());
        let progress = |done: u64, total: u64| {
            let mut last = lock(&last);
            if last.elapsed() >= Duration::from_millis(200) {
                *last = Instant::now();
                worker.notify(json!({ "type": "full-progress", "done": done, "total": total }));
            }
        };
        let rendered = job.render(&plan, &progress, &cancel)?;
        if cancel.is_cancelled() {
            return Err(twinray::Error::Cancelled);
        }
        let written = job.write(&loaded, &plan, &rendered)?;
        let messages = [job.messages(), &plan.messages, &rendered.messages].concat();
        Ok::<_, twinray::Error>((written, messages))
    })
    .await;
    let (written, messages) = match done {
        Ok(Ok(w)) => {
            full.ended(&Ok(()));
            w
        }
        Ok(Err(e)) => {
            let message = e.to_string();
            full.ended(&Err(e));
            return refuse(StatusCode::BAD_REQUEST, message);
        }
        Err(e) => return refuse(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()),
    };
    let files = written
        .iter()
        .map(|p| {
            let name = file_name_of(p);
            RenderedFile {
                url: format!("/api/download/{render}/{name}"),
                bytes: std::fs::metadata(p).map(|m| m.len()).unwrap_or(0),
                name,
            }
        })
        .collect::<Vec<_>>();
    folder.0 = None;
    app.renders.keep(render, dir, written);
    Json(json!({
        "files": files,
        "command": command,
        "seconds": start.elapsed().as_secs_f64(),
        "messages": info::notes(&messages),
    }))
    .into_response()
}

/// A full-size render's folder, deleted when dropped unless its files were
/// kept (`None`).
struct RenderFolder(Option<PathBuf>);

impl Drop for RenderFolder {
    fn drop(&mut self) {
        if let Some(dir) = &self.0 {
            renders::remove(dir);
        }
    }
}

/// A file of a full-size render kept, by name (only the files it wrote).
async fn download(
    State(app): State<Arc<App>>,
    Path((render, file)): Path<(String, String)>,
) -> Response {
    let Some(path) = app.renders.file(&render, &file) else {
        return refuse(
            StatusCode::NOT_FOUND,
            "no such file: only the newest full-size renders are kept",
        );
    };
    let reading = path.clone();
    match tokio::task::spawn_blocking(move || std::fs::read(reading)).await {
        Ok(Ok(bytes)) => {
            let kind = match path.extension().and_then(|e| e.to_str()) {
                Some("png") => "image/png",
                Some("jpg" | "jpeg" | "mpo") => "image/jpeg",
                Some("json") => "application/json",
                _ => "application/octet-stream",
            };
            let disposition = format!("attachment; filename=\"{}\"", file.replace('"', ""));
            (
                [
                    (header::CONTENT_TYPE, kind.to_string()),
                    (header::CONTENT_DISPOSITION, disposition),
                ],
                bytes,
            )
                .into_response()
        }
        Ok(Err(e)) => refuse(StatusCode::NOT_FOUND, e.to_string()),
        Err(e) => refuse(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()),
    }
}
