//! Helpers shared by the integration tests: a GPU renderer (lavapipe in CI), scenes written as
//! Lua source, and small statistics.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

pub mod fuzz;
pub mod gltf_builder;
pub mod serve;
pub mod watch;

use refrakt::frame::FrameDesc;
use refrakt::gpu::GpuContext;
use refrakt::lua::{Limits, ScriptHost};
use refrakt::pipeline::Renderer;
use refrakt::scene::eval::{EvalOptions, evaluate};

pub fn renderer() -> Renderer {
    let ctx = GpuContext::new(None).expect("a GPU adapter (install mesa-vulkan-drivers for lavapipe)");
    Renderer::new(ctx).expect("pipelines compile")
}

/// One renderer for every test of a test binary that asks for it, so its pipelines compile once
/// (on lavapipe that is most of a small test's time); the tests take turns with it.
pub fn shared_renderer() -> std::sync::MutexGuard<'static, Renderer> {
    static SHARED: std::sync::OnceLock<std::sync::Mutex<Renderer>> = std::sync::OnceLock::new();
    SHARED.get_or_init(|| std::sync::Mutex::new(renderer())).lock().unwrap_or_else(|e| e.into_inner())
}

/// Writes `source` as `name` into a fresh temporary folder and returns (folder, script path).
pub fn write_script(name: &str, source: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, source).unwrap();
    (dir, path)
}

pub fn load(path: &Path) -> ScriptHost {
    ScriptHost::load(path, &[], &Limits::default()).unwrap_or_else(|e| panic!("{e:#}"))
}

/// The error loading `body` fails with, as scene.lua after a two-line header (so the body's
/// first line is line 3): `local r = require("refrakt")`, `local scene = r.scene{}`.
pub fn load_error(body: &str, limits: &Limits) -> String {
    let source = format!("local r = require(\"refrakt\")\nlocal scene = r.scene{{}}\n{body}\nreturn scene\n");
    let (_dir, path) = write_script("scene.lua", &source);
    match ScriptHost::load(&path, &[], limits) {
        Ok(_) => panic!("this should fail to load:\n{body}"),
        Err(e) => format!("{e:#}"),
    }
}

/// The frame a Lua scene evaluates to at t = 0.
pub fn frame_from_lua(source: &str) -> FrameDesc {
    frame_from_lua_with(source, &EvalOptions::default())
}

/// The same with the command line's options (`--region`, `--size`, …).
pub fn frame_from_lua_with(source: &str, opts: &EvalOptions) -> FrameDesc {
    let (_dir, path) = write_script("scene.lua", source);
    let host = load(&path);
    host.update(0.0).unwrap();
    let scene = host.scene().borrow();
    evaluate(&scene, 0.0, opts).unwrap_or_else(|e| panic!("{e:#}"))
}

pub fn mean(v: &[f32]) -> f32 {
    v.iter().sum::<f32>() / v.len() as f32
}

pub fn max(v: &[f32]) -> f32 {
    v.iter().copied().fold(0.0, f32::max)
}

/// Pearson's correlation coefficient of two samples of one length.
pub fn correlation(a: &[f32], b: &[f32]) -> f32 {
    let (ma, mb) = (mean(a), mean(b));
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        ab += (x - ma) * (y - mb);
        aa += (x - ma) * (x - ma);
        bb += (y - mb) * (y - mb);
    }
    ab / (aa * bb).sqrt()
}

/// A small deterministic generator for test inputs (xorshift).
pub struct Rng(pub u64);

impl Rng {
    pub fn next_f32(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }

    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }

    pub fn unit_vector(&mut self) -> glam::Vec3 {
        loop {
            let v = glam::Vec3::new(self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0));
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
}

/// The filtered caustic irradiance (W/m², rgb + photon count) of one chart of receiver `index`.
pub fn chart(r: &refrakt::pipeline::Renderer, index: usize, slot: usize) -> (refrakt::gpu::types::Chart, Vec<[f32; 4]>) {
    let rec = r.receivers().unwrap();
    let table = rec.layout.receivers[index];
    let slots = [table.charts_a, table.charts_b, table.charts_c].concat();
    let c = rec.layout.charts[slots[slot] as usize];
    let all: Vec<[f32; 4]> = bytemuck::cast_slice(&refrakt::gpu::readback::read_buffer(&r.ctx, &rec.caustic_irradiance.buffer).unwrap()).to_vec();
    (c, all[c.offset as usize..(c.offset + c.width * c.height) as usize].to_vec())
}

/// World position (in the chart's two axes) of texel (i, j)'s centre.
pub fn texel_centre(c: &refrakt::gpu::types::Chart, i: u32, j: u32) -> glam::Vec2 {
    glam::Vec2::from(c.origin) + (glam::Vec2::new(i as f32, j as f32) + 0.5) * c.texel
}

/// A Mitsuba reference of n × n pixels whose alpha marks the pixels to compare: each pixel's
/// mean of r, g, b, and the mask.
pub fn masked_reference(name: &str, n: usize) -> (Vec<f32>, Vec<bool>) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("tests/data/mitsuba/{name}.exr"));
    let reference = refrakt::output::exr::read(&path).unwrap_or_else(|e| panic!("{}: {e:#}", path.display()));
    assert_eq!((reference.width as usize, reference.height as usize), (n, n));
    let rgba = &reference.layers[0].data;
    (rgba.chunks(4).map(|p| (p[0] + p[1] + p[2]) / 3.0).collect(), rgba.chunks(4).map(|p| p[3] > 0.5).collect())
}

/// `got` against `exact` (n × n) over the `compared` pixels: both means, and the relative L1 of
/// each 8×8 block's sum (blocks with fewer than half their pixels compared are skipped).
pub fn masked_means_and_block_l1(got: &[f32], exact: &[f32], compared: &[bool], n: usize) -> (f64, f64, f64) {
    let count = compared.iter().filter(|&&c| c).count() as f64;
    let mean = |img: &[f32]| img.iter().zip(compared).filter(|(_, c)| **c).map(|(v, _)| *v as f64).sum::<f64>() / count;
    let (mut l1, mut total) = (0.0f64, 0.0f64);
    for block in 0..(n / 8) * (n / 8) {
        let (bx, by) = (block % (n / 8), block / (n / 8));
        let pixels: Vec<usize> = (0..64).map(|k| (by * 8 + k / 8) * n + bx * 8 + k % 8).filter(|&i| compared[i]).collect();
        if pixels.len() < 32 {
            continue;
        }
        let sum = |img: &[f32]| pixels.iter().map(|&i| img[i] as f64).sum::<f64>();
        l1 += (sum(got) - sum(exact)).abs();
        total += sum(exact);
    }
    (mean(got), mean(exact), l1 / total)
}
