//! Materials: what a shape is made of. Glass (and any refractive or absorbing medium) goes into
//! the index volume; diffuse surfaces are opaque receivers of direct and caustic light.

use std::sync::Arc;

use glam::{Vec2, Vec3};

/// A refractive or absorbing medium: index, absorption (Beer–Lambert), scattering.
#[derive(Clone, Debug, PartialEq)]
pub struct Glass {
    pub ior: f32,
    /// Absorption coefficient per metre, per channel.
    pub absorption: Vec3,
    /// Scattering coefficient per metre, per channel.
    pub scattering: Vec3,
    /// Henyey–Greenstein anisotropy of the scattering, in (−1, 1).
    pub g: f32,
    /// Multiplies the light transmitted through each crossing of the surface, linear rgb in
    /// [0, 1] (KHR_materials_transmission's base colour: coloured glass whose colour does not
    /// deepen with thickness — that is `absorption`). Applies at sharp interfaces.
    pub tint: Vec3,
    /// GGX roughness of the surface, 0 (polished) to 1 (KHR_materials_transmission's roughness,
    /// α = roughness²): frosted glass blurs what it refracts and reflects. Sharp interfaces only.
    pub roughness: f32,
    /// A thin sheet (a window pane, a soap film): light crossing it is reflected by the Fresnel
    /// of a thin slab or goes straight through, tinted; it has no inside. `None`: decided by the
    /// mesh (closed: a solid; open and flat: a sheet; open and curved: a voxelized solid — the
    /// last two with a warning that it was a guess).
    pub thin: Option<bool>,
    /// Dispersion as KHR_materials_dispersion writes it: 20/V_d, V_d the Abbe number; 0 is
    /// none. The index at wavelength λ is then n(λ) = max(n + (n − 1)·dispersion/20 ·
    /// (523655/λ² − 1.5168), 1) (`cpu::spectrum::ior_at`); gradient-index media disperse the
    /// same way around their local n. Any dispersion in a frame makes its light spectral.
    pub dispersion: f32,
    /// A metallic-roughness texture (glTF): its green channel multiplies `roughness` where a
    /// ray meets the surface — a sharp mesh with texture coordinates only.
    pub roughness_texture: Option<Arc<Texture2d>>,
    /// A base colour texture (glTF, sRGB): its rgb multiplies `tint` where a ray crosses the
    /// surface — a sharp mesh with texture coordinates only.
    pub tint_texture: Option<Arc<Texture2d>>,
    /// Which medium holds where solids overlap (a liquid modelled into its glass's wall): the
    /// higher priority; at equal priority, the smaller object. Like the dielectric priority of
    /// Arnold and Redshift, with higher numbers winning. Sharp interfaces only.
    pub priority: i32,
    /// Whether a rough crossing keeps the light a single microfacet loses to masking (each
    /// crossing divided by its single-scattering albedo, `pipeline::rough_albedo`), as Cycles'
    /// *Multiscatter GGX* keeps it; false: single-scattering GGX (Cycles' *GGX*, the glTF Sample
    /// Viewer), darker the rougher it is — a fully rough ball loses about a tenth of its light.
    pub multiscatter: bool,
    /// Light the surface gives off, radiance per channel (glTF's emissive × emissive strength on
    /// a transmissive material: a lamp's glowing shade): seen where a ray meets the surface from
    /// its front (either side of a thin sheet), and lighting the scene as a glowing receiver of
    /// it would (`pipeline::mesh_lights`: a sharp glass mesh; an analytic shape lights nothing).
    /// Before `emission_strength`.
    pub emission: Vec3,
    /// Multiplies `emission` (KHR_materials_emissive_strength; Blender's Emission Strength),
    /// kept apart so either can be keyed.
    pub emission_strength: f32,
    /// An emissive texture (glTF, sRGB): its rgb multiplies `emission` — a sharp mesh with
    /// texture coordinates only.
    pub emission_texture: Option<Arc<Texture2d>>,
    /// A tangent-space normal map (glTF's convention: linear, +Y toward decreasing v): it bends
    /// the normal each ray and photon refracts and reflects about where it crosses the surface —
    /// ripples on a water surface, hammered or fluted glass — while the medium inside keeps the
    /// mesh's shape. A sharp mesh with texture coordinates only.
    pub normal_texture: Option<Arc<Texture2d>>,
    /// Scales the normal map's x and y (glTF's `normalTexture.scale`): 0 flattens it.
    pub normal_scale: f32,
    /// The fraction of the light entering the surface that is transmitted, 0 to 1
    /// (KHR_materials_transmission's transmissionFactor); the rest meets the material's base
    /// beneath its reflection, a diffuse surface of the base colour (`base`), lit
    /// where the camera sees it. 1: all glass.
    pub transmission: f32,
    /// A transmission texture (glTF, linear): its red channel multiplies `transmission` — glass
    /// with an opaque pattern in it. A sharp mesh with texture coordinates only.
    pub transmission_texture: Option<Arc<Texture2d>>,
    /// How much of a thin sheet is there (glTF's base colour alpha, times the tint texture's
    /// alpha), read as `alpha_mode` says: `Mask` cuts the sheet away where alpha is below
    /// `alpha_cutoff` (a leaded pane's clear openings, a cut-out decal), `Blend` keeps the
    /// fraction alpha of it and lets the rest through unchanged. Solid glass ignores it (warned).
    pub alpha: f32,
    pub alpha_mode: AlphaMode,
    pub alpha_cutoff: f32,
    /// How much of the surface is metal, 0 to 1 (glTF's metallicFactor × the metallic-roughness
    /// texture's blue channel where light meets it): the metal reflects with Schlick's Fresnel
    /// from the base colour (`base`) and passes nothing; the rest is the glass.
    pub metallic: f32,
    /// The colour of the diffuse base (what `transmission` does not pass) and of the metal part,
    /// where it is not the tint: a Principled BSDF's Base Color, whose glass Cycles tints by its
    /// square root at each surface (the add-on writes that root as `extras.refrakt.tint`). None:
    /// the tint, as glTF's one base colour is both. The tint texture multiplies it too.
    pub base_color: Option<Vec3>,
    /// KHR_materials_specular's specular factor, 0 to 1 (Blender's Specular IOR Level, twice
    /// it): how strongly the glass reflects, at every angle — 0 reflects nothing and passes all.
    /// With `specular_color` it reshapes the Fresnel reflectance of the glass's index
    /// (`glass_reflectance` in shaders/shared/interface.wgsl): R′ = specular · (F₀′ + (1 − F₀′)·w),
    /// F₀′ = min(F₀ · specular_color, 1), where w = (R − F₀)/(1 − F₀) is the exact Fresnel's own
    /// rise from its normal-incidence F₀ — the spec's Schlick form with Fresnel's angular shape;
    /// 1 and white give R itself. Total internal reflection stays total. What the surface does
    /// not reflect it passes (or sends to its diffuse base).
    pub specular: f32,
    /// KHR_materials_specular's specular colour: scales the normal-incidence reflectance F₀ per
    /// channel (up to F₀′ = 1), so the reflection is coloured and the light passed the complement.
    pub specular_color: Vec3,
    /// A specular texture (glTF, linear): its alpha multiplies `specular`. A sharp mesh with
    /// texture coordinates only.
    pub specular_texture: Option<Arc<Texture2d>>,
    /// A specular colour texture (glTF, sRGB): its rgb multiplies `specular_color`. Likewise.
    pub specular_color_texture: Option<Arc<Texture2d>>,
}

