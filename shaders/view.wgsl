// Stage 6, view: camera rays through the volume along the ray equation (octree-adaptive steps,
// the same integrator as the photons), attenuated per channel by Beer–Lambert, gathering the
// light scattered toward the camera from the radiance grid (σ_s · phase · fluence, single
// scattering as in Sun et al. 2008, §4.5), and ending on an opaque receiver — lit by the
// lights and the environment (shadow rays, blocked by refractive media: light through glass
// arrives as photons), and by the caustic and indirect maps — or in the environment along the direction they
// leave in.
//
// At a sharp interface (shared/interface.wgsl) a ray splits by the Fresnel equations: the
// transmitted part goes on, the reflected part (weight R) waits on a small stack of branches
// and is traced after, each to its own end, so glass shows the environment, the receivers and
// the sun's disc mirrored in it. Branches end after MAX_EVENTS interface events or when their
// weight falls below MIN_WEIGHT (a reflection of a reflection inside glass is 0.16% of the
// light); the deterministic split keeps frames free of noise.
//
// Writes six planes of vec4 per pixel into `frame`:
//   [0] beauty: linear rgb, alpha = coverage by refractive media or receivers
//   [1] depth of the first medium or surface along the camera axis (x)
//   [2] caustic: light receivers get from the caustic maps (rgb)
//   [3] direct: light receivers get from the lights and the environment (rgb)
//   [4] volume: light scattered toward the camera in the volume (rgb)
//   [5] indirect: light receivers get from the indirect maps, bounced off other receivers (rgb)
// beauty = caustic + direct + indirect + volume + the environment seen through (and around) the
// media.
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
#import shared/env_light.wgsl
#import shared/mesh_light.wgsl
#import shared/hash.wgsl
#import shared/pbr.wgsl
#import shared/glass_surface.wgsl
#import shared/direct_light.wgsl

@group(0) @binding(0) var<uniform> params: ViewParams;
@group(0) @binding(1) var ior_grid: texture_3d<f32>;
@group(0) @binding(2) var extinction_grid: texture_3d<f32>;
@group(0) @binding(3) var scattering_grid: texture_3d<f32>;
@group(0) @binding(4) var grid_sampler: sampler;
@group(0) @binding(5) var env_map: texture_2d<f32>;
@group(0) @binding(6) var env_sampler: sampler;
// The frame's five planes, one binding each (so a frame needs one plane, not all five, to fit
// in a binding): beauty RGBA, depth, and the caustic, direct and volume light.
@group(0) @binding(7) var<storage, read_write> frame_beauty: array<vec4<f32>>;
@group(0) @binding(30) var<storage, read_write> frame_depth: array<vec4<f32>>;
@group(0) @binding(31) var<storage, read_write> frame_caustic: array<vec4<f32>>;
@group(0) @binding(32) var<storage, read_write> frame_direct: array<vec4<f32>>;
@group(0) @binding(33) var<storage, read_write> frame_volume: array<vec4<f32>>;
@group(0) @binding(34) var<storage, read_write> frame_indirect: array<vec4<f32>>;
@group(0) @binding(8) var<uniform> octree_params: OctreeParams;
@group(0) @binding(9) var<storage, read> octree: array<vec4<f32>>;
@group(0) @binding(25) var<storage, read> octree_leaves: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(11) var<storage, read> bvh_triangles: array<BvhTriangle>;
@group(0) @binding(12) var<storage, read> receivers: array<ReceiverGpu>;
@group(0) @binding(13) var<storage, read> charts: array<Chart>;
@group(0) @binding(14) var<storage, read> caustic_irradiance: array<vec4<f32>>;
// The indirect maps' filtered irradiance (bounced light), laid out as the caustic maps.
@group(0) @binding(27) var<storage, read> indirect_irradiance: array<vec4<f32>>;
// The glowing meshes' triangles (shared/mesh_light.wgsl).
@group(0) @binding(28) var<storage, read> light_triangles: array<LightTriangle>;
@group(0) @binding(15) var<storage, read> lights: array<LightGpu>;
@group(0) @binding(16) var fluence_grid: texture_3d<f32>;
@group(0) @binding(17) var direction_grid: texture_3d<f32>;
// (low, high) words of a 64-bit count of the ray-equation steps taken (benchmarks).
@group(0) @binding(18) var<storage, read_write> view_steps: array<atomic<u32>>;
// Three vec4 of texture coordinates and tangent per BVH triangle (shared/pbr.wgsl), and the
// receivers' textures' texels, 8-bit RGBA (src/pipeline/receivers.rs).
@group(0) @binding(19) var<storage, read> triangle_uvs: array<vec4<f32>>;
@group(0) @binding(20) var<storage, read> albedo_texels: array<u32>;
@group(0) @binding(21) var<storage, read> interfaces: array<Interface>;
@group(0) @binding(22) var<storage, read> triangle_normals: array<vec4<f32>>;
// The environment prefiltered for glossy receivers and the split-sum table
// (src/pipeline/specular.rs; read only when VIEW_FLAG_SPECULAR is set).
@group(0) @binding(23) var env_specular: texture_2d_array<f32>;
@group(0) @binding(24) var<storage, read> brdf_lut: array<vec2<f32>>;
// The rough glass albedo table (shared/rough_albedo.wgsl).
@group(0) @binding(29) var<storage, read> rough_albedo_table: array<f32>;
// The environment's importance table (shared/env_light.wgsl, src/pipeline/env_light.rs).
@group(0) @binding(26) var<storage, read> env_table: array<f32>;

