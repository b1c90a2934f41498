//! `refrakt serve`: one long-lived renderer, driven from a web page over a WebSocket.
//!
//! Three parts, joined by "latest state wins" slots ([`slot::Slot`]) so that nothing queues:
//!
//! - **HTTP + WebSocket** ([`http`], axum on tokio): serves the page (static files built into
//!   the binary, `web/`), checks each WebSocket upgrade (Origin, Host, token), and merges each
//!   page message into the session's one truth ([`state::Truth`]), which every page is sent
//!   whole on connect and after each change: pages stay in step with each other and the frame.
//! - **Renderer thread** ([`session`]): owns the GPU; takes the newest view state, renders it
//!   with the renderer's stage reuse, reloads the scene on saves as `refrakt watch` does, and
//!   while nothing changes refines the still view, sample by sample.
//! - **Encoder thread** ([`encode`]): takes the newest rendered image and display settings,
//!   encodes a JPEG and publishes it; every connection sends the newest one it has not sent.
//!   A display change (exposure, tone mapping, layer) re-encodes without rendering.

pub mod encode;
pub mod http;
pub mod protocol;
pub mod session;
pub mod slot;
pub mod state;

use std::net::{IpAddr, SocketAddr};
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize};
use std::sync::{Arc, Mutex};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result};
use axum::body::Bytes;
use serde_json::{Value, json};
use tokio::sync::{broadcast, watch};

use crate::output::Image;
use crate::pipeline::reuse::Reuse;
use crate::render::SceneOptions;
use protocol::{ClientMessage, Display, FrameHeader, FrameTimes, SceneInfo, ViewState, frame_message};
use slot::{Slot, Taken};
use state::{PageState, Truth};

/// Everything `refrakt serve` was asked to do.
#[derive(Clone, Debug)]
pub struct ServeOptions {
    pub scene: SceneOptions,
    pub bind: IpAddr,
    /// 0: any free port (the URL printed says which).
    pub port: u16,
    pub adapter: Option<String>,
    pub debounce: Duration,
    /// The scene clock's start, seconds.
    pub time: f64,
    pub display: Display,
    /// Camera rays per pixel a still view refines to (0: it does not refine)…
    pub refine: u32,
    /// …for at most this long after the last change.
    pub refine_for: Duration,
    /// The page's public origins behind a proxy (`https://render.example`): taken as its own.
    pub origins: Vec<String>,
}

/// Pages connected at once, at most.
pub const MAX_CONNECTIONS: usize = 32;

/// `{"type": kind, …fields}` as text.
fn message_text(kind: &str, mut fields: Value) -> Arc<str> {
    fields["type"] = json!(kind);
    fields.to_string().into()
}

/// A message for every connected page.
#[derive(Clone, Debug)]
pub enum Event {
    Text(Arc<str>),
    Binary(Bytes),
}

impl Event {
    /// `{"type": kind, …fields}`.
    pub fn text(kind: &str, fields: Value) -> Event {
        Event::Text(message_text(kind, fields))
    }
}

/// A frame as the renderer left it for the encoder.
pub struct Rendered {
    pub image: Image,
    pub frame: u64,
    pub input: u64,
    pub revision: u64,
    /// Camera rays per pixel the image averages.
    pub samples: u32,
    pub time: f64,
    pub reused: Reuse,
    pub times: FrameTimes,
}

/// What the encoder thread reads: the newest frame and how to show it.
#[derive(Clone, Default)]
pub struct EncoderInbox {
    pub frame: Option<Arc<Rendered>>,
    pub display: Display,
}

/// What the renderer is doing, for the pages' busy indicator.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Activity {
    pub busy: bool,
    /// The part of the frame the GPU is on: `volume`, `photons`, `view`.
    pub stage: Option<&'static str>,
    /// Whether the frame refines a still view (rather than showing an edit).
    pub refining: bool,
    /// Milliseconds the frame has taken so far, and the time the last frame of its kind took.
    pub elapsed_ms: f64,
    pub eta_ms: Option<f64>,
    /// Camera rays per pixel of the newest frame, and what a still view refines to.
    pub samples: u32,
    pub target: u32,
}

