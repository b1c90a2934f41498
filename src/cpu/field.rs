//! CPU twin of `shaders/voxelize.wgsl` (field rasterization) and `shaders/gradient.wgsl`.

use glam::{UVec3, Vec3, Vec4};

use crate::frame::{FieldDesc, FieldKind, VolumeDesc};

pub fn smootherstep(t: f32) -> f32 {
    let u = t.clamp(0.0, 1.0);
    u * u * u * (u * (u * 6.0 - 15.0) + 10.0)
}

/// Coverage from signed distance `d` (metres, negative inside) and boundary width `w`.
pub fn coverage(d: f32, w: f32) -> f32 {
    if w <= 0.0 { if d < 0.0 { 1.0 } else { 0.0 } } else { smootherstep(0.5 - d / w) }
}

pub fn box_distance(p: Vec3, half_size: Vec3) -> f32 {
    let q = p.abs() - half_size;
    q.max(Vec3::ZERO).length() + q.max_element().min(0.0)
}

/// (α, n_f) of one field at world point `x`.
pub fn field_sample(f: &FieldDesc, x: Vec3) -> (f32, f32) {
    let p = f.world_to_local.transform_point3(x);
    match &f.kind {
        FieldKind::Sphere => (coverage((p.length() - f.half_size.x) * f.scale, f.boundary), f.ior),
        FieldKind::Box => (coverage(box_distance(p, f.half_size) * f.scale, f.boundary), f.ior),
        FieldKind::Luneburg => {
            let r = p.length() / f.half_size.x;
            let n = (2.0 - r * r).max(1.0).sqrt();
            (coverage((p.length() - f.half_size.x) * f.scale, f.boundary), n)
        }
        FieldKind::Slab => {
            let n = f.ior + f.gradient * p.y * f.scale;
            (coverage(box_distance(p, f.half_size) * f.scale, f.boundary), n)
        }
        // Outside its block of samples a sampled field's coverage is zero.
        FieldKind::Sampled(samples) => match samples.at(x) {
            Some(n) => (coverage(box_distance(p, f.half_size) * f.scale, f.boundary), n),
            None => (0.0, 1.0),
        },
    }
}

/// The composited medium at one point over the fog (if any): (n, extinction rgb, scattering rgb + g).
pub fn medium_at(fields: &[FieldDesc], fog: Option<&crate::frame::FogDesc>, x: Vec3) -> (f32, Vec3, Vec4) {
    let mut n = 1.0f32;
    let mut absorption = fog.map_or(Vec3::ZERO, |f| f.absorption);
    let mut scattering = fog.map_or(Vec4::ZERO, |f| f.scattering.extend(f.g));
    for f in fields {
        let (a, nf) = field_sample(f, x);
        if f.sharp {
            // A sharp interface adds no n (rays refract at its surface) and only its scattering,
            // with a hard edge (voxelize.wgsl's `composite`).
            let inside = if a >= 0.5 { 1.0 } else { 0.0 };
            scattering = scattering.lerp(f.glass.scattering.extend(f.glass.g), inside);
            continue;
        }
        n = n * (1.0 - a) + nf * a;
        absorption = absorption.lerp(f.glass.absorption, a);
        scattering = scattering.lerp(f.glass.scattering.extend(f.glass.g), a);
    }
    (n, absorption + scattering.truncate(), scattering)
}

fn index(dims: UVec3, i: UVec3) -> usize {
    (i.x + dims.x * (i.y + dims.y * i.z)) as usize
}

/// n at every voxel centre (x fastest, then y, then z).
pub fn rasterize(fields: &[FieldDesc], volume: &VolumeDesc) -> Vec<f32> {
    let d = volume.dims;
    let mut out = vec![0.0; volume.voxel_count() as usize];
    for z in 0..d.z {
        for y in 0..d.y {
            for x in 0..d.x {
                let i = UVec3::new(x, y, z);
                out[index(d, i)] = medium_at(fields, None, volume.voxel_centre(i)).0;
            }
        }
    }
    out
}

/// (∇n, n) per voxel by central differences with clamped neighbours.
pub fn gradient(volume: &VolumeDesc, n: &[f32]) -> Vec<[f32; 4]> {
    let d = volume.dims.as_ivec3();
    let at = |p: glam::IVec3| {
        let c = p.clamp(glam::IVec3::ZERO, d - 1);
        n[(c.x + d.x * (c.y + d.y * c.z)) as usize]
    };
    let inv_2h = 0.5 / volume.voxel_size;
    let mut out = Vec::with_capacity(n.len());
    for z in 0..d.z {
        for y in 0..d.y {
            for x in 0..d.x {
                let p = glam::IVec3::new(x, y, z);
                let g = Vec3::new(
                    at(p + glam::IVec3::X) - at(p - glam::IVec3::X),
                    at(p + glam::IVec3::Y) - at(p - glam::IVec3::Y),
                    at(p + glam::IVec3::Z) - at(p - glam::IVec3::Z),
                ) * inv_2h;
                out.push([g.x, g.y, g.z, at(p)]);
            }
        }
    }
    out
}
