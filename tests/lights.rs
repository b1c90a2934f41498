//! Lights as artists light: the environment as a light (src/pipeline/env_light.rs,
//! shaders/shared/env_light.wgsl) — receivers lit by it with shadows, against closed forms, and
//! its photons' caustic against a sun light's — and rect lights' photons.

mod common;

use std::f32::consts::PI;
use std::sync::Arc;

use common::{frame_from_lua, shared_renderer};
use glam::{Quat, Vec3};
use refrakt::output::{Image, Layer};
use refrakt::pipeline::env_light::{EnvLightTable, from_table_frame};
use refrakt::scene::{EnvImage, Environment, EnvironmentSource};

fn rgb(layer: &Layer, i: usize) -> Vec3 {
    let c = layer.channels.len();
    Vec3::new(layer.data[c * i], layer.data[c * i + 1], layer.data[c * i + 2])
}

fn layer<'a>(image: &'a Image, name: &str) -> &'a Layer {
    image.layer(name).unwrap_or_else(|| panic!("a {name} layer"))
}

/// The environment of an image (its table is built from it as it is: ≤ 1024 wide), turned by
/// `rotation` about +Y after `tilt`.
fn image_environment(image: EnvImage, intensity: f32, rotation: f32, tilt: Quat) -> Environment {
    Environment { source: EnvironmentSource::Image { path: "test.exr".into(), image: Arc::new(image) }, intensity, rotation, tilt, visible: true }
}

/// A tilt of the environment's horizon (Blender's Mapping turned about X and Y) the tests
/// below turn their images by, so that photons and shadow rays must follow a general turn.
fn tilt() -> Quat {
    Quat::from_rotation_x(0.2) * Quat::from_rotation_z(-0.15)
}

/// The world point an orthographic camera looking straight down (up = −Z) at height 5 sees at
/// pixel (x, y) of a `size`² image `extent` metres wide: (x, z) on the floor.
fn floor_point(x: usize, y: usize, size: usize, extent: f32) -> (f32, f32) {
    let px = extent / size as f32;
    ((x as f32 + 0.5) * px - 0.5 * extent, (y as f32 + 0.5) * px - 0.5 * extent)
}

const TOP_VIEW: &str = "camera = r.camera{ position = {0, 5, 0}, target = {0, 0, 0}, up = {0, 0, -1}, orthographic = 3, size = {96, 96} }";

/// A black ball (r = 0.3 m) resting on a white floor (albedo 0.8) under a uniform sky of
/// radiance 1: the floor sees the sky but for the ball, whose cosine-weighted share of its
/// hemisphere is (r/d)² cos θ = r³/d³ (d: distance to the ball's centre, which stands r above
/// the floor), so L = 0.8 (1 − r³/d³). Ring by ring from the contact outwards, within 3 %.
#[test]
fn a_ball_on_a_floor_under_a_uniform_sky_shades_it_by_its_form_factor() {
    let desc = frame_from_lua(&format!(
        "local r = require('refrakt')
         local scene = r.scene{{ {TOP_VIEW}, environment = r.environment{{ color = {{1, 1, 1}} }}, samples = 4 }}
         scene:add(r.node{{ name = 'floor', shape = r.plane{{ size = {{8, 8}} }}, material = r.diffuse{{ color = {{0.8, 0.8, 0.8}} }} }})
         scene:add(r.node{{ name = 'ball', translation = {{0, 0.3, 0}}, shape = r.sphere{{ radius = 0.3 }}, material = r.diffuse{{ color = {{0, 0, 0}} }} }})
         return scene"
    ));
    let image = shared_renderer().frame(&desc).unwrap();
    let beauty = layer(&image, "beauty");
    let r = 0.3f32;
    let rings = [0.32f32, 0.36, 0.42, 0.5, 0.65, 0.85, 1.1, 1.4];
    let mut sums = vec![(0.0f64, 0.0f64, 0u32); rings.len() - 1];
    for y in 0..96 {
        for x in 0..96 {
            let (px, pz) = floor_point(x, y, 96, 3.0);
            let rho = (px * px + pz * pz).sqrt();
            let Some(ring) = rings.windows(2).position(|w| rho >= w[0] && rho < w[1]) else { continue };
            let d = (rho * rho + r * r).sqrt();
            let expected = 0.8 * (1.0 - (r / d).powi(3));
            let got = rgb(beauty, y * 96 + x);
            sums[ring].0 += got.x as f64;
            sums[ring].1 += expected as f64;
            sums[ring].2 += 1;
        }
    }
    for (i, (got, expected, n)) in sums.iter().enumerate() {
        let (got, expected) = (got / *n as f64, expected / *n as f64);
        println!("ring {:.2}–{:.2} m ({n} px): {got:.4} vs {expected:.4} ({:+.2} %)", rings[i], rings[i + 1], 100.0 * (got / expected - 1.0));
        assert!((got / expected - 1.0).abs() < 0.03, "ring {i}: {got} vs {expected}");
    }
    // The occluded inner ring is darker than the outer one by the closed form's margin.
    assert!(sums[0].0 / sums[0].2 as f64 + 0.15 < sums[6].0 / sums[6].2 as f64);
}

/// A sky of smooth gradients and a bright patch (a texel grid the table keeps as it is).
fn patchy_sky() -> EnvImage {
    let texels = (0..48u32)
        .flat_map(|y| (0..96u32).map(move |x| (x, y)))
        .map(|(x, y)| {
            let patch = if (30..38).contains(&x) && (8..13).contains(&y) { 12.0 } else { 0.0 };
            [0.2 + 0.6 * (y as f32 / 47.0) + patch, 0.4 + 0.3 * (x as f32 / 95.0), 0.9 - 0.5 * (y as f32 / 47.0) + 0.5 * patch, 1.0]
        })
        .collect();
    EnvImage { width: 96, height: 48, texels }
}

