//! The environment as a light, as pbrt-v4's image infinite light: its radiance held piecewise
//! constant over the equirectangular texels, sampled in proportion to luminance × solid angle.
//! Photons leave it (stage 4: a direction from the table, a start on a disc across the volume's
//! bounding sphere), and receivers send shadow rays toward it (stage 6: one direction from the
//! table and one by cos θ per pair, weighted by the balance heuristic).
//!
//! The table is built once per uploaded image (`EnvLightTable::of`), in the environment's own
//! frame (before `rotation`) and without its `intensity` and colour, which scale it on the GPU:
//! an animated intensity or turn costs nothing here. A colour environment is the 1×1 table of
//! ones (uniform over the sphere). Its GPU twin is `shaders/shared/env_light.wgsl`, which reads
//! [`EnvLightTable::gpu_words`].

use std::f32::consts::PI;

use glam::{Quat, Vec2, Vec3};

use crate::scene::environment::{EnvImage, dir_to_uv};
use crate::scene::{Environment, EnvironmentSource};

/// Widest table: larger images are box-filtered down by powers of two (a 3° sun still spans
/// ~8 texels of a 1024-wide table; 1024×512 is 8 MiB on the GPU).
pub const MAX_TABLE_WIDTH: u32 = 1024;

/// Words before the CDFs in [`EnvLightTable::gpu_words`]: width, height (as bits), the
/// luminance power, 0, then ∫ L dω (rgb) and 0.
pub const HEADER_WORDS: usize = 8;

/// The luminance that samples are drawn by: the channels' mean, as the photon raster's.
pub fn luminance(c: Vec3) -> f32 {
    (c.x + c.y + c.z) / 3.0
}

/// Turning the environment by `turn` is looking it up along the direction turned back
/// (`env_rotate` in shared/environment.wgsl): world → the table's frame.
pub fn to_table_frame(turn: Quat, d: Vec3) -> Vec3 {
    turn.inverse() * d
}

/// The table's frame → world (`env_unrotate`).
pub fn from_table_frame(turn: Quat, r: Vec3) -> Vec3 {
    turn * r
}

/// What the table is multiplied by on the GPU: the environment's colour (a colour
/// environment's table is ones) × its intensity, as `env_radiance` scales what is seen.
pub fn scale(env: &Environment) -> Vec3 {
    let colour = match &env.source {
        EnvironmentSource::Color(c) => *c,
        _ => Vec3::ONE,
    };
    colour * env.intensity
}

/// A direction drawn from the table: unit `dir` (table frame), its density in solid angle, and
/// the table's radiance there.
#[derive(Clone, Copy, Debug)]
pub struct EnvSample {
    pub dir: Vec3,
    pub pdf: f32,
    pub radiance: Vec3,
}

#[derive(Clone, Debug, PartialEq)]
pub struct EnvLightTable {
    pub width: u32,
    pub height: u32,
    /// Radiance per texel, row 0 at the top (the image's own texels, or their box filter).
    pub radiance: Vec<Vec3>,
    /// CDF over rows, `height + 1` entries from 0 to 1 (rows weighted by Σ luminance × Ω).
    pub marginal: Vec<f32>,
    /// Per row, the CDF over its texels, `width + 1` entries from 0 to 1.
    pub conditional: Vec<f32>,
    /// ∫ luminance(L) dω over the sphere (the sampling density's normalization).
    pub power: f32,
    /// ∫ L dω over the sphere, rgb: the flux per unit area the environment sends through any
    /// plane, both sides together.
    pub integral: Vec3,
}

impl EnvLightTable {
    /// A colour environment's table: radiance 1 everywhere (the colour scales it).
    pub fn uniform() -> Self {
        Self::from_texels(1, 1, vec![Vec3::ONE])
    }

    /// The table of an equirectangular image, filtered down to at most [`MAX_TABLE_WIDTH`].
    pub fn of_image(image: &EnvImage) -> Self {
        let (mut w, mut h) = (image.width, image.height);
        let mut texels: Vec<Vec3> = image.texels.iter().map(|t| Vec3::new(t[0], t[1], t[2])).collect();
        while w > MAX_TABLE_WIDTH && w % 2 == 0 && h % 2 == 0 {
            (texels, w, h) = (halved(&texels, w, h), w / 2, h / 2);
        }
        Self::from_texels(w, h, texels)
    }

    fn from_texels(width: u32, height: u32, radiance: Vec<Vec3>) -> Self {
        let (w, h) = (width as usize, height as usize);
        let mut conditional = Vec::with_capacity(h * (w + 1));
        let mut row_weights = Vec::with_capacity(h);
        let mut integral = Vec3::ZERO;
        for y in 0..h {
            let row = &radiance[y * w..(y + 1) * w];
            let omega = texel_solid_angle(y as u32, width, height);
            let sum: f32 = row.iter().map(|&l| luminance(l)).sum();
            integral += row.iter().copied().sum::<Vec3>() * omega;
            row_weights.push(sum * omega);
            push_cdf(&mut conditional, row.iter().map(|&l| luminance(l)));
        }
        let mut marginal = Vec::with_capacity(h + 1);
        push_cdf(&mut marginal, row_weights.iter().copied());
        let power = row_weights.iter().sum();
        Self { width, height, radiance, marginal, conditional, power, integral }
    }

