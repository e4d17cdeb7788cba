//! One page's connection: the renders of its settings, coarse to fine, sent
//! as frames over its WebSocket.
//!
//! Every change of settings is planned by the HTTP handler (so that a bad
//! value is refused with its message) and handed to the session's render
//! thread as a [`Prepared`] render with a new generation number. The thread
//! renders the progressive passes of the newest one only: a newer change
//! cancels the render in flight (its [`CancelToken`]), and one render at a
//! time runs per session. When the page goes away the session is closed:
//! the render in flight and its full-size render are cancelled and the
//! thread ends. A page runs one full-size render at a time.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use serde::Serialize;
use tokio::sync::mpsc;

use twinray::job::{CancelToken, Job, Loaded, Plan};
use twinray::output;
use twinray::Error;

/// A change of settings, planned and ready to render.
pub struct Prepared {
    pub generation: u64,
    pub job: Job,
    pub plan: Plan,
    pub loaded: Arc<Loaded>,
    /// When the change reached the server: frames report their latency from it.
    pub received: Instant,
}

/// What the session sends its page.
#[derive(Debug)]
pub enum Outgoing {
    /// A JSON message (progress, errors).
    Text(String),
    /// An encoded frame of `generation` (see [`frame_message`]).
    Frame { generation: u64, bytes: Vec<u8> },
}

/// The header of a frame message.
#[derive(Serialize)]
struct FrameHeader<'a> {
    generation: u64,
    /// Index of the pass, and how many the render has.
    pass: usize,
    passes: usize,
    divisor: u32,
    /// `centres` (one ray per pixel centre) or `final` (the job's sampling).
    sampling: &'a str,
    width: u32,
    height: u32,
    /// Milliseconds from the change's arrival to the frame's encoding, and
    /// of the pass's render alone.
    ms: f64,
    render_ms: f64,
    /// Byte lengths of the PNG images that follow the header.
    sizes: Vec<usize>,
}

/// A frame as one binary WebSocket message: the header's length (u32,
/// little-endian), the header (JSON), then the PNG images one after another.
fn frame_message(header: &FrameHeader, images: &[Vec<u8>]) -> Vec<u8> {
    let head = serde_json::to_vec(header).unwrap_or_default();
    let mut out = Vec::with_capacity(4 + head.len() + images.iter().map(Vec::len).sum::<usize>());
    out.extend_from_slice(&(head.len() as u32).to_le_bytes());
    out.extend_from_slice(&head);
    for image in images {
        out.extend_from_slice(image);
    }
    out
}

/// Splits a frame message into its header and images (the page's job; here
/// for the tests and the benchmark).
pub fn parse_frame(bytes: &[u8]) -> Option<(serde_json::Value, Vec<Vec<u8>>)> {
    let len = u32::from_le_bytes(bytes.get(..4)?.try_into().ok()?) as usize;
    let header: serde_json::Value = serde_json::from_slice(bytes.get(4..4 + len)?).ok()?;
    let mut at = 4 + len;
    let mut images = Vec::new();
    for size in header.get("sizes")?.as_array()? {
        let size = size.as_u64()? as usize;
        images.push(bytes.get(at..at + size)?.to_vec());
        at += size;
    }
    Some((header, images))
}

#[derive(Default)]
struct State {
    /// The newest change not yet started.
    pending: Option<Arc<Prepared>>,
    /// The render in flight: its generation and token.
    running: Option<(u64, CancelToken)>,
    /// The newest change planned (resumed after a refused change).
    last: Option<Arc<Prepared>>,
    /// Whether every pass of `last` was sent.
    last_finished: bool,
    closed: bool,
}

/// How the renders of the sessions ended, counted for the whole server.
#[derive(Debug, Default)]
pub struct Counts {
    /// Renders whose every pass was sent.
    pub finished: AtomicU64,
    /// Renders stopped by a newer change or by the page going away.
    pub cancelled: AtomicU64,
    /// Sessions' render threads running.
    pub threads: AtomicU64,
    /// Full-size renders finished, and stopped (the page gone, the request
    /// dropped or the server stopping).
    pub full_finished: AtomicU64,
    pub full_cancelled: AtomicU64,
}