const FAR_DEPTH: f32 = 1e10;
const NO_HIT: f32 = 3.4e38;
const INV_PI: f32 = 0.318309886;
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

// A point of the image on the image plane at unit distance: y from −1 (the frame's bottom) to 1
// (its top), x scaled by the aspect ratio; the image a region of the frame, moved by the lens
// shift — CameraDesc::image_window.
fn image_plane(pixel: vec2<f32>) -> vec2<f32> {
    let w = params.camera.window;
    return vec2<f32>(w.x + pixel.x * w.z, w.y - pixel.y * w.w);
}

// The camera ray's direction through a point of the image (parallel to the view for an
// orthographic camera) — CameraDesc::ray_through.
fn camera_ray(pixel: vec2<f32>) -> vec3<f32> {
    let cam = params.camera;
    if cam.ortho_half_height > 0.0 {
        return cam.forward;
    }
    let ndc = image_plane(pixel) * cam.tan_half_fov;
    return normalize(cam.forward + ndc.x * cam.right + ndc.y * cam.up);
}

// Where it starts: the pinhole, or the image plane through the camera's position for an
// orthographic camera — CameraDesc::origin_through.
fn camera_origin(pixel: vec2<f32>) -> vec3<f32> {
    let cam = params.camera;
    let ndc = image_plane(pixel) * cam.ortho_half_height;
    return cam.position + ndc.x * cam.right + ndc.y * cam.up;
}

// A point of the aperture (metres along the camera's right and up) for a uniform u: on the disc
// by Shirley and Chiu's concentric map, or on the regular polygon of `blades` corners, a corner's
// triangle chosen by u.x — CameraDesc::aperture_point.
fn aperture_point(u: vec2<f32>) -> vec2<f32> {
    let cam = params.camera;
    if cam.blades >= 3u {
        let n = f32(cam.blades);
        let corner = min(floor(u.x * n), n - 1.0);
        var ab = vec2<f32>(u.x * n - corner, u.y);
        if ab.x + ab.y > 1.0 {
            ab = 1.0 - ab;
        }
        let a0 = cam.blade_rotation + TAU * corner / n;
        let a1 = cam.blade_rotation + TAU * (corner + 1.0) / n;
        return cam.lens_radius * (ab.x * vec2<f32>(cos(a0), sin(a0)) + ab.y * vec2<f32>(cos(a1), sin(a1)));
    }
    let p = 2.0 * u - 1.0;
    if p.x == 0.0 && p.y == 0.0 {
        return vec2<f32>(0.0);
    }
    var r = p.y;
    var theta = 0.5 * PI - 0.25 * PI * (p.x / p.y);
    if abs(p.x) > abs(p.y) {
        r = p.x;
        theta = 0.25 * PI * (p.y / p.x);
    }
    return cam.lens_radius * r * vec2<f32>(cos(theta), sin(theta));
}

