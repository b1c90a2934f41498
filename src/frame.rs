//! The flat frame description: everything one frame needs, in world space, with no hierarchy,
//! no Lua and no glTF left in it. It is the boundary between the scene graph (CPU) and the GPU
//! pipeline; `Renderer::frame` reads nothing else.

use std::sync::Arc;

use glam::{Mat4, Quat, UVec3, Vec2, Vec3};

use crate::gpu::types::{self, field_kind};
use crate::scene::{Diffuse, Environment, EnvironmentSource, Glass, MeshData};

/// The camera, resolved to world space.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraDesc {
    pub position: Vec3,
    /// Orientation: the camera looks down its local −Z, +Y up.
    pub orientation: Quat,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    pub width: u32,
    pub height: u32,
    /// Orthographic: the view's height in metres (its rays parallel to `forward`, starting on
    /// the plane through `position`); `None`: a pinhole.
    pub orthographic: Option<f32>,
    /// A thin lens ([`crate::scene::Lens`]): the aperture's diameter (0: a pinhole), metres …
    pub aperture: f32,
    /// … the distance along the view to the plane in focus, metres …
    pub focus: f32,
    /// … and the diaphragm: a regular polygon of `blades` corners (0: round) turned by
    /// `blade_rotation` radians.
    pub blades: u32,
    pub blade_rotation: f32,
    /// Lens shift ([`crate::scene::Lens::shift`]): the image moved across the image plane, in
    /// fractions of the frame's larger side.
    pub shift: glam::Vec2,
    /// Camera rays start this far along the view (metres; [`crate::scene::Camera::clip_start`]).
    pub clip_start: f32,
    /// A region of the frame (`render --region`, Blender's border render): this image, of
    /// `width` × `height`, is that part of a larger frame. `None`: the whole frame.
    pub crop: Option<Crop>,
}

/// Where an image lies in the frame it is a region of: the frame's size and the image's
/// top-left pixel in it. The region's pixels are the frame's own — the same rays, the same
/// random numbers — so a region renders exactly what the whole frame shows there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crop {
    pub frame: (u32, u32),
    pub origin: (u32, u32),
}

impl CameraDesc {
    pub fn forward(&self) -> Vec3 {
        self.orientation * Vec3::NEG_Z
    }

    pub fn to_gpu(&self) -> types::Camera {
        let right = self.orientation * Vec3::X;
        let up = self.orientation * Vec3::Y;
        types::Camera {
            position: self.position.into(),
            tan_half_fov: (0.5 * self.fov_y).tan(),
            right: right.into(),
            up: up.into(),
            ortho_half_height: self.orthographic.map_or(0.0, |h| 0.5 * h),
            forward: self.forward().into(),
            lens_radius: if self.orthographic.is_some() { 0.0 } else { 0.5 * self.aperture },
            focus_distance: self.focus,
            blades: self.blades,
            blade_rotation: self.blade_rotation,
            window: self.image_window().into(),
            clip_start: self.clip_start,
            ..Default::default()
        }
    }

    /// The whole frame's size, pixels: the image's own, or that of the frame it is a region of.
    pub fn frame_size(&self) -> (u32, u32) {
        self.crop.map_or((self.width, self.height), |c| c.frame)
    }

    /// Pixel (x, y) of the image as pixel (x + origin.0, y + origin.1) of the frame.
    pub fn frame_origin(&self) -> (u32, u32) {
        self.crop.map_or((0, 0), |c| c.origin)
    }

    /// Where the image lies on the image plane at unit distance (before the field of view
    /// scales it): the point of image pixel (x, y) is (w.x + x·w.z, w.y − y·w.w), where the
    /// frame spans y from −1 at its bottom to 1 at its top and x over ± the aspect ratio — the
    /// frame's part the image is, moved by the lens shift (in units of the frame's larger
    /// side, as Blender's Shift X/Y: the view's direction stays, so verticals stay straight).
    pub fn image_window(&self) -> glam::Vec4 {
        let (fw, fh) = self.frame_size();
        let (ox, oy) = self.frame_origin();
        let aspect = fw as f32 / fh as f32;
        let shift = 2.0 * aspect.max(1.0) * self.shift;
        let step = glam::Vec2::new(2.0 * aspect / fw as f32, 2.0 / fh as f32);
        glam::Vec4::new(-aspect + ox as f32 * step.x + shift.x, 1.0 - oy as f32 * step.y + shift.y, step.x, step.y)
    }

    /// A point of the aperture for a uniform `u` in [0, 1)², in metres along the camera's right
    /// and up from its centre: uniform over the disc (Shirley and Chiu's concentric map keeps
    /// strata apart) or over the regular polygon of `blades` corners — the CPU twin of
    /// view.wgsl's `aperture_point`.
    pub fn aperture_point(&self, u: glam::Vec2) -> glam::Vec2 {
        aperture_point(u, 0.5 * self.aperture, self.blades, self.blade_rotation)
    }

