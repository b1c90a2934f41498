//! `refrakt watch`: render a scene to a preview file, then again after every save of a file it
//! read, keeping the GPU and what it holds alive between reloads.
//!
//! - **What is watched**: the files the scene read (script, `require`d modules, meshes,
//!   images — [`SceneSource::files_read`]) and, in a development build, `shaders/`; see
//!   [`files`].
//! - **What is reused**: one device and renderer for the whole session: pipelines, buffers of
//!   unchanged size, meshes and images equal to the last frame's ([`FrameDesc::share_unchanged`]),
//!   and whole stages whose inputs did not change ([`crate::pipeline::reuse`]): a camera move
//!   neither voxelizes nor traces photons again.
//! - **Last good frame**: an error (Lua, shader, asset, GPU limit) is reported and the preview
//!   and the scene stay as they were; the next save renders again. The preview is replaced by a
//!   rename, so a viewer never reads half a file.
//! - **Progressive**: after a change, a fast frame first ([`fast_options`]), then the full one
//!   if nothing changed meanwhile.

pub mod files;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Result, anyhow, bail};
use serde::Serialize;
use serde_json::json;

use crate::frame::FrameDesc;
use crate::gpu::shaders::ShaderLibrary;
use crate::output::{self, ExrCompression, Format, Layers, png::PngOptions};
use crate::pipeline::reuse::Reuse;
use crate::pipeline::{Counters, Renderer};
use crate::progress::{Progress, ProgressMode};
use crate::render::{FrameRange, INTERRUPTED, SceneOptions, SceneSource};
use crate::scene::eval::EvalOptions;
use files::{Change, SceneFiles};

/// Which moments of the scene's clock the preview shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Moment {
    /// `--time T`, seconds.
    Time(f64),
    /// `--frame K`: t = K / fps.
    Frame(i64),
    /// `--frames A..B`: the range once after each change, or round and round with `--loop`.
    Range { frames: FrameRange, looping: bool },
}

/// Everything `refrakt watch` was asked to do.
#[derive(Clone, Debug)]
pub struct WatchOptions {
    /// The preview file (`.exr` or `.png`), rewritten by every frame.
    pub out: PathBuf,
    pub moment: Moment,
    pub png: PngOptions,
    pub progress: ProgressMode,
    pub adapter: Option<String>,
    pub scene: SceneOptions,
    /// The layers an EXR preview holds (a PNG preview shows the beauty pass).
    pub layers: Layers,
    /// After a change, show a fast frame before the full one…
    pub progressive: bool,
    /// …when the last full frame took longer than this (the first one always has a fast frame).
    pub fast_frame_over: Duration,
    /// How long a file must stay quiet before its change is taken.
    pub debounce: Duration,
}

/// The default for [`WatchOptions::fast_frame_over`]: a full frame quicker than this is shown
/// about as soon as a fast one would be, so the fast frame would only delay it.
pub const DEFAULT_FAST_FRAME_OVER: Duration = Duration::from_millis(100);

/// How long a failed load waits for a save still under way before reporting its error.
const SETTLE: Duration = Duration::from_millis(60);

/// The default debounce: longer than the gaps within one save (an editor's write-then-rename,
/// an exporter's stream of writes: well under a millisecond), short enough not to be felt — it
/// is part of every edit's latency. A tool that writes a file in pieces over longer than this
/// may show an error for the half-written file first; the next frame, once it is whole, replaces
/// it (`--debounce` waits longer).
pub const DEFAULT_DEBOUNCE: Duration = Duration::from_millis(10);

impl WatchOptions {
    /// `render/<name>.preview.exr`, where the scene's frames would go.
    pub fn default_out(scene: &Path) -> PathBuf {
        let name = scene.file_stem().map_or("scene".into(), |s| s.to_string_lossy().to_string());
        PathBuf::from("render").join(format!("{name}.preview.exr"))
    }

    fn format(&self) -> Result<Format> {
        match self.out.extension().and_then(|e| e.to_str()).map(str::to_lowercase).as_deref() {
            Some("exr") => Ok(Format::Exr),
            Some("png") => Ok(Format::Png),
            _ => bail!("--out {}: the preview must be an .exr or a .png file", self.out.display()),
        }
    }
}

