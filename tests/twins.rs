//! GPU kernels against their CPU twins (`refrakt::cpu`) on small inputs.

mod common;

use common::*;
use glam::Vec3;
use refrakt::cpu;
use refrakt::gpu::readback;
use refrakt::gpu::types::{ProbeRay, integrator};
use refrakt::pipeline::probe::ProbeOptions;

/// Every analytic field kind, rotated, scaled, overlapping, with absorption.
const FIELDS: &str = r#"
local r = require("refrakt")
local scene = r.scene{ volume = { resolution = 40, margin = 0.02 } }
scene:add(r.node{ name = "ball", translation = {0.3, 0, 0}, shape = r.sphere{ radius = 0.25 },
                  material = r.glass{ ior = 1.5, absorption = {1, 0.5, 0} } })
scene:add(r.node{ name = "cube", translation = {-0.25, 0.05, 0.05}, rotation = {20, 35, 10},
                  shape = r.box{ size = {0.3, 0.25, 0.35} }, material = r.glass{ ior = 1.33 } })
scene:add(r.node{ name = "lens", translation = {0.05, -0.1, -0.2}, scale = 0.8,
                  shape = r.luneburg{ radius = 0.3 } })
scene:add(r.node{ name = "slab", translation = {0, 0.25, 0.1}, rotation = {0, 0, 15},
                  shape = r.slab{ size = {0.6, 0.1, 0.3}, ior = 1.4, gradient = 2.0 } })
return scene
"#;

#[test]
fn voxelize_matches_cpu_rasterization() {
    let desc = frame_from_lua(FIELDS);
    let mut r = renderer();
    r.build_volume(&desc).unwrap();
    let gpu: Vec<f32> = bytemuck::cast_slice(&readback::read_buffer(&r.ctx, &r.grids().unwrap().index_field).unwrap()).to_vec();
    let cpu = cpu::field::rasterize(&desc.fields, &desc.volume);
    assert_eq!(gpu.len(), cpu.len());
    let worst = gpu.iter().zip(&cpu).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
    // Both evaluate the same f32 formulas; only transcendental rounding differs.
    assert!(worst < 2e-5, "largest difference in n between GPU and CPU: {worst}");
    // And the scene is not trivially empty.
    assert!(cpu.iter().any(|&n| n > 1.4), "the fields should reach their interior index");
}

fn read_ior_grid(r: &refrakt::pipeline::Renderer) -> Vec<[f32; 4]> {
    let bytes = r.grids().unwrap().ior_grid.read(&r.ctx).unwrap();
    let halves: &[half::f16] = bytemuck::cast_slice(&bytes);
    halves.chunks(4).map(|c| [c[0].to_f32(), c[1].to_f32(), c[2].to_f32(), c[3].to_f32()]).collect()
}

#[test]
fn gradient_matches_cpu_central_differences() {
    let desc = frame_from_lua(FIELDS);
    let mut r = renderer();
    r.build_volume(&desc).unwrap();
    let gpu = read_ior_grid(&r);
    // The twin of this stage alone: central differences of the GPU's own n grid.
    let n: Vec<f32> = bytemuck::cast_slice(&readback::read_buffer(&r.ctx, &r.grids().unwrap().index_field).unwrap()).to_vec();
    let cpu = cpu::field::gradient(&desc.volume, &n);
    let mut worst = 0.0f32;
    for (g, c) in gpu.iter().zip(&cpu) {
        for k in 0..4 {
            // rgba16float keeps 11 significant bits; the store may truncate instead of round
            // (lavapipe does), so allow one unit in the last place, 2⁻¹⁰ relative (a floor
            // covers subnormals near zero).
            let tol = c[k].abs() * 2f32.powi(-10) + 1e-6;
            worst = worst.max((g[k] - c[k]).abs() / tol);
        }
    }
    assert!(worst <= 1.0, "GPU gradient differs from the CPU twin by {worst}× the f16 tolerance");
}

/// FIELDS with the glass ball and box smoothed (`boundary`), so every object is in the index
/// grid the ray-equation twin integrates (sharp interfaces are probed in tests/glass.rs).
fn smooth_fields() -> String {
    FIELDS.replace("radius = 0.25 }", "radius = 0.25, boundary = 3 }").replace("size = {0.3, 0.25, 0.35} }", "size = {0.3, 0.25, 0.35}, boundary = 3 }")
}

#[test]
fn march_steps_match_cpu_twin_on_random_rays() {
    let desc = frame_from_lua(&smooth_fields());
    let mut r = renderer();
    r.build_volume(&desc).unwrap();
    let field = cpu::ray::GridField { volume: desc.volume, texels: read_ior_grid(&r) };
    let (lo, hi) = (desc.volume.min, desc.volume.max());
    let mut rng = Rng(0x5eed);
    let rays: Vec<ProbeRay> = (0..64)
        .map(|_| {
            let o = lo + (hi - lo) * Vec3::new(rng.range(0.1, 0.9), rng.range(0.1, 0.9), rng.range(0.1, 0.9));
            ProbeRay { origin: o.into(), dir: rng.unit_vector().into(), ..Default::default() }
        })
        .collect();
    let h = desc.volume.step;
    for (name, integ, twin) in [
        ("leapfrog", integrator::LEAPFROG, cpu::ray::march_step as fn(&cpu::ray::GridField, &mut cpu::ray::RayState, f32)),
        ("euler", integrator::EULER, cpu::ray::march_step_euler),
    ] {
        let steps = 60;
        let opts = ProbeOptions { step: h, max_steps: steps, record_every: 1, records_per_ray: steps + 2, integrator: integ, max_step: 0.0 };
        let records = r.probe(&rays, &opts).unwrap();
        let mut worst = 0.0f32;
        for (i, ray) in rays.iter().enumerate() {
            let mut s = cpu::ray::RayState::start(&field, Vec3::from(ray.origin), Vec3::from(ray.dir));
            for k in 1..=steps as usize {
                let rec = records[i * (steps as usize + 2) + k];
                if rec.steps != k as u32 {
                    break; // the ray left the volume before step k
                }
                twin(&field, &mut s, h);
                worst = worst.max((Vec3::from(rec.x) - s.x).length() / desc.volume.voxel_size);
            }
        }
        // Hardware trilinear filtering rounds its weights; over 60 steps the paths may drift
        // apart by a small fraction of a voxel, never more.
        assert!(worst < 0.02, "{name}: GPU and CPU paths drift apart by {worst} voxels within {steps} steps");
    }
}
