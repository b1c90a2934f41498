//! Finished frames: linear HDR layers in memory, written as multi-channel OpenEXR (for the
//! compositor) and tone-mapped sRGB PNG (for eyes). Every file is written under a temporary
//! name in its folder and renamed into place, so an interrupted render leaves only whole files
//! and a viewer watching the path never reads half of one.

pub mod exr;
pub mod png;

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

/// How EXR files are stored.
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

/// [`write`] with a choice of EXR compression.
pub fn write_with(image: &Image, format: Format, path: &Path, png: &png::PngOptions, exr: ExrCompression) -> Result<()> {
    write_atomically(path, |tmp| match format {
        Format::Exr => exr::write(image, tmp, exr),
        Format::Png => png::write(image, tmp, png),
    })
    .with_context(|| format!("writing {}", path.display()))
}
