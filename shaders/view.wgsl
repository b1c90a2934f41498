// Stage 6, view: camera rays bent through the index grid by the ray equation, attenuated per
// color channel by Beer–Lambert, and shaded by the environment along the direction in which
// they leave the volume.
//
// Writes two planes of vec4 per pixel into `frame`: [0] beauty (linear rgb, alpha = coverage of
// refractive or absorbing media), [1] (depth of first entry into a medium along the camera axis,
// 0, 0, 0). Each pixel averages `samples` rays at fixed sub-pixel offsets (the R2 sequence), so
// edges are antialiased and an unchanged pixel renders identically in every frame.

#import shared/types.wgsl
#import shared/grid.wgsl
#import shared/ray.wgsl
#import shared/environment.wgsl

@group(0) @binding(0) var<uniform> params: ViewParams;
@group(0) @binding(1) var ior_grid: texture_3d<f32>;
@group(0) @binding(2) var extinction_grid: texture_3d<f32>;
@group(0) @binding(3) var grid_sampler: sampler;
@group(0) @binding(4) var env_map: texture_2d<f32>;
@group(0) @binding(5) var env_sampler: sampler;
@group(0) @binding(6) var<storage, read_write> frame: array<vec4<f32>>;

// Depth written where a ray meets no medium (Blender's convention for "infinitely far").
const FAR_DEPTH: f32 = 1e10;

// Sub-pixel offset of sample k: the R2 low-discrepancy sequence (Roberts 2018), centred so
// that a single sample sits on the pixel centre.
fn sample_offset(k: u32) -> vec2<f32> {
    return fract(vec2<f32>(0.5) + f32(k) * vec2<f32>(0.7548776662, 0.5698402910));
}

fn camera_ray(pixel: vec2<f32>) -> vec3<f32> {
    let cam = params.camera;
    let ndc = vec2<f32>(
        (2.0 * pixel.x / f32(params.width) - 1.0) * cam.aspect,
        1.0 - 2.0 * pixel.y / f32(params.height),
    ) * cam.tan_half_fov;
    return normalize(cam.forward + ndc.x * cam.right + ndc.y * cam.up);
}

fn is_medium(g: vec4<f32>, extinction: vec3<f32>) -> bool {
    return abs(g.w - 1.0) > params.medium_eps || any(extinction > vec3<f32>(0.0));
}

struct ViewSample {
    radiance: vec3<f32>,
    covered: bool,
    depth: f32,
}

fn trace_view(dir0: vec3<f32>) -> ViewSample {
    let grid = params.grid;
    let origin = params.camera.position;
    var out = ViewSample(vec3<f32>(0.0), false, FAR_DEPTH);
    var dir = dir0;
    var transmittance = vec3<f32>(1.0);
    let span = ray_box(origin, dir, grid.origin, grid_box_max(grid));
    if span.x <= span.y && span.y > 0.0 {
        let h = params.step;
        var s = ray_start(ior_grid, grid_sampler, grid, origin + dir * max(span.x, 0.0), dir);
        for (var i = 0u; i < params.max_steps; i++) {
            let x0 = s.x;
            march_step(ior_grid, grid_sampler, grid, &s, h);
            var extinction = vec3<f32>(0.0);
            if (params.flags & VIEW_FLAG_MEDIA) != 0u {
                // Beer–Lambert over the step, extinction taken at its midpoint.
                extinction = sample_grid(extinction_grid, grid_sampler, grid, 0.5 * (x0 + s.x)).rgb;
                transmittance *= exp(-extinction * h);
            }
            if !out.covered && is_medium(s.g, extinction) {
                out.covered = true;
                out.depth = dot(x0 - origin, params.camera.forward);
            }
            if !in_grid(grid, s.x) || all(transmittance < vec3<f32>(1e-4)) {
                break;
            }
        }
        dir = ray_dir(s);
    }
    if out.covered || params.env.visible != 0u {
        out.radiance = transmittance * env_radiance(env_map, env_sampler, params.env, dir);
    }
    return out;
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    var radiance = vec3<f32>(0.0);
    var coverage = 0.0;
    var depth = FAR_DEPTH;
    for (var k = 0u; k < params.samples; k++) {
        let s = trace_view(camera_ray(vec2<f32>(id.xy) + sample_offset(k)));
        radiance += s.radiance;
        coverage += select(0.0, 1.0, s.covered);
        depth = min(depth, s.depth);
    }
    let inv = 1.0 / f32(params.samples);
    let pixel = id.x + id.y * params.width;
    let plane = params.width * params.height;
    frame[pixel] = vec4<f32>(radiance * inv, coverage * inv);
    frame[plane + pixel] = vec4<f32>(depth, 0.0, 0.0, 0.0);
}
