//! OpenEXR output: one part, 32-bit float channels, ZIP compression (half floats, uncompressed,
//! for `refrakt watch`'s preview: see [`super::ExrCompression`]). The beauty layer is written as
//! plain `R G B A` (what every viewer shows); other layers as `<layer>.<channel>`
//! (`depth.Z`), the naming compositors (Blender, Nuke) split into layers.

use std::path::Path;

use anyhow::{Context, Result};
use exr::prelude::*;

use super::Image;

/// The EXR channel name of a layer's channel.
pub fn channel_name(layer: &str, channel: &str) -> String {
    if layer == "beauty" { channel.to_string() } else { format!("{layer}.{channel}") }
}

pub fn write(image: &super::Image, path: &Path, compression: super::ExrCompression) -> Result<()> {
    let (w, h) = (image.width as usize, image.height as usize);
    let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::new();
    for layer in &image.layers {
        let n = layer.channels.len();
        for (c, name) in layer.channels.iter().enumerate() {
            let values = layer.data.iter().skip(c).step_by(n).copied();
            let samples = match compression {
                super::ExrCompression::Fast if layer.name != "depth" => FlatSamples::F16(values.map(half::f16::from_f32).collect()),
                _ => FlatSamples::F32(values.collect()),
            };
            channels.push(AnyChannel::new(Text::from(channel_name(&layer.name, name).as_str()), samples));
        }
    }
    let attributes =
        LayerAttributes { software_name: Some(Text::from(concat!("refrakt ", env!("CARGO_PKG_VERSION")))), ..Default::default() };
    let layer = |encoding| exr::image::Layer::new((w, h), attributes, encoding, AnyChannels::sort(channels.into()));
    let written = match compression {
        super::ExrCompression::Small => exr::image::Image::from_layer(layer(Encoding::SMALL_LOSSLESS)).write().to_file(path),
        super::ExrCompression::Fast => exr::image::Image::from_layer(layer(Encoding::UNCOMPRESSED)).write().non_parallel().to_file(path),
    };
    written.context("EXR encoding failed")
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
