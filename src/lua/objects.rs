//! The objects a script sees: scene, nodes, shapes, materials, cameras, environment, volume.
//!
//! Each is a userdata over a shared Rust value of the scene graph, with its fields read and
//! written by name (`node.translation = {0, 1, 0}`), so the script edits the same graph that is
//! rendered. One generic wrapper [`Obj`] gives every kind the same behaviour: typed fields with
//! clear errors, "did you mean …?" for unknown ones, `==` by identity, and `tostring`.

use std::path::PathBuf;
use std::rc::Rc;

use glam::{Quat, Vec3};
use mlua::{AnyUserData, IntoLua, Lua, MetaMethod, Table, UserData, UserDataMethods, Value};

use super::convert::{self as cv, FieldName, error_at, unknown_field};
use super::sandbox::FileAccess;
use crate::scene::environment::{self, EnvironmentSource};
use crate::scene::light::LUMENS_PER_WATT;
use crate::scene::{Camera, Environment, Fog, Lens, Light, LightKind, Material, MotionBlur, Node, Origin, Scene, Shape, Shared, VolumeSettings, shared};

/// A scene-graph value a script can read and write field by field.
pub trait LuaObject: Sized + 'static {
    /// Name used in messages and `tostring` ("sphere", "node", …).
    fn kind(&self) -> &'static str;
    /// Every field, for "did you mean" and the docs.
    fn fields(&self) -> &'static [&'static str];
    fn get(&self, lua: &Lua, key: &str) -> mlua::Result<Value>;
    fn set(&mut self, lua: &Lua, key: &str, value: Value) -> mlua::Result<()>;
    /// Methods beyond field access (`scene:add`, `node:find`, …).
    fn methods<M: UserDataMethods<Obj<Self>>>(_m: &mut M) {}
}

/// A shared scene-graph value seen from Lua.
pub struct Obj<T>(pub Shared<T>);

impl<T> Clone for Obj<T> {
    fn clone(&self) -> Self {
        Obj(self.0.clone())
    }
}

impl<T: LuaObject> UserData for Obj<T> {
    fn add_methods<M: UserDataMethods<Self>>(m: &mut M) {
        T::methods(m);
        m.add_meta_method(MetaMethod::Index, |lua, this, key: Value| {
            let key = field_key(lua, &key, this.0.borrow().kind())?;
            this.0.borrow().get(lua, &key)
        });
        m.add_meta_method(MetaMethod::NewIndex, |lua, this, (key, value): (Value, Value)| {
            let key = field_key(lua, &key, this.0.borrow().kind())?;
            writable(lua, &this.0)?.set(lua, &key, value)
        });
        m.add_meta_method(MetaMethod::Eq, |_, this, other: AnyUserData| {
            Ok(other.borrow::<Obj<T>>().map(|o| Rc::ptr_eq(&o.0, &this.0)).unwrap_or(false))
        });
        m.add_meta_method(MetaMethod::ToString, |_, this, ()| Ok(format!("refrakt.{}", this.0.borrow().kind())));
    }
}

/// Borrows a graph object for writing. The graph is only ever borrowed while a frame is being
/// evaluated, and the only script code that runs then is a field's `n` function: that gets an
/// error instead of a panic.
fn writable<'a, T>(lua: &Lua, o: &'a Shared<T>) -> mlua::Result<std::cell::RefMut<'a, T>> {
    o.try_borrow_mut().map_err(|_| {
        error_at(lua, "the scene cannot be changed while a frame is being evaluated (here: inside a field's n function); change it in update(scene, t)")
    })
}

fn field_key(lua: &Lua, key: &Value, kind: &str) -> mlua::Result<String> {
    match key {
        Value::String(s) => Ok(s.to_string_lossy()),
        other => Err(error_at(lua, format!("{kind} fields are named by strings, got {}", cv::describe(other)))),
    }
}

/// Builds an object from a constructor table: every key is set through [`LuaObject::set`] (so
/// constructor and later assignment validate alike), in sorted order so errors are stable.
pub fn construct<T: LuaObject>(lua: &Lua, mut init: T, table: Option<Table>, required: &[&str]) -> mlua::Result<Obj<T>> {
    let mut pairs: Vec<(String, Value)> = Vec::new();
    if let Some(t) = table {
        for pair in t.pairs::<Value, Value>() {
            let (k, v) = pair?;
            pairs.push((field_key(lua, &k, init.kind())?, v));
        }
    }
    pairs.sort_by(|a, b| a.0.cmp(&b.0));
    for name in required {
        if !pairs.iter().any(|(k, _)| k == name) {
            return Err(error_at(lua, format!("{} needs a field \"{name}\"", init.kind())));
        }
    }
    for (k, v) in pairs {
        init.set(lua, &k, v)?;
    }
    Ok(Obj(shared(init)))
}

/// Reads a userdata argument of the expected kind.
pub fn expect_obj<T: LuaObject>(lua: &Lua, name: FieldName, v: &Value, expected: &str) -> mlua::Result<Shared<T>> {
    if let Value::UserData(u) = v {
        if let Ok(o) = u.borrow::<Obj<T>>() {
            return Ok(o.0.clone());
        }
    }
    Err(error_at(lua, format!("{name} must be {expected}, got {}", cv::describe(v))))
}

