//! The environment: what rays see when they leave the scene. A constant color, an
//! equirectangular `.exr`/`.hdr` image, or a procedural preset generated here (so examples and
//! tests need no image files).
//!
//! Lookup follows Blender's equirectangular convention converted to Y up (see
//! `shaders/shared/environment.wgsl`); [`Environment::radiance`] is its CPU twin.

use std::f32::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

use anyhow::{Context, Result, bail};
use glam::{Quat, Vec2, Vec3};

use super::image_header;

/// A linear-light equirectangular image, row 0 at the top.
#[derive(Debug, PartialEq)]
pub struct EnvImage {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[f32; 4]>,
}

impl EnvImage {
    /// An image of `f(direction)`, each texel the mean of 2×2 samples so that hard edges in
    /// `f` come out antialiased. Bands of rows are filled on the CPU's cores side by side (a
    /// 2048×1024 preset is 8M calls of `f`: a quarter of a second on one core, paid at every
    /// start); each texel depends on its own position only, so the image is the same whatever
    /// the cores.
    pub fn from_fn(width: u32, height: u32, f: impl Fn(Vec3) -> Vec3 + Sync) -> Self {
        let mut texels = vec![[0.0f32; 4]; (width * height) as usize];
        let texel = |x: u32, y: u32| {
            let mut c = Vec3::ZERO;
            for (sx, sy) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
                let uv = Vec2::new((x as f32 + sx) / width as f32, (y as f32 + sy) / height as f32);
                c += f(uv_to_dir(uv));
            }
            c *= 0.25;
            [c.x, c.y, c.z, 1.0]
        };
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let band_rows = height.div_ceil(cores as u32).max(1) as usize;
        std::thread::scope(|s| {
            for (band, rows) in texels.chunks_mut((band_rows * width as usize).max(1)).enumerate() {
                let texel = &texel;
                s.spawn(move || {
                    for (i, out) in rows.iter_mut().enumerate() {
                        let (x, y) = (i % width as usize, band * band_rows + i / width as usize);
                        *out = texel(x as u32, y as u32);
                    }
                });
            }
        });
        Self { width, height, texels }
    }

    /// Bilinear lookup at texture coordinates (u wraps, v clamps), like the GPU sampler.
    pub fn bilinear(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.width as i64, self.height as i64);
        let fx = uv.x * w as f32 - 0.5;
        let fy = (uv.y * h as f32 - 0.5).clamp(0.0, (h - 1) as f32);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - x0, fy - y0);
        let texel = |x: i64, y: i64| {
            let t = self.texels[(y.clamp(0, h - 1) * w + x.rem_euclid(w)) as usize];
            Vec3::new(t[0], t[1], t[2])
        };
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = texel(x0, y0).lerp(texel(x0 + 1, y0), tx);
        let bottom = texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), tx);
        top.lerp(bottom, ty)
    }
}

/// Texture coordinates → direction (inverse of [`dir_to_uv`]).
pub fn uv_to_dir(uv: Vec2) -> Vec3 {
    let phi = (uv.x - 0.5) * 2.0 * PI;
    let lat = (0.5 - uv.y) * PI;
    Vec3::new(lat.cos() * phi.cos(), lat.sin(), lat.cos() * phi.sin())
}

/// Direction → texture coordinates, Blender's convention in Y-up (row 0 at the top).
pub fn dir_to_uv(d: Vec3) -> Vec2 {
    let u = 0.5 + d.z.atan2(d.x) / (2.0 * PI);
    let v = 0.5 + d.y.clamp(-1.0, 1.0).asin() / PI;
    Vec2::new(u, 1.0 - v)
}

/// Where the environment's radiance comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum EnvironmentSource {
    Color(Vec3),
    Image { path: PathBuf, image: Arc<EnvImage> },
    Preset { name: String, image: Arc<EnvImage> },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    pub source: EnvironmentSource,
    pub intensity: f32,
    /// Turn about +Y, radians (counter-clockwise seen from above).
    pub rotation: f32,
    /// A turn before `rotation` that tilts the environment's horizon (Blender's Mapping node
    /// rotated about X or Y): what was seen along d is seen along `turn()`·d.
    pub tilt: Quat,
    /// Whether camera rays that meet no medium see it (false: transparent film).
    pub visible: bool,
}

