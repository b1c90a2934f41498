// Stage 1a, mesh solids: one refractive triangle mesh → the signed distance (voxels, negative
// inside) from every voxel centre of its window to its surface, written to the coverage atlas
// that voxelize.wgsl composites into n, κ and σ. The kernels run in this order, once per mesh
// that changed or moved:
//
//   clear_scratch       zero the parity words, the band distances and the large-work list
//   transform_vertices  local coordinates → window-local fixed point (2^fixed_bits per voxel)
//   rasterize           one thread per (triangle, pass): passes 0–2 mark where the rays along
//                       x, y and z cross the triangle; pass 3 takes the triangle's exact
//                       distance to the voxels near it. A triangle that covers many columns
//                       goes to the large-work list instead, so no thread loops for long.
//   rasterize_large     one workgroup per listed (triangle, pass), its columns shared out
//   prefix_parity       per column: running XOR of the crossing marks → parity per voxel
//   signed_distance     per voxel: the three axes vote inside/outside; ± band distance
//
// Inside/outside is the even–odd rule along rays parallel to the three axes, voted (the parity
// count of Nooruddin & Turk 2003, "Simplification and repair of polygonal models using
// volumetric techniques", with three ray directions; docs/meshes.md states the guarantees). A
// ray's vote counts only if it crosses the surface an even number of times over its whole
// line: a ray through a hole crosses an odd number of times and abstains. A voxel is inside
// when most votes cast say so, so a hole never floods the outside, and empties only voxels
// whose three lines all pass through holes. Crossings are decided exactly: vertices are
// snapped to fixed point, and the point-in-triangle test and the side of the crossing are
// signs of integer determinants (int64.wgsl). A column that passes exactly through an edge or
// a vertex counts as if moved by the infinitesimal (−ε, −ε²) in its plane (the tie rule in
// `owns`), so every line crosses a closed mesh an even number of times, shared edges are
// counted once, and flipped triangles change nothing. The CPU twin (src/cpu/mesh.rs) gives
// identical bits.
//
// The distance band: every voxel centre within `reach` ≥ 0.9 voxel of a triangle gets its
// exact distance to the nearest one (atomicMax on the inverted bits of a non-negative f32 is an
// order-independent minimum). Every voxel whose cube the surface touches has its centre within
// √3/2 voxel of it, so the band is a conservative — hence 26-separating — surface
// voxelization; with the sign from the vote it is the signed distance whose smooth step
// (voxelize.wgsl) makes n.

#import shared/types.wgsl
#import shared/int64.wgsl

@group(0) @binding(0) var<storage, read_write> grid_vertices: array<vec4<i32>>;
@group(0) @binding(1) var<storage, read_write> parity_words: array<atomic<u32>>;
@group(0) @binding(2) var<storage, read_write> band_distance: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> large_work: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read_write> atlas: array<f32>;
@group(1) @binding(0) var<uniform> mesh: MeshParams;
@group(1) @binding(1) var<storage, read> local_vertices: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> triangle_indices: array<u32>;

const WG: u32 = 64u;
const LARGE_WG: u32 = 64u;
// Columns one thread handles before a triangle counts as large: a triangle a few voxels
// across stays with its thread (a band column costs ~5 distance evaluations, a crossing
// column one exact test), one spanning many voxels is shared by a workgroup.
const SMALL_CROSSING_COLUMNS: u32 = 256u;
const SMALL_BAND_COLUMNS: u32 = 64u;
const BAND_PASS: u32 = 3u;
// Fixed-point coordinates stay within ±2^18 (relative to the grid origin), so every
// difference fits in 20 bits and every determinant below in 60 (see the twin's bounds test).
const COORD_LIMIT: f32 = 262144.0;
// The signed distance of voxels out of every triangle's reach.
const FAR: f32 = 1e9;
// Band columns are widened by this much (voxels) so no voxel within reach is skipped by
// rounding; the exact distance then decides.
const BAND_SLACK: f32 = 1e-3;

