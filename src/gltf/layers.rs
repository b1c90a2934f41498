//! KHR_materials_clearcoat and KHR_materials_sheen: the layers the Khronos Sample Viewer puts
//! over a metallic-roughness receiver (a car's lacquer, a fabric's sheen), read from the
//! extensions' JSON (the gltf crate does not parse them) into `scene::Diffuse`. How they shade:
//! `shaders/shared/pbr.wgsl`.

use std::sync::Arc;

use anyhow::{Result, anyhow, bail};
use glam::{Affine2, Vec2, Vec3};
use serde_json::Value;

use super::material::{Materials, UvMap, texture_transform};
use crate::scene::{Diffuse, Texture2d};

/// A texture of a layer, with where it is sampled.
type Layer = Option<(Arc<Texture2d>, UvMap)>;

impl Materials<'_> {
    /// Reads both layers' factors and textures into `d`, pushing each texture's UV map onto
    /// `maps` (the material samples all its textures by one map).
    pub(super) fn layers(&mut self, m: &gltf::Material, what: &str, d: &mut Diffuse, maps: &mut Vec<(&'static str, UvMap)>) -> Result<()> {
        if let Some(ext) = m.extension_value("KHR_materials_clearcoat") {
            let name = "KHR_materials_clearcoat";
            d.clearcoat = self.fraction(ext, name, "clearcoatFactor", 0.0, what)?;
            d.clearcoat_roughness = self.fraction(ext, name, "clearcoatRoughnessFactor", 0.0, what)?;
            d.clearcoat_texture = self.layer_texture(ext, "clearcoatTexture", what, "clearcoat", false)?.map(|t| keep(t, "clearcoat", maps));
            d.clearcoat_roughness_texture =
                self.layer_texture(ext, "clearcoatRoughnessTexture", what, "clearcoat roughness", false)?.map(|t| keep(t, "clearcoat roughness", maps));
            d.clearcoat_normal_texture = self.layer_texture(ext, "clearcoatNormalTexture", what, "clearcoat normal", false)?.map(|t| keep(t, "clearcoat normal", maps));
            if let Some(scale) = ext.get("clearcoatNormalTexture").and_then(|t| t.get("scale")) {
                d.clearcoat_normal_scale = scale
                    .as_f64()
                    .filter(|s| s.is_finite())
                    .ok_or_else(|| anyhow!("{}: {what}: {name} clearcoatNormalTexture.scale must be a number, got {scale}", self.at.file))? as f32;
            }
        }
        if let Some(ext) = m.extension_value("KHR_materials_sheen") {
            let name = "KHR_materials_sheen";
            d.sheen_color = match ext.get("sheenColorFactor") {
                None => Vec3::ZERO,
                Some(v) => color(v).ok_or_else(|| anyhow!("{}: {what}: {name} sheenColorFactor must be three numbers from 0 to 1, got {v}", self.at.file))?,
            };
            d.sheen_roughness = self.fraction(ext, name, "sheenRoughnessFactor", 0.0, what)?;
            d.sheen_color_texture = self.layer_texture(ext, "sheenColorTexture", what, "sheen colour", true)?.map(|t| keep(t, "sheen colour", maps));
            d.sheen_roughness_texture = self.layer_texture(ext, "sheenRoughnessTexture", what, "sheen roughness", false)?.map(|t| keep(t, "sheen roughness", maps));
        }
        Ok(())
    }

    /// A factor from 0 to 1 (`default` when absent).
    fn fraction(&self, ext: &Value, extension: &str, key: &str, default: f32, what: &str) -> Result<f32> {
        match ext.get(key) {
            None => Ok(default),
            Some(v) => match v.as_f64() {
                Some(x) if (0.0..=1.0).contains(&x) => Ok(x as f32),
                _ => bail!("{}: {what}: {extension} {key} must be a number from 0 to 1, got {v}", self.at.file),
            },
        }
    }

    /// The textureInfo `key` of an extension's JSON: the texture and its UV map (texCoord and
    /// KHR_texture_transform), or `None` where the extension has none.
    fn layer_texture(&mut self, ext: &Value, key: &str, what: &str, role: &str, srgb: bool) -> Result<Layer> {
        let Some(info) = ext.get(key) else { return Ok(None) };
        let file = self.at.file;
        let index = info.get("index").and_then(Value::as_u64).ok_or_else(|| anyhow!("{file}: {what}: {key} has no texture index"))?;
        let texture = self.doc.textures().nth(index as usize).ok_or_else(|| anyhow!("{file}: {what}: {key} names textures[{index}], which does not exist"))?;
        let set = info.get("texCoord").and_then(Value::as_u64).unwrap_or(0) as u32;
        let map = match info.get("extensions").and_then(|e| e.get("KHR_texture_transform")) {
            None => UvMap { set, transform: Affine2::IDENTITY },
            Some(t) => {
                let pair = |k: &str, d: Vec2| t.get(k).map_or(Some(d), |v| Some(Vec2::new(v.get(0)?.as_f64()? as f32, v.get(1)?.as_f64()? as f32)));
                let (offset, scale) = (pair("offset", Vec2::ZERO), pair("scale", Vec2::ONE));
                let rotation = t.get("rotation").map_or(Some(0.0), |r| r.as_f64().map(|r| r as f32));
                let (Some(offset), Some(scale), Some(rotation)) = (offset, scale, rotation) else {
                    bail!("{file}: {what}: {key}'s KHR_texture_transform offset, rotation and scale must be numbers");
                };
                if !(offset.is_finite() && scale.is_finite() && rotation.is_finite()) {
                    bail!("{file}: {what}: KHR_texture_transform offset, rotation and scale must be finite numbers");
                }
                let set = t.get("texCoord").and_then(Value::as_u64).map_or(set, |s| s as u32);
                UvMap { set, transform: texture_transform(offset, rotation, scale) }
            }
        };
        Ok(Some((self.image_texture(texture, what, role, srgb)?, map)))
    }
}

/// The texture, its UV map noted under `role`.
fn keep(texture: (Arc<Texture2d>, UvMap), role: &'static str, maps: &mut Vec<(&'static str, UvMap)>) -> Arc<Texture2d> {
    maps.push((role, texture.1));
    texture.0
}

/// Three numbers from 0 to 1.
fn color(v: &Value) -> Option<Vec3> {
    let c: Vec<f32> = v.as_array()?.iter().map(|x| x.as_f64().map(|x| x as f32)).collect::<Option<_>>()?;
    (c.len() == 3 && c.iter().all(|x| (0.0..=1.0).contains(x))).then(|| Vec3::from_slice(&c))
}
