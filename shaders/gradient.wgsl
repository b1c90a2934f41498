// Stage 2, gradient: the raw index grid n → the ior_grid texture holding (∇n, n).
//
// ∇n by central differences (second order in the voxel size); at the faces of the box the
// neighbour index is clamped, where the margin guarantees air (n = 1, ∇n = 0) anyway. The
// texture is rgba16float: filterable on every adapter, half the bandwidth of rgba32float, and
// its 11-bit significand keeps ∇n to 5·10⁻⁴ relative — below the integrator's error at the
// default half-voxel step (see README, "Index grid precision").
//
// The CPU twin is `cpu::field::gradient`.

#import shared/types.wgsl

@group(0) @binding(0) var<uniform> grid: GridParams;
@group(0) @binding(1) var<storage, read> index_field: array<f32>;
@group(0) @binding(2) var ior_grid: texture_storage_3d<rgba16float, write>;

fn n_at(p: vec3<i32>) -> f32 {
    let c = clamp(p, vec3<i32>(0), vec3<i32>(grid.dims) - 1);
    return index_field[u32(c.x) + grid.dims.x * (u32(c.y) + grid.dims.y * u32(c.z))];
}

@compute @workgroup_size(4, 4, 4)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id >= grid.dims) {
        return;
    }
    let p = vec3<i32>(id);
    let inv_2h = 0.5 / grid.voxel_size;
    let gradient = vec3<f32>(
        n_at(p + vec3<i32>(1, 0, 0)) - n_at(p - vec3<i32>(1, 0, 0)),
        n_at(p + vec3<i32>(0, 1, 0)) - n_at(p - vec3<i32>(0, 1, 0)),
        n_at(p + vec3<i32>(0, 0, 1)) - n_at(p - vec3<i32>(0, 0, 1)),
    ) * inv_2h;
    textureStore(ior_grid, id, vec4<f32>(gradient, n_at(p)));
}
