//! The energy a rough glass surface keeps: the directional albedo E of a single GGX microfacet
//! crossing, tabulated once on the CPU, by which the view and the photons scale what a rough
//! crossing passes on (`shaders/shared/rough_albedo.wgsl` reads the table).
//!
//! A crossing samples one visible microfacet normal m (Heitz 2018) and sends two branches:
//! reflected with weight F(m) G₁(r), refracted with (1 − F(m)) G₁(t) (Smith's masking of the
//! outgoing direction; 0 where it turns back into the surface). Their expected sum over m,
//!
//!   E(θᵢ, α, η) = ⟨F G₁(r) + (1 − F) G₁(t)⟩_m,
//!
//! is below 1 on a rough surface: the masked light is what a real microsurface scatters again
//! and finally lets out (Heitz et al. 2016, "Multiple-scattering microfacet BSDFs with the Smith
//! model"), which Cycles' default *Multiscatter GGX* keeps. Without it, glass of roughness 1 lost
//! 14 % of the light at each entry and about half at each exit (E = 0.86 and 0.48 near normal
//! incidence for n = 1.5) and rendered grey where Cycles renders it white. Dividing both
//! branches by E — albedo scaling, as Turquin 2019 does for rough metals — keeps that energy and
//! the single-scattering lobes' shapes. A thin sheet's transmitted branch is its reflection mirrored through the sheet, so its
//! E is ⟨G₁(r)⟩ whatever F is.
//!
//! The table: E at COS_NODES incidences (cos θᵢ from 0 to 1), ROUGHNESS_NODES roughnesses (α =
//! roughness², 0 to 1) and ETA_NODES relative indices η = n beyond / n before, log-spaced from
//! 1/3 to 3 (η = 1 a node), then one slab for thin sheets; each entry a quadrature of
//! QUADRATURE_NODES² stratified visible normals. Entry (c, r, e) is at
//! `(e · ROUGHNESS_NODES + r) · COS_NODES + c`; thin sheets are e = ETA_NODES.

use std::sync::OnceLock;

use glam::Vec3;
use wgpu::util::DeviceExt;

use crate::cpu::interface::{fresnel_dielectric, ggx_visible_normal, refract, smith_g1};

pub const COS_NODES: usize = 20;
pub const ROUGHNESS_NODES: usize = 12;
pub const ETA_NODES: usize = 25;
/// The relative indices the table spans, [1/ETA_SPAN, ETA_SPAN]; beyond, the nearest edge.
pub const ETA_SPAN: f32 = 3.0;
const QUADRATURE_NODES: u32 = 32;

/// E(θᵢ, α, η) by a quadrature of `nodes`² stratified visible normals: `cos_i` from the normal
/// on the incident side, `roughness` = √α, `eta` = n beyond / n before; `thin` for a sheet.
pub fn single_scattering_albedo(cos_i: f32, roughness: f32, eta: f32, thin: bool, nodes: u32) -> f32 {
    let alpha = (roughness * roughness).max(1e-4);
    let cos_i = cos_i.clamp(1e-3, 1.0);
    let wi = Vec3::new((1.0 - cos_i * cos_i).sqrt(), 0.0, cos_i);
    // Smith's masking of an outgoing direction at cos θ = c; none below the surface.
    let seen = |c: f32| if c > 0.0 { smith_g1(c, alpha) } else { 0.0 };
    let mut sum = 0.0;
    for i in 0..nodes {
        for j in 0..nodes {
            let u = [(i as f32 + 0.5) / nodes as f32, (j as f32 + 0.5) / nodes as f32];
            let m = ggx_visible_normal(wi, alpha, u);
            let cos_m = wi.dot(m);
            let reflected = 2.0 * cos_m * m - wi;
            sum += if thin {
                seen(reflected.z)
            } else {
                let f = fresnel_dielectric(cos_m, eta);
                f * seen(reflected.z) + (1.0 - f) * refract(-wi, m, eta).map_or(0.0, |t| seen(-t.z))
            };
        }
    }
    sum / (nodes * nodes) as f32
}

/// The node positions: cos θᵢ, roughness and η of index c, r, e (cos θᵢ spaced by its square
/// root: E changes fastest at grazing incidence).
fn node(c: usize, r: usize, e: usize) -> (f32, f32, f32) {
    let eta = (ETA_SPAN.ln() * (2.0 * e as f32 / (ETA_NODES - 1) as f32 - 1.0)).exp();
    let x = c as f32 / (COS_NODES - 1) as f32;
    (x * x, r as f32 / (ROUGHNESS_NODES - 1) as f32, eta)
}

