//! glTF files made by the tests themselves, imported: transforms and hierarchy against matrices
//! computed by hand with glam, the three containers (.glb, .gltf with a data: URI, .gltf with a
//! .bin), scenes, materials (KHR transmission/IOR/volume, base color and its texture), lights in
//! KHR units, cameras, refrakt's extras, and `refrakt.gltf` in a Lua scene.

mod common;

use std::path::Path;

use common::gltf_builder::GltfBuilder;
use glam::{Mat4, Quat, Vec3};
use refrakt::gltf::ImportOptions;
use refrakt::render::{GltfScene, SceneSource};
use refrakt::scene::eval::{EvalOptions, evaluate};
use refrakt::scene::light::DEFAULT_LIGHT_RADIUS;
use refrakt::scene::{LightKind, Material, Scene, Shape};
use serde_json::json;

const TETRA: [[f32; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
const TETRA_TRIS: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];

fn load(path: &Path) -> GltfScene {
    GltfScene::load(path, &[], &ImportOptions::default()).unwrap_or_else(|e| panic!("{e:#}"))
}

fn load_with(path: &Path, opts: &ImportOptions) -> anyhow::Result<GltfScene> {
    GltfScene::load(path, &[], opts)
}

fn world(scene: &Scene, name: &str) -> Mat4 {
    let node = scene.find(name).unwrap_or_else(|| panic!("no node {name}"));
    scene.world_matrix(&node).unwrap()
}

fn assert_mat_close(a: Mat4, b: Mat4, tol: f32, what: &str) {
    let d = (a - b).abs().to_cols_array().into_iter().fold(0.0, f32::max);
    assert!(d < tol, "{what}: off by {d}\n{a}\n{b}");
}

/// Root "A" (TRS, non-uniform scale) ▸ "B" (a column-major matrix) ▸ "C" (TRS, with a mesh).
fn hierarchy() -> (GltfBuilder, [Mat4; 3]) {
    let mut g = GltfBuilder::new();
    let mesh = g.mesh(&TETRA, &TETRA_TRIS, None);
    let (ta, ra, sa) = (Vec3::new(1.0, 2.0, -3.0), Quat::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1), Vec3::new(2.0, 0.5, 1.5));
    let b = Mat4::from_scale_rotation_translation(Vec3::new(0.8, 0.8, 1.2), Quat::from_rotation_z(0.4), Vec3::new(0.0, 1.0, 0.5));
    let (tc, rc, sc) = (Vec3::new(-0.5, 0.0, 0.25), Quat::from_rotation_x(-1.2), Vec3::splat(0.3));
    let c = g.push("nodes", json!({ "name": "C", "mesh": mesh, "translation": tc.to_array(), "rotation": rc.to_array(), "scale": sc.to_array() }));
    let bn = g.push("nodes", json!({ "name": "B", "matrix": b.to_cols_array(), "children": [c] }));
    let a = g.push("nodes", json!({ "name": "A", "translation": ta.to_array(), "rotation": ra.to_array(), "scale": sa.to_array(), "children": [bn] }));
    g.scene("Main", &[a]);
    let ma = Mat4::from_translation(ta) * Mat4::from_quat(ra) * Mat4::from_scale(sa);
    let mc = Mat4::from_translation(tc) * Mat4::from_quat(rc) * Mat4::from_scale(sc);
    (g, [ma, ma * b, ma * b * mc])
}

#[test]
fn node_hierarchy_gives_hand_computed_world_matrices_in_every_container() {
    let (g, want) = hierarchy();
    let dir = tempfile::tempdir().unwrap();
    let files = [
        g.write_glb(&dir.path().join("h.glb")),
        g.write_embedded(&dir.path().join("embedded.gltf")),
        g.write_external(&dir.path().join("external.gltf"), "external data.bin"),
    ];
    for f in &files {
        let s = load(f);
        for (name, m) in ["A", "B", "C"].iter().zip(want) {
            assert_mat_close(world(&s.scene, name), m, 1e-5, &format!("{} in {}", name, f.display()));
        }
        let desc = evaluate(&s.scene, 0.0, &EvalOptions::default()).unwrap();
        // The tetrahedron has no material: the glTF default, an opaque white receiver.
        assert_eq!(desc.receivers.len(), 1);
        assert_eq!(desc.receivers[0].mesh.positions[3], Vec3::from(TETRA[3]));
        assert_mat_close(desc.receivers[0].world, want[2], 1e-5, "receiver world");
    }
}

