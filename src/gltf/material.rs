//! glTF materials as refrakt materials. A material that transmits light
//! (KHR_materials_transmission) is a refractive medium: its index from KHR_materials_ior, its
//! absorption from KHR_materials_volume's attenuation (σ = −ln(attenuationColor) /
//! attenuationDistance per metre, the Beer–Lambert reading the extension's spec gives), and
//! refrakt's material extras override that medium where present. Anything else is an opaque
//! receiver of the metallic-roughness model (`scene::Diffuse`): base colour, metallic,
//! roughness, their textures, normal and occlusion maps, emission (with
//! KHR_materials_emissive_strength), alphaMode / alphaCutoff, KHR_materials_specular's
//! specular factor, and the clearcoat and sheen layers (`super::layers`). On glass,
//! KHR_materials_specular's factors and textures too (`Glass::specular`).

use std::collections::HashMap;
use std::sync::Arc;

use anyhow::{Result, anyhow, bail};
use glam::{Affine2, Vec2, Vec3};

use super::buffers::{self, Location};
use super::extras;
use crate::scene::image_header;
use crate::scene::material::srgb_to_linear;
use crate::scene::{AlphaMode, Diffuse, Glass, Material, Texture2d, Wrap};
use crate::warnings::Collector;

/// A glTF material made into refrakt's, with the smooth boundary width its extras set.
pub struct Converted {
    pub material: Material,
    pub boundary: Option<f32>,
    /// Where its textures are sampled (one map for all of a material's textures: the first
    /// texture's, with a warning when another differs).
    pub uv: Option<UvMap>,
}

/// The TEXCOORD_n set a texture samples, and the KHR_texture_transform applied to it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvMap {
    pub set: u32,
    pub transform: Affine2,
}

impl UvMap {
    /// "TEXCOORD_1 with a texture transform", for messages.
    fn plain(&self) -> String {
        let transformed = if self.transform == Affine2::IDENTITY { "" } else { " with a texture transform" };
        format!("TEXCOORD_{}{transformed}", self.set)
    }

    fn of(info: &gltf::texture::Info, file: &str, what: &str) -> Result<Self> {
        let Some(t) = info.texture_transform() else { return Ok(Self { set: info.tex_coord(), transform: Affine2::IDENTITY }) };
        let (offset, scale) = (Vec2::from(t.offset()), Vec2::from(t.scale()));
        if !(offset.is_finite() && scale.is_finite() && t.rotation().is_finite()) {
            bail!("{file}: {what}: KHR_texture_transform offset, rotation and scale must be finite numbers");
        }
        Ok(Self { set: t.tex_coord().unwrap_or(info.tex_coord()), transform: texture_transform(offset, t.rotation(), scale) })
    }
}

/// KHR_texture_transform: uv' = T(offset) · R(rotation) · S(scale) · uv. The rotation turns the
/// UVs counter-clockwise as the image is seen (v pointing down), i.e. u' = cos·u + sin·v,
/// v' = −sin·u + cos·v: the extension's example (offset [0, 1], rotation π/2, scale ½) then
/// maps the unit square onto the image's lower-left quadrant, as the spec says it does.
pub fn texture_transform(offset: Vec2, rotation: f32, scale: Vec2) -> Affine2 {
    let (sin, cos) = rotation.sin_cos();
    Affine2::from_cols(Vec2::new(cos, -sin) * scale.x, Vec2::new(sin, cos) * scale.y, offset)
}

/// Converts materials, decoding each texture image once.
pub struct Materials<'a> {
    pub doc: &'a gltf::Document,
    pub buffers: &'a [Vec<u8>],
    pub at: &'a Location<'a>,
    /// Decoded images by (index, sRGB-encoded, wrap modes).
    textures: HashMap<(usize, bool, [Wrap; 2]), Arc<Texture2d>>,
}

/// The glTF default material (§3.9.6): base color 1, opaque.
pub fn default_material() -> Converted {
    Converted { material: Material::Diffuse(Diffuse::pbr()), boundary: None, uv: None }
}

