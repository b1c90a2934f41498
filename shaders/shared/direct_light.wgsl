// Light reaching a point directly, for the view stage (view.wgsl): shadow rays toward the
// lights and the environment and what they pass (receivers' cut-outs, thin sheets, media; a
// solid's glass stops them, its light arrives as photons), the lights a path that met glass
// sees, and the suns sampled where a view ray crosses rough glass (multiple importance sampling
// with the microfacet lobe). Keep call sites few: lavapipe inlines each anew, and shadow rays are
// most of the pass's code (`visibility` and `light_arrival` have two each: a receiver's shadow
// rays, `direct_light`, and the suns through rough glass).

// Transmittance along the straight segment from p along unit w for `dist`: exp(−∫σ_t), and
// zero if it passes where n − 1 > eps_refract — light through glass arrives as caustic photons.
fn shadow_transmittance(p: vec3<f32>, w: vec3<f32>, dist: f32) -> vec3<f32> {
    let grid = params.grid;
    let span = ray_box(p, w, grid.origin, grid_box_max(grid));
    let t_end = min(span.y, dist);
    if span.x > span.y || t_end <= 0.0 {
        return vec3<f32>(1.0);
    }
    var t = max(span.x, 0.0);
    var tr = vec3<f32>(1.0);
    for (var k = 0u; k < params.max_steps && t < t_end; k++) {
        let x = p + w * t;
        // Across a cell flat in n and σ, exp(−σ·len) is exact for any length: the whole cell
        // in one step (`max_step` bounds the view ray's steps only for in-scattering's sake).
        let len = min(octree_step(x, w, params.step, NO_HIT), t_end - t);
        let mid = x + w * (0.5 * len);
        if sample_ior(ior_grid, grid_sampler, grid, mid).w - 1.0 > params.eps_refract {
            return vec3<f32>(0.0);
        }
        if has(VIEW_FLAG_MEDIA) {
            tr *= exp(-sample_grid(extinction_grid, grid_sampler, grid, mid).rgb * len);
        }
        t += len;
    }
    return tr;
}

// Cut-outs and see-through receivers a shadow ray looks past, at most.
const MAX_SEE_THROUGH: u32 = 8u;

// What a polished thin sheet passes of a shadow ray at a hit on it: its thin-slab transmittance
// (1 − R_thin, the inner reflections summed per polarization, cross_interface's R) × its tint
// × its transmission where it is there, all of it where alpha cuts it away (`sheet_passes`),
// straight through — exactly what its photons would carry, so they leave that light to shadow
// rays (march.wgsl). A solid's surface or a rough sheet passes nothing: its light is photons'.
fn sheet_transmittance(hit: SurfaceHit, w: vec3<f32>) -> vec3<f32> {
    let f = interfaces[hit.interface_id];
    if (f.kind & INTERFACE_THIN) == 0u {
        return vec3<f32>(0.0);
    }
    let surface = glass_surface_at(hit, 0u);
    if surface.coverage <= 0.0 {
        return vec3<f32>(1.0);
    }
    if surface.roughness > 0.0 {
        return vec3<f32>(0.0);
    }
    return sheet_passes(surface, glass_reflectance(abs(dot(w, hit.normal)), interface_ior(f), true, surface.specular));
}

// The light that passes the analytic interfaces along p + t·w, t < dist: each crossing of a
// polished thin shell (a bubble, a lamp's globe) passes its `sheet_transmittance`; a solid's
// surface stops it.
fn analytic_transmittance(p: vec3<f32>, w: vec3<f32>, dist: f32) -> vec3<f32> {
    var passed = vec3<f32>(1.0);
    var t_min = 1e-4;
    for (var i = 0u; i < MAX_SEE_THROUGH; i++) {
        let hit = analytic_hit(p, w, t_min, no_surface(dist), NO_INTERFACE);
        if hit.t >= dist {
            return passed;
        }
        passed *= sheet_transmittance(hit, w);
        if all(passed <= vec3<f32>(0.0)) {
            return passed;
        }
        t_min = hit.t + 1e-4;
    }
    return vec3<f32>(0.0);
}