    /// The thin-lens camera ray through a point of the image leaving aperture point `lens`
    /// (metres, [`Self::aperture_point`]): (origin, unit direction). Every such ray of a pixel
    /// passes through the point the pinhole ray meets on the plane in focus. It starts on the
    /// plane `clip_start` along the view (Cycles' clipping: a distance along the view axis, not
    /// along the ray) — the CPU twin of view.wgsl's `camera_ray_through_lens`.
    pub fn lens_ray_through(&self, pixel: glam::Vec2, lens: glam::Vec2) -> (Vec3, Vec3) {
        let (origin, dir) = (self.origin_through(pixel), self.ray_through(pixel));
        let (start, dir) = if self.orthographic.is_some() || self.aperture <= 0.0 {
            (origin, dir)
        } else {
            let in_focus = origin + dir * (self.focus / dir.dot(self.forward()));
            let start = origin + lens.x * (self.orientation * Vec3::X) + lens.y * (self.orientation * Vec3::Y);
            (start, (in_focus - start).normalize())
        };
        if self.clip_start <= 0.0 {
            return (start, dir);
        }
        (start + dir * (self.clip_start / dir.dot(self.forward())), dir)
    }

    /// The angle (radians) one pixel spans at the image's centre: the cone a camera ray
    /// stands for, over which a per-ray environment is filtered.
    /// (Orthographic rays are parallel: a cone of no width.)
    pub fn pixel_angle(&self) -> f32 {
        match self.orthographic {
            Some(_) => 0.0,
            None => 2.0 * (0.5 * self.fov_y).tan() / self.frame_size().1 as f32,
        }
    }

    /// Where the camera ray through a point of the image starts: the camera's position for a
    /// pinhole, a point of the image plane through it for an orthographic camera — the CPU
    /// twin of view.wgsl's `camera_origin`.
    pub fn origin_through(&self, pixel: glam::Vec2) -> Vec3 {
        let Some(height) = self.orthographic else { return self.position };
        let (nx, ny) = self.image_plane(pixel);
        self.position + 0.5 * height * (nx * (self.orientation * Vec3::X) + ny * (self.orientation * Vec3::Y))
    }

    /// A point of the image as (x, y) on the image plane at unit distance ([`Self::image_window`]).
    fn image_plane(&self, pixel: glam::Vec2) -> (f32, f32) {
        let w = self.image_window();
        (w.x + pixel.x * w.z, w.y - pixel.y * w.w)
    }

    /// The unit direction of the ray through pixel (x, y)'s centre — CPU twin of `camera_ray`.
    pub fn ray(&self, x: u32, y: u32) -> Vec3 {
        self.ray_through(glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5))
    }

    /// Unit direction of the camera ray through a point of the image, in pixels from its
    /// top-left corner (pixel (x, y) spans x..x + 1, y..y + 1): the CPU twin of view.wgsl's
    /// `camera_ray`.
    pub fn ray_through(&self, pixel: glam::Vec2) -> Vec3 {
        if self.orthographic.is_some() {
            return self.forward();
        }
        let t = (0.5 * self.fov_y).tan();
        let (nx, ny) = self.image_plane(pixel);
        let (nx, ny) = (nx * t, ny * t);
        (self.forward() + nx * (self.orientation * Vec3::X) + ny * (self.orientation * Vec3::Y)).normalize()
    }
}

/// A point of an aperture of `radius` for a uniform `u` in [0, 1)²: on the disc by Shirley and
/// Chiu's concentric map, or on the regular polygon of `blades` (≥ 3) corners on that circle,
/// turned by `rotation` — a corner's triangle chosen by `u.x`, a point of it uniformly.
pub fn aperture_point(u: glam::Vec2, radius: f32, blades: u32, rotation: f32) -> glam::Vec2 {
    use std::f32::consts::{FRAC_PI_4, TAU};
    if blades >= 3 {
        let n = blades as f32;
        let scaled = u.x * n;
        let corner = scaled.floor().min(n - 1.0);
        let (mut a, mut b) = (scaled - corner, u.y);
        if a + b > 1.0 {
            (a, b) = (1.0 - a, 1.0 - b);
        }
        let at = |k: f32| glam::Vec2::from_angle(rotation + TAU * k / n);
        return radius * (a * at(corner) + b * at(corner + 1.0));
    }
    let p = 2.0 * u - glam::Vec2::ONE;
    if p == glam::Vec2::ZERO {
        return glam::Vec2::ZERO;
    }
    let (r, theta) = if p.x.abs() > p.y.abs() { (p.x, FRAC_PI_4 * (p.y / p.x)) } else { (p.y, 2.0 * FRAC_PI_4 - FRAC_PI_4 * (p.x / p.y)) };
    radius * r * glam::Vec2::from_angle(theta)
}