impl Default for Environment {
    fn default() -> Self {
        Self { source: EnvironmentSource::Color(Vec3::splat(0.05)), intensity: 1.0, rotation: 0.0, tilt: Quat::IDENTITY, visible: true }
    }
}

impl Environment {
    pub fn image(&self) -> Option<&Arc<EnvImage>> {
        match &self.source {
            EnvironmentSource::Color(_) => None,
            EnvironmentSource::Image { image, .. } | EnvironmentSource::Preset { image, .. } => Some(image),
        }
    }

    /// Whether the GPU evaluates the environment per ray (the studio preset, sharp at any
    /// output size) rather than looking it up in its image.
    pub fn evaluated_per_ray(&self) -> bool {
        matches!(&self.source, EnvironmentSource::Preset { name, .. } if name == "studio")
    }

    /// The environment's whole turn, R_y(rotation) · tilt: what was seen along d (in the image's
    /// own frame) is seen along turn·d.
    pub fn turn(&self) -> Quat {
        Quat::from_rotation_y(self.rotation) * self.tilt
    }

    /// Radiance seen along unit direction `d`, as a point.
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        self.radiance_over(d, 0.0)
    }

    /// Radiance seen along unit direction `d` by a cone `footprint` radians wide (a camera
    /// pixel's) — the CPU twin of `env_radiance` in WGSL.
    pub fn radiance_over(&self, d: Vec3, footprint: f32) -> Vec3 {
        let r = self.turn().inverse() * d;
        match &self.source {
            EnvironmentSource::Color(col) => *col * self.intensity,
            _ if self.evaluated_per_ray() => studio(r, footprint) * self.intensity,
            EnvironmentSource::Image { image, .. } | EnvironmentSource::Preset { image, .. } => {
                image.bilinear(dir_to_uv(r)) * self.intensity
            }
        }
    }
}

/// Loads an equirectangular `.exr` or `.hdr` file as linear RGB. Its header is checked against
/// [`image_header::ENVIRONMENT`] before any pixel memory is allocated.
pub fn load_image(path: &Path) -> Result<EnvImage> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_lowercase();
    let caps = image_header::ENVIRONMENT;
    let image = match ext.as_str() {
        "exr" => {
            image_header::check_exr(path, &caps)?;
            let img = exr::prelude::read_first_rgba_layer_from_file(
                path,
                |res, _| EnvImage {
                    width: res.width() as u32,
                    height: res.height() as u32,
                    texels: vec![[0.0, 0.0, 0.0, 1.0]; res.width() * res.height()],
                },
                |img: &mut EnvImage, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                    let w = img.width as usize;
                    img.texels[pos.y() * w + pos.x()] = [r, g, b, 1.0];
                },
            )
            .with_context(|| format!("cannot read the environment image {}", path.display()))?;
            img.layer_data.channel_data.pixels
        }
        "hdr" => {
            image_header::check_hdr(path, &caps)?;
            let mut reader = image::ImageReader::open(path)
                .with_context(|| format!("cannot read the environment image {}", path.display()))?;
            reader.set_format(image::ImageFormat::Hdr);
            let mut limits = image::Limits::default();
            limits.max_alloc = Some(caps.max_texels() * 16);
            reader.limits(limits);
            let img = reader
                .decode()
                .with_context(|| format!("cannot read the environment image {}", path.display()))?
                .into_rgb32f();
            EnvImage {
                width: img.width(),
                height: img.height(),
                texels: img.pixels().map(|p| [p[0], p[1], p[2], 1.0]).collect(),
            }
        }
        _ => bail!(
            "environment image {} must be an equirectangular .exr or .hdr file",
            path.display()
        ),
    };
    if image.width < 2 || image.height < 1 {
        bail!("environment image {} is empty", path.display());
    }
    if image.texels.iter().any(|t| !t.iter().all(|c| c.is_finite())) {
        bail!("environment image {} contains NaN or infinite texels", path.display());
    }
    Ok(image)
}