impl<'a> Materials<'a> {
    pub fn new(doc: &'a gltf::Document, buffers: &'a [Vec<u8>], at: &'a Location<'a>) -> Self {
        Self { doc, buffers, at, textures: HashMap::new() }
    }

    pub fn convert(&mut self, m: &gltf::Material, warnings: &mut Collector) -> Result<Converted> {
        let index = m.index().unwrap_or(0);
        let what = format!("materials[{index}]{}", super::mesh::quoted(m.name()));
        let medium = extras::medium(m, self.at.file, &what, warnings)?.unwrap_or_default();
        let transmission = m.transmission().map_or(0.0, |t| t.transmission_factor());
        if transmission > 0.0 || medium.is_medium() {
            let (glass, uv) = self.glass(m, &what, transmission, &medium, warnings)?;
            return Ok(Converted { material: Material::Glass(glass), boundary: medium.boundary, uv });
        }
        let (diffuse, uv) = self.receiver(m, &what, warnings)?;
        Ok(Converted { material: Material::Diffuse(diffuse), boundary: medium.boundary, uv })
    }

    /// An opaque (or cut-out, or see-through) material of the metallic-roughness model.
    fn receiver(&mut self, m: &gltf::Material, what: &str, warnings: &mut Collector) -> Result<(Diffuse, Option<UvMap>)> {
        let file = self.at.file;
        let pbr = m.pbr_metallic_roughness();
        let [r, g, b, a] = pbr.base_color_factor();
        let factors = [r, g, b, a, pbr.metallic_factor(), pbr.roughness_factor(), m.alpha_cutoff().unwrap_or(0.5)];
        if !factors.iter().all(|f| f.is_finite()) {
            bail!("{file}: {what}: baseColorFactor, metallicFactor, roughnessFactor and alphaCutoff must be finite");
        }
        let (emission, strength) = emissive(m, file, what)?;
        let mut d = Diffuse {
            color: Vec3::new(r, g, b).clamp(Vec3::ZERO, Vec3::ONE),
            alpha: a.clamp(0.0, 1.0),
            alpha_mode: alpha_mode(m),
            alpha_cutoff: m.alpha_cutoff().unwrap_or(0.5).clamp(0.0, 1.0),
            metallic: pbr.metallic_factor().clamp(0.0, 1.0),
            roughness: pbr.roughness_factor().clamp(0.0, 1.0),
            specular: m.specular().map_or(1.0, |s| s.specular_factor()).clamp(0.0, 1.0),
            emission,
            emission_strength: strength,
            ..Diffuse::pbr()
        };
        // Each texture with where it is sampled; the material keeps the first one's UV map.
        let mut maps: Vec<(&'static str, UvMap)> = Vec::new();
        let mut load = |this: &mut Self, info: &gltf::texture::Info, role: &'static str, srgb: bool| -> Result<Arc<Texture2d>> {
            maps.push((role, UvMap::of(info, file, what)?));
            this.texture(info, what, role, srgb)
        };
        if let Some(info) = pbr.base_color_texture() {
            d.texture = Some(load(self, &info, "base color", true)?);
        }
        if let Some(info) = pbr.metallic_roughness_texture() {
            d.metallic_roughness_texture = Some(load(self, &info, "metallic-roughness", false)?);
        }
        if let Some(info) = m.emissive_texture() {
            d.emission_texture = Some(load(self, &info, "emissive", true)?);
        }
        if let Some(n) = m.normal_texture() {
            d.normal_scale = n.scale();
            // (The gltf crate does not expose a normal or occlusion texture's
            // KHR_texture_transform: it is taken to be the other textures'.)
            let transform = maps.first().map_or(Affine2::IDENTITY, |m| m.1.transform);
            maps.push(("normal", UvMap { set: n.tex_coord(), transform }));
            d.normal_texture = Some(self.image_texture(n.texture(), what, "normal", false)?);
        }
        if let Some(o) = m.occlusion_texture() {
            d.occlusion_strength = o.strength().clamp(0.0, 1.0);
            let transform = maps.first().map_or(Affine2::IDENTITY, |m| m.1.transform);
            maps.push(("occlusion", UvMap { set: o.tex_coord(), transform }));
            d.occlusion_texture = Some(self.image_texture(o.texture(), what, "occlusion", false)?);
        }
        self.layers(m, what, &mut d, &mut maps)?;
        warn_uv_maps_differ(&maps, what, warnings);
        let uv = maps.first().map(|m| m.1);
        Ok((d, uv))
    }