/// The voxel volume: an axis-aligned box of cubic voxels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeDesc {
    pub min: Vec3,
    pub voxel_size: f32,
    pub dims: UVec3,
    /// Arc length of one viewing-pass step, metres.
    pub step: f32,
    /// Surfaces of two sharp solids closer than this along a ray are crossed as one interface
    /// (`VolumeSettings::contact`), metres.
    pub contact: f32,
}

impl VolumeDesc {
    pub fn max(&self) -> Vec3 {
        self.min + self.dims.as_vec3() * self.voxel_size
    }

    pub fn voxel_count(&self) -> u64 {
        self.dims.x as u64 * self.dims.y as u64 * self.dims.z as u64
    }

    /// Centre of voxel `i`.
    pub fn voxel_centre(&self, i: UVec3) -> Vec3 {
        self.min + (i.as_vec3() + 0.5) * self.voxel_size
    }

    pub fn to_gpu(&self) -> types::GridParams {
        types::GridParams {
            origin: self.min.into(),
            voxel_size: self.voxel_size,
            dims: self.dims.into(),
            voxel_count: self.voxel_count().min(u32::MAX as u64) as u32,
            inv_extent: (1.0 / (texture_dims(self.dims).as_vec3() * self.voxel_size)).into(),
            _pad0: 0.0,
        }
    }
}

/// The sides of the 3D texture that holds a grid of `dims` voxels: each side that is a power of
/// two gets texels more (1 → 3, 2 → 3, 128 → 129), never read (`grid_uvw` in
/// `shaders/shared/grid.wgsl` holds lookups inside the grid's own voxels) — but for a side of
/// [`UNPADDED_SIDE`] or more, which stays as it is: 2048 is the 3D texture side WebGPU
/// guarantees, and the longest side a volume may have.
///
/// Why: Mesa's llvmpipe compiles a shader variant per combination of its sampled textures'
/// sides being powers of two or not (`lp_sampler_static_texture_state`: `pot_width`, …), ~70 s
/// each for the view and march stages on two cores. With no side a power of two, every volume
/// and the fog's radiance grids share one variant. On other GPUs it costs a few texels.
pub const UNPADDED_SIDE: u32 = 2048;

pub fn texture_dims(dims: UVec3) -> UVec3 {
    let side = |mut s: u32| {
        while s.is_power_of_two() && s < UNPADDED_SIDE {
            s += 1;
        }
        s
    };
    UVec3::new(side(dims.x), side(dims.y), side(dims.z))
}

/// Kinds of index field.
#[derive(Clone, Debug, PartialEq)]
pub enum FieldKind {
    Sphere,
    Box,
    Luneburg,
    Slab,
    /// A script's n(x, y, z), sampled on the CPU at voxel centres (`scene::index_fn`).
    Sampled(Arc<IndexSamples>),
}

/// n sampled at the centres of a block of voxels of the volume: voxels `first` to
/// `first + dims − 1`, x fastest. Outside the block the field's coverage is zero (so an empty
/// block is a field that covers no voxel).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IndexSamples {
    pub first: UVec3,
    pub dims: UVec3,
    pub values: Arc<[f32]>,
    /// The volume's placement the block refers to (min corner, voxel size).
    pub origin: Vec3,
    pub voxel_size: f32,
}

// Equality of the data, and (as `Eq`) equal to itself: `Arc<IndexSamples>`'s == then checks the pointer
// first, so the stage-reuse keys and `FrameDesc::share_unchanged` compare shared data for free.
// (Its floats are checked finite before they reach the GPU.)
impl Eq for IndexSamples {}

impl IndexSamples {
    /// n at the voxel containing world point `x`, or `None` outside the block.
    pub fn at(&self, x: Vec3) -> Option<f32> {
        let i = ((x - self.origin) / self.voxel_size).floor().as_ivec3() - self.first.as_ivec3();
        if i.cmplt(glam::IVec3::ZERO).any() || i.cmpge(self.dims.as_ivec3()).any() {
            return None;
        }
        let i = i.as_uvec3();
        Some(self.values[(i.x + self.dims.x * (i.y + self.dims.y * i.z)) as usize])
    }
}

/// How a frame carries light (`FrameDesc::spectrum`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spectrum {
    /// Some glass disperses: photons and camera samples carry wavelengths.
    pub spectral: bool,
    /// KHR dispersion (20/V_d) of the media in the index grid.
    pub grid_dispersion: f32,
}