// Thread index of a 1D dispatch spread over x and z (a dimension holds at most 65535 groups).
fn flat_id(group: vec3<u32>, groups: vec3<u32>, local: u32, size: u32) -> u32 {
    return (group.x + group.z * groups.x) * size + local;
}

// Coordinates in the frame (u, v, w) of rays along `axis`: w along the rays, and (u, v, w)
// right-handed, so the sign of a triangle's area in (u, v) is the sign of its normal's w.
fn to_frame(p: vec3<i32>, axis: u32) -> vec3<i32> {
    switch axis {
        case 0u: { return p.yzx; }
        case 1u: { return p.zxy; }
        default: { return p; }
    }
}

fn to_frame_u(p: vec3<u32>, axis: u32) -> vec3<u32> {
    return vec3<u32>(to_frame(vec3<i32>(p), axis));
}

fn to_frame_f(p: vec3<f32>, axis: u32) -> vec3<f32> {
    switch axis {
        case 0u: { return p.yzx; }
        case 1u: { return p.zxy; }
        default: { return p; }
    }
}

fn from_frame(p: vec3<u32>, axis: u32) -> vec3<u32> {
    switch axis {
        case 0u: { return p.zxy; }
        case 1u: { return p.yzx; }
        default: { return p; }
    }
}

fn fixed_step() -> i32 {
    return 1 << mesh.fixed_bits;
}

fn window_index(v: vec3<u32>) -> u32 {
    return v.x + mesh.window_dims.x * (v.y + mesh.window_dims.y * v.z);
}

fn corner(tri: u32, k: u32) -> vec3<i32> {
    return grid_vertices[triangle_indices[3u * tri + k]].xyz;
}

@compute @workgroup_size(WG)
fn clear_scratch(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                 @builtin(local_invocation_index) local: u32) {
    let i = flat_id(group, groups, local, WG);
    if i < mesh.parity_words {
        atomicStore(&parity_words[i], 0u);
    }
    if i < mesh.band_voxels {
        atomicStore(&band_distance[i], 0u);
    }
    if i == 0u {
        atomicStore(&large_work[0], 0u);
    }
}

// Local → grid voxels by the node's matrix, then to fixed point, clamped, relative to the
// window. Rounding is to nearest even, as Rust's `round_ties_even` in the twin.
@compute @workgroup_size(WG)
fn transform_vertices(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                      @builtin(local_invocation_index) local: u32) {
    let i = flat_id(group, groups, local, WG);
    if i >= mesh.vertex_count {
        return;
    }
    let p = (mesh.grid_from_local * vec4<f32>(local_vertices[i].xyz, 1.0)).xyz;
    let fixed = round(clamp(p * f32(fixed_step()), vec3<f32>(-COORD_LIMIT), vec3<f32>(COORD_LIMIT)));
    grid_vertices[i] = vec4<i32>(vec3<i32>(fixed) - mesh.window_min * fixed_step(), 0);
}

// ---------------------------------------------------------------------------------------------
// Crossings (passes 0–2).

// A triangle seen along the rays of one axis, in that axis' frame, counter-clockwise in (u, v).
struct Crossing {
    a: vec3<i32>,
    b: vec3<i32>,
    c: vec3<i32>,
    // (b − a) × (c − a), exactly; normal_w > 0.
    normal_u: I64,
    normal_v: I64,
    normal_w: I64,
    // Columns (u, v) whose centre lies in the projected bounding box, clipped to the window.
    first: vec2<i32>,
    size: vec2<u32>,
    columns: u32,
}

fn crossing_normal(x: ptr<function, Crossing>) {
    let e1 = (*x).b - (*x).a;
    let e2 = (*x).c - (*x).a;
    (*x).normal_u = i64_sub(i64_mul(e1.y, e2.z), i64_mul(e1.z, e2.y));
    (*x).normal_v = i64_sub(i64_mul(e1.z, e2.x), i64_mul(e1.x, e2.z));
    (*x).normal_w = i64_sub(i64_mul(e1.x, e2.y), i64_mul(e1.y, e2.x));
}

