//! Stage 1a, mesh solids (`shaders/voxelize_mesh.wgsl`): every refractive triangle mesh of the
//! frame → the signed distance from each voxel centre of its window to its surface, kept in a
//! coverage atlas that the voxelize kernel turns into the mesh's smooth coverage and composites
//! into n, κ and σ. CPU twin: `cpu::mesh`.
//!
//! **What is guaranteed.** Inside/outside at voxel centres is the even–odd rule along lines
//! parallel to x, y and z, voted; the crossings are decided exactly in fixed point (2^`s` per
//! voxel). For a closed mesh (every line crosses it an even number of times: any watertight
//! surface, self-intersecting or nested ones included) all three lines agree and the result is
//! the exact even–odd solid at every voxel centre, whatever the triangles' winding. Repeated
//! triangles are counted once ([`MeshData::solid_triangles`]). A line through a hole crosses an
//! odd number of times and abstains; a voxel is inside when most of the votes cast say so. A
//! voxel seen through closed surface along another axis is thus still classified right, a hole
//! never floods the outside, and only voxels whose three lines all pass through holes are lost
//! (counted outside). The solid is closed across a hole roughly along its rim, with a hard
//! (unsmoothed) boundary there, as no triangle gives a distance. Every voxel within 0.9 voxel of a triangle gets its exact distance
//! to the surface, which makes the band of surface voxels conservative and so 26-separating:
//! along any 26-connected path the classification changes only inside the band.
//!
//! **Only what changed.** A mesh's signed distances stay in the atlas between frames and are
//! recomputed only when its geometry, its world matrix, its boundary width or the volume box
//! changed; a new frame only re-composites them. Moving one object in a fixed box (set
//! `volume.min`/`max`) thus re-voxelizes that object alone; in a box fitted to the objects,
//! a move that changes the box redoes them all.

use std::collections::HashSet;
use std::sync::Arc;

use anyhow::{Result, bail};
use glam::{DMat4, DVec3, IVec3, Mat4, UVec3, Vec3};

use super::layout;
use super::timing::Profiler;
use crate::frame::{FrameDesc, MeshInstance, VolumeDesc};
use crate::gpu::GpuContext;
use crate::gpu::readback;
use crate::gpu::shaders::ShaderLibrary;
use crate::gpu::types::{MeshParams, MeshVolume};
use crate::scene::MeshData;

/// Fixed-point coordinates are clamped to ±2^18 (relative to the grid origin), so that every
/// determinant of the exact tests fits in 60 bits.
pub const COORD_LIMIT: i32 = 1 << 18;
/// The signed distance stored for voxels beyond every triangle's reach (sign: inside or not).
pub const FAR: f32 = 1e9;
/// Distance (voxels) within which every voxel gets its exact distance, whatever the boundary
/// width: the surface touches a voxel's cube only if it passes within √3/2 of its centre.
pub const SEPARATING_REACH: f32 = 0.9;

const WORKGROUP: u32 = 64;
const LARGE_WORKGROUPS: u32 = 512;

/// The box of grid voxels a mesh's solid is computed over: its bounds widened by the reach
/// of the band and a voxel, clipped to the grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshWindow {
    pub min: UVec3,
    pub dims: UVec3,
}

impl MeshWindow {
    /// `None` when the mesh lies wholly outside the volume.
    pub fn of(instance: &MeshInstance, volume: &VolumeDesc) -> Option<Self> {
        let pad = reach(instance, volume) + 1.0;
        let to_voxels = |p: Vec3| (p - volume.min) / volume.voxel_size;
        let lo = (to_voxels(instance.bounds.0) - pad).floor().max(Vec3::ZERO);
        let hi = (to_voxels(instance.bounds.1) + pad).ceil().min(volume.dims.as_vec3());
        if hi.cmple(lo).any() {
            return None;
        }
        Some(Self { min: lo.as_uvec3(), dims: (hi - lo).as_uvec3() })
    }

    pub fn voxels(&self) -> u64 {
        self.dims.x as u64 * self.dims.y as u64 * self.dims.z as u64
    }

    /// Index of window voxel `v`, x fastest.
    pub fn index(&self, v: UVec3) -> usize {
        (v.x + self.dims.x * (v.y + self.dims.y * v.z)) as usize
    }

