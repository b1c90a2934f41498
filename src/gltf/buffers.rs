//! The bytes a glTF file points at: buffers (glTF 2.0 §3.6.1) and images (§3.8.3), each from
//! the `.glb`'s BIN chunk, a `data:` URI (base64), or a file next to the glTF file. File names
//! go through the scene's file policy (below the scene's folder or an `--allow-read` one) and
//! are recorded for `refrakt watch`. Sizes the file claims are checked against the bytes that
//! exist before anything is allocated for them.

use std::io::Read;
use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow, bail};
use base64::Engine;

use crate::lua::sandbox::FileAccess;

/// Where relative URIs resolve and how files may be read.
pub struct Location<'a> {
    /// The glTF file as the user named it, for messages.
    pub file: &'a str,
    /// Its folder: relative URIs resolve here (§2.8 "URIs").
    pub dir: &'a Path,
    pub access: &'a FileAccess,
}

impl Location<'_> {
    /// A file named by a relative URI, through the file policy.
    fn resolve(&self, uri: &str, what: &str) -> Result<PathBuf> {
        if uri.contains("://") || uri.starts_with('/') {
            bail!("{}: {what} has the URI \"{uri}\"; refrakt reads only files named relative to the glTF file", self.file);
        }
        let path = percent_decode(uri).ok_or_else(|| anyhow!("{}: {what}: the URI \"{uri}\" is not valid UTF-8 after decoding", self.file))?;
        self.access.resolve_in(self.dir, &path).map_err(|m| anyhow!("{}: {what}: {m}", self.file))
    }
}

/// §2.8: URIs are RFC 3986 references, so "my%20model.bin" names "my model.bin".
fn percent_decode(uri: &str) -> Option<String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        match (bytes[i], bytes.get(i + 1).copied().and_then(hex), bytes.get(i + 2).copied().and_then(hex)) {
            (b'%', Some(h), Some(l)) => {
                out.push((h * 16 + l) as u8);
                i += 3;
            }
            (b, _, _) => {
                out.push(b);
                i += 1;
            }
        }
    }
    String::from_utf8(out).ok()
}

/// The payload of a `data:[<mediatype>][;base64],<data>` URI, or `None` for other URIs.
fn data_uri(uri: &str) -> Option<Result<Vec<u8>, String>> {
    let rest = uri.strip_prefix("data:")?;
    let Some((header, payload)) = rest.split_once(',') else { return Some(Err("a data URI without a comma".into())) };
    if !header.ends_with(";base64") {
        return Some(Err("a data URI that is not base64-encoded".into()));
    }
    Some(base64::engine::general_purpose::STANDARD.decode(payload.trim()).map_err(|e| format!("bad base64 in a data URI: {e}")))
}

/// Reads at most `limit` bytes of a file; `Err` names the file.
fn read_file(path: &Path, limit: u64) -> std::io::Result<Vec<u8>> {
    let f = std::fs::File::open(path)?;
    let mut data = Vec::new();
    f.take(limit).read_to_end(&mut data)?;
    Ok(data)
}

/// The bytes of every buffer, each exactly `byteLength` long.
pub fn load_buffers(doc: &gltf::Document, bin: Option<&[u8]>, at: &Location) -> Result<Vec<Vec<u8>>> {
    doc.buffers()
        .map(|b| {
            let i = b.index();
            let claimed = b.length() as u64;
            let what = format!("buffers[{i}]");
            if matches!(b.source(), gltf::buffer::Source::Bin) && super::meshopt::is_fallback(&doc.as_json().buffers[i]) {
                // Stands in for meshopt-compressed views, which are decoded into buffers of
                // their own (super::meshopt); it has no bytes to read.
                return Ok(Vec::new());
            }
            let data = match b.source() {
                // §4.4.3.3: the buffer without a URI is the BIN chunk.
                gltf::buffer::Source::Bin => bin.map(<[u8]>::to_vec).ok_or_else(|| {
                    anyhow!("{}: {what} has no uri, and the file has no binary chunk to stand for it (re-export the file)", at.file)
                })?,
                gltf::buffer::Source::Uri(uri) => match data_uri(uri) {
                    Some(decoded) => decoded.map_err(|m| anyhow!("{}: {what}: {m}", at.file))?,
                    None => {
                        let path = at.resolve(uri, &what)?;
                        // Read no more than the buffer claims; a shorter file is caught below.
                        read_file(&path, claimed).map_err(|e| anyhow!("{}: {what}: cannot read {}: {e}", at.file, path.display()))?
                    }
                },
            };
            if (data.len() as u64) < claimed {
                bail!(
                    "{}: {what} claims byteLength {claimed}, but its data has only {} bytes (a truncated or missing .bin? \
                     re-export the file)",
                    at.file,
                    data.len()
                );
            }
            let mut data = data;
            data.truncate(claimed as usize);
            Ok(data)
        })
        .collect()
}

/// The encoded bytes of image `index` (PNG or JPEG), and a name for messages.
pub fn image_bytes(doc: &gltf::Document, buffers: &[Vec<u8>], index: usize, at: &Location) -> Result<Vec<u8>> {
    let image = doc.images().nth(index).ok_or_else(|| anyhow!("{}: images[{index}] does not exist", at.file))?;
    let what = format!("images[{index}]");
    match image.source() {
        gltf::image::Source::View { view, .. } => {
            let data = &buffers[view.buffer().index()];
            let (start, len) = (view.offset(), view.length());
            start
                .checked_add(len)
                .and_then(|end| data.get(start..end))
                .map(<[u8]>::to_vec)
                .ok_or_else(|| anyhow!("{}: {what}: bufferViews[{}] runs past the end of its buffer", at.file, view.index()))
        }
        gltf::image::Source::Uri { uri, .. } => match data_uri(uri) {
            Some(decoded) => decoded.map_err(|m| anyhow!("{}: {what}: {m}", at.file)),
            None => {
                let path = at.resolve(uri, &what)?;
                std::fs::read(&path).map_err(|e| anyhow!("{}: {what}: cannot read {}: {e}", at.file, path.display()))
            }
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_escapes_decode() {
        assert_eq!(percent_decode("my%20model.bin").as_deref(), Some("my model.bin"));
        assert_eq!(percent_decode("a%2").as_deref(), Some("a%2"));
    }

    #[test]
    fn data_uris_decode() {
        assert_eq!(data_uri("data:application/octet-stream;base64,AAEC").unwrap().unwrap(), vec![0, 1, 2]);
        assert!(data_uri("data:text/plain,abc").unwrap().is_err());
        assert!(data_uri("model.bin").is_none());
    }
}
