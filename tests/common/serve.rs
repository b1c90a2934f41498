//! `refrakt serve` driven as a page drives it: the real binary on a free port, a WebSocket
//! client (tokio-tungstenite), messages and frames as the protocol has them.

use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use futures_util::{SinkExt, StreamExt};
use serde_json::Value;
use tokio::net::TcpStream;
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::tungstenite::client::IntoClientRequest;
use tokio_tungstenite::{MaybeTlsStream, WebSocketStream};

pub use super::watch::PATIENCE;

/// A running `refrakt serve`.
pub struct Server {
    pub child: Child,
    pub url: String,
    pub port: u16,
}

impl Server {
    /// Starts `refrakt serve SCENE --port 0 …` and waits for the URL it prints.
    pub fn start(scene: &Path, extra: &[&str]) -> Self {
        let mut child = Command::new(env!("CARGO_BIN_EXE_refrakt"))
            .args(["serve", scene.to_str().unwrap(), "--port", "0", "--debounce", "50"])
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("refrakt runs");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
        let event: Value = serde_json::from_str(&line).unwrap_or_else(|e| panic!("not JSON ({e}): {line:?}"));
        assert_eq!(event["event"], "serving", "{event}");
        Self { url: event["url"].as_str().unwrap().to_string(), port: event["port"].as_u64().unwrap() as u16, child }
    }

    /// The WebSocket URL of the page's connection (with the page's token, if any).
    pub fn ws_url(&self) -> String {
        let token = self.url.split_once("?token=").map(|(_, t)| format!("?token={t}")).unwrap_or_default();
        format!("ws://127.0.0.1:{}/ws{token}", self.port)
    }

    /// The server's resident memory, KiB.
    pub fn rss_kib(&self) -> u64 {
        let status = std::fs::read_to_string(format!("/proc/{}/status", self.child.id())).unwrap();
        let line = status.lines().find(|l| l.starts_with("VmRSS:")).unwrap();
        line.split_whitespace().nth(1).unwrap().parse().unwrap()
    }