    /// Parity words per column along each axis: one bit per voxel plus one for the line.
    pub fn axis_words(&self) -> [u32; 3] {
        self.dims.to_array().map(|len| (len + 1).div_ceil(32))
    }

    /// Where each axis' parity words start, and how many there are in all.
    pub fn axis_offsets(&self) -> ([u32; 3], u32) {
        let words = self.axis_words();
        let mut offsets = [0u32; 3];
        let mut total = 0;
        for axis in 0..3 {
            offsets[axis] = total;
            total += words[axis] * self.columns(axis);
        }
        (offsets, total)
    }

    /// Lines of voxels along `axis`.
    pub fn columns(&self, axis: usize) -> u32 {
        self.dims.to_array().iter().enumerate().filter(|(a, _)| *a != axis).map(|(_, d)| d).product()
    }
}

/// Distance (voxels) out to which voxels get their exact distance to a mesh's surface: half
/// its boundary width, and at least [`SEPARATING_REACH`].
pub fn reach(instance: &MeshInstance, volume: &VolumeDesc) -> f32 {
    (0.5 * instance.boundary / volume.voxel_size).max(SEPARATING_REACH)
}

/// Fixed-point bits per voxel: the grid spans at most 2^16 units along its longest side.
pub fn fixed_bits(dims: UVec3) -> u32 {
    let longest = dims.max_element().max(2);
    (16 - (32 - (longest - 1).leading_zeros()) as i32).clamp(1, 14) as u32
}

/// Local mesh coordinates → grid coordinates in voxels (grid origin at 0), composed in f64.
pub fn grid_from_local(instance: &MeshInstance, volume: &VolumeDesc) -> Mat4 {
    let scale = DMat4::from_scale(DVec3::splat(1.0 / volume.voxel_size as f64));
    (scale * DMat4::from_translation(-volume.min.as_dvec3()) * instance.world.as_dmat4()).as_mat4()
}

/// The uniforms of one mesh's run.
pub fn mesh_params(instance: &MeshInstance, volume: &VolumeDesc, window: &MeshWindow, geometry: (u32, u32), atlas_offset: u32) -> MeshParams {
    let (axis_offset, parity_words) = window.axis_offsets();
    MeshParams {
        grid_from_local: grid_from_local(instance, volume).to_cols_array_2d(),
        window_min: window.min.as_ivec3().into(),
        fixed_bits: fixed_bits(volume.dims),
        window_dims: window.dims.into(),
        vertex_count: geometry.0,
        triangle_count: geometry.1,
        axis_offset,
        axis_words: window.axis_words(),
        atlas_offset,
        reach: reach(instance, volume),
        parity_words,
        band_voxels: window.voxels() as u32,
        _pad0: 0,
    }
}

/// How much mesh work a frame did (added to `Renderer::counters`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MeshWork {
    /// Meshes whose solid was computed this frame.
    pub voxelized: u64,
    /// Meshes whose solid from an earlier frame was used as it was.
    pub reused: u64,
    /// Triangles rasterized this frame.
    pub triangles: u64,
}

/// What a mesh's signed distances in the atlas were computed from.
#[derive(Clone, Debug, PartialEq)]
struct Made {
    mesh: usize,
    world: Mat4,
    reach: f32,
    volume: (Vec3, f32, UVec3),
}

/// A mesh uploaded in its local coordinates (vec4 per vertex, 3 indices per triangle).
struct Geometry {
    mesh: Arc<MeshData>,
    vertices: wgpu::Buffer,
    triangles: wgpu::Buffer,
    vertex_count: u32,
    triangle_count: u32,
}

/// A range of the atlas, in f32 words.
#[derive(Clone, Copy, Debug)]
struct Region {
    offset: u64,
    capacity: u64,
}

/// Everything kept for the mesh at one position of the frame's mesh list.
struct Slot {
    params: wgpu::Buffer,
    geometry: Option<Geometry>,
    /// Bind group 1 (params, vertices, triangles), remade when the geometry buffers change.
    group: Option<wgpu::BindGroup>,
    region: Option<Region>,
    made: Option<Made>,
    window: Option<MeshWindow>,
}

