// Opaque receivers and their caustic charts (see ReceiverGpu and Chart in types.wgsl; the charts
// are laid out by src/pipeline/receivers.rs).
//
// Expects the stage to declare `receivers: array<ReceiverGpu>` and `charts: array<Chart>`
// (storage, read), and what shared/texture.wgsl needs.

#import shared/texture.wgsl

// The chart of `receiver` for the side of a surface that faces `facing`; `back` when that side
// is the back of the triangle (see ReceiverGpu). −1 if it has none.
fn chart_for(receiver: u32, facing: vec3<f32>, back: bool) -> i32 {
    let a = abs(facing);
    let axis = select(select(2u, 1u, a.y >= a.z), 0u, a.x >= a.y && a.x >= a.z);
    let slot = 2u * axis + select(1u, 0u, facing[axis] > 0.0) + select(0u, 6u, back);
    let r = receivers[receiver];
    if slot < 4u {
        return r.charts_a[slot];
    }
    if slot < 8u {
        return r.charts_b[slot - 4u];
    }
    return r.charts_c[slot - 8u];
}

// Continuous texel coordinates of world point p in a chart (texel (i, j) spans [i, i+1)).
fn chart_coords(chart: Chart, p: vec3<f32>) -> vec2<f32> {
    let axis = chart.axis / 2u;
    return (vec2<f32>(p[(axis + 1u) % 3u], p[(axis + 2u) % 3u]) - chart.origin) / chart.texel;
}

// Base colour (rgb) and alpha at a hit: the factors times the base colour texture.
fn base_color_at(r: ReceiverGpu, uv: vec2<f32>) -> vec4<f32> {
    if !has_texture(r.base_texture) {
        return vec4<f32>(r.albedo, r.alpha);
    }
    let t = texture_at(r.base_texture, uv);
    return vec4<f32>(r.albedo * t.rgb, r.alpha * t.a);
}
