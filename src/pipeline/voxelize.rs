//! Stage 1, voxelize (`shaders/voxelize.wgsl`): the frame's analytic index fields and its
//! refractive meshes → the raw index grid and the extinction and scattering grids. Meshes are
//! first turned into signed distances by [`MeshVoxelizer`] (stage 1a); this stage then
//! composites fields and meshes in order. CPU twins: `cpu::field`, `cpu::mesh`.

use anyhow::Result;

use super::layout;
use super::resources::{GRID_FORMAT, Grids};
use super::timing::Profiler;
use crate::frame::FrameDesc;
use crate::gpu::GpuContext;
use crate::gpu::shaders::ShaderLibrary;
use crate::gpu::types::{Field, MeshVolume, VoxelizeParams};
use super::voxelize_mesh::{MeshVoxelizer, MeshWork};

pub struct Voxelize {
    pipeline: wgpu::ComputePipeline,
    bgl: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    fields: wgpu::Buffer,
    fields_capacity: usize,
    meshes: MeshVoxelizer,
    mesh_volumes: wgpu::Buffer,
    mesh_volumes_capacity: usize,
    /// Bind group and the generations (grids, atlas, mesh list) it was made for.
    bound: Option<((u64, u64, usize), wgpu::BindGroup)>,
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
                layout::storage(5, true),
                layout::storage(6, true),
            ],
        )?;
        let params = layout::uniform_buffer::<VoxelizeParams>(device, "voxelize params");
        let (fields, fields_capacity) = list_buffer::<Field>(device, "fields", 8);
        let (mesh_volumes, mesh_volumes_capacity) = list_buffer::<MeshVolume>(device, "mesh volumes", 8);
        let meshes = MeshVoxelizer::new(device, shaders)?;
        Ok(Self { pipeline, bgl, params, fields, fields_capacity, meshes, mesh_volumes, mesh_volumes_capacity, bound: None })
    }

    /// The mesh solids (stage 1a), for tests and benchmarks.
    pub fn meshes(&self) -> &MeshVoxelizer {
        &self.meshes
    }

    pub fn meshes_mut(&mut self) -> &mut MeshVoxelizer {
        &mut self.meshes
    }

    pub fn encode(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        profiler: &mut Profiler,
        desc: &FrameDesc,
        grids: &Grids,
    ) -> Result<MeshWork> {
        let (mesh_volumes, work) = self.meshes.encode(ctx, enc, profiler, &desc.meshes, &desc.volume)?; // meshes → atlas
        let fields: Vec<Field> = desc.fields.iter().map(|f| f.to_gpu()).collect();
        if fields.len() > self.fields_capacity {
            (self.fields, self.fields_capacity) = list_buffer::<Field>(&ctx.device, "fields", fields.len().next_power_of_two());
            self.bound = None;
        }
        if !fields.is_empty() {
            ctx.queue.write_buffer(&self.fields, 0, bytemuck::cast_slice(&fields));
        }
        if mesh_volumes.len() > self.mesh_volumes_capacity {
            (self.mesh_volumes, self.mesh_volumes_capacity) =
                list_buffer::<MeshVolume>(&ctx.device, "mesh volumes", mesh_volumes.len().next_power_of_two());
            self.bound = None;
        }
        if !mesh_volumes.is_empty() {
            ctx.queue.write_buffer(&self.mesh_volumes, 0, bytemuck::cast_slice(&mesh_volumes));
        }
        let params = VoxelizeParams {
            grid: desc.volume.to_gpu(),
            field_count: fields.len() as u32,
            mesh_count: mesh_volumes.len() as u32,
            ..Default::default()
        };
        ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));

        let (atlas, atlas_generation) = self.meshes.atlas();
        let key = (grids.generation, atlas_generation, self.mesh_volumes_capacity);
        if self.bound.as_ref().is_none_or(|(k, _)| *k != key) {
            let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("voxelize"),
                layout: &self.bgl,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: self.params.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: self.fields.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 2, resource: grids.index_field.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&grids.extinction_grid.view) },
                    wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(&grids.scattering_grid.view) },
                    wgpu::BindGroupEntry { binding: 5, resource: self.mesh_volumes.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 6, resource: atlas.as_entire_binding() },
                ],
            });
            self.bound = Some((key, bg));
        }
        let (_, bg) = self.bound.as_ref().expect("bound above");
        let mut pass = profiler.pass(enc, "voxelize");
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bg, &[]);
        let d = (grids.dims + 3) / 4;
        pass.dispatch_workgroups(d.x, d.y, d.z);
        Ok(work)
    }
}

/// A storage buffer for `capacity` items of `T`.
fn list_buffer<T>(device: &wgpu::Device, label: &str, capacity: usize) -> (wgpu::Buffer, usize) {
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: (capacity * std::mem::size_of::<T>()) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    (buffer, capacity)
}