/// Buffers used while one mesh is voxelized, shared by all (they only grow).
struct Scratch {
    grid_vertices: wgpu::Buffer,
    parity_words: wgpu::Buffer,
    band_distance: wgpu::Buffer,
    large_work: wgpu::Buffer,
    generation: u64,
}

/// Signed distances of all meshes, each in its own region.
struct Atlas {
    buffer: wgpu::Buffer,
    used: u64,
    generation: u64,
}

struct Kernels {
    clear_scratch: wgpu::ComputePipeline,
    transform_vertices: wgpu::ComputePipeline,
    rasterize: wgpu::ComputePipeline,
    rasterize_large: wgpu::ComputePipeline,
    prefix_parity: wgpu::ComputePipeline,
    signed_distance: wgpu::ComputePipeline,
}

pub struct MeshVoxelizer {
    kernels: Kernels,
    scratch_layout: wgpu::BindGroupLayout,
    mesh_layout: wgpu::BindGroupLayout,
    scratch: Scratch,
    atlas: Atlas,
    /// Bind group 0 (scratch and atlas) and the generations it was made for.
    scratch_group: Option<((u64, u64), wgpu::BindGroup)>,
    slots: Vec<Slot>,
    /// Meshes already warned about reaching far beyond the volume.
    warned: HashSet<String>,
    /// Slot whose run left the scratch buffers as they are now (tests read them).
    last_run: Option<usize>,
}

fn storage(device: &wgpu::Device, label: &str, bytes: u64, extra: wgpu::BufferUsages) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(16).next_multiple_of(4),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC | extra,
        mapped_at_creation: false,
    })
}

/// A storage buffer of at least `bytes`: `current` if it is big enough, else a new one.
fn grown(device: &wgpu::Device, current: &wgpu::Buffer, label: &str, bytes: u64) -> Option<wgpu::Buffer> {
    (bytes > current.size()).then(|| storage(device, label, bytes.next_power_of_two(), wgpu::BufferUsages::empty()))
}

/// `groups` workgroups of a 1D dispatch spread over x and z (each holds at most `limit`).
fn spread(groups: u32, limit: u32) -> (u32, u32) {
    let x = groups.clamp(1, limit);
    (x, groups.div_ceil(x).max(1))
}

impl MeshVoxelizer {
    pub fn new(device: &wgpu::Device, shaders: &ShaderLibrary) -> Result<Self> {
        let rw = |b| layout::storage(b, false);
        let scratch_entries = [rw(0), rw(1), rw(2), rw(3), rw(4)];
        let mesh_entries = [layout::uniform(0), layout::storage(1, true), layout::storage(2, true)];
        let entry_points =
            ["clear_scratch", "transform_vertices", "rasterize", "rasterize_large", "prefix_parity", "signed_distance"];
        let (pipelines, mut layouts) =
            layout::pipelines(device, shaders, "voxelize_mesh", &[&scratch_entries, &mesh_entries], &entry_points)?;
        let [clear_scratch, transform_vertices, rasterize, rasterize_large, prefix_parity, signed_distance] =
            <[wgpu::ComputePipeline; 6]>::try_from(pipelines).map_err(|_| anyhow::anyhow!("six mesh kernels"))?;
        let mesh_layout = layouts.pop().expect("two layouts");
        let scratch_layout = layouts.pop().expect("two layouts");
        let none = wgpu::BufferUsages::empty();
        Ok(Self {
            kernels: Kernels { clear_scratch, transform_vertices, rasterize, rasterize_large, prefix_parity, signed_distance },
            scratch_layout,
            mesh_layout,
            scratch: Scratch {
                grid_vertices: storage(device, "grid_vertices", 16, none),
                parity_words: storage(device, "parity_words", 16, none),
                band_distance: storage(device, "band_distance", 16, none),
                large_work: storage(device, "large_work", 16, none),
                generation: 0,
            },
            atlas: Atlas { buffer: storage(device, "mesh_atlas", 16, none), used: 0, generation: 0 },
            scratch_group: None,
            slots: Vec::new(),
            warned: HashSet::new(),
            last_run: None,
        })
    }