// The camera ray of sample k through a point of the image: the pinhole's, or a thin lens's
// (pbrt-v4 §5.2.3) leaving a random point of the aperture toward where the pinhole ray meets
// the plane in focus — CameraDesc::lens_ray_through. (The aperture point is a pure function
// of the pixel and the sample: no flicker between frames.) It starts on the plane `clip_start`
// along the view, as Cycles clips: a distance along the view axis, not along the ray.
fn camera_ray_through_lens(pixel: vec2<f32>, k: u32) -> array<vec3<f32>, 2> {
    let cam = params.camera;
    var start = camera_origin(pixel);
    var dir = camera_ray(pixel);
    if cam.lens_radius > 0.0 {
        let u = vec2<f32>(random01(0x1e35a7bdu, pixel_key, 2u * k), random01(0x1e35a7bdu, pixel_key, 2u * k + 1u));
        let lens = aperture_point(u);
        let in_focus = start + dir * (cam.focus_distance / dot(dir, cam.forward));
        start += lens.x * cam.right + lens.y * cam.up;
        dir = normalize(in_focus - start);
    }
    if cam.clip_start > 0.0 {
        start += dir * (cam.clip_start / dot(dir, cam.forward));
    }
    return array<vec3<f32>, 2>(start, dir);
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

// Bilinear lookup of a chart's filtered caustic (or indirect) irradiance.
fn chart_irradiance(chart: Chart, p: vec3<f32>, indirect: bool) -> vec3<f32> {
    let f = chart_coords(chart, p) - 0.5;
    let size = vec2<i32>(i32(chart.width), i32(chart.height));
    let i0 = vec2<i32>(floor(f));
    let t = f - floor(f);
    var e = vec3<f32>(0.0);
    for (var k = 0u; k < 4u; k++) {
        let o = vec2<i32>(i32(k & 1u), i32(k >> 1u));
        let c = clamp(i0 + o, vec2<i32>(0), size - 1);
        let w = select(1.0 - t.x, t.x, o.x == 1) * select(1.0 - t.y, t.y, o.y == 1);
        let texel = chart.offset + u32(c.x) + chart.width * u32(c.y);
        e += w * select(caustic_irradiance[texel].rgb, indirect_irradiance[texel].rgb, indirect);
    }
    return e;
}

struct Shading {
    caustic: vec3<f32>,
    direct: vec3<f32>,
    indirect: vec3<f32>,
}

// The caustic (or, `indirect`, the bounced) irradiance at p on the side `facing` of receiver
// `receiver`, 0 without the photons that make it.
fn map_irradiance_at(receiver: u32, p: vec3<f32>, facing: vec3<f32>, back: bool, indirect: bool) -> vec3<f32> {
    if has(select(VIEW_FLAG_CAUSTICS, VIEW_FLAG_INDIRECT, indirect)) {
        let c = chart_for(receiver, facing, back);
        if c >= 0 {
            // (The indirect maps' charts, coarser, follow the caustic maps'.)
            return chart_irradiance(charts[u32(c) + select(0u, params.indirect_chart_base, indirect)], p, indirect);
        }
    }
    return vec3<f32>(0.0);
}

// A receiver of the full metallic-roughness model at a hit: its surface, the textures applied.
fn pbr_surface(r: ReceiverGpu, hit: SurfaceHit, uv: vec2<f32>, base: vec3<f32>, facing: vec3<f32>, d: vec3<f32>) -> PbrSurface {
    // The coat's normal: the surface's own bent by the coat's normal map, not the base's
    // (KHR_materials_clearcoat).
    let coat_n = mapped_normal(r.clearcoat_normal_texture, r.clearcoat_normal_scale, hit.triangle, hit.u, hit.v, uv, facing);
    var s = PbrSurface(base, r.metallic, r.roughness, r.specular, 1.0, pbr_normal(r, hit.triangle, hit.u, hit.v, uv, facing), -d, 0.0,
                       r.clearcoat, r.clearcoat_roughness, coat_n, clamp(dot(coat_n, -d), 1e-4, 1.0), r.sheen_color, r.sheen_roughness);
    if has_texture(r.metallic_roughness_texture) {
        let mr = texture_at(r.metallic_roughness_texture, uv);
        s.roughness *= mr.g;
        s.metallic *= mr.b;
    }
    if has_texture(r.clearcoat_texture) {
        s.clearcoat *= texture_at(r.clearcoat_texture, uv).r;
    }
    if has_texture(r.clearcoat_roughness_texture) {
        s.clearcoat_roughness *= texture_at(r.clearcoat_roughness_texture, uv).g;
    }
    if has_texture(r.sheen_color_texture) {
        s.sheen_color *= texture_at(r.sheen_color_texture, uv).rgb;
    }
    if has_texture(r.sheen_roughness_texture) {
        s.sheen_roughness *= texture_at(r.sheen_roughness_texture, uv).a;
    }
    if has_texture(r.occlusion_texture) {
        s.occlusion = 1.0 + r.occlusion_strength * (texture_at(r.occlusion_texture, uv).r - 1.0);
    }
    s.n_v = clamp(dot(s.n, s.v), 1e-4, 1.0);
    return s;
}

// A Lambertian surface of albedo `base` facing `facing`, seen along d, as direct_light takes it.
fn lambert_surface(base: vec3<f32>, facing: vec3<f32>, d: vec3<f32>) -> PbrSurface {
    return PbrSurface(base, 0.0, 1.0, 0.0, 1.0, facing, -d, 1.0, 0.0, 1.0, facing, 1.0, vec3<f32>(0.0), 0.0);
}

// Radiance leaving a receiver toward the camera at the hit, split into caustic, direct (the
// lights, the environment and the surface's own emission) and indirect (bounced) light. A
// receiver of the full model takes the lights through both lobes, the environment by the split
// sum, the caustic and bounced light on the diffuse lobe only; a Lambertian one (metallic 0,
// specular 0) reflects albedo / π of each; its emission times `glow` (`glow_share`). With
// `glass_base`, the diffuse base beneath a partly transmissive glass surface met at p, whose
// facing normal is hit.normal: a Lambertian of albedo 1 (its colour is in the branch's weight,
// `base_branch`) lit by the lights and the environment only, as glass has no irradiance maps.
// (One call of `direct_light` for all three: lavapipe inlines every call site anew.)
fn shade_receiver(hit: SurfaceHit, p: vec3<f32>, d: vec3<f32>, k: u32, path: u32, glow: f32, glass_base: bool) -> Shading {
    var facing = hit.normal;
    var base = vec3<f32>(1.0);
    var emission = vec3<f32>(0.0);
    var e_caustic = vec3<f32>(0.0);
    var e_indirect = vec3<f32>(0.0);
    var pbr = false;
    var s = lambert_surface(base, facing, d);
    var env = LightResponse(vec3<f32>(1.0), vec3<f32>(0.0));
    if !glass_base {
        let back = dot(hit.normal, d) > 0.0;
        facing = select(hit.normal, -hit.normal, back);
        let receiver = bvh_triangles[hit.triangle].receiver;
        let r = receivers[receiver];
        let uv = hit_uv(hit.triangle, hit.u, hit.v);
        base = base_color_at(r, uv).rgb;
        emission = emission_at(r, uv) * glow;
        e_caustic = map_irradiance_at(receiver, p, facing, back, false);
        e_indirect = map_irradiance_at(receiver, p, facing, back, true);
        pbr = has(VIEW_FLAG_SPECULAR) && (r.flags & RECEIVER_PBR) != 0u;
        s = lambert_surface(base, facing, d);
        if pbr {
            s = pbr_surface(r, hit, uv, base, facing, d);
            env = pbr_environment(s, params.env);
        }
    }
    // Lift the shading point off the surface so its own triangle does not shadow it.
    let q = p + facing * (1e-4 + 1e-3 * params.grid.voxel_size);
    // The occlusion texture darkens the environment's light, not the lights'.
    // (The glossy lobes' environment light, shadowed, comes back in lit.specular.)
    let lit = direct_light(q, facing, s, pbr, env.diffuse * s.occlusion, env.specular * s.occlusion, k, path);
    if pbr {
        // The caustic and bounced light land on the diffuse lobe, with the share it keeps of
        // the environment's.
        return Shading(env.diffuse * e_caustic, lit.diffuse + lit.specular + emission, env.diffuse * e_indirect);
    }
    return Shading(base * INV_PI * e_caustic, base * INV_PI * lit.diffuse + emission, base * INV_PI * e_indirect);
}

struct ViewSample {
    radiance: vec3<f32>,
    caustic: vec3<f32>,
    direct: vec3<f32>,
    volume: vec3<f32>,
    indirect: vec3<f32>,
    covered: bool,
    depth: f32,
    steps: u32,
}

fn no_light() -> ViewSample {
    return ViewSample(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), false, FAR_DEPTH, 0u);
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
    // The density of its direction where a rough crossing sent it into the open and the lights
    // were sampled there too (`lights_through_rough`); 0 otherwise.
    lobe_pdf: f32,
}

