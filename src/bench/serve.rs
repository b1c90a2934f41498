//! `refrakt bench --scenes serve`: frames per second that `refrakt serve` delivers to a
//! WebSocket client while the camera orbits and while a light is dragged, and where a frame's
//! time goes.
//!
//! The real server runs in-process on a free loopback port with the `seed` scene held still
//! (its clock at 0), on its own GPU device; a tokio-tungstenite client connects as the page does
//! and, for each phase, sends a move every 2 ms — faster than any frame, as a drag in a browser
//! is from the renderer's point of view — while it counts the frames that arrive. Each frame's
//! header carries the server's times (scene evaluation, render, readback, encode); delivery is
//! the time from the encoded frame being ready to the client having read it (one clock: one
//! machine); latency is from sending a move to receiving the first frame that shows it.

use std::collections::HashMap;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result, anyhow};
use futures_util::{SinkExt, StreamExt};
use serde_json::{Value, json};
use tokio_tungstenite::tungstenite::Message;

use super::{BenchOptions, SEED_DETAIL, Spread, scene_source};
use crate::render::SceneOptions;
use crate::scene::eval::EvalOptions;
use crate::serve::protocol::{Display, split_frame_message};
use crate::serve::{ServeOptions, start};

/// Not a scene of its own: `--scenes serve` measures `refrakt serve`.
pub const SERVE: &str = "serve";
/// How often the client sends a move.
const MOVE_EVERY: Duration = Duration::from_millis(2);

/// Runs both phases; `seconds` each (after a one-second warm-up).
pub fn measure(opts: &BenchOptions, eval: &EvalOptions, seconds: f64) -> Result<Value> {
    let dir = tempfile::tempdir()?;
    let (source, allow) = scene_source("seed", opts, SEED_DETAIL)?;
    let path = dir.path().join("seed.lua");
    std::fs::write(&path, source)?;
    let serve = ServeOptions {
        scene: SceneOptions::for_bench(eval, &allow),
        bind: [127, 0, 0, 1].into(),
        port: 0,
        adapter: opts.adapter.clone(),
        debounce: Duration::from_millis(10),
        time: 0.0,
        display: Display::default(),
        // Moves arrive every 2 ms: a still view never forms; refinement would only blur that.
        refine: 0,
        refine_for: Duration::ZERO,
        origins: Vec::new(),
    };
    let running = start(&path, &serve)?;
    let url = format!("ws://{}/ws", running.addr);
    let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build()?;
    let result = rt.block_on(async { phases(&url, seconds).await });
    running.stop()?;
    let mut report = result?;
    report["size"] = json!(eval.size.map(|(w, h)| [w, h]).unwrap_or([1024, 576]));
    Ok(report)
}

type Socket = tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;
type Sink = futures_util::stream::SplitSink<Socket, Message>;
type Stream = futures_util::stream::SplitStream<Socket>;

async fn phases(url: &str, seconds: f64) -> Result<Value> {
    let (ws, _) = tokio_tungstenite::connect_async(url).await.context("connecting to the server")?;
    let (mut sink, mut stream) = ws.split();
    let light = first_light(&mut stream).await?;
    let orbit = phase((&mut sink, &mut stream), seconds, 1, |i| {
        let a = 0.01 * i as f64;
        json!({ "type": "camera", "camera": { "position": [0.75 * a.sin(), 0.32, 0.75 * a.cos()], "target": [0, 0.03, 0], "fov": 35 } })
    })
    .await?;
    let drag = match &light {
        Some(name) => {
            let name = name.clone();
            let phase = phase((&mut sink, &mut stream), seconds, 10_000_000, move |i| {
                let a = 0.005 * i as f64;
                json!({ "type": "light", "name": name, "position": [0.6 * a.cos(), 0.6, 0.6 * a.sin()] })
            });
            phase.await?
        }
        None => json!({ "skipped": "the scene has no light" }),
    };
    Ok(json!({ "orbit": orbit, "light_drag": drag }))
}

/// Waits for the `scene` event and the first frame (in either order); returns the first light's
/// name.
async fn first_light(ws: &mut Stream) -> Result<Option<String>> {
    let mut light = None;
    let (mut scene_seen, mut frame_seen) = (false, false);
    while !(scene_seen && frame_seen) {
        match next(ws, Duration::from_secs(600)).await? {
            Message::Text(t) => {
                let e: Value = serde_json::from_str(&t)?;
                match e["type"].as_str() {
                    Some("scene") => {
                        scene_seen = true;
                        light = e["lights"][0]["name"].as_str().map(String::from);
                    }
                    Some("error") => return Err(anyhow!("the server: {}", e["message"])),
                    _ => {}
                }
            }
            Message::Binary(_) => frame_seen = true,
            _ => {}
        }
    }
    Ok(light)
}

