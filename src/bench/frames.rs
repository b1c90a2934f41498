//! `refrakt bench --scenes frames`: `refrakt render --frames` end to end — the frames of `seed`
//! rendered, read back, encoded and written to a temporary folder as `render` does — under
//! several frame flows and EXR codecs, with frames per second and where the time went.
//!
//! Each flow is one `render` run of `--frames` frames (after a warm-up run of two frames, so the
//! first one does not pay for the driver's shader compilation; none with `--quick`): frames per second counts from the first
//! frame's evaluation to the last frame's files in place; the split ([`FrameSplit`]) says which
//! part of the pipeline bounds it.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use anyhow::Result;
use serde_json::{Value, json};

use super::BenchOptions;
use crate::output::Format;
use crate::output::exr::{ExrCodec, ExrSettings};
use crate::render::{FrameFlow, FrameRange, FrameSplit, RenderOptions, SceneOptions};
use crate::scene::eval::EvalOptions;

/// One way of writing frames: formats and flow.
struct Flow {
    name: String,
    formats: Vec<Format>,
    flow: FrameFlow,
}

/// The flows measured: the previous flow's shape (two frames in flight, one writer compressing
/// each EXR on all cores), then the pipelined one with each EXR codec, half floats, and PNG alone.
fn flows(quick: bool) -> Vec<Flow> {
    let exr = |codec, half| ExrSettings { codec, half, parallel: false, layers: Default::default() };
    let pipelined = |exr| FrameFlow { exr, ..FrameFlow::default() };
    let mut flows = vec![Flow {
        name: "exr zip, 2 in flight, 1 writer (as before)".into(),
        formats: vec![Format::Exr],
        flow: FrameFlow { frames_in_flight: 2, writers: 1, ..pipelined(exr(ExrCodec::Zip, false)) },
    }];
    let codecs: &[ExrCodec] =
        if quick { &[ExrCodec::Zip, ExrCodec::None] } else { &[ExrCodec::None, ExrCodec::Rle, ExrCodec::Zips, ExrCodec::Zip, ExrCodec::Piz, ExrCodec::Dwaa] };
    for &codec in codecs {
        flows.push(Flow { name: format!("exr {}", codec_name(codec)), formats: vec![Format::Exr], flow: pipelined(exr(codec, false)) });
    }
    if !quick {
        for codec in [ExrCodec::None, ExrCodec::Zip] {
            let name = format!("exr {} half", codec_name(codec));
            flows.push(Flow { name, formats: vec![Format::Exr], flow: pipelined(exr(codec, true)) });
        }
        flows.push(Flow { name: "png".into(), formats: vec![Format::Png], flow: FrameFlow::default() });
        // Where the machine has more cores than the default writers, a writer per core.
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        if cores > FrameFlow::default().writers {
            for codec in [ExrCodec::None, ExrCodec::Zip] {
                let flow = FrameFlow { writers: cores, ..pipelined(exr(codec, false)) };
                flows.push(Flow { name: format!("exr {}, a writer per core", codec_name(codec)), formats: vec![Format::Exr], flow });
            }
        }
    }
    flows
}

fn codec_name(codec: ExrCodec) -> String {
    serde_json::to_value(codec).ok().and_then(|v| v.as_str().map(str::to_string)).unwrap_or_default()
}

/// Renders `frames` frames of the scene at `scene` with `flow`, into a fresh folder.
fn render(scene: &std::path::Path, eval: &EvalOptions, flow: &Flow, frames: u32, opts: &BenchOptions, allow_read: &[PathBuf]) -> Result<FrameSplit> {
    let out = tempfile::Builder::new().prefix("refrakt-bench-frames-").tempdir()?;
    let split = Arc::new(Mutex::new(FrameSplit::default()));
    let opts = RenderOptions {
        frames: Some(FrameRange { first: 0, last: frames as i64 - 1 }),
        time: 0.0,
        out: out.path().to_path_buf(),
        name: None,
        formats: flow.formats.clone(),
        png: Default::default(),
        skip_existing: false,
        progress: crate::progress::ProgressMode::Quiet,
        adapter: opts.adapter.clone(),
        gpus: vec![],
        chunk: 1,
        scene: SceneOptions::for_bench(eval, allow_read),
        flow: FrameFlow { split: Some(split.clone()), ..flow.flow.clone() },
    };
    crate::render::run(scene, &opts)?;
    let s = split.lock().unwrap_or_else(std::sync::PoisonError::into_inner).clone();
    Ok(s)
}

/// The part of the pipeline that bounds a run: the main thread (evaluate, submit, read back),
/// the GPU, or the writers (convert, encode and write, spread over `writers` threads).
fn bound(s: &FrameSplit, writers: usize) -> (&'static str, f64) {
    let main = s.evaluate_s + s.submit_s + s.readback_s;
    let writing = (s.convert_s + s.encode_s + s.write_s) / writers.max(1) as f64;
    let mut parts = [("main thread (evaluate + submit + readback)", main), ("GPU", s.gpu_s), ("writers (convert + encode + write)", writing)];
    parts.sort_by(|a, b| b.1.total_cmp(&a.1));
    parts[0]
}

