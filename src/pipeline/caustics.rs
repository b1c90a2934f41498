//! Stage 5b, caustics (`shaders/caustics.wgsl`): the receivers' caustic maps from photon
//! deposits to irradiance, with a footprint that adapts to the photon density and a filter that
//! keeps every photon's energy (each texel's deposits are spread over its own footprint).

use anyhow::Result;

use super::layout;
use super::receivers::{Receivers, indirect_chart_base};
use super::timing::Profiler;
use crate::gpu::GpuContext;
use crate::gpu::shaders::ShaderLibrary;
use crate::gpu::types::{CausticLevel, CausticParams, Chart};

/// How caustic maps are filtered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CausticFilter {
    /// The smallest footprint holding `target` photons (k nearest neighbours, smoothly).
    Adaptive { target: u32 },
    /// A fixed square of half-size `radius` texels (as the seed's fixed Gaussian).
    Fixed { radius: u32 },
}

impl CausticFilter {
    /// The filter of the indirect maps: bounced light is smooth, so the adaptive footprint
    /// gathers `INDIRECT_TARGET_SCALE` times the photons (less noise, the same sharpness where
    /// photons are dense); a fixed one stays as it is.
    pub fn for_indirect(self) -> Self {
        match self {
            CausticFilter::Adaptive { target } => CausticFilter::Adaptive { target: target * INDIRECT_TARGET_SCALE },
            fixed => fixed,
        }
    }
}

/// How many times the caustic maps' photon target the indirect maps' footprints hold.
pub const INDIRECT_TARGET_SCALE: u32 = 16;

impl Default for CausticFilter {
    fn default() -> Self {
        CausticFilter::Adaptive { target: 32 }
    }
}

/// Largest half-size (texels) the adaptive footprint grows to.
pub const MAX_RADIUS: u32 = 64;

/// Footprints of half-size up to this are summed texel by texel (at most 25 reads) instead of
/// through a summed-area table of their level, which costs two scans of the whole atlas.
pub const DIRECT_RADIUS: u32 = 2;

/// How much a level of half-size `radius` coarsens the chart: the wide levels (8 texels and more)
/// are spread over 9 × 9 cells of radius/4 texels (see caustics.wgsl), so their tables cover
/// 1/4, 1/16, … of the chart.
pub fn coarsening(radius: u32) -> u32 {
    if radius >= 8 { radius / 4 } else { 1 }
}

/// The adaptive filter's smallest levels (half-sizes 0, 1, 2) are filtered in one pass
/// (`gather_direct_levels`, which mirrors this number as `DIRECT_LEVELS`).
pub const DIRECT_LEVELS: usize = 3;

/// Cells of this many texels a side and more are summed by a workgroup each
/// (`spread_wide_level`), smaller ones by a thread each (`spread_level`).
pub const WIDE_COARSENING: u32 = 8;

/// The footprint sizes a filter spreads over, in the shader's level order: {0, 1, 2, 4, …,
/// MAX_RADIUS} for the adaptive filter, the one square of a fixed one.
pub fn level_radii(filter: CausticFilter) -> Vec<u32> {
    match filter {
        CausticFilter::Adaptive { .. } => std::iter::once(0).chain((0..).map(|k| 1 << k).take_while(|&r| r <= MAX_RADIUS)).collect(),
        CausticFilter::Fixed { radius } => vec![radius.max(1)],
    }
}

/// Which of the receivers' maps a pass filters: the caustic maps (photons through glass) or the
/// indirect maps (bounced light).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChartMap {
    Caustic = 0,
    Indirect = 1,
}

impl ChartMap {
    fn label(self) -> &'static str {
        match self {
            ChartMap::Caustic => "caustics",
            ChartMap::Indirect => "indirect",
        }
    }
}

