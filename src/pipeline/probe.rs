//! The probe kernel (`shaders/probe.wgsl`): traces given rays through the current `ior_grid`
//! with the same step the view and photon passes use, and records their states. Tests compare
//! it with the CPU twin (`cpu::ray`) and with closed-form optics; `refrakt trace` prints it.

use anyhow::Result;

use super::layout;
use super::resources::Grids;
use crate::gpu::GpuContext;
use crate::gpu::readback::Staging;
use crate::gpu::shaders::ShaderLibrary;
use crate::gpu::types::{ProbeParams, ProbeRay, ProbeRecord, integrator};

/// How to trace.
#[derive(Clone, Debug)]
pub struct ProbeOptions {
    /// Arc length per step, metres.
    pub step: f32,
    pub max_steps: u32,
    /// Record the state every this many steps (the first and last state are always kept).
    pub record_every: u32,
    /// States kept per ray (≥ 2: start and end).
    pub records_per_ray: u32,
    /// `integrator::LEAPFROG` or `integrator::EULER`.
    pub integrator: u32,
}

impl ProbeOptions {
    /// Start and end states only, with the default integrator.
    pub fn endpoints(step: f32, max_steps: u32) -> Self {
        Self { step, max_steps, record_every: u32::MAX, records_per_ray: 2, integrator: integrator::LEAPFROG }
    }
}

pub struct Probe {
    pipeline: wgpu::ComputePipeline,
    bgl: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
}

impl Probe {
    pub fn new(device: &wgpu::Device, shaders: &ShaderLibrary) -> Result<Self> {
        let (pipeline, bgl) = layout::pipeline(
            device,
            shaders,
            "probe",
            &[
                layout::uniform(0),
                layout::texture(1, wgpu::TextureViewDimension::D3),
                layout::sampler(2),
                layout::storage(3, true),
                layout::storage(4, false),
            ],
        )?;
        let params = layout::uniform_buffer::<ProbeParams>(device, "probe params");
        Ok(Self { pipeline, bgl, params })
    }

    /// Traces `rays`; returns `records_per_ray` states per ray, ray after ray.
    pub fn run(&self, ctx: &GpuContext, grids: &Grids, rays: &[ProbeRay], opts: &ProbeOptions) -> Result<Vec<ProbeRecord>> {
        let device = &ctx.device;
        let records_per_ray = opts.records_per_ray.max(2);
        let params = ProbeParams {
            grid: grids.placement.ok_or_else(|| anyhow::anyhow!("the volume has not been built yet"))?,
            step: opts.step,
            max_steps: opts.max_steps,
            record_every: opts.record_every.max(1),
            ray_count: rays.len() as u32,
            records_per_ray,
            integrator: opts.integrator,
            ..Default::default()
        };
        ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let ray_buf = wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("probe rays"),
                contents: bytemuck::cast_slice(rays),
                usage: wgpu::BufferUsages::STORAGE,
            },
        );
        let out_size = (rays.len() * records_per_ray as usize * std::mem::size_of::<ProbeRecord>()) as u64;
        let out = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("probe records"),
            size: out_size.max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("probe"),
            layout: &self.bgl,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: self.params.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&grids.ior_grid.view) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&grids.sampler) },
                wgpu::BindGroupEntry { binding: 3, resource: ray_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: out.as_entire_binding() },
            ],
        });
        let staging = Staging::new(device, out_size, "probe readback");
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("probe"), timestamp_writes: None });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bg, &[]);
            pass.dispatch_workgroups((rays.len() as u32).div_ceil(64), 1, 1);
        }
        enc.copy_buffer_to_buffer(&out, 0, &staging.buffer, 0, out_size.max(16));
        ctx.queue.submit([enc.finish()]);
        let bytes = staging.read(ctx, out_size)?;
        Ok(bytemuck::cast_slice(&bytes[..out_size as usize]).to_vec())
    }
}
