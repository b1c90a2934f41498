//! The frame pipeline of `refrakt render`: frames from the scene to the GPU and from the GPU to
//! disk, overlapped.
//!
//! ```text
//! main thread:  evaluate k+2 → submit k+2 │ wait k → map k → hand k to the writers
//! GPU:          renders k, k+1, k+2 in the order submitted
//! writers:      convert, encode and write k−1, k−2, … side by side (bounded: output::pool)
//! ```
//!
//! A frame's image is converted from the mapped staging buffer into layers by the writer that
//! takes it (`Renderer::finish_mapped`), not by the main thread: that was 4–12 ms a frame of
//! the main thread's time at 1024×576 with every layer.
//!
//! Up to [`FrameFlow::frames_in_flight`] frames are on the GPU at once, each with readback
//! buffers of its own, so what a frame shows does not depend on how many there are; frames are
//! read back, handed to the writers and reported in order.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{Result, anyhow, bail};

use super::{INTERRUPTED, RenderOptions, frame_paths, frame_time};
use crate::output::exr::ExrSettings;
use crate::output::pool::{FrameImage, FramePool, WriteJob, Written};
use crate::output::{Format, Layers};
use crate::pipeline::{Renderer, Ticket};
use crate::progress::Progress;

/// How frames flow from the GPU to disk (`--frames-in-flight`, `--writers`,
/// `--exr-compression`, `--exr-half`).
#[derive(Clone, Debug)]
pub struct FrameFlow {
    /// Frames submitted to the GPU before the first of them is read back (1 to
    /// [`crate::pipeline::MAX_FRAMES_IN_FLIGHT`]).
    pub frames_in_flight: usize,
    /// Threads converting, encoding and writing frames side by side; with one, an EXR's blocks
    /// are compressed on all cores instead.
    pub writers: usize,
    /// EXR codec and precision (its `parallel` is set from `writers`).
    pub exr: ExrSettings,
    /// Where the run's time goes, summed over its frames (`refrakt bench --scenes frames`).
    pub split: Option<Arc<Mutex<FrameSplit>>>,
}

impl Default for FrameFlow {
    fn default() -> Self {
        Self { frames_in_flight: 3, writers: default_writers(), exr: ExrSettings::default(), split: None }
    }
}

/// Frame writers by default: one per core, at most 8 (each holds a frame in memory, 56 bytes a
/// pixel with every layer).
pub fn default_writers() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get()).min(8)
}

/// Where a render's time went, in seconds summed over its frames. The main thread's parts add
/// up to its wall time; the writers' parts (`encode`, `write`) run beside it on several threads.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameSplit {
    pub frames: u64,
    /// Running `update` and evaluating the scene.
    pub evaluate_s: f64,
    /// Encoding the GPU work and submitting it.
    pub submit_s: f64,
    /// Waiting for the GPU to finish a frame.
    pub gpu_wait_s: f64,
    /// Mapping the frame's staging buffer (the writers convert it: `convert_s`).
    pub readback_s: f64,
    /// Waiting for a writer to take the frame (the writers are the bottleneck when this grows).
    pub queue_wait_s: f64,
    /// After the last frame was read back: waiting for the writers to finish.
    pub drain_s: f64,
    /// Converting frames from their mapped staging buffers into layers (all writers together).
    pub convert_s: f64,
    /// Encoding EXR/PNG files in memory (all writers together).
    pub encode_s: f64,
    /// Writing the files and renaming them into place (all writers together).
    pub write_s: f64,
    /// The GPU's own time for the frames (timestamp queries), when the adapter has them.
    pub gpu_s: f64,
    /// Bytes written.
    pub bytes: u64,
    /// Seconds from the first frame's evaluation to the last frame's files in place.
    pub run_s: f64,
}

impl FrameSplit {
    fn add(split: &Option<Arc<Mutex<FrameSplit>>>, f: impl FnOnce(&mut FrameSplit)) {
        if let Some(s) = split {
            f(&mut lock(s));
        }
    }
}