impl Glass {
    /// The colour of the diffuse base and the metal part (`base_color`, else the tint).
    pub fn base(&self) -> Vec3 {
        self.base_color.unwrap_or(self.tint)
    }

    /// The absorption coefficient (per metre, per channel) of a medium that turns white light
    /// `color` after `distance` metres: Beer–Lambert, σ = −ln(color) / distance (glTF's
    /// attenuation color and distance). `None` unless each component is in (0, 1].
    pub fn absorption_from(color: Vec3, distance: f32) -> Option<Vec3> {
        (color.min_element() > 0.0 && color.max_element() <= 1.0).then(|| -Vec3::new(color.x.ln(), color.y.ln(), color.z.ln()) / distance)
    }

    /// Whether its index differs from air's enough to bend light (n − 1 beyond
    /// `photons::EPS_REFRACT`, the kernels' own test): glass that does not renders as air.
    pub fn refracts(&self) -> bool {
        (self.ior - 1.0).abs() > crate::pipeline::photons::EPS_REFRACT
    }

    /// The emitted radiance at full texture: `emission × emission_strength`.
    pub fn emitted(&self) -> Vec3 {
        self.emission * self.emission_strength
    }

    /// Its textures in the order the interface record holds them: roughness, tint, emission,
    /// normal map, transmission, specular, specular colour (`pipeline::interfaces::GlassTextures`).
    pub fn textures(&self) -> [&Option<Arc<Texture2d>>; 7] {
        [
            &self.roughness_texture,
            &self.tint_texture,
            &self.emission_texture,
            &self.normal_texture,
            &self.transmission_texture,
            &self.specular_texture,
            &self.specular_color_texture,
        ]
    }

