// Stage 5, march: photons follow the ray equation through the volume (Sun et al. 2008, §4.4),
// with the octree choosing the step: one straight jump across a flat cell, velocity-Verlet steps
// of `min_step` where n varies (the same integrator as the view pass). Along the way:
//
// - Beer–Lambert: the flux of each channel decays by exp(−σ_t·ds).
// - Each segment deposits flux × length into the radiance grid over the voxels it crosses (exact
//   3D DDA, with the flux's decay inside each voxel integrated exactly), as fixed-point u32
//   atomics — the fluence that scattering media show as light shafts.
// - At a sharp interface (shared/interface.wgsl) the photon reflects with probability R, the
//   Fresnel reflectance, and refracts (tinted) otherwise: each branch's expected flux is exact,
//   so caustics from reflection (the bright patch beside a glass block) appear as well. Inside,
//   the interface's own absorption attenuates it over the exact path.
// - A photon that reaches an opaque receiver after meeting glass (an interface, or a smooth
//   medium where n − 1 > eps_refract) deposits its flux into that receiver's caustic map; one
//   that did not is dropped there, because the direct light — whose shadow rays stop at the
//   same glass — already accounts for it.
//
// - Bounce photons (index ≥ bounce_first; photons.wgsl's second population, from every light's
//   whole emission) deposit nothing on their first receiver (direct light and caustics are
//   counted elsewhere) and then leave each receiver they reach by Russian roulette on its
//   albedo: with probability q = max(albedo) in a cosine-weighted direction, flux × albedo/q
//   (energy-exact in expectation), up to `bounces` times. Every landing after the first
//   deposits into the indirect maps (`indirect_atlas`, the same charts): light that reached the
//   receiver over at least one diffuse bounce. They fill no radiance grid (fog lit by bounced
//   light is left out) and no statistics.
//
// Fixed point: deposits are (photon flux / flux_unit) · scale, flux_unit the mean photon flux.
// The scales are chosen on the CPU (src/pipeline/march.rs) so that even every photon landing on
// one texel or voxel stays below 2³¹; beyond that an accumulator saturates (the add is undone
// and counted in the statistics), it never wraps.
//
// With dispersion in the frame (MARCH_FLAG_SPECTRAL) each photon carries one wavelength and its
// flux becomes the XYZ of that wavelength (`spectral_flux`); indices, tints and absorption are
// taken at it, and the caustics stage and `resolve` turn the XYZ sums into linear sRGB.
//
// `resolve` turns the radiance grid into the filtered textures the view pass samples.

#import shared/types.wgsl
#import shared/grid.wgsl
#import shared/ray.wgsl
#import shared/octree.wgsl
#import shared/bvh.wgsl
#import shared/interface.wgsl
#import shared/hash.wgsl
#import shared/dda.wgsl
#import shared/receivers.wgsl
#import shared/glass_surface.wgsl
#import shared/lights.wgsl

