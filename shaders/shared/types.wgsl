// GPU structs, mirrored member by member from src/gpu/types.rs (a test checks names, offsets
// and sizes). Change both sides together.

struct GridParams {
    origin: vec3<f32>,
    voxel_size: f32,
    dims: vec3<u32>,
    voxel_count: u32,
    inv_extent: vec3<f32>,
    _pad0: f32,
}

struct Camera {
    position: vec3<f32>,
    tan_half_fov: f32,
    right: vec3<f32>,
    // Camera rays start this far along `forward` (metres): Blender's Clip Start, glTF's znear.
    clip_start: f32,
    up: vec3<f32>,
    // Half the view's height of an orthographic camera (metres); 0: a pinhole.
    ortho_half_height: f32,
    forward: vec3<f32>,
    // A thin lens: aperture radius (0: a pinhole), distance to the plane in focus (metres),
    // corners of the polygonal aperture (0: round) and its turn (radians).
    lens_radius: f32,
    focus_distance: f32,
    blades: u32,
    blade_rotation: f32,
    _pad1: f32,
    // The image on the image plane at unit distance: pixel (x, y) at (x0 + x·dx, y0 − y·dy) as
    // (x0, y0, dx, dy) — a region of the frame, moved by the lens shift.
    window: vec4<f32>,
}

struct EnvParams {
    color: vec3<f32>,
    intensity: f32,
    turn: vec4<f32>,
    kind: u32,
    visible: u32,
    footprint: f32,
    _pad0: f32,
}

// EnvParams.kind (src/gpu/types.rs, env_kind).
const ENV_COLOR: u32 = 0u;
const ENV_IMAGE: u32 = 1u;
const ENV_STUDIO: u32 = 2u;

struct ViewParams {
    camera: Camera,
    grid: GridParams,
    env: EnvParams,
    width: u32,
    height: u32,
    max_steps: u32,
    flags: u32,
    step: f32,
    medium_eps: f32,
    samples: u32,
    light_count: u32,
    max_step: f32,
    eps_refract: f32,
    max_path: f32,
    camera_media_lo: u32,
    env_pairs: u32,
    indirect_chart_base: u32,
    glowing_count: u32,
    camera_media_hi: u32,
    sample_first: u32,
    sample_count: u32,
    grid_dispersion: f32,
    wavelengths_per_sample: u32,
    pixel_key_first: u32,
    pixel_key_stride: u32,
    _pad: vec2<u32>,
}

struct Field {
    world_to_local: mat4x4<f32>,
    half_size: vec3<f32>,
    kind: u32,
    ior: f32,
    ior_gradient: f32,
    boundary: f32,
    scale: f32,
    absorption: vec4<f32>,
    scattering: vec4<f32>,
    sample_first: vec3<u32>,
    sample_offset: u32,
    sample_dims: vec3<u32>,
    sharp: u32,
}

struct VoxelizeParams {
    grid: GridParams,
    field_count: u32,
    mesh_count: u32,
    _pad1: u32,
    _pad2: u32,
    fog_absorption: vec4<f32>,
    fog_scattering: vec4<f32>,
}

struct MeshParams {
    grid_from_local: mat4x4<f32>,
    window_min: vec3<i32>,
    fixed_bits: u32,
    window_dims: vec3<u32>,
    triangle_count: u32,
    axis_offset: vec3<u32>,
    vertex_count: u32,
    axis_words: vec3<u32>,
    atlas_offset: u32,
    reach: f32,
    parity_words: u32,
    band_voxels: u32,
    _pad0: u32,
}

