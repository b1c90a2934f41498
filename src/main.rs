//! The `refrakt` command line.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::Ordering;
use std::time::Duration;

use anyhow::Result;
use clap::{Args, Parser, Subcommand};

use refrakt::gltf::ImportOptions;
use refrakt::output::{Format, LayerSet, Layers};
use refrakt::output::png::{PngOptions, ToneMap};
use refrakt::progress::ProgressMode;
use refrakt::output::exr::{ExrCodec, ExrSettings};
use refrakt::render::{self, FrameFlow, FrameRange, RenderOptions, SceneOptions};
use refrakt::scene::eval::{EvalOptions, Region};
use refrakt::watch::{self, Moment, WatchOptions};

#[derive(Parser)]
#[command(name = "refrakt", version, about = "Render glass, water and gradient-index media with their caustics, on the GPU")]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// More log output (repeat for more).
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,
    /// Say no warnings about the scene (errors are still said).
    #[arg(short, long, global = true)]
    quiet: bool,
    /// How warnings about the scene are said: a line of text each, or a JSON object per line
    /// on stderr (`{"type": "warning", "file", "message", "subjects", "count", "at"}`).
    #[arg(long, value_name = "FORMAT", global = true, default_value = "text")]
    warnings: WarningFormat,
}

/// `--warnings`: the formats a user picks (`--quiet` is the third).
#[derive(Clone, Copy, clap::ValueEnum)]
enum WarningFormat {
    Text,
    Json,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (a .lua script or a .gltf/.glb file) to EXR/PNG frames.
    Render(Box<RenderArgs>),
    /// Bundle a scene with exactly the files it reads into one .tar.zst that renders the same
    /// anywhere (`refrakt render BUNDLE`; what refrakt-farm ships to its workers).
    Pack(Box<PackArgs>),
    /// Render a scene to a preview file, and again on every save of a file it read.
    Watch(Box<WatchArgs>),
    /// Serve an interactive page: orbit the camera, drag lights, switch layers, in a browser;
    /// re-renders on every save as `watch` does.
    Serve(Box<ServeArgs>),
    /// Print the evaluated scene of each frame as one line of JSON (nodes, camera, lights,
    /// materials, volume); no GPU needed. Schema in docs/gltf.md.
    Dump(Box<DumpArgs>),
    /// Show the GPU adapter refrakt would use, its limits, and why it was chosen.
    Info {
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// Time every stage on built-in scenes with GPU timestamps; JSON on stdout.
    Bench(BenchArgs),
}

#[derive(Args)]
struct BenchArgs {
    /// Scenes to run: built-in ones (seed, seed-dispersion, heavy, grin) or scene files (examples/default.lua);
    /// `watch` measures `refrakt watch`'s edit-to-image latency on examples/default.lua (up to
    /// 10 edits of each kind, --frames); `serve` the frames/s `refrakt serve` delivers to a
    /// WebSocket client while orbiting and while dragging a light on `seed`, and where they go.
    #[arg(long, value_delimiter = ',', default_value = "seed,heavy,grin")]
    scenes: Vec<String>,
    /// Tiny sizes and three frames (a smoke test for CPU adapters and CI).
    #[arg(long)]
    quick: bool,
    /// Measured frames per scene (after two warm-up frames).
    #[arg(long, default_value_t = 30)]
    frames: u32,
    /// An OBJ mesh for `seed` (e.g. the Stanford bunny, bunny.obj) instead of the procedural pebble.
    #[arg(long, value_name = "PATH")]
    mesh: Option<PathBuf>,
    /// Also sweep photons, volume and image size on `seed` (stage times for a scaling table).
    #[arg(long)]
    scaling: bool,
    /// Also measure caustic noise against photon count on `seed`, its twins and scene files (RMSE
    /// to 64× the photons).
    #[arg(long)]
    quality: bool,
    /// Write the JSON here as well as to stdout.
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Compare with an earlier run's JSON: print each median time's ratio, and fail when a scene,
    /// a stage or a frame flow is slower than there by more than noise.
    #[arg(long, value_name = "FILE")]
    compare: Option<PathBuf>,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args)]