/// A page's session.
pub struct Session {
    pub id: String,
    out: mpsc::Sender<Outgoing>,
    state: Mutex<State>,
    wake: Condvar,
    /// The newest generation handed out.
    generation: AtomicU64,
    /// The generation of the newest change submitted: older frames are stale.
    accepted: AtomicU64,
    /// The token of the full-size render in flight.
    full: Mutex<Option<CancelToken>>,
    counts: Arc<Counts>,
}

/// A page's full-size render in flight: its token is raised when the page
/// goes away, and when this is dropped (the request answered or abandoned).
pub struct FullRender {
    session: Arc<Session>,
    pub cancel: CancelToken,
}

impl FullRender {
    /// Counts how the render ended.
    pub fn ended(&self, result: &twinray::Result<()>) {
        let counts = &self.session.counts;
        match result {
            Ok(()) => counts.full_finished.fetch_add(1, Ordering::Relaxed),
            Err(Error::Cancelled) => counts.full_cancelled.fetch_add(1, Ordering::Relaxed),
            Err(_) => 0,
        };
    }
}

impl Drop for FullRender {
    fn drop(&mut self) {
        self.cancel.cancel();
        *self.session.full.lock().unwrap_or_else(|e| e.into_inner()) = None;
    }
}

impl Session {
    /// A session sending to `out`, with its render thread.
    pub fn start(id: String, out: mpsc::Sender<Outgoing>, counts: Arc<Counts>) -> Arc<Session> {
        let name = format!("preview-session-{}", &id[..id.len().min(8)]);
        let session = Arc::new(Session {
            id,
            out,
            state: Mutex::new(State::default()),
            wake: Condvar::new(),
            generation: AtomicU64::new(0),
            accepted: AtomicU64::new(0),
            full: Mutex::new(None),
            counts,
        });
        let worker = Arc::clone(&session);
        session.counts.threads.fetch_add(1, Ordering::SeqCst);
        let started = std::thread::Builder::new().name(name).spawn(move || {
            worker.render_loop();
            worker.counts.threads.fetch_sub(1, Ordering::SeqCst);
        });
        if let Err(e) = started {
            session.counts.threads.fetch_sub(1, Ordering::SeqCst);
            eprintln!("twinray: cannot start a render thread: {e}");
        }
        session
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        // A panic while holding the lock leaves plain data: carry on with it.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// A new generation for a change, and the render in flight cancelled:
    /// the change is planned next, with the workers to itself.
    pub fn begin_change(&self) -> u64 {
        let generation = self.generation.fetch_add(1, Ordering::SeqCst) + 1;
        if let Some((_, cancel)) = &self.lock().running {
            cancel.cancel();
        }
        generation
    }

    /// The newest generation handed out.
    pub fn generation(&self) -> u64 {
        self.generation.load(Ordering::SeqCst)
    }

    /// The generation of the newest change submitted: frames of older
    /// ones are stale.
    pub fn accepted(&self) -> u64 {
        self.accepted.load(Ordering::SeqCst)
    }

    /// Renders `prepared` next, unless a newer change came meanwhile (it is
    /// then kept in case that one is refused).
    pub fn submit(&self, prepared: Arc<Prepared>) {
        let mut state = self.lock();
        if state
            .last
            .as_ref()
            .is_some_and(|l| l.generation > prepared.generation)
        {
            return;
        }
        state.last = Some(Arc::clone(&prepared));
        state.last_finished = false;
        if prepared.generation < self.generation() {
            return;
        }
        self.accepted.store(prepared.generation, Ordering::SeqCst);
        if let Some((_, cancel)) = &state.running {
            cancel.cancel();
        }
        state.pending = Some(prepared);
        self.wake.notify_all();
    }

    /// After a refused change (whose start cancelled the render in flight):
    /// the newest change planned is rendered again, unless it had finished.
    pub fn resume(&self) {
        let mut state = self.lock();
        if state.pending.is_some() || state.last_finished {
            return;
        }
        if let Some(last) = state.last.clone() {
            self.accepted.store(last.generation, Ordering::SeqCst);
            state.pending = Some(last);
            self.wake.notify_all();
        }
    }

    /// The page went away: everything stops, the thread ends.
    pub fn close(&self) {
        let mut state = self.lock();
        state.closed = true;
        state.pending = None;
        if let Some((_, cancel)) = &state.running {
            cancel.cancel();
        }
        if let Some(full) = &*self.full.lock().unwrap_or_else(|e| e.into_inner()) {
            full.cancel();
        }
        self.wake.notify_all();
    }

    /// A full-size render for the page, unless one is in flight or the
    /// page has gone.
    pub fn begin_full(self: &Arc<Self>) -> Option<FullRender> {
        // Under the state's lock, as `close` takes it: a render begun
        // now is seen by a close that follows.
        let state = self.lock();
        let mut full = self.full.lock().unwrap_or_else(|e| e.into_inner());
        if state.closed || full.is_some() {
            return None;
        }
        let cancel = CancelToken::new();
        *full = Some(cancel.clone());
        Some(FullRender {
            session: Arc::clone(self),
            cancel,
        })
    }

    /// Whether a render is in flight or waiting (for the tests).
    pub fn is_busy(&self) -> bool {
        let state = self.lock();
        state.running.is_some() || state.pending.is_some()
    }

    /// Sends a JSON message to the page, unless its queue is full.
    pub fn notify(&self, message: serde_json::Value) {
        let _ = self.out.try_send(Outgoing::Text(message.to_string()));
    }

    fn render_loop(&self) {
        loop {
            let (work, cancel) = {
                let mut state = self.lock();
                loop {
                    if state.closed {
                        return;
                    }
                    if let Some(work) = state.pending.take() {
                        let cancel = CancelToken::new();
                        state.running = Some((work.generation, cancel.clone()));
                        break (work, cancel);
                    }
                    state = self.wake.wait(state).unwrap_or_else(|e| e.into_inner());
                }
            };
            let result = self.render_passes(&work, &cancel);
            {
                let mut state = self.lock();
                state.running = None;
                if result.is_ok() && state.last.as_ref().is_some_and(|l| Arc::ptr_eq(l, &work)) {
                    state.last_finished = true;
                }
            }
            match result {
                Ok(()) => {
                    self.counts.finished.fetch_add(1, Ordering::Relaxed);
                }
                Err(Error::Cancelled) => {
                    self.counts.cancelled.fetch_add(1, Ordering::Relaxed);
                }
                Err(e) => self.notify(serde_json::json!({
                    "type": "error",
                    "generation": work.generation,
                    "error": e.to_string(),
                })),
            }
        }
    }

    /// The passes of one change, each sent as a frame when done.
    fn render_passes(&self, work: &Prepared, cancel: &CancelToken) -> twinray::Result<()> {
        let (job, plan) = (&work.job, &work.plan);
        let passes = job.progressive_passes(plan.width);
        for (i, pass) in passes.iter().enumerate() {
            if cancel.is_cancelled() {
                return Err(Error::Cancelled);
            }
            let start = Instant::now();
            let reduced = job.reduced_plan(&work.loaded, plan, pass.divisor)?;
            let last_sent = Mutex::new(Instant::now());
            let progress = |done: u64, total: u64| {
                let mut last = last_sent.lock().unwrap_or_else(|e| e.into_inner());
                if last.elapsed() >= Duration::from_millis(150) {
                    *last = Instant::now();
                    self.notify(serde_json::json!({
                        "type": "progress", "generation": work.generation,
                        "pass": i, "done": done, "total": total,
                    }));
                }
            };
            let rendered = job.render_sampled(&reduced, pass.sampling, &progress, cancel)?;
            let render_ms = start.elapsed().as_secs_f64() * 1e3;
            let srgb = job.write_options();
            let images = job
                .compose(&reduced, &rendered)?
                .iter()
                .map(|image| output::png_bytes(image, &srgb))
                .collect::<twinray::Result<Vec<_>>>()?;
            let header = FrameHeader {
                generation: work.generation,
                pass: i,
                passes: passes.len(),
                divisor: pass.divisor,
                sampling: if pass.sampling.is_some() {
                    "centres"
                } else {
                    "final"
                },
                width: reduced.width,
                height: reduced.height,
                ms: work.received.elapsed().as_secs_f64() * 1e3,
                render_ms,
                sizes: images.iter().map(Vec::len).collect(),
            };
            let message = Outgoing::Frame {
                generation: work.generation,
                bytes: frame_message(&header, &images),
            };
            if self.out.blocking_send(message).is_err() {
                // The page is gone.
                return Err(Error::Cancelled);
            }
        }
        Ok(())
    }
}
