//! Stage 5b, caustics (`shaders/caustics.wgsl`): the receivers' caustic maps from photon
//! deposits to irradiance, with a footprint that adapts to the photon density.

use anyhow::Result;

use super::layout;
use super::receivers::Receivers;
use super::timing::Profiler;
use crate::gpu::GpuContext;
use crate::gpu::shaders::ShaderLibrary;
use crate::gpu::types::CausticParams;

/// How caustic maps are filtered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CausticFilter {
    /// The smallest footprint holding `target` photons (k nearest neighbours, smoothly).
    Adaptive { target: u32 },
    /// A fixed square of half-size `radius` texels (as the seed's fixed Gaussian).
    Fixed { radius: u32 },
}

impl Default for CausticFilter {
    fn default() -> Self {
        CausticFilter::Adaptive { target: 32 }
    }
}

/// Largest half-size (texels) the adaptive footprint grows to.
pub const MAX_RADIUS: u32 = 64;

pub struct Caustics {
    rows: wgpu::ComputePipeline,
    columns: wgpu::ComputePipeline,
    filter: wgpu::ComputePipeline,
    bgl: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    bound: Option<(u64, wgpu::BindGroup)>,
}

impl Caustics {
    pub fn new(device: &wgpu::Device, shaders: &ShaderLibrary) -> Result<Self> {
        let entries =
            [layout::uniform(0), layout::storage(1, true), layout::storage(2, true), layout::storage(3, false), layout::storage(4, false)];
        let (rows, bgl) = layout::pipeline_entry(device, shaders, "caustics", "sat_rows", &entries)?;
        let (columns, _) = layout::pipeline_entry(device, shaders, "caustics", "sat_columns", &entries)?;
        let (filter, _) = layout::pipeline_entry(device, shaders, "caustics", "filter_charts", &entries)?;
        let params = layout::uniform_buffer::<CausticParams>(device, "caustic params");
        Ok(Self { rows, columns, filter, bgl, params, bound: None })
    }

    /// `flux_unit`: watts per fixed-point unit of deposited flux.
    pub fn encode(&mut self, ctx: &GpuContext, enc: &mut wgpu::CommandEncoder, profiler: &mut Profiler, receivers: &Receivers, filter: CausticFilter, flux_unit: f32, spectral: bool) {
        let charts = &receivers.layout.charts;
        if charts.is_empty() {
            return;
        }
        let (target_count, fixed_radius) = match filter {
            CausticFilter::Adaptive { target } => (target, 0),
            CausticFilter::Fixed { radius } => (0, radius.max(1)),
        };
        let params = CausticParams {
            chart_count: charts.len() as u32,
            target_count,
            fixed_radius,
            max_radius: MAX_RADIUS,
            flux_unit,
            spectral: spectral as u32,
            ..Default::default()
        };
        ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        if self.bound.as_ref().is_none_or(|(g, _)| *g != receivers.generation) {
            let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("caustics"),
                layout: &self.bgl,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: self.params.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: receivers.charts.buffer.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 2, resource: receivers.caustic_atlas.buffer.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 3, resource: receivers.caustic_sat.buffer.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 4, resource: receivers.caustic_irradiance.buffer.as_entire_binding() },
                ],
            });
            self.bound = Some((receivers.generation, bg));
        }
        let (_, bg) = self.bound.as_ref().expect("bound above");
        let max_w = charts.iter().map(|c| c.width).max().unwrap_or(1);
        let max_h = charts.iter().map(|c| c.height).max().unwrap_or(1);
        let n = charts.len() as u32;
        let mut pass = profiler.pass(enc, "caustics");
        pass.set_bind_group(0, bg, &[]);
        pass.set_pipeline(&self.rows);
        pass.dispatch_workgroups(max_h, n, 1);
        pass.set_pipeline(&self.columns);
        pass.dispatch_workgroups(max_w, n, 1);
        pass.set_pipeline(&self.filter);
        pass.dispatch_workgroups(max_w.div_ceil(8), max_h.div_ceil(8), n);
    }
}
