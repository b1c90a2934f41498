//! Progress of a multi-frame render: a bar on a terminal, one line per frame otherwise, or
//! JSON lines on stdout for programs (the Blender add-on):
//!
//! ```text
//! {"event":"start","frames":48,"first":1,"last":48}
//! {"event":"frame","frame":1,"done":1,"total":48,"seconds":0.41,"files":["out/scene.0001.exr"]}
//! {"event":"frame","frame":9,"done":2,"total":48,"seconds":0.43,"files":[…],"gpu":1}
//! {"event":"skip","frame":2,"done":2,"total":48}
//! {"event":"done","frames":47,"skipped":1,"seconds":19.6}
//! {"event":"error","message":"scene.lua:12: …","frame":3}
//! ```
//!
//! A frame's `seconds` is the time since the previous frame's files were in place (since the
//! start for the first): frames are pipelined (one is evaluated while the GPU renders the one
//! before), so times measured from each frame's own start would overlap; these add up to the
//! total (per renderer with `--gpus`, whose frame events say which renderer, `gpu`, the index
//! in `--gpus`, wrote them). `done` of the last event counts skipped frames; `frames` of `done` does not.
//!
//! `refrakt watch` adds `{"event":"watching","files":[…],"shaders":…}` and writes `frame` events
//! with `quality` and `stats` (see `watch::FrameEvent`); its errors do not end the process.

use std::io::{IsTerminal, Write};
use std::path::PathBuf;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum ProgressMode {
    /// A bar on a terminal, lines otherwise.
    #[default]
    Auto,
    Bar,
    Lines,
    Json,
    Quiet,
}

pub struct Progress {
    mode: ProgressMode,
    bar: Option<indicatif::ProgressBar>,
    total: u64,
    /// Frames rendered or skipped so far.
    done: u64,
    skipped: u64,
    /// Seconds the last frame took (for the time left of the next one).
    last_frame: Option<f64>,
}

fn json_line(value: serde_json::Value) {
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "{value}");
    let _ = out.flush();
}

impl Progress {
    pub fn new(mode: ProgressMode) -> Self {
        let mode = match mode {
            ProgressMode::Auto if std::io::stderr().is_terminal() => ProgressMode::Bar,
            ProgressMode::Auto => ProgressMode::Lines,
            m => m,
        };
        Self { mode, bar: None, total: 0, done: 0, skipped: 0, last_frame: None }
    }

    pub fn start(&mut self, first: i64, last: i64) {
        self.total = (last - first + 1) as u64;
        match self.mode {
            ProgressMode::Bar => {
                let bar = indicatif::ProgressBar::new(self.total);
                if let Ok(style) = indicatif::ProgressStyle::with_template("{spinner} frame {pos}/{len} [{bar:32}] {elapsed} (eta {eta}) {msg}") {
                    bar.set_style(style.progress_chars("=> "));
                }
                // The spinner and clock move while a frame renders, which takes a minute on a
                // CPU driver; the message says which part of the frame the GPU is on.
                bar.enable_steady_tick(std::time::Duration::from_millis(120));
                self.bar = Some(bar);
            }
            ProgressMode::Json => json_line(serde_json::json!({"event": "start", "frames": self.total, "first": first, "last": last})),
            _ => {}
        }
    }

    /// Where the frame in flight is (a bar's message only: lines and JSON stay one per frame).
    pub fn within_frame(&mut self, frame: Option<i64>, p: &crate::pipeline::parts::FrameProgress) {
        if let Some(b) = &self.bar {
            b.set_message(crate::pipeline::parts::progress_line(frame, p, self.last_frame));
        }
    }

    /// Frame `frame` is written (by renderer `gpu` of `--gpus`, when there are several).
    pub fn frame(&mut self, frame: i64, seconds: f64, files: &[PathBuf], gpu: Option<usize>) {
        self.done += 1;
        self.last_frame = Some(seconds);
        let names: Vec<String> = files.iter().map(|p| p.display().to_string()).collect();
        match self.mode {
            ProgressMode::Bar => {
                if let Some(b) = &self.bar {
                    b.set_message(format!("{seconds:.2} s/frame"));
                    b.inc(1);
                }
            }
            ProgressMode::Lines => {
                let on = gpu.map_or(String::new(), |g| format!(" on GPU {g}"));
                eprintln!("frame {frame} ({}/{}){on}, {seconds:.2} s after the last: {}", self.done, self.total, names.join(", "))
            }
            ProgressMode::Json => {
                let mut event = serde_json::json!({
                    "event": "frame", "frame": frame, "done": self.done, "total": self.total,
                    "seconds": seconds, "files": names,
                });
                if let Some(g) = gpu {
                    event["gpu"] = g.into();
                }
                json_line(event)
            }
            ProgressMode::Quiet | ProgressMode::Auto => {}
        }
    }

    pub fn skip(&mut self, frame: i64) {
        self.done += 1;
        self.skipped += 1;
        match self.mode {
            ProgressMode::Bar => {
                if let Some(b) = &self.bar {
                    b.inc(1);
                }
            }
            ProgressMode::Lines => eprintln!("frame {frame} ({}/{}) exists, skipped", self.done, self.total),
            ProgressMode::Json => json_line(serde_json::json!({"event": "skip", "frame": frame, "done": self.done, "total": self.total})),
            _ => {}
        }
    }

    pub fn finish(&mut self, seconds: f64) {
        let rendered = self.done - self.skipped;
        let summary = match self.skipped {
            0 => format!("rendered {rendered} frame(s) in {seconds:.2} s"),
            n => format!("rendered {rendered} frame(s) in {seconds:.2} s; skipped {n} whose files exist"),
        };
        match self.mode {
            ProgressMode::Bar => {
                if let Some(b) = self.bar.take() {
                    b.finish_and_clear();
                }
                eprintln!("{summary}");
            }
            ProgressMode::Lines => eprintln!("{summary}"),
            ProgressMode::Json => {
                json_line(serde_json::json!({"event": "done", "frames": rendered, "skipped": self.skipped, "seconds": seconds}))
            }
            _ => {}
        }
    }

    /// A frame that the caller describes (`refrakt watch`): `event` as a JSON line, or `line`
    /// on stderr.
    pub fn frame_note(&mut self, event: serde_json::Value, line: &str) {
        self.done += 1;
        self.note(event, line);
    }

    /// Any other news: `event` as a JSON line, or `line` on stderr.
    pub fn note(&mut self, event: serde_json::Value, line: &str) {
        match self.mode {
            ProgressMode::Json => json_line(event),
            ProgressMode::Quiet => {}
            _ => eprintln!("{line}"),
        }
    }

    /// Reports a failure (the caller also returns the error, which main prints).
    pub fn error(&mut self, message: &str, frame: Option<i64>) {
        if let Some(b) = self.bar.take() {
            b.abandon();
        }
        if self.mode == ProgressMode::Json {
            json_line(serde_json::json!({"event": "error", "message": message, "frame": frame}));
        }
    }
}
