//! Glass in Lua: `refrakt.glass{…}` (`scene::Glass`) — a refractive, absorbing, scattering
//! medium, or with `thin = true` a sheet — and its fields read and written by name.

use std::sync::Arc;

use glam::Vec3;
use mlua::{Lua, Table, Value};

use super::convert::{self as cv, FieldName, error_at};
use super::objects::{Obj, construct, number_value, vec_value};
use super::pbr::{texture, texture_value};
use crate::scene::{AlphaMode, Glass, Material, Texture2d};

pub const FIELDS: &[&str] = &[
    "ior", "absorption", "color", "distance", "scattering", "g", "tint", "roughness", "thin", "dispersion", "abbe", "priority", "multiscatter", "emission",
    "emission_strength", "tint_texture", "roughness_texture", "emission_texture", "normal_texture", "normal_scale", "transmission",
    "transmission_texture", "alpha", "alpha_mode", "alpha_cutoff", "metallic", "base_color", "specular", "specular_color", "specular_texture",
    "specular_color_texture",
];

/// The texture field `key` of `g`, and whether its file is sRGB-encoded (colour) or linear.
fn texture_slot<'a>(g: &'a mut Glass, key: &str) -> Option<(&'a mut Option<Arc<Texture2d>>, bool)> {
    Some(match key {
        "tint_texture" => (&mut g.tint_texture, true),
        "roughness_texture" => (&mut g.roughness_texture, false),
        "emission_texture" => (&mut g.emission_texture, true),
        "normal_texture" => (&mut g.normal_texture, false),
        "transmission_texture" => (&mut g.transmission_texture, false),
        "specular_texture" => (&mut g.specular_texture, false),
        "specular_color_texture" => (&mut g.specular_color_texture, true),
        _ => return None,
    })
}

/// A colour each of whose channels is a fraction from 0 to 1.
fn fraction_color(lua: &Lua, name: FieldName, value: &Value, meaning: &str) -> mlua::Result<Vec3> {
    let c = cv::color(lua, name, value)?;
    if c.max_element() > 1.0 {
        return Err(error_at(lua, &format!("{name} is {meaning}, each channel from 0 to 1 (got {c})")));
    }
    Ok(c)
}

/// Glass field `key` of `g`; None when glass has no such field.
pub fn get(lua: &Lua, g: &Glass, key: &str) -> Option<mlua::Result<Value>> {
    Some(match key {
        "ior" => Ok(number_value(g.ior)),
        "absorption" => vec_value(lua, g.absorption),
        "scattering" => vec_value(lua, g.scattering),
        "g" => Ok(number_value(g.g)),
        "tint" => vec_value(lua, g.tint),
        "roughness" => Ok(number_value(g.roughness)),
        "thin" => Ok(g.thin.map_or(Value::Nil, Value::Boolean)),
        "dispersion" => Ok(number_value(g.dispersion)),
        "priority" => Ok(Value::Integer(g.priority as i64)),
        "multiscatter" => Ok(Value::Boolean(g.multiscatter)),
        "emission" => vec_value(lua, g.emission),
        "emission_strength" => Ok(number_value(g.emission_strength)),
        "normal_scale" => Ok(number_value(g.normal_scale)),
        "tint_texture" => texture_value(lua, &g.tint_texture),
        "roughness_texture" => texture_value(lua, &g.roughness_texture),
        "emission_texture" => texture_value(lua, &g.emission_texture),
        "normal_texture" => texture_value(lua, &g.normal_texture),
        "transmission_texture" => texture_value(lua, &g.transmission_texture),
        "specular_texture" => texture_value(lua, &g.specular_texture),
        "specular_color_texture" => texture_value(lua, &g.specular_color_texture),
        "specular" => Ok(number_value(g.specular)),
        "specular_color" => vec_value(lua, g.specular_color),
        "transmission" => Ok(number_value(g.transmission)),
        "alpha" => Ok(number_value(g.alpha)),
        "metallic" => Ok(number_value(g.metallic)),
        "base_color" => vec_value(lua, g.base()),
        "alpha_cutoff" => Ok(number_value(g.alpha_cutoff)),
        "alpha_mode" => lua.create_string(g.alpha_mode.name()).map(Value::String),
        // The Abbe number V_d = 20/dispersion; nil without dispersion.
        "abbe" => Ok(if g.dispersion > 0.0 { number_value(20.0 / g.dispersion) } else { Value::Nil }),
        // Transmittance over one metre (the color a 1 m thick piece has).
        "color" => vec_value(lua, (-g.absorption).exp()),
        "distance" => Ok(Value::Number(1.0)),
        _ => return None,
    })
}

/// Sets glass field `key` of `g`; None when glass has no such field.
pub fn set(lua: &Lua, g: &mut Glass, key: &str, value: Value) -> Option<mlua::Result<()>> {
    FIELDS.contains(&key).then(|| set_field(lua, g, key, value))
}

