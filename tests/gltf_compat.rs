//! Real-world glTF files as refrakt reads them (issue #15): meshopt-compressed geometry,
//! Draco and KTX2 files refused with what to do, KHR_texture_transform, scenes, animations and
//! cameras chosen by index, the default view of a file without a camera, the warning for glass
//! that encloses no volume, one warning per pair of overlapping animations, and no −0 in
//! `refrakt dump`. Every file is made here by the test.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::gltf_builder::{GltfBuilder, glb};
use glam::{Vec2, Vec3, Vec4};
use refrakt::gltf::ImportOptions;
use refrakt::lua::sandbox::FileAccess;
use refrakt::render::GltfScene;
use refrakt::scene::eval::{EvalOptions, evaluate};
use refrakt::scene::{EnvironmentSource, Scene};
use serde_json::{Value, json};

const TETRA: [[f32; 3]; 4] = [[0.0, 0.0, 0.0], [0.3, 0.0, 0.0], [0.0, 0.3, 0.0], [0.0, 0.0, 0.3]];
const TETRA_TRIS: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];

fn load(path: &Path, opts: &ImportOptions) -> anyhow::Result<GltfScene> {
    GltfScene::load(path, &[], opts)
}

/// The import's warnings (`GltfScene::load` logs them; `import` returns them).
fn warnings(path: &Path) -> Vec<String> {
    let access = FileAccess::new(path.parent().unwrap(), &[]).unwrap();
    let name = path.file_name().unwrap().to_string_lossy().to_string();
    let import = refrakt::gltf::import(path, &name, &access, &ImportOptions::default()).unwrap_or_else(|e| panic!("{e:#}"));
    import.warnings.iter().map(ToString::to_string).collect()
}

/// `refrakt dump ARGS…`: (exit code, stdout, stderr).
fn dump(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_refrakt")).arg("dump").args(args).output().unwrap();
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stdout).into(), String::from_utf8_lossy(&out.stderr).into())
}

fn first_receiver_mesh(scene: &Scene) -> std::sync::Arc<refrakt::scene::MeshData> {
    let desc = evaluate(scene, 0.0, &EvalOptions::default()).unwrap();
    desc.receivers[0].mesh.clone()
}

// -------------------------------------------------------------------------------------------
// 1. Compressed files.

/// Appends `bytes` to the builder's binary chunk (4-byte aligned); returns their offset.
fn append(g: &mut GltfBuilder, bytes: &[u8]) -> usize {
    while !g.bin.len().is_multiple_of(4) {
        g.bin.push(0);
    }
    let at = g.bin.len();
    g.bin.extend_from_slice(bytes);
    at
}

/// A bufferView on the fallback buffer 1 whose bytes are `compressed` in buffer 0.
fn compressed_view(g: &mut GltfBuilder, ext: &str, compressed: &[u8], count: usize, stride: usize, mode: &str, filter: &str) -> usize {
    let at = append(g, compressed);
    let mut e = json!({ "buffer": 0, "byteOffset": at, "byteLength": compressed.len(), "byteStride": stride, "count": count, "mode": mode });
    if filter != "NONE" {
        e["filter"] = json!(filter);
    }
    let mut view = json!({ "buffer": 1, "byteLength": count * stride, "extensions": { ext: e } });
    if mode == "ATTRIBUTES" {
        view["byteStride"] = json!(stride);
    }
    g.push("bufferViews", view)
}

/// A tetrahedron whose positions (EXPONENTIAL-filtered when `filtered`) and indices are
/// meshopt-compressed, as gltfpack -cc writes it: compressed data in the BIN chunk, the views on
/// a fallback buffer without data.
fn meshopt_tetra(ext: &str, filtered: bool) -> (GltfBuilder, Vec<Vec3>) {
    let mut g = GltfBuilder::new();
    g.uses(ext, true);
    let (positions, filter) = if filtered {
        let encoded = meshopt::encode_filter_exp::<3>(&TETRA, 15, meshopt::EncodeExpMode::Separate);
        // What the file stores is what its reader gets back: the filtered values.
        let mut decoded = encoded.clone();
        meshopt::decode_filter_exp(&mut decoded);
        let values: Vec<Vec3> = decoded.iter().map(|v| Vec3::from_array(v.map(f32::from_bits))).collect();
        (meshopt::encode_vertex_buffer(&encoded).unwrap(), (values, "EXPONENTIAL"))
    } else {
        (meshopt::encode_vertex_buffer(&TETRA).unwrap(), (TETRA.iter().map(|p| Vec3::from_array(*p)).collect(), "NONE"))
    };
    let pos_view = compressed_view(&mut g, ext, &positions, 4, 12, "ATTRIBUTES", filter.1);
    let flat: Vec<u32> = TETRA_TRIS.iter().flatten().copied().collect();
    let indices = meshopt::encode_index_buffer(&flat, 4).unwrap();
    let idx_view = compressed_view(&mut g, ext, &indices, 12, 2, "TRIANGLES", "NONE");
    let pos = g.push("accessors", json!({ "bufferView": pos_view, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [0.3, 0.3, 0.3] }));
    let idx = g.push("accessors", json!({ "bufferView": idx_view, "componentType": 5123, "count": 12, "type": "SCALAR" }));
    let mesh = g.push("meshes", json!({ "primitives": [{ "attributes": { "POSITION": pos }, "indices": idx }] }));
    let n = g.push("nodes", json!({ "name": "Gem", "mesh": mesh }));
    g.scene("S", &[n]);
    (g, filter.0)
}