#[test]
fn files_read_lists_the_gltf_and_its_external_buffer() {
    let (g, _) = hierarchy();
    let dir = tempfile::tempdir().unwrap();
    let path = g.write_external(&dir.path().join("scene.gltf"), "my%20data.bin");
    std::fs::rename(dir.path().join("my%20data.bin"), dir.path().join("my data.bin")).unwrap();
    let source = SceneSource::load_with(&path, &[], &Default::default(), &ImportOptions::default()).unwrap();
    let read: Vec<String> = source.files_read().iter().map(|p| p.file_name().unwrap().to_string_lossy().to_string()).collect();
    assert_eq!(read, ["scene.gltf", "my data.bin"]);
}

#[test]
fn a_scene_is_chosen_by_name_or_the_files_default() {
    let mut g = GltfBuilder::new();
    let a = g.push("nodes", json!({ "name": "in-first" }));
    let b = g.push("nodes", json!({ "name": "in-second" }));
    g.scene("First", &[a]);
    g.scene("Second", &[b]);
    g.json["scene"] = json!(1);
    let dir = tempfile::tempdir().unwrap();
    let path = g.write_glb(&dir.path().join("two.glb"));
    assert!(load(&path).scene.find("in-second").is_some(), "the file's `scene` is the default");
    let first = load_with(&path, &ImportOptions { scene: Some("First".into()), ..Default::default() }).unwrap();
    assert!(first.scene.find("in-first").is_some() && first.scene.find("in-second").is_none());
    let e = format!("{:#}", load_with(&path, &ImportOptions { scene: Some("Third".into()), ..Default::default() }).err().unwrap());
    assert!(e.contains("no scene called \"Third\"") && e.contains("0 \"First\", 1 \"Second\""), "{e}");
}

/// A material of each kind on its own tetrahedron node: (name, material JSON).
fn material_scene(materials: &[(&str, serde_json::Value)]) -> GltfBuilder {
    let mut g = GltfBuilder::new();
    // Required extensions refrakt reads are accepted; unknown ones used (not required) warn.
    for ext in ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume", "KHR_materials_dispersion"] {
        g.uses(ext, true);
    }
    g.uses("KHR_materials_anisotropy", false);
    let mut roots = Vec::new();
    for (i, (name, m)) in materials.iter().enumerate() {
        let mi = g.push("materials", m.clone());
        let mesh = g.mesh(&TETRA, &TETRA_TRIS, Some(mi));
        roots.push(g.push("nodes", json!({ "name": name, "mesh": mesh, "translation": [2.0 * i as f32, 0.0, 0.0] })));
    }
    g.scene("S", &roots);
    g
}

fn material_of(scene: &Scene, name: &str) -> Material {
    scene.find(name).unwrap().borrow().material.as_ref().unwrap().borrow().clone()
}