    /// The atlas of signed distances (voxelize binds it).
    pub fn atlas(&self) -> (&wgpu::Buffer, u64) {
        (&self.atlas.buffer, self.atlas.generation)
    }

    /// Forgets every mesh's solid, so the next frame computes all of them (benchmarks time
    /// that work; nothing else needs this).
    pub fn forget(&mut self) {
        for slot in &mut self.slots {
            slot.made = None;
        }
    }

    /// Voxelizes the meshes of `desc` that changed since the last frame into the atlas, and
    /// returns what the voxelize kernel needs of every mesh in the volume, in scene order.
    pub fn encode(
        &mut self,
        ctx: &GpuContext,
        enc: &mut wgpu::CommandEncoder,
        profiler: &mut Profiler,
        meshes: &[MeshInstance],
        volume: &VolumeDesc,
    ) -> Result<(Vec<MeshVolume>, MeshWork)> {
        self.slots.truncate(meshes.len());
        while self.slots.len() < meshes.len() {
            let params = layout::uniform_buffer::<MeshParams>(&ctx.device, "mesh params");
            self.slots.push(Slot { params, geometry: None, group: None, region: None, made: None, window: None });
        }
        let windows: Vec<Option<MeshWindow>> = meshes.iter().map(|m| MeshWindow::of(m, volume)).collect();
        self.place_in_atlas(ctx, enc, &windows)?;

        let mut work = MeshWork::default();
        let mut runs = Vec::new();
        let mut volumes = Vec::new();
        for (i, (m, window)) in meshes.iter().zip(&windows).enumerate() {
            self.slots[i].window = *window;
            let Some(window) = window else { continue };
            self.warn_if_clamped(m, volume);
            let made = Made {
                mesh: Arc::as_ptr(&m.mesh) as usize,
                world: m.world,
                reach: reach(m, volume),
                volume: (volume.min, volume.voxel_size, volume.dims),
            };
            let slot = &mut self.slots[i];
            let region = slot.region.expect("placed above");
            if slot.made.as_ref() == Some(&made) && slot.geometry.as_ref().is_some_and(|g| Arc::ptr_eq(&g.mesh, &m.mesh)) {
                work.reused += 1;
            } else {
                upload(ctx, slot, &self.mesh_layout, &m.mesh);
                let g = slot.geometry.as_ref().expect("uploaded");
                let params = mesh_params(m, volume, window, (g.vertex_count, g.triangle_count), region.offset as u32);
                ctx.queue.write_buffer(&slot.params, 0, bytemuck::bytes_of(&params));
                work.voxelized += 1;
                work.triangles += g.triangle_count as u64;
                slot.made = Some(made);
                runs.push((i, params));
            }
            volumes.push(MeshVolume {
                window_min: window.min.into(),
                atlas_offset: region.offset as u32,
                window_dims: window.dims.into(),
                ior: m.glass.ior,
                absorption: m.glass.absorption.into(),
                boundary: m.boundary,
                scattering: m.glass.scattering.extend(m.glass.g).into(),
                sharp: m.sharp as u32,
                ..Default::default()
            });
        }
        if !runs.is_empty() {
            self.reserve_scratch(ctx, &runs);
            self.dispatch(ctx, enc, profiler, &runs);
        }
        Ok((volumes, work))
    }