/// One analytic index field in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct FieldDesc {
    /// The node it came from, for messages.
    pub name: String,
    pub kind: FieldKind,
    pub world_to_local: Mat4,
    /// Local half extents (radius in x for spheres and Luneburg lenses).
    pub half_size: Vec3,
    /// Constant index, or n₀ of a slab.
    pub ior: f32,
    /// Slab dn/dy, per metre.
    pub gradient: f32,
    /// Smooth boundary width, metres.
    pub boundary: f32,
    /// Metres per local unit.
    pub scale: f32,
    /// World-space bounding box, including half the boundary.
    pub bounds: (Vec3, Vec3),
    /// A sharp interface (a glass sphere or box): rays refract at its exact surface, and the
    /// grid holds only its medium (see `gpu::types::Interface`).
    pub sharp: bool,
    /// A sharp surface that is a thin shell with no inside (a bubble: `Glass::thin`).
    pub thin: bool,
    /// Its material: the medium it holds (absorption, scattering, dispersion; none in a shell)
    /// and, where sharp, its surface — the same record a sharp mesh's surface is filled from
    /// (`pipeline::interfaces::surface_record`). Its `ior` is a sphere's or box's; a slab's,
    /// Luneburg lens's or index function's own is `ior` above.
    pub glass: crate::scene::Glass,
}

impl FieldDesc {
    /// The GPU record; a sampled field's values start at `sample_offset` in the samples buffer.
    pub fn to_gpu(&self, sample_offset: u32) -> types::Field {
        let (first, dims) = match &self.kind {
            FieldKind::Sampled(s) => (s.first, s.dims),
            _ => (UVec3::ZERO, UVec3::ZERO),
        };
        types::Field {
            world_to_local: self.world_to_local.to_cols_array_2d(),
            half_size: self.half_size.into(),
            kind: match self.kind {
                FieldKind::Sphere => field_kind::SPHERE,
                FieldKind::Box => field_kind::BOX,
                FieldKind::Luneburg => field_kind::LUNEBURG,
                FieldKind::Slab => field_kind::SLAB,
                FieldKind::Sampled(_) => field_kind::SAMPLED,
            },
            ior: self.ior,
            ior_gradient: self.gradient,
            boundary: self.boundary,
            scale: self.scale,
            absorption: self.glass.absorption.extend(0.0).into(),
            scattering: self.glass.scattering.extend(self.glass.g).into(),
            sample_first: first.into(),
            sample_offset,
            sample_dims: dims.into(),
            sharp: self.sharp as u32,
        }
    }

    /// Whether the field absorbs or scatters light.
    pub fn has_medium(&self) -> bool {
        self.glass.absorption.max_element() > 0.0 || self.glass.scattering.max_element() > 0.0
    }
}

/// A refractive triangle mesh placed in the world, to be voxelized into the volume.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshInstance {
    pub name: String,
    /// Where it was defined (`scene.lua:14`), for messages.
    pub origin: String,
    pub mesh: Arc<MeshData>,
    pub world: Mat4,
    pub glass: Glass,
    /// Smooth boundary width, metres.
    pub boundary: f32,
    /// World-space bounding box.
    pub bounds: (Vec3, Vec3),
    /// A sharp interface (a closed glass mesh, or a thin sheet): rays refract at its
    /// triangles, and the grid holds only its medium.
    pub sharp: bool,
    /// A thin sheet (`Glass::thin`, or an open flat mesh): a sharp surface with no inside.
    pub thin: bool,
    /// How the mesh is read was guessed from its shape (`Glass::thin` unset on an open
    /// mesh): the frame warns, saying how to choose.
    pub guessed: bool,
}

/// An opaque diffuse surface placed in the world (planes, boxes and spheres arrive here as
/// triangle meshes too).
#[derive(Clone, Debug, PartialEq)]
pub struct Receiver {
    pub name: String,
    pub mesh: Arc<MeshData>,
    pub world: Mat4,
    pub diffuse: Diffuse,
}

/// How a light emits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightShape {
    Point,
    /// Cosines of the outer (zero) and inner (full intensity) half-angles.
    Spot { cos_outer: f32, cos_inner: f32 },
    /// Half the sun's angular diameter, radians.
    Sun { half_angle: f32 },
    /// Rectangle of `size` spanned by `right` and `up`, emitting along `direction` — or,
    /// `round`, the ellipse inscribed in it.
    Rect { size: Vec2, round: bool },
    /// A glowing mesh: an emissive receiver's triangles `first .. first + count` of the frame's
    /// light triangles (`pipeline::mesh_lights`), `area` m² in all, glowing with `radiant` on
    /// both sides as Cycles' emission does — or, `closed`, on its outer side (its triangles
    /// wound outward), the inner side's light having nowhere to go but the mesh itself.
    /// `outside`: a point just off its first triangle's glowing side, where the media its
    /// photons start in are found (its centroid may lie inside it: glass that glows).
    /// `patterned`: it glows through an emission texture, so it lights by the texture's mean
    /// where the camera sees the pattern — not sampled at rough crossings, whose branches see it.
    Mesh { first: u32, count: u32, area: f32, closed: bool, outside: Vec3, patterned: bool },
}

