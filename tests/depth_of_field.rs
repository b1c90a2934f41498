//! Depth of field: a thin-lens camera (`r.camera{ aperture, focus, blades }`) against the thin
//! lens's closed form. A small glowing ball 2 m away, seen in a black world by a 64×64 camera:
//! focused at 1 m through an aperture of A = 0.3 m, each point of it spreads over the circle of
//! confusion, of diameter A·|d − F|/d on the plane in focus — 8.96 pixels in radius here; in
//! focus it stays as sharp as through the pinhole; and the light in the image is the same.
//!
//! And the rest of the camera's framing: a region of the frame (`render --region`, Blender's
//! border render) renders exactly what the whole frame shows there, and a lens shift moves the
//! image across the image plane — a shifted frame is that region of a wider one.

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
    let lens = serde_json::json!({ "aperture": 0.025, "focus": 2.5, "blades": 6, "blade_rotation": 30.0, "shift": [0.1, -0.2] });
    let camera = g.push("cameras", serde_json::json!({ "name": "Lens", "type": "perspective", "perspective": { "yfov": 0.6, "znear": 0.1 },
                                                        "extras": { "refrakt": lens } }));
    let node = g.push("nodes", serde_json::json!({ "name": "Cam", "camera": camera, "translation": [0.0, 0.0, 3.0] }));
    g.scene("S", &[node]);
    let dir = tempfile::tempdir().unwrap();
    let load = |g: &common::gltf_builder::GltfBuilder, name: &str| refrakt::render::GltfScene::load(&g.write_glb(&dir.path().join(name)), &[], &Default::default());
    let source = load(&g, "lens.glb").unwrap();
    let c = refrakt::scene::eval::evaluate(&source.scene, 0.0, &Default::default()).unwrap().camera;
    assert_eq!((c.aperture, c.focus, c.blades, c.shift), (0.025, 2.5, 6, glam::Vec2::new(0.1, -0.2)));
    assert_eq!(c.clip_start, 0.1, "znear is where its rays start");
    assert!((c.blade_rotation - 30f32.to_radians()).abs() < 1e-6);
    // Without `focus`: 10 m (a glTF camera has no target).
    g.json["cameras"][camera]["extras"]["refrakt"] = serde_json::json!({ "aperture": 0.025 });
    let source = load(&g, "unfocused.glb").unwrap();
    assert_eq!(refrakt::scene::eval::evaluate(&source.scene, 0.0, &Default::default()).unwrap().camera.focus, refrakt::scene::Lens::DEFAULT_FOCUS);
    g.json["cameras"][camera]["extras"]["refrakt"]["blades"] = serde_json::json!(2);
    let error = format!("{:#}", load(&g, "bad.glb").err().unwrap());
    assert!(error.contains("cameras[0] \"Lens\"") && error.contains("blades"), "{error}");
    g.json["cameras"][camera]["extras"]["refrakt"] = serde_json::json!({ "shift": [0.0, 12.0] });
    let error = format!("{:#}", load(&g, "bad_shift.glb").err().unwrap());
    assert!(error.contains("shift"), "{error}");
}

/// Clip start (Blender's, glTF's znear; `camera.clip_start`): nothing nearer along the view is
/// seen. A black wall 1 m in front of the camera hides the glowing ball 2 m away; clipped at 1.5
/// m the ball shows with all of its light (within 1 % of the image without the wall), through
/// the pinhole and through a thin lens alike; clipped at 2.5 m, past the ball, nothing is left.
#[test]
fn clip_start_cuts_away_what_lies_nearer_along_the_view() {
    let light = |clip_start: f32, wall: bool, aperture: f32| {
        let wall = if wall {
            r#"scene:add(r.node{ translation = {0, 0, -1}, rotation = {90, 0, 0}, shape = r.plane{ size = {4, 4} }, material = r.diffuse{ color = {0, 0, 0} } })"#
        } else {
            ""
        };
        let source = scene(aperture, DISTANCE, 0)
            .replace("samples = 256", "samples = 16")
            .replace("blade_rotation = 18", &format!("blade_rotation = 18, clip_start = {clip_start}"))
            .replace("return scene", &format!("{wall}\nreturn scene"));
        let image = shared_renderer().frame(&frame_from_lua(&source)).unwrap();
        image.layer("beauty").unwrap().data.chunks(4).map(|p| p[0] as f64).sum::<f64>()
    };
    for aperture in [0.0, 0.3] {
        let open = light(0.0, false, aperture);
        let (hidden, clipped, past) = (light(0.0, true, aperture), light(1.5, true, aperture), light(2.5, true, aperture));
        eprintln!("aperture {aperture}: the ball's light {open:.3}; behind the wall {hidden:.3}, clipped at 1.5 m {clipped:.3}, at 2.5 m {past:.3}");
        assert!(open > 1.0 && hidden < 1e-3 * open && past < 1e-3 * open, "aperture {aperture}: {open} {hidden} {past}");
        assert!((clipped / open - 1.0).abs() < 0.01, "aperture {aperture}: clipped {clipped} vs {open}");
    }
}

