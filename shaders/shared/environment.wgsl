// The environment seen along a direction. Equirectangular images follow Blender's convention
// (converted to Y up), so an HDRI lights a refrakt scene as it lights the same scene in Blender:
// u = 0.5 + atan2(d.z, d.x) / 2π (the image centre looks down +X), v = 0.5 + asin(d.y) / π,
// image row 0 at the top. `turn` (a unit quaternion: the scene's rotation about +Y times its
// tilt) turns the environment: what was seen along d is then seen along turn·d.
//
// Needs: #import shared/types.wgsl. The CPU twin is `Environment::radiance_over` in
// src/scene/environment.rs (and `studio` there for `env_studio`).

const PI: f32 = 3.14159265358979;

// q·v·q⁻¹ for a unit quaternion q = (x, y, z, w): v + 2w(u × v) + 2u × (u × v), u = q.xyz.
fn quat_rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let t = 2.0 * cross(q.xyz, v);
    return v + q.w * t + cross(q.xyz, t);
}

// Turning the environment by q is looking it up along the direction turned back by q⁻¹.
fn env_rotate(env: EnvParams, d: vec3<f32>) -> vec3<f32> {
    return quat_rotate(vec4<f32>(-env.turn.xyz, env.turn.w), d);
}

fn env_uv(env: EnvParams, d: vec3<f32>) -> vec2<f32> {
    let r = env_rotate(env, d);
    let u = 0.5 + atan2(r.z, r.x) / (2.0 * PI);
    let v = 0.5 + asin(clamp(r.y, -1.0, 1.0)) / PI;
    return vec2<f32>(u, 1.0 - v);
}

fn env_radiance(env_map: texture_2d<f32>, lin: sampler, env: EnvParams, d: vec3<f32>) -> vec3<f32> {
    if env.kind == ENV_COLOR {
        return env.color * env.intensity;
    }
    if env.kind == ENV_STUDIO {
        return env_studio(env_rotate(env, d), env.footprint) * env.intensity;
    }
    return textureSampleLevel(env_map, lin, env_uv(env, d), 0.0).rgb * env.color * env.intensity;
}

// The share of odd squares ((⌊x⌋ + ⌊y⌋) odd) in the box of width w centred on p: the checker
// convolved with a box, in closed form. Per axis the ±1 square wave is −2× the slope of the
// triangle wave |fract(x/2) − ½|, so its mean over the box is a difference of triangle waves
// over w; the box is separable, so the 2D mean is the product of the axes' means.
fn box_filtered_checker(p: vec2<f32>, w_in: vec2<f32>) -> f32 {
    let w = max(w_in, vec2<f32>(1e-4));
    let wave = 2.0 * (abs(fract((p - 0.5 * w) * 0.5) - 0.5) - abs(fract((p + 0.5 * w) * 0.5) - 0.5)) / w;
    return 0.5 - 0.5 * wave.x * wave.y;
}

// The studio preset, per ray: a dim grey cyclorama, 0.5 m floor tiles 1.5 m below the eye
// (box-filtered over the footprint of a cone `footprint` radians wide, so edges stay smooth at
// any output size and far tiles fade to their mean), and two soft boxes.
fn env_studio(d: vec3<f32>, footprint: f32) -> vec3<f32> {
    let horizon = vec3<f32>(0.55, 0.56, 0.6);
    if d.y < 0.0 {
        let depth = max(-d.y, 1e-3);
        // The cone's footprint on the floor: footprint·t across the ray, 1/|d.y| times that
        // along its horizontal heading; its bounding box per axis is the filter's width.
        let t = 1.5 / depth;
        let p = d.xz * t * 2.0;
        var heading = vec2<f32>(1.0, 0.0);
        if dot(d.xz, d.xz) > 0.0 {
            heading = normalize(d.xz);
        }
        let across = footprint * t * 2.0;
        let along = across / depth;
        let w = vec2<f32>(length(vec2<f32>(heading.x * along, heading.y * across)),
                          length(vec2<f32>(heading.y * along, heading.x * across)));
        let dark = box_filtered_checker(p, w);
        let base = mix(vec3<f32>(0.62, 0.6, 0.56), vec3<f32>(0.16, 0.16, 0.18), dark);
        return mix(horizon, base, smoothstep(0.0, 0.25, -d.y));
    }
    let wall = mix(horizon, vec3<f32>(0.22, 0.24, 0.3), smoothstep(0.0, 0.9, d.y));
    let key = 14.0 * smoothstep(cos(0.28 * 1.15), cos(0.28), dot(d, normalize(vec3<f32>(-1.0, 1.2, 0.6))));
    let rim = 8.0 * smoothstep(cos(0.18 * 1.15), cos(0.18), dot(d, normalize(vec3<f32>(1.0, 0.6, -1.0))));
    return wall + vec3<f32>(1.0, 0.97, 0.92) * key + vec3<f32>(0.85, 0.9, 1.0) * rim;
}
