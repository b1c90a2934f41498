//! Finished frames: linear HDR layers in memory, written as multi-channel OpenEXR (for the
//! compositor) and tone-mapped sRGB PNG (for eyes). Every file is written under a temporary
//! name in its folder and renamed into place, so an interrupted render leaves only whole files
//! and a viewer watching the path never reads half of one.

pub mod exr;
pub mod png;
pub mod pool;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

/// One named layer: `channels` interleaved per pixel, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Layer {
    pub name: String,
    pub channels: Vec<String>,
    pub data: Vec<f32>,
}

impl Layer {
    pub fn new(name: &str, channels: &[&str], data: Vec<f32>) -> Self {
        Self { name: name.into(), channels: channels.iter().map(|c| c.to_string()).collect(), data }
    }
}

/// A rendered frame: the `beauty` layer (linear RGBA, alpha = coverage of refractive media)
/// first, then auxiliary layers (`depth`, …).
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub layers: Vec<Layer>,
}

impl Image {
    pub fn layer(&self, name: &str) -> Option<&Layer> {
        self.layers.iter().find(|l| l.name == name)
    }

    /// Linear RGBA of pixel (x, y) in the beauty layer.
    pub fn beauty(&self, x: u32, y: u32) -> [f32; 4] {
        let i = 4 * (y * self.width + x) as usize;
        let d = &self.layers[0].data;
        [d[i], d[i + 1], d[i + 2], d[i + 3]]
    }
}

/// Which layers a frame brings back from the GPU: all of them (for EXR frames), or the beauty
/// pass alone (what a PNG, or a preview, shows: a fifth of the readback and of the file).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Layers {
    #[default]
    All,
    Beauty,
}

/// Every layer a frame has, in the order of its planes (`pipeline::resources::plane_layer`).
pub const LAYER_NAMES: [&str; 6] = ["beauty", "depth", "caustic", "direct", "volume", "indirect"];

/// The layers an EXR frame keeps (`render --layers`): all of them by default; fewer make smaller
/// files, encoded sooner.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LayerSet(u8);

impl Default for LayerSet {
    fn default() -> Self {
        Self((1 << LAYER_NAMES.len()) - 1)
    }
}

impl LayerSet {
    pub fn contains(self, layer: &str) -> bool {
        LAYER_NAMES.iter().position(|n| *n == layer).is_some_and(|k| self.0 & (1 << k) != 0)
    }

    /// The layers the GPU must bring back for these: the beauty plane alone, or every plane.
    pub fn readback(self) -> Layers {
        if self.0 == 1 { Layers::Beauty } else { Layers::All }
    }
}

impl std::str::FromStr for LayerSet {
    type Err = String;

    /// `all`, or layer names separated by commas (`beauty,depth,caustic`).
    fn from_str(s: &str) -> Result<Self, String> {
        if s.trim() == "all" {
            return Ok(Self::default());
        }
        let mut set = 0;
        for name in s.split(',').map(str::trim) {
            let k = LAYER_NAMES
                .iter()
                .position(|n| *n == name)
                .ok_or_else(|| format!("no layer \"{name}\" (layers: all, or some of {})", LAYER_NAMES.join(", ")))?;
            set |= 1 << k;
        }
        Ok(Self(set))
    }
}

/// Output formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    Exr,
    Png,
}

impl Format {
    pub fn extension(self) -> &'static str {
        match self {
            Format::Exr => "exr",
            Format::Png => "png",
        }
    }
}

