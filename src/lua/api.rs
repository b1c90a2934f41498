//! The `refrakt` module scripts `require`: constructors for every object of the scene graph, and
//! small vector/quaternion helpers (angles in degrees on the Lua side).

use glam::{Quat, Vec3};
use mlua::{Lua, Table, Value};

use super::convert::{self as cv, FieldName, error_at};
use super::objects::{LQuat, Obj, construct, new_glass, new_node};
use crate::scene::{Camera, Diffuse, Environment, Fog, Light, LightKind, Material, Scene, Shape, VolumeSettings};

fn shape(lua: &Lua, init: Shape, t: Option<Table>, required: &[&str]) -> mlua::Result<Obj<Shape>> {
    construct(lua, init, t, required)
}

/// Builds the module table.
pub fn module(lua: &Lua) -> mlua::Result<Table> {
    let r = lua.create_table()?;
    r.raw_set("version", env!("CARGO_PKG_VERSION"))?;

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
    super::meshes::register(lua, &r)?;
    r.raw_set("glass", lua.create_function(|lua, t: Option<Table>| new_glass(lua, t))?)?;
    r.raw_set(
        "diffuse",
        lua.create_function(|lua, t: Option<Table>| construct(lua, Material::Diffuse(Diffuse::default()), t, &[]))?,
    )?;
    r.raw_set("fog", lua.create_function(|lua, t: Option<Table>| construct(lua, Fog::default(), t, &[]))?)?;

    // Lights (KHR_lights_punctual units: candela, lux).
    let light = |kind: LightKind| move |lua: &Lua, t: Option<Table>| construct(lua, Light::new(kind.clone()), t, &[]);
    r.raw_set("point", lua.create_function(light(LightKind::Point))?)?;
    r.raw_set(
        "spot",
        lua.create_function(light(LightKind::Spot { angle: 30f32.to_radians(), blend: 0.15 }))?,
    )?;
    r.raw_set("sun", lua.create_function(light(LightKind::Sun { angular_diameter: 0.53f32.to_radians() }))?)?;
    r.raw_set("rect", lua.create_function(light(LightKind::Rect { size: glam::Vec2::ONE }))?)?;
    r.raw_set("camera", lua.create_function(|lua, t: Option<Table>| construct(lua, Camera::default(), t, &[]))?)?;
    r.raw_set(
        "environment",
        lua.create_function(|lua, t: Option<Table>| construct(lua, Environment::default(), t, &[]))?,
    )?;
    r.raw_set("volume", lua.create_function(|lua, t: Option<Table>| construct(lua, VolumeSettings::default(), t, &[]))?)?;

    // Rotations.
    r.raw_set(
        "euler",
        lua.create_function(|lua, v: Value| {
            Ok(LQuat(cv::rotation(lua, FieldName { what: "refrakt.euler", field: "angles" }, &v)?))
        })?,
    )?;
    r.raw_set(
        "axis_angle",
        lua.create_function(|lua, (axis, degrees): (Value, Value)| {
            let axis = cv::vec3(lua, FieldName { what: "refrakt.axis_angle", field: "axis" }, &axis)?;
            let deg = cv::number(lua, FieldName { what: "refrakt.axis_angle", field: "degrees" }, &degrees)?;
            if axis.length_squared() < 1e-12 {
                return Err(error_at(lua, "refrakt.axis_angle: the axis must not be the zero vector"));
            }
            Ok(LQuat(Quat::from_axis_angle(axis.normalize(), (deg as f32).to_radians())))
        })?,
    )?;
    r.raw_set(
        "quat",
        lua.create_function(|lua, v: Table| {
            let get = |k: &str, i: usize| -> mlua::Result<f32> {
                let mut x: Value = v.raw_get(k)?;
                if x.is_nil() {
                    x = v.raw_get(i)?;
                }
                Ok(cv::number(lua, FieldName { what: "refrakt.quat", field: k }, &x)? as f32)
            };
            let q = Quat::from_xyzw(get("x", 2)?, get("y", 3)?, get("z", 4)?, get("w", 1)?);
            if q.length_squared() < 1e-12 {
                return Err(error_at(lua, "refrakt.quat: a rotation quaternion must not be zero"));
            }
            Ok(LQuat(q.normalize()))
        })?,
    )?;
    r.raw_set(
        "slerp",
        lua.create_function(|lua, (a, b, t): (mlua::UserDataRef<LQuat>, mlua::UserDataRef<LQuat>, Value)| {
            let t = cv::number(lua, FieldName { what: "refrakt.slerp", field: "t" }, &t)? as f32;
            Ok(LQuat(a.0.slerp(b.0, t)))
        })?,
    )?;
    Ok(r)
}
