//! Every struct the CPU hands to the GPU, declared once here with `bytemuck` and mirrored
//! member by member in `shaders/shared/types.wgsl`. The test at the bottom parses the WGSL with
//! naga and checks that names, offsets and sizes agree, so a drifted field fails a test instead
//! of silently shearing a uniform.
//!
//! WGSL's layout rules put `vec3<f32>` on 16-byte boundaries; every `[f32; 3]` here is followed
//! by a 4-byte member (often an explicit `_padN`) so that both sides agree without guesswork.

/// Implemented by [`gpu_struct!`]: the WGSL struct name and the Rust field offsets.
pub trait GpuLayout {
    const WGSL_NAME: &'static str;
    fn fields() -> Vec<(&'static str, usize)>;
}

macro_rules! gpu_struct {
    ($(#[$m:meta])* pub struct $name:ident { $($(#[$fm:meta])* pub $field:ident : $ty:ty),* $(,)? }) => {
        $(#[$m])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
        pub struct $name { $($(#[$fm])* pub $field: $ty),* }
        impl GpuLayout for $name {
            const WGSL_NAME: &'static str = stringify!($name);
            fn fields() -> Vec<(&'static str, usize)> {
                vec![$((stringify!($field), std::mem::offset_of!($name, $field))),*]
            }
        }
    };
}

gpu_struct! {
    /// The voxel grid's placement in the world. Voxel `i` has its centre at
    /// `origin + (i + 0.5) · voxel_size`; texture coordinates are `(x − origin) · inv_extent`,
    /// `inv_extent` of the texture's extent (`frame::texture_dims`, a little more than `dims`).
    pub struct GridParams {
        pub origin: [f32; 3],
        pub voxel_size: f32,
        pub dims: [u32; 3],
        pub voxel_count: u32,
        pub inv_extent: [f32; 3],
        pub _pad0: f32,
    }
}

gpu_struct! {
    /// A camera: an orthonormal basis, the tangent of half the vertical field of view, a thin
    /// lens (a pinhole where its radius is 0), and where the image lies on the image plane.
    pub struct Camera {
        pub position: [f32; 3],
        pub tan_half_fov: f32,
        pub right: [f32; 3],
        /// Camera rays start this far along `forward` (metres; `CameraDesc::clip_start`).
        pub clip_start: f32,
        pub up: [f32; 3],
        /// Half the view's height (metres) of an orthographic camera; 0: a pinhole.
        pub ortho_half_height: f32,
        pub forward: [f32; 3],
        /// A thin lens's aperture radius, metres; 0: a pinhole.
        pub lens_radius: f32,
        /// Distance along `forward` to the plane in focus, metres.
        pub focus_distance: f32,
        /// Corners of the polygonal aperture (0: round) and its turn, radians.
        pub blades: u32,
        pub blade_rotation: f32,
        pub _pad1: f32,
        /// The image on the image plane at unit distance: pixel (x, y) at (x₀ + x·dx, y₀ − y·dy)
        /// as (x₀, y₀, dx, dy) — `CameraDesc::image_window` (region and lens shift).
        pub window: [f32; 4],
    }
}

gpu_struct! {
    /// The environment seen by rays that leave the scene: one of [`env_kind`]'s, scaled by
    /// `intensity` and turned by the unit quaternion `turn` (x, y, z, w: `Environment::turn`).
    pub struct EnvParams {
        pub color: [f32; 3],
        pub intensity: f32,
        pub turn: [f32; 4],
        pub kind: u32,
        pub visible: u32,
        /// The angular width (radians) of a camera pixel: the cone a per-ray environment
        /// (the studio preset) is filtered over.
        pub footprint: f32,
        pub _pad0: f32,
    }
}

gpu_struct! {
    /// Uniforms of the viewing pass (`shaders/view.wgsl`).
    pub struct ViewParams {
        pub camera: Camera,
        pub grid: GridParams,
        pub env: EnvParams,
        pub width: u32,
        pub height: u32,
        pub max_steps: u32,
        pub flags: u32,
        /// Arc length of one ray-equation step, metres.
        pub step: f32,
        /// |n − 1| above which a sample counts as refractive (alpha, depth).
        pub medium_eps: f32,
        /// Rays per pixel (a fixed R2 pattern of sub-pixel offsets: no flicker between frames).
        pub samples: u32,
        pub light_count: u32,
        /// Longest straight step across a flat octree cell, metres.
        pub max_step: f32,
        /// n − 1 above which a medium counts as refractive (it blocks shadow rays).
        pub eps_refract: f32,
        /// Longest path a camera ray follows through the volume, metres (`march::max_path`).
        pub max_path: f32,
        /// The sharp interfaces around the camera, packed (`interfaces::media_at`): low word…
        pub camera_media_lo: u32,
        /// Shadow rays toward the environment per receiver hit, in pairs (one drawn from the
        /// environment's table, one by cos θ): `view::env_pairs`; 0 when the environment is dark.
        pub env_pairs: u32,
        /// Where the indirect maps' charts start in `charts` (`receivers::indirect_chart_base`).
        pub indirect_chart_base: u32,
        /// Glowing meshes: the last `glowing_count` of the `light_count` lights, each taking
        /// `GLOWING_CANDIDATES` shadow samples (shaders/view.wgsl, `shadow_ray`).
        pub glowing_count: u32,
        /// …and high word.
        pub camera_media_hi: u32,
        /// The camera samples this dispatch traces: from `sample_first`, `sample_count` of them
        /// (all of `samples` in one dispatch, except on CPU adapters: `view::samples_per_dispatch`).
        pub sample_first: u32,
        pub sample_count: u32,
        /// KHR dispersion (20/V_d) of the gradient-index media in the grid (spectral frames).
        pub grid_dispersion: f32,
        /// Wavelengths a camera sample that meets dispersive glass is traced at (spectral frames:
        /// `view::wavelengths_per_sample`; 1 otherwise).
        pub wavelengths_per_sample: u32,
        /// Pixel (x, y)'s random numbers are keyed by its index in the whole frame,
        /// `pixel_key_first + x + y · pixel_key_stride`: a region (`render --region`) draws the
        /// frame's own.
        pub pixel_key_first: u32,
        pub pixel_key_stride: u32,
        pub _pad: [u32; 2],
    }
}

gpu_struct! {
    /// One analytic index field, in the frame of the node that carries it (`shaders/voxelize.wgsl`).
    pub struct Field {
        pub world_to_local: [[f32; 4]; 4],
        /// Box and slab half extents; sphere and Luneburg radius in x.
        pub half_size: [f32; 3],
        pub kind: u32,
        /// Constant index (sphere, box), or n₀ at the slab's centre plane.
        pub ior: f32,
        /// Slab gradient dn/dy along the local y axis, per metre.
        pub ior_gradient: f32,
        /// Width of the smooth boundary, metres (0: a hard step).
        pub boundary: f32,
        /// Metres per local unit (the node's uniform scale).
        pub scale: f32,
        /// Absorption coefficient per metre, rgb (w unused).
        pub absorption: [f32; 4],
        /// Scattering coefficient per metre, rgb; w: Henyey–Greenstein g.
        pub scattering: [f32; 4],
        /// Sampled fields: the first voxel of their block of samples…
        pub sample_first: [u32; 3],
        /// …where the block starts in the samples buffer…
        pub sample_offset: u32,
        /// …and its size in voxels (x fastest).
        pub sample_dims: [u32; 3],
        /// 1: a sharp interface (see [`Interface`]): the field adds its medium to the grids and
        /// marks the octree, but no n — rays refract at its exact surface instead.
        pub sharp: u32,
    }
}

gpu_struct! {
    /// Uniforms of the voxelize stage.
    pub struct VoxelizeParams {
        pub grid: GridParams,
        pub field_count: u32,
        pub mesh_count: u32,
        pub _pad1: u32,
        pub _pad2: u32,
        /// The medium between objects (fog, or nothing): absorption rgb per metre (w unused)…
        pub fog_absorption: [f32; 4],
        /// …and scattering rgb per metre, w: Henyey–Greenstein g.
        pub fog_scattering: [f32; 4],
    }
}

gpu_struct! {
    /// One mesh's run of the mesh-solid kernels (`shaders/voxelize_mesh.wgsl`). The window is
    /// the box of grid voxels it covers; coordinates inside are fixed point, 2^`fixed_bits` per
    /// voxel. Parity words hold, per axis, one bit per voxel along each column plus one for the
    /// whole line, `axis_words` words per column, starting at `axis_offset`.
    pub struct MeshParams {
        /// Local mesh coordinates → grid coordinates in voxels (grid origin at 0).
        pub grid_from_local: [[f32; 4]; 4],
        pub window_min: [i32; 3],
        pub fixed_bits: u32,
        pub window_dims: [u32; 3],
        pub triangle_count: u32,
        pub axis_offset: [u32; 3],
        pub vertex_count: u32,
        pub axis_words: [u32; 3],
        /// Where this mesh's signed distances start in the coverage atlas (f32 words).
        pub atlas_offset: u32,
        /// Distance (voxels) within which voxels get their exact distance to the surface.
        pub reach: f32,
        pub parity_words: u32,
        pub band_voxels: u32,
        pub _pad0: u32,
    }
}

gpu_struct! {
    /// A voxelized mesh as the voxelize kernel composites it: its window of the grid, where its
    /// signed distances lie in the atlas, and its medium.
    pub struct MeshVolume {
        pub window_min: [u32; 3],
        pub atlas_offset: u32,
        pub window_dims: [u32; 3],
        pub ior: f32,
        /// Absorption coefficient per metre, rgb.
        pub absorption: [f32; 3],
        /// Width of the smooth boundary, metres (0: a hard step).
        pub boundary: f32,
        /// Scattering coefficient per metre, rgb; w: Henyey–Greenstein g.
        pub scattering: [f32; 4],
        /// 1: a sharp interface, as `Field::sharp`.
        pub sharp: u32,
        pub _pad0: u32,
        pub _pad1: u32,
        pub _pad2: u32,
    }
}

gpu_struct! {
    /// Uniforms of the probe kernel, which traces given rays for tests and `refrakt trace`.
    pub struct ProbeParams {
        pub grid: GridParams,
        pub step: f32,
        pub max_steps: u32,
        pub record_every: u32,
        pub ray_count: u32,
        pub records_per_ray: u32,
        pub integrator: u32,
        /// > 0: adaptive steps up to this length through flat octree cells (metres).
        pub max_step: f32,
        pub _pad1: u32,
    }
}

gpu_struct! {
    /// A ray handed to the probe kernel: world-space origin and unit direction; with a
    /// `wavelength` (nm, > 0) it sees dispersive glass at that wavelength, and the grid's
    /// gradient-index media with KHR dispersion `grid_dispersion` (`shared/spectrum.wgsl`).
    pub struct ProbeRay {
        pub origin: [f32; 3],
        pub wavelength: f32,
        pub dir: [f32; 3],
        pub grid_dispersion: f32,
    }
}

gpu_struct! {
    /// A recorded state of a probed ray: position, n there, v = n·direction, steps taken.
    pub struct ProbeRecord {
        pub x: [f32; 3],
        pub n: f32,
        pub v: [f32; 3],
        pub steps: u32,
    }
}

gpu_struct! {
    /// A node of the receivers' BVH: a leaf when `count > 0` (triangles `first..first+count`),
    /// else an interior node whose children are `first` and `first + 1`.
    pub struct BvhNode {
        pub min: [f32; 3],
        pub first: u32,
        pub max: [f32; 3],
        pub count: u32,
    }
}

gpu_struct! {
    /// A receiver triangle: a vertex and two edges, plus the receiver it belongs to.
    pub struct BvhTriangle {
        pub v0: [f32; 3],
        pub receiver: u32,
        pub e1: [f32; 3],
        pub _pad0: u32,
        pub e2: [f32; 3],
        pub _pad1: u32,
    }
}

gpu_struct! {
    /// A sharp interface: the closed surface of a constant-index object (glass, water) where a
    /// ray or photon refracts or reflects once, by Snell and Fresnel, instead of bending across
    /// a smoothed step of n. Spheres and boxes are exact (intersected in their local frame);
    /// meshes are found through the receivers' BVH, whose triangles carry
    /// `INTERFACE_BIT | index`. Analytic interfaces come first in the buffer.
    pub struct Interface {
        pub world_to_local: [[f32; 4]; 4],
        /// Box half extents, sphere radius in x (local units).
        pub half_size: [f32; 3],
        /// One of [`interface_kind`]'s shapes, with [`interface_kind::THIN`] set for a sheet.
        pub kind: u32,
        /// Transmission tint per crossing (KHR_materials_transmission's base colour), rgb.
        pub tint: [f32; 3],
        /// Index of refraction inside.
        pub ior: f32,
        /// Absorption coefficient inside, per metre, rgb (Beer–Lambert over the exact path).
        pub absorption: [f32; 3],
        /// GGX roughness (α = roughness²); 0 is a polished surface.
        pub roughness: f32,
        /// KHR dispersion, 20/V_d: the index at wavelength λ is `cpu::spectrum::ior_at`; 0: none.
        pub dispersion: f32,
        /// Which medium holds where solids overlap: of the interfaces a path is inside, the one
        /// of highest rank (`interfaces::table`: the glass's `priority`, then the smaller
        /// object). Unique per solid.
        pub rank: u32,
        /// How far along a ray another solid's surface may lie from this one's and still be
        /// crossed with it as one interface (world units; 0: never) — a liquid against its glass.
        pub contact: f32,
        /// A glowing glass mesh's side its light is drawn on (`ReceiverGpu::glow_side`).
        pub glow_side: f32,
        /// A glass mesh's roughness texture (green channel × `roughness`), as a receiver's
        /// textures are given: (first texel, width, height, encoding | wrap); zeros for none.
        pub roughness_texture: [u32; 4],
        /// Its tint texture (rgb × `tint`), likewise.
        pub tint_texture: [u32; 4],
        /// Its emissive texture (rgb × `emission`), likewise.
        pub emission_texture: [u32; 4],
        /// Radiance the surface gives off toward a ray that meets its front (`Glass::emission`).
        pub emission: [f32; 3],
        /// A glowing glass mesh's world area (`ReceiverGpu::glow_area`); 0 on analytic shapes,
        /// whose glow lights nothing.
        pub glow_area: f32,
        /// Its tangent-space normal map (glTF's `normalTexture`), as the textures above: it
        /// bends the normal each crossing refracts and reflects about.
        pub normal_texture: [u32; 4],
        /// The normal map's x and y scale (glTF's `normalTexture.scale`).
        pub normal_scale: f32,
        /// The fraction of the light entering the surface that passes it (`Glass::transmission`);
        /// the rest meets a diffuse base of `base_color`.
        pub transmission: f32,
        /// A thin sheet's alpha (× the tint texture's) and cutoff, read as `kind`'s ALPHA_MASK
        /// or ALPHA_BLEND bit says (`Glass::alpha_mode`); neither: the sheet is all there.
        pub alpha: f32,
        pub alpha_cutoff: f32,
        /// Its transmission texture (red × `transmission`), as the textures above.
        pub transmission_texture: [u32; 4],
        /// The colour of the diffuse base and the metal part (`Glass::base`; × the tint texture).
        pub base_color: [f32; 3],
        /// How much of the surface is metal (`Glass::metallic`; × the roughness texture's blue).
        pub metallic: f32,
        /// KHR_materials_specular's colour (`Glass::specular_color`; × its texture's rgb).
        pub specular_color: [f32; 3],
        /// KHR_materials_specular's factor (`Glass::specular`; × its texture's alpha).
        pub specular: f32,
        /// The specular and specular-colour textures, as the textures above.
        pub specular_texture: [u32; 4],
        pub specular_color_texture: [u32; 4],
    }
}

gpu_struct! {
    /// An opaque receiver: its albedo and its caustic charts, one per side a surface faces: slot
    /// 2·axis + (0 for +, 1 for −), plus 6 when it is the back of the triangles that face that
    /// way (the inside of a room) — slots 0–3 in `charts_a`, 4–7 in `charts_b`, 8–11 in
    /// `charts_c`; −1 where it has none. Then its metallic-roughness material (`scene::Diffuse`)
    /// and its textures in the receivers' texels.
    pub struct ReceiverGpu {
        pub albedo: [f32; 3],
        pub alpha: f32,
        pub charts_a: [i32; 4],
        pub charts_b: [i32; 4],
        pub charts_c: [i32; 4],
        /// Emitted radiance (× strength).
        pub emission: [f32; 3],
        pub metallic: f32,
        pub roughness: f32,
        pub specular: f32,
        pub alpha_cutoff: f32,
        /// `receiver_flags` bits.
        pub flags: u32,
        pub normal_scale: f32,
        pub occlusion_strength: f32,
        /// KHR_materials_clearcoat: the coat's weight and perceptual roughness.
        pub clearcoat: f32,
        pub clearcoat_roughness: f32,
        /// KHR_materials_sheen: the sheen's colour and perceptual roughness.
        pub sheen_color: [f32; 3],
        pub sheen_roughness: f32,
        /// Each texture as (first texel, width, height, encoding and wrap modes:
        /// `texel_encoding`); width 0: none.
        pub base_texture: [u32; 4],
        pub metallic_roughness_texture: [u32; 4],
        pub normal_texture: [u32; 4],
        pub occlusion_texture: [u32; 4],
        pub emission_texture: [u32; 4],
        pub clearcoat_texture: [u32; 4],
        pub clearcoat_roughness_texture: [u32; 4],
        pub sheen_color_texture: [u32; 4],
        pub sheen_roughness_texture: [u32; 4],
        pub clearcoat_normal_texture: [u32; 4],
        pub clearcoat_normal_scale: f32,
        /// A glowing receiver's world area and the side it lights from (`mesh_lights::glow_measure`),
        /// for weighing its glow that branches leaving rough glass find; area 0: not weighed.
        pub glow_area: f32,
        pub glow_side: f32,
        pub _pad2: f32,
    }
}

gpu_struct! {
    /// A caustic map: a world-axis-aligned rectangle of texels over a receiver, seen along
    /// `axis` (0..6: +X, −X, +Y, −Y, +Z, −Z). Texel (i, j) covers
    /// `origin + (i, j) · texel` in the two other world axes (u = axis+1, v = axis+2 mod 3).
    pub struct Chart {
        pub origin: [f32; 2],
        pub texel: f32,
        pub axis: u32,
        pub width: u32,
        pub height: u32,
        pub offset: u32,
        pub _pad0: u32,
    }
}

gpu_struct! {
    /// A light in world space, radiometric (see `frame::LightDesc`).
    pub struct LightGpu {
        pub position: [f32; 3],
        pub kind: u32,
        pub direction: [f32; 3],
        pub cos_outer: f32,
        pub right: [f32; 3],
        pub cos_inner: f32,
        pub up: [f32; 3],
        pub half_angle: f32,
        pub radiant: [f32; 3],
        pub size_x: f32,
        pub size_y: f32,
        /// Point and spot lights: the radius of the bulb glass shows, metres.
        pub radius: f32,
        /// The sharp interfaces around the light, packed (`interfaces::media_at`).
        pub media: [u32; 2],
        /// A glowing mesh's triangles: `light_triangles[first .. first + count]`.
        pub first_triangle: u32,
        pub triangle_count: u32,
        /// A glowing mesh's area (m²), and the sides it glows on: 2 (an open mesh, as Cycles'
        /// emission), or 1 for a closed one, its triangles wound outward (the inner side's
        /// light would only land on the mesh itself).
        pub area: f32,
        pub sides: u32,
        /// 1: camera rays see the bulb or panel (`frame::LightDesc::visible`), 0: only glass shows it.
        pub visible: u32,
        /// 1: sampled at rough crossings (`lights_through_rough`); 0: a glowing mesh whose glow
        /// has a pattern (`LightShape::Mesh::patterned`), left to the branches.
        pub rough_sampled: u32,
        pub _pad1: u32,
        pub _pad2: u32,
    }
}

gpu_struct! {
    /// One triangle of a glowing mesh (`LightShape::Mesh`), in world space: corner `v0` and the
    /// edges `e1`, `e2` from it. `cdf`: the mesh's area up to and including this triangle, as a
    /// fraction of its whole, so a uniform number picks triangles by area (by power: the mesh
    /// glows with one radiance).
    pub struct LightTriangle {
        pub v0: [f32; 3],
        pub cdf: f32,
        pub e1: [f32; 3],
        pub _pad0: f32,
        pub e2: [f32; 3],
        pub _pad1: f32,
        /// What a point drawn here weighs, per channel, against the light's mean radiance over
        /// its whole area drawn uniformly: 1 but on a patterned glow's pieces
        /// (`pipeline::mesh_lights`), drawn by their power.
        pub scale: [f32; 3],
        pub _pad2: f32,
    }
}

gpu_struct! {
    /// How one light's photons are placed: a G×G raster of cells over the directions (point,
    /// spot: an equal-area map of the cone around `axis` with cosine `cos_max`) or the area (sun:
    /// a rectangle of half extents `half_width`, `half_height` across `axis`, centred on `origin`)
    /// that can reach the volume. `measure` is each cell's solid angle (sr) or area (m²).
    pub struct Emitter {
        pub origin: [f32; 3],
        pub light: u32,
        pub axis: [f32; 3],
        pub cos_max: f32,
        pub right: [f32; 3],
        pub half_width: f32,
        pub up: [f32; 3],
        pub half_height: f32,
        pub measure: f32,
        pub first_cell: u32,
        /// The environment's emitter: how far from `origin` its photons start, back along their
        /// direction (`lights::scene_reach`: outside every receiver, so a closed room keeps the
        /// sky out).
        pub start_distance: f32,
        pub _pad1: u32,
    }
}

gpu_struct! {
    /// A photon leaving its light: origin, unit direction, flux (W per channel), flags (bit 0: a
    /// live photon; bits 1–31: in a spectral frame, its wavelength sample u = (flags >> 1) / 2³¹).
    pub struct Photon {
        pub origin: [f32; 3],
        pub flags: u32,
        pub dir: [f32; 3],
        /// The sharp interfaces the photon starts inside, packed (from its light): low word…
        pub media_lo: u32,
        pub flux: [f32; 3],
        /// …and high word.
        pub media_hi: u32,
    }
}

gpu_struct! {
    /// The min/max pyramid of the index grid: level L has `levels[L].xyz` cells starting at
    /// cell `levels[L].w` of the octree buffer; level 0 cells span 2×2×2 voxel centres.
    pub struct OctreeParams {
        pub grid: GridParams,
        pub level_count: u32,
        /// A cell is flat when its n varies by less than this…
        pub eps_n: f32,
        /// …and its extinction (largest channel) by less than this, per metre.
        pub eps_sigma: f32,
        /// Cells of level 0, which has a buffer of its own; the levels above lie in a second
        /// buffer from offset `levels[1][3]` = `leaf_cells` on (see `shaders/shared/octree.wgsl`).
        pub leaf_cells: u32,
        /// Per level: cells along x, y, z, and the level's first cell in the whole pyramid.
        pub levels: [[u32; 4]; 12],
    }
}

gpu_struct! {
    /// Uniforms of the photons stage (importance raster, CDF, emission).
    pub struct PhotonParams {
        pub grid: GridParams,
        pub emitter_count: u32,
        /// Cells per side of each emitter's raster.
        pub cells: u32,
        pub photon_count: u32,
        pub seed: u32,
        /// Importance of cells whose rays cross only the scattering medium (not glass).
        pub medium_importance: f32,
        /// n − 1 above which a medium counts as refractive.
        pub eps_refract: f32,
        /// `photon_flags`.
        pub flags: u32,
        /// Where this population's photons go in the photon buffer (the bounce photons follow
        /// the caustic photons).
        pub photon_offset: u32,
        /// The environment, for its emitter (`ENV_LIGHT`): turn, colour and intensity.
        pub env: EnvParams,
        /// This population's first emitter in the emitter buffer.
        pub first_emitter: u32,
        pub _pad2: u32,
        pub _pad3: u32,
        pub _pad4: u32,
    }
}

gpu_struct! {
    /// Uniforms of the march stage.
    pub struct MarchParams {
        pub grid: GridParams,
        pub photon_count: u32,
        pub max_steps: u32,
        /// Arc length of a step where n varies, metres.
        pub min_step: f32,
        /// Longest straight step through a flat cell, metres.
        pub max_step: f32,
        /// Fixed-point units per (photon flux / mean photon flux) · voxel length, radiance grid.
        pub radiance_scale: f32,
        /// Fixed-point units per (photon flux / mean photon flux), caustic maps and statistics.
        pub flux_scale: f32,
        /// W per unit of photon flux / mean photon flux.
        pub flux_unit: f32,
        pub flags: u32,
        pub eps_refract: f32,
        pub receiver_count: u32,
        /// Longest path a photon follows, metres: see `march::max_path`.
        pub max_path: f32,
        /// The frame's photon seed: interface events draw reflect-or-refract from
        /// hash(seed, photon, event).
        pub seed: u32,
        /// KHR dispersion (20/V_d) of the gradient-index media in the grid, for spectral photons.
        pub grid_dispersion: f32,
        /// Spectral photons' wavelengths: uniform in [band_min, band_max] nm when band_max > 0
        /// (narrow-band tests), else over the visible spectrum (`cpu::spectrum`).
        pub band_min: f32,
        pub band_max: f32,
        /// Index of the first bounce photon (`photon_count` when there are none): photons from
        /// it on follow light over diffuse bounces into the indirect maps (march.wgsl).
        pub bounce_first: u32,
        /// Diffuse bounces a bounce photon may take.
        pub bounces: u32,
        /// W per unit of bounce-photon flux / their mean flux (the indirect maps' unit).
        pub bounce_flux_unit: f32,
        /// Fixed-point units per (bounce-photon flux / their mean flux), indirect maps.
        pub bounce_flux_scale: f32,
        /// Where the indirect maps' charts start in `charts` (`receivers::indirect_chart_base`).
        pub indirect_chart_base: u32,
    }
}

gpu_struct! {
    /// Uniforms of the caustics stage (filtering the receivers' caustic maps).
    pub struct CausticParams {
        pub chart_count: u32,
        /// Photons a filter footprint should hold (density-adaptive kernel).
        pub target_count: u32,
        /// 0: adaptive; r > 0: fixed box of half-size r texels.
        pub fixed_radius: u32,
        pub max_radius: u32,
        /// W per fixed-point unit of deposited flux.
        pub flux_unit: f32,
        /// 1: the deposits are XYZ of spectral photons, written out as linear sRGB.
        pub spectral: u32,
        /// Footprint levels of half-size up to this are summed texel by texel, without a table.
        pub direct_radius: u32,
        pub _pad2: u32,
    }
}

gpu_struct! {
    /// One footprint size of the caustic filter (a uniform per level, bound as group 1): the
    /// level's place in the list of sizes, the half-size of its square in texels, and how it is
    /// spread: on the chart coarsened `coarsening`× in each axis, over squares of half-size
    /// `reach` cells there (radius / coarsening; `coarsening` = 1 for the narrow levels).
    pub struct CausticLevel {
        pub index: u32,
        pub radius: u32,
        pub coarsening: u32,
        pub reach: u32,
    }
}

/// Environment kinds, as `EnvParams::kind` (mirrored by constants in `types.wgsl`).
pub mod env_kind {
    /// A constant colour.
    pub const COLOR: u32 = 0;
    /// An equirectangular image, looked up bilinearly.
    pub const IMAGE: u32 = 1;
    /// The studio preset, evaluated per ray (`env_studio`); its image serves glossy lobes.
    pub const STUDIO: u32 = 2;
}

/// Interface kinds, as `Interface::kind` (mirrored by constants in `types.wgsl`).
pub mod interface_kind {
    /// Ends the list of analytic interfaces.
    pub const NONE: u32 = 0;
    pub const SPHERE: u32 = 1;
    pub const BOX: u32 = 2;
    pub const MESH: u32 = 3;
    /// The bits of `kind` that hold the shape.
    pub const SHAPE: u32 = 0xff;
    /// Set in `kind` for a thin sheet or shell: no inside, light passes undeviated or reflects.
    pub const THIN: u32 = 0x100;
    /// Set in `kind` for rough glass that does not keep the light masking takes
    /// (`Glass::multiscatter` false: single-scattering GGX).
    pub const SINGLE_SCATTERING: u32 = 0x200;
    /// Set in `kind` for a thin sheet cut away where its alpha is below its cutoff.
    pub const ALPHA_MASK: u32 = 0x400;
    /// Set in `kind` for a thin sheet that is there by the fraction alpha.
    pub const ALPHA_BLEND: u32 = 0x800;
    /// Set in `BvhTriangle::receiver` of an interface's triangle (low bits: the interface).
    pub const BIT: u32 = 0x8000_0000;
}

/// Field kinds, as `Field::kind` (mirrored by constants in `types.wgsl`).
pub mod field_kind {
    pub const SPHERE: u32 = 0;
    pub const BOX: u32 = 1;
    pub const LUNEBURG: u32 = 2;
    pub const SLAB: u32 = 3;
    /// A script's n(x, y, z), sampled on the CPU (`scene::index_fn`).
    pub const SAMPLED: u32 = 4;
}

/// `ViewParams::flags` bits (mirrored in `types.wgsl`).
pub mod receiver_flags {
    /// Shaded with the full metallic-roughness model (specular lobes, smooth normals, normal
    /// map); without it a receiver is Lambertian, as before PBR.
    pub const PBR: u32 = 1;
    /// alphaMode MASK: a cut-out.
    pub const MASK: u32 = 2;
    /// alphaMode BLEND: see-through.
    pub const BLEND: u32 = 4;
}

/// `ReceiverGpu` texture encodings: how a texel's 8-bit channels decode.
pub mod texel_encoding {
    /// RGB sRGB-encoded (colour textures), A linear.
    pub const SRGB: u32 = 0;
    /// Every channel linear (metallic-roughness, normal, occlusion).
    pub const LINEAR: u32 = 1;
    /// The low byte holds the encoding; bits 8–9 the wrap mode along u, 10–11 along v
    /// (`WRAP_*`).
    pub const WRAP_U_SHIFT: u32 = 8;
    pub const WRAP_V_SHIFT: u32 = 10;
    pub const WRAP_REPEAT: u32 = 0;
    pub const WRAP_CLAMP: u32 = 1;
    pub const WRAP_MIRROR: u32 = 2;
}

pub mod view_flags {
    /// Some object absorbs or scatters: sample the medium grid along rays.
    pub const MEDIA: u32 = 1;
    /// Something scatters: gather in-scattered light from the radiance grid.
    pub const SCATTERING: u32 = 2;
    /// Photons were traced: receivers read their caustic maps.
    pub const CAUSTICS: u32 = 4;
    /// Some receiver is a cut-out or see-through, or some glass a thin sheet: shadow rays look
    /// past them.
    pub const SEE_THROUGH: u32 = 8;
    /// Some receiver has a specular lobe: the prefiltered environment is bound.
    pub const SPECULAR: u32 = 16;
    /// Some glass disperses: each camera sample carries a wavelength (`shaders/view.wgsl`).
    pub const SPECTRAL: u32 = 32;
    /// Bounce photons were traced: receivers read their indirect maps.
    pub const INDIRECT: u32 = 64;
    /// Some light's bulb or panel is seen by camera rays (`LightGpu::visible`).
    pub const VISIBLE_LIGHTS: u32 = 128;
}

/// `PhotonParams::flags` bits.
pub mod photon_flags {
    /// The frame's photons carry wavelengths: their in-cell position and their wavelength are
    /// drawn together (photons.wgsl's `cell_sample`, march.wgsl's `spectral_flux`).
    pub const SPECTRAL: u32 = 1;
}

/// `MarchParams::flags` bits.
pub mod march_flags {
    /// Deposit flux along paths into the radiance grid (only needed when something scatters).
    pub const DEPOSIT_RADIANCE: u32 = 1;
    /// Also deposit the photons' mean direction (only needed when a scattering medium is
    /// anisotropic, g ≠ 0: an isotropic phase function does not look at it). Half the atomics.
    pub const DEPOSIT_DIRECTION: u32 = 2;
    /// Some glass disperses: each photon carries one wavelength and XYZ flux.
    pub const SPECTRAL: u32 = 4;
}

/// `Emitter::light` of the environment's emitter (it has no `LightGpu`).
pub const ENV_LIGHT: u32 = u32::MAX;

/// Light kinds (`LightGpu::kind`).
pub mod light_kind {
    pub const POINT: u32 = 0;
    pub const SPOT: u32 = 1;
    pub const SUN: u32 = 2;
    pub const RECT: u32 = 3;
    /// A rect's inscribed ellipse (`LightShape::Rect { round: true }`).
    pub const DISK: u32 = 4;
    /// A glowing mesh (`LightShape::Mesh`): an emissive receiver's triangles.
    pub const MESH: u32 = 5;
}

/// Probe integrators (`ProbeParams::integrator`).
pub mod integrator {
    /// Velocity Verlet on the ray Hamiltonian: second order, one field sample per step.
    pub const LEAPFROG: u32 = 0;
    /// Forward Euler, the paper's step: first order.
    pub const EULER: u32 = 1;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::shaders::{ShaderLibrary, validate};

    /// Checks one Rust struct against the WGSL struct of the same name.
    fn check<T: GpuLayout>(module: &naga::Module) {
        let (_, ty) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(T::WGSL_NAME))
            .unwrap_or_else(|| panic!("struct {} missing from types.wgsl", T::WGSL_NAME));
        let naga::TypeInner::Struct { members, span } = &ty.inner else {
            panic!("{} is not a struct in WGSL", T::WGSL_NAME)
        };
        let wgsl: Vec<(&str, usize)> =
            members.iter().map(|m| (m.name.as_deref().unwrap_or("?"), m.offset as usize)).collect();
        assert_eq!(wgsl, T::fields(), "member names/offsets of {}", T::WGSL_NAME);
        assert_eq!(*span as usize, std::mem::size_of::<T>(), "size of {}", T::WGSL_NAME);
    }

    #[test]
    fn rust_and_wgsl_structs_agree() {
        let composed = ShaderLibrary::Embedded.compose("shared/types").unwrap();
        let module = validate(&composed).unwrap();
        check::<GridParams>(&module);
        check::<Camera>(&module);
        check::<EnvParams>(&module);
        check::<ViewParams>(&module);
        check::<Field>(&module);
        check::<VoxelizeParams>(&module);
        check::<MeshParams>(&module);
        check::<MeshVolume>(&module);
        check::<ProbeParams>(&module);
        check::<ProbeRay>(&module);
        check::<ProbeRecord>(&module);
        check::<BvhNode>(&module);
        check::<BvhTriangle>(&module);
        check::<Interface>(&module);
        check::<ReceiverGpu>(&module);
        check::<Chart>(&module);
        check::<LightGpu>(&module);
        check::<Emitter>(&module);
        check::<LightTriangle>(&module);
        check::<Photon>(&module);
        check::<OctreeParams>(&module);
        check::<PhotonParams>(&module);
        check::<MarchParams>(&module);
        check::<CausticParams>(&module);
        check::<CausticLevel>(&module);
    }

    /// Every `const INTERFACE_*`, `FIELD_*` and `VIEW_FLAG_*` of types.wgsl has the value its Rust twin has
    /// (a flag added on one side only would be read as another).
    #[test]
    fn rust_and_wgsl_kind_constants_agree() {
        use interface_kind as i;
        let rust = [
            ("INTERFACE_NONE", i::NONE), ("INTERFACE_SPHERE", i::SPHERE), ("INTERFACE_BOX", i::BOX), ("INTERFACE_MESH", i::MESH),
            ("INTERFACE_SHAPE", i::SHAPE), ("INTERFACE_THIN", i::THIN), ("INTERFACE_SINGLE_SCATTERING", i::SINGLE_SCATTERING),
            ("INTERFACE_ALPHA_MASK", i::ALPHA_MASK), ("INTERFACE_ALPHA_BLEND", i::ALPHA_BLEND), ("INTERFACE_BIT", i::BIT), ("FIELD_SPHERE", field_kind::SPHERE), ("FIELD_BOX", field_kind::BOX),
            ("FIELD_LUNEBURG", field_kind::LUNEBURG), ("FIELD_SLAB", field_kind::SLAB), ("FIELD_SAMPLED", field_kind::SAMPLED),
            ("VIEW_FLAG_MEDIA", view_flags::MEDIA), ("VIEW_FLAG_SCATTERING", view_flags::SCATTERING),
            ("VIEW_FLAG_CAUSTICS", view_flags::CAUSTICS), ("VIEW_FLAG_SEE_THROUGH", view_flags::SEE_THROUGH),
            ("VIEW_FLAG_SPECULAR", view_flags::SPECULAR), ("VIEW_FLAG_SPECTRAL", view_flags::SPECTRAL),
            ("VIEW_FLAG_INDIRECT", view_flags::INDIRECT), ("VIEW_FLAG_VISIBLE_LIGHTS", view_flags::VISIBLE_LIGHTS),
        ];
        let text = include_str!("../../shaders/shared/types.wgsl");
        let wgsl: Vec<(&str, u32)> = text
            .lines()
            .filter_map(|l| l.strip_prefix("const ")?.split_once(": u32 = "))
            .filter(|(name, _)| ["INTERFACE_", "FIELD_", "VIEW_FLAG_"].iter().any(|p| name.starts_with(p)))
            .map(|(name, v)| {
                let v = v.trim_end_matches(';').trim_end_matches('u');
                (name, v.strip_prefix("0x").map_or_else(|| v.parse(), |hex| u32::from_str_radix(hex, 16)).unwrap())
            })
            .collect();
        assert_eq!(wgsl, rust);
    }
}