fn crossing_setup(tri: u32, axis: u32) -> Crossing {
    var x: Crossing;
    x.a = to_frame(corner(tri, 0u), axis);
    x.b = to_frame(corner(tri, 1u), axis);
    x.c = to_frame(corner(tri, 2u), axis);
    crossing_normal(&x);
    let orientation = i64_sign(x.normal_w);
    if orientation == 0 {
        return x; // seen edge-on: the rays graze it, it crosses none (columns = 0)
    }
    if orientation < 0 {
        let b = x.b;
        x.b = x.c;
        x.c = b;
        crossing_normal(&x);
    }
    // Centres at j·step + step/2: the first column at or after the box's low side, the last at
    // or before its high side (>> on i32 is floor division).
    let half = fixed_step() >> 1u;
    let lo = min(min(x.a.xy, x.b.xy), x.c.xy);
    let hi = max(max(x.a.xy, x.b.xy), x.c.xy);
    let first = max(-((vec2<i32>(half) - lo) >> vec2<u32>(mesh.fixed_bits)), vec2<i32>(0));
    let last = min((hi - vec2<i32>(half)) >> vec2<u32>(mesh.fixed_bits), vec2<i32>(to_frame_u(mesh.window_dims, axis).xy) - 1);
    if all(last >= first) {
        x.first = first;
        x.size = vec2<u32>(last - first + 1);
        x.columns = x.size.x * x.size.y;
    }
    return x;
}

// Whether point q of the (u, v) plane counts as inside the half-plane left of p0 → p1. On the
// line itself, q counts as moved by (−ε, −ε²): inside if the edge runs up, or level and left.
// Exactly one of an edge and its reverse owns the points on it.
fn owns(p0: vec2<i32>, p1: vec2<i32>, q: vec2<i32>) -> bool {
    let side = i64_sign(i64_sub(i64_mul(p0.x - q.x, p1.y - q.y), i64_mul(p0.y - q.y, p1.x - q.x)));
    let d = p1 - p0;
    return side > 0 || (side == 0 && (d.y > 0 || (d.y == 0 && d.x < 0)));
}

// Whether the centre of voxel j of the column is on or past the triangle's plane:
// N·(P − a) ≥ 0, where `base` holds the column's constant part N_u·Δu + N_v·Δv.
fn past_plane(x: Crossing, base: I64, j: i32) -> bool {
    let w = j * fixed_step() + (fixed_step() >> 1u);
    return i64_sign(i64_add(base, i64_mul_i32(x.normal_w, w - x.a.z))) >= 0;
}

// Marks column c of the triangle's box if its ray crosses the triangle: the bit of the first
// voxel past the crossing (the line's last bit when no voxel of the window is past it).
fn cross_column(x: Crossing, axis: u32, c: u32) {
    let column = x.first + vec2<i32>(vec2<u32>(c % x.size.x, c / x.size.x));
    let q = column * fixed_step() + (fixed_step() >> 1u);
    if !(owns(x.a.xy, x.b.xy, q) && owns(x.b.xy, x.c.xy, q) && owns(x.c.xy, x.a.xy, q)) {
        return;
    }
    let dims = to_frame_u(mesh.window_dims, axis);
    let base = i64_add(i64_mul_i32(x.normal_u, q.x - x.a.x), i64_mul_i32(x.normal_v, q.y - x.a.y));
    // A float estimate of the crossing, then the exact test settles the voxel.
    let w_hit = f32(x.a.z) - i64_to_f32(base) / i64_to_f32(x.normal_w);
    let len = i32(dims.z);
    var k = i32(clamp(ceil((w_hit - f32(fixed_step() >> 1u)) / f32(fixed_step())), 0.0, f32(len)));
    while k > 0 && past_plane(x, base, k - 1) {
        k -= 1;
    }
    while k < len && !past_plane(x, base, k) {
        k += 1;
    }
    let word = mesh.axis_offset[axis] + (u32(column.x) + dims.x * u32(column.y)) * mesh.axis_words[axis] + u32(k) / 32u;
    atomicXor(&parity_words[word], 1u << (u32(k) % 32u));
}

