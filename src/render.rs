//! `refrakt render`: load a scene, and for each frame run `update`, evaluate the graph, render,
//! and write the files (atomically, so an interrupted run leaves only whole frames and
//! `--skip-existing` can resume it).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{Result, anyhow, bail};

use crate::frame::FrameDesc;
use crate::gltf::{ImportOptions, Player};
use crate::lua::sandbox::FileAccess;
use crate::lua::{Limits, ScriptHost};
use crate::output::{self, Format, Image, Layers, png::PngOptions};
use crate::pipeline::Renderer;
use crate::progress::{Progress, ProgressMode};
use crate::scene::Scene;
use crate::scene::eval::{EvalOptions, evaluate, placed_nodes};

/// Set by Ctrl-C / SIGTERM: the render stops after the frame in hand.
pub static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// An inclusive frame range, `A..B` or a single frame `K`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameRange {
    pub first: i64,
    pub last: i64,
}

impl std::str::FromStr for FrameRange {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let parse = |t: &str| t.trim().parse::<i64>().map_err(|_| format!("\"{s}\" is not a frame range like 1..48 or 12"));
        let (first, last) = match s.split_once("..") {
            Some((a, b)) => (parse(a)?, parse(b.trim_start_matches('='))?),
            None => (parse(s)?, parse(s)?),
        };
        if first < 0 || last < first {
            return Err(format!("frame range {s}: frames must be ≥ 0 and the range must not run backwards"));
        }
        Ok(Self { first, last })
    }
}

/// How to load and evaluate a scene: what `render`, `watch` and `dump` share.
#[derive(Clone, Debug)]
pub struct SceneOptions {
    /// Frames per second of the scene clock: frame k is the scene at t = k / fps.
    pub fps: f64,
    pub eval: EvalOptions,
    /// Folders the scene may read besides its own.
    pub allow_read: Vec<PathBuf>,
    pub limits: Limits,
    /// `--scene` / `--animation` for a glTF scene.
    pub gltf: ImportOptions,
    /// Values of a script's `refrakt.param`s (`refrakt serve`'s sliders); empty: the defaults.
    pub params: std::collections::BTreeMap<String, f64>,
}

impl SceneOptions {
    /// Loads the scene at `path` with these options.
    pub fn load(&self, path: &Path) -> Result<SceneSource> {
        SceneSource::load_with_params(path, &self.allow_read, &self.limits, &self.gltf, &self.params)
    }
}

/// Everything `refrakt render` was asked to do.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub frames: Option<FrameRange>,
    /// Scene time of a still (`--time`), seconds; frames of a range are at k / fps.
    pub time: f64,
    pub out: PathBuf,
    pub name: Option<String>,
    pub formats: Vec<Format>,
    pub png: PngOptions,
    pub skip_existing: bool,
    pub progress: ProgressMode,
    pub adapter: Option<String>,
    /// One renderer per adapter named here (`--gpus`), each taking the next `chunk` frames of
    /// the range in turn; empty: one renderer, on `adapter`.
    pub gpus: Vec<String>,
    pub chunk: u32,
    pub scene: SceneOptions,
}

/// A scene that can be evaluated at any time.
pub enum SceneSource {
    Lua(ScriptHost),
    Gltf(Box<GltfScene>),
}

/// A `.gltf`/`.glb` file rendered as it is: its scene graph and the player of its animations.
pub struct GltfScene {
    pub scene: Scene,
    pub player: Player,
    /// The file's scenes and animations, and which were taken.
    pub catalog: crate::gltf::Catalog,
    /// The file policy its buffers and images were read through (and the record of them).
    pub access: FileAccess,
}

