// Receivers' materials: glTF 2.0's metallic-roughness model (scene::Diffuse, ReceiverGpu).
//
// - Textures: shared/texture.wgsl.
// - BRDF (glTF 2.0 spec, appendix B, with KHR_materials_specular's weight s):
//   dielectric = (1 − F_d)·c/π + F_d·D·V,  F_d = Schlick(0.04·s, s, v·h)
//   metal      = F_m·D·V,                  F_m = Schlick(c, 1, v·h)
//   f = mix(dielectric, metal, metallic), D = GGX, V = Smith height-correlated, α = roughness².
// - The environment's specular light by the split sum (src/pipeline/specular.rs): the
//   prefiltered environment along the mirror direction × (F0·A + F90·B) from the BRDF table.
// - KHR_materials_sheen over that (the Sample Viewer's model): f_sheen = c_s·D_Charlie·V_sheen,
//   the layer below scaled by 1 − max(c_s)·E, E the sheen's directional albedo (the table's
//   second half; for lights the smaller at n·v and at n·l, as the extension says).
// - KHR_materials_clearcoat over all: f_coat = clearcoat·F_c(v·h)·D·V about the coat's own
//   normal (n = 1.5: F0 = 0.04), the layers below scaled by 1 − clearcoat·F_c(n_c·v).
//
// Expects the stage to declare `receivers`, `triangle_normals`, what shared/texture.wgsl needs,
// `env_map`, `env_sampler`, `env_specular` (texture_2d_array, SPECULAR_LEVELS layers) and
// `brdf_lut` (array<vec2<f32>>, BRDF_LUT_SIZE²), and to import types, environment and
// interface (shading_normal).

#import shared/texture.wgsl

const SPECULAR_LEVELS: f32 = 5.0;
const BRDF_LUT_SIZE: u32 = 32u;
// Perceptual roughness the lights see at least: a GGX lobe of α → 0 is a delta that a point
// light never meets (its highlight would vanish, not sharpen).
const MIN_LIGHT_ROUGHNESS: f32 = 0.03;

// The fraction of what is behind a receiver that it hides at a hit: 1 when opaque, 0 or 1 for
// a cut-out (MASK), alpha when see-through (BLEND).
fn coverage_of(r: ReceiverGpu, triangle: u32, u: f32, v: f32) -> f32 {
    if (r.flags & (RECEIVER_MASK | RECEIVER_BLEND)) == 0u {
        return 1.0;
    }
    let alpha = base_color_at(r, hit_uv(triangle, u, v)).a;
    if (r.flags & RECEIVER_MASK) != 0u {
        return select(0.0, 1.0, alpha >= r.alpha_cutoff);
    }
    return clamp(alpha, 0.0, 1.0);
}

// The emitted radiance at a hit.
fn emission_at(r: ReceiverGpu, uv: vec2<f32>) -> vec3<f32> {
    if has_texture(r.emission_texture) {
        return r.emission * texture_at(r.emission_texture, uv).rgb;
    }
    return r.emission;
}

// The shading normal of a PBR receiver at a hit, on the side `facing` (the geometric normal
// toward the viewer): its smooth normal, bent by its normal map.
fn pbr_normal(r: ReceiverGpu, triangle: u32, u: f32, v: f32, uv: vec2<f32>, facing: vec3<f32>) -> vec3<f32> {
    return mapped_normal(r.normal_texture, r.normal_scale, triangle, u, v, uv, facing);
}

// The smooth normal at a hit on the side `facing`, bent by the tangent-space normal map
// `texture` (none: as it is), its x and y scaled by `scale`.
fn mapped_normal(texture: vec4<u32>, scale: f32, triangle: u32, u: f32, v: f32, uv: vec2<f32>, facing: vec3<f32>) -> vec3<f32> {
    let n = shading_normal(triangle, u, v);
    let bent = bent_normal(n, texture, scale, triangle, uv);
    return select(bent, -bent, dot(n, facing) < 0.0);
}

// Schlick's Fresnel from f0 to f90 at v·h.
fn schlick(f0: vec3<f32>, f90: f32, v_h: f32) -> vec3<f32> {
    let x = 1.0 - clamp(v_h, 0.0, 1.0);
    let x2 = x * x;
    return f0 + (vec3<f32>(f90) - f0) * (x2 * x2 * x);
}

fn ggx_d(n_h: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let f = n_h * n_h * (a2 - 1.0) + 1.0;
    return a2 / (PI * f * f);
}

fn smith_visibility(n_l: f32, n_v: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let s = n_l * sqrt(n_v * n_v * (1.0 - a2) + a2) + n_v * sqrt(n_l * n_l * (1.0 - a2) + a2);
    return select(0.0, 0.5 / s, s > 0.0);
}

