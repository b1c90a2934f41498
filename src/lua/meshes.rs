//! Mesh shapes for scene scripts: `refrakt.mesh{file = "bunny.obj"}` (or a mesh given by its
//! `vertices` and `triangles`), and procedural solids made as triangle meshes — `icosphere`,
//! `cube`, `cylinder`, `torus`, `lathe` (a solid of revolution) and `blob` (a lumpy pebble).
//! Each returns a `mesh` shape; with a glass material it is voxelized into the index volume.
//!
//! A mesh is immutable: to animate or deform one, make a new shape in `update` (the renderer
//! re-voxelizes only meshes that changed or moved).

use std::sync::Arc;

use glam::Vec2;
use mlua::{Lua, Table, Value};

use super::convert::{self as cv, FieldName, error_at, unknown_field};
use super::objects::{LuaObject, Obj};
use super::sandbox::FileAccess;
use crate::scene::{MeshData, Normals, Shape, mesh, obj, shared};

/// Fields every mesh constructor takes.
const EVERY_MESH: [&str; 2] = ["boundary", "smooth"];

/// The constructor table of one mesh constructor: only known keys (a typo gets "did you
/// mean …?"), read with the usual typed conversions.
struct Args<'a> {
    lua: &'a Lua,
    what: &'static str,
    table: Table,
}

impl<'a> Args<'a> {
    fn new(lua: &'a Lua, what: &'static str, table: Option<Table>, known: &[&str]) -> mlua::Result<Self> {
        let table = match table {
            Some(t) => t,
            None => lua.create_table()?,
        };
        for pair in table.pairs::<Value, Value>() {
            let (k, _) = pair?;
            let key = match &k {
                Value::String(s) => s.to_string_lossy(),
                other => return Err(error_at(lua, format!("{what} fields are named by strings, got {}", cv::describe(other)))),
            };
            if !known.contains(&key.as_str()) && !EVERY_MESH.contains(&key.as_str()) {
                let mut all = known.to_vec();
                all.extend(EVERY_MESH);
                return Err(unknown_field(lua, what, &key, &all));
            }
        }
        Ok(Self { lua, what, table })
    }

    fn get(&self, key: &str) -> mlua::Result<Value> {
        self.table.raw_get(key)
    }

    fn name<'k>(&self, field: &'k str) -> FieldName<'k>
    where
        'a: 'k,
    {
        FieldName { what: self.what, field }
    }

    fn required(&self, key: &str) -> mlua::Result<Value> {
        let v = self.get(key)?;
        if v.is_nil() {
            return Err(error_at(self.lua, format!("{} needs a field \"{key}\"", self.what)));
        }
        Ok(v)
    }

    /// `smooth`: a crease angle in degrees (faces meeting at less share a smooth normal), `true`
    /// for Blender's default of 30°, `false` for flat faces; `None` keeps the mesh's own normals
    /// (a file's, or a procedural shape's 30°).
    fn smooth(&self) -> mlua::Result<Option<Normals>> {
        Ok(match self.get("smooth")? {
            Value::Nil => None,
            Value::Boolean(true) => Some(Normals::Crease(mesh::SMOOTH_CREASE_DEGREES)),
            Value::Boolean(false) => Some(Normals::Flat),
            v => Some(Normals::Crease(cv::number_in(
                self.lua,
                self.name("smooth"),
                &v,
                Some(0.0),
                Some(180.0),
                "a crease angle in degrees from 0 to 180, or true (30°) or false (flat)",
            )? as f32)),
        })
    }

    /// A length in metres (> 0), required.
    fn length(&self, key: &str) -> mlua::Result<f32> {
        cv::positive(self.lua, self.name(key), &self.required(key)?)
    }

    /// A whole number in [lo, hi], `default` when absent.
    fn count(&self, key: &str, default: u32, lo: u32, hi: u32) -> mlua::Result<u32> {
        match self.get(key)? {
            Value::Nil => Ok(default),
            v => Ok(cv::integer(self.lua, self.name(key), &v, lo as i64, hi as i64)? as u32),
        }
    }

    /// The `mesh` shape made of `mesh`, with this table's `boundary` and `smooth` if it has them.
    fn shape(&self, mut mesh: MeshData, source: String) -> mlua::Result<Obj<Shape>> {
        if let Some(normals) = self.smooth()? {
            mesh.normals = normals;
        }
        let mut shape = Shape::Mesh { mesh: Arc::new(mesh), source, boundary: None };
        let boundary = self.get("boundary")?;
        if !boundary.is_nil() {
            shape.set(self.lua, "boundary", boundary)?;
        }
        Ok(Obj(shared(shape)))
    }
}