/// The .glb with the fallback buffer (declared, no bytes) after the BIN chunk's buffer.
fn write_with_fallback(g: &GltfBuilder, ext: &str, path: &Path) -> PathBuf {
    let mut j = g.json.clone();
    let fallback: usize = j["bufferViews"].as_array().unwrap().iter().map(|v| v["byteLength"].as_u64().unwrap() as usize).sum();
    j["buffers"] = json!([{ "byteLength": g.bin.len() }, { "byteLength": fallback, "extensions": { ext: { "fallback": true } } }]);
    std::fs::write(path, glb(&serde_json::to_vec(&j).unwrap(), &g.bin)).unwrap();
    path.to_path_buf()
}

#[test]
fn meshopt_compressed_geometry_imports_as_the_plain_file_would() {
    let dir = tempfile::tempdir().unwrap();
    for ext in ["EXT_meshopt_compression", "KHR_meshopt_compression"] {
        for filtered in [false, true] {
            let (g, want) = meshopt_tetra(ext, filtered);
            let path = write_with_fallback(&g, ext, &dir.path().join(format!("{ext}-{filtered}.glb")));
            let s = load(&path, &ImportOptions::default()).unwrap_or_else(|e| panic!("{ext}: {e:#}"));
            let mesh = first_receiver_mesh(&s.scene);
            assert_eq!(mesh.positions, want, "{ext}, filtered {filtered}");
            // The index codec may rotate a triangle's corners (keeping its winding).
            let rotated = |t: &[u32; 3]| {
                let k = (0..3).min_by_key(|&k| t[k]).unwrap();
                [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
            };
            assert_eq!(mesh.triangles.iter().map(rotated).collect::<Vec<_>>(), TETRA_TRIS.iter().map(rotated).collect::<Vec<_>>(), "{ext}");
            if filtered {
                assert!(want.iter().zip(TETRA).all(|(a, b)| (*a - Vec3::from_array(b)).length() < 1e-4), "15-bit mantissas: {want:?}");
            }
            assert!(!warnings(&path).iter().any(|w| w.contains("meshopt")), "a supported extension is not warned about");
        }
    }
}

#[test]
fn damaged_meshopt_data_is_refused_with_the_view_named() {
    let dir = tempfile::tempdir().unwrap();
    let ext = "EXT_meshopt_compression";
    type Damage = fn(&mut GltfBuilder);
    let cases: [(&str, Damage, &[&str]); 3] = [
        ("short.glb", |g| g.json["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["byteLength"] = json!(5), &["bufferViews[0].extensions.EXT_meshopt_compression", "cannot be decoded"]),
        ("huge.glb", |g| {
            g.json["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["count"] = json!(1u64 << 40);
            g.json["bufferViews"][0]["byteLength"] = json!(12u64 << 40);
        }, &["bufferViews[0]", "exceed the 1024 MiB"]),
        ("stride.glb", |g| g.json["bufferViews"][1]["extensions"]["EXT_meshopt_compression"]["count"] = json!(10), &["bufferViews[1]", "TRIANGLES", "multiple of 3"]),
    ];
    for (name, damage, needles) in cases {
        let (mut g, _) = meshopt_tetra(ext, false);
        damage(&mut g);
        let path = write_with_fallback(&g, ext, &dir.path().join(name));
        let (code, _, err) = dump(&[path.to_str().unwrap()]);
        assert_ne!(code, 0, "{name}");
        assert!(!err.contains("panicked") && err.trim().lines().count() == 1, "{name}: one paragraph, no panic: {err}");
        for n in std::iter::once(&name).chain(needles) {
            assert!(err.contains(n), "{name}: stderr should contain {n:?}: {err}");
        }
    }
}

#[test]
fn draco_and_ktx2_files_are_refused_with_what_to_do() {
    let dir = tempfile::tempdir().unwrap();
    // As real Draco files have them: accessors without a bufferView, the data in the extension.
    let mut draco = GltfBuilder::new();
    draco.uses("KHR_draco_mesh_compression", true);
    let view = draco.view(&[0u8; 16]);
    draco.push("accessors", json!({ "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 1] }));
    draco.push("meshes", json!({ "primitives": [{ "attributes": { "POSITION": 0 },
        "extensions": { "KHR_draco_mesh_compression": { "bufferView": view, "attributes": { "POSITION": 0 } } } }] }));
    let n = draco.push("nodes", json!({ "mesh": 0 }));
    draco.scene("S", &[n]);
    // A KTX2 texture: its image only in the extension, no `source`.
    let mut ktx = GltfBuilder::new();
    ktx.uses("KHR_texture_basisu", true);
    let view = ktx.view(b"\xABKTX 20\xBB\r\n\x1A\n");
    ktx.push("images", json!({ "bufferView": view, "mimeType": "image/ktx2" }));
    ktx.push("textures", json!({ "extensions": { "KHR_texture_basisu": { "source": 0 } } }));
    ktx.push("materials", json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }));
    let mesh = ktx.mesh(&TETRA, &TETRA_TRIS, Some(0));
    let n = ktx.push("nodes", json!({ "mesh": mesh }));
    ktx.scene("S", &[n]);
    for (g, name, needles) in [
        (draco, "draco.glb", ["requires the glTF extension KHR_draco_mesh_compression", "gltf-transform copy in.glb out.glb"]),
        (ktx, "ktx2.glb", ["requires the glTF extension KHR_texture_basisu", "gltf-transform ktxdecompress in.glb out.glb"]),
    ] {
        let path = g.write_glb(&dir.path().join(name));
        let (code, _, err) = dump(&[path.to_str().unwrap()]);
        assert_ne!(code, 0);
        assert!(!err.contains("is invalid") && err.trim().lines().count() == 1, "the extension, not a validation error: {err}");
        for n in needles {
            assert!(err.contains(n), "{name}: {n:?} in {err}");
        }
    }
}

// -------------------------------------------------------------------------------------------
// 2. KHR_texture_transform.

#[test]
fn texture_transforms_apply_to_the_texcoord_set_they_name() {
    let mut g = GltfBuilder::new();
    g.uses("KHR_texture_transform", true);
    g.uses("KHR_mesh_quantization", true);
    let mut png = Vec::new();
    image::DynamicImage::ImageRgba8(image::RgbaImage::from_pixel(2, 2, image::Rgba([200, 100, 50, 255])))
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let png_view = g.view(&png);
    g.push("images", json!({ "bufferView": png_view, "mimeType": "image/png" }));
    g.push("textures", json!({ "source": 0 }));
    let (offset, rotation, scale) = ([0.125f32, -0.5], 0.7f32, [2.0f32, 0.25]);
    g.push("materials", json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0, "texCoord": 0,
        "extensions": { "KHR_texture_transform": { "offset": offset, "rotation": rotation, "scale": scale, "texCoord": 1 } } } } }));
    let pos = g.floats(&TETRA.concat(), "VEC3");
    let idx = g.uints(&TETRA_TRIS.concat(), "SCALAR", 5125);
    // TEXCOORD_0 is a decoy; TEXCOORD_1 is quantized to normalized u16, as gltfpack writes it.
    let uv0 = g.floats(&[9.0; 8], "VEC2");
    let quantized: [u16; 8] = [0, 0, 65535, 0, 0, 65535, 32768, 16384];
    let uv1_view = g.view(&quantized.iter().flat_map(|q| q.to_le_bytes()).collect::<Vec<_>>());
    let uv1 = g.push("accessors", json!({ "bufferView": uv1_view, "componentType": 5123, "normalized": true, "count": 4, "type": "VEC2" }));
    g.push("meshes", json!({ "primitives": [{ "attributes": { "POSITION": pos, "TEXCOORD_0": uv0, "TEXCOORD_1": uv1 }, "indices": idx, "material": 0 }] }));
    let n = g.push("nodes", json!({ "mesh": 0 }));
    g.scene("S", &[n]);
    let dir = tempfile::tempdir().unwrap();
    let path = g.write_glb(&dir.path().join("transform.glb"));
    let s = load(&path, &ImportOptions::default()).unwrap();
    let uvs = first_receiver_mesh(&s.scene).uvs.clone().expect("texture coordinates");
    // The extension's matrix, written out: T · R · S with R = [[cos, sin], [−sin, cos]].
    let (sin, cos) = rotation.sin_cos();
    for (k, uv) in uvs.iter().enumerate() {
        let q = Vec2::new(quantized[2 * k] as f32, quantized[2 * k + 1] as f32) / 65535.0;
        let scaled = q * Vec2::from(scale);
        let want = Vec2::new(cos * scaled.x + sin * scaled.y, -sin * scaled.x + cos * scaled.y) + Vec2::from(offset);
        assert!((*uv - want).length() < 1e-6, "vertex {k}: {uv} vs {want}");
    }
    assert!(!warnings(&path).iter().any(|w| w.contains("KHR_texture_transform")));
}

// -------------------------------------------------------------------------------------------
// 3. Choosing by index.

/// Two unnamed scenes (a mover in the second), two unnamed animations, two unnamed cameras.
fn unnamed_everything() -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let mesh = g.mesh(&TETRA, &TETRA_TRIS, None);
    let a = g.push("nodes", json!({ "name": "in-first", "mesh": mesh }));
    let b = g.push("nodes", json!({ "name": "in-second", "mesh": mesh }));
    g.push("cameras", json!({ "type": "perspective", "perspective": { "yfov": 0.5, "znear": 0.1 } }));
    let c0 = g.push("nodes", json!({ "camera": 0, "translation": [0.0, 0.0, 5.0] }));
    let c1 = g.push("nodes", json!({ "camera": 0, "translation": [1.0, 2.0, 7.0] }));
    g.push("scenes", json!({ "nodes": [a, c0, c1] }));
    g.push("scenes", json!({ "nodes": [b, c0, c1] }));
    let times = g.floats(&[0.0, 1.0], "SCALAR");
    for dx in [1.0f32, -1.0] {
        let values = g.floats(&[0.0, 0.0, 0.0, dx, 0.0, 0.0], "VEC3");
        g.push("animations", json!({ "samplers": [{ "input": times, "output": values }], "channels": [{ "sampler": 0, "target": { "node": b, "path": "translation" } }] }));
    }
    g
}

