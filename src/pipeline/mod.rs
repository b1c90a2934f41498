//! The GPU pipeline: one module per stage, each owning its pipeline, uniforms and bind group,
//! and [`Renderer::frame`] reading top to bottom as the frame does (DESIGN.md, "Data flow of one
//! frame"): voxelize → gradient → octree → photons → march → caustics → view.
//!
//! Resources shared between stages (grids, environment, receivers, lights, radiance grid, frame
//! target) live in [`resources`], [`receivers`] and [`lights`]; they are allocated when a size
//! changes and reused otherwise, and stages rebind only when a resource they use was reallocated.

pub mod caustics;
pub mod env_light;
pub mod gradient;
pub mod interfaces;
pub mod lights;
pub mod march;
pub mod mesh_lights;
pub mod octree;
pub mod parts;
pub mod photons;
pub mod probe;
pub mod receivers;
pub mod resources;
pub mod reuse;
pub mod rough_albedo;
pub mod specular;
pub mod timing;
pub mod view;
pub mod voxelize;
pub mod voxelize_mesh;

use anyhow::{Result, bail};
use glam::UVec3;

use crate::frame::{FrameDesc, LightDesc};
use crate::gpu::GpuContext;
use crate::gpu::shaders::ShaderLibrary;
use crate::gpu::types::{MarchParams, march_flags};
use crate::output::{Image, Layers};
use caustics::{CausticFilter, ChartMap};
use lights::LightBuffers;
use march::PhotonStats;
use parts::{FrameProgress, Part};
use receivers::Receivers;
pub use resources::MappedFrame;
use resources::{EnvironmentTexture, FrameTarget, Grids, RadianceGrid};
use reuse::{PhotonKey, Reuse, StageCache, VolumeKey};
use timing::Profiler;

/// Statistics a test or `refrakt watch` can read: how much work the frames did.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Counters {
    pub frames: u64,
    /// Index volumes built (voxelize → gradient → octree ran).
    pub volume_builds: u64,
    /// Frames that used the volume already on the GPU (see [`reuse`]).
    pub volumes_reused: u64,
    pub grid_allocations: u64,
    pub environment_uploads: u64,
    pub receiver_uploads: u64,
    /// Photon passes traced (photons → march → caustics ran).
    pub photon_traces: u64,
    /// Frames that used the radiance grid and caustic maps already on the GPU.
    pub photons_reused: u64,
    /// Times every stage's pipeline was rebuilt from edited shaders.
    pub shader_reloads: u64,
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

/// Choices about how (not what) to render: the same scene may be rendered with any of these.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub caustic_filter: CausticFilter,
    /// The photons' random seed. Fixed, so every frame of an animation uses the same photons.
    pub photon_seed: u32,
    /// Deposit into the radiance grid even when nothing scatters (tests of the deposits).
    pub always_deposit: bool,
    /// Never deposit into the radiance grid (benchmarks: the cost of the deposits alone).
    pub never_deposit: bool,
    /// How many times the mean photon flux one photon may carry before fixed-point deposits
    /// could saturate (see `march::flux_scale`). Tests lower it to force saturation.
    pub fixed_point_headroom: f32,
    /// Skip the volume and photon stages when their inputs equal the last frame's (see
    /// [`reuse`]); off, every frame runs every stage (benchmarks time each stage).
    pub reuse_unchanged: bool,
    /// Spectral photons only in this band, nm (tests); `None`: the visible spectrum.
    pub wavelength_band: Option<(f32, f32)>,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            caustic_filter: CausticFilter::default(),
            photon_seed: 0x5eed_cafe,
            always_deposit: false,
            never_deposit: false,
            fixed_point_headroom: march::MAX_RELATIVE_FLUX,
            reuse_unchanged: true,
            wavelength_band: None,
        }
    }
}

/// Most frames [`Renderer::submit`] may have in flight: each one in flight holds a staging buffer
/// of the whole frame (80 bytes a pixel).
pub const MAX_FRAMES_IN_FLIGHT: usize = 4;

/// Frames read back whose conversion into layers may wait on other threads
/// ([`Renderer::finish_mapped`]), beyond the frames in flight.
pub const HANDED_OFF_FRAMES: usize = 3;

/// Most photons one frame traces (48 bytes each on the GPU).
pub const MAX_PHOTONS: u32 = 1 << 26;