// The light that passes the surfaces along p + t·w, t < dist, when some are cut-outs,
// see-through or thin glass: each receiver hides its coverage, a thin sheet passes its
// transmittance; a solid's glass surface stops it (its light arrives as photons) — unless
// `glass_passes` (the glossy environment's ray, `glossy_ray`), when every glass surface lets it by.
fn receivers_transmittance(p: vec3<f32>, w: vec3<f32>, dist: f32, glass_passes: bool) -> vec3<f32> {
    var t_min = 1e-4;
    var passed = vec3<f32>(1.0);
    for (var i = 0u; i < MAX_SEE_THROUGH; i++) {
        let b = bvh_closest_hit(p, w, t_min, dist, 0xffffffffu);
        if b.triangle == 0xffffffffu {
            return passed;
        }
        let word = bvh_triangles[b.triangle].receiver;
        if (word & INTERFACE_BIT) != 0u {
            if !glass_passes {
                let id = word & ~INTERFACE_BIT;
                passed *= sheet_transmittance(SurfaceHit(b.t, b.triangle, id, shading_normal(b.triangle, b.u, b.v), b.u, b.v), w);
            }
        } else {
            passed *= 1.0 - coverage_of(receivers[word], b.triangle, b.u, b.v);
        }
        if all(passed <= vec3<f32>(0.0)) {
            return vec3<f32>(0.0);
        }
        t_min = b.t + 1e-4;
    }
    return vec3<f32>(0.0);
}

// Visibility of a light from p along w up to dist: opaque receivers and glass surfaces (light
// through glass arrives as caustic photons), then media. With `glass_passes`, opaque receivers
// alone: the glossy environment's ray (`glossy_ray`), which no photon carries, sees the sky
// through glass as a glossy reflection of it would, about (the refraction not followed).
fn visibility(p: vec3<f32>, w: vec3<f32>, dist: f32, glass_passes: bool) -> vec3<f32> {
    if glass_passes {
        return receivers_transmittance(p, w, dist, true);
    }
    if has(VIEW_FLAG_SEE_THROUGH) {
        let passed = receivers_transmittance(p, w, dist, false) * analytic_transmittance(p, w, dist);
        if all(passed <= vec3<f32>(0.0)) {
            return vec3<f32>(0.0);
        }
        return passed * shadow_transmittance(p, w, dist);
    }
    if bvh_any_hit(p, w, 1e-4, dist) || analytic_any_hit(p, w, 1e-4, dist) {
        return vec3<f32>(0.0);
    }
    return shadow_transmittance(p, w, dist);
}

// A point or spot light with a radius, seen from p outside its sphere: a bulb, lighting p from
// the cone it fills. From inside (or on) the sphere it lights p as the point it is.
fn is_bulb_seen_from(l: LightGpu, p: vec3<f32>) -> bool {
    let to_centre = l.position - p;
    return (l.kind == LIGHT_POINT || l.kind == LIGHT_SPOT) && l.radius > 0.0 && dot(to_centre, to_centre) > l.radius * l.radius * 1.0001;
}

// Light l as seen from p (one shadow sample, k picks it): the unit direction toward it, its
// intensity toward p (the sun: its illuminance) and the squared distance it falls off with
// (1 for the sun), and how far the shadow ray goes.
struct LightArrival {
    w: vec3<f32>,
    intensity: vec3<f32>,
    dist2: f32,
    dist: f32,
}

fn light_arrival(l: LightGpu, p: vec3<f32>, k: u32) -> LightArrival {
    let u = r2(k + 7u);
    // A sun's, a glowing mesh's and a bulb's numbers are rotated per pixel (Cranley–Patterson)
    // as the environment's are: a penumbra drawn with the same few directions or points in
    // every pixel shows them as steps (and a mesh's points fall over its triangles in whatever
    // order they were listed); rotated, neighbouring pixels differ and the steps become fine
    // noise that more samples average away.
    let key = pcg_hash(pixel_key ^ 0x2f6b3c1du);
    let rotated = fract(u + vec2<f32>(random01(key, 0u, 44u), random01(key, 0u, 45u)));
    if l.kind == LIGHT_SUN {
        var w = -l.direction;
        if l.half_angle > 0.0 {
            w = cone_direction(w, l.right, l.up, l.half_angle, rotated);
        }
        return LightArrival(w, l.radiant, 1.0, NO_HIT);
    }
    if l.kind == LIGHT_MESH {
        return glowing_mesh_arrival(l, p, rotated);
    }
    if is_bulb_seen_from(l, p) {
        return bulb_arrival(l, p, rotated);
    }
    var aim = l.position;
    let area_light = l.kind == LIGHT_RECT || l.kind == LIGHT_DISK;
    var area = l.size_x * l.size_y;
    if l.kind == LIGHT_RECT {
        aim += l.right * ((u.x - 0.5) * l.size_x) + l.up * ((u.y - 0.5) * l.size_y);
    } else if l.kind == LIGHT_DISK {
        // The inscribed ellipse, uniform by area (the concentric map).
        let q = concentric_disk(u);
        aim += l.right * (0.5 * q.x * l.size_x) + l.up * (0.5 * q.y * l.size_y);
        area *= 0.25 * PI;
    }
    let to_light = aim - p;
    let dist2 = dot(to_light, to_light);
    let dist = sqrt(dist2);
    let w = to_light / dist;
    var intensity: vec3<f32>;
    if area_light {
        // A one-sided Lambertian emitter of radiance L: I(θ) = L · A · cos θ (one sample).
        intensity = l.radiant * area * max(dot(-w, l.direction), 0.0);
    } else {
        intensity = light_intensity(l, -w);
    }
    return LightArrival(w, intensity, dist2, dist);
}

