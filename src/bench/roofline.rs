//! Bare kernels (`shaders/roofline.wgsl`) that bound the march and view stages on the adapter at
//! hand: steps per second with nothing but the unavoidable texture sample (and, for photons, the
//! atomic deposit). Stage throughputs are reported as fractions of these.

use anyhow::{Result, anyhow};

use crate::pipeline::{Renderer, layout};

/// Steps per second of the bare kernels.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Roofline {
    pub march_steps_per_s: f64,
    pub view_steps_per_s: f64,
}

/// Threads per measurement (each takes `STEPS` = 256 steps in the shader): enough to fill an
/// H200 many times over, so the figure is the kernel's throughput, not its launch.
pub const THREADS: u32 = 1 << 20;
/// Threads under `--quick`, where the adapter is a CPU and only the report's shape matters.
pub const QUICK_THREADS: u32 = 1 << 15;
const STEPS: f64 = 256.0;

/// Measures both bare kernels, `threads` wide, against the renderer's current grids (render a
/// frame first).
pub fn measure(renderer: &mut Renderer, threads: u32, runs: usize) -> Result<Roofline> {
    let ctx = &renderer.ctx;
    let grids = renderer.grids().ok_or_else(|| anyhow!("the roofline needs a volume: render a frame first"))?;
    let shaders = crate::gpu::shaders::ShaderLibrary::Embedded;
    let entries = [
        layout::uniform(0),
        layout::texture(1, wgpu::TextureViewDimension::D3),
        layout::sampler(2),
        layout::storage(3, false),
        layout::storage(4, false),
    ];
    let (march, bgl) = layout::pipeline_entry(&ctx.device, &shaders, "roofline", "bare_march", &entries)?;
    let (view, _) = layout::pipeline_entry(&ctx.device, &shaders, "roofline", "bare_view", &entries)?;
    let buffer = |label, size: u64, usage| ctx.device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false });
    let params = buffer("roofline grid", std::mem::size_of::<crate::gpu::types::GridParams>() as u64, crate::pipeline::layout::PARAMS | wgpu::BufferUsages::COPY_DST);
    ctx.queue.write_buffer(&params, 0, bytemuck::bytes_of(&grids.octree_layout.grid));
    let voxels = grids.dims.x as u64 * grids.dims.y as u64 * grids.dims.z as u64;
    let deposits = buffer("roofline deposits", voxels * 4, wgpu::BufferUsages::STORAGE);
    let sink = buffer("roofline sink", threads as u64 * 4, wgpu::BufferUsages::STORAGE);
    let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("roofline"),
        layout: &bgl,
        entries: &[
            layout::bind(0, &params),
            wgpu::BindGroupEntry { binding: 1, resource: layout::texture_view(&grids.ior_grid.view) },
            wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&grids.sampler) },
            layout::bind(3, &deposits),
            layout::bind(4, &sink),
        ],
    });
    if !renderer.profiler.enable(&renderer.ctx) {
        return Err(anyhow!("the adapter has no timestamp queries"));
    }
    let mut best = [f64::INFINITY; 2];
    for _ in 0..runs.max(1) + 1 {
        let ctx = &renderer.ctx;
        renderer.profiler.begin_frame();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        for (label, pipeline) in [("bare_march", &march), ("bare_view", &view)] {
            let mut pass = renderer.profiler.pass(&mut enc, label);
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &bg, &[]);
            let (x, y) = layout::workgroups_1d(threads, 64);
            pass.dispatch_workgroups(x, y, 1);
        }
        renderer.profiler.resolve(&mut enc, 0);
        ctx.queue.submit([enc.finish()]);
        renderer.profiler.collect(&renderer.ctx, 0)?;
        for (i, label) in ["bare_march", "bare_view"].iter().enumerate() {
            if let Some((_, ms)) = renderer.profiler.last.iter().find(|(l, _)| l == label) {
                best[i] = best[i].min(*ms);
            }
        }
    }
    let rate = |ms: f64| threads as f64 * STEPS / (ms * 1e-3);
    Ok(Roofline { march_steps_per_s: rate(best[0]), view_steps_per_s: rate(best[1]) })
}
