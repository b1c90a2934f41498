// Sharp interfaces: where a ray or photon meets the surface of a constant-index object (glass,
// water) it refracts or reflects once, at the exact surface, by Snell's law and the unpolarized
// Fresnel equations (pbrt-v4 §9.5), instead of bending across a smoothed step of n. Smooth
// gradient-index interiors (Luneburg, slabs, script fields) keep the ray equation and reflect
// nothing: they are not interfaces.
//
// Spheres and boxes are intersected exactly in their local frame; meshes are triangles of the
// receivers' BVH whose `receiver` word carries INTERFACE_BIT | interface index, shaded with
// interpolated corner normals. Which medium a path is in is tracked by the set of solids it is
// inside (crossing a solid's surface leaves it when it is in the set, else enters it), up to
// MEDIA_DEPTH; where solids overlap, the one of highest rank holds (nested dielectrics with
// priorities: the liquid that overlaps its glass is liquid there). A surface that does not
// change which medium holds — the glass's inner wall inside the liquid that overlaps it — is
// not there for light at all. Another solid's surface within the first one's `contact`
// distance is crossed with it as one interface: water against glass meets glass/water
// Fresnel, with no film of air between, however the two were modelled (coincident,
// overlapping, or a hair apart).
//
// With dispersion, the index of each medium is the one at the path's wavelength
// (shared/spectrum.wgsl: `path_wavelength`, 0 for an RGB path, which keeps `ior` exactly).
//
// Expects the stage to declare `interfaces: array<Interface>`, `triangle_normals:
// array<vec4<f32>>` (3 per BVH triangle), `rough_albedo_table: array<f32>`
// (shared/rough_albedo.wgsl) and what shared/bvh.wgsl needs. The CPU twin is
// src/cpu/interface.rs.

#import shared/spectrum.wgsl
#import shared/rough_albedo.wgsl

const NO_INTERFACE: u32 = 0xffffffffu;
const MEDIA_DEPTH: u32 = 4u;

// The next surface along a straight line: a receiver (`interface` = NO_INTERFACE, `triangle` its
// BVH triangle) or an interface, with the unit shading normal at the hit (either orientation).
struct SurfaceHit {
    t: f32,
    triangle: u32,
    interface_id: u32,
    normal: vec3<f32>,
    u: f32,
    v: f32,
}

fn is_receiver_hit(h: SurfaceHit) -> bool {
    return h.triangle != 0xffffffffu && h.interface_id == NO_INTERFACE;
}

fn no_surface(t_max: f32) -> SurfaceHit {
    return SurfaceHit(t_max, 0xffffffffu, NO_INTERFACE, vec3<f32>(0.0, 1.0, 0.0), 0.0, 0.0);
}

// Parameter interval (t₀, t₁) where o + t·d is inside interface i's solid (t₀ > t₁: missed), and
// the local normals there. Local coordinates keep t: world_to_local is affine, so a point at
// parameter t maps to local o' + t·d' without renormalising d'.
struct Span {
    t0: f32,
    t1: f32,
    n0: vec3<f32>,
    n1: vec3<f32>,
}

fn sphere_span(o: vec3<f32>, d: vec3<f32>, r: f32) -> Span {
    // |o + t·d|² = r²: t = (−b ± √(b² − a·c)) / a with b = o·d.
    let a = dot(d, d);
    let b = dot(o, d);
    let c = dot(o, o) - r * r;
    let disc = b * b - a * c;
    if disc < 0.0 {
        return Span(1.0, -1.0, vec3<f32>(0.0), vec3<f32>(0.0));
    }
    let q = sqrt(disc);
    let t0 = (-b - q) / a;
    let t1 = (-b + q) / a;
    return Span(t0, t1, o + t0 * d, o + t1 * d);
}