@group(0) @binding(0) var<uniform> params: MarchParams;
@group(0) @binding(1) var<storage, read> photons: array<Photon>;
@group(0) @binding(2) var ior_grid: texture_3d<f32>;
@group(0) @binding(3) var extinction_grid: texture_3d<f32>;
@group(0) @binding(4) var grid_sampler: sampler;
@group(0) @binding(5) var<uniform> octree_params: OctreeParams;
@group(0) @binding(6) var<storage, read> octree: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> bvh_nodes: array<BvhNode>;
@group(0) @binding(8) var<storage, read> bvh_triangles: array<BvhTriangle>;
@group(0) @binding(9) var<storage, read> receivers: array<ReceiverGpu>;
@group(0) @binding(10) var<storage, read> charts: array<Chart>;
// The radiance grid's deposits, 3 words per voxel in each of two buffers (each its own binding,
// so a volume needs half the binding size): flux·length r, g, b (u32) and
// luminance·length·direction x, y, z (i32 bits).
@group(0) @binding(11) var<storage, read_write> radiance_flux: array<atomic<u32>>;
// 4 words per texel: photon count, flux r, g, b.
@group(0) @binding(12) var<storage, read_write> caustic_atlas: array<atomic<u32>>;
// (low, high) word pairs, see STAT_* below.
@group(0) @binding(13) var<storage, read_write> stats: array<atomic<u32>>;
@group(0) @binding(14) var fluence_grid: texture_storage_3d<rgba16float, write>;
@group(0) @binding(15) var direction_grid: texture_storage_3d<rgba16float, write>;
@group(0) @binding(16) var<storage, read> interfaces: array<Interface>;
@group(0) @binding(17) var<storage, read> triangle_normals: array<vec4<f32>>;
@group(0) @binding(18) var<storage, read_write> radiance_direction: array<atomic<u32>>;
@group(0) @binding(19) var<storage, read> octree_leaves: array<vec4<f32>>;
// Texture coordinates of the BVH triangles and the texels of glass meshes' textures
// (shared/glass_surface.wgsl: a photon meets a textured glass where it is clear or frosted).
@group(0) @binding(20) var<storage, read> triangle_uvs: array<vec4<f32>>;
@group(0) @binding(21) var<storage, read> albedo_texels: array<u32>;
// The indirect maps' deposits, laid out as `caustic_atlas` (bounce photons, see above).
@group(0) @binding(22) var<storage, read_write> indirect_atlas: array<atomic<u32>>;
// The rough glass albedo table (shared/rough_albedo.wgsl).
@group(0) @binding(23) var<storage, read> rough_albedo_table: array<f32>;

// Statistics, each an rgb triple of 64-bit fixed-point flux sums (flux_scale units).
const STAT_EMITTED: u32 = 0u;
const STAT_RECEIVED: u32 = 3u;
const STAT_CAUSTIC: u32 = 6u;
const STAT_ESCAPED: u32 = 9u;
// A 64-bit count of deposits undone by saturation.
const STAT_SATURATED: u32 = 12u;
// A 64-bit count of the integration steps all photons took (benchmarks: photon-steps/s).
const STAT_STEPS: u32 = 13u;

const STAT_COUNT: u32 = 14u;

const FIXED_SATURATION: u32 = 0x80000000u;

// The statistics of this workgroup's photons, as (low, high) word pairs like `stats`. Every
// photon adds to the same few counters, so adding each straight to `stats` would queue all of a
// frame's photons on a dozen global words; photons add here instead (workgroup memory, which
// wgpu zero-initializes), and one thread per counter adds the workgroup's total to `stats`.
var<workgroup> workgroup_stats: array<atomic<u32>, 28>;

// The photon being marched (its index) and how many fixed-point values it has rounded so far:
// the counter its rounding dither hashes.
var<private> photon_key: u32;
var<private> roundings: u32;

// Fixed point with dithered rounding: u32(x·scale + U), U uniform in [0, 1), is x·scale in
// expectation. A frame of N photons shares 2³¹ units, so at 10M photons a mean photon is worth
// 13 units, and truncating lost 3.5 % of every caustic; the dither, a counter-based random
// number, loses nothing on average and stays deterministic.
fn to_fixed(value: f32, scale: f32) -> u32 {
    roundings++;
    // One hash of (photon, rounding): the dither need not be as good as the photons' numbers.
    let dither = f32(pcg_hash((photon_key * 0x9e3779b9u) ^ (roundings + params.seed)) >> 8u) * (1.0 / 16777216.0);
    return u32(clamp(value * scale + dither, 0.0, 1073741823.0));
}

// Adds v to the workgroup's 64-bit counter `stat` (words 2·stat, 2·stat + 1): the carry is
// exact because atomicAdd returns the value it added to.
fn stat_add(stat: u32, v: u32) {
    let old = atomicAdd(&workgroup_stats[2u * stat], v);
    if old + v < old {
        atomicAdd(&workgroup_stats[2u * stat + 1u], 1u);
    }
}

// Adds the workgroup's counter `stat` to the frame's, carrying into the high word the same way.
fn stat_flush(stat: u32) {
    let low = atomicLoad(&workgroup_stats[2u * stat]);
    let high = atomicLoad(&workgroup_stats[2u * stat + 1u]);
    var carry = 0u;
    if low != 0u {
        let old = atomicAdd(&stats[2u * stat], low);
        carry = select(0u, 1u, old + low < old);
    }
    if high + carry != 0u {
        atomicAdd(&stats[2u * stat + 1u], high + carry);
    }
}