pub struct Renderer {
    pub ctx: GpuContext,
    shaders: ShaderLibrary,
    voxelize: voxelize::Voxelize,
    gradient: gradient::Gradient,
    octree: octree::Octree,
    photons: photons::Photons,
    march: march::March,
    caustics: caustics::Caustics,
    view: view::View,
    probe: probe::Probe,
    grids: Option<Grids>,
    environment: EnvironmentTexture,
    receivers: Receivers,
    /// The glowing meshes, kept while they do not change.
    glowing: mesh_lights::GlowingMeshes,
    lights: LightBuffers,
    radiance: Option<RadianceGrid>,
    target: Option<FrameTarget>,
    pub settings: RenderSettings,
    /// Which layers frames bring back (`Layers::Beauty` when only a PNG or a preview is made).
    /// Not a [`RenderSettings`]: it changes what is read, not what is rendered.
    pub layers: Layers,
    /// Progressive refinement (`refrakt serve` while the view is still): pass k > 0 traces
    /// camera samples k·samples … (k+1)·samples − 1 and adds their mean to the planes the pass
    /// before left, so after K passes the planes hold K times the mean of K·samples samples —
    /// the caller divides by K. Pass k must follow pass k − 1 of the same frame description;
    /// 0 (the default) renders a frame of its own.
    pub refinement: u32,
    /// Motion blur (`render::motion`): instant k of a frame's n, as (k, n). Instant k traces
    /// camera samples k·samples … (k+1)·samples − 1 and adds them, over all n·samples, to the
    /// planes instant k − 1 left, so after the last the planes hold the frame's mean. Instant k
    /// must follow instant k − 1 of the same frame; `None` (the default): a frame of one instant.
    pub instant: Option<(u32, u32)>,
    pub profiler: Profiler,
    pub counters: Counters,
    stats: Option<PhotonStats>,
    view_steps: u64,
    /// Keys of the volume and photon results the GPU holds.
    cache: StageCache,
    /// The readback slot the next submitted frame uses, and which slots hold a frame in flight.
    next_slot: usize,
    pending: [bool; MAX_FRAMES_IN_FLIGHT],
    /// Readback slots in use: frames that may be submitted before the first is finished.
    frames_in_flight: usize,
}

/// A frame in flight: which readback slot it uses, what it took from the cache, and the
/// march's uniforms if it traced photons (to turn its statistics into watts).
#[must_use = "a submitted frame must be finished to read it back"]
pub struct Ticket {
    slot: usize,
    /// The frame target's staging buffer its image comes home in.
    readback: usize,
    photons: Option<crate::gpu::types::MarchParams>,
    /// The layers its readback brings back.
    layers: Layers,
    pub reused: Reuse,
    /// Its parts' submissions, to wait for them one by one ([`Renderer::wait`]).
    submitted: parts::Submitted,
}

/// Every stage's pipeline, built from one shader library.
struct Stages {
    voxelize: voxelize::Voxelize,
    gradient: gradient::Gradient,
    octree: octree::Octree,
    photons: photons::Photons,
    march: march::March,
    caustics: caustics::Caustics,
    view: view::View,
    probe: probe::Probe,
}

impl Stages {
    fn new(device: &wgpu::Device, shaders: &ShaderLibrary) -> Result<Self> {
        Ok(Self {
            voxelize: voxelize::Voxelize::new(device, shaders)?,
            gradient: gradient::Gradient::new(device, shaders)?,
            octree: octree::Octree::new(device, shaders)?,
            photons: photons::Photons::new(device, shaders)?,
            march: march::March::new(device, shaders)?,
            caustics: caustics::Caustics::new(device, shaders)?,
            view: view::View::new(device, shaders)?,
            probe: probe::Probe::new(device, shaders)?,
        })
    }
}

impl Renderer {
    pub fn new(ctx: GpuContext) -> Result<Self> {
        Self::with_shaders(ctx, ShaderLibrary::Embedded)
    }

    pub fn with_shaders(ctx: GpuContext, shaders: ShaderLibrary) -> Result<Self> {
        let s = Stages::new(&ctx.device, &shaders)?;
        Ok(Self::with_stages(ctx, shaders, s))
    }

    /// A renderer on `shaders`, or, when they do not compile, on the embedded ones (returned
    /// with the error): `refrakt watch` starts anyway, and `shaders` stay the library that
    /// [`reload_shaders`](Self::reload_shaders) reads, so saving a fix switches to them.
    pub fn with_shaders_or_embedded(ctx: GpuContext, shaders: ShaderLibrary) -> Result<(Self, Option<anyhow::Error>)> {
        let (s, failed) = match Stages::new(&ctx.device, &shaders) {
            Ok(s) => (s, None),
            Err(e) => (Stages::new(&ctx.device, &ShaderLibrary::Embedded)?, Some(e)),
        };
        Ok((Self::with_stages(ctx, shaders, s), failed))
    }

    fn with_stages(ctx: GpuContext, shaders: ShaderLibrary, s: Stages) -> Self {
        let environment = EnvironmentTexture::new(&ctx);
        let profiler = Profiler::new(&ctx);
        let lights = LightBuffers::new(&ctx.device);
        let receivers = Receivers::new(&ctx.device);
        Self {
            voxelize: s.voxelize,
            gradient: s.gradient,
            octree: s.octree,
            photons: s.photons,
            march: s.march,
            caustics: s.caustics,
            view: s.view,
            probe: s.probe,
            ctx,
            shaders,
            grids: None,
            environment,
            receivers,
            glowing: Default::default(),
            lights,
            radiance: None,
            target: None,
            settings: RenderSettings::default(),
            layers: Layers::All,
            refinement: 0,
            instant: None,
            profiler,
            counters: Counters::default(),
            stats: None,
            view_steps: 0,
            cache: StageCache::default(),
            next_slot: 0,
            pending: [false; MAX_FRAMES_IN_FLIGHT],
            frames_in_flight: 2,
        }
    }

    /// How many frames may be submitted before the first of them is finished (1 to
    /// [`MAX_FRAMES_IN_FLIGHT`]; 2 by default). What frames show does not depend on it: the GPU
    /// runs them in the order submitted, and each has readback buffers of its own.
    pub fn set_frames_in_flight(&mut self, frames: usize) -> Result<()> {
        if !(1..=MAX_FRAMES_IN_FLIGHT).contains(&frames) {
            bail!("frames in flight must be 1 to {MAX_FRAMES_IN_FLIGHT}, not {frames}");
        }
        if self.pending.iter().any(|&p| p) {
            bail!("internal: the frames in flight change while frames are in flight; finish them first");
        }
        (self.frames_in_flight, self.next_slot) = (frames, 0);
        Ok(())
    }

