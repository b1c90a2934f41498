//! Image headers checked before any pixel memory is allocated.
//!
//! A decoder allocates what the header claims: an 8×4 EXR whose `dataWindow` says 200000²
//! asks for 640 GB, and a 373-byte file that says 16384×8192 holds 2 GB for seconds before it
//! fails on the missing pixels. So every image a scene reads (environment `.exr`/`.hdr`, glTF
//! textures in PNG or JPEG) has its header read first and is refused, with one message, when
//! it is larger than the documented caps ([`ENVIRONMENT`], [`TEXTURE`]) or when the file is too
//! short to hold the pixels it declares.

use std::io::{BufRead, Read};
use std::path::Path;

use anyhow::{Context, Result, anyhow, bail};

/// The largest image refrakt decodes for one purpose.
#[derive(Clone, Copy, Debug)]
pub struct Caps {
    /// Texels along either side.
    pub max_side: u64,
    /// The largest image in texels, as width × height: its area is the most texels in all (what
    /// sets the memory: 16 bytes each once decoded to float RGBA).
    pub max_image: (u64, u64),
}

/// Environment images: up to the 16K equirectangular images sold as "16K HDRI" (16384×8192,
/// 2 GiB as float RGBA).
pub const ENVIRONMENT: Caps = Caps { max_side: 16384, max_image: (16384, 8192) };

/// glTF textures: up to 8192×8192 (1 GiB as float RGBA).
pub const TEXTURE: Caps = Caps { max_side: 8192, max_image: (8192, 8192) };

impl Caps {
    /// The most texels an image may have in all.
    pub const fn max_texels(&self) -> u64 {
        self.max_image.0 * self.max_image.1
    }

    /// Refuses a declared size beyond these caps.
    pub fn check(&self, width: u64, height: u64) -> Result<()> {
        if width == 0 || height == 0 {
            bail!("the image header declares {width}×{height} texels: the image is empty or damaged");
        }
        if width > self.max_side || height > self.max_side || width.saturating_mul(height) > self.max_texels() {
            bail!(
                "the image header declares {width}×{height} texels, more than refrakt reads for this use \
                 (at most {side} a side and {w}×{h} texels in all, {mib} MiB as float RGBA); downscale the image, \
                 or check that the file is not damaged",
                side = self.max_side,
                w = self.max_image.0,
                h = self.max_image.1,
                mib = (self.max_texels() * 16) >> 20,
            );
        }
        Ok(())
    }
}

/// Least bytes an EXR chunk takes in the file: its 8-byte entry in the offset table and a
/// chunk header (a scanline block's y and byte count; a tile's header is longer).
const EXR_MIN_CHUNK_BYTES: u64 = 16;

/// Reads the headers of the EXR file at `path` and checks every layer's data window against
/// `caps`, and the file's length against the chunks the headers declare.
pub fn check_exr(path: &Path, caps: &Caps) -> Result<()> {
    let what = path.display().to_string();
    let meta = exr::meta::MetaData::read_from_file(path, false).with_context(|| format!("{what}: not a readable OpenEXR file"))?;
    let mut least = 0u64;
    for header in &meta.headers {
        let size = header.layer_size;
        caps.check(size.0 as u64, size.1 as u64).map_err(|e| anyhow!("{what}: {e}"))?;
        least = least.saturating_add((header.chunk_count as u64).saturating_mul(EXR_MIN_CHUNK_BYTES));
    }
    check_length(&what, path, least)
}

/// Reads the header of the Radiance `.hdr` file at `path` and checks its size against `caps`,
/// and the file's length against its scanlines.
pub fn check_hdr(path: &Path, caps: &Caps) -> Result<()> {
    let what = path.display().to_string();
    let file = std::fs::File::open(path).with_context(|| format!("cannot open {what}"))?;
    let (width, height) = hdr_size(std::io::BufReader::new(file)).with_context(|| format!("{what}: not a readable Radiance HDR file"))?;
    caps.check(width, height).map_err(|e| anyhow!("{what}: {e}"))?;
    // Every scanline starts with a whole 4-byte pixel (or the 4-byte mark of run-length coding).
    check_length(&what, path, 4 * height)
}