fn opt_obj<T: LuaObject>(lua: &Lua, name: FieldName, v: &Value, expected: &str) -> mlua::Result<Option<Shared<T>>> {
    if v.is_nil() { Ok(None) } else { expect_obj(lua, name, v, expected).map(Some) }
}

pub fn vec_value(lua: &Lua, v: Vec3) -> mlua::Result<Value> {
    lua.create_sequence_from(v.to_array().map(decimal))?.into_lua(lua)
}

/// The f64 a script most likely wrote for a value stored as f32: the shortest decimal that
/// rounds to it. So `glass.ior = 1.62` reads back as exactly 1.62, not 1.6200000047683716.
pub(crate) fn decimal(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(x as f64)
}

pub fn number_value(x: f32) -> Value {
    Value::Number(decimal(x))
}

fn obj_value<T: LuaObject>(lua: &Lua, o: &Option<Shared<T>>) -> mlua::Result<Value> {
    match o {
        Some(s) => Obj(s.clone()).into_lua(lua),
        None => Ok(Value::Nil),
    }
}

// ---------------------------------------------------------------------------------------------
// Quaternions (value type).

/// A rotation, made by `refrakt.quat`, `refrakt.axis_angle` or `refrakt.euler`.
#[derive(Clone, Copy)]
pub struct LQuat(pub Quat);

impl UserData for LQuat {
    fn add_fields<F: mlua::UserDataFields<Self>>(f: &mut F) {
        f.add_field_method_get("w", |_, q| Ok(q.0.w));
        f.add_field_method_get("x", |_, q| Ok(q.0.x));
        f.add_field_method_get("y", |_, q| Ok(q.0.y));
        f.add_field_method_get("z", |_, q| Ok(q.0.z));
    }
    fn add_methods<M: UserDataMethods<Self>>(m: &mut M) {
        m.add_method("inverse", |_, q, ()| Ok(LQuat(q.0.inverse())));
        m.add_method("euler", |lua, q, ()| {
            let (z, y, x) = q.0.to_euler(glam::EulerRot::ZYX);
            vec_value(lua, Vec3::new(x, y, z) * (180.0 / std::f32::consts::PI))
        });
        m.add_method("rotate", |lua, q, v: Value| {
            let v = cv::vec3(lua, FieldName { what: "quat:rotate", field: "vector" }, &v)?;
            vec_value(lua, q.0 * v)
        });
        m.add_meta_function(MetaMethod::Mul, |lua, (a, b): (AnyUserData, Value)| {
            let a = a.borrow::<LQuat>()?.0;
            if let Value::UserData(u) = &b {
                if let Ok(q) = u.borrow::<LQuat>() {
                    return LQuat((a * q.0).normalize()).into_lua(lua);
                }
            }
            let v = cv::vec3(lua, FieldName { what: "quat *", field: "operand" }, &b)?;
            vec_value(lua, a * v)
        });
        m.add_meta_method(MetaMethod::ToString, |_, q, ()| {
            Ok(format!("refrakt.quat{{w = {}, x = {}, y = {}, z = {}}}", q.0.w, q.0.x, q.0.y, q.0.z))
        });
    }
}

// ---------------------------------------------------------------------------------------------
// Scene.

const SCENE_FIELDS: &[&str] = &["camera", "environment", "volume", "photons", "bounces", "bounce_photons", "samples", "duration", "fog", "shutter", "motion_steps", "children"];

