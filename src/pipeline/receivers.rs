//! The opaque receivers on the GPU: their triangles in a BVH, their albedo, and the caustic
//! charts refracted photons land in (`shaders/shared/receivers.wgsl`).
//!
//! A chart is a world-axis-aligned grid of texels over the triangles of one receiver whose
//! surfaces face one of the six axis directions, on one side (front faces, or back faces — the
//! inside of a room). Planes, boxes and walls map onto charts exactly; curved receivers are
//! split by the direction they face, like a cube map, so surfaces of one receiver that face the
//! same way and overlap in projection share texels (a documented limit, rare for floors and
//! walls). Charts are rebuilt only when the receivers change.

use anyhow::Result;
use glam::{Vec2, Vec3};

use crate::bvh::{Bvh, Triangle};
use crate::frame::{FrameDesc, Receiver};
use crate::gpu::GpuContext;
use crate::gpu::types::{BvhNode, BvhTriangle, Chart, ReceiverGpu};

/// Texels along the longest side of one chart, at most.
pub const MAX_CHART_SIDE: f32 = 2048.0;
/// Texels over all charts, at most (16 bytes each in three buffers).
pub const MAX_ATLAS_TEXELS: f32 = 8.0 * 1024.0 * 1024.0;

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
        .filter(|t| t.iter().all(|&i| (i as usize) < p.len()))
        .map(|t| Triangle { v: t.map(|i| p[i as usize]), receiver: index })
        .collect()
}

/// CPU-side layout of the receivers: what goes into the GPU buffers.
pub struct ReceiverLayout {
    pub bvh: Bvh,
    pub receivers: Vec<ReceiverGpu>,
    pub charts: Vec<Chart>,
    pub texels: u32,
}

/// Lays out BVH and charts; `texel` is the wanted texel size (metres), grown where a chart or
/// the whole atlas would be too large.
pub fn layout(receivers: &[Receiver], texel: f32) -> ReceiverLayout {
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
    let bvh = Bvh::build(triangles);
    // Grow the texel where one chart would be too long, then everywhere if the atlas is too big.
    let texel_for = |lo: Vec2, hi: Vec2, base: f32| base.max((hi - lo).max_element() / MAX_CHART_SIDE);
    let count = |base: f32| -> f32 {
        extents.iter().flatten().flatten().map(|&(lo, hi)| {
            let t = texel_for(lo, hi, base);
            ((hi - lo) / t + 2.0).ceil().element_product()
        }).sum()
    };
    let mut base = texel.max(1e-6);
    let total = count(base);
    if total > MAX_ATLAS_TEXELS {
        base *= (total / MAX_ATLAS_TEXELS).sqrt() * 1.01;
    }
    let mut charts = Vec::new();
    let mut table = Vec::with_capacity(receivers.len());
    let mut offset = 0u32;
    for (i, r) in receivers.iter().enumerate() {
        let mut slots = [-1i32; 12];
        for (slot, e) in extents[i].iter().enumerate() {
            let Some((lo, hi)) = *e else { continue };
            let t = texel_for(lo, hi, base);
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
        table.push(ReceiverGpu {
            albedo: r.diffuse.color.into(),
            _pad0: 0,
            charts_a: slots[0..4].try_into().expect("4"),
            charts_b: slots[4..8].try_into().expect("4"),
            charts_c: slots[8..12].try_into().expect("4"),
        });
    }
    ReceiverLayout { bvh, receivers: table, charts, texels: offset }
}

/// The receivers' GPU buffers and the caustic maps sized by their charts.
pub struct Receivers {
    pub bvh_nodes: wgpu::Buffer,
    pub bvh_triangles: wgpu::Buffer,
    pub receivers: wgpu::Buffer,
    pub charts: wgpu::Buffer,
    /// 4 u32 per texel: photon count, flux r, g, b (fixed point), written by the march stage.
    pub caustic_atlas: wgpu::Buffer,
    /// Summed-area table of the atlas (caustics stage).
    pub caustic_sat: wgpu::Buffer,
    /// Filtered irradiance per texel (caustics stage → view stage).
    pub caustic_irradiance: wgpu::Buffer,
    pub layout: ReceiverLayout,
    pub generation: u64,
    key: Vec<(usize, glam::Mat4, [u32; 3])>,
}

fn storage(ctx: &GpuContext, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: (bytes.len() as u64).max(64),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    ctx.queue.write_buffer(&buffer, 0, bytes);
    buffer
}

/// What identifies the receivers of a frame (meshes by pointer, placement, albedo bits).
fn key_of(desc: &FrameDesc, texel: f32) -> Vec<(usize, glam::Mat4, [u32; 3])> {
    let mut key: Vec<_> = desc
        .receivers
        .iter()
        .map(|r| (std::sync::Arc::as_ptr(&r.mesh) as usize, r.world, r.diffuse.color.to_array().map(f32::to_bits)))
        .collect();
    key.push((0, glam::Mat4::from_scale(Vec3::splat(texel)), [0; 3]));
    key
}

impl Receivers {
    /// The chart texel for a frame: half a voxel of the volume, where caustics are sharpest.
    pub fn texel_for(desc: &FrameDesc) -> f32 {
        0.5 * desc.volume.voxel_size
    }

    pub fn new(ctx: &GpuContext, desc: &FrameDesc) -> Result<Self> {
        let texel = Self::texel_for(desc);
        let layout = layout(&desc.receivers, texel);
        let mut nodes = layout.bvh.nodes.clone();
        if layout.bvh.triangles.is_empty() {
            nodes = vec![BvhNode::default()]; // first = 0, count = 0: the empty tree
        }
        let triangles: Vec<BvhTriangle> = layout.bvh.gpu_triangles();
        let texels = layout.texels.max(1) as u64;
        let zeros = |label: &str, size: u64| {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        Ok(Self {
            bvh_nodes: storage(ctx, "bvh nodes", bytemuck::cast_slice(&nodes)),
            bvh_triangles: storage(ctx, "bvh triangles", bytemuck::cast_slice(&triangles)),
            receivers: storage(ctx, "receivers", bytemuck::cast_slice(&layout.receivers)),
            charts: storage(ctx, "charts", bytemuck::cast_slice(&layout.charts)),
            caustic_atlas: zeros("caustic atlas", texels * 16),
            caustic_sat: zeros("caustic sat", texels * 16),
            caustic_irradiance: zeros("caustic irradiance", texels * 16),
            layout,
            generation: super::resources::next_generation(),
            key: key_of(desc, texel),
        })
    }

    /// Whether this frame's receivers differ from the ones uploaded.
    pub fn changed(&self, desc: &FrameDesc) -> bool {
        self.key != key_of(desc, Self::texel_for(desc))
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
        let l = layout(&[floor], 0.01);
        // Top (+Y front) and bottom (the back of the same triangles, facing −Y).
        assert_eq!(l.charts.len(), 2);
        let top = &l.charts[l.receivers[0].charts_a[2] as usize];
        assert_eq!(top.axis, 2);
        // A +Y chart spans (z, x): 2 m and 4 m at 1 cm, plus a texel of margin on each side.
        assert_eq!((top.width, top.height), (202, 402));
        let cube = receiver(mesh::cuboid(Vec3::ONE), glam::Mat4::IDENTITY);
        assert_eq!(layout(&[cube], 0.01).charts.len(), 12);
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
        let l = layout(&[floor], 0.001);
        assert!(l.texels as f32 <= MAX_ATLAS_TEXELS * 1.01, "{} texels", l.texels);
        assert!(l.charts.iter().all(|c| c.width as f32 <= MAX_CHART_SIDE + 3.0));
    }
}