#[test]
fn transmission_ior_and_volume_make_glass_with_beer_lambert_absorption() {
    let (c, d) = ([0.8f32, 0.5, 0.25], 0.2f32);
    let g = material_scene(&[
        ("glass", json!({ "pbrMetallicRoughness": { "metallicFactor": 0.0 }, "extensions": {
            "KHR_materials_transmission": { "transmissionFactor": 1.0 },
            "KHR_materials_ior": { "ior": 1.33 },
            "KHR_materials_dispersion": { "dispersion": 0.625 },
            "KHR_materials_volume": { "thicknessFactor": 0.1, "attenuationColor": c, "attenuationDistance": d } } })),
        ("clear", json!({ "pbrMetallicRoughness": { "metallicFactor": 0.0 }, "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1.0 } } })),
        ("override", json!({ "pbrMetallicRoughness": { "metallicFactor": 0.0 }, "extensions": {
            "KHR_materials_transmission": { "transmissionFactor": 1.0 },
            "KHR_materials_volume": { "attenuationColor": c, "attenuationDistance": d } },
            "extras": { "refrakt": { "absorption": [0.4, 0.2, 0.0], "scattering": [0.1, 0.1, 0.1], "g": 0.3, "boundary": 2.0 } } })),
        ("smoke", json!({ "extras": { "refrakt": { "scattering": [0.5, 0.5, 0.5] } } })),
        ("paint", json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.2, 0.4, 0.6, 1.0] } })),
    ]);
    let dir = tempfile::tempdir().unwrap();
    let s = load(&g.write_glb(&dir.path().join("m.glb"))).scene;
    let Material::Glass(glass) = material_of(&s, "glass") else { panic!("glass") };
    assert_eq!(glass.ior, 1.33);
    assert_eq!(glass.dispersion, 0.625, "KHR_materials_dispersion: 20/V_d as it is");
    // Beer–Lambert: exp(−σ d) = c, per channel, computed here in f64.
    for (k, &ck) in c.iter().enumerate() {
        let sigma = -(ck as f64).ln() / d as f64;
        assert!((glass.absorption[k] as f64 - sigma).abs() < 1e-5 * sigma, "channel {k}: {} vs {sigma}", glass.absorption[k]);
    }
    let Material::Glass(clear) = material_of(&s, "clear") else { panic!("clear") };
    assert_eq!((clear.ior, clear.absorption, clear.dispersion), (1.5, Vec3::ZERO, 0.0), "KHR_materials_ior's default, no volume, no dispersion");
    let Material::Glass(o) = material_of(&s, "override") else { panic!("override") };
    assert_eq!((o.absorption, o.scattering, o.g), (Vec3::new(0.4, 0.2, 0.0), Vec3::splat(0.1), 0.3), "extras win over the volume");
    let shape = s.find("override").unwrap().borrow().shape.as_ref().unwrap().borrow().clone();
    assert!(matches!(shape, Shape::Mesh { boundary: Some(2.0), .. }), "the material's boundary on its mesh");
    let Material::Glass(smoke) = material_of(&s, "smoke") else { panic!("a medium without a surface") };
    assert_eq!((smoke.ior, smoke.scattering), (1.0, Vec3::splat(0.5)));
    let Material::Diffuse(paint) = material_of(&s, "paint") else { panic!("paint") };
    assert_eq!(paint.color, Vec3::new(0.2, 0.4, 0.6));
    let path = dir.path().join("m.glb");
    let import = refrakt::gltf::import(&path, "m.glb", &refrakt::lua::sandbox::FileAccess::new(dir.path(), &[]).unwrap(), &ImportOptions::default()).unwrap();
    assert!(import.warnings.iter().any(|w| w.to_string().contains("KHR_materials_anisotropy is not supported")), "{:?}", import.warnings);
    assert!(!import.warnings.iter().any(|w| w.to_string().contains("KHR_materials_dispersion")), "{:?}", import.warnings);
}

#[test]
fn a_negative_or_non_numeric_dispersion_is_refused_with_its_material() {
    for bad in [json!(-0.5), json!("strong")] {
        let g = material_scene(&[("prism", json!({ "pbrMetallicRoughness": { "metallicFactor": 0.0 }, "extensions": {
            "KHR_materials_transmission": { "transmissionFactor": 1.0 },
            "KHR_materials_dispersion": { "dispersion": bad } } }))]);
        let dir = tempfile::tempdir().unwrap();
        let path = g.write_glb(&dir.path().join("m.glb"));
        let e = format!("{:#}", load_with(&path, &ImportOptions::default()).err().expect("refused"));
        assert!(e.contains("KHR_materials_dispersion dispersion") && e.contains("m.glb"), "{e}");
    }
}

#[test]
fn a_base_color_texture_is_decoded_from_srgb_to_linear() {
    let mut png = Vec::new();
    let img = image::RgbaImage::from_raw(2, 1, vec![255, 128, 0, 255, 10, 200, 60, 255]).unwrap();
    image::DynamicImage::ImageRgba8(img).write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
    let mut g = material_scene(&[("tex", json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }))]);
    let view = g.view(&png);
    g.push("images", json!({ "bufferView": view, "mimeType": "image/png" }));
    g.push("textures", json!({ "source": 0 }));
    let dir = tempfile::tempdir().unwrap();
    let s = load(&g.write_glb(&dir.path().join("t.glb"))).scene;
    let Material::Diffuse(d) = material_of(&s, "tex") else { panic!() };
    let t = d.texture.expect("a texture");
    // IEC 61966-2-1 by hand for two of the bytes.
    let linear = |c: f64| if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) };
    assert_eq!((t.width, t.height), (2, 1));
    assert!((t.texels[0][1] as f64 - linear(128.0 / 255.0)).abs() < 1e-6);
    assert!((t.texels[1][0] as f64 - linear(10.0 / 255.0)).abs() < 1e-6);
}