/// An unoccluded plane under an environment image gets E = ∫ L max(n·ω, 0) dω of the image, so
/// its radiance is albedo/π × E: a floor (any turn of the environment gives the same E) and a
/// wall facing +X (whose E depends on the turn, so the shadow rays' directions are checked
/// against the image), within 1 %.
#[test]
fn an_open_plane_under_an_image_gets_its_irradiance_exactly() {
    let (intensity, rotation) = (1.3f32, 0.7f32);
    let table = EnvLightTable::of_image(&patchy_sky());
    for (normal, placement) in [(Vec3::Y, "rotation = {0, 0, 0}"), (Vec3::X, "rotation = {0, 0, -90}")] {
        let mut desc = frame_from_lua(&format!(
            "local r = require('refrakt')
             local scene = r.scene{{ camera = r.camera{{ position = {{4 * {nx}, 4 * {ny}, 0}}, target = {{0, 0, 0}}, up = {{0, 0, -1}}, orthographic = 2, size = {{32, 32}} }}, samples = 4 }}
             scene:add(r.node{{ name = 'plane', {placement}, shape = r.plane{{ size = {{6, 6}} }}, material = r.diffuse{{ color = {{0.5, 0.5, 0.5}} }} }})
             return scene",
            nx = normal.x,
            ny = normal.y
        ));
        desc.environment = image_environment(patchy_sky(), intensity, rotation, tilt());
        let image = shared_renderer().frame(&desc).unwrap();
        let direct = layer(&image, "direct");
        let n = direct.data.len() / direct.channels.len();
        let mean = (0..n).map(|i| rgb(direct, i)).sum::<Vec3>() / n as f32;
        let e = table.irradiance(refrakt::pipeline::env_light::to_table_frame(desc.environment.turn(), normal), 16) * intensity;
        let expected = e * 0.5 / PI;
        println!("plane facing {normal}: {mean} vs {expected}");
        for c in 0..3 {
            assert!((mean[c] / expected[c] - 1.0).abs() < 0.01, "facing {normal}, channel {c}: {} vs {}", mean[c], expected[c]);
        }
    }
}

/// A glass ball (r = 0.3 m, n = 1.5) 0.5 m over a white floor in a black environment, seen from
/// straight above (orthographic, 2.4 m across, 64²), lit by the Lua statement `light`.
fn ball_over_floor(photons: u32, samples: u32, light: &str) -> refrakt::frame::FrameDesc {
    frame_from_lua(&format!(
        "local r = require('refrakt')
         local scene = r.scene{{ camera = r.camera{{ position = {{0, 5, 0}}, target = {{0, 0, 0}}, up = {{0, 0, -1}}, orthographic = 2.4, size = {{64, 64}} }},
                                environment = r.environment{{ color = {{0, 0, 0}} }}, photons = {photons}, samples = {samples},
                                volume = {{ resolution = 48 }} }}
         scene:add(r.node{{ name = 'floor', shape = r.plane{{ size = {{6, 6}} }}, material = r.diffuse{{ color = {{0.8, 0.8, 0.8}} }} }})
         scene:add(r.node{{ name = 'ball', translation = {{0, 0.5, 0}}, shape = r.sphere{{ radius = 0.3 }}, material = r.glass{{ ior = 1.5 }} }})
         {light}
         return scene"
    ))
}

/// An environment image holding only a sun (a disc 3° across) lights a glass ball on a floor
/// as a sun light of the same irradiance and angular size does: its photons make the same
/// caustic (the flux that passed glass to the floor, and the caustic seen, within 3 %; relative L1
/// of the two caustic images ≤ 0.15) and its shadow rays
/// the same direct light and shadow (mean within 2 %). The environment is turned, so photons
/// and shadow rays must both follow the turn to agree with the light placed where it shows.
#[test]
fn an_hdri_sun_throws_the_caustic_and_shadow_of_a_sun_light() {
    let (rotation, half_angle) = (0.9f32, 1.5f32.to_radians());
    // The sun in the image's own frame, 60° up.
    let (elevation, azimuth) = (60f32.to_radians(), 0.6f32);
    let sun_table = Vec3::new(elevation.cos() * azimuth.cos(), elevation.sin(), elevation.cos() * azimuth.sin());
    let radiance = 40.0;
    let sky = EnvImage::from_fn(1024, 512, |d| if d.dot(sun_table) >= half_angle.cos() { Vec3::splat(radiance) } else { Vec3::ZERO });
    let table = EnvLightTable::of_image(&sky);
    let environment = image_environment(sky, 1.0, rotation, tilt());
    let toward_sun = from_table_frame(environment.turn(), sun_table);
    // The irradiance the image's sun gives a plane facing it: the sun light's (lux = W/m² · 683).
    let e_sun = table.irradiance(sun_table, 2).x;
    let scene = |light: &str| ball_over_floor(800_000, 2, light);
    let sun = scene(&format!(
        "scene:add(r.node{{ name = 'sun', light = r.sun{{ direction = {{{}, {}, {}}}, intensity = {}, angular_diameter = 3 }} }})",
        -toward_sun.x,
        -toward_sun.y,
        -toward_sun.z,
        e_sun * 683.0
    ));
    let mut hdri = scene("");
    hdri.environment = environment;
    let mut r = shared_renderer();
    let with_sun = r.frame(&sun).unwrap();
    let flux_sun = r.photon_stats().expect("photons were traced").caustic[0];
    let with_hdri = r.frame(&hdri).unwrap();
    let flux_hdri = r.photon_stats().expect("photons were traced").caustic[0];
    drop(r);
    let sum = |image: &Image, name: &str| -> f64 {
        let l = layer(image, name);
        (0..l.data.len() / l.channels.len()).map(|i| rgb(l, i).x as f64).sum()
    };
    let (caustic_sun, caustic_hdri) = (sum(&with_sun, "caustic"), sum(&with_hdri, "caustic"));
    let (direct_sun, direct_hdri) = (sum(&with_sun, "direct"), sum(&with_hdri, "direct"));
    let (a, b) = (layer(&with_sun, "caustic"), layer(&with_hdri, "caustic"));
    let n = a.data.len() / a.channels.len();
    let l1: f64 = (0..n).map(|i| (rgb(a, i).x - rgb(b, i).x).abs() as f64).sum::<f64>() / caustic_sun;
    println!("caustic flux: HDRI {flux_hdri:.5} W vs sun {flux_sun:.5} W ({:+.2} %)", 100.0 * (flux_hdri / flux_sun - 1.0));
    println!("caustic seen: HDRI {caustic_hdri:.3} vs sun {caustic_sun:.3} ({:+.2} %), relative L1 {l1:.3}", 100.0 * (caustic_hdri / caustic_sun - 1.0));
    println!("direct light: HDRI {direct_hdri:.3} vs sun {direct_sun:.3} ({:+.2} %)", 100.0 * (direct_hdri / direct_sun - 1.0));
    assert!(caustic_sun > 0.0, "the sun light makes a caustic");
    assert!((flux_hdri / flux_sun - 1.0).abs() < 0.03);
    assert!((caustic_hdri / caustic_sun - 1.0).abs() < 0.03);
    assert!(l1 < 0.15, "the two caustics differ in shape: relative L1 {l1}");
    assert!((direct_hdri / direct_sun - 1.0).abs() < 0.02);
}