/// What the server's threads share.
pub struct Shared {
    pub view: Slot<ViewState>,
    pub encoder: Slot<EncoderInbox>,
    /// The one truth: what every page shows.
    pub truth: Mutex<Truth>,
    /// The truth as the pages are told it (a `state` message, JSON), and the renderer's activity
    /// (an `activity` message): the newest of each goes to every page.
    pub state: watch::Sender<Arc<str>>,
    pub activity: watch::Sender<Arc<str>>,
    /// The frame the newest JPEG shows, and how: what HDR requests read.
    pub shown: Mutex<Option<(Arc<Rendered>, Display)>>,
    /// The scene as last loaded.
    pub info: Mutex<Option<SceneInfo>>,
    /// Numbers the connections, and counts those open.
    pub connections: AtomicU64,
    pub open: AtomicUsize,
    /// Messages all pages together may send (besides each page's own allowance).
    pub bucket: Mutex<http::Bucket>,
    /// The newest encoded frame message (JPEG).
    pub frames: watch::Sender<Option<Bytes>>,
    /// Scene loads, errors, HDR answers: small and rare; a page that falls behind skips some.
    pub events: broadcast::Sender<Event>,
    /// The newest `scene` and `error` events, for pages that connect later.
    pub scene: Mutex<Option<Event>>,
    pub error: Mutex<Option<Event>>,
    pub stop: AtomicBool,
    /// When set (`--bind` beyond loopback), WebSocket upgrades must carry `?token=`.
    pub token: Option<String>,
    /// `ServeOptions::origins`.
    pub origins: Vec<String>,
    /// `ServeOptions::refine`: what a still view refines to (the pages say so).
    pub refine: u32,
}

impl Shared {
    pub fn new(state: PageState, token: Option<String>, origins: Vec<String>, refine: u32) -> Self {
        let truth = Truth::new(state);
        Self {
            view: Slot::new(truth.state.view(0, 0)),
            encoder: Slot::new(EncoderInbox { display: truth.state.display, ..Default::default() }),
            state: watch::Sender::new(state_text(&truth)),
            activity: watch::Sender::new(message_text("activity", json!(Activity::default()))),
            truth: Mutex::new(truth),
            shown: Mutex::new(None),
            info: Mutex::new(None),
            connections: AtomicU64::new(0),
            open: AtomicUsize::new(0),
            bucket: Mutex::new(http::Bucket::new(http::SERVER_RATE, http::SERVER_BURST)),
            frames: watch::Sender::new(None),
            events: broadcast::Sender::new(16),
            scene: Mutex::new(None),
            error: Mutex::new(None),
            stop: AtomicBool::new(false),
            token,
            origins,
            refine,
        }
    }

    pub fn send_event(&self, event: Event) {
        let _ = self.events.send(event); // no page connected: nobody to tell
    }

    /// Tells the pages of an error (kept for pages that connect later); `kept`: the last good
    /// frame stays on screen.
    pub fn report_error(&self, message: &str, kept: bool) {
        let event = Event::text("error", json!({ "message": message, "kept": kept }));
        *lock(&self.error) = Some(event.clone());
        self.send_event(event);
    }

    /// Tells the pages that the error is gone (a frame rendered).
    pub fn clear_error(&self) {
        *lock(&self.error) = None;
        self.send_event(Event::text("ok", json!({})));
    }

    /// A scene loaded: the pages are told of it, and edits of names it lacks are dropped.
    pub fn set_scene(&self, info: SceneInfo) {
        let event = Event::text("scene", serde_json::to_value(&info).unwrap_or_default());
        *lock(&self.scene) = Some(event.clone());
        let _ = self.events.send(event);
        let mut truth = lock(&self.truth);
        if truth.scene_loaded(&info) {
            self.publish(&truth);
        }
        *lock(&self.info) = Some(info);
    }

    /// Merges an edit from connection `by` into the truth and tells the renderer, the encoder
    /// and every page; the reason when it cannot be taken.
    pub fn edit(&self, message: &ClientMessage, by: u64) -> Result<(), String> {
        let mut truth = lock(&self.truth);
        truth.apply(message, by)?;
        self.publish(&truth);
        Ok(())
    }

