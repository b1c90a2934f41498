// The voxel grid: world ↔ texture coordinates, the box test, and filtered lookups of the
// index-of-refraction grid. Outside the box the medium is air: n = 1, ∇n = 0.

// Texture coordinates of x. The texture has a few texels more than the grid (frame.rs's
// texture_dims: no side a power of two, for lavapipe's sake), so x is held at most at the last
// voxel's centre: beyond it the sample is that voxel's value, as clamp-to-edge gives it.
fn grid_uvw(grid: GridParams, x: vec3<f32>) -> vec3<f32> {
    let last_centre = (vec3<f32>(grid.dims) - 0.5) * grid.voxel_size;
    return min(x - grid.origin, last_centre) * grid.inv_extent;
}

fn grid_box_max(grid: GridParams) -> vec3<f32> {
    return grid.origin + vec3<f32>(grid.dims) * grid.voxel_size;
}

fn in_grid(grid: GridParams, x: vec3<f32>) -> bool {
    return all(x >= grid.origin) && all(x <= grid_box_max(grid));
}

// Slab test: the parameter interval [t_near, t_far] where origin + t·dir is inside the box
// (t_near > t_far when the line misses it).
fn ray_box(origin: vec3<f32>, dir: vec3<f32>, box_min: vec3<f32>, box_max: vec3<f32>) -> vec2<f32> {
    let inv = 1.0 / dir;
    let t0 = (box_min - origin) * inv;
    let t1 = (box_max - origin) * inv;
    let lo = min(t0, t1);
    let hi = max(t0, t1);
    return vec2<f32>(max(max(lo.x, lo.y), lo.z), min(min(hi.x, hi.y), hi.z));
}

// Dispersion of the gradient-index media along the path being traced: n(λ) − 1 = (n − 1)·k,
// ∇n(λ) = ∇n·k, k = (n(λ) − 1)/(n_d − 1) from KHR_materials_dispersion's formula at the
// path's wavelength (see spectrum.wgsl). 1 (no dispersion) leaves the grid's values as they are.
var<private> grid_dispersion_scale: f32 = 1.0;

// (∇n, n) at x, trilinearly filtered from the rgba16float ior_grid.
fn sample_ior(ior_grid: texture_3d<f32>, lin: sampler, grid: GridParams, x: vec3<f32>) -> vec4<f32> {
    if !in_grid(grid, x) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let g = textureSampleLevel(ior_grid, lin, grid_uvw(grid, x), 0.0);
    if grid_dispersion_scale == 1.0 {
        return g;
    }
    return vec4<f32>(g.xyz * grid_dispersion_scale, 1.0 + (g.w - 1.0) * grid_dispersion_scale);
}

// Any trilinearly filtered rgba grid (extinction, scattering), zero outside the box.
fn sample_grid(tex: texture_3d<f32>, lin: sampler, grid: GridParams, x: vec3<f32>) -> vec4<f32> {
    if !in_grid(grid, x) {
        return vec4<f32>(0.0);
    }
    return textureSampleLevel(tex, lin, grid_uvw(grid, x), 0.0);
}
