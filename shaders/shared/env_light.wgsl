// The environment as a light (pbrt-v4's image infinite light): its radiance piecewise constant
// over the equirectangular texels of `env_table`, directions drawn in proportion to luminance ×
// solid angle — by the marginal CDF over rows, then the row's CDF over texels, then uniformly in
// solid angle inside the texel (uniform in φ and in sin β), so the density is exactly
// luminance(L) / ∫ luminance(L) dω over each texel.
//
// Needs shared/types.wgsl and shared/environment.wgsl (`env_rotate`, PI), and a binding
// `env_table: array<f32>` in the including stage, laid out as `EnvLightTable::gpu_words`
// (src/pipeline/env_light.rs, the CPU twin): width and height (bits), ∫ lum dω, 0, ∫ L dω (rgb),
// 0, the marginal CDF (height + 1), the rows' CDFs (height × (width + 1)), the radiance (3 words
// a texel). The table is in the environment's own frame without its colour and intensity;
// `EnvParams` turns and scales it as it does the environment seen.

const ENV_TABLE_HEADER: u32 = 8u;

struct EnvLightSample {
    dir: vec3<f32>,
    // Density per steradian of having drawn `dir`.
    pdf: f32,
    // The environment's radiance along `dir` (scaled by colour × intensity).
    radiance: vec3<f32>,
}

fn env_table_size() -> vec2<u32> {
    return vec2<u32>(bitcast<u32>(env_table[0]), bitcast<u32>(env_table[1]));
}

// ∫ luminance(L) dω of the unscaled table.
fn env_table_power() -> f32 {
    return env_table[2];
}

// ∫ L dω (rgb) of the environment, scaled: the flux per unit area it sends through a plane.
fn env_light_integral(env: EnvParams) -> vec3<f32> {
    return vec3<f32>(env_table[4], env_table[5], env_table[6]) * env.color * env.intensity;
}

fn env_table_radiance(texel: u32) -> vec3<f32> {
    let size = env_table_size();
    let base = ENV_TABLE_HEADER + (size.y + 1u) + size.y * (size.x + 1u) + 3u * texel;
    return vec3<f32>(env_table[base], env_table[base + 1u], env_table[base + 2u]);
}

// The last i in [0, n) with cdf[first + i] ≤ u (the CDF has n + 1 entries from 0 to 1), and
// where u lies in that interval (0..1).
fn env_cdf_search(first: u32, n: u32, u: f32) -> vec2<f32> {
    var lo = 0u;
    var hi = n - 1u;
    while lo < hi {
        let mid = (lo + hi + 1u) / 2u;
        if env_table[first + mid] <= u {
            lo = mid;
        } else {
            hi = mid - 1u;
        }
    }
    let a = env_table[first + lo];
    let width = env_table[first + lo + 1u] - a;
    let t = select(0.5, clamp((u - a) / width, 0.0, 0.99999994), width > 0.0);
    return vec2<f32>(f32(lo), t);
}

fn env_luminance(c: vec3<f32>) -> f32 {
    return (c.r + c.g + c.b) / 3.0;
}

// The inverse of env_rotate: the table's frame → world.
fn env_unrotate(env: EnvParams, r: vec3<f32>) -> vec3<f32> {
    return quat_rotate(env.turn, r);
}

// A world direction drawn from the environment by two uniform numbers.
fn env_light_sample(env: EnvParams, u: vec2<f32>) -> EnvLightSample {
    let size = env_table_size();
    let row_pick = env_cdf_search(ENV_TABLE_HEADER, size.y, u.x);
    let row = u32(row_pick.x);
    let col_pick = env_cdf_search(ENV_TABLE_HEADER + size.y + 1u + row * (size.x + 1u), size.x, u.y);
    let col = u32(col_pick.x);
    // sin β across the row, uniform in solid angle (row 0 at the top).
    let top = sin((0.5 - f32(row) / f32(size.y)) * PI);
    let bottom = sin((0.5 - f32(row + 1u) / f32(size.y)) * PI);
    let y = mix(bottom, top, row_pick.y);
    let phi = ((f32(col) + col_pick.y) / f32(size.x) - 0.5) * 2.0 * PI;
    let c = sqrt(max(0.0, 1.0 - y * y));
    let raw = env_table_radiance(row * size.x + col);
    let dir = env_unrotate(env, vec3<f32>(c * cos(phi), y, c * sin(phi)));
    return EnvLightSample(dir, env_luminance(raw) / env_table_power(), raw * env.color * env.intensity);
}

// The table texel world direction d falls in.
fn env_table_texel(env: EnvParams, d: vec3<f32>) -> u32 {
    let size = env_table_size();
    let uv = env_uv(env, d);
    let x = u32(clamp(floor(fract(uv.x) * f32(size.x)), 0.0, f32(size.x - 1u)));
    let y = u32(clamp(floor(uv.y * f32(size.y)), 0.0, f32(size.y - 1u)));
    return y * size.x + x;
}

// The density env_light_sample draws world direction d with, and the light's radiance there.
fn env_light_at(env: EnvParams, d: vec3<f32>) -> EnvLightSample {
    let raw = env_table_radiance(env_table_texel(env, d));
    return EnvLightSample(d, env_luminance(raw) / env_table_power(), raw * env.color * env.intensity);
}
