//! `refrakt serve`: one long-lived renderer, driven from a web page over a WebSocket.
//!
//! Three parts, joined by "latest state wins" slots ([`slot::Slot`]) so that nothing queues:
//!
//! - **HTTP + WebSocket** ([`http`], axum on tokio): serves the page (static files built into
//!   the binary, `web/`), checks each WebSocket upgrade (Origin, Host, token), and merges each
//!   page message into the session's [`ViewState`] or [`Display`].
//! - **Renderer thread** ([`session`]): owns the GPU; takes the newest view state, renders it
//!   with the renderer's stage reuse, reloads the scene on saves as `refrakt watch` does.
//! - **Encoder thread** ([`encode`]): takes the newest rendered image and display settings,
//!   encodes a JPEG and publishes it; every connection sends the newest one it has not sent.
//!   A display change (exposure, tone mapping, layer) re-encodes without rendering.

pub mod encode;
pub mod http;
pub mod protocol;
pub mod session;
pub mod slot;

use std::net::{IpAddr, SocketAddr};
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result};
use axum::body::Bytes;
use serde_json::{Value, json};
use tokio::sync::{broadcast, watch};

use crate::output::Image;
use crate::pipeline::reuse::Reuse;
use crate::render::SceneOptions;
use protocol::{Display, FrameHeader, FrameTimes, SceneInfo, ViewState, frame_message};
use slot::{Slot, Taken};

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
}

/// A message for every connected page.
#[derive(Clone, Debug)]
pub enum Event {
    Text(Arc<str>),
    Binary(Bytes),
}

impl Event {
    /// `{"type": kind, …fields}`.
    pub fn text(kind: &str, mut fields: Value) -> Event {
        fields["type"] = json!(kind);
        Event::Text(fields.to_string().into())
    }
}

/// A frame as the renderer left it for the encoder.
pub struct Rendered {
    pub image: Image,
    pub frame: u64,
    pub input: u64,
    pub time: f64,
    pub reused: Reuse,
    pub times: FrameTimes,
}

/// What the encoder thread reads: the newest frame, how to show it, and HDR requests.
#[derive(Clone, Default)]
pub struct EncoderInbox {
    pub frame: Option<Arc<Rendered>>,
    pub display: Display,
    /// Counts requests; the encoder answers each new count with the shown frame's floats.
    pub hdr_requests: u64,
}

/// What the server's threads share.
pub struct Shared {
    pub view: Slot<ViewState>,
    pub encoder: Slot<EncoderInbox>,
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
}

impl Shared {
    pub fn new(state: ViewState, display: Display, token: Option<String>) -> Self {
        Self {
            view: Slot::new(state),
            encoder: Slot::new(EncoderInbox { display, ..Default::default() }),
            frames: watch::Sender::new(None),
            events: broadcast::Sender::new(16),
            scene: Mutex::new(None),
            error: Mutex::new(None),
            stop: AtomicBool::new(false),
            token,
        }
    }

    pub fn send_event(&self, event: Event) {
        let _ = self.events.send(event); // no page connected: nobody to tell
    }

    /// Tells the pages of an error (kept for pages that connect later); `kept`: the last good
    /// frame stays on screen.
    pub fn report_error(&self, message: &str, kept: bool) {
        let event = Event::text("error", json!({ "message": message, "kept": kept }));
        *self.error.lock().unwrap_or_else(|e| e.into_inner()) = Some(event.clone());
        self.send_event(event);
    }

    /// Tells the pages that the error is gone (a frame rendered).
    pub fn clear_error(&self) {
        *self.error.lock().unwrap_or_else(|e| e.into_inner()) = None;
        self.send_event(Event::text("ok", json!({})));
    }

    pub fn set_scene(&self, info: SceneInfo) {
        let event = Event::text("scene", serde_json::to_value(info).unwrap_or_default());
        *self.scene.lock().unwrap_or_else(|e| e.into_inner()) = Some(event.clone());
        let _ = self.events.send(event);
    }

    /// Stops both threads.
    pub fn close(&self) {
        self.stop.store(true, std::sync::atomic::Ordering::SeqCst);
        self.view.close();
        self.encoder.close();
    }
}

/// The encoder thread: encodes the newest frame whenever it, the display settings or an HDR
/// request change; stops when the slot closes.
pub fn encode_loop(shared: &Shared) {
    let (mut shown, mut hdr_sent) = (None, 0);
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
                Ok(message) => drop(shared.frames.send_replace(Some(Bytes::from(message)))),
                Err(e) => tracing::error!("{e:#}"),
            }
        }
        if inbox.hdr_requests != hdr_sent {
            hdr_sent = inbox.hdr_requests;
            if let Ok((payload, channels)) = encode::hdr(&frame.image, inbox.display.layer) {
                let header = header(&frame, &inbox.display, "hdr", channels, frame.times.clone(), Vec::new());
                shared.send_event(Event::Binary(Bytes::from(frame_message(&header, &payload))));
            }
        }
    }
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
    let state = ViewState { time: opts.time, ..Default::default() };
    let shared = Arc::new(Shared::new(state, opts.display, token));
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
