//! WGSL sources: one file per pipeline stage in `shaders/`, shared pieces in `shaders/shared/`.
//!
//! WGSL has no include mechanism, so a stage pulls shared code in with a line
//! `#import shared/ray.wgsl`; [`ShaderLibrary::compose`] splices each import in once, keeps a
//! map from lines of the composed text back to the file they came from, and validates the result
//! with naga so an error names `shaders/<file>.wgsl:<line>`, not a line of the spliced text.
//!
//! Release builds carry the sources inside the binary. `refrakt watch` in a development build
//! reads them from the source tree instead, so shader edits take effect without a rebuild.

use std::borrow::Cow;
use std::collections::HashSet;
use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow, bail};

macro_rules! embedded {
    ($($name:literal),* $(,)?) => {
        &[$(($name, include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/shaders/", $name)))),*]
    };
}

/// Every WGSL file under `shaders/`, embedded at build time (the list is made by `build.rs`).
const EMBEDDED: &[(&str, &str)] = include!(concat!(env!("OUT_DIR"), "/shaders.rs"));

/// Where shader text comes from.
#[derive(Clone, Debug)]
pub enum ShaderLibrary {
    Embedded,
    /// A `shaders/` folder on disk (for live editing of shaders).
    Dir(PathBuf),
}

/// A stage's source with its imports spliced in.
pub struct Composed {
    pub stage: String,
    pub code: String,
    lines: usize,
    /// (first line in `code`, file, first line in that file), in order.
    segments: Vec<(usize, String, usize)>,
}

impl Composed {
    /// Maps a 1-based line of the composed text to `file:line`.
    pub fn origin(&self, line: usize) -> String {
        let seg = self.segments.iter().rev().find(|(start, _, _)| *start <= line);
        match seg {
            Some((start, file, file_line)) => format!("shaders/{file}:{}", file_line + line - start),
            None => format!("shaders/{}.wgsl:{line}", self.stage),
        }
    }
}

/// Environment variable naming a `shaders/` folder for `refrakt watch` to read (and watch)
/// instead of the source tree's: a copy to experiment on, or the tests'.
pub const SHADER_DIR_ENV: &str = "REFRAKT_SHADERS";

impl ShaderLibrary {
    /// The folder in `$REFRAKT_SHADERS` if set, else the embedded sources: what `refrakt bench`
    /// measures, so a shader variant can be timed with the same binary.
    pub fn from_env() -> Self {
        match std::env::var_os(SHADER_DIR_ENV).filter(|d| !d.is_empty()) {
            Some(dir) => ShaderLibrary::Dir(PathBuf::from(dir)),
            None => ShaderLibrary::Embedded,
        }
    }

    /// The folder in `$REFRAKT_SHADERS` if set, else the source tree's `shaders/` when this
    /// binary runs from inside that tree (a development build: `target/…/refrakt`), else the
    /// embedded sources. A binary copied elsewhere uses what is embedded in it, even on the
    /// machine it was built on: its `watch` and its `render` must draw with the same shaders.
    pub fn for_development() -> Self {
        if let lib @ ShaderLibrary::Dir(_) = Self::from_env() {
            return lib;
        }
        let tree = Path::new(env!("CARGO_MANIFEST_DIR"));
        let exe = std::env::current_exe().unwrap_or_default();
        let dir = tree.join("shaders");
        if runs_from(&exe, tree) && dir.is_dir() { ShaderLibrary::Dir(dir) } else { ShaderLibrary::Embedded }
    }

    /// The folder to watch for shader edits, if any.
    pub fn dir(&self) -> Option<&Path> {
        match self {
            ShaderLibrary::Dir(d) => Some(d),
            ShaderLibrary::Embedded => None,
        }
    }

    fn read(&self, name: &str) -> Result<Cow<'static, str>> {
        match self {
            ShaderLibrary::Embedded => EMBEDDED
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, text)| Cow::Borrowed(*text))
                .ok_or_else(|| anyhow!("no shader named {name}")),
            ShaderLibrary::Dir(dir) => std::fs::read_to_string(dir.join(name))
                .map(Cow::Owned)
                .map_err(|e| anyhow!("cannot read shaders/{name}: {e}")),
        }
    }

    /// The stage's file with every `#import` spliced in (each file once).
    pub fn compose(&self, stage: &str) -> Result<Composed> {
        let mut out = Composed { stage: stage.to_string(), code: String::new(), lines: 0, segments: Vec::new() };
        let mut seen = HashSet::new();
        self.splice(&format!("{stage}.wgsl"), &mut out, &mut seen, 0)?;
        Ok(out)
    }

    fn splice(&self, file: &str, out: &mut Composed, seen: &mut HashSet<String>, depth: u32) -> Result<()> {
        if depth > 8 {
            bail!("shaders/{file}: imports nest deeper than 8 levels (an import cycle?)");
        }
        if !seen.insert(file.to_string()) {
            return Ok(());
        }
        let text = self.read(file)?;
        let mut pending_start: Option<usize> = None;
        for (i, line) in text.lines().enumerate() {
            if let Some(import) = line.trim().strip_prefix("#import ") {
                self.splice(import.trim(), out, seen, depth + 1)?;
                pending_start = None;
                continue;
            }
            let out_line = out.lines + 1;
            if pending_start.is_none() {
                out.segments.push((out_line, file.to_string(), i + 1));
                pending_start = Some(out_line);
            }
            out.code.push_str(line);
            out.code.push('\n');
            out.lines += 1;
        }
        Ok(())
    }

    /// Composes and validates a stage, then creates its module. Errors name file:line. With
    /// `uniforms_as_storage` (the device binds uniforms as storage buffers:
    /// `gpu::uniforms_as_storage`), the stage's uniforms are declared so (line for line: errors
    /// keep their lines).
    pub fn module(&self, device: &wgpu::Device, stage: &str, uniforms_as_storage: bool) -> Result<wgpu::ShaderModule> {
        let mut composed = self.compose(stage)?;
        if uniforms_as_storage {
            composed.code = composed.code.replace("var<uniform>", "var<storage, read>");
        }
        validate(&composed)?;
        Ok(device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(stage),
            source: wgpu::ShaderSource::Wgsl(composed.code.into()),
        }))
    }
}

