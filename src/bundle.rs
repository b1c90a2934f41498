//! Scene bundles: `refrakt pack SCENE -o shot.tar.zst` collects exactly the files a scene reads
//! (the list `refrakt watch` watches: script, modules, meshes, images, glTF buffers) into one
//! zstd-compressed tar archive with their relative layout, and `refrakt render shot.tar.zst`
//! renders it. A bundle renders the same frames anywhere, which is what a render farm ships to
//! its workers (see `farm/`).
//!
//! Layout: `refrakt-bundle.json` (the manifest: format, the scene's path, the files) first,
//! then every file below the folder that holds all of them, as plain files with fixed owner,
//! mode and time, in name order, so packing the same scene twice gives the same bytes.
//!
//! Unpacking trusts nothing in the archive: only plain files and folders, only relative paths
//! with no `..`, no links, no repeats, and caps on the number of files and on each file's and
//! the whole bundle's unpacked size (a small archive cannot fill the disk).

use std::io::{Read, Write};
use std::path::{Component, Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use serde::{Deserialize, Serialize};

use crate::render::{FrameRange, SceneOptions};

/// The manifest's name inside a bundle.
pub const MANIFEST: &str = "refrakt-bundle.json";
/// The manifest format written and read.
const FORMAT: u32 = 1;
/// Caps on what a bundle may unpack to.
pub const MAX_FILES: usize = 10_000;
pub const MAX_FILE_BYTES: u64 = 4 << 30;
pub const MAX_TOTAL_BYTES: u64 = 16 << 30;
/// The longest path a bundle may name.
const MAX_PATH_BYTES: usize = 1024;

/// What a bundle holds.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Manifest {
    pub format: u32,
    /// The scene file, relative to the bundle's root (`/`-separated).
    pub scene: String,
    /// Every file in the bundle, the scene included, relative to its root.
    pub files: Vec<String>,
}

/// Whether `path` names a bundle (`.tar.zst`), as opposed to a scene file.
pub fn is_bundle(path: &Path) -> bool {
    path.file_name().is_some_and(|n| n.to_string_lossy().to_lowercase().ends_with(".tar.zst"))
}

/// Which moments of the scene to run while packing: files a script reads only in `update`
/// are found by running it at those times.
#[derive(Clone, Copy, Debug)]
pub enum Moments {
    Frames(FrameRange),
    Time(f64),
}

/// What `pack` put in the bundle.
#[derive(Debug)]
pub struct Packed {
    pub manifest: Manifest,
    /// The folder the bundle's paths are relative to.
    pub root: PathBuf,
    pub bytes: u64,
}

/// Loads the scene (refusing, as rendering would, any read outside its folder and the
/// `--allow-read` ones), runs it at `moments`, and writes the files it read to `out`.
pub fn pack(scene_path: &Path, scene: &SceneOptions, moments: Moments, out: &Path) -> Result<Packed> {
    if is_bundle(scene_path) {
        bail!("{} is already a bundle; pack the scene it came from", scene_path.display());
    }
    let files = files_read(scene_path, scene, moments)?;
    let script = scene_path.canonicalize().with_context(|| format!("cannot open {}", scene_path.display()))?;
    let root = common_folder(files.iter().chain([&script]))?;
    let relative = |p: &Path| -> Result<String> { bundle_path(p.strip_prefix(&root).expect("below the common folder")) };
    let manifest = Manifest { format: FORMAT, scene: relative(&script)?, files: files.iter().map(|p| relative(p)).collect::<Result<_>>()? };
    if manifest.files.len() > MAX_FILES {
        bail!("the scene reads {} files; a bundle holds at most {MAX_FILES}", manifest.files.len());
    }
    crate::output::write_atomically(out, |tmp| write_archive(tmp, &manifest, &root))
        .map_err(|e| anyhow!("-o {}: {e:#}", out.display()))?;
    let bytes = std::fs::metadata(out).map(|m| m.len()).unwrap_or(0);
    Ok(Packed { manifest, root, bytes })
}

