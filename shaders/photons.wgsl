// Stage 4, photons: where the photons leave the lights (Sun et al. 2008, §4.3).
//
// The paper rasterizes the refractive objects from each light to emit photons only where they
// matter. Here every light gets a G×G raster over the directions (or, for the sun, the area)
// that can reach the volume, and each cell a weight = its power × its importance: 1 when its
// central ray crosses a refractive cell of the octree (smooth or sharp glass), `medium_importance` when it crosses only a
// scattering medium (light shafts), 0 otherwise. One CDF over all lights' cells then splits the
// photon budget over lights and cells by weight, and photon i takes the stratified sample
// u = (i + ξ)/N of it, so its flux — I(ω)·cell measure / (N·pmf) — keeps the estimate unbiased
// wherever the weight is nonzero. All randomness is hash(seed, i): the same photons every frame.
//
// Entry points, in order: `importance_raster` (one thread per cell; `bounce_raster` for the
// bounce photons), `scan` (one workgroup: the CDF), `emit` (one thread per photon).
//
// They run twice a frame. First for the caustic photons, as above. Then, where the frame
// traces bounced light, for the bounce photons (`bounce_raster`): each light's whole
// emission (`lights::bounce_emitter_for`), every cell of importance 1, written after the caustic
// photons (`photon_offset`); march.wgsl follows them over diffuse bounces.

#import shared/types.wgsl
#import shared/grid.wgsl
#import shared/hash.wgsl
#import shared/lights.wgsl
#import shared/dda.wgsl
#import shared/environment.wgsl
#import shared/env_light.wgsl
#import shared/mesh_light.wgsl

@group(0) @binding(0) var<uniform> params: PhotonParams;
@group(0) @binding(1) var<storage, read> emitters: array<Emitter>;
@group(0) @binding(2) var<storage, read> lights: array<LightGpu>;
@group(0) @binding(3) var<uniform> octree_params: OctreeParams;
// Level 0 of the pyramid (the dual grid's cells).
@group(0) @binding(4) var<storage, read> octree_leaves: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> cdf: array<f32>;
@group(0) @binding(6) var<storage, read_write> photons: array<Photon>;
// Per level-0 octree cell, the n − 1 of sharp glass near it (octree.wgsl).
@group(0) @binding(7) var<storage, read> glass_mark: array<f32>;
// The environment's importance table (shared/env_light.wgsl), for its emitter.
@group(0) @binding(8) var<storage, read> env_table: array<f32>;
// The glowing meshes' triangles (shared/mesh_light.wgsl).
@group(0) @binding(9) var<storage, read> light_triangles: array<LightTriangle>;

// Raster rays are classified by the octree's level-0 cells, which follow the objects' outline to
// a voxel (each cell bounds the 4×4×4 voxels around it, so the test stays conservative): few
// photons are spent on rays that miss the glass; a raster ray crosses at most a few hundred
// cells.

// Origin and direction of the point (u ∈ [0,1)²) of an emitter's raster.
struct EmitterRay {
    origin: vec3<f32>,
    dir: vec3<f32>,
}

// Emitters whose photons each take a direction of their own within a raster cell: the
// environment and area lights. `SpreadRay.weight` is the radiance over the direction's density,
// L(ω)/p(ω): a photon's flux is that × the cell's `measure` × total/(N·weight).
//
// - The environment's emitter (`Emitter.light == ENV_LIGHT`) is a disc as wide as the volume's
//   bounding sphere (radius `half_width` about `origin`), square to each photon's direction,
//   which is drawn from the environment (shared/env_light.wgsl), and `start_distance` back
//   along it, outside every receiver; its cells are equal areas of the disc (the concentric
//   map), `measure` the area of one.
// - A rect light's cells are equal areas of the rect (`measure` the area of one); its photons
//   leave uniformly over the cone of directions from their start that holds the volume's
//   bounding sphere (as a point light's raster does), L cos θ / p = L cos θ × the cone's solid
//   angle — or, from inside the sphere, cosine-weighted about its normal (`axis`): π L.
// - A glowing mesh's cells are equal areas of its two sides (shared/mesh_light.wgsl), each
//   point emitting as a rect's does about that side's normal.
struct SpreadRay {
    origin: vec3<f32>,
    dir: vec3<f32>,
    weight: vec3<f32>,
}

