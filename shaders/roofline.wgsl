// Bare kernels that bound what the march and view stages can reach on this GPU (`refrakt
// bench`): the work each step cannot avoid, and nothing else.
//
// `bare_march`: per step, one trilinear sample of an rgba16float 3D texture and one u32
// atomicAdd into a grid — what a photon step costs at least. `bare_view`: per step, one
// trilinear sample — what a view-ray step costs at least.

#import shared/types.wgsl

@group(0) @binding(0) var<uniform> grid: GridParams;
@group(0) @binding(1) var ior_grid: texture_3d<f32>;
@group(0) @binding(2) var lin: sampler;
@group(0) @binding(3) var<storage, read_write> deposits: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read_write> sink: array<f32>;

const STEPS: u32 = 256u;

// A start point and direction per thread, spread over the grid (a cheap integer hash).
fn start(i: u32) -> vec3<f32> {
    let h = vec3<u32>(i * 73856093u, i * 19349663u, i * 83492791u);
    return vec3<f32>(h % 1024u) / 1024.0;
}

@compute @workgroup_size(64)
fn bare_march(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = id.x + id.y * groups.x * 64u;
    var p = start(i);
    let d = normalize(start(i + 7919u) - 0.5) / vec3<f32>(grid.dims);
    var acc = 0.0;
    for (var k = 0u; k < STEPS; k++) {
        p = fract(p + d);
        acc += textureSampleLevel(ior_grid, lin, p, 0.0).w;
        let c = min(vec3<u32>(p * vec3<f32>(grid.dims)), grid.dims - 1u);
        atomicAdd(&deposits[c.x + grid.dims.x * (c.y + grid.dims.y * c.z)], 1u);
    }
    sink[i] = acc;
}

@compute @workgroup_size(64)
fn bare_view(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = id.x + id.y * groups.x * 64u;
    var p = start(i);
    let d = normalize(start(i + 7919u) - 0.5) / vec3<f32>(grid.dims);
    var acc = 0.0;
    for (var k = 0u; k < STEPS; k++) {
        p = fract(p + d);
        acc += textureSampleLevel(ior_grid, lin, p, 0.0).w;
    }
    sink[i] = acc;
}
