//! CPU twin of `shaders/shared/interface.wgsl`: what happens where a ray or photon meets a sharp
//! interface between two media of constant index — the unpolarized Fresnel reflectance, Snell's
//! refraction and total internal reflection (pbrt-v4 §9.5, `FrDielectric` and `Refract`).

use glam::Vec3;

/// Unpolarized reflectance of a smooth dielectric interface (the mean of the s- and
/// p-polarized Fresnel equations) for light arriving at cos θᵢ = `cos_i` (> 0, measured from the
/// normal on the incident side) from a medium of index n₁ into one of n₂, `eta` = n₂ / n₁.
/// Returns 1 past the critical angle (total internal reflection).
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    // Snell: sin θₜ = sin θᵢ / η.
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parallel * r_parallel + r_perpendicular * r_perpendicular)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed forms: R₀ = ((η − 1)/(η + 1))² at normal incidence, zero p-reflectance at
    /// Brewster's angle (tan θ_B = η), so R = R_s / 2 there.
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
}
