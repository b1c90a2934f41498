//! A rendered frame as the page sees it: one layer through the display transform (exposure,
//! tone mapping, sRGB) into a JPEG, or the layer's linear floats on request.
//!
//! JPEG because every browser decodes it quickly and the `image` crate encodes it; a 1024×576
//! frame is a small fraction of its raw 2.4 MB. WebP is not used: the `image` crate's WebP
//! encoder is lossless only, several times larger and slower to encode. The `image` JPEG encoder
//! runs on one core, so a frame is cut into horizontal strips (whole 16-row blocks, so no seam
//! shows), each put through the display transform and encoded on a core of its own: the frame
//! message carries the strips one after another, and the page draws each at its row.

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
        LayerChoice::Indirect => ("indirect", 0),
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

/// Rows of a strip: whole JPEG blocks (16 rows with chroma subsampling).
const STRIP_ALIGN: u32 = 16;
/// Fewest rows worth a strip of their own.
const STRIP_MIN_ROWS: u32 = 64;

/// How a frame is cut: (first row, rows) of each strip.
pub fn strips(height: u32, cores: usize) -> Vec<(u32, u32)> {
    let count = (height / STRIP_MIN_ROWS).clamp(1, cores.clamp(1, 16) as u32);
    let rows = height.div_ceil(count).div_ceil(STRIP_ALIGN) * STRIP_ALIGN;
    (0..height).step_by(rows as usize).map(|y| (y, rows.min(height - y))).collect()
}

fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// Rows `first..first + rows` of the layer as 8-bit sRGB, 3 bytes a pixel.
fn display_rows(image: &Image, d: &Display, near: f32, (first, rows): (u32, u32)) -> Result<Vec<u8>> {
    let (data, channels, offset) = layer_data(image, d.layer)?;
    let opts = PngOptions { exposure: d.exposure, tonemap: d.tonemap, alpha: false };
    let start = (first * image.width) as usize;
    let mut rgb = vec![0u8; 3 * (rows * image.width) as usize];
    for (i, px) in rgb.chunks_exact_mut(3).enumerate() {
        let at = (start + i) * channels;
        px.copy_from_slice(&match d.layer {
            LayerChoice::Alpha => [grey(data[at + offset]); 3],
            LayerChoice::Depth => [depth_grey(data[at], near); 3],
            _ => display([data[at], data[at + 1], data[at + 2]], &opts),
        });
    }
    Ok(rgb)
}

/// The nearest depth (the depth layer's white point); 1 for other layers.
fn near_of(image: &Image, d: &Display) -> Result<f32> {
    let (data, ..) = layer_data(image, d.layer)?;
    Ok(if d.layer == LayerChoice::Depth { nearest_depth(data) } else { 1.0 })
}

