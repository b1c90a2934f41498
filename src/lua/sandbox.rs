//! The sandbox scene scripts run in.
//!
//! Scripts get Lua's table, string, math, utf8 and coroutine libraries, the clocks of `os`, and
//! nothing that reaches the system: no `io`, no `os.execute`, no `package.loadlib`, no `debug`,
//! no bytecode (`load` takes text only, `string.dump` is gone); each refuses with an error that
//! says so. Files are read only through the refrakt API and only below the scene's folder (or a
//! folder the user allowed with `--allow-read`); every file read is recorded, so `refrakt watch`
//! knows exactly what to watch. A runaway script is stopped after a time budget per call (also
//! inside coroutines and `pcall`) and a memory limit, each with a message naming file:line.

use std::cell::{Cell, RefCell};
use std::path::{Component, Path, PathBuf};
use std::time::{Duration, Instant};

use mlua::{HookTriggers, Lua, StdLib, Table, Value, VmState};

use super::convert::error_at;

/// Limits for one script.
#[derive(Clone, Debug)]
pub struct Limits {
    /// Wall time allowed for loading the script, and for each `update` call.
    pub time_budget: Duration,
    /// Heap the Lua state may use.
    pub memory_bytes: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Self { time_budget: Duration::from_secs(10), memory_bytes: 1 << 30 }
    }
}

/// Which files a script may read, and which it did read.
pub struct FileAccess {
    /// The scene's folder, canonical: relative paths resolve here.
    pub base: PathBuf,
    /// Folders reads may come from (the base, plus `--allow-read` ones), canonical.
    pub roots: Vec<PathBuf>,
    /// Every file the script read (or looked for and found missing), in order, without repeats.
    pub read: RefCell<Vec<PathBuf>>,
}

impl FileAccess {
    pub fn new(base: &Path, extra: &[PathBuf]) -> std::io::Result<Self> {
        let base = base.canonicalize()?;
        let mut roots = vec![base.clone()];
        for e in extra {
            roots.push(e.canonicalize()?);
        }
        Ok(Self { base, roots, read: RefCell::new(Vec::new()) })
    }

    /// Resolves `given` (relative to the scene's folder) to a readable file inside an allowed
    /// folder and records it as read. Errors name the script's file:line.
    pub fn resolve(lua: &Lua, given: &str) -> mlua::Result<PathBuf> {
        let access = lua.app_data_ref::<FileAccess>().ok_or_else(|| error_at(lua, "file access is not available here"))?;
        access.resolve_in(&access.base, given).map_err(|m| error_at(lua, m))
    }

    /// Resolves `given` relative to `dir` (a glTF file names its buffers relative to itself) to
    /// a readable file inside an allowed folder, and records it as read — or, when it does not
    /// exist, as looked for (so `refrakt watch` renders once it appears).
    pub fn resolve_in(&self, dir: &Path, given: &str) -> Result<PathBuf, String> {
        let joined = dir.join(given);
        let path = joined.canonicalize().map_err(|e| {
            self.record_missing(&joined);
            format!("cannot open \"{given}\" (looked for {}): {e}", joined.display())
        })?;
        if !self.roots.iter().any(|r| path.starts_with(r)) {
            return Err(format!(
                "\"{given}\" is outside the scene's folder {}; scenes may read only files below \
                 it (add a folder with --allow-read DIR)",
                self.base.display()
            ));
        }
        self.record(&path);
        Ok(path)
    }

    /// Records a file that was looked for and is missing, when its folder is one reads may
    /// come from: creating it may fix the scene (`refrakt watch` watches it).
    fn record_missing(&self, path: &Path) {
        let (Some(dir), Some(name)) = (path.parent().and_then(|d| d.canonicalize().ok()), path.file_name()) else { return };
        if self.roots.iter().any(|r| dir.starts_with(r)) {
            self.record(&dir.join(name));
        }
    }