/// A dark environment is no light: no photons leave it and receivers are shaded as by the lights
/// alone, bit for bit whatever its image.
#[test]
fn a_dark_environment_changes_nothing() {
    let source = "local r = require('refrakt')
         local scene = r.scene{ camera = r.camera{ position = {0, 2, 3}, target = {0, 0, 0}, size = {24, 16} }, photons = 20000, samples = 1, volume = { resolution = 24 } }
         scene:add(r.node{ name = 'floor', shape = r.plane{ size = {4, 4} }, material = r.diffuse{ color = {0.8, 0.8, 0.8} } })
         scene:add(r.node{ name = 'ball', translation = {0, 0.5, 0}, shape = r.sphere{ radius = 0.3 }, material = r.glass{ ior = 1.5 } })
         scene:add(r.node{ name = 'sun', light = r.sun{ direction = {0.2, -1, 0.1}, intensity = 700 } })
         return scene";
    let mut black = frame_from_lua(source);
    black.environment = Environment { source: EnvironmentSource::Color(Vec3::ZERO), ..Environment::default() };
    let mut dark_image = black.clone();
    dark_image.environment = image_environment(EnvImage { width: 4, height: 2, texels: vec![[0.0, 0.0, 0.0, 1.0]; 8] }, 1.0, 0.0, Quat::IDENTITY);
    let mut r = shared_renderer();
    let a = r.frame(&black).unwrap();
    let b = r.frame(&dark_image).unwrap();
    for name in ["caustic", "direct"] {
        assert_eq!(layer(&a, name).data, layer(&b, name).data, "{name}");
    }
}

/// A small rect light (4 cm square, radiance L), a disk light (4 cm across) and a glowing square
/// (an emissive mesh, 4 cm a side, both sides glowing), 2.5 m above a glass ball send photons as
/// a point light of intensity L·A at their centre does, but for their cos θ falloff (0.9954 on
/// average over the ball): the caustic flux (the march's sum over the photons that passed glass
/// and reached the floor) within 1.5 % of 0.9954 × the point light's, and the caustic seen
/// (relative L1 of the caustic images, which differ also by the light's blur of the focus)
/// ≤ 0.15. (The glowing square's back faces away from the ball: none of its photons go there.)
/// So does a patterned glowing square twice as wide whose emission texture glows only in its
/// middle quarter, the same 4 cm square: its photons leave from the pattern alone.
#[test]
fn a_small_area_lights_caustic_is_a_point_lights() {
    let (radiance, side) = (2.0e6f32, 0.04f32);
    // Lights face along −Z: turned to face the floor; a plane is level already.
    let facing_down = "rotation = r.look_at({0.1, 3, 0.05}, {0.1, 0, 0.05}, {0, 0, -1}),";
    let scene = |lamp: &str| ball_over_floor(400_000, 1, &format!("scene:add(r.node{{ name = 'lamp', translation = {{0.1, 3, 0.05}}, {lamp} }})"));
    let mut r = shared_renderer();
    let with_point = r.frame(&scene(&format!("{facing_down} light = r.point{{ intensity = {} }}", radiance * side * side))).unwrap();
    let flux_point = r.photon_stats().expect("photons were traced").caustic[0];
    let glowing = format!(
        "shape = r.plane{{ size = {{{side}, {side}}} }}, material = r.pbr{{ color = {{0, 0, 0}}, emission = {{1, 1, 1}}, emission_strength = {} }}",
        radiance / 683.0
    );
    let patterned = glowing.replace(&format!("size = {{{side}, {side}}}"), &format!("size = {{{}, {}}}", 2.0 * side, 2.0 * side));
    let lamps = [
        ("rect", side * side, format!("{facing_down} light = r.rect{{ size = {{{side}, {side}}}, intensity = {radiance} }}")),
        ("disk", PI / 4.0 * side * side, format!("{facing_down} light = r.disk{{ size = {{{side}, {side}}}, intensity = {radiance} }}")),
        ("glowing mesh", side * side, glowing),
        ("patterned glowing mesh", side * side, patterned),
    ];
    for (kind, area, lamp) in lamps {
        let mut desc = scene(&lamp);
        if kind.starts_with("patterned") {
            // White in the middle 33 of 66 texels each way (u, v from 17/66 to 50/66): a 4 cm square.
            let middle = |i: usize| (17..50).contains(&i);
            let texels = (0..66 * 66).map(|i| if middle(i % 66) && middle(i / 66) { [1.0; 4] } else { [0.0, 0.0, 0.0, 1.0] }).collect();
            let texture = refrakt::scene::Texture2d { width: 66, height: 66, texels, wrap: Default::default() };
            desc.receivers.iter_mut().find(|r| r.name == "lamp").expect("the lamp").diffuse.emission_texture = Some(Arc::new(texture));
        }
        let with_area = r.frame(&desc).unwrap();
        let flux_area = r.photon_stats().expect("photons were traced").caustic[0] * (side * side / area) as f64;
        let (a, b) = (layer(&with_point, "caustic"), layer(&with_area, "caustic"));
        // The glowing square is seen, 2 m from the camera, right where the camera (looking
        // through the ball along the light's way back) sees the focus: those pixels are left out.
        let depth = layer(&with_area, "depth");
        let n = a.data.len() / a.channels.len();
        let open: Vec<usize> = (0..n).filter(|&i| depth.data[i * depth.channels.len()] > 2.5).collect();
        let seen = open.iter().map(|&i| rgb(a, i).x as f64).sum::<f64>();
        let l1 = open.iter().map(|&i| (rgb(a, i).x - rgb(b, i).x * side * side / area).abs() as f64).sum::<f64>() / seen;
        let ratio = flux_area / flux_point / 0.9954;
        println!("caustic flux: {kind} {flux_area:.5} W (per L·A of the rect) vs point {flux_point:.5} W × 0.9954 ({:+.2} %); images' relative L1 {l1:.3}", 100.0 * (ratio - 1.0));
        assert!(flux_point > 0.0 && seen > 0.0);
        assert!((ratio - 1.0).abs() < 0.015, "{kind}: caustic flux ratio {ratio}");
        assert!(l1 < 0.15, "{kind}: relative L1 {l1}");
    }
}

