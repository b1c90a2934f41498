//! CPU twin of the receivers' shading (`shaders/shared/pbr.wgsl`): glTF 2.0's metallic-roughness
//! BRDF with KHR_materials_specular, under KHR_materials_sheen and KHR_materials_clearcoat as the
//! Khronos Sample Viewer layers them, for one light direction and for a uniform environment.
//! The same tables as the shader (`pipeline::specular::lut_at`), so a test compares the GPU's
//! arithmetic with this, and this with closed forms.

use std::f32::consts::{FRAC_1_PI, PI};

use glam::Vec3;

use crate::pipeline::specular::{charlie_d, ggx_d, lut_at, sheen_visibility, smith_visibility};

/// The perceptual roughness the lights see at least (`MIN_LIGHT_ROUGHNESS` in the shader).
pub const MIN_LIGHT_ROUGHNESS: f32 = 0.03;

/// A shading point: the material's values there, the normal `n`, the coat's normal `coat_n`
/// (`n` unless the coat has a normal map of its own) and the direction `v` toward the viewer,
/// all unit.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    pub base: Vec3,
    pub metallic: f32,
    pub roughness: f32,
    pub specular: f32,
    pub clearcoat: f32,
    pub clearcoat_roughness: f32,
    pub sheen_color: Vec3,
    pub sheen_roughness: f32,
    pub n: Vec3,
    pub coat_n: Vec3,
    pub v: Vec3,
}

/// Schlick's Fresnel from f0 to f90 at cos θ.
pub fn schlick(f0: Vec3, f90: f32, cos: f32) -> Vec3 {
    f0 + (Vec3::splat(f90) - f0) * (1.0 - cos.clamp(0.0, 1.0)).powi(5)
}

impl Surface {
    fn n_v(&self) -> f32 {
        self.n.dot(self.v).clamp(1e-4, 1.0)
    }

    fn coat_n_v(&self) -> f32 {
        self.coat_n.dot(self.v).clamp(1e-4, 1.0)
    }

    fn coat_weight(&self) -> f32 {
        self.clearcoat * schlick(Vec3::splat(0.04), 1.0, self.coat_n_v()).x
    }

    fn sheen_albedo(&self, cos: f32) -> f32 {
        lut_at(1, cos, self.sheen_roughness)[0]
    }

    /// The BRDF f(l, v) for light arriving from unit direction `l` (toward the light).
    pub fn brdf(&self, l: Vec3) -> Vec3 {
        let (n_l, n_v) = (self.n.dot(l), self.n_v());
        if n_l <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (l + self.v).normalize();
        let (n_h, v_h) = (self.n.dot(h).max(0.0), self.v.dot(h));
        let r = self.roughness.max(MIN_LIGHT_ROUGHNESS);
        let lobe = ggx_d(n_h, r * r) * smith_visibility(n_l, n_v, r * r);
        let f_d = schlick(Vec3::splat(0.04 * self.specular), self.specular, v_h);
        let f_m = schlick(self.base, 1.0, v_h);
        let diffuse = self.base * FRAC_1_PI * (Vec3::ONE - f_d) * (1.0 - self.metallic);
        let mut f = diffuse + lobe * f_d.lerp(f_m, self.metallic);
        let sheen = self.sheen_color.max_element();
        if sheen > 0.0 {
            let below = (1.0 - sheen * self.sheen_albedo(n_v)).min(1.0 - sheen * self.sheen_albedo(n_l));
            f = f * below + self.sheen_color * charlie_d(n_h, self.sheen_roughness) * sheen_visibility(n_l, n_v, self.sheen_roughness);
        }
        if self.clearcoat > 0.0 {
            f *= 1.0 - self.coat_weight();
            let c_l = self.coat_n.dot(l);
            if c_l > 0.0 {
                let r = self.clearcoat_roughness.max(MIN_LIGHT_ROUGHNESS);
                let lobe = ggx_d(self.coat_n.dot(h).max(0.0), r * r) * smith_visibility(c_l, self.coat_n_v(), r * r);
                // Weighed by n·l like the rest, the coat's own cosine being n_c·l.
                f += Vec3::splat(self.clearcoat * lobe * schlick(Vec3::splat(0.04), 1.0, v_h).x * c_l / n_l);
            }
        }
        f
    }

    /// The radiance toward the viewer under an environment of uniform radiance `l` (no
    /// occlusion): the diffuse lobe by π·albedo-weight, the lobes by the split sum, the sheen
    /// by its albedo, the coat by its own split sum.
    pub fn under_uniform_sky(&self, l: Vec3) -> Vec3 {
        let n_v = self.n_v();
        let [a, b] = lut_at(0, n_v, self.roughness);
        let e_dielectric = self.specular * (0.04 * a + b);
        let e_metal = self.base * a + Vec3::splat(b);
        let mut diffuse = self.base * FRAC_1_PI * (1.0 - e_dielectric) * (1.0 - self.metallic);
        let mut specular = l * Vec3::splat(e_dielectric).lerp(e_metal, self.metallic);
        let sheen = self.sheen_color.max_element();
        if sheen > 0.0 {
            let e = self.sheen_albedo(n_v);
            diffuse *= 1.0 - sheen * e;
            specular = specular * (1.0 - sheen * e) + self.sheen_color * e * l;
        }
        if self.clearcoat > 0.0 {
            let [a, b] = lut_at(0, self.coat_n_v(), self.clearcoat_roughness);
            let below = 1.0 - self.coat_weight();
            diffuse *= below;
            specular = specular * below + self.clearcoat * (0.04 * a + b) * l;
        }
        // A uniform sky's irradiance is π·L.
        diffuse * PI * l + specular
    }
}