fn stat_flux(stat: u32, flux: vec3<f32>) {
    for (var c = 0u; c < 3u; c++) {
        stat_add(stat + c, to_fixed(flux[c] / params.flux_unit, params.flux_scale));
    }
}

// Adds to a saturating radiance or caustic word. Adds are ≤ 2³⁰ and far fewer than 2³¹/2³⁰ …
// run at once per word, so the transient sum never wraps; past 2³¹ the add is undone.
fn add_radiance(i: u32, v: u32) {
    if v == 0u {
        return;
    }
    if atomicAdd(&radiance_flux[i], v) >= FIXED_SATURATION {
        atomicSub(&radiance_flux[i], v);
        stat_add(STAT_SATURATED, 1u);
    }
}

// (Into the caustic maps' deposits, or the indirect maps'.)
fn add_to_chart(i: u32, v: u32, indirect: bool) {
    if v == 0u {
        return;
    }
    // (Both sides of a `select` would run: each atomic has a branch of its own.)
    if indirect {
        if atomicAdd(&indirect_atlas[i], v) >= FIXED_SATURATION {
            atomicSub(&indirect_atlas[i], v);
            stat_add(STAT_SATURATED, 1u);
        }
    } else if atomicAdd(&caustic_atlas[i], v) >= FIXED_SATURATION {
        atomicSub(&caustic_atlas[i], v);
        stat_add(STAT_SATURATED, 1u);
    }
}

// Deposits flux·length of the segment a → b over the voxels it crosses (exact 3D DDA). The flux
// entering at a is `flux`, and it decays as exp(−σ_t·s) along the segment (σ_t constant over
// it: a flat octree cell, or one short step), so a voxel crossed from s₀ for a length ℓ gets
// exactly ∫ flux·exp(−σ_t·s) ds = flux·exp(−σ_t·s₀)·ℓ·(1 − e^{−τ})/τ, τ = σ_t·ℓ. (A straight
// jump across homogeneous fog spans up to 64 voxels: the mean flux spread evenly would light a
// shaft uniformly along its length.)
fn deposit_segment(a: vec3<f32>, b: vec3<f32>, flux: vec3<f32>, extinction: vec3<f32>) {
    let grid = params.grid;
    let dir = normalize(b - a);
    var entering = flux / params.flux_unit;
    var dda = dda_begin((a - grid.origin) / grid.voxel_size, (b - grid.origin) / grid.voxel_size);
    while dda_more(dda) {
        let c = dda.cell;
        let len = dda_advance(&dda);
        let tau = extinction * (len * grid.voxel_size);
        let across = exp(-tau);
        let mean_share = select((1.0 - across) / tau, 1.0 - 0.5 * tau, tau < vec3<f32>(1e-4));
        let inside = entering * (len * mean_share);
        entering *= across;
        if any(c < vec3<i32>(0)) || any(c >= vec3<i32>(grid.dims)) {
            continue;
        }
        pend(3u * (u32(c.x) + grid.dims.x * (u32(c.y) + grid.dims.y * u32(c.z))), inside, dir);
    }
}

// Deposits into the same voxel one after another (the many short steps through glass, the voxel
// two segments share) are summed in the thread's pending voxel and reach the grid as one set of
// atomics when the photon moves on: in fog the atomics, not the arithmetic, bound the march.
struct PendingVoxel {
    index: u32,
    flux_length: vec3<f32>,
    direction: vec3<f32>,
}

const NO_VOXEL: u32 = 0xffffffffu;
var<private> pending: PendingVoxel = PendingVoxel(NO_VOXEL, vec3<f32>(0.0), vec3<f32>(0.0));

// Adds flux·length (flux_unit · cell units) travelled along unit dir to voxel word v.
fn pend(v: u32, flux_length: vec3<f32>, dir: vec3<f32>) {
    if v != pending.index {
        flush_pending();
        pending = PendingVoxel(v, vec3<f32>(0.0), vec3<f32>(0.0));
    }
    pending.flux_length += flux_length;
    pending.direction += dir * ((flux_length.r + flux_length.g + flux_length.b) / 3.0);
}

