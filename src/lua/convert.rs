//! Reading Lua values into Rust with errors a technical artist can act on: each names the
//! script's file:line, the object and field, what was expected and what was given
//! (`scene.lua:12: light.intensity must be a number ≥ 0, got "bright"`).

use glam::{Quat, Vec3};
use mlua::{Lua, Value};

/// `file:line` of the innermost Lua code on the stack (the caller of a Rust function).
pub fn location(lua: &Lua) -> String {
    for level in 0..16 {
        let found = lua.inspect_stack(level, |d| {
            let line = d.current_line()?;
            let src = d.source();
            let short = src.short_src.as_deref().unwrap_or("?").to_string();
            Some(format!("{short}:{line}"))
        });
        match found {
            Some(Some(loc)) => return loc,
            Some(None) => continue,
            None => break,
        }
    }
    "?".to_string()
}

/// A Lua error carrying `file:line: message`.
pub fn error_at(lua: &Lua, message: impl std::fmt::Display) -> mlua::Error {
    mlua::Error::RuntimeError(format!("{}: {message}", location(lua)))
}

/// A short rendering of a Lua value for error messages.
pub fn describe(v: &Value) -> String {
    match v {
        Value::Nil => "nil".into(),
        Value::Boolean(b) => b.to_string(),
        Value::Integer(i) => i.to_string(),
        Value::Number(n) => format_number(*n),
        Value::String(s) => format!("\"{}\"", s.to_string_lossy()),
        Value::Table(t) => {
            let items: Vec<String> = t
                .clone()
                .sequence_values::<Value>()
                .take(5)
                .map(|v| v.map(|v| describe(&v)).unwrap_or_else(|_| "?".into()))
                .collect();
            if items.is_empty() { "a table".into() } else { format!("{{{}}}", items.join(", ")) }
        }
        // refrakt's objects name themselves (`refrakt.sphere`) through __tostring.
        Value::UserData(_) => match v.to_string() {
            Ok(name) => format!("a {name}"),
            Err(_) => "userdata".into(),
        },
        other => other.type_name().to_string(),
    }
}

fn format_number(n: f64) -> String {
    if n.is_nan() {
        "nan".into()
    } else if n.is_infinite() {
        if n > 0.0 { "inf".into() } else { "-inf".into() }
    } else {
        format!("{n}")
    }
}

/// The field being read: `what.field`, for messages.
#[derive(Clone, Copy)]
pub struct FieldName<'a> {
    pub what: &'a str,
    pub field: &'a str,
}

impl std::fmt::Display for FieldName<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}.{}", self.what, self.field)
    }
}

pub fn wrong(lua: &Lua, name: FieldName, expected: &str, got: &Value) -> mlua::Error {
    error_at(lua, format!("{name} must be {expected}, got {}", describe(got)))
}

/// A finite number.
pub fn number(lua: &Lua, name: FieldName, v: &Value) -> mlua::Result<f64> {
    let n = match v {
        Value::Integer(i) => *i as f64,
        Value::Number(n) => *n,
        _ => return Err(wrong(lua, name, "a number", v)),
    };
    if !n.is_finite() {
        return Err(wrong(lua, name, "a finite number", v));
    }
    Ok(n)
}

/// A finite number within [lo, hi] (either bound optional), described as `expected`.
pub fn number_in(lua: &Lua, name: FieldName, v: &Value, lo: Option<f64>, hi: Option<f64>, expected: &str) -> mlua::Result<f64> {
    let n = number(lua, name, v).map_err(|_| wrong(lua, name, expected, v))?;
    if lo.is_some_and(|lo| n < lo) || hi.is_some_and(|hi| n > hi) {
        return Err(wrong(lua, name, expected, v));
    }
    Ok(n)
}

pub fn positive(lua: &Lua, name: FieldName, v: &Value) -> mlua::Result<f32> {
    let n = number(lua, name, v).map_err(|_| wrong(lua, name, "a number > 0", v))?;
    if n <= 0.0 {
        return Err(wrong(lua, name, "a number > 0", v));
    }
    Ok(n as f32)
}