struct GpuArgs {
    /// Use the adapter of this index in `refrakt info`'s list (identical GPUs have identical
    /// names), or whose name, driver or backend contains this text (also $REFRAKT_ADAPTER).
    #[arg(long, value_name = "INDEX|SUBSTRING")]
    adapter: Option<String>,
}

#[derive(Args)]
struct PackArgs {
    /// The scene: a .lua script, or a .gltf/.glb file.
    scene: PathBuf,
    /// The bundle to write, e.g. shot.tar.zst.
    #[arg(short, long, value_name = "FILE")]
    out: PathBuf,
    /// Run the scene at these frames while packing, so files a script reads only in `update`
    /// are bundled too (the range you will render).
    #[arg(long, value_name = "A..B")]
    frames: Option<FrameRange>,
    /// Run the scene at this time, seconds, while packing (without --frames).
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, conflicts_with = "frames", allow_hyphen_values = true)]
    time: f64,
    #[command(flatten)]
    scene_args: SceneArgs,
}

/// How to evaluate a scene: shared by `render`, `watch` and `dump`.
#[derive(Args)]
struct SceneArgs {
    /// Frames per second of the scene clock.
    #[arg(long, default_value_t = 24.0)]
    fps: f64,
    /// Image size, overriding the camera's, e.g. 1920x1080.
    #[arg(long, value_name = "WxH", value_parser = parse_size, allow_hyphen_values = true)]
    size: Option<(u32, u32)>,
    /// Render only this region of the frame, X,Y,W,H in pixels from its top-left corner (as
    /// Blender's border render): the images are W×H, each pixel what the whole frame has there.
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_region, allow_hyphen_values = true)]
    region: Option<Region>,
    /// Voxels along the longest side of the volume (8 to 2048), overriding the scene's.
    #[arg(long, value_name = "N", value_parser = |s: &str| parse_whole(s, 8, 2048), allow_hyphen_values = true)]
    volume: Option<u32>,
    /// Photons per frame (0 to 2^30; 1e6 is read as 1000000), overriding the scene's budget;
    /// 0 renders without caustics or light shafts. The bounce photons scale by the same factor.
    #[arg(long, value_name = "N", value_parser = |s: &str| parse_whole(s, 0, 1 << 30), allow_hyphen_values = true)]
    photons: Option<u32>,
    /// Diffuse bounces of bounced light (0 to 1024), overriding the scene's (default 4, as
    /// Cycles); 0 renders without bounced light.
    #[arg(long, value_name = "N", value_parser = |s: &str| parse_whole(s, 0, 1024), allow_hyphen_values = true)]
    bounces: Option<u32>,
    /// Camera rays per pixel (1 to 256), overriding the scene's (antialiasing).
    #[arg(long, value_name = "N", value_parser = |s: &str| parse_whole(s, 1, 256), allow_hyphen_values = true)]
    samples: Option<u32>,
    /// Use the camera node of this name, or of this index among the camera nodes (as `refrakt
    /// dump` lists them under `cameras`).
    #[arg(long, value_name = "NAME|INDEX")]
    camera: Option<String>,
    /// glTF: render the scene of this name or index (default: the file's default scene, else its first).
    #[arg(long = "scene", value_name = "NAME|INDEX")]
    gltf_scene: Option<String>,
    /// glTF: play only the animation of this name or index (default: all of the file's animations at once).
    #[arg(long, value_name = "NAME|INDEX")]
    animation: Option<String>,
    /// glTF: give meshes the materials of this KHR_materials_variants variant (by name, else index).
    #[arg(long, value_name = "NAME|INDEX")]
    variant: Option<String>,
    /// Let the scene read files below this folder too (repeatable).
    #[arg(long, value_name = "DIR")]
    allow_read: Vec<PathBuf>,
    /// Seconds a script may run per call (loading, each update) before it is stopped.
    #[arg(long, default_value_t = 10.0, value_name = "SECONDS")]
    script_timeout: f64,
    /// Memory a script may use, MiB.
    #[arg(long, default_value_t = 1024, value_name = "MIB")]
    script_memory: usize,
    /// Light the scene with this environment instead of its own: a preset (studio, sky,
    /// checker) or an equirectangular .exr/.hdr file, times INTENSITY (default 1), e.g.
    /// `studio:0.5` or `sky.hdr:2`.
    #[arg(long, value_name = "PRESET|FILE[:INTENSITY]")]
    environment: Option<String>,
}