    fn glass(
        &mut self,
        m: &gltf::Material,
        what: &str,
        transmission: f32,
        medium: &extras::MediumExtras,
        warnings: &mut Collector,
    ) -> Result<(Glass, Option<UvMap>)> {
        let file = self.at.file;
        // KHR_materials_ior: the default 1.5 when absent; a medium without transmission (a
        // volume in Blender with no glass surface) is index-matched to the air around it.
        let ior = m.ior().unwrap_or(if transmission > 0.0 { 1.5 } else { 1.0 });
        if !(1.0..=4.0).contains(&ior) {
            bail!("{file}: {what}: KHR_materials_ior ior is {ior}; refrakt renders indices from 1 to 4");
        }
        // KHR_materials_transmission: the base colour tints what passes each surface.
        let [r, g, b, a] = m.pbr_metallic_roughness().base_color_factor();
        if ![r, g, b, a, m.alpha_cutoff().unwrap_or(0.5)].iter().all(|f| f.is_finite()) {
            bail!("{file}: {what}: baseColorFactor and alphaCutoff must be finite");
        }
        let tint = Vec3::new(r, g, b).clamp(Vec3::ZERO, Vec3::ONE);
        // KHR_materials_transmission's factor: the rest of the light meets the base colour's
        // diffuse base (a medium without transmission has no surface of its own: all passes).
        let passed = if transmission > 0.0 { transmission.min(1.0) } else { 1.0 };
        let mut glass = Glass { ior, absorption: attenuation(m, file, what)?, tint, transmission: passed, ..Glass::default() };
        // Base colour alpha cuts a thin sheet (a solid ignores it, and the frame says so).
        (glass.alpha, glass.alpha_mode, glass.alpha_cutoff) = (a.clamp(0.0, 1.0), alpha_mode(m), m.alpha_cutoff().unwrap_or(0.5).clamp(0.0, 1.0));
        if let Some(a) = medium.absorption {
            glass.absorption = Vec3::from(a);
        }
        if let Some(s) = medium.scattering {
            glass.scattering = Vec3::from(s);
        }
        if let Some(g) = medium.g {
            glass.g = g;
        }
        if let Some(t) = medium.tint {
            // The base colour stays the diffuse base's and the metal's (`Glass::base_color`).
            glass.base_color = Some(glass.tint);
            glass.tint = Vec3::from(t);
        }
        glass.dispersion = dispersion(m, file, what)?;
        glass.priority = medium.priority.unwrap_or(0);
        glass.multiscatter = medium.multiscatter.unwrap_or(true);
        let mut uv = None;
        if transmission > 0.0 {
            glass.roughness = transmission_roughness(m, file, what)?;
            glass.metallic = transmission_metallic(m, file, what)?;
            glass.thin = medium.thin.or(thin_walled(m));
            uv = self.glass_textures(m, what, &mut glass, warnings)?;
        }
        Ok((glass, uv))
    }

