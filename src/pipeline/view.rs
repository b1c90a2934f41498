//! Stage 6, view (`shaders/view.wgsl`): camera rays bent through the volume, gathering
//! in-scattered light, ending on receivers (direct + caustic light) or in the environment.

use anyhow::Result;

use super::layout;
use super::lights::LightBuffers;
use super::receivers::Receivers;
use super::resources::{EnvironmentTexture, FrameTarget, Grids, RadianceGrid};
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
    /// `main_companions`: each pixel's hero and companion wavelength in threads of their own
    /// (frames with `wavelengths_per_sample` 2), made from `module` the first time a frame
    /// needs it — a second compile of the pass's large shader that most sessions never use.
    companions: Option<wgpu::ComputePipeline>,
    module: layout::StageModule,
    params: wgpu::Buffer,
    /// The uniforms of each dispatch when a frame's samples are split (CPU adapters), copied
    /// into `params` before its dispatch.
    batches: Option<wgpu::Buffer>,
    /// 64-bit count of the ray-equation steps of the last frame (benchmarks).
    pub steps: wgpu::Buffer,
    steps_staging: [crate::gpu::readback::Staging; super::MAX_FRAMES_IN_FLIGHT],
    /// The split-sum table (`specular::brdf_lut`), constant.
    brdf_lut: wgpu::Buffer,
    /// Bind group and the generations of what it binds.
    bound: Option<([u64; 6], wgpu::BindGroup)>,
}

/// Everything the view reads besides the frame description.
pub struct ViewInputs<'a> {
    pub grids: &'a Grids,
    pub environment: &'a EnvironmentTexture,
    pub receivers: &'a Receivers,
    pub lights: &'a LightBuffers,
    pub radiance: &'a RadianceGrid,
    pub target: &'a FrameTarget,
    /// Whether photons were traced this frame (receivers read their caustic maps).
    pub caustics: bool,
    /// Whether bounce photons were traced this frame (receivers read their indirect maps).
    pub indirect: bool,
    /// Whether the radiance grid holds this frame's fluence.
    pub scattering: bool,
    /// The frame's first camera sample ([`Renderer::refinement`](super::Renderer::refinement),
    /// [`Renderer::instant`](super::Renderer::instant)).
    pub sample_first: u32,
    /// The camera samples the frame's planes average over: `samples`, or all its instants'.
    pub frame_samples: u32,
}

/// Where camera sample k falls inside its pixel (0..1 on each axis): the R2 low-discrepancy
/// sequence (Roberts 2018), the same in every pixel — the CPU twin of view.wgsl's `r2`.
pub fn sample_offset(k: u32) -> glam::Vec2 {
    (glam::Vec2::splat(0.5) + k as f32 * glam::Vec2::new(0.754_877_7, 0.569_840_3)).fract()
}

/// Camera samples one dispatch traces on a CPU adapter. Mesa's llvmpipe (lavapipe) ends every
/// loop of a shader invocation, silently, once its loops have run 65 535 iterations in all
/// (gallivm's `LP_MAX_TGSI_LOOP_ITERATIONS`): a pixel's many samples in one invocation would
/// lose light past it (48 samples of a small scene already did). GPUs take all in one dispatch.
pub const CPU_SAMPLES_PER_DISPATCH: u32 = 4;

/// Wavelengths per pixel that a spectral frame traces at least where camera rays meet
/// dispersive glass: a pixel of one sample traces the sample at a companion wavelength too, half
/// the spectrum on, where it meets dispersion, so one sample per pixel — a live session, `seed`
/// — does not turn a caustic seen through the glass into the colour of one wavelength (a
/// wavelength's sample weighs its colour by M·x̄ȳz̄(λ)/p(λ), up to 5.6× on a channel). Two, not
/// more: those pixels are the view's slowest, and each wavelength retraces them (measured on
/// the H200, docs/performance.md, Dispersion). The companion runs in a thread of its own, the z = 1 half of
/// `main_companions`' workgroups (8 × 8 × 2): this must stay 2.
pub const SPECTRAL_WAVELENGTHS_PER_PIXEL: u32 = 2;

/// Wavelengths per camera sample: enough that a pixel's samples take at least
/// `SPECTRAL_WAVELENGTHS_PER_PIXEL` of them; 1 without dispersion.
pub fn wavelengths_per_sample(spectral: bool, samples: u32) -> u32 {
    if spectral { SPECTRAL_WAVELENGTHS_PER_PIXEL.div_ceil(samples.max(1)) } else { 1 }
}