    pub fn frames_in_flight(&self) -> usize {
        self.frames_in_flight
    }

    /// Rebuilds every stage's pipeline from the shader library (for live shader edits). On a
    /// WGSL error the old pipelines stay and the error names the file and line. Results of
    /// the old shaders are not reused: the next frame runs every stage.
    pub fn reload_shaders(&mut self) -> Result<()> {
        let s = Stages::new(&self.ctx.device, &self.shaders)?;
        (self.voxelize, self.gradient, self.octree, self.photons) = (s.voxelize, s.gradient, s.octree, s.photons);
        (self.march, self.caustics, self.view, self.probe) = (s.march, s.caustics, s.view, s.probe);
        self.cache.clear();
        self.counters.shader_reloads += 1;
        Ok(())
    }

    pub fn shaders(&self) -> &ShaderLibrary {
        &self.shaders
    }

    /// Checks a frame against what the adapter can do, before anything is allocated.
    pub fn check_limits(&self, desc: &FrameDesc) -> Result<()> {
        self.check_grid_limits(desc)?;
        let name = &self.ctx.info.name;
        let binding = self.binding_limit();
        // The largest buffers bound at once: the octree's and, with a scattering medium, the
        // radiance grid's deposits.
        let deposits = if needs_scattering(desc) { RadianceGrid::deposit_binding_bytes(desc.volume.dims) } else { 0 };
        self.check_volume_binding(desc, Grids::largest_binding(desc.volume.dims).max(deposits))?;
        let (w, h) = (desc.camera.width, desc.camera.height);
        // Each of the frame's planes is bound on its own; the six share one buffer.
        let (plane, frame) = (FrameTarget::plane_bytes(w, h), FrameTarget::bytes(&self.ctx, w, h));
        if plane > binding || frame > self.ctx.limits.max_buffer_size {
            bail!(
                "a {w}×{h} image needs {} MiB of frame buffer ({} MiB per layer), more than the adapter \"{name}\" \
                 allows ({} MiB per buffer, {} MiB per binding); render smaller (--size)",
                frame >> 20,
                plane >> 20,
                self.ctx.limits.max_buffer_size >> 20,
                binding >> 20
            );
        }
        // Caustic and bounce photons share one buffer.
        let photons = desc.photons as u64 + if desc.traces_bounces() { desc.bounce_photons as u64 } else { 0 };
        if photons > MAX_PHOTONS as u64 {
            bail!(
                "photons = {} and bounce_photons = {} are more than refrakt traces per frame ({MAX_PHOTONS} together); lower the photon budget",
                desc.photons,
                desc.bounce_photons
            );
        }
        let photon_bytes = std::mem::size_of::<crate::gpu::types::Photon>() as u64;
        if photons * photon_bytes > binding {
            bail!(
                "{photons} photons (photons and bounce_photons) need {} MiB in one buffer ({photon_bytes} B each), more than the {} MiB the adapter \"{}\" \
                 binds at once; lower the photon budget (--photons, photons or bounce_photons) to at most {} in all",
                (photons * photon_bytes) >> 20,
                binding >> 20,
                self.ctx.info.name,
                binding / photon_bytes
            );
        }
        Ok(())
    }

    /// The most bytes one buffer binding may hold on this adapter.
    fn binding_limit(&self) -> u64 {
        let l = &self.ctx.limits;
        l.max_storage_buffer_binding_size.min(l.max_buffer_size)
    }

    /// Checks what the voxel grids themselves need: 3D textures of the volume's size (and the
    /// texel or two `frame::texture_dims` adds) and its per-voxel index buffer in one binding.
    pub fn check_grid_limits(&self, desc: &FrameDesc) -> Result<()> {
        let l = &self.ctx.limits;
        let dims = desc.volume.dims;
        let name = &self.ctx.info.name;
        let side = crate::frame::texture_dims(dims).max_element();
        if side > l.max_texture_dimension_3d {
            bail!(
                "the volume needs a {}×{}×{} voxel grid (3D textures of {side} per side), but the adapter \"{name}\" \
                 allows at most {} per side; lower the volume resolution (--volume or volume.resolution)",
                dims.x, dims.y, dims.z, l.max_texture_dimension_3d
            );
        }
        self.check_volume_binding(desc, desc.volume.voxel_count() * 4)
    }

    /// Checks that a buffer of `bytes` for the frame's volume fits in one binding.
    fn check_volume_binding(&self, desc: &FrameDesc, bytes: u64) -> Result<()> {
        let (dims, binding) = (desc.volume.dims, self.binding_limit());
        if bytes > binding {
            bail!(
                "the volume's {}×{}×{} voxels need {} MiB in one buffer, more than the {} MiB the adapter \"{}\" \
                 binds at once; lower the volume resolution (--volume or volume.resolution)",
                dims.x, dims.y, dims.z, bytes >> 20, binding >> 20, self.ctx.info.name
            );
        }
        Ok(())
    }

