//! A frame is submitted in parts — the volume (voxelize, gradient, octree), the photons
//! (emission, march, caustic maps), the view — so that waiting for it can say which part the
//! GPU is on. On a CPU driver a frame takes tens of seconds, and a terminal that shows nothing
//! for that long looks hung (issue #16); a fast GPU finishes before the first report.

use std::time::{Duration, Instant};

use anyhow::{Result, bail};

/// One part of a frame, in the order the GPU runs them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// Voxelize, gradient, octree (skipped when the volume is reused).
    Volume,
    /// Photon emission, march and caustic maps (skipped when reused or without lights).
    Photons,
    /// The camera rays and the readback.
    View,
}

impl Part {
    /// What the GPU does in this part, for a progress line.
    pub fn doing(self, photons: u32) -> String {
        match self {
            Part::Volume => "building the volume".into(),
            Part::Photons => format!("tracing {photons} photons"),
            Part::View => "tracing camera rays".into(),
        }
    }
}

/// How far a frame in flight has come.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameProgress {
    /// Parts finished, of `parts` in this frame.
    pub done: usize,
    pub parts: usize,
    /// The part the GPU is on (`None` once all are done).
    pub current: Option<Part>,
    /// Photons the frame traces (0 when it reuses them or has no lights).
    pub photons: u32,
    /// Since the frame was submitted.
    pub elapsed: Duration,
}

/// How often a wait reports while a part runs.
const REPORT_EVERY: Duration = Duration::from_millis(150);

/// The submissions of one frame, as [`super::Renderer::submit`] made them.
#[derive(Debug)]
pub struct Submitted {
    pub parts: Vec<(Part, wgpu::SubmissionIndex)>,
    pub photons: u32,
    pub at: Instant,
}

impl Submitted {
    /// Whether the GPU has finished every part (without waiting).
    pub fn is_done(&self, device: &wgpu::Device) -> Result<bool> {
        let Some((_, last)) = self.parts.last() else { return Ok(true) };
        match device.poll(wgpu::PollType::Wait { submission_index: Some(last.clone()), timeout: Some(std::time::Duration::ZERO) }) {
            Ok(_) => Ok(true),
            Err(wgpu::PollError::Timeout) => Ok(false),
            Err(e) => bail!("polling the GPU failed: {e}"),
        }
    }

    /// Waits for each part in turn, calling `report` when a part begins, every
    /// [`REPORT_EVERY`] while it runs, and once all are done.
    pub fn wait(&self, device: &wgpu::Device, report: &mut dyn FnMut(&FrameProgress)) -> Result<()> {
        let n = self.parts.len();
        let progress = |done: usize, current: Option<Part>| FrameProgress {
            done,
            parts: n,
            current,
            photons: self.photons,
            elapsed: self.at.elapsed(),
        };
        for (done, (part, index)) in self.parts.iter().enumerate() {
            loop {
                report(&progress(done, Some(*part)));
                let wait = wgpu::PollType::Wait { submission_index: Some(index.clone()), timeout: Some(REPORT_EVERY) };
                match device.poll(wait) {
                    Ok(_) => break,
                    Err(wgpu::PollError::Timeout) => continue,
                    Err(e) => bail!("waiting for the GPU failed: {e}"),
                }
            }
        }
        report(&progress(n, None));
        Ok(())
    }
}

/// A progress line for frame `frame` (its number in a range, if any): what the GPU is on,
/// how long the frame has taken, and, from the frame before (`last`, seconds), about how long
/// is left.
pub fn progress_line(frame: Option<i64>, p: &FrameProgress, last: Option<f64>) -> String {
    let what = match frame {
        Some(k) => format!("frame {k}"),
        None => "frame".to_string(),
    };
    let doing = match p.current {
        Some(part) => format!("{} (part {} of {})", part.doing(p.photons), p.done + 1, p.parts),
        None => "reading back".to_string(),
    };
    let elapsed = p.elapsed.as_secs_f64();
    let left = match last {
        Some(total) if total > elapsed => format!(", about {:.0} s left", (total - elapsed).ceil()),
        Some(_) => ", finishing".to_string(),
        None => String::new(),
    };
    format!("{what}: {doing}, {elapsed:.0} s{left}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_line_says_the_part_the_time_and_what_is_left() {
        let p = FrameProgress { done: 1, parts: 3, current: Some(Part::Photons), photons: 70000, elapsed: Duration::from_secs_f64(12.3) };
        assert_eq!(progress_line(Some(3), &p, Some(20.0)), "frame 3: tracing 70000 photons (part 2 of 3), 12 s, about 8 s left");
        assert_eq!(progress_line(None, &p, None), "frame: tracing 70000 photons (part 2 of 3), 12 s");
        assert_eq!(progress_line(None, &p, Some(5.0)), "frame: tracing 70000 photons (part 2 of 3), 12 s, finishing");
        let done = FrameProgress { done: 3, current: None, ..p };
        assert!(progress_line(Some(3), &done, None).starts_with("frame 3: reading back"));
    }
}
