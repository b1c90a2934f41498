//! The `refrakt` command line.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::Ordering;
use std::time::Duration;

use anyhow::Result;
use clap::{Args, Parser, Subcommand};

use refrakt::gltf::ImportOptions;
use refrakt::output::Format;
use refrakt::output::png::{PngOptions, ToneMap};
use refrakt::progress::ProgressMode;
use refrakt::render::{self, FrameRange, RenderOptions};
use refrakt::scene::eval::EvalOptions;

#[derive(Parser)]
#[command(name = "refrakt", version, about = "Render glass, water and gradient-index media with their caustics, on the GPU")]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// More log output (repeat for more).
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (a .lua script or a .gltf/.glb file) to EXR/PNG frames.
    Render(Box<RenderArgs>),
    /// Print the evaluated scene of each frame as one line of JSON (nodes, camera, lights,
    /// materials, volume); no GPU needed. Schema in docs/gltf.md.
    Dump(Box<SceneArgs>),
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
    /// Scenes to run: built-in ones (seed, heavy, grin) or scene files (examples/default.lua).
    #[arg(long, value_delimiter = ',', default_value = "seed,heavy,grin")]
    scenes: Vec<String>,
    /// Tiny sizes and three frames (a smoke test for CPU adapters and CI).
    #[arg(long)]
    quick: bool,
    /// Measured frames per scene (after two warm-up frames).
    #[arg(long, default_value_t = 30)]
    frames: u32,
    /// An OBJ mesh for `seed` (e.g. ../shared/assets/bunny.obj) instead of the procedural pebble.
    #[arg(long, value_name = "PATH")]
    mesh: Option<PathBuf>,
    /// Also sweep photons, volume and image size on `seed` (stage times for a scaling table).
    #[arg(long)]
    scaling: bool,
    /// Also measure caustic noise against photon count on `seed` (RMSE to 64× the photons).
    #[arg(long)]
    quality: bool,
    /// Write the JSON here as well as to stdout.
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Print the ratio of each median time to the ones in an earlier JSON.
    #[arg(long, value_name = "FILE")]
    compare: Option<PathBuf>,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args)]
struct GpuArgs {
    /// Use the adapter whose name, driver or backend contains this text (also $REFRAKT_ADAPTER).
    #[arg(long, value_name = "SUBSTRING")]
    adapter: Option<String>,
}

/// What picks the scene and the frames: shared by `render` and `dump`.
#[derive(Args)]
struct SceneArgs {
    /// The scene: a .lua script, or a .gltf/.glb file (rendered with its own cameras, lights and materials).
    scene: PathBuf,
    /// Frames to render, e.g. 1..48 (inclusive); frame k is the scene at t = k / fps.
    #[arg(long, value_name = "A..B")]
    frames: Option<FrameRange>,
    /// Frames per second of the scene clock.
    #[arg(long, default_value_t = 24.0)]
    fps: f64,
    /// Render a still of the scene at this time, seconds (what frame k of --frames shows at k / fps).
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, conflicts_with = "frames", allow_hyphen_values = true)]
    time: f64,
    /// Image size, overriding the camera's, e.g. 1920x1080.
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    size: Option<(u32, u32)>,
    /// Voxels along the longest side of the volume, overriding the scene's.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(8..=2048))]
    volume: Option<u32>,
    /// Photons per frame, overriding the scene's budget.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=(1 << 30)))]
    photons: Option<u32>,
    /// Camera rays per pixel, overriding the scene's (antialiasing).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=256))]
    samples: Option<u32>,
    /// Use the node of this name that carries a camera.
    #[arg(long)]
    camera: Option<String>,
    /// glTF: render the scene of this name (default: the file's default scene, else its first).
    #[arg(long = "scene", value_name = "NAME")]
    gltf_scene: Option<String>,
    /// glTF: play only the animation of this name (default: all of the file's animations at once).
    #[arg(long, value_name = "NAME")]
    animation: Option<String>,
    /// Let the scene read files below this folder too (repeatable).
    #[arg(long, value_name = "DIR")]
    allow_read: Vec<PathBuf>,
    /// Seconds a script may run per call (loading, each update) before it is stopped.
    #[arg(long, default_value_t = 10.0, value_name = "SECONDS")]
    script_timeout: f64,
    /// Memory a script may use, MiB.
    #[arg(long, default_value_t = 1024, value_name = "MIB")]
    script_memory: usize,
}

