//! Bad glTF input: each damage a file can have gives one clear error naming the file and what
//! is wrong, a non-zero exit, never a panic, and never an allocation sized by what the file
//! claims (the 1 GB buffer is refused under a 256 MiB address-space limit). A property test
//! mutates valid files at random and checks that importing, animating and evaluating them
//! returns (Ok or a message) without panicking.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::fuzz::{fuzz_config, mutate, mutation};
use common::gltf_builder::{GltfBuilder, glb, sample_scene};
use proptest::prelude::*;
use refrakt::gltf::ImportOptions;
use refrakt::lua::sandbox::FileAccess;
use refrakt::scene::eval::{EvalOptions, evaluate};
use serde_json::json;

/// `refrakt dump FILE` (a GPU is not needed), optionally under an address-space limit (KiB).
fn dump(path: &Path, memory_kib: Option<u64>) -> (i32, String) {
    let bin = env!("CARGO_BIN_EXE_refrakt");
    let out = match memory_kib {
        Some(kib) => Command::new("sh").arg("-c").arg(format!("ulimit -v {kib} && exec \"$0\" dump \"$1\"")).arg(bin).arg(path).output(),
        None => Command::new(bin).arg("dump").arg(path).output(),
    }
    .unwrap();
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into())
}

fn assert_refused(path: &Path, needles: &[&str]) {
    assert_refused_within(path, None, needles)
}

fn assert_refused_within(path: &Path, memory_kib: Option<u64>, needles: &[&str]) {
    let (code, err) = dump(path, memory_kib);
    assert_ne!(code, 0, "must fail: {err}");
    assert!(!err.contains("panicked") && !err.contains("internal error") && !err.contains("memory allocation"), "no panic: {err}");
    assert_eq!(err.trim().lines().count(), 1, "one paragraph: {err}");
    let name = path.file_name().unwrap().to_string_lossy();
    for n in std::iter::once(name.as_ref()).chain(needles.iter().copied()) {
        assert!(err.contains(n), "stderr should contain {n:?}:\n{err}");
    }
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn a_valid_sample_dumps() {
    let dir = tempfile::tempdir().unwrap();
    let p = sample_scene().write_glb(&dir.path().join("sample.glb"));
    let (code, err) = dump(&p, None);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn a_truncated_glb_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = sample_scene().glb_bytes();
    for (name, cut) in [("header.glb", 7), ("half.glb", bytes.len() / 2), ("last-byte.glb", bytes.len() - 1)] {
        let p = write(dir.path(), name, &bytes[..cut]);
        assert_refused(&p, &["truncated or damaged"]);
    }
}

#[test]
fn a_wrong_magic_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = sample_scene().glb_bytes();
    bytes[..4].copy_from_slice(b"glTX");
    assert_refused(&write(dir.path(), "magic.glb", &bytes), &["not a binary glTF file", "67 6c 54 58"]);
}

#[test]
fn an_accessor_index_out_of_range_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut g = sample_scene();
    g.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(999);
    assert_refused(&g.write_glb(&dir.path().join("index.glb")), &["meshes[0].primitives[0].attributes", "index out of range"]);
}

#[test]
fn a_missing_buffer_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = sample_scene().write_external(&dir.path().join("scene.gltf"), "scene.bin");
    std::fs::remove_file(dir.path().join("scene.bin")).unwrap();
    assert_refused(&p, &["buffers[0]", "cannot open \"scene.bin\""]);
}

#[test]
fn a_nan_in_an_animation_sampler_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut g = sample_scene();
    let out = g.floats(&[0.0, 0.5, 0.0, f32::NAN, 0.7, 0.0, 0.0, 0.5, 0.0], "VEC3");
    g.json["animations"][0]["samplers"][0]["output"] = json!(out);
    assert_refused(&g.write_glb(&dir.path().join("nan.glb")), &["animations[0] \"Play\" samplers[0]", "NaN"]);
}