fn box_span(o: vec3<f32>, d: vec3<f32>, h: vec3<f32>) -> Span {
    let inv = 1.0 / d;
    let ta = (-h - o) * inv;
    let tb = (h - o) * inv;
    let lo = min(ta, tb);
    let hi = max(ta, tb);
    let t0 = max(max(lo.x, lo.y), lo.z);
    let t1 = min(min(hi.x, hi.y), hi.z);
    // The face of a slab test's winning plane: its axis, against the direction of travel on
    // entry and along it on exit.
    let axis0 = select(select(vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(0.0, 1.0, 0.0), lo.y >= lo.z), vec3<f32>(1.0, 0.0, 0.0), lo.x >= lo.y && lo.x >= lo.z);
    let axis1 = select(select(vec3<f32>(0.0, 0.0, 1.0), vec3<f32>(0.0, 1.0, 0.0), hi.y <= hi.z), vec3<f32>(1.0, 0.0, 0.0), hi.x <= hi.y && hi.x <= hi.z);
    return Span(t0, t1, -axis0 * sign(d), axis1 * sign(d));
}

fn analytic_span(f: Interface, o: vec3<f32>, d: vec3<f32>) -> Span {
    let lo = (f.world_to_local * vec4<f32>(o, 1.0)).xyz;
    let ld = (f.world_to_local * vec4<f32>(d, 0.0)).xyz;
    if (f.kind & INTERFACE_SHAPE) == INTERFACE_SPHERE {
        return sphere_span(lo, ld, f.half_size.x);
    }
    return box_span(lo, ld, f.half_size);
}

// A local normal to world: normals transform by the inverse transpose of local → world, which
// is the transpose of world_to_local.
fn normal_to_world(f: Interface, n: vec3<f32>) -> vec3<f32> {
    let m = mat3x3<f32>(f.world_to_local[0].xyz, f.world_to_local[1].xyz, f.world_to_local[2].xyz);
    return normalize(transpose(m) * n);
}

// The closest analytic interface surface along o + t·d, t in (t_min, best.t), but for interface
// `skip` (NO_INTERFACE: none).
fn analytic_hit(o: vec3<f32>, d: vec3<f32>, t_min: f32, best: SurfaceHit, skip: u32) -> SurfaceHit {
    var hit = best;
    let count = arrayLength(&interfaces);
    for (var i = 0u; i < count; i++) {
        let f = interfaces[i];
        let shape = f.kind & INTERFACE_SHAPE;
        if shape == INTERFACE_NONE || shape == INTERFACE_MESH {
            break;
        }
        let s = analytic_span(f, o, d);
        if s.t0 > s.t1 || i == skip {
            continue;
        }
        if s.t0 > t_min && s.t0 < hit.t {
            hit = SurfaceHit(s.t0, 0xffffffffu, i, normal_to_world(f, s.n0), 0.0, 0.0);
        } else if s.t1 > t_min && s.t1 < hit.t {
            hit = SurfaceHit(s.t1, 0xffffffffu, i, normal_to_world(f, s.n1), 0.0, 0.0);
        }
    }
    return hit;
}

// The interpolated shading normal of BVH triangle k at barycentrics (u, v).
fn shading_normal(k: u32, u: f32, v: f32) -> vec3<f32> {
    let n = triangle_normals[3u * k].xyz * (1.0 - u - v) + triangle_normals[3u * k + 1u].xyz * u + triangle_normals[3u * k + 2u].xyz * v;
    return normalize(n);
}

// The next surface of any kind — receiver, mesh interface or analytic interface — along
// o + t·d for t in (t_min, t_max), but for interface `skip` (NO_INTERFACE: none).
fn surface_hit(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32, skip: u32) -> SurfaceHit {
    let b = bvh_closest_hit(o, d, t_min, t_max, select(INTERFACE_BIT | skip, 0xffffffffu, skip == NO_INTERFACE));
    var hit = no_surface(b.t);
    if b.triangle != 0xffffffffu {
        let word = bvh_triangles[b.triangle].receiver;
        let is_interface = (word & INTERFACE_BIT) != 0u;
        let normal = select(bvh_triangle_normal(b.triangle), shading_normal(b.triangle, b.u, b.v), is_interface);
        hit = SurfaceHit(b.t, b.triangle, select(NO_INTERFACE, word & ~INTERFACE_BIT, is_interface), normal, b.u, b.v);
    }
    return analytic_hit(o, d, t_min, hit, skip);
}

