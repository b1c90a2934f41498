//! The receivers' material in Lua: `refrakt.diffuse{…}` and its alias with glTF's defaults,
//! `refrakt.pbr{…}` — glTF 2.0's metallic-roughness model (`scene::Diffuse`). The fields are the
//! same; only the defaults differ (`diffuse`: Lambertian, `metallic = 0`, `specular = 0`;
//! `pbr`: glTF's, `color = 1`, `metallic = 1`, `roughness = 1`, `specular = 1`).

use std::sync::Arc;

use mlua::{Lua, Value};

use super::convert::{self as cv, FieldName, error_at};
use super::sandbox::FileAccess;
use crate::scene::{AlphaMode, Diffuse, Texture2d};

pub const FIELDS: &[&str] = &[
    "color",
    "alpha",
    "alpha_mode",
    "alpha_cutoff",
    "metallic",
    "roughness",
    "specular",
    "emission",
    "emission_strength",
    "normal_scale",
    "occlusion_strength",
    "texture",
    "metallic_roughness_texture",
    "normal_texture",
    "occlusion_texture",
    "emission_texture",
    "clearcoat",
    "clearcoat_roughness",
    "clearcoat_texture",
    "clearcoat_roughness_texture",
    "clearcoat_normal_texture",
    "clearcoat_normal_scale",
    "sheen_color",
    "sheen_roughness",
    "sheen_color_texture",
    "sheen_roughness_texture",
];

/// The texture field `key` of `d`, and whether its file is sRGB-encoded (colour) or linear.
fn texture_slot<'a>(d: &'a mut Diffuse, key: &str) -> Option<(&'a mut Option<Arc<Texture2d>>, bool)> {
    Some(match key {
        "texture" => (&mut d.texture, true),
        "metallic_roughness_texture" => (&mut d.metallic_roughness_texture, false),
        "normal_texture" => (&mut d.normal_texture, false),
        "occlusion_texture" => (&mut d.occlusion_texture, false),
        "emission_texture" => (&mut d.emission_texture, true),
        "clearcoat_texture" => (&mut d.clearcoat_texture, false),
        "clearcoat_roughness_texture" => (&mut d.clearcoat_roughness_texture, false),
        "clearcoat_normal_texture" => (&mut d.clearcoat_normal_texture, false),
        "sheen_color_texture" => (&mut d.sheen_color_texture, true),
        "sheen_roughness_texture" => (&mut d.sheen_roughness_texture, false),
        _ => return None,
    })
}

/// A texture reads back as `{width, height}` (its file is not kept).
pub(super) fn texture_value(lua: &Lua, t: &Option<Arc<Texture2d>>) -> mlua::Result<Value> {
    let Some(t) = t else { return Ok(Value::Nil) };
    let table = lua.create_table()?;
    table.raw_set("width", t.width)?;
    table.raw_set("height", t.height)?;
    Ok(Value::Table(table))
}

pub fn get(lua: &Lua, d: &Diffuse, key: &str) -> Option<mlua::Result<Value>> {
    let number = |x: f32| Ok(Value::Number(x as f64));
    Some(match key {
        "color" => super::objects::vec_value(lua, d.color),
        "emission" => super::objects::vec_value(lua, d.emission),
        "alpha" => number(d.alpha),
        "alpha_mode" => lua.create_string(d.alpha_mode.name()).map(Value::String),
        "alpha_cutoff" => number(d.alpha_cutoff),
        "metallic" => number(d.metallic),
        "roughness" => number(d.roughness),
        "specular" => number(d.specular),
        "emission_strength" => number(d.emission_strength),
        "normal_scale" => number(d.normal_scale),
        "occlusion_strength" => number(d.occlusion_strength),
        "texture" => texture_value(lua, &d.texture),
        "metallic_roughness_texture" => texture_value(lua, &d.metallic_roughness_texture),
        "normal_texture" => texture_value(lua, &d.normal_texture),
        "occlusion_texture" => texture_value(lua, &d.occlusion_texture),
        "emission_texture" => texture_value(lua, &d.emission_texture),
        "clearcoat" => number(d.clearcoat),
        "clearcoat_roughness" => number(d.clearcoat_roughness),
        "sheen_color" => super::objects::vec_value(lua, d.sheen_color),
        "sheen_roughness" => number(d.sheen_roughness),
        "clearcoat_texture" => texture_value(lua, &d.clearcoat_texture),
        "clearcoat_roughness_texture" => texture_value(lua, &d.clearcoat_roughness_texture),
        "clearcoat_normal_texture" => texture_value(lua, &d.clearcoat_normal_texture),
        "clearcoat_normal_scale" => number(d.clearcoat_normal_scale),
        "sheen_color_texture" => texture_value(lua, &d.sheen_color_texture),
        "sheen_roughness_texture" => texture_value(lua, &d.sheen_roughness_texture),
        _ => return None,
    })
}

