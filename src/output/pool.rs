//! Frames encoded and written on a bounded pool of threads, so that EXR/PNG encoding and file
//! writes of several frames overlap each other and the GPU's next frames.
//!
//! - **Bounded.** At most one frame waits in the queue besides the `workers` being encoded:
//!   [`FramePool::send`] blocks while it is full, so a GPU faster than the disk cannot grow
//!   memory without end.
//! - **In order.** Frames may finish out of order (a smaller PNG before a larger EXR), but they
//!   are reported — progress, errors — in the order they were sent.
//! - **Whole files.** Each file is written under a temporary name and renamed
//!   ([`super::write_bytes`]); dropping the pool waits for every frame sent, so an interrupted
//!   render still writes every frame it rendered.
//! - **The same bytes.** Each file's bytes depend only on its frame and settings, never on
//!   which thread encoded it or how many there are.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

use anyhow::{Result, anyhow};

use super::exr::ExrSettings;
use super::png::PngOptions;
use super::{Format, Image};

/// One frame to write: its image and the files it goes to.
pub struct WriteJob {
    pub frame: i64,
    pub image: FrameImage,
    pub files: Vec<(Format, PathBuf)>,
    pub png: PngOptions,
    pub exr: ExrSettings,
}

/// A frame's image: in hand, or still to be made by the writer — read back from the GPU but not
/// yet converted into layers, which the writer does first (`Renderer::finish_mapped`), so the
/// thread that submits frames does not.
pub enum FrameImage {
    Ready(Image),
    Deferred(Box<dyn FnOnce() -> Image + Send>),
}

impl FrameImage {
    fn into_image(self) -> Image {
        match self {
            FrameImage::Ready(image) => image,
            FrameImage::Deferred(convert) => convert(),
        }
    }
}

/// A frame whose files are in place (or failed), as reported in order.
#[derive(Debug)]
pub struct Written {
    pub frame: i64,
    pub files: Vec<PathBuf>,
    /// Seconds making the image (a deferred one), encoding the files in memory, and writing
    /// and renaming them.
    pub convert_s: f64,
    pub encode_s: f64,
    pub write_s: f64,
    /// When its last file was in place.
    pub done_at: Instant,
}

/// What is called, in the order frames were sent, for each frame written.
pub type Report = Box<dyn FnMut(&Written) + Send>;

/// Frames finished by the workers, held until every earlier one is reported.
struct Ordered {
    next: u64,
    held: BTreeMap<u64, Result<Written>>,
    reported: u64,
    error: Option<anyhow::Error>,
    report: Report,
}

impl Ordered {
    /// Files frame `seq`'s outcome, then reports every frame now in order.
    fn finished(&mut self, seq: u64, outcome: Result<Written>) {
        self.held.insert(seq, outcome);
        while let Some(outcome) = self.held.remove(&self.next) {
            match outcome {
                Ok(w) => (self.report)(&w),
                Err(e) => {
                    self.error.get_or_insert(e);
                }
            }
            self.next += 1;
            self.reported += 1;
        }
    }
}

struct Shared {
    ordered: Mutex<Ordered>,
    reported: Condvar,
}

impl Shared {
    fn lock(&self) -> std::sync::MutexGuard<'_, Ordered> {
        self.ordered.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

/// A bounded pool of frame writers (see the module's notes).
pub struct FramePool {
    jobs: Option<SyncSender<(u64, WriteJob)>>,
    shared: Arc<Shared>,
    threads: Vec<JoinHandle<()>>,
    sent: u64,
}

impl FramePool {
    /// `workers` threads (at least one); `report` is called for each frame written, in order.
    pub fn new(workers: usize, report: Report) -> Self {
        let workers = workers.max(1);
        let (jobs, inbox) = sync_channel::<(u64, WriteJob)>(1);
        let inbox = Arc::new(Mutex::new(inbox));
        let ordered = Ordered { next: 0, held: BTreeMap::new(), reported: 0, error: None, report };
        let shared = Arc::new(Shared { ordered: Mutex::new(ordered), reported: Condvar::new() });
        let threads = (0..workers)
            .map(|i| {
                let (inbox, shared) = (inbox.clone(), shared.clone());
                std::thread::Builder::new()
                    .name(format!("refrakt frame writer {i}"))
                    .spawn(move || work(&inbox, &shared))
                    .expect("cannot start a frame writer thread")
            })
            .collect();
        Self { jobs: Some(jobs), shared, threads, sent: 0 }
    }

    /// Hands a frame to the pool, waiting while the queue is full.
    pub fn send(&mut self, job: WriteJob) -> Result<()> {
        let jobs = self.jobs.as_ref().ok_or_else(|| anyhow!("the frame writers have stopped"))?;
        jobs.send((self.sent, job)).map_err(|_| anyhow!("the frame writers have stopped"))?;
        self.sent += 1;
        Ok(())
    }