fn set_field(lua: &Lua, g: &mut Glass, key: &str, value: Value) -> mlua::Result<()> {
    let name = FieldName { what: "glass", field: key };
    match key {
        "ior" => {
            g.ior = cv::number_in(lua, name, &value, Some(1.0), Some(4.0), "a number from 1 to 4")? as f32
        }
        "absorption" => g.absorption = cv::color(lua, name, &value)?,
        "scattering" => g.scattering = cv::color(lua, name, &value)?,
        "emission" => g.emission = cv::color(lua, name, &value)?,
        "emission_strength" => g.emission_strength = cv::non_negative(lua, name, &value)?,
        "tint" => g.tint = fraction_color(lua, name, &value, "a fraction of the light passed per surface")?,
        "base_color" => g.base_color = Some(fraction_color(lua, name, &value, "the diffuse base's and the metal's colour")?),
        "roughness" => {
            g.roughness = cv::number_in(lua, name, &value, Some(0.0), Some(1.0), "a number from 0 (polished) to 1")? as f32
        }
        "thin" => {
            g.thin = match value {
                Value::Nil => None,
                Value::Boolean(b) => Some(b),
                other => {
                    return Err(error_at(
                        lua,
                        &format!("glass.thin is true (a sheet), false (a solid) or nil (decided by the mesh), got {}", other.type_name()),
                    ));
                }
            }
        }
        "dispersion" => {
            g.dispersion = cv::number_in(lua, name, &value, Some(0.0), Some(20.0), "20/V_d (KHR_materials_dispersion), from 0 (none) to 20")? as f32
        }
        "abbe" => {
            let abbe = match value {
                Value::Nil => 0.0,
                _ => cv::number_in(lua, name, &value, Some(1.0), Some(1e6), "an Abbe number V_d ≥ 1 (crown glass 59, flint 36, diamond 55), or nil for none")?,
            };
            g.dispersion = crate::cpu::spectrum::dispersion_from_abbe(abbe as f32);
        }
        "priority" => {
            g.priority = cv::integer(lua, name, &value, -1000, 1000)? as i32;
        }
        "multiscatter" => {
            let Value::Boolean(b) = value else {
                return Err(error_at(
                    lua,
                    &format!("glass.multiscatter is true (rough glass keeps its energy, Cycles' Multiscatter GGX) or false (single-scattering GGX), got {}", value.type_name()),
                ));
            };
            g.multiscatter = b;
        }
        "g" => {
            g.g = cv::number_in(lua, name, &value, Some(-0.99), Some(0.99), "a number from −0.99 to 0.99")? as f32
        }
        "normal_scale" => g.normal_scale = cv::number_in(lua, name, &value, Some(-16.0), Some(16.0), "a number from −16 to 16")? as f32,
        "alpha" => g.alpha = cv::number_in(lua, name, &value, Some(0.0), Some(1.0), "a number from 0 to 1")? as f32,
        "metallic" => g.metallic = cv::number_in(lua, name, &value, Some(0.0), Some(1.0), "a number from 0 (glass) to 1 (metal)")? as f32,
        "alpha_cutoff" => g.alpha_cutoff = cv::number_in(lua, name, &value, Some(0.0), Some(1.0), "a number from 0 to 1")? as f32,
        "alpha_mode" => {
            let given = cv::string(lua, name, &value)?;
            g.alpha_mode = AlphaMode::parse(&given).ok_or_else(|| {
                error_at(lua, format!("{name} is \"OPAQUE\", \"MASK\" (a cut-out) or \"BLEND\" (see-through), got \"{given}\""))
            })?;
        }
        "transmission" => {
            g.transmission = cv::number_in(lua, name, &value, Some(0.0), Some(1.0), "a number from 0 (an opaque, diffuse base) to 1 (all glass)")? as f32
        }
        "specular" => {
            g.specular = cv::number_in(lua, name, &value, Some(0.0), Some(1.0), "a number from 0 (reflects nothing) to 1 (the Fresnel reflection of its ior)")? as f32
        }
        // (KHR_materials_specular lets the colour exceed 1: F₀ × colour is capped at 1.)
        "specular_color" => g.specular_color = cv::color(lua, name, &value)?,
        "tint_texture" | "roughness_texture" | "emission_texture" | "normal_texture" | "transmission_texture" | "specular_texture" | "specular_color_texture" => {
            let (slot, srgb) = texture_slot(g, key).expect("a texture field");
            *slot = texture(lua, name, &value, srgb)?;
        }
        "color" | "distance" => {
            return Err(error_at(
                lua,
                "glass.color and glass.distance are set together in refrakt.glass{color = {…}, distance = …} \
                 (the color light takes on after travelling that far); after that, set glass.absorption",
            ));
        }
        _ => unreachable!("set_field is called for glass fields only"),
    }
    Ok(())
}

/// `refrakt.glass{…}`: `color` + `distance` (glTF's attenuation color and distance) become
/// absorption = −ln(color) / distance.
pub fn new_glass(lua: &Lua, table: Option<Table>) -> mlua::Result<Obj<Material>> {
    let mut color = None;
    let mut distance = 1.0f32;
    let rest = lua.create_table()?;
    if let Some(t) = table {
        for pair in t.pairs::<Value, Value>() {
            let (k, v) = pair?;
            let key = match &k { Value::String(s) => s.to_str().ok().map(|x| x.to_string()), _ => None };
            match key.as_deref() {
                Some("color") => {
                    color = Some(cv::color(lua, FieldName { what: "glass", field: "color" }, &v)?);
                }
                Some("distance") => distance = cv::positive(lua, FieldName { what: "glass", field: "distance" }, &v)?,
                Some("abbe") if t.contains_key("dispersion")? => {
                    return Err(error_at(lua, "give glass either abbe (V_d) or dispersion (20/V_d), not both"));
                }
                _ => rest.raw_set(k, v)?,
            }
        }
    }
    let obj = construct(lua, Material::Glass(Glass::default()), Some(rest), &[])?;
    if let (Some(c), Material::Glass(g)) = (color, &mut *obj.0.borrow_mut()) {
        if g.absorption != Vec3::ZERO {
            return Err(error_at(lua, "give glass either absorption or color + distance, not both"));
        }
        g.absorption = Glass::absorption_from(c, distance)
            .ok_or_else(|| error_at(lua, "glass.color must have components in (0, 1] (the transmitted fraction)"))?;
    }
    Ok(obj)
}