    /// Whether KHR_materials_specular changes its reflectance (a factor or colour other than 1,
    /// or a texture of either).
    pub fn has_specular(&self) -> bool {
        self.specular != 1.0 || self.specular_color != Vec3::ONE || self.specular_texture.is_some() || self.specular_color_texture.is_some()
    }

    /// Whether it carries any texture.
    pub fn textured(&self) -> bool {
        self.textures().iter().any(|t| t.is_some())
    }

    /// Whether it colours the light that crosses it (a tint or a tint texture).
    pub fn tinted(&self) -> bool {
        self.tint != Vec3::ONE || self.tint_texture.is_some()
    }

    /// The fraction of a sheet that its alpha leaves there, over its whole tint texture (the
    /// shaders' `sheet_coverage` of alpha × the texture's alpha, averaged over the texels; the
    /// factor alone without one). A solid is all there (`thin` false).
    pub fn mean_coverage(&self, thin: bool) -> f32 {
        let coverage = |alpha: f32| match self.alpha_mode {
            AlphaMode::Opaque => 1.0,
            AlphaMode::Mask => if alpha >= self.alpha_cutoff { 1.0 } else { 0.0 },
            AlphaMode::Blend => alpha.clamp(0.0, 1.0),
        };
        match &self.tint_texture {
            _ if !thin => 1.0,
            Some(t) if !t.texels.is_empty() => t.texels.iter().map(|c| coverage(self.alpha * c[3])).sum::<f32>() / t.texels.len() as f32,
            _ => coverage(self.alpha),
        }
    }
}

impl Default for Glass {
    fn default() -> Self {
        Self { ior: 1.5, absorption: Vec3::ZERO, scattering: Vec3::ZERO, g: 0.0, tint: Vec3::ONE, roughness: 0.0, thin: None, dispersion: 0.0,
               roughness_texture: None, tint_texture: None, priority: 0, multiscatter: true, emission: Vec3::ZERO, emission_strength: 1.0,
               emission_texture: None, normal_texture: None, normal_scale: 1.0, transmission: 1.0, transmission_texture: None, alpha: 1.0,
               alpha_mode: AlphaMode::Opaque, alpha_cutoff: 0.5, metallic: 0.0, base_color: None, specular: 1.0, specular_color: Vec3::ONE,
               specular_texture: None, specular_color_texture: None }
    }
}

/// The sRGB transfer function, inverted (IEC 61966-2-1): an encoded value in [0, 1] to linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// A linear-light RGBA texture, row 0 at the top (glTF's convention for UV (0, 0)), and how it
/// continues beyond [0, 1] along u and v (its glTF sampler's wrapS and wrapT).
#[derive(Debug, PartialEq)]
pub struct Texture2d {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[f32; 4]>,
    pub wrap: [Wrap; 2],
}

/// A texture's addressing beyond [0, 1] (glTF 2.0 §5.26, the OpenGL modes it names).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Wrap {
    /// REPEAT (10497, the default): the image tiles.
    #[default]
    Repeat,
    /// CLAMP_TO_EDGE (33071): the edge texels go on.
    Clamp,
    /// MIRRORED_REPEAT (33648): the image tiles, every other tile mirrored.
    Mirror,
}

impl Wrap {
    /// A texture coordinate brought into [0, 1]: repeated, clamped, or mirrored in odd tiles.
    pub fn coordinate(self, x: f32) -> f32 {
        let f = x - x.floor();
        match self {
            Wrap::Repeat => f,
            Wrap::Clamp => x.clamp(0.0, 1.0),
            Wrap::Mirror if (x.floor() as i64).rem_euclid(2) == 1 => 1.0 - f,
            Wrap::Mirror => f,
        }
    }

    /// Texel `i` of a row of `n` (a bilinear footprint reaches one texel past either edge):
    /// the same texel one period on, the edge texel, or its mirror image past the edge.
    pub fn texel(self, i: i64, n: i64) -> i64 {
        match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Clamp => i.clamp(0, n - 1),
            Wrap::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m < n { m } else { 2 * n - 1 - m }
            }
        }
    }
}