// A bulb — a point or spot light of radius r, a sphere of radiance I/(π r²) — seen from p
// outside it, through one direction uniform over the cone it fills (sin α = r/d, solid angle
// Ω = 2π(1 − cos α) = 2π sin²α/(1 + cos α), kept exact for small bulbs): E ≈ L · Ω · cos θ, so
// its shadows are soft, and where nothing is in the way it gives the point light's I cos θ/d²
// on average (exactly, for a receiver the whole sphere is above). The shadow ray ends on the
// sphere. (Its photons still leave from its centre: caustics keep a point light's focus.)
fn bulb_arrival(l: LightGpu, p: vec3<f32>, u: vec2<f32>) -> LightArrival {
    let to_centre = l.position - p;
    let d2 = dot(to_centre, to_centre);
    let axis = to_centre * inverseSqrt(d2);
    let r2 = l.radius * l.radius;
    let sin2 = r2 / d2;
    let cos_a = sqrt(1.0 - sin2);
    let frame = cone_frame(axis);
    let w = cap_direction(axis, frame[0], frame[1], cos_a, u);
    // The near root of |p + t·w − centre|² = r².
    let b = dot(w, to_centre);
    let t = b - sqrt(max(b * b - (d2 - r2), 0.0));
    let radiance = light_intensity(l, -axis) / (PI * r2);
    return LightArrival(w, radiance * (TAU * sin2 / (1.0 + cos_a)), 1.0, t);
}

// A glowing mesh seen from p through one point spread uniformly over its surface: each side
// that glows a Lambertian emitter of radiance L, so I(θ) = L · A · cos θ (one sample; 0 from a
// closed mesh's point facing away, which then costs no shadow ray) — a patterned glow's points
// drawn by power instead, weighed by their piece's scale. The shadow ray stops just short of the
// point, which lies on a receiver's own triangle.
fn glowing_mesh_arrival(l: LightGpu, p: vec3<f32>, u: vec2<f32>) -> LightArrival {
    let q = mesh_light_point(l, u);
    let to_light = q.p - p;
    let dist2 = dot(to_light, to_light);
    let dist = sqrt(dist2);
    let w = to_light / dist;
    return LightArrival(w, l.radiant * q.scale * (l.area * mesh_light_cos(l, q.n, -w)), dist2, dist * (1.0 - 1e-4));
}

// The key a pixel's branch `path` hashes its rotations of a sequence with (`random01`).
fn branch_key(path: u32) -> u32 {
    return pcg_hash(pixel_key ^ (path * 0x68bc21ebu));
}

// Four uniform numbers for shadow-ray pair j toward the environment of camera sample k on
// branch `path` of this pixel: point k·pairs + j of the R2 sequence, rotated per pixel and
// branch (Cranley–Patterson) once for the table's direction (xy) and once for the cosine one
// (zw), so a pixel's directions are evenly spread and neighbouring pixels' are independent.
fn env_numbers(k: u32, path: u32, j: u32) -> vec4<f32> {
    let key = branch_key(path);
    let rotation = vec4<f32>(random01(key, 0u, 40u), random01(key, 0u, 41u), random01(key, 0u, 42u), random01(key, 0u, 43u));
    let a = r2(k * params.env_pairs + j);
    return fract(vec4<f32>(a, a) + rotation);
}