// Whether any analytic interface lies along o + t·d, t in (t_min, t_max) (shadow rays).
fn analytic_any_hit(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> bool {
    return analytic_hit(o, d, t_min, no_surface(t_max), NO_INTERFACE).t < t_max;
}

// The solids a path is inside, in the order entered: up to MEDIA_DEPTH interface indices + 1
// (0: an empty slot) in 16 bits each, two to a word — so the set lives in registers, not in
// memory a marching loop would read every step — and the medium that holds there (the one of
// highest rank; NO_INTERFACE in air) with its index and absorption, kept at hand. Lights and
// the camera inside glass start with the media the CPU found around them
// (`pipeline::interfaces::media_at`).
struct Media {
    ids: vec2<u32>,
    depth: u32,
    holder: u32,
    ior: f32,
    absorption: vec3<f32>,
}

fn no_media() -> Media {
    return Media(vec2<u32>(0u), 0u, NO_INTERFACE, 1.0, vec3<f32>(0.0));
}

fn media_id(m: Media, slot: u32) -> u32 {
    return ((m.ids[slot / 2u] >> (16u * (slot % 2u))) & 0xffffu) - 1u;
}

// The medium that holds among m's solids — the highest rank — and its optics.
fn media_top(m: Media) -> Media {
    var out = m;
    out.holder = NO_INTERFACE;
    out.ior = 1.0;
    out.absorption = vec3<f32>(0.0);
    var rank = 0u;
    for (var slot = 0u; slot < out.depth; slot++) {
        let i = media_id(out, slot);
        let f = interfaces[i];
        if out.holder == NO_INTERFACE || f.rank > rank {
            out.holder = i;
            rank = f.rank;
            out.ior = interface_ior(f);
            out.absorption = f.absorption;
        }
    }
    return out;
}

// Media from their packed words (slots filled from the first).
fn media_unpacked(ids: vec2<u32>) -> Media {
    var depth = 0u;
    for (var slot = 0u; slot < MEDIA_DEPTH; slot++) {
        if ((ids[slot / 2u] >> (16u * (slot % 2u))) & 0xffffu) != 0u {
            depth = slot + 1u;
        }
    }
    return media_top(Media(ids, depth, NO_INTERFACE, 1.0, vec3<f32>(0.0)));
}

// The media after crossing interface i: leaving it if the path is inside it, else entering it.
// (Leaving one that is not the last entered closes the gap: the later ones move down a slot.)
fn media_crossed(m: Media, i: u32) -> Media {
    var out = m;
    var found = false;
    for (var slot = 0u; slot < m.depth; slot++) {
        found = found || media_id(m, slot) == i;
        if found && slot + 1u < m.depth {
            out = media_with(out, slot, media_id(m, slot + 1u));
        }
    }
    if found {
        out = media_with(out, m.depth - 1u, NO_INTERFACE);
        out.depth -= 1u;
    } else if m.depth < MEDIA_DEPTH {
        out = media_with(out, m.depth, i);
        out.depth += 1u;
    }
    return media_top(out);
}

// m with interface i in a slot (NO_INTERFACE: emptied).
fn media_with(m: Media, slot: u32, i: u32) -> Media {
    var out = m;
    let shift = 16u * (slot % 2u);
    out.ids[slot / 2u] = (out.ids[slot / 2u] & ~(0xffffu << shift)) | (((i + 1u) & 0xffffu) << shift);
    return out;
}

// An interface's index at the path's wavelength.
fn interface_ior(f: Interface) -> f32 {
    return ior_at(f.ior, f.dispersion, path_wavelength);
}

// The s- and p-polarized Fresnel reflectances (R_s, R_p) for cos θᵢ (> 0) and η = n₂/n₁; both 1
// past the critical angle.
fn fresnel_polarized(cos_i: f32, eta: f32) -> vec2<f32> {
    let c = clamp(cos_i, 0.0, 1.0);
    let sin2_t = (1.0 - c * c) / (eta * eta);
    if sin2_t >= 1.0 {
        return vec2<f32>(1.0);
    }
    let cos_t = sqrt(1.0 - sin2_t);
    let r_parallel = (eta * c - cos_t) / (eta * c + cos_t);
    let r_perpendicular = (c - eta * cos_t) / (c + eta * cos_t);
    return vec2<f32>(r_perpendicular * r_perpendicular, r_parallel * r_parallel);
}

// Unpolarized Fresnel reflectance: the mean of the two polarizations'.
fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let r = fresnel_polarized(cos_i, eta);
    return 0.5 * (r.x + r.y);
}