fn flow_json(flow: &Flow, s: &FrameSplit) -> Value {
    let n = s.frames.max(1) as f64;
    let per_frame = |seconds: f64| seconds * 1e3 / n;
    let (bound, bound_s) = bound(s, flow.flow.writers);
    json!({
        "flow": flow.name,
        "formats": flow.formats.iter().map(|f| f.extension()).collect::<Vec<_>>(),
        "exr": { "compression": codec_name(flow.flow.exr.codec), "half": flow.flow.exr.half },
        "frames_in_flight": flow.flow.frames_in_flight,
        "writers": flow.flow.writers,
        "frames": s.frames,
        "seconds": s.run_s,
        "fps": s.frames as f64 / s.run_s.max(1e-9),
        "mb_per_frame": s.bytes as f64 / n / 1e6,
        "ms_per_frame": {
            "evaluate": per_frame(s.evaluate_s),
            "submit": per_frame(s.submit_s),
            "gpu_wait": per_frame(s.gpu_wait_s),
            "readback": per_frame(s.readback_s),
            "queue_wait": per_frame(s.queue_wait_s),
            "drain": per_frame(s.drain_s),
            "convert": per_frame(s.convert_s),
            "encode": per_frame(s.encode_s),
            "write": per_frame(s.write_s),
            "gpu": per_frame(s.gpu_s),
        },
        "bound": { "by": bound, "ms_per_frame": per_frame(bound_s) },
    })
}

/// What one frame of the scene costs to encode on one core with each EXR codec (and as PNG), and
/// the size of the file: the CPU a frame rate needs, whatever the GPU does.
fn encode_costs(scene: &std::path::Path, eval: &EvalOptions, opts: &BenchOptions, allow_read: &[PathBuf]) -> Result<Value> {
    let mut source = crate::render::SceneSource::load(scene, allow_read, &Default::default())?;
    let mut renderer = crate::pipeline::Renderer::new(crate::gpu::GpuContext::new(opts.adapter.as_deref())?)?;
    let image = renderer.frame(&source.frame_desc(0.0, eval)?)?;
    let time = |encode: &dyn Fn() -> Result<Vec<u8>>| -> Result<(f64, usize)> {
        let mut ms = Vec::new();
        let mut bytes = 0;
        for _ in 0..3 {
            let t0 = std::time::Instant::now();
            bytes = encode()?.len();
            ms.push(t0.elapsed().as_secs_f64() * 1e3);
        }
        Ok((super::median(&ms), bytes))
    };
    let mut rows = Vec::new();
    for codec in [ExrCodec::None, ExrCodec::Rle, ExrCodec::Zips, ExrCodec::Zip, ExrCodec::Piz, ExrCodec::Dwaa] {
        for half in [false, true] {
            let settings = ExrSettings { codec, half, parallel: false, layers: Default::default() };
            let (ms, bytes) = time(&|| crate::output::exr::encode(&image, settings))?;
            rows.push(json!({ "format": "exr", "compression": codec_name(codec), "half": half, "encode_ms": ms, "mb": bytes as f64 / 1e6 }));
        }
    }
    let (ms, bytes) = time(&|| crate::output::png::encode(&image, &Default::default()))?;
    rows.push(json!({ "format": "png", "encode_ms": ms, "mb": bytes as f64 / 1e6 }));
    Ok(json!({ "size": [image.width, image.height], "one_core": rows }))
}

/// Measures every flow on `seed` (with `--mesh` if given) and returns the JSON section.
pub fn measure(opts: &BenchOptions, eval: &EvalOptions, frames: u32) -> Result<Value> {
    let (source, allow) = super::scene_source("seed", opts, super::SEED_DETAIL)?;
    let dir = tempfile::Builder::new().prefix("refrakt-bench-frames-scene-").tempdir()?;
    let scene = dir.path().join("seed.lua");
    std::fs::write(&scene, source)?;
    let mut rows = Vec::new();
    let frames = frames.max(2);
    for flow in flows(opts.quick) {
        // A warm-up run: shader compilation, allocations, the page cache of the output folder
        // (not for --quick, a smoke test).
        if !opts.quick {
            render(&scene, eval, &flow, 2, opts, &allow)?;
        }
        let split = render(&scene, eval, &flow, frames, opts, &allow)?;
        rows.push(flow_json(&flow, &split));
    }
    Ok(json!({
        "encode": encode_costs(&scene, eval, opts, &allow)?,
        "scene": "seed",
        "settings": { "frames": frames, "cores": std::thread::available_parallelism().map_or(1, |n| n.get()) },
        "flows": rows,
    }))
}