fn flush_pending() {
    let v = pending.index;
    if v == NO_VOXEL {
        return;
    }
    for (var k = 0u; k < 3u; k++) {
        add_radiance(v + k, to_fixed(pending.flux_length[k], params.radiance_scale));
    }
    if (params.flags & MARCH_FLAG_DEPOSIT_DIRECTION) != 0u {
        let d = vec3<i32>(round(pending.direction * params.radiance_scale));
        for (var k = 0u; k < 3u; k++) {
            if d[k] != 0 {
                atomicAdd(&radiance_direction[v + k], bitcast<u32>(d[k]));
            }
        }
    }
    pending.index = NO_VOXEL;
}

// A photon lands on a receiver: its flux goes to the texel under the hit point, of the caustic
// maps (a refracted photon) or the indirect maps (a bounced one).
fn deposit_on_chart(hit: SurfaceHit, p: vec3<f32>, d: vec3<f32>, flux: vec3<f32>, indirect: bool) {
    let n = hit.normal;
    let back = dot(n, d) > 0.0;
    let facing = select(n, -n, back);
    let chart_index = chart_for(bvh_triangles[hit.triangle].receiver, facing, back);
    if chart_index < 0 {
        return;
    }
    // (The indirect maps' charts, coarser, follow the caustic maps'.)
    let chart = charts[u32(chart_index) + select(0u, params.indirect_chart_base, indirect)];
    let t = clamp(vec2<i32>(floor(chart_coords(chart, p))), vec2<i32>(0), vec2<i32>(i32(chart.width), i32(chart.height)) - 1);
    let texel = 4u * (chart.offset + u32(t.x) + chart.width * u32(t.y));
    // Irradiance is flux per surface area; the chart's texel is the surface's projection, so
    // the projected share of the flux is what divides by the texel area.
    let projected = abs(facing[chart.axis / 2u]);
    let unit = select(params.flux_unit, params.bounce_flux_unit, indirect);
    let scale = select(params.flux_scale, params.bounce_flux_scale, indirect);
    let rel = flux / unit * projected;
    if indirect {
        atomicAdd(&indirect_atlas[texel], 1u);
    } else {
        atomicAdd(&caustic_atlas[texel], 1u);
    }
    for (var k = 0u; k < 3u; k++) {
        add_to_chart(texel + 1u + k, to_fixed(rel[k], scale), indirect);
    }
}

// Where a caustic photon's path ends: on a receiver (deposit if refracted) or escaping.
fn land(end: PathEnd) {
    if !end.landed {
        return;
    }
    if !is_receiver_hit(end.hit) {
        stat_flux(STAT_ESCAPED, end.flux);
        return;
    }
    stat_flux(STAT_RECEIVED, end.flux);
    if end.refracted {
        stat_flux(STAT_CAUSTIC, end.flux);
        deposit_on_chart(end.hit, end.p, end.d, end.flux, false);
    }
}

const NO_HIT: f32 = 3.4e38;
// Interface events (reflections and refractions) a photon may have before it counts as trapped.
const MAX_EVENTS: u32 = 64u;

// Extinction over a segment: the grid's media at its midpoint and the interface medium the
// photon is inside (at the photon's wavelength, when it has one).
fn segment_extinction(a: vec3<f32>, b: vec3<f32>, media: Media) -> vec3<f32> {
    return at_wavelength(sample_grid(extinction_grid, grid_sampler, params.grid, 0.5 * (a + b)).rgb + media.absorption);
}