struct MeshVolume {
    window_min: vec3<u32>,
    atlas_offset: u32,
    window_dims: vec3<u32>,
    ior: f32,
    absorption: vec3<f32>,
    boundary: f32,
    scattering: vec4<f32>,
    sharp: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct ProbeParams {
    grid: GridParams,
    step: f32,
    max_steps: u32,
    record_every: u32,
    ray_count: u32,
    records_per_ray: u32,
    integrator: u32,
    max_step: f32,
    _pad1: u32,
}

struct ProbeRay {
    origin: vec3<f32>,
    wavelength: f32,
    dir: vec3<f32>,
    grid_dispersion: f32,
}

struct ProbeRecord {
    x: vec3<f32>,
    n: f32,
    v: vec3<f32>,
    steps: u32,
}

struct BvhNode {
    min: vec3<f32>,
    first: u32,
    max: vec3<f32>,
    count: u32,
}

struct BvhTriangle {
    v0: vec3<f32>,
    receiver: u32,
    e1: vec3<f32>,
    _pad0: u32,
    e2: vec3<f32>,
    _pad1: u32,
}

struct Interface {
    world_to_local: mat4x4<f32>,
    half_size: vec3<f32>,
    kind: u32,
    tint: vec3<f32>,
    ior: f32,
    absorption: vec3<f32>,
    roughness: f32,
    dispersion: f32,
    rank: u32,
    contact: f32,
    // A glowing glass mesh's side and world area, as a receiver's (glow_side, glow_area).
    glow_side: f32,
    roughness_texture: vec4<u32>,
    tint_texture: vec4<u32>,
    emission_texture: vec4<u32>,
    emission: vec3<f32>,
    glow_area: f32,
    // A glass mesh's tangent-space normal map and its x, y scale.
    normal_texture: vec4<u32>,
    normal_scale: f32,
    // The fraction of the light entering the surface that passes it; the rest meets a diffuse
    // base of the base colour. Times the transmission texture's red channel.
    transmission: f32,
    // A thin sheet's alpha and cutoff, read as the kind's INTERFACE_ALPHA_* bit says.
    alpha: f32,
    alpha_cutoff: f32,
    transmission_texture: vec4<u32>,
    // The colour of the diffuse base and the metal part (the tint unless a Principled BSDF's
    // Base Color differs from it), × the tint texture.
    base_color: vec3<f32>,
    // How much of the surface is metal (× the roughness texture's blue channel).
    metallic: f32,
    // KHR_materials_specular: the colour scaling F0 (× its texture's rgb) and the factor
    // scaling the whole reflectance (× its texture's alpha).
    specular_color: vec3<f32>,
    specular: f32,
    specular_texture: vec4<u32>,
    specular_color_texture: vec4<u32>,
}

struct ReceiverGpu {
    albedo: vec3<f32>,
    alpha: f32,
    charts_a: vec4<i32>,
    charts_b: vec4<i32>,
    charts_c: vec4<i32>,
    emission: vec3<f32>,
    metallic: f32,
    roughness: f32,
    specular: f32,
    alpha_cutoff: f32,
    flags: u32,
    normal_scale: f32,
    occlusion_strength: f32,
    clearcoat: f32,
    clearcoat_roughness: f32,
    sheen_color: vec3<f32>,
    sheen_roughness: f32,
    base_texture: vec4<u32>,
    metallic_roughness_texture: vec4<u32>,
    normal_texture: vec4<u32>,
    occlusion_texture: vec4<u32>,
    emission_texture: vec4<u32>,
    clearcoat_texture: vec4<u32>,
    clearcoat_roughness_texture: vec4<u32>,
    sheen_color_texture: vec4<u32>,
    sheen_roughness_texture: vec4<u32>,
    clearcoat_normal_texture: vec4<u32>,
    clearcoat_normal_scale: f32,
    // A glowing receiver's world area and the side it lights from (0 both, ±1 the side its
    // triangles' normals point to or the other); area 0: its glow is not weighed (view.wgsl).
    glow_area: f32,
    glow_side: f32,
    _pad2: f32,
}

const RECEIVER_PBR: u32 = 1u;
const RECEIVER_MASK: u32 = 2u;
const RECEIVER_BLEND: u32 = 4u;
const TEXEL_SRGB: u32 = 0u;
// A texture's encoding is the low byte of its fourth word; bits 8–9 and 10–11 its wrap modes
// along u and v (texel_encoding in src/gpu/types.rs).
const WRAP_REPEAT: u32 = 0u;
const WRAP_CLAMP: u32 = 1u;
const WRAP_MIRROR: u32 = 2u;

struct Chart {
    origin: vec2<f32>,
    texel: f32,
    axis: u32,
    width: u32,
    height: u32,
    offset: u32,
    _pad0: u32,
}

struct LightGpu {
    position: vec3<f32>,
    kind: u32,
    direction: vec3<f32>,
    cos_outer: f32,
    right: vec3<f32>,
    cos_inner: f32,
    up: vec3<f32>,
    half_angle: f32,
    radiant: vec3<f32>,
    size_x: f32,
    size_y: f32,
    radius: f32,
    media: vec2<u32>,
    // A glowing mesh's triangles (light_triangles[first_triangle ..][.. triangle_count]), area
    // and the sides it glows on (2, or 1 for a closed mesh wound outward).
    first_triangle: u32,
    triangle_count: u32,
    area: f32,
    sides: u32,
    // 1: camera rays see the bulb or panel; 0: only glass shows it.
    visible: u32,
    // 1: sampled at rough crossings; 0: a glowing mesh with a pattern, left to the branches.
    rough_sampled: u32,
    _pad1: u32,
    _pad2: u32,
}

// One triangle of a glowing mesh: corner v0, edges e1 and e2, and the mesh's area fraction up to
// and including it (`cdf`).
struct LightTriangle {
    v0: vec3<f32>,
    cdf: f32,
    e1: vec3<f32>,
    _pad0: f32,
    e2: vec3<f32>,
    _pad1: f32,
    // A patterned glow's piece: its radiance over the light's, over the density it is drawn
    // with (src/pipeline/mesh_lights.rs, `piece_scale`); 1 on a glow of one radiance.
    scale: vec3<f32>,
    _pad2: f32,
}

struct Emitter {
    origin: vec3<f32>,
    light: u32,
    axis: vec3<f32>,
    cos_max: f32,
    right: vec3<f32>,
    half_width: f32,
    up: vec3<f32>,
    half_height: f32,
    measure: f32,
    first_cell: u32,
    start_distance: f32,
    _pad1: u32,
}

struct Photon {
    origin: vec3<f32>,
    flags: u32,
    dir: vec3<f32>,
    media_lo: u32,
    flux: vec3<f32>,
    media_hi: u32,
}

struct OctreeParams {
    grid: GridParams,
    level_count: u32,
    eps_n: f32,
    eps_sigma: f32,
    leaf_cells: u32,
    levels: array<vec4<u32>, 12>,
}

struct PhotonParams {
    grid: GridParams,
    emitter_count: u32,
    cells: u32,
    photon_count: u32,
    seed: u32,
    medium_importance: f32,
    eps_refract: f32,
    // PHOTON_FLAG_* bits.
    flags: u32,
    photon_offset: u32,
    env: EnvParams,
    first_emitter: u32,
    _pad2: u32,
    _pad3: u32,
    _pad4: u32,
}

struct MarchParams {
    grid: GridParams,
    photon_count: u32,
    max_steps: u32,
    min_step: f32,
    max_step: f32,
    radiance_scale: f32,
    flux_scale: f32,
    flux_unit: f32,
    flags: u32,
    eps_refract: f32,
    receiver_count: u32,
    max_path: f32,
    seed: u32,
    grid_dispersion: f32,
    band_min: f32,
    band_max: f32,
    bounce_first: u32,
    bounces: u32,
    bounce_flux_unit: f32,
    bounce_flux_scale: f32,
    indirect_chart_base: u32,
}

struct CausticParams {
    chart_count: u32,
    target_count: u32,
    fixed_radius: u32,
    max_radius: u32,
    flux_unit: f32,
    spectral: u32,
    direct_radius: u32,
    _pad2: u32,
}

struct CausticLevel {
    index: u32,
    radius: u32,
    coarsening: u32,
    reach: u32,
}

const INTERFACE_NONE: u32 = 0u;
const INTERFACE_SPHERE: u32 = 1u;
const INTERFACE_BOX: u32 = 2u;
const INTERFACE_MESH: u32 = 3u;
const INTERFACE_SHAPE: u32 = 0xffu;
const INTERFACE_THIN: u32 = 0x100u;
const INTERFACE_SINGLE_SCATTERING: u32 = 0x200u;
const INTERFACE_ALPHA_MASK: u32 = 0x400u;
const INTERFACE_ALPHA_BLEND: u32 = 0x800u;
const INTERFACE_BIT: u32 = 0x80000000u;

const FIELD_SPHERE: u32 = 0u;
const FIELD_BOX: u32 = 1u;
const FIELD_LUNEBURG: u32 = 2u;
const FIELD_SLAB: u32 = 3u;
const FIELD_SAMPLED: u32 = 4u;

const VIEW_FLAG_MEDIA: u32 = 1u;
const VIEW_FLAG_SCATTERING: u32 = 2u;
const VIEW_FLAG_CAUSTICS: u32 = 4u;
const VIEW_FLAG_SEE_THROUGH: u32 = 8u;
const VIEW_FLAG_SPECULAR: u32 = 16u;
const VIEW_FLAG_SPECTRAL: u32 = 32u;
const VIEW_FLAG_INDIRECT: u32 = 64u;
const VIEW_FLAG_VISIBLE_LIGHTS: u32 = 128u;

const MARCH_FLAG_DEPOSIT_RADIANCE: u32 = 1u;
const MARCH_FLAG_DEPOSIT_DIRECTION: u32 = 2u;
const MARCH_FLAG_SPECTRAL: u32 = 4u;

const PHOTON_FLAG_SPECTRAL: u32 = 1u;

// Photon.flags: bit 0 marks a live photon; bits 1–31 hold a spectral photon's wavelength sample.
const PHOTON_LIVE: u32 = 1u;

const LIGHT_POINT: u32 = 0u;
const LIGHT_SPOT: u32 = 1u;
const LIGHT_SUN: u32 = 2u;
const LIGHT_RECT: u32 = 3u;
const LIGHT_DISK: u32 = 4u;
const LIGHT_MESH: u32 = 5u;
// Emitter.light of the environment's emitter (it has no LightGpu).
const ENV_LIGHT: u32 = 0xffffffffu;

const INTEGRATOR_LEAPFROG: u32 = 0u;
const INTEGRATOR_EULER: u32 = 1u;
