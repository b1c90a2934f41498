//! Stage 1, voxelize (`shaders/voxelize.wgsl`): the frame's analytic index fields → the raw
//! index grid and the extinction and scattering grids. CPU twin: `cpu::field`.

use anyhow::Result;

use super::layout;
use super::resources::{GRID_FORMAT, Grids};
use super::timing::Profiler;
use crate::frame::FrameDesc;
use crate::gpu::GpuContext;
use crate::gpu::shaders::ShaderLibrary;
use crate::gpu::types::{Field, VoxelizeParams};

pub struct Voxelize {
    pipeline: wgpu::ComputePipeline,
    bgl: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    fields: wgpu::Buffer,
    fields_capacity: usize,
    /// Bind group and the grid generation it was made for.
    bound: Option<(u64, wgpu::BindGroup)>,
}

impl Voxelize {
    pub fn new(device: &wgpu::Device, shaders: &ShaderLibrary) -> Result<Self> {
        let d3 = wgpu::TextureViewDimension::D3;
        let (pipeline, bgl) = layout::pipeline(
            device,
            shaders,
            "voxelize",
            &[
                layout::uniform(0),
                layout::storage(1, true),
                layout::storage(2, false),
                layout::storage_texture(3, GRID_FORMAT, d3),
                layout::storage_texture(4, GRID_FORMAT, d3),
            ],
        )?;
        let params = layout::uniform_buffer::<VoxelizeParams>(device, "voxelize params");
        let (fields, fields_capacity) = Self::field_buffer(device, 8);
        Ok(Self { pipeline, bgl, params, fields, fields_capacity, bound: None })
    }

    fn field_buffer(device: &wgpu::Device, capacity: usize) -> (wgpu::Buffer, usize) {
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("fields"),
            size: (capacity * std::mem::size_of::<Field>()) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        (buffer, capacity)
    }

    pub fn encode(&mut self, ctx: &GpuContext, enc: &mut wgpu::CommandEncoder, profiler: &mut Profiler, desc: &FrameDesc, grids: &Grids) {
        let fields: Vec<Field> = desc.fields.iter().map(|f| f.to_gpu()).collect();
        if fields.len() > self.fields_capacity {
            (self.fields, self.fields_capacity) = Self::field_buffer(&ctx.device, fields.len().next_power_of_two());
            self.bound = None;
        }
        if !fields.is_empty() {
            ctx.queue.write_buffer(&self.fields, 0, bytemuck::cast_slice(&fields));
        }
        let fog = desc.fog.unwrap_or(crate::frame::FogDesc { scattering: glam::Vec3::ZERO, absorption: glam::Vec3::ZERO, g: 0.0 });
        let params = VoxelizeParams {
            grid: desc.volume.to_gpu(),
            field_count: fields.len() as u32,
            fog_absorption: fog.absorption.extend(0.0).into(),
            fog_scattering: fog.scattering.extend(fog.g).into(),
            ..Default::default()
        };
        ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));

        if self.bound.as_ref().is_none_or(|(g, _)| *g != grids.generation) {
            let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("voxelize"),
                layout: &self.bgl,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: self.params.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: self.fields.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 2, resource: grids.index_field.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&grids.extinction_grid.view) },
                    wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(&grids.scattering_grid.view) },
                ],
            });
            self.bound = Some((grids.generation, bg));
        }
        let (_, bg) = self.bound.as_ref().expect("bound above");
        let mut pass = profiler.pass(enc, "voxelize");
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bg, &[]);
        let d = (grids.dims + 3) / 4;
        pass.dispatch_workgroups(d.x, d.y, d.z);
    }
}