/// The environment `--environment PRESET|FILE[:INTENSITY]` names: a built-in preset, else an
/// equirectangular `.exr` / `.hdr` file (relative to the working folder), times an intensity
/// (default 1) after the last `:` when that is a number ≥ 0 — so `C:\sky.hdr` and `sky:2` both
/// read as meant.
pub fn from_arg(arg: &str) -> Result<Environment> {
    let (name, intensity) = match arg.rsplit_once(':').map(|(n, i)| (n, i.parse::<f32>())) {
        Some((name, Ok(i))) if i.is_finite() && i >= 0.0 => (name, i),
        Some((_, Ok(i))) => bail!("--environment {arg}: the intensity after ':' must be a number ≥ 0, got {i}"),
        _ => (arg, 1.0),
    };
    let source = if PRESETS.contains(&name) {
        EnvironmentSource::Preset { name: name.to_string(), image: preset(name)? }
    } else {
        let path = Path::new(name);
        if !path.is_file() {
            bail!(
                "--environment {arg}: \"{name}\" is neither a preset ({}) nor an .exr or .hdr file that exists",
                PRESETS.join(", ")
            );
        }
        EnvironmentSource::Image { path: path.to_path_buf(), image: load_image(path)?.into() }
    };
    Ok(Environment { source, intensity, ..Environment::default() })
}

/// Names of the built-in environments.
pub const PRESETS: &[&str] = &["studio", "sky", "sunny", "checker"];

/// A built-in environment, generated once per process.
pub fn preset(name: &str) -> Result<Arc<EnvImage>> {
    static CACHE: OnceLock<Mutex<Vec<(String, Arc<EnvImage>)>>> = OnceLock::new();
    let cache = CACHE.get_or_init(|| Mutex::new(Vec::new()));
    let mut cache = cache.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, img)) = cache.iter().find(|(n, _)| n == name) {
        return Ok(img.clone());
    }
    let img = Arc::new(match name {
        "studio" => {
            // Two by two samples a texel: each stands for a cone half a texel wide.
            let footprint = PI / 2048.0;
            EnvImage::from_fn(2048, 1024, |d| studio(d, footprint))
        }
        "sky" => EnvImage::from_fn(2048, 1024, sky),
        "sunny" => EnvImage::from_fn(2048, 1024, sunny),
        "checker" => EnvImage::from_fn(512, 256, checker),
        _ => bail!("unknown environment preset \"{name}\" (choose one of: {})", PRESETS.join(", ")),
    });
    cache.push((name.to_string(), img.clone()));
    Ok(img)
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The studio floor's tiles: 0.5 m squares on a plane 1.5 m below the eye.
const STUDIO_FLOOR_DEPTH: f32 = 1.5;
const STUDIO_TILES_PER_METRE: f32 = 2.0;