pub fn non_negative(lua: &Lua, name: FieldName, v: &Value) -> mlua::Result<f32> {
    Ok(number_in(lua, name, v, Some(0.0), None, "a number ≥ 0")? as f32)
}

/// A whole number in [lo, hi].
pub fn integer(lua: &Lua, name: FieldName, v: &Value, lo: i64, hi: i64) -> mlua::Result<i64> {
    let expected = format!("a whole number from {lo} to {hi}");
    let n = number(lua, name, v).map_err(|_| wrong(lua, name, &expected, v))?;
    if n.fract() != 0.0 || n < lo as f64 || n > hi as f64 {
        return Err(wrong(lua, name, &expected, v));
    }
    Ok(n as i64)
}

pub fn boolean(lua: &Lua, name: FieldName, v: &Value) -> mlua::Result<bool> {
    match v {
        Value::Boolean(b) => Ok(*b),
        _ => Err(wrong(lua, name, "true or false", v)),
    }
}

pub fn string(lua: &Lua, name: FieldName, v: &Value) -> mlua::Result<String> {
    match v {
        Value::String(s) => Ok(s.to_str().map_err(|_| wrong(lua, name, "UTF-8 text", v))?.to_string()),
        _ => Err(wrong(lua, name, "a string", v)),
    }
}

/// `{x, y, z}` (or `{x = …, y = …, z = …}`) of finite numbers.
pub fn vec3(lua: &Lua, name: FieldName, v: &Value) -> mlua::Result<Vec3> {
    let expected = "a vector {x, y, z} of three finite numbers";
    let Value::Table(t) = v else { return Err(wrong(lua, name, expected, v)) };
    let mut c = [0f32; 3];
    for (i, key) in ["x", "y", "z"].iter().enumerate() {
        let mut item: Value = t.raw_get(i + 1)?;
        if item.is_nil() {
            item = t.raw_get(*key)?;
        }
        let n = match item {
            Value::Integer(k) => k as f64,
            Value::Number(n) => n,
            _ => return Err(wrong(lua, name, expected, v)),
        };
        if !n.is_finite() {
            return Err(error_at(
                lua,
                format!("{name} must be {expected}, but component {} is {}", key, format_number(n)),
            ));
        }
        c[i] = n as f32;
    }
    if t.raw_len() > 3 {
        return Err(wrong(lua, name, expected, v));
    }
    Ok(Vec3::from(c))
}

/// A linear RGB color `{r, g, b}` with non-negative components.
pub fn color(lua: &Lua, name: FieldName, v: &Value) -> mlua::Result<Vec3> {
    let c = vec3(lua, name, v).map_err(|_| wrong(lua, name, "a color {r, g, b} of numbers ≥ 0", v))?;
    if c.min_element() < 0.0 {
        return Err(wrong(lua, name, "a color {r, g, b} of numbers ≥ 0", v));
    }
    Ok(c)
}

/// A positive vector (sizes).
pub fn size3(lua: &Lua, name: FieldName, v: &Value) -> mlua::Result<Vec3> {
    let s = vec3(lua, name, v).map_err(|_| wrong(lua, name, "a size {x, y, z} of numbers > 0", v))?;
    if s.min_element() <= 0.0 {
        return Err(wrong(lua, name, "a size {x, y, z} of numbers > 0", v));
    }
    Ok(s)
}

/// A rotation: Euler angles in degrees `{x, y, z}` (applied X, then Y, then Z — Blender's
/// default "XYZ" order), or a quaternion made by `refrakt.quat`/`refrakt.axis_angle`.
pub fn rotation(lua: &Lua, name: FieldName, v: &Value) -> mlua::Result<Quat> {
    if let Value::UserData(u) = v {
        if let Ok(q) = u.borrow::<super::objects::LQuat>() {
            return Ok(q.0);
        }
    }
    let e = vec3(lua, name, v).map_err(|_| {
        wrong(lua, name, "Euler angles {x, y, z} in degrees or a refrakt.quat", v)
    })?;
    Ok(euler_degrees(e))
}