/// Irradiance at x (normal n) from the triangles of a convex glowing mesh of radiance L, exactly:
/// Lambert's formula for a uniform polygon, E = L/2 Σ_edges Θ_i (n · γ_i) (Θ_i the angle an
/// edge subtends at x, γ_i the unit normal of the plane through x and that edge), over the
/// triangles whose outer side faces x (on a convex mesh, those x sees).
fn glowing_polyhedron_irradiance(positions: &[Vec3], triangles: &[[u32; 3]], centre: Vec3, x: Vec3, n: Vec3, radiance: f32) -> f64 {
    let mut e = 0.0f64;
    for t in triangles {
        let v = t.map(|i| positions[i as usize]);
        let outward = (v[1] - v[0]).cross(v[2] - v[0]);
        let outward = if outward.dot((v[0] + v[1] + v[2]) / 3.0 - centre) < 0.0 { -outward } else { outward };
        if outward.dot(x - v[0]) <= 0.0 {
            continue;
        }
        let r = v.map(|p| (p - x).as_dvec3());
        let sum: f64 = (0..3)
            .map(|i| {
                let (a, b) = (r[i], r[(i + 1) % 3]);
                a.normalize().dot(b.normalize()).clamp(-1.0, 1.0).acos() * n.as_dvec3().dot(a.cross(b).normalize())
            })
            .sum();
        e += 0.5 * radiance as f64 * sum.abs();
    }
    e
}

/// A scene of a white floor and, 1 m over it, `glowing` (a node's shape and material), seen
/// from above over 8 × 8 pixels 2 cm across at 256 samples, without photons or bounces.
fn glowing_over_floor(glowing: &str) -> refrakt::frame::FrameDesc {
    frame_from_lua(&format!(
        "local r = require('refrakt')
         local scene = r.scene{{ camera = r.camera{{ position = {{0, 0.5, 0}}, target = {{0, 0, 0}}, up = {{0, 0, -1}}, orthographic = 0.02, size = {{8, 8}} }},
                                environment = r.environment{{ color = {{0, 0, 0}} }}, photons = 0, bounces = 0, samples = 256 }}
         scene:add(r.node{{ name = 'floor', shape = r.plane{{ size = {{6, 6}} }}, material = r.diffuse{{ color = {{1, 1, 1}} }} }})
         scene:add(r.node{{ name = 'glowing', translation = {{0, 1, 0}}, {glowing} }})
         return scene"
    ))
}

/// The floor's irradiance under `glowing_over_floor`'s mesh of radiance 2 (the mean over the
/// pixels), and Lambert's polygon formula's for its facets at the point below its centre.
fn irradiance_under(desc: &refrakt::frame::FrameDesc, mesh: &refrakt::scene::mesh::MeshData, world: glam::Mat4) -> (f64, f64) {
    let corners: Vec<Vec3> = mesh.positions.iter().map(|p| world.transform_point3(*p)).collect();
    let expected = glowing_polyhedron_irradiance(&corners, &mesh.triangles, Vec3::Y, Vec3::ZERO, Vec3::Y, 2.0);
    let image = shared_renderer().frame(desc).unwrap();
    let e = (0..64).map(|i| rgb(layer(&image, "direct"), i).x as f64).sum::<f64>() / 64.0 * PI as f64;
    (e, expected)
}

/// A glowing ball (an emissive mesh sphere, r = 0.2 m, radiance 2 W/m²/sr) 1 m over a white
/// floor lights the point below it as Lambert's polygon formula says its facets do
/// (`glowing_polyhedron_irradiance`; ≈ π L r²/d² for a true sphere), within 1 %, from shadow
/// rays to points spread over its whole surface (those on its far side facing away: a closed mesh
/// glows on its outer side).
#[test]
fn a_glowing_ball_lights_the_floor_as_its_facets_do() {
    let desc = glowing_over_floor("shape = r.sphere{ radius = 0.2 }, material = r.pbr{ color = {0, 0, 0}, emission = {1, 1, 1}, emission_strength = 2 }");
    let ball = desc.receivers.iter().find(|r| r.name == "glowing").expect("the ball is a receiver");
    let (e, expected) = irradiance_under(&desc, &ball.mesh, ball.world);
    println!(
        "glowing ball: E = {e:.5} vs its facets' {expected:.5} ({:+.2} %; a true sphere's π L r²/d² = {:.5})",
        100.0 * (e / expected - 1.0),
        PI * 2.0 * 0.04
    );
    assert!((e / expected - 1.0).abs() < 0.01, "{e} vs {expected}");
}

