//! Lights on the GPU, and the emitters that say where each light's photons go (`Emitter` in
//! `shaders/shared/types.wgsl`, used by `shaders/photons.wgsl`).

use glam::Vec3;

use crate::frame::{FrameDesc, LightDesc, LightShape, VolumeDesc};
use crate::gpu::types::{ENV_LIGHT, Emitter, LightGpu, light_kind};

/// Cells per side of each light's photon raster (G×G importance cells).
pub const RASTER_CELLS: u32 = 64;

/// The light's record; `media`: the sharp interfaces around it (`interfaces::media_at`).
pub fn light_gpu(l: &LightDesc, media: [u32; 2]) -> LightGpu {
    let (kind, cos_outer, cos_inner, half_angle, size) = match l.shape {
        LightShape::Point => (light_kind::POINT, -1.0, -1.0, 0.0, glam::Vec2::ZERO),
        LightShape::Spot { cos_outer, cos_inner } => (light_kind::SPOT, cos_outer, cos_inner, 0.0, glam::Vec2::ZERO),
        LightShape::Sun { half_angle } => (light_kind::SUN, -1.0, -1.0, half_angle, glam::Vec2::ZERO),
        LightShape::Rect { size } => (light_kind::RECT, -1.0, -1.0, 0.0, size),
    };
    LightGpu {
        position: l.position.into(),
        kind,
        direction: l.direction.into(),
        cos_outer,
        right: l.right.into(),
        cos_inner,
        up: l.up.into(),
        half_angle,
        radiant: l.radiant.into(),
        size_x: size.x,
        size_y: size.y,
        radius: l.radius,
        media,
        ..Default::default()
    }
}

/// How far from the volume's centre the scene reaches: its bounding sphere's radius and the
/// farthest corner of any receiver's box. The environment's photons start beyond it, so
/// whatever stands between the sky and the glass — a room's walls, a ceiling — stops them as it
/// stops the shadow rays.
pub fn scene_reach(desc: &FrameDesc) -> f32 {
    let (lo, hi) = (desc.volume.min, desc.volume.max());
    let centre = 0.5 * (lo + hi);
    let mut reach = 0.5 * (hi - lo).length();
    for r in &desc.receivers {
        if let Some((a, b)) = r.mesh.bounds() {
            for corner in box_corners(a, b) {
                reach = reach.max((r.world.transform_point3(corner) - centre).length());
            }
        }
    }
    reach
}

/// The eight corners of the box (lo, hi).
fn box_corners(lo: Vec3, hi: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|i| Vec3::new(if i & 1 == 0 { lo.x } else { hi.x }, if i & 2 == 0 { lo.y } else { hi.y }, if i & 4 == 0 { lo.z } else { hi.z }))
}

/// Where a light's photons start: its position, or for the sun the plane across its direction
/// just outside the volume's bounding sphere (where its emitter raster lies, `emitter_for`).
/// (Unlike the environment's, the sun's photons start there, inside any room around the
/// volume: a room's walls do not stop them. Starting them beyond every receiver moves every sun
/// caustic by float rounding, and `tests/dispersion_off.rs` holds them to the bit.)
pub fn photon_start(l: &LightDesc, volume: &VolumeDesc) -> Vec3 {
    match l.shape {
        LightShape::Sun { .. } => {
            let (lo, hi) = (volume.min, volume.max());
            0.5 * (lo + hi) - l.direction * (0.5 * (hi - lo).length() * 1.01)
        }
        _ => l.position,
    }
}

/// Where light `index`'s photons can reach the volume: for the sun, the rectangle across its
/// direction that the box projects to; for point and spot lights, the cone of directions that
/// contains the box (the whole sphere from inside it), narrowed to the spot's cone when that is
/// smaller; for a rect light, its area (each photon leaves it toward the volume, `spread_ray`).
pub fn emitter_for(l: &LightDesc, index: u32, volume: &VolumeDesc, first_cell: u32) -> Option<Emitter> {
    let (lo, hi) = (volume.min, volume.max());
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * (hi - lo).length();
    let cells = (RASTER_CELLS * RASTER_CELLS) as f32;
    let corners = box_corners(lo, hi);
    match l.shape {
        LightShape::Rect { size } => Some(Emitter {
            origin: l.position.into(),
            light: index,
            axis: l.direction.into(),
            right: l.right.into(),
            half_width: 0.5 * size.x,
            up: l.up.into(),
            half_height: 0.5 * size.y,
            measure: size.x * size.y / cells,
            first_cell,
            ..Default::default()
        }),
        LightShape::Sun { .. } => {
            let axis = l.direction;
            let right = axis.any_orthonormal_vector();
            let up = axis.cross(right);
            let (mut rx, mut uy) = (0.0f32, 0.0f32);
            for c in &corners {
                rx = rx.max((*c - centre).dot(right).abs());
                uy = uy.max((*c - centre).dot(up).abs());
            }
            Some(Emitter {
                origin: photon_start(l, volume).into(),
                light: index,
                axis: axis.into(),
                cos_max: 1.0,
                right: right.into(),
                half_width: rx,
                up: up.into(),
                half_height: uy,
                measure: 4.0 * rx * uy / cells,
                first_cell,
                ..Default::default()
            })
        }
        LightShape::Point | LightShape::Spot { .. } => {
            let to_box = centre - l.position;
            let distance = to_box.length();
            let (mut axis, mut cos_max) = if distance > radius * 1.001 {
                (to_box / distance, (1.0 - (radius / distance).powi(2)).max(0.0).sqrt())
            } else {
                (Vec3::Y, -1.0)
            };
            if let LightShape::Spot { cos_outer, .. } = l.shape {
                // The smaller of the two cones: either contains every direction that matters.
                if 1.0 - cos_outer < 1.0 - cos_max {
                    (axis, cos_max) = (l.direction, cos_outer);
                }
            }
            let right = axis.any_orthonormal_vector();
            Some(Emitter {
                origin: l.position.into(),
                light: index,
                axis: axis.into(),
                cos_max,
                right: right.into(),
                up: axis.cross(right).into(),
                measure: std::f32::consts::TAU * (1.0 - cos_max) / cells,
                first_cell,
                ..Default::default()
            })
        }
    }
}