#[test]
fn unnamed_scenes_animations_and_cameras_are_chosen_by_index_and_dump_lists_them() {
    let dir = tempfile::tempdir().unwrap();
    let path = unnamed_everything().write_glb(&dir.path().join("unnamed.glb"));
    let p = path.to_str().unwrap();
    let (code, out, err) = dump(&[p, "--scene", "1", "--animation", "1", "--camera", "1", "--time", "1"]);
    assert_eq!(code, 0, "{err}");
    let doc: Value = serde_json::from_str(out.trim()).unwrap();
    let names: Vec<&str> = doc["nodes"].as_array().unwrap().iter().map(|n| n["name"].as_str().unwrap()).collect();
    assert!(names.contains(&"in-second") && !names.contains(&"in-first"), "scene 1: {names:?}");
    let mover = doc["nodes"].as_array().unwrap().iter().find(|n| n["name"] == "in-second").unwrap();
    assert_eq!(mover["world"][12], json!(-1.0), "animation 1 moves it to x = −1 at t = 1");
    assert_eq!(doc["camera"]["position"], json!([1.0, 2.0, 7.0]), "camera 1");
    assert_eq!(doc["cameras"], json!([{ "index": 0, "node": "" }, { "index": 1, "node": "" }]));
    assert_eq!(doc["gltf"]["scenes"], json!([{ "index": 0, "name": null, "chosen": false }, { "index": 1, "name": null, "chosen": true }]));
    assert_eq!(doc["gltf"]["animations"][1], json!({ "index": 1, "name": null, "chosen": true }));
    assert_eq!(doc["gltf"]["animations"][0]["chosen"], json!(false));
    // Out of range: the message lists what there is.
    let (code, _, err) = dump(&[p, "--scene", "2"]);
    assert_ne!(code, 0);
    assert!(err.contains("no scene called \"2\" and no scene of that index (scenes: 0 (unnamed), 1 (unnamed))"), "{err}");
    let (_, _, err) = dump(&[p, "--camera", "5"]);
    assert!(err.contains("cameras: 0 (unnamed), 1 (unnamed)"), "{err}");
    // And from Lua, an index as a number.
    let script = "local r = require(\"refrakt\")\nlocal scene = r.scene{}\nscene:add(r.gltf{ file = \"unnamed.glb\", scene = 1, animation = 0 })\nreturn scene\n";
    std::fs::write(dir.path().join("scene.lua"), script).unwrap();
    let host = common::load(&dir.path().join("scene.lua"));
    host.update(1.0).unwrap();
    let node = host.scene().borrow().find("in-second").expect("scene 1 imported");
    assert_eq!(node.borrow().transform.translation, Vec3::new(1.0, 0.0, 0.0), "animation 0");
}