#[test]
fn punctual_lights_keep_candela_and_lux_and_their_cones() {
    let mut g = GltfBuilder::new();
    g.uses("KHR_lights_punctual", false);
    g.json["extensions"] = json!({ "KHR_lights_punctual": { "lights": [
        { "type": "spot", "color": [1.0, 0.5, 0.25], "intensity": 800.0, "spot": { "innerConeAngle": 0.2, "outerConeAngle": 0.5 } },
        { "type": "directional", "intensity": 3.0 },
        { "type": "point", "intensity": 50.0 } ] } });
    let down = Quat::from_rotation_x(-0.6);
    let spot = g.push("nodes", json!({ "name": "Spot", "translation": [0.0, 3.0, 1.0], "rotation": down.to_array(),
                                        "extensions": { "KHR_lights_punctual": { "light": 0 } } }));
    let sun = g.push("nodes", json!({ "name": "Sun", "extensions": { "KHR_lights_punctual": { "light": 1 } } }));
    let point = g.push("nodes", json!({ "name": "Point", "extensions": { "KHR_lights_punctual": { "light": 2 } } }));
    g.scene("S", &[spot, sun, point]);
    let dir = tempfile::tempdir().unwrap();
    let s = load(&g.write_glb(&dir.path().join("l.glb"))).scene;
    let light = |n: &str| s.find(n).unwrap().borrow().light.as_ref().unwrap().borrow().clone();
    let LightKind::Spot { angle, blend } = light("Spot").kind else { panic!() };
    assert!((angle - 0.5).abs() < 1e-7 && (angle * (1.0 - blend) - 0.2).abs() < 1e-6, "cones {angle} {blend}");
    assert!(matches!(light("Sun").kind, LightKind::Sun { .. }) && light("Point").kind == LightKind::Point);
    let desc = evaluate(&s, 0.0, &EvalOptions::default()).unwrap();
    let l = &desc.lights[0];
    // refrakt's radiometric units: candela / 683 lm/W → W/sr, times the color.
    assert!((l.radiant - Vec3::new(1.0, 0.5, 0.25) * 800.0 / 683.0).abs().max_element() < 1e-5);
    assert!((l.direction - down * Vec3::NEG_Z).length() < 1e-6, "a glTF light shines down its local −Z");
    assert!((desc.lights[1].radiant - Vec3::splat(3.0 / 683.0)).abs().max_element() < 1e-7);
}

#[test]
fn a_light_radius_in_node_extras_sizes_point_and_spot_bulbs() {
    let mut g = GltfBuilder::new();
    g.uses("KHR_lights_punctual", false);
    g.json["extensions"] = json!({ "KHR_lights_punctual": { "lights": [
        { "type": "point", "intensity": 50.0 },
        { "type": "spot", "intensity": 50.0, "spot": { "outerConeAngle": 0.5 } },
        { "type": "directional", "intensity": 3.0 } ] } });
    let light = |name: &str, index: usize, radius: Option<f32>| {
        let extras = radius.map_or(json!(null), |r| json!({ "refrakt": { "light_radius": r } }));
        json!({ "name": name, "extras": extras, "extensions": { "KHR_lights_punctual": { "light": index } } })
    };
    let bulb = g.push("nodes", light("Bulb", 0, Some(0.25)));
    let spot = g.push("nodes", light("Spot", 1, Some(0.0)));
    let plain = g.push("nodes", light("Plain", 0, None));
    let sun = g.push("nodes", light("Sun", 2, Some(0.3)));
    // Seen by the camera: the bulb (and, skipped with a word, the sun).
    for node in [bulb, sun] {
        g.json["nodes"][node]["extras"]["refrakt"]["light_visible"] = json!(true);
    }
    g.scene("S", &[bulb, spot, plain, sun]);
    let dir = tempfile::tempdir().unwrap();
    let s = load(&g.write_glb(&dir.path().join("r.glb"))).scene;
    let radius = |n: &str| s.find(n).unwrap().borrow().light.as_ref().unwrap().borrow().radius;
    assert_eq!((radius("Bulb"), radius("Spot")), (0.25, 0.0));
    assert_eq!(radius("Plain"), DEFAULT_LIGHT_RADIUS);
    let access = refrakt::lua::sandbox::FileAccess::new(dir.path(), &[]).unwrap();
    let import = refrakt::gltf::import(&dir.path().join("r.glb"), "r.glb", &access, &ImportOptions::default()).unwrap();
    let warned = "r.glb: nodes[3] \"Sun\": extras.refrakt.light_radius is for point and spot lights; skipped";
    assert!(import.warnings.iter().any(|w| w.to_string() == warned), "{:?}", import.warnings);
    let warned = "r.glb: nodes[3] \"Sun\": extras.refrakt.light_visible is for point, spot and area lights (a sun is never seen); skipped";
    assert!(import.warnings.iter().any(|w| w.to_string() == warned), "{:?}", import.warnings);
    let desc = evaluate(&s, 0.0, &EvalOptions::default()).unwrap();
    assert_eq!(desc.lights.iter().map(|l| l.radius).take(3).collect::<Vec<_>>(), [0.25, 0.0, DEFAULT_LIGHT_RADIUS]);
    assert_eq!(desc.lights.iter().map(|l| l.visible).collect::<Vec<_>>(), [true, false, false, false]);

    let mut bad = GltfBuilder::new();
    bad.uses("KHR_lights_punctual", false);
    bad.json["extensions"] = g.json["extensions"].clone();
    let node = bad.push("nodes", light("Bulb", 0, Some(-1.0)));
    bad.scene("S", &[node]);
    let err = load_with(&bad.write_glb(&dir.path().join("bad.glb")), &ImportOptions::default()).err().expect("a negative radius is refused");
    assert!(format!("{err:#}").contains("nodes[0].extras.refrakt.light_radius must be a number ≥ 0 (metres)"), "{err:#}");
}