// A branch that is the diffuse base beneath a partly transmissive glass surface (glTF's
// KHR_materials_transmission: of the light the surface does not reflect, the fraction
// `transmission` passes and the rest meets the material's base, Lambertian of its base colour),
// met at x: d is the surface's normal facing the camera's side, weight the branch's times
// (1 − R)(1 − transmission) × the base colour. It is shaded where receivers are
// (`meet_receiver`), marked by a negative lobe_pdf, and its random numbers hash a path number
// of its own (the high bit: paths double per event, at most MAX_EVENTS times).
fn base_branch(b: Branch, p: vec3<f32>, c: Crossing) -> Branch {
    return Branch(p, c.normal, b.weight * c.base, b.media, b.events, b.path | 0x80000000u, -1.0);
}

fn is_base_branch(b: Branch) -> bool {
    return b.lobe_pdf < 0.0;
}

// The two uniform numbers that pick a rough surface's microfacet for camera sample k on branch
// `path` of this pixel: a counter-based hash (shared/hash.wgsl), so a pixel renders the same
// every frame and rough glass converges with `samples`.
fn facet_numbers(k: u32, path: u32) -> vec2<f32> {
    let key = pcg_hash(pixel_key ^ (k * 0x9e3779b9u));
    return vec2<f32>(random01(key, path, 0u), random01(key, path, 1u));
}

// Whether a branch looks for the lights it passes (`lights_seen`): once it met glass, which shows
// every light with a size, and before that where some light is visible to the camera.
fn sees_lights(b: Branch) -> bool {
    return b.events > 0u || has(VIEW_FLAG_VISIBLE_LIGHTS);
}

