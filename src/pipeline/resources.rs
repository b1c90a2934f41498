//! GPU resources shared between stages: the voxel grids, the environment map and the frame
//! target. Each carries a generation number so stages rebuild a bind group only when the
//! resource behind it was reallocated (a size change), never per frame.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use anyhow::{Result, anyhow};
use glam::UVec3;

use crate::gpu::GpuContext;
use crate::gpu::readback::{Mapped, Staging};
use crate::output::{Image, LAYER_NAMES, Layer, Layers};
use crate::scene::{EnvImage, Environment};

use super::env_light::EnvLightTable;

static GENERATION: AtomicU64 = AtomicU64::new(1);

pub(crate) fn next_generation() -> u64 {
    GENERATION.fetch_add(1, Ordering::Relaxed)
}

/// Runs `f` inside an out-of-memory error scope, turning an allocation failure into a message.
fn allocating<T>(ctx: &GpuContext, what: &str, f: impl FnOnce() -> T) -> Result<T> {
    let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let value = f();
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(anyhow!(
            "the GPU \"{}\" has not enough memory for {what}: {e}; lower the volume resolution or image size",
            ctx.info.name
        ));
    }
    Ok(value)
}

/// The format of every filtered 3D grid: see `shaders/gradient.wgsl` for why 16-bit floats.
pub const GRID_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// One filterable 3D grid that compute stages write and later stages sample: `dims` voxels in
/// a texture a little larger (`frame::texture_dims`).
pub struct Grid3d {
    pub dims: UVec3,
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
}

impl Grid3d {
    fn new(device: &wgpu::Device, dims: UVec3, label: &str) -> Self {
        let size = crate::frame::texture_dims(dims);
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d { width: size.x, height: size.y, depth_or_array_layers: size.z },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format: GRID_FORMAT,
            usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        Self { dims, texture, view }
    }

    /// The grid's voxels (not the texture's spare texels), 8 bytes each, x fastest (test and
    /// diagnostic use).
    pub fn read(&self, ctx: &GpuContext) -> Result<Vec<u8>> {
        crate::gpu::readback::read_texture_3d(ctx, &self.texture, self.dims, 8)
    }
}

/// The voxel grids of the volume.
pub struct Grids {
    pub dims: UVec3,
    pub generation: u64,
    /// Where the grids sit in the world as of the last frame that filled them.
    pub placement: Option<crate::gpu::types::GridParams>,
    /// Raw n per voxel (f32), written by voxelize, read by gradient.
    pub index_field: wgpu::Buffer,
    /// (∇n, n), trilinearly sampled by every ray-marching stage.
    pub ior_grid: Grid3d,
    /// Extinction σ_t = absorption + scattering per metre (rgb).
    pub extinction_grid: Grid3d,
    /// Scattering σ_s per metre (rgb) and Henyey–Greenstein g (a).
    pub scattering_grid: Grid3d,
    /// Trilinear, clamped to the box edge.
    pub sampler: wgpu::Sampler,
    /// The min/max pyramid (`shaders/octree.wgsl`): level 0, the levels above it, the shape,
    /// and that shape as a uniform.
    pub octree_leaves: wgpu::Buffer,
    pub octree: wgpu::Buffer,
    pub octree_layout: crate::gpu::types::OctreeParams,
    pub octree_params: wgpu::Buffer,
    /// Per level-0 octree cell, the n − 1 of sharp glass in its block (0: none): where the
    /// photon raster aims. Kept out of the pyramid so sharp glass leaves it flat.
    pub glass_mark: wgpu::Buffer,
}

impl Grids {
    /// Bytes of the largest buffer the grids of a `dims` volume bind at once: the octree's
    /// level 0 (16 bytes per cell of the dual grid).
    pub fn largest_binding(dims: UVec3) -> u64 {
        let voxels = dims.x as u64 * dims.y as u64 * dims.z as u64;
        let [leaves, upper] = Self::octree_bytes(&Self::octree_layout(dims));
        leaves.max(upper).max(voxels * 4)
    }

    fn octree_layout(dims: UVec3) -> crate::gpu::types::OctreeParams {
        super::octree::layout_for(crate::gpu::types::GridParams { dims: dims.into(), ..Default::default() })
    }

    /// Bytes of the octree's two buffers: level 0, and the levels above it (at least one cell).
    fn octree_bytes(layout: &crate::gpu::types::OctreeParams) -> [u64; 2] {
        let leaves = super::octree::level_cells(layout, 0);
        [leaves * 16, (super::octree::cell_count(layout) - leaves).max(1) * 16]
    }

