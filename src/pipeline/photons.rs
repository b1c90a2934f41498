//! Stage 4, photons (`shaders/photons.wgsl`): importance raster per light, one CDF over all
//! lights' cells, and stratified emission of the frame's photon budget — once for the caustic
//! photons (toward the volume), once for the bounce photons (everywhere, for bounced light).

use anyhow::Result;

use super::layout;
use super::lights::{LightBuffers, RASTER_CELLS};
use super::resources::{EnvironmentTexture, Grids};
use super::timing::Profiler;
use crate::gpu::GpuContext;
use crate::gpu::shaders::ShaderLibrary;
use crate::gpu::types::{EnvParams, Photon, PhotonParams, photon_flags};

/// How much a raster cell whose ray crosses only a scattering medium (no glass) is worth,
/// against 1 for one that crosses glass: enough photons for light shafts, most for caustics.
pub const MEDIUM_IMPORTANCE: f32 = 0.25;
/// n − 1 above which a medium refracts (photons through it become caustic photons; shadow rays
/// through it are blocked). The same threshold everywhere keeps direct and caustic light from
/// counting a path twice.
pub const EPS_REFRACT: f32 = 0.01;

pub struct Photons {
    importance: wgpu::ComputePipeline,
    /// The bounce population's raster: power alone (`bounce_raster`).
    bounce_raster: wgpu::ComputePipeline,
    scan: wgpu::ComputePipeline,
    emit: wgpu::ComputePipeline,
    bgl: wgpu::BindGroupLayout,
    /// The caustic and the bounce population's uniforms.
    params: [wgpu::Buffer; 2],
    /// Per raster cell: its weight, then (after `scan`) the cumulative weight.
    cdf: wgpu::Buffer,
    cdf_cells: u32,
    pub photons: wgpu::Buffer,
    pub capacity: u32,
    /// Generation of these buffers (consumers rebind when it changes).
    pub generation: u64,
    bound: [Option<([u64; 4], wgpu::BindGroup)>; 2],
}

/// One population's photons: how many, and what they are for.
#[derive(Clone, Copy, Debug, Default)]
pub struct Budget {
    /// Caustic photons (toward the volume's glass and media).
    pub caustic: u32,
    /// Bounce photons (every light's whole emission), after the caustic ones.
    pub bounce: u32,
}

impl Budget {
    pub fn total(&self) -> u32 {
        self.caustic.saturating_add(self.bounce)
    }
}

/// Seeds the bounce population apart from the caustic one (both hash their photon index).
const BOUNCE_SEED: u32 = 0x5bd1_e995;

impl Photons {
    pub fn new(device: &wgpu::Device, shaders: &ShaderLibrary) -> Result<Self> {
        let entries = [
            layout::uniform(0),
            layout::storage(1, true),
            layout::storage(2, true),
            layout::uniform(3),
            layout::storage(4, true),
            layout::storage(5, false),
            layout::storage(6, false),
            layout::storage(7, true),
            layout::storage(8, true),
            layout::storage(9, true),
        ];
        let (importance, bgl) = layout::pipeline_entry(device, shaders, "photons", "importance_raster", &entries)?;
        let (bounce_raster, _) = layout::pipeline_entry(device, shaders, "photons", "bounce_raster", &entries)?;
        let (scan, _) = layout::pipeline_entry(device, shaders, "photons", "scan", &entries)?;
        let (emit, _) = layout::pipeline_entry(device, shaders, "photons", "emit", &entries)?;
        let params = [layout::uniform_buffer::<PhotonParams>(device, "photon params"), layout::uniform_buffer::<PhotonParams>(device, "bounce photon params")];
        let (cdf, cdf_cells) = (Self::buffer(device, "cdf", 4, RASTER_CELLS * RASTER_CELLS), RASTER_CELLS * RASTER_CELLS);
        let photons = Self::buffer(device, "photons", std::mem::size_of::<Photon>() as u64, 1024);
        Ok(Self {
            importance,
            bounce_raster,
            scan,
            emit,
            bgl,
            params,
            cdf,
            cdf_cells,
            photons,
            capacity: 1024,
            generation: super::resources::next_generation(),
            bound: [None, None],
        })
    }