    /// The first error among the frames reported so far, if any (without waiting).
    pub fn check(&mut self) -> Result<()> {
        self.shared.lock().error.take().map_or(Ok(()), Err)
    }

    /// Waits until every frame sent is written, then returns the first error among them.
    pub fn finish(&mut self) -> Result<()> {
        let mut ordered = self.shared.lock();
        while ordered.reported < self.sent {
            ordered = self.shared.reported.wait(ordered).unwrap_or_else(std::sync::PoisonError::into_inner);
        }
        ordered.error.take().map_or(Ok(()), Err)
    }
}

impl Drop for FramePool {
    /// Closes the queue and waits for the workers, which write every frame already sent.
    fn drop(&mut self) {
        self.jobs.take();
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// A worker: takes frames from the queue until it is closed.
fn work(inbox: &Mutex<Receiver<(u64, WriteJob)>>, shared: &Shared) {
    loop {
        let next = inbox.lock().unwrap_or_else(std::sync::PoisonError::into_inner).recv();
        let Ok((seq, job)) = next else { return };
        let frame = job.frame;
        // A panic in an encoder is this frame's error, not a lost report that would be waited
        // for forever.
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| write_job(job)))
            .unwrap_or_else(|_| Err(anyhow!("frame {frame}: encoding it failed (a bug in refrakt)")));
        shared.lock().finished(seq, outcome);
        shared.reported.notify_all();
    }
}

/// Encodes and writes one frame's files, timing each part.
pub fn write_job(job: WriteJob) -> Result<Written> {
    let (mut encode_s, mut write_s) = (0.0, 0.0);
    let t0 = Instant::now();
    let image = job.image.into_image();
    let convert_s = t0.elapsed().as_secs_f64();
    for (format, path) in &job.files {
        let t0 = Instant::now();
        let bytes = super::encode(&image, *format, &job.png, job.exr)
            .map_err(|e| e.context(format!("writing {}", path.display())))?;
        let t1 = Instant::now();
        super::write_bytes(path, &bytes)?;
        encode_s += (t1 - t0).as_secs_f64();
        write_s += t1.elapsed().as_secs_f64();
    }
    let files = job.files.into_iter().map(|(_, p)| p).collect();
    Ok(Written { frame: job.frame, files, convert_s, encode_s, write_s, done_at: Instant::now() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::Layer;

    fn image(value: f32) -> Image {
        Image { width: 4, height: 2, layers: vec![Layer::new("beauty", &["R", "G", "B", "A"], vec![value; 32])] }
    }

    fn job(dir: &std::path::Path, frame: i64, formats: &[Format]) -> WriteJob {
        let files = formats.iter().map(|f| (*f, dir.join(format!("f.{frame}.{}", f.extension())))).collect();
        let value = frame as f32 / 10.0;
        // Odd frames' images are made by the writer, as `render --frames` hands them over.
        let image = if frame % 2 == 0 { FrameImage::Ready(image(value)) } else { FrameImage::Deferred(Box::new(move || image(value))) };
        WriteJob { frame, image, files, png: PngOptions::default(), exr: ExrSettings::default() }
    }

    #[test]
    fn frames_are_reported_in_the_order_sent_and_all_are_written() {
        let dir = tempfile::tempdir().unwrap();
        let order = Arc::new(Mutex::new(Vec::new()));
        let seen = order.clone();
        let mut pool = FramePool::new(3, Box::new(move |w| seen.lock().unwrap().push(w.frame)));
        for k in 0..12 {
            // Every third frame is an EXR and a PNG, the others a PNG: they finish out of order.
            let formats: &[Format] = if k % 3 == 0 { &[Format::Exr, Format::Png] } else { &[Format::Png] };
            pool.send(job(dir.path(), k, formats)).unwrap();
        }
        pool.finish().unwrap();
        assert_eq!(*order.lock().unwrap(), (0..12).collect::<Vec<_>>());
        assert!((0..12).all(|k| dir.path().join(format!("f.{k}.png")).exists()));
    }

    #[test]
    fn an_error_comes_back_and_the_other_frames_are_still_written() {
        let dir = tempfile::tempdir().unwrap();
        let mut pool = FramePool::new(2, Box::new(|_| {}));
        pool.send(job(dir.path(), 0, &[Format::Png])).unwrap();
        // A folder where the file should go: the rename fails.
        std::fs::create_dir_all(dir.path().join("f.1.png").join("x")).unwrap();
        pool.send(job(dir.path(), 1, &[Format::Png])).unwrap();
        pool.send(job(dir.path(), 2, &[Format::Png])).unwrap();
        let err = pool.finish().unwrap_err();
        assert!(format!("{err:#}").contains("f.1.png"), "{err:#}");
        assert!(dir.path().join("f.0.png").is_file() && dir.path().join("f.2.png").is_file());
    }
}
