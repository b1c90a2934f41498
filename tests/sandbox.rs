//! The sandbox scene scripts run in: every way out is refused with a clear error naming the
//! script's file:line, and runaway scripts (time, memory, recursion) are stopped.

mod common;

use std::time::{Duration, Instant};

use refrakt::lua::{Limits, ScriptHost};

/// A short time budget, so the endless loops end quickly; the other cases get a long one, so
/// that on a loaded machine the limit under test (memory, stack, a refusal) is what stops them.
fn limits() -> Limits {
    Limits { time_budget: Duration::from_secs(60), memory_bytes: 64 << 20 }
}

fn short_budget() -> Limits {
    Limits { time_budget: Duration::from_millis(300), ..limits() }
}

/// The error `body` is refused with (its first line is scene.lua:3).
fn refused(body: &str) -> String {
    common::load_error(body, &limits())
}

/// The error `body` is stopped with under the short time budget.
fn stopped(body: &str) -> String {
    common::load_error(body, &short_budget())
}

fn assert_contains(message: &str, needles: &[&str]) {
    for n in needles {
        assert!(message.contains(n), "the error should contain {n:?}:\n{message}");
    }
    assert!(!message.contains("stack traceback"), "one paragraph, no traceback:\n{message}");
}

/// A compiled chunk (it starts with ESC) as the scene or as a module: refused, naming the file.
#[test]
fn bytecode_is_refused_with_the_files_name() {
    let (_dir, path) = common::write_script("scene.lua", "\x1bLuaT\0");
    let e = format!("{:#}", ScriptHost::load(&path, &[], &limits()).err().expect("bytecode is refused"));
    assert_contains(&e, &["scene.lua: this is precompiled Lua bytecode"]);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("lib.lua"), "\x1b").unwrap();
    std::fs::write(dir.path().join("scene.lua"), "local lib = require(\"lib\")\nreturn lib\n").unwrap();
    let e = format!("{:#}", ScriptHost::load(&dir.path().join("scene.lua"), &[], &limits()).err().expect("bytecode is refused"));
    assert_contains(&e, &["lib.lua: this is precompiled Lua bytecode"]);
}

#[test]
fn os_execute_is_refused() {
    let e = refused("os.execute(\"touch /tmp/refrakt-escaped\")");
    assert_contains(&e, &["scene.lua:3:", "os.execute is not available in scene scripts"]);
    assert!(!std::path::Path::new("/tmp/refrakt-escaped").exists());
}

#[test]
fn io_open_is_refused() {
    let e = refused("local f = io.open(\"/etc/passwd\")");
    assert_contains(&e, &["scene.lua:3:", "io.open is not available in scene scripts", "through the refrakt API"]);
}

#[test]
fn io_popen_and_os_getenv_are_refused() {
    assert_contains(&refused("io.popen(\"ls\")"), &["scene.lua:3:", "io.popen is not available"]);
    assert_contains(&refused("local home = os.getenv(\"HOME\")"), &["scene.lua:3:", "os.getenv is not available"]);
}

#[test]
fn require_cannot_climb_out_of_the_scene_folder() {
    let outer = tempfile::tempdir().unwrap();
    // The module exists, two folders up: it must still be refused.
    std::fs::write(outer.path().join("x.lua"), "return {}").unwrap();
    let scene_dir = outer.path().join("a/b");
    std::fs::create_dir_all(&scene_dir).unwrap();
    let path = scene_dir.join("scene.lua");
    std::fs::write(&path, "local r = require(\"refrakt\")\nlocal x = require(\"../../x\")\nreturn r.scene{}\n").unwrap();
    let e = format!("{:#}", ScriptHost::load(&path, &[], &limits()).err().expect("refused"));
    assert_contains(&e, &["scene.lua:2:", "require(\"../../x\")", "without \"..\" or absolute paths"]);
    let e = refused("require(\"/etc/passwd\")");
    assert_contains(&e, &["scene.lua:3:", "without \"..\" or absolute paths"]);
}

#[test]
fn a_symlink_out_of_the_scene_folder_is_refused() {
    let outer = tempfile::tempdir().unwrap();
    std::fs::write(outer.path().join("secret.lua"), "return {}").unwrap();
    let scene_dir = outer.path().join("scene");
    std::fs::create_dir(&scene_dir).unwrap();
    std::os::unix::fs::symlink(outer.path().join("secret.lua"), scene_dir.join("link.lua")).unwrap();
    let path = scene_dir.join("scene.lua");
    std::fs::write(&path, "local r = require(\"refrakt\")\nrequire(\"link\")\nreturn r.scene{}\n").unwrap();
    let e = format!("{:#}", ScriptHost::load(&path, &[], &limits()).err().expect("refused"));
    assert_contains(&e, &["scene.lua:2:", "outside the scene's folder", "--allow-read"]);
}

#[test]
fn package_loadlib_is_refused() {
    let e = refused("local f = package.loadlib(\"/lib/x86_64-linux-gnu/libc.so.6\", \"system\")");
    assert_contains(&e, &["scene.lua:3:", "package.loadlib is not available"]);
}

#[test]
fn bytecode_cannot_be_made_or_loaded() {
    let e = refused("local f = load(string.dump(function() return 1 end))");
    assert_contains(&e, &["scene.lua:3:", "string.dump is not available"]);
    // Bytecode from elsewhere (the header of a Lua 5.4 chunk) is refused by load itself.
    let e = refused("local f = load(\"\\27LuaT\\0\\25\\147\\r\\n\\26\\n\")");
    assert_contains(&e, &["scene.lua:3:", "load of precompiled bytecode is not available"]);
    // So is bytecode handed over in pieces by a reader function.
    let e = refused("local parts = {\"\\27Lua\", \"T\"}\nlocal i = 0\nload(function() i = i + 1 return parts[i] end)");
    assert_contains(&e, &["scene.lua:5:", "precompiled bytecode"]);
}