/// Euler angles (degrees) applied X, then Y, then Z: R = Rz · Ry · Rx.
pub fn euler_degrees(e: Vec3) -> Quat {
    Quat::from_euler(glam::EulerRot::ZYX, e.z.to_radians(), e.y.to_radians(), e.x.to_radians())
}

/// A positive 2D size `{x, y}`.
pub fn size2(lua: &Lua, name: FieldName, v: &Value) -> mlua::Result<glam::Vec2> {
    let expected = "a size {x, y} of two numbers > 0";
    let Value::Table(t) = v else { return Err(wrong(lua, name, expected, v)) };
    if t.raw_len() != 2 {
        return Err(wrong(lua, name, expected, v));
    }
    let x: Value = t.raw_get(1)?;
    let y: Value = t.raw_get(2)?;
    let x = positive(lua, name, &x).map_err(|_| wrong(lua, name, expected, v))?;
    let y = positive(lua, name, &y).map_err(|_| wrong(lua, name, expected, v))?;
    Ok(glam::Vec2::new(x, y))
}

/// `{x, y}` of two numbers from −`bound` to `bound`.
pub fn vec2_within(lua: &Lua, name: FieldName, v: &Value, bound: f64) -> mlua::Result<glam::Vec2> {
    let expected = format!("a pair {{x, y}} of numbers from -{bound} to {bound}");
    let Value::Table(t) = v else { return Err(wrong(lua, name, &expected, v)) };
    if t.raw_len() != 2 {
        return Err(wrong(lua, name, &expected, v));
    }
    let component = |i: usize| -> mlua::Result<f32> {
        let item: Value = t.raw_get(i)?;
        Ok(number_in(lua, name, &item, Some(-bound), Some(bound), &expected).map_err(|_| wrong(lua, name, &expected, v))? as f32)
    };
    Ok(glam::Vec2::new(component(1)?, component(2)?))
}

/// `{w, h}` image size in pixels.
pub fn image_size(lua: &Lua, name: FieldName, v: &Value) -> mlua::Result<(u32, u32)> {
    let expected = "an image size {width, height} of whole numbers from 1 to 16384";
    let Value::Table(t) = v else { return Err(wrong(lua, name, expected, v)) };
    let w: Value = t.raw_get(1)?;
    let h: Value = t.raw_get(2)?;
    let w = integer(lua, name, &w, 1, 16384).map_err(|_| wrong(lua, name, expected, v))?;
    let h = integer(lua, name, &h, 1, 16384).map_err(|_| wrong(lua, name, expected, v))?;
    Ok((w as u32, h as u32))
}

/// Levenshtein distance, for "did you mean …?".
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + usize::from(ca != *cb)).min(prev[j + 1] + 1).min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

/// The closest known name, if it is close enough to be a typo.
pub fn suggest<'a>(given: &str, known: &[&'a str]) -> Option<&'a str> {
    known
        .iter()
        .map(|k| (edit_distance(&given.to_lowercase(), k), *k))
        .filter(|(d, k)| *d <= 2.max(k.len() / 3))
        .min_by_key(|(d, _)| *d)
        .map(|(_, k)| k)
}

/// The error for a field an object does not have.
pub fn unknown_field(lua: &Lua, what: &str, field: &str, known: &[&str]) -> mlua::Error {
    let hint = match suggest(field, known) {
        Some(s) => format!(" (did you mean {s}?)"),
        None => format!(" (fields: {})", known.join(", ")),
    };
    error_at(lua, format!("{what} has no field \"{field}\"{hint}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggestions_catch_typos_not_unrelated_words() {
        let known = ["translation", "rotation", "scale", "shape", "material"];
        assert_eq!(suggest("tranlsation", &known), Some("translation"));
        assert_eq!(suggest("scael", &known), Some("scale"));
        assert_eq!(suggest("banana", &known), None);
    }

    #[test]
    fn euler_order_is_x_then_y_then_z() {
        let q = euler_degrees(Vec3::new(90.0, 90.0, 0.0));
        // X first takes +Y to +Z, then Y takes +Z to +X.
        assert!((q * Vec3::Y - Vec3::X).length() < 1e-5);
    }
}