// A thin sheet's reflectance: per polarization the first reflection and every one leaving after
// inner bounces, 2R / (1 + R), then averaged (the polarizations do not mix inside a pane; the sum
// of the averaged R overshoots, by 0.008 at 55° and 0.022 at 74° for n = 1.5).
fn thin_sheet_reflectance(cos_i: f32, eta: f32) -> f32 {
    let r = fresnel_polarized(cos_i, eta);
    let sheet = 2.0 * r / (1.0 + r);
    return 0.5 * (sheet.x + sheet.y);
}

// KHR_materials_specular on glass: the reflectance R of one surface (a polarization's or the
// mean) reshaped as the spec's Schlick form, F₀′ + (F₉₀′ − F₀′)·w, with F₀′ = min(F₀·colour, 1)
// and F₉₀′ = the factor (both scaled by it), but w = (R − F₀)/(1 − F₀), the exact Fresnel's own
// rise from normal incidence (F₀ = ((η − 1)/(η + 1))²) in place of (1 − cos θ)⁵: with factor 1
// and a white colour it is R itself, exactly. Total internal reflection stays total: no light
// can pass there, whatever the surface's weight.
fn specular_reflectance(r: f32, f0: f32, layer: vec4<f32>) -> vec3<f32> {
    if r >= 1.0 {
        return vec3<f32>(1.0);
    }
    let f0_scaled = min(f0 * layer.rgb, vec3<f32>(1.0));
    let w = (r - f0) / (1.0 - f0);
    return clamp(layer.a * (f0_scaled + (vec3<f32>(1.0) - f0_scaled) * w), vec3<f32>(0.0), vec3<f32>(1.0));
}

// Whether a surface's KHR_materials_specular layer (colour, factor) leaves its Fresnel as it is.
fn plain_specular(layer: vec4<f32>) -> bool {
    return all(layer == vec4<f32>(1.0));
}

// The reflectance of a glass surface of relative index η at cos θᵢ, per channel: a solid's
// surface's Fresnel, or a thin sheet's summed inner reflections (`thin_sheet_reflectance`), each
// reshaped by the surface's specular layer (rgb: colour, a: factor; per polarization on a sheet).
fn glass_reflectance(cos_i: f32, eta: f32, thin: bool, layer: vec4<f32>) -> vec3<f32> {
    if plain_specular(layer) {
        if thin {
            return vec3<f32>(thin_sheet_reflectance(cos_i, eta));
        }
        return vec3<f32>(fresnel_dielectric(cos_i, eta));
    }
    let f0 = (eta - 1.0) * (eta - 1.0) / ((eta + 1.0) * (eta + 1.0));
    let r = fresnel_polarized(cos_i, eta);
    if !thin {
        return specular_reflectance(0.5 * (r.x + r.y), f0, layer);
    }
    let s = specular_reflectance(r.x, f0, layer);
    let p = specular_reflectance(r.y, f0, layer);
    return 0.5 * (2.0 * s / (1.0 + s) + 2.0 * p / (1.0 + p));
}

// What happens at one crossing: both outgoing directions, the reflectance R (1 under total
// internal reflection, when `transmitted` is meaningless), the transmitted branch's tint, the
// media on the far side of the surface, and the share of each branch a rough surface's microfacets let through
// (Smith's masking G₁ of the outgoing direction, divided by the surface's albedo E: 1 on a
// polished surface, 0 where the sampled microfacet sent the light back into the surface).
struct Crossing {
    reflected: vec3<f32>,
    transmitted: vec3<f32>,
    reflectance: f32,
    tint: vec3<f32>,
    beyond: Media,
    // The true surface's normal (a mesh's triangle, not the interpolated one) facing it.
    geometric: vec3<f32>,
    // The shading normal facing it (before a rough surface's microfacet), and the relative
    // index η = n beyond / n before that the crossing refracts by.
    normal: vec3<f32>,
    eta: f32,
    reflected_share: f32,
    transmitted_share: f32,
    // 1 / E, the rough surface's albedo (shared/rough_albedo.wgsl) the shares are divided by; 1
    // on a polished one. What weighs light sampled through the crossing alike (`rough_lobe`).
    energy: f32,
    // How far along the incoming direction the last surface crossed lies (a contact partner's;
    // 0 for one surface): the transmitted branch starts past it (`crossing_exit`).
    through: f32,
    // Whether light sees a surface here at all: not where the same medium, or one of the same
    // index, holds on both sides (a wall inside the liquid that overlaps it), nor where a sheet
    // is cut away (`sheet_coverage`). Such a crossing passes straight and counts as no event.
    seen: bool,
    // The share of the light that meets the surface's diffuse base (KHR_materials_transmission:
    // what enters and is not transmitted, coloured by the base colour; the view's `base_branch`).
    base: vec3<f32>,
    // The colour of the reflected light, per unit of `reflectance` (1 but for metal).
    reflected_tint: vec3<f32>,
}