impl GltfScene {
    pub fn load(path: &Path, allow_read: &[PathBuf], opts: &ImportOptions) -> Result<Self> {
        let base = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let access = FileAccess::new(base, allow_read).map_err(|e| anyhow!("cannot open the scene's folder {}: {e}", base.display()))?;
        // A failed import still says what it read or looked for (a missing .bin, a texture), so
        // `refrakt watch` renders once that file is fixed, as for a script.
        let import = crate::gltf::import(path, &path.display().to_string(), &access, opts)
            .map_err(|e| crate::lua::LoadError { message: format!("{e:#}"), files_read: access.read.borrow().clone() })?;
        for w in &import.warnings {
            tracing::warn!("{w}");
        }
        let mut scene = Scene { roots: import.roots, base_dir: access.base.clone(), ..Scene::default() };
        import.settings.apply(&mut scene);
        let mut player = import.player;
        let shown = path.display().to_string();
        if !placed_nodes(&scene).iter().any(|p| p.node.borrow().camera.is_some()) {
            crate::gltf::framing::view_without_camera(&mut scene, &mut player, import.settings.environment.is_none(), opts.size, &shown)?;
        }
        Ok(Self { scene, player, catalog: import.catalog, access })
    }
}

impl SceneSource {
    pub fn load(path: &Path, allow_read: &[PathBuf], limits: &Limits) -> Result<Self> {
        Self::load_with(path, allow_read, limits, &ImportOptions::default())
    }

    /// Loads a `.lua` script or a `.gltf`/`.glb` file (`gltf` picks its scene and animation).
    pub fn load_with(path: &Path, allow_read: &[PathBuf], limits: &Limits, gltf: &ImportOptions) -> Result<Self> {
        Self::load_with_params(path, allow_read, limits, gltf, &std::collections::BTreeMap::new())
    }

    /// [`load_with`](Self::load_with), with values for a script's `refrakt.param`s.
    pub fn load_with_params(path: &Path, allow_read: &[PathBuf], limits: &Limits, gltf: &ImportOptions, params: &std::collections::BTreeMap<String, f64>) -> Result<Self> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_lowercase();
        match ext.as_str() {
            "lua" => {
                if gltf.scene.is_some() || gltf.animation.is_some() {
                    bail!(
                        "{}: --scene and --animation choose within a glTF file; in a Lua script pass them to \
                         refrakt.gltf{{file = …, scene = …, animation = …}}",
                        path.display()
                    );
                }
                Ok(SceneSource::Lua(ScriptHost::load_with_params(path, allow_read, limits, params)?))
            }
            "gltf" | "glb" => Ok(SceneSource::Gltf(Box::new(GltfScene::load(path, allow_read, gltf)?))),
            _ => bail!("{}: a scene is a .lua script or a .gltf/.glb file", path.display()),
        }
    }

    /// Runs the animation to time `t` (seconds) and flattens the scene.
    pub fn frame_desc(&mut self, t: f64, opts: &EvalOptions) -> Result<FrameDesc> {
        match self {
            SceneSource::Lua(host) => {
                host.update(t)?;
                let scene = host.scene().borrow();
                evaluate(&scene, t, opts).map_err(|e| {
                    // Errors about a node already name the line that made it.
                    let (msg, file) = (format!("{e:#}"), host.path().display().to_string());
                    if msg.starts_with(&file) { anyhow!(msg) } else { anyhow!("{file}: {msg}") }
                })
            }
            SceneSource::Gltf(g) => {
                g.player.pose(t);
                g.player.deform(&g.scene);
                evaluate(&g.scene, t, opts)
            }
        }
    }

    /// A script's `refrakt.param`s (none for a glTF file).
    pub fn params(&self) -> Vec<crate::lua::params::Param> {
        match self {
            SceneSource::Lua(host) => host.params(),
            SceneSource::Gltf(_) => Vec::new(),
        }
    }

    /// Whether frames differ over time (a Lua `update`, or animations in a glTF file).
    pub fn is_animated(&self) -> bool {
        match self {
            SceneSource::Lua(host) => host.is_animated(),
            SceneSource::Gltf(g) => g.player.is_animated(),
        }
    }

    /// The scene graph as it stands (after the last `frame_desc`).
    pub fn with_scene<R>(&self, f: impl FnOnce(&Scene) -> R) -> R {
        match self {
            SceneSource::Lua(host) => f(&host.scene().borrow()),
            SceneSource::Gltf(g) => f(&g.scene),
        }
    }

    /// Every file the scene read (script, modules, glTF files, their buffers and images…), for
    /// `refrakt watch`.
    pub fn files_read(&self) -> Vec<PathBuf> {
        match self {
            SceneSource::Lua(host) => host.files_read(),
            SceneSource::Gltf(g) => g.access.read.borrow().clone(),
        }
    }
}

