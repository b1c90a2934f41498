//! `refrakt bench`: fixed built-in scenes rendered for a number of frames, with every stage timed
//! by GPU timestamp queries, as JSON — plus the throughput of the march and view stages against
//! bare kernels on the same adapter, and (for `seed`) photon count against caustic noise.
//!
//! Speed is measured here, never asserted in tests: `tests/bench.rs` only checks that the JSON
//! is complete and every time positive.

pub mod compare;
pub mod frames;
pub mod latency;
pub mod roofline;
pub mod serve;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};
use serde::Serialize;
use serde_json::{Value, json};

use crate::frame::FrameDesc;
use crate::gpu::shaders::ShaderLibrary;
use crate::lua::Limits;
use crate::pipeline::Renderer;
use crate::render::SceneSource;
use crate::scene::eval::EvalOptions;

/// The built-in scenes: name, Lua source, what it stands for.
pub const SCENES: &[(&str, &str, &str)] = &[
    ("seed", include_str!("seed.lua"), "the paper's seed setting: ~5k-triangle glass mesh, 1024×576, 128³, 70k photons, moving object and light"),
    ("seed-dispersion", include_str!("seed.lua"), "seed with dispersive glass (Abbe number 20): every photon and camera sample spectral"),
    ("seed-sunny", include_str!("seed.lua"), "seed lit by its environment alone (the \"sunny\" sky, turning): the sky's photons and shadow rays"),
    ("heavy", include_str!("heavy.lua"), "1920×1080, 256³, 1M photons, fog, three refractive objects"),
    ("grin", include_str!("grin.lua"), "Luneburg lens and gradient slab under a sun, no mesh"),
];

/// Not a scene of its own: `--scenes watch` measures `refrakt watch`'s edit-to-image latency on
/// examples/default.lua ([`latency`]).
pub const WATCH: &str = "watch";

/// Not a scene of its own: `--scenes frames` measures `refrakt render --frames` end to end on
/// `seed`, frames on disk per second under several flows and EXR codecs ([`frames`]).
pub const FRAMES: &str = "frames";

#[derive(Clone, Debug)]
pub struct BenchOptions {
    pub scenes: Vec<String>,
    /// Tiny sizes and few frames (CI on a CPU adapter).
    pub quick: bool,
    pub frames: u32,
    /// An OBJ file for `seed` instead of the procedural pebble (e.g. the Stanford bunny).
    pub mesh: Option<PathBuf>,
    /// Also sweep photon count, volume, image size and triangle count on `seed`.
    pub scaling: bool,
    /// Also measure caustic noise against photon count on `seed`.
    pub quality: bool,
    pub adapter: Option<String>,
}

/// Median and 90th percentile of a series, milliseconds.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Spread {
    pub median: f64,
    pub p90: f64,
}

impl Spread {
    pub fn of(values: &[f64]) -> Spread {
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
        Spread { median: at(0.5), p90: at(0.9) }
    }
}

/// Loads a built-in scene (its source written to a temporary folder, since scripts run from a
/// file).
fn load_scene(name: &str, source: &str, allow_read: &[PathBuf]) -> Result<(SceneSource, tempfile::TempDir)> {
    let dir = tempfile::Builder::new().prefix(&format!("refrakt-bench-{name}-")).tempdir()?;
    let path = dir.path().join(format!("{name}.lua"));
    std::fs::write(&path, source)?;
    Ok((SceneSource::load(&path, allow_read, &Limits::default())?, dir))
}

/// Subdivision of `seed`'s procedural pebble: 20·16² = 5120 triangles, the seed's ~5k.
pub(crate) const SEED_DETAIL: u32 = 16;

/// `seed` and its dispersive twin, which share the mesh and the quality curve.
fn is_seed(name: &str) -> bool {
    name == "seed" || name == "seed-dispersion" || name == "seed-sunny"
}