// Equality of the data, and (as `Eq`) equal to itself: `Arc<Texture2d>`'s == then checks the pointer
// first, so the stage-reuse keys and `FrameDesc::share_unchanged` compare shared data for free.
// (Its floats are checked finite before they reach the GPU.)
impl Eq for Texture2d {}

impl Texture2d {
    /// The texture at half its resolution (rounded up): each texel the mean of the 2 × 2 it
    /// covers (of those that exist, at an odd edge) — the values are linear, so this is the box
    /// filter of the light they reflect. For a scene whose textures exceed the GPU's binding.
    pub fn halved(&self) -> Texture2d {
        let (w, h) = (self.width.div_ceil(2), self.height.div_ceil(2));
        let mut texels = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                let mut sum = [0.0f32; 4];
                let mut n = 0.0;
                for (sx, sy) in [(2 * x, 2 * y), (2 * x + 1, 2 * y), (2 * x, 2 * y + 1), (2 * x + 1, 2 * y + 1)] {
                    if sx < self.width && sy < self.height {
                        let t = self.texels[(sy * self.width + sx) as usize];
                        sum.iter_mut().zip(t).for_each(|(s, v)| *s += v);
                        n += 1.0;
                    }
                }
                texels.push(sum.map(|s| s / n));
            }
        }
        Texture2d { width: w, height: h, texels, wrap: self.wrap }
    }

    /// Bilinear lookup with the texture's wrap modes — the CPU twin of `texture_at` in
    /// `shaders/shared/texture.wgsl`.
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.width as i64, self.height as i64);
        // Into [0, 1] first, so large coordinates keep their precision.
        let [wrap_u, wrap_v] = self.wrap;
        let uv = Vec2::new(wrap_u.coordinate(uv.x), wrap_v.coordinate(uv.y));
        let fx = uv.x * w as f32 - 0.5;
        let fy = uv.y * h as f32 - 0.5;
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - x0, fy - y0);
        let texel = |x: i64, y: i64| {
            let t = self.texels[(wrap_v.texel(y, h) * w + wrap_u.texel(x, w)) as usize];
            Vec3::new(t[0], t[1], t[2])
        };
        let (x0, y0) = (x0 as i64, y0 as i64);
        texel(x0, y0).lerp(texel(x0 + 1, y0), tx).lerp(texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), tx), ty)
    }
}

/// How a receiver's alpha (its `alpha` × the base colour texture's alpha) is read: glTF 2.0's
/// `alphaMode`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AlphaMode {
    /// Alpha is ignored: the surface is opaque.
    #[default]
    Opaque,
    /// A cut-out: where alpha < `alpha_cutoff` the surface is not there (rays and shadow rays go
    /// on to what is behind), elsewhere it is opaque.
    Mask,
    /// See-through: the surface covers the fraction alpha of what is behind, which shows
    /// unbent (no refraction) through the rest.
    Blend,
}

impl AlphaMode {
    /// The glTF / Lua name.
    pub fn name(self) -> &'static str {
        match self {
            AlphaMode::Opaque => "OPAQUE",
            AlphaMode::Mask => "MASK",
            AlphaMode::Blend => "BLEND",
        }
    }

    /// Parses a glTF / Lua name (either case).
    pub fn parse(s: &str) -> Option<Self> {
        [AlphaMode::Opaque, AlphaMode::Mask, AlphaMode::Blend].into_iter().find(|m| m.name().eq_ignore_ascii_case(s))
    }
}