// An orthonormal basis (t, b, n) around unit n (Duff et al. 2017, "Building an Orthonormal
// Basis, Revisited").
fn basis_around(n: vec3<f32>) -> mat3x3<f32> {
    let s = sign(n.z) + f32(n.z == 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    return mat3x3<f32>(vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x), vec3<f32>(b, s + n.y * n.y * a, -n.y), n);
}

// A microfacet normal of a GGX surface of roughness α seen from unit w (local frame, normal +z,
// w.z > 0), drawn from the distribution of visible normals D_w(m) = G₁(w) max(0, w·m) D(m) / w.z
// by two uniform numbers u (Heitz 2018, "Sampling the GGX Distribution of Visible Normals").
fn ggx_visible_normal(w: vec3<f32>, alpha: f32, u: vec2<f32>) -> vec3<f32> {
    // Stretch to the hemisphere configuration, sample the projected disc, unstretch.
    let vh = normalize(vec3<f32>(alpha * w.x, alpha * w.y, w.z));
    let len2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(-vh.y, vh.x, 0.0) * inverseSqrt(len2), len2 > 0.0);
    let t2 = cross(vh, t1);
    let r = sqrt(u.x);
    let phi = 6.283185307 * u.y;
    let p1 = r * cos(phi);
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * sqrt(1.0 - p1 * p1) + s * r * sin(phi);
    let nh = p1 * t1 + p2 * t2 + sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh;
    return normalize(vec3<f32>(alpha * nh.x, alpha * nh.y, max(1e-6, nh.z)));
}

// What a crossing sees of an interface's surface where it is met: the tint of the light passed
// and the GGX roughness — the record's factors, times its textures on a textured glass mesh
// (shared/glass_surface.wgsl).
struct GlassSurface {
    tint: vec3<f32>,
    roughness: f32,
    // Radiance it gives off from its front (`Glass::emission`): seen by view rays only.
    emission: vec3<f32>,
    // The outward normal crossings refract and reflect about: the hit's, bent by a normal map.
    normal: vec3<f32>,
    // The fraction of the light entering the surface that passes it (KHR_materials_transmission);
    // the rest meets a diffuse base of `base_color` (the view's `base_branch`).
    transmission: f32,
    // How much of a thin sheet is there (`sheet_coverage`): 0 where a MASK cuts it away, alpha
    // where it BLENDs, else 1; the rest passes unchanged.
    coverage: f32,
    // How much of the surface is metal (glTF's metallic): it reflects by Schlick's Fresnel from
    // the base colour and passes nothing (`surface_split`).
    metallic: f32,
    // The colour of the diffuse base and the metal: glTF's base colour, the tint but where a
    // Principled BSDF's glass is tinted by the root of it (`Glass::base_color`).
    base_color: vec3<f32>,
    // KHR_materials_specular: the colour scaling F₀ in rgb, the factor in a
    // (`specular_reflectance`); all 1: the Fresnel equations alone.
    specular: vec4<f32>,
}

// The coverage of a sheet of interface f whose alpha is `alpha` where it is met (glTF's alpha
// modes; a solid, or a sheet without one, is all there).
fn sheet_coverage(f: Interface, alpha: f32) -> f32 {
    if (f.kind & INTERFACE_ALPHA_MASK) != 0u {
        return select(0.0, 1.0, alpha >= f.alpha_cutoff);
    }
    if (f.kind & INTERFACE_ALPHA_BLEND) != 0u {
        return clamp(alpha, 0.0, 1.0);
    }
    return 1.0;
}

