//! OpenEXR output: one part of scan lines in increasing order (so the bytes do not depend on how
//! many threads compressed them), 32-bit float channels, ZIP compression by default; the codec
//! and half-float colors are [`ExrSettings`] (half floats, uncompressed, for `refrakt watch`'s
//! preview: see [`super::ExrCompression`]). The beauty layer is written as plain `R G B A` (what
//! every viewer shows); other layers as `<layer>.<channel>` (`depth.Z`), the naming compositors
//! (Blender, Nuke) split into layers.

use std::io::Cursor;
use std::path::Path;

use anyhow::{Context, Result};
use exr::prelude::*;

use super::{Image, LayerSet};

mod scanlines;

/// An EXR codec (`--exr-compression`): the lossless ones every OpenEXR reader knows, and DWAA
/// (lossy, for previews and dailies).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ExrCodec {
    /// zlib over blocks of 16 scan lines (OpenEXR's ZIP): small, lossless.
    #[default]
    Zip,
    /// zlib over single scan lines (ZIPS): lossless, a little larger than ZIP.
    Zips,
    /// Wavelet + Huffman (PIZ): lossless, good on noisy images.
    Piz,
    /// Run lengths (RLE): lossless, fast, large on noisy images.
    Rle,
    /// DCT over blocks of 32 lines (DWAA): lossy on colors — this encoder codes 32-bit colors
    /// to about 2 % on noise, and keeps half-float colors (`--exr-half`) to their precision;
    /// depth is kept exactly.
    Dwaa,
    /// Stored as they are: the largest files, the least CPU.
    None,
}

impl ExrCodec {
    fn compression(self) -> Compression {
        match self {
            ExrCodec::Zip => Compression::ZIP16,
            ExrCodec::Zips => Compression::ZIP1,
            ExrCodec::Piz => Compression::PIZ,
            ExrCodec::Rle => Compression::RLE,
            ExrCodec::Dwaa => Compression::DWAA(None),
            ExrCodec::None => Compression::Uncompressed,
        }
    }
}

/// How an EXR is stored and encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExrSettings {
    pub codec: ExrCodec,
    /// Colors as 16-bit floats (2⁻¹¹ relative); depth stays 32-bit, as 10¹⁰ is beyond half
    /// floats.
    pub half: bool,
    /// Compress the blocks of one file on all cores (a still, a preview); off where frames are
    /// encoded side by side on a pool of their own ([`super::pool`]). The bytes are the same.
    pub parallel: bool,
    /// The image's layers the file keeps (others are left out).
    pub layers: LayerSet,
}

impl Default for ExrSettings {
    fn default() -> Self {
        super::ExrCompression::Small.into()
    }
}

impl From<super::ExrCompression> for ExrSettings {
    fn from(c: super::ExrCompression) -> Self {
        match c {
            super::ExrCompression::Small => Self { codec: ExrCodec::Zip, half: false, parallel: true, layers: LayerSet::default() },
            super::ExrCompression::Fast => Self { codec: ExrCodec::None, half: true, parallel: false, layers: LayerSet::default() },
        }
    }
}

/// Every file's `software` attribute.
const SOFTWARE: &str = concat!("refrakt ", env!("CARGO_PKG_VERSION"));

/// Whether layer `layer`'s channels are stored as 16-bit floats: colors with `half`; depth stays
/// 32-bit, as 10¹⁰ is beyond half floats.
fn stored_as_half(layer: &str, half: bool) -> bool {
    half && layer != "depth"
}

/// The EXR channel name of a layer's channel.
pub fn channel_name(layer: &str, channel: &str) -> String {
    if layer == "beauty" { channel.to_string() } else { format!("{layer}.{channel}") }
}

/// The channels of the image's `layers`, planar, as `exr` takes them.
fn channels(image: &Image, half: bool, layers: LayerSet) -> Vec<AnyChannel<FlatSamples>> {
    let mut channels = Vec::new();
    for layer in image.layers.iter().filter(|l| layers.contains(&l.name)) {
        let n = layer.channels.len();
        for (c, name) in layer.channels.iter().enumerate() {
            let values = layer.data.iter().skip(c).step_by(n).copied();
            let samples = if stored_as_half(&layer.name, half) {
                FlatSamples::F16(values.map(half::f16::from_f32).collect())
            } else {
                FlatSamples::F32(values.collect())
            };
            channels.push(AnyChannel::new(Text::from(channel_name(&layer.name, name).as_str()), samples));
        }
    }
    channels
}

