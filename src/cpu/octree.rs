//! CPU twin of `shaders/octree.wgsl` (building the min/max pyramid) and of the queries in
//! `shaders/shared/octree.wgsl`.

use glam::{UVec3, Vec3};

use crate::gpu::types::OctreeParams;

/// The pyramid for voxel values `n` and `sigma` (largest extinction channel), laid out as
/// `params.levels` says.
pub fn build(params: &OctreeParams, n: &[f32], sigma: &[f32]) -> Vec<[f32; 4]> {
    let d = UVec3::from(params.grid.dims);
    let voxel = |p: UVec3| (p.x + d.x * (p.y + d.y * p.z)) as usize;
    let level = |l: usize| UVec3::new(params.levels[l][0], params.levels[l][1], params.levels[l][2]);
    let mut out = vec![[0.0; 4]; super::super::pipeline::octree::cell_count(params) as usize];
    let merge = |v: [f32; 4], w: [f32; 4]| [v[0].min(w[0]), v[1].max(w[1]), v[2].min(w[2]), v[3].max(w[3])];
    let empty = [1e30, -1e30, 1e30, -1e30];
    let d0 = level(0);
    for z in 0..d0.z {
        for y in 0..d0.y {
            for x in 0..d0.x {
                let mut v = empty;
                for p in leaf_block(params, UVec3::new(x, y, z)) {
                    let (nv, s) = (n[voxel(p)], sigma[voxel(p)]);
                    v = merge(v, [nv, nv, s, s]);
                }
                out[(x + d0.x * (y + d0.y * z)) as usize] = v;
            }
        }
    }
    for l in 1..params.level_count as usize {
        let (here, below) = (level(l), level(l - 1));
        let (off, boff) = (params.levels[l][3], params.levels[l - 1][3]);
        for z in 0..here.z {
            for y in 0..here.y {
                for x in 0..here.x {
                    let mut v = empty;
                    for k in 0..8u32 {
                        let c = UVec3::new(2 * x + (k & 1), 2 * y + ((k >> 1) & 1), 2 * z + (k >> 2));
                        if c.cmplt(below).all() {
                            v = merge(v, out[(boff + c.x + below.x * (c.y + below.y * c.z)) as usize]);
                        }
                    }
                    out[(off + x + here.x * (y + here.y * z)) as usize] = v;
                }
            }
        }
    }
    out
}

/// The voxels of level-0 cell `c`'s block: the 4×4×4 whose values reach the cell through ∇n's
/// central differences (clamped at the grid's faces).
fn leaf_block(params: &OctreeParams, c: UVec3) -> impl Iterator<Item = UVec3> {
    let last = UVec3::from(params.grid.dims).as_ivec3() - 1;
    (0..64i32).map(move |k| {
        let offset = glam::IVec3::new(k & 3, (k >> 2) & 3, k >> 4) - 1;
        (c.as_ivec3() + offset).clamp(glam::IVec3::ZERO, last).as_uvec3()
    })
}

/// The glass mark per level-0 cell (`shaders/octree.wgsl`'s `glass_mark`): the largest `sharp`
/// (extinction's w: n − 1 of sharp glass) over the cell's block.
pub fn glass_mark(params: &OctreeParams, sharp: &[f32]) -> Vec<f32> {
    let d = UVec3::from(params.grid.dims);
    let d0 = UVec3::new(params.levels[0][0], params.levels[0][1], params.levels[0][2]);
    let mut out = Vec::with_capacity((d0.x * d0.y * d0.z) as usize);
    for z in 0..d0.z {
        for y in 0..d0.y {
            for x in 0..d0.x {
                let mark = leaf_block(params, UVec3::new(x, y, z)).map(|p| sharp[(p.x + d.x * (p.y + d.y * p.z)) as usize]).fold(0.0f32, f32::max);
                out.push(mark);
            }
        }
    }
    out
}

/// The largest flat cell containing `x`, as (lo, hi), or `None` where n varies at voxel scale.
pub fn cell(params: &OctreeParams, octree: &[[f32; 4]], x: Vec3) -> Option<(Vec3, Vec3)> {
    let g = &params.grid;
    let u = (x - Vec3::from(g.origin)) / g.voxel_size - 0.5;
    let dual = (UVec3::from(g.dims) - 1).as_vec3();
    if u.cmplt(Vec3::ZERO).any() || u.cmpge(dual).any() {
        return None;
    }
    let c0 = u.as_uvec3();
    for l in (0..params.level_count as usize).rev() {
        let lv = params.levels[l];
        let c = c0 >> l as u32;
        let v = octree[(lv[3] + c.x + lv[0] * (c.y + lv[1] * c.z)) as usize];
        if v[1] - v[0] < params.eps_n && v[3] - v[2] < params.eps_sigma {
            let size = (1u32 << l) as f32;
            let lo = c.as_vec3() * size;
            let hi = (lo + size).min(dual);
            let origin = Vec3::from(g.origin);
            return Some((origin + (lo + 0.5) * g.voxel_size, origin + (hi + 0.5) * g.voxel_size));
        }
    }
    None
}

/// The straight step allowed from `x` along unit `d` — twin of `octree_step`.
pub fn step(params: &OctreeParams, octree: &[[f32; 4]], x: Vec3, d: Vec3, min_step: f32, max_step: f32) -> f32 {
    let Some((lo, hi)) = cell(params, octree, x) else { return min_step };
    let inv = d.recip();
    let t0 = (lo - x) * inv;
    let t1 = (hi - x) * inv;
    let exit = t0.max(t1).min_element();
    (exit + 1e-3 * params.grid.voxel_size).clamp(min_step, max_step)
}