// A spectral photon's wavelength and flux: its wavelength sample u (drawn with its place in its
// raster cell, photons.wgsl's `cell_sample`, carried in bits 1–31 of its flags) mapped through
// the binned wavelength density (spectrum.wgsl's `sample_wavelength`) — or spread uniformly
// over [band_min, band_max] — and carries x̄ȳz̄(λ)·S(λ)/p(λ) of its light's rgb flux,
// whose expectation is that flux's XYZ. Sets the path's wavelength for the interfaces and the
// grid. An RGB frame's photons keep their flux as it is.
fn spectral_flux(flux: vec3<f32>, photon_flags: u32) -> vec3<f32> {
    if (params.flags & MARCH_FLAG_SPECTRAL) == 0u {
        return flux;
    }
    let u = f32(photon_flags >> 1u) * (1.0 / 2147483648.0);
    var lambda = sample_wavelength(u);
    var pdf = wavelength_pdf(lambda);
    if params.band_max > 0.0 {
        lambda = mix(params.band_min, params.band_max, u);
        pdf = 1.0 / (params.band_max - params.band_min);
    }
    path_wavelength = lambda;
    grid_dispersion_scale = dispersion_scale(params.grid_dispersion, lambda);
    return cmf(lambda) * (uplift(flux, lambda) / (pdf * Y_INTEGRAL));
}

// Where a path ended: `landed` on a surface that is no interface (a receiver, or nothing: an
// escape), at p going along d with `flux`, after `steps` integration steps. A path that was
// absorbed or trapped did not land.
struct PathEnd {
    landed: bool,
    hit: SurfaceHit,
    p: vec3<f32>,
    d: vec3<f32>,
    flux: vec3<f32>,
    refracted: bool,
    steps: u32,
}

fn absorbed(steps: u32) -> PathEnd {
    var end: PathEnd;
    end.landed = false;
    end.steps = steps;
    return end;
}