#[test]
fn a_buffer_claiming_a_gigabyte_is_refused_without_allocating_it() {
    let dir = tempfile::tempdir().unwrap();
    let g = sample_scene();
    let mut json = g.json.clone();
    json["buffers"] = json!([{ "byteLength": 1u64 << 30 }]);
    let p = write(dir.path(), "huge.glb", &glb(&serde_json::to_vec(&json).unwrap(), &g.bin));
    // 256 MiB of address space: enough for refrakt, not for the gigabyte.
    assert_refused_within(&p, Some(256 * 1024), &["buffers[0] claims byteLength 1073741824", "has only"]);
    // The same claim for an external file, and an accessor claiming a billion elements.
    let mut json = g.json.clone();
    json["buffers"] = json!([{ "byteLength": 1u64 << 30, "uri": "small.bin" }]);
    std::fs::write(dir.path().join("small.bin"), &g.bin).unwrap();
    let p = write(dir.path(), "huge-external.gltf", &serde_json::to_vec(&json).unwrap());
    assert_refused_within(&p, Some(256 * 1024), &["claims byteLength 1073741824"]);
    let mut json = g.json.clone();
    json["accessors"][0]["count"] = json!(1_000_000_000u64);
    let p = write(dir.path(), "huge-count.glb", &glb(&serde_json::to_vec(&{
        let mut j = json.clone();
        j["buffers"] = json!([{ "byteLength": g.bin.len() }]);
        j
    }).unwrap(), &g.bin));
    assert_refused_within(&p, Some(256 * 1024), &["accessors[0]", "1000000000 elements"]);
}