#[test]
fn a_rect_light_in_node_extras_is_an_area_light_of_that_size_direction_and_radiance() {
    // As the Blender add-on writes an area light (which KHR_lights_punctual lacks): on a node
    // whose local −Z is where it shines, with its size in the local XY plane and nits.
    let mut g = GltfBuilder::new();
    let turn = Quat::from_rotation_y(0.4) * Quat::from_rotation_x(-1.1);
    let rect = json!({ "refrakt": { "light": { "type": "rect", "size": [1.5, 0.5], "color": [1.0, 0.5, 0.25], "intensity": 2000.0 } } });
    let panel = g.push("nodes", json!({ "name": "Panel", "translation": [0.5, 2.0, -1.0], "rotation": turn.to_array(), "extras": rect }));
    let plain = g.push("nodes", json!({ "name": "Plain", "extras": { "refrakt": { "light": { "type": "rect", "size": [1.0, 1.0], "future": 1 } } } }));
    let oval = g.push("nodes", json!({ "name": "Oval", "extras": { "refrakt": { "light": { "type": "disk", "size": [0.8, 0.3] } } } }));
    g.scene("S", &[panel, plain, oval]);
    let dir = tempfile::tempdir().unwrap();
    let path = g.write_glb(&dir.path().join("a.glb"));
    let s = load(&path).scene;
    let light = s.find("Panel").unwrap().borrow().light.as_ref().unwrap().borrow().clone();
    assert_eq!(light.kind, LightKind::Rect { size: glam::Vec2::new(1.5, 0.5), round: false });
    assert_eq!((light.color, light.intensity), (Vec3::new(1.0, 0.5, 0.25), 2000.0));
    let desc = evaluate(&s, 0.0, &EvalOptions::default()).unwrap();
    let l = desc.lights.iter().find(|l| l.name == "Panel").unwrap();
    assert!((l.position - Vec3::new(0.5, 2.0, -1.0)).length() < 1e-6);
    assert!((l.direction - turn * Vec3::NEG_Z).length() < 1e-6, "an area light shines down its node's local −Z");
    assert!((l.right - turn * Vec3::X).length() < 1e-6 && (l.up - turn * Vec3::Y).length() < 1e-6, "its size lies along local X and Y");
    // Radiance in W/(m²·sr): nits / 683 lm/W, times the colour.
    assert!((l.radiant - Vec3::new(1.0, 0.5, 0.25) * 2000.0 / 683.0).abs().max_element() < 1e-5);
    let oval = s.find("Oval").unwrap().borrow().light.as_ref().unwrap().borrow().clone();
    assert_eq!(oval.kind, LightKind::Rect { size: glam::Vec2::new(0.8, 0.3), round: true }, "a disk of diameters 0.8 and 0.3");
    let plain = s.find("Plain").unwrap().borrow().light.as_ref().unwrap().borrow().clone();
    assert_eq!((plain.color, plain.intensity), (Vec3::ONE, 1.0), "colour and intensity default to 1");
    let access = refrakt::lua::sandbox::FileAccess::new(dir.path(), &[]).unwrap();
    let import = refrakt::gltf::import(&path, "a.glb", &access, &ImportOptions::default()).unwrap();
    let warned = "a.glb: nodes[1]: extras.refrakt.light.future is not a refrakt setting (known: type, size, color, intensity); skipped";
    assert!(import.warnings.iter().any(|w| w.to_string() == warned), "{:?}", import.warnings.iter().map(|w| w.to_string()).collect::<Vec<_>>());

    for (light, message) in [
        (json!({ "type": "sphere", "size": [1.0, 1.0] }), "nodes[0].extras.refrakt.light.type is \"sphere\"; refrakt reads \"rect\" and \"disk\""),
        (json!({ "size": [1.0, 1.0] }), "nodes[0].extras.refrakt.light.type must be \"rect\" or \"disk\""),
        (json!({ "type": "rect", "size": [1.0, 0.0] }), "nodes[0].extras.refrakt.light.size must be two numbers > 0 (metres)"),
        (json!({ "type": "rect", "size": [1.0, 1.0], "intensity": -1.0 }), "nodes[0].extras.refrakt.light.intensity must be a number ≥ 0 (nits)"),
    ] {
        let mut bad = GltfBuilder::new();
        let node = bad.push("nodes", json!({ "name": "Bad", "extras": { "refrakt": { "light": light } } }));
        bad.scene("S", &[node]);
        let err = load_with(&bad.write_glb(&dir.path().join("bad.glb")), &ImportOptions::default()).err().expect("refused");
        assert!(format!("{err:#}").contains(message), "{err:#}");
    }
}