/// The layer as 8-bit sRGB, 3 bytes a pixel.
pub fn display_rgb(image: &Image, d: &Display) -> Result<Vec<u8>> {
    display_rows(image, d, near_of(image, d)?, (0, image.height))
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

/// A strip of rows through the display transform, as a JPEG.
fn jpeg_strip(image: &Image, d: &Display, near: f32, strip: (u32, u32)) -> Result<Vec<u8>> {
    let rgb = display_rows(image, d, near, strip)?;
    let mut out = Vec::with_capacity(rgb.len() / 8);
    JpegEncoder::new_with_quality(&mut out, d.quality.clamp(1, 100))
        .encode(&rgb, image.width, strip.1, ExtendedColorType::Rgb8)
        .context("JPEG encoding")?;
    Ok(out)
}

/// The layer through the display transform as JPEG strips, encoded on all cores: the strips'
/// bytes one after another, and each strip's (first row, rows, bytes).
pub fn jpeg(image: &Image, d: &Display) -> Result<(Vec<u8>, Vec<[u32; 3]>)> {
    let near = near_of(image, d)?;
    let cut = strips(image.height, cores());
    let encoded: Vec<Result<Vec<u8>>> = std::thread::scope(|s| {
        let handles: Vec<_> = cut.iter().map(|&strip| s.spawn(move || jpeg_strip(image, d, near, strip))).collect();
        handles.into_iter().map(|h| h.join().unwrap_or_else(|_| Err(anyhow!("a JPEG strip's thread panicked")))).collect()
    });
    let mut bytes = Vec::new();
    let mut table = Vec::with_capacity(cut.len());
    for ((y, rows), strip) in cut.into_iter().zip(encoded) {
        let strip = strip?;
        table.push([y, rows, strip.len() as u32]);
        bytes.extend_from_slice(&strip);
    }
    Ok((bytes, table))
}

/// The layer's linear values in `region` (x, y, width, height) as little-endian `f32`s, rows
/// top to bottom, and how many a pixel has. The region must lie inside the frame.
pub fn hdr(image: &Image, layer: LayerChoice, [x, y, w, h]: [u32; 4]) -> Result<(Vec<u8>, u32)> {
    let (data, channels, _) = layer_data(image, layer)?;
    let inside = x.checked_add(w).is_some_and(|r| r <= image.width) && y.checked_add(h).is_some_and(|b| b <= image.height);
    if !inside || w == 0 || h == 0 {
        return Err(anyhow!("the region {w}×{h} at ({x}, {y}) is not inside the {}×{} frame", image.width, image.height));
    }
    let mut out = Vec::with_capacity(4 * channels * (w * h) as usize);
    for row in y..y + h {
        let start = channels * (row * image.width + x) as usize;
        out.extend_from_slice(bytemuck::cast_slice(&data[start..start + channels * w as usize]));
    }
    Ok((out, channels as u32))
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
        let (jpeg, strips) = jpeg(&image([0.3; 4], None), &Display::default()).unwrap();
        assert_eq!(&jpeg[..2], &[0xFF, 0xD8]);
        assert_eq!(strips, vec![[0, 2, jpeg.len() as u32]]);
    }

    #[test]
    fn an_hdr_region_is_its_rows_of_the_layer_and_one_outside_is_refused() {
        let data: Vec<f32> = (0..24).map(|i| i as f32).collect();
        let img = Image { width: 3, height: 2, layers: vec![Layer::new("beauty", &["R", "G", "B", "A"], data)] };
        let (bytes, channels) = hdr(&img, LayerChoice::Beauty, [1, 0, 2, 2]).unwrap();
        let values: Vec<f32> = bytes.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
        assert_eq!(channels, 4);
        assert_eq!(values, [4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 16.0, 17.0, 18.0, 19.0, 20.0, 21.0, 22.0, 23.0]);
        assert_eq!(hdr(&img, LayerChoice::Beauty, [0, 0, 3, 2]).unwrap().0.len(), 4 * 24);
        for bad in [[2, 0, 2, 1], [0, 1, 1, 2], [u32::MAX, 0, 2, 1], [0, 0, 0, 1]] {
            assert!(hdr(&img, LayerChoice::Beauty, bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn strips_cover_the_frame_in_whole_blocks_and_decode_to_it() {
        for (height, cores) in [(576, 16), (576, 5), (36, 16), (1080, 1), (100, 3), (17, 4)] {
            let cut = strips(height, cores);
            assert!(cut.len() <= cores.max(1), "{height} rows on {cores} cores: {cut:?}");
            let mut next = 0;
            for &(y, rows) in &cut {
                assert_eq!(y, next);
                assert!(rows > 0 && (rows % STRIP_ALIGN == 0 || y + rows == height), "{height}, {cores}: {cut:?}");
                next = y + rows;
            }
            assert_eq!(next, height);
        }
        // A gradient frame of 300 rows: each strip decodes, and together they are the frame.
        let (w, h) = (40u32, 300u32);
        let data = (0..w * h).flat_map(|i| [(i / w) as f32 / h as f32, 0.5, (i % w) as f32 / w as f32, 1.0]).collect();
        let img = Image { width: w, height: h, layers: vec![Layer::new("beauty", &["R", "G", "B", "A"], data)] };
        let d = Display { quality: 95, tonemap: crate::output::png::ToneMap::Clamp, ..Display::default() };
        let (bytes, table) = jpeg(&img, &d).unwrap();
        let whole = display_rgb(&img, &d).unwrap();
        let mut offset = 0;
        for [y, rows, len] in table {
            let strip = image::load_from_memory(&bytes[offset..offset + len as usize]).unwrap().to_rgb8();
            assert_eq!((strip.width(), strip.height()), (w, rows));
            let want = &whole[(3 * y * w) as usize..(3 * (y + rows) * w) as usize];
            let err = strip.as_raw().iter().zip(want).map(|(a, b)| (*a as i32 - *b as i32).abs()).max().unwrap();
            assert!(err <= 12, "strip at row {y}: JPEG error {err}");
            offset += len as usize;
        }
        assert_eq!(offset, bytes.len());
    }
}
