//! The opaque receivers on the GPU: their triangles in a BVH, their albedo (and base color
//! texture), and the caustic charts refracted photons land in (`shaders/shared/receivers.wgsl`).
//!
//! A chart is a world-axis-aligned grid of texels over the triangles of one receiver whose
//! surfaces face one of the six axis directions, on one side (front faces, or back faces — the
//! inside of a room). Planes, boxes and walls map onto charts exactly; curved receivers are
//! split by the direction they face, like a cube map, so surfaces of one receiver that face the
//! same way and overlap in projection share texels (a documented limit, rare for floors and
//! walls). Charts are rebuilt only when the receivers change.
//!
//! The BVH also holds the triangles of sharp glass meshes (`pipeline::interfaces`), so one
//! closest-hit query finds the next surface of either kind and a shadow ray is stopped by both.

use glam::{Vec2, Vec3};

use crate::bvh::{Bvh, Triangle};
use super::resources::GrowableBuffer;
use crate::frame::{FrameDesc, Receiver};
use crate::gpu::GpuContext;
use super::interfaces;
use crate::gpu::types::{BvhNode, BvhTriangle, Chart, ReceiverGpu, interface_kind};

/// Texels along the longest side of one chart, at most.
pub const MAX_CHART_SIDE: f32 = 2048.0;
/// Texels over all charts, at most (16 bytes each in three buffers). 7.5 Mi texels, so that an
/// atlas — with the percent or so that rounding chart sizes up may add — stays under the
/// 128 MiB one binding may hold on many adapters (lavapipe, WebGPU's defaults).
pub const MAX_ATLAS_TEXELS: f32 = 7.5 * 1024.0 * 1024.0;

/// Chart slot of a direction: 2·axis + (0 for +, 1 for −); dominant-axis ties resolve to x,
/// then y, exactly as `chart_for` in WGSL.
pub fn direction_slot(d: Vec3) -> usize {
    let a = d.abs();
    let axis = if a.x >= a.y && a.x >= a.z { 0 } else if a.y >= a.z { 1 } else { 2 };
    2 * axis + usize::from(d[axis] <= 0.0)
}

/// The two world axes a chart of `slot` spans.
fn chart_axes(slot: usize) -> (usize, usize) {
    let axis = (slot % 6) / 2;
    ((axis + 1) % 3, (axis + 2) % 3)
}

/// The world-space triangles of a receiver.
fn world_triangles(r: &Receiver, index: u32) -> Vec<Triangle> {
    let p: Vec<Vec3> = r.mesh.positions.iter().map(|v| r.world.transform_point3(*v)).collect();
    r.mesh
        .triangles
        .iter()
        .enumerate()
        .filter(|(_, t)| t.iter().all(|&i| (i as usize) < p.len()))
        .map(|(k, t)| Triangle { v: t.map(|i| p[i as usize]), receiver: index, index: k as u32 })
        .collect()
}

/// The texture coordinates of a receiver mesh, when it has a texture to use them for.
fn textured(r: &Receiver) -> Option<(&crate::scene::Texture2d, &[Vec2])> {
    let t = r.diffuse.texture.as_deref()?;
    let uvs = r.mesh.uvs.as_deref().filter(|uv| uv.len() == r.mesh.positions.len())?;
    (t.width > 0 && t.height > 0).then_some((t, uvs))
}

fn is_interface(t: &Triangle) -> bool {
    t.receiver & interface_kind::BIT != 0
}

/// Per BVH triangle (in leaf order), its corners' texture coordinates as two vec4s:
/// (uv₀, uv₁), (uv₂, 0, 0); zeros for untextured receivers and interfaces.
fn triangle_uvs(bvh: &Bvh, receivers: &[Receiver]) -> Vec<[f32; 4]> {
    let mut out = Vec::with_capacity(2 * bvh.triangles.len());
    for t in &bvh.triangles {
        let receiver = (!is_interface(t)).then(|| &receivers[t.receiver as usize]);
        let corners = receiver.and_then(|r| textured(r).map(|(_, uv)| r.mesh.triangles[t.index as usize].map(|i| uv[i as usize])));
        let corners = corners.unwrap_or([Vec2::ZERO; 3]);
        out.push([corners[0].x, corners[0].y, corners[1].x, corners[1].y]);
        out.push([corners[2].x, corners[2].y, 0.0, 0.0]);
    }
    out
}