/// An opaque receiver: receives direct light (shadowed by refractive objects) and the caustic
/// light photons bring through them, shaded with glTF 2.0's metallic-roughness model.
///
/// With `metallic = 0` and `specular = 0` (refrakt's `diffuse` defaults) the model is exactly
/// Lambertian: albedo / π, whatever the roughness — `specular` is KHR_materials_specular's
/// specular factor, which scales the dielectric's Fresnel reflection (f0 = 0.04 · specular,
/// f90 = specular). glTF materials (and Lua's `pbr`) have `specular = 1`, the full model.
#[derive(Clone, Debug, PartialEq)]
pub struct Diffuse {
    /// Base colour (albedo of a dielectric, F0 of a metal), linear RGB in [0, 1].
    pub color: Vec3,
    /// Multiplies `color` (glTF's baseColorTexture), sampled by the mesh's UVs; its alpha
    /// multiplies `alpha`.
    pub texture: Option<Arc<Texture2d>>,
    /// Coverage in [0, 1], read as `alpha_mode` says (glTF's baseColorFactor alpha).
    pub alpha: f32,
    pub alpha_mode: AlphaMode,
    /// `Mask`: alpha below this is a hole.
    pub alpha_cutoff: f32,
    /// 0 (dielectric) to 1 (metal).
    pub metallic: f32,
    /// Perceptual roughness, 0 (mirror) to 1; GGX α = roughness².
    pub roughness: f32,
    /// KHR_materials_specular's specular factor, 0 to 1: how much a dielectric reflects.
    pub specular: f32,
    /// glTF's metallicRoughnessTexture: roughness × G, metallic × B (linear).
    pub metallic_roughness_texture: Option<Arc<Texture2d>>,
    /// Tangent-space normal map (linear, +Y toward decreasing v, as glTF's).
    pub normal_texture: Option<Arc<Texture2d>>,
    /// Scales the normal map's x and y.
    pub normal_scale: f32,
    /// Ambient occlusion (R, linear): darkens the environment's light.
    pub occlusion_texture: Option<Arc<Texture2d>>,
    /// 0 (ignore the occlusion texture) to 1.
    pub occlusion_strength: f32,
    /// Emitted radiance, linear RGB (W·m⁻²·sr⁻¹, as the environment's), before `emission_strength`.
    pub emission: Vec3,
    /// Multiplies `emission` (KHR_materials_emissive_strength).
    pub emission_strength: f32,
    /// Multiplies `emission` (glTF's emissiveTexture, sRGB-encoded like the base colour).
    pub emission_texture: Option<Arc<Texture2d>>,
    /// KHR_materials_clearcoat: a clear lacquer (n = 1.5) over the surface, 0 (none) to 1.
    pub clearcoat: f32,
    /// The coat's perceptual roughness (GGX α = roughness²).
    pub clearcoat_roughness: f32,
    /// Multiplies `clearcoat` (R, linear).
    pub clearcoat_texture: Option<Arc<Texture2d>>,
    /// Multiplies `clearcoat_roughness` (G, linear).
    pub clearcoat_roughness_texture: Option<Arc<Texture2d>>,
    /// The coat's own tangent-space normal map (without one, the coat follows the surface's
    /// normals, not bent by `normal_texture`).
    pub clearcoat_normal_texture: Option<Arc<Texture2d>>,
    /// Scales the coat's normal map's x and y.
    pub clearcoat_normal_scale: f32,
    /// KHR_materials_sheen: the colour of a fabric's sheen (linear, 0 to 1; 0: none).
    pub sheen_color: Vec3,
    /// The sheen's perceptual roughness (Charlie α = roughness²).
    pub sheen_roughness: f32,
    /// Multiplies `sheen_color` (RGB, sRGB-encoded).
    pub sheen_color_texture: Option<Arc<Texture2d>>,
    /// Multiplies `sheen_roughness` (A, linear).
    pub sheen_roughness_texture: Option<Arc<Texture2d>>,
}

impl Default for Diffuse {
    fn default() -> Self {
        Self {
            color: Vec3::splat(0.8),
            texture: None,
            alpha: 1.0,
            alpha_mode: AlphaMode::Opaque,
            alpha_cutoff: 0.5,
            metallic: 0.0,
            roughness: 1.0,
            specular: 0.0,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            occlusion_texture: None,
            occlusion_strength: 1.0,
            emission: Vec3::ZERO,
            emission_strength: 1.0,
            emission_texture: None,
            clearcoat: 0.0,
            clearcoat_roughness: 0.0,
            clearcoat_texture: None,
            clearcoat_roughness_texture: None,
            clearcoat_normal_texture: None,
            clearcoat_normal_scale: 1.0,
            sheen_color: Vec3::ZERO,
            sheen_roughness: 0.0,
            sheen_color_texture: None,
            sheen_roughness_texture: None,
        }
    }
}

impl Diffuse {
    /// glTF's metallic-roughness material with its defaults (base colour 1, metallic 1,
    /// roughness 1, specular 1): `refrakt.pbr{…}` and glTF files.
    pub fn pbr() -> Self {
        Self { color: Vec3::ONE, metallic: 1.0, specular: 1.0, ..Self::default() }
    }