/// The scene time of frame `k` (k / fps), or of the still (`--time`).
pub fn frame_time(frame: Option<i64>, opts: &RenderOptions) -> f64 {
    frame.map_or(opts.time, |k| k as f64 / opts.scene.fps)
}

/// The files frame `k` goes to: `<name>.<k>.<ext>` in a range, `k` padded with zeros to the
/// digits of the range's last frame (at least 4, so names sort in frame order); for a still
/// `<name>.<ext>` at t = 0 and `<name>.t<seconds>s.<ext>` at any other `--time`, so stills at
/// different times do not overwrite each other.
pub fn frame_paths(opts: &RenderOptions, name: &str, frame: Option<i64>) -> Vec<(Format, PathBuf)> {
    let digits = opts.frames.map_or(4, |r| frame_digits(r.last));
    opts.formats
        .iter()
        .map(|&f| {
            let file = match frame {
                Some(k) => format!("{name}.{k:0digits$}.{}", f.extension()),
                None if opts.time == 0.0 => format!("{name}.{}", f.extension()),
                None => format!("{name}.t{}s.{}", opts.time, f.extension()),
            };
            (f, opts.out.join(file))
        })
        .collect()
}

/// Digits of frame numbers in file names: those of `last`, and at least 4.
pub fn frame_digits(last: i64) -> usize {
    last.max(0).to_string().len().max(4)
}

/// Checks `--name`: one plain file name (no folders: those go in `--out`), not empty, and not
/// starting with a dot (hidden files, and the pattern of refrakt's temporaries).
pub fn check_name(name: &str) -> Result<()> {
    if name.is_empty() {
        bail!("--name is empty; give the frames a base name, or leave --name out to use the scene's file name");
    }
    if name.contains(['/', '\\', '\0']) || name == ".." {
        bail!("--name \"{name}\" is not a plain file name: put folders in --out (e.g. --out render/shots --name take1)");
    }
    if name.starts_with('.') {
        bail!("--name \"{name}\" starts with a dot, which would make hidden files; choose a name without it");
    }
    Ok(())
}

/// Writes one rendered frame in every requested format.
pub fn write_frame(image: &Image, paths: &[(Format, PathBuf)], png: &PngOptions) -> Result<()> {
    for (format, path) in paths {
        output::write(image, *format, path, png)?;
    }
    Ok(())
}

pub fn run(scene_path: &Path, opts: &RenderOptions) -> Result<()> {
    // What can be known wrong before the scene loads and the GPU starts is reported first.
    if let Some(name) = &opts.name {
        check_name(name)?;
    }
    output::check_writable_folder(&opts.out).map_err(|e| anyhow!("--out {}: {e:#}", opts.out.display()))?;
    output::remove_stale_temporaries(&opts.out);
    let progress = Arc::new(Mutex::new(Progress::new(opts.progress)));
    let current = Mutex::new(None);
    let result = if crate::bundle::is_bundle(scene_path) {
        // The bundle's files may lie beside the scene's folder (they were packed with
        // --allow-read): every file in it may be read.
        crate::bundle::unpack(scene_path).and_then(|b| {
            let mut opts = opts.clone();
            opts.scene.allow_read.push(b.root().to_path_buf());
            render_frames(&b.scene(), &opts, &progress, &current)
        })
    } else {
        render_frames(scene_path, opts, &progress, &current)
    };
    if let Err(e) = &result {
        lock(&progress).error(&format!("{e:#}"), *lock(&current));
    }
    result
}

