// Stage 3, octree: the min/max pyramid of n and extinction over the grid (Sun et al. 2008, §4.2),
// rebuilt every frame. Stored as vec4 (n_min, n_max, σ_min, σ_max) per cell, level 0 in
// `octree_leaves` and the levels above one after another in `octree` (offsets in
// OctreeParams.levels[L].w count from level 0's start; see shared/octree.wgsl) — a mip chain in
// buffers rather than a 3D texture, because level 0 is the dual grid (one cell fewer per axis
// than the voxels) and a buffer lets every stage index any level without a view per mip.
//
// `leaf` fills level 0 from the voxels; `reduce` builds level L from level L−1, one dispatch per
// level. The CPU twin is src/cpu/octree.rs.
//
// A level-0 cell spans the 2×2×2 voxels trilinear interpolation mixes inside it, but ∇n there
// comes from central differences that reach one voxel further: the leaf takes its bounds over
// the 4×4×4 block around the cell, so that in a flat cell ∇n is zero too (to within ε/h) and a
// straight step through it is exactly what the ray equation would do.
//
// Sharp glass (extinction's w, see voxelize.wgsl) is not in n: rays meet it as surfaces
// (shared/interface.wgsl), so the pyramid leaves it out — the air around a glass object and the
// uniform inside of it stay flat at every level, and rays cross both in long straight steps up
// to the surface their lookahead found. Only the photon raster needs to know where sharp glass
// is: `leaf` also writes `glass_mark`, per level-0 cell the largest n − 1 of sharp glass in the
// cell's 4×4×4 block (0 where there is none).

#import shared/types.wgsl

@group(0) @binding(0) var<uniform> octree_params: OctreeParams;
@group(0) @binding(1) var<storage, read> index_field: array<f32>;
@group(0) @binding(2) var extinction_grid: texture_3d<f32>;
@group(0) @binding(3) var<storage, read_write> octree: array<vec4<f32>>;
@group(0) @binding(4) var<uniform> level: u32;
@group(0) @binding(5) var<storage, read_write> glass_mark: array<f32>;
@group(0) @binding(6) var<storage, read_write> octree_leaves: array<vec4<f32>>;

fn voxel_index(p: vec3<u32>) -> u32 {
    let d = octree_params.grid.dims;
    return p.x + d.x * (p.y + d.y * p.z);
}

@compute @workgroup_size(4, 4, 4)
fn leaf(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims0 = octree_params.levels[0].xyz;
    if any(id >= dims0) {
        return;
    }
    var v = vec4<f32>(1e30, -1e30, 1e30, -1e30);
    var sharp = 0.0;
    let last = vec3<i32>(octree_params.grid.dims) - 1;
    for (var k = 0u; k < 64u; k++) {
        let offset = vec3<i32>(i32(k & 3u), i32((k >> 2u) & 3u), i32(k >> 4u)) - 1;
        let p = vec3<u32>(clamp(vec3<i32>(id) + offset, vec3<i32>(0), last));
        let n = index_field[voxel_index(p)];
        let sigma = textureLoad(extinction_grid, p, 0);
        let s = max(sigma.r, max(sigma.g, sigma.b));
        v = vec4<f32>(min(v.x, n), max(v.y, n), min(v.z, s), max(v.w, s));
        sharp = max(sharp, sigma.w);
    }
    let cell = id.x + dims0.x * (id.y + dims0.y * id.z);
    octree_leaves[cell] = v;
    glass_mark[cell] = sharp;
}

@compute @workgroup_size(4, 4, 4)
fn reduce(@builtin(global_invocation_id) id: vec3<u32>) {
    let here = octree_params.levels[level];
    if any(id >= here.xyz) {
        return;
    }
    let below = octree_params.levels[level - 1u];
    var v = vec4<f32>(1e30, -1e30, 1e30, -1e30);
    for (var k = 0u; k < 8u; k++) {
        let c = 2u * id + vec3<u32>(k & 1u, (k >> 1u) & 1u, k >> 2u);
        if all(c < below.xyz) {
            let i = below.w + c.x + below.x * (c.y + below.y * c.z);
            var w: vec4<f32>;
            if level == 1u {
                w = octree_leaves[i];
            } else {
                w = octree[i - octree_params.leaf_cells];
            }
            v = vec4<f32>(min(v.x, w.x), max(v.y, w.y), min(v.z, w.z), max(v.w, w.w));
        }
    }
    octree[here.w - octree_params.leaf_cells + id.x + here.x * (id.y + here.y * id.z)] = v;
}