impl LuaObject for Scene {
    fn kind(&self) -> &'static str {
        "scene"
    }
    fn fields(&self) -> &'static [&'static str] {
        SCENE_FIELDS
    }
    fn get(&self, lua: &Lua, key: &str) -> mlua::Result<Value> {
        match key {
            "camera" => obj_value(lua, &self.camera),
            "environment" => Obj(self.environment.clone()).into_lua(lua),
            "volume" => Obj(self.volume.clone()).into_lua(lua),
            "photons" => Ok(Value::Integer(self.photons as i64)),
            "bounces" => Ok(Value::Integer(self.bounces as i64)),
            "bounce_photons" => Ok(Value::Integer(self.bounce_photons.unwrap_or(self.photons) as i64)),
            "samples" => Ok(Value::Integer(self.samples as i64)),
            "duration" => Ok(self.duration.map_or(Value::Nil, Value::Number)),
            "fog" => obj_value(lua, &self.fog),
            "shutter" => Ok(number_value(self.shutter)),
            "motion_steps" => Ok(Value::Integer(self.motion_steps.into())),
            "children" => node_list(lua, &self.roots),
            _ => Err(unknown_field(lua, "scene", key, SCENE_FIELDS)),
        }
    }
    fn set(&mut self, lua: &Lua, key: &str, value: Value) -> mlua::Result<()> {
        let name = FieldName { what: "scene", field: key };
        match key {
            "camera" => self.camera = opt_obj(lua, name, &value, "a refrakt.camera{…}")?,
            "environment" => {
                self.environment = match &value {
                    // A plain table is shorthand for refrakt.environment{…}.
                    Value::Table(t) => construct(lua, Environment::default(), Some(t.clone()), &[])?.0,
                    _ => expect_obj(lua, name, &value, "a refrakt.environment{…}")?,
                }
            }
            "volume" => {
                self.volume = match &value {
                    Value::Table(t) => {
                        // A box given whole is checked here, where the line is known; corners
                        // set one by one are checked when the frame is evaluated (a box may
                        // pass through a state that is not one while being moved).
                        let volume = construct(lua, VolumeSettings::default(), Some(t.clone()), &[])?.0;
                        if let Some((lo, hi)) = volume.borrow().bounds {
                            volume.borrow().check_bounds(lo, hi).map_err(|e| error_at(lua, e))?;
                        }
                        volume
                    }
                    _ => expect_obj(lua, name, &value, "a volume table {resolution = …, margin = …}")?,
                }
            }
            "photons" => self.photons = cv::integer(lua, name, &value, 0, 1 << 30)? as u32,
            "bounces" => self.bounces = cv::integer(lua, name, &value, 0, crate::scene::MAX_BOUNCES as i64)? as u32,
            "bounce_photons" => {
                self.bounce_photons = match value {
                    Value::Nil => None,
                    _ => Some(cv::integer(lua, name, &value, 0, 1 << 30)? as u32),
                }
            }
            "samples" => self.samples = cv::integer(lua, name, &value, 1, 256)? as u32,
            "duration" => {
                self.duration = match value {
                    Value::Nil => None,
                    _ => Some(cv::number_in(lua, name, &value, Some(0.0), Some(1e6), "a length in seconds from 0 to 10⁶")?),
                }
            }
            "fog" => {
                self.fog = match &value {
                    Value::Table(t) => Some(construct(lua, Fog::default(), Some(t.clone()), &[])?.0),
                    _ => opt_obj(lua, name, &value, "a refrakt.fog{…}")?,
                }
            }
            "shutter" => self.shutter = cv::number_in(lua, name, &value, Some(0.0), Some(MotionBlur::MAX_SHUTTER.into()), "frames the shutter is open, from 0 (no motion blur) to 100")? as f32,
            "motion_steps" => self.motion_steps = cv::integer(lua, name, &value, 1, MotionBlur::MAX_STEPS.into())? as u32,
            "children" => self.roots = read_node_list(lua, name, &value)?,
            _ => return Err(unknown_field(lua, "scene", key, SCENE_FIELDS)),
        }
        Ok(())
    }
    fn methods<M: UserDataMethods<Obj<Self>>>(m: &mut M) {
        m.add_method("add", |lua, this, node: Value| {
            let node = expect_obj::<Node>(lua, FieldName { what: "scene:add", field: "node" }, &node, "a refrakt.node{…}")?;
            writable(lua, &this.0)?.roots.push(node.clone());
            Ok(Obj(node))
        });
        m.add_method("find", |lua, this, name: String| {
            let hit = this.0.borrow().find(&name);
            obj_value(lua, &hit)
        });
        m.add_method("remove", |lua, this, node: Value| {
            let node = expect_obj::<Node>(lua, FieldName { what: "scene:remove", field: "node" }, &node, "a refrakt.node{…}")?;
            Ok(writable(lua, &this.0)?.remove(&node))
        });
        // World coordinates of a point given in a node's local frame (default: its origin).
        m.add_method("to_world", |lua, this, (node, point): (Value, Value)| {
            let what = FieldName { what: "scene:to_world", field: "node" };
            let node = expect_obj::<Node>(lua, what, &node, "a refrakt.node{…}")?;
            let p = if point.is_nil() { Vec3::ZERO } else { cv::vec3(lua, FieldName { field: "point", ..what }, &point)? };
            let world = this.0.borrow().world_matrix(&node).ok_or_else(|| {
                error_at(lua, "scene:to_world: that node is not in the scene (add it with scene:add or node:add first)")
            })?;
            vec_value(lua, world.transform_point3(p))
        });
    }
}

// ---------------------------------------------------------------------------------------------
// Nodes.

const NODE_FIELDS: &[&str] =
    &["name", "translation", "rotation", "scale", "shape", "material", "camera", "light", "visible", "children"];