// One shadow ray of a shading point: toward `w`, up to `dist`, and the irradiance `e` it brings
// if nothing is in the way (already × cos θ about the shading normal).
struct ShadowRay {
    w: vec3<f32>,
    dist: f32,
    e: vec3<f32>,
}

// Glowing meshes' shadow samples per camera sample: a mesh seen from a point is partly hidden by
// itself (a tube or a bulb by half), so one sample each would be mostly noise; a closed mesh's
// candidates facing away cost nothing.
const GLOWING_CANDIDATES: u32 = 4u;

// The first shadow-ray slot toward the environment: after one per light and the glowing
// meshes' extra candidates.
fn environment_slot() -> u32 {
    return params.light_count + (GLOWING_CANDIDATES - 1u) * params.glowing_count;
}

// Shadow ray i of the point p with shading normal n: first one per light (light_arrival) — for
// each glowing mesh (the last `glowing_count` lights) GLOWING_CANDIDATES, each weighing 1/that —
// then two per environment pair: one direction drawn from the environment's table
// (shared/env_light.wgsl), one by cos θ, each weighted by the balance heuristic (Veach 1997,
// §9.2), so a small bright sun and a wide dim sky both converge:
// E_env ≈ Σ L(ω) cos θ / (p_env(ω) + cos θ / π) over both, divided by the pairs. A colour
// environment takes both by cos θ.
fn shadow_ray(i: u32, p: vec3<f32>, n: vec3<f32>, k: u32, path: u32) -> ShadowRay {
    let env_first = environment_slot();
    if i < env_first {
        // One call of light_arrival for both kinds: lavapipe inlines every call site anew, and
        // a second one doubled the view pipeline's compile time.
        let glowing_first = params.light_count - params.glowing_count;
        var light = i;
        var sample = k;
        var candidates = 1u;
        if i >= glowing_first {
            let g = i - glowing_first;
            light = glowing_first + g / GLOWING_CANDIDATES;
            sample = k * GLOWING_CANDIDATES + g % GLOWING_CANDIDATES;
            candidates = GLOWING_CANDIDATES;
        }
        let a = light_arrival(lights[light], p, sample);
        return ShadowRay(a.w, a.dist, a.intensity * max(dot(n, a.w), 0.0) / (a.dist2 * f32(candidates)));
    }
    let j = i - env_first;
    let u = env_numbers(k, path, j / 2u);
    let frame = basis_around(n);
    let rays = f32(2u * params.env_pairs);
    if all(env_table_size() == vec2<u32>(1u)) {
        // A uniform sky: both rays by cos θ, each L·π exactly where nothing is in the way
        // (an open surface's E = π L has no noise), the table's uniform sphere adding only noise.
        let w = cosine_direction(n, frame[0], frame[1], select(u.xy, u.zw, (j & 1u) == 1u));
        return ShadowRay(w, NO_HIT, env_light_at(params.env, w).radiance * (PI / rays));
    }
    var l: EnvLightSample;
    if (j & 1u) == 0u {
        l = env_light_sample(params.env, u.xy);
    } else {
        l = env_light_at(params.env, cosine_direction(n, frame[0], frame[1], u.zw));
    }
    let c = dot(n, l.dir);
    if c <= 0.0 {
        // Below the surface (and, at c = 0 on a black texel, 0/0 otherwise).
        return ShadowRay(l.dir, NO_HIT, vec3<f32>(0.0));
    }
    return ShadowRay(l.dir, NO_HIT, l.radiance * c / ((l.pdf + c * INV_PI) * f32(params.env_pairs)));
}

// The glossy lobes' shadow ray toward the environment: a direction drawn from the base lobe's GGX
// (the visible normals about the shading normal, Heitz 2018, mirrored), carrying `e`, the
// environment's split-sum light on the glossy lobes (`pbr_environment`). Where the direction
// falls below the surface, the mirror direction; where that does too, along the surface's
// normal at distance 0 (nothing in the way).
fn glossy_ray(s: PbrSurface, facing: vec3<f32>, e: vec3<f32>, k: u32, path: u32) -> ShadowRay {
    // Point k of the R2 sequence, rotated per pixel and branch by numbers of its own.
    let key = branch_key(path);
    let u = fract(r2(k) + vec2<f32>(random01(key, 0u, 46u), random01(key, 0u, 47u)));
    let frame = basis_around(s.n);
    let m = frame * ggx_visible_normal(s.v * frame, max(s.roughness * s.roughness, 1e-4), u);
    var w = reflect(-s.v, m);
    if dot(w, facing) <= 0.0 {
        w = reflect(-s.v, s.n);
    }
    if dot(w, facing) <= 0.0 {
        return ShadowRay(facing, 0.0, e);
    }
    return ShadowRay(w, NO_HIT, e);
}

