//! The headless GPU context: one adapter, one device, one queue — no window, no surface.
//!
//! Adapter choice is automatic (discrete GPU first, then integrated, virtual, CPU), and can be
//! overridden by `--adapter SUBSTRING|INDEX` or the `REFRAKT_ADAPTER` environment variable,
//! matched against the adapter's name, driver and backend, or counted in the ranked list of
//! usable adapters (identical GPUs have identical names). `refrakt info` prints what was found and why
//! the chosen one won.

pub mod readback;
pub mod shaders;
pub mod types;

use std::fmt::Write as _;
use std::sync::{Arc, Mutex};

use anyhow::{Result, bail};

/// Environment variable that picks an adapter, like `--adapter`.
pub const ADAPTER_ENV: &str = "REFRAKT_ADAPTER";

/// An open device plus what we learned choosing it.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
    pub features: wgpu::Features,
    /// One sentence: why this adapter was chosen.
    pub reason: String,
    /// Every adapter that was found, for `refrakt info`.
    pub candidates: Vec<wgpu::AdapterInfo>,
    /// Validation errors the device reported outside an error scope (a bug on our side if any).
    uncaptured: Arc<Mutex<Vec<String>>>,
}

/// Lower is better: the order in which device types are preferred.
fn device_rank(t: wgpu::DeviceType) -> u8 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    }
}

/// Native compute backends are preferred over GL, whose compute support is partial.
fn backend_rank(b: wgpu::Backend) -> u8 {
    match b {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
        _ => 1,
    }
}

fn matches_filter(info: &wgpu::AdapterInfo, filter: &str) -> bool {
    let f = filter.to_lowercase();
    [
        info.name.to_lowercase(),
        info.driver.to_lowercase(),
        info.driver_info.to_lowercase(),
        format!("{:?}", info.backend).to_lowercase(),
    ]
    .iter()
    .any(|s| s.contains(&f))
}

/// What to tell a user who has no usable adapter at all.
pub fn no_adapter_help() -> &'static str {
    "refrakt found no GPU adapter (Vulkan, Metal or DX12). On Linux without a GPU, install \
     Mesa's software Vulkan driver lavapipe: `sudo apt-get install mesa-vulkan-drivers \
     libvulkan1` (Debian/Ubuntu) or `sudo dnf install mesa-vulkan-drivers` (Fedora); \
     `bash scripts/setup.sh` does this for you. With a GPU, install its vendor's driver \
     with Vulkan support. `refrakt info` lists what is found."
}

/// Storage buffers one shader stage must be able to bind: what the view pass binds, the most of
/// any stage (a test in `pipeline::view` keeps them equal). WebGPU's default limit is 8, and
/// Mesa's GL drivers offer 16, so such an adapter is refused rather than failing mid-frame.
pub const STORAGE_BUFFERS_PER_STAGE: u32 = 24;

/// Uniform buffers the view pass binds (its parameters and the octree's): storage buffers too
/// where uniforms are bound as storage (`uniforms_as_storage`).
pub const UNIFORM_BUFFERS_OF_VIEW: u32 = 2;

/// Whether a device of this adapter binds the passes' uniform parameters as read-only storage
/// buffers. Mesa's lavapipe specialises a compute shader on the values its loop bounds and
/// branches read from uniform buffers ("uniform inlining") and compiles each new set of values
/// anew: every scene of another octree depth or light count cost the view a minute or more of
/// LLVM on a CPU before its first frame. Storage buffers are never inlined. On a GPU, uniforms
/// stay uniforms (their constant caches).
pub fn uniforms_as_storage(info: &wgpu::AdapterInfo) -> bool {
    info.device_type == wgpu::DeviceType::Cpu && info.backend == wgpu::Backend::Vulkan
}

/// What `adapter` lacks that refrakt needs, if anything.
fn unusable_because(adapter: &wgpu::Adapter) -> Option<String> {
    if !adapter.get_downlevel_capabilities().flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS) {
        return Some("no compute shaders".into());
    }
    let buffers = adapter.limits().max_storage_buffers_per_shader_stage;
    let needed = STORAGE_BUFFERS_PER_STAGE + if uniforms_as_storage(&adapter.get_info()) { UNIFORM_BUFFERS_OF_VIEW } else { 0 };
    (buffers < needed).then(|| format!("{buffers} storage buffers per shader stage, and refrakt's view pass binds {needed}"))
}