/// A light in world space, in radiometric units (see `scene::light`).
#[derive(Clone, Debug, PartialEq)]
pub struct LightDesc {
    pub name: String,
    pub shape: LightShape,
    pub position: Vec3,
    /// Unit direction the light travels: spot axis, sun direction, rect normal.
    pub direction: Vec3,
    /// Unit axes across the direction (rect extents; any orthonormal pair otherwise).
    pub right: Vec3,
    pub up: Vec3,
    /// color × intensity / 683: W/sr (point, spot), W/m² (sun), W/(m²·sr) (rect, mesh).
    pub radiant: Vec3,
    /// Point and spot lights: the bulb's radius glass shows as a highlight, metres.
    pub radius: f32,
    /// The camera sees its bulb or panel directly (`scene::Light::visible`).
    pub visible: bool,
}

/// A homogeneous scattering medium filling the volume box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FogDesc {
    pub scattering: Vec3,
    pub absorption: Vec3,
    pub g: f32,
}

/// Everything the GPU pipeline needs for one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameDesc {
    /// Scene time, seconds.
    pub time: f64,
    pub camera: CameraDesc,
    pub environment: Environment,
    pub volume: VolumeDesc,
    /// Analytic index fields, composited in scene order.
    pub fields: Vec<FieldDesc>,
    /// Refractive meshes, voxelized into the same grid after the fields.
    pub meshes: Vec<MeshInstance>,
    /// Opaque diffuse surfaces.
    pub receivers: Vec<Receiver>,
    pub lights: Vec<LightDesc>,
    pub fog: Option<FogDesc>,
    /// Photon budget of the frame, split over the lights.
    pub photons: u32,
    /// Diffuse bounces of bounced (indirect) light; 0 leaves it out.
    pub bounces: u32,
    /// Photons for bounced light, split over the lights by power.
    pub bounce_photons: u32,
    /// Camera rays per pixel.
    pub samples: u32,
    /// Motion blur: `refrakt render` renders the frame at instants across its shutter interval.
    pub motion_blur: Option<crate::scene::MotionBlur>,
}

impl FrameDesc {
    /// Whether the frame traces bounced light: bounces and a budget for them, and receivers to
    /// bounce off.
    pub fn traces_bounces(&self) -> bool {
        self.bounces > 0 && self.bounce_photons > 0 && !self.receivers.is_empty()
    }

