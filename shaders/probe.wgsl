// Diagnostic kernels: `main` traces given rays through the ior_grid with the integrator the view
// and photon passes use, recording their state along the way; `octree_query` reports the
// straight step the octree allows at given points; `dda_cells` lists the cells a segment
// (origin → origin + dir, in cell units) crosses, as the photons' deposits do. Tests compare both with the CPU twins and
// with closed-form optics; `refrakt trace` prints them.
//
// records[ray · records_per_ray + k] holds the state after k · record_every steps, the last
// slot the state where the ray left the volume (or ran out of steps).

#import shared/types.wgsl
#import shared/grid.wgsl
#import shared/ray.wgsl
#import shared/octree.wgsl
#import shared/bvh.wgsl
#import shared/interface.wgsl
#import shared/dda.wgsl
#import shared/glass_surface.wgsl

@group(0) @binding(0) var<uniform> params: ProbeParams;
@group(0) @binding(1) var ior_grid: texture_3d<f32>;
@group(0) @binding(2) var grid_sampler: sampler;
@group(0) @binding(3) var<storage, read> rays: array<ProbeRay>;
@group(0) @binding(4) var<storage, read_write> records: array<ProbeRecord>;
@group(0) @binding(5) var<uniform> octree_params: OctreeParams;
@group(0) @binding(6) var<storage, read> octree: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> steps_out: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(9) var<storage, read> bvh_triangles: array<BvhTriangle>;
@group(0) @binding(10) var<storage, read> interfaces: array<Interface>;
@group(0) @binding(11) var<storage, read> triangle_normals: array<vec4<f32>>;
@group(0) @binding(12) var<storage, read> octree_leaves: array<vec4<f32>>;
// The rough glass albedo table (shared/rough_albedo.wgsl).
@group(0) @binding(13) var<storage, read> rough_albedo_table: array<f32>;
// Glass meshes' textures (shared/glass_surface.wgsl): a normal map bends the crossings.
@group(0) @binding(14) var<storage, read> triangle_uvs: array<vec4<f32>>;
@group(0) @binding(15) var<storage, read> albedo_texels: array<u32>;

fn record(slot: u32, s: RayState, steps: u32) {
    records[slot] = ProbeRecord(s.x, s.g.w, s.v, steps);
}

// The arc length the next step will take from s.
fn step_length(s: RayState) -> f32 {
    if params.integrator != INTEGRATOR_EULER && params.max_step > 0.0 {
        return octree_step(s.x, normalize(s.v), params.step, params.max_step);
    }
    return params.step;
}

// Crosses the interface `hit` found within the next step: the transmitted branch (the
// reflected one under total internal reflection), from just past the surface.
fn cross_surface(s: ptr<function, RayState>, media: ptr<function, Media>, hit: SurfaceHit) {
    let d = normalize((*s).v);
    let p = (*s).x + d * hit.t;
    // (On a rough surface the probe follows the microfacet its first pair of numbers picks.)
    let c = cross_interface(p, d, hit, glass_surface_at(hit, SURFACE_NORMAL), *media, vec2<f32>(0.0));
    var w = c.reflected;
    if c.reflectance < 1.0 {
        w = c.transmitted;
    }
    *media = media_along(c, w, *media);
    // (v = n·dir with the grid's n: a sharp object's own n is not in the grid, and straight
    // travel inside it needs none.)
    *s = ray_start(ior_grid, grid_sampler, params.grid, crossing_exit(c, p, d, w, 1e-3 * params.grid.voxel_size), w);
}

fn advance(s: ptr<function, RayState>, media: ptr<function, Media>) {
    let len = step_length(*s);
    let hit = surface_hit((*s).x, normalize((*s).v), 0.0, len, NO_INTERFACE);
    if hit.interface_id != NO_INTERFACE {
        cross_surface(s, media, hit);
        return;
    }
    if params.integrator == INTEGRATOR_EULER {
        march_step_euler(ior_grid, grid_sampler, params.grid, s, params.step);
    } else if params.max_step > 0.0 {
        adaptive_step(ior_grid, grid_sampler, params.grid, s, params.step, params.max_step);
    } else {
        march_step(ior_grid, grid_sampler, params.grid, s, params.step);
    }
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let r = id.x;
    if r >= params.ray_count {
        return;
    }
    let grid = params.grid;
    let ray = rays[r];
    path_wavelength = ray.wavelength;
    grid_dispersion_scale = dispersion_scale(ray.grid_dispersion, ray.wavelength);
    let span = ray_box(ray.origin, ray.dir, grid.origin, grid_box_max(grid));
    let base = r * params.records_per_ray;
    var s = ray_start(ior_grid, grid_sampler, grid, ray.origin + ray.dir * max(span.x, 0.0), ray.dir);
    record(base, s, 0u);
    var steps = 0u;
    var media = no_media();
    if span.x <= span.y && span.y > 0.0 {
        for (; steps < params.max_steps; steps++) {
            advance(&s, &media);
            let k = (steps + 1u) / params.record_every;
            if (steps + 1u) % params.record_every == 0u && k < params.records_per_ray - 1u {
                record(base + k, s, steps + 1u);
            }
            if !in_grid(grid, s.x) {
                steps++;
                break;
            }
        }
    }
    record(base + params.records_per_ray - 1u, s, steps);
}

// steps_out[r] = (step length from rays[r].origin along rays[r].dir, 1 if its cell is flat,
// the flat cell's extent along x, 0).
@compute @workgroup_size(64)
fn octree_query(@builtin(global_invocation_id) id: vec3<u32>) {
    let r = id.x;
    if r >= params.ray_count {
        return;
    }
    let ray = rays[r];
    let cell = octree_cell(ray.origin);
    let step = octree_step(ray.origin, ray.dir, params.step, params.max_step);
    steps_out[r] = vec4<f32>(step, select(0.0, 1.0, cell.is_flat), cell.hi.x - cell.lo.x, 0.0);
}

// steps_out[r · records_per_ray + k] = (cell x, y, z, length inside) of the k-th cell crossed
// by segment r (unused slots keep length 0).
@compute @workgroup_size(64)
fn dda_cells(@builtin(global_invocation_id) id: vec3<u32>) {
    let r = id.x;
    if r >= params.ray_count {
        return;
    }
    let seg = rays[r];
    var dda = dda_begin(seg.origin, seg.origin + seg.dir);
    var k = 0u;
    while dda_more(dda) && k < params.records_per_ray {
        let cell = dda.cell;
        let len = dda_advance(&dda);
        steps_out[r * params.records_per_ray + k] = vec4<f32>(vec3<f32>(cell), len);
        k++;
    }
}