// The share of a glowing mesh's glow (world area `area`, lighting from `side`:
// `mesh_lights::glow_measure`) that a branch meeting it at p on `triangle` keeps, where the
// branch left a rough crossing at `lobe_from` that drew the same light (`lights_through_rough`):
// by the balance heuristic, the light's density there distance² / (A cos θ). All of it where
// nothing else drew it: no rough crossing before, a glow not drawn (area 0), or the side of a
// closed mesh its light is not drawn on.
fn glow_share(b: Branch, lobe_from: vec3<f32>, p: vec3<f32>, triangle: u32, area: f32, side: f32) -> f32 {
    if b.lobe_pdf <= 0.0 || area <= 0.0 {
        return 1.0;
    }
    let cos_l = dot(bvh_triangle_normal(triangle), -b.d);
    if side * cos_l < 0.0 {
        return 1.0;
    }
    let to = p - lobe_from;
    return share_of_lobe(b.lobe_pdf, dot(to, to) / (area * max(abs(cos_l), 1e-6)));
}

// Adds the light of the lights a branch passes from `piece` (the start of its last straight
// piece) to `t_max` (`lights_seen`; `lobe_from`: where its last rough crossing was).
fn pass_lights(out: ptr<function, ViewSample>, b: Branch, piece: vec3<f32>, t_max: f32, lobe_from: vec3<f32>) {
    if sees_lights(b) {
        (*out).radiance += b.weight * lights_seen(piece, b.d, t_max, b.lobe_pdf, lobe_from, b.events == 0u);
    }
}

// Ends a branch in the environment, past the lights on its last straight piece.
fn end_in_environment(out: ptr<function, ViewSample>, b: Branch, piece: vec3<f32>, lobe_from: vec3<f32>) {
    if companion_ends_here() {
        return;
    }
    pass_lights(out, b, piece, NO_HIT, lobe_from);
    if (*out).covered || params.env.visible != 0u {
        (*out).radiance += b.weight * env_radiance(env_map, env_sampler, params.env, b.d);
    }
}

// A branch meets a receiver, past the lights on its last straight piece: the receiver's shading,
// weighted by the branch and by its coverage there. Returns the coverage: below 1 (a cut-out, a
// see-through surface) the branch goes on past it with the rest of its weight.
fn meet_receiver(out: ptr<function, ViewSample>, hit: SurfaceHit, p: vec3<f32>, b: Branch, piece: vec3<f32>, lobe_from: vec3<f32>, k: u32) -> f32 {
    if companion_ends_here() {
        return 1.0;
    }
    let glass_base = is_base_branch(b);
    var cover = 1.0;
    var glow = 0.0;
    if !glass_base {
        pass_lights(out, b, piece, distance(piece, p), lobe_from);
        let r = receivers[bvh_triangles[hit.triangle].receiver];
        cover = coverage_of(r, hit.triangle, hit.u, hit.v);
        if cover <= 0.0 {
            return cover;
        }
        glow = glow_share(b, lobe_from, p, hit.triangle, r.glow_area, r.glow_side);
    }
    first_depth(out, p);
    let sh = shade_receiver(hit, p, b.d, k, b.path, glow, glass_base);
    let w = b.weight * cover;
    (*out).caustic += w * sh.caustic;
    (*out).direct += w * sh.direct;
    (*out).indirect += w * sh.indirect;
    (*out).radiance += w * (sh.caustic + sh.direct + sh.indirect);
    return cover;
}

// cos(1 mrad): how far a curved path may turn before the lights it passes are looked for along a
// new straight piece (`trace_branch`).
const STRAIGHT_PIECE_COS: f32 = 0.9999995;

// Cut-outs and see-through receivers a view branch goes on past, at most (its own bound beside
// the shadow rays' `MAX_SEE_THROUGH`, the same count today).
const MAX_RECEIVERS_PASSED: u32 = 8u;