    /// Direction for two uniform numbers (the CPU twin of `env_light_sample`).
    pub fn sample(&self, u: Vec2) -> EnvSample {
        let (row, ty) = search(&self.marginal, u.x);
        let w = self.width as usize;
        let (col, tx) = search(&self.conditional[row * (w + 1)..(row + 1) * (w + 1)], u.y);
        let (top, bottom) = row_sines(row as u32, self.height);
        let y = bottom + (top - bottom) * ty;
        let phi = ((col as f32 + tx) / self.width as f32 - 0.5) * 2.0 * PI;
        let c = (1.0 - y * y).max(0.0).sqrt();
        let dir = Vec3::new(c * phi.cos(), y, c * phi.sin());
        let radiance = self.radiance[row * w + col];
        EnvSample { dir, pdf: luminance(radiance) / self.power, radiance }
    }

    /// The texel a table-frame direction falls in.
    fn texel(&self, d: Vec3) -> usize {
        let uv = dir_to_uv(d);
        let x = ((uv.x * self.width as f32) as i64).rem_euclid(self.width as i64) as usize;
        let y = ((uv.y * self.height as f32) as i64).clamp(0, self.height as i64 - 1) as usize;
        y * self.width as usize + x
    }

    /// Density (per steradian) of drawing table-frame direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        luminance(self.radiance[self.texel(d)]) / self.power
    }

    /// The table's radiance along table-frame direction `d`.
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        self.radiance[self.texel(d)]
    }

    /// E = ∫ L max(n·ω, 0) dω of the table (no occlusion), by a `k`×`k` midpoint rule inside
    /// each texel, equal-area in (φ, sin β): the closed form tests hold images against.
    pub fn irradiance(&self, n: Vec3, k: u32) -> Vec3 {
        let mut e = Vec3::ZERO;
        for y in 0..self.height {
            let (top, bottom) = row_sines(y, self.height);
            let omega = texel_solid_angle(y, self.width, self.height) / (k * k) as f32;
            for x in 0..self.width {
                let l = self.radiance[(y * self.width + x) as usize];
                if l == Vec3::ZERO {
                    continue;
                }
                let mut cos_sum = 0.0;
                for j in 0..k {
                    let s = bottom + (top - bottom) * (j as f32 + 0.5) / k as f32;
                    for i in 0..k {
                        let u = (x as f32 + (i as f32 + 0.5) / k as f32) / self.width as f32;
                        let phi = (u - 0.5) * 2.0 * PI;
                        let c = (1.0 - s * s).max(0.0).sqrt();
                        cos_sum += n.dot(Vec3::new(c * phi.cos(), s, c * phi.sin())).max(0.0);
                    }
                }
                e += l * cos_sum * omega;
            }
        }
        e
    }

    /// The table as the GPU reads it (`shaders/shared/env_light.wgsl`): the header, the
    /// marginal CDF, the conditional CDFs, then the radiance, 3 words a texel.
    pub fn gpu_words(&self) -> Vec<f32> {
        let mut words = Vec::with_capacity(HEADER_WORDS + self.marginal.len() + self.conditional.len() + 3 * self.radiance.len());
        words.extend([f32::from_bits(self.width), f32::from_bits(self.height), self.power, 0.0]);
        words.extend([self.integral.x, self.integral.y, self.integral.z, 0.0]);
        words.extend(&self.marginal);
        words.extend(&self.conditional);
        words.extend(self.radiance.iter().flat_map(|l| l.to_array()));
        words
    }
}

/// sin β at the top and bottom edge of row `y` (β the elevation; row 0 at the top).
fn row_sines(y: u32, height: u32) -> (f32, f32) {
    let edge = |row: u32| ((0.5 - row as f32 / height as f32) * PI).sin();
    (edge(y), edge(y + 1))
}

/// Solid angle of one texel of row `y`: Δφ × (sin β_top − sin β_bottom).
pub fn texel_solid_angle(y: u32, width: u32, height: u32) -> f32 {
    let (top, bottom) = row_sines(y, height);
    2.0 * PI / width as f32 * (top - bottom)
}

/// Appends the CDF of `weights` (a leading 0, then the running sums over the total; uniform
/// steps when all are 0, a row that is then never chosen).
fn push_cdf(out: &mut Vec<f32>, weights: impl Iterator<Item = f32> + Clone) {
    let n = weights.clone().count();
    let total: f64 = weights.clone().map(|w| w as f64).sum();
    out.push(0.0);
    let mut running = 0.0f64;
    for (i, w) in weights.enumerate() {
        running += w as f64;
        out.push(if total > 0.0 { (running / total) as f32 } else { (i + 1) as f32 / n as f32 });
    }
    if let Some(last) = out.last_mut() {
        *last = 1.0;
    }
}