// What a polished sheet of reflectance R (per channel) passes straight through where it is met:
// of the part that is there and not metal, (1 − R) × tint × transmission; the rest, where it is
// cut away, unchanged.
fn sheet_passes(surface: GlassSurface, r: vec3<f32>) -> vec3<f32> {
    return surface.coverage * (1.0 - surface.metallic) * (vec3<f32>(1.0) - r) * surface.tint * surface.transmission + vec3<f32>(1.0 - surface.coverage);
}

// How a surface splits the light that meets it at cos θ = c from the facet's normal, where the
// glass alone reflects R (per channel: a specular colour tints it) (glTF's metallic-roughness model with
// KHR_materials_transmission): the metal (`metallic` of it) reflects Schlick's F from the base
// colour at c; the glass reflects R and of the rest passes `transmission` (tinted)
// into the glass or through the sheet and sends the remainder to its diffuse base; where a sheet
// is cut away (1 − coverage) the light passes unchanged.
struct SurfaceSplit {
    reflected: vec3<f32>,
    passed: vec3<f32>,
    base: vec3<f32>,
}

fn surface_split(surface: GlassSurface, r: vec3<f32>, c: f32) -> SurfaceSplit {
    let x = 1.0 - clamp(c, 0.0, 1.0);
    let x2 = x * x;
    let metal = surface.base_color + (vec3<f32>(1.0) - surface.base_color) * (x2 * x2 * x);
    let glass = surface.coverage * (1.0 - surface.metallic);
    let reflected = glass * r + surface.coverage * surface.metallic * metal;
    let base = glass * (vec3<f32>(1.0) - r) * (1.0 - surface.transmission) * surface.base_color;
    return SurfaceSplit(reflected, sheet_passes(surface, r), base);
}

// The surface of the interface met at `hit` by its factors alone (analytic shapes, untextured
// meshes).
fn plain_surface(hit: SurfaceHit) -> GlassSurface {
    let f = interfaces[hit.interface_id];
    // (A sheet glows where it is there.)
    let coverage = sheet_coverage(f, f.alpha);
    return GlassSurface(f.tint, f.roughness, f.emission * coverage, hit.normal, f.transmission, coverage, f.metallic, f.base_color,
                        vec4<f32>(f.specular_color, f.specular));
}

// Smith's masking for GGX of a direction at cos θ = c from the normal (c > 0):
// G₁ = 2 / (1 + √(1 + α² tan²θ)).
fn smith_g1(c: f32, alpha: f32) -> f32 {
    let c2 = max(c * c, 1e-12);
    return 2.0 / (1.0 + sqrt(1.0 + alpha * alpha * (1.0 - c2) / c2));
}

// Another solid's surface within the contact distance of interface `hit` met at p along d — a
// liquid against its glass — ahead of p, or behind by no more than rounding: it is crossed with
// `hit` as one interface. The distance is the gap's, across it: along a ray at θ from the
// normal a gap is 1/cos θ longer (up to 16 times: grazing rays search 16 contact distances).
// NO_INTERFACE when there is none (`interfaces::table` sets `contact` to 0 on a solid that no
// other comes that near).
fn contact_partner(p: vec3<f32>, d: vec3<f32>, hit: SurfaceHit) -> SurfaceHit {
    let gap = interfaces[hit.interface_id].contact;
    var partner = no_surface(0.0);
    if gap > 0.0 {
        var normal = hit.normal;
        if hit.triangle != 0xffffffffu {
            normal = bvh_triangle_normal(hit.triangle);
        }
        let reach = gap / max(abs(dot(d, normal)), 1.0 / 16.0);
        // (From 1 % of the gap behind p: a coincident surface may round to either side.)
        let back = 0.01 * gap;
        partner = surface_hit(p - d * back, d, 0.0, back + reach, hit.interface_id);
        partner.t -= back;
        if partner.interface_id != NO_INTERFACE && (interfaces[partner.interface_id].kind & INTERFACE_THIN) != 0u {
            partner.interface_id = NO_INTERFACE;
        }
    }
    return partner;
}