/// One point of the scene's clock.
#[derive(Clone, Copy, Debug, PartialEq)]
struct At {
    frame: Option<i64>,
    time: f64,
}

impl Moment {
    /// The points a pass over the moment renders, in order.
    fn points(&self, fps: f64) -> Vec<At> {
        match *self {
            Moment::Time(time) => vec![At { frame: None, time }],
            Moment::Frame(k) => vec![At { frame: Some(k), time: k as f64 / fps }],
            Moment::Range { frames, .. } => {
                (frames.first..=frames.last).map(|k| At { frame: Some(k), time: k as f64 / fps }).collect()
            }
        }
    }

    fn looping(&self) -> bool {
        matches!(self, Moment::Range { looping: true, .. })
    }
}

/// Which frame of a change the preview shows now.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Quality {
    /// The fast frame shown first ([`fast_options`]).
    Preview,
    /// The frame at the full settings.
    Final,
}

/// A frame written to the preview.
#[derive(Clone, Debug, Serialize)]
pub struct FrameEvent {
    pub frame: Option<i64>,
    pub time: f64,
    /// Position in a `--frames` range (1 of 1 for a still).
    pub done: u64,
    pub total: u64,
    /// From the change being noticed (or the frame's turn in a loop) to the file in place.
    pub seconds: f64,
    pub files: Vec<PathBuf>,
    pub quality: Quality,
    pub stats: Stats,
}

/// What the frame reused, and the renderer's work so far.
#[derive(Clone, Debug, Serialize)]
pub struct Stats {
    pub reused: Reuse,
    #[serde(flatten)]
    pub counters: Counters,
}

/// Where a watch session reports: the command line's progress, or the benchmark.
pub trait Report {
    fn watching(&mut self, files: &[PathBuf], shaders: Option<&Path>);
    fn frame(&mut self, frame: &FrameEvent);
    /// An error the session survives: the preview keeps the last good frame when `kept` (there
    /// is none before the first frame).
    fn error(&mut self, message: &str, frame: Option<i64>, kept: bool);
}

impl Report for Progress {
    fn watching(&mut self, files: &[PathBuf], shaders: Option<&Path>) {
        let line = match shaders {
            Some(dir) => format!("watching {} file(s) and the shaders in {}", files.len(), dir.display()),
            None => format!("watching {} file(s)", files.len()),
        };
        self.note(json!({ "event": "watching", "files": files, "shaders": shaders }), &line);
    }

    fn frame(&mut self, f: &FrameEvent) {
        let mut event = serde_json::to_value(f).unwrap_or_default();
        event["event"] = json!("frame");
        let reused: Vec<&str> = [(f.stats.reused.volume, "volume"), (f.stats.reused.photons, "photons")]
            .iter()
            .filter_map(|&(r, what)| r.then_some(what))
            .collect();
        let line = format!(
            "{} frame in {:.2} s{}: {}",
            if f.quality == Quality::Final { "final" } else { "fast" },
            f.seconds,
            if reused.is_empty() { String::new() } else { format!(" (reused the {})", reused.join(" and ")) },
            f.files.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
        );
        self.frame_note(event, &line);
    }

    fn error(&mut self, message: &str, frame: Option<i64>, kept: bool) {
        let after = if kept {
            "the preview keeps the last good frame; refrakt renders again on the next save"
        } else {
            "no frame is shown yet; refrakt renders as soon as a save fixes this"
        };
        eprintln!("error: {message}\n({after})");
        Progress::error(self, message, frame);
    }
}

