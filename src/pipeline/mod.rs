//! The GPU pipeline: one module per stage, each owning its pipeline, uniforms and bind group,
//! and [`Renderer::frame`] reading top to bottom as the frame does.
//!
//! Resources shared between stages (the grids, the environment, the frame target) live in
//! [`resources`]; they are allocated when a size changes and reused otherwise, and stages rebind
//! only when a resource they use was reallocated.

pub mod gradient;
pub mod probe;
pub mod resources;
pub mod timing;
pub mod view;
pub mod voxelize;
pub mod voxelize_mesh;

use anyhow::{Result, bail};

use crate::frame::FrameDesc;
use crate::gpu::GpuContext;
use crate::gpu::shaders::ShaderLibrary;
use crate::output::Image;
use resources::{EnvironmentTexture, FrameTarget, Grids};
use timing::Profiler;

/// Statistics a test or `refrakt watch` can read: how much work the last frames did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    pub frames: u64,
    pub voxelizations: u64,
    pub grid_allocations: u64,
    pub environment_uploads: u64,
    /// Meshes whose solid was computed (they were new, changed or moved).
    pub meshes_voxelized: u64,
    /// Meshes whose solid from an earlier frame was reused.
    pub meshes_reused: u64,
    /// Triangles rasterized into mesh solids.
    pub mesh_triangles: u64,
}

impl Counters {
    fn add_mesh_work(&mut self, w: voxelize_mesh::MeshWork) {
        self.meshes_voxelized += w.voxelized;
        self.meshes_reused += w.reused;
        self.mesh_triangles += w.triangles;
    }
}

pub struct Renderer {
    pub ctx: GpuContext,
    shaders: ShaderLibrary,
    voxelize: voxelize::Voxelize,
    gradient: gradient::Gradient,
    view: view::View,
    probe: probe::Probe,
    grids: Option<Grids>,
    environment: EnvironmentTexture,
    target: Option<FrameTarget>,
    pub profiler: Profiler,
    pub counters: Counters,
}

impl Renderer {
    pub fn new(ctx: GpuContext) -> Result<Self> {
        Self::with_shaders(ctx, ShaderLibrary::Embedded)
    }

    pub fn with_shaders(ctx: GpuContext, shaders: ShaderLibrary) -> Result<Self> {
        let device = &ctx.device;
        let voxelize = voxelize::Voxelize::new(device, &shaders)?;
        let gradient = gradient::Gradient::new(device, &shaders)?;
        let view = view::View::new(device, &shaders)?;
        let probe = probe::Probe::new(device, &shaders)?;
        let environment = EnvironmentTexture::new(&ctx);
        let profiler = Profiler::new(&ctx);
        Ok(Self {
            ctx,
            shaders,
            voxelize,
            gradient,
            view,
            probe,
            grids: None,
            environment,
            target: None,
            profiler,
            counters: Counters::default(),
        })
    }

    /// Rebuilds every stage's pipeline from the shader library (for live shader edits). On a
    /// WGSL error the old pipelines stay and the error names the file and line.
    pub fn reload_shaders(&mut self) -> Result<()> {
        let device = &self.ctx.device;
        let voxelize = voxelize::Voxelize::new(device, &self.shaders)?;
        let gradient = gradient::Gradient::new(device, &self.shaders)?;
        let view = view::View::new(device, &self.shaders)?;
        let probe = probe::Probe::new(device, &self.shaders)?;
        (self.voxelize, self.gradient, self.view, self.probe) = (voxelize, gradient, view, probe);
        Ok(())
    }

    pub fn shaders(&self) -> &ShaderLibrary {
        &self.shaders
    }

