//! The documentation cannot rot: every `lua` example in the README and the guide (docs/*.md)
//! runs, the errors the docs show are the errors refrakt gives, every `refrakt …` command line
//! in an `sh` block is one refrakt's parser takes, every relative link resolves inside the
//! repository, the README stays a front page, and every function of the `refrakt` module is
//! documented.
//!
//! Conventions inside a ```lua block: a first line `-- file: NAME` makes the block a module
//! file NAME for the blocks after it; `-- error: TEXT` means the script must fail with an error
//! containing TEXT; any other block is a scene that must load, and whose `update` (if any) and
//! frame evaluation must succeed at t = 0, 0.5 and 1 s. The examples' assets (examples/*.glb)
//! sit next to the scene, so blocks can import them by name.

mod common;

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::process::Command;

use refrakt::lua::{Limits, ScriptHost};
use refrakt::scene::eval::{EvalOptions, evaluate};

struct Block {
    /// The fence's info string: `lua`, `sh`, `text`…
    lang: String,
    line: usize,
    code: String,
}

/// The fenced code blocks of a Markdown text.
fn code_blocks(text: &str) -> Vec<Block> {
    let mut blocks = Vec::new();
    let mut current: Option<Block> = None;
    for (i, line) in text.lines().enumerate() {
        let fence = line.trim_start().strip_prefix("```");
        match (&mut current, fence) {
            (None, Some(info)) => current = Some(Block { lang: info.trim().to_string(), line: i + 1, code: String::new() }),
            (Some(_), Some(_)) => blocks.extend(current.take()),
            (Some(b), None) => {
                b.code.push_str(line);
                b.code.push('\n');
            }
            (None, None) => {}
        }
    }
    assert!(current.is_none(), "an unclosed ``` block");
    blocks
}

