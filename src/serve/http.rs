//! The HTTP side of `refrakt serve` (axum on tokio): the page's own files, built into the
//! binary, and one WebSocket endpoint. Nothing else is served: no file of the disk, no listing.
//!
//! Each upgrade to a WebSocket is checked ([`check_upgrade`]):
//! - **Token**: bound beyond loopback, the server made a random token and printed it in the
//!   page's URL; an upgrade without it is refused.
//! - **Host**: bound to loopback, the `Host` must be a loopback name or address, so a web page
//!   whose own name resolves to 127.0.0.1 (DNS rebinding) is refused.
//! - **Origin**: when present (browsers always send it), it must be this server's own origin, so
//!   a page from anywhere else open in the same browser cannot drive the renderer.
//!
//! Messages are bounded in size ([`MAX_MESSAGE_BYTES`]) and rate ([`Bucket`]); each is merged
//! into the session's state at once (newest wins), so a flood never queues work.

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::Result;
use axum::Router;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Query, State};
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use serde::Deserialize;
use serde_json::json;

use super::protocol::{ClientMessage, MAX_MESSAGE_BYTES};
use super::{Event, Shared};

const INDEX_HTML: &str = include_str!("../../web/index.html");
const APP_JS: &str = include_str!("../../web/app.js");
const STYLE_CSS: &str = include_str!("../../web/style.css");

/// Messages a page may send per second, on average…
const RATE: f64 = 1000.0;
/// …and in one burst.
const BURST: f64 = 2000.0;

/// Serves until the session stops (run on a thread of its own).
pub fn serve(listener: std::net::TcpListener, shared: Arc<Shared>) -> Result<()> {
    let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(2).thread_name("refrakt-http").enable_all().build()?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::from_std(listener)?;
        let stopped = {
            let shared = shared.clone();
            async move { stopped(&shared).await }
        };
        axum::serve(listener, router(shared)).with_graceful_shutdown(stopped).await?;
        Ok(())
    })
}