    /// The textures of a transmissive material that vary its surface: the base colour texture
    /// tints (KHR_materials_transmission: the base colour is the transmitted colour), the
    /// metallic-roughness texture's green channel scales the roughness and the normal map bends
    /// the normal, where each ray or photon meets the surface; the emissive texture where the
    /// camera sees it glow; KHR_materials_specular's factors and textures reshape its
    /// reflectance. The medium inside (index, absorption) stays one per material.
    fn glass_textures(&mut self, m: &gltf::Material, what: &str, glass: &mut Glass, warnings: &mut Collector) -> Result<Option<UvMap>> {
        let pbr = m.pbr_metallic_roughness();
        let file = self.at.file;
        let mut maps = Vec::new();
        glass.tint_texture = self.mapped_texture(&mut maps, pbr.base_color_texture(), what, "base color", true)?;
        glass.roughness_texture = self.mapped_texture(&mut maps, pbr.metallic_roughness_texture(), what, "metallic-roughness", false)?;
        let (emission, strength) = emissive(m, file, what)?;
        (glass.emission, glass.emission_strength) = (emission, strength);
        if glass.emitted() != Vec3::ZERO {
            glass.emission_texture = self.mapped_texture(&mut maps, m.emissive_texture(), what, "emissive", true)?;
        }
        if let Some(n) = m.normal_texture() {
            // (Its KHR_texture_transform is taken to be the other textures', as on receivers.)
            let transform = maps.first().map_or(Affine2::IDENTITY, |m| m.1.transform);
            maps.push(("normal", UvMap { set: n.tex_coord(), transform }));
            glass.normal_texture = Some(self.image_texture(n.texture(), what, "normal", false)?);
            glass.normal_scale = n.scale();
        }
        glass.transmission_texture = self.mapped_texture(&mut maps, m.transmission().and_then(|t| t.transmission_texture()), what, "transmission", false)?;
        if let Some(specular) = m.specular() {
            // KHR_materials_specular: the factor scales the reflection, the colour its F₀
            // (`Glass::specular`); the factor's texture is in alpha, the colour's is sRGB.
            glass.specular = specular.specular_factor().clamp(0.0, 1.0);
            glass.specular_color = Vec3::from(specular.specular_color_factor()).max(Vec3::ZERO);
            glass.specular_texture = self.mapped_texture(&mut maps, specular.specular_texture(), what, "specular", false)?;
            glass.specular_color_texture = self.mapped_texture(&mut maps, specular.specular_color_texture(), what, "specular color", true)?;
        }
        warn_uv_maps_differ(&maps, what, warnings);
        Ok(maps.first().map(|m| m.1))
    }

    /// A glass's texture in `role`, where the material has one, its UV map noted in `maps` (all
    /// of a material's textures are sampled at the first's: `warn_uv_maps_differ`).
    fn mapped_texture(&mut self, maps: &mut Vec<(&'static str, UvMap)>, info: Option<gltf::texture::Info>, what: &str, role: &'static str, srgb: bool) -> Result<Option<Arc<Texture2d>>> {
        let Some(info) = info else { return Ok(None) };
        maps.push((role, UvMap::of(&info, self.at.file, what)?));
        self.texture(&info, what, role, srgb).map(Some)
    }

    /// A texture, decoded to linear values: colour textures (base color, emissive) are stored
    /// sRGB-encoded (§3.9.2), the others linear.
    fn texture(&mut self, info: &gltf::texture::Info, what: &str, role: &str, srgb: bool) -> Result<Arc<Texture2d>> {
        self.image_texture(info.texture(), what, role, srgb)
    }

    pub(super) fn image_texture(&mut self, texture: gltf::Texture, what: &str, role: &str, srgb: bool) -> Result<Arc<Texture2d>> {
        let sampler = texture.sampler();
        let wrap = [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())];
        let image = texture.source().index();
        if let Some(t) = self.textures.get(&(image, srgb, wrap)) {
            return Ok(t.clone());
        }
        // The same image under another sampler shares nothing but its decoding.
        let decoded = match self.textures.iter().find(|((i, s, _), _)| (*i, *s) == (image, srgb)) {
            Some((_, t)) => Texture2d { width: t.width, height: t.height, texels: t.texels.clone(), wrap },
            None => {
                let bytes = buffers::image_bytes(self.doc, self.buffers, image, self.at)?;
                let d = decode_image(&bytes, srgb).map_err(|e| anyhow!("{}: images[{image}] (the {role} texture of {what}): {e}", self.at.file))?;
                Texture2d { wrap, ..d }
            }
        };
        let decoded = Arc::new(decoded);
        self.textures.insert((image, srgb, wrap), decoded.clone());
        Ok(decoded)
    }
}

