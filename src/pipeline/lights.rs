//! Lights on the GPU, and the emitters that say where each light's photons go (`Emitter` in
//! `shaders/shared/types.wgsl`, used by `shaders/photons.wgsl`).

use glam::Vec3;

use crate::frame::{LightDesc, LightShape, VolumeDesc};
use crate::gpu::types::{ENV_LIGHT, Emitter, LightGpu, LightTriangle, light_kind};

/// Cells per side of each light's photon raster (G×G importance cells).
pub const RASTER_CELLS: u32 = 64;

/// The light's record; `media`: the sharp interfaces around it (`interfaces::media_at`).
pub fn light_gpu(l: &LightDesc, media: [u32; 2]) -> LightGpu {
    let (kind, cos_outer, cos_inner, half_angle, size) = match l.shape {
        LightShape::Point => (light_kind::POINT, -1.0, -1.0, 0.0, glam::Vec2::ZERO),
        LightShape::Spot { cos_outer, cos_inner } => (light_kind::SPOT, cos_outer, cos_inner, 0.0, glam::Vec2::ZERO),
        LightShape::Sun { half_angle } => (light_kind::SUN, -1.0, -1.0, half_angle, glam::Vec2::ZERO),
        LightShape::Rect { size, round: false } => (light_kind::RECT, -1.0, -1.0, 0.0, size),
        LightShape::Rect { size, round: true } => (light_kind::DISK, -1.0, -1.0, 0.0, size),
        LightShape::Mesh { .. } => (light_kind::MESH, -1.0, -1.0, 0.0, glam::Vec2::ZERO),
    };
    let (first_triangle, triangle_count, area, sides) = match l.shape {
        LightShape::Mesh { first, count, area, closed, .. } => (first, count, area, if closed { 1 } else { 2 }),
        _ => (0, 0, 0.0, 0),
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
        first_triangle,
        triangle_count,
        area,
        sides,
        visible: l.visible.into(),
        rough_sampled: (!matches!(l.shape, LightShape::Mesh { patterned: true, .. })).into(),
        _pad1: 0,
        _pad2: 0,
    }
}

/// Whether the light has an area its photons leave from (rect, disk, glowing mesh), each point
/// a Lambertian emitter of radiance `radiant`.
fn has_area(l: &LightDesc) -> bool {
    matches!(l.shape, LightShape::Rect { .. } | LightShape::Mesh { .. })
}

/// How far from the volume's centre the scene reaches: its bounding sphere's radius and the
/// farthest corner of `surfaces`, the world box of every receiver and glass mesh (the BVH's
/// root). The environment's photons start beyond it, so whatever stands between the sky and the
/// glass — a room's walls, a ceiling — stops them as it stops the shadow rays.
pub fn scene_reach(volume: &VolumeDesc, surfaces: Option<(Vec3, Vec3)>) -> f32 {
    let (lo, hi) = (volume.min, volume.max());
    let centre = 0.5 * (lo + hi);
    let corners = surfaces.map(|(a, b)| box_corners(a, b)).unwrap_or_default();
    corners.iter().map(|c| (*c - centre).length()).fold(0.5 * (hi - lo).length(), f32::max)
}

/// The eight corners of the box (lo, hi).
fn box_corners(lo: Vec3, hi: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|i| Vec3::new(if i & 1 == 0 { lo.x } else { hi.x }, if i & 2 == 0 { lo.y } else { hi.y }, if i & 4 == 0 { lo.z } else { hi.z }))
}

/// Where a light's photons start: its position, a glowing mesh's surface just off its glowing
/// side, or for the sun the plane across its direction just outside the volume's bounding
/// sphere (where its emitter raster lies, `emitter_for`).
/// (Unlike the environment's, the sun's photons start there, inside any room around the
/// volume: a room's walls do not stop them. Starting them beyond every receiver moves every sun
/// caustic by float rounding, and `tests/dispersion_off.rs` holds them to the bit.)
pub fn photon_start(l: &LightDesc, volume: &VolumeDesc) -> Vec3 {
    match l.shape {
        LightShape::Sun { .. } => {
            let (lo, hi) = (volume.min, volume.max());
            0.5 * (lo + hi) - l.direction * (0.5 * (hi - lo).length() * 1.01)
        }
        LightShape::Mesh { outside, .. } => outside,
        _ => l.position,
    }
}