// Traces one branch to its end. At an interface it goes on along the transmitted direction and
// pushes the reflected one (or, under total internal reflection, goes on reflected).
fn trace_branch(out: ptr<function, ViewSample>, b0: Branch, stack: ptr<function, array<Branch, BRANCH_STACK>>, top: ptr<function, u32>, k: u32) {
    let grid = params.grid;
    var b = b0;
    let box_max = grid_box_max(grid);
    // Where the branch's current straight piece began (the lights it passes are looked for from
    // there) and its direction there, and where it last crossed rough glass (whose light
    // sampling the lights it meets share by multiple importance sampling, `lights_seen`).
    var piece = b.x;
    var piece_d = b.d;
    var lobe_from = b.x;
    // Each round marches the volume (where the branch is in it or before it) and ends on a
    // receiver, shaded at the one call of `meet_receiver` below (lavapipe inlines every call
    // site anew, and the receiver's shading is most of the pass), or in the environment. Past a
    // cut-out or a see-through receiver, the next round goes on from its far side.
    // A glass's diffuse base goes straight to its shading (`base_branch`).
    let glass_base = is_base_branch(b);
    for (var passed = 0u; passed <= MAX_RECEIVERS_PASSED; passed++) {
        var ahead_of = Lookahead(b.x, SurfaceHit(0.0, 0xffffffffu, NO_INTERFACE, b.d, 0.0, 0.0), true);
        if !glass_base {
            ahead_of = look_from(b.x, b.d);
        }
        var met = glass_base;
        var hit = ahead_of.hit;
        var p = b.x;
        let span = ray_box(b.x, b.d, grid.origin, box_max);
        if !glass_base && span.x <= span.y && span.y > 0.0 && ahead_of.hit.t > max(span.x, 0.0) {
            var s = ray_start(ior_grid, grid_sampler, grid, b.x + b.d * max(span.x, 0.0), b.d);
            var path = 0.0;
            for (var i = 0u; i < params.max_steps; i++) {
                (*out).steps++;
                let x0 = s.x;
                var jump = octree_step(x0, b.d, params.step, params.max_step);
                let bends = jump <= params.step;
                jump = min(jump, ray_box(x0, b.d, grid.origin, box_max).y + 1e-4 * grid.voxel_size);
                // A curved step goes its full length even where the grid's edge is nearer: the
                // surface ahead is looked for as far as the step will go, or a floor just past the
                // edge is stepped over (seen through glass resting on it, a ring of pixels went black).
                let reach = select(jump, params.step, bends);
                let ahead = surface_within(&ahead_of, x0, b.d, reach);
                let on_surface = ahead <= reach;
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
                        met = true;
                        break;
                    }
                    // The lights on the straight piece that ends here (a bulb in a glass shade, a
                    // softbox before the glass).
                    pass_lights(out, b, piece, distance(piece, s.x), lobe_from);
                    let surface = glass_surface_at(hit, SURFACE_NORMAL | SURFACE_EMISSION);
                    // (Where alpha cuts a sheet away, the pixel is not covered by it.)
                    if surface.coverage > 0.0 {
                        first_depth(out, s.x);
                    }
                    // A glowing surface seen from its front (either side of a thin sheet).
                    let glass = interfaces[hit.interface_id];
                    if dot(hit.normal, b.d) < 0.0 || (glass.kind & INTERFACE_THIN) != 0u {
                        (*out).radiance += b.weight * surface.emission * glow_share(b, lobe_from, s.x, hit.triangle, glass.glow_area, glass.glow_side);
                    }
                    let c = cross_interface(s.x, b.d, hit, surface, b.media, facet_numbers(k, b.path));
                    b.events += u32(c.seen);
                    if any(c.base > vec3<f32>(0.0)) && *top < BRANCH_STACK {
                        let base = base_branch(b, s.x, c);
                        if max(base.weight.r, max(base.weight.g, base.weight.b)) > MIN_WEIGHT {
                            (*stack)[*top] = base;
                            *top += 1u;
                        }
                    }
                    // A rough solid's surface: the lights sampled through it (lights_through_rough).
                    let alpha = surface.roughness * surface.roughness;
                    let rough = c.seen && alpha > 0.0 && (interfaces[hit.interface_id].kind & INTERFACE_THIN) == 0u;
                    if rough && !companion_ends_here() {
                        (*out).radiance += b.weight * lights_through_rough(s.x, b, c, surface, alpha, k);
                    }
                    var next = b.d;
                    if c.reflectance < 1.0 {
                        var reflected = Branch(s.x, c.reflected, b.weight * c.reflected_tint * (c.reflectance * c.reflected_share), media_along(c, c.reflected, b.media), b.events, 2u * b.path + 1u, 0.0);
                        if rough {
                            reflected.lobe_pdf = sampled_lobe_pdf(c, surface, b.media, b.d, c.reflected, alpha);
                        }
                        if max(reflected.weight.r, max(reflected.weight.g, reflected.weight.b)) > MIN_WEIGHT && *top < BRANCH_STACK {
                            reflected.x = crossing_exit(c, s.x, b.d, c.reflected, 1e-3 * grid.voxel_size);
                            (*stack)[*top] = reflected;
                            *top += 1u;
                        }
                        b.weight *= (1.0 - c.reflectance) * c.tint * c.transmitted_share;
                        next = c.transmitted;
                    } else {
                        b.weight *= c.reflected_tint * c.reflected_share;
                        next = c.reflected;
                    }
                    b.lobe_pdf = 0.0;
                    if rough {
                        b.lobe_pdf = sampled_lobe_pdf(c, surface, b.media, b.d, next, alpha);
                    }
                    b.media = media_along(c, next, b.media);
                    b.path = 2u * b.path;
                    if b.events >= MAX_EVENTS || max(b.weight.r, max(b.weight.g, b.weight.b)) < MIN_WEIGHT {
                        return;
                    }
                    piece = crossing_exit(c, s.x, b.d, next, 1e-3 * grid.voxel_size);
                    piece_d = next;
                    lobe_from = piece;
                    s = ray_start(ior_grid, grid_sampler, grid, piece, next);
                    b.d = next;
                    ahead_of.valid = false;
                    continue;
                }
                // Only a curved step turns the ray: a straight jump keeps d exactly, and taking it
                // back from v = n·d would round it by an ulp and discard the lookahead every step.
                let d_new = normalize(s.v);
                if bends && dot(d_new, b.d) < 1.0 - 1e-9 {
                    b.d = d_new;
                    ahead_of.valid = false;
                    // A new straight piece once the path has turned by a milliradian: not at
                    // every rounding of d, which near glass moved the piece's start past a
                    // softbox the camera saw before it.
                    if dot(b.d, piece_d) < STRAIGHT_PIECE_COS {
                        piece = s.x;
                        piece_d = b.d;
                    }
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
            // (What the meeting needs is read here, not kept through every step of the march.)
            if met {
                hit = ahead_of.hit;
                p = s.x;
            } else {
                b.x = s.x;
            }
        }
        if !met {
            hit = surface_after(&ahead_of, b.x, b.d);
            if !is_receiver_hit(hit) || passed == MAX_RECEIVERS_PASSED {
                break;
            }
            p = b.x + b.d * hit.t;
        }
        let cover = meet_receiver(out, hit, p, b, piece, lobe_from, k);
        if cover >= 1.0 {
            return;
        }
        // On past a cut-out or through a see-through surface, unbent.
        b.weight *= 1.0 - cover;
        b.x = leave_surface(p, hit.normal, b.d, 1e-3 * grid.voxel_size);
        piece = b.x;
    }
    end_in_environment(out, b, piece, lobe_from);
}