    /// Passes the truth on: to the renderer when what it renders changed, to the encoder, and
    /// to the pages.
    fn publish(&self, truth: &Truth) {
        let view = truth.state.view(truth.input, truth.revision);
        // (A display change alone re-encodes the frame shown: no render.)
        let unchanged = |v: &ViewState| ViewState { revision: view.revision, ..v.clone() } == view;
        if !unchanged(&self.view.peek()) {
            self.view.update(|v| *v = view);
        }
        let display = truth.state.display;
        if self.encoder.peek().display != display {
            self.encoder.update(|i| i.display = display);
        }
        self.state.send_replace(state_text(truth));
    }

    pub fn set_activity(&self, activity: &Activity) {
        self.activity.send_replace(message_text("activity", json!(activity)));
    }

    /// The scene edits as Lua (`None` before a scene loaded).
    pub fn edits_lua(&self) -> Option<String> {
        let info = lock(&self.info);
        Some(lock(&self.truth).edits_lua(info.as_ref()?))
    }

    /// Stops both threads.
    pub fn close(&self) {
        self.stop.store(true, std::sync::atomic::Ordering::SeqCst);
        self.view.close();
        self.encoder.close();
    }
}

/// A lock that a panicked holder left whole (every update is a single assignment).
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

fn state_text(truth: &Truth) -> Arc<str> {
    message_text("state", serde_json::to_value(truth.message()).unwrap_or_default())
}


/// The encoder thread: encodes the newest frame whenever it or the display settings change;
/// stops when the slot closes.
pub fn encode_loop(shared: &Shared) {
    let mut shown = None;
    loop {
        let inbox = match shared.encoder.wait(Duration::from_secs(1)) {
            Taken::Closed => return,
            Taken::Unchanged => continue,
            Taken::Fresh(inbox) => inbox,
        };
        let Some(frame) = inbox.frame else { continue };
        // A layer the frame lacks comes with the next frame (the renderer was told).
        if !encode::has_layer(&frame.image, inbox.display.layer) {
            continue;
        }
        if shown != Some((frame.frame, inbox.display)) {
            shown = Some((frame.frame, inbox.display));
            match encode_jpeg(&frame, &inbox.display) {
                Ok(message) => {
                    *lock(&shared.shown) = Some((frame.clone(), inbox.display));
                    shared.frames.send_replace(Some(Bytes::from(message)));
                }
                Err(e) => tracing::error!("{e:#}"),
            }
        }
    }
}

/// The shown frame's layer as linear floats, of `region` (the whole frame when `None`), as a
/// binary frame message; why not, when there is none to send.
pub fn hdr_message(shared: &Shared, region: Option<[u32; 4]>) -> Result<Vec<u8>, String> {
    let (frame, display) = lock(&shared.shown).clone().ok_or("no frame is shown yet")?;
    let region = region.unwrap_or([0, 0, frame.image.width, frame.image.height]);
    let (payload, channels) = encode::hdr(&frame.image, display.layer, region).map_err(|e| format!("hdr: {e:#}"))?;
    let mut header = header(&frame, &display, "hdr", channels, frame.times.clone(), Vec::new());
    header.region = Some(region);
    Ok(frame_message(&header, &payload))
}

fn encode_jpeg(frame: &Rendered, display: &Display) -> Result<Vec<u8>> {
    let started = std::time::Instant::now();
    let (jpeg, strips) = encode::jpeg(&frame.image, display)?;
    let times = FrameTimes { encode_ms: 1e3 * started.elapsed().as_secs_f64(), ..frame.times.clone() };
    Ok(frame_message(&header(frame, display, "jpeg", 3, times, strips), &jpeg))
}

fn header(frame: &Rendered, display: &Display, kind: &'static str, channels: u32, times: FrameTimes, strips: Vec<[u32; 3]>) -> FrameHeader {
    FrameHeader {
        kind,
        frame: frame.frame,
        input: frame.input,
        width: frame.image.width,
        height: frame.image.height,
        layer: display.layer,
        channels,
        strips,
        region: None,
        samples: frame.samples,
        revision: frame.revision,
        time: frame.time,
        reused: frame.reused,
        times,
        ready_us: SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_micros() as u64),
    }
}