/// A glowing square whose emission texture is a pattern lights the floor by the pattern, not by
/// its mean: a 1 m square 1 m over a white floor, radiance 2 × a texture white on its left half
/// and black on its right (66 × 5 texels: sides not powers of two, which lavapipe would compile
/// the view for anew), seen at the point below the middle of its white half and below the middle
/// of its black half. Each gives what Lambert's polygon formula gives for the white half alone at
/// radiance 2, within 2 % (bilinear filtering blurs one texel's width at the edge); the mean
/// (radiance 1 over the whole square) would give 0.84× and 1.23× of that.
#[test]
fn a_glowing_squares_pattern_lights_the_floor_where_it_glows() {
    for offset in [0.25f32, -0.25] {
        let script = format!(
            "local r = require('refrakt')
             local scene = r.scene{{ camera = r.camera{{ position = {{0, 0.5, 0}}, target = {{0, 0, 0}}, up = {{0, 0, -1}}, orthographic = 0.02, size = {{8, 8}} }},
                                    environment = r.environment{{ color = {{0, 0, 0}} }}, photons = 0, bounces = 0, samples = 256 }}
             scene:add(r.node{{ name = 'floor', shape = r.plane{{ size = {{6, 6}} }}, material = r.diffuse{{ color = {{1, 1, 1}} }} }})
             scene:add(r.node{{ name = 'sign', translation = {{{offset}, 1, 0}}, shape = r.plane{{ size = {{1, 1}} }},
                               material = r.pbr{{ color = {{0, 0, 0}}, emission = {{1, 1, 1}}, emission_strength = 2, emission_texture = 'sign.png' }} }})
             return scene"
        );
        let (dir, path) = common::write_script("scene.lua", &script);
        image::RgbImage::from_fn(66, 5, |x, _| if x < 33 { image::Rgb([255; 3]) } else { image::Rgb([0; 3]) }).save(dir.path().join("sign.png")).unwrap();
        let host = common::load(&path);
        host.update(0.0).unwrap();
        let desc = refrakt::scene::eval::evaluate(&host.scene().borrow(), 0.0, &Default::default()).unwrap();
        let image = shared_renderer().frame(&desc).unwrap();
        let e = (0..64).map(|i| rgb(layer(&image, "direct"), i).x as f64).sum::<f64>() / 64.0 * PI as f64;
        // The white half, x from offset − ½ to offset, wound to face the floor.
        let (x0, x1) = (offset - 0.5, offset);
        let half = [Vec3::new(x0, 1.0, -0.5), Vec3::new(x1, 1.0, -0.5), Vec3::new(x1, 1.0, 0.5), Vec3::new(x0, 1.0, 0.5)];
        let expected = glowing_polyhedron_irradiance(&half, &[[0, 1, 2], [0, 2, 3]], Vec3::new(0.0, 2.0, 0.0), Vec3::ZERO, Vec3::Y, 2.0);
        let square = [Vec3::new(offset - 0.5, 1.0, -0.5), Vec3::new(offset + 0.5, 1.0, -0.5), Vec3::new(offset + 0.5, 1.0, 0.5), Vec3::new(offset - 0.5, 1.0, 0.5)];
        let by_mean = glowing_polyhedron_irradiance(&square, &[[0, 1, 2], [0, 2, 3]], Vec3::new(0.0, 2.0, 0.0), Vec3::ZERO, Vec3::Y, 1.0);
        println!("patterned square at x = {offset}: E = {e:.5} vs its white half's {expected:.5} ({:+.2} %); by the mean it would be {by_mean:.5}", 100.0 * (e / expected - 1.0));
        assert!((e / expected - 1.0).abs() < 0.02, "{e} vs {expected}");
    }
}

/// Glass that glows lights the scene as a glowing mesh does: a glass icosphere (r = 0.2 m, n =
/// 1.5, emission 2 W/m²/sr) 1 m over a white floor gives the point below it what Lambert's
/// polygon formula says its facets' outer sides give (as the glowing ball above), within 1 %.
/// Its photons start outside it, in air, where its centroid is in the glass.
#[test]
fn glowing_glass_lights_the_floor_as_a_glowing_mesh_does() {
    let desc = glowing_over_floor("shape = r.icosphere{ radius = 0.2, subdivisions = 2 }, material = r.glass{ ior = 1.5, emission = {2, 2, 2} }");
    let shade = &desc.meshes[0];
    assert!(shade.sharp, "a closed glass mesh is a sharp surface");
    let mut glowing = refrakt::pipeline::mesh_lights::GlowingMeshes::default();
    glowing.update(&desc.receivers, &desc.meshes, usize::MAX).unwrap();
    let light = &glowing.built.lights[0];
    let media = |p| refrakt::pipeline::interfaces::media_at(&desc, p);
    assert_ne!(media(light.position), [0, 0], "the centroid is in the glass");
    assert_eq!(media(refrakt::pipeline::lights::photon_start(light, &desc.volume)), [0, 0], "its photons start in air");
    let (e, expected) = irradiance_under(&desc, &shade.mesh, shade.world);
    println!("glowing glass: E = {e:.5} vs its facets' {expected:.5} ({:+.2} %)", 100.0 * (e / expected - 1.0));
    assert!((e / expected - 1.0).abs() < 0.01, "{e} vs {expected}");
}