/// How frames come out: shared by `render` and `watch`.
#[derive(Args)]
struct OutputArgs {
    /// PNG exposure in stops.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    exposure: f32,
    /// PNG tone mapping.
    #[arg(long, value_enum, default_value_t = ToneMap::Neutral)]
    tonemap: ToneMap,
    /// How to show progress.
    #[arg(long, value_enum, default_value_t = ProgressMode::Auto)]
    progress: ProgressMode,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args)]
struct RenderArgs {
    /// The scene: a .lua script, or a .gltf/.glb file (rendered with its own cameras, lights and materials).
    scene: PathBuf,
    /// Frames to render, e.g. 1..48 (inclusive); frame k is the scene at t = k / fps.
    #[arg(long, value_name = "A..B")]
    frames: Option<FrameRange>,
    /// Render a still of the scene at this time, seconds (what frame k of --frames shows at k / fps).
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, conflicts_with = "frames", allow_hyphen_values = true)]
    time: f64,
    /// Folder for the frames.
    #[arg(long, short, default_value = "render", value_name = "DIR")]
    out: PathBuf,
    /// Base name of the files (default: the scene's file name).
    #[arg(long)]
    name: Option<String>,
    /// Output formats, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "exr,png")]
    format: Vec<Format>,
    /// Skip frames whose files all exist (resume an interrupted render).
    #[arg(long)]
    skip_existing: bool,
    /// Render on several adapters at once, one renderer each, taking chunks of --chunk frames in
    /// turn: `all` (every GPU of the best kind) or indices as `refrakt info` numbers them (0,1;
    /// an index may repeat to run two renderers on one GPU).
    #[arg(long, value_name = "all|0,1,…", requires = "frames", conflicts_with = "adapter")]
    gpus: Option<String>,
    /// Frames a renderer of --gpus takes at a time.
    #[arg(long, value_name = "N", default_value_t = 8, value_parser = |s: &str| parse_whole(s, 1, 1 << 20), requires = "gpus")]
    chunk: u32,
    #[command(flatten)]
    scene_args: SceneArgs,
    #[command(flatten)]
    output: OutputArgs,
    #[command(flatten)]
    flow: FlowArgs,
}

/// How `render` takes frames from the GPU to disk.
#[derive(Args)]
struct FlowArgs {
    /// EXR compression: zip (lossless, small), zips, piz, rle (lossless), dwaa (lossy colors) or
    /// none (the least CPU: for frame rates the encoders cannot keep up with).
    #[arg(long, value_enum, default_value_t = ExrCodec::Zip)]
    exr_compression: ExrCodec,
    /// Store EXR colors as 16-bit half floats (depth stays 32-bit): half the size and time.
    #[arg(long)]
    exr_half: bool,
    /// The EXR's layers: all, or some of beauty, depth, caustic, direct, volume, indirect (comma
    /// separated): fewer make smaller files, written sooner.
    #[arg(long, value_name = "all|LAYER,…", default_value = "all")]
    layers: LayerSet,
    /// Frames on the GPU at once, each read back while the next ones render (1 to 4).
    #[arg(long, value_name = "N", default_value_t = 3, value_parser = |s: &str| parse_whole(s, 1, refrakt::pipeline::MAX_FRAMES_IN_FLIGHT as u32))]
    frames_in_flight: u32,
    /// Threads converting, encoding and writing frames side by side (default: one per core, at
    /// most 8, each holding a frame in memory; more pays on machines with more cores; 1
    /// compresses each EXR on all cores instead).
    #[arg(long, value_name = "N", value_parser = |s: &str| parse_whole(s, 1, 256))]
    writers: Option<u32>,
}