/// Renders the frames of `opts` on one renderer, or on one per adapter of `--gpus`.
fn render_frames(scene_path: &Path, opts: &RenderOptions, progress: &Arc<Mutex<Progress>>, current: &Mutex<Option<i64>>) -> Result<()> {
    let started = Instant::now();
    let (first, last) = opts.frames.map_or((0, 0), |r| (r.first, r.last));
    lock(progress).start(first, last);
    if opts.gpus.is_empty() {
        let mut frames = first..=last;
        render_all(scene_path, opts, progress, current, &mut || frames.next(), None)?;
    } else {
        crate::gpus::render_on_adapters(opts, first, last, |adapter_opts, next, gpu| {
            render_all(scene_path, adapter_opts, progress, current, next, Some(gpu))
        })?;
    }
    // Interrupted during the last frame (or the only one): it was finished and written, but
    // the command was stopped, and says so with its exit code.
    if INTERRUPTED.load(Ordering::SeqCst) {
        bail!("interrupted; the frame in hand was finished and written whole");
    }
    lock(progress).finish(started.elapsed().as_secs_f64());
    Ok(())
}

/// The progress report, shared by the render loop and the frame writer. (A panic while it was
/// held cannot leave it inconsistent in a way that matters: keep reporting.)
fn lock<T>(progress: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    progress.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A frame on its way out: rendered (or in flight on the GPU), to be written to `paths`.
struct Outgoing {
    frame: i64,
    paths: Vec<(Format, PathBuf)>,
    png: PngOptions,
}

/// Writes frames on a thread of its own, so EXR/PNG encoding overlaps the next frame's GPU
/// work, and reports each frame as soon as its files are in place (so progress follows the
/// frames, not the loop that submits them); the first error comes back to the render loop.
struct FrameWriter {
    jobs: Option<std::sync::mpsc::Sender<(Image, Outgoing)>>,
    done: std::sync::mpsc::Receiver<Result<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
    queued: usize,
}

impl FrameWriter {
    /// `gpu`: the renderer's index in `--gpus`, reported with each frame when there are several.
    fn new(progress: Arc<Mutex<Progress>>, gpu: Option<usize>) -> Self {
        let (jobs, inbox) = std::sync::mpsc::channel::<(Image, Outgoing)>();
        let (outbox, done) = std::sync::mpsc::channel();
        let thread = std::thread::spawn(move || {
            // Frames overlap (see `render_all`): each is timed from the one before it.
            let mut previous = Instant::now();
            for (image, out) in inbox {
                let result = write_frame(&image, &out.paths, &out.png);
                if result.is_ok() {
                    let files: Vec<PathBuf> = out.paths.into_iter().map(|(_, p)| p).collect();
                    lock(&progress).frame(out.frame, previous.elapsed().as_secs_f64(), &files, gpu);
                    previous = Instant::now();
                }
                let failed = result.is_err();
                if outbox.send(result).is_err() || failed {
                    break;
                }
            }
        });
        Self { jobs: Some(jobs), done, thread: Some(thread), queued: 0 }
    }

    fn send(&mut self, image: Image, out: Outgoing) -> Result<()> {
        let jobs = self.jobs.as_ref().ok_or_else(|| anyhow!("the frame writer has stopped"))?;
        jobs.send((image, out)).map_err(|_| anyhow!("the frame writer stopped after an error"))?;
        self.queued += 1;
        Ok(())
    }

    /// The first error among the frames written so far (waiting for all of them when `wait`).
    fn check(&mut self, wait: bool) -> Result<()> {
        while self.queued > 0 {
            let next = if wait { self.done.recv().ok() } else { self.done.try_recv().ok() };
            let Some(result) = next else { break };
            self.queued -= 1;
            result?;
        }
        Ok(())
    }
}

impl Drop for FrameWriter {
    fn drop(&mut self) {
        self.jobs.take();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Waits for frame `frame` on the GPU, showing on the progress bar which part it is on.
fn wait_for(renderer: &Renderer, ticket: &crate::pipeline::Ticket, frame: i64, opts: &RenderOptions, progress: &Mutex<Progress>) -> Result<()> {
    let numbered = opts.frames.map(|_| frame);
    renderer.wait(ticket, &mut |p| lock(progress).within_frame(numbered, p))
}

/// Renders every frame `next` hands out (on the adapter of `opts`); `current` names the frame
/// in hand when one fails; `gpu` is the renderer's index among several (`--gpus`).
///
/// Frames are pipelined: while the GPU renders frame k, the CPU runs `update` and evaluates the
/// scene for frame k+1 and submits it; frame k is then read back and handed to the writer
/// thread. Frames are still written in order, and an error leaves every earlier frame whole.
fn render_all(
    scene_path: &Path,
    opts: &RenderOptions,
    progress: &Arc<Mutex<Progress>>,
    current: &Mutex<Option<i64>>,
    next: &mut dyn FnMut() -> Option<i64>,
    gpu: Option<usize>,
) -> Result<()> {
    let mut source = opts.scene.load(scene_path)?;
    let ctx = crate::gpu::GpuContext::new(opts.adapter.as_deref())?;
    tracing::info!("adapter: {}", ctx.adapter_name());
    let mut renderer = Renderer::new(ctx)?;
    // PNG frames show the beauty pass: read the other layers back only for EXR.
    renderer.layers = if opts.formats.contains(&Format::Exr) { Layers::All } else { Layers::Beauty };
    let name = opts
        .name
        .clone()
        .unwrap_or_else(|| scene_path.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or("frame".into()));
    let first = opts.frames.map_or(0, |r| r.first);
    let mut warned = std::collections::HashSet::new();
    let mut writer = FrameWriter::new(progress.clone(), gpu);
    let mut in_flight: Option<(crate::pipeline::Ticket, Outgoing)> = None;
    let result = (|| -> Result<()> {
        let mut rendered = 0;
        while let Some(k) = next() {
            if INTERRUPTED.load(Ordering::SeqCst) {
                bail!("interrupted after {rendered} frame(s); the frames written are whole");
            }
            let numbered = opts.frames.map(|_| k);
            let paths = frame_paths(opts, &name, numbered);
            if opts.skip_existing && paths.iter().all(|(_, p)| p.exists()) {
                lock(progress).skip(k);
                continue;
            }
            *lock(current) = numbered;
            rendered += 1;
            let t = frame_time(numbered, opts);
            let desc = source.frame_desc(t, &opts.scene.eval).map_err(|e| match numbered {
                Some(k) if gpu.is_some() => anyhow!(
                    "frame {k} (t = {t:.4} s): {e:#} (fix the scene and re-run with --skip-existing to render the \
                     frames not written yet)"
                ),
                Some(k) if k > first => anyhow!(
                    "frame {k} (t = {t:.4} s): {e:#} (frames {first} to {} are written; fix the scene and re-run with \
                     --skip-existing to go on from frame {k})",
                    k - 1
                ),
                Some(k) => anyhow!("frame {k} (t = {t:.4} s): {e:#}"),
                None => e,
            })?;
            for w in desc.warnings() {
                if warned.insert(w.clone()) {
                    tracing::warn!("{w}");
                }
            }
            let ticket = renderer.submit(&desc)?;
            let mut png = opts.png;
            png.alpha = !desc.environment.visible;
            let outgoing = Outgoing { frame: k, paths, png };
            if let Some((previous, out)) = in_flight.replace((ticket, outgoing)) {
                wait_for(&renderer, &previous, out.frame, opts, progress)?;
                writer.send(renderer.finish(previous)?, out)?;
            }
            writer.check(false)?;
        }
        Ok(())
    })();
    // Whatever happened, frames already rendered are written whole before returning.
    let drained = in_flight.take().map_or(Ok(()), |(ticket, out)| {
        wait_for(&renderer, &ticket, out.frame, opts, progress)?;
        renderer.finish(ticket).and_then(|image| writer.send(image, out))
    });
    let written = writer.check(true);
    result?;
    drained?;
    written
}
