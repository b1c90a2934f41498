//! Stage 5, march (`shaders/march.wgsl`): photons through the volume along the ray equation
//! with octree-adaptive steps, depositing into the radiance grid and the receivers' caustic
//! maps; then `resolve` turns the deposits into the fluence the view pass gathers.

use anyhow::Result;

use super::layout;
use super::photons::{Budget, EPS_REFRACT, Photons};
use super::receivers::Receivers;
use super::resources::{GRID_FORMAT, Grids, RadianceGrid};
use super::timing::Profiler;
use crate::frame::Spectrum;
use crate::gpu::GpuContext;
use crate::gpu::readback::Staging;
use crate::gpu::shaders::ShaderLibrary;
use crate::gpu::types::{MarchParams, march_flags};

/// Words in the statistics buffer: 14 64-bit counters (see `STAT_*` in march.wgsl).
const STAT_WORDS: u64 = 2 * 14;

/// Flux sums over all photons of a frame (W per channel), read back on request.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhotonStats {
    /// Flux that left the lights.
    pub emitted: [f64; 3],
    /// Flux that reached a receiver (refracted or not).
    pub received: [f64; 3],
    /// The part of `received` that had been refracted: what the caustic maps hold.
    pub caustic: [f64; 3],
    /// Flux that left the scene without meeting a receiver.
    pub escaped: [f64; 3],
    /// Deposits undone because an accumulator was full.
    pub saturated: u64,
    /// Integration steps all photons took (benchmarks: photon-steps per second).
    pub steps: u64,
}

/// Fixed-point scales: one photon of mean flux deposits `flux_scale` units; a crossing of one
/// voxel deposits `radiance_scale`. Chosen so that every photon of the frame — at up to
/// `headroom` times the mean flux (importance sampling gives medium-only photons 4× the mean)
/// — landing in one texel, or crossing one voxel twice, stays below 2³¹, where accumulators
/// saturate. A mean photon then deposits 2¹⁰ units at 2¹⁶ photons per frame but only 2 at
/// 2²⁶, so deposits are rounded with a dither (march.wgsl, `to_fixed`): unbiased at any count.
pub const MAX_RELATIVE_FLUX: f32 = 16.0;

pub fn flux_scale(photons: u32, headroom: f32) -> f32 {
    (2f32.powi(31) / (photons.max(1) as f32 * headroom)).min(2f32.powi(30))
}

pub fn radiance_scale(photons: u32, headroom: f32) -> f32 {
    flux_scale(photons, headroom) / (2.0 * 3f32.sqrt())
}

/// The longest path a photon or camera ray follows through a volume of this `diagonal`, metres.
///
/// A path through smooth media is at most a few box diagonals long, however much it bends; one
/// that goes on is light trapped by total internal reflection (a lumpy or faceted glass can hold
/// it bouncing inside). Left to the step budget, those few paths kept whole GPU warps busy for
/// thousands of steps — most of the frame, measured on the H200 (`refrakt bench`: cut at three
/// diagonals, the 5k-triangle pebble's march went from 6.3 to 2.2 ms, `heavy`'s from 51.5 to
/// 29.1 ms). A trapped photon is
/// absorbed (in reality it leaks out somewhere after many bounces or is absorbed by the glass);
/// a trapped camera ray leaves along the direction it has.
pub fn max_path(diagonal: f32) -> f32 {
    3.0 * diagonal
}

pub struct March {
    main: wgpu::ComputePipeline,
    resolve: wgpu::ComputePipeline,
    bgl: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    pub stats: wgpu::Buffer,
    stats_staging: [Staging; super::MAX_FRAMES_IN_FLIGHT],
    bound: Option<([u64; 4], wgpu::BindGroup)>,
}