// The light reaching a shading point directly, with its shadows: every shadow ray through one
// call of `visibility` (the BVH walks and the march through the volume, which a compiler inlines
// at each call), the lights' through the surface's response (`pbr`: both lobes; otherwise the
// irradiance, in `diffuse`), the environment's through the diffuse lobe (`env_diffuse`: its
// share) and, on a receiver with glossy lobes, their split-sum light `env_specular` through one
// more ray drawn from the lobe (`glossy_ray`): the prefiltered environment where the sky is open
// along it, none where an opaque receiver is in the way — a ball on a polished floor darkens its
// reflection (the ball itself is not reflected; glass lets the sky by).
fn direct_light(p: vec3<f32>, facing: vec3<f32>, s: PbrSurface, pbr: bool, env_diffuse: vec3<f32>, env_specular: vec3<f32>, k: u32, path: u32) -> LightResponse {
    var out = LightResponse(vec3<f32>(0.0), vec3<f32>(0.0));
    let env_first = environment_slot();
    let glossy_slot = env_first + 2u * params.env_pairs;
    let count = glossy_slot + u32(pbr && any(env_specular > vec3<f32>(0.0)));
    for (var i = 0u; i < count; i++) {
        var ray: ShadowRay;
        if i == glossy_slot {
            ray = glossy_ray(s, facing, env_specular, k, path);
        } else {
            ray = shadow_ray(i, p, s.n, k, path);
        }
        if all(ray.e <= vec3<f32>(0.0)) || dot(facing, ray.w) <= 0.0 {
            continue;
        }
        let e = ray.e * visibility(p, ray.w, ray.dist, i == glossy_slot);
        if i == glossy_slot {
            out.specular += e;
        } else if i >= env_first {
            out.diffuse += env_diffuse * e;
        } else if pbr {
            let response = pbr_response(s, ray.w, dot(s.n, ray.w));
            out.diffuse += response.diffuse * e;
            out.specular += response.specular * e;
        } else {
            out.diffuse += e;
        }
    }
    return out;
}

// The solid angle of a cone of half-angle α (a sun's disc): Ω = 2π(1 − cos α).
fn cone_solid_angle(half_angle: f32) -> f32 {
    return 2.0 * PI * (1.0 - cos(half_angle));
}

// The solid angle a bulb (a sphere of radius r) fills seen from p outside it: the cone of
// sin α = r/d, Ω = 2π(1 − cos α) = 2π sin²α/(1 + cos α) (exact for small bulbs too).
fn bulb_solid_angle(l: LightGpu, p: vec3<f32>) -> f32 {
    let to_centre = l.position - p;
    let sin2 = min(l.radius * l.radius / dot(to_centre, to_centre), 1.0);
    return TAU * sin2 / (1.0 + sqrt(1.0 - sin2));
}

// An area light's area (a disk's or ellipse's: π/4 of its rectangle's).
fn area_light_area(l: LightGpu) -> f32 {
    return l.size_x * l.size_y * select(1.0, 0.25 * PI, l.kind == LIGHT_DISK);
}

// The balance heuristic's share of what a branch leaving a rough crossing finds by its own
// direction (density `lobe_pdf`) where the crossing also sampled the light (density `light_pdf`,
// `lights_through_rough`); all of it where it was not sampled (lobe_pdf 0).
fn share_of_lobe(lobe_pdf: f32, light_pdf: f32) -> f32 {
    return select(1.0, lobe_pdf / (lobe_pdf + light_pdf), lobe_pdf > 0.0);
}

