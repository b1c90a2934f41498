//! The environment's light in glossy receivers, as the Khronos glTF Sample Viewer computes it
//! (Karis 2013, "Real Shading in Unreal Engine 4": the split-sum approximation):
//!
//! L_spec(v) ≈ prefiltered(r, roughness) · (F0 · A(n·v, roughness) + F90 · B(n·v, roughness))
//!
//! - `prefiltered`: the environment convolved with the GGX lobe around the mirror direction r
//!   (assuming n = v = r), at roughness 0.2, 0.4, … 1 ([`LEVELS`] layers of [`WIDTH`] ×
//!   [`HEIGHT`] equirectangular texels; roughness 0 is the environment image itself), each
//!   texel a GGX-importance-sampled estimate that reads a box-filtered pyramid of the image at
//!   the level matching its sample's solid angle (Křivánek & Colbert 2008, "filtered importance
//!   sampling"), so few samples give a smooth result. Computed on the CPU once per image.
//! - `A`, `B`: the directional albedo of the GGX lobe (Smith height-correlated visibility)
//!   split by Schlick's Fresnel, integrated once on the CPU into a [`LUT_SIZE`]² table over
//!   (n·v, roughness): [`brdf_lut`]. The same buffer holds, after it, the directional albedo
//!   E of KHR_materials_sheen's lobe (Charlie distribution, the Sample Viewer's visibility), by
//!   which the sheen dims the surface below it and reflects a uniform environment.
//!
//! The view shader reads both (`shaders/shared/pbr.wgsl`).

use std::f32::consts::PI;
use std::sync::OnceLock;

use glam::{Vec2, Vec3};

use crate::scene::EnvImage;
use crate::scene::environment::{dir_to_uv, uv_to_dir};

/// Prefiltered layers: layer k holds roughness (k + 1) / LEVELS.
pub const LEVELS: u32 = 5;
pub const WIDTH: u32 = 128;
pub const HEIGHT: u32 = 64;
/// GGX samples per prefiltered texel.
const PREFILTER_SAMPLES: u32 = 64;
/// Entries along each side of the BRDF table.
pub const LUT_SIZE: usize = 32;
const LUT_SAMPLES: u32 = 512;

/// The i-th of n points of the Hammersley set on the unit square.
fn hammersley(i: u32, n: u32) -> Vec2 {
    Vec2::new((i as f32 + 0.5) / n as f32, i.reverse_bits() as f32 * (1.0 / 4_294_967_296.0))
}

/// A GGX half vector (α = roughness²) around +z, importance-sampled by D(h)·(n·h).
fn ggx_half_vector(u: Vec2, alpha: f32) -> Vec3 {
    let phi = 2.0 * PI * u.x;
    let cos2 = (1.0 - u.y) / (1.0 + (alpha * alpha - 1.0) * u.y);
    let (cos_t, sin_t) = (cos2.sqrt(), (1.0 - cos2).max(0.0).sqrt());
    Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
}

/// GGX normal distribution D(n·h) for α.
pub fn ggx_d(n_h: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let f = n_h * n_h * (a2 - 1.0) + 1.0;
    a2 / (PI * f * f)
}

/// Smith's height-correlated visibility V = G / (4 (n·l)(n·v)) for GGX (as glTF's spec).
pub fn smith_visibility(n_l: f32, n_v: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let gv = n_l * (n_v * n_v * (1.0 - a2) + a2).sqrt();
    let gl = n_v * (n_l * n_l * (1.0 - a2) + a2).sqrt();
    let s = gv + gl;
    if s > 0.0 { 0.5 / s } else { 0.0 }
}

/// The Charlie sheen distribution (Estevez & Kulla 2017, "Production Friendly Microfacet
/// Sheen BRDF"): D(h) = (2 + 1/α) sin^(1/α)θ_h / 2π, α = roughness² (KHR_materials_sheen).
pub fn charlie_d(n_h: f32, roughness: f32) -> f32 {
    let inv_alpha = 1.0 / (roughness * roughness).max(1e-6);
    let sin2 = (1.0 - n_h * n_h).max(0.0);
    (2.0 + inv_alpha) * sin2.powf(0.5 * inv_alpha) / (2.0 * PI)
}