    fn buffer(device: &wgpu::Device, label: &str, item: u64, count: u32) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: item * count as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    }

    /// Makes room for `count` photons and rasters of `emitters` lights.
    pub fn reserve(&mut self, device: &wgpu::Device, count: u32, emitters: u32) {
        let cells = emitters.max(1) * RASTER_CELLS * RASTER_CELLS;
        if cells > self.cdf_cells {
            self.cdf_cells = cells.next_power_of_two();
            self.cdf = Self::buffer(device, "cdf", 4, self.cdf_cells);
            self.generation = super::resources::next_generation();
        }
        if count > self.capacity {
            // The next power of two, within one binding (`check_limits` refused more photons).
            let limits = device.limits();
            let binding = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
            let most = (binding / std::mem::size_of::<Photon>() as u64) as u32;
            self.capacity = count.next_power_of_two().min(most.max(count));
            self.photons = Self::buffer(device, "photons", std::mem::size_of::<Photon>() as u64, self.capacity);
            self.generation = super::resources::next_generation();
        }
    }

    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        profiler: &mut Profiler,
        grids: &Grids,
        lights: &LightBuffers,
        environment: (&EnvironmentTexture, EnvParams),
        budget: Budget,
        seed: u32,
        scattering: bool,
        spectral: bool,
    ) {
        self.reserve(&ctx.device, budget.total(), lights.emitter_count.max(lights.bounce_emitter_count));
        let spectral_flag = if spectral { photon_flags::SPECTRAL } else { 0 };
        let caustic = PhotonParams {
            grid: grids.octree_layout.grid,
            emitter_count: lights.emitter_count,
            cells: RASTER_CELLS,
            photon_count: budget.caustic,
            seed,
            medium_importance: if scattering { MEDIUM_IMPORTANCE } else { 0.0 },
            eps_refract: EPS_REFRACT,
            flags: spectral_flag,
            env: environment.1,
            ..Default::default()
        };
        let bounce = PhotonParams {
            emitter_count: lights.bounce_emitter_count,
            first_emitter: lights.emitter_count,
            photon_count: budget.bounce,
            photon_offset: budget.caustic,
            seed: seed ^ BOUNCE_SEED,
            ..caustic
        };
        let mut pass = profiler.pass(enc, "photons");
        for (k, params) in [caustic, bounce].into_iter().enumerate() {
            if params.emitter_count == 0 || params.photon_count == 0 {
                continue;
            }
            ctx.queue.write_buffer(&self.params[k], 0, bytemuck::bytes_of(&params));
            self.bind(ctx, k, grids, lights, environment.0);
            pass.set_bind_group(0, &self.bound[k].as_ref().expect("bound").1, &[]);
            pass.set_pipeline(if k == 0 { &self.importance } else { &self.bounce_raster });
            pass.dispatch_workgroups((params.emitter_count * RASTER_CELLS * RASTER_CELLS).div_ceil(64), 1, 1);
            pass.set_pipeline(&self.scan);
            pass.dispatch_workgroups(1, 1, 1);
            pass.set_pipeline(&self.emit);
            let (x, y) = layout::workgroups_1d(params.photon_count, 64);
            pass.dispatch_workgroups(x, y, 1);
        }
    }

    /// Population `k`'s bind group (0 caustic, 1 bounce), made again when a buffer changed.
    fn bind(&mut self, ctx: &GpuContext, k: usize, grids: &Grids, lights: &LightBuffers, env: &EnvironmentTexture) {
        let generations = [grids.generation, lights.generation, self.generation, env.generation];
        if self.bound[k].as_ref().is_none_or(|(g, _)| *g != generations) {
            let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("photons"),
                layout: &self.bgl,
                entries: &[
                    layout::bind(0, &self.params[k]),
                    layout::bind(1, &lights.emitters),
                    layout::bind(2, &lights.lights),
                    layout::bind(3, &grids.octree_params),
                    layout::bind(4, &grids.octree_leaves),
                    layout::bind(5, &self.cdf),
                    layout::bind(6, &self.photons),
                    layout::bind(7, &grids.glass_mark),
                    layout::bind(8, &env.light_table),
                    layout::bind(9, &lights.triangles),
                ],
            });
            self.bound[k] = Some((generations, bg));
        }
    }
}
