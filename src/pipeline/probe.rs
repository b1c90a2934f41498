//! The probe kernels (`shaders/probe.wgsl`): trace given rays through the current `ior_grid`
//! with the same steps the view and photon passes use and record their states; query the
//! octree's straight steps at given points. Tests compare them with the CPU twins (`cpu::ray`,
//! `cpu::octree`) and with closed-form optics. Traced rays refract at sharp interfaces (always
//! the transmitted branch; reflected under total internal reflection), so the same optics tests
//! hold for sharp glass and smooth media alike.

use anyhow::{Result, anyhow};

use super::layout;
use super::receivers::Receivers;
use super::resources::Grids;
use crate::gpu::GpuContext;
use crate::gpu::readback::Staging;
use crate::gpu::shaders::ShaderLibrary;
use crate::gpu::types::{ProbeParams, ProbeRay, ProbeRecord, integrator};

/// How to trace.
#[derive(Clone, Debug)]
pub struct ProbeOptions {
    /// Arc length per step (the minimum step when adaptive), metres.
    pub step: f32,
    pub max_steps: u32,
    /// Record the state every this many steps (the first and last state are always kept).
    pub record_every: u32,
    /// States kept per ray (≥ 2: start and end).
    pub records_per_ray: u32,
    /// `integrator::LEAPFROG` or `integrator::EULER`.
    pub integrator: u32,
    /// > 0: take straight steps up to this long across flat octree cells.
    pub max_step: f32,
}

impl ProbeOptions {
    /// Start and end states only, fixed steps, the default integrator.
    pub fn endpoints(step: f32, max_steps: u32) -> Self {
        Self { step, max_steps, record_every: u32::MAX, records_per_ray: 2, integrator: integrator::LEAPFROG, max_step: 0.0 }
    }
}

pub struct Probe {
    trace: wgpu::ComputePipeline,
    query: wgpu::ComputePipeline,
    dda: wgpu::ComputePipeline,
    bgl: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
}

impl Probe {
    pub fn new(device: &wgpu::Device, shaders: &ShaderLibrary) -> Result<Self> {
        let entries = [
            layout::uniform(0),
            layout::texture(1, wgpu::TextureViewDimension::D3),
            layout::sampler(2),
            layout::storage(3, true),
            layout::storage(4, false),
            layout::uniform(5),
            layout::storage(6, true),
            layout::storage(7, false),
            layout::storage(8, true),
            layout::storage(9, true),
            layout::storage(10, true),
            layout::storage(11, true),
            layout::storage(12, true),
            layout::storage(13, true),
            layout::storage(14, true),
            layout::storage(15, true),
        ];
        let (trace, bgl) = layout::pipeline_entry(device, shaders, "probe", "main", &entries)?;
        let (query, _) = layout::pipeline_entry(device, shaders, "probe", "octree_query", &entries)?;
        let (dda, _) = layout::pipeline_entry(device, shaders, "probe", "dda_cells", &entries)?;
        let params = layout::uniform_buffer::<ProbeParams>(device, "probe params");
        Ok(Self { trace, query, dda, bgl, params })
    }