/// A disk light (r = 0.5 m, radiance 1 W/m²/sr = 683 nits) 1 m over a white floor, facing it:
/// on its axis the floor gets E = π L r²/(h² + r²) (the disk's form factor), within 1 %, from
/// shadow rays to points spread evenly over the disk.
#[test]
fn a_disk_light_lights_the_floor_on_its_axis_by_its_form_factor() {
    let desc = frame_from_lua(
        "local r = require('refrakt')
         local scene = r.scene{ camera = r.camera{ position = {0, 2, 0}, target = {0, 0, 0}, up = {0, 0, -1}, orthographic = 0.02, size = {4, 4} },
                                environment = r.environment{ color = {0, 0, 0} }, photons = 0, bounces = 0, samples = 64 }
         scene:add(r.node{ name = 'floor', shape = r.plane{ size = {6, 6} }, material = r.diffuse{ color = {1, 1, 1} } })
         scene:add(r.node{ name = 'panel', translation = {0, 1, 0}, rotation = {-90, 0, 0}, light = r.disk{ size = {1, 1}, intensity = 683 } })
         return scene",
    );
    let image = shared_renderer().frame(&desc).unwrap();
    let direct = layer(&image, "direct");
    let e = (0..16).map(|i| rgb(direct, i).x).sum::<f32>() / 16.0 * PI;
    let expected = PI * 0.25 / (1.0 + 0.25);
    println!("disk light on its axis: E = {e:.5} vs π L r²/(h² + r²) = {expected:.5} ({:+.2} %)", 100.0 * (e / expected - 1.0));
    assert!((e / expected - 1.0).abs() < 0.01, "{e} vs {expected}");
}

/// The integrating sphere: a point light at the centre of a closed diffuse sphere (r = 1 m) of
/// albedo a. Every bounce spreads the light evenly over the inside, so the irradiance there is
/// E = Φ/(A(1 − a)) — the direct Φ/A times 1/(1 − a) once the bounces are summed. Seen from the
/// centre: the indirect layer over the direct one is a/(1 − a) (±2 %, at a = 0.5 and 0.8, with
/// the bounces that needs), and the beauty is a/π · E.
#[test]
fn an_integrating_sphere_holds_its_light_over_the_bounces() {
    // (10⁶ bounce photons with no caustic ones once ended every bounce photon at its first
    // landing: march.wgsl took the caustic photons' flux unit for theirs.)
    for (albedo, bounce_photons) in [(0.5f32, 1_000_000), (0.8, 400_000)] {
        let desc = frame_from_lua(&format!(
            "local r = require('refrakt')
             local scene = r.scene{{ camera = r.camera{{ position = {{0, 0, 0}}, target = {{0.3, -0.2, -1}}, fov = 50, size = {{24, 24}} }},
                                    environment = r.environment{{ color = {{0, 0, 0}} }}, photons = 0, bounce_photons = {bounce_photons}, bounces = 64,
                                    samples = 1, volume = {{ resolution = 32 }} }}
             scene:add(r.node{{ name = 'sphere', shape = r.sphere{{ radius = 1 }}, material = r.diffuse{{ color = {{{albedo}, {albedo}, {albedo}}} }} }})
             scene:add(r.node{{ name = 'bulb', light = r.point{{ intensity = 683 }} }})
             return scene"
        ));
        let image = shared_renderer().frame(&desc).unwrap();
        let mean_of = |name: &str| {
            let l = layer(&image, name);
            let n = l.data.len() / l.channels.len();
            (0..n).map(|i| rgb(l, i).x as f64).sum::<f64>() / n as f64
        };
        let (direct, indirect, beauty) = (mean_of("direct"), mean_of("indirect"), mean_of("beauty"));
        let expected_ratio = (albedo / (1.0 - albedo)) as f64;
        // 683 cd is 1 W/sr: Φ = 4π W over A = 4π m², so E = 1/(1 − a) W/m².
        let expected_beauty = (albedo / PI / (1.0 - albedo)) as f64;
        println!(
            "a = {albedo}: indirect / direct {:.4} vs {expected_ratio:.4} ({:+.2} %); beauty {beauty:.5} vs {expected_beauty:.5} ({:+.2} %)",
            indirect / direct,
            100.0 * (indirect / direct / expected_ratio - 1.0),
            100.0 * (beauty / expected_beauty - 1.0)
        );
        assert!((indirect / direct / expected_ratio - 1.0).abs() < 0.02, "a = {albedo}: indirect/direct {}", indirect / direct);
        assert!((beauty / expected_beauty - 1.0).abs() < 0.02, "a = {albedo}: beauty {beauty}");
    }
}

