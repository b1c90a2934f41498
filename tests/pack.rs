//! `refrakt pack` and rendering a bundle: the bundle holds exactly the files the scene reads
//! (not its neighbours), renders the same frames byte for byte from another folder after the
//! originals are gone, refuses at pack time a read outside the scene's folder unless
//! `--allow-read` allows it, and refuses to unpack entries that would leave its folder.

use std::path::{Path, PathBuf};
use std::process::Command;

/// A closed tetrahedron.
const TETRA: &str = "v 0 0.5 0\nv -0.45 -0.3 0.3\nv 0.45 -0.3 0.3\nv 0 -0.3 -0.45\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n";

/// A tiny animated scene that reads a module and the mesh at `mesh` (relative to it).
fn scene_source(mesh: &str) -> String {
    format!(
        r#"local r = require("refrakt")
local looks = require("lib.looks")
local scene = r.scene{{
  camera = r.camera{{ position = {{0, 0.2, 2.5}}, target = {{0, 0, 0}}, fov = 35, size = {{32, 18}} }},
  volume = {{ resolution = 16 }},
  photons = 0,
  samples = 1,
}}
local gem = r.node{{ name = "gem", shape = r.mesh{{ file = "{mesh}" }}, material = looks.glass }}
scene:add(gem)
scene:add(r.node{{ name = "floor", translation = {{0, -0.35, 0}}, shape = r.plane{{ size = {{4, 4}} }},
                  material = r.diffuse{{ color = {{0.6, 0.6, 0.6}} }} }})
scene:add(r.node{{ name = "sun", light = r.sun{{ direction = {{0.3, -1, 0.5}}, intensity = 500 }} }})
function update(scene, t)
  gem.rotation = {{0, 40 * t, 0}}
end
return scene
"#
    )
}

const LOOKS: &str = "local r = require(\"refrakt\")\nreturn { glass = r.glass{ ior = 1.5 } }\n";

/// Writes `files` (path relative to `root`, contents) below `root`.
fn write_tree(root: &Path, files: &[(&str, &str)]) {
    for (name, text) in files {
        let path = root.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }
}

fn refrakt(args: &[&str], cwd: &Path) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_refrakt")).args(args).current_dir(cwd).output().unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// Renders frames 0..2 of `scene` (a scene file or a bundle) into `out`, as PNG and EXR.
fn render(scene: &Path, out: &Path, cwd: &Path) {
    let (ok, err) = refrakt(
        &["render", scene.to_str().unwrap(), "--frames", "0..2", "--out", out.to_str().unwrap(), "--progress", "quiet"],
        cwd,
    );
    assert!(ok, "render of {} failed: {err}", scene.display());
}

/// Every file of `dir`, by name, with its bytes.
fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()))
        .collect();
    v.sort();
    v
}

/// The names of the files in a bundle, read with the same crates refrakt uses.
fn bundle_entries(bundle: &Path) -> Vec<String> {
    let decoder = zstd::Decoder::new(std::fs::File::open(bundle).unwrap()).unwrap();
    let mut archive = tar::Archive::new(decoder);
    let mut names: Vec<String> = archive.entries().unwrap().map(|e| e.unwrap().path().unwrap().to_string_lossy().into_owned()).collect();
    names.sort();
    names
}

#[test]
fn a_bundle_holds_exactly_what_the_scene_reads_and_renders_the_same_elsewhere() {
    let work = tempfile::tempdir().unwrap();
    let shot = work.path().join("shot");
    write_tree(&shot, &[
        ("scene.lua", &scene_source("meshes/tetra.obj")),
        ("lib/looks.lua", LOOKS),
        ("meshes/tetra.obj", TETRA),
        ("notes.txt", "not read by the scene"),
        ("meshes/unused.obj", TETRA),
    ]);
    let direct = work.path().join("direct");
    render(&shot.join("scene.lua"), &direct, work.path());

    let bundle = work.path().join("shot.tar.zst");
    let (ok, err) = refrakt(&["pack", "shot/scene.lua", "-o", "shot.tar.zst", "--frames", "0..2"], work.path());
    assert!(ok, "pack failed: {err}");
    assert_eq!(bundle_entries(&bundle), ["lib/looks.lua", "meshes/tetra.obj", "refrakt-bundle.json", "scene.lua"]);

    // Packing again gives the same bytes (fixed metadata, name order).
    let first = std::fs::read(&bundle).unwrap();
    let (ok, err) = refrakt(&["pack", "shot/scene.lua", "-o", "shot.tar.zst", "--frames", "0..2"], work.path());
    assert!(ok, "{err}");
    assert_eq!(std::fs::read(&bundle).unwrap(), first, "packing is deterministic");

    // Elsewhere, with the scene's folder gone: only the bundle is left to read.
    let elsewhere = tempfile::tempdir().unwrap();
    let moved = elsewhere.path().join("take.tar.zst");
    std::fs::rename(&bundle, &moved).unwrap();
    std::fs::remove_dir_all(&shot).unwrap();
    let from_bundle = elsewhere.path().join("frames");
    render(&moved, &from_bundle, elsewhere.path());
    let (a, b) = (files(&direct), files(&from_bundle));
    assert_eq!(a.len(), 6, "three frames, PNG and EXR: {:?}", a.iter().map(|f| &f.0).collect::<Vec<_>>());
    assert_eq!(a, b, "the bundle renders the same files, byte for byte, named after the scene inside");
    assert!(a[0].0.starts_with("scene.0000."), "{}", a[0].0);
}

