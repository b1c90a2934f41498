//! CPU twin of `shaders/shared/ray.wgsl`: the ray equation integrated with velocity Verlet
//! (and the paper's Euler step, for comparison), over any index field — an analytic one for
//! convergence studies, or a grid sampled like the GPU samples `ior_grid`.

use glam::{Vec3, Vec4};

use crate::frame::VolumeDesc;

/// Something that gives (∇n, n) at a point.
pub trait IndexField {
    fn sample(&self, x: Vec3) -> Vec4;
}

/// A field given by a closure returning (∇n, n).
pub struct Analytic<F: Fn(Vec3) -> Vec4>(pub F);

impl<F: Fn(Vec3) -> Vec4> IndexField for Analytic<F> {
    fn sample(&self, x: Vec3) -> Vec4 {
        (self.0)(x)
    }
}

/// The Luneburg lens of radius `r` at the origin, exactly: n = sqrt(2 − (|x|/R)²) inside.
pub fn luneburg(r: f32) -> Analytic<impl Fn(Vec3) -> Vec4> {
    Analytic(move |x: Vec3| {
        let q = x.length_squared() / (r * r);
        if q >= 1.0 {
            return Vec4::new(0.0, 0.0, 0.0, 1.0);
        }
        let n = (2.0 - q).sqrt();
        // ∇n = −x / (R² n)
        (-x / (r * r * n)).extend(n)
    })
}

/// A grid of (∇n, n) texels sampled trilinearly with clamp-to-edge addressing, air outside the
/// box — what `textureSampleLevel` on `ior_grid` computes.
pub struct GridField {
    pub volume: VolumeDesc,
    pub texels: Vec<[f32; 4]>,
}

impl IndexField for GridField {
    fn sample(&self, x: Vec3) -> Vec4 {
        let v = &self.volume;
        let uvw = (x - v.min) / (v.dims.as_vec3() * v.voxel_size);
        if uvw.min_element() < 0.0 || uvw.max_element() > 1.0 {
            return Vec4::new(0.0, 0.0, 0.0, 1.0);
        }
        let d = v.dims.as_ivec3();
        let f = uvw * v.dims.as_vec3() - 0.5;
        let i0 = f.floor();
        let t = f - i0;
        let i0 = i0.as_ivec3();
        let texel = |dx: i32, dy: i32, dz: i32| {
            let c = (i0 + glam::IVec3::new(dx, dy, dz)).clamp(glam::IVec3::ZERO, d - 1);
            Vec4::from(self.texels[(c.x + d.x * (c.y + d.y * c.z)) as usize])
        };
        let x00 = texel(0, 0, 0).lerp(texel(1, 0, 0), t.x);
        let x10 = texel(0, 1, 0).lerp(texel(1, 1, 0), t.x);
        let x01 = texel(0, 0, 1).lerp(texel(1, 0, 1), t.x);
        let x11 = texel(0, 1, 1).lerp(texel(1, 1, 1), t.x);
        x00.lerp(x10, t.y).lerp(x01.lerp(x11, t.y), t.z)
    }
}

/// Position, v = n·dir, and the field sample (∇n, n) at the position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayState {
    pub x: Vec3,
    pub v: Vec3,
    pub g: Vec4,
}

impl RayState {
    pub fn start(field: &impl IndexField, x: Vec3, dir: Vec3) -> Self {
        let g = field.sample(x);
        Self { x, v: dir * g.w, g }
    }

    pub fn dir(&self) -> Vec3 {
        self.v.normalize()
    }
}

/// Velocity Verlet in σ (ds = n dσ), step of arc length ≈ h. Twin of `march_step`.
pub fn march_step(field: &impl IndexField, s: &mut RayState, h: f32) {
    let n0 = s.g.w;
    let dsigma = h / n0;
    let v_half = s.v + (0.5 * dsigma * n0) * s.g.truncate();
    let x1 = s.x + dsigma * v_half;
    let g1 = field.sample(x1);
    s.v = v_half + (0.5 * dsigma * g1.w) * g1.truncate();
    s.x = x1;
    s.g = g1;
}

/// The paper's forward Euler step. Twin of `march_step_euler`.
pub fn march_step_euler(field: &impl IndexField, s: &mut RayState, h: f32) {
    let x1 = s.x + (h / s.g.w) * s.v;
    s.v += h * s.g.truncate();
    s.x = x1;
    s.g = field.sample(x1);
}

/// Which step to take.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Integrator {
    Leapfrog,
    Euler,
}

/// Marches from `s` until the ray leaves the sphere of radius `r_exit` around `centre` (after
/// having entered it) or `max_steps` pass. Returns the final state and the steps taken.
pub fn trace_out_of_sphere(field: &impl IndexField, mut s: RayState, h: f32, centre: Vec3, r_exit: f32, max_steps: u32, integrator: Integrator) -> (RayState, u32) {
    let mut entered = (s.x - centre).length() < r_exit;
    for i in 0..max_steps {
        match integrator {
            Integrator::Leapfrog => march_step(field, &mut s, h),
            Integrator::Euler => march_step_euler(field, &mut s, h),
        }
        let inside = (s.x - centre).length() < r_exit;
        if entered && !inside {
            return (s, i + 1);
        }
        entered |= inside;
    }
    (s, max_steps)
}
