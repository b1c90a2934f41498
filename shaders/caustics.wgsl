// Stage 5b, caustics: the receivers' caustic maps, from raw photon deposits to irradiance.
//
// The seed blurred caustics with one fixed Gaussian: too wide where photons are dense (blurry
// focus), too narrow where they are sparse (noise). Here each texel's footprint adapts to the
// photon density, as k-nearest-neighbour density estimation does: the smallest square of
// half-size r ∈ {0, 1, 2, 4, …} texels holding at least `target_count` photons, blended with the
// next smaller square by how far its count falls short, so the footprint varies smoothly.
//
// The footprint belongs to the texel whose deposits are spread, not to the texel that gathers:
// each texel's flux is spread evenly over its own square(s), so the map holds exactly the flux
// the photons brought. (Gathering with the gathering texel's footprint does not: a sparse texel
// beside a bright caustic reaches into it with a wide square and counts its photons a second
// time — 3.5 % too much light around the glass bunny's caustic against Mitsuba 3, 7.5 % with flat
// normals.) Spreading is done per footprint size ("level"): a layer holds each texel's deposits
// times its weight at that level, and a box filter of that level's size over the layer — a box
// is symmetric, so gathering box sums is scattering over boxes — adds the level's share.
//
// The wide levels (half-size 8 to 64) are spread on the chart coarsened r/4 times in each axis:
// a cell sums its texels' shares, spreads them over the 9 × 9 cells around it, and each cell
// hands what it received evenly to its texels. Energy stays exact; the square becomes 9 cells of
// r/4 texels wide (2r + r/4 texels instead of 2r + 1), aligned to the cells — in the sparse light
// these levels serve, where a photon's square is noise-sized anyway — and the tables of the wide
// levels shrink to 1/4, 1/16, … of the chart.
//
// Box sums come from summed-area tables kept in wrapping u32 arithmetic — exact while every box
// sum is below 2³², as modular differences of the table then give it back. A frame's deposits
// share 2³¹ units with 16× headroom (march.rs), and a level's layer holds at most its share of
// them, times up to 4 where the chart's border cuts a square (those texels spread their flux
// over the part that remains): far below 2³² unless nearly all light lands on a border.
//
// A chart no photon reached (the underside of a floor, a wall facing away from the lights) has
// nothing to spread: `choose_footprints` counts each chart's photons into `chart_photons`, and
// the levels skip the charts without any (their irradiance stays the zero it cleared).
//
// Entry points, in order: `load_deposits`, `sat_rows`, `sat_columns` (the table of the raw
// deposits), `choose_footprints`; for the adaptive filter `gather_direct_levels` (its three
// smallest levels at once); then per remaining level (group 1: `level`) `spread_level` (or
// `spread_wide_level` for cells of 8 × 8 texels and more: caustics.rs, WIDE_COARSENING), `sat_rows`
// and `sat_columns` (only for squares wider than `direct_radius`: a 5 × 5 square is cheaper to
// read than to tabulate), `gather_level`. Per-texel kernels run 8×8 per chart (z: the chart);
// the scans take one workgroup per row/column of each chart.

#import shared/types.wgsl
#import shared/spectrum.wgsl

@group(0) @binding(0) var<uniform> params: CausticParams;
@group(0) @binding(1) var<storage, read> charts: array<Chart>;
// 4 words per texel: photon count, flux r, g, b (fixed point), as the march stage left them.
@group(0) @binding(2) var<storage, read> caustic_atlas: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read_write> sat: array<vec4<u32>>;
// Irradiance (W/m², rgb) and the photon count of the texel's footprint.
@group(0) @binding(4) var<storage, read_write> caustic_irradiance: array<vec4<f32>>;
// What the scans sum: the raw deposits, then one level's weighted deposits.
@group(0) @binding(5) var<storage, read_write> layer: array<vec4<u32>>;
// Each texel's footprint: level `lo` with weight 1 − blend and level lo + 1 with weight blend.
@group(0) @binding(6) var<storage, read_write> footprint: array<vec2<f32>>;
// Photons on each chart (the table of the raw deposits' total), written by choose_footprints.
@group(0) @binding(7) var<storage, read_write> chart_photons: array<u32>;
@group(1) @binding(0) var<uniform> level: CausticLevel;

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

// The value a scan adds up at texel t: the layer for rows, row sums for columns.
fn scan_input(rows: bool, t: u32) -> vec4<u32> {
    if rows {
        return layer[t];
    }
    return sat[t];
}