impl LuaObject for Node {
    fn kind(&self) -> &'static str {
        "node"
    }
    fn fields(&self) -> &'static [&'static str] {
        NODE_FIELDS
    }
    fn get(&self, lua: &Lua, key: &str) -> mlua::Result<Value> {
        match key {
            "name" => self.name.clone().into_lua(lua),
            "translation" => vec_value(lua, self.transform.translation),
            "rotation" => LQuat(self.transform.rotation).into_lua(lua),
            "scale" => vec_value(lua, self.transform.scale),
            "shape" => obj_value(lua, &self.shape),
            "material" => obj_value(lua, &self.material),
            "camera" => obj_value(lua, &self.camera),
            "light" => obj_value(lua, &self.light),
            "visible" => Ok(Value::Boolean(self.visible)),
            "children" => node_list(lua, &self.children),
            _ => Err(unknown_field(lua, "node", key, NODE_FIELDS)),
        }
    }
    fn set(&mut self, lua: &Lua, key: &str, value: Value) -> mlua::Result<()> {
        let name = FieldName { what: "node", field: key };
        match key {
            "name" => self.name = cv::string(lua, name, &value)?,
            "translation" => self.transform.translation = cv::vec3(lua, name, &value)?,
            "rotation" => self.transform.rotation = cv::rotation(lua, name, &value)?,
            "scale" => {
                self.transform.scale = match value {
                    Value::Integer(_) | Value::Number(_) => Vec3::splat(cv::positive(lua, name, &value)?),
                    _ => cv::size3(lua, name, &value)?,
                }
            }
            "shape" => self.shape = opt_obj(lua, name, &value, "a shape such as refrakt.sphere{…}")?,
            "material" => self.material = opt_obj(lua, name, &value, "a material such as refrakt.glass{…}")?,
            "camera" => self.camera = opt_obj(lua, name, &value, "a refrakt.camera{…}")?,
            "light" => self.light = opt_obj(lua, name, &value, "a light such as refrakt.spot{…}")?,
            "visible" => self.visible = cv::boolean(lua, name, &value)?,
            "children" => {
                let children = read_node_list(lua, name, &value)?;
                if children.iter().any(|c| reaches(c, self)) {
                    return Err(error_at(lua, "node.children would make a node its own ancestor"));
                }
                self.children = children;
            }
            _ => return Err(unknown_field(lua, "node", key, NODE_FIELDS)),
        }
        Ok(())
    }
    fn methods<M: UserDataMethods<Obj<Self>>>(m: &mut M) {
        m.add_method("add", |lua, this, child: Value| {
            let child =
                expect_obj::<Node>(lua, FieldName { what: "node:add", field: "child" }, &child, "a refrakt.node{…}")?;
            if reaches(&child, this.0.as_ptr()) {
                return Err(error_at(lua, "node:add would make a node its own ancestor"));
            }
            writable(lua, &this.0)?.children.push(child.clone());
            Ok(Obj(child))
        });
        m.add_method("find", |lua, this, name: String| {
            let scene = Scene { roots: this.0.borrow().children.clone(), ..Scene::default() };
            obj_value(lua, &scene.find(&name))
        });
        m.add_method("remove", |lua, this, child: Value| {
            let what = FieldName { what: "node:remove", field: "child" };
            let child = expect_obj::<Node>(lua, what, &child, "a refrakt.node{…}")?;
            Ok(crate::scene::remove_from(&mut writable(lua, &this.0)?.children, &child))
        });
    }
}

/// A list of nodes as a Lua sequence.
fn node_list(lua: &Lua, nodes: &[Shared<Node>]) -> mlua::Result<Value> {
    Ok(Value::Table(lua.create_sequence_from(nodes.iter().map(|n| Obj(n.clone())))?))
}

fn read_node_list(lua: &Lua, name: FieldName, value: &Value) -> mlua::Result<Vec<Shared<Node>>> {
    let Value::Table(t) = value else {
        return Err(error_at(lua, format!("{name} must be a list of nodes, got {}", cv::describe(value))));
    };
    t.clone().sequence_values::<Value>().map(|v| expect_obj::<Node>(lua, name, &v?, "a list of refrakt.node{…}")).collect()
}

/// Whether `target` is `node` or below it. Compared by address, so `target` itself may be
/// borrowed (it is, while its `children` are being set).
fn reaches(node: &Shared<Node>, target: *const Node) -> bool {
    std::ptr::eq(node.as_ptr(), target) || node.borrow().children.iter().any(|c| reaches(c, target))
}

/// `refrakt.node{…}`: remembers where it was made, for messages about it later.
pub fn new_node(lua: &Lua, table: Option<Table>) -> mlua::Result<Obj<Node>> {
    let mut node = Node::new("");
    node.origin = Origin(cv::location(lua));
    construct(lua, node, table, &[])
}

// ---------------------------------------------------------------------------------------------
// Shapes.

const SPHERE_FIELDS: &[&str] = &["radius", "boundary"];
const BOX_FIELDS: &[&str] = &["size", "boundary"];
const SLAB_FIELDS: &[&str] = &["size", "ior", "gradient", "boundary"];
const MESH_FIELDS: &[&str] = &["source", "triangles", "boundary"];
const PLANE_FIELDS: &[&str] = &["size"];
const FIELD_FIELDS: &[&str] = &["size", "n", "boundary"];

fn boundary_value(b: &Option<f32>) -> mlua::Result<Value> {
    Ok(b.map_or(Value::Nil, number_value))
}

