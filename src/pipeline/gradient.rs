//! Stage 2, gradient (`shaders/gradient.wgsl`): the raw index grid → the `ior_grid` texture of
//! (∇n, n) that every ray-marching stage samples. CPU twin: `cpu::field::gradient`.

use anyhow::Result;

use super::layout;
use super::resources::{GRID_FORMAT, Grids};
use super::timing::Profiler;
use crate::frame::VolumeDesc;
use crate::gpu::GpuContext;
use crate::gpu::shaders::ShaderLibrary;
use crate::gpu::types::GridParams;

pub struct Gradient {
    pipeline: wgpu::ComputePipeline,
    bgl: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    bound: Option<(u64, wgpu::BindGroup)>,
}

impl Gradient {
    pub fn new(device: &wgpu::Device, shaders: &ShaderLibrary) -> Result<Self> {
        let (pipeline, bgl) = layout::pipeline(
            device,
            shaders,
            "gradient",
            &[layout::uniform(0), layout::storage(1, true), layout::storage_texture(2, GRID_FORMAT, wgpu::TextureViewDimension::D3)],
        )?;
        let params = layout::uniform_buffer::<GridParams>(device, "gradient params");
        Ok(Self { pipeline, bgl, params, bound: None })
    }

    pub fn encode(&mut self, ctx: &GpuContext, enc: &mut wgpu::CommandEncoder, profiler: &mut Profiler, volume: &VolumeDesc, grids: &Grids) {
        ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&volume.to_gpu()));
        if self.bound.as_ref().is_none_or(|(g, _)| *g != grids.generation) {
            let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("gradient"),
                layout: &self.bgl,
                entries: &[
                    layout::bind(0, &self.params),
                    layout::bind(1, &grids.index_field),
                    wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&grids.ior_grid.view) },
                ],
            });
            self.bound = Some((grids.generation, bg));
        }
        let (_, bg) = self.bound.as_ref().expect("bound above");
        let mut pass = profiler.pass(enc, "gradient");
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bg, &[]);
        let d = (grids.dims + 3) / 4;
        pass.dispatch_workgroups(d.x, d.y, d.z);
    }
}