fn spreads(e: Emitter) -> bool {
    if e.light == ENV_LIGHT {
        return true;
    }
    let kind = lights[e.light].kind;
    return kind == LIGHT_RECT || kind == LIGHT_DISK || kind == LIGHT_MESH;
}

// The photon ray of raster point u with direction numbers xi.
fn spread_ray(e: Emitter, u: vec2<f32>, xi: vec2<f32>) -> SpreadRay {
    if e.light == ENV_LIGHT {
        // Light from direction ω travels along −ω, from the disc on ω's side.
        let s = env_light_sample(params.env, xi);
        let dir = -s.dir;
        let frame = cone_frame(dir);
        let q = concentric_disk(u) * e.half_width;
        let origin = e.origin + frame[0] * q.x + frame[1] * q.y - dir * e.start_distance;
        return SpreadRay(origin, dir, s.radiance / s.pdf);
    }
    let at = area_point(e, u);
    let radiance = lights[e.light].radiant * at.scale;
    let cone = rect_cone(e, at.p);
    if cone.w <= -1.0 {
        // About a rect's own axes; a mesh's point has only its normal.
        var frame = mat2x3<f32>(e.right, e.up);
        if lights[e.light].kind == LIGHT_MESH {
            frame = cone_frame(at.n);
        }
        return SpreadRay(at.p, cosine_direction(at.n, frame[0], frame[1], xi), PI * radiance);
    }
    let frame = cone_frame(cone.xyz);
    let dir = cap_direction(cone.xyz, frame[0], frame[1], cone.w, xi);
    return SpreadRay(at.p, dir, radiance * max(dot(dir, at.n), 0.0) * TAU * (1.0 - cone.w));
}

// Point u of an area light and the normal it emits about: a rect's (a disk's: the concentric
// map, equal areas for equal cells), or one side of a glowing mesh's surface, lifted off it as
// a photon leaving a receiver is (march.wgsl) so that it does not land where it starts.
fn area_point(e: Emitter, u: vec2<f32>) -> LightPoint {
    let light = lights[e.light];
    if light.kind == LIGHT_MESH {
        let q = mesh_light_side_point(light, u);
        return LightPoint(q.p + q.n * (1e-4 + 1e-3 * params.grid.voxel_size), q.n, q.scale);
    }
    var q = 2.0 * u - 1.0;
    if light.kind == LIGHT_DISK {
        q = concentric_disk(u);
    }
    return LightPoint(e.origin + e.right * (q.x * e.half_width) + e.up * (q.y * e.half_height), e.axis, vec3<f32>(1.0));
}

// The cone a rect light's photons from p leave in: toward the volume (`volume_cone`), or every
// direction for a bounce emitter (`lights::bounce_emitter_for` marks it by cos_max = −2).
// (The emitter says so rather than a flag in the uniforms: a branch on such a flag here made
// lavapipe's heap grow by 0.67 MiB a frame, tests/memory.rs.)
fn rect_cone(e: Emitter, p: vec3<f32>) -> vec4<f32> {
    if e.cos_max < -1.5 {
        return vec4<f32>(0.0, 1.0, 0.0, -1.0);
    }
    return volume_cone(p);
}

// The cone of directions from p that holds the volume's bounding sphere: (axis, cos of its
// half-angle), or cos −1 (every direction) from inside the sphere.
fn volume_cone(p: vec3<f32>) -> vec4<f32> {
    let lo = params.grid.origin;
    let hi = grid_box_max(params.grid);
    let radius = 0.5 * length(hi - lo);
    let to = 0.5 * (lo + hi) - p;
    let d = length(to);
    if d <= radius * 1.001 {
        return vec4<f32>(0.0, 1.0, 0.0, -1.0);
    }
    return vec4<f32>(to / d, sqrt(max(0.0, 1.0 - (radius / d) * (radius / d))));
}