/// Settings of the fast frame shown first after a change. What the renderer cannot take from
/// its cache is done at reduced quality: half the voxels along each side (an eighth of the
/// volume, never below 16 per side), an eighth of the photons, and one camera ray per pixel.
/// `None` when that would be the full frame anyway.
pub fn fast_options(eval: &EvalOptions, full: &FrameDesc, cached: Reuse) -> Option<EvalOptions> {
    const MIN_RESOLUTION: u32 = 16;
    let resolution = eval.resolution.unwrap_or(full.volume.dims.max_element());
    let coarser = !cached.volume && resolution / 2 >= MIN_RESOLUTION;
    let fewer_photons = !cached.photons && full.photons >= 8;
    let one_sample = full.samples > 1;
    if !(coarser || fewer_photons || one_sample) {
        return None;
    }
    Some(EvalOptions {
        resolution: if coarser { Some(resolution / 2) } else { eval.resolution },
        photons: if fewer_photons { Some(full.photons / 8) } else { eval.photons },
        samples: Some(1),
        ..eval.clone()
    })
}

/// `refrakt watch` on the command line: reports go to `opts.progress`; Ctrl-C or SIGTERM ends
/// it (exit code 130).
pub fn run(scene: &Path, opts: &WatchOptions) -> Result<()> {
    opts.format()?; // before the slow start of the GPU
    let folder = opts.out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    output::check_writable_folder(folder).map_err(|e| anyhow!("--out {}: {e:#}", opts.out.display()))?;
    if opts.out.is_dir() {
        bail!("--out {} is a folder; the preview is a file (e.g. --out {}/preview.exr)", opts.out.display(), opts.out.display());
    }
    output::remove_stale_temporaries(folder);
    // A bar makes no sense for a process that never ends: lines on a terminal.
    let mode = match opts.progress {
        ProgressMode::Auto | ProgressMode::Bar => ProgressMode::Lines,
        m => m,
    };
    let mut progress = Progress::new(mode);
    let started = Instant::now();
    let result = (|| {
        let ctx = crate::gpu::GpuContext::new(opts.adapter.as_deref())?;
        tracing::info!("adapter: {}", ctx.adapter_name());
        let library = ShaderLibrary::for_development();
        let (renderer, failed) = Renderer::with_shaders_or_embedded(ctx, library.clone())?;
        let points = opts.moment.points(opts.scene.fps);
        progress.start(points[0].frame.unwrap_or(0), points[points.len() - 1].frame.unwrap_or(0));
        if let (Some(e), Some(dir)) = (failed, library.dir()) {
            let message = format!(
                "{e:#} — refrakt watch starts with the shaders built into it instead, and switches to the ones in {} \
                 once a save makes them compile",
                dir.display()
            );
            Report::error(&mut progress, &message, None, false);
        }
        watch(scene, opts, renderer, &mut progress, &INTERRUPTED)
    })();
    if let Err(e) = &result {
        Progress::error(&mut progress, &format!("{e:#}"), None);
    }
    result?;
    progress.finish(started.elapsed().as_secs_f64());
    Ok(())
}

/// Renders `scene` to the preview and again after each change to its files, until `stop` is
/// set. Errors in the scene are reported and survived; only failing to watch at all returns one.
pub fn watch(scene: &Path, opts: &WatchOptions, renderer: Renderer, report: &mut dyn Report, stop: &AtomicBool) -> Result<()> {
    let mut session = Session::new(scene, opts, renderer, report, stop)?;
    let points = opts.moment.points(opts.scene.fps);
    let mut next = session.load().then_some(0);
    session.rewatch();
    loop {
        if let Some(i) = next {
            let shown = Shown { at: points[i], done: i as u64 + 1, total: points.len() as u64 };
            // (Rendering, or failing to, updates the watched files itself.)
            let rendered = session.render(shown);
            next = match i + 1 {
                _ if !rendered => None,
                n if n < points.len() => Some(n),
                _ if opts.moment.looping() => Some(0),
                _ => None,
            };
        }
        if stop.load(Ordering::SeqCst) {
            return Ok(());
        }
        // Between frames of a range, go on unless something changed.
        if next.is_some() && !session.files.changed() {
            continue;
        }
        let Some(change) = session.files.wait(stop) else { return Ok(()) };
        if session.apply(&change) {
            next = Some(0);
        }
    }
}