    pub fn record(&self, path: &Path) {
        let mut read = self.read.borrow_mut();
        if !read.iter().any(|p| p == path) {
            read.push(path.to_path_buf());
        }
    }
}

/// The clock of the current top-level call, checked by the instruction hook.
struct Budget {
    started: Cell<Instant>,
    limit: Duration,
    /// The heap limit, for checks that refuse an allocation before it is tried.
    memory_bytes: usize,
    /// Last `file:line` the hook saw, for errors (such as out-of-memory) that carry none.
    last_line: RefCell<String>,
}

impl Budget {
    fn expired(&self) -> bool {
        self.started.get().elapsed() > self.limit
    }
}

/// Starts the time budget of a new top-level call (loading, or one `update`). The last line
/// seen is forgotten: a line of an earlier call would name the wrong place.
pub fn start_budget(lua: &Lua) {
    if let Some(b) = lua.app_data_ref::<Budget>() {
        b.started.set(Instant::now());
        b.last_line.borrow_mut().clear();
    }
}

/// The script's name as messages show it, for errors that happen before the instruction hook
/// has seen a line (a one-line memory bomb).
pub struct ScriptName(pub String);

/// The last line the instruction hook saw running.
pub fn last_line(lua: &Lua) -> Option<String> {
    lua.app_data_ref::<Budget>().map(|b| b.last_line.borrow().clone()).filter(|s| !s.is_empty())
}

/// A Lua state with only the safe libraries, the limits installed, and the file policy.
pub fn new_state(access: FileAccess, limits: &Limits) -> mlua::Result<Lua> {
    let libs = StdLib::TABLE | StdLib::STRING | StdLib::MATH | StdLib::UTF8 | StdLib::COROUTINE | StdLib::OS;
    let lua = Lua::new_with(libs, mlua::LuaOptions::default())?;
    lua.set_app_data(access);
    lua.set_app_data(Budget {
        started: Cell::new(Instant::now()),
        limit: limits.time_budget,
        memory_bytes: limits.memory_bytes,
        last_line: RefCell::new(String::new()),
    });
    lua.set_memory_limit(limits.memory_bytes)?;
    // A global hook, not a per-thread one: Lua 5.4 copies the hook into every coroutine the
    // script creates, and only the global kind still finds its callback there.
    lua.set_global_hook(HookTriggers::new().every_nth_instruction(4096), |lua, debug| {
        let Some(budget) = lua.app_data_ref::<Budget>() else { return Ok(VmState::Continue) };
        if let Some(line) = debug.current_line() {
            let src = debug.source();
            *budget.last_line.borrow_mut() = format!("{}:{line}", src.short_src.as_deref().unwrap_or("?"));
        }
        if budget.expired() {
            let at = budget.last_line.borrow().clone();
            return Err(mlua::Error::RuntimeError(format!(
                "{at}: the script ran for more than {} s without finishing (an endless loop?); \
                 the limit is set with --script-timeout",
                budget.limit.as_secs_f64()
            )));
        }
        Ok(VmState::Continue)
    })?;
    restrict_globals(&lua)?;
    Ok(lua)
}

/// Libraries scripts may not reach, and why (the error says so).
const REFUSED_LIBRARIES: &[(&str, &str)] = &[
    ("io", "scene scripts read files only through the refrakt API (environment images, meshes, require), below the scene's folder"),
    ("debug", "it can break the sandbox and the time budget"),
    ("package", "modules are loaded with require(\"name\"), from the scene's folder"),
];

/// The safe corner of `os`: clocks and dates, nothing that runs, removes or reads anything.
const OS_ALLOWED: &[&str] = &["clock", "date", "difftime", "time"];