// A photon's path from where it starts (its light, or a receiver it left) to where it ends.
// `key` seeds its interface choices; `deposit_radiance`: fill the radiance grid on the way;
// `flux_unit`: its population's mean photon flux (caustic or bounce), below 10⁻⁶ of which a
// photon a medium has all but absorbed ends. (The caustic unit for a bounce photon ended every
// one once the bounce budget reached 10⁶ times the caustic one: with `photons = 0`, at 10⁶.)
fn march_path(photon: Photon, start_flux: vec3<f32>, key: u32, deposit_radiance: bool, flux_unit: f32) -> PathEnd {
    var flux = start_flux;
    let index = key;
    let grid = params.grid;
    var d = photon.dir;
    var ahead_of = look_from(photon.origin, d);
    let span = ray_box(photon.origin, d, grid.origin, grid_box_max(grid));
    if span.x > span.y || span.y <= 0.0 || ahead_of.hit.t < span.x {
        return PathEnd(true, ahead_of.hit, photon.origin + d * ahead_of.hit.t, d, flux, false, 0u);
    }
    var s = ray_start(ior_grid, grid_sampler, grid, photon.origin + d * max(span.x, 0.0), d);
    var refracted = false;
    var media = media_unpacked(vec2<u32>(photon.media_lo, photon.media_hi));
    var events = 0u;
    let box_max = grid_box_max(grid);
    var n_steps = 0u;
    var path = 0.0;
    for (; n_steps < params.max_steps; n_steps++) {
        let x0 = s.x;
        var jump = octree_step(x0, d, params.min_step, params.max_step);
        let bends = jump <= params.min_step;
        jump = min(jump, ray_box(x0, d, grid.origin, box_max).y + 1e-4 * grid.voxel_size);
        // As far as the step will go: a curved step is min_step long even where the grid's edge
        // is nearer (view.wgsl, trace_branch).
        let reach = select(jump, params.min_step, bends);
        let ahead = surface_within(&ahead_of, x0, d, reach);
        if ahead <= reach {
            // A surface comes first: finish the segment on it.
            let p = x0 + d * ahead;
            let extinction = segment_extinction(x0, p, media);
            let after = flux * exp(-extinction * ahead);
            if deposit_radiance {
                deposit_segment(x0, p, flux, extinction);
            }
            path += ahead;
            let hit = ahead_of.hit;
            if hit.interface_id == NO_INTERFACE {
                return PathEnd(true, hit, p, d, after, refracted, n_steps + 1u);
            }
            // An interface: reflect with probability R, else refract (tinted) into the media
            // beyond. Either way the photon is now a caustic photon — but for one that passed
            // a polished thin sheet straight.
            flux = after;
            events++;
            let facet = vec2<f32>(random01(params.seed, index, 96u + 2u * events), random01(params.seed, index, 97u + 2u * events));
            let surface = glass_surface_at(hit, SURFACE_NORMAL);
            let c = cross_interface(p, d, hit, surface, media, facet);
            // Light straight through a polished thin sheet is the shadow rays' (view.wgsl,
            // sheet_transmittance): such a photon stays direct light unless it was bent before.
            var passed_sheet = (interfaces[hit.interface_id].kind & INTERFACE_THIN) != 0u && surface.roughness == 0.0;
            let incoming = d;
            if random01(params.seed, index, 16u + events) < c.reflectance {
                d = c.reflected;
                flux *= at_wavelength(c.reflected_tint) * c.reflected_share;
                passed_sheet = false;
            } else {
                d = c.transmitted;
                flux *= at_wavelength(c.tint) * c.transmitted_share;
            }
            media = media_along(c, d, media);
            refracted = refracted || (!passed_sheet && c.seen);
            events -= u32(!c.seen);
            s = ray_start(ior_grid, grid_sampler, grid, crossing_exit(c, p, incoming, d, 1e-3 * grid.voxel_size), d);
            ahead_of.valid = false;
            if events >= MAX_EVENTS || path > params.max_path {
                return absorbed(n_steps + 1u); // trapped by total internal reflection (march.rs)
            }
            continue;
        }
        if bends {
            march_step(ior_grid, grid_sampler, grid, &s, params.min_step);
        } else {
            s.x = x0 + d * jump;
            s.g = sample_ior(ior_grid, grid_sampler, grid, s.x);
            s.v = d * s.g.w;
        }
        let length = distance(x0, s.x);
        path += length;
        if path > params.max_path {
            return absorbed(n_steps + 1u); // trapped by total internal reflection (march.rs)
        }
        let extinction = segment_extinction(x0, s.x, media);
        let after = flux * exp(-extinction * length);
        if deposit_radiance {
            deposit_segment(x0, s.x, flux, extinction);
        }
        flux = after;
        refracted = refracted || s.g.w - 1.0 > params.eps_refract;
        let d_new = normalize(s.v);
        if bends && dot(d_new, d) < 1.0 - 1e-9 {
            // The path bent: the surface ahead must be looked for again along the new direction.
            // (A straight jump keeps d exactly; taking it back from v = n·d would round it by an
            // ulp and cast the BVH again at every step.)
            d = d_new;
            ahead_of.valid = false;
        }
        if max(flux.r, max(flux.g, flux.b)) < 1e-6 * flux_unit {
            return absorbed(n_steps + 1u);
        }
        // (Checked after the step: the entry point itself may round to just outside.)
        if !in_grid(grid, s.x) {
            n_steps++;
            break;
        }
    }
    let hit = surface_after(&ahead_of, s.x, d);
    return PathEnd(true, hit, s.x + d * hit.t, d, flux, refracted, n_steps);
}

// A caustic photon (the index-th of the frame) from its light to where it ends; returns the
// steps it took.
fn march_photon(photon: Photon, index: u32) -> u32 {
    let flux = spectral_flux(photon.flux, photon.flags);
    stat_flux(STAT_EMITTED, flux);
    let end = march_path(photon, flux, index, (params.flags & MARCH_FLAG_DEPOSIT_RADIANCE) != 0u, params.flux_unit);
    land(end);
    return end.steps;
}