/// The environment's emitter: a disc of the volume's bounding-sphere radius, perpendicular to
/// each photon's direction and `reach` ([`scene_reach`]) back from the volume's centre, as the
/// sun's raster (`spread_ray` in shaders/photons.wgsl), its cells equal shares of its area.
/// None when the environment is dark. `integral`: ∫ L dω of the environment, scaled (W/m²
/// through the disc).
pub fn environment_emitter(integral: Vec3, volume: &VolumeDesc, reach: f32, first_cell: u32) -> Option<Emitter> {
    if integral.element_sum() <= 0.0 {
        return None;
    }
    let (lo, hi) = (volume.min, volume.max());
    let radius = 0.5 * (hi - lo).length();
    Some(Emitter {
        origin: (0.5 * (lo + hi)).into(),
        light: ENV_LIGHT,
        half_width: radius,
        start_distance: reach * 1.01,
        measure: std::f32::consts::PI * radius * radius / (RASTER_CELLS * RASTER_CELLS) as f32,
        first_cell,
        ..Default::default()
    })
}

/// Power (W, mean over channels) an emitter's raster covers at most: a scale for the photons'
/// fixed-point flux, not part of any estimate.
pub fn raster_power(e: &Emitter, l: &LightDesc, volume: &VolumeDesc) -> f32 {
    let mean = l.radiant.element_sum() / 3.0;
    // A rect light sends L × the solid angle of the volume's bounding sphere per unit area
    // toward it (at most; π·L from inside it), as `spread_power` weighs its cells.
    let per_measure = if let LightShape::Rect { .. } = l.shape {
        let (lo, hi) = (volume.min, volume.max());
        let (radius, distance) = (0.5 * (hi - lo).length(), (0.5 * (lo + hi) - l.position).length());
        let cone = if distance > radius * 1.001 { std::f32::consts::TAU * (1.0 - (1.0 - (radius / distance).powi(2)).sqrt()) } else { std::f32::consts::PI };
        cone * mean
    } else {
        mean
    };
    e.measure * (RASTER_CELLS * RASTER_CELLS) as f32 * per_measure
}

/// The frame's lights and emitters on the GPU (grown when a frame has more lights).
pub struct LightBuffers {
    pub lights: wgpu::Buffer,
    pub emitters: wgpu::Buffer,
    capacity: usize,
    pub light_count: u32,
    pub emitter_count: u32,
    /// Sum of the emitters' raster powers (W): the scale of the photons' flux.
    pub raster_power: f32,
    pub generation: u64,
}

impl LightBuffers {
    fn buffers(device: &wgpu::Device, capacity: usize) -> (wgpu::Buffer, wgpu::Buffer) {
        let make = |label, size: usize| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: (capacity * size) as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        (make("lights", std::mem::size_of::<LightGpu>()), make("emitters", std::mem::size_of::<Emitter>()))
    }

    pub fn new(device: &wgpu::Device) -> Self {
        let (lights, emitters) = Self::buffers(device, 4);
        Self {
            lights,
            emitters,
            capacity: 4,
            light_count: 0,
            emitter_count: 0,
            raster_power: 0.0,
            generation: super::resources::next_generation(),
        }
    }

    /// Uploads this frame's lights and their emitters, the environment's last.
    /// `media[i]`: the sharp interfaces around light i; `env_integral`: ∫ L dω of the
    /// environment (`EnvLightTable::integral` × its colour and intensity); `reach`:
    /// [`scene_reach`].
    pub fn update(&mut self, ctx: &crate::gpu::GpuContext, lights: &[LightDesc], media: &[[u32; 2]], volume: &VolumeDesc, env_integral: Vec3, reach: f32) {
        // One emitter per light at most, and the environment's.
        if lights.len() + 1 > self.capacity {
            self.capacity = (lights.len() + 1).next_power_of_two();
            (self.lights, self.emitters) = Self::buffers(&ctx.device, self.capacity);
            self.generation = super::resources::next_generation();
        }
        let gpu: Vec<LightGpu> = lights.iter().zip(media).map(|(l, m)| light_gpu(l, *m)).collect();
        let mut emitters = Vec::new();
        self.raster_power = 0.0;
        for (i, l) in lights.iter().enumerate() {
            let first = emitters.len() as u32 * RASTER_CELLS * RASTER_CELLS;
            if let Some(e) = emitter_for(l, i as u32, volume, first) {
                self.raster_power += raster_power(&e, l, volume);
                emitters.push(e);
            }
        }
        let first = emitters.len() as u32 * RASTER_CELLS * RASTER_CELLS;
        if let Some(e) = environment_emitter(env_integral, volume, reach, first) {
            self.raster_power += e.measure * (RASTER_CELLS * RASTER_CELLS) as f32 * env_integral.element_sum() / 3.0;
            emitters.push(e);
        }
        if !gpu.is_empty() {
            ctx.queue.write_buffer(&self.lights, 0, bytemuck::cast_slice(&gpu));
        }
        if !emitters.is_empty() {
            ctx.queue.write_buffer(&self.emitters, 0, bytemuck::cast_slice(&emitters));
        }
        self.light_count = gpu.len() as u32;
        self.emitter_count = emitters.len() as u32;
    }
}