/// The state kept between reloads.
struct Session<'a> {
    path: &'a Path,
    opts: &'a WatchOptions,
    format: Format,
    renderer: Renderer,
    files: SceneFiles,
    report: &'a mut dyn Report,
    stop: &'a AtomicBool,
    /// The scene as last rendered without error.
    current: Option<SceneSource>,
    /// The scene reloaded after an edit, until its first frame renders (then it is current).
    candidate: Option<SceneSource>,
    /// Files read by the last load or render that failed: watched until it is fixed.
    failed_files: Vec<PathBuf>,
    /// The frame last rendered: the next one shares its unchanged meshes and images.
    last: Option<FrameDesc>,
    /// When the change being rendered was noticed (or a range's frame began).
    noticed: Instant,
    /// How long the last full frame took, from submission to the preview in place.
    last_full: Option<Duration>,
}

/// Where a frame stands in what is being shown.
#[derive(Clone, Copy)]
struct Shown {
    at: At,
    done: u64,
    total: u64,
}

impl<'a> Session<'a> {
    fn new(path: &'a Path, opts: &'a WatchOptions, mut renderer: Renderer, report: &'a mut dyn Report, stop: &'a AtomicBool) -> Result<Self> {
        let format = opts.format()?;
        // A PNG preview shows the beauty pass alone, whatever --layers says.
        renderer.layers = if format == Format::Png { Layers::Beauty } else { opts.layers };
        Ok(Self {
            path,
            opts,
            format,
            files: SceneFiles::new(opts.debounce, renderer.shaders().dir())?,
            renderer,
            report,
            stop,
            current: None,
            candidate: None,
            failed_files: Vec::new(),
            last: None,
            noticed: Instant::now(),
            last_full: None,
        })
    }

    /// Takes a change: recompiles the shaders, reloads the scene. Returns whether to render.
    fn apply(&mut self, change: &Change) -> bool {
        self.noticed = Instant::now();
        let mut render = false;
        if !change.shaders.is_empty() {
            // On a WGSL error the old pipelines stay (the message names shaders/<file>:<line>).
            match self.renderer.reload_shaders() {
                Ok(()) => render = self.current.is_some(),
                Err(e) => self.fail(&format!("{e:#}"), None),
            }
        }
        if !change.scene.is_empty() {
            render = self.load();
        }
        render
    }

    /// Loads the scene from disk as the candidate; on an error the current scene stays.
    fn load(&mut self) -> bool {
        let started = Instant::now();
        match self.opts.scene.load(self.path) {
            Ok(source) => {
                tracing::debug!("scene loaded in {:.1} ms", 1e3 * started.elapsed().as_secs_f64());
                self.candidate = Some(source);
                true
            }
            Err(e) => {
                self.candidate = None;
                self.failed_files = crate::lua::files_read_before(&e).to_vec();
                // A save may still be under way (an editor that truncates the file, then writes
                // it): if a file changes again within a moment, the error was about a
                // half-written file, and the next load is the one to report.
                if self.files.settle(SETTLE) {
                    tracing::debug!("a file changed while the scene loaded; not reporting: {e:#}");
                    self.rewatch();
                    return false;
                }
                self.fail(&format!("{e:#}"), None);
                false
            }
        }
    }

    /// Renders one point of the clock into the preview; returns whether it did. A candidate
    /// scene that renders becomes the current one; one that fails is dropped.
    fn render(&mut self, shown: Shown) -> bool {
        if shown.total > 1 {
            self.noticed = Instant::now(); // each frame of a range is timed by itself
        }
        match self.try_render(shown) {
            Ok(()) => {
                if let Some(c) = self.candidate.take() {
                    self.current = Some(c);
                    self.failed_files.clear();
                }
                true
            }
            Err(e) => {
                if let Some(c) = self.candidate.take() {
                    self.failed_files = c.files_read();
                }
                let message = match (shown.at.frame, shown.total > 1) {
                    (Some(k), true) => format!("frame {k} (t = {:.4} s): {e:#}", shown.at.time),
                    _ => format!("{e:#}"),
                };
                self.fail(&message, shown.at.frame);
                false
            }
        }
    }

