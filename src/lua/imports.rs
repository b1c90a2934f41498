//! `refrakt.gltf("file.glb")` or `refrakt.gltf{file = "file.glb", scene = "…", animation = "…"}`:
//! a glTF file (below the scene's folder, like any asset) as a node whose children are the
//! glTF scene's nodes. Its animations play on the scene clock: before each frame the host poses
//! every import at t, then runs the script's `update` (which may move imported nodes on top),
//! then deforms skinned and morphed meshes for the final pose.

use std::cell::RefCell;

use mlua::{Lua, Table, Value};

use super::convert::{self as cv, FieldName, error_at, unknown_field};
use super::objects::Obj;
use super::sandbox::FileAccess;
use crate::gltf::{ImportOptions, Player};
use crate::scene::{Node, Origin, Scene, shared};

/// The animation players of every glTF file the script imported.
#[derive(Default)]
pub struct Imports(RefCell<Vec<Player>>);

const GLTF_FIELDS: &[&str] = &["file", "scene", "animation", "variant"];

/// `refrakt.gltf(…)`.
pub fn new_import(lua: &Lua, args: Value) -> mlua::Result<Obj<Node>> {
    let what = |field| FieldName { what: "gltf", field };
    let (file, opts) = match &args {
        Value::String(_) => (cv::string(lua, what("file"), &args)?, ImportOptions::default()),
        Value::Table(t) => table_args(lua, t)?,
        other => {
            return Err(error_at(
                lua,
                format!("refrakt.gltf takes a file name or {{file = …, scene = …, animation = …}}, got {}", cv::describe(other)),
            ));
        }
    };
    let path = FileAccess::resolve(lua, &file)?;
    let import = {
        let access = lua.app_data_ref::<FileAccess>().ok_or_else(|| error_at(lua, "file access is not available here"))?;
        crate::gltf::import(&path, &file, &access, &opts).map_err(|e| error_at(lua, format!("{e:#}")))?
    };
    let here = cv::location(lua);
    for w in import.warnings {
        crate::warnings::say(&w.at(&here));
    }
    let mut root = Node::new(import.name);
    root.origin = Origin(here);
    root.children = import.roots;
    if lua.app_data_ref::<Imports>().is_none() {
        lua.set_app_data(Imports::default());
    }
    if let Some(imports) = lua.app_data_ref::<Imports>() {
        let mut players = imports.0.borrow_mut();
        // A script that imports in `update` drops earlier imports: forget their players.
        players.retain(Player::is_alive);
        players.push(import.player);
    }
    Ok(Obj(shared(root)))
}

fn table_args(lua: &Lua, t: &Table) -> mlua::Result<(String, ImportOptions)> {
    let mut file = None;
    let mut opts = ImportOptions::default();
    for pair in t.pairs::<Value, Value>() {
        let (k, v) = pair?;
        let key = match &k {
            Value::String(s) => s.to_string_lossy(),
            other => return Err(error_at(lua, format!("gltf fields are named by strings, got {}", cv::describe(other)))),
        };
        let name = FieldName { what: "gltf", field: &key };
        match key.as_str() {
            "file" => file = Some(cv::string(lua, name, &v)?),
            "scene" => opts.scene = Some(name_or_index(lua, name, &v)?),
            "animation" => opts.animation = Some(name_or_index(lua, name, &v)?),
            "variant" => opts.variant = Some(name_or_index(lua, name, &v)?),
            _ => return Err(unknown_field(lua, "gltf", &key, GLTF_FIELDS)),
        }
    }
    let file = file.ok_or_else(|| error_at(lua, "gltf needs a field \"file\" (refrakt.gltf{file = \"model.glb\"})"))?;
    Ok((file, opts))
}

/// A scene or animation by name, or by its index in the file (0 is the first): an integer ≥ 0
/// is passed on as its digits, which the importer reads as an index when no name matches.
fn name_or_index(lua: &Lua, name: FieldName, v: &Value) -> mlua::Result<String> {
    match v {
        Value::Integer(i) if *i >= 0 => Ok(i.to_string()),
        Value::Number(x) if x.fract() == 0.0 && *x >= 0.0 && *x < 1e15 => Ok((*x as i64).to_string()),
        _ => cv::string(lua, name, v).map_err(|_| cv::wrong(lua, name, "a name or an index (an integer ≥ 0)", v)),
    }
}

/// Sets every imported node to its animated pose at `t` seconds.
pub fn pose(lua: &Lua, t: f64) {
    if let Some(imports) = lua.app_data_ref::<Imports>() {
        for p in imports.0.borrow_mut().iter_mut() {
            p.pose(t);
        }
    }
}

/// Deforms imported skinned and morphed meshes for the scene's current pose.
pub fn deform(lua: &Lua, scene: &Scene) {
    if let Some(imports) = lua.app_data_ref::<Imports>() {
        for p in imports.0.borrow_mut().iter_mut() {
            p.deform(scene);
        }
    }
}

/// Whether any import has an animation.
/// The longest animation of the imported files, seconds.
pub fn duration(lua: &Lua) -> Option<f64> {
    lua.app_data_ref::<Imports>().and_then(|i| i.0.borrow().iter().filter_map(Player::duration).reduce(f64::max))
}

pub fn is_animated(lua: &Lua) -> bool {
    lua.app_data_ref::<Imports>().is_some_and(|i| i.0.borrow().iter().any(Player::is_animated))
}
