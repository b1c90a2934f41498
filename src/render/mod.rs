//! `refrakt render`: load a scene, and for each frame run `update`, evaluate the graph, render,
//! and write the files (atomically, so an interrupted run leaves only whole frames and
//! `--skip-existing` can resume it). The frames are pipelined: see [`frames`].

pub mod frames;
pub mod motion;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{Result, anyhow, bail};

use crate::frame::FrameDesc;
use crate::gltf::{ImportOptions, Player};
use crate::lua::sandbox::FileAccess;
use crate::lua::{Limits, ScriptHost};
use crate::output::{self, Format, Image, png::PngOptions};
use crate::progress::{Progress, ProgressMode};
use crate::scene::Scene;
use crate::scene::eval::{EvalOptions, evaluate, placed_nodes};
pub use frames::{FrameFlow, FrameSplit};
use frames::{lock, render_all};

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
    /// What the benchmarks load their scenes with: the scene clock at 24 frames/s, default
    /// limits, glTF choices and params.
    pub fn for_bench(eval: &EvalOptions, allow_read: &[PathBuf]) -> Self {
        Self {
            fps: 24.0,
            eval: eval.clone(),
            allow_read: allow_read.to_vec(),
            limits: Limits::default(),
            gltf: ImportOptions::default(),
            params: Default::default(),
        }
    }

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
    /// Frames in flight, frame writers, EXR compression.
    pub flow: FrameFlow,
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
            crate::warnings::say(w);
        }
        let mut scene = Scene { roots: import.roots, base_dir: access.base.clone(), ..Scene::default() };
        import.settings.apply(&mut scene);
        let mut player = import.player;
        let shown = path.display().to_string();
        let unlit = import.settings.environment.is_none() && !opts.environment_given;
        if !placed_nodes(&scene).iter().any(|p| p.node.borrow().camera.is_some()) {
            crate::gltf::framing::view_without_camera(&mut scene, &mut player, unlit, opts.size, &shown)?;
        } else if unlit {
            crate::gltf::framing::light_without_environment(&mut scene, &shown)?;
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

    /// The animation's length, seconds: the scene's `duration` if it says, else the longest of
    /// its glTF animations.
    pub fn duration(&self) -> Option<f64> {
        match self {
            SceneSource::Lua(host) => host.scene().borrow().duration.or_else(|| host.imports_duration()),
            SceneSource::Gltf(g) => g.player.duration(),
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