#[test]
fn perspective_cameras_take_yfov_and_aspect_and_are_picked_by_name() {
    let mut g = GltfBuilder::new();
    g.push("cameras", json!({ "type": "perspective", "perspective": { "yfov": 0.6, "aspectRatio": 2.0, "znear": 0.1 } }));
    g.push("cameras", json!({ "type": "perspective", "perspective": { "yfov": 0.9, "znear": 0.1 } }));
    let a = g.push("nodes", json!({ "name": "Wide", "camera": 0, "translation": [0.0, 0.0, 5.0] }));
    let b = g.push("nodes", json!({ "name": "Tall", "camera": 1, "translation": [1.0, 0.0, 5.0] }));
    g.scene("S", &[a, b]);
    let dir = tempfile::tempdir().unwrap();
    let s = load(&g.write_glb(&dir.path().join("c.glb"))).scene;
    let first = evaluate(&s, 0.0, &EvalOptions::default()).unwrap().camera;
    assert_eq!((first.fov_y, first.width, first.height), (0.6, 1152, 576), "aspect 2 at the default height");
    let tall = evaluate(&s, 0.0, &EvalOptions { camera: Some("Tall".into()), size: Some((40, 30)), ..Default::default() }).unwrap().camera;
    assert_eq!((tall.fov_y, tall.width, tall.height, tall.position), (0.9, 40, 30, Vec3::new(1.0, 0.0, 5.0)));
}