    pub fn new(ctx: &GpuContext, dims: UVec3) -> Result<Self> {
        let device = &ctx.device;
        let voxels = dims.x as u64 * dims.y as u64 * dims.z as u64;
        let octree_layout = Self::octree_layout(dims);
        let [leaf_bytes, upper_bytes] = Self::octree_bytes(&octree_layout);
        let storage = |label, size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        allocating(ctx, &format!("a {}×{}×{} volume", dims.x, dims.y, dims.z), || Self {
            dims,
            generation: next_generation(),
            placement: None,
            index_field: storage("index_field", voxels * 4),
            ior_grid: Grid3d::new(device, dims, "ior_grid"),
            extinction_grid: Grid3d::new(device, dims, "extinction_grid"),
            scattering_grid: Grid3d::new(device, dims, "scattering_grid"),
            sampler: device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("grid_sampler"),
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                ..Default::default()
            }),
            octree_leaves: storage("octree level 0", leaf_bytes),
            octree: storage("octree levels 1+", upper_bytes),
            glass_mark: storage("glass_mark", leaf_bytes / 4),
            octree_layout,
            octree_params: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("octree params"),
                size: std::mem::size_of::<crate::gpu::types::OctreeParams>() as u64,
                usage: super::layout::PARAMS | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
        })
    }

    /// Records where the grids sit this frame (the octree's shape depends only on the dims).
    pub fn place(&mut self, grid: crate::gpu::types::GridParams) {
        self.placement = Some(grid);
        self.octree_layout.grid = grid;
    }
}

/// The environment map on the GPU (a 1×1 texture for a constant color).
pub struct EnvironmentTexture {
    pub texture: wgpu::Texture,
    pub view: wgpu::TextureView,
    pub sampler: wgpu::Sampler,
    pub generation: u64,
    /// The image now uploaded (compared by identity: images are shared, never mutated).
    uploaded: Option<Arc<EnvImage>>,
    /// The environment as a light: its importance table (`env_light::EnvLightTable`, built once
    /// per image; a colour's is the uniform table) and that table on the GPU.
    pub light: EnvLightTable,
    pub light_table: wgpu::Buffer,
    /// The image the table was built from (None: the uniform table).
    light_of: Option<Arc<EnvImage>>,
    /// The image prefiltered for glossy receivers (`specular::prefilter`: `specular::LEVELS`
    /// layers), computed only once a frame has a specular receiver; 1×1 until then.
    pub specular_view: wgpu::TextureView,
    specular_of: Option<Arc<EnvImage>>,
}

impl EnvironmentTexture {
    pub fn new(ctx: &GpuContext) -> Self {
        let (texture, view) = Self::texture(ctx, 1, 1, &[[1.0; 4]]);
        let sampler = ctx.device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("env_sampler"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let specular_view = Self::array_view(&Self::layers(ctx, 1, 1, 1, &[[0.0; 4]]));
        let light = EnvLightTable::uniform();
        let light_table = Self::table_buffer(ctx, &light);
        Self { texture, view, sampler, generation: next_generation(), uploaded: None, light, light_table, light_of: None, specular_view, specular_of: None }
    }

    fn table_buffer(ctx: &GpuContext, table: &EnvLightTable) -> wgpu::Buffer {
        wgpu::util::DeviceExt::create_buffer_init(
            &ctx.device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("environment light table"),
                contents: bytemuck::cast_slice(&table.gpu_words()),
                usage: wgpu::BufferUsages::STORAGE,
            },
        )
    }

    /// Builds the environment's light table if the one on the GPU is another's; true if it did.
    pub fn update_light(&mut self, ctx: &GpuContext, env: &Environment) -> bool {
        let image = env.image();
        let same = match (image, &self.light_of) {
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            (None, None) => true,
            _ => false,
        };
        if same {
            return false;
        }
        self.light = image.map_or_else(EnvLightTable::uniform, |i| EnvLightTable::of_image(i));
        self.light_table = Self::table_buffer(ctx, &self.light);
        self.light_of = image.cloned();
        self.generation = next_generation();
        true
    }

    fn texture(ctx: &GpuContext, width: u32, height: u32, texels: &[[f32; 4]]) -> (wgpu::Texture, wgpu::TextureView) {
        let texture = Self::layers(ctx, width, height, 1, texels);
        let view = texture.create_view(&Default::default());
        (texture, view)
    }