/// The EXR file of `image`, in memory.
pub fn encode(image: &Image, settings: ExrSettings) -> Result<Vec<u8>> {
    let codec = match settings.codec {
        ExrCodec::None => scanlines::Codec::None,
        ExrCodec::Zips => scanlines::Codec::Zips,
        ExrCodec::Zip => scanlines::Codec::Zip,
        ExrCodec::Piz => scanlines::Codec::Piz,
        ExrCodec::Dwaa => scanlines::Codec::Dwaa,
        ExrCodec::Rle => return encode_with_exr_crate(image, settings),
    };
    Ok(scanlines::encode(image, &settings, codec))
}

/// The EXR file of `image` as the `exr` crate writes it (every codec; refrakt's own writer takes
/// all but RLE).
fn encode_with_exr_crate(image: &Image, settings: ExrSettings) -> Result<Vec<u8>> {
    let size = (image.width as usize, image.height as usize);
    let attributes =
        LayerAttributes { software_name: Some(Text::from(SOFTWARE)), ..Default::default() };
    let encoding = Encoding { compression: settings.codec.compression(), blocks: Blocks::ScanLines, line_order: LineOrder::Increasing };
    let channels = AnyChannels::sort(channels(image, settings.half, settings.layers).into());
    let exr_image = exr::image::Image::from_layer(exr::image::Layer::new(size, attributes, encoding, channels));
    let mut bytes = Cursor::new(Vec::new());
    let written = if settings.parallel {
        exr_image.write().to_buffered(&mut bytes)
    } else {
        exr_image.write().non_parallel().to_buffered(&mut bytes)
    };
    written.with_context(|| format!("EXR encoding ({:?}) failed", settings.codec))?;
    Ok(bytes.into_inner())
}

/// Writes `image` to `path` (not atomically: see [`super::write_with`]).
pub fn write(image: &Image, path: &Path, settings: impl Into<ExrSettings>) -> Result<()> {
    let bytes = encode(image, settings.into())?;
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}

/// Reads an EXR written by [`write`] back into an [`Image`] (tests, the Blender round trip).
pub fn read(path: &Path) -> Result<Image> {
    let img = read_all_flat_layers_from_file(path).with_context(|| format!("cannot read {}", path.display()))?;
    let layer = img.layer_data.first().context("the EXR has no layers")?;
    let (w, h) = (layer.size.width(), layer.size.height());
    let mut layers: Vec<super::Layer> = Vec::new();
    for ch in &layer.channel_data.list {
        let full = ch.name.to_string();
        let (lname, cname) = match full.rsplit_once('.') {
            Some((l, c)) => (l.to_string(), c.to_string()),
            None => ("beauty".to_string(), full.clone()),
        };
        let values: Vec<f32> = ch.sample_data.values_as_f32().collect();
        match layers.iter_mut().find(|l| l.name == lname) {
            Some(l) => {
                l.channels.push(cname);
                l.data.extend(values);
            }
            None => layers.push(super::Layer { name: lname, channels: vec![cname], data: values }),
        }
    }
    // Channels arrive planar and sorted; interleave, and put beauty in R G B A order first.
    for l in &mut layers {
        let mut order: Vec<usize> = (0..l.channels.len()).collect();
        let rank = |c: &str| ["R", "G", "B", "A"].iter().position(|x| *x == c).unwrap_or(4);
        order.sort_by_key(|&i| (rank(&l.channels[i]), l.channels[i].clone()));
        let planes: Vec<&[f32]> = order.iter().map(|&i| &l.data[i * w * h..(i + 1) * w * h]).collect();
        let mut data = Vec::with_capacity(l.data.len());
        for p in 0..w * h {
            data.extend(planes.iter().map(|plane| plane[p]));
        }
        l.channels = order.iter().map(|&i| l.channels[i].clone()).collect();
        l.data = data;
    }
    layers.sort_by_key(|l| l.name != "beauty");
    Ok(Image { width: w as u32, height: h as u32, layers })
}