/// Every existing file the scene read at `moments`, canonical, sorted, the scene itself included.
fn files_read(scene_path: &Path, scene: &SceneOptions, moments: Moments) -> Result<Vec<PathBuf>> {
    let mut source = scene.load(scene_path)?;
    let times: Vec<f64> = match moments {
        Moments::Frames(r) => (r.first..=r.last).map(|k| k as f64 / scene.fps).collect(),
        Moments::Time(t) => vec![t],
    };
    for t in times {
        source.frame_desc(t, &scene.eval).with_context(|| format!("{} at t = {t:.4} s", scene_path.display()))?;
    }
    let mut files: Vec<PathBuf> = source.files_read().into_iter().filter(|p| p.is_file()).collect();
    files.push(scene_path.canonicalize()?);
    files.sort();
    files.dedup();
    Ok(files)
}

/// The deepest folder holding every one of `files`.
fn common_folder<'a>(files: impl Iterator<Item = &'a PathBuf>) -> Result<PathBuf> {
    let mut common: Option<PathBuf> = None;
    for f in files {
        let dir = f.parent().ok_or_else(|| anyhow!("{} has no folder", f.display()))?;
        common = Some(match common {
            None => dir.to_path_buf(),
            Some(c) => c.components().zip(dir.components()).take_while(|(a, b)| a == b).map(|(a, _)| a).collect(),
        });
    }
    common.ok_or_else(|| anyhow!("the scene read no files"))
}

/// A relative path as a bundle names it: `/`-separated plain names.
fn bundle_path(relative: &Path) -> Result<String> {
    let parts: Vec<&str> = relative
        .components()
        .map(|c| match c {
            Component::Normal(s) => s.to_str().ok_or_else(|| anyhow!("{} is not a UTF-8 path", relative.display())),
            _ => Err(anyhow!("{} is not a plain relative path", relative.display())),
        })
        .collect::<Result<_>>()?;
    Ok(parts.join("/"))
}

fn write_archive(tmp: &Path, manifest: &Manifest, root: &Path) -> Result<()> {
    let file = std::fs::File::create(tmp)?;
    let mut tar = tar::Builder::new(zstd::Encoder::new(file, 19)?);
    let json = serde_json::to_vec_pretty(manifest)?;
    append(&mut tar, MANIFEST, &mut json.as_slice(), json.len() as u64)?;
    for name in &manifest.files {
        let path = root.join(name);
        let mut f = std::fs::File::open(&path).with_context(|| format!("cannot read {}", path.display()))?;
        let len = f.metadata()?.len();
        if len > MAX_FILE_BYTES {
            bail!("{} is {} MiB; a bundle holds files of at most {} MiB", path.display(), len >> 20, MAX_FILE_BYTES >> 20);
        }
        append(&mut tar, name, &mut f, len)?;
    }
    tar.into_inner()?.finish()?.sync_all()?;
    Ok(())
}

/// One plain file with fixed metadata (bundles of the same files are the same bytes).
fn append<W: Write>(tar: &mut tar::Builder<W>, name: &str, data: &mut impl Read, len: u64) -> Result<()> {
    let mut header = tar::Header::new_gnu();
    header.set_size(len);
    header.set_mode(0o644);
    header.set_mtime(0);
    header.set_entry_type(tar::EntryType::Regular);
    tar.append_data(&mut header, name, data.take(len))?;
    Ok(())
}

/// A bundle unpacked into a temporary folder, removed when this is dropped.
pub struct Unpacked {
    dir: tempfile::TempDir,
    pub manifest: Manifest,
}

impl Unpacked {
    /// The folder every bundled path is relative to.
    pub fn root(&self) -> &Path {
        self.dir.path()
    }

    /// The scene file, unpacked.
    pub fn scene(&self) -> PathBuf {
        self.dir.path().join(&self.manifest.scene)
    }
}

