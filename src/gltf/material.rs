//! glTF materials as refrakt materials. A material that transmits light
//! (KHR_materials_transmission) is a refractive medium: its index from KHR_materials_ior, its
//! absorption from KHR_materials_volume's attenuation (σ = −ln(attenuationColor) /
//! attenuationDistance per metre, the Beer–Lambert reading the extension's spec gives), and
//! refrakt's material extras override that medium where present. Anything else is an opaque
//! diffuse receiver with the base color (and base color texture) of the metallic-roughness model.

use std::collections::HashMap;
use std::sync::Arc;

use anyhow::{Result, anyhow, bail};
use glam::Vec3;

use super::buffers::{self, Location};
use super::extras;
use crate::scene::image_header;
use crate::scene::material::srgb_to_linear;
use crate::scene::{Diffuse, Glass, Material, Texture2d};

/// A glTF material made into refrakt's, with the smooth boundary width its extras set.
pub struct Converted {
    pub material: Material,
    pub boundary: Option<f32>,
    /// The TEXCOORD set its base color texture samples.
    pub uv_set: Option<u32>,
}

/// Converts materials, decoding each texture image once.
pub struct Materials<'a> {
    pub doc: &'a gltf::Document,
    pub buffers: &'a [Vec<u8>],
    pub at: &'a Location<'a>,
    textures: HashMap<usize, Arc<Texture2d>>,
}

/// The glTF default material (§3.9.6): base color 1, opaque.
pub fn default_material() -> Converted {
    Converted { material: Material::Diffuse(Diffuse { color: Vec3::ONE, texture: None }), boundary: None, uv_set: None }
}

impl<'a> Materials<'a> {
    pub fn new(doc: &'a gltf::Document, buffers: &'a [Vec<u8>], at: &'a Location<'a>) -> Self {
        Self { doc, buffers, at, textures: HashMap::new() }
    }

    pub fn convert(&mut self, m: &gltf::Material, warnings: &mut Vec<String>) -> Result<Converted> {
        let index = m.index().unwrap_or(0);
        let what = format!("materials[{index}]{}", super::mesh::quoted(m.name()));
        let medium = extras::medium(m, self.at.file, &what, warnings)?.unwrap_or_default();
        let transmission = m.transmission().map_or(0.0, |t| t.transmission_factor());
        if transmission > 0.0 || medium.is_medium() {
            let glass = self.glass(m, &what, transmission, &medium, warnings)?;
            return Ok(Converted { material: Material::Glass(glass), boundary: medium.boundary, uv_set: None });
        }
        let pbr = m.pbr_metallic_roughness();
        let [r, g, b, _] = pbr.base_color_factor();
        let color = Vec3::new(r, g, b);
        if !color.is_finite() {
            bail!("{}: {what}: baseColorFactor must be finite", self.at.file);
        }
        let (texture, uv_set) = match pbr.base_color_texture() {
            Some(info) => (Some(self.texture(&info, &what, warnings)?), Some(info.tex_coord())),
            None => (None, None),
        };
        let diffuse = Diffuse { color: color.clamp(Vec3::ZERO, Vec3::ONE), texture };
        Ok(Converted { material: Material::Diffuse(diffuse), boundary: medium.boundary, uv_set })
    }

    fn glass(&self, m: &gltf::Material, what: &str, transmission: f32, medium: &extras::MediumExtras, warnings: &mut Vec<String>) -> Result<Glass> {
        let file = self.at.file;
        if transmission > 0.0 && transmission < 1.0 {
            warnings.push(format!(
                "{file}: {what} transmits {transmission} of the light; refrakt renders it as clear glass (transmission 1)"
            ));
        }
        // KHR_materials_ior: the default 1.5 when absent; a medium without transmission (a
        // volume in Blender with no glass surface) is index-matched to the air around it.
        let ior = m.ior().unwrap_or(if transmission > 0.0 { 1.5 } else { 1.0 });
        if !(1.0..=4.0).contains(&ior) {
            bail!("{file}: {what}: KHR_materials_ior ior is {ior}; refrakt renders indices from 1 to 4");
        }
        let mut glass = Glass { ior, absorption: attenuation(m, file, what)?, ..Glass::default() };
        if let Some(a) = medium.absorption {
            glass.absorption = Vec3::from(a);
        }
        if let Some(s) = medium.scattering {
            glass.scattering = Vec3::from(s);
        }
        if let Some(g) = medium.g {
            glass.g = g;
        }
        Ok(glass)
    }

    /// A base color texture, decoded to linear RGB (glTF stores it sRGB-encoded, §3.9.2).
    fn texture(&mut self, info: &gltf::texture::Info, what: &str, warnings: &mut Vec<String>) -> Result<Arc<Texture2d>> {
        let texture = info.texture();
        let sampler = texture.sampler();
        if sampler.wrap_s() != gltf::texture::WrappingMode::Repeat || sampler.wrap_t() != gltf::texture::WrappingMode::Repeat {
            warnings.push(format!("{}: {what}: refrakt repeats textures; the sampler's other wrapping mode is not used", self.at.file));
        }
        let image = texture.source().index();
        if let Some(t) = self.textures.get(&image) {
            return Ok(t.clone());
        }
        let bytes = buffers::image_bytes(self.doc, self.buffers, image, self.at)?;
        let decoded = decode_image(&bytes).map_err(|e| anyhow!("{}: images[{image}] (the base color of {what}): {e}", self.at.file))?;
        let decoded = Arc::new(decoded);
        self.textures.insert(image, decoded.clone());
        Ok(decoded)
    }
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
/// (larger claims are refused before any pixel memory is allocated).
fn decode_image(bytes: &[u8]) -> Result<Texture2d> {
    let caps = image_header::TEXTURE;
    image_header::check_encoded(bytes, &caps)?;
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format()?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(caps.max_side as u32);
    limits.max_image_height = Some(caps.max_side as u32);
    reader.limits(limits);
    let rgba = reader.decode()?.into_rgba8();
    let linear = |c: u8| srgb_to_linear(c as f32 / 255.0);
    Ok(Texture2d {
        width: rgba.width(),
        height: rgba.height(),
        texels: rgba.pixels().map(|p| [linear(p[0]), linear(p[1]), linear(p[2]), p[3] as f32 / 255.0]).collect(),
    })
}
