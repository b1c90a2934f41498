// A glass mesh's textured surface (scene::Glass's roughness and tint textures, glTF's
// metallic-roughness and base colour textures on a transmissive material): the roughness is the
// factor times the metallic-roughness texture's green channel, the tint the factor times the
// base colour texture, each where the ray or photon meets the surface — so one object can be
// clear in one place and frosted in another. The medium inside (index, absorption) is one per
// object. Analytic shapes and meshes without texture coordinates keep the factors.
//
// Expects the stage to declare `interfaces`, and what shared/texture.wgsl needs; to import
// types and interface.

#import shared/texture.wgsl

fn glass_surface_at(hit: SurfaceHit) -> GlassSurface {
    let f = interfaces[hit.interface_id];
    var s = plain_surface(hit.interface_id);
    if hit.triangle == 0xffffffffu || !(has_texture(f.roughness_texture) || has_texture(f.tint_texture) || has_texture(f.emission_texture)) {
        return s;
    }
    let uv = hit_uv(hit.triangle, hit.u, hit.v);
    if has_texture(f.roughness_texture) {
        s.roughness = clamp(s.roughness * texture_at(f.roughness_texture, uv).g, 0.0, 1.0);
    }
    if has_texture(f.tint_texture) {
        s.tint *= texture_at(f.tint_texture, uv).rgb;
    }
    if has_texture(f.emission_texture) {
        s.emission *= texture_at(f.emission_texture, uv).rgb;
    }
    return s;
}