    /// Gives every mesh in the volume a region of the atlas big enough for its window. Regions
    /// stay where they are while they fit, so unchanged meshes keep their signed distances; the
    /// atlas grows by copying, and is laid out afresh (all meshes redone) when most of it is
    /// abandoned space.
    fn place_in_atlas(&mut self, ctx: &GpuContext, enc: &mut wgpu::CommandEncoder, windows: &[Option<MeshWindow>]) -> Result<()> {
        let fits = |slot: &Slot, w: &MeshWindow| slot.region.is_some_and(|r| r.capacity >= w.voxels());
        // A little room to spare, so a turning mesh does not need a new region every frame.
        let with_room = |w: &MeshWindow| (w.voxels() + w.voxels() / 8).next_multiple_of(1024);
        let live: u64 = windows.iter().flatten().map(with_room).sum();
        let wanted: u64 = self.slots.iter().zip(windows).filter_map(|(s, w)| w.filter(|w| !fits(s, w)).map(|w| with_room(&w))).sum();
        if self.atlas.used + wanted > 2 * live + (1 << 20) {
            self.atlas.used = 0;
            for slot in &mut self.slots {
                (slot.region, slot.made) = (None, None);
            }
        }
        let old_used = self.atlas.used;
        for (slot, w) in self.slots.iter_mut().zip(windows) {
            let Some(w) = w else { continue };
            if !fits(slot, w) {
                slot.region = Some(Region { offset: self.atlas.used, capacity: with_room(w) });
                slot.made = None;
                self.atlas.used += with_room(w);
            }
        }
        let bytes = self.atlas.used * 4;
        let limit = ctx.limits.max_storage_buffer_binding_size.min(ctx.limits.max_buffer_size);
        if bytes > limit {
            bail!(
                "the meshes' voxel windows need {} MiB of signed distances, more than the {} MiB the adapter \"{}\" \
                 binds at once; lower the volume resolution (--volume or volume.resolution)",
                bytes >> 20,
                limit >> 20,
                ctx.info.name
            );
        }
        if bytes > self.atlas.buffer.size() {
            let buffer = storage(&ctx.device, "mesh_atlas", (bytes + bytes / 2).min(limit), wgpu::BufferUsages::empty());
            if old_used > 0 {
                enc.copy_buffer_to_buffer(&self.atlas.buffer, 0, &buffer, 0, old_used * 4);
            }
            self.atlas.buffer = buffer;
            self.atlas.generation += 1;
        }
        Ok(())
    }

    fn warn_if_clamped(&mut self, m: &MeshInstance, volume: &VolumeDesc) {
        let limit = (COORD_LIMIT >> fixed_bits(volume.dims)) as f32 * volume.voxel_size;
        let (lo, hi) = (m.bounds.0 - volume.min, m.bounds.1 - volume.min);
        if (lo.min_element() < -limit || hi.max_element() > limit) && self.warned.insert(m.name.clone()) {
            crate::warnings::say_plain(&format!(
                "{}: mesh \"{}\" reaches more than {limit:.3} m beyond the volume's corner; its vertices are clamped \
                 there, which bends triangles that also reach into the volume (split the mesh, or enlarge the volume)",
                m.origin, m.name
            ));
        }
    }

    /// Grows the scratch buffers to fit the largest run.
    fn reserve_scratch(&mut self, ctx: &GpuContext, runs: &[(usize, MeshParams)]) {
        let max = |f: fn(&MeshParams) -> u32| runs.iter().map(|(_, p)| f(p) as u64).max().unwrap_or(0);
        let d = &ctx.device;
        let s = &mut self.scratch;
        let mut changed = false;
        for (buffer, label, bytes) in [
            (&mut s.grid_vertices, "grid_vertices", 16 * max(|p| p.vertex_count)),
            (&mut s.parity_words, "parity_words", 4 * max(|p| p.parity_words)),
            (&mut s.band_distance, "band_distance", 4 * max(|p| p.band_voxels)),
            (&mut s.large_work, "large_work", 4 * (1 + 4 * max(|p| p.triangle_count))),
        ] {
            if let Some(b) = grown(d, buffer, label, bytes) {
                *buffer = b;
                changed = true;
            }
        }
        if changed {
            s.generation += 1;
        }
    }

