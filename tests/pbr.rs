//! Receivers shaded with glTF 2.0's metallic-roughness model (`scene::Diffuse`,
//! `shaders/shared/pbr.wgsl`), in absolute terms on tiny frames:
//!
//! - a white Lambertian plane under a sun gives E·albedo/π, with `diffuse`'s defaults and with
//!   the PBR fields at their Lambertian values;
//! - a metallic sphere in an analytic test environment matches a split-sum reference that this
//!   file computes by quadrature (its own prefiltered environment and BRDF integrals);
//! - an emissive plane shows its emission exactly;
//! - alpha MASK cut-out pixels show what is behind, BLEND the mix;
//! - a glTF material (factors, textures, extensions) imports into those fields.

mod common;

use std::f32::consts::PI;
use std::path::Path;

use common::*;
use glam::{Vec2, Vec3};
use refrakt::frame::FrameDesc;
use refrakt::scene::AlphaMode;
use serde_json::json;

/// The frame of `source` (a script in `dir`, so it can name files there).
fn frame_in(dir: &Path, source: &str) -> FrameDesc {
    let path = dir.join("scene.lua");
    std::fs::write(&path, source).unwrap();
    let host = load(&path);
    host.update(0.0).unwrap();
    refrakt::scene::eval::evaluate(&host.scene().borrow(), 0.0, &Default::default()).unwrap_or_else(|e| panic!("{e:#}"))
}

/// One layer of a rendered frame, RGBA floats.
fn render(r: &mut refrakt::pipeline::Renderer, desc: &FrameDesc, layer: &str) -> Vec<f32> {
    r.frame(desc).unwrap().layer(layer).unwrap().data.clone()
}

fn rgb(data: &[f32], width: u32, x: u32, y: u32) -> Vec3 {
    let i = 4 * (y * width + x) as usize;
    Vec3::new(data[i], data[i + 1], data[i + 2])
}

/// A scene looking straight down at a 2 m floor at y = 0 carrying `material`, with `extra`
/// Lua statements before `return` (16×16 pixels, one sample, no photons).
fn floor_scene(environment: &str, material: &str, extra: &str) -> String {
    format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{
          camera = r.camera{{ position = {{0, 2, 0}}, target = {{0, 0, 0}}, up = {{0, 0, -1}}, fov = 30, size = {{16, 16}} }},
          environment = r.environment{{ {environment} }},
          samples = 1, photons = 0,
        }}
        scene:add(r.node{{ name = "floor", shape = r.plane{{ size = {{2, 2}} }}, material = {material} }})
        {extra}
        return scene"#
    )
}

#[test]
fn a_white_lambertian_plane_under_a_sun_gives_e_albedo_over_pi() {
    let dir = tempfile::tempdir().unwrap();
    let sun = r#"scene:add(r.node{ name = "sun", light = r.sun{ intensity = 1000, direction = {0, -1, 0}, angular_diameter = 0 } })"#;
    let mut r = renderer();
    for material in [
        "r.diffuse{ color = {1, 1, 1} }",
        "r.diffuse{ color = {0.6, 0.6, 0.6} }",
        // The PBR fields at their Lambertian values: roughness alone changes nothing.
        "r.pbr{ color = {0.6, 0.6, 0.6}, metallic = 0, specular = 0, roughness = 0.3 }",
    ] {
        let desc = frame_in(dir.path(), &floor_scene("color = {0, 0, 0}", material, sun));
        let albedo = desc.receivers[0].diffuse.color;
        let e = desc.lights[0].radiant; // W/m² on a surface facing the sun
        let want = e * albedo / PI;
        let beauty = render(&mut r, &desc, "beauty");
        let mut worst = 0.0f32;
        for y in 0..16 {
            for x in 0..16 {
                worst = worst.max(((rgb(&beauty, 16, x, y) - want) / want).abs().max_element());
            }
        }
        eprintln!("{material}: E = {e}, want {want}, worst relative error {worst:.2e}");
        // f32 arithmetic only: measured 0 to 1e-7 on lavapipe.
        assert!(worst < 1e-5, "{material}: relative error {worst}");
    }
}

#[test]
fn roughness_without_a_specular_lobe_renders_the_lambertian_image_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let sun = r#"scene:add(r.node{ name = "sun", light = r.sun{ intensity = 800, direction = {0.3, -1, 0.2} } })"#;
    let mut r = renderer();
    let plain = render(&mut r, &frame_in(dir.path(), &floor_scene("preset = \"studio\"", "r.diffuse{ color = {0.5, 0.7, 0.2} }", sun)), "beauty");
    let rough = "r.diffuse{ color = {0.5, 0.7, 0.2}, roughness = 0.2, metallic = 0, specular = 0 }";
    let same = render(&mut r, &frame_in(dir.path(), &floor_scene("preset = \"studio\"", rough, sun)), "beauty");
    assert_eq!(plain, same);
    // And the specular lobe shows once it is asked for.
    let glossy = "r.diffuse{ color = {0.5, 0.7, 0.2}, roughness = 0.2, specular = 1 }";
    let shiny = render(&mut r, &frame_in(dir.path(), &floor_scene("preset = \"studio\"", glossy, sun)), "beauty");
    assert!(mean(&shiny) > 1.01 * mean(&plain), "a specular lobe adds light: {} vs {}", mean(&shiny), mean(&plain));
}

