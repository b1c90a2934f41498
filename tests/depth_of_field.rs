//! Depth of field: a thin-lens camera (`r.camera{ aperture, focus, blades }`) against the thin
//! lens's closed form. A small glowing ball 2 m away, seen in a black world by a 64×64 camera:
//! focused at 1 m through an aperture of A = 0.3 m, each point of it spreads over the circle of
//! confusion, of diameter A·|d − F|/d on the plane in focus — 8.96 pixels in radius here; in
//! focus it stays as sharp as through the pinhole; and the light in the image is the same.

mod common;

use common::{frame_from_lua, shared_renderer};

const SIZE: usize = 64;
const FOV_DEGREES: f32 = 30.0;
const DISTANCE: f32 = 2.0;

fn scene(aperture: f32, focus: f32, blades: u32) -> String {
    format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{ camera = r.camera{{ position = {{0, 0, 0}}, target = {{0, 0, -1}}, fov = {FOV_DEGREES}, size = {{{SIZE}, {SIZE}}},
                                                    aperture = {aperture}, focus = {focus}, blades = {blades}, blade_rotation = 18 }},
                               environment = r.environment{{ color = {{0, 0, 0}} }}, photons = 0, samples = 256, volume = {{ resolution = 16 }} }}
        scene:add(r.node{{ translation = {{0, 0, -{DISTANCE}}}, shape = r.sphere{{ radius = 0.02 }},
                           material = r.diffuse{{ color = {{0, 0, 0}}, emission = {{1, 1, 1}}, emission_strength = 10 }} }})
        return scene"#
    )
}

/// The image's total radiance and its spread: the mean squared distance of its light from its
/// centroid, pixels².
fn light_and_spread(aperture: f32, focus: f32, blades: u32) -> (f64, f64) {
    let image = shared_renderer().frame(&frame_from_lua(&scene(aperture, focus, blades))).unwrap();
    let beauty = &image.layer("beauty").unwrap().data;
    let weight = |i: usize| beauty[4 * i] as f64;
    let total: f64 = (0..SIZE * SIZE).map(weight).sum();
    let at = |i: usize| ((i % SIZE) as f64 + 0.5, (i / SIZE) as f64 + 0.5);
    let (cx, cy) = (0..SIZE * SIZE).fold((0.0, 0.0), |(x, y), i| (x + weight(i) * at(i).0, y + weight(i) * at(i).1));
    let (cx, cy) = (cx / total, cy / total);
    let spread = (0..SIZE * SIZE).map(|i| weight(i) * ((at(i).0 - cx).powi(2) + (at(i).1 - cy).powi(2))).sum::<f64>() / total;
    (total, spread)
}

#[test]
fn a_thin_lens_blurs_what_is_out_of_focus_into_its_aperture_and_keeps_the_light() {
    let (aperture, focus) = (0.3f32, 1.0f32);
    // The circle of confusion's radius in pixels: A·|d − F|/d / 2 on the plane in focus, over a
    // pixel's width there.
    let pixel_at_focus = 2.0 * focus * (0.5 * FOV_DEGREES.to_radians()).tan() / SIZE as f32;
    let radius = (0.5 * aperture * (DISTANCE - focus).abs() / DISTANCE / pixel_at_focus) as f64;
    let (pinhole_light, pinhole_spread) = light_and_spread(0.0, focus, 0);
    // A uniform disc of radius R spreads by R²/2, a regular n-gon of circumradius R by
    // R²·(2 + cos 2π/n)/6 (spreads of independent blurs add).
    for (blades, spread_of_aperture) in [(0u32, 0.5), (5, (2.0 + (std::f64::consts::TAU / 5.0).cos()) / 6.0)] {
        let (light, spread) = light_and_spread(aperture, focus, blades);
        let measured = ((spread - pinhole_spread) / spread_of_aperture).sqrt();
        eprintln!("{blades} blades: light {light:.3} vs the pinhole's {pinhole_light:.3}; blur radius {measured:.3} px, thin lens {radius:.3} px");
        assert!((light / pinhole_light - 1.0).abs() < 0.03, "{blades} blades: light {light} vs {pinhole_light}");
        assert!((measured / radius - 1.0).abs() < 0.05, "{blades} blades: blur radius {measured} vs {radius}");
    }
    // Focused on the ball, the same aperture leaves it as sharp as the pinhole does.
    let (light, spread) = light_and_spread(aperture, DISTANCE, 0);
    eprintln!("in focus: light {light:.3}, spread {spread:.3} px² vs the pinhole's {pinhole_spread:.3}");
    assert!((light / pinhole_light - 1.0).abs() < 0.03);
    assert!((spread - pinhole_spread).abs() < 0.1 * pinhole_spread.max(1.0), "in focus: spread {spread} vs {pinhole_spread}");
}

/// A glTF camera's thin lens comes from its `extras.refrakt` (as the Blender add-on writes it);
/// bad values are refused naming the camera and key.
#[test]
fn a_gltf_cameras_lens_comes_from_its_extras() {
    let mut g = common::gltf_builder::GltfBuilder::new();
    let lens = serde_json::json!({ "aperture": 0.025, "focus": 2.5, "blades": 6, "blade_rotation": 30.0 });
    let camera = g.push("cameras", serde_json::json!({ "name": "Lens", "type": "perspective", "perspective": { "yfov": 0.6, "znear": 0.1 },
                                                        "extras": { "refrakt": lens } }));
    let node = g.push("nodes", serde_json::json!({ "name": "Cam", "camera": camera, "translation": [0.0, 0.0, 3.0] }));
    g.scene("S", &[node]);
    let dir = tempfile::tempdir().unwrap();
    let load = |g: &common::gltf_builder::GltfBuilder, name: &str| refrakt::render::GltfScene::load(&g.write_glb(&dir.path().join(name)), &[], &Default::default());
    let source = load(&g, "lens.glb").unwrap();
    let c = refrakt::scene::eval::evaluate(&source.scene, 0.0, &Default::default()).unwrap().camera;
    assert_eq!((c.aperture, c.focus, c.blades), (0.025, 2.5, 6));
    assert!((c.blade_rotation - 30f32.to_radians()).abs() < 1e-6);
    // Without `focus`: 10 m (a glTF camera has no target).
    g.json["cameras"][camera]["extras"]["refrakt"] = serde_json::json!({ "aperture": 0.025 });
    let source = load(&g, "unfocused.glb").unwrap();
    assert_eq!(refrakt::scene::eval::evaluate(&source.scene, 0.0, &Default::default()).unwrap().camera.focus, refrakt::scene::Lens::DEFAULT_FOCUS);
    g.json["cameras"][camera]["extras"]["refrakt"]["blades"] = serde_json::json!(2);
    let error = format!("{:#}", load(&g, "bad.glb").err().unwrap());
    assert!(error.contains("cameras[0] \"Lens\"") && error.contains("blades"), "{error}");
}
