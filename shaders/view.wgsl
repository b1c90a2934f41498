// Stage 6, view: camera rays through the volume along the ray equation (octree-adaptive steps,
// the same integrator as the photons), attenuated per channel by Beer–Lambert, gathering the
// light scattered toward the camera from the radiance grid (σ_s · phase · fluence, single
// scattering as in Sun et al. 2008, §4.5), and ending on an opaque receiver — lit by the
// lights (shadow rays, blocked by refractive media), by the caustic maps, and by the mean
// environment — or in the environment along the direction they leave in.
//
// At a sharp interface (shared/interface.wgsl) a ray splits by the Fresnel equations: the
// transmitted part goes on, the reflected part (weight R) waits on a small stack of branches
// and is traced after, each to its own end, so glass shows the environment, the receivers and
// the sun's disc mirrored in it. Branches end after MAX_EVENTS interface events or when their
// weight falls below MIN_WEIGHT (a reflection of a reflection inside glass is 0.16% of the
// light); the deterministic split keeps frames free of noise.
//
// Writes five planes of vec4 per pixel into `frame`:
//   [0] beauty: linear rgb, alpha = coverage by refractive media or receivers
//   [1] depth of the first medium or surface along the camera axis (x)
//   [2] caustic: light receivers get from the caustic maps (rgb)
//   [3] direct: light receivers get from the lights and the ambient environment (rgb)
//   [4] volume: light scattered toward the camera in the volume (rgb)
// beauty = caustic + direct + volume + the environment seen through (and around) the media.
// Each pixel averages `samples` rays at fixed sub-pixel offsets (the R2 sequence), so edges are
// antialiased, soft shadows are sampled, and an unchanged pixel renders identically every frame.
// With dispersion in the frame, each sample also carries a wavelength (`sample_wavelength_of`).

#import shared/types.wgsl
#import shared/grid.wgsl
#import shared/ray.wgsl
#import shared/octree.wgsl
#import shared/bvh.wgsl
#import shared/interface.wgsl
#import shared/receivers.wgsl
#import shared/lights.wgsl
#import shared/environment.wgsl
#import shared/hash.wgsl

@group(0) @binding(0) var<uniform> params: ViewParams;
@group(0) @binding(1) var ior_grid: texture_3d<f32>;
@group(0) @binding(2) var extinction_grid: texture_3d<f32>;
@group(0) @binding(3) var scattering_grid: texture_3d<f32>;
@group(0) @binding(4) var grid_sampler: sampler;
@group(0) @binding(5) var env_map: texture_2d<f32>;
@group(0) @binding(6) var env_sampler: sampler;
@group(0) @binding(7) var<storage, read_write> frame: array<vec4<f32>>;
@group(0) @binding(8) var<uniform> octree_params: OctreeParams;
@group(0) @binding(9) var<storage, read> octree: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(11) var<storage, read> bvh_triangles: array<BvhTriangle>;
@group(0) @binding(12) var<storage, read> receivers: array<ReceiverGpu>;
@group(0) @binding(13) var<storage, read> charts: array<Chart>;
@group(0) @binding(14) var<storage, read> caustic_irradiance: array<vec4<f32>>;
@group(0) @binding(15) var<storage, read> lights: array<LightGpu>;
@group(0) @binding(16) var fluence_grid: texture_3d<f32>;
@group(0) @binding(17) var direction_grid: texture_3d<f32>;
// (low, high) words of a 64-bit count of the ray-equation steps taken (benchmarks).
@group(0) @binding(18) var<storage, read_write> view_steps: array<atomic<u32>>;
// Two vec4 of texture coordinates per BVH triangle, (uv₀, uv₁) and (uv₂, 0, 0), and the base
// color textures' texels, 8-bit sRGB RGBA (src/pipeline/receivers.rs).
@group(0) @binding(19) var<storage, read> triangle_uvs: array<vec4<f32>>;
@group(0) @binding(20) var<storage, read> albedo_texels: array<u32>;
@group(0) @binding(21) var<storage, read> interfaces: array<Interface>;
@group(0) @binding(22) var<storage, read> triangle_normals: array<vec4<f32>>;