impl FlowArgs {
    fn flow(&self) -> FrameFlow {
        FrameFlow {
            frames_in_flight: self.frames_in_flight as usize,
            writers: self.writers.map_or_else(refrakt::render::frames::default_writers, |w| w as usize),
            exr: ExrSettings { codec: self.exr_compression, half: self.exr_half, parallel: false, layers: self.layers },
            split: None,
        }
    }
}

#[derive(Args)]
struct WatchArgs {
    /// The scene: a .lua script, or a .gltf/.glb file.
    scene: PathBuf,
    /// The preview file, .exr or .png, replaced by each new frame [default: render/<name>.preview.exr].
    #[arg(long, short, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Preview frame K (the scene at t = K / fps).
    #[arg(long, value_name = "K", conflicts_with_all = ["time", "frames"])]
    frame: Option<i64>,
    /// Preview the scene at this time, seconds [default: 0].
    #[arg(long, value_name = "SECONDS", conflicts_with = "frames", allow_hyphen_values = true)]
    time: Option<f64>,
    /// Render these frames into the preview, one after another, after each change.
    #[arg(long, value_name = "A..B")]
    frames: Option<FrameRange>,
    /// Keep rendering the --frames range round and round.
    #[arg(long = "loop", requires = "frames")]
    looping: bool,
    /// Render only the full frame after a change (no fast frame first).
    #[arg(long)]
    no_progressive: bool,
    /// Show a fast frame first only when the last full frame took longer than this, ms (0: always).
    #[arg(long, value_name = "MS", default_value_t = refrakt::watch::DEFAULT_FAST_FRAME_OVER.as_millis() as u64)]
    fast_frame_over: u64,
    /// Layers of an EXR preview: the beauty pass alone (quickest to read back and write), or all
    /// of them (depth, caustic, direct, volume too).
    #[arg(long, value_enum, default_value_t = Layers::Beauty)]
    layers: Layers,
    /// Milliseconds a file must stay unchanged before a change to it is taken.
    #[arg(long, value_name = "MS", default_value_t = refrakt::watch::DEFAULT_DEBOUNCE.as_millis() as u64)]
    debounce: u64,
    #[command(flatten)]
    scene_args: SceneArgs,
    #[command(flatten)]
    output: OutputArgs,
}

#[derive(Args)]
struct ServeArgs {
    /// The scene: a .lua script, or a .gltf/.glb file.
    scene: PathBuf,
    /// TCP port (0: any free one; the URL printed says which).
    #[arg(long, default_value_t = 8080)]
    port: u16,
    /// Address to listen on. Beyond loopback, the page's URL carries an access token (printed).
    #[arg(long, default_value = "127.0.0.1")]
    bind: std::net::IpAddr,
    /// Start the scene clock here, seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, allow_hyphen_values = true)]
    time: f64,
    /// Milliseconds a file must stay unchanged before a change to it is taken.
    #[arg(long, value_name = "MS", default_value_t = refrakt::watch::DEFAULT_DEBOUNCE.as_millis() as u64)]
    debounce: u64,
    /// JPEG quality of the frames sent, 1 to 100.
    #[arg(long, default_value_t = 85, value_parser = clap::value_parser!(u8).range(1..=100))]
    quality: u8,
    /// Camera rays per pixel a still view refines to, pass by pass (0: it does not refine).
    #[arg(long, value_name = "SAMPLES", default_value_t = 64)]
    refine: u32,
    /// Stop refining a still view after this many seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 120.0)]
    refine_seconds: f64,
    /// The page's public origin behind a proxy (e.g. https://render.example), taken as the
    /// page's own by the WebSocket's Origin and Host checks; may be given more than once.
    #[arg(long, value_name = "URL")]
    origin: Vec<String>,
    #[command(flatten)]
    scene_args: SceneArgs,
    #[command(flatten)]
    output: OutputArgs,
}