    /// Checks a frame against what the adapter can do, before anything is allocated.
    pub fn check_limits(&self, desc: &FrameDesc) -> Result<()> {
        let l = &self.ctx.limits;
        let dims = desc.volume.dims;
        let name = &self.ctx.info.name;
        if dims.max_element() > l.max_texture_dimension_3d {
            bail!(
                "the volume needs a {}×{}×{} voxel grid, but the adapter \"{name}\" allows 3D textures of at \
                 most {} per side; lower the volume resolution (--volume or volume.resolution)",
                dims.x, dims.y, dims.z, l.max_texture_dimension_3d
            );
        }
        let grid_bytes = desc.volume.voxel_count() * 4;
        if grid_bytes > l.max_storage_buffer_binding_size.min(l.max_buffer_size) {
            bail!(
                "the volume's {}×{}×{} voxels need {} MiB per grid, more than the {} MiB the adapter \"{name}\" \
                 binds at once; lower the volume resolution (--volume or volume.resolution)",
                dims.x, dims.y, dims.z, grid_bytes >> 20,
                l.max_storage_buffer_binding_size.min(l.max_buffer_size) >> 20
            );
        }
        let (w, h) = (desc.camera.width, desc.camera.height);
        let frame_bytes = FrameTarget::bytes(w, h);
        if frame_bytes > l.max_storage_buffer_binding_size.min(l.max_buffer_size) {
            bail!(
                "a {w}×{h} image needs {} MiB of frame buffer, more than the {} MiB the adapter \"{name}\" \
                 binds at once; render smaller (--size)",
                frame_bytes >> 20,
                l.max_storage_buffer_binding_size >> 20
            );
        }
        Ok(())
    }

    /// Allocates (or reuses) what this frame needs, and rebinds stages whose resources changed.
    fn prepare(&mut self, desc: &FrameDesc) -> Result<()> {
        self.check_limits(desc)?;
        let needs_grids = self.grids.as_ref().is_none_or(|g| g.dims != desc.volume.dims);
        if needs_grids {
            self.grids = Some(Grids::new(&self.ctx, desc.volume.dims)?);
            self.counters.grid_allocations += 1;
        }
        if let Some(g) = self.grids.as_mut() {
            g.placement = Some(desc.volume.to_gpu());
        }
        if self.environment.update(&self.ctx, &desc.environment) {
            self.counters.environment_uploads += 1;
        }
        let (w, h) = (desc.camera.width, desc.camera.height);
        if self.target.as_ref().is_none_or(|t| (t.width, t.height) != (w, h)) {
            self.target = Some(FrameTarget::new(&self.ctx, w, h)?);
        }
        Ok(())
    }

    /// Stages 1–2: the frame's index-of-refraction volume, left on the GPU.
    pub fn build_volume(&mut self, desc: &FrameDesc) -> Result<()> {
        self.prepare(desc)?;
        let grids = self.grids.as_ref().expect("prepared");
        self.profiler.begin_frame();
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        let work = self.voxelize.encode(&self.ctx, &mut enc, &mut self.profiler, desc, grids)?; // fields, meshes → index_field, extinction_grid, scattering_grid
        self.gradient.encode(&self.ctx, &mut enc, &mut self.profiler, &desc.volume, grids); // index_field → ior_grid (∇n, n)
        self.profiler.resolve(&mut enc);
        self.ctx.queue.submit([enc.finish()]);
        self.counters.voxelizations += 1;
        self.counters.add_mesh_work(work);
        Ok(())
    }

    /// Builds the volume with GPU timing on and returns the milliseconds of each pass label
    /// (`refrakt bench`); empty when the adapter has no timestamp queries.
    pub fn time_volume(&mut self, desc: &FrameDesc) -> Result<Vec<(&'static str, f64)>> {
        self.profiler.enable(&self.ctx);
        self.build_volume(desc)?;
        self.profiler.collect(&self.ctx)?;
        Ok(self.profiler.last.clone())
    }

    /// The mesh solids of the last volume (tests compare them with the CPU twin).
    pub fn mesh_voxels(&self) -> &voxelize_mesh::MeshVoxelizer {
        self.voxelize.meshes()
    }

    /// Forgets every mesh's solid, so the next volume computes them all (benchmarks).
    pub fn forget_mesh_voxels(&mut self) {
        self.voxelize.meshes_mut().forget();
    }

    /// Renders one frame: voxelize → gradient → view, then reads the image back.
    pub fn frame(&mut self, desc: &FrameDesc) -> Result<Image> {
        self.prepare(desc)?;
        let grids = self.grids.as_ref().expect("prepared");
        let target = self.target.as_ref().expect("prepared");
        self.profiler.begin_frame();
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        let work = self.voxelize.encode(&self.ctx, &mut enc, &mut self.profiler, desc, grids)?; // fields, meshes → index_field, extinction_grid, scattering_grid
        self.gradient.encode(&self.ctx, &mut enc, &mut self.profiler, &desc.volume, grids); // index_field → ior_grid (∇n, n)
        self.view.encode(&self.ctx, &mut enc, &mut self.profiler, desc, grids, &self.environment, target); // ior_grid, extinction_grid, environment → frame
        target.encode_readback(&mut enc);
        self.profiler.resolve(&mut enc);
        self.ctx.queue.submit([enc.finish()]);
        self.counters.voxelizations += 1;
        self.counters.add_mesh_work(work);
        self.counters.frames += 1;
        let image = target.read(&self.ctx)?;
        self.profiler.collect(&self.ctx)?;
        let errors = self.ctx.take_uncaptured_errors();
        if !errors.is_empty() {
            bail!("the GPU reported an error while rendering (a bug in refrakt): {}", errors.join("; "));
        }
        Ok(image)
    }

