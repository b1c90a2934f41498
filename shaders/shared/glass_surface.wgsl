// A glass mesh's textured surface (scene::Glass's roughness, tint, emission, normal and
// transmission textures, glTF's metallic-roughness, base colour, emissive, normal and
// transmission textures on a transmissive material): the roughness is the factor times the
// metallic-roughness texture's green channel, the tint the factor times the base colour texture,
// the normal the mesh's bent by the normal map, the transmission the factor times the
// transmission texture's red channel, each where the ray or photon meets the surface — so one
// object can be clear in one place and frosted in another, and a flat water surface can ripple.
// The medium inside (index, absorption) is one per object. Analytic shapes and meshes without
// texture coordinates keep the factors and their own normals.
//
// Expects the stage to declare `interfaces`, and what shared/texture.wgsl needs; to import
// types and interface.

#import shared/texture.wgsl

// What a caller needs beyond the roughness, tint and transmission every crossing reads: each
// call site passes a constant, so the lookups it does not need are compiled out (lavapipe
// inlines every call site anew; a shadow ray's sheet needs neither).
const SURFACE_NORMAL: u32 = 1u;
const SURFACE_EMISSION: u32 = 2u;

fn glass_surface_at(hit: SurfaceHit, parts: u32) -> GlassSurface {
    let f = interfaces[hit.interface_id];
    var s = plain_surface(hit);
    let textured = has_texture(f.roughness_texture) || has_texture(f.tint_texture) || has_texture(f.emission_texture) || has_texture(f.normal_texture)
        || has_texture(f.transmission_texture) || has_texture(f.specular_texture) || has_texture(f.specular_color_texture);
    if hit.triangle == 0xffffffffu || !textured {
        return s;
    }
    let uv = hit_uv(hit.triangle, hit.u, hit.v);
    if has_texture(f.roughness_texture) {
        // glTF's metallic-roughness texture: roughness in green, metallic in blue.
        let mr = texture_at(f.roughness_texture, uv);
        s.roughness = clamp(s.roughness * mr.g, 0.0, 1.0);
        s.metallic *= mr.b;
    }
    if has_texture(f.tint_texture) {
        // (Its alpha cuts a sheet: glTF's base colour alpha.)
        let c = texture_at(f.tint_texture, uv);
        s.tint *= c.rgb;
        s.base_color *= c.rgb;
        s.coverage = sheet_coverage(f, f.alpha * c.a);
        s.emission = f.emission * s.coverage;
    }
    if has_texture(f.transmission_texture) {
        s.transmission *= texture_at(f.transmission_texture, uv).r;
    }
    if has_texture(f.specular_texture) {
        // (KHR_materials_specular keeps its factor in the texture's alpha.)
        s.specular.a *= texture_at(f.specular_texture, uv).a;
    }
    if has_texture(f.specular_color_texture) {
        s.specular = vec4<f32>(s.specular.rgb * texture_at(f.specular_color_texture, uv).rgb, s.specular.a);
    }
    if (parts & SURFACE_EMISSION) != 0u && has_texture(f.emission_texture) {
        s.emission *= texture_at(f.emission_texture, uv).rgb;
    }
    if (parts & SURFACE_NORMAL) != 0u {
        s.normal = bent_normal(hit.normal, f.normal_texture, f.normal_scale, hit.triangle, uv);
    }
    return s;
}