/// The frame's dispatches: the uniforms of each, its samples split as the adapter needs.
pub fn dispatches(params: ViewParams, device_type: wgpu::DeviceType) -> Vec<ViewParams> {
    // On a CPU adapter, a dispatch traces at most CPU_SAMPLES_PER_DISPATCH paths per pixel,
    // companions included.
    let per = if device_type == wgpu::DeviceType::Cpu { (CPU_SAMPLES_PER_DISPATCH / params.wavelengths_per_sample.max(1)).max(1) } else { params.samples };
    let end = params.sample_first + params.sample_count;
    (params.sample_first..end)
        .step_by(per as usize)
        .map(|first| ViewParams { sample_first: first, sample_count: per.min(end - first), ..params })
        .collect()
}

/// The environment's uniforms: what camera rays see, and (with its table) the light it is.
pub fn env_params(desc: &FrameDesc) -> EnvParams {
    let env = &desc.environment;
    use crate::gpu::types::env_kind;
    let (color, kind) = match &env.source {
        crate::scene::EnvironmentSource::Color(c) => (*c, env_kind::COLOR),
        _ if env.evaluated_per_ray() => (glam::Vec3::ONE, env_kind::STUDIO),
        _ => (glam::Vec3::ONE, env_kind::IMAGE),
    };
    EnvParams { color: color.into(), intensity: env.intensity, turn: env.turn().to_array(), kind, visible: env.visible as u32, footprint: desc.camera.pixel_angle(), _pad0: 0.0 }
}

/// Shadow-ray pairs toward the environment per receiver hit and camera sample
/// (`ENV_PAIRS_PER_SAMPLE`), 0 when the environment is dark (then receivers are shaded as before
/// it was a light, bit for bit).
pub fn env_pairs(desc: &FrameDesc, env: &EnvironmentTexture) -> u32 {
    let lit = (env.light.integral * super::env_light::scale(&desc.environment)).max_element() > 0.0;
    if lit { ENV_PAIRS_PER_SAMPLE } else { 0 }
}

/// Pairs of shadow rays toward the environment a camera sample takes at a receiver: soft sky
/// shadows converge with samples, and a frame refined pass by pass (`serve`) takes exactly the
/// rays a frame of all those samples takes.
pub const ENV_PAIRS_PER_SAMPLE: u32 = 4;

/// The uniforms of one frame.
pub fn view_params(desc: &FrameDesc, inputs: &ViewInputs) -> ViewParams {
    let v = &desc.volume;
    // A curved ray can wander: allow a few box diagonals of steps before giving up.
    let diagonal = (v.max() - v.min).length();
    let max_steps = ((4.0 * diagonal / v.step).ceil() as u32).clamp(16, 1 << 20);
    let camera_media = super::interfaces::media_at(desc, desc.camera.position);
    let mut flags = 0;
    if desc.has_media() {
        flags |= view_flags::MEDIA;
    }
    if inputs.scattering {
        flags |= view_flags::SCATTERING;
    }
    if inputs.caustics {
        flags |= view_flags::CAUSTICS;
    }
    if inputs.indirect {
        flags |= view_flags::INDIRECT;
    }
    // Shadow rays look past cut-outs, see-through receivers and thin glass sheets and shells.
    let thin_glass = desc.meshes.iter().any(|m| m.sharp && m.thin) || desc.fields.iter().any(|f| f.sharp && f.thin);
    if desc.receivers.iter().any(|r| r.diffuse.alpha_mode != crate::scene::AlphaMode::Opaque) || thin_glass {
        flags |= view_flags::SEE_THROUGH;
    }
    if desc.receivers.iter().any(|r| r.diffuse.is_pbr()) {
        flags |= view_flags::SPECULAR;
    }
    if desc.lights.iter().any(|l| l.visible) {
        flags |= view_flags::VISIBLE_LIGHTS;
    }
    let spectrum = desc.spectrum();
    if spectrum.spectral {
        flags |= view_flags::SPECTRAL;
    }
    let (origin, frame_width) = (desc.camera.frame_origin(), desc.camera.frame_size().0);
    ViewParams {
        camera: desc.camera.to_gpu(),
        grid: v.to_gpu(),
        env: env_params(desc),
        width: desc.camera.width,
        height: desc.camera.height,
        max_steps,
        max_path: super::march::max_path(diagonal),
        flags,
        step: v.step,
        medium_eps: MEDIUM_EPS,
        samples: inputs.frame_samples.max(1),
        sample_first: inputs.sample_first,
        sample_count: desc.samples.max(1),
        light_count: inputs.lights.light_count,
        glowing_count: inputs.lights.glowing_count,
        // In a scattering medium the in-scattered light varies voxel to voxel: sample each.
        max_step: if inputs.scattering { v.voxel_size } else { 64.0 * v.voxel_size },
        eps_refract: super::photons::EPS_REFRACT,
        env_pairs: env_pairs(desc, inputs.environment),
        indirect_chart_base: super::receivers::indirect_chart_base(inputs.receivers.layout.charts.len()),
        camera_media_lo: camera_media[0],
        camera_media_hi: camera_media[1],
        grid_dispersion: spectrum.grid_dispersion,
        wavelengths_per_sample: wavelengths_per_sample(spectrum.spectral, inputs.frame_samples),
        pixel_key_first: origin.0 + origin.1 * frame_width,
        pixel_key_stride: frame_width,
        _pad: [0; 2],
    }
}

