// Queries of the min/max pyramid of n (Sun et al. 2008, §4.2): the largest cell around x where
// n (and the extinction) is constant to within ε, so a ray may cross it in one straight step.
//
// Level 0 cells are the dual cells of the voxel grid — the cube between 2×2×2 voxel centres, in
// which trilinear interpolation only mixes those eight values — so a cell's [min, max] bounds
// every value the filtered field takes inside it. Level L cells merge 2×2×2 cells of level L−1.
//
// Expects the stage to declare `octree_params: OctreeParams` (uniform), `octree_leaves` and
// `octree` (storage, read: array<vec4<f32>> of n_min, n_max, σ_min, σ_max per cell): level 0 in
// the first, the levels above in the second. Level 0 holds 7/8 of the cells; in a buffer of its
// own, a volume's pyramid needs a binding of only its dual grid's size (256×192×154 fits the
// 128 MiB many adapters bind). The CPU twin, src/cpu/octree.rs, keeps one array of all levels.

// Cell `i` of the pyramid, numbered as in the CPU twin's one array (level L from levels[L].w).
fn octree_load(i: u32) -> vec4<f32> {
    if i < octree_params.leaf_cells {
        return octree_leaves[i];
    }
    return octree[i - octree_params.leaf_cells];
}

struct OctreeCell {
    lo: vec3<f32>,
    hi: vec3<f32>,
    is_flat: bool,
}

// The largest flat cell containing x; `is_flat` is false where n varies at voxel scale (or x lies
// in the half-voxel shell outside the dual grid), and then [lo, hi] is empty.
fn octree_cell(x: vec3<f32>) -> OctreeCell {
    let grid = octree_params.grid;
    let u = (x - grid.origin) / grid.voxel_size - 0.5;
    let dual = vec3<f32>(grid.dims - 1u);
    var cell = OctreeCell(x, x, false);
    if any(u < vec3<f32>(0.0)) || any(u >= dual) {
        return cell;
    }
    let c0 = vec3<u32>(u);
    for (var l = i32(octree_params.level_count) - 1; l >= 0; l--) {
        let level = octree_params.levels[l];
        let c = c0 >> vec3<u32>(u32(l));
        let v = octree_load(level.w + c.x + level.x * (c.y + level.y * c.z));
        if v.y - v.x < octree_params.eps_n && v.w - v.z < octree_params.eps_sigma {
            let size = f32(1u << u32(l));
            let lo = vec3<f32>(c) * size;
            let hi = min(lo + size, dual);
            cell.lo = grid.origin + (lo + 0.5) * grid.voxel_size;
            cell.hi = grid.origin + (hi + 0.5) * grid.voxel_size;
            cell.is_flat = true;
            return cell;
        }
    }
    return cell;
}

// Length of a straight step from x along unit d: to the exit of x's flat cell (nudged past its
// face so the next query lands in the next cell), or `min_step` where n varies; clamped to
// [min_step, max_step].
fn octree_step(x: vec3<f32>, d: vec3<f32>, min_step: f32, max_step: f32) -> f32 {
    let cell = octree_cell(x);
    if !cell.is_flat {
        return min_step;
    }
    let exit = ray_box(x, d, cell.lo, cell.hi).y;
    return clamp(exit + 1e-3 * octree_params.grid.voxel_size, min_step, max_step);
}

// One adaptive step of the ray equation: across a flat cell a single straight jump (n is constant
// there to within ε, so the ray is straight), elsewhere one velocity-Verlet step of `min_step`.
// Returns the arc length travelled. Needs shared/ray.wgsl.
fn adaptive_step(ior_grid: texture_3d<f32>, lin: sampler, grid: GridParams, s: ptr<function, RayState>, min_step: f32, max_step: f32) -> f32 {
    let d = normalize((*s).v);
    let jump = octree_step((*s).x, d, min_step, max_step);
    if jump > min_step {
        (*s).x += d * jump;
        (*s).g = sample_ior(ior_grid, lin, grid, (*s).x);
        (*s).v = d * (*s).g.w;
        return jump;
    }
    march_step(ior_grid, lin, grid, s, min_step);
    return min_step;
}