/// Removes or replaces what could reach outside the sandbox. Whatever is taken away answers
/// with an error that says so (`os.execute is not available in scene scripts: …`) rather than
/// Lua's "attempt to call a nil value".
fn restrict_globals(lua: &Lua) -> mlua::Result<()> {
    let g = lua.globals();
    for (name, reason) in REFUSED_LIBRARIES {
        g.raw_set(*name, refusing_table(lua, name, reason, lua.create_table()?)?)?;
    }
    let full_os: Table = g.get("os")?;
    let os = lua.create_table()?;
    for name in OS_ALLOWED {
        os.raw_set(*name, full_os.get::<Value>(*name)?)?;
    }
    g.raw_set("os", refusing_table(lua, "os", "scene scripts may use os.clock, os.date, os.difftime and os.time only", os)?)?;
    let string: Table = g.get("string")?;
    string.raw_set("dump", refusing_function(lua, "string.dump", "precompiled bytecode can break the interpreter's safety")?)?;
    string.raw_set("rep", bounded_rep(lua, string.get("rep")?)?)?;
    g.raw_set("dofile", refusing_function(lua, "dofile", "load modules with require(\"name\"), from the scene's folder")?)?;
    g.raw_set("loadfile", refusing_function(lua, "loadfile", "load modules with require(\"name\"), from the scene's folder")?)?;
    g.raw_set("collectgarbage", refusing_function(lua, "collectgarbage", "the memory limit (--script-memory) governs memory")?)?;
    g.raw_set("require", Value::Nil)?;
    g.raw_set("load", text_only_load(lua)?)?;
    g.raw_set(
        "print",
        lua.create_function(|lua, args: mlua::Variadic<Value>| {
            let parts: Vec<String> = args.iter().map(|v| v.to_string().unwrap_or_else(|_| v.type_name().into())).collect();
            eprintln!("[{}] {}", super::convert::location(lua), parts.join("\t"));
            Ok(())
        })?,
    )?;
    keep_budget_errors(lua)
}

/// `string.rep` that refuses, naming file:line, a string larger than the memory limit before
/// trying to allocate it. (The allocation itself would fail too, but inside one instruction:
/// before the instruction hook has seen the line, so the message could not say where.)
fn bounded_rep(lua: &Lua, rep: mlua::Function) -> mlua::Result<mlua::Function> {
    lua.create_function(move |lua, args: mlua::MultiValue| {
        let len = |v: Option<&Value>| match v {
            Some(Value::String(s)) => s.as_bytes().len() as f64,
            Some(Value::Integer(i)) => i.to_string().len() as f64,
            Some(Value::Number(x)) => x.to_string().len() as f64,
            _ => 0.0,
        };
        let count = match args.get(1) {
            Some(Value::Integer(n)) => *n as f64,
            Some(Value::Number(x)) => *x,
            _ => 0.0,
        };
        let bytes = count.max(0.0) * (len(args.front()) + len(args.get(2)));
        let limit = lua.app_data_ref::<Budget>().map_or(usize::MAX, |b| b.memory_bytes) as f64;
        if bytes > limit {
            return Err(error_at(
                lua,
                format!(
                    "string.rep would make a string of {:.0} MiB, more memory than the script is allowed ({:.0} MiB); \
                     the limit is set with --script-memory",
                    bytes / 1048576.0,
                    limit / 1048576.0
                ),
            ));
        }
        rep.call::<mlua::MultiValue>(args)
    })
}

fn refused(lua: &Lua, what: &str, reason: &str) -> mlua::Error {
    error_at(lua, format!("{what} is not available in scene scripts: {reason} (see docs/lua-api.md, \"Sandbox\")"))
}

fn refusing_function(lua: &Lua, what: &'static str, reason: &'static str) -> mlua::Result<mlua::Function> {
    lua.create_function(move |lua, _: mlua::MultiValue| -> mlua::Result<()> { Err(refused(lua, what, reason)) })
}

