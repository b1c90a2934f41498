//! The sandbox scene scripts run in.
//!
//! Scripts get Lua's table, string, math, utf8 and coroutine libraries and nothing that reaches
//! the system: no `io`, no `os.execute`, no `package.loadlib`, no `debug`, no bytecode (`load`
//! takes text only, `string.dump` is gone). Files are read only through the refrakt API and only
//! below the scene's folder (or a folder the user allowed with `--allow-read`); every file read
//! is recorded, so `refrakt watch` knows exactly what to watch. A runaway script is stopped after
//! a time budget per call and a memory limit, each with a message naming file:line.

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
    /// Every file the script read, in order, without repeats.
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
        let joined = access.base.join(given);
        let path = joined.canonicalize().map_err(|e| {
            error_at(lua, format!("cannot open \"{given}\" (looked for {}): {e}", joined.display()))
        })?;
        if !access.roots.iter().any(|r| path.starts_with(r)) {
            return Err(error_at(
                lua,
                format!(
                    "\"{given}\" is outside the scene's folder {}; scripts may read only files below \
                     it (add a folder with --allow-read DIR)",
                    access.base.display()
                ),
            ));
        }
        access.record(&path);
        Ok(path)
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
    /// Last `file:line` the hook saw, for errors (such as out-of-memory) that carry none.
    last_line: RefCell<String>,
}

/// Starts the time budget of a new top-level call (loading, or one `update`).
pub fn start_budget(lua: &Lua) {
    if let Some(b) = lua.app_data_ref::<Budget>() {
        b.started.set(Instant::now());
    }
}

/// The last line the instruction hook saw running.
pub fn last_line(lua: &Lua) -> Option<String> {
    lua.app_data_ref::<Budget>().map(|b| b.last_line.borrow().clone()).filter(|s| !s.is_empty())
}

/// A Lua state with only the safe libraries, the limits installed, and the file policy.
pub fn new_state(access: FileAccess, limits: &Limits) -> mlua::Result<Lua> {
    let libs = StdLib::TABLE | StdLib::STRING | StdLib::MATH | StdLib::UTF8 | StdLib::COROUTINE;
    let lua = Lua::new_with(libs, mlua::LuaOptions::default())?;
    lua.set_app_data(access);
    lua.set_app_data(Budget {
        started: Cell::new(Instant::now()),
        limit: limits.time_budget,
        last_line: RefCell::new(String::new()),
    });
    lua.set_memory_limit(limits.memory_bytes)?;
    lua.set_hook(HookTriggers::new().every_nth_instruction(4096), |lua, debug| {
        let Some(budget) = lua.app_data_ref::<Budget>() else { return Ok(VmState::Continue) };
        if let Some(line) = debug.current_line() {
            let src = debug.source();
            *budget.last_line.borrow_mut() = format!("{}:{line}", src.short_src.as_deref().unwrap_or("?"));
        }
        if budget.started.get().elapsed() > budget.limit {
            let at = budget.last_line.borrow().clone();
            return Err(mlua::Error::RuntimeError(format!(
                "{at}: the script ran for more than {:.0} s without finishing (an endless loop?); \
                 the limit is set with --script-timeout",
                budget.limit.as_secs_f64()
            )));
        }
        Ok(VmState::Continue)
    })?;
    restrict_globals(&lua)?;
    Ok(lua)
}

/// Removes or replaces what could reach outside the sandbox.
fn restrict_globals(lua: &Lua) -> mlua::Result<()> {
    let g = lua.globals();
    for name in ["dofile", "loadfile", "collectgarbage", "require", "package", "debug", "io"] {
        g.raw_set(name, Value::Nil)?;
    }
    let string: Table = g.get("string")?;
    string.raw_set("dump", Value::Nil)?;
    // `load` of text only: precompiled bytecode can break the interpreter's safety.
    let load = lua.create_function(|lua, (chunk, name, _mode, env): (mlua::LuaString, Option<String>, Value, Option<Table>)| {
        let bytes = chunk.as_bytes();
        if bytes.first() == Some(&0x1b) {
            return Err(error_at(lua, "load: precompiled bytecode is not allowed in scene scripts"));
        }
        let mut c = lua.load(bytes.to_vec()).set_mode(mlua::chunk::ChunkMode::Text);
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
    })?;
    g.raw_set("load", load)?;
    // A safe corner of `os`: clocks and dates, nothing that runs or removes anything.
    let os = lua.create_table()?;
    os.raw_set("clock", lua.create_function(|_, ()| Ok(cpu_clock()))?)?;
    os.raw_set(
        "time",
        lua.create_function(|_, ()| {
            Ok(std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0))
        })?,
    )?;
    g.raw_set("os", os)?;
    g.raw_set(
        "print",
        lua.create_function(|lua, args: mlua::Variadic<Value>| {
            let parts: Vec<String> = args.iter().map(|v| v.to_string().unwrap_or_else(|_| v.type_name().into())).collect();
            eprintln!("[{}] {}", super::convert::location(lua), parts.join("\t"));
            Ok(())
        })?,
    )?;
    Ok(())
}

fn cpu_clock() -> f64 {
    thread_local!(static START: Instant = Instant::now());
    START.with(|s| s.elapsed().as_secs_f64())
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