/// The sheen's visibility, V = 1 / ((1 + Λ(n·v) + Λ(n·l)) · 4 (n·l)(n·v)), clamped to 1, with
/// Λ the curve fit of Estevez & Kulla (the Khronos Sample Viewer's `V_Sheen`).
pub fn sheen_visibility(n_l: f32, n_v: f32, roughness: f32) -> f32 {
    let alpha = (roughness * roughness).max(1e-6);
    let fit = |x: f32| {
        let t = (1.0 - alpha) * (1.0 - alpha);
        let mix = |a: f32, b: f32| a + (b - a) * t;
        mix(21.5473, 25.3245) / (1.0 + mix(3.82987, 3.32435) * x.powf(mix(0.19823, 0.16801))) + mix(-1.97760, -1.27393) * x + mix(-4.32054, -4.85967)
    };
    let lambda = |c: f32| if c.abs() < 0.5 { fit(c).exp() } else { (2.0 * fit(0.5) - fit(1.0 - c)).exp() };
    (1.0 / ((1.0 + lambda(n_v) + lambda(n_l)) * 4.0 * n_v * n_l)).clamp(0.0, 1.0)
}

/// E(n·v, roughness) = ∫ D·V (n·l) dl of the sheen lobe of colour 1, by a midpoint rule over
/// the hemisphere of l (the lobe is broad and smooth; 64 × 64 cells hold it to 10⁻³), the
/// half φ ∈ [0, π] counted twice: v lies in the xz plane, so the integrand is even in φ.
pub fn sheen_albedo_integral(n_v: f32, roughness: f32) -> f32 {
    const CELLS: u32 = 64;
    let v = Vec3::new((1.0 - n_v * n_v).max(0.0).sqrt(), 0.0, n_v);
    let mut sum = 0.0;
    for i in 0..CELLS {
        // Uniform in cos θ, so dω = d(cos θ) dφ.
        let cos_t = (i as f32 + 0.5) / CELLS as f32;
        let sin_t = (1.0 - cos_t * cos_t).sqrt();
        let visibility = sheen_visibility(cos_t, n_v, roughness);
        for j in 0..CELLS / 2 {
            let phi = 2.0 * PI * (j as f32 + 0.5) / CELLS as f32;
            let l = Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
            let h = (l + v).normalize();
            sum += charlie_d(h.z, roughness) * visibility * cos_t;
        }
    }
    2.0 * sum * 2.0 * PI / (CELLS * CELLS) as f32
}

/// (A, B) for n·v and roughness: ∫ f_spec/F · (1 − (1 − v·h)⁵) (n·l) dl and ∫ f_spec/F ·
/// (1 − v·h)⁵ (n·l) dl, GGX importance-sampled.
fn brdf_integral(n_v: f32, roughness: f32) -> [f32; 2] {
    let alpha = roughness * roughness;
    let v = Vec3::new((1.0 - n_v * n_v).max(0.0).sqrt(), 0.0, n_v);
    let (mut a, mut b) = (0.0, 0.0);
    for i in 0..LUT_SAMPLES {
        let h = ggx_half_vector(hammersley(i, LUT_SAMPLES), alpha);
        let v_h = v.dot(h);
        let l = 2.0 * v_h * h - v;
        let (n_l, n_h) = (l.z, h.z);
        if n_l <= 0.0 || v_h <= 0.0 {
            continue;
        }
        // f_spec/F · (n·l) / pdf, with pdf = D (n·h) / (4 v·h): D cancels.
        let weight = smith_visibility(n_l, n_v, alpha) * 4.0 * n_l * v_h / n_h;
        let fc = (1.0 - v_h).powi(5);
        a += (1.0 - fc) * weight;
        b += fc * weight;
    }
    [a / LUT_SAMPLES as f32, b / LUT_SAMPLES as f32]
}

/// The split-sum table: entry `j · LUT_SIZE + i` is (A, B) at n·v = (i + ½)/LUT_SIZE,
/// roughness = (j + ½)/LUT_SIZE (the shader interpolates between entry centres); then, from
/// entry LUT_SIZE², the sheen table laid out alike: (E, 0).
pub fn brdf_lut() -> &'static [[f32; 2]] {
    static LUT: OnceLock<Vec<[f32; 2]>> = OnceLock::new();
    LUT.get_or_init(|| {
        let centre = |k: usize| (k as f32 + 0.5) / LUT_SIZE as f32;
        let entries = 0..LUT_SIZE * LUT_SIZE;
        let ggx = entries.clone().map(|e| brdf_integral(centre(e % LUT_SIZE), centre(e / LUT_SIZE)));
        let sheen = entries.map(|e| [sheen_albedo_integral(centre(e % LUT_SIZE), centre(e / LUT_SIZE)), 0.0]);
        ggx.chain(sheen).collect()
    })
}