/// A glass ball on a floor under a point light (no size: its shadow rays take no random
/// numbers, so a pixel's light does not depend on which pixel of which frame it is).
fn framed_scene(size: (u32, u32), shift_x: f32) -> String {
    format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{ camera = r.camera{{ position = {{0, 1.2, 2.4}}, target = {{0, 0.3, 0}}, fov = 40, size = {{{}, {}}}, shift = {{{shift_x}, 0}} }},
                               environment = r.environment{{ color = {{0, 0, 0}} }}, photons = 20000, samples = 2, volume = {{ resolution = 32 }} }}
        scene:add(r.node{{ translation = {{0, 0.35, 0}}, shape = r.sphere{{ radius = 0.35 }}, material = r.glass{{ ior = 1.5 }} }})
        scene:add(r.node{{ shape = r.plane{{ size = {{4, 4}} }}, material = r.diffuse{{ color = {{0.8, 0.8, 0.8}} }} }})
        scene:add(r.node{{ translation = {{0.6, 2.0, 0.5}}, light = r.point{{ intensity = 40, radius = 0 }} }})
        return scene"#,
        size.0, size.1
    )
}

/// The beauty and caustic planes of `image` within `w` × `h` pixels from (x, y).
fn planes_within(image: &refrakt::output::Image, (x, y): (usize, usize), (w, h): (usize, usize)) -> Vec<f32> {
    let width = image.width as usize;
    ["beauty", "caustic"]
        .iter()
        .flat_map(|name| {
            let layer = image.layer(name).unwrap();
            let c = layer.channels.len();
            (y..y + h).flat_map(move |j| layer.data[c * (j * width + x)..c * (j * width + x + w)].to_vec())
        })
        .collect()
}

fn assert_same_pixels(got: &[f32], want: &[f32], what: &str) {
    let scale = want.iter().fold(0f32, |m, v| m.max(v.abs()));
    let worst = got.iter().zip(want).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max);
    eprintln!("{what}: largest difference {worst:.2e} of the brightest value {scale:.3}");
    assert!(scale > 0.0 && worst <= 1e-5 * scale, "{what}: pixels differ by up to {worst} (brightest {scale})");
}

#[test]
fn a_region_renders_what_the_frame_shows_there_and_a_shift_is_a_region_of_a_wider_frame() {
    use refrakt::scene::eval::{EvalOptions, Region};
    let mut renderer = shared_renderer();
    let full = renderer.frame(&frame_from_lua(&framed_scene((48, 32), 0.0))).unwrap();
    let region = Region { origin: (13, 5), size: (20, 17) };
    let part = renderer.frame(&common::frame_from_lua_with(&framed_scene((48, 32), 0.0), &EvalOptions { region: Some(region), ..Default::default() })).unwrap();
    assert_eq!((part.width, part.height), (20, 17));
    assert_same_pixels(&planes_within(&part, (0, 0), (20, 17)), &planes_within(&full, (13, 5), (20, 17)), "region vs frame");
    // A 32×32 frame shifted by 0.25 of its side (8 pixels) to the right is the 32×32 region of
    // a 64×32 frame (the same vertical field of view) from x = 16 + 8.
    let shifted = renderer.frame(&frame_from_lua(&framed_scene((32, 32), 0.25))).unwrap();
    let wide = EvalOptions { region: Some(Region { origin: (24, 0), size: (32, 32) }), ..Default::default() };
    let of_wide = renderer.frame(&common::frame_from_lua_with(&framed_scene((64, 32), 0.0), &wide)).unwrap();
    assert_same_pixels(&planes_within(&shifted, (0, 0), (32, 32)), &planes_within(&of_wide, (0, 0), (32, 32)), "shifted vs a region of a wider frame");
    // A region that does not fit the frame is refused before anything renders.
    let (_dir, path) = common::write_script("scene.lua", &framed_scene((48, 32), 0.0));
    let host = common::load(&path);
    host.update(0.0).unwrap();
    let outside = EvalOptions { region: Some(Region { origin: (40, 0), size: (20, 10) }), ..Default::default() };
    let err = refrakt::scene::eval::evaluate(&host.scene().borrow(), 0.0, &outside).unwrap_err();
    assert!(format!("{err:#}").contains("reaches past the 48×32 frame"), "{err:#}");
}
