//! `refrakt.param{ name = "ior", default = 1.5, min = 1.0, max = 2.0 }`: a tunable number of the
//! scene. The call returns the value to use — the default, or the value `refrakt serve`'s page
//! set with its slider (clamped to the range) — and declares the parameter, so the page can show
//! it. `render` and `watch` always use the default.

use std::cell::RefCell;
use std::collections::BTreeMap;

use mlua::{Lua, Table, Value};
use serde::Serialize;

use super::convert::{self as cv, FieldName, error_at, unknown_field};

const FIELDS: &[&str] = &["name", "default", "min", "max", "step"];

/// A declared parameter and the value the script got.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Param {
    pub name: String,
    pub value: f64,
    pub default: f64,
    pub min: f64,
    pub max: f64,
    /// The slider's step (default: a hundredth of the range).
    pub step: f64,
}

/// Values set from outside the script (the page's sliders), by parameter name.
#[derive(Clone, Debug, Default)]
pub struct ParamValues(pub BTreeMap<String, f64>);

/// The parameters a script declared, in order.
#[derive(Default)]
pub struct Declared(pub RefCell<Vec<Param>>);

/// Adds `refrakt.param` to the module table.
pub fn install(lua: &Lua, r: &Table) -> mlua::Result<()> {
    r.raw_set("param", lua.create_function(|lua, t: Table| param(lua, t))?)
}

fn param(lua: &Lua, t: Table) -> mlua::Result<f64> {
    let field = |f: &'static str| FieldName { what: "param", field: f };
    for pair in t.pairs::<Value, Value>() {
        let (key, _) = pair?;
        let key = match &key {
            Value::String(s) => s.to_string_lossy(),
            other => cv::describe(other),
        };
        if !FIELDS.contains(&key.as_str()) {
            return Err(unknown_field(lua, "param", &key, FIELDS));
        }
    }
    let name = cv::string(lua, field("name"), &t.raw_get("name")?)?;
    if name.is_empty() || name.len() > 64 {
        return Err(error_at(lua, "param.name must be 1 to 64 characters"));
    }
    let number = |f: &'static str| -> mlua::Result<f64> { cv::number_in(lua, field(f), &t.raw_get(f)?, None, None, "a number") };
    let (default, min, max) = (number("default")?, number("min")?, number("max")?);
    if min >= max {
        return Err(error_at(lua, format!("param \"{name}\": min ({min}) must be less than max ({max})")));
    }
    if !(min..=max).contains(&default) {
        return Err(error_at(lua, format!("param \"{name}\": default {default} is outside min..max ({min}..{max})")));
    }
    let step = match t.raw_get::<Value>("step")? {
        Value::Nil => (max - min) / 100.0,
        v => cv::number_in(lua, field("step"), &v, Some(f64::MIN_POSITIVE), Some(max - min), "a number > 0, at most max − min")?,
    };
    let set = lua.app_data_ref::<ParamValues>().and_then(|v| v.0.get(&name).copied());
    let value = set.filter(|v| v.is_finite()).map_or(default, |v| v.clamp(min, max));
    let p = Param { name: name.clone(), value, default, min, max, step };
    if lua.app_data_ref::<Declared>().is_none() {
        lua.set_app_data(Declared::default());
    }
    let declared = lua.app_data_ref::<Declared>().expect("just set");
    let mut list = declared.0.borrow_mut();
    match list.iter().find(|q| q.name == name) {
        Some(q) if (q.default, q.min, q.max, q.step) != (p.default, p.min, p.max, p.step) => {
            return Err(error_at(lua, format!("param \"{name}\" is declared twice with different settings")));
        }
        Some(_) => {}
        None => list.push(p),
    }
    Ok(value)
}

/// The parameters the script declared so far.
pub fn declared(lua: &Lua) -> Vec<Param> {
    lua.app_data_ref::<Declared>().map(|d| d.0.borrow().clone()).unwrap_or_default()
}
