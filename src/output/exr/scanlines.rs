//! Scan-line EXR files written directly — uncompressed (`--exr-compression none`, `refrakt
//! watch`'s previews), ZIPS and ZIP (the default) — instead of through the `exr` crate's general
//! writer, which spent 45–70 ms of one core on each 33 MB frame of `seed` moving samples through
//! its channel abstractions, and deflated with miniz at level 4 (~0.5 s of one core a frame).
//! Uncompressed files are the crate's bytes exactly (a test compares them); ZIP and ZIPS are the
//! same header and blocks, each block deflated by libdeflate (level [`DEFLATE_LEVEL`]), on all
//! cores when asked.
//!
//! The layout (OpenEXR's file format, single-part scan lines): the magic number and version; the
//! header's attributes, each `name\0 type\0 size value`, ended by `\0`; one 64-bit file offset
//! per block; then each block as its first `y`, its byte count, and its data. A block is
//! [`Codec::lines`] scan lines, each channel by channel in the order of their names
//! (little-endian 16- or 32-bit floats); ZIP and ZIPS store it as OpenEXR's `ImfZip` does:
//! the bytes split into the even-indexed then the odd-indexed ones, each byte replaced by its
//! difference from the one before (+128), then zlib — or as it was, where that is no smaller.

use super::super::{Image, LayerSet};
use super::ExrSettings;

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

/// The channels of the image's `layers`, sorted by name as EXR requires (depth stays 32-bit
/// with `half`).
fn channels(image: &Image, half: bool, layers: LayerSet) -> Vec<Channel<'_>> {
    let mut channels: Vec<Channel> = image
        .layers
        .iter()
        .filter(|layer| layers.contains(&layer.name))
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
fn header(image: &Image, channels: &[Channel], geometry: &Geometry) -> Vec<u8> {
    let (w, h) = (image.width as i32, image.height as i32);
    let mut out = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    attribute(&mut out, "chunkCount", "int", &(geometry.blocks() as i32).to_le_bytes());
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
    attribute(&mut out, "compression", "compression", &[geometry.codec.id()]);
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

/// How blocks of scan lines are stored: the codecs this module writes. PIZ and DWAA blocks are
/// compressed by the `exr` crate's own block compressors (`Compression::compress_image_section_to_le`,
/// the code its writer calls), here on blocks this module lays out, on all cores.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Codec {
    None,
    Zips,
    Zip,
    Piz,
    Dwaa,
}

impl Codec {
    /// Scan lines per block (OpenEXR's `numLinesInBuffer`).
    fn lines(self) -> usize {
        match self {
            Codec::None | Codec::Zips => 1,
            Codec::Zip => 16,
            Codec::Piz | Codec::Dwaa => 32,
        }
    }

    /// The header's `compression` value.
    fn id(self) -> u8 {
        match self {
            Codec::None => 0,
            Codec::Zips => 2,
            Codec::Zip => 3,
            Codec::Piz => 4,
            Codec::Dwaa => 8,
        }
    }

    /// The `exr` crate's compressor for this codec's blocks, where it is not deflate.
    fn crate_compression(self) -> Option<exr::compression::Compression> {
        match self {
            Codec::Piz => Some(exr::compression::Compression::PIZ),
            Codec::Dwaa => Some(exr::compression::Compression::DWAA(None)),
            Codec::None | Codec::Zips | Codec::Zip => None,
        }
    }
}

/// What the `exr` crate's block compressors read of a file: its channels, in order, with their
/// sample types and pLinear flags as this module's header writes them.
fn crate_header(channels: &[Channel], geometry: &Geometry, compression: exr::compression::Compression) -> exr::meta::header::Header {
    use exr::meta::attribute::{ChannelDescription, SampleType};
    let list = channels
        .iter()
        .map(|c| ChannelDescription::named(c.name.as_str(), if c.half { SampleType::F16 } else { SampleType::F32 }))
        .collect();
    exr::meta::header::Header::new("".into(), (geometry.width, geometry.height), list).with_encoding(
        compression,
        exr::meta::BlockDescription::ScanLines,
        exr::meta::attribute::LineOrder::Increasing,
    )
}

