// Glowing meshes (`LIGHT_MESH`, src/pipeline/mesh_lights.rs): points spread uniformly over an
// emissive receiver's surface, for the view's shadow rays and the photons stage.
//
// Needs shared/types.wgsl and a `light_triangles: array<LightTriangle>` binding.

struct LightPoint {
    p: vec3<f32>,
    // The triangle's geometric normal (the side its cross product points to).
    n: vec3<f32>,
    // What the point's light weighs against the light's mean radiance drawn uniformly over its
    // area (`LightTriangle.scale`): 1 on a glow of one radiance and on area lights.
    scale: vec3<f32>,
}

// Point u ∈ [0,1)² of light l's surface: u.x picks a triangle by its share (the first whose
// running share exceeds it) and, rescaled within that share, with u.y a point in it by the
// square-to-triangle map √ (pbrt-v4's SampleUniformTriangle). The shares are of the area — equal
// areas of u are equal areas of the surface — or, on a patterned glow, of the power of its
// pieces, which `scale` then makes up for.
fn mesh_light_point(l: LightGpu, u: vec2<f32>) -> LightPoint {
    var lo = l.first_triangle;
    var hi = l.first_triangle + l.triangle_count - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if light_triangles[mid].cdf > u.x {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    let t = light_triangles[lo];
    let before = select(0.0, light_triangles[max(lo, 1u) - 1u].cdf, lo > l.first_triangle);
    let s = clamp((u.x - before) / max(t.cdf - before, 1e-30), 0.0, 1.0);
    let r = sqrt(s);
    let p = t.v0 + t.e1 * (r * (1.0 - u.y)) + t.e2 * (r * u.y);
    return LightPoint(p, normalize(cross(t.e1, t.e2)), t.scale);
}

// Point u of a side of light l's surface that glows: for a two-sided mesh both sides in equal
// halves of u (its emitter's measure twice its area), u.x < ½ the front (n as the triangle's),
// else the back (n reversed); for a closed one its outer side (its triangles wound outward).
fn mesh_light_side_point(l: LightGpu, u: vec2<f32>) -> LightPoint {
    let two_sided = l.sides != 1u;
    let q = mesh_light_point(l, select(u, vec2<f32>(fract(2.0 * u.x), u.y), two_sided));
    return LightPoint(q.p, select(q.n, -q.n, two_sided && u.x >= 0.5), q.scale);
}

// The cosine a side of light l that glows shows toward w (unit, from the point along n): |cos|
// for a two-sided mesh, the outer side's alone for a closed one.
fn mesh_light_cos(l: LightGpu, n: vec3<f32>, w: vec3<f32>) -> f32 {
    let c = dot(n, w);
    return select(abs(c), max(c, 0.0), l.sides == 1u);
}
