//! Stage 6, view (`shaders/view.wgsl`): camera rays bent through the volume, attenuated, and
//! shaded by the environment where they leave it.

use anyhow::Result;

use super::layout;
use super::resources::{EnvironmentTexture, FrameTarget, Grids};
use super::timing::Profiler;
use crate::frame::FrameDesc;
use crate::gpu::GpuContext;
use crate::gpu::shaders::ShaderLibrary;
use crate::gpu::types::{EnvParams, ViewParams, view_flags};

/// |n − 1| above which a sample counts as inside a refractive object (alpha, depth): just
/// above the spacing of 16-bit floats at 1 (2⁻¹⁰), so air stored as exactly 1 never counts.
pub const MEDIUM_EPS: f32 = 1.5e-3;

pub struct View {
    pipeline: wgpu::ComputePipeline,
    bgl: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    /// Bind group and the generations (grids, environment, target) it was made for.
    bound: Option<([u64; 3], wgpu::BindGroup)>,
}

/// The uniforms of one frame.
pub fn view_params(desc: &FrameDesc) -> ViewParams {
    let v = &desc.volume;
    let env = &desc.environment;
    let (color, kind) = match &env.source {
        crate::scene::EnvironmentSource::Color(c) => (*c, 0),
        _ => (glam::Vec3::ONE, 1),
    };
    // A curved ray can wander: allow three box diagonals of steps before giving up.
    let diagonal = (v.max() - v.min).length();
    let max_steps = ((3.0 * diagonal / v.step).ceil() as u32).clamp(16, 1 << 20);
    ViewParams {
        camera: desc.camera.to_gpu(),
        grid: v.to_gpu(),
        env: EnvParams {
            color: color.into(),
            intensity: env.intensity,
            rotation: env.rotation,
            kind,
            visible: env.visible as u32,
            _pad0: 0,
        },
        width: desc.camera.width,
        height: desc.camera.height,
        max_steps,
        flags: if desc.has_media() { view_flags::MEDIA } else { 0 },
        step: v.step,
        medium_eps: MEDIUM_EPS,
        samples: desc.samples.max(1),
        ..Default::default()
    }
}

impl View {
    pub fn new(device: &wgpu::Device, shaders: &ShaderLibrary) -> Result<Self> {
        let d3 = wgpu::TextureViewDimension::D3;
        let (pipeline, bgl) = layout::pipeline(
            device,
            shaders,
            "view",
            &[
                layout::uniform(0),
                layout::texture(1, d3),
                layout::texture(2, d3),
                layout::sampler(3),
                layout::texture(4, wgpu::TextureViewDimension::D2),
                layout::sampler(5),
                layout::storage(6, false),
            ],
        )?;
        let params = layout::uniform_buffer::<ViewParams>(device, "view params");
        Ok(Self { pipeline, bgl, params, bound: None })
    }

    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        profiler: &mut Profiler,
        desc: &FrameDesc,
        grids: &Grids,
        env: &EnvironmentTexture,
        target: &FrameTarget,
    ) {
        ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&view_params(desc)));
        let generations = [grids.generation, env.generation, target.generation];
        if self.bound.as_ref().is_none_or(|(g, _)| *g != generations) {
            let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("view"),
                layout: &self.bgl,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: self.params.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&grids.ior_grid.view) },
                    wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&grids.extinction_grid.view) },
                    wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::Sampler(&grids.sampler) },
                    wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::TextureView(&env.view) },
                    wgpu::BindGroupEntry { binding: 5, resource: wgpu::BindingResource::Sampler(&env.sampler) },
                    wgpu::BindGroupEntry { binding: 6, resource: target.buffer.as_entire_binding() },
                ],
            });
            self.bound = Some((generations, bg));
        }
        let (_, bg) = self.bound.as_ref().expect("bound above");
        let mut pass = profiler.pass(enc, "view");
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bg, &[]);
        pass.dispatch_workgroups(target.width.div_ceil(8), target.height.div_ceil(8), 1);
    }
}
