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

// Threads walk in step like the rays of a view or the photons of one raster cell do: thread i
// starts on a 1024-wide sheet across the grid and marches mostly along +z, so neighbouring
// threads read neighbouring texels.
fn start(i: u32) -> vec3<f32> {
    return vec3<f32>(f32(i % 1024u) / 1024.0, f32((i / 1024u) % 1024u) / 1024.0, 0.0);
}

fn direction() -> vec3<f32> {
    return normalize(vec3<f32>(0.3, 0.2, 1.0)) / vec3<f32>(grid.dims);
}

@compute @workgroup_size(64)
fn bare_march(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = id.x + id.y * groups.x * 64u;
    var p = start(i);
    let d = direction();
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
    let d = direction();
    var acc = 0.0;
    for (var k = 0u; k < STEPS; k++) {
        p = fract(p + d);
        acc += textureSampleLevel(ior_grid, lin, p, 0.0).w;
    }
    sink[i] = acc;
}
