// The energy a rough glass surface keeps (src/pipeline/rough_albedo.rs, its CPU twin and the
// table's maker): E(θᵢ, α, η), the expected weight of a single GGX microfacet crossing's two
// branches, by which `cross_interface` divides them (albedo scaling: the light the masking term
// loses is what a real microsurface scatters again, as Cycles' Multiscatter GGX keeps it).
// Expects the stage to bind `rough_albedo_table: array<f32>`.

const ROUGH_ALBEDO_COS: u32 = 20u;
const ROUGH_ALBEDO_ROUGHNESS: u32 = 12u;
const ROUGH_ALBEDO_ETA: u32 = 25u;
const ROUGH_ALBEDO_ETA_SPAN: f32 = 3.0;

// Node index and weight of x in [0, 1] over n nodes.
fn rough_albedo_place(x: f32, n: u32) -> vec2<f32> {
    let f = clamp(x, 0.0, 1.0) * f32(n - 1u);
    let i = min(floor(f), f32(n - 2u));
    return vec2<f32>(i, f - i);
}

// The table's slab e, bilinear in (√cos θᵢ, roughness).
fn rough_albedo_slab(e: u32, c: vec2<f32>, r: vec2<f32>) -> f32 {
    let base = (e * ROUGH_ALBEDO_ROUGHNESS + u32(r.x)) * ROUGH_ALBEDO_COS + u32(c.x);
    let row0 = mix(rough_albedo_table[base], rough_albedo_table[base + 1u], c.y);
    let row1 = mix(rough_albedo_table[base + ROUGH_ALBEDO_COS], rough_albedo_table[base + ROUGH_ALBEDO_COS + 1u], c.y);
    return mix(row0, row1, r.y);
}

// E at cos θᵢ (from the normal on the incident side), roughness (√α), η = n beyond / n before;
// a thin sheet's E does not depend on η. Trilinear in (√cos θᵢ, roughness, ln η).
fn rough_albedo(cos_i: f32, roughness: f32, eta: f32, thin: bool) -> f32 {
    let c = rough_albedo_place(sqrt(max(cos_i, 0.0)), ROUGH_ALBEDO_COS);
    let r = rough_albedo_place(roughness, ROUGH_ALBEDO_ROUGHNESS);
    if thin {
        return rough_albedo_slab(ROUGH_ALBEDO_ETA, c, r);
    }
    let e = rough_albedo_place(0.5 + 0.5 * log(eta) / log(ROUGH_ALBEDO_ETA_SPAN), ROUGH_ALBEDO_ETA);
    return mix(rough_albedo_slab(u32(e.x), c, r), rough_albedo_slab(u32(e.x) + 1u, c, r), e.y);
}
