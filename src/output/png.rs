//! PNG output: exposure, a tone mapper, the sRGB transfer function, 8 bits.
//!
//! The default tone mapper is Khronos PBR Neutral (Khronos Group, 2024): it leaves colors below
//! 0.76 untouched (so a diffuse albedo reads as itself) and rolls highlights off toward white
//! with a little desaturation — faithful for glass and product shots. `aces` is Narkowicz's fit
//! of the ACES filmic curve; `clamp` only clips.

use std::path::Path;

use anyhow::{Context, Result};

use super::Image;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ToneMap {
    #[default]
    Neutral,
    Aces,
    Clamp,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PngOptions {
    /// Exposure in stops: linear values are scaled by 2^exposure before tone mapping.
    pub exposure: f32,
    pub tonemap: ToneMap,
    /// Write the alpha channel (for a transparent film); otherwise RGB.
    pub alpha: bool,
}

impl Default for PngOptions {
    fn default() -> Self {
        Self { exposure: 0.0, tonemap: ToneMap::Neutral, alpha: false }
    }
}

/// Khronos PBR Neutral tone mapping of linear RGB.
pub fn pbr_neutral(c: [f32; 3]) -> [f32; 3] {
    const START: f32 = 0.8 - 0.04;
    const DESATURATION: f32 = 0.15;
    let x = c[0].min(c[1]).min(c[2]);
    let offset = if x < 0.08 { x - 6.25 * x * x } else { 0.04 };
    let c = c.map(|v| v - offset);
    let peak = c[0].max(c[1]).max(c[2]);
    if peak < START {
        return c;
    }
    let d = 1.0 - START;
    let new_peak = 1.0 - d * d / (peak + d - START);
    let g = 1.0 - 1.0 / (DESATURATION * (peak - new_peak) + 1.0);
    c.map(|v| v * new_peak / peak * (1.0 - g) + new_peak * g)
}

/// Narkowicz's ACES filmic fit.
pub fn aces(c: [f32; 3]) -> [f32; 3] {
    c.map(|x| ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0))
}

/// The sRGB opto-electronic transfer function.
pub fn srgb_encode(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 }
}

/// 8-bit display value of a linear color.
pub fn display(c: [f32; 3], opts: &PngOptions) -> [u8; 3] {
    let scale = opts.exposure.exp2();
    let c = c.map(|v| if v.is_finite() { (v * scale).max(0.0) } else { 0.0 });
    let mapped = match opts.tonemap {
        ToneMap::Neutral => pbr_neutral(c),
        ToneMap::Aces => aces(c),
        ToneMap::Clamp => c,
    };
    mapped.map(|v| (srgb_encode(v) * 255.0 + 0.5) as u8)
}

/// The PNG file of `image`'s beauty pass, tone-mapped, in memory.
pub fn encode(image: &Image, opts: &PngOptions) -> Result<Vec<u8>> {
    let beauty = &image.layers[0].data;
    let channels = if opts.alpha { 4 } else { 3 };
    let mut pixels = Vec::with_capacity((image.width * image.height) as usize * channels);
    for px in beauty.chunks(4) {
        pixels.extend_from_slice(&display([px[0], px[1], px[2]], opts));
        if opts.alpha {
            pixels.push((px[3].clamp(0.0, 1.0) * 255.0 + 0.5) as u8);
        }
    }
    let color = if opts.alpha { image::ExtendedColorType::Rgba8 } else { image::ExtendedColorType::Rgb8 };
    let mut bytes = std::io::Cursor::new(Vec::new());
    image::write_buffer_with_format(&mut bytes, &pixels, image.width, image.height, color, image::ImageFormat::Png)
        .context("PNG encoding failed")?;
    Ok(bytes.into_inner())
}

/// Writes `image` to `path` (not atomically: see [`super::write_with`]).
pub fn write(image: &Image, path: &Path, opts: &PngOptions) -> Result<()> {
    let bytes = encode(image, opts)?;
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neutral_keeps_mid_tones_and_compresses_highlights() {
        // Below the compression start, only the small toe offset applies.
        let c = pbr_neutral([0.5, 0.4, 0.3]);
        assert!((c[0] - 0.46).abs() < 1e-6 && (c[2] - 0.26).abs() < 1e-6, "{c:?}");
        // Highlights approach but never exceed white.
        let h = pbr_neutral([50.0, 50.0, 50.0]);
        assert!(h.iter().all(|&v| v > 0.95 && v <= 1.0), "{h:?}");
    }

    #[test]
    fn srgb_matches_the_standard_at_known_points() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_encode(0.18) - 0.4614).abs() < 1e-3);
    }
}