#[test]
fn text_load_still_works() {
    let source = "local r = require(\"refrakt\")\nlocal f = load(\"return 1 + 1\")\nassert(f() == 2)\n\
                  local parts = {\"return \", \"40 + 2\"}\nlocal i = 0\n\
                  assert(load(function() i = i + 1 return parts[i] end)() == 42)\n\
                  local _, err = load(\"return +\")\nassert(err:find(\"unexpected symbol\"))\nreturn r.scene{}\n";
    let (_dir, path) = common::write_script("scene.lua", source);
    ScriptHost::load(&path, &[], &limits()).unwrap_or_else(|e| panic!("{e:#}"));
}

#[test]
fn debug_sethook_is_refused() {
    let e = refused("debug.sethook()");
    assert_contains(&e, &["scene.lua:3:", "debug.sethook is not available"]);
}

#[test]
fn an_endless_loop_is_stopped_by_the_time_budget() {
    let started = Instant::now();
    let e = stopped("local i = 0\nwhile true do i = i + 1 end");
    assert_contains(&e, &["scene.lua:4:", "ran for more than 0.3 s", "--script-timeout"]);
    assert!(started.elapsed() < Duration::from_secs(5), "stopped promptly");
}

#[test]
fn an_endless_loop_cannot_hide_in_pcall_or_a_coroutine() {
    let e = stopped("while true do pcall(function() while true do end end) end");
    assert_contains(&e, &["scene.lua:3:", "ran for more than"]);
    let e = stopped("coroutine.wrap(function()\n  while true do end\nend)()");
    assert_contains(&e, &["scene.lua:4:", "ran for more than"]);
    let e = stopped("local co = coroutine.create(function() while true do end end)\nwhile true do coroutine.resume(co) end");
    assert_contains(&e, &["scene.lua:3:", "ran for more than"]);
}

#[test]
fn an_endless_update_is_stopped_with_its_line() {
    let source = "local r = require(\"refrakt\")\nlocal scene = r.scene{}\nfunction update(scene, t)\n  \
                  while t >= 0 do end\nend\nreturn scene\n";
    let (_dir, path) = common::write_script("scene.lua", source);
    let host = ScriptHost::load(&path, &[], &short_budget()).unwrap();
    let e = format!("{:#}", host.update(0.5).expect_err("stopped"));
    assert_contains(&e, &["scene.lua:4:", "ran for more than"]);
    // The budget is per call: the next update starts a fresh one (and is stopped again).
    assert!(host.update(1.0).is_err());
}

#[test]
fn a_table_that_grows_without_bound_hits_the_memory_limit() {
    let e = refused("local t = {}\nlocal i = 0\nwhile true do\n  i = i + 1\n  t[i] = {i}\nend");
    assert_contains(&e, &["scene.lua:", "more memory than allowed", "--script-memory"]);
    // A one-line bomb (issue #16: it was reported at "?:"), as a function and as a method.
    let e = refused("local s = string.rep(\"x\", 1 << 30)");
    assert_contains(&e, &["scene.lua:3:", "string.rep would make a string of 1024 MiB", "--script-memory"]);
    let e = refused("local n = 40\nlocal s = (\"xy\"):rep(1 << n, \",\")");
    assert_contains(&e, &["scene.lua:4:", "string.rep would make a string"]);
    // Within the limit, string.rep is Lua's own.
    let e = refused("assert(string.rep(\"ab\", 3, \"-\") == \"ab-ab-ab\" and (\"x\"):rep(0) == \"\")\nerror(\"fine\")");
    assert_contains(&e, &["scene.lua:4:", "fine"]);
    // A bomb the hook has not seen a line of yet names the script at least.
    let e = refused("local big = table.concat({string.rep(\"x\", 40 << 20), string.rep(\"y\", 40 << 20)})");
    assert_contains(&e, &["scene.lua", "more memory than allowed"]);
    assert!(!e.contains("?:"), "{e}");
}

#[test]
fn deep_recursion_is_stopped() {
    let e = refused("local function f(n) return f(n + 1) + 1 end\nf(1)");
    assert_contains(&e, &["scene.lua:3:", "stack overflow", "calls itself without end"]);
    // Recursion through a metamethod (C calls between the Lua frames).
    let e = refused("local t = setmetatable({}, {__index = function(t, k) return t[k] end})\nlocal x = t.a");
    assert_contains(&e, &["scene.lua:3:", "stack overflow"]);
}

#[test]
fn dofile_loadfile_and_collectgarbage_are_refused() {
    assert_contains(&refused("dofile(\"/etc/passwd\")"), &["scene.lua:3:", "dofile is not available", "require"]);
    assert_contains(&refused("loadfile(\"/etc/passwd\")"), &["scene.lua:3:", "loadfile is not available"]);
    assert_contains(&refused("collectgarbage(\"stop\")"), &["scene.lua:3:", "collectgarbage is not available"]);
}

#[test]
fn safe_parts_of_os_remain() {
    let source = "local r = require(\"refrakt\")\nassert(type(os.clock()) == \"number\")\n\
                  assert(type(os.time()) == \"number\")\nassert(os.date(\"!%Y\", 0) == \"1970\")\n\
                  assert(os.difftime(5, 3) == 2)\nreturn r.scene{}\n";
    let (_dir, path) = common::write_script("scene.lua", source);
    ScriptHost::load(&path, &[], &limits()).unwrap_or_else(|e| panic!("{e:#}"));
}
