// Stage 1, voxelize: analytic index fields and voxelized meshes → the raw index grid n and the
// medium grids.
//
// The volume starts as the scene's fog (or empty air). Each object contributes a smooth
// coverage α ∈ [0, 1] (a C² step across its boundary, `boundary` metres wide, centred on the
// surface) and its own index n_f and medium. Objects are composited in order, later over
// earlier: n ← mix(n, n_f, α) — first the index fields in scene order, then the meshes in scene
// order, so where glass objects overlap the later-listed one wins (a mesh over any field). A
// smooth α keeps ∇n finite, so the ray equation bends rays at a surface the way Snell's law does
// in the limit of a thin boundary. A field's α comes from its analytic signed distance; a
// mesh's from the signed distance voxelize_mesh.wgsl left in the atlas.
//
// Sharp interfaces (constant-index glass spheres, boxes and closed meshes, `sharp` = 1) put no n
// into the grid: rays refract at their exact surfaces (shared/interface.wgsl) and take their
// absorption from the interface itself. They add only their scattering (with a hard edge) and
// mark the voxels they touch in the extinction grid's w — the excess n − 1 of the glass there —
// so the octree can tell photons where glass is (octree.wgsl).
//
// The CPU twin is src/cpu/field.rs (fields) and src/cpu/mesh.rs (meshes).

#import shared/types.wgsl

@group(0) @binding(0) var<uniform> params: VoxelizeParams;
@group(0) @binding(1) var<storage, read> fields: array<Field>;
@group(0) @binding(2) var<storage, read_write> index_field: array<f32>;
@group(0) @binding(3) var extinction_grid: texture_storage_3d<rgba16float, write>;
@group(0) @binding(4) var scattering_grid: texture_storage_3d<rgba16float, write>;
@group(0) @binding(5) var<storage, read> field_samples: array<f32>;
@group(0) @binding(6) var<storage, read> meshes: array<MeshVolume>;
@group(0) @binding(7) var<storage, read> atlas: array<f32>;

// Quintic smoothstep on [0, 1]: C², so ∇n is continuous across the boundary.
fn smootherstep(t: f32) -> f32 {
    let u = clamp(t, 0.0, 1.0);
    return u * u * u * (u * (u * 6.0 - 15.0) + 10.0);
}

// Coverage from signed distance d (metres, negative inside) and boundary width w.
fn coverage(d: f32, w: f32) -> f32 {
    if w <= 0.0 {
        return select(0.0, 1.0, d < 0.0);
    }
    return smootherstep(0.5 - d / w);
}

fn box_distance(p: vec3<f32>, half_size: vec3<f32>) -> f32 {
    let q = abs(p) - half_size;
    return length(max(q, vec3<f32>(0.0))) + min(max(q.x, max(q.y, q.z)), 0.0);
}

// n of a sampled field (a script's n(x, y, z), evaluated on the CPU at voxel centres) at the
// voxel containing x; `ok` is false outside its block of samples, where coverage is zero anyway.
struct Sample {
    n: f32,
    ok: bool,
}

fn sampled_index(f: Field, x: vec3<f32>) -> Sample {
    let v = vec3<i32>(floor((x - params.grid.origin) / params.grid.voxel_size)) - vec3<i32>(f.sample_first);
    if any(v < vec3<i32>(0)) || any(v >= vec3<i32>(f.sample_dims)) {
        return Sample(1.0, false);
    }
    let i = vec3<u32>(v);
    return Sample(field_samples[f.sample_offset + i.x + f.sample_dims.x * (i.y + f.sample_dims.y * i.z)], true);
}