/// The interval of `cdf` (n + 1 entries) that u falls in, and where in it (0..1): the last i
/// with cdf[i] ≤ u, skipping empty intervals (the GPU's binary search finds the same).
fn search(cdf: &[f32], u: f32) -> (usize, f32) {
    let n = cdf.len() - 1;
    let (mut lo, mut hi) = (0usize, n - 1);
    while lo < hi {
        let mid = (lo + hi).div_ceil(2);
        if cdf[mid] <= u {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    let width = cdf[lo + 1] - cdf[lo];
    (lo, if width > 0.0 { ((u - cdf[lo]) / width).clamp(0.0, 1.0 - f32::EPSILON) } else { 0.5 })
}

/// Half the resolution: each texel the solid-angle-weighted mean of its 2×2 (rows nearer a pole
/// hold less of the sphere).
fn halved(texels: &[Vec3], w: u32, h: u32) -> Vec<Vec3> {
    let (w2, h2) = (w / 2, h / 2);
    let mut out = Vec::with_capacity((w2 * h2) as usize);
    for y in 0..h2 {
        let (a, b) = (texel_solid_angle(2 * y, w, h), texel_solid_angle(2 * y + 1, w, h));
        for x in 0..w2 {
            let at = |yy: u32, xx: u32| texels[(yy * w + xx) as usize];
            let top = at(2 * y, 2 * x) + at(2 * y, 2 * x + 1);
            let bottom = at(2 * y + 1, 2 * x) + at(2 * y + 1, 2 * x + 1);
            out.push((top * a + bottom * b) / (2.0 * (a + b)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::environment::uv_to_dir;

    /// The direction through the centre of texel (x, y).
    fn centre_of(table: &EnvLightTable, x: u32, y: u32) -> Vec3 {
        uv_to_dir(Vec2::new((x as f32 + 0.5) / table.width as f32, (y as f32 + 0.5) / table.height as f32))
    }

    fn image(w: u32, h: u32, f: impl Fn(u32, u32) -> [f32; 3]) -> EnvImage {
        let texels = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| { let c = f(x, y); [c[0], c[1], c[2], 1.0] }).collect();
        EnvImage { width: w, height: h, texels }
    }

    #[test]
    fn a_uniform_table_is_uniform_over_the_sphere() {
        let t = EnvLightTable::uniform();
        assert!((t.power - 4.0 * PI).abs() < 1e-4);
        assert!((t.integral - Vec3::splat(4.0 * PI)).abs().max_element() < 1e-4);
        // E on any plane under radiance 1 is π.
        assert!((t.irradiance(Vec3::Y, 64) - Vec3::splat(PI)).abs().max_element() < 2e-3);
        let s = t.sample(Vec2::new(0.3, 0.7));
        assert!((s.pdf - 1.0 / (4.0 * PI)).abs() < 1e-6);
        assert!((s.dir.length() - 1.0).abs() < 1e-5);
        // Uniform in solid angle: y = sin β uniform in [−1, 1], from the bottom of the row up.
        assert!((t.sample(Vec2::new(0.25, 0.5)).dir.y + 0.5).abs() < 1e-5);
    }

    /// Sampling lands each texel with probability luminance × Ω / power, and the density it
    /// reports integrates to one.
    #[test]
    fn samples_follow_luminance_times_solid_angle() {
        let t = EnvLightTable::of_image(&image(16, 8, |x, y| [(x + 1) as f32, (y * y) as f32, 0.5]));
        let n = 256u32;
        let mut counts = vec![0u32; 128];
        for i in 0..n {
            for j in 0..n {
                let s = t.sample(Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32));
                counts[t.texel(s.dir)] += 1;
                assert!((s.pdf - t.pdf(s.dir)).abs() <= 1e-6 * s.pdf.max(1.0), "the density at the sample is the density of its texel");
            }
        }
        for y in 0..8 {
            for x in 0..16 {
                let i = (y * 16 + x) as usize;
                let p = luminance(t.radiance[i]) * texel_solid_angle(y, 16, 8) / t.power;
                let got = counts[i] as f32 / (n * n) as f32;
                assert!((got - p).abs() < 2e-3 + 0.02 * p, "texel ({x}, {y}): {got} drawn, {p} expected");
                assert_eq!(t.texel(centre_of(&t, x, y)), i);
            }
        }
    }

    #[test]
    fn halving_keeps_the_integral() {
        let img = image(2048, 1024, |x, y| [((x / 7) % 3) as f32, (y % 5) as f32 * 0.1, 1.0]);
        let full = EnvLightTable::from_texels(2048, 1024, img.texels.iter().map(|t| Vec3::new(t[0], t[1], t[2])).collect());
        let table = EnvLightTable::of_image(&img);
        assert_eq!((table.width, table.height), (1024, 512));
        assert!((table.integral - full.integral).abs().max_element() < 1e-3 * full.integral.max_element());
    }

    #[test]
    fn rotation_round_trips() {
        let d = Vec3::new(0.3, 0.5, -0.8).normalize();
        let turn = Quat::from_rotation_y(0.7) * Quat::from_rotation_x(0.3);
        assert!((from_table_frame(turn, to_table_frame(turn, d)) - d).length() < 1e-6);
    }
}