/// The view pass's bind group layout: grids, environment, the frame's planes, octree, receivers
/// and their BVH and maps, lights, radiance grid, step count and BRDF table. Its storage buffers are the
/// most any stage binds (`gpu::STORAGE_BUFFERS_PER_STAGE`, which adapters are checked against).
fn bindings() -> Vec<wgpu::BindGroupLayoutEntry> {
    let d3 = wgpu::TextureViewDimension::D3;
    vec![
        layout::uniform(0),
        layout::texture(1, d3),
        layout::texture(2, d3),
        layout::texture(3, d3),
        layout::sampler(4),
        layout::texture(5, wgpu::TextureViewDimension::D2),
        layout::sampler(6),
        layout::storage(7, false),
        layout::uniform(8),
        layout::storage(9, true),
        layout::storage(10, true),
        layout::storage(11, true),
        layout::storage(12, true),
        layout::storage(13, true),
        layout::storage(14, true),
        layout::storage(15, true),
        layout::texture(16, d3),
        layout::texture(17, d3),
        layout::storage(18, false),
        layout::storage(19, true),
        layout::storage(20, true),
        layout::storage(21, true),
        layout::storage(22, true),
        layout::texture(23, wgpu::TextureViewDimension::D2Array),
        layout::storage(24, true),
        layout::storage(25, true),
        layout::storage(26, true),
        layout::storage(27, true),
        layout::storage(28, true),
        layout::storage(29, true),
        layout::storage(30, false),
        layout::storage(31, false),
        layout::storage(32, false),
        layout::storage(33, false),
        layout::storage(34, false),
    ]
}