/// libdeflate's level for ZIP and ZIPS, chosen by measure on a frame of `seed` (1024×576, 17
/// channels, 40 MB, one core of the dev machine): level 1 deflates it in 187 ms to 15.74 MB,
/// level 6 in 232 ms to 15.54 MB, where miniz's level 4 (the `exr` crate's) took 495–640 ms
/// for 15.56 MB. Rendered floats are mostly noise in their low bytes: higher levels find little.
pub const DEFLATE_LEVEL: i32 = 1;

/// The scan lines `y0..y0 + lines` of every channel, as a block stores them before compression.
fn block_samples(channels: &[Channel], y0: usize, lines: usize, width: usize, out: &mut [u8]) {
    let mut rest = out;
    for y in y0..y0 + lines {
        for c in channels {
            let (line, after) = rest.split_at_mut(width * c.sample_bytes());
            write_line(c, y, width, line);
            rest = after;
        }
    }
}

/// OpenEXR's ZIP predictor (`ImfZip.cpp`): `raw`'s even-indexed bytes, then its odd-indexed
/// ones, each as its difference from the byte before plus 128 — float samples' high bytes vary
/// slowly, so the differences are small and deflate well.
fn predict(raw: &[u8], out: &mut Vec<u8>) {
    out.clear();
    out.extend(raw.iter().step_by(2));
    out.extend(raw.iter().skip(1).step_by(2));
    let mut previous = out.first().copied().unwrap_or(0);
    for byte in out.iter_mut().skip(1) {
        let value = *byte;
        *byte = value.wrapping_sub(previous).wrapping_add(128);
        previous = value;
    }
}

/// Compresses blocks one after another, reusing its buffers.
struct BlockWriter<'h> {
    raw: Vec<u8>,
    predicted: Vec<u8>,
    deflate: libdeflater::Compressor,
    /// For PIZ and DWAA: the file as the `exr` crate's compressors see it.
    crate_header: Option<&'h exr::meta::header::Header>,
}

impl<'h> BlockWriter<'h> {
    fn new(crate_header: Option<&'h exr::meta::header::Header>) -> Self {
        let level = libdeflater::CompressionLvl::new(DEFLATE_LEVEL).expect("a valid libdeflate level");
        Self { raw: Vec::new(), predicted: Vec::new(), deflate: libdeflater::Compressor::new(level), crate_header }
    }

    /// Block `b`'s chunk: its first `y`, its byte count and its (compressed) data.
    fn chunk(&mut self, channels: &[Channel], b: usize, geometry: &Geometry) -> Vec<u8> {
        let y0 = b * geometry.codec.lines();
        let lines = geometry.codec.lines().min(geometry.height - y0);
        self.raw.resize(lines * geometry.line_bytes, 0);
        block_samples(channels, y0, lines, geometry.width, &mut self.raw);
        if let Some(header) = self.crate_header {
            return crate_chunk(header, &self.raw, y0, lines, geometry.width);
        }
        predict(&self.raw, &mut self.predicted);
        let mut chunk = vec![0; 8 + self.deflate.zlib_compress_bound(self.raw.len())];
        let stored = match self.deflate.zlib_compress(&self.predicted, &mut chunk[8..]) {
            Ok(n) if n < self.raw.len() => n,
            // No smaller compressed (noise): stored as it was, which readers tell by its size.
            _ => {
                chunk[8..8 + self.raw.len()].copy_from_slice(&self.raw);
                self.raw.len()
            }
        };
        chunk.truncate(8 + stored);
        chunk[..4].copy_from_slice(&(y0 as i32).to_le_bytes());
        chunk[4..8].copy_from_slice(&(stored as i32).to_le_bytes());
        chunk
    }
}

/// A PIZ or DWAA block's chunk, compressed by the `exr` crate (which stores the block as it was
/// where that is no larger). `raw` is little-endian, as the crate's native-endian input is on
/// every target refrakt builds for.
fn crate_chunk(header: &exr::meta::header::Header, raw: &[u8], y0: usize, lines: usize, width: usize) -> Vec<u8> {
    let section = exr::meta::attribute::IntegerBounds::new((0, y0 as i32), (width, lines));
    let data = header
        .compression
        .compress_image_section_to_le(header, raw.to_vec(), section)
        .unwrap_or_else(|_| raw.to_vec());
    let mut chunk = Vec::with_capacity(8 + data.len());
    chunk.extend_from_slice(&(y0 as i32).to_le_bytes());
    chunk.extend_from_slice(&(data.len() as i32).to_le_bytes());
    chunk.extend_from_slice(&data);
    chunk
}

