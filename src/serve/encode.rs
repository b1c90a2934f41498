//! A rendered frame as the page sees it: one layer through the display transform (exposure,
//! tone mapping, sRGB) into a JPEG, or the layer's linear floats on request.
//!
//! JPEG because every browser decodes it in hardware-friendly time and the `image` crate
//! encodes it; a 1024×576 frame is ~50–150 KB, a fraction of the raw 2.4 MB. WebP is not used:
//! the `image` crate's WebP encoder is lossless only, several times larger and slower to encode.
//! The display transform runs over bands of rows on all cores.

use anyhow::{Context, Result, anyhow};
use image::ExtendedColorType;
use image::codecs::jpeg::JpegEncoder;

use super::protocol::{Display, LayerChoice};
use crate::output::Image;
use crate::output::png::{PngOptions, display, srgb_encode};

/// Depth shown as grey: near (white) to this many times the nearest depth (black), on a log scale.
const DEPTH_RANGE: f32 = 8.0;
/// Depths at or beyond this are "no surface" (refrakt writes 10¹⁰ there).
const NO_SURFACE: f32 = 1e9;

/// The layer's linear values: the data, channels per pixel, and the channel offset of the
/// values shown (alpha is the beauty layer's fourth channel).
fn layer_data(image: &Image, layer: LayerChoice) -> Result<(&[f32], usize, usize)> {
    let (name, offset) = match layer {
        LayerChoice::Beauty => ("beauty", 0),
        LayerChoice::Alpha => ("beauty", 3),
        LayerChoice::Caustic => ("caustic", 0),
        LayerChoice::Direct => ("direct", 0),
        LayerChoice::Volume => ("volume", 0),
        LayerChoice::Depth => ("depth", 0),
    };
    let l = image.layer(name).ok_or_else(|| anyhow!("the frame has no {name} layer yet"))?;
    Ok((&l.data, l.channels.len(), offset))
}

/// Whether `image` holds what `layer` shows.
pub fn has_layer(image: &Image, layer: LayerChoice) -> bool {
    layer_data(image, layer).is_ok()
}

/// The layer as 8-bit sRGB, 3 bytes a pixel.
pub fn display_rgb(image: &Image, d: &Display) -> Result<Vec<u8>> {
    let (data, channels, offset) = layer_data(image, d.layer)?;
    let pixels = (image.width * image.height) as usize;
    let mut rgb = vec![0u8; 3 * pixels];
    let opts = PngOptions { exposure: d.exposure, tonemap: d.tonemap, alpha: false };
    let near = if d.layer == LayerChoice::Depth { nearest_depth(data) } else { 1.0 };
    let width = image.width as usize;
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(16);
    let rows_per_band = (image.height as usize).div_ceil(threads).max(1);
    std::thread::scope(|s| {
        for (band, out) in rgb.chunks_mut(3 * width * rows_per_band).enumerate() {
            let first = band * rows_per_band * width;
            s.spawn(move || {
                for (i, px) in out.chunks_exact_mut(3).enumerate() {
                    let at = (first + i) * channels;
                    px.copy_from_slice(&match d.layer {
                        LayerChoice::Alpha => [grey(data[at + offset]); 3],
                        LayerChoice::Depth => [depth_grey(data[at], near); 3],
                        _ => display([data[at], data[at + 1], data[at + 2]], &opts),
                    });
                }
            });
        }
    });
    Ok(rgb)
}

fn grey(v: f32) -> u8 {
    (srgb_encode(v) * 255.0 + 0.5) as u8
}

fn nearest_depth(depth: &[f32]) -> f32 {
    depth.iter().copied().filter(|z| z.is_finite() && *z > 0.0).fold(f32::INFINITY, f32::min).min(NO_SURFACE)
}

fn depth_grey(z: f32, near: f32) -> u8 {
    if !(z.is_finite() && z > 0.0 && z < NO_SURFACE) {
        return 0;
    }
    let t = ((z / near).ln() / DEPTH_RANGE.ln()).clamp(0.0, 1.0);
    ((1.0 - t) * 255.0 + 0.5) as u8
}

/// The layer through the display transform, as a JPEG.
pub fn jpeg(image: &Image, d: &Display) -> Result<Vec<u8>> {
    let rgb = display_rgb(image, d)?;
    let mut out = Vec::with_capacity(rgb.len() / 8);
    JpegEncoder::new_with_quality(&mut out, d.quality.clamp(1, 100))
        .encode(&rgb, image.width, image.height, ExtendedColorType::Rgb8)
        .context("JPEG encoding")?;
    Ok(out)
}

/// The layer's linear values as little-endian `f32`s, and how many a pixel has.
pub fn hdr(image: &Image, layer: LayerChoice) -> Result<(Vec<u8>, u32)> {
    let (data, channels, _) = layer_data(image, layer)?;
    Ok((bytemuck::cast_slice(data).to_vec(), channels as u32))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::Layer;

    fn image(rgba: [f32; 4], depth: Option<f32>) -> Image {
        let mut layers = vec![Layer::new("beauty", &["R", "G", "B", "A"], rgba.repeat(6))];
        if let Some(z) = depth {
            layers.push(Layer::new("depth", &["Z"], vec![z, 2.0 * z, 1e10, z, z, z]));
        }
        Image { width: 3, height: 2, layers }
    }

    #[test]
    fn beauty_and_alpha_go_through_the_display_transform() {
        let img = image([0.5, 0.25, 0.0, 0.5], None);
        let d = Display { tonemap: crate::output::png::ToneMap::Clamp, ..Display::default() };
        let rgb = display_rgb(&img, &d).unwrap();
        assert_eq!(&rgb[..3], &display([0.5, 0.25, 0.0], &PngOptions { tonemap: d.tonemap, ..PngOptions::default() }));
        let brighter = display_rgb(&img, &Display { exposure: 1.0, ..d }).unwrap();
        assert!(brighter[0] > rgb[0] && brighter[1] > rgb[1]);
        let alpha = display_rgb(&img, &Display { layer: LayerChoice::Alpha, ..d }).unwrap();
        assert_eq!(alpha[0], grey(0.5));
    }

    #[test]
    fn depth_is_near_white_far_dark_none_black_and_a_missing_layer_is_an_error() {
        let d = Display { layer: LayerChoice::Depth, ..Display::default() };
        let rgb = display_rgb(&image([0.0; 4], Some(1.5)), &d).unwrap();
        assert_eq!(rgb[0], 255);
        assert!(rgb[3] < 255 && rgb[3] > 0);
        assert_eq!(rgb[6], 0);
        assert!(display_rgb(&image([0.0; 4], None), &d).is_err());
        let jpeg = jpeg(&image([0.3; 4], None), &Display::default()).unwrap();
        assert_eq!(&jpeg[..2], &[0xFF, 0xD8]);
    }
}
