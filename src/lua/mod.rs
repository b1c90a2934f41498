//! Lua scene scripts: run a script in the sandbox, take the scene it returns, and call its
//! `update(scene, t)` before each frame. The pipeline never sees Lua: it reads the
//! [`FrameDesc`](crate::frame::FrameDesc) the scene graph evaluates to.

pub mod api;
pub mod convert;
pub mod field;
pub mod glass;
pub mod imports;
pub mod meshes;
pub mod objects;
pub mod params;
pub mod pbr;
pub mod sandbox;
pub mod vecmath;

use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow};
use mlua::{Function, Lua, Table, Value};

use crate::scene::{Scene, Shared};
use objects::Obj;
pub use sandbox::Limits;

/// A loaded script: its Lua state and the scene it returned.
pub struct ScriptHost {
    lua: Lua,
    scene: Shared<Scene>,
    update: Option<Function>,
    path: PathBuf,
}

/// A scene (a script, or a glTF file) that failed to load, with the files it had read (or
/// looked for) by then: the files whose edit may fix it, for `refrakt watch`. Shown, it is
/// just the message.
#[derive(Debug)]
pub struct LoadError {
    pub message: String,
    pub files_read: Vec<PathBuf>,
}

impl std::fmt::Display for LoadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for LoadError {}

/// The files a failed scene load had read, if it got as far as reading any.
pub fn files_read_before(e: &anyhow::Error) -> &[PathBuf] {
    e.downcast_ref::<LoadError>().map_or(&[], |l| &l.files_read)
}

/// The user-facing text of a Lua error: `file:line: message`, without mlua's wrapping or the
/// traceback.
pub fn message(e: &mlua::Error) -> String {
    match e {
        mlua::Error::SyntaxError { message, .. } => message.clone(),
        mlua::Error::RuntimeError(m) => strip_traceback(m),
        mlua::Error::CallbackError { cause, .. } => message(cause),
        mlua::Error::WithContext { context, cause } => format!("{context}: {}", message(cause)),
        mlua::Error::MemoryError(_) => "the script ran out of memory".to_string(),
        other => strip_traceback(&other.to_string()),
    }
}

fn strip_traceback(m: &str) -> String {
    m.split("\nstack traceback:").next().unwrap_or(m).trim().to_string()
}

impl ScriptHost {
    /// Runs the script at `path` and takes the scene it returns.
    pub fn load(path: &Path, allow_read: &[PathBuf], limits: &Limits) -> Result<Self> {
        Self::load_with_params(path, allow_read, limits, &std::collections::BTreeMap::new())
    }

    /// [`load`](Self::load), with values for the script's `refrakt.param`s (by name; the
    /// others take their defaults).
    pub fn load_with_params(path: &Path, allow_read: &[PathBuf], limits: &Limits, params: &std::collections::BTreeMap<String, f64>) -> Result<Self> {
        let shown = path.display().to_string();
        let source = std::fs::read_to_string(path)
            .map_err(|e| anyhow!("cannot read the scene script {shown}: {e}"))?;
        let base = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let access = sandbox::FileAccess::new(base, allow_read)
            .map_err(|e| anyhow!("cannot open the scene's folder {}: {e}", base.display()))?;
        access.record(&path.canonicalize().unwrap_or_else(|_| path.to_path_buf()));
        let lua = sandbox::new_state(access, limits).map_err(|e| anyhow!("cannot start Lua: {e}"))?;
        lua.set_app_data(sandbox::ScriptName(shown.clone()));
        lua.set_app_data(params::ParamValues(params.clone()));
        install_require(&lua).map_err(|e| anyhow!("cannot start Lua: {e}"))?;
        match Self::scene_of(&lua, &shown, source) {
            Ok((scene, update)) => Ok(Self { lua, scene, update, path: path.to_path_buf() }),
            Err(e) => Err(LoadError { message: format!("{e:#}"), files_read: files_of(&lua) }.into()),
        }
    }

    /// Runs the script; returns the scene it built and the `update` it defines.
    fn scene_of(lua: &Lua, shown: &str, source: String) -> Result<(Shared<Scene>, Option<Function>)> {
        refuse_bytecode(shown, &source).map_err(|m| anyhow!(m))?;
        sandbox::start_budget(lua);
        let returned: Value = lua
            .load(source)
            .set_name(format!("@{shown}"))
            .set_mode(mlua::chunk::ChunkMode::Text)
            .eval()
            .map_err(|e| script_error(lua, &e))?;
        let scene = match &returned {
            Value::UserData(u) => u.borrow::<Obj<Scene>>().ok().map(|o| o.0.clone()),
            _ => None,
        }
        .ok_or_else(|| {
            anyhow!(
                "{shown}: the script must end with `return scene`, where scene = refrakt.scene{{…}}; \
                 it returned {}",
                convert::describe(&returned)
            )
        })?;
        let update = match lua.globals().get::<Value>("update") {
            Ok(Value::Function(f)) => Some(f),
            Ok(Value::Nil) => None,
            Ok(other) => {
                return Err(anyhow!("{shown}: `update` must be a function(scene, t), got {}", convert::describe(&other)));
            }
            Err(e) => return Err(script_error(lua, &e)),
        };
        Ok((scene, update))
    }