    /// A half-float texture of `layers` layers from `texels` (layer after layer).
    fn layers(ctx: &GpuContext, width: u32, height: u32, layers: u32, texels: &[[f32; 4]]) -> wgpu::Texture {
        let size = wgpu::Extent3d { width, height, depth_or_array_layers: layers };
        let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("environment"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba16Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let halves: Vec<half::f16> = texels.iter().flatten().map(|&c| half::f16::from_f32(c)).collect();
        ctx.queue.write_texture(
            texture.as_image_copy(),
            bytemuck::cast_slice(&halves),
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(width * 8), rows_per_image: Some(height) },
            size,
        );
        texture
    }

    /// A view of all of a texture's layers as a 2D array (even of one layer).
    fn array_view(texture: &wgpu::Texture) -> wgpu::TextureView {
        texture.create_view(&wgpu::TextureViewDescriptor { dimension: Some(wgpu::TextureViewDimension::D2Array), ..Default::default() })
    }

    /// Prefilters the environment's image for glossy receivers if that was not done for it yet
    /// (a colour environment needs none: the shader uses its colour); true if it uploaded.
    pub fn update_specular(&mut self, ctx: &GpuContext, env: &Environment) -> bool {
        let Some(image) = env.image() else { return false };
        if self.specular_of.as_ref().is_some_and(|u| Arc::ptr_eq(u, image)) {
            return false;
        }
        use super::specular::{HEIGHT, LEVELS, WIDTH, prefilter};
        self.specular_view = Self::array_view(&Self::layers(ctx, WIDTH, HEIGHT, LEVELS, &prefilter(image)));
        self.specular_of = Some(image.clone());
        self.generation = next_generation();
        true
    }

    /// Uploads the environment's image if it is not the one on the GPU; true if it uploaded.
    pub fn update(&mut self, ctx: &GpuContext, env: &Environment) -> bool {
        let Some(image) = env.image() else { return false };
        if self.uploaded.as_ref().is_some_and(|u| Arc::ptr_eq(u, image)) {
            return false;
        }
        let max = ctx.limits.max_texture_dimension_2d;
        let (texture, view) = if image.width <= max && image.height <= max {
            Self::texture(ctx, image.width, image.height, &image.texels)
        } else {
            crate::warnings::say_plain(&format!(
            "environment image {}×{} exceeds the adapter's {max} texels; using it at reduced size",
            image.width, image.height
        ));
            let reduced = EnvImage::from_fn(max.min(image.width), (max / 2).min(image.height), |d| image.bilinear(crate::scene::environment::dir_to_uv(d)));
            Self::texture(ctx, reduced.width, reduced.height, &reduced.texels)
        };
        (self.texture, self.view) = (texture, view);
        self.uploaded = Some(image.clone());
        self.generation = next_generation();
        true
    }
}

/// Planes of vec4 per pixel the view stage writes: beauty, depth, caustic, direct, volume,
/// indirect.
pub const FRAME_PLANES: u64 = LAYER_NAMES.len() as u64;

/// Where the view stage writes the image, and the staging buffer it comes home through. The
/// planes lie one after another in one buffer, each bound on its own (a binding must start at a
/// multiple of the adapter's offset alignment, so each plane starts at one): a frame needs one
/// plane, not all six, to fit in a binding — 4K on adapters that bind 128 MiB.
pub struct FrameTarget {
    pub width: u32,
    pub height: u32,
    pub generation: u64,
    pub buffer: wgpu::Buffer,
    /// Bytes from one plane's start to the next's.
    plane_stride: u64,
    /// The frame's way home: one staging buffer per frame in flight, so frames k+1, k+2, … can
    /// be submitted before frame k is read, and more while frames already read back are still
    /// mapped, being converted on other threads ([`MappedFrame`]). Allocated as first needed.
    staging: Vec<Staging>,
    holds: Arc<Holds>,
}

/// Which of a frame target's staging buffers are taken (by a frame in flight, or a
/// [`MappedFrame`] not yet converted), and a signal when one is given back.
#[derive(Default)]
struct Holds {
    taken: std::sync::Mutex<Vec<bool>>,
    given_back: std::sync::Condvar,
}