/// Writes `path` through a temporary file in the same folder and a rename.
pub fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create the output folder {}", dir.display()))?;
    let tmp = temporary_name(path);
    let _in_flight = InFlight::register(&tmp);
    let result = write(&tmp).and_then(|()| {
        std::fs::rename(&tmp, path).with_context(|| format!("cannot move {} into place", path.display()))
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Checks, before any work, that frames can be written into the folder `dir`: it is a folder
/// (or can be made, below the nearest one that exists), and a file can be created in it. Only a
/// probe file is written (and removed at once); missing folders are made when the first frame
/// is written.
pub fn check_writable_folder(dir: &Path) -> Result<()> {
    let mut existing = dir;
    while !existing.as_os_str().is_empty() && !existing.exists() {
        existing = existing.parent().unwrap_or(Path::new(""));
    }
    let existing = if existing.as_os_str().is_empty() { Path::new(".") } else { existing };
    if !existing.is_dir() {
        anyhow::bail!(
            "{} is a file, not a folder; frames need a folder (choose another --out, or move the file)",
            existing.display()
        );
    }
    let probe = temporary_name(&existing.join("refrakt-write-probe"));
    std::fs::write(&probe, b"")
        .with_context(|| format!("cannot write in {} (check its permissions, or choose another --out)", existing.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// Temporary files being written now, so that a forced exit can remove them.
static IN_FLIGHT: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Registers a temporary file for the duration of its write.
struct InFlight(PathBuf);

impl InFlight {
    fn register(tmp: &Path) -> Self {
        IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner()).push(tmp.to_path_buf());
        Self(tmp.to_path_buf())
    }
}

impl Drop for InFlight {
    fn drop(&mut self) {
        IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner()).retain(|p| p != &self.0);
    }
}

/// Removes the temporary files of writes still in progress: called before the process exits
/// without finishing them (a second Ctrl-C), so that only whole files are left.
pub fn remove_temporaries_in_flight() {
    for tmp in IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner()).drain(..) {
        let _ = std::fs::remove_file(tmp);
    }
}

/// `dir/.name.tmp-PID.ext`: hidden, unique per process, same extension (so encoders that look
/// at it still work), and recognisable for cleanup.
pub fn temporary_name(path: &Path) -> PathBuf {
    let name = path.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
    let ext = path.extension().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp-{}.{ext}", std::process::id()))
}

/// Whether a file name is one of our temporaries (for `refrakt watch` cleanup and tests).
pub fn is_temporary(name: &str) -> bool {
    name.starts_with('.') && name.contains(".tmp-")
}

/// The process id in the name of one of our temporaries, `.<stem>.tmp-<pid>.<ext>` with an
/// extension refrakt writes (exr, png, json); `None` for any other name.
pub fn temporary_owner(name: &str) -> Option<u32> {
    let rest = name.strip_prefix('.')?;
    let (stem, tail) = rest.rsplit_once(".tmp-")?;
    let (pid, ext) = tail.split_once('.')?;
    let ours = !stem.is_empty() && matches!(ext, "exr" | "png" | "json") && !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit());
    if ours { pid.parse().ok() } else { None }
}

/// A temporary younger than this may belong to a write in progress (of a process whose id
/// was reused) and is left alone.
const STALE_AFTER: std::time::Duration = std::time::Duration::from_secs(60);

/// Whether a file is a temporary that a refrakt process left behind when it was killed (`kill
/// -9`, a crash): our name pattern, its writer no longer running (`alive`), and older than a
/// write takes.
pub fn is_stale_temporary(name: &str, age: std::time::Duration, alive: impl Fn(u32) -> bool) -> bool {
    temporary_owner(name).is_some_and(|pid| pid != std::process::id() && !alive(pid) && age >= STALE_AFTER)
}

/// Whether process `pid` is running (Linux: /proc; elsewhere assumed running, so nothing is
/// removed).
fn process_alive(pid: u32) -> bool {
    if cfg!(target_os = "linux") { Path::new(&format!("/proc/{pid}")).exists() } else { true }
}

/// Removes, from the folder `dir`, the temporaries that killed refrakt processes left behind
/// ([`is_stale_temporary`]); returns how many. Whole frames are never touched.
pub fn remove_stale_temporaries(dir: &Path) -> usize {
    let Ok(entries) = std::fs::read_dir(dir) else { return 0 };
    let now = std::time::SystemTime::now();
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().to_string();
        let Ok(meta) = entry.metadata() else { continue };
        let age = meta.modified().ok().and_then(|m| now.duration_since(m).ok()).unwrap_or_default();
        if meta.is_file() && is_stale_temporary(&name, age, process_alive) && std::fs::remove_file(entry.path()).is_ok() {
            removed += 1;
        }
    }
    if removed > 0 {
        tracing::warn!("removed {removed} temporary file(s) that an interrupted refrakt left in {}", dir.display());
    }
    removed
}

/// How EXR files are stored, by purpose (see [`exr::ExrSettings`] for every choice).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ExrCompression {
    /// 32-bit floats, ZIP (lossless): small files, for frames that are kept.
    #[default]
    Small,
    /// Colors as 16-bit floats (2⁻¹¹ relative, what a preview needs; depth stays 32-bit, as 10¹⁰
    /// is beyond half floats), uncompressed, on one thread: about a fifth of ZIP's time, for a
    /// preview replaced moments later (`refrakt watch`, where the write is part of the
    /// edit-to-image time).
    Fast,
}

/// Writes the image in `format` to `path`, atomically.
pub fn write(image: &Image, format: Format, path: &Path, png: &png::PngOptions) -> Result<()> {
    write_with(image, format, path, png, ExrCompression::Small)
}

/// The file of `image` in `format`, in memory (what [`write_with`] writes).
pub fn encode(image: &Image, format: Format, png: &png::PngOptions, exr: impl Into<exr::ExrSettings>) -> Result<Vec<u8>> {
    match format {
        Format::Exr => exr::encode(image, exr.into()),
        Format::Png => png::encode(image, png),
    }
}

/// Writes `bytes` to `path` atomically (a temporary file in its folder, then a rename).
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomically(path, |tmp| std::fs::write(tmp, bytes).with_context(|| format!("cannot write {}", tmp.display())))
        .with_context(|| format!("writing {}", path.display()))
}

/// [`write`] with a choice of EXR compression.
pub fn write_with(image: &Image, format: Format, path: &Path, png: &png::PngOptions, exr: impl Into<exr::ExrSettings>) -> Result<()> {
    let bytes = encode(image, format, png, exr).with_context(|| format!("writing {}", path.display()))?;
    write_bytes(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn only_our_temporaries_of_dead_writers_are_stale() {
        let old = Duration::from_secs(3600);
        let dead = |_| false;
        assert_eq!(temporary_owner(".lens.0001.tmp-4242.exr"), Some(4242));
        assert!(is_stale_temporary(".lens.0001.tmp-4242.exr", old, dead));
        assert!(is_stale_temporary(".a.b.tmp-7.png", old, dead));
        // Someone else's hidden files, whole frames, and other extensions stay.
        for name in [".lens.tmp-notes.exr", "lens.0001.exr", ".lens.tmp-4242.blend", ".tmp-4242.exr", ".x.tmp-.exr", ".x.tmp-12a.png"] {
            assert!(!is_stale_temporary(name, old, dead), "{name}");
        }
        // A running writer's, a young one's, and this process's own stay.
        assert!(!is_stale_temporary(".lens.tmp-4242.exr", old, |_| true));
        assert!(!is_stale_temporary(".lens.tmp-4242.exr", Duration::from_secs(5), dead));
        assert!(!is_stale_temporary(&format!(".lens.tmp-{}.exr", std::process::id()), old, dead));
        // The names refrakt gives its temporaries follow the pattern.
        let tmp = temporary_name(Path::new("out/lens.0001.exr"));
        assert_eq!(temporary_owner(&tmp.file_name().unwrap().to_string_lossy()), Some(std::process::id()));
    }
}