// What a spreading emitter's cell is weighted by before its importance, per unit `measure`:
// ∫ L dω for the environment; for a rect, L × the solid angle of the volume's cone from the
// cell's centre (an upper bound of its power toward the volume: cos θ ≤ 1).
fn spread_power(e: Emitter, u: vec2<f32>) -> vec3<f32> {
    if e.light == ENV_LIGHT {
        return env_light_integral(params.env);
    }
    let at = area_point(e, u);
    let cone = rect_cone(e, at.p);
    // Nothing reaches the volume from a side that faces away from all of its cone (the back
    // of a glowing sheet): cos θ ≤ 0 over the cone when the angle from the normal to its axis
    // is at least 90° plus its half-angle.
    if cone.w > -1.0 && dot(cone.xyz, at.n) <= -sqrt(max(0.0, 1.0 - cone.w * cone.w)) {
        return vec3<f32>(0.0);
    }
    return lights[e.light].radiant * select(TAU * (1.0 - cone.w), PI, cone.w <= -1.0);
}

// A spreading emitter's cell is worth what rays through it along a few of its directions meet
// (their largest importance), never less than SPREAD_MIN_IMPORTANCE: its photons take other
// directions, so a cell whose test rays all miss may still reach glass, and a weight kept above
// zero keeps the estimate unbiased (only noisier there).
const SPREAD_TEST_DIRECTIONS: u32 = 4u;
const SPREAD_MIN_IMPORTANCE: f32 = 0.0625;

fn spread_importance(e: Emitter, cell: u32, u: vec2<f32>) -> f32 {
    var best = SPREAD_MIN_IMPORTANCE;
    for (var t = 0u; t < SPREAD_TEST_DIRECTIONS; t++) {
        let ray = spread_ray(e, u, vec2<f32>(random01(params.seed, cell, 300u + 2u * t), random01(params.seed, cell, 301u + 2u * t)));
        best = max(best, importance(ray.origin, ray.dir));
    }
    return best;
}

fn emitter_ray(e: Emitter, u: vec2<f32>) -> EmitterRay {
    let light = lights[e.light];
    if light.kind == LIGHT_SUN {
        let p = e.origin + e.right * ((2.0 * u.x - 1.0) * e.half_width) + e.up * ((2.0 * u.y - 1.0) * e.half_height);
        return EmitterRay(p, e.axis);
    }
    return EmitterRay(e.origin, cap_direction(e.axis, e.right, e.up, e.cos_max, u));
}

// Power (W per channel) that leaves through a cell of measure `m` around a ray.
fn cell_power(e: Emitter, dir: vec3<f32>) -> vec3<f32> {
    let light = lights[e.light];
    if light.kind == LIGHT_SUN {
        return light.radiant * e.measure;
    }
    return light_intensity(light, dir) * e.measure;
}

// 1 if the ray crosses a refractive octree cell, medium_importance if only a scattering
// medium, 0 if neither (then no photon is needed there: direct light covers it).
fn importance(o: vec3<f32>, d: vec3<f32>) -> f32 {
    let grid = params.grid;
    let span = ray_box(o, d, grid.origin, grid_box_max(grid));
    if span.x > span.y || span.y <= 0.0 {
        return 0.0;
    }
    let dims = octree_params.levels[0];
    // Level-0 cells in dual-grid units: x ↦ (x − origin)/h − 1/2.
    let to_cells = vec3<f32>(-0.5) - grid.origin / grid.voxel_size;
    let a = (o + d * max(span.x, 0.0)) / grid.voxel_size + to_cells;
    let b = (o + d * span.y) / grid.voxel_size + to_cells;
    var medium = false;
    var dda = dda_begin(a, b);
    while dda_more(dda) {
        let c = clamp(dda.cell, vec3<i32>(0), vec3<i32>(dims.xyz) - 1);
        dda_advance(&dda);
        let cell = u32(c.x) + dims.x * (u32(c.y) + dims.y * u32(c.z));
        let v = octree_leaves[cell];
        if v.y - 1.0 > params.eps_refract || glass_mark[cell] > params.eps_refract {
            return 1.0;
        }
        medium = medium || v.w > 0.0;
    }
    return select(0.0, params.medium_importance, medium);
}