/// Parses and validates composed WGSL with naga, turning the first error into
/// `shaders/<file>:<line>: <message>`.
pub fn validate(c: &Composed) -> Result<naga::Module> {
    let module = naga::front::wgsl::parse_str(&c.code).map_err(|e| {
        let at = e.location(&c.code).map(|l| c.origin(l.line_number as usize));
        anyhow!("{}: WGSL error: {}", at.unwrap_or_else(|| c.origin(1)), e.message())
    })?;
    let mut validator =
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default());
    validator.validate(&module).map_err(|e| {
        let at = e.location(&c.code).map(|l| c.origin(l.line_number as usize));
        let mut msg = e.as_inner().to_string();
        let mut src: Option<&dyn std::error::Error> = std::error::Error::source(e.as_inner());
        while let Some(s) = src {
            msg.push_str(": ");
            msg.push_str(&s.to_string());
            src = s.source();
        }
        anyhow!("{}: WGSL validation error: {msg}", at.unwrap_or_else(|| c.origin(1)))
    })?;
    Ok(module)
}

/// Whether the executable `exe` lies inside the source tree `tree` (both made canonical, so a
/// link or a relative path does not fool it).
pub fn runs_from(exe: &Path, tree: &Path) -> bool {
    match (exe.canonicalize(), tree.canonicalize()) {
        (Ok(exe), Ok(tree)) => exe.starts_with(tree),
        _ => false,
    }
}

/// Names of all stages with a WGSL file (the embedded files that are not under `shared/`).
pub fn stage_names() -> impl Iterator<Item = &'static str> {
    EMBEDDED.iter().filter(|(n, _)| !n.starts_with("shared/")).map(|(n, _)| n.trim_end_matches(".wgsl"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_binary_inside_the_tree_runs_from_it() {
        let tree = tempfile::tempdir().unwrap();
        let bin = tree.path().join("target/debug");
        std::fs::create_dir_all(&bin).unwrap();
        std::fs::write(bin.join("refrakt"), b"").unwrap();
        assert!(runs_from(&bin.join("refrakt"), tree.path()));
        let elsewhere = tempfile::tempdir().unwrap();
        std::fs::write(elsewhere.path().join("refrakt"), b"").unwrap();
        assert!(!runs_from(&elsewhere.path().join("refrakt"), tree.path()));
        // A sibling folder whose name starts like the tree's is not inside it.
        let sibling = PathBuf::from(format!("{}-copy", tree.path().display()));
        std::fs::create_dir_all(&sibling).unwrap();
        std::fs::write(sibling.join("refrakt"), b"").unwrap();
        assert!(!runs_from(&sibling.join("refrakt"), tree.path()));
        std::fs::remove_dir_all(&sibling).unwrap();
    }
}