/// Where light `index`'s photons can reach the volume: for the sun, the rectangle across its
/// direction that the box projects to; for point and spot lights, the cone of directions that
/// contains the box (the whole sphere from inside it), narrowed to the spot's cone when that is
/// smaller; for a rect light, its area (each photon leaves it toward the volume, `spread_ray`);
/// for a glowing mesh, the sides of its surface it glows on.
pub fn emitter_for(l: &LightDesc, index: u32, volume: &VolumeDesc, first_cell: u32) -> Option<Emitter> {
    let (lo, hi) = (volume.min, volume.max());
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * (hi - lo).length();
    let cells = (RASTER_CELLS * RASTER_CELLS) as f32;
    let corners = box_corners(lo, hi);
    match l.shape {
        LightShape::Rect { size, round } => Some(rect_emitter(l, index, size, round, first_cell)),
        LightShape::Mesh { area, closed, .. } => Some(mesh_emitter(l, index, area, closed, first_cell)),
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
            Some(cone_emitter(l, index, axis, cos_max, first_cell))
        }
    }
}

/// A point or spot light's emitter: the cap of directions within acos(cos_max) of `axis` from
/// its position, in equal cells (the whole sphere at cos_max = −1).
fn cone_emitter(l: &LightDesc, index: u32, axis: Vec3, cos_max: f32, first_cell: u32) -> Emitter {
    let right = axis.any_orthonormal_vector();
    Emitter {
        origin: l.position.into(),
        light: index,
        axis: axis.into(),
        cos_max,
        right: right.into(),
        up: axis.cross(right).into(),
        measure: std::f32::consts::TAU * (1.0 - cos_max) / (RASTER_CELLS * RASTER_CELLS) as f32,
        first_cell,
        ..Default::default()
    }
}

/// A rect (or, `round`, a disk's) light's emitter: its area, in equal cells (its photons'
/// directions are drawn per photon, `spread_ray` in shaders/photons.wgsl).
fn rect_emitter(l: &LightDesc, index: u32, size: glam::Vec2, round: bool, first_cell: u32) -> Emitter {
    let area = size.x * size.y * if round { std::f32::consts::FRAC_PI_4 } else { 1.0 };
    Emitter {
        origin: l.position.into(),
        light: index,
        axis: l.direction.into(),
        right: l.right.into(),
        half_width: 0.5 * size.x,
        up: l.up.into(),
        half_height: 0.5 * size.y,
        measure: area / (RASTER_CELLS * RASTER_CELLS) as f32,
        first_cell,
        ..Default::default()
    }
}

/// A glowing mesh's emitter: the sides of its surface it glows on, in equal cells
/// (`mesh_light_side_point` in shaders/shared/mesh_light.wgsl maps a cell to a side and a point;
/// directions per photon, as a rect's).
fn mesh_emitter(l: &LightDesc, index: u32, area: f32, closed: bool, first_cell: u32) -> Emitter {
    let sides = if closed { 1.0 } else { 2.0 };
    Emitter {
        origin: l.position.into(),
        light: index,
        axis: l.direction.into(),
        right: l.right.into(),
        up: l.up.into(),
        measure: sides * area / (RASTER_CELLS * RASTER_CELLS) as f32,
        first_cell,
        ..Default::default()
    }
}

/// The environment's emitter: a disc of radius `radius` about `centre` (the volume's bounding
/// sphere for caustics, the scene's for bounced light), perpendicular to each photon's
/// direction and `reach` ([`scene_reach`]) back from `centre`, as the sun's raster
/// (`spread_ray` in shaders/photons.wgsl), its cells equal shares of its area. None when the
/// environment is dark. `integral`: ∫ L dω of the environment, scaled (W/m² through the disc).
pub fn environment_emitter(integral: Vec3, centre: Vec3, radius: f32, reach: f32, first_cell: u32) -> Option<Emitter> {
    if integral.element_sum() <= 0.0 {
        return None;
    }
    Some(Emitter {
        origin: centre.into(),
        light: ENV_LIGHT,
        half_width: radius,
        start_distance: reach * 1.01,
        measure: std::f32::consts::PI * radius * radius / (RASTER_CELLS * RASTER_CELLS) as f32,
        first_cell,
        ..Default::default()
    })
}

