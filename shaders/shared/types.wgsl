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
    aspect: f32,
    up: vec3<f32>,
    _pad0: f32,
    forward: vec3<f32>,
    _pad1: f32,
}

struct EnvParams {
    color: vec3<f32>,
    intensity: f32,
    rotation: f32,
    kind: u32,
    visible: u32,
    _pad0: u32,
}

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
    _pad0: f32,
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
}

struct VoxelizeParams {
    grid: GridParams,
    field_count: u32,
    mesh_count: u32,
    _pad1: u32,
    _pad2: u32,
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
}

struct ProbeParams {
    grid: GridParams,
    step: f32,
    max_steps: u32,
    record_every: u32,
    ray_count: u32,
    records_per_ray: u32,
    integrator: u32,
    _pad0: u32,
    _pad1: u32,
}

struct ProbeRay {
    origin: vec3<f32>,
    _pad0: f32,
    dir: vec3<f32>,
    _pad1: f32,
}

struct ProbeRecord {
    x: vec3<f32>,
    n: f32,
    v: vec3<f32>,
    steps: u32,
}

const FIELD_SPHERE: u32 = 0u;
const FIELD_BOX: u32 = 1u;
const FIELD_LUNEBURG: u32 = 2u;
const FIELD_SLAB: u32 = 3u;

const VIEW_FLAG_MEDIA: u32 = 1u;

const INTEGRATOR_LEAPFROG: u32 = 0u;
const INTEGRATOR_EULER: u32 = 1u;