// ---------------------------------------------------------------------------------------------
// The distance band (pass 3).

// A triangle in the frame of its dominant normal axis, in window voxels, and the columns
// within `reach` of its projection.
struct Band {
    a: vec3<f32>,
    b: vec3<f32>,
    c: vec3<f32>,
    normal: vec3<f32>,
    axis: u32,
    first: vec2<i32>,
    size: vec2<u32>,
    columns: u32,
    // Half the band's depth along w: reach / |normal_w|.
    half_depth: f32,
}

fn band_setup(tri: u32) -> Band {
    var band: Band;
    let scale = 1.0 / f32(fixed_step());
    let a = vec3<f32>(corner(tri, 0u)) * scale;
    let b = vec3<f32>(corner(tri, 1u)) * scale;
    let c = vec3<f32>(corner(tri, 2u)) * scale;
    let n = cross(b - a, c - a);
    let area2 = length(n);
    if area2 == 0.0 {
        return band;
    }
    let m = abs(n);
    band.axis = select(select(2u, 1u, m.y >= m.z), 0u, m.x >= m.y && m.x >= m.z);
    band.a = to_frame_f(a, band.axis);
    band.b = to_frame_f(b, band.axis);
    band.c = to_frame_f(c, band.axis);
    band.normal = to_frame_f(n / area2, band.axis);
    let r = mesh.reach;
    let lo = min(min(band.a.xy, band.b.xy), band.c.xy) - r;
    let hi = max(max(band.a.xy, band.b.xy), band.c.xy) + r;
    let first = max(vec2<i32>(ceil(lo - 0.5)), vec2<i32>(0));
    let last = min(vec2<i32>(floor(hi - 0.5)), vec2<i32>(to_frame_u(mesh.window_dims, band.axis).xy) - 1);
    if all(last >= first) {
        band.first = first;
        band.size = vec2<u32>(last - first + 1);
        band.columns = band.size.x * band.size.y;
        band.half_depth = r / abs(band.normal.z);
    }
    return band;
}