// -------------------------------------------------------------------------------------------
// 4. Files without a camera.

/// A tetrahedron that an animation carries from x = 0 to x = 4 and up to y = 2 over 2 s.
fn camera_less(environment: bool) -> GltfBuilder {
    let mut g = GltfBuilder::new();
    let mesh = g.mesh(&TETRA, &TETRA_TRIS, None);
    let n = g.push("nodes", json!({ "name": "Mover", "mesh": mesh }));
    let still = g.push("nodes", json!({ "name": "Still", "mesh": mesh, "translation": [-1.0, 0.0, 0.0] }));
    let times = g.floats(&[0.0, 1.0, 2.0], "SCALAR");
    let values = g.floats(&[0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 4.0, 2.0, 0.0], "VEC3");
    g.push("animations", json!({ "name": "Go", "samplers": [{ "input": times, "output": values }], "channels": [{ "sampler": 0, "target": { "node": n, "path": "translation" } }] }));
    let s = g.scene("S", &[n, still]);
    if environment {
        g.json["scenes"][s]["extras"] = json!({ "refrakt": { "environment": { "color": [0.1, 0.2, 0.3] } } });
    }
    g
}

/// Where world point `p` lands in the frame's image, in [−1, 1]² when inside it.
fn ndc(cam: &refrakt::frame::CameraDesc, p: Vec3) -> Vec2 {
    let local = cam.orientation.inverse() * (p - cam.position);
    let depth = -local.z;
    assert!(depth > 0.0, "{p} is behind the camera");
    let half_y = (0.5 * cam.fov_y).tan();
    let half_x = half_y * cam.width as f32 / cam.height as f32;
    Vec2::new(local.x / depth / half_x, local.y / depth / half_y)
}

