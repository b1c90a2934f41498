//! Per-stage GPU times from timestamp queries. Every stage opens its compute passes through
//! [`Profiler::pass`], which, when profiling is on and the adapter supports it, brackets the
//! pass with two timestamps; `refrakt bench` reads the durations after each frame.

use anyhow::Result;

use crate::gpu::GpuContext;
use crate::gpu::readback::Staging;

/// Most passes one frame may time.
const MAX_PASSES: u32 = 64;

pub struct Profiler {
    enabled: bool,
    supported: bool,
    query_set: Option<wgpu::QuerySet>,
    resolve: Option<wgpu::Buffer>,
    /// One staging buffer and label list per readback slot (see `Renderer::submit`).
    staging: [Option<Staging>; super::MAX_FRAMES_IN_FLIGHT],
    slot_labels: [Vec<&'static str>; super::MAX_FRAMES_IN_FLIGHT],
    labels: Vec<&'static str>,
    period_ns: f32,
    /// (stage label, milliseconds) of the last collected frame, in pass order.
    pub last: Vec<(&'static str, f64)>,
}

impl Profiler {
    pub fn new(ctx: &GpuContext) -> Self {
        Self {
            enabled: false,
            supported: ctx.has_timestamps(),
            query_set: None,
            resolve: None,
            staging: Default::default(),
            slot_labels: Default::default(),
            labels: Vec::new(),
            period_ns: ctx.queue.get_timestamp_period(),
            last: Vec::new(),
        }
    }

    /// Turns timing on (if the adapter can); returns whether it is on.
    pub fn enable(&mut self, ctx: &GpuContext) -> bool {
        if !self.supported {
            return false;
        }
        if self.query_set.is_none() {
            self.query_set = Some(ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("stage timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2 * MAX_PASSES,
            }));
            let size = 2 * MAX_PASSES as u64 * 8;
            self.resolve = Some(ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp resolve"),
                size,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }));
            self.staging = std::array::from_fn(|_| Some(Staging::new(&ctx.device, size, "timestamp readback")));
        }
        self.enabled = true;
        true
    }

    pub fn begin_frame(&mut self) {
        self.labels.clear();
    }

    /// A compute pass named `label`, timed when profiling is on.
    pub fn pass<'e>(&mut self, enc: &'e mut wgpu::CommandEncoder, label: &'static str) -> wgpu::ComputePass<'e> {
        let slot = self.labels.len() as u32;
        let timestamp_writes = match &self.query_set {
            Some(qs) if self.enabled && slot < MAX_PASSES => {
                self.labels.push(label);
                Some(wgpu::ComputePassTimestampWrites {
                    query_set: qs,
                    beginning_of_pass_write_index: Some(2 * slot),
                    end_of_pass_write_index: Some(2 * slot + 1),
                })
            }
            _ => None,
        };
        enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes })
    }

    /// Copies this frame's timestamps toward the CPU into readback `slot` (call once, after the
    /// last pass).
    pub fn resolve(&mut self, enc: &mut wgpu::CommandEncoder, slot: usize) {
        self.slot_labels[slot] = self.labels.clone();
        let (Some(qs), Some(buf), Some(staging)) = (&self.query_set, &self.resolve, &self.staging[slot]) else { return };
        let n = self.labels.len() as u32;
        if n == 0 {
            return;
        }
        enc.resolve_query_set(qs, 0..2 * n, buf, 0);
        enc.copy_buffer_to_buffer(buf, 0, &staging.buffer, 0, 2 * n as u64 * 8);
    }

    /// Reads the timestamps of readback `slot` into [`last`](Self::last), summing passes of one
    /// label.
    pub fn collect(&mut self, ctx: &GpuContext, slot: usize) -> Result<()> {
        self.last.clear();
        let Some(staging) = &self.staging[slot] else { return Ok(()) };
        let n = self.slot_labels[slot].len();
        if !self.enabled || n == 0 {
            return Ok(());
        }
        let bytes = staging.read(ctx, 2 * n as u64 * 8)?;
        let ticks: &[u64] = bytemuck::cast_slice(&bytes);
        for (i, label) in self.slot_labels[slot].iter().enumerate() {
            let ms = ticks[2 * i + 1].saturating_sub(ticks[2 * i]) as f64 * self.period_ns as f64 * 1e-6;
            match self.last.iter_mut().find(|(l, _)| l == label) {
                Some((_, total)) => *total += ms,
                None => self.last.push((label, ms)),
            }
        }
        Ok(())
    }
}