// The crossing of interface `hit` at p, whose surface there is `surface`, by direction d from
// `media`, with two uniform numbers u that pick a microfacet on a rough surface (unused on a
// polished one). A solid's surface refracts
// into the medium beyond; a thin sheet reflects the Fresnel of a thin slab summed over its
// inner reflections (2R / (1 + R) per polarization, averaged), and passes the rest straight through — the light
// refracted in and back out leaves parallel to how it came (on a rough sheet: the reflection
// mirrored through the sheet, as glTF's thin-walled transmission has it).
fn cross_interface(p: vec3<f32>, d: vec3<f32>, hit: SurfaceHit, surface: GlassSurface, media: Media, u: vec2<f32>) -> Crossing {
    let f = interfaces[hit.interface_id];
    let thin = (f.kind & INTERFACE_THIN) != 0u;
    // A sheet's far side is the medium it stands in; its own glass sets the reflectance.
    var beyond = media;
    var eta = interface_ior(f) / media.ior;
    if f.dispersion > 0.0 && path_wavelength > 0.0 {
        path_dispersed = true;
    }
    var through = 0.0;
    if !thin {
        beyond = media_crossed(media, hit.interface_id);
        let partner = contact_partner(p, d, hit);
        if partner.interface_id != NO_INTERFACE {
            beyond = media_crossed(beyond, partner.interface_id);
            through = max(partner.t, 0.0);
        }
        eta = beyond.ior / media.ior;
    }
    var geometric = hit.normal;
    if hit.triangle != 0xffffffffu {
        geometric = bvh_triangle_normal(hit.triangle);
    }
    geometric = select(geometric, -geometric, dot(geometric, d) > 0.0);
    let n = select(surface.normal, -surface.normal, dot(surface.normal, d) > 0.0);
    // (Where the index does not change — tinted glass of index 1, a liquid of its glass's index —
    // the crossing below bends and reflects nothing but still tints.)
    if (!thin && beyond.holder == media.holder) || surface.coverage <= 0.0 {
        return Crossing(d, d, 0.0, vec3<f32>(1.0), beyond, geometric, n, eta, 1.0, 1.0, 1.0, through, false, vec3<f32>(0.0), vec3<f32>(1.0));
    }
    let alpha = surface.roughness * surface.roughness;
    var m = n;
    if alpha > 0.0 {
        let frame = basis_around(n);
        m = frame * ggx_visible_normal(-d * frame, alpha, u);
    }
    let cos_i = -dot(d, m);
    let reflectances = glass_reflectance(cos_i, eta, thin, surface.specular);
    var reflectance = reflectances.r;
    let reflected = d + 2.0 * cos_i * m;
    var transmitted = reflected;
    // (Refracted wherever the index allows it: a specular colour may raise one channel's
    // reflectance to 1 where the others still pass.)
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if thin {
        transmitted = reflected - 2.0 * dot(reflected, n) * n;
    } else if sin2_t < 1.0 {
        let cos_t = sqrt(1.0 - sin2_t);
        transmitted = normalize(d / eta + (cos_i / eta - cos_t) * m);
    }
    var reflected_share = 1.0;
    var transmitted_share = 1.0;
    var energy = 1.0;
    if alpha > 0.0 {
        let cr = dot(reflected, n);
        let ct = -dot(transmitted, n);
        // The light a single microfacet loses to masking, kept (albedo scaling) — unless the
        // glass asks for single-scattering GGX.
        if (interfaces[hit.interface_id].kind & INTERFACE_SINGLE_SCATTERING) == 0u {
            energy = 1.0 / max(rough_albedo(-dot(d, n), surface.roughness, eta, thin), 0.05);
        }
        reflected_share = smith_g1(max(cr, 0.0), alpha) * step(0.0, cr) * energy;
        transmitted_share = smith_g1(max(ct, 0.0), alpha) * step(0.0, ct) * energy;
    }
    var tint = surface.tint * surface.transmission;
    var reflected_tint = vec3<f32>(1.0);
    if surface.coverage < 1.0 || surface.metallic > 0.0 || !plain_specular(surface.specular) {
        // Metal (coloured reflection, nothing passed), a sheet partly there (alpha BLEND: the
        // rest passes unchanged) or a specular colour, folded into one reflectance (the mean over
        // the channels), the colour of what it reflects and the tint of what passes, so photons,
        // view branches and shadow rays (`sheet_passes`) agree. (Exact on polished glass; a rough
        // sheet partly there sends what passes its uncovered part along the microfacet's direction.)
        let split = surface_split(surface, reflectances, cos_i);
        let r = (split.reflected.r + split.reflected.g + split.reflected.b) / 3.0;
        reflected_tint = split.reflected / max(r, 1e-6);
        tint = split.passed / max(1.0 - r, 1e-6);
        reflectance = r;
        return Crossing(reflected, transmitted, reflectance, tint, beyond, geometric, n, eta, reflected_share, transmitted_share, energy, through, true, split.base, reflected_tint);
    }
    let base = (1.0 - reflectance) * (1.0 - surface.transmission) * surface.base_color;
    return Crossing(reflected, transmitted, reflectance, tint, beyond, geometric, n, eta, reflected_share, transmitted_share, energy, through, true, base, reflected_tint);
}