/// Where light `index`'s photons go for bounced light: everywhere it shines, not only toward
/// the volume. A point light's whole sphere (a spot's cone); the sun's square across its
/// direction as wide as the scene (`reach` about `centre`), starting outside it; a rect light's
/// area, its photons cosine-weighted over its hemisphere (photons.wgsl, `bounce_raster` and `rect_cone`).
pub fn bounce_emitter_for(l: &LightDesc, index: u32, centre: Vec3, reach: f32, first_cell: u32) -> Emitter {
    let cells = (RASTER_CELLS * RASTER_CELLS) as f32;
    let frame = |axis: Vec3| {
        let right = axis.any_orthonormal_vector();
        (right, axis.cross(right))
    };
    match l.shape {
        // cos_max −2: its photons leave over the whole hemisphere (photons.wgsl, `rect_cone`).
        LightShape::Rect { size, round } => Emitter { cos_max: -2.0, ..rect_emitter(l, index, size, round, first_cell) },
        LightShape::Mesh { area, closed, .. } => Emitter { cos_max: -2.0, ..mesh_emitter(l, index, area, closed, first_cell) },
        LightShape::Sun { .. } => {
            let (right, up) = frame(l.direction);
            Emitter {
                origin: (centre - l.direction * reach * 1.01).into(),
                light: index,
                axis: l.direction.into(),
                cos_max: 1.0,
                right: right.into(),
                half_width: reach,
                up: up.into(),
                half_height: reach,
                measure: 4.0 * reach * reach / cells,
                first_cell,
                ..Default::default()
            }
        }
        LightShape::Point | LightShape::Spot { .. } => {
            let (axis, cos_max) = match l.shape {
                LightShape::Spot { cos_outer, .. } => (l.direction, cos_outer),
                _ => (Vec3::Y, -1.0),
            };
            cone_emitter(l, index, axis, cos_max, first_cell)
        }
    }
}

/// Power (W, mean over channels) an emitter's raster covers at most: a scale for the photons'
/// fixed-point flux, not part of any estimate.
pub fn raster_power(e: &Emitter, l: &LightDesc, volume: &VolumeDesc) -> f32 {
    let mean = l.radiant.element_sum() / 3.0;
    // A rect light sends L × the solid angle of the volume's bounding sphere per unit area
    // toward it (at most; π·L from inside it), as `spread_power` weighs its cells.
    let per_measure = if has_area(l) {
        let (lo, hi) = (volume.min, volume.max());
        let (radius, distance) = (0.5 * (hi - lo).length(), (0.5 * (lo + hi) - l.position).length());
        let cone = if distance > radius * 1.001 { std::f32::consts::TAU * (1.0 - (1.0 - (radius / distance).powi(2)).sqrt()) } else { std::f32::consts::PI };
        cone * mean
    } else {
        mean
    };
    e.measure * (RASTER_CELLS * RASTER_CELLS) as f32 * per_measure
}

/// Power (W, mean over channels) a bounce emitter's raster covers at most (`bounce_emitter_for`):
/// an area light's π·L per unit area, the others' power per unit measure as for caustics.
pub fn bounce_raster_power(e: &Emitter, l: &LightDesc) -> f32 {
    let per_measure = l.radiant.element_sum() / 3.0 * if has_area(l) { std::f32::consts::PI } else { 1.0 };
    e.measure * (RASTER_CELLS * RASTER_CELLS) as f32 * per_measure
}

/// Power (W, mean over channels) the environment's raster covers: its disc's area × ∫ L dω.
fn environment_raster_power(e: &Emitter, integral: Vec3) -> f32 {
    e.measure * (RASTER_CELLS * RASTER_CELLS) as f32 * integral.element_sum() / 3.0
}

/// The frame's lights and emitters on the GPU (grown when a frame has more lights): the
/// caustic emitters (toward the volume) first, then the bounce emitters (everywhere).
pub struct LightBuffers {
    pub lights: wgpu::Buffer,
    pub emitters: wgpu::Buffer,
    /// The glowing meshes' triangles (`mesh_lights`; one unused record where there are none).
    pub triangles: wgpu::Buffer,
    capacity: usize,
    triangle_capacity: usize,
    pub light_count: u32,
    /// Glowing meshes: the last of the `light_count` lights.
    pub glowing_count: u32,
    /// Caustic emitters: `emitters[0..emitter_count]`.
    pub emitter_count: u32,
    /// Bounce emitters: `emitters[emitter_count..emitter_count + bounce_emitter_count]`.
    pub bounce_emitter_count: u32,
    /// Sum of the caustic emitters' raster powers (W): the scale of the photons' flux.
    pub raster_power: f32,
    /// The same for the bounce emitters.
    pub bounce_raster_power: f32,
    pub generation: u64,
}

