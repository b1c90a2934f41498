// The environment seen along a direction. Equirectangular images follow Blender's convention
// (converted to Y up), so an HDRI lights a refrakt scene as it lights the same scene in Blender:
// u = 0.5 + atan2(d.z, d.x) / 2π (the image centre looks down +X), v = 0.5 + asin(d.y) / π,
// image row 0 at the top. `rotation` turns the environment about +Y (radians, counter-clockwise
// seen from above): what was seen along d is then seen along R_y(rotation)·d.
//
// Needs: #import shared/types.wgsl. The CPU twin is `Environment::radiance` in src/scene/environment.rs.

const PI: f32 = 3.14159265358979;

fn env_uv(env: EnvParams, d: vec3<f32>) -> vec2<f32> {
    let c = cos(env.rotation);
    let s = sin(env.rotation);
    // Rotating the environment by +θ is looking it up along the direction turned by −θ.
    let r = vec3<f32>(c * d.x - s * d.z, d.y, s * d.x + c * d.z);
    let u = 0.5 + atan2(r.z, r.x) / (2.0 * PI);
    let v = 0.5 + asin(clamp(r.y, -1.0, 1.0)) / PI;
    return vec2<f32>(u, 1.0 - v);
}

fn env_radiance(env_map: texture_2d<f32>, lin: sampler, env: EnvParams, d: vec3<f32>) -> vec3<f32> {
    if env.kind == 0u {
        return env.color * env.intensity;
    }
    return textureSampleLevel(env_map, lin, env_uv(env, d), 0.0).rgb * env.color * env.intensity;
}