// A chart's size at the current level's coarsening (cells; the texels at coarsening 1). The
// cells of a level are stored where the chart's texels are, cell (i, j) at texel (i, j).
fn cells(chart: Chart) -> vec2<u32> {
    return (vec2<u32>(chart.width, chart.height) + level.coarsening - 1u) / level.coarsening;
}

fn scan_line(chart: Chart, rows: bool, line: u32, lid: u32) {
    let size = cells(chart);
    let length = select(size.y, size.x, rows);
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

// Whether this level skips chart c: one no photon reached. (The table of the raw deposits —
// the level of half-size 0 — is what counts them, so it never skips.)
fn skips(c: u32) -> bool {
    return level.radius > 0u && chart_photons[c] == 0u;
}

// (Each workgroup's line is uniform across it: all its threads return, or none, so the
// barriers in scan_line are reached by all.)
@compute @workgroup_size(256)
fn sat_rows(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let chart = charts[group.y];
    if group.x >= cells(chart).y || skips(group.y) {
        return;
    }
    scan_line(chart, true, group.x, lid);
}

@compute @workgroup_size(256)
fn sat_columns(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let chart = charts[group.y];
    if group.x >= cells(chart).x || skips(group.y) {
        return;
    }
    scan_line(chart, false, group.x, lid);
}

// The square of half-size r around t, clamped to a grid of `size`: (lo, hi), inclusive.
fn square_in(size: vec2<u32>, t: vec2<i32>, r: i32) -> array<vec2<i32>, 2> {
    return array<vec2<i32>, 2>(max(t - r, vec2<i32>(0)), min(t + r, vec2<i32>(size) - 1));
}

// The same on the chart's texels.
fn square(chart: Chart, t: vec2<i32>, r: i32) -> array<vec2<i32>, 2> {
    return square_in(vec2<u32>(chart.width, chart.height), t, r);
}

fn texels_in(s: array<vec2<i32>, 2>) -> f32 {
    return f32((s[1].x - s[0].x + 1) * (s[1].y - s[0].y + 1));
}

// Sum over the texels of square s from the summed-area table.
fn box_sum(chart: Chart, s: array<vec2<i32>, 2>) -> vec4<u32> {
    let a = s[0] - 1;
    let b = s[1];
    var sum = sat[chart.offset + u32(b.x) + chart.width * u32(b.y)];
    if a.x >= 0 {
        sum -= sat[chart.offset + u32(a.x) + chart.width * u32(b.y)];
    }
    if a.y >= 0 {
        sum -= sat[chart.offset + u32(b.x) + chart.width * u32(a.y)];
    }
    if a.x >= 0 && a.y >= 0 {
        sum += sat[chart.offset + u32(a.x) + chart.width * u32(a.y)];
    }
    return sum;
}

// Photons in the square of half-size r around t (from the table of the raw deposits).
fn photons_within(chart: Chart, t: vec2<i32>, r: i32) -> f32 {
    return f32(box_sum(chart, square(chart, t, r)).x);
}

// The chart, texel and atlas index of a per-texel thread; the chart index is u32 max when the
// thread has no texel.
struct Texel {
    chart: Chart,
    t: vec2<i32>,
    index: u32,
}

fn texel_of(id: vec3<u32>) -> Texel {
    var out: Texel;
    out.index = 0xffffffffu;
    if id.z >= params.chart_count {
        return out;
    }
    out.chart = charts[id.z];
    if id.x < out.chart.width && id.y < out.chart.height {
        out.t = vec2<i32>(id.xy);
        out.index = out.chart.offset + id.x + out.chart.width * id.y;
    }
    return out;
}

@compute @workgroup_size(8, 8, 1)
fn load_deposits(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = texel_of(id);
    if x.index != 0xffffffffu {
        layer[x.index] = caustic_atlas[x.index];
    }
}

// The radius of level k in the adaptive list {0, 1, 2, 4, …} (caustics.rs: `level_radii`).
fn adaptive_radius(k: u32) -> i32 {
    return i32((1u << k) >> 1u);
}

// Each texel's footprint from the photon counts around it, as k nearest neighbours: the
// smallest square holding `target_count` photons, blended toward the next smaller one by how
// close that came; the largest when none does. Clears the irradiance it will add up into.
@compute @workgroup_size(8, 8, 1)
fn choose_footprints(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = texel_of(id);
    if x.index == 0xffffffffu {
        return;
    }
    if all(x.t == vec2<i32>(0)) {
        let whole = array<vec2<i32>, 2>(vec2<i32>(0), vec2<i32>(i32(x.chart.width), i32(x.chart.height)) - 1);
        chart_photons[id.z] = box_sum(x.chart, whole).x;
    }
    if params.fixed_radius > 0u {
        footprint[x.index] = vec2<f32>(0.0, 0.0);
        caustic_irradiance[x.index] = vec4<f32>(0.0, 0.0, 0.0, photons_within(x.chart, x.t, i32(params.fixed_radius)));
        return;
    }
    let target_count = f32(params.target_count);
    var lo = 0u;
    var blend = 0.0;
    var previous = photons_within(x.chart, x.t, 0);
    var count = previous;
    var k = 1u;
    while previous < target_count && adaptive_radius(k) <= i32(params.max_radius) {
        let next = photons_within(x.chart, x.t, adaptive_radius(k));
        if next >= target_count {
            blend = (target_count - previous) / max(next - previous, 1.0);
            lo = k - 1u;
            count = mix(previous, next, blend);
        } else {
            lo = k;
            count = next;
        }
        previous = next;
        k++;
    }
    footprint[x.index] = vec2<f32>(f32(lo), blend);
    caustic_irradiance[x.index] = vec4<f32>(0.0, 0.0, 0.0, count);
}

// A texel's share at this level: its flux times its weight here (fixed point).
fn share(index: u32) -> vec3<f32> {
    let f = footprint[index];
    let lo = u32(f.x);
    var weight = 0.0;
    if level.index == lo {
        weight = 1.0 - f.y;
    } else if level.index == lo + 1u {
        weight = f.y;
    }
    return vec3<f32>(caustic_atlas[index].yzw) * weight;
}

// Writes cell c's layer value: the shares of its texels, `sum`, times the part of its square the
// chart's border cuts off (so the part that remains carries all of it).
fn write_cell(chart: Chart, c: vec2<u32>, sum: vec3<f32>) {
    let r = i32(level.reach);
    let whole = f32((2 * r + 1) * (2 * r + 1));
    let scale = whole / texels_in(square_in(cells(chart), vec2<i32>(c), r));
    // Round to nearest: unbiased over the many texels a caustic covers.
    layer[chart.offset + c.x + chart.width * c.y] = vec4<u32>(0u, vec3<u32>(sum * scale + 0.5));
}

// The texels of cell c (first, one past the last).
fn cell_texels(chart: Chart, c: vec2<u32>) -> array<vec2<u32>, 2> {
    let first = c * level.coarsening;
    return array<vec2<u32>, 2>(first, min(first + level.coarsening, vec2<u32>(chart.width, chart.height)));
}

// The layer of this level, one thread per cell (levels of up to 4 × 4 texels a cell).
@compute @workgroup_size(8, 8, 1)
fn spread_level(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.z >= params.chart_count || chart_photons[id.z] == 0u {
        return;
    }
    let chart = charts[id.z];
    if any(id.xy >= cells(chart)) {
        return;
    }
    let span = cell_texels(chart, id.xy);
    var sum = vec3<f32>(0.0);
    for (var j = span[0].y; j < span[1].y; j++) {
        for (var i = span[0].x; i < span[1].x; i++) {
            sum += share(chart.offset + i + chart.width * j);
        }
    }
    write_cell(chart, id.xy, sum);
}

// The layer of a wide level (cells of 8 × 8 texels and more), one workgroup per cell: each
// thread sums every CELL_THREADS-th texel, then a tree in workgroup memory adds the threads'
// sums. (One thread summing a 16 × 16 cell alone waited on 256 loads in a row: the slowest
// dispatch of the stage.)
const CELL_THREADS: u32 = 64u;
var<workgroup> cell_sums: array<vec3<f32>, CELL_THREADS>;

@compute @workgroup_size(64)
fn spread_wide_level(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    // (Uniform across the workgroup: all its threads return, or none reach the barriers.)
    if group.z >= params.chart_count || skips(group.z) {
        return;
    }
    let chart = charts[group.z];
    if any(group.xy >= cells(chart)) {
        return;
    }
    let span = cell_texels(chart, group.xy);
    let size = span[1] - span[0];
    var sum = vec3<f32>(0.0);
    for (var i = lid; i < size.x * size.y; i += CELL_THREADS) {
        let t = span[0] + vec2<u32>(i % size.x, i / size.x);
        sum += share(chart.offset + t.x + chart.width * t.y);
    }
    cell_sums[lid] = sum;
    workgroupBarrier();
    for (var half = CELL_THREADS / 2u; half > 0u; half /= 2u) {
        if lid < half {
            cell_sums[lid] += cell_sums[lid + half];
        }
        workgroupBarrier();
    }
    if lid == 0u {
        write_cell(chart, group.xy, cell_sums[0]);
    }
}

// Adds to texel x's irradiance the flux (fixed-point units) that landed on `texels` texels
// around it, spread evenly: W/m² over their area.
fn add_irradiance(x: Texel, flux: vec3<f32>, texels: f32) {
    var e = flux * params.flux_unit / (texels * x.chart.texel * x.chart.texel);
    if params.spectral != 0u {
        // Spectral photons deposited XYZ (shared/spectrum.wgsl).
        e = xyz_to_rgb(e);
    }
    caustic_irradiance[x.index] += vec4<f32>(e, 0.0);
}

// The adaptive filter's three smallest levels (half-sizes 0, 1 and 2: squares of up to 5 × 5
// texels) in one pass, without their layers: each texel adds, from each of the 5 × 5 texels
// around it, that texel's share at every one of these levels whose square covers it — the
// share spread evenly over the part of its square inside the chart, as `spread_level` and
// `gather_level` would (six dispatches, each over the whole chart, became one).
const DIRECT_LEVELS: u32 = 3u;

@compute @workgroup_size(8, 8, 1)
fn gather_direct_levels(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = texel_of(id);
    if x.index == 0xffffffffu || chart_photons[id.z] == 0u {
        return;
    }
    let near = square(x.chart, x.t, adaptive_radius(DIRECT_LEVELS - 1u));
    var flux = vec3<f32>(0.0);
    for (var j = near[0].y; j <= near[1].y; j++) {
        for (var i = near[0].x; i <= near[1].x; i++) {
            let s = vec2<i32>(i, j);
            let index = x.chart.offset + u32(i) + x.chart.width * u32(j);
            let f = footprint[index];
            let lo = u32(f.x);
            let d = abs(s - x.t);
            let distance = max(d.x, d.y);
            // (This texel's weight at levels lo and lo + 1, each over its clipped square.)
            var part = 0.0;
            for (var k = lo; k < min(lo + 2u, DIRECT_LEVELS); k++) {
                let r = adaptive_radius(k);
                if distance <= r {
                    let weight = select(f.y, 1.0 - f.y, k == lo);
                    part += weight / texels_in(square(x.chart, s, r));
                }
            }
            if part > 0.0 {
                flux += vec3<f32>(caustic_atlas[index].yzw) * part;
            }
        }
    }
    add_irradiance(x, flux, 1.0);
}

// The layer's sum over square s: read texel by texel for the small squares, whose levels build
// no summed-area table (`CausticParams.direct_radius`), else from the table.
fn level_sum(chart: Chart, s: array<vec2<i32>, 2>) -> vec4<u32> {
    if level.reach > params.direct_radius {
        return box_sum(chart, s);
    }
    var sum = vec4<u32>(0u);
    for (var j = s[0].y; j <= s[1].y; j++) {
        for (var i = s[0].x; i <= s[1].x; i++) {
            sum += layer[chart.offset + u32(i) + chart.width * u32(j)];
        }
    }
    return sum;
}

// Adds this level's share: the flux spread onto t's cell by every cell within `reach` of it,
// each spread evenly over (2·reach + 1)² cells, and by the cell evenly over its texels.
@compute @workgroup_size(8, 8, 1)
fn gather_level(@builtin(global_invocation_id) id: vec3<u32>) {
    let x = texel_of(id);
    if x.index == 0xffffffffu || chart_photons[id.z] == 0u {
        return;
    }
    let k = i32(level.coarsening);
    let cell = x.t / k;
    let r = i32(level.reach);
    let flux = vec3<f32>(level_sum(x.chart, square_in(cells(x.chart), cell, r)).yzw);
    let first = cell * k;
    let last = min(first + k, vec2<i32>(i32(x.chart.width), i32(x.chart.height)));
    let texels_of_cell = f32((last.x - first.x) * (last.y - first.y));
    add_irradiance(x, flux, f32((2 * r + 1) * (2 * r + 1)) * texels_of_cell);
}