/// Unpacks `bundle` into a new temporary folder, checking every entry (see the module's notes).
pub fn unpack(bundle: &Path) -> Result<Unpacked> {
    let shown = bundle.display();
    let file = std::fs::File::open(bundle).with_context(|| format!("cannot open the bundle {shown}"))?;
    let dir = tempfile::Builder::new().prefix("refrakt-bundle-").tempdir().context("cannot make a folder to unpack the bundle in")?;
    let decoder = zstd::Decoder::new(file).with_context(|| format!("{shown}: not a zstd-compressed bundle"))?;
    // Tar's headers and padding come on top of the files' bytes: a little slack beyond the cap.
    let mut archive = tar::Archive::new(decoder.take(MAX_TOTAL_BYTES + (MAX_FILES as u64 + 2) * 1024));
    let mut total = 0u64;
    let mut names = std::collections::BTreeSet::new();
    let mut manifest = None;
    for entry in archive.entries().with_context(|| format!("{shown}: not a refrakt bundle (a .tar.zst made by refrakt pack)"))? {
        let mut entry = entry.with_context(|| format!("{shown}: damaged or truncated bundle"))?;
        let kind = entry.header().entry_type();
        let name = checked_name(&entry.path_bytes()).map_err(|e| anyhow!("{shown}: {e}"))?;
        if kind.is_dir() {
            continue;
        }
        if !kind.is_file() {
            bail!("{shown}: \"{name}\" is not a plain file ({kind:?}); bundles hold only files and folders");
        }
        let size = entry.header().size()?;
        total = total.saturating_add(size);
        if size > MAX_FILE_BYTES || total > MAX_TOTAL_BYTES {
            bail!("{shown}: \"{name}\" takes the bundle past its caps ({} MiB a file, {} MiB in all)", MAX_FILE_BYTES >> 20, MAX_TOTAL_BYTES >> 20);
        }
        if !names.insert(name.clone()) || names.len() > MAX_FILES + 1 {
            bail!("{shown}: \"{name}\" is in the bundle twice, or the bundle has more than {MAX_FILES} files");
        }
        if name == MANIFEST {
            let mut text = String::new();
            entry.read_to_string(&mut text).with_context(|| format!("{shown}: cannot read its {MANIFEST}"))?;
            manifest = Some(serde_json::from_str::<Manifest>(&text).with_context(|| format!("{shown}: its {MANIFEST} is not a bundle manifest"))?);
            continue;
        }
        write_entry(&mut entry, &dir.path().join(&name), size).with_context(|| format!("{shown}: cannot unpack \"{name}\""))?;
    }
    let manifest = manifest.ok_or_else(|| anyhow!("{shown}: not a refrakt bundle (it has no {MANIFEST}; make bundles with refrakt pack)"))?;
    if manifest.format != FORMAT {
        bail!("{shown}: bundle format {} (this refrakt reads format {FORMAT}); pack the scene again with this refrakt", manifest.format);
    }
    checked_name(manifest.scene.as_bytes()).map_err(|e| anyhow!("{shown}: its scene path: {e}"))?;
    if !names.contains(&manifest.scene) {
        bail!("{shown}: its manifest names the scene \"{}\", which the bundle does not hold", manifest.scene);
    }
    Ok(Unpacked { dir, manifest })
}

/// An entry's path, if it is a plain relative one: UTF-8, no `..`, no root, not too long.
fn checked_name(raw: &[u8]) -> Result<String> {
    let name = std::str::from_utf8(raw).map_err(|_| anyhow!("a path in it is not UTF-8"))?;
    let trimmed = name.trim_end_matches('/');
    let plain = !trimmed.is_empty()
        && trimmed.len() <= MAX_PATH_BYTES
        && !trimmed.contains(['\\', '\0'])
        && trimmed.split('/').all(|p| !p.is_empty() && p != "." && p != "..")
        && !trimmed.starts_with('/');
    if !plain {
        bail!("\"{name}\" is not a plain relative path (no \"..\", no leading \"/\"); refusing to unpack it");
    }
    Ok(trimmed.to_string())
}

/// Writes one file of at most `size` bytes at `path` (which must not exist yet).
fn write_entry(entry: &mut impl Read, path: &Path, size: u64) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    let mut out = std::fs::OpenOptions::new().write(true).create_new(true).open(path)?;
    let copied = std::io::copy(&mut entry.take(size), &mut out)?;
    if copied != size {
        bail!("the bundle ends inside it ({copied} of {size} bytes)");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_that_leave_the_folder_are_refused() {
        for bad in ["../x.lua", "a/../../x", "/etc/passwd", "a//b", "./a", "", "a\\..\\b"] {
            assert!(checked_name(bad.as_bytes()).is_err(), "{bad:?} accepted");
        }
        assert_eq!(checked_name(b"lib/util.lua").unwrap(), "lib/util.lua");
        assert_eq!(checked_name(b"meshes/").unwrap(), "meshes");
    }

    #[test]
    fn the_common_folder_is_the_deepest_shared_one() {
        let files = [PathBuf::from("/a/b/c/scene.lua"), PathBuf::from("/a/b/assets/x.obj"), PathBuf::from("/a/b/c/lib/m.lua")];
        assert_eq!(common_folder(files.iter()).unwrap(), PathBuf::from("/a/b"));
    }
}
