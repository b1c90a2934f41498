//! Stage 3, octree (`shaders/octree.wgsl`): the min/max pyramid of n and extinction that tells
//! the marching stages where a ray may take one long straight step, and the level-0 mark of
//! sharp glass that tells the photon raster where to aim. CPU twin: `cpu::octree`.

use anyhow::Result;
use glam::UVec3;

use super::layout;
use super::resources::Grids;
use super::timing::Profiler;
use crate::gpu::GpuContext;
use crate::gpu::shaders::ShaderLibrary;
use crate::gpu::types::{GridParams, OctreeParams};

/// n may vary by this much inside a cell crossed in one straight step. About the spacing of
/// the 16-bit index texture near n = 1.5, so a flat glass interior stays flat.
pub const EPS_N: f32 = 1e-3;
/// Extinction (largest channel, per metre) may vary by this much inside such a cell.
pub const EPS_SIGMA: f32 = 1e-3;
pub const MAX_LEVELS: usize = 12;

/// The pyramid's shape for a grid of `dims` voxels: level 0 has dims − 1 cells (the dual grid),
/// each level above halves it (rounding up) until one cell is left.
pub fn layout_for(grid: GridParams) -> OctreeParams {
    let mut levels = [[0u32; 4]; MAX_LEVELS];
    let mut dims = (UVec3::from(grid.dims) - 1).max(UVec3::ONE);
    let mut offset = 0u32;
    let mut count = 0;
    while count < MAX_LEVELS {
        levels[count] = [dims.x, dims.y, dims.z, offset];
        // Saturating: a grid too large for u32 offsets is far beyond what any adapter binds,
        // and `Renderer::check_limits` refuses it by its byte size before it is used.
        offset = offset.saturating_add(dims.x.saturating_mul(dims.y).saturating_mul(dims.z));
        count += 1;
        if dims == UVec3::ONE {
            break;
        }
        dims = (dims + 1) / 2;
    }
    let leaf_cells = levels[0][0].saturating_mul(levels[0][1]).saturating_mul(levels[0][2]);
    OctreeParams { grid, level_count: count as u32, eps_n: EPS_N, eps_sigma: EPS_SIGMA, leaf_cells, levels }
}

/// Cells of level `l`.
pub fn level_cells(p: &OctreeParams, l: usize) -> u64 {
    p.levels[l][0] as u64 * p.levels[l][1] as u64 * p.levels[l][2] as u64
}

/// Cells over all levels.
pub fn cell_count(p: &OctreeParams) -> u64 {
    (0..p.level_count as usize).map(|l| level_cells(p, l)).sum()
}

pub struct Octree {
    leaf: wgpu::ComputePipeline,
    reduce: wgpu::ComputePipeline,
    bgl: wgpu::BindGroupLayout,
    /// One uniform per level (the level `reduce` builds).
    level_uniforms: Vec<wgpu::Buffer>,
    /// Bind groups per level, and the grid generation they were made for.
    bound: Option<(u64, Vec<wgpu::BindGroup>)>,
}

impl Octree {
    pub fn new(device: &wgpu::Device, shaders: &ShaderLibrary) -> Result<Self> {
        let entries = [
            layout::uniform(0),
            layout::storage(1, true),
            layout::texture(2, wgpu::TextureViewDimension::D3),
            layout::storage(3, false),
            layout::uniform(4),
            layout::storage(5, false),
            layout::storage(6, false),
        ];
        let (leaf, bgl) = layout::pipeline_entry(device, shaders, "octree", "leaf", &entries)?;
        let (reduce, _) = layout::pipeline_entry(device, shaders, "octree", "reduce", &entries)?;
        let level_uniforms = (0..MAX_LEVELS as u32)
            .map(|l| {
                wgpu::util::DeviceExt::create_buffer_init(
                    device,
                    &wgpu::util::BufferInitDescriptor {
                        label: Some("octree level"),
                        contents: bytemuck::cast_slice(&[l, 0, 0, 0]),
                        usage: super::layout::PARAMS,
                    },
                )
            })
            .collect();
        Ok(Self { leaf, reduce, bgl, level_uniforms, bound: None })
    }

    pub fn encode(&mut self, ctx: &GpuContext, enc: &mut wgpu::CommandEncoder, profiler: &mut Profiler, grids: &Grids) {
        let params = grids.octree_layout;
        ctx.queue.write_buffer(&grids.octree_params, 0, bytemuck::bytes_of(&params));
        if self.bound.as_ref().is_none_or(|(g, _)| *g != grids.generation) {
            let groups = self
                .level_uniforms
                .iter()
                .map(|u| {
                    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("octree"),
                        layout: &self.bgl,
                        entries: &[
                            layout::bind(0, &grids.octree_params),
                            layout::bind(1, &grids.index_field),
                            wgpu::BindGroupEntry {
                                binding: 2,
                                resource: wgpu::BindingResource::TextureView(&grids.extinction_grid.view),
                            },
                            layout::bind(3, &grids.octree),
                            layout::bind(4, u),
                            layout::bind(5, &grids.glass_mark),
                            layout::bind(6, &grids.octree_leaves),
                        ],
                    })
                })
                .collect();
            self.bound = Some((grids.generation, groups));
        }
        let (_, groups) = self.bound.as_ref().expect("bound above");
        let mut pass = profiler.pass(enc, "octree");
        pass.set_pipeline(&self.leaf);
        pass.set_bind_group(0, &groups[0], &[]);
        let d = (UVec3::from_slice(&params.levels[0][..3]) + 3) / 4;
        pass.dispatch_workgroups(d.x, d.y, d.z);
        pass.set_pipeline(&self.reduce);
        for l in 1..params.level_count as usize {
            pass.set_bind_group(0, &groups[l], &[]);
            let d = (UVec3::from_slice(&params.levels[l][..3]) + 3) / 4;
            pass.dispatch_workgroups(d.x, d.y, d.z);
        }
    }
}