// The light a path sees of the lights along o + t·d, 0 < t < t_max: each bulb of a point or spot
// light it passes (a sphere of its radius r whose radiance toward the viewer is I(ω) / (π r²)),
// each area light it passes in front of (a one-sided panel of radiance L: a softbox's highlight
// in glass) and, where the path leaves the scene, the suns' discs over the sky (a uniform disc of
// its angular radius: E over its solid angle 2π(1 − cos α)). As in Cycles, a light is no
// surface: it adds its light and the path goes on to what lies behind it (and covers nothing
// in the frame's alpha and depth). Where the path's last rough crossing (at `lobe_from`, on the
// same line behind o) also sampled the lights (`lobe_pdf` > 0: `lights_through_rough`), each
// light gives its share by the balance heuristic, its density taken as that crossing drew it: a
// sun's 1/Ω, a bulb's 1/Ω(lobe_from), an area light's distance² / (A cos θ) from lobe_from. A
// camera ray that met no glass (`camera`) sees only the lights marked visible (Blender's Ray
// Visibility ▸ Camera; never a sun's disc).
fn lights_seen(o: vec3<f32>, d: vec3<f32>, t_max: f32, lobe_pdf: f32, lobe_from: vec3<f32>, camera: bool) -> vec3<f32> {
    var seen = vec3<f32>(0.0);
    for (var i = 0u; i < params.light_count; i++) {
        let light = lights[i];
        if camera && light.visible == 0u {
            continue;
        }
        if light.kind == LIGHT_SUN {
            if t_max >= NO_HIT && light.half_angle > 0.0 && dot(d, -light.direction) >= cos(light.half_angle) {
                let solid_angle = cone_solid_angle(light.half_angle);
                seen += light.radiant / solid_angle * share_of_lobe(lobe_pdf, 1.0 / solid_angle);
            }
        } else if light.kind == LIGHT_RECT || light.kind == LIGHT_DISK {
            let facing = -dot(d, light.direction);
            let t = dot(light.position - o, light.direction) / -facing;
            if facing > 0.0 && t > 0.0 && t < t_max {
                let q = o + d * t - light.position;
                let xy = vec2<f32>(dot(q, light.right) / light.size_x, dot(q, light.up) / light.size_y) * 2.0;
                let inside = select(max(abs(xy.x), abs(xy.y)) <= 1.0, dot(xy, xy) <= 1.0, light.kind == LIGHT_DISK);
                if inside {
                    let from_crossing = distance(lobe_from, o + d * t);
                    seen += light.radiant * share_of_lobe(lobe_pdf, from_crossing * from_crossing / (area_light_area(light) * facing));
                }
            }
        } else if light.radius > 0.0 {
            let oc = o - light.position;
            let b = dot(oc, d);
            let disc = b * b - (dot(oc, oc) - light.radius * light.radius);
            let t = -b - sqrt(max(disc, 0.0));
            if disc >= 0.0 && t > 0.0 && t < t_max {
                let radiance = light_intensity(light, -d) / (PI * light.radius * light.radius);
                seen += radiance * share_of_lobe(lobe_pdf, 1.0 / bulb_solid_angle(light, lobe_from));
            }
        }
    }
    return seen;
}

// What a rough crossing (cross_interface on GGX of roughness α) gives a direction w chosen
// otherwise — toward a light: the density of its branches' directions there (the visible normals'
// D_wi(m) = G₁(wi) max(0, wi·m) D(m) / wi·n times the Jacobian of reflection, 1 / 4 wi·m, or of
// refraction, η² |w·m| / (wi·m + η w·m)²; Walter et al. 2007, Heitz 2018) and the weight the
// branch along w would carry per unit of light, per channel: the surface's split of the light at
// the microfacet m that sends it along w (`surface_split`: the glass's F — its
// `glass_reflectance` — and the metal's, reflected; what passes, tinted) × G₁(w): what multiple
// importance sampling with lights needs. d: the incoming direction; n: the shading normal toward
// where d comes from; eta: the index beyond over the index before. pdf 0 where the crossing
// sends nothing along w.
struct RoughLobe {
    pdf: f32,
    weight: vec3<f32>,
}

fn rough_lobe(d: vec3<f32>, n: vec3<f32>, w: vec3<f32>, alpha: f32, eta: f32, surface: GlassSurface) -> RoughLobe {
    let wi = -d;
    let cos_i = dot(wi, n);
    let reflect = dot(w, n) > 0.0;
    var m = select(wi + eta * w, wi + w, reflect);
    m = normalize(m) * select(-1.0, 1.0, dot(m, n) > 0.0);
    let i_m = dot(wi, m);
    let o_m = dot(w, m);
    if cos_i <= 0.0 || i_m <= 0.0 || (!reflect && o_m >= 0.0) {
        return RoughLobe(0.0, vec3<f32>(0.0));
    }
    let visible = smith_g1(cos_i, alpha) * i_m * ggx_d(dot(m, n), alpha) / cos_i;
    let split = surface_split(surface, glass_reflectance(i_m, eta, false, surface.specular), i_m);
    let g_out = smith_g1(abs(dot(w, n)), alpha);
    if reflect {
        return RoughLobe(visible / (4.0 * i_m), split.reflected * g_out);
    }
    let denom = i_m + eta * o_m;
    return RoughLobe(visible * eta * eta * abs(o_m) / (denom * denom), split.passed * g_out);
}