/// `refrakt.mesh{file = "…obj"}` or `refrakt.mesh{vertices = {{x, y, z}, …}, triangles = {{1, 2, 3}, …}}`
/// (with `normals`, one per vertex, to shade it smooth, flat without; and `uvs`, one `{u, v}` per
/// vertex, for textures).
fn mesh_from(lua: &Lua, t: Option<Table>) -> mlua::Result<Obj<Shape>> {
    let args = Args::new(lua, "mesh", t, &["file", "vertices", "triangles", "normals", "uvs"])?;
    let file = args.get("file")?;
    if !file.is_nil() {
        if ["vertices", "triangles", "normals", "uvs"].iter().any(|k| args.get(k).is_ok_and(|v| !v.is_nil())) {
            return Err(error_at(lua, "give a mesh either a file or vertices and triangles (and normals, uvs), not both"));
        }
        let given = cv::string(lua, args.name("file"), &file)?;
        let path = FileAccess::resolve(lua, &given)?;
        let mesh = obj::load(&path).map_err(|e| error_at(lua, format!("{e:#}")))?;
        return args.shape(mesh, given);
    }
    let (vertices, triangles) = (args.get("vertices")?, args.get("triangles")?);
    if vertices.is_nil() && triangles.is_nil() {
        return Err(error_at(
            lua,
            "mesh needs a file (refrakt.mesh{file = \"model.obj\"}) or vertices and triangles \
             (refrakt.mesh{vertices = {{x, y, z}, …}, triangles = {{1, 2, 3}, …}})",
        ));
    }
    let mut mesh = MeshData::default();
    for (i, v) in list(lua, "mesh.vertices", &vertices)?.into_iter().enumerate() {
        let field = format!("vertices[{}]", i + 1);
        mesh.positions.push(cv::vec3(lua, args.name(&field), &v)?);
    }
    let n = mesh.positions.len() as i64;
    for (i, t) in list(lua, "mesh.triangles", &triangles)?.into_iter().enumerate() {
        let field = format!("triangles[{}]", i + 1);
        let corners = list(lua, &format!("mesh.{field}"), &t)?;
        if corners.len() != 3 {
            return Err(error_at(lua, format!("mesh.{field} must list three vertex numbers, got {}", cv::describe(&t))));
        }
        let mut tri = [0u32; 3];
        for (k, c) in corners.iter().enumerate() {
            // 1-based, as everything in Lua.
            tri[k] = (cv::integer(lua, args.name(&field), c, 1, n.max(1))? - 1) as u32;
        }
        mesh.triangles.push(tri);
    }
    let vertex_count = mesh.positions.len();
    if let Some(normals) = per_vertex(&args, "normals", "normals", vertex_count, |name, v| cv::vec3(lua, name, v))? {
        mesh.normals = Normals::Authored(normals);
    }
    // Texture coordinates (glass textures, a receiver's textures): a 1 × 1 tile is (0, 0) to
    // (1, 1), larger numbers repeat it; ±1e6 bounds typos, not tiling.
    mesh.uvs = per_vertex(&args, "uvs", "texture coordinates", vertex_count, |name, v| cv::vec2_within(lua, name, v, 1e6))?;
    mesh.check().map_err(|e| error_at(lua, format!("mesh: {e}")))?;
    args.shape(mesh, "vertices".into())
}

/// Field `key` of a mesh made in Lua: one item per vertex, in the vertices' order, each read by
/// `item`; None when absent.
fn per_vertex<T>(args: &Args, key: &str, what: &str, vertices: usize, item: impl Fn(FieldName, &Value) -> mlua::Result<T>) -> mlua::Result<Option<Vec<T>>> {
    let value = args.get(key)?;
    if value.is_nil() {
        return Ok(None);
    }
    let items = list(args.lua, &format!("mesh.{key}"), &value)?;
    if items.len() != vertices {
        return Err(error_at(args.lua, format!("mesh.{key} lists {} {what} for {vertices} vertices; give one per vertex, in the same order", items.len())));
    }
    let field = |i: usize| format!("{key}[{}]", i + 1);
    items.iter().enumerate().map(|(i, v)| item(args.name(&field(i)), v)).collect::<mlua::Result<_>>().map(Some)
}

/// The items of a Lua sequence.
fn list(lua: &Lua, what: &str, v: &Value) -> mlua::Result<Vec<Value>> {
    match v {
        Value::Table(t) => t.clone().sequence_values::<Value>().collect(),
        other => Err(error_at(lua, format!("{what} must be a list, got {}", cv::describe(other)))),
    }
}

fn icosphere(lua: &Lua, t: Option<Table>) -> mlua::Result<Obj<Shape>> {
    let a = Args::new(lua, "icosphere", t, &["radius", "subdivisions"])?;
    a.shape(mesh::icosphere(a.length("radius")?, a.count("subdivisions", 4, 0, 7)?), "icosphere".into())
}