impl March {
    pub fn new(device: &wgpu::Device, shaders: &ShaderLibrary) -> Result<Self> {
        let d3 = wgpu::TextureViewDimension::D3;
        let entries = [
            layout::uniform(0),
            layout::storage(1, true),
            layout::texture(2, d3),
            layout::texture(3, d3),
            layout::sampler(4),
            layout::uniform(5),
            layout::storage(6, true),
            layout::storage(7, true),
            layout::storage(8, true),
            layout::storage(9, true),
            layout::storage(10, true),
            layout::storage(11, false),
            layout::storage(12, false),
            layout::storage(13, false),
            layout::storage_texture(14, GRID_FORMAT, d3),
            layout::storage_texture(15, GRID_FORMAT, d3),
            layout::storage(16, true),
            layout::storage(17, true),
            layout::storage(18, false),
            layout::storage(19, true),
            layout::storage(20, true),
            layout::storage(21, true),
            layout::storage(22, false),
            layout::storage(23, true),
        ];
        let (main, bgl) = layout::pipeline_entry(device, shaders, "march", "main", &entries)?;
        let (resolve, _) = layout::pipeline_entry(device, shaders, "march", "resolve", &entries)?;
        let params = layout::uniform_buffer::<MarchParams>(device, "march params");
        let stats = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("photon stats"),
            size: STAT_WORDS * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let stats_staging = std::array::from_fn(|_| Staging::new(device, STAT_WORDS * 4, "stats readback"));
        Ok(Self { main, resolve, bgl, params, stats, stats_staging, bound: None })
    }

