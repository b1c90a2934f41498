//! `refrakt dump`: the evaluated scene per frame as JSON lines, for Lua and glTF scenes,
//! checked against values worked out here from the scene's own numbers.

mod common;

use std::path::Path;
use std::process::Command;

use common::gltf_builder::sample_scene;
use common::write_script;
use glam::{Mat4, Quat, Vec3};
use serde_json::Value;

fn dump(args: &[&str]) -> Result<Vec<Value>, String> {
    let out = Command::new(env!("CARGO_BIN_EXE_refrakt")).arg("dump").args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    if !out.status.success() {
        assert!(!err.contains("panicked") && !err.contains("internal error"), "{err}");
        return Err(err);
    }
    Ok(String::from_utf8_lossy(&out.stdout).lines().map(|l| serde_json::from_str(l).unwrap()).collect())
}

fn v3(v: &Value) -> Vec3 {
    Vec3::new(v[0].as_f64().unwrap() as f32, v[1].as_f64().unwrap() as f32, v[2].as_f64().unwrap() as f32)
}

fn mat(v: &Value) -> Mat4 {
    let a: Vec<f32> = v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap() as f32).collect();
    Mat4::from_cols_slice(&a)
}

fn node<'a>(doc: &'a Value, name: &str) -> &'a Value {
    doc["nodes"].as_array().unwrap().iter().find(|n| n["name"] == name).unwrap_or_else(|| panic!("no node {name}"))
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

const SCENE: &str = r#"local r = require("refrakt")
local scene = r.scene{
  camera = r.camera{ position = {1, 2, 3}, target = {0, 0.5, 0}, fov = 40, size = {320, 200} },
  photons = 1234, samples = 2, volume = { resolution = 32 },
}
local rig = scene:add(r.node{ name = "rig", translation = {0, 1, 0}, scale = {2, 1, 1} })
local glass = r.glass{ ior = 1.33, absorption = {0.1, 0.2, 0.3} }
rig:add(r.node{ name = "ball", translation = {0.25, 0, 0}, shape = r.sphere{ radius = 0.2 }, material = glass })
scene:add(r.node{ name = "floor", shape = r.plane{ size = {4, 4} }, material = r.diffuse{ color = {0.5, 0.6, 0.7} } })
scene:add(r.node{ name = "key", translation = {0, 3, 0}, light = r.spot{ target = {0, 0, 0}, angle = 20, blend = 0.25, intensity = 600, color = {1, 0.5, 0.25} } })
scene:add(r.node{ name = "sky", light = r.sun{ direction = {0, -1, -1}, intensity = 2 } })
function update(scene, t)
  rig.translation = {t, 1, 0}
end
return scene
"#;

#[test]
fn a_lua_scene_dumps_frames_nodes_camera_lights_and_materials() {
    let (_dir, path) = write_script("scene.lua", SCENE);
    let docs = dump(&[path.to_str().unwrap(), "--frames", "2..4", "--fps", "10", "--size", "32x16"]).unwrap();
    assert_eq!(docs.len(), 3);
    for (doc, k) in docs.iter().zip(2..) {
        let t = k as f32 / 10.0;
        assert_eq!(doc["frame"], k);
        assert!((doc["time"].as_f64().unwrap() - k as f64 / 10.0).abs() < 1e-12);
        let rig = Mat4::from_scale_rotation_translation(Vec3::new(2.0, 1.0, 1.0), Quat::IDENTITY, Vec3::new(t, 1.0, 0.0));
        let want = rig * Mat4::from_translation(Vec3::new(0.25, 0.0, 0.0));
        assert!(mat(&node(doc, "ball")["world"]).abs_diff_eq(want, 1e-6), "ball at frame {k}");
        let c = &doc["camera"];
        let forward = (Vec3::new(0.0, 0.5, 0.0) - Vec3::new(1.0, 2.0, 3.0)).normalize();
        assert!(close(v3(&c["position"]), Vec3::new(1.0, 2.0, 3.0)) && close(v3(&c["forward"]), forward));
        assert!(v3(&c["up"]).dot(forward).abs() < 1e-6 && v3(&c["up"]).y > 0.0);
        assert!((c["yfov"].as_f64().unwrap() - 40f64.to_radians()).abs() < 1e-6);
        assert_eq!(c["size"], serde_json::json!([32, 16]));
        let key = &doc["lights"][0];
        assert_eq!((key["node"].as_str(), key["kind"].as_str(), key["unit"].as_str()), (Some("key"), Some("spot"), Some("cd")));
        assert!(close(v3(&key["radiant"]), Vec3::new(1.0, 0.5, 0.25) * 600.0 / 683.0));
        assert!((key["outer_cone_angle"].as_f64().unwrap() - 20f64.to_radians()).abs() < 1e-6);
        assert!((key["inner_cone_angle"].as_f64().unwrap() - 15f64.to_radians()).abs() < 1e-6);
        assert!(close(v3(&key["direction"]), Vec3::NEG_Y) && close(v3(&key["position"]), Vec3::new(0.0, 3.0, 0.0)));
        let sky = &doc["lights"][1];
        assert_eq!((sky["kind"].as_str(), sky["unit"].as_str()), (Some("sun"), Some("lx")));
        assert!(close(v3(&sky["direction"]), Vec3::new(0.0, -1.0, -1.0).normalize()) && close(v3(&sky["radiant"]), Vec3::splat(2.0 / 683.0)));
        let glass = &doc["materials"][node(doc, "ball")["material"].as_u64().unwrap() as usize];
        assert_eq!((glass["kind"].as_str(), glass["ior"].as_f64()), (Some("glass"), Some(1.33)));
        assert!(close(v3(&glass["absorption"]), Vec3::new(0.1, 0.2, 0.3)));
        let floor = &doc["materials"][node(doc, "floor")["material"].as_u64().unwrap() as usize];
        assert!(floor["kind"] == "diffuse" && close(v3(&floor["color"]), Vec3::new(0.5, 0.6, 0.7)));
        assert!(node(doc, "rig")["material"].is_null());
        assert_eq!((doc["photons"].as_u64(), doc["samples"].as_u64()), (Some(1234), Some(2)));
        // The volume box holds the ball (world radius 0.2 · its scale up to 2) and has cubic voxels.
        let (lo, hi) = (v3(&doc["volume"]["min"]), v3(&doc["volume"]["max"]));
        let centre = want.transform_point3(Vec3::ZERO);
        assert!((lo + Vec3::splat(0.2)).cmple(centre).all() && (hi - Vec3::splat(0.2)).cmpge(centre).all(), "{lo} {hi} {centre}");
        let dims = &doc["volume"]["dims"];
        let voxel = doc["volume"]["voxel_size"].as_f64().unwrap() as f32;
        assert!(close((hi - lo) / voxel, Vec3::new(dims[0].as_f64().unwrap() as f32, dims[1].as_f64().unwrap() as f32, dims[2].as_f64().unwrap() as f32)));
    }
}

