// Lights: how much they emit toward a direction, and the equal-area maps the photons stage uses
// to spread photons over the directions (or the area) that can reach the volume.
//
// Needs shared/types.wgsl. Units are radiometric: `radiant` is W/sr for point and spot lights,
// W/m² for the sun (KHR_lights_punctual's cd and lux divided by 683 lm/W).

const TAU: f32 = 6.28318530717959;

// Spot cone: full intensity inside the inner angle, zero outside the outer one, smooth between
// (Blender's spot blend is a smoothstep too).
fn spot_falloff(light: LightGpu, dir_from_light: vec3<f32>) -> f32 {
    if light.kind != LIGHT_SPOT {
        return 1.0;
    }
    return smoothstep(light.cos_outer, light.cos_inner, dot(dir_from_light, light.direction));
}

// Radiant intensity (W/sr) of a point or spot light along `dir_from_light`.
fn light_intensity(light: LightGpu, dir_from_light: vec3<f32>) -> vec3<f32> {
    return light.radiant * spot_falloff(light, dir_from_light);
}

// Shirley & Chiu's concentric map of the unit square onto the unit disc (equal-area).
fn concentric_disk(u: vec2<f32>) -> vec2<f32> {
    let a = 2.0 * u - 1.0;
    if a.x == 0.0 && a.y == 0.0 {
        return vec2<f32>(0.0);
    }
    if abs(a.x) > abs(a.y) {
        let phi = (TAU / 8.0) * (a.y / a.x);
        return a.x * vec2<f32>(cos(phi), sin(phi));
    }
    let phi = TAU / 4.0 - (TAU / 8.0) * (a.x / a.y);
    return a.y * vec2<f32>(cos(phi), sin(phi));
}

// Equal-area map of the unit square onto the cap of directions within acos(cos_max) of `axis`
// (the whole sphere when cos_max = −1): the disc radius r maps to cos θ = 1 − r²(1 − cos_max).
fn cap_direction(axis: vec3<f32>, right: vec3<f32>, up: vec3<f32>, cos_max: f32, u: vec2<f32>) -> vec3<f32> {
    let disk = concentric_disk(u);
    let r2 = dot(disk, disk);
    let cos_theta = 1.0 - r2 * (1.0 - cos_max);
    let sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
    let azimuth = select(vec2<f32>(1.0, 0.0), disk / sqrt(r2), r2 > 0.0);
    return cos_theta * axis + sin_theta * (azimuth.x * right + azimuth.y * up);
}

// A direction about `axis` (with `right`, `up` an orthonormal frame) of density cos θ / π:
// Malley's method, the concentric disc lifted to the hemisphere.
fn cosine_direction(axis: vec3<f32>, right: vec3<f32>, up: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let d = concentric_disk(u);
    return d.x * right + d.y * up + sqrt(max(0.0, 1.0 - dot(d, d))) * axis;
}

// A direction within half-angle `half_angle` of `axis`, uniform in solid angle.
fn cone_direction(axis: vec3<f32>, right: vec3<f32>, up: vec3<f32>, half_angle: f32, u: vec2<f32>) -> vec3<f32> {
    return cap_direction(axis, right, up, cos(half_angle), u);
}

// An orthonormal pair across unit `axis`.
fn cone_frame(axis: vec3<f32>) -> mat2x3<f32> {
    let right = normalize(select(vec3<f32>(0.0, -axis.z, axis.y), vec3<f32>(axis.z, 0.0, -axis.x), abs(axis.x) > abs(axis.y)));
    return mat2x3<f32>(right, cross(axis, right));
}