/// The size in the header of a Radiance `.hdr` stream: text lines up to a blank one, then the
/// resolution line (`-Y h +X w`). Lines are read with a bound, so a file of one endless line
/// costs no memory.
fn hdr_size(mut r: impl BufRead) -> Result<(u64, u64)> {
    const MAX_LINE: u64 = 4096;
    const MAX_LINES: usize = 256;
    let mut line = Vec::new();
    let read_line = |r: &mut dyn BufRead, line: &mut Vec<u8>| -> Result<()> {
        line.clear();
        r.take(MAX_LINE).read_until(b'\n', line)?;
        if line.last() != Some(&b'\n') {
            bail!("a header line is longer than {MAX_LINE} bytes or the header ends early");
        }
        Ok(())
    };
    read_line(&mut r, &mut line)?;
    if !line.starts_with(b"#?") {
        bail!("it does not start with the Radiance signature #?");
    }
    for _ in 0..MAX_LINES {
        read_line(&mut r, &mut line)?;
        if line.trim_ascii().is_empty() {
            read_line(&mut r, &mut line)?;
            let text = String::from_utf8_lossy(&line);
            let words: Vec<&str> = text.split_whitespace().collect();
            let [ya, h, xa, w] = words[..] else { bail!("the resolution line \"{}\" is not like -Y 512 +X 1024", text.trim()) };
            let parse = |s: &str| s.parse::<u64>().map_err(|_| anyhow::anyhow!("the resolution line \"{}\" has a bad number {s}", text.trim()));
            if !ya.ends_with('Y') || !xa.ends_with('X') {
                bail!("the resolution line \"{}\" is not like -Y 512 +X 1024 (rotated images are not read)", text.trim());
            }
            return Ok((parse(w)?, parse(h)?));
        }
    }
    bail!("the header has more than {MAX_LINES} lines")
}

/// Checks the encoded PNG/JPEG/HDR image in `bytes` (a glTF texture): its declared size
/// against `caps`. (The caller names the image in the message.)
pub fn check_encoded(bytes: &[u8], caps: &Caps) -> Result<()> {
    let reader = image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format()?;
    let (w, h) = reader.into_dimensions().map_err(|e| anyhow!("cannot read the image header: {e}"))?;
    caps.check(w as u64, h as u64)
}

fn check_length(what: &str, path: &Path, least: u64) -> Result<()> {
    let len = std::fs::metadata(path).with_context(|| format!("cannot open {what}"))?.len();
    if len < least {
        bail!(
            "{what}: the file is {len} bytes, too short for the pixels its header declares (at least {least} bytes): \
             it is truncated or damaged"
        );
    }
    Ok(())
}

/// The size in the header of a Radiance `.hdr` image held in memory (tests, fuzzing).
pub fn hdr_size_of(bytes: &[u8]) -> Result<(u64, u64)> {
    hdr_size(std::io::BufReader::new(bytes.take(1 << 20)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn caps_refuse_a_side_or_an_area_too_large() {
        assert!(ENVIRONMENT.check(16384, 8192).is_ok());
        let side = ENVIRONMENT.check(200000, 2).unwrap_err().to_string();
        assert!(side.contains("the image header declares 200000×2 texels") && side.contains("16384 a side"), "{side}");
        assert!(ENVIRONMENT.check(16384, 16384).is_err(), "area");
        assert!(ENVIRONMENT.check(0, 5).is_err(), "empty");
        assert!(TEXTURE.check(8193, 1).is_err());
    }

    #[test]
    fn hdr_header_gives_the_size() {
        let head = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 8\n";
        assert_eq!(hdr_size_of(head).unwrap(), (8, 4));
        let endless = [b"#?RADIANCE\n".as_slice(), &[b'a'; 10000]].concat();
        assert!(hdr_size_of(&endless).is_err());
        assert_eq!(hdr_size_of(b"#?RADIANCE\n\n-Y 4294967295999 +X 2\n").unwrap(), (2, 4294967295999));
        assert!(ENVIRONMENT.check(2, 4294967295999).is_err());
        assert!(hdr_size_of(b"#?RADIANCE\n\n-Y 99999999999999999999999 +X 2\n").is_err());
        assert!(hdr_size_of(b"#?RADIANCE\n\n+X 2 -Y 4\n").is_err(), "rotated");
        assert!(hdr_size_of(b"P6 2 2 255\n").is_err());
    }
}