pub struct Caustics {
    load: wgpu::ComputePipeline,
    rows: wgpu::ComputePipeline,
    columns: wgpu::ComputePipeline,
    choose: wgpu::ComputePipeline,
    spread: wgpu::ComputePipeline,
    spread_wide: wgpu::ComputePipeline,
    gather: wgpu::ComputePipeline,
    gather_direct: wgpu::ComputePipeline,
    bgl: wgpu::BindGroupLayout,
    level_bgl: wgpu::BindGroupLayout,
    /// Per map (caustic, indirect): its uniforms and bind group.
    params: [wgpu::Buffer; 2],
    /// Keyed by the receivers' buffers and both chart counts (the indirect charts' binding range
    /// follows them).
    bound: [Option<([u64; 3], wgpu::BindGroup)>; 2],
    /// One uniform and bind group per (level index, radius), made once.
    levels: Vec<(CausticLevel, wgpu::Buffer, wgpu::BindGroup)>,
}

impl Caustics {
    pub fn new(device: &wgpu::Device, shaders: &ShaderLibrary) -> Result<Self> {
        let entries = [
            layout::uniform(0),
            layout::storage(1, true),
            layout::storage(2, true),
            layout::storage(3, false),
            layout::storage(4, false),
            layout::storage(5, false),
            layout::storage(6, false),
            layout::storage(7, false),
        ];
        let entry_points = ["load_deposits", "sat_rows", "sat_columns", "choose_footprints", "spread_level", "spread_wide_level", "gather_level", "gather_direct_levels"];
        let (pipelines, mut layouts) = layout::pipelines(device, shaders, "caustics", &[&entries, &[layout::uniform(0)]], &entry_points)?;
        let [load, rows, columns, choose, spread, spread_wide, gather, gather_direct] =
            <[_; 8]>::try_from(pipelines).map_err(|_| anyhow::anyhow!("eight caustics pipelines"))?;
        let level_bgl = layouts.pop().expect("two layouts");
        let bgl = layouts.pop().expect("two layouts");
        let params = [layout::uniform_buffer::<CausticParams>(device, "caustic params"), layout::uniform_buffer::<CausticParams>(device, "indirect params")];
        Ok(Self { load, rows, columns, choose, spread, spread_wide, gather, gather_direct, bgl, level_bgl, params, bound: [None, None], levels: Vec::new() })
    }

