//! `refrakt bench --scenes watch`: how long `refrakt watch` takes from saving an edit of the
//! default scene (examples/default.lua) to the new preview file being in place.
//!
//! The scene is copied to a temporary folder and watched in-process, on a thread of its own with
//! its own GPU device, exactly as the command line does (a real file watcher, the debounce, EXR
//! written and renamed). The script is then saved over and over the way an editor saves (write a
//! temporary file, rename it over the script), alternating two kinds of edit:
//!
//! - a camera move: the volume on the GPU is reused; only the view pass runs;
//! - an object edit (the glass ball's absorption): the volume is built again.
//!
//! Each is timed from just before the rename to the moment the preview file was renamed into
//! place: the first image (the fast frame, when there is one) and the final one; then all again
//! with `--no-progressive` (the final frame alone, which then comes sooner).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use serde_json::{Value, json};

use super::{BenchOptions, Spread, settings_json};
use crate::pipeline::{Counters, Renderer};
use crate::output::Layers;
use crate::render::{SceneOptions, SceneSource};
use crate::scene::eval::EvalOptions;
use crate::watch::{self, FrameEvent, Moment, Quality, Report, WatchOptions};

const DEFAULT_SCENE: &str = include_str!("../../examples/default.lua");
/// The lines of the default scene the edits rewrite.
const CAMERA_LINE: &str = "position = {0, 0.9, 3.1}";
const BALL_LINE: &str = "absorption = {0.4, 0.15, 0.0}";
/// Longest wait for one frame (a full-size frame on a CPU adapter takes a while).
const FRAME_TIMEOUT: Duration = Duration::from_secs(600);

/// What the watch thread tells the benchmark.
enum Heard {
    /// When the frame was in place, and how long after its change was noticed.
    Frame { at: Instant, work: f64, quality: Quality, counters: Counters },
    Error(String),
}

/// Passes the session's frames and errors to the benchmark, stamped with when they happened.
struct Relay(Sender<Heard>);

impl Report for Relay {
    fn watching(&mut self, _files: &[PathBuf], _shaders: Option<&Path>) {}

    fn frame(&mut self, f: &FrameEvent) {
        let frame = Heard::Frame { at: Instant::now(), work: f.seconds * 1e3, quality: f.quality, counters: f.stats.counters.clone() };
        let _ = self.0.send(frame);
    }

    fn error(&mut self, message: &str, _frame: Option<i64>, _kept: bool) {
        let _ = self.0.send(Heard::Error(message.to_string()));
    }
}

/// The timings of one kind of edit.
#[derive(Default)]
struct Timings {
    first_image: Vec<f64>,
    final_image: Vec<f64>,
    /// From the change being noticed (after the debounce) to the final image.
    notice_to_final: Vec<f64>,
    volume_builds: u64,
    photon_traces: u64,
}

impl Timings {
    fn json(&self) -> Value {
        json!({
            "first_image_ms": Spread::of(&self.first_image),
            "final_image_ms": Spread::of(&self.final_image),
            "notice_to_final_ms": Spread::of(&self.notice_to_final),
            "volume_builds": self.volume_builds,
            "photon_traces": self.photon_traces,
        })
    }
}

/// Measures `edits` edits of each kind, as users run `refrakt watch` (a fast frame first) and
/// with `--no-progressive`; the JSON of `bench`'s `watch_latency`.
pub fn measure(opts: &BenchOptions, eval: &EvalOptions, edits: u32) -> Result<Value> {
    for line in [CAMERA_LINE, BALL_LINE] {
        if !DEFAULT_SCENE.contains(line) {
            bail!("internal: examples/default.lua no longer contains `{line}`, which the latency benchmark edits");
        }
    }
    let progressive = session(opts, eval, edits, true)?;
    let single = session(opts, eval, edits, false)?;
    Ok(json!({
        "scene": "examples/default.lua",
        "settings": progressive.settings,
        "debounce_ms": watch::DEFAULT_DEBOUNCE.as_secs_f64() * 1e3,
        "edits": edits,
        "camera_edit": progressive.camera.json(),
        "object_edit": progressive.object.json(),
        "without_fast_frame": { "camera_edit": single.camera.json(), "object_edit": single.object.json() },
    }))
}

/// What one watch session measured.
struct Measured {
    settings: Value,
    camera: Timings,
    object: Timings,
}