/// The table at (n·v, roughness), bilinear between entry centres as the shader reads it
/// (`lut_at` in shaders/shared/pbr.wgsl); `table` 0 is (A, B), 1 the sheen's (E, 0).
pub fn lut_at(table: usize, n_v: f32, roughness: f32) -> [f32; 2] {
    let lut = &brdf_lut()[table * LUT_SIZE * LUT_SIZE..];
    let last = (LUT_SIZE - 1) as f32;
    let f = (Vec2::new(n_v, roughness) * LUT_SIZE as f32 - 0.5).clamp(Vec2::ZERO, Vec2::splat(last));
    let (i, t) = (f.floor(), f - f.floor());
    let (i0, j0) = (i.x as usize, i.y as usize);
    let (i1, j1) = ((i0 + 1).min(LUT_SIZE - 1), (j0 + 1).min(LUT_SIZE - 1));
    let at = |i: usize, j: usize| Vec2::from(lut[j * LUT_SIZE + i]);
    let row0 = at(i0, j0).lerp(at(i1, j0), t.x);
    let row1 = at(i0, j1).lerp(at(i1, j1), t.x);
    row0.lerp(row1, t.y).to_array()
}

/// An image and its box-filtered halvings down to one texel row.
struct Pyramid {
    levels: Vec<EnvImage>,
}

impl Pyramid {
    fn of(image: &EnvImage) -> Self {
        let mut levels = vec![EnvImage { width: image.width, height: image.height, texels: image.texels.clone() }];
        while let Some(last) = levels.last().filter(|l| l.width > 1 && l.height > 1) {
            let (w, h) = (last.width / 2, last.height / 2);
            let mut texels = Vec::with_capacity((w * h) as usize);
            for y in 0..h {
                for x in 0..w {
                    let mut c = [0.0f32; 4];
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let t = last.texels[((2 * y + dy) * last.width + 2 * x + dx) as usize];
                        c.iter_mut().zip(t).for_each(|(c, t)| *c += 0.25 * t);
                    }
                    texels.push(c);
                }
            }
            levels.push(EnvImage { width: w, height: h, texels });
        }
        Self { levels }
    }

    /// Trilinear lookup at level `lod` (0 = the image).
    fn sample(&self, uv: Vec2, lod: f32) -> Vec3 {
        let top = (self.levels.len() - 1) as f32;
        let lod = lod.clamp(0.0, top);
        let (l0, t) = (lod.floor(), lod - lod.floor());
        let a = self.levels[l0 as usize].bilinear(uv);
        if t == 0.0 { a } else { a.lerp(self.levels[(l0 as usize + 1).min(top as usize)].bilinear(uv), t) }
    }
}

/// An orthonormal basis (t, b) around unit n.
fn basis(n: Vec3) -> (Vec3, Vec3) {
    let up = if n.y.abs() < 0.999 { Vec3::Y } else { Vec3::X };
    let t = up.cross(n).normalize();
    (t, n.cross(t))
}

/// The environment convolved with the GGX lobe of `roughness` around `r` (n = v = r),
/// weighted by n·l as the Sample Viewer does.
fn prefilter_texel(pyramid: &Pyramid, r: Vec3, roughness: f32) -> Vec3 {
    let alpha = roughness * roughness;
    let (t, b) = basis(r);
    let base = &pyramid.levels[0];
    let texel_solid_angle = 4.0 * PI / (base.width * base.height) as f32;
    let (mut sum, mut weight) = (Vec3::ZERO, 0.0);
    for i in 0..PREFILTER_SAMPLES {
        let hl = ggx_half_vector(hammersley(i, PREFILTER_SAMPLES), alpha);
        let h = t * hl.x + b * hl.y + r * hl.z;
        let l = 2.0 * r.dot(h) * h - r;
        let n_l = r.dot(l);
        if n_l <= 0.0 {
            continue;
        }
        // pdf of l: D(n·h)(n·h) / (4 v·h), and n·h = v·h here.
        let pdf = ggx_d(hl.z, alpha) / 4.0;
        let sample_solid_angle = 1.0 / (PREFILTER_SAMPLES as f32 * pdf.max(1e-8));
        let lod = 0.5 * (sample_solid_angle / texel_solid_angle).log2() + 1.0;
        sum += pyramid.sample(dir_to_uv(l), lod) * n_l;
        weight += n_l;
    }
    sum / weight.max(1e-12)
}

