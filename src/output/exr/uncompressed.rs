//! Uncompressed EXR files (`--exr-compression none`, `refrakt watch`'s previews), written
//! directly: the `exr` crate's general writer spent 45–70 ms of one core on each 33 MB frame of
//! `seed` (sample by sample through its channel abstractions), the largest share of a frame
//! writer's time; this writes the same bytes — header, offset table and scan lines, as the
//! crate lays them out (a test compares the two byte for byte) — at the speed of copying them.
//!
//! The layout (OpenEXR's file format, single-part scan lines, no compression): the magic number
//! and version; the header's attributes, each `name\0 type\0 size value`, ended by `\0`; one
//! 64-bit file offset per scan line; then each line as `y`, its byte count, and its samples,
//! channel by channel in the order of their names (little-endian 16- or 32-bit floats).

use super::super::Image;

/// OpenEXR's pixel types.
const HALF: i32 = 1;
const FLOAT: i32 = 2;

/// One channel of the file: its name and where its samples lie in the image.
struct Channel<'a> {
    name: String,
    /// The layer's interleaved samples, this channel's at `offset + i · stride`.
    data: &'a [f32],
    offset: usize,
    stride: usize,
    half: bool,
}

impl Channel<'_> {
    fn sample_bytes(&self) -> usize {
        if self.half { 2 } else { 4 }
    }
}

/// The channels of `image`, sorted by name as EXR requires (depth stays 32-bit with `half`).
fn channels(image: &Image, half: bool) -> Vec<Channel<'_>> {
    let mut channels: Vec<Channel> = image
        .layers
        .iter()
        .flat_map(|layer| {
            let stride = layer.channels.len();
            layer.channels.iter().enumerate().map(move |(offset, name)| Channel {
                name: super::channel_name(&layer.name, name),
                data: &layer.data,
                offset,
                stride,
                half: super::stored_as_half(&layer.name, half),
            })
        })
        .collect();
    channels.sort_by(|a, b| a.name.as_bytes().cmp(b.name.as_bytes()));
    channels
}

fn attribute(out: &mut Vec<u8>, name: &str, kind: &str, value: &[u8]) {
    for text in [name, kind] {
        out.extend_from_slice(text.as_bytes());
        out.push(0);
    }
    out.extend_from_slice(&(value.len() as i32).to_le_bytes());
    out.extend_from_slice(value);
}