impl View {
    pub fn new(device: &wgpu::Device, shaders: &ShaderLibrary) -> Result<Self> {
        let module = layout::StageModule::new(device, shaders, "view", &[&bindings()])?;
        let pipeline = module.pipeline(device, "main");
        let params = layout::uniform_buffer::<ViewParams>(device, "view params");
        let steps = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view steps"),
            size: 8,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let steps_staging = std::array::from_fn(|_| crate::gpu::readback::Staging::new(device, 8, "view steps readback"));
        let brdf_lut = wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("brdf lut"),
                contents: bytemuck::cast_slice(super::specular::brdf_lut()),
                usage: wgpu::BufferUsages::STORAGE,
            },
        );
        Ok(Self { pipeline, companions: None, module, params, batches: None, steps, steps_staging, brdf_lut, bound: None })
    }

    pub fn encode(&mut self, ctx: &GpuContext, enc: &mut wgpu::CommandEncoder, profiler: &mut Profiler, desc: &FrameDesc, inputs: &ViewInputs) {
        let dispatches = dispatches(view_params(desc, inputs), ctx.info.device_type);
        let with_companions = dispatches[0].wavelengths_per_sample > 1;
        if with_companions && self.companions.is_none() {
            self.companions = Some(self.module.pipeline(&ctx.device, "main_companions"));
        }
        let size = std::mem::size_of::<ViewParams>() as u64;
        if dispatches.len() == 1 {
            ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&dispatches[0]));
        } else {
            let needed = size * dispatches.len() as u64;
            if self.batches.as_ref().is_none_or(|b| b.size() < needed) {
                self.batches = Some(ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("view dispatches"),
                    size: needed,
                    usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }));
            }
            ctx.queue.write_buffer(self.batches.as_ref().expect("made above"), 0, bytemuck::cast_slice(&dispatches));
        }
        let (grids, env, receivers, lights, radiance, target) =
            (inputs.grids, inputs.environment, inputs.receivers, inputs.lights, inputs.radiance, inputs.target);
        let generations = [grids.generation, env.generation, target.generation, receivers.generation, lights.generation, radiance.generation];
        if self.bound.as_ref().is_none_or(|(g, _)| *g != generations) {
            let bg = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("view"),
                layout: &self.module.layouts[0],
                entries: &[
                    layout::bind(0, &self.params),
                    wgpu::BindGroupEntry { binding: 1, resource: layout::texture_view(&grids.ior_grid.view) },
                    wgpu::BindGroupEntry { binding: 2, resource: layout::texture_view(&grids.extinction_grid.view) },
                    wgpu::BindGroupEntry { binding: 3, resource: layout::texture_view(&grids.scattering_grid.view) },
                    wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::Sampler(&grids.sampler) },
                    wgpu::BindGroupEntry { binding: 5, resource: layout::texture_view(&env.view) },
                    wgpu::BindGroupEntry { binding: 6, resource: wgpu::BindingResource::Sampler(&env.sampler) },
                    wgpu::BindGroupEntry { binding: 7, resource: target.plane(0) },
                    wgpu::BindGroupEntry { binding: 30, resource: target.plane(1) },
                    wgpu::BindGroupEntry { binding: 31, resource: target.plane(2) },
                    wgpu::BindGroupEntry { binding: 32, resource: target.plane(3) },
                    wgpu::BindGroupEntry { binding: 33, resource: target.plane(4) },
                    wgpu::BindGroupEntry { binding: 34, resource: target.plane(5) },
                    layout::bind(8, &grids.octree_params),
                    layout::bind(9, &grids.octree),
                    layout::bind(25, &grids.octree_leaves),
                    layout::bind(10, &receivers.bvh_nodes.buffer),
                    layout::bind(11, &receivers.bvh_triangles.buffer),
                    layout::bind(12, &receivers.receivers.buffer),
                    layout::bind(13, &receivers.charts.buffer),
                    layout::bind(14, &receivers.caustic_irradiance.buffer),
                    layout::bind(15, &lights.lights),
                    wgpu::BindGroupEntry { binding: 16, resource: layout::texture_view(&radiance.fluence.view) },
                    wgpu::BindGroupEntry { binding: 17, resource: layout::texture_view(&radiance.direction.view) },
                    layout::bind(18, &self.steps),
                    layout::bind(19, &receivers.triangle_uvs.buffer),
                    layout::bind(20, &receivers.albedo_texels.buffer),
                    layout::bind(21, &receivers.interfaces.buffer),
                    layout::bind(22, &receivers.triangle_normals.buffer),
                    wgpu::BindGroupEntry { binding: 23, resource: layout::texture_view(&env.specular_view) },
                    layout::bind(24, &self.brdf_lut),
                    layout::bind(26, &env.light_table),
                    layout::bind(27, &receivers.indirect_irradiance.buffer),
                    layout::bind(28, &lights.triangles),
                    layout::bind(29, &receivers.rough_albedo),
                ],
            });
            self.bound = Some((generations, bg));
        }
        let (_, bg) = self.bound.as_ref().expect("bound above");
        let pipeline = if with_companions { self.companions.as_ref().expect("made above") } else { &self.pipeline };
        enc.clear_buffer(&self.steps, 0, None);
        for b in 0..dispatches.len() as u64 {
            if let (Some(batches), true) = (&self.batches, dispatches.len() > 1) {
                enc.copy_buffer_to_buffer(batches, b * size, &self.params, 0, size);
            }
            let mut pass = profiler.pass(enc, "view");
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bg, &[]);
            pass.dispatch_workgroups(target.width.div_ceil(8), target.height.div_ceil(8), 1);
        }
    }

    /// Copies the step count toward the CPU into readback `slot`.
    pub fn encode_steps_readback(&self, enc: &mut wgpu::CommandEncoder, slot: usize) {
        enc.copy_buffer_to_buffer(&self.steps, 0, &self.steps_staging[slot].buffer, 0, 8);
    }

    /// The ray-equation steps of the frame submitted into readback `slot`.
    pub fn read_steps(&self, ctx: &GpuContext, slot: usize) -> Result<u64> {
        let bytes = self.steps_staging[slot].read(ctx, 8)?;
        let words: &[u32] = bytemuck::cast_slice(&bytes);
        Ok(words[0] as u64 | (words[1] as u64) << 32)
    }
}

#[cfg(test)]
mod tests {
    /// Adapters are refused below this many storage buffers a stage: it must be what the view,
    /// the stage that binds the most, binds.
    #[test]
    fn adapters_are_checked_for_the_views_storage_buffers() {
        let storage = super::bindings().iter().filter(|e| matches!(e.ty, wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Storage { .. }, .. })).count();
        assert_eq!(storage as u32, crate::gpu::STORAGE_BUFFERS_PER_STAGE);
    }
}