/// The source of built-in scene `name` with the bench's substitutions (`seed`'s pebble made with
/// `detail`).
pub(crate) fn scene_source(name: &str, opts: &BenchOptions, detail: u32) -> Result<(String, Vec<PathBuf>)> {
    let (_, source, _) = SCENES.iter().find(|s| s.0 == name).ok_or_else(|| {
        anyhow!("no built-in scene \"{name}\" (scenes: {}, {WATCH} for the edit-to-image latency, {FRAMES} for frames on disk per second)", SCENES.iter().map(|s| s.0).collect::<Vec<_>>().join(", "))
    })?;
    let mut allow = Vec::new();
    let mut mesh = String::new();
    if is_seed(name) {
        if let Some(m) = &opts.mesh {
            let m = m.canonicalize().with_context(|| format!("--mesh {}", m.display()))?;
            allow.push(m.parent().map(Path::to_path_buf).unwrap_or_default());
            mesh = m.display().to_string();
        }
    }
    let glass = if name == "seed-dispersion" { ", abbe = 20" } else { "" };
    let source = source.replace("@MESH@", &mesh.replace('\\', "\\\\").replace('"', "\\\"")).replace("@DETAIL@", &detail.to_string()).replace("@GLASS@", glass).replace("@SKY@", if name == "seed-sunny" { "true" } else { "false" });
    Ok((source, allow))
}

/// A scene to benchmark: a built-in one by name, or a scene file (`examples/default.lua`) as it
/// is. The folder holds a built-in scene's source while it runs.
fn open_scene(name: &str, opts: &BenchOptions) -> Result<(SceneSource, Option<tempfile::TempDir>)> {
    let path = Path::new(name);
    if path.extension().is_some_and(|e| e == "lua") {
        let scene = SceneSource::load(path, &[], &Limits::default()).with_context(|| format!("bench scene {name}"))?;
        return Ok((scene, None));
    }
    let (source, allow) = scene_source(name, opts, SEED_DETAIL)?;
    let (scene, dir) = load_scene(name, &source, &allow)?;
    Ok((scene, Some(dir)))
}

/// Settings `--quick` shrinks every scene to.
fn quick_eval() -> EvalOptions {
    EvalOptions { size: Some((96, 54)), resolution: Some(32), photons: Some(4_000), samples: Some(1), ..Default::default() }
}

/// What one scene's frames measured.
struct SceneRun {
    stages: BTreeMap<&'static str, Vec<f64>>,
    gpu: Vec<f64>,
    wall: Vec<f64>,
    photon_steps: Vec<f64>,
    view_steps: Vec<f64>,
    desc: FrameDesc,
    /// The last measured frame's photons and environment shadow rays (`Renderer::light_work`).
    light_work: (crate::pipeline::photons::Budget, u32),
}

/// How long each scene renders unmeasured frames, after the first two, before its timings count.
const WARM_UP: std::time::Duration = std::time::Duration::from_secs(1);

/// Frames whose wall time (with the image read back, as `refrakt render` does) is measured.
const WALL_FRAMES: u32 = 10;

/// Renders `frames` frames of a scene (after [`WARM_UP`] of unmeasured ones) and collects the
/// timings.
///
/// GPU times come from frames submitted back to back, two in flight, without reading the image
/// back (only statistics and timestamps), as an interactive viewer would keep the GPU busy: a
/// GPU left idle between frames lowers its clocks, and the stage times would measure that.
/// Wall times come from separate frames rendered one at a time with the image read back.
fn run_scene(renderer: &mut Renderer, source: &mut SceneSource, eval: &EvalOptions, frames: u32, fps: f64) -> Result<SceneRun> {
    let mut run = SceneRun {
        stages: BTreeMap::new(),
        gpu: Vec::new(),
        wall: Vec::new(),
        photon_steps: Vec::new(),
        view_steps: Vec::new(),
        desc: source.frame_desc(0.0, eval)?,
        light_work: Default::default(),
    };
    // Unmeasured frames first: the first two compile pipelines and grow buffers, and a GPU that
    // sat idle starts at low clocks (the H200 at 345 of its 1980 MHz) and runs at speed only
    // after a moment of work — measured cold, its first scene took 2.5× as long. The moment is
    // timed from the third frame: a scene whose pipelines compile for seconds (dispersion's on a
    // fresh machine) leaves the GPU idle all that while, and timed from the first it read 3×.
    let first = source.frame_desc(0.0, eval)?;
    for _ in 0..2 {
        let ticket = renderer.submit(&first)?;
        renderer.finish_without_image(ticket)?;
    }
    let warm_up = Instant::now();
    while warm_up.elapsed() < WARM_UP {
        let ticket = renderer.submit(&first)?;
        renderer.finish_without_image(ticket)?;
    }
    let mut in_flight: Option<crate::pipeline::Ticket> = None;
    for k in 0..frames {
        let desc = source.frame_desc(k as f64 / fps, eval)?;
        let ticket = renderer.submit(&desc)?;
        if let Some(previous) = in_flight.replace(ticket) {
            renderer.finish_without_image(previous)?;
            record_gpu(&mut run, renderer);
        }
        run.desc = desc;
    }
    run.light_work = renderer.light_work(&run.desc);
    if let Some(last) = in_flight.take() {
        renderer.finish_without_image(last)?;
        record_gpu(&mut run, renderer);
    }
    for k in 0..frames.min(WALL_FRAMES) {
        let desc = source.frame_desc(k as f64 / fps, eval)?;
        let t0 = Instant::now();
        renderer.frame(&desc)?;
        run.wall.push(t0.elapsed().as_secs_f64() * 1e3);
    }
    Ok(run)
}