/// The prefiltered layers of `image`, layer after layer, RGBA rows top to bottom.
pub fn prefilter(image: &EnvImage) -> Vec<[f32; 4]> {
    let pyramid = Pyramid::of(image);
    let texels_per_layer = (WIDTH * HEIGHT) as usize;
    let mut out = vec![[0.0f32; 4]; LEVELS as usize * texels_per_layer];
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(16);
    let rows_per_thread = (LEVELS * HEIGHT).div_ceil(threads as u32) as usize;
    std::thread::scope(|scope| {
        for (chunk, texels) in out.chunks_mut(rows_per_thread * WIDTH as usize).enumerate() {
            let pyramid = &pyramid;
            scope.spawn(move || {
                for (k, texel) in texels.iter_mut().enumerate() {
                    let row = (chunk * rows_per_thread + k / WIDTH as usize) as u32;
                    let (layer, y, x) = (row / HEIGHT, row % HEIGHT, k as u32 % WIDTH);
                    let roughness = (layer + 1) as f32 / LEVELS as f32;
                    let uv = Vec2::new((x as f32 + 0.5) / WIDTH as f32, (y as f32 + 0.5) / HEIGHT as f32);
                    *texel = prefilter_texel(pyramid, uv_to_dir(uv), roughness).extend(1.0).to_array();
                }
            });
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_brdf_table_holds_the_known_albedos() {
        let lut = brdf_lut();
        let at = |i: usize, j: usize| lut[j * LUT_SIZE + i];
        // A smooth surface seen head-on reflects all (A + B = 1, Fresnel's F0 part being A).
        let [a, b] = at(LUT_SIZE - 1, 0);
        assert!((a + b - 1.0).abs() < 0.02, "A + B = {}", a + b);
        // A rough one loses what multiple scattering would return: single-scattering GGX keeps
        // only about half at roughness 1 and n·v = ½ (0.457 measured here).
        let [a, b] = at(LUT_SIZE / 2, LUT_SIZE - 1);
        assert!((0.4..0.55).contains(&(a + b)), "A + B = {}", a + b);
        assert!(lut.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    }

    #[test]
    fn the_sheen_table_holds_the_lobes_albedo() {
        // Against a finer quadrature of the same integral, in spherical coordinates (θ, φ) this
        // time, so a slip in either parametrization shows.
        let fine = |n_v: f32, roughness: f32| {
            let v = Vec3::new((1.0 - n_v * n_v).sqrt(), 0.0, n_v);
            let (n, mut sum) = (400u32, 0.0f64);
            for i in 0..n {
                let theta = 0.5 * PI * (i as f32 + 0.5) / n as f32;
                for j in 0..n {
                    let phi = 2.0 * PI * (j as f32 + 0.5) / n as f32;
                    let l = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
                    let f = charlie_d((l + v).normalize().z, roughness) * sheen_visibility(l.z, n_v, roughness);
                    sum += (f * l.z * theta.sin()) as f64;
                }
            }
            (sum * (0.5 * PI as f64 / n as f64) * (2.0 * PI as f64 / n as f64)) as f32
        };
        for (n_v, roughness) in [(0.9, 0.3), (0.5, 0.5), (0.2, 0.8), (0.7, 1.0)] {
            let (table, exact) = (sheen_albedo_integral(n_v, roughness), fine(n_v, roughness));
            assert!((table - exact).abs() < 2e-3 + 0.01 * exact, "E({n_v}, {roughness}) = {table}, finer quadrature {exact}");
            // A sheen reflects a part of the light, never more than all of it.
            assert!((0.0..1.0).contains(&table), "E({n_v}, {roughness}) = {table}");
        }
        // The table's entries are the integral at their centres.
        let centre = (3.5 / LUT_SIZE as f32, 20.5 / LUT_SIZE as f32);
        assert!((lut_at(1, centre.0, centre.1)[0] - sheen_albedo_integral(centre.0, centre.1)).abs() < 1e-6);
    }

    #[test]
    fn a_constant_environment_prefilters_to_itself() {
        let image = EnvImage::from_fn(64, 32, |_| Vec3::new(0.25, 0.5, 1.0));
        let layers = prefilter(&image);
        for t in layers {
            assert!((Vec3::new(t[0], t[1], t[2]) - Vec3::new(0.25, 0.5, 1.0)).abs().max_element() < 1e-4, "{t:?}");
        }
    }
}