    /// Whether the surface needs more than the Lambertian shading: a specular lobe (metal or
    /// dielectric Fresnel), a normal map, a clear coat or a sheen. Receivers without one are
    /// shaded as before PBR.
    pub fn is_pbr(&self) -> bool {
        self.metallic > 0.0 || self.specular > 0.0 || self.normal_texture.is_some() || self.clearcoat > 0.0 || self.sheen_color.max_element() > 0.0
    }

    /// The emitted radiance at full texture: `emission × emission_strength`.
    pub fn emitted(&self) -> Vec3 {
        self.emission * self.emission_strength
    }
}

/// What a node's shape is made of.
#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    /// Refractive/absorbing medium (glass, water; fog or smoke with ior = 1).
    Glass(Glass),
    /// Opaque diffuse receiver.
    Diffuse(Diffuse),
}

/// A homogeneous scattering medium filling the whole volume box, so light shafts show.
#[derive(Clone, Debug, PartialEq)]
pub struct Fog {
    /// Scattering coefficient per metre, per channel.
    pub scattering: Vec3,
    /// Absorption coefficient per metre, per channel.
    pub absorption: Vec3,
    /// Henyey–Greenstein anisotropy, in (−1, 1): > 0 scatters forward.
    pub g: f32,
}

impl Default for Fog {
    fn default() -> Self {
        Self { scattering: Vec3::splat(0.05), absorption: Vec3::ZERO, g: 0.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Halving averages each 2 × 2 block, and at an odd edge the texels that exist.
    #[test]
    fn a_halved_texture_is_the_box_filter_of_the_whole() {
        let t = Texture2d { width: 3, height: 2, texels: (0..6).map(|i| [i as f32, 1.0, 0.0, 1.0]).collect(), wrap: [Wrap::Clamp; 2] };
        let h = t.halved();
        assert_eq!((h.width, h.height, h.wrap), (2, 1, [Wrap::Clamp; 2]));
        // Row 0: 0 1 2, row 1: 3 4 5 → (0+1+3+4)/4 = 2 and (2+5)/2 = 3.5.
        assert_eq!(h.texels, vec![[2.0, 1.0, 0.0, 1.0], [3.5, 1.0, 0.0, 1.0]]);
        let one = h.halved();
        assert_eq!((one.width, one.height), (1, 1));
        assert_eq!(one.halved().texels, one.texels, "a single texel halves to itself");
    }

    /// A 4-texel row of values 0, 1, 2, 3 sampled between texel centres along u: repeat tiles it,
    /// clamp holds the edge texel, mirror reflects it in every odd tile (glTF 2.0 §5.26).
    #[test]
    fn each_wrap_mode_continues_the_image_as_gl_does() {
        let row = |wrap: Wrap| Texture2d {
            width: 4,
            height: 1,
            texels: (0..4).map(|i| [i as f32, 0.0, 0.0, 1.0]).collect(),
            wrap: [wrap, Wrap::Repeat],
        };
        let at = |t: &Texture2d, u: f32| t.sample(Vec2::new(u, 0.5)).x;
        let (repeat, clamp, mirror) = (row(Wrap::Repeat), row(Wrap::Clamp), row(Wrap::Mirror));
        // Texel centres sit at u = (i + ½)/4; the next tile starts at u = 1.
        for (u, r, c, m) in [
            (0.125, 0.0, 0.0, 0.0),
            (0.875, 3.0, 3.0, 3.0),
            (1.125, 0.0, 3.0, 3.0), // tile 1: repeat starts again, clamp holds, mirror runs back
            (1.375, 1.0, 3.0, 2.0),
            (2.125, 0.0, 3.0, 0.0), // tile 2 is upright again
            (-0.125, 3.0, 0.0, 0.0),
            (-0.375, 2.0, 0.0, 1.0),
            (1.0, 1.5, 3.0, 3.0), // on the seam: repeat blends the edges, mirror meets itself
        ] {
            assert!((at(&repeat, u) - r).abs() < 1e-5, "repeat at {u}: {}", at(&repeat, u));
            assert!((at(&clamp, u) - c).abs() < 1e-5, "clamp at {u}: {}", at(&clamp, u));
            assert!((at(&mirror, u) - m).abs() < 1e-5, "mirror at {u}: {}", at(&mirror, u));
        }
    }
}