/// Per BVH triangle (in leaf order), the unit shading normals at its three corners, one vec4
/// each: a sharp mesh's smooth normals, a receiver's face normal.
fn triangle_normals(bvh: &Bvh, interface_normals: &[[Vec3; 3]]) -> Vec<[f32; 4]> {
    bvh.triangles
        .iter()
        .flat_map(|t| if is_interface(t) { interface_normals[t.index as usize] } else { [t.normal().normalize(); 3] })
        .map(|n| n.extend(0.0).to_array())
        .collect()
}

/// A linear color as the 8-bit sRGB RGBA texel the GPU decodes (`unpack4x8unorm`, then the
/// inverse transfer function): the base color textures' own encoding, 4 bytes a texel.
fn srgb8(c: [f32; 4]) -> u32 {
    let byte = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u32;
    let e = |x: f32| byte(crate::output::png::srgb_encode(x));
    e(c[0]) | e(c[1]) << 8 | e(c[2]) << 16 | byte(c[3]) << 24
}

/// CPU-side layout of the receivers: what goes into the GPU buffers.
pub struct ReceiverLayout {
    pub bvh: Bvh,
    pub receivers: Vec<ReceiverGpu>,
    pub charts: Vec<Chart>,
    pub texels: u32,
    /// Two vec4 of texture coordinates per BVH triangle (see `triangle_uvs`).
    pub triangle_uvs: Vec<[f32; 4]>,
    /// Three vec4 of corner normals per BVH triangle (see `triangle_normals`).
    pub triangle_normals: Vec<[f32; 4]>,
    /// Every base color texture's texels, sRGB8-packed, one after another.
    pub albedo_texels: Vec<u32>,
}

/// Lays out BVH and charts; `texel` is the wanted texel size (metres), grown where a chart or
/// the whole atlas would be too large. `interfaces` are the sharp meshes' triangles and corner
/// normals (`interfaces::triangles`): they join the BVH but get no charts.
pub fn layout(receivers: &[Receiver], interfaces: (Vec<Triangle>, Vec<[Vec3; 3]>), texel: f32) -> ReceiverLayout {
    let mut triangles = Vec::new();
    // (receiver, slot) → bounds in the chart's two axes.
    let mut extents: Vec<[Option<(Vec2, Vec2)>; 12]> = vec![[None; 12]; receivers.len()];
    for (i, r) in receivers.iter().enumerate() {
        for t in world_triangles(r, i as u32) {
            let n = t.normal();
            if !n.is_finite() || n.length_squared() == 0.0 {
                continue;
            }
            for slot in [direction_slot(n), 6 + direction_slot(-n)] {
                let (u, v) = chart_axes(slot);
                for p in t.v {
                    let q = Vec2::new(p[u], p[v]);
                    let e = extents[i][slot].get_or_insert((q, q));
                    *e = (e.0.min(q), e.1.max(q));
                }
            }
            triangles.push(t);
        }
    }
    let (interface_triangles, interface_normals) = interfaces;
    triangles.extend(interface_triangles);
    let bvh = Bvh::build(triangles);
    // Grow the texel where one chart would be too long, then every chart's by one factor if the
    // atlas is too big (growing only the wanted size would not shrink charts already capped).
    let base = texel.max(1e-6);
    let capped = |lo: Vec2, hi: Vec2| base.max((hi - lo).max_element() / MAX_CHART_SIDE);
    let total: f32 = extents
        .iter()
        .flatten()
        .flatten()
        .map(|&(lo, hi)| ((hi - lo) / capped(lo, hi) + 2.0).ceil().element_product())
        .sum();
    let shrink = if total > MAX_ATLAS_TEXELS { (total / MAX_ATLAS_TEXELS).sqrt() * 1.01 } else { 1.0 };
    let texel_for = |lo: Vec2, hi: Vec2| capped(lo, hi) * shrink;
    let mut charts = Vec::new();
    let mut table = Vec::with_capacity(receivers.len());
    let mut offset = 0u32;
    let mut albedo_texels = Vec::new();
    // Receivers sharing a texture share its texels.
    let mut placed: Vec<(*const crate::scene::Texture2d, u32)> = Vec::new();
    for (i, r) in receivers.iter().enumerate() {
        let mut slots = [-1i32; 12];
        for (slot, e) in extents[i].iter().enumerate() {
            let Some((lo, hi)) = *e else { continue };
            let t = texel_for(lo, hi);
            // One texel of margin on each side: deposits at the edge stay inside.
            let size = ((hi - lo) / t + 2.0).ceil().as_uvec2().max(glam::UVec2::ONE);
            slots[slot] = charts.len() as i32;
            charts.push(Chart {
                origin: (lo - Vec2::splat(t)).into(),
                texel: t,
                axis: (slot % 6) as u32,
                width: size.x,
                height: size.y,
                offset,
                _pad0: 0,
            });
            offset += size.x * size.y;
        }
        let (texture, size) = match textured(r) {
            Some((t, _)) => {
                let start = match placed.iter().find(|(p, _)| std::ptr::eq(*p, t)) {
                    Some(&(_, start)) => start,
                    None => {
                        let start = albedo_texels.len() as u32;
                        albedo_texels.extend(t.texels.iter().map(|&c| srgb8(c)));
                        placed.push((t, start));
                        start
                    }
                };
                (start, [t.width, t.height])
            }
            None => (0, [0, 0]),
        };
        table.push(ReceiverGpu {
            albedo: r.diffuse.color.into(),
            texture,
            charts_a: slots[0..4].try_into().expect("4"),
            charts_b: slots[4..8].try_into().expect("4"),
            charts_c: slots[8..12].try_into().expect("4"),
            texture_width: size[0],
            texture_height: size[1],
            _pad0: 0,
            _pad1: 0,
        });
    }
    let triangle_uvs = triangle_uvs(&bvh, receivers);
    let triangle_normals = triangle_normals(&bvh, &interface_normals);
    ReceiverLayout { bvh, receivers: table, charts, texels: offset, triangle_uvs, triangle_normals, albedo_texels }
}

