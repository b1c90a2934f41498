//! Motion blur in `refrakt render`: a frame whose scene has a shutter ([`MotionBlur`]) is the
//! scene rendered at instants across the shutter interval, averaged on the GPU.
//!
//! Each instant is a frame of the pipeline of its own — the scene evaluated at its time, the
//! volume built and the photons traced for it — whose view adds its camera samples to the
//! planes the instant before left ([`Renderer::instant`]): the planes end as the mean over all
//! the frame's samples, nothing is read back before the last instant. An instant takes its
//! share of the frame's camera samples and photons, its photons drawn with a seed of its own
//! (so the instants together trace as many different photons as a still; the same seeds every
//! frame, so a still scene does not flicker).

use anyhow::{Context, Result};

use super::SceneSource;
use crate::frame::FrameDesc;
use crate::pipeline::{Renderer, Ticket};
use crate::scene::MotionBlur;
use crate::scene::eval::EvalOptions;

/// Submits the motion-blurred frame at `t` (whose description at `t` says how): every instant
/// but the last is rendered and waited for; the last's ticket is the frame's.
pub fn submit(renderer: &mut Renderer, source: &mut SceneSource, eval: &EvalOptions, blur: MotionBlur, t: f64, fps: f64) -> Result<Ticket> {
    let seed = renderer.settings.photon_seed;
    let result = (|| {
        let mut last = None;
        for (k, instant) in blur.instants(t, fps).enumerate() {
            if let Some(ticket) = last.take() {
                renderer.finish_without_image(ticket)?;
            }
            // An error names the instant: a script may fail at a time the frame itself is not.
            let at = || format!("motion blur: instant {} of {} (t = {instant:.4} s)", k + 1, blur.steps);
            let desc = share(source.frame_desc(instant, eval).with_context(at)?, blur.steps);
            renderer.instant = Some((k as u32, blur.steps));
            renderer.settings.photon_seed = instant_seed(seed, k as u32);
            last = Some(renderer.submit(&desc).with_context(at)?);
        }
        Ok(last.expect("a motion-blurred frame has instants"))
    })();
    renderer.instant = None;
    renderer.settings.photon_seed = seed;
    result
}

/// One instant's share of the frame's camera samples and photons.
fn share(mut desc: FrameDesc, steps: u32) -> FrameDesc {
    desc.samples = desc.samples.div_ceil(steps).max(1);
    desc.photons = desc.photons.div_ceil(steps);
    desc.bounce_photons = desc.bounce_photons.div_ceil(steps);
    desc
}

/// The photon seed of instant `k` (instant 0 keeps the frame's).
fn instant_seed(seed: u32, k: u32) -> u32 {
    seed.wrapping_add(k.wrapping_mul(0x9e37_79b9))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The instants are the midpoints of equal parts of the shutter interval, centred on the
    /// frame's time (Blender's position Center).
    #[test]
    fn instants_split_the_shutter_interval_around_the_frame() {
        let blur = MotionBlur { shutter: 0.5, steps: 4 };
        let got: Vec<f64> = blur.instants(1.0, 25.0).collect();
        let open = 0.5 / 25.0;
        let want: Vec<f64> = [-0.375, -0.125, 0.125, 0.375].iter().map(|f| 1.0 + f * open).collect();
        assert!(got.iter().zip(&want).all(|(a, b)| (a - b).abs() < 1e-12), "{got:?} vs {want:?}");
        assert_eq!(MotionBlur::of(0.0, 8), None);
        assert_eq!(MotionBlur::of(0.5, 1), None);
        let seeds: std::collections::HashSet<u32> = (0..64).map(|k| instant_seed(7, k)).collect();
        assert_eq!(seeds.len(), 64, "each instant draws photons of its own");
    }
}