/// A sampler's wrapS or wrapT as refrakt's addressing.
fn wrap(mode: gltf::texture::WrappingMode) -> Wrap {
    match mode {
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::Mirror,
    }
}

/// glTF's alphaMode as refrakt's.
fn alpha_mode(m: &gltf::Material) -> AlphaMode {
    match m.alpha_mode() {
        gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
        gltf::material::AlphaMode::Mask => AlphaMode::Mask,
        gltf::material::AlphaMode::Blend => AlphaMode::Blend,
    }
}

/// A material's emission: glTF's emissiveFactor (components below 0, outside the spec's 0..1,
/// taken as 0) and KHR_materials_emissive_strength (1 when absent), for receivers and glass alike.
fn emissive(m: &gltf::Material, file: &str, what: &str) -> Result<(Vec3, f32)> {
    let factor = Vec3::from(m.emissive_factor());
    let strength = m.emissive_strength().unwrap_or(1.0);
    if !factor.is_finite() || !strength.is_finite() || strength < 0.0 {
        bail!("{file}: {what}: emissiveFactor and KHR_materials_emissive_strength must be finite (the strength ≥ 0)");
    }
    Ok((factor.max(Vec3::ZERO), strength))
}

/// KHR_materials_transmission's roughness is the material's metallic-roughness roughness
/// (GGX, α = roughness²).
fn transmission_roughness(m: &gltf::Material, file: &str, what: &str) -> Result<f32> {
    let roughness = m.pbr_metallic_roughness().roughness_factor();
    if !(0.0..=1.0).contains(&roughness) {
        bail!("{file}: {what}: roughnessFactor is {roughness}; it must be from 0 to 1");
    }
    Ok(roughness)
}

/// The metal part of a transmissive material's surface (the glTF PBR spec: transmission applies
/// to the dielectric part only): metallicFactor, which the metallic-roughness texture's blue
/// channel scales where light meets the glass. Its default is 1, as for every material: the
/// Khronos samples leave it out and paint their glass's metal in the texture (0 on the glass).
fn transmission_metallic(m: &gltf::Material, file: &str, what: &str) -> Result<f32> {
    let metallic = m.pbr_metallic_roughness().metallic_factor();
    if !(0.0..=1.0).contains(&metallic) {
        bail!("{file}: {what}: metallicFactor is {metallic}; it must be from 0 to 1");
    }
    Ok(metallic)
}

/// Warns once per texture whose UV map (set and transform) differs from the first texture's:
/// a material's textures are all sampled with the first one's.
fn warn_uv_maps_differ(maps: &[(&str, UvMap)], what: &str, warnings: &mut Collector) {
    let Some(&(first, uv)) = maps.first() else { return };
    for (role, map) in maps.iter().skip(1).filter(|(_, map)| *map != uv) {
        warnings.about(
            what,
            format!(
                "its {role} texture samples {} but its {first} texture {}; refrakt samples all of a material's textures as the first one",
                map.plain(),
                uv.plain()
            ),
        );
    }
}

/// Transmission without KHR_materials_volume is thin-walled, by that extension's definition: a
/// sheet with no inside. With a volume the mesh decides (`scene::eval`: closed meshes are
/// solids) — also at thicknessFactor 0 when an attenuation is given, since only a volume can
/// attenuate; a volume with neither is thin-walled again, as the extension says.
fn thin_walled(m: &gltf::Material) -> Option<bool> {
    match m.volume() {
        Some(v) if v.thickness_factor() > 0.0 || v.attenuation_distance().is_finite() => None,
        _ => Some(true),
    }
}