async fn next(ws: &mut Stream, timeout: Duration) -> Result<Message> {
    tokio::time::timeout(timeout, ws.next())
        .await
        .map_err(|_| anyhow!("no message from the server within {timeout:?}"))?
        .ok_or_else(|| anyhow!("the server closed the connection"))?
        .map_err(Into::into)
}

fn now_us() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_micros() as u64)
}

/// Sends `message(i)` (with id `first_id + i`) every [`MOVE_EVERY`] for a warm-up second and
/// `seconds`, and measures the frames that arrive in the measured part.
async fn phase((sink, stream): (&mut Sink, &mut Stream), seconds: f64, first_id: u64, message: impl Fn(u64) -> Value) -> Result<Value> {
    let warm_up = Duration::from_secs(1);
    let length = warm_up + Duration::from_secs_f64(seconds);
    let started = Instant::now();
    let mut sent_at: HashMap<u64, Instant> = HashMap::new();
    let mut tick = tokio::time::interval(MOVE_EVERY);
    let mut i = 0u64;
    let mut frames = Vec::new();
    let mut last_frame = 0;
    while started.elapsed() < length {
        tokio::select! {
            _ = tick.tick() => {
                let mut m = message(i);
                m["id"] = json!(first_id + i);
                sent_at.insert(first_id + i, Instant::now());
                sink.send(Message::text(m.to_string())).await?;
                i += 1;
            }
            received = next(stream, Duration::from_secs(600)) => {
                if let Message::Binary(b) = received? {
                    let got = (Instant::now(), now_us());
                    let (header, _) = split_frame_message(&b).ok_or_else(|| anyhow!("a binary message that is not a frame"))?;
                    let frame = header["frame"].as_u64().unwrap_or(0);
                    if frame != last_frame && started.elapsed() > warm_up {
                        let latency = header["input"].as_u64().and_then(|id| sent_at.get(&id)).map(|t| (got.0 - *t).as_secs_f64() * 1e3);
                        frames.push((header, got.1, latency, b.len()));
                    }
                    last_frame = frame;
                }
            }
        }
    }
    Ok(summary(&frames, seconds, i))
}

fn summary(frames: &[(Value, u64, Option<f64>, usize)], seconds: f64, moves: u64) -> Value {
    let series = |f: &dyn Fn(&Value) -> Option<f64>| -> Option<Spread> {
        let v: Vec<f64> = frames.iter().filter_map(|(h, ..)| f(h)).collect();
        (!v.is_empty()).then(|| Spread::of(&v))
    };
    let times = |key: &'static str| series(&move |h: &Value| h["times"][key].as_f64());
    let delivery: Vec<f64> = frames.iter().filter_map(|(h, got, ..)| h["ready_us"].as_u64().map(|r| got.saturating_sub(r) as f64 / 1e3)).collect();
    let latency: Vec<f64> = frames.iter().filter_map(|f| f.2).collect();
    let mut gpu: HashMap<String, Vec<f64>> = HashMap::new();
    for (h, ..) in frames {
        for s in h["times"]["gpu"].as_array().into_iter().flatten() {
            if let (Some(stage), Some(ms)) = (s[0].as_str(), s[1].as_f64()) {
                gpu.entry(stage.to_string()).or_default().push(ms);
            }
        }
    }
    let reused = |key: &str| frames.iter().filter(|(h, ..)| h["reused"][key] == true).count();
    json!({
        "frames_per_second": frames.len() as f64 / seconds,
        "frames": frames.len(),
        "moves_sent": moves,
        "reused_volume": reused("volume"),
        "reused_photons": reused("photons"),
        "scene_ms": times("scene_ms"),
        "render_ms": times("render_ms"),
        "readback_ms": times("readback_ms"),
        "encode_ms": times("encode_ms"),
        "delivery_ms": (!delivery.is_empty()).then(|| Spread::of(&delivery)),
        "latency_ms": (!latency.is_empty()).then(|| Spread::of(&latency)),
        "frame_kib": frames.iter().map(|f| f.3).sum::<usize>() as f64 / 1024.0 / frames.len().max(1) as f64,
        "gpu_ms": gpu.iter().map(|(k, v)| (k.clone(), Spread::of(v))).collect::<std::collections::BTreeMap<_, _>>(),
    })
}
