// Stage 5b, caustics: the receivers' caustic maps, from raw photon deposits to irradiance.
//
// The seed blurred caustics with one fixed Gaussian: too wide where photons are dense (blurry
// focus), too narrow where they are sparse (noise). Here each texel's footprint adapts to the
// photon density, as k-nearest-neighbour density estimation does: the smallest square of
// half-size r ∈ {0, 1, 2, 4, …} texels holding at least `target_count` photons, blended with the
// next smaller square by how far its count falls short, so the footprint varies smoothly.
// Box sums come from summed-area tables kept in wrapping u32 arithmetic — exact, because every
// box sum is itself below 2³² (deposits saturate at 2³¹ per texel) and modular differences of
// the table give it back.
//
// Entry points, in order: `sat_rows`, `sat_columns` (one workgroup per row/column of each
// chart), `filter_charts` (one thread per texel).

#import shared/types.wgsl
#import shared/spectrum.wgsl

@group(0) @binding(0) var<uniform> params: CausticParams;
@group(0) @binding(1) var<storage, read> charts: array<Chart>;
// 4 words per texel: photon count, flux r, g, b (fixed point), as the march stage left them.
@group(0) @binding(2) var<storage, read> caustic_atlas: array<u32>;
@group(0) @binding(3) var<storage, read_write> sat: array<vec4<u32>>;
// Irradiance (W/m², rgb) and the photon count of the footprint used.
@group(0) @binding(4) var<storage, read_write> caustic_irradiance: array<vec4<f32>>;

// One workgroup scans one row (or column) of one chart: each thread sums a contiguous run of
// texels, the workgroup scans the 256 run totals (Hillis–Steele, in workgroup memory), and each
// thread rewrites its run with the totals before it. Wrapping u32 sums, so the order of
// additions does not matter.
const SCAN_THREADS: u32 = 256u;
var<workgroup> runs: array<vec4<u32>, 256>;

// Texel index of element k of line `line` (a row when `rows`, else a column) of a chart.
fn line_texel(chart: Chart, rows: bool, line: u32, k: u32) -> u32 {
    if rows {
        return chart.offset + k + chart.width * line;
    }
    return chart.offset + line + chart.width * k;
}

// The value a scan adds up at texel t: raw deposits for rows, row sums for columns.
fn scan_input(rows: bool, t: u32) -> vec4<u32> {
    if rows {
        return vec4<u32>(caustic_atlas[4u * t], caustic_atlas[4u * t + 1u], caustic_atlas[4u * t + 2u], caustic_atlas[4u * t + 3u]);
    }
    return sat[t];
}

fn scan_line(chart: Chart, rows: bool, line: u32, lid: u32) {
    let length = select(chart.height, chart.width, rows);
    let per = (length + SCAN_THREADS - 1u) / SCAN_THREADS;
    let first = lid * per;
    let last = min(first + per, length);
    var sum = vec4<u32>(0u);
    for (var k = first; k < last; k++) {
        sum += scan_input(rows, line_texel(chart, rows, line, k));
    }
    runs[lid] = sum;
    workgroupBarrier();
    for (var offset = 1u; offset < SCAN_THREADS; offset *= 2u) {
        let before = select(vec4<u32>(0u), runs[lid - offset], lid >= offset);
        workgroupBarrier();
        runs[lid] += before;
        workgroupBarrier();
    }
    var running = select(vec4<u32>(0u), runs[lid - 1u], lid > 0u);
    for (var k = first; k < last; k++) {
        let t = line_texel(chart, rows, line, k);
        running += scan_input(rows, t);
        sat[t] = running;
    }
}

// (Each workgroup's line is uniform across it: all its threads return, or none, so the
// barriers in scan_line are reached by all.)
@compute @workgroup_size(256)
fn sat_rows(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let chart = charts[group.y];
    if group.x >= chart.height {
        return;
    }
    scan_line(chart, true, group.x, lid);
}

@compute @workgroup_size(256)
fn sat_columns(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let chart = charts[group.y];
    if group.x >= chart.width {
        return;
    }
    scan_line(chart, false, group.x, lid);
}

// Sum over texels [lo, hi] (inclusive, clamped to the chart) from the summed-area table.
fn box_sum(chart: Chart, lo: vec2<i32>, hi: vec2<i32>) -> vec4<u32> {
    let size = vec2<i32>(i32(chart.width), i32(chart.height));
    let a = clamp(lo, vec2<i32>(0), size - 1) - 1;
    let b = clamp(hi, vec2<i32>(0), size - 1);
    var s = sat[chart.offset + u32(b.x) + chart.width * u32(b.y)];
    if a.x >= 0 {
        s -= sat[chart.offset + u32(a.x) + chart.width * u32(b.y)];
    }
    if a.y >= 0 {
        s -= sat[chart.offset + u32(b.x) + chart.width * u32(a.y)];
    }
    if a.x >= 0 && a.y >= 0 {
        s += sat[chart.offset + u32(a.x) + chart.width * u32(a.y)];
    }
    return s;
}

// Mean irradiance over the square of half-size r around t, and its photon count.
fn box_irradiance(chart: Chart, t: vec2<i32>, r: i32) -> vec4<f32> {
    let size = vec2<i32>(i32(chart.width), i32(chart.height));
    let lo = max(t - r, vec2<i32>(0));
    let hi = min(t + r, size - 1);
    let texels = f32((hi.x - lo.x + 1) * (hi.y - lo.y + 1));
    let s = box_sum(chart, lo, hi);
    let flux = vec3<f32>(s.yzw) * params.flux_unit;
    return vec4<f32>(flux / (texels * chart.texel * chart.texel), f32(s.x));
}

@compute @workgroup_size(8, 8, 1)
fn filter_charts(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.z >= params.chart_count {
        return;
    }
    let chart = charts[id.z];
    if id.x >= chart.width || id.y >= chart.height {
        return;
    }
    let t = vec2<i32>(id.xy);
    var result: vec4<f32>;
    if params.fixed_radius > 0u {
        result = box_irradiance(chart, t, i32(params.fixed_radius));
    } else {
        let target_count = f32(params.target_count);
        var previous = box_irradiance(chart, t, 0);
        result = previous;
        var r = 1;
        while previous.w < target_count && r <= i32(params.max_radius) {
            let next = box_irradiance(chart, t, r);
            if next.w >= target_count {
                // Blend toward the smaller footprint by how close its count came to the target.
                let blend = (target_count - previous.w) / max(next.w - previous.w, 1.0);
                result = mix(previous, next, blend);
            } else {
                result = next;
            }
            previous = next;
            r *= 2;
        }
    }
    if params.spectral != 0u {
        // Spectral photons deposited XYZ (shared/spectrum.wgsl).
        result = vec4<f32>(xyz_to_rgb(result.rgb), result.w);
    }
    caustic_irradiance[chart.offset + id.x + chart.width * id.y] = result;
}