#[derive(Args)]
struct DumpArgs {
    /// The scene: a .lua script, or a .gltf/.glb file.
    scene: PathBuf,
    /// Frames to dump, e.g. 1..48 (inclusive); frame k is the scene at t = k / fps.
    #[arg(long, value_name = "A..B")]
    frames: Option<FrameRange>,
    /// Dump the scene at this time, seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, conflicts_with = "frames", allow_hyphen_values = true)]
    time: f64,
    #[command(flatten)]
    scene_args: SceneArgs,
}

impl SceneArgs {
    fn check(&self) -> Result<()> {
        if !(self.fps.is_finite() && self.fps > 0.0) {
            anyhow::bail!("--fps must be a positive number, got {}", self.fps);
        }
        if !(self.script_timeout.is_finite() && self.script_timeout > 0.0) {
            anyhow::bail!("--script-timeout must be a positive number of seconds");
        }
        Ok(())
    }

    /// The checked options.
    fn options(&self) -> Result<SceneOptions> {
        self.check()?;
        Ok(SceneOptions {
            fps: self.fps,
            eval: EvalOptions {
                size: self.size,
                region: self.region,
                resolution: self.volume,
                camera: self.camera.clone(),
                samples: self.samples,
                photons: self.photons,
                bounces: self.bounces,
                environment: self.environment.as_deref().map(refrakt::scene::environment::from_arg).transpose()?,
            },
            allow_read: self.allow_read.clone(),
            limits: refrakt::lua::Limits { time_budget: Duration::from_secs_f64(self.script_timeout), memory_bytes: self.script_memory << 20 },
            gltf: ImportOptions {
                scene: self.gltf_scene.clone(),
                animation: self.animation.clone(),
                variant: self.variant.clone(),
                size: self.size,
                environment_given: self.environment.is_some(),
            },
            params: Default::default(),
        })
    }
}

impl OutputArgs {
    fn png(&self) -> PngOptions {
        PngOptions { exposure: self.exposure, tonemap: self.tonemap, alpha: false }
    }
}

fn check_time(time: f64) -> Result<()> {
    if !time.is_finite() {
        anyhow::bail!("--time must be a finite number of seconds, got {time}");
    }
    Ok(())
}

/// `render`'s options, for `render` and (with its own frames) `dump`.
fn render_options(frames: Option<FrameRange>, time: f64, c: &SceneArgs) -> Result<RenderOptions> {
    check_time(time)?;
    Ok(RenderOptions {
        frames,
        time,
        out: PathBuf::from("render"),
        name: None,
        formats: vec![Format::Exr, Format::Png],
        png: PngOptions { exposure: 0.0, tonemap: ToneMap::Neutral, alpha: false },
        skip_existing: false,
        progress: ProgressMode::Auto,
        adapter: None,
        gpus: Vec::new(),
        chunk: 1,
        scene: c.options()?,
        flow: FrameFlow::default(),
    })
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let err = || format!("\"{s}\" is not a size like 1024x576");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(err)?;
    let side = |t: &str| whole_number(t.trim()).ok_or_else(err);
    let (w, h) = (side(w)?, side(h)?);
    if !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
        return Err(format!("size {s}: width and height must be from 1 to 16384"));
    }
    Ok((w as u32, h as u32))
}

fn parse_region(s: &str) -> Result<Region, String> {
    let err = || format!("\"{s}\" is not a region like 0,0,512,288 (x, y, width, height in pixels)");
    let parts: Vec<i128> = s.split(',').map(|t| whole_number(t.trim())).collect::<Option<_>>().ok_or_else(err)?;
    let [x, y, w, h] = parts[..] else { return Err(err()) };
    if x < 0 || y < 0 || x >= 16384 || y >= 16384 || !(1..=16384).contains(&w) || !(1..=16384).contains(&h) {
        return Err(format!("region {s}: x and y must be from 0, width and height from 1, all below 16384"));
    }
    Ok(Region { origin: (x as u32, y as u32), size: (w as u32, h as u32) })
}