// (α, n_f) of one field at world point x.
fn field_sample(f: Field, x: vec3<f32>) -> vec2<f32> {
    let p = (f.world_to_local * vec4<f32>(x, 1.0)).xyz;
    switch f.kind {
        case FIELD_SPHERE: {
            return vec2<f32>(coverage((length(p) - f.half_size.x) * f.scale, f.boundary), f.ior);
        }
        case FIELD_BOX: {
            return vec2<f32>(coverage(box_distance(p, f.half_size) * f.scale, f.boundary), f.ior);
        }
        case FIELD_LUNEBURG: {
            // n(r) = sqrt(2 − (r/R)²) inside, 1 on the surface: continuous, so no seam.
            let r = length(p) / f.half_size.x;
            let n = sqrt(max(2.0 - r * r, 1.0));
            return vec2<f32>(coverage((length(p) - f.half_size.x) * f.scale, f.boundary), n);
        }
        case FIELD_SAMPLED: {
            let s = sampled_index(f, x);
            return vec2<f32>(select(0.0, coverage(box_distance(p, f.half_size) * f.scale, f.boundary), s.ok), s.n);
        }
        default: {
            // FIELD_SLAB: n = n₀ + g·y along the local y axis (metres).
            let n = f.ior + f.ior_gradient * p.y * f.scale;
            return vec2<f32>(coverage(box_distance(p, f.half_size) * f.scale, f.boundary), n);
        }
    }
}

// What one object contributes at a voxel: coverage α, its index there, and whether it is sharp.
struct Contribution {
    alpha: f32,
    n: f32,
    sharp: bool,
}

// The grids so far at a voxel, and the object composited over them.
struct Voxel {
    n: f32,
    absorption: vec3<f32>,
    scattering: vec4<f32>,
    sharp_excess: f32,
}

fn composite(v: ptr<function, Voxel>, c: Contribution, absorption: vec3<f32>, scattering: vec4<f32>) {
    if c.sharp {
        let inside = select(0.0, 1.0, c.alpha >= 0.5);
        (*v).scattering = mix((*v).scattering, scattering, inside);
        if c.alpha > 0.0 {
            (*v).sharp_excess = max((*v).sharp_excess, abs(c.n - 1.0));
        }
        return;
    }
    (*v).n = mix((*v).n, c.n, c.alpha);
    (*v).absorption = mix((*v).absorption, absorption, c.alpha);
    (*v).scattering = mix((*v).scattering, scattering, c.alpha);
}

@compute @workgroup_size(4, 4, 4)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let grid = params.grid;
    if any(id >= grid.dims) {
        return;
    }
    let x = grid.origin + (vec3<f32>(id) + 0.5) * grid.voxel_size;
    var v = Voxel(1.0, params.fog_absorption.rgb, params.fog_scattering, 0.0);
    // The loop bounds also read the arrays' lengths: bounds taken from uniforms alone let Mesa
    // 22.3's lavapipe specialise this shader on their values and compile it again at every
    // dispatch, never freeing the last variant (~0.5 MiB per volume rebuild; tests/memory.rs).
    for (var i = 0u; i < min(params.field_count, arrayLength(&fields)); i++) {
        let f = fields[i];
        let s = field_sample(f, x);
        composite(&v, Contribution(s.x, s.y, f.sharp != 0u), f.absorption.rgb, f.scattering);
    }
    for (var i = 0u; i < min(params.mesh_count, arrayLength(&meshes)); i++) {
        let m = meshes[i];
        let local = vec3<i32>(id) - vec3<i32>(m.window_min);
        if any(local < vec3<i32>(0)) || any(local >= vec3<i32>(m.window_dims)) {
            continue;
        }
        let w = vec3<u32>(local);
        // Signed distance in voxels, negative inside.
        let d = atlas[m.atlas_offset + w.x + m.window_dims.x * (w.y + m.window_dims.y * w.z)];
        let alpha = coverage(d * grid.voxel_size, m.boundary);
        composite(&v, Contribution(alpha, m.ior, m.sharp != 0u), m.absorption, m.scattering);
    }
    let idx = id.x + grid.dims.x * (id.y + grid.dims.y * id.z);
    index_field[idx] = v.n;
    // Extinction σ_t = absorption + scattering (w: the sharp glass mark); the scattering grid
    // keeps σ_s and g for the in-scattering term.
    textureStore(extinction_grid, id, vec4<f32>(v.absorption + v.scattering.rgb, v.sharp_excess));
    textureStore(scattering_grid, id, v.scattering);
}
