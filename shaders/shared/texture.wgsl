// Textures on surfaces, receivers' and glass meshes' alike: each is (first texel, width,
// height, encoding | wrap bits) in `albedo_texels`, 8-bit RGBA (colour sRGB-encoded or linear,
// alpha linear), looked up bilinearly with the sampler's wrap modes at a BVH hit's interpolated
// UVs. The CPU twins are Texture2d::sample and Wrap (src/scene/material.rs).
//
// Expects the stage to declare `albedo_texels: array<u32>` and `triangle_uvs: array<vec4<f32>>`
// (three vec4 per BVH triangle: (uv₀, uv₁), (uv₂, –), (tangent, sign)), and to import types.

// The inverse sRGB transfer function (IEC 61966-2-1): colour texels are stored encoded.
fn srgb_decode(c: vec3<f32>) -> vec3<f32> {
    return select(pow((c + 0.055) / 1.055, vec3<f32>(2.4)), c / 12.92, c <= vec3<f32>(0.04045));
}

fn has_texture(t: vec4<u32>) -> bool {
    return t.y != 0u;
}

// The wrap modes (u, v) of texture t.
fn texture_wrap(t: vec4<u32>) -> vec2<u32> {
    return vec2<u32>((t.w >> 8u) & 3u, (t.w >> 10u) & 3u);
}

// A texture coordinate brought into [0, 1]: repeated, clamped, or mirrored in odd tiles (glTF's
// REPEAT, CLAMP_TO_EDGE, MIRRORED_REPEAT) — the twin of Wrap::coordinate.
fn wrap_coordinate(x: f32, mode: u32) -> f32 {
    if mode == WRAP_CLAMP {
        return clamp(x, 0.0, 1.0);
    }
    let f = x - floor(x);
    if mode == WRAP_MIRROR && (i32(floor(x)) & 1) != 0 {
        return 1.0 - f;
    }
    return f;
}

// Texel i of a row of n, a bilinear footprint reaching one past either edge — Wrap::texel.
fn wrap_texel(i: i32, n: i32, mode: u32) -> i32 {
    if mode == WRAP_CLAMP {
        return clamp(i, 0, n - 1);
    }
    if mode == WRAP_MIRROR {
        let m = ((i % (2 * n)) + 2 * n) % (2 * n);
        return select(2 * n - 1 - m, m, m < n);
    }
    return ((i % n) + n) % n;
}

fn texel_of(t: vec4<u32>, x: i32, y: i32) -> vec4<f32> {
    let size = vec2<i32>(i32(t.y), i32(t.z));
    let wrap = texture_wrap(t);
    let c = vec2<i32>(wrap_texel(x, size.x, wrap.x), wrap_texel(y, size.y, wrap.y));
    let v = unpack4x8unorm(albedo_texels[t.x + u32(c.x + size.x * c.y)]);
    if (t.w & 0xffu) == TEXEL_SRGB {
        return vec4<f32>(srgb_decode(v.rgb), v.a);
    }
    return v;
}

// Bilinear lookup with the texture's wrap modes — the twin of Texture2d::sample.
fn texture_at(t: vec4<u32>, uv: vec2<f32>) -> vec4<f32> {
    let wrap = texture_wrap(t);
    let inside = vec2<f32>(wrap_coordinate(uv.x, wrap.x), wrap_coordinate(uv.y, wrap.y));
    let f = inside * vec2<f32>(f32(t.y), f32(t.z)) - 0.5;
    let i = vec2<i32>(floor(f));
    let w = f - floor(f);
    let top = mix(texel_of(t, i.x, i.y), texel_of(t, i.x + 1, i.y), w.x);
    let bottom = mix(texel_of(t, i.x, i.y + 1), texel_of(t, i.x + 1, i.y + 1), w.x);
    return mix(top, bottom, w.y);
}

// The texture coordinates at a receiver hit (Möller–Trumbore's (u, v) weigh the second and
// third corners).
fn hit_uv(triangle: u32, u: f32, v: f32) -> vec2<f32> {
    let a = triangle_uvs[3u * triangle];
    let b = triangle_uvs[3u * triangle + 1u];
    return a.xy * (1.0 - u - v) + a.zw * u + b.xy * v;
}

// The outward normal n of BVH triangle `triangle` at texture coordinates uv, bent by the
// tangent-space normal map `texture` (none: n as it is; glTF §3.9.3: +Y toward decreasing v),
// its x and y scaled by `scale`. The tangent frame is the triangle's (`triangle_uvs`), made
// orthogonal to n.
fn bent_normal(n: vec3<f32>, texture: vec4<u32>, scale: f32, triangle: u32, uv: vec2<f32>) -> vec3<f32> {
    if !has_texture(texture) {
        return n;
    }
    let tangent = triangle_uvs[3u * triangle + 2u];
    let t = tangent.xyz - n * dot(n, tangent.xyz);
    if dot(t, t) <= 1e-12 {
        return n;
    }
    let tu = normalize(t);
    let b = tangent.w * cross(n, tu);
    var m = texture_at(texture, uv).xyz * 2.0 - 1.0;
    m = vec3<f32>(m.xy * scale, m.z);
    return normalize(tu * m.x + b * m.y + n * m.z);
}