    fn dispatch(&mut self, ctx: &GpuContext, enc: &mut wgpu::CommandEncoder, profiler: &mut Profiler, runs: &[(usize, MeshParams)]) {
        let key = (self.scratch.generation, self.atlas.generation);
        if self.scratch_group.as_ref().is_none_or(|(k, _)| *k != key) {
            let s = &self.scratch;
            let buffers = [&s.grid_vertices, &s.parity_words, &s.band_distance, &s.large_work, &self.atlas.buffer];
            let entries: Vec<wgpu::BindGroupEntry> = buffers
                .iter()
                .enumerate()
                .map(|(i, b)| layout::bind(i as u32, b))
                .collect();
            let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("mesh scratch"), layout: &self.scratch_layout, entries: &entries });
            self.scratch_group = Some((key, group));
        }
        let limit = ctx.limits.max_compute_workgroups_per_dimension;
        let k = &self.kernels;
        let mut pass = profiler.pass(enc, "voxelize.meshes");
        pass.set_bind_group(0, &self.scratch_group.as_ref().expect("made above").1, &[]);
        for (i, p) in runs {
            pass.set_bind_group(1, self.slots[*i].group.as_ref().expect("uploaded"), &[]);
            let groups = |n: u32| spread(n.div_ceil(WORKGROUP), limit);
            let (x, z) = groups(p.parity_words.max(p.band_voxels));
            pass.set_pipeline(&k.clear_scratch); // scratch ← 0
            pass.dispatch_workgroups(x, 1, z);
            let (x, z) = groups(p.vertex_count);
            pass.set_pipeline(&k.transform_vertices); // local_vertices → grid_vertices
            pass.dispatch_workgroups(x, 1, z);
            let (x, z) = groups(p.triangle_count);
            pass.set_pipeline(&k.rasterize); // grid_vertices, triangles → parity_words (crossings), band_distance, large_work
            pass.dispatch_workgroups(x, 4, z);
            pass.set_pipeline(&k.rasterize_large); // large_work → parity_words, band_distance
            pass.dispatch_workgroups((4 * p.triangle_count).clamp(1, LARGE_WORKGROUPS), 1, 1);
            let (x, z) = groups(self.slots[*i].window.map_or(1, |w| (0..3).map(|a| w.columns(a)).max().unwrap_or(1)));
            pass.set_pipeline(&k.prefix_parity); // parity_words: crossings → parity
            pass.dispatch_workgroups(x, 3, z);
            let d = UVec3::from(p.window_dims).map(|n| n.div_ceil(4));
            pass.set_pipeline(&k.signed_distance); // parity_words, band_distance → atlas
            pass.dispatch_workgroups(d.x, d.y, d.z);
        }
        self.last_run = runs.last().map(|(i, _)| *i);
    }

    /// The window mesh `i` of the last frame covered (`None` outside the volume).
    pub fn window(&self, i: usize) -> Option<MeshWindow> {
        self.slots.get(i).and_then(|s| s.window)
    }

    /// Mesh `i`'s signed distances (voxels, negative inside) over its window, as last computed.
    pub fn read_signed_distance(&self, ctx: &GpuContext, i: usize) -> Result<Vec<f32>> {
        let slot = self.slots.get(i).ok_or_else(|| anyhow::anyhow!("no mesh {i}"))?;
        let (Some(w), Some(r)) = (slot.window, slot.region) else { bail!("mesh {i} is outside the volume") };
        let all = readback::read_buffer(ctx, &self.atlas.buffer)?;
        let words: &[f32] = bytemuck::cast_slice(&all);
        Ok(words[r.offset as usize..(r.offset + w.voxels()) as usize].to_vec())
    }

    /// The parity words and window-local fixed-point vertices the last voxelized mesh left in
    /// the scratch buffers (for the CPU twin comparison), and which mesh that was.
    pub fn read_scratch(&self, ctx: &GpuContext) -> Result<(usize, Vec<u32>, Vec<IVec3>)> {
        let Some(i) = self.last_run else { bail!("no mesh has been voxelized yet") };
        let w = self.slots[i].window.expect("voxelized meshes have a window");
        let words: Vec<u32> = bytemuck::cast_slice(&readback::read_buffer(ctx, &self.scratch.parity_words)?).to_vec();
        let vertices: Vec<[i32; 4]> = bytemuck::cast_slice(&readback::read_buffer(ctx, &self.scratch.grid_vertices)?).to_vec();
        let count = self.slots[i].geometry.as_ref().map_or(0, |g| g.vertex_count as usize);
        Ok((
            i,
            words[..w.axis_offsets().1 as usize].to_vec(),
            vertices[..count].iter().map(|v| IVec3::new(v[0], v[1], v[2])).collect(),
        ))
    }
}