    /// The status line of a plain HTTP GET of `path`.
    pub fn get_status(&self, path: &str) -> String {
        let mut s = std::net::TcpStream::connect(("127.0.0.1", self.port)).unwrap();
        write!(s, "GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{}\r\nConnection: close\r\n\r\n", self.port).unwrap();
        let mut text = String::new();
        s.read_to_string(&mut text).unwrap();
        text.lines().next().unwrap_or_default().to_string()
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// What the server sent.
#[derive(Debug)]
pub enum Received {
    Event(Value),
    Frame { header: Value, payload: Vec<u8> },
}

/// A WebSocket client, with its own runtime so tests stay synchronous.
pub struct Client {
    rt: tokio::runtime::Runtime,
    ws: WebSocketStream<MaybeTlsStream<TcpStream>>,
    /// Everything received so far, for failure messages.
    pub seen: Vec<String>,
    /// Messages a wait passed over, offered to the next waits first (the server may send an
    /// event and a frame in either order).
    skipped: std::collections::VecDeque<Received>,
}

impl Client {
    /// Connects with these extra headers (e.g. an Origin); the server's refusal as an error.
    pub fn connect_with(url: &str, headers: &[(&str, &str)]) -> Result<Client, String> {
        let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
        let mut request = url.into_client_request().unwrap();
        for (k, v) in headers {
            let name: tokio_tungstenite::tungstenite::http::HeaderName = k.parse().unwrap();
            request.headers_mut().insert(name, v.parse().unwrap());
        }
        let ws = rt.block_on(tokio_tungstenite::connect_async(request)).map_err(|e| e.to_string())?.0;
        Ok(Client { rt, ws, seen: Vec::new(), skipped: Default::default() })
    }

    pub fn connect(server: &Server) -> Client {
        Self::connect_with(&server.ws_url(), &[]).unwrap_or_else(|e| panic!("connect: {e}"))
    }

    pub fn send(&mut self, message: Value) {
        self.rt.block_on(self.ws.send(Message::text(message.to_string()))).unwrap();
    }

    /// Sends many messages in one go (one flush).
    pub fn send_all(&mut self, messages: impl IntoIterator<Item = Value>) {
        self.rt.block_on(async {
            for m in messages {
                self.ws.feed(Message::text(m.to_string())).await.unwrap();
            }
            self.ws.flush().await.unwrap();
        });
    }

    /// The next message, or `None` after `timeout`.
    pub fn next_within(&mut self, timeout: Duration) -> Option<Received> {
        loop {
            let message = self.rt.block_on(async { tokio::time::timeout(timeout, self.ws.next()).await }).ok()??.unwrap();
            match message {
                Message::Text(t) => {
                    self.seen.push(t.to_string());
                    return Some(Received::Event(serde_json::from_str(&t).unwrap()));
                }
                Message::Binary(b) => {
                    let (header, payload) = refrakt::serve::protocol::split_frame_message(&b).expect("a frame message");
                    self.seen.push(header.to_string());
                    return Some(Received::Frame { header, payload: payload.to_vec() });
                }
                _ => continue,
            }
        }
    }

    /// Waits for a message `want` accepts, first among those earlier waits passed over (the
    /// others are kept for later waits); panics after [`PATIENCE`].
    pub fn wait_for<T>(&mut self, what: &str, mut want: impl FnMut(&Received) -> Option<T>) -> T {
        let earlier = std::mem::take(&mut self.skipped);
        let mut found = None;
        for r in earlier {
            match found.is_none().then(|| want(&r)).flatten() {
                Some(t) => found = Some(t),
                None => self.skipped.push_back(r),
            }
        }
        if let Some(t) = found {
            return t;
        }
        let until = Instant::now() + PATIENCE;
        while let Some(left) = until.checked_duration_since(Instant::now()) {
            if let Some(r) = self.next_within(left) {
                match want(&r) {
                    Some(t) => return t,
                    None => self.skipped.push_back(r),
                }
            }
        }
        panic!("no {what} within {PATIENCE:?}; received:\n{}", self.seen.join("\n"));
    }

    /// Drops the messages earlier waits passed over.
    pub fn forget_skipped(&mut self) {
        self.skipped.clear();
    }

    /// The next event of this type.
    pub fn event(&mut self, kind: &str) -> Value {
        self.wait_for(kind, |r| match r {
            Received::Event(e) if e["type"] == kind => Some(e.clone()),
            _ => None,
        })
    }

    /// The next frame of this kind (`jpeg`, `hdr`) whose header `accept`s.
    pub fn frame(&mut self, kind: &str, accept: impl Fn(&Value) -> bool) -> (Value, Vec<u8>) {
        self.wait_for(kind, |r| match r {
            Received::Frame { header, payload } if header["kind"] == kind && accept(header) => Some((header.clone(), payload.clone())),
            _ => None,
        })
    }
}

/// A `jpeg` frame message's picture: its strips decoded and stacked.
pub fn picture(header: &Value, payload: &[u8]) -> image::RgbImage {
    let (w, h) = (header["width"].as_u64().unwrap() as u32, header["height"].as_u64().unwrap() as u32);
    let mut out = image::RgbImage::new(w, h);
    let mut offset = 0;
    for s in header["strips"].as_array().expect("strips") {
        let [y, rows, len] = [0, 1, 2].map(|i| s[i].as_u64().unwrap() as u32);
        let strip = image::load_from_memory_with_format(&payload[offset..offset + len as usize], image::ImageFormat::Jpeg).expect("a JPEG strip").to_rgb8();
        assert_eq!((strip.width(), strip.height()), (w, rows), "strip at row {y}");
        image::imageops::replace(&mut out, &strip, 0, y as i64);
        offset += len as usize;
    }
    assert_eq!(offset, payload.len(), "the strips fill the payload");
    out
}