#[derive(Args)]
struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Folder for the frames.
    #[arg(long, short, default_value = "render", value_name = "DIR")]
    out: PathBuf,
    /// Base name of the files (default: the scene's file name).
    #[arg(long)]
    name: Option<String>,
    /// Output formats, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "exr,png")]
    format: Vec<Format>,
    /// PNG exposure in stops.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    exposure: f32,
    /// PNG tone mapping.
    #[arg(long, value_enum, default_value_t = ToneMap::Neutral)]
    tonemap: ToneMap,
    /// Skip frames whose files all exist (resume an interrupted render).
    #[arg(long)]
    skip_existing: bool,
    /// How to show progress.
    #[arg(long, value_enum, default_value_t = ProgressMode::Auto)]
    progress: ProgressMode,
    #[command(flatten)]
    gpu: GpuArgs,
}

/// The options `render` and `dump` share, checked; render-only ones at their defaults.
fn scene_options(a: SceneArgs) -> Result<(PathBuf, RenderOptions)> {
    if !(a.fps.is_finite() && a.fps > 0.0) {
        anyhow::bail!("--fps must be a positive number, got {}", a.fps);
    }
    if !a.time.is_finite() {
        anyhow::bail!("--time must be a finite number of seconds, got {}", a.time);
    }
    if !(a.script_timeout.is_finite() && a.script_timeout > 0.0) {
        anyhow::bail!("--script-timeout must be a positive number of seconds");
    }
    let opts = RenderOptions {
        frames: a.frames,
        fps: a.fps,
        time: a.time,
        out: PathBuf::from("render"),
        name: None,
        formats: vec![Format::Exr, Format::Png],
        eval: EvalOptions { size: a.size, resolution: a.volume, camera: a.camera, samples: a.samples, photons: a.photons },
        png: PngOptions { exposure: 0.0, tonemap: ToneMap::Neutral, alpha: false },
        skip_existing: false,
        progress: ProgressMode::Auto,
        adapter: None,
        allow_read: a.allow_read,
        limits: refrakt::lua::Limits {
            time_budget: Duration::from_secs_f64(a.script_timeout),
            memory_bytes: a.script_memory << 20,
        },
        gltf: ImportOptions { scene: a.gltf_scene, animation: a.animation },
    };
    Ok((a.scene, opts))
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let err = || format!("\"{s}\" is not a size like 1024x576");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(err)?;
    let (w, h): (u32, u32) = (w.trim().parse().map_err(|_| err())?, h.trim().parse().map_err(|_| err())?);
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("size {s}: width and height must be from 1 to 16384"));
    }
    Ok((w, h))
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
                for line in refrakt::bench::compare(&report, &before) {
                    eprintln!("{line}");
                }
            }
            Ok(())
        }
        Command::Render(a) => {
            let a = *a;
            let (scene, base) = scene_options(a.scene)?;
            let opts = RenderOptions {
                out: a.out,
                name: a.name,
                formats: a.format,
                png: PngOptions { exposure: a.exposure, tonemap: a.tonemap, alpha: false },
                skip_existing: a.skip_existing,
                progress: a.progress,
                adapter: a.gpu.adapter,
                ..base
            };
            render::run(&scene, &opts)
        }
        Command::Dump(a) => {
            let (scene, opts) = scene_options(*a)?;
            refrakt::dump::run(&scene, &opts, &mut std::io::stdout().lock())
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
    std::panic::set_hook(Box::new(|info| {
        eprintln!("refrakt: internal error (a bug in refrakt, please report it): {info}");
    }));
    let _ = ctrlc::set_handler(|| {
        if render::INTERRUPTED.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
    });
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            if render::INTERRUPTED.load(Ordering::SeqCst) { ExitCode::from(130) } else { ExitCode::FAILURE }
        }
    }
}