impl Holds {
    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<bool>> {
        self.taken.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    fn give_back(&self, index: usize) {
        self.lock()[index] = false;
        self.given_back.notify_all();
    }
}

/// Gives a staging buffer back when dropped.
struct Hold {
    holds: Arc<Holds>,
    index: usize,
}

impl Drop for Hold {
    fn drop(&mut self) {
        self.holds.give_back(self.index);
    }
}

/// A frame read back but not yet converted into layers: its staging buffer stays mapped (and
/// taken) until [`image`](Self::image) has converted it, on whichever thread calls it.
pub struct MappedFrame {
    // (Dropped in this order: unmapped, then given back.)
    bytes: Mapped,
    _hold: Hold,
    width: u32,
    height: u32,
    plane_stride: u64,
    planes: usize,
}

impl MappedFrame {
    /// The planes converted into layers straight from the mapped staging buffer (the frame is
    /// the largest readback, 80 bytes a pixel, and copying it whole first doubled its cost), each
    /// plane on a thread of its own; then the buffer is unmapped and given back.
    pub fn image(self) -> Image {
        let n = (self.width * self.height) as usize;
        let floats: &[f32] = bytemuck::cast_slice(self.bytes.bytes());
        let stride = self.plane_stride as usize / 4;
        let plane = |k: usize| &floats[stride * k..stride * k + 4 * n];
        let layers = if self.planes == 1 {
            vec![plane_layer(0, plane(0))]
        } else {
            std::thread::scope(|s| {
                let threads: Vec<_> = (0..self.planes).map(|k| s.spawn(move || plane_layer(k, plane(k)))).collect();
                threads.into_iter().map(|t| t.join().expect("converting a frame plane")).collect()
            })
        };
        Image { width: self.width, height: self.height, layers }
    }
}

impl FrameTarget {
    /// Bytes of one plane: a vec4 of f32 per pixel.
    pub fn plane_bytes(width: u32, height: u32) -> u64 {
        width as u64 * height as u64 * 16
    }

    fn plane_stride(ctx: &GpuContext, width: u32, height: u32) -> u64 {
        Self::plane_bytes(width, height).next_multiple_of(ctx.limits.min_storage_buffer_offset_alignment as u64)
    }

    /// Bytes of the whole buffer on this adapter.
    pub fn bytes(ctx: &GpuContext, width: u32, height: u32) -> u64 {
        Self::plane_stride(ctx, width, height) * FRAME_PLANES
    }

    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> Result<Self> {
        let size = Self::bytes(ctx, width, height);
        allocating(ctx, &format!("a {width}×{height} frame"), || Self {
            width,
            height,
            generation: next_generation(),
            buffer: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("frame"),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            plane_stride: Self::plane_stride(ctx, width, height),
            staging: Vec::new(),
            holds: Arc::default(),
        })
    }

    /// The binding of plane `k` (beauty, depth, caustic, direct, volume).
    pub fn plane(&self, k: u64) -> wgpu::BindingResource<'_> {
        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: &self.buffer,
            offset: k * self.plane_stride,
            size: wgpu::BufferSize::new(Self::plane_bytes(self.width, self.height)),
        })
    }

    /// Takes a free staging buffer for the next frame's readback (allocating one while fewer
    /// than `limit` exist, else waiting for a [`MappedFrame`] to give one back); returns its index.
    pub fn take_staging(&mut self, ctx: &GpuContext, limit: usize) -> usize {
        let mut taken = self.holds.lock();
        loop {
            if let Some(i) = taken.iter().position(|t| !t) {
                taken[i] = true;
                return i;
            }
            if taken.len() < limit.max(1) {
                taken.push(true);
                self.staging.push(Staging::new(&ctx.device, self.buffer.size(), "frame readback"));
                return taken.len() - 1;
            }
            taken = self.holds.given_back.wait(taken).unwrap_or_else(std::sync::PoisonError::into_inner);
        }
    }

    /// Gives back a staging buffer whose frame is finished without its image.
    pub fn give_back(&self, index: usize) {
        self.holds.give_back(index);
    }

    /// Bytes of the planes that bring `layers` back: the beauty plane comes first.
    fn readback_bytes(&self, layers: Layers) -> u64 {
        match layers {
            Layers::All => self.buffer.size(),
            Layers::Beauty => self.plane_stride,
        }
    }

    pub fn encode_readback(&self, enc: &mut wgpu::CommandEncoder, staging: usize, layers: Layers) {
        enc.copy_buffer_to_buffer(&self.buffer, 0, &self.staging[staging].buffer, 0, self.readback_bytes(layers));
    }

    /// Maps staging buffer `staging` after the submission with
    /// [`encode_readback`](Self::encode_readback) finished; the buffer is given back once the
    /// result is converted (or dropped), also when mapping fails.
    pub fn map(&self, ctx: &GpuContext, staging: usize, layers: Layers) -> Result<MappedFrame> {
        let hold = Hold { holds: self.holds.clone(), index: staging };
        let bytes = self.staging[staging].map(ctx, self.readback_bytes(layers))?;
        let planes = match layers {
            Layers::All => FRAME_PLANES as usize,
            Layers::Beauty => 1,
        };
        Ok(MappedFrame { bytes, _hold: hold, width: self.width, height: self.height, plane_stride: self.plane_stride, planes })
    }
}

