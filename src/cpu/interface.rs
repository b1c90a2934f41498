//! CPU twin of `shaders/shared/interface.wgsl`: what happens where a ray or photon meets a sharp
//! interface between two media of constant index — the unpolarized Fresnel reflectance, Snell's
//! refraction and total internal reflection (pbrt-v4 §9.5, `FrDielectric` and `Refract`).

use glam::Vec3;

/// The s- and p-polarized reflectances (R_s, R_p) of a smooth dielectric interface for light
/// arriving at cos θᵢ = `cos_i` (> 0, measured from the normal on the incident side) from a
/// medium of index n₁ into one of n₂, `eta` = n₂ / n₁; both 1 past the critical angle (total
/// internal reflection).
pub fn fresnel_polarized(cos_i: f32, eta: f32) -> (f32, f32) {
    let cos_i = cos_i.clamp(0.0, 1.0);
    // Snell: sin θₜ = sin θᵢ / η.
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return (1.0, 1.0);
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    (r_perpendicular * r_perpendicular, r_parallel * r_parallel)
}

/// Unpolarized reflectance of a smooth dielectric interface: the mean of
/// [`fresnel_polarized`]'s two (pbrt-v4's `FrDielectric`). Returns 1 past the critical angle.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let (s, p) = fresnel_polarized(cos_i, eta);
    0.5 * (s + p)
}

/// Mirror reflection of direction `d` about the unit normal `n`.
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// Refraction of unit direction `d` through an interface whose unit normal `n` faces the incident
/// side (d·n < 0), `eta` = n₂ / n₁; `None` under total internal reflection.
pub fn refract(d: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = -d.dot(n);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((d / eta + (cos_i / eta - cos_t) * n).normalize())
}

/// Fraction of the light a plane-parallel slab of clear glass passes at normal incidence once all
/// its internal reflections are summed: T = (1 − R)² / (1 − R²) = (1 − R) / (1 + R).
pub fn slab_transmittance(eta: f32) -> f32 {
    let r = fresnel_dielectric(1.0, eta);
    (1.0 - r) / (1.0 + r)
}

/// Reflectance and transmittance of a stack of clear, parallel interfaces (glass on water: air/
/// glass, glass/water, water/air) at normal incidence, given each interface's Fresnel R, with
/// every reflection between them summed incoherently. A clear interface reflects R from either
/// side, so two stacks a and b add as R = R_a + T_a² R_b / (1 − R_a R_b), T = T_a T_b / (1 −
/// R_a R_b) (the adding method; one interface: R, 1 − R).
pub fn stack_of_interfaces(reflectances: &[f64]) -> (f64, f64) {
    reflectances.iter().fold((0.0, 1.0), |(ra, ta), &rb| {
        let inner = 1.0 - ra * rb;
        (ra + ta * ta * rb / inner, ta * (1.0 - rb) / inner)
    })
}

/// Reflectance of a thin sheet of clear glass of index ratio `eta` for light at cos θᵢ = `cos_i`:
/// per polarization, the first reflection plus every one that leaves after bouncing inside,
/// R + T²R / (1 − R²) = 2R / (1 + R) (incoherent sums: a pane, not a soap film's interference),
/// then the mean of the two. The polarizations do not mix inside a pane, so the sum must be
/// taken for each before averaging: 2R̄/(1 + R̄) of the averaged R̄ is too large wherever R_s and
/// R_p differ (+0.008 at 55°, +0.022 at 74° for n = 1.5). What passes, 1 − R_thin, goes on undeviated.
pub fn thin_sheet_reflectance(cos_i: f32, eta: f32) -> f32 {
    let (s, p) = fresnel_polarized(cos_i, eta);
    0.5 * (thin_sum(s) + thin_sum(p))
}

/// One polarization's thin-slab sum of reflections, 2R / (1 + R).
fn thin_sum(r: f32) -> f32 {
    2.0 * r / (1.0 + r)
}

/// GGX's distribution of microfacet normals (Trowbridge–Reitz; Walter et al. 2007, eq. 33) at
/// cos θₘ = `cos_m` from the mean normal, for α = roughness²:
/// D(m) = α² / (π cos⁴θₘ (α² + tan²θₘ)²), normalized so ∫ D(m) cos θₘ dω = 1.
pub fn ggx_distribution(cos_m: f32, alpha: f32) -> f32 {
    if cos_m <= 0.0 {
        return 0.0;
    }
    let c2 = cos_m * cos_m;
    let tan2 = (1.0 - c2) / c2;
    let a2 = alpha * alpha;
    a2 / (std::f32::consts::PI * c2 * c2 * (a2 + tan2).powi(2))
}