    /// The bind group of level `index` with half-size `radius`, made the first time it is asked.
    fn level(&mut self, device: &wgpu::Device, index: u32, radius: u32) -> usize {
        let coarsening = coarsening(radius);
        let want = CausticLevel { index, radius, coarsening, reach: radius / coarsening };
        if let Some(k) = self.levels.iter().position(|(l, _, _)| *l == want) {
            return k;
        }
        use wgpu::util::DeviceExt;
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("caustic level"),
            contents: bytemuck::bytes_of(&want),
            usage: layout::PARAMS,
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("caustic level"),
            layout: &self.level_bgl,
            entries: &[layout::bind(0, &buffer)],
        });
        self.levels.push((want, buffer, group));
        self.levels.len() - 1
    }

    /// Filters one of the receivers' maps: `map`'s deposits to its irradiance. `flux_unit`:
    /// watts per fixed-point unit of deposited flux. The two maps share the scratch tables, so
    /// the indirect maps are filtered after the caustic maps, in the same encoder.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(&mut self, ctx: &GpuContext, enc: &mut wgpu::CommandEncoder, profiler: &mut Profiler, receivers: &Receivers, map: ChartMap, filter: CausticFilter, flux_unit: f32, spectral: bool) {
        let charts = match map {
            ChartMap::Caustic => &receivers.layout.charts,
            ChartMap::Indirect => &receivers.layout.indirect_charts,
        };
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
            direct_radius: DIRECT_RADIUS,
            ..Default::default()
        };
        let k = map as usize;
        ctx.queue.write_buffer(&self.params[k], 0, bytemuck::bytes_of(&params));
        let key = [receivers.generation, receivers.layout.charts.len() as u64, charts.len() as u64];
        if self.bound[k].as_ref().is_none_or(|(g, _)| *g != key) {
            let (atlas, irradiance) = match map {
                ChartMap::Caustic => (&receivers.caustic_atlas, &receivers.caustic_irradiance),
                ChartMap::Indirect => (&receivers.indirect_atlas, &receivers.indirect_irradiance),
            };
            // The indirect maps' charts follow the caustic maps' in the same buffer.
            let chart_bytes = std::mem::size_of::<Chart>() as u64;
            let first = match map {
                ChartMap::Caustic => 0,
                ChartMap::Indirect => indirect_chart_base(receivers.layout.charts.len()) as u64,
            };
            let chart_range = wgpu::BufferBinding {
                buffer: &receivers.charts.buffer,
                offset: first * chart_bytes,
                size: wgpu::BufferSize::new(charts.len() as u64 * chart_bytes),
            };
            let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("caustics"),
                layout: &self.bgl,
                entries: &[
                    layout::bind(0, &self.params[k]),
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Buffer(chart_range) },
                    layout::bind(2, &atlas.buffer),
                    layout::bind(3, &receivers.caustic_sat.buffer),
                    layout::bind(4, &irradiance.buffer),
                    layout::bind(5, &receivers.caustic_layer.buffer),
                    layout::bind(6, &receivers.caustic_footprint.buffer),
                    layout::bind(7, &receivers.chart_photons.buffer),
                ],
            });
            self.bound[k] = Some((key, bg));
        }
        let levels: Vec<usize> = level_radii(filter).into_iter().enumerate().map(|(k, r)| self.level(&ctx.device, k as u32, r)).collect();
        // The photon counts are tabulated on the chart itself (a level of half-size 0).
        let texel_level = self.level(&ctx.device, 0, 0);
        let (_, bg) = self.bound[k].as_ref().expect("bound above");
        let max_w = charts.iter().map(|c| c.width).max().unwrap_or(1);
        let max_h = charts.iter().map(|c| c.height).max().unwrap_or(1);
        let n = charts.len() as u32;
        let mut pass = profiler.pass(enc, map.label());
        pass.set_bind_group(0, bg, &[]);
        pass.set_bind_group(1, &self.levels[texel_level].2, &[]);
        let per_texel = |pass: &mut wgpu::ComputePass, pipeline: &wgpu::ComputePipeline| {
            pass.set_pipeline(pipeline);
            pass.dispatch_workgroups(max_w.div_ceil(8), max_h.div_ceil(8), n);
        };
        let table = |pass: &mut wgpu::ComputePass| {
            pass.set_pipeline(&self.rows);
            pass.dispatch_workgroups(max_h, n, 1);
            pass.set_pipeline(&self.columns);
            pass.dispatch_workgroups(max_w, n, 1);
        };
        // The table of the raw deposits, and each texel's footprint from its photon counts.
        per_texel(&mut pass, &self.load);
        table(&mut pass);
        per_texel(&mut pass, &self.choose);
        // Each level's share, spread over squares of its size: the adaptive filter's smallest
        // levels in one pass, the others one by one.
        let direct = match filter {
            CausticFilter::Adaptive { .. } => DIRECT_LEVELS,
            CausticFilter::Fixed { .. } => 0,
        };
        if direct > 0 {
            per_texel(&mut pass, &self.gather_direct);
        }
        for &k in &levels[direct..] {
            let level = self.levels[k].0;
            pass.set_bind_group(1, &self.levels[k].2, &[]);
            if level.coarsening >= WIDE_COARSENING {
                let cells = |texels: u32| texels.div_ceil(level.coarsening);
                pass.set_pipeline(&self.spread_wide);
                pass.dispatch_workgroups(cells(max_w), cells(max_h), n);
            } else {
                per_texel(&mut pass, &self.spread);
            }
            if level.reach > DIRECT_RADIUS {
                table(&mut pass);
            }
            per_texel(&mut pass, &self.gather);
        }
    }
}