    /// Things about the frame a user should hear of even though it renders: lights that cannot
    /// light anything they probably meant, photons switched off.
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        for l in self.lights.iter().filter(|l| !matches!(l.shape, LightShape::Sun { .. })) {
            for r in self.receivers.iter().filter(|r| r.mesh.encloses(r.world, l.position)) {
                out.push(format!(
                    "light \"{}\" is inside receiver \"{}\": only the inside of its surfaces is lit (right for a \
                     room; move the light out if \"{}\" is a solid object)",
                    l.name, r.name, r.name
                ));
            }
        }
        for m in self.meshes.iter().filter(|m| m.guessed) {
            out.push(if m.thin {
                format!(
                    "{}: glass mesh \"{}\" is flat: rendered as a thin sheet (set thin = true on its glass to say so, \
                     or thin = false to voxelize it as a solid)",
                    m.origin, m.name
                )
            } else {
                format!(
                    "{}: glass mesh \"{}\" is open: rendered as the solid its surface voxelizes to (set thin = true on \
                     its glass for a thin sheet, thin = false to say it is a solid, or close the mesh for a sharp surface)",
                    m.origin, m.name
                )
            });
        }
        for m in self.meshes.iter().filter(|m| !m.sharp && !m.glass.refracts() && m.glass.tinted()) {
            out.push(format!(
                "{}: glass mesh \"{}\" has index {} and is neither a closed solid nor a sheet: it bends no light, and refrakt \
                 renders it as air, without its tint (close the mesh, make it a sheet: thin = true, or give it an index above {})",
                m.origin, m.name, m.glass.ior, 1.0 + crate::pipeline::photons::EPS_REFRACT
            ));
        }
        for f in self.fields.iter().filter(|f| f.sharp && f.glass.emitted().max_element() > 0.0) {
            out.push(format!(
                "glass \"{}\" glows on an analytic shape: its glow shows where it is seen but lights nothing (a glass \
                 mesh's glow lights the scene: r.icosphere, r.mesh)",
                f.name
            ));
        }
        for f in self.fields.iter().filter(|f| f.glass.textured()) {
            out.push(format!(
                "glass \"{}\" has textures, but a sphere or box has no texture coordinates: it keeps its factors (give it a \
                 mesh with texture coordinates: r.cube, r.plane, an OBJ with vt, a glTF with TEXCOORD_0)",
                f.name
            ));
        }
        let solid_with_alpha = self.meshes.iter().filter(|m| !m.thin && m.glass.alpha_mode != crate::scene::AlphaMode::Opaque).map(|m| (&m.name, m.glass.alpha_mode));
        for (name, mode) in solid_with_alpha.chain(self.fields.iter().filter(|f| !f.thin && f.glass.alpha_mode != crate::scene::AlphaMode::Opaque).map(|f| (&f.name, f.glass.alpha_mode))) {
            out.push(format!(
                "glass \"{name}\" has alpha mode {}, but alpha cuts thin glass only (a sheet, a shell): as a solid it is all there \
                 (make it a sheet: thin = true, or glTF without KHR_materials_volume)",
                mode.name()
            ));
        }
        for m in self.meshes.iter().filter(|m| m.glass.textured() && !(m.sharp && m.mesh.uvs.is_some())) {
            let why = if m.sharp { "has no texture coordinates" } else { "is voxelized into a smooth medium, which has no surface to texture" };
            out.push(format!("{}: glass mesh \"{}\" has textures, but it {why}: it keeps its factors", m.origin, m.name));
        }
        for f in self.fields.iter().filter(|f| !f.sharp && f.glass.tint != Vec3::ONE) {
            out.push(format!(
                "glass \"{}\" is a smooth index field, and a tint colours light where it crosses a sharp surface only (leave \
                 out `boundary` on a sphere or box, or colour the field with `absorption`): its tint is not applied",
                f.name
            ));
        }
        let (lo, hi) = (self.volume.min, self.volume.max());
        let sharp = self.fields.iter().filter(|f| f.sharp).map(|f| (&f.name, f.bounds));
        for (name, (b_lo, b_hi)) in sharp.chain(self.meshes.iter().filter(|m| m.sharp).map(|m| (&m.name, m.bounds))) {
            let slack = 1e-3 * self.volume.voxel_size;
            if b_lo.cmplt(lo - slack).any() || b_hi.cmpgt(hi + slack).any() {
                out.push(format!(
                    "glass \"{name}\" reaches outside the volume box ({lo} to {hi}): light that meets it out there is not \
                     refracted, though it still casts a shadow (enlarge volume.min/max, or leave them out so the box fits the glass)"
                ));
            }
        }
        let grid = self.grid_dispersions();
        if grid.iter().any(|&(_, d)| d != grid[0].1) {
            let names: Vec<String> = grid.iter().map(|(n, d)| format!("\"{n}\" {d}")).collect();
            out.push(format!(
                "gradient-index and voxelized media share one dispersion per frame, the largest: {} (objects with a sharp \
                 surface keep their own)",
                names.join(", ")
            ));
        }
        if self.photons == 0 && !self.lights.is_empty() && (!self.receivers.is_empty() || self.fog.is_some()) {
            out.push("photons = 0: no caustics or light shafts are traced (set scene.photons or --photons)".into());
        }
        out
    }

    /// Makes this frame share the meshes, sampled index fields and environment image of
    /// `earlier` wherever they are equal in value. A script reloaded after an edit makes all of
    /// them anew; shared again, the renderer sees them unchanged by identity, as it does between
    /// frames of one run (unchanged meshes are not voxelized again, nor images uploaded again).
    pub fn share_unchanged(&mut self, earlier: &FrameDesc) {
        let meshes: Vec<&Arc<MeshData>> = earlier.meshes.iter().map(|m| &m.mesh).chain(earlier.receivers.iter().map(|r| &r.mesh)).collect();
        for mesh in self.meshes.iter_mut().map(|m| &mut m.mesh).chain(self.receivers.iter_mut().map(|r| &mut r.mesh)) {
            share_if_equal(mesh, &meshes);
        }
        let samples: Vec<&Arc<IndexSamples>> = earlier.fields.iter().filter_map(|f| match &f.kind {
            FieldKind::Sampled(s) => Some(s),
            _ => None,
        }).collect();
        for field in &mut self.fields {
            if let FieldKind::Sampled(s) = &mut field.kind {
                share_if_equal(s, &samples);
            }
        }
        if let (EnvironmentSource::Image { image, .. }, Some(old)) = (&mut self.environment.source, earlier.environment.image()) {
            share_if_equal(image, &[old]);
        }
    }

    /// Whether the frame's light is spectral (some glass disperses), and the dispersion of the
    /// media in the index grid: gradient-index fields and voxelized solids share one per frame,
    /// the largest among them (`warnings` says when they differ); sharp glass keeps its own on
    /// its interface record.
    pub fn spectrum(&self) -> Spectrum {
        let sharp = self.fields.iter().filter(|f| f.sharp).map(|f| f.glass.dispersion).chain(self.meshes.iter().filter(|m| m.sharp).map(|m| m.glass.dispersion));
        let grid_dispersion = self.grid_dispersions().iter().map(|&(_, d)| d).fold(0.0, f32::max);
        Spectrum { spectral: grid_dispersion > 0.0 || sharp.fold(0.0, f32::max) > 0.0, grid_dispersion }
    }

    /// (name, dispersion) of each object whose index is in the grid, not on a sharp surface.
    fn grid_dispersions(&self) -> Vec<(&str, f32)> {
        let fields = self.fields.iter().filter(|f| !f.sharp).map(|f| (f.name.as_str(), f.glass.dispersion));
        fields.chain(self.meshes.iter().filter(|m| !m.sharp).map(|m| (m.name.as_str(), m.glass.dispersion))).collect()
    }

    /// Whether anything absorbs or scatters (so rays must sample the medium grids).
    pub fn has_media(&self) -> bool {
        self.fields.iter().any(FieldDesc::has_medium)
            || self.meshes.iter().any(|m| m.glass.absorption.max_element() > 0.0 || m.glass.scattering.max_element() > 0.0)
            || self.fog.is_some()
    }
}