async fn stopped(shared: &Shared) {
    while !shared.stop.load(Ordering::SeqCst) {
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

fn router(shared: Arc<Shared>) -> Router {
    Router::new()
        .route("/", get(|| async { asset("text/html; charset=utf-8", INDEX_HTML) }))
        .route("/app.js", get(|| async { asset("text/javascript; charset=utf-8", APP_JS) }))
        .route("/style.css", get(|| async { asset("text/css; charset=utf-8", STYLE_CSS) }))
        .route("/ws", get(upgrade))
        .fallback(|| async { (StatusCode::NOT_FOUND, "refrakt serve has only its page: /") })
        .with_state(shared)
}

fn asset(kind: &'static str, body: &'static str) -> Response {
    ([(header::CONTENT_TYPE, kind), (header::CACHE_CONTROL, "no-cache")], body).into_response()
}

#[derive(Deserialize)]
struct WsQuery {
    token: Option<String>,
}

async fn upgrade(State(shared): State<Arc<Shared>>, Query(q): Query<WsQuery>, headers: HeaderMap, ws: WebSocketUpgrade) -> Response {
    if let Err(why) = check_upgrade(&headers, q.token.as_deref(), shared.token.as_deref()) {
        tracing::warn!("refused a WebSocket: {why}");
        return (StatusCode::FORBIDDEN, why).into_response();
    }
    ws.max_message_size(MAX_MESSAGE_BYTES).max_frame_size(MAX_MESSAGE_BYTES).on_upgrade(move |socket| connection(socket, shared))
}

/// Whether an upgrade may go ahead (see the module's notes); the reason when not.
pub fn check_upgrade(headers: &HeaderMap, token: Option<&str>, expected: Option<&str>) -> Result<(), &'static str> {
    let text = |name| headers.get(name).and_then(|v| v.to_str().ok());
    if let Some(expected) = expected
        && !token.is_some_and(|t| constant_time_eq(t.as_bytes(), expected.as_bytes()))
    {
        return Err("the access token is missing or wrong (use the URL refrakt serve printed)");
    }
    let host = text(header::HOST).ok_or("no Host header")?;
    if expected.is_none() && !is_loopback_host(host) {
        return Err("this server listens on loopback only; the Host is not a loopback name");
    }
    match text(header::ORIGIN) {
        Some(origin) if !origin.eq_ignore_ascii_case(&format!("http://{host}")) => Err("the Origin is not this server's page"),
        _ => Ok(()),
    }
}

fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// `localhost`, `127.x.y.z` or `[::1]`, with or without a port.
fn is_loopback_host(host: &str) -> bool {
    let name = match host.strip_prefix('[') {
        Some(rest) => rest.split(']').next().unwrap_or(""),
        None => host.rsplit_once(':').map_or(host, |(name, _)| name),
    };
    name.eq_ignore_ascii_case("localhost") || name.parse::<std::net::IpAddr>().is_ok_and(|ip| ip.is_loopback())
}

/// A token bucket: `BURST` messages at once, `RATE` a second after that.
pub struct Bucket {
    tokens: f64,
    last: Instant,
}

impl Bucket {
    pub fn new() -> Self {
        Self { tokens: BURST, last: Instant::now() }
    }

    /// Whether one more message may be taken now.
    pub fn take(&mut self) -> bool {
        let now = Instant::now();
        self.tokens = (self.tokens + RATE * (now - self.last).as_secs_f64()).min(BURST);
        self.last = now;
        if self.tokens < 1.0 {
            return false;
        }
        self.tokens -= 1.0;
        true
    }
}

impl Default for Bucket {
    fn default() -> Self {
        Self::new()
    }
}

fn text_message(event: &Event) -> Message {
    match event {
        Event::Text(t) => Message::text(t.to_string()),
        Event::Binary(b) => Message::binary(b.clone()),
    }
}

/// One page's connection: sends it the newest frame and the events; merges its messages into
/// the session. Ends (freeing what it holds) when the page goes or the server stops.
async fn connection(mut socket: WebSocket, shared: Arc<Shared>) {
    let mut frames = shared.frames.subscribe();
    let mut events = shared.events.subscribe();
    let greeting: Vec<Event> = [&shared.scene, &shared.error].iter().filter_map(|m| m.lock().unwrap_or_else(|e| e.into_inner()).clone()).collect();
    for event in &greeting {
        if socket.send(text_message(event)).await.is_err() {
            return;
        }
    }
    frames.mark_changed(); // the newest frame, if there is one, goes first
    let mut bucket = Bucket::new();
    let mut warned = false;
    let mut tick = tokio::time::interval(Duration::from_millis(200));
    loop {
        // Biased, in this order: an event (rare: a scene load, an error) goes before the frame
        // that follows it, and a flood of incoming messages cannot starve the frames.
        let outgoing = tokio::select! {
            biased;
            event = events.recv() => match event {
                Ok(event) => Some(text_message(&event)),
                Err(tokio::sync::broadcast::error::RecvError::Lagged(_)) => None,
                Err(_) => return,
            },
            changed = frames.changed() => match changed {
                Ok(()) => frames.borrow_and_update().clone().map(Message::binary),
                Err(_) => return,
            },
            incoming = socket.recv() => match incoming {
                Some(Ok(Message::Text(text))) if bucket.take() => take_message(&text, &shared).map(|e| Message::text(e.to_string())),
                Some(Ok(Message::Text(_))) if !std::mem::replace(&mut warned, true) => {
                    Some(Message::text(json!({ "type": "warning", "message": "too many messages: some were dropped" }).to_string()))
                }
                Some(Ok(Message::Close(_))) | Some(Err(_)) | None => return,
                Some(Ok(_)) => None,
            },
            _ = tick.tick() => shared.stop.load(Ordering::SeqCst).then_some(Message::Close(None)),
        };
        let closing = matches!(outgoing, Some(Message::Close(_)));
        if let Some(message) = outgoing
            && (socket.send(message).await.is_err() || closing)
        {
            return;
        }
    }
}

/// Merges one page message into the session; a message that cannot be taken gets an answer.
fn take_message(text: &str, shared: &Shared) -> Option<serde_json::Value> {
    let message: ClientMessage = match serde_json::from_str(text) {
        Ok(m) => m,
        Err(e) => return Some(json!({ "type": "warning", "message": format!("a message the server does not understand: {e}") })),
    };
    if let Err(e) = message.check() {
        return Some(json!({ "type": "warning", "message": e }));
    }
    apply(message, shared);
    None
}

/// Puts a checked message into the session's state.
pub fn apply(message: ClientMessage, shared: &Shared) {
    let mark = |s: &mut super::ViewState, id: u64| {
        if id != 0 {
            s.input = id;
        }
    };
    match message {
        ClientMessage::Camera { id, camera } => shared.view.update(|s| {
            s.camera = camera;
            mark(s, id)
        }),
        ClientMessage::Light { id, name, edit, reset } => shared.view.update(|s| {
            if reset {
                s.lights.remove(&name);
            } else {
                let e = s.lights.entry(name).or_default();
                e.position = edit.position.or(e.position);
                e.direction = edit.direction.or(e.direction);
                e.intensity = edit.intensity.or(e.intensity);
                e.color = edit.color.or(e.color);
            }
            mark(s, id)
        }),
        ClientMessage::Param { id, name, value } => shared.view.update(|s| {
            s.params.insert(name, value);
            mark(s, id)
        }),
        ClientMessage::Time { id, time } => shared.view.update(|s| {
            s.time = time;
            mark(s, id)
        }),
        ClientMessage::Display { id, display } => {
            let all = display.layer.needs_all_layers();
            if shared.view.peek().all_layers != all || id != 0 {
                shared.view.update(|s| {
                    s.all_layers = all;
                    mark(s, id)
                });
            }
            shared.encoder.update(|i| i.display = display);
        }
        ClientMessage::Hdr => shared.encoder.update(|i| i.hdr_requests += 1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use axum::http::HeaderValue;

    fn headers(host: &str, origin: Option<&str>) -> HeaderMap {
        let mut h = HeaderMap::new();
        h.insert(header::HOST, HeaderValue::from_str(host).unwrap());
        if let Some(o) = origin {
            h.insert(header::ORIGIN, HeaderValue::from_str(o).unwrap());
        }
        h
    }

    #[test]
    fn loopback_takes_its_own_page_and_refuses_other_origins_and_rebound_names() {
        assert!(check_upgrade(&headers("127.0.0.1:8080", Some("http://127.0.0.1:8080")), None, None).is_ok());
        assert!(check_upgrade(&headers("localhost:8080", Some("http://localhost:8080")), None, None).is_ok());
        assert!(check_upgrade(&headers("[::1]:8080", Some("http://[::1]:8080")), None, None).is_ok());
        assert!(check_upgrade(&headers("127.0.0.1:8080", None), None, None).is_ok(), "a client that is not a browser");
        assert!(check_upgrade(&headers("127.0.0.1:8080", Some("http://evil.example")), None, None).is_err());
        assert!(check_upgrade(&headers("127.0.0.1:8080", Some("http://127.0.0.1:9999")), None, None).is_err());
        assert!(check_upgrade(&headers("evil.example:8080", Some("http://evil.example:8080")), None, None).is_err());
    }

    #[test]
    fn beyond_loopback_the_token_is_required() {
        let h = headers("10.0.0.5:8080", Some("http://10.0.0.5:8080"));
        assert!(check_upgrade(&h, Some("abc123"), Some("abc123")).is_ok());
        assert!(check_upgrade(&h, Some("abc124"), Some("abc123")).is_err());
        assert!(check_upgrade(&h, None, Some("abc123")).is_err());
        let elsewhere = headers("10.0.0.5:8080", Some("http://evil.example"));
        assert!(check_upgrade(&elsewhere, Some("abc123"), Some("abc123")).is_err());
    }

    #[test]
    fn the_bucket_allows_a_burst_then_its_rate() {
        let mut b = Bucket::new();
        let taken = (0..3 * BURST as usize).filter(|_| b.take()).count();
        assert!(taken >= BURST as usize && taken < BURST as usize + 100, "{taken}");
    }
}