#[test]
fn refrakt_extras_set_the_scene_and_turn_nodes_into_fields_or_leave_them_out() {
    let mut g = GltfBuilder::new();
    let glass = g.push("materials", json!({ "pbrMetallicRoughness": { "metallicFactor": 0.0 }, "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1.0 } },
                                             "extras": { "refrakt": { "absorption": [0.1, 0.2, 0.3] } } }));
    let mesh = g.mesh(&TETRA, &TETRA_TRIS, Some(glass));
    let lens = g.push("nodes", json!({ "name": "Lens", "mesh": mesh, "extras": { "refrakt": { "field": "luneburg", "radius": 0.4, "boundary": 2.0 } } }));
    let ball = g.push("nodes", json!({ "name": "Ball", "mesh": mesh, "extras": { "refrakt": { "field": "sphere", "radius": 0.3, "ior": 1.7 } } }));
    let slab = g.push("nodes", json!({ "name": "Slab", "extras": { "refrakt": { "field": "slab", "size": [1.0, 0.5, 1.0], "ior": 1.4, "gradient": 0.2 } } }));
    let hidden = g.push("nodes", json!({ "name": "Bounds", "mesh": mesh, "extras": { "refrakt": { "role": "ignore" } }, "children": [] }));
    let s = g.push("scenes", json!({ "name": "S", "nodes": [lens, ball, slab, hidden], "extras": { "refrakt": {
        "photons": 1234, "samples": 3, "volume": { "resolution": 40, "margin": 0.1, "boundary": 2.5, "step": 0.75 },
        "environment": { "visible": false, "color": [0.1, 0.2, 0.3], "intensity": 2.0, "rotation": 90.0 },
        "fog": { "scattering": [0.01, 0.02, 0.03], "absorption": [0.0, 0.0, 0.001], "g": 0.2 },
        "future_setting": 1 } } }));
    g.json["scene"] = json!(s);
    let dir = tempfile::tempdir().unwrap();
    let path = g.write_glb(&dir.path().join("x.glb"));
    let scene = load(&path).scene;
    assert_eq!((scene.photons, scene.samples), (1234, 3));
    let v = scene.volume.borrow().clone();
    assert_eq!((v.resolution, v.margin, v.boundary, v.step), (40, 0.1, 2.5, 0.75));
    let env = scene.environment.borrow().clone();
    assert_eq!((env.visible, env.intensity, env.rotation), (false, 2.0, 90f32.to_radians()));
    assert_eq!(scene.fog.as_ref().unwrap().borrow().g, 0.2);
    let shape = |n: &str| scene.find(n).unwrap().borrow().shape.as_ref().map(|s| s.borrow().clone());
    assert_eq!(shape("Lens"), Some(Shape::Luneburg { radius: 0.4, boundary: Some(2.0) }));
    assert_eq!(shape("Ball"), Some(Shape::Sphere { radius: 0.3, boundary: None }));
    assert_eq!(shape("Slab"), Some(Shape::Slab { size: Vec3::new(1.0, 0.5, 1.0), ior: 1.4, gradient: 0.2, boundary: None }));
    assert_eq!(shape("Bounds"), None, "role ignore leaves the mesh out");
    let Material::Glass(b) = material_of(&scene, "Ball") else { panic!() };
    assert_eq!((b.ior, b.absorption), (1.7, Vec3::new(0.1, 0.2, 0.3)), "the sphere's index from the extras, its medium from the material");
    let desc = evaluate(&scene, 0.0, &EvalOptions::default()).unwrap();
    assert_eq!((desc.fields.len(), desc.meshes.len(), desc.receivers.len()), (3, 0, 0));
    // The unknown key is reported, not fatal.
    let import = refrakt::gltf::import(&path, "x.glb", &refrakt::lua::sandbox::FileAccess::new(dir.path(), &[]).unwrap(), &ImportOptions::default()).unwrap();
    assert!(import.warnings.iter().any(|w| w.to_string().contains("future_setting")), "{:?}", import.warnings);
}

#[test]
fn primitives_of_one_mesh_become_child_nodes_and_strips_fans_become_triangles() {
    let mut g = GltfBuilder::new();
    let quad = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
    let p: Vec<f32> = quad.iter().flatten().copied().collect();
    let pos = g.floats(&p, "VEC3");
    let fan_idx = g.uints(&[0, 1, 3, 2], "SCALAR", 5123);
    g.push("meshes", json!({ "name": "Quad", "primitives": [
        { "attributes": { "POSITION": pos }, "mode": 5 },
        { "attributes": { "POSITION": pos }, "indices": fan_idx, "mode": 6 } ] }));
    let n = g.push("nodes", json!({ "name": "Q", "mesh": 0 }));
    g.scene("S", &[n]);
    let dir = tempfile::tempdir().unwrap();
    let s = load(&g.write_glb(&dir.path().join("q.glb"))).scene;
    let tris = |n: &str| match &*s.find(n).unwrap().borrow().shape.as_ref().unwrap().borrow() {
        Shape::Mesh { mesh, .. } => mesh.triangles.clone(),
        _ => panic!(),
    };
    // §3.7.2.1: strip triangles {vᵢ, vᵢ₊₍₁₊ᵢ mod 2₎, vᵢ₊₍₂₋ᵢ mod 2₎}; fan {vᵢ₊₁, vᵢ₊₂, v₀}.
    assert_eq!(tris("Q.0"), vec![[0, 1, 2], [1, 3, 2]]);
    assert_eq!(tris("Q.1"), vec![[1, 3, 0], [3, 2, 0]]);
}

