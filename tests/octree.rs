//! The octree (min/max pyramid of n): GPU against its CPU twin on random and analytic grids, and
//! the property that makes adaptive steps safe.

mod common;

use common::*;
use glam::{Vec3, Vec4};
use refrakt::cpu;
use refrakt::gpu::readback;
use refrakt::gpu::types::ProbeRay;

/// Many overlapping spheres and boxes of random index and absorption, smoothed (an explicit
/// `boundary` keeps them in the grid rather than sharp): a "random" grid with flat interiors,
/// flat air and every kind of boundary.
fn random_scene(seed: u64) -> String {
    let mut rng = Rng(seed);
    let mut s = String::from("local r = require(\"refrakt\")\nlocal scene = r.scene{ volume = { resolution = 48 } }\n");
    for _ in 0..24 {
        let (x, y, z) = (rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
        let ior = rng.range(1.05, 1.8);
        let k = rng.range(0.0, 2.0);
        if rng.next_f32() < 0.5 {
            s += &format!("scene:add(r.node{{ translation = {{{x}, {y}, {z}}}, shape = r.sphere{{ radius = {}, boundary = 3 }}, material = r.glass{{ ior = {ior}, absorption = {{{k}, 0, 0}} }} }})\n", rng.range(0.1, 0.4));
        } else {
            s += &format!("scene:add(r.node{{ translation = {{{x}, {y}, {z}}}, rotation = {{{}, {}, 0}}, shape = r.box{{ size = {{{}, {}, {}}}, boundary = 3 }}, material = r.glass{{ ior = {ior} }} }})\n", rng.range(0.0, 90.0), rng.range(0.0, 90.0), rng.range(0.1, 0.6), rng.range(0.1, 0.6), rng.range(0.1, 0.6));
        }
    }
    s + "return scene\n"
}

const LENS: &str = r#"local r = require("refrakt")
local scene = r.scene{ volume = { resolution = 48 } }
scene:add(r.node{ shape = r.luneburg{ radius = 0.5 } })
scene:add(r.node{ translation = {0.8, 0, 0}, shape = r.box{ size = {0.3, 0.6, 0.6} }, material = r.glass{ ior = 1.5 } })
return scene"#;

struct Volume {
    desc: refrakt::frame::FrameDesc,
    renderer: refrakt::pipeline::Renderer,
    n: Vec<f32>,
    sigma: Vec<f32>,
    sharp: Vec<f32>,
    octree: Vec<[f32; 4]>,
    glass_mark: Vec<f32>,
}

fn build(source: &str) -> Volume {
    let desc = frame_from_lua(source);
    let mut renderer = renderer();
    renderer.build_volume(&desc).unwrap();
    let grids = renderer.grids().unwrap();
    let n: Vec<f32> = bytemuck::cast_slice(&readback::read_buffer(&renderer.ctx, &grids.index_field).unwrap()).to_vec();
    let ext = grids.extinction_grid.read(&renderer.ctx).unwrap();
    let halves: &[half::f16] = bytemuck::cast_slice(&ext);
    let sigma = halves.chunks(4).map(|c| c[0].to_f32().max(c[1].to_f32()).max(c[2].to_f32())).collect();
    let sharp = halves.chunks(4).map(|c| c[3].to_f32()).collect();
    // Level 0 and the levels above it, as the CPU twin's one array of all levels.
    let cells = |buffer| bytemuck::cast_slice::<u8, [f32; 4]>(&readback::read_buffer(&renderer.ctx, buffer).unwrap()).to_vec();
    let mut octree = cells(&grids.octree_leaves);
    octree.extend(cells(&grids.octree));
    octree.truncate(refrakt::pipeline::octree::cell_count(&grids.octree_layout) as usize);
    let glass_mark = bytemuck::cast_slice::<u8, f32>(&readback::read_buffer(&renderer.ctx, &grids.glass_mark).unwrap()).to_vec();
    Volume { desc, renderer, n, sigma, sharp, octree, glass_mark }
}

#[test]
fn gpu_octree_equals_cpu_twin() {
    for source in [random_scene(1), random_scene(2), LENS.to_string()] {
        let v = build(&source);
        let params = v.renderer.grids().unwrap().octree_layout;
        let cpu = cpu::octree::build(&params, &v.n, &v.sigma);
        assert_eq!(cpu.len(), v.octree.len());
        // Both take min/max of the same stored values: no rounding anywhere.
        assert_eq!(cpu, v.octree, "octree cells differ");
        assert_eq!(cpu::octree::glass_mark(&params, &v.sharp), v.glass_mark, "glass marks differ");
        assert!(params.level_count >= 6, "a 48³ grid has a pyramid of {} levels", params.level_count);
    }
}

/// Sharp glass is met at its surface, not marched through: it stays out of the pyramid (so the
/// whole grid around and inside a glass ball is one flat cell, crossed in long straight steps),
/// and only the glass mark the photon raster aims by shows it.
#[test]
fn sharp_glass_leaves_the_pyramid_flat_and_sets_the_glass_mark() {
    let v = build(
        r#"local r = require("refrakt")
local scene = r.scene{ volume = { resolution = 32 } }
scene:add(r.node{ shape = r.sphere{ radius = 0.5 }, material = r.glass{ ior = 1.5 } })
return scene"#,
    );
    let params = v.renderer.grids().unwrap().octree_layout;
    let top = params.levels[params.level_count as usize - 1];
    let root = v.octree[top[3] as usize];
    assert!(root[1] - root[0] < params.eps_n && root[0] == 1.0, "the root cell holds n in [{}, {}]", root[0], root[1]);
    let d0 = params.levels[0];
    let cell = |x: u32, y: u32, z: u32| v.glass_mark[(x + d0[0] * (y + d0[1] * z)) as usize];
    let centre = cell(d0[0] / 2, d0[1] / 2, d0[2] / 2);
    assert!((centre - 0.5).abs() < 1e-3, "the glass mark at the ball's centre is {centre}, not n − 1 = 0.5");
    assert_eq!(cell(0, 0, 0), 0.0, "the glass mark in the corner, outside the ball");
}

fn random_queries(v: &Volume, count: usize, seed: u64) -> Vec<ProbeRay> {
    let (lo, hi) = (v.desc.volume.min, v.desc.volume.max());
    let mut rng = Rng(seed);
    (0..count)
        .map(|_| {
            let x = lo + (hi - lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            ProbeRay { origin: x.into(), dir: rng.unit_vector().into(), ..Default::default() }
        })
        .collect()
}

#[test]
fn gpu_steps_equal_cpu_steps_and_never_cross_a_change_of_n() {
    for (source, seed) in [(random_scene(3), 11), (LENS.to_string(), 12)] {
        let mut v = build(&source);
        let h = v.desc.volume.voxel_size;
        let (min_step, max_step) = (0.5 * h, 64.0 * h);
        let queries = random_queries(&v, 2000, seed);
        let gpu = v.renderer.probe_octree(&queries, min_step, max_step).unwrap();
        let params = v.renderer.grids().unwrap().octree_layout;
        // The field the pyramid bounds: trilinear n from the f32 voxels.
        let field = cpu::ray::GridField { volume: v.desc.volume, texels: v.n.iter().map(|&n| [0.0, 0.0, 0.0, n]).collect() };
        let mut long_steps = 0;
        for (q, g) in queries.iter().zip(&gpu) {
            let (x, d) = (Vec3::from(q.origin), Vec3::from(q.dir));
            let cpu = cpu::octree::step(&params, &v.octree, x, d, min_step, max_step);
            assert!((g[0] - cpu).abs() <= 1e-5 * cpu.max(1.0), "step at {x}: GPU {} vs CPU {cpu}", g[0]);
            if g[1] == 1.0 && g[0] > min_step {
                long_steps += 1;
                // Everything the straight step passes over stays within ε of where it started
                // (the last 1/1000 voxel is the nudge into the next cell).
                let n0 = field.sample(x).w;
                let end = g[0] - 2e-3 * h;
                let samples = (end / (0.125 * h)).ceil() as usize;
                for k in 0..=samples {
                    let n = field.sample(x + d * end * k as f32 / samples as f32).w;
                    assert!((n - n0).abs() <= params.eps_n, "step from {x} along {d} crosses n {n} vs {n0}");
                }
            }
        }
        assert!(long_steps > 200, "the octree should allow long steps in flat regions ({long_steps})");
    }
}

trait Sample {
    fn sample(&self, x: Vec3) -> Vec4;
}

impl Sample for cpu::ray::GridField {
    fn sample(&self, x: Vec3) -> Vec4 {
        cpu::ray::IndexField::sample(self, x)
    }
}