/// Takes the timings and step counts of the frame just finished.
fn record_gpu(run: &mut SceneRun, renderer: &Renderer) {
    let timings = &renderer.profiler.last;
    run.gpu.push(timings.iter().map(|t| t.1).sum());
    for (label, ms) in timings {
        run.stages.entry(label).or_default().push(*ms);
    }
    run.photon_steps.push(renderer.photon_stats().map_or(0.0, |s| s.steps as f64));
    run.view_steps.push(renderer.view_steps() as f64);
}

/// Why the adapter cannot render a scene at these settings (its limits), if it cannot: such a
/// scene or sweep point is reported as skipped rather than ending the benchmark.
fn beyond_adapter(renderer: &Renderer, source: &mut SceneSource, eval: &EvalOptions) -> Result<Option<String>> {
    let desc = source.frame_desc(0.0, eval)?;
    Ok(renderer.check_limits(&desc).err().map(|e| format!("{e:#}")))
}

pub(crate) fn median(v: &[f64]) -> f64 {
    Spread::of(v).median
}

/// Steps per second of a stage: median steps over median milliseconds.
fn steps_per_second(steps: &[f64], stage_ms: Option<&Vec<f64>>) -> Option<f64> {
    let ms = median(stage_ms?);
    (ms > 0.0).then(|| median(steps) / (ms * 1e-3))
}

/// A scene's settings, and (`light_work`, for a measured scene) the photons its frames trace
/// (the caustic ones and the bounce population, which is as large again by default) and the
/// environment's shadow rays per receiver hit: what the environment and bounced light cost.
fn settings_json(d: &FrameDesc, light_work: Option<(crate::pipeline::photons::Budget, u32)>) -> Value {
    let mut settings = json!({
        "size": [d.camera.width, d.camera.height],
        "volume": [d.volume.dims.x, d.volume.dims.y, d.volume.dims.z],
        "photons": d.photons,
        "samples": d.samples,
        "triangles": d.meshes.iter().map(|m| m.mesh.triangles.len()).sum::<usize>(),
        "lights": d.lights.len(),
        "fog": d.fog.is_some(),
    });
    if let Some((budget, env_rays)) = light_work {
        settings["photons_traced"] = json!({ "caustic": budget.caustic, "bounce": budget.bounce });
        settings["environment_shadow_rays"] = json!(env_rays);
    }
    settings
}

fn scene_json(name: &str, run: &SceneRun, roofline: Option<&roofline::Roofline>) -> Value {
    let stages: BTreeMap<_, _> = run.stages.iter().map(|(k, v)| (k.to_string(), Spread::of(v))).collect();
    let photon_rate = steps_per_second(&run.photon_steps, run.stages.get("march"));
    let view_rate = steps_per_second(&run.view_steps, run.stages.get("view"));
    json!({
        "name": name,
        "settings": settings_json(&run.desc, Some(run.light_work)),
        "frames": run.wall.len(),
        "stages_ms": stages,
        "gpu_ms": Spread::of(&run.gpu),
        "wall_ms": Spread::of(&run.wall),
        "gpu_fps": 1e3 / median(&run.gpu),
        "photon_steps_per_s": photon_rate,
        "view_steps_per_s": view_rate,
        "fraction_of_bare_kernels": roofline.map(|r| json!({
            "march": photon_rate.map(|p| p / r.march_steps_per_s),
            "view": view_rate.map(|v| v / r.view_steps_per_s),
        })),
    })
}