// Distance from p to the triangle abc (Ericson, "Real-Time Collision Detection", §5.1.5: the
// closest point by Voronoi regions of the vertices, edges and face).
fn triangle_distance(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> f32 {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return length(ap);
    }
    let bp = p - b;
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return length(bp);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return length(ap - ab * (d1 / (d1 - d3)));
    }
    let cp = p - c;
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return length(cp);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return length(ap - ac * (d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return length(bp - (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
    }
    let denom = 1.0 / (va + vb + vc);
    return length(ap - ab * (vb * denom) - ac * (vc * denom));
}

// The voxels of column c within reach of the triangle's plane: their exact distance to it.
fn band_column(band: Band, c: u32) {
    let column = band.first + vec2<i32>(vec2<u32>(c % band.size.x, c / band.size.x));
    let centre = vec2<f32>(column) + 0.5;
    let w_plane = band.a.z - dot(band.normal.xy, centre - band.a.xy) / band.normal.z;
    let depth = i32(to_frame_u(mesh.window_dims, band.axis).z);
    let j0 = max(i32(ceil(w_plane - band.half_depth - 0.5 - BAND_SLACK)), 0);
    let j1 = min(i32(floor(w_plane + band.half_depth - 0.5 + BAND_SLACK)), depth - 1);
    for (var j = j0; j <= j1; j++) {
        let d = triangle_distance(vec3<f32>(centre, f32(j) + 0.5), band.a, band.b, band.c);
        if d < mesh.reach {
            let voxel = from_frame(vec3<u32>(vec2<u32>(column), u32(j)), band.axis);
            atomicMax(&band_distance[window_index(voxel)], ~bitcast<u32>(d));
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Rasterization: small triangles here, large ones listed for rasterize_large.

@compute @workgroup_size(WG)
fn rasterize(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
             @builtin(local_invocation_index) local: u32) {
    let tri = flat_id(group, groups, local, WG);
    let pass_ = group.y;
    if tri >= mesh.triangle_count {
        return;
    }
    if pass_ == BAND_PASS {
        let band = band_setup(tri);
        if band.columns > SMALL_BAND_COLUMNS {
            list_large(tri, pass_);
            return;
        }
        for (var c = 0u; c < band.columns; c++) {
            band_column(band, c);
        }
    } else {
        let x = crossing_setup(tri, pass_);
        if x.columns > SMALL_CROSSING_COLUMNS {
            list_large(tri, pass_);
            return;
        }
        for (var c = 0u; c < x.columns; c++) {
            cross_column(x, pass_, c);
        }
    }
}

// Each (triangle, pass) is listed at most once, so the list holds at most 4 per triangle.
fn list_large(tri: u32, pass_: u32) {
    let slot = atomicAdd(&large_work[0], 1u);
    atomicStore(&large_work[1u + slot], (tri << 2u) | pass_);
}

// Each workgroup takes listed (triangle, pass) items in turn and shares out their columns.
@compute @workgroup_size(LARGE_WG)
fn rasterize_large(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                   @builtin(local_invocation_index) local: u32) {
    let count = atomicLoad(&large_work[0]);
    for (var i = group.x; i < count; i += groups.x) {
        let item = atomicLoad(&large_work[1u + i]);
        let tri = item >> 2u;
        let pass_ = item & 3u;
        if pass_ == BAND_PASS {
            let band = band_setup(tri);
            for (var c = local; c < band.columns; c += LARGE_WG) {
                band_column(band, c);
            }
        } else {
            let x = crossing_setup(tri, pass_);
            for (var c = local; c < x.columns; c += LARGE_WG) {
                cross_column(x, pass_, c);
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Parity and the signed distance.

// After this, bit j of a column is the parity of the crossings before voxel j's centre, and
// the bit after the last voxel the parity of the whole line.
@compute @workgroup_size(WG)
fn prefix_parity(@builtin(workgroup_id) group: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
                 @builtin(local_invocation_index) local: u32) {
    let column = flat_id(group, groups, local, WG);
    let axis = group.y;
    let dims = to_frame_u(mesh.window_dims, axis);
    if column >= dims.x * dims.y {
        return;
    }
    let base = mesh.axis_offset[axis] + column * mesh.axis_words[axis];
    var carry = 0u;
    for (var k = 0u; k < mesh.axis_words[axis]; k++) {
        // Inclusive prefix XOR within the word, then the parity carried from the words before.
        var x = atomicLoad(&parity_words[base + k]);
        x ^= x << 1u;
        x ^= x << 2u;
        x ^= x << 4u;
        x ^= x << 8u;
        x ^= x << 16u;
        x ^= carry;
        atomicStore(&parity_words[base + k], x);
        carry = 0u - (x >> 31u);
    }
}

fn parity_bit(base: u32, bit: u32) -> u32 {
    return (atomicLoad(&parity_words[base + bit / 32u]) >> (bit % 32u)) & 1u;
}

@compute @workgroup_size(4, 4, 4)
fn signed_distance(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id >= mesh.window_dims) {
        return;
    }
    // Each axis whose line crosses the surface an even number of times votes; a line with an
    // odd count passes through a hole and says nothing. Inside takes a majority of the votes
    // cast, so where every line passes through holes the voxel is outside: holes never flood.
    var votes = 0;
    for (var axis = 0u; axis < 3u; axis++) {
        let p = to_frame_u(id, axis);
        let dims = to_frame_u(mesh.window_dims, axis);
        let base = mesh.axis_offset[axis] + (p.x + dims.x * p.y) * mesh.axis_words[axis];
        if parity_bit(base, dims.z) == 0u {
            votes += select(-1, 1, parity_bit(base, p.z) == 1u);
        }
    }
    let inside = votes > 0;
    let i = window_index(id);
    let code = atomicLoad(&band_distance[i]);
    let d = select(FAR, bitcast<f32>(~code), code != 0u);
    atlas[mesh.atlas_offset + i] = select(d, -d, inside);
}