// A PBR surface point: what the lights and the environment need.
struct PbrSurface {
    base: vec3<f32>,
    metallic: f32,
    roughness: f32,
    specular: f32,
    occlusion: f32,
    n: vec3<f32>,
    v: vec3<f32>,
    n_v: f32,
    clearcoat: f32,
    clearcoat_roughness: f32,
    // The coat's normal (the surface's without its normal map) and n_c·v.
    coat_n: vec3<f32>,
    coat_n_v: f32,
    sheen_color: vec3<f32>,
    sheen_roughness: f32,
}

// The Charlie sheen distribution (Estevez & Kulla 2017): (2 + 1/α) sin^(1/α)θ_h / 2π, α = r².
fn charlie_d(n_h: f32, roughness: f32) -> f32 {
    let inv_alpha = 1.0 / max(roughness * roughness, 1e-6);
    let sin2 = max(1.0 - n_h * n_h, 0.0);
    return (2.0 + inv_alpha) * pow(sin2, 0.5 * inv_alpha) / (2.0 * PI);
}

// Estevez & Kulla's fit of the sheen's Λ (the Sample Viewer's lambdaSheenNumericHelper).
fn sheen_lambda_fit(x: f32, alpha: f32) -> f32 {
    let t = (1.0 - alpha) * (1.0 - alpha);
    let a = mix(21.5473, 25.3245, t);
    let b = mix(3.82987, 3.32435, t);
    let c = mix(0.19823, 0.16801, t);
    let d = mix(-1.97760, -1.27393, t);
    let e = mix(-4.32054, -4.85967, t);
    return a / (1.0 + b * pow(x, c)) + d * x + e;
}

fn sheen_lambda(cos_theta: f32, alpha: f32) -> f32 {
    if abs(cos_theta) < 0.5 {
        return exp(sheen_lambda_fit(cos_theta, alpha));
    }
    return exp(2.0 * sheen_lambda_fit(0.5, alpha) - sheen_lambda_fit(1.0 - cos_theta, alpha));
}

// The sheen's visibility 1 / ((1 + Λ(n·v) + Λ(n·l)) · 4 (n·l)(n·v)), at most 1.
fn sheen_visibility(n_l: f32, n_v: f32, roughness: f32) -> f32 {
    let alpha = max(roughness * roughness, 1e-6);
    return clamp(1.0 / ((1.0 + sheen_lambda(n_v, alpha) + sheen_lambda(n_l, alpha)) * (4.0 * n_v * n_l)), 0.0, 1.0);
}

// The sheen's directional albedo E(cos θ) (the table's second half).
fn sheen_albedo(cos_theta: f32, roughness: f32) -> f32 {
    return lut_at(1u, cos_theta, roughness).x;
}

fn max3(c: vec3<f32>) -> f32 {
    return max(c.x, max(c.y, c.z));
}

// The coat's Fresnel weight toward the viewer, clearcoat·F_c(n_c·v): what the coat takes from
// the layers below.
fn coat_weight(s: PbrSurface) -> f32 {
    return s.clearcoat * schlick(vec3<f32>(0.04), 1.0, s.coat_n_v).x;
}

// The BRDF's two parts for light arriving along w: (diffuse weight per irradiance ×π: the
// share the diffuse lobe keeps, times (1 − metallic)), and the specular lobe's value.
struct LightResponse {
    diffuse: vec3<f32>,
    specular: vec3<f32>,
}

fn pbr_response(s: PbrSurface, w: vec3<f32>, n_l: f32) -> LightResponse {
    let h = normalize(w + s.v);
    let v_h = dot(s.v, h);
    let alpha = max(s.roughness, MIN_LIGHT_ROUGHNESS) * max(s.roughness, MIN_LIGHT_ROUGHNESS);
    let lobe = ggx_d(max(dot(s.n, h), 0.0), alpha) * smith_visibility(n_l, s.n_v, alpha);
    let f_d = schlick(vec3<f32>(0.04 * s.specular), s.specular, v_h);
    let f_m = schlick(s.base, 1.0, v_h);
    var diffuse = s.base * INV_PI * (1.0 - f_d) * (1.0 - s.metallic);
    var specular = lobe * mix(f_d, f_m, s.metallic);
    let sheen = max3(s.sheen_color);
    if sheen > 0.0 {
        let below = min(1.0 - sheen * sheen_albedo(s.n_v, s.sheen_roughness), 1.0 - sheen * sheen_albedo(n_l, s.sheen_roughness));
        diffuse *= below;
        specular = specular * below + s.sheen_color * charlie_d(max(dot(s.n, h), 0.0), s.sheen_roughness) * sheen_visibility(n_l, s.n_v, s.sheen_roughness);
    }
    if s.clearcoat > 0.0 {
        let below = 1.0 - coat_weight(s);
        diffuse *= below;
        specular *= below;
        let c_l = dot(s.coat_n, w);
        if c_l > 0.0 {
            let r = max(s.clearcoat_roughness, MIN_LIGHT_ROUGHNESS);
            let coat = ggx_d(max(dot(s.coat_n, h), 0.0), r * r) * smith_visibility(c_l, s.coat_n_v, r * r) * schlick(vec3<f32>(0.04), 1.0, v_h).x;
            // The caller weighs the response by n·l; the coat's own cosine is n_c·l.
            specular += vec3<f32>(s.clearcoat * coat * c_l / n_l);
        }
    }
    return LightResponse(diffuse, specular);
}