fn luminance(c: vec3<f32>) -> f32 {
    return (c.r + c.g + c.b) / 3.0;
}

fn cell_count() -> u32 {
    return params.emitter_count * params.cells * params.cells;
}

// Raster cell `cell`'s emitter and the centre u of the cell in its raster.
struct RasterCell {
    e: Emitter,
    u: vec2<f32>,
}

fn raster_cell(cell: u32) -> RasterCell {
    let per = params.cells * params.cells;
    let local = cell % per;
    let u = (vec2<f32>(f32(local % params.cells), f32(local / params.cells)) + 0.5) / f32(params.cells);
    return RasterCell(emitters[params.first_emitter + cell / per], u);
}

@compute @workgroup_size(64)
fn importance_raster(@builtin(global_invocation_id) id: vec3<u32>) {
    let cell = id.x;
    if cell >= cell_count() {
        return;
    }
    let c = raster_cell(cell);
    if spreads(c.e) {
        cdf[cell] = luminance(spread_power(c.e, c.u) * c.e.measure) * spread_importance(c.e, cell, c.u);
        return;
    }
    let ray = emitter_ray(c.e, c.u);
    cdf[cell] = luminance(cell_power(c.e, ray.dir)) * importance(ray.origin, ray.dir);
}

// The bounce population's raster: bounced light matters wherever it lands,
// so every cell is worth its power. (A kernel of its own: the importance walk behind a branch on
// a flag in the uniforms made lavapipe's heap grow by 0.67 MiB a frame, tests/memory.rs.)
@compute @workgroup_size(64)
fn bounce_raster(@builtin(global_invocation_id) id: vec3<u32>) {
    let cell = id.x;
    if cell >= cell_count() {
        return;
    }
    let c = raster_cell(cell);
    if spreads(c.e) {
        cdf[cell] = luminance(spread_power(c.e, c.u) * c.e.measure);
        return;
    }
    cdf[cell] = luminance(cell_power(c.e, emitter_ray(c.e, c.u).dir));
}

var<workgroup> chunk_sums: array<f32, 256>;

// In-place inclusive prefix sum of the weights, in a fixed order (deterministic): each thread
// sums a contiguous chunk, one thread scans the chunk sums, then each chunk is rewritten.
@compute @workgroup_size(256)
fn scan(@builtin(local_invocation_index) lid: u32) {
    let n = cell_count();
    let chunk = (n + 255u) / 256u;
    let first = lid * chunk;
    let last = min(first + chunk, n);
    var sum = 0.0;
    for (var i = first; i < last; i++) {
        sum += cdf[i];
    }
    chunk_sums[lid] = sum;
    workgroupBarrier();
    if lid == 0u {
        for (var k = 1u; k < 256u; k++) {
            chunk_sums[k] += chunk_sums[k - 1u];
        }
    }
    workgroupBarrier();
    var running = select(0.0, chunk_sums[lid - 1u], lid > 0u);
    for (var i = first; i < last; i++) {
        running += cdf[i];
        cdf[i] = running;
    }
}

