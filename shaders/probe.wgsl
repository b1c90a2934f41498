// Diagnostic kernel: traces given rays through the ior_grid with the integrator the view and
// photon passes use, recording their state along the way. Tests compare it with the CPU twin
// and with closed-form optics; `refrakt trace` prints it.
//
// records[ray · records_per_ray + k] holds the state after k · record_every steps, the last
// slot the state where the ray left the volume (or ran out of steps).

#import shared/types.wgsl
#import shared/grid.wgsl
#import shared/ray.wgsl

@group(0) @binding(0) var<uniform> params: ProbeParams;
@group(0) @binding(1) var ior_grid: texture_3d<f32>;
@group(0) @binding(2) var grid_sampler: sampler;
@group(0) @binding(3) var<storage, read> rays: array<ProbeRay>;
@group(0) @binding(4) var<storage, read_write> records: array<ProbeRecord>;

fn record(slot: u32, s: RayState, steps: u32) {
    records[slot] = ProbeRecord(s.x, s.g.w, s.v, steps);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let r = id.x;
    if r >= params.ray_count {
        return;
    }
    let grid = params.grid;
    let ray = rays[r];
    let span = ray_box(ray.origin, ray.dir, grid.origin, grid_box_max(grid));
    let base = r * params.records_per_ray;
    var s = ray_start(ior_grid, grid_sampler, grid, ray.origin + ray.dir * max(span.x, 0.0), ray.dir);
    record(base, s, 0u);
    var steps = 0u;
    if span.x <= span.y && span.y > 0.0 {
        for (; steps < params.max_steps; steps++) {
            if params.integrator == INTEGRATOR_EULER {
                march_step_euler(ior_grid, grid_sampler, grid, &s, params.step);
            } else {
                march_step(ior_grid, grid_sampler, grid, &s, params.step);
            }
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