/// Uploads `mesh` into the slot unless it is there already (meshes are compared by identity:
/// a changed mesh is a new `Arc`), reusing the slot's buffers when they are big enough.
fn upload(ctx: &GpuContext, slot: &mut Slot, layout: &wgpu::BindGroupLayout, mesh: &Arc<MeshData>) {
    if slot.geometry.as_ref().is_some_and(|g| Arc::ptr_eq(&g.mesh, mesh)) {
        return;
    }
    let vertices: Vec<[f32; 4]> = mesh.positions.iter().map(|p| p.extend(1.0).to_array()).collect();
    let triangles = mesh.solid_triangles();
    let (vertex_bytes, triangle_bytes): (&[u8], &[u8]) = (bytemuck::cast_slice(&vertices), bytemuck::cast_slice(&triangles));
    let d = &ctx.device;
    let (vertex_buffer, triangle_buffer) = match slot.geometry.take() {
        Some(g) if g.vertices.size() >= vertex_bytes.len() as u64 && g.triangles.size() >= triangle_bytes.len() as u64 => {
            (g.vertices, g.triangles)
        }
        _ => {
            slot.group = None;
            let none = wgpu::BufferUsages::empty();
            (storage(d, "mesh vertices", vertex_bytes.len() as u64, none), storage(d, "mesh triangles", triangle_bytes.len() as u64, none))
        }
    };
    ctx.queue.write_buffer(&vertex_buffer, 0, vertex_bytes);
    ctx.queue.write_buffer(&triangle_buffer, 0, triangle_bytes);
    if slot.group.is_none() {
        slot.group = Some(d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("mesh"),
            layout,
            entries: &[
                layout::bind(0, &slot.params),
                layout::bind(1, &vertex_buffer),
                layout::bind(2, &triangle_buffer),
            ],
        }));
    }
    slot.geometry = Some(Geometry {
        mesh: mesh.clone(),
        vertices: vertex_buffer,
        triangles: triangle_buffer,
        vertex_count: vertices.len() as u32,
        triangle_count: triangles.len() as u32,
    });
}

/// The frame [`benchmark`] voxelizes: `mesh` alone in glass, in a volume of `resolution` voxels
/// along its longest side.
pub fn benchmark_frame(mesh: Arc<MeshData>, resolution: u32) -> Result<FrameDesc> {
    use crate::scene::{Glass, Material, Node, Scene, Shape, eval, shared};
    let mut scene = Scene::default();
    let mut node = Node::new("benchmark");
    node.shape = Some(shared(Shape::Mesh { mesh, source: "benchmark".into(), boundary: None }));
    node.material = Some(shared(Material::Glass(Glass::default())));
    scene.roots.push(shared(node));
    eval::evaluate(&scene, 0.0, &eval::EvalOptions { resolution: Some(resolution), ..Default::default() })
}

/// GPU time of the voxelize stage for one mesh, as [`benchmark`] measures it.
#[derive(Clone, Debug, PartialEq)]
pub struct VoxelizeTiming {
    /// Volume dimensions the mesh was voxelized into.
    pub dims: UVec3,
    /// Triangles voxelized.
    pub triangles: u32,
    /// Median milliseconds of the mesh-solid kernels (`voxelize.meshes`).
    pub meshes_ms: f64,
    /// Median milliseconds of compositing into n, κ, σ (`voxelize`).
    pub composite_ms: f64,
}

/// Times the voxelize stage on a [`benchmark_frame`], computing the meshes' solids afresh in
/// each of `runs` runs (`refrakt bench`). `None` when the adapter has no timestamp queries.
pub fn benchmark(renderer: &mut super::Renderer, desc: &FrameDesc, runs: u32) -> Result<Option<VoxelizeTiming>> {
    let triangles = desc.meshes.iter().map(|m| m.mesh.solid_triangles().len() as u32).sum();
    let mut meshes = Vec::new();
    let mut composite = Vec::new();
    // One run first to allocate and compile; it is not counted.
    for run in 0..=runs {
        renderer.forget_mesh_voxels();
        let passes = renderer.time_voxelize(desc)?;
        if passes.is_empty() {
            return Ok(None);
        }
        let ms = |label: &str| passes.iter().filter(|(l, _)| *l == label).map(|(_, ms)| ms).sum::<f64>();
        if run > 0 {
            meshes.push(ms("voxelize.meshes"));
            composite.push(ms("voxelize"));
        }
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    Ok(Some(VoxelizeTiming { dims: desc.volume.dims, triangles, meshes_ms: median(meshes), composite_ms: median(composite) }))
}