    /// The fast frame (for a still, when there is one to gain), then the full one unless a
    /// change arrived in between.
    fn try_render(&mut self, shown: Shown) -> Result<()> {
        let source = self.candidate.as_mut().or(self.current.as_mut()).ok_or_else(|| anyhow!("no scene is loaded"))?;
        let full = frame_at(source, shown.at, &self.opts.scene.eval, self.last.as_ref())?;
        // Limits are checked on the full frame first, so that an error names the size the
        // scene asks for, not the fast frame's smaller one.
        self.renderer.check_limits(&full)?;
        // A range shows its frames at the full settings; a still shows a fast frame first only
        // when full frames take long enough for it to be seen sooner.
        let slow = self.last_full.is_none_or(|d| d > self.opts.fast_frame_over);
        let progressive = self.opts.progressive && shown.total == 1 && slow;
        let fast_eval = progressive.then(|| fast_options(&self.opts.scene.eval, &full, self.renderer.would_reuse(&full))).flatten();
        if let Some(eval) = fast_eval {
            let fast = frame_at(source, shown.at, &eval, self.last.as_ref())?;
            self.show(fast, shown, Quality::Preview)?;
            if self.files.changed() {
                return Ok(()); // the next change is rendered instead
            }
        }
        self.show(full, shown, Quality::Final)
    }

    /// Renders `desc` and puts it in the preview's place.
    fn show(&mut self, desc: FrameDesc, shown: Shown, quality: Quality) -> Result<()> {
        for w in desc.warnings() {
            crate::warnings::say_plain(&w);
        }
        let started = Instant::now();
        let ticket = self.renderer.submit(&desc)?;
        let reused = ticket.reused;
        let image = self.renderer.finish(ticket)?;
        if self.stop.load(Ordering::SeqCst) {
            return Ok(()); // stopping: the preview stays as it was
        }
        let rendered = started.elapsed();
        let png = PngOptions { alpha: !desc.environment.visible, ..self.opts.png };
        output::write_with(&image, self.format, &self.opts.out, &png, ExrCompression::Fast)?;
        tracing::debug!(
            "{quality:?} frame: rendered and read back in {:.1} ms, written in {:.1} ms ({:.1} ms since the change was noticed)",
            1e3 * rendered.as_secs_f64(),
            1e3 * (started.elapsed() - rendered).as_secs_f64(),
            1e3 * self.noticed.elapsed().as_secs_f64()
        );
        if quality == Quality::Final {
            self.last_full = Some(started.elapsed());
        }
        self.rewatch(); // files the frame read (an `update` may load meshes) before it is seen
        self.report.frame(&FrameEvent {
            frame: shown.at.frame,
            time: shown.at.time,
            done: shown.done,
            total: shown.total,
            seconds: self.noticed.elapsed().as_secs_f64(),
            files: vec![self.opts.out.clone()],
            quality,
            stats: Stats { reused, counters: self.renderer.counters.clone() },
        });
        self.last = Some(desc);
        Ok(())
    }

    /// Reports an error the session survives, once the files that may fix it are watched (so
    /// that a fix saved the moment the error is seen is not missed).
    fn fail(&mut self, message: &str, frame: Option<i64>) {
        self.rewatch();
        let kept = self.last.is_some();
        self.report.error(message, frame, kept);
    }

    /// Watches the files of the current scene, of the candidate, and of the last failure.
    fn rewatch(&mut self) {
        let mut list = vec![self.path.to_path_buf()];
        for source in self.current.iter().chain(&self.candidate) {
            list.extend(source.files_read());
        }
        list.extend(self.failed_files.iter().cloned());
        match self.files.watch(&list) {
            Ok(true) => self.report.watching(&self.files.watched(), self.files.shaders()),
            Ok(false) => {}
            Err(e) => {
                let kept = self.last.is_some();
                self.report.error(&format!("{e:#}"), None, kept)
            }
        }
    }
}

/// The scene at `at`, sharing what is unchanged with the frame before.
fn frame_at(source: &mut SceneSource, at: At, eval: &EvalOptions, last: Option<&FrameDesc>) -> Result<FrameDesc> {
    let mut desc = source.frame_desc(at.time, eval)?;
    if let Some(last) = last {
        desc.share_unchanged(last);
    }
    Ok(desc)
}