// Dispersion (VIEW_FLAG_SPECTRAL): camera sample k of a pixel carries one wavelength — a hero
// wavelength per pixel (hashed), with the pixel's other samples as its companions, spaced
// evenly over the spectrum (the rotation of Wilkie et al. 2014's hero wavelengths). Dispersive
// glass sends each wavelength its own way, so each companion is traced as a sample of its own.
// A pixel of one sample has a companion within it (j = 1 of wavelengths_per_sample, half the
// spectrum on), traced by a thread of its own (`main_companions`).
fn sample_wavelength_of(k: u32, j: u32) {
    path_dispersed = false;
    if !has(VIEW_FLAG_SPECTRAL) {
        return;
    }
    // (A refinement pass's samples, k ≥ samples, hash a hero wavelength of their own.)
    let slot = f32(k % params.samples) + f32(j) / f32(wavelengths_per_sample());
    let u = fract(random01(0x5bd1e995u, pixel_key, k / params.samples) + slot / f32(params.samples));
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
    out.indirect = xyz_to_rgb(sample_xyz(s.indirect, path_wavelength));
    return out;
}

fn trace_view(pixel: vec2<f32>, k: u32, j: u32) -> ViewSample {
    let ray = camera_ray_through_lens(pixel, k);
    sample_wavelength_of(k, j);
    var out = no_light();
    var stack: array<Branch, BRANCH_STACK>;
    var top = 0u;
    var branch = Branch(ray[0], ray[1], vec3<f32>(1.0), media_unpacked(vec2<u32>(params.camera_media_lo, params.camera_media_hi)), 0u, 1u, 0.0);
    // (One call site: the branch tracer is the pass's largest function.)
    loop {
        trace_branch(&out, branch, &stack, &top, k);
        if top == 0u || companion_gave_up {
            break;
        }
        top--;
        branch = stack[top];
    }
    out.radiance += out.volume;
    return spectral_sample(out);
}

fn wavelengths_per_sample() -> u32 {
    return max(params.wavelengths_per_sample, 1u);
}

// The ray-equation steps of this workgroup's pixels, (low, high) words: one global add per
// workgroup rather than one per pixel, all on the same word (see march.wgsl's statistics).
var<workgroup> workgroup_steps: array<atomic<u32>, 2>;

fn count_steps(steps: u32) {
    let old = atomicAdd(&workgroup_steps[0], steps);
    if old + steps < old {
        atomicAdd(&workgroup_steps[1], 1u);
    }
}

// After a barrier: the workgroup's steps into the frame's count, by its first thread.
fn flush_steps(lane: u32) {
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

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    if id.x < params.width && id.y < params.height {
        count_steps(shade_pixel(id.xy));
    }
    workgroupBarrier();
    flush_steps(lane);
}

// The pixel being shaded (its index in the whole frame), which keys its random numbers.
var<private> pixel_key: u32;

fn key_of(p: vec2<u32>) -> u32 {
    return params.pixel_key_first + p.x + p.y * params.pixel_key_stride;
}

// Traces this dispatch's camera rays of pixel `p` (samples sample_first… of `samples`) and
// writes its six planes — or, after the first dispatch of a pixel's samples, adds to them;
// returns the steps they took. (Splitting the samples keeps each invocation under lavapipe's
// 65 535 loop iterations per shader, past which it silently ends every loop.)
fn shade_pixel(p: vec2<u32>) -> u32 {
    pixel_key = key_of(p);
    var sum = no_light();
    var coverage = 0.0;
    for (var k = params.sample_first; k < params.sample_first + params.sample_count; k++) {
        let s = trace_view(vec2<f32>(p) + r2(k), k, 0u);
        coverage += select(0.0, 1.0, s.covered);
        add_sample(&sum, s, 1.0);
    }
    write_pixel(p, sum, coverage);
    return sum.steps;
}