/// KHR_materials_dispersion: `dispersion` = 20/V_d (default 0, none), any value ≥ 0.
fn dispersion(m: &gltf::Material, file: &str, what: &str) -> Result<f32> {
    let Some(ext) = m.extension_value("KHR_materials_dispersion") else { return Ok(0.0) };
    let d = match ext.get("dispersion") {
        None => return Ok(0.0),
        Some(v) => v.as_f64().ok_or_else(|| anyhow!("{file}: {what}: KHR_materials_dispersion dispersion must be a number, got {v}"))?,
    };
    if !(0.0..=20.0).contains(&d) {
        bail!("{file}: {what}: KHR_materials_dispersion dispersion is {d}; it is 20/V_d (V_d the Abbe number), from 0 (none) to 20");
    }
    Ok(d as f32)
}

/// KHR_materials_volume: white light turns attenuationColor c after attenuationDistance d, so
/// by Beer–Lambert σ = −ln(c) / d per metre (d = ∞, the default, absorbs nothing).
fn attenuation(m: &gltf::Material, file: &str, what: &str) -> Result<Vec3> {
    let Some(v) = m.volume() else { return Ok(Vec3::ZERO) };
    let (c, d) = (Vec3::from(v.attenuation_color()), v.attenuation_distance());
    if d.is_nan() || d <= 0.0 {
        bail!("{file}: {what}: KHR_materials_volume attenuationDistance is {d}; it must be > 0 (metres)");
    }
    Glass::absorption_from(c, d)
        .ok_or_else(|| anyhow!("{file}: {what}: KHR_materials_volume attenuationColor {c} must have components in (0, 1]"))
}

/// Decodes a PNG or JPEG texture, its header checked against [`image_header::TEXTURE`] first
/// (larger claims are refused before any pixel memory is allocated); RGB sRGB-decoded when
/// `srgb`, else read as linear, alpha always linear.
pub fn decode_image(bytes: &[u8], srgb: bool) -> Result<Texture2d> {
    let caps = image_header::TEXTURE;
    image_header::check_encoded(bytes, &caps)?;
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format()?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(caps.max_side as u32);
    limits.max_image_height = Some(caps.max_side as u32);
    reader.limits(limits);
    let rgba = reader.decode()?.into_rgba8();
    let linear = |c: u8| if srgb { srgb_to_linear(c as f32 / 255.0) } else { c as f32 / 255.0 };
    Ok(Texture2d {
        width: rgba.width(),
        height: rgba.height(),
        texels: rgba.pixels().map(|p| [linear(p[0]), linear(p[1]), linear(p[2]), p[3] as f32 / 255.0]).collect(),
        wrap: [Wrap::Repeat; 2],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_extensions_example_maps_the_unit_square_onto_the_lower_left_quadrant() {
        // "This example utilizes only the lower left quadrant of the source image, rotated
        // clockwise 90°": offset [0, 1], rotation π/2, scale [0.5, 0.5].
        let t = texture_transform(Vec2::new(0.0, 1.0), std::f32::consts::FRAC_PI_2, Vec2::splat(0.5));
        for (uv, want) in [((0.0, 0.0), (0.0, 1.0)), ((1.0, 0.0), (0.0, 0.5)), ((0.0, 1.0), (0.5, 1.0)), ((1.0, 1.0), (0.5, 0.5))] {
            let got = t.transform_point2(Vec2::new(uv.0, uv.1));
            assert!((got - Vec2::new(want.0, want.1)).length() < 1e-6, "{uv:?} → {got}, want {want:?}");
        }
        // Offset and scale alone: what gltfpack writes for quantized texture coordinates.
        let q = texture_transform(Vec2::new(0.25, -0.5), 0.0, Vec2::new(2.0, 4.0));
        assert_eq!(q.transform_point2(Vec2::new(0.5, 0.5)), Vec2::new(1.25, 1.5));
    }
}