/// A whole number as people write them: `70000`, `-1`, or `1e6` (exponent notation when the
/// value is whole).
fn whole_number(s: &str) -> Option<i128> {
    if let Ok(n) = s.parse::<i128>() {
        return Some(n);
    }
    let x: f64 = s.parse().ok()?;
    (x.is_finite() && x.fract() == 0.0 && x.abs() < 1e30).then_some(x as i128)
}

/// A count option: a whole number from `lo` to `hi`, with a message that says so.
fn parse_whole(s: &str, lo: u32, hi: u32) -> Result<u32, String> {
    let n = whole_number(s.trim()).ok_or_else(|| format!("\"{s}\" is not a whole number (from {lo} to {hi})"))?;
    if n < lo as i128 || n > hi as i128 {
        return Err(format!("{s} is out of range: it must be a whole number from {lo} to {hi}"));
    }
    Ok(n as u32)
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info { gpu } => {
            let ctx = refrakt::gpu::GpuContext::new(gpu.adapter.as_deref())?;
            print!("{}", ctx.report());
            Ok(())
        }
        Command::Bench(a) => {
            let opts = refrakt::bench::BenchOptions {
                scenes: a.scenes,
                quick: a.quick,
                frames: a.frames.max(1),
                mesh: a.mesh,
                scaling: a.scaling,
                quality: a.quality,
                adapter: a.gpu.adapter,
            };
            let report = refrakt::bench::run(&opts)?;
            let text = serde_json::to_string_pretty(&report)?;
            println!("{text}");
            if let Some(path) = &a.out {
                refrakt::output::write_atomically(path, |tmp| Ok(std::fs::write(tmp, &text)?))?;
            }
            if let Some(path) = &a.compare {
                let before: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("--compare {}: {e}", path.display()))?)
                    .map_err(|e| anyhow::anyhow!("--compare {}: not a refrakt bench JSON file: {e}", path.display()))?;
                let comparison = refrakt::bench::compare::compare(&report, &before);
                for line in &comparison.lines {
                    eprintln!("{line}");
                }
                if !comparison.regressions.is_empty() {
                    anyhow::bail!(
                        "slower than {} by more than noise:\n  {}",
                        path.display(),
                        comparison.regressions.join("\n  ")
                    );
                }
            }
            Ok(())
        }
        Command::Render(a) => {
            let opts = RenderOptions {
                out: a.out.clone(),
                name: a.name.clone(),
                formats: a.format.clone(),
                png: a.output.png(),
                skip_existing: a.skip_existing,
                progress: a.output.progress,
                adapter: a.output.gpu.adapter.clone(),
                gpus: a.gpus.as_deref().map(refrakt::gpus::parse_gpus).transpose()?.unwrap_or_default(),
                chunk: a.chunk,
                flow: a.flow.flow(),
                ..render_options(a.frames, a.time, &a.scene_args)?
            };
            render::run(&a.scene, &opts)
        }
        Command::Pack(a) => {
            check_time(a.time)?;
            let moments = a.frames.map_or(refrakt::bundle::Moments::Time(a.time), refrakt::bundle::Moments::Frames);
            if a.scene_args.environment.is_some() {
                anyhow::bail!(
                    "--environment is not packed: a bundle renders the scene's own environment (set it in the scene, or \
                     give --environment when rendering the bundle)"
                );
            }
            let packed = refrakt::bundle::pack(&a.scene, &a.scene_args.options()?, moments, &a.out)?;
            eprintln!(
                "packed {} file(s) from {} into {} ({} KiB); scene: {}",
                packed.manifest.files.len(),
                packed.root.display(),
                a.out.display(),
                packed.bytes.div_ceil(1024),
                packed.manifest.scene
            );
            for f in &packed.manifest.files {
                eprintln!("  {f}");
            }
            Ok(())
        }
        Command::Dump(a) => {
            let opts = render_options(a.frames, a.time, &a.scene_args)?;
            refrakt::dump::run(&a.scene, &opts, &mut std::io::stdout().lock())
        }
        Command::Serve(a) => {
            check_time(a.time)?;
            let opts = refrakt::serve::ServeOptions {
                scene: a.scene_args.options()?,
                bind: a.bind,
                port: a.port,
                adapter: a.output.gpu.adapter.clone(),
                debounce: Duration::from_millis(a.debounce),
                time: a.time,
                display: refrakt::serve::protocol::Display { exposure: a.output.exposure, tonemap: a.output.tonemap, quality: a.quality, ..Default::default() },
                refine: a.refine.min(1 << 16),
                refine_for: Duration::try_from_secs_f64(a.refine_seconds).map_err(|_| anyhow::anyhow!("--refine-seconds: a number of seconds, 0 or more"))?,
                origins: a.origin.iter().map(|o| o.trim_end_matches('/').to_string()).collect(),
            };
            refrakt::serve::run(&a.scene, &opts)
        }
        Command::Watch(a) => {
            let scene = a.scene_args.options()?;
            let moment = match (a.frames, a.frame, a.time) {
                (Some(frames), _, _) => Moment::Range { frames, looping: a.looping },
                (None, Some(k), _) => Moment::Frame(k),
                (None, None, t) => {
                    let t = t.unwrap_or(0.0);
                    check_time(t)?;
                    Moment::Time(t)
                }
            };
            let opts = WatchOptions {
                out: a.out.clone().unwrap_or_else(|| WatchOptions::default_out(&a.scene)),
                moment,
                png: a.output.png(),
                progress: a.output.progress,
                adapter: a.output.gpu.adapter.clone(),
                scene,
                layers: a.layers,
                progressive: !a.no_progressive,
                fast_frame_over: Duration::from_millis(a.fast_frame_over),
                debounce: Duration::from_millis(a.debounce),
            };
            watch::run(&a.scene, &opts)
        }
    }
}