    pub fn scene(&self) -> &Shared<Scene> {
        &self.scene
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The `refrakt.param`s the script declared, with the values it got.
    pub fn params(&self) -> Vec<params::Param> {
        params::declared(&self.lua)
    }

    pub fn is_animated(&self) -> bool {
        self.update.is_some() || imports::is_animated(&self.lua)
    }

    /// The longest animation of the glTF files the script imported, seconds.
    pub fn imports_duration(&self) -> Option<f64> {
        imports::duration(&self.lua)
    }

    /// Poses imported glTF files at t (seconds), calls `update(scene, t)` if the script
    /// defines it, then deforms the imports' skinned and morphed meshes for the final pose.
    pub fn update(&self, t: f64) -> Result<()> {
        imports::pose(&self.lua, t);
        if let Some(f) = &self.update {
            sandbox::start_budget(&self.lua);
            f.call::<()>((Obj(self.scene.clone()), t)).map_err(|e| script_error(&self.lua, &e))?;
        }
        imports::deform(&self.lua, &self.scene.borrow());
        Ok(())
    }

    /// Every file the script read so far (itself, modules, images, meshes), and files it looked
    /// for that were missing.
    pub fn files_read(&self) -> Vec<PathBuf> {
        files_of(&self.lua)
    }
}

fn files_of(lua: &Lua) -> Vec<PathBuf> {
    lua.app_data_ref::<sandbox::FileAccess>().map(|a| a.read.borrow().clone()).unwrap_or_default()
}

/// Lua takes a chunk that starts with ESC for precompiled bytecode, which the sandbox never
/// loads (`ChunkMode::Text`); Lua's own refusal names no file, so say it here with the name.
/// (Found by the `lua_api` fuzz target: a one-byte script "\x1b".)
fn refuse_bytecode(shown: &str, source: &str) -> std::result::Result<(), String> {
    if source.starts_with('\x1b') {
        return Err(format!(
            "{shown}: this is precompiled Lua bytecode, not a script; refrakt runs scripts from their source text only"
        ));
    }
    Ok(())
}

/// A script error as one readable paragraph; out-of-memory gets the last line that ran, and a
/// stack overflow a hint at its usual cause.
pub(crate) fn script_error(lua: &Lua, e: &mlua::Error) -> anyhow::Error {
    let is_memory = matches!(e, mlua::Error::MemoryError(_))
        || matches!(e, mlua::Error::CallbackError { cause, .. } if matches!(**cause, mlua::Error::MemoryError(_)));
    if is_memory {
        // The line the instruction hook saw last, else (a bomb in the call's first
        // instructions) at least the script.
        let at = sandbox::last_line(lua)
            .or_else(|| lua.app_data_ref::<sandbox::ScriptName>().map(|n| n.0.clone()))
            .unwrap_or_else(|| "the script".into());
        return anyhow!(
            "{at}: the script used more memory than allowed (a table that grows without bound?); \
             the limit is set with --script-memory"
        );
    }
    let text = message(e);
    if text.ends_with("stack overflow") {
        return anyhow!("{text} (a function that calls itself without end?)");
    }
    anyhow!("{text}")
}

/// `require`: "refrakt" is the API; anything else is a module file below the scene's folder.
fn install_require(lua: &Lua) -> mlua::Result<()> {
    let loaded = lua.create_table()?;
    loaded.raw_set("refrakt", api::module(lua)?)?;
    let require = lua.create_function(move |lua, name: String| {
        let loaded: Table = lua.named_registry_value("refrakt.loaded")?;
        let cached: Value = loaded.raw_get(name.as_str())?;
        if !cached.is_nil() {
            return Ok(cached);
        }
        let rel = sandbox::module_path(&name).map_err(|m| convert::error_at(lua, m))?;
        let path = sandbox::FileAccess::resolve(lua, &rel.to_string_lossy())?;
        let source = std::fs::read_to_string(&path)
            .map_err(|e| convert::error_at(lua, format!("require(\"{name}\"): cannot read {}: {e}", path.display())))?;
        let shown = shown_path(lua, &rel);
        refuse_bytecode(&shown, &source).map_err(|m| convert::error_at(lua, m))?;
        let value: Value = lua.load(source).set_name(format!("@{shown}")).set_mode(mlua::chunk::ChunkMode::Text).eval()?;
        let value = if value.is_nil() { Value::Boolean(true) } else { value };
        loaded.raw_set(name.as_str(), value.clone())?;
        Ok(value)
    })?;
    lua.set_named_registry_value("refrakt.loaded", loaded)?;
    lua.globals().raw_set("require", require)
}

/// How a module's path is shown in messages: as the user would type it from the current folder.
fn shown_path(lua: &Lua, rel: &Path) -> String {
    let base = lua.app_data_ref::<sandbox::FileAccess>().map(|a| a.base.clone()).unwrap_or_default();
    let full = base.join(rel);
    let cwd = std::env::current_dir().ok().and_then(|c| c.canonicalize().ok());
    match cwd.and_then(|c| full.strip_prefix(&c).ok().map(Path::to_path_buf)) {
        Some(r) => r.display().to_string(),
        None => full.display().to_string(),
    }
}