// Table `table` of the BRDF buffer (0: the split sum's (A, B); 1: the sheen's (E, 0)) at
// (cos θ, roughness): bilinear between the entry centres.
fn lut_at(table: u32, cos_theta: f32, roughness: f32) -> vec2<f32> {
    let last = f32(BRDF_LUT_SIZE - 1u);
    let f = clamp(vec2<f32>(cos_theta, roughness) * f32(BRDF_LUT_SIZE) - 0.5, vec2<f32>(0.0), vec2<f32>(last));
    let i = vec2<u32>(floor(f));
    let j = min(i + 1u, vec2<u32>(BRDF_LUT_SIZE - 1u));
    let t = f - floor(f);
    let base = table * BRDF_LUT_SIZE * BRDF_LUT_SIZE;
    let row0 = mix(brdf_lut[base + i.y * BRDF_LUT_SIZE + i.x], brdf_lut[base + i.y * BRDF_LUT_SIZE + j.x], t.x);
    let row1 = mix(brdf_lut[base + j.y * BRDF_LUT_SIZE + i.x], brdf_lut[base + j.y * BRDF_LUT_SIZE + j.x], t.x);
    return mix(row0, row1, t.y);
}

// The environment's radiance along r convolved with the GGX lobe of `roughness`: the image
// itself at 0, the prefiltered layers at 0.2 … 1, linear in between.
fn prefiltered_environment(env: EnvParams, r: vec3<f32>, roughness: f32) -> vec3<f32> {
    if env.kind == 0u {
        return env.color * env.intensity;
    }
    let lod = clamp(roughness, 0.0, 1.0) * SPECULAR_LEVELS;
    let uv = env_uv(env, r);
    let layer = min(floor(lod), SPECULAR_LEVELS - 1.0);
    let t = lod - layer;
    var lower: vec3<f32>;
    if layer < 1.0 {
        lower = textureSampleLevel(env_map, env_sampler, uv, 0.0).rgb;
    } else {
        lower = textureSampleLevel(env_specular, env_sampler, uv, i32(layer) - 1, 0.0).rgb;
    }
    let upper = textureSampleLevel(env_specular, env_sampler, uv, i32(layer), 0.0).rgb;
    return mix(lower, upper, t) * env.color * env.intensity;
}

// The environment's light leaving the surface: (the diffuse lobe's share of an irradiance, as
// `LightResponse.diffuse`; the specular radiance), before occlusion.
fn pbr_environment(s: PbrSurface, env: EnvParams) -> LightResponse {
    let ab = lut_at(0u, s.n_v, s.roughness);
    let e_dielectric = s.specular * (0.04 * ab.x + ab.y);
    let e_metal = s.base * ab.x + ab.y;
    let r = reflect(-s.v, s.n);
    var specular = prefiltered_environment(env, r, s.roughness) * mix(vec3<f32>(e_dielectric), e_metal, s.metallic);
    var diffuse = s.base * INV_PI * (1.0 - e_dielectric) * (1.0 - s.metallic);
    let sheen = max3(s.sheen_color);
    if sheen > 0.0 {
        // The sheen reflects E of the light around the normal (exactly so for a uniform
        // environment; the roughest prefiltered layer stands for the lobe, broad as it is).
        let e_sheen = sheen_albedo(s.n_v, s.sheen_roughness);
        diffuse *= 1.0 - sheen * e_sheen;
        specular = specular * (1.0 - sheen * e_sheen) + s.sheen_color * e_sheen * prefiltered_environment(env, s.n, 1.0);
    }
    if s.clearcoat > 0.0 {
        let below = 1.0 - coat_weight(s);
        let coat_ab = lut_at(0u, s.coat_n_v, s.clearcoat_roughness);
        let coat = prefiltered_environment(env, reflect(-s.v, s.coat_n), s.clearcoat_roughness) * (0.04 * coat_ab.x + coat_ab.y);
        diffuse *= below;
        specular = specular * below + s.clearcoat * coat;
    }
    return LightResponse(diffuse, specular);
}
