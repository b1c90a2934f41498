//! The HTTP side of `refrakt serve` (axum on tokio): the page's own files, built into the
//! binary, and one WebSocket endpoint. Nothing else is served: no file of the disk, no listing.
//!
//! Each upgrade to a WebSocket is checked ([`check_upgrade`]):
//! - **Token**: bound beyond loopback, the server made a random token and printed it in the
//!   page's URL; an upgrade without it is refused.
//! - **Host**: bound to loopback, the `Host` must be a loopback name or address, so a web page
//!   whose own name resolves to 127.0.0.1 (DNS rebinding) is refused.
//! - **Origin**: when present (browsers always send it), it must be this server's own origin
//!   (`http://` or, behind a TLS proxy, `https://` and the same host), so a page from anywhere
//!   else open in the same browser cannot drive the renderer.
//!
//! Messages are bounded in size ([`MAX_MESSAGE_BYTES`]) and rate ([`Bucket`]: per page and for
//! all pages together), pages in number ([`MAX_CONNECTIONS`]); each message is merged into the
//! session's state at once (newest wins), so a flood never queues work. What answers one page
//! (a warning, HDR values) goes to that page alone. The page's own files come with a
//! Content-Security-Policy that allows nothing but themselves and the WebSocket, and may be
//! framed by no other site.

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
use super::{Event, MAX_CONNECTIONS, Shared, lock};

const INDEX_HTML: &str = include_str!("../../web/index.html");
const APP_JS: &str = include_str!("../../web/app.js");
const STYLE_CSS: &str = include_str!("../../web/style.css");
const FAVICON_SVG: &str = include_str!("../../web/favicon.svg");

/// Messages a page may send per second, on average…
const RATE: f64 = 1000.0;
/// …and in one burst.
const BURST: f64 = 2000.0;
/// Messages all pages together may send per second, and in one burst.
pub const SERVER_RATE: f64 = 4000.0;
pub const SERVER_BURST: f64 = 8000.0;
/// Warnings a page is sent per second, and in one burst (more are dropped).
const WARNING_RATE: f64 = 10.0;
const WARNING_BURST: f64 = 50.0;

/// The page's files may load only themselves and speak only to this server's WebSocket (the
/// frames are drawn from `blob:` URLs), and no other site may frame them.
const CONTENT_SECURITY_POLICY: &str = "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' blob: data:; \
     connect-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'self'";

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
        .route("/favicon.svg", get(|| async { asset("image/svg+xml", FAVICON_SVG) }))
        .route("/favicon.ico", get(|| async { asset("image/svg+xml", FAVICON_SVG) }))
        .route("/ws", get(upgrade))
        .fallback(|| async { (StatusCode::NOT_FOUND, "refrakt serve has only its page: /") })
        .with_state(shared)
}

fn asset(kind: &'static str, body: &'static str) -> Response {
    let headers = [
        (header::CONTENT_TYPE, kind),
        (header::CACHE_CONTROL, "no-cache"),
        (header::CONTENT_SECURITY_POLICY, CONTENT_SECURITY_POLICY),
        (header::X_CONTENT_TYPE_OPTIONS, "nosniff"),
        (header::REFERRER_POLICY, "no-referrer"),
    ];
    (headers, body).into_response()
}

#[derive(Deserialize)]
struct WsQuery {
    token: Option<String>,
}

async fn upgrade(State(shared): State<Arc<Shared>>, Query(q): Query<WsQuery>, headers: HeaderMap, ws: WebSocketUpgrade) -> Response {
    if let Err(why) = check_upgrade(&headers, q.token.as_deref(), shared.token.as_deref(), &shared.origins) {
        tracing::warn!("refused a WebSocket: {why}");
        return (StatusCode::FORBIDDEN, why).into_response();
    }
    if shared.open.load(Ordering::SeqCst) >= MAX_CONNECTIONS {
        return (StatusCode::SERVICE_UNAVAILABLE, format!("refrakt serve takes at most {MAX_CONNECTIONS} pages at once")).into_response();
    }
    ws.max_message_size(MAX_MESSAGE_BYTES).max_frame_size(MAX_MESSAGE_BYTES).on_upgrade(move |socket| connection(socket, shared))
}