#[test]
fn a_file_without_a_camera_is_framed_over_its_whole_animation_in_a_studio() {
    let dir = tempfile::tempdir().unwrap();
    let path = camera_less(false).write_glb(&dir.path().join("nocam.glb"));
    for size in [None, Some((200, 400))] {
        let mut s = load(&path, &ImportOptions { size, ..Default::default() }).unwrap();
        assert!(s.scene.camera.is_some(), "a default camera");
        let mut widest = 0.0f32;
        for t in [0.0, 0.5, 1.0, 1.5, 2.0] {
            s.player.pose(t);
            s.player.deform(&s.scene);
            let desc = evaluate(&s.scene, t, &EvalOptions { size, ..Default::default() }).unwrap();
            for r in &desc.receivers {
                for p in &r.mesh.positions {
                    let q = ndc(&desc.camera, r.world.transform_point3(*p));
                    assert!(q.x.abs() <= 1.0 && q.y.abs() <= 1.0, "t = {t}, size {size:?}: {p} of {} lands at {q}", r.name);
                    widest = widest.max(q.x.abs()).max(q.y.abs());
                }
            }
        }
        assert!(widest > 0.3, "framed, not lost in the distance: the scene spans {widest} of the half-image");
        assert!(matches!(&s.scene.environment.borrow().source, EnvironmentSource::Preset { name, .. } if name == "studio"));
    }
    // The log says so.
    let (code, _, err) = dump(&[path.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("nocam.glb: the file has no camera, so a default camera") && err.contains("\"studio\" environment"), "{err}");
    // A file's own environment stays; a file's own camera means no default view at all.
    let own_env = camera_less(true).write_glb(&dir.path().join("env.glb"));
    let s = load(&own_env, &ImportOptions::default()).unwrap();
    assert!(s.scene.camera.is_some() && matches!(s.scene.environment.borrow().source, EnvironmentSource::Color(c) if c == Vec3::new(0.1, 0.2, 0.3)));
    let mut with_camera = camera_less(false);
    with_camera.push("cameras", json!({ "type": "perspective", "perspective": { "yfov": 0.5, "znear": 0.1 } }));
    let c = with_camera.push("nodes", json!({ "camera": 0, "translation": [0.0, 0.0, 9.0] }));
    with_camera.json["scenes"][0]["nodes"].as_array_mut().unwrap().push(json!(c));
    let cam = with_camera.write_glb(&dir.path().join("cam.glb"));
    let s = load(&cam, &ImportOptions::default()).unwrap();
    assert!(s.scene.camera.is_none(), "the file's own camera, no default view");
    // Its own camera but no environment: lit by the studio preset too, as viewers do, said once.
    assert!(matches!(&s.scene.environment.borrow().source, EnvironmentSource::Preset { name, .. } if name == "studio"));
    let environment = |args: &[&str]| {
        let (code, out, err) = dump(args);
        assert_eq!(code, 0, "{err}");
        let doc: Value = serde_json::from_str(out.lines().next().unwrap()).unwrap();
        (doc["environment"].clone(), err)
    };
    let (env, err) = environment(&[cam.to_str().unwrap()]);
    assert_eq!((env["kind"].as_str(), env["source"].as_str()), (Some("preset"), Some("studio")));
    assert_eq!(err.matches("sets no environment").count(), 1, "{err}");
    // --environment PRESET|FILE[:INTENSITY] replaces it, and the file's own, and a script's.
    let (env, err) = environment(&[cam.to_str().unwrap(), "--environment", "sky:2"]);
    assert_eq!((env["source"].as_str(), env["intensity"].as_f64()), (Some("sky"), Some(2.0)));
    assert!(!err.contains("sets no environment"), "{err}");
    let (env, _) = environment(&[own_env.to_str().unwrap(), "--environment", "checker"]);
    assert_eq!((env["source"].as_str(), env["intensity"].as_f64()), (Some("checker"), Some(1.0)));
    let script = dir.path().join("s.lua");
    std::fs::write(&script, "local r = require(\"refrakt\")\nreturn r.scene{ environment = r.environment{ color = {1, 0, 0} } }\n").unwrap();
    let (env, _) = environment(&[script.to_str().unwrap(), "--environment", "studio:0.5"]);
    assert_eq!((env["source"].as_str(), env["intensity"].as_f64()), (Some("studio"), Some(0.5)));
    for (bad, says) in [("nope", "neither a preset (studio, sky, sunny, checker) nor an .exr or .hdr file"), ("sky:-1", "must be a number ≥ 0")] {
        let (code, _, err) = dump(&[cam.to_str().unwrap(), "--environment", bad]);
        assert!(code != 0 && err.contains(says), "--environment {bad}: {err}");
    }
    // And the renders follow: the file lit by the studio preset; at half its intensity every
    // pixel half as bright (the environment is the scene's only light); the checker another picture.
    let beauty = |extra: &[&str]| {
        let out = dir.path().join(format!("render{}", extra.len() + extra.first().map_or(0, |e| e.len())));
        let mut args = vec!["render", cam.to_str().unwrap(), "--out", out.to_str().unwrap(), "--format", "exr", "--size", "24x16", "--volume", "16", "--samples", "1", "--photons", "0", "--progress", "quiet"];
        args.extend_from_slice(extra);
        let done = Command::new(env!("CARGO_BIN_EXE_refrakt")).args(&args).output().unwrap();
        assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));
        let image = refrakt::output::exr::read(&out.join("cam.exr")).unwrap();
        let c = image.layers[0].channels.len();
        image.layers[0].data.chunks(c).flat_map(|p| p[..3].to_vec()).collect::<Vec<f32>>()
    };
    let (studio, half, checker) = (beauty(&[]), beauty(&["--environment", "studio:0.5"]), beauty(&["--environment", "checker"]));
    let brightest = studio.iter().cloned().fold(0.0, f32::max);
    assert!(brightest > 0.0, "the studio lights the file");
    let worst = studio.iter().zip(&half).map(|(a, b)| (0.5 * a - b).abs()).fold(0.0, f32::max);
    assert!(worst <= 1e-3 * brightest, "studio:0.5 is not half the studio's light: off by {worst} of {brightest}");
    let changed = studio.iter().zip(&checker).filter(|(a, b)| (*a - *b).abs() > 0.01 * brightest).count();
    assert!(changed > studio.len() / 4, "--environment checker changed only {changed} of {} values", studio.len());
}

// -------------------------------------------------------------------------------------------
// 5. Thin-walled and volumetric glass.

