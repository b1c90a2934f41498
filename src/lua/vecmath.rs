//! Vector, rotation and color helpers of the `refrakt` module. Vectors are plain Lua tables
//! `{x, y, z}` (so they go straight into `node.translation`), rotations are `refrakt.quat`
//! values, angles are degrees, colors linear Rec.709.

use glam::{Quat, Vec3};
use mlua::{Function, Lua, Table, Value};

use super::convert::{self as cv, FieldName, error_at};
use super::objects::{LQuat, vec_value};
use crate::scene::look_rotation;
use crate::scene::material::srgb_to_linear;

/// Adds `refrakt.vec`, the rotation constructors and `refrakt.srgb` to the module table.
pub fn install(lua: &Lua, r: &Table) -> mlua::Result<()> {
    r.raw_set("vec", vec_table(lua)?)?;
    r.raw_set(
        "euler",
        lua.create_function(|lua, v: Value| Ok(LQuat(cv::rotation(lua, arg("refrakt.euler", "angles"), &v)?)))?,
    )?;
    r.raw_set(
        "axis_angle",
        lua.create_function(|lua, (axis, degrees): (Value, Value)| {
            let axis = nonzero(lua, "refrakt.axis_angle", "axis", &axis)?;
            let deg = cv::number(lua, arg("refrakt.axis_angle", "degrees"), &degrees)?;
            Ok(LQuat(Quat::from_axis_angle(axis, (deg as f32).to_radians())))
        })?,
    )?;
    r.raw_set("quat", lua.create_function(quat)?)?;
    r.raw_set(
        "slerp",
        lua.create_function(|lua, (a, b, t): (Value, Value, Value)| {
            let a = cv::rotation(lua, arg("refrakt.slerp", "a"), &a)?;
            let b = cv::rotation(lua, arg("refrakt.slerp", "b"), &b)?;
            let t = cv::number(lua, arg("refrakt.slerp", "t"), &t)? as f32;
            Ok(LQuat(a.slerp(b, t)))
        })?,
    )?;
    r.raw_set(
        "look_at",
        lua.create_function(|lua, (from, to, up): (Value, Value, Value)| {
            let from = cv::vec3(lua, arg("refrakt.look_at", "from"), &from)?;
            let to = cv::vec3(lua, arg("refrakt.look_at", "to"), &to)?;
            let up = if up.is_nil() { Vec3::Y } else { nonzero(lua, "refrakt.look_at", "up", &up)? };
            let forward = (to - from)
                .try_normalize()
                .ok_or_else(|| error_at(lua, "refrakt.look_at: from and to are the same point, so there is no direction"))?;
            Ok(LQuat(look_rotation(forward, up)))
        })?,
    )?;
    r.raw_set("srgb", lua.create_function(srgb)?)?;
    Ok(())
}

fn arg<'a>(what: &'a str, field: &'a str) -> FieldName<'a> {
    FieldName { what, field }
}

/// A vector that must have a direction; returned normalized.
fn nonzero(lua: &Lua, what: &str, field: &str, v: &Value) -> mlua::Result<Vec3> {
    cv::vec3(lua, arg(what, field), v)?
        .try_normalize()
        .ok_or_else(|| error_at(lua, format!("{what}: {field} must not be the zero vector")))
}

/// `refrakt.quat{w, x, y, z}` or `refrakt.quat{w = …, x = …, y = …, z = …}` (normalized).
fn quat(lua: &Lua, v: Value) -> mlua::Result<LQuat> {
    let Value::Table(t) = &v else {
        return Err(error_at(lua, format!("refrakt.quat takes a table {{w, x, y, z}}, got {}", cv::describe(&v))));
    };
    let get = |k: &str, i: usize| -> mlua::Result<f32> {
        let mut x: Value = t.raw_get(k)?;
        if x.is_nil() {
            x = t.raw_get(i)?;
        }
        Ok(cv::number(lua, arg("refrakt.quat", k), &x)? as f32)
    };
    let q = Quat::from_xyzw(get("x", 2)?, get("y", 3)?, get("z", 4)?, get("w", 1)?);
    if q.length_squared() < 1e-12 {
        return Err(error_at(lua, "refrakt.quat: a rotation quaternion must not be zero"));
    }
    Ok(LQuat(q.normalize()))
}