/// Whether an upgrade may go ahead (see the module's notes); the reason when not. `origins`:
/// the page's public origins behind a proxy (`--origin`), taken as its own, Host and Origin.
pub fn check_upgrade(headers: &HeaderMap, token: Option<&str>, expected: Option<&str>, origins: &[String]) -> Result<(), &'static str> {
    let text = |name| headers.get(name).and_then(|v| v.to_str().ok());
    if let Some(expected) = expected
        && !token.is_some_and(|t| constant_time_eq(t.as_bytes(), expected.as_bytes()))
    {
        return Err("the access token is missing or wrong (use the URL refrakt serve printed)");
    }
    let host = text(header::HOST).ok_or("no Host header")?;
    let public = |host: &str| origins.iter().any(|o| o.split_once("://").is_some_and(|(_, h)| h.eq_ignore_ascii_case(host)));
    if expected.is_none() && !is_loopback_host(host) && !public(host) {
        return Err("this server listens on loopback only; the Host is not a loopback name (behind a proxy, name its origin with --origin)");
    }
    // Behind a TLS proxy that passes the Host on, the page is https:// on the same Host.
    let own = |origin: &str| {
        ["http://", "https://"].iter().any(|scheme| origin.eq_ignore_ascii_case(&format!("{scheme}{host}"))) || origins.iter().any(|o| o.eq_ignore_ascii_case(origin))
    };
    match text(header::ORIGIN) {
        Some(origin) if !own(origin) => Err("the Origin is not this server's page (behind a proxy, name its origin with --origin)"),
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

/// A token bucket: `burst` messages at once, `rate` a second after that.
pub struct Bucket {
    tokens: f64,
    rate: f64,
    burst: f64,
    last: Instant,
}

impl Bucket {
    pub fn new(rate: f64, burst: f64) -> Self {
        Self { tokens: burst, rate, burst, last: Instant::now() }
    }

    /// Whether one more message may be taken now.
    pub fn take(&mut self) -> bool {
        let now = Instant::now();
        self.tokens = (self.tokens + self.rate * (now - self.last).as_secs_f64()).min(self.burst);
        self.last = now;
        if self.tokens < 1.0 {
            return false;
        }
        self.tokens -= 1.0;
        true
    }
}

fn text_message(event: &Event) -> Message {
    match event {
        Event::Text(t) => Message::text(t.to_string()),
        Event::Binary(b) => Message::binary(b.clone()),
    }
}

/// Counts a page's connection while it is open.
struct Open<'a>(&'a Shared);

impl Drop for Open<'_> {
    fn drop(&mut self) {
        self.0.open.fetch_sub(1, Ordering::SeqCst);
    }
}