/// The receivers' GPU buffers and the caustic maps sized by their charts. Buffers only grow:
/// moving receivers re-upload, they do not reallocate.
pub struct Receivers {
    pub bvh_nodes: GrowableBuffer,
    pub bvh_triangles: GrowableBuffer,
    pub receivers: GrowableBuffer,
    pub charts: GrowableBuffer,
    /// Texture coordinates of the BVH triangles and the base color texels (view stage).
    pub triangle_uvs: GrowableBuffer,
    /// Corner normals of the BVH triangles (interfaces' shading normals).
    pub triangle_normals: GrowableBuffer,
    /// The sharp interfaces' records (`pipeline::interfaces::table`), written every frame.
    pub interfaces: GrowableBuffer,
    pub albedo_texels: GrowableBuffer,
    /// 4 u32 per texel: photon count, flux r, g, b (fixed point), written by the march stage.
    pub caustic_atlas: GrowableBuffer,
    /// Summed-area table of the atlas (caustics stage).
    pub caustic_sat: GrowableBuffer,
    /// Filtered irradiance per texel (caustics stage → view stage).
    pub caustic_irradiance: GrowableBuffer,
    pub layout: ReceiverLayout,
    /// Changes when a buffer was reallocated (consumers rebind).
    pub generation: u64,
    key: Option<(Vec<ReceiverKey>, Vec<(usize, glam::Mat4)>)>,
}

/// What identifies a receiver: its mesh and texture by pointer, placement, albedo bits.
type ReceiverKey = (usize, usize, glam::Mat4, [u32; 3]);

/// What identifies the receivers of a frame.
fn key_of(desc: &FrameDesc, texel: f32) -> Vec<ReceiverKey> {
    let mut key: Vec<_> = desc
        .receivers
        .iter()
        .map(|r| {
            let texture = r.diffuse.texture.as_ref().map_or(0, |t| std::sync::Arc::as_ptr(t) as usize);
            (std::sync::Arc::as_ptr(&r.mesh) as usize, texture, r.world, r.diffuse.color.to_array().map(f32::to_bits))
        })
        .collect();
    key.push((0, 0, glam::Mat4::from_scale(Vec3::splat(texel)), [0; 3]));
    key
}

impl Receivers {
    /// The chart texel for a frame: half a voxel of the volume, where caustics are sharpest.
    pub fn texel_for(desc: &FrameDesc) -> f32 {
        0.5 * desc.volume.voxel_size
    }

    pub fn new(device: &wgpu::Device) -> Self {
        let buffer = |label| GrowableBuffer::new(device, label, 64);
        Self {
            bvh_nodes: buffer("bvh nodes"),
            bvh_triangles: buffer("bvh triangles"),
            receivers: buffer("receivers"),
            charts: buffer("charts"),
            triangle_uvs: buffer("triangle uvs"),
            triangle_normals: buffer("triangle normals"),
            interfaces: buffer("interfaces"),
            albedo_texels: buffer("albedo texels"),
            caustic_atlas: buffer("caustic atlas"),
            caustic_sat: buffer("caustic sat"),
            caustic_irradiance: buffer("caustic irradiance"),
            layout: layout(&[], Default::default(), 1.0),
            generation: super::resources::next_generation(),
            key: None,
        }
    }