// The first cell whose cumulative weight exceeds u.
fn find_cell(u: f32) -> u32 {
    var lo = 0u;
    var hi = cell_count() - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if cdf[mid] > u {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

// Where in its raster cell photon i leaves (xy), and in a spectral frame its wavelength sample
// (z, for march.wgsl's `spectral_flux`). An RGB frame hashes the position. A spectral frame
// draws position and wavelength together: photon i takes the i-th point of the R₃ sequence
// (shared/hash.wgsl), rotated per cell (Cranley–Patterson). A cell's photons are consecutive and
// any run of R₃ fills the cube evenly, so the photons that land on one patch of a caustic — from
// one patch of a cell — still cover the spectrum, and its colour noise falls. The rotation makes
// each cell's sample unbiased on its own: unrotated, the runs of neighbouring cells continue one
// lattice, whose planes tie wavelength to place across the raster (a white light's caustic
// behind a dispersive ball came out 1.6 % short in blue). Its position part is random; its
// wavelength part steps by the golden ratio from cell to cell, so the frame as a whole stays as
// evenly spread over the spectrum as the photons' golden-ratio wavelengths were before.
fn cell_sample(i: u32, cell: u32) -> vec3<f32> {
    let seed = params.seed;
    if (params.flags & PHOTON_FLAG_SPECTRAL) == 0u {
        return vec3<f32>(random01(seed, i, 1u), random01(seed, i, 2u), 0.0);
    }
    let shift = vec3<f32>(random01(seed, cell, 201u), random01(seed, cell, 202u), fract(f32(cell * 0x9e3779b9u) * FIXED_32_TO_UNIT + random01(seed, 0u, 203u)));
    return fract(vec3<f32>(f32(i * R3_ALPHA_1), f32(i * R3_ALPHA_2), f32(i * R3_ALPHA_3)) * FIXED_32_TO_UNIT + shift);
}

@compute @workgroup_size(64)
fn emit(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    // Dispatched as a 2D grid of workgroups when there are more than 65 535 of them.
    let i = id.x + id.y * groups.x * 64u;
    let n = params.photon_count;
    if i >= n {
        return;
    }
    let slot = params.photon_offset + i;
    let total = cdf[cell_count() - 1u];
    if total <= 0.0 {
        photons[slot] = Photon(vec3<f32>(0.0), 0u, vec3<f32>(0.0, 0.0, 1.0), 0u, vec3<f32>(0.0), 0u);
        return;
    }
    let seed = params.seed;
    // Stratified over the CDF: photon i takes the i-th of N equal slices.
    let u = (f32(i) + random01(seed, i, 0u)) / f32(n) * total;
    let cell = find_cell(u);
    let weight = cdf[cell] - select(0.0, cdf[cell - 1u], cell > 0u);
    let per = params.cells * params.cells;
    let e = emitters[params.first_emitter + cell / per];
    let local = cell % per;
    let sample = cell_sample(i, cell);
    let uc = (vec2<f32>(f32(local % params.cells), f32(local / params.cells)) + sample.xy) / f32(params.cells);
    // Bit 0: a live photon; bits 1–31: its wavelength sample (0 in an RGB frame).
    let flags = PHOTON_LIVE | (u32(sample.z * 2147483648.0) << 1u);
    if spreads(e) {
        let ray = spread_ray(e, uc, vec2<f32>(random01(seed, i, 5u), random01(seed, i, 6u)));
        let flux = ray.weight * e.measure * (total / (f32(n) * weight));
        // The environment's photons start in air: its disc lies outside the volume, which holds
        // every sharp object.
        var media = vec2<u32>(0u);
        if e.light != ENV_LIGHT {
            media = lights[e.light].media;
        }
        photons[slot] = Photon(ray.origin, flags, ray.dir, media.x, flux, media.y);
        return;
    }
    var ray = emitter_ray(e, uc);
    let light = lights[e.light];
    let flux = cell_power(e, ray.dir) * (total / (f32(n) * weight));
    if light.kind == LIGHT_SUN && light.half_angle > 0.0 {
        // The sun's disc: directions spread over its angular radius (soft caustics).
        ray.dir = cone_direction(e.axis, e.right, e.up, light.half_angle, vec2<f32>(random01(seed, i, 3u), random01(seed, i, 4u)));
    }
    photons[slot] = Photon(ray.origin, flags, ray.dir, light.media.x, flux, light.media.y);
}