/// One page's connection: tells it who it is and the session as it stands (scene, state,
/// error, activity, the newest frame), then every change; takes its messages. Ends (freeing
/// what it holds) when the page goes or the server stops.
async fn connection(mut socket: WebSocket, shared: Arc<Shared>) {
    shared.open.fetch_add(1, Ordering::SeqCst);
    let _open = Open(&shared);
    let me = shared.connections.fetch_add(1, Ordering::SeqCst) + 1;
    let mut frames = shared.frames.subscribe();
    let mut events = shared.events.subscribe();
    let (mut state, mut activity) = (shared.state.subscribe(), shared.activity.subscribe());
    let hello = Event::text("hello", json!({ "connection": me, "refine": shared.refine }));
    let greeting: Vec<Event> = [&shared.scene, &shared.error].iter().filter_map(|m| lock(m).clone()).collect();
    for event in std::iter::once(&hello).chain(&greeting) {
        if socket.send(text_message(event)).await.is_err() {
            return;
        }
    }
    // The state, the activity and the newest frame, if there is one, go first.
    state.mark_changed();
    activity.mark_changed();
    frames.mark_changed();
    let mut page = Page { me, shared: &shared, bucket: Bucket::new(RATE, BURST), warnings: Bucket::new(WARNING_RATE, WARNING_BURST), warned: false };
    let mut tick = tokio::time::interval(Duration::from_millis(200));
    loop {
        // Biased, in this order: an event (rare: a scene load, an error) goes before the state
        // and the frame that follow it, and a flood of incoming messages cannot starve them.
        let outgoing = tokio::select! {
            biased;
            event = events.recv() => match event {
                Ok(event) => Some(text_message(&event)),
                Err(tokio::sync::broadcast::error::RecvError::Lagged(_)) => None,
                Err(_) => return,
            },
            changed = state.changed() => match changed {
                Ok(()) => Some(Message::text(state.borrow_and_update().to_string())),
                Err(_) => return,
            },
            changed = activity.changed() => match changed {
                Ok(()) => Some(Message::text(activity.borrow_and_update().to_string())),
                Err(_) => return,
            },
            changed = frames.changed() => match changed {
                Ok(()) => frames.borrow_and_update().clone().map(Message::binary),
                Err(_) => return,
            },
            incoming = socket.recv() => match incoming {
                Some(Ok(Message::Text(text))) => page.take(&text),
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

/// One page, as its connection sees it: who it is and its allowances.
struct Page<'a> {
    me: u64,
    shared: &'a Shared,
    bucket: Bucket,
    warnings: Bucket,
    /// Whether it has been told that it sends too much.
    warned: bool,
}

impl Page<'_> {
    /// Takes one message from the page; what answers it, for this page alone.
    fn take(&mut self, text: &str) -> Option<Message> {
        if !self.bucket.take() || !lock(&self.shared.bucket).take() {
            return (!std::mem::replace(&mut self.warned, true)).then(|| warning("too many messages: some were dropped"));
        }
        self.warned = false;
        let answer = match serde_json::from_str::<ClientMessage>(text) {
            Err(e) => Err(format!("a message the server does not understand: {e}")),
            Ok(message) => message.check().and_then(|()| match message {
                ClientMessage::Hdr { region } => super::hdr_message(self.shared, region).map(|m| Some(Message::binary(m))),
                ClientMessage::Lua => Ok(self.shared.edits_lua().map(|lua| Message::text(json!({ "type": "lua", "lua": lua }).to_string()))),
                message => self.shared.edit(&message, self.me).map(|()| None),
            }),
        };
        match answer {
            Ok(reply) => reply,
            Err(why) => self.warnings.take().then(|| warning(&why)),
        }
    }
}

fn warning(message: &str) -> Message {
    Message::text(json!({ "type": "warning", "message": message }).to_string())
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
        assert!(check_upgrade(&headers("127.0.0.1:8080", Some("http://127.0.0.1:8080")), None, None, &[]).is_ok());
        assert!(check_upgrade(&headers("localhost:8080", Some("http://localhost:8080")), None, None, &[]).is_ok());
        assert!(check_upgrade(&headers("[::1]:8080", Some("http://[::1]:8080")), None, None, &[]).is_ok());
        assert!(check_upgrade(&headers("127.0.0.1:8080", None), None, None, &[]).is_ok(), "a client that is not a browser");
        assert!(check_upgrade(&headers("127.0.0.1:8080", Some("http://evil.example")), None, None, &[]).is_err());
        assert!(check_upgrade(&headers("127.0.0.1:8080", Some("http://127.0.0.1:9999")), None, None, &[]).is_err());
        assert!(check_upgrade(&headers("evil.example:8080", Some("http://evil.example:8080")), None, None, &[]).is_err());
    }

    #[test]
    fn behind_a_tls_proxy_the_https_origin_of_the_same_host_is_the_page() {
        assert!(check_upgrade(&headers("localhost:8443", Some("https://localhost:8443")), None, None, &[]).is_ok());
        let h = headers("render.example:443", Some("https://render.example:443"));
        assert!(check_upgrade(&h, Some("t"), Some("t"), &[]).is_ok());
        assert!(check_upgrade(&headers("render.example:443", Some("https://evil.example")), Some("t"), Some("t"), &[]).is_err());
        assert!(check_upgrade(&headers("localhost:8443", Some("ftp://localhost:8443")), None, None, &[]).is_err());
        // A proxy that passes its own Host on to a server on loopback: named by --origin.
        let public = ["https://render.example".to_string()];
        let proxied = headers("render.example", Some("https://render.example"));
        assert!(check_upgrade(&proxied, None, None, &[]).is_err());
        assert!(check_upgrade(&proxied, None, None, &public).is_ok());
        assert!(check_upgrade(&headers("localhost:8080", Some("https://render.example")), None, None, &public).is_ok(), "a proxy that sets Host");
        assert!(check_upgrade(&headers("render.example", Some("https://evil.example")), None, None, &public).is_err());
    }

    #[test]
    fn beyond_loopback_the_token_is_required() {
        let h = headers("10.0.0.5:8080", Some("http://10.0.0.5:8080"));
        assert!(check_upgrade(&h, Some("abc123"), Some("abc123"), &[]).is_ok());
        assert!(check_upgrade(&h, Some("abc124"), Some("abc123"), &[]).is_err());
        assert!(check_upgrade(&h, None, Some("abc123"), &[]).is_err());
        let elsewhere = headers("10.0.0.5:8080", Some("http://evil.example"));
        assert!(check_upgrade(&elsewhere, Some("abc123"), Some("abc123"), &[]).is_err());
    }

    #[test]
    fn the_bucket_allows_a_burst_then_its_rate() {
        let mut b = Bucket::new(RATE, BURST);
        let taken = (0..3 * BURST as usize).filter(|_| b.take()).count();
        assert!(taken >= BURST as usize && taken < BURST as usize + 100, "{taken}");
    }
}