/// Transmission without KHR_materials_volume is thin-walled (the extension's definition): a pane
/// made of one sheet renders as a sheet, without a word; a closed solid with such a material is
/// named in a warning (it renders as a thin shell); with a thickness, the mesh decides.
#[test]
fn thin_walled_glass_is_a_sheet_and_a_solid_with_it_is_named_in_a_warning() {
    let mut g = GltfBuilder::new();
    g.uses("KHR_materials_transmission", false);
    g.uses("KHR_materials_volume", false);
    let thin = g.push(
        "materials",
        json!({ "name": "Pane", "pbrMetallicRoughness": { "metallicFactor": 0.0, "roughnessFactor": 0.25 }, "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1.0 } } }),
    );
    let thick = g.push(
        "materials",
        json!({ "name": "Solid", "pbrMetallicRoughness": { "metallicFactor": 0.0 }, "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1.0 }, "KHR_materials_volume": { "thicknessFactor": 0.1 } } }),
    );
    let pane = g.mesh(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]], &[[0, 1, 2], [0, 2, 3]], Some(thin));
    let shell = g.mesh(&TETRA, &TETRA_TRIS, Some(thin));
    g.json["meshes"][shell]["name"] = json!("ShellMesh");
    let solid = g.mesh(&TETRA, &TETRA_TRIS, Some(thick));
    let nodes: Vec<usize> = [("Window", pane), ("Window2", pane), ("Bubble", shell), ("Gem", solid)]
        .iter()
        .map(|(name, mesh)| g.push("nodes", json!({ "name": name, "mesh": mesh })))
        .collect();
    g.scene("S", &nodes);
    let dir = tempfile::tempdir().unwrap();
    let path = g.write_glb(&dir.path().join("window.glb"));
    let w = warnings(&path);
    let shells: Vec<&String> = w.iter().filter(|w| w.contains("thin-walled")).collect();
    assert_eq!(shells.len(), 1, "the closed thin-walled solid only, once: {w:?}");
    for needle in ["window.glb: meshes[1] \"ShellMesh\" primitives[0] (on nodes[2] \"Bubble\")", "thin shell", "thicknessFactor > 0"] {
        assert!(shells[0].contains(needle), "{needle:?} in {}", shells[0]);
    }
    let s = load(&path, &ImportOptions::default()).unwrap();
    let desc = evaluate(&s.scene, 0.0, &EvalOptions::default()).unwrap();
    let mesh = |name: &str| desc.meshes.iter().find(|m| m.name == name).unwrap_or_else(|| panic!("{name} in {:?}", desc.meshes));
    let (window, bubble, gem) = (mesh("Window"), mesh("Bubble"), mesh("Gem"));
    assert_eq!((window.glass.thin, window.thin, window.sharp, window.glass.roughness), (Some(true), true, true, 0.25));
    assert!(bubble.thin && bubble.sharp);
    assert_eq!((gem.glass.thin, gem.thin, gem.sharp, gem.glass.roughness), (None, false, true, 1.0), "a solid; glTF's default roughness is 1");
    assert!(desc.warnings().iter().all(|w| !w.contains("glass mesh")), "nothing was guessed: {:?}", desc.warnings());
}

// -------------------------------------------------------------------------------------------
// 6. Quieter warnings, cleaner dump.

#[test]
fn overlapping_animations_warn_once_per_pair() {
    let mut g = GltfBuilder::new();
    let nodes: Vec<usize> = (0..5).map(|i| g.push("nodes", json!({ "name": format!("bone{i}") }))).collect();
    let times = g.floats(&[0.0, 1.0], "SCALAR");
    for name in ["Walk", "Run", "Survey"] {
        let t = g.floats(&[0.0; 6], "VEC3");
        let r = g.floats(&Vec4::W.to_array().repeat(2), "VEC4");
        let channels: Vec<Value> = nodes
            .iter()
            .flat_map(|&n| [json!({ "sampler": 0, "target": { "node": n, "path": "translation" } }), json!({ "sampler": 1, "target": { "node": n, "path": "rotation" } })])
            .collect();
        g.push("animations", json!({ "name": name, "samplers": [{ "input": times, "output": t }, { "input": times, "output": r }], "channels": channels }));
    }
    g.scene("S", &nodes);
    let dir = tempfile::tempdir().unwrap();
    let w = warnings(&g.write_glb(&dir.path().join("fox.glb")));
    let overlaps: Vec<&String> = w.iter().filter(|w| w.contains("both drive")).collect();
    assert_eq!(overlaps.len(), 2, "{overlaps:#?}");
    assert!(overlaps[0].contains("\"Walk\" and \"Run\" both drive the translation of nodes[0] and 9 more properties"), "{}", overlaps[0]);
    assert!(overlaps[1].contains("\"Run\" and \"Survey\""), "{}", overlaps[1]);
}

#[test]
fn dump_prints_zero_not_negative_zero() {
    let mut g = GltfBuilder::new();
    g.uses("KHR_materials_transmission", false);
    g.uses("KHR_materials_volume", false);
    // −ln(1) / d is −0: the red channel absorbs nothing.
    let m = g.push("materials", json!({ "pbrMetallicRoughness": { "metallicFactor": 0.0 }, "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1.0 },
        "KHR_materials_volume": { "attenuationColor": [1.0, 0.5, 0.25], "attenuationDistance": 2.0 } } }));
    let mesh = g.mesh(&TETRA, &TETRA_TRIS, Some(m));
    let n = g.push("nodes", json!({ "mesh": mesh }));
    g.scene("S", &[n]);
    let dir = tempfile::tempdir().unwrap();
    let (code, out, err) = dump(&[g.write_glb(&dir.path().join("absorb.glb")).to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let doc: Value = serde_json::from_str(out.trim()).unwrap();
    fn negative_zeros(v: &Value) -> usize {
        match v {
            Value::Number(n) => usize::from(n.as_f64().is_some_and(|x| x == 0.0 && x.is_sign_negative())),
            Value::Array(items) => items.iter().map(negative_zeros).sum(),
            Value::Object(fields) => fields.values().map(negative_zeros).sum(),
            _ => 0,
        }
    }
    assert_eq!(negative_zeros(&doc), 0, "{out}");
    let absorption = &doc["materials"][0]["absorption"];
    assert_eq!(absorption[0].as_f64(), Some(0.0));
    assert!(["0.0", "0"].contains(&absorption[0].to_string().as_str()), "{absorption}");
    assert!((absorption[1].as_f64().unwrap() - 2f64.ln() / 2.0).abs() < 1e-6);
}

/// The same remark about five materials is one line that counts and names them; `--warnings
/// json` says it as one JSON object; `--quiet` says nothing (and the scene still loads).
#[test]
fn a_remark_about_many_materials_is_said_once_and_json_or_quiet_on_request() {
    let mut g = GltfBuilder::new();
    let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let nodes: Vec<usize> = (0..5)
        .map(|k| {
            let m = g.push("materials", json!({ "name": format!("Paint{k}"), "extras": { "refrakt": { "shine": 1 } } }));
            let mesh = g.mesh(&tri, &[[0, 1, 2]], Some(m));
            g.push("nodes", json!({ "mesh": mesh }))
        })
        .collect();
    g.scene("S", &nodes);
    let dir = tempfile::tempdir().unwrap();
    let path = g.write_glb(&dir.path().join("car.glb"));
    let w = warnings(&path);
    let about: Vec<&String> = w.iter().filter(|w| w.contains("extras.refrakt.shine")).collect();
    assert_eq!(about.len(), 1, "{w:#?}");
    assert!(about[0].starts_with("car.glb: materials[0] \"Paint0\", materials[1] \"Paint1\", materials[2] \"Paint2\" and 2 more (5 in all): "), "{}", about[0]);
    let run = |extra: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_refrakt")).arg("dump").arg(&path).args(extra).output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8(out.stderr).unwrap()
    };
    let text = run(&[]);
    assert_eq!(text.matches("extras.refrakt.shine").count(), 1, "{text}");
    let json = run(&["--warnings", "json"]);
    let said: Vec<Value> = json.lines().filter_map(|l| serde_json::from_str(l).ok()).collect();
    let shine = said.iter().find(|w| w["message"].as_str().is_some_and(|m| m.contains("shine"))).unwrap_or_else(|| panic!("{json}"));
    assert_eq!((shine["type"].as_str(), shine["file"].as_str(), shine["count"].as_u64()), (Some("warning"), Some(path.to_str().unwrap()), Some(5)));
    assert_eq!(shine["subjects"][4], "materials[4] \"Paint4\"");
    assert_eq!(run(&["--quiet"]), "", "--quiet says nothing");
}

// -------------------------------------------------------------------------------------------
// 7. KHR_materials_variants.

/// A tetrahedron whose own material is grey, in variant "red" red, in variant "glass" glass, and
/// in variant "same" (which it does not map) its own grey.
fn variant_tetra() -> GltfBuilder {
    let mut g = GltfBuilder::new();
    g.uses("KHR_materials_variants", false);
    g.uses("KHR_materials_transmission", false);
    let grey = g.push("materials", json!({ "name": "grey", "pbrMetallicRoughness": { "baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0 } }));
    let red = g.push("materials", json!({ "name": "red", "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.1, 0.1, 1.0], "metallicFactor": 0.0 } }));
    let glass = g.push("materials", json!({ "name": "glass", "pbrMetallicRoughness": { "roughnessFactor": 0.0, "metallicFactor": 0.0 },
                                            "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1.0 } } }));
    let mesh = g.mesh(&TETRA, &TETRA_TRIS, Some(grey));
    g.json["meshes"][mesh]["primitives"][0]["extensions"] = json!({ "KHR_materials_variants": {
        "mappings": [{ "material": red, "variants": [0] }, { "material": glass, "variants": [1] }] } });
    g.json["extensions"] = json!({ "KHR_materials_variants": { "variants": [{ "name": "red" }, { "name": "glass" }, { "name": "same" }] } });
    let node = g.push("nodes", json!({ "name": "tetra", "mesh": mesh }));
    g.scene("s", &[node]);
    g
}

#[test]
fn a_material_variant_gives_each_primitive_the_material_it_maps() {
    let dir = tempfile::tempdir().unwrap();
    let path = variant_tetra().write_glb(&dir.path().join("variants.glb"));
    let p = path.to_str().unwrap();
    let material = |args: &[&str]| -> Value {
        let (code, out, err) = dump(&[&[p], args].concat());
        assert_eq!(code, 0, "{err}");
        let doc: Value = serde_json::from_str(out.trim()).unwrap();
        let tetra = doc["nodes"].as_array().unwrap().iter().find(|n| n["name"] == "tetra").unwrap().clone();
        doc["materials"][tetra["material"].as_u64().unwrap() as usize].clone()
    };
    assert_eq!(material(&[])["color"], json!([0.5, 0.5, 0.5]), "no variant: the primitive's own material");
    assert_eq!(material(&["--variant", "red"])["color"], json!([0.8, 0.1, 0.1]));
    assert_eq!(material(&["--variant", "1"])["kind"], json!("glass"), "by index, and a variant may turn a receiver into glass");
    assert_eq!(material(&["--variant", "same"])["color"], json!([0.5, 0.5, 0.5]), "an unmapped variant keeps the own material");
    let (_, out, _) = dump(&[p, "--variant", "red"]);
    let doc: Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(doc["gltf"]["variants"][0], json!({ "index": 0, "name": "red", "chosen": true }));
    assert_eq!(doc["gltf"]["variants"][2]["chosen"], json!(false));
    let (code, _, err) = dump(&[p, "--variant", "blue"]);
    assert_ne!(code, 0);
    assert!(err.contains("no material variant called \"blue\"") && err.contains("(variants: 0 \"red\", 1 \"glass\", 2 \"same\")"), "{err}");
    // From Lua.
    let script = "local r = require(\"refrakt\")\nlocal scene = r.scene{}\nscene:add(r.gltf{ file = \"variants.glb\", variant = \"red\" })\nreturn scene\n";
    std::fs::write(dir.path().join("scene.lua"), script).unwrap();
    let host = common::load(&dir.path().join("scene.lua"));
    host.update(0.0).unwrap();
    let node = host.scene().borrow().find("tetra").expect("imported");
    let m = node.borrow().material.clone().expect("a material");
    assert!(matches!(&*m.borrow(), refrakt::scene::Material::Diffuse(d) if d.color == Vec3::new(0.8, 0.1, 0.1)));
}

/// A glass material's textures and layers are read without a word, as the dump shows: its
/// emission (which lights the scene as a glowing mesh's), its normal map (which bends its
/// crossings), its transmission factor and texture (which split the light between the glass and
/// its diffuse base), its alpha (which cuts a sheet; on a solid it is said at render) and
/// KHR_materials_specular's factor, colour and textures (which reshape its reflectance). Its
/// `extras.refrakt.tint` (what the add-on writes for a Principled BSDF's glass with a diffuse
/// base) is the tint, and the base colour stays the base's.
#[test]
fn a_glass_materials_textures_and_layers_are_read_without_a_word() {
    let mut g = GltfBuilder::new();
    let mut png = Vec::new();
    image::RgbaImage::new(1, 1).write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
    let view = g.view(&png);
    let image = g.push("images", json!({ "bufferView": view, "mimeType": "image/png" }));
    let texture = g.push("textures", json!({ "source": image }));
    for ext in ["KHR_materials_transmission", "KHR_materials_specular"] {
        g.uses(ext, false);
    }
    let glass = g.push("materials", json!({ "name": "Etched", "alphaMode": "MASK", "normalTexture": { "index": texture }, "emissiveFactor": [1, 1, 1],
        "pbrMetallicRoughness": { "metallicFactor": 0.0, "baseColorFactor": [0.25, 0.5625, 1.0, 1.0] },
        "extras": { "refrakt": { "tint": [0.5, 0.75, 1.0] } },
        "extensions": { "KHR_materials_transmission": { "transmissionFactor": 0.75, "transmissionTexture": { "index": texture } },
                        "KHR_materials_specular": { "specularFactor": 0.5, "specularColorFactor": [2.0, 1.0, 0.5],
                                                    "specularTexture": { "index": texture }, "specularColorTexture": { "index": texture } } } }));
    let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mesh = g.mesh(&tri, &[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], Some(glass));
    let node = g.push("nodes", json!({ "mesh": mesh }));
    g.scene("S", &[node]);
    let dir = tempfile::tempdir().unwrap();
    let w = warnings(&g.write_glb(&dir.path().join("etched.glb")));
    assert!(w.iter().all(|w| !w.contains("Etched")), "{w:#?}");
    let (code, out, err) = dump(&[dir.path().join("etched.glb").to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let doc: Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(doc["materials"][0]["normal_texture"], json!([1, 1]), "{}", doc["materials"]);
    assert_eq!(doc["materials"][0]["normal_scale"], json!(1.0));
    assert_eq!(doc["materials"][0]["transmission"], json!(0.75));
    assert_eq!(doc["materials"][0]["transmission_texture"], json!([1, 1]));
    assert_eq!(doc["materials"][0]["alpha_mode"], json!("MASK"));
    assert_eq!(doc["materials"][0]["specular"], json!(0.5));
    assert_eq!(doc["materials"][0]["specular_color"], json!([2.0, 1.0, 0.5]));
    assert_eq!((&doc["materials"][0]["specular_texture"], &doc["materials"][0]["specular_color_texture"]), (&json!([1, 1]), &json!([1, 1])));
    assert_eq!((&doc["materials"][0]["tint"], &doc["materials"][0]["base_color"]), (&json!([0.5, 0.75, 1.0]), &json!([0.25, 0.5625, 1.0])));
    assert!(w.iter().all(|w| !w.contains("alpha") && !w.contains("tint")), "{w:#?}");
}

/// glTF's metallic on a transmissive material is read as the spec says (transmission applies to
/// the dielectric part only): metallicFactor, whose default is 1. Glass left without it is a
/// mirror, as in glTF viewers, and the import says so; a factor of 0 is clear glass and an
/// explicit part is read without a word.
#[test]
fn metallic_on_glass_is_read_and_a_default_mirror_is_said() {
    let mut g = GltfBuilder::new();
    g.uses("KHR_materials_transmission", false);
    let transmission = json!({ "KHR_materials_transmission": { "transmissionFactor": 1.0 } });
    let unsaid = g.push("materials", json!({ "name": "Unsaid", "extensions": transmission }));
    let clear = g.push("materials", json!({ "name": "Clear", "pbrMetallicRoughness": { "metallicFactor": 0.0 }, "extensions": transmission }));
    let gilt = g.push("materials", json!({ "name": "Gilt", "pbrMetallicRoughness": { "metallicFactor": 0.25 }, "extensions": transmission }));
    let nodes: Vec<usize> = [unsaid, clear, gilt].iter().enumerate().map(|(k, &m)| {
        let mesh = g.mesh(&TETRA, &TETRA_TRIS, Some(m));
        g.push("nodes", json!({ "mesh": mesh, "translation": [2.0 * k as f32, 0.0, 0.0] }))
    }).collect();
    g.scene("S", &nodes);
    let dir = tempfile::tempdir().unwrap();
    let path = g.write_glb(&dir.path().join("metal.glb"));
    let w = warnings(&path);
    let said: Vec<&String> = w.iter().filter(|w| w.contains("metallic")).collect();
    assert_eq!(said.len(), 1, "{w:#?}");
    assert!(said[0].contains("materials[0] \"Unsaid\"") && said[0].contains("\"metallicFactor\": 0"), "{}", said[0]);
    let (code, out, err) = dump(&[path.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let doc: Value = serde_json::from_str(out.trim()).unwrap();
    let metallic: Vec<&Value> = (0..3).map(|k| &doc["materials"][k]["metallic"]).collect();
    assert_eq!(metallic, [&json!(1.0), &json!(0.0), &json!(0.25)], "{}", doc["materials"]);
}
