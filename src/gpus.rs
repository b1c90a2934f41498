//! `refrakt render --gpus all|0,1`: every GPU of one machine on one frame range.
//!
//! One renderer per adapter, each on a thread of its own with its own copy of the scene (a
//! script's state is not shared), takes the next chunk of `--chunk` frames from a shared queue
//! until the range is used up: chunks interleave over the adapters, a faster GPU takes more of
//! them, and each frame is handed out, rendered and written exactly once. Consecutive frames
//! stay on one renderer within a chunk, so the stages a frame shares with the one before are
//! reused (see `pipeline::reuse`). The first error stops the other renderers from taking new
//! chunks; the frames in their hands are finished and written whole.

use std::ops::RangeInclusive;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};

use anyhow::{Result, bail};

use crate::render::RenderOptions;

/// Chunks of an inclusive frame range, handed out in order, each exactly once.
pub struct ChunkQueue {
    next: AtomicI64,
    last: i64,
    chunk: i64,
    stopped: AtomicBool,
}

impl ChunkQueue {
    pub fn new(first: i64, last: i64, chunk: u32) -> Self {
        Self { next: AtomicI64::new(first), last, chunk: chunk.max(1) as i64, stopped: AtomicBool::new(false) }
    }

    /// The next chunk, or `None` once the range is used up or the queue was stopped.
    pub fn take(&self) -> Option<RangeInclusive<i64>> {
        if self.stopped.load(Ordering::SeqCst) {
            return None;
        }
        let a = self.next.fetch_add(self.chunk, Ordering::SeqCst);
        (a <= self.last).then(|| a..=(a + self.chunk - 1).min(self.last))
    }

    /// Hands out nothing more.
    pub fn stop(&self) {
        self.stopped.store(true, Ordering::SeqCst);
    }

    /// The frames of the queue's chunks one after another, for one renderer.
    pub fn frames(&self) -> impl FnMut() -> Option<i64> + '_ {
        let mut chunk: Option<RangeInclusive<i64>> = None;
        move || loop {
            if let Some(k) = chunk.as_mut().and_then(Iterator::next) {
                return Some(k);
            }
            chunk = Some(self.take()?);
        }
    }
}

/// The adapters `--gpus` names: `all` (every usable adapter of the best kind) or a
/// comma-separated list of indices as `refrakt info` numbers them (an index may repeat: two
/// renderers sharing one GPU).
pub fn parse_gpus(spec: &str) -> Result<Vec<String>> {
    let adapters = crate::gpu::usable_adapters()?;
    let listed = || {
        let names: Vec<String> = adapters.iter().enumerate().map(|(i, a)| format!("{i}: {} ({:?})", a.name, a.backend)).collect();
        names.join(", ")
    };
    if spec.trim().eq_ignore_ascii_case("all") {
        return Ok(crate::gpu::all_of_best_kind(&adapters).iter().map(usize::to_string).collect());
    }
    let mut gpus = Vec::new();
    for part in spec.split(',') {
        match crate::gpu::adapter_index(part, adapters.len()) {
            Some(i) => gpus.push(i.to_string()),
            None => bail!("--gpus {spec}: \"{}\" is not the index of a usable adapter; they are {}", part.trim(), listed()),
        }
    }
    if gpus.is_empty() {
        bail!("--gpus is empty; give `all` or indices such as 0,1");
    }
    Ok(gpus)
}

/// Runs `render` once per adapter of `opts.gpus`, each with its own copy of `opts` (its
/// `adapter` set) and the frames it takes from one shared queue over `first..=last`.
pub fn render_on_adapters<F>(opts: &RenderOptions, first: i64, last: i64, render: F) -> Result<()>
where
    F: Fn(&RenderOptions, &mut dyn FnMut() -> Option<i64>, usize) -> Result<()> + Sync,
{
    let queue = ChunkQueue::new(first, last, opts.chunk);
    let first_error = Mutex::new(None);
    std::thread::scope(|s| {
        for (gpu, adapter) in opts.gpus.iter().enumerate() {
            let mut own = opts.clone();
            own.adapter = Some(adapter.clone());
            let (queue, first_error, render) = (&queue, &first_error, &render);
            s.spawn(move || {
                let mut frames = queue.frames();
                if let Err(e) = render(&own, &mut frames, gpu) {
                    queue.stop();
                    let mut slot = first_error.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
                    if slot.is_none() {
                        *slot = Some(e.context(format!("GPU {gpu} of --gpus (adapter {adapter})")));
                    }
                }
            });
        }
    });
    match first_error.into_inner().unwrap_or_else(std::sync::PoisonError::into_inner) {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_frame_is_handed_out_once_across_threads() {
        let queue = ChunkQueue::new(3, 104, 4);
        let taken = Mutex::new(Vec::new());
        std::thread::scope(|s| {
            for _ in 0..4 {
                s.spawn(|| {
                    let mut next = queue.frames();
                    while let Some(k) = next() {
                        taken.lock().unwrap().push(k);
                    }
                });
            }
        });
        let mut taken = taken.into_inner().unwrap();
        taken.sort();
        assert_eq!(taken, (3..=104).collect::<Vec<_>>());
    }

    #[test]
    fn chunks_are_consecutive_and_the_last_is_cut_at_the_range_end() {
        let queue = ChunkQueue::new(0, 9, 4);
        assert_eq!(queue.take(), Some(0..=3));
        assert_eq!(queue.take(), Some(4..=7));
        assert_eq!(queue.take(), Some(8..=9));
        assert_eq!(queue.take(), None);
    }

    #[test]
    fn adapter_indices_are_whole_numbers_below_the_count_else_names() {
        use crate::gpu::adapter_index;
        assert_eq!(adapter_index("1", 2), Some(1));
        assert_eq!(adapter_index(" 0 ", 1), Some(0));
        // Past the count, or not a whole number: matched against names instead.
        assert_eq!(adapter_index("4090", 8), None);
        assert_eq!(adapter_index("-1", 8), None);
        assert_eq!(adapter_index("llvmpipe", 8), None);
        assert_eq!(adapter_index("", 8), None);
    }

    #[test]
    fn a_stopped_queue_hands_out_nothing() {
        let queue = ChunkQueue::new(0, 99, 1);
        assert!(queue.take().is_some());
        queue.stop();
        assert_eq!(queue.take(), None);
    }
}