fn main() -> ExitCode {
    // Mesa's Vulkan drivers complain on every start when a headless session has no runtime
    // directory; give them one. (Before any thread exists, so setting the variable is sound.)
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir()) };
    }
    let cli = Cli::parse();
    let level = match cli.verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("REFRAKT_LOG")
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(format!("refrakt={level},wgpu_core=error,wgpu_hal=off,naga=error"))),
        )
        .with_writer(std::io::stderr)
        .without_time()
        .with_target(false)
        .init();
    refrakt::warnings::set_format(match (cli.quiet, cli.warnings) {
        (true, _) => refrakt::warnings::Format::Quiet,
        (false, WarningFormat::Text) => refrakt::warnings::Format::Text,
        (false, WarningFormat::Json) => refrakt::warnings::Format::Json,
    });
    std::panic::set_hook(Box::new(|info| {
        eprintln!("refrakt: internal error (a bug in refrakt, please report it): {info}");
    }));
    // The first Ctrl-C / SIGTERM asks the command to stop after the frame in hand, and says so
    // at once (a frame can take a minute on a CPU driver); a second one exits at once, removing
    // the temporary file of a write in progress. (ctrlc runs this on a thread of its own, not
    // in the signal handler, so printing is safe.)
    let _ = ctrlc::set_handler(|| {
        if render::INTERRUPTED.swap(true, Ordering::SeqCst) {
            eprintln!("refrakt: stopping now (frames already written are whole)");
            refrakt::output::remove_temporaries_in_flight();
            std::process::exit(130);
        }
        eprintln!("refrakt: stopping after the frame in hand; press Ctrl-C again to stop now");
    });
    // `watch` ends only when interrupted, and that is its normal end: no error, but 130.
    let watching = matches!(cli.command, Command::Watch(_) | Command::Serve(_));
    match run(cli) {
        Ok(()) if watching => ExitCode::from(130),
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            if render::INTERRUPTED.load(Ordering::SeqCst) { ExitCode::from(130) } else { ExitCode::FAILURE }
        }
    }
}
