//! Stage 1, voxelize (`shaders/voxelize.wgsl`): the frame's index fields and its refractive
//! meshes → the raw index grid and the extinction and scattering grids. Analytic fields are
//! evaluated on the GPU; fields a script defines by a function arrive as blocks of samples
//! (`field_samples`); meshes are first turned into signed distances by [`MeshVoxelizer`]
//! (stage 1a). This stage composites fields, then meshes, in scene order. CPU twins:
//! `cpu::field`, `cpu::mesh`.

use anyhow::Result;

use super::layout;
use super::resources::{GRID_FORMAT, GrowableBuffer, Grids};
use super::timing::Profiler;
use crate::frame::{FieldKind, FrameDesc};
use crate::gpu::GpuContext;
use crate::gpu::shaders::ShaderLibrary;
use crate::gpu::types::{Field, MeshVolume, VoxelizeParams};
use super::voxelize_mesh::{MeshVoxelizer, MeshWork};

pub struct Voxelize {
    pipeline: wgpu::ComputePipeline,
    bgl: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    fields: GrowableBuffer,
    /// n of sampled fields, one block after another (`Field::sample_offset`).
    field_samples: GrowableBuffer,
    meshes: MeshVoxelizer,
    /// The meshes in the volume (`MeshVolume`), composited after the fields.
    mesh_volumes: GrowableBuffer,
    /// Bind group and the generations (grids, mesh atlas) it was made for.
    bound: Option<((u64, u64), wgpu::BindGroup)>,
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
                layout::storage(7, true),
            ],
        )?;
        let params = layout::uniform_buffer::<VoxelizeParams>(device, "voxelize params");
        let fields = GrowableBuffer::new(device, "fields", 8 * std::mem::size_of::<Field>() as u64);
        let field_samples = GrowableBuffer::new(device, "field samples", 0);
        let meshes = MeshVoxelizer::new(device, shaders)?;
        let mesh_volumes = GrowableBuffer::new(device, "mesh volumes", 8 * std::mem::size_of::<MeshVolume>() as u64);
        Ok(Self { pipeline, bgl, params, fields, field_samples, meshes, mesh_volumes, bound: None })
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
        let mut samples: Vec<f32> = Vec::new();
        let fields: Vec<Field> = desc
            .fields
            .iter()
            .map(|f| {
                let offset = samples.len() as u32;
                if let FieldKind::Sampled(s) = &f.kind {
                    samples.extend_from_slice(&s.values);
                }
                f.to_gpu(offset)
            })
            .collect();
        if self.fields.write(ctx, bytemuck::cast_slice(&fields))
            | self.field_samples.write(ctx, bytemuck::cast_slice(&samples))
            | self.mesh_volumes.write(ctx, bytemuck::cast_slice(&mesh_volumes))
        {
            self.bound = None;
        }
        let fog = desc.fog.unwrap_or(crate::frame::FogDesc { scattering: glam::Vec3::ZERO, absorption: glam::Vec3::ZERO, g: 0.0 });
        let params = VoxelizeParams {
            grid: desc.volume.to_gpu(),
            field_count: fields.len() as u32,
            mesh_count: mesh_volumes.len() as u32,
            fog_absorption: fog.absorption.extend(0.0).into(),
            fog_scattering: fog.scattering.extend(fog.g).into(),
            ..Default::default()
        };
        ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));

        let (atlas, atlas_generation) = self.meshes.atlas();
        let key = (grids.generation, atlas_generation);
        if self.bound.as_ref().is_none_or(|(k, _)| *k != key) {
            let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("voxelize"),
                layout: &self.bgl,
                entries: &[
                    layout::bind(0, &self.params),
                    layout::bind(1, &self.fields.buffer),
                    layout::bind(2, &grids.index_field),
                    wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&grids.extinction_grid.view) },
                    wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(&grids.scattering_grid.view) },
                    layout::bind(5, &self.field_samples.buffer),
                    layout::bind(6, &self.mesh_volumes.buffer),
                    layout::bind(7, &atlas),
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