#[test]
fn an_emissive_plane_shows_its_emission_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = renderer();
    let material = "r.diffuse{ color = {0.3, 0.3, 0.3}, emission = {1.5, 0.75, 0.25}, emission_strength = 2 }";
    let desc = frame_in(dir.path(), &floor_scene("color = {0, 0, 0}", material, ""));
    let image = r.frame(&desc).unwrap();
    let want = Vec3::new(3.0, 1.5, 0.5);
    for (layer, expect) in [("beauty", want), ("direct", want), ("caustic", Vec3::ZERO)] {
        let data = &image.layer(layer).unwrap().data;
        let channels = data.len() / 256;
        for y in 0..16 {
            for x in 0..16 {
                let i = channels * (y * 16 + x);
                let got = Vec3::new(data[i], data[i + 1], data[i + 2]);
                assert!((got - expect).abs().max_element() <= 1e-6 * expect.max_element().max(1.0), "{layer} ({x}, {y}): {got} != {expect}");
            }
        }
    }
}

/// An 8×8 RGBA PNG: the left half's alpha is 0, the right half's 1, colour white.
fn write_half_alpha_png(path: &Path) {
    let bytes: Vec<u8> = (0..64u32).flat_map(|i| [255, 255, 255, if i % 8 < 4 { 0 } else { 255 }]).collect();
    image::RgbaImage::from_raw(8, 8, bytes).unwrap().save(path).unwrap();
}