/// Caustic noise against photon count on `seed`'s first frame: RMSE of the caustic layer against
/// a reference with 64× the photons, and the photon stages' GPU time. The reference's own noise
/// adds to each point's: at 8× the photons the RMSE reads √(1 + 8/64) = 1.06× too high.
fn quality_curve(renderer: &mut Renderer, source: &mut SceneSource, eval: &EvalOptions, base: u32) -> Result<Value> {
    let at = |renderer: &mut Renderer, source: &mut SceneSource, photons: u32| -> Result<(Vec<f32>, f64)> {
        let desc = source.frame_desc(0.0, &EvalOptions { photons: Some(photons), ..eval.clone() })?;
        let image = renderer.frame(&desc)?;
        let ms = renderer.profiler.last.iter().filter(|(l, _)| matches!(*l, "photons" | "march" | "caustics")).map(|t| t.1).sum();
        Ok((image.layer("caustic").map(|l| l.data.clone()).unwrap_or_default(), ms))
    };
    let (reference, _) = at(renderer, source, base * 64)?;
    let mut points = Vec::new();
    // Up to 8×: the dispersive twin needs ~5× seed's photons for seed's noise (dispersion_cost.py).
    for factor in [0.125, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0] {
        let photons = (base as f64 * factor) as u32;
        let (caustic, ms) = at(renderer, source, photons)?;
        let rmse = (caustic.iter().zip(&reference).map(|(a, b)| ((a - b) as f64).powi(2)).sum::<f64>() / caustic.len().max(1) as f64).sqrt();
        points.push(json!({ "photons": photons, "photon_stages_ms": ms, "caustic_rmse": rmse }));
    }
    Ok(json!({ "reference_photons": base * 64, "points": points }))
}

/// One row of a scaling sweep: the settings and each stage's median time.
fn scaling_row(what: &str, run: &SceneRun) -> Value {
    json!({
        "sweep": what,
        "settings": settings_json(&run.desc, Some(run.light_work)),
        "stages_ms": run.stages.iter().map(|(k, v)| (k.to_string(), median(v))).collect::<BTreeMap<_, _>>(),
        "gpu_ms": median(&run.gpu),
    })
}

/// How each stage's time grows with one setting of `seed` (the others at their seed values):
/// photons, volume resolution, image size, and the triangle count of the procedural pebble.
fn scaling(renderer: &mut Renderer, source: &mut SceneSource, base: &EvalOptions, frames: u32, opts: &BenchOptions) -> Result<Value> {
    let mut rows = Vec::new();
    let sweeps: Vec<(&str, Vec<EvalOptions>)> = vec![
        ("photons", [17_500u32, 35_000, 70_000, 140_000, 280_000, 1_000_000, 4_000_000, 10_000_000].iter().map(|&p| EvalOptions { photons: Some(p), ..base.clone() }).collect()),
        ("volume", [64u32, 96, 128, 192, 256, 384, 512].iter().map(|&v| EvalOptions { resolution: Some(v), ..base.clone() }).collect()),
        ("image", [(512u32, 288u32), (1024, 576), (1920, 1080), (3840, 2160)].iter().map(|&s| EvalOptions { size: Some(s), ..base.clone() }).collect()),
    ];
    for (what, options) in sweeps {
        for o in options {
            if let Some(why) = beyond_adapter(renderer, source, &o)? {
                rows.push(json!({ "sweep": what, "settings": settings_json(&source.frame_desc(0.0, &o)?, None), "skipped": why }));
                continue;
            }
            let run = run_scene(renderer, source, &o, frames, 24.0)?;
            rows.push(scaling_row(what, &run));
        }
    }
    // Triangles: 20·detail² of them, from 1280 to 328k (always the pebble, even with --mesh).
    let pebble = BenchOptions { mesh: None, ..opts.clone() };
    for detail in [8u32, 16, 32, 64, 128] {
        let (text, allow) = scene_source("seed", &pebble, detail)?;
        let (mut scene, _dir) = load_scene("seed", &text, &allow)?;
        let run = run_scene(renderer, &mut scene, base, frames, 24.0)?;
        rows.push(scaling_row("triangles", &run));
    }
    Ok(Value::Array(rows))
}

/// The voxelize stage alone on the meshes: the bunny at 128³ and 100k triangles at 256³.
fn voxelize_meshes(renderer: &mut Renderer, bunny: Option<&Path>, runs: u32) -> Result<Value> {
    use crate::scene::{mesh, obj};
    use std::sync::Arc;
    let mut cases = Vec::new();
    if let Some(b) = bunny {
        cases.push(("bunny", Arc::new(obj::load(b)?), 128));
    }
    cases.push(("blob-100k", Arc::new(mesh::blob(0.5, 0.15, 1, 71)), 256));
    let mut out = Vec::new();
    for (name, m, resolution) in cases {
        let desc = crate::pipeline::voxelize_mesh::benchmark_frame(m, resolution)?;
        if let Err(why) = renderer.check_grid_limits(&desc) {
            out.push(json!({ "mesh": name, "resolution": resolution, "skipped": format!("{why:#}") }));
            continue;
        }
        if let Some(t) = crate::pipeline::voxelize_mesh::benchmark(renderer, &desc, runs)? {
            out.push(json!({
                "mesh": name, "triangles": t.triangles, "volume": [t.dims.x, t.dims.y, t.dims.z],
                "meshes_ms": t.meshes_ms, "composite_ms": t.composite_ms, "voxelize_ms": t.meshes_ms + t.composite_ms,
            }));
        }
    }
    Ok(Value::Array(out))
}