#[test]
fn lua_imports_a_subtree_and_nodes_parent_both_ways() {
    let (g, want) = hierarchy();
    let dir = tempfile::tempdir().unwrap();
    g.write_glb(&dir.path().join("h.glb"));
    let script = r#"local r = require("refrakt")
        local scene = r.scene{}
        local holder = scene:add(r.node{ name = "holder", translation = {0, 0, 2}, rotation = {0, 90, 0} })
        local imported = holder:add(r.gltf("h.glb"))
        scene:find("B"):add(r.node{ name = "pin", translation = {0.1, 0.2, 0.3} })
        assert(imported.name == "Main" and #imported.children == 1)
        return scene"#;
    std::fs::write(dir.path().join("scene.lua"), script).unwrap();
    let host = common::load(&dir.path().join("scene.lua"));
    host.update(0.0).unwrap();
    let scene = host.scene().borrow();
    let holder = Mat4::from_translation(Vec3::new(0.0, 0.0, 2.0)) * Mat4::from_rotation_y(90f32.to_radians());
    assert_mat_close(world(&scene, "C"), holder * want[2], 1e-5, "C under the script's node");
    assert_mat_close(world(&scene, "pin"), holder * want[1] * Mat4::from_translation(Vec3::new(0.1, 0.2, 0.3)), 1e-5, "pin under B");
    let read: Vec<String> = host.files_read().iter().map(|p| p.file_name().unwrap().to_string_lossy().to_string()).collect();
    assert_eq!(read, ["scene.lua", "h.glb"]);
}

/// §3.7.2.1: "When normals are not specified, client implementations MUST calculate flat
/// normals"; given, they shade the mesh. A curved mesh left without them is warned of, once.
#[test]
fn normals_shade_as_given_and_a_primitive_without_them_is_flat() {
    use refrakt::scene::{Normals, mesh};
    let mut g = GltfBuilder::new();
    let ball = mesh::icosphere(1.0, 2);
    let positions: Vec<[f32; 3]> = ball.positions.iter().map(|p| p.to_array()).collect();
    let bare = g.mesh(&positions, &ball.triangles, None);
    let with_normals = g.mesh(&positions, &ball.triangles, None);
    let normals: Vec<f32> = ball.positions.iter().flat_map(|p| p.normalize().to_array()).collect();
    let n = g.floats(&normals, "VEC3");
    g.json["meshes"][with_normals]["primitives"][0]["attributes"]["NORMAL"] = json!(n);
    let cube = g.mesh(&TETRA, &TETRA_TRIS, None);
    let nodes = [("Bare", bare), ("Smooth", with_normals), ("Tetra", cube), ("Bare again", bare)].map(|(name, mesh)| g.push("nodes", json!({ "name": name, "mesh": mesh })));
    g.scene("S", &nodes);
    let dir = tempfile::tempdir().unwrap();
    let path = g.write_glb(&dir.path().join("normals.glb"));
    let access = refrakt::lua::sandbox::FileAccess::new(dir.path(), &[]).unwrap();
    let import = refrakt::gltf::import(&path, "normals.glb", &access, &ImportOptions::default()).unwrap();
    let scene = load(&path).scene;
    let mesh_of = |name: &str| match &*scene.find(name).unwrap().borrow().shape.as_ref().unwrap().borrow() {
        Shape::Mesh { mesh, .. } => mesh.clone(),
        other => panic!("{other:?}"),
    };
    assert_eq!(mesh_of("Bare").normals, Normals::Flat);
    for (t, corners) in ball.triangles.iter().zip(mesh_of("Bare").corner_normals()) {
        let [a, b, c] = t.map(|i| ball.positions[i as usize]);
        assert!(corners.iter().all(|n| n.dot((b - a).cross(c - a).normalize()) > 1.0 - 1e-6), "flat: the face's own normal");
    }
    for (t, corners) in ball.triangles.iter().zip(mesh_of("Smooth").corner_normals()) {
        assert!(t.iter().zip(corners).all(|(&i, n)| n.dot(ball.positions[i as usize].normalize()) > 1.0 - 1e-6), "NORMAL as given");
    }
    let said: Vec<String> = import.warnings.iter().map(|w| w.to_string()).filter(|w| w.contains("no NORMAL")).collect();
    assert_eq!(said.len(), 1, "the bare ball, once for its two nodes; not the tetrahedron, whose faces meet at sharp angles: {said:?}");
    assert!(said[0].contains("meshes[0]") && said[0].contains("shaded flat") && said[0].contains("Export"), "{said:?}");
}