const FAR_DEPTH: f32 = 1e10;
const NO_HIT: f32 = 3.4e38;
const INV_PI: f32 = 0.318309886;
const FRAME_PLANES: u32 = 5u;
// Interface events along one camera sample's branches, and the weight below which a branch is
// not traced (its light would change the pixel by less than 8-bit precision resolves).
const MAX_EVENTS: u32 = 8u;
const MIN_WEIGHT: f32 = 2e-3;
const BRANCH_STACK: u32 = 4u;

// Sub-pixel offset of sample k: the R2 low-discrepancy sequence (Roberts 2018), centred so a
// single sample sits on the pixel centre. Also drives soft-shadow samples.
fn r2(k: u32) -> vec2<f32> {
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

fn has(flag: u32) -> bool {
    return (params.flags & flag) != 0u;
}

// Henyey–Greenstein phase function for the angle θ between the light's travel and the scattered
// direction.
fn phase_hg(cos_theta: f32, g: f32) -> f32 {
    let denom = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (4.0 * PI * denom * sqrt(denom));
}

// Radiance scattered toward the camera per unit length at x (viewed along d): σ_s · phase ·
// fluence, the phase taken against the voxel's mean photon direction and blended toward
// isotropic where the light arrives from many directions (|mean| < 1).
fn in_scattering(x: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    let grid = params.grid;
    let scattering = sample_grid(scattering_grid, grid_sampler, grid, x);
    if all(scattering.rgb <= vec3<f32>(0.0)) {
        return vec3<f32>(0.0);
    }
    let fluence = sample_grid(fluence_grid, grid_sampler, grid, x).rgb;
    let mean_dir = sample_grid(direction_grid, grid_sampler, grid, x).xyz;
    let a = min(length(mean_dir), 1.0);
    let cos_theta = select(0.0, dot(mean_dir / max(a, 1e-6), -d), a > 0.0);
    let phase = a * phase_hg(cos_theta, scattering.w) + (1.0 - a) / (4.0 * PI);
    return scattering.rgb * phase * fluence;
}

// Transmittance along the straight segment from p along unit w for `dist`: exp(−∫σ_t), and
// zero if it passes where n − 1 > eps_refract — light through glass arrives as caustic photons.
fn shadow_transmittance(p: vec3<f32>, w: vec3<f32>, dist: f32) -> vec3<f32> {
    let grid = params.grid;
    let span = ray_box(p, w, grid.origin, grid_box_max(grid));
    let t_end = min(span.y, dist);
    if span.x > span.y || t_end <= 0.0 {
        return vec3<f32>(1.0);
    }
    var t = max(span.x, 0.0);
    var tr = vec3<f32>(1.0);
    for (var k = 0u; k < params.max_steps && t < t_end; k++) {
        let x = p + w * t;
        let len = min(octree_step(x, w, params.step, params.max_step), t_end - t);
        let mid = x + w * (0.5 * len);
        if sample_ior(ior_grid, grid_sampler, grid, mid).w - 1.0 > params.eps_refract {
            return vec3<f32>(0.0);
        }
        if has(VIEW_FLAG_MEDIA) {
            tr *= exp(-sample_grid(extinction_grid, grid_sampler, grid, mid).rgb * len);
        }
        t += len;
    }
    return tr;
}

// Visibility of a light from p along w up to dist: opaque receivers and glass surfaces (light
// through glass arrives as caustic photons), then media.
fn visibility(p: vec3<f32>, w: vec3<f32>, dist: f32) -> vec3<f32> {
    if bvh_any_hit(p, w, 1e-4, dist) || analytic_any_hit(p, w, 1e-4, dist) {
        return vec3<f32>(0.0);
    }
    return shadow_transmittance(p, w, dist);
}

// Irradiance at p (facing normal n) from light l, with one shadow sample (k picks it).
fn direct_irradiance(l: LightGpu, p: vec3<f32>, n: vec3<f32>, k: u32) -> vec3<f32> {
    let u = r2(k + 7u);
    if l.kind == LIGHT_SUN {
        var w = -l.direction;
        if l.half_angle > 0.0 {
            w = cone_direction(w, l.right, l.up, l.half_angle, u);
        }
        let c = dot(n, w);
        if c <= 0.0 {
            return vec3<f32>(0.0);
        }
        return l.radiant * c * visibility(p, w, NO_HIT);
    }
    var aim = l.position;
    if l.kind == LIGHT_RECT {
        aim += l.right * ((u.x - 0.5) * l.size_x) + l.up * ((u.y - 0.5) * l.size_y);
    }
    let to_light = aim - p;
    let dist2 = dot(to_light, to_light);
    let dist = sqrt(dist2);
    let w = to_light / dist;
    let c = dot(n, w);
    if c <= 0.0 {
        return vec3<f32>(0.0);
    }
    var intensity: vec3<f32>;
    if l.kind == LIGHT_RECT {
        // A one-sided Lambertian emitter of radiance L: I(θ) = L · A · cos θ (one sample).
        intensity = l.radiant * (l.size_x * l.size_y) * max(dot(-w, l.direction), 0.0);
    } else {
        intensity = light_intensity(l, -w);
    }
    if all(intensity <= vec3<f32>(0.0)) {
        return vec3<f32>(0.0);
    }
    return intensity * c / dist2 * visibility(p, w, dist);
}

// Bilinear lookup of a chart's filtered caustic irradiance.
fn caustic_at(chart: Chart, p: vec3<f32>) -> vec3<f32> {
    let f = chart_coords(chart, p) - 0.5;
    let size = vec2<i32>(i32(chart.width), i32(chart.height));
    let i0 = vec2<i32>(floor(f));
    let t = f - floor(f);
    var e = vec3<f32>(0.0);
    for (var k = 0u; k < 4u; k++) {
        let o = vec2<i32>(i32(k & 1u), i32(k >> 1u));
        let c = clamp(i0 + o, vec2<i32>(0), size - 1);
        let w = select(1.0 - t.x, t.x, o.x == 1) * select(1.0 - t.y, t.y, o.y == 1);
        e += w * caustic_irradiance[chart.offset + u32(c.x) + chart.width * u32(c.y)].rgb;
    }
    return e;
}

struct Shading {
    caustic: vec3<f32>,
    direct: vec3<f32>,
}

// The inverse sRGB transfer function (IEC 61966-2-1): the texels are stored encoded.
fn srgb_decode(c: vec3<f32>) -> vec3<f32> {
    return select(pow((c + 0.055) / 1.055, vec3<f32>(2.4)), c / 12.92, c <= vec3<f32>(0.04045));
}

fn albedo_texel(r: ReceiverGpu, x: i32, y: i32) -> vec3<f32> {
    let size = vec2<i32>(i32(r.texture_width), i32(r.texture_height));
    let c = ((vec2<i32>(x, y) % size) + size) % size;
    return srgb_decode(unpack4x8unorm(albedo_texels[r.texture + u32(c.x + size.x * c.y)]).rgb);
}

// The receiver's albedo at a hit: its color times its base color texture, looked up at the
// hit's interpolated texture coordinates, bilinear with repeat — the twin of Texture2d::sample.
fn albedo_at(hit: SurfaceHit, receiver: u32) -> vec3<f32> {
    let r = receivers[receiver];
    if r.texture_width == 0u {
        return r.albedo;
    }
    let a = triangle_uvs[2u * hit.triangle];
    let b = triangle_uvs[2u * hit.triangle + 1u];
    // Möller–Trumbore's (u, v) weigh the second and third corners.
    let uv = a.xy * (1.0 - hit.u - hit.v) + a.zw * hit.u + b.xy * hit.v;
    let f = (uv - floor(uv)) * vec2<f32>(f32(r.texture_width), f32(r.texture_height)) - 0.5;
    let i = vec2<i32>(floor(f));
    let t = f - floor(f);
    let top = mix(albedo_texel(r, i.x, i.y), albedo_texel(r, i.x + 1, i.y), t.x);
    let bottom = mix(albedo_texel(r, i.x, i.y + 1), albedo_texel(r, i.x + 1, i.y + 1), t.x);
    return r.albedo * mix(top, bottom, t.y);
}

// Radiance leaving a receiver toward the camera at the hit, split into caustic and direct.
fn shade_receiver(hit: SurfaceHit, p: vec3<f32>, d: vec3<f32>, k: u32) -> Shading {
    let n = hit.normal;
    let back = dot(n, d) > 0.0;
    let facing = select(n, -n, back);
    let receiver = bvh_triangles[hit.triangle].receiver;
    let albedo = albedo_at(hit, receiver);
    // Lift the shading point off the surface so its own triangle does not shadow it.
    let q = p + facing * (1e-4 + 1e-3 * params.grid.voxel_size);
    var e_direct = PI * params.ambient;
    for (var i = 0u; i < params.light_count; i++) {
        e_direct += direct_irradiance(lights[i], q, facing, k);
    }
    var e_caustic = vec3<f32>(0.0);
    if has(VIEW_FLAG_CAUSTICS) {
        let c = chart_for(receiver, facing, back);
        if c >= 0 {
            e_caustic = caustic_at(charts[u32(c)], p);
        }
    }
    return Shading(albedo * INV_PI * e_caustic, albedo * INV_PI * e_direct);
}

struct ViewSample {
    radiance: vec3<f32>,
    caustic: vec3<f32>,
    direct: vec3<f32>,
    volume: vec3<f32>,
    covered: bool,
    depth: f32,
    steps: u32,
}

fn first_depth(s: ptr<function, ViewSample>, p: vec3<f32>) {
    if !(*s).covered {
        (*s).covered = true;
        (*s).depth = dot(p - params.camera.position, params.camera.forward);
    }
}

fn is_medium(g: vec4<f32>, extinction: vec3<f32>) -> bool {
    return abs(g.w - 1.0) > params.medium_eps || any(extinction > vec3<f32>(0.0));
}

// One straight-or-curved piece of a camera sample's path: where it starts, where it goes, what
// fraction of the light it carries to the camera, the media it is in, the events so far.
struct Branch {
    x: vec3<f32>,
    d: vec3<f32>,
    weight: vec3<f32>,
    media: Media,
    events: u32,
    // Which branch this is: 1 for the camera's, then 2p at each event for the path going on
    // and 2p + 1 for the reflection it leaves — the counter its random numbers hash.
    path: u32,
}

// The two uniform numbers that pick a rough surface's microfacet for camera sample k on branch
// `path` of this pixel: a counter-based hash (shared/hash.wgsl), so a pixel renders the same
// every frame and rough glass converges with `samples`.
fn facet_numbers(k: u32, path: u32) -> vec2<f32> {
    let key = pcg_hash(pixel_key ^ (k * 0x9e3779b9u));
    return vec2<f32>(random01(key, path, 0u), random01(key, path, 1u));
}

// Radiance of the lights a path that met glass sees along o + t·d, t < t_max: the sun's disc
// (a uniform disc of its angular radius: E over its solid angle 2π(1 − cos α)), seen only by a
// path that leaves the scene, and the bulbs of point and spot lights, spheres of their radius r
// whose radiance toward the viewer is I(ω) / (π r²).
fn lights_seen(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> vec3<f32> {
    var l = vec3<f32>(0.0);
    for (var i = 0u; i < params.light_count; i++) {
        let light = lights[i];
        if light.kind == LIGHT_SUN {
            let cos_a = cos(light.half_angle);
            if t_max >= NO_HIT && light.half_angle > 0.0 && dot(d, -light.direction) >= cos_a {
                l += light.radiant / (2.0 * PI * (1.0 - cos_a));
            }
        } else if light.kind != LIGHT_RECT && light.radius > 0.0 {
            let oc = o - light.position;
            let b = dot(oc, d);
            let disc = b * b - (dot(oc, oc) - light.radius * light.radius);
            if disc >= 0.0 && -b - sqrt(disc) > 0.0 && -b - sqrt(disc) < t_max {
                l += light_intensity(light, -d) / (PI * light.radius * light.radius);
            }
        }
    }
    return l;
}

// Ends a branch in the environment (and the lights' discs, once it met glass).
fn end_in_environment(out: ptr<function, ViewSample>, b: Branch) {
    if (*out).covered || params.env.visible != 0u {
        (*out).radiance += b.weight * env_radiance(env_map, env_sampler, params.env, b.d);
    }
    if b.events > 0u {
        (*out).radiance += b.weight * lights_seen(b.x, b.d, NO_HIT);
    }
}

// Ends a branch on a receiver: its shading, weighted (and, once it met glass, the bulbs it
// passed since `start`, the start of its last straight piece).
fn end_on_receiver(out: ptr<function, ViewSample>, hit: SurfaceHit, p: vec3<f32>, b: Branch, start: vec3<f32>, k: u32) {
    first_depth(out, p);
    let sh = shade_receiver(hit, p, b.d, k);
    (*out).caustic += b.weight * sh.caustic;
    (*out).direct += b.weight * sh.direct;
    (*out).radiance += b.weight * (sh.caustic + sh.direct);
    if b.events > 0u {
        (*out).radiance += b.weight * lights_seen(start, b.d, distance(start, p));
    }
}

// Traces one branch to its end. At an interface it goes on along the transmitted direction and
// pushes the reflected one (or, under total internal reflection, goes on reflected).
fn trace_branch(out: ptr<function, ViewSample>, b0: Branch, stack: ptr<function, array<Branch, BRANCH_STACK>>, top: ptr<function, u32>, k: u32) {
    let grid = params.grid;
    var b = b0;
    var ahead_of = look_from(b.x, b.d);
    let box_max = grid_box_max(grid);
    let span = ray_box(b.x, b.d, grid.origin, box_max);
    if span.x <= span.y && span.y > 0.0 && ahead_of.hit.t > max(span.x, 0.0) {
        var s = ray_start(ior_grid, grid_sampler, grid, b.x + b.d * max(span.x, 0.0), b.d);
        var path = 0.0;
        for (var i = 0u; i < params.max_steps; i++) {
            (*out).steps++;
            let x0 = s.x;
            var jump = octree_step(x0, b.d, params.step, params.max_step);
            let bends = jump <= params.step;
            jump = min(jump, ray_box(x0, b.d, grid.origin, box_max).y + 1e-4 * grid.voxel_size);
            let ahead = surface_within(&ahead_of, x0, b.d, jump);
            let on_surface = ahead <= jump;
            if on_surface {
                s.x = x0 + b.d * ahead;
            } else if bends {
                march_step(ior_grid, grid_sampler, grid, &s, params.step);
            } else {
                s.x = x0 + b.d * jump;
                s.g = sample_ior(ior_grid, grid_sampler, grid, s.x);
                s.v = b.d * s.g.w;
            }
            let len = distance(x0, s.x);
            path += len;
            let mid = 0.5 * (x0 + s.x);
            var extinction = b.media.absorption;
            if has(VIEW_FLAG_MEDIA) {
                // Beer–Lambert over the step, with the in-scattered light of its midpoint.
                extinction += sample_grid(extinction_grid, grid_sampler, grid, mid).rgb;
                if has(VIEW_FLAG_SCATTERING) {
                    (*out).volume += b.weight * exp(-0.5 * extinction * len) * in_scattering(mid, b.d) * len;
                }
            }
            b.weight *= exp(-extinction * len);
            if is_medium(s.g, extinction) {
                first_depth(out, x0);
            }
            path_dispersed = path_dispersed || (grid_dispersion_scale != 1.0 && s.g.w - 1.0 > params.eps_refract);
            if on_surface {
                let hit = ahead_of.hit;
                if hit.interface_id == NO_INTERFACE {
                    end_on_receiver(out, hit, s.x, b, ahead_of.origin, k);
                    return;
                }
                first_depth(out, s.x);
                let c = cross_interface(b.d, hit, b.media, facet_numbers(k, b.path));
                b.events++;
                var next = b.d;
                if c.reflectance < 1.0 {
                    var reflected = Branch(s.x, c.reflected, b.weight * (c.reflectance * c.reflected_share), b.media, b.events, 2u * b.path + 1u);
                    if max(reflected.weight.r, max(reflected.weight.g, reflected.weight.b)) > MIN_WEIGHT && *top < BRANCH_STACK {
                        reflected.x = leave_surface(s.x, c.facing, c.reflected, 1e-3 * grid.voxel_size);
                        (*stack)[*top] = reflected;
                        *top += 1u;
                    }
                    b.weight *= (1.0 - c.reflectance) * c.tint * c.transmitted_share;
                    b.media = c.beyond;
                    next = c.transmitted;
                } else {
                    b.weight *= c.reflected_share;
                    next = c.reflected;
                }
                b.path = 2u * b.path;
                if b.events >= MAX_EVENTS || max(b.weight.r, max(b.weight.g, b.weight.b)) < MIN_WEIGHT {
                    return;
                }
                b.d = next;
                s = ray_start(ior_grid, grid_sampler, grid, leave_surface(s.x, c.facing, next, 1e-3 * grid.voxel_size), next);
                ahead_of.valid = false;
                continue;
            }
            // Only a curved step turns the ray: a straight jump keeps d exactly, and taking it
            // back from v = n·d would round it by an ulp and discard the lookahead every step.
            let d_new = normalize(s.v);
            if bends && dot(d_new, b.d) < 1.0 - 1e-9 {
                b.d = d_new;
                ahead_of.valid = false;
            }
            if all(b.weight < vec3<f32>(1e-4)) {
                return;
            }
            // (Checked after the step: the entry point itself may round to just outside.)
            // A path longer than max_path is trapped by total internal reflection: it leaves
            // along the direction it has (see march.rs, `max_path`).
            if !in_grid(grid, s.x) || path > params.max_path {
                break;
            }
        }
        b.x = s.x;
    }
    let hit = surface_after(&ahead_of, b.x, b.d);
    if is_receiver_hit(hit) {
        end_on_receiver(out, hit, b.x + b.d * hit.t, b, b.x, k);
        return;
    }
    end_in_environment(out, b);
}

// Dispersion (VIEW_FLAG_SPECTRAL): camera sample k of a pixel carries one wavelength — a hero
// wavelength per pixel (hashed), with the pixel's other samples as its companions, spaced
// evenly over the spectrum (the rotation of Wilkie et al. 2014's hero wavelengths). Dispersive
// glass sends each wavelength its own way, so each companion is traced as a sample of its own.
fn sample_wavelength_of(k: u32) {
    path_dispersed = false;
    if !has(VIEW_FLAG_SPECTRAL) {
        return;
    }
    let u = fract(random01(0x5bd1e995u, pixel_key, 0u) + f32(k) / f32(params.samples));
    path_wavelength = sample_wavelength(u);
    grid_dispersion_scale = dispersion_scale(params.grid_dispersion, path_wavelength);
}

// A sample that met dispersion becomes what its wavelength contributes: its rgb as a spectrum
// at λ, through the colour matching functions, back to rgb (its mean over λ is that rgb). A
// sample that met none keeps its rgb exactly, so only what dispersion touched is spectral.
fn spectral_sample(s: ViewSample) -> ViewSample {
    if !path_dispersed {
        return s;
    }
    var out = s;
    out.radiance = xyz_to_rgb(sample_xyz(s.radiance, path_wavelength));
    out.caustic = xyz_to_rgb(sample_xyz(s.caustic, path_wavelength));
    out.direct = xyz_to_rgb(sample_xyz(s.direct, path_wavelength));
    out.volume = xyz_to_rgb(sample_xyz(s.volume, path_wavelength));
    return out;
}

fn trace_view(dir0: vec3<f32>, k: u32) -> ViewSample {
    sample_wavelength_of(k);
    var out = ViewSample(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), false, FAR_DEPTH, 0u);
    var stack: array<Branch, BRANCH_STACK>;
    var top = 0u;
    var branch = Branch(params.camera.position, dir0, vec3<f32>(1.0), media_unpacked(vec2<u32>(params.camera_media_lo, params.camera_media_hi)), 0u, 1u);
    // (One call site: the branch tracer is the pass's largest function.)
    loop {
        trace_branch(&out, branch, &stack, &top, k);
        if top == 0u {
            break;
        }
        top--;
        branch = stack[top];
    }
    out.radiance += out.volume;
    return spectral_sample(out);
}

// The ray-equation steps of this workgroup's pixels, (low, high) words: one global add per
// workgroup rather than one per pixel, all on the same word (see march.wgsl's statistics).
var<workgroup> workgroup_steps: array<atomic<u32>, 2>;

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    if id.x < params.width && id.y < params.height {
        let steps = shade_pixel(id.xy);
        let old = atomicAdd(&workgroup_steps[0], steps);
        if old + steps < old {
            atomicAdd(&workgroup_steps[1], 1u);
        }
    }
    workgroupBarrier();
    if lane == 0u {
        let low = atomicLoad(&workgroup_steps[0]);
        let old = atomicAdd(&view_steps[0], low);
        let carry = select(0u, 1u, old + low < old);
        let high = atomicLoad(&workgroup_steps[1]) + carry;
        if high != 0u {
            atomicAdd(&view_steps[1], high);
        }
    }
}