/// The layer of frame plane `k` (vec4 per pixel), named by [`LAYER_NAMES`]: beauty RGBA, depth,
/// then the caustic, direct, volume and indirect (bounced) light (RGB).
fn plane_layer(k: usize, plane: &[f32]) -> Layer {
    let name = LAYER_NAMES[k];
    match k {
        0 => Layer::new(name, &["R", "G", "B", "A"], plane.to_vec()),
        1 => Layer::new(name, &["Z"], plane.chunks_exact(4).map(|c| c[0]).collect()),
        _ => {
            // (flat_map's size hint is unknown, so reserve the exact length up front)
            let mut out = Vec::with_capacity(plane.len() / 4 * 3);
            out.extend(plane.chunks_exact(4).flat_map(|c| [c[0], c[1], c[2]]));
            Layer::new(name, &["R", "G", "B"], out)
        }
    }
}

/// Light carried by photons through the volume: fixed-point deposits (march stage) and the
/// filtered fluence and mean-direction textures the view pass samples. Allocated at full size
/// only while something in the frame scatters light; a 1-voxel stand-in otherwise.
pub struct RadianceGrid {
    pub dims: UVec3,
    pub generation: u64,
    /// 3 u32 per voxel: flux·length r, g, b.
    pub flux_deposits: wgpu::Buffer,
    /// 3 i32 per voxel: luminance·length·direction x, y, z. (Two buffers, each bound on its own:
    /// a volume needs half the binding size that one buffer of all six words would.)
    pub direction_deposits: wgpu::Buffer,
    pub fluence: Grid3d,
    pub direction: Grid3d,
}

impl RadianceGrid {
    /// Bytes of each of the two deposit buffers of a `dims` volume (3 words per voxel).
    pub fn deposit_binding_bytes(dims: UVec3) -> u64 {
        dims.x as u64 * dims.y as u64 * dims.z as u64 * 12
    }

    pub fn new(ctx: &GpuContext, dims: UVec3) -> Result<Self> {
        let bytes = Self::deposit_binding_bytes(dims);
        let deposits = |label| {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        allocating(ctx, "the radiance grid", || Self {
            dims,
            generation: next_generation(),
            flux_deposits: deposits("radiance flux deposits"),
            direction_deposits: deposits("radiance direction deposits"),
            fluence: Grid3d::new(&ctx.device, dims, "fluence_grid"),
            direction: Grid3d::new(&ctx.device, dims, "direction_grid"),
        })
    }
}

/// A storage buffer that a stage refills every frame with a variable amount of data, growing to
/// the next power of two when a frame needs more (so it is reallocated rarely, not per frame).
pub struct GrowableBuffer {
    pub buffer: wgpu::Buffer,
    label: &'static str,
    capacity: u64,
}

impl GrowableBuffer {
    pub fn new(device: &wgpu::Device, label: &'static str, capacity: u64) -> Self {
        let capacity = capacity.max(16);
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: capacity,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Self { buffer, label, capacity }
    }

    /// Makes room for `bytes` without uploading; returns true when it reallocated.
    pub fn reserve(&mut self, ctx: &GpuContext, bytes: u64) -> bool {
        let grown = bytes > self.capacity;
        if grown {
            *self = Self::new(&ctx.device, self.label, Self::grown_capacity(ctx, bytes));
        }
        grown
    }

    /// The next power of two above `bytes`, but no more than one binding may hold (when `bytes`
    /// fits in one): rounding up must not be what makes a buffer unbindable.
    fn grown_capacity(ctx: &GpuContext, bytes: u64) -> u64 {
        let binding = ctx.limits.max_storage_buffer_binding_size.min(ctx.limits.max_buffer_size);
        bytes.next_power_of_two().min(binding.max(bytes))
    }

    /// Uploads `bytes`; returns true when the buffer was reallocated (bind groups must be rebuilt).
    pub fn write(&mut self, ctx: &GpuContext, bytes: &[u8]) -> bool {
        let grown = bytes.len() as u64 > self.capacity;
        if grown {
            *self = Self::new(&ctx.device, self.label, Self::grown_capacity(ctx, bytes.len() as u64));
        }
        if !bytes.is_empty() {
            ctx.queue.write_buffer(&self.buffer, 0, bytes);
        }
        grown
    }
}