// Lights seen in rough glass, by both strategies (Veach 1997, multiple importance sampling with
// the balance heuristic): the branches' own directions find a sun's small disc, a bulb or a
// softbox only now and then — their glints through frosted glass were the fireflies of frosted
// frames — so at a rough crossing, each is also sampled directly where the direction toward it
// leaves into the open: a direction over a sun's disc or a bulb's cone, or a point of an area
// light or of a glowing mesh, the weight the crossing would give a branch along it
// (`rough_lobe`), a shadow ray. A sun or point of no size, which no branch can find, is all
// light sampling. Returns the light; `lobe_pdf` then weighs what the branches find
// (`lights_seen`, `glow_share`). A glowing mesh whose glow has a pattern is left to the branches
// (its points are drawn by its pieces' power, a density `glow_share` does not know). The lobe's
// weight is the surface's split at the facet that sends each light's direction — glass, metal
// and what passes, each in its colour — not at the facet the branches drew.
fn lights_through_rough(p: vec3<f32>, b: Branch, c: Crossing, surface: GlassSurface, alpha: f32, k: u32) -> vec3<f32> {
    var light = vec3<f32>(0.0);
    for (var i = 0u; i < params.light_count; i++) {
        let l = lights[i];
        let bulb = is_bulb_seen_from(l, p);
        let area = l.kind == LIGHT_RECT || l.kind == LIGHT_DISK;
        let glowing = l.kind == LIGHT_MESH;
        if (glowing && l.rough_sampled == 0u) || (l.kind != LIGHT_SUN && !bulb && !area && l.radius > 0.0) {
            continue;
        }
        let a = light_arrival(l, p, k);
        let lobe = rough_lobe(b.d, c.normal, a.w, alpha, c.eta, surface);
        if lobe.pdf <= 0.0 || media_along(c, a.w, b.media).depth != 0u || all(a.intensity <= vec3<f32>(0.0)) {
            continue;
        }
        // (L/p_light)·X·pdf_lobe·w_light: the radiance over the light's density — a sun's E, a
        // bulb's L·Ω, an area light's or a glowing mesh's L·A cos θ / d² (intensity / dist²) —
        // times the lobe's weight
        // per unit of light X (kept from masking as the branches are: c.energy) times its
        // density, times the balance heuristic's share (none for a light of no size).
        var light_pdf = 0.0;
        if l.kind == LIGHT_SUN && l.half_angle > 0.0 {
            light_pdf = 1.0 / cone_solid_angle(l.half_angle);
        } else if bulb {
            light_pdf = 1.0 / bulb_solid_angle(l, p);
        } else if area {
            light_pdf = a.dist2 / (area_light_area(l) * max(dot(-a.w, l.direction), 1e-6));
        } else if glowing {
            // A point uniform over its area A: d² / (A cos θ), with A cos θ = intensity / L.
            let radiance = max(l.radiant.r, max(l.radiant.g, l.radiant.b));
            light_pdf = a.dist2 * radiance / max(a.intensity.r, max(a.intensity.g, a.intensity.b));
        }
        let share = select(1.0, light_pdf / (light_pdf + lobe.pdf), light_pdf > 0.0);
        let seen = visibility(leave_surface(p, c.geometric, a.w, 1e-3 * params.grid.voxel_size), a.w, a.dist, false);
        light += a.intensity / a.dist2 * seen * lobe.weight * (c.energy * lobe.pdf * share);
    }
    return light;
}

// The density `lights_through_rough` weighs a branch leaving a rough crossing along w by: its
// lobe's, where w leaves into the open (there the lights were sampled too), else 0.
fn sampled_lobe_pdf(c: Crossing, surface: GlassSurface, media: Media, d: vec3<f32>, w: vec3<f32>, alpha: f32) -> f32 {
    if media_along(c, w, media).depth != 0u {
        return 0.0;
    }
    return rough_lobe(d, c.normal, w, alpha, c.eta, surface).pdf;
}