/// A photo studio: a dim grey cyclorama, a tiled floor that shows refraction clearly, and two
/// soft boxes that put highlights and bright caustic-like shapes into glass.
///
/// `footprint` is the angular width (radians) of the cone of directions the lookup stands for
/// (a camera pixel's): the floor's checker is box-filtered over that cone's footprint on the
/// floor, so its edges are antialiased at any output size and its far tiles fade to their mean
/// instead of aliasing. The GPU evaluates this per ray (`env_studio` in
/// `shaders/shared/environment.wgsl`); the equirectangular image made from it serves only the
/// environment's mean and the glossy receivers' prefiltered lobes.
pub fn studio(d: Vec3, footprint: f32) -> Vec3 {
    let horizon = Vec3::new(0.55, 0.56, 0.6);
    if d.y < 0.0 {
        let depth = (-d.y).max(1e-3);
        // Where the ray meets the floor, in tiles, and the cone's footprint there: across the
        // ray it is footprint·t wide, along the ray's horizontal heading stretched by 1/|d.y|
        // (the grazing angle); its bounding box per axis is the box filter's width.
        let t = STUDIO_FLOOR_DEPTH / depth;
        let p = Vec2::new(d.x, d.z) * t * STUDIO_TILES_PER_METRE;
        let heading = Vec2::new(d.x, d.z).normalize_or(Vec2::X);
        let across = footprint * t * STUDIO_TILES_PER_METRE;
        let along = across / depth;
        let w = Vec2::new(
            (heading.x * along).hypot(heading.y * across),
            (heading.y * along).hypot(heading.x * across),
        );
        let dark = box_filtered_checker(p, w);
        let base = Vec3::new(0.62, 0.6, 0.56).lerp(Vec3::new(0.16, 0.16, 0.18), dark);
        let fade = smoothstep(0.0, 0.25, -d.y);
        return horizon.lerp(base, fade);
    }
    let wall = horizon.lerp(Vec3::new(0.22, 0.24, 0.3), smoothstep(0.0, 0.9, d.y));
    let softbox = |centre: Vec3, size: f32, power: f32| {
        let c = centre.normalize();
        let cos = d.dot(c);
        power * smoothstep((size * 1.15).cos(), size.cos(), cos)
    };
    let key = softbox(Vec3::new(-1.0, 1.2, 0.6), 0.28, 14.0);
    let rim = softbox(Vec3::new(1.0, 0.6, -1.0), 0.18, 8.0);
    wall + Vec3::new(1.0, 0.97, 0.92) * key + Vec3::new(0.85, 0.9, 1.0) * rim
}

/// The share of odd squares ((⌊x⌋ + ⌊y⌋) odd) in the box of width `w` centred on `p`: the
/// checker convolved with a box, in closed form. Per axis, the square wave s(x) = ±1 (+1 where
/// ⌊x⌋ is even) is −2× the slope of the triangle wave tri(x) = |fract(x/2) − ½|, so its mean
/// over the box is 2·(tri(p − w/2) − tri(p + w/2))/w; the box is separable, so the 2D mean of
/// s(x)·s(y) is the product of the axes' means, and the odd share is (1 − that)/2. At w → 0 it
/// is the plain checker; over many squares it tends to ½.
pub fn box_filtered_checker(p: Vec2, w: Vec2) -> f32 {
    let w = w.max(Vec2::splat(1e-4));
    let tri = |x: Vec2| (fract(x * 0.5) - Vec2::splat(0.5)).abs();
    let wave = 2.0 * (tri(p - 0.5 * w) - tri(p + 0.5 * w)) / w;
    0.5 - 0.5 * wave.x * wave.y
}

fn fract(x: Vec2) -> Vec2 {
    x - x.floor()
}

/// A clear sky: blue zenith, bright hazy horizon, brown ground, and a small warm sun.
fn sky(d: Vec3) -> Vec3 {
    sky_with_sun(d, Vec3::new(60.0, 55.0, 45.0))
}

/// A blue sky over brown ground with a sun disc ~2.3° across, 37° up, of radiance `sun`.
fn sky_with_sun(d: Vec3, sun: Vec3) -> Vec3 {
    if d.y < 0.0 {
        return Vec3::new(0.25, 0.22, 0.18).lerp(Vec3::new(0.12, 0.1, 0.08), smoothstep(0.0, 0.4, -d.y));
    }
    let base = Vec3::new(0.9, 0.95, 1.05).lerp(Vec3::new(0.18, 0.32, 0.7), smoothstep(0.0, 0.6, d.y));
    let sun_dir = Vec3::new(0.4, 0.6, -0.7).normalize();
    base + sun * smoothstep(0.9995, 0.9998, d.dot(sun_dir))
}

/// The sky with a sun as bright as a clear day's against its sky: on a floor the sun gives
/// about five times the sky's irradiance, so it casts hard shadows and caustics — an HDRI
/// as photographed, for scenes lit by their environment alone.
fn sunny(d: Vec3) -> Vec3 {
    sky_with_sun(d, Vec3::new(6000.0, 5600.0, 5000.0))
}