/// `table`, with any other key of library `name` answering with an error.
fn refusing_table(lua: &Lua, name: &'static str, reason: &'static str, table: Table) -> mlua::Result<Table> {
    let meta = lua.create_table()?;
    meta.raw_set(
        "__index",
        lua.create_function(move |lua, (_, key): (Value, Value)| -> mlua::Result<()> {
            let key = key.to_string().unwrap_or_else(|_| "?".into());
            Err(refused(lua, &format!("{name}.{key}"), reason))
        })?,
    )?;
    table.set_metatable(Some(meta))?;
    Ok(table)
}

/// `load` of text only (precompiled bytecode can break the interpreter's safety); the chunk may
/// be a string or a function returning pieces, as in standard Lua.
fn text_only_load(lua: &Lua) -> mlua::Result<mlua::Function> {
    lua.create_function(|lua, (chunk, name, _mode, env): (Value, Option<String>, Value, Option<Table>)| {
        let bytes: Vec<u8> = match &chunk {
            Value::String(s) => s.as_bytes().to_vec(),
            Value::Function(f) => {
                let mut all = Vec::new();
                while let Some(piece) = f.call::<Option<mlua::LuaString>>(())? {
                    if piece.as_bytes().is_empty() {
                        break;
                    }
                    all.extend_from_slice(&piece.as_bytes());
                }
                all
            }
            other => {
                return Err(error_at(lua, format!("load expects a string or a function, got {}", super::convert::describe(other))));
            }
        };
        if bytes.first() == Some(&0x1b) {
            return Err(refused(lua, "load of precompiled bytecode", "it can break the interpreter's safety"));
        }
        let mut c = lua.load(bytes).set_mode(mlua::chunk::ChunkMode::Text);
        if let Some(n) = name {
            c = c.set_name(n);
        }
        if let Some(env) = env {
            c = c.set_environment(env);
        }
        match c.into_function() {
            Ok(f) => Ok((Value::Function(f), Value::Nil)),
            Err(e) => Ok((Value::Nil, Value::String(lua.create_string(super::message(&e))?))),
        }
    })
}

/// `pcall`, `xpcall` and `coroutine.resume` catch errors, including the time budget's; once the
/// budget is spent they pass the error on, so `while true do pcall(f) end` still stops.
fn keep_budget_errors(lua: &Lua) -> mlua::Result<()> {
    let expired = lua.create_function(|lua, ()| Ok(lua.app_data_ref::<Budget>().is_some_and(|b| b.expired())))?;
    lua.load(
        r#"
        local expired, pcall, xpcall, resume, error = ...
        local function pass(ok, ...)
          if not ok and expired() then error((...), 0) end
          return ok, ...
        end
        _G.pcall = function(f, ...) return pass(pcall(f, ...)) end
        _G.xpcall = function(f, handler, ...) return pass(xpcall(f, handler, ...)) end
        coroutine.resume = function(co, ...) return pass(resume(co, ...)) end
        "#,
    )
    .set_name("=sandbox")
    .call::<()>((
        expired,
        lua.globals().get::<Value>("pcall")?,
        lua.globals().get::<Value>("xpcall")?,
        lua.globals().get::<Table>("coroutine")?.get::<Value>("resume")?,
        lua.globals().get::<Value>("error")?,
    ))
}

/// Turns a module name (`"materials"`, `"lib.rigs"`) into a relative path (`lib/rigs.lua`),
/// refusing anything that climbs out of the scene's folder.
pub fn module_path(name: &str) -> Result<PathBuf, String> {
    let rel = if name.ends_with(".lua") { name.to_string() } else { format!("{}.lua", name.replace('.', "/")) };
    let path = PathBuf::from(&rel);
    let ok = path.components().all(|c| matches!(c, Component::Normal(_)));
    if !ok || name.is_empty() {
        return Err(format!(
            "require(\"{name}\"): modules must be named relative to the scene's folder, without \"..\" \
             or absolute paths (e.g. require(\"materials\") loads materials.lua next to the scene)"
        ));
    }
    Ok(path)
}