/// A fresh access token: 128 random bits as hex.
fn new_token() -> Result<String> {
    let mut bytes = [0u8; 16];
    getrandom::fill(&mut bytes).map_err(|e| anyhow::anyhow!("no random numbers for the access token: {e}"))?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// A running server: its address, the page's URL, and the handle that stops it.
pub struct Running {
    pub addr: SocketAddr,
    pub url: String,
    pub shared: Arc<Shared>,
    threads: Vec<std::thread::JoinHandle<Result<()>>>,
}

impl Running {
    /// Stops the server and waits for its threads; returns the renderer thread's error, if any.
    pub fn stop(mut self) -> Result<()> {
        self.shared.close();
        let mut result = Ok(());
        for t in self.threads.drain(..) {
            let r = t.join().map_err(|_| anyhow::anyhow!("a server thread panicked")).and_then(|r| r);
            result = result.and(r);
        }
        result
    }
}

/// Starts the server: binds, starts the GPU and the threads, returns once it listens.
pub fn start(scene: &Path, opts: &ServeOptions) -> Result<Running> {
    let token = if opts.bind.is_loopback() { None } else { Some(new_token()?) };
    let state = PageState { time: opts.time, display: opts.display, ..Default::default() };
    let shared = Arc::new(Shared::new(state, token, opts.origins.clone(), opts.refine));
    let listener = std::net::TcpListener::bind((opts.bind, opts.port)).with_context(|| format!("cannot listen on {}:{}", opts.bind, opts.port))?;
    listener.set_nonblocking(true)?;
    let addr = listener.local_addr()?;
    let ctx = crate::gpu::GpuContext::new(opts.adapter.as_deref())?;
    tracing::info!("adapter: {}", ctx.adapter_name());
    let library = crate::gpu::shaders::ShaderLibrary::for_development();
    let (renderer, failed) = crate::pipeline::Renderer::with_shaders_or_embedded(ctx, library)?;
    if let Some(e) = failed {
        shared.report_error(&format!("{e:#} (the shaders built in are used until a save makes these compile)"), false);
    }
    let mut threads = Vec::new();
    let (path, o, s) = (scene.to_path_buf(), opts.clone(), shared.clone());
    threads.push(std::thread::Builder::new().name("refrakt-render".into()).spawn(move || {
        let result = session::run(&path, &o, renderer, &s);
        s.close();
        result
    })?);
    let s = shared.clone();
    threads.push(std::thread::Builder::new().name("refrakt-encode".into()).spawn(move || {
        encode_loop(&s);
        Ok(())
    })?);
    let s = shared.clone();
    threads.push(std::thread::Builder::new().name("refrakt-http".into()).spawn(move || http::serve(listener, s))?);
    let host = if addr.ip().is_unspecified() { "127.0.0.1".to_string() } else { addr.ip().to_string() };
    let host = if addr.is_ipv6() && !addr.ip().is_unspecified() { format!("[{host}]") } else { host };
    let url = match &shared.token {
        Some(t) => format!("http://{host}:{}/?token={t}", addr.port()),
        None => format!("http://{host}:{}/", addr.port()),
    };
    Ok(Running { addr, url, shared, threads })
}

/// `refrakt serve` on the command line: prints the URL (a JSON line on stdout for tools, a
/// sentence on stderr for people) and serves until Ctrl-C.
pub fn run(scene: &Path, opts: &ServeOptions) -> Result<()> {
    if !scene.is_file() {
        anyhow::bail!("{}: no such scene file", scene.display());
    }
    let running = start(scene, opts)?;
    if running.shared.token.is_some() {
        eprintln!(
            "warning: refrakt serve listens on {} beyond this machine; anyone who can reach it and has the URL's token can \
             drive the renderer (the page cannot run Lua or read files)",
            running.addr
        );
    }
    println!("{}", json!({ "event": "serving", "url": running.url, "port": running.addr.port() }));
    eprintln!("refrakt serve: open {} (Ctrl-C stops)", running.url);
    while !crate::render::INTERRUPTED.load(std::sync::atomic::Ordering::SeqCst) && !running.shared.stop.load(std::sync::atomic::Ordering::SeqCst) {
        std::thread::sleep(Duration::from_millis(50));
    }
    running.stop()
}