    /// The voxel grids of this frame's size, allocated when the size changed, placed where the
    /// frame's volume is.
    fn ensure_grids(&mut self, desc: &FrameDesc) -> Result<()> {
        if self.grids.as_ref().is_none_or(|g| g.dims != desc.volume.dims) {
            self.grids = Some(Grids::new(&self.ctx, desc.volume.dims)?);
            self.counters.grid_allocations += 1;
        }
        if let Some(g) = self.grids.as_mut() {
            g.place(desc.volume.to_gpu());
        }
        Ok(())
    }

    /// Allocates (or reuses) what this frame needs.
    fn prepare(&mut self, desc: &FrameDesc) -> Result<()> {
        self.check_limits(desc)?;
        self.ensure_grids(desc)?;
        if self.environment.update(&self.ctx, &desc.environment) {
            self.counters.environment_uploads += 1;
        }
        self.environment.update_light(&self.ctx, &desc.environment);
        if desc.receivers.iter().any(|r| r.diffuse.is_pbr()) {
            self.environment.update_specular(&self.ctx, &desc.environment);
        }
        if self.receivers.update(&self.ctx, desc) {
            self.counters.receiver_uploads += 1;
        }
        let bvh = &self.receivers.layout.bvh;
        let surfaces = bvh.nodes.first().filter(|_| !bvh.triangles.is_empty()).map(|n| (glam::Vec3::from(n.min), glam::Vec3::from(n.max)));
        let reach = lights::scene_reach(&desc.volume, surfaces);
        // The scene's lights, then its glowing meshes (receivers and glass that emit light).
        let triangle_size = std::mem::size_of::<crate::gpu::types::LightTriangle>() as u64;
        let max_triangles = (self.binding_limit() / triangle_size) as usize;
        if let Err(count) = self.glowing.update(&desc.receivers, &desc.meshes, max_triangles) {
            bail!(
                "the glowing meshes (emissive materials) have {count} triangles in all, and {} holds at most \
                 {max_triangles} in one buffer: simplify them or turn their emission off",
                self.ctx.info.name,
            );
        }
        let all_lights: Vec<LightDesc> = desc.lights.iter().chain(&self.glowing.built.lights).cloned().collect();
        let media: Vec<[u32; 2]> =
            all_lights.iter().map(|l| interfaces::media_at(desc, lights::photon_start(l, &desc.volume))).collect();
        // The environment's caustic photons matter only where glass or a medium bends or
        // scatters them (its direct light is the receivers' shadow rays).
        let env = lights::EnvEmission {
            integral: self.environment.light.integral * env_light::scale(&desc.environment),
            caustics: !desc.fields.is_empty() || !desc.meshes.is_empty() || desc.fog.is_some(),
        };
        let new_triangles = if self.glowing.changed { &self.glowing.built.triangles[..] } else { &[] };
        self.lights.update(&self.ctx, &all_lights, new_triangles, &media, &desc.volume, env, reach, desc.traces_bounces());
        let radiance_dims = if self.deposits(desc) { desc.volume.dims } else { UVec3::ONE };
        if self.radiance.as_ref().is_none_or(|r| r.dims != radiance_dims) {
            self.radiance = Some(RadianceGrid::new(&self.ctx, radiance_dims)?);
        }
        let (w, h) = (desc.camera.width, desc.camera.height);
        if self.target.as_ref().is_none_or(|t| (t.width, t.height) != (w, h)) {
            self.target = Some(FrameTarget::new(&self.ctx, w, h)?);
        }
        Ok(())
    }

    /// Whether photons have anything to do this frame: a budget, a light that emits them, and
    /// something they can show (caustics on receivers, or light in a scattering medium).
    fn traces_photons(&self, desc: &FrameDesc) -> bool {
        let budget = self.photon_budget(desc);
        budget.total() > 0
            && self.lights.emitter_count + self.lights.bounce_emitter_count > 0
            && (!desc.receivers.is_empty() || needs_scattering(desc) || self.settings.always_deposit)
    }

    /// The frame's photons: the caustic budget where a light has a caustic emitter, the bounce
    /// budget where one has a bounce emitter.
    fn photon_budget(&self, desc: &FrameDesc) -> photons::Budget {
        photons::Budget {
            caustic: if self.lights.emitter_count > 0 { desc.photons } else { 0 },
            bounce: if self.lights.bounce_emitter_count > 0 { desc.bounce_photons } else { 0 },
        }
    }

    fn deposits(&self, desc: &FrameDesc) -> bool {
        (needs_scattering(desc) || self.settings.always_deposit) && !self.settings.never_deposit
    }

    /// Stages 1–3: the frame's index-of-refraction volume and its octree, left on the GPU.
    pub fn build_volume(&mut self, desc: &FrameDesc) -> Result<()> {
        self.prepare(desc)?;
        let grids = self.grids.as_ref().expect("prepared");
        self.profiler.begin_frame();
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        let work = self.voxelize.encode(&self.ctx, &mut enc, &mut self.profiler, desc, grids)?; // fields, meshes → index_field, extinction_grid, scattering_grid
        self.gradient.encode(&self.ctx, &mut enc, &mut self.profiler, &desc.volume, grids); // index_field → ior_grid (∇n, n)
        self.octree.encode(&self.ctx, &mut enc, &mut self.profiler, grids); // index_field, extinction_grid → octree
        // Timings go through the next readback slot (this call waits for nothing in flight).
        self.profiler.resolve(&mut enc, self.next_slot);
        self.ctx.queue.submit([enc.finish()]);
        self.counters.volume_builds += 1;
        self.counters.add_mesh_work(work);
        self.cache.built_volume(VolumeKey::of(desc, grids.generation));
        Ok(())
    }