impl LuaObject for Shape {
    fn kind(&self) -> &'static str {
        self.kind_name()
    }
    fn fields(&self) -> &'static [&'static str] {
        match self {
            Shape::Sphere { .. } | Shape::Luneburg { .. } => SPHERE_FIELDS,
            Shape::Box { .. } => BOX_FIELDS,
            Shape::Slab { .. } => SLAB_FIELDS,
            Shape::Mesh { .. } => MESH_FIELDS,
            Shape::Plane { .. } => PLANE_FIELDS,
            Shape::Field { .. } => FIELD_FIELDS,
        }
    }
    fn get(&self, lua: &Lua, key: &str) -> mlua::Result<Value> {
        match (self, key) {
            (Shape::Sphere { radius, .. } | Shape::Luneburg { radius, .. }, "radius") => Ok(number_value(*radius)),
            (Shape::Box { size, .. } | Shape::Slab { size, .. } | Shape::Field { size, .. }, "size") => vec_value(lua, *size),
            (Shape::Field { n, .. }, "n") => super::field::function_value(n),
            (Shape::Plane { size }, "size") => lua.create_sequence_from(size.to_array().map(decimal))?.into_lua(lua),
            (Shape::Slab { ior, .. }, "ior") => Ok(number_value(*ior)),
            (Shape::Slab { gradient, .. }, "gradient") => Ok(number_value(*gradient)),
            (Shape::Mesh { source, .. }, "source") => source.clone().into_lua(lua),
            (Shape::Mesh { mesh, .. }, "triangles") => Ok(Value::Integer(mesh.triangles.len() as i64)),
            (
                Shape::Sphere { boundary: b, .. }
                | Shape::Luneburg { boundary: b, .. }
                | Shape::Box { boundary: b, .. }
                | Shape::Slab { boundary: b, .. }
                | Shape::Mesh { boundary: b, .. }
                | Shape::Field { boundary: b, .. },
                "boundary",
            ) => boundary_value(b),
            _ => Err(unknown_field(lua, self.kind_name(), key, self.fields())),
        }
    }
    fn set(&mut self, lua: &Lua, key: &str, value: Value) -> mlua::Result<()> {
        let kind = self.kind_name();
        let name = FieldName { what: kind, field: key };
        let fields = self.fields();
        match (self, key) {
            (Shape::Sphere { radius, .. } | Shape::Luneburg { radius, .. }, "radius") => {
                *radius = cv::positive(lua, name, &value)?
            }
            (Shape::Box { size, .. } | Shape::Slab { size, .. } | Shape::Field { size, .. }, "size") => {
                *size = cv::size3(lua, name, &value)?
            }
            (Shape::Field { n, .. }, "n") => *n = super::field::index_fn(lua, name, &value)?,
            (Shape::Plane { size }, "size") => *size = cv::size2(lua, name, &value)?,
            (Shape::Slab { ior, .. }, "ior") => {
                *ior = cv::number_in(lua, name, &value, Some(1.0), Some(4.0), "a number from 1 to 4")? as f32
            }
            (Shape::Slab { gradient, .. }, "gradient") => *gradient = cv::number(lua, name, &value)? as f32,
            (Shape::Mesh { .. }, "source" | "triangles") => {
                return Err(error_at(lua, format!("{name} is read-only (make a new mesh instead)")));
            }
            (
                Shape::Sphere { boundary, .. }
                | Shape::Luneburg { boundary, .. }
                | Shape::Box { boundary, .. }
                | Shape::Slab { boundary, .. }
                | Shape::Mesh { boundary, .. }
                | Shape::Field { boundary, .. },
                "boundary",
            ) => {
                *boundary = if value.is_nil() {
                    None
                } else {
                    Some(cv::number_in(lua, name, &value, Some(0.0), Some(16.0), "a width in voxels from 0 to 16")? as f32)
                }
            }
            _ => return Err(unknown_field(lua, kind, key, fields)),
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Materials.

impl LuaObject for Material {
    fn kind(&self) -> &'static str {
        match self {
            Material::Glass(_) => "glass",
            // (`refrakt.pbr{…}` and a diffuse given a specular lobe or a normal map)
            Material::Diffuse(d) if d.is_pbr() => "pbr",
            Material::Diffuse(_) => "diffuse",
        }
    }
    fn fields(&self) -> &'static [&'static str] {
        match self {
            Material::Glass(_) => super::glass::FIELDS,
            Material::Diffuse(_) => super::pbr::FIELDS,
        }
    }
    fn get(&self, lua: &Lua, key: &str) -> mlua::Result<Value> {
        let value = match self {
            Material::Glass(g) => super::glass::get(lua, g, key),
            Material::Diffuse(d) => super::pbr::get(lua, d, key),
        };
        value.unwrap_or_else(|| Err(unknown_field(lua, self.kind(), key, self.fields())))
    }
    fn set(&mut self, lua: &Lua, key: &str, value: Value) -> mlua::Result<()> {
        let (kind, fields) = (self.kind(), self.fields());
        let done = match self {
            Material::Glass(g) => super::glass::set(lua, g, key, value),
            Material::Diffuse(d) => super::pbr::set(lua, d, kind, key, value),
        };
        done.unwrap_or_else(|| Err(unknown_field(lua, kind, key, fields)))
    }
}

// ---------------------------------------------------------------------------------------------
// Lights.

const POINT_FIELDS: &[&str] = &["color", "intensity", "power", "radius", "visible"];
const SPOT_FIELDS: &[&str] = &["color", "intensity", "power", "angle", "blend", "target", "radius", "visible"];
const SUN_FIELDS: &[&str] = &["color", "intensity", "strength", "direction", "angular_diameter"];
const RECT_FIELDS: &[&str] = &["color", "intensity", "size", "target", "visible"];

/// Candela per watt of a point light radiating equally in all directions: 683 lm/W / 4π sr.
const CANDELA_PER_WATT: f32 = LUMENS_PER_WATT / (4.0 * std::f32::consts::PI);