#[test]
fn a_still_is_the_frame_at_the_same_time() {
    let (_dir, path) = write_script("scene.lua", SCENE);
    let p = path.to_str().unwrap();
    let frames = dump(&[p, "--frames", "3", "--fps", "10"]).unwrap();
    let mut still = dump(&[p, "--time", "0.3"]).unwrap();
    assert!(still[0]["frame"].is_null());
    still[0]["frame"] = frames[0]["frame"].clone();
    assert_eq!(frames[0], still[0]);
}

fn write_sample(dir: &Path) -> String {
    sample_scene().write_glb(&dir.join("sample.glb")).to_string_lossy().to_string()
}

#[test]
fn a_gltf_scene_dumps_its_animation_camera_and_settings() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_sample(dir.path());
    // The sample's "Play" animation moves Gem LINEARly from y 0.5 (t 0) to 0.7 (t 0.5).
    let docs = dump(&[&p, "--frames", "0..6", "--fps", "24"]).unwrap();
    for (k, doc) in docs.iter().enumerate() {
        let t = k as f32 / 24.0;
        let y = if t < 0.5 { 0.5 + 0.2 * t / 0.5 } else { 0.7 - 0.2 * (t - 0.5) / 0.5 };
        assert!(close(mat(&node(doc, "Gem")["world"]).w_axis.truncate(), Vec3::new(0.0, y, 0.0)), "Gem at frame {k}");
    }
    let doc = &docs[0];
    assert_eq!((doc["photons"].as_u64(), doc["samples"].as_u64()), (Some(5000), Some(1)), "the scene's extras");
    assert_eq!(doc["camera"]["size"], serde_json::json!([864, 576]), "aspect 1.5 at 576 rows");
    let gem = &doc["meshes"].as_array().unwrap().iter().find(|m| m["node"] == "Gem").unwrap();
    assert_eq!((gem["vertices"].as_u64(), gem["triangles"].as_u64()), (Some(4), Some(4)));
    // Only "Bob" plays: Gem rests at its node translation, the camera moves.
    let bob = dump(&[&p, "--time", "0.25", "--animation", "Bob"]).unwrap();
    assert!(close(mat(&node(&bob[0], "Gem")["world"]).w_axis.truncate(), Vec3::new(0.0, 0.5, 0.0)));
    let e = dump(&[&p, "--scene", "Elsewhere"]).unwrap_err();
    assert!(e.contains("no scene called \"Elsewhere\"") && e.contains("\"Sample\""), "{e}");
    let e = dump(&[&p, "--camera", "Nope"]).unwrap_err();
    assert!(e.contains("--camera \"Nope\"") && e.contains("\"Camera\""), "{e}");
}

#[test]
fn scene_and_animation_options_are_for_gltf_files() {
    let (_dir, path) = write_script("scene.lua", SCENE);
    let e = dump(&[path.to_str().unwrap(), "--animation", "Walk"]).unwrap_err();
    assert!(e.contains("refrakt.gltf{file = …, scene = …, animation = …}"), "{e}");
}