// A bounce photon from its light over up to `bounces` diffuse bounces (see the top); returns
// the steps it took.
fn march_bounces(photon: Photon, index: u32) -> u32 {
    var leg = photon;
    var flux = spectral_flux(photon.flux, photon.flags);
    var steps = 0u;
    for (var bounce = 0u; ; bounce++) {
        // Each leg draws its own interface choices.
        let key = index ^ (bounce * 0x9e3779b9u);
        let end = march_path(leg, flux, key, false, params.bounce_flux_unit);
        steps += end.steps;
        if !end.landed || !is_receiver_hit(end.hit) {
            break;
        }
        if bounce > 0u {
            deposit_on_chart(end.hit, end.p, end.d, end.flux, true);
        }
        if bounce >= params.bounces {
            break;
        }
        // Russian roulette on the albedo: leave with probability q, carrying albedo/q.
        let r = receivers[bvh_triangles[end.hit.triangle].receiver];
        // (At the photon's wavelength when it has one: its flux is then that wavelength's XYZ.)
        let albedo = at_wavelength(diffuse_albedo(r, end.hit));
        let q = max(albedo.r, max(albedo.g, albedo.b));
        if random01(params.seed, index, 400u + 3u * bounce) >= q {
            break;
        }
        flux = end.flux * albedo / q;
        let facing = select(end.hit.normal, -end.hit.normal, dot(end.hit.normal, end.d) > 0.0);
        let frame = cone_frame(facing);
        let u = vec2<f32>(random01(params.seed, index, 401u + 3u * bounce), random01(params.seed, index, 402u + 3u * bounce));
        let dir = cosine_direction(facing, frame[0], frame[1], u);
        // Off the surface so its own triangle is not hit again; it leaves into air.
        let origin = end.p + facing * (1e-4 + 1e-3 * params.grid.voxel_size);
        leg = Photon(origin, leg.flags, dir, 0u, flux, 0u);
    }
    return steps;
}

// The share of light a receiver scatters diffusely at a hit: its base colour (with its texture),
// less what a metal reflects specularly. (Glossy lobes do not bounce light here.)
fn diffuse_albedo(r: ReceiverGpu, hit: SurfaceHit) -> vec3<f32> {
    let base = base_color_at(r, hit_uv(hit.triangle, hit.u, hit.v)).rgb;
    return clamp(base * (1.0 - r.metallic), vec3<f32>(0.0), vec3<f32>(1.0));
}

@compute @workgroup_size(64)
fn main(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    // Dispatched as a 2D grid of workgroups when there are more than 65 535 of them.
    let i = id.x + id.y * groups.x * 64u;
    if i < params.photon_count {
        let photon = photons[i];
        if (photon.flags & PHOTON_LIVE) != 0u {
            photon_key = i;
            if i >= params.bounce_first {
                stat_add(STAT_STEPS, march_bounces(photon, i));
            } else {
                stat_add(STAT_STEPS, march_photon(photon, i));
                flush_pending(); // the photon's last voxel
            }
        }
    }
    workgroupBarrier();
    if lane < STAT_COUNT {
        stat_flush(lane);
    }
}

// Fluence (W/m²) and mean photon direction per voxel, for the view pass's in-scattering.
@compute @workgroup_size(4, 4, 4)
fn resolve(@builtin(global_invocation_id) id: vec3<u32>) {
    let grid = params.grid;
    if any(id >= grid.dims) {
        return;
    }
    let v = 3u * (id.x + grid.dims.x * (id.y + grid.dims.y * id.z));
    let sums = vec3<f32>(f32(atomicLoad(&radiance_flux[v])), f32(atomicLoad(&radiance_flux[v + 1u])), f32(atomicLoad(&radiance_flux[v + 2u])));
    // Σ flux·length / voxel volume: sums are (flux/flux_unit)·(length/h)·scale.
    let fluence = sums * (params.flux_unit / (params.radiance_scale * grid.voxel_size * grid.voxel_size));
    let dir_sum = vec3<f32>(
        f32(bitcast<i32>(atomicLoad(&radiance_direction[v]))),
        f32(bitcast<i32>(atomicLoad(&radiance_direction[v + 1u]))),
        f32(bitcast<i32>(atomicLoad(&radiance_direction[v + 2u]))),
    );
    let lum = (sums.r + sums.g + sums.b) / 3.0;
    // The luminance-weighted mean direction: its length (≤ 1) says how collimated the light is.
    let mean_dir = select(vec3<f32>(0.0), dir_sum / lum, lum > 0.0);
    // Spectral photons deposited XYZ.
    let rgb = select(fluence, xyz_to_rgb(fluence), (params.flags & MARCH_FLAG_SPECTRAL) != 0u);
    textureStore(fluence_grid, id, vec4<f32>(rgb, 0.0));
    textureStore(direction_grid, id, vec4<f32>(mean_dir, 0.0));
}