/// The table (module docs), computed once per process, on all cores (a few tenths of a second
/// on two).
pub fn table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let slab = COS_NODES * ROUGHNESS_NODES;
        let entry = |k: usize| {
            let (e, r, c) = (k / slab, (k % slab) / COS_NODES, k % COS_NODES);
            let (cos_i, roughness, eta) = node(c, r, e.min(ETA_NODES - 1));
            single_scattering_albedo(cos_i, roughness, eta, e == ETA_NODES, QUADRATURE_NODES)
        };
        let mut table = vec![0.0; slab * (ETA_NODES + 1)];
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        let chunk = table.len().div_ceil(threads);
        std::thread::scope(|s| {
            for (i, part) in table.chunks_mut(chunk).enumerate() {
                s.spawn(move || part.iter_mut().enumerate().for_each(|(j, v)| *v = entry(i * chunk + j)));
            }
        });
        table
    })
}

/// E from the table, trilinear between nodes in (cos θᵢ, roughness, ln η) as the shader reads it
/// (`rough_albedo` in shaders/shared/rough_albedo.wgsl).
pub fn rough_albedo(cos_i: f32, roughness: f32, eta: f32, thin: bool) -> f32 {
    let t = table();
    let place = |x: f32, nodes: usize| {
        let f = x.clamp(0.0, 1.0) * (nodes - 1) as f32;
        let i = (f.floor() as usize).min(nodes - 2);
        (i, f - i as f32)
    };
    let (c, tc) = place(cos_i.max(0.0).sqrt(), COS_NODES);
    let (r, tr) = place(roughness, ROUGHNESS_NODES);
    let (e, te) = if thin { (ETA_NODES, 0.0) } else { place(0.5 + 0.5 * eta.ln() / ETA_SPAN.ln(), ETA_NODES) };
    let at = |e: usize, r: usize, c: usize| t[(e * ROUGHNESS_NODES + r) * COS_NODES + c];
    let bilinear = |e: usize| {
        let row = |r: usize| at(e, r, c) + tc * (at(e, r, c + 1) - at(e, r, c));
        row(r) + tr * (row(r + 1) - row(r))
    };
    if thin { bilinear(e) } else { bilinear(e) + te * (bilinear(e + 1) - bilinear(e)) }
}

/// The table as a storage buffer (one, in `Receivers`, for the stages that cross rough glass).
pub fn buffer(device: &wgpu::Device) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("rough albedo"),
        contents: bytemuck::cast_slice(table()),
        usage: wgpu::BufferUsages::STORAGE,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table, read between its nodes, against a fine quadrature (256²) over the incidences,
    /// roughnesses and indices views and photons meet (into and out of water, glass, diamond;
    /// thin sheets): within 1.5 % (1.1 % at worst, at grazing incidence). And its limits: E = 1 on a polished surface, never above 1,
    /// falling as the roughness grows.
    #[test]
    fn the_table_matches_a_fine_quadrature_between_its_nodes() {
        let mut worst: f32 = 0.0;
        for &eta in &[1.0 / 2.42, 1.0 / 1.5, 1.0 / 1.33, 1.0, 1.33, 1.5, 2.42] {
            for &thin in &[false, true] {
                for &roughness in &[0.13, 0.37, 0.55, 0.81, 0.96] {
                    for k in 0..7 {
                        let cos_i = 0.03 + 0.97 * (k as f32 + 0.37) / 7.0;
                        let fine = single_scattering_albedo(cos_i, roughness, eta, thin, 256);
                        let read = rough_albedo(cos_i, roughness, eta, thin);
                        assert!(fine <= 1.0 + 1e-4);
                        worst = worst.max((read - fine).abs() / fine);
                    }
                }
            }
        }
        eprintln!("worst relative error of the table: {worst:.4}");
        assert!(worst < 0.015, "{worst}");
        assert!((rough_albedo(0.7, 0.0, 1.5, false) - 1.0).abs() < 2e-3);
        let e: Vec<f32> = [0.2, 0.4, 0.7, 1.0].iter().map(|&r| rough_albedo(0.9, r, 1.5, false)).collect();
        eprintln!("E at cos θ 0.9, η 1.5, roughness 0.2 / 0.4 / 0.7 / 1: {e:?}");
        assert!(e.windows(2).all(|w| w[1] < w[0]) && e[3] < 0.9, "{e:?}");
    }
}