/// `refrakt.vec`: arithmetic on `{x, y, z}` tables.
fn vec_table(lua: &Lua) -> mlua::Result<Table> {
    let t = lua.create_table()?;
    let binary = |name: &'static str, op: fn(Vec3, Vec3) -> Vec3| -> mlua::Result<Function> {
        lua.create_function(move |lua, (a, b): (Value, Value)| {
            let what = format!("refrakt.vec.{name}");
            vec_value(lua, op(cv::vec3(lua, arg(&what, "a"), &a)?, cv::vec3(lua, arg(&what, "b"), &b)?))
        })
    };
    t.raw_set("add", binary("add", |a, b| a + b)?)?;
    t.raw_set("sub", binary("sub", |a, b| a - b)?)?;
    t.raw_set("mul", binary("mul", |a, b| a * b)?)?;
    t.raw_set("cross", binary("cross", Vec3::cross)?)?;
    let scalar = |name: &'static str, op: fn(Vec3, Vec3) -> f32| -> mlua::Result<Function> {
        lua.create_function(move |lua, (a, b): (Value, Value)| {
            let what = format!("refrakt.vec.{name}");
            Ok(op(cv::vec3(lua, arg(&what, "a"), &a)?, cv::vec3(lua, arg(&what, "b"), &b)?) as f64)
        })
    };
    t.raw_set("dot", scalar("dot", |a, b| a.dot(b))?)?;
    t.raw_set("distance", scalar("distance", Vec3::distance)?)?;
    t.raw_set(
        "scale",
        lua.create_function(|lua, (v, s): (Value, Value)| {
            let v = cv::vec3(lua, arg("refrakt.vec.scale", "v"), &v)?;
            vec_value(lua, v * cv::number(lua, arg("refrakt.vec.scale", "s"), &s)? as f32)
        })?,
    )?;
    t.raw_set(
        "length",
        lua.create_function(|lua, v: Value| Ok(cv::vec3(lua, arg("refrakt.vec.length", "v"), &v)?.length() as f64))?,
    )?;
    t.raw_set(
        "normalize",
        lua.create_function(|lua, v: Value| vec_value(lua, nonzero(lua, "refrakt.vec.normalize", "v", &v)?))?,
    )?;
    t.raw_set(
        "lerp",
        lua.create_function(|lua, (a, b, s): (Value, Value, Value)| {
            let a = cv::vec3(lua, arg("refrakt.vec.lerp", "a"), &a)?;
            let b = cv::vec3(lua, arg("refrakt.vec.lerp", "b"), &b)?;
            vec_value(lua, a.lerp(b, cv::number(lua, arg("refrakt.vec.lerp", "t"), &s)? as f32))
        })?,
    )?;
    Ok(t)
}

/// `refrakt.srgb("#ffcc88")` or `refrakt.srgb{1, 0.8, 0.53}`: a color as a color picker shows
/// it (sRGB-encoded) → the linear Rec.709 values refrakt works in.
fn srgb(lua: &Lua, v: Value) -> mlua::Result<Value> {
    let encoded = match &v {
        Value::String(s) => hex_color(&s.to_string_lossy()).ok_or_else(|| {
            error_at(lua, format!("refrakt.srgb: \"{}\" is not a hex color like \"#ffcc88\"", s.to_string_lossy()))
        })?,
        _ => {
            let c = cv::color(lua, arg("refrakt.srgb", "color"), &v)?;
            if c.max_element() > 1.0 {
                return Err(error_at(
                    lua,
                    format!("refrakt.srgb: components are from 0 to 1, got {c} (for 0–255 values, divide by 255)"),
                ));
            }
            c
        }
    };
    vec_value(lua, encoded.map(srgb_to_linear))
}

fn hex_color(s: &str) -> Option<Vec3> {
    let h = s.strip_prefix('#').unwrap_or(s);
    if h.len() != 6 || !h.is_ascii() {
        return None;
    }
    let byte = |i: usize| u8::from_str_radix(&h[i..i + 2], 16).ok().map(|b| b as f32 / 255.0);
    Some(Vec3::new(byte(0)?, byte(2)?, byte(4)?))
}