fn add_sample(sum: ptr<function, ViewSample>, s: ViewSample, share: f32) {
    (*sum).radiance += s.radiance * share;
    (*sum).caustic += s.caustic * share;
    (*sum).direct += s.direct * share;
    (*sum).volume += s.volume * share;
    (*sum).indirect += s.indirect * share;
    (*sum).steps += s.steps;
    (*sum).depth = min((*sum).depth, s.depth);
}

// Pixel p's planes: the sum of this dispatch's samples (covering `coverage` of them) over all
// the frame's samples, added to what earlier dispatches wrote.
fn write_pixel(p: vec2<u32>, sum: ViewSample, coverage: f32) {
    let inv = 1.0 / f32(params.samples);
    let pixel = p.x + p.y * params.width;
    var beauty = vec4<f32>(sum.radiance * inv, coverage * inv);
    var depth = sum.depth;
    var caustic = vec4<f32>(sum.caustic * inv, 0.0);
    var direct = vec4<f32>(sum.direct * inv, 0.0);
    var volume = vec4<f32>(sum.volume * inv, 0.0);
    var indirect = vec4<f32>(sum.indirect * inv, 0.0);
    if params.sample_first > 0u {
        beauty += frame_beauty[pixel];
        depth = min(depth, frame_depth[pixel].x);
        caustic += frame_caustic[pixel];
        direct += frame_direct[pixel];
        volume += frame_volume[pixel];
        indirect += frame_indirect[pixel];
    }
    frame_beauty[pixel] = beauty;
    frame_depth[pixel] = vec4<f32>(depth, 0.0, 0.0, 0.0);
    frame_caustic[pixel] = caustic;
    frame_direct[pixel] = direct;
    frame_volume[pixel] = volume;
    frame_indirect[pixel] = indirect;
}

// Companions in threads of their own (a spectral frame of one sample per pixel): the
// workgroup's z = 0 threads trace its 8 × 8 pixels at their hero wavelength, its z = 1 threads
// the same rays at the companion wavelength, at once. Traced after the hero in the same
// thread, the companion doubled the time of the pixels behind dispersive glass, the view's
// slowest, which set the pass's time. A companion gives up at the first branch that ends
// before the path met dispersion (its hero's sample keeps its rgb there, exact at every
// wavelength), so on the rest of the frame its thread costs little.
var<private> tracing_companion: bool = false;
var<private> companion_gave_up: bool = false;
// The companions' samples (radiance, caustic, direct, volume, indirect), w = 1 where one met
// dispersion.
var<workgroup> companion_light: array<array<vec4<f32>, 5>, 64>;

// Whether a branch ending here ends a companion's trace: one not yet dispersed is its hero's.
fn companion_ends_here() -> bool {
    if tracing_companion && !path_dispersed {
        companion_gave_up = true;
    }
    return companion_gave_up;
}

@compute @workgroup_size(8, 8, 2)
fn main_companions(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_id) local: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    let inside = id.x < params.width && id.y < params.height;
    let slot = local.x + 8u * local.y;
    var s = no_light();
    let j = local.z;
    let k = params.sample_first;
    if inside {
        pixel_key = key_of(id.xy);
        tracing_companion = j == 1u;
        s = trace_view(vec2<f32>(id.xy) + r2(k), k, j);
        count_steps(s.steps);
    }
    if j == 1u {
        let met = select(0.0, 1.0, inside && path_dispersed && !companion_gave_up);
        companion_light[slot] = array<vec4<f32>, 5>(vec4<f32>(s.radiance, met), vec4<f32>(s.caustic, 0.0), vec4<f32>(s.direct, 0.0), vec4<f32>(s.volume, 0.0), vec4<f32>(s.indirect, 0.0));
    }
    workgroupBarrier();
    if inside && j == 0u {
        var sum = no_light();
        let c = companion_light[slot];
        // The hero alone where its path met no dispersion, or where the companion gave up at a
        // branch that ended before (then the hero's one wavelength is the sample: unbiased, as
        // whether that happens depends only on the path up to its first dispersion).
        let share = select(1.0, 0.5, path_dispersed && c[0].w > 0.0);
        add_sample(&sum, s, share);
        if share < 1.0 {
            add_sample(&sum, ViewSample(c[0].rgb, c[1].rgb, c[2].rgb, c[3].rgb, c[4].rgb, false, FAR_DEPTH, 0u), share);
        }
        write_pixel(id.xy, sum, select(0.0, 1.0, s.covered));
    }
    workgroupBarrier();
    flush_steps(lane);
}