/// The image's size and blocks.
struct Geometry {
    codec: Codec,
    width: usize,
    height: usize,
    /// Bytes of one scan line of every channel.
    line_bytes: usize,
}

impl Geometry {
    fn blocks(&self) -> usize {
        self.height.div_ceil(self.codec.lines())
    }
}

/// The EXR file of `image`'s chosen layers with `codec`, colors as 16-bit floats with `half`;
/// ZIP's and ZIPS's blocks deflated on all cores with `parallel` (the bytes are the same either
/// way).
pub fn encode(image: &Image, settings: &ExrSettings, codec: Codec) -> Vec<u8> {
    let channels = channels(image, settings.half, settings.layers);
    let (width, height) = (image.width as usize, image.height as usize);
    let line_bytes = channels.iter().map(|c| width * c.sample_bytes()).sum();
    let geometry = Geometry { codec, width, height, line_bytes };
    let mut out = header(image, &channels, &geometry);
    if codec == Codec::None {
        write_uncompressed(&channels, &geometry, &mut out);
        return out;
    }
    let chunks = compress_blocks(&channels, &geometry, settings.parallel);
    let mut offset = out.len() + 8 * chunks.len();
    for chunk in &chunks {
        out.extend_from_slice(&(offset as u64).to_le_bytes());
        offset += chunk.len();
    }
    out.reserve(offset - out.len());
    for chunk in &chunks {
        out.extend_from_slice(chunk);
    }
    out
}

/// Every block's chunk, in order: on one thread, or on a thread per core taking every n-th block.
fn compress_blocks(channels: &[Channel], geometry: &Geometry, parallel: bool) -> Vec<Vec<u8>> {
    let blocks = geometry.blocks();
    let threads = if parallel { std::thread::available_parallelism().map_or(1, |n| n.get()).min(blocks) } else { 1 };
    let header = geometry.codec.crate_compression().map(|c| crate_header(channels, geometry, c));
    let header = header.as_ref();
    if threads <= 1 {
        let mut writer = BlockWriter::new(header);
        return (0..blocks).map(|b| writer.chunk(channels, b, geometry)).collect();
    }
    let mut chunks = vec![Vec::new(); blocks];
    std::thread::scope(|scope| {
        let per_thread: Vec<_> = (0..threads)
            .map(|t| {
                scope.spawn(move || {
                    let mut writer = BlockWriter::new(header);
                    (t..blocks).step_by(threads).map(|b| (b, writer.chunk(channels, b, geometry))).collect::<Vec<_>>()
                })
            })
            .collect();
        for handle in per_thread {
            for (b, chunk) in handle.join().expect("a block compressor panicked") {
                chunks[b] = chunk;
            }
        }
    });
    chunks
}