/// A longitude/latitude checkerboard with a tint per octant: every direction is recognisable,
/// which makes it the environment of the optics tests.
fn checker(d: Vec3) -> Vec3 {
    let uv = dir_to_uv(d);
    let cell = ((uv.x * 24.0).floor() as i64 + (uv.y * 12.0).floor() as i64).rem_euclid(2);
    let tint = Vec3::new(
        if d.x > 0.0 { 1.0 } else { 0.35 },
        if d.y > 0.0 { 1.0 } else { 0.35 },
        if d.z > 0.0 { 1.0 } else { 0.35 },
    );
    tint * if cell == 0 { 1.0 } else { 0.15 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uv_and_direction_are_inverse() {
        for &d in &[Vec3::X, Vec3::Z, Vec3::new(-0.3, 0.5, 0.8).normalize(), Vec3::new(0.1, -0.9, -0.2).normalize()] {
            let back = uv_to_dir(dir_to_uv(d));
            assert!((back - d).length() < 1e-5, "{d} → {back}");
        }
        // Blender's convention: the image centre looks down +X, the top row is straight up.
        assert!((dir_to_uv(Vec3::X) - Vec2::new(0.5, 0.5)).length() < 1e-6);
        assert!(dir_to_uv(Vec3::Y).y.abs() < 1e-6);
    }

    #[test]
    fn every_texel_is_the_mean_of_its_own_four_samples_whatever_the_bands() {
        // A size no core count divides evenly, and a function that tells directions apart.
        let f = |d: Vec3| Vec3::new(d.x, d.y * d.y, (3.0 * d.z).sin());
        let (w, h) = (37, 13);
        let img = EnvImage::from_fn(w, h, f);
        for y in 0..h {
            for x in 0..w {
                let at = |sx: f32, sy: f32| f(uv_to_dir(Vec2::new((x as f32 + sx) / w as f32, (y as f32 + sy) / h as f32)));
                let mean = (at(0.25, 0.25) + at(0.75, 0.25) + at(0.25, 0.75) + at(0.75, 0.75)) * 0.25;
                let t = img.texels[(x + w * y) as usize];
                assert!((Vec3::new(t[0], t[1], t[2]) - mean).length() < 1e-6, "texel ({x}, {y})");
                assert_eq!(t[3], 1.0);
            }
        }
    }

    /// The checker's closed-form box filter against the mean of the plain checker over the box,
    /// by a 256×256 grid of points, for boxes from a tenth of a square to many squares.
    #[test]
    fn the_box_filtered_checker_is_the_checkers_mean_over_the_box() {
        let plain = |p: Vec2| ((p.x.floor() as i64 + p.y.floor() as i64).rem_euclid(2)) as f32;
        for (p, w) in [
            (Vec2::new(0.3, 0.7), Vec2::new(0.1, 0.1)),
            (Vec2::new(1.05, -2.5), Vec2::new(0.3, 0.05)),
            (Vec2::new(-0.5, 3.2), Vec2::new(1.7, 0.6)),
            (Vec2::new(10.25, 4.9), Vec2::new(6.3, 11.0)),
        ] {
            let n = 256;
            let mut sum = 0.0;
            for i in 0..n {
                for j in 0..n {
                    let o = (Vec2::new(i as f32, j as f32) + 0.5) / n as f32 - 0.5;
                    sum += plain(p + o * w);
                }
            }
            let mean = sum / (n * n) as f32;
            let filtered = box_filtered_checker(p, w);
            assert!((filtered - mean).abs() < 0.01, "at {p}, width {w}: {filtered} vs the mean {mean}");
        }
        // A vanishing box is the plain checker; a box of many squares their mean.
        assert!(box_filtered_checker(Vec2::new(0.5, 0.5), Vec2::ZERO).abs() < 1e-3);
        assert!((box_filtered_checker(Vec2::new(1.5, 0.5), Vec2::ZERO) - 1.0).abs() < 1e-3);
        assert!((box_filtered_checker(Vec2::new(0.2, 0.9), Vec2::splat(40.3)) - 0.5).abs() < 0.02);
    }

    /// The studio's floor tiles are sharp for a point and filtered for a cone: across a tile
    /// edge, a pixel's value moves smoothly from one tile's colour to the other's, and far away
    /// near the horizon the tiles average out instead of aliasing.
    #[test]
    fn the_studio_floor_is_filtered_over_the_lookups_cone() {
        let dir = |x: f32, z: f32| Vec3::new(x, -1.5, z).normalize();
        // A point exactly at an edge of tiles (x = 0.5 m) is one tile or the other; a cone
        // stepping across it moves through the values in between.
        let steps: Vec<f32> = (0..9).map(|i| studio(dir(0.5 + (i as f32 - 4.0) * 0.002, 0.25), 0.004).x).collect();
        assert!(steps.windows(2).all(|w| w[1] >= w[0] - 1e-6) || steps.windows(2).all(|w| w[1] <= w[0] + 1e-6), "{steps:?}");
        assert!(steps[0] != steps[8] && steps[4] != steps[0] && steps[4] != steps[8], "{steps:?}");
        // Near the horizon a pixel's cone covers many tiles: their mean, not one of them.
        let far = Vec3::new(1.0, -0.02, 0.3).normalize();
        let (bright, dark) = (studio(far, 0.0), studio(far, 0.002));
        let mean = Vec3::new(0.55, 0.56, 0.6).lerp((Vec3::new(0.62, 0.6, 0.56) + Vec3::new(0.16, 0.16, 0.18)) * 0.5, smoothstep(0.0, 0.25, -far.y));
        assert!((dark - mean).length() < 0.02, "{dark} vs the tiles' mean {mean} (a point sees {bright})");
    }

    #[test]
    fn rotation_turns_the_environment_counter_clockwise_about_y() {
        let img = preset("checker").unwrap();
        let env = |rotation| Environment {
            source: EnvironmentSource::Preset { name: "checker".into(), image: img.clone() },
            intensity: 1.0,
            rotation,
            tilt: Quat::IDENTITY,
            visible: true,
        };
        // What was seen along +X is seen along R_y(90°)·X = −Z after turning by 90°.
        let before = env(0.0).radiance(Vec3::new(1.0, 0.3, 0.05).normalize());
        let after = env(PI / 2.0).radiance(Vec3::new(0.05, 0.3, -1.0).normalize());
        assert!((before - after).length() < 1e-3, "{before} vs {after}");
    }

    #[test]
    fn tilt_turns_the_environment_before_its_rotation() {
        // An image whose colour is the direction it is seen along, (d + 1)/2.
        let image = Arc::new(EnvImage::from_fn(256, 128, |d| (d + Vec3::ONE) / 2.0));
        let env = |rotation: f32, tilt: Quat| Environment {
            source: EnvironmentSource::Image { path: "d.exr".into(), image: image.clone() },
            rotation,
            tilt,
            ..Default::default()
        };
        let seen = |env: &Environment, d: Vec3| env.radiance(d.normalize()) * 2.0 - Vec3::ONE;
        // Tilted 90° about X, the zenith is seen along R_x(90°)·Y = +Z.
        let tilted = env(0.0, Quat::from_rotation_x(PI / 2.0));
        assert!((seen(&tilted, Vec3::Z) - Vec3::Y).length() < 0.02, "{}", seen(&tilted, Vec3::Z));
        // Then turned 90° about Y: along R_y(90°)·Z = +X.
        let both = env(PI / 2.0, Quat::from_rotation_x(PI / 2.0));
        assert!((seen(&both, Vec3::X) - Vec3::Y).length() < 0.02, "{}", seen(&both, Vec3::X));
        assert_eq!(both.turn(), Quat::from_rotation_y(PI / 2.0) * Quat::from_rotation_x(PI / 2.0));
    }
}