/// The floor seen from above, with a 1 m square card of `card` half a metre above it.
fn card_scene(card: &str) -> String {
    let card_node = if card.is_empty() {
        String::new()
    } else {
        format!(r#"scene:add(r.node{{ name = "card", translation = {{0, 0.5, 0}}, shape = r.plane{{ size = {{1, 1}} }}, material = {card} }})"#)
    };
    floor_scene("color = {0.5, 0.5, 0.5}", "r.diffuse{ color = {0.8, 0.1, 0.1} }", &card_node)
}

/// Pixels looking at the card's middle third, left (u < 0.5) and right halves.
fn card_pixels() -> (Vec<(u32, u32)>, Vec<(u32, u32)>) {
    // fov 30° from 2 m: the 16 pixels span ±0.536 m at the floor, ±0.402 m at the card.
    let left = (6..10).flat_map(|y| (2..6).map(move |x| (x, y))).collect();
    let right = (6..10).flat_map(|y| (10..14).map(move |x| (x, y))).collect();
    (left, right)
}

#[test]
fn alpha_mask_cut_outs_show_what_is_behind_and_blend_mixes() {
    let dir = tempfile::tempdir().unwrap();
    write_half_alpha_png(&dir.path().join("half.png"));
    let mut r = renderer();
    // The floor glows instead of reflecting: the sky lights the scene, and the card shades the
    // floor from part of it, which is not what this test measures.
    let glowing = |card: &str| card_scene(card).replace("r.diffuse{ color = {0.8, 0.1, 0.1} }", "r.diffuse{ color = {0, 0, 0}, emission = {0.8, 0.1, 0.1} }");
    let mut beauty = |card: &str| render(&mut r, &frame_in(dir.path(), &glowing(card)), "beauty");
    let floor = beauty("");
    let opaque = beauty(r#"r.diffuse{ color = {0.1, 0.2, 0.9} }"#);
    let mask = beauty(r#"r.diffuse{ color = {0.1, 0.2, 0.9}, texture = "half.png", alpha_mode = "MASK" }"#);
    let blend = beauty(r#"r.diffuse{ color = {0.1, 0.2, 0.9}, alpha = 0.25, alpha_mode = "BLEND" }"#);
    let (left, right) = card_pixels();
    for &(x, y) in &left {
        // The texture's alpha is 0 there: the floor shows, as without the card.
        let (got, want) = (rgb(&mask, 16, x, y), rgb(&floor, 16, x, y));
        assert!((got - want).abs().max_element() < 1e-5, "cut-out ({x}, {y}): {got} vs the floor {want}");
        assert!((rgb(&opaque, 16, x, y) - want).abs().max_element() > 0.05, "the card hides the floor at ({x}, {y})");
    }
    for &(x, y) in &right {
        let (got, want) = (rgb(&mask, 16, x, y), rgb(&opaque, 16, x, y));
        assert!((got - want).abs().max_element() < 1e-5, "masked-in ({x}, {y}): {got} vs the opaque card {want}");
    }
    for &(x, y) in left.iter().chain(&right) {
        let want = 0.25 * rgb(&opaque, 16, x, y) + 0.75 * rgb(&floor, 16, x, y);
        let got = rgb(&blend, 16, x, y);
        assert!((got - want).abs().max_element() < 1e-5, "blend ({x}, {y}): {got} vs {want}");
    }
}

#[test]
fn a_cut_out_lets_the_sun_through_and_a_see_through_card_casts_a_partial_shadow() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = renderer();
    let sun = r#"scene:add(r.node{ name = "sun", light = r.sun{ intensity = 1000, direction = {0, -1, 0}, angular_diameter = 0 } })"#;
    // The camera looks down through the card at its shadow on the floor: where the card is a
    // hole (MASK, alpha 0 everywhere) and where it lets 60% through (BLEND, alpha 0.4), against
    // the floor lit without the card.
    let scene = |card: &str| {
        let s = card_scene(card).replace("color = {0.5, 0.5, 0.5}", "color = {0, 0, 0}");
        s.replace("return scene", &format!("{sun}\nreturn scene"))
    };
    let lit = render(&mut r, &frame_in(dir.path(), &scene("")), "beauty");
    let hole = render(&mut r, &frame_in(dir.path(), &scene(r#"r.diffuse{ alpha = 0, alpha_mode = "MASK" }"#)), "beauty");
    let tinted = render(&mut r, &frame_in(dir.path(), &scene(r#"r.diffuse{ color = {0, 0, 0}, alpha = 0.4, alpha_mode = "BLEND" }"#)), "beauty");
    let (left, right) = card_pixels();
    for &(x, y) in left.iter().chain(&right) {
        let floor = rgb(&lit, 16, x, y);
        assert!((rgb(&hole, 16, x, y) - floor).abs().max_element() < 1e-5);
        // Seen through the black card (60% of the floor) and lit through it (60% of the sun).
        let want = 0.6 * 0.6 * floor;
        assert!((rgb(&tinted, 16, x, y) - want).abs().max_element() < 1e-4 * floor.max_element(), "({x}, {y}): {} vs {want}", rgb(&tinted, 16, x, y));
    }
}

// ---------------------------------------------------------------------------------------------
// A metallic sphere against the split sum, computed here by quadrature.

const SPHERE_R: f32 = 0.5;

/// The test environment: smooth, coloured, different in every direction.
fn environment(d: Vec3) -> Vec3 {
    let s = 0.5 + 0.5 * d.y;
    Vec3::new(0.1 + 1.4 * s * s, 0.4 + 0.3 * d.x, 0.35 + 0.25 * d.z + 0.2 * d.x * d.y)
}

fn write_environment(path: &Path) {
    let (w, h) = (256usize, 128usize);
    exr::prelude::write_rgba_file(path, w, h, |x, y| {
        let uv = Vec2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
        let c = environment(refrakt::scene::environment::uv_to_dir(uv));
        (c.x, c.y, c.z, 1.0)
    })
    .unwrap();
}

/// Directions spread evenly over the sphere (a Fibonacci lattice), each standing for 4π/n sr.
fn sphere_directions(n: usize) -> Vec<Vec3> {
    let golden = PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - y * y).sqrt();
            let phi = golden * i as f32;
            Vec3::new(r * phi.cos(), y, r * phi.sin())
        })
        .collect()
}

fn ggx_d(n_h: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let f = n_h * n_h * (a2 - 1.0) + 1.0;
    a2 / (PI * f * f)
}

fn smith_v(n_l: f32, n_v: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    0.5 / (n_l * (n_v * n_v * (1.0 - a2) + a2).sqrt() + n_v * (n_l * n_l * (1.0 - a2) + a2).sqrt())
}

/// The split sum for a metal of colour f0 and roughness at normal n, view v: the environment
/// convolved with the GGX lobe around the mirror direction (n = v = r, weighted by n·l, as
/// Karis and the Sample Viewer prefilter), times f0·A + B, both integrated over `dirs`.
fn split_sum(dirs: &[Vec3], f0: Vec3, roughness: f32, n: Vec3, v: Vec3) -> Vec3 {
    let alpha = roughness * roughness;
    let r = (2.0 * n.dot(v) * n - v).normalize();
    let (mut sum, mut weight) = (Vec3::ZERO, 0.0);
    for &l in dirs {
        let n_l = r.dot(l);
        if n_l > 0.0 {
            let h = (l + r).normalize();
            // Prefilter kernel: D(h)(n·h)/(4 v·h) (the sampling density), × n·l.
            let w = ggx_d(r.dot(h), alpha) / 4.0 * n_l;
            sum += environment(l) * w;
            weight += w;
        }
    }
    let prefiltered = sum / weight;
    let n_v = n.dot(v).max(1e-4);
    let (mut a, mut b) = (0.0, 0.0);
    for &l in dirs {
        let n_l = n.dot(l);
        if n_l > 0.0 {
            let h = (l + v).normalize();
            let fc = (1.0 - v.dot(h).max(0.0)).powi(5);
            let f = ggx_d(n.dot(h).max(0.0), alpha) * smith_v(n_l, n_v, alpha) * n_l * (4.0 * PI / dirs.len() as f32);
            a += (1.0 - fc) * f;
            b += fc * f;
        }
    }
    prefiltered * (f0 * a + Vec3::splat(b))
}

#[test]
fn a_metallic_sphere_matches_the_split_sum_reference() {
    let dir = tempfile::tempdir().unwrap();
    write_environment(&dir.path().join("env.exr"));
    let mut r = renderer();
    let f0 = Vec3::new(0.95, 0.64, 0.54);
    let sphere = |roughness: f32| {
        format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{
              camera = r.camera{{ position = {{0, 0.3, 2.5}}, target = {{0, 0, 0}}, fov = 30, size = {{32, 32}} }},
              environment = r.environment{{ image = "env.exr" }},
              samples = 1, photons = 0,
            }}
            scene:add(r.node{{ name = "ball", shape = r.icosphere{{ radius = {SPHERE_R}, subdivisions = 5 }},
                              material = r.pbr{{ color = {{{}, {}, {}}}, metallic = 1, roughness = {roughness} }} }})
            return scene"#,
            f0.x, f0.y, f0.z
        )
    };
    let dirs = sphere_directions(40_000);
    for roughness in [0.5f32, 0.3] {
        let desc = frame_in(dir.path(), &sphere(roughness));
        let beauty = render(&mut r, &desc, "beauty");
        let cam = &desc.camera;
        let (mut err, mut err_other, mut count) = (0.0f32, 0.0f32, 0);
        for y in 0..32 {
            for x in 0..32 {
                let d = cam.ray(x, y);
                let o = cam.position;
                // Rays well inside the silhouette (the facets' outline differs from the sphere's).
                let b = o.dot(d);
                let disc = b * b - (o.dot(o) - SPHERE_R * SPHERE_R);
                if disc < 0.3 * SPHERE_R * SPHERE_R {
                    continue;
                }
                let p = o + d * (-b - disc.sqrt());
                let n = p.normalize();
                let want = split_sum(&dirs, f0, roughness, n, -d);
                // A different metal would be far off: steel's grey instead of copper.
                let steel = split_sum(&dirs, Vec3::splat(0.56), roughness, n, -d);
                let got = rgb(&beauty, 32, x, y);
                err += (got - want).abs().element_sum() / 3.0;
                err_other += (steel - want).abs().element_sum() / 3.0;
                count += 1;
            }
        }
        let (mae, mae_other) = (err / count as f32, err_other / count as f32);
        eprintln!("metal, roughness {roughness}: MAE vs the split sum {mae:.4} over {count} pixels (steel instead of copper would be {mae_other:.4})");
        assert!(count > 200);
        // Measured 0.0085 (roughness 0.5) and 0.0070 (0.3) on lavapipe, radiance ~0.3–1.3: the
        // prefiltered layers (128×64 texels, 64 samples each, half floats), the 32² BRDF table
        // and the icosphere's facets.
        assert!(mae < 0.015, "roughness {roughness}: MAE {mae}");
        assert!(mae_other > 3.0 * mae, "the bound must tell materials apart: {mae_other} vs {mae}");
    }
}

// ---------------------------------------------------------------------------------------------
// Lua fields and glTF import.

/// The environment on a polished floor has shadows: a mirror-like metal floor (metallic 1,
/// roughness 0.05, white) around a black ball (r = 0.3 m, resting on it, reflecting nothing)
/// under a uniform sky of radiance 1, seen obliquely. Where a floor pixel's mirror direction
/// misses the ball by a margin the floor shows the lobe's split-sum light, as the open floor
/// far off does (within 2 %); where it meets the ball, none (below 3 % of it) — the ball is in
/// the way of the sky, and not itself reflected. Before the glossy lobe's shadow ray
/// (`glossy_ray`) the sky showed through the ball's reflection. A glass ball in its place lets
/// the sky by (within 3 %: its refraction is not followed).
#[test]
fn a_polished_floor_reflects_the_sky_with_the_shadow_of_a_ball_on_it() {
    let (radius, centre) = (0.3f32, Vec3::new(0.0, 0.3, 0.0));
    for ball in ["r.diffuse{ color = {0, 0, 0} }", "r.glass{ ior = 1.5 }"] {
        let desc = frame_from_lua(&format!(
            r#"local r = require("refrakt")
            local scene = r.scene{{ camera = r.camera{{ position = {{0, 1.6, 2.2}}, target = {{0, 0, 0.2}}, fov = 40, size = {{48, 48}} }},
                                    environment = r.environment{{ color = {{1, 1, 1}} }}, samples = 4, photons = 0, bounces = 0, volume = {{ resolution = 16 }} }}
            scene:add(r.node{{ name = "floor", shape = r.plane{{ size = {{6, 6}} }}, material = r.pbr{{ color = {{1, 1, 1}}, metallic = 1, roughness = 0.05 }} }})
            scene:add(r.node{{ name = "ball", translation = {{0, 0.3, 0}}, shape = r.sphere{{ radius = {radius} }}, material = {ball} }})
            return scene"#
        ));
        let mut r = renderer();
        let beauty = render(&mut r, &desc, "beauty");
        // How far a ray from o along unit d passes from the ball's centre (∞ going away).
        let miss = |o: Vec3, d: Vec3| {
            let t = (centre - o).dot(d);
            if t <= 0.0 { f32::INFINITY } else { (o + d * t - centre).length() }
        };
        let (mut open, mut behind, mut far) = (Vec::new(), Vec::new(), Vec::new());
        for y in 0..48 {
            for x in 0..48 {
                let (o, d) = (desc.camera.position, desc.camera.ray(x, y));
                let t = -o.y / d.y;
                if d.y >= 0.0 || miss(o, d) < radius + 0.02 {
                    continue; // the sky, or the ball itself (and its outline)
                }
                let p = o + d * t;
                let mirrored = Vec3::new(d.x, -d.y, d.z);
                let seen = rgb(&beauty, 48, x, y).x;
                let gap = miss(p, mirrored);
                if gap < radius - 0.03 {
                    behind.push(seen);
                } else if gap > radius + 0.05 {
                    open.push(seen);
                    if (p - centre).length() > 1.0 {
                        far.push(seen);
                    }
                }
            }
        }
        let (open_mean, behind_mean, far_mean) = (mean(&open), mean(&behind), mean(&far));
        println!(
            "{ball}: polished floor where its reflection misses the ball {open_mean:.4} ({} px), far off {far_mean:.4} ({} px), where it meets the ball {behind_mean:.4} ({} px)",
            open.len(),
            far.len(),
            behind.len()
        );
        assert!(open.len() > 300 && behind.len() > 20 && far.len() > 100, "{} {} {}", open.len(), behind.len(), far.len());
        assert!((open_mean / far_mean - 1.0).abs() < 0.02, "{open_mean} vs {far_mean}");
        if ball.contains("glass") {
            assert!((behind_mean / far_mean - 1.0).abs() < 0.03, "glass lets the sky by: {behind_mean} vs {far_mean}");
        } else {
            assert!(behind_mean < 0.03 * far_mean, "the ball's shadow in the reflection: {behind_mean} vs {far_mean}");
        }
    }
}

#[test]
fn lua_fields_read_back_and_bad_values_name_the_field() {
    let desc = frame_from_lua(
        r#"local r = require("refrakt")
        local scene = r.scene{}
        local m = r.pbr{ color = {0.5, 0.5, 0.5}, roughness = 0.25, emission = {1, 2, 3}, alpha_mode = "blend", alpha = 0.5 }
        assert(m.metallic == 1 and m.specular == 1 and m.alpha_mode == "BLEND" and m.alpha_cutoff == 0.5)
        local d = r.diffuse{}
        assert(d.metallic == 0 and d.specular == 0 and d.roughness == 1 and d.emission_strength == 1 and d.texture == nil)
        assert(d.clearcoat == 0 and d.sheen_color[1] == 0 and d.sheen_roughness == 0)
        m.clearcoat = 0.5
        m.sheen_color = {0.2, 0.4, 0.6}
        assert(m.clearcoat == 0.5 and m.sheen_color[3] == 0.6)
        scene:add(r.node{ name = "floor", shape = r.plane{ size = {1, 1} }, material = m })
        return scene"#,
    );
    let d = &desc.receivers[0].diffuse;
    assert_eq!((d.metallic, d.roughness, d.specular, d.alpha, d.alpha_mode), (1.0, 0.25, 1.0, 0.5, AlphaMode::Blend));
    assert_eq!(d.emitted(), Vec3::new(1.0, 2.0, 3.0));
    assert_eq!((d.clearcoat, d.sheen_color), (0.5, Vec3::new(0.2, 0.4, 0.6)));
    let limits = refrakt::lua::Limits::default();
    let e = load_error("local m = r.pbr{ sheen_color = {2, 0, 0} }", &limits);
    assert!(e.contains("sheen_color is a reflectance") && e.contains("from 0 to 1"), "{e}");
    let e = load_error("local m = r.pbr{ clearcoat = -1 }", &limits);
    assert!(e.contains("clearcoat") && e.contains("from 0 to 1"), "{e}");
    let e = load_error(r#"local m = r.diffuse{ alpha_mode = "HALF" }"#, &limits);
    assert!(e.contains("scene.lua:3") && e.contains("\"OPAQUE\", \"MASK\"") && e.contains("HALF"), "{e}");
    let e = load_error("local m = r.pbr{ metallic = 2 }", &limits);
    assert!(e.contains("metallic") && e.contains("from 0 to 1"), "{e}");
    let e = load_error(r#"local m = r.diffuse{ normal_texture = "missing.png" }"#, &limits);
    assert!(e.contains("missing.png"), "{e}");
}

/// A 2×2 PNG of one RGBA colour, as a data URI.
fn png_uri(c: [u8; 4]) -> String {
    use base64::Engine;
    let mut png = Vec::new();
    let img = image::RgbaImage::from_raw(2, 2, c.repeat(4)).unwrap();
    image::DynamicImage::ImageRgba8(img).write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
    format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(png))
}

#[test]
fn a_gltf_material_imports_every_pbr_field() {
    let dir = tempfile::tempdir().unwrap();
    let mut g = common::gltf_builder::GltfBuilder::new();
    g.uses("KHR_materials_emissive_strength", true);
    g.uses("KHR_materials_specular", false);
    g.uses("KHR_materials_clearcoat", true);
    g.uses("KHR_materials_sheen", true);
    for (i, c) in [[128u8, 128, 128, 200], [0, 128, 64, 255], [128, 128, 255, 255], [100, 0, 0, 255], [255, 128, 0, 255], [64, 32, 0, 16]].iter().enumerate() {
        g.push("images", json!({ "uri": png_uri(*c) }));
        g.push("textures", json!({ "source": i }));
    }
    let m = g.push(
        "materials",
        json!({
            "pbrMetallicRoughness": {
                "baseColorFactor": [0.9, 0.8, 0.7, 0.6], "metallicFactor": 0.3, "roughnessFactor": 0.6,
                "baseColorTexture": { "index": 0 }, "metallicRoughnessTexture": { "index": 1 } },
            "normalTexture": { "index": 2, "scale": 0.5 },
            "occlusionTexture": { "index": 3, "strength": 0.7 },
            "emissiveTexture": { "index": 4 },
            "emissiveFactor": [1.0, 0.5, 0.25],
            "alphaMode": "MASK", "alphaCutoff": 0.3,
            "extensions": { "KHR_materials_emissive_strength": { "emissiveStrength": 4.0 },
                            "KHR_materials_specular": { "specularFactor": 0.5 },
                            "KHR_materials_clearcoat": { "clearcoatFactor": 0.8, "clearcoatRoughnessFactor": 0.25,
                                                         "clearcoatTexture": { "index": 5 }, "clearcoatRoughnessTexture": { "index": 5 },
                                                         "clearcoatNormalTexture": { "index": 2, "scale": 0.5 } },
                            "KHR_materials_sheen": { "sheenColorFactor": [0.5, 0.25, 1.0], "sheenRoughnessFactor": 0.4,
                                                     "sheenColorTexture": { "index": 5 }, "sheenRoughnessTexture": { "index": 5 } } }
        }),
    );
    let pos = g.floats(&[-1.0, 0.0, -1.0, 1.0, 0.0, -1.0, 1.0, 0.0, 1.0], "VEC3");
    let uv = g.floats(&[0.0, 0.0, 1.0, 0.0, 1.0, 1.0], "VEC2");
    g.push("meshes", json!({ "primitives": [{ "attributes": { "POSITION": pos, "TEXCOORD_0": uv }, "material": m }] }));
    let n = g.push("nodes", json!({ "name": "card", "mesh": 0 }));
    g.scene("Card", &[n]);
    g.write_embedded(&dir.path().join("card.gltf"));
    let desc = frame_in(dir.path(), "local r = require(\"refrakt\")\nlocal scene = r.scene{}\nscene:add(r.gltf(\"card.gltf\"))\nreturn scene");
    let d = &desc.receivers[0].diffuse;
    assert_eq!(d.color, Vec3::new(0.9, 0.8, 0.7));
    assert_eq!((d.alpha, d.alpha_mode, d.alpha_cutoff), (0.6, AlphaMode::Mask, 0.3));
    assert_eq!((d.metallic, d.roughness, d.specular), (0.3, 0.6, 0.5));
    assert_eq!((d.normal_scale, d.occlusion_strength), (0.5, 0.7));
    assert_eq!(d.emitted(), Vec3::new(4.0, 2.0, 1.0));
    let texel = |t: &Option<std::sync::Arc<refrakt::scene::Texture2d>>| t.as_ref().expect("imported").texels[0];
    // Colour textures are sRGB-decoded, data textures read as they are; alpha is linear.
    let srgb = refrakt::scene::material::srgb_to_linear(128.0 / 255.0);
    assert_eq!(texel(&d.texture), [srgb, srgb, srgb, 200.0 / 255.0]);
    assert_eq!(texel(&d.metallic_roughness_texture), [0.0, 128.0 / 255.0, 64.0 / 255.0, 1.0]);
    assert_eq!(texel(&d.normal_texture), [128.0 / 255.0, 128.0 / 255.0, 1.0, 1.0]);
    assert_eq!(texel(&d.occlusion_texture)[0], 100.0 / 255.0);
    assert_eq!(texel(&d.emission_texture), [1.0, srgb, 0.0, 1.0]);
    // KHR_materials_clearcoat (coat in R, its roughness in G) and KHR_materials_sheen (colour
    // sRGB in RGB, roughness in A), one texture in both roles.
    assert_eq!((d.clearcoat, d.clearcoat_roughness, d.sheen_color, d.sheen_roughness), (0.8, 0.25, Vec3::new(0.5, 0.25, 1.0), 0.4));
    assert_eq!(texel(&d.clearcoat_texture), [64.0 / 255.0, 32.0 / 255.0, 0.0, 16.0 / 255.0]);
    assert!(std::sync::Arc::ptr_eq(d.clearcoat_texture.as_ref().unwrap(), d.clearcoat_roughness_texture.as_ref().unwrap()));
    assert_eq!((texel(&d.clearcoat_normal_texture), d.clearcoat_normal_scale), ([128.0 / 255.0, 128.0 / 255.0, 1.0, 1.0], 0.5));
    let s = refrakt::scene::material::srgb_to_linear;
    assert_eq!(texel(&d.sheen_color_texture), [s(64.0 / 255.0), s(32.0 / 255.0), 0.0, 16.0 / 255.0]);
    assert_eq!(texel(&d.sheen_roughness_texture)[3], 16.0 / 255.0);
    // A file with none of it is glTF's default material: the full model, a rough metal.
    let mut g = common::gltf_builder::GltfBuilder::new();
    let mesh = g.mesh(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], &[[0, 2, 1]], None);
    let n = g.push("nodes", json!({ "mesh": mesh }));
    g.scene("Plain", &[n]);
    g.write_embedded(&dir.path().join("plain.gltf"));
    let desc = frame_in(dir.path(), "local r = require(\"refrakt\")\nlocal scene = r.scene{}\nscene:add(r.gltf(\"plain.gltf\"))\nreturn scene");
    let d = &desc.receivers[0].diffuse;
    assert_eq!((d.color, d.metallic, d.roughness, d.specular, d.alpha_mode), (Vec3::ONE, 1.0, 1.0, 1.0, AlphaMode::Opaque));
}

// KHR_materials_clearcoat and KHR_materials_sheen: the GPU against the CPU twin
// (`refrakt::cpu::pbr`), and the twin against closed forms.

/// A direction at `polar` degrees from +Y (the floor's normal), `azimuth` degrees around it.
fn polar(polar: f32, azimuth: f32) -> Vec3 {
    let (t, p) = (polar.to_radians(), azimuth.to_radians());
    Vec3::new(t.sin() * p.cos(), t.cos(), t.sin() * p.sin())
}

/// A 6 m floor of `material` seen by an orthographic camera from direction `view` (toward
/// the camera), so every pixel sees the floor along the same v (8×8 pixels, no photons).
fn layered_floor(view: Vec3, material: &str, environment: &str, extra: &str) -> String {
    let eye = 3.0 * view;
    format!(
        r#"local r = require("refrakt")
        local scene = r.scene{{
          camera = r.camera{{ orthographic = 0.5, position = {{{}, {}, {}}}, target = {{0, 0, 0}}, up = {{0, 1, 0}}, size = {{8, 8}} }},
          environment = r.environment{{ {environment} }},
          samples = 1, photons = 0,
        }}
        scene:add(r.node{{ name = "floor", shape = r.plane{{ size = {{6, 6}} }}, material = {material} }})
        {extra}
        return scene"#,
        eye.x, eye.y, eye.z
    )
}

const LAYERED: [(&str, refrakt::cpu::pbr::Surface); 3] = {
    use refrakt::cpu::pbr::Surface;
    let s = Surface {
        base: Vec3::ZERO, metallic: 0.0, roughness: 1.0, specular: 1.0, clearcoat: 0.0, clearcoat_roughness: 0.0,
        sheen_color: Vec3::ZERO, sheen_roughness: 0.0, n: Vec3::Y, coat_n: Vec3::Y, v: Vec3::Y,
    };
    [
        (
            "r.pbr{ color = {0.6, 0.25, 0.1}, metallic = 0, roughness = 0.6, clearcoat = 1, clearcoat_roughness = 0.15 }",
            Surface { base: Vec3::new(0.6, 0.25, 0.1), metallic: 0.0, roughness: 0.6, clearcoat: 1.0, clearcoat_roughness: 0.15, ..s },
        ),
        (
            "r.pbr{ color = {0.2, 0.1, 0.3}, metallic = 0, roughness = 0.8, sheen_color = {0.9, 0.6, 0.3}, sheen_roughness = 0.4 }",
            Surface { base: Vec3::new(0.2, 0.1, 0.3), metallic: 0.0, roughness: 0.8, sheen_color: Vec3::new(0.9, 0.6, 0.3), sheen_roughness: 0.4, ..s },
        ),
        (
            "r.pbr{ color = {0.9, 0.6, 0.5}, roughness = 0.4, clearcoat = 0.7, clearcoat_roughness = 0.3, sheen_color = {0.5, 0.5, 0.5}, sheen_roughness = 0.7 }",
            Surface {
                base: Vec3::new(0.9, 0.6, 0.5), metallic: 1.0, roughness: 0.4, clearcoat: 0.7, clearcoat_roughness: 0.3,
                sheen_color: Vec3::splat(0.5), sheen_roughness: 0.7, ..s
            },
        ),
    ]
};

/// Every pixel of the beauty layer against `want`, relative per channel; the worst.
fn worst_relative(beauty: &[f32], want: Vec3) -> f32 {
    beauty.chunks(4).map(|p| ((Vec3::new(p[0], p[1], p[2]) - want).abs() / want.max(Vec3::splat(1e-3))).max_element()).fold(0.0, f32::max)
}

/// The floor of `material` under a sun from (view, sun polar, sun azimuth) degrees (black
/// sky): the radiance the twin `surface` gives, and the beauty layer's worst relative error.
fn under_a_sun(r: &mut refrakt::pipeline::Renderer, dir: &Path, material: &str, surface: refrakt::cpu::pbr::Surface, (view, sun, azimuth): (f32, f32, f32)) -> (Vec3, f32) {
    let (v, l) = (polar(view, 0.0), polar(sun, azimuth));
    let light = format!(
        "scene:add(r.node{{ name = \"sun\", light = r.sun{{ intensity = 1000, direction = {{{}, {}, {}}}, angular_diameter = 0 }} }})",
        -l.x, -l.y, -l.z
    );
    let desc = frame_in(dir, &layered_floor(v, material, "color = {0, 0, 0}", &light));
    let want = refrakt::cpu::pbr::Surface { v, ..surface }.brdf(l) * desc.lights[0].radiant * l.y;
    (want, worst_relative(&render(r, &desc, "beauty"), want))
}

#[test]
fn clearcoat_and_sheen_under_a_sun_match_the_cpu_twin_at_several_angles() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = renderer();
    // (view polar, sun polar, sun azimuth relative to the view): near the coat's mirror
    // direction, across, grazing behind the viewer (the sheen's back-scatter) and overhead.
    let angles = [(20.0, 22.0, 180.0), (55.0, 40.0, 90.0), (55.0, 70.0, 0.0), (20.0, 0.0, 0.0)];
    let mut worst = 0.0f32;
    for (material, surface) in &LAYERED {
        for (view, sun, azimuth) in angles {
            let (want, error) = under_a_sun(&mut r, dir.path(), material, *surface, (view, sun, azimuth));
            eprintln!("{material}, view {view}°, sun {sun}° at {azimuth}°: radiance {want}, worst relative error {error:.1e}");
            worst = worst.max(error);
        }
    }
    // f32 arithmetic in another order, and pow/exp on the GPU: measured 1.3e-4 on lavapipe (at
    // the coat's highlight), 3e-7 elsewhere.
    assert!(worst < 1e-3, "worst relative error {worst}");
}

#[test]
fn clearcoat_and_sheen_under_a_uniform_sky_match_the_cpu_twin_and_their_albedos() {
    use refrakt::cpu::pbr::Surface;
    let dir = tempfile::tempdir().unwrap();
    let mut r = renderer();
    let sky = Vec3::new(0.8, 1.0, 1.2);
    let environment = format!("color = {{{}, {}, {}}}", sky.x, sky.y, sky.z);
    let mut worst = 0.0f32;
    for (material, surface) in &LAYERED {
        for view in [15.0, 60.0] {
            let v = polar(view, 0.0);
            let desc = frame_in(dir.path(), &layered_floor(v, material, &environment, ""));
            let want = Surface { v, ..*surface }.under_uniform_sky(sky);
            let error = worst_relative(&render(&mut r, &desc, "beauty"), want);
            eprintln!("{material} under a uniform sky, view {view}°: radiance {want}, worst relative error {error:.1e}");
            worst = worst.max(error);
        }
    }
    assert!(worst < 1e-3, "worst relative error {worst}");

    // The twin against closed forms: on a black base that reflects nothing, what a uniform sky
    // gives is the layer's own directional albedo — ∫ f cos θ dω, integrated here from the
    // BRDF itself (the sheen: its colour times E; the coat: its Fresnel-weighted GGX lobe).
    let black = Surface { base: Vec3::ZERO, specular: 0.0, ..LAYERED[0].1 };
    for (what, s) in [
        ("sheen", Surface { clearcoat: 0.0, sheen_color: Vec3::new(0.9, 0.6, 0.3), sheen_roughness: 0.5, ..black }),
        ("coat", Surface { clearcoat: 0.8, clearcoat_roughness: 0.4, ..black }),
    ] {
        for view in [10.0, 45.0, 75.0] {
            let s = Surface { v: polar(view, 0.0), ..s };
            let n = 512;
            let mut albedo = Vec3::ZERO;
            for i in 0..n {
                let cos_t = (i as f32 + 0.5) / n as f32;
                for j in 0..n {
                    let l = polar(cos_t.acos().to_degrees(), 360.0 * (j as f32 + 0.5) / n as f32);
                    albedo += s.brdf(l) * l.y;
                }
            }
            albedo *= 2.0 * PI / (n * n) as f32;
            let sky = s.under_uniform_sky(Vec3::ONE);
            eprintln!("{what} on black, view {view}°: ∫ f cos = {albedo}, uniform sky {sky}");
            // The table's bilinear steps and the coat's split sum (its Fresnel at n·v against
            // v·h inside the integral): within 3 %.
            assert!(((sky - albedo).abs() / albedo.max(Vec3::splat(1e-3))).max_element() < 0.03, "{what}, view {view}°: {sky} vs {albedo}");
        }
    }
}

/// KHR_materials_clearcoat's clearcoatNormalTexture (Lua `clearcoat_normal_texture`): a
/// constant map tilting the coat's normal 20° toward the plane's +u (+x) moves the coat's
/// highlight as the twin with that coat normal says, and leaves the base's normal alone.
#[test]
fn a_coat_normal_map_tilts_the_coat_alone() {
    use refrakt::cpu::pbr::Surface;
    let dir = tempfile::tempdir().unwrap();
    // Tangent space (x along +u, z the normal), 8 bits as PNG stores it; the twin takes the
    // texel as the shader decodes it.
    let tilt = 20f32.to_radians();
    let texel = [tilt.sin(), 0.0, tilt.cos()].map(|c| ((0.5 * c + 0.5) * 255.0).round() as u8);
    image::RgbaImage::from_pixel(2, 2, image::Rgba([texel[0], texel[1], texel[2], 255])).save(dir.path().join("tilt.png")).unwrap();
    let m = Vec3::from(texel.map(|c| c as f32 / 255.0 * 2.0 - 1.0));
    // The plane's tangent is +x (u grows along it); glTF's +Y of tangent space points toward
    // decreasing v, −z here. (128 decodes to 1/255, not 0: that 0.2° counts at the coat's
    // sharp highlight.)
    let coat_n = Vec3::new(m.x, m.z, -m.y).normalize();
    let material = "r.pbr{ color = {0.6, 0.25, 0.1}, metallic = 0, roughness = 0.6, clearcoat = 1, clearcoat_roughness = 0.15, clearcoat_normal_texture = \"tilt.png\" }";
    let surface = Surface { coat_n, ..LAYERED[0].1 };
    let mut r = renderer();
    let mut worst = 0.0f32;
    // The untilted mirror direction, the tilted one, and across.
    for (view, sun, azimuth) in [(20.0, 22.0, 180.0), (30.0, 10.0, 0.0), (55.0, 40.0, 90.0)] {
        let (want, error) = under_a_sun(&mut r, dir.path(), material, surface, (view, sun, azimuth));
        let (v, l) = (polar(view, 0.0), polar(sun, azimuth));
        let (tilted, untilted) = (Surface { v, ..surface }.brdf(l), Surface { v, ..LAYERED[0].1 }.brdf(l));
        eprintln!("tilted coat, view {view}°, sun {sun}° at {azimuth}°: radiance {want} (BRDF {tilted}, untilted {untilted}), worst relative error {error:.1e}");
        worst = worst.max(error);
        if view == 30.0 {
            // The view at 30° mirrored about the coat normal tilted 20° toward it is at 10° on
            // the same side: the tilted coat sends the sun to the viewer, an untilted one would not.
            assert!(tilted.x > 3.0 * untilted.x, "the tilt moves the highlight: {tilted} vs {untilted}");
        }
    }
    assert!(worst < 1e-3, "worst relative error {worst}");
}

/// A real file: Khronos' ClearCoatCarPaint (tests/data/khronos, CC0), a red metallic-flake base
/// (a normal map tiled ×3 by KHR_texture_transform) under a polished coat. It imports with its
/// coat and no warning about it, and renders: the coat adds a highlight and reflections that the
/// same frame without it lacks.
#[test]
fn khronos_clear_coat_car_paint_renders_with_its_coat() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/khronos/ClearCoatCarPaint.glb");
    let access = refrakt::lua::sandbox::FileAccess::new(path.parent().unwrap(), &[]).unwrap();
    let import = refrakt::gltf::import(&path, "ClearCoatCarPaint.glb", &access, &Default::default()).unwrap_or_else(|e| panic!("{e:#}"));
    assert!(!import.warnings.iter().any(|w| w.to_string().contains("clearcoat") || w.to_string().contains("not supported")), "{:?}", import.warnings);
    let scene = refrakt::render::GltfScene::load(&path, &[], &Default::default()).unwrap();
    let opts = refrakt::scene::eval::EvalOptions { size: Some((48, 27)), photons: Some(0), samples: Some(1), resolution: Some(32), ..Default::default() };
    let coated = refrakt::scene::eval::evaluate(&scene.scene, 0.0, &opts).unwrap();
    let d = &coated.receivers[0].diffuse;
    assert_eq!((d.clearcoat, d.clearcoat_roughness, d.metallic, d.normal_scale), (1.0, 0.0, 0.3, 0.2));
    assert!(d.normal_texture.is_some() && d.clearcoat_normal_texture.is_none());
    let mut bare = coated.clone();
    bare.receivers[0].diffuse.clearcoat = 0.0;
    let mut r = renderer();
    let (with, without) = (render(&mut r, &coated, "beauty"), render(&mut r, &bare, "beauty"));
    // Pixels of the ball: where the two frames differ at all.
    let ball: Vec<usize> = (0..with.len() / 4).filter(|&k| (0..3).any(|c| (with[4 * k + c] - without[4 * k + c]).abs() > 1e-6)).collect();
    let brightest = |img: &[f32]| ball.iter().map(|&k| img[4 * k] + img[4 * k + 1] + img[4 * k + 2]).fold(0.0f32, f32::max);
    let mean = |img: &[f32]| ball.iter().map(|&k| img[4 * k] + img[4 * k + 1] + img[4 * k + 2]).sum::<f32>() / ball.len() as f32;
    eprintln!(
        "ClearCoatCarPaint, 48×27: {} ball pixels; brightest {:.3} with the coat, {:.3} without; mean {:.4} vs {:.4}",
        ball.len(), brightest(&with), brightest(&without), mean(&with), mean(&without)
    );
    assert!(ball.len() > 100, "the ball should fill part of the frame");
    assert!(brightest(&with) > 1.5 * brightest(&without) && mean(&with) > mean(&without), "the coat reflects the studio");
}