    /// Stage 1 alone with GPU timing on: the milliseconds of each pass label (`refrakt bench`'s
    /// voxelize figures); empty when the adapter has no timestamp queries. It binds only the
    /// voxel grids, so it also runs on volumes whose octree the adapter cannot bind (256³ on
    /// lavapipe); what it leaves on the GPU is not a whole volume, so nothing reuses it.
    pub fn time_voxelize(&mut self, desc: &FrameDesc) -> Result<Vec<(&'static str, f64)>> {
        self.check_grid_limits(desc)?;
        self.ensure_grids(desc)?;
        self.profiler.enable(&self.ctx);
        self.profiler.begin_frame();
        let grids = self.grids.as_ref().expect("allocated");
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        let work = self.voxelize.encode(&self.ctx, &mut enc, &mut self.profiler, desc, grids)?; // fields, meshes → index_field, extinction_grid, scattering_grid
        self.profiler.resolve(&mut enc, self.next_slot);
        self.ctx.queue.submit([enc.finish()]);
        self.counters.add_mesh_work(work);
        self.cache.clear();
        self.profiler.collect(&self.ctx, self.next_slot)?;
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

    /// Renders one frame, top to bottom, then reads the image back.
    pub fn frame(&mut self, desc: &FrameDesc) -> Result<Image> {
        let ticket = self.submit(desc)?;
        self.finish(ticket)
    }

    /// Encodes and submits one frame, top to bottom, without waiting for it. Its results come
    /// back through one of [`frames_in_flight`](Self::set_frames_in_flight) readback slots, so
    /// the caller can submit frames k+1, k+2, … (after running `update` and evaluating the scene
    /// for each) before it [`finish`](Self::finish)es frame k. Frames are finished in the order
    /// they were submitted.
    pub fn submit(&mut self, desc: &FrameDesc) -> Result<Ticket> {
        let slot = self.next_slot;
        if self.pending[slot] {
            bail!("internal: {} frame(s) are already in flight; finish one before submitting another", self.frames_in_flight);
        }
        let size_changes = self.target.as_ref().is_some_and(|t| (t.width, t.height) != (desc.camera.width, desc.camera.height));
        if size_changes && self.pending.iter().any(|&p| p) {
            bail!("internal: the image size changes while a frame is in flight; finish it first");
        }
        self.prepare(desc)?;
        let readback = self.target.as_mut().expect("prepared").take_staging(&self.ctx, self.frames_in_flight + HANDED_OFF_FRAMES);
        let photons = self.traces_photons(desc);
        let deposit = photons && self.deposits(desc);
        // Photon flux is kept relative to the mean photon flux (fixed point): the lights' power
        // toward the volume over the budget (and for bounced light, their whole power over its).
        let budget = self.photon_budget(desc);
        let flux_unit = (self.lights.raster_power / budget.caustic.max(1) as f32).max(1e-30);
        let bounce_flux_unit = (self.lights.bounce_raster_power / budget.bounce.max(1) as f32).max(1e-30);
        let (grids, receivers, radiance, target) = (
            self.grids.as_ref().expect("prepared"),
            &self.receivers,
            self.radiance.as_ref().expect("prepared"),
            self.target.as_ref().expect("prepared"),
        );
        let base = MarchParams {
            seed: self.settings.photon_seed,
            indirect_chart_base: receivers::indirect_chart_base(self.receivers.layout.charts.len()),
            ..march::March::params(grids, budget, flux_unit, (bounce_flux_unit, desc.bounces), deposit, anisotropic_scattering(desc), desc.receivers.len() as u32, self.settings.fixed_point_headroom) };
        let march_params = march::March::with_spectrum(base, desc.spectrum(), self.settings.wavelength_band);
        let (volume_key, photon_key) = self.stage_keys(desc);
        let mut reused = self.reuse_of(&volume_key, &photon_key);
        reused.photons &= photons;
        self.profiler.begin_frame();
        let submitted_at = std::time::Instant::now();
        let mut parts = Vec::new();
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        if !reused.volume {
            let work = self.voxelize.encode(&self.ctx, &mut enc, &mut self.profiler, desc, grids).inspect_err(|_| target.give_back(readback))?; // fields, meshes → index_field, extinction_grid, scattering_grid
            self.gradient.encode(&self.ctx, &mut enc, &mut self.profiler, &desc.volume, grids); // index_field → ior_grid (∇n, n)
            self.octree.encode(&self.ctx, &mut enc, &mut self.profiler, grids); // index_field, extinction_grid → octree
            self.counters.volume_builds += 1;
            self.counters.add_mesh_work(work);
            parts.push((Part::Volume, self.submit_part(&mut enc)));
        }
        let trace = photons && !reused.photons;
        if trace {
            let (seed, scattering) = (self.settings.photon_seed, needs_scattering(desc));
            let spectral = march_params.flags & march_flags::SPECTRAL != 0; // wavelengths, XYZ deposits
            let environment = (&self.environment, view::env_params(desc));
            self.photons.encode(&self.ctx, &mut enc, &mut self.profiler, grids, &self.lights, environment, budget, seed, scattering, spectral); // lights, environment, octree → photons
            self.march.encode(&self.ctx, &mut enc, &mut self.profiler, &march_params, grids, &self.photons, receivers, radiance); // photons, grids, receivers → radiance, caustic atlas
            let filter = self.settings.caustic_filter;
            let caustic_unit = flux_unit / march_params.flux_scale;
            self.caustics.encode(&self.ctx, &mut enc, &mut self.profiler, receivers, ChartMap::Caustic, filter, caustic_unit, spectral); // caustic atlas → caustic irradiance
            if budget.bounce > 0 {
                let indirect_unit = bounce_flux_unit / march_params.bounce_flux_scale;
                self.caustics.encode(&self.ctx, &mut enc, &mut self.profiler, receivers, ChartMap::Indirect, filter.for_indirect(), indirect_unit, spectral); // indirect atlas → indirect irradiance
            }
            self.march.encode_stats_readback(&mut enc, slot);
            self.counters.photon_traces += 1;
            parts.push((Part::Photons, self.submit_part(&mut enc)));
        }
        let samples = desc.samples.max(1);
        let (instant, instants) = self.instant.unwrap_or((0, 1));
        let inputs = view::ViewInputs {
            grids,
            environment: &self.environment,
            receivers,
            lights: &self.lights,
            radiance,
            target,
            caustics: photons,
            indirect: photons && budget.bounce > 0,
            scattering: deposit,
            sample_first: samples * (instant + self.refinement),
            frame_samples: samples * instants,
        };
        self.view.encode(&self.ctx, &mut enc, &mut self.profiler, desc, &inputs); // grids, octree, receivers, lights, radiance, environment → frame
        target.encode_readback(&mut enc, readback, self.layers);
        self.view.encode_steps_readback(&mut enc, slot);
        self.profiler.resolve(&mut enc, slot);
        parts.push((Part::View, self.ctx.queue.submit([enc.finish()])));
        self.counters.volumes_reused += reused.volume as u64;
        self.counters.photons_reused += reused.photons as u64;
        self.counters.frames += 1;
        if !reused.volume {
            self.cache.built_volume(volume_key);
        }
        if trace {
            self.cache.traced_photons(photon_key);
        }
        self.pending[slot] = true;
        self.next_slot = (slot + 1) % self.frames_in_flight;
        let submitted = parts::Submitted { parts, photons: if trace { desc.photons } else { 0 }, at: submitted_at };
        Ok(Ticket { slot, readback, photons: trace.then_some(march_params), layers: self.layers, reused, submitted })
    }

    /// Submits what `enc` holds as one part of the frame and starts a new encoder for the next.
    fn submit_part(&self, enc: &mut wgpu::CommandEncoder) -> wgpu::SubmissionIndex {
        let full = std::mem::replace(enc, self.ctx.device.create_command_encoder(&Default::default()));
        self.ctx.queue.submit([full.finish()])
    }

    /// Waits for a submitted frame part by part, telling `report` which part the GPU is on
    /// (progress within a frame); [`finish`](Self::finish) then reads it back at once.
    /// Whether the GPU has finished `ticket`'s frame, so [`finish`](Self::finish) would not wait.
    pub fn is_finished(&self, ticket: &Ticket) -> Result<bool> {
        ticket.submitted.is_done(&self.ctx.device)
    }

    pub fn wait(&self, ticket: &Ticket, report: &mut dyn FnMut(&FrameProgress)) -> Result<()> {
        ticket.submitted.wait(&self.ctx.device, report)
    }

    /// The keys of this frame's volume and photon results, as the resources stand now.
    fn stage_keys(&self, desc: &FrameDesc) -> (VolumeKey, PhotonKey) {
        let grids = self.grids.as_ref().map_or(0, |g| g.generation);
        let radiance = self.radiance.as_ref().map_or(0, |r| r.generation);
        let volume = VolumeKey::of(desc, grids);
        let photons = PhotonKey::of(desc, [self.receivers.generation, radiance], &self.settings);
        (volume, photons)
    }

    fn reuse_of(&self, volume: &VolumeKey, photons: &PhotonKey) -> Reuse {
        if !self.settings.reuse_unchanged {
            return Reuse::default();
        }
        self.cache.reuse(volume, photons)
    }

    /// What a frame of `desc` submitted now would take from the cache (before any resource
    /// it needs is reallocated: a frame that changes the volume's size reuses nothing anyway).
    /// `photons` is true also when the frame traces none.
    pub fn would_reuse(&self, desc: &FrameDesc) -> Reuse {
        let (volume, photons) = self.stage_keys(desc);
        let mut reused = self.reuse_of(&volume, &photons);
        reused.photons |= reused.volume && !self.traces_photons(desc);
        reused
    }

    /// Waits for a submitted frame and reads its image, statistics and timings back.
    pub fn finish(&mut self, ticket: Ticket) -> Result<Image> {
        Ok(self.finish_mapped(ticket)?.image())
    }

    /// Waits for a submitted frame and reads its statistics and timings back, and its image as
    /// far as mapping it: [`MappedFrame::image`] converts it into layers on whichever thread
    /// calls it (`refrakt render --frames` does it on the frame writers), while this thread
    /// goes on submitting frames. Up to [`HANDED_OFF_FRAMES`] frames may wait so, each holding
    /// a staging buffer of the frame's size, before `submit` waits for one to be converted.
    pub fn finish_mapped(&mut self, ticket: Ticket) -> Result<MappedFrame> {
        let frame = self.target.as_ref().expect("a frame was submitted").map(&self.ctx, ticket.readback, ticket.layers)?;
        self.finish_results(ticket)?;
        Ok(frame)
    }

    /// Waits for a submitted frame and reads back its statistics and timings but not its image
    /// (`refrakt bench` times frames this way, back to back, so the GPU is never left waiting
    /// on the host's readback and its clocks stay up).
    pub fn finish_without_image(&mut self, ticket: Ticket) -> Result<()> {
        self.target.as_ref().expect("a frame was submitted").give_back(ticket.readback);
        self.finish_results(ticket)
    }

    /// The frame's statistics, step counts and timings.
    fn finish_results(&mut self, ticket: Ticket) -> Result<()> {
        let slot = ticket.slot;
        self.pending[slot] = false;
        self.stats = match &ticket.photons {
            Some(params) => Some(self.march.read_stats(&self.ctx, params, slot)?),
            // The photons of the frame whose results were reused: its statistics stand.
            None if ticket.reused.photons => self.stats,
            None => None,
        };
        self.view_steps = self.view.read_steps(&self.ctx, slot)?;
        if let Some(s) = self.stats.filter(|s| s.saturated > 0) {
            tracing::warn!(
                "{} photon deposits saturated the fixed-point range this frame; the caustic maps and the \
                 radiance grid are clipped there (a bug in refrakt's scaling — please report the scene)",
                s.saturated
            );
        }
        self.profiler.collect(&self.ctx, slot)?;
        let errors = self.ctx.take_uncaptured_errors();
        if !errors.is_empty() {
            bail!("the GPU reported an error while rendering (a bug in refrakt): {}", errors.join("; "));
        }
        Ok(())
    }

    /// Ray-equation steps the view pass took in the last finished frame.
    pub fn view_steps(&self) -> u64 {
        self.view_steps
    }

    /// What `desc`'s light costs the photon and view stages (after a frame of it, so the
    /// environment's table is built): the photons traced per population, and the shadow rays a
    /// receiver hit casts toward the environment per camera sample (0 for a dark one).
    pub fn light_work(&self, desc: &FrameDesc) -> (photons::Budget, u32) {
        let budget = if self.traces_photons(desc) { self.photon_budget(desc) } else { photons::Budget::default() };
        (budget, 2 * view::env_pairs(desc, &self.environment))
    }

    /// Photon statistics of the last frame that traced photons.
    pub fn photon_stats(&self) -> Option<PhotonStats> {
        self.stats
    }

    /// Traces rays through the volume built by the last [`build_volume`](Self::build_volume) or
    /// [`frame`](Self::frame) (tests, `refrakt trace`).
    pub fn probe(&mut self, rays: &[crate::gpu::types::ProbeRay], opts: &probe::ProbeOptions) -> Result<Vec<crate::gpu::types::ProbeRecord>> {
        let Some(grids) = self.grids.as_ref() else { bail!("probe needs a volume: call build_volume first") };
        self.probe.trace(&self.ctx, grids, &self.receivers, rays, opts)
    }

    /// The octree's straight step at each ray's origin (tests): see [`probe::Probe::octree_steps`].
    pub fn probe_octree(&mut self, rays: &[crate::gpu::types::ProbeRay], step: f32, max_step: f32) -> Result<Vec<[f32; 4]>> {
        let Some(grids) = self.grids.as_ref() else { bail!("probe needs a volume: call build_volume first") };
        self.probe.octree_steps(&self.ctx, grids, &self.receivers, rays, step, max_step)
    }

    /// The cells segments cross, as the photon deposits traverse them (tests):
    /// see [`probe::Probe::dda_cells`].
    pub fn probe_dda(&mut self, segments: &[crate::gpu::types::ProbeRay], max_cells: u32) -> Result<Vec<[f32; 4]>> {
        let Some(grids) = self.grids.as_ref() else { bail!("probe needs a volume: call build_volume first") };
        self.probe.dda_cells(&self.ctx, grids, &self.receivers, segments, max_cells)
    }

    /// The current grids (tests read them back to compare with the CPU twins).
    pub fn grids(&self) -> Option<&Grids> {
        self.grids.as_ref()
    }

    /// The current receivers and caustic maps (tests read them back).
    pub fn receivers(&self) -> Option<&Receivers> {
        Some(&self.receivers)
    }

    /// The current radiance grid (tests read its deposits back).
    pub fn radiance(&self) -> Option<&RadianceGrid> {
        self.radiance.as_ref()
    }
}

/// The scattering coefficient and phase anisotropy g of every medium in the frame: the fog, then
/// each field and mesh.
fn scattering_media(desc: &FrameDesc) -> impl Iterator<Item = (glam::Vec3, f32)> + '_ {
    let fog = desc.fog.iter().map(|f| (f.scattering, f.g));
    let fields = desc.fields.iter().map(|f| (f.glass.scattering, f.glass.g));
    fog.chain(fields).chain(desc.meshes.iter().map(|m| (m.glass.scattering, m.glass.g)))
}