/// What the environment gives the emitters: ∫ L dω (`EnvLightTable::integral` × its colour
/// and intensity), and whether it sends caustic photons too (only where glass, fields or fog can
/// bend or scatter them; its direct light is the receivers' shadow rays).
#[derive(Clone, Copy, Debug)]
pub struct EnvEmission {
    pub integral: Vec3,
    pub caustics: bool,
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
        (make("lights", std::mem::size_of::<LightGpu>()), make("emitters", 2 * std::mem::size_of::<Emitter>()))
    }

    fn triangle_buffer(device: &wgpu::Device, capacity: usize) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("light triangles"),
            size: (capacity * std::mem::size_of::<LightTriangle>()) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    pub fn new(device: &wgpu::Device) -> Self {
        let (lights, emitters) = Self::buffers(device, 4);
        Self {
            lights,
            emitters,
            triangles: Self::triangle_buffer(device, 1),
            capacity: 4,
            triangle_capacity: 1,
            light_count: 0,
            glowing_count: 0,
            emitter_count: 0,
            bounce_emitter_count: 0,
            raster_power: 0.0,
            bounce_raster_power: 0.0,
            generation: super::resources::next_generation(),
        }
    }

    /// Uploads this frame's lights and their emitters, the environment's last in each set, and
    /// the glowing meshes' `triangles` where they changed (empty: the last ones stand).
    /// `media[i]`: the sharp interfaces around light i; `reach`: [`scene_reach`]; `bounce`:
    /// whether the frame traces bounced light (else no bounce emitters).
    #[allow(clippy::too_many_arguments)]
    pub fn update(
        &mut self,
        ctx: &crate::gpu::GpuContext,
        lights: &[LightDesc],
        triangles: &[LightTriangle],
        media: &[[u32; 2]],
        volume: &VolumeDesc,
        env: EnvEmission,
        reach: f32,
        bounce: bool,
    ) {
        if triangles.len() > self.triangle_capacity {
            self.triangle_capacity = triangles.len().next_power_of_two();
            self.triangles = Self::triangle_buffer(&ctx.device, self.triangle_capacity);
            self.generation = super::resources::next_generation();
        }
        if !triangles.is_empty() {
            ctx.queue.write_buffer(&self.triangles, 0, bytemuck::cast_slice(triangles));
        }
        // One emitter per light at most, and the environment's, in each set.
        if lights.len() + 1 > self.capacity {
            self.capacity = (lights.len() + 1).next_power_of_two();
            (self.lights, self.emitters) = Self::buffers(&ctx.device, self.capacity);
            self.generation = super::resources::next_generation();
        }
        let gpu: Vec<LightGpu> = lights.iter().zip(media).map(|(l, m)| light_gpu(l, *m)).collect();
        let cells = RASTER_CELLS * RASTER_CELLS;
        let (lo, hi) = (volume.min, volume.max());
        let centre = 0.5 * (lo + hi);
        let mut emitters = Vec::new();
        self.raster_power = 0.0;
        for (i, l) in lights.iter().enumerate() {
            if let Some(e) = emitter_for(l, i as u32, volume, emitters.len() as u32 * cells) {
                self.raster_power += raster_power(&e, l, volume);
                emitters.push(e);
            }
        }
        let env_integral = if env.caustics { env.integral } else { Vec3::ZERO };
        if let Some(e) = environment_emitter(env_integral, centre, 0.5 * (hi - lo).length(), reach, emitters.len() as u32 * cells) {
            self.raster_power += environment_raster_power(&e, env_integral);
            emitters.push(e);
        }
        self.emitter_count = emitters.len() as u32;
        // The bounce set's cells are numbered from 0: its raster is scanned on its own.
        self.bounce_raster_power = 0.0;
        if bounce {
            let first = emitters.len();
            for (i, l) in lights.iter().enumerate() {
                let e = bounce_emitter_for(l, i as u32, centre, reach, (emitters.len() - first) as u32 * cells);
                self.bounce_raster_power += bounce_raster_power(&e, l);
                emitters.push(e);
            }
            if let Some(e) = environment_emitter(env.integral, centre, reach, reach, (emitters.len() - first) as u32 * cells) {
                self.bounce_raster_power += environment_raster_power(&e, env.integral);
                emitters.push(e);
            }
        }
        self.bounce_emitter_count = emitters.len() as u32 - self.emitter_count;
        if !gpu.is_empty() {
            ctx.queue.write_buffer(&self.lights, 0, bytemuck::cast_slice(&gpu));
        }
        if !emitters.is_empty() {
            ctx.queue.write_buffer(&self.emitters, 0, bytemuck::cast_slice(&emitters));
        }
        self.light_count = gpu.len() as u32;
        self.glowing_count = lights.iter().filter(|l| matches!(l.shape, LightShape::Mesh { .. })).count() as u32;
        debug_assert!(lights.iter().rev().take(self.glowing_count as usize).all(|l| matches!(l.shape, LightShape::Mesh { .. })), "glowing meshes come last");
    }
}