fn words(values: &[i32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// The magic number, version and header, in the `exr` crate's order of attributes.
fn header(image: &Image, channels: &[Channel]) -> Vec<u8> {
    let (w, h) = (image.width as i32, image.height as i32);
    let mut out = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    attribute(&mut out, "chunkCount", "int", &h.to_le_bytes());
    let mut list = Vec::new();
    for c in channels {
        list.extend_from_slice(c.name.as_bytes());
        list.push(0);
        // Pixel type, pLinear and three reserved bytes, x and y sampling. pLinear (a hint to
        // lossy codecs) as the crate guesses it from the name: all but perceptual R, G, B, …
        let perceptual = ["R", "G", "B", "L", "Y", "X", "Z"].iter().any(|p| c.name.eq_ignore_ascii_case(p));
        list.extend_from_slice(&(if c.half { HALF } else { FLOAT }).to_le_bytes());
        list.extend_from_slice(&[u8::from(!perceptual), 0, 0, 0]);
        list.extend_from_slice(&words(&[1, 1]));
    }
    list.push(0);
    attribute(&mut out, "channels", "chlist", &list);
    attribute(&mut out, "compression", "compression", &[0]);
    attribute(&mut out, "lineOrder", "lineOrder", &[0]);
    let window = words(&[0, 0, w - 1, h - 1]);
    attribute(&mut out, "displayWindow", "box2i", &window);
    attribute(&mut out, "pixelAspectRatio", "float", &1f32.to_le_bytes());
    attribute(&mut out, "screenWindowCenter", "v2f", &[0; 8]);
    attribute(&mut out, "screenWindowWidth", "float", &1f32.to_le_bytes());
    attribute(&mut out, "dataWindow", "box2i", &window);
    attribute(&mut out, "type", "string", b"scanlineimage");
    attribute(&mut out, "software", "string", super::SOFTWARE.as_bytes());
    out.push(0);
    out
}

/// Channel `c`'s samples of scan line `y` into `out` (its bytes for that line).
fn write_line(c: &Channel, y: usize, width: usize, out: &mut [u8]) {
    let line = &c.data[y * width * c.stride..(y + 1) * width * c.stride];
    let samples = line.chunks_exact(c.stride).map(|pixel| pixel[c.offset]);
    if c.half {
        for (bytes, v) in out.chunks_exact_mut(2).zip(samples) {
            bytes.copy_from_slice(&half::f16::from_f32(v).to_le_bytes());
        }
    } else {
        for (bytes, v) in out.chunks_exact_mut(4).zip(samples) {
            bytes.copy_from_slice(&v.to_le_bytes());
        }
    }
}

/// The uncompressed EXR file of `image`, colors as 16-bit floats with `half`.
pub fn encode(image: &Image, half: bool) -> Vec<u8> {
    let channels = channels(image, half);
    let (width, height) = (image.width as usize, image.height as usize);
    let line_bytes: usize = channels.iter().map(|c| width * c.sample_bytes()).sum();
    let chunk_bytes = 8 + line_bytes;
    let mut out = header(image, &channels);
    let first_chunk = out.len() + 8 * height;
    for y in 0..height {
        out.extend_from_slice(&((first_chunk + y * chunk_bytes) as u64).to_le_bytes());
    }
    out.resize(first_chunk + height * chunk_bytes, 0);
    for (y, chunk) in out[first_chunk..].chunks_exact_mut(chunk_bytes).enumerate() {
        chunk[..4].copy_from_slice(&(y as i32).to_le_bytes());
        chunk[4..8].copy_from_slice(&(line_bytes as i32).to_le_bytes());
        let mut rest = &mut chunk[8..];
        for c in &channels {
            let (line, after) = rest.split_at_mut(width * c.sample_bytes());
            write_line(c, y, width, line);
            rest = after;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::{ExrCodec, ExrSettings, encode_with_exr_crate};
    use super::*;
    use crate::output::Layer;

    fn image(width: u32, height: u32) -> Image {
        let n = (width * height) as usize;
        let layer = |name: &str, channels: &[&str], seed: f32| {
            let data = (0..n * channels.len()).map(|i| (i as f32 * 0.37 + seed).sin() * 1e3f32.powf((i % 7) as f32 / 3.0 - 1.0)).collect();
            Layer::new(name, channels, data)
        };
        Image {
            width,
            height,
            layers: vec![
                layer("beauty", &["R", "G", "B", "A"], 0.0),
                layer("depth", &["Z"], 1.0),
                layer("caustic", &["R", "G", "B"], 2.0),
                layer("volume", &["R", "G", "B"], 3.0),
            ],
        }
    }

    /// The same bytes as the `exr` crate writes, at odd sizes, in 32- and 16-bit colors.
    #[test]
    fn writes_the_bytes_the_exr_crate_writes() {
        for (w, h) in [(1, 1), (3, 2), (67, 53), (256, 17)] {
            for half in [false, true] {
                let img = image(w, h);
                let crate_bytes = encode_with_exr_crate(&img, ExrSettings { codec: ExrCodec::None, half, parallel: false }).unwrap();
                let ours = encode(&img, half);
                assert_eq!(ours.len(), crate_bytes.len(), "{w}×{h}, half {half}: file size");
                let first = ours.iter().zip(&crate_bytes).position(|(a, b)| a != b);
                assert!(first.is_none(), "{w}×{h}, half {half}: bytes differ from offset {first:?}");
            }
        }
    }
}