/// Whether anything in the frame scatters light (fog, or a medium with a scattering color).
pub fn needs_scattering(desc: &FrameDesc) -> bool {
    scattering_media(desc).any(|(sigma, _)| sigma.max_element() > 0.0)
}

/// Whether a scattering medium in the frame has a non-isotropic phase function (g ≠ 0), so the
/// view pass needs the photons' mean direction per voxel.
pub fn anisotropic_scattering(desc: &FrameDesc) -> bool {
    scattering_media(desc).any(|(sigma, g)| sigma.max_element() > 0.0 && g != 0.0)
}

/// Bind group layout entries, spelled once.
pub(crate) mod layout {
    pub fn uniform(binding: u32) -> wgpu::BindGroupLayoutEntry {
        buffer(binding, wgpu::BufferBindingType::Uniform)
    }
    pub fn storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
        buffer(binding, wgpu::BufferBindingType::Storage { read_only })
    }
    /// A uniform binding as the read-only storage binding `ShaderLibrary::module` declares it
    /// on such devices (`gpu::uniforms_as_storage`); other bindings as they are.
    fn uniform_as_storage(mut e: wgpu::BindGroupLayoutEntry) -> wgpu::BindGroupLayoutEntry {
        if let wgpu::BindingType::Buffer { ty: ty @ wgpu::BufferBindingType::Uniform, .. } = &mut e.ty {
            *ty = wgpu::BufferBindingType::Storage { read_only: true };
        }
        e
    }

    /// What a buffer of parameters is made for: bound as a uniform, or as a read-only storage
    /// buffer on a device that binds uniforms so (`gpu::uniforms_as_storage`).
    pub const PARAMS: wgpu::BufferUsages = wgpu::BufferUsages::UNIFORM.union(wgpu::BufferUsages::STORAGE);

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
    /// Workgroups for `count` threads of a 1D kernel with `size` threads per group, as a 2D grid
    /// when there are more than a dispatch dimension holds (the kernel folds id.y back in).
    pub fn workgroups_1d(count: u32, size: u32) -> (u32, u32) {
        let groups = count.div_ceil(size).max(1);
        let x = groups.min(65_535);
        (x, groups.div_ceil(x))
    }

    /// A bind group entry for the whole of `buffer`.
    pub fn bind(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
        wgpu::BindGroupEntry { binding, resource: buffer.as_entire_binding() }
    }
    pub fn texture_view(t: &wgpu::TextureView) -> wgpu::BindingResource<'_> {
        wgpu::BindingResource::TextureView(t)
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
        pipeline_entry(device, shaders, stage, "main", entries)
    }

    /// A compute pipeline for entry point `entry` of `stage` with one bind group of `entries`.
    pub fn pipeline_entry(
        device: &wgpu::Device,
        shaders: &crate::gpu::shaders::ShaderLibrary,
        stage: &str,
        entry: &str,
        entries: &[wgpu::BindGroupLayoutEntry],
    ) -> anyhow::Result<(wgpu::ComputePipeline, wgpu::BindGroupLayout)> {
        let (mut pipelines, mut layouts) = pipelines(device, shaders, stage, &[entries], &[entry])?;
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
        let parts = StageModule::new(device, shaders, stage, groups)?;
        let pipelines = entry_points.iter().map(|entry| parts.pipeline(device, entry)).collect();
        Ok((pipelines, parts.layouts))
    }

    /// A stage's compiled module and its pipeline layout of bind groups, kept where a pipeline
    /// of another entry point is made only when first needed (each costs a driver compile).
    pub struct StageModule {
        module: wgpu::ShaderModule,
        layout: wgpu::PipelineLayout,
        pub layouts: Vec<wgpu::BindGroupLayout>,
    }

    impl StageModule {
        pub fn new(
            device: &wgpu::Device,
            shaders: &crate::gpu::shaders::ShaderLibrary,
            stage: &str,
            groups: &[&[wgpu::BindGroupLayoutEntry]],
        ) -> anyhow::Result<Self> {
            // One decision for the module's declarations and the layouts' entries.
            let as_storage = crate::gpu::uniforms_as_storage(&device.adapter_info());
            let module = shaders.module(device, stage, as_storage)?;
            let layouts: Vec<wgpu::BindGroupLayout> = groups
                .iter()
                .map(|entries| {
                    let entries: Vec<_> = entries.iter().map(|e| if as_storage { uniform_as_storage(*e) } else { *e }).collect();
                    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(stage), entries: &entries })
                })
                .collect();
            let bind_group_layouts: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().map(Some).collect();
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(stage),
                bind_group_layouts: &bind_group_layouts,
                immediate_size: 0,
            });
            Ok(Self { module, layout, layouts })
        }

        /// The compute pipeline of entry point `entry`.
        pub fn pipeline(&self, device: &wgpu::Device, entry: &str) -> wgpu::ComputePipeline {
            // The driver's share at creation (on lavapipe its NIR passes; LLVM compiles at the
            // pipeline's first dispatch), a line at -vv.
            let start = std::time::Instant::now();
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&self.layout),
                module: &self.module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            });
            tracing::debug!("created the {entry} pipeline in {:.2} s", start.elapsed().as_secs_f64());
            pipeline
        }
    }

    /// A uniform buffer for one `T`.
    pub fn uniform_buffer<T>(device: &wgpu::Device, label: &str) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: std::mem::size_of::<T>() as u64,
            usage: PARAMS | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }
}