// The pixel being shaded (its index), which keys its random numbers.
var<private> pixel_key: u32;

// Traces this dispatch's camera rays of pixel `p` (samples sample_first… of `samples`) and
// writes its five planes — or, after the first dispatch of a pixel's samples, adds to them;
// returns the steps they took. (Splitting the samples keeps each invocation under lavapipe's
// 65 535 loop iterations per shader, past which it silently ends every loop.)
fn shade_pixel(p: vec2<u32>) -> u32 {
    let id = vec3<u32>(p, 0u);
    pixel_key = p.x + p.y * params.width;
    var sum = ViewSample(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), false, FAR_DEPTH, 0u);
    var coverage = 0.0;
    for (var k = params.sample_first; k < params.sample_first + params.sample_count; k++) {
        let s = trace_view(camera_ray(vec2<f32>(id.xy) + r2(k)), k);
        sum.radiance += s.radiance;
        sum.caustic += s.caustic;
        sum.direct += s.direct;
        sum.volume += s.volume;
        sum.steps += s.steps;
        coverage += select(0.0, 1.0, s.covered);
        sum.depth = min(sum.depth, s.depth);
    }
    let inv = 1.0 / f32(params.samples);
    let pixel = id.x + id.y * params.width;
    let plane = params.width * params.height;
    var planes = array<vec4<f32>, FRAME_PLANES>(
        vec4<f32>(sum.radiance * inv, coverage * inv),
        vec4<f32>(sum.depth, 0.0, 0.0, 0.0),
        vec4<f32>(sum.caustic * inv, 0.0),
        vec4<f32>(sum.direct * inv, 0.0),
        vec4<f32>(sum.volume * inv, 0.0),
    );
    if params.sample_first > 0u {
        for (var i = 0u; i < FRAME_PLANES; i++) {
            planes[i] += frame[i * plane + pixel];
        }
        planes[1] = vec4<f32>(min(sum.depth, frame[plane + pixel].x), 0.0, 0.0, 0.0);
    }
    for (var i = 0u; i < FRAME_PLANES; i++) {
        frame[i * plane + pixel] = planes[i];
    }
    return sum.steps;
}
