//! The documentation cannot rot: every `lua` example in docs/lua-api.md and the README runs,
//! the errors the docs show are the errors refrakt gives, and every function of the `refrakt`
//! module is documented.
//!
//! Conventions inside a ```lua block: a first line `-- file: NAME` makes the block a module
//! file NAME for the blocks after it; `-- error: TEXT` means the script must fail with an error
//! containing TEXT; any other block is a scene that must load, and whose `update` (if any) and
//! frame evaluation must succeed at t = 0, 0.5 and 1 s. The examples' assets (examples/*.glb)
//! sit next to the scene, so blocks can import them by name.

mod common;

use std::path::Path;

use refrakt::lua::{Limits, ScriptHost};
use refrakt::scene::eval::{EvalOptions, evaluate};

struct Block {
    line: usize,
    code: String,
}

fn lua_blocks(text: &str) -> Vec<Block> {
    let mut blocks = Vec::new();
    let mut current: Option<Block> = None;
    for (i, line) in text.lines().enumerate() {
        match &mut current {
            None if line.trim_start().starts_with("```lua") => current = Some(Block { line: i + 1, code: String::new() }),
            Some(_) if line.trim_start().starts_with("```") => blocks.extend(current.take()),
            Some(b) => {
                b.code.push_str(line);
                b.code.push('\n');
            }
            None => {}
        }
    }
    assert!(current.is_none(), "an unclosed ```lua block");
    blocks
}

/// Loads and evaluates `scene.lua` in `dir` at a few times.
fn run_scene(path: &Path) -> anyhow::Result<()> {
    let host = ScriptHost::load(path, &[], &Limits::default())?;
    for t in [0.0, 0.5, 1.0] {
        host.update(t)?;
        evaluate(&host.scene().borrow(), t, &EvalOptions::default())?;
    }
    Ok(())
}

/// The examples' assets (everything in examples/ but the Lua scenes), so doc examples can use
/// them by name: `refrakt.gltf("pendulum.glb")`.
fn copy_example_assets(to: &Path) {
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    for entry in std::fs::read_dir(examples).unwrap() {
        let path = entry.unwrap().path();
        if path.is_file() && path.extension().is_some_and(|e| e != "lua") {
            std::fs::copy(&path, to.join(path.file_name().unwrap())).unwrap();
        }
    }
}

/// Runs every block of `doc` (a path relative to the crate); returns how many were scenes.
fn run_doc(doc: &str) -> usize {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(doc)).unwrap();
    let dir = tempfile::tempdir().unwrap();
    copy_example_assets(dir.path());
    let scene = dir.path().join("scene.lua");
    let blocks = lua_blocks(&text);
    assert_eq!(blocks.len(), text.matches("```lua").count(), "{doc}: every ```lua block is parsed");
    let mut scenes = 0;
    for b in blocks {
        let first = b.code.lines().next().unwrap_or("");
        if let Some(name) = first.strip_prefix("-- file: ") {
            let path = dir.path().join(name.trim());
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(path, &b.code).unwrap();
            continue;
        }
        std::fs::write(&scene, &b.code).unwrap();
        let result = run_scene(&scene);
        match first.strip_prefix("-- error: ") {
            Some(expected) => {
                let e = format!("{:#}", result.err().unwrap_or_else(|| panic!("{doc}:{}: the example should fail", b.line)));
                assert!(e.contains(expected.trim()), "{doc}:{}: expected an error containing {expected:?}, got:\n{e}", b.line);
            }
            None => {
                result.unwrap_or_else(|e| panic!("{doc}:{}: the example fails:\n{e:#}", b.line));
                scenes += 1;
            }
        }
    }
    scenes
}

#[test]
fn every_example_in_the_lua_reference_runs() {
    assert!(run_doc("docs/lua-api.md") >= 10);
}

#[test]
fn every_lua_example_in_the_readme_runs() {
    assert!(run_doc("README.md") >= 1);
}

/// Every function of the module (and of `refrakt.vec`) is named in the reference, as
/// `refrakt.NAME` (the `vec` functions as `vec.NAME`, as its table writes them).
#[test]
fn every_module_function_is_documented() {
    let docs = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/lua-api.md")).unwrap();
    assert!(!docs.contains("]==]"));
    let script = format!(
        r#"local r = require("refrakt")
        local docs = [==[{docs}]==]
        local missing = {{}}
        local function check(prefix, t)
          for name, value in pairs(t) do
            if type(value) == "function" and not docs:find(prefix .. name, 1, true) then
              missing[#missing + 1] = prefix .. name
            end
          end
        end
        check("refrakt.", r)
        check("vec.", r.vec)
        assert(docs:find("refrakt.vec", 1, true) and docs:find("refrakt.ior", 1, true))
        table.sort(missing)
        assert(#missing == 0, "not in docs/lua-api.md: " .. table.concat(missing, ", "))
        return r.scene{{}}"#
    );
    let (_dir, path) = common::write_script("scene.lua", &script);
    ScriptHost::load(&path, &[], &Limits::default()).unwrap_or_else(|e| panic!("{e:#}"));
}