    /// Runs a kernel over `rays`, returning the bytes it wrote to records (`Kernel::Trace`) or
    /// to the steps buffer.
    #[allow(clippy::too_many_arguments)]
    fn run(&self, ctx: &GpuContext, grids: &Grids, surfaces: &Receivers, rays: &[ProbeRay], params: ProbeParams, kernel: Kernel, out_size: u64) -> Result<Vec<u8>> {
        let query = kernel != Kernel::Trace;
        let device = &ctx.device;
        ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let storage = |label, size: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.max(16),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let ray_buf = storage("probe rays", std::mem::size_of_val(rays) as u64);
        ctx.queue.write_buffer(&ray_buf, 0, bytemuck::cast_slice(rays));
        let (records, steps) = if query { (storage("unused", 16), storage("probe steps", out_size)) } else { (storage("probe records", out_size), storage("unused", 16)) };
        let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("probe"),
            layout: &self.bgl,
            entries: &[
                layout::bind(0, &self.params),
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&grids.ior_grid.view) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&grids.sampler) },
                layout::bind(3, &ray_buf),
                layout::bind(4, &records),
                layout::bind(5, &grids.octree_params),
                layout::bind(6, &grids.octree),
                layout::bind(7, &steps),
                layout::bind(8, &surfaces.bvh_nodes.buffer),
                layout::bind(9, &surfaces.bvh_triangles.buffer),
                layout::bind(10, &surfaces.interfaces.buffer),
                layout::bind(11, &surfaces.triangle_normals.buffer),
                layout::bind(12, &grids.octree_leaves),
                layout::bind(13, &surfaces.rough_albedo),
                layout::bind(14, &surfaces.triangle_uvs.buffer),
                layout::bind(15, &surfaces.albedo_texels.buffer),
            ],
        });
        let out = if query { &steps } else { &records };
        let staging = Staging::new(device, out_size, "probe readback");
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("probe"), timestamp_writes: None });
            pass.set_pipeline(match kernel {
                Kernel::Trace => &self.trace,
                Kernel::Octree => &self.query,
                Kernel::Dda => &self.dda,
            });
            pass.set_bind_group(0, &bg, &[]);
            pass.dispatch_workgroups((rays.len() as u32).div_ceil(64), 1, 1);
        }
        enc.copy_buffer_to_buffer(out, 0, &staging.buffer, 0, out_size.max(16));
        ctx.queue.submit([enc.finish()]);
        let mut bytes = staging.read(ctx, out_size)?;
        bytes.truncate(out_size as usize);
        Ok(bytes)
    }

    fn params(grids: &Grids, rays: usize, opts: &ProbeOptions) -> Result<ProbeParams> {
        Ok(ProbeParams {
            grid: grids.placement.ok_or_else(|| anyhow!("the volume has not been built yet"))?,
            step: opts.step,
            max_steps: opts.max_steps,
            record_every: opts.record_every.max(1),
            ray_count: rays as u32,
            records_per_ray: opts.records_per_ray.max(2),
            integrator: opts.integrator,
            max_step: opts.max_step,
            _pad1: 0,
        })
    }

    /// Traces `rays`; returns `records_per_ray` states per ray, ray after ray.
    pub fn trace(&self, ctx: &GpuContext, grids: &Grids, surfaces: &Receivers, rays: &[ProbeRay], opts: &ProbeOptions) -> Result<Vec<ProbeRecord>> {
        let params = Self::params(grids, rays.len(), opts)?;
        let size = (rays.len() * params.records_per_ray as usize * std::mem::size_of::<ProbeRecord>()) as u64;
        Ok(bytemuck::cast_slice(&self.run(ctx, grids, surfaces, rays, params, Kernel::Trace, size)?).to_vec())
    }

    /// The octree's straight step at each ray's origin along its direction, clamped to
    /// [`step`, `max_step`]: (step, flat?, flat cell's x extent) per ray.
    pub fn octree_steps(&self, ctx: &GpuContext, grids: &Grids, surfaces: &Receivers, rays: &[ProbeRay], step: f32, max_step: f32) -> Result<Vec<[f32; 4]>> {
        let opts = ProbeOptions { max_step, ..ProbeOptions::endpoints(step, 0) };
        let params = Self::params(grids, rays.len(), &opts)?;
        let size = (rays.len() * 16) as u64;
        Ok(bytemuck::cast_slice(&self.run(ctx, grids, surfaces, rays, params, Kernel::Octree, size)?).to_vec())
    }

    /// The cells each segment (origin → origin + dir, cell units) crosses: up to `max_cells`
    /// (cell x, y, z, length) per segment, unused slots with length 0.
    pub fn dda_cells(&self, ctx: &GpuContext, grids: &Grids, surfaces: &Receivers, segments: &[ProbeRay], max_cells: u32) -> Result<Vec<[f32; 4]>> {
        let opts = ProbeOptions { records_per_ray: max_cells, ..ProbeOptions::endpoints(0.0, 0) };
        let mut params = Self::params(grids, segments.len(), &opts)?;
        params.records_per_ray = max_cells;
        let size = (segments.len() * max_cells as usize * 16) as u64;
        Ok(bytemuck::cast_slice(&self.run(ctx, grids, surfaces, segments, params, Kernel::Dda, size)?).to_vec())
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Kernel {
    Trace,
    Octree,
    Dda,
}