fn cube(lua: &Lua, t: Option<Table>) -> mlua::Result<Obj<Shape>> {
    let a = Args::new(lua, "cube", t, &["size"])?;
    a.shape(mesh::cuboid(cv::size3(lua, a.name("size"), &a.required("size")?)?), "cube".into())
}

fn cylinder(lua: &Lua, t: Option<Table>) -> mlua::Result<Obj<Shape>> {
    let a = Args::new(lua, "cylinder", t, &["radius", "height", "segments"])?;
    let m = mesh::cylinder(a.length("radius")?, a.length("height")?, a.count("segments", 64, 3, 4096)?);
    a.shape(m, "cylinder".into())
}

fn torus(lua: &Lua, t: Option<Table>) -> mlua::Result<Obj<Shape>> {
    let a = Args::new(lua, "torus", t, &["major_radius", "minor_radius", "major_segments", "minor_segments"])?;
    let (major, minor) = (a.length("major_radius")?, a.length("minor_radius")?);
    if minor >= major {
        return Err(error_at(
            lua,
            format!("torus.minor_radius ({minor}) must be smaller than torus.major_radius ({major}), or the tube would cross the axis"),
        ));
    }
    let m = mesh::torus(major, minor, a.count("major_segments", 64, 3, 4096)?, a.count("minor_segments", 32, 3, 4096)?);
    a.shape(m, "torus".into())
}

fn blob(lua: &Lua, t: Option<Table>) -> mlua::Result<Obj<Shape>> {
    let a = Args::new(lua, "blob", t, &["radius", "bumps", "seed", "detail"])?;
    let bumps = match a.get("bumps")? {
        Value::Nil => 0.15,
        v => cv::number_in(lua, a.name("bumps"), &v, Some(0.0), Some(0.5), "a relative height from 0 to 0.5")? as f32,
    };
    let m = mesh::blob(a.length("radius")?, bumps, a.count("seed", 1, 0, i32::MAX as u32)?, a.count("detail", 16, 1, 256)?);
    a.shape(m, "blob".into())
}

fn lathe(lua: &Lua, t: Option<Table>) -> mlua::Result<Obj<Shape>> {
    let a = Args::new(lua, "lathe", t, &["profile", "segments", "closed"])?;
    let mut profile = Vec::new();
    for (i, p) in list(lua, "lathe.profile", &a.required("profile")?)?.into_iter().enumerate() {
        let field = format!("profile[{}]", i + 1);
        let point = list(lua, &format!("lathe.{field}"), &p)?;
        let number = |k: usize| cv::number(lua, a.name(&field), point.get(k).unwrap_or(&Value::Nil));
        if point.len() != 2 || number(0)? < 0.0 {
            return Err(error_at(
                lua,
                format!("lathe.{field} must be a point {{radius, height}} with radius ≥ 0, got {}", cv::describe(&p)),
            ));
        }
        profile.push(Vec2::new(number(0)? as f32, number(1)? as f32));
    }
    if profile.len() < 2 {
        return Err(error_at(lua, "lathe.profile needs at least two points {radius, height}"));
    }
    let closed = match a.get("closed")? {
        Value::Nil => false,
        v => cv::boolean(lua, a.name("closed"), &v)?,
    };
    let m = mesh::lathe(&profile, a.count("segments", 64, 3, 4096)?, closed);
    m.check().map_err(|e| error_at(lua, format!("lathe: {e} (does the profile enclose an area?)")))?;
    a.shape(m, "lathe".into())
}

/// `refrakt.getenv("REFRAKT_…")`: a setting from the environment, so one script can take a
/// mesh path or a quality level from the command line. Only names starting with `REFRAKT_`
/// are visible, so a script cannot read the user's other variables.
fn getenv(lua: &Lua, name: String) -> mlua::Result<Option<String>> {
    if !name.starts_with("REFRAKT_") {
        return Err(error_at(lua, format!("refrakt.getenv(\"{name}\"): scripts may read only variables whose names start with REFRAKT_")));
    }
    Ok(std::env::var(&name).ok())
}

/// Adds the mesh constructors to the `refrakt` module table.
pub fn register(lua: &Lua, r: &Table) -> mlua::Result<()> {
    type Ctor = fn(&Lua, Option<Table>) -> mlua::Result<Obj<Shape>>;
    let ctors: [(&str, Ctor); 7] = [
        ("mesh", mesh_from),
        ("icosphere", icosphere),
        ("cube", cube),
        ("cylinder", cylinder),
        ("torus", torus),
        ("blob", blob),
        ("lathe", lathe),
    ];
    for (name, f) in ctors {
        r.raw_set(name, lua.create_function(f)?)?;
    }
    r.raw_set("getenv", lua.create_function(getenv)?)
}
