//! `refrakt.field{size = …, n = function(x, y, z) … end}`: an index field defined by a script
//! function. `scene::index_fn` samples it at voxel centres each frame (on the CPU, one call per
//! voxel: the slow way to define n, documented as such).

use std::any::Any;
use std::rc::Rc;

use anyhow::{Result, bail};
use glam::Vec3;
use mlua::{Function, Lua, Table, Value, WeakLua};

use super::convert::{self as cv, FieldName, error_at};
use super::objects::{Obj, construct};
use crate::scene::{IndexFn, IndexFunction, Shape};

/// A Lua function n(x, y, z), called in the sandbox under the script's time budget.
struct LuaIndexFn {
    function: Function,
    /// Weak, so a scene holding the function does not keep its own Lua state alive.
    lua: WeakLua,
    /// Where the function was defined (`scene.lua:7`), for messages.
    defined_at: String,
}

impl IndexFunction for LuaIndexFn {
    fn sample(&self, points: &[Vec3]) -> Result<Vec<f32>> {
        let lua = self.lua.upgrade();
        // All the samples of one field count as one call against the time budget.
        super::sandbox::start_budget(&lua);
        points.iter().map(|p| self.call(&lua, *p)).collect()
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

impl LuaIndexFn {
    fn call(&self, lua: &Lua, p: Vec3) -> Result<f32> {
        let v: Value = self.function.call((p.x, p.y, p.z)).map_err(|e| super::script_error(lua, &e))?;
        let n = match v {
            Value::Integer(i) => i as f64,
            Value::Number(n) => n,
            _ => f64::NAN,
        };
        if !(1.0..=4.0).contains(&n) {
            bail!(
                "{}: field.n({:.4}, {:.4}, {:.4}) returned {}; it must return the index of refraction there, a number \
                 from 1 to 4 (clamp it, e.g. math.max(1, …), where the formula leaves that range)",
                self.defined_at,
                p.x,
                p.y,
                p.z,
                cv::describe(&v)
            );
        }
        Ok(n as f32)
    }
}

/// Reads `field.n`: a function (x, y, z) → n.
pub fn index_fn(lua: &Lua, name: FieldName, v: &Value) -> mlua::Result<IndexFn> {
    let Value::Function(f) = v else {
        return Err(error_at(
            lua,
            format!("{name} must be a function(x, y, z) returning the index of refraction, got {}", cv::describe(v)),
        ));
    };
    let info = f.info();
    let defined_at = match (info.short_src, info.line_defined) {
        (Some(src), Some(line)) => format!("{src}:{line}"),
        _ => cv::location(lua),
    };
    Ok(IndexFn(Rc::new(LuaIndexFn { function: f.clone(), lua: lua.weak(), defined_at })))
}

/// `field.n` read back: the script's own function.
pub fn function_value(n: &IndexFn) -> mlua::Result<Value> {
    Ok(n.0.as_any().downcast_ref::<LuaIndexFn>().map_or(Value::Nil, |f| Value::Function(f.function.clone())))
}

/// `refrakt.field{size = {…}, n = function(x, y, z) … end, boundary = …}`.
pub fn new_field(lua: &Lua, table: Option<Table>) -> mlua::Result<Obj<Shape>> {
    let n: Value = match &table {
        Some(t) => t.raw_get("n")?,
        None => Value::Nil,
    };
    if n.is_nil() {
        return Err(error_at(lua, "field needs a field \"n\", a function(x, y, z) returning the index of refraction"));
    }
    let n = index_fn(lua, FieldName { what: "field", field: "n" }, &n)?;
    construct(lua, Shape::Field { size: Vec3::ONE, n, boundary: None }, table, &["size"])
}