#[test]
fn other_damage_gets_its_own_message() {
    let dir = tempfile::tempdir().unwrap();
    type Damage = Box<dyn Fn(&mut GltfBuilder)>;
    let cases: Vec<(&str, Damage, &[&str])> = vec![
        ("draco.glb", Box::new(|g| g.uses("KHR_draco_mesh_compression", true)), &["requires the glTF extension KHR_draco_mesh_compression", "gltf-transform copy"]),
        ("lines.glb", Box::new(|g| g.json["meshes"][0]["primitives"][0]["mode"] = json!(1)), &["meshes[0] \"Gem\" primitives[0]", "Lines", "triangle meshes only"]),
        ("two-parents.glb", Box::new(|g| g.json["nodes"][1]["children"] = json!([3])), &["nodes[3] is a child of both nodes[1] and nodes[5]"]),
        ("cycle.glb", Box::new(|g| {
            // Root ▸ Tip ▸ Root, no longer under the rig.
            g.json["nodes"][5]["children"] = json!([4]);
            g.json["nodes"][2]["children"] = json!([3]);
        }), &["is its own ancestor"]),
        ("version.glb", Box::new(|g| g.json["asset"]["version"] = json!("1.0")), &["asset.version is \"1.0\""]),
        ("times.glb", Box::new(|g| {
            let t = g.floats(&[0.0, 0.5, 0.5], "SCALAR");
            g.json["animations"][0]["samplers"][0]["input"] = json!(t);
        }), &["keyframe times must increase"]),
        ("joint.glb", Box::new(|g| { g.json["skins"][0]["joints"] = json!([3]); }), &["skins[0]", "names joint 1", "has 1 joints"]),
        ("volume.glb", Box::new(|g| g.json["materials"][0]["extensions"]["KHR_materials_volume"]["attenuationDistance"] = json!(0.0)), &["materials[0] \"Glass\"", "attenuationDistance"]),
        ("attenuation.glb", Box::new(|g| g.json["materials"][0]["extensions"]["KHR_materials_volume"]["attenuationColor"] = json!([0.0, 0.5, 0.5])), &["materials[0] \"Glass\"", "attenuationColor", "(0, 1]"]),
        ("extras.glb", Box::new(|g| g.json["scenes"][0]["extras"]["refrakt"]["samples"] = json!(0)), &["scenes[0].extras.refrakt.samples must be from 1 to 256"]),
        // Found by the property test below: the gltf crate's image reader unwraps these.
        ("mime.glb", Box::new(|g| { g.json["images"][0].as_object_mut().unwrap().remove("mimeType"); }), &["images[0] has a bufferView but no mimeType"]),
        ("channel-node.glb", Box::new(|g| g.json["animations"][0]["channels"][0]["target"]["node"] = json!(999)), &["animations[0].channels[0].target.node: index out of range"]),
        ("channel-path.glb", Box::new(|g| g.json["animations"][0]["channels"][0]["target"]["path"] = json!("pointer")), &["animations[0].channels[0].target.path is not one of"]),
        ("no-image-data.glb", Box::new(|g| { g.json["images"][0].as_object_mut().unwrap().remove("bufferView"); }), &["images[0] has neither a uri nor a bufferView"]),
    ];
    for (name, damage, needles) in cases {
        let mut g = sample_scene();
        damage(&mut g);
        assert_refused(&g.write_glb(&dir.path().join(name)), needles);
    }
    // A chain of 1200 nodes: deeper than refrakt walks (a stack overflow otherwise).
    let mut g = GltfBuilder::new();
    for i in 0..1200usize {
        let mut node = json!({ "name": format!("n{i}") });
        if i + 1 < 1200 {
            node["children"] = json!([i + 1]);
        }
        g.push("nodes", node);
    }
    g.scene("Deep", &[0]);
    assert_refused(&g.write_glb(&dir.path().join("deep.glb")), &["1001 levels deep", "up to 1000 levels"]);
    let p = write(dir.path(), "json.glb", br#"{"asset": {"version": "2.0"}}"#);
    assert_refused(&p, &["not a binary glTF file"]);
    let p = write(dir.path(), "broken.gltf", br#"{"asset": {"version": "2.0"}, "nodes": [ {"name": 1} ]"#);
    assert_refused(&p, &["cannot be read"]);
}

/// Imports `bytes` as `name`, then plays, deforms and evaluates it: any outcome but a panic.
fn import_bytes(dir: &Path, name: &str, bytes: &[u8]) {
    let path = write(dir, name, bytes);
    let access = FileAccess::new(dir, &[]).unwrap();
    if let Ok(mut import) = refrakt::gltf::import(&path, name, &access, &ImportOptions::default()) {
        let mut scene = refrakt::scene::Scene { roots: std::mem::take(&mut import.roots), ..Default::default() };
        import.settings.apply(&mut scene);
        for t in [0.0, 0.3, 2.0] {
            import.player.pose(t);
            import.player.deform(&scene);
            let _ = evaluate(&scene, t, &EvalOptions { resolution: Some(16), ..Default::default() });
        }
    }
}

/// Digits of the JSON text replaced: indices, counts and offsets move, the JSON stays JSON.
fn mutate_numbers(text: &str, picks: &[(usize, u32)]) -> String {
    let mut bytes = text.as_bytes().to_vec();
    let digits: Vec<usize> = bytes.iter().enumerate().filter(|(_, b)| b.is_ascii_digit()).map(|(i, _)| i).collect();
    for &(i, d) in picks {
        if !digits.is_empty() {
            bytes[digits[i % digits.len()]] = b'0' + (d % 10) as u8;
        }
    }
    String::from_utf8(bytes).unwrap()
}

proptest! {
    #![proptest_config(fuzz_config())]

    #[test]
    fn mutated_glb_files_never_panic(ms in proptest::collection::vec(mutation(), 1..6)) {
        let dir = tempfile::tempdir().unwrap();
        import_bytes(dir.path(), "m.glb", &mutate(sample_scene().glb_bytes(), &ms));
    }

    #[test]
    fn mutated_gltf_json_never_panics(picks in proptest::collection::vec((any::<usize>(), 0..10u32), 1..5)) {
        let dir = tempfile::tempdir().unwrap();
        let g = sample_scene();
        g.write_embedded(&dir.path().join("m.gltf"));
        let text = std::fs::read_to_string(dir.path().join("m.gltf")).unwrap();
        import_bytes(dir.path(), "m.gltf", mutate_numbers(&text, &picks).as_bytes());
    }

    #[test]
    fn mutated_binary_chunks_never_panic(ms in proptest::collection::vec(mutation(), 1..8)) {
        // Damage only the BIN chunk (the JSON stays valid), so accessors read garbage.
        let dir = tempfile::tempdir().unwrap();
        let g = sample_scene();
        let mut json = g.json.clone();
        json["buffers"] = json!([{ "byteLength": g.bin.len() }]);
        import_bytes(dir.path(), "b.glb", &glb(&serde_json::to_vec(&json).unwrap(), &mutate(g.bin.clone(), &ms)));
    }
}