/// Replaces `value` by the first of `candidates` equal to it, so both are one shared `Arc`.
fn share_if_equal<T: PartialEq>(value: &mut Arc<T>, candidates: &[&Arc<T>]) {
    if let Some(same) = candidates.iter().find(|c| Arc::ptr_eq(c, value) || c.as_ref() == value.as_ref()) {
        *value = Arc::clone(same);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;
    use std::f32::consts::TAU;

    /// A 64×64 grid of uniform numbers.
    fn grid() -> impl Iterator<Item = Vec2> {
        (0..64 * 64).map(|i| Vec2::new((i % 64) as f32 + 0.5, (i / 64) as f32 + 0.5) / 64.0)
    }

    /// Aperture points cover the disc or polygon uniformly: none outside, and the mean squared
    /// distance from the centre that of a uniform disc (R²/2) or regular n-gon
    /// (R²·(2 + cos 2π/n)/6).
    #[test]
    fn aperture_points_are_uniform_over_the_disc_and_the_polygon() {
        let r = 0.7f32;
        for (blades, expected) in [(0u32, 0.5f32), (3, (2.0 + (TAU / 3.0).cos()) / 6.0), (6, (2.0 + (TAU / 6.0).cos()) / 6.0)] {
            let points: Vec<Vec2> = grid().map(|u| aperture_point(u, r, blades, 0.3)).collect();
            let mean_r2 = points.iter().map(|p| p.length_squared()).sum::<f32>() / points.len() as f32;
            assert!((mean_r2 / (expected * r * r) - 1.0).abs() < 0.01, "{blades} blades: mean r² {mean_r2}");
            assert!(points.iter().all(|p| p.length() <= r * 1.0001), "{blades} blades: a point outside the aperture");
            let centroid = points.iter().copied().sum::<Vec2>() / points.len() as f32;
            assert!(centroid.length() < 0.01 * r, "{blades} blades: centroid {centroid}");
        }
    }

    fn camera(width: u32, height: u32) -> CameraDesc {
        CameraDesc {
            position: Vec3::new(0.3, 1.0, 2.0),
            orientation: glam::Quat::from_rotation_y(0.4) * glam::Quat::from_rotation_x(-0.2),
            fov_y: 0.7,
            width,
            height,
            orthographic: None,
            aperture: 0.0,
            focus: 3.0,
            blades: 0,
            blade_rotation: 0.0,
            shift: Vec2::ZERO,
            clip_start: 0.0,
            crop: None,
        }
    }

    /// A region's pixels are the frame's: the same rays (perspective and orthographic), the
    /// same footprint.
    #[test]
    fn a_regions_rays_are_the_frames_own() {
        for orthographic in [None, Some(1.5)] {
            let frame = CameraDesc { orthographic, ..camera(40, 30) };
            let region = CameraDesc { width: 12, height: 7, crop: Some(Crop { frame: (40, 30), origin: (25, 9) }), ..frame };
            for (x, y) in [(0.5, 0.5), (11.5, 6.5), (3.25, 4.75)] {
                let p = Vec2::new(x, y);
                let q = p + Vec2::new(25.0, 9.0);
                assert!(region.ray_through(p).abs_diff_eq(frame.ray_through(q), 1e-6), "{orthographic:?}: pixel {p}");
                assert!(region.origin_through(p).abs_diff_eq(frame.origin_through(q), 1e-6), "{orthographic:?}: pixel {p}");
            }
            assert_eq!(region.pixel_angle(), frame.pixel_angle());
        }
    }

    /// Lens shift moves the image by the shift times the frame's larger side (Blender's unit),
    /// landscape and portrait: the shifted ray through a pixel is the unshifted one through the
    /// pixel that far across, up being −y in pixels.
    #[test]
    fn a_lens_shift_moves_the_image_by_fractions_of_its_larger_side() {
        for (w, h) in [(40, 30), (30, 40)] {
            let plain = camera(w, h);
            let shifted = CameraDesc { shift: Vec2::new(0.125, -0.25), ..plain };
            let side = w.max(h) as f32;
            for p in [Vec2::new(0.5, 0.5), Vec2::new(17.3, 12.9)] {
                let moved = p + Vec2::new(0.125 * side, 0.25 * side);
                assert!(shifted.ray_through(p).abs_diff_eq(plain.ray_through(moved), 1e-5), "{w}×{h}: pixel {p}");
            }
            // The view keeps its direction: no turn, verticals stay parallel.
            assert_eq!(shifted.forward(), plain.forward());
        }
    }

    /// Every thin-lens ray of a pixel passes through the point the pinhole ray meets on the plane
    /// in focus; with no aperture the ray is the pinhole's.
    #[test]
    fn a_pixels_lens_rays_meet_on_the_plane_in_focus() {
        let camera = CameraDesc { aperture: 0.2, ..camera(40, 30) };
        let pixel = Vec2::new(7.3, 21.6);
        let pinhole = camera.ray_through(pixel);
        let in_focus = camera.position + pinhole * (camera.focus / pinhole.dot(camera.forward()));
        for u in grid().step_by(97) {
            let (origin, dir) = camera.lens_ray_through(pixel, camera.aperture_point(u));
            assert!((dir.length() - 1.0).abs() < 1e-5);
            let t = (in_focus - origin).dot(camera.forward()) / dir.dot(camera.forward());
            assert!((origin + t * dir - in_focus).length() < 1e-4, "a lens ray misses the point in focus");
            assert!((origin - camera.position).dot(camera.forward()).abs() < 1e-6, "the aperture lies across the view");
        }
        let pinhole_camera = CameraDesc { aperture: 0.0, ..camera };
        assert_eq!(pinhole_camera.lens_ray_through(pixel, Vec2::new(0.05, 0.0)), (camera.position, pinhole));
    }

    #[test]
    fn a_grid_texture_has_no_side_a_power_of_two_and_holds_its_voxels() {
        assert_eq!(texture_dims(UVec3::new(1, 2, 4)), UVec3::new(3, 3, 5));
        assert_eq!(texture_dims(UVec3::new(128, 127, 96)), UVec3::new(129, 127, 96));
        for side in 1..UNPADDED_SIDE {
            let t = texture_dims(UVec3::splat(side)).x;
            assert!(!t.is_power_of_two() && t >= side && t <= side + 2, "{side} -> {t}");
        }
        // The longest side a volume may have stays within WebGPU's guaranteed 3D texture side.
        assert_eq!(texture_dims(UVec3::new(2048, 1024, 16)), UVec3::new(2048, 1025, 17));
    }

    #[test]
    fn camera_rays_start_on_the_clip_plane() {
        let base = camera(40, 30);
        for (orthographic, aperture) in [(None, 0.0), (None, 0.2), (Some(2.0), 0.0)] {
            let c = CameraDesc { orthographic, aperture, clip_start: 0.75, ..base };
            let unclipped = CameraDesc { clip_start: 0.0, ..c };
            for (pixel, lens) in [(Vec2::new(3.5, 27.5), Vec2::new(0.05, -0.03)), (Vec2::new(20.0, 15.0), Vec2::ZERO)] {
                let (start, dir) = c.lens_ray_through(pixel, lens);
                let (origin, same_dir) = unclipped.lens_ray_through(pixel, lens);
                assert_eq!(dir, same_dir);
                assert!(((start - c.position).dot(c.forward()) - 0.75).abs() < 1e-5, "{orthographic:?} {aperture}: starts at {start}");
                assert!((start - origin).cross(dir).length() < 1e-5, "on the same ray");
            }
        }
    }
}