/// Sets `key`; `None` if the material has no such field.
pub fn set(lua: &Lua, d: &mut Diffuse, what: &'static str, key: &str, value: Value) -> Option<mlua::Result<()>> {
    if !FIELDS.contains(&key) {
        return None;
    }
    let name = FieldName { what, field: key };
    let fraction = |v: &Value| cv::number_in(lua, name, v, Some(0.0), Some(1.0), "a number from 0 to 1").map(|x| x as f32);
    let result = (|| {
        match key {
            "color" => d.color = reflectance(lua, name, &value, "an albedo")?,
            "sheen_color" => d.sheen_color = reflectance(lua, name, &value, "a reflectance")?,
            "clearcoat" => d.clearcoat = fraction(&value)?,
            "clearcoat_roughness" => d.clearcoat_roughness = fraction(&value)?,
            "sheen_roughness" => d.sheen_roughness = fraction(&value)?,
            "alpha" => d.alpha = fraction(&value)?,
            "alpha_cutoff" => d.alpha_cutoff = fraction(&value)?,
            "metallic" => d.metallic = fraction(&value)?,
            "roughness" => d.roughness = fraction(&value)?,
            "specular" => d.specular = fraction(&value)?,
            "occlusion_strength" => d.occlusion_strength = fraction(&value)?,
            "alpha_mode" => {
                let given = cv::string(lua, name, &value)?;
                d.alpha_mode = AlphaMode::parse(&given)
                    .ok_or_else(|| error_at(lua, format!("{name} is \"OPAQUE\", \"MASK\" (a cut-out) or \"BLEND\" (see-through), got \"{given}\"")))?;
            }
            "emission" => d.emission = cv::color(lua, name, &value)?,
            "emission_strength" => d.emission_strength = cv::non_negative(lua, name, &value)?,
            "normal_scale" => d.normal_scale = cv::number_in(lua, name, &value, Some(-16.0), Some(16.0), "a number from −16 to 16")? as f32,
            "clearcoat_normal_scale" => {
                d.clearcoat_normal_scale = cv::number_in(lua, name, &value, Some(-16.0), Some(16.0), "a number from −16 to 16")? as f32
            }
            _ => {
                let (slot, srgb) = texture_slot(d, key).expect("the caller checked the field");
                *slot = texture(lua, name, &value, srgb)?;
            }
        }
        Ok(())
    })();
    Some(result)
}

/// A colour whose components are fractions of the light (0 to 1).
fn reflectance(lua: &Lua, name: FieldName, value: &Value, what: &str) -> mlua::Result<glam::Vec3> {
    let c = cv::color(lua, name, value)?;
    if c.max_element() > 1.0 {
        return Err(error_at(lua, format!("{name} is {what}: components must be from 0 to 1, got {c}")));
    }
    Ok(c)
}

/// A PNG or JPEG texture named relative to the scene's folder (nil: none).
pub(super) fn texture(lua: &Lua, name: FieldName, value: &Value, srgb: bool) -> mlua::Result<Option<Arc<Texture2d>>> {
    if value.is_nil() {
        return Ok(None);
    }
    let given = cv::string(lua, name, value)?;
    let path = FileAccess::resolve(lua, &given)?;
    let bytes = std::fs::read(&path).map_err(|e| error_at(lua, format!("{name}: cannot read {}: {e}", path.display())))?;
    let decoded = crate::gltf::material::decode_image(&bytes, srgb).map_err(|e| error_at(lua, format!("{name}: {}: {e:#}", path.display())))?;
    Ok(Some(Arc::new(decoded)))
}