fn lua_blocks(text: &str) -> Vec<Block> {
    code_blocks(text).into_iter().filter(|b| b.lang == "lua").collect()
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The README and every chapter of the guide, as paths relative to the crate.
fn documents() -> Vec<String> {
    let mut docs = vec!["README.md".to_string(), "CHANGELOG.md".to_string()];
    let mut guide: Vec<String> = std::fs::read_dir(root().join("docs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".md"))
        .map(|n| format!("docs/{n}"))
        .collect();
    guide.sort();
    docs.extend(guide);
    docs
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
    let examples = root().join("examples");
    for entry in std::fs::read_dir(examples).unwrap() {
        let path = entry.unwrap().path();
        if path.is_file() && path.extension().is_some_and(|e| e != "lua") {
            std::fs::copy(&path, to.join(path.file_name().unwrap())).unwrap();
        }
    }
}

/// Runs every block of `doc` (a path relative to the crate); returns how many were scenes.
fn run_doc(doc: &str) -> usize {
    let text = std::fs::read_to_string(root().join(doc)).unwrap();
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
fn every_lua_example_in_the_readme_and_the_guide_runs() {
    assert!(run_doc("README.md") >= 1, "the README shows a scene");
    for doc in documents().iter().filter(|d| *d != "docs/lua-api.md" && *d != "README.md") {
        run_doc(doc);
    }
}

/// The README is a front page: short, and its first code block is the two commands a new
/// user runs (render the default example; run every test).
#[test]
fn the_readme_is_a_front_page() {
    let text = std::fs::read_to_string(root().join("README.md")).unwrap();
    let lines = text.lines().count();
    assert!(lines <= 250, "README.md has {lines} lines: keep it a front page (at most 250) and move facts into docs/");
    let first = code_blocks(&text).into_iter().next().expect("the README shows its commands");
    let commands: Vec<&str> = first.code.lines().map(|l| l.split('#').next().unwrap().trim()).filter(|l| !l.is_empty()).collect();
    assert_eq!(commands, ["bash scripts/render.sh", "bash scripts/test.sh"], "README.md:{}: the first code block", first.line);
    for command in &commands {
        let script = command.trim_start_matches("bash ");
        assert!(root().join(script).is_file(), "{script} exists");
    }
    assert!(root().join("examples/default.lua").is_file());
    let ci = std::fs::read_to_string(root().join(".ci/run")).unwrap();
    assert!(ci.contains("bash scripts/test.sh"), ".ci/run runs the README's test command");
}

/// GitHub's anchor for a heading: lower case, punctuation dropped (letters, digits, spaces,
/// `-` and `_` kept), spaces to hyphens; a repeated heading gets `-1`, `-2`….
fn anchors(text: &str) -> HashSet<String> {
    let mut seen = HashSet::new();
    for line in lines_outside_code_blocks(text) {
        let Some(heading) = line.strip_prefix('#') else { continue };
        let title = heading.trim_start_matches('#').trim();
        let slug: String = title
            .to_lowercase()
            .chars()
            .filter(|c| c.is_alphanumeric() || *c == ' ' || *c == '-' || *c == '_')
            .map(|c| if c == ' ' { '-' } else { c })
            .collect();
        let mut unique = slug.clone();
        let mut n = 0;
        while !seen.insert(unique.clone()) {
            n += 1;
            unique = format!("{slug}-{n}");
        }
    }
    seen
}

/// The lines of a Markdown text outside its fenced code blocks (fences left out too).
fn lines_outside_code_blocks(text: &str) -> impl Iterator<Item = &str> {
    let mut in_code = false;
    text.lines().filter(move |line| {
        let fence = line.trim_start().starts_with("```");
        in_code ^= fence;
        !fence && !in_code
    })
}

/// The text outside code blocks and inline code spans, where links are links.
fn prose(text: &str) -> String {
    let mut out = String::new();
    for line in lines_outside_code_blocks(text) {
        for (i, part) in line.split('`').enumerate() {
            if i % 2 == 0 {
                out.push_str(part);
            }
        }
        out.push('\n');
    }
    out
}

/// Every link target of a Markdown text: `[text](target)`, `![alt](target)`, `[ref]: target`
/// and `src="target"`.
fn link_targets(text: &str) -> Vec<String> {
    let text = prose(text);
    let mut targets = Vec::new();
    for (i, _) in text.match_indices("](") {
        let rest = &text[i + 2..];
        if let Some(end) = rest.find(')') {
            targets.push(rest[..end].split_whitespace().next().unwrap_or("").to_string());
        }
    }
    for line in text.lines() {
        let t = line.trim_start();
        if t.starts_with('[') && let Some(i) = t.find("]: ") {
            targets.push(t[i + 3..].split_whitespace().next().unwrap_or("").to_string());
        }
    }
    for (i, _) in text.match_indices("src=\"") {
        let rest = &text[i + 5..];
        targets.extend(rest.find('"').map(|end| rest[..end].to_string()));
    }
    targets
}

/// Every relative link in the README and the guide names a file inside the repository (and,
/// for `file.md#part`, one of its headings); nothing points outside it, where a user of the
/// project has nothing.
#[test]
fn every_link_resolves_inside_the_repository() {
    let root = root().canonicalize().unwrap();
    let mut checked = 0;
    for doc in documents() {
        let path = root.join(&doc);
        let text = std::fs::read_to_string(&path).unwrap();
        for target in link_targets(&text) {
            if target.is_empty() || target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (file, fragment) = target.split_once('#').unwrap_or((&target, ""));
            let linked = if file.is_empty() { path.clone() } else { path.parent().unwrap().join(file) };
            let resolved = linked.canonicalize().unwrap_or_else(|_| panic!("{doc}: the link {target} names no file"));
            assert!(resolved.starts_with(&root), "{doc}: the link {target} leaves the repository");
            if !fragment.is_empty() && resolved.extension().is_some_and(|e| e == "md") {
                let headings = anchors(&std::fs::read_to_string(&resolved).unwrap());
                assert!(headings.contains(fragment), "{doc}: the link {target}: no heading #{fragment} there");
            }
            checked += 1;
        }
    }
    assert!(checked > 20, "only {checked} links checked");
}

/// Every `refrakt …` command line in an `sh` block is one the real command line takes: each
/// is run with `--help` appended, which parses the words before it (an unknown option, a bad
/// value or a misspelt subcommand fails) and then prints help instead of running.
#[test]
fn every_refrakt_command_in_the_docs_parses() {
    let mut checked = 0;
    for doc in documents() {
        let text = std::fs::read_to_string(root().join(&doc)).unwrap();
        for block in code_blocks(&text).into_iter().filter(|b| b.lang == "sh" || b.lang == "bash") {
            for (i, line) in block.code.lines().enumerate() {
                let command = line.split(" #").next().unwrap().trim();
                let Some(args) = command.strip_prefix("refrakt ") else { continue };
                let words: Vec<&str> = args.split_whitespace().take_while(|w| !["|", ">", "&&", ";", "2>&1"].contains(w)).collect();
                let out = Command::new(env!("CARGO_BIN_EXE_refrakt")).args(&words).arg("--help").output().unwrap();
                assert!(
                    out.status.success(),
                    "{doc}:{}: `{command}` is not a valid refrakt command line:\n{}",
                    block.line + 1 + i,
                    String::from_utf8_lossy(&out.stderr)
                );
                checked += 1;
            }
        }
    }
    assert!(checked >= 10, "only {checked} command lines checked");
}

/// Every function of the module (and of `refrakt.vec`) is named in the reference, as
/// `refrakt.NAME` (the `vec` functions as `vec.NAME`, as its table writes them).
#[test]
fn every_module_function_is_documented() {
    let docs = std::fs::read_to_string(root().join("docs/lua-api.md")).unwrap();
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

/// The glTF chapter's support table names every extension the importer reads and every one it
/// refuses with advice, each on a row of its own, and both ways: a row that says something is
/// read names an extension the importer reads, a row that reads nothing ("—") one it does not.
/// The table cannot drift from the code.
#[test]
fn the_gltf_support_table_names_every_extension_the_importer_knows() {
    use refrakt::gltf::document::{SUPPORTED_EXTENSIONS, UNDECODABLE};
    let text = std::fs::read_to_string(root().join("docs/gltf.md")).unwrap();
    let start = text.find("## Support table").expect("docs/gltf.md has a support table");
    let table = &text[start..text[start..].find("\n## ").map_or(text.len(), |end| start + end)];
    let rows: Vec<(&str, &str)> = table
        .lines()
        .filter(|l| l.starts_with("| `"))
        .map(|l| {
            let cells: Vec<&str> = l.split(" | ").collect();
            (cells[0].trim_start_matches("| `").trim_end_matches('`'), cells[1].trim())
        })
        .collect();
    let names = SUPPORTED_EXTENSIONS.iter().copied().chain(UNDECODABLE.iter().map(|(name, _)| *name));
    for name in names {
        assert!(rows.iter().any(|(row, _)| *row == name), "docs/gltf.md's support table has no row for {name}");
    }
    for (name, read) in &rows {
        let supported = SUPPORTED_EXTENSIONS.contains(name);
        assert_eq!(*read != "—", supported, "docs/gltf.md's support table: {name} reads \"{read}\", but the importer {} it", if supported { "reads" } else { "does not read" });
    }
}