    /// The march's uniforms for a frame. `deposit`: fill the radiance grid; `directional`: with the photons'
    /// mean direction too (an anisotropic medium needs it). `flux_unit`: the caustic photons'
    /// mean flux (W); `bounce`: the bounce photons' mean flux and how many bounces they take.
    #[allow(clippy::too_many_arguments)]
    pub fn params(grids: &Grids, budget: Budget, flux_unit: f32, bounce: (f32, u32), deposit: bool, directional: bool, receiver_count: u32, headroom: f32) -> MarchParams {
        let photons = budget.caustic;
        let grid = grids.octree_layout.grid;
        let diagonal = (glam::UVec3::from(grid.dims).as_vec3().length() + 1.0) * grid.voxel_size;
        let min_step = 0.5 * grid.voxel_size;
        MarchParams {
            grid,
            photon_count: budget.total(),
            bounce_first: budget.caustic,
            bounces: bounce.1,
            bounce_flux_unit: bounce.0,
            // Each bounce photon deposits once per bounce at most, and never gains flux.
            bounce_flux_scale: flux_scale(budget.bounce.saturating_mul(bounce.1.max(1)), headroom),
            // A safety net: paths end by length first (`max_path`), but a path of many short
            // bending steps is bounded here.
            max_steps: ((8.0 * diagonal / min_step) as u32).max(64),
            max_path: max_path(diagonal),
            min_step,
            max_step: 64.0 * grid.voxel_size,
            radiance_scale: radiance_scale(photons, headroom),
            flux_scale: flux_scale(photons, headroom),
            flux_unit,
            flags: match (deposit, directional) {
                (false, _) => 0,
                (true, false) => march_flags::DEPOSIT_RADIANCE,
                (true, true) => march_flags::DEPOSIT_RADIANCE | march_flags::DEPOSIT_DIRECTION,
            },
            eps_refract: EPS_REFRACT,
            receiver_count,
            ..Default::default()
        }
    }

    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        profiler: &mut Profiler,
        params: &MarchParams,
        grids: &Grids,
        photons: &Photons,
        receivers: &Receivers,
        radiance: &RadianceGrid,
    ) {
        ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(params));
        let generations = [grids.generation, photons.generation, receivers.generation, radiance.generation];
        if self.bound.as_ref().is_none_or(|(g, _)| *g != generations) {
            let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("march"),
                layout: &self.bgl,
                entries: &[
                    layout::bind(0, &self.params),
                    layout::bind(1, &photons.photons),
                    wgpu::BindGroupEntry { binding: 2, resource: layout::texture_view(&grids.ior_grid.view) },
                    wgpu::BindGroupEntry { binding: 3, resource: layout::texture_view(&grids.extinction_grid.view) },
                    wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::Sampler(&grids.sampler) },
                    layout::bind(5, &grids.octree_params),
                    layout::bind(6, &grids.octree),
                    layout::bind(7, &receivers.bvh_nodes.buffer),
                    layout::bind(8, &receivers.bvh_triangles.buffer),
                    layout::bind(9, &receivers.receivers.buffer),
                    layout::bind(10, &receivers.charts.buffer),
                    layout::bind(11, &radiance.flux_deposits),
                    layout::bind(12, &receivers.caustic_atlas.buffer),
                    layout::bind(13, &self.stats),
                    wgpu::BindGroupEntry { binding: 14, resource: layout::texture_view(&radiance.fluence.view) },
                    wgpu::BindGroupEntry { binding: 15, resource: layout::texture_view(&radiance.direction.view) },
                    layout::bind(16, &receivers.interfaces.buffer),
                    layout::bind(17, &receivers.triangle_normals.buffer),
                    layout::bind(18, &radiance.direction_deposits),
                    layout::bind(19, &grids.octree_leaves),
                    layout::bind(20, &receivers.triangle_uvs.buffer),
                    layout::bind(21, &receivers.albedo_texels.buffer),
                    layout::bind(22, &receivers.indirect_atlas.buffer),
                    layout::bind(23, &receivers.rough_albedo),
                ],
            });
            self.bound = Some((generations, bg));
        }
        let (_, bg) = self.bound.as_ref().expect("bound above");
        enc.clear_buffer(&receivers.caustic_atlas.buffer, 0, None);
        if params.bounce_first < params.photon_count {
            enc.clear_buffer(&receivers.indirect_atlas.buffer, 0, None);
        }
        enc.clear_buffer(&self.stats, 0, None);
        let deposit = params.flags & march_flags::DEPOSIT_RADIANCE != 0;
        if deposit {
            enc.clear_buffer(&radiance.flux_deposits, 0, None);
            enc.clear_buffer(&radiance.direction_deposits, 0, None);
        }
        let mut pass = profiler.pass(enc, "march");
        pass.set_bind_group(0, bg, &[]);
        pass.set_pipeline(&self.main);
        let (x, y) = layout::workgroups_1d(params.photon_count, 64);
        pass.dispatch_workgroups(x, y, 1);
        if deposit {
            pass.set_pipeline(&self.resolve);
            let d = (radiance.dims + 3) / 4;
            pass.dispatch_workgroups(d.x, d.y, d.z);
        }
    }

    /// Copies the statistics toward the CPU into readback `slot` (after `encode`, in the same
    /// submission).
    pub fn encode_stats_readback(&self, enc: &mut wgpu::CommandEncoder, slot: usize) {
        enc.copy_buffer_to_buffer(&self.stats, 0, &self.stats_staging[slot].buffer, 0, STAT_WORDS * 4);
    }

    /// The statistics of the frame submitted into readback `slot`, in watts.
    /// Makes `params` spectral when the frame disperses (`FrameDesc::spectrum`): photons carry
    /// wavelengths, over the visible spectrum or uniformly over `band` (nm; tests).
    pub fn with_spectrum(params: MarchParams, spectrum: Spectrum, band: Option<(f32, f32)>) -> MarchParams {
        if !spectrum.spectral {
            return params;
        }
        let (band_min, band_max) = band.unwrap_or((0.0, 0.0));
        MarchParams { flags: params.flags | march_flags::SPECTRAL, grid_dispersion: spectrum.grid_dispersion, band_min, band_max, ..params }
    }

    pub fn read_stats(&self, ctx: &GpuContext, params: &MarchParams, slot: usize) -> Result<PhotonStats> {
        let bytes = self.stats_staging[slot].read(ctx, STAT_WORDS * 4)?;
        let words: &[u32] = bytemuck::cast_slice(&bytes);
        let wide = |k: usize| (words[2 * k] as u64 | ((words[2 * k + 1] as u64) << 32)) as f64;
        let spectral = params.flags & march_flags::SPECTRAL != 0;
        let watts = |first: usize| {
            let sums = [0, 1, 2].map(|c| wide(first + c) * params.flux_unit as f64 / params.flux_scale as f64);
            // Spectral photons' sums are XYZ.
            if spectral { crate::cpu::spectrum::xyz_to_rgb(glam::DVec3::from(sums).as_vec3()).as_dvec3().to_array() } else { sums }
        };
        Ok(PhotonStats { emitted: watts(0), received: watts(3), caustic: watts(6), escaped: watts(9), saturated: wide(12) as u64, steps: wide(13) as u64 })
    }
}