/// Every adapter found (for `refrakt info`), and those refrakt can use (compute shaders), best
/// first: discrete GPUs, then integrated, virtual and CPU ones, in the driver's order within
/// each kind. `--adapter N` and `--gpus` count in this order, so index 0 is the adapter refrakt
/// chooses by itself.
async fn ranked_adapters() -> Result<(Vec<wgpu::Adapter>, Vec<wgpu::AdapterInfo>)> {
    // Native compute backends first; GL (whose EGL probing is noisy and whose compute support
    // is partial) only when nothing else is there. WGPU_BACKEND overrides both.
    let instance_for = |backends: wgpu::Backends| {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::from_env().unwrap_or(backends);
        wgpu::Instance::new(desc)
    };
    let mut instance = instance_for(wgpu::Backends::PRIMARY);
    let mut adapters = instance.enumerate_adapters(wgpu::Backends::all()).await;
    if adapters.is_empty() {
        instance = instance_for(wgpu::Backends::SECONDARY);
        adapters = instance.enumerate_adapters(wgpu::Backends::all()).await;
    }
    let candidates: Vec<wgpu::AdapterInfo> = adapters.iter().map(|a| a.get_info()).collect();
    if adapters.is_empty() {
        bail!("{}", no_adapter_help());
    }
    let (mut usable, mut refused) = (Vec::new(), Vec::new());
    for a in adapters {
        match unusable_because(&a) {
            None => usable.push(a),
            Some(why) => refused.push(format!("\"{}\" ({:?}) has {why}", a.get_info().name, a.get_info().backend)),
        }
    }
    if usable.is_empty() {
        bail!("no adapter refrakt can use: {}. {}", refused.join("; "), no_adapter_help());
    }
    // A stable sort: adapters of one kind keep the driver's order (identical GPUs stay apart by index).
    usable.sort_by_key(|a| {
        let i = a.get_info();
        (device_rank(i.device_type), backend_rank(i.backend))
    });
    Ok((usable, candidates))
}

/// The adapter `filter` names: an index into the ranked list when it is a whole number below
/// its length (identical GPUs have identical names), otherwise the best adapter whose name,
/// driver or backend contains it. With an index, also the reason to report.
fn pick<'a>(usable: &'a [wgpu::Adapter], candidates: &[wgpu::AdapterInfo], f: &str, source: &str) -> Result<(&'a wgpu::Adapter, Option<String>)> {
    if let Some(i) = adapter_index(f, usable.len()) {
        return Ok((&usable[i], Some(format!("it is adapter {i} of {} (by index, {source} {f})", usable.len()))));
    }
    if let Some(a) = usable.iter().find(|a| matches_filter(&a.get_info(), f)) {
        return Ok((a, None));
    }
    let names: Vec<String> = usable.iter().enumerate().map(|(i, a)| format!("{i}: \"{}\" ({:?})", a.get_info().name, a.get_info().backend)).collect();
    let unusable = candidates.len() - usable.len();
    bail!(
        "no adapter matches {source} \"{f}\"; usable adapters: {}{}. Give an index from this list, part of one of \
         these names or backends, or unset {source} to choose automatically.",
        if names.is_empty() { "none".to_string() } else { names.join(", ") },
        if unusable > 0 { format!(" ({unusable} more without compute shaders)") } else { String::new() }
    )
}

/// `filter` as an adapter index: a whole number below `count`.
pub fn adapter_index(filter: &str, count: usize) -> Option<usize> {
    let f = filter.trim();
    if f.is_empty() || !f.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    f.parse::<usize>().ok().filter(|&i| i < count)
}

/// The usable adapters, best first (the order of `--adapter N`), as `refrakt info` lists them.
pub fn usable_adapters() -> Result<Vec<wgpu::AdapterInfo>> {
    let (usable, _) = pollster::block_on(ranked_adapters())?;
    Ok(usable.iter().map(|a| a.get_info()).collect())
}

/// `--gpus all`: the indices of every usable adapter of the best kind present (every discrete
/// GPU on a GPU machine, not the CPU driver beside them; the CPU driver on a machine without one).
pub fn all_of_best_kind(adapters: &[wgpu::AdapterInfo]) -> Vec<usize> {
    let Some(best) = adapters.first().map(|a| device_rank(a.device_type)) else { return Vec::new() };
    (0..adapters.len()).filter(|&i| device_rank(adapters[i].device_type) == best).collect()
}

impl GpuContext {
    /// Opens the best adapter, or the one `filter` (or `$REFRAKT_ADAPTER`) names.
    pub fn new(filter: Option<&str>) -> Result<Self> {
        pollster::block_on(Self::open(filter))
    }