/// A glowing ball (an emissive mesh sphere, r = 0.1 m, radiance L) at the centre of the
/// integrating sphere (r = 1 m, albedo a = 0.5) sends its bounce photons from its outer side (a
/// closed mesh glows on that side alone), so the wall gets Φ = π L A_ball of first light,
/// as from a point light of intensity Φ/4π at its centre (a Lambertian sphere shines evenly every
/// way). Every bounce after spreads evenly, less the share f = A_ball/A the black ball takes back:
/// the ball's indirect light over the point's is a(1 − f)/(1 − a(1 − f)) over a/(1 − a), within
/// 2 % (the same estimator on both sides of the ratio, so what its charts do on a curved wall
/// cancels).
#[test]
fn a_glowing_ball_fills_an_integrating_sphere_as_a_point_light_of_its_power() {
    let (albedo, radiance) = (0.5f64, 30.0f32);
    let scene = |source: &str| {
        frame_from_lua(&format!(
            "local r = require('refrakt')
             local scene = r.scene{{ camera = r.camera{{ position = {{0, 0.5, 0}}, target = {{0.3, 0.9, -1}}, fov = 50, size = {{24, 24}} }},
                                    environment = r.environment{{ color = {{0, 0, 0}} }}, photons = 0, bounce_photons = 400000, bounces = 64,
                                    samples = 1, volume = {{ resolution = 32 }} }}
             scene:add(r.node{{ name = 'sphere', shape = r.sphere{{ radius = 1 }}, material = r.diffuse{{ color = {{{albedo}, {albedo}, {albedo}}} }} }})
             scene:add(r.node{{ name = 'source', {source} }})
             return scene"
        ))
    };
    let ball = scene(&format!("shape = r.sphere{{ radius = 0.1 }}, material = r.pbr{{ color = {{0, 0, 0}}, emission = {{1, 1, 1}}, emission_strength = {radiance} }}"));
    let glowing = refrakt::pipeline::mesh_lights::mesh_lights(&ball.receivers);
    let refrakt::frame::LightShape::Mesh { area: ball_area, .. } = glowing.lights[0].shape else { panic!("the ball is a glowing mesh") };
    let flux = std::f64::consts::PI * radiance as f64 * ball_area as f64;
    let point = scene(&format!("light = r.point{{ intensity = {} }}", flux / (4.0 * std::f64::consts::PI) * 683.0));
    let mut r = shared_renderer();
    let indirect = |image: &Image| {
        let l = layer(image, "indirect");
        let n = l.data.len() / l.channels.len();
        (0..n).map(|i| rgb(l, i).x as f64).sum::<f64>() / n as f64
    };
    let from_ball = indirect(&r.frame(&ball).unwrap());
    let from_point = indirect(&r.frame(&point).unwrap());
    let kept = albedo * (1.0 - ball_area as f64 / (4.0 * std::f64::consts::PI));
    let expected = kept / (1.0 - kept) / (albedo / (1.0 - albedo));
    let ratio = from_ball / from_point;
    println!("glowing ball in an integrating sphere: indirect {from_ball:.5}, from a point light of its power {from_point:.5}: ratio {ratio:.4} vs {expected:.4} ({:+.2} %)", 100.0 * (ratio / expected - 1.0));
    assert!((ratio / expected - 1.0).abs() < 0.02, "{ratio} vs {expected}");
}

/// The fraction of a disc of radius ρ beyond a line at signed distance c from its centre.
fn uncovered_disc(c: f64, rho: f64) -> f64 {
    let c = c.clamp(-rho, rho);
    (rho * rho * (c / rho).acos() - c * (rho * rho - c * c).sqrt()) / (std::f64::consts::PI * rho * rho)
}

/// The floor's direct light across a shadow's edge: a white floor, an opaque sheet over x < 0
/// at 1 m, `light` above, seen straight down through an orthographic camera 0.3 m wide (80
/// columns, `rows` along the edge). In `bins` bins of columns across s ∈ [−0.15, 0.15] m, the
/// mean E/E₀ (E = π × radiance) against `expected(s)`; returns the worst difference.
fn penumbra_departure(light: &str, rows: usize, samples: u32, bins: usize, e0: f64, expected: impl Fn(f64) -> f64) -> f64 {
    let width = 80usize;
    let desc = frame_from_lua(&format!(
        "local r = require('refrakt')
         local scene = r.scene{{ camera = r.camera{{ position = {{0, 0.5, 0}}, target = {{0, 0, 0}}, up = {{0, 0, -1}}, orthographic = {}, size = {{{width}, {rows}}} }},
                                environment = r.environment{{ color = {{0, 0, 0}} }}, photons = 0, bounces = 0, samples = {samples} }}
         scene:add(r.node{{ name = 'floor', shape = r.plane{{ size = {{6, 6}} }}, material = r.diffuse{{ color = {{1, 1, 1}} }} }})
         scene:add(r.node{{ name = 'sheet', translation = {{-2, 1, 0}}, shape = r.plane{{ size = {{4, 4}} }}, material = r.diffuse{{ color = {{0, 0, 0}} }} }})
         scene:add(r.node{{ name = 'light', {light} }})
         return scene",
        0.3 * rows as f64 / width as f64
    ));
    let image = shared_renderer().frame(&desc).unwrap();
    let direct = layer(&image, "direct");
    let per_bin = width / bins;
    let mut worst = 0.0f64;
    for bin in 0..bins {
        let columns = per_bin * bin..per_bin * (bin + 1);
        let (mut measured, mut want) = (0.0, 0.0);
        for x in columns.clone() {
            // Image x along world +X (the camera's right, up = −Z).
            let s = (x as f64 + 0.5) / width as f64 * 0.3 - 0.15;
            for y in 0..rows {
                measured += rgb(direct, y * width + x).x as f64 * std::f64::consts::PI / e0;
            }
            want += rows as f64 * expected(s);
        }
        let n = (columns.len() * rows) as f64;
        let (m, e) = (measured / n, want / n);
        println!("{light}: s from {:+.3} m: E/E0 {m:.4} vs {e:.4}", columns.start as f64 / width as f64 * 0.3 - 0.15);
        worst = worst.max((m - e).abs());
    }
    worst
}

/// A sun's size softens its shadow, and one sample per pixel already draws the penumbra without
/// steps: the sun's directions are rotated per pixel, so along the shadow's straight edge the
/// pixels' binary answers average to the part of the sun's disc (radius tan α) the edge leaves
/// uncovered. A sun of angular diameter 10° straight above the sheet; averaged along the edge
/// (64 rows) in 5 bins, E/E₀ within 0.05 of the fraction (the binomial noise is ~0.016); the
/// same directions in every pixel gave a step at one offset, 0.11 off.
#[test]
fn a_suns_penumbra_is_the_uncovered_part_of_its_disc_without_steps() {
    let rho = 5f64.to_radians().tan();
    let sun = "light = r.sun{ direction = {0, -1, 0}, intensity = 683, angular_diameter = 10 }";
    let worst = penumbra_departure(sun, 64, 1, 5, 1.0, |s| uncovered_disc(-s, rho));
    assert!(worst < 0.05, "the sun's penumbra departs from its uncovered disc by {worst}");
}