/// The offset table and the scan lines of an uncompressed file, written in place (at the speed
/// of copying them).
fn write_uncompressed(channels: &[Channel], geometry: &Geometry, out: &mut Vec<u8>) {
    let Geometry { width, height, line_bytes, .. } = *geometry;
    let chunk_bytes = 8 + line_bytes;
    let first_chunk = out.len() + 8 * height;
    for y in 0..height {
        out.extend_from_slice(&((first_chunk + y * chunk_bytes) as u64).to_le_bytes());
    }
    out.resize(first_chunk + height * chunk_bytes, 0);
    for (y, chunk) in out[first_chunk..].chunks_exact_mut(chunk_bytes).enumerate() {
        chunk[..4].copy_from_slice(&(y as i32).to_le_bytes());
        chunk[4..8].copy_from_slice(&(line_bytes as i32).to_le_bytes());
        block_samples(channels, y, 1, width, &mut chunk[8..]);
    }
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

    /// The same bytes as the `exr` crate writes, at odd sizes (one block, a part block, several),
    /// in 32- and 16-bit colors: uncompressed, and PIZ and DWAA, whose blocks its compressors
    /// fill (on all cores here, one by one there).
    #[test]
    fn writes_the_bytes_the_exr_crate_writes() {
        for (codec, ours_codec) in [(ExrCodec::None, Codec::None), (ExrCodec::Piz, Codec::Piz), (ExrCodec::Dwaa, Codec::Dwaa)] {
            for (w, h) in [(1, 1), (3, 2), (67, 53), (256, 17)] {
                for half in [false, true] {
                    let img = image(w, h);
                    let settings = ExrSettings { codec, half, parallel: false, layers: LayerSet::default() };
                    let crate_bytes = encode_with_exr_crate(&img, settings).unwrap();
                    let ours = encode(&img, &ExrSettings { parallel: true, ..settings }, ours_codec);
                    assert_eq!(ours.len(), crate_bytes.len(), "{codec:?} {w}×{h}, half {half}: file size");
                    let first = ours.iter().zip(&crate_bytes).position(|(a, b)| a != b);
                    assert!(first.is_none(), "{codec:?} {w}×{h}, half {half}: bytes differ from offset {first:?}");
                }
            }
        }
    }

    /// ZIP and ZIPS files read back by the `exr` crate's decoder to the very samples written
    /// (bit for bit; half floats as `half` rounds them), at sizes that leave a short last block,
    /// on one thread and on many (the same bytes), with a block of incompressible noise stored
    /// as it is.
    #[test]
    fn zip_and_zips_read_back_bit_for_bit() {
        let dir = tempfile::tempdir().unwrap();
        for (w, h) in [(1, 1), (67, 53), (256, 17)] {
            for half in [false, true] {
                let img = image(w, h);
                for codec in [Codec::Zip, Codec::Zips] {
                    let settings = |parallel| ExrSettings { codec: ExrCodec::Zip, half, parallel, layers: LayerSet::default() };
                    let bytes = encode(&img, &settings(false), codec);
                    assert_eq!(bytes, encode(&img, &settings(true), codec), "{codec:?} {w}×{h}: threads change the bytes");
                    let path = dir.path().join("f.exr");
                    std::fs::write(&path, &bytes).unwrap();
                    let back = crate::output::exr::read(&path).unwrap();
                    for layer in &img.layers {
                        let got = back.layer(&layer.name).unwrap();
                        assert_eq!(got.channels, layer.channels);
                        let rounded = |v: f32| if super::super::stored_as_half(&layer.name, half) { half::f16::from_f32(v).to_f32() } else { v };
                        let same = layer.data.iter().zip(&got.data).all(|(a, b)| rounded(*a).to_bits() == b.to_bits());
                        assert!(same, "{codec:?} {w}×{h} half {half}: layer {} differs", layer.name);
                    }
                }
            }
        }
    }

    /// Where deflate cannot shrink a block (white noise), the block is stored raw, and still read.
    #[test]
    fn incompressible_blocks_are_stored_as_they_are() {
        let mut state = 0x9e3779b97f4a7c15u64;
        let noise = (0..64 * 16 * 4)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                f32::from_bits((state as u32 & 0x807f_ffff) | 0x3f00_0000)
            })
            .collect::<Vec<_>>();
        let img = Image { width: 64, height: 16, layers: vec![Layer::new("beauty", &["R", "G", "B", "A"], noise.clone())] };
        let bytes = encode(&img, &ExrSettings { codec: ExrCodec::Zip, half: false, parallel: false, layers: LayerSet::default() }, Codec::Zip);
        let raw_block = 64 * 16 * 4 * 4;
        let stored = i32::from_le_bytes(bytes[bytes.len() - raw_block - 4..bytes.len() - raw_block].try_into().unwrap());
        assert_eq!(stored as usize, raw_block, "the block's byte count says it is stored raw");
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("n.exr"), &bytes).unwrap();
        let back = crate::output::exr::read(&dir.path().join("n.exr")).unwrap();
        assert!(back.layers[0].data.iter().zip(&noise).all(|(a, b)| a.to_bits() == b.to_bits()));
    }
}