    /// Traces rays through the volume built by the last [`build_volume`](Self::build_volume) or
    /// [`frame`](Self::frame) (tests, `refrakt trace`).
    pub fn probe(&mut self, rays: &[crate::gpu::types::ProbeRay], opts: &probe::ProbeOptions) -> Result<Vec<crate::gpu::types::ProbeRecord>> {
        let Some(grids) = self.grids.as_ref() else { bail!("probe needs a volume: call build_volume first") };
        self.probe.run(&self.ctx, grids, rays, opts)
    }

    /// The current grids (tests read them back to compare with the CPU twins).
    pub fn grids(&self) -> Option<&Grids> {
        self.grids.as_ref()
    }
}

/// Bind group layout entries, spelled once.
pub(crate) mod layout {
    pub fn uniform(binding: u32) -> wgpu::BindGroupLayoutEntry {
        buffer(binding, wgpu::BufferBindingType::Uniform)
    }
    pub fn storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
        buffer(binding, wgpu::BufferBindingType::Storage { read_only })
    }
    fn buffer(binding: u32, ty: wgpu::BufferBindingType) -> wgpu::BindGroupLayoutEntry {
        wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
            count: None,
        }
    }
    pub fn texture(binding: u32, dim: wgpu::TextureViewDimension) -> wgpu::BindGroupLayoutEntry {
        wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: true },
                view_dimension: dim,
                multisampled: false,
            },
            count: None,
        }
    }
    pub fn storage_texture(binding: u32, format: wgpu::TextureFormat, dim: wgpu::TextureViewDimension) -> wgpu::BindGroupLayoutEntry {
        wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::StorageTexture { access: wgpu::StorageTextureAccess::WriteOnly, format, view_dimension: dim },
            count: None,
        }
    }
    pub fn sampler(binding: u32) -> wgpu::BindGroupLayoutEntry {
        wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
            count: None,
        }
    }

    /// A compute pipeline for `stage`'s `main` with one bind group of `entries`.
    pub fn pipeline(
        device: &wgpu::Device,
        shaders: &crate::gpu::shaders::ShaderLibrary,
        stage: &str,
        entries: &[wgpu::BindGroupLayoutEntry],
    ) -> anyhow::Result<(wgpu::ComputePipeline, wgpu::BindGroupLayout)> {
        let (mut pipelines, mut layouts) = pipelines(device, shaders, stage, &[entries], &["main"])?;
        Ok((pipelines.remove(0), layouts.remove(0)))
    }

    /// Compute pipelines for several entry points of `stage`'s module, sharing one pipeline
    /// layout of bind groups `groups` (group i has the entries `groups[i]`).
    pub fn pipelines(
        device: &wgpu::Device,
        shaders: &crate::gpu::shaders::ShaderLibrary,
        stage: &str,
        groups: &[&[wgpu::BindGroupLayoutEntry]],
        entry_points: &[&str],
    ) -> anyhow::Result<(Vec<wgpu::ComputePipeline>, Vec<wgpu::BindGroupLayout>)> {
        let module = shaders.module(device, stage)?;
        let layouts: Vec<wgpu::BindGroupLayout> = groups
            .iter()
            .map(|entries| device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(stage), entries }))
            .collect();
        let bind_group_layouts: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().map(Some).collect();
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(stage),
            bind_group_layouts: &bind_group_layouts,
            immediate_size: 0,
        });
        let pipelines = entry_points
            .iter()
            .map(|entry| {
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(entry),
                    layout: Some(&pl),
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: None,
                })
            })
            .collect();
        Ok((pipelines, layouts))
    }

    /// A uniform buffer for one `T`.
    pub fn uniform_buffer<T>(device: &wgpu::Device, label: &str) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: std::mem::size_of::<T>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }
}