/// A bulb's radius softens its shadow. A point light of radius R = 0.1 m, 2 m over the sheet's
/// edge: a floor point at x = s sees the part of the bulb's disc (radius ρ = R·H/√(H² − R²) as
/// seen from the floor) beyond the line the edge casts on it, at c = −s (the sheet halfway up),
/// a fraction f = (ρ² acos(c/ρ) − c√(ρ² − c²))/(πρ²) of its light E₀ = I/H² (a Lambertian sphere
/// looks like an evenly bright disc). Across the penumbra (10 bins), E/E₀ within 0.03 of f cos³θ;
/// a point of light would cast a step.
#[test]
fn a_bulbs_radius_softens_its_shadow_as_its_disc_is_covered() {
    let (radius, height, intensity) = (0.1f64, 2.0f64, 683.0f64);
    let rho = radius * height / (height * height - radius * radius).sqrt();
    let bulb = format!("translation = {{0, {height}, 0}}, light = r.point{{ intensity = {intensity}, radius = {radius} }}");
    let worst = penumbra_departure(&bulb, 4, 64, 10, intensity / 683.0 / (height * height), |s| {
        let cos = height / (height * height + s * s).sqrt();
        uncovered_disc(-s, rho) * cos * cos * cos
    });
    assert!(worst < 0.03, "the penumbra departs from the covered disc's by {worst}");
}

/// Lights the camera sees (`visible = true`, Blender's Ray Visibility ▸ Camera), as Cycles shows
/// them: a light is no surface, so what it adds goes on top of what lies behind it and it covers
/// nothing. Looking up at a panel of radiance 1 W/m²/sr (683 nits) facing down, over a black
/// sky, every pixel is 1 and transparent; before a glass block, every pixel is the block's plus
/// 1, with the block's alpha and depth. A bulb of radius R and intensity π R² W/sr is a disc of
/// radiance 1; a spot aimed away is not seen, nor a panel from behind, and a light left
/// invisible (the default) adds nothing.
#[test]
fn the_camera_sees_visible_lights_added_to_what_lies_behind() {
    let render = |eye: f32, light: &str, block: bool| {
        let block = if block { "scene:add(r.node{ name = 'block', translation = {0, 1.3, 0}, shape = r.box{ size = {1, 0.2, 1} }, material = r.glass{ ior = 1.5 } })" } else { "" };
        let desc = frame_from_lua(&format!(
            "local r = require('refrakt')
             local scene = r.scene{{ camera = r.camera{{ position = {{0, {eye}, 0}}, target = {{0, 1, 0}}, up = {{0, 0, -1}}, orthographic = 0.2, size = {{4, 4}} }},
                                    environment = r.environment{{ color = {{0, 0, 0}} }}, photons = 2000, bounces = 0, samples = 4 }}
             scene:add(r.node{{ name = 'floor', shape = r.plane{{ size = {{6, 6}} }}, material = r.diffuse{{ color = {{1, 1, 1}} }} }})
             {block}
             scene:add(r.node{{ name = 'lamp', translation = {{0, 1, 0}}, rotation = {{-90, 0, 0}}, light = {light} }})
             return scene"
        ));
        shared_renderer().frame(&desc).unwrap()
    };
    let pixels = |image: &Image| (0..16).map(|i| rgb(layer(image, "beauty"), i)).collect::<Vec<_>>();
    let alpha = |image: &Image| (0..16).map(|i| layer(image, "beauty").data[4 * i + 3]).collect::<Vec<_>>();
    let panel = |visible: bool| format!("r.rect{{ size = {{1, 1}}, intensity = 683, visible = {visible} }}");
    let over_sky = render(0.2, &panel(true), false);
    assert!(pixels(&over_sky).iter().all(|p| (*p - Vec3::ONE).abs().max_element() < 1e-5), "a visible panel: {:?}", pixels(&over_sky));
    assert!(alpha(&over_sky).iter().all(|&a| a == 0.0), "a light covers nothing: {:?}", alpha(&over_sky));
    assert_eq!(pixels(&render(0.2, &panel(false), false)), vec![Vec3::ZERO; 16], "an invisible panel");
    let (seen, unseen) = (render(0.2, &panel(true), true), render(0.2, &panel(false), true));
    for (i, (p, q)) in pixels(&seen).iter().zip(pixels(&unseen)).enumerate() {
        assert!((*p - q - Vec3::ONE).abs().max_element() < 1e-4, "pixel {i}: the block's {q} plus the panel's 1, got {p}");
    }
    assert!(pixels(&unseen).iter().all(|p| p.max_element() > 0.0), "the block shows the lit floor");
    assert_eq!((alpha(&seen), &layer(&seen, "depth").data), (alpha(&unseen), &layer(&unseen, "depth").data), "the block's alpha and depth");
    // From above, the camera sees the panel's back and the lit floor beyond it.
    assert_eq!(pixels(&render(3.0, &panel(true), false)), pixels(&render(3.0, &panel(false), false)), "a panel seen from behind adds nothing");

    // A bulb of radiance 1 (I = π R² W/sr) filling the view, and a spot aimed up, away from it.
    let r = 0.3f32;
    let bulb = format!("r.point{{ radius = {r}, intensity = {}, visible = true }}", 683.0 * PI * r * r);
    for p in pixels(&render(0.2, &bulb, false)) {
        assert!((p - Vec3::ONE).abs().max_element() < 1e-4, "a visible bulb of radiance 1: {p}");
    }
    let spot = format!("r.spot{{ radius = {r}, intensity = 1000, angle = 30, target = {{0, 2, 0}}, visible = true }}");
    assert_eq!(pixels(&render(0.2, &spot, false)), vec![Vec3::ZERO; 16], "a spot aimed away is dark from behind");
}
