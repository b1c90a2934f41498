//! The photon pipeline: DDA deposits against their CPU twin, caustics against closed-form
//! optics, energy conservation, determinism, bad input.

mod common;

use common::*;
use glam::{IVec3, Vec3};
use refrakt::cpu;
use refrakt::gpu::types::ProbeRay;

#[test]
fn dda_matches_cpu_twin_and_conserves_length() {
    let desc = frame_from_lua("local r = require(\"refrakt\")\nreturn r.scene{ volume = { resolution = 16 } }");
    let mut r = renderer();
    r.build_volume(&desc).unwrap();
    let mut rng = Rng(77);
    let mut segments: Vec<ProbeRay> = (0..300)
        .map(|_| {
            let a = Vec3::new(rng.range(0.0, 12.0), rng.range(0.0, 12.0), rng.range(0.0, 12.0));
            ProbeRay { origin: a.into(), dir: (rng.unit_vector() * rng.range(0.0, 9.0)).into(), ..Default::default() }
        })
        .collect();
    // Axis-aligned, cell-face-aligned and zero-length segments are the classic DDA traps.
    segments.push(ProbeRay { origin: [1.0, 2.0, 3.0], dir: [5.0, 0.0, 0.0], ..Default::default() });
    segments.push(ProbeRay { origin: [1.5, 2.5, 3.5], dir: [0.0, -2.25, 0.0], ..Default::default() });
    segments.push(ProbeRay { origin: [1.5, 2.5, 3.5], dir: [0.0, 0.0, 0.0], ..Default::default() });
    let max_cells = 48;
    let gpu = r.probe_dda(&segments, max_cells).unwrap();
    for (i, s) in segments.iter().enumerate() {
        let (a, d) = (Vec3::from(s.origin), Vec3::from(s.dir));
        let cpu = cpu::dda::traverse(a, a + d);
        let gpu_cells: Vec<(IVec3, f32)> = gpu[i * max_cells as usize..(i + 1) * max_cells as usize]
            .iter()
            .take(cpu.len())
            .map(|c| (Vec3::new(c[0], c[1], c[2]).as_ivec3(), c[3]))
            .collect();
        assert_eq!(gpu_cells.iter().map(|c| c.0).collect::<Vec<_>>(), cpu.iter().map(|c| c.0).collect::<Vec<_>>(), "segment {i}: cells");
        for ((_, g), (_, c)) in gpu_cells.iter().zip(&cpu) {
            assert!((g - c).abs() < 1e-5 * d.length().max(1.0), "segment {i}: lengths {g} vs {c}");
        }
        // The lengths add up to the segment: nothing lost between cells, nothing counted twice.
        let total: f32 = cpu.iter().map(|c| c.1).sum();
        assert!((total - d.length()).abs() <= 1e-5 * d.length().max(1.0), "segment {i}: {total} vs {}", d.length());
        // Consecutive cells are face neighbours.
        for w in cpu.windows(2) {
            assert_eq!((w[1].0 - w[0].0).abs().element_sum(), 1, "segment {i} jumps a cell");
        }
    }
}

/// The filtered caustic irradiance (W/m², rgb + photon count) of one chart of receiver `index`.
fn chart(r: &refrakt::pipeline::Renderer, index: usize, slot: usize) -> (refrakt::gpu::types::Chart, Vec<[f32; 4]>) {
    let rec = r.receivers().unwrap();
    let table = rec.layout.receivers[index];
    let slots = [table.charts_a, table.charts_b, table.charts_c].concat();
    let c = rec.layout.charts[slots[slot] as usize];
    let all: Vec<[f32; 4]> = bytemuck::cast_slice(&refrakt::gpu::readback::read_buffer(&r.ctx, &rec.caustic_irradiance).unwrap()).to_vec();
    (c, all[c.offset as usize..(c.offset + c.width * c.height) as usize].to_vec())
}

/// World position (in the chart's two axes) of texel (i, j)'s centre.
fn texel_centre(c: &refrakt::gpu::types::Chart, i: u32, j: u32) -> glam::Vec2 {
    glam::Vec2::from(c.origin) + (glam::Vec2::new(i as f32, j as f32) + 0.5) * c.texel
}

/// A Luneburg lens (radius 0.5) under a sun shining straight down, with a floor `screen` metres
/// below its far pole.
fn lens_under_sun(resolution: u32, photons: u32, screen: f32) -> String {
    format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{ volume = {{ resolution = {resolution}, margin = 0.1 }}, photons = {photons},
                               camera = r.camera{{ size = {{8, 8}} }} }}
        scene:add(r.node{{ name = "lens", shape = r.luneburg{{ radius = 0.5 }} }})
        scene:add(r.node{{ name = "screen", translation = {{0, {}, 0}}, shape = r.plane{{ size = {{4, 4}} }},
                          material = r.diffuse{{ color = {{1, 1, 1}} }} }})
        scene:add(r.node{{ name = "sun", light = r.sun{{ direction = {{0, -1, 0}}, intensity = 683, angular_diameter = 0 }} }})
        return scene"#,
        -0.5 - screen
    )
}

#[test]
fn luneburg_under_the_sun_focuses_on_the_far_pole() {
    let mut misses = Vec::new();
    for resolution in [64u32, 128] {
        let desc = frame_from_lua(&lens_under_sun(resolution, 100_000, 0.5));
        let mut r = renderer();
        r.settings.always_deposit = true;
        r.frame(&desc).unwrap();
        let rad = r.radiance().unwrap();
        let bytes = refrakt::gpu::readback::read_texture_3d(&r.ctx, &rad.fluence.texture, 8).unwrap();
        let halves: &[half::f16] = bytemuck::cast_slice(&bytes);
        let (mut best, mut at) = (0.0f32, 0usize);
        for (i, t) in halves.chunks(4).enumerate() {
            let v = t[0].to_f32();
            if v > best {
                (best, at) = (v, i);
            }
        }
        let d = desc.volume.dims;
        let idx = glam::UVec3::new(at as u32 % d.x, (at as u32 / d.x) % d.y, at as u32 / (d.x * d.y));
        let peak = desc.volume.voxel_centre(idx);
        let miss = (peak - Vec3::new(0.0, -0.5, 0.0)).length() / desc.volume.voxel_size;
        eprintln!("{resolution}³: fluence peaks {miss:.2} voxels ({:.4} m) from the far pole", miss * desc.volume.voxel_size);
        misses.push((miss, miss * desc.volume.voxel_size));
    }
    assert!(misses[0].0 <= 1.0, "64³: the focus is {} voxels from the pole", misses[0].0);
    assert!(misses[1].1 < misses[0].1, "128³ must focus closer to the pole than 64³: {misses:?}");
}
