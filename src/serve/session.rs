//! The renderer thread of `refrakt serve`: it owns the GPU, takes the newest [`ViewState`] from
//! its slot, renders it, and hands the image to the encoder thread through another slot. Between
//! frames it takes saves of the scene's files as `refrakt watch` does: the scene is reloaded
//! (the page's camera and light edits stay), a shader save recompiles, and an error is sent to
//! the page while the last good scene and frame stay.
//!
//! Stage reuse is the renderer's own ([`crate::pipeline::reuse`]): a camera move reruns only
//! the view pass, a light move photons → caustics → view, and the frame header says which.
//!
//! While nothing changes, the still view refines: each pass traces the scene's `samples` more
//! camera rays per pixel and adds them to the planes on the GPU ([`Renderer::refinement`]),
//! until `--refine` rays per pixel or `--refine-seconds` — the image after K passes is
//! `refrakt render --samples K·samples`'s. Each frame tells the pages what the renderer is doing
//! ([`super::Activity`]: the part of the frame the GPU is on, and the time the last frame of
//! the same kind took).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::{Result, anyhow};
use glam::Vec3;

use super::protocol::{CameraPose, FrameTimes, LensInfo, LightInfo, SceneInfo, ViewState};
use super::slot::Taken;
use super::{Activity, Rendered, ServeOptions, Shared};
use crate::frame::FrameDesc;
use crate::output::Layers;
use crate::pipeline::Renderer;
use crate::render::SceneSource;
use crate::watch::files::SceneFiles;

/// How often the renderer looks at the files while no view change arrives.
const FILE_POLL: Duration = Duration::from_millis(20);
/// A frame that takes longer than this shows the pages a busy indicator (the wait reports on
/// each part and every 150 ms); a quicker one is only its frame.
const BUSY_AFTER: Duration = Duration::from_millis(100);

/// The scene as loaded, and what is being tried.
struct Session<'a> {
    path: &'a Path,
    opts: &'a ServeOptions,
    shared: &'a Shared,
    renderer: Renderer,
    files: SceneFiles,
    /// The scene as last rendered without error.
    current: Option<SceneSource>,
    /// A reloaded scene, until its first frame renders.
    candidate: Option<SceneSource>,
    /// Files read by the last failed load: watched until it is fixed.
    failed_files: Vec<PathBuf>,
    last: Option<FrameDesc>,
    /// The `refrakt.param` values the scene was last loaded with.
    params: std::collections::BTreeMap<String, f64>,
    frames: u64,
    /// Whether an error is on the page (an `ok` event clears it).
    failing: bool,
    /// The state last rendered, the refinement passes it has had, and since when it is still.
    still: Option<(ViewState, u32, Instant)>,
    /// Milliseconds the last frame of each kind took (what it reused, whether it refined).
    took: std::collections::HashMap<(bool, bool, bool), f64>,
}

/// Runs until `shared` is closed. Errors in the scene are sent to the page and survived.
pub fn run(path: &Path, opts: &ServeOptions, mut renderer: Renderer, shared: &Shared) -> Result<()> {
    renderer.profiler.enable(&renderer.ctx);
    let files = SceneFiles::new(opts.debounce, renderer.shaders().dir())?;
    let mut s = Session {
        path,
        opts,
        shared,
        renderer,
        files,
        current: None,
        candidate: None,
        failed_files: Vec::new(),
        last: None,
        params: Default::default(),
        frames: 0,
        failing: false,
        still: None,
        took: Default::default(),
    };
    let mut pending = s.load();
    s.rewatch();
    loop {
        if s.files.changed()
            && let Some(change) = s.files.wait(&shared.stop)
        {
            if !change.shaders.is_empty() {
                match s.renderer.reload_shaders() {
                    Ok(()) => pending = true,
                    Err(e) => s.fail(&format!("{e:#}")),
                }
            }
            if !change.scene.is_empty() {
                pending |= s.load();
            }
        }
        let state = match shared.view.wait(FILE_POLL) {
            Taken::Closed => return Ok(()),
            Taken::Fresh(state) => Some(state),
            Taken::Unchanged if pending => Some(shared.view.peek()),
            Taken::Unchanged => None,
        };
        if let Some(state) = state {
            pending = false;
            s.render(&state);
        } else {
            s.refine();
        }
        if shared.stop.load(Ordering::SeqCst) {
            return Ok(());
        }
    }
}