/// Copies the default scene to a temporary folder, watches it on a thread of its own, and times
/// the edits.
fn session(opts: &BenchOptions, eval: &EvalOptions, edits: u32, progressive: bool) -> Result<Measured> {
    let dir = tempfile::Builder::new().prefix("refrakt-bench-watch-").tempdir()?;
    let script = dir.path().join("default.lua");
    std::fs::write(&script, DEFAULT_SCENE)?;
    let settings = settings_json(&SceneSource::load(&script, &[], &Default::default())?.frame_desc(0.0, eval)?, None);
    let watch_opts = WatchOptions {
        out: dir.path().join("default.preview.exr"),
        moment: Moment::Frame(0),
        png: Default::default(),
        progress: crate::progress::ProgressMode::Quiet,
        adapter: opts.adapter.clone(),
        scene: SceneOptions::for_bench(eval, &[]),
        // What `refrakt watch` writes by default: the beauty pass.
        layers: Layers::Beauty,
        progressive,
        fast_frame_over: Duration::ZERO,
        debounce: watch::DEFAULT_DEBOUNCE,
    };
    let stop = Arc::new(AtomicBool::new(false));
    let (sender, heard) = channel();
    let thread = {
        let (script, opts, stop) = (script.clone(), watch_opts, stop.clone());
        std::thread::spawn(move || -> Result<()> {
            let renderer = Renderer::new(crate::gpu::GpuContext::new(opts.adapter.as_deref())?)?;
            watch::watch(&script, &opts, renderer, &mut Relay(sender), &stop)
        })
    };
    let measured = edit_and_time(&script, &heard, edits);
    stop.store(true, Ordering::SeqCst);
    let ended = thread.join().map_err(|_| anyhow!("the watch thread panicked"))?;
    let (camera, object) = measured?;
    ended?;
    Ok(Measured { settings, camera, object })
}

/// Waits for the first frame, then times `edits` camera moves and `edits` object edits, in turn.
fn edit_and_time(script: &Path, heard: &Receiver<Heard>, edits: u32) -> Result<(Timings, Timings)> {
    let mut last = wait_for_final(heard)?.3;
    // The camera's line and the ball's, as the script has them now; and their timings.
    let mut lines = [CAMERA_LINE.to_string(), BALL_LINE.to_string()];
    let mut timings = [Timings::default(), Timings::default()];
    for i in 0..edits {
        // Alternate two values, so that every save changes the scene, and only in one line.
        let (x, blue) = if i % 2 == 0 { ("0.05", "0.05") } else { ("0", "0.0") };
        let edited = [format!("position = {{{x}, 0.9, 3.1}}"), format!("absorption = {{0.4, 0.15, {blue}}}")];
        for (kind, line) in edited.into_iter().enumerate() {
            lines[kind] = line;
            let source = DEFAULT_SCENE.replace(CAMERA_LINE, &lines[0]).replace(BALL_LINE, &lines[1]);
            let saved = save_like_an_editor(script, &source)?;
            let (first, done, work, counters) = wait_for_final(heard)?;
            let t = &mut timings[kind];
            t.first_image.push(ms(first - saved));
            t.final_image.push(ms(done - saved));
            t.notice_to_final.push(work);
            t.volume_builds += counters.volume_builds - last.volume_builds;
            t.photon_traces += counters.photon_traces - last.photon_traces;
            last = counters;
        }
    }
    let [camera, object] = timings;
    Ok((camera, object))
}

/// Writes `text` to a temporary file next to `path` and renames it over `path`; returns the
/// moment of the rename.
fn save_like_an_editor(path: &Path, text: &str) -> Result<Instant> {
    let tmp = path.with_extension("lua.saving");
    std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
    let at = Instant::now();
    std::fs::rename(&tmp, path).with_context(|| format!("renaming over {}", path.display()))?;
    Ok(at)
}

/// Waits for the next final frame; returns when the first frame (fast or final) and the final one
/// were in place, the final one's time from notice to image, and the counters after it.
fn wait_for_final(heard: &Receiver<Heard>) -> Result<(Instant, Instant, f64, Counters)> {
    let mut first = None;
    loop {
        match heard.recv_timeout(FRAME_TIMEOUT) {
            Ok(Heard::Frame { at, work, quality, counters }) => {
                let first = *first.get_or_insert(at);
                if quality == Quality::Final {
                    return Ok((first, at, work, counters));
                }
            }
            Ok(Heard::Error(message)) => bail!("the watched scene failed: {message}"),
            Err(_) => bail!("no frame from the watch session within {} s", FRAME_TIMEOUT.as_secs()),
        }
    }
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}