/// Runs `f`, adding its seconds to the split's part `part`.
fn timed<T>(split: &Option<Arc<Mutex<FrameSplit>>>, part: fn(&mut FrameSplit) -> &mut f64, f: impl FnOnce() -> T) -> T {
    let t0 = Instant::now();
    let out = f();
    FrameSplit::add(split, |s| *part(s) += t0.elapsed().as_secs_f64());
    out
}

/// The progress report, shared by the render loop and the frame writers. (A panic while it was
/// held cannot leave it inconsistent in a way that matters: keep reporting.)
pub(super) fn lock<T>(progress: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    progress.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A frame on its way out: rendered (or in flight on the GPU), to be written to `paths`.
struct Outgoing {
    frame: i64,
    paths: Vec<(Format, PathBuf)>,
    png: crate::output::png::PngOptions,
}

/// The pool that writes a renderer's frames, reporting each frame as soon as its files (and
/// every earlier frame's) are in place. A frame's time is the time since the previous frame's
/// files were in place, so the times add up to the run's.
fn frame_pool(opts: &RenderOptions, progress: &Arc<Mutex<Progress>>, gpu: Option<usize>) -> FramePool {
    let progress = progress.clone();
    let split = opts.flow.split.clone();
    let mut previous = Instant::now();
    FramePool::new(
        opts.flow.writers,
        Box::new(move |w: &Written| {
            let at = w.done_at.max(previous);
            lock(&progress).frame(w.frame, (at - previous).as_secs_f64(), &w.files, gpu);
            previous = at;
            let bytes: u64 = w.files.iter().filter_map(|p| std::fs::metadata(p).ok()).map(|m| m.len()).sum();
            FrameSplit::add(&split, |s| {
                (s.frames, s.convert_s, s.encode_s, s.write_s, s.bytes) =
                    (s.frames + 1, s.convert_s + w.convert_s, s.encode_s + w.encode_s, s.write_s + w.write_s, s.bytes + bytes);
            });
        }),
    )
}

/// Waits for frame `frame` on the GPU, showing on the progress bar which part it is on.
fn wait_for(renderer: &Renderer, ticket: &Ticket, frame: i64, opts: &RenderOptions, progress: &Mutex<Progress>) -> Result<()> {
    let numbered = opts.frames.map(|_| frame);
    renderer.wait(ticket, &mut |p| lock(progress).within_frame(numbered, p))
}

/// Waits for the oldest frame in flight, reads it back and hands it to the writers.
fn retire(renderer: &mut Renderer, pool: &mut FramePool, (ticket, out): (Ticket, Outgoing), opts: &RenderOptions, progress: &Mutex<Progress>) -> Result<()> {
    let split = &opts.flow.split;
    timed(split, |s| &mut s.gpu_wait_s, || wait_for(renderer, &ticket, out.frame, opts, progress))?;
    let mapped = timed(split, |s| &mut s.readback_s, || renderer.finish_mapped(ticket))?;
    let gpu_ms: f64 = renderer.profiler.last.iter().map(|t| t.1).sum();
    FrameSplit::add(split, |s| s.gpu_s += gpu_ms * 1e-3);
    let exr = ExrSettings { parallel: opts.flow.writers <= 1, ..opts.flow.exr };
    let image = FrameImage::Deferred(Box::new(move || mapped.image()));
    let job = WriteJob { frame: out.frame, image, files: out.paths, png: out.png, exr };
    timed(split, |s| &mut s.queue_wait_s, || pool.send(job))
}

/// A renderer on the adapter of `opts`, set up for its frames.
fn renderer_for(opts: &RenderOptions) -> Result<Renderer> {
    let ctx = crate::gpu::GpuContext::new(opts.adapter.as_deref())?;
    tracing::info!("adapter: {}", ctx.adapter_name());
    let mut renderer = Renderer::new(ctx)?;
    renderer.set_frames_in_flight(opts.flow.frames_in_flight)?;
    // PNG frames show the beauty pass: read the other layers back only for EXR.
    renderer.layers = if opts.formats.contains(&Format::Exr) { opts.flow.exr.layers.readback() } else { Layers::Beauty };
    if opts.flow.split.is_some() {
        renderer.profiler.enable(&renderer.ctx);
    }
    Ok(renderer)
}

/// Renders every frame `next` hands out (on the adapter of `opts`); `current` names the frame
/// in hand when one fails; `gpu` is the renderer's index among several (`--gpus`).
///
/// Frames are pipelined (see the module's notes). Frames are still written in order of
/// reporting, and an error — or Ctrl-C — leaves every frame already submitted written whole.
pub(super) fn render_all(
    scene_path: &Path,
    opts: &RenderOptions,
    progress: &Arc<Mutex<Progress>>,
    current: &Mutex<Option<i64>>,
    next: &mut dyn FnMut() -> Option<i64>,
    gpu: Option<usize>,
) -> Result<()> {
    let mut source = opts.scene.load(scene_path)?;
    let mut renderer = renderer_for(opts)?;
    let name = opts
        .name
        .clone()
        .unwrap_or_else(|| scene_path.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or("frame".into()));
    let first = opts.frames.map_or(0, |r| r.first);
    let split = &opts.flow.split;
    let mut pool = frame_pool(opts, progress, gpu);
    let mut in_flight: VecDeque<(Ticket, Outgoing)> = VecDeque::new();
    let started = Instant::now();
    let result = (|| -> Result<()> {
        let mut rendered = 0;
        while let Some(k) = next() {
            // Frames the GPU has finished go to the writers now, not only when the pipeline is
            // full: each is written and reported as soon as it can be, even while a slow
            // `update` evaluates the next (the add-on's progress bar reads these reports).
            while in_flight.front().map(|(t, _)| renderer.is_finished(t)).transpose()?.unwrap_or(false) {
                let done = in_flight.pop_front().expect("a frame is in flight");
                retire(&mut renderer, &mut pool, done, opts, progress)?;
            }
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
            let desc = timed(split, |s| &mut s.evaluate_s, || source.frame_desc(t, &opts.scene.eval)).map_err(|e| match numbered {
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
                crate::warnings::say_plain(&w);
            }
            let ticket = match desc.motion_blur {
                // A motion-blurred frame's instants take the renderer's readback slots one after
                // another: the frames before it are finished first.
                Some(blur) => {
                    while let Some(done) = in_flight.pop_front() {
                        retire(&mut renderer, &mut pool, done, opts, progress)?;
                    }
                    timed(split, |s| &mut s.submit_s, || super::motion::submit(&mut renderer, &mut source, &opts.scene.eval, blur, t, opts.scene.fps))?
                }
                None => timed(split, |s| &mut s.submit_s, || renderer.submit(&desc))?,
            };
            let mut png = opts.png;
            png.alpha = !desc.environment.visible;
            in_flight.push_back((ticket, Outgoing { frame: k, paths, png }));
            if in_flight.len() >= renderer.frames_in_flight() {
                let oldest = in_flight.pop_front().expect("a frame is in flight");
                retire(&mut renderer, &mut pool, oldest, opts, progress)?;
            }
            pool.check()?;
        }
        Ok(())
    })();
    // Whatever happened, frames already submitted are written whole before returning.
    let mut drained = Ok(());
    while let Some(frame) = in_flight.pop_front() {
        if drained.is_ok() {
            drained = retire(&mut renderer, &mut pool, frame, opts, progress);
        }
    }
    let written = timed(split, |s| &mut s.drain_s, || pool.finish());
    FrameSplit::add(split, |s| s.run_s += started.elapsed().as_secs_f64());
    result?;
    drained?;
    written
}