    async fn open(filter: Option<&str>) -> Result<Self> {
        let env_filter = std::env::var(ADAPTER_ENV).ok().filter(|s| !s.trim().is_empty());
        let (filter, filter_source) = match (filter, env_filter.as_deref()) {
            (Some(f), _) => (Some(f.to_string()), "--adapter"),
            (None, Some(f)) => (Some(f.to_string()), ADAPTER_ENV),
            (None, None) => (None, ""),
        };
        let (usable, candidates) = ranked_adapters().await?;
        let (adapter, index_reason) = match &filter {
            Some(f) => pick(&usable, &candidates, f, filter_source)?,
            None => (usable.first().ok_or_else(|| anyhow::anyhow!("no adapter with compute shaders was found. {}", no_adapter_help()))?, None),
        };
        let info = adapter.get_info();
        let reason = match (&filter, index_reason) {
            (_, Some(r)) => r,
            (Some(f), None) => format!("it matches {filter_source} \"{f}\""),
            (None, None) => format!(
                "it is the most capable of {} adapter(s) found ({:?} on {:?}; discrete GPUs are \
                 preferred, then integrated, virtual and CPU ones)",
                candidates.len(),
                info.device_type,
                info.backend
            ),
        };
        // Ask for everything the adapter offers: large volumes need more than the WebGPU
        // defaults (128 MiB storage bindings, 2048³ textures are fine but buffers are not).
        let limits = adapter.limits();
        let wanted = wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS;
        let features = adapter.features() & wanted;
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("refrakt"),
                required_features: features,
                required_limits: limits.clone(),
                experimental_features: wgpu::ExperimentalFeatures::disabled(),
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            })
            .await
            .map_err(|e| anyhow::anyhow!("could not open the adapter \"{}\": {e}", info.name))?;
        let uncaptured = Arc::new(Mutex::new(Vec::new()));
        let sink = uncaptured.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            tracing::error!("GPU error: {e}");
            sink.lock().map(|mut v| v.push(e.to_string())).ok();
        }));
        Ok(Self { device, queue, info, limits, features, reason, candidates, uncaptured })
    }

    /// Whether GPU timestamp queries can time each stage.
    pub fn has_timestamps(&self) -> bool {
        self.features.contains(wgpu::Features::TIMESTAMP_QUERY)
    }

    /// Errors the device raised outside any error scope since the last call.
    pub fn take_uncaptured_errors(&self) -> Vec<String> {
        self.uncaptured.lock().map(|mut v| std::mem::take(&mut *v)).unwrap_or_default()
    }

    /// The human-readable report printed by `refrakt info`.
    pub fn report(&self) -> String {
        let i = &self.info;
        let l = &self.limits;
        let mut s = String::new();
        let _ = writeln!(s, "adapter:  {} ({:?}, {:?})", i.name, i.device_type, i.backend);
        let _ = writeln!(s, "driver:   {} {}", i.driver, i.driver_info);
        let _ = writeln!(s, "chosen because {}", self.reason);
        let _ = writeln!(s, "limits the pipeline depends on:");
        let _ = writeln!(s, "  max 3D texture side          {}", l.max_texture_dimension_3d);
        let _ = writeln!(s, "  max 2D texture side          {}", l.max_texture_dimension_2d);
        let _ = writeln!(s, "  max buffer size              {} MiB", l.max_buffer_size >> 20);
        let _ = writeln!(
            s,
            "  max storage buffer binding   {} MiB",
            l.max_storage_buffer_binding_size >> 20
        );
        let _ = writeln!(s, "  max storage textures / stage {}", l.max_storage_textures_per_shader_stage);
        let _ = writeln!(s, "  max storage buffers / stage  {}", l.max_storage_buffers_per_shader_stage);
        let _ = writeln!(s, "  max workgroup invocations    {}", l.max_compute_invocations_per_workgroup);
        let _ = writeln!(s, "  max workgroups per dimension {}", l.max_compute_workgroups_per_dimension);
        let _ = writeln!(
            s,
            "  timestamp queries            {}",
            if self.has_timestamps() { "yes (refrakt bench times each stage)" } else { "no" }
        );
        let _ = writeln!(s, "adapters found (--adapter N and --gpus count the usable ones, best first):");
        let usable = usable_adapters().unwrap_or_default();
        for c in &self.candidates {
            let mark = if c.name == i.name && c.backend == i.backend && c.device_pci_bus_id == i.device_pci_bus_id { "*" } else { " " };
            let index = usable
                .iter()
                .position(|u| u.name == c.name && u.backend == c.backend && u.device_pci_bus_id == c.device_pci_bus_id)
                .map_or("-".to_string(), |k| k.to_string());
            let bus = if c.device_pci_bus_id.is_empty() { String::new() } else { format!(", PCI {}", c.device_pci_bus_id) };
            let _ = writeln!(s, " {mark} {index:>2}  {} ({:?}, {:?}, {}{bus})", c.name, c.device_type, c.backend, c.driver);
        }
        s
    }

    /// A short one-line description, for logs and benchmark JSON.
    pub fn adapter_name(&self) -> String {
        format!("{} ({:?}, {})", self.info.name, self.info.backend, self.info.driver_info)
    }
}