#[test]
fn a_read_outside_the_folder_is_refused_at_pack_time_unless_allowed() {
    let work = tempfile::tempdir().unwrap();
    write_tree(work.path(), &[
        ("shot/scene.lua", &scene_source("../assets/tetra.obj")),
        ("shot/lib/looks.lua", LOOKS),
        ("assets/tetra.obj", TETRA),
    ]);
    let (ok, err) = refrakt(&["pack", "shot/scene.lua", "-o", "shot.tar.zst"], work.path());
    assert!(!ok, "packing a scene that reads outside its folder must fail");
    assert!(err.contains("outside the scene's folder") && err.contains("--allow-read"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!work.path().join("shot.tar.zst").exists(), "no bundle is left behind");

    let (ok, err) = refrakt(&["pack", "shot/scene.lua", "-o", "shot.tar.zst", "--allow-read", "assets"], work.path());
    assert!(ok, "{err}");
    let bundle = work.path().join("shot.tar.zst");
    assert_eq!(bundle_entries(&bundle), ["assets/tetra.obj", "refrakt-bundle.json", "shot/lib/looks.lua", "shot/scene.lua"]);
    // The layout above the scene's folder is kept, so "../assets" resolves inside the bundle.
    let direct = work.path().join("direct");
    let (ok, err) = refrakt(
        &["render", "shot/scene.lua", "--allow-read", "assets", "--frames", "0..2", "--out", "direct", "--progress", "quiet"],
        work.path(),
    );
    assert!(ok, "{err}");
    let elsewhere = tempfile::tempdir().unwrap();
    let from_bundle = elsewhere.path().join("frames");
    render(&bundle, &from_bundle, elsewhere.path());
    assert_eq!(files(&direct), files(&from_bundle));
}

/// A bundle whose entry is named `name` (written raw, as a hostile archive would), holding `data`.
fn hostile_bundle(dir: &Path, name: &str, kind: tar::EntryType, data: &[u8]) -> PathBuf {
    let path = dir.join("hostile.tar.zst");
    let mut tar = tar::Builder::new(zstd::Encoder::new(std::fs::File::create(&path).unwrap(), 3).unwrap());
    let manifest = br#"{"format":1,"scene":"scene.lua","files":["scene.lua"]}"#;
    let mut header = tar::Header::new_gnu();
    header.set_size(manifest.len() as u64);
    header.set_entry_type(tar::EntryType::Regular);
    tar.append_data(&mut header, "refrakt-bundle.json", &manifest[..]).unwrap();
    let mut header = tar::Header::new_old();
    let raw = &mut header.as_old_mut().name;
    raw[..name.len()].copy_from_slice(name.as_bytes());
    header.set_size(data.len() as u64);
    header.set_entry_type(kind);
    header.set_cksum();
    tar.append(&header, data).unwrap();
    tar.into_inner().unwrap().finish().unwrap();
    path
}

#[test]
fn hostile_bundles_are_refused_with_a_message() {
    let work = tempfile::tempdir().unwrap();
    let cases = [
        ("../escaped.lua", tar::EntryType::Regular, "not a plain relative path"),
        ("/tmp/escaped.lua", tar::EntryType::Regular, "not a plain relative path"),
        ("scene.lua", tar::EntryType::Symlink, "not a plain file"),
    ];
    for (name, kind, needle) in cases {
        let bundle = hostile_bundle(work.path(), name, kind, b"return nil");
        let (ok, err) = refrakt(&["render", bundle.to_str().unwrap(), "--out", "out", "--progress", "quiet"], work.path());
        assert!(!ok, "{name} was unpacked");
        assert!(err.contains(needle) && !err.contains("panicked"), "{name}: {err}");
    }
    assert!(!work.path().parent().unwrap().join("escaped.lua").exists());
    let garbage = work.path().join("garbage.tar.zst");
    std::fs::write(&garbage, b"not zstd at all").unwrap();
    let (ok, err) = refrakt(&["render", garbage.to_str().unwrap(), "--out", "out"], work.path());
    assert!(!ok && err.contains("garbage.tar.zst") && !err.contains("panicked"), "{err}");
}
