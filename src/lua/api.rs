//! The `refrakt` module scripts `require`: constructors for every object of the scene graph, and
//! (from `vecmath`) vector, rotation and color helpers (angles in degrees on the Lua side).

use glam::Vec3;
use mlua::{Lua, Table};

use super::glass::new_glass;
use super::objects::{Obj, construct, new_node};
use crate::scene::{Camera, Diffuse, Environment, Fog, Light, LightKind, Material, Scene, Shape, VolumeSettings};

fn shape(lua: &Lua, init: Shape, t: Option<Table>, required: &[&str]) -> mlua::Result<Obj<Shape>> {
    construct(lua, init, t, required)
}

/// Builds the module table.
pub fn module(lua: &Lua) -> mlua::Result<Table> {
    let r = lua.create_table()?;
    r.raw_set("version", env!("CARGO_PKG_VERSION"))?;
    super::params::install(lua, &r)?;

    r.raw_set(
        "scene",
        lua.create_function(|lua, t: Option<Table>| {
            let base = lua
                .app_data_ref::<super::sandbox::FileAccess>()
                .map(|a| a.base.clone())
                .unwrap_or_default();
            construct(lua, Scene { base_dir: base, ..Scene::default() }, t, &[])
        })?,
    )?;
    r.raw_set("node", lua.create_function(|lua, t: Option<Table>| new_node(lua, t))?)?;

    r.raw_set(
        "sphere",
        lua.create_function(|lua, t: Option<Table>| shape(lua, Shape::Sphere { radius: 0.0, boundary: None }, t, &["radius"]))?,
    )?;
    r.raw_set(
        "box",
        lua.create_function(|lua, t: Option<Table>| shape(lua, Shape::Box { size: Vec3::ONE, boundary: None }, t, &["size"]))?,
    )?;
    r.raw_set(
        "luneburg",
        lua.create_function(|lua, t: Option<Table>| {
            shape(lua, Shape::Luneburg { radius: 0.0, boundary: None }, t, &["radius"])
        })?,
    )?;
    r.raw_set(
        "slab",
        lua.create_function(|lua, t: Option<Table>| {
            shape(lua, Shape::Slab { size: Vec3::ONE, ior: 1.5, gradient: 0.0, boundary: None }, t, &["size", "gradient"])
        })?,
    )?;
    r.raw_set(
        "plane",
        lua.create_function(|lua, t: Option<Table>| shape(lua, Shape::Plane { size: glam::Vec2::ONE }, t, &["size"]))?,
    )?;
    r.raw_set("field", lua.create_function(|lua, t: Option<Table>| super::field::new_field(lua, t))?)?;
    r.raw_set("gltf", lua.create_function(|lua, v: mlua::Value| super::imports::new_import(lua, v))?)?;
    super::meshes::register(lua, &r)?;
    r.raw_set("glass", lua.create_function(|lua, t: Option<Table>| new_glass(lua, t))?)?;
    r.raw_set(
        "diffuse",
        lua.create_function(|lua, t: Option<Table>| construct(lua, Material::Diffuse(Diffuse::default()), t, &[]))?,
    )?;
    // The same material with glTF's defaults (metallic 1, roughness 1, specular 1, color 1).
    r.raw_set("pbr", lua.create_function(|lua, t: Option<Table>| construct(lua, Material::Diffuse(Diffuse::pbr()), t, &[]))?)?;
    r.raw_set("fog", lua.create_function(|lua, t: Option<Table>| construct(lua, Fog::default(), t, &[]))?)?;

    // Lights (KHR_lights_punctual units: candela, lux).
    let light = |kind: LightKind| move |lua: &Lua, t: Option<Table>| construct(lua, Light::new(kind.clone()), t, &[]);
    r.raw_set("point", lua.create_function(light(LightKind::Point))?)?;
    r.raw_set(
        "spot",
        lua.create_function(light(LightKind::Spot { angle: 30f32.to_radians(), blend: 0.15 }))?,
    )?;
    r.raw_set("sun", lua.create_function(light(LightKind::Sun { angular_diameter: 0.53f32.to_radians() }))?)?;
    r.raw_set("rect", lua.create_function(light(LightKind::Rect { size: glam::Vec2::ONE, round: false }))?)?;
    r.raw_set("disk", lua.create_function(light(LightKind::Rect { size: glam::Vec2::ONE, round: true }))?)?;
    r.raw_set("camera", lua.create_function(|lua, t: Option<Table>| construct(lua, Camera::default(), t, &[]))?)?;
    r.raw_set(
        "environment",
        lua.create_function(|lua, t: Option<Table>| construct(lua, Environment::default(), t, &[]))?,
    )?;
    r.raw_set("volume", lua.create_function(|lua, t: Option<Table>| construct(lua, VolumeSettings::default(), t, &[]))?)?;

    r.raw_set("ior", ior_table(lua)?)?;
    super::vecmath::install(lua, &r)?;
    Ok(r)
}

/// Indices of refraction of common media at 589 nm (the sodium D line), so scripts can say
/// `ior = r.ior.water`.
const NAMED_IORS: &[(&str, f64)] = &[
    ("air", 1.000293),
    ("water", 1.333),
    ("ice", 1.309),
    ("fused_silica", 1.458),
    ("acrylic", 1.491),
    ("glass", 1.5),
    ("crown", 1.5168),
    ("flint", 1.62),
    ("sapphire", 1.77),
    ("diamond", 2.417),
];

fn ior_table(lua: &Lua) -> mlua::Result<Table> {
    let t = lua.create_table()?;
    for (name, n) in NAMED_IORS {
        t.raw_set(*name, *n)?;
    }
    Ok(t)
}