    /// Uploads this frame's receivers if they changed; true if they did.
    pub fn update(&mut self, ctx: &GpuContext, desc: &FrameDesc) -> bool {
        let table = interfaces::table(desc);
        if self.interfaces.write(ctx, bytemuck::cast_slice(&table)) {
            self.generation = super::resources::next_generation();
        }
        let texel = Self::texel_for(desc);
        let key = (key_of(desc, texel), interfaces::mesh_key(desc));
        if self.key.as_ref() == Some(&key) {
            return false;
        }
        self.layout = layout(&desc.receivers, interfaces::triangles(desc), texel);
        let mut nodes = self.layout.bvh.nodes.clone();
        if self.layout.bvh.triangles.is_empty() {
            nodes = vec![BvhNode::default()]; // first = 0, count = 0: the empty tree
        }
        let triangles: Vec<BvhTriangle> = self.layout.bvh.gpu_triangles();
        let texel_bytes = self.layout.texels.max(1) as u64 * 16;
        let mut grown = self.bvh_nodes.write(ctx, bytemuck::cast_slice(&nodes));
        grown |= self.bvh_triangles.write(ctx, bytemuck::cast_slice(&triangles));
        // Empty arrays still bind a buffer of at least one element.
        let table = if self.layout.receivers.is_empty() { vec![ReceiverGpu::default()] } else { self.layout.receivers.clone() };
        grown |= self.receivers.write(ctx, bytemuck::cast_slice(&table));
        grown |= self.charts.write(ctx, bytemuck::cast_slice(&self.layout.charts));
        let uvs = if self.layout.triangle_uvs.is_empty() { vec![[0.0f32; 4]] } else { self.layout.triangle_uvs.clone() };
        grown |= self.triangle_uvs.write(ctx, bytemuck::cast_slice(&uvs));
        let normals = if self.layout.triangle_normals.is_empty() { vec![[0.0f32; 4]] } else { self.layout.triangle_normals.clone() };
        grown |= self.triangle_normals.write(ctx, bytemuck::cast_slice(&normals));
        let texels = if self.layout.albedo_texels.is_empty() { vec![0u32] } else { self.layout.albedo_texels.clone() };
        grown |= self.albedo_texels.write(ctx, bytemuck::cast_slice(&texels));
        grown |= self.caustic_atlas.reserve(ctx, texel_bytes);
        grown |= self.caustic_sat.reserve(ctx, texel_bytes);
        grown |= self.caustic_irradiance.reserve(ctx, texel_bytes);
        if grown {
            self.generation = super::resources::next_generation();
        }
        self.key = Some(key);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Diffuse, mesh};
    use std::sync::Arc;

    fn receiver(m: crate::scene::MeshData, world: glam::Mat4) -> Receiver {
        Receiver { name: "r".into(), mesh: Arc::new(m), world, diffuse: Diffuse::default() }
    }

    #[test]
    fn a_floor_gets_one_chart_per_side_a_box_twelve() {
        let floor = receiver(mesh::plane(Vec2::new(4.0, 2.0)), glam::Mat4::IDENTITY);
        let l = layout(&[floor], Default::default(), 0.01);
        // Top (+Y front) and bottom (the back of the same triangles, facing −Y).
        assert_eq!(l.charts.len(), 2);
        let top = &l.charts[l.receivers[0].charts_a[2] as usize];
        assert_eq!(top.axis, 2);
        // A +Y chart spans (z, x): 2 m and 4 m at 1 cm, plus a texel of margin on each side.
        assert_eq!((top.width, top.height), (202, 402));
        let cube = receiver(mesh::cuboid(Vec3::ONE), glam::Mat4::IDENTITY);
        assert_eq!(layout(&[cube], Default::default(), 0.01).charts.len(), 12);
    }

    #[test]
    fn slots_match_the_dominant_axis() {
        assert_eq!(direction_slot(Vec3::new(0.1, 0.9, 0.2)), 2);
        assert_eq!(direction_slot(Vec3::new(0.1, -0.9, 0.2)), 3);
        assert_eq!(direction_slot(Vec3::new(-0.7, 0.1, 0.7)), 1, "ties go to x");
    }

    #[test]
    fn huge_receivers_are_capped() {
        let floor = receiver(mesh::plane(Vec2::new(1000.0, 1000.0)), glam::Mat4::IDENTITY);
        let l = layout(&[floor], Default::default(), 0.001);
        assert!(l.texels as f32 <= MAX_ATLAS_TEXELS * 1.01, "{} texels", l.texels);
        assert!(l.charts.iter().all(|c| c.width as f32 <= MAX_CHART_SIDE + 3.0));
    }
}