impl LuaObject for Light {
    fn kind(&self) -> &'static str {
        match self.kind {
            LightKind::Point => "point",
            LightKind::Spot { .. } => "spot",
            LightKind::Sun { .. } => "sun",
            LightKind::Rect { round: false, .. } => "rect",
            LightKind::Rect { round: true, .. } => "disk",
        }
    }
    fn fields(&self) -> &'static [&'static str] {
        match self.kind {
            LightKind::Point => POINT_FIELDS,
            LightKind::Spot { .. } => SPOT_FIELDS,
            LightKind::Sun { .. } => SUN_FIELDS,
            LightKind::Rect { .. } => RECT_FIELDS,
        }
    }
    fn get(&self, lua: &Lua, key: &str) -> mlua::Result<Value> {
        let num = |x: f32| Ok(number_value(x));
        match (&self.kind, key) {
            (_, "color") => vec_value(lua, self.color),
            (_, "intensity") => num(self.intensity),
            (LightKind::Point | LightKind::Spot { .. }, "power") => num(self.intensity / CANDELA_PER_WATT),
            (LightKind::Sun { .. }, "strength") => num(self.intensity / LUMENS_PER_WATT),
            (LightKind::Spot { angle, .. }, "angle") => num(angle.to_degrees()),
            (LightKind::Spot { blend, .. }, "blend") => num(*blend),
            (LightKind::Point | LightKind::Spot { .. }, "radius") => num(self.radius),
            (LightKind::Point | LightKind::Spot { .. } | LightKind::Rect { .. }, "visible") => Ok(Value::Boolean(self.visible)),
            (LightKind::Sun { angular_diameter }, "angular_diameter") => num(angular_diameter.to_degrees()),
            (LightKind::Rect { size, .. }, "size") => lua.create_sequence_from(size.to_array().map(decimal))?.into_lua(lua),
            (LightKind::Spot { .. } | LightKind::Rect { .. }, "target") => self.target.map_or(Ok(Value::Nil), |t| vec_value(lua, t)),
            (LightKind::Sun { .. }, "direction") => self.direction.map_or(Ok(Value::Nil), |d| vec_value(lua, d)),
            _ => Err(unknown_field(lua, self.kind(), key, self.fields())),
        }
    }
    fn set(&mut self, lua: &Lua, key: &str, value: Value) -> mlua::Result<()> {
        let kind = self.kind();
        let fields = self.fields();
        let name = FieldName { what: kind, field: key };
        match (&mut self.kind, key) {
            (_, "color") => self.color = cv::color(lua, name, &value)?,
            (_, "intensity") => self.intensity = cv::non_negative(lua, name, &value)?,
            (LightKind::Point | LightKind::Spot { .. }, "power") => {
                self.intensity = cv::non_negative(lua, name, &value)? * CANDELA_PER_WATT
            }
            (LightKind::Sun { .. }, "strength") => self.intensity = cv::non_negative(lua, name, &value)? * LUMENS_PER_WATT,
            (LightKind::Point | LightKind::Spot { .. }, "radius") => {
                self.radius = cv::number_in(lua, name, &value, Some(0.0), Some(10.0), "a radius in metres from 0 to 10")? as f32
            }
            (LightKind::Point | LightKind::Spot { .. } | LightKind::Rect { .. }, "visible") => {
                self.visible = cv::boolean(lua, name, &value)?
            }
            (LightKind::Spot { angle, .. }, "angle") => {
                *angle = (cv::number_in(lua, name, &value, Some(0.1), Some(90.0), "a half-angle in degrees from 0.1 to 90")?
                    as f32)
                    .to_radians()
            }
            (LightKind::Spot { blend, .. }, "blend") => {
                *blend = cv::number_in(lua, name, &value, Some(0.0), Some(1.0), "a number from 0 to 1")? as f32
            }
            (LightKind::Sun { angular_diameter }, "angular_diameter") => {
                *angular_diameter =
                    (cv::number_in(lua, name, &value, Some(0.0), Some(45.0), "an angle in degrees from 0 to 45")? as f32)
                        .to_radians()
            }
            (LightKind::Rect { size, .. }, "size") => *size = cv::size2(lua, name, &value)?,
            (LightKind::Spot { .. } | LightKind::Rect { .. }, "target") => self.target = Some(cv::vec3(lua, name, &value)?),
            (LightKind::Sun { .. }, "direction") => {
                let d = cv::vec3(lua, name, &value)?;
                if d.length_squared() < 1e-12 {
                    return Err(error_at(lua, "sun.direction must not be the zero vector"));
                }
                self.direction = Some(d.normalize());
            }
            _ => return Err(unknown_field(lua, kind, key, fields)),
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Fog.

const FOG_FIELDS: &[&str] = &["density", "color", "scattering", "absorption", "g"];

impl LuaObject for Fog {
    fn kind(&self) -> &'static str {
        "fog"
    }
    fn fields(&self) -> &'static [&'static str] {
        FOG_FIELDS
    }
    fn get(&self, lua: &Lua, key: &str) -> mlua::Result<Value> {
        match key {
            "density" => Ok(number_value(self.scattering.max_element())),
            "color" => vec_value(lua, self.scattering / self.scattering.max_element().max(1e-12)),
            "scattering" => vec_value(lua, self.scattering),
            "absorption" => vec_value(lua, self.absorption),
            "g" => Ok(number_value(self.g)),
            _ => Err(unknown_field(lua, "fog", key, FOG_FIELDS)),
        }
    }
    fn set(&mut self, lua: &Lua, key: &str, value: Value) -> mlua::Result<()> {
        let name = FieldName { what: "fog", field: key };
        match key {
            // density (per metre) keeps the color; color (relative) keeps the density.
            "density" => {
                let d = cv::non_negative(lua, name, &value)?;
                let color = self.scattering / self.scattering.max_element().max(1e-12);
                self.scattering = if self.scattering.max_element() > 0.0 { color * d } else { Vec3::splat(d) };
            }
            "color" => {
                let c = cv::color(lua, name, &value)?;
                self.scattering = c / c.max_element().max(1e-12) * self.scattering.max_element();
            }
            "scattering" => self.scattering = cv::color(lua, name, &value)?,
            "absorption" => self.absorption = cv::color(lua, name, &value)?,
            "g" => self.g = cv::number_in(lua, name, &value, Some(-0.99), Some(0.99), "a number from −0.99 to 0.99")? as f32,
            _ => return Err(unknown_field(lua, "fog", key, FOG_FIELDS)),
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Camera.

const CAMERA_FIELDS: &[&str] =
    &["position", "target", "rotation", "up", "fov", "size", "orthographic", "aperture", "focus", "blades", "blade_rotation", "shift", "clip_start"];

impl LuaObject for Camera {
    fn kind(&self) -> &'static str {
        "camera"
    }
    fn fields(&self) -> &'static [&'static str] {
        CAMERA_FIELDS
    }
    fn get(&self, lua: &Lua, key: &str) -> mlua::Result<Value> {
        match key {
            "position" => vec_value(lua, self.position),
            "target" => self.target.map_or(Ok(Value::Nil), |t| vec_value(lua, t)),
            "rotation" => LQuat(self.orientation()).into_lua(lua),
            "up" => vec_value(lua, self.up),
            "fov" => Ok(number_value(self.fov_y.to_degrees())),
            "size" => lua.create_sequence_from([self.size.0, self.size.1])?.into_lua(lua),
            "orthographic" => Ok(self.orthographic.map_or(Value::Nil, number_value)),
            "aperture" => Ok(number_value(self.lens.aperture)),
            "focus" => Ok(self.lens.focus.map_or(Value::Nil, number_value)),
            "blades" => Ok(Value::Integer(self.lens.blades.into())),
            "blade_rotation" => Ok(number_value(self.lens.blade_rotation.to_degrees())),
            "shift" => lua.create_sequence_from(self.lens.shift.to_array().map(decimal))?.into_lua(lua),
            "clip_start" => Ok(number_value(self.clip_start)),
            _ => Err(unknown_field(lua, "camera", key, CAMERA_FIELDS)),
        }
    }
    fn set(&mut self, lua: &Lua, key: &str, value: Value) -> mlua::Result<()> {
        let name = FieldName { what: "camera", field: key };
        match key {
            "position" => self.position = cv::vec3(lua, name, &value)?,
            "target" => {
                self.target = Some(cv::vec3(lua, name, &value)?);
                self.rotation = None;
            }
            "rotation" => {
                self.rotation = Some(cv::rotation(lua, name, &value)?);
                self.target = None;
            }
            "up" => {
                let up = cv::vec3(lua, name, &value)?;
                if up.length_squared() < 1e-12 {
                    return Err(error_at(lua, "camera.up must not be the zero vector"));
                }
                self.up = up.normalize();
            }
            "fov" => {
                self.fov_y = (cv::number_in(lua, name, &value, Some(0.1), Some(179.0), "an angle in degrees from 0.1 to 179")?
                    as f32)
                    .to_radians()
            }
            "size" => self.size = cv::image_size(lua, name, &value)?,
            "orthographic" => {
                self.orthographic = match value {
                    Value::Nil => None,
                    v => Some(cv::number_in(lua, name, &v, Some(1e-6), Some(1e6), "the view's height in metres, > 0 (nil: a pinhole)")? as f32),
                }
            }
            "aperture" => {
                self.lens.aperture = cv::number_in(lua, name, &value, Some(0.0), Some(Lens::MAX_APERTURE.into()), "the aperture's diameter in metres, from 0 (a pinhole) to 100")? as f32
            }
            "focus" => {
                self.lens.focus = match value {
                    Value::Nil => None,
                    v => Some(cv::number_in(lua, name, &v, Some(1e-4), Some(1e6), "the distance to the plane in focus in metres, > 0 (nil: the target's)")? as f32),
                }
            }
            "blades" => {
                let blades = cv::number_in(lua, name, &value, Some(0.0), Some(Lens::MAX_BLADES.into()), "0 (a round aperture) or 3 to 64 blades")?;
                if blades.fract() != 0.0 || !Lens::blades_are_valid(blades as u32) {
                    return Err(error_at(lua, format!("camera.blades must be 0 (a round aperture) or a whole number from 3 to 64, got {blades}")));
                }
                self.lens.blades = blades as u32;
            }
            "blade_rotation" => self.lens.blade_rotation = (cv::number_in(lua, name, &value, Some(-3600.0), Some(3600.0), "an angle in degrees")? as f32).to_radians(),
            "shift" => self.lens.shift = cv::vec2_within(lua, name, &value, Lens::MAX_SHIFT.into())?,
            "clip_start" => {
                self.clip_start = cv::number_in(lua, name, &value, Some(0.0), Some(Camera::MAX_CLIP_START.into()), "a distance along the view in metres, from 0 to 1e6")? as f32
            }
            _ => return Err(unknown_field(lua, "camera", key, CAMERA_FIELDS)),
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Environment.

const ENVIRONMENT_FIELDS: &[&str] = &["color", "image", "preset", "intensity", "rotation", "tilt", "visible"];

impl LuaObject for Environment {
    fn kind(&self) -> &'static str {
        "environment"
    }
    fn fields(&self) -> &'static [&'static str] {
        ENVIRONMENT_FIELDS
    }
    fn get(&self, lua: &Lua, key: &str) -> mlua::Result<Value> {
        match (key, &self.source) {
            ("color", EnvironmentSource::Color(c)) => vec_value(lua, *c),
            ("image", EnvironmentSource::Image { path, .. }) => path.display().to_string().into_lua(lua),
            ("preset", EnvironmentSource::Preset { name, .. }) => name.clone().into_lua(lua),
            ("color" | "image" | "preset", _) => Ok(Value::Nil),
            ("intensity", _) => Ok(number_value(self.intensity)),
            ("rotation", _) => Ok(number_value(self.rotation.to_degrees())),
            ("tilt", _) => LQuat(self.tilt).into_lua(lua),
            ("visible", _) => Ok(Value::Boolean(self.visible)),
            _ => Err(unknown_field(lua, "environment", key, ENVIRONMENT_FIELDS)),
        }
    }
    fn set(&mut self, lua: &Lua, key: &str, value: Value) -> mlua::Result<()> {
        let name = FieldName { what: "environment", field: key };
        match key {
            "color" => self.source = EnvironmentSource::Color(cv::color(lua, name, &value)?),
            "image" => {
                let given = cv::string(lua, name, &value)?;
                let path = FileAccess::resolve(lua, &given)?;
                let image = environment::load_image(&path).map_err(|e| error_at(lua, format!("{e:#}")))?;
                self.source = EnvironmentSource::Image { path: PathBuf::from(given), image: image.into() };
            }
            "preset" => {
                let preset = cv::string(lua, name, &value)?;
                let image = environment::preset(&preset).map_err(|e| error_at(lua, format!("environment.preset: {e}")))?;
                self.source = EnvironmentSource::Preset { name: preset, image };
            }
            "intensity" => self.intensity = cv::non_negative(lua, name, &value)?,
            "rotation" => self.rotation = (cv::number(lua, name, &value)? as f32).to_radians(),
            "tilt" => self.tilt = cv::rotation(lua, name, &value)?,
            "visible" => self.visible = cv::boolean(lua, name, &value)?,
            _ => return Err(unknown_field(lua, "environment", key, ENVIRONMENT_FIELDS)),
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Volume settings.

const VOLUME_FIELDS: &[&str] = &["resolution", "margin", "min", "max", "boundary", "step", "contact"];

impl LuaObject for VolumeSettings {
    fn kind(&self) -> &'static str {
        "volume"
    }
    fn fields(&self) -> &'static [&'static str] {
        VOLUME_FIELDS
    }
    fn get(&self, lua: &Lua, key: &str) -> mlua::Result<Value> {
        match key {
            "resolution" => Ok(Value::Integer(self.resolution as i64)),
            "margin" => Ok(number_value(self.margin)),
            "min" => self.bounds.map_or(Ok(Value::Nil), |b| vec_value(lua, b.0)),
            "max" => self.bounds.map_or(Ok(Value::Nil), |b| vec_value(lua, b.1)),
            "boundary" => Ok(number_value(self.boundary)),
            "step" => Ok(number_value(self.step)),
            "contact" => Ok(number_value(self.contact)),
            _ => Err(unknown_field(lua, "volume", key, VOLUME_FIELDS)),
        }
    }
    fn set(&mut self, lua: &Lua, key: &str, value: Value) -> mlua::Result<()> {
        let name = FieldName { what: "volume", field: key };
        match key {
            "resolution" => self.resolution = cv::integer(lua, name, &value, 8, 2048)? as u32,
            "margin" => self.margin = cv::non_negative(lua, name, &value)?,
            "min" | "max" => {
                let p = cv::vec3(lua, name, &value)?;
                let (mut lo, mut hi) = self.bounds.unwrap_or((Vec3::NAN, Vec3::NAN));
                if key == "min" { lo = p } else { hi = p }
                self.bounds = Some((lo, hi));
                self.bounds_origin = Some(cv::location(lua));
            }
            "boundary" => {
                self.boundary =
                    cv::number_in(lua, name, &value, Some(0.0), Some(16.0), "a width in voxels from 0 to 16")? as f32
            }
            "step" => {
                self.step =
                    cv::number_in(lua, name, &value, Some(0.01), Some(8.0), "a step in voxels from 0.01 to 8")? as f32
            }
            "contact" => self.contact = cv::non_negative(lua, name, &value)?,
            _ => return Err(unknown_field(lua, "volume", key, VOLUME_FIELDS)),
        }
        Ok(())
    }
}