impl Session<'_> {
    /// Loads the scene as the candidate; returns whether there is something new to render.
    fn load(&mut self) -> bool {
        let opts = crate::render::SceneOptions { params: self.params.clone(), ..self.opts.scene.clone() };
        match opts.load(self.path) {
            Ok(source) => {
                self.candidate = Some(source);
                true
            }
            Err(e) => {
                self.candidate = None;
                self.failed_files = crate::lua::files_read_before(&e).to_vec();
                self.fail(&format!("{e:#}"));
                false
            }
        }
    }

    /// Renders `state`; a candidate that renders becomes current, one that fails is dropped.
    fn render(&mut self, state: &ViewState) {
        self.still = None;
        if state.params != self.params {
            self.params = state.params.clone();
            if !self.load() {
                return;
            }
        }
        match self.try_render(state, 0) {
            Ok(()) => {
                if let Some(c) = self.candidate.take() {
                    self.current = Some(c);
                    self.failed_files.clear();
                    self.rewatch();
                }
                if std::mem::take(&mut self.failing) {
                    self.shared.clear_error();
                }
            }
            Err(e) => {
                if let Some(c) = self.candidate.take() {
                    self.failed_files = c.files_read();
                }
                self.fail(&format!("{e:#}"));
                return;
            }
        }
        self.still = Some((state.clone(), 0, Instant::now()));
    }

    /// One more refinement pass of the still view, if it has not reached its target.
    fn refine(&mut self) {
        let Some((state, passes, since)) = self.still.clone() else { return };
        let per_pass = self.last.as_ref().map_or(1, |d| d.samples.max(1));
        if (passes + 2) * per_pass > self.opts.refine || since.elapsed() > self.opts.refine_for {
            return;
        }
        match self.try_render(&state, passes + 1) {
            Ok(()) => self.still = Some((state, passes + 1, since)),
            Err(e) => {
                self.still = None;
                self.fail(&format!("{e:#}"));
            }
        }
    }

    /// Renders `state`, as refinement pass `refinement` (0: a frame of its own).
    fn try_render(&mut self, state: &ViewState, refinement: u32) -> Result<()> {
        let started = Instant::now();
        let is_new = self.candidate.is_some();
        let source = self.candidate.as_mut().or(self.current.as_mut()).ok_or_else(|| anyhow!("no scene is loaded"))?;
        let mut desc = source.frame_desc(state.time, &self.opts.scene.eval)?;
        if let Some(last) = &self.last {
            desc.share_unchanged(last);
        }
        let info = (is_new || self.last.is_none()).then(|| scene_info(self.path, &desc, source, self.opts.scene.fps));
        state.apply(&mut desc);
        self.renderer.check_limits(&desc)?;
        self.renderer.layers = if state.all_layers { Layers::All } else { Layers::Beauty };
        self.renderer.refinement = refinement;
        let samples = (refinement + 1) * desc.samples.max(1);
        let would = self.renderer.would_reuse(&desc);
        let kind = (would.volume, would.photons, refinement > 0);
        let mut activity = Activity { busy: true, refining: refinement > 0, eta_ms: self.took.get(&kind).copied(), samples, target: self.opts.refine.max(desc.samples), ..Default::default() };
        let submitted = Instant::now();
        let ticket = self.renderer.submit(&desc)?;
        let reused = ticket.reused;
        let shared = self.shared;
        self.renderer.wait(&ticket, &mut |p| {
            activity.stage = p.current.map(|part| match part {
                crate::pipeline::parts::Part::Volume => "volume",
                crate::pipeline::parts::Part::Photons => "photons",
                crate::pipeline::parts::Part::View => "view",
            });
            activity.elapsed_ms = ms(p.elapsed);
            if p.elapsed >= BUSY_AFTER {
                shared.set_activity(&activity);
            }
        })?;
        let rendered = Instant::now();
        let mut image = self.renderer.finish(ticket)?;
        average_passes(&mut image, refinement + 1);
        let times = FrameTimes {
            scene_ms: ms(submitted - started),
            render_ms: ms(rendered - submitted),
            readback_ms: ms(rendered.elapsed()),
            encode_ms: 0.0,
            gpu: self.renderer.profiler.last.iter().map(|&(stage, t)| (stage.to_string(), t)).collect(),
        };
        self.frames += 1;
        if let Some(info) = info {
            self.shared.set_scene(info); // before the frame: the page knows the scene it shows
        }
        self.took.insert(kind, ms(started.elapsed()));
        if activity.elapsed_ms >= ms(BUSY_AFTER) {
            self.shared.set_activity(&Activity { busy: false, samples, target: activity.target, ..Default::default() });
        }
        let frame = Rendered { image, frame: self.frames, input: state.input, revision: state.revision, samples, time: state.time, reused, times };
        self.shared.encoder.update(|inbox| inbox.frame = Some(Arc::new(frame)));
        for w in desc.warnings() {
            crate::warnings::say_plain(&w);
        }
        self.last = Some(desc);
        Ok(())
    }

    fn fail(&mut self, message: &str) {
        self.rewatch();
        self.failing = true;
        let kept = self.last.is_some();
        eprintln!("error: {message}");
        self.shared.report_error(message, kept);
    }

    fn rewatch(&mut self) {
        let mut list = vec![self.path.to_path_buf()];
        for source in self.current.iter().chain(&self.candidate) {
            list.extend(source.files_read());
        }
        list.extend(self.failed_files.iter().cloned());
        if let Err(e) = self.files.watch(&list) {
            tracing::warn!("{e:#}");
        }
    }
}

fn ms(d: Duration) -> f64 {
    1e3 * d.as_secs_f64()
}

/// The planes after `passes` refinement passes hold the sum of each pass's mean: their mean is
/// the sum over `passes` (depth, a minimum, stays).
fn average_passes(image: &mut crate::output::Image, passes: u32) {
    if passes <= 1 {
        return;
    }
    let k = 1.0 / passes as f32;
    for layer in image.layers.iter_mut().filter(|l| l.name != "depth") {
        layer.data.iter_mut().for_each(|v| *v *= k);
    }
}

/// What the page is told of a newly loaded scene (its camera and lights before any edit).
fn scene_info(path: &Path, desc: &FrameDesc, source: &SceneSource, fps: f64) -> SceneInfo {
    let focus = 0.5 * (desc.volume.min + desc.volume.max());
    let focus = if focus.is_finite() { focus } else { Vec3::ZERO };
    SceneInfo {
        name: path.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned()),
        camera: CameraPose::of(&desc.camera, focus),
        size: [desc.camera.width, desc.camera.height],
        lights: desc.lights.iter().map(LightInfo::of).collect(),
        animated: source.is_animated(),
        duration: source.duration(),
        params: source.params(),
        fps,
        focus: focus.into(),
        lens: LensInfo::of(&desc.camera),
    }
}