// The media of a branch that leaves crossing c along w: the media beyond only if w passes
// through the true surface. Interpolated normals can send a branch to the other side of the
// triangle than its name says (a reflection into the glass, a refraction back out); the stack
// must follow the side the path is on, where the next surface it meets will see it — as
// renderers without a stack (Mitsuba's dielectric) decide by that side. (Before: the glass bunny
// with smooth normals disagreed in ~2 % of crossings, and its caustic came out ~2 % bright.)
fn media_along(c: Crossing, w: vec3<f32>, media: Media) -> Media {
    if dot(w, c.geometric) < 0.0 {
        return c.beyond;
    }
    return media;
}

// A point just off the surface on the side a new direction w leaves to, so the next query
// does not find the same surface again (`facing`: the true surface's normal, `Crossing.geometric`).
fn leave_surface(p: vec3<f32>, facing: vec3<f32>, w: vec3<f32>, eps: f32) -> vec3<f32> {
    return p + select(-facing, facing, dot(w, facing) > 0.0) * eps;
}

// Where a branch leaving crossing c (met at p along d) along w starts: just off the surface,
// and past every surface the crossing took when w goes through it.
fn crossing_exit(c: Crossing, p: vec3<f32>, d: vec3<f32>, w: vec3<f32>, eps: f32) -> vec3<f32> {
    let past = select(0.0, c.through, dot(w, c.geometric) < 0.0);
    return leave_surface(p + d * past, c.geometric, w, eps);
}

// The surface ahead of a marching path: `hit` along the straight line from `origin` (the BVH and
// the analytic interfaces), valid while the path has not bent since it was cast. Casting the
// BVH costs a traversal, so after a bend it waits until a step could reach the BVH's box;
// analytic interfaces are cheap and checked within every step meanwhile.
struct Lookahead {
    origin: vec3<f32>,
    hit: SurfaceHit,
    valid: bool,
}

fn look_from(x: vec3<f32>, d: vec3<f32>) -> Lookahead {
    return Lookahead(x, surface_hit(x, d, 0.0, 3.4e38, NO_INTERFACE), true);
}

// Distance from x0 along d to the next surface if it lies within `jump` (then `la.hit` is that
// surface); 3.4e38 otherwise.
fn surface_within(la: ptr<function, Lookahead>, x0: vec3<f32>, d: vec3<f32>, jump: f32) -> f32 {
    if (*la).valid {
        return (*la).hit.t - dot(x0 - (*la).origin, d);
    }
    if bvh_may_hit(x0, d, jump) {
        *la = look_from(x0, d);
        return (*la).hit.t;
    }
    let h = analytic_hit(x0, d, 0.0, no_surface(jump), NO_INTERFACE);
    if h.t < jump {
        (*la).origin = x0;
        (*la).hit = h;
        return h.t;
    }
    return 3.4e38;
}

// The surface ahead of x along d once a path stops marching (it left the grid).
fn surface_after(la: ptr<function, Lookahead>, x: vec3<f32>, d: vec3<f32>) -> SurfaceHit {
    if !(*la).valid {
        *la = look_from(x, d);
    }
    var hit = (*la).hit;
    hit.t -= dot(x - (*la).origin, d);
    return hit;
}