/// Smith's masking for GGX of a direction at cos θ = `c` (> 0) from the mean normal:
/// G₁ = 2 / (1 + √(1 + α² tan²θ)) — the share of the microfacets facing that direction it sees.
pub fn smith_g1(c: f32, alpha: f32) -> f32 {
    let c2 = (c * c).max(1e-12);
    2.0 / (1.0 + (1.0 + alpha * alpha * (1.0 - c2) / c2).sqrt())
}

/// A microfacet normal drawn from GGX's distribution of normals visible from `w` (local frame:
/// mean normal +z, w.z > 0), D_w(m) = G₁(w) max(0, w·m) D(m) / w.z, by two uniform numbers `u`
/// (Heitz 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4)).
pub fn ggx_visible_normal(w: Vec3, alpha: f32, u: [f32; 2]) -> Vec3 {
    // Stretch to the configuration of a hemisphere, sample its projected disc, unstretch.
    let vh = Vec3::new(alpha * w.x, alpha * w.y, w.z).normalize();
    let len2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = if len2 > 0.0 { Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt() } else { Vec3::X };
    let t2 = vh.cross(t1);
    let r = u[0].sqrt();
    let phi = std::f32::consts::TAU * u[1];
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).sqrt() + s * r * phi.sin();
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(1e-6)).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed forms: R₀ = ((η − 1)/(η + 1))² at normal incidence, zero p-reflectance at
    /// Brewster's angle (tan θ_B = η), so R = R_s / 2 there.
    #[test]
    fn a_stack_of_two_interfaces_is_a_slab() {
        let r = fresnel_dielectric(1.0, 1.5) as f64;
        let (reflected, transmitted) = stack_of_interfaces(&[r, r]);
        assert!((transmitted - slab_transmittance(1.5) as f64).abs() < 1e-6);
        assert!((reflected + transmitted - 1.0).abs() < 1e-12, "a clear stack loses nothing");
        assert_eq!(stack_of_interfaces(&[r]), (r, 1.0 - r));
    }

    #[test]
    fn fresnel_matches_the_closed_forms() {
        let eta = 1.5f32;
        assert!((fresnel_dielectric(1.0, eta) - 0.04).abs() < 1e-6);
        let brewster = eta.atan();
        let (ci, si) = (brewster.cos(), brewster.sin());
        let ct = (1.0 - (si / eta).powi(2)).sqrt();
        let rs = ((ci - eta * ct) / (ci + eta * ct)).powi(2);
        assert!((fresnel_dielectric(ci, eta) - 0.5 * rs).abs() < 1e-6);
        // Fresnel's equations in his own angle form (Born & Wolf §1.5.3), an independent
        // closed form: R_s = sin²(θᵢ − θₜ)/sin²(θᵢ + θₜ), R_p = tan²(θᵢ − θₜ)/tan²(θᵢ + θₜ).
        for deg in [30.0f32, 60.0, 85.0] {
            let ti = deg.to_radians();
            let tt = (ti.sin() / eta).asin();
            let rs = ((ti - tt).sin() / (ti + tt).sin()).powi(2);
            let rp = ((ti - tt).tan() / (ti + tt).tan()).powi(2);
            let got = fresnel_dielectric(ti.cos(), eta);
            assert!((got - 0.5 * (rs + rp)).abs() < 1e-5, "{deg}°: {got} vs {}", 0.5 * (rs + rp));
        }
        // Leaving glass: total internal reflection past the critical angle asin(1/1.5) = 41.81°.
        assert_eq!(fresnel_dielectric(42.0f32.to_radians().cos(), 1.0 / eta), 1.0);
        assert!(fresnel_dielectric(41.5f32.to_radians().cos(), 1.0 / eta) < 1.0);
        assert!((slab_transmittance(eta) - 0.923_077).abs() < 1e-5);
    }

    #[test]
    fn refraction_obeys_snells_law_and_reflection_mirrors() {
        let n = Vec3::Y;
        let d = Vec3::new(30f32.to_radians().sin(), -30f32.to_radians().cos(), 0.0);
        let t = refract(d, n, 1.5).unwrap();
        assert!((t.x - 30f32.to_radians().sin() / 1.5).abs() < 1e-6);
        assert!(refract(Vec3::new(0.8, -0.6, 0.0), n, 1.0 / 1.5).is_none());
        assert!((reflect(d, n) - Vec3::new(d.x, -d.y, 0.0)).length() < 1e-6);
    }

    /// A thin pane: each polarization's reflections summed term by term (R, then T²R, T²R³, …
    /// leaving after 2k inner bounces) and averaged; at normal incidence (R_s = R_p = 0.04) the
    /// familiar 2R/(1 + R) = 0.0769, and at 55° below the sum of the averaged R.
    #[test]
    fn a_thin_sheet_sums_each_polarization() {
        for deg in [0.0f32, 30.0, 55.0, 60.0, 85.0] {
            let c = deg.to_radians().cos();
            let series = |r: f32| r + (0..200).map(|k| (1.0 - r).powi(2) * r.powi(2 * k + 1)).sum::<f32>();
            let (s, p) = fresnel_polarized(c, 1.5);
            let sheet = thin_sheet_reflectance(c, 1.5);
            assert!((sheet - 0.5 * (series(s) + series(p))).abs() < 1e-5, "{deg}°: {sheet}");
            assert!(sheet <= thin_sum(fresnel_dielectric(c, 1.5)) + 1e-6);
        }
        assert!((thin_sheet_reflectance(1.0, 1.5) - 0.076_923).abs() < 1e-5);
        let c55 = 55f32.to_radians().cos();
        let averaged_first = thin_sum(fresnel_dielectric(c55, 1.5));
        assert!(averaged_first - thin_sheet_reflectance(c55, 1.5) > 0.007, "the averaged form overshoots at 55°");
    }

    /// Seen head-on, the visible normals are D(m) cos θₘ itself, whose CDF in tan²θₘ is the
    /// closed form x / (α² + x); the sampler must follow it (Kolmogorov–Smirnov distance).
    #[test]
    fn visible_normals_follow_ggx_head_on() {
        for alpha in [0.05f32, 0.3, 0.8] {
            let n = 4096;
            let mut tan2: Vec<f32> = (0..n)
                .map(|i| {
                    // A stratified 64 × 64 grid of (u₀, u₁).
                    let u = [((i / 64) as f32 + 0.5) / 64.0, ((i % 64) as f32 + 0.5) / 64.0];
                    let m = ggx_visible_normal(Vec3::Z, alpha, u);
                    (1.0 - m.z * m.z) / (m.z * m.z)
                })
                .collect();
            tan2.sort_by(f32::total_cmp);
            let ks = tan2
                .iter()
                .enumerate()
                .map(|(i, &x)| (x / (alpha * alpha + x) - (i as f32 + 0.5) / n as f32).abs())
                .fold(0.0f32, f32::max);
            assert!(ks < 0.02, "α = {alpha}: KS distance {ks}");
        }
    }

    /// Seen obliquely, the mean of m·z over the sampler's normals equals the integral of
    /// D_w(m) (m·z) over the hemisphere, by quadrature of GGX's own D and G₁ (and D_w integrates
    /// to 1, which checks D and G₁ against each other).
    #[test]
    fn visible_normals_follow_ggx_obliquely() {
        let alpha = 0.4f32;
        let w = Vec3::new(60f32.to_radians().sin(), 0.0, 60f32.to_radians().cos());
        let g1 = smith_g1(w.z, alpha);
        let (mut total, mut mean_z) = (0.0f64, 0.0f64);
        let (nt, np) = (2000, 400);
        for i in 0..nt {
            let theta = (i as f32 + 0.5) / nt as f32 * std::f32::consts::FRAC_PI_2;
            for j in 0..np {
                let phi = (j as f32 + 0.5) / np as f32 * std::f32::consts::TAU;
                let m = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
                let d_w = g1 * w.dot(m).max(0.0) * ggx_distribution(m.z, alpha) / w.z;
                let d_omega = theta.sin() * (std::f32::consts::FRAC_PI_2 / nt as f32) * (std::f32::consts::TAU / np as f32);
                total += (d_w * d_omega) as f64;
                mean_z += (d_w * d_omega * m.z) as f64;
            }
        }
        assert!((total - 1.0).abs() < 5e-3, "∫ D_w = {total}");
        let n = 256;
        let sampled: f64 = (0..n * n)
            .map(|i| {
                let u = [((i / n) as f32 + 0.5) / n as f32, ((i % n) as f32 + 0.5) / n as f32];
                ggx_visible_normal(w, alpha, u).z as f64
            })
            .sum::<f64>()
            / (n * n) as f64;
        assert!((sampled - mean_z).abs() < 2e-3, "E[m·z] sampled {sampled} vs quadrature {mean_z}");
    }
}