/// Runs the benchmark and returns its JSON document.
pub fn run(opts: &BenchOptions) -> Result<Value> {
    let ctx = crate::gpu::GpuContext::new(opts.adapter.as_deref())?;
    let adapter = ctx.adapter_name();
    let mut renderer = Renderer::with_shaders(ctx, ShaderLibrary::from_env())?;
    // Every stage of every frame is timed, also where a frame could reuse the last one's work.
    renderer.settings.reuse_unchanged = false;
    if !renderer.profiler.enable(&renderer.ctx) {
        bail!("the adapter \"{adapter}\" has no GPU timestamp queries, so stage times cannot be measured");
    }
    let frames = if opts.quick { opts.frames.min(3) } else { opts.frames };
    let mut scenes = Vec::new();
    let mut roof = None;
    let mut quality = Value::Null;
    let mut sweep = Value::Null;
    let mut latency = Value::Null;
    let mut frame_output = Value::Null;
    let mut serving = Value::Null;
    for name in &opts.scenes {
        if name == serve::SERVE {
            let eval = if opts.quick { quick_eval() } else { EvalOptions::default() };
            serving = serve::measure(opts, &eval, if opts.quick { 2.0 } else { 5.0 })?;
            continue;
        }
        if name == FRAMES {
            let eval = if opts.quick { quick_eval() } else { EvalOptions::default() };
            // (--quick shrinks the frames, not their count: what is measured is the flow.)
            frame_output = frames::measure(opts, &eval, opts.frames)?;
            continue;
        }
        if name == WATCH {
            let eval = if opts.quick { quick_eval() } else { EvalOptions::default() };
            latency = latency::measure(opts, &eval, frames.min(10))?;
            continue;
        }
        // (`built_in`: the folder a built-in scene is written to; None for a scene file.)
        let (mut scene, built_in) = open_scene(name, opts)?;
        let eval = if opts.quick { quick_eval() } else { EvalOptions::default() };
        if let Some(why) = beyond_adapter(&renderer, &mut scene, &eval)? {
            scenes.push(json!({ "name": name, "skipped": why }));
            continue;
        }
        let run = run_scene(&mut renderer, &mut scene, &eval, frames, 24.0)?;
        if roof.is_none() {
            let threads = if opts.quick { roofline::QUICK_THREADS } else { roofline::THREADS };
            roof = Some(roofline::measure(&mut renderer, threads, 3)?);
        }
        let mut report = scene_json(name, &run, roof.as_ref());
        if run.desc.fog.is_some() {
            // How much of the march is the radiance deposits (the light-shaft fluence): the same
            // frames without them.
            renderer.settings.never_deposit = true;
            let bare = run_scene(&mut renderer, &mut scene, &eval, frames.min(5), 24.0)?;
            renderer.settings.never_deposit = false;
            report["march_ms_without_deposits"] = json!(bare.stages.get("march").map(|v| Spread::of(v)));
        }
        if opts.quality && (is_seed(name) || built_in.is_none()) {
            // Each scene's caustic noise against its own 64× reference; `seed_quality` keeps seed's.
            let curve = quality_curve(&mut renderer, &mut scene, &eval, run.desc.photons)?;
            if name == "seed" {
                quality = curve.clone();
            }
            report["quality"] = curve;
        }
        scenes.push(report);
        if name == "seed" && opts.scaling {
            sweep = scaling(&mut renderer, &mut scene, &eval, frames.min(5), opts)?;
        }
    }
    let voxelize = if opts.quick { Value::Null } else { voxelize_meshes(&mut renderer, opts.mesh.as_deref(), 5)? };
    Ok(json!({
        "refrakt": env!("CARGO_PKG_VERSION"),
        "adapter": adapter,
        "quick": opts.quick,
        "bare_kernels": roof,
        "scenes": scenes,
        "seed_quality": quality,
        "seed_scaling": sweep,
        "voxelize": voxelize,
        "watch_latency": latency,
        "frame_output": frame_output,
        "serve": serving,
    }))
}
